//! `omnikin simulate --plant dynamic --closed-loop`: the runtime on the sphere's dynamic plant
//! with the simulated camera, behind `simulate`'s command and files.

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

fn circle(dir: &Path) -> PathBuf {
    let path = dir.join("circle.csv");
    omnikin()
        .args([
            "plan",
            "circle",
            "--robot",
            "sphere-omni",
            "--radius",
            "0.2",
        ])
        .args(["--omega", "2", "--rate", "100", "--out"])
        .arg(&path)
        .assert()
        .success();
    path
}

fn metrics(out: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap()
}

/// The usual keys, computed on the truth of each trial; the camera and the fusion's counts in
/// `simulation`; the camera lost for [1, 2) s is 25 fixes fewer per trial.
#[test]
fn writes_the_usual_files_and_counts_the_fixes() {
    let dir = TestDir::new("closed-loop-cli", "files");
    let plan = circle(dir.path());
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        omnikin()
            .arg("simulate")
            .arg(&plan)
            .args([
                "--robot",
                "sphere-omni",
                "--plant",
                "dynamic",
                "--closed-loop",
            ])
            .args(["--trials", "2", "--threads", "1", "--out"])
            .arg(&out)
            .args(extra)
            .assert()
            .success()
            .stderr(predicate::str::contains("closed loop: 2 trials"));
        out
    };
    let full = run("full", &[]);
    for f in ["metrics.json", "trials.csv", "mean.csv", "figure.svg"] {
        assert!(full.join(f).is_file(), "{f}");
    }
    let m = metrics(&full);
    for key in [
        "max_deviation_pct_of_path",
        "radius_ratio",
        "rms_deviation_m",
    ] {
        assert!(m[key].as_f64().is_some_and(f64::is_finite), "{key}: {m}");
    }
    let s = &m["simulation"];
    assert_eq!(s["closed_loop"], true);
    assert_eq!(s["camera"]["rate_hz"], 25.0);
    let sent = s["fixes_sent"].as_u64().unwrap();
    // 3.14 s of 25 frames/s, twice, less the ones in flight at the end.
    assert!((150..=160).contains(&sent), "{sent}");
    let gap = run("gap", &["--camera-outage", "1,2"]);
    assert_eq!(
        sent - metrics(&gap)["simulation"]["fixes_sent"].as_u64().unwrap(),
        50
    );
    let blind = run("blind", &["--no-camera"]);
    let b = metrics(&blind);
    assert_eq!(b["simulation"]["camera"], Value::Null);
    assert_eq!(b["simulation"]["fixes_sent"], 0);
    // The tilt feedback is on by default, designed for ζ = 1/√2 from the robot file; the
    // 0.4 m/s circle then lands within 3 % of its radius, and without it ≥ 10 % too large.
    let t = &s["tilt_feedback"];
    assert!(
        (t["damping_ratio"].as_f64().unwrap() - 0.5f64.sqrt()).abs() < 1e-12,
        "{t}"
    );
    assert!(t["gain_per_s"].as_f64().is_some_and(|g| g > 0.0), "{t}");
    let ratio = m["radius_ratio"].as_f64().unwrap();
    assert!((ratio - 1.0).abs() < 0.03, "{ratio}");
    let level = metrics(&run("level", &["--no-tilt-feedback"]));
    assert_eq!(level["simulation"]["tilt_feedback"], Value::Null);
    assert!(level["radius_ratio"].as_f64().unwrap() > 1.1, "{level}");
    let two = metrics(&run("markers", &["--camera-heading-noise", "0.01"]));
    assert_eq!(two["simulation"]["camera"]["heading_noise_std_rad"], 0.01);
}

/// Misplaced or bad options name the flag and the rule.
#[test]
fn bad_options_name_the_flag() {
    let dir = TestDir::new("closed-loop-cli", "bad");
    let plan = circle(dir.path());
    let out = dir.path().join("out");
    let sim = |extra: &[&str]| {
        let mut c = omnikin();
        c.arg("simulate")
            .arg(&plan)
            .args(["--robot", "sphere-omni", "--out"])
            .arg(&out)
            .args(extra);
        c
    };
    sim(&["--closed-loop"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "--closed-loop needs --plant dynamic",
        ));
    sim(&[
        "--plant",
        "dynamic",
        "--closed-loop",
        "--camera-dropout",
        "1.5",
    ])
    .assert()
    .failure()
    .stderr(predicate::str::contains("camera_gaps.dropout_probability"));
    sim(&[
        "--plant",
        "dynamic",
        "--closed-loop",
        "--camera-outage",
        "3,1",
    ])
    .assert()
    .failure()
    .stderr(predicate::str::contains("camera_gaps.outage"));
    sim(&["--plant", "dynamic", "--camera-noise", "0.01"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("--closed-loop"));
    sim(&[
        "--plant",
        "dynamic",
        "--closed-loop",
        "--no-camera",
        "--camera-rate",
        "10",
    ])
    .assert()
    .failure()
    .stderr(predicate::str::contains("--no-camera"));
    assert!(!out.exists());
}
