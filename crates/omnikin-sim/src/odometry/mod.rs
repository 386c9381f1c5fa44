//! # Odometry over a recorded encoder log, optionally fused with camera fixes
//!
//! The pipeline behind `omnikin odometry`, as a library so that the command line and the Python
//! bindings run the same code on in-memory tables (no files): a parsed encoder log
//! ([`NumericTable`], conventions.md "Encoder log CSV for odometry") and optional camera fixes
//! go through the core's [`Odometry`] and [`PoseEstimator`]; the result is one row per log
//! sample ([`OdometryColumns`]) and a [`OdometrySummary`].
//!
//! * Log: `t,q1..qN` cumulative wheel angles (rad, or counts with
//!   [`OdometryOptions::counts_per_rev`]), one per wheel of the robot; `s1..sN` steer angles for
//!   the steerable kinds (caster3, swerve); optional `gyro_z` (rad/s) and `yaw` (rad).
//! * Fixes: `t,x,y` (s, m, m; world frame) with optional `heading` (rad) and `arrival` (s; when
//!   the fix reached the robot, default `t`). Each fix is handed to the filter when it arrives
//!   and fused at the time it was taken.
//!
//! Errors name the table, the line and the column ([`OdometryError`]).

use omnikin::description::RobotDescription;
use omnikin::estimate::estimator::{EstimatorError, Fix, FixOutcome, PoseEstimator, ProcessNoise};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::nalgebra::{Matrix3, Vector3};
use omnikin::{MAX_WHEELS, Pose2};

use crate::table::{NumericTable, TableError};

/// Odometry-step history kept for late camera fixes (at 100 Hz: 2.5 s).
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

    fn push(&mut self, t: f64, estimate: Pose2<f64>, odometry: Pose2<f64>) {
        self.t.push(t);
        self.x.push(estimate.x);
        self.y.push(estimate.y);
        self.heading.push(estimate.heading);
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
    /// Fix counters, when fixes were given.
    pub fixes: Option<FixSummary>,
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
    enum Source {
        Wheels,
        Gyro(usize),
        Yaw(usize),
    }
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
        |file: &str, line: usize, e: EstimatorError| input(file, Some(line), e.to_string());
    let mut est = PoseEstimator::<f64, HISTORY>::new(
        t0,
        start,
        Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 1e-4)),
        ProcessNoise::wheel_odometry(),
    )
    .map_err(|e| estimator_error(&log.file, log.rows[0].0, e))?;
    let mut odo = Odometry::new(robot, start);
    let mut columns = OdometryColumns::default();
    let mut counts = FixSummary::default();
    let mut next_fix = 0;
    let mut max_slip = (0.0f64, t0);
    let mut spin_sum = (0.0f64, 0usize);
    let mut path = 0.0;
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
        let heading = match source {
            Source::Wheels => HeadingInput::Wheels,
            Source::Gyro(g) => HeadingInput::GyroRate(at(g) - options.gyro_bias),
            Source::Yaw(y) => HeadingInput::Absolute(at(y)),
        };
        let step = odo
            .update(&reading, heading)
            .map_err(|e| input(&log.file, Some(line), e.to_string()))?;
        path += step.delta.x.hypot(step.delta.y);
        if step.slip_residual > max_slip.0 {
            max_slip = (step.slip_residual, t);
        }
        if let Some(x) = step.shell_spin {
            spin_sum = (spin_sum.0 + x, spin_sum.1 + 1);
        }
        if step.dt > 0.0 {
            est.predict(t, step.delta)
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
                    Ok(FixOutcome::Accepted { mahalanobis2 }) => {
                        counts.accepted += 1;
                        FixResult::Accepted { mahalanobis2 }
                    }
                    Ok(FixOutcome::Rejected { mahalanobis2, gate }) => {
                        counts.rejected += 1;
                        FixResult::Rejected { mahalanobis2, gate }
                    }
                    Err(EstimatorError::FixTooOld { .. }) => {
                        counts.too_late += 1;
                        FixResult::TooLate
                    }
                    Err(e) => return Err(estimator_error(&fix_file, rec.line, e)),
                };
            }
        }
        let estimate = if fix_list.is_some() {
            est.pose()
        } else {
            step.pose
        };
        columns.push(t, estimate, step.pose);
    }

    let end = columns.pose(columns.len() - 1).unwrap_or(start);
    let duration = columns.t.last().copied().unwrap_or(t0) - t0;
    let fixes_out = fix_list.unwrap_or_default();
    let fix_summary = fixes.map(|_| {
        let p = odo.pose();
        FixSummary {
            after_log: fixes_out.len() - next_fix,
            fused_minus_odometry: (p.x - end.x).hypot(p.y - end.y),
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
        fixes: fix_summary,
    };
    Ok(OdometryRun {
        columns,
        fixes: fixes_out,
        summary,
    })
}
