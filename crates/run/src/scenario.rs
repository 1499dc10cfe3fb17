//! The scenario file: one experiment, declared.
//!
//! ```toml
//! params = "../params/paper.toml"       # robot parameters, relative to this file
//! [task]
//! q0 = [-2.35, 0.0, -1.55, 0.0]         # rad: q1 absolute from +x, the rest relative
//! qd0 = [0.0, 0.0, 0.0, 0.0]            # rad/s (optional, default at rest)
//! target = [0.8, 0.0]                   # m, the target bar in the grip frame
//! obstacles = [{ center = [0.55, -0.2], radius = 0.1 }]
//! [planner]                             # every field optional; see brachia::planning::PlannerSettings
//! swing_time = "auto"                   # or seconds
//! knot_dt = 0.03                        # default 0.03 (shooting); the paper's 0.01 for collocation
//! transcription = "multiple-shooting"   # (default) | euler | trapezoidal | hermite-simpson
//! q1_diag = [0.01, 0.01, 0.01, 0.01]
//! r1_diag = [1.0, 1.0, 1.0]
//! avoid_obstacles = true
//! [solver]                              # see brachia::planning::NlpSettings
//! backend = "ocp"                       # ocp (default; multiple-shooting only) | pounce | ripopt
//! [tracking]                            # see TrackingSettings (controller, MPC and PD settings)
//! controller = "mpc"                    # mpc | pd | open-loop | tvlqr
//! kalman = true                         # feed it through the Kalman filter ([tracking.estimator])
//! replan = { threshold_m = 0.01, latency_s = 0.02 }  # MPC + online re-planning (docs/replanning.md)
//! estimate_params = {}                  # online mass/inertia estimate (docs/estimation.md)
//! [plant]                               # see PlantSettings
//! kind = "rapier"                       # model (RK4) | rapier (physics engine with contacts)
//! substeps = 1
//! # in the plant only (the planner never sees them): free balls and fixed circles
//! obstacles = [{ kind = "ball", center = [0.02, -0.44], radius = 0.05, mass = 0.4, restitution = 0.3, gravity = false }]
//! [disturbances]                        # see brachia::sim::Disturbances and docs/robustness.md
//! mass_scale = [1.1, 0.9, 1.0, 1.0]     # per-link factors (also com_scale, inertia_scale, length_scale)
//! actuation_delay_s = 0.005             # also measurement_delay_s
//! motor_time_constant_s = 0.01
//! pushes = [{ t_s = 0.5, link = 4, point_m = 0.3, impulse_n_s = [0.0, 0.2] }]
//! ```

use brachia::control::{
    EstimateMethod, EstimatorSettings, MpcSettings, ParamEstimatorSettings, PdSettings,
    ReplanSettings, TvlqrSettings,
};
use brachia::limits;
use brachia::planning::{freefall_time, NlpSettings, PlannerSettings, SwingTask, SwingTime};
use brachia::sim::Disturbances;
use brachia::{Error, Robot};
use brachia_rapier::{Obstacle, RapierSettings};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A scenario as written in a TOML file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// A name for reports (default: the file stem).
    #[serde(default)]
    pub name: String,
    /// Robot parameters file, relative to the scenario file: a brachia TOML file or a URDF file
    /// (`.urdf`, read with the `[urdf]` table).
    pub params: PathBuf,
    /// How to read a URDF robot: its grip joint, tip, passive joints and ignored branches
    /// (docs/robots.md). Default none (a TOML robot).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub urdf: Option<brachia::urdf::UrdfOptions>,
    /// What to plan.
    pub task: SwingTask,
    /// Planner settings.
    #[serde(default)]
    pub planner: PlannerSettings,
    /// NLP solver settings.
    #[serde(default)]
    pub solver: NlpSettings,
    /// Closed-loop tracking settings (`brachia track`).
    #[serde(default)]
    pub tracking: TrackingSettings,
    /// The plant the controller runs against.
    #[serde(default)]
    pub plant: PlantSettings,
    /// What differs between the planner's world and the plant's (docs/robustness.md).
    #[serde(default)]
    pub disturbances: Disturbances,
}

/// Which controller tracks the plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum ControllerKind {
    /// Linear MPC (paper Section IV).
    #[default]
    Mpc,
    /// PD on the actuated joints plus the planned torque.
    Pd,
    /// Replay of the planned torques.
    OpenLoop,
    /// Time-varying LQR along the plan (`[tracking.tvlqr]`).
    Tvlqr,
}

/// Which plant the controller runs against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum PlantKind {
    /// RK4 integration of the model.
    #[default]
    Model,
    /// The rapier physics engine.
    Rapier,
}

/// Closed-loop settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackingSettings {
    /// Controller. Default MPC.
    pub controller: ControllerKind,
    /// MPC settings.
    pub mpc: MpcSettings,
    /// PD baseline settings.
    pub pd: PdSettings,
    /// TVLQR baseline settings (`controller = "tvlqr"`).
    pub tvlqr: TvlqrSettings,
    /// Feed the controller through the Kalman filter along the plan (`[tracking.estimator]`: noise
    /// model, known measurement and actuation delays). Default false.
    pub kalman: bool,
    /// Kalman filter settings (used when `kalman = true`).
    pub estimator: EstimatorSettings,
    /// Time simulated after the end of the planned swing (the reference holds its final state), s.
    /// Default 0.
    pub hold_s: f64,
    /// Control period, s. Default 0.001 (1 kHz).
    pub control_dt: f64,
    /// Sensor noise on q (rad) and qd (rad/s), standard deviations. Default 0.
    pub noise_q_std: f64,
    /// See `noise_q_std`. Default 0.
    pub noise_qd_std: f64,
    /// Noise seed. Default 0.
    pub seed: u64,
    /// Online re-planning around the MPC (see `brachia::control::ReplanSettings`,
    /// docs/replanning.md); absent: none. Only with `controller = "mpc"`. Default none.
    pub replan: Option<ReplanSettings>,
    /// Online estimation of the robot's masses and inertias, fed to the MPC and the re-planner
    /// (see `brachia::control::ParamEstimatorSettings`, docs/estimation.md); absent: none. Only
    /// with `controller = "mpc"` and without `kalman`. Default none.
    pub estimate_params: Option<ParamEstimatorSettings>,
}

impl Default for TrackingSettings {
    fn default() -> Self {
        TrackingSettings {
            controller: ControllerKind::Mpc,
            mpc: MpcSettings::default(),
            pd: PdSettings::default(),
            tvlqr: TvlqrSettings::default(),
            kalman: false,
            estimator: EstimatorSettings::default(),
            hold_s: 0.0,
            control_dt: 0.001,
            noise_q_std: 0.0,
            noise_qd_std: 0.0,
            seed: 0,
            replan: None,
            estimate_params: None,
        }
    }
}

/// Plant settings, including a deliberate mismatch between the planner's model and the plant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlantSettings {
    /// Plant kind. Default `model` (the RK4 model).
    pub kind: PlantKind,
    /// Factor on every link mass and inertia of the plant (1 = the planner's model). Default 1.
    pub mass_scale: f64,
    /// Integration sub-steps per control period (RK4 steps for the model plant, engine steps for the
    /// rapier plant). Default 1.
    pub substeps: usize,
    /// Obstacles that exist only in the plant's world (the planner does not know them): fixed circles
    /// (`kind = "circle"`) and free balls (`kind = "ball"`) the robot can knock away. Rapier plant only.
    /// The task's obstacles (`[task] obstacles`) are always added to the rapier world as fixed circles
    /// as well. Default none.
    pub obstacles: Vec<Obstacle>,
    /// Coulomb friction of the link capsules (rapier plant). Default 0.5.
    pub link_friction: f64,
    /// Restitution of the link capsules in [0, 1] (rapier plant). Default 0.
    pub link_restitution: f64,
}

impl PlantSettings {
    /// The rapier plant's settings.
    pub fn rapier(&self) -> RapierSettings {
        RapierSettings {
            substeps: self.substeps,
            link_friction: self.link_friction,
            link_restitution: self.link_restitution,
            ..RapierSettings::default()
        }
    }
}

impl Default for PlantSettings {
    fn default() -> Self {
        PlantSettings {
            kind: PlantKind::Model,
            mass_scale: 1.0,
            substeps: 1,
            obstacles: Vec::new(),
            link_friction: RapierSettings::default().link_friction,
            link_restitution: RapierSettings::default().link_restitution,
        }
    }
}

/// A scenario with its robot loaded and its paths resolved.
#[derive(Debug, Clone)]
pub struct LoadedScenario {
    /// The scenario (with `params` made absolute or relative to the working directory).
    pub scenario: Scenario,
    /// The validated robot.
    pub robot: Robot,
    /// Where it was read from.
    pub path: PathBuf,
}

/// Re-home an error of a settings section into the file it came from: the field of an
/// [`Error::InvalidValue`] gets the prefix `section.` and the source `src`; an [`Error::Dimension`] becomes an
/// invalid value of that section. Other errors pass through.
pub fn in_section(e: Error, src: &str, section: &str) -> Error {
    match e {
        Error::InvalidValue {
            field,
            value,
            reason,
            ..
        } => Error::InvalidValue {
            source_name: src.to_string(),
            field: if field.starts_with(&format!("{section}.")) {
                field
            } else {
                format!("{section}.{field}")
            },
            value,
            reason,
        },
        Error::Dimension {
            what,
            expected,
            got,
        } => Error::invalid(
            src,
            format!("{section}: {what}"),
            format!("{got} values"),
            format!("needs {expected}"),
        ),
        other => other,
    }
}

/// Parse TOML text into `T`; `source` names it in the error, with the dotted field the error lies in
/// and the parser's line, column and text ([`brachia::toml_path::toml_error`]).
pub fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, source: &str) -> Result<T, Error> {
    toml::from_str(text).map_err(|e| brachia::toml_path::toml_error(&e, text, source))
}

/// Read a text file of at most [`brachia::limits::MAX_TOML_BYTES`]; an I/O error names the path.
pub fn read_text(path: &Path) -> Result<String, Error> {
    brachia::limits::read_text_capped(path, brachia::limits::MAX_TOML_BYTES, "TOML file")
}

/// The first step of loading a scenario file `source` (swing or traverse): an empty `name` becomes
/// the file's stem, and `params` is resolved against `base_dir`.
pub(crate) fn resolve_name_and_params(
    name: &mut String,
    params: &mut PathBuf,
    source: &Path,
    base_dir: &Path,
) {
    if name.is_empty() {
        *name = source
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default();
    }
    *params = base_dir.join(&*params);
}

/// The `[planner]` and `[solver]` sections of the scenario file `src` checked for a robot of `n`
/// links and against each other (the backend); errors name the field as written
/// (`planner.knot_dt`, `solver.max_iter`).
pub(crate) fn check_solve_sections(
    planner: &PlannerSettings,
    solver: &NlpSettings,
    n: usize,
    src: &str,
) -> Result<(), Error> {
    planner
        .validate(n, src)
        .map_err(|e| in_section(e, src, "planner"))?;
    solver
        .validate()
        .map_err(|e| in_section(e, src, "solver"))?;
    planner.check_backend(solver, src)
}

/// Which sections of a scenario a command uses (and so validates).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Uses {
    /// Robot, task, planner and solver (`brachia plan`).
    Plan,
    /// Everything: also tracking and plant (`brachia track`, `brachia reproduce`).
    Track,
}

impl Scenario {
    /// Parse a scenario from TOML text; `source` names it in errors.
    pub fn from_toml_str(text: &str, source: &str) -> Result<Self, Error> {
        parse_toml(text, source)
    }

    /// Read a scenario file, load its robot and validate every section (nothing is solved).
    pub fn load(path: &Path) -> Result<LoadedScenario, Error> {
        Self::load_for(path, Uses::Track)
    }

    /// Read a scenario file, load its robot and validate the sections `uses` needs (nothing is solved):
    /// every value finite and in range, vectors of the robot's length, the start state inside the
    /// bounds, the swing's collocation grid and the closed loop's steps within [`brachia::limits`].
    /// Errors name the file, the field as written (`task.qd0[2]`, `tracking.mpc.horizon`), the value
    /// and the rule.
    pub fn load_for(path: &Path, uses: Uses) -> Result<LoadedScenario, Error> {
        let text = read_text(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        Self::load_str_for(&text, path, base, uses)
    }

    /// [`Scenario::load_for`] of TOML text: `source` names it in errors (and gives the default
    /// name, its stem), `base_dir` is the folder its relative `params` path is resolved against.
    pub fn load_str_for(
        text: &str,
        source: &Path,
        base_dir: &Path,
        uses: Uses,
    ) -> Result<LoadedScenario, Error> {
        let path = source;
        let src = path.display().to_string();
        let mut sc = Self::from_toml_str(text, &src)?;
        resolve_name_and_params(&mut sc.name, &mut sc.params, path, base_dir);
        let robot = brachia::urdf::load_robot(&sc.params, sc.urdf.as_ref(), &src)?;
        check_solve_sections(&sc.planner, &sc.solver, robot.n(), &src)?;
        let rename = |e: Error, section: &str| in_section(e, &src, section);
        brachia::planning::validate_task(&robot, &sc.task, &sc.planner, &src, "task.")?;
        let swing_time = match sc.planner.swing_time {
            SwingTime::Seconds(t) => t,
            SwingTime::Auto(_) => {
                let start_ee = robot.ee_position(&sc.task.q0);
                let x_mid = 0.5 * (start_ee[0] + sc.task.target[0]);
                let rule = match freefall_time(&robot, &sc.task.q0, x_mid) {
                    // no rule time: the planner searches from the locked chain's half period, up
                    // to twice it (brachia::planning::strategy::swing_time)
                    Err(Error::InfeasibleTask(m)) => {
                        brachia::planning::reference_swing_time(&robot, &sc.task.q0)
                            .ok_or(Error::InfeasibleTask(m))
                    }
                    other => other,
                };
                let tf = rule.map_err(|e| match e {
                    Error::InfeasibleTask(m) => Error::invalid(
                        &src,
                        "planner.swing_time",
                        "\"auto\"",
                        format!("{m}; give swing_time in seconds"),
                    ),
                    other => rename(other, "planner"),
                })?;
                2.0 * tf
            }
        };
        // a free swing time can end at its range's top: the grid and the run are sized by it
        let swing_time = sc.planner.longest_swing_time(swing_time);
        // an "auto" swing time of almost nothing: the geometry is the cause, not knot_dt
        let auto = matches!(sc.planner.swing_time, SwingTime::Auto(_));
        if auto && sc.planner.free_swing_time.is_none() && swing_time < MIN_AUTO_SWING_TIME_S {
            return Err(auto_too_short(&robot, &sc.task, swing_time, &src));
        }
        sc.planner
            .grid(robot.n(), swing_time, &src)
            .map_err(|e| rename(e, "planner"))?;
        let ls = LoadedScenario {
            scenario: sc,
            robot,
            path: path.to_path_buf(),
        };
        if uses == Uses::Track {
            ls.check_tracking(swing_time)?;
        }
        Ok(ls)
    }
}

/// Shortest swing time `swing_time = "auto"` may resolve to, s: twice the locked chain's free fall
/// to the midpoint is below it only when the target is at (or straight above or below) the hand's
/// start, which no grid step can mend.
pub const MIN_AUTO_SWING_TIME_S: f64 = 0.1;

/// The refusal of a `swing_time = "auto"` whose twice-the-free-fall time is below
/// [`MIN_AUTO_SWING_TIME_S`]: it names the swing time and the geometry that makes it so (a target at
/// the hand's start, or straight above or below it), never `knot_dt`.
fn auto_too_short(robot: &Robot, task: &SwingTask, t: f64, src: &str) -> Error {
    let ee = robot.ee_position(&task.q0);
    let at_start = (ee[0] - task.target[0]).hypot(ee[1] - task.target[1]);
    let why = if at_start < 1e-2 * robot.reach() {
        "the hand starts at the target: there is nothing to swing to".to_string()
    } else {
        format!(
            "the target [{}, {}] is about straight above or below the hand's start [{:.4}, {:.4}], \
             so the locked chain's fall to the midpoint takes almost no time",
            task.target[0], task.target[1], ee[0], ee[1]
        )
    };
    Error::invalid(
        src,
        "planner.swing_time",
        "\"auto\"",
        format!(
            "resolves to {t:.4} s (twice the locked chain's free fall to the midpoint between the \
             hand and the target), too short to plan: {why}; give swing_time in seconds or move \
             task.target"
        ),
    )
}

/// The model mismatch of `[disturbances]` on the robot `base`: every link's centre of mass, scaled by
/// `com_scale`, must stay on the link scaled by `length_scale`; a refusal names the factor that
/// moves it off (`disturbances.com_scale[i]`, or `disturbances.length_scale[i]` when the link is
/// shortened under it), not the robot's `com`.
pub(crate) fn check_mismatch(
    base: &brachia::model::RobotParams,
    d: &Disturbances,
    src: &str,
) -> Result<(), Error> {
    let f = |v: &Vec<f64>, i: usize| v.get(i).copied().unwrap_or(1.0);
    for (i, l) in base.links.iter().enumerate() {
        let (cs, ls) = (f(&d.com_scale, i), f(&d.length_scale, i));
        let (com, len) = (l.com * cs, l.length * ls);
        if com > len {
            let (field, v) = if cs > 1.0 || d.length_scale.is_empty() {
                ("com_scale", cs)
            } else {
                ("length_scale", ls)
            };
            return Err(Error::invalid(
                src,
                format!("disturbances.{field}[{i}]"),
                v,
                format!(
                    "link {}'s centre of mass would lie {com} m from its proximal joint (com {} m x \
                     com_scale {cs}), beyond its length {len} m (length {} m x length_scale {ls}): \
                     a centre of mass stays on its link",
                    i + 1,
                    l.com,
                    l.length
                ),
            ));
        }
    }
    Ok(())
}

impl LoadedScenario {
    /// Check the `[tracking]` and `[plant]` sections for a swing of `swing_time` seconds.
    pub(crate) fn check_tracking(&self, swing_time: f64) -> Result<(), Error> {
        let (sc, n) = (&self.scenario, self.robot.n());
        let src = self.path.display().to_string();
        let rename = |e: Error, section: &str| in_section(e, &src, section);
        sc.tracking
            .mpc
            .validate(n)
            .map_err(|e| rename(e, "tracking.mpc"))?;
        sc.tracking
            .pd
            .validate(n)
            .map_err(|e| rename(e, "tracking.pd"))?;
        sc.tracking
            .tvlqr
            .validate(n)
            .map_err(|e| rename(e, "tracking.tvlqr"))?;
        sc.tracking
            .estimator
            .validate()
            .map_err(|e| rename(e, "tracking.estimator"))?;
        let t = &sc.tracking;
        if let Some(e) = &t.estimate_params {
            e.validate(&src)
                .map_err(|e| rename(e, "tracking.estimate_params"))?;
            if e.method == EstimateMethod::Ekf && self.robot.off_axis() {
                return Err(Error::invalid(
                    &src,
                    "tracking.estimate_params.method",
                    "ekf",
                    "the joint filter needs every centre of mass on its link's axis (com_across = 0): \
                     use method = \"windows\" for this robot",
                ));
            }
            if t.controller != ControllerKind::Mpc || t.kalman {
                return Err(Error::invalid(
                    &src,
                    "tracking.estimate_params",
                    format!("controller {:?}, kalman {}", t.controller, t.kalman),
                    "the mass estimate feeds the MPC only: set tracking.controller = \"mpc\" \
                     without tracking.kalman, or remove tracking.estimate_params",
                ));
            }
        }
        if let Some(r) = &t.replan {
            r.validate(&src).map_err(|e| rename(e, "tracking.replan"))?;
            // the re-plans run on their own mesh (knot_dt_s) over the same swing: its grid is
            // checked here, under its own name, not at the first re-plan as `planner.knot_dt`
            let mesh = PlannerSettings {
                knot_dt: r.knot_dt_s,
                ..sc.planner.clone()
            };
            mesh.grid(n, swing_time, &src).map_err(|e| match e {
                Error::InvalidValue { value, reason, .. } => Error::InvalidValue {
                    source_name: src.clone(),
                    field: "tracking.replan.knot_dt_s".into(),
                    value,
                    reason: reason.replace("knot_dt must", "knot_dt_s must"),
                },
                other => other,
            })?;
            if t.controller != ControllerKind::Mpc {
                return Err(Error::invalid(
                    &src,
                    "tracking.replan",
                    format!("controller {:?}", t.controller),
                    "online re-planning wraps the MPC only: set tracking.controller = \"mpc\" or \
                     remove tracking.replan",
                ));
            }
        }
        for (field, v) in [
            ("tracking.hold_s", t.hold_s),
            ("tracking.noise_q_std", t.noise_q_std),
            ("tracking.noise_qd_std", t.noise_qd_std),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(&src, field, v, "must be finite and >= 0"));
            }
        }
        let hmax = limits::MAX_HOLD_S;
        if t.hold_s > hmax {
            return Err(Error::invalid(
                &src,
                "tracking.hold_s",
                t.hold_s,
                format!("must be at most {hmax} s (brachia::limits::MAX_HOLD_S)"),
            ));
        }
        for (field, v) in [
            ("tracking.noise_q_std", t.noise_q_std),
            ("tracking.noise_qd_std", t.noise_qd_std),
        ] {
            if v > 10.0 {
                return Err(Error::invalid(&src, field, v, "must be at most 10"));
            }
        }
        if !(t.control_dt.is_finite() && t.control_dt > 0.0 && t.control_dt <= 0.1) {
            return Err(Error::invalid(
                &src,
                "tracking.control_dt",
                t.control_dt,
                "must be in (0, 0.1] s",
            ));
        }
        let duration = swing_time + t.hold_s;
        let smax = limits::MAX_RUN_STEPS;
        let Some(steps) = limits::count(duration, t.control_dt, smax) else {
            return Err(Error::invalid(
                &src,
                "tracking.control_dt",
                t.control_dt,
                format!(
                    "swing {swing_time:.3} s + hold {} s would take more than {smax} control steps \
                     (brachia::limits::MAX_RUN_STEPS); control_dt must be >= {:.3e} s",
                    t.hold_s,
                    duration / smax as f64
                ),
            ));
        };
        let pl = &sc.plant;
        if !(pl.mass_scale.is_finite() && pl.mass_scale > 0.0 && pl.mass_scale <= 100.0) {
            return Err(Error::invalid(
                &src,
                "plant.mass_scale",
                pl.mass_scale,
                "must be in (0, 100]",
            ));
        }
        let kmax = limits::MAX_SUBSTEPS;
        if pl.substeps == 0 || pl.substeps > kmax {
            return Err(Error::invalid(
                &src,
                "plant.substeps",
                pl.substeps,
                format!("must be 1..={kmax}"),
            ));
        }
        let total = steps as u64 * pl.substeps as u64;
        if total > limits::MAX_SIM_STEPS {
            return Err(Error::invalid(
                &src,
                "plant.substeps",
                pl.substeps,
                format!(
                    "{steps} control steps x {} substeps = {total} integration steps; at most {} \
                     (brachia::limits::MAX_SIM_STEPS)",
                    pl.substeps,
                    limits::MAX_SIM_STEPS
                ),
            ));
        }
        pl.rapier().validate(&src).map_err(|e| rename(e, "plant"))?;
        if pl.obstacles.len() > brachia::planning::MAX_OBSTACLES {
            return Err(Error::invalid(
                &src,
                "plant.obstacles",
                format!("{} obstacles", pl.obstacles.len()),
                format!("at most {}", brachia::planning::MAX_OBSTACLES),
            ));
        }
        for (i, o) in pl.obstacles.iter().enumerate() {
            o.validate(&src, i).map_err(|e| rename(e, "plant"))?;
        }
        let d = &sc.disturbances;
        d.validate(n, t.control_dt, &src)
            .map_err(|e| rename(e, "disturbances"))?;
        if (d.noise_q_std > 0.0 || d.noise_qd_std > 0.0)
            && (t.noise_q_std > 0.0 || t.noise_qd_std > 0.0)
        {
            return Err(Error::invalid(
                &src,
                "disturbances.noise_q_std",
                d.noise_q_std,
                "sensor noise is given twice: use [disturbances] noise_q_std / noise_qd_std or \
                 [tracking] noise_q_std / noise_qd_std, not both",
            ));
        }
        let base = self.robot.params().clone().with_mass_scale(pl.mass_scale);
        check_mismatch(&base, d, &src)?;
        let params = d.plant_params(&base);
        Robot::from_params(params.clone(), &src).map_err(|e| rename(e, "disturbances"))?;
        // a push the run never applies (after the swing, or off its link) is refused, not listed in
        // the report as if it had happened
        let shortest = sc.planner.free_swing_time.map_or(swing_time, |r| r[0]);
        for (i, p) in d.pushes.iter().enumerate() {
            if p.t_s >= shortest {
                return Err(Error::invalid(
                    &src,
                    format!("disturbances.pushes[{i}].t_s"),
                    p.t_s,
                    format!(
                        "a push happens during the swing: t_s must be below the swing time \
                         ({shortest:.4} s{})",
                        if sc.planner.free_swing_time.is_some() {
                            ", the shortest of planner.free_swing_time"
                        } else {
                            ""
                        }
                    ),
                ));
            }
            let len = params.links[p.link - 1].length;
            if p.point_m > len {
                return Err(Error::invalid(
                    &src,
                    format!("disturbances.pushes[{i}].point_m"),
                    p.point_m,
                    format!(
                        "a point along link {}: at most its length on the plant, {len} m",
                        p.link
                    ),
                ));
            }
        }
        Ok(())
    }
}
