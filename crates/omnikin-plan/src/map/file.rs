//! Reading a `MAP.toml`: keep-out circles and polygons and an optional keep-in polygon,
//! validated with the line of every offending value (conventions.md, "Maps").
//!
//! ```toml
//! [[keep_out]]
//! circle = [1.0, 0.5, 0.2]                           # x, y, radius (m)
//!
//! [[keep_out]]
//! polygon = [[2.0, -0.5], [2.6, -0.5], [2.6, 0.3]]  # counter-clockwise (m)
//!
//! [keep_in]
//! polygon = [[-1.0, -2.0], [5.0, -2.0], [5.0, 2.0], [-1.0, 2.0]]
//! ```

use serde::Deserialize;
use toml::Spanned;

use super::geometry::{segments_meet, signed_area};
use super::{Map, MapError, Obstacle, Shape};
use crate::error::num;

/// Largest coordinate magnitude of a map, m: beyond it the values are taken for millimetres
/// (a robot's map spans metres to hundreds of metres).
pub const MAX_MAP_COORDINATE: f64 = 1000.0;
/// Largest keep-out circle radius, m (larger ones are taken for millimetres).
pub const MAX_OBSTACLE_RADIUS: f64 = 100.0;
/// Most keep-out obstacles and most vertices of one polygon in a map (the planner's graph
/// grows with their product).
pub const MAX_MAP_ITEMS: usize = 10_000;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMap {
    #[serde(default)]
    keep_out: Vec<Spanned<RawKeepOut>>,
    keep_in: Option<Spanned<RawKeepIn>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKeepOut {
    circle: Option<Spanned<Vec<f64>>>,
    polygon: Option<Spanned<Vec<Vec<f64>>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKeepIn {
    polygon: Spanned<Vec<Vec<f64>>>,
}

/// The 1-based line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    1 + text[..at.min(text.len())].matches('\n').count()
}

/// Checks one coordinate or radius: finite, and not so large that it must be millimetres.
fn check_value(
    what: &str,
    v: f64,
    max: f64,
    err: &dyn Fn(String) -> MapError,
) -> Result<(), MapError> {
    if !v.is_finite() {
        return Err(err(format!("{what} = {} is not a finite number", num(v))));
    }
    if v.abs() > max {
        return Err(err(format!(
            "{what} = {} m looks like millimetres (beyond {max} m): maps are in metres \
             (conventions.md, \"Maps\"); write {} m if millimetres were meant",
            num(v),
            num(v / 1000.0)
        )));
    }
    Ok(())
}

/// A polygon's vertices checked: pairs of coordinates, at least three distinct corners, no
/// zero-area or self-intersecting outline, counter-clockwise. A closing vertex equal to the
/// first is dropped.
fn polygon(
    raw: &[Vec<f64>],
    table: &str,
    err: &dyn Fn(String) -> MapError,
) -> Result<Vec<[f64; 2]>, MapError> {
    if raw.len() > MAX_MAP_ITEMS {
        return Err(err(format!(
            "{table} polygon has {} vertices, more than MAX_MAP_ITEMS = {MAX_MAP_ITEMS} \
             (omnikin_plan::map)",
            raw.len()
        )));
    }
    let mut v = Vec::with_capacity(raw.len());
    for (i, p) in raw.iter().enumerate() {
        let &[x, y] = p.as_slice() else {
            return Err(err(format!(
                "{table} polygon vertex {} has {} numbers; each vertex is [x, y] (m)",
                i + 1,
                p.len()
            )));
        };
        check_value(&format!("vertex {} x", i + 1), x, MAX_MAP_COORDINATE, err)?;
        check_value(&format!("vertex {} y", i + 1), y, MAX_MAP_COORDINATE, err)?;
        v.push([x, y]);
    }
    if v.len() > 1 && v.first() == v.last() {
        v.pop();
    }
    if v.len() < 3 {
        return Err(err(format!(
            "degenerate {table} polygon: {} distinct vertices; a polygon needs at least 3",
            v.len()
        )));
    }
    let n = v.len();
    for i in 0..n {
        if v[i] == v[(i + 1) % n] {
            return Err(err(format!(
                "degenerate {table} polygon: vertex {} repeats vertex {}",
                (i + 1) % n + 1,
                i + 1
            )));
        }
    }
    let extent = v
        .iter()
        .flat_map(|p| p.iter())
        .fold(0.0f64, |m, c| m.max(c.abs()))
        .max(1.0);
    let base = super::geometry::sub(v[1], v[0]);
    let collinear = v.iter().all(|p| {
        super::geometry::cross(super::geometry::sub(*p, v[0]), base).abs()
            <= 1e-12 * extent * extent
    });
    if collinear {
        return Err(err(format!(
            "degenerate {table} polygon: its {n} vertices are collinear (zero area)"
        )));
    }
    // Non-adjacent edges must not meet (adjacent ones share only their common vertex).
    for i in 0..n {
        for j in i + 1..n {
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            let (a, b, c, d) = (v[i], v[(i + 1) % n], v[j], v[(j + 1) % n]);
            let meet = if adjacent {
                // Adjacent edges folding back onto each other overlap.
                let (p, q, r) = if j == i + 1 { (a, b, d) } else { (c, a, b) };
                let (u, w) = (super::geometry::sub(p, q), super::geometry::sub(r, q));
                super::geometry::cross(u, w) == 0.0 && super::geometry::dot(u, w) > 0.0
            } else {
                segments_meet(a, b, c, d)
            };
            if meet {
                return Err(err(format!(
                    "self-intersecting {table} polygon: edge {} (vertex {} → {}) meets edge {} \
                     (vertex {} → {}); a polygon's outline must not cross itself",
                    i + 1,
                    i + 1,
                    (i + 1) % n + 1,
                    j + 1,
                    j + 1,
                    (j + 1) % n + 1
                )));
            }
        }
    }
    let area = signed_area(&v);
    if area < 0.0 {
        return Err(err(format!(
            "{table} polygon is clockwise (signed area {area} m²): list the vertices \
             counter-clockwise (conventions.md, \"Maps\")"
        )));
    }
    Ok(v)
}

/// Parses and validates a map (see the module docs); `source_name` names it in errors.
pub(super) fn parse(text: &str, source_name: &str) -> Result<Map, MapError> {
    let text = crate::waypoints::strip_bom(text);
    let raw: RawMap = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| line_of(text, s.start));
        MapError::at(source_name, line, e.message().trim().to_string())
    })?;
    if raw.keep_out.len() > MAX_MAP_ITEMS {
        return Err(MapError::at(
            source_name,
            None,
            format!(
                "{} keep_out tables, more than MAX_MAP_ITEMS = {MAX_MAP_ITEMS} (omnikin_plan::map)",
                raw.keep_out.len()
            ),
        ));
    }
    let mut keep_out = Vec::with_capacity(raw.keep_out.len());
    for (k, table) in raw.keep_out.iter().enumerate() {
        let table_line = line_of(text, table.span().start);
        let table = table.get_ref();
        let shape = match (&table.circle, &table.polygon) {
            (Some(c), None) => {
                let line = line_of(text, c.span().start);
                let err = |m: String| {
                    MapError::at(source_name, Some(line), format!("keep_out {}: {m}", k + 1))
                };
                let &[x, y, r] = c.get_ref().as_slice() else {
                    return Err(err(format!(
                        "circle has {} numbers; it is [x, y, radius] (m)",
                        c.get_ref().len()
                    )));
                };
                check_value("circle x", x, MAX_MAP_COORDINATE, &err)?;
                check_value("circle y", y, MAX_MAP_COORDINATE, &err)?;
                check_value("circle radius", r, MAX_OBSTACLE_RADIUS, &err)?;
                if r <= 0.0 {
                    return Err(err(format!("circle radius = {} m must be > 0", num(r))));
                }
                (
                    Shape::Circle {
                        centre: [x, y],
                        radius: r,
                    },
                    line,
                )
            }
            (None, Some(p)) => {
                let line = line_of(text, p.span().start);
                let err = |m: String| {
                    MapError::at(source_name, Some(line), format!("keep_out {}: {m}", k + 1))
                };
                (
                    Shape::Polygon(polygon(p.get_ref(), "keep_out", &err)?),
                    line,
                )
            }
            (Some(_), Some(_)) => {
                return Err(MapError::at(
                    source_name,
                    Some(table_line),
                    format!(
                        "keep_out {}: has both circle and polygon; one table holds one obstacle",
                        k + 1
                    ),
                ));
            }
            (None, None) => {
                return Err(MapError::at(
                    source_name,
                    Some(table_line),
                    format!(
                        "keep_out {}: needs circle = [x, y, radius] or polygon = [[x, y], …]",
                        k + 1
                    ),
                ));
            }
        };
        keep_out.push(Obstacle {
            shape: shape.0,
            line: shape.1,
        });
    }
    let keep_in = match &raw.keep_in {
        None => None,
        Some(t) => {
            let p = &t.get_ref().polygon;
            let line = line_of(text, p.span().start);
            let err = |m: String| MapError::at(source_name, Some(line), format!("keep_in: {m}"));
            Some(Obstacle {
                shape: Shape::Polygon(polygon(p.get_ref(), "keep_in", &err)?),
                line,
            })
        }
    };
    Ok(Map {
        source_name: source_name.to_string(),
        keep_out,
        keep_in,
    })
}
