//! Input limits of the planner: how large a plan may grow, and the plausible range of every
//! physical parameter a request can carry.
//!
//! Every allocation that grows with the input is bounded by one of the `MAX_*` constants
//! below, **checked before allocating** from what the inputs imply (e.g. samples = duration ×
//! rate), and refused with [`PlanningError::TooLarge`], which names the limit, the value the
//! inputs imply and what to change. Every physical parameter has a stated range (the `*_RANGE`
//! constants, SI units); a value outside it is refused with [`PlanningError::OutOfRange`]
//! naming the parameter, the value and the range. The ranges are wide — several orders of
//! magnitude around anything a wheeled robot does — and exist so that absurd but finite values
//! (`1e-9` m/s, `1e300` rad) are reported as what they are instead of producing a plan of
//! billions of samples or a plan of one sample.
//!
//! To raise a limit, change the constant here and rebuild; the error messages say which one.

use crate::PlanningError;

/// Most samples in one plan (time stamps `k / rate` plus the end): `duration × rate + 2`.
/// 2·10⁶ samples are 5.5 h at 100 Hz and about 280 MB in memory (136 bytes a sample), so a
/// plan of this size can still be written with a figure (≈ 0.5 GB) and simulated one trial
/// per core (≈ 260 MB a trial) within 3 GB. The planner refuses a request that would need
/// more before it samples anything.
pub const MAX_PLAN_SAMPLES: usize = 2_000_000;

/// Most rows a plan file may have when it is read back (the same bound as
/// [`MAX_PLAN_SAMPLES`], checked row by row while reading).
pub const MAX_PLAN_ROWS: usize = MAX_PLAN_SAMPLES;

/// Most grid cells of one move of the planner's adaptive grid (≈ 200 bytes a cell).
pub const MAX_MOVE_GRID_CELLS: usize = 400_000;

/// Most grid cells of all moves of a plan together (≈ 200 bytes a cell: 400 MB; 100 km of
/// path on the profiles' coarsest 5 cm grid, 200 km on the time-optimal timing's 10 cm). Checked from the path's length before the grid is built,
/// and again as refinement adds cells.
pub const MAX_PLAN_GRID_CELLS: usize = 2_000_000;

/// Most waypoints in a waypoint file.
pub const MAX_WAYPOINTS: usize = 100_000;

/// Largest waypoint file, bytes: 64 MiB (over 600 bytes for each of [`MAX_WAYPOINTS`]); the
/// file is read whole, so a multi-gigabyte one aborted the process instead of being refused.
pub const MAX_WAYPOINT_FILE_BYTES: usize = 64 << 20;

/// Longest line of a CSV input read as a stream (plans, tracks), bytes: 1 MiB, some 10⁴
/// columns. The CSV reader grows its record buffer to the longest line, so without this bound
/// one line of gigabytes (a file without newlines) exhausted memory and aborted the process.
pub const MAX_CSV_LINE: usize = 1 << 20;

/// A reader that fails with [`std::io::ErrorKind::InvalidData`] once a line (bytes between
/// `\n`) exceeds `max` bytes, naming the limit; otherwise passes the bytes through.
#[derive(Debug)]
pub struct LineLimit<R> {
    inner: R,
    max: usize,
    run: usize,
}

impl<R> LineLimit<R> {
    /// Limits `inner`'s lines to `max` bytes (use [`MAX_CSV_LINE`]).
    pub fn new(inner: R, max: usize) -> Self {
        Self { inner, max, run: 0 }
    }
}

impl<R: std::io::Read> std::io::Read for LineLimit<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in &buf[..n] {
            if b == b'\n' {
                self.run = 0;
            } else {
                self.run += 1;
                if self.run > self.max {
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        format!(
                            "a line longer than {} bytes (the limit MAX_CSV_LINE of \
                             omnikin_plan::limits): is this a CSV file?",
                            self.max
                        ),
                    ));
                }
            }
        }
        Ok(n)
    }
}

/// Plan sampling rate, Hz.
pub const RATE_RANGE: (f64, f64) = (0.1, 1e5);

/// Speed along a path (cruise speed, `--speed`, `--max-speed`), m/s.
pub const SPEED_RANGE: (f64, f64) = (1e-4, 100.0);

/// Acceleration along a path, m/s².
pub const ACCEL_RANGE: (f64, f64) = (1e-7, 1e4);

/// Jerk along a path, m/s³.
pub const JERK_RANGE: (f64, f64) = (1e-9, 1e6);

/// Yaw rate of a turn in place, and the magnitude of a circle's `omega`, rad/s.
pub const YAW_RATE_RANGE: (f64, f64) = (1e-4, 1e3);

/// Yaw acceleration of a turn in place, rad/s².
pub const YAW_ACCEL_RANGE: (f64, f64) = (1e-7, 1e5);

/// A path's size: square side, circle radius, fillet radius, m.
pub const LENGTH_RANGE: (f64, f64) = (1e-4, 1e4);

/// Largest coordinate magnitude of a waypoint, m (world frame).
pub const MAX_COORDINATE: f64 = 1e6;

/// Largest heading magnitude (waypoint headings, constant headings, offsets; unwrapped), rad.
pub const MAX_HEADING: f64 = 1e6;

/// Largest magnitude of a rate in a plan file (`yaw_rate`, wheel rates `w1…`, steer rates
/// `sd1…`), rad/s: the largest motor rate a robot file may allow
/// ([`omnikin::description::MOTOR_RATE_RANGE`]). A plan's positions and velocities are held to
/// [`MAX_COORDINATE`] (m, m/s), its headings and steer angles to [`MAX_HEADING`].
pub const MAX_PLAN_RATE: f64 = omnikin::description::MOTOR_RATE_RANGE.1;

/// Largest spin while translating (heading change per metre of path), rad/m.
pub const MAX_SPIN: f64 = 1e3;

/// Number of turns of a circle.
pub const TURNS_RANGE: (f64, f64) = (1e-3, 1e3);

/// Ramp time of a circle that starts from rest, s.
pub const RAMP_RANGE: (f64, f64) = (1e-4, 1e5);

/// Checks `min ≤ value ≤ max` (and finiteness).
///
/// # Errors
/// [`PlanningError::OutOfRange`] naming `name`, the value, the range and its `unit`.
pub fn check_range(
    name: &'static str,
    value: f64,
    (min, max): (f64, f64),
    unit: &'static str,
) -> Result<(), PlanningError> {
    if value.is_finite() && value >= min && value <= max {
        Ok(())
    } else {
        Err(PlanningError::OutOfRange {
            name,
            value,
            min,
            max,
            unit,
        })
    }
}

/// Checks `|value| ≤ max` (and finiteness).
///
/// # Errors
/// [`PlanningError::OutOfRange`] naming `name`, the value, the range `[−max, max]` and `unit`.
pub fn check_magnitude(
    name: &'static str,
    value: f64,
    max: f64,
    unit: &'static str,
) -> Result<(), PlanningError> {
    check_range(name, value, (-max, max), unit)
}
