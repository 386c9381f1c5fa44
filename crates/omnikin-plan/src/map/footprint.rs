//! The footprint radius of a robot: the robot file's `footprint_radius`, else from its
//! geometry (when `--footprint-radius` is not given).
//!
//! The geometry's default is the smallest disk about the robot's centre that holds what the
//! geometry knows of the robot: the sphere's shell and the ballbot's ball (their radius), and for wheeled
//! bases the outermost wheel contact plus its wheel radius (a caster's mount radius, caster
//! offset and wheel radius). A chassis wider than its wheels is not in the robot file, so for
//! wheeled bases this is a lower bound: give the real radius with `--footprint-radius`.

use omnikin::description::{Geometry, RobotDescription};

/// Where a footprint radius came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FootprintSource {
    /// Given by the user (`--footprint-radius`, the API's argument).
    Given,
    /// The robot file's `footprint_radius`.
    RobotFile,
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
            Self::RobotFile => "the robot file's footprint_radius",
            Self::BodyRadius => "the robot's shell/ball radius",
            Self::WheelReach => {
                "the outermost wheel's reach (a lower bound: the chassis may be wider)"
            }
        }
    }
}

/// The footprint radius of `d` (m) and where it came from: the robot file's
/// `footprint_radius`, else the geometry's reach
/// ([`RobotDescription::geometry_reach`](omnikin::description::RobotDescription::geometry_reach)).
pub fn footprint_radius(d: &RobotDescription) -> (f64, FootprintSource) {
    if let Some(f) = d.footprint_radius {
        return (f, FootprintSource::RobotFile);
    }
    let source = match d.geometry {
        Geometry::Sphere(_) | Geometry::Ballbot(_) => FootprintSource::BodyRadius,
        _ => FootprintSource::WheelReach,
    };
    (d.geometry_reach(), source)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_robot_files_radius_comes_before_the_geometrys() {
        let s = RobotDescription::preset("sphere-omni").unwrap();
        assert_eq!(s.footprint_radius, Some(0.15));
        assert_eq!(footprint_radius(&s), (0.15, FootprintSource::RobotFile));
        let mut k = RobotDescription::preset("kiwi").unwrap();
        assert_eq!(k.footprint_radius, None);
        assert_eq!(
            footprint_radius(&k),
            (k.geometry_reach(), FootprintSource::WheelReach)
        );
        k.footprint_radius = Some(0.4);
        assert_eq!(footprint_radius(&k), (0.4, FootprintSource::RobotFile));
    }
}
