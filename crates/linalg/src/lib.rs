//! Small dense linear algebra for brachia: the kernels that the OCP solver's Riccati recursion, the
//! robot model's dynamics, the MPC and its box QP, the obstacle detour seeds and the shooting
//! transcription share.
//!
//! # Conventions
//! - Every matrix is a **row-major** slice: `a[i * n + j]` is row i, column j of a matrix with n
//!   columns (a row stride other than n is stated where a function takes one).
//! - Nothing here allocates; every function works in place on the caller's buffers, so the
//!   1 kHz control loop and the solver's iterations can call them freely.
//! - Sizes are run-time values. Widths that occur in brachia's stages (small robots) are dispatched
//!   to kernels with a constant width ([`dispatch_width!`]) that do the same arithmetic in the same
//!   order as the any-width loops, so a result never depends on which path ran.
//! - The order of summation of every product is stated: each entry `c_ij` is accumulated term by
//!   term in the order of the inner index unless the function says otherwise ([`dot_lanes`]).
//!
//! # Contents
//! - [`cholesky`]: `A = L L^T` of a symmetric positive definite matrix in place, with a
//!   [`NotPositiveDefinite`] status naming the failing column; [`cholesky_solve`] for any number of
//!   right-hand sides, [`cholesky_solve_vec`] for one; [`cholesky_solve_in_place`] for both at
//!   once. Generic over [`Scalar`]: `f64` and the dual numbers of `num-dual` (exact derivatives of
//!   a solve). [`Scaling`] says how a pivot is applied: a division per entry or a multiplication
//!   by its reciprocal.
//! - Products: [`gemm_nn`], [`gemm_nn_acc`], [`gemm_tn_acc`], [`gemm_nt`], [`gemv_n_acc`],
//!   [`gemv_t_acc`], [`dot_acc`], [`add_lincomb`], [`add_lincomb2`].
//! - [`dot_lanes`], [`dot_lanes_x4`]: dot products in four accumulators (long rows).
//! - [`sym_eigen`], [`eigen_solve`]: a symmetric eigendecomposition by Jacobi rotations and a solve
//!   with it (small indefinite matrices).

#![warn(missing_docs)]

/// Calls `$kernel::<N>(args)` with the run-time width `$w` as the constant `N` when `$w` is one of
/// the listed literal widths, else evaluates `$fallback`. A kernel with a constant width keeps a
/// row of its result in registers and unrolls its loops; the kernels of this crate do the same
/// arithmetic as their any-width fallback.
///
/// ```
/// fn sum<const N: usize>(v: &[f64]) -> f64 {
///     v[..N].iter().sum()
/// }
/// let v = [1.0, 2.0, 3.0];
/// let s = brachia_linalg::dispatch_width!(v.len(), [1, 2, 3], sum(&v), v.iter().sum::<f64>());
/// assert_eq!(s, 6.0);
/// ```
#[macro_export]
macro_rules! dispatch_width {
    ($w:expr, [$($n:literal),+ $(,)?], $kernel:ident $args:tt, $fallback:expr) => {
        match $w {
            $($n => $kernel::<$n> $args,)+
            _ => $fallback,
        }
    };
}

mod cholesky;
mod eigen;
mod lanes;
mod lincomb;
mod products;

pub use cholesky::{
    cholesky, cholesky_solve, cholesky_solve_in_place, cholesky_solve_vec, cholesky_with_pivot,
    NotPositiveDefinite, Scaling,
};
pub use eigen::{eigen_solve, sym_eigen};
pub use lanes::{dot_lanes, dot_lanes_x4};
pub use lincomb::{add_lincomb, add_lincomb2};
pub use products::{dot_acc, gemm_nn, gemm_nn_acc, gemm_nt, gemm_tn_acc, gemv_n_acc, gemv_t_acc};

/// A real number or a dual number over `f64` (`f64`, `Dual64`, `HyperDual64`, ...): the scalar
/// type of [`cholesky`] and [`cholesky_solve`].
pub trait Scalar: num_dual::DualNum<Primitive = f64> + Copy {}

impl<T: num_dual::DualNum<Primitive = f64> + Copy> Scalar for T {}

#[cfg(test)]
pub(crate) mod testing {
    /// `len` deterministic values in [-1, 1) scaled by 1, 1e-3 or 37 (varied exponents, so that a
    /// kernel that sums in another order than its reference differs in the last bits), from a
    /// xorshift generator seeded by `seed`. The same `(len, seed)` always gives the same values.
    pub(crate) fn values(len: usize, seed: u64) -> Vec<f64> {
        let mut x = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        (0..len)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let u = (x >> 11) as f64 / (1u64 << 53) as f64;
                (2.0 * u - 1.0) * [1.0, 1e-3, 37.0][(x % 3) as usize]
            })
            .collect()
    }
}
