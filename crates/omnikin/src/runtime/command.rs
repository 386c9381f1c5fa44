//! What an operator can ask of the runtime: the [`Command`]s (with the [`Frame`] of a
//! velocity command and the [`PlanPoint`]s of an uploaded plan) and why one is rejected
//! ([`CommandError`]).

use serde::{Deserialize, Serialize};

use super::config::Config;
use crate::{Pose2, Real, Twist2};

/// Frame of a velocity command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Frame {
    /// Robot frame: x forward, y left.
    Robot,
    /// World frame: converted with the current estimated heading every cycle.
    World,
}

/// One sample of an uploaded plan (world frame, SI units; as a row of the plan CSV without the
/// wheel rates, which the runtime recomputes with feedback).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanPoint<T> {
    /// Plan time, s.
    pub t: T,
    /// Reference pose (m, m, rad unwrapped).
    pub pose: Pose2<T>,
    /// Reference **world-frame** twist (m/s, m/s, rad/s): the feed-forward.
    pub twist: Twist2<T>,
}

impl<T: Real> PlanPoint<T> {
    /// All zeros.
    pub fn zero() -> Self {
        let z = T::zero();
        Self {
            t: z,
            pose: Pose2::new(z, z, z),
            twist: Twist2::new(z, z, z),
        }
    }
}

/// An operator command, already authenticated and decoded by the link.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command<'a, T> {
    /// Session start; only feeds the watchdog.
    Hello,
    /// Keeps the link alive (feeds the watchdog).
    Heartbeat,
    /// Drive with this twist (m/s, m/s, rad/s) in `frame` until told otherwise.
    Velocity {
        /// The twist.
        twist: Twist2<T>,
        /// Its frame.
        frame: Frame,
    },
    /// Start uploading plan `id` of `len` points (clears the buffer).
    PlanBegin {
        /// Plan identifier chosen by the operator.
        id: u16,
        /// Number of points that will follow.
        len: u16,
    },
    /// Points `offset..offset + points.len()` of plan `id`. Chunks may be re-sent (idempotent)
    /// and must not leave a gap.
    PlanChunk {
        /// Plan identifier.
        id: u16,
        /// Index of the first point.
        offset: u16,
        /// The points.
        points: &'a [PlanPoint<T>],
    },
    /// Start following plan `id` (all its points must have arrived).
    PlanStart {
        /// Plan identifier.
        id: u16,
    },
    /// Brake to rest within the acceleration limits.
    Stop,
    /// Emergency stop: motors to zero at once; latched until [`Command::Clear`].
    EStop,
    /// Clear the e-stop latch and the fault history.
    Clear,
    /// Reset the pose estimate (world frame, m, m, rad).
    SetPose(Pose2<T>),
}

/// Why a command was rejected (it is then not executed at all, and counted).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum CommandError {
    /// A value is NaN or infinite.
    #[error("{field} must be finite")]
    NonFinite {
        /// The field, e.g. `"vx"`, `"plan.pose.x"`.
        field: &'static str,
    },
    /// A value exceeds the accepted bound ([`Config::max_speed`], [`Config::max_yaw_rate`]).
    #[error("{field} = {value} exceeds the accepted bound {limit}")]
    OverLimit {
        /// The field, `"speed"` or `"yaw_rate"` (or `"plan.speed"`, `"plan.yaw_rate"`).
        field: &'static str,
        /// The value.
        value: f64,
        /// The bound.
        limit: f64,
    },
    /// The emergency stop is latched: only `Clear`, `Stop`, `EStop`, `Hello`, `Heartbeat`
    /// and `SetPose` are accepted.
    #[error("emergency stop is latched; send clear first")]
    EStopLatched,
    /// The plan does not fit the buffer.
    #[error("plan of {len} points exceeds the capacity of {capacity}")]
    PlanTooLong {
        /// Requested length.
        len: u16,
        /// Buffer capacity.
        capacity: usize,
    },
    /// A plan message names another plan than the one being uploaded.
    #[error("plan id {got} does not match the plan being uploaded ({expected})")]
    PlanIdMismatch {
        /// The current plan id.
        expected: u16,
        /// The id in the message.
        got: u16,
    },
    /// A chunk would leave a gap or run past the announced length.
    #[error(
        "plan chunk at offset {offset} with {count} points does not fit (have {have}, announced {len})"
    )]
    PlanChunkOutOfPlace {
        /// Chunk offset.
        offset: u16,
        /// Points in the chunk.
        count: usize,
        /// Points received so far.
        have: u16,
        /// Announced length.
        len: u16,
    },
    /// Plan times do not increase strictly.
    #[error("plan point {index}: time does not increase")]
    PlanTimeNotIncreasing {
        /// Index of the offending point.
        index: usize,
    },
    /// Start requested before every point arrived.
    #[error("plan incomplete: {have} of {len} points")]
    PlanIncomplete {
        /// Points received.
        have: u16,
        /// Announced length (at least 2 needed).
        len: u16,
    },
    /// A new plan upload was begun while a plan is running.
    #[error("a plan is running; stop it first")]
    Busy,
    /// The runtime does not take this kind of command (the balance runtime follows velocity
    /// commands, not plans).
    #[error("{what} are not supported by this runtime: {instead}")]
    NotSupported {
        /// What was sent, e.g. `"plans"`.
        what: &'static str,
        /// What to send instead.
        instead: &'static str,
    },
}

/// Checks a commanded (or planned, `plan`) twist: finite, linear speed within
/// [`Config::max_speed`], yaw rate within [`Config::max_yaw_rate`].
pub(super) fn check_motion<T: Real>(
    twist: Twist2<T>,
    plan: bool,
    cfg: &Config<T>,
) -> Result<(), CommandError> {
    check_twist(twist, plan, cfg.max_speed, cfg.max_yaw_rate)
}

/// [`check_motion`] against explicit bounds (m/s, rad/s): every runtime's one check of a
/// commanded twist.
pub(super) fn check_twist<T: Real>(
    twist: Twist2<T>,
    plan: bool,
    max_speed: T,
    max_yaw_rate: T,
) -> Result<(), CommandError> {
    let f = |x: T, field| {
        if x.is_finite() {
            Ok(())
        } else {
            Err(CommandError::NonFinite { field })
        }
    };
    let (fx, fy, fw, fs, fyr) = if plan {
        (
            "plan.vx",
            "plan.vy",
            "plan.yaw_rate",
            "plan.speed",
            "plan.yaw_rate",
        )
    } else {
        ("vx", "vy", "yaw_rate", "speed", "yaw_rate")
    };
    f(twist.vx, fx)?;
    f(twist.vy, fy)?;
    f(twist.yaw_rate, fw)?;
    let speed = (twist.vx * twist.vx + twist.vy * twist.vy).sqrt();
    if speed > max_speed {
        return Err(CommandError::OverLimit {
            field: fs,
            value: speed.to_f64(),
            limit: max_speed.to_f64(),
        });
    }
    if twist.yaw_rate.abs() > max_yaw_rate {
        return Err(CommandError::OverLimit {
            field: fyr,
            value: twist.yaw_rate.to_f64(),
            limit: max_yaw_rate.to_f64(),
        });
    }
    Ok(())
}
