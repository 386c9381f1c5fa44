//! What the balance controller is built from: the LQR weights ([`Weights`]), the
//! configuration ([`BalanceConfig`], with the preset's values) and why a build fails
//! ([`BalanceError`]).

use super::lqr::LqrError;
use super::planar::{Plane, PlantParams};
use crate::ballbot::BallbotParams;
use crate::{GeometryError, Real};

/// Bryson's-rule bounds for the LQR weights (`Q_ii = 1/max²`, `R = 1/max²`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights {
    /// Acceptable ball position error, m.
    pub position: f64,
    /// Acceptable body tilt, rad.
    pub tilt: f64,
    /// Acceptable ball speed error, m/s.
    pub velocity: f64,
    /// Acceptable tilt rate, rad/s.
    pub tilt_rate: f64,
    /// Acceptable model torque `Tx`, `Ty`, N·m.
    pub torque: f64,
    /// Acceptable yaw error, rad.
    pub yaw: f64,
    /// Acceptable yaw-rate error, rad/s.
    pub yaw_rate: f64,
    /// Acceptable model torque `Tz`, N·m.
    pub yaw_torque: f64,
}

impl Default for Weights {
    /// Position 0.05 m, tilt 1° (0.01745 rad), speed 0.2 m/s, tilt rate 0.1 rad/s, torque
    /// 1 N·m; yaw 0.1 rad, yaw rate 0.5 rad/s, yaw torque 0.5 N·m. Chosen for the preset
    /// (Kugle-class): upright within 3 s from 5° without saturating, a 0.4 m square at 0.2 m/s
    /// within 5 cm.
    fn default() -> Self {
        Self {
            position: 0.05,
            tilt: 1.0f64.to_radians(),
            velocity: 0.2,
            tilt_rate: 0.1,
            torque: 1.0,
            yaw: 0.1,
            yaw_rate: 0.5,
            yaw_torque: 0.5,
        }
    }
}

/// Everything the balance controller is built from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BalanceConfig<T> {
    /// Wheel geometry (paper 001).
    pub geometry: BallbotParams<T>,
    /// Masses, inertias, centre-of-mass height, damping.
    pub plant: PlantParams<T>,
    /// Control rate, Hz.
    pub rate_hz: T,
    /// LQR weights.
    pub weights: Weights,
    /// Largest wheel torque magnitude, N·m (per motor, at the wheel).
    pub torque_limit: T,
    /// Tilt beyond which the robot counts as fallen (motors off), rad.
    pub fall_tilt: T,
    /// Largest position error the outer loop acts on, m.
    pub max_position_error: T,
}

/// Kugle's motor limit at the wheel: 13:3 gear × 30.5 mN·m/A × 15 A (its motor driver's
/// current limit) = 1.98 N·m.
pub const PRESET_TORQUE_LIMIT: f64 = 13.0 / 3.0 * 30.5e-3 * 15.0;

impl<T: Real> BalanceConfig<T> {
    /// The `ballbot` preset ([`BallbotParams::preset`], [`PlantParams::preset`]) at 200 Hz
    /// (Kugle's rate) with [`Weights::default`], the torque limit [`PRESET_TORQUE_LIMIT`], a
    /// fall threshold of 20° and a position-error bound of 0.3 m.
    pub fn preset() -> Self {
        Self {
            geometry: BallbotParams::preset(),
            plant: PlantParams::preset(),
            rate_hz: T::of(200.0),
            weights: Weights::default(),
            torque_limit: T::of(PRESET_TORQUE_LIMIT),
            fall_tilt: T::of(20.0f64.to_radians()),
            max_position_error: T::of(0.3),
        }
    }
}

impl From<GeometryError> for BalanceError {
    fn from(e: GeometryError) -> Self {
        Self::Geometry(e)
    }
}

/// Why a balance controller could not be built.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum BalanceError {
    /// The wheel geometry is invalid. Its message includes the cause, so the cause is not
    /// also its `source` (an error chain would print it twice).
    #[error("ballbot geometry: {0}")]
    Geometry(GeometryError),
    /// A physical or controller parameter is out of range.
    #[error("{field} = {value}: {rule}")]
    Parameter {
        /// The parameter.
        field: &'static str,
        /// Its value (SI).
        value: f64,
        /// The rule broken.
        rule: &'static str,
    },
    /// The LQR design of one planar model failed.
    #[error("LQR design of the {} model: {error}", plane.name())]
    Lqr {
        /// The planar model.
        plane: Plane,
        /// Why.
        error: LqrError,
    },
}

pub(crate) fn check(
    field: &'static str,
    v: f64,
    ok: bool,
    rule: &'static str,
) -> Result<(), BalanceError> {
    if v.is_finite() && ok {
        Ok(())
    } else {
        Err(BalanceError::Parameter {
            field,
            value: v,
            rule,
        })
    }
}

pub(crate) fn plant_f64<T: Real>(p: &PlantParams<T>) -> PlantParams<f64> {
    PlantParams {
        ball_radius: p.ball_radius.to_f64(),
        wheel_radius: p.wheel_radius.to_f64(),
        ball_mass: p.ball_mass.to_f64(),
        ball_inertia: p.ball_inertia.to_f64(),
        body_mass: p.body_mass.to_f64(),
        body_inertia: p.body_inertia.map(|v| v.to_f64()),
        com_height: p.com_height.to_f64(),
        floor_damping: p.floor_damping.to_f64(),
        relative_damping: p.relative_damping.to_f64(),
        gravity: p.gravity.to_f64(),
    }
}

/// Checks the physical parameters: positive masses, inertias, lengths, gravity; damping ≥ 0.
pub fn validate_plant<T: Real>(p: &PlantParams<T>) -> Result<(), BalanceError> {
    let p = plant_f64(p);
    const POS: &str = "must be finite and > 0";
    check("ball_radius", p.ball_radius, p.ball_radius > 0.0, POS)?;
    check("wheel_radius", p.wheel_radius, p.wheel_radius > 0.0, POS)?;
    check("ball_mass", p.ball_mass, p.ball_mass > 0.0, POS)?;
    check("ball_inertia", p.ball_inertia, p.ball_inertia > 0.0, POS)?;
    check("body_mass", p.body_mass, p.body_mass > 0.0, POS)?;
    const J: [&str; 3] = ["body_inertia[0]", "body_inertia[1]", "body_inertia[2]"];
    for i in 0..3 {
        check(J[i], p.body_inertia[i], p.body_inertia[i] > 0.0, POS)?;
    }
    check("com_height", p.com_height, p.com_height > 0.0, POS)?;
    check("gravity", p.gravity, p.gravity > 0.0, POS)?;
    const NONNEG: &str = "must be finite and ≥ 0";
    check(
        "floor_damping",
        p.floor_damping,
        p.floor_damping >= 0.0,
        NONNEG,
    )?;
    check(
        "relative_damping",
        p.relative_damping,
        p.relative_damping >= 0.0,
        NONNEG,
    )?;
    Ok(())
}
