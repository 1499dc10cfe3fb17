//! The multiple-shooting problem's exact derivatives against central finite differences
//! (`brachia::fdcheck`): every stage's dynamics and clearance Jacobian, every stage's Lagrangian
//! Hessian (second-order adjoint through the RK4 stages), the terminal rows; and the shooting map Phi
//! against `brachia::integrate::Rk4` on the same inputs. Robots with n = 3, 4 and 6 links; one and three
//! RK4 sub-steps. Units: rad, rad/s, N m, s, m.

use brachia::fdcheck::assert_ocp_derivatives;
use brachia::integrate::Rk4;
mod common;

use brachia::ad::{Diff, LocalFn};
use brachia::math::Scalar;
use brachia::model::{Circle, ClearanceFn, LinkParams, Robot, Scratch};
use brachia::planning::DistanceClearanceFn;
use brachia::planning::{
    AdDynamics, AnalyticDynamics, Bounds, PointDynamics, SwingOcp, SwingOcpSpec,
};
use brachia_ocp::{EvalLevel, OcpDims, OcpProblem, Primal, StageEval, TerminalEval};
use common::{chain_robot, random_multipliers};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// An n-link chain of unequal links (n = 4: the paper's robot).
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

const OBSTACLES: [Circle; 2] = [
    Circle {
        center: [0.25, -0.45],
        radius: 0.08,
    },
    Circle {
        center: [-0.35, -0.3],
        radius: 0.05,
    },
];

fn problem<D: PointDynamics>(robot: &Robot, intervals: usize, substeps: usize) -> SwingOcp<D> {
    // from 3 stages on, half of them on the problem's helper thread: exercise that path too
    problem_split::<D>(robot, intervals, substeps, 3)
}

fn problem_split<D: PointDynamics>(
    robot: &Robot,
    intervals: usize,
    substeps: usize,
    parallel_min_stages: usize,
) -> SwingOcp<D> {
    let n = robot.n();
    let clearance = DistanceClearanceFn::new(
        ClearanceFn::new(robot.clone(), &OBSTACLES[..], 0.01)
            .unwrap()
            .with_self_collision(true),
    );
    let spec = SwingOcpSpec {
        intervals,
        swing_time_s: 0.06 * intervals as f64,
        substeps,
        q1_diag: (0..n).map(|i| 0.01 + 0.02 * i as f64).collect(),
        r1_diag: (0..n - 1).map(|j| 1.0 + 0.5 * j as f64).collect(),
        x_start: vec![0.0; 2 * n],
        target: [0.3, -0.1],
        bounds: Bounds::default(),
        parallel_min_stages,
        substep_clearance: true,
    };
    SwingOcp::with_dynamics(robot.clone(), spec, Some(clearance)).unwrap()
}

fn random_point(rng: &mut ChaCha8Rng, dims: &OcpDims) -> Primal {
    let mut z = Primal::zeros(dims);
    let n = z.x[0].len() / 2;
    for (x, u) in z.x.iter_mut().zip(z.u.iter_mut()) {
        x[0] = rng.gen_range(-2.4..-0.7);
        for v in &mut x[1..n] {
            *v = rng.gen_range(-1.2..1.2);
        }
        for v in &mut x[n..] {
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

fn eval(ocp: &mut dyn OcpProblem, z: &Primal, level: EvalLevel) -> Bufs {
    let mut b = bufs(ocp.dims());
    ocp.evaluate(z, level, &mut b.stages, &mut b.term).unwrap();
    b
}

fn check_all_derivatives<D: PointDynamics>(robot: &Robot, substeps: usize, seed: u64) {
    let intervals = 3;
    let mut ocp: SwingOcp<D> = problem(robot, intervals, substeps);
    let mut probe: SwingOcp<D> = problem(robot, intervals, substeps);
    assert!(ocp.n_clearance() > 0);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let z = random_point(&mut rng, ocp.dims());
    let m = random_multipliers(&mut rng, ocp.dims());
    let what = format!("n={} substeps={substeps}", robot.n());
    assert_ocp_derivatives(&what, &mut ocp, &mut probe, &z, 0.7, &m);
}

#[test]
fn derivatives_match_finite_differences_for_3_4_6_links() {
    for (n, seed) in [(3, 1), (4, 2), (6, 3)] {
        let robot = robot(n);
        check_all_derivatives::<AnalyticDynamics>(&robot, 1, seed);
        check_all_derivatives::<AdDynamics>(&robot, 1, seed);
    }
}

#[test]
fn derivatives_match_finite_differences_with_substeps() {
    check_all_derivatives::<AnalyticDynamics>(&robot(4), 3, 7);
    check_all_derivatives::<AdDynamics>(&robot(6), 2, 8);
}

#[test]
fn shooting_map_is_rk4_on_the_same_inputs() {
    for n in [3, 4, 6] {
        for substeps in [1, 2, 5] {
            let robot = robot(n);
            let mut ocp: SwingOcp = problem(&robot, 3, substeps);
            let mut rng = ChaCha8Rng::seed_from_u64(n as u64 * 10 + substeps as u64);
            let z = random_point(&mut rng, ocp.dims());
            let h = ocp.interval();
            let mut rk4 = Rk4::new(&robot);
            for level in [EvalLevel::Values, EvalLevel::FirstOrder] {
                let b = eval(&mut ocp, &z, level);
                for k in 0..3 {
                    let mut x = z.x[k].clone();
                    rk4.advance(&robot, &mut x, &z.u[k], h, substeps);
                    let err = x
                        .iter()
                        .zip(&b.stages[k].f)
                        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
                    assert!(
                        err <= 1e-13,
                        "n={n} substeps={substeps} stage {k} {level:?}: |Phi - Rk4| = {err:e}"
                    );
                }
            }
        }
    }
}

#[test]
fn hessian_does_not_depend_on_which_point_was_evaluated_last() {
    // The Hessian reuses the forward record of the last first-order evaluation when it is at the same
    // point; at another point it must recompute it.
    let robot = robot(4);
    let mut ocp: SwingOcp = problem(&robot, 3, 2);
    let mut fresh: SwingOcp = problem(&robot, 3, 2);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (z1, z2) = (
        random_point(&mut rng, ocp.dims()),
        random_point(&mut rng, ocp.dims()),
    );
    let m = random_multipliers(&mut rng, ocp.dims());
    eval(&mut ocp, &z1, EvalLevel::FirstOrder);
    eval(&mut ocp, &z2, EvalLevel::Values);
    let mut a = bufs(ocp.dims());
    ocp.hessians(&z2, 1.0, &m, &mut a.stages).unwrap();
    eval(&mut fresh, &z2, EvalLevel::FirstOrder);
    let mut b = bufs(fresh.dims());
    fresh.hessians(&z2, 1.0, &m, &mut b.stages).unwrap();
    for k in 0..4 {
        assert_eq!(a.stages[k].hess, b.stages[k].hess, "stage {k}");
    }
}

#[test]
fn closed_form_and_automatic_differentiation_agree_stage_by_stage() {
    // AD is the oracle of the closed-form derivatives: same Jacobians and Hessians to rounding.
    for n in [3, 4, 6] {
        let robot = robot(n);
        let mut an: SwingOcp<AnalyticDynamics> = problem(&robot, 4, 2);
        let mut ad: SwingOcp<AdDynamics> = problem(&robot, 4, 2);
        let mut rng = ChaCha8Rng::seed_from_u64(40 + n as u64);
        let z = random_point(&mut rng, an.dims());
        let m = random_multipliers(&mut rng, an.dims());
        let (a, b) = (
            eval(&mut an, &z, EvalLevel::FirstOrder),
            eval(&mut ad, &z, EvalLevel::FirstOrder),
        );
        let (mut ha, mut hb) = (bufs(an.dims()), bufs(ad.dims()));
        an.hessians(&z, 0.9, &m, &mut ha.stages).unwrap();
        ad.hessians(&z, 0.9, &m, &mut hb.stages).unwrap();
        let close = |x: &[f64], y: &[f64]| {
            x.iter()
                .zip(y)
                .all(|(p, q)| (p - q).abs() <= 1e-9 * p.abs().max(q.abs()).max(1.0))
        };
        for k in 0..=4 {
            assert!(close(&a.stages[k].f, &b.stages[k].f), "n={n} stage {k} f");
            assert!(
                close(&a.stages[k].jac_f, &b.stages[k].jac_f),
                "n={n} stage {k} jac"
            );
            assert!(
                close(&ha.stages[k].hess, &hb.stages[k].hess),
                "n={n} stage {k} hess"
            );
        }
    }
}

// ---- free swing time: T as the last state component ----

/// A free-swing-time problem (T in [0.05, 2] s) and a random point with T in [0.12, 0.3] s (3 intervals).
fn free_problem<D: PointDynamics>(robot: &Robot, intervals: usize, substeps: usize) -> SwingOcp<D> {
    problem::<D>(robot, intervals, substeps)
        .with_free_swing_time(0.05, 2.0)
        .unwrap()
}

fn random_free_point(rng: &mut ChaCha8Rng, dims: &OcpDims) -> Primal {
    let mut z = random_point(rng, dims);
    let nx = z.x[0].len() - 1;
    let t = rng.gen_range(0.12..0.3);
    for x in &mut z.x {
        // T slightly different per stage: the derivatives hold off the feasible set too
        x[nx] = t * rng.gen_range(0.95..1.05);
    }
    z
}

#[test]
fn free_swing_time_derivatives_match_finite_differences() {
    for (n, substeps, seed) in [(3, 1, 11), (4, 1, 12), (4, 3, 13), (6, 2, 14)] {
        let robot = robot(n);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut ocp: SwingOcp = free_problem(&robot, 3, substeps);
        let mut probe: SwingOcp = free_problem(&robot, 3, substeps);
        assert_eq!(ocp.dims().stages[0].nx, 2 * n + 1);
        let z = random_free_point(&mut rng, ocp.dims());
        let m = random_multipliers(&mut rng, ocp.dims());
        let what = format!("free T, n={n} substeps={substeps}");
        assert_ocp_derivatives(&what, &mut ocp, &mut probe, &z, 0.7, &m);
        let mut ocp: SwingOcp<AdDynamics> = free_problem(&robot, 3, substeps);
        let mut probe: SwingOcp<AdDynamics> = free_problem(&robot, 3, substeps);
        assert_ocp_derivatives(&(what + " (AD points)"), &mut ocp, &mut probe, &z, 0.7, &m);
    }
}

/// One stage's flow `Phi(q, qd, T, u)` (RK4, `substeps` steps of `T / (K substeps)`) written once for
/// any scalar type: the AD oracle of the free-swing-time derivatives, independent of the shooting
/// problem's forward and reverse sweeps.
struct FreeFlowFn {
    robot: Robot,
    intervals: usize,
    substeps: usize,
}

impl LocalFn for FreeFlowFn {
    type Scratch<T: Scalar> = Scratch<T>;
    fn n_in(&self) -> usize {
        3 * self.robot.n()
    }
    fn n_out(&self) -> usize {
        2 * self.robot.n()
    }
    fn scratch<T: Scalar>(&self) -> Scratch<T> {
        Scratch::new(self.robot.n())
    }
    fn eval<T: Scalar>(&self, ws: &mut Scratch<T>, z: &[T], out: &mut [T]) {
        let n = self.robot.n();
        let nx = 2 * n;
        let hs = z[nx] * (1.0 / (self.intervals * self.substeps) as f64);
        let u = &z[nx + 1..];
        let mut x: Vec<T> = z[..nx].to_vec();
        let deriv = |ws: &mut Scratch<T>, y: &[T]| -> Vec<T> {
            let mut k = vec![y[0] * 0.0; nx];
            k[..n].copy_from_slice(&y[n..]);
            let mut qdd = vec![y[0] * 0.0; n];
            self.robot
                .forward_dynamics_into(ws, &y[..n], &y[n..], u, &mut qdd);
            k[n..].copy_from_slice(&qdd);
            k
        };
        for _ in 0..self.substeps {
            let k1 = deriv(ws, &x);
            let y2: Vec<T> = (0..nx).map(|a| x[a] + hs * 0.5 * k1[a]).collect();
            let k2 = deriv(ws, &y2);
            let y3: Vec<T> = (0..nx).map(|a| x[a] + hs * 0.5 * k2[a]).collect();
            let k3 = deriv(ws, &y3);
            let y4: Vec<T> = (0..nx).map(|a| x[a] + hs * k3[a]).collect();
            let k4 = deriv(ws, &y4);
            for a in 0..nx {
                x[a] += hs * (1.0 / 6.0) * (k1[a] + k2[a] * 2.0 + k3[a] * 2.0 + k4[a]);
            }
        }
        out.copy_from_slice(&x);
    }
}

#[test]
fn free_swing_time_flow_derivatives_agree_with_automatic_differentiation_of_the_whole_flow() {
    // The T column of the dynamics Jacobian and the T row of the Hessian of lam^T Phi are the
    // shooting problem's own composition (tangent pass and second-order adjoint): AD of the whole
    // flow, written independently above, is their oracle. sigma = 0 and mu = 0 leave Phi's part.
    for (n, substeps) in [(3, 1), (4, 1), (4, 3), (6, 2)] {
        let robot = robot(n);
        let nx = 2 * n;
        let k_int = 4;
        let mut ocp: SwingOcp = free_problem(&robot, k_int, substeps);
        let mut rng = ChaCha8Rng::seed_from_u64(60 + n as u64 + substeps as u64);
        let z = random_free_point(&mut rng, ocp.dims());
        let mut m = random_multipliers(&mut rng, ocp.dims());
        for v in m.mu.iter_mut().flat_map(|v| v.iter_mut()) {
            *v = 0.0;
        }
        let b = eval(&mut ocp, &z, EvalLevel::FirstOrder);
        let mut hb = bufs(ocp.dims());
        ocp.hessians(&z, 0.0, &m, &mut hb.stages).unwrap();
        let f = FreeFlowFn {
            robot: robot.clone(),
            intervals: k_int,
            substeps,
        };
        let mut diff = Diff::new(&f);
        let nz = 3 * n;
        for k in 0..k_int {
            let zk = [z.x[k].as_slice(), &z.u[k]].concat();
            let (mut val, mut jac, mut hess) =
                (vec![0.0; nx], vec![0.0; nx * nz], vec![0.0; nz * nz]);
            diff.jacobian(&f, &zk, &mut val, &mut jac);
            diff.hessian_weighted(&f, &zk, &m.lam[k][..nx], &mut hess);
            let close = |p: f64, q: f64| (p - q).abs() <= 1e-9 * p.abs().max(q.abs()).max(1.0);
            for a in 0..nx {
                assert!(close(val[a], b.stages[k].f[a]), "n={n} stage {k} f[{a}]");
                for c in 0..nz {
                    let (p, q) = (jac[a * nz + c], b.stages[k].jac_f[a * nz + c]);
                    assert!(
                        close(p, q),
                        "n={n} m={substeps} stage {k} jac[{a}][{c}]: AD {p} vs {q}"
                    );
                }
            }
            // the T row of the dynamics: T_{k+1} = T_k
            assert_eq!(b.stages[k].f[nx], z.x[k][nx]);
            for a in 0..nz {
                for c in 0..nz {
                    let (p, q) = (hess[a * nz + c], hb.stages[k].hess[a * nz + c]);
                    assert!(
                        close(p, q),
                        "n={n} m={substeps} stage {k} hess[{a}][{c}]: AD {p} vs {q}"
                    );
                }
            }
        }
    }
}

/// Half the stages on the problem's helper thread give the numbers of every stage on the calling
/// thread, bit for bit: values, first order and Hessians at several points, in an order where a
/// Hessian follows a value-only evaluation at another point (the recorded forward pass), with a
/// fixed and a free swing time.
#[test]
fn the_helper_thread_evaluates_the_same_numbers_as_the_calling_thread() {
    let robot = robot(4);
    // a fixed T, a free T, and a fixed T again after a free one (the helper's buffers resized twice)
    for (free, round_trip) in [(false, false), (true, false), (false, true)] {
        let build = |min_stages: usize| {
            let p: SwingOcp = problem_split(&robot, 9, 2, min_stages);
            if free {
                p.with_free_swing_time(0.05, 2.0).unwrap()
            } else if round_trip {
                p.with_free_swing_time(0.05, 2.0)
                    .unwrap()
                    .with_fixed_swing_time(0.5)
                    .unwrap()
            } else {
                p
            }
        };
        let (mut split, mut serial) = (build(0), build(usize::MAX));
        assert!(!serial.has_helper_thread());
        if rayon::current_num_threads() > 1 {
            assert!(split.has_helper_thread());
        }
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let point = |rng: &mut ChaCha8Rng, dims: &OcpDims| {
            if free {
                random_free_point(rng, dims)
            } else {
                random_point(rng, dims)
            }
        };
        let same = |a: &Bufs, b: &Bufs, what: &str| {
            for (k, (x, y)) in a.stages.iter().zip(&b.stages).enumerate() {
                let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                assert_eq!(x.cost.to_bits(), y.cost.to_bits(), "{what}: cost at {k}");
                for (name, u, v) in [
                    ("grad", &x.grad, &y.grad),
                    ("f", &x.f, &y.f),
                    ("jac_f", &x.jac_f, &y.jac_f),
                    ("c", &x.c, &y.c),
                    ("jac_c", &x.jac_c, &y.jac_c),
                    ("hess", &x.hess, &y.hess),
                ] {
                    assert_eq!(
                        bits(u),
                        bits(v),
                        "{what}: {name} at stage {k} (free {free})"
                    );
                }
            }
            assert_eq!(a.term.r, b.term.r, "{what}: terminal rows");
            assert_eq!(a.term.jac_r, b.term.jac_r, "{what}: terminal Jacobian");
        };
        for round in 0..3 {
            let z1 = point(&mut rng, split.dims());
            let z2 = point(&mut rng, split.dims());
            let m = random_multipliers(&mut rng, split.dims());
            let (mut a, mut b) = (bufs(split.dims()), bufs(serial.dims()));
            for (ocp, out) in [(&mut split, &mut a), (&mut serial, &mut b)] {
                ocp.evaluate(&z1, EvalLevel::FirstOrder, &mut out.stages, &mut out.term)
                    .unwrap();
            }
            same(&a, &b, &format!("first order, round {round}"));
            for (ocp, out) in [(&mut split, &mut a), (&mut serial, &mut b)] {
                ocp.evaluate(&z2, EvalLevel::Values, &mut out.stages, &mut out.term)
                    .unwrap();
                ocp.hessians(&z1, 0.7, &m, &mut out.stages).unwrap();
            }
            same(
                &a,
                &b,
                &format!("values at z2, Hessian at z1, round {round}"),
            );
            for (ocp, out) in [(&mut split, &mut a), (&mut serial, &mut b)] {
                ocp.evaluate(&z2, EvalLevel::FirstOrder, &mut out.stages, &mut out.term)
                    .unwrap();
                ocp.hessians(&z2, 1.3, &m, &mut out.stages).unwrap();
            }
            same(
                &a,
                &b,
                &format!("first order and Hessian at z2, round {round}"),
            );
        }
        // called from a rayon worker, the problem with a helper evaluates every stage there
        let z = point(&mut rng, split.dims());
        let m = random_multipliers(&mut rng, split.dims());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let a = pool.install(|| {
            let mut a = bufs(split.dims());
            split
                .evaluate(&z, EvalLevel::FirstOrder, &mut a.stages, &mut a.term)
                .unwrap();
            split.hessians(&z, 0.9, &m, &mut a.stages).unwrap();
            a
        });
        let mut b = bufs(serial.dims());
        serial
            .evaluate(&z, EvalLevel::FirstOrder, &mut b.stages, &mut b.term)
            .unwrap();
        serial.hessians(&z, 0.9, &m, &mut b.stages).unwrap();
        same(&a, &b, "on a rayon worker");
    }
}
