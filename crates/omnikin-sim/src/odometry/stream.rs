//! The odometry pipeline one log row at a time ([`OdometryStream`]): what [`run`](super::run)
//! does over a whole table, with memory that does not grow with the log.
//!
//! The stream holds the robot, the core's [`Odometry`] and [`PoseFusion`] (its history of
//! [`HISTORY`] states, about 100 kB), the fixes ([`FixList`], 80 bytes per fix) and running
//! sums for the summary. What grows with the log is small and stated: one `f64` per second of
//! log with a shell spin (the per-second means whose scatter bounds `Ω3`, at most one per row)
//! and one [`OdometryEvent`] per slip or collision. Each row's estimate is returned by
//! [`push`](OdometryStream::push) for the caller to write or keep; [`finish`](OdometryStream::finish)
//! gives the fixes' fates, the events and the summary.

use omnikin::description::RobotDescription;
use omnikin::estimate::fix::Fix;
use omnikin::estimate::fusion::{
    FusionConfig, FusionError, FusionOutcome, PoseFusion, Recovery, StepHeading,
};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::nalgebra::{Matrix3, Vector3};
use omnikin::{MAX_WHEELS, Pose2};

use super::events::{self, OdometryEvent, ResolvedThresholds};
use super::tilt;
use super::{
    FixRecord, FixResult, FixSummary, HISTORY, HeadingSource, OdometryInputError, OdometryOptions,
    OdometrySummary, ShellSpin, TiltReport, check_options, input, num,
};
use crate::table::require;

/// Camera fixes for the pipeline: the file that named them (in errors) and the fixes sorted by
/// arrival ([`read_fixes`](super::read_fixes), [`read_fix_rows`](super::read_fix_rows)).
#[derive(Clone, Debug, PartialEq)]
pub struct FixList {
    /// The fixes file, as named in errors.
    pub file: String,
    /// The fixes, sorted by arrival; each one's [`FixRecord::result`] is filled in by the run.
    pub records: Vec<FixRecord>,
}

/// One log sample's estimate (world frame; m, m, rad unwrapped).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryRow {
    /// Sample time, s (the log's `t`).
    pub t: f64,
    /// The estimate: fused with the fixes when there are fixes, else the wheel odometry.
    pub estimate: Pose2<f64>,
    /// 1-σ of the estimate's x, y (m) and heading (rad); zeros without fixes.
    pub std: [f64; 3],
    /// The pure wheel odometry (no fixes).
    pub odometry: Pose2<f64>,
}

/// What a finished stream gives besides its rows.
#[derive(Clone, Debug, PartialEq)]
pub struct OdometryEnd {
    /// Every fix in arrival order with its fate (empty without fixes).
    pub fixes: Vec<FixRecord>,
    /// Counters and end pose.
    pub summary: OdometrySummary,
    /// Slip and collision events, by start time.
    pub events: Vec<OdometryEvent>,
}

#[derive(Clone, Copy)]
enum Source {
    Wheels,
    Gyro(usize),
    Yaw(usize),
}

/// The odometry pipeline fed one encoder-log row at a time: [`new`](Self::new) checks the
/// header and the options, [`push`](Self::push) each row in log order, then
/// [`finish`](Self::finish). The rows and the summary are those of [`run`](super::run) over
/// the same table, bit for bit (it is this stream).
pub struct OdometryStream {
    log_file: String,
    header: Vec<String>,
    robot_name: String,
    kind: &'static str,
    options: OdometryOptions,
    n: usize,
    q: Vec<usize>,
    s: Vec<usize>,
    source: Source,
    inertial: Option<[usize; 5]>,
    tilt_note: &'static str,
    scale: f64,
    fixes: Option<FixList>,
    next_fix: usize,
    step_heading: StepHeading,
    config: FusionConfig<f64>,
    /// Created at the first row (its time is the filter's start). About 100 kB: on the heap.
    est: Option<Box<PoseFusion<f64, HISTORY>>>,
    odo: Odometry<f64>,
    counts: FixSummary,
    t0: f64,
    rows: usize,
    last: Option<(f64, Pose2<f64>)>,
    max_slip: (f64, f64),
    spin_sum: (f64, usize),
    // Mean wheel heading rate at zero spin, and per-second means of Ω3 (their scatter).
    wheel_rate_sum: f64,
    blocks: Vec<f64>,
    block: (f64, usize, f64),
    path: f64,
    tilt_tracker: Option<tilt::TiltTracker>,
    // A sphere's or ballbot's wheels on a tilted platform measure the relative rate in the
    // tilted frame: with the tilt tracked, their increments are de-tilted before the level
    // kinematics (tilt::shell_maps).
    shell_maps: Option<(Matrix3<f64>, Matrix3<f64>)>,
    /// (previous raw angles, de-tilted cumulative angles, previous time).
    detilted: Option<([f64; 3], [f64; 3], f64)>,
    /// The de-tilting's change of the wheels' relative spin ω̃_z over the last step, rad/s.
    wheel_difference: f64,
    /// Sum of (vertical rate − gyro_z) and of the de-tilted minus raw wheel spin over the
    /// samples with a spin: their difference to the uncompensated Ω3.
    tilt_difference_sum: f64,
    thresholds: ResolvedThresholds,
    detector: events::Detector,
}

impl OdometryStream {
    /// Starts the pipeline for the robot `description` over a log named `log_file` whose
    /// columns are `header`, fusing `fixes` when given.
    ///
    /// # Errors
    /// [`OdometryInputError`] naming the file, line 1 and the column: missing wheel or steer
    /// columns, a log of another robot (extra `q`/`s` columns), `imu` without a `yaw` or
    /// `gyro_z` column; bad options; a robot description that does not build.
    pub fn new(
        description: &RobotDescription,
        log_file: &str,
        header: &[String],
        fixes: Option<FixList>,
        options: &OdometryOptions,
    ) -> Result<Self, OdometryInputError> {
        check_options(options)?;
        let robot = description.build::<f64>()?;
        let n = robot.wheels();
        let steerable = robot.steerable();
        let col = |name: &str| header.iter().position(|h| h == name);
        let wheel_cols: Vec<String> = std::iter::once("t".to_string())
            .chain((1..=n).map(|i| format!("q{i}")))
            .collect();
        let q = require(
            log_file,
            header,
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
            require(
                log_file,
                header,
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
        for c in [format!("q{}", n + 1), extra] {
            if col(&c).is_some() {
                return Err(input(
                    log_file,
                    Some(1),
                    format!(
                        "column {c}: {} ({}) has {n} wheels{}, but the log has {c}: is it \
                         the log of another robot? (header: {})",
                        description.name,
                        description.kind(),
                        if steerable {
                            " with steering"
                        } else {
                            " and no steering"
                        },
                        omnikin::description::excerpt(&header.join(","))
                    ),
                ));
            }
        }
        let inertial_cols = ["gyro_x", "gyro_y", "accel_x", "accel_y", "accel_z"].map(col);
        let source = match (options.imu, col("yaw"), col("gyro_z")) {
            (false, _, _) => Source::Wheels,
            (true, Some(y), _) => Source::Yaw(y),
            (true, None, Some(g)) => Source::Gyro(g),
            (true, None, None) => {
                return Err(input(
                    log_file,
                    Some(1),
                    format!(
                        "--imu needs a yaw or gyro_z column (header: {})",
                        header.join(",")
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
        let scale = options
            .counts_per_rev
            .map_or(1.0, |n| std::f64::consts::TAU / n as f64);
        let start = options
            .initial_pose
            .unwrap_or_else(|| Pose2::new(0.0, 0.0, 0.0));
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
        let odo = Odometry::new(robot, start);
        let tilt_tracker = inertial.map(|_| tilt::TiltTracker::new());
        let shell_maps = tilt_tracker
            .as_ref()
            .and_then(|_| tilt::shell_maps(odo.robot()));
        let thresholds = ResolvedThresholds::resolve(&options.events, &description.events);
        let detector = events::Detector::new(
            thresholds.thresholds,
            !matches!(source, Source::Wheels),
            odo.robot().motors() > 3,
        );
        Ok(Self {
            log_file: log_file.to_string(),
            header: header.to_vec(),
            robot_name: description.name.clone(),
            kind: description.kind(),
            options: *options,
            n,
            q,
            s,
            source,
            inertial,
            tilt_note,
            scale,
            fixes,
            next_fix: 0,
            step_heading,
            config,
            est: None,
            odo,
            counts: FixSummary::default(),
            t0: 0.0,
            rows: 0,
            last: None,
            max_slip: (0.0, 0.0),
            spin_sum: (0.0, 0),
            wheel_rate_sum: 0.0,
            blocks: Vec::new(),
            block: (0.0, 0, 0.0),
            path: 0.0,
            tilt_tracker,
            shell_maps,
            detilted: None,
            wheel_difference: 0.0,
            tilt_difference_sum: 0.0,
            thresholds,
            detector,
        })
    }

    /// Log rows pushed so far.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Takes the log row `values` (in header order) from line `line`, and returns its
    /// estimate. Rows must come in log order (the table readers check that time increases).
    ///
    /// # Errors
    /// [`OdometryInputError::Input`] naming the line and column: a value outside the plausible
    /// ranges of `omnikin_plan::limits`, a step the odometry or the filter refuses, a bad fix;
    /// a row narrower than the header.
    pub fn push(&mut self, line: usize, values: &[f64]) -> Result<OdometryRow, OdometryInputError> {
        if values.len() != self.header.len() {
            return Err(input(
                &self.log_file,
                Some(line),
                format!(
                    "{} values, but the header has {} columns",
                    values.len(),
                    self.header.len()
                ),
            ));
        }
        let at = |i: usize| values[i];
        let t = at(self.q[0]);
        if self.est.is_none() {
            self.start_filter(line, t)?;
        }
        let (log_file, header, scale) = (&self.log_file, &self.header, self.scale);
        let mut reading = EncoderReading::new(t, [0.0; MAX_WHEELS]);
        for i in 0..self.n {
            reading.wheel_angles[i] = at(self.q[i + 1]) * scale;
        }
        for (i, &c) in self.s.iter().enumerate() {
            reading.steer_angles[i] = at(c) * scale;
        }
        // Finite but meaningless angles and rates (a steer angle of 1e308 rad was used as
        // is): held to the plan file's bounds, naming the line and column.
        let bounded = |col: usize, max: f64, unit: &str| -> Result<(), OdometryInputError> {
            if at(col).abs() > max {
                return Err(input(
                    log_file,
                    Some(line),
                    format!(
                        "column {}: {} {unit} is outside the plausible range [-{max:e}, \
                         {max:e}] {unit} (omnikin_plan::limits)",
                        header[col],
                        num(at(col))
                    ),
                ));
            }
            Ok(())
        };
        for &c in &self.s {
            let unit = if self.options.counts_per_rev.is_some() {
                "counts"
            } else {
                "rad"
            };
            bounded(c, omnikin_plan::limits::MAX_HEADING / scale.min(1.0), unit)?;
        }
        match self.source {
            Source::Wheels => {}
            Source::Gyro(g) => bounded(g, omnikin_plan::limits::MAX_PLAN_RATE, "rad/s")?,
            Source::Yaw(y) => bounded(y, omnikin_plan::limits::MAX_HEADING, "rad")?,
        }
        if let Some(c) = self.inertial {
            for &col in &c[..2] {
                bounded(col, omnikin_plan::limits::MAX_PLAN_RATE, "rad/s")?;
            }
            for &col in &c[2..] {
                bounded(col, omnikin_plan::limits::ACCEL_RANGE.1, "m/s²")?;
            }
        }
        let gyro_bias = self.options.gyro_bias;
        let heading = match (self.source, self.inertial, self.tilt_tracker.as_mut()) {
            (Source::Wheels, _, _) => HeadingInput::Wheels,
            (Source::Gyro(g), Some(c), Some(tracker)) => {
                let gyro = [at(c[0]), at(c[1]), at(g) - gyro_bias];
                let rate = tracker
                    .step(t, gyro, [at(c[2]), at(c[3]), at(c[4])])
                    .map_err(|e| {
                        input(
                            log_file,
                            Some(line),
                            format!("columns accel_x,accel_y,accel_z: {e}"),
                        )
                    })?;
                HeadingInput::GyroRate(rate)
            }
            (Source::Gyro(g), _, _) => HeadingInput::GyroRate(at(g) - gyro_bias),
            (Source::Yaw(y), _, _) => HeadingInput::Absolute(at(y)),
        };
        if let (Some(maps), Some(tracker)) = (&self.shell_maps, self.tilt_tracker.as_mut()) {
            let raw = [
                reading.wheel_angles[0],
                reading.wheel_angles[1],
                reading.wheel_angles[2],
            ];
            let level = match self.detilted {
                None => raw,
                Some((prev, level, t0)) => {
                    let dq = [raw[0] - prev[0], raw[1] - prev[1], raw[2] - prev[2]];
                    let d = tracker.level_increments(maps, dq, t - t0);
                    if t > t0 {
                        let z = |v: [f64; 3]| (maps.1 * Vector3::from(v)).z;
                        self.wheel_difference = (z(d) - z(dq)) / (t - t0);
                    }
                    [level[0] + d[0], level[1] + d[1], level[2] + d[2]]
                }
            };
            self.detilted = Some((raw, level, t));
            reading.wheel_angles[..3].copy_from_slice(&level);
        }
        let step = self
            .odo
            .update(&reading, heading)
            .map_err(|e| input(log_file, Some(line), e.to_string()))?;
        self.path += step.delta.x.hypot(step.delta.y);
        self.detector.step(&step);
        if let Some(tracker) = self.tilt_tracker.as_mut() {
            tracker.after_step(&step);
        }
        if step.slip_residual > self.max_slip.0 {
            self.max_slip = (step.slip_residual, t);
        }
        if let Some(x) = step.shell_spin {
            self.spin_sum = (self.spin_sum.0 + x, self.spin_sum.1 + 1);
            self.wheel_rate_sum += step.twist.yaw_rate - x;
            if let Some(tracker) = &self.tilt_tracker {
                self.tilt_difference_sum += tracker.last_difference + self.wheel_difference;
            }
            let block = &mut self.block;
            *block = (block.0 + x, block.1 + 1, block.2);
            if t - block.2 >= 1.0 {
                self.blocks.push(block.0 / block.1 as f64);
                *block = (0.0, 0, t);
            }
        }
        let Some(est) = self.est.as_mut() else {
            // start_filter above set it.
            return Err(input(
                log_file,
                Some(line),
                "the filter did not start".into(),
            ));
        };
        let estimator_error =
            |file: &str, line: usize, e: FusionError| input(file, Some(line), e.to_string());
        if step.dt > 0.0 {
            est.predict(t, step.delta, self.step_heading)
                .map_err(|e| estimator_error(log_file, line, e))?;
        }
        if let Some(list) = self.fixes.as_mut() {
            let counts = &mut self.counts;
            while self.next_fix < list.records.len() && list.records[self.next_fix].arrival <= t {
                let rec = &mut list.records[self.next_fix];
                self.next_fix += 1;
                let fix = Fix {
                    t: rec.t,
                    x: rec.x,
                    y: rec.y,
                    heading: rec.heading,
                    std_xy: self.options.fix_std,
                    std_heading: self.options.fix_heading_std,
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
                    Err(e) => return Err(estimator_error(&list.file, rec.line, e)),
                };
            }
        }
        let (estimate, std) = if self.fixes.is_some() {
            let p = est.pose_covariance();
            let sd = |i: usize| p[(i, i)].max(0.0).sqrt();
            (est.pose(), [sd(0), sd(1), sd(2)])
        } else {
            (step.pose, [0.0; 3])
        };
        self.rows += 1;
        self.last = Some((t, estimate));
        Ok(OdometryRow {
            t,
            estimate,
            std,
            odometry: step.pose,
        })
    }

    /// The first row (time `t0`, line `line`) starts the filter and the summary's clocks.
    fn start_filter(&mut self, line: usize, t0: f64) -> Result<(), OdometryInputError> {
        let est = match self.options.initial_pose {
            Some(p) => PoseFusion::<f64, HISTORY>::new(
                t0,
                p,
                Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 1e-4)),
                self.config,
            ),
            None => PoseFusion::awaiting_fix(t0, 0.0, self.config),
        };
        let est = est.map_err(|e| input(&self.log_file, Some(line), e.to_string()))?;
        self.est = Some(Box::new(est));
        self.t0 = t0;
        self.max_slip = (0.0, t0);
        self.block = (0.0, 0, t0);
        Ok(())
    }

    /// Ends the run: the fixes' fates, the events and the summary.
    ///
    /// # Errors
    /// [`OdometryInputError::Input`] when no row was pushed (`no samples after the header`).
    pub fn finish(self) -> Result<OdometryEnd, OdometryInputError> {
        let (Some(est), Some((t_end, end))) = (self.est.as_deref(), self.last) else {
            return Err(input(
                &self.log_file,
                None,
                "no samples after the header".into(),
            ));
        };
        let (config, options, source, t0) = (self.config, self.options, self.source, self.t0);
        let duration = t_end - t0;
        let fix_summary = self.fixes.as_ref().map(|list| {
            let p = self.odo.pose();
            let (b, sb) = est.gyro_bias();
            FixSummary {
                after_log: list.records.len() - self.next_fix,
                fused_minus_odometry: (p.x - end.x).hypot(p.y - end.y),
                gyro_bias: (config.gyro_bias_std > 0.0).then_some((options.gyro_bias + b, sb)),
                wheel_scale: (config.scale_std > 0.0).then(|| est.wheel_scale()),
                ..self.counts
            }
        });
        let spin_sum = self.spin_sum;
        let blocks = &self.blocks;
        let step_heading = self.step_heading;
        let has_fixes = self.fixes.is_some();
        let summary = OdometrySummary {
            robot: self.robot_name.clone(),
            kind: self.kind,
            heading_source: match source {
                Source::Wheels => HeadingSource::Wheels,
                Source::Gyro(_) => HeadingSource::Gyro,
                Source::Yaw(_) => HeadingSource::Yaw,
            },
            samples: self.rows,
            duration,
            path_length: self.path,
            end,
            max_slip: (self.odo.robot().motors() > 3).then_some(self.max_slip),
            mean_shell_spin: (spin_sum.1 > 0).then(|| spin_sum.0 / spin_sum.1 as f64),
            shell_spin: (spin_sum.1 > 0).then(|| {
                let n = spin_sum.1 as f64;
                let (raw, w) = (spin_sum.0 / n, self.wheel_rate_sum / n);
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
                let from_fixes = has_fixes && est.initialised();
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
                let tilt = match self
                    .tilt_tracker
                    .as_ref()
                    .and_then(tilt::TiltTracker::figures)
                {
                    Some(f) => {
                        let spin_std = f.rate_std();
                        var += spin_std * spin_std;
                        TiltReport::Compensated {
                            mean_tilt: f.mean_tilt,
                            max_tilt: f.max_tilt,
                            tilt_std: f.tilt_std,
                            spin_std,
                            uncompensated: mean - self.tilt_difference_sum / n,
                        }
                    }
                    None => TiltReport::NotCompensated(self.tilt_note),
                };
                ShellSpin {
                    mean,
                    std: var.max(0.0).sqrt(),
                    uncorrected: raw,
                    from_fixes,
                    tilt,
                }
            }),
            shell_spin_unobservable: (self.odo.robot().kind().has_vertical_spin()
                && matches!(source, Source::Wheels))
            .then_some(
                "the heading comes from the wheels, so the spin is assumed (0), not measured: use --imu",
            ),
            fixes: fix_summary,
            event_thresholds: self.thresholds,
        };
        Ok(OdometryEnd {
            fixes: self.fixes.map(|l| l.records).unwrap_or_default(),
            summary,
            events: self.detector.finish(),
        })
    }
}
