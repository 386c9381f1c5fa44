//! Planning a 20-waypoint quintic-spline path for `sphere-omni` within its motor limits
//! (12 rad/s, 400 rad/s²), sampled at 1 kHz: with a trapezoidal profile (re-timed where a
//! wheel limit binds) and with the time-optimal forward–backward pass.
//!
//! `cargo bench -p omnikin-plan` (or `-- --test` for one quick run of each).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use omnikin::description::RobotDescription;
use omnikin_plan::RobotModel;
use omnikin_plan::heading::HeadingLaw;
use omnikin_plan::path::Path;
use omnikin_plan::planner::{InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing, plan};
use omnikin_plan::profile::ProfileKind;

/// 20 waypoints meandering along +x (about 11 m of path).
fn waypoints() -> Vec<[f64; 2]> {
    (0..20)
        .map(|k| {
            let k = k as f64;
            [0.5 * k, 0.4 * (0.9 * k).sin() + 0.1 * (2.3 * k).cos()]
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let robot =
        RobotModel::from_description(&RobotDescription::preset("sphere-omni").unwrap()).unwrap();
    let path = Path::spline(&waypoints()).unwrap();
    let heading = HeadingLaw::Tangent { offset: 0.0 };
    let limits = MotionLimits {
        max_speed: 0.6,
        max_accel: 1.0,
        ..MotionLimits::default()
    };
    let mut group = c.benchmark_group("spline 20 waypoints, 1 kHz");
    group.sample_size(10);
    for (name, timing) in [
        (
            "trapezoid",
            Timing::Profile {
                kind: ProfileKind::Trapezoid,
                limits,
            },
        ),
        ("time-optimal", Timing::TimeOptimal { limits }),
    ] {
        let opts = PlanOptions {
            timing,
            on_limit: OnLimit::Retime,
            rate: 1000.0,
            initial_steer: InitialSteer::Aligned,
        };
        group.bench_function(name, |b| {
            b.iter(|| plan(black_box(&path), &heading, &robot, &opts).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
