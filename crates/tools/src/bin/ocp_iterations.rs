//! Iteration counts behind the tables of docs/ocp.md: cold solves of the random QP suite and of
//! the pendulum swing-ups, and warm re-solves after a shift of the pendulum's x_0.
//! `cargo run -p brachia-tools --release --bin ocp_iterations`

use brachia_ocp::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[path = "../../../ocp/tests/common/mod.rs"]
mod common;

fn cold_table(name: &str, s: &OcpSettings) {
    // the random QPs of tests/qp.rs (same generator, other seed) and the robot-sized one
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let (mut total, mut fails, mut n) = (0, 0, 0);
    for _ in 0..40 {
        let kk = rng.gen_range(1..15);
        let nx = rng.gen_range(1..5);
        let nu = rng.gen_range(0..4);
        let nc = rng.gen_range(0..3);
        let nr = rng.gen_range(0..=nx.min(2));
        let free = rng.gen_bool(0.3);
        let mut p = common::random_qp(&mut rng, kk, nx, nu, nc, nr, free);
        let mut solver = OcpSolver::new(&p.dims.clone()).unwrap();
        let st = solver.solve(&mut p, s);
        n += 1;
        total += st.iterations;
        if st.status != OcpStatus::Solved {
            fails += 1;
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let mut big = common::random_qp_with(&mut rng, 223, 8, 3, 2, 4, false, 0.9, 0.05);
    let mut solver = OcpSolver::new(&big.dims.clone()).unwrap();
    let sb = solver.solve(&mut big, s);
    let mut pend = String::new();
    for (kk, tmax) in [(60, 5.0), (100, 4.0), (100, 6.0), (160, 3.0)] {
        let mut p = common::Pendulum::new(kk, 0.05, tmax);
        let mut solver = OcpSolver::new(&p.dims).unwrap();
        let st = solver.solve(&mut p, s);
        pend += &format!(
            " {}{}",
            st.iterations,
            if st.status == OcpStatus::Solved {
                "".to_string()
            } else {
                format!("({:?})", st.status)
            }
        );
        pend += &format!("[{:.4}]", st.objective);
    }
    println!(
        "{name:<28} QPs: {total} iterations over {n} ({fails} not Solved); K223: {} ({:?}); pendulum (60,5) (100,4) (100,6) (160,3):{pend}",
        sb.iterations, sb.status
    );
}

fn warm_table(name: &str, warm: &OcpSettings) {
    let mut line = String::new();
    for shift in [0.01, 0.05, 0.1] {
        let mut p = common::Pendulum::new(100, 0.05, 4.0);
        let mut solver = OcpSolver::new(&p.dims).unwrap();
        let c0 = solver.solve(&mut p, &OcpSettings::default());
        assert_eq!(c0.status, OcpStatus::Solved);
        p.x0 = [shift, 0.0];
        let w = solver.solve(&mut p, warm);
        let mut fresh = OcpSolver::new(&p.dims).unwrap();
        let c = fresh.solve(&mut p, &OcpSettings::default());
        line += &format!(
            "  {shift}: warm {} {:?} ({:.4}) cold {} ({:.4})",
            w.iterations, w.status, w.objective, c.iterations, c.objective
        );
    }
    println!("{name:<28}{line}");
}

fn main() {
    let d = OcpSettings::default();
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 2 || args[1] == "cold" {
        cold_table("default", &d);
        let ad = OcpSettings {
            mu_strategy: MuStrategy::Adaptive,
            ..d.clone()
        };
        cold_table("adaptive", &ad);
        for k in [1, 3] {
            cold_table(
                &format!("{k} centrality correctors"),
                &OcpSettings {
                    centrality_correctors: k,
                    ..d.clone()
                },
            );
            cold_table(
                &format!("adaptive, {k} correctors"),
                &OcpSettings {
                    centrality_correctors: k,
                    ..ad.clone()
                },
            );
        }
        cold_table(
            "adaptive mu_init 1",
            &OcpSettings {
                mu_init: 1.0,
                ..ad.clone()
            },
        );
        cold_table(
            "adaptive bound_push 0.1",
            &OcpSettings {
                bound_push: 0.1,
                ..ad.clone()
            },
        );
        for mu in [0.01, 1.0] {
            cold_table(
                &format!("mu_init {mu}"),
                &OcpSettings {
                    mu_init: mu,
                    ..d.clone()
                },
            );
        }
        for bp in [1e-1, 1e-3] {
            cold_table(
                &format!("bound_push {bp}"),
                &OcpSettings {
                    bound_push: bp,
                    ..d.clone()
                },
            );
        }
    }
    if args.len() < 2 || args[1] == "primal" {
        for (mu, push) in [(0.1, 1e-2), (1e-2, 1e-2), (1e-3, 1e-3), (1e-2, 1e-1)] {
            primal_warm(mu, push);
        }
    }
    if args.len() < 2 || args[1] == "warm" {
        for (duals, mu, push) in [
            (WarmDuals::Stored, 1e-6, 1e-9),
            (WarmDuals::Stored, 1e-4, 1e-9),
            (WarmDuals::Centered, 1e-1, 1e-2),
            (WarmDuals::Centered, 1e-2, 1e-2),
            (WarmDuals::Centered, 1e-3, 1e-3),
            (WarmDuals::Reset, 1e-1, 1e-2),
            (WarmDuals::Reset, 1e-2, 1e-2),
            (WarmDuals::Reset, 1e-3, 1e-3),
            (WarmDuals::Reset, 1e-1, 1e-1),
        ] {
            warm_table(
                &format!("adaptive {duals:?} mu {mu:e} push {push:e}"),
                &OcpSettings {
                    warm_start: true,
                    warm_duals: duals,
                    mu_init: mu,
                    warm_bound_push: push,
                    mu_strategy: MuStrategy::Adaptive,
                    ..d.clone()
                },
            );
            warm_table(
                &format!("{duals:?} mu {mu:e} push {push:e}"),
                &OcpSettings {
                    warm_start: true,
                    warm_duals: duals,
                    mu_init: mu,
                    warm_bound_push: push,
                    ..d.clone()
                },
            );
        }
    }
}

/// The pendulum with the initial guess taken from a stored primal (a primal-only warm start).
struct Guessed(common::Pendulum, Primal);

impl OcpProblem for Guessed {
    fn dims(&self) -> &OcpDims {
        &self.0.dims
    }
    fn bounds(&self, k: usize, b: &mut StageBounds) {
        self.0.bounds(k, b)
    }
    fn initial_guess(&self, z: &mut Primal) {
        *z = self.1.clone();
    }
    fn evaluate(
        &mut self,
        z: &Primal,
        level: EvalLevel,
        s: &mut [StageEval],
        t: &mut TerminalEval,
    ) -> Result<(), EvalError> {
        self.0.evaluate(z, level, s, t)
    }
    fn hessians(
        &mut self,
        z: &Primal,
        sigma: f64,
        m: &Multipliers,
        s: &mut [StageEval],
    ) -> Result<(), EvalError> {
        self.0.hessians(z, sigma, m, s)
    }
}

pub fn primal_warm(mu: f64, push: f64) {
    let mut line = String::new();
    for shift in [0.01, 0.05, 0.1] {
        let mut p = common::Pendulum::new(100, 0.05, 4.0);
        let mut solver = OcpSolver::new(&p.dims).unwrap();
        let c0 = solver.solve(&mut p, &OcpSettings::default());
        assert_eq!(c0.status, OcpStatus::Solved);
        p.x0 = [shift, 0.0];
        let mut g = Guessed(p, solver.primal().clone());
        let s = OcpSettings {
            mu_init: mu,
            bound_push: push,
            ..OcpSettings::default()
        };
        let w = solver.solve(&mut g, &s);
        line += &format!(
            "  {shift}: {} {:?} ({:.4})",
            w.iterations, w.status, w.objective
        );
    }
    println!("primal-only mu {mu:e} push {push:e}{line}");
}
