//! The command-line contract of conventions.md: every command, JSON keys, negative values
//! after flags, and errors on stderr with a non-zero exit code naming the bad field.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use assert_cmd::Command;
use predicates::prelude::*;
use serde_json::Value;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

fn json_of(args: &[&str]) -> Value {
    let out = omnikin().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{args:?}: {e}: {}", String::from_utf8_lossy(&out.stdout)))
}

fn triple(v: &Value, key: &str) -> [f64; 3] {
    let a = v[key]
        .as_array()
        .unwrap_or_else(|| panic!("missing {key} in {v}"));
    assert_eq!(a.len(), 3);
    [
        a[0].as_f64().unwrap(),
        a[1].as_f64().unwrap(),
        a[2].as_f64().unwrap(),
    ]
}

#[test]
fn reference_value_from_the_readme() {
    let v = json_of(&[
        "inverse",
        "sphere-omni",
        "--vx",
        "0.1",
        "--vy",
        "0",
        "--yaw-rate",
        "0",
        "--json",
    ]);
    let w = triple(&v, "wheel_rates");
    let expected = [-1.428571, 1.589103, -0.160532];
    for i in 0..3 {
        assert!((w[i] - expected[i]).abs() < 5e-7, "{w:?}");
    }
    assert_eq!(v.as_object().unwrap().len(), 1, "only wheel_rates: {v}");
}

#[test]
fn inverse_then_forward_round_trips_for_every_robot() {
    for robot in ["sphere-omni", "ballbot"] {
        let v = json_of(&[
            "inverse",
            robot,
            "--vx",
            "-0.1",
            "--vy",
            "0.05",
            "--yaw-rate",
            "-0.3",
            "--json",
        ]);
        let w = triple(&v, "wheel_rates");
        let list = format!("{},{},{}", w[0], w[1], w[2]);
        let f = json_of(&["forward", robot, "--wheel-rates", &list, "--json"]);
        assert!(
            (f["vx"].as_f64().unwrap() + 0.1).abs() < 1e-12,
            "{robot}: {f}"
        );
        assert!(
            (f["vy"].as_f64().unwrap() - 0.05).abs() < 1e-12,
            "{robot}: {f}"
        );
        assert!(
            (f["yaw_rate"].as_f64().unwrap() + 0.3).abs() < 1e-12,
            "{robot}: {f}"
        );
    }
    let v = json_of(&[
        "inverse",
        "caster3",
        "--vx",
        "-0.2",
        "--vy",
        "0.1",
        "--yaw-rate",
        "0.4",
        "--world",
        "--heading",
        "0.7",
        "--steer",
        "-0.3,0.2,1.1",
        "--json",
    ]);
    let roll = triple(&v, "wheel_rates");
    let steer = triple(&v, "steer_rates");
    let f = json_of(&[
        "forward",
        "caster3",
        "--wheel-rates",
        &format!("{},{},{}", roll[0], roll[1], roll[2]),
        "--steer",
        "-0.3,0.2,1.1",
        "--steer-rates",
        &format!("{},{},{}", steer[0], steer[1], steer[2]),
        "--heading",
        "0.7",
        "--json",
    ]);
    assert!((f["vx"].as_f64().unwrap() + 0.2).abs() < 1e-12, "{f}");
    assert!((f["vy"].as_f64().unwrap() - 0.1).abs() < 1e-12, "{f}");
    assert!((f["yaw_rate"].as_f64().unwrap() - 0.4).abs() < 1e-12, "{f}");
    assert!(f["slip_residual"].as_f64().unwrap() < 1e-12, "{f}");
}

#[test]
fn world_frame_flags_rotate_the_input() {
    // Moving along world +y while heading +90° is moving forward in the robot frame.
    let a = json_of(&[
        "inverse",
        "sphere-omni",
        "--vx",
        "0",
        "--vy",
        "0.1",
        "--world",
        "--heading",
        "1.5707963267948966",
        "--json",
    ]);
    let b = json_of(&["inverse", "sphere-omni", "--vx", "0.1", "--json"]);
    let (wa, wb) = (triple(&a, "wheel_rates"), triple(&b, "wheel_rates"));
    for i in 0..3 {
        assert!((wa[i] - wb[i]).abs() < 1e-12);
    }
    // Forward with --heading reports the world frame.
    let f = json_of(&[
        "forward",
        "sphere-omni",
        "--wheel-rates",
        &format!("{},{},{}", wb[0], wb[1], wb[2]),
        "--heading",
        "1.5707963267948966",
        "--json",
    ]);
    assert!(
        f["vx"].as_f64().unwrap().abs() < 1e-12 && (f["vy"].as_f64().unwrap() - 0.1).abs() < 1e-12,
        "{f}"
    );
}

#[test]
fn inconsistent_caster_rates_show_slip() {
    let f = json_of(&[
        "forward",
        "caster3",
        "--wheel-rates",
        "-1.2,0.5,-3",
        "--steer-rates",
        "0,0,0",
        "--json",
    ]);
    assert!(f["slip_residual"].as_f64().unwrap() > 0.01, "{f}");
}

#[test]
fn torques_round_trip_and_keys() {
    let v = json_of(&[
        "torques",
        "ballbot",
        "--model",
        "0.3,-0.7,0.2",
        "--yaw",
        "-0.4",
        "--json",
    ]);
    let t = triple(&v, "wheel_torques");
    let back = json_of(&[
        "torques",
        "ballbot",
        "--wheels",
        &format!("{},{},{}", t[0], t[1], t[2]),
        "--yaw",
        "-0.4",
        "--json",
    ]);
    let m = triple(&back, "model_torques");
    for (a, b) in m.iter().zip([0.3, -0.7, 0.2]) {
        assert!((a - b).abs() < 1e-12, "{m:?}");
    }
    omnikin()
        .args(["torques", "sphere-omni", "--model", "1,2,3"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "only to robot kinds with a torque map",
        ));
    omnikin()
        .args(["torques", "ballbot"])
        .assert()
        .failure()
        .code(2);
    omnikin()
        .args([
            "torques", "ballbot", "--model", "1,2,3", "--wheels", "1,2,3",
        ])
        .assert()
        .failure()
        .code(2);
}

#[test]
fn check_ballbot_prints_the_balance_design_and_says_it_is_stable() {
    omnikin()
        .args(["check", "ballbot"])
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "balance controller (LQR per planar model",
        ))
        .stdout(predicate::str::contains("y (sagittal): K (φ, θ, φ̇, θ̇) = ["))
        .stdout(predicate::str::contains("closed loop: stable"));
    let j = json_of(&["check", "ballbot", "--json"]);
    let planes = j["balance"]["planes"].as_array().unwrap();
    assert_eq!(planes.len(), 3);
    for p in planes {
        let poles = p["poles"].as_array().unwrap();
        assert!(poles.len() == 4 || poles.len() == 2);
        for z in poles {
            let (re, im) = (z[0].as_f64().unwrap(), z[1].as_f64().unwrap());
            assert!(re.hypot(im) < 1.0, "{p}");
        }
        assert_eq!(p["stable"], true);
    }
    assert_eq!(j["balance"]["stable"], true);
    // Other kinds have no balance controller.
    assert!(
        json_of(&["check", "kiwi", "--json"])
            .get("balance")
            .is_none()
    );
}

#[test]
fn check_every_preset_and_a_file() {
    for robot in ["sphere-omni", "ballbot", "caster3"] {
        omnikin()
            .args(["check", robot])
            .assert()
            .success()
            .stdout(predicate::str::contains("valid"))
            .stdout(predicate::str::contains("max_wheel_rate"));
        let j = json_of(&["check", robot, "--json"]);
        assert_eq!(j["kind"], robot);
        assert!(j["max_yaw_rate_rad_per_s"].as_f64().unwrap() > 0.0);
    }
    omnikin()
        .args(["check", "sphere-omni"])
        .assert()
        .success()
        .stdout(predicate::str::contains("s_i·n_i 0.056569 m"))
        .stdout(predicate::str::contains("condition number"));
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/../../robots/caster3.toml");
    omnikin()
        .args(["check", file])
        .assert()
        .success()
        .stdout(predicate::str::contains("caster3"));
}

#[test]
fn bad_robot_files_are_reported_with_file_field_and_rule() {
    let dir = TestDir::new("cli-test", "bad-robot");
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "kind = \"ballbot\"\n[geometry]\nball_radius = -0.1\nwheel_radius = 0.05\nzenith_deg = 45.0\nazimuths_deg = [0.0, 120.0, -120.0]\n").unwrap();
    omnikin()
        .args(["check", bad.to_str().unwrap()])
        .assert()
        .failure()
        .code(1)
        .stderr(predicate::str::contains("bad.toml:3: geometry.ball_radius"))
        .stderr(predicate::str::contains("must be > 0"));
    std::fs::write(&bad, "kind = \"ballbot\"\n[geometry]\nball_radius = 0.1\nwheel_radius = 0.05\nzenith_deg = 45.0\nazimuths_deg = [0.0, 120.0, -120.0]\ncolour = \"red\"\n").unwrap();
    omnikin()
        .args(["inverse", bad.to_str().unwrap(), "--vx", "1"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("bad.toml:7"))
        .stderr(predicate::str::contains("unknown field `colour`"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_flags_fail_with_the_field_named() {
    omnikin()
        .args(["inverse", "sphere-omni", "--vx", "abc"])
        .assert()
        .failure()
        .code(2)
        .stderr(predicate::str::contains("--vx"));
    omnikin()
        .args(["inverse", "sphere-omni", "--vx", "NaN"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("finite"));
    omnikin()
        .args(["forward", "sphere-omni", "--wheel-rates", "1,2"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("--wheel-rates"))
        .stderr(predicate::str::contains("expected 3 values"));
    omnikin()
        .args(["forward", "caster3", "--wheel-rates", "1,2,3"])
        .assert()
        .failure()
        .code(1)
        .stderr(predicate::str::contains("--steer-rates"));
    omnikin()
        .args(["inverse", "sphere-omni", "--steer", "0,0,0"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "--steer applies only to kinds with steering (caster3, swerve)",
        ));
    omnikin()
        .args(["inverse", "caster3", "--shell-spin", "1"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("--shell-spin"));
    omnikin()
        .args(["inverse", "no-such-robot"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("no preset or file"));
}

#[test]
fn negative_values_directly_after_flags() {
    let v = json_of(&[
        "inverse",
        "sphere-omni",
        "--vx",
        "-0.1",
        "--vy",
        "-0",
        "--yaw-rate",
        "-1e-1",
        "--json",
    ]);
    assert!(triple(&v, "wheel_rates")[0] > 0.0);
    json_of(&[
        "forward",
        "ballbot",
        "--wheel-rates",
        "-1.2,0.5,-3",
        "--shell-spin",
        "-0.5",
        "--json",
    ]);
    json_of(&[
        "torques", "ballbot", "--wheels", "-1,-2,-3", "--yaw", "-3", "--json",
    ]);
}

#[test]
fn over_limit_request_warns_but_answers() {
    omnikin()
        .args(["inverse", "sphere-omni", "--vx", "2"])
        .assert()
        .success()
        .stderr(predicate::str::contains("exceeds limits.max_wheel_rate"));
}

#[test]
fn help_lists_the_commands() {
    omnikin()
        .arg("--help")
        .assert()
        .success()
        .stdout(predicate::str::contains("inverse"))
        .stdout(predicate::str::contains("forward"))
        .stdout(predicate::str::contains("torques"))
        .stdout(predicate::str::contains("check"));
}

/// The scratch directories of the suites (tests/common/test_dir.rs) are removed when a test
/// passes and kept when it fails: /tmp grew by some 100 MB per run of the test command.
#[test]
fn a_passing_test_removes_its_directory_and_a_failing_one_keeps_it() {
    let d = TestDir::new("test-dir", "passes");
    std::fs::write(d.join("f.txt"), "x").unwrap();
    let removed = d.to_path_buf();
    drop(d);
    assert!(!removed.exists(), "removed when the test passes");

    let f = TestDir::file("test-dir", "out.csv");
    assert_eq!(f.file_name().unwrap(), "out.csv");
    let dir = f.parent().unwrap().to_path_buf();
    assert!(dir.is_dir() && !f.exists());
    let failing = std::thread::spawn(move || {
        let _f = f;
        panic!("a failing test (expected)");
    });
    assert!(failing.join().is_err());
    assert!(dir.is_dir(), "kept when the test fails");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A missing input file is named once with the system's reason, never with the reason
/// repeated ("No such file or directory (os error 2): No such file or directory (os error 2)").
#[test]
fn a_missing_input_file_is_reported_once() {
    let dir = std::env::temp_dir().join("omnikin-cli-no-such-dir");
    let missing = dir.join("none.csv");
    let missing = missing.to_str().unwrap();
    let reason = std::fs::File::open(missing).unwrap_err().to_string();
    let out_dir = dir.join("out");
    let out_dir = out_dir.to_str().unwrap();
    for args in [
        vec!["simulate", missing, "--robot", "kiwi", "--out", out_dir],
        vec!["evaluate", "--plan", missing, missing, "--out", out_dir],
        vec!["plan", "waypoints", missing, "--robot", "kiwi"],
        vec!["check", missing],
    ] {
        let out = omnikin().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(err.starts_with("error: "), "{args:?}: {err}");
        assert!(err.contains(missing), "{args:?}: {err}");
        assert_eq!(err.matches(&reason).count(), 1, "{args:?}: {err}");
    }
}

/// `check` states the footprint radius a map grows its obstacles by, and where it came from:
/// kiwi's wheels sit 0.15 m from the centre with 0.05 m radius (robots/kiwi.toml), so without a
/// `footprint_radius` the disk reaches 0.20 m; the file's own value wins when given.
#[test]
fn check_prints_the_footprint_and_its_source() {
    let j = json_of(&["check", "kiwi", "--json"]);
    let reach = 0.15f64.hypot(0.0) + 0.05;
    assert!((j["footprint_radius"].as_f64().unwrap() - reach).abs() < 1e-9);
    assert!(
        j["footprint_source"]
            .as_str()
            .unwrap()
            .contains("outermost wheel")
    );
    omnikin()
        .args(["check", "kiwi"])
        .assert()
        .success()
        .stdout(predicate::str::contains("footprint radius: 0.2000 m"));
    let j = json_of(&["check", "sphere-omni", "--json"]);
    assert_eq!(j["footprint_radius"].as_f64(), Some(0.15));
    let dir = TestDir::new("cli-test", "footprint");
    let file = dir.join("wide-kiwi.toml");
    let kiwi = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../robots/kiwi.toml"
    ))
    .unwrap();
    let wide = kiwi.replacen(
        "name = \"kiwi\"\n",
        "name = \"kiwi\"\nfootprint_radius = 0.3\n",
        1,
    );
    assert_ne!(wide, kiwi);
    std::fs::write(&file, wide).unwrap();
    let j = json_of(&["check", file.to_str().unwrap(), "--json"]);
    assert_eq!(j["footprint_radius"].as_f64(), Some(0.3));
    assert!(
        j["footprint_source"]
            .as_str()
            .unwrap()
            .contains("footprint_radius")
    );
}
