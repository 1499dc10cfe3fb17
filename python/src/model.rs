//! `Robot` (parameters, kinematics, dynamics) and `Trajectory` (a sampled swing).
//!
//! Conventions: `q[0]` absolute angle of link 1 from +x, `q[i >= 1]` relative (rad); `qd` in rad/s;
//! `tau` = torques of joints 2..n (N m); positions in m in the grip frame (y up, gravity along -y).
//! `M` is `(n, n)`, `Cqd`, `G`, `qdd` are `(n,)`, `joint_positions` is `(n + 1, 2)`, `ee_jacobian` is
//! `(2, n)`.

use crate::convert::{arr1, arr2, bad, matrix, rs, to_py, vector};
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
        vector(q, "q", self.inner.n(), "joint angles, rad")
    }
    /// `qd` (n values, rad/s).
    fn qd(&self, qd: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        vector(qd, "qd", self.inner.n(), "joint velocities, rad/s")
    }
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
        arr2(py, self.inner.mass_matrix(&q), self.inner.n())
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
        arr1(py, &out)
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
        arr1(py, &out)
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
        let tau = vector(tau, "tau", self.inner.nu(), "torques of joints 2..n, N m")?;
        arr1(py, &self.inner.forward_dynamics(&q, &qd, &tau))
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
        let qdd = vector(qdd, "qdd", n, "joint accelerations, rad/s^2")?;
        let mut out = vec![0.0; n];
        self.inner
            .inverse_dynamics_into(&mut Scratch::new(n), &q, &qd, &qdd, &mut out);
        arr1(py, &out)
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
        arr2(py, pts.concat(), 2)
    }

    /// End-effector (distal tip of link n) position ``[x, y]``, m, shape ``(2,)``.
    fn ee_position<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let q = self.q(q)?;
        arr1(py, &self.inner.ee_position(&q))
    }

    /// End-effector velocity ``J(q) qd``, m/s, shape ``(2,)``.
    fn ee_velocity<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        qd: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (q, qd) = (self.q(q)?, self.qd(qd)?);
        arr1(py, &self.inner.ee_velocity(&q, &qd))
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
        arr2(py, jac, n)
    }

    /// Total mechanical energy (kinetic + potential, zero potential at the grip height), J.
    fn energy(&self, q: &Bound<'_, PyAny>, qd: &Bound<'_, PyAny>) -> PyResult<f64> {
        let (q, qd) = (self.q(q)?, self.qd(qd)?);
        Ok(self.inner.energy(&q, &qd))
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

#[pymethods]
impl Trajectory {
    /// A trajectory from arrays: ``t`` (samples,) strictly increasing; ``q``, ``qd``
    /// (samples, n); ``tau`` (samples, n - 1). n is read from ``q`` (2..=12 links).
    #[new]
    fn new(
        t: &Bound<'_, PyAny>,
        q: &Bound<'_, PyAny>,
        qd: &Bound<'_, PyAny>,
        tau: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let tv = crate::convert::any_vector(t, "t", MAX_SAMPLES)?;
        let len = tv.len();
        if len == 0 || len > MAX_SAMPLES {
            return Err(bad(format!(
                "t: {len} samples; a trajectory needs 1..={MAX_SAMPLES} (brachia::limits::MAX_OUTPUT_SAMPLES)"
            )));
        }
        if let Some(k) = (1..len).find(|&k| tv[k] <= tv[k - 1]) {
            return Err(bad(format!(
                "t[{k}] = {}: times must increase strictly (t[{}] = {})",
                tv[k],
                k - 1,
                tv[k - 1]
            )));
        }
        let n = crate::convert::columns(q, "q")?;
        if !(2..=MAX_LINKS).contains(&n) {
            return Err(bad(format!(
                "q: {n} columns; a robot has 2..={MAX_LINKS} links (one column per joint)"
            )));
        }
        let (qv, _) = matrix(q, "q", Some(len), n, "joint angles per sample, rad")?;
        let (qdv, _) = matrix(qd, "qd", Some(len), n, "joint velocities per sample, rad/s")?;
        let (tauv, _) = matrix(
            tau,
            "tau",
            Some(len),
            n - 1,
            "torques of joints 2..n per sample, N m",
        )?;
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
    fn state_at<'py>(&self, py: Python<'py>, t: f64) -> PyResult<Bound<'py, PyAny>> {
        if !t.is_finite() {
            return Err(bad(format!("t = {t}: must be finite")));
        }
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
