//! What every `omnikin.plan` request is built from, shared by [`crate::plan`] (square, circle,
//! waypoints) and [`crate::plan_goal`] (goal): the request's parts and the `initial_steer`
//! option.

use omnikin_plan::RobotModel;
use omnikin_plan::heading::HeadingLaw;
use omnikin_plan::path::Path;
use omnikin_plan::planner::{InitialSteer, PlanOptions};
use pyo3::prelude::*;

use crate::arrays::value_error;
use crate::options::Options;

/// The path, heading law and options of a request, and the context of a "too fast" error.
pub(crate) type Request = (Path, HeadingLaw, PlanOptions, String);

/// The `initial_steer` option (steerable kinds only, one angle per wheel, rad).
pub(crate) fn initial_steer(o: &mut Options, robot: &RobotModel) -> PyResult<InitialSteer> {
    match o.list("initial_steer")? {
        Some(g) if !robot.steerable() => Err(value_error(format!(
            "initial_steer {g:?} applies only to robot kinds with steering (caster3, swerve), not {}",
            robot.model.kind().name()
        ))),
        Some(g) if g.len() != robot.wheels() => Err(value_error(format!(
            "initial_steer: {} has {} wheels, got {} values",
            robot.name,
            robot.wheels(),
            g.len()
        ))),
        Some(g) => Ok(InitialSteer::Given(omnikin_plan::per_wheel(&g))),
        None => Ok(InitialSteer::Aligned),
    }
}
