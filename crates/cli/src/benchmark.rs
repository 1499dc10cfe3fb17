//! `brachia benchmark`: the robustness benchmark of a scenario (library:
//! `brachia_experiments::benchmark`; docs/robustness.md).

use crate::{check_cancel, exp_error, interrupted, CliError};
use brachia_experiments::{
    check_out_dir, run_benchmark, BenchmarkOutcome, BenchmarkSettings, CancelToken, Progress,
    Scenario,
};
use std::path::PathBuf;

/// Arguments of `brachia benchmark`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML), e.g. scenarios/tracking.toml: the plan, the controllers' settings, the
    /// sweeps' plant; its [disturbances] are the base every level adds to.
    #[arg(long)]
    scenario: PathBuf,
    /// Output folder: runs.csv, scorecard.json, summary.md, success_<disturbance>.png.
    #[arg(long)]
    out: PathBuf,
    /// 3 levels per disturbance and 6 Monte Carlo runs (CI) instead of 21 and 200.
    #[arg(long)]
    quick: bool,
    /// Worker threads (default: all cores); results do not depend on it.
    #[arg(long)]
    jobs: Option<usize>,
    /// Levels per disturbance (overrides --quick's and the full run's).
    #[arg(long)]
    levels: Option<usize>,
    /// Monte Carlo runs of the original family (overrides --quick's and the full run's).
    #[arg(long)]
    monte_carlo: Option<usize>,
    /// Runs of each other Monte Carlo family (overrides --quick's 1 and the full run's 50).
    #[arg(long)]
    family_runs: Option<usize>,
    /// Base seed of every draw (default 0); another seed draws a fresh set.
    #[arg(long)]
    seed: Option<u64>,
    /// Only this sweep (repeatable), e.g. --sweep actuation_delay.
    #[arg(long)]
    sweep: Vec<String>,
    /// Only this controller (repeatable): mpc, pd, open-loop, tvlqr, mpc+kalman, mpc+replan,
    /// mpc+kalman+replan, mpc+estimate+replan.
    #[arg(long)]
    controller: Vec<String>,
    /// Only one part of the benchmark: the sweeps, or the Monte Carlo (e.g. --only monte-carlo).
    #[arg(long, value_enum)]
    only: Option<Part>,
    /// No progress bar.
    #[arg(long)]
    no_progress: bool,
    /// Write into a non-empty --out folder that is not a brachia run folder (its files are kept).
    #[arg(long)]
    force: bool,
}

/// A part of the benchmark (`--only`).
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum Part {
    /// The disturbance sweeps (no Monte Carlo).
    Sweeps,
    /// The Monte Carlo (no sweeps).
    MonteCarlo,
}

/// A refusal of a benchmark setting named as the user wrote it: the flag (`--family-runs`), not the
/// settings field (`family_runs`).
fn as_flag(e: brachia::Error) -> brachia::Error {
    match e {
        brachia::Error::InvalidValue {
            field,
            value,
            reason,
            ..
        } => {
            let flag = match field.as_str() {
                "monte_carlo_runs" => "--monte-carlo".to_string(),
                f => format!("--{}", f.replace('_', "-")),
            };
            brachia::Error::invalid("command line", flag, value, reason)
        }
        e => e,
    }
}

/// Run the command.
pub fn run(a: Args, cancel: &CancelToken) -> Result<(), CliError> {
    let ls = Scenario::load(&a.scenario)?;
    let mut s = if a.quick {
        BenchmarkSettings::quick()
    } else {
        BenchmarkSettings::full()
    };
    s.jobs = a.jobs;
    s.levels = a.levels.unwrap_or(s.levels);
    s.monte_carlo_runs = a.monte_carlo.unwrap_or(s.monte_carlo_runs);
    s.family_runs = a.family_runs.unwrap_or(s.family_runs);
    s.seed = a.seed.unwrap_or(s.seed);
    s.only_sweeps = a.sweep;
    s.only_controllers = a.controller;
    s.cancel = Some(cancel.clone());
    let conflict = |flag: &str, value: String, part: &str| {
        brachia::Error::invalid(
            "command line",
            flag,
            value,
            format!("conflicts with --only {part}, which does not run it"),
        )
    };
    match a.only {
        Some(Part::Sweeps) => {
            if let Some(n) = a.monte_carlo {
                return Err(conflict("--monte-carlo", n.to_string(), "sweeps").into());
            }
            if let Some(n) = a.family_runs {
                return Err(conflict("--family-runs", n.to_string(), "sweeps").into());
            }
            s.monte_carlo_runs = 0;
            s.family_runs = 0;
        }
        Some(Part::MonteCarlo) => {
            if let Some(n) = a.levels {
                return Err(conflict("--levels", n.to_string(), "monte-carlo").into());
            }
            if let Some(name) = s.only_sweeps.first() {
                return Err(conflict("--sweep", name.clone(), "monte-carlo").into());
            }
            s.run_sweeps = false;
        }
        None => {}
    }
    s.validate().map_err(as_flag)?;
    check_out_dir(&a.out, a.force)?;
    let bar = crate::io::progress_bar(a.no_progress);
    let show = |p: Progress| crate::io::show_progress(&bar, p);
    let out = run_benchmark(&ls, &s, &show);
    bar.finish_and_clear();
    check_cancel(cancel, &a.out)?;
    let out = out?;
    match out {
        BenchmarkOutcome::Cancelled => Err(interrupted(&a.out)),
        BenchmarkOutcome::Done(b) => {
            b.write_cancellable(&a.out, cancel)
                .map_err(exp_error(&a.out))?;
            eprintln!(
                "benchmark: {} runs in {:.1} s; summary {}",
                b.rows.len(),
                b.wall_time_s,
                a.out.join("summary.md").display()
            );
            for c in &b.scores {
                eprintln!(
                    "benchmark: {}: robustness score {:.3}, success {:.1} %",
                    c.controller, c.robustness_score, c.overall.success_pct
                );
            }
            Ok(())
        }
        BenchmarkOutcome::PlanFailed(status) => Err(CliError::Failed(format!(
            "the planner did not converge (status {status}); nothing was benchmarked"
        ))),
    }
}
