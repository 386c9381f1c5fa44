//! # Operator link: the wire format between the PC and the robot
//!
//! Paper 000's operator sets motion commands on a PC and sends them over a wireless link to
//! the microcontroller. This module is that link's codec, the same on both ends, `no_std`, no
//! allocation, over **any byte stream** (UDP datagrams, a serial port, a radio modem).
//!
//! ## Frame format (protocol version [`PROTOCOL_VERSION`] = 1; stable)
//! ```text
//! COBS( version:u8 | flags:u8 | seq:u64 LE | body | tag[8] (if flags & AUTH) | crc32:u32 LE ) 0x00
//! ```
//! * **COBS** (consistent overhead byte stuffing) removes every `0x00` from the frame so a
//!   single `0x00` delimits frames; a receiver that joins mid-stream re-synchronises at the
//!   next delimiter.
//! * `version` is checked before anything else; a frame of another version is dropped and
//!   counted ([`LinkCounters::version`]).
//! * `seq` is the sender's sequence number, strictly increasing per sender. The receiver keeps
//!   a 64-frame sliding window ([`ReplayWindow`]): a repeated or too-old `seq` is dropped and
//!   counted ([`LinkCounters::replay`]) — duplicates from the network and replayed recordings
//!   alike. A sender must start above any `seq` it used before (the host tools use
//!   microseconds since the Unix epoch).
//! * `body` is one [`Message`] in **postcard** (serde's compact, varint-based format; the
//!   schema is this module's types, whose field order is part of the protocol).
//! * `tag` (optional): the first [`TAG_LEN`] = 8 bytes of HMAC-SHA256(key, version … body) with
//!   a shared key ([`Key`]). With a key configured, a frame without a valid tag is dropped and
//!   counted ([`LinkCounters::auth`]) and never executed.
//! * `crc32`: CRC-32C (Castagnoli, `CRC_32_ISCSI`) over everything before it; a corrupt frame
//!   is dropped and counted ([`LinkCounters::crc`]).
//!
//! Frames are at most [`MAX_FRAME`] bytes on the wire, delimiter included. Floats on the wire
//! are `f32` whatever the runtime's scalar type. Units and frames are those of
//! [`crate::runtime`]: SI, world or robot frame as each field says.
//!
//! ## Guarantees
//! * No allocation, no `unsafe`; decoding arbitrary bytes never panics (property-tested and
//!   fuzzed: `fuzz/`).
//! * Every byte sequence that is not a valid, authentic, fresh frame is dropped and lands in
//!   exactly one counter of [`LinkCounters`].

/// The fixed-capacity vector crate of [`Message::PlanChunk`] (re-exported so hosts build
/// chunks without depending on it themselves).
pub use heapless;
use hmac::{Hmac, Mac};
use serde::{Deserialize, Serialize};
use sha2::Sha256;

use crate::runtime::{Command, Faults, Frame, Mode, PlanPoint, PlanStatus, Runtime, Status};
use crate::{Pose2, Real, Twist2};

/// The protocol version sent in every frame.
pub const PROTOCOL_VERSION: u8 = 1;
/// Bytes of the truncated HMAC-SHA256 tag.
pub const TAG_LEN: usize = 8;
/// Plan points per [`Message::PlanChunk`].
pub const CHUNK_POINTS: usize = 8;
/// Header bytes: version, flags, seq.
pub const HEADER_LEN: usize = 10;
/// Largest postcard body, bytes.
pub const MAX_BODY: usize = 320;
/// Largest raw (un-stuffed) frame: header, body, tag, CRC.
pub const MAX_RAW: usize = HEADER_LEN + MAX_BODY + TAG_LEN + 4;
/// Largest frame on the wire, bytes, including the `0x00` delimiter.
pub const MAX_FRAME: usize = cobs::max_encoding_length(MAX_RAW) + 1;
/// Flag bit: the frame carries a tag.
pub const FLAG_AUTH: u8 = 1;

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);

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
}

/// The robot's answer to [`Message::Hello`].
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
    /// Dropped: repeated or too-old sequence number (duplicate or replay).
    pub replay: u32,
    /// Dropped: body is not a valid message (postcard error, trailing bytes).
    pub malformed: u32,
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
}

impl Telemetry {
    /// Telemetry from a runtime status and the link counters.
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
        }
    }
}

/// Every message of the protocol. Operator → robot: `Hello` … `SetPose`; robot → operator:
/// `HelloAck`, `Telemetry`. Variant order is part of the wire format.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Message {
    /// Session start; the robot answers [`Message::HelloAck`]. Carries the sender's version.
    Hello {
        /// The sender's protocol version.
        protocol: u8,
    },
    /// Robot's answer to `Hello`.
    HelloAck(RobotInfo),
    /// Keep-alive: feeds the watchdog.
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
}

impl Message {
    /// The runtime command of an operator message (`None` for `HelloAck` and `Telemetry`).
    /// Chunk points are converted into `buf`.
    pub fn command<'b, T: Real>(
        &self,
        buf: &'b mut [PlanPoint<T>; CHUNK_POINTS],
    ) -> Option<Command<'b, T>> {
        let c = |x: f32| T::of(x as f64);
        Some(match self {
            Message::Hello { .. } => Command::Hello,
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
            Message::HelloAck(_) | Message::Telemetry(_) => return None,
        })
    }
}

/// A shared authentication key (1–64 bytes; use at least 16 random bytes).
#[derive(Clone, Copy)]
pub struct Key {
    bytes: [u8; 64],
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
        let mut k = [0u8; 64];
        k[..bytes.len()].copy_from_slice(bytes);
        Ok(Self {
            bytes: k,
            len: bytes.len(),
        })
    }

    fn tag(&self, data: &[u8]) -> [u8; TAG_LEN] {
        // HMAC accepts keys of any length; `new_from_slice` cannot fail for HMAC.
        let mut out = [0u8; TAG_LEN];
        if let Ok(mut mac) = Hmac::<Sha256>::new_from_slice(&self.bytes[..self.len]) {
            mac.update(data);
            let full = mac.finalize().into_bytes();
            out.copy_from_slice(&full[..TAG_LEN]);
        }
        out
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
    /// Missing or wrong tag.
    #[error("not authenticated")]
    Auth,
    /// Repeated or too-old sequence number.
    #[error("replayed or duplicate sequence number {0}")]
    Replay(u64),
    /// Body not a valid message.
    #[error("malformed message")]
    Malformed,
}

/// One end of the link: sequence numbers out, replay window, key and counters in.
#[derive(Clone, Copy, Debug)]
pub struct Endpoint {
    key: Option<Key>,
    tx_seq: u64,
    window: ReplayWindow,
    counters: LinkCounters,
}

impl Endpoint {
    /// An endpoint with an optional shared key whose first frame carries `first_seq`
    /// (≥ 1; use a value above any `seq` this sender used before, e.g. µs since the Unix
    /// epoch on a PC, 1 on a robot whose peer starts a fresh window per session).
    pub fn new(key: Option<Key>, first_seq: u64) -> Self {
        Self {
            key,
            tx_seq: first_seq.max(1),
            window: ReplayWindow::default(),
            counters: LinkCounters::default(),
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

    /// The sequence number the next frame will carry.
    pub fn next_seq(&self) -> u64 {
        self.tx_seq
    }

    /// Encodes `msg` as one delimited frame into `out` (at least [`MAX_FRAME`] bytes is
    /// always enough); returns the number of bytes written, delimiter included.
    ///
    /// # Errors
    /// [`EncodeError::TooLarge`] when the body exceeds [`MAX_BODY`] or `out` is too small.
    pub fn encode(&mut self, msg: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
        let seq = self.tx_seq;
        let n = encode_frame(msg, seq, self.key.as_ref(), out)?;
        self.tx_seq = self.tx_seq.wrapping_add(1).max(1);
        Ok(n)
    }

    /// Decodes one frame (the bytes between two delimiters, without them; decoded in place)
    /// and applies authentication and the replay window. Counts the frame in exactly one
    /// counter.
    ///
    /// # Errors
    /// [`DropReason`]: the frame was dropped and must not be acted upon.
    pub fn decode(&mut self, frame: &mut [u8]) -> Result<(u64, Message), DropReason> {
        let r = self.decode_inner(frame);
        let c = &mut self.counters;
        let slot = match r {
            Ok(_) => &mut c.ok,
            Err(DropReason::Framing) => &mut c.framing,
            Err(DropReason::Crc) => &mut c.crc,
            Err(DropReason::Version(_)) => &mut c.version,
            Err(DropReason::Auth) => &mut c.auth,
            Err(DropReason::Replay(_)) => &mut c.replay,
            Err(DropReason::Malformed) => &mut c.malformed,
        };
        *slot = slot.saturating_add(1);
        r
    }

    /// Counts a frame dropped before decoding (e.g. cut off at the end of a datagram, or
    /// longer than the receive buffer).
    pub fn count_framing_drop(&mut self) {
        self.counters.framing = self.counters.framing.saturating_add(1);
    }

    fn decode_inner(&mut self, frame: &mut [u8]) -> Result<(u64, Message), DropReason> {
        let parsed = parse_frame(frame, self.key.as_ref())?;
        if !self.window.is_fresh(parsed.0) {
            return Err(DropReason::Replay(parsed.0));
        }
        self.window.accept(parsed.0);
        Ok(parsed)
    }
}

/// Encodes `msg` with sequence number `seq` (and a tag if `key` is given) into `out`, COBS
/// stuffed and `0x00`-terminated. Returns the bytes written. Stateless: see
/// [`Endpoint::encode`] for the usual use.
///
/// # Errors
/// [`EncodeError::TooLarge`].
pub fn encode_frame(
    msg: &Message,
    seq: u64,
    key: Option<&Key>,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let mut raw = [0u8; MAX_RAW];
    raw[0] = PROTOCOL_VERSION;
    raw[1] = if key.is_some() { FLAG_AUTH } else { 0 };
    raw[2..HEADER_LEN].copy_from_slice(&seq.to_le_bytes());
    let body_len = postcard::to_slice(msg, &mut raw[HEADER_LEN..HEADER_LEN + MAX_BODY])
        .map_err(|_| EncodeError::TooLarge)?
        .len();
    let mut n = HEADER_LEN + body_len;
    if let Some(k) = key {
        let tag = k.tag(&raw[..n]);
        raw[n..n + TAG_LEN].copy_from_slice(&tag);
        n += TAG_LEN;
    }
    let crc = CRC.checksum(&raw[..n]);
    raw[n..n + 4].copy_from_slice(&crc.to_le_bytes());
    n += 4;
    if out.len() < cobs::max_encoding_length(n) + 1 {
        return Err(EncodeError::TooLarge);
    }
    let m = cobs::try_encode(&raw[..n], out).map_err(|_| EncodeError::TooLarge)?;
    out[m] = 0;
    Ok(m + 1)
}

/// Decodes one frame without replay checking: COBS (in place), CRC, version, tag (required
/// when `key` is given; ignored otherwise), body. Never panics on any input.
///
/// # Errors
/// [`DropReason`] (never [`DropReason::Replay`]).
pub fn parse_frame(frame: &mut [u8], key: Option<&Key>) -> Result<(u64, Message), DropReason> {
    if frame.is_empty() || frame.len() > MAX_FRAME {
        return Err(DropReason::Framing);
    }
    let n = cobs::decode_in_place(frame).map_err(|_| DropReason::Framing)?;
    let raw = frame.get(..n).ok_or(DropReason::Framing)?;
    if n < HEADER_LEN + 4 + 1 {
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
    let flags = data[1];
    let mut seq_bytes = [0u8; 8];
    seq_bytes.copy_from_slice(&data[2..HEADER_LEN]);
    let seq = u64::from_le_bytes(seq_bytes);
    let mut end = data.len();
    if flags & FLAG_AUTH != 0 {
        if end < HEADER_LEN + TAG_LEN + 1 {
            return Err(DropReason::Framing);
        }
        end -= TAG_LEN;
    }
    if let Some(k) = key {
        if flags & FLAG_AUTH == 0 {
            return Err(DropReason::Auth);
        }
        let want = k.tag(&data[..end]);
        // Constant-time comparison.
        let diff = want
            .iter()
            .zip(&data[end..end + TAG_LEN])
            .fold(0u8, |d, (a, b)| d | (a ^ b));
        if diff != 0 {
            return Err(DropReason::Auth);
        }
    }
    let (msg, rest) = postcard::take_from_bytes::<Message>(&data[HEADER_LEN..end])
        .map_err(|_| DropReason::Malformed)?;
    if !rest.is_empty() {
        return Err(DropReason::Malformed);
    }
    Ok((seq, msg))
}

/// Splits a byte stream into frames at `0x00` delimiters, with a fixed buffer of `N` bytes
/// (use [`MAX_FRAME`]). Frames longer than `N` are discarded up to the next delimiter and
/// counted as framing drops.
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

    /// Feeds `bytes`; for each complete frame calls `on_frame` with the decoded result of
    /// [`Endpoint::decode`] (drops are already counted there).
    pub fn feed(
        &mut self,
        bytes: &[u8],
        endpoint: &mut Endpoint,
        mut on_frame: impl FnMut(Result<(u64, Message), DropReason>),
    ) {
        for &b in bytes {
            if b == 0 {
                if self.overflow {
                    endpoint.count_framing_drop();
                    on_frame(Err(DropReason::Framing));
                } else if self.len > 0 {
                    let r = endpoint.decode(&mut self.buf[..self.len]);
                    on_frame(r);
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
    /// is a truncated frame — dropped and counted. Returns `true` if one was dropped.
    pub fn end_of_datagram(&mut self, endpoint: &mut Endpoint) -> bool {
        let dropped = self.len > 0 || self.overflow;
        if dropped {
            endpoint.count_framing_drop();
        }
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
    /// Hello: send this [`RobotInfo`] back as [`Message::HelloAck`].
    Hello(RobotInfo),
    /// The runtime rejected it (counted there).
    Rejected(crate::runtime::CommandError),
    /// Not a command (a robot → operator message); ignored.
    Ignored,
}

/// Robot side: hands one decoded message to the runtime at clock time `now_us`.
pub fn serve<T: Real, const N: usize>(
    runtime: &mut Runtime<T, N>,
    msg: &Message,
    authenticated: bool,
    now_us: u64,
) -> Served {
    let mut buf = [PlanPoint::zero(); CHUNK_POINTS];
    let Some(cmd) = msg.command(&mut buf) else {
        return Served::Ignored;
    };
    match runtime.handle(cmd, now_us) {
        Ok(()) => match msg {
            Message::Hello { .. } => Served::Hello(RobotInfo {
                protocol: PROTOCOL_VERSION,
                kind: match runtime.robot() {
                    crate::Robot::Sphere(_) => RobotKind::Sphere,
                    crate::Robot::Ballbot(_) => RobotKind::Ballbot,
                    crate::Robot::Caster(_) => RobotKind::Caster,
                },
                plan_capacity: N.min(u16::MAX as usize) as u16,
                rate_hz: runtime.config().rate_hz.to_f64() as f32,
                watchdog: runtime.config().watchdog.to_f64() as f32,
                authenticated,
            }),
            _ => Served::Accepted,
        },
        Err(e) => Served::Rejected(e),
    }
}
