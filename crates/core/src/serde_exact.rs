//! Fixed-length vectors read exactly: `[x, y]` with three values is an error, not a silent truncation.

use serde::de::Deserializer;
use serde::Deserialize;

/// [`pair`] for an optional field (with `#[serde(default, deserialize_with =
/// "brachia::serde_exact::opt_pair")]`: absent is `None`).
pub fn opt_pair<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 2]>, D::Error> {
    pair(d).map(Some)
}

/// Deserialize `[f64; 2]` from a sequence of exactly two numbers (for
/// `#[serde(deserialize_with = "brachia::serde_exact::pair")]`).
pub fn pair<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    exactly_two(Vec::<f64>::deserialize(d)?)
}

/// The two entries of `v`, or the error that names how many it holds.
pub(crate) fn exactly_two<T: Copy + std::fmt::Debug, E: serde::de::Error>(
    v: Vec<T>,
) -> Result<[T; 2], E> {
    match v[..] {
        [a, b] => Ok([a, b]),
        _ => Err(E::custom(format!(
            "expected exactly 2 numbers [x, y], got {} ({v:?})",
            v.len()
        ))),
    }
}
