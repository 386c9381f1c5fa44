//! The robot file's body limits ([`omnikin::description::BodyLimits`]) on the command line:
//! a flag may lower one but not raise it above what the robot will do ([`flag`]), and a plan
//! is compared with them before it is driven or simulated ([`plan_excess`]) — before an
//! upload, with the stricter of the robot file's and the robot's own ([`held`]).

use anyhow::{Result, bail};
use omnikin::description::{BodyLimits, LimitSource, RobotDescription};
use omnikin::link::RobotLimits;
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

/// The limits a plan is held to before it is uploaded: for each, the stricter of the robot
/// file's (`--robot`) and the ones the robot's runtime enforces (its handshake's
/// [`RobotLimits`]); `None` when neither is known. A value the robot sends that is not a
/// positive finite number (`f32::INFINITY`: not limited) limits nothing.
pub fn held(file: Option<&BodyLimits>, told: Option<&RobotLimits>) -> Option<BodyLimits> {
    let told = told.map(|t| {
        let limit = |v: f32| Some(f64::from(v)).filter(|v| v.is_finite() && *v > 0.0);
        let (max_accel, max_accel_source) = match limit(t.max_accel) {
            Some(a) => (a, LimitSource::Robot),
            None => (f64::INFINITY, LimitSource::Unlimited),
        };
        let (max_yaw_accel, max_yaw_accel_source) = match limit(t.max_yaw_accel) {
            Some(a) => (a, LimitSource::Robot),
            None => (f64::INFINITY, LimitSource::Unlimited),
        };
        let max_jerk = limit(t.max_jerk);
        BodyLimits {
            max_accel,
            max_accel_source,
            max_yaw_accel,
            max_yaw_accel_source,
            max_jerk,
            max_jerk_source: match max_jerk {
                Some(_) => LimitSource::Robot,
                None => LimitSource::Unlimited,
            },
        }
    });
    let (f, t) = match (file, told) {
        (None, None) => return None,
        (Some(f), None) => return Some(*f),
        (None, Some(t)) => return Some(t),
        (Some(f), Some(t)) => (*f, t),
    };
    // The runtime's arbitrary default is no file limit: the robot's value stands alone then.
    let pick = |fv: f64, fs: LimitSource, tv: f64, ts: LimitSource| {
        if fs == LimitSource::Default || tv < fv {
            (tv, ts)
        } else {
            (fv, fs)
        }
    };
    let (max_accel, max_accel_source) = pick(
        f.max_accel,
        f.max_accel_source,
        t.max_accel,
        t.max_accel_source,
    );
    let (max_yaw_accel, max_yaw_accel_source) = pick(
        f.max_yaw_accel,
        f.max_yaw_accel_source,
        t.max_yaw_accel,
        t.max_yaw_accel_source,
    );
    let (max_jerk, max_jerk_source) = match (f.max_jerk, t.max_jerk) {
        (Some(a), Some(b)) if b < a => (Some(b), t.max_jerk_source),
        (Some(a), _) => (Some(a), f.max_jerk_source),
        (None, b) => (b, t.max_jerk_source),
    };
    Some(BodyLimits {
        max_accel,
        max_accel_source,
        max_yaw_accel,
        max_yaw_accel_source,
        max_jerk,
        max_jerk_source,
    })
}

/// The limits a robot's handshake told, for `drive hello`, to four significant digits: "body
/// limits: acceleration 22.86 m/s², yaw acceleration 264 rad/s², jerk unlimited".
pub fn told_line(t: &RobotLimits) -> String {
    let v = |x: f32, unit: &str| {
        let x = f64::from(x);
        if x.is_finite() && x > 0.0 {
            // Four significant digits (an f32 carries about seven).
            let decimals = (3 - x.log10().floor() as i32).max(0) as usize;
            let t = format!("{x:.decimals$}");
            let t = if t.contains('.') {
                t.trim_end_matches('0').trim_end_matches('.')
            } else {
                &t
            };
            format!("{t} {unit}")
        } else {
            "unlimited".to_string()
        }
    };
    format!(
        "body limits: acceleration {}, yaw acceleration {}, jerk {}",
        v(t.max_accel, "m/s²"),
        v(t.max_yaw_accel, "rad/s²"),
        v(t.max_jerk, "m/s³")
    )
}

/// A limit for messages: four significant digits.
fn round(v: f64) -> String {
    if !v.is_finite() {
        return "unlimited".to_string();
    }
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
        check(
            "jerk",
            p.jerk,
            j,
            "m/s³",
            limits.max_jerk_source,
            "max_jerk",
        );
    }
    out
}

/// What `plan` (a plan file from elsewhere, or made for another robot) asks beyond the robot
/// file's limits, one sentence per limit naming it, the plan's peak and its time: each motor
/// quantity with a limit (the planner's own check, [`omnikin_plan::planner::plan_peaks`]) and
/// the body limits ([`plan_excess`]); empty when the plan is within them.
///
/// # Errors
/// The robot file cannot be turned into a planning model.
pub fn plan_beyond_file(d: &RobotDescription, plan: &Plan) -> Result<Vec<String>> {
    let model = omnikin_plan::RobotModel::from_description(d)?;
    let mut out: Vec<String> = omnikin_plan::planner::plan_peaks(plan, &model)
        .iter()
        .filter_map(|p| {
            let limit = p.limit?;
            (p.value > limit * (1.0 + TOLERANCE)).then(|| {
                format!(
                    "the plan asks {} {unit} of {} {} {} at t = {:.2} s, more than the robot's \
                     {} {unit} (the robot file's limits.{})",
                    round(p.value),
                    p.quantity.motor(),
                    if p.quantity.is_accel() {
                        "acceleration"
                    } else {
                        "rate"
                    },
                    p.motor,
                    p.t,
                    round(limit),
                    p.quantity.key(),
                    unit = p.quantity.unit(),
                )
            })
        })
        .collect();
    out.extend(plan_excess(&d.body_limits(), &peaks(plan)));
    Ok(out)
}

/// One line on a plan within the limits: its peaks beside the limits of `robot` (a name, or
/// words such as "the robot's").
pub fn within_line(robot: &str, limits: &BodyLimits, p: &Peaks) -> String {
    format!(
        "plan within {robot} body limits: acceleration {} of {} m/s², yaw acceleration {} of {} rad/s²",
        round(p.accel.0),
        round(limits.max_accel),
        round(p.yaw_accel.0),
        round(limits.max_yaw_accel)
    )
}

/// Before an upload: `plan` held to the stricter of the robot file's limits (`file`: its
/// name, e.g. "sphere-omni's", and limits) and the robot's own (`told`, its handshake) —
/// the line to show when it is within them (`None`: no limit known).
///
/// # Errors
/// The plan asks for more than a limit: `label` (e.g. "plan circle.csv"), each limit exceeded,
/// and what to do about it.
pub fn check_upload(
    plan: &Plan,
    label: &str,
    file: Option<(&str, &BodyLimits)>,
    told: &RobotLimits,
) -> Result<Option<String>> {
    let Some(limits) = held(file.map(|(_, l)| l), Some(told)) else {
        return Ok(None);
    };
    let peaks = peaks(plan);
    let excess = plan_excess(&limits, &peaks);
    if !excess.is_empty() {
        bail!(
            "{label}: not uploaded: {}; the robot would lag behind it (re-plan slower, e.g. a longer --ramp-fraction or a lower --max-accel)",
            excess.join("; ")
        );
    }
    let name = file.map_or("the robot's", |(n, _)| n);
    Ok(Some(within_line(name, &limits, &peaks)))
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
            max_jerk_source: LimitSource::Unlimited,
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

    #[test]
    fn the_stricter_of_the_file_and_the_robot_holds_each_limit() {
        let told = RobotLimits {
            max_accel: 0.5,
            max_yaw_accel: 8.0,
            max_jerk: f32::INFINITY,
        };
        let f = limits();
        assert_eq!(held(None, None), None);
        assert_eq!(held(Some(&f), None), Some(f));
        let h = held(Some(&f), Some(&told)).unwrap();
        assert_eq!((h.max_accel, h.max_accel_source), (0.5, LimitSource::Robot));
        assert_eq!(
            (h.max_yaw_accel, h.max_yaw_accel_source),
            (4.0, LimitSource::WheelLimits)
        );
        assert_eq!(
            (h.max_jerk, h.max_jerk_source),
            (None, LimitSource::Unlimited)
        );
        // A file jerk limit stays; a stricter robot jerk replaces it.
        let jerky = BodyLimits {
            max_jerk: Some(10.0),
            max_jerk_source: LimitSource::File,
            ..f
        };
        assert_eq!(
            held(Some(&jerky), Some(&told)).unwrap().max_jerk,
            Some(10.0)
        );
        let h = held(
            Some(&jerky),
            Some(&RobotLimits {
                max_jerk: 3.0,
                ..told
            }),
        )
        .unwrap();
        assert_eq!(
            (h.max_jerk, h.max_jerk_source),
            (Some(3.0), LimitSource::Robot)
        );
        // The runtime's default in a file without limits yields to the robot's value, even
        // a larger one; a value that is no limit (NaN, ∞, ≤ 0) limits nothing.
        let default = BodyLimits {
            max_accel: 1.0,
            max_accel_source: LimitSource::Default,
            ..f
        };
        let h = held(
            Some(&default),
            Some(&RobotLimits {
                max_accel: 3.0,
                ..told
            }),
        )
        .unwrap();
        assert_eq!((h.max_accel, h.max_accel_source), (3.0, LimitSource::Robot));
        for bad in [f32::NAN, f32::INFINITY, 0.0, -1.0] {
            let h = held(
                None,
                Some(&RobotLimits {
                    max_accel: bad,
                    ..told
                }),
            )
            .unwrap();
            assert_eq!(h.max_accel_source, LimitSource::Unlimited, "{bad}");
            let p = Peaks {
                accel: (1e6, 0.0),
                ..Peaks::default()
            };
            assert!(plan_excess(&h, &p).is_empty(), "{bad}");
        }
    }
}
