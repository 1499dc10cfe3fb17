//! Numbers that may not be finite, read back from JSON. JSON has no infinity or NaN: serde_json
//! writes such a value as `null`. A field read with these functions takes `null` as
//! `f64::INFINITY` (a diverged or failed prediction, an unknown error), so a report that holds one
//! reads back instead of failing to parse (docs/formats.md, "Values that are not finite").
//!
//! [`from_value`] reads a whole report so (every number at any depth); [`number`], [`opt_number`]
//! and [`opt_pair`] read one field so, also where the report is read with plain serde_json.

use serde::de::{DeserializeOwned, Deserializer};
use serde::Deserialize;

mod value;
pub use value::from_value;

/// A field read with [`from_value`] (with `#[serde(deserialize_with =
/// "brachia::serde_nonfinite::lenient")]`): for a flattened field, whose numbers serde buffers
/// before they are read, so that a `null` among them is still read as infinite.
pub fn lenient<'de, D: Deserializer<'de>, T: DeserializeOwned>(d: D) -> Result<T, D::Error> {
    from_value(serde_json::Value::deserialize(d)?).map_err(serde::de::Error::custom)
}

/// A number, or `null` read as `f64::INFINITY` (with `#[serde(deserialize_with =
/// "brachia::serde_nonfinite::number")]`).
pub fn number<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::INFINITY))
}

/// [`number`] for an optional field (with `#[serde(default, deserialize_with =
/// "brachia::serde_nonfinite::opt_number")]`): absent is `None`, `null` is `Some(INFINITY)`.
pub fn opt_number<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    number(d).map(Some)
}

/// An optional pair of exactly two numbers (as [`crate::serde_exact::pair`]), each `null` read as
/// `f64::INFINITY` (with `#[serde(default, deserialize_with =
/// "brachia::serde_nonfinite::opt_pair")]`): absent is `None`.
pub fn opt_pair<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 2]>, D::Error> {
    let [a, b] = crate::serde_exact::exactly_two(Vec::<Option<f64>>::deserialize(d)?)?;
    Ok(Some([
        a.unwrap_or(f64::INFINITY),
        b.unwrap_or(f64::INFINITY),
    ]))
}

#[cfg(test)]
mod tests {
    use crate::control::ReplanEvent;
    use crate::planning::SolveStatus;
    use serde::{Deserialize, Serialize};
    use std::collections::BTreeMap;

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    enum Shape {
        Point,
        Scale(f64),
        Pair(f64, f64),
        Box { lo: [f64; 2], hi: Vec<f64> },
    }

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    struct Inner {
        value: f64,
        maybe: Option<f64>,
        list: Vec<f64>,
    }

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    struct Outer {
        name: String,
        count: usize,
        at: [f64; 2],
        inner: Inner,
        history: Vec<Inner>,
        by_name: BTreeMap<String, Inner>,
        shapes: Vec<Shape>,
        pairs: Vec<(f64, f64)>,
    }

    fn outer(x: f64) -> Outer {
        let inner = Inner {
            value: x,
            maybe: Some(0.5),
            list: vec![1.0, x],
        };
        Outer {
            name: "o".into(),
            count: 3,
            at: [x, 2.0],
            inner: inner.clone(),
            history: vec![
                inner.clone(),
                Inner {
                    maybe: None,
                    ..inner.clone()
                },
            ],
            by_name: [("a".to_string(), inner)].into_iter().collect(),
            shapes: vec![
                Shape::Point,
                Shape::Scale(x),
                Shape::Pair(1.0, x),
                Shape::Box {
                    lo: [x, 0.0],
                    hi: vec![x],
                },
            ],
            pairs: vec![(x, 1.0)],
        }
    }

    /// Every number that was not finite, at any depth (fields, vectors, arrays, map values, tuple
    /// and struct variants), is written `null` and read back by `from_value` as infinite; a
    /// `None` stays `None`; a value without `null`s reads as serde_json reads it.
    #[test]
    fn a_whole_report_reads_its_nulls_back_as_infinite() {
        let inf = outer(f64::INFINITY);
        let text = serde_json::to_string(&inf).unwrap();
        assert!(serde_json::from_str::<Outer>(&text).is_err(), "{text}");
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(super::from_value::<Outer>(v).unwrap(), inf);
        // NaN is written the same way and reads back as infinite
        let v = serde_json::to_value(outer(f64::NAN)).unwrap();
        assert_eq!(super::from_value::<Outer>(v).unwrap(), inf);
        let fin = outer(0.25);
        let v = serde_json::to_value(&fin).unwrap();
        assert_eq!(super::from_value::<Outer>(v).unwrap(), fin);
    }

    /// What serde_json refuses for other reasons is still refused, with serde_json's message.
    #[test]
    fn a_malformed_report_is_refused_as_serde_json_refuses_it() {
        let good = serde_json::to_value(outer(1.0)).unwrap();
        let cases: Vec<(&str, serde_json::Value)> = vec![
            ("/at", serde_json::json!([1.0, 2.0, 3.0])),
            ("/at", serde_json::json!([1.0])),
            ("/count", serde_json::Value::Null),
            ("/count", serde_json::json!(-1)),
            ("/inner/value", serde_json::json!("1.0")),
            ("/inner/list", serde_json::json!({"a": 1.0})),
            ("/name", serde_json::Value::Null),
            ("/shapes/0", serde_json::json!("Circle")),
            (
                "/shapes/1",
                serde_json::json!({"Scale": 1.0, "Pair": [1.0, 2.0]}),
            ),
            ("/shapes/2", serde_json::json!({"Pair": 1.0})),
            ("/shapes/3", serde_json::json!({"Box": [1.0]})),
            ("/inner", serde_json::json!({"maybe": 1.0, "list": []})),
        ];
        for (at, bad) in cases {
            let mut v = good.clone();
            *v.pointer_mut(at).unwrap() = bad.clone();
            let want = serde_json::from_value::<Outer>(v.clone())
                .unwrap_err()
                .to_string();
            let got = super::from_value::<Outer>(v).unwrap_err().to_string();
            assert_eq!(got, want, "{at} = {bad}");
        }
    }

    /// A re-plan whose predictions diverged and whose solve failed is written with `null`s and
    /// reads back with the same infinities; a finite entry beside a `null` keeps its value.
    #[test]
    fn a_replan_with_diverged_predictions_reads_back() {
        let ev = ReplanEvent {
            t_trigger_s: 1.3,
            predicted_miss_m: f64::INFINITY,
            status: SolveStatus::Other("the re-plan failed".into()),
            iterations: 12,
            solve_time_s: 0.01,
            wall_time_s: 0.02,
            latency_s: 0.02,
            t_switch_s: None,
            plan_ee_error_m: f64::INFINITY,
            adopted: false,
            end_box_dropped: false,
            predicted_continue_m: Some(f64::INFINITY),
            predicted_replan_m: Some(0.004),
            planned_on_estimate: false,
            predicted_at_switch_m: Some([f64::INFINITY, 0.003]),
        };
        let text = serde_json::to_string(&ev).unwrap();
        assert!(
            text.contains("\"predicted_at_switch_m\":[null,0.003]"),
            "{text}"
        );
        assert!(text.contains("\"plan_ee_error_m\":null"), "{text}");
        let back: ReplanEvent = serde_json::from_str(&text).unwrap();
        assert_eq!(back, ev);
        // absent optional fields stay absent
        let bare = ReplanEvent {
            predicted_continue_m: None,
            predicted_replan_m: None,
            predicted_at_switch_m: None,
            ..ev
        };
        let text = serde_json::to_string(&bare).unwrap();
        assert_eq!(serde_json::from_str::<ReplanEvent>(&text).unwrap(), bare);
        // three entries are still refused
        let bad = text.replace(
            "\"predicted_miss_m\"",
            "\"predicted_at_switch_m\":[1.0,null,2.0],\"predicted_miss_m\"",
        );
        assert!(serde_json::from_str::<ReplanEvent>(&bad).is_err());
    }
}
