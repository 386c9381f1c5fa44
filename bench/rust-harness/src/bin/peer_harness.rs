//! The Rust side of the WPILib peer comparison (`bench/peers/run.sh` runs it alternately with
//! `bench/peers/wpimath_harness.cpp`). Same inputs and loop shape as the C++ harness: a
//! 64-entry table built before timing, one call per iteration, inputs through `black_box`,
//! every result consumed by `black_box`. One process run = one round; each benchmark prints
//! `name<TAB>median ns per call<TAB>extra`.
//!
//! `omnikin-peer-harness [--batch-ms 20] [--batches 15]`

use std::hint::black_box;

use omnikin::caster::{Caster3, CasterParams};
use omnikin::description::RobotDescription;
use omnikin::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::{Pose2, Robot};
use omnikin_bench::{Inputs, K, measure, robot};
use omnikin_plan::RobotModel;
use omnikin_plan::heading::HeadingLaw;
use omnikin_plan::path::Path;
use omnikin_plan::planner::{InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing, plan};
use omnikin_plan::profile::ProfileKind;

fn main() {
    let mut batch_ms = 20.0;
    let mut batches = 15usize;
    let args: Vec<String> = std::env::args().collect();
    for w in args.windows(2) {
        match w[0].as_str() {
            "--batch-ms" => batch_ms = w[1].parse().expect("--batch-ms NUMBER"),
            "--batches" => batches = w[1].parse().expect("--batches NUMBER"),
            _ => {}
        }
    }
    let inp = Inputs::new();
    let caster = Caster3::<f64>::new(CasterParams::preset()).unwrap();

    // Caster inverse: world twist + heading + steer angles -> six motor rates.
    let ns = measure(batch_ms, batches, |i| {
        let k = i as usize & (K - 1);
        let r = caster.motor_rates(
            black_box(inp.twist[k]),
            black_box(inp.heading[k]),
            black_box(inp.steer[k]),
        );
        black_box(r.unwrap());
    });
    println!("caster_inverse\t{ns:.3}\t-");

    // Sphere and ballbot inverse: robot twist (+ spin 0) -> three wheel rates.
    for name in ["sphere", "ballbot"] {
        let rob = robot(name).unwrap();
        let ns = match rob {
            Robot::Sphere(s) => measure(batch_ms, batches, |i| {
                let k = i as usize & (K - 1);
                black_box(
                    s.wheel_rates(black_box(inp.twist[k]), black_box(0.0))
                        .unwrap(),
                );
            }),
            Robot::Ballbot(b) => measure(batch_ms, batches, |i| {
                let k = i as usize & (K - 1);
                black_box(
                    b.wheel_rates(black_box(inp.twist[k]), black_box(0.0))
                        .unwrap(),
                );
            }),
            Robot::Caster(_) => unreachable!(),
        };
        println!("{name}_inverse\t{ns:.3}\t-");
    }

    // Caster odometry step: encoder sample (wheel angles, steer angles) + absolute yaw, like
    // SwerveDriveOdometry::Update(gyroAngle, modulePositions).
    {
        let r = caster.params().wheel_radius;
        let angle_step: [[f64; 3]; K] =
            core::array::from_fn(|k| core::array::from_fn(|j| inp.dist_step[k][j] / r));
        let mut odo = Odometry::new(Robot::Caster(caster), Pose2::new(0.0, 0.0, 0.0));
        let (mut t, mut yaw, mut wheel) = (0.0f64, 0.0f64, [0.0f64; 3]);
        let mut failures = 0u64;
        let ns = measure(batch_ms, batches, |i| {
            let k = i as usize & (K - 1);
            for j in 0..3 {
                wheel[j] += angle_step[k][j];
            }
            t += 1e-3;
            yaw += 1e-3 * inp.twist[k].yaw_rate;
            let reading =
                EncoderReading::with_steer(black_box(t), black_box(wheel), black_box(inp.steer[k]));
            match odo.update(&reading, HeadingInput::Absolute(black_box(yaw))) {
                Ok(step) => {
                    black_box(step.pose);
                }
                Err(_) => failures += 1,
            }
        });
        assert_eq!(failures, 0, "odometry steps failed");
        println!("caster_odometry\t{ns:.3}\t-");
    }

    // The 20-waypoint spline of crates/omnikin-plan/benches/plan.rs, sphere-omni limits,
    // 0.6 m/s and 1 m/s² (WPILib's TrajectoryConfig gets the same two).
    {
        let wps: Vec<[f64; 2]> = (0..20)
            .map(|k| {
                let k = k as f64;
                [0.5 * k, 0.4 * (0.9 * k).sin() + 0.1 * (2.3 * k).cos()]
            })
            .collect();
        let model = RobotModel::from_description(&RobotDescription::preset("sphere-omni").unwrap())
            .unwrap();
        let path = Path::spline(&wps).unwrap();
        let heading = HeadingLaw::Tangent { offset: 0.0 };
        let limits = MotionLimits {
            max_speed: 0.6,
            max_accel: 1.0,
            ..MotionLimits::default()
        };
        let configs = [
            (
                "plan20_1khz_trapezoid",
                1000.0,
                Timing::Profile {
                    kind: ProfileKind::Trapezoid,
                    limits,
                },
            ),
            (
                "plan20_1khz_time_optimal",
                1000.0,
                Timing::TimeOptimal { limits },
            ),
            (
                "plan20_11hz_time_optimal",
                11.0,
                Timing::TimeOptimal { limits },
            ),
        ];
        for (name, rate, timing) in configs {
            let opts = PlanOptions {
                timing,
                on_limit: OnLimit::Retime,
                rate,
                initial_steer: InitialSteer::Aligned,
            };
            let out = plan(&path, &heading, &model, &opts).unwrap();
            let n = out.plan.samples.len();
            let dur = out.plan.samples.last().map_or(0.0, |s| s.t);
            let ns = measure((batch_ms * 5.0).max(50.0), batches.min(7), |_| {
                black_box(plan(black_box(&path), &heading, &model, &opts).unwrap());
            });
            println!(
                "{name}\t{ns:.3}\tsamples={n} duration_s={dur:.3} length_m={:.3}",
                path.length()
            );
        }
    }
}
