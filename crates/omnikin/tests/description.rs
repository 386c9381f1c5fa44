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
        // The kind is the file's `kind` key (paper robots are named after it; the layouts are
        // kinds omni and swerve).
        let key: toml::Value = toml::from_str(text).unwrap();
        assert_eq!(Some(d.kind()), key["kind"].as_str(), "{name}");
        assert!(d.limits.max_wheel_rate.is_some());
        assert!(d.build::<f64>().is_ok() && d.build::<f32>().is_ok());
        let from_file = RobotDescription::resolve(&format!(
            "{}/../../robots/{name}.toml",
            env!("CARGO_MANIFEST_DIR")
        ))
        .unwrap();
        assert_eq!(from_file.geometry, d.geometry);
        assert_eq!(from_file.limits, d.limits);
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

/// `robots/` and `PRESETS` list the same robots: a file added to `robots/` without a preset
/// (or a preset whose file was removed or renamed) fails here.
#[test]
fn every_robot_file_is_a_preset() {
    let dir = format!("{}/../../robots", env!("CARGO_MANIFEST_DIR"));
    let mut on_disk: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| {
            let path = e.unwrap().path();
            (path.extension()? == "toml").then(|| path.file_stem()?.to_str().map(str::to_owned))?
        })
        .collect();
    on_disk.sort();
    let mut presets: Vec<String> = PRESETS.iter().map(|(n, _)| n.to_string()).collect();
    presets.sort();
    assert_eq!(
        on_disk, presets,
        "robots/*.toml against description::PRESETS"
    );
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

/// The 1-based line of `text` that starts with `start` (the line an error must name).
fn line_of(text: &str, start: &str) -> usize {
    1 + text
        .lines()
        .position(|l| l.trim_start().starts_with(start))
        .unwrap_or_else(|| panic!("no line starts with {start}"))
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
    let text = sphere_with("wheel_radius = 0.07", "wheel_radius = -0.07");
    assert_eq!(
        error_of(&text),
        format!(
            "robots/test.toml:{}: geometry.wheel_radius (wheel 1): wheel_radius[0] must be > 0 \
             (got -0.07)",
            line_of(&text, "wheel_radius = -0.07")
        )
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

/// Issue 12, observation 9: a fourth value in a per-wheel list was silently dropped (serde
/// fills a three-element array and ignores the rest).
#[test]
fn a_fourth_value_in_a_per_wheel_list_is_an_error_naming_the_key() {
    let e = error_of(&sphere_with(
        "azimuths_deg = [0.0, 120.0, 240.0]",
        "azimuths_deg = [0.0, 120.0, 240.0, 300.0]",
    ));
    assert!(
        e.contains("geometry.azimuths_deg: expected 3 values (one per wheel), got 4"),
        "{e}"
    );
    let line = PRESETS[0]
        .1
        .lines()
        .position(|l| l.starts_with("azimuths_deg"))
        .unwrap()
        + 1;
    assert!(e.starts_with(&format!("robots/test.toml:{line}:")), "{e}");
    let e = error_of(&sphere_with(
        "azimuths_deg = [0.0, 120.0, 240.0]",
        "azimuths_deg = [0.0, 120.0]",
    ));
    assert!(e.contains("got 2"), "{e}");
    let e = error_of(&sphere_with(
        "wheel_radius = 0.07",
        "wheel_radius = [0.07, 0.07, 0.07, 0.07]",
    ));
    assert!(
        e.contains("geometry.wheel_radius") && e.contains("got 4 values"),
        "{e}"
    );
    let (_, ballbot) = PRESETS[1];
    let e = error_of(&ballbot.replacen(
        "azimuths_deg = [0.0, 120.0, -120.0]",
        "azimuths_deg = [0.0, 120.0, -120.0, 60.0]",
        1,
    ));
    assert!(
        e.contains("geometry.azimuths_deg") && e.contains("got 4"),
        "{e}"
    );
    let (_, caster) = PRESETS[2];
    let e = error_of(&caster.replacen(
        "mount_angles_deg = [0.0, -120.0, 120.0]",
        "mount_angles_deg = [0.0, -120.0, 120.0, 180.0]",
        1,
    ));
    assert!(
        e.contains("geometry.mount_angles_deg") && e.contains("got 4"),
        "{e}"
    );
}

/// Issue 12, observations 5 and 9: finite but absurd values (a rate limit of 1e-308 rad/s made
/// every plan take ~1e308 s) are refused with the field, the value and the range.
#[test]
fn implausible_lengths_and_motor_limits_name_field_value_and_range() {
    use omnikin::description::{LENGTH_RANGE, MOTOR_ACCEL_RANGE, MOTOR_RATE_RANGE};
    let text = sphere_with("max_wheel_rate = 12.0", "max_wheel_rate = 1e-308");
    assert_eq!(
        error_of(&text),
        format!(
            "robots/test.toml:{}: limits.max_wheel_rate: 1e-308 rad/s is outside the plausible \
             range [0.001, 100000] rad/s (omnikin::description)",
            line_of(&text, "max_wheel_rate = 1e-308")
        )
    );
    assert_eq!(MOTOR_RATE_RANGE, (0.001, 100000.0));
    let e = error_of(&sphere_with(
        "max_wheel_accel = 400.0",
        "max_wheel_accel = 1e300",
    ));
    assert!(
        e.contains("limits.max_wheel_accel: 1e300 rad/s²")
            && e.contains(&format!("{:e}", MOTOR_ACCEL_RANGE.1)),
        "{e}"
    );
    // A 50 m shell is valid geometry, but not a plausible robot.
    let e = error_of(&sphere_with("shell_radius = 0.15", "shell_radius = 50.0"));
    assert!(
        e.contains("geometry.shell_radius: 50 m is outside the plausible range [1e-4, 10] m"),
        "{e}"
    );
    let (_, caster) = PRESETS[2];
    let e = error_of(&caster.replacen("eccentricity = 0.04", "eccentricity = 1e-9", 1));
    assert!(e.contains("geometry.eccentricity: 1e-9 m"), "{e}");
    assert!(LENGTH_RANGE.0 <= 0.04 && 0.2 <= LENGTH_RANGE.1);
    // The presets sit well inside every range.
    for (name, _) in PRESETS {
        assert!(RobotDescription::preset(name).is_some(), "{name}");
    }
}

/// Issue 12, observation 9: control characters in a robot name reached terminals and SVG
/// figures (where they make the XML invalid).
#[test]
fn robot_names_are_printable_and_bounded() {
    use omnikin::description::MAX_NAME_CHARS;
    let e = error_of(&sphere_with(
        "name = \"sphere-omni\"",
        "name = \"evil\\u001b[2Jname\"",
    ));
    assert!(
        e.contains("name: must be printable: contains the control character U+001B"),
        "{e}"
    );
    let e = error_of(&sphere_with(
        "name = \"sphere-omni\"",
        "name = \"a\\u0007\"",
    ));
    assert!(e.contains("U+0007"), "{e}");
    let long = "n".repeat(MAX_NAME_CHARS + 1);
    let e = error_of(&sphere_with(
        "name = \"sphere-omni\"",
        &format!("name = \"{long}\""),
    ));
    assert!(
        e.contains(&format!("1 to {MAX_NAME_CHARS} characters")),
        "{e}"
    );
    let e = error_of(&sphere_with("name = \"sphere-omni\"", "name = \"\""));
    assert!(e.contains("got 0"), "{e}");
    // Printable non-ASCII and XML-special characters are fine (figures escape them).
    let ok = RobotDescription::from_toml_str(
        &sphere_with("name = \"sphere-omni\"", "name = \"Kugel <β> & co\""),
        "t",
    )
    .unwrap();
    assert_eq!(ok.name, "Kugel <β> & co");
}

/// Issue 12, observation 9: a UTF-8 byte-order mark (Windows editors) is not content.
#[test]
fn a_byte_order_mark_is_skipped() {
    for (name, text) in PRESETS {
        let with_bom = format!("\u{feff}{text}");
        let d = RobotDescription::from_toml_str(&with_bom, "bom.toml").unwrap();
        assert_eq!(d.geometry, RobotDescription::preset(name).unwrap().geometry);
    }
}

#[test]
fn events_table_is_read_checked_and_names_the_line() {
    use omnikin::description::EventSpec;
    let (_, kiwi) = PRESETS.iter().find(|(n, _)| *n == "kiwi").unwrap();
    let d = RobotDescription::from_toml_str(kiwi, "kiwi").unwrap();
    assert_eq!(d.events, EventSpec::default());
    let text = format!("{kiwi}\n[events]\nslip_yaw_rate = 0.5\nslip_residual = 0.02\n");
    let d = RobotDescription::from_toml_str(&text, "k.toml").unwrap();
    let t = d.events.thresholds();
    assert_eq!(
        (t.slip_yaw_rate, t.slip_residual, t.collision_decel),
        (
            0.5,
            0.02,
            omnikin::description::events::DEFAULT_COLLISION_DECEL
        )
    );
    let line_of =
        |text: &str, key: &str| text.lines().position(|l| l.starts_with(key)).unwrap() + 1;
    for (bad, rule) in [
        ("collision_decel = -3.0", "outside the plausible range"),
        ("collision_decel = 1e9", "outside the plausible range"),
        ("slip_yaw_rate = nan", "outside the plausible range"),
        ("colision_decel = 3.0", "unknown field `colision_decel`"),
        ("slip_yaw_rate = \"big\"", "invalid type"),
    ] {
        let text = format!("{kiwi}\n[events]\nslip_residual = 0.5\n{bad}\n");
        let e = error_of(&text);
        let key = bad.split(' ').next().unwrap();
        let line = line_of(&text, key);
        assert!(e.contains(rule), "{e}");
        assert!(
            e.contains(&format!("robots/test.toml:{line}:")),
            "{e} (line {line})"
        );
    }
    // Any kind has one.
    let text = sphere_with("[limits]", "[events]\ncollision_decel = 5.0\n\n[limits]");
    let d = RobotDescription::from_toml_str(&text, "s.toml").unwrap();
    assert_eq!(d.events.collision_decel, Some(5.0));
}

/// An error about one value names the line where that value is written, not the line of its
/// table's header (`[[geometry.wheels]]`, `[limits]`), and not no line at all.
#[test]
fn value_errors_name_the_value_line() {
    let kiwi = PRESETS.iter().find(|(n, _)| *n == "kiwi").unwrap().1;
    // The first wheel's roller angle, three lines below its `[[geometry.wheels]]` header.
    let first = line_of(kiwi, "roller_angle_deg = 0.0");
    let lines: Vec<&str> = kiwi.lines().collect();
    let bad: String = lines
        .iter()
        .enumerate()
        .map(|(i, l)| {
            if i + 1 == first {
                "roller_angle_deg = 90.0\n".to_string()
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let e = error_of(&bad);
    assert!(
        e.starts_with(&format!(
            "robots/test.toml:{first}: geometry.wheels[0].roller_angle_deg: 90 degrees"
        )),
        "{e}"
    );
    assert!(!lines[first - 1].starts_with('['), "{}", lines[first - 1]);
    // A geometry value checked by the model (the ballbot's ball radius).
    let ballbot = PRESETS.iter().find(|(n, _)| *n == "ballbot").unwrap().1;
    let from = whole_line(ballbot, "ball_radius = ");
    let text = ballbot.replacen(&from, "ball_radius = -0.1", 1);
    let e = error_of(&text);
    assert!(
        e.starts_with(&format!(
            "robots/test.toml:{}: geometry.ball_radius:",
            line_of(&text, "ball_radius = -0.1")
        )),
        "{e}"
    );
    // A limit (no line before: the `[limits]` values were checked after deserialising).
    let text = sphere_with("max_wheel_accel = 400.0", "max_wheel_accel = -1");
    let e = error_of(&text);
    assert_eq!(
        e,
        format!(
            "robots/test.toml:{}: limits.max_wheel_accel: must be a finite number > 0 (got -1)",
            line_of(&text, "max_wheel_accel = -1")
        )
    );
}

/// The whole line of `text` that starts with `start`, comment included.
fn whole_line(text: &str, start: &str) -> String {
    text.lines()
        .find(|l| l.starts_with(start))
        .unwrap_or_else(|| panic!("no line starts with {start}"))
        .to_string()
}
