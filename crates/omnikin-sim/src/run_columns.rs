//! The columns of a simulation's tables, defined once for every front end: `trials.csv` (one
//! row per trial and plan sample) and `mean.csv` (the mean trajectory, its 95 % band and the
//! plan). `omnikin simulate` writes them as CSV; `omnikin.simulate` returns them as columns.

use omnikin_plan::Plan;

use crate::Trial;
use crate::metrics::MeanTrajectory;

/// The columns of `trials.csv` before the encoders: trial index, time (s), pose in the world
/// frame (m, m, rad), the tracked point (m, m) and the least-squares slip residual (m/s).
pub const TRIAL_COLUMNS: [&str; 8] = [
    "trial",
    "t",
    "x",
    "y",
    "heading",
    "tracked_x",
    "tracked_y",
    "slip_residual",
];

/// The columns of `trials.csv` for a robot of `wheels` wheels: [`TRIAL_COLUMNS`], then one
/// encoder column `q1..qN` per wheel (rad, cumulative).
pub fn trial_columns(wheels: usize) -> Vec<String> {
    TRIAL_COLUMNS
        .iter()
        .map(|s| s.to_string())
        .chain((1..=wheels).map(|i| format!("q{i}")))
        .collect()
}

/// Row `k` of trial `i` in the order of [`trial_columns`] (`tr.wheels` encoder values), into
/// `row` (cleared first).
pub fn trial_row(i: usize, tr: &Trial, k: usize, row: &mut Vec<f64>) {
    let wheels = tr.wheels.min(omnikin::MAX_WHEELS);
    let (p, q) = (tr.pose[k], tr.tracked[k]);
    row.clear();
    row.extend([
        i as f64,
        tr.t[k],
        p.x,
        p.y,
        p.heading,
        q[0],
        q[1],
        tr.slip_residual[k],
    ]);
    row.extend_from_slice(&tr.encoder_angles[k][..wheels]);
}

/// The columns of `mean.csv`: time (s), the mean tracked position (m), the 95 % half-widths
/// in x and y (m) and the plan's position (m), all in the world frame.
pub const MEAN_COLUMNS: [&str; 7] = ["t", "x", "y", "x_ci95", "y_ci95", "plan_x", "plan_y"];

/// Row `k` of `mean.csv` in the order of [`MEAN_COLUMNS`].
pub fn mean_row(plan: &Plan, mean: &MeanTrajectory, k: usize) -> [f64; 7] {
    let s = &plan.samples[k];
    let (m, h) = (mean.mean[k], mean.half_width[k]);
    [s.t, m[0], m[1], h[0], h[1], s.pose.x, s.pose.y]
}

/// A CSV line of `values` as the command writes them (Rust's shortest round-trip form; an
/// integral value such as a trial index without a decimal point).
pub fn csv_line(values: &[f64]) -> String {
    let mut s = String::with_capacity(values.len() * 20);
    for (j, v) in values.iter().enumerate() {
        if j > 0 {
            s.push(',');
        }
        s.push_str(&v.to_string());
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_has_one_value_per_column() {
        let mut tr = Trial::with_capacity(3, 1);
        tr.t.push(0.5);
        tr.pose.push(omnikin::Pose2::new(1.0, 2.0, 0.25));
        tr.tracked.push([1.5, 2.5]);
        tr.slip_residual.push(0.0);
        tr.wheel_angles.push([0.0; omnikin::MAX_WHEELS]);
        let mut encoders = [9.0; omnikin::MAX_WHEELS];
        encoders[..3].copy_from_slice(&[0.1, 0.2, 0.3]);
        tr.encoder_angles.push(encoders);
        tr.steer_angles.push([0.0; omnikin::MAX_WHEELS]);
        let mut row = Vec::new();
        trial_row(7, &tr, 0, &mut row);
        assert_eq!(row.len(), trial_columns(3).len());
        assert_eq!(csv_line(&row), "7,0.5,1,2,0.25,1.5,2.5,0,0.1,0.2,0.3");
        assert_eq!(trial_columns(3).last().map(String::as_str), Some("q3"));
    }
}
