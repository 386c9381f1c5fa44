//! The `[dynamics]` table of a `sphere-omni` robot file: parsed values, absent keys, and errors
//! that name the field.

use omnikin::description::RobotDescription;

const BASE: &str = r#"
kind = "sphere-omni"
[geometry]
shell_radius = 0.15
wheel_radius = 0.07
tilt_deg = 45.0
roller_angle_deg = 45.0
azimuths_deg = [0.0, 120.0, 240.0]
"#;

fn with(dynamics: &str) -> Result<RobotDescription, omnikin::description::DescriptionError> {
    RobotDescription::from_toml_str(&format!("{BASE}\n[dynamics]\n{dynamics}\n"), "test.toml")
}

#[test]
fn the_table_is_optional_and_its_values_are_kept() {
    let d = RobotDescription::from_toml_str(BASE, "test.toml").unwrap();
    assert_eq!(d.sphere_dynamics, None);
    let d = with("platform_mass = 2.5\ncom_depth = 0.07\nplatform_inertia = [0.003, 0.004, 0.006]\npull_out_torque = inf")
        .unwrap();
    let s = d.sphere_dynamics.unwrap();
    assert_eq!(s.platform_mass, Some(2.5));
    assert_eq!(s.com_depth, Some(0.07));
    assert_eq!(s.platform_moments(), Some([0.003, 0.004, 0.006]));
    assert_eq!(s.pull_out_torque, Some(f64::INFINITY));
    assert_eq!(s.shell_mass, None);
    let s = with(
        "roller_friction = inf\nroller_viscous = 0.5\nroller_preload = 3.0\nfloor_friction = 0.3",
    )
    .unwrap()
    .sphere_dynamics
    .unwrap();
    assert_eq!(s.roller_friction, Some(f64::INFINITY));
    assert_eq!(
        (s.roller_viscous, s.roller_preload, s.floor_friction),
        (Some(0.5), Some(3.0), Some(0.3))
    );
}

#[test]
fn the_motor_model_is_chosen_by_name_and_a_wrong_name_is_refused() {
    use omnikin::description::MotorModel;
    let s = with("motor = \"stepper\"\nstepper_steps_per_rev = 400\nstepper_corner_speed = 40.0\nstepper_damping = 0.0")
        .unwrap()
        .sphere_dynamics
        .unwrap();
    assert_eq!(s.motor, Some(MotorModel::Stepper));
    assert_eq!(
        (
            s.stepper_steps_per_rev,
            s.stepper_corner_speed,
            s.stepper_damping
        ),
        (Some(400.0), Some(40.0), Some(0.0))
    );
    let s = with("motor = \"rate\"").unwrap().sphere_dynamics.unwrap();
    assert_eq!(s.motor, Some(MotorModel::Rate));
    let e = with("motor = \"servo\"").unwrap_err().to_string();
    assert!(
        e.contains("servo") && e.contains("stepper") && e.contains("rate"),
        "the error names the bad value and the two names: {e}"
    );
    for (text, field) in [
        (
            "stepper_steps_per_rev = 202",
            "dynamics.stepper_steps_per_rev",
        ),
        (
            "stepper_steps_per_rev = 0",
            "dynamics.stepper_steps_per_rev",
        ),
        (
            "stepper_corner_speed = 0.0",
            "dynamics.stepper_corner_speed",
        ),
        ("stepper_damping = -0.1", "dynamics.stepper_damping"),
    ] {
        let e = with(text).unwrap_err();
        assert_eq!(e.field, field, "{text}: {e}");
        assert!(e.line.is_some(), "{text}: {e}");
    }
}

#[test]
fn the_sphere_preset_carries_its_dynamics() {
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let s = d
        .sphere_dynamics
        .expect("the preset has a [dynamics] table");
    assert!(s.platform_mass.is_some() && s.com_depth.is_some());
}

#[test]
fn bad_values_name_their_field() {
    for (text, field) in [
        ("shell_mass = -0.5", "dynamics.shell_mass"),
        ("platform_mass = nan", "dynamics.platform_mass"),
        ("com_depth = 0.15", "dynamics.com_depth"),
        (
            "platform_inertia = [0.004, 0.004]",
            "dynamics.platform_inertia",
        ),
        (
            "platform_inertia = [0.001, 0.001, 0.006]",
            "dynamics.platform_inertia",
        ),
        (
            "shell_mass = 0.5\nshell_inertia = 0.02",
            "dynamics.shell_inertia",
        ),
        ("pull_out_torque = 0.0", "dynamics.pull_out_torque"),
        ("pivot_friction = -0.001", "dynamics.pivot_friction"),
        ("tracked_height = 0.4", "dynamics.tracked_height"),
        ("roller_friction = 0.0", "dynamics.roller_friction"),
        ("roller_friction = nan", "dynamics.roller_friction"),
        ("roller_viscous = -1.0", "dynamics.roller_viscous"),
        ("roller_preload = -2.0", "dynamics.roller_preload"),
        ("floor_friction = 0.0", "dynamics.floor_friction"),
        ("max_tilt_deg = 90.0", "dynamics.max_tilt_deg"),
    ] {
        let e = with(text).unwrap_err();
        assert_eq!(e.field, field, "{text}: {e}");
        assert!(e.line.is_some(), "{text}: {e}");
    }
    let e = with("platform_mas = 2.0").unwrap_err();
    assert!(e.to_string().contains("platform_mas"), "{e}");
}

#[test]
fn other_kinds_reject_the_table() {
    let text = r#"
kind = "caster3"
[geometry]
mount_radius = 0.2
eccentricity = 0.03
wheel_radius = 0.04
mount_angles_deg = [0.0, -120.0, 120.0]
[dynamics]
platform_mass = 2.0
"#;
    let e = RobotDescription::from_toml_str(text, "c.toml").unwrap_err();
    assert_eq!(e.field, "dynamics", "{e}");
}

#[test]
fn the_floor_is_chosen_by_name_and_a_wrong_name_is_refused() {
    use omnikin::description::FloorSurface;
    for s in FloorSurface::ALL {
        let spec = with(&format!("floor = \"{}\"", s.name()))
            .unwrap()
            .sphere_dynamics
            .unwrap();
        assert_eq!(spec.floor, Some(s));
        assert!(spec.floor_overrides().is_empty());
    }
    let spec = with("floor = \"carpet\"\nfloor_friction = 0.3\npivot_friction = 0.05")
        .unwrap()
        .sphere_dynamics
        .unwrap();
    assert_eq!(spec.floor_overrides(), ["pivot_friction", "floor_friction"]);
    // Without a named floor the explicit values override nothing.
    let spec = with("pivot_friction = 0.05")
        .unwrap()
        .sphere_dynamics
        .unwrap();
    assert!(spec.floor_overrides().is_empty());
    let e = with("floor = \"parquet\"").unwrap_err().to_string();
    assert!(
        e.contains("floor") && e.contains("parquet"),
        "the error names the field and the bad value: {e}"
    );
    for s in FloorSurface::ALL {
        assert!(e.contains(s.name()), "the error lists {}: {e}", s.name());
    }
}
