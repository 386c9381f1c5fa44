//! `omnikin drive goal --map` and `omnikin drive obstacle`, as processes: the glue of the
//! goal run (`omnikin_host::goal_run`, tested in depth by omnikin-host's `drive_goal` test)
//! with a simulated robot, and the errors of bad input.

mod common;

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{BIN, free_port};

const HALL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/maps/hall.toml");

fn obstacle(control: &str, shape: &[&str]) -> std::process::Output {
    let out = Command::new(BIN)
        .args(["drive", "--timeout", "5", "obstacle", "--control", control])
        .args(shape)
        .output()
        .unwrap();
    eprintln!(
        "drive obstacle {shape:?}: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn an_obstacle_sent_to_a_running_goal_is_spliced_around_and_the_goal_reached() {
    let addr = format!("127.0.0.1:{}", free_port());
    let control = format!("127.0.0.1:{}", free_port());
    let mut robot = Command::new(BIN)
        .args([
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            &addr,
        ])
        .args([
            "--time-scale",
            "4",
            "--max-time",
            "60",
            "--disturbances",
            "hardware",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(150));
    let mut drive = Command::new(BIN)
        .args(["drive", "--connect", &addr, "goal", "4,3", "--map", HALL])
        .args([
            "--robot",
            "sphere-omni",
            "--max-speed",
            "0.3",
            "--control",
            &control,
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(drive.stdout.take().unwrap()).lines();
    let mut seen = Vec::new();
    // The first plan is up: an obstacle on it, about 10 s of plan time ahead of its start.
    for l in lines.by_ref() {
        let l = l.unwrap();
        seen.push(l.clone());
        if l.starts_with("plan ") {
            break;
        }
    }
    let out = obstacle(&control, &["--circle", "2.1,2.1,0.15"]);
    assert!(out.status.success());
    let answer = String::from_utf8_lossy(&out.stdout);
    assert!(
        answer.contains("added; re-planned, spliced at plan time"),
        "{answer}"
    );
    seen.extend(lines.map(|l| l.unwrap()));
    let end = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(s) = drive.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < end, "drive goal did not end");
        std::thread::sleep(Duration::from_millis(20));
    };
    let _ = robot.kill();
    let _ = robot.wait();
    let all = seen.join("\n");
    eprintln!("{all}");
    assert!(status.success(), "{all}");
    assert!(
        all.contains("obstacle 1: circle at (2.1, 2.1) radius 0.15 m added"),
        "{all}"
    );
    assert!(
        all.contains("goal reached: 1 re-plan(s) spliced without stopping, 0 with a stop"),
        "{all}"
    );
}

#[test]
fn bad_input_is_an_error_naming_the_flag() {
    let control = format!("127.0.0.1:{}", free_port());
    let out = obstacle(&control, &["--circle", "1,2"]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--circle: expected X,Y,R (m), got 2 values")
    );
    let out = obstacle(&control, &["--polygon", "0,0,1,0,1"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("--polygon: expected X1,Y1,X2,Y2,X3,Y3"));
    let out = obstacle(&control, &[]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("give exactly one of --circle"));
    // Nobody listening: a bounded wait, then the error says so.
    let t0 = Instant::now();
    let out = Command::new(BIN)
        .args([
            "drive",
            "--timeout",
            "0.3",
            "obstacle",
            "--control",
            &control,
        ])
        .args(["--circle", "1,1,0.2"])
        .output()
        .unwrap();
    assert!(t0.elapsed() < Duration::from_secs(5));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("no answer from a drive goal at {control}")),
        "{err}"
    );
    // drive goal: the robot's address, the goal, the control address.
    let goal = |args: &[&str]| {
        let out = Command::new(BIN).arg("drive").args(args).output().unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let err = goal(&["goal", "4,3", "--map", HALL, "--robot", "sphere-omni"]);
    assert!(
        err.contains("--connect ADDR (the robot's address) is required"),
        "{err}"
    );
    let port = format!("127.0.0.1:{}", free_port());
    let base = ["--connect", &port, "--timeout", "0.3", "goal"];
    let err = goal(
        &[
            &base[..],
            &["1.2,0.4", "--map", HALL, "--robot", "sphere-omni"],
        ]
        .concat(),
    );
    assert!(
        err.contains("hall.toml:6: the goal (1.2, 0.4) is inside the keep_out circle"),
        "{err}"
    );
    let err = goal(&[&base[..], &["4", "--map", HALL, "--robot", "sphere-omni"]].concat());
    assert!(err.contains("goal: expected X,Y or X,Y,H"), "{err}");
    for (flag, val, says) in [
        (
            "--max-speed",
            "1e-9",
            "--max-speed 0.000000001: must be between 0.001 and 100 m/s",
        ),
        ("--max-accel", "0", "--max-accel 0: must be between"),
        (
            "--replan-tolerance",
            "0",
            "--replan-tolerance 0: must be > 0 m",
        ),
        ("--margin", "-1", "--margin -1: must be between 0 and 10 m"),
        (
            "--footprint-radius",
            "0",
            "--footprint-radius 0: must be > 0",
        ),
    ] {
        let err = goal(
            &[
                &base[..],
                &["4,3", "--map", HALL, "--robot", "sphere-omni", flag, val],
            ]
            .concat(),
        );
        assert!(err.contains(says), "{flag} {val}: {err}");
    }
    let err = goal(
        &[
            &base[..],
            &[
                "4,3",
                "--map",
                HALL,
                "--robot",
                "sphere-omni",
                "--control",
                "10.1.2.3:7480",
            ],
        ]
        .concat(),
    );
    assert!(
        err.contains("--control 10.1.2.3:7480: obstacles are not authenticated"),
        "{err}"
    );
}
