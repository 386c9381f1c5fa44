//! The sphere in closed loop: the core [`Runtime`] — the firmware's control loop — follows a
//! plan on the dynamic shell + platform plant ([`SilPlant::dynamic`]), fusing the fixes of a
//! simulated overhead camera ([`Camera`]).
//!
//! Every control period (the runtime's [`Config::rate_hz`]):
//! 1. the camera is offered the **truth** — the tracked point
//!    ([`crate::dynamics::sphere::SphereDynamics::tracked_height`], what paper 000's video tracks) and the platform's
//!    heading — and takes a frame when its clock says so; each fix that has arrived (capture
//!    time + latency) goes to the runtime as a [`Command::Fix`] stamped with its **capture**
//!    time and σ = the camera's noise, as the link would deliver it;
//! 2. the runtime's cycle reads the plant's encoders (the stepper angles) and IMU (the tilted
//!    platform's gyro, and its accelerometer's specific force at the platform's centre of mass,
//!    [`crate::sil::SilImu`]), runs its fusion and trajectory controller and writes
//!    wheel-rate set-points;
//! 3. each set-point is scaled by this trial's wheel error (radius error and speed fluctuation
//!    of [`DynamicProfile`], a rate error the encoders see) and the plant advances one period
//!    with it ([`SilPlant::advance`]).
//!
//! The truth is recorded at every cycle and interpolated to the plan's sample times, so the
//! result is a [`Trial`] that the metrics ([`crate::metrics::evaluate`]) score as they score
//! an open-loop run. A trial draws everything — the robot ([`DynamicProfile::draw_robot`]),
//! the wheel fluctuations, the camera's noise — from [`crate::trial_rng`]`(seed, index)` and a
//! second stream of it for the camera: one seed, one result, on any number of threads.
//!
//! The controller is the runtime's own (`v = v_ref + k_position · (p_ref − p̂)`, clamped to
//! `max_correction`; docs of [`omnikin::runtime`]) with, when [`Config::tilt`] is set, its tilt
//! feedback and lean feed-forward ([`omnikin::runtime::TiltFeedback`], designed here by
//! [`tilt_feedback`] from the dynamics, its linearised figures by [`tilt_margins`] and, with
//! the runtime's tilt estimate in the loop, by [`tilt_poles`]); nothing
//! here adds control. What is weak: the trajectory gains are [`Config::new`]'s, not designed
//! from the linearised dynamics, and the runtime's odometry is the level kinematic model's,
//! blind to the lean (the camera corrects it, with its latency). docs/closed-loop.md has the
//! measured table.

use omnikin::runtime::hal::{Encoders, Imu, MotorCommand, MotorOutputs};
use omnikin::runtime::{CameraFix, Command, CommandError, Config, FixCounters, PlanPoint, Runtime};
use omnikin::{MAX_WHEELS, Pose2, Robot};
use omnikin_plan::Plan;
use rand_distr::{Distribution, StandardNormal};

use crate::camera::Camera;
use crate::dynamics::sphere::{DynamicProfile, DynamicsError};
use crate::sensors::{CameraGaps, CameraProfile};
use crate::sil::{Held, SilImu, SilPlant};
use crate::{SimError, Trial};

/// Plan points the runtime holds ([`Runtime`]'s `N`): a longer plan is decimated evenly
/// (the runtime interpolates between points). 4096 points: 41 s of a 100 Hz plan.
pub const PLAN_CAPACITY: usize = 4096;

/// Points per [`Command::PlanChunk`] (the link's chunk size is irrelevant here: no link).
const CHUNK: usize = 64;

/// Smallest σ a fix is sent with, m: a noise-free camera still is not exact (the runtime
/// refuses σ = 0).
const MIN_FIX_STD: f64 = 1e-4;

/// How a closed-loop run is set up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosedLoopOptions {
    /// The runtime's configuration: control rate, limits, gains, fusion.
    pub config: Config<f64>,
    /// The plant and its trial-to-trial variation ([`DynamicProfile::exact`]: none).
    pub profile: DynamicProfile,
    /// The overhead camera and the frames it loses; `None`: no camera (odometry only).
    pub camera: Option<(CameraProfile, CameraGaps)>,
    /// The idealised accelerometer that reads gravity alone ([`SilImu::GravityOnly`]), for
    /// comparison; `false` (what a real IMU reads): the specific force at the platform's
    /// centre of mass ([`SilImu::at_centre_of_mass`]).
    pub gravity_only_imu: bool,
}

/// One closed-loop run.
#[derive(Clone, Debug, PartialEq)]
pub struct ClosedLoopTrial {
    /// The truth at the plan's sample times: shell centre with the platform's heading, the
    /// tracked point (no tracker noise: the metrics score the truth), the wheel angles.
    pub trial: Trial,
    /// Largest platform tilt, rad.
    pub max_tilt: f64,
    /// Pull-out events per motor.
    pub pull_outs: [u64; 3],
    /// What became of the camera's fixes in the runtime's fusion.
    pub fixes: FixCounters,
    /// Fixes the camera delivered.
    pub fixes_sent: u64,
    /// Distance between the runtime's estimate and the true shell centre at each sample, m.
    pub estimate_error: Vec<f64>,
    /// |wrapped runtime heading − true platform heading| at each sample, rad.
    pub heading_error: Vec<f64>,
}

/// Why a closed-loop run could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ClosedLoopError {
    /// The plan is unusable (the message says why).
    #[error("plan: {0}")]
    Plan(String),
    /// The runtime's configuration or a command was refused.
    #[error("runtime: {0}")]
    Runtime(String),
    /// The dynamic plant refused the robot or its parameters.
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    /// The camera's profile was refused (the message names the key).
    #[error("camera: {0}")]
    Camera(String),
    /// The plant diverged.
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// The motor board of one trial: the runtime's set-points scaled by the trial's wheel errors.
struct Scaled<'a> {
    plant: &'a mut SilPlant,
    scale: [f64; 3],
}

impl MotorOutputs<f64> for Scaled<'_> {
    type Error = core::convert::Infallible;
    fn set_rates(&mut self, c: &MotorCommand<f64>) -> Result<(), Self::Error> {
        let mut c = *c;
        for (w, k) in c.wheel.iter_mut().zip(self.scale) {
            *w *= k;
        }
        self.plant.set_rates(&c)
    }
}

/// The plan as the runtime's points, times from 0, decimated evenly (keeping the last) to
/// at most [`PLAN_CAPACITY`].
fn plan_points(plan: &Plan) -> Vec<PlanPoint<f64>> {
    let n = plan.samples.len();
    let t0 = plan.samples[0].t;
    let step = n.div_ceil(PLAN_CAPACITY - 1).max(1);
    let mut idx: Vec<usize> = (0..n).step_by(step).collect();
    if idx.last() != Some(&(n - 1)) {
        idx.push(n - 1);
    }
    idx.iter()
        .map(|&i| {
            let s = &plan.samples[i];
            PlanPoint {
                t: s.t - t0,
                pose: s.pose,
                twist: s.twist,
            }
        })
        .collect()
}

fn runtime_err(e: CommandError) -> ClosedLoopError {
    ClosedLoopError::Runtime(format!("{e:?}"))
}

/// The truth at one cycle.
#[derive(Clone, Copy)]
struct Sample {
    t: f64,
    pose: Pose2<f64>,
    tracked: [f64; 2],
    wheels: [f64; 3],
    estimate: Pose2<f64>,
}

fn lerp(a: f64, b: f64, u: f64) -> f64 {
    a + (b - a) * u
}

/// Runs `plan` (a `sphere-omni` plan) in closed loop: trial `index` of a run seeded `seed`.
/// The robot starts at rest, level, at the plan's first pose, and the runtime knows that pose.
///
/// # Errors
/// [`ClosedLoopError`]: a plan with fewer than two samples or not for three wheels, a
/// configuration or camera profile that is refused, a plant that diverges.
pub fn run(
    robot: Robot<f64>,
    plan: &Plan,
    opts: &ClosedLoopOptions,
    seed: u64,
    index: usize,
) -> Result<ClosedLoopTrial, ClosedLoopError> {
    if plan.samples.len() < 2 || plan.wheels != 3 {
        return Err(ClosedLoopError::Plan(format!(
            "the sphere's closed loop needs a plan for 3 wheels with at least 2 samples (got {} wheels, {} samples)",
            plan.wheels,
            plan.samples.len()
        )));
    }
    let mut rng = crate::trial_rng(seed, index);
    let (params, radius_scale) = opts.profile.draw_robot(&mut rng);
    let mut camera = match opts.camera {
        Some((p, g)) => {
            // The camera's own stream, so its noise does not move the plant's draws.
            let mut cam_rng = crate::trial_rng(seed, index);
            cam_rng.set_stream((1 << 32) | index as u64);
            Some(Camera::new(p, g, cam_rng).map_err(ClosedLoopError::Camera)?)
        }
        None => None,
    };
    let start = plan.samples[0].pose;
    let mut rt = Box::new(
        Runtime::<f64, PLAN_CAPACITY>::new(robot, opts.config, start)
            .map_err(|e| ClosedLoopError::Runtime(e.to_string()))?,
    );
    let mut plant = SilPlant::dynamic(robot, params, start)?;
    if opts.gravity_only_imu {
        plant.set_imu(SilImu::GravityOnly);
    }
    let points = plan_points(plan);
    let len = points.len() as u16;
    rt.handle(Command::PlanBegin { id: 1, len }, 0)
        .map_err(runtime_err)?;
    for (k, chunk) in points.chunks(CHUNK).enumerate() {
        let offset = (k * CHUNK) as u16;
        rt.handle(
            Command::PlanChunk {
                id: 1,
                offset,
                points: chunk,
            },
            0,
        )
        .map_err(runtime_err)?;
    }
    rt.handle(Command::PlanStart { id: 1 }, 0)
        .map_err(runtime_err)?;

    let dt = 1.0 / opts.config.rate_hz;
    let end = points[points.len() - 1].t;
    let cycles = (end / dt).ceil() as usize + 1;
    let zt = params.tracked_height - params.geometry.shell_radius;
    let fluct = opts.profile.fluctuation_rel;
    let (mut max_tilt, mut sent) = (0.0f64, 0u64);
    let mut samples: Vec<Sample> = Vec::with_capacity(cycles + 1);
    for _ in 0..=cycles {
        let now = plant.time_us();
        let t = now as f64 * 1e-6;
        let Some(sim) = plant.dynamics() else {
            return Err(ClosedLoopError::Plan("the plant is not dynamic".into()));
        };
        let st = sim.state();
        let k = st.platform_z();
        let pose = plant.true_pose();
        let tracked = [st.centre[0] + zt * k.x, st.centre[1] + zt * k.y];
        max_tilt = max_tilt.max(st.tilt());
        samples.push(Sample {
            t,
            pose,
            tracked,
            wheels: st.wheel_angles,
            estimate: rt.pose(),
        });
        if t > end + 1e-9 {
            break;
        }
        rt.handle(Command::Heartbeat, now).map_err(runtime_err)?;
        if let Some(cam) = camera.as_mut() {
            cam.capture(t, tracked[0], tracked[1], pose.heading);
            while let Some(f) = cam.deliver(t) {
                let std = cam.profile().noise_std.max(MIN_FIX_STD);
                let fix = CameraFix {
                    capture_us: (f.t * 1e6).round() as u64,
                    x: f.x,
                    y: f.y,
                    heading: f.heading,
                    std_xy: std,
                    std_heading: cam.profile().heading_noise_std.unwrap_or(1.0).max(1e-4),
                };
                sent += 1;
                // A refused fix (an outlier beyond the gate) is counted by the runtime.
                let _ = rt.handle(Command::Fix(fix), now);
            }
        }
        let enc = match Encoders::read(&mut plant) {
            Ok(e) => e,
            Err(e) => match e {},
        };
        let imu = match Imu::read(&mut plant) {
            Ok(i) => i,
            Err(e) => match e {},
        };
        let mut scale = radius_scale;
        if fluct > 0.0 {
            for s in scale.iter_mut() {
                let n: f64 = StandardNormal.sample(&mut rng);
                *s *= 1.0 + fluct * n;
            }
        }
        let mut board = Scaled {
            plant: &mut plant,
            scale,
        };
        rt.cycle(now, &mut Held(enc), &mut Held(imu), &mut board);
        plant.advance(dt)?;
    }
    let trial = resample(plan, &samples);
    let estimate_error = interpolate_error(plan, &samples, |s| {
        (s.estimate.x - s.pose.x).hypot(s.estimate.y - s.pose.y)
    });
    let heading_error = interpolate_error(plan, &samples, |s| {
        omnikin::wrap_angle(s.estimate.heading - s.pose.heading).abs()
    });
    let sim = plant.dynamics();
    Ok(ClosedLoopTrial {
        trial,
        max_tilt,
        pull_outs: sim.map_or([0; 3], |s| s.pull_outs()),
        fixes: rt.fix_counters(),
        fixes_sent: sent,
        estimate_error,
        heading_error,
    })
}

/// Index `j` and weight `u` such that plan time `t` lies between cycles `j` and `j + 1`.
fn bracket(samples: &[Sample], t: f64) -> (usize, f64) {
    let j = samples
        .partition_point(|s| s.t <= t)
        .saturating_sub(1)
        .min(samples.len().saturating_sub(2));
    let (a, b) = (samples[j].t, samples[j + 1].t);
    let u = if b > a {
        ((t - a) / (b - a)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (j, u)
}

/// The cycles' truth at the plan's sample times (linear interpolation).
fn resample(plan: &Plan, samples: &[Sample]) -> Trial {
    let n = plan.samples.len();
    let t0 = plan.samples[0].t;
    let mut trial = Trial::with_capacity(3, n);
    for s in &plan.samples {
        let (j, u) = bracket(samples, s.t - t0);
        let (a, b) = (&samples[j], &samples[j + 1]);
        let mut w = [0.0; MAX_WHEELS];
        for i in 0..3 {
            w[i] = lerp(a.wheels[i], b.wheels[i], u);
        }
        trial.t.push(s.t);
        trial.pose.push(Pose2::new(
            lerp(a.pose.x, b.pose.x, u),
            lerp(a.pose.y, b.pose.y, u),
            lerp(a.pose.heading, b.pose.heading, u),
        ));
        trial.tracked.push([
            lerp(a.tracked[0], b.tracked[0], u),
            lerp(a.tracked[1], b.tracked[1], u),
        ]);
        trial.slip_residual.push(0.0);
        trial.wheel_angles.push(w);
        trial.encoder_angles.push(w);
        trial.steer_angles.push([0.0; MAX_WHEELS]);
    }
    trial
}

/// `e(cycle)` (an error of the estimate) at the plan's sample times.
fn interpolate_error(plan: &Plan, samples: &[Sample], e: impl Fn(&Sample) -> f64) -> Vec<f64> {
    let t0 = plan.samples[0].t;
    plan.samples
        .iter()
        .map(|s| {
            let (j, u) = bracket(samples, s.t - t0);
            let (a, b) = (&samples[j], &samples[j + 1]);
            lerp(e(a), e(b), u)
        })
        .collect()
}

/// Translation noise of the runtime's wheel odometry in its fusion filter, m/√m
/// ([`omnikin::estimate::noise::ProcessNoise::translation`]). The runtime integrates the level
/// kinematic model, which misses the leaning sphere's motion by up to ε ≈ 1.4 of the distance
/// (open loop, paper 000's 0.5 m/s circle grows ×2.4 on the preset); over one 25 Hz camera
/// interval at 0.5 m/s (2 cm) that is an error of ε·√(v/f) ≈ 1.4·√0.02 ≈ 0.2 m/√m in the
/// filter's random-walk model. With the 0.02 m/√m of a level robot the χ² gate rejects about
/// half of the camera's fixes as inconsistent with the odometry (measured, docs/closed-loop.md).
pub const ODOMETRY_TRANSLATION_NOISE: f64 = 0.2;

/// The runtime configuration the closed loop runs with by default for a robot whose motor and
/// body limits are given: [`Config::new`] at `rate_hz` (its gains) with the wheel-rate and
/// -acceleration limits and the body acceleration (from the robot file), the heading from the
/// gyro (the wheels do not see the platform's yaw when the shell spins on the floor or the
/// platform tilts; the IMU on the platform does) and [`ODOMETRY_TRANSLATION_NOISE`].
pub fn config(
    rate_hz: f64,
    max_wheel_rate: Option<f64>,
    max_wheel_accel: Option<f64>,
    max_accel: f64,
    max_yaw_accel: f64,
) -> Config<f64> {
    let mut c = Config::new(rate_hz);
    c.rate_limits.wheel = max_wheel_rate;
    c.wheel_accel = max_wheel_accel;
    c.slew.accel = max_accel;
    c.slew.yaw_accel = max_yaw_accel;
    c.heading_from_gyro = true;
    c.fusion.noise.translation = ODOMETRY_TRANSLATION_NOISE;
    c
}

/// Damping ratio the tilt feedback is designed for ([`tilt_feedback`]): `1/√2`, the
/// second-order design that is fastest without overshoot of the magnitude response (a choice
/// made before any closed-loop run was compared, not fitted).
pub const TILT_DAMPING_RATIO: f64 = core::f64::consts::FRAC_1_SQRT_2;

/// Time constant of the tilt estimate's pull toward the accelerometer
/// ([`omnikin::runtime::TiltFeedback::accel_time_constant`]), s: 1 s, below the rocking's
/// 7.5 rad/s by a factor of about 7, where the linearised loop with the estimator
/// ([`tilt_poles`]) keeps a damping ratio above 0.6 (preset: 0.64; 0.39 with the accelerometer
/// alone) and a gyro bias `b` leans the estimate by only `b τ`. Chosen from [`tilt_poles`]
/// before any closed-loop run was compared, not fitted.
pub const TILT_ACCEL_TIME_CONSTANT: f64 = 1.0;

/// The tilt feedback of [`omnikin::runtime::TiltFeedback`] designed from the dynamics `p`
/// (the linearised rocking about the level platform, the derivation on that type):
///
/// * `J = I_s + m_s R² + I_p + m_p (R − h)²` (the rocking inertia about the floor contact,
///   kg·m²; `I_p` the mean of the platform's two horizontal principal moments),
///   `k = m_p g h` (N·m/rad), `B = M R² + I_s − m_p h R` (kg·m²);
/// * gain `c = 2 ζ √(k J) / B`, 1/s, with `ζ` = [`TILT_DAMPING_RATIO`];
/// * lean per acceleration `L = (M R − m_p h + I_s/R) / (m_p g h)`, rad per m/s² (the
///   quasi-static lean, linearised).
///
/// Preset `sphere-omni` (`h` 0.0872 m): `c` ≈ 8.7 /s against the undamped rocking at
/// ≈ 7.5 rad/s.
pub fn tilt_feedback(
    p: &crate::dynamics::sphere::SphereDynamics,
) -> omnikin::runtime::TiltFeedback<f64> {
    let r = p.geometry.shell_radius;
    let (mp, h, ms, is) = (p.platform_mass, p.com_depth, p.shell_mass, p.shell_inertia);
    let m = mp + ms;
    let ip = 0.5 * (p.platform_inertia[0][0] + p.platform_inertia[1][1]);
    let j = is + ms * r * r + ip + mp * (r - h) * (r - h);
    let k = mp * p.gravity * h;
    let b = m * r * r + is - mp * h * r;
    omnikin::runtime::TiltFeedback {
        gain: 2.0 * TILT_DAMPING_RATIO * (k * j).sqrt() / b,
        shell_radius: r,
        lean_per_accel: (m * r - mp * h + is / r) / k,
        accel_time_constant: TILT_ACCEL_TIME_CONSTANT,
    }
}

/// The tilt loop with its estimator, linearised per horizontal axis ([`tilt_poles`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltPoles {
    /// The characteristic polynomial `a₃ s³ + a₂ s² + a₁ s + a₀`, highest power first.
    pub coefficients: [f64; 4],
    /// Its roots, rad/s (`re`, `im`), sorted by real part, the slowest last.
    pub poles: [(f64, f64); 3],
    /// The smallest damping ratio `−re/|s|` among the poles (negative: unstable).
    pub damping_ratio: f64,
}

/// The closed tilt loop's poles with the runtime's tilt estimate in it
/// ([`omnikin::runtime::TiltFeedback`]): the feedback `tf` on the dynamics `p`, the IMU
/// `imu_depth` (m) below the shell centre on the platform's axis, regulation about the level
/// platform at rest (no commanded acceleration), the gyro exact.
///
/// Per axis (the notation of [`tilt_feedback`], `γ_x = −θ`): the wheels get
/// `u = −c γ̂_x = c θ − c e` with the estimate's error `e = γ̂_x − γ_x`; the plant
/// `J θ̈ + K θ = −B u̇` (`K = m_p g h`); the accelerometer's direction is
/// `γ_x + a_p/g` with the IMU point's acceleration `a_p = ẍ − d θ̈ = R u̇ + (R − d) θ̈`; the
/// filter makes `τ ė + e = a_p/g`. Eliminating `u`, `e`:
///
/// ```text
/// (J s² + B c s + K)(τ' s + 1) = (B c / g) s² (R c + (R − d) s),   τ' = τ + R c / g
/// a₃ = J τ + c (J R − B (R − d))/g,  a₂ = J + B c τ,  a₁ = B c + K τ + K R c/g,  a₀ = K
/// ```
///
/// `τ → ∞` (gyro alone) leaves the designed pair and an integrator (the drift a gyro alone
/// cannot see); `τ = 0` (the accelerometer alone) has `a₃ = c (J R − B (R − d))/g`, which is
/// negative with the IMU at the shell centre on the preset (`J < B`): unstable.
pub fn tilt_poles(
    p: &crate::dynamics::sphere::SphereDynamics,
    tf: &omnikin::runtime::TiltFeedback<f64>,
    imu_depth: f64,
) -> TiltPoles {
    let r = p.geometry.shell_radius;
    let (mp, h, ms, is) = (p.platform_mass, p.com_depth, p.shell_mass, p.shell_inertia);
    let ip = 0.5 * (p.platform_inertia[0][0] + p.platform_inertia[1][1]);
    let j = is + ms * r * r + ip + mp * (r - h) * (r - h);
    let k = mp * p.gravity * h;
    let b = (mp + ms) * r * r + is - mp * h * r;
    let (c, g, tau, d) = (tf.gain, p.gravity, tf.accel_time_constant, imu_depth);
    let a = [
        j * tau + c * (j * r - b * (r - d)) / g,
        j + b * c * tau,
        b * c + k * tau + k * r * c / g,
        k,
    ];
    // The roots as the companion matrix's eigenvalues.
    let comp = omnikin::nalgebra::Matrix3::new(
        -a[1] / a[0],
        -a[2] / a[0],
        -a[3] / a[0],
        1.0,
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
    );
    let ev = comp.complex_eigenvalues();
    let mut poles = [
        (ev[0].re, ev[0].im),
        (ev[1].re, ev[1].im),
        (ev[2].re, ev[2].im),
    ];
    poles.sort_by(|x, y| x.0.total_cmp(&y.0));
    let damping_ratio = poles
        .iter()
        .map(|&(re, im)| -re / re.hypot(im))
        .fold(f64::INFINITY, f64::min);
    TiltPoles {
        coefficients: a,
        poles,
        damping_ratio,
    }
}

/// The tilt loop's linearised figures ([`tilt_margins`]), per horizontal axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltMargins {
    /// The undamped rocking (rate-held wheels, no feedback), rad/s: `√(m_p g h / J)`.
    pub open_frequency: f64,
    /// The closed loop's damping ratio, `B c / (2 √(m_p g h J))`.
    pub damping_ratio: f64,
    /// The loop gain's upper crossover `|L(jω)| = 1`, rad/s (`L(s) = c B s / (J s² + m_p g h)`).
    pub crossover: f64,
    /// Phase margin at that crossover, degrees (90: `L` is ±90° away from its resonance).
    pub phase_margin_deg: f64,
    /// Delay margin, s: the pure delay that uses up the phase margin at the crossover. Compare
    /// with the control loop's own delay (about 1.5 periods: one cycle's computation and the
    /// zero-order hold's half period).
    pub delay_margin: f64,
}

/// The tilt loop's figures for the feedback `tf` on the dynamics `p` (which need not be the
/// ones it was designed from): the linearised per-axis model of
/// [`omnikin::runtime::TiltFeedback`], `J θ̈ + B c θ̇ + m_p g h θ = 0`, its loop gain
/// `L(s) = c B s / (J s² + m_p g h)` and the margins at its upper crossover
/// `ω_c = (c B + √(c² B² + 4 J m_p g h)) / (2 J)`.
pub fn tilt_margins(
    p: &crate::dynamics::sphere::SphereDynamics,
    tf: &omnikin::runtime::TiltFeedback<f64>,
) -> TiltMargins {
    let r = p.geometry.shell_radius;
    let (mp, h, ms, is) = (p.platform_mass, p.com_depth, p.shell_mass, p.shell_inertia);
    let ip = 0.5 * (p.platform_inertia[0][0] + p.platform_inertia[1][1]);
    let j = is + ms * r * r + ip + mp * (r - h) * (r - h);
    let k = mp * p.gravity * h;
    let b = (mp + ms) * r * r + is - mp * h * r;
    let cb = tf.gain * b;
    let wn = (k / j).sqrt();
    let wc = (cb + (cb * cb + 4.0 * j * k).sqrt()) / (2.0 * j);
    TiltMargins {
        open_frequency: wn,
        damping_ratio: cb / (2.0 * (k * j).sqrt()),
        crossover: wc,
        phase_margin_deg: 90.0,
        delay_margin: core::f64::consts::FRAC_PI_2 / wc,
    }
}

/// Checks a camera profile and its gaps before a long run.
///
/// # Errors
/// The camera's message naming the key.
pub fn check_camera(camera: &Option<(CameraProfile, CameraGaps)>) -> Result<(), String> {
    if let Some((p, g)) = camera {
        Camera::new(*p, *g, crate::trial_rng(0, 0)).map(|_| ())
    } else {
        Ok(())
    }
}
