//! Time-varying LQR along the plan (the AcroMonk / Drake baseline): gains from a backward Riccati
//! recursion on the model linearised along the plan, computed once in [`Tvlqr::new`].
//!
//! Conventions: state `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the rest relative),
//! input `u = tau` = torques of joints 2..n (N m), EE `y = [x_ee, y_ee]` (m), time in s.
//!
//! On a grid `t_k = k dt` (k = 0..N, `N = ceil(T / dt)`, T the plan's duration) the model is linearised
//! at the plan point `(x^d(t_k), u^d(t_k))` with the exact Jacobians ([`crate::model::Linearizer`]) and
//! discretised by the exact zero-order hold over dt. The cost is
//! `sum_k dt (|dx_k|^2_Qt_k + |du_k|^2_R) + |dx_N|^2_(terminal_s Qt_N)`, `Qt_k = Q + C_k^T W C_k`
//! (`C_k` the EE Jacobian at the plan point, so W weighs the EE error like the MPC), with
//! `dx = x - x^d`, `du = u - u^d`. Riccati: `S_N = terminal_s Qt_N`,
//! `K_k = (dt R + B^T S_{k+1} B)^-1 B^T S_{k+1} A`,
//! `S_k = dt Qt_k + K^T dt R K + (A - B K)^T S_{k+1} (A - B K)`. The control law is
//! `u = clamp(u^d(t) - K(t) (x - x^d(t)))` with K linearly interpolated between grid points and held
//! past the ends.

use super::tracking::{TrackerSettings, Tracking};
use super::{ControlInfo, Controller};
use crate::error::{Error, Result};
use crate::model::{LinearModel, Linearizer, Robot, MAX_LINKS};
use crate::trajectory::Trajectory;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Largest number of grid intervals of the gain schedule of a 4-link robot (state dimension 8); a
/// robot of state dimension `nx` gets `MAX_TVLQR_STAGES * 64 / nx^2` (at most this), since the memory
/// of the backward pass grows with `nx^2` per stage ([`max_tvlqr_stages`]; a 12-link schedule of
/// 200 000 stages took 3.4 GB).
pub const MAX_TVLQR_STAGES: usize = 200_000;

/// Largest number of grid intervals of the gain schedule for an `n`-link robot (see
/// [`MAX_TVLQR_STAGES`]).
pub fn max_tvlqr_stages(n: usize) -> usize {
    let nx = (2 * n).max(1);
    (MAX_TVLQR_STAGES * 64 / (nx * nx)).min(MAX_TVLQR_STAGES)
}

/// Settings of [`Tvlqr`] (weights are densities per second of the tracking error).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TvlqrSettings {
    /// Grid spacing of the gain schedule, s. Default 0.005.
    pub dt: f64,
    /// Diagonal of Q (2n values: q then qd; 1/(rad^2 s), 1/((rad/s)^2 s)). Default
    /// empty: `[5000 x n, 50 x n]` for n links (the MPC's per-step weights divided by its 20 ms step),
    /// filled when the controller is built.
    pub q_diag: Vec<f64>,
    /// Diagonal of the EE weight W (2 values, 1/(m^2 s)). Default `[1e5, 1e5]`.
    pub w_diag: Vec<f64>,
    /// Diagonal of R (n - 1 values, 1/((N m)^2 s), > 0). Default empty: `[0.5 x (n - 1)]`, filled
    /// when the controller is built.
    pub r_diag: Vec<f64>,
    /// Terminal weight as a time: `S_N = terminal_s Qt_N`, s (>= 0). Default 0.1.
    pub terminal_s: f64,
}

impl TrackerSettings for TvlqrSettings {
    fn checked(&self, n: usize) -> Result<Self> {
        self.validate(n)?;
        Ok(self.resolved(n))
    }
}

impl Default for TvlqrSettings {
    /// Empty `q_diag` / `r_diag`: the per-link defaults, filled in when the controller is built.
    fn default() -> Self {
        TvlqrSettings {
            dt: 0.005,
            q_diag: Vec::new(),
            w_diag: vec![1e5, 1e5],
            r_diag: Vec::new(),
            terminal_s: 0.1,
        }
    }
}

impl TvlqrSettings {
    /// These settings with empty `q_diag` / `r_diag` filled for an n-link robot.
    pub fn resolved(&self, n: usize) -> Self {
        let mut s = self.clone();
        if s.q_diag.is_empty() {
            s.q_diag = vec![5000.0; n];
            s.q_diag.extend(std::iter::repeat_n(50.0, n));
        }
        if s.r_diag.is_empty() {
            s.r_diag = vec![0.5; n.saturating_sub(1)];
        }
        s
    }

    /// Check the values for an n-link robot. Errors name the field as written in a scenario's
    /// `[tracking.tvlqr]`.
    pub fn validate(&self, n: usize) -> Result<()> {
        let src = "TvlqrSettings";
        if !(self.dt.is_finite() && self.dt >= 1e-4 && self.dt <= 1.0) {
            return Err(Error::invalid(src, "dt", self.dt, "must be in [1e-4, 1] s"));
        }
        let s = self.resolved(n);
        super::check_tracking_weights(
            src,
            n,
            [&s.q_diag, &s.w_diag, &s.r_diag],
            "keeps the Riccati step invertible",
        )?;
        if !(self.terminal_s.is_finite() && self.terminal_s >= 0.0 && self.terminal_s <= 1e6) {
            return Err(Error::invalid(
                src,
                "terminal_s",
                self.terminal_s,
                "must be finite and in [0, 1e6] s",
            ));
        }
        Ok(())
    }
}

/// One discrete stage `x+ = A x + B u` with stage weights `Q`, `R`, for [`riccati_gains`].
#[derive(Debug, Clone)]
pub struct LqrStage {
    /// State matrix, nx x nx.
    pub a: DMatrix<f64>,
    /// Input matrix, nx x nu.
    pub b: DMatrix<f64>,
    /// State weight of this stage, nx x nx (symmetric, >= 0).
    pub q: DMatrix<f64>,
    /// Input weight, nu x nu (symmetric, > 0).
    pub r: DMatrix<f64>,
}

/// Gains `K_k` (k = 0..N-1) of the finite-horizon LQR `min sum_k |x_k|^2_Q_k + |u_k|^2_R_k +
/// |x_N|^2_S_N` by the backward Riccati recursion (Joseph-symmetric form), and `S_0`. Returns None
/// if a step's `R + B^T S B` is not positive definite.
pub fn riccati_gains(
    stages: &[LqrStage],
    s_n: &DMatrix<f64>,
) -> Option<(Vec<DMatrix<f64>>, DMatrix<f64>)> {
    let mut s = s_n.clone();
    let mut gains = vec![DMatrix::zeros(0, 0); stages.len()];
    for (k, st) in stages.iter().enumerate().rev() {
        let bts = st.b.transpose() * &s;
        let m = &st.r + &bts * &st.b;
        let chol = m.cholesky()?;
        let kk = chol.solve(&(&bts * &st.a));
        let acl = &st.a - &st.b * &kk;
        let sn = &st.q + kk.transpose() * &st.r * &kk + acl.transpose() * &s * &acl;
        s = (&sn + sn.transpose()) * 0.5;
        gains[k] = kk;
    }
    Some((gains, s))
}

/// TVLQR tracker of a plan (see the module docs). Gains are computed in [`Tvlqr::new`] (and again in
/// [`Tvlqr::set_reference`]); a control call does not allocate.
#[derive(Debug, Clone)]
pub struct Tvlqr {
    tr: Tracking<TvlqrSettings>,
    /// Gains `K_k` row-major nu x nx, k = 0..=N (the last repeats K_{N-1}).
    gains: Vec<f64>,
    stages: usize,
}

impl Tvlqr {
    /// A TVLQR tracker of `reference` for `robot` (owned values or shared `Arc`s).
    pub fn new(
        robot: impl Into<Arc<Robot>>,
        reference: impl Into<Arc<Trajectory>>,
        settings: TvlqrSettings,
    ) -> Result<Self> {
        let tr = Tracking::new(robot, reference, &settings)?;
        let gains = compute_gains(&tr.robot, &tr.reference, &tr.settings)?;
        let stages = gains.len() / (tr.robot.nu() * tr.robot.nx()) - 1;
        Ok(Tvlqr { tr, gains, stages })
    }

    /// Track another plan: the gains are recomputed (this allocates); on error the current plan and
    /// gains are kept.
    pub fn set_reference(&mut self, reference: impl Into<Arc<Trajectory>>) -> Result<()> {
        let reference: Arc<Trajectory> = reference.into();
        let tr = &mut self.tr;
        reference.check_reference(&tr.robot)?;
        let gains = compute_gains(&tr.robot, &reference, &tr.settings)?;
        self.stages = gains.len() / (tr.robot.nu() * tr.robot.nx()) - 1;
        self.gains = gains;
        tr.reference = reference;
        Ok(())
    }

    /// The settings in use (empty weights filled with the per-link defaults).
    pub fn settings(&self) -> &TvlqrSettings {
        &self.tr.settings
    }

    /// The gain at grid point k (nu x nx row-major), k = 0..=N.
    pub fn gain(&self, k: usize) -> &[f64] {
        let blk = self.tr.robot.nu() * self.tr.robot.nx();
        let k = k.min(self.stages);
        &self.gains[k * blk..(k + 1) * blk]
    }

    /// Number of grid intervals N.
    pub fn stages(&self) -> usize {
        self.stages
    }
}

fn compute_gains(robot: &Robot, reference: &Trajectory, s: &TvlqrSettings) -> Result<Vec<f64>> {
    let n = robot.n;
    let (nx, nu) = (2 * n, n - 1);
    let dt = s.dt;
    let t_end = reference.duration();
    let t0 = reference.t[0];
    let count = (t_end / dt).ceil().max(1.0);
    let cap = max_tvlqr_stages(n);
    if !count.is_finite() || count > cap as f64 {
        return Err(Error::invalid(
            "TvlqrSettings",
            "dt",
            dt,
            format!(
                "the plan's {t_end} s would need more than {cap} grid intervals for {n} links \
                 (brachia::control::tvlqr::max_tvlqr_stages: MAX_TVLQR_STAGES scaled by 64 / (2n)^2)"
            ),
        ));
    }
    let nst = count as usize;
    let mut lin = Linearizer::new(robot.clone());
    let mut lm = LinearModel::zeros(n);
    let mut x = vec![0.0; nx];
    let mut u = vec![0.0; nu];
    let qd = DMatrix::from_diagonal(&DVector::from_column_slice(&s.q_diag));
    let rd = DMatrix::from_diagonal(&DVector::from_column_slice(&s.r_diag)) * dt;
    let w = DMatrix::from_diagonal(&DVector::from_column_slice(&s.w_diag));
    let mut stages = Vec::with_capacity(nst);
    let mut qt_at = |k: usize, lin: &mut Linearizer, lm: &mut LinearModel| {
        let t = t0 + k as f64 * dt;
        reference.state_at(t, &mut x);
        reference.tau_at(t, &mut u);
        lin.linearize_into(&x, &u, lm);
        let c = DMatrix::from_row_slice(2, nx, &lm.c);
        &qd + c.transpose() * &w * c
    };
    for k in 0..nst {
        let qt = qt_at(k, &mut lin, &mut lm);
        // ZOH of the linear part: top rows of exp(dt [A B; 0 0]).
        let mut m = DMatrix::zeros(nx + nu, nx + nu);
        for i in 0..nx {
            for j in 0..nx {
                m[(i, j)] = dt * lm.a[i * nx + j];
            }
            for j in 0..nu {
                m[(i, nx + j)] = dt * lm.b[i * nu + j];
            }
        }
        let e = m.exp();
        stages.push(LqrStage {
            a: e.view((0, 0), (nx, nx)).into_owned(),
            b: e.view((0, nx), (nx, nu)).into_owned(),
            q: qt * dt,
            r: rd.clone(),
        });
    }
    let s_n = qt_at(nst, &mut lin, &mut lm) * s.terminal_s;
    let (gains, _) = riccati_gains(&stages, &s_n).ok_or_else(|| {
        Error::invalid(
            "TvlqrSettings",
            "r_diag",
            format!("{:?}", s.r_diag),
            "the Riccati recursion lost positive definiteness",
        )
    })?;
    let blk = nu * nx;
    let mut out = vec![0.0; (nst + 1) * blk];
    for (k, g) in gains.iter().enumerate() {
        for i in 0..nu {
            for j in 0..nx {
                out[k * blk + i * nx + j] = g[(i, j)];
            }
        }
    }
    let last = out[(nst - 1) * blk..nst * blk].to_vec();
    out[nst * blk..].copy_from_slice(&last);
    if out.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "TvlqrSettings",
            "q_diag",
            format!("{:?}", s.q_diag),
            "the Riccati recursion produced non-finite gains",
        ));
    }
    Ok(out)
}

impl Controller for Tvlqr {
    /// `u = clamp(u^d(t) - K(t) (x - x^d(t)))`; a measured state of the wrong length or with NaNs
    /// yields the planned torque (clamped).
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        self.law(t, t, x, tau);
        ControlInfo { iterations: 0 }
    }

    fn name(&self) -> &'static str {
        "tvlqr"
    }

    fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
        Tvlqr::set_reference(self, reference)
    }
}

impl Tvlqr {
    /// The control law with the feed-forward torque taken at `t_ff` and the feedback at `t`:
    /// `tau = clamp(u^d(t_ff) - K(t) (x - x^d(t)))` (`t_ff = t` is [`Controller::control`]; a rollout
    /// that holds the torque over a step takes the plan's torque at the step's midpoint). A state of
    /// the wrong length or with NaNs yields `u^d(t_ff)` (clamped). Does not allocate.
    pub fn law(&mut self, t: f64, t_ff: f64, x: &[f64], tau: &mut [f64]) {
        let tr = &mut self.tr;
        let n = tr.robot.n;
        let (nx, nu) = (2 * n, n - 1);
        let mut ud = [0.0; MAX_LINKS];
        tr.reference.tau_at(t_ff, &mut ud[..nu]);
        let valid = x.len() == nx && x.iter().all(|v| v.is_finite());
        if valid {
            tr.reference.state_at(t, &mut tr.xref);
            let pos = ((t - tr.reference.t[0]) / tr.settings.dt).clamp(0.0, self.stages as f64);
            let k0 = (pos.floor() as usize).min(self.stages);
            let k1 = (k0 + 1).min(self.stages);
            let r = pos - k0 as f64;
            let blk = nu * nx;
            let (g0, g1) = (
                &self.gains[k0 * blk..(k0 + 1) * blk],
                &self.gains[k1 * blk..(k1 + 1) * blk],
            );
            for i in 0..nu {
                let mut v = 0.0;
                for j in 0..nx {
                    let kij = g0[i * nx + j] + r * (g1[i * nx + j] - g0[i * nx + j]);
                    v += kij * (x[j] - tr.xref[j]);
                }
                ud[i] -= v;
            }
        }
        for (j, o) in tau.iter_mut().enumerate().take(nu) {
            *o = ud[j].clamp(tr.robot.tau_min[j], tr.robot.tau_max[j]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scalar time-invariant LQR over a long horizon converges to the closed-form solution of the
    /// discrete algebraic Riccati equation.
    #[test]
    fn scalar_riccati_matches_the_dare() {
        for &(a, b, q, r) in &[
            (1.1, 0.5, 2.0, 0.3),
            (0.9, 1.0, 1.0, 1.0),
            (1.5, 0.2, 0.1, 5.0),
        ] {
            let st = LqrStage {
                a: DMatrix::from_element(1, 1, a),
                b: DMatrix::from_element(1, 1, b),
                q: DMatrix::from_element(1, 1, q),
                r: DMatrix::from_element(1, 1, r),
            };
            let stages = vec![st; 400];
            let (k, s0) = riccati_gains(&stages, &DMatrix::zeros(1, 1)).unwrap();
            // b^2 S^2 + (r (1 - a^2) - q b^2) S - q r = 0.
            let (qa, qb, qc) = (b * b, r * (1.0 - a * a) - q * b * b, -q * r);
            let s = (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
            let kx = a * b * s / (r + b * b * s);
            assert!((s0[(0, 0)] - s).abs() < 1e-9 * s, "{} vs {s}", s0[(0, 0)]);
            assert!((k[0][(0, 0)] - kx).abs() < 1e-9 * kx.abs());
            // The last stage sees S_N = 0: K = 0.
            assert_eq!(k[399][(0, 0)], 0.0);
        }
    }

    #[test]
    fn settings_are_validated() {
        let bad = [
            TvlqrSettings {
                dt: 0.0,
                ..TvlqrSettings::default()
            },
            TvlqrSettings {
                r_diag: vec![0.0; 3],
                ..TvlqrSettings::default()
            },
            TvlqrSettings {
                q_diag: vec![1.0; 3],
                ..TvlqrSettings::default()
            },
            TvlqrSettings {
                terminal_s: f64::NAN,
                ..TvlqrSettings::default()
            },
        ];
        for s in bad {
            let e = s.validate(4).unwrap_err().to_string();
            assert!(e.contains("TvlqrSettings"), "{e}");
        }
        TvlqrSettings::default().validate(4).unwrap();
    }
}

#[cfg(test)]
mod stage_limit_tests {
    use super::*;

    #[test]
    fn the_stage_limit_shrinks_with_the_state_dimension_squared() {
        assert_eq!(max_tvlqr_stages(4), MAX_TVLQR_STAGES);
        assert_eq!(max_tvlqr_stages(2), MAX_TVLQR_STAGES);
        assert_eq!(max_tvlqr_stages(12), MAX_TVLQR_STAGES * 64 / 576);
        assert!(max_tvlqr_stages(MAX_LINKS) >= 1);
    }
}
