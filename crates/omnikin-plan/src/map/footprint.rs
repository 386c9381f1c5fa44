//! The footprint radius of a robot: the robot file's `footprint_radius`, else from its
//! geometry (when `--footprint-radius` is not given).
//!
//! The geometry's default is the smallest disk about the robot's centre that holds what the
//! geometry knows of the robot: the sphere's shell and the ballbot's ball (their radius), and for wheeled
//! bases the outermost wheel contact plus its wheel radius (a caster's mount radius, caster
//! offset and wheel radius). A chassis wider than its wheels is not in the robot file, so for
//! wheeled bases this is a lower bound: give the real radius with `--footprint-radius`.

use omnikin::description::{FOOTPRINT_SLACK, Geometry, LENGTH_RANGE, RobotDescription};

use super::MapError;
use crate::error::num;

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

/// The footprint radius (m) to plan with and where it came from: `given` (the user's
/// `--footprint-radius`, the API's argument) checked by the rule the robot file's key obeys — a
/// finite length in [`LENGTH_RANGE`] and at least the geometry's reach, so that a map's checks
/// cannot pass a robot whose shell or wheels touch an obstacle — else [`footprint_radius`].
///
/// # Errors
/// [`MapError`] named after `flag` with the value, the rule and the geometry's reach.
pub fn checked_footprint(
    d: &RobotDescription,
    given: Option<f64>,
    flag: &str,
) -> Result<(f64, FootprintSource), MapError> {
    let Some(f) = given else {
        return Ok(footprint_radius(d));
    };
    let (min, max) = LENGTH_RANGE;
    if !(f.is_finite() && (min..=max).contains(&f)) {
        return Err(MapError::at(
            flag,
            None,
            format!(
                "{} m is outside the plausible range [{}, {}] m (a radius in metres)",
                num(f),
                num(min),
                num(max)
            ),
        ));
    }
    let reach = d.geometry_reach();
    if f < reach - FOOTPRINT_SLACK {
        return Err(MapError::at(
            flag,
            None,
            format!(
                "{} m is smaller than the robot's own geometry ({} m: {}); the footprint is a \
                 disk about the centre holding the whole robot",
                num(f),
                num(reach),
                match d.geometry {
                    Geometry::Sphere(_) => "the shell radius",
                    Geometry::Ballbot(_) => "the ball radius",
                    _ => "the outermost wheel's distance from the centre plus its wheel radius",
                }
            ),
        ));
    }
    Ok((f, FootprintSource::Given))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_given_radius_obeys_the_robot_files_rule() {
        let k = RobotDescription::preset("kiwi").unwrap();
        let reach = k.geometry_reach();
        assert_eq!(
            checked_footprint(&k, Some(reach + 0.1), "--footprint-radius").unwrap(),
            (reach + 0.1, FootprintSource::Given)
        );
        assert_eq!(
            checked_footprint(&k, None, "--footprint-radius").unwrap(),
            footprint_radius(&k)
        );
        for bad in [1e-300, reach * 0.5, 1e300, f64::NAN, -1.0, 0.0] {
            let e = checked_footprint(&k, Some(bad), "--footprint-radius").unwrap_err();
            let text = e.to_string();
            assert!(text.starts_with("--footprint-radius: "), "{text}");
            assert!(text.len() < 260, "a short message: {text}");
        }
        let e = checked_footprint(&k, Some(1e-300), "--footprint-radius").unwrap_err();
        assert!(e.message.contains("1e-300 m"), "{e}");
        let e = checked_footprint(&k, Some(reach * 0.5), "--footprint-radius").unwrap_err();
        assert!(
            e.message.contains("smaller than the robot's own geometry"),
            "{e}"
        );
    }

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
