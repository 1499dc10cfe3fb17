//! `Robot` (parameters, kinematics, dynamics) and `Trajectory` (a sampled swing).
//!
//! Conventions: `q[0]` absolute angle of link 1 from +x, `q[i >= 1]` relative (rad); `qd` in rad/s;
//! `tau` = torques of joints 2..n (N m); positions in m in the grip frame (y up, gravity along -y).
//! `M` is `(n, n)`, `Cqd`, `G`, `qdd` are `(n,)`, `joint_positions` is `(n + 1, 2)`, `ee_jacobian` is
//! `(2, n)`.

use crate::convert::{
    any_vector, arr1, arr2, bad, finite_result, matrix, num, rs, scalar, vector, vector_or_rows,
    Arg, Range, Real,
};
use crate::dicts::to_py;
use brachia::model::{Scratch, MAX_LINKS};
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;

/// A validated robot: a planar chain of n links hanging from the grip point (joint 1, passive).
///
/// Build it with ``Robot.from_toml(path)``, ``Robot.from_toml_str(text)`` or ``Robot.paper()``.
/// Angles: ``q[0]`` absolute angle of link 1 from +x (counter-clockwise), ``q[i]`` (i >= 1) relative to
/// link i; rad, rad/s, N m, m, kg. Every method checks the lengths of its arrays (``BrachiaError``).
#[pyclass(module = "brachia", frozen)]
pub struct Robot {
    pub(crate) inner: Arc<brachia::Robot>,
}

impl Robot {
    /// `q` (n values, rad).
    fn q(&self, q: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        vector(
            q,
            Arg::new("q", "joint angles, rad", Range::Angle),
            self.inner.n(),
        )
    }
    /// `qd` (n values, rad/s).
    fn qd(&self, qd: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        let arg = Arg::new("qd", "joint velocities, rad/s", Range::Rate);
        vector(qd, arg, self.inner.n())
    }

    /// `f` applied to `v` (n values) or to each row of `v` (k x n), as a numpy array of the same
    /// shape (`what` names the call).
    fn map_rows<'py>(
        &self,
        py: Python<'py>,
        v: &Bound<'_, PyAny>,
        arg: Arg<'_>,
        what: &str,
        f: impl Fn(&brachia::Robot, &[f64]) -> Vec<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = self.inner.n();
        let (values, rows) = vector_or_rows(v, arg, n)?;
        let out: Vec<f64> = values.chunks(n).flat_map(|r| f(&self.inner, r)).collect();
        match rows {
            Some(_) => out2(py, out, n, what),
            None => out1(py, &out, what),
        }
    }
}

/// `v` as a numpy vector once it is finite (`what` names the call).
fn out1<'py>(py: Python<'py>, v: &[f64], what: &str) -> PyResult<Bound<'py, PyAny>> {
    arr1(py, finite_result(v, what)?)
}

/// `v` (rows of `cols`) as a numpy matrix once it is finite (`what` names the call).
fn out2<'py>(py: Python<'py>, v: Vec<f64>, cols: usize, what: &str) -> PyResult<Bound<'py, PyAny>> {
    finite_result(&v, what)?;
    arr2(py, v, cols)
}

#[pymethods]
impl Robot {
    /// Load and validate a robot parameters file (TOML, see ``params/paper.toml``).
    ///
    /// Raises ``BrachiaError`` naming the file, the field, the value and the rule.
    #[staticmethod]
    fn from_toml(path: PathBuf) -> PyResult<Self> {
        let r = brachia::Robot::from_toml_file(&path).map_err(rs)?;
        Ok(Robot { inner: Arc::new(r) })
    }

    /// Parse and validate robot parameters from TOML text; ``source_name`` names it in errors.
    #[staticmethod]
    #[pyo3(signature = (text, source_name = "<string>"))]
    fn from_toml_str(text: &str, source_name: &str) -> PyResult<Self> {
        if text.len() > brachia::limits::MAX_TOML_BYTES as usize {
            return Err(bad(format!(
                "{source_name}: {} bytes; a parameters text may have at most {} (brachia::limits::MAX_TOML_BYTES)",
                text.len(),
                brachia::limits::MAX_TOML_BYTES
            )));
        }
        let p = brachia::model::RobotParams::from_toml_str(text, source_name).map_err(rs)?;
        let r = brachia::Robot::from_params(p, source_name).map_err(rs)?;
        Ok(Robot { inner: Arc::new(r) })
    }

    /// Import the serial chain of a URDF file (docs/robots.md): ``grip`` names the grip joint,
    /// ``tip`` the tip link (``"LINK"`` or ``"LINK:x,y,z"``, a point in its frame, m); ``passive``
    /// the joints without an actuator when the file has no ``<transmission>``; ``ignore`` branches
    /// off the chain to leave out; ``gravity`` the URDF world's, along -z (m/s^2).
    ///
    /// Raises ``BrachiaError`` naming the file, the URDF element, the value and the rule.
    #[staticmethod]
    #[pyo3(signature = (path, grip, tip, passive = Vec::new(), ignore = Vec::new(), gravity = 9.81))]
    fn from_urdf(
        path: PathBuf,
        grip: String,
        tip: &str,
        passive: Vec<String>,
        ignore: Vec<String>,
        gravity: f64,
    ) -> PyResult<Self> {
        let tip: brachia::urdf::Tip = tip.parse().map_err(bad)?;
        if !(gravity.is_finite() && (0.0..=brachia::limits::MAX_GRAVITY).contains(&gravity)) {
            return Err(bad(format!(
                "gravity = {gravity}: must be in [0, {}] m/s^2",
                brachia::limits::MAX_GRAVITY
            )));
        }
        let opts = brachia::urdf::UrdfOptions {
            passive,
            ignore,
            gravity,
            ..brachia::urdf::UrdfOptions::new(grip, tip)
        };
        let imp = brachia::urdf::import_urdf_file(&path, &opts).map_err(rs)?;
        let r = brachia::Robot::from_params(imp.params, &path.display().to_string()).map_err(rs)?;
        Ok(Robot { inner: Arc::new(r) })
    }

    /// The robot as a URDF document (grip joint ``grip``, tip link ``tip``, joints in the x-z
    /// plane turning about -y; docs/robots.md, "Export").
    fn to_urdf(&self) -> PyResult<String> {
        brachia::urdf::to_urdf(&self.inner).map_err(rs)
    }

    /// The robot as a MuJoCo MJCF document (hinge joints about -y, motors on joints 2..n, RK4 at
    /// 1 ms).
    fn to_mjcf(&self) -> String {
        brachia::urdf::to_mjcf(&self.inner)
    }

    /// brachia's ``q`` from the robot's own (URDF) joint angles ``phi``:
    /// ``q_i = s_i phi_i + joint_offset_i`` (``s_i = -1`` for a reversed joint). ``phi`` of shape
    /// ``(n,)``, or ``(k, n)`` for a whole trajectory (one row per sample).
    fn q_from_urdf<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'_, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let arg = Arg::new("q", "joint angles, rad", Range::Angle);
        self.map_rows(py, q, arg, "q_from_urdf", |r, v| r.q_from_joint_angles(v))
    }

    /// The robot's own (URDF) joint angles from brachia's ``q``:
    /// ``phi_i = s_i (q_i - joint_offset_i)``; shape ``(n,)`` or ``(k, n)`` (a trajectory's ``q``).
    fn q_to_urdf<'py>(&self, py: Python<'py>, q: &Bound<'_, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let arg = Arg::new("q", "joint angles, rad", Range::Angle);
        self.map_rows(py, q, arg, "q_to_urdf", |r, v| r.q_to_joint_angles(v))
    }

    /// The robot's own (URDF) joint velocities from brachia's ``qd``; shape ``(n,)`` or ``(k, n)``.
    fn qd_to_urdf<'py>(
        &self,
        py: Python<'py>,
        qd: &Bound<'_, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let arg = Arg::new("qd", "joint velocities, rad/s", Range::Rate);
        self.map_rows(py, qd, arg, "qd_to_urdf", |r, v| r.qd_to_joint_rates(v))
    }

    /// The paper's 4-link robot (Table I, ``params/paper.toml``).
    #[staticmethod]
    fn paper() -> Self {
        Robot {
            inner: Arc::new(brachia::Robot::paper()),
        }
    }

    /// Number of links n (= joints).
    #[getter]
    fn n_links(&self) -> usize {
        self.inner.n()
    }

    /// State dimension 2n (``x = [q, qd]``).
    #[getter]
    fn nx(&self) -> usize {
        self.inner.nx()
    }

    /// Number of actuated joints n - 1 (length of ``tau``).
    #[getter]
    fn nu(&self) -> usize {
        self.inner.nu()
    }

    /// The name from the parameters file.
    #[getter]
    fn name(&self) -> String {
        self.inner.params().name.clone()
    }

    /// Gravitational acceleration, m/s^2 (along -y).
    #[getter]
    fn gravity(&self) -> f64 {
        self.inner.gravity
    }

    /// Link lengths, m, shape ``(n,)``.
    #[getter]
    fn lengths<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, self.inner.lengths())
    }

    /// Link masses, kg, shape ``(n,)``.
    #[getter]
    fn masses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, self.inner.masses())
    }

    /// Lower torque limits of joints 2..n, N m, shape ``(n - 1,)``.
    #[getter]
    fn tau_min<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, &self.inner.tau_min)
    }

    /// Upper torque limits of joints 2..n, N m, shape ``(n - 1,)``.
    #[getter]
    fn tau_max<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, &self.inner.tau_max)
    }

    /// The parameters as a dict (the TOML schema: name, gravity, links, actuators).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, self.inner.params())
    }

    /// Mass matrix ``M(q)``, shape ``(n, n)``, kg m^2 (symmetric positive definite).
    #[pyo3(name = "M")]
    fn mass_matrix<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = self.q(q)?;
        out2(py, self.inner.mass_matrix(&q), self.inner.n(), "M")
    }

    /// Coriolis and centrifugal forces ``C(q, qd) qd``, shape ``(n,)``, N m.
    #[pyo3(name = "Cqd")]
    fn coriolis<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        qd: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (q, qd) = (self.q(q)?, self.qd(qd)?);
        let n = self.inner.n();
        let mut out = vec![0.0; n];
        self.inner
            .coriolis_into(&mut Scratch::new(n), &q, &qd, &mut out);
        out1(py, &out, "Cqd")
    }

    /// Gravity forces ``G(q) = dV/dq``, shape ``(n,)``, N m.
    #[pyo3(name = "G")]
    fn gravity_forces<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = self.q(q)?;
        let n = self.inner.n();
        let mut out = vec![0.0; n];
        self.inner.gravity_into(&mut Scratch::new(n), &q, &mut out);
        out1(py, &out, "G")
    }

    /// Forward dynamics ``qdd = M^-1 (B tau - C qd - G)``, shape ``(n,)``, rad/s^2; ``tau`` has n - 1
    /// values (joints 2..n, N m; not clamped).
    fn qdd<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        qd: &Bound<'py, PyAny>,
        tau: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (q, qd) = (self.q(q)?, self.qd(qd)?);
        let arg = Arg::new("tau", "torques of joints 2..n, N m", Range::Torque);
        let tau = vector(tau, arg, self.inner.nu())?;
        out1(py, &self.inner.forward_dynamics(&q, &qd, &tau), "qdd")
    }

    /// Inverse dynamics ``M qdd + C qd + G``, shape ``(n,)``, N m: entry 0 (the passive grip) is zero
    /// for a motion the robot can make, entries 1.. are the torques.
    fn inverse_dynamics<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        qd: &Bound<'py, PyAny>,
        qdd: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (q, qd) = (self.q(q)?, self.qd(qd)?);
        let n = self.inner.n();
        let arg = Arg::new("qdd", "joint accelerations, rad/s^2", Range::Accel);
        let qdd = vector(qdd, arg, n)?;
        let mut out = vec![0.0; n];
        self.inner
            .inverse_dynamics_into(&mut Scratch::new(n), &q, &qd, &qdd, &mut out);
        out1(py, &out, "inverse_dynamics")
    }

    /// Joint positions, shape ``(n + 1, 2)``, m: row 0 the grip (origin), row i the distal end of
    /// link i, row n the end effector.
    fn joint_positions<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = self.q(q)?;
        let mut pts = vec![[0.0; 2]; self.inner.n() + 1];
        self.inner.joint_positions(&q, &mut pts);
        out2(py, pts.concat(), 2, "joint_positions")
    }

    /// End-effector (distal tip of link n) position ``[x, y]``, m, shape ``(2,)``.
    fn ee_position<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = self.q(q)?;
        out1(py, &self.inner.ee_position(&q), "ee_position")
    }

    /// End-effector velocity ``J(q) qd``, m/s, shape ``(2,)``.
    fn ee_velocity<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        qd: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (q, qd) = (self.q(q)?, self.qd(qd)?);
        out1(py, &self.inner.ee_velocity(&q, &qd), "ee_velocity")
    }

    /// End-effector Jacobian ``J = d ee / d q``, shape ``(2, n)``, m/rad.
    fn ee_jacobian<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = self.q(q)?;
        let n = self.inner.n();
        let mut jac = vec![0.0; 2 * n];
        self.inner.ee_jacobian(&q, &mut jac);
        out2(py, jac, n, "ee_jacobian")
    }

    /// Total mechanical energy (kinetic + potential, zero potential at the grip height), J.
    fn energy(&self, q: &Bound<'_, PyAny>, qd: &Bound<'_, PyAny>) -> PyResult<f64> {
        let (q, qd) = (self.q(q)?, self.qd(qd)?);
        Ok(finite_result(&[self.inner.energy(&q, &qd)], "energy")?[0])
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot(name={:?}, n_links={}, gravity={})",
            self.inner.params().name,
            self.inner.n(),
            self.inner.gravity
        )
    }
}

/// A sampled trajectory: times ``t`` (samples,), s; ``q``, ``qd`` (samples, n), rad and rad/s;
/// ``tau`` (samples, n - 1), N m (joints 2..n). The reference a controller tracks.
#[pyclass(module = "brachia", frozen)]
pub struct Trajectory {
    pub(crate) inner: Arc<brachia::trajectory::Trajectory>,
}

/// Largest number of samples accepted from Python (the planner's own output cap).
const MAX_SAMPLES: usize = brachia::limits::MAX_OUTPUT_SAMPLES;

/// Shortest time between two samples of a trajectory, s (the planner's finest output is 0.2 ms;
/// closer samples only come from a time column in the wrong unit, or from numerical noise).
pub(crate) const MIN_SAMPLE_DT_S: f64 = 1e-6;

#[pymethods]
impl Trajectory {
    /// A trajectory from arrays: ``t`` (samples,) from 0 to at most 600 s, increasing by at least
    /// 1e-6 s per sample; ``q``, ``qd`` (samples, n); ``tau`` (samples, n - 1). n is read from ``q``
    /// (2..=12 links); at least 2 samples. Angles, velocities and torques obey the rules of
    /// docs/python.md (``|q| <= 4 pi`` rad, ``|qd| <= 1000`` rad/s, ``|tau| <= 1e6`` N m).
    #[new]
    fn new(
        t: &Bound<'_, PyAny>,
        q: &Bound<'_, PyAny>,
        qd: &Bound<'_, PyAny>,
        tau: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let targ = Arg::new("t", "sample times, s", Range::Time);
        let tv = any_vector(t, targ, 2, MAX_SAMPLES)?;
        if let Some(k) = (1..tv.len()).find(|&k| tv[k] - tv[k - 1] < MIN_SAMPLE_DT_S) {
            return Err(bad(format!(
                "t[{k}] = {}: times must increase by at least {MIN_SAMPLE_DT_S:e} s per sample \
                 (t[{}] = {})",
                num(tv[k]),
                k - 1,
                num(tv[k - 1])
            )));
        }
        let len = tv.len();
        let qarg = Arg::new("q", "joint angles per sample, rad", Range::Angle);
        let (qv, _, n) = matrix(q, qarg, Some(len), None)?;
        if !(2..=MAX_LINKS).contains(&n) {
            return Err(bad(format!(
                "q: {n} columns; a robot has 2..={MAX_LINKS} links (one column per joint)"
            )));
        }
        let qdarg = Arg::new("qd", "joint velocities per sample, rad/s", Range::Rate);
        let (qdv, _, _) = matrix(qd, qdarg, Some(len), Some(n))?;
        let tauarg = Arg::new(
            "tau",
            "torques of joints 2..n per sample, N m",
            Range::Torque,
        );
        let (tauv, _, _) = matrix(tau, tauarg, Some(len), Some(n - 1))?;
        Ok(Trajectory {
            inner: Arc::new(brachia::trajectory::Trajectory {
                n,
                t: tv,
                q: qv,
                qd: qdv,
                tau: tauv,
            }),
        })
    }

    /// Number of links n.
    #[getter]
    fn n_links(&self) -> usize {
        self.inner.n
    }

    /// Sample times, s, shape ``(samples,)``.
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, &self.inner.t)
    }

    /// Joint angles, rad, shape ``(samples, n)``.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.inner.q.clone(), self.inner.n)
    }

    /// Joint velocities, rad/s, shape ``(samples, n)``.
    #[getter]
    fn qd<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.inner.qd.clone(), self.inner.n)
    }

    /// Torques of joints 2..n, N m, shape ``(samples, n - 1)``.
    #[getter]
    fn tau<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.inner.tau.clone(), self.inner.n - 1)
    }

    /// Duration (last time minus first), s.
    #[getter]
    fn duration(&self) -> f64 {
        self.inner.duration()
    }

    /// State ``[q, qd]`` at time ``t`` (linear interpolation between samples, held past the ends),
    /// shape ``(2n,)``.
    fn state_at<'py>(&self, py: Python<'py>, t: Real) -> PyResult<Bound<'py, PyAny>> {
        let t = scalar("t", t.0, None)?;
        let mut x = vec![0.0; 2 * self.inner.n];
        self.inner.state_at(t, &mut x);
        arr1(py, &x)
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Trajectory(n_links={}, samples={}, duration={:.6})",
            self.inner.n,
            self.inner.len(),
            self.inner.duration()
        )
    }
}
