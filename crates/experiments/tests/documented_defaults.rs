//! Documented defaults are the defaults: for every settings struct a user writes in a scenario or a
//! settings file, each field's doc comment states its default ("Default X." or "(default X)"), and
//! that value is the one `Default` gives. The struct's source is read with a small parser (the field
//! docs and names), `Default` is serialised with serde, and the two are compared field by field.
//! Fields that hold a nested settings struct are checked as structs of their own.

use serde::Serialize;
use serde_json::Value;
use std::path::Path;

/// A documented default, as read from a doc comment.
#[derive(Debug, Clone, PartialEq)]
enum Documented {
    Number(f64),
    Bool(bool),
    /// `none`, `None`, "empty": no value (null, an absent key, an empty list or string).
    Nothing,
    /// A word or an enum variant (`MuStrategy::Monotone` is `Monotone`), compared with the
    /// serialised name ignoring case, `-` and `_`.
    Word(String),
    List(Vec<f64>),
}

/// One field of a struct: its Rust name, its serialised name and its doc comment.
struct Field {
    name: String,
    key: String,
    doc: String,
}

/// The fields of `pub struct NAME {` in `src`, with their joined doc comments.
fn fields(src: &str, name: &str) -> Vec<Field> {
    let open = format!("pub struct {name} {{");
    let start = src
        .find(&open)
        .unwrap_or_else(|| panic!("`{open}` not found"));
    let mut out = Vec::new();
    let mut doc = String::new();
    let mut rename: Option<String> = None;
    for line in src[start + open.len()..].lines() {
        let t = line.trim();
        if t.starts_with('}') {
            break;
        }
        if let Some(d) = t.strip_prefix("///") {
            doc.push(' ');
            doc.push_str(d.trim());
        } else if t.starts_with("#[serde(") {
            if let Some(i) = t.find("rename = \"") {
                let rest = &t[i + 10..];
                rename = rest.split('"').next().map(str::to_string);
            }
        } else if let Some(decl) = t.strip_prefix("pub ") {
            let field = decl.split(':').next().unwrap_or("").trim().to_string();
            out.push(Field {
                key: rename.take().unwrap_or_else(|| field.clone()),
                name: field,
                doc: std::mem::take(&mut doc).trim().to_string(),
            });
        }
    }
    out
}

fn number(s: &str) -> Option<f64> {
    let s = s.trim();
    match s {
        "pi" => Some(std::f64::consts::PI),
        "-pi" => Some(-std::f64::consts::PI),
        _ => s.parse().ok(),
    }
}

fn list(inner: &str) -> Option<Documented> {
    let parts: Vec<&str> = inner.split(',').map(str::trim).collect();
    if parts.len() == 4 && parts[2] == "..." {
        // an arithmetic sequence a, b, ..., z
        let (a, b, z) = (number(parts[0])?, number(parts[1])?, number(parts[3])?);
        let step = b - a;
        let count = ((z - a) / step).round() as i64;
        return Some(Documented::List(
            (0..=count).map(|i| a + step * i as f64).collect(),
        ));
    }
    parts
        .iter()
        .map(|p| number(p))
        .collect::<Option<Vec<f64>>>()
        .map(Documented::List)
}

/// Reads a literal: a number, true/false, none, a quoted word, a bracketed list or a word.
fn literal(s: &str) -> Option<Documented> {
    let s = s.trim();
    let bare = s.trim_matches('"');
    match bare {
        "true" => return Some(Documented::Bool(true)),
        "false" => return Some(Documented::Bool(false)),
        "none" | "None" | "empty" => return Some(Documented::Nothing),
        _ => {}
    }
    if let Some(v) = number(bare) {
        return Some(Documented::Number(v));
    }
    if let Some(inner) = s
        .strip_prefix('[')
        .and_then(|r| r.strip_suffix(']'))
        .or_else(|| s.strip_prefix('(').and_then(|r| r.strip_suffix(')')))
    {
        return list(inner);
    }
    let word = bare.rsplit("::").next().unwrap_or(bare);
    if !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        return Some(Documented::Word(word.to_string()));
    }
    None
}

/// The value that follows "Default " / "(default ": `` `lit` ``, ``[`Path`]``, ``[`CONST`] = v``,
/// `[a, b]`, `(a, b)`, `a, b, ..., z`, or one word or number (a final period dropped).
fn value_after(text: &str) -> Option<Documented> {
    let t = text.trim_start();
    if let Some(rest) = t.strip_prefix("[`") {
        let (path, after) = rest.split_once("`]")?;
        if let Some(v) = after.trim_start().strip_prefix("= ") {
            return value_after(v);
        }
        return literal(path);
    }
    if let Some(rest) = t.strip_prefix('`') {
        return literal(rest.split('`').next()?);
    }
    if t.starts_with('[') || t.starts_with('(') {
        let close = if t.starts_with('[') { ']' } else { ')' };
        let end = t.find(close)?;
        return literal(&t[..=end]);
    }
    let seq: Vec<&str> = t.splitn(5, ", ").collect();
    if seq.len() >= 4 && seq[2] == "..." {
        let last = seq[3]
            .split(|c: char| c.is_whitespace())
            .next()?
            .trim_end_matches(['.', ';', ')']);
        return list(&format!("{}, {}, ..., {}", seq[0], seq[1], last));
    }
    let word = t.split(|c: char| c.is_whitespace() || c == ',' || c == ';' || c == ')');
    let word = word.into_iter().next()?;
    let word = word.trim_end_matches(['.', ':']);
    literal(word)
}

/// The field's documented default: the first "Default X" beginning a sentence, else "(default X",
/// "; default X" or ", default X".
fn documented(doc: &str) -> Option<Result<Documented, String>> {
    let mut at = None;
    for (i, _) in doc.match_indices("Default ") {
        let before = doc[..i].trim_end();
        if i == 0 || before.ends_with('.') || before.ends_with(';') || before.ends_with('(') {
            at = Some(i + "Default ".len());
            break;
        }
    }
    for lead in ["(default ", "; default ", ", default "] {
        if at.is_none() {
            at = doc.find(lead).map(|i| i + lead.len());
        }
    }
    let at = at?;
    Some(value_after(&doc[at..]).ok_or_else(|| doc[at..].chars().take(60).collect()))
}

fn norm(s: &str) -> String {
    s.chars()
        .filter(|c| *c != '-' && *c != '_')
        .flat_map(char::to_lowercase)
        .collect()
}

fn agrees(doc: &Documented, v: Option<&Value>) -> bool {
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs()) + 1e-15;
    match (doc, v) {
        (Documented::Nothing, None | Some(Value::Null)) => true,
        (Documented::Nothing, Some(Value::Array(a))) => a.is_empty(),
        (Documented::Nothing, Some(Value::String(s))) => s.is_empty(),
        (Documented::Number(x), Some(Value::Number(n))) => {
            close(*x, n.as_f64().unwrap_or(f64::NAN))
        }
        (Documented::Bool(b), Some(Value::Bool(c))) => b == c,
        (Documented::Word(w), Some(Value::String(s))) => norm(w) == norm(s),
        (Documented::Word(w), Some(Value::Object(o))) => {
            o.len() == 1 && o.keys().all(|k| norm(k) == norm(w))
        }
        (Documented::List(xs), Some(Value::Array(a))) => {
            xs.len() == a.len()
                && xs
                    .iter()
                    .zip(a)
                    .all(|(x, v)| v.as_f64().is_some_and(|y| close(*x, y)))
        }
        _ => false,
    }
}

/// Every field of `name` (in `file`, relative to the workspace) against `default` serialised:
/// the list of disagreements, missing or unreadable documented defaults. `skipped` gives the values
/// of fields that serde leaves out at their default (`skip_serializing_if`).
fn check<T: Serialize>(
    file: &str,
    name: &str,
    default: &T,
    skipped: &[(&str, Value)],
) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let src = std::fs::read_to_string(root.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
    let json = serde_json::to_value(default).expect("settings serialise");
    let mut obj = json
        .as_object()
        .expect("a settings struct serialises to a map")
        .clone();
    for (key, value) in skipped {
        assert!(!obj.contains_key(*key), "{name}::{key} is serialised");
        obj.insert(key.to_string(), value.clone());
    }
    let fields = fields(&src, name);
    assert!(!fields.is_empty(), "{file}: no fields read for {name}");
    let mut problems = Vec::new();
    for f in fields {
        let value = obj.get(&f.key);
        match documented(&f.doc) {
            // a nested settings struct: checked as a struct of its own
            _ if matches!(value, Some(Value::Object(o)) if o.len() > 1) => {}
            None => problems.push(format!(
                "{file}: {name}::{} documents no default (Default gives {})",
                f.name,
                value.map_or("nothing".to_string(), Value::to_string)
            )),
            Some(Err(text)) => problems.push(format!(
                "{file}: {name}::{}: unreadable documented default \"{text}\"",
                f.name
            )),
            Some(Ok(doc)) if !agrees(&doc, value) => problems.push(format!(
                "{file}: {name}::{} is documented as {doc:?}, Default gives {}",
                f.name,
                value.map_or("nothing".to_string(), Value::to_string)
            )),
            Some(Ok(_)) => {}
        }
    }
    problems
}

#[test]
fn every_settings_field_documents_the_default_it_has() {
    use brachia::control::{
        BoxQpSettings, EstimatorSettings, MpcSettings, ParamEstimatorSettings, PdSettings,
        ReplanSettings, TvlqrSettings,
    };
    use brachia::planning::{Bounds, NlpSettings, PlannerSettings, ShootingSettings};
    use brachia::sim::{Disturbances, NoiseSettings, RunSettings};
    use brachia_experiments::parameter_study::ParameterStudySettings;
    use brachia_experiments::scenario::{PlantSettings, TrackingSettings};

    let mut problems = Vec::new();
    let core = "crates/core/src";
    problems.extend(check(
        "crates/ocp/src/settings.rs",
        "OcpSettings",
        &brachia_ocp::OcpSettings::default(),
        &[],
    ));
    let s = &format!("{core}/planning/settings.rs");
    let planner = PlannerSettings::default();
    let starts = serde_json::json!(planner.swing_time_starts);
    problems.extend(check(
        s,
        "PlannerSettings",
        &planner,
        &[("swing_time_starts", starts)],
    ));
    problems.extend(check(
        s,
        "ShootingSettings",
        &ShootingSettings::default(),
        &[],
    ));
    problems.extend(check(s, "Bounds", &Bounds::default(), &[]));
    let nlp = &format!("{core}/planning/nlp/problem.rs");
    problems.extend(check(nlp, "NlpSettings", &NlpSettings::default(), &[]));
    let c = |f: &str| format!("{core}/control/{f}.rs");
    problems.extend(check(
        &c("mpc"),
        "MpcSettings",
        &MpcSettings::default(),
        &[],
    ));
    problems.extend(check(
        &c("boxqp"),
        "BoxQpSettings",
        &BoxQpSettings::default(),
        &[],
    ));
    problems.extend(check(
        &c("tvlqr"),
        "TvlqrSettings",
        &TvlqrSettings::default(),
        &[],
    ));
    problems.extend(check(
        &c("estimator"),
        "EstimatorSettings",
        &EstimatorSettings::default(),
        &[],
    ));
    problems.extend(check(
        &c("replanning"),
        "ReplanSettings",
        &ReplanSettings::default(),
        &[],
    ));
    problems.extend(check(
        &c("param_estimator"),
        "ParamEstimatorSettings",
        &ParamEstimatorSettings::default(),
        &[],
    ));
    problems.extend(check(
        &c("baselines"),
        "PdSettings",
        &PdSettings::default(),
        &[],
    ));
    let sim = |f: &str| format!("{core}/sim/{f}.rs");
    problems.extend(check(
        &sim("runner"),
        "RunSettings",
        &RunSettings::default(),
        &[],
    ));
    problems.extend(check(
        &sim("noisy"),
        "NoiseSettings",
        &NoiseSettings::default(),
        &[],
    ));
    problems.extend(check(
        &sim("disturbances"),
        "Disturbances",
        &Disturbances::default(),
        &[],
    ));
    let run = "crates/run/src";
    problems.extend(check(
        &format!("{run}/scenario.rs"),
        "TrackingSettings",
        &TrackingSettings::default(),
        &[],
    ));
    problems.extend(check(
        &format!("{run}/scenario.rs"),
        "PlantSettings",
        &PlantSettings::default(),
        &[],
    ));
    problems.extend(check(
        "crates/experiments/src/parameter_study.rs",
        "ParameterStudySettings",
        &ParameterStudySettings::default(),
        &[],
    ));
    problems.extend(check(
        &format!("{run}/gym/mod.rs"),
        "SwingEnvSettings",
        &brachia_experiments::gym::SwingEnvSettings::default(),
        &[],
    ));
    problems.extend(check(
        &format!("{run}/gym/reward.rs"),
        "RewardWeights",
        &brachia_experiments::gym::RewardWeights::default(),
        &[],
    ));
    problems.extend(check(
        "crates/rapier-plant/src/settings.rs",
        "RapierSettings",
        &brachia_rapier::RapierSettings::default(),
        &[],
    ));
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_reader_finds_a_wrong_default() {
    // the parser itself: a doc that disagrees with the serialised value is caught
    let src = "pub struct S {\n    /// A tolerance. Default 1e-9.\n    pub a: f64,\n    /// A flag (default true).\n    pub b: bool,\n    /// Grid. Default -0.5, -0.4, ..., 0.5.\n    pub c: Vec<f64>,\n}\n";
    let f = fields(src, "S");
    assert_eq!(f.len(), 3);
    let a = documented(&f[0].doc).unwrap().unwrap();
    assert!(!agrees(&a, Some(&serde_json::json!(1e-2))));
    assert!(agrees(&a, Some(&serde_json::json!(1e-9))));
    let b = documented(&f[1].doc).unwrap().unwrap();
    assert!(agrees(&b, Some(&serde_json::json!(true))));
    let c = documented(&f[2].doc).unwrap().unwrap();
    assert!(agrees(
        &c,
        Some(&serde_json::json!([
            -0.5, -0.4, -0.3, -0.2, -0.1, 0.0, 0.1, 0.2, 0.3, 0.4, 0.5
        ]))
    ));
}
