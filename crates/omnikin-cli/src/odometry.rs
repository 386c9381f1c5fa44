//! `omnikin odometry LOG.csv --robot R [--imu] [--fixes FIXES.csv] --out poses.csv [--plot F.svg|png|pdf]`:
//! wheel odometry (and camera fusion) over a recorded encoder log. The pipeline is
//! [`omnikin_sim::odometry::OdometryStream`]; this file parses the arguments and streams the log
//! through it row by row into the outputs; the summary's sentences are
//! [`omnikin_sim::odometry::report`]'s and the figure [`omnikin_plot::odometry`]'s.
//!
//! Input: the encoder log of conventions.md (`t,q1..qN` cumulative wheel angles in rad, or
//! counts with `--counts-per-rev`, one per wheel of the robot; `s1..sN` steer angles for the
//! steerable kinds, caster3 and swerve; optional `gyro_z` rad/s and `yaw` rad, and
//! `gyro_x,gyro_y,accel_x,accel_y,accel_z` for the platform tilt). Fixes: `t,x,y`
//! with optional `heading` and `arrival` (s; when the fix reached the robot, default `t`); each fix is handed to the filter when it arrives and fused
//! at the time it was taken. Output: `t,x,y,heading` per log row. Bad files are rejected with
//! `FILE:LINE: column NAME: what is wrong`.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use omnikin::Pose2;
use omnikin_plot::odometry::OdometryFigure;
use omnikin_sim::odometry::{
    EventOverrides, OdometryOptions, OdometryStream, read_fix_rows, report,
};
// The log and fixes parser lives in the library so that it can be fuzzed (fuzz/).
use omnikin_sim::table::NumericRows;

use crate::args::{Triple, finite_f64};

/// `omnikin odometry`.
#[derive(clap::Args, Debug)]
pub struct OdometryArgs {
    /// Encoder log CSV: t,q1..qN (rad, cumulative; one per wheel), steerable kinds (caster3,
    /// swerve) add s1..sN (rad); optional gyro_z (rad/s) and yaw (rad); optional gyro_x,gyro_y
    /// (rad/s) and accel_x,accel_y,accel_z (m/s², platform frame) for the tilt compensation.
    pub log: PathBuf,
    /// Robot: preset name (sphere-omni, ballbot, caster3, kiwi, x-drive, mecanum, swerve4) or
    /// path to a TOML description.
    #[arg(long)]
    pub robot: String,
    /// Heading from the IMU instead of the wheels: the log's `yaw` column (absolute heading) if
    /// present, otherwise its `gyro_z` column (integrated, trapezoidal rule).
    #[arg(long)]
    pub imu: bool,
    /// Camera fixes CSV: t,x,y (m) with optional heading (rad) and arrival (s); fused by a
    /// Kalman filter at the time each was taken, outliers rejected by a 99.9 % chi-square gate.
    #[arg(long, value_name = "FIXES.csv")]
    pub fixes: Option<PathBuf>,
    /// Output pose CSV: t,x,y,heading (world frame, heading unwrapped).
    #[arg(long, value_name = "poses.csv")]
    pub out: PathBuf,
    /// Also draw the path (odometry, fused estimate, fixes) and the heading as a figure; the
    /// extension chooses the format: .svg, .png or .pdf.
    #[arg(long, value_name = "FILE.svg|png|pdf")]
    pub plot: Option<PathBuf>,
    /// Ground truth to draw in the --plot figure (a tracked trajectory CSV: t,x,y with optional
    /// heading; e.g. a motion-capture record or a simulation's truth), as a dashed black line.
    #[arg(long, value_name = "TRUTH.csv", requires = "plot")]
    pub truth: Option<PathBuf>,
    /// The q (and s) columns are encoder counts with this many counts per revolution.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub counts_per_rev: Option<u32>,
    /// Starting pose X,Y,HEADING (m, m, rad; world frame).
    #[arg(long, allow_hyphen_values = true, value_name = "X,Y,H")]
    pub initial_pose: Option<Triple>,
    /// Standard deviation of a fix's x and y, m.
    #[arg(long, default_value_t = 0.01, value_parser = positive_f64)]
    pub fix_std: f64,
    /// Standard deviation of a fix's heading, rad (fixes with a heading column).
    #[arg(long, default_value_t = 0.05, value_parser = positive_f64)]
    pub fix_heading_std: f64,
    /// Also write the estimate as MCAP with Foxglove schemas (/pose, /tf;
    /// docs/seeing-the-robot.md).
    #[arg(long, value_name = "FILE")]
    pub mcap: Option<PathBuf>,
    /// Gyro bias to subtract from gyro_z, rad/s.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub gyro_bias: f64,
    /// Oldest fix still fused at the time it was taken, s before the latest encoder sample
    /// (whatever the encoder rate); older fixes are counted as too late.
    #[arg(long, default_value_t = 1.0, value_parser = positive_f64, value_name = "S")]
    pub max_latency: f64,
    /// Do not estimate the remaining gyro bias (with --imu on gyro_z).
    #[arg(long)]
    pub no_gyro_bias_state: bool,
    /// Do not estimate the common wheel-scale factor.
    #[arg(long)]
    pub no_wheel_scale_state: bool,
    /// Rejected fixes in a row that trigger a recovery (re-initialisation when they agree
    /// within --recovery-spread, covariance inflation otherwise).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=16), value_name = "N")]
    pub recovery_count: u32,
    /// Spread of the rejected fixes' innovations within which they count as agreeing, m.
    #[arg(long, default_value_t = 0.05, value_parser = positive_f64, value_name = "M")]
    pub recovery_spread: f64,
    /// Do not compensate the platform tilt (with gyro_x,gyro_y and accel_x,accel_y,accel_z
    /// columns, the heading rate is otherwise the body rate about the vertical).
    #[arg(long)]
    pub no_tilt_compensation: bool,
    /// Also write the slip and collision events to this CSV: kind,start,end,peak.
    #[arg(long, value_name = "events.csv")]
    pub events: Option<PathBuf>,
    /// Yaw-rate disagreement between the wheels and the IMU heading that counts as slip, rad/s
    /// (overrides the robot file's events.slip_yaw_rate; default 0.3).
    #[arg(long, value_parser = positive_f64, value_name = "RAD_S")]
    pub slip_yaw_rate: Option<f64>,
    /// Least-squares slip residual that counts as slip (kinds with more motors than twist
    /// components), m/s (overrides the robot file's events.slip_residual; default 0.05).
    #[arg(long, value_parser = positive_f64, value_name = "M_S")]
    pub slip_residual: Option<f64>,
    /// Deceleration of the wheel speed (over 50 ms) that counts as a collision, m/s²
    /// (overrides the robot file's events.collision_decel; default 3).
    #[arg(long, value_parser = positive_f64, value_name = "M_S2")]
    pub collision_decel: Option<f64>,
}

fn positive_f64(s: &str) -> std::result::Result<f64, String> {
    let v = finite_f64(s)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("must be > 0, got \"{s}\""))
    }
}

impl OdometryArgs {
    /// The library's options from the flags.
    pub fn options(&self) -> OdometryOptions {
        OdometryOptions {
            imu: self.imu,
            counts_per_rev: self.counts_per_rev,
            initial_pose: self
                .initial_pose
                .map(|p| Pose2::new(p.0[0], p.0[1], p.0[2])),
            fix_std: self.fix_std,
            fix_heading_std: self.fix_heading_std,
            gyro_bias: self.gyro_bias,
            max_latency: self.max_latency,
            estimate_gyro_bias: !self.no_gyro_bias_state,
            estimate_wheel_scale: !self.no_wheel_scale_state,
            recovery_count: self.recovery_count,
            recovery_spread: self.recovery_spread,
            tilt_compensation: !self.no_tilt_compensation,
            events: EventOverrides {
                slip_yaw_rate: self.slip_yaw_rate,
                slip_residual: self.slip_residual,
                collision_decel: self.collision_decel,
            },
        }
    }
}

/// Runs `omnikin odometry`: the log is read, estimated and written one row at a time (the
/// outputs to temporary files, moved into place at the end, removed on an error or on
/// SIGINT/SIGTERM), so the memory does not grow with the log: the fixes (80 bytes each) and,
/// with `--plot`, the thinned figure lines (at most `MAX_FIGURE_POINTS` points each) are what
/// is held.
pub fn run(args: &OdometryArgs) -> Result<()> {
    let description = crate::kinematics::resolve_robot(&args.robot)?;
    if let Some(Triple([_, _, h])) = args.initial_pose
        && h.abs() > std::f64::consts::TAU
    {
        crate::errln!(
            "warning: --initial-pose: heading {h} is read in radians ({:.1}°); if {h}° was meant, write {:.4}",
            h.to_degrees(),
            h.to_radians()
        );
    }
    let mut log = NumericRows::open(&args.log)?;
    let fixes = match &args.fixes {
        Some(path) => Some(read_fix_rows(NumericRows::open(path)?)?),
        None => None,
    };
    let fix_file = fixes.as_ref().map(|f| f.file.clone());
    // Read before the log is, so that a bad truth file fails before any output is written.
    let truth = match &args.truth {
        Some(path) => Some(omnikin_sim::track::Track::load(path)?),
        None => None,
    };
    let mut stream =
        OdometryStream::new(&description, &log.file, &log.header, fixes, &args.options())?;
    // The figure's lines are thinned as the rows come, which needs their number first: a
    // first pass over the file counts them. A pipe or FIFO cannot be read twice: its lines
    // are kept whole (16 bytes per point) and thinned when drawn, as before.
    let mut lines = match &args.plot {
        Some(_) if std::fs::metadata(&args.log).is_ok_and(|m| m.is_file()) => {
            Some(OdometryFigure::new(
                NumericRows::open(&args.log)?.count_rows()?,
                fix_file.is_some(),
            ))
        }
        Some(_) => Some(OdometryFigure::new(0, fix_file.is_some())),
        None => None,
    };
    crate::output::catch_signals()?;
    let cannot = |flag: &str, path: &Path| format!("{flag} {}: cannot write", path.display());
    let mut out = crate::output::OutFile::create("--out", &args.out)?;
    writeln!(out, "t,x,y,heading").with_context(|| cannot("--out", &args.out))?;
    let mut mcap = match &args.mcap {
        Some(p) => Some(crate::mcap_log::PoseLog::create("--mcap", p)?),
        None => None,
    };
    while let Some((line, values)) = log.next_row()? {
        crate::output::check_interrupted()?;
        let row = stream.push(line, values)?;
        let p = row.estimate;
        let f = omnikin_plan::CsvFloat;
        writeln!(out, "{},{},{},{}", f(row.t), f(p.x), f(p.y), f(p.heading))
            .with_context(|| cannot("--out", &args.out))?;
        if let Some(m) = mcap.as_mut() {
            m.push(row.t, p)?;
        }
        if let Some(l) = lines.as_mut() {
            l.push(&row);
        }
    }
    // A signal after the last row still stops the command before its outputs appear.
    crate::output::check_interrupted()?;
    let r = stream.finish()?;
    if let Some(file) = &fix_file {
        for line in report::fix_messages(file, &r.fixes) {
            crate::errln!("{line}");
        }
    }
    out.commit()?;
    if let Some(m) = mcap {
        m.finish()?;
    }

    for line in report::summary_lines(&r, &description.source_name) {
        crate::errln!("{line}");
    }
    crate::errln!("wrote {}", args.out.display());
    if let Some(path) = &args.events {
        let text = report::events_csv(&r);
        crate::output::write_file("--events", path, |w| {
            std::io::Write::write_all(w, text.as_bytes())
        })?;
        crate::errln!("wrote {}", path.display());
    }
    if let (Some(svg), Some(lines)) = (&args.plot, lines) {
        lines.write("--plot", svg, &r.fixes, truth.as_ref())?;
        crate::errln!("wrote {}", svg.display());
    }
    Ok(())
}
