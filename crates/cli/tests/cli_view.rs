//! `brachia view DIR`: the page of a run folder, written beside its files; bad folders refused (exit 2).

mod common;

use common::{brachia, folder_page_data, page_data, run_ok, snapshot, tracking_plan, view};
use std::path::Path;

#[test]
fn plan_writes_view_and_view_rewrites_it_touching_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let out = tracking_plan(dir.path(), "plan", &[]);
    let page = std::fs::read_to_string(out.join("view.html")).unwrap();
    assert!(!page.contains("http://") && !page.contains("https://"));
    let d = page_data(&page);
    assert_eq!(d["kind"], "plan");
    let t = d["t"].as_array().unwrap();
    let q = d["q"].as_array().unwrap();
    assert_eq!(t.len(), q.len());
    assert_eq!(t[0].as_f64(), Some(0.0));
    let swing = d["t"][t.len() - 1].as_f64().unwrap();
    assert!(
        swing > 1.0 && t.len() as f64 > swing / 0.0101,
        "{} samples",
        t.len()
    );
    // the hand at the last sample is on the target bar
    let lengths: Vec<f64> = serde_json::from_value(d["robot"]["lengths"].clone()).unwrap();
    let qe: Vec<f64> = serde_json::from_value(q[q.len() - 1].clone()).unwrap();
    let (mut th, mut x, mut y) = (0.0, 0.0, 0.0);
    for (qi, l) in qe.iter().zip(&lengths) {
        th += qi;
        x += th.cos() * l;
        y += th.sin() * l;
    }
    let target: Vec<f64> = serde_json::from_value(d["target"].clone()).unwrap();
    assert!(
        (x - target[0]).hypot(y - target[1]) < 2e-3,
        "hand ({x}, {y})"
    );

    // brachia view rewrites the page; every other file stays as it was
    std::fs::remove_file(out.join("view.html")).unwrap();
    let before = snapshot(&out);
    run_ok(brachia().arg("view").arg(&out));
    let mut after = snapshot(&out);
    // the manifest lists the new page with its own stamp; every other file is byte for byte the same
    let listed = |files: &[(String, Vec<u8>)]| -> Vec<String> {
        let m = &files.iter().find(|(n, _)| n == ".brachia-run").unwrap().1;
        String::from_utf8_lossy(m)
            .lines()
            .filter(|l| !l.ends_with(" view.html"))
            .map(String::from)
            .collect()
    };
    assert_eq!(listed(&before), listed(&after));
    let mut before = before;
    before.retain(|(n, _)| n != ".brachia-run");
    after.retain(|(n, _)| n != "view.html" && n != ".brachia-run");
    assert_eq!(before, after);
    // the same swing as the page the run wrote (read back from the CSV's printed digits)
    let again = folder_page_data(&out);
    assert_eq!(again["kind"], "plan");
    let ta = again["t"].as_array().unwrap();
    assert_eq!(ta.len(), t.len());
    for (x, y) in ta.iter().zip(t) {
        assert!(
            (x.as_f64().unwrap() - y.as_f64().unwrap()).abs() < 1e-5,
            "{x} {y}"
        );
    }
    let (a, b) = (again["q"].as_array().unwrap(), q);
    assert_eq!(a.len(), b.len());
    for (ra, rb) in a.iter().zip(b) {
        for (x, y) in ra.as_array().unwrap().iter().zip(rb.as_array().unwrap()) {
            assert!((x.as_f64().unwrap() - y.as_f64().unwrap()).abs() < 1e-4);
        }
    }
    let manifest = std::fs::read_to_string(out.join(".brachia-run")).unwrap();
    assert!(manifest.lines().any(|l| l.ends_with(" view.html")));
}

#[test]
fn no_view_leaves_the_page_out() {
    let dir = tempfile::tempdir().unwrap();
    let out = tracking_plan(dir.path(), "plan", &["--no-view"]);
    assert!(!out.join("view.html").exists());
    assert!(out.join("trajectory.csv").is_file());
}

#[test]
fn bad_folders_are_refused_with_exit_2_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    // not a folder
    let (code, err) = view(&dir.path().join("nowhere"));
    assert_eq!(code, Some(2));
    assert!(err.contains("nowhere"));
    // a folder that is no run folder
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let (code, err) = view(&empty);
    assert_eq!(code, Some(2));
    assert!(
        err.contains("closed_loop.csv") && err.contains("trajectory.csv"),
        "{err}"
    );
    assert!(std::fs::read_dir(&empty).unwrap().next().is_none());
    // a plan folder missing its report, and one with a tampered value
    let out = tracking_plan(dir.path(), "plan", &["--no-view"]);
    let report = std::fs::read(out.join("report.json")).unwrap();
    std::fs::remove_file(out.join("report.json")).unwrap();
    let (code, err) = view(&out);
    assert_eq!(code, Some(2));
    assert!(err.contains("report.json"), "{err}");
    std::fs::write(out.join("report.json"), report).unwrap();
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let mut lines: Vec<String> = csv.lines().map(String::from).collect();
    let mut cells: Vec<&str> = lines[4].split(',').collect();
    cells[2] = "inf";
    lines[4] = cells.join(",");
    std::fs::write(out.join("trajectory.csv"), lines.join("\n") + "\n").unwrap();
    let before = snapshot(&out);
    let (code, err) = view(&out);
    assert_eq!(code, Some(2));
    assert!(
        err.contains("trajectory.csv") && err.contains("line 5"),
        "{err}"
    );
    assert_eq!(snapshot(&out), before);
}

/// A three-bar ladder for the paper's robot (two swings, one per hand).
fn ladder(dir: &Path) -> std::path::PathBuf {
    let p = dir.join("ladder.toml");
    let params = common::root().join("params/paper.toml");
    std::fs::write(
        &p,
        format!(
            "params = {:?}\n[ladder]\nbars = [{{ x = 0.0, y = 0.0 }}, {{ x = 1.0, y = 0.0 }}, \
             {{ x = 2.0, y = 0.0 }}]\n[planner]\nswing_time = \"auto\"\nknot_dt = 0.03\n\
             transcription = \"multiple-shooting\"\n[planner.bounds]\nqd_end_max = 1.0\n\
             [solver]\nbackend = \"ocp\"\n",
            params.display().to_string()
        ),
    )
    .unwrap();
    p
}

#[test]
fn traverse_and_simulate_write_their_pages_and_view_reads_their_folders_back() {
    let dir = tempfile::tempdir().unwrap();
    // a traverse: the whole ladder in the world frame, the chain re-rooted at the grip switch
    let out = dir.path().join("traverse");
    run_ok(
        brachia()
            .args(["traverse", "--scenario"])
            .arg(ladder(dir.path()))
            .arg("--out")
            .arg(&out),
    );
    let d = folder_page_data(&out);
    assert_eq!(d["kind"], "traverse");
    assert_eq!(d["bars"].as_array().unwrap().len(), 3);
    let hold: Vec<u8> = serde_json::from_value(d["hold"].clone()).unwrap();
    assert_eq!((hold[0], hold[hold.len() - 1]), (0, 1));
    let switches = d["switches"].as_array().unwrap();
    assert_eq!(switches.len(), 2);
    assert!(switches[0]["text"]
        .as_str()
        .unwrap()
        .contains("caught bar 1"));
    // the last sample's free hand (the last point of the chain that holds) is on the last bar
    let pts = d["pts"].as_array().unwrap();
    let last: Vec<f64> = serde_json::from_value(pts[pts.len() - 1].clone()).unwrap();
    let hand = &last[last.len() - 2..];
    assert!((hand[0] - 2.0).hypot(hand[1]) < 0.02, "{hand:?}");
    // every row for the tooltips, one per 10 ms for the drawing
    let rows = std::fs::read_to_string(out.join("traverse.csv")).unwrap();
    assert_eq!(
        d["full"]["t"].as_array().unwrap().len(),
        rows.lines().count() - 2
    );
    // brachia view draws the same page from the folder
    std::fs::remove_file(out.join("view.html")).unwrap();
    run_ok(brachia().arg("view").arg(&out));
    let again = folder_page_data(&out);
    assert_eq!(again["t"], d["t"]);
    assert_eq!(again["pts"], d["pts"]);
    // a tampered traverse.csv is refused naming the file, the line and the column; nothing written
    let mut lines: Vec<String> = rows.lines().map(String::from).collect();
    let head: Vec<&str> = lines[1].split(',').collect();
    let col = head.iter().position(|c| *c == "holding_hand").unwrap();
    let mut cells: Vec<String> = lines[7].split(',').map(String::from).collect();
    cells[col] = "2".into();
    lines[7] = cells.join(",");
    std::fs::write(out.join("traverse.csv"), lines.join("\n") + "\n").unwrap();
    let before = snapshot(&out);
    let (code, err) = view(&out);
    assert_eq!(code, Some(2));
    assert!(
        err.contains("traverse.csv") && err.contains("line 8, holding_hand"),
        "{err}"
    );
    assert_eq!(snapshot(&out), before);

    // a passive simulation: its robot beside it, the mechanical energy plotted
    let sim = dir.path().join("simulate");
    run_ok(
        brachia()
            .args([
                "simulate",
                "--params",
                "params/paper.toml",
                "--q0=-1.2,0.5,0.3,0.2",
                "--duration",
                "1.0",
                "--out",
            ])
            .arg(&sim),
    );
    assert!(sim.join("params.toml").is_file());
    let d = folder_page_data(&sim);
    assert_eq!(d["kind"], "simulate");
    assert!(d["target"].is_null());
    let e: Vec<f64> = serde_json::from_value(d["full"]["mechanical"].clone()).unwrap();
    assert_eq!(e.len(), 1001);
    assert!(e.iter().all(|x| (x - e[0]).abs() < 1e-4));
    std::fs::remove_file(sim.join("params.toml")).unwrap();
    let (code, err) = view(&sim);
    assert_eq!(code, Some(2));
    assert!(err.contains("params.toml"), "{err}");
}

#[test]
fn a_track_folder_without_its_plan_is_drawn_from_its_log() {
    let dir = tempfile::tempdir().unwrap();
    let plan = tracking_plan(dir.path(), "plan", &[]);
    let out = dir.path().join("track");
    run_ok(
        brachia()
            .args([
                "track",
                "--no-view",
                "--plant",
                "model",
                "--scenario",
                "scenarios/tracking.toml",
                "--plan",
            ])
            .arg(&plan)
            .arg("--out")
            .arg(&out),
    );
    assert!(!out.join("plan").exists() && !out.join("view.html").exists());
    run_ok(brachia().arg("view").arg(&out));
    let d = folder_page_data(&out);
    assert_eq!(d["kind"], "track");
    assert!(d["notes"][0].as_str().unwrap().contains("holds no plan"));
    // the link lengths found from the log are the plan's robot's (0.355 m each)
    let lengths: Vec<f64> = serde_json::from_value(d["robot"]["lengths"].clone()).unwrap();
    assert!(
        lengths.iter().all(|l| (l - 0.355).abs() < 1e-4),
        "{lengths:?}"
    );
    // the controller's step time of every row, from closed_loop.csv
    let us: Vec<f64> = serde_json::from_value(d["full"]["control_us"].clone()).unwrap();
    assert!(us.len() > 2000 && us[..us.len() - 1].iter().all(|&x| x > 0.0));
}
