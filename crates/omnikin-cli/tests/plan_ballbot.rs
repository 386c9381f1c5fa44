//! A ballbot's plans stay within the acceleration its lean limit allows (robot file
//! `[dynamics] max_tilt_deg` less `lean_margin`), and the plan report says so.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::Path;

use assert_cmd::Command;
use predicates::prelude::*;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

fn tmp(name: &str) -> TestDir {
    TestDir::new("plan-lean", name)
}

/// Largest change of the world velocity between samples, m/s².
fn peak_accel(path: &Path) -> f64 {
    let p = omnikin_plan::Plan::load_csv(path).unwrap();
    p.samples
        .windows(2)
        .map(|w| {
            let dt = w[1].t - w[0].t;
            ((w[1].twist.vx - w[0].twist.vx) / dt).hypot((w[1].twist.vy - w[0].twist.vy) / dt)
        })
        .fold(0.0, f64::max)
}

fn square(robot: &str, out: &Path, extra: &[&str]) -> assert_cmd::assert::Assert {
    omnikin()
        .args([
            "plan", "square", "--robot", robot, "--side", "0.4", "--speed", "0.2", "--out",
        ])
        .arg(out)
        .args(extra)
        .assert()
}

#[test]
fn the_ballbot_square_is_slowed_to_its_lean_limit_and_says_so() {
    let d = tmp("square");
    let limit = omnikin::description::RobotDescription::preset("ballbot")
        .unwrap()
        .lean_acceleration_limit()
        .unwrap()
        .0;
    // Default ramps (5 % of a 2 s leg): 2 m/s² asked, lowered to the lean limit.
    let fast = d.join("fast.csv");
    square("ballbot", &fast, &[])
        .success()
        .stderr(predicate::str::contains("lean limit: body acceleration ≤"))
        .stderr(predicate::str::contains(
            "the request's 2.000 m/s² lowered to it",
        ));
    let a = peak_accel(&fast);
    assert!(a <= limit * 1.001 && a > 0.9 * limit, "{a} vs {limit}");
    // Quarter ramps: 0.4 m/s², within the limit, unchanged.
    let slow = d.join("slow.csv");
    square("ballbot", &slow, &["--ramp-fraction", "0.25"])
        .success()
        .stderr(
            predicate::str::contains("lean limit").and(predicate::str::contains("lowered").not()),
        );
    assert!((peak_accel(&slow) - 0.4).abs() < 1e-6);
    // Other kinds have no lean limit: the same request keeps its 2 m/s².
    let kiwi = d.join("kiwi.csv");
    square("kiwi", &kiwi, &[])
        .success()
        .stderr(predicate::str::contains("lean limit").not());
    assert!((peak_accel(&kiwi) - 2.0).abs() < 1e-6);
}

#[test]
fn a_smaller_lean_limit_in_the_robot_file_gives_a_gentler_plan() {
    let d = tmp("file");
    let text = omnikin::description::PRESETS
        .iter()
        .find(|(n, _)| *n == "ballbot")
        .unwrap()
        .1
        .replace("max_tilt_deg = 10.0", "max_tilt_deg = 3.0");
    let robot = d.join("careful.toml");
    std::fs::write(&robot, text).unwrap();
    let (ten, three) = (d.join("ten.csv"), d.join("three.csv"));
    square("ballbot", &ten, &[]).success();
    square(robot.to_str().unwrap(), &three, &[])
        .success()
        .stderr(predicate::str::contains("max_tilt_deg 3°"));
    let (a10, a3) = (peak_accel(&ten), peak_accel(&three));
    assert!(a3 < 0.35 * a10 && a3 > 0.25 * a10, "{a3} vs {a10}");
}
