//! The robustness benchmark (`brachia benchmark`): one plan of a scenario, tracked by every controller
//! of [`controllers`] under every disturbance of [`sweeps`] at RealAIGym-style levels, plus a Monte
//! Carlo mix on the rapier plant; scored and written into a run folder.
//!
//! - **Sweeps**: each disturbance at `levels` evenly spaced levels from 0 (the scenario as written) to
//!   its maximum (21 levels in the full run, 3 with `quick`), on the scenario's plant, added to the
//!   scenario's own `[disturbances]` (and its `[tracking]` sensor noise; see [`sweeps`]).
//! - **Monte Carlo families** ([`crate::families`]): the original mix `monte_carlo` (each link's
//!   mass x U(0.85, 1.15), sigma_q = 0.002 rad, a free 0.05-0.5 kg ball on the planned EE path; 200
//!   runs in the full run, 6 with `quick`) and families of one kind of trouble each (coherent and
//!   per-link mass, geometry, a ball anywhere, delays and noise, a push, all mixed; 50 runs each, 1
//!   with `quick`), on the rapier plant, each draw combined with the scenario's disturbances
//!   ([`with_scenario`]).
//! - **Success** ([`crate::success`]): the run captures the bar: the plant's EE (its own, possibly
//!   mismatched, geometry) within 2 cm of the bar and no faster than 0.5 m/s, at any time of the
//!   run; the run is scored (error, energy, torques) up to its capture.
//! - **Seeds**: run i of a sweep or of the Monte Carlo draws from ChaCha8 seeded by a fixed function of
//!   (disturbance, level) or of i, the same for every controller; results do not depend on `jobs`.
//!
//! Files: `runs.csv` (one row per run: scores, the Monte Carlo ball, the plant's contacts, the re-plans
//! with their trigger times and predicted misses; [`Benchmark::runs_csv`]), `scorecard.json`,
//! `summary.md`, `success_<disturbance>.png/.svg`, `success_by_family.png/.svg` (success per Monte
//! Carlo family and controller, with the run count).
//! Units: s, m, rad, rad/s, N m, N s, J, kg. See docs/robustness.md.

use crate::plan_run::run_plan;
use crate::progress::{CancelToken, Progress, ProgressFn};
use crate::run_folder::{install, stage_for, RunFolder};
use crate::scenario::{LoadedScenario, PlantKind};
use crate::ExpError;
use brachia::sim::{
    run_closed_loop, ClosedLoopLog, Controller, Disturbances, ModelPlant, RunSettings,
};
use brachia::trajectory::Trajectory;
use brachia::{Error, Robot};
use brachia_rapier::{Circle, ContactEvent, Obstacle, RapierPlant};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

mod controllers;
mod extra;
mod family_figure;
mod per_draw;
mod sweeps;
pub use controllers::{
    controllers, replan_settings, BenchController, ControllerEntry, REPLAN_LATENCY_S,
};
use extra::Entry;
pub use extra::{BuildExtra, ExtraController};
pub use family_figure::FAMILY_FIGURE;
pub use per_draw::{per_draw, per_draw_md, PerDraw, PER_DRAW_NOISE_M};
pub use sweeps::{sweeps, ApplyLevel, Rule, Sweep, SweepContext};

/// The success radius: the hand within this distance of the bar (and slow) captures it, m (the
/// one definition, [`crate::success`]).
pub use crate::success::SUCCESS_RADIUS_M;

/// Most sweep levels per disturbance.
pub const MAX_LEVELS: usize = 101;

/// Most Monte Carlo runs.
pub const MAX_MONTE_CARLO_RUNS: usize = 10_000;

/// Settings of a benchmark run.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchmarkSettings {
    /// Levels per disturbance (>= 2; 21 full, 3 quick).
    pub levels: usize,
    /// Monte Carlo runs of the original family `monte_carlo` (0 skips it; 200 full, 6 quick).
    pub monte_carlo_runs: usize,
    /// Runs of each other Monte Carlo family ([`crate::families::families`]; 0 skips them; 50
    /// full, 1 quick).
    pub family_runs: usize,
    /// Run the sweeps (false: only the Monte Carlo). Default true.
    pub run_sweeps: bool,
    /// Worker threads (None: rayon's default, all cores).
    pub jobs: Option<usize>,
    /// Only these sweeps (names of [`sweeps`]); empty: all.
    pub only_sweeps: Vec<String>,
    /// Only these controllers (names of [`controllers`]); empty: all.
    pub only_controllers: Vec<String>,
    /// Base seed of the Monte Carlo draws and the sweeps' noise.
    pub seed: u64,
    /// A cancel flag, checked before every run and by the plan's solves at every iteration: once it
    /// is set, no further run starts and the benchmark ends as [`BenchmarkOutcome::Cancelled`].
    /// Default `None`.
    pub cancel: Option<CancelToken>,
}

impl BenchmarkSettings {
    /// The full benchmark: 21 levels, 200 Monte Carlo runs.
    pub fn full() -> Self {
        BenchmarkSettings {
            levels: 21,
            monte_carlo_runs: 200,
            family_runs: 50,
            run_sweeps: true,
            jobs: None,
            only_sweeps: Vec::new(),
            only_controllers: Vec::new(),
            seed: 0,
            cancel: None,
        }
    }

    /// The quick benchmark (CI): 3 levels, 6 Monte Carlo runs.
    pub fn quick() -> Self {
        BenchmarkSettings {
            levels: 3,
            monte_carlo_runs: 6,
            family_runs: 1,
            ..Self::full()
        }
    }

    /// Check the values (counts bounded, names known).
    pub fn validate(&self) -> Result<(), Error> {
        let src = "benchmark settings";
        if !(2..=MAX_LEVELS).contains(&self.levels) {
            return Err(Error::invalid(
                src,
                "levels",
                self.levels,
                format!("must be 2..={MAX_LEVELS}"),
            ));
        }
        for (field, v) in [
            ("monte_carlo_runs", self.monte_carlo_runs),
            ("family_runs", self.family_runs),
        ] {
            if v > MAX_MONTE_CARLO_RUNS {
                return Err(Error::invalid(
                    src,
                    field,
                    v,
                    format!("must be at most {MAX_MONTE_CARLO_RUNS}"),
                ));
            }
        }
        if let Some(j) = self.jobs {
            if !(1..=1024).contains(&j) {
                return Err(Error::invalid(src, "jobs", j, "must be 1..=1024"));
            }
        }
        if !self.run_sweeps && self.monte_carlo_runs == 0 && self.family_runs == 0 {
            return Err(Error::invalid(
                src,
                "monte_carlo_runs",
                0,
                "with no sweeps and no family runs the benchmark would run nothing (give at least 1)",
            ));
        }
        for (field, names) in [
            ("sweep", &self.only_sweeps),
            ("controller", &self.only_controllers),
        ] {
            if let Some((_, n)) = names
                .iter()
                .enumerate()
                .find(|(k, n)| names[..*k].contains(n))
            {
                return Err(Error::invalid(
                    src,
                    field,
                    n,
                    "given twice: each is run once, so name it once",
                ));
            }
        }
        let sw: Vec<&str> = sweeps().iter().map(|s| s.name).collect();
        if let Some(s) = self.only_sweeps.iter().find(|s| !sw.contains(&s.as_str())) {
            return Err(Error::invalid(
                src,
                "sweep",
                s,
                format!("unknown; the sweeps are {}", sw.join(", ")),
            ));
        }
        let cs: Vec<&str> = controllers().iter().map(|c| c.name).collect();
        if let Some(c) = self
            .only_controllers
            .iter()
            .find(|c| !cs.contains(&c.as_str()))
        {
            return Err(Error::invalid(
                src,
                "controller",
                c,
                format!("unknown; the controllers are {}", cs.join(", ")),
            ));
        }
        Ok(())
    }
}

/// One run of the benchmark (a row of `runs.csv`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BenchRow {
    /// Controller name.
    pub controller: String,
    /// Disturbance (a sweep's name, or `monte_carlo`).
    pub disturbance: String,
    /// Level in the sweep's unit (the Monte Carlo run index for `monte_carlo`).
    pub level: f64,
    /// Seed of the run's random draws.
    pub seed: u64,
    /// The run captured the bar ([`crate::success`]: the plant's hand within
    /// [`SUCCESS_RADIUS_M`] of the bar and no faster than [`crate::CAPTURE_SPEED_M_S`], at any
    /// time of the run).
    pub success: bool,
    /// Time of the capture, s from the run's start (`None`, an empty CSV field: a miss).
    #[serde(default)]
    pub capture_t_s: Option<f64>,
    /// The hand's distance to the bar at the capture, or (a miss) at the end of the swing, m.
    pub final_error_m: f64,
    /// Paper eq. (18) of the applied (commanded) torques up to the capture (a miss: the whole
    /// run), J.
    pub energy_j: f64,
    /// Largest |commanded torque| up to the capture, N m.
    pub peak_torque_nm: f64,
    /// RMS of the step-to-step change of the commanded torque up to the capture, N m.
    pub smoothness_nm: f64,
    /// Mass of the Monte Carlo ball, kg (0: no ball).
    pub ball_kg: f64,
    /// Time at which the planned EE passes the ball's centre, s (`None`, an empty CSV field: no ball).
    pub ball_t_s: Option<f64>,
    /// Time of the plant's first contact, s (`None`: none, or not the rapier plant).
    pub contact_s: Option<f64>,
    /// Re-plans triggered (0 for controllers without re-planning).
    pub replans: usize,
    /// Re-plans adopted (converged, within 1 mm of the bar, switched to).
    pub replans_adopted: usize,
    /// Modelled trigger-to-switch latency of the re-plans, s (0 without re-plans).
    pub replan_latency_s: f64,
    /// Interior-point iterations of all re-plans (a load-independent measure of their cost).
    pub replan_iterations: usize,
    /// Time of the plant's last contact, s (`None`: none, or not the rapier plant).
    pub contact_last_s: Option<f64>,
    /// Total normal contact impulse on the robot over the run, N s (0: none, or not the rapier plant).
    pub contact_impulse_n_s: f64,
    /// Trigger time of each re-plan, s, in order.
    pub replan_t_s: Vec<f64>,
    /// The predicted capture miss that triggered each re-plan, m, in order.
    pub replan_miss_m: Vec<f64>,
}

/// Scores of one controller on one disturbance (or overall).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// Runs scored.
    pub runs: usize,
    /// Runs that succeeded, %.
    pub success_pct: f64,
    /// Mean energy, J.
    pub energy_j: f64,
    /// Largest peak torque, N m.
    pub peak_torque_nm: f64,
    /// Mean smoothness, N m.
    pub smoothness_nm: f64,
    /// Mean final error, m.
    pub final_error_m: f64,
    /// Mean re-plans per run.
    pub replans_per_run: f64,
}

/// One controller's scorecard.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ControllerScore {
    /// Controller name.
    pub controller: String,
    /// Per disturbance (sweeps, then `monte_carlo`).
    pub per_disturbance: Vec<(String, Score)>,
    /// Over every run.
    pub overall: Score,
    /// RealAIGym-style robustness score: the mean over the sweeps of the fraction of levels that
    /// succeeded, in [0, 1].
    pub robustness_score: f64,
}

/// The benchmark's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Benchmark {
    /// Scenario name.
    pub scenario: String,
    /// Levels per disturbance.
    pub levels: usize,
    /// Monte Carlo runs.
    pub monte_carlo_runs: usize,
    /// The success rule, m.
    pub success_radius_m: f64,
    /// The sweeps: name, level meaning, levels.
    pub sweeps: Vec<(String, String, Vec<f64>)>,
    /// Every run, in a fixed order (sweeps by controller, disturbance, level; then the Monte Carlo).
    pub rows: Vec<BenchRow>,
    /// Per controller.
    pub scores: Vec<ControllerScore>,
    /// Wall time of the simulations, s.
    pub wall_time_s: f64,
}

/// One job: which controller, which disturbances, on which plant, with which balls.
struct Job {
    controller: usize,
    disturbance: String,
    level: f64,
    seed: u64,
    dist: Disturbances,
    plant: PlantKind,
    balls: Vec<Obstacle>,
    /// Planned time at the ball.
    ball_t_s: Option<f64>,
    probot: Robot,
}

/// SplitMix64 of `x`: decorrelated seeds from small integers.
fn mix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A Monte Carlo draw combined with the scenario's `[disturbances]` `base`: the per-link mass factors
/// multiply the scenario's, the draw's sensor noise adds to the scenario's, everything else of the
/// scenario (friction, delays, lag, torque noise and limit, start offset, pushes, other factors) is
/// kept; the noise seed is the draw's.
pub fn with_scenario(base: &Disturbances, draw: &Disturbances) -> Disturbances {
    let mut d = base.clone();
    let n = draw.mass_scale.len().max(base.mass_scale.len());
    d.mass_scale = (0..n)
        .map(|i| {
            base.mass_scale.get(i).copied().unwrap_or(1.0)
                * draw.mass_scale.get(i).copied().unwrap_or(1.0)
        })
        .collect();
    d.noise_q_std += draw.noise_q_std;
    d.noise_qd_std += draw.noise_qd_std;
    d.seed = draw.seed;
    d
}

/// The closed loop of `ctrl` along `reference` (its first state moved by `dist`'s start offset, for
/// its duration, at the scenario's control period) on the plant `probot` of kind `plant` wrapped in
/// `dist`'s disturbances: the model plant with the scenario's sub-steps, or the rapier plant with
/// the scenario's settings, the task's obstacles, the scenario's plant obstacles and `extra`. The
/// log and the rapier plant's contacts (none on the model plant).
pub fn simulate(
    ls: &LoadedScenario,
    reference: &Arc<Trajectory>,
    probot: &Robot,
    plant: PlantKind,
    dist: &Disturbances,
    extra: &[Obstacle],
    ctrl: &mut dyn Controller,
) -> Result<(ClosedLoopLog, Vec<ContactEvent>), Error> {
    let sc = &ls.scenario;
    let dt = sc.tracking.control_dt;
    let x0 = dist.start_state(&[reference.q(0), reference.qd(0)].concat());
    let settings = RunSettings {
        duration_s: reference.duration(),
        control_dt: dt,
        cancel: sc.solver.cancel.clone(),
    };
    Ok(match plant {
        PlantKind::Model => {
            let mut p = ModelPlant::new(probot.clone(), &x0);
            p.substeps = sc.plant.substeps;
            let mut w = dist.wrap(Box::new(&mut p), dt)?;
            let log = run_closed_loop(w.as_mut(), ctrl, reference, &ls.robot, &settings)?;
            (log, Vec::new())
        }
        PlantKind::Rapier => {
            let mut p = RapierPlant::new(probot, &x0, &sc.plant.rapier())?;
            for c in &sc.task.obstacles {
                p.add_obstacle(&Obstacle::Circle(Circle {
                    center: c.center,
                    radius: c.radius,
                }))?;
            }
            for o in sc.plant.obstacles.iter().chain(extra) {
                p.add_obstacle(o)?;
            }
            let log = {
                let mut w = dist.wrap(Box::new(&mut p), dt)?;
                run_closed_loop(w.as_mut(), ctrl, reference, &ls.robot, &settings)?
            };
            (log, p.contacts().to_vec())
        }
    })
}

/// Run one job: plant, wrappers, controller, closed loop, scores.
fn run_job(
    ls: &LoadedScenario,
    reference: &Arc<Trajectory>,
    entry: &Entry<'_>,
    job: &Job,
) -> Result<BenchRow, Error> {
    let sc = &ls.scenario;
    let mut built = entry.build(ls, reference)?;
    let (log, contacts) = simulate(
        ls,
        reference,
        &job.probot,
        job.plant,
        &job.dist,
        &job.balls,
        built.controller(),
    )?;
    let replans = built.replans();
    let n = ls.robot.n();
    let caught = crate::success::capture(&job.probot, &log, reference.duration(), sc.task.target);
    // the gripper closes at the capture: the run is scored up to it
    let log = crate::success::judged_log(&log, &caught);
    let last = log.len() - 1;
    let err = caught.bar_error_m;
    let s = log.summary();
    let nu = n - 1;
    let mut sq = 0.0;
    for k in 1..last {
        for j in 0..nu {
            let d = log.tau(k)[j] - log.tau(k - 1)[j];
            sq += d * d;
        }
    }
    let smooth = if last > 1 {
        (sq / ((last - 1) * nu) as f64).sqrt()
    } else {
        0.0
    };
    Ok(BenchRow {
        controller: entry.name().to_string(),
        disturbance: job.disturbance.clone(),
        level: job.level,
        seed: job.seed,
        success: caught.reaches_bar,
        capture_t_s: caught.capture_t_s,
        final_error_m: err,
        energy_j: s.energy_j,
        peak_torque_nm: s.tau_min.abs().max(s.tau_max.abs()),
        smoothness_nm: smooth,
        ball_kg: job.balls.iter().map(ball_mass).sum(),
        ball_t_s: job.ball_t_s,
        contact_s: contacts.first().map(|c| c.t),
        contact_last_s: contacts.last().map(|c| c.t),
        contact_impulse_n_s: contacts.iter().map(|c| c.impulse).sum(),
        replan_t_s: replans.iter().map(|e| e.t_trigger_s).collect(),
        replan_miss_m: replans.iter().map(|e| e.predicted_miss_m).collect(),
        replans: replans.len(),
        replans_adopted: replans.iter().filter(|e| e.t_switch_s.is_some()).count(),
        replan_latency_s: replans.iter().map(|e| e.latency_s).fold(0.0, f64::max),
        replan_iterations: replans.iter().map(|e| e.iterations).sum(),
    })
}

/// A CSV field: the value to 1 us, or empty.
fn opt(v: Option<f64>) -> String {
    v.map(|v| format!("{v:.6}")).unwrap_or_default()
}

/// A CSV field of several values: each to 1 us, separated by `;` (empty: none).
fn list(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:.6}"))
        .collect::<Vec<_>>()
        .join(";")
}

fn ball_mass(o: &Obstacle) -> f64 {
    match o {
        Obstacle::Ball(b) => b.mass,
        _ => 0.0,
    }
}

/// Levels `0, max / (levels - 1), ..., max`.
pub fn levels(max: f64, levels: usize) -> Vec<f64> {
    (0..levels)
        .map(|i| max * i as f64 / (levels - 1) as f64)
        .collect()
}

fn score(rows: &[&BenchRow]) -> Score {
    let m = rows.len().max(1) as f64;
    Score {
        runs: rows.len(),
        success_pct: 100.0 * rows.iter().filter(|r| r.success).count() as f64 / m,
        energy_j: rows.iter().map(|r| r.energy_j).sum::<f64>() / m,
        peak_torque_nm: rows.iter().map(|r| r.peak_torque_nm).fold(0.0, f64::max),
        smoothness_nm: rows.iter().map(|r| r.smoothness_nm).sum::<f64>() / m,
        final_error_m: rows.iter().map(|r| r.final_error_m).sum::<f64>() / m,
        replans_per_run: rows.iter().map(|r| r.replans as f64).sum::<f64>() / m,
    }
}

/// What [`run_benchmark`] did.
#[derive(Debug, Clone)]
pub enum BenchmarkOutcome {
    /// The benchmark ran.
    Done(Box<Benchmark>),
    /// The scenario's plan did not converge (its status): nothing was run.
    PlanFailed(String),
    /// [`BenchmarkSettings::cancel`] was set before the benchmark finished: nothing of it is returned.
    Cancelled,
}

/// Plan the scenario, then run the benchmark (see the module docs). `progress` is called once per
/// finished run (from the worker threads). Errors on bad settings or scenario before any run; a plan
/// that does not converge is [`BenchmarkOutcome::PlanFailed`].
pub fn run_benchmark(
    ls: &LoadedScenario,
    settings: &BenchmarkSettings,
    progress: ProgressFn<'_>,
) -> Result<BenchmarkOutcome, Error> {
    settings.validate()?;
    let cancelled = || settings.cancel.as_ref().is_some_and(|c| c.is_cancelled());
    let mut with_token;
    let ls = match &settings.cancel {
        Some(c) => {
            with_token = ls.clone();
            with_token.scenario.solver.cancel = Some(c.clone());
            &with_token
        }
        None => ls,
    };
    let plan = run_plan(ls)?;
    if cancelled() {
        return Ok(BenchmarkOutcome::Cancelled);
    }
    if !plan.plan.converged() {
        return Ok(BenchmarkOutcome::PlanFailed(format!(
            "{:?}",
            plan.plan.status
        )));
    }
    let reference = Arc::new(plan.plan.trajectory.clone());
    // a run stopped by the token may fail on its way out (a re-planner whose cold plan was
    // cancelled): the benchmark was cancelled, not refused
    let b = run_benchmark_on(ls, reference, settings, progress);
    if cancelled() {
        return Ok(BenchmarkOutcome::Cancelled);
    }
    let b = b?;
    Ok(BenchmarkOutcome::Done(Box::new(b)))
}

/// A refusal of the disturbances a sweep level makes, named as the user wrote the field
/// (`disturbances.mass_scale[0]`) and with the sweep and level that took it out of range.
fn at_level(e: Error, sweep: &str, level: f64) -> Error {
    match e {
        Error::InvalidValue {
            source_name,
            field,
            value,
            reason,
        } => Error::InvalidValue {
            source_name,
            field: format!("disturbances.{field}"),
            value,
            reason: format!(
                "{reason} (the scenario's value with the `{sweep}` sweep's level {level} added)"
            ),
        },
        e => e,
    }
}

/// The benchmark of a given plan `reference` (1 ms samples of a converged plan of `ls`). Once
/// `settings.cancel` is set, the runs not yet started are skipped: the rows then miss them (check the
/// token; [`run_benchmark`] says [`BenchmarkOutcome::Cancelled`]).
pub fn run_benchmark_on(
    ls: &LoadedScenario,
    reference: Arc<Trajectory>,
    settings: &BenchmarkSettings,
    progress: ProgressFn<'_>,
) -> Result<Benchmark, Error> {
    run_benchmark_with(ls, reference, settings, &[], progress)
}

/// [`run_benchmark_on`] with the caller's controllers `extra` scored beside the built-in ones
/// (those `settings.only_controllers` keeps; with `extra` given, an empty list keeps none of them).
/// Each name must be new. The extra controllers' runs take part in the same draws.
pub fn run_benchmark_with(
    ls: &LoadedScenario,
    reference: Arc<Trajectory>,
    settings: &BenchmarkSettings,
    extra: &[ExtraController],
    progress: ProgressFn<'_>,
) -> Result<Benchmark, Error> {
    settings.validate()?;
    extra::check_names(extra)?;
    let sc = &ls.scenario;
    let n = ls.robot.n();
    let ctx = SweepContext {
        robot: ls.robot.clone(),
        swing_time_s: reference.duration(),
    };
    let entries: Vec<Entry<'_>> = controllers()
        .into_iter()
        .filter(|c| {
            (settings.only_controllers.is_empty() && extra.is_empty())
                || settings.only_controllers.iter().any(|o| o == c.name)
        })
        .map(Entry::Builtin)
        .chain(extra.iter().map(Entry::Extra))
        .collect();
    let chosen: Vec<Sweep> = sweeps()
        .into_iter()
        .filter(|s| {
            settings.only_sweeps.is_empty() || settings.only_sweeps.iter().any(|o| o == s.name)
        })
        .collect();
    let base_params = ls
        .robot
        .params()
        .clone()
        .with_mass_scale(sc.plant.mass_scale);
    let src = format!("benchmark of {}", ls.path.display());
    let make_robot = |d: &Disturbances| -> Result<Robot, Error> {
        d.validate(n, sc.tracking.control_dt, &src)?;
        Robot::from_params(d.plant_params(&base_params), &src)
    };
    // the scenario's disturbances, with its [tracking] sensor noise (the two are exclusive): the base
    // every sweep level and every Monte Carlo draw adds to
    let mut base = sc.disturbances.clone();
    base.noise_q_std += sc.tracking.noise_q_std;
    base.noise_qd_std += sc.tracking.noise_qd_std;
    // every job, checked, before any simulation
    let mut jobs = Vec::new();
    let mut sweep_levels = Vec::new();
    let fams = crate::families::families();
    for (si, s) in chosen.iter().enumerate().filter(|_| settings.run_sweeps) {
        let lv = levels(s.max, settings.levels);
        for (li, &l) in lv.iter().enumerate() {
            let seed = mix(settings.seed ^ mix(((si as u64) << 32) | li as u64));
            let mut d = base.clone();
            d.seed = seed;
            s.apply(&mut d, l, &ctx);
            let probot = make_robot(&d).map_err(|e| at_level(e, s.name, l))?;
            for ci in 0..entries.len() {
                jobs.push(Job {
                    controller: ci,
                    disturbance: s.name.to_string(),
                    level: l,
                    seed,
                    dist: d.clone(),
                    plant: sc.plant.kind,
                    balls: Vec::new(),
                    ball_t_s: None,
                    probot: probot.clone(),
                });
            }
        }
        sweep_levels.push((s.name.to_string(), s.level.to_string(), lv));
    }
    for (fi, fam) in fams.iter().enumerate() {
        let runs = match fi {
            0 => settings.monte_carlo_runs,
            _ => settings.family_runs,
        };
        for i in 0..runs {
            // the original family keeps its seeds; the others draw from their own streams
            let seed = mix(settings.seed ^ mix(u64::MAX - i as u64 - ((fi as u64) << 40)));
            let draw = (fam.draw)(&ls.robot, &reference, seed);
            let d = with_scenario(&base, &draw.dist);
            let probot = make_robot(&d)?;
            for ci in 0..entries.len() {
                jobs.push(Job {
                    controller: ci,
                    disturbance: fam.name.into(),
                    level: i as f64,
                    seed,
                    dist: d.clone(),
                    plant: PlantKind::Rapier,
                    balls: draw.balls.clone(),
                    ball_t_s: draw.ball_t_s,
                    probot: probot.clone(),
                });
            }
        }
    }
    let total = jobs.len() as u64;
    let done = AtomicU64::new(0);
    let wall = Instant::now();
    let cancelled = || settings.cancel.as_ref().is_some_and(|c| c.is_cancelled());
    let work = || -> Result<Vec<BenchRow>, Error> {
        jobs.par_iter()
            .with_max_len(1)
            .filter(|_| !cancelled())
            .map(|job| {
                let r = run_job(ls, &reference, &entries[job.controller], job);
                progress(Progress {
                    done: done.fetch_add(1, Ordering::Relaxed) + 1,
                    total,
                    what: "benchmark runs",
                });
                r
            })
            .collect()
    };
    let rows = match settings.jobs {
        None => work()?,
        Some(j) => rayon::ThreadPoolBuilder::new()
            .num_threads(j)
            .build()
            .map_err(|e| Error::invalid("benchmark settings", "jobs", j, e.to_string()))?
            .install(work)?,
    };
    let wall_time_s = wall.elapsed().as_secs_f64();
    let mut scores = Vec::new();
    for e in &entries {
        let mine: Vec<&BenchRow> = rows.iter().filter(|r| r.controller == e.name()).collect();
        let mut per = Vec::new();
        let mut frac = Vec::new();
        for (name, _, _) in &sweep_levels {
            let rs: Vec<&BenchRow> = mine
                .iter()
                .copied()
                .filter(|r| &r.disturbance == name)
                .collect();
            let s = score(&rs);
            frac.push(s.success_pct / 100.0);
            per.push((name.clone(), s));
        }
        for fam in &fams {
            let mc: Vec<&BenchRow> = mine
                .iter()
                .copied()
                .filter(|r| r.disturbance == fam.name)
                .collect();
            if !mc.is_empty() {
                per.push((fam.name.into(), score(&mc)));
            }
        }
        scores.push(ControllerScore {
            controller: e.name().to_string(),
            per_disturbance: per,
            overall: score(&mine),
            robustness_score: if frac.is_empty() {
                0.0
            } else {
                frac.iter().sum::<f64>() / frac.len() as f64
            },
        });
    }
    Ok(Benchmark {
        scenario: sc.name.clone(),
        levels: settings.levels,
        monte_carlo_runs: settings.monte_carlo_runs,
        success_radius_m: SUCCESS_RADIUS_M,
        sweeps: sweep_levels,
        rows,
        scores,
        wall_time_s,
    })
}

impl Benchmark {
    /// `runs.csv`: one row per run.
    pub fn runs_csv(&self) -> String {
        let mut s = String::from(
            "controller,disturbance,level,seed,success,final_error_m,energy_j,peak_torque_nm,smoothness_nm,\
             ball_kg,ball_t_s,contact_s,replans,replans_adopted,replan_latency_s,replan_iterations,\
             contact_last_s,contact_impulse_n_s,replan_t_s,replan_miss_m,capture_t_s\n",
        );
        for r in &self.rows {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{:.9},{:.9},{:.9},{:.9},{:.6},{},{},{},{},{:.6},{},{},{:.6},{},{},{}",
                r.controller,
                r.disturbance,
                r.level,
                r.seed,
                u8::from(r.success),
                r.final_error_m,
                r.energy_j,
                r.peak_torque_nm,
                r.smoothness_nm,
                r.ball_kg,
                opt(r.ball_t_s),
                opt(r.contact_s),
                r.replans,
                r.replans_adopted,
                r.replan_latency_s,
                r.replan_iterations,
                opt(r.contact_last_s),
                r.contact_impulse_n_s,
                list(&r.replan_t_s),
                list(&r.replan_miss_m),
                opt(r.capture_t_s)
            );
        }
        s
    }

    /// `scorecard.json`: the scores and the benchmark's definition (no per-run rows, no wall time).
    pub fn scorecard_json(&self) -> serde_json::Value {
        serde_json::json!({
            // schema 2: success is the capture rule at any time of the run
            "schema_version": crate::schema::CAPTURE_SCHEMA_VERSION,
            "scenario": self.scenario,
            "levels": self.levels,
            "monte_carlo_runs": self.monte_carlo_runs,
            "success_radius_m": self.success_radius_m,
            "capture_speed_m_s": crate::CAPTURE_SPEED_M_S,
            "sweeps": self.sweeps.iter().map(|(n, what, lv)| serde_json::json!({
                "name": n, "level": what, "levels": lv,
            })).collect::<Vec<_>>(),
            "controllers": self.scores.iter().map(|c| serde_json::json!({
                "controller": c.controller,
                "robustness_score": c.robustness_score,
                "overall": c.overall,
                "per_disturbance": c.per_disturbance.iter()
                    .map(|(n, s)| (n.clone(), serde_json::to_value(s).unwrap_or_default()))
                    .collect::<serde_json::Map<_, _>>(),
            })).collect::<Vec<_>>(),
        })
    }

    /// `summary.md`: success % per disturbance and overall, energy, peak torque, smoothness,
    /// robustness score.
    pub fn summary_md(&self) -> String {
        let mut s = format!(
            "# Robustness benchmark: {}\n\n{} levels per disturbance, {} Monte Carlo runs (rapier plant: \
             mass x U(0.85, 1.15) per link, sigma_q = 0.002 rad, a 0.05-0.5 kg ball on the path). \
             Success: the hand within {} m of the bar and no faster than {} m/s at any time of the \
             run (the capture; the run is scored up to it). Robustness score: mean over the sweeps of the \
             fraction of levels that succeeded (RealAIGym-style). Simulations took {:.1} s.\n\n",
            self.scenario,
            self.levels,
            self.monte_carlo_runs,
            self.success_radius_m,
            crate::CAPTURE_SPEED_M_S,
            self.wall_time_s
        );
        s.push_str("| controller | robustness score | success % (all runs) | energy (J) | peak torque (N m) | smoothness (N m) |\n|---|---|---|---|---|---|\n");
        for c in &self.scores {
            let _ = writeln!(
                s,
                "| {} | {:.3} | {:.1} | {:.3} | {:.2} | {:.4} |",
                c.controller,
                c.robustness_score,
                c.overall.success_pct,
                c.overall.energy_j,
                c.overall.peak_torque_nm,
                c.overall.smoothness_nm
            );
        }
        s.push_str("\n## Success % per disturbance\n\n| disturbance | range |");
        for c in &self.scores {
            let _ = write!(s, " {} |", c.controller);
        }
        s.push_str("\n|---|---|");
        for _ in &self.scores {
            s.push_str("---|");
        }
        s.push('\n');
        let mut names: Vec<(String, String)> = self
            .sweeps
            .iter()
            .map(|(n, what, lv)| {
                (
                    n.clone(),
                    format!("{what}: 0..{}", lv.last().copied().unwrap_or(0.0)),
                )
            })
            .collect();
        for f in crate::families::families() {
            names.push((f.name.into(), format!("{}, rapier plant", f.what)));
        }
        for (n, what) in &names {
            let _ = write!(s, "| {n} | {what} |");
            for c in &self.scores {
                match c.per_disturbance.iter().find(|(m, _)| m == n) {
                    Some((_, sc)) => {
                        let _ = write!(s, " {:.1} |", sc.success_pct);
                    }
                    None => s.push_str(" - |"),
                }
            }
            s.push('\n');
        }
        let families: Vec<&str> = crate::families::families().iter().map(|f| f.name).collect();
        s.push_str(&per_draw_md(&self.rows, &families));
        s.push_str("\nPlots: `success_<disturbance>.png` (success against level, one curve per controller)");
        if !self.families_run().is_empty() {
            s.push_str(", `success_by_family.png` (success per Monte Carlo family and controller)");
        }
        s.push_str(".\n");
        s
    }

    /// The run folder's files except the plots (`runs.csv`, `scorecard.json`, `summary.md`).
    pub fn folder(&self) -> RunFolder {
        let mut f = RunFolder::default();
        f.add("runs.csv", self.runs_csv());
        f.add_json("scorecard.json", &self.scorecard_json());
        f.add("summary.md", self.summary_md());
        f
    }

    /// Draw `success_<disturbance>.png/.svg` into `dir`: success (0 or 100 %) against level, one
    /// curve per controller; and `success_by_family.png/.svg` ([`FAMILY_FIGURE`]).
    pub fn draw_plots(&self, dir: &Path) -> Result<(), ExpError> {
        for (name, what, lv) in &self.sweeps {
            let series = self
                .scores
                .iter()
                .enumerate()
                .map(|(ci, c)| {
                    let y = lv
                        .iter()
                        .map(|&l| {
                            let ok = self.rows.iter().any(|r| {
                                r.controller == c.controller
                                    && &r.disturbance == name
                                    && r.level == l
                                    && r.success
                            });
                            if ok {
                                100.0
                            } else {
                                0.0
                            }
                        })
                        .collect();
                    brachia_plot::Series::new(c.controller.clone(), lv.clone(), y).colour(ci)
                })
                .collect();
            let fig = brachia_plot::LinePlot {
                title: format!("{}: success against {name}", self.scenario),
                x_label: what.clone(),
                y_label: "success (%)".into(),
                series,
                size: None,
            };
            let path = dir.join(format!("success_{name}.png"));
            brachia_plot::line_plot(&path, &fig).map_err(|e| ExpError::Write {
                path: path.clone(),
                source: std::io::Error::other(e.to_string()),
            })?;
        }
        self.draw_family_figure(dir)
    }

    /// Write the run folder `dir` (staged next to it and renamed into place).
    pub fn write(&self, dir: &Path) -> Result<(), ExpError> {
        self.write_cancellable(dir, &CancelToken::new())
    }

    /// [`Benchmark::write`] that can be cancelled: once `cancel` is set before the staged folder is
    /// renamed into place, it is removed and the write ends with [`ExpError::Cancelled`] (`dir` is as
    /// it was).
    pub fn write_cancellable(&self, dir: &Path, cancel: &CancelToken) -> Result<(), ExpError> {
        let stage = stage_for(dir)?;
        let folder = self.folder();
        // the staging folder's manifest lists the files before they are written: a benchmark killed
        // half-way leaves a staging folder whose files the next run can prove are brachia's
        let r = crate::run_folder::list_in_stage(&folder, &stage)
            .and_then(|()| folder.write_into(&stage))
            .and_then(|()| cancel.check().map_err(ExpError::from))
            .and_then(|()| self.draw_plots(&stage))
            .and_then(|()| cancel.check().map_err(ExpError::from));
        match r {
            Ok(()) => install(&stage, dir),
            Err(e) => {
                crate::staging::remove(&stage);
                Err(e)
            }
        }
    }
}
