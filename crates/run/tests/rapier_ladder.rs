//! Ladders on the rapier plant: a short ladder traverse against the physics engine, where every
//! capture rebuilds the multibody rooted at the bar the hand caught (docs/ladders.md, "The rapier
//! plant"); a forced miss ends the run with a status naming the swing and the miss; traverse
//! `[disturbances]` take only the per-link factors.
//!
//! Conventions: world frame x right, y up, m; rad; SI units. The 3-bar cuts keep the scenario's
//! planner, solver and rest condition; each runs in seconds in release.

use brachia_run::{run_traverse, LadderScenario, LoadedLadder, TraverseStatus};
use std::cell::Cell;
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

/// Cuts of the scenarios ([`cut`]) loaded as traverses, each written into a folder of its own under
/// one temporary folder (kept while the runs need it).
struct Cuts {
    dir: tempfile::TempDir,
    made: Cell<usize>,
}

impl Cuts {
    fn new() -> Self {
        Cuts {
            dir: tempfile::tempdir().unwrap(),
            made: Cell::new(0),
        }
    }

    /// The cut, written and loaded as [`LadderScenario::load`] gives it.
    fn try_load(
        &self,
        name: &str,
        bars: usize,
        edit: impl FnOnce(&mut toml::Table),
    ) -> Result<LoadedLadder, brachia::Error> {
        let sub = self.dir.path().join(self.made.get().to_string());
        self.made.set(self.made.get() + 1);
        std::fs::create_dir_all(&sub).unwrap();
        LadderScenario::load(&cut(&sub, name, bars, edit))
    }

    /// The cut, loaded (a refusal fails the test, naming it).
    fn load(&self, name: &str, bars: usize, edit: impl FnOnce(&mut toml::Table)) -> LoadedLadder {
        self.try_load(name, bars, edit)
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// The message of the cut's refusal (a cut that loads fails the test).
    fn refusal(&self, name: &str, bars: usize, edit: impl FnOnce(&mut toml::Table)) -> String {
        match self.try_load(name, bars, edit) {
            Ok(_) => panic!("{name}: the edited cut loads"),
            Err(e) => e.to_string(),
        }
    }
}

#[test]
fn a_three_bar_cut_of_the_even_ladder_completes_on_rapier_with_captures_within_2_cm() {
    let cuts = Cuts::new();
    let ll = cuts.load("ladder-even-rapier.toml", 3, |_| {});
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
    let cuts = Cuts::new();
    // a capture radius of 1 micrometre: no tracked hand gets that close
    let ll = cuts.load("ladder-even-rapier.toml", 3, |v| {
        let l = v["ladder"].as_table_mut().unwrap();
        l.insert("capture_radius".into(), toml::Value::Float(1e-6));
    });
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
    let cuts = Cuts::new();
    let e = cuts.refusal("ladder-even-rapier.toml", 3, |v| {
        let mut d = toml::Table::new();
        d.insert("viscous_nm_s".into(), toml::Value::Float(0.1));
        v.insert("disturbances".into(), toml::Value::Table(d));
    });
    assert!(
        e.contains("disturbances.viscous_nm_s") && e.contains("mass_scale"),
        "{e}"
    );
    let e = cuts.refusal("ladder-even-rapier.toml", 3, |v| {
        let mut d = toml::Table::new();
        d.insert(
            "mass_scale".into(),
            toml::Value::Array(vec![toml::Value::Float(1.1); 3]),
        );
        v.insert("disturbances".into(), toml::Value::Table(d));
    });
    assert!(e.contains("mass_scale"), "{e}");
}

#[test]
fn the_irregular_ladder_completes_on_rapier_with_every_capture_within_2_cm() {
    // all six bars: swing 2 starts with a relative joint past planner.bounds.q_rel_max (the tracked
    // chain ends a little past the plan's bound), which the traverse widens for that swing
    let cuts = Cuts::new();
    let ll = cuts.load("ladder-irregular-rapier.toml", 6, |_| {});
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

/// `[disturbances.ball]` as a TOML table.
fn ball_table(swing: i64, at_s: f64, mass: f64) -> toml::Value {
    let mut b = toml::Table::new();
    b.insert("swing".into(), toml::Value::Integer(swing));
    b.insert("at_s".into(), toml::Value::Float(at_s));
    b.insert("mass".into(), toml::Value::Float(mass));
    b.insert("radius".into(), toml::Value::Float(0.05));
    b.insert("restitution".into(), toml::Value::Float(0.5));
    let mut d = toml::Table::new();
    d.insert("ball".into(), toml::Value::Table(b));
    toml::Value::Table(d)
}

#[test]
fn a_ball_on_a_swing_is_validated_naming_the_field() {
    let cuts = Cuts::new();
    for (swing, at_s, mass, field) in [
        (2, 0.9, 0.2, "disturbances.ball.swing"),
        (0, -0.1, 0.2, "disturbances.ball.at_s"),
        (0, 0.9, 0.0, "disturbances.ball.mass"),
    ] {
        let e = cuts.refusal("ladder-even-rapier.toml", 3, |v| {
            v.insert("disturbances".into(), ball_table(swing, at_s, mass));
        });
        assert!(e.contains(field), "{field}: {e}");
    }
    // a time past the swing's planned time is found when the swing is planned
    let ll = cuts.load("ladder-even-rapier.toml", 3, |v| {
        v.insert("disturbances".into(), ball_table(0, 50.0, 0.2));
    });
    let e = run_traverse(&ll).unwrap_err().to_string();
    assert!(e.contains("disturbances.ball.at_s"), "{e}");
}

#[test]
fn the_model_plant_ignores_the_ball_and_completes() {
    let cuts = Cuts::new();
    let ll = cuts.load("ladder-even.toml", 3, |v| {
        v.insert("disturbances".into(), ball_table(1, 0.9, 0.2));
    });
    let tr = run_traverse(&ll).unwrap();
    assert!(tr.status.completed(), "{}", tr.status);
    let b = tr.ball.as_ref().expect("the ball of swing 1 is recorded");
    assert!(b.ignored && b.obstacle_id.is_none() && b.swing == 1);
    assert!(tr.world.obstacles.is_empty());
    assert_eq!(tr.ball_contacts().count(), 0);
    assert_eq!(tr.report(&ll)["ball"]["ignored"], true);
}

#[test]
fn a_ball_on_swing_1_is_hit_by_the_swinging_hand_on_rapier() {
    // the ball is put into the world when swing 1 starts, on its planned hand path 0.9 s in:
    // the contact log shows the hit within swing 1, after the ball appeared
    let cuts = Cuts::new();
    let ll = cuts.load("ladder-even-rapier.toml", 3, |v| {
        v.insert("disturbances".into(), ball_table(1, 0.9, 0.2));
    });
    let tr = run_traverse(&ll).unwrap();
    assert!(tr.swings.len() == 2, "{} ({:?})", tr.status, tr.swings);
    let b = tr.ball.as_ref().expect("the ball of swing 1");
    assert_eq!(b.obstacle_id, Some(0));
    assert!(!b.ignored);
    let s1 = &tr.swings[1];
    let hits: Vec<_> = tr.ball_contacts().collect();
    assert!(!hits.is_empty(), "the ball was not hit: {s1:?}");
    for c in &hits {
        assert!(
            c.t >= s1.t_start_s && c.t <= s1.t_start_s + s1.duration_s + 1e-9,
            "{c:?}"
        );
    }
    assert!(s1.contact_events > 0);
    // the obstacle track has the ball's columns, NaN before swing 1
    let csv = tr.obstacles_csv();
    assert!(
        csv.starts_with("t,obstacle_0_x,obstacle_0_y\n"),
        "{csv:.80}"
    );
    assert!(tr.world.track.iter().all(|r| r.len() == 3));
    let first = &tr.world.track[0];
    assert!(first[0] >= s1.t_start_s - 1e-9, "{first:?}");
    let r = tr.report(&ll);
    assert!(r["ball_contact_events"].as_u64().unwrap() > 0);
}

/// The disturbed traverse on a cut of `scenarios/ladder-{even,irregular}-disturbed-rapier.toml`
/// (every link mass +10 %, a ball on swing 1, MPC with online re-planning): the cut completes with
/// every capture within 2 cm, the ball is hit by the chain during swing 1 and re-planned after; the
/// same cut without re-planning misses swing 0 (the mass mismatch alone).
fn disturbed_cut(name: &str, bars: usize) {
    let cuts = Cuts::new();
    let ll = cuts.load(name, bars, |_| {});
    assert!(ll
        .scenario
        .disturbances
        .model
        .mass_scale
        .iter()
        .all(|&m| m == 1.1));
    let tr = run_traverse(&ll).unwrap();
    assert!(tr.status.completed(), "{} ({:?})", tr.status, tr.swings);
    assert_eq!(tr.swings.len(), bars - 1);
    for s in &tr.swings {
        assert!(s.capture_error_m <= 0.02, "swing {}: {s:?}", s.swing);
        assert!(s.switch_residual_m_s <= 0.1, "swing {}: {s:?}", s.swing);
        assert!(s.regrip.as_ref().unwrap().position_residual_m < 1e-9);
        assert_eq!(s.replans, s.replan_events.len());
    }
    // the ball was really hit, inside swing 1, and a re-plan was adopted after the first hit
    let s1 = &tr.swings[1];
    let hits: Vec<_> = tr.ball_contacts().collect();
    assert!(!hits.is_empty(), "the ball was not hit: {s1:?}");
    let end1 = s1.t_start_s + s1.duration_s + 1e-9;
    assert!(hits.iter().all(|c| c.t >= s1.t_start_s && c.t <= end1));
    let t_hit = hits[0].t - s1.t_start_s;
    assert!(
        s1.replan_events
            .iter()
            .any(|e| e.adopted && e.t_trigger_s >= t_hit),
        "no re-plan adopted after the hit at {t_hit} s: {:?}",
        s1.replan_events
    );
    eprintln!(
        "{name}: {:?}",
        tr.swings
            .iter()
            .map(|s| (s.capture_error_m, s.replans, s.energy_j))
            .collect::<Vec<_>>()
    );

    // without re-planning the heavier chain misses the first bar
    let ll = cuts.load(name, 2, |v| {
        let t = v["tracking"].as_table_mut().unwrap();
        t.remove("replan");
        let d = v["disturbances"].as_table_mut().unwrap();
        d.remove("ball");
    });
    let tr = run_traverse(&ll).unwrap();
    match &tr.status {
        TraverseStatus::CaptureMissed { swing, miss_m, .. } => {
            assert_eq!(*swing, 0);
            assert!(*miss_m > 0.02, "{miss_m}");
        }
        other => panic!("plain MPC: expected a miss on swing 0, got {other}"),
    }
}

#[test]
fn the_even_ladder_with_heavier_links_and_a_ball_completes_on_rapier_with_replanning() {
    disturbed_cut("ladder-even-disturbed-rapier.toml", 3);
}

#[test]
fn the_irregular_ladder_with_heavier_links_and_a_ball_completes_on_rapier_with_replanning() {
    // four bars: swing 2 is the irregular ladder's hardest under the mass mismatch
    disturbed_cut("ladder-irregular-disturbed-rapier.toml", 4);
}

/// `ladder.lookahead = 2` under the disturbed irregular ladder (a 4-bar cut of
/// `scenarios/ladder-irregular-disturbed-rapier.toml`: every link mass +10 %, a ball on swing 1, MPC
/// with online re-planning; docs/ladders.md, "Lookahead"). With the joint plans' switch states free
/// (`lookahead_switch = "free"`, the behaviour before the fix) swing 1 ends with the chain moving
/// and its hand arrives at bar 2 faster than the capture speed (1.35 cm, 0.101 m/s). With the
/// scenario's `lookahead_switch = "rest"` (the rest condition at every switch) and the re-plans of
/// each joint-planned swing aiming at the joint plan's switch pose, the cut completes, and with
/// less positive work than the same cut planned swing by swing (lookahead 1).
#[test]
fn lookahead_two_completes_the_disturbed_irregular_ladder_with_rest_at_the_switches() {
    let cuts = Cuts::new();
    let name = "ladder-irregular-disturbed-rapier.toml";
    let run = |lookahead: i64, switch: Option<&str>| {
        let ll = cuts.load(name, 4, |v| {
            let l = v["ladder"].as_table_mut().unwrap();
            l.insert("lookahead".into(), toml::Value::Integer(lookahead));
            if let Some(s) = switch {
                l.insert("lookahead_switch".into(), toml::Value::String(s.into()));
            }
        });
        run_traverse(&ll).unwrap()
    };
    let alone = run(1, None);
    let ahead = run(2, None);
    assert_eq!(ahead.swings[0].plan_source, brachia_run::PlanSource::Joint);
    for tr in [&alone, &ahead] {
        assert!(tr.status.completed(), "{} ({:?})", tr.status, tr.swings);
        for s in &tr.swings {
            assert!(s.capture_error_m <= 0.02, "swing {}: {s:?}", s.swing);
            assert!(s.switch_residual_m_s <= 0.1, "swing {}: {s:?}", s.swing);
        }
    }
    let sources: Vec<_> = ahead.swings.iter().map(|s| s.plan_source).collect();
    use brachia_run::PlanSource::{Joint, JointGuess};
    assert_eq!(sources, [Joint, Joint, JointGuess]);
    let work =
        |tr: &brachia_run::Traverse| tr.swings.iter().map(|s| s.positive_work_j).sum::<f64>();
    eprintln!(
        "positive work: lookahead 1 {}, 2 {}",
        work(&alone),
        work(&ahead)
    );
    assert!(
        work(&ahead) < 0.9 * work(&alone),
        "lookahead 2: {} J, 1: {} J",
        work(&ahead),
        work(&alone)
    );

    let free = run(2, Some("free"));
    match &free.status {
        TraverseStatus::CaptureMissed { swing, bar, .. } => assert_eq!((*swing, *bar), (1, 2)),
        other => panic!("free switch states: expected a miss at bar 2, got {other}"),
    }
}
