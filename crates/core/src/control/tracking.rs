//! What a tracker of a plan is built from: the robot, the plan it tracks (checked against the robot),
//! its settings (checked and resolved for the robot's link count) and a buffer for the plan's state.
//! [`super::Pd`] and [`super::Tvlqr`] hold one; the checks live here once.

use crate::error::Result;
use crate::model::Robot;
use crate::trajectory::Trajectory;
use std::sync::Arc;

/// Settings of a plan tracker: checked for an n-link robot, then resolved (empty per-link vectors
/// filled with their defaults).
pub(crate) trait TrackerSettings: Sized {
    /// The settings checked for an `n`-link robot and resolved.
    fn checked(&self, n: usize) -> Result<Self>;
}

/// The robot, the plan and the resolved settings of a tracker, with a state buffer of the plan
/// (2n values) for the control law. Built once; the control law reads it without allocating.
#[derive(Debug, Clone)]
pub(crate) struct Tracking<S> {
    /// The robot controlled.
    pub(crate) robot: Arc<Robot>,
    /// The plan tracked, checked against `robot` ([`Trajectory::check_reference`]).
    pub(crate) reference: Arc<Trajectory>,
    /// The settings, resolved for the robot.
    pub(crate) settings: S,
    /// The plan's state at the time of the last control call (2n values).
    pub(crate) xref: Vec<f64>,
}

impl<S: TrackerSettings> Tracking<S> {
    /// `reference` checked against `robot`, `settings` checked and resolved for its link count.
    /// `robot` and `reference` may be owned values or shared `Arc`s.
    pub(crate) fn new(
        robot: impl Into<Arc<Robot>>,
        reference: impl Into<Arc<Trajectory>>,
        settings: &S,
    ) -> Result<Self> {
        let (robot, reference): (Arc<Robot>, Arc<Trajectory>) = (robot.into(), reference.into());
        reference.check_reference(&robot)?;
        let settings = settings.checked(robot.n)?;
        Ok(Tracking {
            xref: vec![0.0; robot.nx()],
            robot,
            reference,
            settings,
        })
    }
}

impl<S> Tracking<S> {
    /// Track `reference` from now on (checked like in [`Tracking::new`]; on error the current plan is
    /// kept).
    pub(crate) fn set_reference(&mut self, reference: impl Into<Arc<Trajectory>>) -> Result<()> {
        super::swap_reference(&self.robot, &mut self.reference, reference)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::{PdSettings, TvlqrSettings};

    /// A plan of `n` links at rest, `samples` samples 10 ms apart.
    fn plan(n: usize, samples: usize) -> Trajectory {
        let mut p = Trajectory::new(n);
        for k in 0..samples {
            p.push(
                k as f64 * 0.01,
                &vec![0.0; n],
                &vec![0.0; n],
                &vec![0.0; n - 1],
            );
        }
        p
    }

    #[test]
    fn both_trackers_fill_their_defaults_and_refuse_the_same_bad_plan() {
        let robot = Robot::paper();
        let ok = plan(robot.n, 5);
        let pd = Tracking::new(robot.clone(), ok.clone(), &PdSettings::default()).unwrap();
        assert_eq!(pd.settings, PdSettings::for_links(robot.n));
        assert_eq!(pd.xref.len(), robot.nx());
        let lq = Tracking::new(robot.clone(), ok, &TvlqrSettings::default()).unwrap();
        assert_eq!(lq.settings, TvlqrSettings::default().resolved(robot.n));
        // a plan of another link count, or an empty one: refused by both with the same message
        let bad = plan(robot.n - 1, 5);
        let e1 = Tracking::new(robot.clone(), bad.clone(), &PdSettings::default())
            .unwrap_err()
            .to_string();
        let e2 = Tracking::new(robot.clone(), bad, &TvlqrSettings::default())
            .unwrap_err()
            .to_string();
        assert_eq!(e1, e2);
        assert!(e1.contains("reference links"), "{e1}");
        let e1 =
            Tracking::new(robot.clone(), plan(robot.n, 0), &PdSettings::default()).unwrap_err();
        let e2 =
            Tracking::new(robot.clone(), plan(robot.n, 0), &TvlqrSettings::default()).unwrap_err();
        assert_eq!(e1.to_string(), e2.to_string());
        // bad settings name their own struct
        let s = PdSettings {
            kp: vec![1.0],
            ..PdSettings::default()
        };
        let e = Tracking::new(robot.clone(), plan(robot.n, 5), &s).unwrap_err();
        assert!(e.to_string().contains("PdSettings"), "{e}");
    }
}
