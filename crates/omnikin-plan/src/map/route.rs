//! The shortest collision-free route of a round footprint: a visibility graph on the obstacles
//! inflated by the footprint radius `f`, searched with A*.
//!
//! **Nodes.** The inflated obstacles are bounded by lines and circular arcs: a keep-out circle
//! of radius `r` becomes a circle of radius `R = r + f`, a polygon gains an arc of radius `f`
//! about each convex corner (and the keep-in polygon about each reflex corner, the corners the
//! free space wraps around). Each arc is replaced by the vertices of a polygon that
//! circumscribes it, in steps of at most `2π/ARC_STEPS` (`δ`), at radius `R/cos(δ/2)` (plus a
//! relative margin of [`NODE_MARGIN`]); its chords are tangent to the arc, so they keep the
//! clearance. A shortest path bends only on those arcs, so it runs through these nodes.
//!
//! **Length bound.** Wrapping the circumscribed polygon instead of an arc of angle `α` costs at
//! most `α R (tan(δ/2)/(δ/2) − 1)`: with `ARC_STEPS = 64`, 0.081 % of the wrapped arc, so less
//! than 0.081 % of the route (tangent legs are straight either way). Passages narrower than
//! `2f` plus the nodes' `1 − cos(δ/2) = 0.12 %` of `R` count as closed. The tests compare the
//! route against a lower bound computed independently (inscribed polygons).
//!
//! **Edges.** Node pairs whose segment keeps at least `f` from every shape (an exact
//! segment–circle and segment–polygon distance), and only the segments tangent to the chain at
//! both ends (both chain neighbours of a node on one side of the line): a shortest path never
//! uses another. A* with the straight-line distance to the goal as the heuristic, evaluating a
//! segment only when it would improve a node.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::file::MAX_MAP_COORDINATE;
use super::geometry::{cross, dist, dot, sub};
use super::{Map, MapError, Shape};
use crate::error::num;

/// Nodes per full turn of an arc (see the module docs for the length bound it gives).
pub const ARC_STEPS: usize = 64;
/// Nodes sit this much (relative) outside the circumscribed polygon, so that chords between
/// neighbours clear the arc by a margin rounding cannot eat.
pub const NODE_MARGIN: f64 = 1e-6;
/// A segment is clear when its distance to every shape is at least `f (1 − CLEAR_TOLERANCE)`.
pub const CLEAR_TOLERANCE: f64 = 1e-9;

/// A collision-free polyline from the start to the goal.
#[derive(Clone, Debug, PartialEq)]
pub struct Route {
    /// The corners, start first and goal last, world frame, m.
    pub points: Vec<[f64; 2]>,
    /// Total length, m.
    pub length: f64,
}

/// A graph node: a corner of a circumscribed arc polygon, with its chain neighbours.
struct Node {
    p: [f64; 2],
    prev: usize,
    next: usize,
    free: bool,
}

/// `m` steps from angle `a0` sweeping `sweep` about `c`, at the circumscribing radius of
/// `radius`: `m + 1` points (or `m` for a full turn).
fn arc_points(c: [f64; 2], radius: f64, a0: f64, sweep: f64, full: bool) -> Vec<[f64; 2]> {
    let step = std::f64::consts::TAU / ARC_STEPS as f64;
    let m = ((sweep.abs() / step).ceil() as usize).max(1);
    let d = sweep / m as f64;
    let rho = radius * (1.0 + NODE_MARGIN) / (d / 2.0).cos();
    let count = if full { m } else { m + 1 };
    (0..count)
        .map(|j| {
            let a = a0 + j as f64 * d;
            [c[0] + rho * a.cos(), c[1] + rho * a.sin()]
        })
        .collect()
}

/// The arc nodes of a polygon's outline: about its convex corners for a keep-out polygon
/// (`sign = 1`), its reflex corners for the keep-in polygon (`sign = −1`).
fn polygon_points(v: &[[f64; 2]], f: f64, sign: f64) -> Vec<[f64; 2]> {
    let n = v.len();
    let unit = |a: [f64; 2]| {
        let l = a[0].hypot(a[1]);
        [a[0] / l, a[1] / l]
    };
    let mut out = Vec::new();
    for i in 0..n {
        let d_in = unit(sub(v[i], v[(i + n - 1) % n]));
        let d_out = unit(sub(v[(i + 1) % n], v[i]));
        let turn = cross(d_in, d_out).atan2(dot(d_in, d_out));
        if turn * sign > 1e-12 {
            // The normal of the incoming edge on the free side.
            let normal = [sign * d_in[1], -sign * d_in[0]];
            out.extend(arc_points(v[i], f, normal[1].atan2(normal[0]), turn, false));
        }
    }
    out
}

/// Builds the node chains of every shape.
fn nodes(map: &Map, f: f64) -> Vec<Node> {
    let mut chains: Vec<Vec<[f64; 2]>> = Vec::new();
    for o in &map.keep_out {
        chains.push(match &o.shape {
            Shape::Circle { centre, radius } => {
                arc_points(*centre, radius + f, 0.0, std::f64::consts::TAU, true)
            }
            Shape::Polygon(v) => polygon_points(v, f, 1.0),
        });
    }
    if let Some(k) = &map.keep_in
        && let Shape::Polygon(v) = &k.shape
    {
        chains.push(polygon_points(v, f, -1.0));
    }
    let mut out = Vec::new();
    for c in chains {
        let base = out.len();
        let m = c.len();
        for (j, p) in c.into_iter().enumerate() {
            out.push(Node {
                p,
                prev: base + (j + m - 1) % m,
                next: base + (j + 1) % m,
                free: map.clearance(p) >= f * (1.0 - CLEAR_TOLERANCE),
            });
        }
    }
    out
}

/// Whether the line through node `u` and `q` supports `u`'s chain locally (both chain
/// neighbours on one side, or on the line).
fn tangent(nodes: &[Node], u: usize, q: [f64; 2]) -> bool {
    let p = nodes[u].p;
    let e = sub(q, p);
    let c1 = cross(e, sub(nodes[nodes[u].prev].p, p));
    let c2 = cross(e, sub(nodes[nodes[u].next].p, p));
    let scale = 1e-12 * dot(e, e).sqrt() * dist(nodes[nodes[u].next].p, p);
    !((c1 > scale && c2 < -scale) || (c1 < -scale && c2 > scale))
}

/// Whether the segment `a b` keeps the footprint `f` clear of every shape.
pub fn segment_clear(map: &Map, a: [f64; 2], b: [f64; 2], f: f64) -> bool {
    map.segment_clearance(a, b) >= f * (1.0 - CLEAR_TOLERANCE)
}

/// The shortest collision-free route of a footprint of radius `f` (m) from `from` to `to`
/// (world frame, m), within the length bound of the module docs.
///
/// # Errors
/// [`MapError`] when `f` is not a positive length, when the start or the goal is inside an
/// obstacle, too close to one for the footprint or outside the keep-in polygon (naming the
/// obstacle's line), and when no path exists (naming the obstacles whose inflated shapes close
/// the passages).
pub fn shortest_route(map: &Map, f: f64, from: [f64; 2], to: [f64; 2]) -> Result<Route, MapError> {
    if !(f.is_finite() && f > 0.0) {
        return Err(MapError::at(
            &map.source_name,
            None,
            format!(
                "footprint radius = {} m must be a finite length > 0",
                num(f)
            ),
        ));
    }
    for (p, what) in [(from, "start"), (to, "goal")] {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return Err(MapError::at(
                &map.source_name,
                None,
                format!(
                    "{what} ({}, {}) is not a finite point",
                    num(p[0]),
                    num(p[1])
                ),
            ));
        }
        if p[0].abs().max(p[1].abs()) > MAX_MAP_COORDINATE {
            return Err(MapError::at(
                &map.source_name,
                None,
                format!(
                    "{what} ({}, {}) is beyond {MAX_MAP_COORDINATE} m: maps and points are in \
                     metres (conventions.md, \"Maps\")",
                    num(p[0]),
                    num(p[1])
                ),
            ));
        }
        map.check_point(p, f, what)?;
    }
    if segment_clear(map, from, to, f) {
        return Ok(Route {
            points: vec![from, to],
            length: dist(from, to),
        });
    }
    let nodes = nodes(map, f);
    let n = nodes.len();
    let (start, goal) = (n, n + 1);
    let pts: Vec<[f64; 2]> = nodes.iter().map(|q| q.p).chain([from, to]).collect();
    let mut g = vec![f64::INFINITY; n + 2];
    let mut came = vec![usize::MAX; n + 2];
    let mut closed = vec![false; n + 2];
    let mut heap = BinaryHeap::new();
    g[start] = 0.0;
    // Non-negative f64 order as their bit patterns.
    heap.push(Reverse((dist(from, to).to_bits(), start)));
    while let Some(Reverse((_, u))) = heap.pop() {
        if closed[u] {
            continue;
        }
        closed[u] = true;
        if u == goal {
            break;
        }
        for w in 0..n + 2 {
            if closed[w] || w == start || (w < n && !nodes[w].free) {
                continue;
            }
            if (u < n && !tangent(&nodes, u, pts[w])) || (w < n && !tangent(&nodes, w, pts[u])) {
                continue;
            }
            let ng = g[u] + dist(pts[u], pts[w]);
            if ng >= g[w] || !segment_clear(map, pts[u], pts[w], f) {
                continue;
            }
            g[w] = ng;
            came[w] = u;
            heap.push(Reverse(((ng + dist(pts[w], to)).to_bits(), w)));
        }
    }
    if !closed[goal] {
        return Err(unreachable(map, f, from, to, &nodes));
    }
    let mut points = vec![to];
    let mut u = goal;
    while u != start {
        u = came[u];
        points.push(pts[u]);
    }
    points.reverse();
    Ok(Route {
        points,
        length: g[goal],
    })
}

/// Distance between two keep-out shapes, m (0 when they overlap).
fn shape_distance(a: &Shape, b: &Shape) -> f64 {
    use super::geometry::{inside, segment_to_boundary};
    match (a, b) {
        (
            Shape::Circle {
                centre: c1,
                radius: r1,
            },
            Shape::Circle {
                centre: c2,
                radius: r2,
            },
        ) => (dist(*c1, *c2) - r1 - r2).max(0.0),
        (Shape::Circle { centre, radius }, Shape::Polygon(v))
        | (Shape::Polygon(v), Shape::Circle { centre, radius }) => {
            if inside(*centre, v) {
                0.0
            } else {
                (super::geometry::dist_to_boundary(*centre, v) - radius).max(0.0)
            }
        }
        (Shape::Polygon(v), Shape::Polygon(w)) => {
            if inside(v[0], w) || inside(w[0], v) {
                return 0.0;
            }
            (0..v.len())
                .map(|i| segment_to_boundary(v[i], v[(i + 1) % v.len()], w))
                .fold(f64::INFINITY, f64::min)
        }
    }
}

/// What `src` reaches on the graph of [`shortest_route`] (the same edges: clear segments,
/// tangent at their nodes): how many nodes, and whether `target` is among the points reached.
fn reach(map: &Map, f: f64, nodes: &[Node], src: [f64; 2], target: [f64; 2]) -> (usize, bool) {
    let n = nodes.len();
    let mut seen = vec![false; n];
    // (node index, or None for `src`; its point)
    let mut stack = vec![(None, src)];
    let (mut count, mut found) = (0, false);
    while let Some((u, p)) = stack.pop() {
        if !found && segment_clear(map, p, target, f) {
            found = true;
        }
        for w in 0..n {
            if seen[w]
                || !nodes[w].free
                || !tangent(nodes, w, p)
                || u.is_some_and(|u| !tangent(nodes, u, nodes[w].p))
                || !segment_clear(map, p, nodes[w].p, f)
            {
                continue;
            }
            seen[w] = true;
            count += 1;
            stack.push((Some(w), nodes[w].p));
        }
    }
    (count, found)
}

/// Which of the start and the goal is enclosed, when no route joins them. Without a keep-in
/// polygon the free space around all the shapes is open: a point that cannot reach a point
/// beyond their bounding box is enclosed. Inside a keep-in polygon the smaller region (fewer
/// graph nodes reached) is the enclosed one.
fn enclosed(map: &Map, f: f64, from: [f64; 2], to: [f64; 2], nodes: &[Node]) -> &'static str {
    let far = nodes
        .iter()
        .map(|q| q.p)
        .chain([from, to])
        .fold([f64::NEG_INFINITY; 2], |m, p| {
            [m[0].max(p[0]), m[1].max(p[1])]
        });
    let outside = [far[0] + 2.0 * f + 1.0, far[1] + 2.0 * f + 1.0];
    let (start_nodes, start_out) = reach(map, f, nodes, from, outside);
    let (goal_nodes, goal_out) = reach(map, f, nodes, to, outside);
    if map.keep_in.is_none() {
        return match (start_out, goal_out) {
            (true, _) => "the goal is enclosed",
            (false, true) => "the start is enclosed",
            (false, false) => "the start and the goal are each enclosed",
        };
    }
    match start_nodes.cmp(&goal_nodes) {
        std::cmp::Ordering::Greater => "the goal is enclosed",
        std::cmp::Ordering::Less => "the start is enclosed",
        std::cmp::Ordering::Equal => "the start and the goal are each enclosed",
    }
}

/// Why no route exists: the shapes whose inflated outlines touch another's (or the keep-in
/// boundary's), i.e. the walls that close the passages, and which end they enclose.
fn unreachable(map: &Map, f: f64, from: [f64; 2], to: [f64; 2], nodes: &[Node]) -> MapError {
    let mut lines = Vec::new();
    let k = map.keep_out.len();
    for i in 0..k {
        let a = &map.keep_out[i].shape;
        let to_others = (0..k)
            .filter(|&j| j != i)
            .any(|j| shape_distance(a, &map.keep_out[j].shape) < 2.0 * f);
        let to_wall = map.keep_in.as_ref().is_some_and(|w| match (&w.shape, a) {
            (Shape::Polygon(v), Shape::Circle { centre, radius }) => {
                super::geometry::dist_to_boundary(*centre, v) - radius < 2.0 * f
            }
            (Shape::Polygon(v), Shape::Polygon(p)) => {
                (0..p.len())
                    .map(|i| super::geometry::segment_to_boundary(p[i], p[(i + 1) % p.len()], v))
                    .fold(f64::INFINITY, f64::min)
                    < 2.0 * f
            }
            _ => false,
        });
        if to_others || to_wall {
            lines.push(map.keep_out[i].line.to_string());
        }
    }
    let walls = if lines.is_empty() {
        "the keep_in polygon's own narrows".to_string()
    } else {
        format!("the keep_out shapes at lines {}", lines.join(", "))
    };
    MapError::at(
        &map.source_name,
        None,
        format!(
            "no collision-free path from the start ({}, {}) to the goal ({}, {}): with the \
             footprint radius {} m, {walls} leave gaps narrower than the footprint's diameter \
             {} m: {}",
            num(from[0]),
            num(from[1]),
            num(to[0]),
            num(to[1]),
            num(f),
            num(2.0 * f),
            enclosed(map, f, from, to, nodes)
        ),
    )
}
