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
//!
//! ## Layout
//! Every item is re-exported here (`omnikin::link::X`); the files hold one concept each:
//! `frame.rs` the v2 frame codec and [`FrameReader`], `cobs.rs` byte stuffing, `message.rs`
//! the messages and wire types, `auth.rs` keys and the replay window, `error.rs` drop reasons
//! and counters, `session.rs` the shared session state, `robot.rs` and `operator.rs` the two
//! ends, [`v1`] the v1 compatibility answer.

/// The fixed-capacity vector crate of [`Message::PlanChunk`] (re-exported so hosts build
/// chunks without depending on it themselves).
pub use heapless;

mod auth;
mod cobs;
mod error;
mod frame;
mod message;
mod operator;
mod robot;
mod session;
pub mod v1;

pub use auth::{Key, KeyError, MacKey, ReplayWindow};
pub use cobs::{cobs_decode_in_place, cobs_encode, cobs_max_len};
pub use error::{DropReason, EncodeError, LinkCounters};
pub use frame::{
    FrameReader, Header, Kind, Parsed, decode_message, encode_frame_with, encode_hello,
    encode_message, parse_frame,
};
use frame::{ct_eq, decode_hello, postcard_body, stuff};
pub use message::{
    EndReason, Estimate, Hello, HelloAck, Message, RobotInfo, RobotKind, SimTruth, Telemetry,
    TelemetrySource, WireFix, WirePoint,
};
pub use operator::{OperatorEvent, OperatorLink};
pub use robot::{PENDING_SLOTS, RobotEvent, RobotLink, Served, robot_info, serve};

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
