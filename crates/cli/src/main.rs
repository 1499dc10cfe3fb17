//! `brachia`: the command-line interface, a thin layer over the library.
//!
//! Exit codes (docs/limits.md): 0 success, results to be trusted; 1 a solver or run failure (a plan that
//! did not converge: its report is still written); 2 bad input, refused before any work (nothing is
//! written); 3 an I/O failure after the inputs were accepted (a file could not be written).

mod benchmark;
mod io;
mod plan;
mod report;
mod reproduce;
mod simulate;
mod track;
mod traverse;

use clap::{Parser, Subcommand};
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
    /// Plan an energy-optimal swing for a scenario (direct collocation).
    Plan(plan::Args),
    /// Plan (or read a plan) and track it in closed loop at 1 kHz (MPC, PD or open loop).
    Track(track::Args),
    /// Traverse a ladder: plan and track every swing, switching the grip at every bar (model plant).
    Traverse(traverse::Args),
    /// Reproduce the paper's experiments (Section V): run folders, figures, animations, REPORT.md.
    Reproduce(reproduce::Args),
    /// The robustness benchmark: every controller under every disturbance, swept and mixed.
    Benchmark(benchmark::Args),
    /// Redraw every figure and REPORT.md of a `reproduce` output folder from its run folders (no
    /// planning, no simulation).
    Report(report::Args),
}

/// An error of a command: bad input (exit 2), a failure after the inputs were accepted (exit 1) or an
/// I/O failure (exit 3).
#[derive(Debug)]
pub enum CliError {
    /// Invalid or missing input: exit code 2, nothing written.
    Input(String),
    /// A computation did not succeed: exit code 1.
    Failed(String),
    /// A file could not be written after the work was done: exit code 3.
    Io(String),
}

impl From<brachia::Error> for CliError {
    fn from(e: brachia::Error) -> Self {
        CliError::Input(e.to_string())
    }
}

impl From<brachia_experiments::ExpError> for CliError {
    fn from(e: brachia_experiments::ExpError) -> Self {
        use brachia_experiments::ExpError;
        match e {
            ExpError::Write { .. } => CliError::Io(format!("could not write the results: {e}")),
            other => CliError::Input(other.to_string()),
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Simulate(a) => simulate::run(a),
        Command::Plan(a) => plan::run(a),
        Command::Track(a) => track::run(a),
        Command::Traverse(a) => traverse::run(a),
        Command::Reproduce(a) => reproduce::run(a),
        Command::Report(a) => report::run(a),
        Command::Benchmark(a) => benchmark::run(a),
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
    }
}
