//! Maps for the autonomous mode: keep-out circles and polygons, an optional keep-in polygon,
//! and the shortest collision-free path of a round footprint between two points (issue 40).
//!
//! Conventions ("Maps" in conventions.md): world frame, metres; polygons counter-clockwise;
//! the footprint is a disk of radius `f` and clearance is measured from its edge, so the robot's
//! centre must stay at least `f` from every keep-out shape and from the keep-in boundary.
//!
//! | module | what |
//! |---|---|
//! | [`file`] | `MAP.toml` parsing and validation, errors naming the line and the rule |
//! | [`footprint`] | the footprint radius from the robot's geometry |
//! | [`route`] | the shortest route: visibility graph on the inflated obstacles + A* |
//! | [`smooth`] | the route as a filleted [`crate::path::Path`] checked sample by sample |
//! | [`goal`] | start to goal: route, smoothing and the heading law of the request |
//!
//! ```
//! use omnikin_plan::map::Map;
//! let map = Map::from_toml("[[keep_out]]\ncircle = [1.0, 0.0, 0.3]\n", "demo.toml")?;
//! let route = omnikin_plan::map::route::shortest_route(&map, 0.2, [0.0, 0.0], [2.0, 0.0])?;
//! assert!(route.length > 2.0); // around the circle
//! assert!(map.segment_clearance(route.points[0], route.points[1]) >= 0.2 - 1e-9);
//! # Ok::<(), omnikin_plan::map::MapError>(())
//! ```

mod error;
pub mod file;
pub mod footprint;
pub(crate) mod geometry;
pub mod goal;
pub mod route;
pub mod smooth;

pub use error::MapError;

use crate::error::num;
use geometry::{dist, dist_point_segment, dist_to_boundary, inside, segment_to_boundary};

/// The shape of a keep-out obstacle or of the keep-in boundary (world frame, m).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A disk.
    Circle {
        /// Centre, m.
        centre: [f64; 2],
        /// Radius, m (> 0).
        radius: f64,
    },
    /// A simple polygon, counter-clockwise, without the closing vertex.
    Polygon(Vec<[f64; 2]>),
}

/// A shape of the map with the line of the file it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    /// The shape.
    pub shape: Shape,
    /// 1-based line of its `circle` or `polygon` value in the map file.
    pub line: usize,
}

/// A validated map (see [`file`] for the format).
#[derive(Clone, Debug, PartialEq)]
pub struct Map {
    /// The file it was read from (names it in errors).
    pub source_name: String,
    /// Keep-out obstacles, in file order.
    pub keep_out: Vec<Obstacle>,
    /// The keep-in boundary (a [`Shape::Polygon`]), if any: the robot stays inside it.
    pub keep_in: Option<Obstacle>,
}

/// Signed distance from `p` to a keep-out shape, m: negative inside it.
fn signed_distance(p: [f64; 2], s: &Shape) -> f64 {
    match s {
        Shape::Circle { centre, radius } => dist(p, *centre) - radius,
        Shape::Polygon(v) => {
            let d = dist_to_boundary(p, v);
            if inside(p, v) { -d } else { d }
        }
    }
}

impl Map {
    /// Reads and validates a map file.
    ///
    /// # Errors
    /// [`MapError`] for an unreadable file (over 1 MiB, not UTF-8) or any rule of [`file`].
    pub fn load(path: &std::path::Path) -> Result<Self, MapError> {
        let name = path.display().to_string();
        let text = omnikin::description::read_text_limited(
            path,
            omnikin::description::MAX_TOML_BYTES,
            "MAX_TOML_BYTES of omnikin::description",
        )
        .map_err(|e| MapError::at(&name, None, format!("cannot read: {e}")))?;
        Self::from_toml(&text, &name)
    }

    /// Parses and validates map text; `source_name` names it in errors.
    ///
    /// # Errors
    /// [`MapError`] naming the line and the rule (see [`file`]).
    pub fn from_toml(text: &str, source_name: &str) -> Result<Self, MapError> {
        file::parse(text, source_name)
    }

    /// Distance from `p` to the nearest keep-out shape or keep-in edge, m: negative inside an
    /// obstacle or outside the keep-in polygon. The footprint fits at `p` when it is ≥ `f`.
    pub fn clearance(&self, p: [f64; 2]) -> f64 {
        self.nearest(p).0
    }

    /// [`Map::clearance`] and the shape that sets it.
    fn nearest(&self, p: [f64; 2]) -> (f64, Option<&Obstacle>) {
        let mut best = (f64::INFINITY, None);
        for o in &self.keep_out {
            let d = signed_distance(p, &o.shape);
            if d < best.0 {
                best = (d, Some(o));
            }
        }
        if let Some(k) = &self.keep_in
            && let Shape::Polygon(v) = &k.shape
        {
            let d = dist_to_boundary(p, v);
            let d = if inside(p, v) { d } else { -d };
            if d < best.0 {
                best = (d, Some(k));
            }
        }
        best
    }

    /// Smallest distance from any point of the segment `a b` to the map's shapes (as
    /// [`Map::clearance`], but ≤ 0 whenever the segment touches or enters a shape).
    pub fn segment_clearance(&self, a: [f64; 2], b: [f64; 2]) -> f64 {
        let mut best = f64::INFINITY;
        for o in &self.keep_out {
            let d = match &o.shape {
                Shape::Circle { centre, radius } => dist_point_segment(*centre, a, b) - radius,
                Shape::Polygon(v) => {
                    if inside(a, v) {
                        -1.0
                    } else {
                        segment_to_boundary(a, b, v)
                    }
                }
            };
            best = best.min(d);
        }
        if let Some(k) = &self.keep_in
            && let Shape::Polygon(v) = &k.shape
        {
            best = best.min(if inside(a, v) {
                segment_to_boundary(a, b, v)
            } else {
                -1.0
            });
        }
        best
    }

    /// Checks that a footprint of radius `f` (m) fits at `p`; `what` names the point
    /// (`start`, `goal`, `waypoint 3`).
    ///
    /// # Errors
    /// [`MapError`] at the line of the obstacle that `p` is inside or too close to, or of the
    /// keep-in polygon it is outside of.
    pub fn check_point(&self, p: [f64; 2], f: f64, what: &str) -> Result<(), MapError> {
        let (d, o) = self.nearest(p);
        if d >= f {
            return Ok(());
        }
        let Some(o) = o else { return Ok(()) };
        let is_keep_in = self.keep_in.as_ref().is_some_and(|k| std::ptr::eq(k, o));
        let shape = match (&o.shape, is_keep_in) {
            (_, true) => "the keep_in polygon".to_string(),
            (Shape::Circle { .. }, false) => "the keep_out circle".to_string(),
            (Shape::Polygon(_), false) => "the keep_out polygon".to_string(),
        };
        let message = if d < 0.0 {
            if is_keep_in {
                format!("{what} ({}, {}) is outside {shape}", num(p[0]), num(p[1]))
            } else {
                format!("{what} ({}, {}) is inside {shape}", num(p[0]), num(p[1]))
            }
        } else {
            format!(
                "{what} ({}, {}) is {d:.4} m from {shape}: the footprint (radius {} m) overlaps it",
                num(p[0]),
                num(p[1]),
                num(f)
            )
        };
        Err(MapError::at(&self.source_name, Some(o.line), message))
    }
}

#[cfg(test)]
mod tests;
