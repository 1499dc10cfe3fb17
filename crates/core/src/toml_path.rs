//! The dotted path of the field a TOML error points at (`tracking.replan.threshold_m`,
//! `links[2].mass`), so that a parse error of a parameters or scenario file names the field as the
//! user wrote it beside the parser's line, column and text.
//!
//! The parser reports where in the text the error lies (a byte span: the value of a wrong type, the
//! key of an unknown field, the table that lacks a field); [`key_path`] finds the innermost key or
//! value whose span holds the start of that span in the document's tree.

use crate::error::Error;
use std::ops::Range;
use toml_edit::{Item, Table, Value};

/// The [`Error::Parse`] of a TOML error `e` of the text `text` read from `source`: the parser's
/// message (line, column, the offending text) on one line, led by `field `PATH`:` when the error's
/// span lies in a field ([`key_path`]).
pub fn toml_error(e: &toml::de::Error, text: &str, source: &str) -> Error {
    let message = e.to_string().trim_end().replace('\n', " ");
    let path = e.span().and_then(|s| key_path(text, s.start));
    Error::Parse {
        path: source.into(),
        message: match path {
            Some(p) => format!("field `{p}`: {message}"),
            None => message,
        },
    }
}

/// The dotted path (`a.b.c`, array entries as `name[i]`) of the innermost key or value of the TOML
/// document `text` whose span holds the byte offset `pos`; `None` when the text does not parse or
/// `pos` lies outside every field.
pub fn key_path(text: &str, pos: usize) -> Option<String> {
    let doc = toml_edit::ImDocument::parse(text).ok()?;
    let mut best: Option<(usize, String)> = None;
    walk_table(doc.as_table(), "", pos, &mut best);
    best.map(|(_, p)| p)
}

/// Keep `path` when `span` holds `pos` and is narrower than the best so far (the document's root,
/// the empty path, names no field).
fn consider(
    span: Option<Range<usize>>,
    path: &str,
    pos: usize,
    best: &mut Option<(usize, String)>,
) {
    let Some(s) = span.filter(|_| !path.is_empty()) else {
        return;
    };
    let holds = s.start <= pos && pos < s.end.max(s.start + 1);
    if holds && best.as_ref().is_none_or(|(w, _)| s.len() <= *w) {
        *best = Some((s.len(), path.to_string()));
    }
}

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

fn walk_table(t: &Table, prefix: &str, pos: usize, best: &mut Option<(usize, String)>) {
    consider(t.span(), prefix, pos, best);
    for (k, item) in t.iter() {
        let path = join(prefix, k);
        consider(t.key(k).and_then(|k| k.span()), &path, pos, best);
        walk_item(item, &path, pos, best);
    }
}

fn walk_item(item: &Item, path: &str, pos: usize, best: &mut Option<(usize, String)>) {
    match item {
        Item::None => {}
        Item::Value(v) => walk_value(v, path, pos, best),
        Item::Table(t) => walk_table(t, path, pos, best),
        Item::ArrayOfTables(a) => {
            for (i, t) in a.iter().enumerate() {
                walk_table(t, &format!("{path}[{i}]"), pos, best);
            }
        }
    }
}

fn walk_value(v: &Value, path: &str, pos: usize, best: &mut Option<(usize, String)>) {
    consider(v.span(), path, pos, best);
    match v {
        Value::Array(a) => {
            for (i, e) in a.iter().enumerate() {
                walk_value(e, &format!("{path}[{i}]"), pos, best);
            }
        }
        Value::InlineTable(t) => {
            for (k, e) in t.iter() {
                let p = join(path, k);
                consider(t.key(k).and_then(|k| k.span()), &p, pos, best);
                walk_value(e, &p, pos, best);
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Replan {
        threshold_m: f64,
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Tracking {
        replan: Replan,
        #[serde(default)]
        gains: Vec<f64>,
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Link {
        mass: f64,
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Doc {
        #[serde(default)]
        name: String,
        tracking: Option<Tracking>,
        #[serde(default)]
        links: Vec<Link>,
    }

    fn err(text: &str) -> String {
        let e = toml::from_str::<Doc>(text).unwrap_err();
        toml_error(&e, text, "s.toml").to_string()
    }

    #[test]
    fn a_type_error_names_the_dotted_field_in_every_toml_spelling() {
        for text in [
            "[tracking.replan]\nthreshold_m = \"x\"\n",
            "[tracking]\nreplan = { threshold_m = \"x\" }\n",
            "[tracking]\nreplan.threshold_m = \"x\"\n",
            "tracking = { replan = { threshold_m = \"x\" } }\n",
        ] {
            let e = err(text);
            assert!(
                e.starts_with("s.toml: field `tracking.replan.threshold_m`: "),
                "{e}"
            );
            // the parser's own line, column and text stay
            assert!(e.contains("line ") && e.contains("\"x\""), "{e}");
        }
        let e = err("[[links]]\nmass = 1.0\n[[links]]\nmass = 2.0\n[[links]]\nmass = true\n");
        assert!(e.contains("field `links[2].mass`"), "{e}");
        let e = err("[tracking]\nreplan = { threshold_m = 0.1 }\ngains = [1.0, \"a\"]\n");
        assert!(e.contains("field `tracking.gains[1]`"), "{e}");
    }

    #[test]
    fn unknown_and_missing_fields_name_where_they_are() {
        let e = err("[tracking.replan]\nthreshold_m = 0.1\nthreshold = 2\n");
        assert!(e.contains("field `tracking.replan.threshold`"), "{e}");
        let e = err("[tracking.replan]\n");
        assert!(
            e.starts_with("s.toml: field `tracking.replan`: ") && e.contains("threshold_m"),
            "{e}"
        );
        // a syntax error has no field: the parser's message alone
        let e = err("name = \n");
        assert!(e.starts_with("s.toml: TOML parse error"), "{e}");
    }

    #[test]
    fn positions_outside_every_field_have_no_path() {
        assert_eq!(key_path("a = 1\n\n# note\n", 8), None);
        assert_eq!(key_path("a = 1\n", 4).as_deref(), Some("a"));
        assert_eq!(key_path("not toml [", 0), None);
    }
}
