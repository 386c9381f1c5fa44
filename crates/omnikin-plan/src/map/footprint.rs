//! The footprint radius of a robot from its geometry, when neither `--footprint-radius` nor a
//! `footprint_radius` is given.
//!
//! The default is the smallest disk about the robot's centre that holds what the geometry
//! knows of the robot: the sphere's shell and the ballbot's ball (their radius), and for wheeled
//! bases the outermost wheel contact plus its wheel radius (a caster's mount radius, caster
//! offset and wheel radius). A chassis wider than its wheels is not in the robot file, so for
//! wheeled bases this is a lower bound: give the real radius with `--footprint-radius`.

use omnikin::description::{Geometry, RobotDescription};

/// Where a footprint radius came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FootprintSource {
    /// Given by the user (`--footprint-radius`, the API's argument).
    Given,
    /// The sphere's shell radius or the ballbot's ball radius.
    BodyRadius,
    /// The outermost wheel (or caster) reach plus its wheel radius: a lower bound of the
    /// chassis.
    WheelReach,
}

impl FootprintSource {
    /// How the source reads in a summary.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Given => "given",
            Self::BodyRadius => "the robot's shell/ball radius",
            Self::WheelReach => {
                "the outermost wheel's reach (a lower bound: the chassis may be wider)"
            }
        }
    }
}

/// The footprint radius of `d` (m) from its geometry, and where it came from.
pub fn footprint_radius(d: &RobotDescription) -> (f64, FootprintSource) {
    let reach = |p: [f64; 2], r: f64| p[0].hypot(p[1]) + r;
    match &d.geometry {
        Geometry::Sphere(p) => (p.shell_radius, FootprintSource::BodyRadius),
        Geometry::Ballbot(p) => (p.ball_radius, FootprintSource::BodyRadius),
        Geometry::Caster(p) => (
            p.mount_radius + p.eccentricity.abs() + p.wheel_radius,
            FootprintSource::WheelReach,
        ),
        Geometry::Omni(w) => (
            w.iter()
                .map(|w| reach(w.position, w.radius))
                .fold(0.0, f64::max),
            FootprintSource::WheelReach,
        ),
        Geometry::Swerve { modules, .. } => (
            modules
                .iter()
                .map(|m| reach(m.position, m.wheel_radius))
                .fold(0.0, f64::max),
            FootprintSource::WheelReach,
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sphere_is_its_shell_and_swerve4_reaches_past_its_modules() {
        let s = RobotDescription::preset("sphere-omni").unwrap();
        assert_eq!(footprint_radius(&s), (0.15, FootprintSource::BodyRadius));
        let w = RobotDescription::preset("swerve4").unwrap();
        let Geometry::Swerve { modules, .. } = &w.geometry else {
            panic!("swerve4 is a swerve")
        };
        let (f, src) = footprint_radius(&w);
        assert_eq!(src, FootprintSource::WheelReach);
        for m in modules {
            assert!(f >= m.position[0].hypot(m.position[1]) + m.wheel_radius - 1e-15);
        }
    }
}
