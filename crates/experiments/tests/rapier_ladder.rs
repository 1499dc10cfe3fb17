//! Issue 14 on the rapier plant: a short ladder traverse against the physics engine, where every
//! capture rebuilds the multibody rooted at the bar the hand caught (docs/ladders.md, "The rapier
//! plant"); a forced miss ends the run with a status naming the swing and the miss; traverse
//! `[disturbances]` take only the per-link factors.
//!
//! Conventions: world frame x right, y up, m; rad; SI units. The 3-bar cuts keep the scenario's
//! planner, solver and rest condition; each runs in seconds in release.

use brachia_experiments::{run_traverse, LadderScenario, TraverseStatus};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The first `bars` bars of `scenarios/NAME` with the params path made absolute and `edit` applied,
/// written into `dir`.
fn cut(dir: &Path, name: &str, bars: usize, edit: impl FnOnce(&mut toml::Table)) -> PathBuf {
    let text = std::fs::read_to_string(root().join("scenarios").join(name)).unwrap();
    let mut v: toml::Table = text.parse().unwrap();
    let params = root().join("params/paper.toml").display().to_string();
    v.insert("params".into(), toml::Value::String(params));
    let ladder = v["ladder"].as_table_mut().unwrap();
    ladder["bars"].as_array_mut().unwrap().truncate(bars);
    edit(&mut v);
    let p = dir.join(name);
    std::fs::write(&p, toml::to_string(&v).unwrap()).unwrap();
    p
}

#[test]
fn a_three_bar_cut_of_the_even_ladder_completes_on_rapier_with_captures_within_2_cm() {
    let dir = tempfile::tempdir().unwrap();
    let ll = LadderScenario::load(&cut(dir.path(), "ladder-even-rapier.toml", 3, |_| {}))
        .unwrap_or_else(|e| panic!("{e}"));
    let tr = run_traverse(&ll).unwrap();
    assert!(tr.status.completed(), "{} ({:?})", tr.status, tr.swings);
    assert_eq!(tr.plant, "rapier");
    assert_eq!(tr.swings.len(), 2);
    for s in &tr.swings {
        assert!(s.capture_error_m < 0.02, "swing {}: {s:?}", s.swing);
        assert!(s.switch_residual_m_s < 0.1, "swing {}: {s:?}", s.swing);
        assert!(s.energy_j.is_finite() && s.positive_work_j > 0.0);
        // the engine's chain was rebuilt at the bar with every joint where it was
        let g = s.regrip.as_ref().expect("a rapier switch");
        assert!(g.position_residual_m < 1e-9, "{g:?}");
        // read from the engine bodies (the model kinematics give the switch residual): both slow
        assert!(g.ee_speed_m_s < 0.1 && s.switch_residual_m_s < 0.1, "{g:?}");
        // hand A first in the parameters file's order: the hand that closed is the last joint on
        // even swings (hand B), the first on odd ones (hand A); it is at rest after the switch
        let hand = if s.swing % 2 == 0 { 4 } else { 0 };
        let v = g.velocities_after[hand];
        assert!(v[0].hypot(v[1]) < 1e-9, "swing {}: {v:?}", s.swing);
    }
    // the second swing hangs from hand B at the bar the first one caught
    let b1 = ll.scenario.ladder.bars[1];
    let g = tr.swings[1].grip;
    assert!((g[0] - b1.x).hypot(g[1] - b1.y) < 0.02);
    let r = tr.report(&ll);
    assert_eq!(r["plant"], "rapier");
    assert_eq!(r["totals"]["bars_caught"], 2);
    assert!(
        r["totals"]["regrip_position_residual_max_m"]
            .as_f64()
            .unwrap()
            < 1e-9
    );
    let f = tr.folder(&ll).unwrap();
    for name in [
        "traverse.csv",
        "report.json",
        "contacts.csv",
        "obstacles.csv",
        "traverse.gif",
    ] {
        assert!(f.get(name).is_some(), "{name}");
    }
}

#[test]
fn a_miss_on_rapier_ends_the_run_with_a_status_naming_the_swing_and_the_miss() {
    let dir = tempfile::tempdir().unwrap();
    // a capture radius of 1 micrometre: no tracked hand gets that close
    let path = cut(dir.path(), "ladder-even-rapier.toml", 3, |v| {
        let l = v["ladder"].as_table_mut().unwrap();
        l.insert("capture_radius".into(), toml::Value::Float(1e-6));
    });
    let ll = LadderScenario::load(&path).unwrap();
    let tr = run_traverse(&ll).unwrap();
    match &tr.status {
        TraverseStatus::CaptureMissed {
            swing, bar, miss_m, ..
        } => {
            assert_eq!((*swing, *bar), (0, 1));
            assert!(*miss_m > 1e-6 && *miss_m < 0.02, "{miss_m}");
            assert!((tr.swings[0].capture_error_m - miss_m).abs() < 1e-15);
        }
        other => panic!("expected a miss, got {other}"),
    }
    assert!(tr
        .status
        .to_string()
        .contains("swing 0: the hand missed bar 1 by"));
    assert_eq!(tr.swings.len(), 1);
    assert!(tr.swings[0].regrip.is_none());
    // the folder is still written
    assert!(tr.folder(&ll).unwrap().get("report.json").is_some());
}

#[test]
fn traverse_disturbances_take_only_the_per_link_factors() {
    let dir = tempfile::tempdir().unwrap();
    let path = cut(dir.path(), "ladder-even-rapier.toml", 3, |v| {
        let mut d = toml::Table::new();
        d.insert("viscous_nm_s".into(), toml::Value::Float(0.1));
        v.insert("disturbances".into(), toml::Value::Table(d));
    });
    let e = LadderScenario::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("disturbances.viscous_nm_s") && e.contains("mass_scale"),
        "{e}"
    );
    let path = cut(dir.path(), "ladder-even-rapier.toml", 3, |v| {
        let mut d = toml::Table::new();
        d.insert(
            "mass_scale".into(),
            toml::Value::Array(vec![toml::Value::Float(1.1); 3]),
        );
        v.insert("disturbances".into(), toml::Value::Table(d));
    });
    let e = LadderScenario::load(&path).unwrap_err().to_string();
    assert!(e.contains("mass_scale"), "{e}");
}

#[test]
fn the_irregular_ladder_completes_on_rapier_with_every_capture_within_2_cm() {
    // all six bars: swing 2 starts with a relative joint past planner.bounds.q_rel_max (the tracked
    // chain ends a little past the plan's bound), which the traverse widens for that swing
    let dir = tempfile::tempdir().unwrap();
    let ll = LadderScenario::load(&cut(dir.path(), "ladder-irregular-rapier.toml", 6, |_| {}))
        .unwrap_or_else(|e| panic!("{e}"));
    let tr = run_traverse(&ll).unwrap();
    assert!(tr.status.completed(), "{} ({:?})", tr.status, tr.swings);
    assert_eq!(tr.swings.len(), 5);
    for s in &tr.swings {
        assert!(s.capture_error_m < 0.02, "swing {}: {s:?}", s.swing);
        assert!(s.switch_residual_m_s < 0.1, "swing {}: {s:?}", s.swing);
        assert!(s.energy_j.is_finite() && s.positive_work_j > 0.0);
        let g = s.regrip.as_ref().expect("a rapier switch");
        assert!(g.position_residual_m < 1e-9, "{g:?}");
    }
    let r = tr.report(&ll);
    assert_eq!(r["totals"]["bars_caught"], 5);
    for k in 0..5 {
        assert!(r["swings"][k]["energy_j"].as_f64().is_some());
    }
}
