//! The joint multi-swing problem ([`brachia::planning::MultiSwingOcp`]): its exact derivatives against
//! central finite differences (`brachia::fdcheck`) on every stage (the swings' shooting stages, the
//! capture transition `[x; ee(x) - bar; ee_vel(x)]` into the boundary stage and the grasp-switch map
//! out of it), on an asymmetric 3-link chain and the paper's robot, two and three swings; its bounds
//! (capture rows fixed, the later swings' knot 0 free); the map's Jacobian against the map.
//! Units: rad, rad/s, N m, s, m.

use brachia::fdcheck::{assert_jacobian, assert_ocp_derivatives};
mod common;

use brachia::model::{reroot_jacobian, reroot_state, Circle, ClearanceFn, LinkParams, Robot};
use brachia::planning::DistanceClearanceFn;
use brachia::planning::{Bounds, MultiSwingOcp, SwingOcp, SwingOcpSpec};
use brachia_ocp::{EvalLevel, OcpDims, OcpProblem, Primal, StageBounds, StageEval, TerminalEval};
use common::{chain_robot, random_multipliers};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{PI, TAU};

/// An n-link chain of unequal links (link 1 unlike link n, so the re-rooted chain differs); n = 4:
/// the paper's robot.
fn robot(n: usize) -> Robot {
    if n == 4 {
        return Robot::paper();
    }
    let links = (0..n)
        .map(|i| LinkParams {
            length: 0.2 + 0.03 * i as f64,
            mass: 0.3 + 0.05 * i as f64,
            com: 0.08 + 0.01 * i as f64,
            inertia: 0.01 + 0.004 * i as f64,
            radius: 0.02,
            ..Default::default()
        })
        .collect();
    chain_robot(&format!("chain-{n}"), links, 5.0)
}

/// Swing i of a joint problem: the chain as written for even i, re-rooted for odd i; an obstacle, so
/// the clearance rows are in it; the rest condition at the last knot of the last swing only.
fn phase(robot: &Robot, i: usize, intervals: usize, last: bool) -> SwingOcp {
    let r = if i.is_multiple_of(2) {
        robot.clone()
    } else {
        robot.rerooted().unwrap()
    };
    let n = r.n();
    let clearance = DistanceClearanceFn::new(
        ClearanceFn::new(
            r.clone(),
            &[Circle {
                center: [0.25, -0.45],
                radius: 0.08,
            }][..],
            0.01,
        )
        .unwrap()
        .with_self_collision(true),
    );
    let spec = SwingOcpSpec {
        intervals,
        swing_time_s: 0.07 * intervals as f64,
        substeps: 1 + i % 2,
        q1_diag: (0..n).map(|j| 0.01 + 0.02 * j as f64).collect(),
        r1_diag: (0..n - 1).map(|j| 1.0 + 0.5 * j as f64).collect(),
        x_start: vec![-1.5; 2 * n],
        target: [0.3 + 0.1 * i as f64, -0.1],
        bounds: Bounds {
            qd_end_max: last.then_some(1.0),
            ..Bounds::default()
        },
        parallel_min_stages: 2, // exercise the parallel path too
        substep_clearance: true,
    };
    SwingOcp::new(r, spec, Some(clearance)).unwrap()
}

fn joint(robot: &Robot, swings: usize) -> MultiSwingOcp {
    let phases = (0..swings)
        .map(|i| phase(robot, i, 2 + i % 2, i + 1 == swings))
        .collect();
    let shifts: Vec<f64> = (0..swings - 1)
        .map(|i| PI + TAU * (i as f64 - 1.0))
        .collect();
    MultiSwingOcp::new(phases, &shifts).unwrap()
}

fn random_point(rng: &mut ChaCha8Rng, dims: &OcpDims) -> Primal {
    let mut z = Primal::zeros(dims);
    for (x, u) in z.x.iter_mut().zip(z.u.iter_mut()) {
        for v in x.iter_mut() {
            *v = rng.gen_range(-1.5..1.5);
        }
        for v in u.iter_mut() {
            *v = rng.gen_range(-2.0..2.0);
        }
    }
    z
}

struct Bufs {
    stages: Vec<StageEval>,
    term: TerminalEval,
}

fn bufs(d: &OcpDims) -> Bufs {
    Bufs {
        stages: d.stage_evals(),
        term: d.terminal_eval(),
    }
}

fn eval(ocp: &mut MultiSwingOcp, z: &Primal, level: EvalLevel) -> Bufs {
    let mut b = bufs(ocp.dims());
    ocp.evaluate(z, level, &mut b.stages, &mut b.term).unwrap();
    b
}

fn check_all_derivatives(robot: &Robot, swings: usize, seed: u64) {
    let n = robot.n();
    let mut ocp = joint(robot, swings);
    let mut probe = joint(robot, swings);
    let dims = ocp.dims().clone();
    let boundaries = dims.stages.iter().filter(|s| s.nx == 2 * n + 4).count();
    assert_eq!(boundaries, swings - 1, "one boundary stage per switch");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let z = random_point(&mut rng, &dims);
    // random multipliers, the boundary transitions' included
    let m = random_multipliers(&mut rng, &dims);
    let what = format!("n={n} swings={swings}");
    assert_ocp_derivatives(&what, &mut ocp, &mut probe, &z, 0.7, &m);
}

#[test]
fn joint_problem_derivatives_match_finite_differences() {
    check_all_derivatives(&robot(3), 2, 11);
    check_all_derivatives(&robot(3), 3, 12);
    check_all_derivatives(&robot(4), 2, 13);
}

/// The boundary stage's transition is the grasp-switch map: the re-rooted chain's state of
/// `reroot_state` (up to the representative of q'_1, here `sum q + shift`), its Jacobian the constant
/// `P` of `reroot_jacobian` (checked against central differences of `reroot_state`); the capture
/// transition carries the last knot and the swing's terminal rows.
#[test]
fn the_boundary_is_the_capture_and_the_grasp_switch_map() {
    let robot = robot(3);
    let n = 3;
    let mut ocp = joint(&robot, 2);
    let dims = ocp.dims().clone();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let z = random_point(&mut rng, &dims);
    let b = eval(&mut ocp, &z, EvalLevel::FirstOrder);
    let last0 = *ocp.phase_stages(0).end();
    let bs = last0 + 1;
    let xb = &z.x[bs][..2 * n];
    let mut mapped = vec![0.0; 2 * n];
    reroot_state(xb, &mut mapped);
    let f = &b.stages[bs].f;
    let sum: f64 = xb[..n].iter().sum();
    assert!(
        (f[0] - (sum + PI - TAU)).abs() < 1e-14,
        "q'_1 = sum q + shift"
    );
    let turns = (f[0] - mapped[0]) / TAU;
    assert!(
        (turns - turns.round()).abs() < 1e-12,
        "q'_1 {} vs {}",
        f[0],
        mapped[0]
    );
    for e in 1..2 * n {
        assert_eq!(f[e], mapped[e], "entry {e}");
    }
    let mut p = vec![0.0; 2 * n * 2 * n];
    reroot_jacobian(n, 2 * n, &mut p);
    // q1 near 0 so no wrap inside the differences
    let x0 = [0.3, -0.2, 0.1, 0.4, -0.5, 0.6];
    assert_jacobian("reroot_jacobian", reroot_state, &x0, &p, 1e-9);
    // capture transition: [x_K; ee - target; ee_vel]
    let fk = &b.stages[last0].f;
    assert_eq!(&fk[..2 * n], &z.x[last0][..]);
    let q = &z.x[last0][..n];
    let qd = &z.x[last0][n..];
    let ee = robot.ee_position(q);
    let v = robot.ee_velocity(q, qd);
    let target = ocp.phase(0).target();
    for (a, b) in fk[2 * n..]
        .iter()
        .zip([ee[0] - target[0], ee[1] - target[1], v[0], v[1]])
    {
        assert!((a - b).abs() < 1e-13, "{a} vs {b}");
    }
}

#[test]
fn the_capture_is_fixed_and_later_swings_start_free() {
    let robot = robot(3);
    let n = 3;
    let ocp = joint(&robot, 3);
    let dims = ocp.dims().clone();
    let bounds = |k: usize| {
        let mut b = StageBounds::unbounded(dims.stages[k]);
        ocp.bounds(k, &mut b);
        b
    };
    // swing 0's knot 0 is its fixed start state
    let b0 = bounds(0);
    assert_eq!(b0.x_lo, b0.x_hi);
    for i in 0..3 {
        let r = ocp.phase_stages(i);
        let (first, last) = (*r.start(), *r.end());
        if i > 0 {
            let b = bounds(first);
            assert!(b.x_lo.iter().all(|v| *v == f64::NEG_INFINITY));
            assert!(b.x_hi.iter().all(|v| *v == f64::INFINITY));
        }
        let bl = bounds(last);
        let qd_end = if i == 2 { 1.0 } else { 15.0 };
        assert_eq!(
            bl.x_hi[n], qd_end,
            "swing {i}: the rest condition only at the end"
        );
        if i < 2 {
            let bb = bounds(last + 1);
            assert_eq!(&bb.x_lo[2 * n..], &[0.0; 4]);
            assert_eq!(&bb.x_hi[2 * n..], &[0.0; 4]);
            assert!(bb.x_lo[..2 * n].iter().all(|v| *v == f64::NEG_INFINITY));
        }
    }
}

#[test]
fn a_joint_problem_is_refused_with_the_wrong_shifts_or_mixed_link_counts() {
    let r3 = robot(3);
    let r4 = robot(4);
    let two = || vec![phase(&r3, 0, 2, false), phase(&r3, 1, 2, true)];
    assert!(MultiSwingOcp::new(two(), &[]).is_err());
    assert!(MultiSwingOcp::new(two(), &[f64::NAN]).is_err());
    assert!(MultiSwingOcp::new(Vec::new(), &[]).is_err());
    let mixed = vec![phase(&r3, 0, 2, false), phase(&r4, 1, 2, true)];
    assert!(MultiSwingOcp::new(mixed, &[PI]).is_err());
    assert!(MultiSwingOcp::new(two(), &[PI]).is_ok());
}
