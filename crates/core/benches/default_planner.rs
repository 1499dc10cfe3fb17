//! The default planner's time (multiple shooting, 30 ms knots, 3 RK4 steps per interval, the `ocp`
//! backend, self-collision rows on): what one interior-point iteration costs and what whole plans
//! cost, on the paper's tracking swing (`scenarios/tracking.toml`) and its V-C obstacle
//! (`scenarios/obstacle.toml`).
//!
//! A manual pass before the criterion groups prints medians and every plan's iterations and
//! objective (to the last digit), so two builds can be compared in one sitting: per iteration, the
//! problem's evaluations one iteration makes (a value-only evaluation for the line search's trial
//! point, a first-order evaluation at the accepted point, the Hessians) with their split, and the
//! Newton step (condensing, Riccati factorisation, solves) at the plan's solution; whole plans of
//! both scenarios. `RAYON_NUM_THREADS=1` keeps every stage on the calling thread.
//! `cargo bench -p brachia --bench default_planner`.

use brachia::model::{Circle, ClearanceFn, Robot};
use brachia::planning::{
    plan, Backend, DistanceClearanceFn, NlpSettings, Plan, PlannerSettings, SwingOcp, SwingOcpSpec,
    SwingTask,
};
use brachia_ocp::{
    EvalLevel, Multipliers, OcpProblem, OcpSettings, OcpSolver, Primal, StageEval, TerminalEval,
};
use criterion::{criterion_group, criterion_main, Criterion};
use shared::{median, plan_primal};
use std::sync::Arc;
use std::time::Instant;

mod shared;

/// The two scenarios: (name, task).
fn cases() -> [(&'static str, SwingTask); 2] {
    let tracking = SwingTask::paper();
    let obstacle = SwingTask {
        target: [0.5, 0.0],
        obstacles: vec![Circle {
            center: [0.55, -0.2],
            radius: 0.1,
        }],
        ..SwingTask::paper()
    };
    [("tracking", tracking), ("obstacle", obstacle)]
}

fn nlp() -> NlpSettings {
    NlpSettings {
        backend: Backend::Ocp,
        ..Default::default()
    }
}

/// The plan's problem (sub-step clearance rows on, as in the refined solve of an obstacle plan)
/// with its solution, multipliers of moderate size and the evaluation buffers.
struct AtSolution {
    ocp: SwingOcp,
    z: Primal,
    m: Multipliers,
    st: Vec<StageEval>,
    term: TerminalEval,
}

fn at_solution(robot: &Robot, task: &SwingTask, p: &Plan) -> AtSolution {
    let s = PlannerSettings::default();
    let n = robot.n();
    let k_last = p.layout.intervals;
    let spec = SwingOcpSpec {
        intervals: k_last,
        swing_time_s: p.swing_time_s,
        substeps: s.shooting.substeps,
        q1_diag: s.q1(n),
        r1_diag: s.r1(n),
        x_start: [p.points.q(0), p.points.qd(0)].concat(),
        target: task.target,
        bounds: s.bounds.clone(),
        parallel_min_stages: s.shooting.parallel_min_stages,
        substep_clearance: true,
    };
    let cf = ClearanceFn::new(
        Arc::new(robot.clone()),
        task.obstacles.as_slice(),
        s.obstacle_margin,
    )
    .unwrap()
    .with_self_collision(s.self_collision);
    let mut ocp = SwingOcp::new(robot.clone(), spec, Some(DistanceClearanceFn::new(cf))).unwrap();
    let dims = ocp.dims().clone();
    let z = plan_primal(&dims, p);
    let mut m = Multipliers::zeros(&dims);
    m.lam.iter_mut().flatten().for_each(|v| *v = 0.3);
    m.mu.iter_mut().flatten().for_each(|v| *v = 0.01);
    let st: Vec<StageEval> = (0..=k_last)
        .map(|k| StageEval::zeros(dims.stages[k], if k < k_last { 2 * n } else { 0 }))
        .collect();
    let term = TerminalEval::zeros(4, 2 * n);
    // a solve from the plan's solution leaves the solver's iterate there (for the Newton step)
    *ocp.guess_mut() = z.clone();
    AtSolution {
        ocp,
        z,
        m,
        st,
        term,
    }
}

impl AtSolution {
    /// One iteration's evaluations: (values, first order, Hessians), s each.
    fn iteration(&mut self) -> [f64; 3] {
        let t = Instant::now();
        self.ocp
            .evaluate(&self.z, EvalLevel::Values, &mut self.st, &mut self.term)
            .unwrap();
        let tv = t.elapsed().as_secs_f64();
        let t = Instant::now();
        self.ocp
            .evaluate(&self.z, EvalLevel::FirstOrder, &mut self.st, &mut self.term)
            .unwrap();
        let tf = t.elapsed().as_secs_f64();
        let t = Instant::now();
        self.ocp
            .hessians(&self.z, 1.0, &self.m, &mut self.st)
            .unwrap();
        [tv, tf, t.elapsed().as_secs_f64()]
    }
}

/// The manual pass (module docs).
fn report(robot: &Robot) {
    for (name, task) in cases() {
        let mut times = vec![];
        let mut last = None;
        for _ in 0..5 {
            let t = Instant::now();
            let p = plan(robot, &task, &PlannerSettings::default(), &nlp()).unwrap();
            times.push(t.elapsed().as_secs_f64());
            last = Some(p);
        }
        let p = last.unwrap();
        assert!(p.converged(), "{name}: {:?}", p.failure_message());
        let cb = &p.callback_timings;
        eprintln!(
            "plan/{name}: median {:.1} ms, {} iterations in {} solves, objective {:.17e}, \
             split {:?}, callbacks {cb:?}",
            median(&times) * 1e3,
            p.iterations,
            p.solves.len(),
            p.objective,
            p.time_split
        );
        let mut a = at_solution(robot, &task, &p);
        let (mut tv, mut tf, mut th) = (vec![], vec![], vec![]);
        for _ in 0..51 {
            let [v, f, h] = a.iteration();
            tv.push(v);
            tf.push(f);
            th.push(h);
        }
        let mut solver = OcpSolver::new(&a.ocp.dims().clone()).unwrap();
        let settings = OcpSettings {
            max_iter: 3,
            ..Default::default()
        };
        solver.solve(&mut a.ocp, &settings);
        let mut tn = vec![];
        for _ in 0..51 {
            let t = Instant::now();
            assert!(solver.bench_newton_step(1e-3));
            tn.push(t.elapsed().as_secs_f64());
        }
        let (v, f, h, s) = (median(&tv), median(&tf), median(&th), median(&tn));
        eprintln!(
            "iteration/{name} ({} stages): evaluations {:.3} ms (values {:.3}, first order {:.3}, \
             Hessians {:.3}), Newton step {:.3} ms",
            a.st.len(),
            (v + f + h) * 1e3,
            v * 1e3,
            f * 1e3,
            h * 1e3,
            s * 1e3
        );
    }
}

fn bench(c: &mut Criterion) {
    let robot = Robot::paper();
    report(&robot);
    let mut g = c.benchmark_group("iteration");
    for (name, task) in cases() {
        let p = plan(&robot, &task, &PlannerSettings::default(), &nlp()).unwrap();
        let mut a = at_solution(&robot, &task, &p);
        g.bench_function(format!("{name}/evaluations"), |b| b.iter(|| a.iteration()));
    }
    g.finish();
    let mut g = c.benchmark_group("plan");
    g.sample_size(10);
    for (name, task) in cases() {
        g.bench_function(name, |b| {
            b.iter(|| {
                let p = plan(&robot, &task, &PlannerSettings::default(), &nlp()).unwrap();
                assert!(p.converged());
                p.objective
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
