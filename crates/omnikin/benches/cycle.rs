//! One odometry step and one full control-loop cycle per robot, in `f32` and `f64`.
//!
//! * `odometry/<robot>/<type>`: [`Odometry::update`] with an encoder sample (wheel angles
//!   advancing, caster steer angles varying) and an absolute yaw (as WPILib's
//!   `SwerveDriveOdometry::Update` takes a gyro angle).
//! * `control_cycle/<robot>/<type>`: [`Runtime::handle`] of a new velocity command followed by
//!   [`Runtime::cycle`] at 1 kHz — encoders → odometry → watchdog → desaturation within 12
//!   rad/s (steer 20 rad/s) → slew (1 m/s², 4 rad/s²) → inverse kinematics → wheel
//!   acceleration limit (400 rad/s²) → motors — on a simulated board whose motors turn exactly
//!   as commanded.
//!
//! `cargo bench -p omnikin --bench cycle` (or `-- --test` for one quick run of each).

use std::hint::black_box;

use criterion::{
    BenchmarkGroup, Criterion, criterion_group, criterion_main, measurement::WallTime,
};
use omnikin::ballbot::{Ballbot, BallbotParams};
use omnikin::caster::{Caster3, CasterParams};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::runtime::hal::{EncoderAngles, Encoders, MotorCommand, MotorOutputs, NoImu};
use omnikin::runtime::limits::RateLimits;
use omnikin::runtime::{Command, Config, Frame, Runtime};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Real, Robot, Twist2};

const K: usize = 64;

fn robot<T: Real>(name: &str) -> Robot<T> {
    match name {
        "sphere" => Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap()),
        "ballbot" => Robot::Ballbot(Ballbot::new(BallbotParams::preset()).unwrap()),
        _ => Robot::Caster(Caster3::new(CasterParams::preset()).unwrap()),
    }
}

/// Per-step encoder increments (rad), steer angles (rad), yaw-rate and twist commands: the
/// table of the peer harnesses (bench/peers).
struct Table<T> {
    wheel_step: [[T; 3]; K],
    steer: [[T; 3]; K],
    yaw_rate: [T; K],
    twist: [Twist2<T>; K],
}

fn table<T: Real>() -> Table<T> {
    let f = |k: usize| k as f64;
    Table {
        // 1e-3 m per step on a 0.05 m wheel.
        wheel_step: core::array::from_fn(|k| {
            core::array::from_fn(|j| T::of(0.02 * (0.5 + 0.3 * (0.11 * f(k) + j as f64).sin())))
        }),
        steer: core::array::from_fn(|k| {
            core::array::from_fn(|j| T::of(0.8 * (0.13 * f(k) + j as f64).sin()))
        }),
        yaw_rate: core::array::from_fn(|k| T::of(1.2 * (0.23 * f(k) + 1.0).sin())),
        twist: core::array::from_fn(|k| {
            Twist2::new(
                T::of(0.5 * (0.1 * f(k) + 0.3).sin()),
                T::of(0.4 * (0.17 * f(k)).cos()),
                T::of(1.2 * (0.23 * f(k) + 1.0).sin()),
            )
        }),
    }
}

fn odometry<T: Real>(g: &mut BenchmarkGroup<'_, WallTime>, ty: &str) {
    let tab = table::<T>();
    let dt = T::of(1e-3);
    for name in ["sphere", "ballbot", "caster"] {
        let rob = robot::<T>(name);
        let origin = Pose2::new(T::zero(), T::zero(), T::zero());
        let mut odo = Odometry::new(rob, origin);
        let (mut t, mut yaw, mut wheel) = (T::zero(), T::zero(), [T::zero(); 3]);
        let (mut k, mut failed) = (0usize, 0u64);
        g.bench_function(format!("odometry/{name}/{ty}"), |b| {
            b.iter(|| {
                k = (k + 1) & (K - 1);
                if t > T::of(100.0) {
                    // Start over every 100 s of robot time, so that f32 time stamps and angles
                    // stay resolved at 1 kHz (the runtime re-bases its odometry the same way).
                    (t, yaw, wheel) = (T::zero(), T::zero(), [T::zero(); 3]);
                    odo = Odometry::new(rob, origin);
                }
                t += dt;
                yaw += tab.yaw_rate[k] * dt;
                for j in 0..3 {
                    wheel[j] += tab.wheel_step[k][j];
                }
                let reading = EncoderReading::with_steer(t, wheel, tab.steer[k]);
                let r = odo.update(black_box(&reading), HeadingInput::Absolute(black_box(yaw)));
                failed += r.is_err() as u64;
                black_box(r)
            })
        });
        assert_eq!(failed, 0, "odometry/{name}/{ty}: steps failed");
    }
}

/// The encoders of a board whose motors turn exactly as commanded over one period.
struct Enc<T>(EncoderAngles<T>);

impl<T: Real> Encoders<T> for Enc<T> {
    type Error = ();
    fn read(&mut self) -> Result<EncoderAngles<T>, ()> {
        Ok(black_box(self.0))
    }
}

/// The motor drivers: keep the last set-points.
struct Motors<T>(MotorCommand<T>);

impl<T: Real> MotorOutputs<T> for Motors<T> {
    type Error = ();
    fn set_rates(&mut self, c: &MotorCommand<T>) -> Result<(), ()> {
        self.0 = *black_box(c);
        Ok(())
    }
}

fn control_cycle<T: Real>(g: &mut BenchmarkGroup<'_, WallTime>, ty: &str) {
    let tab = table::<T>();
    for name in ["sphere", "ballbot", "caster"] {
        let mut cfg = Config::new(T::of(1000.0));
        cfg.rate_limits = RateLimits {
            wheel: Some(T::of(12.0)),
            steer: Some(T::of(20.0)),
        };
        cfg.wheel_accel = Some(T::of(400.0));
        cfg.steer_accel = Some(T::of(400.0));
        let mut rt = Runtime::<T, 16>::new(
            robot::<T>(name),
            cfg,
            Pose2::new(T::zero(), T::zero(), T::zero()),
        )
        .unwrap();
        let mut enc = Enc(EncoderAngles::zero());
        let mut motors = Motors(MotorCommand::zero());
        let dt = T::of(1e-3);
        let (mut now_us, mut k) = (0u64, 0usize);
        g.bench_function(format!("control_cycle/{name}/{ty}"), |b| {
            b.iter(|| {
                k = (k + 1) & (K - 1);
                now_us += 1000;
                let cmd = Command::Velocity {
                    twist: black_box(tab.twist[k]),
                    frame: Frame::Robot,
                };
                let _ = black_box(rt.handle(cmd, now_us));
                let st = black_box(rt.cycle(now_us, &mut enc, &mut NoImu, &mut motors));
                // The motors turn as commanded until the next cycle.
                for i in 0..3 {
                    enc.0.wheel[i] += motors.0.wheel[i] * dt;
                    enc.0.steer[i] += motors.0.steer[i] * dt;
                }
                st
            })
        });
    }
}

fn benches_all(c: &mut Criterion) {
    let mut g = c.benchmark_group("cycle");
    odometry::<f32>(&mut g, "f32");
    odometry::<f64>(&mut g, "f64");
    control_cycle::<f32>(&mut g, "f32");
    control_cycle::<f64>(&mut g, "f64");
    g.finish();
}

criterion_group!(benches, benches_all);
criterion_main!(benches);
