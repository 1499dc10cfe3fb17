//! The obstacle scan of docs/planner.md ("Obstacles on the path"): one 0.08 m obstacle at a link's
//! midpoint on the unobstructed tracking swing (scenarios/tracking.toml, multiple shooting, 10 ms knots),
//! planned by multiple shooting on `ocp` (continuation guess, the default) and, as the baseline, by
//! Hermite-Simpson on pounce from the smooth-step guess alone (`obstacle_guess = "direct"`; with
//! `--hs-default` the default guess strategies, detour seeds and continuation). Prints a Markdown table.
//! `cargo run --release -p brachia-tools --bin obstacle_scan [-- --no-pounce | --pounce-only] [--hs-default]
//! [--only 1,4,7]` (placement numbers, 1-based).
//! Units: m, s.

use brachia::model::Robot;
use brachia::planning::strategy::obstacles::path_placements;
use brachia::planning::{
    plan, Backend, NlpSettings, ObstacleGuess, Plan, PlannerSettings, SwingTask, Transcription,
};
use std::time::Instant;

fn cell(p: &Plan, wall: f64) -> String {
    let strat = p
        .guess
        .as_ref()
        .map(|g| {
            let won = g
                .seeds
                .iter()
                .find(|s| s.converged == Some(true))
                .map(|s| format!(", seed {:?}", s.kind))
                .unwrap_or_default();
            let cs = match &g.cspace {
                Some(c) if c.converged.is_some() => format!(
                    ", cspace {} ({} cells, {} waypoints)",
                    match (c.converged, c.relaxed_converged) {
                        (Some(true), Some(true)) =>
                            "converged after the actuator-limit continuation",
                        (Some(true), _) => "converged",
                        (_, Some(true)) => "failed (converged with widened limits only)",
                        _ => "failed",
                    },
                    c.cells_discovered,
                    c.waypoints
                ),
                Some(c) if !c.found => format!(", cspace: no path ({} cells)", c.cells_discovered),
                _ => String::new(),
            };
            format!("{:?}{won}{cs} ({} solves)", g.strategy, g.solves)
        })
        .unwrap_or_default();
    format!(
        "{} | {} | {:.4} | {:.2} | {strat}",
        if p.converged() { "yes" } else { "**no**" },
        p.iterations,
        p.objective,
        wall
    )
}

fn main() -> Result<(), brachia::Error> {
    let run_pounce = !std::env::args().any(|a| a == "--no-pounce");
    let run_ocp = !std::env::args().any(|a| a == "--pounce-only");
    let hs_default = std::env::args().any(|a| a == "--hs-default");
    let args: Vec<String> = std::env::args().collect();
    let only: Vec<usize> = args
        .iter()
        .position(|a| a == "--only")
        .and_then(|i| args.get(i + 1))
        .map(|v| v.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_default();
    let robot = Robot::paper();
    let task = SwingTask {
        q0: vec![-2.35, 0.0, -1.55, 0.0],
        qd0: vec![],
        target: [0.8, 0.0],
        obstacles: vec![],
    };
    let ms = PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt: 0.01,
        shooting: brachia::planning::ShootingSettings {
            substeps: 1,
            ..Default::default()
        },
        ..Default::default()
    };
    let ocp = NlpSettings {
        backend: Backend::Ocp,
        ..Default::default()
    };
    let pounce = NlpSettings {
        backend: Backend::Pounce,
        ..Default::default()
    };
    let hs = PlannerSettings {
        transcription: Transcription::HermiteSimpson,
        knot_dt: 0.01,
        obstacle_guess: if hs_default {
            ObstacleGuess::Continuation
        } else {
            ObstacleGuess::Direct
        },
        ..Default::default()
    };
    let base = plan(&robot, &task, &ms, &ocp)?;
    let places = path_placements(&robot, &base.points, task.target, 0.08, 0.01, 8)?;
    println!("| # | t (s) | link | centre (m) | ocp: converged | iterations | objective | wall (s) | strategy | pounce HS cold: converged | iterations | wall (s) | blockage (ocp) |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let (mut n_ocp, mut n_hs) = (0, 0);
    for (i, pl) in places.iter().enumerate() {
        if !only.is_empty() && !only.contains(&(i + 1)) {
            continue;
        }
        let tk = SwingTask {
            obstacles: vec![pl.obstacle],
            ..task.clone()
        };
        if !run_ocp {
            let t0 = Instant::now();
            let b = plan(&robot, &tk, &hs, &pounce)?;
            let wb = t0.elapsed().as_secs_f64();
            n_hs += usize::from(b.converged());
            println!(
                "| {} | {:.3} | {} | pounce HS: {} |",
                i + 1,
                pl.time_s,
                pl.link + 1,
                cell(&b, wb)
            );
            continue;
        }
        let t0 = Instant::now();
        let a = plan(&robot, &tk, &ms, &ocp)?;
        let wa = t0.elapsed().as_secs_f64();
        n_ocp += usize::from(a.converged());
        let b = if run_pounce {
            let t0 = Instant::now();
            let b = plan(&robot, &tk, &hs, &pounce)?;
            let wb = t0.elapsed().as_secs_f64();
            n_hs += usize::from(b.converged());
            format!(
                "{} | {} | {:.2}",
                if b.converged() { "yes" } else { "**no**" },
                b.iterations,
                wb
            )
        } else {
            "- | - | -".into()
        };
        println!(
            "| {} | {:.3} | {} | ({:.3}, {:.3}) | {} | {b} | {} |",
            i + 1,
            pl.time_s,
            pl.link + 1,
            pl.obstacle.center[0],
            pl.obstacle.center[1],
            cell(&a, wa),
            a.blockage
                .as_ref()
                .map(|b| b.to_string())
                .unwrap_or_default()
        );
    }
    println!();
    println!(
        "ocp (multiple shooting, default guess): {n_ocp}/{} converged; pounce (Hermite-Simpson, {}): {}",
        places.len(),
        if hs_default { "default guess" } else { "direct" },
        if run_pounce {
            format!("{n_hs}/{}", places.len())
        } else {
            "not run".into()
        }
    );
    Ok(())
}
