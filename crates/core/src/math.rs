//! Scalar types used across brachia.
//!
//! Every model function (kinematics, dynamics, collision distances) is written once, generic over a
//! [`Scalar`]: `f64` for plain evaluation, `Dual64` for exact first derivatives and `HyperDual64` for
//! exact second derivatives (see [`crate::ad`]). Units are SI throughout: metres, radians, seconds,
//! kilograms, newton-metres.

use num_dual::DualNum;

pub use num_dual::{Dual64, HyperDual64};

/// A real number or a dual number over `f64`: what model code is generic over.
pub trait Scalar: DualNum<Primitive = f64> + Copy {}

impl<T: DualNum<Primitive = f64> + Copy> Scalar for T {}

/// Lift a constant into any scalar type.
#[inline(always)]
pub fn c<T: Scalar>(v: f64) -> T {
    T::from(v)
}

/// Real part of a scalar (the value without derivative parts).
#[inline(always)]
pub fn re<T: Scalar>(v: T) -> f64 {
    v.re()
}
