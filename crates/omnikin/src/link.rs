//! # Operator link: the wire format between the PC and the robot
//!
//! Paper 000's operator sets motion commands on a PC and sends them over a wireless link to
//! the microcontroller. This module is that link's codec and session logic, the same on both
//! ends, `no_std`, no allocation, over **any byte stream** (UDP datagrams, a serial port, a
//! radio modem).
//!
//! ## Frame format (protocol version [`PROTOCOL_VERSION`] = 2)
//! ```text
//! COBS( version:u8 = 2 | kind:u8 | session:u64 LE | seq:u64 LE | body | tag[16] | crc32c:u32 LE ) 0x00
//! ```
//! * **COBS** removes every `0x00` from the frame so a single `0x00` delimits frames; a
//!   receiver that joins mid-stream re-synchronises at the next delimiter.
//! * `crc32c` (CRC-32C, Castagnoli) over everything before it: a corrupt frame is dropped
//!   ([`LinkCounters::crc`]). It catches noise, not attackers; the tag does that.
//! * `version` is checked right after the CRC; a frame of another version is dropped
//!   ([`LinkCounters::version`]) — a robot answers a v1 peer with one v1 answer it can print
//!   ([`v1`]).
//! * `kind`: [`Kind`] in the low 7 bits; bit 7 ([`KIND_TAGGED`]) says the frame carries a
//!   `tag`. A handshake frame ([`Kind::Hello`], [`Kind::HelloAck`]) has `session = 0` (Hello)
//!   or the new session's id (HelloAck) and `seq = 0`; a [`Kind::Session`] frame carries one
//!   [`Message`] of session `session` with sequence number `seq` ≥ 1.
//! * `tag` (with a pre-shared [`Key`] only): the first [`TAG_LEN`] = 16 bytes of HMAC-SHA256
//!   over `version … body`, keyed with the PSK for handshake frames and with the session key
//!   for session frames. A keyed endpoint drops a frame without a valid tag, an unkeyed one a
//!   frame with a tag ([`LinkCounters::auth`]).
//! * `body`: postcard (serde's compact varint format; the schema is this module's types,
//!   whose field order is part of the protocol). A Hello is zero-padded to
//!   [`HANDSHAKE_BODY`] bytes, so it is never smaller than the robot's answer.
//!
//! ## Sessions
//! ```text
//! operator                                                  robot
//!   | Hello{protocol, client_nonce}   (session 0, PSK tag)    |
//!   |-------------------------------------------------------->|  pending session P (the
//!   |   HelloAck{info, client_nonce, robot_nonce} (id P, PSK) |  active one is untouched)
//!   |<--------------------------------------------------------|
//!   | K_s, P from (PSK, client_nonce, robot_nonce)            |
//!   | Session frame (id P, seq 1, K_s tag): Heartbeat …       |
//!   |-------------------------------------------------------->|  key confirmed: P becomes the
//!   |   Telemetry (id P, robot seq 1.., K_s tag)              |  active session; the previous
//!   |<--------------------------------------------------------|  operator gets SessionEnd
//! ```
//! `prk = HMAC(PSK, "omnikin-v2 session" | client_nonce | robot_nonce)`,
//! `K_s = HMAC(prk, "omnikin-v2 key")`, `P = HMAC(prk, "omnikin-v2 id")[..8]` (LE, never 0);
//! without a key the PSK is empty. The keyed MAC state of `K_s` is built once per session and
//! cloned per frame. Sequence numbers start at 1 in each direction of each session and pass a
//! 64-frame sliding window ([`ReplayWindow`]): a repeated or too-old `seq` is dropped
//! ([`LinkCounters::replay`]). A frame of another session — a recording of an old one, a guess
//! — is dropped ([`LinkCounters::session`]). One operator session at a time.
//!
//! Frames are at most [`MAX_FRAME`] bytes on the wire, delimiter included. Floats on the wire
//! are `f32` whatever the runtime's scalar type. Units and frames are those of
//! [`crate::runtime`]: SI, world or robot frame as each field says.
//!
//! ## Guarantees
//! * No allocation, no `unsafe`; decoding arbitrary bytes never panics (property-tested and
//!   fuzzed: `fuzz/`).
//! * Every byte sequence that is not a valid, authentic, fresh frame of this endpoint's
//!   session is dropped and lands in exactly one counter of [`LinkCounters`].

/// The fixed-capacity vector crate of [`Message::PlanChunk`] (re-exported so hosts build
/// chunks without depending on it themselves).
pub use heapless;
use hmac::{Hmac, Mac};
use serde::{Deserialize, Serialize};
use sha2::Sha256;

use crate::runtime::hal::{Entropy, EntropyError};
use crate::runtime::{Command, Faults, Frame, Mode, PlanPoint, PlanStatus, Runtime, Status};
use crate::{Pose2, Real, Twist2};

/// The protocol version sent first in every frame.
pub const PROTOCOL_VERSION: u8 = 2;
/// Bytes of the truncated HMAC-SHA256 tag.
pub const TAG_LEN: usize = 16;
/// Bytes of each handshake nonce.
pub const NONCE_LEN: usize = 16;
/// Plan points per [`Message::PlanChunk`].
pub const CHUNK_POINTS: usize = 8;
/// Header bytes: version, kind, session, seq.
pub const HEADER_LEN: usize = 18;
/// Largest postcard body, bytes.
pub const MAX_BODY: usize = 320;
/// Largest raw (un-stuffed) frame: header, body, tag, CRC.
pub const MAX_RAW: usize = HEADER_LEN + MAX_BODY + TAG_LEN + 4;
/// Largest frame on the wire, bytes, including the `0x00` delimiter.
pub const MAX_FRAME: usize = cobs_max_len(MAX_RAW) + 1;
/// Bit 7 of the kind byte: the frame carries a tag.
pub const KIND_TAGGED: u8 = 0x80;
/// Body bytes of a Hello (zero-padded) — the largest [`HelloAck`] body, so a robot's answer
/// is never larger than the Hello that asked for it (anti-amplification).
pub const HANDSHAKE_BODY: usize = 46;

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);

/// What a frame is (the low 7 bits of the kind byte).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Kind {
    /// Operator → robot: start a session ([`Hello`]).
    Hello = 1,
    /// Robot → operator: the answer to a Hello ([`HelloAck`]); `session` is the new id.
    HelloAck = 2,
    /// Either way: one [`Message`] of an established session.
    Session = 3,
}

impl Kind {
    fn from_u8(b: u8) -> Option<Self> {
        match b {
            1 => Some(Kind::Hello),
            2 => Some(Kind::HelloAck),
            3 => Some(Kind::Session),
            _ => None,
        }
    }
}
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
    /// To a runtime point (no validation: [`Runtime::handle`] validates).
    pub fn to_point<T: Real>(&self) -> PlanPoint<T> {
        let c = |x: f32| T::of(x as f64);
        PlanPoint {
            t: c(self.t),
            pose: Pose2::new(c(self.pose[0]), c(self.pose[1]), c(self.pose[2])),
            twist: Twist2::new(c(self.twist[0]), c(self.twist[1]), c(self.twist[2])),
        }
    }
}

/// Which robot model a runtime drives (in [`RobotInfo`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum RobotKind {
    /// `sphere-omni`.
    Sphere,
    /// `ballbot`.
    Ballbot,
    /// `caster3`.
    Caster,
    /// `omni` (N omni/mecanum wheels).
    Omni,
    /// `swerve` (N centred steerable modules).
    Swerve,
}

impl RobotKind {
    /// The wire name of a robot kind.
    pub fn of(kind: crate::Kind) -> Self {
        match kind {
            crate::Kind::Sphere => RobotKind::Sphere,
            crate::Kind::Ballbot => RobotKind::Ballbot,
            crate::Kind::Caster => RobotKind::Caster,
            crate::Kind::Omni => RobotKind::Omni,
            crate::Kind::Swerve => RobotKind::Swerve,
        }
    }

    /// The robot kind of a wire name.
    pub fn kind(self) -> crate::Kind {
        match self {
            RobotKind::Sphere => crate::Kind::Sphere,
            RobotKind::Ballbot => crate::Kind::Ballbot,
            RobotKind::Caster => crate::Kind::Caster,
            RobotKind::Omni => crate::Kind::Omni,
            RobotKind::Swerve => crate::Kind::Swerve,
        }
    }
}

/// Who the robot is, in its answer to a Hello ([`HelloAck`]; the same fields as in v1).
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
}

/// Link statistics: every dropped frame is counted in exactly one field.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkCounters {
    /// Frames accepted (decoded, authentic, fresh).
    pub ok: u32,
    /// Dropped: COBS error, too long, too short, or cut off (truncated) at the end of a
    /// datagram.
    pub framing: u32,
    /// Dropped: CRC mismatch.
    pub crc: u32,
    /// Dropped: other protocol version.
    pub version: u32,
    /// Dropped: missing or wrong authentication tag.
    pub auth: u32,
    /// Dropped: repeated or too-old sequence number (duplicate or replay), a repeat of the
    /// Hello that opened the active session, or a repeated answer to this operator's Hello.
    pub replay: u32,
    /// Dropped: body is not a valid message (postcard error, trailing bytes, unknown kind,
    /// unpadded Hello, a frame meant for the other end).
    pub malformed: u32,
    /// Dropped: a frame of a session that is not this endpoint's (a recording of an old
    /// session, a guessed id, a frame from before a restart) or an answer to a Hello this
    /// endpoint did not send.
    pub session: u32,
    /// Dropped: a Hello that could not be answered because the entropy source failed.
    pub entropy: u32,
}

impl LinkCounters {
    /// Total frames dropped.
    pub fn dropped(&self) -> u32 {
        self.framing
            .saturating_add(self.crc)
            .saturating_add(self.version)
            .saturating_add(self.auth)
            .saturating_add(self.replay)
            .saturating_add(self.malformed)
            .saturating_add(self.session)
            .saturating_add(self.entropy)
    }
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
    /// Commanded wheel rates, rad/s.
    pub wheel_rates: [f32; 3],
    /// Commanded caster steer rates, rad/s (zeros otherwise).
    pub steer_rates: [f32; 3],
    /// Encoder wheel angles, rad.
    pub wheel_angles: [f32; 3],
    /// Caster steer angles, rad (zeros otherwise).
    pub steer_angles: [f32; 3],
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
    /// Caster slip residual, m/s.
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
}

impl Telemetry {
    /// Telemetry from a runtime status and the link counters (`ack_seq`, `estop_seq` zero:
    /// [`RobotLink::telemetry`] fills them in).
    pub fn new<T: Real>(s: &Status<T>, link: &LinkCounters) -> Self {
        let f = |x: T| x.to_f64() as f32;
        let p = |p: Pose2<T>| [f(p.x), f(p.y), f(p.heading)];
        let w = |t: Twist2<T>| [f(t.vx), f(t.vy), f(t.yaw_rate)];
        let a = |x: [T; 3]| x.map(f);
        let imu = s.imu;
        Self {
            time_us: s.time_us,
            mode: s.mode,
            faults: s.faults,
            fault_history: s.fault_history,
            pose: p(s.pose),
            twist: w(s.twist),
            command: w(s.command),
            wheel_rates: a(s.motors.wheel),
            steer_rates: a(s.motors.steer),
            wheel_angles: a(s.encoders.wheel),
            steer_angles: a(s.encoders.steer),
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
        }
    }
}

/// Why a session ended ([`Message::SessionEnd`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum EndReason {
    /// Another operator completed a handshake and took over.
    TakenOver,
}

/// Every message of a session (the body of a [`Kind::Session`] frame). Operator → robot:
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
}

/// The body of a [`Kind::Hello`] frame (then zero padding up to [`HANDSHAKE_BODY`] bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Hello {
    /// The operator's protocol version.
    pub protocol: u8,
    /// Fresh random bytes of the operator, echoed by the robot.
    pub client_nonce: [u8; NONCE_LEN],
}

/// The body of a [`Kind::HelloAck`] frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HelloAck {
    /// Who the robot is.
    pub info: RobotInfo,
    /// The Hello's nonce (binds the answer to that Hello).
    pub client_nonce: [u8; NONCE_LEN],
    /// Fresh random bytes of the robot (make the session new even for a replayed Hello).
    pub robot_nonce: [u8; NONCE_LEN],
}

impl Message {
    /// The runtime command of an operator message (`None` for `Telemetry` and `SessionEnd`).
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
            Message::Telemetry(_) | Message::SessionEnd(_) => return None,
        })
    }
}

/// An HMAC-SHA256 key with its key schedule done once: each tag clones the keyed state
/// (inner and outer hash primed with the padded key) instead of hashing the key again.
#[derive(Clone)]
pub struct MacKey {
    mac: Hmac<Sha256>,
}

impl core::fmt::Debug for MacKey {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("MacKey(..)")
    }
}

impl MacKey {
    /// The keyed state of `key` (any length; HMAC hashes keys longer than 64 bytes).
    pub fn new(key: &[u8]) -> Self {
        let mac = match Hmac::<Sha256>::new_from_slice(key) {
            Ok(m) => m,
            // Unreachable: HMAC takes keys of any length.
            Err(_) => <Hmac<Sha256> as hmac::digest::KeyInit>::new(&Default::default()),
        };
        Self { mac }
    }

    /// The full 32-byte HMAC of the concatenation of `parts`.
    pub fn full(&self, parts: &[&[u8]]) -> [u8; 32] {
        let mut m = self.mac.clone();
        for p in parts {
            m.update(p);
        }
        m.finalize().into_bytes().into()
    }

    /// The [`TAG_LEN`]-byte tag of `data`.
    pub fn tag(&self, data: &[u8]) -> [u8; TAG_LEN] {
        let full = self.full(&[data]);
        let mut out = [0u8; TAG_LEN];
        out.copy_from_slice(&full[..TAG_LEN]);
        out
    }
}

/// A pre-shared key (PSK, 1–64 bytes; use at least 16 random bytes), kept as its keyed MAC
/// state.
#[derive(Clone)]
pub struct Key {
    mac: MacKey,
    len: usize,
}

impl core::fmt::Debug for Key {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "Key({} bytes)", self.len)
    }
}

/// A key of the wrong length.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("key must be 1 to 64 bytes (got {len})")]
pub struct KeyError {
    /// The length given.
    pub len: usize,
}

impl Key {
    /// A key from its bytes.
    ///
    /// # Errors
    /// [`KeyError`] when `bytes` is empty or longer than 64 bytes.
    pub fn new(bytes: &[u8]) -> Result<Self, KeyError> {
        if bytes.is_empty() || bytes.len() > 64 {
            return Err(KeyError { len: bytes.len() });
        }
        Ok(Self {
            mac: MacKey::new(bytes),
            len: bytes.len(),
        })
    }

    /// The keyed MAC state of the PSK (tags of handshake frames).
    pub fn mac(&self) -> &MacKey {
        &self.mac
    }
}

/// Sliding-window replay filter over 64-bit sequence numbers (RFC 4303 style, 64 frames).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReplayWindow {
    top: u64,
    bits: u64,
}

impl ReplayWindow {
    /// `true` if `seq` is fresh: above the highest seen, or within the 64 below it and not yet
    /// seen. `seq = 0` is never fresh.
    pub fn is_fresh(&self, seq: u64) -> bool {
        if seq == 0 {
            return false;
        }
        if seq > self.top {
            return true;
        }
        let back = self.top - seq;
        back < 64 && self.bits & (1u64 << back) == 0
    }

    /// Records `seq` as seen (call only after [`ReplayWindow::is_fresh`] and authentication).
    pub fn accept(&mut self, seq: u64) {
        if seq > self.top {
            let shift = seq - self.top;
            self.bits = if shift >= 64 { 0 } else { self.bits << shift };
            self.bits |= 1;
            self.top = seq;
        } else {
            let back = self.top - seq;
            if back < 64 {
                self.bits |= 1u64 << back;
            }
        }
    }

    /// Highest sequence number accepted so far (0: none).
    pub fn top(&self) -> u64 {
        self.top
    }
}

/// Why a frame was not sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    /// The message does not fit [`MAX_BODY`] or the output buffer.
    #[error("message too large for one frame")]
    TooLarge,
    /// No established session to send it in (handshake first).
    #[error("no session: the handshake has not completed")]
    NoSession,
    /// The entropy source failed while making a nonce.
    #[error("the entropy source failed")]
    Entropy,
}

impl From<EntropyError> for EncodeError {
    fn from(_: EntropyError) -> Self {
        EncodeError::Entropy
    }
}

/// Why a frame was dropped (each maps to one [`LinkCounters`] field).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DropReason {
    /// COBS error, wrong length, or truncated.
    #[error("framing error")]
    Framing,
    /// CRC mismatch.
    #[error("CRC mismatch")]
    Crc,
    /// Other protocol version.
    #[error("protocol version {0}, expected {PROTOCOL_VERSION}")]
    Version(u8),
    /// Missing, unexpected or wrong tag.
    #[error("not authenticated")]
    Auth,
    /// Repeated or too-old sequence number.
    #[error("replayed or duplicate sequence number {0}")]
    Replay(u64),
    /// Body not a valid message, or a frame kind this end does not take.
    #[error("malformed message")]
    Malformed,
    /// A frame of a session that is not this endpoint's.
    #[error("frame of another session ({0:#018x})")]
    Session(u64),
    /// A Hello that could not be answered: no entropy.
    #[error("no entropy to answer a hello")]
    Entropy,
}

impl LinkCounters {
    fn count<T>(&mut self, r: &Result<T, DropReason>) {
        let slot = match r {
            Ok(_) => &mut self.ok,
            Err(DropReason::Framing) => &mut self.framing,
            Err(DropReason::Crc) => &mut self.crc,
            Err(DropReason::Version(_)) => &mut self.version,
            Err(DropReason::Auth) => &mut self.auth,
            Err(DropReason::Replay(_)) => &mut self.replay,
            Err(DropReason::Malformed) => &mut self.malformed,
            Err(DropReason::Session(_)) => &mut self.session,
            Err(DropReason::Entropy) => &mut self.entropy,
        };
        *slot = slot.saturating_add(1);
    }
}

/// The fixed fields of a v2 frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Frame kind.
    pub kind: Kind,
    /// Session id (0 in a Hello).
    pub session: u64,
    /// Sequence number (0 in handshake frames).
    pub seq: u64,
    /// Whether a tag follows the body.
    pub tagged: bool,
}

/// A frame whose COBS, length, CRC and version checked out; tag not yet verified.
#[derive(Clone, Copy, Debug)]
pub struct Parsed<'a> {
    /// The header.
    pub header: Header,
    /// The body bytes.
    pub body: &'a [u8],
    signed: &'a [u8],
    tag: &'a [u8],
}

fn ct_eq(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

impl Parsed<'_> {
    /// Checks the tag: with `mac`, the frame must carry a valid tag under it; without, it must
    /// carry none.
    ///
    /// # Errors
    /// [`DropReason::Auth`].
    pub fn verify(&self, mac: Option<&MacKey>) -> Result<(), DropReason> {
        match (mac, self.header.tagged) {
            (None, false) => Ok(()),
            (Some(m), true) if ct_eq(&m.tag(self.signed), self.tag) => Ok(()),
            _ => Err(DropReason::Auth),
        }
    }
}

/// Decodes one frame's envelope (the bytes between two delimiters, without them; COBS-decoded
/// in place): length, COBS, CRC, version, kind. Never panics on any input.
///
/// # Errors
/// [`DropReason::Framing`], [`DropReason::Crc`], [`DropReason::Version`],
/// [`DropReason::Malformed`] (unknown kind).
pub fn parse_frame(frame: &mut [u8]) -> Result<Parsed<'_>, DropReason> {
    if frame.is_empty() || frame.len() > MAX_FRAME {
        return Err(DropReason::Framing);
    }
    let n = cobs_decode_in_place(frame).ok_or(DropReason::Framing)?;
    let raw = frame.get(..n).ok_or(DropReason::Framing)?;
    // The shortest frame of any version: v1's 10-byte header, a 1-byte body and the CRC.
    if n < 15 {
        return Err(DropReason::Framing);
    }
    let (data, crc) = raw.split_at(n - 4);
    let crc = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
    if CRC.checksum(data) != crc {
        return Err(DropReason::Crc);
    }
    if data[0] != PROTOCOL_VERSION {
        return Err(DropReason::Version(data[0]));
    }
    if data.len() < HEADER_LEN + 1 {
        return Err(DropReason::Framing);
    }
    let kind = Kind::from_u8(data[1] & !KIND_TAGGED).ok_or(DropReason::Malformed)?;
    let tagged = data[1] & KIND_TAGGED != 0;
    let u64_at = |i: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&data[i..i + 8]);
        u64::from_le_bytes(b)
    };
    let header = Header {
        kind,
        session: u64_at(2),
        seq: u64_at(10),
        tagged,
    };
    let end = if tagged {
        if data.len() < HEADER_LEN + TAG_LEN + 1 {
            return Err(DropReason::Framing);
        }
        data.len() - TAG_LEN
    } else {
        data.len()
    };
    Ok(Parsed {
        header,
        body: &data[HEADER_LEN..end],
        signed: &data[..end],
        tag: &data[end..],
    })
}

/// Encodes one v2 frame: `header` (its `tagged` is taken from `mac`), then the body that
/// `body` writes into the slice it is given (returning its length), the tag under `mac` and
/// the CRC; COBS-stuffed and `0x00`-terminated into `out`. Returns the bytes written.
///
/// # Errors
/// [`EncodeError::TooLarge`] when the body exceeds [`MAX_BODY`] or `out` is too small.
pub fn encode_frame_with(
    kind: Kind,
    session: u64,
    seq: u64,
    mac: Option<&MacKey>,
    body: impl FnOnce(&mut [u8]) -> Result<usize, EncodeError>,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let mut raw = [0u8; MAX_RAW];
    raw[0] = PROTOCOL_VERSION;
    raw[1] = kind as u8 | if mac.is_some() { KIND_TAGGED } else { 0 };
    raw[2..10].copy_from_slice(&session.to_le_bytes());
    raw[10..HEADER_LEN].copy_from_slice(&seq.to_le_bytes());
    let body_len = body(&mut raw[HEADER_LEN..HEADER_LEN + MAX_BODY])?;
    if body_len > MAX_BODY {
        return Err(EncodeError::TooLarge);
    }
    let mut n = HEADER_LEN + body_len;
    if let Some(m) = mac {
        let tag = m.tag(&raw[..n]);
        raw[n..n + TAG_LEN].copy_from_slice(&tag);
        n += TAG_LEN;
    }
    stuff(&mut raw, n, out)
}

/// CRC over `raw[..n]`, appended; COBS into `out` with the delimiter.
fn stuff(raw: &mut [u8; MAX_RAW], n: usize, out: &mut [u8]) -> Result<usize, EncodeError> {
    let crc = CRC.checksum(&raw[..n]);
    raw[n..n + 4].copy_from_slice(&crc.to_le_bytes());
    let n = n + 4;
    if out.len() < cobs_max_len(n) + 1 {
        return Err(EncodeError::TooLarge);
    }
    let m = cobs_encode(&raw[..n], out).ok_or(EncodeError::TooLarge)?;
    out[m] = 0;
    Ok(m + 1)
}

/// COBS-decodes `buf` in place (one frame, without its delimiter); returns the decoded length,
/// or `None` for a zero byte or a block running past the end. A byte loop without the `cobs`
/// crate's per-byte state machine (the link's hottest code: see `bench/instructions.sh
/// link-open`); property-tested against the `cobs` crate in both directions.
pub fn cobs_decode_in_place(buf: &mut [u8]) -> Option<usize> {
    let n = buf.len();
    let (mut r, mut w) = (0usize, 0usize);
    while r < n {
        let code = buf[r] as usize;
        if code == 0 {
            return None;
        }
        let end = r + code;
        if end > n {
            return None;
        }
        r += 1;
        while r < end {
            let b = buf[r];
            if b == 0 {
                return None;
            }
            buf[w] = b;
            w += 1;
            r += 1;
        }
        if code != 0xFF && r < n {
            buf[w] = 0;
            w += 1;
        }
    }
    Some(w)
}

/// COBS-encodes `src` into `out` (no delimiter); returns the encoded length, or `None` when
/// `out` is shorter than [`cobs_max_len`]`(src.len())`.
pub fn cobs_encode(src: &[u8], out: &mut [u8]) -> Option<usize> {
    if out.len() < cobs_max_len(src.len()) {
        return None;
    }
    let (mut code_at, mut w, mut code) = (0usize, 1usize, 1u8);
    for &b in src {
        if b == 0 {
            out[code_at] = code;
            code_at = w;
            w += 1;
            code = 1;
        } else {
            out[w] = b;
            w += 1;
            code += 1;
            if code == 0xFF {
                out[code_at] = code;
                code_at = w;
                w += 1;
                code = 1;
            }
        }
    }
    out[code_at] = code;
    Some(w)
}

/// The longest COBS encoding of `n` bytes: one code byte per started 254-byte block, plus one.
pub const fn cobs_max_len(n: usize) -> usize {
    n + n / 254 + 1
}

fn postcard_body<S: Serialize>(v: &S) -> impl FnOnce(&mut [u8]) -> Result<usize, EncodeError> {
    move |b| {
        postcard::to_slice(v, b)
            .map(|s| s.len())
            .map_err(|_| EncodeError::TooLarge)
    }
}

/// Encodes a session frame carrying `msg` (stateless; [`RobotLink::encode`] and
/// [`OperatorLink::encode`] are the usual way).
///
/// # Errors
/// [`EncodeError::TooLarge`].
pub fn encode_message(
    session: u64,
    seq: u64,
    msg: &Message,
    mac: Option<&MacKey>,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    encode_frame_with(Kind::Session, session, seq, mac, postcard_body(msg), out)
}

/// Encodes a Hello (zero-padded to [`HANDSHAKE_BODY`] bytes), tagged with the PSK if given.
///
/// # Errors
/// [`EncodeError::TooLarge`] when `out` is too small.
pub fn encode_hello(
    hello: &Hello,
    psk: Option<&Key>,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let body = |b: &mut [u8]| {
        let n = postcard::to_slice(hello, b)
            .map_err(|_| EncodeError::TooLarge)?
            .len();
        // `b` is zeroed: the padding is already there.
        Ok(n.max(HANDSHAKE_BODY))
    };
    encode_frame_with(Kind::Hello, 0, 0, psk.map(Key::mac), body, out)
}

/// Decodes a message body (no trailing bytes).
///
/// # Errors
/// [`DropReason::Malformed`].
pub fn decode_message(body: &[u8]) -> Result<Message, DropReason> {
    match postcard::take_from_bytes::<Message>(body) {
        Ok((m, [])) => Ok(m),
        _ => Err(DropReason::Malformed),
    }
}

fn decode_hello(body: &[u8]) -> Result<Hello, DropReason> {
    if body.len() < HANDSHAKE_BODY {
        // Unpadded: answering it could amplify.
        return Err(DropReason::Malformed);
    }
    match postcard::take_from_bytes::<Hello>(body) {
        Ok((h, rest)) if rest.iter().all(|&b| b == 0) => Ok(h),
        _ => Err(DropReason::Malformed),
    }
}

/// One direction-pair of an established session: its id, MAC key, outgoing sequence numbers
/// and incoming replay window.
#[derive(Clone, Debug)]
struct Session {
    id: u64,
    mac: Option<MacKey>,
    tx_seq: u64,
    window: ReplayWindow,
}

impl Session {
    /// The session id and key `K_s` of a handshake.
    fn derive(
        psk: Option<&Key>,
        client: &[u8; NONCE_LEN],
        robot: &[u8; NONCE_LEN],
    ) -> (u64, [u8; 32]) {
        let empty;
        let base = match psk {
            Some(k) => &k.mac,
            None => {
                empty = MacKey::new(&[]);
                &empty
            }
        };
        let prk = MacKey::new(&base.full(&[b"omnikin-v2 session", client, robot]));
        let ks = prk.full(&[b"omnikin-v2 key"]);
        let idb = prk.full(&[b"omnikin-v2 id"]);
        let mut id = [0u8; 8];
        id.copy_from_slice(&idb[..8]);
        (u64::from_le_bytes(id).max(1), ks)
    }

    /// A fresh session (keyed MAC state built here, once).
    fn new(id: u64, ks: &[u8; 32], keyed: bool) -> Self {
        Session {
            id,
            mac: keyed.then(|| MacKey::new(ks)),
            tx_seq: 1,
            window: ReplayWindow::default(),
        }
    }

    fn encode(&mut self, msg: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
        let n = encode_message(self.id, self.tx_seq, msg, self.mac.as_ref(), out)?;
        self.tx_seq = self.tx_seq.saturating_add(1);
        Ok(n)
    }

    /// Verifies, checks freshness and decodes a frame of this session; `to_robot` says which
    /// end is receiving. Both directions share `K_s`, so a message for the other end (a
    /// robot's own telemetry reflected back to it, an operator's command sent back to the
    /// operator) carries a valid tag: it is dropped as malformed before it can move the
    /// replay window (which would lock out the peer's lower sequence numbers) or `ack_seq`.
    fn open(&mut self, p: &Parsed<'_>, to_robot: bool) -> Result<(u64, Message), DropReason> {
        p.verify(self.mac.as_ref())?;
        let seq = p.header.seq;
        if !self.window.is_fresh(seq) {
            return Err(DropReason::Replay(seq));
        }
        let msg = decode_message(p.body)?;
        let for_robot = !matches!(msg, Message::Telemetry(_) | Message::SessionEnd(_));
        if for_robot != to_robot {
            return Err(DropReason::Malformed);
        }
        self.window.accept(seq);
        Ok((seq, msg))
    }
}

/// A handshake waiting for its key confirmation: id and `K_s` only (the keyed MAC state is
/// built when a frame claims the id), so the pending slots stay small.
#[derive(Clone, Debug)]
struct Pending {
    id: u64,
    ks: [u8; 32],
    client_nonce: [u8; NONCE_LEN],
    robot_nonce: [u8; NONCE_LEN],
}

/// What [`RobotLink::receive`] got.
// No heap in the core: the large variant is a value, not a Box.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum RobotEvent {
    /// A valid Hello: `reply[..n]` holds the HelloAck for its sender (never larger than the
    /// Hello). The active session is untouched; the new one is pending until its operator's
    /// first session frame verifies.
    Hello(usize),
    /// A message of the active session.
    Message {
        /// Its sequence number.
        seq: u64,
        /// The message.
        msg: Message,
        /// This frame confirmed a new session, which is now the active one.
        new_session: bool,
        /// The new session took over from another: `reply[..n]` holds the previous operator's
        /// [`Message::SessionEnd`], to be sent to that operator's address.
        replaced: Option<usize>,
    },
}

/// Handshakes a robot keeps pending at once: a legitimate handshake completes unless this many
/// other Hellos (a flood of spoofed or replayed ones) arrive within its round trip.
pub const PENDING_SLOTS: usize = 4;

/// The robot's end of the link: the active session, up to [`PENDING_SLOTS`] pending ones, the
/// counters.
#[derive(Clone, Debug)]
pub struct RobotLink {
    key: Option<Key>,
    active: Option<Session>,
    /// The client nonce of the Hello that opened the active session.
    active_nonce: [u8; NONCE_LEN],
    pending: [Option<Pending>; PENDING_SLOTS],
    /// Hellos answered, and the count at which each slot was filled (the oldest is replaced).
    hellos: u64,
    pending_since: [u64; PENDING_SLOTS],
    counters: LinkCounters,
    ack_seq: u64,
    estop_seq: u64,
    v1_seq: u64,
}

impl RobotLink {
    /// A robot end with an optional pre-shared key.
    pub fn new(key: Option<Key>) -> Self {
        Self {
            key,
            active: None,
            active_nonce: [0; NONCE_LEN],
            pending: [const { None }; PENDING_SLOTS],
            hellos: 0,
            pending_since: [0; PENDING_SLOTS],
            counters: LinkCounters::default(),
            ack_seq: 0,
            estop_seq: 0,
            v1_seq: 1,
        }
    }

    /// Receive statistics.
    pub fn counters(&self) -> &LinkCounters {
        &self.counters
    }

    /// Whether a key is configured.
    pub fn authenticated(&self) -> bool {
        self.key.is_some()
    }

    /// The active session's id, if any.
    pub fn session_id(&self) -> Option<u64> {
        self.active.as_ref().map(|s| s.id)
    }

    /// The newest pending (handshaken, not yet confirmed) session's id, if any.
    pub fn pending_id(&self) -> Option<u64> {
        (0..PENDING_SLOTS)
            .filter(|&i| self.pending[i].is_some())
            .max_by_key(|&i| self.pending_since[i])
            .and_then(|i| self.pending[i].as_ref().map(|p| p.id))
    }

    /// Counts a frame dropped before decoding (cut off at the end of a datagram, or longer
    /// than the receive buffer).
    pub fn count_framing_drop(&mut self) {
        self.counters.framing = self.counters.framing.saturating_add(1);
    }

    /// Decodes one frame (the bytes between two delimiters, without them; decoded in place)
    /// and runs the session logic; `info` goes into a HelloAck, `rng` makes its nonce, `reply`
    /// (at least [`MAX_FRAME`] bytes) receives the frame to send back, if any (see
    /// [`RobotEvent`]). Counts the frame in exactly one counter. A repeat of a pending Hello
    /// (a retransmission after a lost HelloAck, a duplicate) is answered again with the same
    /// answer and counts as `ok` (it is not dropped); a repeat of the Hello that opened the
    /// active session is dropped as a replay, unanswered.
    ///
    /// # Errors
    /// [`DropReason`]: the frame was dropped and must not be acted upon.
    pub fn receive(
        &mut self,
        frame: &mut [u8],
        info: &RobotInfo,
        rng: &mut impl Entropy,
        reply: &mut [u8],
    ) -> Result<RobotEvent, DropReason> {
        let r = self.receive_inner(frame, info, rng, reply);
        self.counters.count(&r);
        r
    }

    fn receive_inner(
        &mut self,
        frame: &mut [u8],
        info: &RobotInfo,
        rng: &mut impl Entropy,
        reply: &mut [u8],
    ) -> Result<RobotEvent, DropReason> {
        let received = frame.len();
        let p = parse_frame(frame)?;
        match p.header.kind {
            Kind::Hello => {
                p.verify(self.key.as_ref().map(Key::mac))?;
                if p.header.session != 0 || p.header.seq != 0 {
                    return Err(DropReason::Malformed);
                }
                let hello = decode_hello(p.body)?;
                if hello.protocol != PROTOCOL_VERSION {
                    return Err(DropReason::Version(hello.protocol));
                }
                if self.active.is_some() && hello.client_nonce == self.active_nonce {
                    return Err(DropReason::Replay(0));
                }
                // A retransmitted Hello gets the same answer (the same pending session);
                // another Hello takes a free slot, or replaces the oldest pending one.
                let same = self.pending.iter().position(|p| {
                    p.as_ref()
                        .is_some_and(|p| p.client_nonce == hello.client_nonce)
                });
                let (slot, robot_nonce) = match same {
                    Some(i) => (
                        i,
                        self.pending[i]
                            .as_ref()
                            .map_or([0; NONCE_LEN], |p| p.robot_nonce),
                    ),
                    None => {
                        let mut rn = [0u8; NONCE_LEN];
                        rng.fill(&mut rn).map_err(|_| DropReason::Entropy)?;
                        let free = self.pending.iter().position(Option::is_none);
                        let oldest = (0..PENDING_SLOTS)
                            .min_by_key(|&i| self.pending_since[i])
                            .unwrap_or(0);
                        (free.unwrap_or(oldest), rn)
                    }
                };
                let (id, ks) =
                    Session::derive(self.key.as_ref(), &hello.client_nonce, &robot_nonce);
                let ack = HelloAck {
                    info: *info,
                    client_nonce: hello.client_nonce,
                    robot_nonce,
                };
                let n = encode_frame_with(
                    Kind::HelloAck,
                    id,
                    0,
                    self.key.as_ref().map(Key::mac),
                    postcard_body(&ack),
                    reply,
                )
                .map_err(|_| DropReason::Malformed)?;
                // Anti-amplification, by construction (the Hello is padded) and checked.
                if n - 1 > received {
                    return Err(DropReason::Malformed);
                }
                if same.is_none() {
                    self.hellos += 1;
                    self.pending_since[slot] = self.hellos;
                }
                self.pending[slot] = Some(Pending {
                    id,
                    ks,
                    client_nonce: hello.client_nonce,
                    robot_nonce,
                });
                Ok(RobotEvent::Hello(n))
            }
            Kind::HelloAck => Err(DropReason::Malformed),
            Kind::Session => {
                let id = p.header.session;
                if let Some(a) = self.active.as_mut().filter(|a| a.id == id) {
                    let (seq, msg) = a.open(&p, true)?;
                    self.ack_seq = self.ack_seq.max(seq);
                    return Ok(RobotEvent::Message {
                        seq,
                        msg,
                        new_session: false,
                        replaced: None,
                    });
                }
                let Some(slot) = self
                    .pending
                    .iter()
                    .position(|pd| pd.as_ref().is_some_and(|pd| pd.id == id))
                else {
                    return Err(DropReason::Session(id));
                };
                // Key confirmation: the new operator proved it holds K_s.
                let Some(pd) = self.pending[slot].as_ref() else {
                    return Err(DropReason::Session(id));
                };
                let mut session = Session::new(id, &pd.ks, self.key.is_some());
                let (seq, msg) = session.open(&p, true)?;
                // The other pending handshakes stay (they may still confirm and take over).
                if let Some(pd) = self.pending[slot].take() {
                    self.active_nonce = pd.client_nonce;
                }
                let new = Some(session);
                let replaced = match self.active.take() {
                    Some(mut old) => old
                        .encode(&Message::SessionEnd(EndReason::TakenOver), reply)
                        .ok(),
                    None => None,
                };
                self.active = new;
                self.ack_seq = seq;
                self.estop_seq = 0;
                Ok(RobotEvent::Message {
                    seq,
                    msg,
                    new_session: true,
                    replaced,
                })
            }
        }
    }

    /// Records what the runtime did with message `seq` of the active session (for the
    /// telemetry's `estop_seq`). [`serve`] calls it.
    pub fn note(&mut self, seq: u64, msg: &Message, accepted: bool) {
        match msg {
            Message::EStop if accepted => self.estop_seq = seq,
            Message::Clear if accepted => self.estop_seq = 0,
            _ => {}
        }
    }

    /// Telemetry for the active session: the status, the counters, `ack_seq` and `estop_seq`
    /// (the latter 0 unless the runtime is in e-stop).
    pub fn telemetry<T: Real>(&self, s: &Status<T>) -> Telemetry {
        let mut t = Telemetry::new(s, &self.counters);
        t.ack_seq = self.ack_seq;
        t.estop_seq = if s.mode == Mode::EStop {
            self.estop_seq
        } else {
            0
        };
        t
    }

    /// Encodes `msg` (telemetry) in the active session into `out` (at least [`MAX_FRAME`]
    /// bytes); returns the bytes written, delimiter included.
    ///
    /// # Errors
    /// [`EncodeError::NoSession`] before any session is confirmed, [`EncodeError::TooLarge`].
    pub fn encode(&mut self, msg: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
        match self.active.as_mut() {
            Some(s) => s.encode(msg, out),
            None => Err(EncodeError::NoSession),
        }
    }

    /// The answer to a frame of protocol v1 ([`DropReason::Version`]`(1)`): a v1 HelloAck that
    /// says `protocol: 2`, tagged the v1 way with the PSK, so a v1 operator prints "robot
    /// speaks protocol version 2". The caller bounds how often it is sent (it is larger than
    /// the smallest v1 frame: send it only within the sender's anti-amplification budget).
    ///
    /// # Errors
    /// [`EncodeError::TooLarge`] when `out` is too small.
    pub fn version_reply(
        &mut self,
        info: &RobotInfo,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let mut i = *info;
        i.protocol = PROTOCOL_VERSION;
        let n = v1::encode_hello_ack(&i, self.v1_seq, self.key.as_ref(), out)?;
        self.v1_seq = self.v1_seq.saturating_add(1);
        Ok(n)
    }
}

/// What [`OperatorLink::receive`] got.
// No heap in the core: the large variant is a value, not a Box.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum OperatorEvent {
    /// The robot answered this operator's Hello: the session is established (the robot takes
    /// it over once the first session frame reaches it).
    Established(RobotInfo),
    /// A message of this operator's session.
    Message {
        /// Its sequence number.
        seq: u64,
        /// The message.
        msg: Message,
    },
}

// No heap in the core: the large variant is a value, not a Box.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum OpState {
    Idle,
    Handshaking([u8; NONCE_LEN]),
    Established {
        session: Session,
        client_nonce: [u8; NONCE_LEN],
        info: RobotInfo,
    },
}

/// The operator's end of the link: its handshake and its one session.
#[derive(Clone, Debug)]
pub struct OperatorLink {
    key: Option<Key>,
    state: OpState,
    ended: Option<EndReason>,
    counters: LinkCounters,
}

impl OperatorLink {
    /// An operator end with an optional pre-shared key.
    pub fn new(key: Option<Key>) -> Self {
        Self {
            key,
            state: OpState::Idle,
            ended: None,
            counters: LinkCounters::default(),
        }
    }

    /// Receive statistics.
    pub fn counters(&self) -> &LinkCounters {
        &self.counters
    }

    /// The session id once established.
    pub fn session_id(&self) -> Option<u64> {
        match &self.state {
            OpState::Established { session, .. } => Some(session.id),
            _ => None,
        }
    }

    /// The robot's answer to the handshake, once established.
    pub fn info(&self) -> Option<RobotInfo> {
        match &self.state {
            OpState::Established { info, .. } => Some(*info),
            _ => None,
        }
    }

    /// The sequence number the next session frame will carry (`None` before the handshake).
    pub fn next_seq(&self) -> Option<u64> {
        match &self.state {
            OpState::Established { session, .. } => Some(session.tx_seq),
            _ => None,
        }
    }

    /// Why the robot ended this session, if it did ([`Message::SessionEnd`]).
    pub fn ended(&self) -> Option<EndReason> {
        self.ended
    }

    /// Counts a frame dropped before decoding.
    pub fn count_framing_drop(&mut self) {
        self.counters.framing = self.counters.framing.saturating_add(1);
    }

    /// Encodes a Hello into `out`: a fresh nonce from `rng` for a new handshake, the same one
    /// for a retransmission while waiting for the answer. Returns the bytes written.
    ///
    /// # Errors
    /// [`EncodeError::Entropy`], [`EncodeError::TooLarge`].
    pub fn hello(&mut self, rng: &mut impl Entropy, out: &mut [u8]) -> Result<usize, EncodeError> {
        let nonce = match self.state {
            OpState::Handshaking(n) => n,
            _ => {
                let mut n = [0u8; NONCE_LEN];
                rng.fill(&mut n)?;
                self.state = OpState::Handshaking(n);
                self.ended = None;
                n
            }
        };
        let h = Hello {
            protocol: PROTOCOL_VERSION,
            client_nonce: nonce,
        };
        encode_hello(&h, self.key.as_ref(), out)
    }

    /// Encodes `msg` in this operator's session.
    ///
    /// # Errors
    /// [`EncodeError::NoSession`] before the handshake, [`EncodeError::TooLarge`].
    pub fn encode(&mut self, msg: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
        match &mut self.state {
            OpState::Established { session, .. } => session.encode(msg, out),
            _ => Err(EncodeError::NoSession),
        }
    }

    /// Decodes one frame (decoded in place): the answer to this operator's Hello, or a
    /// message of its session. Counts the frame in exactly one counter.
    ///
    /// # Errors
    /// [`DropReason`]: the frame was dropped.
    pub fn receive(&mut self, frame: &mut [u8]) -> Result<OperatorEvent, DropReason> {
        let r = self.receive_inner(frame);
        self.counters.count(&r);
        r
    }

    fn receive_inner(&mut self, frame: &mut [u8]) -> Result<OperatorEvent, DropReason> {
        let p = parse_frame(frame)?;
        match p.header.kind {
            Kind::Hello => Err(DropReason::Malformed),
            Kind::HelloAck => {
                p.verify(self.key.as_ref().map(Key::mac))?;
                let ack = match postcard::take_from_bytes::<HelloAck>(p.body) {
                    Ok((a, [])) => a,
                    _ => return Err(DropReason::Malformed),
                };
                match &self.state {
                    OpState::Handshaking(n) if *n == ack.client_nonce => {
                        let (id, ks) = Session::derive(self.key.as_ref(), n, &ack.robot_nonce);
                        if id != p.header.session {
                            return Err(DropReason::Session(p.header.session));
                        }
                        self.state = OpState::Established {
                            session: Session::new(id, &ks, self.key.is_some()),
                            client_nonce: *n,
                            info: ack.info,
                        };
                        Ok(OperatorEvent::Established(ack.info))
                    }
                    // A retransmitted answer to the Hello this session came from.
                    OpState::Established { client_nonce, .. }
                        if *client_nonce == ack.client_nonce =>
                    {
                        Err(DropReason::Replay(0))
                    }
                    _ => Err(DropReason::Session(p.header.session)),
                }
            }
            Kind::Session => match &mut self.state {
                OpState::Established { session, .. } if session.id == p.header.session => {
                    let (seq, msg) = session.open(&p, false)?;
                    if let Message::SessionEnd(r) = msg {
                        self.ended = Some(r);
                    }
                    Ok(OperatorEvent::Message { seq, msg })
                }
                _ => Err(DropReason::Session(p.header.session)),
            },
        }
    }
}

/// Splits a byte stream into frames at `0x00` delimiters, with a fixed buffer of `N` bytes
/// (use [`MAX_FRAME`]). Frames longer than `N` are discarded up to the next delimiter.
#[derive(Clone, Debug)]
pub struct FrameReader<const N: usize> {
    buf: [u8; N],
    len: usize,
    overflow: bool,
}

impl<const N: usize> Default for FrameReader<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameReader<N> {
    /// Empty.
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            overflow: false,
        }
    }

    /// Feeds `bytes`; for each complete frame calls `on_frame` with its bytes (without the
    /// delimiter, to hand to [`RobotLink::receive`] or [`OperatorLink::receive`]), or with
    /// `None` for a frame longer than the buffer (count it: `count_framing_drop`).
    pub fn feed(&mut self, bytes: &[u8], mut on_frame: impl FnMut(Option<&mut [u8]>)) {
        for &b in bytes {
            if b == 0 {
                if self.overflow {
                    on_frame(None);
                } else if self.len > 0 {
                    on_frame(Some(&mut self.buf[..self.len]));
                }
                self.len = 0;
                self.overflow = false;
            } else if self.len < N {
                self.buf[self.len] = b;
                self.len += 1;
            } else {
                self.overflow = true;
            }
        }
    }

    /// For message-oriented transports (UDP): a datagram ended; an unterminated partial frame
    /// is a truncated frame — discarded. Returns `true` if one was (count it:
    /// `count_framing_drop`).
    pub fn end_of_datagram(&mut self) -> bool {
        let dropped = self.len > 0 || self.overflow;
        self.len = 0;
        self.overflow = false;
        dropped
    }
}

/// What [`serve`] did with a message.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Served {
    /// Executed (or accepted) by the runtime.
    Accepted,
    /// The runtime rejected it (counted there).
    Rejected(crate::runtime::CommandError),
    /// Not a command (a robot → operator message); ignored.
    Ignored,
}

/// Who this runtime is, for the HelloAck.
pub fn robot_info<T: Real, const N: usize>(
    runtime: &Runtime<T, N>,
    authenticated: bool,
) -> RobotInfo {
    RobotInfo {
        protocol: PROTOCOL_VERSION,
        kind: RobotKind::of(runtime.robot().kind()),
        plan_capacity: N.min(u16::MAX as usize) as u16,
        rate_hz: runtime.config().rate_hz.to_f64() as f32,
        watchdog: runtime.config().watchdog.to_f64() as f32,
        authenticated,
    }
}

/// Robot side: hands message `seq` of the active session (from [`RobotEvent::Message`]) to the
/// runtime at clock time `now_us`, and records the outcome in `link` (e-stop confirmation).
pub fn serve<T: Real, const N: usize>(
    runtime: &mut Runtime<T, N>,
    link: &mut RobotLink,
    seq: u64,
    msg: &Message,
    now_us: u64,
) -> Served {
    let mut buf = [PlanPoint::zero(); CHUNK_POINTS];
    let Some(cmd) = msg.command(&mut buf) else {
        return Served::Ignored;
    };
    let r = runtime.handle(cmd, now_us);
    link.note(seq, msg, r.is_ok());
    match r {
        Ok(()) => Served::Accepted,
        Err(e) => Served::Rejected(e),
    }
}

/// Protocol v1 (`COBS(version=1 | flags | seq:u64 | body | tag[8] | crc32c)`), kept only so
/// that v1 and v2 peers tell each other apart: a v2 robot answers a v1 frame with a v1 HelloAck
/// saying `protocol: 2`; a v2 operator that gets no answer probes with a v1 Hello, so a v1
/// robot's HelloAck (`protocol: 1`) names the mismatch.
pub mod v1 {
    use super::{CRC, EncodeError, Key, MAX_RAW, RobotInfo, Serialize, stuff};
    use serde::Deserialize;

    /// The version byte of v1 frames.
    pub const VERSION: u8 = 1;
    const HEADER: usize = 10;
    const TAG: usize = 8;
    const FLAG_AUTH: u8 = 1;

    /// The first two variants of v1's `Message` (postcard writes the variant index first, so
    /// these encode and decode exactly as v1's `Hello` and `HelloAck`).
    #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
    pub enum Frame {
        /// v1 `Hello { protocol }`.
        Hello {
            /// The sender's protocol version.
            protocol: u8,
        },
        /// v1 `HelloAck(RobotInfo)`.
        HelloAck(RobotInfo),
    }

    fn encode(
        f: &Frame,
        seq: u64,
        key: Option<&Key>,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let mut raw = [0u8; MAX_RAW];
        raw[0] = VERSION;
        raw[1] = if key.is_some() { FLAG_AUTH } else { 0 };
        raw[2..HEADER].copy_from_slice(&seq.to_le_bytes());
        let body = postcard::to_slice(f, &mut raw[HEADER..HEADER + 64])
            .map_err(|_| EncodeError::TooLarge)?
            .len();
        let mut n = HEADER + body;
        if let Some(k) = key {
            let t = k.mac().tag(&raw[..n]);
            raw[n..n + TAG].copy_from_slice(&t[..TAG]);
            n += TAG;
        }
        stuff(&mut raw, n, out)
    }

    /// A v1 Hello as a v1 operator sends it.
    ///
    /// # Errors
    /// [`EncodeError::TooLarge`] when `out` is too small.
    pub fn encode_hello(seq: u64, key: Option<&Key>, out: &mut [u8]) -> Result<usize, EncodeError> {
        encode(&Frame::Hello { protocol: VERSION }, seq, key, out)
    }

    /// A v1 HelloAck carrying `info`.
    ///
    /// # Errors
    /// [`EncodeError::TooLarge`] when `out` is too small.
    pub fn encode_hello_ack(
        info: &RobotInfo,
        seq: u64,
        key: Option<&Key>,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        encode(&Frame::HelloAck(*info), seq, key, out)
    }

    /// Decodes a v1 Hello or HelloAck (the bytes between delimiters, decoded in place; the
    /// tag checked when `key` is given, as v1 did). `None` for anything else, never a panic.
    pub fn parse(frame: &mut [u8], key: Option<&Key>) -> Option<(u64, Frame)> {
        let n = super::cobs_decode_in_place(frame)?;
        let raw = frame.get(..n)?;
        if n < HEADER + 1 + 4 {
            return None;
        }
        let (data, crc) = raw.split_at(n - 4);
        if CRC.checksum(data).to_le_bytes() != crc[..4] || data[0] != VERSION {
            return None;
        }
        let mut s = [0u8; 8];
        s.copy_from_slice(&data[2..HEADER]);
        let mut end = data.len();
        if data[1] & FLAG_AUTH != 0 {
            end = end.checked_sub(TAG).filter(|&e| e > HEADER)?;
        }
        if let Some(k) = key {
            let t = k.mac().tag(&data[..end]);
            if data[1] & FLAG_AUTH == 0 || !super::ct_eq(&t[..TAG], &data[end..end + TAG]) {
                return None;
            }
        }
        match postcard::take_from_bytes::<Frame>(&data[HEADER..end]) {
            Ok((f, [])) => Some((u64::from_le_bytes(s), f)),
            _ => None,
        }
    }
}
