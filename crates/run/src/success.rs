//! The one definition of a caught bar, used by `brachia track`, the robustness benchmark, the
//! learning environment `brachia/Swing-v0` and the Python API.
//!
//! **The capture rule.** A state *captures* the bar when the plant's hand (its own, possibly
//! mismatched, geometry, at the plant's true state) is within [`SUCCESS_RADIUS_M`] of the target
//! bar and moves slower than [`CAPTURE_SPEED_M_S`] ([`hand_at_bar`]). A run **reaches the bar**
//! when some logged state captures it, at any time within the run and before any divergence: a
//! real gripper closes then, so the run is judged at its first capture ([`capture`]): the capture
//! time, the hand's distance to the bar there, and the scores of the log up to that row
//! ([`judged_log`]). A run without a capture is a miss, and its distance is the hand's at the end
//! of the swing (the reference's duration). Distances are measured to the bar itself
//! (`task.target`), never to the reference's end point.
//!
//! **Other radii and speeds.** A ladder's gripper closes by the same test with its own radius and
//! speed (`[ladder] capture_radius`, `capture_speed`): a [`CaptureRule`] holds the two numbers,
//! [`CaptureRule::SUCCESS`] is the rule above, and [`hand_at_bar`] and [`capture`] are its methods
//! for that rule.

use brachia::sim::ClosedLoopLog;
use brachia::Robot;

/// The success radius: the hand within this distance of the bar, m.
pub const SUCCESS_RADIUS_M: f64 = 0.02;

/// The capture speed: the hand at the bar slower than this (or as fast), m/s.
pub const CAPTURE_SPEED_M_S: f64 = 0.5;

/// The two numbers of a capture: the hand within `radius_m` of the bar and no faster than
/// `speed_m_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureRule {
    /// The capture radius, m.
    pub radius_m: f64,
    /// The capture speed, m/s.
    pub speed_m_s: f64,
}

impl CaptureRule {
    /// The success rule of every run: [`SUCCESS_RADIUS_M`] and [`CAPTURE_SPEED_M_S`].
    pub const SUCCESS: CaptureRule = CaptureRule {
        radius_m: SUCCESS_RADIUS_M,
        speed_m_s: CAPTURE_SPEED_M_S,
    };

    /// The hand of `plant` at the state `x = [q, qd]` (the plant's true state, in the frame of its
    /// grip) against the bar `target` (same frame), judged by this rule: see [`HandAtBar`].
    pub fn hand_at_bar(&self, plant: &Robot, x: &[f64], target: [f64; 2]) -> HandAtBar {
        let n = plant.n();
        let p = plant.ee_position(&x[..n]);
        let v = plant.ee_velocity(&x[..n], &x[n..2 * n]);
        let distance_m = (p[0] - target[0]).hypot(p[1] - target[1]);
        let speed_m_s = v[0].hypot(v[1]);
        HandAtBar {
            ee: [p[0], p[1]],
            distance_m,
            speed_m_s,
            captures: distance_m.is_finite()
                && speed_m_s.is_finite()
                && distance_m <= self.radius_m
                && speed_m_s <= self.speed_m_s,
        }
    }

    /// The capture verdict of `log` by this rule: as [`capture`].
    pub fn capture(
        &self,
        plant: &Robot,
        log: &ClosedLoopLog,
        swing_end_s: f64,
        target: [f64; 2],
    ) -> Capture {
        let rows = log.len();
        if rows == 0 {
            return Capture {
                t_s: 0.0,
                row: 0,
                ee: [f64::NAN; 2],
                bar_error_m: f64::INFINITY,
                hand_speed_m_s: f64::INFINITY,
                capture_t_s: None,
                reaches_bar: false,
            };
        }
        let hit = (0..rows).find_map(|k| {
            let h = self.hand_at_bar(plant, log.x(k), target);
            h.captures.then_some((k, h))
        });
        let (row, h) = hit.unwrap_or_else(|| {
            // the last row at or before the end of the swing (to half a microsecond: the log's times
            // are sums of control periods)
            let t_end = log.t[0] + swing_end_s + 5e-7;
            let k = log.t.iter().rposition(|&t| t <= t_end).unwrap_or(0);
            (k, self.hand_at_bar(plant, log.x(k), target))
        });
        Capture {
            t_s: log.t[row],
            row,
            ee: h.ee,
            bar_error_m: h.distance_m,
            hand_speed_m_s: h.speed_m_s,
            capture_t_s: hit.map(|_| log.t[row] - log.t[0]),
            reaches_bar: hit.is_some(),
        }
    }
}

/// The plant's hand against the bar in one state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandAtBar {
    /// The hand, m.
    pub ee: [f64; 2],
    /// Its distance to the bar, m.
    pub distance_m: f64,
    /// Its speed, m/s.
    pub speed_m_s: f64,
    /// The rule ([`CaptureRule`]; [`CaptureRule::SUCCESS`] unless said otherwise): every value
    /// finite, `distance_m <= radius_m` and `speed_m_s <= speed_m_s`.
    pub captures: bool,
}

/// The hand of `plant` at the state `x = [q, qd]` (the plant's true state) against the bar
/// `target`, by the success rule ([`CaptureRule::SUCCESS`]): see [`HandAtBar`].
pub fn hand_at_bar(plant: &Robot, x: &[f64], target: [f64; 2]) -> HandAtBar {
    CaptureRule::SUCCESS.hand_at_bar(plant, x, target)
}

/// How a closed loop's hand met the bar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capture {
    /// Time of the row judged, s: the first capture, or (a miss) the last row at or before the end
    /// of the swing.
    pub t_s: f64,
    /// Index of that row in the log.
    pub row: usize,
    /// The plant's hand at that time, m.
    pub ee: [f64; 2],
    /// Its distance to the bar, m (infinite when the log is empty).
    pub bar_error_m: f64,
    /// Its speed, m/s (infinite when the log is empty).
    pub hand_speed_m_s: f64,
    /// Time of the first capture, s from the log's start (`None`: a miss).
    pub capture_t_s: Option<f64>,
    /// The verdict: some row captures the bar.
    pub reaches_bar: bool,
}

/// The capture verdict of `log`, a closed loop of the plant `plant` (the robot whose geometry moves:
/// the planner's robot with any mismatch applied), against the bar `target`; `swing_end_s` (s after
/// the log's start) is where a miss is measured. Every row of the log is tested (a diverged loop's
/// log ends before its divergence, so a capture before it counts).
pub fn capture(plant: &Robot, log: &ClosedLoopLog, swing_end_s: f64, target: [f64; 2]) -> Capture {
    CaptureRule::SUCCESS.capture(plant, log, swing_end_s, target)
}

/// The part of `log` a run is judged on: up to and including the row of the first capture (the
/// gripper closes there), or the whole log for a miss.
pub fn judged_log(log: &ClosedLoopLog, c: &Capture) -> ClosedLoopLog {
    if !c.reaches_bar || c.row + 1 >= log.len() {
        return log.clone();
    }
    let rows = c.row + 1;
    let n = log.n;
    let take = |v: &[f64], width: usize| v[..(rows * width).min(v.len())].to_vec();
    ClosedLoopLog {
        n,
        plant: log.plant.clone(),
        controller: log.controller.clone(),
        t: take(&log.t, 1),
        x: take(&log.x, 2 * n),
        tau: take(&log.tau, n - 1),
        ee: log.ee[..rows.min(log.ee.len())].to_vec(),
        ref_x: take(&log.ref_x, 2 * n),
        ref_ee: log.ref_ee[..rows.min(log.ref_ee.len())].to_vec(),
        control_us: take(&log.control_us, 1),
        iterations: log.iterations[..rows.min(log.iterations.len())].to_vec(),
        diverged_at_s: None,
    }
}
