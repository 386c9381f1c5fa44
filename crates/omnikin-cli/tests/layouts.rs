//! The kinematics commands for the common layouts (issue 13): `inverse`, `forward`, `torques`
//! and `check` for kiwi, X-drive, mecanum and swerve4, against formulas written out here
//! independently of the library (WPILib's MecanumDriveKinematics / SwerveDriveKinematics
//! conventions divided by the wheel radius).

use assert_cmd::Command;
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
    serde_json::from_slice(&out.stdout).unwrap()
}

fn list(v: &Value, key: &str) -> Vec<f64> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("missing {key} in {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + b.abs())
}

fn error_of(args: &[&str]) -> String {
    let out = omnikin().args(args).output().unwrap();
    assert!(!out.status.success(), "{args:?} should fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

const TWISTS: [(f64, f64, f64); 4] = [
    (0.3, 0.1, 0.5),
    (-0.2, 0.4, 0.0),
    (0.0, 0.0, -1.3),
    (1.1, -0.7, 2.0),
];

fn twist_args(t: (f64, f64, f64)) -> [String; 6] {
    [
        "--vx".into(),
        t.0.to_string(),
        "--vy".into(),
        t.1.to_string(),
        "--yaw-rate".into(),
        t.2.to_string(),
    ]
}

fn run_inverse(robot: &str, t: (f64, f64, f64)) -> Value {
    let a = twist_args(t);
    let mut args = vec!["inverse", robot];
    args.extend(a.iter().map(String::as_str));
    args.push("--json");
    json_of(&args)
}

#[test]
fn mecanum_inverse_is_wpilib_to_wheel_speeds_over_r() {
    // FL (0.25, 0.2), FR (0.25, −0.2), RL (−0.25, 0.2), RR (−0.25, −0.2), r = 0.05:
    // FL = vx − vy − (a+b)ω, FR = vx + vy + (a+b)ω, RL = vx + vy − (a+b)ω, RR = vx − vy + (a+b)ω.
    for t in TWISTS {
        let (vx, vy, w) = t;
        let k = 0.45 * w;
        let want = [vx - vy - k, vx + vy + k, vx + vy - k, vx - vy + k].map(|v| v / 0.05);
        let got = list(&run_inverse("mecanum", t), "wheel_rates");
        assert_eq!(got.len(), 4);
        for i in 0..4 {
            assert!(
                close(got[i], want[i]),
                "{t:?} wheel {i}: {} vs {}",
                got[i],
                want[i]
            );
        }
        // And forward gives the twist back.
        let rates = got.iter().map(f64::to_string).collect::<Vec<_>>().join(",");
        let f = json_of(&["forward", "mecanum", "--wheel-rates", &rates, "--json"]);
        assert!(close(f["vx"].as_f64().unwrap(), vx), "{f}");
        assert!(close(f["vy"].as_f64().unwrap(), vy), "{f}");
        assert!(close(f["yaw_rate"].as_f64().unwrap(), w), "{f}");
        assert!(f["slip_residual"].as_f64().unwrap().abs() < 1e-9);
    }
}

#[test]
fn kiwi_and_x_drive_inverse_follow_the_wheel_directions() {
    for t in TWISTS {
        let (vx, vy, w) = t;
        let got = list(&run_inverse("kiwi", t), "wheel_rates");
        for (i, g) in got.iter().enumerate() {
            let th = (120.0 * i as f64).to_radians();
            let want = (-th.sin() * vx + th.cos() * vy + 0.15 * w) / 0.05;
            assert!(close(*g, want), "kiwi {t:?} wheel {i}");
        }
        assert_eq!(list(&run_inverse("x-drive", t), "wheel_rates").len(), 4);
    }
}

#[test]
fn swerve4_inverse_is_wpilib_module_states_and_forward_inverts_it() {
    let pos = [(0.3, 0.3), (0.3, -0.3), (-0.3, 0.3), (-0.3, -0.3)];
    for t in TWISTS {
        let (vx, vy, w) = t;
        let v = run_inverse("swerve4", t);
        let rates = list(&v, "wheel_rates");
        let angles = list(&v, "steer_angles");
        assert!(v.get("steer_rates").is_none(), "{v}");
        for i in 0..4 {
            let (x, y) = pos[i];
            let (u, q) = (vx - w * y, vy + w * x);
            let speed = u.hypot(q);
            assert!(close(rates[i], speed / 0.05), "{t:?} module {i}");
            assert!(rates[i] >= 0.0);
            if speed > 1e-6 {
                assert!(
                    close(angles[i], q.atan2(u)),
                    "{t:?} module {i}: {}",
                    angles[i]
                );
            }
        }
        let join = |x: &[f64]| x.iter().map(f64::to_string).collect::<Vec<_>>().join(",");
        let f = json_of(&[
            "forward",
            "swerve4",
            "--wheel-rates",
            &join(&rates),
            "--steer",
            &join(&angles),
            "--json",
        ]);
        assert!(close(f["vx"].as_f64().unwrap(), vx), "{f}");
        assert!(close(f["vy"].as_f64().unwrap(), vy), "{f}");
        assert!(close(f["yaw_rate"].as_f64().unwrap(), w), "{f}");
    }
}

#[test]
fn swerve_at_rest_keeps_the_given_steer_angles() {
    let v = json_of(&[
        "inverse",
        "swerve4",
        "--steer",
        "0.1,-0.2,0.3,-0.4",
        "--json",
    ]);
    assert_eq!(list(&v, "steer_angles"), vec![0.1, -0.2, 0.3, -0.4]);
    assert_eq!(list(&v, "wheel_rates"), vec![0.0; 4]);
}

#[test]
fn wrong_list_lengths_name_the_expected_count() {
    let e = error_of(&["forward", "mecanum", "--wheel-rates", "1,2,3"]);
    assert!(
        e.contains("expected 4 values") && e.contains("got 3"),
        "{e}"
    );
    let e = error_of(&[
        "forward",
        "swerve4",
        "--wheel-rates",
        "1,2,3,4",
        "--steer",
        "0,0",
    ]);
    assert!(e.contains("--steer") && e.contains("expected 4"), "{e}");
    let e = error_of(&["forward", "kiwi", "--wheel-rates", "1,2,3,4"]);
    assert!(e.contains("expected 3 values"), "{e}");
    let e = error_of(&["inverse", "mecanum", "--steer", "0,0,0,0"]);
    assert!(e.contains("--steer applies only"), "{e}");
    let e = error_of(&["inverse", "kiwi", "--shell-spin", "1"]);
    assert!(e.contains("--shell-spin applies only"), "{e}");
}

#[test]
fn torques_balance_power_for_the_wrench_kinds() {
    // Wheel torques of a wrench, and back: the wrench is reproduced, and the power of the
    // torques on the wheel rates of a twist equals the power of the wrench on the twist.
    for robot in ["kiwi", "x-drive", "mecanum"] {
        let v = json_of(&["torques", robot, "--wrench", "3,-2,0.5", "--json"]);
        let tau = list(&v, "wheel_torques");
        let join = tau.iter().map(f64::to_string).collect::<Vec<_>>().join(",");
        let back = json_of(&["torques", robot, "--wheels", &join, "--json"]);
        let g = list(&back, "wrench");
        for (a, b) in g.iter().zip([3.0, -2.0, 0.5]) {
            assert!(close(*a, b), "{robot}: {g:?}");
        }
        let t = (0.2, 0.1, -0.4);
        let rates = list(&run_inverse(robot, t), "wheel_rates");
        let p_wheels: f64 = tau.iter().zip(&rates).map(|(a, b)| a * b).sum();
        let p_body = 3.0 * t.0 - 2.0 * t.1 + 0.5 * t.2;
        assert!(close(p_wheels, p_body), "{robot}: {p_wheels} vs {p_body}");
    }
    let e = error_of(&["torques", "mecanum", "--model", "1,2,3"]);
    assert!(e.contains("--wrench"), "{e}");
    let e = error_of(&["torques", "caster3", "--wheels", "1,2,3"]);
    assert!(e.contains("torque map"), "{e}");
}

#[test]
fn check_reports_the_layout_and_its_reach() {
    let v = json_of(&["check", "mecanum", "--json"]);
    assert_eq!(v["kind"], "omni");
    assert_eq!(v["wheels"], 4);
    // Straight ahead every mecanum wheel turns at vx/r: the reach is r·max_wheel_rate.
    let ahead = v["max_speed_m_per_s"][0]["speed"].as_f64().unwrap();
    assert!(close(ahead, 0.05 * 60.0), "{v}");
    let v = json_of(&["check", "swerve4", "--json"]);
    assert_eq!(v["motors"], 8);
}
