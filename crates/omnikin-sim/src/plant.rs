//! The open-loop simulator: a plan's motor set-points, interpolated between samples, through
//! the one plant step of [`crate::plant_step`] (motor models, forward kinematics, exact SE(2)
//! steps), recorded at the plan's sample times with what a tracker and the encoders would see.

use omnikin::{Actuators, MAX_WHEELS, Pose2, Robot};
use omnikin_plan::Plan;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::limits::MAX_PLANT_STEPS;
use crate::plant_step::{Motors, Plant};
use crate::profile::{Hold, Profile};

/// One simulated run, recorded at the plan's sample times.
#[derive(Clone, Debug, PartialEq)]
pub struct Trial {
    /// Number of wheels of the simulated robot: the used entries of the per-wheel arrays.
    pub wheels: usize,
    /// Sample times, s (the plan's).
    pub t: Vec<f64>,
    /// True pose of the robot centre (world frame; heading unwrapped).
    pub pose: Vec<Pose2<f64>>,
    /// What the tracker recorded: the tracked point with tracking noise, m (world frame).
    pub tracked: Vec<[f64; 2]>,
    /// Slip residual of the least-squares forward kinematics at the last plant step before
    /// each sample, m/s (0 for kinds with as many constraints as unknowns: sphere, ballbot,
    /// 3-wheel omni).
    pub slip_residual: Vec<f64>,
    /// Actual cumulative wheel (roll) angles, rad: the encoders' ground truth (entries
    /// `0..wheels` used).
    pub wheel_angles: Vec<[f64; MAX_WHEELS]>,
    /// What the wheel encoders read, rad: `wheel_angles` quantised down to whole counts
    /// (`[encoder] counts_per_rev`; equal to `wheel_angles` without an encoder profile).
    pub encoder_angles: Vec<[f64; MAX_WHEELS]>,
    /// Steerable kinds: actual steer angles, rad (zeros for the others).
    pub steer_angles: Vec<[f64; MAX_WHEELS]>,
}

impl Trial {
    /// An empty trial of a `wheels`-wheel robot with room for `n` samples.
    pub fn with_capacity(wheels: usize, n: usize) -> Self {
        Self {
            wheels,
            t: Vec::with_capacity(n),
            pose: Vec::with_capacity(n),
            tracked: Vec::with_capacity(n),
            slip_residual: Vec::with_capacity(n),
            wheel_angles: Vec::with_capacity(n),
            encoder_angles: Vec::with_capacity(n),
            steer_angles: Vec::with_capacity(n),
        }
    }
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
/// angle increments, and [`crate::plant_step::Plant::step`] moves the robot by them (wheel-radius
/// errors, roller modulation, forward kinematics with the spin law of the profile, floor slip,
/// an exact SE(2) step) — the same plant step as software in the loop
/// ([`crate::sil::SilPlant`]). The motors start at the first sample's rates, the pose and
/// steer angles at its pose and steer angles. Plant steps divide each plan interval evenly, so
/// the state lands exactly on every sample time.
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
    let steerable = robot.steerable();
    if plan.wheels != robot.wheels() {
        return Err(SimError::Mismatch(format!(
            "the plan has {} wheel columns but the robot ({}) has {} wheels",
            plan.wheels,
            robot.kind().name(),
            robot.wheels()
        )));
    }
    if steerable != plan.steerable() {
        return Err(SimError::Mismatch(if steerable {
            format!(
                "the robot ({}) steers its wheels but the plan has no steer columns (s1.., sd1..)",
                robot.kind().name()
            )
        } else {
            format!(
                "the plan has steer columns but the robot ({}) has no steering",
                robot.kind().name()
            )
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
    let (first_steer, first_steer_rates) = first
        .steer
        .unwrap_or(([0.0; MAX_WHEELS], [0.0; MAX_WHEELS]));
    let mut plant = Plant::new(*robot, profile, first.pose, first_steer, rng);
    let mut motors = Motors::new(&plant, profile, first.wheel_rates, first_steer_rates);

    let n = samples.len();
    let mut out = Trial::with_capacity(robot.wheels(), n);
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
    let offset = profile.tracking.offset.unwrap_or([0.0, 0.0]);
    let noise = profile.tracking.noise_std.unwrap_or(0.0);
    let mut record = |t: f64, plant: &Plant, motors: &Motors, rng: &mut ChaCha8Rng| {
        let pose = plant.pose();
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
        let angles = motors.wheel_angles();
        out.t.push(t);
        out.pose.push(pose);
        out.tracked.push(p);
        out.slip_residual.push(plant.slip_residual());
        out.wheel_angles.push(angles);
        out.encoder_angles.push(match count {
            Some(q) => angles.map(|a| (a / q).floor() * q),
            None => angles,
        });
        out.steer_angles.push(plant.steer_angles());
    };
    record(first.t, &plant, &motors, rng);

    for k in 0..n - 1 {
        let (a, b) = (&samples[k], &samples[k + 1]);
        let interval = b.t - a.t;
        let steps = ((interval * rate).round() as usize).max(1);
        let dt = interval / steps as f64;
        let (sa, sb) = (
            a.steer.map(|s| s.1).unwrap_or([0.0; MAX_WHEELS]),
            b.steer.map(|s| s.1).unwrap_or([0.0; MAX_WHEELS]),
        );
        for j in 0..steps {
            let f = match profile.hold {
                Hold::Linear => (j as f64 + 0.5) / steps as f64,
                Hold::Zoh => 0.0,
            };
            let lerp = |x: f64, y: f64| x + (y - x) * f;
            let wheel = core::array::from_fn(|i| lerp(a.wheel_rates[i], b.wheel_rates[i]));
            let steer = core::array::from_fn(|i| lerp(sa[i], sb[i]));
            let motion = motors.step(wheel, steer, dt, rng);
            plant
                .step(&motion, dt, rng)
                .map_err(|source| SimError::Kinematics {
                    t: a.t + j as f64 * dt,
                    source,
                })?;
        }
        record(b.t, &plant, &motors, rng);
    }
    Ok(out)
}

/// Checks that `plan`'s wheel rates (and steering) are what `robot`'s inverse kinematics give
/// for the planned motion. Returns a description of the largest disagreement when it exceeds
/// 1e-6 relative (rad/s, or rad for steer angles), e.g. a plan made for another robot or
/// geometry. (Simulating a nominal plan on a deliberately different robot file is legitimate,
/// so callers usually warn.)
///
/// The steering compared is what the kind's inverse fixes: the steer **rates** of a kind whose
/// steer rates follow from the twist (the caster), the steer **angles** of one whose steer
/// angles are set-points ([`omnikin::Kind::steer_is_set_point`], swerve; the inverse is asked
/// from the plan's own angles, so a stopped module and the flip optimisation agree). The plan
/// must have the robot's wheel count ([`simulate_trial`] refuses it otherwise); only the first
/// `min(plan, robot)` wheels are compared.
pub fn plan_mismatch(robot: &Robot<f64>, plan: &Plan) -> Option<String> {
    // (excess, t, column, plan, robot)
    let mut worst: Option<(f64, f64, String, f64, f64)> = None;
    let n = robot.wheels().min(plan.wheels);
    let set_point = robot.kind().steer_is_set_point();
    for s in &plan.samples {
        let current = match s.steer {
            Some((g, _)) => Actuators::at_steer(&g[..n]),
            None => Actuators::zero(),
        };
        let Ok(a) = robot.inverse_world(s.twist, s.pose.heading, &current) else {
            continue;
        };
        let mut pairs: Vec<(String, f64, f64)> = (0..n)
            .map(|i| (format!("w{}", i + 1), s.wheel_rates[i], a.wheel_rates[i]))
            .collect();
        if let (true, Some((g, gd))) = (robot.steerable(), s.steer) {
            pairs.extend((0..n).map(|i| {
                if set_point {
                    // The planned angle against the inverse's, as the nearest equivalent angle.
                    let e = g[i] + omnikin::wrap_angle(a.steer_angles[i] - g[i]);
                    (format!("s{}", i + 1), g[i], e)
                } else {
                    (format!("sd{}", i + 1), gd[i], a.steer_rates[i])
                }
            }));
        }
        for (name, p, e) in pairs {
            let excess = (p - e).abs() / (1.0 + e.abs());
            if excess > 1e-6 && worst.as_ref().is_none_or(|w| excess > w.0) {
                worst = Some((excess, s.t, name, p, e));
            }
        }
    }
    worst.map(|(_, t, name, p, e)| {
        let unit = if name.starts_with("s") && !name.starts_with("sd") { "rad" } else { "rad/s" };
        format!("the plan's {name} = {p:.6} {unit} at t = {t:.3} s, but this robot's inverse kinematics give {e:.6} {unit} (planned for another robot or geometry?)")
    })
}
