//! The simulator, the sensors and odometry for the common layouts (kiwi, mecanum, swerve4)
//! through the uniform robot API: a noise-free simulation follows a plan exactly, slip makes
//! it deviate and the metrics report it, and odometry over the simulated encoder log recovers
//! the true pose even when the motors do not follow their set-points. The plans are built here
//! from the robots' own inverse kinematics (the planner is tested on its own).

use omnikin::description::RobotDescription;
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::{Actuators, Pose2, Robot, Twist2};
use omnikin_plan::{Plan, Sample};
use omnikin_sim::metrics::{Run, evaluate};
use omnikin_sim::sensors::{SensorProfile, emit, write_encoder_log};
use omnikin_sim::{Profile, SimError, Trial, plan_mismatch, simulate_trial};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const LAYOUTS: [&str; 3] = ["kiwi", "mecanum", "swerve4"];

fn preset(name: &str) -> Robot<f64> {
    RobotDescription::preset(name).unwrap().build().unwrap()
}

/// The pose after holding the robot-frame twist `tw` for `t` seconds from the origin, in
/// closed form (rotation about the instantaneous centre), independent of `omnikin::se2`.
fn arc(tw: Twist2<f64>, t: f64) -> Pose2<f64> {
    let th = tw.yaw_rate * t;
    let c = [-tw.vy / tw.yaw_rate, tw.vx / tw.yaw_rate];
    let (s, co) = th.sin_cos();
    Pose2::new(
        c[0] - (co * c[0] - s * c[1]),
        c[1] - (s * c[0] + co * c[1]),
        th,
    )
}

/// A circle: the robot-frame twist `tw` held for `t_end` s, sampled every `dt` s, with the
/// robot's inverse kinematics for the motor columns (wheel rates, and steer angles and rates
/// for a steerable kind).
fn circle_plan(robot: &Robot<f64>, tw: Twist2<f64>, t_end: f64, dt: f64) -> Plan {
    let n = robot.wheels();
    let mut current = Actuators::zero();
    let steps = (t_end / dt).round() as usize;
    let samples = (0..=steps)
        .map(|k| {
            let t = k as f64 * dt;
            let pose = arc(tw, t);
            let a = robot.inverse(tw, &current).unwrap();
            current = a;
            let steer = robot
                .steerable()
                .then_some((&a.steer_angles[..n], &a.steer_rates[..n]));
            Sample::new(
                t,
                pose,
                tw.to_world(pose.heading),
                &a.wheel_rates[..n],
                steer,
            )
        })
        .collect();
    Plan { wheels: n, samples }
}

const TWIST: Twist2<f64> = Twist2 {
    vx: 0.3,
    vy: 0.1,
    yaw_rate: 0.6,
};

fn deviation(trial: &Trial, plan: &Plan) -> f64 {
    trial
        .pose
        .iter()
        .zip(&plan.samples)
        .map(|(p, s)| (p.x - s.pose.x).hypot(p.y - s.pose.y))
        .fold(0.0, f64::max)
}

fn run_of(trial: &Trial) -> Run {
    Run {
        xy: trial.pose.iter().map(|p| [p.x, p.y]).collect(),
        heading: Some(trial.pose.iter().map(|p| p.heading).collect()),
    }
}

fn profile(text: &str) -> Profile {
    Profile::from_toml_str(text, "<test>").unwrap()
}

#[test]
fn a_noise_free_simulation_follows_the_plan_exactly() {
    for name in LAYOUTS {
        let robot = preset(name);
        let plan = circle_plan(&robot, TWIST, 8.0, 0.01);
        assert_eq!(plan_mismatch(&robot, &plan), None, "{name}");
        let trial = simulate_trial(
            &robot,
            &plan,
            &Profile::default(),
            &mut ChaCha8Rng::seed_from_u64(1),
        )
        .unwrap();
        assert_eq!(trial.wheels, robot.wheels());
        let dev = deviation(&trial, &plan);
        assert!(dev < 1e-9, "{name}: max deviation {dev:e} m");
        let heading = trial
            .pose
            .iter()
            .zip(&plan.samples)
            .map(|(p, s)| (p.heading - s.pose.heading).abs())
            .fold(0.0, f64::max);
        assert!(heading < 1e-9, "{name}: heading error {heading:e} rad");
        // Consistent motor rates: the least-squares fit leaves no slip.
        assert!(
            trial.slip_residual.iter().all(|r| r.abs() < 1e-9),
            "{name}: {:?}",
            trial.slip_residual.iter().fold(0.0f64, |m, r| m.max(*r))
        );
        // The wheels turned as planned: the last wheel angles are the rates × time.
        let last = trial.wheel_angles.last().unwrap();
        for i in 0..robot.wheels() {
            let expected = plan.samples[0].wheel_rates[i] * 8.0;
            assert!((last[i] - expected).abs() < 1e-9, "{name} wheel {i}");
        }
        assert!(last[robot.wheels()..].iter().all(|&q| q == 0.0));
        let m = evaluate(&plan, &[run_of(&trial)]).unwrap().metrics;
        assert!(m.max_deviation_m < 1e-9, "{name}: {m:?}");
    }
}

#[test]
fn slip_makes_the_simulation_deviate_and_the_metrics_report_it() {
    let slip = profile(
        "[wheel_motor]\nradius_error_std = 0.01\n[floor]\nrel_std = 0.03\ncorr_time = 0.3\n",
    );
    for name in LAYOUTS {
        let robot = preset(name);
        let plan = circle_plan(&robot, TWIST, 8.0, 0.01);
        let runs: Vec<(Trial, Run)> = (0..3)
            .map(|i| {
                let t = simulate_trial(&robot, &plan, &slip, &mut omnikin_sim::trial_rng(7, i))
                    .unwrap();
                let r = run_of(&t);
                (t, r)
            })
            .collect();
        let worst = runs
            .iter()
            .map(|(t, _)| deviation(t, &plan))
            .fold(0.0, f64::max);
        assert!(
            worst > 5e-3,
            "{name}: slip moved the robot only {worst:e} m"
        );
        let runs: Vec<Run> = runs.into_iter().map(|(_, r)| r).collect();
        let m = evaluate(&plan, &runs).unwrap().metrics;
        assert_eq!(m.runs, 3);
        // The metrics measure the deviation from the planned path (not from the planned
        // position at each time), so they cannot exceed the largest position error.
        assert!(
            m.max_deviation_m > 1e-3 && m.max_deviation_m <= worst + 1e-12,
            "{name}: {} vs {worst}",
            m.max_deviation_m
        );
        assert!(m.end_point_error_m > 1e-3, "{name}: {m:?}");
    }
}

#[test]
fn radius_errors_leave_a_slip_residual_on_over_determined_layouts_only() {
    let radius = profile("[wheel_motor]\nradius_error_std = 0.02\n");
    for name in LAYOUTS {
        let robot = preset(name);
        let plan = circle_plan(&robot, TWIST, 2.0, 0.01);
        let trial =
            simulate_trial(&robot, &plan, &radius, &mut ChaCha8Rng::seed_from_u64(5)).unwrap();
        let slip = trial.slip_residual.iter().fold(0.0f64, |m, r| m.max(*r));
        if robot.motors() > 3 {
            assert!(slip > 1e-4, "{name}: slip residual {slip:e} m/s");
        } else {
            assert!(slip < 1e-12, "{name}: three wheels fit exactly, {slip:e}");
        }
    }
}

/// Odometry from a simulated encoder log (exact angles).
fn odometry(robot: Robot<f64>, trial: &Trial) -> Vec<Pose2<f64>> {
    let sensors = emit(
        &robot,
        trial,
        &SensorProfile::default(),
        &mut ChaCha8Rng::seed_from_u64(2),
    );
    let mut odo = Odometry::new(robot, trial.pose[0]);
    sensors
        .encoder
        .iter()
        .map(|r| {
            let reading =
                EncoderReading::with_steer(r.t, r.q, r.steer.unwrap_or([0.0; omnikin::MAX_WHEELS]));
            odo.update(&reading, HeadingInput::Wheels).unwrap().pose
        })
        .collect()
}

#[test]
fn odometry_of_the_simulated_encoder_log_recovers_the_true_pose() {
    // Motors that lag, fluctuate and run off their set-points: the robot leaves the plan, but
    // the encoders see every turn. One plant step per plan interval (zero-order hold), so each
    // interval is one constant twist, which odometry reconstructs exactly.
    let motors = profile(
        "rate = 100.0\nhold = \"zoh\"\n[wheel_motor]\nlag_time_constant = 0.05\n\
         fluctuation_abs = 0.3\nfluctuation_rel = 0.05\nfluctuation_period = 0.13\n\
         rate_bias_rel = 0.03\n",
    );
    for name in LAYOUTS {
        let robot = preset(name);
        let plan = circle_plan(&robot, TWIST, 6.0, 0.01);
        for (what, prof, moved) in [
            ("ideal", Profile::default(), false),
            ("motors", motors, true),
        ] {
            let trial =
                simulate_trial(&robot, &plan, &prof, &mut ChaCha8Rng::seed_from_u64(3)).unwrap();
            let off_plan = deviation(&trial, &plan);
            assert_eq!(
                off_plan > 1e-3,
                moved,
                "{name} {what}: {off_plan:e} m off the plan"
            );
            let poses = odometry(robot, &trial);
            assert_eq!(poses.len(), trial.pose.len());
            for (k, (p, q)) in poses.iter().zip(&trial.pose).enumerate() {
                let err = (p.x - q.x)
                    .hypot(p.y - q.y)
                    .max((p.heading - q.heading).abs());
                assert!(err < 1e-9, "{name} {what} at sample {k}: {p:?} vs {q:?}");
            }
        }
    }
}

#[test]
fn the_encoder_log_has_one_column_per_wheel_and_steer_columns_for_swerve() {
    for (name, header) in [
        ("kiwi", "t,q1,q2,q3,gyro_z"),
        ("mecanum", "t,q1,q2,q3,q4,gyro_z"),
        ("swerve4", "t,q1,q2,q3,q4,s1,s2,s3,s4,gyro_z"),
    ] {
        let robot = preset(name);
        let plan = circle_plan(&robot, TWIST, 0.1, 0.01);
        let trial = simulate_trial(
            &robot,
            &plan,
            &Profile::default(),
            &mut ChaCha8Rng::seed_from_u64(1),
        )
        .unwrap();
        let sp = SensorProfile {
            gyro: Some(Default::default()),
            ..SensorProfile::default()
        };
        let s = emit(&robot, &trial, &sp, &mut ChaCha8Rng::seed_from_u64(1));
        let mut buf = Vec::new();
        write_encoder_log(&s.encoder, &mut buf).unwrap();
        let text = String::from_utf8(buf).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some(header), "{name}");
        let cols = header.split(',').count();
        let last: Vec<f64> = lines
            .last()
            .unwrap()
            .split(',')
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(last.len(), cols, "{name}");
        // The wheel columns read the trial's wheel angles, the steer columns its steer angles.
        let k = trial.t.len() - 1;
        let n = robot.wheels();
        assert_eq!(&last[1..=n], &trial.wheel_angles[k][..n], "{name}");
        if robot.steerable() {
            assert_eq!(&last[n + 1..=2 * n], &trial.steer_angles[k][..n], "{name}");
            assert!(trial.steer_angles[k][..n].iter().any(|&g| g != 0.0));
        }
    }
}

#[test]
fn a_plan_of_another_robot_is_refused_or_reported() {
    let kiwi = preset("kiwi");
    let mecanum = preset("mecanum");
    let kiwi_plan = circle_plan(&kiwi, TWIST, 0.5, 0.01);
    let e = simulate_trial(
        &mecanum,
        &kiwi_plan,
        &Profile::default(),
        &mut ChaCha8Rng::seed_from_u64(1),
    )
    .unwrap_err();
    assert!(
        matches!(&e, SimError::Mismatch(m) if m.contains("3 wheel columns") && m.contains("4 wheels")),
        "{e}"
    );
    // Same wheel count, other geometry: simulated, but reported.
    let x_drive = preset("x-drive");
    let mecanum_plan = circle_plan(&mecanum, TWIST, 0.5, 0.01);
    let why = plan_mismatch(&x_drive, &mecanum_plan).expect("a mismatch");
    assert!(why.contains("the plan's w"), "{why}");
    // A swerve plan with its steer angles turned: the angles are what disagrees.
    let swerve = preset("swerve4");
    let mut plan = circle_plan(&swerve, TWIST, 0.5, 0.01);
    for s in &mut plan.samples {
        if let Some((g, _)) = &mut s.steer {
            g[2] += 0.3;
        }
    }
    let why = plan_mismatch(&swerve, &plan).expect("a mismatch");
    assert!(why.contains("s3") && why.contains("rad "), "{why}");
    // A swerve plan without steer columns is refused, naming them.
    let mut plan = circle_plan(&swerve, TWIST, 0.5, 0.01);
    for s in &mut plan.samples {
        s.steer = None;
    }
    let e = simulate_trial(
        &swerve,
        &plan,
        &Profile::default(),
        &mut ChaCha8Rng::seed_from_u64(1),
    )
    .unwrap_err();
    assert!(e.to_string().contains("no steer columns"), "{e}");
}

#[test]
fn a_circle_is_exact_at_any_plant_rate() {
    // Two samples 2 s apart: the plant rate alone sets the number of steps (2 to 2000).
    for name in LAYOUTS {
        let robot = preset(name);
        let plan = circle_plan(&robot, TWIST, 2.0, 2.0);
        assert_eq!(plan.samples.len(), 2);
        for rate in [1.0, 3.0, 100.0, 1000.0] {
            let trial = simulate_trial(
                &robot,
                &plan,
                &profile(&format!("rate = {rate}\n")),
                &mut ChaCha8Rng::seed_from_u64(1),
            )
            .unwrap();
            let (p, q) = (trial.pose[1], arc(TWIST, 2.0));
            let err = (p.x - q.x)
                .hypot(p.y - q.y)
                .max((p.heading - q.heading).abs());
            assert!(err < 1e-12, "{name} at {rate} Hz: {p:?} vs {q:?}");
        }
    }
}
