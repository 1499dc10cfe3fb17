//! The joint multi-swing plan against swing-by-swing planning on a ladder scenario (docs/ladders.md,
//! "The joint multi-swing plan"): `cargo run --release -p brachia-run --example joint_swings --
//! scenarios/ladder-even.toml 2 [rest]` (`rest`: keep the rest condition at the inner switches) prints per swing the objective, eq. 18 energy and positive work of
//! both plans, and the joint solve's status, iterations, time and residuals.

use brachia_run::ladder::joint_swings;
use brachia_run::LadderScenario;
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .map_or("scenarios/ladder-even.toml", String::as_str);
    let swings: usize = args.get(2).map_or(Ok(2), |s| s.parse())?;
    let rest = args.get(3).is_some_and(|a| a == "rest");
    let ll = LadderScenario::load(Path::new(path))?;
    let t = std::time::Instant::now();
    let j = joint_swings(&ll, swings, rest)?;
    let wall = t.elapsed().as_secs_f64();
    println!(
        "{path}, {swings} swings, rest at switches {rest}: {:?} ({wall:.2} s wall in all)",
        j.status
    );
    println!("| swing | ref objective | joint objective | ref energy eq. 18 (J) | joint energy eq. 18 (J) | ref positive work (J) | joint positive work (J) | ref iterations | ref time (s) | capture residual (m, m/s) |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for (i, r) in j.reference.iter().enumerate() {
        match j.phases.get(i) {
            Some(p) => println!(
                "| {i} | {:.4} | {:.4} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {:.3} | {:.1e}, {:.1e} |",
                p.reference_objective,
                p.objective,
                r.energy_j,
                p.plan.energy_j,
                r.positive_work_j,
                p.plan.positive_work_j,
                r.iterations,
                r.solve_time_s,
                p.plan.violations.ee_position,
                p.plan.violations.ee_velocity
            ),
            None => println!("| {i} | {:.4} | - | {:.3} | - | {:.3} | - | {} | {:.3} | - |", r.objective, r.energy_j, r.positive_work_j, r.iterations, r.solve_time_s),
        }
    }
    let (pos, vel) = j.capture_residual();
    println!(
        "total: objective ref {:.4} joint {:.4}; energy ref {:.3} J joint {:.3} J; joint solve {} iterations {:.3} s; max defect {:.1e}; capture residual {pos:.1e} m {vel:.1e} m/s",
        j.reference_objective,
        j.objective,
        j.reference_energy_j(),
        j.energy_j(),
        j.solve.as_ref().map_or(0, |s| s.iterations),
        j.solve.as_ref().map_or(0.0, |s| s.time_s),
        j.max_defect
    );
    let (rit, rt) = j
        .reference
        .iter()
        .fold((0, 0.0), |(a, b), p| (a + p.iterations, b + p.solve_time_s));
    println!(
        "summary | {path} | {swings} | {rest} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {:.2} | {rit} | {} | {rt:.3} | {:.3} | {pos:.1e}, {vel:.1e} |",
        j.reference_objective,
        j.objective,
        j.reference_energy_j(),
        j.energy_j(),
        j.reference.iter().map(|p| p.positive_work_j).sum::<f64>(),
        j.phases.iter().map(|p| p.plan.positive_work_j).sum::<f64>(),
        j.solve.as_ref().map_or(0, |s| s.iterations),
        j.solve.as_ref().map_or(0.0, |s| s.time_s),
    );
    for (i, p) in j.phases.iter().enumerate() {
        let k = p.plan.layout.intervals;
        let qd = p.plan.points.qd(k);
        println!(
            "swing {i}: end rates {:?}, replay miss {:.2e} m, violations {:?}",
            qd, p.plan.replay_ee_error_m, p.plan.violations
        );
    }
    Ok(())
}
