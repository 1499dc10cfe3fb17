//! The re-planning tests' world: the paper's swing planned on the 30 ms re-planning mesh (multiple
//! shooting, the OCP backend), the default MPC tracking it, and the model plant (RK4, one step per
//! 1 kHz control period) with a joint-velocity offset: a kick of the true state at one step, or a
//! glitch of the measurement over a window of steps. Units: s, m, rad, rad/s, N m.

// each test binary that includes this module uses a part of it
#![allow(dead_code)]

use brachia::control::{Mpc, MpcSettings};
use brachia::integrate::Rk4;
use brachia::model::Robot;
use brachia::planning::{
    Backend, NlpSettings, Plan, PlannerSettings, SwingPlanner, SwingTask, Transcription,
};
use brachia::sim::{ClosedLoop, Controller, Plant, RunSettings};
use brachia::trajectory::Trajectory;
use std::sync::Arc;

/// The control period, s.
pub const DT: f64 = 0.001;

/// The target bar of `SwingTask::paper()`, m.
pub const BAR: [f64; 2] = [0.8, 0.0];

/// Where the joint-velocity offset of an [`OffsetModel`] goes.
#[derive(Debug, Clone, Copy)]
pub enum Offset {
    /// Added to the true joint velocities once, after control step `k` (an impulsive hit; a step
    /// past the run's end: never).
    Kick(usize),
    /// Added to the measured joint velocities during control steps `[k0, k1)`; the plant's own
    /// state is never disturbed.
    Glitch(usize, usize),
}

impl Offset {
    /// A kick at `t_hit`, s.
    pub fn kick_at(t_hit: f64) -> Self {
        Offset::Kick((t_hit / DT).round() as usize)
    }

    /// A glitch of `steps` control periods from `t0`, s.
    pub fn glitch_at(t0: f64, steps: usize) -> Self {
        let k0 = (t0 / DT).round() as usize;
        Offset::Glitch(k0, k0 + steps)
    }
}

/// The model (RK4, one step per period) with the velocity offset `dqd` placed by `offset`.
pub struct OffsetModel {
    robot: Arc<Robot>,
    rk4: Rk4,
    /// The true state.
    pub x: Vec<f64>,
    steps: usize,
    offset: Offset,
    dqd: Vec<f64>,
}

impl OffsetModel {
    /// The model of `robot` from `x0`.
    pub fn new(robot: &Arc<Robot>, x0: Vec<f64>, offset: Offset, dqd: &[f64]) -> Self {
        OffsetModel {
            robot: Arc::clone(robot),
            rk4: Rk4::new(robot),
            x: x0,
            steps: 0,
            offset,
            dqd: dqd.to_vec(),
        }
    }
}

impl Plant for OffsetModel {
    fn n_links(&self) -> usize {
        self.robot.n()
    }
    fn time(&self) -> f64 {
        self.steps as f64 * DT
    }
    fn state(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.x);
        if let Offset::Glitch(k0, k1) = self.offset {
            if (k0..k1).contains(&self.steps) {
                let n = self.robot.n();
                for i in 0..n {
                    x[n + i] += self.dqd[i];
                }
            }
        }
    }
    fn step(&mut self, tau: &[f64], dt: f64) {
        let n = self.robot.n();
        let u: Vec<f64> = (0..n - 1)
            .map(|j| tau[j].clamp(self.robot.tau_min[j], self.robot.tau_max[j]))
            .collect();
        self.rk4.step(&self.robot, &mut self.x, &u, dt);
        self.steps += 1;
        if let Offset::Kick(k) = self.offset {
            if self.steps == k {
                for i in 0..n {
                    self.x[n + i] += self.dqd[i];
                }
            }
        }
    }
    fn energy(&self) -> f64 {
        let n = self.robot.n();
        self.robot.energy(&self.x[..n], &self.x[n..])
    }
    fn name(&self) -> &'static str {
        match self.offset {
            Offset::Kick(_) => "kicked-model",
            Offset::Glitch(..) => "glitched-model",
        }
    }
}

/// Run `c` (built on `robot`) along `reference` against the model of `plant_robot` with `offset`
/// and `dqd`; the true hand's final distance from [`BAR`], m.
pub fn final_miss<C: Controller>(
    robot: &Arc<Robot>,
    plant_robot: &Arc<Robot>,
    reference: &Arc<Trajectory>,
    c: &mut C,
    offset: Offset,
    dqd: &[f64],
) -> f64 {
    let n = robot.n();
    let x0 = [reference.q(0), reference.qd(0)].concat();
    let plant = OffsetModel::new(plant_robot, x0, offset, dqd);
    let rs = RunSettings {
        duration_s: reference.duration(),
        control_dt: DT,
        cancel: None,
    };
    let mut cl = ClosedLoop::new(plant, c, Arc::clone(robot), Arc::clone(reference), &rs).unwrap();
    cl.run();
    let ee = plant_robot.ee_position(&cl.plant().x[..n]);
    (ee[0] - BAR[0]).hypot(ee[1] - BAR[1])
}

/// The planner of the paper's swing on the 30 ms re-planning mesh, not planned yet.
pub fn unplanned(robot: &Arc<Robot>) -> SwingPlanner {
    let s = PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt: 0.03,
        ..Default::default()
    };
    let nlp = NlpSettings {
        backend: Backend::Ocp,
        ..Default::default()
    };
    SwingPlanner::new(Arc::clone(robot), SwingTask::paper(), &s, &nlp).unwrap()
}

/// [`unplanned`], planned: the planner and its plan, which converged.
pub fn planned(robot: &Arc<Robot>) -> (SwingPlanner, Plan) {
    let mut p = unplanned(robot);
    let plan = p.plan().unwrap();
    assert!(plan.converged(), "{:?}", plan.status);
    (p, plan)
}

/// The default MPC tracking `reference`.
pub fn tracker(robot: &Arc<Robot>, reference: &Arc<Trajectory>) -> Mpc {
    Mpc::new(
        Arc::clone(robot),
        Arc::clone(reference),
        MpcSettings::default(),
    )
    .unwrap()
}
