//! Every limit on a size that follows from input, in one place (see `docs/limits.md`).
//!
//! Each size a user's input decides (collocation points, output samples, closed-loop steps, the MPC
//! horizon, integration steps, links, the size of an input file) is checked against one of these limits
//! *before* anything of that size is allocated, with an error that says what the input would need. The
//! limits are generous for the paper's experiments (a 2-3 s swing at 10 ms knots has ~250 intervals, a
//! closed loop ~3000 steps) and keep the worst accepted input to seconds of work and tens of MB.

use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

pub use crate::model::MAX_LINKS;

/// Largest TOML file read (robot parameters, scenarios, study settings), bytes: 1 MB. A robot of 12 links
/// takes about 1 kB.
pub const MAX_TOML_BYTES: u64 = 1 << 20;

/// Largest CSV file read (a plan folder's `trajectory.csv`), bytes: 64 MB (a 1 ms, 12-link trajectory
/// of [`MAX_SWING_TIME_S`] is about 30 MB).
pub const MAX_CSV_BYTES: u64 = 64 << 20;

/// Largest JSON file read (a plan folder's `report.json`), bytes: 1 MB.
pub const MAX_JSON_BYTES: u64 = 1 << 20;

/// Longest swing the planner accepts, s. The freefall search that sets `"auto"` stops at 20 s, so an
/// automatic swing time is at most 40 s.
pub const MAX_SWING_TIME_S: f64 = 40.0;

/// Fewest collocation intervals `N = round(T / knot_dt)`: below this the discrete problem no longer
/// describes the swing (with N = 2 the open-loop replay misses the bar by a metre).
pub const MIN_INTERVALS: usize = 10;

/// Most collocation intervals: 2000 (the paper's 2.2 s swing at 10 ms knots has 220; one iteration of a
/// 2000-interval Hermite-Simpson problem already takes about a second).
pub const MAX_INTERVALS: usize = 2000;

/// Largest `n^2 x N` of a plan (n links, N intervals): the 4-link robot's [`MAX_INTERVALS`] (16 x 2000).
/// The planner's memory grows with the links squared per interval (a 12-link Hermite-Simpson plan of
/// 2000 intervals reached 5.7 GB on pounce): a 6-link plan may have 888 intervals, a 12-link one 222.
pub const MAX_LINK_INTERVALS: usize = 16 * MAX_INTERVALS;

/// Most samples of a resampled output trajectory (`T / output_dt + 1`): 200 000 (200 s at 1 ms).
pub const MAX_OUTPUT_SAMPLES: usize = 200_000;

/// Largest `[planner] output_dt`, s: the energy of eq. (18) and the tracked reference come from the
/// resampled trajectory, which must resolve the swing (on the tracking swing eq. (18) is off by 1.7 %
/// at 30 ms and by 69 % at 0.5 s, which a hostile-input sweep passed as a plan exiting 0).
pub const MAX_OUTPUT_DT_S: f64 = 0.02;

/// Largest solver tolerance (`[solver] tol`, `constr_viol_tol`, `acceptable_tol`): a looser one
/// declares points far from the optimum "solved" (`tol = 1e308` stopped after 7 iterations at 2.4
/// times the optimal objective).
pub const MAX_SOLVER_TOL: f64 = 1e-2;

/// Longest simulated closed loop (swing plus hold) or passive simulation, s.
pub const MAX_RUN_DURATION_S: f64 = 600.0;

/// Most control steps of one closed-loop run (`duration / control_dt`): 600 000 (600 s at 1 kHz).
pub const MAX_RUN_STEPS: usize = 600_000;

/// Largest sensor-noise standard deviation of [`crate::sim::NoiseSettings`] (rad for angles, rad/s
/// for rates; `[tracking] noise_q_std`, `noise_qd_std`).
pub const MAX_NOISE_STD: f64 = 10.0;

/// Longest hold after a planned swing (`[tracking] hold_s`), s.
pub const MAX_HOLD_S: f64 = 60.0;

/// Longest MPC horizon, steps (the default is 20; each step adds a block to the condensed QP, whose
/// memory grows with the square of the horizon).
pub const MAX_MPC_HORIZON: usize = 200;

/// Longest time an MPC horizon may span (`horizon * dt_mpc`), s.
pub const MAX_MPC_SPAN_S: f64 = 10.0;

/// Most output rows of `brachia simulate` (`duration / dt + 1`): 1 000 000.
pub const MAX_SIM_ROWS: usize = 1_000_000;

/// Most RK4 steps of `brachia simulate` (rows times substeps): 20 000 000 (about 20 s for 4 links).
pub const MAX_SIM_STEPS: u64 = 20_000_000;

/// Integration sub-steps per output or control period.
pub const MAX_SUBSTEPS: usize = 1000;

/// Largest |gravity| accepted, m/s^2 (Jupiter is 25).
pub const MAX_GRAVITY: f64 = 100.0;

/// Largest absolute joint angle of a start state, rad (two turns).
pub const MAX_ANGLE_RAD: f64 = 4.0 * std::f64::consts::PI;

/// Largest absolute joint velocity of a start state, rad/s.
pub const MAX_RATE_RAD_S: f64 = 1000.0;

/// What kind of file `meta` describes, for a message (`a FIFO`, `a character device`, ...).
fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    let _ = meta;
    "not a regular file"
}

/// Read a text file of at most `cap` bytes. Anything but a regular file (a folder, a FIFO, a device such
/// as `/dev/zero` or `/dev/null`, a socket) is refused by its metadata before it is opened, so no input
/// blocks or streams forever; a regular file larger than `cap` is refused by its size before anything is
/// read (and one that grows while read, after `cap + 1` bytes). `what` names the kind of file in the
/// message.
pub fn read_text_capped(path: &Path, cap: u64, what: &str) -> Result<String> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    // the kind of file is checked before it is opened: opening a FIFO blocks until a writer comes,
    // and a device or socket is no input file either
    let meta = std::fs::metadata(path).map_err(io)?;
    if meta.is_dir() {
        return Err(Error::invalid(
            path.display().to_string(),
            what,
            "a folder",
            "must be a file",
        ));
    }
    if !meta.is_file() {
        return Err(Error::invalid(
            path.display().to_string(),
            what,
            file_kind(&meta),
            "not a regular file; an input must be a regular file (not a FIFO, device or socket)",
        ));
    }
    let too_big = |size: String| {
        Error::invalid(
            path.display().to_string(),
            what,
            size,
            format!("a {what} may have at most {cap} bytes (brachia::limits)"),
        )
    };
    let f = std::fs::File::open(path).map_err(io)?;
    if let Ok(m) = f.metadata() {
        if m.is_file() && m.len() > cap {
            return Err(too_big(format!("{} bytes", m.len())));
        }
    }
    let mut buf = Vec::new();
    f.take(cap + 1).read_to_end(&mut buf).map_err(io)?;
    if buf.len() as u64 > cap {
        return Err(too_big(format!("more than {cap} bytes")));
    }
    String::from_utf8(buf).map_err(|e| {
        Error::invalid(
            path.display().to_string(),
            what,
            format!("invalid UTF-8 at byte {}", e.utf8_error().valid_up_to()),
            "must be UTF-8 text",
        )
    })
}

/// `ceil(span / step)` as a count, or `None` when it is not finite or exceeds `max` (checked in floating
/// point, before any conversion that could overflow).
pub fn count(span: f64, step: f64, max: usize) -> Option<usize> {
    let c = span / step;
    if c.is_finite() && c >= 0.0 && c <= max as f64 {
        Some(c.round() as usize)
    } else {
        None
    }
}

/// Longest measurement or actuation delay of a disturbance wrapper ([`crate::sim::ActuationDelay`],
/// [`crate::sim::MeasurementDelay`]), s: 1 s (the delay buffer holds `delay / control_dt` samples).
pub const MAX_DELAY_S: f64 = 1.0;

/// Most delay steps of a delay wrapper (`delay_s / control_dt`, rounded): 100 000.
pub const MAX_DELAY_STEPS: usize = 100_000;

/// Longest motor time constant of [`crate::sim::MotorLag`], s.
pub const MAX_MOTOR_TAU_S: f64 = 10.0;

/// Largest torque-noise standard deviation of [`crate::sim::TorqueNoise`], N m.
pub const MAX_TORQUE_NOISE_NM: f64 = 100.0;

/// Largest Coulomb friction (N m) or viscous damping (N m s/rad) of [`crate::sim::JointFriction`].
pub const MAX_FRICTION: f64 = 100.0;

/// Most impulsive pushes of one run ([`crate::sim::Pushes`]).
pub const MAX_PUSHES: usize = 100;
