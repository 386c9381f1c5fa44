//! # Operator link: the wire format between the PC and the robot
//!
//! Paper 000's operator sets motion commands on a PC and sends them over a wireless link to
//! the microcontroller. This module is that link's codec and session logic, the same on both
//! ends, `no_std`, no allocation, over **any byte stream** (UDP datagrams, a serial port, a
//! radio modem).
//!
//! ## Frame format (protocol version [`PROTOCOL_VERSION`] = 4)
//! ```text
//! COBS( version:u8 = 4 | kind:u8 | session:u64 LE | seq:u64 LE | [opening] | body | tag[16] | crc32c:u32 LE ) 0x00
//! ```
//! * **COBS** removes every `0x00` from the frame so a single `0x00` delimits frames; a
//!   receiver that joins mid-stream re-synchronises at the next delimiter.
//! * `crc32c` (CRC-32C, Castagnoli) over everything before it: a corrupt frame is dropped
//!   ([`LinkCounters::crc`]). It catches noise, not attackers; the tag does that.
//! * `version` is checked right after the CRC; a frame of another version is dropped
//!   ([`LinkCounters::version`]) — a robot answers a v1 peer with one v1 answer it can print
//!   ([`v1`]).
//! * `kind`: [`FrameKind`] in the low 7 bits; bit 7 ([`KIND_TAGGED`]) says the frame carries a
//!   `tag`. A handshake frame ([`FrameKind::Hello`], [`FrameKind::HelloAck`]) has `session = 0` and
//!   `seq = 0`; a [`FrameKind::Session`] frame carries one [`Message`] of session `session` with
//!   sequence number `seq` ≥ 1; a [`FrameKind::Open`] frame is a session frame of the operator
//!   that the robot has not confirmed yet, with the handshake's [`Opening`]
//!   (`client_nonce[16] | epoch:u32 | flags:u8`, [`OPENING_LEN`] bytes) after the header.
//! * `tag` (with a pre-shared [`Key`] only): the first [`TAG_LEN`] = 16 bytes of HMAC-SHA256
//!   over `version … body`, keyed with the PSK for handshake frames and with the session key
//!   for session and open frames. A keyed endpoint drops a frame without a valid tag, an
//!   unkeyed one a frame with a tag ([`LinkCounters::auth`]).
//! * `body`: postcard (serde's compact varint format; the schema is this module's types,
//!   whose field order is part of the protocol). A Hello is zero-padded to
//!   [`HANDSHAKE_BODY`] bytes, so it is never smaller than the robot's answer.
//!
//! ## Sessions
//! ```text
//! operator                                                  robot
//!   | Hello{protocol, client_nonce}         (PSK tag)         |
//!   |-------------------------------------------------------->|  no state: robot_nonce =
//!   |   HelloAck{info, client_nonce, robot_nonce, epoch} (PSK)|  PRF(secret_epoch, client_nonce)
//!   |<--------------------------------------------------------|
//!   | K_s, P from (PSK, client_nonce, robot_nonce)            |
//!   | Open frame (id P, seq 1.., opening, K_s tag): Heartbeat |
//!   |-------------------------------------------------------->|  re-derives robot_nonce, P, K_s;
//!   |   Telemetry (id P, robot seq 1.., K_s tag)              |  the tag proves the key: P is
//!   |<--------------------------------------------------------|  the active session, at the
//!   | Session frames (id P) from the first robot frame on     |  address that proved it
//! ```
//! `prk = HMAC(PSK, "omnikin-v2 session" | client_nonce | robot_nonce)` (the labels kept from v2),
//! `K_s = HMAC(prk, "omnikin-v2 key")`, `P = HMAC(prk, "omnikin-v2 id")[..8]` (LE, never 0);
//! without a key the PSK is empty. The robot answers a Hello without keeping anything
//! ([`HandshakeSecrets`]): a replayed or spoofed Hello gets an answer no larger than itself
//! and changes nothing. A session exists only once an open frame verified under `K_s`; the
//! client nonces of the sessions each handshake epoch opened are remembered while the epoch
//! lives (one to two [`EPOCH_US`]), so a replayed first frame opens nothing. An open frame
//! without [`Opening::take_over`] does not replace a live session (one heard within
//! [`LIVE_US`]): the robot answers [`Message::Busy`] instead. Sequence numbers start at 1 in
//! each direction of each session and pass a 64-frame sliding window ([`ReplayWindow`]): a
//! repeated or too-old `seq` is dropped ([`LinkCounters::replay`]). A frame of another
//! session — a recording of an old one, a guess — is dropped ([`LinkCounters::session`]). One
//! operator session at a time.
//!
//! ## E-stop ordering
//! An accepted [`Message::EStop`] is a barrier in its session: a [`Message::Clear`] or a
//! motion command ([`Message::SetVelocity`], the plan messages, [`Message::SetPose`]) with a
//! lower sequence number — held back and delivered late — is never executed
//! ([`LinkCounters::stale`]). The telemetry names the e-stop that is latched
//! ([`Telemetry::estop_seq`]) and the clear that ended the last one ([`Telemetry::clear_seq`]).
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
//!
//! ## Layout
//! Every item is re-exported here (`omnikin::link::X`); the files hold one concept each:
//! `frame.rs` the v3 frame codec and [`FrameReader`], `cobs.rs` byte stuffing, `message.rs`
//! the messages and wire types, `auth.rs` keys and the replay window, `handshake.rs` the
//! robot's rotating handshake secrets, `error.rs` drop reasons and counters, `session.rs` the
//! shared session state, `robot.rs` and `operator.rs` the two ends, [`v1`] the v1
//! compatibility answer.

/// The fixed-capacity vector crate of [`Message::PlanChunk`] (re-exported so hosts build
/// chunks without depending on it themselves).
pub use heapless;

mod auth;
mod cobs;
mod error;
mod frame;
mod handshake;
mod message;
mod operator;
mod robot;
mod session;
pub mod v1;

pub use auth::{Key, KeyError, MacKey, ReplayWindow};
pub use cobs::{cobs_decode_in_place, cobs_encode, cobs_max_len};
pub use error::{DropReason, EncodeError, LinkCounters};
pub use frame::{
    FrameKind, FrameReader, Header, Opening, Parsed, decode_message, encode_frame_with,
    encode_hello, encode_message, encode_open, parse_frame, peek_kind,
};
use frame::{ct_eq, decode_hello, postcard_body, stuff};
pub use handshake::{EPOCH_US, FirstFrame, HandshakeSecrets, USED_PER_EPOCH};
pub use message::{
    Busy, EndReason, Estimate, Hello, HelloAck, Message, RobotInfo, RobotKind, RobotLimits,
    SimTruth, Telemetry, TelemetrySource, WireFix, WirePoint,
};
pub use operator::{OperatorEvent, OperatorLink};
pub use robot::{LIVE_US, RobotEvent, RobotLink, Served, robot_info, serve};

/// The protocol version sent first in every frame (4: the HelloAck's [`RobotInfo`] carries
/// the runtime's body limits, [`RobotLimits`], and the Hello's padding grew to match; 3:
/// stateless handshake, open frames, e-stop barrier; v2 kept pending handshakes). Peers of
/// different versions drop each other's frames and name the mismatch through [`v1`].
pub const PROTOCOL_VERSION: u8 = 4;
/// Bytes of the truncated HMAC-SHA256 tag.
pub const TAG_LEN: usize = 16;
/// Bytes of each handshake nonce.
pub const NONCE_LEN: usize = 16;
/// Plan points per [`Message::PlanChunk`].
pub const CHUNK_POINTS: usize = 8;
/// Header bytes: version, kind, session, seq.
pub const HEADER_LEN: usize = 18;
/// Bytes of an [`Opening`] (after the header of a [`FrameKind::Open`] frame): client nonce, epoch,
/// flags.
pub const OPENING_LEN: usize = NONCE_LEN + 4 + 1;
/// Largest postcard body, bytes.
pub const MAX_BODY: usize = 320;
/// Largest raw (un-stuffed) frame: header, opening, body, tag, CRC.
pub const MAX_RAW: usize = HEADER_LEN + OPENING_LEN + MAX_BODY + TAG_LEN + 4;
/// Largest frame on the wire, bytes, including the `0x00` delimiter.
pub const MAX_FRAME: usize = cobs_max_len(MAX_RAW) + 1;
/// Bit 7 of the kind byte: the frame carries a tag.
pub const KIND_TAGGED: u8 = 0x80;
/// Body bytes of a Hello (zero-padded) — the largest [`HelloAck`] body, so a robot's answer
/// is never larger than the Hello that asked for it (anti-amplification): v3's 51 bytes plus
/// the 12 of [`RobotLimits`].
pub const HANDSHAKE_BODY: usize = 63;

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);
