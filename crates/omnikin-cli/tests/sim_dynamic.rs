//! `omnikin simulate --plant dynamic`: the sphere's shell + platform dynamics behind the same
//! command and files as the kinematic plant.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::PathBuf;

use assert_cmd::Command;
use predicates::prelude::*;
use serde_json::Value;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

fn tmp(name: &str) -> TestDir {
    TestDir::new("dyn-cli", name)
}

fn circle(dir: &std::path::Path, omega: &str) -> PathBuf {
    let path = dir.join(format!("circle-{omega}.csv"));
    omnikin()
        .args([
            "plan",
            "circle",
            "--robot",
            "sphere-omni",
            "--radius",
            "0.2",
            "--omega",
            omega,
            "--rate",
            "100",
            "--out",
        ])
        .arg(&path)
        .assert()
        .success();
    path
}

fn metrics(dir: &std::path::Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("metrics.json")).unwrap()).unwrap()
}

#[test]
fn the_dynamic_plant_writes_the_same_files_and_grows_the_fast_circle() {
    let d = tmp("circles");
    let mut ratios = Vec::new();
    for omega in ["0.5", "2"] {
        let plan = circle(&d, omega);
        let out = d.join(format!("out-{omega}"));
        omnikin()
            .args(["simulate"])
            .arg(&plan)
            .args(["--robot", "sphere-omni", "--plant", "dynamic", "--out"])
            .arg(&out)
            .assert()
            .success()
            .stderr(predicate::str::contains("dynamic plant: largest tilt"));
        for f in ["metrics.json", "trials.csv", "mean.csv", "figure.svg"] {
            assert!(out.join(f).exists(), "{f} missing");
        }
        let m = metrics(&out);
        assert_eq!(m["simulation"]["plant"], "dynamic");
        assert_eq!(m["runs"], 1);
        assert!(m["simulation"]["max_tilt_rad"].as_f64().unwrap() > 0.0);
        // Each contact event with its time: as many of each kind as the counts say, in time
        // order, inside the run (the 0.4 m/s circle's full-speed start slides the shell).
        let sim = &m["simulation"];
        let log = sim["contact_events"].as_array().unwrap();
        let count = |kind: &str| log.iter().filter(|e| e["kind"] == kind).count() as u64;
        let sum = |key: &str| -> u64 {
            sim[key]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_u64().unwrap())
                .sum()
        };
        // One entry per kind, wheel and plan step (several starts in one step: one entry).
        let floor = sim["floor_slips"].as_u64().unwrap();
        for (kind, n) in [
            ("roller_slip", sum("roller_slips")),
            ("lift_off", sum("lift_offs")),
            ("floor_slip", floor),
        ] {
            assert!(
                count(kind) <= n && (n == 0) == (count(kind) == 0),
                "{kind}: {log:?}"
            );
        }
        let end = std::f64::consts::TAU / omega.parse::<f64>().unwrap() + 0.01;
        let t: Vec<f64> = log.iter().map(|e| e["t"].as_f64().unwrap()).collect();
        assert!(t.windows(2).all(|w| w[0] <= w[1]) && t.iter().all(|&t| t > 0.0 && t < end));
        if omega == "2" {
            assert!(
                floor > 0,
                "the full-speed 0.4 m/s start slides the shell: {sim}"
            );
        }
        ratios.push(m["radius_ratio"].as_f64().unwrap());
    }
    // The kinematic plant gives 1.000 for both; the dynamics grow the fast circle much more.
    assert!(ratios[0] > 1.0 && ratios[0] < 1.05, "{ratios:?}");
    assert!(ratios[1] > ratios[0] + 0.2, "{ratios:?}");
}

#[test]
fn the_dynamic_plant_is_refused_where_it_does_not_exist() {
    let d = tmp("refused");
    let plan = circle(&d, "0.5");
    omnikin()
        .args(["simulate"])
        .arg(&plan)
        .args(["--robot", "kiwi", "--plant", "dynamic", "--out"])
        .arg(d.join("o1"))
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "only kinds sphere-omni and ballbot",
        ));
    let profile = d.join("p.toml");
    std::fs::write(&profile, "").unwrap();
    omnikin()
        .args(["simulate"])
        .arg(&plan)
        .args([
            "--robot",
            "sphere-omni",
            "--plant",
            "dynamic",
            "--disturbances",
        ])
        .arg(&profile)
        .arg("--out")
        .arg(d.join("o2"))
        .assert()
        .failure()
        .stderr(predicate::str::contains("--disturbances"));
}
