//! The one definition of a caught bar, used by `brachia track`, the robustness benchmark and the
//! Python API.
//!
//! A swing **reaches the bar** when the closed loop did not diverge and the plant's hand (its own,
//! possibly mismatched, geometry) is within [`SUCCESS_RADIUS_M`] of the target bar at the end of the
//! swing (the reference's duration; a hold after it does not count). Distances are measured to the
//! bar itself (`task.target`), never to the reference's end point.

use brachia::sim::ClosedLoopLog;
use brachia::Robot;

/// The success radius: the hand within this distance of the bar at the end of the swing, m.
pub const SUCCESS_RADIUS_M: f64 = 0.02;

/// Where a closed loop's hand ended against the bar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capture {
    /// Time of the row measured (the last row at or before the end of the swing), s.
    pub t_s: f64,
    /// The plant's hand at that time, m.
    pub ee: [f64; 2],
    /// Its distance to the bar, m (infinite when the log is empty).
    pub bar_error_m: f64,
    /// The verdict: not diverged and `bar_error_m <= SUCCESS_RADIUS_M`.
    pub reaches_bar: bool,
}

/// The capture verdict of `log`, a closed loop of the plant `plant` (the robot whose geometry moves:
/// the planner's robot with any mismatch applied), against the bar `target` at the end of the swing
/// `swing_end_s` (s after the log's start). A diverged loop never reaches the bar.
pub fn capture(plant: &Robot, log: &ClosedLoopLog, swing_end_s: f64, target: [f64; 2]) -> Capture {
    let rows = log.len();
    if rows == 0 {
        return Capture {
            t_s: 0.0,
            ee: [f64::NAN; 2],
            bar_error_m: f64::INFINITY,
            reaches_bar: false,
        };
    }
    // the last row at or before the end of the swing (to half a microsecond: the log's times are
    // sums of control periods)
    let t_end = log.t[0] + swing_end_s + 5e-7;
    let k = log.t.iter().rposition(|&t| t <= t_end).unwrap_or(0);
    let n = log.n;
    let p = plant.ee_position(&log.x(k)[..n]);
    let ee = [p[0], p[1]];
    let bar_error_m = (ee[0] - target[0]).hypot(ee[1] - target[1]);
    let diverged = log.diverged_at_s.is_some();
    Capture {
        t_s: log.t[k],
        ee,
        bar_error_m,
        reaches_bar: !diverged && bar_error_m.is_finite() && bar_error_m <= SUCCESS_RADIUS_M,
    }
}
