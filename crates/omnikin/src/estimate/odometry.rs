//! Wheel odometry for all three robots: cumulative encoder angles in, world pose out, one fixed-size
//! step per encoder sample (no allocation, no panic).
//!
//! Each [`Odometry::update`] takes the encoder increments since the previous sample, turns them
//! into the robot-frame displacement of the step by the robot's forward kinematics (the maps are
//! linear in the rates, so they apply to angle increments directly), picks the heading change
//! from the chosen [`HeadingInput`] (wheels, integrated gyro, or an absolute yaw) and advances
//! the pose with the exact SE(2) exponential [`crate::se2::twist_exp`] — exact on arcs and
//! in-place turns (constant body twist over the step), second order otherwise, so no Euler drift.
//!
//! * **Sphere** (paper 000): pose of the shell centre; `ω̃Δ = G⁻¹ Δχ` gives the rolling distance
//!   `(R ω̃Δ_y, −R ω̃Δ_x)` in the platform frame and the wheel heading change `Ω3·Δt − ω̃Δ_z`.
//!   With a measured heading the shell spin `Ω3 = (ω̃Δ_z + Δψ)/Δt` (eq. 5.6 read backwards, see
//!   [`crate::sphere::SphereOmni::shell_spin`]) is reported in [`OdometryStep::shell_spin`].
//! * **Ballbot** (paper 001): pose of the ball centre and body yaw; the position step is
//!   [`crate::ballbot::Ballbot::ball_displacement`], which removes the part of the wheel motion
//!   caused by the body's own rotation. The ball's spin about the vertical is reported like the
//!   sphere's shell spin.
//! * **Caster** (paper 003): six encoders (roll angles `φ_i`, steer angles `γ_i`); steer
//!   increments `Δγ_i` play the role of steer rates, the least-squares forward kinematics
//!   [`crate::caster::Caster3::body_twist`] is evaluated at the mid-step steer angles, and its
//!   slip residual (divided by `Δt`, so in m/s) is exposed per step in
//!   [`OdometryStep::slip_residual`] and [`OdometryStep::wheel_slip`] so a caller can detect a
//!   slipping wheel.
//!
//! Frames and units follow the project conventions (REP-103, SI): world pose `(x, y, heading)`
//! in m, m, rad with the heading unwrapped; robot-frame increments in the frame of the pose at
//! the start of the step.

use core::num::NonZeroU32;

use crate::caster::CasterRates;
use crate::{InputError, Pose2, Real, Robot, Twist2, se2};
// Also the path `drive/` imports it by (`crate::odometry::wrap_angle`) until the lead's merge.
pub(crate) use crate::wrap_angle;

/// Why an odometry (or estimator) update was rejected. The state is left unchanged.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum OdometryError {
    /// An input value is NaN or infinite.
    #[error("{field} must be finite")]
    NonFinite {
        /// The input's name (e.g. `"t"`, `"wheel_angles[1]"`, `"gyro_rate"`).
        field: &'static str,
    },
    /// The sample's time does not increase strictly.
    #[error("time {t} s does not increase (previous sample at {previous} s)")]
    NonMonotonicTime {
        /// The rejected sample's time, s.
        t: f64,
        /// The previous sample's time, s.
        previous: f64,
    },
    /// The robot's forward kinematics rejected the increments (e.g. a singular caster
    /// configuration).
    #[error("forward kinematics: {0}")]
    Kinematics(InputError),
}

impl From<InputError> for OdometryError {
    fn from(e: InputError) -> Self {
        OdometryError::Kinematics(e)
    }
}

/// One encoder sample: time and cumulative angles. For the caster also the steer angles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncoderReading<T> {
    /// Sample time, s (must increase strictly from sample to sample).
    pub t: T,
    /// Cumulative wheel angles, rad (sphere: `χ_i` about `n_i`; ballbot: `ψ_i`; caster: roll
    /// angles `φ_i`), not wrapped: counters are expected to keep counting.
    pub wheel_angles: [T; 3],
    /// Caster only: steer angles `γ_i` relative to the body, rad (0 = pointing radially
    /// outward). May be wrapped (an absolute steer encoder); increments are wrapped into
    /// `(−π, π]`. Ignored for the sphere and the ballbot.
    pub steer_angles: [T; 3],
}

impl<T: Real> EncoderReading<T> {
    /// A sample of three wheel angles (sphere, ballbot); steer angles are set to 0.
    pub fn new(t: T, wheel_angles: [T; 3]) -> Self {
        Self {
            t,
            wheel_angles,
            steer_angles: [T::zero(); 3],
        }
    }

    /// A caster sample: roll angles `φ_i` and steer angles `γ_i` (rad).
    pub fn with_steer(t: T, wheel_angles: [T; 3], steer_angles: [T; 3]) -> Self {
        Self {
            t,
            wheel_angles,
            steer_angles,
        }
    }
}

/// Encoder counts → angle in rad: `2π · counts / counts_per_rev`. The counts are cumulative;
/// take differences of wrapping hardware counters with `wrapping_sub` before accumulating.
///
/// For `f32` firmware prefer accumulating counts as integers and converting only increments:
/// a cumulative angle of 10⁴ rad has an `f32` resolution of about 1 mrad.
#[inline]
pub fn counts_to_radians<T: Real>(counts: i64, counts_per_rev: NonZeroU32) -> T {
    T::of(counts as f64 * (core::f64::consts::TAU / counts_per_rev.get() as f64))
}

/// Where the heading change of a step comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HeadingInput<T> {
    /// From the wheels (forward kinematics; sphere and ballbot assume the shell/ball spin set
    /// with [`Odometry::with_assumed_spin`], 0 by default).
    Wheels,
    /// Gyro z rate at this sample, rad/s (bias already removed), integrated by the trapezoidal
    /// rule with the previous gyro sample (the rectangle rule on the first one).
    GyroRate(T),
    /// Absolute yaw at this sample, rad (e.g. from an AHRS or a magnetometer), possibly wrapped:
    /// the heading change is the wrapped difference to the previous yaw sample, so the output
    /// heading stays unwrapped. Falls back to [`HeadingInput::Wheels`] for a step without a
    /// previous yaw sample.
    Absolute(T),
}

/// What one odometry step produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryStep<T> {
    /// Sample time, s.
    pub t: T,
    /// Length of the step, s (0 for the first sample, which only sets the reference).
    pub dt: T,
    /// World pose after the step (m, m, rad unwrapped).
    pub pose: Pose2<T>,
    /// The step's pose change in the robot frame at its start (`pose = pose_before ⊕ delta`),
    /// the input a [`crate::estimate::estimator::PoseEstimator`] predicts with.
    pub delta: Pose2<T>,
    /// Mean robot-frame twist over the step (m/s, m/s, rad/s): `delta = exp(twist·dt)`.
    pub twist: Twist2<T>,
    /// Heading change implied by the wheels alone, rad (equals `delta.heading` with
    /// [`HeadingInput::Wheels`]); compare with a gyro to detect slip.
    pub wheel_heading_change: T,
    /// Caster: least-squares slip residual of the six encoder increments, m/s (mean over the
    /// step; see [`crate::caster::CasterForward::slip_residual`]). 0 for the other robots.
    pub slip_residual: T,
    /// Caster: per-wheel part of the slip residual, m/s. 0 for the other robots.
    pub wheel_slip: [T; 3],
    /// Sphere: shell spin `Ω3` about the vertical (rad/s, mean over the step) recovered from the
    /// wheels and the measured heading change, `Ω3 = (ω̃Δ_z + Δψ)/Δt` (paper 000, eq. 5.6);
    /// ballbot: the ball's spin, likewise. `None` when the heading comes from the wheels (then
    /// the spin is assumed, not measured), for the caster, and on the first sample.
    pub shell_spin: Option<T>,
}

/// Wheel odometry of one robot (WPILib-style `Odometry`): feed it every encoder sample with
/// [`Odometry::update`], read the pose. Fixed-size state, `Copy`, no allocation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Odometry<T> {
    robot: Robot<T>,
    pose: Pose2<T>,
    last: Option<EncoderReading<T>>,
    last_gyro: Option<T>,
    last_yaw: Option<T>,
    assumed_spin: T,
}

/// `Ok(x)` if finite, else [`OdometryError::NonFinite`] naming `field`.
#[inline]
fn finite<T: Real>(x: T, field: &'static str) -> Result<T, OdometryError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(OdometryError::NonFinite { field })
    }
}

/// The robot-frame increment of one step implied by the encoders alone.
struct WheelIncrement<T> {
    /// Robot-frame translation generator `(u, v)` (m): `delta = exp((u, v, Δθ))`.
    u: T,
    v: T,
    /// Heading change from the wheels, rad (sphere/ballbot: with zero spin).
    heading: T,
    /// Sphere/ballbot: `ω̃Δ_z` (rad), the relative rotation about the vertical.
    rel_z: T,
    slip: T,
    wheel_slip: [T; 3],
}

impl<T: Real> Odometry<T> {
    /// Odometry of `robot` starting at the world pose `pose` (m, m, rad). The first
    /// [`Odometry::update`] only records the encoder reference.
    pub fn new(robot: Robot<T>, pose: Pose2<T>) -> Self {
        Self {
            robot,
            pose,
            last: None,
            last_gyro: None,
            last_yaw: None,
            assumed_spin: T::zero(),
        }
    }

    /// Sets the shell (sphere) or ball (ballbot) spin `Ω3` about the vertical, rad/s, assumed
    /// when the heading comes from the wheels (default 0, "rubber rolling", paper 000 §5).
    pub fn with_assumed_spin(mut self, spin: T) -> Self {
        self.assumed_spin = spin;
        self
    }

    /// The robot model.
    pub fn robot(&self) -> &Robot<T> {
        &self.robot
    }

    /// The current world pose (m, m, rad unwrapped).
    pub fn pose(&self) -> Pose2<T> {
        self.pose
    }

    /// Time of the last accepted sample, s (`None` before the first).
    pub fn time(&self) -> Option<T> {
        self.last.map(|r| r.t)
    }

    /// Moves the pose to `pose` (e.g. after an external fix) without touching the encoder,
    /// gyro and yaw references (WPILib `resetPosition`): the next step continues from there.
    pub fn reset_pose(&mut self, pose: Pose2<T>) {
        self.pose = pose;
    }

    /// Advances the odometry by one encoder sample.
    ///
    /// The increments since the previous sample give the robot-frame translation through the
    /// forward kinematics (see the module docs per robot); the heading change comes from
    /// `heading`; the pose advances by the exact SE(2) step
    /// `pose ⊕ exp(u, v, Δθ)` ([`se2::twist_exp`], [`se2::compose`]), i.e. assuming a constant
    /// body twist over the step.
    ///
    /// # Errors
    /// [`OdometryError::NonFinite`] for a non-finite time, angle, gyro rate or yaw;
    /// [`OdometryError::NonMonotonicTime`] when `reading.t` does not exceed the previous
    /// sample's time; [`OdometryError::Kinematics`] when the forward kinematics fail. On error
    /// the state is unchanged.
    pub fn update(
        &mut self,
        reading: &EncoderReading<T>,
        heading: HeadingInput<T>,
    ) -> Result<OdometryStep<T>, OdometryError> {
        self.check_finite(reading, heading)?;
        let Some(prev) = self.last else {
            return Ok(self.first_sample(reading, heading));
        };
        let dt = reading.t - prev.t;
        if dt.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
            return Err(OdometryError::NonMonotonicTime {
                t: reading.t.to_f64(),
                previous: prev.t.to_f64(),
            });
        }
        // The rotation of the pose at the start of the step (every robot composes with it).
        let (sin0, cos0) = self.pose.heading.sin_cos();

        let inc = self.increment(&prev, reading)?;
        let spin_turn = self.assumed_spin * dt;
        let wheel_heading = match self.robot {
            Robot::Caster(_) => inc.heading,
            _ => inc.heading + spin_turn,
        };
        // The heading change of the step and whether it was measured.
        let (dtheta, measured) = match heading {
            HeadingInput::Wheels => (wheel_heading, false),
            HeadingInput::GyroRate(g) => {
                let g0 = self.last_gyro.unwrap_or(g);
                ((g0 + g) * T::of(0.5) * dt, true)
            }
            HeadingInput::Absolute(y) => match self.last_yaw {
                Some(y0) => (wrap_angle(y - y0), true),
                None => (wheel_heading, false),
            },
        };
        let body = Twist2::new(inc.u, inc.v, dtheta);
        let (delta, pose) = match self.robot {
            Robot::Ballbot(b) => {
                // Paper 001's odometry step: the world ball displacement between the two yaws.
                let yaw0 = self.pose.heading;
                let d = b.ball_displacement(
                    sub3(reading.wheel_angles, prev.wheel_angles),
                    yaw0,
                    yaw0 + dtheta,
                )?;
                let (s, c) = (sin0, cos0);
                let delta = Pose2::new(c * d[0] + s * d[1], -s * d[0] + c * d[1], dtheta);
                let pose = Pose2::new(self.pose.x + d[0], self.pose.y + d[1], yaw0 + dtheta);
                (delta, pose)
            }
            _ => {
                let delta = se2::twist_exp(body, T::one());
                (delta, se2::compose_rotated(self.pose, sin0, cos0, delta))
            }
        };
        let inv_dt = T::one() / dt;
        let shell_spin = match (&self.robot, measured) {
            (Robot::Caster(_), _) | (_, false) => None,
            _ => Some((inc.rel_z + dtheta) * inv_dt),
        };
        let step = OdometryStep {
            t: reading.t,
            dt,
            pose,
            delta,
            twist: Twist2::new(inc.u * inv_dt, inc.v * inv_dt, dtheta * inv_dt),
            wheel_heading_change: wheel_heading,
            slip_residual: inc.slip * inv_dt,
            wheel_slip: inc.wheel_slip.map(|s| s * inv_dt),
            shell_spin,
        };
        // Commit only after everything succeeded.
        self.pose = pose;
        self.last = Some(*reading);
        match heading {
            HeadingInput::GyroRate(g) => self.last_gyro = Some(g),
            HeadingInput::Absolute(y) => self.last_yaw = Some(y),
            HeadingInput::Wheels => {}
        }
        Ok(step)
    }

    /// The first sample: records the references, reports a zero step at the current pose.
    #[cold]
    fn first_sample(
        &mut self,
        reading: &EncoderReading<T>,
        heading: HeadingInput<T>,
    ) -> OdometryStep<T> {
        self.last = Some(*reading);
        match heading {
            HeadingInput::GyroRate(g) => self.last_gyro = Some(g),
            HeadingInput::Absolute(y) => self.last_yaw = Some(y),
            HeadingInput::Wheels => {}
        }
        OdometryStep {
            t: reading.t,
            dt: T::zero(),
            pose: self.pose,
            delta: Pose2::new(T::zero(), T::zero(), T::zero()),
            twist: Twist2::new(T::zero(), T::zero(), T::zero()),
            wheel_heading_change: T::zero(),
            slip_residual: T::zero(),
            wheel_slip: [T::zero(); 3],
            shell_spin: None,
        }
    }

    /// [`OdometryError::NonFinite`] naming the first non-finite input (`t`, then wheel `i`
    /// and, for the caster, steer `i` for `i = 0, 1, 2`, then the gyro rate or yaw).
    #[inline(always)]
    fn check_finite(
        &self,
        reading: &EncoderReading<T>,
        heading: HeadingInput<T>,
    ) -> Result<(), OdometryError> {
        let caster = matches!(self.robot, Robot::Caster(_));
        let h = match heading {
            HeadingInput::Wheels => T::zero(),
            HeadingInput::GyroRate(g) => g,
            HeadingInput::Absolute(y) => y,
        };
        let [w0, w1, w2] = reading.wheel_angles;
        let mut sum = reading.t + w0 + w1 + w2 + h;
        if caster {
            let [s0, s1, s2] = reading.steer_angles;
            sum += s0 + s1 + s2;
        }
        // One test for the usual case: a sum is finite if every term is (it may also be
        // infinite when finite terms overflow; the field-by-field pass below then finds nothing).
        if sum.is_finite() {
            return Ok(());
        }
        Self::first_non_finite(reading, heading, caster)
    }

    /// The field-by-field pass of [`Odometry::check_finite`].
    #[cold]
    #[inline(never)]
    fn first_non_finite(
        reading: &EncoderReading<T>,
        heading: HeadingInput<T>,
        caster: bool,
    ) -> Result<(), OdometryError> {
        const WHEEL: [&str; 3] = ["wheel_angles[0]", "wheel_angles[1]", "wheel_angles[2]"];
        const STEER: [&str; 3] = ["steer_angles[0]", "steer_angles[1]", "steer_angles[2]"];
        finite(reading.t, "t")?;
        for i in 0..3 {
            finite(reading.wheel_angles[i], WHEEL[i])?;
            if caster {
                finite(reading.steer_angles[i], STEER[i])?;
            }
        }
        match heading {
            HeadingInput::Wheels => {}
            HeadingInput::GyroRate(g) => {
                finite(g, "gyro_rate")?;
            }
            HeadingInput::Absolute(y) => {
                finite(y, "yaw")?;
            }
        }
        Ok(())
    }

    /// Robot-frame increment from the encoders alone (forward kinematics on increments).
    fn increment(
        &self,
        prev: &EncoderReading<T>,
        now: &EncoderReading<T>,
    ) -> Result<WheelIncrement<T>, OdometryError> {
        let dq = sub3(now.wheel_angles, prev.wheel_angles);
        let zero = [T::zero(); 3];
        match &self.robot {
            Robot::Sphere(m) => {
                // body_twist with Ω3 = 0 on increments: (R ω̃Δ_y, −R ω̃Δ_x, −ω̃Δ_z).
                let tw = m.body_twist(dq, T::zero())?;
                Ok(WheelIncrement {
                    u: tw.vx,
                    v: tw.vy,
                    heading: tw.yaw_rate,
                    rel_z: -tw.yaw_rate,
                    slip: T::zero(),
                    wheel_slip: zero,
                })
            }
            Robot::Ballbot(m) => {
                let tw = m.body_twist(dq, T::zero())?;
                Ok(WheelIncrement {
                    u: tw.vx,
                    v: tw.vy,
                    heading: tw.yaw_rate,
                    rel_z: -tw.yaw_rate,
                    slip: T::zero(),
                    wheel_slip: zero,
                })
            }
            Robot::Caster(m) => {
                let mut dg = zero;
                let mut mid = zero;
                for i in 0..3 {
                    dg[i] = wrap_angle(now.steer_angles[i] - prev.steer_angles[i]);
                    mid[i] = prev.steer_angles[i] + dg[i] * T::of(0.5);
                }
                let rates = CasterRates {
                    roll: dq,
                    steer: dg,
                };
                // Heading 0: the least-squares twist comes out in the robot frame. The angles
                // were checked, so the increments are finite unless a difference overflowed;
                // then the fit fails (a non-finite rate makes the yaw rate NaN) and the checked
                // path names the rate.
                let f = match m.body_twist_robot_unchecked(&rates, mid) {
                    Ok(f) => f,
                    Err(_) => m.body_twist(&rates, T::zero(), mid)?,
                };
                Ok(WheelIncrement {
                    u: f.twist.vx,
                    v: f.twist.vy,
                    heading: f.twist.yaw_rate,
                    rel_z: T::zero(),
                    slip: f.slip_residual,
                    wheel_slip: f.wheel_slip,
                })
            }
        }
    }
}

#[inline]
fn sub3<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts() {
        let cpr = NonZeroU32::new(4096).unwrap();
        let a: f64 = counts_to_radians(2048, cpr);
        assert!((a - core::f64::consts::PI).abs() < 1e-15);
        let b: f64 = counts_to_radians(-4096 * 3, cpr);
        assert!((b + 3.0 * core::f64::consts::TAU).abs() < 1e-12);
    }
}
