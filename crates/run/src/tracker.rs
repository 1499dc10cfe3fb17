//! The controller a tracking run drives, as the scenario's `[tracking]` section composes it: the
//! tracking controller alone, wrapped by online re-planning (`replan`), by the online mass estimate
//! (`estimate_params`, docs/estimation.md), or both (the estimate outermost, so that the re-planner
//! predicts and re-plans on the estimated model and passes it on to the MPC).

use crate::scenario::LoadedScenario;
use brachia::control::Replanning;
use brachia::control::{
    Adaptive, EstimateReport, ParamEstimatorSettings, ReplanEvent, ReplanSettings,
};
use brachia::sim::Controller;
use brachia::trajectory::Trajectory;
use brachia::Error;
use std::sync::Arc;

/// A tracking controller with its optional wrappers, kept typed so that a run can report the
/// re-plans and the estimate afterwards.
pub enum Tracker {
    /// The tracking controller alone.
    Plain(Box<dyn Controller>),
    /// With online re-planning.
    Replanning(Box<Replanning<Box<dyn Controller>>>),
    /// Fed the online mass estimate.
    Adaptive(Box<Adaptive<Box<dyn Controller>>>),
    /// Both: the estimate feeds the re-planner, which passes it on.
    AdaptiveReplanning(Box<Adaptive<Replanning<Box<dyn Controller>>>>),
}

impl Tracker {
    /// Wrap `base` (tracking `reference`, the scenario's robot) with re-planning when `replan` is
    /// given and with the estimate when `estimate` is. Errors when the re-planner's cold plan does
    /// not converge or a setting is invalid.
    pub fn build(
        ls: &LoadedScenario,
        reference: &Arc<Trajectory>,
        base: Box<dyn Controller>,
        replan: Option<ReplanSettings>,
        estimate: Option<ParamEstimatorSettings>,
    ) -> Result<Tracker, Error> {
        let sc = &ls.scenario;
        Ok(match (replan, estimate) {
            (None, None) => Tracker::Plain(base),
            (None, Some(e)) => {
                Tracker::Adaptive(Box::new(Adaptive::new(base, ls.robot.clone(), e)?))
            }
            (Some(rs), e) => {
                let r = Replanning::build(
                    base,
                    ls.robot.clone(),
                    &sc.task,
                    &sc.planner,
                    &sc.solver,
                    Arc::clone(reference),
                    rs,
                )?;
                match e {
                    None => Tracker::Replanning(Box::new(r)),
                    Some(e) => Tracker::AdaptiveReplanning(Box::new(Adaptive::new(
                        r,
                        ls.robot.clone(),
                        e,
                    )?)),
                }
            }
        })
    }

    /// The controller the loop drives.
    pub fn controller(&mut self) -> &mut dyn Controller {
        match self {
            Tracker::Plain(c) => c.as_mut(),
            Tracker::Replanning(c) => c.as_mut(),
            Tracker::Adaptive(c) => c.as_mut(),
            Tracker::AdaptiveReplanning(c) => c.as_mut(),
        }
    }

    /// The re-plans so far (none without re-planning).
    pub fn replans(&self) -> &[ReplanEvent] {
        match self {
            Tracker::Replanning(c) => c.events(),
            Tracker::AdaptiveReplanning(c) => c.inner().events(),
            _ => &[],
        }
    }

    /// Whether it re-plans.
    pub fn replanning(&self) -> bool {
        matches!(
            self,
            Tracker::Replanning(_) | Tracker::AdaptiveReplanning(_)
        )
    }

    /// The estimate, its uncertainty and history (none without the estimate).
    pub fn estimate(&self) -> Option<EstimateReport> {
        match self {
            Tracker::Adaptive(c) => Some(c.report()),
            Tracker::AdaptiveReplanning(c) => Some(c.report()),
            _ => None,
        }
    }
}
