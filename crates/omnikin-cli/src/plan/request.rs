//! Each kind of `omnikin plan` turned into a path, a heading law and planner options from its
//! flags, described in one line for the summary, and planned for the robot; a failure says
//! which request was too fast for which robot.

use anyhow::{Result, bail};
use omnikin::description::RobotDescription;
use omnikin_plan::generators::{Circle, Square};
use omnikin_plan::heading::{HeadingLaw, HeadingProfile};
use omnikin_plan::path::{Corners, Path};
use omnikin_plan::planner::{InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing, plan};
use omnikin_plan::waypoints::Waypoints;
use omnikin_plan::{PlanningError, RobotModel};

use super::args::{
    CircleArgs, Common, CornerArg, HeadingArg, PathArg, ProfileArg, SquareArgs, WaypointArgs,
};
use super::write::finish;

pub(super) fn square(a: &SquareArgs) -> Result<()> {
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
    let lean = super::lean::apply(&d, &mut opts);
    let what = format!(
        "square (Sphere paper, eq. 6.1): side {} m, speed {} m/s, ramps {} % of the leg time ({:.3} s), heading 0",
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
    finish_leaning(&a.common, &d, &robot, &what, &planned, lean, None)
}

pub(super) fn circle(a: &CircleArgs) -> Result<()> {
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
    let lean = super::lean::apply(&d, &mut opts);
    let what = format!(
        "circle (Sphere paper, eq. 6.3): radius {} m, omega {} rad/s ({:.3} m/s), {} turn(s), heading = {}, {}",
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
    finish_leaning(&a.common, &d, &robot, &what, &planned, lean, None)
}

pub(super) fn waypoints(a: &WaypointArgs) -> Result<()> {
    let (d, robot) = load_robot(&a.common.robot)?;
    let file = a.file.display().to_string();
    let wp = Waypoints::load(&a.file)?;
    heading_unit_warning(&wp, &file);
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
    let (path, map, repair) = super::goal::check_waypoints(a, &d, &wp, path)?;
    let (heading, heading_what) = waypoint_heading(a, &wp, &path, &file)?;
    let limits = motion_limits(
        &d,
        a.max_speed,
        a.max_accel,
        a.max_jerk,
        a.max_yaw_rate,
        a.max_yaw_accel,
    )?;
    let max_accel = limits.max_accel;
    let timing = if a.time_optimal {
        Timing::TimeOptimal { limits }
    } else {
        Timing::Profile {
            kind: a.profile.into(),
            limits,
        }
    };
    let mut opts = PlanOptions {
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
        repair.unwrap_or_else(|| match (a.path, a.corners) {
            (PathArg::Spline, _) => "quintic spline".to_string(),
            (PathArg::Polyline, CornerArg::Stop) => "polyline, stop at corners".into(),
            (PathArg::Polyline, CornerArg::Fillet) =>
                format!("polyline, fillets of {} m", a.fillet_radius),
        }),
        if a.time_optimal {
            format!(
                "time-optimal within {} m/s, {} m/s²",
                a.max_speed, max_accel
            )
        } else {
            format!(
                "{} profile within {} m/s, {} m/s²{}",
                match a.profile {
                    ProfileArg::Trapezoid => "trapezoidal",
                    ProfileArg::SCurve => "S-curve",
                },
                a.max_speed,
                max_accel,
                if a.profile == ProfileArg::SCurve {
                    format!(", {} m/s³", a.max_jerk)
                } else {
                    String::new()
                }
            )
        }
    );
    let lean = super::lean::apply(&d, &mut opts);
    let planned = plan(&path, &heading, &robot, &opts).map_err(|e| {
        too_fast(e, || {
            format!("{file}: the requested timing is too fast for {}", d.name)
        })
    })?;
    finish_leaning(&a.common, &d, &robot, &what, &planned, lean, map.as_ref())
}

/// The motion limits of a request: `--max-accel` and `--max-yaw-accel` bounded by the robot's
/// body limits (their defaults lowered to them; a larger value given is refused, a ballbot's
/// acceleration is left to its lean limit).
pub(super) fn motion_limits(
    d: &RobotDescription,
    max_speed: f64,
    max_accel_arg: Option<f64>,
    max_jerk: f64,
    max_yaw_rate: f64,
    max_yaw_accel_arg: Option<f64>,
) -> Result<MotionLimits> {
    // The robot's body limits bound the request (a ballbot's acceleration is lowered to its
    // lean limit below instead, with a note).
    let body = d.body_limits();
    let flag = crate::body_limits::flag;
    let max_accel = match (max_accel_arg, d.lean_acceleration_limit()) {
        (Some(v), Some(_)) => v,
        (given, _) => flag(
            "--max-accel",
            given,
            body.max_accel,
            body.max_accel_source,
            "max_accel",
            "m/s²",
            d,
        )
        .map(|v| {
            if given.is_some() {
                v
            } else {
                v.min(DEFAULT_MAX_ACCEL)
            }
        })?,
    };
    let max_yaw_accel = flag(
        "--max-yaw-accel",
        max_yaw_accel_arg,
        body.max_yaw_accel,
        body.max_yaw_accel_source,
        "max_yaw_accel",
        "rad/s²",
        d,
    )
    .map(|v| {
        if max_yaw_accel_arg.is_some() {
            v
        } else {
            v.min(DEFAULT_MAX_YAW_ACCEL)
        }
    })?;
    Ok(MotionLimits {
        max_speed,
        max_accel,
        max_jerk,
        max_yaw_rate,
        max_yaw_accel,
    })
}

/// A waypoint heading beyond ±2π is valid (the planner turns that far) but is far more often
/// degrees typed where radians are read: said once, for the first such waypoint.
fn heading_unit_warning(wp: &Waypoints, file: &str) {
    let Some(h) = &wp.headings else { return };
    if let Some((i, v)) = h
        .iter()
        .enumerate()
        .find(|(_, v)| v.abs() > std::f64::consts::TAU)
    {
        crate::errln!(
            "warning: {file}:{}: heading {v} is read in radians ({:.1}°, {:.1} turns); headings are radians: if {v}° was meant, write {:.4}",
            wp.lines[i],
            v.to_degrees(),
            v / std::f64::consts::TAU,
            v.to_radians()
        );
    }
}

/// The heading law of `omnikin plan waypoints` and its description: `--heading-law` (by
/// default the file's headings when it has them, else constant), with the constant law's
/// `--spin` as a linear heading profile along the path.
fn waypoint_heading(
    a: &WaypointArgs,
    wp: &Waypoints,
    path: &Path,
    file: &str,
) -> Result<(HeadingLaw, String)> {
    let law = a.heading_law.unwrap_or(if wp.headings.is_some() {
        HeadingArg::Waypoints
    } else {
        HeadingArg::Constant
    });
    Ok(match law {
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
                "direction of motion + {} rad (Sphere paper, eq. 5.5)",
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
    })
}

/// [`finish`], then a ballbot's lean-limit line.
pub(super) fn finish_leaning(
    c: &Common,
    d: &RobotDescription,
    robot: &RobotModel,
    what: &str,
    planned: &omnikin_plan::planner::Planned,
    lean: Option<super::lean::LeanLimit>,
    map: Option<&omnikin_plan::map::Map>,
) -> Result<()> {
    finish(c, d, robot, what, planned, map)?;
    if let Some(l) = &lean {
        super::lean::report(l, &planned.plan);
    }
    // What `omnikin robot` slews at: a plan asking for more is tracked with a lag (a
    // ballbot's acceleration is the lean limit's, reported above).
    let mut body = d.body_limits();
    if lean.is_some() {
        body.max_accel = f64::INFINITY;
    }
    let peaks = crate::body_limits::peaks(&planned.plan);
    for e in crate::body_limits::plan_excess(&body, &peaks) {
        crate::errln!(
            "warning: {e}: `omnikin robot` holds the robot to that limit, so it will lag behind this plan"
        );
    }
    Ok(())
}

/// `plan waypoints --max-accel` when not given (or the robot's body limit if lower), m/s².
const DEFAULT_MAX_ACCEL: f64 = 0.5;
/// `plan waypoints --max-yaw-accel` when not given (or the robot's limit if lower), rad/s².
const DEFAULT_MAX_YAW_ACCEL: f64 = 2.0;

pub(super) fn load_robot(robot: &str) -> Result<(RobotDescription, RobotModel)> {
    let d = crate::kinematics::resolve_robot(robot)?;
    let m = RobotModel::from_description(&d)?;
    Ok((d, m))
}

pub(super) fn initial_steer(c: &Common, robot: &RobotModel) -> Result<InitialSteer> {
    match &c.initial_steer {
        Some(g) if !robot.steerable() => bail!(
            "--initial-steer {:?} applies only to robot kinds with steering (caster3, swerve), not {}",
            g.0,
            robot.model.kind().name()
        ),
        Some(g) => {
            let g = g.exactly(robot.wheels(), "--initial-steer", &robot.name)?;
            Ok(InitialSteer::Given(omnikin_plan::per_wheel(g)))
        }
        None => Ok(InitialSteer::Aligned),
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
