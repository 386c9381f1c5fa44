//! Values in the other unit are said, not silently used: radians typed into a robot file's
//! `_deg` keys, a 2 m wheel on a 0.15 m base, waypoint headings in degrees. Each run still
//! succeeds (an odd robot may be meant); stderr names the key or line and the unit read.

use std::path::PathBuf;

use assert_cmd::Command;
use predicates::prelude::*;

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("unit-guards-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

/// The kiwi preset's file with its drive angles in radians, and a wheel radius.
fn kiwi(dir: &std::path::Path, name: &str, radians: bool, radius: &str) -> PathBuf {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut s = std::fs::read_to_string(root.join("robots/kiwi.toml")).unwrap();
    if radians {
        for (deg, rad) in [("90.0", "1.5708"), ("210.0", "3.6652"), ("330.0", "5.7596")] {
            s = s.replace(
                &format!("drive_angle_deg = {deg}"),
                &format!("drive_angle_deg = {rad}"),
            );
        }
    }
    s = s.replace("radius = 0.05", &format!("radius = {radius}"));
    let p = dir.join(name);
    std::fs::write(&p, s).unwrap();
    p
}

#[test]
fn check_names_radians_in_deg_keys_and_impossible_proportions() {
    let d = tmp("check");
    let rad = kiwi(&d, "rad.toml", true, "0.05");
    omnikin()
        .args(["check", rad.to_str().unwrap()])
        .assert()
        .success()
        .stderr(predicate::str::contains(
            "geometry.wheels[0].drive_angle_deg = 1.5708 is read in degrees",
        ))
        .stdout(predicate::str::contains("valid, with 1 warning (above)"));
    let big = kiwi(&d, "big.toml", false, "2.0");
    omnikin()
        .args(["check", big.to_str().unwrap()])
        .assert()
        .success()
        .stderr(predicate::str::contains(
            "geometry.wheels[0].radius 2 m is larger than the wheel's distance from the centre",
        ))
        .stdout(predicate::str::contains("with 3 warnings"));
    // The same warnings wherever the robot is read (plan here), and none for the preset.
    omnikin()
        .args(["plan", "square", "--robot", rad.to_str().unwrap()])
        .assert()
        .success()
        .stderr(predicate::str::contains("is read in degrees"));
    omnikin()
        .args(["check", "kiwi"])
        .assert()
        .success()
        .stderr(predicate::str::contains("warning").not());
}

#[test]
fn waypoint_headings_beyond_a_turn_are_named_with_their_line() {
    let d = tmp("waypoints");
    let wp = d.join("wp.csv");
    std::fs::write(&wp, "x,y,heading\n0,0,0\n1,0,90\n2,0,90\n").unwrap();
    omnikin()
        .args(["plan", "waypoints", wp.to_str().unwrap(), "--robot", "kiwi"])
        .assert()
        .success()
        .stderr(predicate::str::contains(
            "wp.csv:3: heading 90 is read in radians (5156.6°, 14.3 turns)",
        ))
        .stderr(predicate::str::contains("write 1.5708"));
    std::fs::write(&wp, "x,y,heading\n0,0,0\n1,0,1.5708\n2,0,3.1416\n").unwrap();
    omnikin()
        .args(["plan", "waypoints", wp.to_str().unwrap(), "--robot", "kiwi"])
        .assert()
        .success()
        .stderr(predicate::str::contains("warning").not());
}

#[test]
fn an_initial_pose_heading_in_degrees_is_named() {
    let d = tmp("initial-pose");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let log = root.join("examples/logs/kiwi-encoders.csv");
    let out = d.join("poses.csv");
    omnikin()
        .args(["odometry", log.to_str().unwrap(), "--robot", "kiwi"])
        .args(["--initial-pose", "0,0,90", "--out", out.to_str().unwrap()])
        .assert()
        .success()
        .stderr(predicate::str::contains(
            "--initial-pose: heading 90 is read in radians (5156.6°); if 90° was meant, write 1.5708",
        ));
}
