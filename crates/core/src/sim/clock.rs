//! A plant clock that counts steps: `t = t_base + k * dt`, so 1160 steps of 1 ms read 1.16 s, not a
//! sum of 1160 roundings. Units: s.

/// Time of a plant advanced in steps. While the step length stays the same the time is
/// `t_base + k * dt` (k steps since the length last changed); a step of another length starts a new
/// count from the current time.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepClock {
    t_base: f64,
    dt: f64,
    k: u64,
}

impl StepClock {
    /// A clock reading `t0`.
    pub fn new(t0: f64) -> Self {
        StepClock {
            t_base: t0,
            dt: 0.0,
            k: 0,
        }
    }

    /// The time, s.
    pub fn time(&self) -> f64 {
        self.t_base + self.k as f64 * self.dt
    }

    /// Advance by one step of `dt` seconds.
    pub fn advance(&mut self, dt: f64) {
        if dt != self.dt {
            self.t_base = self.time();
            self.dt = dt;
            self.k = 0;
        }
        self.k += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_steps_instead_of_summing_them() {
        let mut c = StepClock::new(0.0);
        let mut sum = 0.0;
        for _ in 0..1159 {
            c.advance(1e-3);
            sum += 1e-3;
        }
        assert_eq!(c.time(), 1159.0 * 1e-3);
        assert_ne!(sum, 1159.0 * 1e-3, "the sum drifts (why the clock counts)");
        c.advance(0.5);
        assert_eq!(c.time(), 1159.0 * 1e-3 + 0.5);
    }
}
