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
    /// Start uploading plan `id` of `len` points as a **splice** of the running plan: written
    /// into the buffer's free part while the running plan goes on, then (after its chunks and
    /// [`Command::PlanStart`]) followed from its first point's time on, without stopping (the
    /// rules: `runtime/plan.rs`'s module docs and [`CommandError::SpliceOutside`]).
    PlanSplice {
        /// Plan identifier chosen by the operator (the chunks and start name it).
        id: u16,
        /// Number of points that will follow.
        len: u16,
    },
    /// [`Command::PlanSplice`] planned from where the robot **is** rather than from the
    /// running plan's reference: its first point's position and velocity are not checked (its
    /// heading and yaw rate are), and at its switch the runtime re-bases the reference on the
    /// measured pose, the offset fading out no faster than `max_correction` (`runtime/plan.rs`'s
    /// module docs, "Re-based splice"). For a re-plan after the robot drifted from its plan.
    PlanSpliceRebased {
        /// Plan identifier chosen by the operator (the chunks and start name it).
        id: u16,
        /// Number of points that will follow.
        len: u16,
    },
    /// Start following plan `id` (all its points must have arrived); for a splice, arm it.
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
    /// An external pose fix (camera, motion capture) to fuse into the estimate at its capture
    /// time ([`CameraFix`]). It does not feed the watchdog (it is a measurement, not a motion
    /// command or heartbeat).
    Fix(CameraFix<T>),
}

/// History entries of the runtime's fusion filter ([`crate::estimate::fusion::PoseFusion`]):
/// half of them span [`Config::fusion`]'s `max_latency` whatever the control rate (1 s: 62.5 ms
/// per entry), the other half hold the fixes of that window (each fix splits at most one
/// entry). So every fix up to `max_latency` late is fused while the fixes come at most about
/// `FIX_HISTORY/2 − 1 = 15` per `max_latency` (15 Hz at 1 s); faster, the history covers
/// `(FIX_HISTORY − 1) / (16/max_latency + fix rate)` seconds (a 25 Hz camera and 1 s: 0.75 s;
/// 0.3 s late at 25 Hz and 0.9 s late at 10 Hz are tested, `tests/runtime_fixes.rs`) and older
/// fixes are counted [`FixCounters::too_late`](super::FixCounters::too_late). 37 scalars per
/// entry (an increment with its noise, a fix, the mean and covariance triangle after it):
/// 148 bytes in `f32`, 4.6 KiB for the history of a firmware's runtime.
pub const FIX_HISTORY: usize = 32;

/// Largest |x|, |y| of a [`CameraFix`], m: a fix farther from the world origin is refused.
pub const FIX_MAX_COORDINATE: f64 = 1.0e4;
/// Largest standard deviation of a [`CameraFix`] position, m.
pub const FIX_MAX_STD_XY: f64 = 100.0;

/// An external pose measurement for the runtime's fusion ([`Command::Fix`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraFix<T> {
    /// When the measurement was **taken**, robot clock µs (the clock of the telemetry's
    /// `time_us` and of [`Runtime::cycle`](super::Runtime::cycle)'s `now_us`).
    pub capture_us: u64,
    /// World x, m.
    pub x: T,
    /// World y, m.
    pub y: T,
    /// World heading, rad (any wrapping), or `None` for a position-only fix.
    pub heading: Option<T>,
    /// Standard deviation of each position coordinate, m (0 < σ ≤ [`FIX_MAX_STD_XY`]).
    pub std_xy: T,
    /// Standard deviation of the heading, rad (0 < σ ≤ π; unused without a heading).
    pub std_heading: T,
}

impl<T: Real> CameraFix<T> {
    /// Checks the fix: every value finite, |x|, |y| ≤ [`FIX_MAX_COORDINATE`], `std_xy` in
    /// (0, [`FIX_MAX_STD_XY`]], `std_heading` in (0, π] when there is a heading.
    ///
    /// # Errors
    /// [`CommandError::NonFinite`], [`CommandError::OverLimit`], [`CommandError::OutOfRange`]
    /// naming the field.
    pub fn check(&self) -> Result<(), CommandError> {
        let mut fields = [
            (self.x, "fix.x"),
            (self.y, "fix.y"),
            (self.std_xy, "fix.std_xy"),
            (T::zero(), "fix.heading"),
            (T::one(), "fix.std_heading"),
        ];
        if let Some(h) = self.heading {
            fields[3].0 = h;
            fields[4].0 = self.std_heading;
        }
        for (v, field) in fields {
            if !v.is_finite() {
                return Err(CommandError::NonFinite { field });
            }
        }
        for (v, field) in [(self.x, "fix.x"), (self.y, "fix.y")] {
            if v.abs().to_f64() > FIX_MAX_COORDINATE {
                return Err(CommandError::OverLimit {
                    field,
                    value: v.to_f64(),
                    limit: FIX_MAX_COORDINATE,
                });
            }
        }
        let range = |v: T, field, max: f64, rule| {
            let x = v.to_f64();
            if x > 0.0 && x <= max {
                Ok(())
            } else {
                Err(CommandError::OutOfRange {
                    field,
                    value: x,
                    rule,
                })
            }
        };
        range(
            self.std_xy,
            "fix.std_xy",
            FIX_MAX_STD_XY,
            "must be in (0, 100] m",
        )?;
        if self.heading.is_some() {
            range(
                self.std_heading,
                "fix.std_heading",
                core::f64::consts::PI,
                "must be in (0, pi] rad",
            )?;
        }
        Ok(())
    }
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
    #[error("a plan is running; stop it first, or splice into it")]
    Busy,
    /// A splice was sent while no plan runs (it ended, was stopped, or never started).
    #[error("no plan is running to splice into; upload a plan with plan begin")]
    NothingToSplice,
    /// A splice does not fit the buffer's free points (those after the running plan's end
    /// and before its current segment).
    #[error("splice of {len} points does not fit the {free} free points of the plan buffer")]
    SpliceNoRoom {
        /// Points of the splice.
        len: u16,
        /// Free points now.
        free: usize,
    },
    /// A splice's first point time is not ahead of the running plan's time or not before its
    /// end; the running plan goes on unchanged.
    #[error(
        "splice at plan time {at} s must lie after the running plan's time {now} s and before its end {end} s"
    )]
    SpliceOutside {
        /// The splice's first point time, s.
        at: f64,
        /// The running plan's time, s.
        now: f64,
        /// The running plan's last point time, s.
        end: f64,
    },
    /// The runtime does not take this kind of command (the balance runtime follows velocity
    /// commands, not plans).
    #[error("{what} are not supported by this runtime: {instead}")]
    NotSupported {
        /// What was sent, e.g. `"plans"`.
        what: &'static str,
        /// What to send instead.
        instead: &'static str,
    },
    /// A value outside its allowed range (a fix's standard deviation, …).
    #[error("{field} = {value}: {rule}")]
    OutOfRange {
        /// The field, e.g. `"fix.std_xy"`.
        field: &'static str,
        /// The value sent.
        value: f64,
        /// The rule it breaks.
        rule: &'static str,
    },
    /// A fix stamped after the runtime's newest odometry step (the estimate does not
    /// extrapolate; send a fix once the robot's clock has reached its capture time).
    #[error(
        "fix captured at {capture_us} µs is newer than the robot's latest cycle ({latest_us} µs)"
    )]
    FixInFuture {
        /// The fix's capture time, µs.
        capture_us: u64,
        /// Clock time of the newest odometry step, µs.
        latest_us: u64,
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
