//! `brachia reproduce --quick` as CI runs it: every experiment's run folder, every figure the report
//! embeds, the comparison table and the summary; bad input exits 2 and writes nothing.

mod common;

use common::brachia;

#[test]
fn quick_reproduction_writes_report_figures_and_run_folders() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    // the user's own files in --out (with --force) and beside the results page survive
    let mine = [
        (out.join("figures/mine.png"), "my figure"),
        (out.join("tracking/notes.txt"), "my notes"),
        (dir.path().join("pub/results/mine.png"), "my page figure"),
    ];
    for (p, text) in &mine {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    let page = dir.path().join("pub/results.md");
    let o = brachia()
        .args(["reproduce", "--quick", "--no-progress", "--force", "--out"])
        .arg(&out)
        .arg("--results-page")
        .arg(&page)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for (p, text) in &mine {
        assert_eq!(
            std::fs::read_to_string(p).unwrap(),
            *text,
            "{}",
            p.display()
        );
    }
    assert!(page.is_file() && dir.path().join("pub/results/.brachia-page").is_file());
    assert!(out.join(brachia_experiments::MANIFEST).is_file());
    // nothing but the two folders (no staging folder) beside them
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    assert!(names.iter().all(|n| !n.starts_with('.')), "{names:?}");
    for f in [
        "REPORT.md",
        "summary.json",
        "tracking/closed_loop.csv",
        "tracking/plan/trajectory.csv",
        "tracking-model/report.json",
        "obstacle/avoid/report.json",
        "obstacle/ignored/report.json",
        "robustness/mpc/contacts.csv",
        "robustness/pd/report.json",
        "robustness/open-loop/obstacles.csv",
        "robustness-paper/report.json",
        "parameter-study/report.json",
        "parameter-study/cells.csv",
        "ladder/report.json",
        "ladder/traverse.csv",
        "ladder/traverse.gif",
        "ladder/energy_per_swing.png",
        "ladder/joint_swings.json",
        "views/parameter-study.html",
        "views/tracking.html",
        "views/obstacle-avoid.html",
        "views/robustness-mpc.html",
        "views/ladder.html",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    let md = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(md.contains("| quantity | paper | brachia | note |"));
    assert!(md.contains("(views/parameter-study.html)"));
    for row in [
        "plan time",
        "MPC time",
        "planned energy",
        "final EE error",
        "torque range",
        "T_freefall grows",
    ] {
        assert!(md.contains(row), "the table lacks {row}");
    }
    // every embedded figure exists as PNG with its SVG, every linked GIF exists
    let mut images = 0;
    for part in md.split("](").skip(1) {
        let link = &part[..part.find(')').unwrap()];
        let p = out.join(link);
        assert!(p.is_file(), "REPORT.md links a missing file {link}");
        if link.ends_with(".png") {
            assert!(p.with_extension("svg").is_file(), "no SVG beside {link}");
            images += 1;
        }
    }
    assert!(images >= 16, "only {images} figures embedded");
    assert!(md.contains(".gif"));
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["mode"], "quick");
    // the joint plan of the quick ladder's two swings, against swing by swing
    let js = &s["ladder"]["joint_swings"];
    assert_eq!(js["converged"], true, "{js}");
    assert_eq!(js["swings"], 2);
    assert!(
        js["joint"]["objective"].as_f64().unwrap()
            <= js["swing_by_swing"]["objective"].as_f64().unwrap()
    );
    assert!(md.contains("swings planned jointly"));
    assert!(
        s["failures"].as_array().unwrap().is_empty(),
        "{}",
        s["failures"]
    );
    let hit = s["robustness"]["runs"]["mpc"]["first_contact_s"]
        .as_f64()
        .unwrap();
    assert!((0.5..=0.7).contains(&hit));
    assert!(
        s["tracking"]["rapier"]["ee_final_error_m"]
            .as_f64()
            .unwrap()
            < 0.01
    );
    assert_eq!(s["parameter_study"]["grid"], serde_json::json!([3, 3]));
    // the quick mode traverses the first three bars of the even ladder
    assert_eq!(s["ladder"]["completed"], true, "{}", s["ladder"]);
    assert_eq!(s["ladder"]["swings"].as_array().unwrap().len(), 2);
    assert!(md.contains("## E. A ladder traverse"));
    // no temporary file left behind anywhere
    let mut stack = vec![out.clone()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            assert!(
                !name.ends_with(".partial") && !name.ends_with(".tmp"),
                "left {name}"
            );
            if e.path().is_dir() {
                stack.push(e.path());
            }
        }
    }
    redraw_from_the_run_folders(&out, &md);
}

/// `brachia report` redraws every figure and REPORT.md of the reproduction from its run folders
/// (no planning, no simulation): figures deleted, REPORT.md comes back byte-identical, every linked
/// figure is back, and the user's file among the figures is kept.
fn redraw_from_the_run_folders(out: &std::path::Path, md: &str) {
    let figs = out.join("figures");
    let drawn: Vec<String> = std::fs::read_dir(&figs)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|n| n != "mine.png")
        .collect();
    assert!(drawn.len() >= 20, "{drawn:?}");
    for n in &drawn {
        std::fs::remove_file(figs.join(n)).unwrap();
    }
    std::fs::remove_file(out.join("REPORT.md")).unwrap();
    let page = std::fs::read(out.join("views/ladder.html")).unwrap();
    std::fs::remove_file(out.join("views/ladder.html")).unwrap();
    let summary_before = std::fs::read(out.join("summary.json")).unwrap();
    let t0 = std::time::Instant::now();
    let o = brachia().arg("report").arg(out).output().unwrap();
    let secs = t0.elapsed().as_secs_f64();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read_to_string(out.join("REPORT.md")).unwrap(), md);
    for n in &drawn {
        assert!(figs.join(n).is_file(), "report did not redraw {n}");
    }
    assert_eq!(std::fs::read(out.join("views/ladder.html")).unwrap(), page);
    assert_eq!(
        std::fs::read_to_string(figs.join("mine.png")).unwrap(),
        "my figure"
    );
    assert_eq!(
        std::fs::read(out.join("summary.json")).unwrap(),
        summary_before
    );
    let manifest = std::fs::read_to_string(out.join(brachia_experiments::MANIFEST)).unwrap();
    assert!(manifest.contains("figures/fig5_tracking_joints.png"));
    assert!(!manifest.contains("mine.png"));
    let names: Vec<String> = std::fs::read_dir(out)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    assert!(
        names.iter().all(|n| !n.contains("partial")),
        "a staging folder was left: {names:?}"
    );
    eprintln!("brachia report redrew {} files in {secs:.1} s", drawn.len());
    // a run folder removed: refused naming a file of it, nothing redrawn (REPORT.md as it was)
    let aside = out.join("pd-aside");
    std::fs::rename(out.join("robustness/pd"), &aside).unwrap();
    let o = brachia().arg("report").arg(out).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("robustness/pd/") && err.contains("missing"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(out.join("REPORT.md")).unwrap(), md);
    std::fs::rename(&aside, out.join("robustness/pd")).unwrap();
}

#[test]
fn report_refuses_a_folder_that_is_not_a_run_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("notes.txt"), "mine").unwrap();
    let o = brachia().arg("report").arg(dir.path()).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(".brachia-run") && err.contains("missing"),
        "{err}"
    );
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    assert_eq!(names, ["notes.txt"]);
    // a manifest alone is not enough: the reproduction's summary.json is named
    std::fs::write(
        dir.path().join(brachia_experiments::MANIFEST),
        "# brachia run-folder manifest, schema 1\n",
    )
    .unwrap();
    let o = brachia().arg("report").arg(dir.path()).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("summary.json"), "{err}");
    assert!(!dir.path().join("figures").exists());
}

#[test]
fn missing_scenarios_exit_2_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let o = brachia()
        .args(["reproduce", "--quick", "--no-progress", "--scenarios"])
        .arg(dir.path().join("nowhere"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("tracking.toml"), "{err}");
    assert!(!out.exists());
}
