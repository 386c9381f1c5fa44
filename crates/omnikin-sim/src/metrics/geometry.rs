//! Plane geometry of the metrics: the distance from a point to a polyline (the test oracle of
//! [`PathIndex`](crate::path_index::PathIndex)) and the least-squares circle fit behind the
//! radius ratio of paper 000's circles.

use serde::Serialize;

/// A circle fitted to points (geometric least squares).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FittedCircle {
    /// Centre, m.
    pub center: [f64; 2],
    /// Radius, m.
    pub radius: f64,
    /// RMS radial residual of the points, m.
    pub rms_residual: f64,
}

/// Distance from `p` to the polyline through `path` (nearest point on any segment), m.
///
/// Scans every segment: O(n) for one point. For many points against one path use
/// [`PathIndex`](crate::path_index::PathIndex), which gives the same value bit for bit (this function is its test oracle).
pub fn distance_to_path(p: [f64; 2], path: &[[f64; 2]]) -> f64 {
    if path.len() == 1 {
        return (p[0] - path[0][0]).hypot(p[1] - path[0][1]);
    }
    let mut best = f64::INFINITY;
    for w in path.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = dx * dx + dy * dy;
        let s = if len2 > 0.0 {
            (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d2 = (p[0] - a[0] - s * dx).powi(2) + (p[1] - a[1] - s * dy).powi(2);
        best = best.min(d2);
    }
    best.sqrt()
}

/// Fits a circle to `points`: the algebraic (Kåsa) fit refined by Gauss–Newton on the
/// geometric distances. `None` for fewer than 3 points or collinear points.
pub fn fit_circle(points: &[[f64; 2]]) -> Option<FittedCircle> {
    if points.len() < 3 {
        return None;
    }
    // Kåsa: minimise Σ (x² + y² + D x + E y + F)², in coordinates centred on the centroid.
    let n = points.len() as f64;
    let cx = points.iter().map(|p| p[0]).sum::<f64>() / n;
    let cy = points.iter().map(|p| p[1]).sum::<f64>() / n;
    let mut ata = [[0.0f64; 3]; 3];
    let mut atb = [0.0f64; 3];
    for p in points {
        let (x, y) = (p[0] - cx, p[1] - cy);
        let row = [x, y, 1.0];
        let rhs = -(x * x + y * y);
        for i in 0..3 {
            atb[i] += row[i] * rhs;
            for j in 0..3 {
                ata[i][j] += row[i] * row[j];
            }
        }
    }
    let sol = solve3(ata, atb)?;
    let (mut a, mut b) = (-sol[0] / 2.0, -sol[1] / 2.0);
    let r2 = a * a + b * b - sol[2];
    if r2.is_nan() || r2 <= 0.0 {
        return None;
    }
    let mut r = r2.sqrt();
    // Gauss–Newton on residuals d_i = |p_i − c| − r.
    for _ in 0..20 {
        let mut jtj = [[0.0f64; 3]; 3];
        let mut jtr = [0.0f64; 3];
        for p in points {
            let (dx, dy) = (p[0] - cx - a, p[1] - cy - b);
            let d = dx.hypot(dy);
            if d == 0.0 {
                continue;
            }
            let row = [-dx / d, -dy / d, -1.0];
            let res = d - r;
            for i in 0..3 {
                jtr[i] += row[i] * res;
                for j in 0..3 {
                    jtj[i][j] += row[i] * row[j];
                }
            }
        }
        let Some(step) = solve3(jtj, jtr) else { break };
        a -= step[0];
        b -= step[1];
        r -= step[2];
        if step.iter().map(|s| s.abs()).fold(0.0, f64::max) < 1e-13 * (1.0 + r.abs()) {
            break;
        }
    }
    let rms = (points
        .iter()
        .map(|p| ((p[0] - cx - a).hypot(p[1] - cy - b) - r).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    (r.is_finite() && r > 0.0).then_some(FittedCircle {
        center: [a + cx, b + cy],
        radius: r,
        rms_residual: rms,
    })
}

/// Solves a 3×3 system by Cramer's rule; `None` when (nearly) singular.
fn solve3(m: [[f64; 3]; 3], v: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    let scale = m.iter().flatten().map(|x| x.abs()).fold(0.0, f64::max);
    if d.is_nan() || d.abs() <= 1e-14 * scale.powi(3) {
        return None;
    }
    let mut out = [0.0; 3];
    for c in 0..3 {
        let mut mc = m;
        for r in 0..3 {
            mc[r][c] = v[r];
        }
        out[c] = det(&mc) / d;
    }
    Some(out)
}
