//! Issue 11: the corpus of hostile inputs (`tests/hostile/cases.txt`, files beside it). Every case is a
//! bad input that must be refused fast and cleanly: the binary runs under a time limit and a memory cap,
//! and each case asserts no panic or abort, the expected exit code, a one-line refusal naming the field
//! (and the file), no output folder and no staging folder left behind, and no user file touched.
//!
//! A case line is `id | exit | must contain (&&-separated) | command | edits (;;-separated)`. Placeholders:
//! `{S}` the case's scenario (a copy of `scenarios/tracking.toml` with the edits `S:old=>new`, `S+line`,
//! or another base `S=path`), `{P}` its robot (a copy of `params/paper.toml` with `P:` / `P+` / `P=`
//! edits), `{OUT}` an output folder in the case's temporary folder `{T}`, `{H}` the corpus folder, `{R}`
//! the repository root. `pre:NAME` prepares the case (see `prepare`); `\n` in an edit is a newline.

mod common;

use common::root;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Time limit of one case (a refusal takes milliseconds; this only catches hangs).
const CASE_LIMIT: Duration = Duration::from_secs(10);
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
    out: PathBuf,
    h: PathBuf,
    r: PathBuf,
}

impl Env {
    fn subst(&self, s: &str) -> String {
        s.replace("{S}", &self.s.display().to_string())
            .replace("{P}", &self.p.display().to_string())
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
        other => panic!("unknown preparation {other}"),
    }
    keep
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
    timed_out: bool,
}

fn run_limited(args: &[String], cwd: &Path) -> Outcome {
    let start = Instant::now();
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {MEMORY_CAP_KB}; exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_brachia"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn brachia");
    let mut stderr = child.stderr.take().expect("stderr");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let mut timed_out = false;
    let status = loop {
        if let Some(st) = child.try_wait().expect("wait") {
            break st;
        }
        if start.elapsed() > CASE_LIMIT {
            let _ = child.kill();
            timed_out = true;
            break child.wait().expect("wait");
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let elapsed = start.elapsed();
    Outcome {
        code: status.code(),
        stderr: reader.join().unwrap_or_default(),
        elapsed,
        timed_out,
    }
}

fn run_case(case: &Case, h: &Path) -> Result<Duration, String> {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path().to_path_buf();
    let env = Env {
        s: t.join("case.toml"),
        p: t.join("robot.toml"),
        out: t.join("out"),
        h: h.to_path_buf(),
        r: root().canonicalize().unwrap(),
        t: t.clone(),
    };
    let mut scen = std::fs::read_to_string(env.r.join("scenarios/tracking.toml")).unwrap();
    let mut params = std::fs::read_to_string(env.r.join("params/paper.toml")).unwrap();
    let mut pres = Vec::new();
    for e in &case.edits {
        if let Some(rest) = e.strip_prefix("S=") {
            scen = std::fs::read_to_string(env.subst(rest)).unwrap();
        } else if let Some(rest) = e.strip_prefix("P=") {
            params = std::fs::read_to_string(env.subst(rest)).unwrap();
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
    std::fs::write(&env.s, scen).unwrap();
    std::fs::write(&env.p, params).unwrap();
    let mut keep = Vec::new();
    for p in &pres {
        keep.extend(prepare(p, &env));
    }
    let out_existed = env.out.exists();
    let args: Vec<String> = case.cmd.split_whitespace().map(|a| env.subst(a)).collect();
    let o = run_limited(&args, &env.r);
    let err = &o.stderr;
    let fail = |why: String| {
        Err(format!(
            "{why}\n  command: {}\n  stderr: {err}",
            args.join(" ")
        ))
    };
    if o.timed_out {
        return fail(format!("no answer within {CASE_LIMIT:?} (a hang)"));
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
    Ok(o.elapsed)
}

#[test]
fn every_hostile_input_is_refused_fast_and_cleanly() {
    let h = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/hostile")
        .canonicalize()
        .unwrap();
    let cases = parse_cases(&std::fs::read_to_string(h.join("cases.txt")).unwrap());
    assert!(cases.len() >= 150, "{} cases", cases.len());
    let mut ids = std::collections::HashSet::new();
    for c in &cases {
        assert!(ids.insert(c.id.clone()), "duplicate case id {}", c.id);
    }
    // two workers: the cases are independent
    let chunks: Vec<Vec<&Case>> = (0..2)
        .map(|w| cases.iter().skip(w).step_by(2).collect())
        .collect();
    let results: Vec<(String, Result<Duration, String>)> = std::thread::scope(|s| {
        let hs: Vec<_> = chunks
            .iter()
            .map(|chunk| {
                let h = &h;
                s.spawn(move || {
                    chunk
                        .iter()
                        .map(|c| (c.id.clone(), run_case(c, h)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        hs.into_iter().flat_map(|j| j.join().unwrap()).collect()
    });
    let failures: Vec<String> = results
        .iter()
        .filter_map(|(id, r)| r.as_ref().err().map(|e| format!("case {id}: {e}")))
        .collect();
    let slowest = results
        .iter()
        .filter_map(|(id, r)| r.as_ref().ok().map(|d| (*d, id.clone())))
        .max();
    assert!(
        failures.is_empty(),
        "{} of {} hostile cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
    let (d, id) = slowest.unwrap();
    assert!(
        d < Duration::from_secs(3),
        "slowest refusal: {id} took {d:?}"
    );
}
