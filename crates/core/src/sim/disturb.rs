//! Disturbances on the actuation side, as plant wrappers: each wraps any [`Plant`] and changes what
//! the torque commanded over a control period does to it. Measurement-side wrappers are
//! [`super::Noisy`] (sensor noise) and [`MeasurementDelay`].
//!
//! Conventions: torques of joints 2..n in N m, time in s, state `x = [q (n), qd (n)]` (rad, rad/s).
//! A wrapper's [`Plant::step`] receives the torque the controller commanded (clamped by the loop) and
//! holds it over `[t_k, t_k + dt)`; [`ActuationDelay::applied`] / [`MotorLag::applied`] give the
//! torque actually handed to the inner plant at the last step. Delays are whole numbers of control
//! periods (`round(delay_s / dt)`); the loop logs the commanded torque.
//! Units and defaults of every disturbance: docs/robustness.md.

use super::Plant;
use crate::error::{Error, Result};

/// Number of control periods in `delay_s` (rounded), checked: `delay_s` finite, in
/// `[0, MAX_DELAY_S]`, `dt > 0` and at most `MAX_DELAY_STEPS` periods. `what` names the field.
pub fn delay_steps(what: &str, delay_s: f64, dt: f64) -> Result<usize> {
    let max = crate::limits::MAX_DELAY_S;
    if !(delay_s.is_finite() && (0.0..=max).contains(&delay_s)) {
        return Err(Error::invalid(
            what,
            "delay_s",
            delay_s,
            format!("must be finite and in [0, {max}] s (brachia::limits::MAX_DELAY_S)"),
        ));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::invalid(what, "control_dt", dt, "must be > 0"));
    }
    let smax = crate::limits::MAX_DELAY_STEPS;
    match crate::limits::count(delay_s, dt, smax) {
        Some(c) => Ok(c),
        None => Err(Error::invalid(
            what,
            "delay_s",
            delay_s,
            format!(
                "{delay_s} s at a {dt} s period is more than {smax} steps \
                 (brachia::limits::MAX_DELAY_STEPS)"
            ),
        )),
    }
}

/// Actuation delay: the torque commanded at step k reaches the inner plant at step k + d (d control
/// periods later); over the first d steps the inner plant gets zero torque (nothing commanded has
/// arrived yet).
#[derive(Debug, Clone)]
pub struct ActuationDelay<P> {
    inner: P,
    delay: usize,
    /// Ring of the last `delay` commands, `delay x nu`.
    ring: Vec<f64>,
    head: usize,
    applied: Vec<f64>,
}

impl<P: Plant> ActuationDelay<P> {
    /// Delay the inner plant's torques by `delay_steps` control periods (at most
    /// [`crate::limits::MAX_DELAY_STEPS`]; see [`delay_steps`] to convert seconds).
    pub fn new(inner: P, delay_steps: usize) -> Result<Self> {
        let max = crate::limits::MAX_DELAY_STEPS;
        if delay_steps > max {
            return Err(Error::invalid(
                "ActuationDelay",
                "delay_steps",
                delay_steps,
                format!("must be at most {max} (brachia::limits::MAX_DELAY_STEPS)"),
            ));
        }
        let nu = inner.n_links().saturating_sub(1);
        Ok(ActuationDelay {
            inner,
            delay: delay_steps,
            ring: vec![0.0; delay_steps * nu],
            head: 0,
            applied: vec![0.0; nu],
        })
    }

    /// The delay, control periods.
    pub fn delay_steps(&self) -> usize {
        self.delay
    }

    /// The torque handed to the inner plant at the last step (zeros before the first), N m.
    pub fn applied(&self) -> &[f64] {
        &self.applied
    }

    /// The wrapped plant.
    pub fn inner(&self) -> &P {
        &self.inner
    }

    /// The wrapped plant, mutable.
    pub fn inner_mut(&mut self) -> &mut P {
        &mut self.inner
    }
}

impl<P: Plant> Plant for ActuationDelay<P> {
    forward_plant!();
    fn step(&mut self, tau: &[f64], dt: f64) {
        let nu = self.applied.len();
        if self.delay == 0 {
            self.applied.copy_from_slice(&tau[..nu]);
        } else {
            let slot = &mut self.ring[self.head * nu..(self.head + 1) * nu];
            self.applied.copy_from_slice(slot);
            slot.copy_from_slice(&tau[..nu]);
            self.head = (self.head + 1) % self.delay;
        }
        self.inner.step(&self.applied, dt);
    }
}

/// First-order motor lag: the torque the motor delivers, `tau_m`, follows the command `u` as
/// `T dtau_m/dt = u - tau_m` (time constant `T`, s), starting from zero. Over a period with `u` held,
/// `tau_m(t_k + s) = u + (tau_m(t_k) - u) exp(-s / T)`; the inner plant receives the mean of that over
/// the period, `u + (tau_m(t_k) - u) (T / dt) (1 - exp(-dt / T))` (exact impulse), and `tau_m` ends the
/// period at `u + (tau_m(t_k) - u) exp(-dt / T)`. `T = 0` passes the command through.
#[derive(Debug, Clone)]
pub struct MotorLag<P> {
    inner: P,
    time_constant_s: f64,
    /// The motor torque at the start of the next period, N m.
    state: Vec<f64>,
    applied: Vec<f64>,
}

impl<P: Plant> MotorLag<P> {
    /// Lag the inner plant's torques with time constant `time_constant_s` (finite, in
    /// `[0, MAX_MOTOR_TAU_S]`).
    pub fn new(inner: P, time_constant_s: f64) -> Result<Self> {
        let max = crate::limits::MAX_MOTOR_TAU_S;
        if !(time_constant_s.is_finite() && (0.0..=max).contains(&time_constant_s)) {
            return Err(Error::invalid(
                "MotorLag",
                "time_constant_s",
                time_constant_s,
                format!("must be finite and in [0, {max}] s (brachia::limits::MAX_MOTOR_TAU_S)"),
            ));
        }
        let nu = inner.n_links().saturating_sub(1);
        Ok(MotorLag {
            inner,
            time_constant_s,
            state: vec![0.0; nu],
            applied: vec![0.0; nu],
        })
    }

    /// The motor torque now (at the end of the last period), N m.
    pub fn motor_torque(&self) -> &[f64] {
        &self.state
    }

    /// The torque handed to the inner plant at the last step (the mean over that period), N m.
    pub fn applied(&self) -> &[f64] {
        &self.applied
    }

    /// The wrapped plant.
    pub fn inner(&self) -> &P {
        &self.inner
    }

    /// The wrapped plant, mutable.
    pub fn inner_mut(&mut self) -> &mut P {
        &mut self.inner
    }
}

impl<P: Plant> Plant for MotorLag<P> {
    forward_plant!();
    fn step(&mut self, tau: &[f64], dt: f64) {
        let tc = self.time_constant_s;
        let (decay, mean) = if tc > 0.0 && dt > 0.0 {
            let e = (-dt / tc).exp();
            // (T / dt)(1 - e^{-dt/T}), by expm1 so that dt << T keeps its digits
            (e, -(tc / dt) * (-dt / tc).exp_m1())
        } else {
            (0.0, 0.0)
        };
        for j in 0..self.state.len() {
            let (u, m0) = (tau[j], self.state[j]);
            self.applied[j] = u + (m0 - u) * mean;
            self.state[j] = u + (m0 - u) * decay;
        }
        self.inner.step(&self.applied, dt);
    }
}

/// Measurement delay: the controller sees the inner plant's measured state of d control periods ago
/// (the start state over the first d periods); the true state (logged) is current.
#[derive(Debug, Clone)]
pub struct MeasurementDelay<P> {
    inner: P,
    delay: usize,
    /// Ring of the last `delay + 1` measurements, `(delay + 1) x 2n`; `head` is the oldest.
    ring: Vec<f64>,
    head: usize,
}

impl<P: Plant> MeasurementDelay<P> {
    /// Delay the inner plant's measurements by `delay_steps` control periods (at most
    /// [`crate::limits::MAX_DELAY_STEPS`]; see [`delay_steps`] to convert seconds).
    pub fn new(inner: P, delay_steps: usize) -> Result<Self> {
        let max = crate::limits::MAX_DELAY_STEPS;
        if delay_steps > max {
            return Err(Error::invalid(
                "MeasurementDelay",
                "delay_steps",
                delay_steps,
                format!("must be at most {max} (brachia::limits::MAX_DELAY_STEPS)"),
            ));
        }
        let nx = 2 * inner.n_links();
        let mut ring = vec![0.0; (delay_steps + 1) * nx];
        inner.state(&mut ring[..nx]);
        for k in 1..=delay_steps {
            ring.copy_within(..nx, k * nx);
        }
        Ok(MeasurementDelay {
            inner,
            delay: delay_steps,
            ring,
            head: 0,
        })
    }

    /// The wrapped plant.
    pub fn inner(&self) -> &P {
        &self.inner
    }
}

impl<P: Plant> Plant for MeasurementDelay<P> {
    forward_plant!(own_state);
    /// The inner plant's measurement of `delay` periods ago.
    fn state(&self, x: &mut [f64]) {
        let nx = x.len();
        x.copy_from_slice(&self.ring[self.head * nx..(self.head + 1) * nx]);
    }
    fn step(&mut self, tau: &[f64], dt: f64) {
        self.inner.step(tau, dt);
        let nx = 2 * self.inner.n_links();
        // the oldest slot takes the newest measurement and the next slot becomes the oldest
        let (h, slots) = (self.head, self.delay + 1);
        self.inner.state(&mut self.ring[h * nx..(h + 1) * nx]);
        self.head = (h + 1) % slots;
    }
}

/// Gaussian torque noise: the inner plant receives `tau + e`, `e_j ~ N(0, std^2)` drawn afresh every
/// control period (ChaCha8 from `seed`, joints in order), so the noise is white at the control rate.
#[derive(Debug, Clone)]
pub struct TorqueNoise<P> {
    inner: P,
    std_nm: f64,
    rng: rand_chacha::ChaCha8Rng,
    applied: Vec<f64>,
}

impl<P: Plant> TorqueNoise<P> {
    /// Add noise of standard deviation `std_nm` (finite, in `[0, MAX_TORQUE_NOISE_NM]`) N m.
    pub fn new(inner: P, std_nm: f64, seed: u64) -> Result<Self> {
        use rand::SeedableRng;
        let max = crate::limits::MAX_TORQUE_NOISE_NM;
        if !(std_nm.is_finite() && (0.0..=max).contains(&std_nm)) {
            return Err(Error::invalid(
                "TorqueNoise",
                "std_nm",
                std_nm,
                format!(
                    "must be finite and in [0, {max}] N m (brachia::limits::MAX_TORQUE_NOISE_NM)"
                ),
            ));
        }
        let nu = inner.n_links().saturating_sub(1);
        Ok(TorqueNoise {
            inner,
            std_nm,
            rng: rand_chacha::ChaCha8Rng::seed_from_u64(seed),
            applied: vec![0.0; nu],
        })
    }

    /// The torque handed to the inner plant at the last step, N m.
    pub fn applied(&self) -> &[f64] {
        &self.applied
    }
}

impl<P: Plant> Plant for TorqueNoise<P> {
    forward_plant!();
    fn step(&mut self, tau: &[f64], dt: f64) {
        for j in 0..self.applied.len() {
            self.applied[j] = tau[j] + self.std_nm * super::noisy::normal(&mut self.rng);
        }
        self.inner.step(&self.applied, dt);
    }
}

/// Lower torque limits than the planner's: the inner plant receives `tau` clamped to
/// `[-limit, limit]` on every actuated joint.
#[derive(Debug, Clone)]
pub struct TorqueLimit<P> {
    inner: P,
    limit_nm: f64,
    applied: Vec<f64>,
}

impl<P: Plant> TorqueLimit<P> {
    /// Clamp to `+-limit_nm` (finite, > 0).
    pub fn new(inner: P, limit_nm: f64) -> Result<Self> {
        if !(limit_nm.is_finite() && limit_nm > 0.0) {
            return Err(Error::invalid(
                "TorqueLimit",
                "limit_nm",
                limit_nm,
                "must be finite and > 0",
            ));
        }
        let nu = inner.n_links().saturating_sub(1);
        Ok(TorqueLimit {
            inner,
            limit_nm,
            applied: vec![0.0; nu],
        })
    }

    /// The torque handed to the inner plant at the last step, N m.
    pub fn applied(&self) -> &[f64] {
        &self.applied
    }
}

impl<P: Plant> Plant for TorqueLimit<P> {
    forward_plant!();
    fn step(&mut self, tau: &[f64], dt: f64) {
        for j in 0..self.applied.len() {
            self.applied[j] = tau[j].clamp(-self.limit_nm, self.limit_nm);
        }
        self.inner.step(&self.applied, dt);
    }
}

/// Velocity scale of the smoothed Coulomb friction of [`JointFriction`], rad/s: the friction torque
/// is `coulomb * tanh(qd / FRICTION_SMOOTHING_RAD_S)`.
pub const FRICTION_SMOOTHING_RAD_S: f64 = 0.01;

/// Joint friction on the actuated joints 2..n: the inner plant receives
/// `tau_j - viscous * qd_j - coulomb * tanh(qd_j / FRICTION_SMOOTHING_RAD_S)`, with `qd_j` the true
/// relative joint velocity at the start of the period (friction held over the period like the
/// torque). The passive grip joint 1 is not covered (a plant takes torques of joints 2..n only).
#[derive(Debug, Clone)]
pub struct JointFriction<P> {
    inner: P,
    coulomb_nm: f64,
    viscous_nm_s: f64,
    x: Vec<f64>,
    applied: Vec<f64>,
}

impl<P: Plant> JointFriction<P> {
    /// Coulomb friction `coulomb_nm` (N m) and viscous damping `viscous_nm_s` (N m s/rad), both
    /// finite and in `[0, MAX_FRICTION]`.
    pub fn new(inner: P, coulomb_nm: f64, viscous_nm_s: f64) -> Result<Self> {
        let max = crate::limits::MAX_FRICTION;
        for (name, v) in [("coulomb_nm", coulomb_nm), ("viscous_nm_s", viscous_nm_s)] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err(Error::invalid(
                    "JointFriction",
                    name,
                    v,
                    format!("must be finite and in [0, {max}] (brachia::limits::MAX_FRICTION)"),
                ));
            }
        }
        let n = inner.n_links();
        Ok(JointFriction {
            inner,
            coulomb_nm,
            viscous_nm_s,
            x: vec![0.0; 2 * n],
            applied: vec![0.0; n.saturating_sub(1)],
        })
    }

    /// The torque handed to the inner plant at the last step (command plus friction), N m.
    pub fn applied(&self) -> &[f64] {
        &self.applied
    }
}

impl<P: Plant> Plant for JointFriction<P> {
    forward_plant!();
    fn step(&mut self, tau: &[f64], dt: f64) {
        self.inner.true_state(&mut self.x);
        let n = self.x.len() / 2;
        for j in 0..self.applied.len() {
            let w = self.x[n + j + 1];
            self.applied[j] = tau[j]
                - self.viscous_nm_s * w
                - self.coulomb_nm * (w / FRICTION_SMOOTHING_RAD_S).tanh();
        }
        self.inner.step(&self.applied, dt);
    }
}

/// One impulsive push (a scenario's `[[disturbances.pushes]]`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Push {
    /// When, s: applied at the start of the control period holding it.
    pub t_s: f64,
    /// Which link, 1..n as in the paper.
    pub link: usize,
    /// Where along the link, m from its proximal joint (0..=length).
    pub point_m: f64,
    /// The impulse, N s, grip frame (x right, y up): exactly two values (a third is an error, not
    /// dropped).
    #[serde(deserialize_with = "crate::serde_exact::pair")]
    pub impulse_n_s: [f64; 2],
}

/// Scheduled pushes: at the first step whose period `[t_k, t_k + dt)` holds a push's time the push is
/// handed to the inner plant ([`Plant::push`]) before it advances.
#[derive(Debug, Clone)]
pub struct Pushes<P> {
    inner: P,
    pushes: Vec<Push>,
    next: usize,
}

impl<P: Plant> Pushes<P> {
    /// Schedule `pushes` (at most [`crate::limits::MAX_PUSHES`]; times finite and >= 0, link in
    /// 1..=n, point along the link >= 0, impulse finite with |J| <= 1000 N s); sorted by time here.
    pub fn new(inner: P, pushes: &[Push]) -> Result<Self> {
        validate_pushes("Pushes", inner.n_links(), pushes)?;
        let mut pushes = pushes.to_vec();
        pushes.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
        Ok(Pushes {
            inner,
            pushes,
            next: 0,
        })
    }

    /// Pushes applied so far.
    pub fn applied(&self) -> usize {
        self.next
    }
}

/// Check pushes for an n-link robot (see [`Pushes::new`]); `src` names the source in errors.
pub fn validate_pushes(src: &str, n: usize, pushes: &[Push]) -> Result<()> {
    let max = crate::limits::MAX_PUSHES;
    if pushes.len() > max {
        return Err(Error::invalid(
            src,
            "pushes",
            format!("{} pushes", pushes.len()),
            format!("at most {max} (brachia::limits::MAX_PUSHES)"),
        ));
    }
    for (i, p) in pushes.iter().enumerate() {
        let f = |name: &str| format!("pushes[{i}].{name}");
        if !(p.t_s.is_finite() && p.t_s >= 0.0) {
            return Err(Error::invalid(
                src,
                f("t_s"),
                p.t_s,
                "must be finite and >= 0",
            ));
        }
        if !(1..=n).contains(&p.link) {
            return Err(Error::invalid(
                src,
                f("link"),
                p.link,
                format!("must be a link 1..={n}"),
            ));
        }
        if !(p.point_m.is_finite() && (0.0..=100.0).contains(&p.point_m)) {
            return Err(Error::invalid(
                src,
                f("point_m"),
                p.point_m,
                "must be finite and in [0, 100] m (a point along the link)",
            ));
        }
        let mag = p.impulse_n_s[0].hypot(p.impulse_n_s[1]);
        if !(mag.is_finite() && mag <= 1000.0) {
            return Err(Error::invalid(
                src,
                f("impulse_n_s"),
                format!("{:?}", p.impulse_n_s),
                "must be finite with magnitude <= 1000 N s",
            ));
        }
    }
    Ok(())
}

impl<P: Plant> Plant for Pushes<P> {
    forward_plant!();
    fn step(&mut self, tau: &[f64], dt: f64) {
        let t_end = self.inner.time() + dt;
        while let Some(p) = self.pushes.get(self.next) {
            if p.t_s >= t_end {
                break;
            }
            // validated at construction: the inner plant either accepts or cannot be pushed at all
            let _ = self.inner.push(p.link - 1, p.point_m, p.impulse_n_s);
            self.next += 1;
        }
        self.inner.step(tau, dt);
    }
}

/// Jacobian of the position of the point `s` metres along link `link` (0-based) with respect to
/// `q`, 2 x n row-major into `jac` (2n): `p = sum_{l < link} len_l u(th_l) + s u(th_link)`,
/// `u(th) = [cos th, sin th]`, `th_l = q_1 + ... + q_l`.
pub fn point_jacobian(
    robot: &crate::model::Robot,
    q: &[f64],
    link: usize,
    s: f64,
    jac: &mut [f64],
) {
    let n = robot.n;
    let mut th = [0.0; crate::model::MAX_LINKS];
    robot.absolute_angles(q, &mut th[..n]);
    jac[..2 * n].fill(0.0);
    // d p / d q_m = sum over links l >= m of (len or s)_l u'(th_l), l <= link
    let (mut sx, mut sy) = (0.0, 0.0);
    for l in (0..=link.min(n - 1)).rev() {
        let arm = if l == link { s } else { robot.len[l] };
        let (sn, co) = th[l].sin_cos();
        sx -= arm * sn;
        sy += arm * co;
        jac[l] = sx;
        jac[n + l] = sy;
    }
}
