//! `brachia robot import` and `export` write their file through a locked staging folder beside it
//! (`.NAME.partial-PID-K`, docs/limits.md): killed outright (`kill -9`) at any moment, a run leaves at
//! most such a folder, which the next run removes; a folder whose owner is alive, or a folder of that
//! name without brachia's lock file, is never removed.

mod common;

use brachia_experiments::staging;
use common::brachia;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The environment variable that turns [`stage_holder`] into a process holding a staging folder.
const HOLD: &str = "BRACHIA_TEST_HOLD_STAGE_IN";

/// Not a test of its own: run by [`a_dead_owners_folder_is_removed_and_a_live_ones_kept`] as a child
/// process (this test binary again) that creates a staging folder in `$HOLD`, says so on stdout and
/// waits to be killed.
#[test]
#[ignore = "a child process of another test"]
fn stage_holder() {
    let Some(dir) = std::env::var_os(HOLD) else {
        return;
    };
    let stage = staging::create_unique(Path::new(&dir), ".robot.urdf.partial-").unwrap();
    println!("holding {}", stage.display());
    std::thread::sleep(Duration::from_secs(120));
}

/// Start this test binary as a [`stage_holder`] in `dir`; returns it and the folder it holds.
fn start_holder(dir: &Path) -> (std::process::Child, PathBuf) {
    let mut c = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "stage_holder", "--ignored", "--nocapture"])
        .env(HOLD, dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut out = c.stdout.take().unwrap();
    let mut text = String::new();
    let start = Instant::now();
    let mut buf = [0u8; 256];
    while !text.contains('\n') || !text.contains("holding ") {
        use std::io::Read;
        let n = out.read(&mut buf).unwrap();
        assert!(n > 0 && start.elapsed() < Duration::from_secs(30), "{text}");
        text.push_str(&String::from_utf8_lossy(&buf[..n]));
    }
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("holding "))
        .unwrap()
        .trim()
        .to_string();
    (c, PathBuf::from(line))
}

fn stages(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .contains(".partial")
        })
        .collect();
    v.sort();
    v
}

fn export(out: &Path) -> Command {
    let mut c = brachia();
    c.args([
        "robot",
        "export",
        "--params",
        "params/paper.toml",
        "--format",
        "urdf",
        "--force",
        "--out",
    ])
    .arg(out);
    c
}

#[test]
fn a_dead_owners_folder_is_removed_and_a_live_ones_kept() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("robot.urdf");
    // a folder of the user's with a staging name and no lock file
    let user = d.path().join(".robot.urdf.partial-4000000-0");
    std::fs::create_dir(&user).unwrap();
    std::fs::write(user.join("mine.txt"), b"mine").unwrap();
    // a process holding one, alive while brachia runs
    let (mut live, live_stage) = start_holder(d.path());
    // a process holding a staging folder, killed with SIGKILL: its folder stays, its lock dies
    let (mut dead, dead_stage) = start_holder(d.path());
    dead.kill().unwrap();
    dead.wait().unwrap();
    assert!(dead_stage.join(staging::STAGE_LOCK).is_file());
    assert!(live_stage.join(staging::STAGE_LOCK).is_file());
    // brachia itself killed with SIGKILL at several points of its run
    for delay_ms in [0u64, 1, 2, 4, 8, 16] {
        let mut c = export(&out)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(delay_ms));
        let _ = c.kill();
        c.wait().unwrap();
    }
    let o = export(&out).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read_to_string(&out).unwrap().contains("<robot"));
    let left = stages(d.path());
    assert_eq!(
        left,
        {
            let mut v = vec![user.clone(), live_stage.clone()];
            v.sort();
            v
        },
        "the dead owner's folder {} is removed, the live one's and the user's kept",
        dead_stage.display()
    );
    assert_eq!(std::fs::read(user.join("mine.txt")).unwrap(), b"mine");
    live.kill().unwrap();
    live.wait().unwrap();
    // its owner dead now: the next run removes it too
    let o = export(&out).output().unwrap();
    assert!(o.status.success());
    assert_eq!(stages(d.path()), vec![user]);
}

#[test]
fn import_writes_through_a_locked_stage_and_leaves_none() {
    let d = tempfile::tempdir().unwrap();
    let urdf = d.path().join("robot.urdf");
    assert!(export(&urdf).status().unwrap().success());
    let toml = d.path().join("robot.toml");
    let (mut dead, dead_stage) = {
        // a dead holder's folder named for robot.toml
        let hold = d.path().join("hold");
        std::fs::create_dir(&hold).unwrap();
        let (c, s) = start_holder(&hold);
        (c, s)
    };
    dead.kill().unwrap();
    dead.wait().unwrap();
    let moved = d.path().join(".robot.toml.partial-1-0");
    std::fs::rename(&dead_stage, &moved).unwrap();
    let o = brachia()
        .args(["robot", "import"])
        .arg(&urdf)
        .args(["--grip", "grip", "--tip", "tip", "--out"])
        .arg(&toml)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(brachia::Robot::from_toml_file(&toml).is_ok());
    assert!(stages(d.path()).is_empty(), "{:?}", stages(d.path()));
}
