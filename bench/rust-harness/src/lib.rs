//! Shared pieces of omnikin's performance harnesses (see `bench/` and the README's
//! "Performance" section): the input tables (identical to the C++ side,
//! `bench/peers/wpimath_harness.cpp`), the robots, a simulated board, one control cycle per
//! robot, and a batch timer.

use std::hint::black_box;
use std::time::Instant;

use omnikin::ballbot::{Ballbot, BallbotParams};
use omnikin::caster::{Caster3, CasterParams};
use omnikin::runtime::hal::{
    EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs, NoImu,
};
use omnikin::runtime::limits::RateLimits;
use omnikin::runtime::{Command, Config, Faults, Frame, Runtime, Status, TiltFeedback};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Robot, Twist2};

/// Length of the input tables (a power of two: the loops index with `i & (K - 1)`).
pub const K: usize = 64;

/// The inputs of every harness, built before timing. Same formulas as the C++ harness.
pub struct Inputs {
    /// Robot-frame twists (m/s, m/s, rad/s).
    pub twist: [Twist2<f64>; K],
    /// Headings, rad.
    pub heading: [f64; K],
    /// Caster steer angles, rad.
    pub steer: [[f64; 3]; K],
    /// Per-step travel of each wheel, m (1 kHz, about 0.5 m/s).
    pub dist_step: [[f64; 3]; K],
}

impl Inputs {
    /// The table.
    pub fn new() -> Self {
        let f = |k: usize| k as f64;
        Self {
            twist: core::array::from_fn(|k| {
                Twist2::new(
                    0.5 * (0.1 * f(k) + 0.3).sin(),
                    0.4 * (0.17 * f(k)).cos(),
                    1.2 * (0.23 * f(k) + 1.0).sin(),
                )
            }),
            heading: core::array::from_fn(|k| 0.05 * f(k)),
            steer: core::array::from_fn(|k| {
                core::array::from_fn(|j| 0.8 * (0.13 * f(k) + j as f64).sin())
            }),
            dist_step: core::array::from_fn(|k| {
                core::array::from_fn(|j| 1e-3 * (0.5 + 0.3 * (0.11 * f(k) + j as f64).sin()))
            }),
        }
    }
}

impl Default for Inputs {
    fn default() -> Self {
        Self::new()
    }
}

/// The preset robots by name: `sphere`, `ballbot`, `caster`.
pub fn robot(name: &str) -> Option<Robot<f64>> {
    Some(match name {
        "sphere" => Robot::Sphere(SphereOmni::new(SphereParams::preset()).ok()?),
        "ballbot" => Robot::Ballbot(Ballbot::new(BallbotParams::preset()).ok()?),
        "caster" => Robot::Caster(Caster3::new(CasterParams::preset()).ok()?),
        _ => return None,
    })
}

/// Encoders of a simulated board whose motors turn exactly as commanded.
pub struct Enc(pub EncoderAngles<f64>);

impl Encoders<f64> for Enc {
    type Error = ();
    fn read(&mut self) -> Result<EncoderAngles<f64>, ()> {
        Ok(black_box(self.0))
    }
}

/// An IMU reading a fixed sample (read through `black_box`).
pub struct TableImu(pub ImuSample<f64>);

impl Imu<f64> for TableImu {
    type Error = ();
    fn read(&mut self) -> Result<Option<ImuSample<f64>>, ()> {
        Ok(Some(black_box(self.0)))
    }
}

/// Motor drivers of the simulated board: keep the last set-points.
pub struct Motors(pub MotorCommand<f64>);

impl MotorOutputs<f64> for Motors {
    type Error = ();
    fn set_rates(&mut self, c: &MotorCommand<f64>) -> Result<(), ()> {
        self.0 = *black_box(c);
        Ok(())
    }
}

/// A robot's control loop at 1 kHz on the simulated board, as `benches/cycle.rs` runs it:
/// motor limits 12 rad/s (steer 20 rad/s), 400 rad/s², body slew 1 m/s² and 4 rad/s².
pub struct Loop {
    rt: Runtime<f64, 16>,
    enc: Enc,
    motors: Motors,
    now_us: u64,
    k: usize,
}

impl Loop {
    /// The loop of `robot`, at rest at the origin.
    pub fn new(robot: Robot<f64>) -> Self {
        let mut cfg = Config::new(1000.0);
        cfg.rate_limits = RateLimits {
            wheel: Some(12.0),
            steer: Some(20.0),
        };
        cfg.wheel_accel = Some(400.0);
        cfg.steer_accel = Some(400.0);
        let rt = Runtime::new(robot, cfg, Pose2::new(0.0, 0.0, 0.0)).expect("valid config");
        Self {
            rt,
            enc: Enc(EncoderAngles::zero()),
            motors: Motors(MotorCommand::zero()),
            now_us: 0,
            k: 0,
        }
    }

    /// One cycle: the simulated motors turn for the period since the previous cycle, a new
    /// velocity command from the table arrives (`handle`), then `cycle` (encoders → odometry
    /// → watchdog → desaturation → slew → inverse kinematics → acceleration limit → motors).
    /// Returns the cycle's faults; the full status is [`Loop::status`] (telemetry, built at
    /// the link's rate, not every cycle).
    ///
    /// The simulated motors turn for the period **before** the cycle: the same sequence of
    /// encoder readings as turning them after it.
    #[inline(never)]
    pub fn step(&mut self, inputs: &Inputs) -> Faults {
        self.prepare(inputs);
        self.rt
            .cycle(self.now_us, &mut self.enc, &mut NoImu, &mut self.motors)
    }

    /// The sphere's loop with the tilt feedback (`Config::tilt`, paper 000's preset: gain
    /// 8.61 /s, `R` 0.15 m, lean 0.146 rad per m/s², the tilt estimate's 1 s) and the heading from the gyro's vertical
    /// component: what [`Loop::step_tilted`] measures.
    pub fn tilted(robot: Robot<f64>) -> Self {
        let mut lp = Self::new(robot);
        let mut cfg = *lp.rt.config();
        cfg.tilt = Some(TiltFeedback {
            gain: 8.61,
            shell_radius: 0.15,
            lean_per_accel: 0.146,
            accel_time_constant: 1.0,
        });
        cfg.heading_from_gyro = true;
        lp.rt = Runtime::new(*lp.rt.robot(), cfg, Pose2::new(0.0, 0.0, 0.0)).expect("valid config");
        lp
    }

    /// [`Loop::step`] with an IMU on a rocking platform (gyro and accelerometer from the
    /// table), for a loop built by [`Loop::tilted`].
    #[inline(never)]
    pub fn step_tilted(&mut self, inputs: &Inputs) -> Faults {
        self.prepare(inputs);
        let t = inputs.twist[self.k];
        let mut imu = TableImu(ImuSample {
            gyro: [0.3 * t.vy, -0.3 * t.vx, t.yaw_rate],
            accel: [0.5 * t.vx, 0.5 * t.vy, 9.81],
        });
        self.rt
            .cycle(self.now_us, &mut self.enc, &mut imu, &mut self.motors)
    }

    /// The runtime's status after the latest cycle (a telemetry frame's content).
    #[inline(never)]
    pub fn status(&self) -> Status<f64> {
        self.rt.status()
    }

    /// The motors turn for one period at the previous cycle's set-points, the clock advances
    /// and the next command from the table arrives.
    #[inline(always)]
    fn prepare(&mut self, inputs: &Inputs) {
        for i in 0..3 {
            self.enc.0.wheel[i] += self.motors.0.wheel[i] * 1e-3;
            self.enc.0.steer[i] += self.motors.0.steer[i] * 1e-3;
        }
        self.k = (self.k + 1) & (K - 1);
        self.now_us += 1000;
        let cmd = Command::Velocity {
            twist: black_box(inputs.twist[self.k]),
            frame: Frame::Robot,
        };
        let _ = black_box(self.rt.handle(cmd, self.now_us));
    }
}

/// Batch timer: calibrates a batch to about `batch_ms`, runs `batches` of them, and returns
/// the median ns per call (the fastest batch when the environment variable
/// `OMNIKIN_BENCH_MIN=1` is set: a lower bound that other load on the machine disturbs
/// less). `body(i)` makes one call with iteration index `i`.
pub fn measure(batch_ms: f64, batches: usize, mut body: impl FnMut(u64)) -> f64 {
    let mut n: u64 = 1;
    loop {
        let t0 = Instant::now();
        for i in 0..n {
            body(i);
        }
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        if ms > batch_ms / 4.0 || n > 1 << 40 {
            n = ((n as f64 * batch_ms / ms.max(1e-6)) as u64).max(1);
            break;
        }
        n *= 4;
    }
    let mut per = Vec::with_capacity(batches);
    let mut base = 0;
    for _ in 0..batches {
        let t0 = Instant::now();
        for i in base..base + n {
            body(i);
        }
        per.push(t0.elapsed().as_secs_f64() * 1e9 / n as f64);
        base += n;
    }
    per.sort_by(f64::total_cmp);
    if std::env::var("OMNIKIN_BENCH_MIN").is_ok_and(|v| v == "1") {
        per[0]
    } else {
        per[per.len() / 2]
    }
}

/// The 20 waypoints of `crates/omnikin-plan/benches/plan.rs` (about 10.8 m along +x).
pub fn waypoints20() -> Vec<[f64; 2]> {
    (0..20)
        .map(|k| {
            let k = k as f64;
            [0.5 * k, 0.4 * (0.9 * k).sin() + 0.1 * (2.3 * k).cos()]
        })
        .collect()
}

/// The peer comparison's planning problem: the 20-waypoint spline, tangent heading, the
/// `sphere-omni` preset's motor limits, 0.6 m/s and 1 m/s² (WPILib's `TrajectoryConfig` gets
/// the same two), time-optimal timing, sampled at `rate` Hz.
pub fn plan20(
    rate: f64,
) -> (
    omnikin_plan::path::Path,
    omnikin_plan::heading::HeadingLaw,
    omnikin_plan::RobotModel,
    omnikin_plan::planner::PlanOptions,
) {
    use omnikin_plan::planner::{InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing};
    let model = omnikin_plan::RobotModel::from_description(
        &omnikin::description::RobotDescription::preset("sphere-omni").expect("preset"),
    )
    .expect("preset model");
    let path = omnikin_plan::path::Path::spline(&waypoints20()).expect("spline");
    let limits = MotionLimits {
        max_speed: 0.6,
        max_accel: 1.0,
        ..MotionLimits::default()
    };
    let opts = PlanOptions {
        timing: Timing::TimeOptimal { limits },
        on_limit: OnLimit::Retime,
        rate,
        initial_steer: InitialSteer::Aligned,
    };
    (
        path,
        omnikin_plan::heading::HeadingLaw::Tangent { offset: 0.0 },
        model,
        opts,
    )
}
