//! Obstacles of the rapier plant and the contact log.
//!
//! Positions in m in the world frame (grip point at the origin, y up), masses in kg, impulses in N s.

use brachia::trajectory::Trajectory;
use brachia::{Error, Result, Robot};
use serde::{Deserialize, Serialize};

/// A fixed circle (a static disc the robot can hit but not move): the core's obstacle type, the one
/// the planner avoids (its radius must be > 0 here, [`Obstacle::validate`]).
pub use brachia::model::Circle;

/// A free dynamic ball the robot can knock away.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ball {
    /// Initial centre `[x, y]`, m (the ball starts at rest).
    #[serde(deserialize_with = "brachia::serde_exact::pair")]
    pub center: [f64; 2],
    /// Radius, m (> 0).
    pub radius: f64,
    /// Mass, kg (> 0); the inertia is that of a uniform disc.
    pub mass: f64,
    /// Restitution in [0, 1]; a contact uses the larger of the two colliders' restitutions.
    pub restitution: f64,
    /// Whether gravity acts on the ball (`false`: it floats until hit).
    pub gravity: bool,
}

impl Ball {
    /// A floating ball (no gravity, at rest) centred on the planned EE path: at the EE position of
    /// the knot of `plan` at or before time `t` (s, the plan's clock; clamped to the plan), in the
    /// plan's frame (the grip at the origin; shift it for a world with the grip elsewhere). Returns
    /// the ball and the planned time of that knot, s: the hand following the plan runs into the ball
    /// then. Used by the Monte Carlo benchmark and by a ladder's ball hit. Values are not checked
    /// here ([`Obstacle::validate`] does, when the plant adds the ball).
    pub fn on_path(
        plan: &Trajectory,
        robot: &Robot,
        t: f64,
        mass: f64,
        radius: f64,
        restitution: f64,
    ) -> (Ball, f64) {
        let (k, _) = plan.locate(t);
        let ball = Ball {
            center: robot.ee_position(plan.q(k)),
            radius,
            mass,
            restitution,
            gravity: false,
        };
        (ball, plan.t[k])
    }

    /// Smallest gap between the ball and the robot's link capsules in pose `q` (grip at the origin,
    /// the ball in the same frame), m; negative when they overlap.
    pub fn clearance(&self, robot: &Robot, q: &[f64]) -> f64 {
        let mut segs = vec![([0.0; 2], [0.0; 2]); robot.n()];
        robot.link_segments(q, &mut segs);
        segs.iter()
            .enumerate()
            .map(|(i, (a, b))| {
                point_segment_distance(self.center, *a, *b) - self.radius - robot.radii()[i]
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// Distance from point `p` to the segment `a`-`b`, m (the core's exact point-segment distance).
pub(crate) fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    brachia::geometry::point_segment_dist2(p, a, b).sqrt()
}

/// An obstacle of the plant's world.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Obstacle {
    /// A fixed circle.
    Circle(Circle),
    /// A free dynamic ball.
    Ball(Ball),
}

impl Obstacle {
    /// Check every value; errors name the field as `obstacles[index].<field>`.
    pub fn validate(&self, source_name: &str, index: usize) -> Result<()> {
        let bad = |field: &str, value: f64, reason: &str| {
            Err(Error::invalid(
                source_name,
                format!("obstacles[{index}].{field}"),
                value,
                reason,
            ))
        };
        let (center, radius) = self.shape();
        for (k, c) in center.iter().enumerate() {
            if !c.is_finite() {
                return bad(&format!("center[{k}]"), *c, "must be finite");
            }
        }
        if !(radius.is_finite() && radius > 0.0) {
            return bad("radius", radius, "must be a finite number > 0");
        }
        if let Obstacle::Ball(b) = self {
            if !(b.mass.is_finite() && b.mass > 0.0) {
                return bad("mass", b.mass, "must be a finite number > 0");
            }
            if !(0.0..=1.0).contains(&b.restitution) {
                return bad("restitution", b.restitution, "must lie in [0, 1]");
            }
        }
        Ok(())
    }

    /// Initial centre (m) and radius (m).
    pub fn shape(&self) -> ([f64; 2], f64) {
        match self {
            Obstacle::Circle(c) => (c.center, c.radius),
            Obstacle::Ball(b) => (b.center, b.radius),
        }
    }
}

/// What a link touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ContactBody {
    /// The obstacle with this id (the order in which obstacles were added, from 0).
    Obstacle(usize),
    /// Another link, 0-based (only with `RapierSettings::self_contacts`; logged once per pair, on the
    /// lower-indexed link).
    Link(usize),
}

/// One contact of one control step: a link pushed on (or was pushed by) a body.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ContactEvent {
    /// Plant time at the end of the control step in which the contact acted, s.
    pub t: f64,
    /// The link, 0-based (link 1 of the paper is 0).
    pub link: usize,
    /// The other body.
    pub body: ContactBody,
    /// Total normal contact impulse over the control step (summed over engine sub-steps), N s (> 0).
    pub impulse: f64,
}
