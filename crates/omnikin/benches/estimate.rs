//! Cost of one estimation step next to one odometry step, `f64` and `f32`:
//!
//! * `estimate/odometry/<type>`: [`Odometry::update`] of the sphere with an absolute yaw (as in
//!   `cycle`).
//! * `estimate/fusion_predict/<type>`: [`PoseFusion::predict`], one 1 kHz odometry step into a
//!   256-entry history (5 states: pose, gyro bias, wheel scale).
//! * `estimate/fusion_step/<type>`: one filter step as a 10 Hz camera sees it: 100 predictions
//!   and one fix taken 0.3 s earlier (gated, fused at its time, the later entries replayed),
//!   reported per prediction + update cycle of 100 steps.
//!
//! * `estimate/events_step/<type>`: [`EventDetector::step`], the slip and collision detector
//!   the runtime runs after each odometry step (gyro given; a full 128-sample window).
//!
//! `cargo bench -p omnikin --bench estimate` (or `-- --test` for one quick run of each).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use omnikin::estimate::events::{EventDetector, EventThresholds};
use omnikin::estimate::fix::Fix;
use omnikin::estimate::fusion::{FusionConfig, PoseFusion, StepHeading};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::nalgebra::Matrix3;
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Real, Robot, Twist2, se2};

fn odometry<T: Real>(c: &mut Criterion, name: &str) {
    let fresh = || {
        Odometry::new(
            Robot::Sphere(SphereOmni::<T>::new(SphereParams::preset()).unwrap()),
            Pose2::new(T::zero(), T::zero(), T::zero()),
        )
    };
    let mut odo = fresh();
    let mut k = 0u32;
    c.bench_function(&format!("estimate/odometry/{name}"), |b| {
        b.iter(|| {
            // Restart every 2^16 steps (65 s): past ~2^24 ms an f32 clock no longer
            // advances by 1 ms, and every update would be refused as not later.
            k += 1;
            if k == 1 << 16 {
                k = 1;
                odo = fresh();
            }
            let t = T::of(k as f64 * 1e-3);
            let a = T::of(k as f64 * 1e-3);
            let r = EncoderReading::new(t, [a, a * T::of(0.5), -a]);
            black_box(odo.update(black_box(&r), HeadingInput::Absolute(t * T::of(0.1))))
        })
    });
}

/// Steps after which the benchmarks restart their clock at 0 (65 s at 1 kHz): past ~2^24 ms
/// an `f32` clock no longer advances by 1 ms, and every step would be refused as not later.
const REBASE: u64 = 1 << 16;

fn fusion<T: Real>(c: &mut Criterion, name: &str) {
    let delta = se2::twist_exp(Twist2::new(T::of(0.3), T::zero(), T::of(0.2)), T::of(1e-3));
    let new = || {
        PoseFusion::<T, 256>::new(
            T::zero(),
            Pose2::new(T::zero(), T::zero(), T::zero()),
            Matrix3::identity() * T::of(1e-4),
            FusionConfig::default(),
        )
        .unwrap()
    };
    let mut f = Box::new(new());
    let mut k = 0u64;
    c.bench_function(&format!("estimate/fusion_predict/{name}"), |b| {
        b.iter(|| {
            k += 1;
            if k == REBASE {
                // As the runtime re-bases: an f32 clock must stay where 1 ms is resolved.
                f.shift_time(T::of(k as f64 * 1e-3));
                k = 0;
            }
            black_box(f.predict(T::of(k as f64 * 1e-3), delta, StepHeading::Gyro))
        })
    });
    let mut f = Box::new(new());
    let mut k = 0u64;
    c.bench_function(&format!("estimate/fusion_step/{name}"), |b| {
        b.iter(|| {
            if k >= REBASE {
                f.shift_time(T::of(k as f64 * 1e-3));
                k = 0;
            }
            for _ in 0..100 {
                k += 1;
                let _ = f.predict(T::of(k as f64 * 1e-3), delta, StepHeading::Gyro);
            }
            let p = f.pose();
            let t = T::of(k as f64 * 1e-3 - 0.3);
            black_box(f.add_fix(&Fix::position(t, p.x, p.y, T::of(0.01))))
        })
    });
}

fn events<T: Real>(c: &mut Criterion, name: &str) {
    let mut odo = Odometry::new(
        Robot::Sphere(SphereOmni::<T>::new(SphereParams::preset()).unwrap()),
        Pose2::new(T::zero(), T::zero(), T::zero()),
    );
    let r = |k: u32| {
        let a = T::of(k as f64 * 1e-3);
        EncoderReading::new(a, [a, a * T::of(0.5), -a])
    };
    odo.update(&r(0), HeadingInput::Wheels).unwrap();
    let mut step = odo.update(&r(1), HeadingInput::Wheels).unwrap();
    let mut det = EventDetector::new(EventThresholds::standard(), false);
    let mut k = 0u32;
    c.bench_function(&format!("estimate/events_step/{name}"), |b| {
        b.iter(|| {
            k = k.wrapping_add(1);
            step.t = T::of(k as f64 * 1e-3);
            black_box(det.step(black_box(&step), Some(T::of(0.1))))
        })
    });
}

fn benches(c: &mut Criterion) {
    odometry::<f64>(c, "f64");
    odometry::<f32>(c, "f32");
    fusion::<f64>(c, "f64");
    fusion::<f32>(c, "f32");
    events::<f64>(c, "f64");
    events::<f32>(c, "f32");
}

criterion_group!(estimate, benches);
criterion_main!(estimate);
