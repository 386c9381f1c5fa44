//! The paper's evaluation metrics (paper 000, §6): deviation from the planned path (m and % of
//! the distance travelled), mean trajectory with a 95 % confidence band, fitted circle radius,
//! repeatability across runs.

use omnikin_plan::Plan;
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, StudentsT};

/// One run's positions (and headings, when known) on the plan's time grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// Positions, m, world frame, one per plan sample.
    pub xy: Vec<[f64; 2]>,
    /// Headings, rad (unwrapped), one per plan sample, when the run recorded them.
    pub heading: Option<Vec<f64>>,
}

/// Mean trajectory over runs with a two-sided confidence band (Student t over runs, at each
/// sample time, per coordinate).
#[derive(Clone, Debug, PartialEq)]
pub struct MeanTrajectory {
    /// Mean position at each sample, m.
    pub mean: Vec<[f64; 2]>,
    /// Half-width of the band in x and y at each sample, m (0 for a single run).
    pub half_width: Vec<[f64; 2]>,
    /// Mean heading at each sample when every run has headings, rad.
    pub heading: Option<Vec<f64>>,
}

/// A circle fitted to points (geometric least squares).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Circle {
    /// Centre, m.
    pub center: [f64; 2],
    /// Radius, m.
    pub radius: f64,
    /// RMS radial residual of the points, m.
    pub rms_residual: f64,
}

/// The metrics of a set of runs against a plan. Distances in m, angles in rad.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Metrics {
    /// Number of runs.
    pub runs: usize,
    /// Length of the planned path, m.
    pub path_length_m: f64,
    /// Duration of the plan, s.
    pub duration_s: f64,
    /// Largest distance of any run's point from the planned path (nearest point), m.
    pub max_deviation_m: f64,
    /// The same, in % of the planned path length (paper 000: ≤ 7 % at low speed).
    pub max_deviation_pct_of_path: f64,
    /// RMS distance from the planned path over all runs and samples, m.
    pub rms_deviation_m: f64,
    /// Largest time-aligned error |run(t) − plan(t)|, m (includes being late or early).
    pub max_tracking_error_m: f64,
    /// Mean over runs of the end-point error |run(T) − plan(T)|, m.
    pub end_point_error_m: f64,
    /// Largest end-point error of any run, m.
    pub max_end_point_error_m: f64,
    /// Largest |heading − planned heading| over runs and samples, rad (when runs have headings).
    pub max_heading_error_rad: Option<f64>,
    /// Largest distance of the mean trajectory from the planned path, m.
    pub mean_max_deviation_m: f64,
    /// Largest distance of any run from the mean trajectory at the same time, m (repeatability;
    /// paper 000 saw up to 0.110 m).
    pub max_deviation_from_mean_m: f64,
    /// RMS distance of the runs' end points from their mean, m.
    pub end_point_spread_m: f64,
    /// Largest half-width of the 95 % band (norm of the x and y half-widths), m.
    pub ci95_max_half_width_m: f64,
    /// Circle fitted to the plan (when the plan is a circle: residual < 1 % of the radius).
    pub planned_circle: Option<Circle>,
    /// Circle fitted to the mean trajectory (when the plan is a circle).
    pub fitted_circle: Option<Circle>,
    /// Fitted radius of the mean trajectory / planned radius (paper 000: 1.4 at 0.4 m/s, 1.6 at
    /// 0.5 m/s).
    pub radius_ratio: Option<f64>,
}

/// `a − b` folded into (−π, π]: headings that differ by whole turns are equal.
pub fn angle_diff(a: f64, b: f64) -> f64 {
    let d = a - b;
    d - core::f64::consts::TAU * (d / core::f64::consts::TAU).round()
}

/// The plan as seen by a tracker that follows a point at the horizontal `offset` (robot frame,
/// m) from the robot centre: each planned position moved by the offset rotated with the
/// planned heading. Metrics of tracked runs are computed against this path.
pub fn tracked_reference(plan: &Plan, offset: [f64; 2]) -> Plan {
    let mut out = plan.clone();
    for s in &mut out.samples {
        let (sn, cs) = s.pose.heading.sin_cos();
        s.pose.x += cs * offset[0] - sn * offset[1];
        s.pose.y += sn * offset[0] + cs * offset[1];
    }
    out
}

/// Two-sided Student-t quantile for `level` (e.g. 0.95) with `n − 1` degrees of freedom.
pub fn t_quantile(level: f64, n: usize) -> f64 {
    if n < 2 {
        return f64::NAN;
    }
    StudentsT::new(0.0, 1.0, (n - 1) as f64)
        .map(|d| d.inverse_cdf(0.5 + level / 2.0))
        .unwrap_or(f64::NAN)
}

/// Mean trajectory and its `level` confidence band over `runs` (all on the same time grid).
pub fn mean_trajectory(runs: &[Run], level: f64) -> MeanTrajectory {
    let n = runs.len();
    let len = runs.first().map_or(0, |r| r.xy.len());
    let tq = t_quantile(level, n);
    let mut mean = Vec::with_capacity(len);
    let mut half = Vec::with_capacity(len);
    for k in 0..len {
        let mut m = [0.0; 2];
        for r in runs {
            m[0] += r.xy[k][0];
            m[1] += r.xy[k][1];
        }
        m = m.map(|v| v / n as f64);
        let mut h = [0.0; 2];
        if n >= 2 {
            for c in 0..2 {
                let var: f64 = runs
                    .iter()
                    .map(|r| (r.xy[k][c] - m[c]).powi(2))
                    .sum::<f64>()
                    / (n - 1) as f64;
                h[c] = tq * (var / n as f64).sqrt();
            }
        }
        mean.push(m);
        half.push(h);
    }
    let heading = if n > 0 && runs.iter().all(|r| r.heading.is_some()) {
        Some(
            (0..len)
                .map(|k| {
                    runs.iter()
                        .map(|r| r.heading.as_ref().map_or(0.0, |h| h[k]))
                        .sum::<f64>()
                        / n as f64
                })
                .collect(),
        )
    } else {
        None
    };
    MeanTrajectory {
        mean,
        half_width: half,
        heading,
    }
}

/// Distance from `p` to the polyline through `path` (nearest point on any segment), m.
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
pub fn fit_circle(points: &[[f64; 2]]) -> Option<Circle> {
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
    (r.is_finite() && r > 0.0).then_some(Circle {
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

/// Evaluates `runs` against `plan` (all runs sampled at the plan's sample times).
pub fn evaluate(plan: &Plan, runs: &[Run]) -> Metrics {
    let path: Vec<[f64; 2]> = plan.samples.iter().map(|s| [s.pose.x, s.pose.y]).collect();
    let length = plan.path_length();
    let mean = mean_trajectory(runs, 0.95);
    let (mut max_dev, mut sum_sq, mut count, mut max_track, mut max_head) =
        (0.0f64, 0.0f64, 0usize, 0.0f64, None::<f64>);
    let (mut end_sum, mut end_max) = (0.0f64, 0.0f64);
    let mut max_from_mean = 0.0f64;
    let last = path.len().saturating_sub(1);
    for r in runs {
        for (k, p) in r.xy.iter().enumerate() {
            let d = distance_to_path(*p, &path);
            max_dev = max_dev.max(d);
            sum_sq += d * d;
            count += 1;
            max_track = max_track.max((p[0] - path[k][0]).hypot(p[1] - path[k][1]));
            max_from_mean =
                max_from_mean.max((p[0] - mean.mean[k][0]).hypot(p[1] - mean.mean[k][1]));
        }
        if let Some(h) = &r.heading {
            let e = h
                .iter()
                .zip(&plan.samples)
                .map(|(h, s)| angle_diff(*h, s.pose.heading).abs())
                .fold(0.0, f64::max);
            max_head = Some(max_head.map_or(e, |m: f64| m.max(e)));
        }
        if let Some(p) = r.xy.last() {
            let e = (p[0] - path[last][0]).hypot(p[1] - path[last][1]);
            end_sum += e;
            end_max = end_max.max(e);
        }
    }
    let n = runs.len().max(1) as f64;
    let end_mean = {
        let mut m = [0.0; 2];
        for r in runs {
            if let Some(p) = r.xy.last() {
                m[0] += p[0] / n;
                m[1] += p[1] / n;
            }
        }
        m
    };
    let spread = (runs
        .iter()
        .filter_map(|r| r.xy.last())
        .map(|p| (p[0] - end_mean[0]).powi(2) + (p[1] - end_mean[1]).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let mean_max_dev = mean
        .mean
        .iter()
        .map(|p| distance_to_path(*p, &path))
        .fold(0.0, f64::max);
    let ci = mean
        .half_width
        .iter()
        .map(|h| h[0].hypot(h[1]))
        .fold(0.0, f64::max);
    let planned_circle =
        fit_circle(&path).filter(|c| c.rms_residual < 0.01 * c.radius && length > 3.0 * c.radius);
    let fitted_circle = planned_circle.and_then(|_| fit_circle(&mean.mean));
    let radius_ratio = match (planned_circle, fitted_circle) {
        (Some(p), Some(f)) => Some(f.radius / p.radius),
        _ => None,
    };
    Metrics {
        runs: runs.len(),
        path_length_m: length,
        duration_s: plan.duration(),
        max_deviation_m: max_dev,
        max_deviation_pct_of_path: if length > 0.0 {
            100.0 * max_dev / length
        } else {
            0.0
        },
        rms_deviation_m: if count > 0 {
            (sum_sq / count as f64).sqrt()
        } else {
            0.0
        },
        max_tracking_error_m: max_track,
        end_point_error_m: end_sum / n,
        max_end_point_error_m: end_max,
        max_heading_error_rad: max_head,
        mean_max_deviation_m: mean_max_dev,
        max_deviation_from_mean_m: max_from_mean,
        end_point_spread_m: spread,
        ci95_max_half_width_m: ci,
        planned_circle,
        fitted_circle,
        radius_ratio,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_quantiles_match_tables() {
        // Two-sided 95 %: df 1 → 12.706, df 2 → 4.303, df 9 → 2.262, df 29 → 2.045.
        for (n, q) in [(2, 12.706), (3, 4.303), (10, 2.262), (30, 2.045)] {
            assert!((t_quantile(0.95, n) - q).abs() < 1e-3, "n {n}");
        }
        assert!(t_quantile(0.95, 1).is_nan());
    }

    #[test]
    fn circle_fit_recovers_a_noisy_arc() {
        let pts: Vec<[f64; 2]> = (0..200)
            .map(|k| {
                let a = k as f64 * 0.02;
                let r = 0.3 + 0.001 * ((k * 7919) % 13) as f64 / 13.0;
                [1.0 + r * a.cos(), -2.0 + r * a.sin()]
            })
            .collect();
        let c = fit_circle(&pts).unwrap();
        assert!((c.radius - 0.3005).abs() < 1e-3, "{c:?}");
        assert!(
            (c.center[0] - 1.0).abs() < 1e-3 && (c.center[1] + 2.0).abs() < 1e-3,
            "{c:?}"
        );
        assert!(fit_circle(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]).is_none());
    }

    #[test]
    fn distance_to_a_polyline() {
        let path = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
        assert!((distance_to_path([0.5, 0.2], &path) - 0.2).abs() < 1e-15);
        assert!((distance_to_path([1.5, 0.5], &path) - 0.5).abs() < 1e-15);
        assert!((distance_to_path([-3.0, 4.0], &path) - 5.0).abs() < 1e-15);
    }

    #[test]
    fn band_half_width_is_t_times_standard_error() {
        let runs: Vec<Run> = [0.0, 1.0, 2.0]
            .iter()
            .map(|&x| Run {
                xy: vec![[x, -x]],
                heading: None,
            })
            .collect();
        let m = mean_trajectory(&runs, 0.95);
        assert_eq!(m.mean[0], [1.0, -1.0]);
        // s = 1, n = 3: 4.303 / √3.
        assert!((m.half_width[0][0] - 4.302653 / 3f64.sqrt()).abs() < 1e-5);
    }
}
