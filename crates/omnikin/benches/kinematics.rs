//! Inverse and forward kinematics of the three paper robots through their own models, and of
//! every preset (kiwi, X-drive, mecanum, swerve4 too) through the uniform `omnikin::Robot`, in
//! `f32` and `f64`, one call per iteration. Inputs cycle through a 64-entry table and pass through
//! `black_box`, so neither the inputs nor the results can be folded away.
//!
//! `cargo bench -p omnikin --bench kinematics` (or `-- --test` for one quick run of each).

use std::hint::black_box;

use criterion::{
    BenchmarkGroup, Criterion, criterion_group, criterion_main, measurement::WallTime,
};
use omnikin::Real;
use omnikin::Twist2;
use omnikin::ballbot::{Ballbot, BallbotParams};
use omnikin::caster::{Caster3, CasterParams, CasterRates};
use omnikin::description::{PRESETS, RobotDescription};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Actuators, Robot};

const K: usize = 64;

/// One input set: a twist, a heading and three steer angles (the caster's).
#[derive(Clone, Copy)]
struct Input<T> {
    twist: Twist2<T>,
    heading: T,
    steer: [T; 3],
}

/// The same table as the peer harnesses (bench/peers): smooth, non-trivial values.
fn inputs<T: Real>() -> Vec<Input<T>> {
    (0..K)
        .map(|k| {
            let k = k as f64;
            Input {
                twist: Twist2::new(
                    T::of(0.5 * (0.1 * k + 0.3).sin()),
                    T::of(0.4 * (0.17 * k).cos()),
                    T::of(1.2 * (0.23 * k + 1.0).sin()),
                ),
                heading: T::of(0.05 * k),
                steer: core::array::from_fn(|j| T::of(0.8 * (0.13 * k + j as f64).sin())),
            }
        })
        .collect()
}

fn robots<T: Real>(g: &mut BenchmarkGroup<'_, WallTime>, ty: &str) {
    let inp = inputs::<T>();
    let sphere = SphereOmni::<T>::new(SphereParams::preset()).unwrap();
    let ballbot = Ballbot::<T>::new(BallbotParams::preset()).unwrap();
    let caster = Caster3::<T>::new(CasterParams::preset()).unwrap();
    // Forward inputs: the rates the inverse gives for the same table.
    let sphere_rates: Vec<[T; 3]> = inp
        .iter()
        .map(|x| sphere.wheel_rates(x.twist, T::zero()).unwrap())
        .collect();
    let ballbot_rates: Vec<[T; 3]> = inp
        .iter()
        .map(|x| ballbot.wheel_rates(x.twist, T::zero()).unwrap())
        .collect();
    let caster_rates: Vec<CasterRates<T>> = inp
        .iter()
        .map(|x| caster.motor_rates(x.twist, x.heading, x.steer).unwrap())
        .collect();

    let mut i = 0usize;
    g.bench_function(format!("sphere/inverse/{ty}"), |b| {
        b.iter(|| {
            i = (i + 1) & (K - 1);
            let x = black_box(&inp[i]);
            black_box(sphere.wheel_rates(x.twist, T::zero()))
        })
    });
    g.bench_function(format!("sphere/forward/{ty}"), |b| {
        b.iter(|| {
            i = (i + 1) & (K - 1);
            black_box(sphere.body_twist(*black_box(&sphere_rates[i]), T::zero()))
        })
    });
    g.bench_function(format!("ballbot/inverse/{ty}"), |b| {
        b.iter(|| {
            i = (i + 1) & (K - 1);
            let x = black_box(&inp[i]);
            black_box(ballbot.wheel_rates(x.twist, T::zero()))
        })
    });
    g.bench_function(format!("ballbot/forward/{ty}"), |b| {
        b.iter(|| {
            i = (i + 1) & (K - 1);
            black_box(ballbot.body_twist(*black_box(&ballbot_rates[i]), T::zero()))
        })
    });
    g.bench_function(format!("caster/inverse/{ty}"), |b| {
        b.iter(|| {
            i = (i + 1) & (K - 1);
            let x = black_box(&inp[i]);
            black_box(caster.motor_rates(x.twist, x.heading, x.steer))
        })
    });
    g.bench_function(format!("caster/forward/{ty}"), |b| {
        b.iter(|| {
            i = (i + 1) & (K - 1);
            let x = black_box(&inp[i]);
            black_box(caster.body_twist(black_box(&caster_rates[i]), x.heading, x.steer))
        })
    });
}

/// The uniform path: `Robot::inverse` and `Robot::forward` of every preset
/// (`omnikin::description::PRESETS`, built as a robot file builds them), on the same twist
/// table; the forward inputs are the inverse's outputs.
fn presets<T: Real>(g: &mut BenchmarkGroup<'_, WallTime>, ty: &str) {
    let inp = inputs::<T>();
    for (name, _) in PRESETS {
        let robot: Robot<T> = RobotDescription::preset(name)
            .expect("preset")
            .build()
            .expect("preset robot");
        let rest = Actuators::<T>::zero();
        let acts: Vec<Actuators<T>> = inp
            .iter()
            .map(|x| robot.inverse(x.twist, &rest).unwrap())
            .collect();
        let mut i = 0usize;
        g.bench_function(format!("robot/{name}/inverse/{ty}"), |b| {
            b.iter(|| {
                i = (i + 1) & (K - 1);
                let x = black_box(&inp[i]);
                black_box(robot.inverse(x.twist, black_box(&rest)))
            })
        });
        g.bench_function(format!("robot/{name}/forward/{ty}"), |b| {
            b.iter(|| {
                i = (i + 1) & (K - 1);
                black_box(robot.forward(black_box(&acts[i])))
            })
        });
    }
}

fn kinematics(c: &mut Criterion) {
    let mut g = c.benchmark_group("kinematics");
    robots::<f32>(&mut g, "f32");
    robots::<f64>(&mut g, "f64");
    presets::<f32>(&mut g, "f32");
    presets::<f64>(&mut g, "f64");
    g.finish();
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
