//! The v3 frame codec: the header layout ([`FrameKind`], [`Header`], the first frames'
//! [`Opening`]), CRC-32C, tag and COBS around a postcard body ([`parse_frame`],
//! [`encode_frame_with`], [`encode_message`], [`encode_open`], [`encode_hello`],
//! [`decode_message`]), and the [`FrameReader`] that cuts a byte stream at its `0x00`
//! delimiters.

use serde::Serialize;

use super::{
    CRC, DropReason, EncodeError, HANDSHAKE_BODY, HEADER_LEN, Hello, KIND_TAGGED, Key, MAX_BODY,
    MAX_FRAME, MAX_RAW, MacKey, Message, NONCE_LEN, OPENING_LEN, PROTOCOL_VERSION, TAG_LEN,
    cobs_decode_in_place, cobs_encode, cobs_max_len,
};

/// What a frame is (the low 7 bits of the kind byte).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum FrameKind {
    /// Operator → robot: start a session ([`Hello`]).
    Hello = 1,
    /// Robot → operator: the answer to a Hello ([`HelloAck`](super::HelloAck)); `session` is the new id.
    HelloAck = 2,
    /// Either way: one [`Message`] of an established session.
    Session = 3,
    /// Operator → robot: one [`Message`] of a session the robot has not confirmed yet, with
    /// the handshake's [`Opening`] after the header, so that a robot that keeps no handshake
    /// state can re-derive the session and verify the frame.
    Open = 4,
}

impl FrameKind {
    fn from_u8(b: u8) -> Option<Self> {
        match b {
            1 => Some(FrameKind::Hello),
            2 => Some(FrameKind::HelloAck),
            3 => Some(FrameKind::Session),
            4 => Some(FrameKind::Open),
            _ => None,
        }
    }
}

/// The fixed fields of a v3 frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Frame kind.
    pub kind: FrameKind,
    /// Session id (0 in a Hello).
    pub session: u64,
    /// Sequence number (0 in handshake frames).
    pub seq: u64,
    /// Whether a tag follows the body.
    pub tagged: bool,
}

/// What an operator's first frames ([`FrameKind::Open`]) carry between the header and the body:
/// `client_nonce[16] | epoch:u32 LE | flags:u8` ([`OPENING_LEN`] bytes, under the tag).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Opening {
    /// The client nonce of the operator's Hello.
    pub client_nonce: [u8; NONCE_LEN],
    /// The robot's handshake epoch named in its HelloAck.
    pub epoch: u32,
    /// Take the robot over from an operator whose session is live (flag bit 0). Without it a
    /// robot that is held answers [`Message::Busy`](super::Message::Busy).
    pub take_over: bool,
}

impl Opening {
    const TAKE_OVER: u8 = 1;

    fn write(&self, b: &mut [u8]) {
        b[..NONCE_LEN].copy_from_slice(&self.client_nonce);
        b[NONCE_LEN..NONCE_LEN + 4].copy_from_slice(&self.epoch.to_le_bytes());
        b[NONCE_LEN + 4] = if self.take_over { Self::TAKE_OVER } else { 0 };
    }

    fn read(b: &[u8]) -> Option<Self> {
        let b = b.get(..OPENING_LEN)?;
        let mut client_nonce = [0u8; NONCE_LEN];
        client_nonce.copy_from_slice(&b[..NONCE_LEN]);
        let mut e = [0u8; 4];
        e.copy_from_slice(&b[NONCE_LEN..NONCE_LEN + 4]);
        let flags = b[NONCE_LEN + 4];
        if flags & !Self::TAKE_OVER != 0 {
            return None;
        }
        Some(Self {
            client_nonce,
            epoch: u32::from_le_bytes(e),
            take_over: flags & Self::TAKE_OVER != 0,
        })
    }
}

/// A frame whose COBS, length, CRC and version checked out; tag not yet verified.
#[derive(Clone, Copy, Debug)]
pub struct Parsed<'a> {
    /// The header.
    pub header: Header,
    /// The handshake fields of a [`FrameKind::Open`] frame (`None` for the other kinds).
    pub opening: Option<Opening>,
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
/// [`DropReason::Malformed`] (unknown kind, or unknown flags of an [`Opening`]).
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
    let kind = FrameKind::from_u8(data[1] & !KIND_TAGGED).ok_or(DropReason::Malformed)?;
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
    let start = if kind == FrameKind::Open {
        HEADER_LEN + OPENING_LEN
    } else {
        HEADER_LEN
    };
    let end = if tagged {
        if data.len() < start + TAG_LEN + 1 {
            return Err(DropReason::Framing);
        }
        data.len() - TAG_LEN
    } else {
        if data.len() < start + 1 {
            return Err(DropReason::Framing);
        }
        data.len()
    };
    let opening = if kind == FrameKind::Open {
        Some(Opening::read(&data[HEADER_LEN..start]).ok_or(DropReason::Malformed)?)
    } else {
        None
    };
    Ok(Parsed {
        header,
        opening,
        body: &data[start..end],
        signed: &data[..end],
        tag: &data[end..],
    })
}

/// Encodes one v3 frame: `header` (its `tagged` is taken from `mac`), then the body that
/// `body` writes into the slice it is given (returning its length), the tag under `mac` and
/// the CRC; COBS-stuffed and `0x00`-terminated into `out`. Returns the bytes written.
///
/// # Errors
/// [`EncodeError::TooLarge`] when the body exceeds [`MAX_BODY`] or `out` is too small.
/// A [`FrameKind::Open`] frame is written by [`encode_open`] (its [`Opening`] goes first).
pub fn encode_frame_with(
    kind: FrameKind,
    session: u64,
    seq: u64,
    mac: Option<&MacKey>,
    body: impl FnOnce(&mut [u8]) -> Result<usize, EncodeError>,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    if kind == FrameKind::Open {
        return Err(EncodeError::TooLarge);
    }
    encode_raw(kind, session, seq, None, mac, body, out)
}

fn encode_raw(
    kind: FrameKind,
    session: u64,
    seq: u64,
    opening: Option<&Opening>,
    mac: Option<&MacKey>,
    body: impl FnOnce(&mut [u8]) -> Result<usize, EncodeError>,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    let mut raw = [0u8; MAX_RAW];
    raw[0] = PROTOCOL_VERSION;
    raw[1] = kind as u8 | if mac.is_some() { KIND_TAGGED } else { 0 };
    raw[2..10].copy_from_slice(&session.to_le_bytes());
    raw[10..HEADER_LEN].copy_from_slice(&seq.to_le_bytes());
    let start = match opening {
        Some(o) => {
            o.write(&mut raw[HEADER_LEN..HEADER_LEN + OPENING_LEN]);
            HEADER_LEN + OPENING_LEN
        }
        None => HEADER_LEN,
    };
    let body_len = body(&mut raw[start..start + MAX_BODY])?;
    if body_len > MAX_BODY {
        return Err(EncodeError::TooLarge);
    }
    let mut n = start + body_len;
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
    encode_frame_with(
        FrameKind::Session,
        session,
        seq,
        mac,
        postcard_body(msg),
        out,
    )
}

/// Encodes an operator's first frame ([`FrameKind::Open`]): a session frame carrying `msg` with the
/// handshake's `opening` (stateless; [`OperatorLink::encode`](super::OperatorLink::encode) sends
/// these until the robot confirms the session).
///
/// # Errors
/// [`EncodeError::TooLarge`].
pub fn encode_open(
    session: u64,
    seq: u64,
    opening: &Opening,
    msg: &Message,
    mac: Option<&MacKey>,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    encode_raw(
        FrameKind::Open,
        session,
        seq,
        Some(opening),
        mac,
        postcard_body(msg),
        out,
    )
}

/// The kind of a frame (the bytes between two delimiters, still COBS-encoded) from its first
/// bytes, without decoding it — a host's cheap look before it spends work on a frame (rate
/// limits on Hellos). `None` when it is not visibly a v3 frame. A valid frame's first two raw
/// bytes (version, kind) are non-zero, so COBS's first code byte is at least 3 and copies them
/// unchanged.
pub fn peek_kind(frame: &[u8]) -> Option<FrameKind> {
    match frame {
        [code, version, kind, ..] if *code >= 3 && *version == PROTOCOL_VERSION => {
            FrameKind::from_u8(kind & !KIND_TAGGED)
        }
        _ => None,
    }
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
    encode_frame_with(FrameKind::Hello, 0, 0, psk.map(Key::mac), body, out)
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
