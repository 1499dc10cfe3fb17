//! The closed loop: a controller drives a plant at a fixed control period; the loop (not the
//! controller) keeps the log. [`ClosedLoop::step`] runs one period; [`run_closed_loop`] runs to the end.
//!
//! Conventions: state `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the rest relative),
//! torques `tau` of joints 2..n (N m), EE position `[x, y]` (m, grip frame, gravity along -y), time in s.
//! At step k (time `t_k`, the plant's time) the controller sees the plant's measured state
//! ([`Plant::state`]; wrap the plant in [`super::Noisy`] for sensor noise), the log records the true
//! state ([`Plant::true_state`]), and the torque, clamped to the robot's limits, is held over
//! `[t_k, t_k + control_dt)`.

use super::{Controller, Plant};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::sync::Arc;
use std::time::Instant;

/// Settings of a closed-loop run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunSettings {
    /// Simulated duration, s (rounded to a whole number of control periods). Default 1.5.
    pub duration_s: f64,
    /// Control period, s. Default 0.001 (1 kHz).
    pub control_dt: f64,
    /// A cancel flag checked by [`ClosedLoop::run`] every [`CANCEL_CHECK_STEPS`] steps: once it is
    /// set the run stops there, its log ends early (the caller checks the token and discards it). Not
    /// part of a settings file (skipped by serde). Default `None`.
    #[serde(skip)]
    pub cancel: Option<crate::CancelToken>,
}

/// Control steps between two checks of [`RunSettings::cancel`] in [`ClosedLoop::run`] (0.064 s of
/// simulated time at 1 kHz, well under 0.2 s of wall time even for the slowest controller).
pub const CANCEL_CHECK_STEPS: usize = 64;

impl Default for RunSettings {
    fn default() -> Self {
        RunSettings {
            duration_s: 1.5,
            control_dt: 0.001,
            cancel: None,
        }
    }
}

impl RunSettings {
    /// Number of control steps: `duration_s / control_dt`, rounded (call after [`RunSettings::validate`]).
    pub fn steps(&self) -> usize {
        (self.duration_s / self.control_dt).round() as usize
    }

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
    /// Time at which the closed loop diverged, s: the plant's state left [`DIVERGENCE_BOUND`] (or
    /// became NaN or infinite), or the controller returned a non-finite torque. The run stopped there;
    /// the log holds the rows before it (every value finite). `None` for a run that did not diverge.
    pub diverged_at_s: Option<f64>,
}

/// A closed loop whose plant state has an entry beyond this bound (rad, rad/s; or NaN, or infinite) has
/// diverged: no swing turns a joint a million radians or spins it at a million rad/s. The run stops at
/// the first such state ([`ClosedLoopLog::diverged_at_s`]), so the log and its metrics stay finite.
pub const DIVERGENCE_BOUND: f64 = 1e6;

/// True when some entry of `v` is NaN, infinite or beyond [`DIVERGENCE_BOUND`].
fn diverged(v: &[f64]) -> bool {
    v.iter()
        .any(|x| !x.is_finite() || x.abs() > DIVERGENCE_BOUND)
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
    /// Time at which the closed loop diverged, s ([`ClosedLoopLog::diverged_at_s`]; the metrics above
    /// cover the rows before it); absent when it did not. A diverged run's results are not to be trusted.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub diverged_at_s: Option<f64>,
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
            diverged_at_s: self.diverged_at_s,
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
        c.push("control_us".to_string());
        c
    }

    /// CSV text with header
    /// `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y,ref_q1..ref_qn,ref_qd1..ref_qdn,ref_ee_x,ref_ee_y,control_us`
    /// (SI units: s, rad, rad/s, N m, m; the controller's wall time of the step in microseconds, 0 in
    /// the last row and where it was not measured).
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
            let us = self.control_us.get(k).copied().unwrap_or(0.0);
            let _ = writeln!(
                s,
                ",{:.9},{:.9},{us:.3}",
                self.ref_ee[k][0], self.ref_ee[k][1]
            );
        }
        s
    }

    /// Parse CSV text written by [`ClosedLoopLog::to_csv`]; `source_name` names it in errors. The header
    /// must be `to_csv`'s for some number of links n >= 2 (or the same without `control_us`, as
    /// written before the step times were recorded), every row has every column, every value is
    /// finite and times increase strictly; errors name the line, the column and the value. The CSV does
    /// not hold the plant and controller names or the controller's iterations: they are left empty
    /// (`plant`, `controller`, `iterations`; `control_us` too for a file without that column). The caller caps the text's
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
        let mut want = Self::csv_columns(n);
        if cols.len() + 1 == want.len() {
            want.pop();
        }
        let timed = want.last().is_some_and(|c| c == "control_us");
        if n < 2 || cols != want {
            return Err(Error::invalid(
                source_name,
                "header",
                header.chars().take(160).collect::<String>(),
                "expected t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y,ref_q1..ref_qn,ref_qd1..ref_qdn,\
                 ref_ee_x,ref_ee_y,control_us (the header of a closed_loop.csv, n >= 2 links; \
                 control_us may be absent)",
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
            if timed {
                log.control_us.push(row[r + 2 * n + 2]);
            }
        }
        Ok(log)
    }
}

/// Diagnostics of one [`ClosedLoop::step`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepInfo {
    /// Time at the start of the step (the plant's), s.
    pub t: f64,
    /// Iterations reported by the controller.
    pub iterations: usize,
    /// Wall time of the controller call, microseconds.
    pub control_us: f64,
}

/// A controller driving a plant one control period at a time, logging every period.
///
/// Built with the run's settings (duration and control period); the log's memory is reserved at
/// construction, so a step allocates nothing beyond what the plant and controller do. Between steps
/// the caller may inspect or change the plant and the controller ([`ClosedLoop::plant_mut`],
/// [`ClosedLoop::controller_mut`]) or swap the plan ([`ClosedLoop::set_reference`]).
/// [`ClosedLoop::finish`] appends the final state and returns the log.
#[derive(Debug)]
pub struct ClosedLoop<P, C> {
    plant: P,
    controller: C,
    robot: Arc<Robot>,
    reference: Arc<Trajectory>,
    control_dt: f64,
    steps: usize,
    done: usize,
    log: ClosedLoopLog,
    x: Vec<f64>,
    xm: Vec<f64>,
    xr: Vec<f64>,
    tau: Vec<f64>,
    cancel: Option<crate::CancelToken>,
}

impl<P: Plant, C: Controller> ClosedLoop<P, C> {
    /// A loop of `controller` on `plant` for `settings.duration_s` at `settings.control_dt`, logging
    /// against `reference` (sampled by linear interpolation at the control instants, held after its
    /// end). The plant's current state and time are the start; times in the log are the plant's.
    /// `robot` (the controller's model: torque limits, EE positions of the log) and `reference` may
    /// be owned values or shared `Arc`s. A start state that is not finite, or has an entry beyond
    /// [`DIVERGENCE_BOUND`], is refused.
    pub fn new(
        plant: P,
        controller: C,
        robot: impl Into<Arc<Robot>>,
        reference: impl Into<Arc<Trajectory>>,
        settings: &RunSettings,
    ) -> Result<Self> {
        settings.validate()?;
        let (robot, reference): (Arc<Robot>, Arc<Trajectory>) = (robot.into(), reference.into());
        let n = robot.n;
        if plant.n_links() != n {
            return Err(Error::Dimension {
                what: "plant links".into(),
                expected: n,
                got: plant.n_links(),
            });
        }
        reference.check_reference(&robot)?;
        let (nx, nu) = (2 * n, n - 1);
        let mut x = vec![0.0; nx];
        plant.true_state(&mut x);
        if diverged(&x) {
            return Err(Error::invalid(
                "closed loop",
                "start state",
                format!("{x:?}"),
                format!("must be finite, every entry within {DIVERGENCE_BOUND:e} rad or rad/s"),
            ));
        }
        let steps = settings.steps();
        let rows = steps + 1;
        let log = ClosedLoopLog {
            n,
            plant: plant.name().into(),
            controller: controller.name().into(),
            t: Vec::with_capacity(rows),
            x: Vec::with_capacity(rows * nx),
            tau: Vec::with_capacity(rows * nu),
            ee: Vec::with_capacity(rows),
            ref_x: Vec::with_capacity(rows * nx),
            ref_ee: Vec::with_capacity(rows),
            control_us: Vec::with_capacity(rows),
            iterations: Vec::with_capacity(rows),
            diverged_at_s: None,
        };
        Ok(ClosedLoop {
            plant,
            controller,
            robot,
            reference,
            control_dt: settings.control_dt,
            steps,
            done: 0,
            log,
            x,
            xm: vec![0.0; nx],
            xr: vec![0.0; nx],
            tau: vec![0.0; nu],
            cancel: settings.cancel.clone(),
        })
    }

    /// Log the plant's true state and the reference at the plant's time into a new row; `None` (and
    /// nothing logged, the divergence recorded) when that state has diverged.
    fn log_state(&mut self) -> Option<f64> {
        let n = self.robot.n;
        let t = self.plant.time();
        self.plant.true_state(&mut self.x);
        if diverged(&self.x) {
            self.log.diverged_at_s = Some(t);
            return None;
        }
        self.reference.state_at(t, &mut self.xr);
        let log = &mut self.log;
        log.t.push(t);
        log.x.extend_from_slice(&self.x);
        log.ee.push(self.robot.ee_position(&self.x[..n]));
        log.ref_x.extend_from_slice(&self.xr);
        log.ref_ee.push(self.robot.ee_position(&self.xr[..n]));
        Some(t)
    }

    /// One control period: measure, control, clamp to the robot's torque limits, advance the plant,
    /// log. `None` (nothing done) once the run's duration is reached, or once the loop diverged: the
    /// plant's state left [`DIVERGENCE_BOUND`] (that state is not logged) or the controller returned a
    /// non-finite torque (not applied: that row logs zero torque); the time is recorded in
    /// [`ClosedLoopLog::diverged_at_s`] ([`ClosedLoop::diverged_at`]). The log of a diverged loop has at
    /// least one row: a start state beyond the bound is refused by [`ClosedLoop::new`].
    pub fn step(&mut self) -> Option<StepInfo> {
        if self.is_done() {
            return None;
        }
        let t = self.log_state()?;
        self.plant.state(&mut self.xm);
        let start = Instant::now();
        let info = self.controller.control(t, &self.xm, &mut self.tau);
        let us = start.elapsed().as_secs_f64() * 1e6;
        // a non-finite torque is not applied: the row keeps its (finite) state with zero torque (inside
        // the limits, which bracket 0), and the run stops
        let bad = self.tau.iter().any(|v| !v.is_finite());
        for (j, v) in self.tau.iter_mut().enumerate() {
            *v = if bad {
                0.0
            } else {
                v.clamp(self.robot.tau_min[j], self.robot.tau_max[j])
            };
        }
        self.log.tau.extend_from_slice(&self.tau);
        self.log.control_us.push(us);
        self.log.iterations.push(info.iterations);
        if bad {
            self.log.diverged_at_s = Some(t);
            return None;
        }
        self.plant.step(&self.tau, self.control_dt);
        self.done += 1;
        Some(StepInfo {
            t,
            iterations: info.iterations,
            control_us: us,
        })
    }

    /// Step until the run's duration is reached (or [`RunSettings::cancel`] is set: checked every
    /// [`CANCEL_CHECK_STEPS`] steps).
    pub fn run(&mut self) {
        loop {
            if self.done.is_multiple_of(CANCEL_CHECK_STEPS)
                && self.cancel.as_ref().is_some_and(|c| c.is_cancelled())
            {
                return;
            }
            if self.step().is_none() {
                return;
            }
        }
    }

    /// True once the run's duration is reached or the loop diverged.
    pub fn is_done(&self) -> bool {
        self.done >= self.steps || self.log.diverged_at_s.is_some()
    }

    /// The time at which the loop diverged ([`ClosedLoopLog::diverged_at_s`]), if it did.
    pub fn diverged_at(&self) -> Option<f64> {
        self.log.diverged_at_s
    }

    /// Steps taken so far.
    pub fn steps_done(&self) -> usize {
        self.done
    }

    /// Steps of the whole run (`duration_s / control_dt`, rounded).
    pub fn steps_total(&self) -> usize {
        self.steps
    }

    /// The torque applied over the last step (zeros before the first), N m.
    pub fn last_tau(&self) -> &[f64] {
        &self.tau
    }

    /// The log so far: one row per step taken (the final state is appended by
    /// [`ClosedLoop::finish`]).
    pub fn log(&self) -> &ClosedLoopLog {
        &self.log
    }

    /// Log against another plan from the next step on and hand it to the controller
    /// ([`Controller::set_reference`]); checked first, and on error neither is changed.
    pub fn set_reference(&mut self, reference: impl Into<Arc<Trajectory>>) -> Result<()> {
        let reference = reference.into();
        reference.check_reference(&self.robot)?;
        self.controller.set_reference(Arc::clone(&reference))?;
        self.reference = reference;
        Ok(())
    }

    /// The plant.
    pub fn plant(&self) -> &P {
        &self.plant
    }

    /// The plant, mutable (e.g. to push it between steps).
    pub fn plant_mut(&mut self) -> &mut P {
        &mut self.plant
    }

    /// The controller.
    pub fn controller(&self) -> &C {
        &self.controller
    }

    /// The controller, mutable.
    pub fn controller_mut(&mut self) -> &mut C {
        &mut self.controller
    }

    /// Append the final state (its torque repeats the last applied one, its timing entries are zero)
    /// and return the log, the plant and the controller.
    /// A diverged loop appends nothing: its log ends with the last finite row.
    pub fn into_parts(mut self) -> (P, C, ClosedLoopLog) {
        if self.log.diverged_at_s.is_none() && self.log_state().is_some() {
            self.log.tau.extend_from_slice(&self.tau);
            self.log.control_us.push(0.0);
            self.log.iterations.push(0);
        }
        (self.plant, self.controller, self.log)
    }

    /// Append the final state (see [`ClosedLoop::into_parts`]) and return the log.
    pub fn finish(self) -> ClosedLoopLog {
        self.into_parts().2
    }
}

/// Run `ctrl` on `plant` for `settings.duration_s` at `settings.control_dt`, logging against
/// `reference`: [`ClosedLoop`] stepped to the end. The plant's current state and time are the start;
/// times in the log are the plant's times.
pub fn run_closed_loop(
    plant: &mut dyn Plant,
    ctrl: &mut dyn Controller,
    reference: &Trajectory,
    robot: &Robot,
    settings: &RunSettings,
) -> Result<ClosedLoopLog> {
    let mut cl = ClosedLoop::new(plant, ctrl, robot.clone(), reference.clone(), settings)?;
    cl.run();
    Ok(cl.finish())
}
