//! The optional `[dynamics]` table of a robot file, dispatched by kind (a `ballbot`'s is
//! [`super::BallbotDynamicsSpec`]); here the `sphere-omni` one: the masses, inertias, motor
//! and floor-friction parameters of the shell + platform dynamic model (`omnikin-sim`'s
//! `dynamics::sphere`), every key optional (absent = that model's documented default), SI
//! units:
//!
//! ```toml
//! [dynamics]
//! shell_mass = 0.5                          # m_s [kg]
//! shell_inertia = 0.0075                    # I_s about the centre [kg m^2] (default 2/3 m_s R^2)
//! platform_mass = 2.0                       # m_p [kg]
//! platform_inertia = [0.004, 0.004, 0.006]  # principal moments about platform x, y, z [kg m^2]
//! com_depth = 0.08                          # h, platform centre of mass below the centre [m]
//! pull_out_torque = 0.3                     # stepper pull-out torque [N m] (inf = ideal)
//! motor = "rate"                            # "rate" (imposes rates) or "stepper" (angles)
//! stepper_steps_per_rev = 200               # full steps per revolution (1.8 deg hybrid)
//! stepper_corner_speed = 50.0               # pull-out torque falls as 1/speed above [rad/s]
//! stepper_damping = 0.01                    # rotor damping against the field [N m s/rad]
//! pivot_friction = 0.005                    # Coulomb spin friction at the floor [N m]
//! pivot_velocity_scale = 0.005              # its tanh regularisation [rad/s]
//! rolling_resistance = 0.005                # C_rr (torque C_rr M g R)
//! rolling_velocity_scale = 0.01             # its regularisation [rad/s]
//! tracked_height = 0.12                     # tracked point above the floor contact [m]
//! roller_friction = 0.5                     # roller-shell mu (inf = rigid, never slip or lift)
//! roller_viscous = 1.0                      # sliding roller's viscous part [N s/m]
//! roller_preload = 0.0                      # normal preload per wheel [N]
//! floor_friction = 0.4                      # shell-floor mu (the floor force's cone)
//! floor = "vinyl"                           # or linoleum, carpet, concrete: sets the three
//!                                           # floor values above unless they are given
//! max_tilt_deg = 20.0                       # platform tilt a plan should not exceed [deg]
//! ```
//!
//! Parsing checks each value on its own (finite, sign, inside the shell, the inertia triangle
//! inequality) and names the field; the dynamic model checks the combination again when it is
//! built.

use std::format;
use std::string::{String, ToString};

use serde::Deserialize;

use super::ballbot_dynamics::BallbotDynamicsSpec;
use super::{DescriptionError, Geometry};

/// How the `sphere-omni` dynamic model's motors act (`motor = "rate" | "stepper"` in
/// `[dynamics]`; any other name is rejected naming the key and the two names).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MotorModel {
    /// Each motor imposes its commanded wheel rate up to the pull-out torque, delivers the
    /// pull-out torque while slipping and resynchronises when its rotor has caught up.
    #[default]
    Rate,
    /// Each motor imposes the commanded *angle* through the hybrid stepper's torque–angle
    /// stiffness, up to a pull-out torque that falls with speed; beyond it the rotor slips
    /// poles (loses steps) and stays stalled unless the command lets it catch a pole again.
    Stepper,
}

/// The floor a `sphere-omni` robot rolls on (`floor = "linoleum" | "vinyl" | "carpet" |
/// "concrete"` in `[dynamics]`; any other name is rejected naming the key and the four
/// names). It sets the floor's three values — pivot friction, rolling resistance, shell–floor
/// friction coefficient — from `omnikin-sim`'s table of surfaces (sources and which values are
/// estimates: its `dynamics::sphere::floor` module); a value given explicitly in the same
/// table overrides the surface's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FloorSurface {
    /// Linoleum sheet (the same contact row as vinyl: no source separates their moduli).
    Linoleum,
    /// Sheet vinyl (plasticised PVC wear layer), a lab floor: the `sphere-omni` preset's.
    Vinyl,
    /// Low-pile carpet.
    Carpet,
    /// Smooth (sealed or painted) concrete.
    Concrete,
}

impl FloorSurface {
    /// Every surface, in the order the error message lists them.
    pub const ALL: [FloorSurface; 4] = [
        FloorSurface::Linoleum,
        FloorSurface::Vinyl,
        FloorSurface::Carpet,
        FloorSurface::Concrete,
    ];

    /// The name the robot file uses.
    pub fn name(self) -> &'static str {
        match self {
            FloorSurface::Linoleum => "linoleum",
            FloorSurface::Vinyl => "vinyl",
            FloorSurface::Carpet => "carpet",
            FloorSurface::Concrete => "concrete",
        }
    }
}

impl<'de> Deserialize<'de> for FloorSurface {
    /// A surface by its [`name`](FloorSurface::name); any other text is refused naming the key
    /// `dynamics.floor` and the accepted names.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        FloorSurface::ALL
            .into_iter()
            .find(|s| s.name() == text)
            .ok_or_else(|| {
                let names: std::vec::Vec<&str> =
                    FloorSurface::ALL.iter().map(|s| s.name()).collect();
                serde::de::Error::custom(format!(
                    "dynamics.floor = \"{text}\" is not a floor surface; accepted: {}",
                    names.join(", ")
                ))
            })
    }
}

/// The `[dynamics]` table of a `sphere-omni` robot file, as given: `None` = the dynamic model's
/// default for paper 000's robot.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereDynamicsSpec {
    /// Shell mass `m_s`, kg.
    pub shell_mass: Option<f64>,
    /// Shell moment of inertia about its centre, kg·m².
    pub shell_inertia: Option<f64>,
    /// Platform mass `m_p`, kg.
    pub platform_mass: Option<f64>,
    /// Principal moments of the platform's inertia about its centre of mass, about the
    /// platform's x, y, z axes, kg·m².
    pub platform_inertia: Option<std::vec::Vec<f64>>,
    /// Depth `h` of the platform's centre of mass below the shell centre, m.
    pub com_depth: Option<f64>,
    /// Stepper pull-out torque, N·m (`inf` for an ideal rate source).
    pub pull_out_torque: Option<f64>,
    /// Motor model: `"rate"` (default) or `"stepper"`.
    pub motor: Option<MotorModel>,
    /// Full steps per revolution of the stepper (200 for a 1.8° hybrid stepper).
    pub stepper_steps_per_rev: Option<f64>,
    /// Speed above which the stepper's pull-out torque falls as 1/speed, rad/s.
    pub stepper_corner_speed: Option<f64>,
    /// Viscous damping of the stepper's rotor against its field, N·m·s/rad.
    pub stepper_damping: Option<f64>,
    /// Coulomb pivot (spin) friction torque at the floor contact, N·m.
    pub pivot_friction: Option<f64>,
    /// Velocity scale of the pivot friction's regularisation, rad/s.
    pub pivot_velocity_scale: Option<f64>,
    /// Rolling-resistance coefficient `C_rr` (dimensionless).
    pub rolling_resistance: Option<f64>,
    /// Velocity scale of the rolling resistance's regularisation, rad/s.
    pub rolling_velocity_scale: Option<f64>,
    /// Height of the tracked point above the floor contact with the platform level, m.
    pub tracked_height: Option<f64>,
    /// Roller–shell friction coefficient μ (`inf` = rigid contacts that never slip or lift).
    pub roller_friction: Option<f64>,
    /// Viscous part of a sliding roller's force, N·s/m.
    pub roller_viscous: Option<f64>,
    /// Normal preload per wheel, N.
    pub roller_preload: Option<f64>,
    /// Shell–floor friction coefficient (the floor force's cone).
    pub floor_friction: Option<f64>,
    /// Named floor surface: sets `pivot_friction`, `rolling_resistance` and `floor_friction`
    /// unless they are given here too (the given values then override the surface's).
    pub floor: Option<FloorSurface>,
    /// Largest platform tilt a plan should cause, degrees.
    pub max_tilt_deg: Option<f64>,
}

impl SphereDynamicsSpec {
    /// With a named [`floor`](Self::floor): the floor keys given explicitly beside it, which
    /// override the surface's values (in the order `pivot_friction`, `rolling_resistance`,
    /// `floor_friction`); empty without a named floor.
    pub fn floor_overrides(&self) -> std::vec::Vec<&'static str> {
        if self.floor.is_none() {
            return std::vec::Vec::new();
        }
        [
            ("pivot_friction", self.pivot_friction),
            ("rolling_resistance", self.rolling_resistance),
            ("floor_friction", self.floor_friction),
        ]
        .into_iter()
        .filter(|(_, v)| v.is_some())
        .map(|(k, _)| k)
        .collect()
    }

    /// The platform's principal moments, kg·m², when given (checked to be three by parsing).
    pub fn platform_moments(&self) -> Option<[f64; 3]> {
        match self.platform_inertia.as_deref() {
            Some(&[a, b, c]) => Some([a, b, c]),
            _ => None,
        }
    }

    /// Checks every given value; `shell_radius` (m) bounds the depths and heights. Returns the
    /// field (TOML key path) and the rule of the first bad one.
    pub fn check(&self, shell_radius: f64) -> Result<(), (&'static str, String)> {
        let positive = |field: &'static str, v: Option<f64>| match v {
            Some(x) if !(x.is_finite() && x > 0.0) => {
                Err((field, format!("must be a finite number > 0 (got {x})")))
            }
            _ => Ok(()),
        };
        let nonneg = |field: &'static str, v: Option<f64>| match v {
            Some(x) if !(x.is_finite() && x >= 0.0) => {
                Err((field, format!("must be a finite number ≥ 0 (got {x})")))
            }
            _ => Ok(()),
        };
        positive("dynamics.shell_mass", self.shell_mass)?;
        positive("dynamics.shell_inertia", self.shell_inertia)?;
        if let (Some(m), Some(i)) = (self.shell_mass, self.shell_inertia)
            && i > m * shell_radius * shell_radius * (1.0 + 1e-12)
        {
            return Err((
                "dynamics.shell_inertia",
                format!(
                    "{i} kg m^2 exceeds m_s R^2 = {} kg m^2 (all the mass on the shell's \
                     surface; a thin shell has 2/3 m_s R^2)",
                    m * shell_radius * shell_radius
                ),
            ));
        }
        positive("dynamics.platform_mass", self.platform_mass)?;
        if let Some(v) = &self.platform_inertia {
            let &[a, b, c] = v.as_slice() else {
                return Err((
                    "dynamics.platform_inertia",
                    format!(
                        "expected 3 principal moments (about platform x, y, z), got {} values",
                        v.len()
                    ),
                ));
            };
            for x in [a, b, c] {
                positive("dynamics.platform_inertia", Some(x))?;
            }
            let tol = 1e-12 * (a + b + c);
            if a > b + c + tol || b > a + c + tol || c > a + b + tol {
                return Err((
                    "dynamics.platform_inertia",
                    format!(
                        "principal moments [{a}, {b}, {c}] violate the triangle inequality \
                         (each at most the sum of the other two)"
                    ),
                ));
            }
        }
        nonneg("dynamics.com_depth", self.com_depth)?;
        if let Some(h) = self.com_depth
            && h >= shell_radius
        {
            return Err((
                "dynamics.com_depth",
                format!(
                    "{h} m puts the platform's centre of mass outside the shell (R = \
                     {shell_radius} m)"
                ),
            ));
        }
        if let Some(t) = self.pull_out_torque
            && (t.is_nan() || t <= 0.0)
        {
            return Err((
                "dynamics.pull_out_torque",
                format!("must be > 0 N m, or inf for an ideal motor (got {t})"),
            ));
        }
        if let Some(n) = self.stepper_steps_per_rev
            && !(n.is_finite() && n >= 4.0 && n % 4.0 == 0.0)
        {
            return Err((
                "dynamics.stepper_steps_per_rev",
                format!(
                    "must be a positive multiple of 4 (a two-phase motor's full steps per \
                     revolution, 200 for 1.8 deg; got {n})"
                ),
            ));
        }
        positive("dynamics.stepper_corner_speed", self.stepper_corner_speed)?;
        nonneg("dynamics.stepper_damping", self.stepper_damping)?;
        nonneg("dynamics.pivot_friction", self.pivot_friction)?;
        positive("dynamics.pivot_velocity_scale", self.pivot_velocity_scale)?;
        nonneg("dynamics.rolling_resistance", self.rolling_resistance)?;
        positive(
            "dynamics.rolling_velocity_scale",
            self.rolling_velocity_scale,
        )?;
        if let Some(m) = self.roller_friction
            && (m.is_nan() || m <= 0.0)
        {
            return Err((
                "dynamics.roller_friction",
                format!("must be > 0, or inf for rigid contacts (got {m})"),
            ));
        }
        nonneg("dynamics.roller_viscous", self.roller_viscous)?;
        nonneg("dynamics.roller_preload", self.roller_preload)?;
        positive("dynamics.floor_friction", self.floor_friction)?;
        nonneg("dynamics.tracked_height", self.tracked_height)?;
        if let Some(z) = self.tracked_height
            && z > 2.0 * shell_radius
        {
            return Err((
                "dynamics.tracked_height",
                format!(
                    "{z} m is above the shell's top (2R = {} m)",
                    2.0 * shell_radius
                ),
            ));
        }
        if let Some(d) = self.max_tilt_deg
            && !(d > 0.0 && d < 90.0)
        {
            return Err((
                "dynamics.max_tilt_deg",
                format!("must be strictly between 0 and 90 degrees (got {d})"),
            ));
        }
        Ok(())
    }
}

#[derive(Deserialize)]
struct Only<S> {
    dynamics: Option<toml::Spanned<S>>,
}

/// The `[dynamics]` table of a description, by kind.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Parsed {
    /// None given.
    None,
    /// A `sphere-omni` table.
    Sphere(SphereDynamicsSpec),
    /// A `ballbot` table.
    Ballbot(BallbotDynamicsSpec),
}

/// The 1-based line of `key = …` inside the section `[section]` of `text` (or of the section
/// header when the key is not found there), for error messages.
pub(super) fn key_line(text: &str, section: &str, key: &str) -> Option<usize> {
    let header = format!("[{section}]");
    let lines: std::vec::Vec<&str> = text.lines().collect();
    let start = lines
        .iter()
        .position(|l| l.trim_start().starts_with(&header))?;
    for (i, l) in lines.iter().enumerate().skip(start + 1) {
        let t = l.trim_start();
        if t.starts_with('[') {
            break;
        }
        if let Some(rest) = t.strip_prefix(key)
            && rest.trim_start().starts_with('=')
        {
            return Some(i + 1);
        }
    }
    Some(start + 1)
}

/// Parses and checks the `[dynamics]` table of a file of geometry `geometry`: `sphere-omni`
/// (checked against its `shell_radius`) and `ballbot` (against its `ball_radius`) have one
/// ([`crate::Kind::has_dynamics`]).
pub(super) fn parse(
    text: &str,
    geometry: &Geometry,
    err: &dyn Fn(Option<usize>, &str, String) -> DescriptionError,
    de_err: &dyn Fn(toml::de::Error) -> DescriptionError,
) -> Result<Parsed, DescriptionError> {
    let table_line = |start: usize| Some(1 + text[..start.min(text.len())].matches('\n').count());
    match geometry {
        Geometry::Sphere(p) => {
            let r = p.shell_radius;
            let only: Only<SphereDynamicsSpec> = toml::from_str(text).map_err(de_err)?;
            let Some(spec) = only.dynamics else {
                return Ok(Parsed::None);
            };
            let line = table_line(spec.span().start);
            let spec = spec.into_inner();
            spec.check(r)
                .map_err(|(field, rule)| err(line, field, rule.to_string()))?;
            Ok(Parsed::Sphere(spec))
        }
        Geometry::Ballbot(p) => {
            let r = p.ball_radius;
            let only: Only<BallbotDynamicsSpec> = toml::from_str(text).map_err(de_err)?;
            let Some(spec) = only.dynamics else {
                return Ok(Parsed::None);
            };
            let spec = spec.into_inner();
            spec.check(r).map_err(|(field, rule)| {
                let path = field.strip_prefix("dynamics.").unwrap_or(&field);
                let (section, key) = match path.rsplit_once('.') {
                    Some((sub, key)) => (format!("dynamics.{sub}"), key),
                    None => ("dynamics".to_string(), path),
                };
                err(key_line(text, &section, key), &field, rule)
            })?;
            Ok(Parsed::Ballbot(spec))
        }
        Geometry::Caster(_) | Geometry::Omni(_) | Geometry::Swerve { .. } => {
            let kind = geometry.kind().name();
            let only: Only<toml::Value> = toml::from_str(text).map_err(de_err)?;
            match only.dynamics {
                None => Ok(Parsed::None),
                Some(spec) => Err(err(
                    table_line(spec.span().start),
                    "dynamics",
                    format!(
                        "a [dynamics] table is read only for kinds \"sphere-omni\" and \"ballbot\", not \"{kind}\""
                    ),
                )),
            }
        }
    }
}
