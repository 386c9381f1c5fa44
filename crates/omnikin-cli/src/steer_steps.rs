//! A plan's steer angles against its steer rates. The simulator (and any steer motor driven by
//! rate) moves a module by the plan's `sd` columns; a plan whose `s` columns step between two
//! samples by more than those rates account for cannot be followed: a swerve plan re-steering
//! its modules at a stop (the planner keeps a stopped module's angle and points it along the
//! next motion at the first sample of that motion, with `sd = 0`) simulated as if the modules
//! never turned — an ideal-plant square ended 1.6 m from its end point, with exit code 0.

use omnikin_plan::Plan;

/// Largest accepted difference between a steer-angle step and the trapezoidal integral of the
/// steer rates over it, rad (0.57°; a consistent plan's differences are of order `dt³`).
pub const MAX_UNEXPLAINED_STEER_STEP: f64 = 1e-2;

/// A steer step that the plan's steer rates do not explain.
pub struct SteerStep {
    /// 1-based module.
    pub module: usize,
    /// The two sample times, s.
    pub t: (f64, f64),
    /// The step of the angle (wrapped to (−π, π]), rad.
    pub step: f64,
    /// What the steer rates integrate to over the interval, rad.
    pub by_rates: f64,
}

impl std::fmt::Display for SteerStep {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let i = self.module;
        write!(
            f,
            "s{i} steps by {:.4} rad between t = {} s and t = {} s, but its steer rate sd{i} \
             accounts for {:.4} rad ({:.0} rad/s would be needed)",
            self.step,
            self.t.0,
            self.t.1,
            self.by_rates,
            (self.step - self.by_rates).abs() / (self.t.1 - self.t.0)
        )
    }
}

/// The first interval of `plan` whose steer-angle step differs from the integral of its steer
/// rates by more than [`MAX_UNEXPLAINED_STEER_STEP`]; `None` for a consistent plan or one
/// without steering.
pub fn unexplained_steer_step(plan: &Plan) -> Option<SteerStep> {
    let n = plan.wheels;
    plan.samples.windows(2).find_map(|w| {
        let ((ga, gda), (gb, gdb)) = (w[0].steer?, w[1].steer?);
        let dt = w[1].t - w[0].t;
        (0..n).find_map(|i| {
            let step = omnikin::wrap_angle(gb[i] - ga[i]);
            let by_rates = 0.5 * (gda[i] + gdb[i]) * dt;
            let off = omnikin::wrap_angle(step - by_rates).abs();
            (off > MAX_UNEXPLAINED_STEER_STEP).then_some(SteerStep {
                module: i + 1,
                t: (w[0].t, w[1].t),
                step,
                by_rates,
            })
        })
    })
}
