//! # Odometry over a recorded encoder log, optionally fused with camera fixes
//!
//! The pipeline behind `omnikin odometry`, as a library so that the command line and the Python
//! bindings run the same code on in-memory tables (no files): a parsed encoder log
//! ([`NumericTable`], conventions.md "Encoder log CSV for odometry") and optional camera fixes
//! go through the core's [`Odometry`] and [`PoseFusion`] (pose, gyro bias, wheel scale); the
//! result is one row per log sample ([`OdometryColumns`]), every fix's fate ([`FixRecord`]),
//! the slip and collision events ([`events`]) and an [`OdometrySummary`].
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
//! Errors name the table, the line and the column ([`OdometryError`]).

use omnikin::description::RobotDescription;
use omnikin::estimate::estimator::Fix;
use omnikin::estimate::fusion::{
    FusionConfig, FusionError, FusionOutcome, PoseFusion, Recovery, StepHeading,
};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::nalgebra::{Matrix3, Vector3};
use omnikin::{MAX_WHEELS, Pose2};

use crate::table::{NumericTable, TableError};

pub mod events;
pub mod tilt;
pub use events::{
    EventKind, EventOverrides, EventThresholds, OdometryEvent, ResolvedThresholds, ThresholdSource,
};

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

    fn push(&mut self, t: f64, estimate: Pose2<f64>, std: [f64; 3], odometry: Pose2<f64>) {
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
pub enum OdometryError {
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

fn input(file: &str, line: Option<usize>, message: String) -> OdometryError {
    OdometryError::Input {
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

fn check_options(o: &OdometryOptions) -> Result<(), OdometryError> {
    let bad = |option, message: String| Err(OdometryError::Option { option, message });
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
/// [`OdometryError::Table`] for missing columns, [`OdometryError::Input`] for an arrival
/// before the fix was taken.
pub fn read_fixes(table: &NumericTable) -> Result<Vec<FixRecord>, OdometryError> {
    let c = table.require(&["t", "x", "y"], "fixes need t,x,y")?;
    let heading = table.col("heading");
    let arrival = table.col("arrival");
    let mut fixes = Vec::with_capacity(table.rows.len());
    for (line, v) in &table.rows {
        let t = v[c[0]];
        let arr = arrival.map_or(t, |a| v[a]);
        if arr < t {
            return Err(input(
                &table.file,
                Some(*line),
                format!("column arrival: {arr} is before the fix was taken (t = {t})"),
            ));
        }
        fixes.push(FixRecord {
            line: *line,
            t,
            arrival: arr,
            x: v[c[1]],
            y: v[c[2]],
            heading: heading.map(|h| v[h]),
            result: FixResult::AfterLog,
        });
    }
    fixes.sort_by(|a, b| a.arrival.total_cmp(&b.arrival));
    Ok(fixes)
}

/// Runs wheel odometry over `log` for the robot `description`, fusing `fixes` (a table as
/// [`read_fixes`] reads) when given.
///
/// # Errors
/// [`OdometryError`] naming the table, line and column: missing wheel or steer columns, a log
/// of another robot (extra `q`/`s` columns), `imu` without a `yaw` or `gyro_z` column, an empty
/// log, values outside the plausible ranges of `omnikin_plan::limits`, bad fixes or options.
pub fn run(
    description: &RobotDescription,
    log: &NumericTable,
    fixes: Option<&NumericTable>,
    options: &OdometryOptions,
) -> Result<OdometryRun, OdometryError> {
    check_options(options)?;
    let robot = description.build::<f64>()?;
    let n = robot.wheels();
    let steerable = robot.steerable();
    let wheel_cols: Vec<String> = std::iter::once("t".to_string())
        .chain((1..=n).map(|i| format!("q{i}")))
        .collect();
    let q = log.require(
        &wheel_cols.iter().map(String::as_str).collect::<Vec<_>>(),
        &format!(
            "an encoder log of {} ({}, {n} wheels) needs {}",
            description.name,
            description.kind(),
            wheel_cols.join(",")
        ),
    )?;
    let s = if steerable {
        let steer_cols: Vec<String> = (1..=n).map(|i| format!("s{i}")).collect();
        log.require(
            &steer_cols.iter().map(String::as_str).collect::<Vec<_>>(),
            &format!(
                "{} ({}) steers its wheels: it needs its steer angles {}",
                description.name,
                description.kind(),
                steer_cols.join(",")
            ),
        )?
    } else {
        Vec::new()
    };
    // A log of another robot: more wheel columns, or steer angles the robot does not have,
    // were ignored and the odometry of the wrong robot written without a word.
    let extra = if steerable {
        format!("s{}", n + 1)
    } else {
        "s1".to_string()
    };
    for col in [format!("q{}", n + 1), extra] {
        if log.col(&col).is_some() {
            return Err(input(
                &log.file,
                Some(1),
                format!(
                    "column {col}: {} ({}) has {n} wheels{}, but the log has {col}: is it \
                     the log of another robot? (header: {})",
                    description.name,
                    description.kind(),
                    if steerable {
                        " with steering"
                    } else {
                        " and no steering"
                    },
                    omnikin::description::excerpt(&log.header.join(","))
                ),
            ));
        }
    }
    #[derive(Clone, Copy)]
    enum Source {
        Wheels,
        Gyro(usize),
        Yaw(usize),
    }
    let inertial_cols = ["gyro_x", "gyro_y", "accel_x", "accel_y", "accel_z"].map(|c| log.col(c));
    let source = match (options.imu, log.col("yaw"), log.col("gyro_z")) {
        (false, _, _) => Source::Wheels,
        (true, Some(y), _) => Source::Yaw(y),
        (true, None, Some(g)) => Source::Gyro(g),
        (true, None, None) => {
            return Err(input(
                &log.file,
                Some(1),
                format!(
                    "--imu needs a yaw or gyro_z column (header: {})",
                    log.header.join(",")
                ),
            ));
        }
    };
    let has_accel = inertial_cols[2..].iter().all(Option::is_some);
    let has_gyro_xy = inertial_cols[..2].iter().all(Option::is_some);
    // The columns of the 3-axis gyro and the accelerometer, when the tilt is compensated.
    let (inertial, tilt_note) = match source {
        Source::Wheels => (None, "the heading comes from the wheels"),
        Source::Yaw(_) => (
            None,
            "the yaw column is taken as the heading about the vertical as given",
        ),
        Source::Gyro(_) if !has_accel => (
            None,
            "no accel_x,accel_y,accel_z columns: gyro_z taken as the heading rate",
        ),
        Source::Gyro(_) if !has_gyro_xy => (
            None,
            "accel columns but no gyro_x,gyro_y: the body rate cannot be projected on the \
             vertical",
        ),
        Source::Gyro(_) if !options.tilt_compensation => (None, "switched off"),
        Source::Gyro(_) => (Some(inertial_cols.map(|c| c.unwrap_or(0))), ""),
    };
    if log.rows.is_empty() {
        return Err(input(&log.file, None, "no samples after the header".into()));
    }
    let scale = options
        .counts_per_rev
        .map_or(1.0, |n| std::f64::consts::TAU / n as f64);
    let start = options
        .initial_pose
        .unwrap_or_else(|| Pose2::new(0.0, 0.0, 0.0));

    let (fix_file, mut fix_list) = match fixes {
        Some(table) => (table.file.clone(), Some(read_fixes(table)?)),
        None => (String::new(), None),
    };
    let t0 = log.rows[0].1[q[0]];
    let estimator_error =
        |file: &str, line: usize, e: FusionError| input(file, Some(line), e.to_string());
    let step_heading = match source {
        Source::Wheels => StepHeading::Wheels,
        Source::Gyro(_) => StepHeading::Gyro,
        Source::Yaw(_) => StepHeading::Absolute,
    };
    let defaults = FusionConfig::<f64>::default();
    let config = FusionConfig {
        gyro_bias_std: if options.estimate_gyro_bias && step_heading == StepHeading::Gyro {
            defaults.gyro_bias_std
        } else {
            0.0
        },
        scale_std: if options.estimate_wheel_scale {
            defaults.scale_std
        } else {
            0.0
        },
        max_latency: options.max_latency,
        recovery_count: options.recovery_count,
        recovery_spread: options.recovery_spread,
        ..defaults
    };
    let est = match options.initial_pose {
        Some(p) => PoseFusion::<f64, HISTORY>::new(
            t0,
            p,
            Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 1e-4)),
            config,
        ),
        None => PoseFusion::awaiting_fix(t0, 0.0, config),
    };
    // About 100 kB: on the heap.
    let mut est = Box::new(est.map_err(|e| estimator_error(&log.file, log.rows[0].0, e))?);
    let mut odo = Odometry::new(robot, start);
    let mut columns = OdometryColumns::default();
    let mut counts = FixSummary::default();
    let mut next_fix = 0;
    let mut max_slip = (0.0f64, t0);
    let mut spin_sum = (0.0f64, 0usize);
    // Mean wheel heading rate at zero spin, and per-second means of Ω3 (their scatter).
    let mut wheel_rate_sum = 0.0f64;
    let mut blocks: Vec<f64> = Vec::new();
    let mut block = (0.0f64, 0usize, t0);
    let mut path = 0.0;
    let mut tilt_tracker = inertial.map(|_| tilt::TiltTracker::new());
    // A sphere's or ballbot's wheels on a tilted platform measure the relative rate in the
    // tilted frame: with the tilt tracked, their increments are de-tilted before the level
    // kinematics (tilt::shell_maps). (previous raw angles, de-tilted cumulative angles).
    let shell_maps = tilt_tracker
        .as_ref()
        .and_then(|_| tilt::shell_maps(odo.robot()));
    let mut detilted: Option<([f64; 3], [f64; 3], f64)> = None;
    // The de-tilting's change of the wheels' relative spin ω̃_z over the last step, rad/s.
    let mut wheel_difference = 0.0f64;
    // Sum of (vertical rate − gyro_z) and of the de-tilted minus raw wheel spin over the
    // samples with a spin: their difference to the uncompensated Ω3.
    let mut tilt_difference_sum = 0.0f64;
    let thresholds = ResolvedThresholds::resolve(&options.events, &description.events);
    let mut detector = events::Detector::new(
        thresholds.thresholds,
        !matches!(source, Source::Wheels),
        odo.robot().motors() > 3,
    );
    for (line, v) in &log.rows {
        let line = *line;
        let at = |i: usize| v[i];
        let t = at(q[0]);
        let mut reading = EncoderReading::new(t, [0.0; MAX_WHEELS]);
        for i in 0..n {
            reading.wheel_angles[i] = at(q[i + 1]) * scale;
        }
        for (i, &c) in s.iter().enumerate() {
            reading.steer_angles[i] = at(c) * scale;
        }
        // Finite but meaningless angles and rates (a steer angle of 1e308 rad was used as
        // is): held to the plan file's bounds, naming the line and column.
        let bounded = |col: usize, max: f64, unit: &str| -> Result<(), OdometryError> {
            if at(col).abs() > max {
                return Err(input(
                    &log.file,
                    Some(line),
                    format!(
                        "column {}: {} {unit} is outside the plausible range [-{max:e}, \
                         {max:e}] {unit} (omnikin_plan::limits)",
                        log.header[col],
                        num(at(col))
                    ),
                ));
            }
            Ok(())
        };
        for &c in &s {
            let unit = if options.counts_per_rev.is_some() {
                "counts"
            } else {
                "rad"
            };
            bounded(c, omnikin_plan::limits::MAX_HEADING / scale.min(1.0), unit)?;
        }
        match source {
            Source::Wheels => {}
            Source::Gyro(g) => bounded(g, omnikin_plan::limits::MAX_PLAN_RATE, "rad/s")?,
            Source::Yaw(y) => bounded(y, omnikin_plan::limits::MAX_HEADING, "rad")?,
        }
        if let Some(c) = inertial {
            for &col in &c[..2] {
                bounded(col, omnikin_plan::limits::MAX_PLAN_RATE, "rad/s")?;
            }
            for &col in &c[2..] {
                bounded(col, omnikin_plan::limits::ACCEL_RANGE.1, "m/s²")?;
            }
        }
        let heading = match (source, inertial, tilt_tracker.as_mut()) {
            (Source::Wheels, _, _) => HeadingInput::Wheels,
            (Source::Gyro(g), Some(c), Some(tracker)) => {
                let gyro = [at(c[0]), at(c[1]), at(g) - options.gyro_bias];
                let rate = tracker
                    .step(t, gyro, [at(c[2]), at(c[3]), at(c[4])])
                    .map_err(|e| {
                        input(
                            &log.file,
                            Some(line),
                            format!("columns accel_x,accel_y,accel_z: {e}"),
                        )
                    })?;
                HeadingInput::GyroRate(rate)
            }
            (Source::Gyro(g), _, _) => HeadingInput::GyroRate(at(g) - options.gyro_bias),
            (Source::Yaw(y), _, _) => HeadingInput::Absolute(at(y)),
        };
        if let (Some(maps), Some(tracker)) = (&shell_maps, tilt_tracker.as_mut()) {
            let raw = [
                reading.wheel_angles[0],
                reading.wheel_angles[1],
                reading.wheel_angles[2],
            ];
            let level = match detilted {
                None => raw,
                Some((prev, level, t0)) => {
                    let dq = [raw[0] - prev[0], raw[1] - prev[1], raw[2] - prev[2]];
                    let d = tracker.level_increments(maps, dq, t - t0);
                    if t > t0 {
                        let z = |v: [f64; 3]| (maps.1 * omnikin::nalgebra::Vector3::from(v)).z;
                        wheel_difference = (z(d) - z(dq)) / (t - t0);
                    }
                    [level[0] + d[0], level[1] + d[1], level[2] + d[2]]
                }
            };
            detilted = Some((raw, level, t));
            reading.wheel_angles[..3].copy_from_slice(&level);
        }
        let step = odo
            .update(&reading, heading)
            .map_err(|e| input(&log.file, Some(line), e.to_string()))?;
        path += step.delta.x.hypot(step.delta.y);
        detector.step(&step);
        if let Some(tracker) = tilt_tracker.as_mut() {
            tracker.after_step(&step);
        }
        if step.slip_residual > max_slip.0 {
            max_slip = (step.slip_residual, t);
        }
        if let Some(x) = step.shell_spin {
            spin_sum = (spin_sum.0 + x, spin_sum.1 + 1);
            wheel_rate_sum += step.twist.yaw_rate - x;
            if let Some(tracker) = &tilt_tracker {
                tilt_difference_sum += tracker.last_difference + wheel_difference;
            }
            block = (block.0 + x, block.1 + 1, block.2);
            if t - block.2 >= 1.0 {
                blocks.push(block.0 / block.1 as f64);
                block = (0.0, 0, t);
            }
        }
        if step.dt > 0.0 {
            est.predict(t, step.delta, step_heading)
                .map_err(|e| estimator_error(&log.file, line, e))?;
        }
        if let Some(list) = fix_list.as_mut() {
            while next_fix < list.len() && list[next_fix].arrival <= t {
                let rec = &mut list[next_fix];
                next_fix += 1;
                let fix = Fix {
                    t: rec.t,
                    x: rec.x,
                    y: rec.y,
                    heading: rec.heading,
                    std_xy: options.fix_std,
                    std_heading: options.fix_heading_std,
                };
                rec.result = match est.add_fix(&fix) {
                    Ok(FusionOutcome::Accepted { mahalanobis2 }) => {
                        counts.accepted += 1;
                        FixResult::Accepted { mahalanobis2 }
                    }
                    Ok(FusionOutcome::Rejected { mahalanobis2, gate }) => {
                        counts.rejected += 1;
                        FixResult::Rejected { mahalanobis2, gate }
                    }
                    Ok(FusionOutcome::Initialised) => {
                        counts.accepted += 1;
                        counts.initialised_at = Some(rec.t);
                        FixResult::Initialised
                    }
                    Ok(FusionOutcome::Recovered { recovery, rejected }) => {
                        counts.accepted += 1;
                        match recovery {
                            Recovery::Reinitialised => counts.reinitialised += 1,
                            Recovery::Inflated => counts.inflated += 1,
                        }
                        FixResult::Recovered { recovery, rejected }
                    }
                    Err(FusionError::TooLate { .. }) => {
                        counts.too_late += 1;
                        FixResult::TooLate
                    }
                    Err(e) => return Err(estimator_error(&fix_file, rec.line, e)),
                };
            }
        }
        let (estimate, std) = if fix_list.is_some() {
            let p = est.pose_covariance();
            let sd = |i: usize| p[(i, i)].max(0.0).sqrt();
            (est.pose(), [sd(0), sd(1), sd(2)])
        } else {
            (step.pose, [0.0; 3])
        };
        columns.push(t, estimate, std, step.pose);
    }

    let end = columns.pose(columns.len() - 1).unwrap_or(start);
    let duration = columns.t.last().copied().unwrap_or(t0) - t0;
    let fixes_out = fix_list.unwrap_or_default();
    let fix_summary = fixes.map(|_| {
        let p = odo.pose();
        let (b, sb) = est.gyro_bias();
        FixSummary {
            after_log: fixes_out.len() - next_fix,
            fused_minus_odometry: (p.x - end.x).hypot(p.y - end.y),
            gyro_bias: (config.gyro_bias_std > 0.0).then_some((options.gyro_bias + b, sb)),
            wheel_scale: (config.scale_std > 0.0).then(|| est.wheel_scale()),
            ..counts
        }
    });
    let summary = OdometrySummary {
        robot: description.name.clone(),
        kind: description.kind(),
        heading_source: match source {
            Source::Wheels => HeadingSource::Wheels,
            Source::Gyro(_) => HeadingSource::Gyro,
            Source::Yaw(_) => HeadingSource::Yaw,
        },
        samples: columns.len(),
        duration,
        path_length: path,
        end,
        max_slip: (odo.robot().motors() > 3).then_some(max_slip),
        mean_shell_spin: (spin_sum.1 > 0).then(|| spin_sum.0 / spin_sum.1 as f64),
        shell_spin: (spin_sum.1 > 0).then(|| {
            let n = spin_sum.1 as f64;
            let (raw, w) = (spin_sum.0 / n, wheel_rate_sum / n);
            // Scatter of the per-second means (the samples themselves are correlated).
            let scatter = if blocks.len() >= 2 {
                let m = blocks.iter().sum::<f64>() / blocks.len() as f64;
                let var = blocks.iter().map(|b| (b - m).powi(2)).sum::<f64>()
                    / (blocks.len() - 1) as f64;
                (var / blocks.len() as f64).sqrt()
            } else {
                0.0
            };
            let gyro = step_heading == StepHeading::Gyro;
            let from_fixes = fixes.is_some() && est.initialised();
            let (xs, p) = est.state();
            let (b, k, vb, vk, cbk) = if from_fixes {
                (
                    if gyro { xs[3] } else { 0.0 },
                    xs[4],
                    if gyro { p[(3, 3)] } else { 0.0 },
                    p[(4, 4)],
                    if gyro { p[(3, 4)] } else { 0.0 },
                )
            } else {
                let d = FusionConfig::<f64>::default();
                let vb = if gyro { d.gyro_bias_std.powi(2) } else { 0.0 };
                (0.0, 1.0, vb, d.scale_std.powi(2), 0.0)
            };
            // A state switched off has no variance: its prior is the honest bound.
            let d = FusionConfig::<f64>::default();
            let vb = if gyro && config.gyro_bias_std == 0.0 {
                d.gyro_bias_std.powi(2)
            } else {
                vb
            };
            let vk = if config.scale_std == 0.0 {
                d.scale_std.powi(2)
            } else {
                vk
            };
            // Ω3 = raw − b − (k − 1)·w;  ∂/∂b = −1, ∂/∂k = −w.
            let mut var = vb + w * w * vk + 2.0 * w * cbk + scatter * scatter;
            let mean = raw - b - (k - 1.0) * w;
            let tilt = match tilt_tracker.as_ref().and_then(tilt::TiltTracker::figures) {
                Some(f) => {
                    let spin_std = f.rate_std();
                    var += spin_std * spin_std;
                    TiltReport::Compensated {
                        mean_tilt: f.mean_tilt,
                        max_tilt: f.max_tilt,
                        tilt_std: f.tilt_std,
                        spin_std,
                        uncompensated: mean - tilt_difference_sum / n,
                    }
                }
                None => TiltReport::NotCompensated(tilt_note),
            };
            ShellSpin {
                mean,
                std: var.max(0.0).sqrt(),
                uncorrected: raw,
                from_fixes,
                tilt,
            }
        }),
        shell_spin_unobservable: (odo.robot().kind().has_vertical_spin()
            && matches!(source, Source::Wheels))
        .then_some(
            "the heading comes from the wheels, so the spin is assumed (0), not measured: use --imu",
        ),
        fixes: fix_summary,
        event_thresholds: thresholds,
    };
    Ok(OdometryRun {
        columns,
        fixes: fixes_out,
        summary,
        events: detector.finish(),
    })
}
