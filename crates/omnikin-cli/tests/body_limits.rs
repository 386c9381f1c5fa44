//! One set of body limits from the robot file to the robot: `omnikin robot` slews at the
//! robot file's limits (derived from the wheel limits when the file gives none) and refuses a
//! flag above them, `plan` refuses a request above them and warns about a plan that asks for
//! more, `drive plan` refuses such a plan before uploading it (the robot's limits come with
//! its handshake; `--robot` adds the file's, the stricter applies), and the README tour's
//! square is tracked on the ideal plant.

use std::path::PathBuf;

use common::{BIN, Robot};

mod common;

fn tmp(name: &str) -> common::test_dir::TestDir {
    common::tmp("body_limits", name)
}

fn run(args: &[&str]) -> std::process::Output {
    std::process::Command::new(BIN).args(args).output().unwrap()
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The README tour's plan: `plan square --robot sphere-omni --side 0.4 --speed 0.2` (2 m/s²
/// ramps).
fn tour_plan() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/plans/square-sphere-omni.csv")
}

/// The kiwi preset with `[limits] max_accel = 0.5` (m/s²).
fn slow_kiwi(dir: &std::path::Path) -> PathBuf {
    let text = omnikin::description::PRESETS
        .iter()
        .find(|(n, _)| *n == "kiwi")
        .unwrap()
        .1
        .replace(
            "max_wheel_accel = 200.0",
            "max_wheel_accel = 200.0\nmax_accel = 0.5",
        );
    assert!(text.contains("max_accel = 0.5"));
    let p = dir.join("slow-kiwi.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn robot_refuses_an_acceleration_flag_above_the_robot_file() {
    // kiwi: max_wheel_accel 200 rad/s² on 0.05 m wheels → 10 m/s² in its worst direction.
    let o = run(&[
        "robot",
        "--sim",
        "--robot",
        "kiwi",
        "--listen",
        "127.0.0.1:0",
        "--max-accel",
        "20",
        "--max-time",
        "0.1",
    ]);
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(
        e.contains("--max-accel 20: robot kiwi: above what the robot will do, 10 m/s²"),
        "{e}"
    );
    assert!(e.contains("limits.max_wheel_accel"), "{e}");
    // A lower value is a choice the operator may make.
    let o = run(&[
        "robot",
        "--sim",
        "--robot",
        "kiwi",
        "--listen",
        "127.0.0.1:0",
        "--max-accel",
        "5",
        "--max-time",
        "0.1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn plan_refuses_a_request_above_the_limit_and_warns_about_a_plan_beyond_it() {
    let dir = tmp("plan");
    let wp = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/waypoints.csv");
    let out = dir.path().join("w.csv");
    let o = run(&[
        "plan",
        "waypoints",
        wp.to_str().unwrap(),
        "--robot",
        "kiwi",
        "--max-accel",
        "20",
        "--out",
        out.to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(
        e.contains("--max-accel 20: robot kiwi: above what the robot will do"),
        "{e}"
    );
    // A square with 2 m/s² ramps on a robot that does 0.5 m/s²: written, with a warning.
    let kiwi = slow_kiwi(dir.path());
    let out = dir.path().join("sq.csv");
    let o = run(&[
        "plan",
        "square",
        "--robot",
        kiwi.to_str().unwrap(),
        "--speed",
        "0.2",
        "--out",
        out.to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains("warning: the plan asks 2 m/s² of acceleration")
            && e.contains("more than the robot's 0.5 m/s² (the robot file's limits.max_accel)"),
        "{e}"
    );
}

#[test]
fn drive_refuses_to_upload_a_plan_beyond_the_robots_limits() {
    let dir = tmp("drive");
    let kiwi = slow_kiwi(dir.path());
    let robot = Robot::start_robot(kiwi.to_str().unwrap(), &["--max-time", "30"]);
    let plan = dir.path().join("sq.csv");
    let o = run(&[
        "plan",
        "square",
        "--robot",
        "kiwi",
        "--speed",
        "0.2",
        "--out",
        plan.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = common::drive(
        &robot.addr,
        "3",
        &[
            "plan",
            plan.to_str().unwrap(),
            "--set-pose",
            "--robot",
            kiwi.to_str().unwrap(),
        ],
    );
    let e = stderr(&o);
    assert!(!o.status.success(), "{e}");
    assert!(
        e.contains("not uploaded: the plan asks 2 m/s² of acceleration")
            && e.contains("more than the robot's 0.5 m/s²"),
        "{e}"
    );
    assert!(!String::from_utf8_lossy(&o.stdout).contains("uploaded plan"));
}

/// Without `--robot` the robot's handshake names its limits; with a `--robot` file whose limits
/// are looser (the kiwi preset's, derived from its wheels), the robot's stricter 0.5 m/s² still
/// applies.
#[test]
fn drive_refuses_a_plan_beyond_the_limits_the_robot_tells_at_the_handshake() {
    let dir = tmp("drive_told");
    let kiwi = slow_kiwi(dir.path());
    let robot = Robot::start_robot(kiwi.to_str().unwrap(), &["--max-time", "30"]);
    let o = common::drive(&robot.addr, "3", &["hello"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("robot: body limits: acceleration 0.5 m/s², yaw acceleration ")
            && out.contains(", jerk unlimited"),
        "{out}"
    );
    let plan = dir.path().join("sq.csv");
    let o = run(&[
        "plan",
        "square",
        "--robot",
        "kiwi",
        "--speed",
        "0.2",
        "--out",
        plan.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for extra in [&[][..], &["--robot", "kiwi"][..]] {
        let mut args = vec!["plan", plan.to_str().unwrap(), "--set-pose"];
        args.extend_from_slice(extra);
        let o = common::drive(&robot.addr, "3", &args);
        let e = stderr(&o);
        assert!(!o.status.success(), "{extra:?}: {e}");
        assert!(
            e.contains("not uploaded: the plan asks 2 m/s² of acceleration")
                && e.contains(
                    "more than the robot's 0.5 m/s² (what the robot's runtime enforces, from its handshake)"
                ),
            "{extra:?}: {e}"
        );
        assert!(!String::from_utf8_lossy(&o.stdout).contains("uploaded plan"));
    }
}

/// `simulate` warns, as `plan` does, about a plan that asks more than the robot file allows:
/// a motor limit (the wheel rate) and a body limit (the acceleration), each named with the
/// plan's peak and its time; a plan within the limits gets no warning.
#[test]
fn simulate_warns_about_a_plan_beyond_the_robot_files_limits() {
    let dir = tmp("simulate");
    let plan = dir.path().join("sq.csv");
    let o = run(&[
        "plan",
        "square",
        "--robot",
        "kiwi",
        "--speed",
        "0.2",
        "--out",
        plan.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let kiwi = slow_kiwi(dir.path());
    let text = std::fs::read_to_string(&kiwi)
        .unwrap()
        .replace("max_wheel_rate = 40.0", "max_wheel_rate = 3.0");
    assert!(text.contains("max_wheel_rate = 3.0"), "{text}");
    std::fs::write(&kiwi, text).unwrap();
    for (robot, warned) in [(kiwi.to_str().unwrap(), true), ("kiwi", false)] {
        let out = dir.path().join(format!("sim-{warned}"));
        let o = run(&[
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            robot,
            "--trials",
            "1",
            "--out",
            out.to_str().unwrap(),
        ]);
        let e = stderr(&o);
        assert!(o.status.success(), "{e}");
        assert_eq!(e.contains("warning:"), warned, "{e}");
        if warned {
            assert!(
                e.contains("the plan asks 4 rad/s of wheel rate 1 at t = 0.10 s, more than the robot's 3 rad/s (the robot file's limits.max_wheel_rate)"),
                "{e}"
            );
            assert!(
                e.contains("the plan asks 2 m/s² of acceleration at t = ")
                    && e.contains(
                        "more than the robot's 0.5 m/s² (the robot file's limits.max_accel)"
                    ),
                "{e}"
            );
        }
    }
}

/// The README tour's drive on the ideal plant: the runtime slews at the sphere's own limit
/// (22.9 m/s² from its wheels), not the 1 m/s² it used to default to (0.0198 m of error).
#[test]
fn the_tour_square_is_tracked_within_5_mm() {
    let robot = Robot::start(&["--max-time", "60"]);
    let plan = tour_plan();
    let o = common::drive(
        &robot.addr,
        "5",
        &[
            "plan",
            plan.to_str().unwrap(),
            "--set-pose",
            "--robot",
            "sphere-omni",
        ],
    );
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{out}{}", stderr(&o));
    assert!(
        out.contains("plan within sphere-omni's body limits"),
        "{out}"
    );
    let err: f64 = out
        .split("max |pose - reference| ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no tracking error in {out}"));
    assert!(err < 0.005, "tracking error {err} m: {out}");
}
