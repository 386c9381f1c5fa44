//! `omnikin.plan(robot, "goal", map=…, start=…, goal=…)`: `omnikin plan goal`'s request (the
//! shortest collision-free route across a map, filleted, time-optimal) with the same options.

use omnikin_plan::RobotModel;
use omnikin_plan::map::Map;
use omnikin_plan::map::footprint::checked_footprint;
use omnikin_plan::planner::{MotionLimits, OnLimit, PlanOptions, StartVelocity, Timing};
use omnikin_plan::splice::goal_request;
use pyo3::prelude::*;

use crate::arrays::value_error;
use crate::options::Options;
use crate::plan_request::{Request, initial_steer};
use crate::robot::PyRobot;

/// `X, Y[, H]` of option `name` (required).
fn pose(o: &mut Options, name: &'static str) -> PyResult<([f64; 2], Option<f64>)> {
    match o.list(name)?.as_deref() {
        Some(&[x, y]) => Ok(([x, y], None)),
        Some(&[x, y, h]) => Ok(([x, y], Some(h))),
        Some(v) => Err(value_error(format!(
            "{name}: expected [x, y] or [x, y, heading] (m, m, rad), got {} values",
            v.len()
        ))),
        None => Err(value_error(format!(
            "goal needs {name} = [x, y] or [x, y, heading] (m, m, rad, world frame)"
        ))),
    }
}

/// The goal request: map file, start and goal poses, footprint radius (default the robot
/// file's `footprint_radius`, else from its geometry, as the CLI), the motion limits and the
/// rate.
/// With a `start` velocity the path leaves the start along it and the heading starts at its
/// yaw rate, as `plan goal --start-velocity`.
pub(crate) fn goal(
    o: &mut Options,
    d: &PyRobot,
    robot: &RobotModel,
    start: StartVelocity,
) -> PyResult<Request> {
    let Some(file) = o.opt_str("map")? else {
        return Err(value_error(
            "goal needs map (a MAP.toml path: [[keep_out]] circle/polygon tables, optional \
             [keep_in] polygon)",
        ));
    };
    let map = Map::load(std::path::Path::new(&file)).map_err(|e| value_error(e.to_string()))?;
    let (from, h0) = pose(o, "start")?;
    let (to, h1) = pose(o, "goal")?;
    let f = checked_footprint(
        &d.desc,
        o.opt_positive("footprint_radius")?,
        "footprint_radius",
    )
    .map_err(|e| value_error(e.to_string()))?
    .0;
    let limits = MotionLimits {
        max_speed: o.positive("max_speed", 0.2)?,
        max_accel: o.positive("max_accel", 0.5)?,
        max_yaw_rate: o.positive("max_yaw_rate", 1.0)?,
        max_yaw_accel: o.positive("max_yaw_accel", 2.0)?,
        ..MotionLimits::default()
    };
    let (way, _, heading) =
        goal_request(&map, f, from, to, [h0, h1], &start, limits.max_accel, robot)
            .map_err(|e| value_error(e.to_string()))?;
    let path = way.smoothed.path;
    let opts = PlanOptions {
        timing: Timing::TimeOptimal { limits },
        on_limit: OnLimit::Retime,
        rate: o.positive("rate", 100.0)?,
        initial_steer: initial_steer(o, robot)?,
    };
    let ctx = format!("{file}: the goal's timing is too fast for {}", d.desc.name);
    Ok((path, heading, opts, ctx))
}
