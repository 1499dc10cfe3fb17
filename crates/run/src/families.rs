//! The Monte Carlo families of the robustness benchmark (docs/robustness.md "Monte Carlo families"):
//! each family draws one kind of trouble, so that a controller tuned to one distribution shows its
//! weak spot in another. `monte_carlo` is the original mix (per-link mass factors, sigma_q = 0.002
//! rad, a ball on the planned hand path); the others are listed by [`families`].
//!
//! Every draw comes from ChaCha8 seeded by the run's seed alone, so a family's draws are the same for
//! every controller. Units: s, m, rad, rad/s, kg, N s.

use brachia::sim::{Disturbances, Push};
use brachia::trajectory::Trajectory;
use brachia::Robot;
use brachia_rapier::{Ball, Obstacle};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One draw of a family: the plant's disturbances (mismatch, noise, delays, pushes), the balls in its
/// world, and the planned time at the ball.
#[derive(Debug, Clone, PartialEq)]
pub struct Draw {
    /// Disturbances of the run (combined with the scenario's by the benchmark).
    pub dist: Disturbances,
    /// Free balls in the plant's world.
    pub balls: Vec<Obstacle>,
    /// Planned time at the ball's centre, s.
    pub ball_t_s: Option<f64>,
}

/// A Monte Carlo family: its name in `runs.csv` and the scorecard, what it draws, and how.
#[derive(Debug, Clone, Copy)]
pub struct Family {
    /// Name (the `disturbance` column of `runs.csv`).
    pub name: &'static str,
    /// What one draw holds, for summaries.
    pub what: &'static str,
    /// Draws run `seed` for `robot` (the planner's) and its plan `reference`.
    pub draw: fn(&Robot, &Trajectory, u64) -> Draw,
}

/// Sensor noise of the families that add it: sigma_q = 0.0015 rad, sigma_qd = 0.015 rad/s.
const NOISE: (f64, f64) = (0.0015, 0.015);

fn noisy(seed: u64) -> Disturbances {
    Disturbances {
        noise_q_std: NOISE.0,
        noise_qd_std: NOISE.1,
        seed,
        ..Disturbances::default()
    }
}

/// A free ball (no gravity, restitution 0.3, radius 0.05 m, mass U(0.05, 0.5) kg) centred `off` m
/// beside the point `u` (0..1) along link `link` (0-based) of the plan's pose at `t` (fraction of T);
/// `None` when it touches the start pose.
fn ball_on_link(
    robot: &Robot,
    reference: &Trajectory,
    rng: &mut ChaCha8Rng,
    (t, link, u, off): (f64, usize, f64, f64),
) -> Option<(Ball, f64)> {
    let mass = rng.gen_range(0.05..0.5);
    let (k, _) = reference.locate(t * reference.duration());
    let mut segs = vec![([0.0; 2], [0.0; 2]); robot.n()];
    robot.link_segments(reference.q(k), &mut segs);
    let (a, b) = segs[link];
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len = dx.hypot(dy).max(1e-12);
    let ball = Ball {
        center: [
            a[0] + u * dx - off * dy / len,
            a[1] + u * dy + off * dx / len,
        ],
        radius: 0.05,
        mass,
        restitution: 0.3,
        gravity: false,
    };
    (ball.clearance(robot, reference.q(0)) > 0.01).then_some((ball, reference.t[k]))
}

/// Up to 50 tries of `place` (which draws the ball's placement) for a ball clear of the start pose.
fn some_ball(
    robot: &Robot,
    reference: &Trajectory,
    rng: &mut ChaCha8Rng,
    place: impl Fn(&mut ChaCha8Rng) -> (f64, usize, f64, f64),
) -> (Vec<Obstacle>, Option<f64>) {
    for _ in 0..50 {
        let p = place(rng);
        if let Some((b, t)) = ball_on_link(robot, reference, rng, p) {
            return (vec![Obstacle::Ball(b)], Some(t));
        }
    }
    (Vec::new(), None)
}

/// The original Monte Carlo: each link's mass x U(0.85, 1.15), sigma_q = 0.002 rad, and a ball on
/// the planned EE path at a time in [0.2 T, 0.8 T] that does not touch the start pose.
pub fn original(robot: &Robot, reference: &Trajectory, seed: u64) -> Draw {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = robot.n();
    let mass_scale: Vec<f64> = (0..n).map(|_| rng.gen_range(0.85..1.15)).collect();
    let mass = rng.gen_range(0.05..0.5);
    let t_end = reference.duration();
    let mut ball = None;
    for _ in 0..50 {
        let t = rng.gen_range(0.2..0.8) * t_end;
        let (b, t_ball) = Ball::on_path(reference, robot, t, mass, 0.05, 0.3);
        if b.clearance(robot, reference.q(0)) > 0.01 {
            ball = Some((b, t_ball));
            break;
        }
    }
    Draw {
        dist: Disturbances {
            mass_scale,
            noise_q_std: 0.002,
            seed,
            ..Disturbances::default()
        },
        ball_t_s: ball.as_ref().map(|(_, t)| *t),
        balls: ball
            .map(|(b, _)| vec![Obstacle::Ball(b)])
            .unwrap_or_default(),
    }
}

/// Every mass and inertia x one factor U(0.85, 1.15) (a payload), sensor noise, and a ball on the
/// swinging arm's path (links n - 1 and n, a point 20-100 % along, at [0.2 T, 0.8 T]).
fn coherent_mass(robot: &Robot, reference: &Trajectory, seed: u64) -> Draw {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = robot.n();
    let f = rng.gen_range(0.85..1.15);
    let (balls, ball_t_s) = some_ball(robot, reference, &mut rng, |r| {
        let t = r.gen_range(0.2..0.8);
        (t, n - 2 + r.gen_range(0..2), r.gen_range(0.2..1.0), 0.0)
    });
    Draw {
        dist: Disturbances {
            mass_scale: vec![f; n],
            inertia_scale: vec![f; n],
            ..noisy(seed)
        },
        balls,
        ball_t_s,
    }
}

/// Each link's mass and inertia x its own U(0.85, 1.15) factors, sensor noise, no ball.
fn per_link_mass(robot: &Robot, _reference: &Trajectory, seed: u64) -> Draw {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = robot.n();
    let mut draw = |_| rng.gen_range(0.85..1.15);
    Draw {
        dist: Disturbances {
            mass_scale: (0..n).map(&mut draw).collect(),
            inertia_scale: (0..n).map(&mut draw).collect(),
            ..noisy(seed)
        },
        balls: Vec::new(),
        ball_t_s: None,
    }
}

/// Geometry and inertia mismatch: each link's length x U(0.97, 1.03), centre-of-mass distance x
/// U(0.9, 1.1), inertia x U(0.8, 1.2); sensor noise; no ball.
fn geometry(robot: &Robot, _reference: &Trajectory, seed: u64) -> Draw {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = robot.n();
    let mut v = |lo: f64, hi: f64| (0..n).map(|_| rng.gen_range(lo..hi)).collect::<Vec<f64>>();
    Draw {
        dist: Disturbances {
            length_scale: v(0.97, 1.03),
            com_scale: v(0.9, 1.1),
            inertia_scale: v(0.8, 1.2),
            ..noisy(seed)
        },
        balls: Vec::new(),
        ball_t_s: None,
    }
}

/// A ball anywhere: on any link's path (any point, up to 5 cm off its axis) at any time in
/// [0.05 T, 0.95 T]; sensor noise.
fn ball_anywhere(robot: &Robot, reference: &Trajectory, seed: u64) -> Draw {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = robot.n();
    let (balls, ball_t_s) = some_ball(robot, reference, &mut rng, |r| {
        let t = r.gen_range(0.05..0.95);
        (
            t,
            r.gen_range(0..n),
            r.gen_range(0.0..1.0),
            r.gen_range(-0.05..0.05),
        )
    });
    Draw {
        dist: noisy(seed),
        balls,
        ball_t_s,
    }
}

/// Delays and noise: measurement and actuation delays of 0-5 control periods of 1 ms each, sensor
/// noise sigma_q U(0, 0.003) rad and sigma_qd U(0, 0.03) rad/s, torque noise U(0, 0.2) N m.
fn delays_noise(_robot: &Robot, _reference: &Trajectory, seed: u64) -> Draw {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    Draw {
        dist: Disturbances {
            measurement_delay_s: rng.gen_range(0..=5) as f64 * 1e-3,
            actuation_delay_s: rng.gen_range(0..=5) as f64 * 1e-3,
            noise_q_std: rng.gen_range(0.0..0.003),
            noise_qd_std: rng.gen_range(0.0..0.03),
            torque_noise_std: rng.gen_range(0.0..0.2),
            seed,
            ..Disturbances::default()
        },
        balls: Vec::new(),
        ball_t_s: None,
    }
}

/// A push: an impulse of U(0, 0.3) N s in a uniform direction at a point of a random link at a time
/// in [0.1 T, 0.9 T]; sensor noise.
fn push(robot: &Robot, reference: &Trajectory, seed: u64) -> Draw {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = robot.n();
    let link = rng.gen_range(0..n);
    let j = rng.gen_range(0.0..0.3);
    let a = rng.gen_range(0.0..std::f64::consts::TAU);
    let p = Push {
        t_s: rng.gen_range(0.1..0.9) * reference.duration(),
        link: link + 1,
        point_m: rng.gen_range(0.0..1.0) * robot.lengths()[link],
        impulse_n_s: [j * a.cos(), j * a.sin()],
    };
    Draw {
        dist: Disturbances {
            pushes: vec![p],
            ..noisy(seed)
        },
        balls: Vec::new(),
        ball_t_s: None,
    }
}

/// Everything at once: a coherent mass factor, a ball anywhere, delays and noise, and a push.
fn mixed(robot: &Robot, reference: &Trajectory, seed: u64) -> Draw {
    let c = coherent_mass(robot, reference, seed);
    let b = ball_anywhere(robot, reference, seed ^ 0x5EED_0001);
    let d = delays_noise(robot, reference, seed ^ 0x5EED_0002);
    let p = push(robot, reference, seed ^ 0x5EED_0003);
    let mut dist = d.dist;
    dist.pushes = p.dist.pushes;
    dist.mass_scale = c.dist.mass_scale;
    dist.inertia_scale = c.dist.inertia_scale;
    dist.seed = seed;
    Draw {
        dist,
        balls: b.balls,
        ball_t_s: b.ball_t_s,
    }
}

/// Every Monte Carlo family, the original first.
pub fn families() -> Vec<Family> {
    vec![
        Family {
            name: "monte_carlo",
            what: "per-link mass x U(0.85, 1.15), sigma_q 0.002 rad, a ball on the hand's path",
            draw: original,
        },
        Family {
            name: "mc_coherent_mass",
            what: "all masses and inertias x one U(0.85, 1.15), noise, a ball on the swinging arm",
            draw: coherent_mass,
        },
        Family {
            name: "mc_per_link_mass",
            what: "per-link mass and inertia x U(0.85, 1.15) each, noise",
            draw: per_link_mass,
        },
        Family {
            name: "mc_geometry",
            what:
                "length x U(0.97, 1.03), com x U(0.9, 1.1), inertia x U(0.8, 1.2) per link, noise",
            draw: geometry,
        },
        Family {
            name: "mc_ball_anywhere",
            what: "a ball on any link's path at any time, noise",
            draw: ball_anywhere,
        },
        Family {
            name: "mc_delays_noise",
            what: "0-5 ms measurement and actuation delays, sensor and torque noise",
            draw: delays_noise,
        },
        Family {
            name: "mc_push",
            what: "an impulse of up to 0.3 N s on a random link at a random time, noise",
            draw: push,
        },
        Family {
            name: "mc_mixed",
            what: "coherent mass, a ball anywhere, delays and noise, and a push",
            draw: mixed,
        },
    ]
}
