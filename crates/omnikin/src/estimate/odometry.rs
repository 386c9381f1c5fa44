//! Wheel odometry for every robot kind: cumulative encoder angles in, world pose out, one
//! fixed-size step per encoder sample (no allocation, no panic). The increments go through the
//! uniform [`crate::Robot::displacement`], so a kind added in `drive/robot/` has odometry.
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
//! * **Omni, swerve**: the least-squares forward kinematics of the wheel increments (swerve: at
//!   the end reading's steer angles, WPILib's `ToTwist2d`); with more wheels than three the
//!   slip residual is reported as for the caster.
//!
//! Frames and units follow the project conventions (REP-103, SI): world pose `(x, y, heading)`
//! in m, m, rad with the heading unwrapped; robot-frame increments in the frame of the pose at
//! the start of the step.

use core::num::NonZeroU32;

use crate::drive::Rot2;
use crate::{EncoderAngles, InputError, MAX_WHEELS, Pose2, Real, Robot, Twist2, wrap_angle};

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

/// One encoder sample: time and cumulative angles, for any robot (entries
/// `0..robot.wheels()` used, the rest ignored).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncoderReading<T> {
    /// Sample time, s (must increase strictly from sample to sample).
    pub t: T,
    /// Cumulative wheel angles, rad (sphere: `χ_i` about `n_i`; ballbot: `ψ_i`; caster: roll
    /// angles `φ_i`; omni and swerve: wheel angles), not wrapped: counters are expected to
    /// keep counting.
    pub wheel_angles: [T; MAX_WHEELS],
    /// Steerable kinds (caster, swerve): steer angles `γ_i` relative to the body, rad. May be
    /// wrapped (an absolute steer encoder); increments are wrapped into `(−π, π]`. Ignored for
    /// the other kinds.
    pub steer_angles: [T; MAX_WHEELS],
}

impl<T: Real> EncoderReading<T> {
    /// A sample of `N ≤ MAX_WHEELS` wheel angles (rad); steer angles are set to 0.
    pub fn new<const N: usize>(t: T, wheel_angles: [T; N]) -> Self {
        let a = EncoderAngles::new(&wheel_angles, &[]);
        Self {
            t,
            wheel_angles: a.wheel,
            steer_angles: a.steer,
        }
    }

    /// A sample of a steerable robot: wheel (roll) angles `φ_i` and steer angles `γ_i` (rad).
    pub fn with_steer<const N: usize>(t: T, wheel_angles: [T; N], steer_angles: [T; N]) -> Self {
        let a = EncoderAngles::new(&wheel_angles, &steer_angles);
        Self {
            t,
            wheel_angles: a.wheel,
            steer_angles: a.steer,
        }
    }

    /// The angles of the sample.
    #[inline]
    pub fn angles(&self) -> EncoderAngles<T> {
        EncoderAngles {
            wheel: self.wheel_angles,
            steer: self.steer_angles,
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
    /// the input a [`crate::estimate::fusion::PoseFusion`] predicts with.
    pub delta: Pose2<T>,
    /// Mean robot-frame twist over the step (m/s, m/s, rad/s): `delta = exp(twist·dt)`.
    pub twist: Twist2<T>,
    /// Heading change implied by the wheels alone, rad (equals `delta.heading` with
    /// [`HeadingInput::Wheels`]); compare with a gyro to detect slip.
    pub wheel_heading_change: T,
    /// Least-squares slip residual of the encoder increments, m/s (mean over the step; see
    /// [`crate::Motion::slip_residual`]): caster, swerve, omni with more than three wheels. 0
    /// for the kinds with exactly as many wheel constraints as unknowns.
    pub slip_residual: T,
    /// Per-wheel part of the slip residual, m/s (entries past the wheel count are 0).
    pub wheel_slip: [T; MAX_WHEELS],
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
    /// `Rot2::from_angle(pose.heading)`, kept with the pose: the next step composes with it
    /// and a control loop turns its commands with it ([`Odometry::rotation`]), so one
    /// `sin_cos` per step serves both.
    rot: Rot2<T>,
    /// Time of the last accepted sample, s (`None` before the first).
    last_t: Option<T>,
    /// Its angles (all zero before the first sample): kept as the [`EncoderAngles`] the
    /// kinematics take, so a step reads them in place instead of rebuilding them.
    last_angles: EncoderAngles<T>,
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

impl<T: Real> Odometry<T> {
    /// Odometry of `robot` starting at the world pose `pose` (m, m, rad). The first
    /// [`Odometry::update`] only records the encoder reference.
    pub fn new(robot: Robot<T>, pose: Pose2<T>) -> Self {
        Self {
            robot,
            pose,
            rot: Rot2::from_angle(pose.heading),
            last_t: None,
            last_angles: EncoderAngles::zero(),
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
        self.last_t
    }

    /// Moves the pose to `pose` (e.g. after an external fix) without touching the encoder,
    /// gyro and yaw references (WPILib `resetPosition`): the next step continues from there.
    pub fn reset_pose(&mut self, pose: Pose2<T>) {
        self.pose = pose;
        self.rot = Rot2::from_angle(pose.heading);
    }

    /// The rotation of the current heading, `Rot2::from_angle(self.pose().heading)` (kept
    /// with the pose, so free).
    #[inline]
    pub fn rotation(&self) -> Rot2<T> {
        self.rot
    }

    /// Advances the odometry by one encoder sample.
    ///
    /// The increments since the previous sample give the robot-frame translation through the
    /// forward kinematics (see the module docs per robot); the heading change comes from
    /// `heading`; the pose advances by the exact SE(2) step
    /// `pose ⊕ exp(u, v, Δθ)` ([`crate::se2::twist_exp`], [`crate::se2::compose`]), i.e. assuming a constant
    /// body twist over the step.
    ///
    /// # Errors
    /// [`OdometryError::NonFinite`] for a non-finite time, angle, gyro rate or yaw;
    /// [`OdometryError::NonMonotonicTime`] when `reading.t` does not exceed the previous
    /// sample's time; [`OdometryError::Kinematics`] when the forward kinematics fail. On error
    /// the state is unchanged.
    #[inline]
    pub fn update(
        &mut self,
        reading: &EncoderReading<T>,
        heading: HeadingInput<T>,
    ) -> Result<OdometryStep<T>, OdometryError> {
        self.update_angles(reading.t, &reading.angles(), heading)
    }

    /// [`Odometry::update`] of a sample given as its time `t` (s) and the HAL's
    /// [`EncoderAngles`] (rad), read in place: a control cycle that already holds the angles
    /// steps without building an [`EncoderReading`] (two 6-wide array copies fewer). Same
    /// result, same errors (an angle is named `wheel_angles[i]` / `steer_angles[i]`), same
    /// state on error.
    ///
    /// # Errors
    /// As [`Odometry::update`].
    #[inline]
    pub fn update_angles(
        &mut self,
        t: T,
        end: &EncoderAngles<T>,
        heading: HeadingInput<T>,
    ) -> Result<OdometryStep<T>, OdometryError> {
        self.check_finite(t, end, heading)?;
        let Some(t0) = self.last_t else {
            return Ok(self.first_sample(t, end, heading));
        };
        let dt = t - t0;
        if dt.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
            return Err(OdometryError::NonMonotonicTime {
                t: t.to_f64(),
                previous: t0.to_f64(),
            });
        }
        let start = &self.last_angles;
        // One dispatch on the kind for the whole kinematic step (see `KindStep`).
        let KindStepOut {
            inc,
            wheel_heading,
            dtheta,
            measured,
            delta,
            pose,
        } = self.robot.visit(KindStep {
            start,
            end,
            pose: self.pose,
            rot: self.rot,
            heading,
            spin_step: self.assumed_spin * dt,
            dt,
            last_gyro: self.last_gyro,
            last_yaw: self.last_yaw,
        })?;
        let spins = self.robot.kind().has_vertical_spin();
        let inv_dt = T::one() / dt;
        // Sphere/ballbot: the spin the measured heading reveals, `Ω3 = (ω̃Δ_z + Δψ)/Δt` with
        // `ω̃Δ_z = −(wheel heading change at zero spin)`.
        let shell_spin = if spins && measured {
            Some((dtheta - inc.twist.yaw_rate) * inv_dt)
        } else {
            None
        };
        let step = OdometryStep {
            t,
            dt,
            pose,
            delta,
            twist: Twist2::new(
                inc.twist.vx * inv_dt,
                inc.twist.vy * inv_dt,
                dtheta * inv_dt,
            ),
            wheel_heading_change: wheel_heading,
            slip_residual: inc.slip_residual * inv_dt,
            wheel_slip: inc.wheel_slip.map(|s| s * inv_dt),
            shell_spin,
        };
        // Commit only after everything succeeded.
        self.pose = pose;
        self.rot = Rot2::from_angle(pose.heading);
        self.last_t = Some(t);
        self.last_angles = *end;
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
        t: T,
        angles: &EncoderAngles<T>,
        heading: HeadingInput<T>,
    ) -> OdometryStep<T> {
        self.last_t = Some(t);
        self.last_angles = *angles;
        match heading {
            HeadingInput::GyroRate(g) => self.last_gyro = Some(g),
            HeadingInput::Absolute(y) => self.last_yaw = Some(y),
            HeadingInput::Wheels => {}
        }
        OdometryStep {
            t,
            dt: T::zero(),
            pose: self.pose,
            delta: Pose2::new(T::zero(), T::zero(), T::zero()),
            twist: Twist2::new(T::zero(), T::zero(), T::zero()),
            wheel_heading_change: T::zero(),
            slip_residual: T::zero(),
            wheel_slip: [T::zero(); MAX_WHEELS],
            shell_spin: None,
        }
    }

    /// [`OdometryError::NonFinite`] naming the first non-finite input (`t`, then wheel `i`
    /// and, for the caster, steer `i` for `i = 0, 1, 2`, then the gyro rate or yaw).
    #[inline(always)]
    fn check_finite(
        &self,
        t: T,
        angles: &EncoderAngles<T>,
        heading: HeadingInput<T>,
    ) -> Result<(), OdometryError> {
        let (n, steer) = (self.robot.wheels(), self.robot.steerable());
        let h = match heading {
            HeadingInput::Wheels => T::zero(),
            HeadingInput::GyroRate(g) => g,
            HeadingInput::Absolute(y) => y,
        };
        let mut sum = t + h;
        for i in 0..n {
            sum += angles.wheel[i];
            if steer {
                sum += angles.steer[i];
            }
        }
        // One test for the usual case: a sum is finite if every term is (it may also be
        // infinite when finite terms overflow; the field-by-field pass below then finds nothing).
        if sum.is_finite() {
            return Ok(());
        }
        Self::first_non_finite(t, angles, heading, n, steer)
    }

    /// The field-by-field pass of [`Odometry::check_finite`].
    #[cold]
    #[inline(never)]
    fn first_non_finite(
        t: T,
        angles: &EncoderAngles<T>,
        heading: HeadingInput<T>,
        n: usize,
        steer: bool,
    ) -> Result<(), OdometryError> {
        const WHEEL: [&str; MAX_WHEELS] = [
            "wheel_angles[0]",
            "wheel_angles[1]",
            "wheel_angles[2]",
            "wheel_angles[3]",
            "wheel_angles[4]",
            "wheel_angles[5]",
        ];
        const STEER: [&str; MAX_WHEELS] = [
            "steer_angles[0]",
            "steer_angles[1]",
            "steer_angles[2]",
            "steer_angles[3]",
            "steer_angles[4]",
            "steer_angles[5]",
        ];
        finite(t, "t")?;
        for i in 0..n {
            finite(angles.wheel[i], WHEEL[i])?;
            if steer {
                finite(angles.steer[i], STEER[i])?;
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
}

/// The kinematic part of [`Odometry::update`], run on the concrete model
/// ([`crate::Robot::visit`]): displacement, heading change of the step, pose step.
struct KindStep<'a, T> {
    start: &'a EncoderAngles<T>,
    end: &'a EncoderAngles<T>,
    pose: Pose2<T>,
    /// The rotation of `pose.heading`.
    rot: Rot2<T>,
    heading: HeadingInput<T>,
    /// The assumed vertical spin's heading change over the step (sphere, ballbot), rad.
    spin_step: T,
    dt: T,
    last_gyro: Option<T>,
    last_yaw: Option<T>,
}

/// What [`KindStep`] returns.
struct KindStepOut<T> {
    inc: crate::Motion<T>,
    wheel_heading: T,
    dtheta: T,
    measured: bool,
    delta: Pose2<T>,
    pose: Pose2<T>,
}

impl<T: Real> crate::drive::KindVisitor<T> for KindStep<'_, T> {
    type Output = Result<KindStepOut<T>, crate::InputError>;

    #[inline(always)]
    fn visit<M: crate::drive::KindModel<T>>(self, m: &M) -> Self::Output {
        let inc = m.displacement(self.start, self.end)?;
        let wheel_heading = if M::KIND.has_vertical_spin() {
            inc.twist.yaw_rate + self.spin_step
        } else {
            inc.twist.yaw_rate
        };
        // The heading change of the step and whether it was measured.
        let (dtheta, measured) = match self.heading {
            HeadingInput::Wheels => (wheel_heading, false),
            HeadingInput::GyroRate(g) => {
                let g0 = self.last_gyro.unwrap_or(g);
                ((g0 + g) * T::of(0.5) * self.dt, true)
            }
            HeadingInput::Absolute(y) => match self.last_yaw {
                Some(y0) => (wrap_angle(y - y0), true),
                None => (wheel_heading, false),
            },
        };
        let body = Twist2::new(inc.twist.vx, inc.twist.vy, dtheta);
        let (delta, pose) = m.step_pose(self.pose, self.rot, body, self.start, self.end)?;
        Ok(KindStepOut {
            inc,
            wheel_heading,
            dtheta,
            measured,
            delta,
            pose,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cached rotation is the heading's `sin_cos` after every step and pose reset.
    #[test]
    fn rotation_follows_the_heading() {
        use crate::ballbot::{Ballbot, BallbotParams};
        use crate::sphere::{SphereOmni, SphereParams};
        let robots = [
            Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap()),
            Robot::Ballbot(Ballbot::new(BallbotParams::preset()).unwrap()),
        ];
        for robot in robots {
            let mut odo = Odometry::new(robot, Pose2::new(0.5, -0.2, 2.9));
            assert_eq!(odo.rotation(), Rot2::from_angle(2.9));
            for k in 0..400 {
                let f = k as f64;
                let q = [0.31 * f, -0.07 * f * f * 1e-2, 0.2 * (0.1 * f).sin()];
                let r = EncoderReading::new(f * 1e-2, q);
                odo.update(&r, HeadingInput::Wheels).unwrap();
                assert_eq!(odo.rotation(), Rot2::from_angle(odo.pose().heading));
                if k == 200 {
                    odo.reset_pose(Pose2::new(1.0, 1.0, -7.0));
                    assert_eq!(odo.rotation(), Rot2::from_angle(-7.0));
                }
            }
            assert!(odo.pose().heading.abs() > 0.1, "the heading moved");
        }
    }

    #[test]
    fn counts() {
        let cpr = NonZeroU32::new(4096).unwrap();
        let a: f64 = counts_to_radians(2048, cpr);
        assert!((a - core::f64::consts::PI).abs() < 1e-15);
        let b: f64 = counts_to_radians(-4096 * 3, cpr);
        assert!((b + 3.0 * core::f64::consts::TAU).abs() < 1e-12);
    }
}
