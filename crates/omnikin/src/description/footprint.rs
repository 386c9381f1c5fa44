//! The robot's footprint: the optional top-level `footprint_radius` key (m) and the smallest
//! disk the geometry itself occupies, which the key may not undercut.
//!
//! The footprint is the disk about the robot's centre that a map's clearances are measured
//! from (conventions.md, "Maps"). The geometry knows only part of the robot: the sphere's
//! shell and the ballbot's ball (their radius), and for wheeled bases the outermost wheel
//! contact plus its wheel radius (a caster's mount radius, caster offset and wheel radius).
//! A chassis wider than that is not in the geometry; `footprint_radius` says it.

use std::format;
use std::string::String;

use super::{DescriptionError, Geometry, LENGTH_RANGE, RobotDescription, num};

/// Slack (m) below the geometry's reach that a `footprint_radius` may have: rounding in the
/// last printed digit, not a smaller robot.
pub const FOOTPRINT_SLACK: f64 = 1e-9;

/// The radius (m) of the smallest disk about the robot's centre that holds what `g`
/// describes: the shell or ball radius, else the outermost wheel's (module's, caster's) reach
/// plus its wheel radius. For wheeled bases a lower bound of the chassis.
pub fn geometry_reach(g: &Geometry) -> f64 {
    let reach = |p: [f64; 2], r: f64| p[0].hypot(p[1]) + r;
    match g {
        Geometry::Sphere(p) => p.shell_radius,
        Geometry::Ballbot(p) => p.ball_radius,
        Geometry::Caster(p) => p.mount_radius + p.eccentricity.abs() + p.wheel_radius,
        Geometry::Omni(w) => w
            .iter()
            .map(|w| reach(w.position, w.radius))
            .fold(0.0, f64::max),
        Geometry::Swerve { modules, .. } => modules
            .iter()
            .map(|m| reach(m.position, m.wheel_radius))
            .fold(0.0, f64::max),
    }
}

impl RobotDescription {
    /// The radius (m) of the smallest disk holding the described geometry
    /// ([`geometry_reach`]).
    pub fn geometry_reach(&self) -> f64 {
        geometry_reach(&self.geometry)
    }
}

/// Checks a file's `footprint_radius`: a finite length in [`LENGTH_RANGE`] (so millimetres
/// are refused) and at least [`geometry_reach`] (less [`FOOTPRINT_SLACK`]): a footprint
/// smaller than the shell or than the wheels' reach would let a map's checks pass a robot
/// whose wheels touch an obstacle.
pub(super) fn check(
    footprint: Option<f64>,
    g: &Geometry,
    err: &dyn Fn(Option<usize>, &str, String) -> DescriptionError,
) -> Result<(), DescriptionError> {
    let Some(f) = footprint else { return Ok(()) };
    let field = "footprint_radius";
    let (min, max) = LENGTH_RANGE;
    if !(f.is_finite() && (min..=max).contains(&f)) {
        return Err(err(
            None,
            field,
            format!(
                "{} m is outside the plausible range [{}, {}] m (a radius in metres)",
                num(f),
                num(min),
                num(max)
            ),
        ));
    }
    let reach = geometry_reach(g);
    if f < reach - FOOTPRINT_SLACK {
        let what = match g {
            Geometry::Sphere(_) => "the shell radius",
            Geometry::Ballbot(_) => "the ball radius",
            Geometry::Caster(_) | Geometry::Omni(_) | Geometry::Swerve { .. } => {
                "the outermost wheel's distance from the centre plus its wheel radius"
            }
        };
        return Err(err(
            None,
            field,
            format!(
                "{} m is smaller than the robot's geometry: {what} is {} m; the footprint is a \
                 disk about the centre holding the whole robot",
                num(f),
                num(reach)
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::string::ToString;

    use super::*;

    const KIWI: &str = include_str!("../../../../robots/kiwi.toml");

    /// The kiwi preset with `line` inserted after its `kind` line.
    fn kiwi_with(line: &str) -> std::string::String {
        KIWI.replacen("kind = \"omni\"", &format!("kind = \"omni\"\n{line}"), 1)
    }

    /// The 1-based line of the `footprint_radius` key in `text`.
    fn key_line(text: &str) -> Option<usize> {
        text.lines()
            .position(|l| l.starts_with("footprint_radius"))
            .map(|i| i + 1)
    }

    #[test]
    fn a_given_radius_is_kept_and_absent_is_none() {
        let d = RobotDescription::from_toml_str(&kiwi_with("footprint_radius = 0.3"), "k").unwrap();
        assert_eq!(d.footprint_radius, Some(0.3));
        let d = RobotDescription::from_toml_str(KIWI, "k").unwrap();
        assert_eq!(d.footprint_radius, None);
    }

    #[test]
    fn a_radius_inside_the_wheels_is_refused_naming_the_line_and_the_reach() {
        let d = RobotDescription::preset("kiwi").unwrap();
        let reach = d.geometry_reach();
        let below = reach * 0.99;
        let e = RobotDescription::from_toml_str(
            &kiwi_with(&format!("footprint_radius = {below}")),
            "k",
        )
        .unwrap_err();
        assert_eq!(e.field, "footprint_radius");
        assert_eq!(e.line, key_line(&kiwi_with("footprint_radius = 1")), "{e}");
        assert!(e.rule.contains(&num(reach)), "{e}");
        assert!(e.rule.contains("outermost wheel"), "{e}");
        // The reach itself is accepted.
        let ok = RobotDescription::from_toml_str(
            &kiwi_with(&format!("footprint_radius = {reach}")),
            "k",
        );
        assert_eq!(ok.unwrap().footprint_radius, Some(reach));
    }

    #[test]
    fn millimetres_negative_and_wrong_types_are_refused() {
        for (v, says) in [
            ("250.0", "plausible range"),
            ("-0.3", "plausible range"),
            ("0.0", "plausible range"),
            ("nan", "plausible range"),
            ("\"0.3\"", "invalid type"),
        ] {
            let text = kiwi_with(&format!("footprint_radius = {v}"));
            let e = RobotDescription::from_toml_str(&text, "k").unwrap_err();
            assert!(key_line(&text).is_some());
            assert_eq!(e.line, key_line(&text), "{v}: {e}");
            assert!(e.to_string().contains(says), "{v}: {e}");
        }
    }

    #[test]
    fn the_sphere_reaches_its_shell_and_swerve4_past_its_modules() {
        let s = RobotDescription::preset("sphere-omni").unwrap();
        assert_eq!(s.geometry_reach(), 0.15);
        let w = RobotDescription::preset("swerve4").unwrap();
        let Geometry::Swerve { modules, .. } = &w.geometry else {
            panic!("swerve4 is a swerve")
        };
        for m in modules {
            assert!(
                w.geometry_reach() >= m.position[0].hypot(m.position[1]) + m.wheel_radius - 1e-15
            );
        }
    }
}
