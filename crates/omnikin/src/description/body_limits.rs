//! The body's acceleration and jerk limits: one set, from the robot file, that `plan`,
//! `simulate`, `robot` (the runtime's slew limits) and `drive` all use.
//!
//! A robot file may state them in `[limits]` (`max_accel` m/s², `max_yaw_accel` rad/s²,
//! `max_jerk` m/s³). Absent, the accelerations are derived from `max_wheel_accel` (and
//! `max_steer_accel` for steerable kinds): the wheel rates are linear in the robot-frame twist
//! (`ω = J v`, at fixed steer angles), so a body acceleration `a` from rest needs the wheel
//! accelerations `J a`. [`BodyLimits`]' `max_accel` is the largest `|a|` whose wheel
//! accelerations stay within `max_wheel_accel` in **every** direction (no yaw, no shell spin,
//! a steerable robot's wheels steered along the motion, sampled every
//! [`DIRECTION_STEP_DEG`]°): the isotropic limit a world-frame slew can hold at any heading.
//! `max_yaw_accel` is the same for a turn on the spot. A ballbot's linear limit is the smaller
//! of that and its lean limit ([`RobotDescription::lean_acceleration_limit`]). Without wheel
//! limits either, the runtime's historical defaults apply ([`DEFAULT_ACCEL`],
//! [`DEFAULT_YAW_ACCEL`]). The jerk is never derived (wheel limits say nothing about it):
//! absent means unlimited.
//!
//! The derivation ignores what a motion already under way adds (a rotating robot's
//! centripetal terms `ψ̇ × v`, a combined translation and turn): the runtime keeps limiting
//! every motor's acceleration on its own (`Config::wheel_accel`).

use std::format;
use std::string::{String, ToString};

use crate::{Actuators, Robot, Twist2};

use super::RobotDescription;

/// Plausible range of `limits.max_accel`, m/s² (the runtime's `Config::validate` range).
pub const BODY_ACCEL_RANGE: (f64, f64) = (1e-6, 1e3);
/// Plausible range of `limits.max_yaw_accel`, rad/s² (the runtime's range).
pub const YAW_ACCEL_RANGE: (f64, f64) = (1e-6, 1e4);
/// Plausible range of `limits.max_jerk`, m/s³ (the runtime's range).
pub const BODY_JERK_RANGE: (f64, f64) = (1e-6, 1e6);
/// Linear acceleration of a robot file with neither `max_accel` nor `max_wheel_accel`, m/s².
pub const DEFAULT_ACCEL: f64 = 1.0;
/// Yaw acceleration of a robot file with neither `max_yaw_accel` nor `max_wheel_accel`,
/// rad/s².
pub const DEFAULT_YAW_ACCEL: f64 = 4.0;
/// Spacing of the directions the derivation samples, degrees (1440 directions: the worst
/// direction's wheel acceleration is underestimated by at most `1 − cos(0.125°)` ≈ 2.4·10⁻⁶).
pub const DIRECTION_STEP_DEG: f64 = 0.25;

/// Where one body limit came from (printed beside it, so a reader knows what to edit).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitSource {
    /// The robot file's `[limits]` key.
    File,
    /// Derived from the motor acceleration limits (`max_wheel_accel`, `max_steer_accel`).
    WheelLimits,
    /// A ballbot's lean limit (`[dynamics] max_tilt_deg` less `lean_margin`).
    LeanLimit,
    /// Neither given nor derivable: [`DEFAULT_ACCEL`] / [`DEFAULT_YAW_ACCEL`].
    Default,
    /// No limit (jerk not given).
    Unlimited,
    /// What the robot's runtime enforces, as its link handshake told the operator
    /// ([`crate::link::RobotLimits`]).
    Robot,
}

impl LimitSource {
    /// Words for a message: "limits.max_accel", "derived from limits.max_wheel_accel", ….
    pub fn describe(self, key: &str) -> String {
        match self {
            Self::File => format!("the robot file's limits.{key}"),
            Self::WheelLimits => "derived from limits.max_wheel_accel".to_string(),
            Self::LeanLimit => "the ballbot's lean limit".to_string(),
            Self::Default => "default: the robot file has no acceleration limits".to_string(),
            Self::Unlimited => "unlimited".to_string(),
            Self::Robot => "what the robot's runtime enforces, from its handshake".to_string(),
        }
    }
}

/// The body limits of a robot ([`RobotDescription::body_limits`]; module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyLimits {
    /// Largest linear (world-frame) acceleration, m/s².
    pub max_accel: f64,
    /// Where `max_accel` came from.
    pub max_accel_source: LimitSource,
    /// Largest yaw acceleration, rad/s².
    pub max_yaw_accel: f64,
    /// Where `max_yaw_accel` came from.
    pub max_yaw_accel_source: LimitSource,
    /// Largest linear jerk, m/s³ (`None`: unlimited).
    pub max_jerk: Option<f64>,
    /// Where `max_jerk` came from ([`LimitSource::File`], or [`LimitSource::Unlimited`]).
    pub max_jerk_source: LimitSource,
}

impl RobotDescription {
    /// The body acceleration and jerk limits (module doc: from `[limits]`, else derived from
    /// the motor acceleration limits, else the defaults).
    pub fn body_limits(&self) -> BodyLimits {
        let derived = self.build::<f64>().ok().and_then(|r| {
            derive(
                &r,
                self.limits.max_wheel_accel?,
                self.limits.max_steer_accel,
            )
        });
        let lean = self.lean_acceleration_limit().map(|(a, _, _)| a);
        let (max_accel, max_accel_source) = match (self.limits.max_accel, derived, lean) {
            (Some(a), _, _) => (a, LimitSource::File),
            (None, Some((a, _)), Some(l)) if l < a => (l, LimitSource::LeanLimit),
            (None, Some((a, _)), _) => (a, LimitSource::WheelLimits),
            (None, None, Some(l)) => (l, LimitSource::LeanLimit),
            (None, None, None) => (DEFAULT_ACCEL, LimitSource::Default),
        };
        let (max_yaw_accel, max_yaw_accel_source) = match (self.limits.max_yaw_accel, derived) {
            (Some(a), _) => (a, LimitSource::File),
            (None, Some((_, y))) => (y, LimitSource::WheelLimits),
            (None, None) => (DEFAULT_YAW_ACCEL, LimitSource::Default),
        };
        BodyLimits {
            max_accel,
            max_accel_source,
            max_yaw_accel,
            max_yaw_accel_source,
            max_jerk: self.limits.max_jerk,
            max_jerk_source: match self.limits.max_jerk {
                Some(_) => LimitSource::File,
                None => LimitSource::Unlimited,
            },
        }
    }
}

/// `(max_accel, max_yaw_accel)` within the motor acceleration limits (module doc), or `None`
/// when the inverse kinematics fails or a limit is not finite.
fn derive(robot: &Robot<f64>, wheel_accel: f64, steer_accel: Option<f64>) -> Option<(f64, f64)> {
    let n = robot.wheels();
    // The largest share of a motor limit that the unit acceleration `t` takes.
    let share = |t: Twist2<f64>| -> Option<f64> {
        let current = if robot.steerable() {
            Actuators::at_steer(&robot.aligned_steer(t).ok()?[..n])
        } else {
            Actuators::zero()
        };
        let a = robot.inverse(t, &current).ok()?;
        let wheel = a.wheel_rates[..n]
            .iter()
            .fold(0.0f64, |m, w| m.max(w.abs()))
            / wheel_accel;
        let steer = match steer_accel {
            Some(s) if robot.steerable() => {
                a.steer_rates[..n]
                    .iter()
                    .fold(0.0f64, |m, w| m.max(w.abs()))
                    / s
            }
            _ => 0.0,
        };
        Some(wheel.max(steer))
    };
    let steps = (360.0 / DIRECTION_STEP_DEG) as usize;
    let mut worst = 0.0f64;
    for k in 0..steps {
        let th = (k as f64 * DIRECTION_STEP_DEG).to_radians();
        worst = worst.max(share(Twist2::new(th.cos(), th.sin(), 0.0))?);
    }
    let yaw = share(Twist2::new(0.0, 0.0, 1.0))?;
    let ok = |s: f64| (s.is_finite() && s > 0.0).then(|| 1.0 / s);
    Some((ok(worst)?, ok(yaw)?))
}
