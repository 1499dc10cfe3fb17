//! `brachia robot import` and `brachia robot export` as a user runs them: the files written, the
//! round trip through them, and the refusals (exit 2, the URDF element named, nothing written).

use std::path::Path;
use std::process::{Command, Output};

fn brachia() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_brachia"));
    c.current_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
    c
}

const HOOK: &str = "crates/core/tests/data/urdf/hook2.urdf";

fn run(args: &[&str], out: &Path) -> Output {
    brachia().args(args).arg("--out").arg(out).output().unwrap()
}

#[test]
fn import_writes_a_traced_parameters_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("hook2.toml");
    let o = run(
        &[
            "robot",
            "import",
            HOOK,
            "--grip",
            "hand",
            "--tip",
            "hook:0,0.03,-0.05",
        ],
        &out,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("<mass> of link \"arm\""), "{text}");
    assert!(text.contains("joint_reversed = true"), "{text}");
    // the file is a robot the other commands take
    let sim = dir.path().join("sim");
    let o = brachia()
        .args(["simulate", "--params"])
        .arg(&out)
        .args(["--q0=-1.2,0.3", "--duration", "0.2", "--out"])
        .arg(&sim)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // an existing --out needs --force
    let o = run(
        &["robot", "import", HOOK, "--grip", "hand", "--tip", "hook"],
        &out,
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--force"));
}

#[test]
fn export_then_import_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = dir.path().join("paper.urdf");
    let o = run(
        &[
            "robot",
            "export",
            "--params",
            "params/paper.toml",
            "--format",
            "urdf",
        ],
        &urdf,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mjcf = dir.path().join("paper.xml");
    let o = run(
        &[
            "robot",
            "export",
            "--params",
            "params/paper.toml",
            "--format",
            "mjcf",
        ],
        &mjcf,
    );
    assert!(o.status.success());
    assert!(std::fs::read_to_string(&mjcf).unwrap().contains("<mujoco"));
    let back = dir.path().join("paper.toml");
    let u = urdf.to_string_lossy().to_string();
    let o = run(
        &["robot", "import", &u, "--grip", "grip", "--tip", "tip"],
        &back,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let a = brachia::Robot::paper();
    let b = brachia::Robot::from_toml_file(&back).unwrap();
    for q in [[-2.35, 0.0, -1.55, 0.0], [0.3, -1.0, 2.0, 0.5]] {
        let (ma, mb) = (a.mass_matrix(&q), b.mass_matrix(&q));
        for (x, y) in ma.iter().zip(&mb) {
            assert!((x - y).abs() < 1e-12, "{ma:?} vs {mb:?}");
        }
    }
}

#[path = "../../core/tests/data/urdf/refusals.rs"]
mod refusals;

/// The lines of a `[urdf]` table for `case`.
fn urdf_table(case: &refusals::RefusalCase) -> String {
    format!(
        "[urdf]\ngrip = {:?}\ntip = {:?}\npassive = {:?}\nignore = {:?}\n",
        case.grip, case.tip, case.passive, case.ignore
    )
}

#[test]
fn refusals_exit_2_naming_the_element() {
    let dir = tempfile::tempdir().unwrap();
    for (i, case) in refusals::refusal_cases().into_iter().enumerate() {
        let what = &case.what;
        let file = dir.path().join(format!("case{i}.urdf"));
        std::fs::write(&file, case.urdf_text()).unwrap();
        let f = file.to_string_lossy().to_string();
        let name = format!("case{i}.urdf");
        // brachia robot import
        let out = dir.path().join(format!("case{i}.toml"));
        let mut a = vec![
            "robot",
            "import",
            f.as_str(),
            "--grip",
            &case.grip,
            "--tip",
            &case.tip,
        ];
        let (passive, ignore) = (case.passive.join(","), case.ignore.join(","));
        if !case.passive.is_empty() {
            a.extend(["--passive", passive.as_str()]);
        }
        if !case.ignore.is_empty() {
            a.extend(["--ignore", ignore.as_str()]);
        }
        let o = run(&a, &out);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{what}: {err}");
        assert!(
            err.contains(&case.names) && err.contains(&name),
            "{what}: {err}"
        );
        assert!(!out.exists(), "{what}: nothing written");
        // a scenario naming the file
        let scenario = dir.path().join(format!("case{i}-scenario.toml"));
        std::fs::write(
            &scenario,
            format!(
                "params = {f:?}\n{}[task]\nq0 = [-2.3, -0.6]\ntarget = [0.45, 0.0]\n",
                urdf_table(&case)
            ),
        )
        .unwrap();
        let out = dir.path().join(format!("case{i}-plan"));
        let o = brachia()
            .args(["plan", "--scenario"])
            .arg(&scenario)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{what} (scenario): {err}");
        assert!(
            err.contains(&case.names) && err.contains(&name),
            "{what} (scenario): {err}"
        );
        assert!(!out.exists(), "{what} (scenario): nothing written");
    }
}
