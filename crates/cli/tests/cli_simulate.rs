//! The `simulate` command as a user runs it: outputs, exit codes, no partial files on bad input.

use std::path::Path;
use std::process::Command;

fn brachia() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_brachia"));
    c.current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
    c
}

#[test]
fn simulate_writes_trajectory_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let st = brachia()
        .args([
            "simulate",
            "--params",
            "params/paper.toml",
            "--q0=-2.35,0,-1.55,0",
            "--duration",
            "1",
        ])
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let csv = csv
        .strip_prefix("# brachia trajectory schema 1\n")
        .expect("the schema line");
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t,q1,q2,q3,q4,qd1,qd2,qd3,qd4,tau2,tau3,tau4,ee_x,ee_y,energy"
    );
    assert_eq!(lines.count(), 1001, "1 ms rows from 0 to 1 s inclusive");
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert!(rep["energy_drift_max_rel"].as_f64().unwrap() < 1e-6);
}

fn assert_refused(args: &[&str], needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = brachia()
        .args(args)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{args:?}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(needle),
        "stderr {err:?} should name {needle:?}"
    );
    assert!(
        !Path::new(&out).exists(),
        "nothing may be written on bad input"
    );
}

#[test]
fn bad_input_exits_2_names_the_problem_and_writes_nothing() {
    assert_refused(
        &[
            "simulate",
            "--params",
            "params/missing.toml",
            "--q0=0,0,0,0",
        ],
        "missing.toml",
    );
    assert_refused(
        &["simulate", "--params", "params/paper.toml", "--q0=0,0,0"],
        "--q0",
    );
    assert_refused(
        &["simulate", "--params", "params/paper.toml", "--q0=0,0,x,0"],
        "--q0",
    );
    assert_refused(
        &[
            "simulate",
            "--params",
            "params/paper.toml",
            "--q0=0,0,0,0",
            "--duration",
            "-1",
        ],
        "--duration",
    );
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../params/paper.toml"
    ))
    .unwrap()
    .replacen("mass = 0.56", "mass = -1", 1);
    std::fs::write(&bad, text).unwrap();
    assert_refused(
        &[
            "simulate",
            "--params",
            bad.to_str().unwrap(),
            "--q0=0,0,0,0",
        ],
        "links[1].mass",
    );
}

/// Any link count from 2 to 12 works end to end; the 3- and 6-link robots of params/ simulate
/// with energy conserved.
#[test]
fn three_and_six_link_robots_simulate() {
    let dir = tempfile::tempdir().unwrap();
    for (params, q0, n) in [
        ("params/three-link.toml", "--q0=-2.2,0,-1.0", 3),
        ("params/six-link.toml", "--q0=-2.35,0,-0.5,0,-0.5,0", 6),
    ] {
        let out = dir.path().join(format!("run{n}"));
        let o = brachia()
            .args([
                "simulate",
                "--params",
                params,
                q0,
                "--duration",
                "0.5",
                "--out",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
        let csv = csv
            .strip_prefix("# brachia trajectory schema 1\n")
            .expect("the schema line");
        let header = csv.lines().next().unwrap();
        assert!(
            header.contains(&format!(",q{n},")) && header.contains(&format!(",tau{n},")),
            "{header}"
        );
        let rep: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap())
                .unwrap();
        assert!(
            rep["energy_drift_max_rel"].as_f64().unwrap() < 1e-5,
            "{rep}"
        );
    }
}
