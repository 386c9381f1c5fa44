//! The `[dynamics]` table of a `ballbot` robot file: the preset's values equal the controller's
//! preset, absent keys take them, bad values name their key and line, and the balance
//! configuration and the plan's acceleration limit follow from the file.

use omnikin::control::{BalanceConfig, BalanceController, PlantParams};
use omnikin::description::RobotDescription;

const BASE: &str = r#"kind = "ballbot"
[geometry]
ball_radius = 0.12
wheel_radius = 0.05
zenith_deg = 45.0
azimuths_deg = [0.0, 120.0, -120.0]
"#;

fn with(dynamics: &str) -> Result<RobotDescription, omnikin::description::DescriptionError> {
    RobotDescription::from_toml_str(&format!("{BASE}[dynamics]\n{dynamics}\n"), "b.toml")
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-12)
}

#[test]
fn the_preset_file_gives_the_controller_preset() {
    let d = RobotDescription::preset("ballbot").unwrap();
    assert!(
        d.ballbot_dynamics.is_some(),
        "the preset has a [dynamics] table"
    );
    let c = d.balance_config::<f64>().unwrap();
    let p = BalanceConfig::<f64>::preset();
    let (a, b) = (c.plant, p.plant);
    for (x, y) in [
        (a.ball_radius, b.ball_radius),
        (a.wheel_radius, b.wheel_radius),
        (a.ball_mass, b.ball_mass),
        (a.ball_inertia, b.ball_inertia),
        (a.body_mass, b.body_mass),
        (a.body_inertia[0], b.body_inertia[0]),
        (a.body_inertia[1], b.body_inertia[1]),
        (a.body_inertia[2], b.body_inertia[2]),
        (a.com_height, b.com_height),
        (a.floor_damping, b.floor_damping),
        (a.relative_damping, b.relative_damping),
        (c.torque_limit, p.torque_limit),
        (c.rate_hz, p.rate_hz),
        (c.fall_tilt, p.fall_tilt),
    ] {
        assert!(close(x, y), "{x} vs {y}");
    }
    assert_eq!(c.weights, p.weights);
    assert_eq!(c.geometry, p.geometry);
    // And without the table the same values.
    let bare = RobotDescription::from_toml_str(BASE, "b.toml").unwrap();
    assert_eq!(bare.ballbot_dynamics, None);
    let c0 = bare.balance_config::<f64>().unwrap();
    assert_eq!(c0.plant, PlantParams::preset());
    BalanceController::new(c).unwrap();
    BalanceController::new(d.balance_config::<f32>().unwrap()).unwrap();
    // Other kinds have none.
    assert!(
        RobotDescription::preset("kiwi")
            .unwrap()
            .balance_config::<f64>()
            .is_none()
    );
}

#[test]
fn given_values_reach_the_controller_configuration() {
    let d = with(
        "body_mass = 12.0\ncom_height = 0.3\ntorque_limit = 3.0\ncontrol_rate_hz = 400.0\n\
         fall_tilt_deg = 25.0\n[dynamics.weights]\ntilt_deg = 2.0\ntorque = 0.5",
    )
    .unwrap();
    let c = d.balance_config::<f64>().unwrap();
    assert_eq!(c.plant.body_mass, 12.0);
    assert_eq!(c.plant.com_height, 0.3);
    assert_eq!(c.torque_limit, 3.0);
    assert_eq!(c.rate_hz, 400.0);
    assert!(close(c.fall_tilt, 25.0f64.to_radians()));
    assert!(close(c.weights.tilt, 2.0f64.to_radians()));
    assert_eq!(c.weights.torque, 0.5);
    assert_eq!(c.weights.position, 0.05, "absent weight keeps its default");
    assert_eq!(c.plant.ball_mass, PlantParams::<f64>::preset().ball_mass);
    let k = BalanceController::new(c).unwrap();
    let kp = BalanceController::new(BalanceConfig::<f64>::preset()).unwrap();
    assert_ne!(k.designs()[1].gain, kp.designs()[1].gain, "other gains");
}

#[test]
fn bad_values_name_their_key_and_line() {
    for (text, field, line) in [
        ("ball_mass = -1.0", "dynamics.ball_mass", 8),
        (
            "body_mass = 2.0\ncom_height = nan",
            "dynamics.com_height",
            9,
        ),
        ("ball_inertia = 0.5", "dynamics.ball_inertia", 8),
        ("body_inertia = [1.0, 1.0]", "dynamics.body_inertia", 8),
        ("body_inertia = [1.0, 1.0, 3.0]", "dynamics.body_inertia", 8),
        ("torque_limit = 0.0", "dynamics.torque_limit", 8),
        ("floor_damping = -0.1", "dynamics.floor_damping", 8),
        ("max_tilt_deg = 50.0", "dynamics.max_tilt_deg", 8),
        ("max_tilt_deg = 25.0", "dynamics.max_tilt_deg", 8),
        ("fall_tilt_deg = 5.0", "dynamics.fall_tilt_deg", 8),
        ("lean_margin = 1.0", "dynamics.lean_margin", 8),
        ("control_rate_hz = 1.0", "dynamics.control_rate_hz", 8),
        (
            "body_mass = 2.0\n[dynamics.weights]\nyaw = 0.1\ntilt_deg = -1.0",
            "dynamics.weights.tilt_deg",
            11,
        ),
    ] {
        let e = with(text).unwrap_err();
        assert_eq!(e.field, field, "{text}: {e}");
        assert_eq!(e.line, Some(line), "{text}: {e}");
    }
    let e = with("body_mas = 2.0").unwrap_err();
    assert!(e.to_string().contains("body_mas"), "{e}");
    // The sphere's keys are not a ballbot's.
    assert!(with("platform_mass = 2.0").is_err());
}

#[test]
fn the_plan_acceleration_limit_follows_the_lean_limit() {
    let (a, tilt, margin) = RobotDescription::preset("ballbot")
        .unwrap()
        .lean_acceleration_limit()
        .unwrap();
    assert_eq!((tilt, margin), (10.0, 0.25));
    let p = PlantParams::<f64>::preset();
    // Below g tan θ (the ball's inertia costs lean) and above half of it.
    let g_tan = 9.81 * 10.0f64.to_radians().tan();
    assert!(a < 0.75 * g_tan && a > 0.5 * g_tan, "{a} vs {g_tan}");
    assert!(close(
        a,
        0.75 * p.acceleration_for_lean(10.0f64.to_radians())
    ));
    // A larger lean limit allows more.
    let (a2, ..) = with("max_tilt_deg = 15.0")
        .unwrap()
        .lean_acceleration_limit()
        .unwrap();
    assert!(a2 > a);
    assert!(
        RobotDescription::preset("kiwi")
            .unwrap()
            .lean_acceleration_limit()
            .is_none()
    );
}
