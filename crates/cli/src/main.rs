//! `brachia`: the command-line interface, a thin layer over the library.
//!
//! Exit codes (docs/limits.md): 0 success, results to be trusted; 1 a solver or run failure (a plan that
//! did not converge: its report is still written); 2 bad input, refused before any work (nothing is
//! written); 3 an I/O failure after the inputs were accepted (a file could not be written); 130 stopped
//! by Ctrl-C (SIGINT), 143 by SIGTERM: nothing was written, the previous results are as they were.

mod benchmark;
mod error;
mod io;
mod plan;
mod report;
mod reproduce;
mod robot;
mod simulate;
mod stoppable;
mod track;
mod traverse;
mod view;

use brachia_experiments::CancelToken;
use clap::{Parser, Subcommand};
pub use error::{
    check_cancel, exp_error, interrupted, CliError, EXIT_INTERRUPTED, EXIT_TERMINATED,
};
use std::process::ExitCode;

/// Plan and track energy-optimal swings of underactuated brachiation robots.
#[derive(Parser)]
#[command(name = "brachia", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate the passive chain (zero torque) with the RK4 model plant.
    Simulate(simulate::Args),
    /// Plan an energy-optimal swing for a scenario (multiple shooting on the Riccati solver by default).
    Plan(plan::Args),
    /// Plan (or read a plan) and track it in closed loop at 1 kHz (MPC, PD or open loop).
    Track(track::Args),
    /// Traverse a ladder: plan and track every swing, switching the grip at every bar (model or rapier plant).
    Traverse(traverse::Args),
    /// Reproduce the paper's experiments (Section V): run folders, figures, animations, REPORT.md.
    Reproduce(reproduce::Args),
    /// The robustness benchmark: every controller under every disturbance, swept and mixed.
    Benchmark(benchmark::Args),
    /// Redraw every figure and REPORT.md of a `reproduce` output folder from its run folders (no
    /// planning, no simulation).
    Report(report::Args),
    /// Write the interactive page view.html of a run folder (plan, track, traverse, simulate,
    /// benchmark; one self-contained file).
    View(view::Args),
    /// Import a robot from a URDF file, or export one as URDF or MuJoCo MJCF.
    Robot(robot::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // Ctrl-C: the first press sets the cancel flag, which the work checks between its units (a solve,
    // an experiment, a swing, a thousand simulation rows) and then stops without writing anything; a
    // second press stops at once (the staging folder is left hidden, removed by the next run)
    let cancel = CancelToken::new();
    // SIGTERM (`kill PID`, a service manager's stop) stops the same way, with its own exit code
    let terminated = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let handler = [
        (signal_hook::consts::SIGINT, EXIT_INTERRUPTED),
        (signal_hook::consts::SIGTERM, EXIT_TERMINATED),
    ]
    .into_iter()
    .try_for_each(|(sig, code)| {
        signal_hook::flag::register_conditional_shutdown(sig, i32::from(code), cancel.flag())
            .and_then(|_| signal_hook::flag::register(sig, cancel.flag()))
            .map(|_| ())
    })
    .and_then(|()| {
        signal_hook::flag::register(signal_hook::consts::SIGTERM, terminated.clone()).map(|_| ())
    });
    if let Err(e) = handler {
        eprintln!("brachia: note: no Ctrl-C handler ({e}); Ctrl-C stops at once");
    }
    let result = match cli.command {
        Command::Simulate(a) => simulate::run(a, &cancel),
        Command::Plan(a) => plan::run(a, &cancel),
        Command::Track(a) => track::run(a, &cancel),
        Command::Traverse(a) => traverse::run(a, &cancel),
        Command::Reproduce(a) => reproduce::run(a, &cancel),
        Command::Report(a) => report::run(a, &cancel),
        Command::Benchmark(a) => benchmark::run(a, &cancel),
        Command::View(a) => view::run(a),
        Command::Robot(a) => robot::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError::Input(msg)) => {
            eprintln!("error: {msg}");
            ExitCode::from(2)
        }
        Err(CliError::Failed(msg)) => {
            eprintln!("error: {msg}");
            ExitCode::from(1)
        }
        Err(CliError::Io(msg)) => {
            eprintln!("error: {msg}");
            ExitCode::from(3)
        }
        Err(CliError::Interrupted(msg)) if terminated.load(std::sync::atomic::Ordering::SeqCst) => {
            eprintln!("error: {}", msg.replace("(Ctrl-C)", "(SIGTERM)"));
            ExitCode::from(EXIT_TERMINATED)
        }
        Err(CliError::Interrupted(msg)) => {
            eprintln!("error: {msg}");
            ExitCode::from(EXIT_INTERRUPTED)
        }
    }
}
