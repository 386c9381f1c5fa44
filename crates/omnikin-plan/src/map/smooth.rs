//! A [`Route`] as a path the planner times: a polyline whose corners are rounded by circular
//! fillets ([`Corners::Fillet`]), checked against the map sample by sample.
//!
//! The route's corners lie on polygons circumscribing arcs of radius at least the footprint
//! radius `f`, so a fillet of radius up to `f` stays between the chords and the arc it
//! replaces. The radius is also limited so that every fillet fits on its legs. The straight
//! pieces lie on the route's segments, whose clearance the route search checked exactly; the
//! fillet arcs are sampled every `f / 50` (ends included), and if any sample comes closer than
//! `f` to a shape, the radius is halved (at most [`MAX_SHRINKS`] times) before falling back to
//! a polyline that stops at its corners (the route itself, which is clear).

use super::Map;
use super::route::{CLEAR_TOLERANCE, Route};
use crate::PlanningError;
use crate::path::{Corners, Path};

/// How many times the fillet radius is halved before the corners become stops.
pub const MAX_SHRINKS: usize = 12;

/// A smoothed route: the path and the fillet radius used (`None`: stops at the corners).
#[derive(Clone, Debug)]
pub struct Smoothed {
    /// The path, world frame, m.
    pub path: Path,
    /// The fillet radius of its corners, m, or `None` when it stops at them.
    pub fillet_radius: Option<f64>,
    /// The smallest clearance of the route's segments and the fillets' samples, m (≥ `f`).
    pub min_clearance: f64,
}

/// Smallest clearance of `path` sampled every `step` metres and at its end, m.
pub fn path_clearance(map: &Map, path: &Path, step: f64) -> f64 {
    let l = path.length();
    let n = (l / step).ceil().max(1.0) as usize;
    (0..=n)
        .map(|k| map.clearance(path.at(l * k as f64 / n as f64).point))
        .fold(f64::INFINITY, f64::min)
}

/// Smallest clearance of the fillet arcs of `path` (a filleted polyline through `points` with
/// fillets of `radius`), sampled every `step` metres and at their ends, m.
fn fillet_clearance(map: &Map, path: &Path, points: &[[f64; 2]], radius: f64, step: f64) -> f64 {
    let s_at = path.waypoint_arc_lengths();
    let mut best = f64::INFINITY;
    for k in 1..points.len() - 1 {
        let (a, b) = (sub(points[k], points[k - 1]), sub(points[k + 1], points[k]));
        let turn = (a[0] * b[1] - a[1] * b[0]).atan2(a[0] * b[0] + a[1] * b[1]);
        // The fillet is centred on the waypoint's arc length (its closest point).
        let half = radius * turn.abs() / 2.0;
        let n = ((2.0 * half / step).ceil() as usize).max(1);
        for j in 0..=n {
            let s = s_at[k] - half + 2.0 * half * j as f64 / n as f64;
            best = best.min(map.clearance(path.at(s.clamp(0.0, path.length())).point));
        }
    }
    best
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// Largest fillet radius that fits on every leg of `points`, m.
fn fitting_radius(points: &[[f64; 2]]) -> f64 {
    let n = points.len();
    let dir = |i: usize| {
        let d = [
            points[i + 1][0] - points[i][0],
            points[i + 1][1] - points[i][1],
        ];
        let l = d[0].hypot(d[1]);
        ([d[0] / l, d[1] / l], l)
    };
    let half_tan = |k: usize| {
        if k == 0 || k == n - 1 {
            return 0.0;
        }
        let (a, _) = dir(k - 1);
        let (b, _) = dir(k);
        let turn = (a[0] * b[1] - a[1] * b[0]).atan2(a[0] * b[0] + a[1] * b[1]);
        (turn.abs() / 2.0).tan()
    };
    (0..n - 1)
        .map(|j| {
            let t = half_tan(j) + half_tan(j + 1);
            if t > 0.0 { dir(j).1 / t } else { f64::INFINITY }
        })
        .fold(f64::INFINITY, f64::min)
}

/// The route as a filleted path keeping the footprint `f` (m) clear of every shape at every
/// checked sample.
///
/// # Errors
/// [`PlanningError::InvalidPath`] only if even the stopping polyline cannot be built (a route
/// with repeated points).
pub fn smooth(map: &Map, route: &Route, f: f64) -> Result<Smoothed, PlanningError> {
    let step = f / 50.0;
    let min_radius = crate::limits::LENGTH_RANGE.0;
    let lines = route
        .points
        .windows(2)
        .map(|w| map.segment_clearance(w[0], w[1]))
        .fold(f64::INFINITY, f64::min);
    let mut radius = f.min(fitting_radius(&route.points) * (1.0 - 1e-9));
    if route.points.len() > 2 {
        for _ in 0..=MAX_SHRINKS {
            if radius < min_radius {
                break;
            }
            if let Ok(path) = Path::polyline(&route.points, Corners::Fillet { radius }) {
                let c = lines.min(fillet_clearance(map, &path, &route.points, radius, step));
                if c >= f * (1.0 - CLEAR_TOLERANCE) {
                    return Ok(Smoothed {
                        path,
                        fillet_radius: Some(radius),
                        min_clearance: c,
                    });
                }
            }
            radius /= 2.0;
        }
    }
    Ok(Smoothed {
        path: Path::polyline(&route.points, Corners::Stop)?,
        fillet_radius: None,
        min_clearance: lines,
    })
}
