//! The optional `[dynamics]` table of a `ballbot` robot file: the masses, inertias, friction and
//! motor limit of the ball + body dynamics, the lean limit plans respect, and the balance
//! controller's rate, fall threshold and (optional) LQR weights. Every key is optional (absent =
//! the preset's value, [`PlantParams::preset`], [`BalanceConfig::preset`]); SI units, angles in
//! degrees where the key says `_deg`:
//!
//! ```toml
//! [dynamics]
//! ball_mass = 1.478                          # m_b [kg]
//! ball_inertia = 0.0132586                   # I_b about the centre [kg m^2]
//! body_mass = 16.154                         # m_B, everything above the ball [kg]
//! body_inertia = [1.29465, 1.3064, 0.100218] # principal moments about body x, y, z [kg m^2]
//! com_height = 0.42123854                    # l, body centre of mass above the ball centre [m]
//! torque_limit = 1.9825                      # per wheel, at the wheel [N m]
//! floor_damping = 0.001                      # ball's absolute rotation [N m s/rad]
//! relative_damping = 0.001                   # ball relative to the body [N m s/rad]
//! max_tilt_deg = 10.0                        # lean a plan may ask for [deg]
//! lean_margin = 0.25                         # share of that lean kept for the controller
//! fall_tilt_deg = 20.0                       # fallen beyond this: motors off [deg]
//! control_rate_hz = 200.0                    # balance controller rate [Hz]
//!
//! [dynamics.weights]                         # Bryson's rule bounds (control::Weights)
//! position = 0.05                            # m
//! tilt_deg = 1.0                             # deg
//! velocity = 0.2                             # m/s
//! tilt_rate = 0.1                            # rad/s
//! torque = 1.0                               # N m (model torques Tx, Ty)
//! yaw = 0.1                                  # rad
//! yaw_rate = 0.5                             # rad/s
//! yaw_torque = 0.5                           # N m (model torque Tz)
//! ```
//!
//! Parsing checks each value on its own (finite, sign, range, the ball inside its radius, the
//! inertia triangle inequality, the lean limit below the fall threshold) and names the key and
//! its line; the controller's design checks the combination again when it is built.

use std::format;
use std::string::String;

use serde::Deserialize;

use crate::Real;
use crate::ballbot::BallbotParams;
use crate::control::{BalanceConfig, PlantParams, Weights};

/// The ballbot's lean limit when the file gives none, degrees.
pub const DEFAULT_MAX_TILT_DEG: f64 = 10.0;
/// The share of the lean limit kept for the controller when the file gives none.
pub const DEFAULT_LEAN_MARGIN: f64 = 0.25;

/// The `[dynamics.weights]` table: Bryson's-rule bounds of [`Weights`], `None` = its default.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeightsSpec {
    /// Acceptable ball position error, m.
    pub position: Option<f64>,
    /// Acceptable body tilt, degrees.
    pub tilt_deg: Option<f64>,
    /// Acceptable ball speed error, m/s.
    pub velocity: Option<f64>,
    /// Acceptable tilt rate, rad/s.
    pub tilt_rate: Option<f64>,
    /// Acceptable model torque `Tx`, `Ty`, N·m.
    pub torque: Option<f64>,
    /// Acceptable yaw error, rad.
    pub yaw: Option<f64>,
    /// Acceptable yaw-rate error, rad/s.
    pub yaw_rate: Option<f64>,
    /// Acceptable model torque `Tz`, N·m.
    pub yaw_torque: Option<f64>,
}

/// The `[dynamics]` table of a `ballbot` robot file, as given: `None` = the preset's value.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BallbotDynamicsSpec {
    /// Ball mass `m_b`, kg.
    pub ball_mass: Option<f64>,
    /// Ball moment of inertia about its centre `I_b`, kg·m².
    pub ball_inertia: Option<f64>,
    /// Body mass `m_B` (everything above the ball), kg.
    pub body_mass: Option<f64>,
    /// Body principal moments of inertia about its centre of mass, body x, y, z, kg·m².
    pub body_inertia: Option<std::vec::Vec<f64>>,
    /// Height `l` of the body's centre of mass above the ball centre, m.
    pub com_height: Option<f64>,
    /// Largest wheel torque magnitude per motor (at the wheel), N·m.
    pub torque_limit: Option<f64>,
    /// Viscous damping of the ball's absolute rotation, N·m·s/rad.
    pub floor_damping: Option<f64>,
    /// Viscous damping of the ball's rotation relative to the body, N·m·s/rad.
    pub relative_damping: Option<f64>,
    /// Largest lean a plan may ask for, degrees (the planner's acceleration limit).
    pub max_tilt_deg: Option<f64>,
    /// Share of `max_tilt_deg` kept for the controller's corrections, in `[0, 1)`.
    pub lean_margin: Option<f64>,
    /// Tilt beyond which the robot counts as fallen (motors off), degrees.
    pub fall_tilt_deg: Option<f64>,
    /// Balance controller rate, Hz.
    pub control_rate_hz: Option<f64>,
    /// LQR weights.
    pub weights: Option<WeightsSpec>,
}

/// A rule broken by one key: `(key path, rule)`.
pub type SpecError = (String, String);

fn positive(field: &str, v: Option<f64>) -> Result<(), SpecError> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err((
            field.into(),
            format!("must be a finite number > 0 (got {x})"),
        )),
        _ => Ok(()),
    }
}

fn nonneg(field: &str, v: Option<f64>) -> Result<(), SpecError> {
    match v {
        Some(x) if !(x.is_finite() && x >= 0.0) => Err((
            field.into(),
            format!("must be a finite number ≥ 0 (got {x})"),
        )),
        _ => Ok(()),
    }
}

fn within(field: &str, v: Option<f64>, lo: f64, hi: f64, unit: &str) -> Result<(), SpecError> {
    match v {
        Some(x) if !(x.is_finite() && x >= lo && x <= hi) => Err((
            field.into(),
            format!("must be in [{lo}, {hi}] {unit} (got {x})"),
        )),
        _ => Ok(()),
    }
}

impl BallbotDynamicsSpec {
    /// The body's principal moments, kg·m², when given (checked to be three by parsing).
    pub fn body_moments(&self) -> Option<[f64; 3]> {
        match self.body_inertia.as_deref() {
            Some(&[a, b, c]) => Some([a, b, c]),
            _ => None,
        }
    }

    /// Checks every given value; `ball_radius` (m) bounds the ball's inertia. Returns the key
    /// path (`dynamics.body_mass`, `dynamics.weights.tilt_deg`) and the rule of the first bad
    /// one.
    pub fn check(&self, ball_radius: f64) -> Result<(), SpecError> {
        within("dynamics.ball_mass", self.ball_mass, 1e-3, 1e3, "kg")?;
        positive("dynamics.ball_inertia", self.ball_inertia)?;
        let mb = self
            .ball_mass
            .unwrap_or(PlantParams::<f64>::preset().ball_mass);
        if let Some(i) = self.ball_inertia
            && i > mb * ball_radius * ball_radius * (1.0 + 1e-12)
        {
            return Err((
                "dynamics.ball_inertia".into(),
                format!(
                    "{i} kg m^2 exceeds m_b R^2 = {} kg m^2 (all the ball's mass on its \
                     surface; a thin shell has 2/3 m_b R^2)",
                    mb * ball_radius * ball_radius
                ),
            ));
        }
        within("dynamics.body_mass", self.body_mass, 1e-3, 1e4, "kg")?;
        if let Some(v) = &self.body_inertia {
            let &[a, b, c] = v.as_slice() else {
                return Err((
                    "dynamics.body_inertia".into(),
                    format!(
                        "expected 3 principal moments (about body x, y, z), got {} values",
                        v.len()
                    ),
                ));
            };
            for x in [a, b, c] {
                positive("dynamics.body_inertia", Some(x))?;
            }
            let tol = 1e-12 * (a + b + c);
            if a > b + c + tol || b > a + c + tol || c > a + b + tol {
                return Err((
                    "dynamics.body_inertia".into(),
                    format!(
                        "principal moments [{a}, {b}, {c}] violate the triangle inequality \
                         (each at most the sum of the other two)"
                    ),
                ));
            }
        }
        within("dynamics.com_height", self.com_height, 1e-3, 10.0, "m")?;
        positive("dynamics.torque_limit", self.torque_limit)?;
        nonneg("dynamics.floor_damping", self.floor_damping)?;
        nonneg("dynamics.relative_damping", self.relative_damping)?;
        if let Some(d) = self.max_tilt_deg
            && !(d > 0.0 && d < 45.0)
        {
            return Err((
                "dynamics.max_tilt_deg".into(),
                format!("must be strictly between 0 and 45 degrees (got {d})"),
            ));
        }
        if let Some(m) = self.lean_margin
            && !(0.0..1.0).contains(&m)
        {
            return Err((
                "dynamics.lean_margin".into(),
                format!("must be in [0, 1): the share of the lean kept for control (got {m})"),
            ));
        }
        if let Some(d) = self.fall_tilt_deg
            && !(d > 0.0 && d < 90.0)
        {
            return Err((
                "dynamics.fall_tilt_deg".into(),
                format!("must be strictly between 0 and 90 degrees (got {d})"),
            ));
        }
        let (lean, fall) = (self.max_tilt(), self.fall_tilt_deg());
        if lean >= fall {
            let field = if self.max_tilt_deg.is_some() {
                "dynamics.max_tilt_deg"
            } else {
                "dynamics.fall_tilt_deg"
            };
            return Err((
                field.into(),
                format!(
                    "the lean limit {lean}° must be below the fall threshold {fall}° (a plan \
                     at the limit would trip the fall detection)"
                ),
            ));
        }
        within(
            "dynamics.control_rate_hz",
            self.control_rate_hz,
            10.0,
            100_000.0,
            "Hz",
        )?;
        if let Some(w) = &self.weights {
            for (k, v) in [
                ("dynamics.weights.position", w.position),
                ("dynamics.weights.tilt_deg", w.tilt_deg),
                ("dynamics.weights.velocity", w.velocity),
                ("dynamics.weights.tilt_rate", w.tilt_rate),
                ("dynamics.weights.torque", w.torque),
                ("dynamics.weights.yaw", w.yaw),
                ("dynamics.weights.yaw_rate", w.yaw_rate),
                ("dynamics.weights.yaw_torque", w.yaw_torque),
            ] {
                positive(k, v)?;
            }
        }
        Ok(())
    }

    /// The lean limit a plan may ask for, degrees (default [`DEFAULT_MAX_TILT_DEG`]).
    pub fn max_tilt(&self) -> f64 {
        self.max_tilt_deg.unwrap_or(DEFAULT_MAX_TILT_DEG)
    }

    /// The share of the lean limit kept for the controller (default [`DEFAULT_LEAN_MARGIN`]).
    pub fn lean_margin(&self) -> f64 {
        self.lean_margin.unwrap_or(DEFAULT_LEAN_MARGIN)
    }

    /// The fall threshold, degrees (default: the preset controller's 20°).
    pub fn fall_tilt_deg(&self) -> f64 {
        self.fall_tilt_deg
            .unwrap_or_else(|| BalanceConfig::<f64>::preset().fall_tilt.to_degrees())
    }

    /// The physical parameters: the given values over [`PlantParams::preset`], with the
    /// geometry's ball and wheel radii.
    pub fn plant_params<T: Real>(&self, geometry: &BallbotParams<f64>) -> PlantParams<T> {
        let p = PlantParams::<f64>::preset();
        let j = self.body_moments().unwrap_or(p.body_inertia);
        PlantParams {
            ball_radius: T::of(geometry.ball_radius),
            wheel_radius: T::of(geometry.wheel_radius),
            ball_mass: T::of(self.ball_mass.unwrap_or(p.ball_mass)),
            ball_inertia: T::of(self.ball_inertia.unwrap_or(p.ball_inertia)),
            body_mass: T::of(self.body_mass.unwrap_or(p.body_mass)),
            body_inertia: j.map(T::of),
            com_height: T::of(self.com_height.unwrap_or(p.com_height)),
            floor_damping: T::of(self.floor_damping.unwrap_or(p.floor_damping)),
            relative_damping: T::of(self.relative_damping.unwrap_or(p.relative_damping)),
            gravity: T::of(p.gravity),
        }
    }

    /// The LQR weights: the given bounds over [`Weights::default`].
    pub fn weights(&self) -> Weights {
        let d = Weights::default();
        let Some(w) = &self.weights else {
            return d;
        };
        Weights {
            position: w.position.unwrap_or(d.position),
            tilt: w.tilt_deg.map_or(d.tilt, f64::to_radians),
            velocity: w.velocity.unwrap_or(d.velocity),
            tilt_rate: w.tilt_rate.unwrap_or(d.tilt_rate),
            torque: w.torque.unwrap_or(d.torque),
            yaw: w.yaw.unwrap_or(d.yaw),
            yaw_rate: w.yaw_rate.unwrap_or(d.yaw_rate),
            yaw_torque: w.yaw_torque.unwrap_or(d.yaw_torque),
        }
    }

    /// The balance controller's configuration: [`BalanceConfig::preset`] with this robot's
    /// geometry, parameters, torque limit, rate, fall threshold and weights.
    pub fn balance_config<T: Real>(&self, geometry: &BallbotParams<f64>) -> BalanceConfig<T> {
        let pre = BalanceConfig::<T>::preset();
        BalanceConfig {
            geometry: BallbotParams {
                ball_radius: T::of(geometry.ball_radius),
                wheel_radius: T::of(geometry.wheel_radius),
                zenith: T::of(geometry.zenith),
                azimuths: geometry.azimuths.map(T::of),
            },
            plant: self.plant_params(geometry),
            rate_hz: self.control_rate_hz.map_or(pre.rate_hz, T::of),
            weights: self.weights(),
            torque_limit: self.torque_limit.map_or(pre.torque_limit, T::of),
            fall_tilt: T::of(self.fall_tilt_deg().to_radians()),
            max_position_error: pre.max_position_error,
        }
    }

    /// The body acceleration a plan may ask for, m/s²: the acceleration the planar model
    /// holds at the lean limit ([`PlantParams::acceleration_for_lean`] of
    /// `max_tilt_deg`), less the `lean_margin` share kept for the controller.
    pub fn max_plan_acceleration(&self, geometry: &BallbotParams<f64>) -> f64 {
        let p = self.plant_params::<f64>(geometry);
        (1.0 - self.lean_margin()) * p.acceleration_for_lean(self.max_tilt().to_radians())
    }
}

impl super::RobotDescription {
    /// A `ballbot`'s balance controller configuration from its geometry and `[dynamics]` table
    /// (the preset's values where the table, or a key of it, is absent); `None` for another
    /// kind.
    pub fn balance_config<T: Real>(&self) -> Option<BalanceConfig<T>> {
        let super::Geometry::Ballbot(g) = &self.geometry else {
            return None;
        };
        Some(
            self.ballbot_dynamics
                .clone()
                .unwrap_or_default()
                .balance_config(g),
        )
    }

    /// The body acceleration a plan may ask of a `ballbot` (its lean limit less the
    /// controller's margin, [`BallbotDynamicsSpec::max_plan_acceleration`]), m/s², with the
    /// lean limit (degrees) and the margin it was computed from; `None` for another kind.
    pub fn lean_acceleration_limit(&self) -> Option<(f64, f64, f64)> {
        let super::Geometry::Ballbot(g) = &self.geometry else {
            return None;
        };
        let spec = self.ballbot_dynamics.clone().unwrap_or_default();
        Some((
            spec.max_plan_acceleration(g),
            spec.max_tilt(),
            spec.lean_margin(),
        ))
    }
}
