//! The OCP-as-NLP adapter: its sparse Jacobian and lower-triangle Hessian against finite differences
//! (`brachia::fdcheck`), and pounce solving a coarse multiple-shooting swing to `Solved`, with the
//! stage-structured solver reaching the same optimum on the very same problem. Units: rad, m, s, N m.

use brachia::fdcheck::{assert_hessian, assert_jacobian};
use brachia::model::{ik_from_seed, mirrored_pose};
use brachia::model::{Circle, ClearanceFn, Robot};
use brachia::planning::nlp::SparseNlp;
use brachia::planning::DistanceClearanceFn;
use brachia::planning::{
    freefall_time, solve, Bounds, NlpSettings, OcpNlp, SolveStatus, SwingOcp, SwingOcpSpec,
};
use brachia_ocp::{OcpProblem, OcpSettings, OcpSolver};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const Q0: [f64; 4] = [-2.35, 0.0, -1.55, 0.0];
const TARGET: [f64; 2] = [0.8, 0.0];

fn spec(intervals: usize, t: f64) -> SwingOcpSpec {
    SwingOcpSpec {
        intervals,
        swing_time_s: t,
        substeps: 1,
        q1_diag: vec![0.01; 4],
        r1_diag: vec![1.0; 3],
        x_start: [Q0, [0.0; 4]].concat(),
        target: TARGET,
        bounds: Bounds::default(),
        parallel_min_stages: usize::MAX,
        substep_clearance: true,
    }
}

fn dense(rows: &[usize], cols: &[usize], vals: &[f64], m: usize, n: usize, sym: bool) -> Vec<f64> {
    let mut d = vec![0.0; m * n];
    for k in 0..vals.len() {
        d[rows[k] * n + cols[k]] += vals[k];
        if sym && rows[k] != cols[k] {
            d[cols[k] * n + rows[k]] += vals[k];
        }
    }
    d
}

#[test]
fn adapter_derivatives_match_finite_differences() {
    let robot = Robot::paper();
    let obstacles = [Circle {
        center: [0.3, -0.5],
        radius: 0.1,
    }];
    let make = || {
        let cf = DistanceClearanceFn::new(
            ClearanceFn::new(robot.clone(), &obstacles[..], 0.01).unwrap(),
        );
        OcpNlp::new(SwingOcp::new(robot.clone(), spec(3, 0.3), Some(cf)).unwrap())
    };
    let (mut nlp, mut probe) = (make(), make());
    let (nv, m) = (nlp.n_vars(), nlp.n_cons());
    assert_eq!(nv, 3 * 11 + 8); // x_3 has no input
    let nc = nlp.problem().n_clearance();
    assert_eq!(nc, 4 + 10); // 4 links vs the obstacle, 10 end-point rows of the 3 non-adjacent pairs
    assert_eq!(m, 3 * 8 + 3 * nc + 4); // dynamics, clearance (k >= 1), terminal
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let x: Vec<f64> = (0..nv)
        .map(|i| match i % 11 {
            0 => rng.gen_range(-2.4..-0.8),
            1..=3 => rng.gen_range(-1.0..1.0),
            _ => rng.gen_range(-1.5..1.5),
        })
        .collect();
    let (jr, jc) = nlp.jacobian_structure();
    let mut seen = std::collections::HashSet::new();
    assert!(jr.iter().zip(&jc).all(|e| seen.insert(e)), "no duplicates");
    let mut jv = vec![0.0; jr.len()];
    nlp.jacobian_values(&x, &mut jv);
    let jac = dense(&jr, &jc, &jv, m, nv, false);
    assert_jacobian(
        "adapter constraint Jacobian",
        |x, g| probe.constraints(x, g),
        &x,
        &jac,
        1e-6,
    );
    let mut grad = vec![0.0; nv];
    nlp.gradient(&x, &mut grad);
    assert_jacobian(
        "adapter objective gradient",
        |x, f| f[0] = probe.objective(x),
        &x,
        &grad,
        1e-7,
    );
    let lam: Vec<f64> = (0..m).map(|_| rng.gen_range(-1.0..1.0)).collect();
    let sigma = 0.6;
    let (hr, hc) = nlp.hessian_structure();
    assert!(hr.iter().zip(&hc).all(|(r, c)| r >= c), "lower triangle");
    let mut hv = vec![0.0; hr.len()];
    nlp.hessian_values(&x, sigma, &lam, &mut hv);
    let hess = dense(&hr, &hc, &hv, nv, nv, true);
    assert_hessian(
        "adapter Lagrangian Hessian",
        |x, g| {
            probe.gradient(x, g);
            g.iter_mut().for_each(|v| *v *= sigma);
            let mut jv = vec![0.0; jr.len()];
            probe.jacobian_values(x, &mut jv);
            for k in 0..jv.len() {
                g[jc[k]] += lam[jr[k]] * jv[k];
            }
        },
        &x,
        &hess,
        1e-5,
    );
}

/// The coarse tracking swing (100 ms intervals) with the planner's guess: a smooth step to the
/// inverse-kinematics target pose, torques zero.
fn coarse_swing(robot: &Robot) -> SwingOcp {
    let start_ee = robot.ee_position(&Q0);
    let t = 2.0 * freefall_time(robot, &Q0, 0.5 * (start_ee[0] + TARGET[0])).unwrap();
    let k_last = (t / 0.1).round() as usize;
    let mut ocp = SwingOcp::new(robot.clone(), spec(k_last, t), None).unwrap();
    let qt = ik_from_seed(robot, &mirrored_pose(&Q0), TARGET).unwrap();
    let g = ocp.guess_mut();
    for k in 1..=k_last {
        let r = k as f64 / k_last as f64;
        let (s, sd) = (r * r * (3.0 - 2.0 * r), 6.0 * r * (1.0 - r) / t);
        for i in 0..4 {
            g.x[k][i] = Q0[i] + s * (qt[i] - Q0[i]);
            g.x[k][4 + i] = sd * (qt[i] - Q0[i]);
        }
    }
    ocp
}

#[test]
fn pounce_solves_a_coarse_swing_and_the_ocp_solver_agrees() {
    let robot = Robot::paper();
    let mut nlp = OcpNlp::new(coarse_swing(&robot));
    let sol = solve(
        &mut nlp,
        &NlpSettings {
            backend: brachia::planning::Backend::Pounce,
            ..NlpSettings::default()
        },
    );
    assert_eq!(sol.status, SolveStatus::Solved, "{}", sol.backend_status);
    assert!(sol.max_constraint_violation < 1e-8);

    let mut ocp = coarse_swing(&robot);
    let mut solver = OcpSolver::new(ocp.dims()).unwrap();
    let stats = solver.solve(&mut ocp, &OcpSettings::default());
    assert!(stats.status.is_converged(), "{:?}", stats.status);
    let rel = (stats.objective - sol.objective).abs() / sol.objective;
    assert!(
        rel < 1e-6,
        "ocp {} vs pounce {} (rel {rel:e})",
        stats.objective,
        sol.objective
    );
}
