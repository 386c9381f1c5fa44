//! What a caller asks of the planner: the motion limits ([`MotionLimits`]), the timing law
//! ([`Timing`]), what to do at a motor limit ([`OnLimit`]), a steerable robot's initial steer angles
//! ([`InitialSteer`]), all bundled in [`PlanOptions`].

use omnikin::MAX_WHEELS;

use crate::PlanningError;
use crate::limits::check_range;
use crate::profile::ProfileKind;

/// Requested limits of the motion itself (not the motors'): along the path, and for turns in
/// place.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionLimits {
    /// Largest speed along the path, m/s.
    pub max_speed: f64,
    /// Largest tangential acceleration along the path, m/s².
    pub max_accel: f64,
    /// Largest jerk along the path, m/s³ (S-curve profiles only).
    pub max_jerk: f64,
    /// Largest yaw rate of a turn in place, rad/s.
    pub max_yaw_rate: f64,
    /// Largest yaw acceleration of a turn in place, rad/s² (an S-curve turn uses the jerk
    /// `max_yaw_accel · max_jerk / max_accel`, so its ramps take as long as the path's).
    pub max_yaw_accel: f64,
}

impl Default for MotionLimits {
    /// 0.2 m/s, 0.5 m/s², 5 m/s³; turns in place 1 rad/s, 2 rad/s².
    fn default() -> Self {
        Self {
            max_speed: 0.2,
            max_accel: 0.5,
            max_jerk: 5.0,
            max_yaw_rate: 1.0,
            max_yaw_accel: 2.0,
        }
    }
}

impl MotionLimits {
    /// Checks every limit against its range in [`crate::limits`].
    pub(super) fn validate(&self, jerk: bool) -> Result<(), PlanningError> {
        use crate::limits::{
            ACCEL_RANGE, JERK_RANGE, SPEED_RANGE, YAW_ACCEL_RANGE, YAW_RATE_RANGE,
        };
        check_range("max speed", self.max_speed, SPEED_RANGE, "m/s")?;
        check_range("max acceleration", self.max_accel, ACCEL_RANGE, "m/s²")?;
        check_range("max yaw rate", self.max_yaw_rate, YAW_RATE_RANGE, "rad/s")?;
        check_range(
            "max yaw acceleration",
            self.max_yaw_accel,
            YAW_ACCEL_RANGE,
            "rad/s²",
        )?;
        if jerk {
            check_range("max jerk", self.max_jerk, JERK_RANGE, "m/s³")?;
        }
        Ok(())
    }
}

/// How the planner times the path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Timing {
    /// A trapezoidal or S-curve profile per move (rest to rest) within `limits`; slowed
    /// uniformly (time dilation) where a motor limit would be exceeded.
    Profile {
        /// Trapezoid or S-curve.
        kind: ProfileKind,
        /// Speed, acceleration and jerk limits of the motion.
        limits: MotionLimits,
    },
    /// The fastest timing that respects `limits` and every motor limit (forward–backward pass;
    /// jerk not limited).
    TimeOptimal {
        /// Speed and acceleration limits of the motion.
        limits: MotionLimits,
    },
    /// Constant speed `speed` (m/s) from the first sample to the last, no ramps — paper 000's
    /// circle law (eq. 6.3), which starts at full speed. Only for paths without stops.
    ConstantSpeed {
        /// Speed along the path, m/s.
        speed: f64,
    },
}

/// What to do when a requested (non-optimal) timing would exceed a motor limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnLimit {
    /// Slow the offending moves down until every limit holds, and report it.
    Retime,
    /// Refuse with [`PlanningError::LimitExceeded`] naming the motor, the rate, the time and
    /// the excess.
    Reject,
}

/// Initial steer angles of a steerable robot (caster, swerve; ignored for the others).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InitialSteer {
    /// Given steer angles `γ_i`, rad: entries `0..N` for `N` wheels (modules), the rest
    /// ignored ([`crate::per_wheel`] pads a slice).
    Given([f64; MAX_WHEELS]),
    /// The configuration the first motion needs ([`omnikin::Robot::aligned_steer`]). A
    /// swerve's modules point along their velocity in the first motion. A caster's wheels
    /// trail: each wheel trails its steering axis so its
    /// steer rate is zero at the start. Wheel `i`'s steering axis `F_i` moves with
    /// `v_F = (ẋ, ẏ) + θ̇ k × D(cos(α_i+θ), sin(α_i+θ))` (direction `χ`); the steer rate
    /// (paper 003, eq. 3) vanishes for `sin(β_i − χ) = θ̇ d/|v_F|`, which has two solutions.
    /// The planner takes the **trailing** one, `β_i = χ + π − asin(θ̇ d/|v_F|)` (for a pure
    /// translation `β_i = χ + π`, a roll rate `φ̇ = v/r > 0`), because it is the stable
    /// equilibrium of `dγ/ds`: a leading wheel (`β_i = χ`) would need ever larger steer rates
    /// to follow any curve (errors grow like `e^{s/d}`), as a shopping-cart caster flips round.
    /// `γ_i = β_i − α_i − θ` is wrapped into (−π, π].
    Aligned,
}

/// Everything the planner needs besides the path, heading law and robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanOptions {
    /// The timing law.
    pub timing: Timing,
    /// Re-time or reject when a motor limit would be exceeded (not used by
    /// [`Timing::TimeOptimal`], which never exceeds one).
    pub on_limit: OnLimit,
    /// Sampling rate of the output, Hz (samples at `k / rate`, plus the exact end time).
    pub rate: f64,
    /// Steerable kinds only: initial steer angles (a swerve's are the current angles of its
    /// first sample, which it keeps while at rest).
    pub initial_steer: InitialSteer,
}

/// The motion a plan starts with when it does not start at rest
/// ([`super::plan_from_velocity`]): world frame (conventions.md), SI units.
///
/// The velocity must lie along the path's first tangent (the plan moves along its path), and
/// the yaw rate, when given, must be the heading law's `dψ/ds` at the start times the speed
/// (`ψ̇ = ψ'(s) ṡ`, paper 000, §5: the heading is a function of the arc length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartVelocity {
    /// World-frame velocity along x, m/s.
    pub vx: f64,
    /// World-frame velocity along y, m/s.
    pub vy: f64,
    /// Yaw rate, rad/s; `None`: whatever the heading law gives at the start speed.
    pub yaw_rate: Option<f64>,
}

impl StartVelocity {
    /// At rest (a plan from it is [`super::plan`]'s, sample for sample).
    pub const REST: Self = Self {
        vx: 0.0,
        vy: 0.0,
        yaw_rate: None,
    };

    /// The speed `√(vx² + vy²)`, m/s.
    pub fn speed(&self) -> f64 {
        self.vx.hypot(self.vy)
    }

    /// From its components as the front ends take them (`--start-velocity VX,VY[,W]`,
    /// Python's `start_velocity=[vx, vy(, yaw_rate)]`; world frame, m/s, rad/s); `None` for
    /// another number of values.
    pub fn from_components(v: &[f64]) -> Option<Self> {
        match *v {
            [vx, vy] => Some(Self {
                vx,
                vy,
                yaw_rate: None,
            }),
            [vx, vy, w] => Some(Self {
                vx,
                vy,
                yaw_rate: Some(w),
            }),
            _ => None,
        }
    }
}
