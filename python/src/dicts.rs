//! Dicts and other structured values between Python and the library: settings, tasks and obstacles
//! go through JSON into the library's serde types (numpy arrays of any byte order become lists first,
//! NaN and infinities are refused), and results come back as Python dicts and lists.

use crate::convert::bad;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// JSON fallback for `json.dumps`: numpy arrays and scalars as Python lists and numbers.
#[pyfunction]
#[pyo3(name = "_jsonable")]
pub(crate) fn jsonable<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    obj.call_method0("tolist")
}

/// `obj` (dicts, lists, numbers, strings, numpy arrays) as JSON text; `name` names it in errors.
pub(crate) fn to_json(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<String> {
    let py = obj.py();
    let json = py.import("json")?;
    let kw = PyDict::new(py);
    kw.set_item("default", wrap_pyfunction!(jsonable, py)?)?;
    kw.set_item("allow_nan", false)?;
    let s = json.call_method("dumps", (obj,), Some(&kw)).map_err(|e| {
        match non_finite(obj, name, 0) {
            Some((path, v)) => bad(format!("{path} = {v}: must be finite")),
            None => bad(format!("{name}: cannot be read as settings data ({e})")),
        }
    })?;
    s.extract::<String>()
}

/// Where in `obj` (dicts, lists, tuples, numpy arrays and numbers, named `path`) the first NaN or
/// infinity is, and the value, as `disturbances.mass_scale.uniform[0]` and `nan`.
fn non_finite(obj: &Bound<'_, PyAny>, path: &str, depth: usize) -> Option<(String, String)> {
    if depth > 32 {
        return None;
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        for (k, v) in d.iter() {
            let key = k.str().map(|s| s.to_string()).unwrap_or_default();
            if let Some(found) = non_finite(&v, &format!("{path}.{key}"), depth + 1) {
                return Some(found);
            }
        }
        return None;
    }
    if obj.hasattr("tolist").unwrap_or(false) && !obj.is_instance_of::<pyo3::types::PyFloat>() {
        let list = obj.call_method0("tolist").ok()?;
        return non_finite(&list, path, depth + 1);
    }
    if let Ok(seq) = obj.cast::<pyo3::types::PySequence>() {
        if obj.is_instance_of::<pyo3::types::PyString>() {
            return None;
        }
        for i in 0..seq.len().unwrap_or(0).min(1 << 20) {
            let item = seq.get_item(i).ok()?;
            if let Some(found) = non_finite(&item, &format!("{path}[{i}]"), depth + 1) {
                return Some(found);
            }
        }
        return None;
    }
    if obj.is_instance_of::<pyo3::types::PyFloat>() {
        let v: f64 = obj.extract().ok()?;
        if !v.is_finite() {
            return Some((path.to_string(), format!("{v}")));
        }
    }
    None
}

/// A Python dict (or `None` = `{}`) with `kwargs` merged over it, as a serde value of type `T`;
/// `name` names it in errors (serde's message names the unknown or mistyped field).
pub(crate) fn settings_from<T: serde::de::DeserializeOwned>(
    obj: Option<&Bound<'_, PyAny>>,
    kwargs: Option<&Bound<'_, PyDict>>,
    name: &str,
) -> PyResult<T> {
    let value = merged(obj, kwargs, name)?;
    from_value(value, name)
}

/// A serde value as `T`; `name` names it in errors.
pub(crate) fn from_value<T: serde::de::DeserializeOwned>(
    v: serde_json::Value,
    name: &str,
) -> PyResult<T> {
    serde_json::from_value(v.clone()).map_err(|e| {
        // name the key at fault: the one without which the rest reads (serde's messages of an
        // untagged enum or a wrong type do not name it)
        let culprit = v.as_object().and_then(|m| {
            m.iter().find_map(|(k, val)| {
                let mut rest = m.clone();
                rest.remove(k);
                serde_json::from_value::<T>(serde_json::Value::Object(rest))
                    .is_ok()
                    .then(|| (k.clone(), val.clone()))
            })
        });
        match culprit {
            Some((k, val)) => bad(format!("{name}.{k} = {val}: {e}")),
            None => bad(format!("{name}: {e}")),
        }
    })
}

/// A dict (or `None`) with `kwargs` merged over it, as a JSON object.
pub(crate) fn merged(
    obj: Option<&Bound<'_, PyAny>>,
    kwargs: Option<&Bound<'_, PyDict>>,
    name: &str,
) -> PyResult<serde_json::Value> {
    let mut map = serde_json::Map::new();
    if let Some(o) = obj.filter(|o| !o.is_none()) {
        if !o.is_instance_of::<PyDict>() {
            return Err(bad(format!(
                "{name}: expected a dict of settings, got {}",
                o.get_type().name()?
            )));
        }
        map = object(o, name)?;
    }
    if let Some(kw) = kwargs {
        map.extend(object(kw.as_any(), name)?);
    }
    Ok(serde_json::Value::Object(map))
}

/// A Python dict as a JSON object.
fn object(
    o: &Bound<'_, PyAny>,
    name: &str,
) -> PyResult<serde_json::Map<String, serde_json::Value>> {
    let text = to_json(o, name)?;
    match serde_json::from_str(&text) {
        Ok(serde_json::Value::Object(m)) => Ok(m),
        Ok(_) => Err(bad(format!("{name}: expected a dict of settings"))),
        Err(e) => Err(bad(format!("{name}: {e}"))),
    }
}

/// A serde-serialisable value as a Python object (dicts, lists, floats, strings, None).
pub(crate) fn to_py<'py>(
    py: Python<'py>,
    v: &impl serde::Serialize,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(|e| bad(format!("serialising a result: {e}")))?;
    py.import("json")?.call_method1("loads", (text,))
}
