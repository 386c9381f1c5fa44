//! `omnikin plan goal`: the shortest collision-free path across a map, timed by the
//! time-optimal planner; and `plan waypoints --map`: the check (and `--repair`) of a given route
//! against a map. The geometry is `omnikin_plan::map`'s; this file reads flags and reports.

use anyhow::{Result, bail};
use omnikin::description::RobotDescription;
use omnikin_plan::map::Map;
use omnikin_plan::map::footprint::{FootprintSource, checked_footprint};
use omnikin_plan::map::route::shortest_route;
use omnikin_plan::map::smooth::smooth;
use omnikin_plan::path::Path;
use omnikin_plan::planner::{OnLimit, PlanOptions, Timing, plan_from_velocity};
use omnikin_plan::splice::goal_request;
use omnikin_plan::waypoints::Waypoints;

use super::args::{GoalArgs, HeadingArg, WaypointArgs};
use super::setup::{finish_leaning, initial_steer, load_robot, motion_limits};
use crate::args::{List, num};

/// The footprint radius: the flag's (checked by the robot file's rule), else the robot's.
fn footprint(given: Option<f64>, d: &RobotDescription) -> Result<(f64, FootprintSource)> {
    Ok(checked_footprint(d, given, "--footprint-radius")?)
}

/// `X,Y[,H]` of `flag` (m, m, rad; heading `None` when not given): `plan goal`'s and `drive
/// goal`'s poses.
pub(crate) fn pose(l: &List, flag: &str) -> Result<([f64; 2], Option<f64>)> {
    match l.0.as_slice() {
        &[x, y] => Ok(([x, y], None)),
        &[x, y, h] => {
            omnikin_plan::limits::check_magnitude(
                "heading",
                h,
                omnikin_plan::limits::MAX_HEADING,
                "rad",
            )
            .map_err(|e| anyhow::anyhow!("{flag}: {e}"))?;
            Ok(([x, y], Some(h)))
        }
        v => bail!(
            "{flag}: expected X,Y or X,Y,H (m, m, rad), got {} values",
            v.len()
        ),
    }
}

/// Runs `omnikin plan goal`.
pub(super) fn goal(a: &GoalArgs) -> Result<()> {
    let (d, robot) = load_robot(&a.common.robot)?;
    let map = Map::load(&a.map)?;
    let (from, h0) = pose(&a.from, "--from")?;
    let (to, h1) = pose(&a.to, "--to")?;
    let (f, source) = footprint(a.footprint_radius, &d)?;
    let limits = motion_limits(
        &d,
        a.max_speed,
        a.max_accel,
        omnikin_plan::planner::MotionLimits::default().max_jerk,
        a.max_yaw_rate,
        a.max_yaw_accel,
    )?;
    let start = super::setup::start_velocity(a.start_velocity.as_ref())?;
    let speed = start.speed();
    // Moving: a lead-in along the velocity, then the route; at rest the route from the start.
    let (way, lead_in, heading) = goal_request(
        &map,
        f,
        from,
        to,
        [h0, h1],
        &start,
        limits.max_accel,
        &robot,
    )?;
    let path = &way.smoothed.path;
    let mut opts = PlanOptions {
        timing: Timing::TimeOptimal { limits },
        on_limit: OnLimit::Retime,
        rate: a.common.rate,
        initial_steer: initial_steer(&a.common, &robot)?,
    };
    let what = format!(
        "goal across {}: ({}, {}) to ({}, {}), footprint radius {} m ({}); shortest route {:.4} m \
         with {} corners, path {:.4} m ({}), closest approach {:.4} m from a shape; \
         time-optimal within {} m/s, {} m/s²",
        map.source_name,
        num(from[0]),
        num(from[1]),
        num(to[0]),
        num(to[1]),
        num(f),
        source.describe(),
        way.route.length,
        way.route.points.len().saturating_sub(2),
        path.length(),
        match way.smoothed.fillet_radius {
            Some(r) => format!("fillets of {r:.4} m"),
            None => "stops at the corners".into(),
        },
        way.smoothed.min_clearance,
        a.max_speed,
        limits.max_accel
    );
    let what = if speed > 0.0 {
        format!(
            "{what}; from ({}, {}) m/s, a lead-in of {lead_in:.4} m along it",
            num(start.vx),
            num(start.vy)
        )
    } else {
        what
    };
    let lean = omnikin_plan::lean::apply(&d, &mut opts);
    let planned = plan_from_velocity(path, &heading, &robot, &opts, start)?;
    finish_leaning(
        &a.common,
        &d,
        &robot,
        &what,
        &planned,
        lean,
        Some(&map),
        speed > 0.0,
    )
}

/// `plan waypoints --map`: `Ok((path, map, repair))` when the path keeps the footprint clear of every
/// shape (with `--repair`, after replacing the route by shortest routes between the
/// waypoints, `repair` describing the new path); an error naming the first waypoint or point of the path that does not, and the
/// shape's line, otherwise.
pub(super) fn check_waypoints(
    a: &WaypointArgs,
    d: &RobotDescription,
    wp: &Waypoints,
    path: Path,
) -> Result<(Path, Option<Map>, Option<String>)> {
    let Some(map_file) = &a.map else {
        return Ok((path, None, None));
    };
    let map = Map::load(map_file)?;
    let (f, _) = footprint(a.footprint_radius, d)?;
    for (i, p) in wp.points.iter().enumerate() {
        map.check_point(*p, f, &format!("waypoint {} (line {})", i + 1, wp.lines[i]))?;
    }
    let step = f / 50.0;
    let l = path.length();
    let n = (l / step).ceil().max(1.0) as usize;
    let first_clash = (0..=n).map(|k| l * k as f64 / n as f64).find(|&s| {
        map.clearance(path.at(s).point) < f * (1.0 - omnikin_plan::map::route::CLEAR_TOLERANCE)
    });
    let Some(s) = first_clash else {
        return Ok((path, Some(map), None));
    };
    if !a.repair {
        let p = path.at(s).point;
        let e = map
            .check_point(p, f, &format!("the path at s = {s:.4} m"))
            .expect_err("the clearance there is below the footprint");
        bail!(
            "{e}; --repair replaces the legs that come too close by the shortest routes around the shapes"
        );
    }
    if wp.headings.is_some() || a.heading_law == Some(HeadingArg::Waypoints) {
        bail!(
            "--repair changes the route's corners, so the waypoints' headings have no place on it; \
             use --heading-law constant or tangent"
        );
    }
    let mut points = vec![wp.points[0]];
    for w in wp.points.windows(2) {
        let r = shortest_route(&map, f, w[0], w[1])?;
        points.extend_from_slice(&r.points[1..]);
    }
    let length = points
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    let route = omnikin_plan::map::route::Route { points, length };
    let smoothed = smooth(&map, &route, f)?;
    crate::errln!(
        "repaired: the path came within {:.4} m of a shape at s = {s:.4} m (footprint {f} m); \
         now {} corners, {:.4} m, closest approach {:.4} m",
        map.clearance(path.at(s).point),
        route.points.len().saturating_sub(2),
        smoothed.path.length(),
        smoothed.min_clearance
    );
    let repair = format!(
        "repaired around {}: shortest routes between the waypoints, {}",
        map.source_name,
        match smoothed.fillet_radius {
            Some(r) => format!("fillets of {r:.4} m"),
            None => "stop at corners".into(),
        }
    );
    Ok((smoothed.path, Some(map), Some(repair)))
}
