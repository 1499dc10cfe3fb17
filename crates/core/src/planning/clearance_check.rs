//! The clearance of a plan in continuous time: every sample of its resampled trajectory (the plan's
//! `trajectory`, `output_dt` apart, 1 ms by default) against the obstacles it avoids and, with
//! self-collision on, every pair of non-adjacent links.
//!
//! The solver's clearance rows hold at the points it checks (the knots, and the RK4 sub-step states
//! of multiple shooting); between them a fast link can come closer. A plan whose trajectory comes
//! closer than the required clearance (the planner's `obstacle_margin`) minus
//! [`CLEARANCE_TOLERANCE_M`] is not converged ([`crate::planning::Plan::converged`]), whatever the
//! solver's status: its [`ClearanceViolation`] names the obstacle or the link pair, the link, the
//! time and the shortfall. Units: m, s.

use crate::error::Result;
use crate::model::{Circle, ClearanceFn, ClearancePair, Robot};
use crate::planning::settings::PlannerSettings;
use crate::planning::task::SwingTask;
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::fmt;

/// How far below the required clearance (the planner's `obstacle_margin`) a plan's resampled
/// trajectory may come before the plan is refused, m.
pub const CLEARANCE_TOLERANCE_M: f64 = 1e-3;

/// What comes too close: a link and an obstacle, or two non-adjacent links. Indices 0-based
/// (`Display` numbers links from 1, obstacles from 0, as the rest of the planner's messages do).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ClearanceSubject {
    /// Link `link` against obstacle `obstacle` (its position in the task's list).
    Obstacle {
        /// 0-based obstacle index.
        obstacle: usize,
        /// 0-based link index.
        link: usize,
    },
    /// Link `a` against link `b` (`b >= a + 2`).
    Links {
        /// 0-based index of the proximal link.
        a: usize,
        /// 0-based index of the distal link.
        b: usize,
    },
}

impl fmt::Display for ClearanceSubject {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ClearanceSubject::Obstacle { obstacle, link } => {
                write!(f, "link {} and obstacle {obstacle}", link + 1)
            }
            ClearanceSubject::Links { a, b } => write!(f, "link {} and link {}", a + 1, b + 1),
        }
    }
}

/// The closest approach of a plan's resampled trajectory that breaks the required clearance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ClearanceViolation {
    /// The pair that comes too close.
    pub subject: ClearanceSubject,
    /// Time of the closest sample, s.
    pub time_s: f64,
    /// Surface distance there, m (negative: the capsules overlap by that much).
    pub clearance_m: f64,
    /// The required clearance (the planner's `obstacle_margin`), m.
    pub required_m: f64,
    /// The tolerance the check allows below `required_m`, m ([`CLEARANCE_TOLERANCE_M`]).
    pub tolerance_m: f64,
}

impl ClearanceViolation {
    /// How far the trajectory comes inside the required clearance, m (> `tolerance_m`).
    pub fn shortfall_m(&self) -> f64 {
        self.required_m - self.clearance_m
    }
}

impl fmt::Display for ClearanceViolation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self.subject {
            ClearanceSubject::Obstacle { .. } if self.clearance_m < 0.0 => {
                format!("{} overlap by {:.4} m", self.subject, -self.clearance_m)
            }
            _ => format!(
                "{} come within {:.4} m of each other",
                self.subject, self.clearance_m
            ),
        };
        write!(
            f,
            "{what} at t = {:.3} s on the resampled trajectory: {:.4} m inside the required \
             clearance of {:.4} m (tolerance {:.4} m)",
            self.time_s,
            self.shortfall_m(),
            self.required_m,
            self.tolerance_m
        )
    }
}

/// The closest approach of `trajectory` that breaks the clearance the planner requires of `task`
/// (the obstacles when `settings.avoid_obstacles`, the non-adjacent link pairs when
/// `settings.self_collision`, at `settings.obstacle_margin` minus [`CLEARANCE_TOLERANCE_M`]);
/// `None` when every sample keeps it (or nothing is checked). Errors on an invalid obstacle.
pub fn check_clearance(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    trajectory: &Trajectory,
) -> Result<Option<ClearanceViolation>> {
    let obstacles: &[Circle] = if settings.avoid_obstacles {
        &task.obstacles
    } else {
        &[]
    };
    if (obstacles.is_empty() && !settings.self_collision) || trajectory.is_empty() {
        return Ok(None);
    }
    let margin = settings.obstacle_margin;
    let cf = ClearanceFn::new(robot.clone(), obstacles, margin)?
        .with_self_collision(settings.self_collision);
    let mut worst: Option<(ClearancePair, f64, f64)> = None;
    for k in 0..trajectory.len() {
        if let Some((p, d)) = cf.min_clearance_pair(trajectory.q(k)) {
            if worst.is_none_or(|(_, w, _)| d < w) {
                worst = Some((p, d, trajectory.t[k]));
            }
        }
    }
    let Some((pair, d, t)) = worst.filter(|w| w.1 < margin - CLEARANCE_TOLERANCE_M) else {
        return Ok(None);
    };
    let subject = match pair {
        ClearancePair::LinkObstacle { link, obstacle } => {
            ClearanceSubject::Obstacle { obstacle, link }
        }
        ClearancePair::LinkLink { a, b } => ClearanceSubject::Links { a, b },
        // the exact check reports link pairs by their segments, never a joint row
        ClearancePair::JointLink { joint, link } => ClearanceSubject::Links {
            a: joint.min(link),
            b: joint.max(link),
        },
    };
    Ok(Some(ClearanceViolation {
        subject,
        time_s: t,
        clearance_m: d,
        required_m: margin,
        tolerance_m: CLEARANCE_TOLERANCE_M,
    }))
}
