//! # Odometry over a recorded encoder log, optionally fused with camera fixes
//!
//! The pipeline behind `omnikin odometry`, as a library so that the command line and the Python
//! bindings run the same code: an encoder log (conventions.md "Encoder log CSV for odometry")
//! and optional camera fixes go through the core's
//! [`Odometry`](omnikin::estimate::odometry::Odometry) and
//! [`PoseFusion`](omnikin::estimate::fusion::PoseFusion) (pose, gyro bias, wheel scale); the
//! result is one row per log sample, every fix's fate ([`FixRecord`]), the slip and collision
//! events ([`events`]) and an [`OdometrySummary`]. [`OdometryStream`] takes the log one row at
//! a time (the command line reads it with [`NumericRows`] and writes each row as it comes, so
//! its memory does not grow with the log); [`run`] is that stream over a whole
//! [`NumericTable`], its rows kept as [`OdometryColumns`].
//!
//! * Log: `t,q1..qN` cumulative wheel angles (rad, or counts with
//!   [`OdometryOptions::counts_per_rev`]), one per wheel of the robot; `s1..sN` steer angles for
//!   the steerable kinds (caster3, swerve); optional `gyro_z` (rad/s) and `yaw` (rad); optional
//!   `gyro_x,gyro_y` (rad/s) and `accel_x,accel_y,accel_z` (m/s², specific force), platform
//!   frame: with `gyro_z` the heading rate is the body rate about the vertical, the platform's
//!   tilt from the accelerometer ([`tilt`]).
//! * Fixes: `t,x,y` (s, m, m; world frame) with optional `heading` (rad) and `arrival` (s; when
//!   the fix reached the robot, default `t`). Each fix is handed to the filter when it arrives
//!   and fused at the time it was taken.
//!
//! Errors name the table, the line and the column ([`OdometryInputError`]).

use omnikin::Pose2;
use omnikin::description::RobotDescription;
use omnikin::estimate::fusion::Recovery;

use crate::table::{NumericRows, NumericTable, TableError};

pub mod events;
pub mod report;
pub mod stream;
pub mod tilt;
pub use events::{
    EventKind, EventOverrides, EventThresholds, OdometryEvent, ResolvedThresholds, ThresholdSource,
};
pub use stream::{FixList, OdometryEnd, OdometryRow, OdometryStream};

/// Entries of the filter's history (sized by time: half of them cover
/// [`OdometryOptions::max_latency`] whatever the encoder rate).
pub const HISTORY: usize = 256;

/// How to run the pipeline. [`Default`] gives the command line's defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryOptions {
    /// Heading from the IMU instead of the wheels: the log's `yaw` column (absolute heading) if
    /// present, otherwise its `gyro_z` column (integrated, trapezoidal rule). Default `false`.
    pub imu: bool,
    /// The `q` (and `s`) columns are encoder counts with this many counts per revolution
    /// (`None`: radians). Must be ≥ 1.
    pub counts_per_rev: Option<u32>,
    /// Starting pose (m, m, rad; world frame). `None`: the origin.
    pub initial_pose: Option<Pose2<f64>>,
    /// Standard deviation of a fix's x and y, m (> 0). Default 0.01.
    pub fix_std: f64,
    /// Standard deviation of a fix's heading, rad (> 0; fixes with a heading). Default 0.05.
    pub fix_heading_std: f64,
    /// Gyro bias subtracted from `gyro_z`, rad/s. Default 0.
    pub gyro_bias: f64,
    /// Oldest fix still fused at its time, s before the latest encoder sample (> 0); older
    /// fixes are counted as too late. Default 1.
    pub max_latency: f64,
    /// Estimate the (remaining) gyro bias when the heading comes from `gyro_z`. Default `true`.
    pub estimate_gyro_bias: bool,
    /// Estimate a common wheel-scale factor (true / measured travel). Default `true`.
    pub estimate_wheel_scale: bool,
    /// Rejected fixes in a row that trigger a recovery (1..=16). Default 5.
    pub recovery_count: u32,
    /// Spread within which a run of rejected fixes counts as agreeing (re-initialise, else
    /// inflate the covariance), m (> 0). Default 0.05.
    pub recovery_spread: f64,
    /// With `gyro_x,gyro_y,accel_x,accel_y,accel_z` columns and the heading from `gyro_z`:
    /// estimate the platform's tilt and use the body rate about the vertical as the heading
    /// rate ([`tilt`]). Default `true`.
    pub tilt_compensation: bool,
    /// Slip and collision thresholds that override the robot file's `[events]` table (which
    /// overrides [`EventThresholds::default`]). Default: none.
    pub events: EventOverrides,
}

impl Default for OdometryOptions {
    fn default() -> Self {
        Self {
            imu: false,
            counts_per_rev: None,
            initial_pose: None,
            fix_std: 0.01,
            fix_heading_std: 0.05,
            gyro_bias: 0.0,
            max_latency: 1.0,
            estimate_gyro_bias: true,
            estimate_wheel_scale: true,
            recovery_count: 5,
            recovery_spread: 0.05,
            tilt_compensation: true,
            events: EventOverrides::default(),
        }
    }
}

/// Where the heading came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeadingSource {
    /// The wheels' forward kinematics.
    Wheels,
    /// The `gyro_z` column, integrated.
    Gyro,
    /// The `yaw` column.
    Yaw,
}

impl HeadingSource {
    /// How the summary names it: "the wheels", "gyro_z (integrated)", "the yaw column".
    pub fn describe(self) -> &'static str {
        match self {
            Self::Wheels => "the wheels",
            Self::Gyro => "gyro_z (integrated)",
            Self::Yaw => "the yaw column",
        }
    }
}

/// One row per log sample, as columns (world frame; m, m, rad unwrapped).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OdometryColumns {
    /// Sample time, s (the log's `t`).
    pub t: Vec<f64>,
    /// Estimated x, m: fused with the fixes when there are fixes, else the wheel odometry.
    pub x: Vec<f64>,
    /// Estimated y, m (as `x`).
    pub y: Vec<f64>,
    /// Estimated heading, rad, unwrapped (as `x`).
    pub heading: Vec<f64>,
    /// 1-σ of the estimated x, m (0 without fixes: the odometry has no covariance here).
    pub std_x: Vec<f64>,
    /// 1-σ of the estimated y, m.
    pub std_y: Vec<f64>,
    /// 1-σ of the estimated heading, rad.
    pub std_heading: Vec<f64>,
    /// Pure odometry x, m (no fixes).
    pub odometry_x: Vec<f64>,
    /// Pure odometry y, m.
    pub odometry_y: Vec<f64>,
    /// Pure odometry heading, rad, unwrapped.
    pub odometry_heading: Vec<f64>,
}

impl OdometryColumns {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True without rows.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The estimated pose of row `i`.
    pub fn pose(&self, i: usize) -> Option<Pose2<f64>> {
        Some(Pose2::new(
            *self.x.get(i)?,
            *self.y.get(i)?,
            *self.heading.get(i)?,
        ))
    }

    /// The pure odometry pose of row `i`.
    pub fn odometry_pose(&self, i: usize) -> Option<Pose2<f64>> {
        Some(Pose2::new(
            *self.odometry_x.get(i)?,
            *self.odometry_y.get(i)?,
            *self.odometry_heading.get(i)?,
        ))
    }

    /// Appends one row of [`OdometryStream::push`].
    pub fn push(&mut self, row: &OdometryRow) {
        let OdometryRow {
            t,
            estimate,
            std,
            odometry,
        } = *row;
        self.t.push(t);
        self.x.push(estimate.x);
        self.y.push(estimate.y);
        self.heading.push(estimate.heading);
        self.std_x.push(std[0]);
        self.std_y.push(std[1]);
        self.std_heading.push(std[2]);
        self.odometry_x.push(odometry.x);
        self.odometry_y.push(odometry.y);
        self.odometry_heading.push(odometry.heading);
    }
}

/// What happened to one fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FixResult {
    /// Fused; `mahalanobis2` is `d²` of its innovation.
    Accepted {
        /// `d² = νᵀ S⁻¹ ν`.
        mahalanobis2: f64,
    },
    /// Rejected by the χ² gate as an outlier.
    Rejected {
        /// `d² = νᵀ S⁻¹ ν`.
        mahalanobis2: f64,
        /// The threshold it exceeded.
        gate: f64,
    },
    /// Taken before the oldest state the history still holds: arrived too late to be fused.
    TooLate,
    /// Arrived after the last log sample: never handed to the filter.
    AfterLog,
    /// The first fix without [`OdometryOptions::initial_pose`]: it set the pose.
    Initialised,
    /// Ended a run of `rejected` rejections by a recovery (re-initialisation or covariance
    /// inflation), then fused: an event.
    Recovered {
        /// Re-initialised or inflated.
        recovery: Recovery,
        /// Rejections before it.
        rejected: u32,
    },
}

/// One fix of the input and what became of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixRecord {
    /// Line of the fixes table.
    pub line: usize,
    /// When it was taken, s.
    pub t: f64,
    /// When it arrived, s (`arrival` column, default `t`).
    pub arrival: f64,
    /// Measured x, m.
    pub x: f64,
    /// Measured y, m.
    pub y: f64,
    /// Measured heading, rad, if the table has one.
    pub heading: Option<f64>,
    /// Its fate.
    pub result: FixResult,
}

/// Fix counters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FixSummary {
    /// Fixes fused.
    pub accepted: usize,
    /// Fixes rejected by the gate.
    pub rejected: usize,
    /// Fixes older than the history when they arrived (dropped).
    pub too_late: usize,
    /// Fixes that arrived after the last log sample.
    pub after_log: usize,
    /// Distance between the fused and the pure-odometry end positions, m.
    pub fused_minus_odometry: f64,
    /// Recoveries by re-initialisation (a run of agreeing rejected fixes).
    pub reinitialised: usize,
    /// Recoveries by covariance inflation.
    pub inflated: usize,
    /// Time the first fix set the pose, s (no initial pose given).
    pub initialised_at: Option<f64>,
    /// Estimated gyro bias, rad/s (the given `gyro_bias` plus the filter's), and its 1-σ;
    /// `None` unless the heading comes from `gyro_z` and the state is on.
    pub gyro_bias: Option<(f64, f64)>,
    /// Estimated common wheel-scale factor (true / measured travel) and its 1-σ; `None` when
    /// the state is off.
    pub wheel_scale: Option<(f64, f64)>,
}

/// What the run produced besides the rows.
#[derive(Clone, Debug, PartialEq)]
pub struct OdometrySummary {
    /// The robot's name.
    pub robot: String,
    /// Its kind (`sphere-omni`, ...).
    pub kind: &'static str,
    /// Where the heading came from.
    pub heading_source: HeadingSource,
    /// Log samples.
    pub samples: usize,
    /// Last minus first time, s.
    pub duration: f64,
    /// Length of the odometry path, m (sum of the step translations).
    pub path_length: f64,
    /// Last estimated pose (fused if there are fixes).
    pub end: Pose2<f64>,
    /// Largest least-squares slip residual (m/s) and its time (s), for the kinds with more
    /// motors than twist components (caster, swerve, 4-wheel omni); `None` otherwise.
    pub max_slip: Option<(f64, f64)>,
    /// Mean shell/ball spin about the vertical from wheels + IMU heading, rad/s (sphere and
    /// ballbot with `imu`); `None` otherwise.
    pub mean_shell_spin: Option<f64>,
    /// The mean shell/ball spin `Ω3` with its 1-σ bound, corrected for the estimated gyro bias
    /// and wheel scale when the filter has them (sphere and ballbot with `imu`).
    pub shell_spin: Option<ShellSpin>,
    /// Why `Ω3` is not measured, for the sphere and the ballbot without `imu`.
    pub shell_spin_unobservable: Option<&'static str>,
    /// Fix counters, when fixes were given.
    pub fixes: Option<FixSummary>,
    /// The slip and collision thresholds used, and where each came from (the options, the
    /// robot file's `[events]`, the default).
    pub event_thresholds: ResolvedThresholds,
}

/// The mean shell (sphere) or ball (ballbot) spin about the vertical over the log,
/// `Ω3 = (Δψ − k·w)/Δt − b` with `Δψ` the IMU heading change, `w` the wheels' heading change
/// at zero spin (paper 000, eq. 5.6), `b` the gyro bias and `k` the wheel scale.
///
/// The 1-σ bound combines the scatter of the per-second means, the gyro-bias and wheel-scale
/// uncertainty (the filter's, or its priors 0.02 rad/s and 0.05 without fixes) and their
/// correlation, and the platform tilt's uncertainty when it is compensated ([`TiltReport`]).
/// Without compensation, on a tilted platform the gyro's z axis is not vertical and `Ω3` is
/// biased by about `−ψ̇·(1 − cos tilt)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellSpin {
    /// Mean `Ω3`, rad/s, corrected.
    pub mean: f64,
    /// Its 1-σ bound, rad/s.
    pub std: f64,
    /// The mean before the bias and scale correction, rad/s.
    pub uncorrected: f64,
    /// Whether the filter's bias and scale estimates (from fixes) were used, not their priors.
    pub from_fixes: bool,
    /// Whether the platform tilt was compensated, and its figures.
    pub tilt: TiltReport,
}

/// The platform tilt behind an `Ω3` estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TiltReport {
    /// The heading rate was the body rate about the vertical ([`tilt`]).
    Compensated {
        /// Mean tilt over the log, rad.
        mean_tilt: f64,
        /// Largest tilt, rad.
        max_tilt: f64,
        /// 1-σ of the tilt estimate, rad.
        tilt_std: f64,
        /// Its share of [`ShellSpin::std`], rad/s (first order: `tilt_std` times the mean
        /// horizontal body rate; second order: the mean heading rate times `tilt_std²`).
        spin_std: f64,
        /// `Ω3` as it would be with `gyro_z` as the heading rate (bias and scale corrected the
        /// same way), rad/s: the bias the compensation removed is `mean − uncompensated`.
        uncompensated: f64,
    },
    /// Not compensated, and why (no accelerometer columns, no 3-axis gyro, switched off, or
    /// an absolute `yaw` heading).
    NotCompensated(&'static str),
}

/// The result of [`run`].
#[derive(Clone, Debug, PartialEq)]
pub struct OdometryRun {
    /// One row per log sample.
    pub columns: OdometryColumns,
    /// Every fix in arrival order with its fate (empty without fixes).
    pub fixes: Vec<FixRecord>,
    /// Counters and end pose.
    pub summary: OdometrySummary,
    /// Slip and collision events, by start time.
    pub events: Vec<OdometryEvent>,
}

/// Why the pipeline stopped: a malformed or inconsistent input, named by file, line and column.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum OdometryInputError {
    /// A table error (a missing column).
    #[error(transparent)]
    Table(#[from] TableError),
    /// The robot description does not build.
    #[error(transparent)]
    Robot(#[from] omnikin::description::DescriptionError),
    /// An input that breaks a rule: `FILE:LINE: what is wrong` (or `FILE: ...` without a line).
    #[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Input {
        /// The table.
        file: String,
        /// 1-based line, if one is at fault.
        line: Option<usize>,
        /// What is wrong: the column and the rule.
        message: String,
    },
    /// An option is out of range.
    #[error("option {option}: {message}")]
    Option {
        /// The option's field name.
        option: &'static str,
        /// The rule.
        message: String,
    },
}

fn input(file: &str, line: Option<usize>, message: String) -> OdometryInputError {
    OdometryInputError::Input {
        file: file.to_string(),
        line,
        message,
    }
}

/// A number as the command line quotes it: plain in `[1e-4, 1e9)`, scientific outside.
fn num(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && a.is_finite() && !(1e-4..1e9).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

fn check_options(o: &OdometryOptions) -> Result<(), OdometryInputError> {
    let bad = |option, message: String| Err(OdometryInputError::Option { option, message });
    for (v, name) in [
        (o.fix_std, "fix_std"),
        (o.fix_heading_std, "fix_heading_std"),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return bad(name, format!("must be a finite number > 0, got {v}"));
        }
    }
    if !(o.max_latency.is_finite() && o.max_latency > 0.0) {
        return bad(
            "max_latency",
            format!("must be a finite number > 0, got {}", o.max_latency),
        );
    }
    if !(o.recovery_spread.is_finite() && o.recovery_spread > 0.0) {
        return bad(
            "recovery_spread",
            format!("must be a finite number > 0, got {}", o.recovery_spread),
        );
    }
    if !(1..=omnikin::estimate::fusion::MAX_RECOVERY_COUNT).contains(&o.recovery_count) {
        return bad(
            "recovery_count",
            format!("must be in 1..=16, got {}", o.recovery_count),
        );
    }
    for (v, name) in [
        (o.events.slip_yaw_rate, "events.slip_yaw_rate"),
        (o.events.slip_residual, "events.slip_residual"),
        (o.events.collision_decel, "events.collision_decel"),
    ] {
        if let Some(v) = v
            && !(v.is_finite() && v > 0.0)
        {
            return bad(name, format!("must be a finite number > 0, got {v}"));
        }
    }
    if !o.gyro_bias.is_finite() {
        return bad("gyro_bias", format!("must be finite, got {}", o.gyro_bias));
    }
    if o.counts_per_rev == Some(0) {
        return bad("counts_per_rev", "must be >= 1, got 0".into());
    }
    if let Some(p) = o.initial_pose
        && !(p.x.is_finite() && p.y.is_finite() && p.heading.is_finite())
    {
        return bad("initial_pose", format!("must be finite, got {p:?}"));
    }
    Ok(())
}

/// Reads the fixes table: `t,x,y` with optional `heading` and `arrival`, sorted by arrival.
///
/// # Errors
/// [`OdometryInputError::Table`] for missing columns, [`OdometryInputError::Input`] for an arrival
/// before the fix was taken.
pub fn read_fixes(table: &NumericTable) -> Result<Vec<FixRecord>, OdometryInputError> {
    let columns = FixColumns::of(table.require(&["t", "x", "y"], FIX_COLUMNS)?, |n| {
        table.col(n)
    });
    let mut fixes = Vec::with_capacity(table.rows.len());
    for (line, v) in &table.rows {
        fixes.push(columns.record(&table.file, *line, v)?);
    }
    fixes.sort_by(|a, b| a.arrival.total_cmp(&b.arrival));
    Ok(fixes)
}

/// [`read_fixes`] from a table read row by row: the fixes are held (80 bytes each, so 800 MB
/// at [`MAX_TRACK_ROWS`](crate::limits::MAX_TRACK_ROWS)), not the table.
///
/// # Errors
/// As [`read_fixes`], and the table's own errors (a bad row, a time that does not increase).
pub fn read_fix_rows<R: std::io::BufRead>(
    mut rows: NumericRows<R>,
) -> Result<FixList, OdometryInputError> {
    let columns = FixColumns::of(rows.require(&["t", "x", "y"], FIX_COLUMNS)?, |n| {
        rows.col(n)
    });
    let file = rows.file.clone();
    let mut records = Vec::new();
    while let Some((line, v)) = rows.next_row()? {
        records.push(columns.record(&file, line, v)?);
    }
    records.sort_by(|a, b| a.arrival.total_cmp(&b.arrival));
    Ok(FixList { file, records })
}

const FIX_COLUMNS: &str = "fixes need t,x,y";

/// Where a fixes table keeps each field.
struct FixColumns {
    txy: Vec<usize>,
    heading: Option<usize>,
    arrival: Option<usize>,
}

impl FixColumns {
    fn of(txy: Vec<usize>, col: impl Fn(&str) -> Option<usize>) -> Self {
        Self {
            txy,
            heading: col("heading"),
            arrival: col("arrival"),
        }
    }

    /// The fix of row `v` (line `line` of `file`), its result not yet known.
    fn record(&self, file: &str, line: usize, v: &[f64]) -> Result<FixRecord, OdometryInputError> {
        let t = v[self.txy[0]];
        let arr = self.arrival.map_or(t, |a| v[a]);
        if arr < t {
            return Err(input(
                file,
                Some(line),
                format!("column arrival: {arr} is before the fix was taken (t = {t})"),
            ));
        }
        Ok(FixRecord {
            line,
            t,
            arrival: arr,
            x: v[self.txy[1]],
            y: v[self.txy[2]],
            heading: self.heading.map(|h| v[h]),
            result: FixResult::AfterLog,
        })
    }
}

/// Runs wheel odometry over `log` for the robot `description`, fusing `fixes` (a table as
/// [`read_fixes`] reads) when given: [`OdometryStream`] over every row, the rows kept.
///
/// # Errors
/// [`OdometryInputError`] naming the table, line and column: missing wheel or steer columns, a log
/// of another robot (extra `q`/`s` columns), `imu` without a `yaw` or `gyro_z` column, an empty
/// log, values outside the plausible ranges of `omnikin_plan::limits`, bad fixes or options.
pub fn run(
    description: &RobotDescription,
    log: &NumericTable,
    fixes: Option<&NumericTable>,
    options: &OdometryOptions,
) -> Result<OdometryRun, OdometryInputError> {
    let fixes = match fixes {
        Some(table) => Some(FixList {
            file: table.file.clone(),
            records: read_fixes(table)?,
        }),
        None => None,
    };
    let mut stream = OdometryStream::new(description, &log.file, &log.header, fixes, options)?;
    let mut columns = OdometryColumns::default();
    for (line, v) in &log.rows {
        columns.push(&stream.push(*line, v)?);
    }
    let end = stream.finish()?;
    Ok(OdometryRun {
        columns,
        fixes: end.fixes,
        summary: end.summary,
        events: end.events,
    })
}
