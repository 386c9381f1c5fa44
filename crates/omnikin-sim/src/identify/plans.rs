//! Test plans for identification (`omnikin plan sysid`): motions that excite what must be
//! identified, inside the robot file's limits.
//!
//! | plan | body motion | identifies |
//! |------|-------------|------------|
//! | `along` | forward, stop, back (`vx`) | wheel radii (scale), drive angles |
//! | `along-across` | a square at constant heading: forward, left, back, right | the drive angles against each other (one heading for both directions) |
//! | `spin` | spin in place one way, stop, back | wheel positions (`p × d`), mount geometry, gyro scale |
//! | `figure-eight` | forward at constant speed, a full circle left then one right | all of the above together, gyro bias against scale |
//! | `stop` (sphere-omni) | forward, then a short stop and [`STOP_REST`] s at rest | the platform's centre-of-mass depth and the rolling resistance from the rocking after the stop (IMU) |
//! | `spin-stop` (sphere-omni) | a spin in place, then a short stop and [`STOP_REST`] s at rest | the floor's pivot friction from the decay of the spin after the stop (IMU `gz`) |
//!
//! Every segment is a body twist with cosine ramps `v(t) = V sin²(π t / 2τ)` up and down
//! (peak acceleration `π V / 2τ`), held between them, then half a second at rest. The
//! amplitude is chosen so the largest wheel rate is half of `limits.max_wheel_rate` (and steer
//! rates half of `max_steer_rate`), and the ramps so the wheels' acceleration stays within
//! half of `max_wheel_accel`: the plans stay well inside the limits, which keeps wheel slip —
//! the one thing the identification cannot model — small. Without limits in the file, 10 rad/s
//! and 50 rad/s² are assumed. The sphere's `stop` is the exception: its stop ramp is as short
//! as half the wheel-acceleration limit allows (the other ramps are 1 s or longer), so that the
//! platform, swung forward by the deceleration, rocks freely afterwards on the locked wheels;
//! its speed is half the wheel-rate limit's, or less: low enough that the file's dynamic model
//! tilts by at most 95 % of its `max_tilt_deg`. Its `spin-stop` is the same for a spin in place:
//! the wheels lock the platform to the shell, and the whole robot's spin then decays under the
//! floor's pivot friction alone. The ballbot's sways are not planned here.
//!
//! A swerve turns its modules at rest before each segment (`steer_to`): every segment's
//! twist has one direction, so the module angles are constant while the wheels roll, and a
//! reversal does not flip a module by π within one sample (which no steer motor can follow).
//!
//! Samples are `rate` Hz; poses integrate the body twist exactly on SE(2) from the origin.

use omnikin::description::RobotDescription;
use omnikin::{Actuators, Kind, Pose2, Robot, Twist2};
use omnikin_plan::{Plan, Sample};

/// One test plan and what it is for.
#[derive(Clone, Debug, PartialEq)]
pub struct SysidPlan {
    /// File stem: `along`, `along-across`, `spin`, `figure-eight`; for sphere-omni also `stop`
    /// and `spin-stop`.
    pub name: &'static str,
    /// What the plan identifies (one sentence, for the plan file's companion and the docs).
    pub identifies: &'static str,
    /// The plan.
    pub plan: Plan,
}

/// Why the plans could not be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SysidPlanError {
    /// The robot does not build or its inverse kinematics fail.
    #[error("{0}")]
    Robot(String),
}

/// Assumed wheel-rate limit when the file has none, rad/s.
pub const DEFAULT_WHEEL_RATE: f64 = 10.0;
/// Assumed wheel-acceleration limit when the file has none, rad/s².
pub const DEFAULT_WHEEL_ACCEL: f64 = 50.0;

/// Assumed steer-rate limit when the file has none, rad/s.
pub const DEFAULT_STEER_RATE: f64 = 6.0;
/// Assumed steer-acceleration limit when the file has none, rad/s².
pub const DEFAULT_STEER_ACCEL: f64 = 30.0;

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

/// Turns a swerve's modules, at rest, from their current angles to those of `twist` (unit
/// twist of the next segment): a cosine profile `γ(t) = γ₀ + Δ sin²(π t / 2T)` per module
/// along the shorter way round (`Δ` wrapped into (−π, π]), with `T` such that the peak steer
/// rate `π |Δ| / 2T` is at most `steer_rate` and the peak steer acceleration `π² |Δ| / 2T²` at
/// most `steer_accel`. Pushes one zero-twist actuator state per sample and leaves `act` at the
/// new angles (so the next segment's first, zero-speed sample keeps them).
fn steer_to(
    robot: &Robot<f64>,
    twist: Twist2<f64>,
    act: &mut Actuators<f64>,
    limits: (f64, f64),
    dt: f64,
    out: &mut Vec<(Twist2<f64>, Actuators<f64>)>,
) -> Result<(), SysidPlanError> {
    let n = robot.wheels();
    let target = robot
        .inverse(twist, act)
        .map_err(|e| SysidPlanError::Robot(format!("steering: {e}")))?;
    let from = act.steer_angles;
    let delta: Vec<f64> = (0..n)
        .map(|i| omnikin::wrap_angle(target.steer_angles[i] - from[i]))
        .collect();
    let big = delta.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    if big < 1e-9 {
        return Ok(());
    }
    let pi = std::f64::consts::PI;
    let len = (pi * big / (2.0 * limits.0)).max(pi * (big / (2.0 * limits.1)).sqrt());
    let steps = (len / dt).ceil() as usize + 1;
    let len = steps as f64 * dt;
    for k in 0..=steps {
        let t = k as f64 * dt;
        let mut a = Actuators::zero();
        for i in 0..n {
            a.steer_angles[i] = from[i] + delta[i] * (0.5 * pi * t / len).sin().powi(2);
            a.steer_rates[i] = delta[i] * pi / (2.0 * len) * (pi * t / len).sin();
        }
        out.push((Twist2::new(0.0, 0.0, 0.0), a));
    }
    for i in 0..n {
        act.steer_angles[i] = from[i] + delta[i];
        act.steer_rates[i] = 0.0;
    }
    Ok(())
}

fn build(
    robot: &Robot<f64>,
    name: &str,
    amplitude: f64,
    tau: f64,
    rate: f64,
    steer_limits: (f64, f64),
) -> Result<Plan, SysidPlanError> {
    let dt = 1.0 / rate;
    let n = robot.wheels();
    let swerve = robot.kind() == Kind::Swerve;
    let mut act = Actuators::zero();
    // (body twist, actuators) per sample.
    let mut steps: Vec<(Twist2<f64>, Actuators<f64>)> = Vec::new();
    let push = |tw: Twist2<f64>,
                act: &mut Actuators<f64>,
                steps: &mut Vec<(Twist2<f64>, Actuators<f64>)>|
     -> Result<(), SysidPlanError> {
        let a = robot
            .inverse(tw, act)
            .map_err(|e| SysidPlanError::Robot(format!("{name}: {e}")))?;
        if robot.kind() == Kind::Caster {
            // The caster's steer angles are state: its inverse gives the steer rates at the
            // current angles, and the angles advance by them (as the simulator turns them).
            let mut next = a;
            for i in 0..n {
                next.steer_angles[i] += a.steer_rates[i] * dt;
            }
            steps.push((tw, a));
            *act = next;
        } else {
            steps.push((tw, a));
            *act = a;
        }
        Ok(())
    };
    for seg in shapes(name) {
        // Holds scale with 1/amplitude for the figure eight (a full circle at any speed) and
        // are seconds otherwise.
        let hold = if name == "figure-eight" {
            seg.hold / amplitude
        } else {
            seg.hold
        };
        let unit = Twist2::new(seg.twist[0], seg.twist[1], seg.twist[2]);
        if swerve {
            // A segment's twist has one direction, so its module angles are constant: turn
            // the modules to them at rest first (the inverse would flip them by π in one
            // sample when the motion reverses).
            steer_to(robot, unit, &mut act, steer_limits, dt, &mut steps)?;
        }
        let len = 2.0 * tau + hold;
        let count = (len / dt).ceil() as usize;
        for k in 0..count {
            let e = amplitude * envelope(k as f64 * dt, tau, hold);
            push(
                Twist2::new(unit.vx * e, unit.vy * e, unit.yaw_rate * e),
                &mut act,
                &mut steps,
            )?;
        }
        for _ in 0..(0.5 / dt) as usize {
            push(Twist2::new(0.0, 0.0, 0.0), &mut act, &mut steps)?;
        }
    }
    push(Twist2::new(0.0, 0.0, 0.0), &mut act, &mut steps)?;
    let mut pose = Pose2::new(0.0, 0.0, 0.0);
    let mut samples = Vec::with_capacity(steps.len());
    for (k, (tw, a)) in steps.iter().enumerate() {
        let steer = robot
            .steerable()
            .then(|| (&a.steer_angles[..n], &a.steer_rates[..n]));
        samples.push(Sample::new(
            k as f64 * dt,
            pose,
            tw.to_world(pose.heading),
            &a.wheel_rates[..n],
            steer,
        ));
        pose = omnikin::se2::integrate(pose, *tw, dt);
    }
    Ok(Plan { wheels: n, samples })
}

/// Seconds at rest after the sphere's `stop` (the rocking's record).
pub const STOP_REST: f64 = 4.0;

/// The sphere's `stop` and `spin-stop`: the unit body twist `unit` (`vx = 1` forward, or
/// `yaw_rate = 1` a spin in place) at `amplitude` with a cosine ramp of `tau` s up, held 1.5 s,
/// stopped with a cosine ramp of `tau_stop` s, then [`STOP_REST`] s at rest; poses integrated
/// as [`build`] does.
fn build_stop(
    robot: &Robot<f64>,
    unit: Twist2<f64>,
    amplitude: f64,
    tau: f64,
    tau_stop: f64,
    rate: f64,
) -> Result<Plan, SysidPlanError> {
    let dt = 1.0 / rate;
    let n = robot.wheels();
    let s = |u: f64| (std::f64::consts::FRAC_PI_2 * u).sin().powi(2);
    let hold = 1.5;
    let len = tau + hold + tau_stop + STOP_REST;
    let count = (len / dt).ceil() as usize + 1;
    let mut pose = Pose2::new(0.0, 0.0, 0.0);
    let mut samples = Vec::with_capacity(count);
    for k in 0..count {
        let t = k as f64 * dt;
        let e = if t < tau {
            s(t / tau)
        } else if t < tau + hold {
            1.0
        } else if t < tau + hold + tau_stop {
            s((tau + hold + tau_stop - t) / tau_stop)
        } else {
            0.0
        };
        let e = amplitude * e;
        let tw = Twist2::new(unit.vx * e, unit.vy * e, unit.yaw_rate * e);
        let a = robot
            .inverse(tw, &Actuators::zero())
            .map_err(|e| SysidPlanError::Robot(format!("stop: {e}")))?;
        samples.push(Sample::new(
            t,
            pose,
            tw.to_world(pose.heading),
            &a.wheel_rates[..n],
            None,
        ));
        pose = omnikin::se2::integrate(pose, tw, dt);
    }
    Ok(Plan { wheels: n, samples })
}

/// The sphere's stop plan along `unit` (see [`build_stop`]): at half the wheel-rate limit (less
/// if the file's dynamic model would tilt past 95 % of `max_tilt_deg`), ramps from the peak
/// wheel acceleration `π w / 2τ` of a cosine ramp: 1 s (or longer) up, the stop as short as
/// half the acceleration limit allows, at least one sample.
fn sphere_stop(
    desc: &RobotDescription,
    robot: &Robot<f64>,
    unit: Twist2<f64>,
    (max_rate, max_accel): (f64, f64),
    rate: f64,
) -> Result<Plan, SysidPlanError> {
    let probe = build_stop(robot, unit, 1.0, 1.0, 1.0, rate)?;
    let (w, _, _) = peaks(&probe);
    let amp = 0.5 * max_rate / w.max(1e-12);
    let peak = 0.5 * max_rate;
    let tau = (std::f64::consts::PI * peak / (2.0 * 0.5 * max_accel)).max(1.0);
    let mut tau_stop = (std::f64::consts::PI * peak / (2.0 * 0.5 * max_accel)).max(1.0 / rate);
    let mut amp = amp;
    let mut plan = build_stop(robot, unit, amp, tau, tau_stop, rate)?;
    // The sampled ramp's steps exceed the continuous peak by up to one sample's change.
    for _ in 0..16 {
        let (_, a, _) = peaks(&plan);
        if a <= 0.5 * max_accel {
            break;
        }
        tau_stop *= a / (0.5 * max_accel) * 1.05;
        plan = build_stop(robot, unit, amp, tau, tau_stop, rate)?;
    }
    // The swing after the stop within the file's `max_tilt_deg`, as the file's dynamic model
    // has it: slower until the model's largest tilt is within 95 % of it.
    let max_tilt = desc
        .sphere_dynamics
        .as_ref()
        .and_then(|s| s.max_tilt_deg)
        .map(f64::to_radians);
    if let (Some(limit), Ok(model)) = (
        max_tilt,
        crate::dynamics::sphere::SphereDynamics::from_description(desc),
    ) {
        for _ in 0..8 {
            let Ok(run) = crate::dynamics::sphere::simulate_plan(model, &plan) else {
                break;
            };
            if run.max_tilt <= 0.95 * limit {
                break;
            }
            amp *= 0.9 * limit / run.max_tilt;
            plan = build_stop(robot, unit, amp, tau, tau_stop, rate)?;
        }
    }
    Ok(plan)
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

/// The test plans of the module table for `desc` (four; six for sphere-omni), sampled at `rate` Hz, each at half the
/// file's limits.
///
/// # Errors
/// [`SysidPlanError::Robot`] when the robot does not build or its inverse kinematics fail.
pub fn sysid_plans(desc: &RobotDescription, rate: f64) -> Result<Vec<SysidPlan>, SysidPlanError> {
    let robot = desc
        .build::<f64>()
        .map_err(|e| SysidPlanError::Robot(e.to_string()))?;
    let max_rate = desc.limits.max_wheel_rate.unwrap_or(DEFAULT_WHEEL_RATE);
    let max_accel = desc.limits.max_wheel_accel.unwrap_or(DEFAULT_WHEEL_ACCEL);
    let max_steer = desc.limits.max_steer_rate;
    // The swerve's turns between segments, at half the steer limits.
    let steer_limits = (
        0.5 * max_steer.unwrap_or(DEFAULT_STEER_RATE),
        0.5 * desc.limits.max_steer_accel.unwrap_or(DEFAULT_STEER_ACCEL),
    );
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
        let probe = build(&robot, name, 1.0, 1.0, rate, steer_limits)?;
        let (w, _, s) = peaks(&probe);
        let mut amp = 0.5 * max_rate / w.max(1e-12);
        // The caster steers while it moves (rates ∝ amplitude); a swerve turns only at rest,
        // between segments, at rates that do not depend on the amplitude.
        let steers_moving = robot.kind() != Kind::Swerve;
        if let Some(ms) = max_steer
            && s > 0.0
            && steers_moving
        {
            amp = amp.min(0.5 * ms / s);
        }
        let mut tau = 1.0;
        let mut plan = build(&robot, name, amp, tau, rate, steer_limits)?;
        // The caster's steer rates are not linear in the twist (they depend on the steer
        // state): lower the amplitude until they fit, and lengthen the ramps until the wheel
        // acceleration does.
        for _ in 0..16 {
            let (_, a, s) = peaks(&plan);
            if let Some(ms) = max_steer
                && s > 0.5 * ms
                && steers_moving
            {
                amp *= 0.5 * ms / s * 0.95;
            } else if a > 0.5 * max_accel {
                tau *= a / (0.5 * max_accel) * 1.05;
            } else {
                break;
            }
            plan = build(&robot, name, amp, tau, rate, steer_limits)?;
        }
        out.push(SysidPlan {
            name,
            identifies,
            plan,
        });
    }
    if desc.kind() == "sphere-omni" {
        let limits = (max_rate, max_accel);
        out.push(SysidPlan {
            name: "stop",
            identifies: "the platform's centre-of-mass depth (com_depth) and rolling_resistance from the rocking after a short stop: record the IMU log",
            plan: sphere_stop(desc, &robot, Twist2::new(1.0, 0.0, 0.0), limits, rate)?,
        });
        out.push(SysidPlan {
            name: "spin-stop",
            identifies: "the floor's pivot friction (pivot_friction) from the spin's decay after a short stop of a spin in place: record the IMU log",
            plan: sphere_stop(desc, &robot, Twist2::new(0.0, 0.0, 1.0), limits, rate)?,
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

    /// The sphere gets a fifth plan, `stop` (and a sixth, `spin-stop`): within half its wheel-rate and acceleration
    /// limits, ending with [`STOP_REST`] s at rest, and its file's dynamic model swings by at
    /// most 95 % of `max_tilt_deg` (at half the rate limit the preset's swung 25°).
    #[test]
    fn the_spheres_stop_swings_within_its_tilt_limit() {
        use crate::dynamics::sphere::{SphereDynamics, simulate_plan};
        let d = RobotDescription::preset("sphere-omni").unwrap();
        let plans = sysid_plans(&d, 50.0).unwrap();
        assert_eq!(plans.len(), 6);
        let stop = &plans.iter().find(|p| p.name == "stop").unwrap().plan;
        let (w, a, _) = peaks(stop);
        assert!(
            w <= 0.5 * d.limits.max_wheel_rate.unwrap() * (1.0 + 1e-9),
            "{w}"
        );
        assert!(a <= 0.5 * d.limits.max_wheel_accel.unwrap() * 1.001, "{a}");
        let still = stop
            .samples
            .iter()
            .rev()
            .take_while(|s| s.wheel_rates[..3].iter().all(|r| *r == 0.0))
            .count();
        assert!(still as f64 / 50.0 >= STOP_REST - 0.05, "{still}");
        let limit = d
            .sphere_dynamics
            .as_ref()
            .unwrap()
            .max_tilt_deg
            .unwrap()
            .to_radians();
        let run = simulate_plan(SphereDynamics::from_description(&d).unwrap(), stop).unwrap();
        assert!(run.max_tilt <= 0.95 * limit, "{} of {limit}", run.max_tilt);
        assert!(
            run.max_tilt > 0.5 * limit,
            "the stop still swings: {}",
            run.max_tilt
        );
        // The spin's stop: within the same limits, a spin in place (it turns, it does not
        // travel), ending with the same rest.
        let spin = &plans.iter().find(|p| p.name == "spin-stop").unwrap().plan;
        let (w, a, _) = peaks(spin);
        assert!(
            w <= 0.5 * d.limits.max_wheel_rate.unwrap() * (1.0 + 1e-9),
            "{w}"
        );
        assert!(a <= 0.5 * d.limits.max_wheel_accel.unwrap() * 1.001, "{a}");
        let last = spin.samples.last().unwrap();
        assert!(last.pose.heading.abs() > 1.0 && last.pose.x.hypot(last.pose.y) < 1e-9);
        let still = spin
            .samples
            .iter()
            .rev()
            .take_while(|s| s.wheel_rates[..3].iter().all(|r| *r == 0.0))
            .count();
        assert!(still as f64 / 50.0 >= STOP_REST - 0.05, "{still}");
    }

    /// A swerve's modules turn only at rest, between segments, within half the steer limits,
    /// and keep one angle while the wheels roll (a reversal would otherwise flip them by π in
    /// one sample): the steer angles of consecutive samples differ by at most the limit × dt.
    #[test]
    fn a_swerve_turns_its_modules_at_rest() {
        let d = RobotDescription::preset("swerve4").unwrap();
        let ms = d.limits.max_steer_rate.unwrap();
        let plans = sysid_plans(&d, 50.0).unwrap();
        assert_eq!(plans.len(), 4);
        for p in &plans {
            let mut turned = false;
            for w in p.plan.samples.windows(2) {
                let (Some((a, _)), Some((b, rates))) = (w[0].steer, w[1].steer) else {
                    panic!("swerve samples carry steering")
                };
                for i in 0..4 {
                    let step = omnikin::wrap_angle(b[i] - a[i]).abs();
                    assert!(step <= 0.5 * ms * 0.02 * 1.001, "{}: step {step}", p.name);
                    assert!(rates[i].abs() <= 0.5 * ms * 1.001, "{}", p.name);
                    if step > 1e-9 {
                        turned = true;
                        assert!(
                            w[1].wheel_rates[i].abs() < 1e-12,
                            "{}: module {i} turns while rolling",
                            p.name
                        );
                    }
                }
            }
            let (w, _, _) = peaks(&p.plan);
            let lim = d.limits.max_wheel_rate.unwrap();
            assert!(
                w <= 0.5 * lim * (1.0 + 1e-9) && w > 0.3 * lim,
                "{}: {w}",
                p.name
            );
            if p.name != "along" {
                assert!(turned, "{} never turns its modules", p.name);
            }
        }
    }
}
