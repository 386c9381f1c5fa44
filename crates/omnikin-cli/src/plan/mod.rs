//! `omnikin plan`: paper 000's square and circle, or a path through waypoints, planned within
//! the robot file's motor limits and written as a plan CSV/JSON (conventions.md columns), with
//! an optional SVG figure and a human summary on stderr.

use std::io::Write;
use std::path::{Path as FsPath, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use omnikin::description::RobotDescription;
use omnikin_plan::generators::{Circle, Square};
use omnikin_plan::heading::{HeadingLaw, HeadingProfile};
use omnikin_plan::path::{Corners, Path};
use omnikin_plan::planner::{
    InitialSteer, Limiter, MotionLimits, MoveKind, OnLimit, PlanOptions, Planned, Timing, plan,
};
use omnikin_plan::profile::ProfileKind;
use omnikin_plan::waypoints::Waypoints;
use omnikin_plan::{Plan, PlanningError, Quantity, RobotModel};

use crate::args::{Triple, finite_f64};
use crate::plot::{self, Arrow, PALETTE, Series};

/// `omnikin plan`.
#[derive(Args, Debug)]
pub struct PlanArgs {
    #[command(subcommand)]
    pub kind: PlanKind,
}

/// What to plan.
#[derive(Subcommand, Debug)]
pub enum PlanKind {
    /// Paper 000's square (eq. 6.1): legs +y, +x, -y, -x from the origin, heading 0, full stop
    /// at each corner, ramps of --ramp-fraction of the leg time.
    ///
    /// Paper series (side 0.4 m): --speed 0.1, 0.2, 0.4, 0.5 (leg time 4/k s).
    Square(SquareArgs),
    /// Paper 000's circle (eq. 6.3): x = R cos(w t), y = R sin(w t), heading = w t.
    ///
    /// Starts at full speed like the paper unless --ramp is given. omega is fixed by the
    /// request: a circle too fast for the robot is rejected with the wheel, rate and excess.
    /// Paper series (radius 0.2 m): --omega 0.5, 1, 2, 2.5.
    Circle(CircleArgs),
    /// A path through waypoints from FILE: CSV `x,y[,heading]` (optional header) or TOML
    /// `[[waypoint]]` tables with x, y[, heading] (m, rad).
    Waypoints(WaypointArgs),
}

/// Output format of the plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// `t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3[,s1,s2,s3,sd1,sd2,sd3]`.
    Csv,
    /// `{"columns": [...], "samples": [[...], ...]}`.
    Json,
}

/// Velocity profile shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ProfileArg {
    /// Constant-acceleration ramps.
    Trapezoid,
    /// Jerk-limited ramps.
    SCurve,
}

impl From<ProfileArg> for ProfileKind {
    fn from(p: ProfileArg) -> Self {
        match p {
            ProfileArg::Trapezoid => ProfileKind::Trapezoid,
            ProfileArg::SCurve => ProfileKind::SCurve,
        }
    }
}

/// Heading law.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum HeadingArg {
    /// Constant heading --heading (plus --spin rad/m along the path).
    Constant,
    /// Heading = direction of motion + --heading-offset (paper 000, eq. 5.5); turns in place
    /// at stops.
    Tangent,
    /// Interpolate the waypoint file's heading column along the path (natural cubic spline).
    Waypoints,
}

/// Path through the waypoints.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PathArg {
    /// Straight legs (corners per --corners).
    Polyline,
    /// Quintic spline with continuous curvature.
    Spline,
}

/// Corner treatment of a polyline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CornerArg {
    /// Full stop at each corner.
    Stop,
    /// Circular fillet of --fillet-radius.
    Fillet,
}

/// Options shared by every plan kind.
#[derive(Args, Debug)]
pub struct Common {
    /// Robot: preset name (sphere-omni, ballbot, caster3) or path to a TOML description.
    #[arg(long)]
    pub robot: String,
    /// Sampling rate, Hz (samples at k/rate, plus the exact end time).
    #[arg(long, default_value_t = 100.0, allow_hyphen_values = true, value_parser = positive)]
    pub rate: f64,
    /// Output file (default: stdout).
    #[arg(long, short)]
    pub out: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Csv)]
    pub format: Format,
    /// Also draw the plan as an SVG figure (path with arrows, wheel rates over time).
    #[arg(long, value_name = "SVG")]
    pub plot: Option<PathBuf>,
    /// caster3: initial steer angles G1,G2,G3, rad (default: aligned with the first motion,
    /// each wheel trailing its steering axis).
    #[arg(long, allow_hyphen_values = true, value_name = "G1,G2,G3")]
    pub initial_steer: Option<Triple>,
}

/// `omnikin plan square`.
#[derive(Args, Debug)]
pub struct SquareArgs {
    /// Side length, m.
    #[arg(long, default_value_t = 0.4, allow_hyphen_values = true, value_parser = positive)]
    pub side: f64,
    /// Cruise speed along each leg, m/s.
    #[arg(long, default_value_t = 0.1, allow_hyphen_values = true, value_parser = positive)]
    pub speed: f64,
    /// Duration of each ramp as a fraction of side/speed (paper: at most 5 %).
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true, value_parser = positive)]
    pub ramp_fraction: f64,
    /// Ramp shape.
    #[arg(long, value_enum, default_value_t = ProfileArg::Trapezoid)]
    pub profile: ProfileArg,
    /// Reject instead of slowing down when a motor limit would be exceeded.
    #[arg(long)]
    pub no_retime: bool,
    #[command(flatten)]
    pub common: Common,
}

/// `omnikin plan circle`.
#[derive(Args, Debug)]
pub struct CircleArgs {
    /// Radius R_t, m.
    #[arg(long, default_value_t = 0.2, allow_hyphen_values = true, value_parser = positive)]
    pub radius: f64,
    /// Angular rate omega_0 about the centre, rad/s (negative: clockwise).
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub omega: f64,
    /// Number of turns.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = positive)]
    pub turns: f64,
    /// Ramp up from rest (and down at the end) over this many seconds instead of starting at
    /// full speed.
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    pub ramp: Option<f64>,
    /// Face the direction of motion (paper 000, eq. 5.5: heading = omega t + pi/2) instead of
    /// eq. 6.3's heading = omega t.
    #[arg(long)]
    pub face_motion: bool,
    #[command(flatten)]
    pub common: Common,
}

/// `omnikin plan waypoints`.
#[derive(Args, Debug)]
pub struct WaypointArgs {
    /// Waypoint file (.csv or .toml).
    pub file: PathBuf,
    /// Path through the waypoints.
    #[arg(long, value_enum, default_value_t = PathArg::Polyline)]
    pub path: PathArg,
    /// Polyline corners.
    #[arg(long, value_enum, default_value_t = CornerArg::Stop)]
    pub corners: CornerArg,
    /// Fillet radius for --corners fillet, m.
    #[arg(long, default_value_t = 0.1, allow_hyphen_values = true, value_parser = positive)]
    pub fillet_radius: f64,
    /// Heading law (default: waypoints if the file has a heading column, else constant).
    #[arg(long, value_enum)]
    pub heading_law: Option<HeadingArg>,
    /// Constant heading, rad (constant law).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub heading: f64,
    /// Spin while translating, rad per metre of path (constant law): heading = H + spin * s.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub spin: f64,
    /// Added to the direction of motion, rad (tangent law).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub heading_offset: f64,
    /// Max speed along the path, m/s.
    #[arg(long, default_value_t = 0.2, allow_hyphen_values = true, value_parser = positive)]
    pub max_speed: f64,
    /// Max acceleration along the path, m/s².
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = positive)]
    pub max_accel: f64,
    /// Max jerk along the path, m/s³ (s-curve profile).
    #[arg(long, default_value_t = 5.0, allow_hyphen_values = true, value_parser = positive, conflicts_with = "time_optimal")]
    pub max_jerk: f64,
    /// Max yaw rate of a turn in place, rad/s.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = positive)]
    pub max_yaw_rate: f64,
    /// Max yaw acceleration of a turn in place, rad/s².
    #[arg(long, default_value_t = 2.0, allow_hyphen_values = true, value_parser = positive)]
    pub max_yaw_accel: f64,
    /// Velocity profile shape.
    #[arg(long, value_enum, default_value_t = ProfileArg::Trapezoid, conflicts_with = "time_optimal")]
    pub profile: ProfileArg,
    /// Fastest timing within all limits (forward-backward pass over the path; no jerk limit).
    #[arg(long)]
    pub time_optimal: bool,
    /// Reject instead of slowing down when a motor limit would be exceeded.
    #[arg(long, conflicts_with = "time_optimal")]
    pub no_retime: bool,
    #[command(flatten)]
    pub common: Common,
}

/// A finite number > 0.
fn positive(s: &str) -> Result<f64, String> {
    let v = finite_f64(s)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("must be > 0, got {v}"))
    }
}

/// A planning error, with "too fast" context only when a motor limit is what failed (a
/// parameter out of range or a plan over a size limit says so by itself).
fn too_fast(e: PlanningError, context: impl FnOnce() -> String) -> anyhow::Error {
    match e {
        PlanningError::LimitExceeded(_) | PlanningError::Infeasible(_) => {
            anyhow::Error::new(e).context(context())
        }
        e => e.into(),
    }
}

fn load_robot(robot: &str) -> Result<(RobotDescription, RobotModel)> {
    let d = RobotDescription::resolve(robot)?;
    let m = RobotModel::from_description(&d)?;
    Ok((d, m))
}

fn initial_steer(c: &Common, robot: &RobotModel) -> Result<InitialSteer> {
    match c.initial_steer {
        Some(g) if !robot.is_caster() => bail!(
            "--initial-steer {:?} applies only to robot kind caster3",
            g.0
        ),
        Some(g) => Ok(InitialSteer::Given(g.0)),
        None => Ok(InitialSteer::Aligned),
    }
}

/// Runs `omnikin plan …`.
pub fn run(a: &PlanArgs) -> Result<()> {
    match &a.kind {
        PlanKind::Square(s) => square(s),
        PlanKind::Circle(c) => circle(c),
        PlanKind::Waypoints(w) => waypoints(w),
    }
    .map_err(name_the_flag)
}

/// A parameter out of its plausible range is named by the library as the API names it
/// (`rate`, `max speed`); on the command line the message starts with the flag that set it
/// (`--rate`, `--max-speed`).
fn name_the_flag(e: anyhow::Error) -> anyhow::Error {
    let flag = match e.downcast_ref::<PlanningError>() {
        Some(PlanningError::OutOfRange { name, .. }) => format!("--{}", name.replace(' ', "-")),
        _ => return e,
    };
    e.context(flag)
}

fn square(a: &SquareArgs) -> Result<()> {
    let (d, robot) = load_robot(&a.common.robot)?;
    let sq = Square {
        side: a.side,
        speed: a.speed,
        ramp_fraction: a.ramp_fraction,
        profile: a.profile.into(),
    };
    let on_limit = if a.no_retime {
        OnLimit::Reject
    } else {
        OnLimit::Retime
    };
    let mut opts = sq.options(a.common.rate, on_limit);
    opts.initial_steer = initial_steer(&a.common, &robot)?;
    let what = format!(
        "square (paper 000, eq. 6.1): side {} m, speed {} m/s, ramps {} % of the leg time ({:.3} s), heading 0",
        a.side,
        a.speed,
        a.ramp_fraction * 100.0,
        sq.ramp_time()
    );
    let planned = plan(&sq.path()?, &sq.heading(), &robot, &opts).map_err(|e| {
        too_fast(e, || {
            format!("square at {} m/s is too fast for {}", a.speed, d.name)
        })
    })?;
    finish(&a.common, &d, &robot, &what, &planned)
}

fn circle(a: &CircleArgs) -> Result<()> {
    let (d, robot) = load_robot(&a.common.robot)?;
    let c = Circle {
        radius: a.radius,
        omega: a.omega,
        turns: a.turns,
        ramp: a.ramp,
        face_motion: a.face_motion,
    };
    let mut opts = c.options(a.common.rate);
    opts.initial_steer = initial_steer(&a.common, &robot)?;
    let what = format!(
        "circle (paper 000, eq. 6.3): radius {} m, omega {} rad/s ({:.3} m/s), {} turn(s), heading = {}, {}",
        a.radius,
        a.omega,
        c.speed(),
        a.turns,
        if a.face_motion {
            "direction of motion (eq. 5.5)"
        } else {
            "omega t"
        },
        match a.ramp {
            Some(r) => format!("ramps of {r} s"),
            None => "full speed from the start (paper's law)".into(),
        }
    );
    let planned = plan(&c.path()?, &c.heading(), &robot, &opts).map_err(|e| {
        too_fast(e, || {
            format!(
                "circle with omega {} rad/s (radius {} m) is too fast for {}",
                a.omega, a.radius, d.name
            )
        })
    })?;
    finish(&a.common, &d, &robot, &what, &planned)
}

fn waypoints(a: &WaypointArgs) -> Result<()> {
    let (d, robot) = load_robot(&a.common.robot)?;
    let file = a.file.display().to_string();
    let wp = Waypoints::load(&a.file)?;
    let path = match (a.path, a.corners) {
        (PathArg::Spline, _) => Path::spline(&wp.points),
        (PathArg::Polyline, CornerArg::Stop) => Path::polyline(&wp.points, Corners::Stop),
        (PathArg::Polyline, CornerArg::Fillet) => Path::polyline(
            &wp.points,
            Corners::Fillet {
                radius: a.fillet_radius,
            },
        ),
    }
    .map_err(|e| wp.locate(&file, e))?;
    let law = a.heading_law.unwrap_or(if wp.headings.is_some() {
        HeadingArg::Waypoints
    } else {
        HeadingArg::Constant
    });
    let (heading, heading_what) = match law {
        HeadingArg::Constant if a.spin == 0.0 => (
            HeadingLaw::Constant(a.heading),
            format!("constant {} rad", a.heading),
        ),
        HeadingArg::Constant => {
            omnikin_plan::limits::check_magnitude(
                "spin",
                a.spin,
                omnikin_plan::limits::MAX_SPIN,
                "rad/m",
            )?;
            let l = path.length();
            let prof = HeadingProfile::new(&[(0.0, a.heading), (l, a.heading + a.spin * l)])?;
            (
                HeadingLaw::Profile(prof),
                format!(
                    "{} rad + {} rad/m along the path (spin while translating)",
                    a.heading, a.spin
                ),
            )
        }
        HeadingArg::Tangent => (
            HeadingLaw::Tangent {
                offset: a.heading_offset,
            },
            format!(
                "direction of motion + {} rad (paper 000, eq. 5.5)",
                a.heading_offset
            ),
        ),
        HeadingArg::Waypoints => {
            let Some(h) = &wp.headings else {
                bail!("{file}: --heading-law waypoints needs a heading column (x,y,heading)");
            };
            let pts: Vec<(f64, f64)> = path
                .waypoint_arc_lengths()
                .iter()
                .copied()
                .zip(h.iter().copied())
                .collect();
            (
                HeadingLaw::Profile(HeadingProfile::new(&pts)?),
                "the file's headings, interpolated along the path".into(),
            )
        }
    };
    let limits = MotionLimits {
        max_speed: a.max_speed,
        max_accel: a.max_accel,
        max_jerk: a.max_jerk,
        max_yaw_rate: a.max_yaw_rate,
        max_yaw_accel: a.max_yaw_accel,
    };
    let timing = if a.time_optimal {
        Timing::TimeOptimal { limits }
    } else {
        Timing::Profile {
            kind: a.profile.into(),
            limits,
        }
    };
    let opts = PlanOptions {
        timing,
        on_limit: if a.no_retime {
            OnLimit::Reject
        } else {
            OnLimit::Retime
        },
        rate: a.common.rate,
        initial_steer: initial_steer(&a.common, &robot)?,
    };
    let what = format!(
        "{} waypoints from {file}: {}, heading {heading_what}, {}",
        wp.points.len(),
        match (a.path, a.corners) {
            (PathArg::Spline, _) => "quintic spline".to_string(),
            (PathArg::Polyline, CornerArg::Stop) => "polyline, stop at corners".into(),
            (PathArg::Polyline, CornerArg::Fillet) =>
                format!("polyline, fillets of {} m", a.fillet_radius),
        },
        if a.time_optimal {
            format!(
                "time-optimal within {} m/s, {} m/s²",
                a.max_speed, a.max_accel
            )
        } else {
            format!(
                "{} profile within {} m/s, {} m/s²{}",
                match a.profile {
                    ProfileArg::Trapezoid => "trapezoidal",
                    ProfileArg::SCurve => "S-curve",
                },
                a.max_speed,
                a.max_accel,
                if a.profile == ProfileArg::SCurve {
                    format!(", {} m/s³", a.max_jerk)
                } else {
                    String::new()
                }
            )
        }
    );
    let planned = plan(&path, &heading, &robot, &opts).map_err(|e| {
        too_fast(e, || {
            format!("{file}: the requested timing is too fast for {}", d.name)
        })
    })?;
    finish(&a.common, &d, &robot, &what, &planned)
}

/// Writes the plan, the figure and the summary.
fn finish(
    c: &Common,
    d: &RobotDescription,
    robot: &RobotModel,
    what: &str,
    planned: &Planned,
) -> Result<()> {
    let plan = &planned.plan;
    match &c.out {
        Some(path) => {
            let mut f = crate::output::OutFile::create("--out", path)?;
            write_plan(plan, c.format, &mut f)
                .with_context(|| format!("--out {}: cannot write", path.display()))?;
            f.commit()?;
        }
        None => {
            write_plan(plan, c.format, crate::output::Stdout)
                .context("cannot write the plan to stdout")?;
        }
    }
    if let Some(svg) = &c.plot {
        let title = format!("{} — {}", d.name, what.split(':').next().unwrap_or(what));
        plan_figure("--plot", svg, &title, plan, robot)?;
    }
    summary(c, d, robot, what, planned);
    Ok(())
}

fn write_plan<W: Write>(plan: &Plan, format: Format, mut out: W) -> Result<()> {
    match format {
        Format::Csv => plan.write_csv(&mut out)?,
        Format::Json => {
            plan.write_json(&mut out)?;
            writeln!(out)?;
        }
    }
    out.flush()?;
    Ok(())
}

fn summary(c: &Common, d: &RobotDescription, robot: &RobotModel, what: &str, planned: &Planned) {
    let r = &planned.report;
    let n = planned.plan.samples.len();
    crate::errln!("plan: {what}");
    crate::errln!("robot: {} ({}, {})", d.name, d.kind(), d.source_name);
    crate::errln!(
        "{n} samples at {} Hz -> {} ({})",
        c.rate,
        c.out
            .as_ref()
            .map_or("stdout".to_string(), |p| p.display().to_string()),
        match c.format {
            Format::Csv => "csv",
            Format::Json => "json",
        }
    );
    let turns = r
        .moves
        .iter()
        .filter(|m| matches!(m.kind, MoveKind::Turn { .. }))
        .count();
    crate::errln!(
        "duration {:.3} s, path length {:.3} m, {} move(s){}",
        r.duration,
        r.path_length,
        r.moves.len(),
        if turns > 0 {
            format!(" incl. {turns} turn(s) in place")
        } else {
            String::new()
        }
    );
    for p in &r.peaks {
        let name = match p.quantity {
            Quantity::WheelRate => "peak wheel rate ",
            Quantity::WheelAccel => "peak wheel accel",
            Quantity::SteerRate => "peak steer rate ",
            Quantity::SteerAccel => "peak steer accel",
        };
        let limit = match p.limit {
            Some(l) => format!(
                "limit {l} {} ({:.1} % of it)",
                p.quantity.unit(),
                100.0 * p.value / l
            ),
            None => "no limit in the robot file".into(),
        };
        if p.value < 1e-9 {
            crate::errln!(
                "{name} {:>9.3} {:<7} (constant), {limit}",
                0.0,
                p.quantity.unit()
            );
            continue;
        }
        crate::errln!(
            "{name} {:>9.3} {:<7} ({} {} at t = {:.2} s), {limit}",
            p.value,
            p.quantity.unit(),
            p.quantity.motor(),
            p.motor,
            p.t
        );
    }
    let motor_active = r
        .active
        .iter()
        .any(|(l, _)| matches!(l, Limiter::Motor { .. }));
    let shares: Vec<String> = r
        .active
        .iter()
        .map(|(l, s)| format!("{l} {:.0} %", 100.0 * s))
        .collect();
    crate::errln!(
        "timing limited by: {}{}",
        shares.join(", "),
        if motor_active {
            ""
        } else {
            " (no motor limit was active)"
        }
    );
    for rt in &r.retimed {
        let m = &r.moves[rt.move_index];
        crate::errln!(
            "re-timed: move {} ({}) slowed to {:.1} % of the requested speed by {}",
            rt.move_index + 1,
            match m.kind {
                MoveKind::Travel { s0, s1 } => format!("s = {s0:.3}..{s1:.3} m"),
                MoveKind::Turn { angle } => format!("turn in place by {angle:.3} rad"),
            },
            100.0 * rt.factor,
            rt.limiter
        );
    }
    if r.starts_moving
        && let Some(s) = planned.plan.samples.first()
    {
        let w = s.wheel_rates;
        crate::errln!(
            "note: the plan starts at full speed (paper 000's law): at t = 0 the wheels must already turn at {:.3}, {:.3}, {:.3} rad/s; use --ramp to start from rest",
            w[0],
            w[1],
            w[2]
        );
    }
    if robot.is_caster()
        && let Some((g, _)) = planned.plan.samples.first().and_then(|s| s.steer)
    {
        crate::errln!(
            "initial steer angles: {:.4}, {:.4}, {:.4} rad{}",
            g[0],
            g[1],
            g[2],
            if c.initial_steer.is_none() {
                " (aligned with the first motion)"
            } else {
                ""
            }
        );
    }
}

/// Draws the plan: the path with direction arrows (left), wheel rates over time (top right),
/// steer rates (caster) or speed and yaw rate (bottom right).
pub fn plan_figure(
    flag: &str,
    svg: &FsPath,
    title: &str,
    plan: &Plan,
    robot: &RobotModel,
) -> Result<()> {
    plot::svg_file(flag, svg, (1300, 640), |root| {
        draw_plan(root, title, plan, robot)
    })
}

fn draw_plan(root: &plot::Area, title: &str, plan: &Plan, robot: &RobotModel) -> Result<()> {
    use plotters::prelude::*;
    root.fill(&WHITE).map_err(plot::draw_err)?;
    let root = root
        .titled(&crate::plot::svg_text(title), ("sans-serif", 22))
        .map_err(plot::draw_err)?;
    let (left, right) = root.split_horizontally(600);
    let (top, bottom) = right.split_vertically(305);
    let s = &plan.samples;
    let xy: Vec<(f64, f64)> = s.iter().map(|p| (p.pose.x, p.pose.y)).collect();
    // Arrows at ~12 evenly spaced points along the path (by arc length), pointing along the
    // velocity there.
    let total = plan.path_length();
    let mut arrows = Vec::new();
    let mut next = total / 24.0;
    let mut acc = 0.0;
    for w in s.windows(2) {
        acc += (w[1].pose.x - w[0].pose.x).hypot(w[1].pose.y - w[0].pose.y);
        if acc >= next && total > 0.0 {
            let v = (w[1].twist.vx, w[1].twist.vy);
            if v.0.hypot(v.1) > 1e-9 {
                arrows.push(Arrow {
                    at: (w[1].pose.x, w[1].pose.y),
                    dir: v,
                    color: PALETTE[3],
                });
            }
            next += total / 12.0;
        }
    }
    plot::xy_panel(
        &left,
        "path (world frame), arrows = direction of motion",
        "x [m]",
        "y [m]",
        &[Series::solid("planned path r_C", xy, PALETTE[0])],
        &[],
        &arrows,
    )?;
    let t: Vec<f64> = s.iter().map(|p| p.t).collect();
    let wheels: Vec<Series> = (0..3)
        .map(|i| {
            Series::solid(
                format!("w{}", i + 1),
                t.iter()
                    .zip(s)
                    .map(|(&t, p)| (t, p.wheel_rates[i]))
                    .collect(),
                PALETTE[i],
            )
        })
        .collect();
    let caster = robot.is_caster();
    plot::time_panel(
        &top,
        if caster { "roll rates" } else { "wheel rates" },
        "rate [rad/s]",
        &wheels,
        &[],
        robot.limits.max_wheel_rate.map(|l| (l, "±max_wheel_rate")),
    )?;
    if caster {
        let steer: Vec<Series> = (0..3)
            .map(|i| {
                Series::solid(
                    format!("sd{}", i + 1),
                    t.iter()
                        .zip(s)
                        .map(|(&t, p)| (t, p.steer.map_or(0.0, |(_, r)| r[i])))
                        .collect(),
                    PALETTE[i + 3],
                )
            })
            .collect();
        plot::time_panel(
            &bottom,
            "steer rates",
            "steer rate [rad/s]",
            &steer,
            &[],
            robot.limits.max_steer_rate.map(|l| (l, "±max_steer_rate")),
        )?;
    } else {
        let speed = Series::solid(
            "speed |v| [m/s]",
            t.iter()
                .zip(s)
                .map(|(&t, p)| (t, p.twist.vx.hypot(p.twist.vy)))
                .collect(),
            PALETTE[4],
        );
        let yaw = Series::solid(
            "yaw rate [rad/s]",
            t.iter()
                .zip(s)
                .map(|(&t, p)| (t, p.twist.yaw_rate))
                .collect(),
            PALETTE[5],
        );
        plot::time_panel(
            &bottom,
            "speed and yaw rate",
            "[m/s], [rad/s]",
            &[speed, yaw],
            &[],
            None,
        )?;
    }
    Ok(())
}
