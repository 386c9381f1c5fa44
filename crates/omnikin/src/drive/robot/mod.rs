//! # robot — every kind behind one type, the dispatch written once
//!
//! [`Robot`] is the enum over the concrete models a robot file can name (the sphere of
//! paper 000, the ballbot of paper 001, the caster base of paper 003, N-wheel [`Omni`] and
//! N-module [`Swerve`] drives). Every layer above the core — planner, simulator, runtime,
//! odometry, CLI — speaks to a robot only through the methods here, which take and return the
//! **uniform, fixed-capacity** values [`Actuators`] (what the motors do) and [`EncoderAngles`]
//! (what the encoders read): at most [`MAX_WHEELS`] wheels, the first [`Robot::wheels`] entries
//! used, the rest zero. No heap, no panic, `Copy`.
//!
//! ```
//! use omnikin::description::RobotDescription;
//! use omnikin::{Actuators, Robot, Twist2};
//!
//! // Any robot file or preset; the code below does not know which kind it is.
//! let robot: Robot<f64> = RobotDescription::preset("mecanum").unwrap().build()?;
//! let a = robot.inverse(Twist2::new(0.3, 0.1, 0.5), &Actuators::zero())?;
//! assert_eq!(robot.wheels(), 4);
//! // WPILib's MecanumDriveKinematics::ToWheelSpeeds front-left / r: (0.3 − 0.1 − 0.45·0.5)/0.05.
//! assert!((a.wheel_rates[0] - -0.5).abs() < 1e-12);
//! let back = robot.forward(&a)?;
//! assert!((back.twist.yaw_rate - 0.5).abs() < 1e-12 && back.slip_residual < 1e-12);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## The one place a kind is added
//!
//! 1. write the model (its own module, its own parameter type and validation);
//! 2. implement [`KindModel`] for it in `members.rs` — the uniform verbs in the robot frame;
//! 3. add a variant to [`Robot`] and its line to the `dispatch!` macro below, and a [`Kind`]
//!    (`values.rs`);
//! 4. teach `description/schema.rs` to build it from a robot file.
//!
//! Files: `values.rs` (the uniform values and [`Kind`]), `model.rs` (the [`KindModel`]
//! trait), `members.rs` (its implementation for every kind), this file (the enum and the one
//! dispatch).
//!
//! Nothing else matches on the kind: the layers above ask [`Robot::kind`],
//! [`Robot::wheels`], [`Kind::steerable`] and friends.
//!
//! ## Frames and conventions of the uniform verbs
//!
//! | verb | in | out | frame |
//! |---|---|---|---|
//! | [`Robot::inverse`] | body twist (m/s, m/s, rad/s), current actuators | actuators | robot |
//! | [`Robot::inverse_accel`] | twist and its robot-frame time derivative | actuators with steer rates | robot |
//! | [`Robot::forward`] | actuators | twist + slip residual (m/s) | robot |
//! | [`Robot::displacement`] | two encoder readings | `twist·Δt` + slip (m) | robot at the start |
//! | [`Robot::desaturate`] | actuators, wheel-rate limit | scaled actuators, factor | — |
//! | [`Robot::wheel_torques`], [`Robot::generalized_forces`] | generalized forces / wheel torques | the other | robot (see [`TorqueSpace`]) |
//!
//! World-frame quantities are reached only through an explicit heading
//! ([`crate::Twist2::to_world`] / [`crate::Twist2::to_robot`]). The sphere and ballbot verbs
//! assume no spin of the shell/ball about the vertical (`Ω3 = 0`, paper 000's "rubber
//! rolling"); their inherent methods take the spin explicitly. The caster's paper equations are
//! written in the world frame; its verbs here are evaluated at heading 0, which is the robot
//! frame (the model is invariant under rotation of the world).
//!
//! Steer angles are radians (`γ_i`, from the module's reference direction, CCW): the caster's
//! relative to the radial direction of its mount (paper 003), a swerve module's from robot +x.

use crate::ballbot::Ballbot;
use crate::caster::{Caster3, CasterRates};
use crate::drive::omni::Omni;
use crate::drive::report::{self, REACH_DIRECTIONS_DEG, Reach};
use crate::drive::swerve::{Swerve, SwervePositions, SwerveState};
use crate::drive::{Desaturated, Rot2, Wrench2, desaturation_scale};
use crate::sphere::SphereOmni;
use crate::wrap_angle;
use crate::{InputError, Pose2, Real, Twist2, se2};

mod members;
mod model;
mod values;

pub use model::KindModel;

pub use values::{Actuators, EncoderAngles, Kind, MAX_WHEELS, Motion, TorqueSpace};

/// Any robot a robot file can describe: the concrete models behind one type. The number of
/// wheels of omni and swerve drives is a const generic of their models, so each supported
/// count is a variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Robot<T> {
    /// Spherical robot with an internal omni-wheel platform (paper 000).
    Sphere(SphereOmni<T>),
    /// Ball-balancing robot (paper 001).
    Ballbot(Ballbot<T>),
    /// Base with three off-centred steerable wheels (paper 003).
    Caster(Caster3<T>),
    /// 3 omni/mecanum wheels (kiwi).
    Omni3(Omni<T, 3>),
    /// 4 omni/mecanum wheels (X-drive, mecanum).
    Omni4(Omni<T, 4>),
    /// 5 omni/mecanum wheels.
    Omni5(Omni<T, 5>),
    /// 6 omni/mecanum wheels.
    Omni6(Omni<T, 6>),
    /// 2 swerve modules.
    Swerve2(Swerve<T, 2>),
    /// 3 swerve modules.
    Swerve3(Swerve<T, 3>),
    /// 4 swerve modules.
    Swerve4(Swerve<T, 4>),
    /// 5 swerve modules.
    Swerve5(Swerve<T, 5>),
    /// 6 swerve modules.
    Swerve6(Swerve<T, 6>),
}

/// The one dispatch on the kind: `$m` bound to the concrete model in every arm.
macro_rules! dispatch {
    ($robot:expr, $m:ident => $body:expr) => {
        match $robot {
            Robot::Sphere($m) => $body,
            Robot::Ballbot($m) => $body,
            Robot::Caster($m) => $body,
            Robot::Omni3($m) => $body,
            Robot::Omni4($m) => $body,
            Robot::Omni5($m) => $body,
            Robot::Omni6($m) => $body,
            Robot::Swerve2($m) => $body,
            Robot::Swerve3($m) => $body,
            Robot::Swerve4($m) => $body,
            Robot::Swerve5($m) => $body,
            Robot::Swerve6($m) => $body,
        }
    };
}

/// Generic code run on a robot's concrete model by [`Robot::visit`]: the body is compiled once
/// per kind, so the kind's methods inline into it and its values stay in registers — for hot
/// paths (the odometry step, the control cycle's inverse) that would otherwise dispatch on the
/// kind for every call and pass the fixed-capacity values through memory.
pub trait KindVisitor<T: Real> {
    /// What the visit returns.
    type Output;
    /// Runs on the concrete model.
    fn visit<M: KindModel<T>>(self, model: &M) -> Self::Output;
}

/// `KIND` of a model value (a helper for the dispatch).
#[inline(always)]
fn kind_of<T: Real, M: KindModel<T>>(_m: &M) -> Kind {
    M::KIND
}

impl<T: Real> Robot<T> {
    /// An omni drive of `wheels.len()` wheels (3–6).
    ///
    /// # Errors
    /// [`crate::GeometryError`] from [`Omni::new`], or
    /// [`crate::GeometryError::WheelCount`] for another count.
    pub fn omni(wheels: &[crate::drive::omni::OmniWheel<T>]) -> Result<Self, crate::GeometryError> {
        Ok(match wheels.len() {
            3 => Robot::Omni3(Omni::new(array(wheels))?),
            4 => Robot::Omni4(Omni::new(array(wheels))?),
            5 => Robot::Omni5(Omni::new(array(wheels))?),
            6 => Robot::Omni6(Omni::new(array(wheels))?),
            n => {
                return Err(crate::GeometryError::WheelCount {
                    field: "wheels",
                    got: n,
                    min: 3,
                    max: MAX_WHEELS,
                });
            }
        })
    }

    /// A swerve drive of `modules.len()` modules (2–6), optimising its steering if `optimize`.
    ///
    /// # Errors
    /// [`crate::GeometryError`] from [`Swerve::new`], or
    /// [`crate::GeometryError::WheelCount`] for another count.
    pub fn swerve(
        modules: &[crate::drive::swerve::SwerveModule<T>],
        optimize: bool,
    ) -> Result<Self, crate::GeometryError> {
        Ok(match modules.len() {
            2 => Robot::Swerve2(Swerve::new(array(modules))?.with_optimization(optimize)),
            3 => Robot::Swerve3(Swerve::new(array(modules))?.with_optimization(optimize)),
            4 => Robot::Swerve4(Swerve::new(array(modules))?.with_optimization(optimize)),
            5 => Robot::Swerve5(Swerve::new(array(modules))?.with_optimization(optimize)),
            6 => Robot::Swerve6(Swerve::new(array(modules))?.with_optimization(optimize)),
            n => {
                return Err(crate::GeometryError::WheelCount {
                    field: "modules",
                    got: n,
                    min: 2,
                    max: MAX_WHEELS,
                });
            }
        })
    }

    /// Runs `visitor` on the concrete model (the one dispatch; see [`KindVisitor`]).
    #[inline(always)]
    pub fn visit<V: KindVisitor<T>>(&self, visitor: V) -> V::Output {
        dispatch!(self, m => visitor.visit(m))
    }

    /// The kind.
    #[inline]
    pub fn kind(&self) -> Kind {
        dispatch!(self, m => kind_of(m))
    }

    /// Number of wheels (modules), the used length of [`Actuators`] and [`EncoderAngles`].
    #[inline]
    pub fn wheels(&self) -> usize {
        dispatch!(self, m => KindModel::<T>::wheels(m))
    }

    /// `true` for kinds with steer motors (caster, swerve).
    #[inline]
    pub fn steerable(&self) -> bool {
        self.kind().steerable()
    }

    /// Number of motors: the wheels, plus as many steer motors for steerable kinds.
    #[inline]
    pub fn motors(&self) -> usize {
        if self.steerable() {
            2 * self.wheels()
        } else {
            self.wheels()
        }
    }

    /// Inverse kinematics: the actuators that drive the **robot-frame** `twist` (see
    /// [`KindModel::inverse`]). Not limited: see [`Robot::desaturate`].
    ///
    /// # Errors
    /// [`InputError`] for a non-finite input or an overflowing result.
    #[inline(always)]
    pub fn inverse(
        &self,
        twist: Twist2<T>,
        current: &Actuators<T>,
    ) -> Result<Actuators<T>, InputError> {
        dispatch!(self, m => KindModel::<T>::inverse(m, twist, current))
    }

    /// [`Robot::inverse`] with the twist's robot-frame time derivative (swerve steer rates).
    ///
    /// # Errors
    /// As [`Robot::inverse`].
    #[inline(always)]
    pub fn inverse_accel(
        &self,
        twist: Twist2<T>,
        twist_rate: Twist2<T>,
        current: &Actuators<T>,
    ) -> Result<Actuators<T>, InputError> {
        dispatch!(self, m => KindModel::<T>::inverse_accel(m, twist, twist_rate, current))
    }

    /// [`Robot::inverse`] of a **world-frame** twist at heading `heading` (rad).
    ///
    /// # Errors
    /// As [`Robot::inverse`], plus a non-finite heading.
    pub fn inverse_world(
        &self,
        twist_world: Twist2<T>,
        heading: T,
        current: &Actuators<T>,
    ) -> Result<Actuators<T>, InputError> {
        crate::real::finite(heading, "heading")?;
        self.inverse(twist_world.to_robot(heading), current)
    }

    /// Steer angles aligned with the robot-frame `twist` a motion starts with (see
    /// [`KindModel::aligned_steer`]). For the caster, wheel `i`'s steering axis `F_i` moves with
    /// `v_F = (vx, vy) + ω k × D(cos α_i, sin α_i)` (direction `χ`); its steer rate vanishes for
    /// `sin(β_i − χ) = ω d/|v_F|`, whose trailing solution `β_i = χ + π − asin(ω d/|v_F|)` is
    /// the stable equilibrium (a leading wheel would need ever larger steer rates to follow
    /// any curve); `γ_i = β_i − α_i` wrapped into (−π, π], 0 for a steering axis at rest.
    ///
    /// # Errors
    /// [`InputError`] for a non-finite twist.
    pub fn aligned_steer(&self, twist: Twist2<T>) -> Result<[T; MAX_WHEELS], InputError> {
        dispatch!(self, m => KindModel::<T>::aligned_steer(m, twist))
    }

    /// See [`KindModel::steer_length`] (m).
    pub fn steer_length(&self) -> Option<T> {
        dispatch!(self, m => KindModel::<T>::steer_length(m))
    }

    /// Forward kinematics: the **robot-frame** twist that best explains `actuators`, with the
    /// slip it implies.
    ///
    /// # Errors
    /// [`InputError`] for a non-finite actuator, a singular configuration or overflow.
    #[inline]
    pub fn forward(&self, actuators: &Actuators<T>) -> Result<Motion<T>, InputError> {
        dispatch!(self, m => KindModel::<T>::forward(m, actuators))
    }

    /// [`Robot::inverse`] with the shell/ball spin `Ω3` (rad/s) of the sphere and the ballbot
    /// (see [`KindModel::inverse_spin`]).
    ///
    /// # Errors
    /// As [`KindModel::inverse_spin`].
    pub fn inverse_spin(
        &self,
        twist: Twist2<T>,
        spin: T,
        current: &Actuators<T>,
    ) -> Result<Actuators<T>, InputError> {
        dispatch!(self, m => KindModel::<T>::inverse_spin(m, twist, spin, current))
    }

    /// [`Robot::forward`] with an assumed shell/ball spin (see [`KindModel::forward_spin`]).
    ///
    /// # Errors
    /// As [`KindModel::forward_spin`].
    pub fn forward_spin(&self, actuators: &Actuators<T>, spin: T) -> Result<Motion<T>, InputError> {
        dispatch!(self, m => KindModel::<T>::forward_spin(m, actuators, spin))
    }

    /// The robot-frame displacement between two encoder readings.
    ///
    /// # Errors
    /// As [`Robot::forward`].
    #[inline]
    pub fn displacement(
        &self,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<Motion<T>, InputError> {
        dispatch!(self, m => KindModel::<T>::displacement(m, start, end))
    }

    /// See [`KindModel::step_pose`] (the rotation of `pose.heading` is computed here).
    ///
    /// # Errors
    /// As [`KindModel::step_pose`].
    #[inline]
    pub fn step_pose(
        &self,
        pose: Pose2<T>,
        body: Twist2<T>,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<(Pose2<T>, Pose2<T>), InputError> {
        let rot = Rot2::from_angle(pose.heading);
        dispatch!(self, m => KindModel::<T>::step_pose(m, pose, rot, body, start, end))
    }

    /// Scales every wheel rate by one factor so the largest magnitude is at most
    /// `max_wheel_rate` (rad/s). Steer angles are kept; steer rates are scaled too (the
    /// scaled actuators drive `scale ×` the twist, whose steering changes `scale ×` as fast).
    ///
    /// # Errors
    /// [`InputError::NonFinite`] for a non-finite limit or rate; [`InputError::Singular`] for a
    /// limit that is not `> 0`.
    pub fn desaturate(
        &self,
        actuators: Actuators<T>,
        max_wheel_rate: T,
    ) -> Result<Desaturated<Actuators<T>, T>, InputError> {
        let n = self.wheels();
        let scale = desaturation_scale(&actuators.wheel_rates[..n], max_wheel_rate)?;
        let mut a = actuators;
        if scale < T::one() {
            for i in 0..n {
                a.wheel_rates[i] *= scale;
                a.steer_rates[i] *= scale;
            }
        }
        Ok(Desaturated {
            actuators: a,
            scale,
        })
    }

    /// Writes the kind's derived geometry, one line each (`omnikin check`).
    ///
    /// # Errors
    /// The writer's.
    pub fn describe(&self, out: &mut dyn core::fmt::Write) -> core::fmt::Result {
        dispatch!(self, m => KindModel::<T>::describe(m, out))
    }

    /// The fastest motion within `max_wheel_rate` (rad/s) and, for steerable kinds,
    /// `max_steer_rate`: along eight robot-frame directions without yaw, and turning on the
    /// spot. From the kind's closed form, or else `max / max_i |ω_i|` of the inverse
    /// kinematics of a unit motion (the map is linear in the twist). `None` for a limit that
    /// is not a positive finite number.
    pub fn reach(&self, max_wheel_rate: f64, max_steer_rate: Option<f64>) -> Option<Reach> {
        if !(max_wheel_rate.is_finite() && max_wheel_rate > 0.0) {
            return None;
        }
        if let Some(r) = dispatch!(self, m => KindModel::<T>::closed_form_reach(m, max_wheel_rate, max_steer_rate))
        {
            return Some(r);
        }
        let n = self.wheels();
        let peak = |t: Twist2<T>| {
            self.inverse(t, &Actuators::zero())
                .map(|a| {
                    a.wheel_rates[..n]
                        .iter()
                        .fold(0.0f64, |m, w| m.max(w.to_f64().abs()))
                })
                .unwrap_or(f64::INFINITY)
        };
        let mut speed = [0.0; 8];
        for (v, d) in speed.iter_mut().zip(REACH_DIRECTIONS_DEG) {
            let r = Rot2::from_angle(T::of(d.to_radians()));
            *v = max_wheel_rate / peak(Twist2::new(r.cos, r.sin, T::zero()));
        }
        Some(Reach {
            speed,
            yaw_rate: max_wheel_rate / peak(Twist2::new(T::zero(), T::zero(), T::one())),
        })
    }

    /// The torque map's generalized forces, or `None` when the kind has none.
    pub fn torque_space(&self) -> Option<TorqueSpace> {
        dispatch!(self, m => KindModel::<T>::torque_space(m))
    }

    /// See [`KindModel::wheel_torques`].
    pub fn wheel_torques(
        &self,
        g: [T; 3],
        steer_angles: &[T; MAX_WHEELS],
    ) -> Option<Result<[T; MAX_WHEELS], InputError>> {
        dispatch!(self, m => KindModel::<T>::wheel_torques(m, g, steer_angles))
    }

    /// See [`KindModel::generalized_forces`].
    pub fn generalized_forces(
        &self,
        tau: &[T; MAX_WHEELS],
        steer_angles: &[T; MAX_WHEELS],
    ) -> Option<Result<[T; 3], InputError>> {
        dispatch!(self, m => KindModel::<T>::generalized_forces(m, tau, steer_angles))
    }
}

/// The first `N` entries of `s` (the callers check the length).
fn array<T: Copy, const N: usize>(s: &[T]) -> [T; N] {
    core::array::from_fn(|i| s[i])
}
