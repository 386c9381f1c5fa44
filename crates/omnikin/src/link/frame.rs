//! The v2 frame codec: the header layout ([`Kind`], [`Header`]), CRC-32C, tag and COBS
//! around a postcard body ([`parse_frame`], [`encode_frame_with`], [`encode_message`],
//! [`encode_hello`], [`decode_message`]), and the [`FrameReader`] that cuts a byte stream at
//! its `0x00` delimiters.

use serde::Serialize;

use super::{
    CRC, DropReason, EncodeError, HANDSHAKE_BODY, HEADER_LEN, Hello, KIND_TAGGED, Key, MAX_BODY,
    MAX_FRAME, MAX_RAW, MacKey, Message, PROTOCOL_VERSION, TAG_LEN, cobs_decode_in_place,
    cobs_encode, cobs_max_len,
};

/// What a frame is (the low 7 bits of the kind byte).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Kind {
    /// Operator → robot: start a session ([`Hello`]).
    Hello = 1,
    /// Robot → operator: the answer to a Hello ([`HelloAck`](super::HelloAck)); `session` is the new id.
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

pub(super) fn ct_eq(a: &[u8], b: &[u8]) -> bool {
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
pub(super) fn stuff(
    raw: &mut [u8; MAX_RAW],
    n: usize,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
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

pub(super) fn postcard_body<S: Serialize>(
    v: &S,
) -> impl FnOnce(&mut [u8]) -> Result<usize, EncodeError> {
    move |b| {
        postcard::to_slice(v, b)
            .map(|s| s.len())
            .map_err(|_| EncodeError::TooLarge)
    }
}

/// Encodes a session frame carrying `msg` (stateless; [`RobotLink::encode`](super::RobotLink::encode) and
/// [`OperatorLink::encode`](super::OperatorLink::encode) are the usual way).
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

pub(super) fn decode_hello(body: &[u8]) -> Result<Hello, DropReason> {
    if body.len() < HANDSHAKE_BODY {
        // Unpadded: answering it could amplify.
        return Err(DropReason::Malformed);
    }
    match postcard::take_from_bytes::<Hello>(body) {
        Ok((h, rest)) if rest.iter().all(|&b| b == 0) => Ok(h),
        _ => Err(DropReason::Malformed),
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
    /// delimiter, to hand to [`RobotLink::receive`](super::RobotLink::receive) or [`OperatorLink::receive`](super::OperatorLink::receive)), or with
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
