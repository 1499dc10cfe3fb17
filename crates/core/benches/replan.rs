//! Warm re-plans of the tracking swing (`scenarios/tracking.toml`: params/paper.toml, T auto ~ 2.23 s,
//! multiple shooting on the re-planning mesh [`REPLAN_KNOT_DT`]: 40 ms knots, 56 intervals, which meets
//! the 1 mm replay accuracy; `BRACHIA_REPLAN_KNOT_DT=0.03` for the 30 ms mesh, 0.01 for the 10 ms
//! one): from the planned state at t = 0.6 s disturbed by uniform +-0.1 rad
//! and +-0.5 rad/s on each joint (seeded, 100 draws, those inside the bounds), re-plan to the bar over
//! the remaining time.
//! - warm: [`SwingPlanner::replan`] (shifted previous solution, the solver's stored multipliers);
//! - cold: [`SwingPlanner::replan_cold`] (the same shifted guess, the solver's cold initialisation);
//! - pounce: the identical problem (same K, h, start, shifted guess) through [`OcpNlp`], warm-started
//!   with the multipliers of its own solution of the undisturbed swing.
//!
//! Before every re-plan the planner is restored to the undisturbed plan (untimed). A manual pass
//! times every re-plan of every draw and prints median, p99, mean iterations, convergence counts and
//! the ratios; the criterion groups then time warm and cold over the draws in turn.

use brachia::planning::workload::{
    disturbed_starts, replan_settings, REPLAN_KNOT_DT, REPLAN_SEED, REPLAN_T_NOW,
};
use brachia::planning::{
    solve, Backend, NlpSettings, OcpNlp, PlannerSettings, SparseNlp, SwingOcp, SwingOcpSpec,
    SwingPlanner, SwingTask,
};
use brachia::Robot;
use brachia_ocp::{OcpSettings, Primal, WarmDuals};
use criterion::{criterion_group, criterion_main, Criterion};
use shared::quantile;
use std::time::{Duration, Instant};

mod shared;

/// The benchmark's re-planning mesh ([`REPLAN_KNOT_DT`] unless `BRACHIA_REPLAN_KNOT_DT` says otherwise).
fn settings() -> (PlannerSettings, NlpSettings) {
    replan_settings(
        std::env::var("BRACHIA_REPLAN_KNOT_DT")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(REPLAN_KNOT_DT),
    )
}

/// An [`OcpNlp`] that offers given multipliers for a warm start.
struct WarmNlp<'a> {
    inner: OcpNlp<SwingOcp>,
    lambda: &'a [f64],
    z_l: &'a [f64],
    z_u: &'a [f64],
}

impl SparseNlp for WarmNlp<'_> {
    fn n_vars(&self) -> usize {
        self.inner.n_vars()
    }
    fn n_cons(&self) -> usize {
        self.inner.n_cons()
    }
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        self.inner.bounds(x_l, x_u, g_l, g_u)
    }
    fn initial_guess(&self, x: &mut [f64]) {
        self.inner.initial_guess(x)
    }
    fn objective(&mut self, x: &[f64]) -> f64 {
        self.inner.objective(x)
    }
    fn gradient(&mut self, x: &[f64], grad: &mut [f64]) {
        self.inner.gradient(x, grad)
    }
    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        self.inner.constraints(x, g)
    }
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        self.inner.jacobian_structure()
    }
    fn jacobian_values(&mut self, x: &[f64], vals: &mut [f64]) {
        self.inner.jacobian_values(x, vals)
    }
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        self.inner.hessian_structure()
    }
    fn hessian_values(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], vals: &mut [f64]) {
        self.inner.hessian_values(x, obj_factor, lambda, vals)
    }
    fn initial_multipliers(&self, lambda: &mut [f64], z_l: &mut [f64], z_u: &mut [f64]) -> bool {
        lambda.copy_from_slice(self.lambda);
        z_l.copy_from_slice(self.z_l);
        z_u.copy_from_slice(self.z_u);
        true
    }
}

/// The re-plan problem for pounce: start `x`, the remaining time, K intervals, guess `z`.
fn pounce_problem(
    robot: &Robot,
    s: &PlannerSettings,
    k: usize,
    t_rem: f64,
    x: &[f64],
    z: &Primal,
) -> OcpNlp<SwingOcp> {
    let n = robot.n();
    let spec = SwingOcpSpec {
        intervals: k,
        swing_time_s: t_rem,
        substeps: s.shooting.substeps,
        q1_diag: s.q1(n),
        r1_diag: s.r1(n),
        x_start: x.to_vec(),
        target: SwingTask::paper().target,
        bounds: s.bounds.clone(),
        parallel_min_stages: s.shooting.parallel_min_stages,
        substep_clearance: s.shooting.substep_clearance,
    };
    let mut ocp = SwingOcp::new(robot.clone(), spec, None).unwrap();
    let g = ocp.guess_mut();
    g.x.clone_from(&z.x);
    g.u.clone_from(&z.u);
    OcpNlp::new(ocp)
}

fn bench(c: &mut Criterion) {
    let robot = Robot::paper();
    let task = SwingTask::paper();
    let (s, nlp) = settings();
    let mut planner = SwingPlanner::new(robot.clone(), task.clone(), &s, &nlp).unwrap();
    if let Some(mu) = std::env::var("BRACHIA_REPLAN_MU")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        planner.warm_settings_mut().mu_init = mu;
    }
    let p = planner.plan().unwrap();
    assert!(p.converged(), "{:?}", p.status);
    let j = p
        .trajectory
        .t
        .iter()
        .position(|t| (t - REPLAN_T_NOW).abs() < 1e-9)
        .unwrap();
    let x_nom = [p.trajectory.q(j), p.trajectory.qd(j)].concat();
    let states = disturbed_starts(&x_nom, &s.bounds, 100, REPLAN_SEED);
    let cp = planner.checkpoint();
    let k = planner.intervals();
    let t_rem = planner.swing_time() - REPLAN_T_NOW;

    // pounce's own solution of the undisturbed full swing: its multipliers warm-start its re-plans
    let pn = NlpSettings {
        backend: Backend::Pounce,
        ..Default::default()
    };
    let nominal = {
        let mut full = pounce_problem(
            &robot,
            &s,
            k,
            planner.swing_time(),
            cp_start(&planner),
            planner.knots(),
        );
        let sol = solve(&mut full, &pn);
        assert!(sol.status.is_converged(), "{:?}", sol.status);
        sol
    };
    let pw = NlpSettings {
        warm_start: true,
        mu_init: Some(brachia::planning::WARM_START_MU_INIT),
        ..pn.clone()
    };

    // warm-start variants (iterations and times over the draws; the default is the planner's own)
    let base = planner.warm_settings_mut().clone();
    let variants: [(&str, WarmDuals, f64, f64); 5] = [
        (
            "stored duals, mu 1e-4, push 1e-9",
            WarmDuals::Stored,
            1e-4,
            1e-9,
        ),
        (
            "reset duals, mu 1e-4, push 1e-2",
            WarmDuals::Reset,
            1e-4,
            1e-2,
        ),
        (
            "reset duals, mu 1e-3, push 1e-3",
            WarmDuals::Reset,
            1e-3,
            1e-3,
        ),
        (
            "reset duals, mu 1e-2, push 1e-2",
            WarmDuals::Reset,
            1e-2,
            1e-2,
        ),
        (
            "centered duals, mu 1e-3, push 1e-3",
            WarmDuals::Centered,
            1e-3,
            1e-3,
        ),
    ];
    // the variants' sweep only on request (BRACHIA_REPLAN_VARIANTS=1): it multiplies the bench time
    let sweep = std::env::var("BRACHIA_REPLAN_VARIANTS").is_ok_and(|v| v == "1");
    for (name, duals, mu, push) in variants.into_iter().filter(|_| sweep) {
        *planner.warm_settings_mut() = OcpSettings {
            warm_duals: duals,
            mu_init: mu,
            warm_bound_push: push,
            ..base.clone()
        };
        let (mut t, mut it, mut conv) = (vec![], 0usize, 0usize);
        for x in &states {
            planner.restore(&cp).unwrap();
            let t0 = Instant::now();
            let w = planner.replan(REPLAN_T_NOW, x).unwrap();
            t.push(t0.elapsed().as_secs_f64());
            it += w.iterations;
            conv += usize::from(w.converged() && w.ee_error_m < 1e-6);
        }
        eprintln!(
            "variant {name}: median {:.2} ms, p99 {:.2} ms, mean {:.1} iterations, {conv}/{} converged",
            quantile(&t, 0.5) * 1e3,
            quantile(&t, 0.99) * 1e3,
            it as f64 / states.len() as f64,
            states.len()
        );
    }
    *planner.warm_settings_mut() = base;

    // manual pass
    let mut z = planner.knots().clone();
    let (mut tw, mut tc, mut tp) = (vec![], vec![], vec![]);
    let (mut iw, mut ic, mut ip) = (0usize, 0usize, 0usize);
    let (mut cw, mut cc, mut cpn) = (0usize, 0usize, 0usize);
    let mut worst = (0usize, 0.0f64);
    // per draw: warm time, iterations, line-search-free share (iterations), status, replay error
    let mut per_draw: Vec<(f64, usize, usize, String)> = vec![];
    let mut objectives = vec![];
    for (d, x) in states.iter().enumerate() {
        planner.restore(&cp).unwrap();
        let t = Instant::now();
        let w = planner.replan(REPLAN_T_NOW, x).unwrap();
        tw.push(t.elapsed().as_secs_f64());
        iw += w.iterations;
        cw += usize::from(w.converged() && w.ee_error_m < 1e-6);
        if w.iterations > worst.0 {
            worst = (w.iterations, tw[tw.len() - 1]);
        }
        per_draw.push((tw[tw.len() - 1], w.iterations, d, format!("{:?}", w.status)));
        objectives.push(w.objective);

        planner.restore(&cp).unwrap();
        planner.shifted_into(REPLAN_T_NOW, x, &mut z).unwrap();
        let t = Instant::now();
        let c = planner.replan_cold(REPLAN_T_NOW, x).unwrap();
        tc.push(t.elapsed().as_secs_f64());
        ic += c.iterations;
        cc += usize::from(c.converged() && c.ee_error_m < 1e-6);

        let mut prob = WarmNlp {
            inner: pounce_problem(&robot, &s, k, t_rem, x, &z),
            lambda: &nominal.lambda,
            z_l: &nominal.z_l,
            z_u: &nominal.z_u,
        };
        let t = Instant::now();
        let sol = solve(&mut prob, &pw);
        tp.push(t.elapsed().as_secs_f64());
        ip += sol.iterations;
        cpn += usize::from(sol.status.is_converged());
    }
    let m = states.len() as f64;
    let row = |name: &str, t: &[f64], it: usize, conv: usize| {
        eprintln!(
            "replan/tracking {name}: median {:.2} ms, p99 {:.2} ms, max {:.2} ms, mean {:.1} iterations, \
             {conv}/{} converged",
            quantile(t, 0.5) * 1e3,
            quantile(t, 0.99) * 1e3,
            quantile(t, 1.0) * 1e3,
            it as f64 / m,
            states.len()
        );
    };
    eprintln!(
        "replan/tracking: {} of 100 draws inside the bounds, K = {k}, h = {:.3} ms (T = {:.3} s)",
        states.len(),
        t_rem / k as f64 * 1e3,
        planner.swing_time()
    );
    row("warm", &tw, iw, cw);
    row("cold", &tc, ic, cc);
    row("pounce (warm, multipliers)", &tp, ip, cpn);
    eprintln!(
        "ratios (median): cold / warm {:.1}, pounce / warm {:.1}; most warm iterations {} ({:.2} ms)",
        quantile(&tc, 0.5) / quantile(&tw, 0.5),
        quantile(&tp, 0.5) / quantile(&tw, 0.5),
        worst.0,
        worst.1 * 1e3
    );

    // where the tail comes from: the slowest warm re-plans, their iterations and time per iteration
    per_draw.sort_by(|a, b| b.0.total_cmp(&a.0));
    let med_per_it = quantile(&tw, 0.5) / (iw as f64 / m);
    for (t, it, d, st) in per_draw.iter().take(3) {
        eprintln!(
            "slowest warm: draw {d}: {:.2} ms, {it} iterations ({:.3} ms each; median draw {:.3} \
             ms per iteration), {st}",
            t * 1e3,
            t * 1e3 / (*it).max(1) as f64,
            med_per_it * 1e3
        );
    }

    // early termination: the warm re-plan stopped at tol 1e-6 (constraint violation still 1e-8 m);
    // how much sooner, and how far from the 1e-8 solution's objective
    let base = planner.warm_settings_mut().clone();
    planner.warm_settings_mut().tol = 1e-6;
    let (mut te, mut ie, mut ce, mut drel, mut dee) = (vec![], 0usize, 0usize, 0.0f64, 0.0f64);
    for (x, obj) in states.iter().zip(&objectives) {
        planner.restore(&cp).unwrap();
        let t = Instant::now();
        let w = planner.replan(REPLAN_T_NOW, x).unwrap();
        te.push(t.elapsed().as_secs_f64());
        ie += w.iterations;
        ce += usize::from(w.converged() && w.ee_error_m < 1e-6);
        drel = drel.max((w.objective - obj).abs() / obj.abs().max(1.0));
        dee = dee.max(w.ee_error_m);
    }
    *planner.warm_settings_mut() = base;
    row("warm, tol 1e-6", &te, ie, ce);
    eprintln!(
        "warm, tol 1e-6: largest objective difference to tol 1e-8 {drel:.2e} (relative), largest \
         EE miss {dee:.2e} m; median ratio tol 1e-8 / 1e-6 {:.2}",
        quantile(&tw, 0.5) / quantile(&te, 0.5)
    );

    let mut g = c.benchmark_group("replan/tracking");
    g.sample_size(20);
    for (name, warm) in [("warm", true), ("cold", false)] {
        let mut i = 0;
        g.bench_function(name, |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    planner.restore(&cp).unwrap();
                    i = (i + 1) % states.len();
                    let t = Instant::now();
                    let out = if warm {
                        planner.replan(REPLAN_T_NOW, &states[i]).unwrap()
                    } else {
                        planner.replan_cold(REPLAN_T_NOW, &states[i]).unwrap()
                    };
                    total += t.elapsed();
                    std::hint::black_box(out.iterations);
                }
                total
            })
        });
    }
    g.finish();
}

/// The start state of the planner's current solution.
fn cp_start(planner: &SwingPlanner) -> &[f64] {
    &planner.knots().x[0]
}

criterion_group!(benches, bench);
criterion_main!(benches);
