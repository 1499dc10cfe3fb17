//! Running the CLI in the tests: a command's outcome checked with its stderr shown, a command
//! interrupted with SIGINT, the plan folder of the tracking swing, a folder's files, the data a page
//! embeds.

use super::brachia;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The stderr of `o`, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).to_string()
}

/// Run `cmd` to its end and check that it exits with `code` (the stderr is shown when not).
pub fn run_expect(cmd: &mut Command, code: i32) -> Output {
    let o = cmd.output().unwrap();
    assert_eq!(o.status.code(), Some(code), "{}", stderr(&o));
    o
}

/// Run `cmd` to its end and check that it exits 0.
pub fn run_ok(cmd: &mut Command) -> Output {
    run_expect(cmd, 0)
}

/// `brachia view DIR`, with its exit code and stderr.
pub fn view(dir: &Path) -> (Option<i32>, String) {
    let o = brachia().arg("view").arg(dir).output().unwrap();
    (o.status.code(), stderr(&o))
}

/// `brachia plan` of scenarios/tracking.toml into `dir/name` (with the options `extra`), exit 0.
pub fn tracking_plan(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    run_ok(
        brachia()
            .arg("plan")
            .args(extra)
            .args(["--scenario", "scenarios/tracking.toml", "--out"])
            .arg(&out),
    );
    out
}

/// Every file directly under `dir` with its contents, sorted by name.
pub fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        if e.file_type().unwrap().is_file() {
            out.push((
                e.file_name().to_string_lossy().to_string(),
                std::fs::read(e.path()).unwrap(),
            ));
        }
    }
    out.sort();
    out
}

/// The JSON embedded in the page text `page`.
pub fn page_data(page: &str) -> serde_json::Value {
    let start = page.find("id=\"brachia-data\">").unwrap() + "id=\"brachia-data\">".len();
    let end = start + page[start..].find("</script>").unwrap();
    serde_json::from_str(&page[start..end]).unwrap()
}

/// The JSON embedded in `dir/view.html`.
pub fn folder_page_data(dir: &Path) -> serde_json::Value {
    page_data(&std::fs::read_to_string(dir.join("view.html")).unwrap())
}

/// Start `cmd`, send SIGINT after `after`, and return its exit code, the time from the signal to the
/// exit, and its stderr.
pub fn interrupt(mut cmd: Command, after: Duration) -> (Option<i32>, Duration, String) {
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(after);
    assert!(
        child.try_wait().unwrap().is_none(),
        "the command ended before it was interrupted: the test needs longer work"
    );
    let sent = Instant::now();
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    let took = sent.elapsed();
    (
        out.status.code(),
        took,
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}
