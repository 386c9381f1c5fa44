//! The pose residuals of each run against time, before and after the fit: what `omnikin
//! identify --plot` draws and `omnikin.identify` returns, so that a reader sees where in a run
//! the prior robot drifted from the reference and whether the estimate explains it.
//!
//! "Before" is the prior robot dead-reckoned from the start pose that best fits it (the start
//! poses alone fitted, the geometry and gyro held at the prior), so a start misalignment is
//! not mistaken for a geometry error; "after" is the estimate from its fitted start pose.
//! Each residual is the dead-reckoned minus the reference pose at a reference time inside the
//! encoder log, as in [`super::model::pose_residuals`], but unweighted (m, rad).

use omnikin::{Pose2, Robot};

use super::model::{dead_reckon, pose_at};
use super::runs::LoggedRun;

/// A run's pose residuals at the reference times inside its encoder log.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseResiduals {
    /// Reference times, s.
    pub t: Vec<f64>,
    /// Dead-reckoned minus reference position `(Δx, Δy)`, m (world frame).
    pub position: Vec<[f64; 2]>,
    /// Dead-reckoned minus reference heading, wrapped into (−π, π], rad (references with a
    /// heading).
    pub heading: Option<Vec<f64>>,
}

impl PoseResiduals {
    /// The residuals of `run` dead-reckoned by `robot` from `start`; `None` when the
    /// kinematics refuse the log.
    pub fn of(robot: &Robot<f64>, run: &LoggedRun, start: Pose2<f64>) -> Option<Self> {
        let poses = dead_reckon(robot, &run.encoders, start)?;
        let r = &run.reference;
        let mut out = Self {
            t: Vec::new(),
            position: Vec::new(),
            heading: r.heading.as_ref().map(|_| Vec::new()),
        };
        for (k, &time) in r.t.iter().enumerate() {
            let Some(p) = pose_at(&run.encoders.t, &poses, time) else {
                continue;
            };
            out.t.push(time);
            out.position.push([p.x - r.xy[k][0], p.y - r.xy[k][1]]);
            if let (Some(h), Some(o)) = (&r.heading, &mut out.heading) {
                o.push(omnikin::wrap_angle(p.heading - h[k]));
            }
        }
        Some(out)
    }

    /// RMS of the position residuals' lengths, m (0 without residuals).
    pub fn position_rms(&self) -> f64 {
        if self.position.is_empty() {
            return 0.0;
        }
        let s: f64 = self
            .position
            .iter()
            .map(|p| p[0] * p[0] + p[1] * p[1])
            .sum();
        (s / self.position.len() as f64).sqrt()
    }
}

/// One run's residuals before and after the fit.
#[derive(Clone, Debug, PartialEq)]
pub struct RunResiduals {
    /// The run's encoder log (file name as given).
    pub encoders: String,
    /// The run's reference (fixes or tracked run, file name as given).
    pub reference: String,
    /// The prior robot, from its best start pose.
    pub before: PoseResiduals,
    /// The estimate, from its fitted start pose.
    pub after: PoseResiduals,
}
