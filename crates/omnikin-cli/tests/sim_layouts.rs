//! `omnikin simulate`, `evaluate` and `odometry` for the common layouts (mecanum, swerve4,
//! kiwi) on plan files: the round trip plan → simulated runs and encoder logs → metrics and
//! odometry, and errors that name the columns a robot needs. The plans are written from the
//! robots' own inverse kinematics (the planner is tested on its own).

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use omnikin::description::RobotDescription;
use omnikin::{Actuators, Pose2, Robot, Twist2};
use omnikin_plan::{Plan, Sample};
use predicates::prelude::*;
use serde_json::Value;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

fn tmp(name: &str) -> TestDir {
    TestDir::new("sim-layouts", name)
}

fn preset(name: &str) -> Robot<f64> {
    RobotDescription::preset(name).unwrap().build().unwrap()
}

/// A circle of the robot-frame twist (0.3, 0.1, 0.6) for 6 s at 50 Hz, with the robot's
/// inverse kinematics in the motor columns, written as a plan CSV.
fn circle_plan(dir: &Path, name: &str) -> PathBuf {
    let robot = preset(name);
    let n = robot.wheels();
    let tw = Twist2::new(0.3, 0.1, 0.6);
    let a = robot.inverse(tw, &Actuators::zero()).unwrap();
    let samples = (0..=300)
        .map(|k| {
            let t = k as f64 / 50.0;
            // The pose on the arc, in closed form (rotation about the instantaneous centre).
            let th = tw.yaw_rate * t;
            let c = [-tw.vy / tw.yaw_rate, tw.vx / tw.yaw_rate];
            let (s, co) = th.sin_cos();
            let pose = Pose2::new(
                c[0] - (co * c[0] - s * c[1]),
                c[1] - (s * c[0] + co * c[1]),
                th,
            );
            let steer = robot
                .steerable()
                .then_some((&a.steer_angles[..n], &a.steer_rates[..n]));
            Sample::new(t, pose, tw.to_world(th), &a.wheel_rates[..n], steer)
        })
        .collect();
    let path = dir.join(format!("{name}-circle.csv"));
    Plan { wheels: n, samples }.save_csv(&path).unwrap();
    path
}

fn metrics(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("metrics.json")).unwrap()).unwrap()
}

/// Rows of a `t,x,y,heading` CSV.
fn poses(path: &Path) -> Vec<[f64; 4]> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,x,y,heading"), "{}", path.display());
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect()
}

fn simulate(plan: &Path, robot: &str, out: &Path, extra: &[&str]) -> String {
    let o = omnikin()
        .args([
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            robot,
            "--out",
            out.to_str().unwrap(),
        ])
        .args(extra)
        .assert()
        .success();
    String::from_utf8(o.get_output().stderr.clone()).unwrap()
}

#[test]
fn mecanum_plan_file_simulate_evaluate_and_odometry_round_trip() {
    let d = tmp("mecanum");
    let plan = circle_plan(&d, "mecanum");
    let exact = d.join("exact.toml");
    std::fs::write(&exact, "").unwrap();

    // Noise-free: the plan exactly, four encoder columns.
    let ideal = d.join("ideal");
    simulate(
        &plan,
        "mecanum",
        &ideal,
        &[
            "--trials",
            "2",
            "--emit-sensors",
            "--sensors",
            exact.to_str().unwrap(),
        ],
    );
    let m = metrics(&ideal);
    assert!(m["max_deviation_m"].as_f64().unwrap() < 1e-9, "{m}");
    assert_eq!(m["simulation"]["kind"], "omni");
    let trials = std::fs::read_to_string(ideal.join("trials.csv")).unwrap();
    assert!(
        trials.starts_with("trial,t,x,y,heading,tracked_x,tracked_y,slip_residual,q1,q2,q3,q4\n"),
        "{}",
        trials.lines().next().unwrap()
    );
    let sensors = ideal.join("sensors").join("trial-000");
    let log = std::fs::read_to_string(sensors.join("encoders.csv")).unwrap();
    assert_eq!(log.lines().next(), Some("t,q1,q2,q3,q4"));

    // Odometry of the encoder log is the true path.
    let odo = d.join("odometry.csv");
    omnikin()
        .args([
            "odometry",
            sensors.join("encoders.csv").to_str().unwrap(),
            "--robot",
            "mecanum",
            "--out",
            odo.to_str().unwrap(),
        ])
        .assert()
        .success()
        .stderr(predicate::str::contains("largest slip residual"));
    let (est, truth) = (poses(&odo), poses(&sensors.join("truth.csv")));
    assert_eq!(est.len(), 301);
    assert_eq!(est.len(), truth.len());
    for (e, t) in est.iter().zip(&truth) {
        let err = (e[1] - t[1]).hypot(e[2] - t[2]).max((e[3] - t[3]).abs());
        assert!(err < 1e-9, "{e:?} vs {t:?}");
    }

    // With slip: the runs leave the plan, and evaluate measures the same on the true path.
    let slip = d.join("slip.toml");
    std::fs::write(
        &slip,
        "[wheel_motor]\nradius_error_std = 0.01\n[floor]\nrel_std = 0.03\ncorr_time = 0.3\n",
    )
    .unwrap();
    let slipped = d.join("slipped");
    simulate(
        &plan,
        "mecanum",
        &slipped,
        &[
            "--disturbances",
            slip.to_str().unwrap(),
            "--trials",
            "1",
            "--seed",
            "4",
            "--emit-sensors",
            "--sensors",
            exact.to_str().unwrap(),
        ],
    );
    let simulated = metrics(&slipped)["max_deviation_m"].as_f64().unwrap();
    assert!(simulated > 1e-3, "slip moved the robot only {simulated} m");
    let eval = d.join("eval");
    omnikin()
        .args([
            "evaluate",
            "--plan",
            plan.to_str().unwrap(),
            slipped
                .join("sensors/trial-000/truth.csv")
                .to_str()
                .unwrap(),
            "--out",
            eval.to_str().unwrap(),
        ])
        .assert()
        .success()
        .stderr(predicate::str::contains("max deviation"));
    let evaluated = metrics(&eval)["max_deviation_m"].as_f64().unwrap();
    // The same run: evaluate's alignment to the start of motion shifts it slightly at most.
    assert!(
        (evaluated - simulated).abs() < 0.2 * simulated,
        "evaluate {evaluated} m, simulate {simulated} m"
    );
}

#[test]
fn swerve_and_kiwi_encoder_logs_round_trip_through_odometry() {
    for (name, header) in [
        ("swerve4", "t,q1,q2,q3,q4,s1,s2,s3,s4"),
        ("kiwi", "t,q1,q2,q3"),
    ] {
        let d = tmp(name);
        let plan = circle_plan(&d, name);
        let exact = d.join("exact.toml");
        std::fs::write(&exact, "").unwrap();
        let out = d.join("out");
        simulate(
            &plan,
            name,
            &out,
            &[
                "--trials",
                "1",
                "--emit-sensors",
                "--sensors",
                exact.to_str().unwrap(),
            ],
        );
        assert!(metrics(&out)["max_deviation_m"].as_f64().unwrap() < 1e-9);
        let sensors = out.join("sensors").join("trial-000");
        let log = std::fs::read_to_string(sensors.join("encoders.csv")).unwrap();
        assert_eq!(log.lines().next(), Some(header), "{name}");
        let odo = d.join("odometry.csv");
        omnikin()
            .args([
                "odometry",
                sensors.join("encoders.csv").to_str().unwrap(),
                "--robot",
                name,
                "--out",
                odo.to_str().unwrap(),
            ])
            .assert()
            .success();
        let (est, truth) = (poses(&odo), poses(&sensors.join("truth.csv")));
        let end = (est[300][1] - truth[300][1]).hypot(est[300][2] - truth[300][2]);
        assert!(end < 1e-9, "{name}: {:?} vs {:?}", est[300], truth[300]);
        // The robot went round most of a circle: the check is not of a robot at rest.
        assert!(truth[300][3] > 3.0, "{name}: {:?}", truth[300]);
    }
}

#[test]
fn errors_name_the_columns_the_robot_needs() {
    let d = tmp("errors");
    // A kiwi log (three wheels) read as a mecanum robot (four).
    let log = d.join("kiwi.csv");
    std::fs::write(&log, "t,q1,q2,q3\n0,0,0,0\n0.1,1,1,1\n").unwrap();
    let out = d.join("poses.csv");
    omnikin()
        .args([
            "odometry",
            log.to_str().unwrap(),
            "--robot",
            "mecanum",
            "--out",
        ])
        .arg(&out)
        .assert()
        .failure()
        .stderr(
            predicate::str::contains("missing column(s) q4")
                .and(predicate::str::contains("t,q1,q2,q3,q4")),
        );
    // A swerve log without its steer angles.
    let log = d.join("swerve.csv");
    std::fs::write(&log, "t,q1,q2,q3,q4\n0,0,0,0,0\n0.1,1,1,1,1\n").unwrap();
    omnikin()
        .args([
            "odometry",
            log.to_str().unwrap(),
            "--robot",
            "swerve4",
            "--out",
        ])
        .arg(&out)
        .assert()
        .failure()
        .stderr(
            predicate::str::contains("missing column(s) s1, s2, s3, s4")
                .and(predicate::str::contains("s1,s2,s3,s4")),
        );
    // A kiwi plan simulated on a mecanum robot.
    let plan = circle_plan(&d, "kiwi");
    omnikin()
        .args([
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            "mecanum",
            "--out",
        ])
        .arg(d.join("sim"))
        .assert()
        .failure()
        .stderr(
            predicate::str::contains("3 wheel columns").and(predicate::str::contains("4 wheels")),
        );
}
