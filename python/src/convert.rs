//! Conversions between Python values and the library's: numpy arrays and scalars in and out, errors
//! into `BrachiaError` (dicts and settings: `crate::dicts`).
//!
//! Arrays in: every array argument of every entry point is read here, by [`vector`], [`read_vector`],
//! [`any_vector`] or [`matrix`], with the same rules:
//! - **dtype**: real numbers only. Float arrays of any width and integer arrays convert to float64;
//!   booleans, complex numbers, Python objects, text and dates are refused (numpy would drop an
//!   imaginary part or turn `True` into 1.0 without a word).
//! - **byte order and layout**: a native-endian float64 buffer is read as it is (no copy of the Python
//!   object); anything else (big-endian, another dtype, a list) goes through
//!   `numpy.asarray(a, dtype=float64, order="C")`, which swaps bytes and copies as needed.
//! - **shape**: the exact number of dimensions and lengths the argument needs.
//! - **finiteness and range**: every value finite, and inside the [`Range`] of its quantity (the rule
//!   the CLI applies to the same quantity, e.g. `|q| <= brachia::limits::MAX_ANGLE_RAD`).
//!
//! A refusal is a `BrachiaError` naming the argument (and the index), the value and the rule.

use brachia::limits;
use pyo3::buffer::PyBuffer;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBool, PyByteArray, PyDict, PyFloat, PyInt};

pyo3::create_exception!(
    brachia,
    BrachiaError,
    PyValueError,
    "Bad input to brachia (a file, a field, a value or an array shape): the message is the Rust \
     library's, naming the file, the field, the value and the rule."
);

/// `numpy.asarray` and `numpy.frombuffer`, looked up once.
static ASARRAY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();
static FROMBUFFER: PyOnceLock<Py<PyAny>> = PyOnceLock::new();

/// Largest joint acceleration accepted (``inverse_dynamics``' ``qdd``), rad/s^2.
pub(crate) const MAX_ACCEL_RAD_S2: f64 = 1e6;
/// Largest torque accepted (``qdd``'s ``tau``; a trajectory's torques), N m: the largest torque
/// limit a parameters file may give.
pub(crate) const MAX_TORQUE_NM: f64 = 1e6;
/// Largest coordinate of a position (a target, a bar), m: the planner's rule for obstacles.
pub(crate) const MAX_POSITION_M: f64 = 1e3;

/// The rule for the values of an array argument (every value must also be finite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Range {
    /// Joint angles, rad: `|v| <= MAX_ANGLE_RAD` (the CLI's rule for a start pose).
    Angle,
    /// Joint velocities, rad/s: `|v| <= MAX_RATE_RAD_S` (the CLI's rule for a start velocity).
    Rate,
    /// States `[q (n), qd (n)]`: the first half of each row angles, the second half velocities.
    State,
    /// Joint accelerations, rad/s^2: `|v| <= MAX_ACCEL_RAD_S2`.
    Accel,
    /// Torques, N m: `|v| <= MAX_TORQUE_NM`.
    Torque,
    /// Positions, m: `|v| <= MAX_POSITION_M`.
    Position,
    /// Times, s: `0 <= t <= MAX_RUN_DURATION_S`.
    Time,
}

impl Range {
    /// The rule broken by `v` in column `col` of rows of `cols` values, if any.
    fn broken(self, v: f64, col: usize, cols: usize) -> Option<String> {
        if !v.is_finite() {
            return Some("must be finite".into());
        }
        let abs = |max: f64, unit: &str, what: &str, limit: &str| {
            (v.abs() > max)
                .then(|| format!("must be at most {max} {unit} in magnitude ({what}; {limit})"))
        };
        match self {
            Range::Angle => abs(
                limits::MAX_ANGLE_RAD,
                "rad",
                "a joint angle",
                "brachia::limits::MAX_ANGLE_RAD",
            ),
            Range::Rate => abs(
                limits::MAX_RATE_RAD_S,
                "rad/s",
                "a joint velocity",
                "brachia::limits::MAX_RATE_RAD_S",
            ),
            Range::State if 2 * col < cols => Range::Angle.broken(v, col, cols),
            Range::State => Range::Rate.broken(v, col, cols),
            Range::Accel => abs(
                MAX_ACCEL_RAD_S2,
                "rad/s^2",
                "a joint acceleration",
                "docs/python.md",
            ),
            Range::Torque => abs(
                MAX_TORQUE_NM,
                "N m",
                "a torque; the largest limit a robot may have",
                "docs/python.md",
            ),
            Range::Position => abs(
                MAX_POSITION_M,
                "m",
                "a position in the grip frame",
                "docs/python.md",
            ),
            Range::Time => (!(0.0..=limits::MAX_RUN_DURATION_S).contains(&v)).then(|| {
                format!(
                    "must lie in [0, {}] s (brachia::limits::MAX_RUN_DURATION_S)",
                    limits::MAX_RUN_DURATION_S
                )
            }),
        }
    }
}

/// An array argument: its name as the user writes it, what it holds (for shape messages) and the rule
/// for its values.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Arg<'a> {
    pub name: &'a str,
    pub what: &'a str,
    pub range: Range,
}

impl<'a> Arg<'a> {
    pub(crate) const fn new(name: &'a str, what: &'a str, range: Range) -> Self {
        Arg { name, what, range }
    }
}

/// `x` for a message: plain for ordinary magnitudes, in exponent form for huge or tiny ones (Rust
/// writes `1e300` with 300 digits otherwise).
pub(crate) fn num(x: f64) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf" } else { "-inf" }.into();
    }
    let a = x.abs();
    if a.is_finite() && a != 0.0 && !(1e-4..1e6).contains(&a) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

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

/// True when a buffer of this `struct` format holds native-endian float64 values. (PyO3's own check
/// takes `>d`, big-endian, as native on a little-endian machine.)
fn native_f64_format(format: &[u8]) -> bool {
    match format {
        b"d" | b"@d" | b"=d" => true,
        b"<d" => cfg!(target_endian = "little"),
        b">d" | b"!d" => cfg!(target_endian = "big"),
        _ => false,
    }
}

/// Why numpy's dtype kind `kind` (`dtype.kind`) cannot be read as real numbers, if it cannot.
fn refused_kind(kind: &str) -> Option<&'static str> {
    match kind {
        "f" | "i" | "u" => None,
        "b" => Some("booleans are not numbers here"),
        "c" => Some("complex numbers are refused (the imaginary part would be dropped)"),
        "O" => Some("Python objects that are not all real numbers (or a ragged list)"),
        "U" | "S" => Some("text is not a number"),
        "M" | "m" => Some("dates and durations are not numbers here"),
        _ => Some("not an array of real numbers"),
    }
}

/// The shape an array argument must have.
#[derive(Clone, Copy, Debug)]
enum Want {
    /// 1-D with `min..=max` values.
    Vector { min: usize, max: usize },
    /// 2-D; rows and columns fixed where given, at least one column.
    Matrix {
        rows: Option<usize>,
        cols: Option<usize>,
    },
}

impl Want {
    fn fits(self, shape: &[usize]) -> bool {
        match (self, shape) {
            (Want::Vector { min, max }, [len]) => (min..=max).contains(len),
            (Want::Matrix { rows, cols }, [r, c]) => {
                *c > 0 && rows.is_none_or(|x| x == *r) && cols.is_none_or(|x| x == *c)
            }
            _ => false,
        }
    }

    /// The refusal of `shape` for `arg`.
    fn refuse(self, arg: &Arg<'_>, shape: &[usize]) -> PyErr {
        let want = match self {
            Want::Vector { min, max } if min == max => format!("a 1-D array of {min} values"),
            Want::Vector { min, max } => format!("a 1-D array of {min} to {max} values"),
            Want::Matrix { rows, cols } => {
                let dim =
                    |d: Option<usize>, any: &str| d.map_or(any.to_string(), |d| d.to_string());
                format!(
                    "an array of shape ({}, {})",
                    dim(rows, "samples"),
                    dim(cols, "columns")
                )
            }
        };
        bad(format!(
            "{}: expected {want} ({}), got shape {shape:?}",
            arg.name, arg.what
        ))
    }
}

/// The values (row-major, native float64) and shape of `obj`, once its shape fits `want`: read
/// from `obj`'s own buffer when it holds native float64 values (into `out` when given, without
/// allocating), else from `numpy.asarray(obj, dtype=float64, order="C")` after the dtype check.
/// Only the values are returned when `out` is given (the vector is then empty).
fn read(
    obj: &Bound<'_, PyAny>,
    arg: &Arg<'_>,
    want: Want,
    out: Option<&mut [f64]>,
) -> PyResult<(Vec<f64>, Vec<usize>)> {
    let py = obj.py();
    let take = |b: &PyBuffer<f64>, out: Option<&mut [f64]>| -> PyResult<(Vec<f64>, Vec<usize>)> {
        let shape = b.shape().to_vec();
        if !want.fits(&shape) {
            return Err(want.refuse(arg, &shape));
        }
        match out {
            Some(o) if o.len() == b.item_count() => {
                b.copy_to_slice(py, o)?;
                Ok((Vec::new(), shape))
            }
            Some(_) => Err(want.refuse(arg, &shape)),
            None => Ok((b.to_vec(py)?, shape)),
        }
    };
    if let Ok(b) = PyBuffer::<f64>::get(obj) {
        if native_f64_format(b.format().to_bytes()) {
            return take(&b, out);
        }
    }
    let name = arg.name;
    let not_numbers = |e: PyErr| bad(format!("{name}: not an array of numbers ({e})"));
    let asarray = ASARRAY.import(py, "numpy", "asarray")?;
    let arr = asarray.call1((obj,)).map_err(not_numbers)?;
    let dtype = arr.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    if let Some(why) = refused_kind(&kind) {
        return Err(bad(format!("{name}: dtype {}: {why}", dtype.str()?)));
    }
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    if !want.fits(&shape) {
        return Err(want.refuse(arg, &shape));
    }
    let kw = PyDict::new(py);
    kw.set_item("dtype", "float64")?;
    kw.set_item("order", "C")?;
    let arr = asarray.call((arr,), Some(&kw)).map_err(not_numbers)?;
    let b = PyBuffer::<f64>::get(&arr).map_err(not_numbers)?;
    take(&b, out)
}

/// Check every value of `v` (rows of `cols` values) against `arg.range`; `two_d` names entries
/// `name[row][col]`, else `name[i]`.
fn check_values(v: &[f64], arg: &Arg<'_>, cols: usize, two_d: bool) -> PyResult<()> {
    let cols = cols.max(1);
    for (i, &x) in v.iter().enumerate() {
        if let Some(rule) = arg.range.broken(x, i % cols, cols) {
            let at = if two_d {
                format!("{}[{}][{}]", arg.name, i / cols, i % cols)
            } else {
                format!("{}[{i}]", arg.name)
            };
            return Err(bad(format!("{at} = {}: {rule}", num(x))));
        }
    }
    Ok(())
}

/// Check the values of a vector that came in another way (a field of a dict) against `range`;
/// `name` names it as the user wrote it (`task.q0`).
pub(crate) fn check_slice(v: &[f64], name: &str, range: Range) -> PyResult<()> {
    check_values(v, &Arg::new(name, "", range), v.len(), false)
}

/// A 1-D array of exactly `len` values.
pub(crate) fn vector(obj: &Bound<'_, PyAny>, arg: Arg<'_>, len: usize) -> PyResult<Vec<f64>> {
    let mut out = vec![0.0; len];
    read_vector(obj, arg, &mut out)?;
    Ok(out)
}

/// Read a 1-D array of exactly `out.len()` values into `out` (no allocation when `obj` is a native
/// float64 array). On an error `out` may hold part of the input.
pub(crate) fn read_vector(obj: &Bound<'_, PyAny>, arg: Arg<'_>, out: &mut [f64]) -> PyResult<()> {
    let len = out.len();
    read(
        obj,
        &arg,
        Want::Vector { min: len, max: len },
        Some(&mut *out),
    )?;
    check_values(out, &arg, len, false)
}

/// A 1-D array of `min..=max` values.
pub(crate) fn any_vector(
    obj: &Bound<'_, PyAny>,
    arg: Arg<'_>,
    min: usize,
    max: usize,
) -> PyResult<Vec<f64>> {
    let (v, _) = read(obj, &arg, Want::Vector { min, max }, None)?;
    check_values(&v, &arg, v.len(), false)?;
    Ok(v)
}

/// A 2-D array of `rows` x `cols` values (any number of rows or columns where `None`; at least
/// one column): `(values row-major, rows, cols)`.
pub(crate) fn matrix(
    obj: &Bound<'_, PyAny>,
    arg: Arg<'_>,
    rows: Option<usize>,
    cols: Option<usize>,
) -> PyResult<(Vec<f64>, usize, usize)> {
    let (v, shape) = read(obj, &arg, Want::Matrix { rows, cols }, None)?;
    check_values(&v, &arg, shape[1], true)?;
    Ok((v, shape[0], shape[1]))
}

/// A 1-D array of `cols` values or a 2-D array of rows of `cols` values (a whole trajectory):
/// `(values row-major, Some(rows))` for a 2-D array, `(values, None)` for a 1-D one.
pub(crate) fn vector_or_rows(
    obj: &Bound<'_, PyAny>,
    arg: Arg<'_>,
    cols: usize,
) -> PyResult<(Vec<f64>, Option<usize>)> {
    let arr = ASARRAY
        .import(obj.py(), "numpy", "asarray")?
        .call1((obj,))
        .map_err(|e| bad(format!("{}: not an array ({e})", arg.name)))?;
    let ndim: usize = arr.getattr("ndim")?.extract()?;
    if ndim == 2 {
        let (v, rows, _) = matrix(obj, arg, None, Some(cols))?;
        Ok((v, Some(rows)))
    } else {
        Ok((vector(obj, arg, cols)?, None))
    }
}

/// A real-number scalar argument: a Python `int` or `float`, a numpy real scalar or a 0-d real
/// array. Booleans, complex numbers (numpy would drop the imaginary part with a warning), text and
/// arrays of more than one value are refused with `BrachiaError` (the traceback's note names the
/// argument). Its range is checked by [`scalar`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Real(pub f64);

/// A count argument (`substeps`, `steps`, `seed`): a Python `int` or a numpy integer, `>= 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Count(pub u64);

/// `obj` as a 0-d numpy array of real numbers (after the dtype check), for a scalar argument.
fn scalar_array<'py>(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<Bound<'py, PyAny>> {
    let type_name = obj.get_type().name()?;
    let arr = ASARRAY
        .import(obj.py(), "numpy", "asarray")?
        .call1((obj,))
        .map_err(|e| bad(format!("expected {what}, got {type_name} ({e})")))?;
    let dtype = arr.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    if let Some(why) = refused_kind(&kind) {
        return Err(bad(format!(
            "expected {what}, got dtype {}: {why}",
            dtype.str()?
        )));
    }
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    if !shape.is_empty() {
        return Err(bad(format!(
            "expected {what}, got an array of shape {shape:?}"
        )));
    }
    Ok(arr)
}

impl<'a, 'py> FromPyObject<'a, 'py> for Real {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let obj = obj.to_owned();
        let what = "a real number";
        if obj.is_instance_of::<PyBool>() {
            return Err(bad(format!("expected {what}, got a bool ({obj})")));
        }
        if obj.is_instance_of::<PyFloat>() || obj.is_instance_of::<PyInt>() {
            return obj
                .extract::<f64>()
                .map(Real)
                .map_err(|e| bad(format!("expected {what}: {e}")));
        }
        let item = scalar_array(&obj, what)?.call_method0("item")?;
        Ok(Real(
            item.extract::<f64>()
                .map_err(|e| bad(format!("expected {what}: {e}")))?,
        ))
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for Count {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let obj = obj.to_owned();
        let what = "a whole number >= 0";
        if obj.is_instance_of::<PyBool>() {
            return Err(bad(format!("expected {what}, got a bool ({obj})")));
        }
        let item = if obj.is_instance_of::<PyInt>() {
            obj.clone()
        } else {
            let arr = scalar_array(&obj, what)?;
            let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
            if kind == "f" {
                return Err(bad(format!("expected {what}, got {obj}")));
            }
            arr.call_method0("item")?
        };
        item.extract::<u64>()
            .map(Count)
            .map_err(|_| bad(format!("expected {what}, got {item}")))
    }
}

/// A scalar argument: finite and, when `range` is given, inside it (`[lo, hi]`, `unit` for the
/// message).
pub(crate) fn scalar(name: &str, v: f64, range: Option<([f64; 2], &str)>) -> PyResult<f64> {
    if !v.is_finite() {
        return Err(bad(format!("{name} = {}: must be finite", num(v))));
    }
    if let Some(([lo, hi], unit)) = range {
        if !(lo..=hi).contains(&v) {
            return Err(bad(format!(
                "{name} = {}: must lie in [{lo}, {hi}] {unit}",
                num(v)
            )));
        }
    }
    Ok(v)
}

/// Check that a result is finite before it is returned: a non-finite value means the inputs
/// overflowed the computation, which is an error, never a silent NaN.
pub(crate) fn finite_result<'v>(v: &'v [f64], what: &str) -> PyResult<&'v [f64]> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(bad(format!(
            "{what}: entry {i} of the result is {} (the inputs overflow the computation)",
            v[i]
        ))),
        None => Ok(v),
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
