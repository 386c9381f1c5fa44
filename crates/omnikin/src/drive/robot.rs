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
//! 2. implement [`KindModel`] for it — the uniform verbs in the robot frame;
//! 3. add a variant to [`Robot`] and its line to the `dispatch!` macro below, and a [`Kind`];
//! 4. teach `description.rs` to build it from a robot file.
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

/// Largest number of wheels (modules) of any kind, the capacity of [`Actuators`] and
/// [`EncoderAngles`]. Omni drives have 3 to 6 wheels, swerve drives 2 to 6 modules.
pub const MAX_WHEELS: usize = 6;

/// The kinds of robot a robot file can name (its `kind` key).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    /// `sphere-omni`: sphere rolled by an internal three-omni-wheel platform (paper 000).
    Sphere,
    /// `ballbot`: body balancing on a ball driven by three omni wheels (paper 001).
    Ballbot,
    /// `caster3`: base on three off-centred steerable wheels (paper 003).
    Caster,
    /// `omni`: 3–6 omni or mecanum wheels (kiwi, X-drive, mecanum, any layout).
    Omni,
    /// `swerve`: 2–6 centred steerable modules.
    Swerve,
}

impl Kind {
    /// Every kind, in the order of the docs.
    pub const ALL: [Kind; 5] = [
        Kind::Sphere,
        Kind::Ballbot,
        Kind::Caster,
        Kind::Omni,
        Kind::Swerve,
    ];

    /// The `kind` key of a robot file.
    pub const fn name(self) -> &'static str {
        match self {
            Kind::Sphere => "sphere-omni",
            Kind::Ballbot => "ballbot",
            Kind::Caster => "caster3",
            Kind::Omni => "omni",
            Kind::Swerve => "swerve",
        }
    }

    /// The kind of a robot file's `kind` key.
    pub fn from_name(name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// `true` when the wheels are steered by their own motors (caster, swerve): the actuator
    /// vector has steer angles and rates, and the encoders read steer angles.
    pub const fn steerable(self) -> bool {
        matches!(self, Kind::Caster | Kind::Swerve)
    }

    /// `true` when the body rolls on a ball or shell that can spin about the vertical
    /// independently of the wheels' odometry (sphere, ballbot): a measured heading then
    /// reveals that spin ([`crate::estimate::odometry::OdometryStep::shell_spin`]).
    pub const fn has_vertical_spin(self) -> bool {
        matches!(self, Kind::Sphere | Kind::Ballbot)
    }

    /// What the robot's wheel units are called in output: `module` (swerve), else `wheel`.
    pub const fn wheel_noun(self) -> &'static str {
        match self {
            Kind::Swerve => "module",
            _ => "wheel",
        }
    }

    /// What spins about the vertical for [`Kind::has_vertical_spin`] kinds: `shell` (sphere),
    /// `ball` (ballbot); `None` for the others.
    pub const fn spin_body(self) -> Option<&'static str> {
        match self {
            Kind::Sphere => Some("shell"),
            Kind::Ballbot => Some("ball"),
            _ => None,
        }
    }

    /// `true` when the steering of a module is free (centred modules): a module steers to any
    /// angle at once kinematically, so its steer angle is a set-point and steer rates follow
    /// from the twist's rate of change only. `false` for the caster, whose steer rates follow
    /// from the twist itself (paper 003).
    pub const fn steer_is_set_point(self) -> bool {
        matches!(self, Kind::Swerve)
    }
}

/// The actuator vector of any robot: what [`Robot::inverse`] returns and [`Robot::forward`]
/// takes. Entries `0..robot.wheels()` are used, the rest are zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Actuators<T> {
    /// Wheel (roll) rates, rad/s: sphere `χ̇_i`, ballbot `ψ̇_i`, caster `φ̇_i`, omni `ω_i`,
    /// swerve `ω_i`.
    pub wheel_rates: [T; MAX_WHEELS],
    /// Steerable kinds: steer angles `γ_i`, rad. 0 for the others.
    pub steer_angles: [T; MAX_WHEELS],
    /// Steerable kinds: steer rates `γ̇_i`, rad/s. 0 for the others.
    pub steer_rates: [T; MAX_WHEELS],
}

impl<T: Real> Actuators<T> {
    /// Everything at rest: zero rates, steering at 0.
    pub fn zero() -> Self {
        Self {
            wheel_rates: [T::zero(); MAX_WHEELS],
            steer_angles: [T::zero(); MAX_WHEELS],
            steer_rates: [T::zero(); MAX_WHEELS],
        }
    }

    /// Actuators from wheel rates (rad/s), the rest zero; entries past `MAX_WHEELS` ignored.
    pub fn from_wheel_rates(rates: &[T]) -> Self {
        let mut a = Self::zero();
        copy_in(&mut a.wheel_rates, rates);
        a
    }

    /// At rest with the given steer angles (rad).
    pub fn at_steer(steer_angles: &[T]) -> Self {
        let mut a = Self::zero();
        copy_in(&mut a.steer_angles, steer_angles);
        a
    }
}

/// One encoder reading of any robot: cumulative wheel angles and steer angles (rad). Entries
/// `0..robot.wheels()` are used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncoderAngles<T> {
    /// Cumulative wheel (roll) angles, rad, not wrapped.
    pub wheel: [T; MAX_WHEELS],
    /// Steerable kinds: steer angles `γ_i`, rad (may be wrapped: increments are wrapped into
    /// `(−π, π]`). 0 for the others.
    pub steer: [T; MAX_WHEELS],
}

impl<T: Real> EncoderAngles<T> {
    /// All zero.
    pub fn zero() -> Self {
        Self {
            wheel: [T::zero(); MAX_WHEELS],
            steer: [T::zero(); MAX_WHEELS],
        }
    }

    /// A reading from slices (entries past `MAX_WHEELS` ignored, missing ones zero).
    pub fn new(wheel: &[T], steer: &[T]) -> Self {
        let mut e = Self::zero();
        copy_in(&mut e.wheel, wheel);
        copy_in(&mut e.steer, steer);
        e
    }
}

fn copy_in<T: Copy>(dst: &mut [T; MAX_WHEELS], src: &[T]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = *s;
    }
}

/// The forward kinematics of a robot: the twist that best explains its actuators (or a
/// displacement that best explains its encoder increments), with the slip it implies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion<T> {
    /// Robot-frame twist (m/s, m/s, rad/s), or displacement (m, m, rad).
    pub twist: Twist2<T>,
    /// `sqrt(Σ wheel_slip²)`: m/s (or m for a displacement). 0 for kinds with exactly as many
    /// constraints as unknowns (sphere, ballbot, 3-wheel omni).
    pub slip_residual: T,
    /// Per wheel slip, m/s (or m); entries past the wheel count are 0.
    pub wheel_slip: [T; MAX_WHEELS],
}

/// The generalized forces a kind's torque map relates to its wheel torques.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TorqueSpace {
    /// Body wrench `[fx, fy, mz]` (N, N, N·m), robot frame ([`Wrench2`]): omni and swerve.
    BodyWrench,
    /// Paper 001's model ("virtual wheel") torques `[Tx, Ty, Tz]` (N·m) at body yaw 0.
    BallbotModel,
}

impl TorqueSpace {
    /// The names of the three components, as printed and in JSON.
    pub const fn components(self) -> [&'static str; 3] {
        match self {
            TorqueSpace::BodyWrench => ["fx", "fy", "mz"],
            TorqueSpace::BallbotModel => ["Tx", "Ty", "Tz"],
        }
    }

    /// Units of the three components.
    pub const fn units(self) -> [&'static str; 3] {
        match self {
            TorqueSpace::BodyWrench => ["N", "N", "N·m"],
            TorqueSpace::BallbotModel => ["N·m", "N·m", "N·m"],
        }
    }

    /// The name of the generalized-force vector (`wrench`, `model_torques`).
    pub const fn name(self) -> &'static str {
        match self {
            TorqueSpace::BodyWrench => "wrench",
            TorqueSpace::BallbotModel => "model_torques",
        }
    }
}

/// What a concrete model implements to be a member of [`Robot`]: the uniform verbs, in the
/// robot frame, on the fixed-capacity [`Actuators`] and [`EncoderAngles`]. See the
/// [module docs](self) for the frame of each verb.
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
    /// `(delta, pose ⊕ delta)`. Default: the exact SE(2) exponential. The ballbot overrides it
    /// with paper 001's ball displacement between the two yaws.
    ///
    /// # Errors
    /// [`InputError`] from the kind's own step.
    fn step_pose(
        &self,
        pose: Pose2<T>,
        body: Twist2<T>,
        _start: &EncoderAngles<T>,
        _end: &EncoderAngles<T>,
    ) -> Result<(Pose2<T>, Pose2<T>), InputError> {
        let delta = se2::twist_exp(body, T::one());
        Ok((delta, se2::compose(pose, delta)))
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
    #[inline]
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
    #[inline]
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

    /// See [`KindModel::step_pose`].
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
        dispatch!(self, m => KindModel::<T>::step_pose(m, pose, body, start, end))
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
            let (s, c) = d.to_radians().sin_cos();
            *v = max_wheel_rate / peak(Twist2::new(T::of(c), T::of(s), T::zero()));
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

    fn displacement(
        &self,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<Motion<T>, InputError> {
        Ok(rigid(self.body_twist(increments(start, end), T::zero())?))
    }

    /// Paper 001's odometry step: the world ball displacement between the two yaws.
    fn step_pose(
        &self,
        pose: Pose2<T>,
        body: Twist2<T>,
        start: &EncoderAngles<T>,
        end: &EncoderAngles<T>,
    ) -> Result<(Pose2<T>, Pose2<T>), InputError> {
        let yaw0 = pose.heading;
        let d = self.ball_displacement(increments(start, end), yaw0, yaw0 + body.yaw_rate)?;
        let r = Rot2::from_angle(yaw0);
        let delta = Pose2::new(
            r.cos * d[0] + r.sin * d[1],
            -r.sin * d[0] + r.cos * d[1],
            body.yaw_rate,
        );
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
        // The fast unchecked fit; on failure the checked one names the input.
        let f = match self.body_twist_robot_unchecked(&rates, mid) {
            Ok(f) => f,
            Err(_) => self.body_twist(&rates, T::zero(), mid)?,
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
