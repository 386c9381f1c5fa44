//! `omnikin plan`: the Sphere paper's square and circle, or a path through waypoints, planned within
//! the robot file's motor limits and written as a plan CSV/JSON (conventions.md columns), with
//! an optional SVG figure and a human summary on stderr.
//!
//! `args` holds the command line, `goal` plans across a map and checks a route against one, `request` turns each kind into a planner call, `write`
//! writes the plan and the summary, `figure` draws the `--plot` SVG, `tilt` reports a sphere's
//! platform tilt and applies `--max-tilt`, `lean` limits a ballbot's acceleration to its lean
//! limit.

mod args;
pub(crate) mod goal;
mod request;
pub(crate) mod setup;
pub mod sysid;
mod tilt;
mod write;

pub use args::{PlanArgs, PlanKind};

use anyhow::Result;
use omnikin_plan::PlanningError;

use request::{circle, square, waypoints};

/// Runs `omnikin plan …`.
pub fn run(a: &PlanArgs) -> Result<()> {
    match &a.kind {
        PlanKind::Square(s) => square(s),
        PlanKind::Circle(c) => circle(c),
        PlanKind::Waypoints(w) => waypoints(w),
        PlanKind::Goal(g) => goal::goal(g),
        PlanKind::Sysid(s) => sysid::run(s),
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
