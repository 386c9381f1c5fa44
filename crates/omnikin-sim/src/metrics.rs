//! The paper's evaluation metrics (paper 000, §6): deviation from the planned path (m and % of
//! the distance travelled), mean trajectory with a 95 % confidence band, fitted circle radius,
//! repeatability across runs.
//!
//! Every metric is O(n log n) or better in the number of samples per run (nearest-segment
//! distances through [`PathIndex`]), and [`Evaluator`] computes them in two streaming passes
//! over the runs, so a Monte Carlo of any size needs memory for one run at a time.

use omnikin_plan::Plan;
use serde::Serialize;

pub use crate::path_index::PathIndex;
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
    /// The reverse of `max_deviation_m`: largest distance of a planned point from the nearest
    /// point of a run's path (max over runs), m. A run that stops short, never moves or skips
    /// part of the path stays near the path (small `max_deviation_m`) but leaves planned
    /// points far from it: this catches it without timing (the larger of the two is the
    /// Hausdorff distance between a run and the plan).
    pub max_plan_distance_from_run_m: f64,
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

/// `a − b` (rad) folded into `(−π, π]` by [`omnikin::wrap_angle`]: headings that differ by
/// whole turns are equal, and a half-turn difference is `+π` whichever way round.
pub fn angle_diff(a: f64, b: f64) -> f64 {
    omnikin::wrap_angle(a - b)
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
///
/// Scans every segment: O(n) for one point. For many points against one path use
/// [`PathIndex`], which gives the same value bit for bit (this function is its test oracle).
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

/// Metrics that could not be computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MetricsError {
    /// A run does not have one position per plan sample.
    #[error(
        "run {run} has {len} positions but the plan has {samples} samples (runs must be resampled onto the plan's time grid)"
    )]
    Length {
        /// 0-based run index.
        run: usize,
        /// Positions (or headings) in the run.
        len: usize,
        /// Samples in the plan.
        samples: usize,
    },
    /// A metric came out NaN or infinite.
    #[error("metric {metric} is {value}: {why}")]
    NonFinite {
        /// The metric's name (as in `metrics.json`).
        metric: &'static str,
        /// Its value.
        value: f64,
        /// Why that happens.
        why: &'static str,
    },
}

impl Metrics {
    /// Every number of the metrics with its name (as in `metrics.json`).
    pub fn values(&self) -> Vec<(&'static str, f64)> {
        let mut v = vec![
            ("path_length_m", self.path_length_m),
            ("duration_s", self.duration_s),
            ("max_deviation_m", self.max_deviation_m),
            ("max_deviation_pct_of_path", self.max_deviation_pct_of_path),
            ("rms_deviation_m", self.rms_deviation_m),
            (
                "max_plan_distance_from_run_m",
                self.max_plan_distance_from_run_m,
            ),
            ("max_tracking_error_m", self.max_tracking_error_m),
            ("end_point_error_m", self.end_point_error_m),
            ("max_end_point_error_m", self.max_end_point_error_m),
            ("mean_max_deviation_m", self.mean_max_deviation_m),
            ("max_deviation_from_mean_m", self.max_deviation_from_mean_m),
            ("end_point_spread_m", self.end_point_spread_m),
            ("ci95_max_half_width_m", self.ci95_max_half_width_m),
        ];
        if let Some(h) = self.max_heading_error_rad {
            v.push(("max_heading_error_rad", h));
        }
        for (name, c) in [
            ("planned_circle", self.planned_circle),
            ("fitted_circle", self.fitted_circle),
        ] {
            if let Some(c) = c {
                let names: [&'static str; 4] = if name == "planned_circle" {
                    [
                        "planned_circle.center[0]",
                        "planned_circle.center[1]",
                        "planned_circle.radius",
                        "planned_circle.rms_residual",
                    ]
                } else {
                    [
                        "fitted_circle.center[0]",
                        "fitted_circle.center[1]",
                        "fitted_circle.radius",
                        "fitted_circle.rms_residual",
                    ]
                };
                v.extend(names.into_iter().zip([
                    c.center[0],
                    c.center[1],
                    c.radius,
                    c.rms_residual,
                ]));
            }
        }
        if let Some(r) = self.radius_ratio {
            v.push(("radius_ratio", r));
        }
        v
    }

    /// `Ok` when every metric is a finite number; otherwise the first that is not, and why
    /// (JSON has no NaN: it would be written as `null` and read as "no value").
    pub fn check_finite(&self) -> Result<(), MetricsError> {
        match self.values().into_iter().find(|(_, v)| !v.is_finite()) {
            None => Ok(()),
            Some((metric, value)) => Err(MetricsError::NonFinite {
                metric,
                value,
                why: if value.is_nan() {
                    "an undefined result (such as ∞ − ∞) of values that overflowed: \
                     coordinates, offsets or times so large (|x| beyond about 1e154) that \
                     their squares overflow"
                } else {
                    "a distance or a sum overflowed: coordinates, offsets or times so large \
                     (|x| beyond about 1e154) that their squares overflow"
                },
            }),
        }
    }
}

/// Metrics and the mean trajectory (95 % band) of a set of runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// The metrics.
    pub metrics: Metrics,
    /// The mean trajectory with its 95 % band.
    pub mean: MeanTrajectory,
}

/// Evaluates runs against a plan in two passes over the runs, **in the same order** both
/// times, without holding them: [`Evaluator::add`] every run, [`Evaluator::second_pass`], then
/// [`SecondPass::add`] every run's positions again and [`SecondPass::finish`]. Memory is
/// O(plan samples), whatever the number of runs; the result depends only on the runs and
/// their order (never on threads). [`evaluate`] does both passes over a slice.
///
/// Cost per run: O(n log n) for n samples (nearest-segment queries through [`PathIndex`]).
#[derive(Clone, Debug)]
pub struct Evaluator {
    path: Vec<[f64; 2]>,
    index: PathIndex,
    plan_heading: Vec<f64>,
    length: f64,
    duration: f64,
    runs: usize,
    sum: Vec<[f64; 2]>,
    heading_sum: Option<Vec<f64>>,
    ends: Vec<[f64; 2]>,
    max_dev: f64,
    sum_sq: f64,
    count: usize,
    max_track: f64,
    max_head: Option<f64>,
    end_sum: f64,
    end_max: f64,
    max_unreached: f64,
}

/// The nearest-segment distances of one run, from [`Evaluator::distances`].
#[derive(Clone, Debug)]
pub struct RunDistances {
    to_plan: Vec<f64>,
    plan_from_run: f64,
}

/// Samples per parallel chunk of nearest-segment queries (each chunk seeds its first query
/// afresh, then with the previous answer).
const QUERY_CHUNK: usize = 4096;

/// Distance from each of `points` to the path of `index` with its nearest segment, in
/// order; parallel over chunks of points, the same values as one query after another.
fn nearest_all(index: &PathIndex, points: &[[f64; 2]]) -> Vec<(f64, usize)> {
    use rayon::prelude::*;
    let chunk = |c: &[[f64; 2]]| {
        let mut hint = 0;
        c.iter()
            .map(|p| {
                let r = index.nearest(*p, hint);
                hint = r.1;
                r
            })
            .collect::<Vec<_>>()
    };
    if points.len() <= QUERY_CHUNK {
        return chunk(points);
    }
    points
        .par_chunks(QUERY_CHUNK)
        .map(chunk)
        .collect::<Vec<_>>()
        .concat()
}

/// Largest distance of `points` from the path of `index` (0 for none).
fn max_distance(index: &PathIndex, points: &[[f64; 2]]) -> f64 {
    nearest_all(index, points)
        .into_iter()
        .fold(0.0, |m, (d, _)| m.max(d))
}

/// The second pass of an [`Evaluator`]: the mean is known; the spread around it is summed.
#[derive(Clone, Debug)]
pub struct SecondPass {
    first: Evaluator,
    mean: Vec<[f64; 2]>,
    heading: Option<Vec<f64>>,
    var_sum: Vec<[f64; 2]>,
    max_from_mean: f64,
    seen: usize,
}

impl Evaluator {
    /// An evaluator of runs of `plan` (each run has one position per plan sample).
    pub fn new(plan: &Plan) -> Self {
        let path: Vec<[f64; 2]> = plan.samples.iter().map(|s| [s.pose.x, s.pose.y]).collect();
        let n = path.len();
        Self {
            index: PathIndex::new(&path),
            path,
            plan_heading: plan.samples.iter().map(|s| s.pose.heading).collect(),
            length: plan.path_length(),
            duration: plan.duration(),
            runs: 0,
            sum: vec![[0.0; 2]; n],
            // The mean heading is summed like `Iterator::sum` (which starts at −0.0).
            heading_sum: Some(vec![-0.0; n]),
            ends: Vec::new(),
            max_dev: 0.0,
            sum_sq: 0.0,
            count: 0,
            max_track: 0.0,
            max_head: None,
            end_sum: 0.0,
            end_max: 0.0,
            max_unreached: 0.0,
        }
    }

    /// Adds the next run (first pass).
    pub fn add(&mut self, run: &Run) -> Result<(), MetricsError> {
        let d = self.distances(&run.xy);
        self.add_with(run, d)
    }

    /// The nearest-segment distances of a run's positions `xy`: the part of
    /// [`Evaluator::add`] that depends on the run alone, so it can run in parallel for several
    /// runs (and runs in parallel over chunks of samples itself). Pass the result to
    /// [`Evaluator::add_with`] with the same run.
    pub fn distances(&self, xy: &[[f64; 2]]) -> RunDistances {
        RunDistances {
            to_plan: nearest_all(&self.index, xy)
                .into_iter()
                .map(|(d, _)| d)
                .collect(),
            // The reverse: how far the plan gets from the run's path (stopping short,
            // skipping); 0 for a run without positions.
            plan_from_run: if xy.is_empty() {
                0.0
            } else {
                max_distance(&PathIndex::new(xy), &self.path)
            },
        }
    }

    /// Adds the next run (first pass) with its [`Evaluator::distances`].
    pub fn add_with(&mut self, run: &Run, distances: RunDistances) -> Result<(), MetricsError> {
        let samples = self.path.len();
        let run_index = self.runs;
        let bad = |len: usize| MetricsError::Length {
            run: run_index,
            len,
            samples,
        };
        if run.xy.len() != samples || distances.to_plan.len() != samples {
            return Err(bad(run.xy.len()));
        }
        if let Some(h) = &run.heading
            && h.len() != samples
        {
            return Err(bad(h.len()));
        }
        self.runs += 1;
        for (k, (p, &d)) in run.xy.iter().zip(&distances.to_plan).enumerate() {
            self.max_dev = self.max_dev.max(d);
            self.sum_sq += d * d;
            self.count += 1;
            let q = self.path[k];
            self.max_track = self.max_track.max((p[0] - q[0]).hypot(p[1] - q[1]));
            self.sum[k][0] += p[0];
            self.sum[k][1] += p[1];
        }
        self.max_unreached = self.max_unreached.max(distances.plan_from_run);
        match (&run.heading, self.heading_sum.as_mut()) {
            (Some(h), Some(sum)) => {
                let e = h
                    .iter()
                    .zip(&self.plan_heading)
                    .map(|(h, p)| angle_diff(*h, *p).abs())
                    .fold(0.0, f64::max);
                self.max_head = Some(self.max_head.map_or(e, |m: f64| m.max(e)));
                for (s, h) in sum.iter_mut().zip(h) {
                    *s += h;
                }
            }
            (Some(h), None) => {
                let e = h
                    .iter()
                    .zip(&self.plan_heading)
                    .map(|(h, p)| angle_diff(*h, *p).abs())
                    .fold(0.0, f64::max);
                self.max_head = Some(self.max_head.map_or(e, |m: f64| m.max(e)));
            }
            (None, _) => self.heading_sum = None,
        }
        if let (Some(p), Some(q)) = (run.xy.last(), self.path.last()) {
            let e = (p[0] - q[0]).hypot(p[1] - q[1]);
            self.end_sum += e;
            self.end_max = self.end_max.max(e);
            self.ends.push(*p);
        }
        Ok(())
    }

    /// Number of runs added so far.
    pub fn runs(&self) -> usize {
        self.runs
    }

    /// Ends the first pass: the mean trajectory is known from here on.
    pub fn second_pass(self) -> SecondPass {
        let n = self.runs as f64;
        let mean: Vec<[f64; 2]> = self.sum.iter().map(|m| m.map(|v| v / n)).collect();
        let heading = match (&self.heading_sum, self.runs) {
            (Some(h), 1..) => Some(h.iter().map(|s| s / n).collect()),
            _ => None,
        };
        let len = if self.runs == 0 { 0 } else { mean.len() };
        SecondPass {
            var_sum: vec![[0.0; 2]; len],
            mean: mean.into_iter().take(len).collect(),
            heading,
            max_from_mean: 0.0,
            seen: 0,
            first: self,
        }
    }
}

impl SecondPass {
    /// The mean trajectory, m (one position per plan sample; empty without runs).
    pub fn mean(&self) -> &[[f64; 2]] {
        &self.mean
    }

    /// Adds the positions of the next run again, in the first pass's order.
    pub fn add(&mut self, xy: &[[f64; 2]]) -> Result<(), MetricsError> {
        if xy.len() != self.mean.len() {
            return Err(MetricsError::Length {
                run: self.seen,
                len: xy.len(),
                samples: self.first.path.len(),
            });
        }
        self.seen += 1;
        for ((p, m), v) in xy.iter().zip(&self.mean).zip(&mut self.var_sum) {
            self.max_from_mean = self.max_from_mean.max((p[0] - m[0]).hypot(p[1] - m[1]));
            for c in 0..2 {
                v[c] += (p[c] - m[c]).powi(2);
            }
        }
        Ok(())
    }

    /// The metrics and the mean trajectory. Every run of the first pass must have been added
    /// again.
    pub fn finish(self) -> Result<Evaluation, MetricsError> {
        let f = self.first;
        if self.seen != f.runs {
            return Err(MetricsError::Length {
                run: self.seen,
                len: 0,
                samples: f.path.len(),
            });
        }
        let n_runs = f.runs;
        let tq = t_quantile(0.95, n_runs);
        let half_width: Vec<[f64; 2]> = self
            .var_sum
            .iter()
            .map(|v| {
                if n_runs >= 2 {
                    v.map(|s| tq * (s / (n_runs - 1) as f64 / n_runs as f64).sqrt())
                } else {
                    [0.0; 2]
                }
            })
            .collect();
        let n = n_runs.max(1) as f64;
        let end_mean = {
            let mut m = [0.0; 2];
            for p in &f.ends {
                m[0] += p[0] / n;
                m[1] += p[1] / n;
            }
            m
        };
        let spread = (f
            .ends
            .iter()
            .map(|p| (p[0] - end_mean[0]).powi(2) + (p[1] - end_mean[1]).powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        let mean_max_dev = max_distance(&f.index, &self.mean);
        let ci = half_width
            .iter()
            .map(|h| h[0].hypot(h[1]))
            .fold(0.0, f64::max);
        let length = f.length;
        let planned_circle = fit_circle(&f.path)
            .filter(|c| c.rms_residual < 0.01 * c.radius && length > 3.0 * c.radius);
        let fitted_circle = planned_circle.and_then(|_| fit_circle(&self.mean));
        let radius_ratio = match (planned_circle, fitted_circle) {
            (Some(p), Some(f)) => Some(f.radius / p.radius),
            _ => None,
        };
        let metrics = Metrics {
            runs: n_runs,
            path_length_m: length,
            duration_s: f.duration,
            max_deviation_m: f.max_dev,
            max_deviation_pct_of_path: if length > 0.0 {
                100.0 * f.max_dev / length
            } else {
                0.0
            },
            rms_deviation_m: if f.count > 0 {
                (f.sum_sq / f.count as f64).sqrt()
            } else {
                0.0
            },
            max_plan_distance_from_run_m: f.max_unreached,
            max_tracking_error_m: f.max_track,
            end_point_error_m: f.end_sum / n,
            max_end_point_error_m: f.end_max,
            max_heading_error_rad: f.max_head,
            mean_max_deviation_m: mean_max_dev,
            max_deviation_from_mean_m: self.max_from_mean,
            end_point_spread_m: spread,
            ci95_max_half_width_m: ci,
            planned_circle,
            fitted_circle,
            radius_ratio,
        };
        Ok(Evaluation {
            metrics,
            mean: MeanTrajectory {
                mean: self.mean,
                half_width,
                heading: self.heading,
            },
        })
    }
}

/// Evaluates `runs` against `plan` (every run sampled at the plan's sample times): both passes
/// of an [`Evaluator`] over the slice. O(r · n log n) for r runs of n samples.
pub fn evaluate(plan: &Plan, runs: &[Run]) -> Result<Evaluation, MetricsError> {
    let mut e = Evaluator::new(plan);
    for r in runs {
        e.add(r)?;
    }
    let mut e = e.second_pass();
    for r in runs {
        e.add(&r.xy)?;
    }
    e.finish()
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
    /// The evaluation before the path index and the streaming passes: every sample against
    /// every segment. The oracle of the property tests.
    fn evaluate_quadratic(plan: &Plan, runs: &[Run]) -> (Metrics, MeanTrajectory) {
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
        let planned_circle = fit_circle(&path)
            .filter(|c| c.rms_residual < 0.01 * c.radius && length > 3.0 * c.radius);
        let fitted_circle = planned_circle.and_then(|_| fit_circle(&mean.mean));
        let radius_ratio = match (planned_circle, fitted_circle) {
            (Some(p), Some(f)) => Some(f.radius / p.radius),
            _ => None,
        };
        (
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
                max_plan_distance_from_run_m: runs
                    .iter()
                    .flat_map(|r| path.iter().map(|q| distance_to_path(*q, &r.xy)))
                    .fold(0.0, f64::max),
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
            },
            mean,
        )
    }

    use omnikin::{Pose2, Twist2};
    use omnikin_plan::Sample;
    use proptest::prelude::*;

    fn plan_of(xy: &[[f64; 2]]) -> Plan {
        Plan {
            samples: xy
                .iter()
                .enumerate()
                .map(|(k, p)| Sample {
                    t: 0.01 * k as f64,
                    pose: Pose2::new(p[0], p[1], 0.1 * k as f64),
                    twist: Twist2::new(0.0, 0.0, 0.0),
                    wheel_rates: [0.0; 3],
                    steer: None,
                })
                .collect(),
        }
    }

    /// Paths the metrics meet: random walks (with repeated points and spikes), and circles of
    /// several laps (points nearly equidistant from many segments), at any scale and offset.
    fn path_strategy() -> impl Strategy<Value = Vec<[f64; 2]>> {
        let walk = (
            prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0, 0u8..8), 1..400),
            -3i32..4,
            prop_oneof![-1e3f64..1e3, -1e7f64..1e7],
        )
            .prop_map(|(steps, e, off)| {
                let scale = 10f64.powi(e);
                let mut p = [off, -off];
                steps
                    .into_iter()
                    .map(|(dx, dy, kind)| {
                        match kind {
                            0 => {}                                    // repeated point
                            1 => p = [p[0] + 50.0 * dx * scale, p[1]], // spike
                            _ => p = [p[0] + dx * scale, p[1] + dy * scale],
                        }
                        p
                    })
                    .collect()
            });
        let circle =
            (3usize..600, 1usize..4, 0.01f64..100.0, -10.0f64..10.0).prop_map(|(n, laps, r, c)| {
                (0..n * laps)
                    .map(|k| {
                        let a = core::f64::consts::TAU * k as f64 / n as f64;
                        [c + r * a.cos(), c + r * a.sin()]
                    })
                    .collect()
            });
        prop_oneof![walk, circle]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// The index gives the exhaustive scan's distance bit for bit, near the path (where
        /// pruning decides), far from it, on vertices, and at the centre of circles.
        #[test]
        fn path_index_equals_the_exhaustive_scan(
            path in path_strategy(),
            queries in prop::collection::vec((0.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, 0u8..4), 1..60),
            hint in 0usize..1000,
        ) {
            let index = PathIndex::new(&path);
            let span = path.iter().flat_map(|p| p.iter()).fold(0.0f64, |m, c| m.max(c.abs())).max(1e-3);
            let mut h = hint;
            for (f, dx, dy, kind) in queries {
                let v = path[((f * path.len() as f64) as usize).min(path.len() - 1)];
                let q = match kind {
                    0 => v,
                    1 => [v[0] + 1e-3 * span * dx, v[1] + 1e-3 * span * dy],
                    2 => [v[0] + 3.0 * span * dx, v[1] + 3.0 * span * dy],
                    _ => {
                        // The centroid: for a circle, nearly equidistant from every segment.
                        let n = path.len() as f64;
                        [path.iter().map(|p| p[0]).sum::<f64>() / n + 1e-9 * dx,
                         path.iter().map(|p| p[1]).sum::<f64>() / n]
                    }
                };
                let brute = distance_to_path(q, &path);
                let (fast, seg) = index.nearest(q, h);
                prop_assert_eq!(fast.to_bits(), brute.to_bits(), "query {:?}", q);
                prop_assert_eq!(index.distance(q).to_bits(), brute.to_bits());
                h = seg;
            }
        }

        /// The streaming two-pass evaluation equals the quadratic one, every metric bit for
        /// bit, and the mean trajectory and band too.
        #[test]
        fn streaming_evaluation_equals_the_quadratic_one(
            path in path_strategy(),
            noise in prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 1..50),
            runs in 1usize..5,
            lag in 0usize..30,
            headings in any::<bool>(),
        ) {
            let plan = plan_of(&path);
            let n = path.len();
            let runs: Vec<Run> = (0..runs)
                .map(|r| Run {
                    xy: (0..n)
                        .map(|k| {
                            let p = path[k.saturating_sub(r * lag).min(n - 1)];
                            let e = noise[(k + r) % noise.len()];
                            [p[0] + 0.05 * e.0 * (r + 1) as f64, p[1] + 0.05 * e.1]
                        })
                        .collect(),
                    heading: headings.then(|| (0..n).map(|k| 0.1 * k as f64 + 0.01 * r as f64).collect()),
                })
                .collect();
            let (want, want_mean) = evaluate_quadratic(&plan, &runs);
            let got = evaluate(&plan, &runs).unwrap();
            let bits = |m: &Metrics| m.values().into_iter().map(|(k, v)| (k, v.to_bits())).collect::<Vec<_>>();
            prop_assert_eq!(bits(&got.metrics), bits(&want));
            prop_assert_eq!(&got.metrics, &want);
            prop_assert_eq!(&got.mean, &want_mean);
            prop_assert_eq!(&mean_trajectory(&runs, 0.95), &want_mean);
        }
    }

    #[test]
    fn a_run_that_never_moves_is_far_from_the_plan() {
        let path: Vec<[f64; 2]> = (0..=100).map(|k| [0.01 * k as f64, 0.0]).collect();
        let plan = plan_of(&path);
        let still = Run {
            xy: vec![path[0]; path.len()],
            heading: None,
        };
        let m = evaluate(&plan, &[still]).unwrap().metrics;
        // On the path all the time (the paper's deviation is 0) ...
        assert_eq!(m.max_deviation_m, 0.0);
        // ... but the plan's end is 1 m from anything the run did.
        assert!(
            (m.max_plan_distance_from_run_m - 1.0).abs() < 1e-12,
            "{m:?}"
        );
        assert!((m.end_point_error_m - 1.0).abs() < 1e-12);
        // A run that follows the plan covers it.
        let follow = Run {
            xy: path.clone(),
            heading: None,
        };
        let m = evaluate(&plan, &[follow]).unwrap().metrics;
        assert_eq!(m.max_plan_distance_from_run_m, 0.0);
    }

    #[test]
    fn non_finite_metrics_are_named() {
        let path = [[0.0, 0.0], [1e300, 0.0], [-1e300, 1e300]];
        let plan = plan_of(&path);
        let run = Run {
            xy: vec![[1e300, 1e300], [-1e300, -1e300], [1e300, -1e300]],
            heading: None,
        };
        let m = evaluate(&plan, &[run]).unwrap().metrics;
        match m.check_finite() {
            Err(MetricsError::NonFinite { metric, value, why }) => {
                assert!(!value.is_finite());
                assert!(
                    m.values()
                        .iter()
                        .any(|(k, v)| *k == metric && v.to_bits() == value.to_bits())
                );
                assert!(why.contains("overflow"), "{why}");
            }
            other => panic!("{other:?} for {m:?}"),
        }
        let fine = evaluate(
            &plan_of(&[[0.0, 0.0], [1.0, 0.0]]),
            &[Run {
                xy: vec![[0.0, 0.1], [1.0, 0.1]],
                heading: None,
            }],
        )
        .unwrap()
        .metrics;
        assert_eq!(fine.check_finite(), Ok(()));
    }

    #[test]
    fn parallel_chunks_of_queries_equal_the_exhaustive_scan() {
        // More points than one chunk, so several chunks run, each with its own hints.
        let path: Vec<[f64; 2]> = (0..700)
            .map(|k| {
                let a = k as f64 * 0.05;
                [a.cos() * (1.0 + 0.01 * a), a.sin()]
            })
            .collect();
        let points: Vec<[f64; 2]> = (0..3 * QUERY_CHUNK + 17)
            .map(|k| {
                let a = k as f64 * 0.0029;
                [1.1 * a.cos(), 0.9 * a.sin() + 0.001 * (k % 7) as f64]
            })
            .collect();
        let got = nearest_all(&PathIndex::new(&path), &points);
        assert_eq!(got.len(), points.len());
        for (p, (d, _)) in points.iter().zip(got) {
            assert_eq!(d.to_bits(), distance_to_path(*p, &path).to_bits());
        }
    }

    #[test]
    fn runs_off_the_plan_grid_are_refused() {
        let plan = plan_of(&[[0.0, 0.0], [1.0, 0.0]]);
        let short = Run {
            xy: vec![[0.0, 0.0]],
            heading: None,
        };
        assert_eq!(
            evaluate(&plan, &[short]),
            Err(MetricsError::Length {
                run: 0,
                len: 1,
                samples: 2
            })
        );
    }
}
