//! A plan through the balancing ballbot: the core's balance controller at its control rate
//! following a plan's world velocities with the previewed lean ([`super::preview`]), on the 3D
//! model, with seeded sensor noise, an optional initial lean and pushes — what
//! `omnikin simulate --robot ballbot --plant dynamic` runs.
//!
//! **Timeline.** The robot stands still for [`PlanRunOptions::lead_in`] (the previewed lean
//! starts ≈ 1/z ≈ 0.27 s before the plan accelerates, so it needs a lead-in), then follows the
//! plan (its velocities linearly interpolated onto the control grid, accelerations by
//! differences, yaw rate from the plan), then holds still for [`PlanRunOptions::tail`]. Pushes
//! and the initial lean happen on this timeline (closed-loop time 0 = start of the lead-in).
//! The [`Trial`] is sampled at the plan's sample times (ball centre as the tracked point, body
//! yaw as the heading, the wheel angles as the encoders); the tilt figures cover the whole run.
//!
//! **Noise** (white, per control cycle, [`SensorNoise::typical`]): tilt 0.05°, tilt and yaw
//! rate 0.005 rad/s, ball position 1 mm, ball velocity 5 mm/s (an AHRS and tilt-corrected
//! wheel odometry of the Kugle class), from a seeded ChaCha8 stream.
//!
//! **Fall.** The controller latches its fall state (motors off) when the tilt passes its fall
//! threshold; the model keeps falling until the body tilts past [`FLOOR_TILT`], where it would
//! hit the floor (not modelled): from there the robot lies still where it fell.

use omnikin::control::{BalanceCommand, BalanceConfig, BalanceController, BalanceState};
use omnikin::nalgebra::{UnitQuaternion, Vector3};
use omnikin::{MAX_WHEELS, Pose2};
use omnikin_plan::Plan;
use rand_distr::{Distribution, StandardNormal};

use super::closed_loop::Push;
use super::preview::lean_preview;
use super::{BallbotDynamics, BallbotPlant, BallbotState};
use crate::Trial;

/// Tilt at which a falling body would touch the floor, rad (80°): the run freezes there.
pub const FLOOR_TILT: f64 = 80.0 * core::f64::consts::PI / 180.0;

/// Standard deviations of the white sensor noise added to each control cycle's measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorNoise {
    /// Tilt angles, rad.
    pub tilt: f64,
    /// Tilt and yaw rates, rad/s.
    pub rate: f64,
    /// Ball position, m.
    pub position: f64,
    /// Ball velocity, m/s.
    pub velocity: f64,
}

impl SensorNoise {
    /// Tilt 0.05°, rates 0.005 rad/s, position 1 mm, velocity 5 mm/s (module doc).
    pub fn typical() -> Self {
        Self {
            tilt: 0.05f64.to_radians(),
            rate: 0.005,
            position: 0.001,
            velocity: 0.005,
        }
    }

    /// No noise.
    pub fn none() -> Self {
        Self {
            tilt: 0.0,
            rate: 0.0,
            position: 0.0,
            velocity: 0.0,
        }
    }
}

/// How a plan is run through the balancing robot.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanRunOptions {
    /// Standing still before the plan starts, s.
    pub lead_in: f64,
    /// Holding still after the plan ends, s.
    pub tail: f64,
    /// Initial lean, rad: the body z axis tilted toward +x (about +y) at closed-loop time 0.
    pub initial_tilt: f64,
    /// Pushes, closed-loop time.
    pub pushes: Vec<Push>,
    /// Sensor noise.
    pub noise: SensorNoise,
    /// Seed of the noise stream.
    pub seed: u64,
    /// RK4 steps of the model per control cycle (≥ 1).
    pub substeps: usize,
}

impl Default for PlanRunOptions {
    /// Lead-in 1 s, tail 2 s, upright, no pushes, [`SensorNoise::typical`], seed 1, 5 RK4
    /// steps per cycle (1 kHz at 200 Hz).
    fn default() -> Self {
        Self {
            lead_in: 1.0,
            tail: 2.0,
            initial_tilt: 0.0,
            pushes: Vec::new(),
            noise: SensorNoise::typical(),
            seed: 1,
            substeps: 5,
        }
    }
}

/// What a plan run gives.
#[derive(Clone, Debug)]
pub struct PlanRun {
    /// The run at the plan's sample times (same shape as a kinematic trial).
    pub trial: Trial,
    /// Closed-loop time of every control cycle, s (0 = start of the lead-in).
    pub t: Vec<f64>,
    /// True tilt at every control cycle, rad.
    pub tilt: Vec<f64>,
    /// Ball centre at every control cycle, world frame, m.
    pub position: Vec<[f64; 2]>,
    /// Largest tilt over the run, rad.
    pub max_tilt: f64,
    /// Tilt at the end of the run (after the tail), rad.
    pub final_tilt: f64,
    /// Closed-loop time at which the controller detected a fall (motors off), s.
    pub fallen_at: Option<f64>,
    /// Control cycles whose torque request the limit scaled down.
    pub saturated_cycles: usize,
    /// Largest applied wheel torque magnitude per wheel, N·m.
    pub peak_torque: [f64; 3],
    /// Closed-loop time at which the plan starts (the lead-in), s.
    pub plan_start: f64,
}

/// Why a plan could not be run.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlanRunError {
    /// The robot's parameters or the controller's design were rejected (its message and
    /// source are the inner error's: a chain prints the cause once).
    #[error(transparent)]
    Balance(#[from] omnikin::control::BalanceError),
    /// The controller rejected a measurement (the state diverged).
    #[error(transparent)]
    Input(#[from] omnikin::InputError),
    /// The plan is not one this run can follow.
    #[error("{0}")]
    Plan(String),
}

/// The plan's world velocity at plan time `t` (linear interpolation, rest outside).
fn velocity_at(plan: &Plan, t: f64) -> [f64; 2] {
    let s = &plan.samples;
    if t < s[0].t || t > s[s.len() - 1].t {
        return [0.0; 2];
    }
    let i = s.partition_point(|x| x.t <= t).clamp(1, s.len() - 1);
    let (a, b) = (&s[i - 1], &s[i]);
    let w = if b.t > a.t {
        ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0)
    } else {
        1.0
    };
    [
        a.twist.vx + w * (b.twist.vx - a.twist.vx),
        a.twist.vy + w * (b.twist.vy - a.twist.vy),
    ]
}

/// The yaw rate of the sample at or before plan time `t` (0 outside the plan).
fn yaw_rate_at(plan: &Plan, t: f64) -> f64 {
    let s = &plan.samples;
    if t < s[0].t || t > s[s.len() - 1].t {
        return 0.0;
    }
    let i = s.partition_point(|x| x.t <= t).max(1);
    s[i - 1].twist.yaw_rate
}

/// Runs `plan` through the ballbot `dynamics` balanced by a controller built from `config`
/// (module doc).
///
/// # Errors
/// [`PlanRunError::Balance`] when the parameters or the design are rejected,
/// [`PlanRunError::Plan`] for a plan with fewer than two samples or over 1 hour,
/// [`PlanRunError::Input`] when the state diverges.
pub fn run_plan(
    dynamics: BallbotDynamics,
    config: BalanceConfig<f64>,
    plan: &Plan,
    opts: &PlanRunOptions,
) -> Result<PlanRun, PlanRunError> {
    let s = &plan.samples;
    if s.len() < 2 {
        return Err(PlanRunError::Plan(
            "the plan needs at least two samples".into(),
        ));
    }
    let t0 = s[0].t;
    let duration = s[s.len() - 1].t - t0;
    if !(duration.is_finite() && duration <= 3600.0) {
        return Err(PlanRunError::Plan(format!(
            "the plan lasts {duration} s; a dynamic run takes at most 3600 s"
        )));
    }
    let plant = BallbotPlant::new(dynamics)?;
    let mut controller = BalanceController::new(config)?;
    let dt = controller.period();
    let lead = opts.lead_in.max(0.0);
    let total = lead + duration + opts.tail.max(0.0);
    let cycles = (total / dt).ceil() as usize + 1;
    // Commands on the control grid.
    let vel: Vec<[f64; 2]> = (0..cycles)
        .map(|k| velocity_at(plan, k as f64 * dt - lead + t0))
        .collect();
    let acc: Vec<[f64; 2]> = (0..cycles)
        .map(|k| {
            let n = vel[(k + 1).min(cycles - 1)];
            [(n[0] - vel[k][0]) / dt, (n[1] - vel[k][1]) / dt]
        })
        .collect();
    let lean = lean_preview(&plant.params().plant_params(), dt, &vel, &acc);
    // Start: the plan's first pose, leaning by the initial tilt.
    let mut state: BallbotState = plant.upright(s[0].pose.heading);
    state.position = [s[0].pose.x, s[0].pose.y];
    state.orientation =
        UnitQuaternion::from_axis_angle(&Vector3::y_axis(), opts.initial_tilt) * state.orientation;
    let yaw0 = s[0].pose.heading;
    let mut rng = crate::trial_rng(opts.seed, 0);
    let mut n = move || -> f64 { StandardNormal.sample(&mut rng) };
    let nz = opts.noise;
    let mut pushed = vec![false; opts.pushes.len()];
    let sub = opts.substeps.max(1);
    let h = dt / sub as f64;
    let mut run = PlanRun {
        trial: Trial {
            wheels: 3,
            t: Vec::new(),
            pose: Vec::new(),
            tracked: Vec::new(),
            slip_residual: Vec::new(),
            wheel_angles: Vec::new(),
            encoder_angles: Vec::new(),
            steer_angles: Vec::new(),
        },
        t: Vec::with_capacity(cycles),
        tilt: Vec::with_capacity(cycles),
        position: Vec::with_capacity(cycles),
        max_tilt: 0.0,
        final_tilt: 0.0,
        fallen_at: None,
        saturated_cycles: 0,
        peak_torque: [0.0; 3],
        plan_start: lead,
    };
    let mut states = Vec::with_capacity(cycles);
    let mut yaw_unwrapped = Vec::with_capacity(cycles);
    let mut last_yaw = yaw0;
    let mut lying = false;
    for k in 0..cycles {
        let t = k as f64 * dt;
        for (i, p) in opts.pushes.iter().enumerate() {
            if !pushed[i] && t >= p.time {
                if !lying {
                    plant.apply_impulse(&mut state, Vector3::new(p.impulse[0], p.impulse[1], 0.0));
                }
                pushed[i] = true;
            }
        }
        let tilt = plant.tilt(&state);
        run.t.push(t);
        run.tilt.push(tilt);
        run.position.push(state.position);
        run.max_tilt = run.max_tilt.max(tilt);
        let (_, _, yaw) = state.orientation.euler_angles();
        last_yaw += omnikin::wrap_angle(yaw - last_yaw);
        yaw_unwrapped.push(last_yaw);
        states.push(state);
        if lying || k + 1 == cycles {
            continue;
        }
        let mut m = plant.measurement(&state);
        for i in 0..2 {
            m.tilt[i] += nz.tilt * n();
            m.tilt_rate[i] += nz.rate * n();
            m.ball_position[i] += nz.position * n();
            m.ball_velocity[i] += nz.velocity * n();
        }
        m.yaw_rate += nz.rate * n();
        let cmd = BalanceCommand {
            velocity: vel[k],
            acceleration: acc[k],
            yaw_rate: yaw_rate_at(plan, t - lead + t0),
            lean: Some(lean[k]),
        };
        let out = controller.step(&m, &cmd)?;
        if out.status == BalanceState::Fallen && run.fallen_at.is_none() {
            run.fallen_at = Some(t);
        }
        run.saturated_cycles += out.saturated as usize;
        for i in 0..3 {
            run.peak_torque[i] = run.peak_torque[i].max(out.wheel_torques[i].abs());
        }
        for _ in 0..sub {
            plant.step(&mut state, out.wheel_torques, Vector3::zeros(), h);
        }
        if run.fallen_at.is_some() && plant.tilt(&state) >= FLOOR_TILT {
            // On the floor: it lies still (the impact is not modelled).
            state.ball_rate = Vector3::zeros();
            state.body_rate = Vector3::zeros();
            lying = true;
        }
    }
    run.final_tilt = *run.tilt.last().unwrap_or(&0.0);
    // The trial at the plan's sample times (linear interpolation between cycles).
    for smp in s {
        let tc = smp.t - t0 + lead;
        let k = ((tc / dt).floor() as usize).min(cycles - 1);
        let k1 = (k + 1).min(cycles - 1);
        let w = (tc / dt - k as f64).clamp(0.0, 1.0);
        let (a, b) = (&states[k], &states[k1]);
        let lerp = |x: f64, y: f64| x + w * (y - x);
        let xy = [
            lerp(a.position[0], b.position[0]),
            lerp(a.position[1], b.position[1]),
        ];
        let heading = lerp(yaw_unwrapped[k], yaw_unwrapped[k1]);
        let mut ang = [0.0; MAX_WHEELS];
        for i in 0..3 {
            ang[i] = lerp(a.wheel_angles[i], b.wheel_angles[i]);
        }
        run.trial.t.push(smp.t);
        run.trial.pose.push(Pose2::new(xy[0], xy[1], heading));
        run.trial.tracked.push(xy);
        run.trial.slip_residual.push(0.0);
        run.trial.wheel_angles.push(ang);
        run.trial.encoder_angles.push(ang);
        run.trial.steer_angles.push([0.0; MAX_WHEELS]);
    }
    Ok(run)
}
