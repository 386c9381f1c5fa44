//! `omnikin simulate` and `omnikin evaluate`: outputs, determinism, and bad input.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Twist2};
use omnikin_plan::{Plan, Sample};
use predicates::prelude::*;
use serde_json::Value;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

fn tmp(name: &str) -> TestDir {
    TestDir::new("sim-cli", name)
}

/// Paper 000, eq. 6.3 at ω0 = 1 rad/s, Rt = 0.2 m, 50 Hz, written as a plan CSV.
fn circle_plan(dir: &Path) -> PathBuf {
    let m = SphereOmni::new(SphereParams::preset()).unwrap();
    let (rt, w0) = (0.2, 1.0);
    let samples = (0..=314)
        .map(|k| {
            let t = k as f64 / 50.0;
            let (s, c) = (w0 * t).sin_cos();
            let pose = Pose2::new(rt * c, rt * s, w0 * t);
            let twist = Twist2::new(-rt * w0 * s, rt * w0 * c, w0);
            Sample {
                t,
                pose,
                twist,
                wheel_rates: omnikin_plan::per_wheel(
                    &m.wheel_rates_world(twist, pose.heading, 0.0).unwrap(),
                ),
                steer: None,
            }
        })
        .collect();
    let path = dir.join("circle.csv");
    Plan { wheels: 3, samples }.save_csv(&path).unwrap();
    path
}

fn metrics(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("metrics.json")).unwrap()).unwrap()
}

#[test]
fn ideal_simulation_matches_the_plan_and_writes_everything() {
    let d = tmp("ideal");
    let plan = circle_plan(&d);
    let out = d.join("out");
    omnikin()
        .args([
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--trials",
            "3",
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .success()
        .stderr(predicate::str::contains("ratio 1.000"));
    for f in ["metrics.json", "trials.csv", "mean.csv", "figure.svg"] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let m = metrics(&out);
    assert!(m["max_deviation_m"].as_f64().unwrap() < 1e-9, "{m}");
    assert!((m["radius_ratio"].as_f64().unwrap() - 1.0).abs() < 1e-6);
    assert_eq!(m["runs"], 3);
    let svg = std::fs::read_to_string(out.join("figure.svg")).unwrap();
    assert!(svg.contains("planned (theoretical)") && svg.contains("x [m]"));
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    assert!(trials.starts_with("trial,t,x,y,heading,tracked_x,tracked_y,slip_residual,q1,q2,q3\n"));
    assert_eq!(trials.lines().count(), 1 + 3 * 315);
}

#[test]
fn same_seed_same_metrics_on_one_and_two_threads() {
    let d = tmp("seed");
    let plan = circle_plan(&d);
    let profile = d.join("noisy.toml");
    std::fs::write(&profile, "[wheel_motor]\nfluctuation_rel = 0.05\nradius_error_std = 0.01\n[tracking]\nnoise_std = 0.002\n").unwrap();
    let run = |threads: &str, seed: &str| {
        let out = d.join(format!("out-{threads}-{seed}"));
        omnikin()
            .args([
                "simulate",
                plan.to_str().unwrap(),
                "--robot",
                "sphere-omni",
                "--disturbances",
                profile.to_str().unwrap(),
                "--trials",
                "6",
                "--seed",
                seed,
                "--threads",
                threads,
                "--out",
                out.to_str().unwrap(),
            ])
            .assert()
            .success();
        let mut m = metrics(&out);
        m.as_object_mut().unwrap().remove("simulation");
        m
    };
    let (a, b) = (run("1", "5"), run("2", "5"));
    assert_eq!(a, b);
    assert!(
        a["max_deviation_m"].as_f64().unwrap() > 1e-4,
        "noise must show: {a}"
    );
    assert_ne!(a, run("2", "6"));
}

#[test]
fn bad_inputs_name_file_and_rule() {
    let d = tmp("bad");
    let plan = circle_plan(&d);
    let out = d.join("out");
    let bad_plan = d.join("bad.csv");
    std::fs::write(
        &bad_plan,
        "t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3\n0,0,0,0,0,0,0,0,0,0\n0.1,0,0,0,0,0,0,0,oops,0\n",
    )
    .unwrap();
    omnikin()
        .args([
            "simulate",
            bad_plan.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "bad.csv:3: column w2: \"oops\" is not a number",
        ));
    let profile = d.join("p.toml");
    std::fs::write(&profile, "[wheel_motor]\nmax_accel = -1\n").unwrap();
    omnikin()
        .args([
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--disturbances",
            profile.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "wheel_motor.max_accel: -1 rad/s² is outside the plausible range",
        ));
    omnikin()
        .args([
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            "caster3",
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("caster3"));
    omnikin()
        .args([
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--trials",
            "0",
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .failure()
        .code(2);
}

#[test]
fn evaluate_a_hand_made_tracked_run() {
    let d = tmp("eval");
    let plan = circle_plan(&d);
    // A camera run: started 2 s before the robot, in its own coordinates (offset by (1, 1)),
    // on a circle 10 % larger than planned.
    let mut text = String::from("t,x,y\n");
    for k in 0..=400 {
        let t = k as f64 * 0.02;
        let tm = (t - 2.0).max(0.0);
        let (s, c) = tm.sin_cos();
        text.push_str(&format!(
            "{t:.2},{:.6},{:.6}\n",
            1.0 + 0.2 + 0.22 * (c - 1.0),
            1.0 + 0.22 * s
        ));
    }
    let track = d.join("run1.csv");
    std::fs::write(&track, &text).unwrap();
    let out = d.join("eval");
    omnikin()
        .args([
            "evaluate",
            "--plan",
            plan.to_str().unwrap(),
            track.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .success();
    let m = metrics(&out);
    assert!(
        (m["radius_ratio"].as_f64().unwrap() - 1.1).abs() < 0.01,
        "{m}"
    );
    assert!(m["max_deviation_m"].as_f64().unwrap() > 0.03);
    assert!(out.join("figure.svg").exists() && out.join("runs.csv").exists());
    let bad = d.join("bad.csv");
    std::fs::write(&bad, "t,x,y\n0,0,0\n0.02,0,\n").unwrap();
    omnikin()
        .args([
            "evaluate",
            "--plan",
            plan.to_str().unwrap(),
            bad.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("bad.csv:3: column y"));
}

#[test]
fn reproduce_sphere_2019_writes_the_table_and_figures() {
    let d = tmp("repro");
    let out = d.join("r");
    let assert = omnikin()
        .args([
            "reproduce",
            "sphere-2019",
            "--trials",
            "2",
            "--dynamic-trials",
            "2",
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .success();
    let stdout = String::from_utf8_lossy(&assert.get_output().stdout).to_string();
    assert!(
        stdout.contains("| circle-0.5 |")
            && stdout.contains("What the kinematic plant explains")
            && stdout.contains("The dynamic profile")
    );
    let csv = std::fs::read_to_string(out.join("table.csv")).unwrap();
    let mut rows = csv::Reader::from_reader(csv.as_bytes());
    let header = rows.headers().unwrap().clone();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let mut n = 0;
    for r in rows.records() {
        let r = r.unwrap();
        n += 1;
        let ideal: f64 = r[col("ideal_max_deviation_pct_of_path")].parse().unwrap();
        assert!(
            ideal < 0.01,
            "ideal plant must reproduce {}: {ideal}",
            &r[0]
        );
        if &r[0] == "circle-0.4" || &r[0] == "circle-0.5" {
            let want = if &r[0] == "circle-0.4" { 1.4 } else { 1.6 };
            let got: f64 = r[col("spin_slip_radius_ratio")].parse().unwrap();
            assert!((got - want).abs() < 0.06, "{}: {got}", &r[0]);
            let hw: f64 = r[col("hardware_radius_ratio")].parse().unwrap();
            assert!((hw - 1.0).abs() < 0.03, "{}: {hw}", &r[0]);
        }
        if &r[0] == "circle-0.4" {
            // The preset's one fitted parameter was fitted here by --fit-to-paper
            // (deterministic model: 1.4; two jittered trials stay near it).
            let got: f64 = r[col("dynamic_radius_ratio")].parse().unwrap();
            assert!((got - 1.4).abs() < 0.1, "dynamic circle-0.4: {got}");
        }
        if &r[0] == "circle-0.1" {
            let got: f64 = r[col("dynamic_radius_ratio")].parse().unwrap();
            assert!((got - 1.0).abs() < 0.05, "dynamic circle-0.1: {got}");
        }
        let d: f64 = r[col("dynamic_max_deviation_from_mean_m")].parse().unwrap();
        assert!(d > 0.0, "{}: the dynamic trials must scatter", &r[0]);
    }
    assert_eq!(n, 8);
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    let fit = &j["dynamic_fitted"];
    assert_eq!(fit["name"], "com_depth");
    assert_eq!(j["dynamic_robot_file"], "preset sphere-omni");
    let h = fit["value"].as_f64().unwrap();
    assert!(h > 0.04 && h < 0.135, "{fit}");
    for s in ["square-0.5", "circle-0.5"] {
        for k in ["max_deviation_pct_of_path", "max_deviation_from_mean_m"] {
            assert!(j["series"][s]["dynamic"][k].is_f64(), "{s}.dynamic.{k}");
        }
    }
    assert!(j["series"]["circle-0.5"]["dynamic"]["radius_ratio"].is_f64());
    assert!(out.join("circle-0.5-dynamic.svg").exists());
    for s in ["square-0.1", "square-0.5", "circle-0.1", "circle-0.5"] {
        assert!(out.join(format!("{s}-hardware.svg")).exists(), "{s}");
    }
    assert!(out.join("table.md").exists() && out.join("metrics.json").exists());
}

/// The README's first command runs twice in a row: without --out, reproduce replaces its own
/// previous results in the per-user data directory; an --out of the user's is not replaced
/// without --force.
#[test]
fn reproduce_twice_replaces_its_own_default_output_only() {
    let d = tmp("repro-twice");
    let quick = [
        "reproduce",
        "sphere-2019",
        "--trials",
        "1",
        "--dynamic-trials",
        "0",
        "--profiles",
        "ideal",
    ];
    let run = || omnikin().env("XDG_DATA_HOME", &*d).args(quick).assert();
    run().success();
    let table = d.join("omnikin/reproduce-sphere-2019/table.md");
    let first = std::fs::metadata(&table).unwrap().modified().unwrap();
    run().success().stderr(predicate::str::contains(
        "replacing the previous results in",
    ));
    assert!(std::fs::metadata(&table).unwrap().modified().unwrap() >= first);
    let mine = d.join("mine");
    let with_out = || {
        omnikin()
            .args(quick)
            .args(["--out", mine.to_str().unwrap()])
            .assert()
    };
    with_out().success();
    with_out()
        .failure()
        .stderr(predicate::str::contains("not replaced without --force"));
}

#[test]
fn reproduce_profiles_selects_what_runs_without_changing_its_numbers() {
    let d = tmp("repro-profiles");
    let run = |name: &str, profiles: Option<&str>| {
        let out = d.join(name);
        let mut args = vec![
            "reproduce",
            "sphere-2019",
            "--trials",
            "2",
            "--dynamic-trials",
            "2",
            "--out",
            out.to_str().unwrap(),
        ];
        if let Some(p) = profiles {
            args.extend(["--profiles", p]);
        }
        omnikin().args(&args).assert().success();
        let csv = std::fs::read_to_string(out.join("table.csv")).unwrap();
        let mut r = csv::Reader::from_reader(csv.as_bytes());
        let header: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
        let rows: Vec<Vec<String>> = r
            .records()
            .map(|x| x.unwrap().iter().map(str::to_string).collect())
            .collect();
        let m: Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap())
                .unwrap();
        (header, rows, m)
    };
    let (header, all, _) = run("all", None);
    let (_, some, m) = run("some", Some("dynamic,hardware"));
    assert_eq!(m["profiles"], serde_json::json!(["hardware", "dynamic"]));
    assert!(m["series"]["circle-0.4"].get("ideal").is_none());
    for (a, b) in all.iter().zip(&some) {
        for (k, h) in header.iter().enumerate() {
            if h.starts_with("hardware_") || h.starts_with("dynamic_") {
                assert_eq!(a[k], b[k], "{} {h}: same seed, same number", a[0]);
            } else if h.starts_with("ideal_") || h.starts_with("spin_slip_") {
                assert_eq!(b[k], "", "{} {h}: a profile left out has no value", a[0]);
            }
        }
    }
    omnikin()
        .args([
            "reproduce",
            "sphere-2019",
            "--profiles",
            "dynamic",
            "--dynamic-trials",
            "0",
        ])
        .args(["--out", d.join("none").to_str().unwrap()])
        .assert()
        .failure()
        .stderr(predicate::str::contains("--profiles: nothing to run"));
    assert!(
        !d.join("none").exists(),
        "refused before anything is written"
    );
}

/// `--profiles dynamic,closed-loop`: the closed loop's columns beside the open loop's (same
/// trials), its own table in table.md, the fast circles within 3 % of their radius where the
/// open loop misses by ≥ 30 %; not in shards.
#[test]
fn reproduce_closed_loop_profile_sits_beside_the_open_loop() {
    let d = tmp("repro-closed");
    let out = d.join("cl");
    omnikin()
        .args([
            "reproduce",
            "sphere-2019",
            "--profiles",
            "dynamic,closed-loop",
        ])
        .args([
            "--dynamic-trials",
            "2",
            "--prior-samples",
            "0",
            "--threads",
            "1",
        ])
        .args(["--out", out.to_str().unwrap()])
        .assert()
        .success();
    let csv = std::fs::read_to_string(out.join("table.csv")).unwrap();
    let mut r = csv::Reader::from_reader(csv.as_bytes());
    let header: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (open, closed, dev) = (
        col("dynamic_radius_ratio"),
        col("closed_loop_radius_ratio"),
        col("closed_loop_max_deviation_pct_of_path"),
    );
    for rec in r.records() {
        let rec = rec.unwrap();
        let d: f64 = rec[dev].parse().unwrap();
        assert!(d < 7.0, "{}: {d} %", &rec[0]);
        if &rec[0] == "circle-0.4" || &rec[0] == "circle-0.5" {
            let (o, c): (f64, f64) = (rec[open].parse().unwrap(), rec[closed].parse().unwrap());
            assert!(o > 1.3 && (c - 1.0).abs() < 0.03, "{}: {o} / {c}", &rec[0]);
        }
    }
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(md.contains("## Closed loop"), "{md}");
    omnikin()
        .args(["reproduce", "sphere-2019", "--profiles", "closed-loop"])
        .args(["--dynamic-trials", "2", "--shard", "1/2"])
        .args(["--out", d.join("shard").to_str().unwrap()])
        .assert()
        .failure()
        .stderr(predicate::str::contains("does not run in shards"));
}

#[test]
fn evaluate_marks_the_emergency_stops_of_a_runs_mode_column() {
    let d = tmp("estop");
    let plan_path = circle_plan(&d);
    let plan = Plan::load_csv(&plan_path).unwrap();
    // The plan followed exactly, with an e-stop latched at plan time 2.5 s and cleared at 2.9 s
    // (the "run" goes on: only the marks are checked), and a second one at 4.0 s.
    let mode = |t: f64| match t {
        t if (2.5..2.9).contains(&t) || (4.0..4.2).contains(&t) => "estop",
        _ => "trajectory",
    };
    let mut text = String::from("t,x,y,mode\n");
    for s in &plan.samples {
        text.push_str(&format!(
            "{},{},{},{}\n",
            s.t,
            s.pose.x,
            s.pose.y,
            mode(s.t)
        ));
    }
    let track = d.join("run.csv");
    std::fs::write(&track, &text).unwrap();
    let plain = d.join("plain.csv");
    std::fs::write(
        &plain,
        text.lines()
            .map(|l| l.rsplit_once(',').unwrap().0.to_string() + "\n")
            .collect::<String>(),
    )
    .unwrap();
    let eval = |track: &Path, out: &str| {
        let out = d.join(out);
        omnikin()
            .args(["evaluate", "--plan"])
            .args([&plan_path, track])
            .arg("--out")
            .arg(&out)
            .assert()
            .success();
        (
            metrics(&out),
            std::fs::read_to_string(out.join("figure.svg")).unwrap(),
        )
    };
    let (m, svg) = eval(&track, "marked");
    let stops: Vec<(f64, f64, f64)> = m["evaluation"]["estops"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["t"].as_f64().unwrap(),
                s["x"].as_f64().unwrap(),
                s["y"].as_f64().unwrap(),
            )
        })
        .collect();
    assert_eq!(stops.len(), 2, "{m}");
    for (&(t, x, y), want) in stops.iter().zip([2.5, 4.0]) {
        let s = plan
            .samples
            .iter()
            .find(|s| (s.t - want).abs() < 1e-9)
            .unwrap();
        assert!((t - want).abs() < 1e-9, "{t}");
        assert!((x - s.pose.x).hypot(y - s.pose.y) < 1e-9, "({x}, {y})");
    }
    // One legend entry in the path's panel and one in each of the three time panels.
    assert_eq!(svg.matches("\ne-stop\n").count(), 4);
    // Without the mode column: no marks, nothing else changes.
    let (m0, svg0) = eval(&plain, "plain");
    assert_eq!(m0["evaluation"]["estops"].as_array().unwrap().len(), 0);
    assert_eq!(svg0.matches("e-stop").count(), 0);
    assert_eq!(m0["max_deviation_m"], m["max_deviation_m"]);
}

#[test]
fn evaluate_with_marker_offset_and_wrapped_heading() {
    let d = tmp("marker");
    let plan_path = circle_plan(&d);
    let plan = Plan::load_csv(&plan_path).unwrap();
    // A perfect run tracked by a marker 0.05 m to the robot's left, heading reported in (−π, π].
    let mut text = String::from("t,x,y,heading\n");
    for s in &plan.samples {
        let (sn, cs) = s.pose.heading.sin_cos();
        let h = omnikin::wrap_angle(s.pose.heading);
        text.push_str(&format!(
            "{},{},{},{}\n",
            s.t,
            s.pose.x - 0.05 * sn,
            s.pose.y + 0.05 * cs,
            h
        ));
    }
    let track = d.join("marker.csv");
    std::fs::write(&track, text).unwrap();
    let out = d.join("eval");
    omnikin()
        .args([
            "evaluate",
            "--plan",
            plan_path.to_str().unwrap(),
            track.to_str().unwrap(),
            "--tracking-offset",
            "0,0.05",
            "--no-align-position",
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .success();
    let m = metrics(&out);
    assert!(m["max_deviation_m"].as_f64().unwrap() < 1e-9, "{m}");
    assert!(m["max_heading_error_rad"].as_f64().unwrap() < 1e-9, "{m}");
    omnikin()
        .args([
            "evaluate",
            "--plan",
            plan_path.to_str().unwrap(),
            track.to_str().unwrap(),
            "--tracking-offset",
            "0.05",
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("two comma-separated numbers"));
}

#[test]
fn simulating_a_plan_on_the_wrong_robot_warns() {
    let d = tmp("wrong");
    let plan = circle_plan(&d);
    omnikin()
        .args([
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            "ballbot",
            "--trials",
            "1",
            "--out",
            d.join("o").to_str().unwrap(),
        ])
        .assert()
        .success()
        .stderr(
            predicate::str::contains("warning:")
                .and(predicate::str::contains("planned for another robot")),
        );
}

/// Issue 5 end to end: the simulator's sensor logs fed to `omnikin odometry` give back the
/// simulated ground truth — to encoder quantisation with encoders alone, and within the camera
/// noise when fused with the (late, noisy) camera fixes under a shell-spin disturbance.
#[test]
fn simulate_emit_sensors_then_odometry_recovers_the_truth() {
    let d = tmp("sensors");
    let plan = circle_plan(&d);
    let out = d.join("sim");
    let profile = d.join("spin.toml");
    std::fs::write(&profile, "[shell_spin]\nstd = 0.05\n").unwrap();
    omnikin()
        .args([
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--disturbances",
            profile.to_str().unwrap(),
            "--trials",
            "2",
            "--emit-sensors",
            "--out",
            out.to_str().unwrap(),
        ])
        .assert()
        .success();
    let trial = out.join("sensors").join("trial-000");
    for f in ["encoders.csv", "truth.csv", "fixes.csv"] {
        assert!(trial.join(f).exists(), "{f}");
    }
    let read = |p: &Path| -> Vec<[f64; 3]> {
        let mut r = csv::Reader::from_path(p).unwrap();
        let h = r.headers().unwrap().clone();
        let col = |n: &str| h.iter().position(|c| c == n).unwrap();
        let (x, y, th) = (col("x"), col("y"), col("heading"));
        r.records()
            .map(|rec| {
                let rec = rec.unwrap();
                [
                    rec[x].parse().unwrap(),
                    rec[y].parse().unwrap(),
                    rec[th].parse().unwrap(),
                ]
            })
            .collect()
    };
    let truth = read(&trial.join("truth.csv"));
    let start = format!("{},{},{}", truth[0][0], truth[0][1], truth[0][2]);
    let end_error = |poses: &[[f64; 3]]| {
        let (a, b) = (poses.last().unwrap(), truth.last().unwrap());
        (a[0] - b[0]).hypot(a[1] - b[1])
    };
    // Encoders alone assume no shell spin: the spin makes them drift.
    let wheels = d.join("wheels.csv");
    omnikin()
        .args([
            "odometry",
            trial.join("encoders.csv").to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--initial-pose",
            &start,
            "--out",
            wheels.to_str().unwrap(),
        ])
        .assert()
        .success();
    let drift = end_error(&read(&wheels));
    // With the camera fixes fused, the estimate stays near the truth.
    let fused = d.join("fused.csv");
    omnikin()
        .args([
            "odometry",
            trial.join("encoders.csv").to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--imu",
            "--fixes",
            trial.join("fixes.csv").to_str().unwrap(),
            "--initial-pose",
            &start,
            "--out",
            fused.to_str().unwrap(),
        ])
        .assert()
        .success();
    let fused_error = end_error(&read(&fused));
    eprintln!("end error: wheels only {drift:.4} m, fused with camera fixes {fused_error:.4} m");
    assert!(
        fused_error < 0.03,
        "fused end error {fused_error} m (wheels-only {drift} m)"
    );
    assert!(
        fused_error < drift,
        "fusion must beat wheels-only: {fused_error} vs {drift}"
    );
}

/// Observation 9: a track that never leaves its start while the plan moves sat on the plan's
/// start point, on the path, and scored 0 deviation with exit 0. It is refused, naming the
/// file and why.
#[test]
fn evaluate_refuses_a_run_that_never_moves() {
    let d = tmp("still");
    let plan = circle_plan(&d);
    let mut text = String::from("t,x,y\n");
    for k in 0..=300 {
        // Tracker jitter of 1 mm around one point: below the 5 mm start-of-motion threshold.
        text.push_str(&format!(
            "{},{},0.5\n",
            k as f64 * 0.02,
            1.0 + 0.001 * (k % 2) as f64
        ));
    }
    let track = d.join("still.csv");
    std::fs::write(&track, &text).unwrap();
    let out = d.join("out");
    omnikin()
        .args([
            "evaluate",
            "--plan",
            plan.to_str().unwrap(),
            track.to_str().unwrap(),
        ])
        .args(["--out", out.to_str().unwrap()])
        .assert()
        .failure()
        .stderr(
            predicate::str::contains("still.csv").and(predicate::str::contains("did not move")),
        );
    assert!(!out.join("metrics.json").exists());
}

/// Observation 9: metrics that overflow were written as `null` with exit 0. Now the command
/// fails and names the metric (or, if the inputs are refused first, the file).
#[test]
fn evaluate_fails_on_non_finite_metrics() {
    let d = tmp("nonfinite");
    let plan = d.join("big-plan.csv");
    std::fs::write(
        &plan,
        "t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3\n0,0,0,0,0,0,0,0,0,0\n1,1e200,0,0,0,0,0,0,0,0\n2,-1e200,1e200,0,0,0,0,0,0,0\n",
    )
    .unwrap();
    let track = d.join("big-track.csv");
    std::fs::write(&track, "t,x,y\n0,0,0\n1,1e200,1e200\n2,-1e200,-1e200\n").unwrap();
    let out = d.join("out");
    let a = omnikin()
        .args([
            "evaluate",
            "--plan",
            plan.to_str().unwrap(),
            track.to_str().unwrap(),
        ])
        .args(["--out", out.to_str().unwrap()])
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&a.get_output().stderr).to_string();
    assert!(
        err.contains("metric max_deviation_m is inf") || err.contains("big-"),
        "{err}"
    );
    if let Ok(j) = std::fs::read_to_string(out.join("metrics.json")) {
        assert!(!j.contains("null"), "{j}");
    }
}

/// Observation 7: the metrics were O(n²) (100 000 rows took minutes). 200 000 rows would take
/// ~10 min that way; the test only checks the result, the CI time limit the speed.
#[test]
fn evaluate_of_a_long_run_matches_the_plan() {
    let d = tmp("long");
    let n = 200_000;
    let mut plan = String::from("t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3\n");
    let mut track = String::from("t,x,y\n");
    for k in 0..n {
        let t = k as f64 * 0.01;
        let a = t / 30.0;
        let (x, y) = (2.0 * a.sin() + 0.001 * t, a.sin() * a.cos());
        plan.push_str(&format!("{t},{x},{y},0,0,0,0,0,0,0\n"));
        // 3 mm above the path: the deviation both ways is at most 3 mm.
        track.push_str(&format!("{t},{x},{}\n", y + 0.003));
    }
    let (p, tr) = (d.join("plan.csv"), d.join("track.csv"));
    std::fs::write(&p, plan).unwrap();
    std::fs::write(&tr, track).unwrap();
    let out = d.join("out");
    omnikin()
        .args([
            "evaluate",
            "--plan",
            p.to_str().unwrap(),
            tr.to_str().unwrap(),
        ])
        .args(["--out", out.to_str().unwrap(), "--no-align-position"])
        .assert()
        .success();
    let m = metrics(&out);
    let dev = m["max_deviation_m"].as_f64().unwrap();
    assert!(dev > 0.0 && dev <= 0.003 + 1e-9, "{m}");
    assert!(
        m["max_plan_distance_from_run_m"].as_f64().unwrap() <= 0.003 + 1e-9,
        "{m}"
    );
    // The figure is drawn from a bounded number of points, not 200 000 per line.
    let svg = std::fs::metadata(out.join("figure.svg")).unwrap().len();
    assert!(svg < 3_000_000, "figure.svg is {svg} bytes");
}

/// Observation 5: simulate keeps only the figure's runs; a figure of more trials says so.
#[test]
fn simulate_draws_a_bounded_number_of_runs() {
    let d = tmp("many");
    let plan = circle_plan(&d);
    let out = d.join("out");
    omnikin()
        .args(["simulate", plan.to_str().unwrap(), "--robot", "sphere-omni"])
        .args(["--trials", "60", "--out", out.to_str().unwrap()])
        .assert()
        .success();
    assert_eq!(metrics(&out)["runs"], 60);
    let svg = std::fs::read_to_string(out.join("figure.svg")).unwrap();
    assert!(svg.contains("60 trials") && svg.contains("(first 50 drawn)"));
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    assert_eq!(trials.lines().count(), 1 + 60 * 315);
    assert!(trials.lines().last().unwrap().starts_with("59,"));
}

#[test]
fn robot_sim_runs_the_dynamic_plant_for_the_sphere_only() {
    let assert = omnikin()
        .args([
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--plant",
            "dynamic",
            "--listen",
            "127.0.0.1:0",
            "--time-scale",
            "10",
            "--max-time",
            "0.3",
        ])
        .assert()
        .success()
        .stderr(predicate::str::contains("dynamic plant (shell + platform)"));
    let out = String::from_utf8_lossy(&assert.get_output().stdout).to_string();
    let j: Value = serde_json::from_str(out.trim()).unwrap();
    assert!(j["time_s"].as_f64().unwrap() >= 0.3, "{j}");
    // At rest without commands: level, no pull-out.
    assert_eq!(j["dynamics"]["max_tilt_rad"].as_f64(), Some(0.0), "{j}");
    assert_eq!(j["dynamics"]["pull_outs"], serde_json::json!([0, 0, 0]));
    omnikin()
        .args([
            "robot",
            "--sim",
            "--robot",
            "kiwi",
            "--plant",
            "dynamic",
            "--listen",
            "127.0.0.1:0",
            "--max-time",
            "0.1",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("sphere-omni"));
    omnikin()
        .args([
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--plant",
            "dynamic",
            "--disturbances",
            "hardware",
            "--listen",
            "127.0.0.1:0",
            "--max-time",
            "0.1",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("no --disturbances"));
}
