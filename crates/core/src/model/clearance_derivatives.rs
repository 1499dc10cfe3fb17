//! Closed-form gradient and Hessian of the capsule clearance rows ([`ClearanceFn`]), the production
//! path of the planners' clearance derivatives (automatic differentiation through [`crate::ad::Diff`]
//! stays the test oracle). Derivation in `docs/derivatives.md` ("Clearance rows").
//!
//! Conventions (repeated from the crate docs): planar, body frame at the grip point (origin), x right,
//! y up; `q[0]` is the absolute angle of link 1 from +x, `q[i > 0]` relative angles; SI units (m, rad).
//! Joint `j` is at `p_j` (`p_0` the grip, `p_n` the end effector); link `i` is the segment
//! `[p_i, p_{i+1}]`.
//!
//! # Method
//! Each row is the squared distance of a point to a link, `d^2 = min_t |u(q, t)|^2` over the
//! closest-point parameter `t` on the link, with `u = sum_j alpha_j p_j - c` the difference of the point
//! and its closest point on the link (the point is an obstacle centre `c`, or a joint `p_j` with `c = 0`:
//! self-collision rows are end points against links, see [`ClearanceFn`]). The piece (`t` clamped to 0
//! or 1, or free) is the one [`crate::geometry`] selects on the same input, so the result is the exact
//! derivative of the very expression the AD oracle differentiates. With `R90 [x, y] = [-y, x]`,
//! `dp_j / dq_m = R90 (p_j - p_m)` and `d^2 p_j / dq_m dq_l = -(p_j - p_max(m, l))` for `max < j`
//! (0 otherwise), so with `w_m = sum_{j > m} alpha_j (p_j - p_m)`:
//! - `F_q[m] = 2 u . R90 w_m` (the gradient, by the envelope theorem: `F_t = 0` at a free optimum),
//! - `F_qq[m][l] = 2 w_m . w_l - 2 u . w_max(m, l)`,
//! - when `t` is free (the point projects inside the link), with `du / dt = sigma e_i` (`e_i = p_{i+1} -
//!   p_i` the row's link, `sigma = +-1`): `F_{q_m t} = 2 sigma (R90 w_m . e_i + u . R90 e_i [m <= i])`,
//!   `F_{tt} = 2 |e_i|^2 > 0`,
//! - the Hessian of the minimum: `F_qq - F_{q t} F_{tt}^{-1} F_{t q}` (implicit function theorem).
//!
//! Where the pieces meet (the point projects on an end of the link) the rows are C1 (the gradient is
//! continuous) and the Hessian is the selected piece's (one-sided), as with AD. Nothing here allocates
//! after [`ClearanceDerivatives::new`].

use super::collision::{ClearanceFn, ClearancePair};
use super::{MAX_LINKS, P2};
use crate::ad::LocalFn;
use crate::geometry::{point_segment_closest, PointSegmentPiece};

/// Which function of the squared distance `d^2` each row is (`R` the row's threshold, the sum of the
/// two radii and the margin, m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ClearanceForm {
    /// `g = d^2 - R^2`, m^2: the rows of [`ClearanceFn`] itself.
    Squared,
    /// `v = sqrt(d^2 - R^2 + (R^2 + eps^2)) - R`, m: the smoothed distance rows the planners use
    /// (`eps` > 0 keeps the gradient finite at `d = 0`).
    Distance {
        /// Smoothing length, m.
        eps: f64,
    },
}

/// Closed-form value, Jacobian and weighted Hessian of the rows of a [`ClearanceFn`] in a
/// [`ClearanceForm`]. Layouts as [`crate::ad::Diff`]: Jacobian row-major `rows x n`, Hessian full
/// symmetric row-major `n x n`. Owns its rows (a [`ClearanceFn`]: shared handles to the robot and
/// the obstacles).
#[derive(Debug, Clone)]
pub struct ClearanceDerivatives {
    f: ClearanceFn,
    form: ClearanceForm,
    pairs: Vec<ClearancePair>,
    thresholds: Vec<f64>,
}

/// One row's derivative data at a configuration.
#[derive(Debug, Clone, Copy)]
struct Row {
    d2: f64,
    /// Difference of the closest points, `u = sum alpha_j p_j - c`.
    u: [f64; 2],
    /// Non-zero weights `alpha_j` (joint index, weight).
    alpha: [(usize, f64); 3],
    n_alpha: usize,
    /// The free closest-point parameter, if the point projects inside the link: (link index of `e`,
    /// sign `sigma`).
    free: Option<(usize, f64)>,
    /// The q indices the row depends on, `lo..=hi`.
    lo: usize,
    hi: usize,
}

#[inline(always)]
fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

#[inline(always)]
fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// `a . R90 b` with `R90 [x, y] = [-y, x]`.
#[inline(always)]
fn dot_r90(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[1] * b[0] - a[0] * b[1]
}

impl ClearanceDerivatives {
    /// The rows of `f` (order and thresholds as [`ClearanceFn`]) in the given form. Allocates the row
    /// list once.
    pub fn new(f: ClearanceFn, form: ClearanceForm) -> Self {
        let pairs = f.pairs();
        let thresholds = pairs.iter().map(|&p| f.threshold(p)).collect();
        ClearanceDerivatives {
            f,
            form,
            pairs,
            thresholds,
        }
    }

    /// Number of rows.
    pub fn n_out(&self) -> usize {
        self.pairs.len()
    }

    /// Number of joint angles (the robot's links).
    pub fn n_in(&self) -> usize {
        self.f.robot.n
    }

    fn joints(&self, q: &[f64]) -> [P2<f64>; MAX_LINKS + 1] {
        let n = self.f.robot.n;
        let mut segs = [([0.0; 2], [0.0; 2]); MAX_LINKS];
        self.f.robot.link_segments(q, &mut segs[..n]);
        let mut p = [[0.0; 2]; MAX_LINKS + 1];
        for j in 0..n {
            p[j] = segs[j].0;
        }
        p[n] = segs[n - 1].1;
        p
    }

    fn row(&self, p: &[P2<f64>], pair: ClearancePair) -> Row {
        match pair {
            ClearancePair::LinkObstacle { link: i, obstacle } => {
                let c = self.f.obstacles[obstacle].center;
                let r = point_segment_closest(c, p[i], p[i + 1]);
                let t = r.t;
                let e = sub(p[i + 1], p[i]);
                Row {
                    d2: r.dist2,
                    u: [p[i][0] + t * e[0] - c[0], p[i][1] + t * e[1] - c[1]],
                    alpha: [(i, 1.0 - t), (i + 1, t), (0, 0.0)],
                    n_alpha: 2,
                    free: (r.piece == PointSegmentPiece::Interior).then_some((i, 1.0)),
                    lo: 0,
                    hi: i,
                }
            }
            ClearancePair::JointLink { joint: j, link: l } => {
                let r = point_segment_closest(p[j], p[l], p[l + 1]);
                let t = r.t;
                let e = sub(p[l + 1], p[l]);
                let (lo, hi) = pair.dependence();
                Row {
                    d2: r.dist2,
                    u: [p[j][0] - p[l][0] - t * e[0], p[j][1] - p[l][1] - t * e[1]],
                    alpha: [(j, 1.0), (l, t - 1.0), (l + 1, -t)],
                    n_alpha: 3,
                    free: (r.piece == PointSegmentPiece::Interior).then_some((l, -1.0)),
                    lo,
                    hi,
                }
            }
            ClearancePair::LinkLink { .. } => {
                unreachable!("link-link pairs are the exact check, never a constraint row")
            }
        }
    }

    /// `w_m = sum_{j > m} alpha_j (p_j - p_m)` into `w[m]` for `m` in `row.lo..=row.hi` (the others
    /// are not written).
    fn w_vectors(p: &[P2<f64>], row: &Row, w: &mut [[f64; 2]]) {
        for (m, wm) in w.iter_mut().enumerate().take(row.hi + 1).skip(row.lo) {
            *wm = [0.0; 2];
            for &(j, al) in &row.alpha[..row.n_alpha] {
                if j > m {
                    let d = sub(p[j], p[m]);
                    wm[0] += al * d[0];
                    wm[1] += al * d[1];
                }
            }
        }
    }

    /// Row value from the squared distance, in the configured form, and the factors `(f1, f2)` that
    /// turn derivatives of `d^2` into derivatives of the row: `grad = f1 grad d^2`,
    /// `hess = f1 hess d^2 + f2 grad d^2 grad d^2^T`.
    fn transform(&self, k: usize, d2: f64) -> (f64, f64, f64) {
        let r = self.thresholds[k];
        let g = d2 - r * r;
        match self.form {
            ClearanceForm::Squared => (g, 1.0, 0.0),
            ClearanceForm::Distance { eps } => {
                let sq = (g + (r * r + eps * eps)).sqrt();
                (sq - r, 0.5 / sq, -0.25 / (sq * sq * sq))
            }
        }
    }

    /// Row values into `out` (length [`Self::n_out`]), bit-identical to the [`LocalFn::eval`] of
    /// [`ClearanceFn`] in the squared form. `q`: n angles.
    pub fn value(&self, q: &[f64], out: &mut [f64]) {
        let p = self.joints(q);
        for (k, &pair) in self.pairs.iter().enumerate() {
            let d2 = match pair {
                ClearancePair::LinkObstacle { link, obstacle } => {
                    point_segment_closest(self.f.obstacles[obstacle].center, p[link], p[link + 1])
                        .dist2
                }
                ClearancePair::JointLink { joint, link } => {
                    point_segment_closest(p[joint], p[link], p[link + 1]).dist2
                }
                ClearancePair::LinkLink { .. } => {
                    unreachable!("link-link pairs are the exact check, never a constraint row")
                }
            };
            out[k] = self.transform(k, d2).0;
        }
    }

    /// Row values into `out` and the Jacobian (row-major `n_out x n`) into `jac`.
    pub fn jacobian(&self, q: &[f64], out: &mut [f64], jac: &mut [f64]) {
        self.jacobian_impl(q, out, jac, None);
    }

    /// [`Self::jacobian`], recording the rows' derivative data at `q` in `rec` (made by
    /// [`Self::record`]) for [`Self::hessian_weighted_recorded`] at the same point. The same
    /// arithmetic: the results are bit for bit those of [`Self::jacobian`].
    pub fn jacobian_recorded(
        &self,
        q: &[f64],
        out: &mut [f64],
        jac: &mut [f64],
        rec: &mut ClearanceRecord,
    ) {
        self.jacobian_impl(q, out, jac, Some(rec));
    }

    fn jacobian_impl(
        &self,
        q: &[f64],
        out: &mut [f64],
        jac: &mut [f64],
        mut rec: Option<&mut ClearanceRecord>,
    ) {
        let n = self.f.robot.n;
        let p = self.joints(q);
        jac[..self.pairs.len() * n].fill(0.0);
        let mut wl = [[0.0; 2]; MAX_LINKS];
        for (k, &pair) in self.pairs.iter().enumerate() {
            let row = self.row(&p, pair);
            let (v, f1, _) = self.transform(k, row.d2);
            out[k] = v;
            let w = match rec.as_deref_mut() {
                Some(r) => {
                    r.rows[k] = row;
                    &mut r.w[k * n..(k + 1) * n]
                }
                None => &mut wl[..n],
            };
            Self::w_vectors(&p, &row, w);
            for m in row.lo..=row.hi {
                jac[k * n + m] = f1 * 2.0 * dot_r90(row.u, w[m]);
            }
        }
        if let Some(r) = rec {
            r.q.copy_from_slice(&q[..n]);
            r.p = p;
            r.valid = true;
        }
    }

    /// Buffers for [`Self::jacobian_recorded`] (allocated here, once; nothing recorded yet).
    pub fn record(&self) -> ClearanceRecord {
        let n = self.f.robot.n;
        let none = Row {
            d2: 0.0,
            u: [0.0; 2],
            alpha: [(0, 0.0); 3],
            n_alpha: 0,
            free: None,
            lo: 0,
            hi: 0,
        };
        ClearanceRecord {
            q: vec![0.0; n],
            valid: false,
            p: [[0.0; 2]; MAX_LINKS + 1],
            rows: vec![none; self.pairs.len()],
            w: vec![[0.0; 2]; self.pairs.len() * n],
        }
    }

    /// Hessian of `sum_k weights_k row_k(q)` (full symmetric `n x n`, row-major) into `hess`.
    pub fn hessian_weighted(&self, q: &[f64], weights: &[f64], hess: &mut [f64]) {
        let n = self.f.robot.n;
        let p = self.joints(q);
        hess[..n * n].fill(0.0);
        let mut w = [[0.0; 2]; MAX_LINKS];
        for (k, &pair) in self.pairs.iter().enumerate() {
            let wk = weights[k];
            if wk == 0.0 {
                continue;
            }
            let row = self.row(&p, pair);
            Self::w_vectors(&p, &row, &mut w[..n]);
            self.add_row_hessian(k, wk, &p, &row, &w[..n], hess);
        }
    }

    /// [`Self::hessian_weighted`] from the rows `rec` recorded at `q` by [`Self::jacobian_recorded`]
    /// (bit for bit the same result); recomputes when `rec` holds another point or nothing.
    pub fn hessian_weighted_recorded(
        &self,
        q: &[f64],
        weights: &[f64],
        hess: &mut [f64],
        rec: &ClearanceRecord,
    ) {
        let n = self.f.robot.n;
        if !(rec.valid && rec.q[..] == q[..n]) {
            self.hessian_weighted(q, weights, hess);
            return;
        }
        hess[..n * n].fill(0.0);
        for k in 0..self.pairs.len() {
            let wk = weights[k];
            if wk == 0.0 {
                continue;
            }
            let w = &rec.w[k * n..(k + 1) * n];
            self.add_row_hessian(k, wk, &rec.p, &rec.rows[k], w, hess);
        }
    }

    /// Add `wk` times row k's Hessian (its data `row`, `w` at the joints `p`) to `hess` (`n x n`).
    #[inline(always)]
    fn add_row_hessian(
        &self,
        k: usize,
        wk: f64,
        p: &[P2<f64>],
        row: &Row,
        w: &[[f64; 2]],
        hess: &mut [f64],
    ) {
        let n = self.f.robot.n;
        let (_, f1, f2) = self.transform(k, row.d2);
        let (lo, hi) = (row.lo, row.hi);
        // gradient of d^2, the mixed column F_{q t} and F_{tt}^{-1} (zero when t is clamped)
        let mut grad = [0.0; MAX_LINKS];
        let mut bq = [0.0; MAX_LINKS];
        let mut inv = 0.0;
        let free = row.free.map(|(i, sg)| {
            (
                i,
                [sg * (p[i + 1][0] - p[i][0]), sg * (p[i + 1][1] - p[i][1])],
            )
        });
        for m in lo..=hi {
            grad[m] = 2.0 * dot_r90(row.u, w[m]);
            if let Some((i, e)) = free {
                // (R90 w_m) . e = e . R90 w_m, then u . R90 e
                let mut v = dot_r90(e, w[m]);
                if m <= i {
                    v += dot_r90(row.u, e);
                }
                bq[m] = 2.0 * v;
            }
        }
        if let Some((_, e)) = free {
            inv = 0.5 / dot(e, e);
        }
        for m in lo..=hi {
            for l in m..=hi {
                let mut h = 2.0 * dot(w[m], w[l]) - 2.0 * dot(row.u, w[l.max(m)]);
                if free.is_some() {
                    h -= bq[m] * inv * bq[l];
                }
                let v = wk * (f1 * h + f2 * grad[m] * grad[l]);
                hess[m * n + l] += v;
                if l != m {
                    hess[l * n + m] += v;
                }
            }
        }
    }
}

/// The rows' derivative data at one configuration, recorded by
/// [`ClearanceDerivatives::jacobian_recorded`] so that the Hessian at the same point
/// ([`ClearanceDerivatives::hessian_weighted_recorded`]) does not recompute the joints, the closest
/// points and the `w_m`. Made by [`ClearanceDerivatives::record`].
#[derive(Debug, Clone)]
pub struct ClearanceRecord {
    q: Vec<f64>,
    valid: bool,
    p: [P2<f64>; MAX_LINKS + 1],
    rows: Vec<Row>,
    /// `w_m` of row k at `w[k n + m]`.
    w: Vec<[f64; 2]>,
}

impl ClearanceDerivatives {
    /// True when entry `(i, j)` of every row's Hessian is structurally zero (as
    /// [`LocalFn::hessian_entry_is_zero`] of [`ClearanceFn`]); [`Self::hessian_weighted`] leaves those
    /// entries exactly zero.
    pub fn hessian_entry_is_zero(&self, i: usize, j: usize) -> bool {
        self.f.hessian_entry_is_zero(i, j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ad::{as_f64_fn, Diff};
    use crate::fdcheck::{assert_hessian, assert_jacobian, compare};
    use crate::model::collision::tests::odd_robot;
    use crate::model::{Circle, LinkSet, Robot};
    use crate::planning::DistanceClearanceFn;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::collections::HashSet;

    use crate::model::collision::tests::TEST_OBSTACLES as OBS;

    /// The pieces a configuration selects: per row, (row kind and point piece, free parameters).
    fn pieces(d: &ClearanceDerivatives, q: &[f64]) -> Vec<(String, usize)> {
        let p = d.joints(q);
        d.pairs
            .iter()
            .map(|&pair| {
                let row = d.row(&p, pair);
                let name = match pair {
                    ClearancePair::LinkObstacle { link, obstacle } => format!(
                        "obstacle {:?}",
                        point_segment_closest(OBS[obstacle].center, p[link], p[link + 1]).piece
                    ),
                    ClearancePair::JointLink { joint, link } => format!(
                        "joint {:?}",
                        point_segment_closest(p[joint], p[link], p[link + 1]).piece
                    ),
                    ClearancePair::LinkLink { .. } => unreachable!("not a row"),
                };
                (name, row.free.is_some() as usize)
            })
            .collect()
    }

    /// Value, Jacobian and weighted Hessian of `d` at `q` against AD through `oracle` (the same rows):
    /// values bit-identical, derivatives to `tol` (scaled as `fdcheck`); with `fd`, also against
    /// finite differences through the shared helper.
    fn check<F: LocalFn>(
        d: &ClearanceDerivatives,
        oracle: &F,
        q: &[f64],
        w: &[f64],
        tol: f64,
        fd: bool,
    ) {
        let (n, m) = (d.n_in(), d.n_out());
        let mut diff = Diff::new(oracle);
        let (mut ga, mut ja, mut ha) = (vec![0.0; m], vec![0.0; m * n], vec![0.0; n * n]);
        diff.jacobian(oracle, q, &mut ga, &mut ja);
        diff.hessian_weighted(oracle, q, w, &mut ha);
        let (mut g, mut gv, mut j, mut h) = (
            vec![0.0; m],
            vec![0.0; m],
            vec![0.0; m * n],
            vec![0.0; n * n],
        );
        d.value(q, &mut gv);
        d.jacobian(q, &mut g, &mut j);
        d.hessian_weighted(q, w, &mut h);
        // bit-identical to the f64 evaluation (AD's real parts may round differently: its division is
        // a product with a reciprocal)
        let mut gf = vec![0.0; m];
        as_f64_fn(oracle)(q, &mut gf);
        assert_eq!(g, gf, "values at {q:?}");
        assert_eq!(gv, gf, "value-only values at {q:?}");
        let rg = compare(&g, &ga, 1);
        assert!(rg.max_scaled_err <= 1e-14, "values vs AD at {q:?}: {rg:?}");
        let rj = compare(&j, &ja, n);
        assert!(rj.max_scaled_err <= tol, "Jacobian vs AD at {q:?}: {rj:?}");
        let rh = compare(&h, &ha, n);
        assert!(rh.max_scaled_err <= tol, "Hessian vs AD at {q:?}: {rh:?}");
        for a in 0..n {
            for b in 0..n {
                assert_eq!(h[a * n + b], h[b * n + a]);
                if d.hessian_entry_is_zero(a, b) {
                    assert_eq!(h[a * n + b], 0.0);
                }
            }
        }
        if fd {
            assert_jacobian(
                "closed-form clearance Jacobian",
                as_f64_fn(oracle),
                q,
                &j,
                1e-6,
            );
            let grad = |x: &[f64], out: &mut [f64]| {
                let (mut gx, mut jx) = (vec![0.0; m], vec![0.0; m * n]);
                d.jacobian(x, &mut gx, &mut jx);
                for c in 0..n {
                    out[c] = (0..m).map(|r| w[r] * jx[r * n + c]).sum();
                }
            };
            // (looser than the AD check: the distance form has 1 / d^3 curvature terms)
            assert_hessian("closed-form clearance Hessian", grad, q, &h, 1e-4);
        }
    }

    fn random_weights(rng: &mut ChaCha8Rng, m: usize) -> Vec<f64> {
        (0..m).map(|_| rng.gen_range(-1.0..1.0)).collect()
    }

    #[test]
    fn matches_ad_and_fd_on_random_poses_and_covers_every_piece() {
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let mut seen = HashSet::new();
        for robot in [Robot::paper(), odd_robot()] {
            let n = robot.n;
            for (self_coll, links) in [
                (true, LinkSet::ALL),
                (true, LinkSet::from_indices(&[0, 2, 3], n).unwrap()),
            ] {
                let f = ClearanceFn::new(robot.clone(), &OBS[..], 0.02)
                    .unwrap()
                    .with_self_collision(self_coll)
                    .with_links(links);
                let squared = ClearanceDerivatives::new(f.clone(), ClearanceForm::Squared);
                let dist_fn = DistanceClearanceFn::new(f.clone());
                let dist = dist_fn.derivatives();
                for it in 0..60 {
                    let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.2..3.2)).collect();
                    let w = random_weights(&mut rng, f.n_out());
                    // FD on a third of the poses (a kink between the FD points is possible but
                    // improbable at these seeds; AD is checked everywhere)
                    check(&squared, &f, &q, &w, 1e-9, it % 3 == 0);
                    check(&dist, &dist_fn, &q, &w, 1e-8, it % 3 == 1);
                    seen.extend(pieces(&squared, &q));
                }
            }
        }
        // every piece the geometry selects, for both kinds of row, with the free parameter it implies
        for want in [
            ("obstacle Start", 0),
            ("obstacle Interior", 1),
            ("obstacle End", 0),
            ("joint Start", 0),
            ("joint Interior", 1),
            ("joint End", 0),
        ] {
            assert!(
                seen.contains(&(want.0.to_string(), want.1)),
                "piece {want:?} never selected: {seen:?}"
            );
        }
    }

    #[test]
    fn recorded_rows_give_the_same_bits() {
        // the Jacobian and Hessian through a record equal the plain ones bit for bit; a record of
        // another point (or none) makes the Hessian recompute
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        for robot in [Robot::paper(), odd_robot()] {
            let n = robot.n;
            let f = ClearanceFn::new(robot.clone(), &OBS[..], 0.02)
                .unwrap()
                .with_self_collision(true);
            let d = DistanceClearanceFn::new(f.clone()).derivatives();
            let m = d.n_out();
            let mut rec = d.record();
            let (mut v0, mut v1) = (vec![0.0; m], vec![0.0; m]);
            let (mut j0, mut j1) = (vec![0.0; m * n], vec![0.0; m * n]);
            let (mut h0, mut h1) = (vec![0.0; n * n], vec![0.0; n * n]);
            for it in 0..40 {
                let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.2..3.2)).collect();
                let w = random_weights(&mut rng, m);
                d.hessian_weighted(&q, &w, &mut h0);
                // nothing or another point recorded: the fallback
                d.hessian_weighted_recorded(&q, &w, &mut h1, &rec);
                assert_eq!(bits(&h0), bits(&h1), "fallback, pose {it}");
                d.jacobian(&q, &mut v0, &mut j0);
                d.jacobian_recorded(&q, &mut v1, &mut j1, &mut rec);
                assert_eq!(bits(&v0), bits(&v1), "values, pose {it}");
                assert_eq!(bits(&j0), bits(&j1), "Jacobian, pose {it}");
                h1.fill(f64::NAN);
                d.hessian_weighted_recorded(&q, &w, &mut h1, &rec);
                assert_eq!(bits(&h0), bits(&h1), "recorded Hessian, pose {it}");
            }
        }
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn parallel_links_are_smooth() {
        // Link 3 folded back exactly antiparallel over link 1 (q2 + q3 = pi), overlapping, and 1e-2 rad
        // either side: where the segment-segment distance has a kink (its closest pair is not unique)
        // the end-point rows are smooth (no end projects onto an end of the other link), so every row
        // matches AD and finite differences on all three poses.
        let robot = Robot::paper();
        let f = ClearanceFn::new(robot.clone(), [], 0.0).unwrap();
        let dist_fn = DistanceClearanceFn::new(f.clone());
        let (sq, dist) = (
            ClearanceDerivatives::new(f.clone(), ClearanceForm::Squared),
            dist_fn.derivatives(),
        );
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let w = random_weights(&mut rng, f.n_out());
        let names = f.row_names();
        for off in [0.0, 1e-2, -1e-2] {
            let q = [0.3, 2.0, std::f64::consts::PI - 2.0 + off, 0.5];
            let kinds = pieces(&sq, &q);
            // the overlap: each link has an end that projects strictly inside the other
            for row in ["end of link 2 vs link 1", "grip vs link 3"] {
                let k = names.iter().position(|s| s == row).unwrap();
                assert_eq!(
                    kinds[k],
                    ("joint Interior".to_string(), 1),
                    "{row}: {kinds:?}"
                );
            }
            check(&sq, &f, &q, &w, 1e-9, true);
            check(&dist, &dist_fn, &q, &w, 1e-8, true);
        }
    }

    #[test]
    fn clamped_parameter_switching_is_c1_and_each_side_matches_ad() {
        // The obstacle's projection on link 2 crosses the link's end (t* = 1) as q[1] turns: on each
        // side the piece differs (Interior / End), the gradient is continuous across, and each side's
        // Hessian is that piece's (against AD and finite differences).
        let robot = Robot::paper();
        let obs = [Circle {
            center: [0.71, 0.1],
            radius: 0.05,
        }];
        let f = ClearanceFn::new(robot.clone(), &obs[..], 0.0)
            .unwrap()
            .with_self_collision(false);
        let d = ClearanceDerivatives::new(f.clone(), ClearanceForm::Squared);
        let n = robot.n;
        let row = 1; // link 2 vs obstacle 0
                     // find the switching angle of q[1] (q = [0, x, 0.4, 0]) by bisection on the piece
        let piece = |x: f64| {
            let p = d.joints(&[0.0, x, 0.4, 0.0]);
            point_segment_closest(obs[0].center, p[1], p[2]).piece
        };
        let (mut lo, mut hi) = (-0.5, 0.5);
        assert_ne!(piece(lo), piece(hi));
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if piece(mid) == piece(lo) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let mut grads = vec![];
        let mut w = vec![0.0; d.n_out()];
        w[row] = 1.0;
        for x in [lo - 1e-4, hi + 1e-4] {
            let q = [0.0, x, 0.4, 0.0];
            check(&d, &f, &q, &w, 1e-9, true);
            let (mut g, mut j) = (vec![0.0; d.n_out()], vec![0.0; d.n_out() * n]);
            d.jacobian(&q, &mut g, &mut j);
            grads.push(j[row * n..(row + 1) * n].to_vec());
        }
        let kinds = [piece(lo - 1e-4), piece(hi + 1e-4)];
        assert!(
            kinds.contains(&PointSegmentPiece::Interior) && kinds.contains(&PointSegmentPiece::End)
        );
        // C1: the gradient moves by O(step) across the switch
        for (a, b) in grads[0].iter().zip(&grads[1]) {
            assert!((a - b).abs() < 1e-3, "{:?} vs {:?}", grads[0], grads[1]);
        }
    }
}
