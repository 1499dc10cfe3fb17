//! The closed-loop runner: a controller drives a plant at a fixed control period; the runner (not the
//! controller) keeps the log.
//!
//! Conventions: state `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the rest relative),
//! torques `tau` of joints 2..n (N m), EE position `[x, y]` (m, grip frame, gravity along -y), time in s.
//! At step k (time `t_k = k control_dt`) the controller sees the measured state (true state plus
//! optional Gaussian sensor noise) and its torque, clamped to the robot's limits, is held over
//! `[t_k, t_k + control_dt)`.

use super::{Controller, Plant};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::trajectory::Trajectory;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::time::Instant;

/// Settings of a closed-loop run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunSettings {
    /// Simulated duration, s (rounded to a whole number of control periods). Default 1.5.
    pub duration_s: f64,
    /// Control period, s. Default 0.001 (1 kHz).
    pub control_dt: f64,
    /// Standard deviation of the Gaussian noise added to measured joint angles, rad. Default 0.
    pub noise_q_std: f64,
    /// Standard deviation of the Gaussian noise added to measured joint velocities, rad/s. Default 0.
    pub noise_qd_std: f64,
    /// Seed of the noise generator (ChaCha8). Default 0.
    pub seed: u64,
}

impl Default for RunSettings {
    fn default() -> Self {
        RunSettings {
            duration_s: 1.5,
            control_dt: 0.001,
            noise_q_std: 0.0,
            noise_qd_std: 0.0,
            seed: 0,
        }
    }
}

impl RunSettings {
    /// Check the values.
    pub fn validate(&self) -> Result<()> {
        let src = "RunSettings";
        if !(self.duration_s.is_finite() && self.duration_s > 0.0) {
            return Err(Error::invalid(
                src,
                "duration_s",
                self.duration_s,
                "must be > 0",
            ));
        }
        if !(self.control_dt.is_finite() && self.control_dt > 0.0) {
            return Err(Error::invalid(
                src,
                "control_dt",
                self.control_dt,
                "must be > 0",
            ));
        }
        for (name, v) in [
            ("noise_q_std", self.noise_q_std),
            ("noise_qd_std", self.noise_qd_std),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(src, name, v, "must be finite and >= 0"));
            }
        }
        let dmax = crate::limits::MAX_RUN_DURATION_S;
        if self.duration_s > dmax {
            return Err(Error::invalid(
                src,
                "duration_s",
                self.duration_s,
                format!(
                    "a closed loop may run at most {dmax} s (brachia::limits::MAX_RUN_DURATION_S)"
                ),
            ));
        }
        let smax = crate::limits::MAX_RUN_STEPS;
        if crate::limits::count(self.duration_s, self.control_dt, smax).is_none() {
            return Err(Error::invalid(
                src,
                "control_dt",
                self.control_dt,
                format!(
                    "{} s at this period would take more than {smax} control steps \
                     (brachia::limits::MAX_RUN_STEPS); control_dt must be >= {:.3e} s",
                    self.duration_s,
                    self.duration_s / smax as f64
                ),
            ));
        }
        Ok(())
    }
}

/// Everything recorded during a run. Row k is time `t[k]`; there are `steps + 1` rows (the last holds
/// the final state; its torque repeats the last applied one and its timing entries are zero).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ClosedLoopLog {
    /// Number of links.
    pub n: usize,
    /// Plant name.
    pub plant: String,
    /// Controller name.
    pub controller: String,
    /// Time, s.
    pub t: Vec<f64>,
    /// True plant state `[q, qd]`, row-major `rows x 2n`.
    pub x: Vec<f64>,
    /// Torque applied over `[t_k, t_k + dt)` after clamping, row-major `rows x (n-1)`, N m.
    pub tau: Vec<f64>,
    /// EE position, m.
    pub ee: Vec<[f64; 2]>,
    /// Reference state at `t[k]`, row-major `rows x 2n`.
    pub ref_x: Vec<f64>,
    /// Reference EE position, m.
    pub ref_ee: Vec<[f64; 2]>,
    /// Wall time of the controller call, microseconds.
    pub control_us: Vec<f64>,
    /// Iterations reported by the controller.
    pub iterations: Vec<usize>,
}

/// Scalar metrics of a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    /// EE distance to the reference EE at the final time, m.
    pub ee_final_error_m: f64,
    /// Largest EE distance to the reference over the run, m.
    pub ee_error_max_m: f64,
    /// RMS over all joints and samples of `q - q^d`, rad.
    pub joint_rms_error_rad: f64,
    /// Paper eq. 18: `sum_{i>=2} int qd_i tau_i dt`, J (exact for the held torques:
    /// `sum_k tau_k . (q_{k+1} - q_k)` over the actuated joints).
    pub energy_j: f64,
    /// Smallest applied torque, N m.
    pub tau_min: f64,
    /// Largest applied torque, N m.
    pub tau_max: f64,
    /// Median controller wall time, us.
    pub control_step_us_p50: f64,
    /// 99th percentile controller wall time, us.
    pub control_step_us_p99: f64,
    /// Largest controller wall time, us.
    pub control_step_us_max: f64,
    /// Mean controller iterations per step.
    pub qp_iterations_mean: f64,
}

impl ClosedLoopLog {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when nothing was logged.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// State of row k.
    pub fn x(&self, k: usize) -> &[f64] {
        &self.x[k * 2 * self.n..(k + 1) * 2 * self.n]
    }

    /// Reference state of row k.
    pub fn ref_x(&self, k: usize) -> &[f64] {
        &self.ref_x[k * 2 * self.n..(k + 1) * 2 * self.n]
    }

    /// Torque of row k.
    pub fn tau(&self, k: usize) -> &[f64] {
        &self.tau[k * (self.n - 1)..(k + 1) * (self.n - 1)]
    }

    /// The executed motion as a [`Trajectory`] (the plant's true `q`, `qd`, without sensor noise, and
    /// the applied `tau` of every row), e.g. for stick diagrams and animations.
    pub fn trajectory(&self) -> Trajectory {
        let n = self.n;
        let mut tr = Trajectory::new(n);
        for k in 0..self.len() {
            let x = self.x(k);
            tr.push(self.t[k], &x[..n], &x[n..], self.tau(k));
        }
        tr
    }

    /// Metrics of the run (all zero for an empty log).
    pub fn summary(&self) -> RunSummary {
        let rows = self.len();
        let mut s = RunSummary {
            ee_final_error_m: 0.0,
            ee_error_max_m: 0.0,
            joint_rms_error_rad: 0.0,
            energy_j: 0.0,
            tau_min: 0.0,
            tau_max: 0.0,
            control_step_us_p50: 0.0,
            control_step_us_p99: 0.0,
            control_step_us_max: 0.0,
            qp_iterations_mean: 0.0,
        };
        if rows == 0 {
            return s;
        }
        let n = self.n;
        let dist = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        s.ee_final_error_m = dist(self.ee[rows - 1], self.ref_ee[rows - 1]);
        let mut sq = 0.0;
        for k in 0..rows {
            s.ee_error_max_m = s.ee_error_max_m.max(dist(self.ee[k], self.ref_ee[k]));
            for i in 0..n {
                let d = self.x(k)[i] - self.ref_x(k)[i];
                sq += d * d;
            }
        }
        s.joint_rms_error_rad = (sq / (rows * n) as f64).sqrt();
        for k in 0..rows - 1 {
            for j in 0..n - 1 {
                s.energy_j += self.tau(k)[j] * (self.x(k + 1)[j + 1] - self.x(k)[j + 1]);
            }
        }
        s.tau_min = self.tau.iter().copied().fold(f64::INFINITY, f64::min);
        s.tau_max = self.tau.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let steps = rows - 1;
        if steps > 0 {
            let mut us: Vec<f64> = self.control_us[..steps].to_vec();
            us.sort_by(f64::total_cmp);
            let pct = |p: f64| us[((p * (steps - 1) as f64).round() as usize).min(steps - 1)];
            s.control_step_us_p50 = pct(0.5);
            s.control_step_us_p99 = pct(0.99);
            s.control_step_us_max = us[steps - 1];
            s.qp_iterations_mean =
                self.iterations[..steps].iter().sum::<usize>() as f64 / steps as f64;
        }
        s
    }

    /// The columns of [`ClosedLoopLog::to_csv`] for `n` links.
    fn csv_columns(n: usize) -> Vec<String> {
        let mut c = vec!["t".to_string()];
        c.extend((1..=n).map(|i| format!("q{i}")));
        c.extend((1..=n).map(|i| format!("qd{i}")));
        c.extend((2..=n).map(|i| format!("tau{i}")));
        c.extend(["ee_x".to_string(), "ee_y".to_string()]);
        c.extend((1..=n).map(|i| format!("ref_q{i}")));
        c.extend((1..=n).map(|i| format!("ref_qd{i}")));
        c.extend(["ref_ee_x".to_string(), "ref_ee_y".to_string()]);
        c
    }

    /// CSV text with header
    /// `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y,ref_q1..ref_qn,ref_qd1..ref_qdn,ref_ee_x,ref_ee_y`
    /// (SI units: s, rad, rad/s, N m, m).
    pub fn to_csv(&self) -> String {
        let n = self.n;
        let mut s = String::with_capacity(self.len() * 400);
        s.push_str(&Self::csv_columns(n).join(","));
        s.push('\n');
        for k in 0..self.len() {
            let _ = write!(s, "{:.6}", self.t[k]);
            for v in self.x(k).iter().chain(self.tau(k)) {
                let _ = write!(s, ",{v:.9}");
            }
            let _ = write!(s, ",{:.9},{:.9}", self.ee[k][0], self.ee[k][1]);
            for v in self.ref_x(k) {
                let _ = write!(s, ",{v:.9}");
            }
            let _ = writeln!(s, ",{:.9},{:.9}", self.ref_ee[k][0], self.ref_ee[k][1]);
        }
        s
    }

    /// Parse CSV text written by [`ClosedLoopLog::to_csv`]; `source_name` names it in errors. The header
    /// must be `to_csv`'s for some number of links n >= 2, every row has every column, every value is
    /// finite and times increase strictly; errors name the line, the column and the value. The CSV does
    /// not hold the plant and controller names, the controller's wall times or its iterations: they
    /// are left empty (`plant`, `controller`, `control_us`, `iterations`). The caller caps the text's
    /// size (`brachia::limits::read_text_capped`); nothing is allocated beyond what the text holds.
    pub fn from_csv(text: &str, source_name: &str) -> Result<Self> {
        let mut lines = text.lines();
        let header = lines.next().unwrap_or("");
        let cols: Vec<&str> = header.split(',').map(str::trim).collect();
        let n = cols
            .iter()
            .filter(|c| {
                c.strip_prefix('q')
                    .is_some_and(|r| r.parse::<usize>().is_ok())
            })
            .count();
        let want = Self::csv_columns(n);
        if n < 2 || cols != want {
            return Err(Error::invalid(
                source_name,
                "header",
                header.chars().take(160).collect::<String>(),
                "expected t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y,ref_q1..ref_qn,ref_qd1..ref_qdn,\
                 ref_ee_x,ref_ee_y (the header of a closed_loop.csv, n >= 2 links)",
            ));
        }
        let mut log = ClosedLoopLog {
            n,
            ..ClosedLoopLog::default()
        };
        let mut row = Vec::with_capacity(want.len());
        for (li, line) in lines.enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let at = |col: &str| format!("line {}, {col}", li + 2);
            row.clear();
            for (j, v) in line.split(',').enumerate() {
                let Some(name) = want.get(j) else {
                    return Err(Error::invalid(
                        source_name,
                        at("row"),
                        line.chars().take(160).collect::<String>(),
                        format!("too many columns (the header has {})", want.len()),
                    ));
                };
                let x: f64 = v
                    .trim()
                    .parse()
                    .map_err(|e| Error::invalid(source_name, at(name), v, format!("{e}")))?;
                if !x.is_finite() {
                    return Err(Error::invalid(
                        source_name,
                        at(name),
                        v,
                        "every value must be finite",
                    ));
                }
                row.push(x);
            }
            if row.len() < want.len() {
                return Err(Error::invalid(
                    source_name,
                    at(&want[row.len()]),
                    "missing",
                    format!("too few columns (the header has {})", want.len()),
                ));
            }
            if let Some(&prev) = log.t.last() {
                if row[0] <= prev {
                    return Err(Error::invalid(
                        source_name,
                        at("t"),
                        row[0],
                        format!("times must increase strictly (previous row: {prev})"),
                    ));
                }
            }
            let (ee, r) = (1 + 3 * n - 1, 3 + 3 * n - 1);
            log.t.push(row[0]);
            log.x.extend_from_slice(&row[1..1 + 2 * n]);
            log.tau.extend_from_slice(&row[1 + 2 * n..ee]);
            log.ee.push([row[ee], row[ee + 1]]);
            log.ref_x.extend_from_slice(&row[r..r + 2 * n]);
            log.ref_ee.push([row[r + 2 * n], row[r + 2 * n + 1]]);
        }
        Ok(log)
    }
}

/// A standard normal sample (Box-Muller).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.gen_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Run `ctrl` on `plant` for `settings.duration_s` at `settings.control_dt`, logging against
/// `reference` (sampled by linear interpolation at the control instants, held after its end).
/// The plant's current state and time are the start; times in the log are the plant's times.
pub fn run_closed_loop(
    plant: &mut dyn Plant,
    ctrl: &mut dyn Controller,
    reference: &Trajectory,
    robot: &Robot,
    settings: &RunSettings,
) -> Result<ClosedLoopLog> {
    settings.validate()?;
    let n = robot.n;
    for (what, got) in [
        ("plant links", plant.n_links()),
        ("reference links", reference.n),
    ] {
        if got != n {
            return Err(Error::Dimension {
                what: what.into(),
                expected: n,
                got,
            });
        }
    }
    if reference.is_empty() {
        return Err(Error::invalid(
            "reference",
            "len",
            0,
            "the reference needs at least one sample",
        ));
    }
    let (nx, nu) = (2 * n, n - 1);
    let steps = (settings.duration_s / settings.control_dt).round() as usize;
    let rows = steps + 1;
    let mut log = ClosedLoopLog {
        n,
        plant: plant.name().into(),
        controller: ctrl.name().into(),
        t: Vec::with_capacity(rows),
        x: Vec::with_capacity(rows * nx),
        tau: Vec::with_capacity(rows * nu),
        ee: Vec::with_capacity(rows),
        ref_x: Vec::with_capacity(rows * nx),
        ref_ee: Vec::with_capacity(rows),
        control_us: Vec::with_capacity(rows),
        iterations: Vec::with_capacity(rows),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let (mut x, mut xm, mut xr) = (vec![0.0; nx], vec![0.0; nx], vec![0.0; nx]);
    let mut tau = vec![0.0; nu];
    let noisy = settings.noise_q_std > 0.0 || settings.noise_qd_std > 0.0;
    for k in 0..rows {
        let t = plant.time();
        plant.state(&mut x);
        reference.state_at(t, &mut xr);
        log.t.push(t);
        log.x.extend_from_slice(&x);
        log.ee.push(robot.ee_position(&x[..n]));
        log.ref_x.extend_from_slice(&xr);
        log.ref_ee.push(robot.ee_position(&xr[..n]));
        if k == steps {
            log.tau.extend_from_slice(&tau);
            log.control_us.push(0.0);
            log.iterations.push(0);
            break;
        }
        xm.copy_from_slice(&x);
        if noisy {
            for i in 0..n {
                xm[i] += settings.noise_q_std * normal(&mut rng);
                xm[n + i] += settings.noise_qd_std * normal(&mut rng);
            }
        }
        let start = Instant::now();
        let info = ctrl.control(t, &xm, &mut tau);
        let us = start.elapsed().as_secs_f64() * 1e6;
        for j in 0..nu {
            tau[j] = tau[j].clamp(robot.tau_min[j], robot.tau_max[j]);
        }
        log.tau.extend_from_slice(&tau);
        log.control_us.push(us);
        log.iterations.push(info.iterations);
        plant.step(&tau, settings.control_dt);
    }
    Ok(log)
}
