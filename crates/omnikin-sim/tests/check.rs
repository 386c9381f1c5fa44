//! `omnikin_sim::check` as a library: what `omnikin check` reports, per kind, without the CLI.

use omnikin::description::{PRESETS, RobotDescription};
use omnikin_sim::check::check;

#[test]
fn every_preset_checks_with_text_and_json_that_agree() {
    for (name, _) in PRESETS {
        let d = RobotDescription::resolve(name).unwrap();
        let r = check(&d).unwrap();
        assert!(
            r.text.starts_with(&format!("robot: {} (", d.name)),
            "{}",
            r.text
        );
        assert_eq!(r.json["name"], d.name.as_str());
        assert_eq!(r.limits[0], "limits:");
        let footprint = r.json["footprint_radius"].as_f64().unwrap();
        assert!(
            r.text
                .contains(&format!("footprint radius: {footprint:.4} m")),
            "{name}"
        );
        // The fastest motion: one speed per reported direction, each > 0, when the file
        // limits the wheel rate.
        if d.limits.max_wheel_rate.is_some() {
            let v = r.json["max_speed_m_per_s"].as_array().unwrap();
            assert!(!v.is_empty() && v.iter().all(|s| s["speed"].as_f64().unwrap() > 0.0));
        }
    }
}

#[test]
fn the_ballbot_is_balanced_and_the_sphere_damped() {
    let b = check(&RobotDescription::resolve("ballbot").unwrap()).unwrap();
    assert_eq!(b.json["balance"]["stable"], true);
    assert!(b.text.contains("closed loop: stable"));
    let s = check(&RobotDescription::resolve("sphere-omni").unwrap()).unwrap();
    let t = &s.json["tilt_feedback"];
    // Designed for ζ = 1/√2 on the linearised rocking.
    assert!((t["damping_ratio"].as_f64().unwrap() - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-3);
    assert!(t["delay_margin_s"].as_f64().unwrap() > 0.015);
    let k = check(&RobotDescription::resolve("kiwi").unwrap()).unwrap();
    assert!(k.json.get("balance").is_none() && k.json.get("tilt_feedback").is_none());
}
