//! The plants of a traverse: the rapier world with the ladder's obstacles, the plant's chains as
//! written and re-rooted, and the ball thrown on a swing's planned path.

use crate::ladder::LoadedLadder;
use crate::scenario::LoadedScenario;
use crate::track_run::plant_robot;
use brachia::{Error, Robot};
use brachia_rapier::{Ball, Circle, Obstacle, RapierPlant};
use serde::Serialize;

/// Put the ball of `[disturbances.ball]` on the planned EE path of the swing that starts now
/// (`reference` in the grip frame of `grip`, world; `t_start` the traverse time): into the rapier
/// world when there is one, else only recorded (the model plant ignores it). Errors name
/// `disturbances.ball.<field>`: a time past the swing's planned time, a ball overlapping the chain.
pub(super) fn throw_ball(
    b: &crate::ladder::SwingBall,
    reference: &brachia::trajectory::Trajectory,
    robot: &Robot,
    grip: [f64; 2],
    t_start: f64,
    rapier: Option<&mut RapierPlant>,
    src: &str,
) -> Result<BallRecord, Error> {
    let t_end = reference.duration();
    if b.at_s >= t_end {
        return Err(Error::invalid(
            src,
            "disturbances.ball.at_s",
            b.at_s,
            format!(
                "must lie within swing {}'s planned time ({t_end:.3} s)",
                b.swing
            ),
        ));
    }
    let (mut ball, t_hit) =
        Ball::on_path(reference, robot, b.at_s, b.mass, b.radius, b.restitution);
    ball.center = [ball.center[0] + grip[0], ball.center[1] + grip[1]];
    let center = ball.center;
    let obstacle_id = match rapier {
        Some(r) => Some(r.add_obstacle(&Obstacle::Ball(ball.clone())).map_err(|e| {
            let reason = match e {
                Error::InvalidValue { reason, .. } => reason,
                other => other.to_string(),
            };
            Error::invalid(
                src,
                "disturbances.ball",
                format!(
                    "centre [{:.4}, {:.4}] at {} s of swing {}",
                    center[0], center[1], b.at_s, b.swing
                ),
                reason,
            )
        })?),
        None => None,
    };
    Ok(BallRecord {
        swing: b.swing,
        obstacle_id,
        center,
        planned_hit_s: t_start + t_hit,
        ignored: obstacle_id.is_none(),
        ball,
    })
}

/// The rapier plant of a traverse: the plant's chain hanging from bar 0 in the world, the ladder's
/// obstacles as fixed circles, then `[plant] obstacles` (world frame). Errors name the obstacle.
pub(super) fn rapier_world(
    ll: &LoadedLadder,
    robot: &Robot,
    x0: &[f64],
) -> Result<(RapierPlant, Vec<Obstacle>), Error> {
    let sc = &ll.scenario;
    let src = ll.path.display().to_string();
    let mut p = RapierPlant::new_at(robot, sc.ladder.bars[0].p(), x0, &sc.plant.rapier())?;
    let n_ladder = sc.ladder.obstacles.len();
    let obstacles: Vec<Obstacle> = sc
        .ladder
        .obstacles
        .iter()
        .map(|c| {
            Obstacle::Circle(Circle {
                center: c.center,
                radius: c.radius,
            })
        })
        .chain(sc.plant.obstacles.iter().cloned())
        .collect();
    for (id, o) in obstacles.iter().enumerate() {
        let field = if id < n_ladder {
            format!("ladder.obstacles[{id}]")
        } else {
            format!("plant.obstacles[{}]", id - n_ladder)
        };
        let c = o.shape().0;
        p.add_obstacle(o).map_err(|e| match e {
            Error::InfeasibleTask(m) => Error::invalid(
                &src,
                field.clone(),
                format!("center [{}, {}]", c[0], c[1]),
                m,
            ),
            Error::InvalidValue { reason, value, .. } => {
                Error::invalid(&src, field.clone(), value, reason)
            }
            other => other,
        })?;
    }
    Ok((p, obstacles))
}

/// The plant's chains (the parameters file's robot with `[plant] mass_scale` and the
/// `[disturbances]` factors, as written and re-rooted): per-link factors name the parameters
/// file's links, whichever hand holds.
pub(super) fn plant_chains(ll: &LoadedLadder) -> Result<[Robot; 2], Error> {
    let sc = &ll.scenario;
    let n = ll.robot.n();
    let grip = sc.ladder.bars[0].p();
    let mut first = crate::ladder::swing_scenario(sc, &ll.x0[..n], &ll.x0[n..], grip, 1);
    first.disturbances = sc.disturbances.model.clone();
    let pr = plant_robot(&LoadedScenario {
        scenario: first,
        robot: ll.robot.clone(),
        path: ll.path.clone(),
    })?;
    brachia::ladder::chains(&pr)
}

/// The ball of `[disturbances.ball]` as it was put into the world (rapier plant).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BallRecord {
    /// The swing it was put in at (its start).
    pub swing: usize,
    /// Its obstacle id in the rapier world (contacts name it `obstacle_<id>`); `None` on the model
    /// plant, which ignores the ball.
    pub obstacle_id: Option<usize>,
    /// Its centre, world, m (the planned EE position at `planned_hit_s`).
    pub center: [f64; 2],
    /// Planned time of the hit, traverse time, s.
    pub planned_hit_s: f64,
    /// True on the model plant (no contacts: the ball is ignored).
    pub ignored: bool,
    /// The ball (world frame).
    pub ball: Ball,
}
