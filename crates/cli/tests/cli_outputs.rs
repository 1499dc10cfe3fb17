//! Outputs that never destroy: `reproduce --out D` must not delete the user's own `figures/` or
//! `tracking/` in D, nor an interrupted reproduce leave the old results half-removed. A run writes into a
//! staging folder, renames it into place, and keeps every file its manifest does not list; these tests
//! use the fast `simulate` (and an interrupted `reproduce`).

mod common;

use common::brachia;
use std::path::Path;

fn simulate(out: &Path, extra: &[&str]) -> std::process::Output {
    brachia()
        .args([
            "simulate",
            "--params",
            "params/paper.toml",
            "--q0=-2.35,0,-1.55,0",
            "--duration",
            "0.2",
            "--out",
        ])
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

fn hidden_entries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with('.'))
        .collect()
}

#[test]
fn a_rerun_replaces_only_what_brachia_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = simulate(&out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let manifest = std::fs::read_to_string(out.join(".brachia-run")).unwrap();
    assert!(manifest.contains("trajectory.csv") && manifest.contains("report.json"));
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    std::fs::create_dir_all(out.join("analysis")).unwrap();
    std::fs::write(out.join("analysis/plot.py"), "print(1)").unwrap();
    let o = simulate(&out, &["--dt", "0.002"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "mine"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("analysis/plot.py")).unwrap(),
        "print(1)"
    );
    let rep = common::report(&out);
    assert_eq!(rep["dt_s"], 0.002);
    assert!(
        hidden_entries(dir.path()).is_empty(),
        "{:?}",
        hidden_entries(dir.path())
    );
}

#[test]
fn force_writes_into_a_users_folder_and_keeps_its_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mine");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("report.json"), "my own report").unwrap();
    std::fs::write(out.join("data.csv"), "1,2").unwrap();
    let o = simulate(&out, &[]);
    assert_eq!(o.status.code(), Some(2), "refused without --force");
    let o = simulate(&out, &["--force"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(out.join("data.csv")).unwrap(),
        "1,2"
    );
    // a name the run also writes: the user's file is kept beside it
    assert_eq!(
        std::fs::read_to_string(out.join("report.json.user")).unwrap(),
        "my own report"
    );
    assert!(common::report(&out)["command"] == "simulate");
}

#[test]
fn a_stale_staging_folder_of_a_dead_run_is_removed() {
    let dir = tempfile::tempdir().unwrap();
    let stale = dir.path().join(".run.partial-4000000-0");
    std::fs::create_dir_all(&stale).unwrap();
    std::fs::write(stale.join(".brachia-run"), "# brachia run folder\n").unwrap();
    let o = simulate(&dir.path().join("run"), &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!stale.exists());
}

#[test]
fn an_interrupted_reproduce_leaves_the_previous_results_intact() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    std::fs::create_dir_all(out.join("figures")).unwrap();
    std::fs::write(
        out.join(".brachia-run"),
        "# brachia run folder\nREPORT.md\nfigures/fig5.png\n",
    )
    .unwrap();
    std::fs::write(out.join("REPORT.md"), "old report").unwrap();
    std::fs::write(out.join("figures/fig5.png"), "old figure").unwrap();
    let mut child = brachia()
        .args(["reproduce", "--quick", "--no-progress", "--out"])
        .arg(&out)
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let _ = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
    let st = child.wait().unwrap();
    assert!(!st.success());
    assert_eq!(
        std::fs::read_to_string(out.join("REPORT.md")).unwrap(),
        "old report"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("figures/fig5.png")).unwrap(),
        "old figure"
    );
    let entries: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    assert_eq!(entries.len(), 3, "{entries:?}");
}
