//! The kinematic plant: a plan's motor commands → what the motors actually did → how the
//! robot actually moved (forward kinematics, exact SE(2) steps).

use omnikin::caster::CasterRates;
use omnikin::{Pose2, Robot, Twist2, se2};
use omnikin_plan::Plan;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::motor::Motor;
use crate::profile::{Hold, Profile};

/// One simulated run, recorded at the plan's sample times.
#[derive(Clone, Debug, PartialEq)]
pub struct Trial {
    /// Sample times, s (the plan's).
    pub t: Vec<f64>,
    /// True pose of the robot centre (world frame; heading unwrapped).
    pub pose: Vec<Pose2<f64>>,
    /// What the tracker recorded: the tracked point with tracking noise, m (world frame).
    pub tracked: Vec<[f64; 2]>,
    /// Caster: slip residual of the least-squares forward kinematics at the last plant step
    /// before each sample, m/s (0 for the other robots).
    pub slip_residual: Vec<f64>,
    /// Actual cumulative wheel (roll) angles, rad: the encoders' ground truth.
    pub wheel_angles: Vec<[f64; 3]>,
    /// Caster: actual steer angles, rad.
    pub steer_angles: Vec<[f64; 3]>,
}

/// A simulation that could not run.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The plan and the robot do not fit together.
    #[error("{0}")]
    Mismatch(String),
    /// The kinematics rejected a state (non-finite values: the simulated motion diverged).
    #[error("at t = {t:.4} s: {source}")]
    Kinematics {
        /// Simulation time, s.
        t: f64,
        /// The core's error.
        source: omnikin::InputError,
    },
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// Simulates one trial of `plan` on `robot` under the disturbances of `profile`, drawing all
/// randomness from `rng` (seed one generator per trial for reproducible Monte Carlo).
///
/// The plan's wheel (and steer) rates are motor set-points, interpolated between samples per
/// `profile.hold`; each motor model ([`crate::profile::MotorProfile`]) turns them into actual
/// angle increments; the increments, scaled by the per-trial wheel-radius errors and roller
/// modulation, go through the robot's forward kinematics (sphere: with the shell spin of the
/// profile; caster: least squares over all six motors, recording the slip residual), the
/// floor slip scales the resulting body velocity, and [`omnikin::se2::integrate`] advances the
/// pose exactly over each plant step. Plant steps divide each plan interval evenly, so the
/// state lands exactly on every sample time.
pub fn simulate_trial(
    robot: &Robot<f64>,
    plan: &Plan,
    profile: &Profile,
    rng: &mut ChaCha8Rng,
) -> Result<Trial, SimError> {
    let samples = &plan.samples;
    let Some(first) = samples.first() else {
        return Err(SimError::Mismatch("the plan has no samples".into()));
    };
    let caster = matches!(robot, Robot::Caster(_));
    if caster != plan.is_caster() {
        return Err(SimError::Mismatch(if caster {
            "robot is caster3 but the plan has no steer columns (s1..s3, sd1..sd3)".into()
        } else {
            "the plan has caster steer columns but the robot is not caster3".into()
        }));
    }
    let rate = profile.rate_hz();
    let wm = profile.wheel_motor;
    let radius_scale: [f64; 3] =
        core::array::from_fn(|_| 1.0 + wm.radius_error_std.unwrap_or(0.0) * gauss(rng));
    let const_spin = profile.shell_spin.std.unwrap_or(0.0) * gauss(rng);
    let roller_amp = profile.roller.amplitude.unwrap_or(0.0);
    let rollers = profile.roller.rollers.unwrap_or(8) as f64;
    let roller_phase: [f64; 3] =
        core::array::from_fn(|_| rng.random_range(0.0..core::f64::consts::TAU));
    let floor_std = profile.floor.rel_std.unwrap_or(0.0);
    let floor_tau = profile.floor.corr_time.unwrap_or(0.5);
    let mut floor = [0.0f64; 3];
    if floor_std > 0.0 {
        floor = core::array::from_fn(|_| floor_std * gauss(rng));
    }
    let offset = profile.tracking.offset.unwrap_or([0.0, 0.0]);
    let noise = profile.tracking.noise_std.unwrap_or(0.0);

    let mut wheels: [Motor; 3] = core::array::from_fn(|i| Motor::new(wm, first.wheel_rates[i]));
    let (first_steer, first_steer_rates) = first.steer.unwrap_or(([0.0; 3], [0.0; 3]));
    let mut steer_motors: [Motor; 3] =
        core::array::from_fn(|i| Motor::new(profile.steer_motor, first_steer_rates[i]));
    let mut steer = first_steer;
    let mut pose = first.pose;
    let mut slip = 0.0;

    let n = samples.len();
    let mut out = Trial {
        t: Vec::with_capacity(n),
        pose: Vec::with_capacity(n),
        tracked: Vec::with_capacity(n),
        slip_residual: Vec::with_capacity(n),
        wheel_angles: Vec::with_capacity(n),
        steer_angles: Vec::with_capacity(n),
    };
    let mut record = |t: f64,
                      pose: Pose2<f64>,
                      slip: f64,
                      wheels: &[Motor; 3],
                      steer: [f64; 3],
                      rng: &mut ChaCha8Rng| {
        let (s, c) = pose.heading.sin_cos();
        let mut p = [
            pose.x + c * offset[0] - s * offset[1],
            pose.y + s * offset[0] + c * offset[1],
        ];
        if noise > 0.0 {
            p[0] += noise * gauss(rng);
            p[1] += noise * gauss(rng);
        }
        out.t.push(t);
        out.pose.push(pose);
        out.tracked.push(p);
        out.slip_residual.push(slip);
        out.wheel_angles
            .push(core::array::from_fn(|i| wheels[i].angle()));
        out.steer_angles.push(steer);
    };
    record(first.t, pose, 0.0, &wheels, steer, rng);

    for k in 0..n - 1 {
        let (a, b) = (&samples[k], &samples[k + 1]);
        let interval = b.t - a.t;
        let steps = ((interval * rate).round() as usize).max(1);
        let dt = interval / steps as f64;
        let (sa, sb) = (
            a.steer.map(|s| s.1).unwrap_or([0.0; 3]),
            b.steer.map(|s| s.1).unwrap_or([0.0; 3]),
        );
        for j in 0..steps {
            let f = match profile.hold {
                Hold::Linear => (j as f64 + 0.5) / steps as f64,
                Hold::Zoh => 0.0,
            };
            let t = a.t + j as f64 * dt;
            let lerp = |x: f64, y: f64| x + (y - x) * f;
            // Effective wheel rates: motor output × radius error × roller modulation.
            let mut w = [0.0; 3];
            for i in 0..3 {
                let q0 = wheels[i].angle();
                let dq = wheels[i].step(lerp(a.wheel_rates[i], b.wheel_rates[i]), dt, rng);
                let mut eff = dq / dt * radius_scale[i];
                if roller_amp > 0.0 {
                    eff *= 1.0 + roller_amp * (rollers * (q0 + 0.5 * dq) + roller_phase[i]).cos();
                }
                w[i] = eff;
            }
            let kin = |source| SimError::Kinematics { t, source };
            let mut twist = match robot {
                Robot::Sphere(m) => {
                    let tw0 = m.body_twist(w, 0.0).map_err(kin)?;
                    // ω̃_z = −tw0.yaw_rate; Ω3 = const + g·|V|^p·ω̃_z.
                    let speed = tw0.vx.hypot(tw0.vy);
                    let g = profile.shell_spin.slip_gain.unwrap_or(0.0);
                    let p = profile.shell_spin.slip_exponent.unwrap_or(1.0);
                    let spin = const_spin + g * speed.powf(p) * (-tw0.yaw_rate);
                    Twist2::new(tw0.vx, tw0.vy, tw0.yaw_rate + spin)
                }
                Robot::Ballbot(m) => m.body_twist(w, const_spin).map_err(kin)?,
                Robot::Caster(m) => {
                    let mut sd = [0.0; 3];
                    let mut steer_next = steer;
                    for i in 0..3 {
                        let d = steer_motors[i].step(lerp(sa[i], sb[i]), dt, rng);
                        sd[i] = d / dt;
                        steer_next[i] += d;
                    }
                    // Forward kinematics at the mid-step steer angles.
                    let mid: [f64; 3] = core::array::from_fn(|i| 0.5 * (steer[i] + steer_next[i]));
                    let fwd = m
                        .body_twist(&CasterRates { roll: w, steer: sd }, pose.heading, mid)
                        .map_err(kin)?;
                    slip = fwd.slip_residual;
                    steer = steer_next;
                    fwd.twist.to_robot(pose.heading)
                }
            };
            if floor_std > 0.0 {
                let decay = (-dt / floor_tau).exp();
                let kick = floor_std * (1.0 - decay * decay).sqrt();
                for e in floor.iter_mut() {
                    *e = *e * decay + kick * gauss(rng);
                }
                twist = Twist2::new(
                    twist.vx * (1.0 + floor[0]),
                    twist.vy * (1.0 + floor[1]),
                    twist.yaw_rate * (1.0 + floor[2]),
                );
            }
            pose = se2::integrate(pose, twist, dt);
        }
        record(b.t, pose, slip, &wheels, steer, rng);
    }
    Ok(out)
}
