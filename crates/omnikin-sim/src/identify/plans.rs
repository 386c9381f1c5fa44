//! Test plans for identification (`omnikin plan sysid`): motions that excite what must be
//! identified, inside the robot file's limits.
//!
//! | plan | body motion | identifies |
//! |------|-------------|------------|
//! | `along` | forward, stop, back (`vx`) | wheel radii (scale), drive angles |
//! | `along-across` | a square at constant heading: forward, left, back, right | the drive angles against each other (one heading for both directions) |
//! | `spin` | spin in place one way, stop, back | wheel positions (`p × d`), mount geometry, gyro scale |
//! | `figure-eight` | forward at constant speed, a full circle left then one right | all of the above together, gyro bias against scale |
//!
//! Every segment is a body twist with cosine ramps `v(t) = V sin²(π t / 2τ)` up and down
//! (peak acceleration `π V / 2τ`), held between them, then half a second at rest. The
//! amplitude is chosen so the largest wheel rate is half of `limits.max_wheel_rate` (and steer
//! rates half of `max_steer_rate`), and the ramps so the wheels' acceleration stays within
//! half of `max_wheel_accel`: the plans stay well inside the limits, which keeps wheel slip —
//! the one thing the identification cannot model — small. Without limits in the file, 10 rad/s
//! and 50 rad/s² are assumed. The sphere's rocking and spin-decay and the ballbot's sways
//! (dynamic parameters) are not planned here.
//!
//! Samples are `rate` Hz; poses integrate the body twist exactly on SE(2) from the origin.

use omnikin::description::RobotDescription;
use omnikin::{Actuators, Kind, Pose2, Robot, Twist2};
use omnikin_plan::{Plan, Sample};

/// One test plan and what it is for.
#[derive(Clone, Debug, PartialEq)]
pub struct SysidPlan {
    /// File stem: `along`, `along-across`, `spin`, `figure-eight`.
    pub name: &'static str,
    /// What the plan identifies (one sentence, for the plan file's companion and the docs).
    pub identifies: &'static str,
    /// The plan.
    pub plan: Plan,
}

/// Why the plans could not be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SysidPlanError {
    /// The robot does not build, its inverse kinematics fail, or its kind has no plans
    /// (swerve).
    #[error("{0}")]
    Robot(String),
}

/// Assumed wheel-rate limit when the file has none, rad/s.
pub const DEFAULT_WHEEL_RATE: f64 = 10.0;
/// Assumed wheel-acceleration limit when the file has none, rad/s².
pub const DEFAULT_WHEEL_ACCEL: f64 = 50.0;

/// A body-twist shape: unit twist per segment, with hold durations (s) relative to the ramp.
struct Segment {
    twist: [f64; 3],
    hold: f64,
}

fn shapes(name: &str) -> Vec<Segment> {
    let seg = |twist: [f64; 3], hold: f64| Segment { twist, hold };
    match name {
        "along" => vec![seg([1.0, 0.0, 0.0], 2.0), seg([-1.0, 0.0, 0.0], 2.0)],
        "along-across" => vec![
            seg([1.0, 0.0, 0.0], 1.5),
            seg([0.0, 1.0, 0.0], 1.5),
            seg([-1.0, 0.0, 0.0], 1.5),
            seg([0.0, -1.0, 0.0], 1.5),
        ],
        "spin" => vec![seg([0.0, 0.0, 1.0], 4.0), seg([0.0, 0.0, -1.0], 4.0)],
        // Yaw rate 1/0.5 of the speed: circles of radius 0.5 (in amplitude units), each a full
        // turn long: 2π·0.5 / 1 = π s at unit speed.
        _ => vec![
            seg([1.0, 0.0, 2.0], std::f64::consts::PI),
            seg([1.0, 0.0, -2.0], std::f64::consts::PI),
        ],
    }
}

/// Body twist at time `t` of a segment of ramp `tau` and hold `hold`, amplitude `v`.
fn envelope(t: f64, tau: f64, hold: f64) -> f64 {
    let s = |u: f64| (std::f64::consts::FRAC_PI_2 * u).sin().powi(2);
    if t < tau {
        s(t / tau)
    } else if t < tau + hold {
        1.0
    } else if t < 2.0 * tau + hold {
        s((2.0 * tau + hold - t) / tau)
    } else {
        0.0
    }
}

fn build(
    robot: &Robot<f64>,
    name: &str,
    amplitude: f64,
    tau: f64,
    rate: f64,
) -> Result<Plan, SysidPlanError> {
    let dt = 1.0 / rate;
    let mut twists = Vec::new();
    for seg in shapes(name) {
        // Holds scale with 1/amplitude for the figure eight (a full circle at any speed) and
        // are seconds otherwise.
        let hold = if name == "figure-eight" {
            seg.hold / amplitude
        } else {
            seg.hold
        };
        let len = 2.0 * tau + hold;
        let steps = (len / dt).ceil() as usize;
        for k in 0..steps {
            let e = amplitude * envelope(k as f64 * dt, tau, hold);
            twists.push(Twist2::new(
                seg.twist[0] * e,
                seg.twist[1] * e,
                seg.twist[2] * e,
            ));
        }
        for _ in 0..(0.5 / dt) as usize {
            twists.push(Twist2::new(0.0, 0.0, 0.0));
        }
    }
    twists.push(Twist2::new(0.0, 0.0, 0.0));
    let n = robot.wheels();
    let mut pose = Pose2::new(0.0, 0.0, 0.0);
    let mut act = Actuators::zero();
    let mut poses = Vec::with_capacity(twists.len());
    let mut acts: Vec<Actuators<f64>> = Vec::with_capacity(twists.len());
    for tw in &twists {
        act = robot
            .inverse(*tw, &act)
            .map_err(|e| SysidPlanError::Robot(format!("{name}: {e}")))?;
        if robot.kind() == Kind::Caster {
            // The caster's steer angles are state: its inverse gives the steer rates at the
            // current angles, and the angles advance by them (as the simulator turns them).
            let mut next = act;
            for i in 0..n {
                next.steer_angles[i] += act.steer_rates[i] * dt;
            }
            acts.push(act);
            act = next;
        } else {
            acts.push(act);
        }
        poses.push(pose);
        pose = omnikin::se2::integrate(pose, *tw, dt);
    }
    let mut samples = Vec::with_capacity(twists.len());
    for (k, ((tw, p), a)) in twists.iter().zip(&poses).zip(&acts).enumerate() {
        let steer = robot
            .steerable()
            .then(|| (&a.steer_angles[..n], &a.steer_rates[..n]));
        samples.push(Sample::new(
            k as f64 * dt,
            *p,
            tw.to_world(p.heading),
            &a.wheel_rates[..n],
            steer,
        ));
    }
    Ok(Plan { wheels: n, samples })
}

/// Largest wheel rate, wheel acceleration and steer rate of a plan.
fn peaks(plan: &Plan) -> (f64, f64, f64) {
    let n = plan.wheels;
    let (mut w, mut a, mut s) = (0.0f64, 0.0f64, 0.0f64);
    for (k, smp) in plan.samples.iter().enumerate() {
        for i in 0..n {
            w = w.max(smp.wheel_rates[i].abs());
            if let Some((_, sd)) = smp.steer {
                s = s.max(sd[i].abs());
            }
            if k > 0 {
                let prev = &plan.samples[k - 1];
                a = a.max((smp.wheel_rates[i] - prev.wheel_rates[i]).abs() / (smp.t - prev.t));
            }
        }
    }
    (w, a, s)
}

/// The four test plans of the module table for `desc`, sampled at `rate` Hz, each at half the
/// file's limits.
///
/// # Errors
/// [`SysidPlanError::Robot`] when the robot does not build, its inverse kinematics fail, or it
/// is a swerve drive (not planned yet: its modules would have to turn between segments).
pub fn sysid_plans(desc: &RobotDescription, rate: f64) -> Result<Vec<SysidPlan>, SysidPlanError> {
    let robot = desc
        .build::<f64>()
        .map_err(|e| SysidPlanError::Robot(e.to_string()))?;
    if robot.kind() == Kind::Swerve {
        return Err(SysidPlanError::Robot(
            "swerve: no sysid plans yet (its modules must turn between the segments, which these constant-twist plans do not schedule); record runs planned with `plan square` or `plan waypoints` and identify from those".into(),
        ));
    }
    let max_rate = desc.limits.max_wheel_rate.unwrap_or(DEFAULT_WHEEL_RATE);
    let max_accel = desc.limits.max_wheel_accel.unwrap_or(DEFAULT_WHEEL_ACCEL);
    let max_steer = desc.limits.max_steer_rate;
    let list: [(&'static str, &'static str); 4] = [
        (
            "along",
            "wheel radius scales and drive angles (straight forward and back)",
        ),
        (
            "along-across",
            "the drive angles against each other: forward, left, back, right at one heading (a square)",
        ),
        (
            "spin",
            "wheel positions / mount geometry and the gyro scale (spins in place both ways)",
        ),
        (
            "figure-eight",
            "everything at once and the gyro bias against its scale (a circle left, then right)",
        ),
    ];
    let mut out = Vec::new();
    for (name, identifies) in list {
        // Amplitude 1 with a 1 s ramp, then scaled (wheel rates are linear in the twist) and
        // the ramp lengthened until the acceleration is within half the limit.
        let probe = build(&robot, name, 1.0, 1.0, rate)?;
        let (w, _, s) = peaks(&probe);
        let mut amp = 0.5 * max_rate / w.max(1e-12);
        if let Some(ms) = max_steer
            && s > 0.0
        {
            amp = amp.min(0.5 * ms / s);
        }
        let mut tau = 1.0;
        let mut plan = build(&robot, name, amp, tau, rate)?;
        // The caster's steer rates are not linear in the twist (they depend on the steer
        // state): lower the amplitude until they fit, and lengthen the ramps until the wheel
        // acceleration does.
        for _ in 0..16 {
            let (_, a, s) = peaks(&plan);
            if let Some(ms) = max_steer
                && s > 0.5 * ms
            {
                amp *= 0.5 * ms / s * 0.95;
            } else if a > 0.5 * max_accel {
                tau *= a / (0.5 * max_accel) * 1.05;
            } else {
                break;
            }
            plan = build(&robot, name, amp, tau, rate)?;
        }
        out.push(SysidPlan {
            name,
            identifies,
            plan,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every preset's plans stay within half its wheel-rate and wheel-acceleration limits, start
    /// and end at rest, and the spin turns the robot while the straight runs do not.
    #[test]
    fn plans_stay_inside_the_limits() {
        for name in ["kiwi", "x-drive", "mecanum", "caster3"] {
            let d = RobotDescription::preset(name).unwrap();
            let plans = sysid_plans(&d, 50.0).unwrap();
            assert_eq!(plans.len(), 4);
            let lim = d.limits.max_wheel_rate.unwrap_or(DEFAULT_WHEEL_RATE);
            let acc = d.limits.max_wheel_accel.unwrap_or(DEFAULT_WHEEL_ACCEL);
            for p in &plans {
                let (w, a, s) = peaks(&p.plan);
                let steer_bound = d.limits.max_steer_rate.is_some_and(|m| s > 0.3 * m);
                assert!(w <= 0.5 * lim * (1.0 + 1e-9), "{name} {}: {w}", p.name);
                // The amplitude is set by one of the two limits (not far inside both).
                assert!(w > 0.3 * lim || steer_bound, "{name} {}: {w}", p.name);
                if let Some(m) = d.limits.max_steer_rate {
                    assert!(s <= 0.5 * m * 1.05, "{name} {}: steer {s}", p.name);
                }
                assert!(a <= 0.5 * acc * 1.001, "{name} {}: {a}", p.name);
                let last = p.plan.samples.last().unwrap();
                assert!(
                    last.wheel_rates[..d.build::<f64>().unwrap().wheels()]
                        .iter()
                        .all(|w| w.abs() < 1e-9)
                );
                let turn = last.pose.heading.abs();
                match p.name {
                    "along" | "along-across" => assert!(turn < 1e-9, "{name} {}", p.name),
                    _ => assert!(
                        p.plan.samples.iter().any(|s| s.pose.heading.abs() > 1.0),
                        "{name} {} never turns",
                        p.name
                    ),
                }
            }
        }
    }

    #[test]
    fn a_swerve_drive_is_refused_by_name() {
        let d = RobotDescription::preset("swerve4").unwrap();
        let e = sysid_plans(&d, 50.0).unwrap_err().to_string();
        assert!(e.starts_with("swerve:"), "{e}");
    }
}
