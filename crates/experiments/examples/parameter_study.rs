//! The paper's parameter study (Section V-A, Figs. 3 and 4) from the command line.
//!
//! ```text
//! cargo run --release -p brachia-experiments --example parameter_study -- \
//!     [--quick] [--knot-dt S] [--hermite-simpson | --trapezoidal] [--pounce] [--cold] [--params FILE]
//!     [--settings FILE] [--out DIR] [--no-progress]
//! ```
//! The default path is the planner's: multiple shooting on the `ocp` backend at 30 ms knots.
//! `--quick` uses 50 ms knots. `--hermite-simpson` and `--trapezoidal` select that collocation rule on
//! pounce (give `--knot-dt 0.01` for the paper's knots); `--pounce` solves on pounce; `--cold` starts
//! every cell cold (no warm start along the row). Prints a per-r2 summary; with `--out` writes the run
//! folder (cells.csv, freefall.csv, report.json, stick diagrams).

use brachia::planning::{Backend, Transcription};
use brachia_experiments::{
    parameter_study_folder, run_parameter_study, BaseParams, ParameterStudySettings,
};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mut s = ParameterStudySettings::default();
    let (mut out, mut progress) = (None::<PathBuf>, true);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--settings" => {
                let p = PathBuf::from(args.next().ok_or("--settings needs a file")?);
                s = ParameterStudySettings::from_toml_file(&p)?;
            }
            "--quick" => s.planner.knot_dt = 0.05,
            "--knot-dt" => {
                s.planner.knot_dt = args.next().ok_or("--knot-dt needs seconds")?.parse()?
            }
            "--trapezoidal" => {
                s.planner.transcription = Transcription::Trapezoidal;
                s.solver.backend = Backend::Pounce;
            }
            "--hermite-simpson" => {
                s.planner.transcription = Transcription::HermiteSimpson;
                s.solver.backend = Backend::Pounce;
            }
            "--pounce" => s.solver.backend = Backend::Pounce,
            "--cold" => s.warm_start = false,
            "--params" => {
                s.base_params =
                    BaseParams::File(PathBuf::from(args.next().ok_or("--params needs a file")?))
            }
            "--out" => out = Some(PathBuf::from(args.next().ok_or("--out needs a folder")?)),
            "--no-progress" => progress = false,
            other => return Err(format!("unknown argument {other}").into()),
        }
    }
    let show = |p: brachia_experiments::Progress| {
        if progress {
            eprint!("\r{}/{} {}", p.done, p.total, p.what);
        }
    };
    let study = run_parameter_study(&s, &show)?;
    if progress {
        eprintln!();
    }
    println!(
        "{} cells, {} failed, wall time {:.1} s, start q = {:?}",
        study.cells.len(),
        study.failed_cells(),
        study.wall_time_s,
        study.start_q
    );
    let replay = study
        .cells
        .iter()
        .filter_map(|c| c.replay_ee_error_m)
        .fold(0.0_f64, f64::max);
    let iters: usize = study.cells.iter().map(|c| c.iterations).sum();
    let solve: f64 = study.cells.iter().map(|c| c.solve_time_s).sum();
    println!(
        "largest replay miss {replay:.2e} m, {iters} iterations, solve time {solve:.2} s in all"
    );
    println!("r2    T_ff [s]  T [s]   E(T) [J]   argmin T [s] (offset)  E_min [J]  failed");
    let f = |v: Option<f64>| {
        v.map(|x| format!("{x:9.4}"))
            .unwrap_or_else(|| "        -".into())
    };
    for r in &study.rows {
        println!(
            "{:.2}  {:8.4}  {:6.4}  {}  {}  ({:+.1}{})  {}  {}",
            r.r2,
            r.freefall_time_s,
            r.swing_time_s,
            f(r.energy_at_t_j),
            f(r.argmin_swing_time_s),
            r.argmin_offset_s.unwrap_or(f64::NAN),
            if r.argmin_at_edge == Some(true) {
                ", edge"
            } else {
                ""
            },
            f(r.min_energy_j),
            r.failed_cells
        );
    }
    println!(
        "energy [J] by r2 (rows) and offset (columns {:?} s):",
        s.offsets_s
    );
    for (i, r) in study.rows.iter().enumerate() {
        let line: Vec<String> = (0..s.offsets_s.len())
            .map(|j| {
                study
                    .cell(i, j)
                    .energy_j
                    .map(|e| format!("{e:7.3}"))
                    .unwrap_or_else(|| "   fail".into())
            })
            .collect();
        println!("{:.2} {}", r.r2, line.join(" "));
    }
    if let Some(dir) = out {
        parameter_study_folder(&study).write(&dir)?;
        println!("wrote {}", dir.display());
    }
    Ok(())
}
