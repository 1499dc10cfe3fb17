//! Ladders: a 3-link and a 5-link robot traverse a short even ladder on the model plant (plan
//! every swing from the state the last left, MPC, capture, grip switch, re-rooted swing), and bars out
//! of reach or too close are refused before any planning, naming the bar.
//!
//! Conventions: world frame x right, y up, m; rad; SI units. Coarse knots (0.04 s) keep each traverse
//! to a few seconds in release.

use brachia_run::{run_traverse, LadderScenario, PlanSource};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A 5-link robot of uniform 0.25 m rods (span 1.25 m); link 1 a little heavier than link 5, so the
/// re-rooted chain differs from the original.
const FIVE_LINK: &str = r#"
name = "five-link"
gravity = 9.81
[[links]]
length = 0.25
mass = 0.45
com = 0.12
inertia = 0.0025
[[links]]
length = 0.25
mass = 0.4
com = 0.125
inertia = 0.002
[[links]]
length = 0.25
mass = 0.4
com = 0.125
inertia = 0.002
[[links]]
length = 0.25
mass = 0.4
com = 0.125
inertia = 0.002
[[links]]
length = 0.25
mass = 0.35
com = 0.13
inertia = 0.002
[actuators]
tau_min = [-5.0, -5.0, -5.0, -5.0]
tau_max = [5.0, 5.0, 5.0, 5.0]
"#;

fn write_scenario(dir: &Path, params: &Path, bars: &[(f64, f64)]) -> PathBuf {
    let bars: Vec<String> = bars
        .iter()
        .map(|(x, y)| format!("{{ x = {x}, y = {y} }}"))
        .collect();
    let text = format!(
        "params = {:?}\n[ladder]\nbars = [{}]\n[planner]\nswing_time = \"auto\"\nknot_dt = 0.04\n",
        params.display().to_string(),
        bars.join(", ")
    );
    let p = dir.join("ladder.toml");
    std::fs::write(&p, text).unwrap();
    p
}

fn traverse(params: &Path, bars: &[(f64, f64)], links: usize) {
    let dir = tempfile::tempdir().unwrap();
    let path = write_scenario(dir.path(), params, bars);
    let ll = LadderScenario::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(ll.robot.n(), links);
    let tr = run_traverse(&ll).unwrap();
    assert!(
        tr.status.completed(),
        "{links} links: {} ({:?})",
        tr.status,
        tr.swings
    );
    assert_eq!(tr.swings.len(), bars.len() - 1);
    for (k, s) in tr.swings.iter().enumerate() {
        assert!(s.captured);
        assert_eq!(s.holding_hand, k % 2, "the hands alternate");
        assert!(s.capture_error_m < 0.02, "swing {k}: {s:?}");
        assert!(s.switch_residual_m_s < 0.1, "swing {k}: {s:?}");
        assert!(s.energy_j.is_finite() && s.positive_work_j >= s.energy_j.max(0.0) - 1e-9);
        // the grip of swing k is the bar caught by swing k - 1, within the capture radius
        let b = ll.scenario.ladder.bars[k];
        assert!((s.grip[0] - b.x).hypot(s.grip[1] - b.y) < 0.02 + 1e-12);
    }
    // the world CSV is continuous across the switches: the hand that lets go stays on its bar
    let csv = tr.to_csv();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    assert_eq!(header.last(), Some(&"hand_b_y"));
    for k in 1..tr.swings.len() {
        let prev = tr.world_joints(k - 1, tr.logs[k - 1].len() - 1);
        let next = tr.world_joints(k, 0);
        for (a, b) in prev.iter().zip(&next) {
            assert!(
                (a[0] - b[0]).hypot(a[1] - b[1]) < 1e-9,
                "swing {k}: {a:?} vs {b:?}"
            );
        }
    }
    let r = tr.report(&ll);
    assert_eq!(r["completed"], true);
    assert_eq!(r["totals"]["bars_caught"], bars.len() - 1);
}

#[test]
fn a_three_link_robot_traverses_a_short_even_ladder_on_the_model_plant() {
    traverse(
        &root().join("params/three-link.toml"),
        &[(0.0, 0.0), (0.8, 0.0), (1.6, 0.0)],
        3,
    );
}

#[test]
fn a_five_link_robot_traverses_a_short_even_ladder_on_the_model_plant() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("five-link.toml");
    std::fs::write(&params, FIVE_LINK).unwrap();
    traverse(&params, &[(0.0, 0.0), (0.8, 0.0), (1.6, 0.0)], 5);
}

/// The first `bars` bars of `scenarios/NAME` (its robot, planner, solver and rest condition unchanged)
/// with `ladder.lookahead` set, the params path made absolute, written into `dir`.
fn ladder_cut(dir: &Path, name: &str, bars: usize, lookahead: i64) -> PathBuf {
    let text = std::fs::read_to_string(root().join("scenarios").join(name)).unwrap();
    let mut v: toml::Table = text.parse().unwrap();
    let params = root()
        .join("scenarios")
        .join(v["params"].as_str().unwrap())
        .display()
        .to_string();
    v.insert("params".into(), toml::Value::String(params));
    let ladder = v["ladder"].as_table_mut().unwrap();
    ladder["bars"].as_array_mut().unwrap().truncate(bars);
    ladder.insert("lookahead".into(), toml::Value::Integer(lookahead));
    let p = dir.join(name);
    std::fs::write(&p, toml::to_string(&v).unwrap()).unwrap();
    p
}

/// The first three bars of `scenarios/NAME`, each swing planned alone.
fn three_bar_cut(dir: &Path, name: &str) -> PathBuf {
    ladder_cut(dir, name, 3, 1)
}

/// A 3-bar cut of a ladder completes with every capture within 2 cm, the chain nearly at
/// rest at every switch (the rest condition `planner.bounds.qd_end_max`), energy reported per swing.
fn three_bar_cut_completes(name: &str) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let ll =
        LadderScenario::load(&three_bar_cut(dir.path(), name)).unwrap_or_else(|e| panic!("{e}"));
    let rest = ll
        .scenario
        .planner
        .bounds
        .qd_end_max
        .expect("a rest condition");
    assert_eq!(ll.scenario.ladder.bars.len(), 3);
    let tr = run_traverse(&ll).unwrap();
    assert!(
        tr.status.completed(),
        "{name}: {} ({:?})",
        tr.status,
        tr.swings
    );
    assert_eq!(tr.swings.len(), 2);
    let n = ll.robot.n();
    for (k, s) in tr.swings.iter().enumerate() {
        assert!(s.capture_error_m < 0.02, "{name} swing {k}: {s:?}");
        assert!(s.switch_residual_m_s < 0.1, "{name} swing {k}: {s:?}");
        assert!(s.energy_j.is_finite() && s.planned_energy_j.is_finite());
        // the tracked chain ends near rest: every joint rate within twice the planned bound
        let log = &tr.logs[k];
        let xe = log.x(log.len() - 1);
        let qd = xe[n..].iter().fold(0.0, |m: f64, v| m.max(v.abs()));
        assert!(qd < 2.0 * rest, "{name} swing {k}: end rate {qd} rad/s");
    }
    let r = tr.report(&ll);
    assert_eq!(r["totals"]["bars_caught"], 2);
    assert!(r["swings"][1]["energy_j"].as_f64().is_some());
    n
}

#[test]
fn a_three_bar_cut_of_the_even_ladder_completes_under_the_rest_condition() {
    three_bar_cut_completes("ladder-even.toml");
}

#[test]
fn a_three_bar_cut_of_the_irregular_ladder_completes_under_the_rest_condition() {
    three_bar_cut_completes("ladder-irregular.toml");
}

/// The 3- and 5-link robots on the even ladder (1 m spacing, the scenario's 30 ms knots and rest
/// condition): a 3-bar cut (one swing from each hand); the full 6-bar runs are measured by
/// `brachia traverse --scenario scenarios/ladder-even-{three,five}-link.toml` (docs/ladders.md).
#[test]
fn a_three_bar_cut_of_the_even_ladder_completes_with_three_links() {
    assert_eq!(three_bar_cut_completes("ladder-even-three-link.toml"), 3);
}

#[test]
fn a_three_bar_cut_of_the_even_ladder_completes_with_five_links() {
    assert_eq!(three_bar_cut_completes("ladder-even-five-link.toml"), 5);
}

#[test]
fn bars_out_of_reach_or_too_close_are_refused_before_planning_naming_the_bar() {
    let dir = tempfile::tempdir().unwrap();
    let params = root().join("params/paper.toml");
    // paper robot: span 1.42 m, spacing allowed in [0.355, 1.349] m
    for (bars, field, rule) in [
        (
            vec![(0.0, 0.0), (1.0, 0.0), (2.4, 0.0)],
            "ladder.bars[2]",
            "out of reach",
        ),
        (
            vec![(0.0, 0.0), (1.0, 0.0), (1.2, 0.1)],
            "ladder.bars[2]",
            "too close",
        ),
        (
            vec![(0.0, 0.0), (1.0, 1.0)],
            "ladder.bars[1]",
            "out of reach",
        ),
        (vec![(0.0, 0.0)], "ladder.bars", "between 2 and"),
    ] {
        let path = write_scenario(dir.path(), &params, &bars);
        let e = LadderScenario::load(&path).unwrap_err().to_string();
        assert!(e.contains(field) && e.contains(rule), "{bars:?}: {e}");
        assert!(e.contains("ladder.toml"), "names the file: {e}");
    }
}

/// `ladder.lookahead = 2` on a 4-bar cut of the irregular ladder: each swing but the last is the first
/// of a joint plan over two swings, re-planned at every bar; the traverse completes and its tracked
/// swings spend less positive work than with every swing planned alone (both run here; measured on the
/// whole ladder: 86.0 J -> 60.1 J, docs/ladders.md "Lookahead").
#[test]
fn planning_two_swings_ahead_completes_the_ladder_with_less_positive_work() {
    let dir = tempfile::tempdir().unwrap();
    let run = |lookahead| {
        let path = ladder_cut(dir.path(), "ladder-irregular.toml", 4, lookahead);
        let ll = LadderScenario::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ll.scenario.ladder.lookahead, lookahead as usize);
        let tr = run_traverse(&ll).unwrap();
        assert!(
            tr.status.completed(),
            "lookahead {lookahead}: {}",
            tr.status
        );
        for s in &tr.swings {
            assert!(s.captured && s.capture_error_m < 0.02, "{s:?}");
        }
        let jointly: Vec<usize> = tr.swings.iter().map(|s| s.planned_jointly).collect();
        let sources: Vec<PlanSource> = tr.swings.iter().map(|s| s.plan_source).collect();
        let work: f64 = tr.swings.iter().map(|s| s.positive_work_j).sum();
        let r = tr.report(&ll);
        assert_eq!(r["swings"][0]["planned_jointly"], jointly[0]);
        let first = if lookahead > 1 { "joint" } else { "alone" };
        assert_eq!(r["swings"][0]["plan_source"], first);
        (jointly, sources, work)
    };
    let (alone, sources, work_alone) = run(1);
    assert_eq!(alone, [1, 1, 1]);
    assert!(
        sources.iter().all(|s| *s == PlanSource::Alone),
        "{sources:?}"
    );
    let (ahead, sources, work_ahead) = run(2);
    assert_eq!(ahead, [2, 2, 1]);
    assert_eq!(sources[..2], [PlanSource::Joint, PlanSource::Joint]);
    // the last swing from the state the last joint plan left, that plan's swing its guess
    assert_eq!(sources[2], PlanSource::JointGuess);
    assert!(
        work_ahead < work_alone,
        "positive work: {work_ahead} J planning ahead, {work_alone} J alone"
    );
}

#[test]
fn a_lookahead_outside_its_range_or_without_the_riccati_backend_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for lookahead in [0, 17] {
        let path = ladder_cut(dir.path(), "ladder-even.toml", 3, lookahead);
        let e = LadderScenario::load(&path).unwrap_err().to_string();
        assert!(
            e.contains("ladder.lookahead") && e.contains("must be 1 to 16"),
            "{e}"
        );
    }
    let path = ladder_cut(dir.path(), "ladder-even.toml", 3, 2);
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("backend = \"ocp\"", "backend = \"pounce\"")
        .replace("\"multiple-shooting\"", "\"hermite-simpson\"");
    std::fs::write(&path, text).unwrap();
    let e = LadderScenario::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("ladder.lookahead") && e.contains("solver.backend"),
        "{e}"
    );
}
