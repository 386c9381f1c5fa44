//! A ballbot accelerates by leaning: its plans are limited to the body acceleration its lean
//! limit allows (the robot file's `[dynamics] max_tilt_deg` less `lean_margin`,
//! [`omnikin::description::RobotDescription::lean_acceleration_limit`]), applied to the
//! request's acceleration limit before planning and reported with the plan's peak body
//! acceleration after it, as the motor limits are — by `omnikin plan` and `omnikin.plan` alike
//! (the front ends print or warn [`LeanLimit::report`]'s lines).

use crate::Plan;
use crate::planner::{PlanOptions, Timing};
use omnikin::description::RobotDescription;

/// The lean limit of a ballbot's plans: what it allowed and what the request asked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeanLimit {
    /// Largest body acceleration, m/s².
    limit: f64,
    /// The lean limit, degrees.
    tilt_deg: f64,
    /// Share kept for the controller.
    margin: f64,
    /// The request's acceleration limit when the lean limit lowered it, m/s².
    lowered_from: Option<f64>,
}

/// For a ballbot, lowers `opts`' acceleration limit to the lean limit (profile and
/// time-optimal timings; a constant-speed timing has no tangential acceleration). `None` for
/// other kinds.
pub fn apply(d: &RobotDescription, opts: &mut PlanOptions) -> Option<LeanLimit> {
    let (limit, tilt_deg, margin) = d.lean_acceleration_limit()?;
    let mut lowered_from = None;
    if let Timing::Profile { limits, .. } | Timing::TimeOptimal { limits } = &mut opts.timing
        && limits.max_accel > limit
    {
        lowered_from = Some(limits.max_accel);
        limits.max_accel = limit;
    }
    Some(LeanLimit {
        limit,
        tilt_deg,
        margin,
        lowered_from,
    })
}

/// The plan's largest body acceleration (tangential and centripetal: the change of the world
/// velocity between samples), m/s², and its time, s.
fn peak_acceleration(plan: &Plan) -> (f64, f64) {
    plan.samples
        .windows(2)
        .filter(|w| w[1].t > w[0].t)
        .map(|w| {
            let dt = w[1].t - w[0].t;
            let a =
                ((w[1].twist.vx - w[0].twist.vx) / dt).hypot((w[1].twist.vy - w[0].twist.vy) / dt);
            (a, w[0].t)
        })
        .fold((0.0, 0.0), |m, x| if x.0 > m.0 { x } else { m })
}

/// What a plan report says about the lean limit.
#[derive(Clone, Debug, PartialEq)]
pub struct LeanReport {
    /// The report's line (the limit, what it lowered, the plan's peak and its share).
    pub line: String,
    /// A warning when the plan still asks for more (a constant-speed circle's centripetal
    /// acceleration is not re-timed), past 1 % for the differences between samples.
    pub warning: Option<String>,
}

impl LeanLimit {
    /// Largest body acceleration the lean limit allows, m/s².
    pub fn limit(&self) -> f64 {
        self.limit
    }

    /// The report of `plan` against this limit (see [`LeanReport`]).
    pub fn report(&self, plan: &Plan) -> LeanReport {
        let l = self;
        let (peak, at) = peak_acceleration(plan);
        let line = format!(
            "lean limit: body acceleration ≤ {:.3} m/s² (max_tilt_deg {}° less {:.0} % kept for \
             the balance controller){}; peak body acceleration {:.3} m/s² at t = {:.2} s ({:.1} % \
             of it)",
            l.limit,
            l.tilt_deg,
            100.0 * l.margin,
            l.lowered_from.map_or(String::new(), |a| format!(
                ", the request's {a:.3} m/s² lowered to it"
            )),
            peak,
            at,
            100.0 * peak / l.limit
        );
        let warning = (peak > 1.01 * l.limit).then(|| {
            format!(
                "the plan asks {peak:.3} m/s² at t = {at:.2} s, more than the lean limit \
                 allows: the ballbot would lean past {}° (a constant-speed circle's centripetal \
                 acceleration is not re-timed; add --ramp or slow down)",
                l.tilt_deg
            )
        });
        LeanReport { line, warning }
    }
}
