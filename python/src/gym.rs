//! The learning environments' Rust side: `SwingCore` (one `brachia_experiments::gym::SwingEnv`) and
//! `SwingBatchCore` (a `SwingBatch` stepped in parallel with the GIL released). The Gymnasium classes
//! in python/brachia/envs.py and python/brachia/vector.py wrap them (docs/rl.md).
//!
//! Arrays: observations are float32 `(obs_dim,)` or `(envs, obs_dim)`; actions are read from float32
//! or float64 buffers (any other dtype through the common reader of `crate::convert`).

use crate::convert::{bad, read_vector, rs, Arg, Range};
use crate::dicts::{merged, to_json, to_py};
use crate::scenario::Scenario;
use crate::shared::Shared;
use brachia::planning::SwingTask;
use brachia_experiments::gym::{
    Autoreset, BatchOutput, Randomization, StepOutcome, SwingBatch, SwingEnv, SwingEnvSettings,
    SwingEnvSpec,
};
use brachia_experiments::scenario::PlantSettings;
use brachia_experiments::{PlantKind, Uses};
use pyo3::buffer::PyBuffer;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyByteArray, PyDict, PyTuple};
use std::path::PathBuf;
use std::sync::Arc;

/// `numpy.frombuffer`, looked up once.
static FROMBUFFER: PyOnceLock<Py<PyAny>> = PyOnceLock::new();

/// A numpy array of `v` (float32) with shape `shape`.
fn arr_f32<'py>(py: Python<'py>, v: &[f32], shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_ne_bytes()).collect();
    let a = FROMBUFFER
        .import(py, "numpy", "frombuffer")?
        .call1((PyByteArray::new(py, &bytes), "float32"))?;
    if shape.len() == 1 {
        Ok(a)
    } else {
        a.call_method1("reshape", PyTuple::new(py, shape)?)
    }
}

/// A numpy array of `v` in the dtype `dtype` (its bytes as numpy expects them).
fn arr_bytes<'py>(
    py: Python<'py>,
    bytes: &[u8],
    dtype: &str,
    shape: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    FROMBUFFER
        .import(py, "numpy", "frombuffer")?
        .call1((PyByteArray::new(py, bytes), dtype))?
        .call_method1("reshape", PyTuple::new(py, shape)?)
}

/// True when a buffer format is native-endian `code` (`f` float32, `d` float64).
fn native(format: &[u8], code: u8) -> bool {
    match format {
        [c] | [b'@' | b'=', c] => *c == code,
        [b'<', c] => *c == code && cfg!(target_endian = "little"),
        [b'>' | b'!', c] => *c == code && cfg!(target_endian = "big"),
        _ => false,
    }
}

/// Read `obj` (exactly `out.len()` values, 1-D or of shape `shape`) into `out`: straight from a
/// native float32 or float64 buffer, else through the common reader (any real dtype, a list).
fn read_actions(
    obj: &Bound<'_, PyAny>,
    name: &str,
    shape: &[usize],
    out: &mut [f64],
) -> PyResult<()> {
    let py = obj.py();
    if let Ok(b) = PyBuffer::<f32>::get(obj) {
        if native(b.format().to_bytes(), b'f') && b.shape() == shape {
            let mut v = vec![0f32; out.len()];
            b.copy_to_slice(py, &mut v)?;
            out.iter_mut().zip(&v).for_each(|(o, x)| *o = f64::from(*x));
            return Ok(());
        }
    }
    if let Ok(b) = PyBuffer::<f64>::get(obj) {
        if native(b.format().to_bytes(), b'd') && b.shape() == shape {
            return b.copy_to_slice(py, out);
        }
    }
    let what = format!("actions scaled to [-1, 1], shape {shape:?}");
    let flat = py
        .import("numpy")?
        .getattr("ravel")?
        .call1((obj,))
        .map_err(|e| bad(format!("{name}: not an array of numbers ({e})")))?;
    let got: Vec<usize> = py
        .import("numpy")?
        .getattr("shape")?
        .call1((obj,))?
        .extract()?;
    if got != shape {
        return Err(bad(format!(
            "{name}: expected an array of shape {shape:?} ({what}), got shape {got:?}"
        )));
    }
    read_vector(&flat, Arg::new(name, &what, Range::Torque), out)
}

/// The spec of a call: `scenario` (None: the paper's V-B swing; a path; a `Scenario`), `plant`,
/// `settings` (dict and keyword arguments) and `disturbances` (None: the scenario's).
fn spec_of(
    scenario: Option<&Bound<'_, PyAny>>,
    plant: Option<&str>,
    settings: Option<&Bound<'_, PyAny>>,
    kwargs: Option<&Bound<'_, PyDict>>,
    disturbances: Option<&Bound<'_, PyAny>>,
) -> PyResult<Arc<SwingEnvSpec>> {
    let plant = match plant {
        None => None,
        Some("model") => Some(PlantKind::Model),
        Some("rapier") => Some(PlantKind::Rapier),
        Some(other) => {
            return Err(bad(format!(
                "plant = {other:?}: expected \"model\" or \"rapier\""
            )))
        }
    };
    let value = merged(settings, kwargs, "settings")?;
    let settings: SwingEnvSettings =
        serde_json::from_value(value).map_err(|e| bad(format!("settings: {e}")))?;
    settings.validate("settings").map_err(rs)?;
    let loaded = match scenario.filter(|s| !s.is_none()) {
        None => None,
        Some(s) => {
            if let Ok(sc) = s.cast::<Scenario>() {
                Some(sc.get().ls.clone())
            } else {
                let path: PathBuf = s.extract().map_err(|_| {
                    bad("scenario: expected None, a path to a scenario file or a Scenario")
                })?;
                Some(brachia_experiments::Scenario::load_for(&path, Uses::Track).map_err(rs)?)
            }
        }
    };
    let (robot, n) = match &loaded {
        Some(ls) => (None, ls.robot.n()),
        None => {
            let r = brachia::Robot::paper();
            let n = r.n();
            (Some(r), n)
        }
    };
    let randomization = match disturbances.filter(|d| !d.is_none()) {
        None => None,
        Some(d) => Some(randomization_of(
            d,
            "disturbances",
            n,
            settings.control_dt,
            settings.time_limit_s,
        )?),
    };
    let spec = match (&loaded, robot) {
        (Some(ls), _) => SwingEnvSpec::from_scenario(ls, plant, settings, randomization),
        (None, Some(r)) => SwingEnvSpec::new(
            &r,
            &SwingTask::paper(),
            plant.unwrap_or_default(),
            &PlantSettings::default(),
            settings,
            randomization,
            "Swing-v0 (the paper's V-B swing)",
        ),
        (None, None) => unreachable!("a robot is loaded when there is no scenario"),
    }
    .map_err(rs)?;
    Ok(Arc::new(spec))
}

/// A dict of the `[disturbances]` schema (ranges `{"uniform": [lo, hi]}` allowed).
fn randomization_of(
    d: &Bound<'_, PyAny>,
    src: &str,
    n: usize,
    control_dt: f64,
    time_limit_s: f64,
) -> PyResult<Randomization> {
    if !d.is_instance_of::<PyDict>() {
        return Err(bad(format!(
            "{src}: expected a dict of the scenario's [disturbances] schema, got {}",
            d.get_type().name()?
        )));
    }
    let text = to_json(d, src)?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("{src}: {e}")))?;
    let r = Randomization::new(value, src, n, control_dt).map_err(rs)?;
    r.check_pushes_within(time_limit_s).map_err(rs)?;
    Ok(r)
}

/// The spec's public facts as a dict.
fn spec_dict<'py>(py: Python<'py>, spec: &SwingEnvSpec) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let (lo, hi) = spec.observation_bounds();
    d.set_item("obs_low", lo.to_vec())?;
    d.set_item("obs_high", hi.to_vec())?;
    d.set_item("action_dim", spec.action_dim())?;
    d.set_item("n_links", spec.robot.n())?;
    d.set_item("target", spec.target.to_vec())?;
    d.set_item("x0", spec.x0.clone())?;
    d.set_item(
        "plant",
        match spec.plant {
            PlantKind::Model => "model",
            PlantKind::Rapier => "rapier",
        },
    )?;
    d.set_item("settings", to_py(py, &spec.settings)?)?;
    d.set_item("randomized", spec.randomization.is_random())?;
    Ok(d)
}

/// The info dict of a step.
fn info<'py>(py: Python<'py>, o: &StepOutcome, t: f64) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("captured", o.captured)?;
    d.set_item("out_of_limits", o.out_of_limits)?;
    d.set_item("distance_m", o.distance_m)?;
    d.set_item("t", t)?;
    d.set_item("capture", o.terms.capture)?;
    d.set_item("progress_m", o.terms.progress_m)?;
    d.set_item("energy_j", o.terms.energy_j)?;
    d.set_item("positive_work_j", o.terms.positive_work_j)?;
    Ok(d)
}

/// One swing environment (the Rust side of ``brachia.envs.SwingEnv``; use that class).
#[pyclass(module = "brachia", frozen)]
pub struct SwingCore {
    spec: Arc<SwingEnvSpec>,
    env: Shared<SwingEnv>,
}

#[pymethods]
impl SwingCore {
    #[new]
    #[pyo3(signature = (scenario = None, plant = None, settings = None, disturbances = None, seed = 0, **kwargs))]
    fn new(
        py: Python<'_>,
        scenario: Option<&Bound<'_, PyAny>>,
        plant: Option<&str>,
        settings: Option<&Bound<'_, PyAny>>,
        disturbances: Option<&Bound<'_, PyAny>>,
        seed: u64,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let spec = spec_of(scenario, plant, settings, kwargs, disturbances)?;
        let s = spec.clone();
        let env = py.detach(move || SwingEnv::new(s, seed)).map_err(rs)?;
        Ok(SwingCore {
            spec,
            env: Shared::new("SwingEnv", env),
        })
    }

    /// The spec: observation bounds, action size, robot size, target, start state, plant, settings.
    fn spec<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        spec_dict(py, &self.spec)
    }

    /// The nominal robot (what the observation's hand position is computed with).
    fn robot(&self) -> crate::model::Robot {
        crate::model::Robot {
            inner: self.spec.robot.clone(),
        }
    }

    /// Start an episode (``seed``: reseed the env's generator; ``disturbances``: this episode's,
    /// the scenario's schema with ranges); returns the first observation.
    #[pyo3(signature = (seed = None, disturbances = None))]
    fn reset<'py>(
        &self,
        py: Python<'py>,
        seed: Option<u64>,
        disturbances: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let r = match disturbances.filter(|d| !d.is_none()) {
            None => None,
            Some(d) => Some(randomization_of(
                d,
                "reset options[\"disturbances\"]",
                self.spec.robot.n(),
                self.spec.settings.control_dt,
                self.spec.settings.time_limit_s,
            )?),
        };
        let mut guard = self.env.lock(py)?;
        let env: &mut SwingEnv = &mut guard;
        let mut obs = vec![0f32; self.spec.observation_dim()];
        py.detach(|| {
            env.reset(seed, r.as_ref())?;
            env.observe(&mut obs);
            Ok::<(), brachia::Error>(())
        })
        .map_err(rs)?;
        arr_f32(py, &obs, &[obs.len()])
    }

    /// One control period: ``(obs, reward, terminated, truncated, info)``.
    fn step<'py>(
        &self,
        py: Python<'py>,
        action: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let nu = self.spec.action_dim();
        let mut a = [0.0; 16];
        let a = a
            .get_mut(..nu)
            .ok_or_else(|| bad("action: more than 16 joints"))?;
        read_actions(action, "action", &[nu], a)?;
        let mut env = self.env.lock(py)?;
        let o = env.step(a).map_err(rs)?;
        let mut obs = [0f32; 64];
        let d = self.spec.observation_dim();
        let obs = obs
            .get_mut(..d)
            .ok_or_else(|| bad("observation: more than 64 values"))?;
        env.observe(obs);
        let t = env.time();
        drop(env);
        let items: [Bound<'py, PyAny>; 5] = [
            arr_f32(py, obs, &[d])?,
            o.reward.into_pyobject(py)?.into_any(),
            pyo3::types::PyBool::new(py, o.terminated)
                .to_owned()
                .into_any(),
            pyo3::types::PyBool::new(py, o.truncated)
                .to_owned()
                .into_any(),
            info(py, &o, t)?.into_any(),
        ];
        PyTuple::new(py, items)
    }

    /// The current pose drawn by the project's plotting code: uint8 ``(height, width, 3)``.
    #[pyo3(signature = (width = 480, height = 360))]
    fn render<'py>(&self, py: Python<'py>, width: u32, height: u32) -> PyResult<Bound<'py, PyAny>> {
        let mut guard = self.env.lock(py)?;
        let env: &mut SwingEnv = &mut guard;
        let rgb = py
            .detach(move || env.render_rgb((width, height)))
            .map_err(|e| bad(format!("render: {e}")))?;
        arr_bytes(py, &rgb, "uint8", &[height as usize, width as usize, 3])
    }

    /// The current episode: its seed, its disturbances (ranges drawn), time, true state.
    fn episode<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let env = self.env.lock(py)?;
        let d = PyDict::new(py);
        d.set_item("seed", env.episode_seed())?;
        d.set_item("disturbances", to_py(py, env.disturbances())?)?;
        d.set_item("t", env.time())?;
        d.set_item("true_state", env.true_state().to_vec())?;
        d.set_item("done", env.done())?;
        Ok(d)
    }
}

/// Copies of one swing environment stepped together in parallel (the Rust side of
/// ``brachia.vector.SwingVectorEnv``; use that class).
#[pyclass(module = "brachia", frozen)]
pub struct SwingBatchCore {
    spec: Arc<SwingEnvSpec>,
    state: Shared<(SwingBatch, BatchOutput, Vec<f64>)>,
}

impl SwingBatchCore {
    /// The outputs of a call as a tuple.
    fn outputs<'py>(&self, py: Python<'py>, out: &BatchOutput) -> PyResult<Bound<'py, PyTuple>> {
        let m = out.reward.len();
        let d = self.spec.observation_dim();
        let f64s = |v: &[f64]| -> Vec<u8> { v.iter().flat_map(|x| x.to_ne_bytes()).collect() };
        let bools = |v: &[bool]| -> Vec<u8> { v.iter().map(|b| u8::from(*b)).collect() };
        let terms = PyDict::new(py);
        let cols: [(&str, Vec<f64>); 5] = [
            ("capture", out.terms.iter().map(|t| t.capture).collect()),
            (
                "progress_m",
                out.terms.iter().map(|t| t.progress_m).collect(),
            ),
            ("energy_j", out.terms.iter().map(|t| t.energy_j).collect()),
            (
                "positive_work_j",
                out.terms.iter().map(|t| t.positive_work_j).collect(),
            ),
            ("distance_m", out.distance_m.clone()),
        ];
        for (k, v) in cols {
            terms.set_item(k, arr_bytes(py, &f64s(&v), "float64", &[m])?)?;
        }
        let items: [Bound<'py, PyAny>; 7] = [
            arr_f32(py, &out.obs, &[m, d])?,
            arr_bytes(py, &f64s(&out.reward), "float64", &[m])?,
            arr_bytes(py, &bools(&out.terminated), "bool", &[m])?,
            arr_bytes(py, &bools(&out.truncated), "bool", &[m])?,
            terms.into_any(),
            arr_f32(py, &out.final_obs, &[m, d])?,
            arr_bytes(py, &bools(&out.ended), "bool", &[m])?,
        ];
        PyTuple::new(py, items)
    }
}

#[pymethods]
impl SwingBatchCore {
    #[new]
    #[pyo3(signature = (num_envs, scenario = None, plant = None, settings = None, disturbances = None,
        seed = 0, autoreset = "next-step", **kwargs))]
    fn new(
        py: Python<'_>,
        num_envs: usize,
        scenario: Option<&Bound<'_, PyAny>>,
        plant: Option<&str>,
        settings: Option<&Bound<'_, PyAny>>,
        disturbances: Option<&Bound<'_, PyAny>>,
        seed: u64,
        autoreset: &str,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let mode = match autoreset {
            "next-step" => Autoreset::NextStep,
            "same-step" => Autoreset::SameStep,
            other => {
                return Err(bad(format!(
                    "autoreset = {other:?}: expected \"next-step\" or \"same-step\""
                )))
            }
        };
        let spec = spec_of(scenario, plant, settings, kwargs, disturbances)?;
        let s = spec.clone();
        let batch = py
            .detach(move || SwingBatch::new(s, num_envs, seed, mode))
            .map_err(rs)?;
        let out = batch.output();
        let actions = vec![0.0; num_envs * spec.action_dim()];
        Ok(SwingBatchCore {
            spec,
            state: Shared::new("SwingVectorEnv", (batch, out, actions)),
        })
    }

    /// The spec (as ``SwingCore.spec``).
    fn spec<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        spec_dict(py, &self.spec)
    }

    /// Reset every copy (copy ``i`` reseeded with ``seed + i``; ``disturbances`` for these
    /// episodes); returns the observations ``(envs, obs_dim)``.
    #[pyo3(signature = (seed = None, disturbances = None))]
    fn reset<'py>(
        &self,
        py: Python<'py>,
        seed: Option<u64>,
        disturbances: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let r = match disturbances.filter(|d| !d.is_none()) {
            None => None,
            Some(d) => Some(randomization_of(
                d,
                "reset options[\"disturbances\"]",
                self.spec.robot.n(),
                self.spec.settings.control_dt,
                self.spec.settings.time_limit_s,
            )?),
        };
        let mut st = self.state.lock(py)?;
        let (batch, out, _) = &mut *st;
        py.detach(|| batch.reset(seed, r.as_ref(), out))
            .map_err(rs)?;
        let m = batch.len();
        arr_f32(py, &out.obs, &[m, self.spec.observation_dim()])
    }

    /// One control period of every copy, ``actions`` ``(envs, n - 1)``: ``(obs, rewards,
    /// terminated, truncated, terms, final_obs, ended)``; the copies step in parallel with the GIL
    /// released.
    fn step<'py>(
        &self,
        py: Python<'py>,
        actions: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let mut st = self.state.lock(py)?;
        let (batch, out, a) = &mut *st;
        let shape = [batch.len(), self.spec.action_dim()];
        read_actions(actions, "actions", &shape, a)?;
        py.detach(|| batch.step(a, out)).map_err(rs)?;
        self.outputs(py, out)
    }

    /// The episode seeds and disturbances of every copy (list of dicts).
    fn episodes<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let st = self.state.lock(py)?;
        st.0.envs()
            .iter()
            .map(|env| {
                let d = PyDict::new(py);
                d.set_item("seed", env.episode_seed())?;
                d.set_item("disturbances", to_py(py, env.disturbances())?)?;
                d.set_item("t", env.time())?;
                Ok(d)
            })
            .collect()
    }
}
