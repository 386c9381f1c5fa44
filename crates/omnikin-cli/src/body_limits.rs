//! The robot file's body limits ([`omnikin::description::BodyLimits`]) on the command line:
//! a flag may lower one but not raise it above what the robot will do ([`flag`]), and a plan
//! is compared with them before it is driven or simulated ([`plan_excess`]).

use anyhow::{Result, bail};
use omnikin::description::{BodyLimits, LimitSource, RobotDescription};
use omnikin_plan::Plan;

/// Share by which a plan's sampled peak may exceed a limit before it counts as asking for
/// more: finite differences of a plan made within the limit stay within it, 1 % covers the
/// CSV's rounding.
pub const TOLERANCE: f64 = 0.01;

/// A limit the runtime takes: `given` (a flag) if any, else the robot's `limit`. A flag above
/// the robot's limit is refused, naming the flag, the limit and where it came from.
///
/// # Errors
/// `given > limit`.
pub fn flag(
    flag: &str,
    given: Option<f64>,
    limit: f64,
    source: LimitSource,
    key: &str,
    unit: &str,
    d: &RobotDescription,
) -> Result<f64> {
    match given {
        Some(v) if v > limit => bail!(
            "{flag} {v}: robot {}: above what the robot will do, {} {unit} ({}); a flag may \
             only lower it (to raise it, set [limits] {key} in the robot file)",
            d.name,
            round(limit),
            source.describe(key)
        ),
        Some(v) => Ok(v),
        None => Ok(limit),
    }
}

/// A limit for messages: four significant digits.
fn round(v: f64) -> String {
    format!("{v:.4}")
        .trim_end_matches('0')
        .trim_end_matches('.')
        .to_string()
}

/// A plan's largest body acceleration, yaw acceleration and jerk (finite differences of its
/// world-frame velocities, the quantities the runtime's slew limits), with their times.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Peaks {
    /// Largest |Δv / Δt| of the world-frame linear velocity, m/s², and its time, s.
    pub accel: (f64, f64),
    /// Largest |Δyaw_rate / Δt|, rad/s², and its time, s.
    pub yaw_accel: (f64, f64),
    /// Largest |Δa / Δt| of the linear acceleration, m/s³, and its time, s.
    pub jerk: (f64, f64),
}

/// The peaks of `plan` (samples with equal times are skipped).
pub fn peaks(plan: &Plan) -> Peaks {
    let max = |m: &mut (f64, f64), v: f64, t: f64| {
        if v > m.0 {
            *m = (v, t);
        }
    };
    let mut p = Peaks::default();
    let mut prev: Option<(f64, f64, f64)> = None;
    for w in plan.samples.windows(2) {
        let dt = w[1].t - w[0].t;
        if dt <= 0.0 {
            continue;
        }
        let ax = (w[1].twist.vx - w[0].twist.vx) / dt;
        let ay = (w[1].twist.vy - w[0].twist.vy) / dt;
        max(&mut p.accel, ax.hypot(ay), w[0].t);
        let yaw = ((w[1].twist.yaw_rate - w[0].twist.yaw_rate) / dt).abs();
        max(&mut p.yaw_accel, yaw, w[0].t);
        let mid = 0.5 * (w[0].t + w[1].t);
        if let Some((pax, pay, pt)) = prev
            && mid > pt
        {
            max(&mut p.jerk, (ax - pax).hypot(ay - pay) / (mid - pt), pt);
        }
        prev = Some((ax, ay, mid));
    }
    p
}

/// What the plan asks beyond `limits`, one sentence per limit naming it, where it came from,
/// the plan's peak and its time; empty when the plan is within them. A limit of a robot file
/// without any acceleration limit ([`LimitSource::Default`], the runtime's arbitrary default)
/// is not held against a plan: the file states nothing to compare with.
pub fn plan_excess(limits: &BodyLimits, p: &Peaks) -> Vec<String> {
    let mut out = Vec::new();
    let mut check = |what: &str,
                     (peak, at): (f64, f64),
                     limit: f64,
                     unit: &str,
                     source: LimitSource,
                     key: &str| {
        if source != LimitSource::Default && peak > limit * (1.0 + TOLERANCE) {
            out.push(format!(
                "the plan asks {} {unit} of {what} at t = {at:.2} s, more than the robot's \
                 {} {unit} ({})",
                round(peak),
                round(limit),
                source.describe(key)
            ));
        }
    };
    check(
        "acceleration",
        p.accel,
        limits.max_accel,
        "m/s²",
        limits.max_accel_source,
        "max_accel",
    );
    check(
        "yaw acceleration",
        p.yaw_accel,
        limits.max_yaw_accel,
        "rad/s²",
        limits.max_yaw_accel_source,
        "max_yaw_accel",
    );
    if let Some(j) = limits.max_jerk {
        check("jerk", p.jerk, j, "m/s³", LimitSource::File, "max_jerk");
    }
    out
}

/// One line on a plan within the limits: its peaks beside the robot's limits.
pub fn within_line(d: &RobotDescription, limits: &BodyLimits, p: &Peaks) -> String {
    format!(
        "plan within {}'s body limits: acceleration {} of {} m/s², yaw acceleration {} of {} rad/s²",
        d.name,
        round(p.accel.0),
        round(limits.max_accel),
        round(p.yaw_accel.0),
        round(limits.max_yaw_accel)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use omnikin::Pose2;
    use omnikin::Twist2;
    use omnikin_plan::Sample;

    fn limits() -> BodyLimits {
        BodyLimits {
            max_accel: 2.0,
            max_accel_source: LimitSource::File,
            max_yaw_accel: 4.0,
            max_yaw_accel_source: LimitSource::WheelLimits,
            max_jerk: None,
        }
    }

    #[test]
    fn a_ramp_at_the_limit_passes_and_a_steeper_one_is_named() {
        for (a, excess) in [(2.0, false), (3.0, true)] {
            let samples = (0..=20)
                .map(|k| {
                    let t = k as f64 * 0.01;
                    Sample {
                        t,
                        pose: Pose2::default(),
                        twist: Twist2::new((a * t).min(0.1), 0.0, 0.0),
                        wheel_rates: [0.0; omnikin::MAX_WHEELS],
                        steer: None,
                    }
                })
                .collect();
            let plan = Plan { wheels: 3, samples };
            let p = peaks(&plan);
            assert!((p.accel.0 - a).abs() < 1e-9, "{p:?}");
            let e = plan_excess(&limits(), &p);
            assert_eq!(!e.is_empty(), excess, "{e:?}");
            if excess {
                assert!(e[0].contains("3 m/s² of acceleration"), "{e:?}");
                assert!(e[0].contains("limits.max_accel"), "{e:?}");
            }
        }
    }
}
