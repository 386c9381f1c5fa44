//! The paper's evaluation metrics (paper 000, §6): deviation from the planned path (m and % of
//! the distance travelled), mean trajectory with a 95 % confidence band, fitted circle radius,
//! repeatability across runs.
//!
//! Every metric is O(n log n) or better in the number of samples per run (nearest-segment
//! distances through [`PathIndex`]), and [`Evaluator`] computes them in two streaming passes
//! over the runs, so a Monte Carlo of any size needs memory for one run at a time.
//!
//! This module holds what the metrics are ([`Run`], [`Metrics`], [`MetricsError`]) and the
//! comparison of headings and tracked points ([`angle_diff`], [`tracked_reference`]); the
//! streaming evaluation is in `evaluator`, the mean trajectory and Student-t band in `stats`,
//! the path distance and circle fit in `geometry`.

mod evaluator;
mod geometry;
mod stats;

pub use crate::path_index::PathIndex;
pub use evaluator::{Evaluation, Evaluator, RunDistances, SecondPass, evaluate};
pub use geometry::{FittedCircle, distance_to_path, fit_circle};
pub use stats::{MeanTrajectory, mean_trajectory, t_quantile};

use omnikin_plan::Plan;
use serde::Serialize;

/// One run's positions (and headings, when known) on the plan's time grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// Positions, m, world frame, one per plan sample.
    pub xy: Vec<[f64; 2]>,
    /// Headings, rad (unwrapped), one per plan sample, when the run recorded them.
    pub heading: Option<Vec<f64>>,
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
    pub planned_circle: Option<FittedCircle>,
    /// Circle fitted to the mean trajectory (when the plan is a circle).
    pub fitted_circle: Option<FittedCircle>,
    /// Fitted radius of the mean trajectory / planned radius (paper 000: 1.4 at 0.4 m/s, 1.6 at
    /// 0.5 m/s).
    pub radius_ratio: Option<f64>,
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

#[cfg(test)]
mod tests;
