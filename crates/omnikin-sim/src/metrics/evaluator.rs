//! The streaming evaluation of runs against a plan: [`Evaluator`] (first pass: distances to
//! the plan, tracking, end-point and heading errors, sums for the mean) and [`SecondPass`]
//! (spread around the mean, band, fitted circle) into an [`Evaluation`]; [`evaluate`] runs
//! both passes over a slice. Nearest-segment queries go through [`PathIndex`], in parallel
//! over chunks of samples.

use omnikin_plan::Plan;

use super::geometry::fit_circle;
use super::stats::{MeanTrajectory, t_quantile};
use super::{Metrics, MetricsError, PathIndex, Run, angle_diff};

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
pub(super) const QUERY_CHUNK: usize = 4096;

/// Distance from each of `points` to the path of `index` with its nearest segment, in
/// order; parallel over chunks of points, the same values as one query after another.
pub(super) fn nearest_all(index: &PathIndex, points: &[[f64; 2]]) -> Vec<(f64, usize)> {
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

/// Largest distance of `points` from the path of `index` (0 for none): parallel over chunks
/// of points, each by [`PathIndex::farthest`]; the same value as the largest of one query
/// after another.
pub(super) fn max_distance(index: &PathIndex, points: &[[f64; 2]]) -> f64 {
    use rayon::prelude::*;
    if points.len() <= QUERY_CHUNK {
        return index.farthest(points);
    }
    points
        .par_chunks(QUERY_CHUNK)
        .map(|c| index.farthest(c))
        .reduce(|| 0.0, f64::max)
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
