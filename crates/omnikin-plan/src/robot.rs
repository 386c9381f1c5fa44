//! The robot as the planner sees it: a core kinematic model plus the motor limits of its
//! description file, with the motor rates arranged as up to six "channels"
//! (wheel 1–3, and for the caster steer 1–3).

use omnikin::description::{Limits, RobotDescription};
use omnikin::{Actuators, Robot, Twist2};

use crate::PlanningError;

/// A robot model with its motor limits (from the robot file's `[limits]`).
#[derive(Clone, Debug, PartialEq)]
pub struct RobotModel {
    /// Display name (the description's `name`).
    pub name: String,
    /// The kinematic model (paper 000 sphere, paper 001 ballbot or paper 003 caster base).
    pub model: Robot<f64>,
    /// Motor limits; `None` = unlimited.
    pub limits: Limits,
}

/// Motor rates of one instant: wheel (roll) rates and, for the caster, steer rates (rad/s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorRates {
    /// Wheel rates `w1, w2, w3` (sphere `χ̇_i`, ballbot `ψ̇_i`, caster roll `φ̇_i`), rad/s.
    pub wheel: [f64; 3],
    /// Caster only: steer rates `γ̇_i`, rad/s.
    pub steer: Option<[f64; 3]>,
}

/// A limited quantity of one motor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Quantity {
    /// Wheel (roll) rate, rad/s (`limits.max_wheel_rate`).
    WheelRate,
    /// Wheel (roll) acceleration, rad/s² (`limits.max_wheel_accel`).
    WheelAccel,
    /// Caster steer rate, rad/s (`limits.max_steer_rate`).
    SteerRate,
    /// Caster steer acceleration, rad/s² (`limits.max_steer_accel`).
    SteerAccel,
}

impl Quantity {
    /// The robot file key of the limit, e.g. `max_wheel_rate`.
    pub fn key(self) -> &'static str {
        match self {
            Quantity::WheelRate => "max_wheel_rate",
            Quantity::WheelAccel => "max_wheel_accel",
            Quantity::SteerRate => "max_steer_rate",
            Quantity::SteerAccel => "max_steer_accel",
        }
    }

    /// Unit, `rad/s` or `rad/s²`.
    pub fn unit(self) -> &'static str {
        match self {
            Quantity::WheelRate | Quantity::SteerRate => "rad/s",
            Quantity::WheelAccel | Quantity::SteerAccel => "rad/s²",
        }
    }

    /// The motor kind, `wheel` or `steer`.
    pub fn motor(self) -> &'static str {
        match self {
            Quantity::WheelRate | Quantity::WheelAccel => "wheel",
            Quantity::SteerRate | Quantity::SteerAccel => "steer",
        }
    }

    /// `true` for an acceleration.
    pub fn is_accel(self) -> bool {
        matches!(self, Quantity::WheelAccel | Quantity::SteerAccel)
    }

    /// The quantity of channel `ch` (0–2 wheels, 3–5 steer motors) and order (rate/accel).
    pub(crate) fn of(ch: usize, accel: bool) -> Self {
        match (ch < 3, accel) {
            (true, false) => Quantity::WheelRate,
            (true, true) => Quantity::WheelAccel,
            (false, false) => Quantity::SteerRate,
            (false, true) => Quantity::SteerAccel,
        }
    }
}

impl RobotModel {
    /// Builds the `f64` model of a validated description.
    ///
    /// # Errors
    /// [`PlanningError::Robot`] if the model cannot be built (it can for every description that
    /// loaded).
    pub fn from_description(d: &RobotDescription) -> Result<Self, PlanningError> {
        let model = d
            .build::<f64>()
            .map_err(|e| PlanningError::Robot(e.to_string()))?;
        Ok(Self {
            name: d.name.clone(),
            model,
            limits: d.limits,
        })
    }

    /// `true` for the caster base (paper 003), whose plans carry steer angles and rates.
    pub fn is_caster(&self) -> bool {
        matches!(self.model, Robot::Caster(_))
    }

    /// Number of motor channels: 3, or 6 for the caster.
    pub fn channels(&self) -> usize {
        if self.is_caster() { 6 } else { 3 }
    }

    /// Rate limit (rad/s) of channel `ch` (0–2 wheels, 3–5 steer motors).
    pub fn rate_limit(&self, ch: usize) -> Option<f64> {
        if ch < 3 {
            self.limits.max_wheel_rate
        } else {
            self.limits.max_steer_rate
        }
    }

    /// Acceleration limit (rad/s²) of channel `ch`.
    pub fn accel_limit(&self, ch: usize) -> Option<f64> {
        if ch < 3 {
            self.limits.max_wheel_accel
        } else {
            self.limits.max_steer_accel
        }
    }

    /// **Inverse kinematics** through the core crate for a world-frame twist `(ẋ, ẏ, ψ̇)`
    /// (m/s, m/s, rad/s) at heading `ψ` (rad) — sphere: `SphereOmni::wheel_rates_world` with
    /// shell spin `Ω3 = 0` (paper 000, eqs. 5.6–5.7); ballbot: `Ballbot::wheel_rates_world`
    /// with ball spin 0 (paper 001); caster: `Caster3::motor_rates` at steer angles `steer`
    /// (rad; paper 003, eq. 2). The result is linear in the twist.
    ///
    /// # Errors
    /// [`PlanningError::Kinematics`] for non-finite input.
    pub fn rates(
        &self,
        heading: f64,
        twist_world: Twist2<f64>,
        steer: [f64; 3],
    ) -> Result<MotorRates, PlanningError> {
        let a = self
            .model
            .inverse_world(twist_world, heading, &Actuators::at_steer(&steer))?;
        Ok(MotorRates {
            wheel: [a.wheel_rates[0], a.wheel_rates[1], a.wheel_rates[2]],
            steer: self
                .is_caster()
                .then(|| [a.steer_rates[0], a.steer_rates[1], a.steer_rates[2]]),
        })
    }

    /// [`RobotModel::rates`] with the heading's `(cos ψ, sin ψ)` given (the planner has them
    /// from the path tangent): the sphere and the ballbot rotate the twist into the robot frame
    /// with them instead of evaluating `sin_cos(ψ)` (paper 000, eq. 5.4); the caster uses
    /// `heading` as [`RobotModel::rates`] does. For the sphere and ballbot a non-finite input
    /// is reported through the robot-frame twist it produces (the first non-finite component),
    /// not by the world-frame field or `"heading"`: the planner validates its inputs before.
    pub(crate) fn rates_cs(
        &self,
        heading: f64,
        cs: [f64; 2],
        twist_world: Twist2<f64>,
        steer: [f64; 3],
    ) -> Result<MotorRates, PlanningError> {
        // World → robot frame: the rotation by −ψ, whose (sin, cos) is (−sin ψ, cos ψ).
        let body = twist_world.rotated_by(omnikin::drive::Rot2 {
            cos: cs[0],
            sin: -cs[1],
        });
        if self.is_caster() {
            return self.rates(heading, twist_world, steer);
        }
        let a = self.model.inverse(body, &Actuators::zero())?;
        let wheel = [a.wheel_rates[0], a.wheel_rates[1], a.wheel_rates[2]];
        Ok(MotorRates { wheel, steer: None })
    }

    /// [`RobotModel::channel_rates`] with the heading's `(cos ψ, sin ψ)` given (see
    /// [`RobotModel::rates_cs`]).
    pub(crate) fn channel_rates_cs(
        &self,
        heading: f64,
        cs: [f64; 2],
        twist_world: Twist2<f64>,
        steer: [f64; 3],
    ) -> Result<[f64; 6], PlanningError> {
        let r = self.rates_cs(heading, cs, twist_world, steer)?;
        let s = r.steer.unwrap_or([0.0; 3]);
        Ok([r.wheel[0], r.wheel[1], r.wheel[2], s[0], s[1], s[2]])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_with_a_given_heading_cosine_match_the_trigonometric_ones() {
        for name in ["sphere-omni", "ballbot", "caster3"] {
            let d = RobotDescription::preset(name).expect("preset");
            let robot = RobotModel::from_description(&d).expect("model");
            for i in 0..200 {
                let x = i as f64;
                let heading = 7.0 * (0.37 * x).sin() - 1.0;
                let twist = Twist2::new((1.3 * x).cos(), (0.7 * x).sin() * 0.8, (2.1 * x).sin());
                let steer = [(0.3 * x).sin(), 1.0 - (0.2 * x).cos(), -(0.5 * x).sin()];
                let want = robot.rates(heading, twist, steer).expect("rates");
                let (s, c) = heading.sin_cos();
                let got = robot
                    .rates_cs(heading, [c, s], twist, steer)
                    .expect("rates");
                let channels = robot
                    .channel_rates_cs(heading, [c, s], twist, steer)
                    .expect("rates");
                let want_steer = want.steer.unwrap_or([0.0; 3]);
                assert_eq!(got.steer.is_some(), want.steer.is_some(), "{name}");
                let got_steer = got.steer.unwrap_or([0.0; 3]);
                for j in 0..3 {
                    for (g, w) in [
                        (got.wheel[j], want.wheel[j]),
                        (channels[j], want.wheel[j]),
                        (got_steer[j], want_steer[j]),
                        (channels[3 + j], want_steer[j]),
                    ] {
                        assert!(
                            (g - w).abs() <= 1e-12 * (1.0 + w.abs()),
                            "{name} heading {heading} motor {j}: {g} vs {w}"
                        );
                    }
                }
            }
            let bad = Twist2::new(f64::NAN, 0.0, 0.0);
            assert!(
                robot
                    .channel_rates_cs(0.0, [1.0, 0.0], bad, [0.0; 3])
                    .is_err()
            );
        }
    }
}
