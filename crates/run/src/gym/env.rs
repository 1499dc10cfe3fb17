//! One swing environment: the plant (with the episode's disturbances), the action scaling, the
//! observation, the reward terms, termination and truncation (see the module docs of `gym`).

use super::{Randomization, RewardTerms, SwingEnvSettings};
use crate::scenario::{LoadedScenario, PlantKind};
use brachia::model::RobotParams;
use brachia::planning::SwingTask;
use brachia::sim::{Disturbances, ModelPlant, Plant, DIVERGENCE_BOUND};
use brachia::{Error, Robot};
use brachia_rapier::{Circle, Obstacle, RapierPlant, RapierSettings};
use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

/// Everything episodes share: the robot, the task, the plant, the settings and the disturbances.
#[derive(Debug, Clone)]
pub struct SwingEnvSpec {
    /// The nominal robot (what a policy knows: the hand in the observation is computed with it).
    pub robot: Arc<Robot>,
    /// The plant's parameters before the episode's model mismatch (`[plant] mass_scale` applied).
    plant_params: RobotParams,
    /// The plant's robot when the episode has no mismatch.
    plant_robot: Arc<Robot>,
    /// Start state `[q0, qd0]`.
    pub x0: Vec<f64>,
    /// The bar to catch, m (grip frame).
    pub target: [f64; 2],
    /// Which plant.
    pub plant: PlantKind,
    /// Rapier settings (substeps set per control period).
    rapier: RapierSettings,
    /// Obstacles of the rapier world: the task's circles, then the plant's.
    pub obstacles: Vec<Obstacle>,
    /// The settings.
    pub settings: SwingEnvSettings,
    /// The disturbances of every episode (ranges drawn per episode).
    pub randomization: Randomization,
    /// Names the source in errors.
    pub src: String,
    /// Observation bounds.
    obs_lo: Vec<f64>,
    obs_hi: Vec<f64>,
}

impl SwingEnvSpec {
    /// The spec of `robot` swinging as `task` says on `plant`, with `[plant]` settings `ps` and the
    /// disturbances `randomization` (`None`: none). Errors name `src`, the field, the value, the rule.
    pub fn new(
        robot: &Robot,
        task: &SwingTask,
        plant: PlantKind,
        ps: &crate::scenario::PlantSettings,
        settings: SwingEnvSettings,
        randomization: Option<Randomization>,
        src: &str,
    ) -> Result<Self, Error> {
        settings.validate(src)?;
        let n = robot.n();
        brachia::planning::validate_task(
            robot,
            task,
            &brachia::planning::PlannerSettings::default(),
            src,
            "task.",
        )?;
        if plant == PlantKind::Model && !ps.obstacles.is_empty() {
            return Err(Error::invalid(
                src,
                "plant.obstacles",
                format!("{} obstacles", ps.obstacles.len()),
                "the model plant simulates no contacts: use the rapier plant",
            ));
        }
        let qd0 = if task.qd0.is_empty() {
            vec![0.0; n]
        } else {
            task.qd0.clone()
        };
        let x0 = [task.q0.clone(), qd0].concat();
        let plant_params = robot.params().clone().with_mass_scale(ps.mass_scale);
        let plant_robot = Arc::new(Robot::from_params(plant_params.clone(), src)?);
        let randomization = match randomization {
            Some(r) => r,
            None => Randomization::fixed(&Disturbances::default(), src),
        };
        randomization.check_pushes_within(settings.time_limit_s)?;
        let obstacles = task
            .obstacles
            .iter()
            .map(|c| {
                Obstacle::Circle(Circle {
                    center: c.center,
                    radius: c.radius,
                })
            })
            .chain(ps.obstacles.iter().cloned())
            .collect();
        let mut rapier = ps.rapier();
        rapier.substeps = settings.substeps();
        let (obs_lo, obs_hi) = bounds(robot, task.target, &settings);
        Ok(SwingEnvSpec {
            robot: Arc::new(robot.clone()),
            plant_params,
            plant_robot,
            x0,
            target: task.target,
            plant,
            rapier,
            obstacles,
            settings,
            randomization,
            src: src.to_string(),
            obs_lo,
            obs_hi,
        })
    }

    /// The spec of a loaded scenario: its robot, task, `[plant]` and `[disturbances]` (fixed, or
    /// `randomization` in their place), on `plant` (`None`: the scenario's `[plant] kind`).
    pub fn from_scenario(
        ls: &LoadedScenario,
        plant: Option<PlantKind>,
        settings: SwingEnvSettings,
        randomization: Option<Randomization>,
    ) -> Result<Self, Error> {
        let src = ls.path.display().to_string();
        let sc = &ls.scenario;
        let r = match randomization {
            Some(r) => r,
            None => Randomization::fixed(&sc.disturbances, &src),
        };
        let plant = plant.unwrap_or(sc.plant.kind);
        SwingEnvSpec::new(
            &ls.robot,
            &sc.task,
            plant,
            &sc.plant,
            settings,
            Some(r),
            &src,
        )
    }

    /// Action size: the actuated joints, n - 1.
    pub fn action_dim(&self) -> usize {
        self.robot.n() - 1
    }

    /// Observation size: `[q, qd]`, the bar relative to the hand, the time left: 2n + 3.
    pub fn observation_dim(&self) -> usize {
        2 * self.robot.n() + 3
    }

    /// Bounds of the observation (`low`, `high`, each 2n + 3 values): angles within
    /// `max_angle_rad`, rates within `max_rate_rad_s`, the bar within twice the robot's reach plus
    /// the bar's distance plus 1 m, the time left within [0, `time_limit_s`].
    pub fn observation_bounds(&self) -> (&[f64], &[f64]) {
        (&self.obs_lo, &self.obs_hi)
    }
}

/// See [`SwingEnvSpec::observation_bounds`].
fn bounds(robot: &Robot, target: [f64; 2], s: &SwingEnvSettings) -> (Vec<f64>, Vec<f64>) {
    let n = robot.n();
    let reach: f64 = robot.params().links.iter().map(|l| l.length).sum();
    let far = 2.0 * reach + target[0].hypot(target[1]) + 1.0;
    let mut hi = vec![s.max_angle_rad; n];
    hi.extend(std::iter::repeat_n(s.max_rate_rad_s, n));
    hi.extend([far, far]);
    let mut lo: Vec<f64> = hi.iter().map(|v| -v).collect();
    hi.push(s.time_limit_s);
    lo.push(0.0);
    (lo, hi)
}

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepOutcome {
    /// The weighted reward.
    pub reward: f64,
    /// The episode ended in the task's own terms (captured, or left the limits).
    pub terminated: bool,
    /// The episode ended at the time limit.
    pub truncated: bool,
    /// The unweighted terms.
    pub terms: RewardTerms,
    /// The plant's hand caught the bar.
    pub captured: bool,
    /// The plant's true state left the limits or diverged.
    pub out_of_limits: bool,
    /// Distance of the plant's hand to the bar after the step, m.
    pub distance_m: f64,
}

/// One swing environment. `reset` before the first `step` is done by [`SwingEnv::new`].
pub struct SwingEnv {
    spec: Arc<SwingEnvSpec>,
    plant: Box<dyn Plant + Send>,
    /// The plant's robot of this episode (mismatch applied).
    probot: Arc<Robot>,
    /// The env's own generator: one episode seed per reset.
    rng: ChaCha8Rng,
    episode_seed: u64,
    disturbances: Disturbances,
    steps: usize,
    /// Measured and true states.
    x: Vec<f64>,
    xt: Vec<f64>,
    tau: Vec<f64>,
    /// True rates of the actuated joints at the start of the step.
    qd_prev: Vec<f64>,
    distance: f64,
    done: bool,
}

impl SwingEnv {
    /// An environment seeded with `seed`, reset once.
    pub fn new(spec: Arc<SwingEnvSpec>, seed: u64) -> Result<Self, Error> {
        let n = spec.robot.n();
        let probot = spec.plant_robot.clone();
        let plant: Box<dyn Plant + Send> = Box::new(ModelPlant::new(probot.clone(), &spec.x0));
        let mut env = SwingEnv {
            plant,
            probot,
            rng: ChaCha8Rng::seed_from_u64(seed),
            episode_seed: 0,
            disturbances: Disturbances::default(),
            steps: 0,
            x: vec![0.0; 2 * n],
            xt: vec![0.0; 2 * n],
            tau: vec![0.0; n - 1],
            qd_prev: vec![0.0; n - 1],
            distance: 0.0,
            done: true,
            spec,
        };
        env.reset(Some(seed), None)?;
        Ok(env)
    }

    /// The shared spec.
    pub fn spec(&self) -> &Arc<SwingEnvSpec> {
        &self.spec
    }

    /// Start a new episode: reseed the env's generator with `seed` (`None`: continue it), draw the
    /// episode's seed and its disturbances (from `randomization`, or the spec's), build the plant.
    pub fn reset(
        &mut self,
        seed: Option<u64>,
        randomization: Option<&Randomization>,
    ) -> Result<(), Error> {
        if let Some(s) = seed {
            self.rng = ChaCha8Rng::seed_from_u64(s);
        }
        self.episode_seed = self.rng.next_u64();
        let mut ep = ChaCha8Rng::seed_from_u64(self.episode_seed);
        let spec = self.spec.clone();
        let r = randomization.unwrap_or(&spec.randomization);
        let d = r.draw(&mut ep)?;
        let mismatch = !(d.mass_scale.is_empty()
            && d.com_scale.is_empty()
            && d.inertia_scale.is_empty()
            && d.length_scale.is_empty());
        self.probot = if mismatch {
            let p = d.plant_params(&spec.plant_params);
            Arc::new(Robot::from_params(p, &spec.src)?)
        } else {
            spec.plant_robot.clone()
        };
        let x0 = d.start_state(&spec.x0);
        let base: Box<dyn Plant + Send> = match spec.plant {
            PlantKind::Model => {
                let mut p = ModelPlant::new(self.probot.clone(), &x0);
                p.substeps = spec.settings.substeps();
                Box::new(p)
            }
            PlantKind::Rapier => {
                let mut p = RapierPlant::new(&self.probot, &x0, &spec.rapier)?;
                for o in &spec.obstacles {
                    p.add_obstacle(o)?;
                }
                Box::new(p)
            }
        };
        self.plant = d.wrap_send(base, spec.settings.control_dt)?;
        self.disturbances = d;
        self.steps = 0;
        self.plant.state(&mut self.x);
        self.plant.true_state(&mut self.xt);
        self.distance = self.hand_distance();
        self.done = false;
        Ok(())
    }

    /// The plant's true hand distance to the bar, m.
    fn hand_distance(&self) -> f64 {
        let n = self.probot.n();
        let p = self.probot.ee_position(&self.xt[..n]);
        let t = self.spec.target;
        (p[0] - t[0]).hypot(p[1] - t[1])
    }

    /// One control period under `action` (n - 1 values, each clipped to [-1, 1]). Errors on a wrong
    /// length, a non-finite value, or a step after the episode ended (reset first).
    pub fn step(&mut self, action: &[f64]) -> Result<StepOutcome, Error> {
        let spec = self.spec.clone();
        let nu = spec.action_dim();
        if action.len() != nu {
            return Err(Error::invalid(
                &spec.src,
                "action",
                format!("{} values", action.len()),
                format!("needs {nu} values (joints 2..{})", nu + 1),
            ));
        }
        if let Some((j, a)) = action.iter().enumerate().find(|(_, a)| !a.is_finite()) {
            return Err(Error::invalid(
                &spec.src,
                format!("action[{j}]"),
                a,
                "must be finite (scaled to [-1, 1])",
            ));
        }
        if self.done {
            return Err(Error::invalid(
                &spec.src,
                "step",
                "after the end of the episode",
                "reset() the environment first",
            ));
        }
        let r = &spec.robot;
        for j in 0..nu {
            let (lo, hi) = (r.tau_min[j], r.tau_max[j]);
            let a = action[j].clamp(-1.0, 1.0);
            self.tau[j] = 0.5 * (lo + hi) + 0.5 * (hi - lo) * a;
        }
        let n = nu + 1;
        let dt = spec.settings.control_dt;
        self.qd_prev.copy_from_slice(&self.xt[n + 1..]);
        self.plant.step(&self.tau, dt);
        self.steps += 1;
        self.plant.state(&mut self.x);
        self.plant.true_state(&mut self.xt);
        let diverged = self
            .xt
            .iter()
            .chain(&self.x)
            .any(|v| !v.is_finite() || v.abs() > DIVERGENCE_BOUND);
        let mut terms = RewardTerms::default();
        let pt = &self.probot;
        for j in 0..nu {
            let tau = self.tau[j].clamp(pt.tau_min[j], pt.tau_max[j]);
            let p = tau * 0.5 * (self.qd_prev[j] + self.xt[n + 1 + j]) * dt;
            terms.energy_j += p;
            terms.positive_work_j += p.max(0.0);
        }
        let s = &spec.settings;
        let out = diverged
            || self.xt[..n].iter().any(|q| q.abs() > s.max_angle_rad)
            || self.xt[n..].iter().any(|qd| qd.abs() > s.max_rate_rad_s);
        // the capture rule of every run (crate::success): the true hand within 2 cm, slow
        let hand = crate::success::hand_at_bar(pt, &self.xt, spec.target);
        let d = hand.distance_m;
        let captured = !out && hand.captures;
        terms.capture = f64::from(u8::from(captured));
        terms.out_of_limits = f64::from(u8::from(out));
        terms.progress_m = if out { 0.0 } else { self.distance - d };
        if !terms.energy_j.is_finite() {
            terms.energy_j = 0.0;
            terms.positive_work_j = 0.0;
        }
        self.distance = if d.is_finite() { d } else { self.distance };
        let terminated = captured || out;
        let truncated = !terminated && self.steps >= s.episode_steps();
        self.done = terminated || truncated;
        Ok(StepOutcome {
            reward: s.reward.reward(&terms),
            terminated,
            truncated,
            terms,
            captured,
            out_of_limits: out,
            distance_m: self.distance,
        })
    }

    /// The observation (2n + 3 values): measured state, bar relative to the hand (nominal robot,
    /// measured angles), time left; clipped to the bounds, a non-finite value written as 0.
    pub fn observe(&self, out: &mut [f32]) {
        let n = self.spec.robot.n();
        let (lo, hi) = self.spec.observation_bounds();
        let hand = self.spec.robot.ee_position(&self.x[..n]);
        let t = self.spec.target;
        let left = (self.spec.settings.episode_steps()
            - self.steps.min(self.spec.settings.episode_steps())) as f64
            * self.spec.settings.control_dt;
        let vals = self
            .x
            .iter()
            .copied()
            .chain([t[0] - hand[0], t[1] - hand[1], left]);
        for (i, v) in vals.enumerate() {
            let v = if v.is_finite() { v } else { 0.0 };
            out[i] = v.clamp(lo[i], hi[i]) as f32;
        }
    }

    /// True when the episode has ended (a `step` needs a `reset` first).
    pub fn done(&self) -> bool {
        self.done
    }

    /// Simulated time of the episode, s.
    pub fn time(&self) -> f64 {
        self.steps as f64 * self.spec.settings.control_dt
    }

    /// The plant's true state `[q, qd]`.
    pub fn true_state(&self) -> &[f64] {
        &self.xt
    }

    /// The seed of the current episode (drawn from the env's generator).
    pub fn episode_seed(&self) -> u64 {
        self.episode_seed
    }

    /// The current episode's disturbances (ranges drawn).
    pub fn disturbances(&self) -> &Disturbances {
        &self.disturbances
    }

    /// The plant's robot of this episode (the nominal one with the drawn mismatch).
    pub fn plant_robot(&self) -> &Robot {
        &self.probot
    }

    /// The current pose drawn by the plotting code: row-major RGB bytes, `height * width * 3`.
    pub fn render_rgb(&self, size: (u32, u32)) -> Result<Vec<u8>, brachia_plot::PlotError> {
        let n = self.probot.n();
        let mut joints = vec![[0.0; 2]; n + 1];
        self.probot.joint_positions(&self.xt[..n], &mut joints);
        let reach: f64 = self.probot.params().links.iter().map(|l| l.length).sum();
        let t = self.spec.target;
        let scene = brachia_plot::FrameScene {
            size,
            bars: vec![[0.0, 0.0]],
            target: Some(t),
            obstacles: self
                .spec
                .obstacles
                .iter()
                .filter_map(|o| match o {
                    Obstacle::Circle(c) => Some(brachia_plot::Obstacle {
                        center: c.center,
                        radius: c.radius,
                    }),
                    _ => None,
                })
                .collect(),
            balls: Vec::new(),
            bounds: Some((
                (-reach).min(t[0] - 0.1),
                reach.max(t[0] + 0.1),
                (-reach).min(t[1] - 0.1),
                (0.3f64).max(t[1] + 0.1),
            )),
            stamp: format!("t = {:.2} s", self.time()),
        };
        brachia_plot::pose_frame_rgb(&scene, &joints)
    }
}
