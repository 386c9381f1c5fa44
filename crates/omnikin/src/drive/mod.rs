//! # drive — every robot kind, and the one type the layers above speak to
//!
//! * One file (or folder) per kind: [`sphere`] (paper 000), [`ballbot`] (paper 001),
//!   [`caster`] (paper 003), [`omni`] (N omni or mecanum wheels: kiwi, X-drive, mecanum, any
//!   irregular layout) and [`swerve`] (N centred steerable modules).
//! * [`robot`]: the [`Robot`] enum over all of them with the uniform verbs on [`Actuators`]
//!   and [`EncoderAngles`] — **the one place the kind is dispatched and the one place a kind is
//!   added** (see its module docs). The planner, simulator, runtime, odometry and CLI use
//!   only [`Robot`] and [`Kind`].
//! * [`Drive`]: the statically sized trait of the const-generic layouts ([`omni::Omni`],
//!   [`swerve::Swerve`]) for firmware that knows its layout at compile time, with WPILib's
//!   split (actuators, positions, inverse, forward, displacement, desaturate).
//!
//! ## What others call these things
//!
//! * **WPILib** (`wpimath`) splits a drive into `Kinematics<S, P>` — `S` the wheel-speeds type
//!   (`MecanumDriveWheelSpeeds`, `wpi::array<SwerveModuleState, N>`), `P` the wheel-positions
//!   type — with `ToChassisSpeeds(S)` (forward), `ToWheelSpeeds(ChassisSpeeds)` (inverse) and
//!   `ToTwist2d(P start, P end)` (the displacement odometry integrates); `Odometry<S, P>` and
//!   `PoseEstimator<S, P>` are written **once**, generic over any kinematics. Desaturation is a
//!   separate call (`DesaturateWheelSpeeds`), never done silently, and `ChassisSpeeds` is
//!   robot-relative unless converted with an explicit gyro angle (`FromFieldRelativeSpeeds`).
//! * **ros2_control** separates the *hardware interface* (per joint: `position`/`velocity`
//!   state interfaces, `velocity` command interfaces) from the *controller* that owns the
//!   kinematics (`mecanum_drive_controller`, `omni_wheel_drive_controller` — the latter only for
//!   equally spaced wheels); the command is a robot-frame `Twist` (`cmd_vel`), odometry is
//!   computed from joint feedback inside the controller.
//! * **nalgebra** names sizes in types (`SVector<T, N>`, `SMatrix<T, R, C>`), so an N-wheel
//!   model needs no heap and the firmware sees its sizes, and keeps rotations as unit complex
//!   numbers (`UnitComplex`: `(cos, sin)`), the angle only computed on demand.
//!
//! ## What we take
//!
//! * A **trait**, [`Drive`], with associated types in WPILib's split: [`Drive::Actuators`] (the
//!   actuator vector: what the inverse returns and the forward takes — ros2_control's command
//!   and state interfaces of the joints) and [`Drive::Positions`] (what the encoders read, for
//!   odometry). The number of wheels is a const generic of each kind (nalgebra's lesson), so
//!   every value is a fixed-size array.
//! * Odometry is written once ([`crate::estimate::odometry::Odometry`], over [`Robot`]; WPILib's lesson): adding a drive
//!   never touches it.
//! * The set of kinds is closed (every kind is a robot-file `kind`), so the layers above hold
//!   an **enum over the concrete models with the `match` in exactly one module**
//!   ([`robot`]'s `dispatch!`): [`Robot`]'s variants delegate to each model's
//!   [`KindModel`] implementation, and a new kind that forgets a verb does not compile. The
//!   runtime cycle, odometry, planner and simulator are written once against [`Robot`].
//!
//! ## One frame per verb
//!
//! | verb | input | output | frame |
//! |---|---|---|---|
//! | [`Drive::inverse`] | body twist `(vx, vy, yaw_rate)` (m/s, m/s, rad/s), current actuators | actuators | **robot frame** |
//! | [`Drive::forward`] | actuators | body twist | **robot frame** |
//! | [`Drive::forward_fit`] | actuators | body twist + slip residual (m/s) | robot frame |
//! | [`Drive::displacement`] | two encoder readings | `twist·Δt` of the step (m, m, rad) | robot frame at the start of the step |
//! | [`Drive::inverse_world`], [`Drive::forward_world`] | as above + **explicit heading** ψ (rad) | | world frame |
//! | [`crate::estimate::odometry::Odometry::update`] | encoder reading, heading source (wheels, gyro rate, absolute yaw) | pose | world frame |
//! | `body_wrench` / `wheel_torques` (per kind, see *Torques*) | wheel torques (N·m) / [`Wrench2`] | the other | robot frame |
//!
//! The world frame is reached **only** through an explicit heading:
//! `v_world = Q(ψ) v_robot` ([`Twist2::to_world`], [`Twist2::to_robot`]). A model written in
//! the world frame in its paper (the caster of paper 003) converts at its boundary.
//!
//! ## Angles are `(cos, sin)`
//!
//! A steering direction is a [`Rot2`] `{cos, sin}` in that order, like nalgebra's
//! `UnitComplex` and WPILib's `Rotation2d`: the inverse kinematics produces it from a velocity
//! with one square root and no `atan2`, the forward kinematics consumes it with no
//! trigonometry; [`Rot2::angle`] gives radians at the edge (CLI, CSV). Wrapping an angle into
//! `(−π, π]` uses the one helper of the crate, [`crate::wrap_angle`].
//!
//! ## Limits and desaturation
//!
//! The kinematics never limit anything (as WPILib: "the wheel speeds are not normalized").
//! [`Drive::desaturate`] scales **every** wheel rate by one factor `s ∈ (0, 1]` so the largest
//! magnitude equals the limit; steering directions are untouched. Because the inverse of every
//! kind is positively homogeneous in the twist (`inverse(s·t) = s·inverse(t)` for `s > 0`), the
//! desaturated actuators drive the twist `s·t`: **the direction of motion and the curvature are
//! preserved**, only the speed drops. [`Desaturated::scale`] reports `s` so a caller can scale
//! its own twist (and its planned time) alike.
//!
//! ## Odometry stepping
//!
//! [`Drive::displacement`] turns two encoder readings into the robot-frame displacement
//! `(Δx, Δy, Δθ)` of the step, the forward kinematics applied to the increments — for
//! steerable kinds with the steering of the *end* reading, as WPILib's
//! `SwerveDriveKinematics::ToTwist2d`. The odometry composes the pose with the exact SE(2)
//! exponential of that displacement ([`crate::se2::twist_exp`]), so a constant twist (a
//! circular arc) is integrated exactly whatever the step; with a gyro, the gyro's wrapped
//! heading change replaces `Δθ` and the pose's heading follows the gyro (WPILib's
//! `Odometry::Update`).
//!
//! ## Torques (the dual map)
//!
//! Where a kind has one, its torque map is the transpose of its velocity map, by virtual work
//! (`Σ τ_i ω_i = W · t` for every motion): wheel torques `τ` (N·m) → body wrench
//! [`Wrench2`] `W = Jᵀ τ` (robot frame), and back with the **minimum-norm** torques
//! `τ = J (JᵀJ)⁻¹ W` (the torques that produce `W` with the least `Σ τ_i²`; with more wheels
//! than three, the rest of the torque space only squeezes the rollers against each other).
//! [`omni::Omni::body_wrench`] / [`omni::Omni::wheel_torques`] precompute both matrices;
//! [`swerve::Swerve::body_wrench`] / [`swerve::Swerve::wheel_torques`] depend on the
//! steering and solve a 3×3 system per call. A `Drive::torques` method returning "not
//! defined" by default is the proposed way to give every kind the CLI's `torques` verb.
//!
//! ## Errors
//!
//! Construction validates the whole geometry and returns [`crate::GeometryError`]: the
//! indexed field (`wheels[2].radius`, `modules[1].position`), the 1-based wheel of a wheel that
//! cannot drive, or — for a **rank-deficient** layout — the rule that fails ("all constraint
//! directions parallel", "all constraint lines through one point", "modules at one point") and
//! the condition number against [`crate::MAX_CONDITION`]. Calls return
//! [`crate::InputError`] naming the first non-finite input (`wheel_rates[3]`) or the output that
//! overflowed. Nothing panics, nothing allocates.
//!
//! ## Robot files for the layouts
//!
//! The presets are `robots/kiwi.toml`, `robots/x-drive.toml`, `robots/mecanum.toml` and
//! `robots/swerve4.toml`; angles in degrees only where the key says `_deg`:
//!
//! ```toml
//! kind = "omni"                    # N >= 3 omni or mecanum wheels, in file order
//! name = "mecanum"
//!
//! [[geometry.wheels]]              # one table per wheel
//! position = [0.25, 0.2]           # p_i, robot frame [m]
//! drive_angle_deg = 0.0            # d_i = (cos, sin) of this, from robot +x, CCW
//! roller_angle_deg = -45.0         # rho_i, from d_i to the roller axis: 0 omni, +-45 mecanum
//! radius = 0.05                    # [m]
//! # ... one [[geometry.wheels]] per wheel
//!
//! [limits]                         # as for the other kinds, every key optional
//! max_wheel_rate = 60.0            # [rad/s]
//! max_wheel_accel = 300.0          # [rad/s^2]
//! ```
//!
//! ```toml
//! kind = "swerve"                  # N >= 2 centred steerable modules, in file order
//! name = "swerve4"
//!
//! [geometry]
//! optimize_steering = false        # flip and reverse (WPILib Optimize); default false
//!
//! [[geometry.modules]]
//! position = [0.3, 0.3]            # steering axis = wheel contact, robot frame [m]
//! wheel_radius = 0.05              # [m]
//! # ... one [[geometry.modules]] per module
//!
//! [limits]                         # max_wheel_rate, max_wheel_accel, max_steer_rate,
//! max_steer_rate = 12.0            # max_steer_accel (rad/s, rad/s^2)
//! ```
//!
//! The number of wheels is a const generic of [`omni::Omni`] and [`swerve::Swerve`];
//! [`Robot::omni`] / [`Robot::swerve`] pick the variant by count (omni 3–6, swerve 2–6,
//! [`MAX_WHEELS`]) and reject other counts with [`crate::GeometryError::WheelCount`]. A wheel
//! count that does not match a `--wheel-rates` list is the CLI's "expected N values" error.
//!
//! Field names of [`crate::GeometryError`] (`wheels[i].position`, `wheels[i].drive`,
//! `wheels[i].roller_angle`, `wheels[i].radius`, `modules[i].position`,
//! `modules[i].wheel_radius`) map onto these keys with the `geometry.` prefix (0-based `i`,
//! the TOML array index; `drive` is `drive_angle_deg`, `roller_angle` is
//! `roller_angle_deg`), as `description.rs` already maps `mount_angles[0]`.

pub mod ballbot;
pub mod caster;
pub mod omni;
pub mod report;
pub mod robot;
pub mod sphere;
pub mod swerve;

pub use robot::{
    Actuators, EncoderAngles, Kind, KindModel, KindVisitor, MAX_WHEELS, Motion, Robot, TorqueSpace,
};

use core::fmt::Debug;

use crate::{InputError, Real, Twist2};

/// Indexed field names `prefix[0]`..`prefix[15]`, then `prefix[16+]` for any later index: the
/// errors are `Copy` and allocation-free, so names are static strings.
macro_rules! indexed_names {
    ($p:literal $(, $s:literal)?) => {
        [
            concat!($p, "[0]" $(, $s)?), concat!($p, "[1]" $(, $s)?), concat!($p, "[2]" $(, $s)?),
            concat!($p, "[3]" $(, $s)?), concat!($p, "[4]" $(, $s)?), concat!($p, "[5]" $(, $s)?),
            concat!($p, "[6]" $(, $s)?), concat!($p, "[7]" $(, $s)?), concat!($p, "[8]" $(, $s)?),
            concat!($p, "[9]" $(, $s)?), concat!($p, "[10]" $(, $s)?), concat!($p, "[11]" $(, $s)?),
            concat!($p, "[12]" $(, $s)?), concat!($p, "[13]" $(, $s)?), concat!($p, "[14]" $(, $s)?),
            concat!($p, "[15]" $(, $s)?), concat!($p, "[16+]" $(, $s)?),
        ]
    };
}
pub(crate) use indexed_names;

/// The name of index `i` in a table built by `indexed_names!` (the last entry for `i ≥ 16`).
#[inline]
pub(crate) fn name_of(table: &[&'static str; 17], i: usize) -> &'static str {
    table[if i < 16 { i } else { 16 }]
}

/// `√x` for `f64` in `no_std` (through `libm`, as every other function of the crate).
#[inline]
pub(crate) fn sqrt64(x: f64) -> f64 {
    nalgebra::ComplexField::sqrt(x)
}

/// Input names shared by the kinds.
pub(crate) const WHEEL_RATES: [&str; 17] = indexed_names!("wheel_rates");
/// Input names of wheel torques.
pub(crate) const WHEEL_TORQUES: [&str; 17] = indexed_names!("wheel_torques");
/// Input names of cumulative wheel angles (odometry).
pub(crate) const WHEEL_ANGLES: [&str; 17] = indexed_names!("wheel_angles");

/// `Err(NonFinite)` naming the first non-finite entry of `x` (called only after a fast check
/// failed, so it is off the hot path).
#[cold]
pub(crate) fn first_non_finite<T: Real>(x: &[T], names: &[&'static str; 17]) -> InputError {
    let i = x.iter().position(|v| !v.is_finite()).unwrap_or(0);
    InputError::NonFinite {
        field: name_of(names, i),
    }
}

/// `true` when every entry is finite. Fast path: one add per entry and one test, since a
/// finite sum implies finite entries (a NaN or ±∞ entry makes the sum NaN or ±∞); only when the
/// sum is not finite (a non-finite entry, or finite entries overflowing) are the entries
/// tested one by one.
#[inline(always)]
// `acc − acc` is 0 for finite `acc` and NaN for ±∞ or NaN: one subtraction and one compare.
#[allow(clippy::eq_op)]
pub(crate) fn all_finite<T: Real>(x: &[T]) -> bool {
    let mut acc = T::zero();
    for &v in x {
        acc += v;
    }
    acc - acc == T::zero() || each_finite(x)
}

#[cold]
#[inline(never)]
fn each_finite<T: Real>(x: &[T]) -> bool {
    x.iter().all(|v| v.is_finite())
}

/// The error of a call whose output from the twist `t` was not finite: the first non-finite
/// component of `t`, or else an overflow of `quantity`. Off the hot path.
#[cold]
pub(crate) fn twist_error<T: Real>(t: Twist2<T>, quantity: &'static str) -> InputError {
    match t.check_finite() {
        Err(e) => e,
        Ok(_) => InputError::Overflow { quantity },
    }
}

/// As [`twist_error`] for an array input named by `names`.
#[cold]
pub(crate) fn array_error<T: Real>(
    x: &[T],
    names: &[&'static str; 17],
    quantity: &'static str,
) -> InputError {
    if all_finite(x) {
        InputError::Overflow { quantity }
    } else {
        first_non_finite(x, names)
    }
}

/// `Ok(())` if the twist is finite, else the first non-finite component.
#[inline(always)]
pub(crate) fn check_twist<T: Real>(t: Twist2<T>) -> Result<(), InputError> {
    if all_finite(&[t.vx, t.vy, t.yaw_rate]) {
        Ok(())
    } else {
        t.check_finite().map(|_| ())
    }
}

/// A planar rotation (a direction) stored as `(cos, sin)`, in that order: a steering
/// direction from robot +x, counter-clockwise positive (WPILib's `Rotation2d`, nalgebra's
/// `UnitComplex`). `cos² + sin² = 1` for every value the crate produces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rot2<T> {
    /// Cosine of the angle.
    pub cos: T,
    /// Sine of the angle.
    pub sin: T,
}

impl<T: Real> Rot2<T> {
    /// The zero angle: robot +x.
    #[inline]
    pub fn identity() -> Self {
        Self {
            cos: T::one(),
            sin: T::zero(),
        }
    }

    /// The direction at `angle` rad from robot +x (one `sin_cos`).
    #[inline]
    pub fn from_angle(angle: T) -> Self {
        let (sin, cos) = angle.sin_cos();
        Self { cos, sin }
    }

    /// The direction of the vector `(x, y)`, or `None` when its length is not a positive finite
    /// number (a zero vector has no direction).
    #[inline]
    pub fn from_vector(x: T, y: T) -> Option<Self> {
        let n = (x * x + y * y).sqrt();
        if n > T::zero() && n.is_finite() {
            Some(Self {
                cos: x / n,
                sin: y / n,
            })
        } else {
            None
        }
    }

    /// The angle in `(−π, π]`, rad (`atan2(sin, cos)`).
    #[inline]
    pub fn angle(self) -> T {
        self.sin.atan2(self.cos)
    }

    /// The opposite direction (the angle plus π).
    #[inline]
    pub fn flipped(self) -> Self {
        Self {
            cos: -self.cos,
            sin: -self.sin,
        }
    }

    /// `(x, y)` rotated by this angle, counter-clockwise.
    #[inline]
    pub fn rotate(self, x: T, y: T) -> (T, T) {
        (self.cos * x - self.sin * y, self.sin * x + self.cos * y)
    }

    /// Cosine of the angle from `other` to `self` (`cos(self − other)`).
    #[inline]
    pub fn cos_to(self, other: Self) -> T {
        self.cos * other.cos + self.sin * other.sin
    }
}

/// A planar force and moment on the body, robot frame: `fx`, `fy` in N, `mz` in N·m about +z
/// through the robot origin. The dual of [`Twist2`]: the power of a wrench on a twist is
/// `fx·vx + fy·vy + mz·yaw_rate` (W).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Wrench2<T> {
    /// Force along robot x, N.
    pub fx: T,
    /// Force along robot y, N.
    pub fy: T,
    /// Moment about +z, N·m.
    pub mz: T,
}

impl<T: Real> Wrench2<T> {
    /// A wrench from its components (N, N, N·m).
    #[inline]
    pub const fn new(fx: T, fy: T, mz: T) -> Self {
        Self { fx, fy, mz }
    }

    /// The components as an array `[fx, fy, mz]`.
    #[inline]
    pub fn to_array(self) -> [T; 3] {
        [self.fx, self.fy, self.mz]
    }
}

/// Names of the wrench components, for [`InputError::NonFinite`].
pub(crate) const WRENCH: [&str; 3] = ["fx", "fy", "mz"];

/// The forward kinematics with its least-squares residual.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit<T> {
    /// The robot-frame body twist that best explains the actuators (least squares), m/s, m/s,
    /// rad/s.
    pub twist: Twist2<T>,
    /// Root-sum-square over the wheels of the slip velocity each wheel would need for the
    /// fitted rigid-body motion, m/s. Zero (to rounding) for actuators produced by
    /// [`Drive::inverse`]; always zero for a kind with exactly as many constraints as
    /// unknowns (three omni wheels).
    pub slip_residual: T,
}

/// The result of [`Drive::desaturate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Desaturated<A, T> {
    /// The actuators with every wheel rate multiplied by `scale`.
    pub actuators: A,
    /// The factor applied, `0 < scale ≤ 1` (1: nothing was over the limit). The desaturated
    /// actuators drive `scale ×` the original twist.
    pub scale: T,
}

/// A wheeled drive: the kinematic map between the robot-frame body twist and the actuator
/// vector, and what odometry needs. Implemented by [`omni::Omni`] and [`swerve::Swerve`]; see
/// the [module docs](self) for the frame of every verb.
///
/// Implementations precompute everything at construction; every method is a fixed-size
/// computation with no allocation and no panic.
pub trait Drive: Copy + Debug {
    /// The scalar type (`f32` or `f64`).
    type Scalar: Real;
    /// The actuator vector: wheel rates (rad/s), plus the steering directions of steerable
    /// kinds. What [`Drive::inverse`] returns and [`Drive::forward`] takes.
    type Actuators: Copy + Debug + PartialEq;
    /// One encoder reading: cumulative wheel angles (rad), plus steering directions of
    /// steerable kinds. What [`Drive::displacement`] takes.
    type Positions: Copy + Debug + PartialEq;

    /// Number of wheels (modules), in the order of the robot file.
    const WHEELS: usize;

    /// The actuators at rest: zero wheel rates, steering (if any) at robot +x.
    fn rest(&self) -> Self::Actuators;

    /// Inverse kinematics: the actuators that produce the **robot-frame** `twist`. `current`
    /// is the actuator state now (a steerable kind keeps a module's steering where its speed
    /// is zero and may use it to optimise; other kinds ignore it).
    ///
    /// Not limited: see [`Drive::desaturate`].
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming the first non-finite twist component;
    /// [`InputError::Overflow`] if a result is not finite.
    fn inverse(
        &self,
        twist: Twist2<Self::Scalar>,
        current: &Self::Actuators,
    ) -> Result<Self::Actuators, InputError>;

    /// Forward kinematics: the **robot-frame** twist that best explains `actuators` (least
    /// squares when there are more constraints than the three unknowns).
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming the first non-finite actuator;
    /// [`InputError::Overflow`] if the result is not finite.
    fn forward(&self, actuators: &Self::Actuators) -> Result<Twist2<Self::Scalar>, InputError>;

    /// [`Drive::forward`] with the least-squares slip residual (m/s).
    ///
    /// # Errors
    /// As [`Drive::forward`].
    fn forward_fit(&self, actuators: &Self::Actuators) -> Result<Fit<Self::Scalar>, InputError>;

    /// The robot-frame displacement `(Δx, Δy, Δθ)` (m, m, rad) between two encoder readings,
    /// in the frame of the robot at `start`: the forward kinematics of the increments (the
    /// generator of the SE(2) step, WPILib's `ToTwist2d`). Exact for constant wheel rates and
    /// steering over the step.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming the first non-finite reading;
    /// [`InputError::Overflow`] if the result is not finite.
    fn displacement(
        &self,
        start: &Self::Positions,
        end: &Self::Positions,
    ) -> Result<Twist2<Self::Scalar>, InputError>;

    /// The wheel rates of `actuators`, rad/s, in wheel order.
    fn wheel_rates(actuators: &Self::Actuators) -> &[Self::Scalar];

    /// `actuators` with every wheel rate multiplied by `factor` (steering untouched).
    fn scale_wheel_rates(actuators: Self::Actuators, factor: Self::Scalar) -> Self::Actuators;

    /// [`Drive::inverse`] of a **world-frame** twist at the explicit heading `heading` (rad):
    /// `inverse(Q(heading)ᵀ twist_world)`.
    ///
    /// # Errors
    /// As [`Drive::inverse`], plus [`InputError::NonFinite`] for a non-finite heading.
    fn inverse_world(
        &self,
        twist_world: Twist2<Self::Scalar>,
        heading: Self::Scalar,
        current: &Self::Actuators,
    ) -> Result<Self::Actuators, InputError> {
        crate::real::finite(heading, "heading")?;
        check_twist(twist_world)?;
        self.inverse(twist_world.to_robot(heading), current)
    }

    /// [`Drive::forward`] turned into the **world frame** at the explicit heading `heading`
    /// (rad): `Q(heading) forward(actuators)`.
    ///
    /// # Errors
    /// As [`Drive::forward`], plus [`InputError::NonFinite`] for a non-finite heading.
    fn forward_world(
        &self,
        actuators: &Self::Actuators,
        heading: Self::Scalar,
    ) -> Result<Twist2<Self::Scalar>, InputError> {
        crate::real::finite(heading, "heading")?;
        Ok(self.forward(actuators)?.to_world(heading))
    }

    /// Scales all wheel rates by one factor so the largest magnitude is at most
    /// `max_wheel_rate` (rad/s), keeping steering: the motion keeps its direction and
    /// curvature (see the [module docs](self)). WPILib's `DesaturateWheelSpeeds`.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] for a non-finite limit or wheel rate;
    /// [`InputError::Singular`] for a limit that is not `> 0`.
    fn desaturate(
        &self,
        actuators: Self::Actuators,
        max_wheel_rate: Self::Scalar,
    ) -> Result<Desaturated<Self::Actuators, Self::Scalar>, InputError> {
        let scale = desaturation_scale(Self::wheel_rates(&actuators), max_wheel_rate)?;
        Ok(Desaturated {
            actuators: if scale < <Self::Scalar as Real>::of(1.0) {
                Self::scale_wheel_rates(actuators, scale)
            } else {
                actuators
            },
            scale,
        })
    }
}

/// The factor `s ∈ (0, 1]` that brings the largest `|rate|` down to `max` (1 when none
/// exceeds it).
///
/// # Errors
/// [`InputError::NonFinite`] for a non-finite limit or rate (naming `wheel_rates[i]`);
/// [`InputError::Singular`] when `max` is not `> 0`.
pub fn desaturation_scale<T: Real>(rates: &[T], max: T) -> Result<T, InputError> {
    crate::real::finite(max, "max_wheel_rate")?;
    if max <= T::zero() {
        return Err(InputError::Singular {
            reason: "max_wheel_rate must be > 0 to desaturate",
        });
    }
    if !all_finite(rates) {
        return Err(first_non_finite(rates, &WHEEL_RATES));
    }
    let mut peak = T::zero();
    for &r in rates {
        if r.abs() > peak {
            peak = r.abs();
        }
    }
    Ok(if peak > max { max / peak } else { T::one() })
}
