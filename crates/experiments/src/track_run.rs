//! A tracking run: plan (or read a plan), run a controller against a plant in closed loop at 1 kHz, and
//! fill the run folder (`closed_loop.csv`, `report.json`, and the plan's files under `plan/`).
//!
//! Units: s, m, rad, rad/s, N m, J. `closed_loop.csv` header: `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y,
//! ref_q1..,ref_qd1..,ref_ee_x,ref_ee_y`.

use crate::plan_run::{run_plan, PlanRun};
use crate::run_folder::RunFolder;
use crate::scenario::{ControllerKind, LoadedScenario, PlantKind};
use brachia::control::{Mpc, OpenLoop, Pd};
use brachia::sim::{
    run_closed_loop, ClosedLoopLog, Controller, ModelPlant, Plant, RunSettings, RunSummary,
};
use brachia::trajectory::Trajectory;
use brachia::{Error, Robot};
use serde_json::{json, Value};

/// Outcome of [`run_track`].
#[derive(Debug, Clone)]
pub struct TrackRun {
    /// The plan that was tracked (absent when the reference was read from a folder).
    pub plan: Option<PlanRun>,
    /// The reference (1 ms).
    pub reference: Trajectory,
    /// The closed-loop log.
    pub log: ClosedLoopLog,
    /// Its summary.
    pub summary: RunSummary,
    /// The run folder's files.
    pub folder: RunFolder,
}

/// Build the controller of `kind` for `reference`.
pub fn make_controller<'a>(
    kind: ControllerKind,
    ls: &'a LoadedScenario,
    reference: &'a Trajectory,
) -> Result<Box<dyn Controller + 'a>, Error> {
    let t = &ls.scenario.tracking;
    Ok(match kind {
        ControllerKind::Mpc => Box::new(Mpc::new(&ls.robot, reference, t.mpc.clone())?),
        ControllerKind::Pd => Box::new(Pd::new(&ls.robot, reference, t.pd.clone())?),
        ControllerKind::OpenLoop => Box::new(OpenLoop::new(&ls.robot, reference)?),
    })
}

/// The plant's robot: the planner's robot with the scenario's mass mismatch.
pub fn plant_robot(ls: &LoadedScenario) -> Result<Robot, Error> {
    let p = ls
        .robot
        .params
        .clone()
        .with_mass_scale(ls.scenario.plant.mass_scale);
    Robot::from_params(p, "plant (scenario [plant])")
}

/// Plan (unless `reference` is given), then track with `controller` on `plant`. Errors on bad input; a plan
/// that does not converge is returned with no closed loop run (`Ok(Err(plan_run))`).
pub fn run_track(
    ls: &LoadedScenario,
    controller: ControllerKind,
    plant: PlantKind,
    reference: Option<(Trajectory, Value)>,
) -> Result<Result<TrackRun, Box<PlanRun>>, Error> {
    let (plan, reference, plan_report) = match reference {
        Some((r, rep)) => (None, r, rep),
        None => {
            let run = run_plan(ls)?;
            if !run.plan.converged() {
                return Ok(Err(Box::new(run)));
            }
            let rep = crate::plan_run::plan_report(ls, &run.plan);
            let r = run.plan.trajectory.clone();
            (Some(run), r, rep)
        }
    };
    let sc = &ls.scenario;
    let probot = plant_robot(ls)?;
    let x0 = [reference.q(0), reference.qd(0)].concat();
    let mut plant_box: Box<dyn Plant> = match plant {
        PlantKind::Model => {
            let mut p = ModelPlant::new(probot, &x0);
            p.substeps = sc.plant.substeps;
            Box::new(p)
        }
        PlantKind::Rapier => {
            return Err(Error::invalid(
                ls.path.display().to_string(),
                "plant.kind",
                "rapier",
                "the rapier plant is not available in this build",
            ))
        }
    };
    let mut ctrl = make_controller(controller, ls, &reference)?;
    let settings = RunSettings {
        duration_s: reference.duration() + sc.tracking.hold_s,
        control_dt: sc.tracking.control_dt,
        noise_q_std: sc.tracking.noise_q_std,
        noise_qd_std: sc.tracking.noise_qd_std,
        seed: sc.tracking.seed,
    };
    let log = run_closed_loop(
        plant_box.as_mut(),
        ctrl.as_mut(),
        &reference,
        &ls.robot,
        &settings,
    )?;
    let (controller_name, plant_name) = (ctrl.name(), plant_box.name());
    drop(ctrl);
    let summary = log.summary();
    let (planned_energy, _) = reference.work();
    let mut folder = RunFolder::default();
    folder.add("closed_loop.csv", log.to_csv());
    let mut report = json!({
        "scenario": sc.name,
        "controller": controller_name,
        "plant": plant_name,
        "plant_mass_scale": sc.plant.mass_scale,
        "plant_substeps": sc.plant.substeps,
        "planned_energy_j": planned_energy,
        "target": sc.task.target,
        "plan": plan_report,
    });
    if let (Value::Object(m), Ok(Value::Object(s))) = (&mut report, serde_json::to_value(summary)) {
        for (k, v) in s {
            m.insert(k, v);
        }
    }
    folder.add_json("report.json", &report);
    if let Some(p) = &plan {
        for name in p.folder.names() {
            if let Some(data) = p.folder.get(name) {
                folder.add(&format!("plan/{name}"), data.to_vec());
            }
        }
    }
    Ok(Ok(TrackRun {
        plan,
        reference,
        log,
        summary,
        folder,
    }))
}

/// Read a plan folder written by `brachia plan` (its `trajectory.csv` and `report.json`).
pub fn read_plan_folder(dir: &std::path::Path, n: usize) -> Result<(Trajectory, Value), Error> {
    let read = |name: &str| {
        let p = dir.join(name);
        std::fs::read_to_string(&p).map_err(|source| Error::Io { path: p, source })
    };
    let tpath = dir.join("trajectory.csv").display().to_string();
    let traj = Trajectory::from_csv(&read("trajectory.csv")?, n, &tpath)?;
    if traj.len() < 2 {
        return Err(Error::invalid(
            &tpath,
            "rows",
            traj.len(),
            "a plan needs at least two samples",
        ));
    }
    let rpath = dir.join("report.json");
    let rep: Value = serde_json::from_str(&read("report.json")?).map_err(|e| Error::Parse {
        path: rpath.clone(),
        message: e.to_string(),
    })?;
    Ok((traj, rep))
}
