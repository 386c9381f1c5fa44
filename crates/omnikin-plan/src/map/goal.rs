//! From a start to a goal on a map: the shortest route ([`super::route`]) smoothed into a path
//! the planner times ([`super::smooth`]), with the heading law a goal request implies.

use super::route::{Route, shortest_route};
use super::smooth::{Smoothed, smooth};
use super::{Map, MapError};
use crate::heading::{HeadingLaw, HeadingProfile};

/// A planned way to a goal: the route and the path made of it.
#[derive(Clone, Debug)]
pub struct GoalPath {
    /// The shortest collision-free polyline.
    pub route: Route,
    /// The path the planner times, and how its corners were rounded.
    pub smoothed: Smoothed,
}

/// The path from `from` to `to` (world frame, m) for a footprint of radius `f` (m).
///
/// # Errors
/// [`MapError`] as [`shortest_route`] (start or goal in or near an obstacle, outside the
/// keep-in polygon, no path), or when the route cannot be made into a path.
pub fn goal_path(map: &Map, f: f64, from: [f64; 2], to: [f64; 2]) -> Result<GoalPath, MapError> {
    let route = shortest_route(map, f, from, to)?;
    let smoothed = smooth(map, &route, f).map_err(|e| {
        MapError::at(
            &map.source_name,
            None,
            format!("the route cannot be smoothed: {e}"),
        )
    })?;
    Ok(GoalPath { route, smoothed })
}

/// The heading law of a goal request: from `from` (rad, default 0) to `to` (default the
/// start's), changing linearly with the arc length over a path of `length` m; constant when
/// both are the same. Headings are used as given (no wrapping: `to = 2π` from 0 is a full
/// turn).
///
/// # Errors
/// [`crate::PlanningError`] for a non-finite heading.
pub fn goal_heading(
    from: Option<f64>,
    to: Option<f64>,
    length: f64,
) -> Result<HeadingLaw, crate::PlanningError> {
    let h0 = from.unwrap_or(0.0);
    let h1 = to.unwrap_or(h0);
    if h0 == h1 {
        return Ok(HeadingLaw::Constant(h0));
    }
    Ok(HeadingLaw::Profile(HeadingProfile::new(&[
        (0.0, h0),
        (length, h1),
    ])?))
}
