//! Sensor noise as a plant wrapper: the controller sees the true state plus seeded Gaussian noise.
//!
//! State `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the rest relative), torques of joints
//! 2..n (N m). One noise sample per control period: drawn when the wrapper is built and after every
//! [`Plant::step`], in the order `q1, qd1, q2, qd2, ...` from a ChaCha8 generator.

use super::Plant;
use crate::error::{Error, Result};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Standard deviations and seed of [`Noisy`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NoiseSettings {
    /// Standard deviation of the noise on measured joint angles, rad. Default 0.
    pub q_std: f64,
    /// Standard deviation of the noise on measured joint velocities, rad/s. Default 0.
    pub qd_std: f64,
    /// Seed of the noise generator (ChaCha8). Default 0.
    pub seed: u64,
}

impl Default for NoiseSettings {
    fn default() -> Self {
        NoiseSettings {
            q_std: 0.0,
            qd_std: 0.0,
            seed: 0,
        }
    }
}

impl NoiseSettings {
    /// Check the values: standard deviations finite, >= 0 and at most
    /// [`crate::limits::MAX_NOISE_STD`].
    pub fn validate(&self) -> Result<()> {
        let max = crate::limits::MAX_NOISE_STD;
        for (name, v) in [("q_std", self.q_std), ("qd_std", self.qd_std)] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err(Error::invalid(
                    "NoiseSettings",
                    name,
                    v,
                    format!("must be finite and in [0, {max}] (brachia::limits::MAX_NOISE_STD)"),
                ));
            }
        }
        Ok(())
    }

    /// True when both standard deviations are zero (the wrapper would change nothing).
    pub fn is_zero(&self) -> bool {
        self.q_std == 0.0 && self.qd_std == 0.0
    }
}

/// A plant whose measured state carries Gaussian sensor noise; its true state (logged by the loop)
/// and its dynamics are the inner plant's.
#[derive(Debug, Clone)]
pub struct Noisy<P> {
    inner: P,
    settings: NoiseSettings,
    rng: ChaCha8Rng,
    /// The current noise sample `[e_q (n), e_qd (n)]`.
    e: Vec<f64>,
}

/// A standard normal sample (Box-Muller).
pub(crate) fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.gen_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

impl<P: Plant> Noisy<P> {
    /// Wrap `inner`; the first noise sample is drawn here.
    pub fn new(inner: P, settings: NoiseSettings) -> Result<Self> {
        settings.validate()?;
        let n = inner.n_links();
        let mut w = Noisy {
            inner,
            settings,
            rng: ChaCha8Rng::seed_from_u64(settings.seed),
            e: vec![0.0; 2 * n],
        };
        w.draw();
        Ok(w)
    }

    fn draw(&mut self) {
        let n = self.e.len() / 2;
        for i in 0..n {
            self.e[i] = self.settings.q_std * normal(&mut self.rng);
            self.e[n + i] = self.settings.qd_std * normal(&mut self.rng);
        }
    }

    /// The wrapped plant.
    pub fn inner(&self) -> &P {
        &self.inner
    }

    /// The wrapped plant, mutable (the current noise sample is kept).
    pub fn inner_mut(&mut self) -> &mut P {
        &mut self.inner
    }

    /// The wrapped plant, unwrapped.
    pub fn into_inner(self) -> P {
        self.inner
    }

    /// The noise settings.
    pub fn settings(&self) -> &NoiseSettings {
        &self.settings
    }
}

impl<P: Plant> Plant for Noisy<P> {
    forward_plant!(own_state);
    /// True state plus the current noise sample.
    fn state(&self, x: &mut [f64]) {
        self.inner.true_state(x);
        for (v, e) in x.iter_mut().zip(&self.e) {
            *v += e;
        }
    }
    /// Advance the inner plant and draw the next noise sample.
    fn step(&mut self, tau: &[f64], dt: f64) {
        self.inner.step(tau, dt);
        self.draw();
    }
}
