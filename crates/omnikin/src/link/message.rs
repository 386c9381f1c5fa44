//! The messages of the link: what an operator and a robot say to each other in a session
//! ([`Message`]), the handshake bodies ([`Hello`], [`HelloAck`]) and the wire types they carry
//! ([`Telemetry`], [`WirePoint`], [`RobotInfo`]). Field and variant order is part of the
//! protocol (postcard writes them in order).

use serde::{Deserialize, Serialize};

use super::{CHUNK_POINTS, LinkCounters, NONCE_LEN};
use crate::estimate::events::EventCounters;
use crate::runtime::{
    BalanceStatus, CameraFix, Command, Faults, FixCounters, Frame, Mode, PlanPoint, PlanStatus,
    Status,
};
use crate::{MAX_WHEELS, Pose2, Real, Twist2};

/// One plan point on the wire (world frame, SI, `f32`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WirePoint {
    /// Plan time, s.
    pub t: f32,
    /// Pose `[x, y, heading]`, m, m, rad.
    pub pose: [f32; 3],
    /// World twist `[vx, vy, yaw_rate]`, m/s, m/s, rad/s.
    pub twist: [f32; 3],
}

impl WirePoint {
    /// From a runtime point.
    pub fn from_point<T: Real>(p: &PlanPoint<T>) -> Self {
        let f = |x: T| x.to_f64() as f32;
        Self {
            t: f(p.t),
            pose: [f(p.pose.x), f(p.pose.y), f(p.pose.heading)],
            twist: [f(p.twist.vx), f(p.twist.vy), f(p.twist.yaw_rate)],
        }
    }
    /// To a runtime point (no validation: [`Runtime::handle`](crate::runtime::Runtime::handle) validates).
    pub fn to_point<T: Real>(&self) -> PlanPoint<T> {
        let c = |x: f32| T::of(x as f64);
        PlanPoint {
            t: c(self.t),
            pose: Pose2::new(c(self.pose[0]), c(self.pose[1]), c(self.pose[2])),
            twist: Twist2::new(c(self.twist[0]), c(self.twist[1]), c(self.twist[2])),
        }
    }
}

/// Which robot model a runtime drives (in [`RobotInfo`]): the core's one kind enum,
/// [`crate::Kind`], carried as its declaration index (postcard; `Sphere` 0 … `Swerve` 4). A new
/// kind is appended there, so the encoding of these five never changes.
pub type RobotKind = crate::Kind;

/// The body limits the robot's runtime enforces on every command (f32, SI units; world
/// frame), in its answer to a Hello, so that an operator can refuse a plan that asks for more
/// before uploading it. `f32::INFINITY` where the runtime does not limit the quantity (a
/// ballbot's yaw acceleration and jerk; a jerk limit the robot file does not set).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotLimits {
    /// Largest linear acceleration magnitude, m/s².
    pub max_accel: f32,
    /// Largest yaw acceleration magnitude, rad/s².
    pub max_yaw_accel: f32,
    /// Largest linear jerk, m/s³.
    pub max_jerk: f32,
}

/// Who the robot is, in its answer to a Hello ([`HelloAck`]; v1's fields, then the limits
/// added in protocol 4 — a v1 answer carries [`v1::V1RobotInfo`](super::v1::V1RobotInfo)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotInfo {
    /// The robot's protocol version.
    pub protocol: u8,
    /// Robot model.
    pub kind: RobotKind,
    /// Plan buffer capacity, points.
    pub plan_capacity: u16,
    /// Control rate, Hz.
    pub rate_hz: f32,
    /// Watchdog time, s.
    pub watchdog: f32,
    /// Whether commands must carry a tag.
    pub authenticated: bool,
    /// The runtime's effective body limits (protocol 4).
    pub limits: RobotLimits,
}

/// Robot state at one cycle, as sent to the operator (all `f32`, SI units).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    /// Robot clock, µs.
    pub time_us: u64,
    /// Mode.
    pub mode: Mode,
    /// Faults active in this cycle.
    pub faults: Faults,
    /// Faults since the last clear.
    pub fault_history: Faults,
    /// Estimated pose `[x, y, heading]` (world; m, m, rad).
    pub pose: [f32; 3],
    /// Measured robot-frame twist `[vx, vy, yaw_rate]` from the encoders.
    pub twist: [f32; 3],
    /// Commanded robot-frame twist after limits.
    pub command: [f32; 3],
    /// The robot's wheel (module) count: the used length of the four per-wheel arrays.
    pub wheels: u8,
    /// Commanded wheel rates, rad/s, in the robot file's wheel order (entries past the wheel
    /// count 0; postcard writes the [`MAX_WHEELS`] floats without a length). A balancing
    /// ballbot commands torques, not rates: zeros ([`Telemetry::from_balance`]).
    pub wheel_rates: [f32; MAX_WHEELS],
    /// Commanded steer rates, rad/s (kinds with steer motors; zeros otherwise).
    pub steer_rates: [f32; MAX_WHEELS],
    /// Encoder wheel angles, rad.
    pub wheel_angles: [f32; MAX_WHEELS],
    /// Encoder steer angles, rad (kinds with steer motors; zeros otherwise).
    pub steer_angles: [f32; MAX_WHEELS],
    /// Gyro, rad/s, robot frame (zeros without an IMU).
    pub gyro: [f32; 3],
    /// Accelerometer, m/s², robot frame (zeros without an IMU).
    pub accel: [f32; 3],
    /// Plan buffer.
    pub plan: PlanStatus,
    /// Plan time, s.
    pub plan_time: f32,
    /// Plan reference pose at `plan_time` `[x, y, heading]`.
    pub reference: [f32; 3],
    /// Least-squares slip residual of the odometry fit, m/s (0 for exactly determined kinds).
    pub slip_residual: f32,
    /// Commands rejected by the runtime.
    pub rejected: u32,
    /// Robot clock of the last valid command, µs (0: none).
    pub last_command_us: u64,
    /// The robot's receive statistics.
    pub link: LinkCounters,
    /// Sequence number of the newest command frame accepted in this session (0: none yet).
    pub ack_seq: u64,
    /// Sequence number of the newest `EStop` accepted in this session while the e-stop is
    /// latched (0: not latched by this session). An operator takes this, in a frame of its own
    /// session, as the confirmation of *its* e-stop.
    pub estop_seq: u64,
    /// Sequence number of the `Clear` that ended this session's last e-stop (0: none): the
    /// confirmation of a clear, and which one it was.
    pub clear_seq: u64,
}

impl Telemetry {
    /// Telemetry from a runtime status and the link counters (`ack_seq`, `estop_seq` zero:
    /// [`RobotLink::telemetry`](super::RobotLink::telemetry) fills them in).
    pub fn new<T: Real>(s: &Status<T>, link: &LinkCounters) -> Self {
        let f = |x: T| x.to_f64() as f32;
        let p = |p: Pose2<T>| [f(p.x), f(p.y), f(p.heading)];
        let w = |t: Twist2<T>| [f(t.vx), f(t.vy), f(t.yaw_rate)];
        let a = |x: [T; 3]| x.map(f);
        let m = |x: [T; MAX_WHEELS]| x.map(f);
        let imu = s.imu;
        Self {
            time_us: s.time_us,
            mode: s.mode,
            faults: s.faults,
            fault_history: s.fault_history,
            pose: p(s.pose),
            twist: w(s.twist),
            command: w(s.command),
            wheels: s.wheels,
            wheel_rates: m(s.motors.wheel),
            steer_rates: m(s.motors.steer),
            wheel_angles: m(s.encoders.wheel),
            steer_angles: m(s.encoders.steer),
            gyro: imu.map_or([0.0; 3], |i| a(i.gyro)),
            accel: imu.map_or([0.0; 3], |i| a(i.accel)),
            plan: s.plan,
            plan_time: f(s.plan_time),
            reference: p(s.reference),
            slip_residual: f(s.slip_residual),
            rejected: s.rejected,
            last_command_us: s.last_command_us,
            link: *link,
            ack_seq: 0,
            estop_seq: 0,
            clear_seq: 0,
        }
    }

    /// Telemetry from the balance runtime's status ([`crate::runtime::BalanceRuntime`]): the
    /// world velocity and command turned into the robot frame with the estimated yaw, three
    /// wheels, zero wheel-rate commands (it commands torques), no plan (the reference is the
    /// estimated pose).
    pub fn from_balance<T: Real>(s: &BalanceStatus<T>, link: &LinkCounters) -> Self {
        let f = |x: T| x.to_f64() as f32;
        let (sn, c) = s.pose.heading.sin_cos();
        let robot = |v: [T; 2], w: T| [f(c * v[0] + sn * v[1]), f(-sn * v[0] + c * v[1]), f(w)];
        let mut wheel_angles = [0.0; MAX_WHEELS];
        for (o, a) in wheel_angles.iter_mut().zip(s.wheel_angles) {
            *o = f(a);
        }
        let pose = [f(s.pose.x), f(s.pose.y), f(s.pose.heading)];
        Self {
            time_us: s.time_us,
            mode: s.mode,
            faults: s.faults,
            fault_history: s.fault_history,
            pose,
            twist: robot(s.velocity, s.yaw_rate),
            command: robot(s.command, s.command_yaw_rate),
            wheels: 3,
            wheel_rates: [0.0; MAX_WHEELS],
            steer_rates: [0.0; MAX_WHEELS],
            wheel_angles,
            steer_angles: [0.0; MAX_WHEELS],
            gyro: s.imu.0.map(f),
            accel: s.imu.1.map(f),
            plan: PlanStatus::default(),
            plan_time: 0.0,
            reference: pose,
            slip_residual: 0.0,
            rejected: s.rejected,
            last_command_us: s.last_command_us,
            link: *link,
            ack_seq: 0,
            estop_seq: 0,
            clear_seq: 0,
        }
    }
}

/// An external pose fix on the wire (operator → robot, [`Message::Fix`]): a camera or
/// motion-capture measurement of the robot's world pose, with the robot-clock time it was
/// taken. The robot validates it ([`CameraFix::check`]) and fuses it at `capture_us`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WireFix {
    /// Capture time, robot clock µs (the clock of [`Telemetry::time_us`]).
    pub capture_us: u64,
    /// World x, m.
    pub x: f32,
    /// World y, m.
    pub y: f32,
    /// World heading, rad, or `None` for a position-only fix.
    pub heading: Option<f32>,
    /// Standard deviation of each position coordinate, m (> 0).
    pub std_xy: f32,
    /// Standard deviation of the heading, rad (> 0 when there is a heading).
    pub std_heading: f32,
}

impl WireFix {
    /// The runtime's fix (no validation: [`Runtime::handle`](crate::runtime::Runtime::handle)
    /// validates).
    pub fn to_fix<T: Real>(&self) -> CameraFix<T> {
        let c = |x: f32| T::of(x as f64);
        CameraFix {
            capture_us: self.capture_us,
            x: c(self.x),
            y: c(self.y),
            heading: self.heading.map(c),
            std_xy: c(self.std_xy),
            std_heading: c(self.std_heading),
        }
    }
}

/// The runtime's estimate at one cycle (robot → operator, [`Message::Estimate`], sent with
/// each [`Telemetry`] of the same cycle): the fusion filter's uncertainty and fix counters and
/// the uncorrected wheel odometry. [`Telemetry::pose`] is the pose the control uses (the fused
/// one once a fix has been accepted). A message of its own so that the v2 `Telemetry` layout is
/// unchanged (a robot or operator without it counts it `malformed` and goes on).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Robot clock, µs (the same cycle as the telemetry sent after it).
    pub time_us: u64,
    /// Variances of the fused pose `[σ²x, σ²y, σ²θ]`, m², m², rad².
    pub covariance: [f32; 3],
    /// Pure wheel odometry `[x, y, heading]` (world; m, m, rad), never corrected by fixes.
    pub odometry: [f32; 3],
    /// Estimated gyro bias, rad/s, and wheel-scale factor (1 nominal).
    pub gyro_bias: f32,
    /// Wheel-scale factor, true / measured travel.
    pub wheel_scale: f32,
    /// Fix counters since the robot started.
    pub fixes: FixCounters,
    /// Slip and collision events since the robot started (the [`Faults::SLIP`] and
    /// [`Faults::COLLISION`] bits of the telemetry are set in the cycles they are detected).
    pub events: EventCounters,
}

impl Estimate {
    /// From a rate runtime's status and its filter's bias and scale.
    pub fn new<T: Real>(s: &Status<T>, gyro_bias: T, wheel_scale: T) -> Self {
        let f = |x: T| x.to_f64() as f32;
        Self {
            time_us: s.time_us,
            covariance: s.covariance.map(f),
            odometry: [f(s.odometry.x), f(s.odometry.y), f(s.odometry.heading)],
            gyro_bias: f(gyro_bias),
            wheel_scale: f(wheel_scale),
            fixes: s.fixes,
            events: s.events,
        }
    }
}

/// A runtime status the link turns into [`Telemetry`] ([`super::RobotLink::telemetry`]).
pub trait TelemetrySource {
    /// The telemetry of this status with the link's counters (`ack_seq`, `estop_seq` zero).
    fn telemetry(&self, link: &LinkCounters) -> Telemetry;
}

impl<T: Real> TelemetrySource for Status<T> {
    fn telemetry(&self, link: &LinkCounters) -> Telemetry {
        Telemetry::new(self, link)
    }
}

impl<T: Real> TelemetrySource for BalanceStatus<T> {
    fn telemetry(&self, link: &LinkCounters) -> Telemetry {
        Telemetry::from_balance(self, link)
    }
}

/// Why a session ended ([`Message::SessionEnd`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum EndReason {
    /// Another operator completed a handshake and took over.
    TakenOver,
}

/// Every message of a session (the body of a [`FrameKind::Session`](super::FrameKind::Session) frame). Operator → robot:
/// `Heartbeat` … `SetPose`; robot → operator: `Telemetry`, `SessionEnd`. Variant order is part
/// of the wire format.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Message {
    /// Keep-alive: feeds the watchdog (and confirms a new session).
    Heartbeat,
    /// Drive at this twist (m/s, m/s, rad/s) in `frame`.
    SetVelocity {
        /// Frame of `vx`, `vy`.
        frame: Frame,
        /// m/s.
        vx: f32,
        /// m/s.
        vy: f32,
        /// rad/s.
        yaw_rate: f32,
    },
    /// Begin uploading plan `id` of `len` points.
    PlanBegin {
        /// Plan id.
        id: u16,
        /// Points to follow.
        len: u16,
    },
    /// Points `offset..` of plan `id` (at most [`CHUNK_POINTS`]).
    PlanChunk {
        /// Plan id.
        id: u16,
        /// First point's index.
        offset: u16,
        /// The points.
        points: heapless::Vec<WirePoint, CHUNK_POINTS>,
    },
    /// Start following plan `id`.
    PlanStart {
        /// Plan id.
        id: u16,
    },
    /// Controlled stop.
    Stop,
    /// Emergency stop (latched).
    EStop,
    /// Clear the e-stop latch and the fault history.
    Clear,
    /// Reset the pose estimate (world; m, m, rad).
    SetPose {
        /// m.
        x: f32,
        /// m.
        y: f32,
        /// rad.
        heading: f32,
    },
    /// Robot state.
    Telemetry(Telemetry),
    /// The robot ended this session (its last frame in it).
    SessionEnd(EndReason),
    /// Operator → robot: an external pose fix to fuse at its capture time. Appended after
    /// the v2 messages of 2 Dec 2026: a robot without it drops it as `malformed`.
    Fix(WireFix),
    /// Robot → operator: the runtime's estimate (covariance, fix counters, wheel odometry),
    /// sent right before the [`Message::Telemetry`] of the same cycle. An operator without it
    /// drops it as `malformed`.
    Estimate(Estimate),
    /// Robot → operator, simulated robots only (`omnikin robot --sim`): the plant's true pose,
    /// sent right before the [`Message::Telemetry`] of the same cycle, so an operator can show
    /// the estimate against the truth. Appended after [`Message::Estimate`]: an operator
    /// without it drops it as `malformed`. A real robot never sends it (it has no truth).
    Truth(SimTruth),
    /// Robot → operator: the answer to an open frame without
    /// [`Opening::take_over`](super::Opening::take_over) while another operator's session is
    /// live. The session is not opened; the operator may open it later, or take over.
    Busy(Busy),
    /// Operator → robot: this operator leaves its session (the last frame a `drive` run or a
    /// console sends). The session stops being live at once, so another operator opens
    /// without taking over; the robot's motion is not affected (the watchdog still applies).
    Bye,
    /// Operator → robot: begin uploading plan `id` of `len` points as a splice of the running
    /// plan ([`Command::PlanSplice`]); its chunks and start are the usual
    /// [`Message::PlanChunk`] and [`Message::PlanStart`]. Appended after [`Message::Bye`]: a
    /// robot without it drops it as `malformed` (its plan status never shows the splice's id,
    /// so the operator's upload does not complete).
    PlanSplice {
        /// Plan id.
        id: u16,
        /// Points to follow.
        len: u16,
    },
    /// Operator → robot: begin uploading plan `id` of `len` points as a **re-based** splice
    /// of the running plan, planned from where the robot is ([`Command::PlanSpliceRebased`]);
    /// its chunks and start are the usual ones. Appended after [`Message::PlanSplice`], so every
    /// earlier message keeps its encoding: a robot without it drops it as `malformed` (the
    /// operator's upload does not complete, and it re-plans another way).
    PlanSpliceRebased {
        /// Plan id.
        id: u16,
        /// Points to follow.
        len: u16,
    },
}

/// Who holds the robot ([`Message::Busy`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Busy {
    /// The live session's id.
    pub holder: u64,
    /// Robot time since that session's newest frame, ms.
    pub idle_ms: u32,
    /// Robot time since that session opened, s.
    pub held_s: u32,
}

/// The simulated plant's true pose at one cycle ([`Message::Truth`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimTruth {
    /// Robot clock, µs (the same cycle as the telemetry sent after it).
    pub time_us: u64,
    /// True pose `[x, y, heading]` (world; m, m, rad).
    pub pose: [f32; 3],
}

/// The body of a [`FrameKind::Hello`](super::FrameKind::Hello) frame (then zero padding up to [`HANDSHAKE_BODY`](super::HANDSHAKE_BODY) bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Hello {
    /// The operator's protocol version.
    pub protocol: u8,
    /// Fresh random bytes of the operator, echoed by the robot.
    pub client_nonce: [u8; NONCE_LEN],
}

/// The body of a [`FrameKind::HelloAck`](super::FrameKind::HelloAck) frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HelloAck {
    /// Who the robot is.
    pub info: RobotInfo,
    /// The Hello's nonce (binds the answer to that Hello).
    pub client_nonce: [u8; NONCE_LEN],
    /// The robot's bytes for this Hello: derived from its handshake secret and the client
    /// nonce ([`HandshakeSecrets`](super::HandshakeSecrets)), so the robot keeps no state.
    pub robot_nonce: [u8; NONCE_LEN],
    /// The handshake epoch the robot answered in; the operator's open frames carry it back.
    pub epoch: u32,
}

impl Message {
    /// Whether this message is for the robot (operator → robot).
    pub fn for_robot(&self) -> bool {
        !matches!(
            self,
            Message::Telemetry(_)
                | Message::SessionEnd(_)
                | Message::Estimate(_)
                | Message::Truth(_)
                | Message::Busy(_)
        )
    }

    /// Whether an accepted e-stop with a higher sequence number voids this message: a clear,
    /// or a command that moves the robot or its estimate (velocity, plan, set-pose).
    pub fn ordered_after_estop(&self) -> bool {
        matches!(
            self,
            Message::Clear
                | Message::SetVelocity { .. }
                | Message::PlanBegin { .. }
                | Message::PlanSplice { .. }
                | Message::PlanSpliceRebased { .. }
                | Message::PlanChunk { .. }
                | Message::PlanStart { .. }
                | Message::SetPose { .. }
        )
    }

    /// The runtime command of an operator message (`None` for `Telemetry`, `SessionEnd`,
    /// `Estimate`, `Truth`, `Busy` and `Bye`).
    /// Chunk points are converted into `buf`.
    pub fn command<'b, T: Real>(
        &self,
        buf: &'b mut [PlanPoint<T>; CHUNK_POINTS],
    ) -> Option<Command<'b, T>> {
        let c = |x: f32| T::of(x as f64);
        Some(match self {
            Message::Heartbeat => Command::Heartbeat,
            Message::SetVelocity {
                frame,
                vx,
                vy,
                yaw_rate,
            } => Command::Velocity {
                twist: Twist2::new(c(*vx), c(*vy), c(*yaw_rate)),
                frame: *frame,
            },
            Message::PlanBegin { id, len } => Command::PlanBegin { id: *id, len: *len },
            Message::PlanSplice { id, len } => Command::PlanSplice { id: *id, len: *len },
            Message::PlanSpliceRebased { id, len } => {
                Command::PlanSpliceRebased { id: *id, len: *len }
            }
            Message::PlanChunk { id, offset, points } => {
                let n = points.len().min(CHUNK_POINTS);
                for (dst, src) in buf.iter_mut().zip(points.iter()) {
                    *dst = src.to_point();
                }
                Command::PlanChunk {
                    id: *id,
                    offset: *offset,
                    points: &buf[..n],
                }
            }
            Message::PlanStart { id } => Command::PlanStart { id: *id },
            Message::Stop => Command::Stop,
            Message::EStop => Command::EStop,
            Message::Clear => Command::Clear,
            Message::SetPose { x, y, heading } => {
                Command::SetPose(Pose2::new(c(*x), c(*y), c(*heading)))
            }
            Message::Fix(f) => Command::Fix(f.to_fix()),
            Message::Telemetry(_)
            | Message::SessionEnd(_)
            | Message::Estimate(_)
            | Message::Truth(_)
            | Message::Busy(_)
            | Message::Bye => return None,
        })
    }
}
