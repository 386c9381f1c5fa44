//! `omnikin evaluate --truth`: the docs' odometry example scored against its ground truth
//! (the figures worked out by hand in docs/odometry.md: fused RMS 5.0 mm, wheels alone
//! 10.0 mm), the JSON's per-run and pooled figures, and the refusals.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use predicates::prelude::*;

fn omnikin() -> Command {
    let mut c = Command::cargo_bin("omnikin").unwrap();
    c.current_dir(examples());
    c
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// The docs' odometry example: the fused estimate and the wheels alone, written to `dir`.
fn odometry(dir: &Path) -> (PathBuf, PathBuf) {
    let (fused, wheels) = (dir.join("fused.csv"), dir.join("wheels.csv"));
    let base = [
        "odometry",
        "--robot",
        "kiwi",
        "logs/kiwi-encoders.csv",
        "--initial-pose",
        "0,0,0",
    ];
    omnikin()
        .args(base)
        .args(["--fixes", "logs/kiwi-fixes.csv", "--out"])
        .arg(&fused)
        .assert()
        .success();
    omnikin()
        .args(base)
        .arg("--out")
        .arg(&wheels)
        .assert()
        .success();
    (fused, wheels)
}

#[test]
fn the_odometry_example_scores_5_mm_fused_and_10_mm_for_the_wheels() {
    let dir = TestDir::new("evaluate_truth", "example");
    let (fused, wheels) = odometry(dir.path());
    let out = omnikin()
        .args(["evaluate", "--truth", "logs/kiwi-truth.csv"])
        .arg(&fused)
        .arg(&wheels)
        .assert()
        .success();
    let text = String::from_utf8_lossy(&out.get_output().stdout).to_string();
    assert!(text.contains("alignment none"), "{text}");
    assert!(
        text.contains("fused.csv: 841 samples; ATE rms 5.0, "),
        "{text}"
    );
    assert!(
        text.contains("wheels.csv: 841 samples; ATE rms 10.0, "),
        "{text}"
    );
    assert!(text.contains("overall (2 runs): 1682 samples"), "{text}");

    let out = omnikin()
        .args(["evaluate", "--json", "--truth", "logs/kiwi-truth.csv"])
        .arg(&fused)
        .arg(&wheels)
        .assert()
        .success();
    let j: serde_json::Value = serde_json::from_slice(&out.get_output().stdout).unwrap();
    let rms = |v: &serde_json::Value| v["ate_m"]["rms"].as_f64().unwrap();
    let (a, b) = (rms(&j["runs"][0]), rms(&j["runs"][1]));
    assert!((a - 0.0050).abs() < 0.00005, "fused ATE {a}");
    assert!((b - 0.0100).abs() < 0.00005, "wheels ATE {b}");
    // Pooled: every sample counts once, so the overall RMS is the RMS of the two.
    let all = rms(&j["overall"]);
    assert!(
        (all - ((a * a + b * b) / 2.0).sqrt()).abs() < 1e-12,
        "{all}"
    );
    assert_eq!(j["runs"][0]["rpe_translation_m"]["count"], 741);
    assert_eq!(j["alignment"], "none");
    // SE(2) alignment can only lower the error it minimises.
    let out = omnikin()
        .args([
            "evaluate",
            "--json",
            "--align",
            "se2",
            "--truth",
            "logs/kiwi-truth.csv",
        ])
        .arg(&fused)
        .assert()
        .success();
    let j: serde_json::Value = serde_json::from_slice(&out.get_output().stdout).unwrap();
    assert!(rms(&j["runs"][0]) < a);
}

#[test]
fn estimates_off_the_truths_clock_and_bad_steps_are_refused_by_name() {
    let dir = TestDir::new("evaluate_truth", "refusals");
    let late = dir.path().join("late.csv");
    std::fs::write(&late, "t,x,y,heading\n100,0,0,0\n101,0,0,0\n").unwrap();
    omnikin()
        .args(["evaluate", "--truth", "logs/kiwi-truth.csv"])
        .arg(&late)
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "late.csv against logs/kiwi-truth.csv",
        ))
        .stderr(predicate::str::contains("do not overlap"));
    let (fused, _) = odometry(dir.path());
    omnikin()
        .args([
            "evaluate",
            "--truth",
            "logs/kiwi-truth.csv",
            "--rpe-time",
            "0",
        ])
        .arg(&fused)
        .assert()
        .failure()
        .stderr(predicate::str::contains("--rpe-time must be > 0"));
    // Plan-mode flags make no sense with --truth.
    omnikin()
        .args(["evaluate", "--truth", "logs/kiwi-truth.csv", "--out", "x"])
        .arg(&fused)
        .assert()
        .failure()
        .stderr(predicate::str::contains("cannot be used with"));
}

/// Without a reference the message names both ways to give one; both at once are refused.
#[test]
fn evaluate_names_both_references_when_neither_is_given() {
    let out = omnikin().args(["evaluate", "run.csv"]).output().unwrap();
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("--plan") && e.contains("--truth"), "{e}");
    omnikin()
        .args([
            "evaluate",
            "--plan",
            "plans/square-sphere-omni.csv",
            "--truth",
            "logs/kiwi-truth.csv",
            "run.csv",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("cannot be used with"));
}
