//! Plans scenario files and obstacle placements and prints what identifies each result: status,
//! iterations of every solve, the objective to the last bit and a hash of the plan's knots, with the
//! median wall time of the repeats. Two builds that print the same lines (times aside) took the same
//! iterates. `cargo run --release -p brachia-tools --bin plan_check -- [--repeat R] CASE...`, a CASE a
//! scenario file (`scenarios/tracking.toml`) or `placement:SEED` (the placement scan's draw of that
//! seed on the paper's swing, `crates/core/tests/placement_scan.rs`, 30 s wall-time limit).
//! Units: m, s.

use brachia::model::Robot;
use brachia::planning::workload::swing_placement;
use brachia::planning::{plan, Backend, NlpSettings, Plan, PlannerSettings, SwingTask};
use brachia_experiments::{Scenario, Uses};
use std::path::Path;
use std::time::Instant;

/// FNV-1a over the bits of the plan's knots (q, qd, tau) and its objective.
fn fingerprint(p: &Plan) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |v: f64| {
        for b in v.to_bits().to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    let t = &p.points;
    for k in 0..t.len() {
        t.q(k)
            .iter()
            .chain(t.qd(k))
            .chain(t.tau(k))
            .for_each(|&v| eat(v));
    }
    eat(p.objective);
    h
}

type Case = (Robot, SwingTask, PlannerSettings, NlpSettings);

fn case(arg: &str) -> Result<Case, String> {
    if let Some(seed) = arg.strip_prefix("placement:") {
        let seed: u64 = seed.parse().map_err(|e| format!("{arg}: {e}"))?;
        let robot = Robot::paper();
        let nlp = NlpSettings {
            backend: Backend::Ocp,
            max_wall_time_s: Some(30.0),
            ..Default::default()
        };
        let s = PlannerSettings::default();
        let free = plan(&robot, &SwingTask::paper(), &s, &nlp).map_err(|e| e.to_string())?;
        let paper = SwingTask::paper();
        let drawn = swing_placement(&robot, &free, &paper.q0, seed)
            .ok_or_else(|| format!("{arg}: overlaps the start pose"))?;
        let task = SwingTask {
            obstacles: drawn.obstacles,
            ..paper
        };
        return Ok((robot, task, s, nlp));
    }
    let ls = Scenario::load_for(Path::new(arg), Uses::Plan).map_err(|e| e.to_string())?;
    let sc = ls.scenario;
    Ok((ls.robot, sc.task, sc.planner, sc.solver))
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut repeat = 1usize;
    if let Some(i) = args.iter().position(|a| a == "--repeat") {
        repeat = args.get(i + 1).and_then(|v| v.parse().ok()).unwrap_or(1);
        args.drain(i..(i + 2).min(args.len()));
    }
    for arg in &args {
        let (robot, task, s, nlp) = match case(arg) {
            Ok(c) => c,
            Err(e) => {
                println!("{arg}: {e}");
                continue;
            }
        };
        let mut times = vec![];
        let mut last = None;
        for _ in 0..repeat.max(1) {
            let t0 = Instant::now();
            let p = plan(&robot, &task, &s, &nlp);
            times.push(t0.elapsed().as_secs_f64());
            last = Some(p);
        }
        times.sort_by(f64::total_cmp);
        let median = times[times.len() / 2];
        match last.expect("one plan") {
            Err(e) => println!("{arg}: error {e}; median {median:.3} s"),
            Ok(p) => {
                let solves: Vec<String> = p
                    .solves
                    .iter()
                    .map(|a| format!("{}:{:?}:{}", a.role, a.status, a.iterations))
                    .collect();
                println!(
                    "{arg}: {:?}, {} iterations [{}], objective {:.17e}, knots {:016x}; median {median:.3} s",
                    p.status,
                    p.iterations,
                    solves.join(", "),
                    p.objective,
                    fingerprint(&p)
                );
            }
        }
    }
}
