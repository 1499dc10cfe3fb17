//! Domain randomisation as data: a scenario's `[disturbances]` section in which any number may be
//! replaced by a range `{ uniform = [lo, hi] }`, drawn anew for every episode.
//!
//! ```toml
//! [disturbances]
//! mass_scale = [{ uniform = [0.85, 1.15] }, 1.0, 1.0, { uniform = [0.9, 1.1] }]
//! noise_q_std = 0.002
//! actuation_delay_s = { uniform = [0.0, 0.02] }
//! pushes = [{ t_s = { uniform = [0.2, 0.8] }, link = 4, point_m = 0.3, impulse_n_s = [0.0, 0.2] }]
//! ```
//!
//! Draws walk the value in a fixed order (keys sorted, lists in order), one uniform number per
//! range from the episode's generator. Without a `seed` (and always for a scenario's own section,
//! [`Randomization::fixed`]), the noise seed of each episode is drawn too. Both ends of every range
//! are checked against [`Disturbances::validate`] when the value is made, so no draw can be refused
//! later.

use brachia::sim::Disturbances;
use brachia::Error;
use rand::{Rng, RngCore};
use serde_json::Value;

/// Disturbances with ranges: see the module docs.
#[derive(Debug, Clone, PartialEq)]
pub struct Randomization {
    value: Value,
    src: String,
    has_seed: bool,
}

/// Which number a range becomes.
enum Pick<'a> {
    Low,
    High,
    Draw(&'a mut dyn RngCore),
}

impl Randomization {
    /// The value `value` (the `[disturbances]` schema, ranges allowed) for an n-link robot at
    /// control period `control_dt`; `src` names it in errors (`src: field[i].uniform`).
    pub fn new(value: Value, src: &str, n: usize, control_dt: f64) -> Result<Self, Error> {
        if !value.is_object() {
            return Err(Error::invalid(
                src,
                "disturbances",
                value.to_string(),
                "must be a table of the [disturbances] schema",
            ));
        }
        let has_seed = value.get("seed").is_some_and(|s| !s.is_null());
        let r = Randomization {
            value,
            src: src.to_string(),
            has_seed,
        };
        // both ends of every range must be valid disturbances
        for pick in [Pick::Low, Pick::High] {
            let d = r.resolve(pick)?;
            d.validate(n, control_dt, src)?;
        }
        Ok(r)
    }

    /// Fixed disturbances (no ranges; a scenario's section). Their noise seed is drawn per
    /// episode like any other: a scenario's `seed` is not used.
    pub fn fixed(d: &Disturbances, src: &str) -> Self {
        let mut value = serde_json::to_value(d).unwrap_or(Value::Null);
        if let Value::Object(m) = &mut value {
            m.remove("seed");
        }
        Randomization {
            value,
            src: src.to_string(),
            has_seed: false,
        }
    }

    /// True when some number is a range.
    pub fn is_random(&self) -> bool {
        fn any(v: &Value) -> bool {
            match v {
                Value::Object(m) => m.contains_key("uniform") || m.values().any(any),
                Value::Array(a) => a.iter().any(any),
                _ => false,
            }
        }
        any(&self.value)
    }

    /// One episode's disturbances, drawn from `rng` (valid by construction).
    pub fn draw(&self, rng: &mut dyn RngCore) -> Result<Disturbances, Error> {
        let mut d = self.resolve(Pick::Draw(&mut *rng))?;
        if !self.has_seed {
            d.seed = rng.next_u64();
        }
        Ok(d)
    }

    /// Refuse a push at or after `time_limit_s`, the end of an episode, at either end of its range:
    /// it would never be applied, while the episode's disturbances list it.
    pub fn check_pushes_within(&self, time_limit_s: f64) -> Result<(), Error> {
        for pick in [Pick::Low, Pick::High] {
            let d = self.resolve(pick)?;
            for (i, p) in d.pushes.iter().enumerate() {
                if p.t_s >= time_limit_s {
                    return Err(Error::invalid(
                        &self.src,
                        format!("disturbances.pushes[{i}].t_s"),
                        p.t_s,
                        format!(
                            "a push happens during the episode: t_s must be below time_limit_s \
                             = {time_limit_s} s (a later push would never be applied)"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The value with every range replaced as `pick` says.
    fn resolve(&self, mut pick: Pick<'_>) -> Result<Disturbances, Error> {
        let v = resolve(&self.value, "", &self.src, &mut pick)?;
        serde_json::from_value::<Disturbances>(v.clone()).map_err(|e| {
            // serde names no field for a mistyped value: find the one that fails alone
            let field = v.as_object().and_then(|m| {
                m.iter().find_map(|(k, x)| {
                    let alone = Value::Object([(k.clone(), x.clone())].into_iter().collect());
                    serde_json::from_value::<Disturbances>(alone)
                        .is_err()
                        .then(|| format!(".{k}"))
                })
            });
            Error::Parse {
                path: self.src.clone().into(),
                message: format!("disturbances{}: {e}", field.unwrap_or_default()),
            }
        })
    }
}

/// `v` (at `path`) with its ranges replaced.
fn resolve(v: &Value, path: &str, src: &str, pick: &mut Pick<'_>) -> Result<Value, Error> {
    let join = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    Ok(match v {
        Value::Object(m) if m.contains_key("uniform") => {
            let field = join("uniform");
            let ends = m
                .get("uniform")
                .and_then(Value::as_array)
                .filter(|a| a.len() == 2 && m.len() == 1)
                .and_then(|a| Some((a[0].as_f64()?, a[1].as_f64()?)))
                .filter(|(lo, hi)| lo.is_finite() && hi.is_finite() && lo <= hi);
            let Some((lo, hi)) = ends else {
                return Err(Error::invalid(
                    src,
                    field,
                    v.to_string(),
                    "a range is { uniform = [lo, hi] } with finite lo <= hi and nothing else",
                ));
            };
            let x = match pick {
                Pick::Low => lo,
                Pick::High => hi,
                Pick::Draw(rng) => {
                    if hi > lo {
                        rng.gen_range(lo..=hi)
                    } else {
                        lo
                    }
                }
            };
            serde_json::Number::from_f64(x)
                .map(Value::Number)
                .unwrap_or(Value::Null)
        }
        Value::Object(m) => {
            let mut out = serde_json::Map::new();
            let mut keys: Vec<&String> = m.keys().collect();
            keys.sort();
            for k in keys {
                out.insert(k.clone(), resolve(&m[k], &join(k), src, pick)?);
            }
            Value::Object(out)
        }
        Value::Array(a) => {
            let mut out = Vec::with_capacity(a.len());
            for (i, x) in a.iter().enumerate() {
                out.push(resolve(x, &format!("{path}[{i}]"), src, pick)?);
            }
            Value::Array(out)
        }
        other => other.clone(),
    })
}
