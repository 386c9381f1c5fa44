//! What every `omnikin plan` request starts and ends with, shared by the path requests
//! (`request.rs`) and `plan goal` (`goal.rs`): the robot, the motion limits its body limits
//! allow, the initial steer, and the summary with a ballbot's lean limit.

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin_plan::RobotModel;
use omnikin_plan::planner::{InitialSteer, MotionLimits};

use super::args::Common;
use super::write::finish;

/// The motion limits of a request: `--max-accel` and `--max-yaw-accel` bounded by the robot's
/// body limits (their defaults lowered to them; a larger value given is refused, a ballbot's
/// acceleration is left to its lean limit).
pub(crate) fn motion_limits(
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

/// [`finish`](super::write::finish), then a ballbot's lean-limit line. `start_velocity`: the
/// plan starts moving because `--start-velocity` asked it to.
#[allow(clippy::too_many_arguments)]
pub(super) fn finish_leaning(
    c: &Common,
    d: &RobotDescription,
    robot: &RobotModel,
    what: &str,
    planned: &omnikin_plan::planner::Planned,
    lean: Option<omnikin_plan::lean::LeanLimit>,
    map: Option<&omnikin_plan::map::Map>,
    start_velocity: bool,
) -> Result<()> {
    finish(c, d, robot, what, planned, map, start_velocity)?;
    if let Some(l) = &lean {
        let r = l.report(&planned.plan);
        crate::errln!("{}", r.line);
        if let Some(w) = r.warning {
            crate::errln!("warning: {w}");
        }
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

/// `--start-velocity VX,VY[,W]` (world frame, m/s, m/s, rad/s; conventions.md): at rest when
/// not given.
pub(super) fn start_velocity(
    l: Option<&crate::args::List>,
) -> Result<omnikin_plan::planner::StartVelocity> {
    use omnikin_plan::planner::StartVelocity;
    match l {
        None => Ok(StartVelocity::REST),
        Some(l) => StartVelocity::from_components(&l.0).with_context(|| {
            format!(
                "--start-velocity: expected VX,VY or VX,VY,W (m/s, m/s, rad/s; world frame), got {} values",
                l.0.len()
            )
        }),
    }
}
