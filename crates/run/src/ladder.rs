//! The traverse scenario file (`brachia traverse`): its `[ladder]` section, its loading and the checks
//! made before anything is planned. The ladder itself (bars, the reach rule, the grip-switch map, the
//! grip and world frames, each swing's task) is the library's [`brachia::ladder`].
//!
//! Conventions (as in `brachia`): **world frame** x right, y up, gravity along -y, metres; bar 0 is where
//! the robot starts (its grip), the last bar is the goal. Angles: `q[0]` absolute angle of link 1 from +x,
//! `q[1..]` relative; the start state `ladder.q0`, `ladder.qd0` is given in the grip frame of bar 0 with
//! the chain as written in the parameters file (link 1 at the grip). SI units throughout.
//!
//! ```toml
//! params = "../params/paper.toml"
//! [ladder]
//! bars = [{ x = 0.0, y = 0.0 }, { x = 1.0, y = 0.0 }, { x = 2.0, y = 0.1 }]   # or [[ladder.bars]] tables
//! q0 = [-2.35, 0.0, -1.55, 0.0]    # optional: default = the swing hand on a virtual bar behind bar 0
//! capture_radius = 0.02            # m (default 0.02)
//! capture_speed = 0.1              # m/s (default 0.1)
//! lookahead = 1                    # swings planned together at every bar (default 1: one by one)
//! lookahead_switch = "free"        # "free" or "rest": the joint plan's inner switch states (default free)
//! obstacles = [{ center = [1.5, -0.3], radius = 0.08 }]   # world frame
//! [planner]    # as in every scenario (swing_time "auto" = 2 T_freefall per swing)
//! [solver]
//! [tracking]
//! [plant]      # kind = "model" (RK4) or "rapier" (physics engine; obstacles = balls, world frame)
//! [disturbances]  # mass_scale, com_scale, inertia_scale per link of the parameters file
//! [disturbances.ball]  # a ball hit on one swing (rapier plant): swing, at_s, mass, radius, restitution
//! ```
//!
//! **Reach rule** (checked before anything is planned, an error names the bar): consecutive bars
//! between [`MIN_SPACING_OF_SPAN`] and [`MAX_SPACING_OF_SPAN`] times the arm span
//! ([`brachia::ladder::check_bars`]).

use crate::scenario::{
    check_solve_sections, in_section, parse_toml, read_text, resolve_name_and_params,
    LoadedScenario, PlantKind, PlantSettings, Scenario, TrackingSettings,
};
pub use brachia::ladder::{
    check_bars, default_hang, joint_swings_json, swing_time, Bar, MAX_BARS, MAX_SPACING_OF_SPAN,
    MIN_SPACING_OF_SPAN,
};
use brachia::model::Circle;
use brachia::planning::{NlpSettings, PlannerSettings};
use brachia::sim::Disturbances;
use brachia::{Error, Robot};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

fn default_capture_radius() -> f64 {
    0.02
}

fn default_capture_speed() -> f64 {
    0.1
}

fn default_lookahead() -> usize {
    1
}

/// The switch states of the joint plans of `[ladder] lookahead = k > 1` (docs/ladders.md,
/// "Lookahead").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LookaheadSwitch {
    /// Free but for the capture (the hand on the bar and at rest): each swing may end with the chain
    /// moving in the way that suits the swings after it. The cheapest on an undisturbed ladder.
    #[default]
    Free,
    /// The rest condition `planner.bounds.qd_end_max` at every switch too (every joint rate at most
    /// `qd_end_max` when a bar is caught), as when each swing is planned alone: the joint plan only
    /// chooses the switch pose. The variant that completes the disturbed rapier ladders: a chain
    /// that arrives moving is what a heavier plant and a hit make miss the capture speed.
    Rest,
}

/// The `[ladder]` section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ladder {
    /// Bars in traverse order (at least 2, at most [`MAX_BARS`]); the robot starts on bar 0.
    pub bars: Vec<Bar>,
    /// Start joint angles at bar 0 (n values, rad); empty = the default hang: the swing hand on a
    /// virtual bar mirrored behind bar 0 (`bar0 - (bar1 - bar0)`), found by inverse kinematics.
    #[serde(default)]
    pub q0: Vec<f64>,
    /// Start joint velocities (n values, rad/s); empty = at rest.
    #[serde(default)]
    pub qd0: Vec<f64>,
    /// Obstacles, world frame (the planner avoids them on every swing).
    #[serde(default)]
    pub obstacles: Vec<Circle>,
    /// Capture radius: the hand closes on the bar when it ends its swing within this distance, m.
    /// Default 0.02.
    #[serde(default = "default_capture_radius")]
    pub capture_radius: f64,
    /// Capture speed: the largest hand speed at which the grip can close, m/s. Default 0.1.
    #[serde(default = "default_capture_speed")]
    pub capture_speed: f64,
    /// Swings planned together at every bar: 1 (the default) plans each swing alone; k > 1 plans
    /// each swing as the first of a joint plan over the next k swings (fewer near the goal;
    /// [`brachia::planning::plan_joint_swings`], solver backend `ocp`), again at every bar from the
    /// state the switch left, so each swing ends in the state best for the swings after it
    /// (docs/ladders.md, "Lookahead"). 1 to [`brachia::planning::MAX_JOINT_SWINGS`].
    #[serde(default = "default_lookahead")]
    pub lookahead: usize,
    /// The joint plans' inner switch states when `lookahead > 1` (ignored at 1). Default
    /// [`LookaheadSwitch::Free`].
    #[serde(default)]
    pub lookahead_switch: LookaheadSwitch,
}

impl Ladder {
    /// The rule the gripper closes by: the capture rule of every run ([`crate::success`]) with
    /// `capture_radius` and `capture_speed`.
    pub fn capture_rule(&self) -> crate::success::CaptureRule {
        crate::success::CaptureRule {
            radius_m: self.capture_radius,
            speed_m_s: self.capture_speed,
        }
    }
}

/// A traverse scenario as written in a TOML file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LadderScenario {
    /// A name for reports (default: the file stem).
    #[serde(default)]
    pub name: String,
    /// Robot parameters file, relative to the scenario file: a brachia TOML file or a URDF file
    /// (`.urdf`, read with the `[urdf]` table).
    pub params: PathBuf,
    /// How to read a URDF robot (docs/robots.md). Default none (a TOML robot).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub urdf: Option<brachia::urdf::UrdfOptions>,
    /// The bars, start state, obstacles and capture rule.
    pub ladder: Ladder,
    /// Planner settings (every swing).
    #[serde(default)]
    pub planner: PlannerSettings,
    /// NLP solver settings.
    #[serde(default)]
    pub solver: NlpSettings,
    /// Closed-loop settings (every swing).
    #[serde(default)]
    pub tracking: TrackingSettings,
    /// The plant.
    #[serde(default)]
    pub plant: PlantSettings,
    /// Plant-model mismatch over the whole traverse: only the per-link factors `mass_scale`,
    /// `com_scale`, `inertia_scale` (link i of the parameters file, whichever hand holds), and a
    /// ball hit on one swing (`[disturbances.ball]`).
    #[serde(default)]
    pub disturbances: LadderDisturbances,
}

fn default_ball_restitution() -> f64 {
    0.3
}

/// A ball hit on one swing of a traverse (`[disturbances.ball]`, rapier plant): when swing `swing`
/// starts, a floating ball (no gravity, at rest) is put into the world on that swing's planned EE
/// path at `at_s` seconds into the swing ([`brachia_rapier::Ball::on_path`], the knot at or before
/// `at_s`), so the swinging hand following the plan runs into it then. Neither the planner nor the
/// controller knows it. The model plant simulates no contacts and ignores it (as `brachia track`
/// ignores `[plant] obstacles` there); the report says so (`ball.ignored`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SwingBall {
    /// The swing (0 = from bar 0 to bar 1); less than the number of swings.
    pub swing: usize,
    /// Time into the swing at which the planned hand reaches the ball, s (> 0 and within the swing's
    /// planned time: checked when the swing is planned).
    pub at_s: f64,
    /// Mass, kg (> 0).
    pub mass: f64,
    /// Radius, m (> 0, at most 0.5).
    pub radius: f64,
    /// Restitution in [0, 1]. Default 0.3 (as the Monte Carlo benchmark's balls).
    #[serde(default = "default_ball_restitution")]
    pub restitution: f64,
}

impl SwingBall {
    /// Check the values that do not need a plan, for a ladder of `swings` swings; errors name
    /// `disturbances.ball.<field>`.
    fn validate(&self, swings: usize, src: &str) -> Result<(), Error> {
        let field = |f: &str| format!("disturbances.ball.{f}");
        if self.swing >= swings {
            return Err(Error::invalid(
                src,
                field("swing"),
                self.swing,
                format!("must name a swing of the ladder: 0..{swings} ({swings} swings)"),
            ));
        }
        for (name, v, max) in [
            ("at_s", self.at_s, 1e3),
            ("mass", self.mass, 1e3),
            ("radius", self.radius, 0.5),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                return Err(Error::invalid(
                    src,
                    field(name),
                    v,
                    format!("must be a finite number in (0, {max}]"),
                ));
            }
        }
        if !(0.0..=1.0).contains(&self.restitution) {
            return Err(Error::invalid(
                src,
                field("restitution"),
                self.restitution,
                "must lie in [0, 1]",
            ));
        }
        Ok(())
    }
}

/// The `[disturbances]` section of a traverse: the scenario's [`Disturbances`] (of which a traverse
/// takes only the per-link factors) and an optional ball hit on one swing. Written as one table:
/// the fields of [`Disturbances`] and a `ball` sub-table.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LadderDisturbances {
    /// The plant-model mismatch (per-link factors).
    pub model: Disturbances,
    /// A ball hit on one swing.
    pub ball: Option<SwingBall>,
}

impl Serialize for LadderDisturbances {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::Error as _;
        let mut v = serde_json::to_value(&self.model).map_err(S::Error::custom)?;
        if let Some(m) = v.as_object_mut() {
            // TOML has no null: leave unset options out
            m.retain(|_, x| !x.is_null());
            if let Some(b) = &self.ball {
                m.insert(
                    "ball".into(),
                    serde_json::to_value(b).map_err(S::Error::custom)?,
                );
            }
        }
        v.serialize(s)
    }
}

impl<'de> Deserialize<'de> for LadderDisturbances {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        let mut t = toml::Table::deserialize(d)?;
        let ball = t
            .remove("ball")
            .map(|v| SwingBall::deserialize(v).map_err(|e| D::Error::custom(format!("ball: {e}"))))
            .transpose()?;
        let model = Disturbances::deserialize(toml::Value::Table(t)).map_err(D::Error::custom)?;
        Ok(LadderDisturbances { model, ball })
    }
}

/// The `[disturbances]` a traverse accepts: per-link `mass_scale`, `com_scale`, `inertia_scale`
/// (validated as in every scenario); any other field is refused, naming it.
fn check_disturbances(d: &Disturbances, n: usize, control_dt: f64, src: &str) -> Result<(), Error> {
    d.validate(n, control_dt, src)
        .map_err(|e| in_section(e, src, "disturbances"))?;
    let kept = Disturbances {
        mass_scale: d.mass_scale.clone(),
        com_scale: d.com_scale.clone(),
        inertia_scale: d.inertia_scale.clone(),
        ..Disturbances::default()
    };
    if *d != kept {
        let (a, b) = (
            serde_json::to_value(d).unwrap_or_default(),
            serde_json::to_value(&kept).unwrap_or_default(),
        );
        let field = a
            .as_object()
            .and_then(|m| m.iter().find(|(k, v)| b.get(k.as_str()) != Some(v)))
            .map(|(k, v)| (k.clone(), v.to_string()))
            .unwrap_or_default();
        return Err(Error::invalid(
            src,
            format!("disturbances.{}", field.0),
            field.1,
            "a traverse takes only the per-link factors mass_scale, com_scale and inertia_scale \
             from [disturbances], and a ball hit on one swing ([disturbances.ball], rapier plant)",
        ));
    }
    Ok(())
}

/// A traverse scenario with its robot loaded, its start state resolved and every check passed.
#[derive(Debug, Clone)]
pub struct LoadedLadder {
    /// The scenario (`params` resolved against the scenario's folder).
    pub scenario: LadderScenario,
    /// The validated robot (link 1 at bar 0).
    pub robot: Robot,
    /// Where it was read from.
    pub path: PathBuf,
    /// The start state `[q0, qd0]` at bar 0 (default hang filled in).
    pub x0: Vec<f64>,
}

impl LadderScenario {
    /// Read a traverse scenario, load its robot and check everything that can be checked before
    /// planning: the settings sections, the bars (count, values, the reach rule), the capture rule, the
    /// start state (or the default hang), the first swing's task and closed-loop limits. Errors name the
    /// file, the field as written (`ladder.bars[3]`, `ladder.q0[1]`), the value and the rule.
    pub fn load(path: &Path) -> Result<LoadedLadder, Error> {
        let text = read_text(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        Self::load_str(&text, path, base)
    }

    /// [`LadderScenario::load`] of TOML text: `source` names it in errors (and gives the default
    /// name, its stem), `base_dir` is the folder its relative `params` path is resolved against.
    pub fn load_str(text: &str, source: &Path, base_dir: &Path) -> Result<LoadedLadder, Error> {
        let path = source;
        let src = path.display().to_string();
        let mut sc: LadderScenario = parse_toml(text, &src)?;
        resolve_name_and_params(&mut sc.name, &mut sc.params, path, base_dir);
        let robot = brachia::urdf::load_robot(&sc.params, sc.urdf.as_ref(), &src)?;
        check_solve_sections(&sc.planner, &sc.solver, robot.n(), &src)?;
        let n = robot.n();
        let rename = |e: Error, section: &str| in_section(e, &src, section);
        let l = &sc.ladder;
        check_bars(&robot, &l.bars, &src)?;
        for (field, v, max) in [
            ("ladder.capture_radius", l.capture_radius, 1.0),
            ("ladder.capture_speed", l.capture_speed, 10.0),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                return Err(Error::invalid(
                    &src,
                    field,
                    v,
                    format!("must be in (0, {max}]"),
                ));
            }
        }
        let max_look = brachia::planning::MAX_JOINT_SWINGS;
        if !(1..=max_look).contains(&l.lookahead) {
            return Err(Error::invalid(
                &src,
                "ladder.lookahead",
                l.lookahead,
                format!("must be 1 to {max_look} (swings planned together at every bar)"),
            ));
        }
        if l.lookahead > 1 && sc.solver.backend != brachia::planning::Backend::Ocp {
            return Err(Error::invalid(
                &src,
                "ladder.lookahead",
                l.lookahead,
                "swings planned together need the Riccati backend: set solver.backend = \"ocp\" \
                 (or lookahead = 1)",
            ));
        }
        if l.lookahead > 1 {
            // the joint plan of the lookahead plans at fixed swing times (docs/ladders.md)
            sc.planner
                .refuse_free_swing_time(
                    &src,
                    "a ladder with lookahead > 1 (a joint multi-swing plan)",
                )
                .map_err(|e| rename(e, "planner"))?;
        }
        if sc.plant.kind == PlantKind::Model && !sc.plant.obstacles.is_empty() {
            return Err(Error::invalid(
                &src,
                "plant.obstacles",
                format!("{} obstacles", sc.plant.obstacles.len()),
                "the model plant simulates no contacts: run them on the rapier plant \
                 (plant.kind = \"rapier\"), or put obstacles the planner avoids in ladder.obstacles",
            ));
        }
        check_disturbances(&sc.disturbances.model, n, sc.tracking.control_dt, &src)?;
        crate::scenario::check_mismatch(robot.params(), &sc.disturbances.model, &src)?;
        if let Some(b) = &sc.disturbances.ball {
            b.validate(l.bars.len() - 1, &src)?;
        }
        let q0 = if l.q0.is_empty() {
            default_hang(&robot, &l.bars, &sc.planner).ok_or_else(|| {
                Error::invalid(
                    &src,
                    "ladder.q0",
                    "[] (the default hang)",
                    "no pose within planner.bounds puts the swing hand on the virtual bar behind \
                     bar 0; give ladder.q0",
                )
            })?
        } else {
            l.q0.clone()
        };
        // the first swing as the traverse runs it: the grip on bar 0 where the ladder puts it (world
        // frame), the target and the obstacles moved into its grip frame
        let first = swing_scenario(&sc, &q0, &l.qd0, l.bars[0].p(), 1);
        let qd0 =
            brachia::planning::validate_task(&robot, &first.task, &sc.planner, &src, "ladder.")
                .map_err(|e| match e {
                    // the first swing's target is bar 1: name it
                    Error::InvalidValue {
                        source_name,
                        field,
                        value,
                        reason,
                    } if field == "ladder.target" => Error::InvalidValue {
                        source_name,
                        field: "ladder.bars[1]".into(),
                        value,
                        reason,
                    },
                    other => other,
                })?;
        let t = swing_time(&robot, &q0, first.task.target, &sc.planner).map_err(|e| match e {
            Error::InfeasibleTask(m) => Error::invalid(
                &src,
                "planner.swing_time",
                "\"auto\"",
                format!("{m} (first swing); give swing_time in seconds"),
            ),
            other => rename(other, "planner"),
        })?;
        // a free swing time can end at its range's top: the grid and the run are sized by it
        let t = sc.planner.longest_swing_time(t);
        sc.planner
            .grid(robot.n(), t, &src)
            .map_err(|e| rename(e, "planner"))?;
        let ls = LoadedScenario {
            scenario: first,
            robot: robot.clone(),
            path: path.to_path_buf(),
        };
        ls.check_tracking(t)?;
        let x0 = [q0, qd0].concat();
        Ok(LoadedLadder {
            scenario: sc,
            robot,
            path: path.to_path_buf(),
            x0,
        })
    }
}

/// The one-swing scenario of the swing to bar `to` from state `(q0, qd0)` with the grip at `grip`
/// (world): the target and the obstacles moved into the grip frame, every other section shared.
pub fn swing_scenario(
    sc: &LadderScenario,
    q0: &[f64],
    qd0: &[f64],
    grip: [f64; 2],
    to: usize,
) -> Scenario {
    Scenario {
        name: format!("{} swing to bar {to}", sc.name),
        params: sc.params.clone(),
        urdf: sc.urdf.clone(),
        task: brachia::ladder::swing_task(&sc.ladder.bars, &sc.ladder.obstacles, q0, qd0, grip, to),
        planner: sc.planner.clone(),
        solver: sc.solver.clone(),
        tracking: sc.tracking.clone(),
        plant: sc.plant.clone(),
        disturbances: Default::default(),
    }
}

/// The first `swings` swings of the ladder planned jointly and swing by swing
/// ([`brachia::planning::plan_joint_swings`]; docs/ladders.md, "The joint multi-swing plan"): from
/// the ladder's start state at bar 0 to bar `swings`, with its obstacles, planner and solver settings
/// (the rest condition `bounds.qd_end_max` at the last bar of the joint plan, and at its inner switches
/// with `rest_at_switches`). Errors on `swings` of 0 or past the last bar, and as `plan_joint_swings`.
pub fn joint_swings(
    ll: &LoadedLadder,
    swings: usize,
    rest_at_switches: bool,
) -> Result<brachia::planning::JointSwingPlan, Error> {
    let sc = &ll.scenario;
    let bars = &sc.ladder.bars;
    if swings == 0 || swings >= bars.len() {
        return Err(Error::invalid(
            ll.path.display().to_string(),
            "swings",
            swings,
            format!(
                "must be 1 to {} (the ladder's bars less one)",
                bars.len() - 1
            ),
        ));
    }
    let task = brachia::ladder::joint_swing_task(
        ll.x0.clone(),
        bars[0].p(),
        &bars[1..=swings],
        &sc.ladder.obstacles,
        rest_at_switches,
    );
    brachia::planning::plan_joint_swings(&ll.robot, &task, &sc.planner, &sc.solver)
}
