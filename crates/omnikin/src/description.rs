//! Robot description files (TOML) and the compiled-in presets (feature `std`).
//!
//! A description names the robot's `kind`, its `[geometry]` and optional motor `[limits]`:
//!
//! ```toml
//! kind = "sphere-omni"            # or "ballbot", "caster3", "omni", "swerve"
//! name = "my-sphere"              # optional, defaults to the kind
//!
//! [geometry]                      # keys depend on the kind, see robots/*.toml
//! shell_radius = 0.15             # m
//! wheel_radius = 0.07             # m (or one per wheel: [0.07, 0.0702, 0.0699])
//! tilt_deg = 45.0                 # angles in degrees only where the key says `_deg`
//! roller_angle_deg = 45.0
//! azimuths_deg = [0.0, 120.0, 240.0]
//!
//! [limits]                        # optional, every key optional
//! max_wheel_rate = 12.0           # rad/s
//! max_wheel_accel = 60.0          # rad/s²
//! ```
//!
//! Loading validates everything and reports the first problem as a [`DescriptionError`] that
//! names the file, the line (for syntax and schema errors) or the field, and the rule broken:
//! unknown keys, missing fields, wrong types, a list without exactly three values (one per
//! wheel), non-positive lengths, a wheel larger than the shell, out-of-range angles, singular
//! geometry, and values that are finite but implausible: lengths outside [`LENGTH_RANGE`],
//! motor limits outside [`MOTOR_RATE_RANGE`] / [`MOTOR_ACCEL_RANGE`], a name longer than
//! [`MAX_NAME_CHARS`] or with control characters. A leading UTF-8 byte-order mark is skipped.

use std::format;
use std::string::{String, ToString};

use serde::Deserialize;

use crate::ballbot::{Ballbot, BallbotParams};
use crate::caster::{Caster3, CasterParams};
use crate::drive::omni::OmniWheel;
use crate::drive::swerve::SwerveModule;
use crate::sphere::{SphereOmni, SphereParams};
use crate::{GeometryError, Kind, Real, Robot};

/// The compiled-in presets: `(name, TOML text)`, identical to the files in `robots/`.
pub const PRESETS: [(&str, &str); 7] = [
    (
        "sphere-omni",
        include_str!("../../../robots/sphere-omni.toml"),
    ),
    ("ballbot", include_str!("../../../robots/ballbot.toml")),
    ("caster3", include_str!("../../../robots/caster3.toml")),
    ("kiwi", include_str!("../../../robots/kiwi.toml")),
    ("x-drive", include_str!("../../../robots/x-drive.toml")),
    ("mecanum", include_str!("../../../robots/mecanum.toml")),
    ("swerve4", include_str!("../../../robots/swerve4.toml")),
];

/// Plausible range of every length in a description (`shell_radius`, `wheel_radius`,
/// `ball_radius`, `mount_radius`, `eccentricity`), m: 0.1 mm to 10 m.
pub const LENGTH_RANGE: (f64, f64) = (1e-4, 10.0);

/// Plausible range of a motor rate limit (`limits.max_wheel_rate`, `limits.max_steer_rate`),
/// rad/s: 10⁻³ rad/s (a turn in under two hours) to 10⁵ rad/s (about 10⁶ rpm).
pub const MOTOR_RATE_RANGE: (f64, f64) = (1e-3, 1e5);

/// Plausible range of a motor acceleration limit (`limits.max_wheel_accel`,
/// `limits.max_steer_accel`), rad/s².
pub const MOTOR_ACCEL_RANGE: (f64, f64) = (1e-3, 1e7);

/// Longest robot name (`name`), in characters. Names are printable: no control characters
/// (they end up in terminal output and SVG figures).
pub const MAX_NAME_CHARS: usize = 64;

/// Characters of a bad value that an error message quotes ([`excerpt`]).
pub const MAX_QUOTED_CHARS: usize = 40;

/// `s` as an error message quotes it: whole up to [`MAX_QUOTED_CHARS`] characters, else its
/// first ones followed by `…` and the full length, so a malformed 1 GB field does not become a
/// 1 GB message.
pub fn excerpt(s: &str) -> std::borrow::Cow<'_, str> {
    match s.char_indices().nth(MAX_QUOTED_CHARS) {
        None => std::borrow::Cow::Borrowed(s),
        Some((end, _)) => std::borrow::Cow::Owned(format!("{}… ({} bytes)", &s[..end], s.len())),
    }
}

/// Largest TOML text file the tools read (robot descriptions, disturbance and sensor
/// profiles), bytes: 1 MiB. The TOML parser needs several times a file's size, so a
/// multi-gigabyte file given as a robot aborted the process instead of being refused.
pub const MAX_TOML_BYTES: usize = 1 << 20;

/// Reads a text file of at most `max` bytes (`limit` names the constant in the error: a
/// file over it is refused before it is read, a device or pipe once `max` bytes came).
///
/// # Errors
/// The I/O error, or [`std::io::ErrorKind::InvalidData`] for a file over the limit or not
/// UTF-8.
pub fn read_text_limited(
    path: &std::path::Path,
    max: usize,
    limit: &str,
) -> std::io::Result<String> {
    use std::io::Read;
    let too_large = || {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("larger than {max} bytes (the limit {limit}): is this the right file?"),
        )
    };
    let f = std::fs::File::open(path)?;
    let len = f.metadata().map(|m| m.len()).unwrap_or(0);
    if len > max as u64 {
        return Err(too_large());
    }
    let mut s = String::with_capacity(len as usize);
    f.take(max as u64 + 1).read_to_string(&mut s)?;
    if s.len() > max {
        return Err(too_large());
    }
    Ok(s)
}

/// A number for a message: plain, or `1e300` style when tiny or huge.
fn num(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && a.is_finite() && !(1e-3..1e6).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A robot description that failed to load: where, which field, which rule.
///
/// Displayed as `FILE: FIELD: RULE`, or `FILE:LINE: RULE` for syntax and schema errors (the
/// rule then names the key, e.g. "unknown field `colour`").
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{source_name}{}{}: {rule}",
    line.map(|l| format!(":{l}")).unwrap_or_default(),
    if field.is_empty() { String::new() } else { format!(": {field}") })]
pub struct DescriptionError {
    /// The file path, or `preset <name>`.
    pub source_name: String,
    /// 1-based line of the offending text, when known.
    pub line: Option<usize>,
    /// The field, as a TOML key path (`geometry.wheel_radius`), or `file` / `kind`; empty for
    /// syntax and schema errors, whose rule names the key.
    pub field: String,
    /// What is wrong and what is allowed.
    pub rule: String,
}

/// Optional motor limits from the `[limits]` table; absent keys are `None` (unlimited).
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Largest wheel (roll) rate magnitude, rad/s.
    pub max_wheel_rate: Option<f64>,
    /// Largest wheel (roll) acceleration magnitude, rad/s².
    pub max_wheel_accel: Option<f64>,
    /// Largest steer rate magnitude (caster only), rad/s.
    pub max_steer_rate: Option<f64>,
    /// Largest steer acceleration magnitude (caster only), rad/s².
    pub max_steer_accel: Option<f64>,
}

/// The geometry of a described robot, in SI units (radians), ready to build a model.
#[derive(Clone, Debug, PartialEq)]
pub enum Geometry {
    /// Spherical robot (paper 000).
    Sphere(SphereParams<f64>),
    /// Ballbot (paper 001).
    Ballbot(BallbotParams<f64>),
    /// Three-caster base (paper 003).
    Caster(CasterParams<f64>),
    /// N omni or mecanum wheels (`kind = "omni"`), in file order.
    Omni(std::vec::Vec<OmniWheel<f64>>),
    /// N centred swerve modules (`kind = "swerve"`), in file order.
    Swerve {
        /// The modules.
        modules: std::vec::Vec<SwerveModule<f64>>,
        /// `optimize_steering`: flip and reverse a module instead of turning it > 90°.
        optimize: bool,
    },
}

/// A validated robot description.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotDescription {
    /// The robot's name (the `name` key, or its kind).
    pub name: String,
    /// Where it came from: a file path or `preset <name>`.
    pub source_name: String,
    /// Geometry in SI units.
    pub geometry: Geometry,
    /// Motor limits.
    pub limits: Limits,
}

#[derive(Deserialize)]
struct Header {
    kind: Option<String>,
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

const KINDS: &str = "one of \"sphere-omni\", \"ballbot\", \"caster3\", \"omni\", \"swerve\"";

impl RobotDescription {
    /// The compiled-in preset called `name` (`sphere-omni`, `ballbot`, `caster3`, `kiwi`,
    /// `x-drive`, `mecanum`, `swerve4`).
    pub fn preset(name: &str) -> Option<Self> {
        let (_, text) = PRESETS.iter().find(|(n, _)| *n == name)?;
        // The presets are tested to load; a failure here would be a build defect.
        Self::from_toml_str(text, &format!("preset {name}")).ok()
    }

    /// A preset name or a path to a TOML file, as `ROBOT` on the command line.
    pub fn resolve(robot: &str) -> Result<Self, DescriptionError> {
        if let Some(d) = Self::preset(robot) {
            return Ok(d);
        }
        let path = std::path::Path::new(robot);
        if !path.exists() && !robot.contains(['/', '\\', '.']) {
            return Err(DescriptionError {
                source_name: robot.to_string(),
                line: None,
                field: "robot".into(),
                rule: format!(
                    "no preset or file of that name (presets: {})",
                    PRESETS.map(|(n, _)| n).join(", ")
                ),
            });
        }
        Self::load(path)
    }

    /// Loads and validates a description file.
    pub fn load(path: &std::path::Path) -> Result<Self, DescriptionError> {
        let source = path.display().to_string();
        let text = read_text_limited(
            path,
            MAX_TOML_BYTES,
            "MAX_TOML_BYTES of omnikin::description",
        )
        .map_err(|e| DescriptionError {
            source_name: source.clone(),
            line: None,
            field: "file".into(),
            rule: format!("cannot read: {e}"),
        })?;
        Self::from_toml_str(&text, &source)
    }

    /// Parses and validates a description from TOML text; `source_name` names it in errors.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self, DescriptionError> {
        // A leading UTF-8 byte-order mark (editors on Windows write one) is not content.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let err = |line, field: &str, rule: String| DescriptionError {
            source_name: source_name.to_string(),
            line,
            field: field.to_string(),
            rule,
        };
        let de_err = |e: toml::de::Error| {
            let line = e
                .span()
                .map(|s| 1 + text[..s.start.min(text.len())].matches('\n').count());
            err(line, "", e.message().trim().to_string())
        };
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
        let header: Header = toml::from_str(text).map_err(de_err)?;
        let kind = header
            .kind
            .ok_or_else(|| err(None, "kind", format!("missing; must be {KINDS}")))?;
        let d = match kind.as_str() {
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
        };
        let (name, geometry, limits) = d;
        for (field, value) in [
            ("limits.max_wheel_rate", limits.max_wheel_rate),
            ("limits.max_wheel_accel", limits.max_wheel_accel),
            ("limits.max_steer_rate", limits.max_steer_rate),
            ("limits.max_steer_accel", limits.max_steer_accel),
        ] {
            if let Some(v) = value
                && !(v.is_finite() && v > 0.0)
            {
                return Err(err(
                    None,
                    field,
                    format!("must be a finite number > 0 (got {v})"),
                ));
            }
        }
        let range = |field: &str, v: f64, (min, max): (f64, f64), unit: &str| {
            if v.is_finite() && v >= min && v <= max {
                Ok(())
            } else {
                Err(err(
                    None,
                    field,
                    format!(
                        "{} {unit} is outside the plausible range [{}, {}] {unit} \
                         (omnikin::description)",
                        num(v),
                        num(min),
                        num(max)
                    ),
                ))
            }
        };
        for (field, value, r, unit) in [
            (
                "limits.max_wheel_rate",
                limits.max_wheel_rate,
                MOTOR_RATE_RANGE,
                "rad/s",
            ),
            (
                "limits.max_wheel_accel",
                limits.max_wheel_accel,
                MOTOR_ACCEL_RANGE,
                "rad/s²",
            ),
            (
                "limits.max_steer_rate",
                limits.max_steer_rate,
                MOTOR_RATE_RANGE,
                "rad/s",
            ),
            (
                "limits.max_steer_accel",
                limits.max_steer_accel,
                MOTOR_ACCEL_RANGE,
                "rad/s²",
            ),
        ] {
            if let Some(v) = value {
                range(field, v, r, unit)?;
            }
        }
        let mut owned: std::vec::Vec<(String, f64)> = std::vec::Vec::new();
        match &geometry {
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
        let lengths: &[(&str, f64)] = match &geometry {
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
        if let Some(n) = &name {
            check_name(n).map_err(|rule| err(None, "name", rule))?;
        }
        let steerable = Kind::from_name(&kind).is_some_and(Kind::steerable);
        if !steerable && (limits.max_steer_rate.is_some() || limits.max_steer_accel.is_some()) {
            return Err(err(
                None,
                "limits.max_steer_rate",
                format!(
                    "steer limits apply only to kinds with steering (\"caster3\", \"swerve\"), \
                     not \"{kind}\""
                ),
            ));
        }
        Ok(Self {
            name: name.unwrap_or(kind),
            source_name: source_name.to_string(),
            geometry,
            limits,
        })
    }

    /// The robot's kind as written in files and on the command line.
    pub fn kind(&self) -> &'static str {
        self.robot_kind().name()
    }

    /// The robot's kind.
    pub fn robot_kind(&self) -> Kind {
        match self.geometry {
            Geometry::Sphere(_) => Kind::Sphere,
            Geometry::Ballbot(_) => Kind::Ballbot,
            Geometry::Caster(_) => Kind::Caster,
            Geometry::Omni(_) => Kind::Omni,
            Geometry::Swerve { .. } => Kind::Swerve,
        }
    }

    /// Builds the kinematic model in scalar type `T` (`f32` or `f64`).
    pub fn build<T: Real>(&self) -> Result<Robot<T>, DescriptionError> {
        let c = |x: f64| T::of(x);
        let kind = self.kind();
        let wrap = |e| geometry_error(e, &self.source_name, kind);
        Ok(match &self.geometry {
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
}

/// Checks a robot name: 1 to [`MAX_NAME_CHARS`] characters, none of them a control character.
fn check_name(name: &str) -> Result<(), String> {
    let chars = name.chars().count();
    if chars == 0 || chars > MAX_NAME_CHARS {
        return Err(format!(
            "must have 1 to {MAX_NAME_CHARS} characters (got {chars})"
        ));
    }
    if let Some(c) = name.chars().find(|c| c.is_control()) {
        return Err(format!(
            "must be printable: contains the control character U+{:04X}",
            u32::from(c)
        ));
    }
    Ok(())
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
