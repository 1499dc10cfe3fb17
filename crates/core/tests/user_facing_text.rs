//! What users read speaks of the software, not of how it was made: README, docs, source comments,
//! tests, benches, examples, scenario and parameter files, the Python package and the CI scripts carry
//! no numbered work sessions or issues, no branch names, no dates of work and no "bar" meaning a
//! target (the bar the robot grips is the only bar). This test scans those files and names every line
//! that does.

use std::path::{Path, PathBuf};

/// Phrases where "bar" means a target rather than the bar the robot grips.
const TARGET_BAR: &[&str] = &[
    "mm bar",
    "ms bar",
    "replay bar",
    "accuracy bar",
    "speed bar",
    "timing bar",
    "the issue's",
    "bar's accuracy",
    "bars' accuracy",
    "bar met",
    "bars met",
    "bar is met",
    "bar's mesh",
    "bar's re-planning",
    "bars (median",
    "bars of a refusal",
    "traverse bar",
    "bar: <=",
    "(bar 1e",
    "part of the bar",
];

fn is_word_char(c: Option<char>) -> bool {
    c.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// `word` (lower case) as a whole word in `line` (lower case), optionally plural.
fn has_word(line: &str, word: &str) -> bool {
    line.match_indices(word).any(|(i, _)| {
        let before = line[..i].chars().next_back();
        let rest = &line[i + word.len()..];
        let rest = rest.strip_prefix('s').unwrap_or(rest);
        !is_word_char(before) && !is_word_char(rest.chars().next())
    })
}

/// "issue 14", "issues 13", "issue #14", "issue#14".
fn numbered_issue(line: &str) -> bool {
    line.match_indices("issue").any(|(i, _)| {
        let before = line[..i].chars().next_back();
        let rest = &line[i + 5..];
        let rest = rest.strip_prefix('s').unwrap_or(rest);
        let rest = rest.trim_start_matches(|c: char| c == '_' || c.is_whitespace());
        let rest = rest.strip_prefix('#').unwrap_or(rest).trim_start();
        !is_word_char(before) && rest.starts_with(|c: char| c.is_ascii_digit())
    })
}

/// A date such as 2026-12-03.
fn date(line: &str) -> bool {
    let b = line.as_bytes();
    (0..b.len().saturating_sub(9)).any(|i| {
        let w = &b[i..i + 10];
        w[0] == b'2'
            && w[1] == b'0'
            && w[2..4].iter().all(u8::is_ascii_digit)
            && w[4] == b'-'
            && w[5..7].iter().all(u8::is_ascii_digit)
            && w[7] == b'-'
            && w[8..10].iter().all(u8::is_ascii_digit)
    })
}

/// Why `line` speaks of the work rather than the software, if it does.
fn process_word(line: &str) -> Option<&'static str> {
    // pytest's fixture scope is the test run, not a work session
    let l = line.to_lowercase().replace("scope=\"session\"", "");
    if has_word(&l, "session") || l.contains("session_") {
        return Some("a work session");
    }
    if numbered_issue(&l) {
        return Some("a numbered issue");
    }
    if l.contains("branch `") {
        return Some("a branch name");
    }
    if date(&l) {
        return Some("a date of work");
    }
    if TARGET_BAR.iter().any(|p| contains_phrase(&l, p)) {
        return Some("\"bar\" as a target");
    }
    None
}

fn scanned(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    matches!(ext, "md" | "rs" | "toml" | "py" | "pyi" | "txt" | "sh")
        || (path.parent().and_then(Path::file_name) == Some(std::ffi::OsStr::new(".ci"))
            && ext.is_empty())
        || name == "README"
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name();
        let name = name.to_str().unwrap_or("");
        if p.is_dir() {
            if !matches!(name, "target" | ".git" | "node_modules" | "__pycache__")
                && !name.starts_with(".venv")
            {
                walk(&p, out);
            }
        } else if scanned(&p) {
            out.push(p);
        }
    }
}

#[test]
fn no_words_of_the_work_in_what_users_read() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let root = root.canonicalize().expect("workspace root");
    let mut files = vec![root.join("README.md")];
    for dir in ["docs", "scenarios", "params", "python", "crates", ".ci"] {
        walk(&root.join(dir), &mut files);
    }
    let this = Path::new(file!()).file_name().expect("file name");
    let mut hits = Vec::new();
    let mut read = 0;
    for f in &files {
        if f.file_name() == Some(this) {
            continue; // the patterns themselves
        }
        let Ok(text) = std::fs::read_to_string(f) else {
            continue; // not text
        };
        read += 1;
        for (i, line) in text.lines().enumerate() {
            if let Some(why) = process_word(line) {
                let rel = f.strip_prefix(&root).unwrap_or(f);
                hits.push(format!(
                    "{}:{}: {why}: {}",
                    rel.display(),
                    i + 1,
                    line.trim()
                ));
            }
        }
    }
    assert!(
        read > 100,
        "only {read} files scanned under {}",
        root.display()
    );
    assert!(
        hits.is_empty(),
        "{} lines speak of the work, not the software:\n{}",
        hits.len(),
        hits.join("\n")
    );
}

#[test]
fn the_scan_tells_the_bar_gripped_from_a_target() {
    assert!(process_word("the robot grips the bar at x = 1 m").is_none());
    assert!(process_word("the EE ends 7.5 mm from the bar").is_none());
    assert!(process_word("@pytest.fixture(scope=\"session\")").is_none());
    assert!(process_word("Tracking under noise (issue 13): the filter").is_some());
    assert!(process_word("since Session 18 the planner").is_some());
    assert!(process_word("the replay stays within the 1 mm bar").is_some());
    assert!(process_word("the slacks' part of the barrier function").is_none());
    assert!(process_word("measured 2026-12-03 on the idle host").is_some());
    assert!(process_word("(branch `mpcfast`)").is_some());
    assert!(process_word("the issues of the solver").is_none());
    assert!(process_word("fn issue_14_ladder_completes()").is_some());
    assert!(process_word("fn since_session_12_warm()").is_some());
}

#[test]
fn every_cell_of_the_readme_tables_is_short() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let mut long = Vec::new();
    for (i, line) in readme.lines().enumerate() {
        if !line.starts_with('|') {
            continue;
        }
        for cell in line.trim().trim_matches('|').split('|') {
            let chars = cell.trim().chars().count();
            if chars > 300 {
                long.push(format!("README.md:{}: a cell of {chars} characters", i + 1));
            }
        }
    }
    assert!(
        long.is_empty(),
        "table cells over 300 characters:\n{}",
        long.join("\n")
    );
}

/// `phrase` occurs in `line` as whole words at its end (a phrase ending in "bar" does not match
/// "barrier").
fn contains_phrase(line: &str, phrase: &str) -> bool {
    line.match_indices(phrase).any(|(i, _)| {
        let end_is_word = phrase.ends_with(|c: char| c.is_alphanumeric());
        !end_is_word
            || !line[i + phrase.len()..]
                .chars()
                .next()
                .is_some_and(char::is_alphanumeric)
    })
}
