//! The runtime's state words: the [`Mode`] the loop is in, the [`Faults`] bit set, the plan
//! buffer's [`PlanStatus`], and the [`Status`] a cycle returns (the content of telemetry).

use serde::{Deserialize, Serialize};

use super::hal::{EncoderAngles, ImuSample, MotorCommand};
use crate::estimate::events::EventCounters;
use crate::{Pose2, Twist2};

#[cfg(doc)]
use super::{Command, Config};

/// What the robot is doing. Wire-stable: the discriminants are sent as one byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u8)]
pub enum Mode {
    /// At rest, waiting for a command.
    Idle = 0,
    /// Following a velocity command.
    Velocity = 1,
    /// Following the uploaded plan.
    Trajectory = 2,
    /// Braking to rest within the acceleration limits (stop command, watchdog, plan end,
    /// hardware fault); becomes [`Mode::Idle`] at rest.
    Stopping = 3,
    /// Emergency stop: motors at zero; latched until [`Command::Clear`].
    EStop = 4,
}

impl Mode {
    /// Lower-case name: `idle`, `velocity`, `trajectory`, `stopping`, `estop`.
    pub const fn name(self) -> &'static str {
        match self {
            Mode::Idle => "idle",
            Mode::Velocity => "velocity",
            Mode::Trajectory => "trajectory",
            Mode::Stopping => "stopping",
            Mode::EStop => "estop",
        }
    }
}

impl core::fmt::Display for Mode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// Fault flags (a bit set). Wire-stable bit positions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Faults(pub u16);

impl Faults {
    /// No fault.
    pub const NONE: Faults = Faults(0);
    /// A motor rate or acceleration limit shaped the command this cycle (desaturation scale
    /// below 1, or the wheel-acceleration limit was active).
    pub const LIMIT: Faults = Faults(1 << 0);
    /// A wheel-slip episode is under way (from the first cycle over the threshold until the
    /// signal has stayed below for the hold time, so the flag rises once per event): the gyro's yaw rate disagrees with the wheels' by more
    /// than [`Config::events`]' `slip_yaw_rate`, or the least-squares slip residual of the
    /// odometry fit (kinds with more than 3 motors: caster, mecanum, swerve, omni with more
    /// than 3 wheels) exceeds its `slip_residual` (both low-passed;
    /// [`crate::estimate::events`]). [`Status::events`] counts the episodes.
    pub const SLIP: Faults = Faults(1 << 1);
    /// No valid command or heartbeat within [`Config::watchdog`] seconds.
    pub const LINK_LOST: Faults = Faults(1 << 2);
    /// The emergency stop is latched.
    pub const ESTOP: Faults = Faults(1 << 3);
    /// A command was rejected (non-finite, over the accepted bounds, e-stop latched, plan
    /// error).
    pub const REJECTED: Faults = Faults(1 << 4);
    /// A hardware trait returned an error, or the kinematics rejected a state.
    pub const HARDWARE: Faults = Faults(1 << 5);
    /// A cycle came more than twice the nominal period after the previous one.
    pub const OVERRUN: Faults = Faults(1 << 6);
    /// A balancing robot fell: its tilt passed the controller's fall threshold, the motors are
    /// off (latched until [`Command::Clear`](super::Command::Clear)).
    pub const FALLEN: Faults = Faults(1 << 7);
    /// A collision episode is under way (likewise): the wheel speed fell faster than [`Config::events`]'
    /// `collision_decel` over its window while no slip was under way
    /// ([`crate::estimate::events`]). [`Status::events`] counts them.
    pub const COLLISION: Faults = Faults(1 << 8);

    /// `true` when every bit of `other` is set.
    pub const fn contains(self, other: Faults) -> bool {
        self.0 & other.0 == other.0
    }
    /// Sets the bits of `other`.
    pub fn insert(&mut self, other: Faults) {
        self.0 |= other.0;
    }
    /// `true` when no bit is set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Every flag with its name, in bit order.
    pub const ALL: [(Faults, &'static str); 9] = [
        (Faults::LIMIT, "limit"),
        (Faults::SLIP, "slip"),
        (Faults::LINK_LOST, "link_lost"),
        (Faults::ESTOP, "estop"),
        (Faults::REJECTED, "rejected"),
        (Faults::HARDWARE, "hardware"),
        (Faults::OVERRUN, "overrun"),
        (Faults::FALLEN, "fallen"),
        (Faults::COLLISION, "collision"),
    ];
}

/// Names joined by `|` (`limit|slip`), or `none`.
impl core::fmt::Display for Faults {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.is_empty() {
            return f.write_str("none");
        }
        let mut first = true;
        for (flag, name) in Faults::ALL {
            if self.contains(flag) {
                if !first {
                    f.write_str("|")?;
                }
                f.write_str(name)?;
                first = false;
            }
        }
        Ok(())
    }
}

/// Progress of the plan buffer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PlanStatus {
    /// Current plan id.
    pub id: u16,
    /// Points received.
    pub received: u16,
    /// Points announced.
    pub len: u16,
    /// `true` once the running plan reached its last point.
    pub done: bool,
}

/// What became of the external fixes ([`Command::Fix`](super::Command::Fix)) since start.
/// Wire-stable field order (it is sent in the link's estimate telemetry).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FixCounters {
    /// Fixes fused (the first one, which initialises a filter that had no pose, and the ones
    /// that ended a recovery included).
    pub accepted: u32,
    /// Fixes refused by the χ² gate (the estimate did not move).
    pub rejected: u32,
    /// Fixes captured before the oldest state the history keeps (more than the fusion's
    /// `max_latency` before the latest cycle, or before the first cycle): dropped.
    pub too_late: u32,
    /// Runs of rejections that ended in a recovery (re-initialisation or covariance
    /// inflation; [`crate::estimate::fusion::Recovery`]).
    pub recoveries: u32,
}

/// Everything the loop knows after a cycle (the content of telemetry).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Status<T> {
    /// Clock time of the cycle, µs.
    pub time_us: u64,
    /// Mode after the cycle.
    pub mode: Mode,
    /// Faults active in this cycle.
    pub faults: Faults,
    /// Faults seen since the last [`Command::Clear`] (sticky).
    pub fault_history: Faults,
    /// Estimated pose (world, m, m, rad unwrapped), the one the control uses: the fused pose
    /// once a fix has been accepted ([`FixCounters::accepted`] > 0), the wheel odometry
    /// (heading per [`Config::heading_from_gyro`]) before.
    pub pose: Pose2<T>,
    /// Pure wheel odometry (world; never corrected by fixes, moved only by
    /// [`Command::SetPose`](super::Command::SetPose)).
    pub odometry: Pose2<T>,
    /// Variances of the fused pose `[σ²x, σ²y, σ²θ]` (m², m², rad²), growing with the
    /// odometry's noise model between fixes. As of the filter's newest closed history entry
    /// ([`crate::estimate::fusion::PoseFusion::settled_pose_variances`]): at most one history
    /// slot (`max_latency / (FIX_HISTORY/2)`, 62.5 ms with the default 1 s) behind the pose —
    /// the covariance step runs at that rate, not every cycle.
    pub covariance: [T; 3],
    /// External fixes so far.
    pub fixes: FixCounters,
    /// Measured robot-frame twist from the encoders (mean over the last cycle).
    pub twist: Twist2<T>,
    /// Commanded robot-frame twist after limits.
    pub command: Twist2<T>,
    /// The robot's wheel (module) count, the used length of `motors` and `encoders`.
    pub wheels: u8,
    /// Motor set-points sent this cycle, rad/s (entries past the wheel count 0).
    pub motors: MotorCommand<T>,
    /// Encoder angles read this cycle, rad.
    pub encoders: EncoderAngles<T>,
    /// Newest IMU sample, if any.
    pub imu: Option<ImuSample<T>>,
    /// Plan buffer status.
    pub plan: PlanStatus,
    /// Plan time of `reference`, s: the plan time that corresponds to the measured `pose`
    /// (meaningful in [`Mode::Trajectory`]).
    pub plan_time: T,
    /// Reference pose of the plan at `plan_time` (world).
    pub reference: Pose2<T>,
    /// Least-squares slip residual of the last odometry step, m/s (0 for kinds with as many
    /// wheel constraints as unknowns: sphere, ballbot, 3-wheel omni).
    pub slip_residual: T,
    /// Slip and collision events since start (episodes: a slip that lasts a second is one).
    pub events: EventCounters,
    /// Commands rejected since start.
    pub rejected: u32,
    /// Clock time of the last valid command, µs (0 = none yet).
    pub last_command_us: u64,
}
