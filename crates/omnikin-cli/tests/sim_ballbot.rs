//! `omnikin simulate --robot ballbot --plant dynamic`: the balance controller on the 3D model
//! follows a plan, settles from a lean, survives a push and reports a fall.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use predicates::prelude::*;
use serde_json::Value;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

fn tmp(name: &str) -> TestDir {
    TestDir::new("ballbot-cli", name)
}

/// `plan square --robot ballbot --side 0.4 --speed 0.2 --ramp-fraction 0.25`.
fn square(dir: &Path) -> PathBuf {
    let path = dir.join("square.csv");
    omnikin()
        .args([
            "plan",
            "square",
            "--robot",
            "ballbot",
            "--side",
            "0.4",
            "--speed",
            "0.2",
            "--ramp-fraction",
            "0.25",
            "--out",
        ])
        .arg(&path)
        .assert()
        .success();
    path
}

fn metrics(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("metrics.json")).unwrap()).unwrap()
}

fn simulate(plan: &Path, out: &Path, extra: &[&str]) -> assert_cmd::assert::Assert {
    omnikin()
        .arg("simulate")
        .arg(plan)
        .args(["--robot", "ballbot", "--plant", "dynamic", "--out"])
        .arg(out)
        .args(extra)
        .assert()
}

#[test]
fn the_square_is_followed_within_5_cm_and_8_degrees() {
    let d = tmp("square");
    let plan = square(&d);
    let out = d.join("out");
    simulate(&plan, &out, &[])
        .success()
        .stderr(predicate::str::contains("balancing: max tilt"));
    for f in ["metrics.json", "trials.csv", "mean.csv", "figure.svg"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let m = metrics(&out);
    let dev = m["max_deviation_m"].as_f64().unwrap();
    let tilt = m["max_tilt_deg"].as_f64().unwrap();
    let fin = m["final_tilt_deg"].as_f64().unwrap();
    eprintln!("square: max deviation {dev} m, max tilt {tilt}°, final tilt {fin}°");
    assert!(dev < 0.05, "{dev}");
    assert!(
        tilt < 8.0 && tilt > 0.5,
        "{tilt}: a square at 0.4 m/s² leans"
    );
    assert!(fin < 0.5, "{fin}");
    assert_eq!(m["fallen"], Value::Bool(false));
    // The figure shows the tilt.
    let svg = std::fs::read_to_string(out.join("figure.svg")).unwrap();
    assert!(svg.contains("tilt"));
    // Another seed, other noise, other numbers.
    let out2 = d.join("out2");
    simulate(&plan, &out2, &["--seed", "7"]).success();
    assert_ne!(metrics(&out2)["max_tilt_deg"], m["max_tilt_deg"]);
}

#[test]
fn an_initial_lean_is_caught_and_a_push_survived_or_reported_as_a_fall() {
    let d = tmp("push");
    let plan = square(&d);
    let lean = d.join("lean");
    simulate(&plan, &lean, &["--initial-tilt-deg", "5"]).success();
    let m = metrics(&lean);
    let tilt = m["max_tilt_deg"].as_f64().unwrap();
    assert!((tilt - 5.0).abs() < 0.2, "starts at 5°: {tilt}");
    assert!(m["final_tilt_deg"].as_f64().unwrap() < 0.5);
    assert_eq!(
        m["simulation"]["initial_tilt_deg"]
            .as_f64()
            .unwrap()
            .round(),
        5.0
    );

    let small = d.join("small");
    simulate(&plan, &small, &["--push", "12@2.0"])
        .success()
        .stderr(predicate::str::contains("FALLEN").not());
    let m = metrics(&small);
    assert_eq!(m["fallen"], Value::Bool(false));
    assert!(
        m["max_tilt_deg"].as_f64().unwrap() > 5.0,
        "the push leans it"
    );
    assert!(
        m["final_tilt_deg"].as_f64().unwrap() < 0.5,
        "and it recovers"
    );

    let big = d.join("big");
    simulate(&plan, &big, &["--push", "25@2.0@90"])
        .success()
        .stderr(predicate::str::contains("FALLEN at t = "));
    let m = metrics(&big);
    assert_eq!(m["fallen"], Value::Bool(true));
    let t = m["fall_time_s"].as_f64().unwrap();
    assert!(t > 2.0 && t < 3.0, "{t}");
    assert!(m["max_tilt_deg"].as_f64().unwrap() > 20.0);
}

#[test]
fn bad_push_and_tilt_values_and_other_robots_are_refused() {
    let d = tmp("bad");
    let plan = square(&d);
    for bad in ["12", "12@", "x@2", "-3@2", "12@-1", "12@2@nan", "12@2@3@4"] {
        simulate(&plan, &d.join("o"), &["--push", bad])
            .failure()
            .stderr(predicate::str::contains("--push"));
    }
    simulate(&plan, &d.join("o"), &["--initial-tilt-deg", "75"])
        .failure()
        .stderr(predicate::str::contains("--initial-tilt-deg"));
    simulate(&plan, &d.join("o"), &["--push", "12@100"])
        .failure()
        .stderr(predicate::str::contains("the run ends"));
    omnikin()
        .arg("simulate")
        .arg(&plan)
        .args(["--robot", "ballbot", "--push", "12@2", "--out"])
        .arg(d.join("k"))
        .assert()
        .failure()
        .stderr(predicate::str::contains("--plant dynamic"));
}
