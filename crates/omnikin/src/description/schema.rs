//! The robot-file schema of every kind: the `[geometry]` tables as the TOML parser sees them,
//! their conversion to validated models, and the mapping of a model's field names back to
//! TOML keys. The one place the description loader knows the kinds (see
//! `crate::drive::robot` for the rest of "adding a robot kind").

use std::format;
use std::string::{String, ToString};

use serde::Deserialize;

use super::{DescriptionError, Geometry, LENGTH_RANGE, Limits, RobotDescription, num};
use crate::ballbot::{Ballbot, BallbotParams};
use crate::caster::{Caster3, CasterParams};
use crate::drive::omni::OmniWheel;
use crate::drive::swerve::SwerveModule;
use crate::sphere::{SphereOmni, SphereParams};
use crate::{GeometryError, Real, Robot};

type Err<'a> = &'a dyn Fn(Option<usize>, &str, String) -> DescriptionError;
/// Checks one value against a plausible range: `(field, value, (min, max), unit)`.
type Range<'a> = &'a dyn Fn(&str, f64, (f64, f64), &str) -> Result<(), DescriptionError>;

#[derive(Deserialize)]
pub(super) struct Header {
    pub(super) kind: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File<G> {
    #[allow(dead_code)]
    kind: String,
    name: Option<String>,
    #[allow(dead_code)]
    description: Option<String>,
    geometry: G,
    #[serde(default)]
    limits: Limits,
    /// Parsed and checked per kind by `super::dynamics`.
    #[allow(dead_code)]
    dynamics: Option<toml::Value>,
}

/// One value for all three wheels, or one per wheel (a list, whose length is checked after
/// parsing: a fixed-size array would silently drop a fourth value).
#[derive(Deserialize)]
#[serde(
    untagged,
    expecting = "a radius in m, or a list of three radii (one per wheel)"
)]
enum PerWheel {
    All(f64),
    Each(std::vec::Vec<f64>),
}

/// A list in the file, with where it is (for the line of a wrong-length error).
type List = toml::Spanned<std::vec::Vec<f64>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereGeometry {
    shell_radius: f64,
    wheel_radius: toml::Spanned<PerWheel>,
    tilt_deg: f64,
    roller_angle_deg: f64,
    azimuths_deg: List,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BallbotGeometry {
    ball_radius: f64,
    wheel_radius: f64,
    zenith_deg: f64,
    azimuths_deg: List,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CasterGeometry {
    mount_radius: f64,
    eccentricity: f64,
    wheel_radius: f64,
    mount_angles_deg: List,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OmniGeometry {
    wheels: std::vec::Vec<OmniWheelFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OmniWheelFile {
    position: [f64; 2],
    drive_angle_deg: f64,
    roller_angle_deg: f64,
    radius: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SwerveGeometry {
    #[serde(default)]
    optimize_steering: bool,
    modules: std::vec::Vec<SwerveModuleFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SwerveModuleFile {
    position: [f64; 2],
    wheel_radius: f64,
}

pub(super) const KINDS: &str =
    "one of \"sphere-omni\", \"ballbot\", \"caster3\", \"omni\", \"swerve\"";

/// Parses the `[geometry]` and `[limits]` of a file of kind `kind` and validates the model:
/// `(name, geometry, limits)`.
pub(super) fn parse(
    text: &str,
    source_name: &str,
    kind: &str,
    err: Err<'_>,
    de_err: &dyn Fn(toml::de::Error) -> DescriptionError,
) -> Result<(Option<String>, Geometry, Limits), DescriptionError> {
    let line_of = |offset: usize| 1 + text[..offset.min(text.len())].matches('\n').count();
    // Exactly three values, one per wheel: the error names the key and its line.
    let three = |l: &List, field: &str| -> Result<[f64; 3], DescriptionError> {
        match l.get_ref().as_slice() {
            &[a, b, c] => Ok([a, b, c]),
            v => Err(err(
                Some(line_of(l.span().start)),
                field,
                format!("expected 3 values (one per wheel), got {}", v.len()),
            )),
        }
    };
    Ok(match kind {
        "sphere-omni" => {
            let f: File<SphereGeometry> = toml::from_str(text).map_err(de_err)?;
            let g = &f.geometry;
            let wheel_radius = match g.wheel_radius.get_ref() {
                PerWheel::All(r) => [*r; 3],
                PerWheel::Each(v) => match v.as_slice() {
                    &[a, b, c] => [a, b, c],
                    v => {
                        return Err(err(
                            Some(line_of(g.wheel_radius.span().start)),
                            "geometry.wheel_radius",
                            format!(
                                "expected a radius in m, or a list of three radii (one per \
                                     wheel); got {} values",
                                v.len()
                            ),
                        ));
                    }
                },
            };
            let p = SphereParams {
                shell_radius: g.shell_radius,
                wheel_radius,
                tilt: g.tilt_deg.to_radians(),
                roller_angle: g.roller_angle_deg.to_radians(),
                azimuths: three(&g.azimuths_deg, "geometry.azimuths_deg")?.map(f64::to_radians),
            };
            SphereOmni::new(p).map_err(|e| geometry_error(e, source_name, "sphere-omni"))?;
            (f.name, Geometry::Sphere(p), f.limits)
        }
        "ballbot" => {
            let f: File<BallbotGeometry> = toml::from_str(text).map_err(de_err)?;
            let g = &f.geometry;
            if !(g.zenith_deg > 0.0 && g.zenith_deg < 90.0) {
                return Err(err(
                    None,
                    "geometry.zenith_deg",
                    format!("must be strictly between 0 and 90 (got {})", g.zenith_deg),
                ));
            }
            let p = BallbotParams {
                ball_radius: g.ball_radius,
                wheel_radius: g.wheel_radius,
                zenith: g.zenith_deg.to_radians(),
                azimuths: three(&g.azimuths_deg, "geometry.azimuths_deg")?.map(f64::to_radians),
            };
            Ballbot::new(p).map_err(|e| geometry_error(e, source_name, "ballbot"))?;
            (f.name, Geometry::Ballbot(p), f.limits)
        }
        "caster3" => {
            let f: File<CasterGeometry> = toml::from_str(text).map_err(de_err)?;
            let g = &f.geometry;
            let p = CasterParams {
                mount_radius: g.mount_radius,
                eccentricity: g.eccentricity,
                wheel_radius: g.wheel_radius,
                mount_angles: three(&g.mount_angles_deg, "geometry.mount_angles_deg")?
                    .map(f64::to_radians),
            };
            Caster3::new(p).map_err(|e| geometry_error(e, source_name, "caster3"))?;
            (f.name, Geometry::Caster(p), f.limits)
        }
        "omni" => {
            let f: File<OmniGeometry> = toml::from_str(text).map_err(de_err)?;
            let wheels: std::vec::Vec<OmniWheel<f64>> = f
                .geometry
                .wheels
                .iter()
                .map(|w| {
                    OmniWheel::at_angle(
                        w.position,
                        w.drive_angle_deg.to_radians(),
                        w.roller_angle_deg.to_radians(),
                        w.radius,
                    )
                })
                .collect();
            Robot::<f64>::omni(&wheels).map_err(|e| geometry_error(e, source_name, "omni"))?;
            (f.name, Geometry::Omni(wheels), f.limits)
        }
        "swerve" => {
            let f: File<SwerveGeometry> = toml::from_str(text).map_err(de_err)?;
            let modules: std::vec::Vec<SwerveModule<f64>> = f
                .geometry
                .modules
                .iter()
                .map(|m| SwerveModule {
                    position: m.position,
                    wheel_radius: m.wheel_radius,
                })
                .collect();
            let optimize = f.geometry.optimize_steering;
            Robot::<f64>::swerve(&modules, optimize)
                .map_err(|e| geometry_error(e, source_name, "swerve"))?;
            (f.name, Geometry::Swerve { modules, optimize }, f.limits)
        }
        other => {
            return Err(err(
                None,
                "kind",
                format!("unknown robot kind \"{other}\"; must be {KINDS}"),
            ));
        }
    })
}

/// Checks every length of `geometry` against [`LENGTH_RANGE`] (`range` reports one).
pub(super) fn check_lengths(
    geometry: &Geometry,
    err: Err<'_>,
    range: Range<'_>,
) -> Result<(), DescriptionError> {
    let mut owned: std::vec::Vec<(String, f64)> = std::vec::Vec::new();
    match geometry {
        Geometry::Omni(w) => {
            for (i, w) in w.iter().enumerate() {
                owned.push((format!("geometry.wheels[{i}].radius"), w.radius));
                let p = w.position[0].hypot(w.position[1]);
                if p.is_nan() || p > LENGTH_RANGE.1 {
                    return Err(err(
                        None,
                        &format!("geometry.wheels[{i}].position"),
                        format!(
                            "is {} m from the robot origin, outside the plausible range \
                                 [0, {}] m (omnikin::description)",
                            num(p),
                            num(LENGTH_RANGE.1)
                        ),
                    ));
                }
            }
        }
        Geometry::Swerve { modules, .. } => {
            for (i, m) in modules.iter().enumerate() {
                owned.push((
                    format!("geometry.modules[{i}].wheel_radius"),
                    m.wheel_radius,
                ));
                let p = m.position[0].hypot(m.position[1]);
                if p.is_nan() || p > LENGTH_RANGE.1 {
                    return Err(err(
                        None,
                        &format!("geometry.modules[{i}].position"),
                        format!(
                            "is {} m from the robot origin, outside the plausible range \
                                 [0, {}] m (omnikin::description)",
                            num(p),
                            num(LENGTH_RANGE.1)
                        ),
                    ));
                }
            }
        }
        _ => {}
    }
    for (field, v) in &owned {
        range(field, *v, LENGTH_RANGE, "m")?;
    }
    let lengths: &[(&str, f64)] = match geometry {
        Geometry::Sphere(p) => &[
            ("geometry.shell_radius", p.shell_radius),
            ("geometry.wheel_radius (wheel 1)", p.wheel_radius[0]),
            ("geometry.wheel_radius (wheel 2)", p.wheel_radius[1]),
            ("geometry.wheel_radius (wheel 3)", p.wheel_radius[2]),
        ],
        Geometry::Ballbot(p) => &[
            ("geometry.ball_radius", p.ball_radius),
            ("geometry.wheel_radius", p.wheel_radius),
        ],
        Geometry::Caster(p) => &[
            ("geometry.mount_radius", p.mount_radius),
            ("geometry.eccentricity", p.eccentricity),
            ("geometry.wheel_radius", p.wheel_radius),
        ],
        Geometry::Omni(_) | Geometry::Swerve { .. } => &[],
    };
    for &(field, v) in lengths {
        range(field, v, LENGTH_RANGE, "m")?;
    }
    Ok(())
}

/// The model of a validated description in scalar type `T`.
pub(super) fn build<T: Real>(d: &RobotDescription) -> Result<Robot<T>, DescriptionError> {
    let c = |x: f64| T::of(x);
    let kind = d.kind();
    let wrap = |e| geometry_error(e, &d.source_name, kind);
    Ok(match &d.geometry {
        Geometry::Omni(wheels) => {
            let w: std::vec::Vec<OmniWheel<T>> = wheels
                .iter()
                .map(|w| OmniWheel {
                    position: w.position.map(c),
                    drive: w.drive.map(c),
                    roller_angle: c(w.roller_angle),
                    radius: c(w.radius),
                })
                .collect();
            Robot::omni(&w).map_err(wrap)?
        }
        Geometry::Swerve { modules, optimize } => {
            let m: std::vec::Vec<SwerveModule<T>> = modules
                .iter()
                .map(|m| SwerveModule {
                    position: m.position.map(c),
                    wheel_radius: c(m.wheel_radius),
                })
                .collect();
            Robot::swerve(&m, *optimize).map_err(wrap)?
        }
        &Geometry::Sphere(p) => Robot::Sphere(
            SphereOmni::new(SphereParams {
                shell_radius: c(p.shell_radius),
                wheel_radius: p.wheel_radius.map(c),
                tilt: c(p.tilt),
                roller_angle: c(p.roller_angle),
                azimuths: p.azimuths.map(c),
            })
            .map_err(wrap)?,
        ),
        &Geometry::Ballbot(p) => Robot::Ballbot(
            Ballbot::new(BallbotParams {
                ball_radius: c(p.ball_radius),
                wheel_radius: c(p.wheel_radius),
                zenith: c(p.zenith),
                azimuths: p.azimuths.map(c),
            })
            .map_err(wrap)?,
        ),
        &Geometry::Caster(p) => Robot::Caster(
            Caster3::new(CasterParams {
                mount_radius: c(p.mount_radius),
                eccentricity: c(p.eccentricity),
                wheel_radius: c(p.wheel_radius),
                mount_angles: p.mount_angles.map(c),
            })
            .map_err(wrap)?,
        ),
    })
}

/// The 1-based wheel an error is about: from a `[i]` index or the error's wheel number.
fn wheel_of(index: &str, e: &GeometryError) -> usize {
    match e {
        GeometryError::WheelTooLarge { wheel, .. } => *wheel,
        _ => index
            .trim_matches(['[', ']'])
            .parse::<usize>()
            .map_or(1, |i| i + 1),
    }
}

/// Maps a core geometry error to the TOML key it is about.
fn geometry_error(e: GeometryError, source_name: &str, kind: &str) -> DescriptionError {
    let core_field = match e {
        GeometryError::NonFinite { field }
        | GeometryError::NotPositive { field, .. }
        | GeometryError::AngleOutOfRange { field, .. } => field,
        GeometryError::WheelTooLarge { .. } => "wheel_radius",
        GeometryError::DeadWheel { .. } => "roller_angle",
        GeometryError::IllConditioned { .. } => "",
        GeometryError::WheelCount { field, .. } => field,
    };
    if kind == "omni" || kind == "swerve" {
        return DescriptionError {
            source_name: source_name.to_string(),
            line: None,
            field: drive_key(&e, core_field, kind),
            rule: e.to_string(),
        };
    }
    let base = core_field.split('[').next().unwrap_or(core_field);
    let index = core_field.strip_prefix(base).unwrap_or("");
    let key = match (kind, base) {
        (_, "") => match kind {
            "sphere-omni" => "geometry (tilt_deg, roller_angle_deg, azimuths_deg)",
            "ballbot" => "geometry.azimuths_deg",
            _ => "geometry.mount_angles_deg",
        }
        .to_string(),
        (_, "tilt" | "roller_angle" | "azimuths" | "zenith" | "mount_angles") => {
            format!("geometry.{base}_deg")
        }
        ("sphere-omni", "wheel_radius") => {
            format!("geometry.wheel_radius (wheel {})", wheel_of(index, &e))
        }
        _ => format!("geometry.{base}"),
    };
    DescriptionError {
        source_name: source_name.to_string(),
        line: None,
        field: key,
        rule: e.to_string(),
    }
}

/// The TOML key of an omni/swerve geometry error: the core names `wheels[i].drive`,
/// `wheels[i].roller_angle`, `modules[i].position`…, the file `geometry.wheels[i].drive_angle_deg`.
fn drive_key(e: &GeometryError, core_field: &str, kind: &str) -> String {
    let list = if kind == "omni" { "wheels" } else { "modules" };
    if let GeometryError::DeadWheel {
        wheel, quantity, ..
    } = e
    {
        let what = if *quantity == "|drive|" {
            "drive_angle_deg"
        } else {
            "roller_angle_deg"
        };
        return format!("geometry.{list}[{}].{what}", wheel.saturating_sub(1));
    }
    if core_field.is_empty() {
        return format!("geometry.{list}");
    }
    let key = core_field
        .replace(".drive", ".drive_angle_deg")
        .replace(".roller_angle", ".roller_angle_deg");
    format!("geometry.{key}")
}
