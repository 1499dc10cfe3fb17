//! Conversions between Python values and the library's: numpy arrays in and out, settings dicts through
//! JSON into the library's serde types, errors into `BrachiaError`.
//!
//! Arrays in: anything `numpy.asarray(x, dtype=float64)` accepts (a float64 array is read without a
//! copy of the Python object). Every vector is checked for its length and for finite values before it
//! reaches the library; the message names the argument, the expected length and what it holds.

use crate::BrachiaError;
use pyo3::buffer::PyBuffer;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyByteArray, PyDict};

/// `numpy.asarray` and `numpy.frombuffer`, looked up once.
static ASARRAY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
static FROMBUFFER: PyOnceLock<Py<PyAny>> = PyOnceLock::new();

/// A `BrachiaError` with this text.
pub(crate) fn bad(msg: impl Into<String>) -> PyErr {
    BrachiaError::new_err(msg.into())
}

/// A library error as a `BrachiaError`, its text unchanged.
pub(crate) fn rs(e: brachia::Error) -> PyErr {
    bad(e.to_string())
}

/// An experiment-layer error as a `BrachiaError`, its text unchanged.
pub(crate) fn exp(e: brachia_experiments::ExpError) -> PyErr {
    bad(e.to_string())
}

/// The float64 buffer of `obj`: directly for a float64 array (or any float64 buffer), else of
/// `numpy.asarray(obj, dtype=float64)`; a value numpy cannot convert is a `BrachiaError` naming `name`.
fn buffer(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<PyBuffer<f64>> {
    if let Ok(b) = PyBuffer::<f64>::get(obj) {
        return Ok(b);
    }
    let py = obj.py();
    let asarray = ASARRAY.import(py, "numpy", "asarray")?;
    let arr = asarray
        .call1((obj, "float64"))
        .map_err(|e| bad(format!("{name}: not an array of numbers ({e})")))?;
    PyBuffer::<f64>::get(&arr).map_err(|e| bad(format!("{name}: not an array of numbers ({e})")))
}

/// The first non-finite entry of `v`, as an error naming `name[i]`.
fn check_finite(v: &[f64], name: &str) -> PyResult<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(bad(format!("{name}[{i}] = {}: must be finite", v[i]))),
        None => Ok(()),
    }
}

/// A 1-D array of exactly `len` finite numbers (`what` says what they are, for the message).
pub(crate) fn vector(
    obj: &Bound<'_, PyAny>,
    name: &str,
    len: usize,
    what: &str,
) -> PyResult<Vec<f64>> {
    let mut out = vec![0.0; len];
    read_vector(obj, name, what, &mut out)?;
    Ok(out)
}

/// Read a 1-D array of exactly `out.len()` finite numbers into `out` (no allocation when `obj` is a
/// float64 array).
pub(crate) fn read_vector(
    obj: &Bound<'_, PyAny>,
    name: &str,
    what: &str,
    out: &mut [f64],
) -> PyResult<()> {
    let len = out.len();
    let b = buffer(obj, name)?;
    if b.dimensions() != 1 || b.item_count() != len {
        return Err(bad(format!(
            "{name}: expected a 1-D array of {len} values ({what}), got shape {:?}",
            b.shape()
        )));
    }
    b.copy_to_slice(obj.py(), out)?;
    check_finite(out, name)
}

/// A 1-D array of finite numbers of any length up to `max`.
pub(crate) fn any_vector(obj: &Bound<'_, PyAny>, name: &str, max: usize) -> PyResult<Vec<f64>> {
    let b = buffer(obj, name)?;
    if b.dimensions() != 1 || b.item_count() > max {
        return Err(bad(format!(
            "{name}: expected a 1-D array of at most {max} values, got shape {:?}",
            b.shape()
        )));
    }
    let v = b.to_vec(obj.py())?;
    check_finite(&v, name)?;
    Ok(v)
}

/// The number of columns of a 2-D array.
pub(crate) fn columns(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<usize> {
    let b = buffer(obj, name)?;
    match b.shape() {
        [_, c] => Ok(*c),
        s => Err(bad(format!(
            "{name}: expected a 2-D array, got shape {s:?}"
        ))),
    }
}

/// A 2-D array of finite numbers with `cols` columns (any number of rows when `rows` is `None`):
/// `(values row-major, rows)`.
pub(crate) fn matrix(
    obj: &Bound<'_, PyAny>,
    name: &str,
    rows: Option<usize>,
    cols: usize,
    what: &str,
) -> PyResult<(Vec<f64>, usize)> {
    let b = buffer(obj, name)?;
    let shape = b.shape().to_vec();
    let ok = shape.len() == 2 && shape[1] == cols && rows.is_none_or(|r| shape[0] == r);
    if !ok {
        let want = match rows {
            Some(r) => format!("({r}, {cols})"),
            None => format!("(samples, {cols})"),
        };
        return Err(bad(format!(
            "{name}: expected an array of shape {want} ({what}), got shape {shape:?}"
        )));
    }
    let v = b.to_vec(obj.py())?;
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(bad(format!(
            "{name}[{}][{}] = {}: must be finite",
            i / cols,
            i % cols,
            v[i]
        ))),
        None => Ok((v, shape[0])),
    }
}

/// A float64 numpy vector holding `v` (a writable array over a new bytearray).
pub(crate) fn arr1<'py>(py: Python<'py>, v: &[f64]) -> PyResult<Bound<'py, PyAny>> {
    if v.is_empty() {
        return ASARRAY
            .import(py, "numpy", "asarray")?
            .call1((Vec::<f64>::new(), "float64"));
    }
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_ne_bytes()).collect();
    let ba = PyByteArray::new(py, &bytes);
    FROMBUFFER
        .import(py, "numpy", "frombuffer")?
        .call1((ba, "float64"))
}

/// A float64 `(rows, cols)` numpy array of the row-major `v`.
pub(crate) fn arr2<'py>(py: Python<'py>, v: Vec<f64>, cols: usize) -> PyResult<Bound<'py, PyAny>> {
    let rows = v.len().checked_div(cols).unwrap_or(0);
    arr1(py, &v)?.call_method1("reshape", (rows, cols))
}

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
    let s = json
        .call_method("dumps", (obj,), Some(&kw))
        .map_err(|e| bad(format!("{name}: cannot be read as settings data ({e})")))?;
    s.extract::<String>()
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
    serde_json::from_value(v).map_err(|e| bad(format!("{name}: {e}")))
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
