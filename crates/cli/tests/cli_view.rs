//! `brachia view DIR`: the page of a run folder, written beside its files; bad folders refused (exit 2).

mod common;

use common::brachia;
use std::path::Path;

/// Every file under `dir` with its contents, sorted.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        if e.file_type().unwrap().is_file() {
            out.push((
                e.file_name().to_string_lossy().to_string(),
                std::fs::read(e.path()).unwrap(),
            ));
        }
    }
    out.sort();
    out
}

/// The JSON embedded in a page.
fn page_data(page: &str) -> serde_json::Value {
    let start = page.find("id=\"brachia-data\">").unwrap() + "id=\"brachia-data\">".len();
    let end = start + page[start..].find("</script>").unwrap();
    serde_json::from_str(&page[start..end]).unwrap()
}

#[test]
fn plan_writes_view_and_view_rewrites_it_touching_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan");
    let o = brachia()
        .args(["plan", "--scenario", "scenarios/tracking.toml", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
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
    let o = brachia().arg("view").arg(&out).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
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
    let again = page_data(&std::fs::read_to_string(out.join("view.html")).unwrap());
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
    let out = dir.path().join("plan");
    let o = brachia()
        .args([
            "plan",
            "--no-view",
            "--scenario",
            "scenarios/tracking.toml",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!out.join("view.html").exists());
    assert!(out.join("trajectory.csv").is_file());
}

#[test]
fn bad_folders_are_refused_with_exit_2_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    // not a folder
    let o = brachia()
        .arg("view")
        .arg(dir.path().join("nowhere"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nowhere"));
    // a folder that is no run folder
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let o = brachia().arg("view").arg(&empty).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(
        err.contains("closed_loop.csv") && err.contains("trajectory.csv"),
        "{err}"
    );
    assert!(std::fs::read_dir(&empty).unwrap().next().is_none());
    // a plan folder missing its report, and one with a tampered value
    let out = dir.path().join("plan");
    let o = brachia()
        .args([
            "plan",
            "--no-view",
            "--scenario",
            "scenarios/tracking.toml",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success());
    let report = std::fs::read(out.join("report.json")).unwrap();
    std::fs::remove_file(out.join("report.json")).unwrap();
    let o = brachia().arg("view").arg(&out).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("report.json"));
    std::fs::write(out.join("report.json"), report).unwrap();
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let mut lines: Vec<String> = csv.lines().map(String::from).collect();
    let mut cells: Vec<&str> = lines[4].split(',').collect();
    cells[2] = "inf";
    lines[4] = cells.join(",");
    std::fs::write(out.join("trajectory.csv"), lines.join("\n") + "\n").unwrap();
    let before = snapshot(&out);
    let o = brachia().arg("view").arg(&out).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(
        err.contains("trajectory.csv") && err.contains("line 5"),
        "{err}"
    );
    assert_eq!(snapshot(&out), before);
}
