//! `omnikin odometry LOG.csv --robot R [--imu] [--fixes FIXES.csv] --out poses.csv [--plot F.svg]`:
//! wheel odometry (and camera fusion) over a recorded encoder log, with the core's
//! [`omnikin::estimate::odometry::Odometry`] and [`omnikin::estimate::estimator::PoseEstimator`].
//!
//! Input: the encoder log of conventions.md (`t,q1..qN` cumulative wheel angles in rad, or
//! counts with `--counts-per-rev`, one per wheel of the robot; `s1..sN` steer angles for the
//! steerable kinds, caster3 and swerve; optional `gyro_z` rad/s and `yaw` rad). Fixes: `t,x,y`
//! with optional `heading` and `arrival` (s; when the fix reached the robot, default `t`); each fix is handed to the filter when it arrives and fused
//! at the time it was taken. Output: `t,x,y,heading` per log row. Bad files are rejected with
//! `FILE:LINE: column NAME: what is wrong`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin::estimate::estimator::{EstimatorError, Fix, FixOutcome, PoseEstimator, ProcessNoise};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::nalgebra::{Matrix3, Vector3};
use omnikin::{MAX_WHEELS, Pose2};
// The log and fixes parser lives in the library so that it can be fuzzed (fuzz/).
use omnikin_sim::table::NumericTable as Table;

use crate::args::{Triple, finite_f64};

/// Odometry-step history kept for late camera fixes (at 100 Hz: 2.5 s).
const HISTORY: usize = 256;

/// `omnikin odometry`.
#[derive(clap::Args, Debug)]
pub struct OdometryArgs {
    /// Encoder log CSV: t,q1..qN (rad, cumulative; one per wheel), steerable kinds (caster3,
    /// swerve) add s1..sN (rad); optional gyro_z (rad/s) and yaw (rad).
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
    /// Also draw the path (odometry, fused estimate, fixes) and the heading to an SVG file.
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
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
}

fn positive_f64(s: &str) -> std::result::Result<f64, String> {
    let v = finite_f64(s)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("must be > 0, got \"{s}\""))
    }
}

/// What the run produced, for the summary and the plot.
struct Output {
    t: Vec<f64>,
    odometry: Vec<Pose2<f64>>,
    estimate: Vec<Pose2<f64>>,
}

/// Runs `omnikin odometry`.
pub fn run(args: &OdometryArgs) -> Result<()> {
    let description = RobotDescription::resolve(&args.robot)?;
    let robot = description.build::<f64>()?;
    let n = robot.wheels();
    let steerable = robot.steerable();
    let log = Table::load(&args.log)?;
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
            bail!(
                "{}:1: column {col}: {} ({}) has {n} wheels{}, but the log has {col}: is it \
                 the log of another robot? (header: {})",
                log.file,
                description.name,
                description.kind(),
                if steerable {
                    " with steering"
                } else {
                    " and no steering"
                },
                omnikin::description::excerpt(&log.header.join(","))
            );
        }
    }
    enum Source {
        Wheels,
        Gyro(usize),
        Yaw(usize),
    }
    let source = match (args.imu, log.col("yaw"), log.col("gyro_z")) {
        (false, _, _) => Source::Wheels,
        (true, Some(y), _) => Source::Yaw(y),
        (true, None, Some(g)) => Source::Gyro(g),
        (true, None, None) => bail!(
            "{}:1: --imu needs a yaw or gyro_z column (header: {})",
            log.file,
            log.header.join(",")
        ),
    };
    if log.rows.is_empty() {
        bail!("{}: no samples after the header", log.file);
    }
    let scale = args
        .counts_per_rev
        .map_or(1.0, |n| std::f64::consts::TAU / n as f64);
    let start = args.initial_pose.map_or(Pose2::new(0.0, 0.0, 0.0), |p| {
        Pose2::new(p.0[0], p.0[1], p.0[2])
    });

    let fixes = match &args.fixes {
        Some(path) => Some(read_fixes(path, args)?),
        None => None,
    };
    let t0 = log.rows[0].1[q[0]];
    let mut est = PoseEstimator::<f64, HISTORY>::new(
        t0,
        start,
        Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 1e-4)),
        ProcessNoise::wheel_odometry(),
    )?;
    let mut odo = Odometry::new(robot, start);
    let mut out = Output {
        t: Vec::new(),
        odometry: Vec::new(),
        estimate: Vec::new(),
    };
    let (mut accepted, mut rejected, mut too_old) = (0usize, 0usize, 0usize);
    let mut next_fix = 0;
    let mut max_slip = (0.0f64, t0);
    let mut spin_sum = (0.0f64, 0usize);
    let mut path = 0.0;
    for (line, v) in &log.rows {
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
        let bounded = |col: usize, max: f64, unit: &str| -> Result<()> {
            if at(col).abs() > max {
                bail!(
                    "{}:{line}: column {}: {} {unit} is outside the plausible range [-{max:e}, \
                     {max:e}] {unit} (omnikin_plan::limits)",
                    log.file,
                    log.header[col],
                    crate::args::num(at(col))
                );
            }
            Ok(())
        };
        for &c in &s {
            let unit = if args.counts_per_rev.is_some() {
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
            Source::Gyro(g) => HeadingInput::GyroRate(at(g) - args.gyro_bias),
            Source::Yaw(y) => HeadingInput::Absolute(at(y)),
        };
        let step = odo
            .update(&reading, heading)
            .with_context(|| format!("{}:{line}", log.file))?;
        path += step.delta.x.hypot(step.delta.y);
        if step.slip_residual > max_slip.0 {
            max_slip = (step.slip_residual, t);
        }
        if let Some(x) = step.shell_spin {
            spin_sum = (spin_sum.0 + x, spin_sum.1 + 1);
        }
        if step.dt > 0.0 {
            est.predict(t, step.delta)
                .with_context(|| format!("{}:{line}", log.file))?;
        }
        if let Some((fix_file, fixes)) = &fixes {
            while next_fix < fixes.len() && fixes[next_fix].1 <= t {
                let (fline, _, fix) = (fixes[next_fix].0, fixes[next_fix].1, fixes[next_fix].2);
                next_fix += 1;
                match est.add_fix(&fix) {
                    Ok(FixOutcome::Accepted { .. }) => accepted += 1,
                    Ok(FixOutcome::Rejected { mahalanobis2, gate }) => {
                        rejected += 1;
                        crate::errln!(
                            "warning: {fix_file}:{fline}: fix at t = {} s rejected as an outlier (d² = {mahalanobis2:.1} > {gate:.1})",
                            fix.t
                        );
                    }
                    Err(EstimatorError::FixTooOld { .. }) => too_old += 1,
                    Err(e) => return Err(anyhow::anyhow!("{fix_file}:{fline}: {e}")),
                }
            }
        }
        out.t.push(t);
        out.odometry.push(step.pose);
        out.estimate.push(if fixes.is_some() {
            est.pose()
        } else {
            step.pose
        });
    }

    let mut csv = String::from("t,x,y,heading\n");
    for (t, p) in out.t.iter().zip(&out.estimate) {
        let _ = writeln!(csv, "{t},{},{},{}", p.x, p.y, p.heading);
    }
    crate::output::write_file("--out", &args.out, |w| {
        std::io::Write::write_all(w, csv.as_bytes())
    })?;
    if let Some(p) = &args.mcap {
        crate::mcap_log::poses("--mcap", p, &out.t, &out.estimate)?;
    }

    let end = out.estimate.last().copied().unwrap_or(start);
    let duration = out.t.last().copied().unwrap_or(t0) - t0;
    crate::errln!(
        "robot: {} ({}); heading from {}",
        description.name,
        description.kind(),
        match source {
            Source::Wheels => "the wheels",
            Source::Gyro(_) => "gyro_z (integrated)",
            Source::Yaw(_) => "the yaw column",
        }
    );
    crate::errln!(
        "{} samples over {duration:.3} s; odometry path {path:.4} m; end pose x {:.4} m, y {:.4} m, heading {:.4} rad",
        out.t.len(),
        end.x,
        end.y,
        end.heading
    );
    // Kinds fitted by least squares (more motors than the twist has components) report slip.
    if robot.motors() > 3 {
        crate::errln!(
            "largest slip residual {} m/s at t = {} s",
            if max_slip.0 < 1e9 {
                format!("{:.4}", max_slip.0)
            } else {
                crate::args::num(max_slip.0)
            },
            crate::args::num(max_slip.1)
        );
    }
    if spin_sum.1 > 0 {
        crate::errln!(
            "mean shell/ball spin about the vertical (from wheels + IMU heading): {:.4} rad/s",
            spin_sum.0 / spin_sum.1 as f64
        );
    }
    if let Some((_, f)) = &fixes {
        let p = out.odometry.last().copied().unwrap_or(start);
        crate::errln!(
            "fixes: {accepted} fused, {rejected} rejected as outliers, {too_old} older than the history, {} after the log; fused end differs from pure odometry by {:.4} m",
            f.len() - next_fix,
            (p.x - end.x).hypot(p.y - end.y)
        );
    }
    crate::errln!("wrote {}", args.out.display());
    if let Some(svg) = &args.plot {
        let fix_points: Vec<(f64, f64)> = fixes
            .as_ref()
            .map(|(_, f)| f.iter().map(|(_, _, x)| (x.x, x.y)).collect())
            .unwrap_or_default();
        figure("--plot", svg, &out, &fix_points, fixes.is_some())?;
        crate::errln!("wrote {}", svg.display());
    }
    Ok(())
}

/// Fixes with their line, arrival time and the filter's measurement, sorted by arrival.
type Fixes = (String, Vec<(usize, f64, Fix<f64>)>);

fn read_fixes(path: &Path, args: &OdometryArgs) -> Result<Fixes> {
    let table = Table::load(path)?;
    let c = table.require(&["t", "x", "y"], "fixes need t,x,y")?;
    let heading = table.col("heading");
    let arrival = table.col("arrival");
    let mut fixes = Vec::with_capacity(table.rows.len());
    for (line, v) in &table.rows {
        let t = v[c[0]];
        let arr = arrival.map_or(t, |a| v[a]);
        if arr < t {
            bail!(
                "{}:{line}: column arrival: {arr} is before the fix was taken (t = {t})",
                table.file
            );
        }
        fixes.push((
            *line,
            arr,
            Fix {
                t,
                x: v[c[1]],
                y: v[c[2]],
                heading: heading.map(|h| v[h]),
                std_xy: args.fix_std,
                std_heading: args.fix_heading_std,
            },
        ));
    }
    fixes.sort_by(|a, b| a.1.total_cmp(&b.1));
    Ok((table.file, fixes))
}

fn figure(flag: &str, svg: &Path, out: &Output, fixes: &[(f64, f64)], fused: bool) -> Result<()> {
    crate::plot::svg_file(flag, svg, (1300, 640), |root| draw(root, out, fixes, fused))
}

fn draw(root: &crate::plot::Area, out: &Output, fixes: &[(f64, f64)], fused: bool) -> Result<()> {
    use crate::plot::{PALETTE, Series, draw_err, time_panel, xy_panel};
    use plotters::prelude::*;
    root.fill(&WHITE).map_err(draw_err)?;
    let (left, right) = root.split_horizontally(700);
    let xy = |p: &[Pose2<f64>]| p.iter().map(|p| (p.x, p.y)).collect::<Vec<_>>();
    let th = |p: &[Pose2<f64>]| {
        out.t
            .iter()
            .zip(p)
            .map(|(&t, p)| (t, p.heading))
            .collect::<Vec<_>>()
    };
    let mut paths = vec![Series::solid(
        "wheel odometry",
        xy(&out.odometry),
        PALETTE[0],
    )];
    let mut headings = vec![Series::solid(
        "wheel odometry",
        th(&out.odometry),
        PALETTE[0],
    )];
    if fused {
        paths.push(Series::solid(
            "fused with fixes",
            xy(&out.estimate),
            PALETTE[1],
        ));
        headings.push(Series::solid(
            "fused with fixes",
            th(&out.estimate),
            PALETTE[1],
        ));
        if !fixes.is_empty() {
            paths.push(Series::dashed("camera fixes", fixes.to_vec(), PALETTE[3]));
        }
    }
    xy_panel(
        &left,
        "estimated path (world frame)",
        "x [m]",
        "y [m]",
        &paths,
        &[],
        &[],
    )?;
    time_panel(&right, "heading", "heading [rad]", &headings, &[], None)?;
    Ok(())
}
