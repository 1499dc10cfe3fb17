//! Schema versions of the files brachia writes (docs/formats.md describes each format).
//!
//! Every JSON file of a run folder (report.json, summary.json, scorecard.json, joint_swings.json) is an
//! object with a field `schema_version`; every CSV file starts with a comment line
//! `# brachia KIND schema N` (KIND the file's name without `.csv`, `stick` for `stick_r2_*.csv`) before
//! its header. [`stamp`] adds them as a run folder is queued ([`crate::RunFolder::add`]); the readers
//! ([`json_version`], [`csv_body`]) refuse a file without one (written by an older brachia: re-run it) or
//! with a version this brachia does not know for the file's kind ([`JsonKind`], [`csv_version`]), naming
//! the file, its kind, the version found and the ones supported.

use brachia::Error;

/// The schema version of every JSON and CSV format this brachia writes and reads.
pub const SCHEMA_VERSION: u32 = 1;

/// The schema version of a track run's `report.json` and a benchmark's `scorecard.json`: 2, since
/// `reaches_bar` and `success` mean the capture rule at any time of the run ([`crate::success`]);
/// every other JSON file is at [`SCHEMA_VERSION`]. Readers of those two take 1 to this ([`JsonKind`]).
pub const CAPTURE_SCHEMA_VERSION: u32 = 2;

/// The JSON field holding the schema version.
pub const SCHEMA_FIELD: &str = "schema_version";

const CSV_PREFIX: &str = "# brachia ";

/// The columns a CSV file of the states of an `n`-link chain starts with:
/// `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y` (a simulation's `trajectory.csv`, `traverse.csv`).
pub fn state_columns(n: usize) -> String {
    let mut s = String::from("t");
    for name in ["q", "qd"] {
        for i in 1..=n {
            s.push_str(&format!(",{name}{i}"));
        }
    }
    for i in 2..=n {
        s.push_str(&format!(",tau{i}"));
    }
    s + ",ee_x,ee_y"
}

/// The kind of a CSV file named `name` (its last path part): the name without `.csv`, `stick` for the
/// parameter study's `stick_r2_*.csv`.
pub fn csv_kind(name: &str) -> Option<&str> {
    let base = name.rsplit('/').next().unwrap_or(name);
    let stem = base.strip_suffix(".csv")?;
    Some(if stem.starts_with("stick_r2_") {
        "stick"
    } else {
        stem
    })
}

/// The schema version this brachia writes for CSV files of kind `kind`: [`SCHEMA_VERSION`], except
/// `closed_loop` at 2 (its last column `control_us`, the controller's step time; a schema 1 file,
/// without it, still reads) and the benchmark's `runs` at 2 (`success` is the capture rule at any
/// time of the run, scores up to the capture, and a last column `capture_t_s`).
pub fn csv_version(kind: &str) -> u32 {
    match kind {
        "closed_loop" | "runs" => 2,
        _ => SCHEMA_VERSION,
    }
}

/// The first line of a CSV file of kind `kind`.
pub fn csv_line(kind: &str) -> String {
    format!("{CSV_PREFIX}{kind} schema {}", csv_version(kind))
}

/// `data` of the file `name` with its schema version: a JSON object gets `schema_version` (other JSON
/// and non-JSON files pass unchanged), a CSV file its first comment line. A file that already carries
/// one is unchanged.
pub fn stamp(name: &str, data: Vec<u8>) -> Vec<u8> {
    if name.ends_with(".json") {
        let Ok(serde_json::Value::Object(mut m)) = serde_json::from_slice(&data) else {
            return data;
        };
        if m.contains_key(SCHEMA_FIELD) {
            return data;
        }
        m.insert(SCHEMA_FIELD.into(), SCHEMA_VERSION.into());
        let text = serde_json::to_string_pretty(&serde_json::Value::Object(m));
        return text.map(|t| (t + "\n").into_bytes()).unwrap_or(data);
    }
    if let Some(kind) = csv_kind(name) {
        if data.starts_with(CSV_PREFIX.as_bytes()) {
            return data;
        }
        let mut out = (csv_line(kind) + "\n").into_bytes();
        out.extend_from_slice(&data);
        return out;
    }
    data
}

/// A kind of JSON file brachia writes: each has the schema version it is written at and the oldest
/// version it still reads ([`json_version`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum JsonKind {
    /// A plan run's `report.json` (also `plan/report.json` of a track run).
    PlanReport,
    /// A track run's `report.json`: schema 2 ([`CAPTURE_SCHEMA_VERSION`]), reads 1 and 2.
    TrackReport,
    /// A simulate run's `report.json`.
    SimulateReport,
    /// A traverse's `report.json` (also a reproduction's `ladder/report.json`).
    TraverseReport,
    /// The parameter study's `report.json`.
    StudyReport,
    /// A benchmark's `scorecard.json`: schema 2 ([`CAPTURE_SCHEMA_VERSION`]), reads 1 and 2.
    Scorecard,
    /// A reproduction's `summary.json`.
    Summary,
    /// A reproduction's `ladder/joint_swings.json`.
    JointSwings,
}

impl JsonKind {
    /// What the file is, in words (`a track run's report.json`).
    pub fn name(self) -> &'static str {
        match self {
            JsonKind::PlanReport => "a plan run's report.json",
            JsonKind::TrackReport => "a track run's report.json",
            JsonKind::SimulateReport => "a simulate run's report.json",
            JsonKind::TraverseReport => "a traverse's report.json",
            JsonKind::StudyReport => "the parameter study's report.json",
            JsonKind::Scorecard => "a benchmark's scorecard.json",
            JsonKind::Summary => "a reproduction's summary.json",
            JsonKind::JointSwings => "a reproduction's joint_swings.json",
        }
    }

    /// The schema version this brachia writes for the kind.
    pub fn version(self) -> u32 {
        match self {
            JsonKind::TrackReport | JsonKind::Scorecard => CAPTURE_SCHEMA_VERSION,
            _ => SCHEMA_VERSION,
        }
    }

    /// The oldest schema version of the kind this brachia still reads (every version from it to
    /// [`JsonKind::version`] reads).
    pub fn oldest(self) -> u32 {
        SCHEMA_VERSION
    }
}

fn supported(oldest: u32, newest: u32) -> String {
    if oldest == newest {
        format!("schema {newest}")
    } else {
        format!("schema {oldest} to {newest}")
    }
}

fn older(file: &str, field: &str, what: &str, reads: &str) -> Error {
    Error::invalid(
        file,
        field,
        "missing",
        format!(
            "{what} without a schema version: it was written by an older brachia (before versioned \
             outputs); run the command that wrote it again (this brachia reads {reads})"
        ),
    )
}

fn unknown(file: &str, field: &str, found: impl ToString, what: &str, reads: &str) -> Error {
    Error::invalid(
        file,
        field,
        found,
        format!(
            "unknown schema version of {what}: this brachia reads {reads}; the file was \
             written by another version of brachia (run the command that wrote it again)"
        ),
    )
}

/// Check the `schema_version` of the JSON value read from `file`, a file of kind `kind`: from
/// [`JsonKind::oldest`] to [`JsonKind::version`]. The error names the file, the kind, the version
/// found and the versions supported.
pub fn json_version(value: &serde_json::Value, file: &str, kind: JsonKind) -> Result<(), Error> {
    let reads = supported(kind.oldest(), kind.version());
    let Some(m) = value.as_object() else {
        return Err(Error::invalid(
            file,
            "(the file)",
            "not a JSON object",
            format!("{} is an object with a field {SCHEMA_FIELD}", kind.name()),
        ));
    };
    let range = u64::from(kind.oldest())..=u64::from(kind.version());
    match m.get(SCHEMA_FIELD) {
        None => Err(older(file, SCHEMA_FIELD, kind.name(), &reads)),
        Some(v) if v.as_u64().is_some_and(|k| range.contains(&k)) => Ok(()),
        Some(v) => Err(unknown(file, SCHEMA_FIELD, v, kind.name(), &reads)),
    }
}

/// The CSV text after its schema line, checked to be `# brachia KIND schema N` for the `kind` of file
/// `file`, N from 1 to the version this brachia writes ([`csv_version`]).
pub fn csv_body<'a>(text: &'a str, file: &str, kind: &str) -> Result<&'a str, Error> {
    let (first, rest) = text.split_once('\n').unwrap_or((text, ""));
    let first = first.trim_end_matches('\r');
    let Some(tail) = first.strip_prefix(CSV_PREFIX) else {
        return Err(older(
            file,
            "line 1 (schema line)",
            &format!("a {kind} CSV file"),
            &supported(1, csv_version(kind)),
        ));
    };
    let want = format!("{kind} schema ");
    let Some(v) = tail.strip_prefix(&want) else {
        return Err(Error::invalid(
            file,
            "line 1 (schema line)",
            first.chars().take(80).collect::<String>(),
            format!("expected `{}`", csv_line(kind)),
        ));
    };
    match v.trim().parse::<u32>() {
        Ok(k) if (1..=csv_version(kind)).contains(&k) => Ok(rest),
        _ => Err(unknown(
            file,
            "line 1 (schema line)",
            v.trim(),
            &format!("a {kind} CSV file"),
            &supported(1, csv_version(kind)),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamped_files_read_back_and_other_versions_are_refused() {
        let csv = stamp("plan/trajectory.csv", b"t,q1\n0,1\n".to_vec());
        let text = String::from_utf8(csv.clone()).unwrap();
        assert_eq!(csv_body(&text, "f", "trajectory").unwrap(), "t,q1\n0,1\n");
        // idempotent: a copied file is not stamped twice
        assert_eq!(stamp("trajectory.csv", csv.clone()), csv);
        assert_eq!(csv_kind("stick_r2_0p5.csv"), Some("stick"));
        let e = csv_body("t,q1\n", "f.csv", "trajectory")
            .unwrap_err()
            .to_string();
        assert!(e.contains("older brachia") && e.contains("f.csv"), "{e}");
        let e = csv_body("# brachia trajectory schema 7\nt\n", "f.csv", "trajectory")
            .unwrap_err()
            .to_string();
        assert!(e.contains('7') && e.contains("schema 1"), "{e}");
        assert!(csv_body("# brachia cells schema 1\nt\n", "f.csv", "trajectory").is_err());
        // closed_loop.csv is written at schema 2 and read at 1 and 2
        let cl = stamp("closed_loop.csv", b"t\n".to_vec());
        assert!(cl.starts_with(b"# brachia closed_loop schema 2\n"));
        for v in ["1", "2"] {
            let text = format!("# brachia closed_loop schema {v}\nt\n");
            assert_eq!(csv_body(&text, "f.csv", "closed_loop").unwrap(), "t\n");
        }
        assert!(csv_body(
            "# brachia closed_loop schema 3\nt\n",
            "f.csv",
            "closed_loop"
        )
        .is_err());
        assert!(csv_body("# brachia trajectory schema 2\nt\n", "f.csv", "trajectory").is_err());

        let js = stamp("report.json", b"{\"a\": 1}".to_vec());
        let v: serde_json::Value = serde_json::from_slice(&js).unwrap();
        assert!(json_version(&v, "r.json", JsonKind::PlanReport).is_ok());
        let e = json_version(&serde_json::json!({"a": 1}), "r.json", JsonKind::PlanReport)
            .unwrap_err()
            .to_string();
        assert!(e.contains("older brachia") && e.contains("r.json"), "{e}");
        assert!(json_version(&serde_json::json!([1]), "r.json", JsonKind::Summary).is_err());
        // the benchmark's runs.csv is written at schema 2
        let runs = stamp(
            "bench/runs.csv",
            b"controller
"
            .to_vec(),
        );
        assert!(runs.starts_with(b"# brachia runs schema 2\n"));
        // other files pass unchanged
        assert_eq!(stamp("params.toml", b"x = 1\n".to_vec()), b"x = 1\n");
    }

    const KINDS: [JsonKind; 8] = [
        JsonKind::PlanReport,
        JsonKind::TrackReport,
        JsonKind::SimulateReport,
        JsonKind::TraverseReport,
        JsonKind::StudyReport,
        JsonKind::Scorecard,
        JsonKind::Summary,
        JsonKind::JointSwings,
    ];

    #[test]
    fn each_json_kind_reads_its_own_versions_only() {
        let at = |v: u32| serde_json::json!({ "schema_version": v, "a": 1 });
        for kind in KINDS {
            for v in 0..=4 {
                let read = json_version(&at(v), "d/report.json", kind);
                let want = (kind.oldest()..=kind.version()).contains(&v);
                assert_eq!(read.is_ok(), want, "{kind:?} at schema {v}: {read:?}");
                if let Err(e) = read {
                    let e = e.to_string();
                    assert!(e.contains("d/report.json"), "{e}");
                    assert!(e.contains(kind.name()), "{e}");
                    assert!(e.contains(&format!("= {v}")), "{e}");
                }
            }
        }
        // the capture rule moved a track report and a scorecard to 2; both still read 1
        for kind in [JsonKind::TrackReport, JsonKind::Scorecard] {
            assert_eq!((kind.oldest(), kind.version()), (1, CAPTURE_SCHEMA_VERSION));
            let e = json_version(&at(3), "s.json", kind)
                .unwrap_err()
                .to_string();
            assert!(e.contains("schema 1 to 2"), "{e}");
        }
        // every other kind is at 1 alone: a report claiming 2 is refused, naming what it is
        let e = json_version(&at(2), "p/report.json", JsonKind::PlanReport)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("a plan run's report.json")
                && e.contains("reads schema 1;")
                && e.contains("schema_version` = 2"),
            "{e}"
        );
        let e = json_version(
            &serde_json::json!({"a": 1}),
            "t.json",
            JsonKind::TrackReport,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("a track run's report.json") && e.contains("schema 1 to 2"),
            "{e}"
        );
    }
}
