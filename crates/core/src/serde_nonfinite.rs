//! Numbers that may not be finite, read back from JSON. JSON has no infinity or NaN: serde_json
//! writes such a value as `null`. A field read with these functions takes `null` as
//! `f64::INFINITY` (a diverged or failed prediction, an unknown error), so a report that holds one
//! reads back instead of failing to parse (docs/formats.md, "Values that are not finite").

use serde::de::Deserializer;
use serde::Deserialize;

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
