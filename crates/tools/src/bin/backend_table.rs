//! The backend table of docs/benchmarks.md: every scenario in `scenarios/` (a ladder's first swing)
//! planned cold three ways, multiple shooting on `ocp`, the same problem on pounce (same guess), and
//! Hermite-Simpson on pounce at the scenario's own knots.
//!
//! ```text
//! cargo run --release -p brachia-tools --bin backend_table -- [--knot-dt S] [--substeps N] FILE..
//! ```
//! `--knot-dt` / `--substeps` set the shooting mesh (default: the planner's defaults). Prints one markdown
//! row per scenario. Units: s, m; objective is the planner's cost (paper eq. 5).

use brachia::planning::{plan, Backend, PlannerSettings, Transcription};
use brachia_experiments::ladder::swing_scenario;
use brachia_experiments::{Scenario, Uses};
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let d = PlannerSettings::default();
    let (mut knot_dt, mut substeps) = (d.knot_dt, d.shooting.substeps);
    let mut files = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--knot-dt" => knot_dt = args.next().ok_or("--knot-dt needs seconds")?.parse()?,
            "--substeps" => substeps = args.next().ok_or("--substeps needs a count")?.parse()?,
            f => files.push(PathBuf::from(f)),
        }
    }
    println!(
        "| scenario | ocp status | ocp it | ocp time | pounce status | pounce it | pounce time | \
         rel. objective diff | ocp objective | ocp replay miss | min clearance | HS status | HS objective | \
         HS replay miss | HS time |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for f in files {
        let text = std::fs::read_to_string(&f)?;
        let (robot, sc) = if text.contains("[ladder]") {
            let ll = brachia_experiments::LadderScenario::load(&f)?;
            let n = ll.robot.n();
            let grip = ll.scenario.ladder.bars[0].p();
            let sc = swing_scenario(&ll.scenario, &ll.x0[..n], &ll.x0[n..], grip, 1);
            (ll.robot, sc)
        } else {
            let ls = Scenario::load_for(&f, Uses::Plan)?;
            (ls.robot, ls.scenario)
        };
        let mut shooting = sc.planner.clone();
        shooting.transcription = Transcription::MultipleShooting;
        shooting.knot_dt = knot_dt;
        shooting.shooting.substeps = substeps;
        let run = |planner: &PlannerSettings, backend: Backend| {
            let solver = brachia::planning::NlpSettings {
                backend,
                ..sc.solver.clone()
            };
            let t = Instant::now();
            let p = plan(&robot, &sc.task, planner, &solver);
            (p, t.elapsed().as_secs_f64())
        };
        let (o, to) = run(&shooting, Backend::Ocp);
        let (p, tp) = run(&shooting, Backend::Pounce);
        let mut hs = sc.planner.clone();
        hs.transcription = Transcription::HermiteSimpson;
        let (h, th) = run(&hs, Backend::Pounce);
        let (o, p, h) = (o?, p?, h?);
        let rel = (o.objective - p.objective).abs() / p.objective.abs().max(1e-12);
        println!(
            "| {} | {:?} | {} | {:.1} ms | {:?} | {} | {:.1} ms | {:.1e} | {:.6} | {:.1e} m | {} | {:?} | {:.6} | {:.1e} m | {:.0} ms |",
            f.file_stem().and_then(|s| s.to_str()).unwrap_or("?"),
            o.status,
            o.iterations,
            to * 1e3,
            p.status,
            p.iterations,
            tp * 1e3,
            rel,
            o.objective,
            o.replay_ee_error_m,
            o.min_obstacle_clearance_m
                .map(|c| format!("{c:.4} m"))
                .unwrap_or_else(|| "-".into()),
            h.status,
            h.objective,
            h.replay_ee_error_m,
            th * 1e3
        );
    }
    Ok(())
}
