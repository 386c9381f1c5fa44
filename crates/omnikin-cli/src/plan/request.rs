//! Each kind of `omnikin plan` turned into a path, a heading law and planner options from its
//! flags, described in one line for the summary, and planned for the robot; a failure says
//! which request was too fast for which robot.

use anyhow::{Result, bail};
use omnikin_plan::PlanningError;
use omnikin_plan::generators::{Circle, Square};
use omnikin_plan::heading::{HeadingLaw, HeadingProfile};
use omnikin_plan::path::{Corners, Path};
use omnikin_plan::planner::{
    OnLimit, PlanOptions, StartVelocity, Timing, plan, plan_from_velocity,
};
use omnikin_plan::waypoints::Waypoints;

use super::args::{
    CircleArgs, CornerArg, HeadingArg, PathArg, ProfileArg, SquareArgs, WaypointArgs,
};
use super::setup::{finish_leaning, initial_steer, load_robot, motion_limits};

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
    let lean = omnikin_plan::lean::apply(&d, &mut opts);
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
    finish_leaning(&a.common, &d, &robot, &what, &planned, lean, None, false)
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
    let lean = omnikin_plan::lean::apply(&d, &mut opts);
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
    finish_leaning(&a.common, &d, &robot, &what, &planned, lean, None, false)
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
    let start = super::setup::start_velocity(a.start_velocity.as_ref())?;
    let what = if start == StartVelocity::REST {
        what
    } else {
        format!(
            "{what}, from ({}, {}) m/s",
            crate::args::num(start.vx),
            crate::args::num(start.vy)
        )
    };
    let lean = omnikin_plan::lean::apply(&d, &mut opts);
    let planned = plan_from_velocity(&path, &heading, &robot, &opts, start).map_err(|e| {
        too_fast(e, || {
            if start == StartVelocity::REST {
                format!("{file}: the requested timing is too fast for {}", d.name)
            } else {
                format!(
                    "{file}: {} cannot start this plan at --start-velocity {},{}",
                    d.name,
                    crate::args::num(start.vx),
                    crate::args::num(start.vy)
                )
            }
        })
    })?;
    finish_leaning(
        &a.common,
        &d,
        &robot,
        &what,
        &planned,
        lean,
        map.as_ref(),
        start != StartVelocity::REST,
    )
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
