//! Odometry and estimation end to end against the simulator's ground truth: noise-free
//! encoders give the planned path back for all three robots; seeded noisy trials report the
//! drift per metre; camera fixes (with latency and outliers) keep the fused estimate bounded
//! while odometry drifts; the sphere's shell spin is recovered from wheels + gyro.

use std::f64::consts::{PI, TAU};

use omnikin::ballbot::{Ballbot, BallbotParams};
use omnikin::caster::{Caster3, CasterParams};
use omnikin::estimate::fix::Fix;
use omnikin::estimate::fusion::{FusionConfig, FusionOutcome, PoseFusion, StepHeading};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Robot, Twist2};
use omnikin_plan::{Plan, Sample};
use omnikin_sim::sensors::{
    CameraProfile, EncoderRow, GyroProfile, SensorProfile, emit, write_encoder_log,
};
use omnikin_sim::{Profile, Trial, simulate_trial, trial_rng};

fn sphere() -> SphereOmni<f64> {
    SphereOmni::new(SphereParams::preset()).unwrap()
}

/// A plan from an analytic world motion, wheel rates from the robot's inverse kinematics.
fn plan(
    robot: &Robot<f64>,
    duration: f64,
    rate: f64,
    motion: impl Fn(f64) -> (Pose2<f64>, Twist2<f64>),
) -> Plan {
    let n = (duration * rate).round() as usize;
    Plan {
        wheels: 3,
        samples: (0..=n)
            .map(|k| {
                let t = k as f64 / rate;
                let (pose, twist) = motion(t);
                let wheel_rates = match robot {
                    Robot::Sphere(m) => m.wheel_rates_world(twist, pose.heading, 0.0).unwrap(),
                    Robot::Ballbot(m) => m.wheel_rates_world(twist, pose.heading, 0.0).unwrap(),
                    _ => unreachable!("sphere and ballbot only; caster plans are built separately"),
                };
                Sample {
                    t,
                    pose,
                    twist,
                    wheel_rates: omnikin_plan::per_wheel(&wheel_rates),
                    steer: None,
                }
            })
            .collect(),
    }
}

/// Paper 000's circle (radius `rt`, heading tangent, ψ = ω0 t) followed by a turn in place.
fn circle_then_turn(robot: &Robot<f64>, rt: f64, w0: f64) -> Plan {
    let lap = TAU / w0;
    plan(robot, lap + 3.0, 100.0, |t| {
        if t <= lap {
            let (s, c) = (w0 * t).sin_cos();
            (
                Pose2::new(rt * c, rt * s, PI / 2.0 + w0 * t),
                Twist2::new(-rt * w0 * s, rt * w0 * c, w0),
            )
        } else {
            let h = PI / 2.0 + w0 * lap - 1.5 * (t - lap);
            (Pose2::new(rt, 0.0, h), Twist2::new(0.0, 0.0, -1.5))
        }
    })
}

/// Caster: all wheels parallel, constant steer and roll rates: a consistent motion along the
/// single-wheel curve (paper 003, eqs. 11–13).
fn caster_plan(m: &Caster3<f64>, duration: f64) -> Plan {
    let p = *m.params();
    let (beta0, rho, xi) = (0.3, 1.5, 4.0);
    let gamma0: [f64; 3] = core::array::from_fn(|i| beta0 - p.mount_angles[i]);
    let n = (duration * 100.0).round() as usize;
    Plan {
        wheels: 3,
        samples: (0..=n)
            .map(|k| {
                let t = k as f64 / 100.0;
                let (s, c) = (beta0 + rho * t).sin_cos();
                Sample {
                    t,
                    pose: Pose2::new(0.0, 0.0, 0.0),
                    twist: Twist2::new(
                        -p.wheel_radius * xi * c + p.eccentricity * rho * s,
                        -p.wheel_radius * xi * s - p.eccentricity * rho * c,
                        0.0,
                    ),
                    wheel_rates: omnikin_plan::per_wheel(&[xi; 3]),
                    steer: Some((
                        omnikin_plan::per_wheel(&core::array::from_fn::<_, 3, _>(|i| {
                            gamma0[i] + rho * t
                        })),
                        omnikin_plan::per_wheel(&[rho; 3]),
                    )),
                }
            })
            .collect(),
    }
}

fn readings(rows: &[EncoderRow]) -> impl Iterator<Item = (EncoderReading<f64>, &EncoderRow)> {
    rows.iter().map(|r| {
        (
            EncoderReading::with_steer(r.t, r.q, r.steer.unwrap_or([0.0; omnikin::MAX_WHEELS])),
            r,
        )
    })
}

/// Runs odometry over the encoder log; returns the poses.
fn odometry(robot: Robot<f64>, trial: &Trial, rows: &[EncoderRow], gyro: bool) -> Vec<Pose2<f64>> {
    let mut odo = Odometry::new(robot, trial.pose[0]);
    readings(rows)
        .map(|(r, row)| {
            let h = match (gyro, row.gyro_z) {
                (true, Some(g)) => HeadingInput::GyroRate(g),
                _ => HeadingInput::Wheels,
            };
            odo.update(&r, h).unwrap().pose
        })
        .collect()
}

fn worst(a: &[Pose2<f64>], b: &[Pose2<f64>]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p.x - q.x).hypot(p.y - q.y))
        .fold(0.0, f64::max)
}

fn path_length(trial: &Trial) -> f64 {
    trial
        .pose
        .windows(2)
        .map(|w| (w[1].x - w[0].x).hypot(w[1].y - w[0].y))
        .sum()
}

#[test]
fn noise_free_simulated_encoders_give_the_path_back() {
    let robots = [
        ("sphere-omni", Robot::Sphere(sphere())),
        (
            "ballbot",
            Robot::Ballbot(Ballbot::new(BallbotParams::preset()).unwrap()),
        ),
    ];
    for (name, robot) in robots {
        let plan = circle_then_turn(&robot, 0.2, 1.0);
        // Zero-order hold: the wheel rates are constant between samples, so every step is a
        // constant twist and the odometry must be exact. (With the default linear ramp the
        // one interval where the circle turns into the turn in place costs ~2.5 µm.)
        let zoh = Profile::from_toml_str("hold = \"zoh\"", "zoh").unwrap();
        let trial = simulate_trial(&robot, &plan, &zoh, &mut trial_rng(1, 0)).unwrap();
        let s = emit(
            &robot,
            &trial,
            &SensorProfile::default(),
            &mut trial_rng(1, 1),
        );
        let poses = odometry(robot, &trial, &s.encoder, false);
        let err = worst(&poses, &trial.pose);
        let herr = (poses.last().unwrap().heading - trial.pose.last().unwrap().heading).abs();
        println!(
            "{name}: circle + turn in place, worst odometry error {err:.2e} m, end heading error {herr:.2e} rad"
        );
        assert!(err < 1e-9 && herr < 1e-9, "{name}: {err:e} {herr:e}");
    }
    let m = Caster3::new(CasterParams::preset()).unwrap();
    let plan = caster_plan(&m, 3.0);
    let robot = Robot::Caster(m);
    let trial = simulate_trial(&robot, &plan, &Profile::default(), &mut trial_rng(1, 0)).unwrap();
    let s = emit(
        &robot,
        &trial,
        &SensorProfile::default(),
        &mut trial_rng(1, 1),
    );
    let poses = odometry(robot, &trial, &s.encoder, false);
    let err = worst(&poses, &trial.pose);
    println!(
        "caster3: single-wheel curve, worst odometry error {err:.2e} m over {:.2} m",
        path_length(&trial)
    );
    // The plant integrates at 1 kHz with mid-step steer angles, the odometry at 100 Hz.
    assert!(err < 1e-5, "{err:e}");
}

/// A realistic disturbance profile: stepper quantisation, lag, speed fluctuation, wheel-radius
/// errors, floor slip.
fn noisy_profile() -> Profile {
    Profile::from_toml_str(
        "[wheel_motor]\nsteps_per_rev = 200\nmicrosteps = 16\nlag_time_constant = 0.005\n\
         fluctuation_abs = 0.02\nfluctuation_rel = 0.01\nradius_error_std = 0.005\n\
         [steer_motor]\nlag_time_constant = 0.005\nfluctuation_abs = 0.02\n\
         [floor]\nrel_std = 0.01\ncorr_time = 0.5\n",
        "noisy",
    )
    .unwrap()
}

#[test]
fn seeded_noisy_trials_report_drift_per_metre() {
    let sensors = SensorProfile {
        counts_per_rev: Some(4096),
        steer_counts_per_rev: Some(4096),
        ..SensorProfile::default()
    };
    let m = Caster3::new(CasterParams::preset()).unwrap();
    let cases = [
        (
            "sphere-omni",
            Robot::Sphere(sphere()),
            circle_then_turn(&Robot::Sphere(sphere()), 0.3, 0.8),
        ),
        (
            "ballbot",
            Robot::Ballbot(Ballbot::new(BallbotParams::preset()).unwrap()),
            circle_then_turn(
                &Robot::Ballbot(Ballbot::new(BallbotParams::preset()).unwrap()),
                0.3,
                0.8,
            ),
        ),
        ("caster3", Robot::Caster(m), caster_plan(&m, 4.0)),
    ];
    for (name, robot, plan) in cases {
        let mut per_metre = Vec::new();
        for i in 0..12 {
            let trial =
                simulate_trial(&robot, &plan, &noisy_profile(), &mut trial_rng(7, i)).unwrap();
            let s = emit(&robot, &trial, &sensors, &mut trial_rng(8, i));
            let poses = odometry(robot, &trial, &s.encoder, false);
            let (a, b) = (poses.last().unwrap(), trial.pose.last().unwrap());
            per_metre.push((a.x - b.x).hypot(a.y - b.y) / path_length(&trial));
        }
        let mean = per_metre.iter().sum::<f64>() / per_metre.len() as f64;
        let max = per_metre.iter().cloned().fold(0.0, f64::max);
        println!(
            "{name}: odometry end drift per metre travelled over 12 seeded trials: mean {:.2} %, max {:.2} %",
            100.0 * mean,
            100.0 * max
        );
        // Radius errors (0.5 %) and floor slip (1 %) are invisible to the encoders: the
        // drift must be there, and of that order.
        assert!(mean > 1e-3 && max < 0.1, "{name}: {per_metre:?}");
    }
}

#[test]
fn camera_fusion_bounds_the_error_while_odometry_drifts() {
    let robot = Robot::Sphere(sphere());
    // Three laps of a 0.3 m circle at 0.24 m/s: 5.7 m.
    let w0 = 0.8;
    let lap = TAU / w0;
    let plan = plan(&robot, 3.0 * lap, 100.0, |t| {
        let (s, c) = (w0 * t).sin_cos();
        (
            Pose2::new(0.3 * c, 0.3 * s, PI / 2.0 + w0 * t),
            Twist2::new(-0.3 * w0 * s, 0.3 * w0 * c, w0),
        )
    });
    let sensors = SensorProfile {
        counts_per_rev: Some(4096),
        camera: Some(CameraProfile {
            period: 0.2,
            latency: 0.12,
            noise_std: 0.005,
            heading_noise_std: None,
            outlier_probability: 0.05,
            outlier_distance: 0.4,
        }),
        ..SensorProfile::default()
    };
    let trial = simulate_trial(&robot, &plan, &noisy_profile(), &mut trial_rng(3, 0)).unwrap();
    let s = emit(&robot, &trial, &sensors, &mut trial_rng(3, 1));
    let mut odo = Odometry::new(robot, trial.pose[0]);
    let mut est = PoseFusion::<f64, 128>::new(
        trial.t[0],
        trial.pose[0],
        omnikin::nalgebra::Matrix3::identity() * 1e-4,
        FusionConfig {
            gyro_bias_std: 0.0,
            scale_std: 0.0,
            ..FusionConfig::default()
        },
    )
    .unwrap();
    let (mut next_fix, mut rejected, mut outliers_rejected) = (0, 0, 0);
    let (mut worst_fused, mut odo_end) = (0.0f64, 0.0);
    for (k, (r, _)) in readings(&s.encoder).enumerate() {
        let step = odo.update(&r, HeadingInput::Wheels).unwrap();
        if k > 0 {
            est.predict(step.t, step.delta, StepHeading::Wheels)
                .unwrap();
        }
        // Fixes are handed over when they arrive, stamped with the time they were taken.
        while next_fix < s.fixes.len() && s.fixes[next_fix].arrival <= r.t + 1e-9 {
            let f = s.fixes[next_fix];
            next_fix += 1;
            if let FusionOutcome::Rejected { .. } =
                est.add_fix(&Fix::position(f.t, f.x, f.y, 0.005)).unwrap()
            {
                rejected += 1;
                outliers_rejected += f.outlier as usize;
            }
        }
        let truth = trial.pose[k];
        if r.t > 2.0 {
            let e = est.pose();
            worst_fused = worst_fused.max((e.x - truth.x).hypot(e.y - truth.y));
        }
        odo_end = (step.pose.x - truth.x).hypot(step.pose.y - truth.y);
    }
    let outliers = s.fixes.iter().filter(|f| f.outlier).count();
    println!(
        "sphere, {:.1} m: odometry end error {odo_end:.3} m; fused worst error {worst_fused:.4} m; {rejected} fixes rejected ({outliers_rejected} of {outliers} outliers)",
        path_length(&trial)
    );
    assert!(odo_end > 0.03, "odometry should drift here: {odo_end}");
    assert!(
        worst_fused < 0.025,
        "fused estimate within 2.5 cm of truth: {worst_fused}"
    );
    assert_eq!(outliers_rejected, outliers, "every outlier rejected");
}

#[test]
fn shell_spin_is_recovered_in_simulation() {
    // Speed-dependent shell spin Ω3 = g·|V|^p·ω̃_z (the profile's model of paper 000's large
    // circles): on the circle every quantity is constant, so the truth is known in closed form.
    let (g, p) = (0.875, 1.22);
    let profile = Profile::from_toml_str(
        &format!("[shell_spin]\nslip_gain = {g}\nslip_exponent = {p}\n"),
        "spin",
    )
    .unwrap();
    let m = sphere();
    let robot = Robot::Sphere(m);
    let (rt, w0) = (0.2, 2.0); // 0.4 m/s, where paper 000 saw 1.4× the radius
    let plan = plan(&robot, 3.0, 100.0, |t| {
        let (s, c) = (w0 * t).sin_cos();
        (
            Pose2::new(rt * c, rt * s, PI / 2.0 + w0 * t),
            Twist2::new(-rt * w0 * s, rt * w0 * c, w0),
        )
    });
    let w = plan.samples[0].wheel_rates;
    let tw0 = m.body_twist([w[0], w[1], w[2]], 0.0).unwrap();
    let spin_true = g * tw0.vx.hypot(tw0.vy).powf(p) * (-tw0.yaw_rate);
    let trial = simulate_trial(&robot, &plan, &profile, &mut trial_rng(5, 0)).unwrap();
    let sensors = SensorProfile {
        gyro: Some(GyroProfile::default()),
        ..SensorProfile::default()
    };
    let s = emit(&robot, &trial, &sensors, &mut trial_rng(5, 1));
    let mut odo = Odometry::new(robot, trial.pose[0]);
    let mut spins = Vec::new();
    for (r, row) in readings(&s.encoder) {
        let step = odo
            .update(&r, HeadingInput::GyroRate(row.gyro_z.unwrap()))
            .unwrap();
        if let Some(x) = step.shell_spin {
            spins.push(x);
        }
    }
    let inner = &spins[2..spins.len() - 2];
    let worst = inner
        .iter()
        .map(|x| (x - spin_true).abs())
        .fold(0.0, f64::max);
    let with_gyro = odo.pose();
    let wheels_only = *odometry(robot, &trial, &s.encoder, false).last().unwrap();
    let end = trial.pose.last().unwrap();
    println!(
        "shell spin: true {spin_true:.4} rad/s, estimated within {worst:.1e}; end error with gyro {:.2e} m, wheels only {:.3} m",
        (with_gyro.x - end.x).hypot(with_gyro.y - end.y),
        (wheels_only.x - end.x).hypot(wheels_only.y - end.y)
    );
    assert!(spin_true.abs() > 0.3, "{spin_true}");
    assert!(worst < 1e-6, "{worst:e}");
    assert!((with_gyro.x - end.x).hypot(with_gyro.y - end.y) < 1e-3);
    assert!((wheels_only.x - end.x).hypot(wheels_only.y - end.y) > 0.05);
}

#[test]
fn encoder_log_has_the_conventions_columns() {
    let m = Caster3::new(CasterParams::preset()).unwrap();
    let robot = Robot::Caster(m);
    let trial = simulate_trial(
        &robot,
        &caster_plan(&m, 0.2),
        &Profile::default(),
        &mut trial_rng(1, 0),
    )
    .unwrap();
    let sensors = SensorProfile {
        counts_per_rev: Some(1000),
        gyro: Some(GyroProfile::default()),
        yaw: Some(Default::default()),
        ..SensorProfile::default()
    };
    let s = emit(&robot, &trial, &sensors, &mut trial_rng(1, 1));
    let mut buf = Vec::new();
    write_encoder_log(&s.encoder, &mut buf).unwrap();
    let text = String::from_utf8(buf).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,q1,q2,q3,s1,s2,s3,gyro_z,yaw"));
    assert_eq!(lines.count(), trial.t.len());
    // Quantised to whole counts of 2π/1000.
    let step = TAU / 1000.0;
    for r in &s.encoder {
        for q in r.q {
            assert!(((q / step) - (q / step).round()).abs() < 1e-6, "{q}");
        }
    }
}
