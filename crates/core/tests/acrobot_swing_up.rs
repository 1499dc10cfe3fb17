//! Known answers before the robot: an acrobot swing-up (Spong's acrobot, torque at the elbow only,
//! RK4 steps, minimum effort, |tau| <= TAU_MAX, from hanging to upright at rest), solved by the
//! stage-structured solver (brachia-ocp) and by pounce (IPOPT's algorithm) on the identical problem
//! through [`OcpNlp`], from the same initial guess: both converge, to the same optimum.
//! The swing-up is multimodal: from this straight-line guess, other horizons and torque limits
//! send the two solvers to different local optima (docs/ocp.md section 11), so the test fixes
//! K = 25, h = 0.1 s, |tau| <= 30 N m (T = 2.5 s), where both reach the same one.
//! Exact derivatives by forward-mode AD (`brachia::ad`), checked against finite differences
//! (`brachia::fdcheck`). Units: rad, rad/s, s, N m, kg, m.

use brachia::ad::{as_f64_fn, Diff, LocalFn};
use brachia::fdcheck::{assert_hessian, assert_jacobian};
use brachia::math::{c, Scalar};
use brachia::planning::{solve, NlpSettings, OcpNlp};
use brachia_ocp::{
    EvalError, EvalLevel, Multipliers, OcpDims, OcpProblem, OcpSettings, OcpSolver, OcpStatus,
    Primal, StageBounds, StageDims, StageEval, TerminalEval,
};
use std::f64::consts::PI;

const K: usize = 25;
const H: f64 = 0.1;
const TAU_MAX: f64 = 30.0;
const GRAV: f64 = 9.81;
// m1 = m2 = 1 kg, l1 = 1 m, centres of mass lc1 = lc2 = 0.5 m, inertias about the joints 1/3 kg m^2
const M2: f64 = 1.0;
const L1: f64 = 1.0;
const LC1: f64 = 0.5;
const LC2: f64 = 0.5;
const I1: f64 = 1.0 / 3.0;
const I2: f64 = 1.0 / 3.0;
const M1: f64 = 1.0;

/// One RK4 step of the acrobot: z = [q1, q2, v1, v2, tau] -> x+ (q1 from the downward vertical,
/// q2 relative to link 1).
struct Step;

fn accel<T: Scalar>(x: &[T; 4], tau: T) -> [T; 4] {
    let (s2, c2) = (x[1].sin(), x[1].cos());
    let m11 = c::<T>(I1 + I2 + M2 * L1 * L1) + c::<T>(2.0 * M2 * L1 * LC2) * c2;
    let m12 = c::<T>(I2) + c::<T>(M2 * L1 * LC2) * c2;
    let m22 = c::<T>(I2);
    let hc = c::<T>(M2 * L1 * LC2) * s2;
    let cor1 = -hc * (c::<T>(2.0) * x[2] * x[3] + x[3] * x[3]);
    let cor2 = hc * x[2] * x[2];
    let s12 = (x[0] + x[1]).sin();
    let g1 = c::<T>((M1 * LC1 + M2 * L1) * GRAV) * x[0].sin() + c::<T>(M2 * LC2 * GRAV) * s12;
    let g2 = c::<T>(M2 * LC2 * GRAV) * s12;
    let (b1, b2) = (-cor1 - g1, tau - cor2 - g2);
    let det = m11 * m22 - m12 * m12;
    [
        x[2],
        x[3],
        (m22 * b1 - m12 * b2) / det,
        (m11 * b2 - m12 * b1) / det,
    ]
}

impl LocalFn for Step {
    type Scratch<T: Scalar> = ();
    fn n_in(&self) -> usize {
        5
    }
    fn n_out(&self) -> usize {
        4
    }
    fn scratch<T: Scalar>(&self) -> Self::Scratch<T> {}
    fn eval<T: Scalar>(&self, _: &mut (), z: &[T], out: &mut [T]) {
        let x = [z[0], z[1], z[2], z[3]];
        let tau = z[4];
        let add = |a: &[T; 4], k: &[T; 4], s: f64| {
            [
                a[0] + k[0] * c::<T>(s),
                a[1] + k[1] * c::<T>(s),
                a[2] + k[2] * c::<T>(s),
                a[3] + k[3] * c::<T>(s),
            ]
        };
        let k1 = accel(&x, tau);
        let k2 = accel(&add(&x, &k1, 0.5 * H), tau);
        let k3 = accel(&add(&x, &k2, 0.5 * H), tau);
        let k4 = accel(&add(&x, &k3, H), tau);
        for i in 0..4 {
            out[i] = x[i]
                + (k1[i] + c::<T>(2.0) * k2[i] + c::<T>(2.0) * k3[i] + k4[i]) * c::<T>(H / 6.0);
        }
    }
}

/// Minimum effort `sum h/2 tau_k^2`, x_0 = 0 (hanging at rest), r(x_K) = x_K - (pi, 0, 0, 0).
struct Acrobot {
    dims: OcpDims,
    diff: Diff<Step>,
}

impl Acrobot {
    fn new() -> Self {
        let stages = (0..=K)
            .map(|k| StageDims {
                nx: 4,
                nu: usize::from(k < K),
                nc: 0,
            })
            .collect();
        Acrobot {
            dims: OcpDims {
                stages,
                n_terminal: 4,
            },
            diff: Diff::new(&Step),
        }
    }
}

impl OcpProblem for Acrobot {
    fn dims(&self) -> &OcpDims {
        &self.dims
    }
    fn bounds(&self, k: usize, b: &mut StageBounds) {
        if k == 0 {
            b.x_lo.fill(0.0);
            b.x_hi.fill(0.0);
        }
        if k < K {
            b.u_lo[0] = -TAU_MAX;
            b.u_hi[0] = TAU_MAX;
        }
    }
    fn initial_guess(&self, z: &mut Primal) {
        // the angle of link 1 interpolated from hanging to upright, at rest, no torque
        for (k, x) in z.x.iter_mut().enumerate() {
            x[0] = PI * k as f64 / K as f64;
        }
    }
    fn evaluate(
        &mut self,
        z: &Primal,
        level: EvalLevel,
        stages: &mut [StageEval],
        terminal: &mut TerminalEval,
    ) -> Result<(), EvalError> {
        let mut zk = [0.0; 5];
        for k in 0..=K {
            let e = &mut stages[k];
            if k == K {
                e.cost = 0.0;
                e.grad.fill(0.0);
                break;
            }
            let tau = z.u[k][0];
            e.cost = 0.5 * H * tau * tau;
            zk[..4].copy_from_slice(&z.x[k]);
            zk[4] = tau;
            if level == EvalLevel::FirstOrder {
                e.grad.fill(0.0);
                e.grad[4] = H * tau;
                self.diff.jacobian(&Step, &zk, &mut e.f, &mut e.jac_f);
            } else {
                self.diff.value(&Step, &zk, &mut e.f);
            }
        }
        let xk = &z.x[K];
        for i in 0..4 {
            terminal.r[i] = xk[i] - if i == 0 { PI } else { 0.0 };
        }
        if level == EvalLevel::FirstOrder {
            terminal.jac_r.fill(0.0);
            for i in 0..4 {
                terminal.jac_r[i * 4 + i] = 1.0;
            }
        }
        Ok(())
    }
    fn hessians(
        &mut self,
        z: &Primal,
        sigma: f64,
        mult: &Multipliers,
        stages: &mut [StageEval],
    ) -> Result<(), EvalError> {
        let mut zk = [0.0; 5];
        for k in 0..=K {
            let e = &mut stages[k];
            e.hess.fill(0.0);
            if k == K {
                break;
            }
            zk[..4].copy_from_slice(&z.x[k]);
            zk[4] = z.u[k][0];
            self.diff
                .hessian_weighted(&Step, &zk, &mult.lam[k], &mut e.hess);
            e.hess[4 * 5 + 4] += sigma * H;
        }
        Ok(())
    }
}

#[test]
fn the_rk4_step_derivatives_match_finite_differences() {
    let mut diff = Diff::new(&Step);
    let z = [0.3, -0.7, 1.1, -0.4, 2.0];
    let w = [0.4, -1.3, 0.7, 2.1];
    let (mut f, mut jac, mut hess) = ([0.0; 4], [0.0; 20], [0.0; 25]);
    diff.jacobian(&Step, &z, &mut f, &mut jac);
    assert_jacobian("acrobot RK4 step", as_f64_fn(&Step), &z, &jac, 1e-6);
    diff.hessian_weighted(&Step, &z, &w, &mut hess);
    // the Hessian of w . f against differences of its gradient w^T J
    let mut d2 = Diff::new(&Step);
    let grad = |z: &[f64], g: &mut [f64]| {
        let (mut f, mut j) = ([0.0; 4], [0.0; 20]);
        d2.jacobian(&Step, z, &mut f, &mut j);
        for (c, gc) in g.iter_mut().enumerate() {
            *gc = (0..4).map(|r| w[r] * j[r * 5 + c]).sum();
        }
    };
    assert_hessian("acrobot RK4 step, w . f", grad, &z, &hess, 1e-5);
}

#[test]
fn the_swing_up_reaches_the_same_optimum_on_ocp_and_pounce() {
    let mut p = Acrobot::new();
    let mut solver = OcpSolver::new(&p.dims.clone()).unwrap();
    let st = solver.solve(&mut p, &OcpSettings::default());
    assert_eq!(st.status, OcpStatus::Solved, "{st:?}");
    assert!(st.primal_infeasibility < 1e-8, "{st:?}");
    let x_end = &solver.primal().x[K];
    assert!((x_end[0] - PI).abs() < 1e-8 && x_end[1..].iter().all(|v| v.abs() < 1e-8));
    let tau_peak = solver
        .primal()
        .u
        .iter()
        .flatten()
        .fold(0.0_f64, |a, t| a.max(t.abs()));
    assert!(tau_peak <= TAU_MAX + 1e-9, "{tau_peak}");

    let mut nlp = OcpNlp::new(Acrobot::new());
    let sol = solve(
        &mut nlp,
        &NlpSettings {
            backend: brachia::planning::Backend::Pounce,
            ..NlpSettings::default()
        },
    );
    assert!(sol.status.is_converged(), "{:?}", sol.status);
    assert!(
        (st.objective - sol.objective).abs() <= 1e-6 * sol.objective.abs(),
        "ocp {} ({} iterations) vs pounce {} ({} iterations)",
        st.objective,
        st.iterations,
        sol.objective,
        sol.iterations
    );
    // the same point, not only the same value
    let mut z = Primal::zeros(&p.dims);
    nlp.unstack(&sol.x, &mut z);
    let dev =
        z.x.iter()
            .flatten()
            .zip(solver.primal().x.iter().flatten())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0_f64, f64::max);
    assert!(dev < 1e-4, "largest state difference {dev}");
    eprintln!(
        "acrobot swing-up: ocp {} iterations, pounce {}, objective {:.9} / {:.9}, peak torque {tau_peak:.3}",
        st.iterations, sol.iterations, st.objective, sol.objective
    );
}
