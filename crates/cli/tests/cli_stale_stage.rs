//! A run killed outright (SIGKILL) leaves its hidden staging folder `.NAME.partial-PID-K` next to
//! `--out`. A reproduction's staging folder holds whole run folders (each with its own manifest) and a
//! benchmark's lists its files before writing them. The next run into the same place clears such a
//! folder of every file a manifest in it proves brachia wrote, and of nothing else: a file it cannot
//! prove (a user's) stays, and so does the folder holding it.

mod common;

use common::brachia;
use std::path::Path;

fn simulate(out: &Path) {
    let o = brachia()
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
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A staging folder as a reproduction killed after its first experiments leaves it: an empty top
/// manifest and complete run folders below it.
fn killed_reproduction(dir: &Path, pid: u32) -> std::path::PathBuf {
    let stage = dir.join(format!(".rep.partial-{pid}-0"));
    std::fs::create_dir_all(&stage).unwrap();
    std::fs::write(
        stage.join(".brachia-run"),
        "# brachia run-folder manifest, schema 1\n",
    )
    .unwrap();
    simulate(&stage.join("tracking"));
    simulate(&stage.join("robustness/mpc"));
    stage
}

#[test]
fn a_killed_reproductions_run_folders_are_cleared_by_the_next_run() {
    let dir = tempfile::tempdir().unwrap();
    // a process id above the kernel's limit (4194304): no such process runs
    let stage = killed_reproduction(dir.path(), 4_999_999);
    simulate(&dir.path().join("rep"));
    assert!(!stage.exists(), "the staging folder is left");
    assert!(dir.path().join("rep/trajectory.csv").is_file());
}

#[test]
fn a_file_no_manifest_proves_stays_with_its_folders() {
    let dir = tempfile::tempdir().unwrap();
    let stage = killed_reproduction(dir.path(), 4_999_998);
    std::fs::write(stage.join("robustness/mine.txt"), "the user's").unwrap();
    // a listed file changed since: not provably brachia's any more
    let edited = stage.join("tracking/report.json");
    std::fs::write(&edited, "edited").unwrap();
    simulate(&dir.path().join("rep"));
    assert_eq!(
        std::fs::read_to_string(stage.join("robustness/mine.txt")).unwrap(),
        "the user's"
    );
    assert_eq!(std::fs::read_to_string(&edited).unwrap(), "edited");
    // the proven files went: the complete run folder below robustness/ is gone
    assert!(!stage.join("robustness/mpc").exists());
    assert!(!stage.join("tracking/trajectory.csv").exists());
}

#[test]
fn a_staging_folder_of_a_running_process_is_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    // this test's own process is alive
    let stage = killed_reproduction(dir.path(), std::process::id());
    simulate(&dir.path().join("rep"));
    assert!(stage.join("tracking/trajectory.csv").is_file());
    assert!(stage.join("robustness/mpc/report.json").is_file());
}
