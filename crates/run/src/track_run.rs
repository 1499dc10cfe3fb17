//! A tracking run: plan (or read a plan), run a controller against a plant in closed loop at 1 kHz, and
//! fill the run folder (`closed_loop.csv`, `report.json`, and the plan's files under `plan/`; on the rapier
//! plant also `contacts.csv` and `obstacles.csv`).
//!
//! Units: s, m, rad, rad/s, N m, N s, J. `closed_loop.csv` header: `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y,
//! ref_q1..,ref_qd1..,ref_ee_x,ref_ee_y`. `contacts.csv`: `t,link,body,impulse` (link 1..n as in the
//! paper; body `obstacle_<id>` or `link_<j>`; the normal impulse over that control step, N s).
//! `obstacles.csv`: `t,obstacle_0_x,obstacle_0_y,...` (obstacle ids: the task's obstacles first, then the
//! plant's).

use crate::plan_run::{replay_trusted, run_plan, PlanReport, PlanRun, REPLAY_TRUST_M};
use crate::run_folder::RunFolder;
use crate::scenario::{ControllerKind, LoadedScenario, PlantKind};
use crate::tracker::Tracker;
use brachia::control::{EstimateReport, Estimated, Mpc, OpenLoop, Pd, ReplanEvent, Tvlqr};
use brachia::sim::{
    run_closed_loop, ClosedLoopLog, Controller, Disturbances, ModelPlant, NoiseSettings, Noisy,
    Plant, RunSettings, RunSummary,
};
use brachia::trajectory::Trajectory;
use brachia::{Error, Robot};
use brachia_rapier::{Circle, ContactBody, ContactEvent, Obstacle, RapierPlant};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::sync::Arc;

/// A track run's machine-readable report (its `report.json`). Units: s, m, N m, N s, J. The closed
/// loop's [`RunSummary`] is flattened into the top level (`ee_final_error_m`, `energy_j`, ...); `plan` is
/// the report of the plan that was tracked. Written with its keys sorted; read back by
/// [`crate::track_folder::TrackFolder::read`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrackReport {
    /// The scenario's name.
    pub scenario: String,
    /// The controller's name (`mpc`, `pd`, `open-loop`).
    pub controller: String,
    /// The plant's name (`model`, `rapier`).
    pub plant: String,
    /// Factor on the plant's link masses and inertias.
    pub plant_mass_scale: f64,
    /// Integration sub-steps per control period.
    pub plant_substeps: usize,
    /// Energy of the reference, paper eq. (18), J.
    pub planned_energy_j: f64,
    /// The target bar, m.
    pub target: [f64; 2],
    /// The obstacles of the plant's world in id order (the task's first; empty on the model plant).
    pub plant_obstacles: Vec<Obstacle>,
    /// Time of the first contact, s.
    pub first_contact_s: Option<f64>,
    /// Number of contact events (rows of `contacts.csv`).
    pub contact_events: usize,
    /// Sum of the contact impulses, N s.
    pub contact_impulse_n_s: f64,
    /// The scenario's `[disturbances]` (all defaults when it has none).
    #[serde(default)]
    pub disturbances: Disturbances,
    /// The tracked plan's report.
    pub plan: PlanReport,
    /// Online re-planning (`[tracking] replan`): whether it ran, and every re-plan (trigger time,
    /// predicted miss, status, iterations, solve and wall time, latency, switch time). False when
    /// a report read back lacks it (one written by an earlier version).
    #[serde(default)]
    pub replanning: bool,
    /// Number of re-plans (`replans.len()`).
    #[serde(default)]
    pub replan_count: usize,
    /// The re-plans, in time order.
    #[serde(default)]
    pub replans: Vec<ReplanEvent>,
    /// Whether the swing catches the bar ([`crate::success::capture`]): at some row of the run
    /// (before any divergence) the plant's hand is within [`crate::success::SUCCESS_RADIUS_M`]
    /// (2 cm) of the target bar and no faster than [`crate::success::CAPTURE_SPEED_M_S`]
    /// (0.5 m/s). `brachia track` exits 1 when it is false.
    #[serde(default)]
    pub reaches_bar: Option<bool>,
    /// Time of the first capture, s from the run's start (`None`: a miss).
    #[serde(default)]
    pub capture_t_s: Option<f64>,
    /// The plant's hand's distance to the target bar at the capture, or (a miss) at the end of the
    /// swing, m (`ee_final_error_m` is the distance to the reference at the last row); infinite
    /// (`null` in JSON) when the run logged no row. Absent (`None`) in a report of schema 1.
    #[serde(default, deserialize_with = "brachia::serde_nonfinite::opt_number")]
    pub bar_error_m: Option<f64>,
    /// The online estimate of the base inertial parameters (`[tracking] estimate_params`,
    /// docs/estimation.md): names, nominal values, the final estimate and its standard deviations,
    /// windows used and rejected, and the estimate after every window. Absent without it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimate: Option<EstimateReport>,
    /// The closed loop's metrics (a number that was not finite is `null` in JSON and reads back as
    /// infinite, as every number of the report).
    #[serde(flatten, deserialize_with = "brachia::serde_nonfinite::lenient")]
    pub summary: RunSummary,
}

impl TrackReport {
    /// The report as JSON (keys sorted, as `report.json` holds it).
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or(serde_json::Value::Null)
    }
}

/// What [`run_track`] did: tracked a plan, or stopped because the plan it made did not converge.
#[derive(Debug, Clone)]
pub enum TrackOutcome {
    /// The plan was tracked.
    Tracked(Box<TrackRun>),
    /// The plan did not converge, or its open-loop replay misses the bar by more than
    /// [`REPLAY_TRUST_M`]; nothing was tracked.
    PlanFailed(Box<PlanRun>),
}

impl TrackOutcome {
    /// The track run, or the plan run that failed.
    pub fn into_tracked(self) -> Result<TrackRun, Box<PlanRun>> {
        match self {
            TrackOutcome::Tracked(r) => Ok(*r),
            TrackOutcome::PlanFailed(p) => Err(p),
        }
    }
}

/// Outcome of [`run_track`].
#[derive(Debug, Clone)]
pub struct TrackRun {
    /// The plan that was tracked (absent when the reference was read from a folder).
    pub plan: Option<PlanRun>,
    /// The plan's machine-readable report (the `plan` entry of `report.json`).
    pub plan_report: PlanReport,
    /// The run's report (`report.json`).
    pub report: TrackReport,
    /// The reference (1 ms).
    pub reference: Trajectory,
    /// The closed-loop log.
    pub log: ClosedLoopLog,
    /// Its summary.
    pub summary: RunSummary,
    /// What happened in the plant's world (empty on the model plant).
    pub world: PlantWorld,
    /// The run folder's files.
    pub folder: RunFolder,
}

/// The obstacles of the plant's world and what the robot did to them (rapier plant; empty otherwise).
#[derive(Debug, Clone, Default)]
pub struct PlantWorld {
    /// The obstacles in id order: the task's obstacles (fixed circles) first, then the plant's.
    pub obstacles: Vec<Obstacle>,
    /// Every contact of a link, in time order.
    pub contacts: Vec<ContactEvent>,
    /// Obstacle centres over time, rows `[t, x_0, y_0, x_1, y_1, ...]` (s, m).
    pub track: Vec<Vec<f64>>,
}

impl PlantWorld {
    /// Time of the first contact, s.
    pub fn first_contact_s(&self) -> Option<f64> {
        self.contacts.first().map(|c| c.t)
    }

    /// `contacts.csv`: `t,link,body,impulse` (link 1..n; body `obstacle_<id>` or `link_<j>` with j 1..n).
    pub fn contacts_csv(&self) -> String {
        let mut s = String::from("t,link,body,impulse\n");
        for c in &self.contacts {
            let body = match c.body {
                ContactBody::Obstacle(id) => format!("obstacle_{id}"),
                ContactBody::Link(j) => format!("link_{}", j + 1),
            };
            let _ = writeln!(s, "{:.6},{},{body},{:.9}", c.t, c.link + 1, c.impulse);
        }
        s
    }
}

/// Build the controller of `kind` for `reference`.
pub fn make_controller(
    kind: ControllerKind,
    ls: &LoadedScenario,
    reference: &Trajectory,
) -> Result<Box<dyn Controller>, Error> {
    let t = &ls.scenario.tracking;
    let (robot, reference) = (ls.robot.clone(), reference.clone());
    let c: Box<dyn Controller> = match kind {
        ControllerKind::Mpc => Box::new(Mpc::new(robot.clone(), reference.clone(), t.mpc.clone())?),
        ControllerKind::Pd => Box::new(Pd::new(robot.clone(), reference.clone(), t.pd.clone())?),
        ControllerKind::OpenLoop => Box::new(OpenLoop::new(robot.clone(), reference.clone())?),
        ControllerKind::Tvlqr => Box::new(Tvlqr::new(
            robot.clone(),
            reference.clone(),
            t.tvlqr.clone(),
        )?),
    };
    if t.kalman && kind != ControllerKind::OpenLoop {
        return Ok(Box::new(Estimated::new(
            c,
            robot,
            reference,
            t.estimator,
            t.control_dt,
        )?));
    }
    Ok(c)
}

/// The plant's robot: the planner's robot with the scenario's mass mismatch (`[plant] mass_scale`, then
/// the per-link factors of `[disturbances]`).
pub fn plant_robot(ls: &LoadedScenario) -> Result<Robot, Error> {
    let p = ls
        .robot
        .params()
        .clone()
        .with_mass_scale(ls.scenario.plant.mass_scale);
    let p = ls.scenario.disturbances.plant_params(&p);
    Robot::from_params(p, "plant (scenario [plant] and [disturbances])")
}

/// Refuse a plant that cannot run the scenario (the model plant simulates no contacts), before planning.
fn check_plant(ls: &LoadedScenario, plant: PlantKind) -> Result<(), Error> {
    if plant == PlantKind::Model && !ls.scenario.plant.obstacles.is_empty() {
        return Err(Error::invalid(
            ls.path.display().to_string(),
            "plant.obstacles",
            format!("{} obstacles", ls.scenario.plant.obstacles.len()),
            "the model plant simulates no contacts: run them on the rapier plant \
             (plant.kind = \"rapier\" or --plant rapier)",
        ));
    }
    Ok(())
}

/// Plan (unless `reference` is given), then track with `controller` on `plant`. Errors on bad input; a plan
/// that does not converge is returned with no closed loop run ([`TrackOutcome::PlanFailed`]).
pub fn run_track(
    ls: &LoadedScenario,
    controller: ControllerKind,
    plant: PlantKind,
    reference: Option<(Trajectory, PlanReport)>,
) -> Result<TrackOutcome, Error> {
    check_plant(ls, plant)?;
    let run = match reference {
        Some((r, rep)) => track_plan(ls, controller, plant, None, r, rep)?,
        None => {
            let run = run_plan(ls)?;
            if !run.plan.converged() || !replay_trusted(run.plan.replay_ee_error_m) {
                return Ok(TrackOutcome::PlanFailed(Box::new(run)));
            }
            let rep = run.report.clone();
            let r = run.plan.trajectory.clone();
            track_plan(ls, controller, plant, Some(run), r, rep)?
        }
    };
    Ok(TrackOutcome::Tracked(Box::new(run)))
}

/// Track `reference` (whose plan report is `plan_report`) with `controller` on `plant`; `plan` is the run
/// that produced it, if it was planned here (its files go under `plan/`). Errors on bad input only.
pub fn track_plan(
    ls: &LoadedScenario,
    controller: ControllerKind,
    plant: PlantKind,
    plan: Option<PlanRun>,
    reference: Trajectory,
    plan_report: PlanReport,
) -> Result<TrackRun, Error> {
    check_plant(ls, plant)?;
    let sc = &ls.scenario;
    let probot = plant_robot(ls)?;
    let x0 = sc
        .disturbances
        .start_state(&[reference.q(0), reference.qd(0)].concat());
    let mut world = PlantWorld::default();
    let mut rapier = None;
    let mut model = None;
    let plant_ref: &mut dyn Plant = match plant {
        PlantKind::Model => {
            let mut p = ModelPlant::new(probot.clone(), &x0);
            p.substeps = sc.plant.substeps;
            model.insert(p)
        }
        PlantKind::Rapier => {
            let mut p = RapierPlant::new(&probot, &x0, &sc.plant.rapier())?;
            let task_obstacles = sc.task.obstacles.iter().map(|c| {
                Obstacle::Circle(Circle {
                    center: c.center,
                    radius: c.radius,
                })
            });
            world.obstacles = task_obstacles
                .chain(sc.plant.obstacles.iter().cloned())
                .collect();
            let n_task = sc.task.obstacles.len();
            for (id, o) in world.obstacles.iter().enumerate() {
                let (field, center) = if id < n_task {
                    (format!("task.obstacles[{id}]"), o.shape().0)
                } else {
                    (format!("plant.obstacles[{}]", id - n_task), o.shape().0)
                };
                p.add_obstacle(o).map_err(|e| match e {
                    Error::InfeasibleTask(m) => Error::invalid(
                        ls.path.display().to_string(),
                        field.clone(),
                        format!("center [{}, {}]", center[0], center[1]),
                        m,
                    ),
                    other => other,
                })?;
            }
            rapier.insert(p)
        }
    };
    let base = make_controller(controller, ls, &reference)?;
    // re-planning and the mass estimate wrap the MPC only (the scenario refuses them otherwise)
    let is_mpc = controller == ControllerKind::Mpc;
    let (replan, estimate) = match is_mpc {
        true => (sc.tracking.replan.clone(), sc.tracking.estimate_params),
        false => (None, None),
    };
    let shared = Arc::new(reference.clone());
    let mut tracker = Tracker::build(ls, &shared, base, replan, estimate)?;
    let ctrl = tracker.controller();
    let settings = RunSettings {
        duration_s: reference.duration() + sc.tracking.hold_s,
        control_dt: sc.tracking.control_dt,
        // the scenario's cancel token (set by the caller, e.g. on Ctrl-C) stops the loop too
        cancel: sc.solver.cancel.clone(),
    };
    let noise = NoiseSettings {
        q_std: sc.tracking.noise_q_std,
        qd_std: sc.tracking.noise_qd_std,
        seed: sc.tracking.seed,
    };
    let log = {
        let mut wrapped = sc
            .disturbances
            .wrap(Box::new(&mut *plant_ref), settings.control_dt)?;
        if !noise.is_zero() {
            wrapped = Box::new(Noisy::new(wrapped, noise)?);
        }
        run_closed_loop(
            wrapped.as_mut(),
            &mut *ctrl,
            &reference,
            &ls.robot,
            &settings,
        )?
    };
    let (controller_name, plant_name) = (ctrl.name(), plant_ref.name());
    let replans = tracker.replans().to_vec();
    let estimate = tracker.estimate();
    if let Some(p) = &rapier {
        world.contacts = p.contacts().to_vec();
        world.track = p.obstacle_track().map(<[f64]>::to_vec).collect();
    }
    let summary = log.summary();
    let caught = crate::success::capture(&probot, &log, reference.duration(), sc.task.target);
    let (planned_energy, _) = reference.work();
    let mut folder = RunFolder::default();
    folder.add("closed_loop.csv", log.to_csv());
    if let Some(p) = &rapier {
        folder.add("contacts.csv", world.contacts_csv());
        folder.add("obstacles.csv", p.obstacle_track_csv());
    }
    let report = TrackReport {
        scenario: sc.name.clone(),
        controller: controller_name.to_string(),
        plant: plant_name.to_string(),
        plant_mass_scale: sc.plant.mass_scale,
        plant_substeps: sc.plant.substeps,
        planned_energy_j: planned_energy,
        target: sc.task.target,
        plant_obstacles: world.obstacles.clone(),
        first_contact_s: world.first_contact_s(),
        contact_events: world.contacts.len(),
        contact_impulse_n_s: world.contacts.iter().map(|c| c.impulse).sum::<f64>(),
        disturbances: sc.disturbances.clone(),
        plan: plan_report.clone(),
        replanning: tracker.replanning(),
        replan_count: replans.len(),
        replans,
        reaches_bar: Some(caught.reaches_bar),
        capture_t_s: caught.capture_t_s,
        bar_error_m: Some(caught.bar_error_m),
        estimate,
        summary,
    };
    // schema 2: `reaches_bar` is the capture rule at any time of the run, with `capture_t_s`
    let mut json = report.to_json();
    if let serde_json::Value::Object(m) = &mut json {
        m.insert(
            crate::schema::SCHEMA_FIELD.into(),
            crate::schema::CAPTURE_SCHEMA_VERSION.into(),
        );
    }
    folder.add_json("report.json", &json);
    if let Some(p) = &plan {
        for name in p.folder.names() {
            if let Some(data) = p.folder.get(name) {
                folder.add(&format!("plan/{name}"), data.to_vec());
            }
        }
    }
    Ok(TrackRun {
        plan,
        plan_report,
        report,
        reference,
        log,
        summary,
        world,
        folder,
    })
}

/// Tolerance between a plan's first sample and the scenario's start state (rad, rad/s): the CSV keeps 9
/// decimals.
const START_TOLERANCE: f64 = 1e-6;

/// Read a plan folder written by `brachia plan` (`trajectory.csv`, `report.json`, `scenario.toml` and
/// its robot) and check it against the scenario `ls` before anything is tracked: the trajectory's
/// content ([`crate::read::read_plan_trajectory`]: header, finite values, times, spacing, the hand
/// columns the forward kinematics of `q` on the scenario's robot), its first sample the scenario's
/// start state (`task.q0`, `task.qd0`), `report.json` a converged [`PlanReport`] whose replay is
/// trusted and whose `swing_time_s` is the trajectory's duration, the last sample's hand on the
/// scenario's target, and every field the plan's `scenario.toml` shares with `ls` (robot, start,
/// target, obstacles, bounds; [`crate::plan_match::check_same_task`]). Files are read with a size cap.
pub fn read_plan_folder(
    dir: &std::path::Path,
    ls: &LoadedScenario,
) -> Result<(Trajectory, PlanReport), Error> {
    let n = ls.robot.n();
    if !dir.is_dir() {
        return Err(Error::invalid(
            dir.display().to_string(),
            "--plan",
            dir.display(),
            "must be a plan folder written by `brachia plan` (trajectory.csv, report.json)",
        ));
    }
    let whose = format!("the scenario's robot ({})", ls.scenario.params.display());
    const PLAN: &str = "a plan folder written by `brachia plan` (trajectory.csv, report.json)";
    let tfile = crate::read::need(dir, "trajectory.csv", PLAN)?;
    let traj = crate::read::read_plan_trajectory(&tfile, &ls.robot, &whose)?;
    let task = &ls.scenario.task;
    let qd0 = if task.qd0.is_empty() {
        vec![0.0; n]
    } else {
        task.qd0.clone()
    };
    for (name, plan_v, sc_v) in [("q0", traj.q(0), &task.q0), ("qd0", traj.qd(0), &qd0)] {
        let diff = plan_v
            .iter()
            .zip(sc_v.iter())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if diff > START_TOLERANCE {
            return Err(Error::invalid(
                ls.path.display().to_string(),
                format!("task.{name}"),
                format!("{sc_v:?}"),
                format!(
                    "the plan in {} starts at {name} = {plan_v:?} (differs by {diff:.3e}); track it \
                     with the scenario it was planned for",
                    dir.display()
                ),
            ));
        }
    }
    let report = crate::read::need(dir, "report.json", PLAN)?;
    let rep: PlanReport = crate::read::read_json(&report, crate::schema::JsonKind::PlanReport)?;
    // the clearance on the folder's own trajectory (a folder written before the check, or edited,
    // says nothing of it)
    let violation = match rep.clearance_violation {
        Some(v) => Some(v),
        None => brachia::planning::check_clearance(
            &ls.robot,
            &ls.scenario.task,
            &ls.scenario.planner,
            &traj,
        )?,
    };
    if let Some(v) = violation {
        return Err(Error::invalid(
            report.display().to_string(),
            "clearance_violation",
            format!("{:.4} m short at t = {:.3} s", v.shortfall_m(), v.time_s),
            format!(
                "the plan's trajectory breaks the required clearance ({v}), so it is not tracked; \
                 re-plan it (`brachia plan` exits 1 for such a plan)"
            ),
        ));
    }
    if !rep.converged {
        return Err(Error::invalid(
            report.display().to_string(),
            "status",
            format!("{:?}", rep.status),
            "the plan did not converge, so it is not tracked; re-plan it (`brachia plan` exits 1 for \
             such a plan)",
        ));
    }
    if !replay_trusted(rep.replay_ee_error_m) {
        return Err(Error::invalid(
            report.display().to_string(),
            "replay_ee_error_m",
            rep.replay_ee_error_m,
            format!(
                "replaying the plan's torques open loop misses the bar by more than {} m, so the plan \
                 cannot be trusted and is not tracked; re-plan it on a finer grid",
                REPLAY_TRUST_M
            ),
        ));
    }
    crate::plan_match::check_duration(&traj, rep.swing_time_s, &report)?;
    crate::plan_match::check_ends_at_target(&traj, ls, &tfile)?;
    let Some(sfile) = crate::read::inside(dir, "scenario.toml")? else {
        return Err(Error::invalid(
            dir.display().to_string(),
            "scenario.toml",
            "missing",
            "a plan folder written by `brachia plan` holds scenario.toml (and its robot, \
             params.toml): without it the plan's robot, target, obstacles and limits cannot be \
             checked against the scenario, so it is not tracked",
        ));
    };
    let plan_ls = crate::read::load_plan_scenario(dir, &sfile)?;
    crate::plan_match::check_same_task(&plan_ls, ls)?;
    Ok((traj, rep))
}
