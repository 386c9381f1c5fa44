//! The robot as the planner sees it: a core kinematic model plus the motor limits of its
//! description file, with its motors arranged as **channels**: `0..N` the `N` wheel motors,
//! `N..2N` the steer motors of steerable kinds ([`RobotModel::channel`] names them). Every
//! kinematic call goes through the uniform [`omnikin::Robot`] API.

use omnikin::description::{Limits, RobotDescription};
use omnikin::{Actuators, MAX_WHEELS, Robot, Twist2};

use crate::PlanningError;

/// A robot model with its motor limits (from the robot file's `[limits]`).
#[derive(Clone, Debug, PartialEq)]
pub struct RobotModel {
    /// Display name (the description's `name`).
    pub name: String,
    /// The kinematic model (any kind: sphere, ballbot, caster, omni, swerve).
    pub model: Robot<f64>,
    /// Motor limits; `None` = unlimited.
    pub limits: Limits,
}

/// Most motor channels of any robot: a wheel motor and a steer motor per wheel.
pub const MAX_CHANNELS: usize = 2 * MAX_WHEELS;

/// A limited quantity of one motor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Quantity {
    /// Wheel (roll) rate, rad/s (`limits.max_wheel_rate`).
    WheelRate,
    /// Wheel (roll) acceleration, rad/s² (`limits.max_wheel_accel`).
    WheelAccel,
    /// Steer rate (caster, swerve), rad/s (`limits.max_steer_rate`).
    SteerRate,
    /// Steer acceleration (caster, swerve), rad/s² (`limits.max_steer_accel`).
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

    /// Number of wheels (modules) `N`.
    pub fn wheels(&self) -> usize {
        self.model.wheels()
    }

    /// `true` for kinds with steer motors (caster, swerve), whose plans carry steer angles
    /// and rates.
    pub fn steerable(&self) -> bool {
        self.model.steerable()
    }

    /// Number of motor channels: `N` wheels, plus `N` steer motors for steerable kinds.
    pub fn channels(&self) -> usize {
        self.model.motors()
    }

    /// What channel `ch` is: its limited quantity (rate, or acceleration if `accel`) and its
    /// 1-based motor number (wheel `ch + 1` for `ch < N`, steer motor `ch − N + 1` after).
    pub fn channel(&self, ch: usize, accel: bool) -> (Quantity, usize) {
        let n = self.wheels();
        let q = match (ch < n, accel) {
            (true, false) => Quantity::WheelRate,
            (true, true) => Quantity::WheelAccel,
            (false, false) => Quantity::SteerRate,
            (false, true) => Quantity::SteerAccel,
        };
        (q, if ch < n { ch + 1 } else { ch - n + 1 })
    }

    /// Rate limit (rad/s) of channel `ch`.
    pub fn rate_limit(&self, ch: usize) -> Option<f64> {
        if ch < self.wheels() {
            self.limits.max_wheel_rate
        } else {
            self.limits.max_steer_rate
        }
    }

    /// Acceleration limit (rad/s²) of channel `ch`.
    pub fn accel_limit(&self, ch: usize) -> Option<f64> {
        if ch < self.wheels() {
            self.limits.max_wheel_accel
        } else {
            self.limits.max_steer_accel
        }
    }

    /// The channel values of actuators: wheel rates in `0..N`, steer rates in `N..2N`
    /// (steerable kinds), the rest 0 (rad/s).
    pub fn channel_values(&self, a: &Actuators<f64>) -> [f64; MAX_CHANNELS] {
        let n = self.wheels();
        let mut out = [0.0; MAX_CHANNELS];
        // Whole arrays and element loops: a slice copy of run-time length is a `memcpy` call.
        // The actuators' entries past `n` are 0, so the wheel rates fill 0..MAX_WHEELS.
        out[..MAX_WHEELS].copy_from_slice(&a.wheel_rates);
        if self.steerable() {
            #[allow(clippy::manual_memcpy)] // the slice copy is the memcpy call avoided here
            for i in 0..n {
                out[n + i] = a.steer_rates[i];
            }
        }
        out
    }

    /// **Inverse kinematics** through the core crate ([`Robot::inverse_accel`]) for a
    /// world-frame twist `(ẋ, ẏ, ψ̇)` (m/s, m/s, rad/s) at heading `ψ` (rad), with the
    /// robot-frame time derivative of the twist `twist_rate` (fixes a swerve's steer rates;
    /// ignored by the other kinds) and the `current` actuators (the caster's steer state, a
    /// swerve's current module angles). The wheel rates and the steer rates of kinds whose
    /// steering follows the twist are linear in the twist.
    ///
    /// # Errors
    /// [`PlanningError::Kinematics`] for non-finite input.
    pub fn actuators(
        &self,
        heading: f64,
        twist_world: Twist2<f64>,
        twist_rate: Twist2<f64>,
        current: &Actuators<f64>,
    ) -> Result<Actuators<f64>, PlanningError> {
        let (s, c) = heading.sin_cos();
        Ok(self.actuators_cs([c, s], twist_world, twist_rate, current)?)
    }

    /// [`RobotModel::actuators`] with the heading's `(cos ψ, sin ψ)` given (the planner has
    /// them from the path tangent), so no `sin_cos(ψ)` is evaluated (paper 000, eq. 5.4). A
    /// non-finite input is reported through the robot-frame twist it produces.
    #[inline]
    pub(crate) fn actuators_cs(
        &self,
        cs: [f64; 2],
        twist_world: Twist2<f64>,
        twist_rate: Twist2<f64>,
        current: &Actuators<f64>,
    ) -> Result<Actuators<f64>, omnikin::InputError> {
        // World → robot frame: the rotation by −ψ, whose (cos, sin) is (cos ψ, −sin ψ).
        let body = twist_world.rotated_by(omnikin::drive::Rot2 {
            cos: cs[0],
            sin: -cs[1],
        });
        self.model.inverse_accel(body, twist_rate, current)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_with_a_given_heading_cosine_match_the_trigonometric_ones() {
        for (name, _) in omnikin::description::PRESETS {
            let d = RobotDescription::preset(name).expect("preset");
            let robot = RobotModel::from_description(&d).expect("model");
            let n = robot.wheels();
            for i in 0..200 {
                let x = i as f64;
                let heading = 7.0 * (0.37 * x).sin() - 1.0;
                let twist = Twist2::new((1.3 * x).cos(), (0.7 * x).sin() * 0.8, (2.1 * x).sin());
                let rate = Twist2::new((0.9 * x).sin(), 0.3, (1.1 * x).cos());
                let steer: Vec<f64> = (0..n).map(|j| (0.3 * x + j as f64).sin()).collect();
                let current = Actuators::at_steer(&steer);
                let want = robot
                    .model
                    .inverse_accel(twist.to_robot(heading), rate, &current)
                    .expect("inverse");
                let (s, c) = heading.sin_cos();
                let got = robot
                    .actuators_cs([c, s], twist, rate, &current)
                    .expect("rates");
                let (gv, wv) = (robot.channel_values(&got), robot.channel_values(&want));
                for ch in 0..MAX_CHANNELS {
                    assert!(
                        (gv[ch] - wv[ch]).abs() <= 1e-12 * (1.0 + wv[ch].abs()),
                        "{name} heading {heading} channel {ch}: {} vs {}",
                        gv[ch],
                        wv[ch]
                    );
                    if ch >= robot.channels() {
                        assert_eq!(gv[ch], 0.0, "{name}");
                    }
                }
            }
            let bad = Twist2::new(f64::NAN, 0.0, 0.0);
            let zero = Twist2::new(0.0, 0.0, 0.0);
            assert!(
                robot
                    .actuators_cs([1.0, 0.0], bad, zero, &Actuators::zero())
                    .is_err()
            );
        }
    }

    #[test]
    fn channels_name_wheels_then_steer_motors() {
        for (name, _) in omnikin::description::PRESETS {
            let robot =
                RobotModel::from_description(&RobotDescription::preset(name).unwrap()).unwrap();
            let n = robot.wheels();
            assert_eq!(robot.channels(), if robot.steerable() { 2 * n } else { n });
            for ch in 0..robot.channels() {
                let (q, m) = robot.channel(ch, false);
                let (qa, ma) = robot.channel(ch, true);
                assert_eq!(m, ma);
                if ch < n {
                    assert_eq!(
                        (q, qa, m),
                        (Quantity::WheelRate, Quantity::WheelAccel, ch + 1)
                    );
                    assert_eq!(robot.rate_limit(ch), robot.limits.max_wheel_rate);
                } else {
                    assert_eq!(
                        (q, qa, m),
                        (Quantity::SteerRate, Quantity::SteerAccel, ch - n + 1)
                    );
                    assert_eq!(robot.accel_limit(ch), robot.limits.max_steer_accel);
                }
            }
        }
    }
}
