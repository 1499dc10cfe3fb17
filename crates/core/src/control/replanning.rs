//! Online re-planning around a tracking controller (docs/replanning.md).
//!
//! [`Replanning`] holds a persistent planner ([`SwingPlanner`], usually on a coarse mesh) and a
//! tracking controller (usually the [`crate::control::Mpc`]). Every `check_period_s` it predicts the
//! capture miss ([`super::replan_gate`]): a rollout of the current model (the planner's robot, or the
//! estimate [`super::Adaptive`] passes in through [`Controller::set_model`]) from the measured state to
//! the swing's end T (RK4 steps of `predict_dt_s`) under TVLQR feedback along the tracked reference,
//! `tau^d` at the step's midpoint minus `K (x - x^d)`, clamped to the robot's limits
//! ([`MissPrediction::Feedback`], the default: a drift that feedback corrects predicts no miss) or
//! under its feed-forward torque only ([`MissPrediction::OpenLoop`]), corrected by the same rollout's
//! error on the planner's robot from the reference's own state (the steps do not align with the
//! plan's torque steps: a 10 ms rollout of the paper's swing from its exact start misses the bar by
//! 7 cm, 1 ms steps by 1.8 mm), and measured to the bar. When the predicted miss exceeds
//! `threshold_m` (and a re-plan is allowed: at most `max_replans`, `min_spacing_s` after the last
//! trigger, `min_remaining_s` before T, none pending), it re-plans from the measured state at that
//! time to the same bar over the remaining time, warm-started from the planner's current solution
//! ([`crate::planning::SwingPlanner::replan`]); when the current model is an estimate, on a planner
//! built for it first (planned cold from the plan first tracked). A converged re-plan is adopted
//! only when its own predicted capture, from the same state on the same model, beats continuing the
//! current plan by more than `adopt_margin_m` (`compare_before_adopting`). The tracking controller
//! keeps tracking the old plan until the new one is "ready": `latency_s` after the trigger
//! (configured, which makes runs reproducible; by default the measured wall time of the re-plan,
//! which is not). The switch happens at the first control step at or after that time (the latency
//! rounded up to control periods), through [`Controller::set_reference`]. A re-plan that does not
//! converge (or misses the bar by more than 1 mm, or is not predicted better) is recorded and not
//! adopted.
//!
//! With `average_steps > 1` the prediction, the re-plan and the comparisons start from the measured
//! state averaged over the last control steps relative to the tracked plan (sensor noise on one
//! measurement otherwise moves the prediction by millimetres); with `compare_at_switch` a pending
//! re-plan is compared with continuing once more at its switch, from the state measured then, and
//! dropped unless still predicted better.
//!
//! Units: s, m, rad, rad/s, N m; state `x = [q (n), qd (n)]`, torques of joints 2..n. The plan's
//! times are absolute (the new plan's samples start at the trigger time).

use super::replan_gate::{CapturePredictor, PlanUnderTest, StateAverage};
use super::{ControlInfo, Controller, Tvlqr, TvlqrSettings};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::planning::{
    Backend, NlpSettings, PlannerSettings, SolveStatus, SwingPlanner, SwingTask, SwingTime,
    Transcription,
};
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Instant;

/// Least `check_period_s`, s: one control period at 1 kHz (with a smaller period every control step
/// predicts, and a tiny one such as 1e-300 s only multiplies the work).
pub const MIN_CHECK_PERIOD_S: f64 = 1e-3;

/// Least `check_period_s x predict_dt_s`, s^2: bounds the rollout work to `2 T / 1e-6` RK4 steps per
/// simulated second (the defaults give 1e-4).
pub const MIN_CHECK_TIMES_STEP_S2: f64 = 1e-6;

/// Most re-plans one run may do (`max_replans` is refused above it; the event log is allocated once).
pub const MAX_REPLANS: usize = 100;

/// Most control steps the measured state is averaged over (`average_steps`).
pub const MAX_AVERAGE_STEPS: usize = 1000;

/// A re-planned swing must end this close to the bar to be adopted, m.
const ADOPT_EE_ERROR_M: f64 = 1e-3;

/// How [`Replanning`] predicts the capture miss.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MissPrediction {
    /// The rollout is closed by TVLQR feedback along the tracked plan (default gains,
    /// [`TvlqrSettings::default`]), clamped to the torque limits: it predicts where a tracking
    /// controller ends, so a slow drift that feedback corrects (model mismatch, sensor noise) predicts
    /// no miss, and only a deviation the limited torques cannot take back (a hit) does.
    #[default]
    Feedback,
    /// The rollout applies the plan's feed-forward torque only: it ignores the feedback the tracking
    /// controller adds and over-estimates the miss, by the most early in the swing.
    OpenLoop,
}

/// Settings of [`Replanning`] (scenario section `[tracking] replan = { ... }`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReplanSettings {
    /// Re-plan when the predicted capture miss exceeds this, m. Default 0.01.
    pub threshold_m: f64,
    /// How often the miss is predicted, s. Default 0.01.
    pub check_period_s: f64,
    /// RK4 step of the prediction rollout, s, in [1e-4, 0.1]. Default 0.01.
    pub predict_dt_s: f64,
    /// Most re-plans per run (at most [`MAX_REPLANS`]). Default 3.
    pub max_replans: usize,
    /// Least time between two re-plan triggers, s (at most the longest swing,
    /// [`crate::limits::MAX_SWING_TIME_S`]). Default 0.1.
    pub min_spacing_s: f64,
    /// No re-plan with less than this left before T, s (at most
    /// [`crate::limits::MAX_SWING_TIME_S`]). Default 0.15.
    pub min_remaining_s: f64,
    /// Time from a re-plan's trigger to the switch of references, s; `None`: the measured wall time
    /// of the re-plan (solve and plan building), which makes a run irreproducible. At most
    /// [`crate::limits::MAX_SWING_TIME_S`]. Default `None`.
    pub latency_s: Option<f64>,
    /// Knot interval of the re-planning mesh that [`Replanning::build`] plans on, s (the planner
    /// keeps its interval count, so re-plans get finer as the swing runs). Default 0.03 (the paper's
    /// swing planned at 30 ms knots replays within 1 mm of the bar).
    pub knot_dt_s: f64,
    /// How the miss is predicted. Default [`MissPrediction::Feedback`].
    pub prediction: MissPrediction,
    /// Adopt a converged re-plan only when its predicted capture error beats that of continuing the
    /// current plan (both predicted from the same state on the current model,
    /// docs/replanning.md "Adopting a re-plan"). Default true.
    pub compare_before_adopting: bool,
    /// How much smaller the re-plan's predicted capture error must be than continuing's, m. Default
    /// 0.002.
    pub adopt_margin_m: f64,
    /// How often the copy of the tracking controller is called in the adoption test's rollouts, s
    /// (the tracking controller is copied when it can be, [`Controller::clone_box`]; else the TVLQR
    /// rollout of the miss prediction stands in). Default 0.001.
    pub adopt_control_period_s: f64,
    /// Re-plan only when the predicted miss exceeds `threshold_m` on this many checks in a row
    /// (at least 1). Default 1.
    pub confirm_checks: usize,
    /// Compare an adopted re-plan with continuing once more at its switch, from the state
    /// measured then, and drop it unless it still beats continuing by more than `adopt_margin_m`
    /// (docs/replanning.md "Comparing again at the switch"; only with `compare_before_adopting`,
    /// refused without it).
    /// The re-plan starts from the state measured at the trigger, sensor noise included, so the
    /// comparison from that same state favours it; the state measured at the switch carries
    /// other noise. Default false.
    pub compare_at_switch: bool,
    /// Predict the miss, re-plan and compare from the measured state averaged over this many
    /// control steps (the last ones, each relative to the tracked plan at its time; 1: the
    /// state measured at the check alone; at most [`MAX_AVERAGE_STEPS`]). Sensor noise on one
    /// measurement moves the predicted miss by millimetres and the re-plan starts from it
    /// (docs/replanning.md "Averaging the measured state"). Default 1.
    pub average_steps: usize,
}

impl Default for ReplanSettings {
    fn default() -> Self {
        ReplanSettings {
            threshold_m: 0.01,
            check_period_s: 0.01,
            predict_dt_s: 0.01,
            max_replans: 3,
            min_spacing_s: 0.1,
            min_remaining_s: 0.15,
            latency_s: None,
            knot_dt_s: 0.03,
            prediction: MissPrediction::Feedback,
            compare_before_adopting: true,
            adopt_margin_m: 0.002,
            adopt_control_period_s: 0.001,
            confirm_checks: 1,
            compare_at_switch: false,
            average_steps: 1,
        }
    }
}

/// Largest `threshold_m`, m: the largest link length brachia accepts.
pub const MAX_THRESHOLD_M: f64 = 1e6;

impl ReplanSettings {
    /// Check the values; `src` names the source (file or section) in errors.
    pub fn validate(&self, src: &str) -> Result<()> {
        let pos = |field: &str, v: f64| -> Result<()> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(src, field, v, "must be finite and > 0"))
            }
        };
        pos("threshold_m", self.threshold_m)?;
        pos("check_period_s", self.check_period_s)?;
        pos("predict_dt_s", self.predict_dt_s)?;
        let nonneg = |field: &str, v: f64| -> Result<()> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(src, field, v, "must be finite and >= 0"))
            }
        };
        // a time beyond the longest swing would switch the re-planning off silently (a re-plan
        // ready only after the swing is never applied)
        let within_swing = |field: &str, v: f64| -> Result<()> {
            nonneg(field, v)?;
            if v > crate::limits::MAX_SWING_TIME_S {
                return Err(Error::invalid(
                    src,
                    field,
                    v,
                    format!(
                        "must be at most the longest swing, {} s (brachia::limits::MAX_SWING_TIME_S): \
                         a longer time would never let a re-plan act",
                        crate::limits::MAX_SWING_TIME_S
                    ),
                ));
            }
            Ok(())
        };
        within_swing("min_spacing_s", self.min_spacing_s)?;
        // a check period beyond the longest swing never checks; a threshold beyond any link's reach
        // is never exceeded; more confirmations than checks in the longest swing never confirm
        within_swing("check_period_s", self.check_period_s)?;
        if self.threshold_m > MAX_THRESHOLD_M {
            return Err(Error::invalid(
                src,
                "threshold_m",
                self.threshold_m,
                format!(
                    "must be at most {MAX_THRESHOLD_M:e} m (the largest link length): a larger \
                     miss is never predicted, so the re-planning would never act"
                ),
            ));
        }
        let max_confirm = (crate::limits::MAX_SWING_TIME_S / MIN_CHECK_PERIOD_S).round() as usize;
        if self.confirm_checks > max_confirm {
            return Err(Error::invalid(
                src,
                "confirm_checks",
                self.confirm_checks,
                format!(
                    "must be at most {max_confirm}, the checks of the longest swing at the shortest \
                     check period: more would never confirm a trigger"
                ),
            ));
        }
        nonneg("adopt_margin_m", self.adopt_margin_m)?;
        if !(self.adopt_control_period_s.is_finite()
            && (1e-3..=0.1).contains(&self.adopt_control_period_s))
        {
            return Err(Error::invalid(
                src,
                "adopt_control_period_s",
                self.adopt_control_period_s,
                "must be in [0.001, 0.1] s",
            ));
        }
        within_swing("min_remaining_s", self.min_remaining_s)?;
        if !(1..=MAX_AVERAGE_STEPS).contains(&self.average_steps) {
            return Err(Error::invalid(
                src,
                "average_steps",
                self.average_steps,
                format!(
                    "must be in [1, {MAX_AVERAGE_STEPS}] (brachia::control::replanning::\
                     MAX_AVERAGE_STEPS)"
                ),
            ));
        }
        // the comparison at the switch repeats the adoption test: without it there is none to repeat
        if self.compare_at_switch && !self.compare_before_adopting {
            return Err(Error::invalid(
                src,
                "compare_at_switch",
                self.compare_at_switch,
                "needs compare_before_adopting = true (the comparison at the switch repeats the \
                 adoption test; with compare_before_adopting = false there is none)",
            ));
        }
        if self.confirm_checks == 0 {
            return Err(Error::invalid(
                src,
                "confirm_checks",
                self.confirm_checks,
                "must be at least 1",
            ));
        }
        if !(self.knot_dt_s.is_finite() && self.knot_dt_s > 0.0 && self.knot_dt_s <= 0.1) {
            return Err(Error::invalid(
                src,
                "knot_dt_s",
                self.knot_dt_s,
                "must be in (0, 0.1] s",
            ));
        }
        if let Some(l) = self.latency_s {
            within_swing("latency_s", l)?;
        }
        if self.max_replans > MAX_REPLANS {
            return Err(Error::invalid(
                src,
                "max_replans",
                self.max_replans,
                format!(
                    "must be at most {MAX_REPLANS} (brachia::control::replanning::MAX_REPLANS)"
                ),
            ));
        }
        // the rollout covers at most the swing; a step below 0.1 ms is refused (cost per check)
        if !(1e-4..=0.1).contains(&self.predict_dt_s) {
            return Err(Error::invalid(
                src,
                "predict_dt_s",
                self.predict_dt_s,
                "must be in [1e-4, 0.1] s (a coarser RK4 step predicts nothing of the swing)",
            ));
        }
        // every check rolls the model out to T twice: the checks are bounded in number (one per
        // control period at 1 kHz at most) and in work (rollout steps per simulated second)
        if self.check_period_s < MIN_CHECK_PERIOD_S {
            return Err(Error::invalid(
                src,
                "check_period_s",
                self.check_period_s,
                format!(
                    "must be >= {MIN_CHECK_PERIOD_S} s (brachia::control::replanning::\
                     MIN_CHECK_PERIOD_S): every check rolls the model out to the swing's end"
                ),
            ));
        }
        if self.check_period_s * self.predict_dt_s < MIN_CHECK_TIMES_STEP_S2 {
            return Err(Error::invalid(
                src,
                "check_period_s",
                self.check_period_s,
                format!(
                    "check_period_s x predict_dt_s = {:e} s^2 must be >= {MIN_CHECK_TIMES_STEP_S2} \
                     s^2 (brachia::control::replanning::MIN_CHECK_TIMES_STEP_S2): each check costs \
                     (T - t) / predict_dt_s rollout steps, so finer checks need a coarser step",
                    self.check_period_s * self.predict_dt_s
                ),
            ));
        }
        Ok(())
    }
}

/// One re-plan of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReplanEvent {
    /// Time of the trigger (the re-plan starts from the state measured then), s.
    pub t_trigger_s: f64,
    /// The predicted capture miss that triggered it, m (infinite: the prediction diverged;
    /// `null` in JSON).
    #[serde(deserialize_with = "crate::serde_nonfinite::number")]
    pub predicted_miss_m: f64,
    /// How the solve ended.
    pub status: SolveStatus,
    /// Interior-point iterations.
    pub iterations: usize,
    /// Wall time of the solver, s.
    pub solve_time_s: f64,
    /// Wall time of the whole re-plan (solve and building the 1 ms plan), s.
    pub wall_time_s: f64,
    /// Latency modelled from trigger to switch (configured or `wall_time_s`), s.
    pub latency_s: f64,
    /// When the tracking controller switched to the new plan, s; `None` when it did not (not
    /// adopted, or the run ended first).
    pub t_switch_s: Option<f64>,
    /// The re-planned swing's final end-effector distance from the bar, m (infinite: the re-plan
    /// failed; `null` in JSON).
    #[serde(deserialize_with = "crate::serde_nonfinite::number")]
    pub plan_ee_error_m: f64,
    /// Whether the plan was adopted (converged, within 1 mm of the bar, and, when compared,
    /// predicted to end closer to the bar than continuing by more than `adopt_margin_m`).
    pub adopted: bool,
    /// True when the re-plan aimed at an end box ([`Replanning::build_toward_end_box`]) failed and
    /// was solved again without it (the rest of the swing as [`Replanning::build`] would re-plan
    /// it); the status, iterations and times are the two attempts' (the last status, the sums).
    /// Absent (false) in every other re-plan.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub end_box_dropped: bool,
    /// Predicted capture error of continuing the current plan from the trigger state on the
    /// current model, m; absent when no comparison was made (`compare_before_adopting` off, or the
    /// re-plan failed); infinite when the prediction diverged (`null` in JSON).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::serde_nonfinite::opt_number"
    )]
    pub predicted_continue_m: Option<f64>,
    /// Predicted capture error of the re-planned swing from the same state on the same model, m;
    /// absent as `predicted_continue_m`, infinite (`null` in JSON) as it.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::serde_nonfinite::opt_number"
    )]
    pub predicted_replan_m: Option<f64>,
    /// True when the re-plan ran on a planner built for the controller's estimated model
    /// ([`super::Adaptive`]; planned cold from the first plan, then re-planned); absent (false)
    /// otherwise.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub planned_on_estimate: bool,
    /// With `compare_at_switch`: the predicted capture errors of continuing and of switching,
    /// from the state measured at the switch, m (`[continue, re-plan]`); absent otherwise. The
    /// re-plan was dropped there (`adopted = false`) unless the second beats the first by more
    /// than `adopt_margin_m`. An entry is infinite (`null` in JSON) when its prediction diverged.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::serde_nonfinite::opt_pair"
    )]
    pub predicted_at_switch_m: Option<[f64; 2]>,
}

/// Whether a re-plan predicted to end `replan` m from the bar beats continuing the current plan
/// (predicted `cont` m) by more than `margin` m; never when either prediction is NaN.
fn beats_continuing(cont: f64, replan: f64, margin: f64) -> bool {
    !(cont.is_nan() || replan.is_nan() || replan + margin >= cont)
}

/// A re-planned swing waiting for its ready time.
struct Pending {
    ready: f64,
    plan: Arc<Trajectory>,
    lqr: Option<Tvlqr>,
}

/// A tracking controller with online re-planning; see the module docs.
pub struct Replanning<C> {
    inner: C,
    planner: SwingPlanner,
    robot: Arc<Robot>,
    reference: Arc<Trajectory>,
    settings: ReplanSettings,
    t_final: f64,
    pending: Option<Pending>,
    /// The feedback of the miss prediction along the tracked plan ([`MissPrediction::Feedback`]).
    lqr: Option<Tvlqr>,
    events: Vec<ReplanEvent>,
    next_check: f64,
    last_trigger: Option<f64>,
    last_miss: f64,
    /// Checks in a row whose predicted miss exceeded the threshold.
    over: usize,
    /// The model the predictions roll out (the planner's robot until [`Controller::set_model`]).
    model: Arc<Robot>,
    target: [f64; 2],
    predictor: CapturePredictor,
    /// How to build a planner on another model (set by [`Replanning::build`]).
    rebuild: Option<Rebuild>,
    /// The measured states of the last `average_steps` control steps.
    average: StateAverage,
    /// The averaged state (scratch).
    xs: Vec<f64>,
}

/// What a planner on an estimated model is built from.
struct Rebuild {
    settings: PlannerSettings,
    nlp: NlpSettings,
    /// The plan first tracked (the cold plan's guess).
    guess: Arc<Trajectory>,
}

impl<C: Controller> Replanning<C> {
    /// Wrap `inner`, which tracks `reference` (absolute times; its end is the swing's T), with
    /// `planner` (planned already: its current solution is the warm start of the first re-plan; the
    /// same swing time and target as the reference). Errors on invalid settings, a planner without a
    /// plan, or a reference that does not fit the planner's robot.
    pub fn new(
        inner: C,
        planner: SwingPlanner,
        reference: impl Into<Arc<Trajectory>>,
        settings: ReplanSettings,
    ) -> Result<Self> {
        settings.validate("replanning")?;
        let reference = reference.into();
        let robot = Arc::clone(planner.robot());
        reference.check_reference(&robot)?;
        if !planner.has_plan() {
            return Err(Error::invalid(
                "replanning",
                "planner",
                "no plan",
                "plan the swing before wrapping the controller (SwingPlanner::plan)",
            ));
        }
        let t_final = planner.swing_time();
        let t_ref = reference.t[reference.len() - 1];
        if (t_ref - t_final).abs() > 1e-6 {
            return Err(Error::invalid(
                "replanning",
                "reference",
                format!("ends at {t_ref} s"),
                format!("must end at the planner's swing time T = {t_final} s"),
            ));
        }
        let lqr = match settings.prediction {
            MissPrediction::Feedback => Some(Tvlqr::new(
                Arc::clone(&robot),
                Arc::clone(&reference),
                TvlqrSettings::default(),
            )?),
            MissPrediction::OpenLoop => None,
        };
        Ok(Replanning {
            inner,
            lqr,
            predictor: CapturePredictor::new(&robot),
            model: Arc::clone(&robot),
            target: planner.target(),
            rebuild: None,
            average: StateAverage::new(robot.nx(), settings.average_steps),
            xs: vec![0.0; robot.nx()],
            robot,
            planner,
            reference,
            t_final,
            pending: None,
            events: Vec::with_capacity(settings.max_replans),
            next_check: f64::NEG_INFINITY,
            last_trigger: None,
            last_miss: 0.0,
            over: 0,
            settings,
        })
    }

    /// Build the planner of `task` for `robot` on the re-planning mesh (`settings.knot_dt_s`,
    /// multiple shooting, the Riccati backend; the rest of `planner` and `nlp` as given), plan the
    /// swing cold, and wrap `inner` (which tracks `reference`). Errors as [`Replanning::new`], on
    /// invalid planner settings, or when the cold plan does not converge.
    pub fn build(
        inner: C,
        robot: impl Into<Arc<Robot>>,
        task: &SwingTask,
        planner: &PlannerSettings,
        nlp: &NlpSettings,
        reference: impl Into<Arc<Trajectory>>,
        settings: ReplanSettings,
    ) -> Result<Self> {
        Self::build_toward_end_box(inner, robot, task, planner, nlp, reference, settings, None)
    }

    /// [`Replanning::build`] for a swing whose reference ends at a state chosen for the swings
    /// after it (the first swing of a joint multi-swing plan): with `Some(end_box)` every (re-)plan
    /// keeps its last knot in the box (2n entries `[lo, hi]`, q then qd;
    /// [`SwingPlanner::set_end_box`]), and the cold plan starts from `reference` (resampled onto the
    /// re-planning mesh) instead of the planner's own guess. A re-plan that does not converge is
    /// solved again without the box, and the box stays dropped for the rest of the swing (what
    /// [`Replanning::build`] re-plans). `None` is [`Replanning::build`]. Errors as
    /// [`Replanning::build`] and on a box of the wrong length or not `lo <= hi`.
    #[allow(clippy::too_many_arguments)]
    pub fn build_toward_end_box(
        inner: C,
        robot: impl Into<Arc<Robot>>,
        task: &SwingTask,
        planner: &PlannerSettings,
        nlp: &NlpSettings,
        reference: impl Into<Arc<Trajectory>>,
        settings: ReplanSettings,
        end_box: Option<&[[f64; 2]]>,
    ) -> Result<Self> {
        settings.validate("replanning")?;
        let reference: Arc<Trajectory> = reference.into();
        // a free swing time was resolved by the plan tracked: the re-plans keep its T
        let swing_time = match planner.free_swing_time {
            Some(_) => SwingTime::Seconds(reference.duration()),
            None => planner.swing_time,
        };
        let ps = PlannerSettings {
            transcription: Transcription::MultipleShooting,
            knot_dt: settings.knot_dt_s,
            swing_time,
            free_swing_time: None,
            swing_time_starts: 1,
            ..planner.clone()
        };
        let nlp = NlpSettings {
            backend: Backend::Ocp,
            ..nlp.clone()
        };
        let mut p = match end_box {
            None => SwingPlanner::new(robot, task.clone(), &ps, &nlp)?,
            Some(r) => {
                let mut p =
                    SwingPlanner::with_guess(robot, task.clone(), &ps, &nlp, Some(&reference))?;
                p.set_end_box(Some(r))?;
                p
            }
        };
        let out = p.plan_outcome()?;
        if !out.converged() {
            return Err(Error::invalid(
                "replanning",
                "planner",
                format!("{:?}", out.status),
                "the cold plan on the re-planning mesh did not converge",
            ));
        }
        let mut r = Self::new(inner, p, Arc::clone(&reference), settings)?;
        if end_box.is_none() {
            r.rebuild = Some(Rebuild {
                settings: ps,
                nlp,
                guess: reference,
            });
        }
        Ok(r)
    }

    /// The re-plans so far.
    pub fn events(&self) -> &[ReplanEvent] {
        &self.events
    }

    /// The last predicted capture miss, m (0 before the first check).
    pub fn last_predicted_miss_m(&self) -> f64 {
        self.last_miss
    }

    /// The plan being tracked.
    pub fn reference(&self) -> &Arc<Trajectory> {
        &self.reference
    }

    /// The tracking controller.
    pub fn inner(&self) -> &C {
        &self.inner
    }

    /// The persistent planner the re-plans run on (its swing time, mesh and current solution).
    pub fn planner(&self) -> &SwingPlanner {
        &self.planner
    }

    /// The settings in use.
    pub fn settings(&self) -> &ReplanSettings {
        &self.settings
    }

    /// Back to the tracking controller, the planner and the re-plans.
    pub fn into_parts(self) -> (C, SwingPlanner, Vec<ReplanEvent>) {
        (self.inner, self.planner, self.events)
    }

    /// The predicted capture miss from `x` at `t`: the distance from the bar of the hand at T
    /// predicted on the current model for the plan tracked ([`super::replan_gate`]), m. Does not
    /// allocate.
    pub fn predict_miss(&mut self, t: f64, x: &[f64]) -> f64 {
        let plan = PlanUnderTest {
            reference: &self.reference,
            lqr: self.lqr.as_mut(),
        };
        let dt = self.settings.predict_dt_s;
        self.predictor
            .capture(
                &self.model,
                &self.robot,
                plan,
                x,
                t,
                self.t_final,
                dt,
                self.target,
            )
            .1
    }

    /// The model the predictions use.
    pub fn model(&self) -> &Arc<Robot> {
        &self.model
    }

    fn may_replan(&self, t: f64) -> bool {
        self.pending.is_none()
            && self.events.len() < self.settings.max_replans
            && self
                .last_trigger
                .is_none_or(|t0| t - t0 >= self.settings.min_spacing_s - 1e-12)
            && self.t_final - t >= self.settings.min_remaining_s
    }

    /// A planner on the current model when it is not the planner's robot (an online estimate):
    /// planned cold from the plan first tracked, it replaces the planner when it converges.
    /// Returns true when it did.
    fn plan_on_model(&mut self) -> bool {
        let Some(rb) = &self.rebuild else {
            return false;
        };
        if Arc::ptr_eq(&self.model, &self.robot) {
            return false;
        }
        let task = self.planner.task().clone();
        let Ok(mut p) = SwingPlanner::with_guess(
            Arc::clone(&self.model),
            task,
            &rb.settings,
            &rb.nlp,
            Some(&rb.guess),
        ) else {
            return false;
        };
        match p.plan_outcome() {
            Ok(o) if o.converged() => {
                self.planner = p;
                self.robot = Arc::clone(&self.model);
                true
            }
            _ => false,
        }
    }

    /// The predicted capture errors on `model` of continuing the current plan and of switching to
    /// `tr` at `ready`, from `x` at `t` (copies of the tracking controller when it can be copied,
    /// else the TVLQR rollouts of the miss prediction).
    fn predict_pair(
        &mut self,
        model: &Robot,
        t: f64,
        x: &[f64],
        tr: &Arc<Trajectory>,
        lqr: Option<&mut Tvlqr>,
        ready: f64,
    ) -> (f64, f64) {
        let (tf, target) = (self.t_final, self.target);
        if let (Some(mut a), Some(mut b)) = (self.inner.clone_box(), self.inner.clone_box()) {
            let gp = self.settings.adopt_control_period_s;
            let p = &mut self.predictor;
            let c = p.closed_loop_capture(a.as_mut(), model, x, t, tf, gp, None, target);
            let d =
                p.closed_loop_capture(b.as_mut(), model, x, t, tf, gp, Some((ready, tr)), target);
            return (c, d);
        }
        let dt = self.settings.predict_dt_s;
        let robot = &self.robot;
        let cont = PlanUnderTest {
            reference: &self.reference,
            lqr: self.lqr.as_mut(),
        };
        let (_, c) = self
            .predictor
            .capture(model, robot, cont, x, t, tf, dt, target);
        let new = PlanUnderTest { reference: tr, lqr };
        let (_, d) = self
            .predictor
            .capture(model, robot, new, x, t, tf, dt, target);
        (c, d)
    }

    /// With `compare_at_switch` (and `compare_before_adopting`): whether the pending re-plan `p`
    /// still beats continuing from the state `x` measured at its switch time `t` (predicted as at
    /// the trigger, the switch now); the predictions go into its event, and a re-plan that does
    /// not is marked not adopted. True otherwise (and for a measured state that is not finite).
    fn still_better_at_switch(&mut self, t: f64, x: &[f64], p: &mut Pending) -> bool {
        let s = &self.settings;
        let valid = x.len() == self.robot.nx() && x.iter().all(|v| v.is_finite());
        if !(s.compare_at_switch && s.compare_before_adopting && valid) {
            return true;
        }
        let model = Arc::clone(&self.model);
        let mut xs = std::mem::take(&mut self.xs);
        self.average.state(&self.reference, t, x, &mut xs);
        let (c, d) = self.predict_pair(&model, t, &xs, &p.plan, p.lqr.as_mut(), t);
        self.xs = xs;
        let better = beats_continuing(c, d, self.settings.adopt_margin_m);
        if let Some(e) = self.events.last_mut() {
            e.predicted_at_switch_m = Some([c, d]);
            e.adopted = better;
        }
        better
    }

    fn replan(&mut self, t: f64, x: &[f64], miss: f64) {
        self.last_trigger = Some(t);
        let start = Instant::now();
        let on_model = self.plan_on_model();
        let mut out = self.planner.replan(t, x);
        // a re-plan aimed at an end box that failed: solved again (from the same warm start, the
        // last converged solution) without it, and without it for the rest of the swing
        let mut end_box_dropped = false;
        let mut spent = (0, 0.0);
        if let (true, Ok(o)) = (self.planner.end_box().is_some(), out.as_ref()) {
            if !o.converged() && self.planner.set_end_box(None).is_ok() {
                end_box_dropped = true;
                spent = (o.iterations, o.solve_time_s);
                out = self.planner.replan(t, x);
            }
        }
        let (status, iterations, solve_time_s, plan_err, mut traj) = match out {
            Ok(o) => {
                let ok = o.converged() && o.ee_error_m <= ADOPT_EE_ERROR_M;
                let traj = if ok {
                    self.planner.current_plan().ok().map(|p| p.trajectory)
                } else {
                    None
                };
                (
                    o.status,
                    o.iterations + spent.0,
                    o.solve_time_s + spent.1,
                    o.ee_error_m,
                    traj,
                )
            }
            Err(e) => (
                SolveStatus::Other(e.to_string()),
                0,
                0.0,
                f64::INFINITY,
                None,
            ),
        };
        let wall = start.elapsed().as_secs_f64();
        let latency = self.settings.latency_s.unwrap_or(wall);
        if let Some(tr) = traj.as_mut() {
            for s in tr.t.iter_mut() {
                *s += t;
            }
        }
        let mut traj = traj.map(Arc::new);
        let lqr = match (&traj, self.settings.prediction) {
            (Some(tr), MissPrediction::Feedback) => {
                match Tvlqr::new(
                    Arc::clone(&self.robot),
                    Arc::clone(tr),
                    TvlqrSettings::default(),
                ) {
                    Ok(l) => Some(l),
                    Err(_) => {
                        traj = None;
                        None
                    }
                }
            }
            _ => None,
        };
        let (mut lqr, mut compared) = (lqr, (None, None));
        if let (Some(tr), true) = (&traj, self.settings.compare_before_adopting) {
            let ready = t + self
                .settings
                .latency_s
                .unwrap_or(start.elapsed().as_secs_f64());
            let model = Arc::clone(&self.model);
            let (c, d) = self.predict_pair(&model, t, x, tr, lqr.as_mut(), ready);
            compared = (Some(c), Some(d));
            if !beats_continuing(c, d, self.settings.adopt_margin_m) {
                traj = None;
                lqr = None;
            }
        }
        let adopted = traj.is_some();
        if let Some(plan) = traj {
            self.pending = Some(Pending {
                ready: t + latency,
                plan,
                lqr,
            });
        }
        self.events.push(ReplanEvent {
            t_trigger_s: t,
            predicted_miss_m: miss,
            status,
            iterations,
            solve_time_s,
            wall_time_s: wall,
            latency_s: latency,
            t_switch_s: None,
            plan_ee_error_m: plan_err,
            adopted,
            end_box_dropped,
            predicted_continue_m: compared.0,
            predicted_replan_m: compared.1,
            planned_on_estimate: on_model,
            predicted_at_switch_m: None,
        });
    }
}

impl<C: Controller> Controller for Replanning<C> {
    /// Switch to a ready plan, predict the miss (every `check_period_s`) and re-plan past the
    /// threshold, then the tracking controller's torque. A measured state of the wrong length or
    /// with NaNs goes to the tracking controller unchecked.
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        let valid = x.len() == self.robot.nx() && x.iter().all(|v| v.is_finite());
        if valid {
            self.average.push(&self.reference, t, x);
        }
        if let Some(p) = &self.pending {
            if t >= p.ready - 1e-9 {
                let mut p = self.pending.take().expect("pending plan");
                if self.still_better_at_switch(t, x, &mut p)
                    && self.inner.set_reference(Arc::clone(&p.plan)).is_ok()
                {
                    self.reference = p.plan;
                    if p.lqr.is_some() {
                        self.lqr = p.lqr;
                    }
                    self.average.clear();
                    if valid {
                        self.average.push(&self.reference, t, x);
                    }
                    if let Some(e) = self.events.last_mut() {
                        e.t_switch_s = Some(t);
                    }
                }
            }
        }
        if valid && t >= self.next_check - 1e-9 {
            self.next_check = t + self.settings.check_period_s;
            if self.t_final - t > 0.0 {
                let mut xs = std::mem::take(&mut self.xs);
                self.average.state(&self.reference, t, x, &mut xs);
                let miss = self.predict_miss(t, &xs);
                self.last_miss = miss;
                self.over = if miss > self.settings.threshold_m {
                    self.over + 1
                } else {
                    0
                };
                if self.over >= self.settings.confirm_checks && self.may_replan(t) {
                    self.replan(t, &xs, miss);
                }
                self.xs = xs;
            }
        }
        self.inner.control(t, x, tau)
    }

    fn name(&self) -> &'static str {
        "replanning"
    }

    /// Track another plan (the planner keeps shifting from its own solution; with the feedback
    /// prediction the TVLQR gains of the plan are computed, which allocates).
    fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
        let lqr = match self.lqr {
            Some(_) => Some(Tvlqr::new(
                Arc::clone(&self.robot),
                Arc::clone(&reference),
                TvlqrSettings::default(),
            )?),
            None => None,
        };
        self.inner.set_reference(Arc::clone(&reference))?;
        self.lqr = lqr;
        self.reference = reference;
        self.pending = None;
        self.average.clear();
        Ok(())
    }

    /// Predict on `robot` from the next check on and pass it on to the tracking controller (its
    /// result is returned; the predictions use `robot` either way). The planner keeps its robot.
    fn set_model(&mut self, robot: Arc<Robot>) -> Result<()> {
        super::base_params::check_model(&self.robot, &robot)?;
        let r = self.inner.set_model(Arc::clone(&robot));
        self.model = robot;
        r
    }
}
