//! What limits a move's timing ([`Limiter`]), a move slowed down by one ([`Retiming`]), and how
//! closely the planner approaches a motor limit ([`MARGIN`]). A leaf of the planner: the
//! timings and the report name limits with it.

use crate::robot::Quantity;

/// The planner aims this fraction below each motor limit, so the final check on the samples
/// (which is strict) passes despite the grid approximation.
pub(super) const MARGIN: f64 = 1.0 - 1e-4;

/// What limited the timing of (part of) a plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Limiter {
    /// The requested speed along the path.
    MaxSpeed,
    /// The requested acceleration along the path.
    MaxAccel,
    /// The requested yaw rate of a turn in place.
    MaxYawRate,
    /// The requested yaw acceleration of a turn in place.
    MaxYawAccel,
    /// A constant speed fixed by the request (paper 000's circle law).
    RequestedSpeed,
    /// A motor limit of the robot file.
    Motor {
        /// Which limit.
        quantity: Quantity,
        /// Motor number, 1-based.
        motor: usize,
    },
}

impl std::fmt::Display for Limiter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Limiter::MaxSpeed => write!(f, "max speed"),
            Limiter::MaxAccel => write!(f, "max acceleration"),
            Limiter::MaxYawRate => write!(f, "max yaw rate (turn in place)"),
            Limiter::MaxYawAccel => write!(f, "max yaw acceleration (turn in place)"),
            Limiter::RequestedSpeed => write!(f, "requested speed"),
            Limiter::Motor { quantity, motor } => {
                write!(
                    f,
                    "limits.{} ({} {motor})",
                    quantity.key(),
                    quantity.motor()
                )
            }
        }
    }
}

/// A move slowed down because of a motor limit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Retiming {
    /// Index of the move (0-based, in order).
    pub move_index: usize,
    /// Time-dilation factor `λ ≤ 1` (the move takes `1/λ` times as long).
    pub factor: f64,
    /// The limit that set it.
    pub limiter: Limiter,
}
