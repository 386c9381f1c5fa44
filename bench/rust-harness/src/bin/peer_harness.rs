//! The Rust side of the WPILib peer comparison (`bench/peers/run.sh` runs it alternately with
//! `bench/peers/wpimath_harness.cpp`). Same inputs and loop shape as the C++ harness: a
//! 64-entry table built before timing, one call per iteration, inputs through `black_box`,
//! every result consumed by `black_box`. One process run = one round; each benchmark prints
//! `name<TAB>median ns per call<TAB>extra`.
//!
//! `omnikin-peer-harness [--batch-ms 20] [--batches 15]`, or
//! `omnikin-peer-harness --count NAME N`: exactly `N` untimed calls of benchmark `NAME`, nothing
//! else (for callgrind: `bench/peers/run.sh --instructions`), or
//! `omnikin-peer-harness --values`: the results of the mecanum and swerve4 calls for the inputs
//! the C++ side's `--values` uses, through the concrete models and again through
//! `omnikin::Robot` (`robot_*` rows), which `bench/peers/agree.py` compares to 1e-9.

use std::hint::black_box;

use omnikin::Twist2;
use omnikin::caster::{Caster3, CasterParams, CasterRates};
use omnikin::drive::Rot2;
use omnikin::drive::omni::{Omni, presets};
use omnikin::drive::swerve::{Swerve, SwerveState, swerve4};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::{Actuators, Pose2, Robot};
use omnikin_bench::{Inputs, K, measure, plan20, robot, waypoints20};
use omnikin_plan::path::Path;
use omnikin_plan::planner::{PlanOptions, Timing, plan};
use omnikin_plan::profile::ProfileKind;

/// Timed runs, or `--count NAME N`.
struct Runner {
    batch_ms: f64,
    batches: usize,
    count: Option<(String, u64)>,
}

impl Runner {
    /// Times `body` (returns the ns per call), or in count mode runs it `N` times if `name` is
    /// the one asked for; `None` when nothing was timed.
    fn run(&self, name: &str, scale: f64, mut body: impl FnMut(u64)) -> Option<f64> {
        match &self.count {
            Some((only, n)) => {
                if only == name {
                    for i in 0..*n {
                        body(i);
                    }
                }
                None
            }
            None => Some(measure(
                (self.batch_ms * scale).max(self.batch_ms),
                if scale > 1.0 {
                    self.batches.min(7)
                } else {
                    self.batches
                },
                body,
            )),
        }
    }
}

/// Wheel radius of the mecanum and swerve4 presets, m.
const R4: f64 = 0.05;

/// The four-wheel tables of the C++ harness (same formulas): steer angles (rad), per-step
/// wheel travel (m), wheel speeds (m/s).
struct Inputs4 {
    steer: [[f64; 4]; K],
    dist: [[f64; 4]; K],
    speed: [[f64; 4]; K],
}

impl Inputs4 {
    fn new() -> Self {
        let f = |k: usize| k as f64;
        Self {
            steer: core::array::from_fn(|k| {
                core::array::from_fn(|j| 0.8 * (0.13 * f(k) + j as f64).sin())
            }),
            dist: core::array::from_fn(|k| {
                core::array::from_fn(|j| 1e-3 * (0.5 + 0.3 * (0.11 * f(k) + j as f64).sin()))
            }),
            speed: core::array::from_fn(|k| {
                core::array::from_fn(|j| 0.5 * (0.19 * f(k) + 0.7 * j as f64).sin())
            }),
        }
    }
}

/// A preset robot as a robot file builds it (`robots/<name>.toml`).
fn preset_robot(name: &str) -> Robot<f64> {
    omnikin::description::RobotDescription::preset(name)
        .expect("preset")
        .build::<f64>()
        .expect("preset robot")
}

fn row(name: &str, k: usize, v: &[f64]) {
    let mut line = format!("{name}\t{k}");
    for x in v {
        line.push_str(&format!("\t{x:.17e}"));
    }
    println!("{line}");
}

/// `--values`: see the crate doc.
fn print_values(inp: &Inputs, in4: &Inputs4) {
    let mec = Omni::new(presets::mecanum::<f64>()).unwrap();
    for k in 0..K {
        row(
            "mecanum_inverse",
            k,
            &mec.wheel_rates(inp.twist[k]).unwrap(),
        );
    }
    for k in 0..K {
        let t = mec.body_twist(&in4.speed[k].map(|v| v / R4)).unwrap();
        row("mecanum_forward", k, &t.to_array());
    }
    let mut odo = Odometry::new(Robot::Omni4(mec), Pose2::default());
    let (mut q, mut yaw) = ([0.0f64; 4], 0.0f64);
    odo.update(&EncoderReading::new(0.0, q), HeadingInput::Absolute(yaw))
        .unwrap();
    for k in 0..4 * K {
        let kk = k & (K - 1);
        for j in 0..4 {
            q[j] += 20.0 * in4.dist[kk][j] * if j % 2 == 1 { 1.0 } else { -0.5 } / R4;
        }
        yaw += 1e-3 * inp.twist[kk].yaw_rate * 20.0;
        let t = (k + 1) as f64;
        let p = odo
            .update(&EncoderReading::new(t, q), HeadingInput::Absolute(yaw))
            .unwrap()
            .pose;
        row(
            "mecanum_odometry",
            k,
            &[p.x, p.y, p.heading.cos(), p.heading.sin()],
        );
    }

    let sw = Swerve::new(swerve4::<f64>()).unwrap();
    // WPILib's kinematics object remembers its module headings; here the caller passes them.
    let mut prev = [Rot2::identity(); 4];
    for k in 0..K {
        let t = if k % 16 == 15 {
            Twist2::default()
        } else {
            inp.twist[k]
        };
        let st = sw.module_states(t, &prev).unwrap();
        prev = st.steer;
        let mut v = st.wheel_rates.to_vec();
        v.extend(st.steer.iter().map(|r| r.cos));
        v.extend(st.steer.iter().map(|r| r.sin));
        row("swerve4_inverse", k, &v);
    }
    for k in 0..K {
        let st = SwerveState::from_angles(in4.speed[k].map(|v| v / R4), in4.steer[k]);
        row(
            "swerve4_forward",
            k,
            &sw.body_twist(&st).unwrap().to_array(),
        );
    }
    let mut odo = Odometry::new(Robot::Swerve4(sw), Pose2::default());
    let (mut q, mut yaw) = ([0.0f64; 4], 0.0f64);
    let start = EncoderReading::with_steer(0.0, q, in4.steer[0]);
    odo.update(&start, HeadingInput::Absolute(yaw)).unwrap();
    for k in 0..4 * K {
        let kk = k & (K - 1);
        for j in 0..4 {
            q[j] += 20.0 * in4.dist[kk][j] / R4;
        }
        yaw += 1e-3 * inp.twist[kk].yaw_rate * 20.0;
        let pos = EncoderReading::with_steer((k + 1) as f64, q, in4.steer[kk]);
        let p = odo.update(&pos, HeadingInput::Absolute(yaw)).unwrap().pose;
        row(
            "swerve4_odometry",
            k,
            &[p.x, p.y, p.heading.cos(), p.heading.sin()],
        );
    }
}

/// `--values` of the uniform path: the same calls as [`print_values`] through `omnikin::Robot`
/// built from the presets, printed as `robot_<name>` rows (agree.py compares each with the
/// WPILib row of the same call).
fn print_robot_values(inp: &Inputs, in4: &Inputs4) {
    let mec = preset_robot("mecanum");
    let zero = Actuators::<f64>::zero();
    for k in 0..K {
        let a = mec.inverse(inp.twist[k], &zero).unwrap();
        row("robot_mecanum_inverse", k, &a.wheel_rates[..4]);
    }
    for k in 0..K {
        let m = mec
            .forward(&Actuators::from_wheel_rates(&in4.speed[k].map(|v| v / R4)))
            .unwrap();
        row("robot_mecanum_forward", k, &m.twist.to_array());
    }
    let mut odo = Odometry::new(mec, Pose2::default());
    let (mut q, mut yaw) = ([0.0f64; 4], 0.0f64);
    odo.update(&EncoderReading::new(0.0, q), HeadingInput::Absolute(yaw))
        .unwrap();
    for k in 0..4 * K {
        let kk = k & (K - 1);
        for j in 0..4 {
            q[j] += 20.0 * in4.dist[kk][j] * if j % 2 == 1 { 1.0 } else { -0.5 } / R4;
        }
        yaw += 1e-3 * inp.twist[kk].yaw_rate * 20.0;
        let r = EncoderReading::new(1e-3 * (k + 1) as f64, q);
        let p = odo.update(&r, HeadingInput::Absolute(yaw)).unwrap().pose;
        row(
            "robot_mecanum_odometry",
            k,
            &[p.x, p.y, p.heading.cos(), p.heading.sin()],
        );
    }

    let sw = preset_robot("swerve4");
    let mut cur = Actuators::<f64>::zero();
    for k in 0..K {
        let t = if k % 16 == 15 {
            Twist2::default()
        } else {
            inp.twist[k]
        };
        let a = sw.inverse(t, &cur).unwrap();
        cur = a;
        let mut v = a.wheel_rates[..4].to_vec();
        v.extend(a.steer_angles[..4].iter().map(|g| g.cos()));
        v.extend(a.steer_angles[..4].iter().map(|g| g.sin()));
        row("robot_swerve4_inverse", k, &v);
    }
    for k in 0..K {
        let mut a = Actuators::from_wheel_rates(&in4.speed[k].map(|v| v / R4));
        a.steer_angles[..4].copy_from_slice(&in4.steer[k]);
        row(
            "robot_swerve4_forward",
            k,
            &sw.forward(&a).unwrap().twist.to_array(),
        );
    }
    let mut odo = Odometry::new(sw, Pose2::default());
    let (mut q, mut yaw) = ([0.0f64; 4], 0.0f64);
    odo.update(
        &EncoderReading::with_steer(0.0, q, in4.steer[0]),
        HeadingInput::Absolute(yaw),
    )
    .unwrap();
    for k in 0..4 * K {
        let kk = k & (K - 1);
        for j in 0..4 {
            q[j] += 20.0 * in4.dist[kk][j] / R4;
        }
        yaw += 1e-3 * inp.twist[kk].yaw_rate * 20.0;
        let r = EncoderReading::with_steer(1e-3 * (k + 1) as f64, q, in4.steer[kk]);
        let p = odo.update(&r, HeadingInput::Absolute(yaw)).unwrap().pose;
        row(
            "robot_swerve4_odometry",
            k,
            &[p.x, p.y, p.heading.cos(), p.heading.sin()],
        );
    }
}

fn main() {
    let mut rn = Runner {
        batch_ms: 20.0,
        batches: 15,
        count: None,
    };
    let args: Vec<String> = std::env::args().collect();
    for (i, w) in args.windows(2).enumerate() {
        match w[0].as_str() {
            "--batch-ms" => rn.batch_ms = w[1].parse().expect("--batch-ms NUMBER"),
            "--batches" => rn.batches = w[1].parse().expect("--batches NUMBER"),
            "--count" => {
                let n = args
                    .get(i + 2)
                    .and_then(|v| v.parse().ok())
                    .expect("--count NAME N");
                rn.count = Some((w[1].clone(), n));
            }
            _ => {}
        }
    }
    let inp = Inputs::new();
    let in4 = Inputs4::new();
    if args.iter().any(|a| a == "--values") {
        print_values(&inp, &in4);
        print_robot_values(&inp, &in4);
        return;
    }
    let caster = Caster3::<f64>::new(CasterParams::preset()).unwrap();

    // Caster inverse: world twist + heading + steer angles -> six motor rates.
    let ns = rn.run("caster_inverse", 1.0, |i| {
        let k = i as usize & (K - 1);
        let r = caster.motor_rates(
            black_box(inp.twist[k]),
            black_box(inp.heading[k]),
            black_box(inp.steer[k]),
        );
        black_box(r.unwrap());
    });
    if let Some(ns) = ns {
        println!("caster_inverse\t{ns:.3}\t-");
    }

    // Sphere and ballbot inverse: robot twist (+ spin 0) -> three wheel rates.
    for name in ["sphere", "ballbot"] {
        let rob = robot(name).unwrap();
        let label = format!("{name}_inverse");
        let ns = match rob {
            Robot::Sphere(s) => rn.run(&label, 1.0, |i| {
                let k = i as usize & (K - 1);
                black_box(
                    s.wheel_rates(black_box(inp.twist[k]), black_box(0.0))
                        .unwrap(),
                );
            }),
            Robot::Ballbot(b) => rn.run(&label, 1.0, |i| {
                let k = i as usize & (K - 1);
                black_box(
                    b.wheel_rates(black_box(inp.twist[k]), black_box(0.0))
                        .unwrap(),
                );
            }),
            _ => unreachable!("sphere or ballbot"),
        };
        if let Some(ns) = ns {
            println!("{label}\t{ns:.3}\t-");
        }
    }

    // Forward kinematics, vs SwerveDriveKinematics::ToChassisSpeeds (robot-relative chassis
    // speeds): the caster's six motor rates + steer angles -> least-squares robot-frame twist
    // (`caster_forward`), and the same turned into the world frame with the heading
    // (`caster_forward_world`, one more sin_cos); the sphere's and ballbot's three wheel rates
    // -> robot twist.
    {
        let rates = |k: usize| {
            let t = inp.twist[k];
            black_box(CasterRates {
                roll: [t.vx, t.vy, t.yaw_rate],
                steer: [t.vy, t.yaw_rate, t.vx],
            })
        };
        let ns = rn.run("caster_forward", 1.0, |i| {
            let k = i as usize & (K - 1);
            let r = caster.robot_twist(&rates(k), black_box(inp.steer[k]));
            black_box(r.unwrap());
        });
        if let Some(ns) = ns {
            println!("caster_forward\t{ns:.3}\t-");
        }
        let ns = rn.run("caster_forward_world", 1.0, |i| {
            let k = i as usize & (K - 1);
            let r = caster.body_twist(
                &rates(k),
                black_box(inp.heading[k]),
                black_box(inp.steer[k]),
            );
            black_box(r.unwrap());
        });
        if let Some(ns) = ns {
            println!("caster_forward_world\t{ns:.3}\t-");
        }
    }
    for name in ["sphere", "ballbot"] {
        let rob = robot(name).unwrap();
        let label = format!("{name}_forward");
        let wheels = |k: usize| black_box([inp.twist[k].vx, inp.twist[k].vy, 0.3]);
        let ns = match rob {
            Robot::Sphere(s) => rn.run(&label, 1.0, |i| {
                let k = i as usize & (K - 1);
                black_box(s.body_twist(wheels(k), black_box(0.0)).unwrap());
            }),
            Robot::Ballbot(b) => rn.run(&label, 1.0, |i| {
                let k = i as usize & (K - 1);
                black_box(b.body_twist(wheels(k), black_box(0.0)).unwrap());
            }),
            _ => unreachable!("sphere or ballbot"),
        };
        if let Some(ns) = ns {
            println!("{label}\t{ns:.3}\t-");
        }
    }

    // Sphere and ballbot odometry step: three wheel angles + absolute yaw (the wheel travel of
    // the shared table, as for the caster).
    for name in ["sphere", "ballbot"] {
        let rob = robot(name).unwrap();
        let label = format!("{name}_odometry");
        let mut odo = Odometry::new(rob, Pose2::new(0.0, 0.0, 0.0));
        let (mut t, mut yaw, mut wheel) = (0.0f64, 0.0f64, [0.0f64; 3]);
        let mut failures = 0u64;
        let ns = rn.run(&label, 1.0, |i| {
            let k = i as usize & (K - 1);
            for j in 0..3 {
                wheel[j] += inp.dist_step[k][j] * 20.0;
            }
            t += 1e-3;
            yaw += 1e-3 * inp.twist[k].yaw_rate;
            let reading = EncoderReading::new(black_box(t), black_box(wheel));
            match odo.update(&reading, HeadingInput::Absolute(black_box(yaw))) {
                Ok(step) => {
                    black_box(step.pose);
                }
                Err(_) => failures += 1,
            }
        });
        assert_eq!(failures, 0, "{label}: odometry steps failed");
        if let Some(ns) = ns {
            println!("{label}\t{ns:.3}\t-");
        }
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
        let ns = rn.run("caster_odometry", 1.0, |i| {
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
        if let Some(ns) = ns {
            println!("caster_odometry\t{ns:.3}\t-");
        }
    }

    // Mecanum (robots/mecanum.toml) vs MecanumDriveKinematics / MecanumDriveOdometry: robot
    // twist -> four wheel rates; four wheel rates -> least-squares robot twist; odometry step
    // from four cumulative wheel angles + absolute gyro yaw.
    {
        let mec = Omni::new(presets::mecanum::<f64>()).unwrap();
        let ns = rn.run("mecanum_inverse", 1.0, |i| {
            let k = i as usize & (K - 1);
            black_box(mec.wheel_rates(black_box(inp.twist[k])).unwrap());
        });
        if let Some(ns) = ns {
            println!("mecanum_inverse\t{ns:.3}\t-");
        }
        // Wheel rates in rad/s: the table's m/s over r, converted before timing (units, not
        // work: WPILib's input is in m/s).
        let rates: [[f64; 4]; K] = core::array::from_fn(|k| in4.speed[k].map(|v| v / R4));
        let ns = rn.run("mecanum_forward", 1.0, |i| {
            let k = i as usize & (K - 1);
            black_box(mec.body_twist(black_box(&rates[k])).unwrap());
        });
        if let Some(ns) = ns {
            println!("mecanum_forward\t{ns:.3}\t-");
        }
        let step: [[f64; 4]; K] = core::array::from_fn(|k| in4.dist[k].map(|v| v / R4));
        let mut odo = Odometry::new(Robot::Omni4(mec), Pose2::default());
        let (mut q, mut yaw, mut t) = ([0.0f64; 4], 0.0f64, 0.0f64);
        let mut failures = 0u64;
        let ns = rn.run("mecanum_odometry", 1.0, |i| {
            let k = i as usize & (K - 1);
            for j in 0..4 {
                q[j] += step[k][j];
            }
            yaw += 1e-3 * inp.twist[k].yaw_rate;
            t += 1e-3;
            let r = EncoderReading::new(t, black_box(q));
            match odo.update(&r, HeadingInput::Absolute(black_box(yaw))) {
                Ok(p) => {
                    black_box(p);
                }
                Err(_) => failures += 1,
            }
        });
        assert_eq!(failures, 0, "mecanum odometry steps failed");
        if let Some(ns) = ns {
            println!("mecanum_odometry\t{ns:.3}\t-");
        }
    }

    // Swerve4 (robots/swerve4.toml) vs SwerveDriveKinematics<4> / SwerveDriveOdometry<4>: the
    // steer angles come in as radians (Rot2::from_angle = one sin_cos each, as WPILib's
    // Rotation2d constructions); the inverse returns (cos, sin) directions as WPILib's
    // Rotation2d does.
    {
        let sw = Swerve::new(swerve4::<f64>()).unwrap();
        let prev = [Rot2::identity(); 4];
        let ns = rn.run("swerve4_inverse", 1.0, |i| {
            let k = i as usize & (K - 1);
            black_box(
                sw.module_states(black_box(inp.twist[k]), black_box(&prev))
                    .unwrap(),
            );
        });
        if let Some(ns) = ns {
            println!("swerve4_inverse\t{ns:.3}\t-");
        }
        let rates: [[f64; 4]; K] = core::array::from_fn(|k| in4.speed[k].map(|v| v / R4));
        let ns = rn.run("swerve4_forward", 1.0, |i| {
            let k = i as usize & (K - 1);
            let st = SwerveState {
                wheel_rates: black_box(rates[k]),
                steer: black_box(in4.steer[k]).map(Rot2::from_angle),
            };
            black_box(sw.body_twist(&st).unwrap());
        });
        if let Some(ns) = ns {
            println!("swerve4_forward\t{ns:.3}\t-");
        }
        let step: [[f64; 4]; K] = core::array::from_fn(|k| in4.dist[k].map(|v| v / R4));
        let mut odo = Odometry::new(Robot::Swerve4(sw), Pose2::default());
        let (mut q, mut yaw, mut t) = ([0.0f64; 4], 0.0f64, 0.0f64);
        let mut failures = 0u64;
        let ns = rn.run("swerve4_odometry", 1.0, |i| {
            let k = i as usize & (K - 1);
            for j in 0..4 {
                q[j] += step[k][j];
            }
            yaw += 1e-3 * inp.twist[k].yaw_rate;
            t += 1e-3;
            let pos = EncoderReading::with_steer(t, black_box(q), black_box(in4.steer[k]));
            match odo.update(&pos, HeadingInput::Absolute(black_box(yaw))) {
                Ok(p) => {
                    black_box(p);
                }
                Err(_) => failures += 1,
            }
        });
        assert_eq!(failures, 0, "swerve4 odometry steps failed");
        if let Some(ns) = ns {
            println!("swerve4_odometry\t{ns:.3}\t-");
        }
    }

    // The uniform path: the same calls through `omnikin::Robot` built from the presets as a
    // robot file builds them (`RobotDescription::build`), with the fixed-capacity `Actuators`
    // and `EncoderAngles` — what the enum dispatch and the uniform values cost over the
    // concrete models above. `Robot::forward` also returns the slip residual and per-wheel slip
    // (the concrete `body_twist` above does not); the swerve's `Robot::inverse` takes the
    // current steer angles in radians (one `sin_cos` each, to keep a stopped module's angle)
    // and returns angles (one `atan2` each); the odometry is `estimate::odometry::Odometry`,
    // as for the sphere, ballbot and caster above.
    for name in ["mecanum", "swerve4"] {
        let rob = preset_robot(name);
        let steer = name == "swerve4";
        let label = |verb: &str| format!("robot_{name}_{verb}");
        let current = Actuators::<f64>::zero();
        let ns = rn.run(&label("inverse"), 1.0, |i| {
            let k = i as usize & (K - 1);
            black_box(
                rob.inverse(black_box(inp.twist[k]), black_box(&current))
                    .unwrap(),
            );
        });
        if let Some(ns) = ns {
            println!("{}\t{ns:.3}\t-", label("inverse"));
        }
        // Wheel rates in rad/s (and steer angles in rad), built before timing as above.
        let acts: [Actuators<f64>; K] = core::array::from_fn(|k| {
            let mut a = Actuators::from_wheel_rates(&in4.speed[k].map(|v| v / R4));
            if steer {
                a.steer_angles[..4].copy_from_slice(&in4.steer[k]);
            }
            a
        });
        let ns = rn.run(&label("forward"), 1.0, |i| {
            let k = i as usize & (K - 1);
            black_box(rob.forward(black_box(&acts[k])).unwrap());
        });
        if let Some(ns) = ns {
            println!("{}\t{ns:.3}\t-", label("forward"));
        }
        let step: [[f64; 4]; K] = core::array::from_fn(|k| in4.dist[k].map(|v| v / R4));
        let mut odo = Odometry::new(rob, Pose2::new(0.0, 0.0, 0.0));
        let (mut t, mut yaw, mut q) = (0.0f64, 0.0f64, [0.0f64; 4]);
        let first = if steer {
            EncoderReading::with_steer(0.0, q, in4.steer[0])
        } else {
            EncoderReading::new(0.0, q)
        };
        odo.update(&first, HeadingInput::Absolute(0.0))
            .expect("first reading");
        let mut failures = 0u64;
        let ns = rn.run(&label("odometry"), 1.0, |i| {
            let k = i as usize & (K - 1);
            for j in 0..4 {
                q[j] += step[k][j];
            }
            t += 1e-3;
            yaw += 1e-3 * inp.twist[k].yaw_rate;
            let reading = if steer {
                EncoderReading::with_steer(black_box(t), black_box(q), black_box(in4.steer[k]))
            } else {
                EncoderReading::new(black_box(t), black_box(q))
            };
            match odo.update(&reading, HeadingInput::Absolute(black_box(yaw))) {
                Ok(step) => {
                    black_box(step.pose);
                }
                Err(_) => failures += 1,
            }
        });
        assert_eq!(failures, 0, "{name}: odometry steps through Robot failed");
        if let Some(ns) = ns {
            println!("{}\t{ns:.3}\t-", label("odometry"));
        }
    }

    // The 20-waypoint spline of crates/omnikin-plan/benches/plan.rs, sphere-omni limits,
    // 0.6 m/s and 1 m/s² (WPILib's TrajectoryConfig gets the same two).
    {
        let (path, heading, model, base) = plan20(1000.0);
        let limits = match base.timing {
            Timing::TimeOptimal { limits } => limits,
            _ => unreachable!(),
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
            ("plan20_1khz_time_optimal", 1000.0, base.timing),
            ("plan20_11hz_time_optimal", 11.0, base.timing),
        ];
        for (name, rate, timing) in configs {
            let opts = PlanOptions {
                timing,
                rate,
                ..base
            };
            // The spline is built inside the timed loop, as GenerateTrajectory builds its own.
            let wps = waypoints20();
            let ns = rn.run(name, 5.0, |_| {
                let path = Path::spline(black_box(&wps)).unwrap();
                black_box(plan(&path, &heading, &model, &opts).unwrap());
            });
            if let Some(ns) = ns {
                let out = plan(&path, &heading, &model, &opts).unwrap();
                let n = out.plan.samples.len();
                let dur = out.plan.samples.last().map_or(0.0, |s| s.t);
                println!(
                    "{name}\t{ns:.3}\tsamples={n} duration_s={dur:.3} length_m={:.3}",
                    path.length()
                );
            }
        }
    }
}
