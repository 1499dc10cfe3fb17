//! No wrong answer with exit 0: `brachia track --plan` tracks only a plan made for the scenario's own
//! task and whose files say what a plan says, success is the plant's hand at the bar, and a miss is a
//! failure (exit 1).

mod common;

use common::{brachia, report, root};
use std::path::Path;
use std::process::Output;

const TRACKING: &str = "scenarios/tracking.toml";

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).to_string()
}

/// scenarios/tracking.toml with its robot path made absolute, `edit` applied (old => new), into `dir`.
fn scenario(dir: &Path, name: &str, edit: Option<(&str, &str)>) -> std::path::PathBuf {
    let mut text = std::fs::read_to_string(root().join(TRACKING))
        .unwrap()
        .replace(
            "params = \"../params/paper.toml\"",
            &format!("params = {:?}", root().join("params/paper.toml")),
        );
    if let Some((old, new)) = edit {
        assert!(text.contains(old), "{old}");
        text = text.replacen(old, new, 1);
    }
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn track(scenario: &Path, plan: &Path, out: &Path) -> Output {
    brachia()
        .arg("track")
        .arg("--scenario")
        .arg(scenario)
        .arg("--plan")
        .arg(plan)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        if e.file_type().unwrap().is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// `track --plan DIR --scenario S` with a plan made for another bar exited 0, its report naming S's
/// target with `reaches_bar: true` and a 0.3 mm error while the hand ended at the plan's bar: only the
/// start state was compared, and the error was measured to the plan's end point. Now every field the
/// plan and the scenario share must agree (refused with exit 2 before any work, naming the field and
/// both values), and a plan that does belong to the scenario is tracked and measured against the bar
/// (at the capture: the first row within 2 cm of it, no faster than 0.5 m/s).
#[test]
fn a_plan_for_another_task_is_refused_and_success_is_measured_at_the_bar() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan");
    let o = brachia()
        .args(["plan", "--scenario", TRACKING, "--out"])
        .arg(&plan)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));

    let cases = [
        (
            "other-bar.toml",
            ("target = [0.8, 0.0]", "target = [0.75, 0.05]"),
            vec!["task.target", "[0.75, 0.05]", "another bar"],
        ),
        (
            "obstacle.toml",
            (
                "target = [0.8, 0.0]",
                "target = [0.8, 0.0]\nobstacles = [{ center = [0.0, 2.0], radius = 0.05 }]",
            ),
            vec!["task.obstacles", "(count)", "= 0", "plan/scenario.toml"],
        ),
        (
            "bounds.toml",
            ("[solver]", "[planner.bounds]\nqd_max = 14.0\n\n[solver]"),
            vec!["planner.bounds.qd_max", "14", "15"],
        ),
    ];
    for (name, edit, words) in cases {
        let sc = scenario(dir.path(), name, Some(edit));
        let out = dir.path().join(format!("out-{name}"));
        let o = track(&sc, &plan, &out);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {e}");
        for w in words {
            assert!(e.contains(w), "{name}: `{w}` not in {e}");
        }
        assert_eq!(e.trim().lines().count(), 1, "{e}");
        assert!(!out.exists());
    }

    // a plan folder without its scenario.toml cannot be checked: refused
    let bare = dir.path().join("bare");
    copy_dir(&plan, &bare);
    std::fs::remove_file(bare.join("scenario.toml")).unwrap();
    let o = track(&root().join(TRACKING), &bare, &dir.path().join("out-bare"));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("scenario.toml"), "{}", stderr(&o));

    // the plan's own scenario, its trajectory.csv saved by a spreadsheet with a byte-order mark: read
    // as the same plan, tracked, and measured against the bar
    let bom = dir.path().join("bom");
    copy_dir(&plan, &bom);
    let t = std::fs::read(bom.join("trajectory.csv")).unwrap();
    std::fs::write(
        bom.join("trajectory.csv"),
        [&b"\xef\xbb\xbf"[..], &t].concat(),
    )
    .unwrap();
    let out = dir.path().join("tracked");
    let o = track(&root().join(TRACKING), &bom, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    let bar = r["bar_error_m"].as_f64().unwrap();
    assert!(bar < 0.02 && r["reaches_bar"] == true, "{r}");
    // the measure is the plant's hand against the bar at the capture (its row of closed_loop.csv),
    // within the swing; no earlier row is within 2 cm and slow, and the first rows are far away
    let csv = std::fs::read_to_string(out.join("closed_loop.csv")).unwrap();
    let swing_end = r["plan"]["swing_time_s"].as_f64().unwrap();
    let t_cap = r["capture_t_s"].as_f64().unwrap();
    assert!(
        t_cap > 0.5 * swing_end && t_cap <= swing_end + 1e-6,
        "{t_cap} of {swing_end}"
    );
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(2)
        .map(|l| {
            l.split(',')
                .map(|v| v.parse().unwrap())
                .collect::<Vec<f64>>()
        })
        .collect();
    let row = rows
        .iter()
        .find(|r| (r[0] - t_cap).abs() < 1e-6)
        .expect("the capture's row");
    let (x, y) = (row[12], row[13]);
    let d = (x - 0.8).hypot(y);
    assert!((d - bar).abs() < 1e-6, "hand {x}, {y}: {d} vs {bar}");
    assert!((rows[0][12] - 0.8).hypot(rows[0][13]) > 0.5);
}

/// A plan folder whose content lies: times 0, 1e-300, ...; a NaN or a moved hand column; a trajectory
/// shorter than its report's swing time. Each was tracked with `reaches_bar: true`; each is refused
/// with exit 2 naming the file, the row and the column.
#[test]
fn a_plan_folder_whose_content_lies_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let plan = root().join("crates/cli/tests/hostile/runs/plan");
    let orig = std::fs::read_to_string(plan.join("trajectory.csv")).unwrap();
    let lines: Vec<&str> = orig.lines().collect();
    let edit = |k: usize, col: usize, v: &str| -> String {
        let mut ls: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        let mut cells: Vec<String> = ls[k].split(',').map(String::from).collect();
        cells[col] = v.into();
        ls[k] = cells.join(",");
        ls.join("\n") + "\n"
    };
    let tiny: String = lines
        .iter()
        .enumerate()
        .map(|(k, l)| match (k, l.split_once(',')) {
            (0 | 1, _) | (_, None) => l.to_string(),
            (_, Some((_, rest))) => format!("{:e},{rest}", (k - 2) as f64 * 1e-300),
        })
        .collect::<Vec<_>>()
        .join("\n");
    let cases = [
        ("tiny", tiny, vec!["trajectory.csv", "line 4, t", "apart"]),
        ("ee-nan", edit(4, 12, "NaN"), vec!["line 5, ee_x", "finite"]),
        (
            "ee-off",
            edit(4, 13, "0.5"),
            vec!["line 5, ee_x/ee_y", "forward kinematics"],
        ),
        (
            "short",
            lines[..lines.len() - 5].join("\n"),
            vec!["report.json", "swing_time_s", "lasts"],
        ),
    ];
    for (name, text, words) in cases {
        let d = dir.path().join(name);
        copy_dir(&plan, &d);
        std::fs::write(d.join("trajectory.csv"), text).unwrap();
        let out = dir.path().join(format!("out-{name}"));
        let o = track(&root().join(TRACKING), &d, &out);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {e}");
        for w in words {
            assert!(e.contains(w), "{name}: `{w}` not in {e}");
        }
        assert!(!out.exists());
    }
}
