//! `brachia track`: plan (or read a plan) and track it in closed loop at 1 kHz.

use crate::{check_cancel, exp_error, CliError};
use brachia::sim::DIVERGENCE_BOUND;
use brachia_experiments::view::{track_run_page, VIEW_FILE};
use brachia_experiments::{
    check_out_apart, check_out_dir, check_settings_apply, read_plan_folder, run_track, CancelToken,
    ControllerKind, PlantKind, RunFolder, Scenario, TrackOutcome, CAPTURE_SPEED_M_S,
    REPLAY_TRUST_M, SUCCESS_RADIUS_M,
};
use std::path::PathBuf;

/// Arguments of `brachia track`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML), e.g. scenarios/tracking.toml.
    #[arg(long)]
    scenario: PathBuf,
    /// Output folder: closed_loop.csv, report.json, view.html and the plan under plan/ (rapier plant:
    /// also contacts.csv and obstacles.csv).
    #[arg(long)]
    out: PathBuf,
    /// Controller (default: the scenario's, else mpc).
    #[arg(long, value_enum)]
    controller: Option<ControllerArg>,
    /// Plant (default: the scenario's, else model).
    #[arg(long, value_enum)]
    plant: Option<PlantArg>,
    /// Track the plan in this folder (written by `brachia plan`) instead of planning.
    #[arg(long)]
    plan: Option<PathBuf>,
    #[command(flatten)]
    folder: crate::io::FolderArgs,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ControllerArg {
    Mpc,
    Pd,
    OpenLoop,
    Tvlqr,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum PlantArg {
    Model,
    Rapier,
}

/// Run the command.
pub fn run(a: Args, cancel: &CancelToken) -> Result<(), CliError> {
    let mut ls = Scenario::load(&a.scenario)?;
    // the plan's solves, the re-plans and the closed loop check the token
    ls.scenario.solver.cancel = Some(cancel.clone());
    let controller = match a.controller {
        Some(ControllerArg::Mpc) => ControllerKind::Mpc,
        Some(ControllerArg::Pd) => ControllerKind::Pd,
        Some(ControllerArg::OpenLoop) => ControllerKind::OpenLoop,
        Some(ControllerArg::Tvlqr) => ControllerKind::Tvlqr,
        None => ls.scenario.tracking.controller,
    };
    let plant = match a.plant {
        Some(PlantArg::Model) => PlantKind::Model,
        Some(PlantArg::Rapier) => PlantKind::Rapier,
        None => ls.scenario.plant.kind,
    };
    // a setting that would have no effect on this controller and plant is refused, not ignored
    check_settings_apply(&ls, controller, plant)?;
    let reference = match &a.plan {
        Some(dir) => Some(read_plan_folder(dir, &ls)?),
        None => None,
    };
    check_out_dir(&a.out, a.folder.force)?;
    if let Some(dir) = &a.plan {
        // a run replaces the files of --out: it must not be (or hold, or lie in) the plan it reads
        check_out_apart(&a.out, dir, "--plan", true)?;
    }
    let outcome = {
        let ls = ls.clone();
        crate::stoppable::in_memory(cancel, &a.out, move || {
            run_track(&ls, controller, plant, reference)
        })?
    };
    check_cancel(cancel, &a.out)?;
    let outcome = outcome?;
    match outcome {
        TrackOutcome::Tracked(mut run) => {
            if !a.folder.no_view {
                let page = track_run_page(&ls, &run);
                run.folder.add(VIEW_FILE, page);
            }
            run.folder.write(&a.out).map_err(exp_error(&a.out))?;
            let s = &run.summary;
            if let Some(t) = s.diverged_at_s {
                return Err(CliError::Failed(format!(
                    "the closed loop diverged at t = {t:.3} s (a state beyond {DIVERGENCE_BOUND:e} rad \
                     or rad/s or not finite, or a non-finite torque): the results cannot be trusted; the \
                     run up to then is in {}",
                    a.out.display()
                )));
            }
            eprintln!(
                "track: EE final error {:.2e} m from the reference (max {:.2e} m), joint RMS error \
                 {:.2e} rad, energy {:.3} J, control step p50 {:.0} us",
                s.ee_final_error_m,
                s.ee_error_max_m,
                s.joint_rms_error_rad,
                s.energy_j,
                s.control_step_us_p50
            );
            if !run.world.obstacles.is_empty() {
                match run.world.first_contact_s() {
                    Some(t) => eprintln!(
                        "track: first contact at {t:.3} s ({} contact events)",
                        run.world.contacts.len()
                    ),
                    None => eprintln!("track: the robot touched no obstacle"),
                }
            }
            if let (Some(t), Some(e)) = (run.report.capture_t_s, run.report.bar_error_m) {
                eprintln!("track: the hand captures the bar at {t:.3} s ({e:.4} m from it)");
            }
            if run.report.reaches_bar != Some(true) {
                // a miss is a failure (exit 1), so a script can tell a catch from a miss
                let bar = run.report.target;
                return Err(CliError::Failed(format!(
                    "this swing misses the bar: the plant's hand never came within the success radius \
                     of {SUCCESS_RADIUS_M} m of the target bar [{}, {}] of {} no faster than \
                     {CAPTURE_SPEED_M_S} m/s (brachia_experiments::success, the capture rule); at the \
                     end of the swing it is {:.4} m from the bar; the run is in {}",
                    bar[0],
                    bar[1],
                    a.scenario.display(),
                    run.report.bar_error_m.unwrap_or(f64::INFINITY),
                    a.out.display()
                )));
            }
            Ok(())
        }
        TrackOutcome::PlanFailed(plan_run) => {
            let mut folder = RunFolder::default();
            for name in plan_run.folder.names() {
                if let Some(data) = plan_run.folder.get(name) {
                    folder.add(&format!("plan/{name}"), data.to_vec());
                }
            }
            folder.write(&a.out).map_err(exp_error(&a.out))?;
            let p = &plan_run.plan;
            let why = if p.converged() {
                format!(
                    "the plan converged, but replaying its torques open loop misses the bar by {:.3} m \
                     (more than {REPLAY_TRUST_M} m)",
                    p.replay_ee_error_m
                )
            } else {
                p.failure_message().unwrap_or_else(|| {
                    format!("the planner did not converge (status {:?})", p.status)
                })
            };
            Err(CliError::Failed(format!(
                "{why}; nothing was tracked; the plan's report is in {}",
                a.out.join("plan").display()
            )))
        }
    }
}
