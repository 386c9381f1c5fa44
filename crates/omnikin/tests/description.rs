//! Robot description files: presets load, and every kind of bad file is rejected with the
//! file, the field (or line) and the rule.
#![cfg(feature = "std")]

use omnikin::Robot;
use omnikin::description::{Geometry, PRESETS, RobotDescription};

#[test]
fn presets_load_build_and_match_the_files() {
    for (name, text) in PRESETS {
        let d = RobotDescription::preset(name).expect(name);
        assert_eq!(d.name, name);
        assert_eq!(d.kind(), name);
        assert!(d.limits.max_wheel_rate.is_some());
        assert!(d.build::<f64>().is_ok() && d.build::<f32>().is_ok());
        let on_disk = std::fs::read_to_string(format!(
            "{}/../../robots/{name}.toml",
            env!("CARGO_MANIFEST_DIR")
        ))
        .unwrap();
        assert_eq!(
            on_disk, text,
            "compiled-in preset differs from robots/{name}.toml"
        );
        let from_file = RobotDescription::resolve(&format!(
            "{}/../../robots/{name}.toml",
            env!("CARGO_MANIFEST_DIR")
        ))
        .unwrap();
        assert_eq!(from_file.geometry, d.geometry);
    }
    let d = RobotDescription::preset("sphere-omni").unwrap();
    match d.geometry {
        Geometry::Sphere(p) => {
            assert_eq!(p.shell_radius, 0.15);
            assert!((p.tilt - 45f64.to_radians()).abs() < 1e-15);
        }
        _ => panic!("wrong kind"),
    }
    assert!(matches!(d.build::<f64>().unwrap(), Robot::Sphere(_)));
    assert!(matches!(
        RobotDescription::preset("caster3")
            .unwrap()
            .build::<f64>()
            .unwrap(),
        Robot::Caster(_)
    ));
}

fn sphere_with(geometry_line_from: &str, to: &str) -> String {
    let (_, text) = PRESETS[0];
    assert!(text.contains(geometry_line_from), "{geometry_line_from}");
    text.replacen(geometry_line_from, to, 1)
}

fn error_of(text: &str) -> String {
    RobotDescription::from_toml_str(text, "robots/test.toml")
        .unwrap_err()
        .to_string()
}

#[test]
fn unknown_key_names_the_line_and_key() {
    let text = sphere_with("tilt_deg = 45.0", "tilt_deg = 45.0\ntilt_degrees = 40.0");
    let e = error_of(&text);
    assert!(e.starts_with("robots/test.toml:"), "{e}");
    assert!(e.contains("unknown field `tilt_degrees`"), "{e}");
    let line = text
        .lines()
        .position(|l| l.starts_with("tilt_degrees"))
        .unwrap()
        + 1;
    assert!(e.contains(&format!(":{line}:")), "{e} (line {line})");
}

#[test]
fn missing_field_is_named() {
    let e = error_of(&sphere_with("shell_radius = 0.15", ""));
    assert!(e.contains("missing field `shell_radius`"), "{e}");
    let e = error_of("name = \"x\"\n");
    assert!(e.contains("kind") && e.contains("missing"), "{e}");
}

#[test]
fn wrong_type_names_the_line() {
    let e = error_of(&sphere_with(
        "shell_radius = 0.15",
        "shell_radius = \"big\"",
    ));
    assert!(e.contains("robots/test.toml:"), "{e}");
    assert!(e.contains("invalid type"), "{e}");
}

#[test]
fn negative_radius_names_field_and_rule() {
    let e = error_of(&sphere_with("wheel_radius = 0.07", "wheel_radius = -0.07"));
    assert_eq!(
        e,
        "robots/test.toml: geometry.wheel_radius (wheel 1): wheel_radius[0] must be > 0 (got -0.07)"
    );
    // One radius per wheel: the third is bad.
    let e = error_of(&sphere_with(
        "wheel_radius = 0.07",
        "wheel_radius = [0.07, 0.07, -0.01]",
    ));
    assert!(
        e.contains("geometry.wheel_radius (wheel 3)") && e.contains("must be > 0"),
        "{e}"
    );
    let e = error_of(&sphere_with(
        "wheel_radius = 0.07",
        "wheel_radius = [0.07, 0.07]",
    ));
    assert!(e.contains("a radius in m, or a list of three radii"), "{e}");
    let ok = RobotDescription::from_toml_str(
        &sphere_with("wheel_radius = 0.07", "wheel_radius = [0.07, 0.071, 0.069]"),
        "t",
    )
    .unwrap();
    match ok.geometry {
        Geometry::Sphere(p) => assert_eq!(p.wheel_radius, [0.07, 0.071, 0.069]),
        _ => panic!("wrong kind"),
    }
}

#[test]
fn wheel_larger_than_shell() {
    let e = error_of(&sphere_with("wheel_radius = 0.07", "wheel_radius = 0.2"));
    assert!(
        e.contains("geometry.wheel_radius") && e.contains("smaller than the shell radius"),
        "{e}"
    );
}

#[test]
fn singular_geometry_reports_condition_number() {
    let e = error_of(&sphere_with(
        "azimuths_deg = [0.0, 120.0, 240.0]",
        "azimuths_deg = [0.0, 0.0, 240.0]",
    ));
    assert!(
        e.contains("geometry") && e.contains("condition number"),
        "{e}"
    );
    let e = error_of(&sphere_with(
        "roller_angle_deg = 45.0",
        "roller_angle_deg = 0.0",
    ));
    assert!(
        e.contains("geometry.roller_angle_deg") && e.contains("wheel 1"),
        "{e}"
    );
}

#[test]
fn ballbot_and_caster_rules() {
    let (_, ballbot) = PRESETS[1];
    let e = error_of(&ballbot.replacen("zenith_deg = 45.0", "zenith_deg = 95.0", 1));
    assert!(
        e.contains("geometry.zenith_deg") && e.contains("between 0 and 90"),
        "{e}"
    );
    let e = error_of(&ballbot.replacen("[limits]", "[limits]\nmax_steer_rate = 3.0", 1));
    assert!(
        e.contains("limits.max_steer_rate") && e.contains("caster3"),
        "{e}"
    );
    let (_, caster) = PRESETS[2];
    let e = error_of(&caster.replacen("eccentricity = 0.04", "eccentricity = 0.0", 1));
    assert!(
        e.contains("geometry.eccentricity") && e.contains("> 0"),
        "{e}"
    );
    let e = error_of(&caster.replacen("max_steer_rate = 10.0", "max_steer_rate = -1.0", 1));
    assert!(
        e.contains("limits.max_steer_rate") && e.contains("> 0"),
        "{e}"
    );
}

#[test]
fn unknown_kind_and_missing_file() {
    let e = error_of("kind = \"hexapod\"\n");
    assert!(e.contains("unknown robot kind \"hexapod\""), "{e}");
    let e = RobotDescription::resolve("no-such-robot")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no preset or file") && e.contains("sphere-omni"),
        "{e}"
    );
    let e = RobotDescription::resolve("missing/robot.toml")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("missing/robot.toml") && e.contains("cannot read"),
        "{e}"
    );
    let e = error_of("kind = [");
    assert!(e.starts_with("robots/test.toml:1:"), "{e}");
}
