//! Plants (what a controller runs against), plant wrappers that add disturbances, and the closed loop.
//!
//! A [`Plant`] reports the measured state in the paper's convention (`x = [q, qd]`, q1 absolute, the
//! rest relative; rad, rad/s) and advances under joint torques (N m, joints 2..n) held for one control
//! period. A [`Controller`] (defined in [`crate::control`], re-exported here) maps time and measured
//! state to torques. [`ClosedLoop`] runs one control period per [`ClosedLoop::step`];
//! [`run_closed_loop`] runs it to the end. The loop, not the controllers, keeps the logs.
//! Disturbances are plant wrappers: [`Noisy`] adds seeded Gaussian sensor noise, [`ActuationDelay`]
//! and [`MotorLag`] change what a commanded torque does (see docs/robustness.md).

/// Forward the [`Plant`] methods of a wrapper to `self.inner`: every one but `step`
/// (`forward_plant!()`), or every one but `step` and `state` (`forward_plant!(own_state)`, for the
/// wrappers that change what is measured). The one body of every plant wrapper.
macro_rules! forward_plant {
    () => {
        forward_plant!(own_state);
        fn state(&self, x: &mut [f64]) {
            self.inner.state(x)
        }
    };
    (own_state) => {
        fn n_links(&self) -> usize {
            self.inner.n_links()
        }
        fn time(&self) -> f64 {
            self.inner.time()
        }
        fn true_state(&self, x: &mut [f64]) {
            self.inner.true_state(x)
        }
        fn energy(&self) -> f64 {
            self.inner.energy()
        }
        /// The inner plant's name (a disturbance is not another plant).
        fn name(&self) -> &'static str {
            self.inner.name()
        }
        fn push(&mut self, link: usize, point_m: f64, impulse: [f64; 2]) -> crate::Result<()> {
            self.inner.push(link, point_m, impulse)
        }
    };
}

mod clock;
mod disturb;
mod disturbances;
mod model_plant;
mod noisy;
mod runner;

pub use crate::control::{ControlInfo, Controller};
pub use clock::StepClock;
pub use disturb::{
    delay_steps, point_jacobian, validate_pushes, ActuationDelay, JointFriction, MeasurementDelay,
    MotorLag, Push, Pushes, TorqueLimit, TorqueNoise, FRICTION_SMOOTHING_RAD_S,
};
pub use disturbances::{Disturbances, MAX_MISMATCH_FACTOR, MAX_START_OFFSET_RAD};
pub use model_plant::ModelPlant;
pub use noisy::{NoiseSettings, Noisy};
pub use runner::{
    run_closed_loop, ClosedLoop, ClosedLoopLog, RunSettings, RunSummary, StepInfo,
    CANCEL_CHECK_STEPS, DIVERGENCE_BOUND,
};

/// Something a controller can drive: a simulator of the model, a physics engine, a wrapper adding noise.
pub trait Plant {
    /// Number of links n.
    fn n_links(&self) -> usize;
    /// Simulated time, s.
    fn time(&self) -> f64;
    /// Measured state `[q (n), qd (n)]`, written into `x` (2n): what a controller sees.
    fn state(&self, x: &mut [f64]);
    /// True state `[q (n), qd (n)]`, written into `x` (2n): what the loop logs. The same as
    /// [`Plant::state`] unless a wrapper corrupts the measurement (e.g. [`Noisy`]).
    fn true_state(&self, x: &mut [f64]) {
        self.state(x)
    }
    /// Apply `tau` (n - 1 values, N m; the plant clamps them to its torque limits) for `dt` seconds.
    fn step(&mut self, tau: &[f64], dt: f64);
    /// Total mechanical energy of the robot, J (for drift checks).
    fn energy(&self) -> f64;
    /// A short name for reports (`model`, `rapier`).
    fn name(&self) -> &'static str;
    /// An impulsive push, applied at the start of the next [`Plant::step`]: `impulse` (N s, grip
    /// frame) at the point `point_m` metres along link `link` (0-based, from its proximal joint).
    /// The default refuses: a plant that cannot be pushed says so.
    fn push(&mut self, link: usize, point_m: f64, impulse: [f64; 2]) -> crate::Result<()> {
        let _ = (link, point_m, impulse);
        Err(crate::Error::invalid(
            "plant",
            "push",
            self.name(),
            "this plant cannot be pushed",
        ))
    }
}

/// [`Plant`] for a pointer `$ptr` to a plant `P` (a borrow, a box): every method forwarded to the
/// plant it points to, written once for every pointer.
macro_rules! plant_through {
    ($(#[$m:meta])* $ptr:ty) => {
        $(#[$m])*
        impl<P: Plant + ?Sized> Plant for $ptr {
            fn n_links(&self) -> usize {
                (**self).n_links()
            }
            fn time(&self) -> f64 {
                (**self).time()
            }
            fn state(&self, x: &mut [f64]) {
                (**self).state(x)
            }
            fn true_state(&self, x: &mut [f64]) {
                (**self).true_state(x)
            }
            fn step(&mut self, tau: &[f64], dt: f64) {
                (**self).step(tau, dt)
            }
            fn energy(&self) -> f64 {
                (**self).energy()
            }
            fn name(&self) -> &'static str {
                (**self).name()
            }
            fn push(&mut self, link: usize, point_m: f64, impulse: [f64; 2]) -> crate::Result<()> {
                (**self).push(link, point_m, impulse)
            }
        }
    };
}

plant_through!(
    /// A mutable borrow of a plant is a plant (so a loop can drive a plant the caller keeps).
    &mut P
);
plant_through!(
    /// A boxed plant is a plant (so a loop can hold a plant chosen at run time).
    Box<P>
);

#[cfg(test)]
mod tests {
    use super::*;

    /// A plant that answers every method itself (none of the trait's defaults).
    struct Own {
        t: f64,
        pushed: usize,
    }

    impl Plant for Own {
        fn n_links(&self) -> usize {
            4
        }
        fn time(&self) -> f64 {
            self.t
        }
        fn state(&self, x: &mut [f64]) {
            x.fill(1.0);
        }
        fn true_state(&self, x: &mut [f64]) {
            x.fill(2.0);
        }
        fn step(&mut self, _tau: &[f64], dt: f64) {
            self.t += dt;
        }
        fn energy(&self) -> f64 {
            3.0
        }
        fn name(&self) -> &'static str {
            "own"
        }
        fn push(&mut self, _link: usize, _point_m: f64, _impulse: [f64; 2]) -> crate::Result<()> {
            self.pushed += 1;
            Ok(())
        }
    }

    /// Every method, called through `p`, reaches `Own`'s.
    fn all_reach_the_plant(mut p: impl Plant) {
        let mut x = [0.0; 8];
        assert_eq!((p.n_links(), p.name(), p.energy()), (4, "own", 3.0));
        p.state(&mut x);
        assert_eq!(x, [1.0; 8]);
        p.true_state(&mut x);
        assert_eq!(x, [2.0; 8]);
        p.step(&[0.0; 3], 0.25);
        assert_eq!(p.time(), 0.25);
        p.push(1, 0.1, [0.0, 1.0]).unwrap();
    }

    #[test]
    fn a_borrowed_or_boxed_plant_forwards_every_method() {
        let mut own = Own { t: 0.0, pushed: 0 };
        all_reach_the_plant(&mut own);
        assert_eq!((own.t, own.pushed), (0.25, 1));
        all_reach_the_plant(Box::new(Own { t: 0.0, pushed: 0 }));
        all_reach_the_plant(Box::new(Own { t: 0.0, pushed: 0 }) as Box<dyn Plant>);
    }
}
