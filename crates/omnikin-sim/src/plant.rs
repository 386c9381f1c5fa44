//! The kinematic plant: a plan's motor commands → what the motors actually did → how the
//! robot actually moved (forward kinematics, exact SE(2) steps).

use omnikin::caster::CasterRates;
use omnikin::{Pose2, Robot, Twist2, se2};
use omnikin_plan::Plan;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::limits::MAX_PLANT_STEPS;
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
    /// What the wheel encoders read, rad: `wheel_angles` quantised down to whole counts
    /// (`[encoder] counts_per_rev`; equal to `wheel_angles` without an encoder profile).
    pub encoder_angles: Vec<[f64; 3]>,
    /// Caster: actual steer angles, rad.
    pub steer_angles: Vec<[f64; 3]>,
}

/// A simulation that could not run.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The plan and the robot do not fit together.
    #[error("{0}")]
    Mismatch(String),
    /// The simulation would need more work or memory than a stated limit of
    /// [`crate::limits`] allows (checked before it starts).
    #[error(
        "{what} needs {needed:.4e} {items}, more than the limit {limit} = {max:e} \
         (omnikin_sim::limits); {hint}"
    )]
    TooLarge {
        /// What would grow, and why.
        what: String,
        /// What is counted (`plant steps`, `trial samples`).
        items: &'static str,
        /// How many the inputs imply.
        needed: f64,
        /// The limit's name (a constant of [`crate::limits`]).
        limit: &'static str,
        /// The limit's value.
        max: f64,
        /// What to change to stay within it.
        hint: &'static str,
    },
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
///
/// # Errors
/// [`SimError::Mismatch`] for an empty plan or a plan of another robot kind;
/// [`SimError::TooLarge`] when the plan needs more than [`crate::limits::MAX_PLANT_STEPS`]
/// plant steps (checked before simulating); [`SimError::Kinematics`] if the motion diverges.
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
    // Every plant step is work: bound their number before starting (a plan whose last time
    // is 1e300 s would otherwise loop for ever). NaN and infinities fail the comparison.
    let steps: f64 = samples
        .windows(2)
        .map(|w| ((w[1].t - w[0].t) * rate).round().max(1.0))
        .sum();
    if steps.is_nan() || steps > MAX_PLANT_STEPS {
        let duration = samples[samples.len() - 1].t - first.t;
        return Err(SimError::TooLarge {
            what: format!("a trial (plan duration {duration:.4e} s × plant rate {rate} Hz)"),
            items: "plant steps",
            needed: steps,
            limit: "MAX_PLANT_STEPS",
            max: MAX_PLANT_STEPS,
            hint: "shorten the plan (check its t column) or lower the profile's plant `rate`",
        });
    }
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
        encoder_angles: Vec::with_capacity(n),
        steer_angles: Vec::with_capacity(n),
    };
    let count = profile
        .encoder
        .counts_per_rev
        .map(|c| core::f64::consts::TAU / c as f64);
    let height = profile.tracking.height.unwrap_or(0.0);
    let tilt_gain = profile.tracking.tilt_gain.unwrap_or(0.0);
    // Previous recorded (time, position) and (time, velocity) of the centre, for the
    // quasi-static lean: velocities and accelerations by differences between samples, so the
    // step-to-step jitter of a stepper does not read as acceleration.
    let mut last_position: Option<(f64, [f64; 2])> = None;
    let mut last_velocity: Option<(f64, [f64; 2])> = None;
    // Shell (ballbot: ball) spin about the vertical, Ω3 = const + g·|V|^p·ω̃_z, added to the
    // yaw rate of a twist computed with Ω3 = 0 (where ω̃_z = −yaw rate).
    let (spin_gain, spin_exp) = (
        profile.shell_spin.slip_gain.unwrap_or(0.0),
        profile.shell_spin.slip_exponent.unwrap_or(1.0),
    );
    let with_spin = |tw0: Twist2<f64>| {
        let spin = const_spin + spin_gain * tw0.vx.hypot(tw0.vy).powf(spin_exp) * (-tw0.yaw_rate);
        Twist2::new(tw0.vx, tw0.vy, tw0.yaw_rate + spin)
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
        if tilt_gain > 0.0 && height != 0.0 {
            let here = [pose.x, pose.y];
            if let Some((t0, p0)) = last_position
                && t > t0
            {
                let v = [(here[0] - p0[0]) / (t - t0), (here[1] - p0[1]) / (t - t0)];
                if let Some((t1, v1)) = last_velocity
                    && t > t1
                {
                    // Two backward differences one interval apart (centred on the previous
                    // sample).
                    let dt = t - t1;
                    let a = [(v[0] - v1[0]) / dt, (v[1] - v1[1]) / dt];
                    let norm = a[0].hypot(a[1]);
                    if norm > 0.0 {
                        let lean = (tilt_gain * norm / 9.80665).atan();
                        let shift = -height * lean.sin() / norm;
                        p[0] += shift * a[0];
                        p[1] += shift * a[1];
                    }
                }
                last_velocity = Some((t, v));
            }
            last_position = Some((t, here));
        }
        if noise > 0.0 {
            p[0] += noise * gauss(rng);
            p[1] += noise * gauss(rng);
        }
        let angles: [f64; 3] = core::array::from_fn(|i| wheels[i].angle());
        out.t.push(t);
        out.pose.push(pose);
        out.tracked.push(p);
        out.slip_residual.push(slip);
        out.wheel_angles.push(angles);
        out.encoder_angles.push(match count {
            Some(q) => angles.map(|a| (a / q).floor() * q),
            None => angles,
        });
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
                Robot::Sphere(m) => with_spin(m.body_twist(w, 0.0).map_err(kin)?),
                Robot::Ballbot(m) => with_spin(m.body_twist(w, 0.0).map_err(kin)?),
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
                _ => {
                    return Err(kin(omnikin::InputError::Singular {
                        reason: "this robot kind is not simulated yet",
                    }));
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

/// Checks that `plan`'s wheel (and steer) rates are what `robot`'s inverse kinematics give for
/// the planned motion. Returns a description of the largest disagreement when it exceeds
/// 1e-6 rad/s relative, e.g. a plan made for another robot or geometry. (Simulating a nominal
/// plan on a deliberately different robot file is legitimate, so callers usually warn.)
pub fn plan_mismatch(robot: &Robot<f64>, plan: &Plan) -> Option<String> {
    let mut worst: Option<(f64, f64, usize, f64, f64)> = None; // (excess, t, wheel, plan, robot)
    for s in &plan.samples {
        let expected: Option<Vec<f64>> = match robot {
            Robot::Sphere(m) => m
                .wheel_rates_world(s.twist, s.pose.heading, 0.0)
                .ok()
                .map(|w| w.to_vec()),
            Robot::Ballbot(m) => m
                .wheel_rates_world(s.twist, s.pose.heading, 0.0)
                .ok()
                .map(|w| w.to_vec()),
            Robot::Caster(m) => s
                .steer
                .and_then(|(g, _)| m.motor_rates(s.twist, s.pose.heading, g).ok())
                .map(|r| r.roll.iter().chain(&r.steer).copied().collect()),
            _ => None,
        };
        let Some(expected) = expected else { continue };
        let planned: Vec<f64> = s
            .wheel_rates
            .iter()
            .chain(s.steer.iter().flat_map(|(_, sd)| sd.iter()))
            .copied()
            .collect();
        for (i, (&p, &e)) in planned.iter().zip(&expected).enumerate() {
            let excess = (p - e).abs() / (1.0 + e.abs());
            if excess > 1e-6 && worst.is_none_or(|w| excess > w.0) {
                worst = Some((excess, s.t, i, p, e));
            }
        }
    }
    worst.map(|(_, t, i, p, e)| {
        let name = if i < 3 { format!("w{}", i + 1) } else { format!("sd{}", i - 2) };
        format!("the plan's {name} = {p:.6} rad/s at t = {t:.3} s, but this robot's inverse kinematics give {e:.6} rad/s (planned for another robot or geometry?)")
    })
}
