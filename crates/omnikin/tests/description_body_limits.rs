//! `RobotDescription::body_limits`: the robot file's body limits, or the ones the wheel limits
//! allow, checked against the layouts' closed forms.

use omnikin::description::{LimitSource, PRESETS, RobotDescription};

fn preset_text(name: &str) -> &'static str {
    PRESETS.iter().find(|(n, _)| *n == name).unwrap().1
}

#[test]
fn kiwi_limits_follow_from_its_wheels() {
    // Kiwi: wheel i's rate is (−sinθ_i vx + cosθ_i vy + L ω)/r, each row of unit length in
    // (vx, vy): a body acceleration a needs at most |a|/r of a wheel, a turn L α / r.
    let b = RobotDescription::preset("kiwi").unwrap().body_limits();
    let (r, l, wheel_accel) = (0.05, 0.15, 200.0);
    assert!((b.max_accel - wheel_accel * r).abs() < 1e-6, "{b:?}");
    assert!(
        (b.max_yaw_accel - wheel_accel * r / l).abs() < 1e-6,
        "{b:?}"
    );
    assert_eq!(b.max_accel_source, LimitSource::WheelLimits);
    assert_eq!(b.max_jerk, None);
}

#[test]
fn mecanum_worst_direction_is_diagonal() {
    // Mecanum: (vx ∓ vy ∓ (lx + ly) ω)/r: the diagonal needs √2 |a| / r of a wheel.
    let b = RobotDescription::preset("mecanum").unwrap().body_limits();
    let (r, lxy, wheel_accel) = (0.05, 0.45, 300.0);
    assert!(
        (b.max_accel - wheel_accel * r / 2f64.sqrt()).abs() < 1e-6,
        "{b:?}"
    );
    assert!(
        (b.max_yaw_accel - wheel_accel * r / lxy).abs() < 1e-6,
        "{b:?}"
    );
}

#[test]
fn the_file_states_them_and_the_ballbot_leans() {
    let text = preset_text("kiwi").replace(
        "max_wheel_accel = 200.0",
        "max_wheel_accel = 200.0\nmax_accel = 0.5\nmax_yaw_accel = 3.0\nmax_jerk = 20.0",
    );
    let b = RobotDescription::from_toml_str(&text, "k.toml")
        .unwrap()
        .body_limits();
    assert_eq!(
        (b.max_accel, b.max_yaw_accel, b.max_jerk),
        (0.5, 3.0, Some(20.0))
    );
    assert_eq!(b.max_accel_source, LimitSource::File);
    // A bad value names the key and its range.
    let bad = preset_text("kiwi").replace(
        "max_wheel_accel = 200.0",
        "max_wheel_accel = 200.0\nmax_accel = 5000.0",
    );
    let e = RobotDescription::from_toml_str(&bad, "k.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("limits.max_accel") && e.contains("m/s²"), "{e}");
    // The ballbot accelerates by leaning: its lean limit is lower than its wheels allow.
    let d = RobotDescription::preset("ballbot").unwrap();
    let b = d.body_limits();
    let (lean, _, _) = d.lean_acceleration_limit().unwrap();
    assert_eq!(
        (b.max_accel, b.max_accel_source),
        (lean, LimitSource::LeanLimit)
    );
    // No limits at all: the runtime's old defaults.
    let none = preset_text("kiwi")
        .replace("max_wheel_rate = 40.0", "")
        .replace("max_wheel_accel = 200.0", "");
    let b = RobotDescription::from_toml_str(&none, "k.toml")
        .unwrap()
        .body_limits();
    assert_eq!(
        (b.max_accel, b.max_accel_source),
        (1.0, LimitSource::Default)
    );
}
