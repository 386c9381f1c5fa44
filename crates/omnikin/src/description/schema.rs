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
use crate::{GeometryError, Kind, Real, Robot};

type Err<'a> = &'a dyn Fn(Option<usize>, &str, String) -> DescriptionError;
/// Checks one value against a plausible range: `(field, value, (min, max), unit)`.
type Range<'a> = &'a dyn Fn(&str, f64, (f64, f64), &str) -> Result<(), DescriptionError>;

#[derive(Deserialize)]
pub(super) struct Header {
    pub(super) kind: Option<String>,
    /// Checked by `super::footprint`.
    pub(super) footprint_radius: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File<G> {
    #[allow(dead_code)]
    kind: String,
    name: Option<String>,
    #[allow(dead_code)]
    description: Option<String>,
    /// Read from the `Header` and checked by `super::footprint`.
    #[allow(dead_code)]
    footprint_radius: Option<f64>,
    geometry: G,
    #[serde(default)]
    limits: Limits,
    /// Parsed and checked per kind by `super::dynamics`.
    #[allow(dead_code)]
    dynamics: Option<toml::Value>,
    /// Parsed and checked by `super::events`.
    #[allow(dead_code)]
    events: Option<toml::Value>,
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
    wheels: std::vec::Vec<toml::Spanned<OmniWheelFile>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OmniWheelFile {
    /// A list, not `[f64; 2]`: a fixed-size array silently dropped a third value.
    position: List,
    drive_angle_deg: f64,
    roller_angle_deg: f64,
    radius: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SwerveGeometry {
    #[serde(default)]
    optimize_steering: bool,
    modules: std::vec::Vec<toml::Spanned<SwerveModuleFile>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SwerveModuleFile {
    /// A list, checked to hold two values (see `OmniWheelFile::position`).
    position: List,
    wheel_radius: f64,
}

/// The `kind` values a robot file may hold, for error messages: `one of "sphere-omni", …`,
/// from [`Kind::ALL`].
pub(super) fn kinds() -> String {
    let names: std::vec::Vec<String> = Kind::ALL
        .iter()
        .map(|k| format!("\"{}\"", k.name()))
        .collect();
    format!("one of {}", names.join(", "))
}

/// Parses the `[geometry]` and `[limits]` of a file of kind `kind` and validates the model:
/// `(name, geometry, limits)`.
pub(super) fn parse(
    text: &str,
    source_name: &str,
    kind: Kind,
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
    // A position: exactly [x, y].
    let two = |l: &List, field: &str| -> Result<[f64; 2], DescriptionError> {
        match l.get_ref().as_slice() {
            &[x, y] => Ok([x, y]),
            v => Err(err(
                Some(line_of(l.span().start)),
                field,
                format!("expected 2 values [x, y] (m, robot frame), got {}", v.len()),
            )),
        }
    };
    Ok(match kind {
        Kind::Sphere => {
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
            SphereOmni::new(p).map_err(|e| geometry_error(e, source_name, kind))?;
            (f.name, Geometry::Sphere(p), f.limits)
        }
        Kind::Ballbot => {
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
            Ballbot::new(p).map_err(|e| geometry_error(e, source_name, kind))?;
            (f.name, Geometry::Ballbot(p), f.limits)
        }
        Kind::Caster => {
            let f: File<CasterGeometry> = toml::from_str(text).map_err(de_err)?;
            let g = &f.geometry;
            let p = CasterParams {
                mount_radius: g.mount_radius,
                eccentricity: g.eccentricity,
                wheel_radius: g.wheel_radius,
                mount_angles: three(&g.mount_angles_deg, "geometry.mount_angles_deg")?
                    .map(f64::to_radians),
            };
            Caster3::new(p).map_err(|e| geometry_error(e, source_name, kind))?;
            (f.name, Geometry::Caster(p), f.limits)
        }
        Kind::Omni => {
            let f: File<OmniGeometry> = toml::from_str(text).map_err(de_err)?;
            let lines: std::vec::Vec<usize> = f
                .geometry
                .wheels
                .iter()
                .map(|w| line_of(w.span().start))
                .collect();
            count(lines.len(), 3, "wheels", source_name, kind)?;
            let mut positions = std::vec::Vec::with_capacity(lines.len());
            for (i, w) in f.geometry.wheels.iter().enumerate() {
                let w = w.get_ref();
                let at = |key: &str| format!("geometry.wheels[{i}].{key}");
                let position = two(&w.position, &at("position"))?;
                positions.push(position);
                angle_in(
                    w.roller_angle_deg,
                    90.0,
                    false,
                    "0 for omni wheels, ±45 for mecanum: rollers across the drive direction \
                     cannot push",
                )
                .map_err(|rule| err(Some(lines[i]), &at("roller_angle_deg"), rule))?;
                angle_in(
                    w.drive_angle_deg,
                    720.0,
                    true,
                    "a direction from robot +x, counter-clockwise, within two turns",
                )
                .map_err(|rule| err(Some(lines[i]), &at("drive_angle_deg"), rule))?;
                wheel_lengths(position, w.radius, "radius")
                    .map_err(|(key, rule)| err(Some(lines[i]), &at(key), rule))?;
            }
            // The positions' own lines: the error names both values where they are written.
            let position_lines: std::vec::Vec<usize> = f
                .geometry
                .wheels
                .iter()
                .map(|w| line_of(w.get_ref().position.span().start))
                .collect();
            distinct(&positions, "wheels", &position_lines, err)?;
            let wheels: std::vec::Vec<OmniWheel<f64>> = f
                .geometry
                .wheels
                .iter()
                .zip(&positions)
                .map(|(w, &position)| {
                    let w = w.get_ref();
                    OmniWheel::at_angle(
                        position,
                        w.drive_angle_deg.to_radians(),
                        w.roller_angle_deg.to_radians(),
                        w.radius,
                    )
                })
                .collect();
            Robot::<f64>::omni(&wheels)
                .map_err(|e| with_line(geometry_error(e, source_name, kind), &lines))?;
            (f.name, Geometry::Omni(wheels), f.limits)
        }
        Kind::Swerve => {
            let f: File<SwerveGeometry> = toml::from_str(text).map_err(de_err)?;
            let lines: std::vec::Vec<usize> = f
                .geometry
                .modules
                .iter()
                .map(|m| line_of(m.span().start))
                .collect();
            count(lines.len(), 2, "modules", source_name, kind)?;
            let mut modules = std::vec::Vec::with_capacity(lines.len());
            for (i, m) in f.geometry.modules.iter().enumerate() {
                let m = m.get_ref();
                let at = |key: &str| format!("geometry.modules[{i}].{key}");
                let position = two(&m.position, &at("position"))?;
                wheel_lengths(position, m.wheel_radius, "wheel_radius")
                    .map_err(|(key, rule)| err(Some(lines[i]), &at(key), rule))?;
                modules.push(SwerveModule {
                    position,
                    wheel_radius: m.wheel_radius,
                });
            }
            let positions: std::vec::Vec<[f64; 2]> = modules.iter().map(|m| m.position).collect();
            let position_lines: std::vec::Vec<usize> = f
                .geometry
                .modules
                .iter()
                .map(|m| line_of(m.get_ref().position.span().start))
                .collect();
            distinct(&positions, "modules", &position_lines, err)?;
            let optimize = f.geometry.optimize_steering;
            Robot::<f64>::swerve(&modules, optimize)
                .map_err(|e| with_line(geometry_error(e, source_name, kind), &lines))?;
            (f.name, Geometry::Swerve { modules, optimize }, f.limits)
        }
    })
}

/// Checks an angle in degrees from a robot file: finite and within `±max` (inclusive when
/// `inclusive`); the rule quotes `what` the angle is.
fn angle_in(v: f64, max: f64, inclusive: bool, what: &str) -> Result<(), String> {
    let ok = v.is_finite()
        && if inclusive {
            v.abs() <= max
        } else {
            v.abs() < max
        };
    if ok {
        return Ok(());
    }
    let (open, close) = if inclusive { ("[", "]") } else { ("(", ")") };
    Err(format!(
        "{} degrees is outside {open}-{max}, {max}{close} ({what})",
        num(v)
    ))
}

/// Checks one wheel's (module's) position and radius against [`LENGTH_RANGE`] before any
/// model is built, so that a 1e308 m radius is reported as implausible rather than as the
/// ill-conditioned matrix it makes: `Err((key, rule))`.
fn wheel_lengths(
    position: [f64; 2],
    radius: f64,
    radius_key: &'static str,
) -> Result<(), (&'static str, String)> {
    let (min, max) = LENGTH_RANGE;
    if !(position[0].is_finite() && position[1].is_finite()) {
        return Err((
            "position",
            format!("must be finite (got [{}, {}])", position[0], position[1]),
        ));
    }
    let p = position[0].hypot(position[1]);
    if p > max {
        return Err((
            "position",
            format!(
                "is {} m from the robot origin, outside the plausible range [0, {}] m \
                 (omnikin::description)",
                num(p),
                num(max)
            ),
        ));
    }
    if !radius.is_finite() {
        return Err((radius_key, format!("must be finite (got {radius})")));
    }
    if radius <= 0.0 {
        return Err((radius_key, format!("must be > 0 (got {})", num(radius))));
    }
    if !(min..=max).contains(&radius) {
        return Err((
            radius_key,
            format!(
                "{} m is outside the plausible range [{}, {}] m (omnikin::description)",
                num(radius),
                num(min),
                num(max)
            ),
        ));
    }
    Ok(())
}

/// Refuses two wheels (modules) whose contact points are closer than the smallest plausible
/// length ([`LENGTH_RANGE`], 0.1 mm): two wheels cannot touch the floor at one point (a table
/// copied without editing it), and a layout that small turns encoder noise into huge yaw rates.
fn distinct(
    positions: &[[f64; 2]],
    list: &str,
    lines: &[usize],
    err: Err<'_>,
) -> Result<(), DescriptionError> {
    for j in 1..positions.len() {
        for i in 0..j {
            let d = (positions[j][0] - positions[i][0]).hypot(positions[j][1] - positions[i][1]);
            if d < LENGTH_RANGE.0 {
                return Err(err(
                    Some(lines[j]),
                    &format!("geometry.{list}[{j}].position"),
                    format!(
                        "is {} m from geometry.{list}[{i}].position (line {}): contact points \
                         must be at least {} m apart (two {list} cannot touch the floor at one \
                         point; omnikin::description)",
                        num(d),
                        lines[i],
                        num(LENGTH_RANGE.0)
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Refuses a wheel (module) count outside `min..=MAX_WHEELS` before any per-wheel check (a
/// 1 MiB file of 15 000 wheels is not compared pairwise): the model's own count error.
fn count(
    n: usize,
    min: usize,
    field: &'static str,
    source_name: &str,
    kind: Kind,
) -> Result<(), DescriptionError> {
    if (min..=crate::MAX_WHEELS).contains(&n) {
        return Ok(());
    }
    let e = GeometryError::WheelCount {
        field,
        got: n,
        min,
        max: crate::MAX_WHEELS,
    };
    Err(geometry_error(e, source_name, kind))
}

/// Adds the line of the wheel (module) a model error names (`geometry.wheels[i]…`).
fn with_line(mut e: DescriptionError, lines: &[usize]) -> DescriptionError {
    let index = e
        .field
        .split_once('[')
        .and_then(|(_, rest)| rest.split_once(']'))
        .and_then(|(i, _)| i.parse::<usize>().ok());
    if let Some(&line) = index.and_then(|i| lines.get(i)) {
        e.line = Some(line);
    }
    e
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
        // Their lengths are fixed fields, checked below.
        Geometry::Sphere(_) | Geometry::Ballbot(_) | Geometry::Caster(_) => {}
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
    let kind = d.robot_kind();
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
fn geometry_error(e: GeometryError, source_name: &str, kind: Kind) -> DescriptionError {
    let core_field = match e {
        GeometryError::NonFinite { field }
        | GeometryError::NotPositive { field, .. }
        | GeometryError::AngleOutOfRange { field, .. } => field,
        GeometryError::WheelTooLarge { .. } => "wheel_radius",
        GeometryError::DeadWheel { .. } => "roller_angle",
        GeometryError::IllConditioned { .. } => "",
        GeometryError::WheelCount { field, .. } => field,
    };
    let floor_layout = match kind {
        Kind::Omni | Kind::Swerve => true,
        Kind::Sphere | Kind::Ballbot | Kind::Caster => false,
    };
    if floor_layout {
        // The core's generic "(wheels nearly coplanar or parallel)" is about the paper robots'
        // 3-D wheel axes; for a floor layout say what the rank test found.
        let rule = match e {
            GeometryError::IllConditioned {
                what,
                condition,
                max,
            } => format!(
                "rank-deficient layout: {what} (condition number {} exceeds {})",
                num(condition),
                num(max)
            ),
            _ => e.to_string(),
        };
        return DescriptionError {
            source_name: source_name.to_string(),
            line: None,
            field: drive_key(&e, core_field, kind),
            rule,
        };
    }
    let base = core_field.split('[').next().unwrap_or(core_field);
    let index = core_field.strip_prefix(base).unwrap_or("");
    let key = match (kind, base) {
        (_, "") => match kind {
            Kind::Sphere => "geometry (tilt_deg, roller_angle_deg, azimuths_deg)",
            Kind::Ballbot => "geometry.azimuths_deg",
            Kind::Caster | Kind::Omni | Kind::Swerve => "geometry.mount_angles_deg",
        }
        .to_string(),
        (_, "tilt" | "roller_angle" | "azimuths" | "zenith" | "mount_angles") => {
            format!("geometry.{base}_deg")
        }
        (Kind::Sphere, "wheel_radius") => {
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
fn drive_key(e: &GeometryError, core_field: &str, kind: Kind) -> String {
    let list = if kind == Kind::Omni {
        "wheels"
    } else {
        "modules"
    };
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
