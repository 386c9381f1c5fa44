//! The optional `[events]` table of a robot file: the thresholds of slip and collision
//! detection ([`crate::estimate::events`]: `omnikin odometry` and the runtime of `omnikin robot`), every key optional (absent = the
//! default below), SI units:
//!
//! ```toml
//! [events]
//! slip_yaw_rate = 0.3       # wheels' and IMU's yaw rates disagree by more: slip [rad/s]
//! slip_residual = 0.05      # least-squares slip residual above: slip [m/s] (redundant kinds)
//! collision_decel = 3.0     # wheel speed falls faster than this: collision [m/s^2]
//! ```
//!
//! Each value must be finite and inside its plausible range ([`SLIP_YAW_RATE_RANGE`],
//! [`SLIP_RESIDUAL_RANGE`], [`COLLISION_DECEL_RANGE`]); an error names the key's line.

use std::format;
use std::string::String;

use serde::Deserialize;

use super::DescriptionError;

pub use crate::estimate::events::{
    DEFAULT_COLLISION_DECEL, DEFAULT_SLIP_RESIDUAL, DEFAULT_SLIP_YAW_RATE,
};

/// Plausible range of `events.slip_yaw_rate`, rad/s: below 10⁻³ rad/s gyro noise alone is an
/// event, above 100 rad/s no wheel slip is ever seen.
pub const SLIP_YAW_RATE_RANGE: (f64, f64) = (1e-3, 100.0);
/// Plausible range of `events.slip_residual`, m/s.
pub const SLIP_RESIDUAL_RANGE: (f64, f64) = (1e-4, 100.0);
/// Plausible range of `events.collision_decel`, m/s² (10⁴ m/s² is a 1000 g shock).
pub const COLLISION_DECEL_RANGE: (f64, f64) = (1e-2, 1e4);

/// The `[events]` table as given: `None` = the default (`DEFAULT_*`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventSpec {
    /// Yaw-rate disagreement between the wheels and the IMU heading that counts as slip,
    /// rad/s.
    pub slip_yaw_rate: Option<f64>,
    /// Least-squares slip residual that counts as slip (kinds with more motors than twist
    /// components), m/s.
    pub slip_residual: Option<f64>,
    /// Deceleration of the wheel speed that counts as a collision, m/s².
    pub collision_decel: Option<f64>,
}

/// Thresholds with every value decided: [`EventSpec::thresholds`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventLevels {
    /// rad/s, as [`EventSpec::slip_yaw_rate`].
    pub slip_yaw_rate: f64,
    /// m/s, as [`EventSpec::slip_residual`].
    pub slip_residual: f64,
    /// m/s², as [`EventSpec::collision_decel`].
    pub collision_decel: f64,
}

impl Default for EventLevels {
    fn default() -> Self {
        Self {
            slip_yaw_rate: DEFAULT_SLIP_YAW_RATE,
            slip_residual: DEFAULT_SLIP_RESIDUAL,
            collision_decel: DEFAULT_COLLISION_DECEL,
        }
    }
}

impl EventSpec {
    /// The given values, the defaults for the others.
    pub fn thresholds(&self) -> EventLevels {
        let d = EventLevels::default();
        EventLevels {
            slip_yaw_rate: self.slip_yaw_rate.unwrap_or(d.slip_yaw_rate),
            slip_residual: self.slip_residual.unwrap_or(d.slip_residual),
            collision_decel: self.collision_decel.unwrap_or(d.collision_decel),
        }
    }

    /// Checks every given value against its range; returns the key and the rule of the first
    /// bad one.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        for (key, value, (min, max), unit) in [
            (
                "slip_yaw_rate",
                self.slip_yaw_rate,
                SLIP_YAW_RATE_RANGE,
                "rad/s",
            ),
            (
                "slip_residual",
                self.slip_residual,
                SLIP_RESIDUAL_RANGE,
                "m/s",
            ),
            (
                "collision_decel",
                self.collision_decel,
                COLLISION_DECEL_RANGE,
                "m/s²",
            ),
        ] {
            if let Some(v) = value
                && !(v.is_finite() && v >= min && v <= max)
            {
                return Err((
                    key,
                    format!(
                        "{} {unit} is outside the plausible range [{}, {}] {unit} \
                         (omnikin::description::events)",
                        super::num(v),
                        super::num(min),
                        super::num(max)
                    ),
                ));
            }
        }
        Ok(())
    }
}

#[derive(Deserialize)]
struct Only {
    events: Option<EventSpec>,
}

/// Parses and checks the `[events]` table (any kind); absent: all defaults.
pub(super) fn parse(
    text: &str,
    err: &dyn Fn(Option<usize>, &str, String) -> DescriptionError,
    de_err: &dyn Fn(toml::de::Error) -> DescriptionError,
) -> Result<EventSpec, DescriptionError> {
    let only: Only = toml::from_str(text).map_err(de_err)?;
    let spec = only.events.unwrap_or_default();
    spec.check().map_err(|(key, rule)| {
        err(
            super::dynamics::key_line(text, "events", key),
            &format!("events.{key}"),
            rule,
        )
    })?;
    Ok(spec)
}
