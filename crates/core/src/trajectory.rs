//! Time series of states and torques: the planner's output, the tracker's reference, the runner's log.
//!
//! Layout: sample k holds time `t[k]` (s), joint angles `q[k*n..(k+1)*n]` (rad; q1 absolute, the rest
//! relative), velocities `qd` (rad/s, same layout) and torques `tau[k*(n-1)..]` (N m, joints 2..n).
//! CSV files carry the header `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y` followed by any extra columns.

use crate::error::{Error, Result};
use crate::model::Robot;
use std::fmt::Write as _;

/// A sampled trajectory of an n-link robot.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trajectory {
    /// Number of links.
    pub n: usize,
    /// Sample times, s (strictly increasing).
    pub t: Vec<f64>,
    /// Joint angles, row-major `len x n`, rad.
    pub q: Vec<f64>,
    /// Joint velocities, row-major `len x n`, rad/s.
    pub qd: Vec<f64>,
    /// Torques of joints 2..n, row-major `len x (n-1)`, N m.
    pub tau: Vec<f64>,
}

impl Trajectory {
    /// An empty trajectory for n links.
    pub fn new(n: usize) -> Self {
        Trajectory {
            n,
            ..Default::default()
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Append one sample.
    pub fn push(&mut self, t: f64, q: &[f64], qd: &[f64], tau: &[f64]) {
        debug_assert_eq!(q.len(), self.n);
        self.t.push(t);
        self.q.extend_from_slice(q);
        self.qd.extend_from_slice(qd);
        self.tau.extend_from_slice(tau);
    }

    /// Joint angles of sample k.
    pub fn q(&self, k: usize) -> &[f64] {
        &self.q[k * self.n..(k + 1) * self.n]
    }

    /// Joint velocities of sample k.
    pub fn qd(&self, k: usize) -> &[f64] {
        &self.qd[k * self.n..(k + 1) * self.n]
    }

    /// Torques of sample k.
    pub fn tau(&self, k: usize) -> &[f64] {
        let m = self.n - 1;
        &self.tau[k * m..(k + 1) * m]
    }

    /// Final time, s.
    pub fn duration(&self) -> f64 {
        self.t.last().copied().unwrap_or(0.0) - self.t.first().copied().unwrap_or(0.0)
    }

    /// A copy with its sample times stretched by `factor` from the first (`t0 + factor (t - t0)`); the
    /// samples' values are kept as they are (a time axis to retime a path over).
    pub fn times_stretched(&self, factor: f64) -> Trajectory {
        let mut out = self.clone();
        let t0 = self.t.first().copied().unwrap_or(0.0);
        for t in out.t.iter_mut() {
            *t = t0 + factor * (*t - t0);
        }
        out
    }

    /// Cubic Hermite interpolation at time `t` (clamped to the ends): q with slopes qd, qd with slopes
    /// `qdd` (knot accelerations, row-major `len x n`), tau linearly. Writes `q`, `qd` (n) and `tau` (n-1).
    /// At a sample time it returns that sample exactly.
    pub fn hermite_at(&self, qdd: &[f64], t: f64, q: &mut [f64], qd: &mut [f64], tau: &mut [f64]) {
        let (n, m) = (self.n, self.n - 1);
        let last = self.len() - 1;
        let t = t.clamp(self.t[0], self.t[last]);
        let seg = (self.t.partition_point(|&s| s <= t).max(1) - 1).min(last.saturating_sub(1));
        let (ta, tb) = (self.t[seg], self.t[seg + 1]);
        let h = tb - ta;
        let r = ((t - ta) / h).clamp(0.0, 1.0);
        let (h00, h10, h01, h11) = hermite_basis(r);
        for i in 0..n {
            let (qa, qb) = (self.q[seg * n + i], self.q[(seg + 1) * n + i]);
            let (va, vb) = (self.qd[seg * n + i], self.qd[(seg + 1) * n + i]);
            let (aa, ab) = (qdd[seg * n + i], qdd[(seg + 1) * n + i]);
            q[i] = h00 * qa + h10 * h * va + h01 * qb + h11 * h * vb;
            qd[i] = h00 * va + h10 * h * aa + h01 * vb + h11 * h * ab;
        }
        for j in 0..m {
            let (ua, ub) = (self.tau[seg * m + j], self.tau[(seg + 1) * m + j]);
            tau[j] = ua + r * (ub - ua);
        }
    }

    /// Resample at a fixed period `dt` with [`Trajectory::hermite_at`] at [`sample_times`] from the
    /// first sample's time to the last's: the last sample is at the last time exactly (the last step
    /// the shorter one). The result agrees with this trajectory at its first and last samples.
    pub fn resample_hermite(&self, qdd: &[f64], dt: f64) -> Trajectory {
        let n = self.n;
        let mut out = Trajectory::new(n);
        let (mut q, mut qd, mut tau) = (vec![0.0; n], vec![0.0; n], vec![0.0; n - 1]);
        for t in sample_times(self.t[0], self.t[self.len() - 1], dt) {
            self.hermite_at(qdd, t, &mut q, &mut qd, &mut tau);
            out.push(t, &q, &qd, &tau);
        }
        out
    }

    /// Linear interpolation of the state at time `t` (clamped to the ends), written into `x = [q, qd]`.
    pub fn state_at(&self, t: f64, x: &mut [f64]) {
        let n = self.n;
        let (k, r) = self.locate(t);
        let k1 = (k + 1).min(self.len() - 1);
        for i in 0..n {
            x[i] = self.q[k * n + i] + r * (self.q[k1 * n + i] - self.q[k * n + i]);
            x[n + i] = self.qd[k * n + i] + r * (self.qd[k1 * n + i] - self.qd[k * n + i]);
        }
    }

    /// Planned torque at time `t` (linear interpolation, held past the ends), written into `out`
    /// (n - 1 values, N m). The one torque interpolation of the controllers and the runner.
    pub fn tau_at(&self, t: f64, out: &mut [f64]) {
        let nu = self.n - 1;
        let (k, r) = self.locate(t);
        let k1 = (k + 1).min(self.len() - 1);
        for j in 0..nu {
            let a = self.tau[k * nu + j];
            let b = self.tau[k1 * nu + j];
            out[j] = a + r * (b - a);
        }
    }

    /// Check that this trajectory can be tracked by `robot`: the same number of links, at least one
    /// sample, and the `q`, `qd`, `tau` arrays sized for `len` samples (its fields are public, so a
    /// hand-built value may be inconsistent). Every controller and the runner call this on their
    /// reference.
    pub fn check_reference(&self, robot: &Robot) -> Result<()> {
        if self.n != robot.n {
            return Err(Error::Dimension {
                what: "reference links".into(),
                expected: robot.n,
                got: self.n,
            });
        }
        if self.is_empty() {
            return Err(Error::invalid(
                "reference",
                "len",
                0,
                "the reference needs at least one sample",
            ));
        }
        let len = self.len();
        for (what, expected, got) in [
            ("reference q values", len * self.n, self.q.len()),
            ("reference qd values", len * self.n, self.qd.len()),
            ("reference tau values", len * (self.n - 1), self.tau.len()),
        ] {
            if got != expected {
                return Err(Error::Dimension {
                    what: what.into(),
                    expected,
                    got,
                });
            }
        }
        Ok(())
    }

    /// Segment index and fraction for time `t` (clamped).
    pub fn locate(&self, t: f64) -> (usize, f64) {
        let len = self.len();
        if t <= self.t[0] || len == 1 {
            return (0, 0.0);
        }
        if t >= self.t[len - 1] {
            return (len - 1, 0.0);
        }
        let k = self.t.partition_point(|&s| s <= t) - 1;
        (k, (t - self.t[k]) / (self.t[k + 1] - self.t[k]))
    }

    /// Energy spent by the actuated joints, paper eq. (18): `sum_i int qd_i tau_i dt` (signed work, J)
    /// and the positive work `sum_i int max(qd_i tau_i, 0) dt` (J), by the trapezoidal rule.
    pub fn work(&self) -> (f64, f64) {
        let (n, m) = (self.n, self.n - 1);
        let power = |k: usize| -> (f64, f64) {
            let mut s = 0.0;
            let mut p = 0.0;
            for j in 0..m {
                let w = self.qd[k * n + j + 1] * self.tau[k * m + j];
                s += w;
                p += w.max(0.0);
            }
            (s, p)
        };
        let (mut e, mut ep) = (0.0, 0.0);
        for k in 0..self.len().saturating_sub(1) {
            let h = self.t[k + 1] - self.t[k];
            let (a, ap) = power(k);
            let (b, bp) = power(k + 1);
            e += 0.5 * h * (a + b);
            ep += 0.5 * h * (ap + bp);
        }
        (e, ep)
    }

    /// CSV text: header `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y[,extra...]`, one row per sample.
    /// `extra` columns must have one value per sample.
    pub fn to_csv(&self, robot: &Robot, extra: &[(&str, &[f64])]) -> String {
        let n = self.n;
        let mut s = String::with_capacity(self.len() * 200);
        s.push('t');
        for i in 1..=n {
            let _ = write!(s, ",q{i}");
        }
        for i in 1..=n {
            let _ = write!(s, ",qd{i}");
        }
        for i in 2..=n {
            let _ = write!(s, ",tau{i}");
        }
        s.push_str(",ee_x,ee_y");
        for (name, _) in extra {
            let _ = write!(s, ",{name}");
        }
        s.push('\n');
        for k in 0..self.len() {
            let _ = write!(s, "{:.6}", self.t[k]);
            for v in self.q(k).iter().chain(self.qd(k)).chain(self.tau(k)) {
                let _ = write!(s, ",{v:.9}");
            }
            let ee = robot.ee_position(self.q(k));
            let _ = write!(s, ",{:.9},{:.9}", ee[0], ee[1]);
            for (_, col) in extra {
                let _ = write!(s, ",{:.9}", col[k]);
            }
            s.push('\n');
        }
        s
    }

    /// Parse CSV text written by [`Trajectory::to_csv`] (extra columns are ignored).
    pub fn from_csv(text: &str, n: usize, source_name: &str) -> Result<Self> {
        // a leading byte-order mark (a spreadsheet's UTF-8 export) is not part of the header
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text.lines();
        let header = lines.next().unwrap_or("");
        let cols: Vec<&str> = header.split(',').collect();
        let want = 1 + 2 * n + (n - 1);
        let expect_q1 = cols.get(1).copied() == Some("q1");
        if cols.first().copied() != Some("t") || cols.len() < want || !expect_q1 {
            return Err(Error::invalid(
                source_name,
                "header",
                header,
                format!("expected t,q1..q{n},qd1..qd{n},tau2..tau{n},..."),
            ));
        }
        let mut tr = Trajectory::new(n);
        for (li, line) in lines.enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let vals: std::result::Result<Vec<f64>, _> = line
                .split(',')
                .take(want)
                .map(|v| v.trim().parse::<f64>())
                .collect();
            let vals = vals.map_err(|e| {
                Error::invalid(source_name, format!("line {}", li + 2), line, e.to_string())
            })?;
            if vals.len() < want {
                return Err(Error::invalid(
                    source_name,
                    format!("line {}", li + 2),
                    line,
                    "too few columns",
                ));
            }
            tr.push(
                vals[0],
                &vals[1..1 + n],
                &vals[1 + n..1 + 2 * n],
                &vals[1 + 2 * n..want],
            );
        }
        Ok(tr)
    }
}

/// The sample times of a trajectory of period `dt` over `[t0, t1]`: `t0 + s dt` while that is
/// before `t1`, then `t1` itself, so the last step is the shorter one. A remainder below `1e-6 dt`
/// is merged into the step before it (which is then at most `1e-6 dt` longer than `dt`), so no step
/// is vanishingly short. At least two samples.
pub fn sample_times(t0: f64, t1: f64, dt: f64) -> Vec<f64> {
    let periods = ((t1 - t0) / dt - 1e-6).ceil().max(1.0) as usize;
    let mut t: Vec<f64> = (0..periods).map(|s| t0 + s as f64 * dt).collect();
    t.push(t1);
    t
}

/// Cubic Hermite basis functions at `r` in [0, 1].
pub fn hermite_basis(r: f64) -> (f64, f64, f64, f64) {
    let r2 = r * r;
    let r3 = r2 * r;
    (
        2.0 * r3 - 3.0 * r2 + 1.0,
        r3 - 2.0 * r2 + r,
        -2.0 * r3 + 3.0 * r2,
        r3 - r2,
    )
}

/// Derivatives of [`hermite_basis`] with respect to `r`.
pub fn hermite_basis_deriv(r: f64) -> (f64, f64, f64, f64) {
    let r2 = r * r;
    (
        6.0 * r2 - 6.0 * r,
        3.0 * r2 - 4.0 * r + 1.0,
        -6.0 * r2 + 6.0 * r,
        3.0 * r2 - 2.0 * r,
    )
}
