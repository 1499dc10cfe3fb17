//! Exact derivatives of small dense functions by forward-mode automatic differentiation.
//!
//! A [`LocalFn`] is written once, generic over [`Scalar`]. [`Diff`] evaluates it in `f64`, its Jacobian
//! with one `Dual64` pass per input, and the Hessian of a weighted sum of its outputs with one
//! `HyperDual64` pass per (lower-triangular) input pair. All buffers are allocated in [`Diff::new`]; no
//! call allocates afterwards. Dimensions are runtime values, so nothing is tied to a number of links.

use crate::math::{Dual64, HyperDual64, Scalar};

/// A smooth function `out = f(z)` of a small input vector, generic over the scalar type.
pub trait LocalFn {
    /// Per-scalar-type buffers the function needs (use `()` if none).
    type Scratch<T: Scalar>;
    /// Number of inputs.
    fn n_in(&self) -> usize;
    /// Number of outputs.
    fn n_out(&self) -> usize;
    /// Fresh buffers for scalar type `T`.
    fn scratch<T: Scalar>(&self) -> Self::Scratch<T>;
    /// Evaluate `out = f(z)`.
    fn eval<T: Scalar>(&self, ws: &mut Self::Scratch<T>, z: &[T], out: &mut [T]);
    /// True when `d^2 f / dz_i dz_j` is zero for every output and every `z` (structure known a priori:
    /// the pass is skipped and the entry left out of sparse Hessians). Default: never.
    fn hessian_entry_is_zero(&self, _i: usize, _j: usize) -> bool {
        false
    }
}

/// Reusable derivative evaluator for one [`LocalFn`].
pub struct Diff<F: LocalFn> {
    ws0: F::Scratch<f64>,
    ws1: F::Scratch<Dual64>,
    ws2: F::Scratch<HyperDual64>,
    z1: Vec<Dual64>,
    o1: Vec<Dual64>,
    z2: Vec<HyperDual64>,
    o2: Vec<HyperDual64>,
}

impl<F: LocalFn> Diff<F> {
    /// Allocate all buffers for `f`.
    pub fn new(f: &F) -> Self {
        let (n, m) = (f.n_in(), f.n_out());
        Diff {
            ws0: f.scratch(),
            ws1: f.scratch(),
            ws2: f.scratch(),
            z1: vec![Dual64::from(0.0); n],
            o1: vec![Dual64::from(0.0); m],
            z2: vec![HyperDual64::from(0.0); n],
            o2: vec![HyperDual64::from(0.0); m],
        }
    }

    /// `out = f(z)` in f64.
    pub fn value(&mut self, f: &F, z: &[f64], out: &mut [f64]) {
        f.eval(&mut self.ws0, z, out);
    }

    /// Value and Jacobian: `out = f(z)`, `jac` row-major `n_out x n_in`.
    pub fn jacobian(&mut self, f: &F, z: &[f64], out: &mut [f64], jac: &mut [f64]) {
        self.jacobian_cols(f, z, 0..f.n_in(), out, jac);
    }

    /// Value and the Jacobian columns in `cols` (other columns of `jac` are left untouched).
    pub fn jacobian_cols(
        &mut self,
        f: &F,
        z: &[f64],
        cols: std::ops::Range<usize>,
        out: &mut [f64],
        jac: &mut [f64],
    ) {
        let (n, m) = (f.n_in(), f.n_out());
        for (d, &v) in self.z1.iter_mut().zip(z) {
            *d = Dual64::new(v, 0.0);
        }
        for j in cols {
            self.z1[j].eps = 1.0;
            f.eval(&mut self.ws1, &self.z1, &mut self.o1);
            self.z1[j].eps = 0.0;
            for i in 0..m {
                jac[i * n + j] = self.o1[i].eps;
                out[i] = self.o1[i].re;
            }
        }
    }

    /// Hessian of `w . f(z)`, written as a full symmetric row-major `n_in x n_in` matrix into `hess`
    /// (entries declared zero by [`LocalFn::hessian_entry_is_zero`] are set to zero).
    pub fn hessian_weighted(&mut self, f: &F, z: &[f64], w: &[f64], hess: &mut [f64]) {
        let n = f.n_in();
        for (d, &v) in self.z2.iter_mut().zip(z) {
            *d = HyperDual64::new(v, 0.0, 0.0, 0.0);
        }
        for i in 0..n {
            for j in 0..=i {
                if f.hessian_entry_is_zero(i, j) {
                    hess[i * n + j] = 0.0;
                    hess[j * n + i] = 0.0;
                    continue;
                }
                self.z2[i].eps1 = 1.0;
                self.z2[j].eps2 = 1.0;
                f.eval(&mut self.ws2, &self.z2, &mut self.o2);
                self.z2[i].eps1 = 0.0;
                self.z2[j].eps2 = 0.0;
                let v: f64 = self.o2.iter().zip(w).map(|(o, wk)| o.eps1eps2 * wk).sum();
                hess[i * n + j] = v;
                hess[j * n + i] = v;
            }
        }
    }
}

/// Sugar: any `Fn` over `f64` cannot be differentiated; this adapter lets tests wrap a [`LocalFn`] as a
/// plain f64 closure for finite differences.
pub fn as_f64_fn<F: LocalFn>(f: &F) -> impl FnMut(&[f64], &mut [f64]) + '_ {
    let mut ws = f.scratch::<f64>();
    move |z, out| f.eval(&mut ws, z, out)
}
