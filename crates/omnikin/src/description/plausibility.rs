//! Plausibility of a valid description: values that pass every rule yet look like the other
//! unit (radians typed into a `_deg` key) or give proportions no robot has (a wheel larger
//! than its distance from the centre). Each is a warning, never an error: an odd robot may be
//! meant. Each message says which unit the file was read in.

use std::format;
use std::string::String;
use std::vec::Vec;

use super::{Geometry, RobotDescription};

/// The radian values people type for common angles: multiples of π/12 (15°) up to 2π.
fn looks_like_radians(deg: f64) -> Option<f64> {
    let step = core::f64::consts::PI / 12.0;
    let k = (deg / step).round();
    (deg.abs() > 1e-9 && deg.abs() <= 2.0 * core::f64::consts::PI + 1e-9 && k != 0.0)
        .then_some(k * step)
        .filter(|r| (deg - r).abs() < 5e-4)
}

impl RobotDescription {
    /// Warnings for values that are valid but implausible, in the file's own key names.
    ///
    /// * `_deg` keys: when every non-zero angle of the file is at most 2π in magnitude and at
    ///   least one of them is within 5·10⁻⁴ of a multiple of π/12 (1.5708, 0.7854, 2.0944, …),
    ///   the file very likely holds radians where degrees are read.
    /// * Proportions: a wheel whose radius exceeds its distance from the robot's centre (omni,
    ///   swerve), a caster wheel larger than its mount radius, a ballbot wheel larger than its
    ///   ball.
    pub fn plausibility(&self) -> Vec<String> {
        let mut out = Vec::new();
        // (key, value in degrees) of every angle the file gave in degrees.
        let mut angles: Vec<(String, f64)> = Vec::new();
        match &self.geometry {
            Geometry::Sphere(g) => {
                angles.push(("geometry.tilt_deg".into(), g.tilt.to_degrees()));
                angles.push((
                    "geometry.roller_angle_deg".into(),
                    g.roller_angle.to_degrees(),
                ));
                for (i, a) in g.azimuths.iter().enumerate() {
                    angles.push((format!("geometry.azimuths_deg[{i}]"), a.to_degrees()));
                }
            }
            Geometry::Ballbot(g) => {
                angles.push(("geometry.zenith_deg".into(), g.zenith.to_degrees()));
                for (i, a) in g.azimuths.iter().enumerate() {
                    angles.push((format!("geometry.azimuths_deg[{i}]"), a.to_degrees()));
                }
                if g.wheel_radius > g.ball_radius {
                    out.push(format!(
                        "geometry.wheel_radius {} m is larger than geometry.ball_radius {} m: no ballbot has these proportions (lengths are read in metres)",
                        g.wheel_radius, g.ball_radius
                    ));
                }
            }
            Geometry::Caster(g) => {
                for (i, a) in g.mount_angles.iter().enumerate() {
                    angles.push((format!("geometry.mount_angles_deg[{i}]"), a.to_degrees()));
                }
                if g.wheel_radius > g.mount_radius {
                    out.push(format!(
                        "geometry.wheel_radius {} m is larger than geometry.mount_radius {} m: no caster base has these proportions (lengths are read in metres)",
                        g.wheel_radius, g.mount_radius
                    ));
                }
            }
            Geometry::Omni(wheels) => {
                for (i, w) in wheels.iter().enumerate() {
                    let at = format!("geometry.wheels[{i}]");
                    angles.push((
                        format!("{at}.drive_angle_deg"),
                        w.drive[1].atan2(w.drive[0]).to_degrees(),
                    ));
                    angles.push((
                        format!("{at}.roller_angle_deg"),
                        w.roller_angle.to_degrees(),
                    ));
                    let d = w.position[0].hypot(w.position[1]);
                    if w.radius > d {
                        out.push(format!(
                            "{at}.radius {} m is larger than the wheel's distance from the centre, {d:.4} m: no robot has these proportions (lengths are read in metres)",
                            w.radius
                        ));
                    }
                }
            }
            Geometry::Swerve { modules, .. } => {
                for (i, m) in modules.iter().enumerate() {
                    let d = m.position[0].hypot(m.position[1]);
                    if m.wheel_radius > d {
                        out.push(format!(
                            "geometry.modules[{i}].wheel_radius {} m is larger than the module's distance from the centre, {d:.4} m: no robot has these proportions (lengths are read in metres)",
                            m.wheel_radius
                        ));
                    }
                }
            }
        }
        let nonzero: Vec<&(String, f64)> = angles.iter().filter(|(_, d)| d.abs() > 1e-9).collect();
        let all_small = nonzero
            .iter()
            .all(|(_, d)| d.abs() <= 2.0 * core::f64::consts::PI + 1e-9);
        if all_small
            && let Some((key, deg, rad)) = nonzero
                .iter()
                .find_map(|(k, d)| looks_like_radians(*d).map(|r| (k, *d, r)))
        {
            out.push(format!(
                "{key} = {deg:.4} is read in degrees, but every angle of this file is at most 2π and this one is {:.0}π/12 in radians: were radians meant? ({:.4} rad is {:.1}°)",
                rad / (core::f64::consts::PI / 12.0),
                deg,
                deg.to_degrees()
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_are_plausible() {
        for name in [
            "sphere-omni",
            "ballbot",
            "caster3",
            "kiwi",
            "x-drive",
            "mecanum",
            "swerve4",
        ] {
            let d = RobotDescription::preset(name).unwrap();
            assert!(
                d.plausibility().is_empty(),
                "{name}: {:?}",
                d.plausibility()
            );
        }
    }

    #[test]
    fn radians_in_a_deg_key_and_a_giant_wheel_are_named() {
        let kiwi = |angle: &str, radius: &str| {
            std::format!(
                "kind = \"omni\"\n\
                 [[geometry.wheels]]\nposition = [0.15, 0.0]\ndrive_angle_deg = {angle}\nroller_angle_deg = 0.0\nradius = {radius}\n\
                 [[geometry.wheels]]\nposition = [-0.075, 0.1299]\ndrive_angle_deg = 3.6652\nroller_angle_deg = 0.0\nradius = {radius}\n\
                 [[geometry.wheels]]\nposition = [-0.075, -0.1299]\ndrive_angle_deg = 5.7596\nroller_angle_deg = 0.0\nradius = {radius}\n"
            )
        };
        let w = RobotDescription::from_toml_str(&kiwi("1.5708", "0.05"), "k.toml")
            .unwrap()
            .plausibility();
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].starts_with("geometry.wheels[0].drive_angle_deg = 1.5708 is read in degrees")
                && w[0].contains("6π/12 in radians"),
            "{w:?}"
        );
        // The same file in degrees: nothing.
        let ok = kiwi("90", "0.05")
            .replace("3.6652", "210")
            .replace("5.7596", "330");
        assert!(
            RobotDescription::from_toml_str(&ok, "k.toml")
                .unwrap()
                .plausibility()
                .is_empty()
        );
        // A 2 m wheel on a 0.15 m base.
        let w = RobotDescription::from_toml_str(&ok.replace("0.05", "2.0"), "k.toml")
            .unwrap()
            .plausibility();
        assert_eq!(w.len(), 3, "{w:?}");
        assert!(w[0].contains("geometry.wheels[0].radius 2 m is larger than the wheel's distance from the centre, 0.1500 m"), "{w:?}");
    }

    #[test]
    // The approximations are the point: what people type for π/2 and π/4.
    #[allow(clippy::approx_constant)]
    fn small_degree_angles_that_are_not_radian_idioms_pass() {
        // A 5° tilt and zero roller angles: all below 2π, but no π/12 multiple.
        assert_eq!(looks_like_radians(5.0), None);
        assert_eq!(looks_like_radians(0.0), None);
        assert!(looks_like_radians(1.5708).is_some());
        assert!(looks_like_radians(0.785398).is_some());
        assert_eq!(looks_like_radians(1.6), None);
    }
}
