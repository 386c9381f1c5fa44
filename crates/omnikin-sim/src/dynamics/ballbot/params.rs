//! The ballbot's physical parameters ([`BallbotDynamics`]) and the preset's defaults.

use omnikin::ballbot::BallbotParams;
use omnikin::control::{PlantParams, validate_plant};

/// Physical parameters of a ballbot (SI units). The wheel geometry (ball radius `R`, wheel
/// radius `r_w`, contact zenith `α`, azimuths) is [`BallbotDynamics::geometry`].
///
/// [`BallbotDynamics::preset`] gives the values for `robots/ballbot.toml`: the geometry of the
/// preset (`R = 0.12 m`, `r_w = 0.05 m`, `α = 45°`) with the masses, inertias, centre of mass,
/// friction and motor limit of the **Kugle V1** ballbot (Aalborg University 2019, Jespersen's
/// thesis; `Parameters/Constants_Kugle.m` of its MATLAB repository: ball 1.478 kg of radius
/// 0.129 m with a 4 mm coating, body 16.15 kg with its centre of mass 0.421 m above the ball
/// centre, wheels 0.05 m at 45°, Maxon motors 30.5 mN·m/A at 15 A through a 13:3 gear). The
/// Kugle ball is 9 mm larger than the preset's; its inertia is recomputed for the preset's
/// radius as a thin shell inside the coating. Rezero (ETH 2010) is of the same class
/// (≈ 14.5 kg, ball radius 0.125 m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallbotDynamics {
    /// Wheel geometry (paper 001); `geometry.ball_radius` is the ball radius `R`, m.
    pub geometry: BallbotParams<f64>,
    /// Ball mass `m_b`, kg.
    pub ball_mass: f64,
    /// Ball moment of inertia about its centre `I_b`, kg·m² (thin shell: `⅔ m_b R²`).
    pub ball_inertia: f64,
    /// Body mass `m_B` (everything above the ball, wheels and motors included), kg.
    pub body_mass: f64,
    /// Body principal moments of inertia about its centre of mass, body axes `(x, y, z)`,
    /// kg·m².
    pub body_inertia: [f64; 3],
    /// Height `l` of the body's centre of mass above the ball centre, along the body z axis, m.
    pub com_height: f64,
    /// Largest wheel torque magnitude per motor (at the wheel), N·m.
    pub torque_limit: f64,
    /// Viscous damping of the ball's absolute rotation (floor rolling and spin), N·m·s/rad.
    pub floor_damping: f64,
    /// Viscous damping of the ball's rotation relative to the body (wheels, gears),
    /// N·m·s/rad.
    pub relative_damping: f64,
    /// Gravitational acceleration, m/s².
    pub gravity: f64,
}

impl BallbotDynamics {
    /// The `ballbot` preset's values (see the type doc; the numbers are the core's
    /// [`PlantParams::preset`] and [`omnikin::control::PRESET_TORQUE_LIMIT`]).
    pub fn preset() -> Self {
        let p = PlantParams::<f64>::preset();
        Self {
            geometry: BallbotParams::<f64>::preset(),
            ball_mass: p.ball_mass,
            ball_inertia: p.ball_inertia,
            body_mass: p.body_mass,
            body_inertia: p.body_inertia,
            com_height: p.com_height,
            torque_limit: omnikin::control::PRESET_TORQUE_LIMIT,
            floor_damping: p.floor_damping,
            relative_damping: p.relative_damping,
            gravity: p.gravity,
        }
    }

    /// The robot a balance controller configuration describes (its geometry, plant
    /// parameters and torque limit), e.g. a robot file's
    /// [`omnikin::description::RobotDescription::balance_config`].
    pub fn from_config(c: &omnikin::control::BalanceConfig<f64>) -> Self {
        let p = c.plant;
        Self {
            geometry: c.geometry,
            ball_mass: p.ball_mass,
            ball_inertia: p.ball_inertia,
            body_mass: p.body_mass,
            body_inertia: p.body_inertia,
            com_height: p.com_height,
            torque_limit: c.torque_limit,
            floor_damping: p.floor_damping,
            relative_damping: p.relative_damping,
            gravity: p.gravity,
        }
    }

    /// The same robot without friction (energy is conserved when the motors are off).
    pub fn frictionless(self) -> Self {
        Self {
            floor_damping: 0.0,
            relative_damping: 0.0,
            ..self
        }
    }

    /// Total mass, kg.
    pub fn total_mass(&self) -> f64 {
        self.ball_mass + self.body_mass
    }

    /// The parameters as the core's controller takes them.
    pub fn plant_params(&self) -> PlantParams<f64> {
        PlantParams {
            ball_radius: self.geometry.ball_radius,
            wheel_radius: self.geometry.wheel_radius,
            ball_mass: self.ball_mass,
            ball_inertia: self.ball_inertia,
            body_mass: self.body_mass,
            body_inertia: self.body_inertia,
            com_height: self.com_height,
            floor_damping: self.floor_damping,
            relative_damping: self.relative_damping,
            gravity: self.gravity,
        }
    }

    /// Checks every parameter (positive masses, inertias, lengths, gravity, torque limit;
    /// damping ≥ 0; a valid wheel geometry).
    ///
    /// # Errors
    /// [`omnikin::control::BalanceError`] naming the parameter.
    pub fn validate(&self) -> Result<(), omnikin::control::BalanceError> {
        omnikin::ballbot::Ballbot::new(self.geometry)?;
        validate_plant(&self.plant_params())?;
        if !(self.torque_limit.is_finite() && self.torque_limit > 0.0) {
            return Err(omnikin::control::BalanceError::Parameter {
                field: "torque_limit",
                value: self.torque_limit,
                rule: "must be finite and > 0",
            });
        }
        Ok(())
    }
}
