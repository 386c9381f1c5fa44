//! The command line of `omnikin plan`: its subcommands (square, circle, waypoints, goal), their
//! flags with defaults and value checks, and the options every kind shares ([`Common`]).

use std::path::PathBuf;

use clap::{Args, Subcommand, ValueEnum};
use omnikin_plan::profile::ProfileKind;

use crate::args::{List, finite_f64};

/// `omnikin plan`.
#[derive(Args, Debug)]
pub struct PlanArgs {
    #[command(subcommand)]
    pub kind: PlanKind,
}

/// What to plan.
#[derive(Subcommand, Debug)]
pub enum PlanKind {
    /// The Sphere paper's square (eq. 6.1): legs +y, +x, -y, -x from the origin, heading 0, full stop
    /// at each corner, ramps of --ramp-fraction of the leg time.
    ///
    /// Paper series (side 0.4 m): --speed 0.1, 0.2, 0.4, 0.5 (leg time 4/k s).
    Square(SquareArgs),
    /// The Sphere paper's circle (eq. 6.3): x = R cos(w t), y = R sin(w t), heading = w t.
    ///
    /// Starts at full speed like the paper unless --ramp is given. omega is fixed by the
    /// request: a circle too fast for the robot is rejected with the wheel, rate and excess.
    /// Paper series (radius 0.2 m): --omega 0.5, 1, 2, 2.5.
    Circle(CircleArgs),
    /// A path through waypoints from FILE: CSV `x,y[,heading]` (optional header) or TOML
    /// `[[waypoint]]` tables with x, y[, heading] (m, rad).
    Waypoints(WaypointArgs),
    /// A collision-free path across a map (MAP.toml: keep-out circles and polygons, keep-in
    /// polygon) from --from to --to, timed by the time-optimal planner.
    Goal(GoalArgs),
    /// Identification test plans into --out DIR (straight runs, spins, a figure of eight),
    /// each within half the robot's limits, for `omnikin identify`.
    Sysid(super::sysid::SysidArgs),
}

/// Output format of the plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// `t,x,y,heading,vx,vy,yaw_rate,w1..wN[,s1..sN,sd1..sdN]` (N wheels; steer columns for
    /// robots with steering).
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
    /// Heading = direction of motion + --heading-offset (Sphere paper, eq. 5.5); turns in place
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
    /// Robot: preset name (sphere-omni, ballbot, caster3, kiwi, x-drive, mecanum, swerve4) or
    /// path to a TOML description.
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
    /// Also draw the plan as a figure (path with arrows, wheel rates over time); the
    /// extension chooses the format: .svg, .png or .pdf.
    #[arg(long, value_name = "FILE.svg|png|pdf")]
    pub plot: Option<PathBuf>,
    /// Robots with steering (caster3, swerve): initial steer angles G1,G2,…, rad, one per
    /// wheel (module) in the robot file's order (default: aligned with the first motion — a
    /// caster's wheels trailing their steering axes, a swerve's modules along their velocity).
    #[arg(long, allow_hyphen_values = true, value_name = "G1,G2,...")]
    pub initial_steer: Option<List>,
    /// sphere-omni: slow the moves whose quasi-static platform tilt would exceed DEG degrees
    /// (a uniform time dilation of each such move; see omnikin_plan::tilt).
    #[arg(long, allow_hyphen_values = true, value_name = "DEG", value_parser = finite_f64)]
    pub max_tilt: Option<f64>,
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
    /// Face the direction of motion (Sphere paper, eq. 5.5: heading = omega t + pi/2) instead of
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
    /// Max acceleration along the path, m/s² [default: 0.5, or the robot's body limit if
    /// lower; a value above the robot's limit (`omnikin check`) is refused, a ballbot's is
    /// lowered to its lean limit].
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    pub max_accel: Option<f64>,
    /// Max jerk along the path, m/s³ (s-curve profile).
    #[arg(long, default_value_t = 5.0, allow_hyphen_values = true, value_parser = positive, conflicts_with = "time_optimal")]
    pub max_jerk: f64,
    /// Max yaw rate of a turn in place, rad/s.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = positive)]
    pub max_yaw_rate: f64,
    /// Max yaw acceleration of a turn in place, rad/s² [default: 2, or the robot's body limit
    /// if lower; a value above the robot's limit is refused].
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    pub max_yaw_accel: Option<f64>,
    /// Velocity profile shape.
    #[arg(long, value_enum, default_value_t = ProfileArg::Trapezoid, conflicts_with = "time_optimal")]
    pub profile: ProfileArg,
    /// Fastest timing within all limits (forward-backward pass over the path; no jerk limit).
    #[arg(long)]
    pub time_optimal: bool,
    /// Reject instead of slowing down when a motor limit would be exceeded.
    #[arg(long, conflicts_with = "time_optimal")]
    pub no_retime: bool,
    /// Check the path against this map (MAP.toml): every waypoint and every point of the path
    /// must keep the footprint clear of every shape.
    #[arg(long, value_name = "MAP.toml")]
    pub map: Option<PathBuf>,
    /// With --map: replace each leg that comes too close to a shape by the shortest
    /// collision-free route between its waypoints (then filleted as `plan goal` does).
    #[arg(long, requires = "map")]
    pub repair: bool,
    /// Footprint radius for --map, m [default: the robot file's geometry, see `plan goal`].
    #[arg(long, allow_hyphen_values = true, value_parser = positive, requires = "map")]
    pub footprint_radius: Option<f64>,
    /// Start moving: world-frame velocity VX,VY (m/s) along the path's first tangent, and
    /// optionally the yaw rate W (rad/s), which must be the heading law's at that speed. The
    /// time-optimal timing starts at this speed instead of rest.
    #[arg(
        long,
        allow_hyphen_values = true,
        value_name = "VX,VY[,W]",
        requires = "time_optimal",
        conflicts_with = "max_tilt"
    )]
    pub start_velocity: Option<List>,
    #[command(flatten)]
    pub common: Common,
}

/// `omnikin plan goal`.
#[derive(Args, Debug)]
pub struct GoalArgs {
    /// The map: `[[keep_out]]` tables with circle = [x, y, radius] or polygon = [[x, y], …]
    /// (counter-clockwise), optional `[keep_in] polygon` (world frame, m).
    #[arg(long, value_name = "MAP.toml")]
    pub map: PathBuf,
    /// Start X,Y[,H] (m, m, rad; heading default 0).
    #[arg(long, allow_hyphen_values = true, value_name = "X,Y[,H]")]
    pub from: List,
    /// Goal X,Y[,H] (m, m, rad; heading default the start's): the heading changes linearly
    /// along the path.
    #[arg(long, allow_hyphen_values = true, value_name = "X,Y[,H]")]
    pub to: List,
    /// Footprint radius, m: the robot's centre keeps this far from every shape [default: the
    /// sphere's shell or the ballbot's ball radius; for wheeled bases the outermost wheel's
    /// reach, a lower bound of the chassis].
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    pub footprint_radius: Option<f64>,
    /// Max speed along the path, m/s.
    #[arg(long, default_value_t = 0.2, allow_hyphen_values = true, value_parser = positive)]
    pub max_speed: f64,
    /// Max acceleration along the path, m/s² [default: 0.5, or the robot's body limit if
    /// lower; a value above the robot's limit is refused].
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    pub max_accel: Option<f64>,
    /// Max yaw rate, rad/s.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = positive)]
    pub max_yaw_rate: f64,
    /// Max yaw acceleration, rad/s² [default: 2, or the robot's body limit if lower].
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    pub max_yaw_accel: Option<f64>,
    /// Start moving: world-frame velocity VX,VY (m/s) and optionally the yaw rate W (rad/s).
    /// The path leaves the start along the velocity (a straight lead-in, then the shortest
    /// route), the heading starts turning at W (default: the heading law's own rate), and the
    /// time-optimal timing starts at this speed instead of rest.
    #[arg(
        long,
        allow_hyphen_values = true,
        value_name = "VX,VY[,W]",
        conflicts_with = "max_tilt"
    )]
    pub start_velocity: Option<List>,
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
