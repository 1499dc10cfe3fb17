//! Placeholder of the NLP seam (replaced by the solver-backend work): the trait the transcription fills.

/// A sparse nonlinear program `min f(x) s.t. g_l <= g(x) <= g_u, x_l <= x <= x_u`.
pub trait SparseNlp {
    /// Number of variables.
    fn n_vars(&self) -> usize;
    /// Number of constraints.
    fn n_cons(&self) -> usize;
    /// Variable and constraint bounds (infinite allowed).
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]);
    /// Starting point.
    fn initial_guess(&self, x: &mut [f64]);
    /// Objective.
    fn objective(&mut self, x: &[f64]) -> f64;
    /// Objective gradient.
    fn gradient(&mut self, x: &[f64], grad: &mut [f64]);
    /// Constraint values.
    fn constraints(&mut self, x: &[f64], g: &mut [f64]);
    /// Jacobian sparsity (rows, cols), 0-based, no duplicates.
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>);
    /// Jacobian values in structure order.
    fn jacobian_values(&mut self, x: &[f64], vals: &mut [f64]);
    /// Lower-triangular Hessian sparsity (row >= col), no duplicates.
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>);
    /// Hessian of `obj_factor f + lambda . g` in structure order.
    fn hessian_values(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], vals: &mut [f64]);
}
