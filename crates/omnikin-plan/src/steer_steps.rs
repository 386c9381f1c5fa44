//! A plan's steer angles against its steer rates. The simulator (and any steer motor driven by
//! rate) moves a module by the plan's `sd` columns; a plan whose `s` columns step between two
//! samples by more than those rates account for cannot be followed: a swerve plan re-steering
//! its modules at a stop between two samples (as `omnikin plan` did before it timed a re-steer
//! at rest, or a plan from elsewhere) simulated as if the modules never turned — an
//! ideal-plant square ended 1.6 m from its end point, with exit code 0.

use crate::Plan;

/// Largest accepted distance of a steer-angle step from the range the steer rates allow over
/// its interval, rad (0.57°), on top of that range's own width. The range is `dt` times the
/// rates between the two samples' rates; widened by its width again, it covers a kink of the
/// steer rate between two samples (a spline waypoint) and a coarse plan (5 Hz) whose rates
/// vary within an interval, but not a re-steer at rest (both rates 0: width 0).
pub const MAX_UNEXPLAINED_STEER_STEP: f64 = 1e-2;

/// The unexplained steer step, rad (5.7°), beyond which `simulate` refuses a plan rather than
/// warning: the simulated modules would point elsewhere than planned for the rest of the run.
pub const MAX_SIMULATED_STEER_STEP: f64 = 0.1;

/// A steer step that the plan's steer rates do not explain.
pub struct SteerStep {
    /// 1-based module.
    pub module: usize,
    /// The two sample times, s.
    pub t: (f64, f64),
    /// The step of the angle (wrapped to (−π, π]), rad.
    pub step: f64,
    /// The step the steer rates allow over the interval: `dt` times the two samples' rates,
    /// rad (the step may lie anywhere between them).
    pub by_rates: (f64, f64),
}

impl SteerStep {
    /// Why the plan steps: a re-steer at rest (both samples' steer rates 0), or samples too
    /// far apart for the steering.
    pub fn cause(&self) -> &'static str {
        if self.by_rates == (0.0, 0.0) {
            "the modules are re-steered at a stop without a planned turn (`omnikin plan` \
             times a re-steer at rest before each motion: re-plan the file with it)"
        } else {
            "the samples are too far apart for the steering (plan it at a higher --rate)"
        }
    }
}

impl std::fmt::Display for SteerStep {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let i = self.module;
        write!(
            f,
            "s{i} steps by {:.4} rad between t = {} s and t = {} s, but its steer rate sd{i} \
             accounts for {:.4} to {:.4} rad ({:.0} rad/s would be needed)",
            self.step,
            self.t.0,
            self.t.1,
            self.by_rates.0,
            self.by_rates.1,
            self.step.abs() / (self.t.1 - self.t.0)
        )
    }
}

/// The first interval of `plan` whose steer-angle step lies more than `tolerance` (rad,
/// [`MAX_UNEXPLAINED_STEER_STEP`] or [`MAX_SIMULATED_STEER_STEP`]) plus the range's width
/// outside what its steer rates allow; `None` for a consistent plan or one without steering.
pub fn unexplained_steer_step(plan: &Plan, tolerance: f64) -> Option<SteerStep> {
    let n = plan.wheels;
    plan.samples.windows(2).find_map(|w| {
        let ((ga, gda), (gb, gdb)) = (w[0].steer?, w[1].steer?);
        let dt = w[1].t - w[0].t;
        (0..n).find_map(|i| {
            let step = omnikin::wrap_angle(gb[i] - ga[i]);
            let (lo, hi) = (gda[i].min(gdb[i]) * dt, gda[i].max(gdb[i]) * dt);
            let off = (lo - step).max(step - hi).max(0.0);
            (off > tolerance + (hi - lo)).then_some(SteerStep {
                module: i + 1,
                t: (w[0].t, w[1].t),
                step,
                by_rates: (lo, hi),
            })
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Sample;
    use omnikin::{MAX_WHEELS, Pose2, Twist2};

    /// A two-module plan at 10 Hz whose module 2 steers at `rate` rad/s while its angle
    /// advances by `step` rad per sample.
    fn plan(rate: f64, step: f64) -> Plan {
        let samples = (0..5)
            .map(|k| {
                let mut g = [0.0; MAX_WHEELS];
                let mut gd = [0.0; MAX_WHEELS];
                g[1] = step * k as f64;
                gd[1] = rate;
                Sample {
                    t: 0.1 * k as f64,
                    pose: Pose2::new(0.0, 0.0, 0.0),
                    twist: Twist2::new(0.0, 0.0, 0.0),
                    wheel_rates: [0.0; MAX_WHEELS],
                    steer: Some((g, gd)),
                }
            })
            .collect();
        Plan { wheels: 2, samples }
    }

    #[test]
    fn steps_the_rates_explain_pass_and_a_resteer_at_rest_is_found() {
        // 1 rad/s over 0.1 s: a step of 0.1 rad is what the rates allow.
        assert!(unexplained_steer_step(&plan(1.0, 0.1), MAX_UNEXPLAINED_STEER_STEP).is_none());
        // Within the tolerance.
        assert!(unexplained_steer_step(&plan(1.0, 0.105), MAX_UNEXPLAINED_STEER_STEP).is_none());
        // A re-steer at rest: 0.5 rad per sample with zero rates.
        let s = unexplained_steer_step(&plan(0.0, 0.5), MAX_UNEXPLAINED_STEER_STEP).unwrap();
        assert_eq!(s.module, 2);
        assert_eq!(s.t, (0.0, 0.1));
        assert!((s.step - 0.5).abs() < 1e-15);
        assert_eq!(s.by_rates, (0.0, 0.0));
        assert!(s.cause().contains("re-steered at a stop"));
        assert!(s.to_string().contains("s2 steps by 0.5000 rad"));
        // Rates too small for the step: the samples are too far apart.
        let s = unexplained_steer_step(&plan(1.0, 0.3), MAX_SIMULATED_STEER_STEP).unwrap();
        assert!(s.cause().contains("higher --rate"));
        // Wrapped: a step of 2π − 0.1 is a step of −0.1 (explained by −1 rad/s).
        let two_pi = 2.0 * std::f64::consts::PI;
        assert!(
            unexplained_steer_step(&plan(-1.0, two_pi - 0.1), MAX_UNEXPLAINED_STEER_STEP).is_none()
        );
    }
}
