//! No setting silently ignored: a scenario section that has no effect on the controller and plant a
//! tracking run uses is refused before any work, naming the file, the field and why.
//!
//! A scenario file serves several commands: `brachia plan` reads only the robot, task, planner and
//! solver, and the commands that run every controller on one scenario (`benchmark`, `reproduce`) use
//! every controller's section. A single tracking run (`brachia track`, Python's `Scenario.track`)
//! uses one controller on one plant, so there a section written for another is refused.

use crate::scenario::{ControllerKind, LoadedScenario, PlantKind, TrackingSettings};
use brachia::Error;

/// The scenario's name for `controller` (as written in `[tracking] controller`).
fn controller_name(c: ControllerKind) -> &'static str {
    match c {
        ControllerKind::Mpc => "mpc",
        ControllerKind::Pd => "pd",
        ControllerKind::OpenLoop => "open-loop",
        ControllerKind::Tvlqr => "tvlqr",
    }
}

/// Refuse every `[tracking]` and `[plant]` setting of `ls` that has no effect on a run of
/// `controller` on `plant`: re-planning (`tracking.replan`) without the MPC, the Kalman filter
/// (`tracking.kalman`) on the open loop (which measures nothing), `[tracking.estimator]` without
/// the Kalman filter, the settings section of a controller that does not run (`tracking.mpc`,
/// `tracking.pd`, `tracking.tvlqr`, when they differ from the defaults), and the rapier plant's
/// contact settings (`plant.link_friction`, `plant.link_restitution`) or world obstacles
/// (`plant.obstacles`) on the model plant. The error names the file, the field, its value and why.
pub fn check_settings_apply(
    ls: &LoadedScenario,
    controller: ControllerKind,
    plant: PlantKind,
) -> Result<(), Error> {
    let src = ls.path.display().to_string();
    check_sections(
        &src,
        &ls.scenario.tracking,
        &ls.scenario.plant,
        controller,
        plant,
    )
}

/// [`check_settings_apply`] for a traverse (`brachia traverse`), which runs the ladder scenario's own
/// controller and plant on every swing: also a `[disturbances.ball]` on the model plant (which
/// simulates no contacts) is refused.
pub fn check_ladder_settings_apply(ll: &crate::ladder::LoadedLadder) -> Result<(), Error> {
    let src = ll.path.display().to_string();
    let sc = &ll.scenario;
    check_sections(
        &src,
        &sc.tracking,
        &sc.plant,
        sc.tracking.controller,
        sc.plant.kind,
    )?;
    if sc.plant.kind == PlantKind::Model {
        if let Some(b) = &sc.disturbances.ball {
            return Err(Error::invalid(
                src,
                "disturbances.ball",
                format!("a ball on swing {}", b.swing),
                "the model plant simulates no contacts, so the ball would be ignored: run the \
                 traverse on the rapier plant (plant.kind = \"rapier\") or remove \
                 [disturbances.ball]",
            ));
        }
    }
    Ok(())
}

/// The rules of [`check_settings_apply`] on the sections `t` and `p` of the scenario file `src`.
fn check_sections(
    src: &str,
    t: &TrackingSettings,
    p: &crate::scenario::PlantSettings,
    controller: ControllerKind,
    plant: PlantKind,
) -> Result<(), Error> {
    let name = controller_name(controller);
    let refuse =
        |field: &str, value: String, why: String| Err(Error::invalid(src, field, value, why));
    if t.estimate_params.is_some() && controller != ControllerKind::Mpc {
        return refuse(
            "tracking.estimate_params",
            "set".into(),
            format!(
                "the mass estimate feeds the MPC only; with controller \"{name}\" it would be \
                 ignored: remove tracking.estimate_params or track with controller \"mpc\""
            ),
        );
    }
    if t.replan.is_some() && controller != ControllerKind::Mpc {
        return refuse(
            "tracking.replan",
            "set".into(),
            format!(
                "online re-planning runs around the MPC only; with controller \"{name}\" it would \
                 be ignored: remove [tracking.replan] or track with controller \"mpc\""
            ),
        );
    }
    if t.kalman && controller == ControllerKind::OpenLoop {
        return refuse(
            "tracking.kalman",
            "true".into(),
            "the open loop replays the planned torques and measures nothing, so the Kalman filter \
             would be ignored: set kalman = false or track with a feedback controller"
                .into(),
        );
    }
    let d = TrackingSettings::default();
    if !t.kalman && t.estimator != d.estimator {
        return refuse(
            "tracking.estimator",
            "set".into(),
            "the estimator's settings are used only with the Kalman filter: set \
             [tracking] kalman = true or remove [tracking.estimator]"
                .into(),
        );
    }
    for (field, kind, differs) in [
        ("tracking.mpc", ControllerKind::Mpc, t.mpc != d.mpc),
        ("tracking.pd", ControllerKind::Pd, t.pd != d.pd),
        ("tracking.tvlqr", ControllerKind::Tvlqr, t.tvlqr != d.tvlqr),
    ] {
        if differs && controller != kind {
            return refuse(
                field,
                "set".into(),
                format!(
                    "the settings of controller \"{}\" have no effect on a run with controller \
                     \"{name}\": remove [{field}] or track with controller \"{}\"",
                    controller_name(kind),
                    controller_name(kind)
                ),
            );
        }
    }
    if plant == PlantKind::Model {
        let d = crate::scenario::PlantSettings::default();
        if !p.obstacles.is_empty() {
            return refuse(
                "plant.obstacles",
                format!("{} obstacles", p.obstacles.len()),
                "the model plant simulates no contacts: run them on the rapier plant \
                 (plant.kind = \"rapier\" or --plant rapier)"
                    .into(),
            );
        }
        for (field, v, dv) in [
            ("plant.link_friction", p.link_friction, d.link_friction),
            (
                "plant.link_restitution",
                p.link_restitution,
                d.link_restitution,
            ),
        ] {
            if v != dv {
                return refuse(
                    field,
                    v.to_string(),
                    "a contact setting of the rapier plant: the model plant simulates no contacts, \
                     so it would be ignored: remove it or run on the rapier plant \
                     (plant.kind = \"rapier\" or --plant rapier)"
                        .into(),
                );
            }
        }
    }
    Ok(())
}
