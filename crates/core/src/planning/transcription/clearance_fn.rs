//! The clearance rows as the transcriptions impose them: the exact surface distance.

use crate::ad::LocalFn;
use crate::model::ClearanceFn;

/// The clearance constraints the planner imposes: the exact surface distance, not its square,
/// `g = sqrt(d^2 + eps^2) - (r_a + r_b + margin) >= 0` for every row of a [`ClearanceFn`] (the paper's
/// eq. (12) compares a squared distance with a length; what is meant is `d >= R`). The squared form
/// `d^2 - R^2` has a vanishing gradient when a link passes through an obstacle's centre (`grad d^2 =
/// 2 d grad d`), which stalls the solver's restoration phase on initial guesses that cut through an
/// obstacle; `sqrt(d^2 + eps^2)` keeps a unit-size gradient everywhere and differs from `d` by less
/// than `eps^2 / (2 d)` (1e-12 / (2 d) m with eps = 1e-6) where it matters.
///
/// Owns its rows (a [`ClearanceFn`]: shared handles to the robot and the obstacles).
#[derive(Debug, Clone)]
pub struct DistanceClearanceFn {
    pub(crate) inner: ClearanceFn,
    thresholds: Vec<f64>,
}

/// Smoothing of the distance at d = 0, m.
const DIST_EPS: f64 = 1e-6;

impl DistanceClearanceFn {
    /// Wrap `inner` (its rows, order and margin).
    pub fn new(inner: ClearanceFn) -> Self {
        let thresholds = inner
            .pairs()
            .into_iter()
            .map(|p| inner.threshold(p))
            .collect();
        DistanceClearanceFn { inner, thresholds }
    }

    /// The closed-form derivatives of these rows (the production path; this `LocalFn` through AD is
    /// their test oracle).
    pub fn derivatives(&self) -> crate::model::ClearanceDerivatives {
        crate::model::ClearanceDerivatives::new(
            self.inner.clone(),
            crate::model::ClearanceForm::Distance { eps: DIST_EPS },
        )
    }
}

impl LocalFn for DistanceClearanceFn {
    type Scratch<T: crate::math::Scalar> = <ClearanceFn as LocalFn>::Scratch<T>;
    fn n_in(&self) -> usize {
        self.inner.n_in()
    }
    fn n_out(&self) -> usize {
        self.thresholds.len()
    }
    fn scratch<T: crate::math::Scalar>(&self) -> Self::Scratch<T> {
        self.inner.scratch()
    }
    fn eval<T: crate::math::Scalar>(&self, ws: &mut Self::Scratch<T>, z: &[T], out: &mut [T]) {
        self.inner.eval(ws, z, out);
        for (o, r) in out.iter_mut().zip(&self.thresholds) {
            *o = (*o + (r * r + DIST_EPS * DIST_EPS)).sqrt() - *r;
        }
    }
    fn hessian_entry_is_zero(&self, i: usize, j: usize) -> bool {
        self.inner.hessian_entry_is_zero(i, j)
    }
}
