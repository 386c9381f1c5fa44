//! Protocol v1 (`COBS(version=1 | flags | seq:u64 | body | tag[8] | crc32c)`), kept only so
//! that v1 and later peers tell each other apart: a later robot answers a v1 frame with a v1
//! HelloAck saying its protocol (e.g. `protocol: 4`); a later operator that gets no answer
//! probes with a v1 Hello, so an older robot's HelloAck (`protocol: 1`, 2 or 3) names the
//! mismatch. The v1 HelloAck's body is frozen ([`V1RobotInfo`]): every version encodes it alike.

use serde::Serialize;

use super::{CRC, EncodeError, Key, MAX_RAW, RobotKind, stuff};
use serde::Deserialize;

/// The version byte of v1 frames.
pub const VERSION: u8 = 1;
const HEADER: usize = 10;
const TAG: usize = 8;
const FLAG_AUTH: u8 = 1;

/// Who the robot is, as v1's `HelloAck` says it (the fields of protocols 1 to 3; protocol 4's
/// [`link::RobotInfo`](super::RobotInfo) appends the body limits, which a v1 answer does not
/// carry: a v1 operator decodes the body exactly, trailing bytes refused).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct V1RobotInfo {
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

impl From<&super::RobotInfo> for V1RobotInfo {
    fn from(i: &super::RobotInfo) -> Self {
        Self {
            protocol: i.protocol,
            kind: i.kind,
            plan_capacity: i.plan_capacity,
            rate_hz: i.rate_hz,
            watchdog: i.watchdog,
            authenticated: i.authenticated,
        }
    }
}

/// The first two variants of v1's `Message` (postcard writes the variant index first, so
/// these encode and decode exactly as v1's `Hello` and `HelloAck`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum V1Frame {
    /// v1 `Hello { protocol }`.
    Hello {
        /// The sender's protocol version.
        protocol: u8,
    },
    /// v1 `HelloAck(V1RobotInfo)`.
    HelloAck(V1RobotInfo),
}

fn encode(f: &V1Frame, seq: u64, key: Option<&Key>, out: &mut [u8]) -> Result<usize, EncodeError> {
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
    encode(&V1Frame::Hello { protocol: VERSION }, seq, key, out)
}

/// A v1 HelloAck carrying `info`.
///
/// # Errors
/// [`EncodeError::TooLarge`] when `out` is too small.
pub fn encode_hello_ack(
    info: &V1RobotInfo,
    seq: u64,
    key: Option<&Key>,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    encode(&V1Frame::HelloAck(*info), seq, key, out)
}

/// Decodes a v1 Hello or HelloAck (the bytes between delimiters, decoded in place; the
/// tag checked when `key` is given, as v1 did). `None` for anything else, never a panic.
pub fn parse(frame: &mut [u8], key: Option<&Key>) -> Option<(u64, V1Frame)> {
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
    match postcard::take_from_bytes::<V1Frame>(&data[HEADER..end]) {
        Ok((f, [])) => Some((u64::from_le_bytes(s), f)),
        _ => None,
    }
}
