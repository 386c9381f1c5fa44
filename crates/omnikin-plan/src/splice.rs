//! Re-planning on the move: a plan that replaces a running one from a splice time `t_s`
//! without stopping ([`omnikin::runtime::Command::PlanSplice`]).
//!
//! The robot accepts a splice whose first point is its own reference at `t_s` — position,
//! heading, world velocity and yaw rate within 1e-3 — which it computes from the points it
//! holds ([`omnikin::runtime::plan_reference`]). [`splice_to_goal`] starts exactly there:
//!
//! 1. **The start**: `(x, y, ψ, vx, vy, ψ̇) = plan_reference(points, t_s)`, on the same points
//!    the robot follows (the uploaded, decimated ones).
//! 2. **The path** leaves the start along the velocity `û = v/|v|`: a straight lead-in to
//!    `q = p + d û` with `d = 1.25 v²/(2 a)` (`a` the requested acceleration: a little more than
//!    the braking distance), halved while the lead-in is not clear of the map for the
//!    footprint, then the shortest collision-free route from `q` to the goal
//!    ([`super::map::route::shortest_route`]), the whole polyline rounded by
//!    [`super::map::smooth::smooth`] (fillets, or stops where no fillet is clear). Its first
//!    tangent is `û`. A robot whose moves stop where a fillet meets a straight (set-point
//!    steering, a swerve: its steer rates follow the curvature) must brake on the straight
//!    before the first fillet, which the fillet at `q` shortens: for it the lead-in is
//!    lengthened (while it stays clear, at most four times) until that straight is `d`.
//! 3. **The heading** starts at `ψ` with `dψ/ds = ψ̇/|v|` (so `ψ̇ = ψ'(s) ṡ` matches): constant when
//!    both `ψ̇` and the turn to the goal's heading are zero, otherwise a natural cubic spline
//!    through `(0, ψ)`, `(L/2, ψ_m)`, `(L, ψ_goal)` whose middle value `ψ_m` is solved for the
//!    start slope (the slope is linear in it). The goal's heading is reached the shorter way
//!    round (`ψ + wrap(ψ_goal − ψ)`); without one the heading at `t_s` is kept.
//! 4. **The timing**: the time-optimal planner from the moving start
//!    ([`crate::planner::plan_from_velocity`]), its samples' times moved by `t_s` onto the
//!    running plan's clock.
//!
//! From a reference at rest (`|v|` and `|ψ̇|` within [`START_TOLERANCE`]) the path is the plain
//! route from the start, planned from rest.

use omnikin::runtime::{PlanPoint, plan_reference};
use omnikin::wrap_angle;

use crate::PlanningError;
use crate::heading::{HeadingLaw, HeadingProfile, Side};
use crate::map::Map;
use crate::map::goal::GoalPath;
use crate::map::route::{Route, segment_clear, shortest_route};
use crate::map::smooth::{Smoothed, smooth};
use crate::planner::{
    PlanOptions, Planned, START_TOLERANCE, StartVelocity, Timing, plan_from_velocity,
};
use crate::robot::RobotModel;

/// The running plan's reference at the splice time: where the replacement starts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpliceStart {
    /// The splice time on the running plan's clock, s.
    pub t: f64,
    /// Position, world frame, m.
    pub position: [f64; 2],
    /// Heading, rad (unwrapped, as the plan's).
    pub heading: f64,
    /// World-frame velocity, m/s.
    pub velocity: [f64; 2],
    /// Yaw rate, rad/s.
    pub yaw_rate: f64,
}

/// The reference of the running plan `points` at `t_s` (s), as the robot computes it
/// ([`plan_reference`]).
///
/// # Errors
/// [`PlanningError::Infeasible`] when `points` is empty or `t_s` is not strictly inside the
/// plan (a splice must take over a running plan, `SpliceOutside` on the robot), or not finite.
pub fn splice_start(points: &[PlanPoint<f64>], t_s: f64) -> Result<SpliceStart, PlanningError> {
    let (Some(first), Some(last)) = (points.first(), points.last()) else {
        return Err(PlanningError::Infeasible(
            "the running plan has no points".into(),
        ));
    };
    if !(t_s > first.t && t_s < last.t) {
        return Err(PlanningError::Infeasible(format!(
            "splice time {t_s} s is not inside the running plan ({} s to {} s)",
            first.t, last.t
        )));
    }
    let (pose, twist) = plan_reference(points, t_s).expect("a plan with points");
    Ok(SpliceStart {
        t: t_s,
        position: [pose.x, pose.y],
        heading: pose.heading,
        velocity: [twist.vx, twist.vy],
        yaw_rate: twist.yaw_rate,
    })
}

/// A replacement plan and how it was made.
#[derive(Clone, Debug)]
pub struct Spliced {
    /// Where it starts (the running plan's reference at the splice time, or the position the
    /// robot was predicted at: [`splice_from`]).
    pub start: SpliceStart,
    /// The path (lead-in, route and fillets) and its clearance.
    pub smoothed: Smoothed,
    /// The lead-in's length `d`, m (0 from rest).
    pub lead_in: f64,
    /// The heading law along the path.
    pub heading: HeadingLaw,
    /// The plan; sample times on the running plan's clock (the first at `start.t`).
    pub planned: Planned,
}

/// The lead-in is this many braking distances `v²/(2a)` long (room for the motor limits,
/// which may brake less hard than the requested acceleration, when its end is a stop).
const LEAD_IN_FACTOR: f64 = 1.25;

/// Shortest lead-in tried before giving up on a start whose motion heads into a shape, m.
const MIN_LEAD_IN: f64 = 1e-3;

/// Plans from the running plan `points`' reference at `t_s` (s) to the goal `to` (world
/// frame, m) with the goal heading `heading` (rad; `None`: keep the start's), around the shapes
/// of `map` for a footprint of radius `f` (m; an empty map for open ground), timed
/// time-optimally by `opts` (its timing must be [`Timing::TimeOptimal`]). See the module docs.
/// The first sample is the start: position and heading exactly, velocity and yaw rate within
/// [`START_TOLERANCE`].
///
/// # Errors
/// As [`splice_start`] and [`moving_goal_path`] (a lead-in not clear of the map, no route);
/// [`PlanningError::Infeasible`] for the start speed (above a limit, or too fast to end the first
/// move at rest: [`plan_from_velocity`]); any error of the planner.
#[allow(clippy::too_many_arguments)]
pub fn splice_to_goal(
    points: &[PlanPoint<f64>],
    t_s: f64,
    to: [f64; 2],
    heading: Option<f64>,
    map: &Map,
    f: f64,
    robot: &RobotModel,
    opts: &PlanOptions,
) -> Result<Spliced, PlanningError> {
    splice_from(splice_start(points, t_s)?, to, heading, map, f, robot, opts)
}

/// [`splice_to_goal`] from a given start: the running plan's reference ([`splice_start`]) or,
/// for a re-plan after a drift, that reference moved to where the robot is predicted to be at
/// `start.t` (position only; heading, velocity and yaw rate the reference's, which the robot
/// checks: [`omnikin::runtime::Command::PlanSpliceRebased`]). Steps 2–4 of the module docs.
///
/// # Errors
/// As [`splice_to_goal`], without [`splice_start`]'s: a non-finite start is refused.
pub fn splice_from(
    start: SpliceStart,
    to: [f64; 2],
    heading: Option<f64>,
    map: &Map,
    f: f64,
    robot: &RobotModel,
    opts: &PlanOptions,
) -> Result<Spliced, PlanningError> {
    let t_s = start.t;
    let finite = [
        start.t,
        start.position[0],
        start.position[1],
        start.heading,
        start.velocity[0],
        start.velocity[1],
        start.yaw_rate,
    ];
    if finite.iter().any(|v| !v.is_finite()) {
        return Err(PlanningError::Infeasible(format!(
            "the splice's start {start:?} is not finite"
        )));
    }
    let Timing::TimeOptimal { limits } = opts.timing else {
        return Err(PlanningError::Infeasible(
            "a splice needs the time-optimal timing (it starts at the running plan's speed)".into(),
        ));
    };
    let [vx, vy] = start.velocity;
    let speed = vx.hypot(vy);
    let moving = speed > START_TOLERANCE;
    let velocity = if moving { start.velocity } else { [0.0, 0.0] };
    let (way, lead_in) = moving_goal_path(
        map,
        f,
        start.position,
        velocity,
        to,
        limits.max_accel,
        robot,
    )?;
    let smoothed = way.smoothed;
    let path = &smoothed.path;
    let h0 = start.heading;
    let h1 = heading.map_or(h0, |h| h0 + wrap_angle(h - h0));
    let slope = if moving { start.yaw_rate / speed } else { 0.0 };
    let law = start_heading(h0, slope, h1, path.length())?;
    let from = if moving {
        StartVelocity {
            vx,
            vy,
            yaw_rate: Some(start.yaw_rate),
        }
    } else {
        StartVelocity {
            vx: 0.0,
            vy: 0.0,
            yaw_rate: Some(if start.yaw_rate.abs() <= START_TOLERANCE {
                0.0
            } else {
                start.yaw_rate
            }),
        }
    };
    let mut planned = plan_from_velocity(path, &law, robot, opts, from)?;
    for s in &mut planned.plan.samples {
        s.t += t_s;
    }
    Ok(Spliced {
        start,
        smoothed,
        lead_in,
        heading: law,
        planned,
    })
}

/// The heading law from `h0` (rad) with slope `slope` (rad/m) at the start to `h1` at the end
/// of a path `len` m long (module docs, step 3).
///
/// # Errors
/// [`PlanningError`] for a heading beyond [`crate::limits::MAX_HEADING`] (a very fast spin at
/// a very slow start).
pub fn start_heading(h0: f64, slope: f64, h1: f64, len: f64) -> Result<HeadingLaw, PlanningError> {
    if slope == 0.0 && h1 == h0 {
        return Ok(HeadingLaw::Constant(h0));
    }
    let mid = len / 2.0;
    let start_slope = |hm: f64| -> Result<f64, PlanningError> {
        Ok(HeadingProfile::new(&[(0.0, h0), (mid, hm), (len, h1)])?
            .at(0.0, Side::After)
            .1)
    };
    // ψ'(0) is linear in the middle value: two evaluations give it.
    let (c0, c1) = (start_slope(h0)?, start_slope(h0 + 1.0)?);
    let hm = h0 + (slope - c0) / (c1 - c0);
    Ok(HeadingLaw::Profile(HeadingProfile::new(&[
        (0.0, h0),
        (mid, hm),
        (len, h1),
    ])?))
}

/// The path from `from` (world frame, m), where the robot moves at `velocity` (m/s), to `to`
/// around the shapes of `map` for a footprint of radius `f` (m): a straight lead-in along the
/// velocity, then the shortest route, rounded (module docs, step 2; `max_accel` (m/s²) sets
/// the lead-in's length, lengthened past the first fillet for a `robot` with set-point
/// steering). At rest (`velocity` zero) it is the plain route from `from`. Returns
/// the path and the lead-in's length (m; 0 at rest). Its first tangent is the velocity's
/// direction. The returned route is the polyline with the lead-in (start, lead-in's end,
/// the route's corners, goal).
///
/// # Errors
/// [`PlanningError::Infeasible`] for a non-finite velocity, a lead-in not clear of the map
/// even at 1 mm, or no route (the map's reason); [`PlanningError::InvalidPath`] from the
/// smoothing.
pub fn moving_goal_path(
    map: &Map,
    f: f64,
    from: [f64; 2],
    velocity: [f64; 2],
    to: [f64; 2],
    max_accel: f64,
    robot: &RobotModel,
) -> Result<(GoalPath, f64), PlanningError> {
    let [vx, vy] = velocity;
    let speed = vx.hypot(vy);
    if !speed.is_finite() {
        return Err(PlanningError::Infeasible(format!(
            "the start velocity ({vx}, {vy}) m/s is not finite"
        )));
    }
    let infeasible = |e: crate::map::MapError| PlanningError::Infeasible(e.to_string());
    let p0 = from;
    if speed == 0.0 {
        let route = shortest_route(map, f, p0, to).map_err(infeasible)?;
        return Ok((path_of(map, f, route.points)?, 0.0));
    }
    let u = [vx / speed, vy / speed];
    // The path with a lead-in of `lead` m, or `None` when the lead-in is not clear.
    let with_lead = |lead: f64| -> Result<Option<GoalPath>, PlanningError> {
        let q = [p0[0] + lead * u[0], p0[1] + lead * u[1]];
        if !segment_clear(map, p0, q, f) {
            return Ok(None);
        }
        let route = shortest_route(map, f, q, to).map_err(infeasible)?;
        let mut pts = vec![p0];
        pts.extend_from_slice(&route.points);
        path_of(map, f, pts).map(Some)
    };
    let far = (to[0] - p0[0]).hypot(to[1] - p0[1]);
    let mut d = (LEAD_IN_FACTOR * speed * speed / (2.0 * max_accel)).max(MIN_LEAD_IN);
    if far > 2.0 * MIN_LEAD_IN {
        d = d.min(far / 2.0);
    }
    let mut way = loop {
        if let Some(way) = with_lead(d)? {
            break way;
        }
        d /= 2.0;
        if d < MIN_LEAD_IN {
            return Err(PlanningError::Infeasible(format!(
                "the motion ({vx:.4}, {vy:.4}) m/s at ({:.4}, {:.4}) heads into a shape of {} \
                 within {MIN_LEAD_IN} m for a footprint of {f} m",
                p0[0], p0[1], map.source_name
            )));
        }
    };
    // A robot that stops where a fillet meets a straight (a swerve) brakes on the straight
    // before the first fillet, which the fillet at the lead-in's end shortens: lengthen the
    // lead-in until that straight is `d`, while it stays clear.
    let mut lead = d;
    let rounds = if robot.model.kind().steer_is_set_point() {
        LEAD_IN_ROUNDS
    } else {
        0
    };
    for _ in 0..rounds {
        let straight = first_straight(&way.smoothed.path);
        if straight >= d * (1.0 - 1e-9) {
            break;
        }
        lead += d - straight;
        match with_lead(lead)? {
            Some(w) => way = w,
            None => {
                lead -= d - straight;
                break;
            }
        }
    }
    Ok((way, lead))
}

/// Why a goal request has no path: the map's answer (no route, a start inside a shape) or the
/// planner's (a lead-in that cannot be laid, a heading law). Displayed as the inner error.
#[derive(Debug, thiserror::Error)]
pub enum GoalRequestError {
    /// The map refused the route.
    #[error(transparent)]
    Map(#[from] crate::map::MapError),
    /// The lead-in or the heading law.
    #[error(transparent)]
    Planning(#[from] PlanningError),
}

/// A goal request's path, lead-in and heading law — what `omnikin plan goal` and
/// `omnikin.plan(robot, "goal", ...)` both plan: from rest the shortest route from `from` to
/// `to` ([`goal_path`](crate::map::goal::goal_path)) with the heading law from `headings[0]` to
/// `headings[1]` ([`goal_heading`](crate::map::goal::goal_heading)); moving (`start` not at
/// rest) a lead-in along the velocity first ([`moving_goal_path`]) and a heading that starts
/// turning at the given yaw rate (`dψ/ds = W / speed`, [`start_heading`]). World frame; m, rad.
///
/// # Errors
/// [`GoalRequestError`]: the map's or the planner's, as the functions above give them.
#[allow(clippy::too_many_arguments)]
pub fn goal_request(
    map: &Map,
    f: f64,
    from: [f64; 2],
    to: [f64; 2],
    headings: [Option<f64>; 2],
    start: &StartVelocity,
    max_accel: f64,
    robot: &RobotModel,
) -> Result<(GoalPath, f64, HeadingLaw), GoalRequestError> {
    let [h0, h1] = headings;
    let speed = start.speed();
    let (way, lead_in) = if speed > 0.0 {
        moving_goal_path(map, f, from, [start.vx, start.vy], to, max_accel, robot)?
    } else {
        (crate::map::goal::goal_path(map, f, from, to)?, 0.0)
    };
    let length = way.smoothed.path.length();
    let heading = match start.yaw_rate {
        Some(w) if speed > 0.0 => start_heading(
            h0.unwrap_or(0.0),
            w / speed,
            h1.or(h0).unwrap_or(0.0),
            length,
        )?,
        _ => crate::map::goal::goal_heading(h0, h1, length)?,
    };
    Ok((way, lead_in, heading))
}

/// Rounds of lengthening the lead-in ([`moving_goal_path`]).
const LEAD_IN_ROUNDS: usize = 4;

/// The length of `path`'s first straight piece, m (0 when it starts curving).
fn first_straight(path: &crate::path::Path) -> f64 {
    match path.joins().first() {
        Some(j) if j.before.curvature == 0.0 => j.s,
        Some(_) => 0.0,
        None if path.at(0.0).curvature == 0.0 => path.length(),
        None => 0.0,
    }
}

/// The polyline `pts` (repeated points dropped) as a route, and smoothed.
fn path_of(map: &Map, f: f64, mut pts: Vec<[f64; 2]>) -> Result<GoalPath, PlanningError> {
    // The goal at the lead-in's end: the route from there is that one point twice.
    pts.dedup_by(|b, a| (b[0] - a[0]).hypot(b[1] - a[1]) <= 1e-9);
    let length = pts
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    let route = Route {
        points: pts,
        length,
    };
    let smoothed = smooth(map, &route, f)?;
    Ok(GoalPath { route, smoothed })
}
