//! The benchmark's built-in controllers: each entry's name and how it is built for one run (plain, with
//! a Kalman filter, with online re-planning).

use crate::scenario::LoadedScenario;
use brachia::control::{
    Adaptive, Estimated, Mpc, OpenLoop, Pd, ReplanEvent, ReplanSettings, Replanning, Tvlqr,
};
use brachia::sim::Controller;
use brachia::trajectory::Trajectory;
use brachia::Error;
use std::sync::Arc;

/// The modelled re-plan latency of the benchmark's re-planning entries, s, used when the scenario's
/// `[tracking] replan` leaves `latency_s` unset (the measured wall time would make the benchmark
/// depend on the machine and its load). 20 ms: the warm re-plan on the 30 ms mesh takes 7.96 ms
/// (median) and 34.7 ms (p99) on the idle machine (docs/benchmarks.md, 100 disturbed starts), so
/// 20 ms is about 2.5x the median, rounded to whole control periods.
pub const REPLAN_LATENCY_S: f64 = 0.02;

/// A controller built for one benchmark run: a plain one, or one with online re-planning (whose
/// re-plans the run reports).
pub enum BenchController {
    /// Any controller.
    Plain(Box<dyn Controller>),
    /// A tracking controller wrapped by [`Replanning`].
    Replanning(Box<Replanning<Box<dyn Controller>>>),
    /// Re-planning fed the online mass estimate ([`Adaptive`]).
    Adaptive(Box<Adaptive<Replanning<Box<dyn Controller>>>>),
}

impl BenchController {
    /// The controller the loop drives.
    pub fn controller(&mut self) -> &mut dyn Controller {
        match self {
            BenchController::Plain(c) => c.as_mut(),
            BenchController::Replanning(r) => r.as_mut(),
            BenchController::Adaptive(r) => r.as_mut(),
        }
    }

    /// The re-plans of the run so far (none for a plain controller).
    pub fn replans(&self) -> &[ReplanEvent] {
        match self {
            BenchController::Plain(_) => &[],
            BenchController::Replanning(r) => r.events(),
            BenchController::Adaptive(r) => r.inner().events(),
        }
    }
}

/// Builds a controller for the benchmark: the scenario (robot, tracking settings) and the plan.
pub type BuildController = fn(&LoadedScenario, &Arc<Trajectory>) -> Result<BenchController, Error>;

/// One controller of the benchmark: a name for reports and how to build it.
#[derive(Debug, Clone, Copy)]
pub struct ControllerEntry {
    /// Name in `runs.csv` and the scorecard.
    pub name: &'static str,
    /// Builds a fresh controller for one run.
    pub build: BuildController,
}

fn mpc(ls: &LoadedScenario, r: &Arc<Trajectory>) -> Result<Box<dyn Controller>, Error> {
    let s = ls.scenario.tracking.mpc.clone();
    Ok(Box::new(Mpc::new(ls.robot.clone(), Arc::clone(r), s)?))
}

fn mpc_kalman(ls: &LoadedScenario, r: &Arc<Trajectory>) -> Result<Box<dyn Controller>, Error> {
    let t = &ls.scenario.tracking;
    let mpc = Mpc::new(ls.robot.clone(), Arc::clone(r), t.mpc.clone())?;
    Ok(Box::new(Estimated::new(
        mpc,
        ls.robot.clone(),
        Arc::clone(r),
        t.estimator,
        t.control_dt,
    )?))
}

/// The re-planning settings of the benchmark: the scenario's `[tracking] replan`, else the
/// defaults; an unset latency becomes [`REPLAN_LATENCY_S`].
pub fn replan_settings(ls: &LoadedScenario) -> ReplanSettings {
    let mut s = ls.scenario.tracking.replan.clone().unwrap_or_default();
    s.latency_s = Some(s.latency_s.unwrap_or(REPLAN_LATENCY_S));
    s
}

/// `inner` (tracking `r`) wrapped by [`Replanning`] on the scenario's task and planner settings.
fn with_replanning(
    ls: &LoadedScenario,
    r: &Arc<Trajectory>,
    inner: Box<dyn Controller>,
) -> Result<BenchController, Error> {
    let sc = &ls.scenario;
    Ok(BenchController::Replanning(Box::new(Replanning::build(
        inner,
        ls.robot.clone(),
        &sc.task,
        &sc.planner,
        &sc.solver,
        Arc::clone(r),
        replan_settings(ls),
    )?)))
}

/// Every controller the benchmark runs: one line each (a new controller is one more entry).
///
/// `mpc+kalman+replan` is `Replanning<Estimated<Mpc>>`: the re-planner is outermost so that its
/// switch of references goes through `Estimated::set_reference` and moves the filter's linearisation
/// and prior to the new plan together with the MPC's (the other order would leave the filter on the
/// abandoned plan); the price is that the miss prediction and the re-plan start from the raw
/// measurement (sigma_q = 0.002 rad in the Monte Carlo, small next to a hit).
pub fn controllers() -> Vec<ControllerEntry> {
    use BenchController::Plain;
    vec![
        ControllerEntry {
            name: "mpc",
            build: |ls, r| Ok(Plain(mpc(ls, r)?)),
        },
        ControllerEntry {
            name: "pd",
            build: |ls, r| {
                let s = ls.scenario.tracking.pd.clone();
                Ok(Plain(Box::new(Pd::new(
                    ls.robot.clone(),
                    Arc::clone(r),
                    s,
                )?)))
            },
        },
        ControllerEntry {
            name: "open-loop",
            build: |ls, r| {
                Ok(Plain(Box::new(OpenLoop::new(
                    ls.robot.clone(),
                    Arc::clone(r),
                )?)))
            },
        },
        ControllerEntry {
            name: "tvlqr",
            build: |ls, r| {
                let s = ls.scenario.tracking.tvlqr.clone();
                Ok(Plain(Box::new(Tvlqr::new(
                    ls.robot.clone(),
                    Arc::clone(r),
                    s,
                )?)))
            },
        },
        ControllerEntry {
            name: "mpc+kalman",
            build: |ls, r| Ok(Plain(mpc_kalman(ls, r)?)),
        },
        ControllerEntry {
            name: "mpc+replan",
            build: |ls, r| with_replanning(ls, r, mpc(ls, r)?),
        },
        ControllerEntry {
            name: "mpc+kalman+replan",
            build: |ls, r| with_replanning(ls, r, mpc_kalman(ls, r)?),
        },
        ControllerEntry {
            name: "mpc+estimate+replan",
            build: |ls, r| {
                let BenchController::Replanning(rp) = with_replanning(ls, r, mpc(ls, r)?)? else {
                    unreachable!("with_replanning builds a re-planner")
                };
                let est = ls.scenario.tracking.estimate_params.unwrap_or_default();
                Ok(BenchController::Adaptive(Box::new(Adaptive::new(
                    *rp,
                    ls.robot.clone(),
                    est,
                )?)))
            },
        },
    ]
}
