//! The uniform values every kind speaks in: the kinds, the fixed-capacity actuator vector and
//! encoder reading, the forward-kinematics result and the torque-map spaces.

use super::*;

/// Largest number of wheels (modules) of any kind, the capacity of [`Actuators`] and
/// [`EncoderAngles`]. Omni drives have 3 to 6 wheels, swerve drives 2 to 6 modules.
pub const MAX_WHEELS: usize = 6;

/// The kinds of robot a robot file can name (its `kind` key): the one kind enum of the
/// project. The link carries it as is ([`crate::link::RobotKind`] is this type), the robot
/// file's `kind` key is [`Kind::name`], and every capability a layer above the core needs
/// ([`Kind::steerable`], [`Kind::balances`], [`Kind::has_dynamics`], …) is a method here, so
/// no other crate compares kind names.
///
/// # Adding a kind
/// Append the variant **at the end**: the link (protocol 4) encodes a kind as its index in
/// this declaration, and the five kinds here keep 0–4 (a test pins them). Every `match` on a
/// kind is exhaustive (no `_ =>` arm), so the compiler lists each place that must learn the
/// new kind; a match that leaves a kind out does not compile:
///
/// ```compile_fail,E0004
/// use omnikin::Kind;
/// // Swerve forgotten: error[E0004]: non-exhaustive patterns: `Kind::Swerve` not covered.
/// fn steerable(k: Kind) -> bool {
///     match k {
///         Kind::Sphere | Kind::Ballbot | Kind::Omni => false,
///         Kind::Caster => true,
///     }
/// }
/// ```
///
/// (The same match with every kind compiles:)
///
/// ```
/// use omnikin::Kind;
/// fn steerable(k: Kind) -> bool {
///     match k {
///         Kind::Sphere | Kind::Ballbot | Kind::Omni => false,
///         Kind::Caster | Kind::Swerve => true,
///     }
/// }
/// assert!(Kind::ALL.iter().all(|&k| steerable(k) == k.steerable()));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
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
        match self {
            Kind::Caster | Kind::Swerve => true,
            Kind::Sphere | Kind::Ballbot | Kind::Omni => false,
        }
    }

    /// `true` when the body balances on its drive (ballbot, paper 001): a dynamic run or
    /// simulated robot needs the balance controller and its plant, not the kinematic runtime.
    pub const fn balances(self) -> bool {
        match self {
            Kind::Ballbot => true,
            Kind::Sphere | Kind::Caster | Kind::Omni | Kind::Swerve => false,
        }
    }

    /// `true` when the kind has a dynamic model: its robot file may carry a `[dynamics]`
    /// table, and `--plant dynamic` simulates it (sphere, paper 000 §4; ballbot, paper 001).
    pub const fn has_dynamics(self) -> bool {
        match self {
            Kind::Sphere | Kind::Ballbot => true,
            Kind::Caster | Kind::Omni | Kind::Swerve => false,
        }
    }

    /// `true` when the body rolls on a ball or shell that can spin about the vertical
    /// independently of the wheels' odometry (sphere, ballbot): a measured heading then
    /// reveals that spin ([`crate::estimate::odometry::OdometryStep::shell_spin`]).
    pub const fn has_vertical_spin(self) -> bool {
        match self {
            Kind::Sphere | Kind::Ballbot => true,
            Kind::Caster | Kind::Omni | Kind::Swerve => false,
        }
    }

    /// What the robot's wheel units are called in output: `module` (swerve), else `wheel`.
    pub const fn wheel_noun(self) -> &'static str {
        match self {
            Kind::Swerve => "module",
            Kind::Sphere | Kind::Ballbot | Kind::Caster | Kind::Omni => "wheel",
        }
    }

    /// What spins about the vertical for [`Kind::has_vertical_spin`] kinds: `shell` (sphere),
    /// `ball` (ballbot); `None` for the others.
    pub const fn spin_body(self) -> Option<&'static str> {
        match self {
            Kind::Sphere => Some("shell"),
            Kind::Ballbot => Some("ball"),
            Kind::Caster | Kind::Omni | Kind::Swerve => None,
        }
    }

    /// `true` when the steering of a module is free (centred modules): a module steers to any
    /// angle at once kinematically, so its steer angle is a set-point and steer rates follow
    /// from the twist's rate of change only. `false` for the caster, whose steer rates follow
    /// from the twist itself (paper 003).
    pub const fn steer_is_set_point(self) -> bool {
        match self {
            Kind::Swerve => true,
            Kind::Sphere | Kind::Ballbot | Kind::Caster | Kind::Omni => false,
        }
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
