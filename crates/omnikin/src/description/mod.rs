//! Robot description files (TOML) and the compiled-in presets (feature `std`).
//!
//! A description names the robot's `kind`, its `[geometry]` and optional motor `[limits]`:
//!
//! ```toml
//! kind = "sphere-omni"            # or "ballbot", "caster3", "omni", "swerve"
//! name = "my-sphere"              # optional, defaults to the kind
//! footprint_radius = 0.15         # optional, m: the disk holding the robot (maps)
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
//! max_accel = 2.0                 # m/s², body (default: from max_wheel_accel, BodyLimits)
//! max_yaw_accel = 8.0             # rad/s² (default: from max_wheel_accel)
//! max_jerk = 50.0                 # m/s³ (default: unlimited)
//!
//! [dynamics]                      # optional, sphere-omni and ballbot: see SphereDynamicsSpec,
//!                                 # BallbotDynamicsSpec
//! platform_mass = 2.0             # kg
//!
//! [events]                        # optional, any kind: slip and collision thresholds
//! slip_yaw_rate = 0.3             # rad/s (see EventSpec)
//! collision_decel = 3.0           # m/s²
//! ```
//!
//! Loading validates everything and reports the first problem as a [`DescriptionError`] that
//! names the file, the line (of the offending value or syntax), the field, and the rule broken:
//! unknown keys, missing fields, wrong types, a list without exactly three values (one per
//! wheel), non-positive lengths, a wheel larger than the shell, out-of-range angles, singular
//! geometry, and values that are finite but implausible: lengths outside [`LENGTH_RANGE`],
//! motor limits outside [`MOTOR_RATE_RANGE`] / [`MOTOR_ACCEL_RANGE`], a name longer than
//! [`MAX_NAME_CHARS`] or with control characters. A leading UTF-8 byte-order mark is skipped.

use std::format;
use std::string::{String, ToString};

use serde::Deserialize;

use crate::ballbot::BallbotParams;
use crate::caster::CasterParams;
use crate::drive::omni::OmniWheel;
use crate::drive::swerve::SwerveModule;
use crate::sphere::SphereParams;
use crate::{Kind, Real, Robot};

mod ballbot_dynamics;
mod body_limits;
mod dynamics;
pub mod events;
mod footprint;
mod locate;
mod plausibility;
mod schema;

pub use ballbot_dynamics::{
    BallbotDynamicsSpec, DEFAULT_LEAN_MARGIN, DEFAULT_MAX_TILT_DEG, WeightsSpec,
};
pub use body_limits::{
    BODY_ACCEL_RANGE, BODY_JERK_RANGE, BodyLimits, DEFAULT_ACCEL, DEFAULT_YAW_ACCEL,
    DIRECTION_STEP_DEG, LimitSource, YAW_ACCEL_RANGE,
};
pub use dynamics::{FloorSurface, MotorModel, SphereDynamicsSpec};
pub use events::{EventLevels, EventSpec};
pub use footprint::{FOOTPRINT_SLACK, geometry_reach};

use schema::{Header, kinds};

/// The compiled-in presets: `(name, TOML text)`, identical to the files in `robots/`.
pub const PRESETS: [(&str, &str); 7] = [
    (
        "sphere-omni",
        include_str!("../../../../robots/sphere-omni.toml"),
    ),
    ("ballbot", include_str!("../../../../robots/ballbot.toml")),
    ("caster3", include_str!("../../../../robots/caster3.toml")),
    ("kiwi", include_str!("../../../../robots/kiwi.toml")),
    ("x-drive", include_str!("../../../../robots/x-drive.toml")),
    ("mecanum", include_str!("../../../../robots/mecanum.toml")),
    ("swerve4", include_str!("../../../../robots/swerve4.toml")),
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
/// Displayed as `FILE:LINE: FIELD: RULE`, the line being that of the field's value
/// (`FILE: FIELD: RULE` when the field is not written in the file, e.g. a missing key), or
/// `FILE:LINE: RULE` for syntax and schema errors (the rule then names the key, e.g.
/// "unknown field `colour`").
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{source_name}{}{}: {rule}",
    line.map(|l| format!(":{l}")).unwrap_or_default(),
    if field.is_empty() { String::new() } else { format!(": {field}") })]
pub struct DescriptionError {
    /// The file path, or `preset <name>`.
    pub source_name: String,
    /// 1-based line of the offending text (the field's value), when known.
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
    /// Largest body (linear, world-frame) acceleration, m/s²; absent: derived from
    /// `max_wheel_accel` ([`RobotDescription::body_limits`]).
    pub max_accel: Option<f64>,
    /// Largest yaw acceleration, rad/s²; absent: derived from `max_wheel_accel`.
    pub max_yaw_accel: Option<f64>,
    /// Largest body (linear) jerk, m/s³; absent: unlimited.
    pub max_jerk: Option<f64>,
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

impl Geometry {
    /// The kind this geometry describes (one variant per [`Kind`]).
    pub fn kind(&self) -> Kind {
        match self {
            Geometry::Sphere(_) => Kind::Sphere,
            Geometry::Ballbot(_) => Kind::Ballbot,
            Geometry::Caster(_) => Kind::Caster,
            Geometry::Omni(_) => Kind::Omni,
            Geometry::Swerve { .. } => Kind::Swerve,
        }
    }
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
    /// The `[dynamics]` table of a `sphere-omni` file (see [`SphereDynamicsSpec`]), if any.
    pub sphere_dynamics: Option<SphereDynamicsSpec>,
    /// The `[dynamics]` table of a `ballbot` file (see [`BallbotDynamicsSpec`]), if any.
    pub ballbot_dynamics: Option<BallbotDynamicsSpec>,
    /// The `[events]` table: slip and collision thresholds as given (all `None` without one;
    /// [`EventSpec::thresholds`] fills in the defaults).
    pub events: EventSpec,
    /// The top-level `footprint_radius` (m): the disk about the centre that holds the whole
    /// robot, for clearances on a map; `None` when not given (at least
    /// [`RobotDescription::geometry_reach`] when given).
    pub footprint_radius: Option<f64>,
}

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
    /// An error about a field names the line of that field's value.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self, DescriptionError> {
        // A leading UTF-8 byte-order mark (editors on Windows write one) is not content.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        Self::parse_checked(text, source_name).map_err(|mut e| {
            if let Some(line) = locate::value_line(text, &e.field) {
                e.line = Some(line);
            }
            e
        })
    }

    /// [`RobotDescription::from_toml_str`] before the line of a field's value is looked up.
    fn parse_checked(text: &str, source_name: &str) -> Result<Self, DescriptionError> {
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
        let header: Header = toml::from_str(text).map_err(de_err)?;
        let kind = header
            .kind
            .ok_or_else(|| err(None, "kind", format!("missing; must be {}", kinds())))?;
        let kind = Kind::from_name(&kind).ok_or_else(|| {
            err(
                None,
                "kind",
                format!("unknown robot kind \"{kind}\"; must be {}", kinds()),
            )
        })?;
        let (name, geometry, limits) = schema::parse(text, source_name, kind, &err, &de_err)?;
        let (sphere_dynamics, ballbot_dynamics) =
            match dynamics::parse(text, &geometry, &err, &de_err)? {
                dynamics::Parsed::None => (None, None),
                dynamics::Parsed::Sphere(s) => (Some(s), None),
                dynamics::Parsed::Ballbot(b) => (None, Some(b)),
            };
        let events = events::parse(text, &err, &de_err)?;
        for (field, value) in [
            ("limits.max_wheel_rate", limits.max_wheel_rate),
            ("limits.max_wheel_accel", limits.max_wheel_accel),
            ("limits.max_steer_rate", limits.max_steer_rate),
            ("limits.max_steer_accel", limits.max_steer_accel),
            ("limits.max_accel", limits.max_accel),
            ("limits.max_yaw_accel", limits.max_yaw_accel),
            ("limits.max_jerk", limits.max_jerk),
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
            (
                "limits.max_accel",
                limits.max_accel,
                BODY_ACCEL_RANGE,
                "m/s²",
            ),
            (
                "limits.max_yaw_accel",
                limits.max_yaw_accel,
                YAW_ACCEL_RANGE,
                "rad/s²",
            ),
            ("limits.max_jerk", limits.max_jerk, BODY_JERK_RANGE, "m/s³"),
        ] {
            if let Some(v) = value {
                range(field, v, r, unit)?;
            }
        }
        schema::check_lengths(&geometry, &err, &range)?;
        footprint::check(header.footprint_radius, &geometry, &err)?;
        if let Some(n) = &name {
            check_name(n).map_err(|rule| err(None, "name", rule))?;
        }
        if !kind.steerable()
            && (limits.max_steer_rate.is_some() || limits.max_steer_accel.is_some())
        {
            let steering: std::vec::Vec<String> = Kind::ALL
                .iter()
                .filter(|k| k.steerable())
                .map(|k| format!("\"{}\"", k.name()))
                .collect();
            return Err(err(
                None,
                "limits.max_steer_rate",
                format!(
                    "steer limits apply only to kinds with steering ({}), not \"{}\"",
                    steering.join(", "),
                    kind.name()
                ),
            ));
        }
        Ok(Self {
            name: name.unwrap_or_else(|| kind.name().to_string()),
            source_name: source_name.to_string(),
            geometry,
            limits,
            sphere_dynamics,
            ballbot_dynamics,
            events,
            footprint_radius: header.footprint_radius,
        })
    }

    /// The robot's kind as written in files and on the command line.
    pub fn kind(&self) -> &'static str {
        self.robot_kind().name()
    }

    /// The robot's kind: ask it what the robot can do ([`Kind::steerable`],
    /// [`Kind::balances`], [`Kind::has_dynamics`]) rather than comparing [`Self::kind`] names.
    pub fn robot_kind(&self) -> Kind {
        self.geometry.kind()
    }

    /// Builds the kinematic model in scalar type `T` (`f32` or `f64`).
    pub fn build<T: Real>(&self) -> Result<Robot<T>, DescriptionError> {
        schema::build(self)
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
