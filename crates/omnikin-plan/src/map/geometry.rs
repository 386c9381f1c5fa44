//! Plane geometry the map needs: distances between points and segments, segment crossings,
//! point-in-polygon and the signed area of a polygon (world frame, m).

/// `a − b`.
pub(crate) fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// `a × b` (the z component), m².
pub(crate) fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// `a · b`, m².
pub(crate) fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// `|a − b|`, m.
pub(crate) fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Distance from `p` to the segment `a b`, m.
pub(crate) fn dist_point_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let ab = sub(b, a);
    let l2 = dot(ab, ab);
    let t = if l2 > 0.0 {
        (dot(sub(p, a), ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    dist(p, [a[0] + t * ab[0], a[1] + t * ab[1]])
}

/// Whether the closed segments `a b` and `c d` share a point (crossing or touching).
pub(crate) fn segments_meet(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let d1 = cross(sub(b, a), sub(c, a));
    let d2 = cross(sub(b, a), sub(d, a));
    let d3 = cross(sub(d, c), sub(a, c));
    let d4 = cross(sub(d, c), sub(b, c));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    let on = |p: [f64; 2], q: [f64; 2], r: [f64; 2], o: f64| {
        o == 0.0
            && r[0] >= p[0].min(q[0])
            && r[0] <= p[0].max(q[0])
            && r[1] >= p[1].min(q[1])
            && r[1] <= p[1].max(q[1])
    };
    on(a, b, c, d1) || on(a, b, d, d2) || on(c, d, a, d3) || on(c, d, b, d4)
}

/// Distance between the segments `a b` and `c d`, m (0 when they meet).
pub(crate) fn dist_segment_segment(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> f64 {
    if segments_meet(a, b, c, d) {
        return 0.0;
    }
    dist_point_segment(a, c, d)
        .min(dist_point_segment(b, c, d))
        .min(dist_point_segment(c, a, b))
        .min(dist_point_segment(d, a, b))
}

/// Whether `p` is strictly inside the polygon `v` (even–odd rule; a point on an edge may
/// count either way, callers keep a clearance from the edges).
pub(crate) fn inside(p: [f64; 2], v: &[[f64; 2]]) -> bool {
    let mut inside = false;
    let n = v.len();
    for i in 0..n {
        let (a, b) = (v[i], v[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Signed area of the polygon `v` (shoelace formula), m²: > 0 counter-clockwise.
pub(crate) fn signed_area(v: &[[f64; 2]]) -> f64 {
    let n = v.len();
    (0..n).map(|i| cross(v[i], v[(i + 1) % n])).sum::<f64>() / 2.0
}

/// Distance from `p` to the boundary of the polygon `v`, m.
pub(crate) fn dist_to_boundary(p: [f64; 2], v: &[[f64; 2]]) -> f64 {
    let n = v.len();
    (0..n)
        .map(|i| dist_point_segment(p, v[i], v[(i + 1) % n]))
        .fold(f64::INFINITY, f64::min)
}

/// Distance from the segment `a b` to the boundary of the polygon `v`, m.
pub(crate) fn segment_to_boundary(a: [f64; 2], b: [f64; 2], v: &[[f64; 2]]) -> f64 {
    let n = v.len();
    (0..n)
        .map(|i| dist_segment_segment(a, b, v[i], v[(i + 1) % n]))
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_of_a_unit_square() {
        let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert!((signed_area(&sq) - 1.0).abs() < 1e-15);
        assert!(inside([0.5, 0.5], &sq));
        assert!(!inside([1.5, 0.5], &sq));
        assert!((dist_to_boundary([2.0, 2.0], &sq) - 2f64.sqrt()).abs() < 1e-12);
        assert!((segment_to_boundary([-1.0, 3.0], [2.0, 3.0], &sq) - 2.0).abs() < 1e-12);
        assert_eq!(segment_to_boundary([0.5, -1.0], [0.5, 2.0], &sq), 0.0);
    }

    #[test]
    fn touching_segments_meet_and_parallel_ones_do_not() {
        assert!(segments_meet(
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0]
        ));
        assert!(!segments_meet(
            [0.0, 0.0],
            [1.0, 0.0],
            [0.0, 1.0],
            [1.0, 1.0]
        ));
        assert!(
            (dist_segment_segment([0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]) - 1.0).abs()
                < 1e-15
        );
    }
}
