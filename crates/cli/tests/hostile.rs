//! The corpus of hostile inputs (`tests/hostile/cases.txt`, files beside it). Every case is a
//! bad input that must be refused fast and cleanly: the binary runs under a time limit and a memory cap,
//! and each case asserts no panic or abort, the expected exit code, a one-line refusal naming the field
//! (and the file), no output folder and no staging folder left behind, and no user file touched.
//!
//! A case line is `id | exit | must contain (&&-separated) | command | edits (;;-separated)`. Placeholders:
//! `{S}` the case's scenario (a copy of `scenarios/tracking.toml` with the edits `S:old=>new`, `S+line`,
//! or another base `S=path`), `{P}` its robot (a copy of `params/paper.toml` with `P:` / `P+` / `P=`
//! edits), `{U}` its URDF robot (a copy of `crates/core/tests/data/urdf/hook2.urdf` with `U:` / `U=`
//! edits; a scenario may name it as `params = "{U}"`), `{OUT}` an output folder in the case's temporary folder `{T}`, `{H}` the corpus folder, `{R}`
//! the repository root. `pre:NAME` prepares the case (see `prepare`); `\n` in an edit is a newline;
//! `sigint:MS` sends SIGINT (Ctrl-C) after MS ms, `sigterm:MS` SIGTERM; `fsize:BLOCKS` runs under `ulimit -f BLOCKS`, so that
//! writing the results fails (an I/O failure, exit 3).
//!
//! Limits, measured per case from the child's own resource use (`wait4`): every refusal
//! (exit 2) uses at most 1 s of CPU time and 200 MB of peak resident memory; every case ends within its
//! time limit (10 s; 60 s for a case interrupted by SIGINT). The test prints the medians and maxima.

// `wait4` (the child's peak RSS and CPU time) and `kill` (SIGINT) are libc calls; nothing else is unsafe.
#![allow(unsafe_code)]

mod common;
#[path = "hostile/urdf_prep.rs"]
mod urdf_prep;

use common::root;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The base of `{U}`, relative to the repository root.
const URDF_BASE: &str = "crates/core/tests/data/urdf/hook2.urdf";

/// Time limit of one case (a refusal takes milliseconds; this only catches hangs).
const CASE_LIMIT: Duration = Duration::from_secs(10);
/// Time limit of a case interrupted by SIGINT (the work stops after its current unit).
const INTERRUPT_LIMIT: Duration = Duration::from_secs(60);
/// The bar of every refusal (exit 2): at most this much CPU time (user + system) of the child, s. CPU
/// time rather than wall time, because the wall time of a loaded CI machine measures the machine.
const REFUSAL_CPU_S: f64 = 1.0;
/// The bar of every refusal: at most this peak resident memory of the child, MB.
const REFUSAL_RSS_MB: f64 = 200.0;
/// Virtual-memory cap of one case, kB (`ulimit -v`): allocation sized by unchecked input fails at once.
const MEMORY_CAP_KB: u64 = 1_500_000;

struct Case {
    line: usize,
    id: String,
    exit: i32,
    must: Vec<String>,
    cmd: String,
    edits: Vec<String>,
}

fn parse_cases(text: &str) -> Vec<Case> {
    let mut out = Vec::new();
    for (i, l) in text.lines().enumerate() {
        let l = l.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = l.splitn(5, " | ").map(str::trim).collect();
        assert!(f.len() >= 4, "cases.txt line {}: {l}", i + 1);
        out.push(Case {
            line: i + 1,
            id: f[0].to_string(),
            exit: f[1].parse().expect("exit code"),
            must: f[2]
                .split("&&")
                .map(|s| s.trim().to_string())
                .filter(|s| !s.is_empty())
                .collect(),
            cmd: f[3].to_string(),
            edits: f
                .get(4)
                .map(|e| {
                    e.split(";;")
                        .map(|s| s.trim().to_string())
                        .filter(|s| !s.is_empty())
                        .collect()
                })
                .unwrap_or_default(),
        });
    }
    out
}

struct Env {
    t: PathBuf,
    s: PathBuf,
    p: PathBuf,
    u: PathBuf,
    out: PathBuf,
    h: PathBuf,
    r: PathBuf,
}

impl Env {
    fn subst(&self, s: &str) -> String {
        s.replace("{S}", &self.s.display().to_string())
            .replace("{P}", &self.p.display().to_string())
            .replace("{U}", &self.u.display().to_string())
            .replace("{OUT}", &self.out.display().to_string())
            .replace("{T}", &self.t.display().to_string())
            .replace("{H}", &self.h.display().to_string())
            .replace("{R}", &self.r.display().to_string())
    }
}

fn apply(text: &mut String, edit: &str, case: &Case) {
    let edit = edit.replace("\\n", "\n");
    if let Some(rest) = edit.strip_prefix('+') {
        text.push('\n');
        text.push_str(rest);
        text.push('\n');
    } else if let Some(rest) = edit.strip_prefix(':') {
        let (old, new) = rest
            .split_once("=>")
            .unwrap_or_else(|| panic!("case {} (line {}): bad edit {edit}", case.id, case.line));
        assert!(
            text.contains(old),
            "case {} (line {}): `{old}` is not in the base file",
            case.id,
            case.line
        );
        *text = text.replacen(old, new, 1);
    } else {
        panic!("case {} (line {}): bad edit {edit}", case.id, case.line);
    }
}

/// Files a case prepares before it runs; returns the user files (path, contents) that must survive.
fn prepare(name: &str, env: &Env) -> Vec<(PathBuf, Vec<u8>)> {
    let mut keep = Vec::new();
    let mut file = |p: PathBuf, data: &[u8]| {
        if let Some(d) = p.parent() {
            std::fs::create_dir_all(d).unwrap();
        }
        std::fs::write(&p, data).unwrap();
        keep.push((p, data.to_vec()));
    };
    match name {
        // --out is a regular file
        "outfile" => file(env.out.clone(), b"my notes\n"),
        // --out is a folder of the user's own files (not a brachia run folder)
        "outuser" => {
            file(env.out.join("figures/mine.png"), b"not brachia's");
            file(env.out.join("tracking/keep.txt"), b"mine");
        }
        // the results page's figure folder name is taken by a file
        "pagestemfile" => file(env.t.join("pub/results"), b"a file"),
        // the results page path is a folder
        "pagedir" => {
            std::fs::create_dir_all(env.t.join("pub/results.md")).unwrap();
            file(env.t.join("pub/results.md/inside.txt"), b"mine");
        }
        // a folder with the user's files where the page's figures would go
        "pageuser" => file(env.t.join("pub/results/mine.png"), b"mine"),
        // a parameters file larger than the 1 MB cap (a million-link robot)
        "millionlinks" => {
            let mut s = String::from("gravity = 9.81\n");
            let link = "[[links]]\nlength = 0.3\nmass = 0.3\ncom = 0.1\ninertia = 0.01\n";
            while s.len() < 3 << 20 {
                s.push_str(link);
            }
            std::fs::write(&env.p, s).unwrap();
        }
        // a scenario larger than the cap (a huge comment)
        "bigscenario" => {
            let mut s = std::fs::read_to_string(&env.s).unwrap();
            s.push('#');
            s.push_str(&"x".repeat(2 << 20));
            std::fs::write(&env.s, s).unwrap();
        }
        // a robot with 13 links, under the size cap
        "thirteenlinks" => {
            let mut s = String::from("gravity = 9.81\n");
            for _ in 0..13 {
                s.push_str("[[links]]\nlength = 0.1\nmass = 0.3\ncom = 0.05\ninertia = 0.01\n");
            }
            s.push_str(&format!(
                "[actuators]\ntau_min = {:?}\ntau_max = {:?}\n",
                vec![-1.0; 12],
                vec![1.0; 12]
            ));
            std::fs::write(&env.p, s).unwrap();
        }
        // invalid UTF-8
        "binaryparams" => std::fs::write(&env.p, [0xff, 0xfe, 0x00, 0x41, 0x80]).unwrap(),
        "binaryscenario" => std::fs::write(&env.s, [b'p', 0xff, 0xfe, 0x00]).unwrap(),
        // a scenario folder for reproduce whose tracking.toml is broken
        "badscenariodir" => {
            let d = env.t.join("sc");
            std::fs::create_dir_all(&d).unwrap();
            for f in [
                "tracking.toml",
                "obstacle.toml",
                "obstacle-ignored.toml",
                "robustness.toml",
                "robustness-paper.toml",
            ] {
                let text = std::fs::read_to_string(env.r.join("scenarios").join(f))
                    .unwrap()
                    .replace(
                        "../params/paper.toml",
                        &env.r.join("params/paper.toml").display().to_string(),
                    );
                std::fs::write(d.join(f), text).unwrap();
            }
            let t = std::fs::read_to_string(d.join("tracking.toml")).unwrap();
            std::fs::write(
                d.join("tracking.toml"),
                t.replace("knot_dt = 0.03", "knot_dt = 1e-5"),
            )
            .unwrap();
        }
        // a ladder of 17 bars (one more than the limit), 1 m apart
        "seventeenbars" => {
            let bars: Vec<String> = (0..17)
                .map(|i| format!("{{ x = {i}.0, y = 0.0 }}"))
                .collect();
            let text = format!(
                "params = {:?}\n[ladder]\nbars = [{}]\n",
                env.p.display().to_string(),
                bars.join(", ")
            );
            std::fs::write(&env.s, text).unwrap();
        }
        // a ladder of a million bars (over the 1 MB size cap of a scenario)
        "millionbars" => {
            let mut text = format!(
                "params = {:?}\n[ladder]\nbars = [\n",
                env.p.display().to_string()
            );
            for i in 0..1_000_000 {
                text.push_str(&format!("{{ x = {i}.0, y = 0.0 }},\n"));
            }
            text.push_str("]\n");
            std::fs::write(&env.s, text).unwrap();
        }
        "emptydir" => std::fs::create_dir_all(env.t.join("empty")).unwrap(),
        "emptysub" => std::fs::create_dir_all(env.t.join("sub")).unwrap(),
        // {T}/run: a simulate run folder written by brachia, then damaged: `simfolder:HOW`
        other if other.starts_with("simfolder:") => {
            let d = env.t.join("run");
            let o = Command::new(env!("CARGO_BIN_EXE_brachia"))
                .args(["simulate", "--params"])
                .arg(env.r.join("params/paper.toml"))
                .args(["--q0=-2.35,0,-1.55,0", "--duration", "0.2", "--out"])
                .arg(&d)
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let traj = std::fs::read_to_string(d.join("trajectory.csv")).unwrap();
            let report = std::fs::read_to_string(d.join("report.json")).unwrap();
            match &other["simfolder:".len()..] {
                "ok" => {}
                "future" => std::fs::write(
                    d.join("trajectory.csv"),
                    traj.replacen("schema 1", "schema 9", 1),
                )
                .unwrap(),
                "reportfuture" => std::fs::write(
                    d.join("report.json"),
                    report.replacen("\"schema_version\": 1", "\"schema_version\": 9", 1),
                )
                .unwrap(),
                "nan" => std::fs::write(
                    d.join("trajectory.csv"),
                    traj.replacen("-2.350000000", "nan", 1),
                )
                .unwrap(),
                "swap" => {
                    let mut lines: Vec<&str> = traj.lines().collect();
                    lines.swap(5, 6);
                    std::fs::write(d.join("trajectory.csv"), lines.join("\n") + "\n").unwrap();
                }
                how => panic!("unknown damage {how}"),
            }
            // every file of the folder must survive the refusal unchanged
            for e in std::fs::read_dir(&d).unwrap().flatten() {
                if e.file_type().unwrap().is_file() {
                    let data = std::fs::read(e.path()).unwrap();
                    file(e.path(), &data);
                }
            }
        }
        // {T}/run: the corpus' plan folder made to look like another kind: `fakekind:KIND`
        other if other.starts_with("fakekind:") => {
            let d = env.t.join("run");
            let src = env.h.join("runs/plan");
            let kind = &other["fakekind:".len()..];
            let skip: &[&str] = match kind {
                "benchmark" => &["trajectory.csv", "report.json"],
                _ => &[],
            };
            if kind != "empty" {
                for e in std::fs::read_dir(&src).unwrap().flatten() {
                    if !skip.iter().any(|n| e.file_name() == **n) {
                        file(d.join(e.file_name()), &std::fs::read(e.path()).unwrap());
                    }
                }
            }
            match kind {
                "traverse" => file(
                    d.join("traverse.csv"),
                    &std::fs::read(src.join("trajectory.csv")).unwrap(),
                ),
                "benchmark" => file(d.join("scorecard.json"), b"{\"schema_version\": 1}\n"),
                "empty" => file(
                    d.join(".brachia-run"),
                    b"# brachia run-folder manifest, schema 1\n",
                ),
                other => panic!("unknown kind {other}"),
            }
        }
        // a FIFO (reading it would block, replacing it would destroy it)
        "fifo" => {
            let fifo = env.t.join("fifo");
            let ok = Command::new("mkfifo").arg(&fifo).status().unwrap();
            assert!(ok.success());
        }
        // an output that is a symbolic link to a file of the user's, or to nothing
        "outlink" => {
            file(env.t.join("target.urdf"), b"the user's file");
            std::os::unix::fs::symlink(env.t.join("target.urdf"), env.t.join("link.urdf")).unwrap();
        }
        "outdangling" => {
            std::os::unix::fs::symlink(env.t.join("nowhere.urdf"), env.t.join("dangling.urdf"))
                .unwrap()
        }
        // a link to the URDF robot file
        "urdflink" => std::os::unix::fs::symlink(&env.u, env.t.join("urdflink")).unwrap(),
        // a thousand pushes
        "manypushes" => {
            let mut s = std::fs::read_to_string(&env.s).unwrap();
            s.push_str("\n[disturbances]\npushes = [\n");
            for k in 0..1000 {
                s.push_str(&format!(
                    "{{ t_s = {}, link = 4, point_m = 0.1, impulse_n_s = [0.0, 0.01] }},\n",
                    k as f64 * 0.002
                ));
            }
            s.push_str("]\n");
            std::fs::write(&env.s, s).unwrap();
        }
        // a symlink to itself
        "symlinkloop" => {
            std::os::unix::fs::symlink(env.t.join("loop"), env.t.join("loop")).unwrap()
        }
        // a reproduction folder whose summary.json is damaged, lacks a field, or is 1 GB (sparse)
        "repcorrupt" | "repmissingfield" | "rephuge" => {
            let d = env.t.join("rep");
            file(
                d.join(".brachia-run"),
                b"# brachia run folder\nsummary.json\n",
            );
            match name {
                "repcorrupt" => file(d.join("summary.json"), b"{\"mode\": \"quick\", \"wall"),
                "repmissingfield" => file(
                    d.join("summary.json"),
                    b"{\"schema_version\": 1, \"wall_time_s\": 1.0}\n",
                ),
                _ => sparse(&d.join("summary.json")),
            }
        }
        // a reproduction folder whose summary.json has a wrong type or a null (`repsummary:KIND`), or
        // whose ladder report is `[]` (`repladder`)
        other if other.starts_with("repsummary:") || other == "repladder" => {
            let d = env.t.join("rep");
            let good = "\"mode\": \"quick\", \"wall_time_s\": 6.0, \"cores\": 2";
            let v = "\"schema_version\": 1";
            let lists = "\"failures\": [], \"warnings\": []";
            let sum = match other {
                "repsummary:wallnull" => {
                    format!("{{{v}, \"mode\": \"quick\", \"wall_time_s\": null, \"cores\": 2, {lists}}}")
                }
                "repsummary:coresstring" => format!(
                    "{{{v}, \"mode\": \"quick\", \"wall_time_s\": 6.0, \"cores\": \"2\", {lists}}}"
                ),
                "repsummary:failuresnumber" => {
                    format!("{{{v}, {good}, \"failures\": 3, \"warnings\": []}}")
                }
                "repsummary:modeother" => {
                    format!(
                        "{{{v}, \"mode\": \"fast\", \"wall_time_s\": 6.0, \"cores\": 2, {lists}}}"
                    )
                }
                _ => format!("{{{v}, {good}, {lists}}}"),
            };
            let mut manifest = String::from("# brachia run folder\nsummary.json\n");
            if other == "repladder" {
                manifest.push_str("ladder/report.json\n");
                file(d.join("ladder/report.json"), b"[]\n");
            }
            file(d.join(".brachia-run"), manifest.as_bytes());
            file(d.join("summary.json"), sum.as_bytes());
        }
        // OUT is the folder of a previous brachia run, with one file of the user's own
        "prevrun" => {
            file(
                env.out.join(".brachia-run"),
                b"# brachia run folder\ntrajectory.csv\nreport.json\n",
            );
            file(env.out.join("trajectory.csv"), b"t,q1\n0,0\n");
            file(env.out.join("report.json"), b"{\"previous\": true}\n");
            file(env.out.join("notes.txt"), b"the user's own notes\n");
        }
        // OUT is a run folder whose manifest lists a file outside OUT, which must survive
        "escapemanifest" => {
            file(env.t.join("victim.txt"), b"outside the output");
            file(
                env.out.join(".brachia-run"),
                b"# brachia run folder\ntrajectory.csv\n../victim.txt\n",
            );
            file(env.out.join("trajectory.csv"), b"t,q1\n0,0\n");
        }
        // OUT is a run folder whose manifest is of a schema this brachia does not know
        "futuremanifest" => {
            file(
                env.out.join(".brachia-run"),
                b"# brachia run-folder manifest, schema 9\n",
            );
            file(env.out.join("trajectory.csv"), b"t,q1\n0,0\n");
        }
        // {T}/run: a copy of the corpus' plan run folder with one file damaged: `run:FILE=HOW`
        other if other.starts_with("run:") => {
            let (f, how) = other["run:".len()..].split_once('=').expect("run:FILE=HOW");
            let src = env.h.join("runs/plan");
            let d = env.t.join("run");
            for e in std::fs::read_dir(&src).unwrap().flatten() {
                let name = e.file_name().to_string_lossy().to_string();
                if name == f {
                    continue;
                }
                file(d.join(&name), &std::fs::read(e.path()).unwrap());
            }
            let target = d.join(f);
            let orig = std::fs::read_to_string(src.join(f)).unwrap_or_default();
            match how {
                "missing" => {}
                "garbage" => file(target, b"\x01garbage, not what it should be {[\n"),
                "1g" => sparse(&target),
                "loop" => std::os::unix::fs::symlink(&target, &target).unwrap(),
                "nan" => {
                    // the third sample's q2 is NaN
                    let mut lines: Vec<String> = orig.lines().map(String::from).collect();
                    let mut cells: Vec<String> = lines[3].split(',').map(String::from).collect();
                    cells[2] = "nan".into();
                    lines[3] = cells.join(",");
                    file(target, (lines.join("\n") + "\n").as_bytes());
                }
                // times 0, 1e-300, 2e-300, ...: strictly increasing, yet no swing
                "tinystep" => {
                    let lines: Vec<String> = orig
                        .lines()
                        .enumerate()
                        .map(|(k, l)| match (k, l.split_once(',')) {
                            (0 | 1, _) | (_, None) => l.to_string(),
                            (_, Some((_, rest))) => format!("{:e},{rest}", (k - 2) as f64 * 1e-300),
                        })
                        .collect();
                    file(target, (lines.join("\n") + "\n").as_bytes());
                }
                // the hand's columns of a sample: NaN (`eenan`) or 10 cm off the kinematics (`eeoff`)
                "eenan" | "eeoff" => {
                    let mut lines: Vec<String> = orig.lines().map(String::from).collect();
                    let mut cells: Vec<String> = lines[5].split(',').map(String::from).collect();
                    let x = cells.len() - 2;
                    cells[x] = if how == "eenan" {
                        "nan".into()
                    } else {
                        format!("{}", cells[x].parse::<f64>().unwrap() + 0.1)
                    };
                    lines[5] = cells.join(",");
                    file(target, (lines.join("\n") + "\n").as_bytes());
                }
                // the last ten samples dropped: shorter than the report's swing time
                "short" => {
                    let lines: Vec<&str> = orig.lines().collect();
                    file(
                        target,
                        (lines[..lines.len() - 10].join("\n") + "\n").as_bytes(),
                    );
                }
                // the file's schema version from the future, or no schema line / field at all
                "future" | "noschema" => {
                    let text = if f.ends_with(".json") {
                        let field = if how == "future" {
                            "\"schema_version\": 9,"
                        } else {
                            ""
                        };
                        orig.replacen("\"schema_version\": 1,", field, 1)
                    } else if how == "future" {
                        orig.replacen("schema 1", "schema 9", 1)
                    } else {
                        orig.lines().skip(1).collect::<Vec<_>>().join("\n") + "\n"
                    };
                    file(target, text.as_bytes());
                }
                // CSV rows edited: the last column dropped, a time of 1e308, two rows swapped, an
                // infinite time, a value beyond f64, the file cut mid-row, a column named twice, a
                // negative time
                "dropcol" | "hugetime" | "swap" | "inftime" | "overflow" | "trunc" | "dupcol"
                | "negtime" => {
                    let mut lines: Vec<String> = orig.lines().map(String::from).collect();
                    let set = |line: &mut String, col: usize, v: &str| {
                        let mut cells: Vec<String> = line.split(',').map(String::from).collect();
                        cells[col] = v.into();
                        *line = cells.join(",");
                    };
                    let n = lines.len();
                    match how {
                        "dropcol" => {
                            for l in lines.iter_mut().skip(1) {
                                let cut = l.rfind(',').unwrap();
                                l.truncate(cut);
                            }
                        }
                        "hugetime" => set(&mut lines[n - 1], 0, "1e308"),
                        "swap" => lines.swap(5, 6),
                        "inftime" => set(&mut lines[n / 2], 0, "inf"),
                        "overflow" => set(&mut lines[4], 3, "1e999"),
                        "trunc" => {
                            let l = &mut lines[n - 1];
                            l.truncate(l.len() / 2);
                        }
                        "dupcol" => lines[1] = lines[1].replacen("q2", "q1", 1),
                        _ => set(&mut lines[3], 0, "-0.02"),
                    }
                    let mut text = lines.join("\n");
                    if how != "trunc" {
                        text.push('\n');
                    }
                    file(target, text.as_bytes());
                }
                // the file replaced by a folder (holding a file of the user's)
                "dir" => file(target.join("inside.txt"), b"the user's"),
                // a symbolic link to a copy of the file outside the folder
                "linkout" => {
                    let outside = env.t.join("outside").join(f);
                    file(outside.clone(), orig.as_bytes());
                    std::os::unix::fs::symlink(&outside, &target).unwrap();
                }
                "null" => file(target, b"null\n"),
                // the plan's scenario with an obstacle far off the swing
                "obstacle" => {
                    let text = orig.replacen(
                        "obstacles = []",
                        "obstacles = [{ center = [0.0, 2.0], radius = 0.05 }]",
                        1,
                    );
                    file(target, text.as_bytes());
                }
                // manifests: an entry listed twice, an entry under a listed file, another schema, a
                // size beyond u64, an absolute path, an empty path, a NUL byte in a path
                "dup" | "collide" | "hugesize" | "abs" | "emptypath" | "nul" => {
                    let first = orig.lines().nth(1).unwrap().to_string();
                    let extra = match how {
                        "dup" => first,
                        "collide" => format!("{first}/inner.csv"),
                        "hugesize" => "99999999999999999999999 00000000 extra.csv".to_string(),
                        "abs" => format!("1 00000000 {}", env.t.join("victim.txt").display()),
                        "emptypath" => "1 00000000 ".to_string(),
                        _ => "1 00000000 a\0b".to_string(),
                    };
                    if how == "abs" {
                        file(env.t.join("victim.txt"), b"x");
                    }
                    file(target, format!("{orig}{extra}\n").as_bytes());
                }
                "nanmass" => {
                    let i = orig.find("mass = ").expect("mass in params.toml") + "mass = ".len();
                    let j = i + orig[i..].find('\n').unwrap_or(0);
                    let text = format!("{}nan{}", &orig[..i], &orig[j..]);
                    file(target, text.as_bytes());
                }
                other => panic!("unknown damage {other}"),
            }
        }
        other => {
            if !urdf_prep::prepare(other, &env.u, &env.t) {
                panic!("unknown preparation {other}")
            }
        }
    }
    keep
}

/// A sparse file of 1 GB (no disk used): it must be refused by its size, not read.
fn sparse(path: &Path) {
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d).unwrap();
    }
    let f = std::fs::File::create(path).unwrap();
    f.set_len(1 << 30).unwrap();
}

/// Names in `dir` that a run leaves behind when it is interrupted or fails half-way.
fn leftovers(dir: &Path) -> Vec<String> {
    let mut v = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if name.contains(".partial") || name.contains(".old-") || name.contains("brachia-probe")
            {
                v.push(e.path().display().to_string());
            }
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(e.path());
            }
        }
    }
    v
}

struct Outcome {
    code: Option<i32>,
    stderr: String,
    elapsed: Duration,
    /// User plus system CPU time of the child (wait4's rusage), s.
    cpu_s: f64,
    /// Peak resident set of the child (wait4's rusage `ru_maxrss`), MB.
    peak_rss_mb: f64,
    timed_out: bool,
}

/// Reap `pid` without blocking: `Some((exit code, rusage))` once it has exited. `wait4` rather than
/// std's `Child::wait`, because it also returns the child's own resource use (peak RSS, CPU time).
fn try_wait4(pid: i32) -> Option<(Option<i32>, libc::rusage)> {
    let mut status: libc::c_int = 0;
    // SAFETY: an all-zero rusage is a valid value of this plain C struct
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `pid` is our own child, not yet reaped; both pointers are to live locals
    let r = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut usage) };
    if r == pid {
        let code = libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status));
        Some((code, usage))
    } else {
        None
    }
}

/// Run brachia with `args` under the virtual-memory cap; `signal_after` sends it a signal (SIGINT as Ctrl-C
/// does) after that long; `limit` is the hang limit.
// the child is reaped by `try_wait4` (libc::wait4), which clippy cannot see
#[allow(clippy::zombie_processes)]
fn run_limited(
    args: &[String],
    cwd: &Path,
    signal_after: Option<(libc::c_int, Duration)>,
    fsize_blocks: Option<u64>,
    limit: Duration,
) -> Outcome {
    let start = Instant::now();
    // a file-size limit (`ulimit -f`, 512-byte blocks) makes larger writes fail with EFBIG; SIGXFSZ is
    // ignored so the write returns the error instead of killing the process
    let fsize = fsize_blocks
        .map(|b| format!("trap '' XFSZ; ulimit -f {b}; "))
        .unwrap_or_default();
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v {MEMORY_CAP_KB}; {fsize}exec \"$0\" \"$@\""
        ))
        .arg(env!("CARGO_BIN_EXE_brachia"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn brachia");
    let pid = child.id() as i32;
    let mut stderr = child.stderr.take().expect("stderr");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let mut timed_out = false;
    let mut signalled = false;
    let (code, usage) = loop {
        if let Some(done) = try_wait4(pid) {
            break done;
        }
        if let Some((sig, after)) = signal_after {
            if !signalled && start.elapsed() >= after {
                // SAFETY: `pid` is our child and has not been reaped (try_wait4 said so)
                unsafe { libc::kill(pid, sig) };
                signalled = true;
            }
        }
        if start.elapsed() > limit && !timed_out {
            let _ = child.kill();
            timed_out = true;
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let elapsed = start.elapsed();
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Outcome {
        code,
        stderr: reader.join().unwrap_or_default(),
        elapsed,
        cpu_s: secs(usage.ru_utime) + secs(usage.ru_stime),
        peak_rss_mb: usage.ru_maxrss as f64 / 1024.0,
        timed_out,
    }
}

/// What one case measured.
struct Measured {
    elapsed: Duration,
    cpu_s: f64,
    peak_rss_mb: f64,
}

fn run_case(case: &Case, h: &Path) -> Result<Measured, String> {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path().to_path_buf();
    let env = Env {
        s: t.join("case.toml"),
        p: t.join("robot.toml"),
        u: t.join("robot.urdf"),
        out: t.join("out"),
        h: h.to_path_buf(),
        r: root().canonicalize().unwrap(),
        t: t.clone(),
    };
    let mut scen = std::fs::read_to_string(env.r.join("scenarios/tracking.toml")).unwrap();
    let mut params = std::fs::read_to_string(env.r.join("params/paper.toml")).unwrap();
    let mut urdf = std::fs::read_to_string(env.r.join(URDF_BASE)).unwrap();
    let mut pres = Vec::new();
    let mut signal_after = None;
    let mut fsize = None;
    for e in &case.edits {
        if let Some(b) = e.strip_prefix("fsize:") {
            fsize = Some(b.parse().expect("fsize:BLOCKS"));
        } else if let Some(ms) = e.strip_prefix("sigint:") {
            let ms: u64 = ms.parse().expect("sigint:MS");
            signal_after = Some((libc::SIGINT, Duration::from_millis(ms)));
        } else if let Some(ms) = e.strip_prefix("sigterm:") {
            let ms: u64 = ms.parse().expect("sigterm:MS");
            signal_after = Some((libc::SIGTERM, Duration::from_millis(ms)));
        } else if let Some(rest) = e.strip_prefix("S=") {
            scen = std::fs::read_to_string(env.subst(rest)).unwrap();
        } else if let Some(rest) = e.strip_prefix("P=") {
            params = std::fs::read_to_string(env.subst(rest)).unwrap();
        } else if let Some(rest) = e.strip_prefix("U=") {
            urdf = std::fs::read_to_string(env.subst(rest)).unwrap();
        } else if let Some(rest) = e.strip_prefix('U') {
            apply(&mut urdf, rest, case);
        } else if let Some(rest) = e.strip_prefix('S') {
            apply(&mut scen, rest, case);
        } else if let Some(rest) = e.strip_prefix('P') {
            apply(&mut params, rest, case);
        } else if let Some(rest) = e.strip_prefix("pre:") {
            pres.push(rest.to_string());
        } else {
            panic!("case {}: bad edit {e}", case.id);
        }
    }
    let scen = scen.replace(
        "params = \"../params/paper.toml\"",
        &format!("params = {:?}", env.p.display().to_string()),
    );
    let scen = scen.replace("{U}", &env.u.display().to_string());
    std::fs::write(&env.s, scen).unwrap();
    std::fs::write(&env.p, params).unwrap();
    std::fs::write(&env.u, urdf).unwrap();
    let mut keep = Vec::new();
    for p in &pres {
        keep.extend(prepare(p, &env));
    }
    let out_existed = env.out.exists();
    let args: Vec<String> = case.cmd.split_whitespace().map(|a| env.subst(a)).collect();
    let limit = if signal_after.is_some() {
        INTERRUPT_LIMIT
    } else {
        CASE_LIMIT
    };
    let o = run_limited(&args, &env.r, signal_after, fsize, limit);
    let err = &o.stderr;
    let fail = |why: String| {
        Err(format!(
            "{why}\n  command: {}\n  stderr: {err}",
            args.join(" ")
        ))
    };
    if o.timed_out {
        return fail(format!("no answer within {limit:?} (a hang)"));
    }
    for bad in [
        "panicked",
        "memory allocation",
        "stack overflow",
        "RUST_BACKTRACE",
    ] {
        if err.contains(bad) {
            return fail(format!("`{bad}` in stderr"));
        }
    }
    if o.code != Some(case.exit) {
        return fail(format!("exit {:?}, expected {}", o.code, case.exit));
    }
    for m in &case.must {
        let m = env.subst(m);
        if !err.contains(&m) {
            return fail(format!("stderr does not name `{m}`"));
        }
    }
    let clap = err.contains("Usage:") || err.contains("For more information");
    if !clap && err.trim().lines().count() != 1 {
        return fail("the refusal is not one line".into());
    }
    if case.exit != 0 && !out_existed && env.out.exists() {
        return fail("an output folder was created".into());
    }
    for (p, data) in &keep {
        if std::fs::read(p).ok().as_deref() != Some(data.as_slice()) {
            return fail(format!(
                "the user's file {} was changed or deleted",
                p.display()
            ));
        }
    }
    let left = leftovers(&t);
    if !left.is_empty() {
        return fail(format!("left behind: {left:?}"));
    }
    // the limits of a refusal: CPU time and peak memory of the child itself
    if case.exit == 2 {
        if o.cpu_s > REFUSAL_CPU_S {
            return fail(format!(
                "the refusal took {:.3} s of CPU time (more than {REFUSAL_CPU_S} s)",
                o.cpu_s
            ));
        }
        if o.peak_rss_mb > REFUSAL_RSS_MB {
            return fail(format!(
                "the refusal peaked at {:.1} MB resident (more than {REFUSAL_RSS_MB} MB)",
                o.peak_rss_mb
            ));
        }
    }
    Ok(Measured {
        elapsed: o.elapsed,
        cpu_s: o.cpu_s,
        peak_rss_mb: o.peak_rss_mb,
    })
}

#[test]
fn every_hostile_input_is_refused_fast_and_cleanly() {
    run_corpus("cases.txt", 150);
}

/// The second corpus: the newer surfaces (benchmark families and seeds, the learning environments'
/// scenario settings, re-planning, estimation, the swing-time search, `view`, concurrency), written
/// from the documentation alone.
/// The third corpus: plan and run folders edited by hand (given to `track --plan`, `report`, `view`
/// and as `--out`), plans made for another robot, ladders, every `[disturbances]` field, the
/// benchmark's flags, re-planning and estimator settings, and the output paths of `robot import` and
/// `export`.
#[test]
fn every_input_of_the_surfaces_corpus_is_refused_fast_and_cleanly() {
    run_corpus("surfaces.txt", 250);
}

#[test]
fn every_input_of_the_sweep_is_refused_fast_and_cleanly() {
    run_corpus("sweep.txt", 100);
}

/// URDF robots (`brachia robot import`, `params = "x.urdf"` with `[urdf]`) and `brachia robot export`.
#[test]
fn every_hostile_urdf_input_is_refused_fast_and_cleanly() {
    run_corpus("urdf.txt", 40);
}

/// Run every case of the corpus file `file` (in `tests/hostile`), which must hold at least
/// `min_cases` cases.
fn run_corpus(file: &str, min_cases: usize) {
    let h = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/hostile")
        .canonicalize()
        .unwrap();
    let cases = parse_cases(&std::fs::read_to_string(h.join(file)).unwrap());
    assert!(cases.len() >= min_cases, "{file}: {} cases", cases.len());
    let mut ids = std::collections::HashSet::new();
    for c in &cases {
        assert!(ids.insert(c.id.clone()), "duplicate case id {}", c.id);
    }
    // two workers pull cases from a shared queue: the cases are independent
    let next = std::sync::atomic::AtomicUsize::new(0);
    let wall = Instant::now();
    let mut results: Vec<(usize, Result<Measured, String>)> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..2)
            .map(|_| {
                let (h, next, cases) = (&h, &next, &cases);
                s.spawn(move || {
                    let mut out = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(c) = cases.get(i) else { break };
                        out.push((i, run_case(c, h)));
                    }
                    out
                })
            })
            .collect();
        hs.into_iter().flat_map(|j| j.join().unwrap()).collect()
    });
    results.sort_by_key(|r| r.0);
    let results: Vec<(String, Result<Measured, String>)> = results
        .into_iter()
        .map(|(i, r)| (cases[i].id.clone(), r))
        .collect();
    let failures: Vec<String> = results
        .iter()
        .filter_map(|(id, r)| r.as_ref().err().map(|e| format!("case {id}: {e}")))
        .collect();
    // the statistics of the refusals (exit 2); the write-failure and Ctrl-C cases do real work
    let refusals: std::collections::HashSet<&str> = cases
        .iter()
        .filter(|c| c.exit == 2)
        .map(|c| c.id.as_str())
        .collect();
    let ok: Vec<(&String, &Measured)> = results
        .iter()
        .filter(|(id, _)| refusals.contains(id.as_str()))
        .filter_map(|(id, r)| r.as_ref().ok().map(|m| (id, m)))
        .collect();
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    let max_by = |f: &dyn Fn(&Measured) -> f64| {
        ok.iter()
            .map(|(id, m)| (f(m), (*id).clone()))
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap_or_default()
    };
    let (cpu_max, cpu_id) = max_by(&|m| m.cpu_s);
    let (rss_max, rss_id) = max_by(&|m| m.peak_rss_mb);
    let (wall_max, wall_id) = max_by(&|m| m.elapsed.as_secs_f64());
    eprintln!(
        "hostile corpus {file}: {} cases ({} refusals) in {:.1} s (2 workers); per refusal: wall median \
         {:.3} s, max {:.3} s ({wall_id}); CPU median {:.3} s, max {cpu_max:.3} s ({cpu_id}); peak RSS \
         median {:.1} MB, max {rss_max:.1} MB ({rss_id})",
        cases.len(),
        refusals.len(),
        wall.elapsed().as_secs_f64(),
        median(ok.iter().map(|(_, m)| m.elapsed.as_secs_f64()).collect()),
        wall_max,
        median(ok.iter().map(|(_, m)| m.cpu_s).collect()),
        median(ok.iter().map(|(_, m)| m.peak_rss_mb).collect()),
    );
    assert!(
        failures.is_empty(),
        "{file}: {} of {} hostile cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}
