//! Statistics over runs on one time grid: the two-sided Student-t quantile and the mean
//! trajectory with its confidence band (paper 000, §6: the mean of three runs with a 95 %
//! band).

use statrs::distribution::{ContinuousCDF, StudentsT};

use super::Run;

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
