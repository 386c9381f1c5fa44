//! The [`KindModel`] implementation of every kind: each maps the uniform values onto its
//! model's own methods (the model stays in its own file under `drive/`).

use super::*;

/// The first `N` entries of a fixed-capacity vector.
#[inline(always)]
fn head<T: Copy, const N: usize>(a: &[T; MAX_WHEELS]) -> [T; N] {
    core::array::from_fn(|i| a[i])
}

/// `[T; N]` padded with zeros to the capacity.
#[inline(always)]
fn pad<T: Real, const N: usize>(a: &[T; N]) -> [T; MAX_WHEELS] {
    let mut out = [T::zero(); MAX_WHEELS];
    out[..N].copy_from_slice(a);
    out
}

/// Wheel-angle increments of the first `N` wheels.
#[inline(always)]
fn increments<T: Real, const N: usize>(start: &EncoderAngles<T>, end: &EncoderAngles<T>) -> [T; N] {
    core::array::from_fn(|i| end.wheel[i] - start.wheel[i])
}

/// A motion with no slip.
#[inline(always)]
fn rigid<T: Real>(twist: Twist2<T>) -> Motion<T> {
    Motion {
        twist,
        slip_residual: T::zero(),
        wheel_slip: [T::zero(); MAX_WHEELS],
    }
}

// ---- paper 000: the sphere --------------------------------------------------------------

impl<T: Real> KindModel<T> for SphereOmni<T> {
    const KIND: Kind = Kind::Sphere;

    fn describe(&self, out: &mut dyn core::fmt::Write) -> core::fmt::Result {
        report::sphere(self, out)
    }

    fn wheels(&self) -> usize {
        3
    }

    #[inline]
    fn inverse(&self, twist: Twist2<T>, _c: &Actuators<T>) -> Result<Actuators<T>, InputError> {
        Ok(Actuators::from_wheel_rates(
            &self.wheel_rates(twist, T::zero())?,
        ))
    }

    #[inline]
    fn forward(&self, a: &Actuators<T>) -> Result<Motion<T>, InputError> {
        Ok(rigid(self.body_twist(head(&a.wheel_rates), T::zero())?))
    }

    fn inverse_spin(
        &self,
        twist: Twist2<T>,
        spin: T,
        _c: &Actuators<T>,
    ) -> Result<Actuators<T>, InputError> {
        Ok(Actuators::from_wheel_rates(&self.wheel_rates(twist, spin)?))
    }

    fn forward_spin(&self, a: &Actuators<T>, spin: T) -> Result<Motion<T>, InputError> {
        Ok(rigid(self.body_twist(head(&a.wheel_rates), spin)?))
    }

    #[inline]
    fn displacement(
        &self,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<Motion<T>, InputError> {
        Ok(rigid(self.body_twist(increments(start, end), T::zero())?))
    }
}

// ---- paper 001: the ballbot -------------------------------------------------------------

impl<T: Real> KindModel<T> for Ballbot<T> {
    const KIND: Kind = Kind::Ballbot;

    fn describe(&self, out: &mut dyn core::fmt::Write) -> core::fmt::Result {
        report::ballbot(self, out)
    }

    fn wheels(&self) -> usize {
        3
    }

    #[inline]
    fn inverse(&self, twist: Twist2<T>, _c: &Actuators<T>) -> Result<Actuators<T>, InputError> {
        Ok(Actuators::from_wheel_rates(
            &self.wheel_rates(twist, T::zero())?,
        ))
    }

    #[inline]
    fn forward(&self, a: &Actuators<T>) -> Result<Motion<T>, InputError> {
        Ok(rigid(self.body_twist(head(&a.wheel_rates), T::zero())?))
    }

    fn inverse_spin(
        &self,
        twist: Twist2<T>,
        spin: T,
        _c: &Actuators<T>,
    ) -> Result<Actuators<T>, InputError> {
        Ok(Actuators::from_wheel_rates(&self.wheel_rates(twist, spin)?))
    }

    fn forward_spin(&self, a: &Actuators<T>, spin: T) -> Result<Motion<T>, InputError> {
        Ok(rigid(self.body_twist(head(&a.wheel_rates), spin)?))
    }

    #[inline]
    fn displacement(
        &self,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<Motion<T>, InputError> {
        Ok(rigid(self.body_twist(increments(start, end), T::zero())?))
    }

    /// Paper 001's odometry step: the world ball displacement between the two yaws.
    #[inline]
    fn step_pose(
        &self,
        pose: Pose2<T>,
        rot: Rot2<T>,
        body: Twist2<T>,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<(Pose2<T>, Pose2<T>), InputError> {
        let yaw0 = pose.heading;
        // `ball_displacement` at the start yaw `yaw0` whose rotation `rot` is given.
        let delta = self.ball_step(increments(start, end), body.yaw_rate)?;
        let d = [
            rot.cos * delta.x - rot.sin * delta.y,
            rot.sin * delta.x + rot.cos * delta.y,
        ];
        Ok((
            delta,
            Pose2::new(pose.x + d[0], pose.y + d[1], yaw0 + body.yaw_rate),
        ))
    }

    fn torque_space(&self) -> Option<TorqueSpace> {
        Some(TorqueSpace::BallbotModel)
    }

    fn wheel_torques(
        &self,
        g: [T; 3],
        _s: &[T; MAX_WHEELS],
    ) -> Option<Result<[T; MAX_WHEELS], InputError>> {
        Some(Ballbot::wheel_torques(self, g, T::zero()).map(|t| pad(&t)))
    }

    fn generalized_forces(
        &self,
        tau: &[T; MAX_WHEELS],
        _s: &[T; MAX_WHEELS],
    ) -> Option<Result<[T; 3], InputError>> {
        Some(self.model_torques(head(tau), T::zero()))
    }
}

// ---- paper 003: the caster base ---------------------------------------------------------

/// Caster motor rates of uniform actuators.
#[inline(always)]
fn caster_rates<T: Real>(a: &Actuators<T>) -> CasterRates<T> {
    CasterRates {
        roll: head(&a.wheel_rates),
        steer: head(&a.steer_rates),
    }
}

/// A caster fit as a uniform motion.
#[inline(always)]
fn caster_motion<T: Real>(f: crate::caster::CasterForward<T>) -> Motion<T> {
    Motion {
        twist: f.twist,
        slip_residual: f.slip_residual,
        wheel_slip: pad(&f.wheel_slip),
    }
}

impl<T: Real> KindModel<T> for Caster3<T> {
    const KIND: Kind = Kind::Caster;

    fn describe(&self, out: &mut dyn core::fmt::Write) -> core::fmt::Result {
        report::caster(self, out)
    }

    fn closed_form_reach(&self, max_wheel_rate: f64, max_steer_rate: Option<f64>) -> Option<Reach> {
        Some(report::caster_reach(self, max_wheel_rate, max_steer_rate))
    }

    fn wheels(&self) -> usize {
        3
    }

    /// Paper 003's inverse at heading 0 (the robot frame) from the current steer angles.
    #[inline]
    fn inverse(&self, twist: Twist2<T>, c: &Actuators<T>) -> Result<Actuators<T>, InputError> {
        let steer: [T; 3] = head(&c.steer_angles);
        let r = self.motor_rates(twist, T::zero(), steer)?;
        let mut a = Actuators::at_steer(&steer);
        a.wheel_rates[..3].copy_from_slice(&r.roll);
        a.steer_rates[..3].copy_from_slice(&r.steer);
        Ok(a)
    }

    #[inline]
    fn forward(&self, a: &Actuators<T>) -> Result<Motion<T>, InputError> {
        Ok(caster_motion(
            self.robot_twist(&caster_rates(a), head(&a.steer_angles))?,
        ))
    }

    /// The trailing configuration of [`Robot::aligned_steer`].
    fn aligned_steer(&self, twist: Twist2<T>) -> Result<[T; MAX_WHEELS], InputError> {
        crate::real::finite3(twist.to_array(), ["vx", "vy", "yaw_rate"])?;
        let p = self.params();
        let mut out = [T::zero(); MAX_WHEELS];
        for (i, g) in out.iter_mut().take(3).enumerate() {
            let (sa, ca) = p.mount_angles[i].sin_cos();
            let vf = [
                twist.vx - twist.yaw_rate * p.mount_radius * sa,
                twist.vy + twist.yaw_rate * p.mount_radius * ca,
            ];
            let speed = vf[0].hypot(vf[1]);
            if speed < T::of(1e-12) {
                continue;
            }
            let chi = vf[1].atan2(vf[0]);
            let rho = (twist.yaw_rate * p.eccentricity / speed).clamp(-T::one(), T::one());
            let beta = chi + T::pi() - rho.asin();
            *g = wrap_angle(beta - p.mount_angles[i]);
        }
        Ok(out)
    }

    /// The eccentricity `d`.
    fn steer_length(&self) -> Option<T> {
        Some(self.params().eccentricity)
    }

    /// The six increments (roll, wrapped steer) fitted at the step's mid steer angles.
    #[inline]
    fn displacement(
        &self,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<Motion<T>, InputError> {
        let mut dg = [T::zero(); 3];
        let mut mid = [T::zero(); 3];
        for i in 0..3 {
            dg[i] = wrap_angle(end.steer[i] - start.steer[i]);
            mid[i] = start.steer[i] + dg[i] * T::of(0.5);
        }
        let rates = CasterRates {
            roll: increments(start, end),
            steer: dg,
        };
        // The fast unchecked fit; on failure the checked one names the input (out of line:
        // `body_twist` is inlined where it is called, and this path is cold).
        #[cold]
        #[inline(never)]
        fn named<T: Real>(
            c: &Caster3<T>,
            rates: &CasterRates<T>,
            steer: [T; 3],
        ) -> Result<crate::caster::CasterForward<T>, InputError> {
            c.body_twist(rates, T::zero(), steer)
        }
        let f = match self.body_twist_robot_unchecked(&rates, mid) {
            Ok(f) => f,
            Err(_) => named(self, &rates, mid)?,
        };
        Ok(caster_motion(f))
    }
}

// ---- N omni / mecanum wheels ------------------------------------------------------------

impl<T: Real, const N: usize> KindModel<T> for Omni<T, N> {
    const KIND: Kind = Kind::Omni;

    fn describe(&self, out: &mut dyn core::fmt::Write) -> core::fmt::Result {
        report::omni(self, out)
    }

    fn wheels(&self) -> usize {
        N
    }

    #[inline]
    fn inverse(&self, twist: Twist2<T>, _c: &Actuators<T>) -> Result<Actuators<T>, InputError> {
        Ok(Actuators::from_wheel_rates(&self.wheel_rates(twist)?))
    }

    #[inline]
    fn forward(&self, a: &Actuators<T>) -> Result<Motion<T>, InputError> {
        let f = self.body_fit(&head(&a.wheel_rates))?;
        Ok(Motion {
            twist: f.twist,
            slip_residual: f.slip_residual,
            wheel_slip: pad(&f.wheel_slip),
        })
    }

    #[inline]
    fn displacement(
        &self,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<Motion<T>, InputError> {
        if !crate::drive::all_finite(&start.wheel[..N]) {
            return Err(crate::drive::first_non_finite(
                &start.wheel[..N],
                &crate::drive::WHEEL_ANGLES,
            ));
        }
        let d: [T; N] = increments(start, end);
        let f = self.body_fit(&d).map_err(|_| {
            crate::drive::array_error(&end.wheel[..N], &crate::drive::WHEEL_ANGLES, "displacement")
        })?;
        Ok(Motion {
            twist: f.twist,
            slip_residual: f.slip_residual,
            wheel_slip: pad(&f.wheel_slip),
        })
    }

    fn torque_space(&self) -> Option<TorqueSpace> {
        Some(TorqueSpace::BodyWrench)
    }

    fn wheel_torques(
        &self,
        g: [T; 3],
        _s: &[T; MAX_WHEELS],
    ) -> Option<Result<[T; MAX_WHEELS], InputError>> {
        Some(Omni::wheel_torques(self, Wrench2::new(g[0], g[1], g[2])).map(|t| pad(&t)))
    }

    fn generalized_forces(
        &self,
        tau: &[T; MAX_WHEELS],
        _s: &[T; MAX_WHEELS],
    ) -> Option<Result<[T; 3], InputError>> {
        Some(self.body_wrench(&head(tau)).map(Wrench2::to_array))
    }
}

// ---- N centred swerve modules -----------------------------------------------------------

/// Steering directions of the first `N` steer angles (one `sin_cos` each).
#[inline(always)]
fn directions<T: Real, const N: usize>(angles: &[T; MAX_WHEELS]) -> [Rot2<T>; N] {
    core::array::from_fn(|i| Rot2::from_angle(angles[i]))
}

impl<T: Real, const N: usize> KindModel<T> for Swerve<T, N> {
    const KIND: Kind = Kind::Swerve;

    fn describe(&self, out: &mut dyn core::fmt::Write) -> core::fmt::Result {
        report::swerve(self, out)
    }

    fn wheels(&self) -> usize {
        N
    }

    /// Module states (optimised against `current` if the drive optimises); steer rates 0.
    #[inline]
    fn inverse(&self, twist: Twist2<T>, c: &Actuators<T>) -> Result<Actuators<T>, InputError> {
        let cur = SwerveState {
            wheel_rates: head(&c.wheel_rates),
            steer: directions(&c.steer_angles),
        };
        let st = crate::drive::Drive::inverse(self, twist, &cur)?;
        let mut a = Actuators::from_wheel_rates(&st.wheel_rates);
        for i in 0..N {
            a.steer_angles[i] = st.steer[i].angle();
        }
        Ok(a)
    }

    /// As [`KindModel::inverse`], with the steer rates of [`Swerve::steer_rates`].
    fn inverse_accel(
        &self,
        twist: Twist2<T>,
        twist_rate: Twist2<T>,
        current: &Actuators<T>,
    ) -> Result<Actuators<T>, InputError> {
        let mut a = self.inverse(twist, current)?;
        let r = self.steer_rates(twist, twist_rate)?;
        a.steer_rates[..N].copy_from_slice(&r.steer_rates);
        Ok(a)
    }

    /// The module directions of the unoptimised inverse (0 for a stopped module).
    fn aligned_steer(&self, twist: Twist2<T>) -> Result<[T; MAX_WHEELS], InputError> {
        let rest = SwerveState {
            wheel_rates: [T::zero(); N],
            steer: directions(&[T::zero(); MAX_WHEELS]),
        };
        let st = crate::drive::Drive::inverse(&self.with_optimization(false), twist, &rest)?;
        let mut out = [T::zero(); MAX_WHEELS];
        for i in 0..N {
            out[i] = st.steer[i].angle();
        }
        Ok(out)
    }

    #[inline]
    fn forward(&self, a: &Actuators<T>) -> Result<Motion<T>, InputError> {
        let st = SwerveState {
            wheel_rates: head(&a.wheel_rates),
            steer: directions(&a.steer_angles),
        };
        let f = self.body_fit(&st)?;
        Ok(Motion {
            twist: f.twist,
            slip_residual: f.slip_residual,
            wheel_slip: pad(&f.module_slip),
        })
    }

    /// WPILib's `ToTwist2d`: wheel increments with the steering of the end reading.
    #[inline]
    fn displacement(
        &self,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<Motion<T>, InputError> {
        let steer = directions(&end.steer);
        let s = SwervePositions {
            wheel_angles: head(&start.wheel),
            steer,
        };
        let e = SwervePositions {
            wheel_angles: head(&end.wheel),
            steer,
        };
        let twist = Swerve::displacement(self, &s, &e)?;
        // The inputs are valid: the fit of the increments adds the per-module slip.
        let fit = self.body_fit(&SwerveState {
            wheel_rates: increments(start, end),
            steer,
        })?;
        Ok(Motion {
            twist,
            slip_residual: fit.slip_residual,
            wheel_slip: pad(&fit.module_slip),
        })
    }

    fn torque_space(&self) -> Option<TorqueSpace> {
        Some(TorqueSpace::BodyWrench)
    }

    fn wheel_torques(
        &self,
        g: [T; 3],
        s: &[T; MAX_WHEELS],
    ) -> Option<Result<[T; MAX_WHEELS], InputError>> {
        Some(
            Swerve::wheel_torques(self, Wrench2::new(g[0], g[1], g[2]), &directions(s))
                .map(|t| pad(&t)),
        )
    }

    fn generalized_forces(
        &self,
        tau: &[T; MAX_WHEELS],
        s: &[T; MAX_WHEELS],
    ) -> Option<Result<[T; 3], InputError>> {
        Some(
            self.body_wrench(&head(tau), &directions(s))
                .map(Wrench2::to_array),
        )
    }
}
