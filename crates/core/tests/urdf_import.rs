//! URDF import and export (`brachia::urdf`): the robots of `tests/data/urdf/` (a two-link hook robot
//! turning about x, a three-link robot turning about y with a zero-length link, the paper's robot
//! about a skew axis), the round trip export -> import (same M, C qd, G in the file's joint angles,
//! same limits), the traced TOML, and every refusal naming its URDF element.

use brachia::model::{Robot, RobotParams, Scratch};
use brachia::urdf::{import_urdf_file, import_urdf_str, imported_toml, to_mjcf, to_urdf, Tip};
use brachia::urdf::{Imported, UrdfOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::PathBuf;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/urdf")
        .join(name)
}

fn opts(grip: &str, tip: &str) -> UrdfOptions {
    UrdfOptions::new(grip, tip.parse::<Tip>().unwrap())
}

fn robot(imp: &Imported) -> Robot {
    Robot::from_params(imp.params.clone(), "<imported>").unwrap()
}

/// M, C qd and G of `robot` in the robot's own joint angles `phi` (rates `phid`).
fn dynamics_in_phi(robot: &Robot, phi: &[f64], phid: &[f64]) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = robot.n();
    let q = robot.q_from_joint_angles(phi);
    let s: Vec<f64> = robot
        .params()
        .links
        .iter()
        .map(|l| if l.joint_reversed { -1.0 } else { 1.0 })
        .collect();
    let qd: Vec<f64> = (0..n).map(|i| s[i] * phid[i]).collect();
    let mut ws = Scratch::new(n);
    let (mut m, mut c, mut g) = (vec![0.0; n * n], vec![0.0; n], vec![0.0; n]);
    robot.mass_matrix_into(&mut ws, &q, &mut m);
    robot.coriolis_into(&mut ws, &q, &qd, &mut c);
    robot.gravity_into(&mut ws, &q, &mut g);
    for i in 0..n {
        for j in 0..n {
            m[i * n + j] *= s[i] * s[j];
        }
        c[i] *= s[i];
        g[i] *= s[i];
    }
    (m, c, g)
}

fn rel(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).fold(0f64, |m, (x, y)| m.max((x - y).abs())) / scale
}

/// Two robots with the same dynamics in their joint angles at random states.
fn assert_same_dynamics(a: &Robot, b: &Robot, what: &str) {
    assert_eq!(a.n(), b.n(), "{what}");
    let n = a.n();
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    for _ in 0..25 {
        let phi: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.0..3.0)).collect();
        let phid: Vec<f64> = (0..n).map(|_| rng.gen_range(-4.0..4.0)).collect();
        let (ma, ca, ga) = dynamics_in_phi(a, &phi, &phid);
        let (mb, cb, gb) = dynamics_in_phi(b, &phi, &phid);
        assert!(rel(&ma, &mb) < 1e-12, "{what}: M {ma:?} vs {mb:?}");
        assert!(rel(&ca, &cb) < 1e-11, "{what}: C qd {ca:?} vs {cb:?}");
        assert!(rel(&ga, &gb) < 1e-12, "{what}: G {ga:?} vs {gb:?}");
    }
}

#[test]
fn the_paper_robot_about_a_skew_axis_is_the_paper_robot() {
    let imp = import_urdf_file(&data("paper4_skew.urdf"), &opts("grip", "tip")).unwrap();
    let r = robot(&imp);
    let paper = Robot::paper();
    assert_eq!(imp.joints, ["grip", "j2", "j3", "j4"]);
    for k in 0..4 {
        let (a, b) = (&r.params().links[k], &paper.params().links[k]);
        assert!((a.length - b.length).abs() < 1e-12, "link {k}");
        assert!((a.mass - b.mass).abs() < 1e-15);
        assert!((a.com - b.com).abs() < 1e-12 && a.com_across.abs() < 1e-12);
        assert!((a.inertia - b.inertia).abs() < 1e-12);
        assert!(!a.joint_reversed);
        if k > 0 {
            assert!(a.joint_offset.abs() < 1e-12, "link {k}: {}", a.joint_offset);
            let (lo, hi) = (a.q_min.unwrap(), a.q_max.unwrap());
            assert!(
                (lo + 2.9).abs() < 1e-12 && (hi - 2.9).abs() < 1e-12,
                "{lo} {hi}"
            );
            assert_eq!(a.qd_max, Some(15.0));
        }
    }
    assert_eq!(r.tau_max(), paper.tau_max());
    // gravity: 9.81 times the length of the world's z projected into the plane
    let (roll, pitch, yaw): (f64, f64, f64) = (0.3, 0.5, 0.7);
    let (sr, cr, sp, cp, sy, cy) = (
        roll.sin(),
        roll.cos(),
        pitch.sin(),
        pitch.cos(),
        yaw.sin(),
        yaw.cos(),
    );
    // the second column of Rz Ry Rx, negated: the axis (0, -1, 0) in the world
    let axis = [
        -(cy * sp * sr - sy * cr),
        -(sy * sp * sr + cy * cr),
        -(cp * sr),
    ];
    let g = 9.81 * (1.0 - axis[2] * axis[2]).sqrt();
    assert!((r.gravity() - g).abs() < 1e-12, "{} vs {g}", r.gravity());
}

#[test]
fn the_hook_robot_merges_fixed_links_and_reads_its_transmission() {
    let imp = import_urdf_file(&data("hook2.urdf"), &opts("hand", "hook:0,0.03,-0.05")).unwrap();
    let r = robot(&imp);
    assert_eq!(r.n(), 2);
    let l = &r.params().links;
    // arm + camera, forearm + hook
    assert!((l[0].mass - 1.02).abs() < 1e-12 && (l[1].mass - 0.78).abs() < 1e-12);
    assert!(!l[0].joint_reversed && l[1].joint_reversed);
    assert!(l[0].com_across != 0.0 && l[1].com_across != 0.0);
    // the axis is horizontal: all of gravity acts in the plane
    assert!((r.gravity() - 9.81).abs() < 1e-12);
    // the elbow's limits, mapped through its reversal and offset
    let (lo, hi) = (l[1].q_min.unwrap(), l[1].q_max.unwrap());
    assert!((lo - (-2.4 + l[1].joint_offset)).abs() < 1e-12, "{lo}");
    assert!((hi - (2.6 + l[1].joint_offset)).abs() < 1e-12, "{hi}");
    assert_eq!(r.tau_max(), &[6.0]);
    assert_eq!(l[0].qd_max, Some(12.0));
    // the grip is 1.2 m up; the tip hangs below it at zero angles, at the hook's point
    let q0 = r.q_from_joint_angles(&[0.0, 0.0]);
    let ee = r.ee_position(&q0);
    assert!(ee[1] < -0.5 && ee[1] > -0.7, "{ee:?}");
    // the joint angle maps of an imported robot are inverse to each other
    let phi = r.q_to_joint_angles(&[0.3, -0.4]);
    let back = r.q_from_joint_angles(&phi);
    assert!((back[0] - 0.3).abs() < 1e-15 && (back[1] + 0.4).abs() < 1e-15);
}

#[test]
fn the_three_link_robot_has_a_zero_length_link() {
    let imp =
        import_urdf_file(&data("three_link.urdf"), &opts("shoulder", "hand:0.22,0,0")).unwrap();
    let r = robot(&imp);
    assert_eq!(imp.joints, ["shoulder", "elbow", "wrist"]);
    let l = &r.params().links;
    // upper + spacer; the knuckle between elbow and wrist has no length in the plane
    assert!((l[0].mass - 0.7).abs() < 1e-12);
    assert_eq!(l[1].length, 0.0);
    assert!(l[1].com != 0.0 || l[1].com_across != 0.0);
    assert!(l[1].joint_reversed && !l[2].joint_reversed);
    assert!((r.gravity() - 9.81).abs() < 1e-12);
    assert_eq!(r.tau_max(), &[4.0, 3.0]);
}

#[test]
fn export_then_import_gives_the_same_robot() {
    // every robot the project ships, and one with every general field
    let params = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../params");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&params)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 6, "{files:?}");
    let mut robots: Vec<Robot> = files
        .iter()
        .map(|f| Robot::from_toml_file(f).unwrap())
        .collect();
    robots.push(
        Robot::from_toml_file(
            &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/general.toml"),
        )
        .unwrap(),
    );
    for r in robots {
        let text = to_urdf(&r).unwrap();
        let imp = import_urdf_str(&text, "exported.urdf", &opts("grip", "tip")).unwrap();
        let back = robot(&imp);
        let what = r.params().name.clone();
        assert_same_dynamics(&r, &back, &what);
        assert!((back.gravity() - r.gravity()).abs() < 1e-12);
        assert_eq!(back.tau_max(), r.tau_max(), "{what}");
        assert_eq!(back.tau_min(), r.tau_min(), "{what}");
        for (a, b) in r.params().links.iter().zip(&back.params().links) {
            // limits in the file's joint angles agree (brachia's angle may differ by the offset
            // of a last link turned towards the end effector)
            let span =
                |l: &brachia::model::LinkParams| l.q_min.zip(l.q_max).map(|(lo, hi)| hi - lo);
            assert_eq!(span(a).is_some(), span(b).is_some(), "{what}");
            if let (Some(x), Some(y)) = (span(a), span(b)) {
                assert!((x - y).abs() < 1e-12);
            }
            assert_eq!(a.qd_max, b.qd_max, "{what}");
        }
        // the end effector is the same point
        let phi = vec![0.2; r.n()];
        let (ea, eb) = (
            r.ee_position(&r.q_from_joint_angles(&phi)),
            back.ee_position(&back.q_from_joint_angles(&phi)),
        );
        assert!(
            (ea[0] - eb[0]).abs() < 1e-12 && (ea[1] - eb[1]).abs() < 1e-12,
            "{what}"
        );
        // the MJCF names every actuated joint once and the grip never
        let mj = to_mjcf(&r);
        assert_eq!(mj.matches("<motor ").count(), r.n() - 1);
        assert!(!mj.contains("joint=\"grip\""));
    }
}

#[test]
fn the_traced_toml_reads_back_as_the_same_robot() {
    for (file, grip, tip) in [
        ("hook2.urdf", "hand", "hook:0,0.03,-0.05"),
        ("three_link.urdf", "shoulder", "hand:0.22,0,0"),
        ("paper4_skew.urdf", "grip", "tip"),
    ] {
        let imp = import_urdf_file(&data(file), &opts(grip, tip)).unwrap();
        let text = imported_toml(&imp, file);
        let back = RobotParams::from_toml_str(&text, "robot.toml").unwrap();
        assert_eq!(back, imp.params, "{file}:\n{text}");
        assert!(text.contains("<mass> of link"), "{text}");
        assert!(text.contains("<limit effort>"), "{text}");
    }
}

#[path = "data/urdf/refusals.rs"]
mod refusals;

#[test]
fn refusals_name_the_urdf_element() {
    for case in refusals::refusal_cases() {
        let o = UrdfOptions {
            passive: case.passive.clone(),
            ignore: case.ignore.clone(),
            ..opts(&case.grip, &case.tip)
        };
        let msg = match import_urdf_str(&case.urdf_text(), "hook2.urdf", &o) {
            Ok(imp) => match Robot::from_params(imp.params, "hook2.urdf") {
                Ok(_) => panic!("{}: accepted", case.what),
                Err(e) => e.to_string(),
            },
            Err(e) => e.to_string(),
        };
        assert!(
            msg.contains("hook2.urdf") && msg.contains(&case.names),
            "{}: {msg} (expected {})",
            case.what,
            case.names
        );
    }
    let o = opts("hand", "hook");
    // a branch listed in urdf.ignore is left out
    let ignore = UrdfOptions {
        ignore: vec!["camera_mount".into()],
        ..o.clone()
    };
    let text = std::fs::read_to_string(data("hook2.urdf"))
        .unwrap()
        .replace(
            "name=\"camera_mount\" type=\"fixed\"",
            "name=\"camera_mount\" type=\"revolute\"",
        );
    let imp = import_urdf_str(&text, "hook2.urdf", &ignore).unwrap();
    assert!((imp.params.links[0].mass - 0.9).abs() < 1e-12);
    // a tip written badly
    assert!("hook:1,2".parse::<Tip>().is_err());
    assert!(":1,2,3".parse::<Tip>().is_err());
}
