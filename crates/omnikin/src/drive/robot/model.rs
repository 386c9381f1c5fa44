//! [`KindModel`]: what a concrete model implements to be a member of [`super::Robot`].

use super::*;

/// What a concrete model implements to be a member of [`Robot`]: the uniform verbs, in the
/// robot frame, on the fixed-capacity [`Actuators`] and [`EncoderAngles`]. See the
/// [module docs](super) for the frame of each verb.
pub trait KindModel<T: Real> {
    /// The kind.
    const KIND: Kind;

    /// Number of wheels (modules).
    fn wheels(&self) -> usize;

    /// Inverse kinematics of the robot-frame `twist`; `current` supplies steer angles where
    /// the kind needs them (caster: the steer state; swerve: the direction a stopped module
    /// keeps, and the optimisation reference). Steer rates of a swerve are 0 (steady twist).
    ///
    /// # Errors
    /// [`InputError`] for a non-finite input or an overflowing result.
    fn inverse(&self, twist: Twist2<T>, current: &Actuators<T>)
    -> Result<Actuators<T>, InputError>;

    /// [`KindModel::inverse`] with the robot-frame time derivative of the twist (`v̇x`, `v̇y`
    /// in m/s², `ω̇` in rad/s²), which fixes a swerve's steer rates. Default: ignores it.
    ///
    /// # Errors
    /// As [`KindModel::inverse`].
    fn inverse_accel(
        &self,
        twist: Twist2<T>,
        _twist_rate: Twist2<T>,
        current: &Actuators<T>,
    ) -> Result<Actuators<T>, InputError> {
        self.inverse(twist, current)
    }

    /// Steer angles (rad) aligned with the robot-frame `twist` a motion starts with, so that
    /// it starts without re-steering. Caster: each wheel **trails** its steering axis, the
    /// stable solution of a zero steer rate (paper 003, eq. 3; see
    /// [`Robot::aligned_steer`]); swerve: the module directions of the inverse (0 for a
    /// stopped module). Default (kinds without steering): zeros.
    ///
    /// # Errors
    /// [`InputError`] for a non-finite twist.
    fn aligned_steer(&self, twist: Twist2<T>) -> Result<[T; MAX_WHEELS], InputError> {
        crate::real::finite3(twist.to_array(), ["vx", "vy", "yaw_rate"])?;
        Ok([T::zero(); MAX_WHEELS])
    }

    /// For kinds whose steer angles follow the path by a first-order law rather than being
    /// set-points (the caster, paper 003, eq. 5): the length (m) over which they change, of
    /// the order of the wheel's eccentricity `d`. `None` for the others (default).
    fn steer_length(&self) -> Option<T> {
        None
    }

    /// Forward kinematics (least squares where over-determined).
    ///
    /// # Errors
    /// [`InputError`] for a non-finite actuator, a singular configuration or overflow.
    fn forward(&self, actuators: &Actuators<T>) -> Result<Motion<T>, InputError>;

    /// [`KindModel::inverse`] with the shell/ball spin `Ω3` about the vertical (rad/s) of the
    /// kinds that have one ([`Kind::has_vertical_spin`]). Default: only `Ω3 = 0` is accepted.
    ///
    /// # Errors
    /// As [`KindModel::inverse`]; [`InputError::Singular`] for a non-zero spin of a kind
    /// without one.
    #[inline]
    fn inverse_spin(
        &self,
        twist: Twist2<T>,
        spin: T,
        current: &Actuators<T>,
    ) -> Result<Actuators<T>, InputError> {
        no_spin(spin)?;
        self.inverse(twist, current)
    }

    /// [`KindModel::forward`] with an assumed shell/ball spin (see
    /// [`KindModel::inverse_spin`]).
    ///
    /// # Errors
    /// As [`KindModel::forward`] and [`KindModel::inverse_spin`].
    fn forward_spin(&self, actuators: &Actuators<T>, spin: T) -> Result<Motion<T>, InputError> {
        no_spin(spin)?;
        self.forward(actuators)
    }

    /// The robot-frame displacement between two encoder readings (forward kinematics of the
    /// increments; steer increments wrapped into `(−π, π]`).
    ///
    /// # Errors
    /// As [`KindModel::forward`].
    fn displacement(
        &self,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<Motion<T>, InputError>;

    /// The pose after a step of robot-frame displacement `body` (heading change already
    /// chosen: wheels or gyro) from `pose`, and the step as a robot-frame pose change:
    /// `(delta, pose ⊕ delta)`. `rot` is the rotation of `pose.heading`
    /// (`Rot2::from_angle(pose.heading)`), which the caller keeps from the previous step so
    /// the step needs no `sin_cos` of its own. Default: the exact SE(2) exponential. The
    /// ballbot overrides it with paper 001's ball displacement between the two yaws.
    ///
    /// # Errors
    /// [`InputError`] from the kind's own step.
    #[inline]
    fn step_pose(
        &self,
        pose: Pose2<T>,
        rot: Rot2<T>,
        body: Twist2<T>,
        _start: &EncoderAngles<T>,
        _end: &EncoderAngles<T>,
    ) -> Result<(Pose2<T>, Pose2<T>), InputError> {
        let delta = se2::twist_exp(body, T::one());
        Ok((delta, se2::compose_rotated(pose, rot.sin, rot.cos, delta)))
    }

    /// The kind's torque map, if it has one.
    fn torque_space(&self) -> Option<TorqueSpace> {
        None
    }

    /// Writes the derived geometry a reader checks a robot file against (one line each; see
    /// [`crate::drive::report`]).
    ///
    /// # Errors
    /// The writer's.
    fn describe(&self, out: &mut dyn core::fmt::Write) -> core::fmt::Result;

    /// The fastest motion within the limits in closed form, where the kind has one; `None`:
    /// [`Robot::reach`] computes it from the inverse kinematics.
    fn closed_form_reach(
        &self,
        _max_wheel_rate: f64,
        _max_steer_rate: Option<f64>,
    ) -> Option<Reach> {
        None
    }

    /// Wheel torques (N·m) for the generalized forces `g` (see [`TorqueSpace`]) at the steer
    /// state of `steer_angles` (steerable kinds); minimum-norm where over-actuated.
    /// `None` when the kind has no torque map.
    fn wheel_torques(
        &self,
        _g: [T; 3],
        _steer_angles: &[T; MAX_WHEELS],
    ) -> Option<Result<[T; MAX_WHEELS], InputError>> {
        None
    }

    /// Generalized forces of wheel torques `tau` (N·m), the transpose of the velocity map.
    /// `None` when the kind has no torque map.
    fn generalized_forces(
        &self,
        _tau: &[T; MAX_WHEELS],
        _steer_angles: &[T; MAX_WHEELS],
    ) -> Option<Result<[T; 3], InputError>> {
        None
    }
}

/// `Ok` for a zero spin: kinds without a shell or ball have no spin to set.
fn no_spin<T: Real>(spin: T) -> Result<(), InputError> {
    crate::real::finite(spin, "shell_spin")?;
    if spin == T::zero() {
        Ok(())
    } else {
        Err(InputError::Singular {
            reason: "shell_spin applies only to kinds rolling on a shell or ball (sphere-omni, ballbot)",
        })
    }
}
