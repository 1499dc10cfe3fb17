//! Planning time of the paper's tracking scenario (`scenarios/tracking.toml`: params/paper.toml,
//! T = 2 T_freefall ~ 2.23 s, 10 ms knots), cold starts:
//! - multiple shooting (RK4, 223 intervals) on the stage-structured solver (`backend = "ocp"`),
//! - the very same problem on pounce-rs (through the OCP adapter),
//! - Hermite-Simpson collocation on pounce-rs, the baseline.
//!
//! A manual pass before the criterion groups plans each a few times in one process and prints the
//! medians, the ratios, the iterations, the time split, the independent 0.1 ms open-loop replay error
//! of each plan's torque profile (which must reach the bar within 1 mm: the bench panics otherwise)
//! and the derivative cost per shooting stage (closed form and AD), the plan with the stages
//! evaluated serially (parallel / serial in the same run), and coarser shooting meshes (20 and 30 ms
//! knots, 1 and 2 RK4 substeps: time, objective, replay miss). The criterion group adds the
//! headline configuration, 30 ms knots with one RK4 step.

use brachia::planning::{
    plan, AdDynamics, AnalyticDynamics, Backend, NlpSettings, Plan, PlannerSettings, PointDynamics,
    SwingOcp, SwingOcpSpec, SwingTask, Transcription,
};
use brachia::Robot;
use brachia_ocp::{EvalLevel, Multipliers, OcpProblem, StageEval, TerminalEval};
use criterion::{criterion_group, criterion_main, Criterion};
use shared::{median, plan_primal};
use std::time::Instant;

mod shared;

fn task() -> SwingTask {
    SwingTask::paper()
}

/// The three configurations: (name, transcription, backend).
const CASES: [(&str, Transcription, Backend); 3] = [
    (
        "multiple-shooting/ocp",
        Transcription::MultipleShooting,
        Backend::Ocp,
    ),
    (
        "multiple-shooting/pounce",
        Transcription::MultipleShooting,
        Backend::Pounce,
    ),
    (
        "hermite-simpson/pounce",
        Transcription::HermiteSimpson,
        Backend::Pounce,
    ),
];

fn settings(tr: Transcription, b: Backend) -> (PlannerSettings, NlpSettings) {
    (
        PlannerSettings {
            transcription: tr,
            knot_dt: 0.01,
            shooting: brachia::planning::ShootingSettings {
                substeps: 1,
                ..Default::default()
            },
            ..Default::default()
        },
        NlpSettings {
            backend: b,
            ..Default::default()
        },
    )
}

/// Seconds per stage of one first-order evaluation and one Hessian evaluation of the whole horizon
/// (serial, or half of the stages on the problem's helper thread), at the plan's solution.
fn per_stage<D: PointDynamics>(robot: &Robot, p: &Plan, parallel: bool) -> (f64, f64) {
    let k_last = p.layout.intervals;
    let spec = SwingOcpSpec {
        intervals: k_last,
        swing_time_s: p.swing_time_s,
        substeps: 1,
        q1_diag: vec![0.01; 4],
        r1_diag: vec![1.0; 3],
        x_start: [p.points.q(0), p.points.qd(0)].concat(),
        target: task().target,
        bounds: Default::default(),
        parallel_min_stages: if parallel { 0 } else { usize::MAX },
        substep_clearance: true,
    };
    let mut ocp: SwingOcp<D> = SwingOcp::with_dynamics(robot.clone(), spec, None).unwrap();
    let dims = ocp.dims().clone();
    let z = plan_primal(&dims, p);
    let mut m = Multipliers::zeros(&dims);
    m.lam.iter_mut().flatten().for_each(|v| *v = 0.3);
    let mut st: Vec<StageEval> = (0..=k_last)
        .map(|k| StageEval::zeros(dims.stages[k], if k < k_last { 8 } else { 0 }))
        .collect();
    let mut term = TerminalEval::zeros(4, 8);
    let (mut jt, mut ht) = (vec![], vec![]);
    for _ in 0..21 {
        let t = Instant::now();
        ocp.evaluate(&z, EvalLevel::FirstOrder, &mut st, &mut term)
            .unwrap();
        jt.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        ocp.hessians(&z, 1.0, &m, &mut st).unwrap();
        ht.push(t.elapsed().as_secs_f64());
    }
    let ns = (k_last + 1) as f64;
    (median(&jt) / ns, median(&ht) / ns)
}

/// The manual pass (see the module docs).
fn report(robot: &Robot) {
    let mut medians = vec![];
    let mut ocp_plan = None;
    for (name, tr, b) in CASES {
        let (s, nlp) = settings(tr, b);
        let (mut times, mut solves) = (vec![], vec![]);
        let mut last = None;
        for _ in 0..5 {
            let t = Instant::now();
            let p = plan(robot, &task(), &s, &nlp).unwrap();
            times.push(t.elapsed().as_secs_f64());
            solves.push(p.solve_time_s);
            last = Some(p);
        }
        let p = last.unwrap();
        assert!(p.converged(), "{name}: {:?}", p.status);
        // the accuracy rule: the replayed torques reach the bar within 1 mm
        assert!(
            p.replay_ee_error_m <= 1e-3,
            "{name}: open-loop replay misses the bar by {} m",
            p.replay_ee_error_m
        );
        let m = median(&times);
        eprintln!(
            "plan/tracking {name}: median {:.1} ms (median solve {:.1} ms), {} iterations, \
             objective {:.6}, replay EE error {:.3e} m, last split {:?}",
            m * 1e3,
            median(&solves) * 1e3,
            p.iterations,
            p.objective,
            p.replay_ee_error_m,
            p.time_split
        );
        medians.push(m);
        if b == Backend::Ocp {
            ocp_plan = Some(p);
        }
    }
    eprintln!(
        "ratios: shooting pounce / ocp {:.1}, hermite-simpson pounce / shooting ocp {:.1}",
        medians[1] / medians[0],
        medians[2] / medians[0]
    );
    let p = ocp_plan.unwrap();
    let ref_objective = p.objective;
    for parallel in [false, true] {
        let (ja, ha) = per_stage::<AnalyticDynamics>(robot, &p, parallel);
        let (jd, hd) = per_stage::<AdDynamics>(robot, &p, parallel);
        eprintln!(
            "per shooting stage (1 RK4 step, {}): first order {:.2} us analytic / {:.1} us AD, \
             Hessian {:.2} us analytic / {:.1} us AD",
            if parallel { "helper thread" } else { "serial" },
            ja * 1e6,
            jd * 1e6,
            ha * 1e6,
            hd * 1e6
        );
    }
    // the whole plan with half the stages on the problem's helper thread against all of them on the
    // calling thread, interleaved (the first plans of a process run slower)
    let (sp, nlp) = settings(Transcription::MultipleShooting, Backend::Ocp);
    let mut ss = sp.clone();
    ss.shooting.parallel_min_stages = usize::MAX;
    let (mut tp, mut ts) = (vec![], vec![]);
    for _ in 0..7 {
        for (s, out) in [(&sp, &mut tp), (&ss, &mut ts)] {
            let t = Instant::now();
            let q = plan(robot, &task(), s, &nlp).unwrap();
            out.push(t.elapsed().as_secs_f64());
            assert!(q.converged());
        }
    }
    let (par, serial) = (median(&tp), median(&ts));
    eprintln!(
        "plan/tracking multiple-shooting/ocp, interleaved: helper thread {:.1} ms, serial stages \
         {:.1} ms, parallel / serial {:.2}",
        par * 1e3,
        serial * 1e3,
        par / serial
    );
    // coarser meshes (RK4 substeps 1 and 2): time, objective, replay miss against the same run's
    // Hermite-Simpson / pounce median
    for (knot_dt, substeps) in COARSE {
        let (s, nlp) = coarse_settings(knot_dt, substeps);
        let mut times = vec![];
        let mut last = None;
        for _ in 0..7 {
            let t = Instant::now();
            let p = plan(robot, &task(), &s, &nlp).unwrap();
            times.push(t.elapsed().as_secs_f64());
            last = Some(p);
        }
        let p = last.unwrap();
        let m = median(&times);
        eprintln!(
            "plan/tracking multiple-shooting/ocp knot_dt {:.0} ms substeps {substeps}: median {:.1} ms \
             ({} intervals, {} iterations, converged {}), objective {:.6} ({:+.2e} relative to 10 ms), \
             replay EE error {:.3e} m (at most 1e-3), hermite-simpson pounce / this {:.1}",
            knot_dt * 1e3,
            m * 1e3,
            p.layout.intervals,
            p.iterations,
            p.converged(),
            p.objective,
            p.objective / ref_objective - 1.0,
            p.replay_ee_error_m,
            medians[2] / m
        );
    }
}

/// Coarser shooting meshes of the manual pass: (knot_dt s, RK4 substeps).
/// (0.03, 3) is the planner's default mesh.
const COARSE: [(f64, usize); 5] = [(0.02, 1), (0.02, 2), (0.03, 1), (0.03, 2), (0.03, 3)];

/// The headline configuration in the criterion group: 30 ms knots, one RK4 step per interval.
const HEADLINE: (f64, usize) = (0.03, 1);

fn coarse_settings(knot_dt: f64, substeps: usize) -> (PlannerSettings, NlpSettings) {
    let (mut s, nlp) = settings(Transcription::MultipleShooting, Backend::Ocp);
    s.knot_dt = knot_dt;
    s.shooting.substeps = substeps;
    (s, nlp)
}

fn bench(c: &mut Criterion) {
    let robot = Robot::paper();
    report(&robot);
    let mut g = c.benchmark_group("plan/tracking");
    g.sample_size(10);
    for (name, tr, b) in CASES {
        let (s, nlp) = settings(tr, b);
        g.bench_function(name, |bch| {
            bch.iter(|| {
                let p = plan(&robot, &task(), &s, &nlp).unwrap();
                assert!(p.converged());
                p.objective
            })
        });
    }
    let (s, nlp) = coarse_settings(HEADLINE.0, HEADLINE.1);
    g.bench_function("multiple-shooting/ocp knot_dt 30 ms", |bch| {
        bch.iter(|| {
            let p = plan(&robot, &task(), &s, &nlp).unwrap();
            assert!(p.converged() && p.replay_ee_error_m <= 1e-3);
            p.objective
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
