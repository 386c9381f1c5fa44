//! The link harness (wire v3): a structured input — Hellos, open and session frames, a robot
//! clock — whose header fields, nonces, openings and body bytes the fuzzer chooses, that
//! [`fixup`] turns into wire frames with a correct tag (under the PSK for handshake frames,
//! under the session key K_s for open and session frames), CRC and COBS stuffing. So mutated
//! inputs get past the CRC and the MAC and reach the stateless handshake, the open-frame
//! checks (epoch, used nonces, key confirmation, Busy, take-over), the replay windows, the
//! postcard body decoder, the e-stop barrier and the robot runtime. [`Session`] runs one input
//! against a robot's [`RobotLink`] and [`Runtime`] and checks every frame against a model of
//! the protocol written from the format's documentation (`omnikin::link` module docs), with
//! its own HMAC key derivation, robot-nonce function and epoch bookkeeping.
//!
//! ## Input format
//! ```text
//! setup:u8  bit 0 keyed (PSK FUZZ_KEY), bit 1 datagram transport, bits 2-3 robot
//!           (0 sphere, 1 ballbot, 2-3 caster)
//! record*   op:u8, then by op & 7:
//!   0     Hello: client_nonce[16]; [protocol:u8, pad:u8, host:u8 if bit 7];
//!         bit 6: the robot's entropy source fails for this one; host bit 0: the host's
//!         rate limiter throttles it (it looks at `peek_kind` only)
//!   1, 5  session frame (kind 3) to handshake k (k:u8, 0 = the newest answered Hello): seq
//!         (bit 6: u64 LE; else i8 delta from the last seq sent in that session), len:u16 LE,
//!         body[len]; bit 7: tagged under the PSK instead of K_s
//!   6     open frame (kind 4) to handshake k: as a session frame, with flags:u8 and
//!         epoch_delta:i8 after the seq; flags bit 0 take over, bit 1 one bit of the client
//!         nonce flipped, bit 2 an unknown opening flag; the epoch is the HelloAck's + delta
//!   2     any frame: version:u8, kind:u8, session:u64, seq:u64, key:u8 (0 PSK, 1 newest
//!         K_s), len:u16 LE, body[len] (an open frame's opening is in the body)
//!   3     cycles: n:u8 -> (n & 15) + 1 control periods, each followed by a telemetry frame
//!   4     junk: len:u8, bytes[len], fed as they are; then a 0x00 unless bit 3 is set (on a
//!         stream the next frame then starts with them)
//!   7     robot clock: advance by bits 3-4: 0 n:u8 ms, 1 n:u8 x 100 ms, 2 n:u8 s,
//!         3 u32 LE µs (EPOCH_US is 10 s, LIVE_US 1 s)
//! Hello, session, open and any frame: bit 3 corrupts the CRC, bit 4 the tag, bit 5 toggles
//! the tag's presence (a keyed robot wants one, an unkeyed one none).
//! ```
//! Everything computed rather than chosen — tag, CRC, stuffing, delimiter — is the one
//! function [`fixup`].
//!
//! ## The model's knowledge of the robot
//! Only what the `omnikin::link` docs state, plus how the robot spends the harness's entropy
//! (its deterministic [`FuzzEntropy`], mirrored by the model): a new handshake epoch takes the
//! next 32 bytes as its secret and, for the first epoch only, the next 4 as its number (LE);
//! later epochs count up by one.

use std::collections::{BTreeMap, BTreeSet};

use hmac::{Hmac, Mac};
use omnikin::link::{
    Busy, DropReason, EPOCH_US, EndReason, FrameKind, FrameReader, HANDSHAKE_BODY, HEADER_LEN,
    HelloAck, KIND_TAGGED, Key, LIVE_US, LinkCounters, MAX_FRAME, Message, NONCE_LEN, OPENING_LEN,
    PROTOCOL_VERSION, RobotEvent, RobotInfo, RobotLink, Served, TAG_LEN, USED_PER_EPOCH, peek_kind,
    robot_info, serve,
};
use omnikin::runtime::hal::{
    EncoderAngles, Encoders, Entropy, EntropyError, MotorCommand, MotorOutputs, NoImu,
};
use omnikin::runtime::limits::RateLimits;
use omnikin::runtime::{Config, Mode, Runtime};
use omnikin::{Pose2, Robot};
use sha2::Sha256;

use crate::alloc::measure;

/// The pre-shared key of keyed robots (any 1–64 bytes).
pub const FUZZ_KEY: &[u8] = b"fuzzing key, 32 bytes long .....";

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);

/// Largest body the harness frames, bytes (above [`omnikin::link::MAX_BODY`], so that frames
/// too long for the receive buffer are generated too).
pub const MAX_SPEC_BODY: usize = 511;
/// Control rate of the fuzzed runtime, Hz.
pub const RATE_HZ: f32 = 100.0;
/// Wheel rate limit of the fuzzed runtime, rad/s.
pub const WHEEL_LIMIT: f32 = 30.0;
/// Steer rate limit of the fuzzed runtime (caster), rad/s.
pub const STEER_LIMIT: f32 = 10.0;
/// Plan buffer of the fuzzed runtime, points.
pub const PLAN_POINTS: usize = 64;

const KIND_HELLO: u8 = 1;
const KIND_HELLO_ACK: u8 = 2;
const KIND_SESSION: u8 = 3;
const KIND_OPEN: u8 = 4;
/// Bit 0 of an opening's flags: take over.
const FLAG_TAKE_OVER: u8 = 1;

fn hmac(key: &[u8], parts: &[&[u8]]) -> [u8; 32] {
    let mut m = <Hmac<Sha256> as Mac>::new_from_slice(key).expect("HMAC takes any key");
    for p in parts {
        m.update(p);
    }
    m.finalize().into_bytes().into()
}

/// The session a handshake makes, per the module docs of `omnikin::link`: `prk = HMAC(PSK,
/// "omnikin-v2 session" | client_nonce | robot_nonce)`, `K_s = HMAC(prk, "omnikin-v2 key")`,
/// id = `HMAC(prk, "omnikin-v2 id")[..8]` LE, never 0; the PSK is empty without a key.
pub fn derive(psk: &[u8], client: &[u8; NONCE_LEN], robot: &[u8; NONCE_LEN]) -> (u64, [u8; 32]) {
    let prk = hmac(psk, &[b"omnikin-v2 session", client, robot]);
    let ks = hmac(&prk, &[b"omnikin-v2 key"]);
    let idb = hmac(&prk, &[b"omnikin-v2 id"]);
    let mut id = [0u8; 8];
    id.copy_from_slice(&idb[..8]);
    (u64::from_le_bytes(id).max(1), ks)
}

/// The robot's nonce for `client` in the epoch whose secret is `secret`, per the docs of
/// `omnikin::link::HandshakeSecrets`: `HMAC(secret, "omnikin-v3 robot nonce" |
/// client_nonce | len(peer) as u32 LE | peer)[..16]`; the harness's robot is on a point-to-point
/// link (no transport address: `peer` empty).
pub fn robot_nonce(secret: &[u8], client: &[u8; NONCE_LEN]) -> [u8; NONCE_LEN] {
    let full = hmac(
        secret,
        &[b"omnikin-v3 robot nonce", client, &0u32.to_le_bytes()],
    );
    let mut n = [0u8; NONCE_LEN];
    n.copy_from_slice(&full[..NONCE_LEN]);
    n
}

/// The [`OPENING_LEN`] bytes of an open frame's opening: `client_nonce | epoch:u32 LE |
/// flags:u8`.
pub fn opening_bytes(client: &[u8; NONCE_LEN], epoch: u32, flags: u8) -> [u8; OPENING_LEN] {
    let mut o = [0u8; OPENING_LEN];
    o[..NONCE_LEN].copy_from_slice(client);
    o[NONCE_LEN..NONCE_LEN + 4].copy_from_slice(&epoch.to_le_bytes());
    o[NONCE_LEN + 4] = flags;
    o
}

/// What the fuzzer chooses in one frame; the rest is computed by [`fixup`].
#[derive(Clone, Copy, Debug)]
pub struct FrameSpec<'a> {
    /// Version byte.
    pub version: u8,
    /// Kind byte (a tag is appended exactly when `kind & KIND_TAGGED`).
    pub kind: u8,
    /// Session id.
    pub session: u64,
    /// Sequence number.
    pub seq: u64,
    /// An open frame's opening, written between the header and the body (under the tag).
    pub opening: Option<[u8; OPENING_LEN]>,
    /// Body, as the fuzzer (or the harness) wrote it.
    pub body: &'a [u8],
    /// The MAC key of the tag: the PSK or a session key.
    pub mac_key: &'a [u8],
    /// `false`: one tag bit is flipped after the MAC is computed.
    pub tag_ok: bool,
    /// `false`: one CRC bit is flipped after the CRC is computed.
    pub crc_ok: bool,
}

impl FrameSpec<'_> {
    /// The bytes between the header and the tag: opening (if any) and body.
    fn after_header(&self) -> Vec<u8> {
        let mut v = self.opening.map(|o| o.to_vec()).unwrap_or_default();
        v.extend_from_slice(self.body);
        v
    }
}

/// The fix-up: the wire bytes of `spec` — header, opening, body, tag (the first [`TAG_LEN`]
/// bytes of HMAC-SHA256 under `spec.mac_key` over everything before it) when the kind says
/// so, CRC-32C, COBS, `0x00` — corrupted only where the spec asks. Returns the unstuffed
/// length.
pub fn fixup(spec: &FrameSpec<'_>, out: &mut Vec<u8>) -> usize {
    let mut raw = Vec::with_capacity(HEADER_LEN + OPENING_LEN + spec.body.len() + TAG_LEN + 4);
    raw.push(spec.version);
    raw.push(spec.kind);
    raw.extend_from_slice(&spec.session.to_le_bytes());
    raw.extend_from_slice(&spec.seq.to_le_bytes());
    if let Some(o) = &spec.opening {
        raw.extend_from_slice(o);
    }
    raw.extend_from_slice(spec.body);
    if spec.kind & KIND_TAGGED != 0 {
        let mut t = [0u8; TAG_LEN];
        t.copy_from_slice(&hmac(spec.mac_key, &[&raw])[..TAG_LEN]);
        if !spec.tag_ok {
            t[0] ^= 1;
        }
        raw.extend_from_slice(&t);
    }
    let mut crc = CRC.checksum(&raw);
    if !spec.crc_ok {
        crc ^= 1 << 7;
    }
    raw.extend_from_slice(&crc.to_le_bytes());
    out.clear();
    out.resize(cobs::max_encoding_length(raw.len()) + 1, 0);
    let n = cobs::try_encode(&raw, out).expect("buffer sized by max_encoding_length");
    out.truncate(n);
    out.push(0);
    raw.len()
}

/// Undoes [`fixup`] for a frame the robot sent (a HelloAck or a session frame, no opening):
/// `(kind, session, seq, body)` if COBS, CRC, version and the tag under `mac_key` (required
/// iff `tagged`) check out.
pub fn unwrap(wire: &[u8], mac_key: Option<&[u8]>) -> Option<(u8, u64, u64, Vec<u8>)> {
    let stuffed = wire.strip_suffix(&[0])?;
    let mut raw = vec![0u8; stuffed.len()];
    let n = cobs::decode(stuffed, &mut raw).ok()?;
    let raw = &raw[..n];
    let (data, crc) = raw.split_at(n.checked_sub(4)?);
    if CRC.checksum(data).to_le_bytes() != crc
        || data.first() != Some(&PROTOCOL_VERSION)
        || data.len() < HEADER_LEN
    {
        return None;
    }
    let kind = data[1];
    let u = |i: usize| u64::from_le_bytes(data[i..i + 8].try_into().expect("8 bytes"));
    let (session, seq) = (u(2), u(10));
    let (signed, tag) = match mac_key {
        Some(_) if kind & KIND_TAGGED == 0 => return None,
        Some(_) => data.split_at(data.len().checked_sub(TAG_LEN)?),
        None if kind & KIND_TAGGED != 0 => return None,
        None => (data, &[][..]),
    };
    if let Some(k) = mac_key
        && hmac(k, &[signed])[..TAG_LEN] != *tag
    {
        return None;
    }
    Some((
        kind & !KIND_TAGGED,
        session,
        seq,
        signed.get(HEADER_LEN..)?.to_vec(),
    ))
}

/// Why a frame should be dropped, as [`DropReason`] without its payload (and the host's
/// throttling, which never reaches the link's `receive`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// [`DropReason::Framing`].
    Framing,
    /// [`DropReason::Crc`].
    Crc,
    /// [`DropReason::Version`].
    Version,
    /// [`DropReason::Auth`].
    Auth,
    /// [`DropReason::Replay`].
    Replay,
    /// [`DropReason::Malformed`].
    Malformed,
    /// [`DropReason::Session`].
    Session,
    /// [`DropReason::Entropy`].
    Entropy,
    /// A Hello the host dropped unread ([`RobotLink::count_throttled`]).
    Throttled,
}

impl From<&DropReason> for Reason {
    fn from(r: &DropReason) -> Self {
        match r {
            DropReason::Framing => Reason::Framing,
            DropReason::Crc => Reason::Crc,
            DropReason::Version(_) => Reason::Version,
            DropReason::Auth => Reason::Auth,
            DropReason::Replay(_) => Reason::Replay,
            DropReason::Malformed => Reason::Malformed,
            DropReason::Session(_) => Reason::Session,
            DropReason::Entropy => Reason::Entropy,
        }
    }
}

/// The counter a result lands in (`None`: accepted).
pub fn counter(c: &LinkCounters, r: Option<Reason>) -> u32 {
    match r {
        None => c.ok,
        Some(Reason::Framing) => c.framing,
        Some(Reason::Crc) => c.crc,
        Some(Reason::Version) => c.version,
        Some(Reason::Auth) => c.auth,
        Some(Reason::Replay) => c.replay,
        Some(Reason::Malformed) => c.malformed,
        Some(Reason::Session) => c.session,
        Some(Reason::Entropy) => c.entropy,
        Some(Reason::Throttled) => c.throttled,
    }
}

/// Every field that counts a frame, summed independently of [`LinkCounters::dropped`]
/// (`stale` is not one: those frames are in `ok`).
fn total(c: &LinkCounters) -> u64 {
    [
        c.ok,
        c.framing,
        c.crc,
        c.version,
        c.auth,
        c.replay,
        c.malformed,
        c.session,
        c.entropy,
        c.throttled,
    ]
    .iter()
    .map(|&x| u64::from(x))
    .sum()
}

/// Reference replay window: the set of accepted sequence numbers, checked naively.
#[derive(Clone, Debug, Default)]
pub struct ReplayModel {
    seen: BTreeSet<u64>,
}

impl ReplayModel {
    /// Fresh: not 0, and above the highest accepted or within the 64 below it and not accepted
    /// before.
    pub fn fresh(&self, seq: u64) -> bool {
        let top = self.top();
        seq != 0 && (seq > top || (top - seq < 64 && !self.seen.contains(&seq)))
    }
    /// Highest accepted (0: none).
    pub fn top(&self) -> u64 {
        self.seen.last().copied().unwrap_or(0)
    }
    /// Records an accepted `seq` (forgets what fell out of the window).
    pub fn accept(&mut self, seq: u64) {
        self.seen.insert(seq);
        let top = self.top();
        self.seen = self.seen.split_off(&top.saturating_sub(63));
    }
}

/// The envelope checks of `parse_frame`, predicted from the spec: `Some(reason)` if the frame
/// dies there (length, CRC, version, kind, an open frame's length and flags).
fn envelope(spec: &FrameSpec<'_>, wire: &[u8], raw_len: usize) -> Option<Reason> {
    let data_len = raw_len - 4;
    let tagged = spec.kind & KIND_TAGGED != 0;
    let kind = spec.kind & !KIND_TAGGED;
    let start = if kind == KIND_OPEN {
        HEADER_LEN + OPENING_LEN
    } else {
        HEADER_LEN
    };
    let least = start + 1 + if tagged { TAG_LEN } else { 0 };
    if wire.len() - 1 > MAX_FRAME || raw_len < 15 {
        Some(Reason::Framing)
    } else if !spec.crc_ok {
        Some(Reason::Crc)
    } else if spec.version != PROTOCOL_VERSION {
        Some(Reason::Version)
    } else if data_len < HEADER_LEN + 1 {
        Some(Reason::Framing)
    } else if !matches!(kind, 1..=4) {
        Some(Reason::Malformed)
    } else if data_len < least {
        Some(Reason::Framing)
    } else if kind == KIND_OPEN && spec.after_header()[NONCE_LEN + 4] & !FLAG_TAKE_OVER != 0 {
        Some(Reason::Malformed)
    } else {
        None
    }
}

/// One handshake epoch as the model keeps it.
#[derive(Clone, Debug)]
struct EpochModel {
    number: u32,
    /// `None` once retired (its used list full).
    secret: Option<[u8; 32]>,
    started_us: u64,
    used: Vec<[u8; NONCE_LEN]>,
}

/// The model of the robot's handshake secrets, from the docs: a Hello is answered in the
/// current epoch, or in a new one when none exists, the current is retired, or it is
/// [`EPOCH_US`] old; an epoch takes first frames while it is one of the newest two and
/// younger than two epochs, for client nonces it has not opened a session for; it retires when
/// it has opened [`USED_PER_EPOCH`].
#[derive(Clone, Debug, Default)]
struct Epochs {
    /// Every epoch ever started, oldest first.
    all: Vec<EpochModel>,
    /// The mirror of the robot's entropy source.
    rng: FuzzEntropy,
}

impl Epochs {
    fn due(&self, now_us: u64) -> bool {
        self.all
            .last()
            .is_none_or(|e| e.secret.is_none() || now_us.saturating_sub(e.started_us) >= EPOCH_US)
    }

    /// Answers a Hello at `now_us`: the epoch's number and secret, after a rotation if one is
    /// due (`None`: it was due and the entropy fails).
    fn answer(&mut self, now_us: u64, fails: bool) -> Option<(u32, [u8; 32])> {
        if self.due(now_us) {
            if fails {
                return None;
            }
            let mut secret = [0u8; 32];
            self.rng
                .fill(&mut secret)
                .expect("the mirror does not fail");
            let number = match self.all.last() {
                Some(e) => e.number.wrapping_add(1),
                None => {
                    let mut b = [0u8; 4];
                    self.rng.fill(&mut b).expect("the mirror does not fail");
                    u32::from_le_bytes(b)
                }
            };
            self.all.push(EpochModel {
                number,
                secret: Some(secret),
                started_us: now_us,
                used: Vec::new(),
            });
        }
        let e = self.all.last().expect("an epoch");
        Some((e.number, e.secret.expect("a live current epoch")))
    }

    /// The index of the live epoch numbered `epoch` at `now_us`.
    fn live(&self, epoch: u32, now_us: u64) -> Option<usize> {
        let n = self.all.len();
        (n.saturating_sub(2)..n).find(|&i| {
            let e = &self.all[i];
            e.number == epoch
                && e.secret.is_some()
                && now_us.saturating_sub(e.started_us) < 2 * EPOCH_US
        })
    }
}

/// A session the robot answered a Hello for (as the operator that sent the Hello knows it).
#[derive(Clone, Debug)]
struct Known {
    id: u64,
    key: [u8; 32],
    client_nonce: [u8; NONCE_LEN],
    /// The epoch of the HelloAck.
    epoch: u32,
    window: ReplayModel,
    /// Last seq the harness sent in it (for delta-coded seqs).
    last_seq: u64,
    /// Robot → operator: highest seq seen.
    rx_top: u64,
}

/// Deterministic entropy for the robot; fails when told to.
#[derive(Clone, Debug, Default)]
pub struct FuzzEntropy {
    state: u64,
    /// The next `fill` fails.
    pub fail: bool,
}

impl Entropy for FuzzEntropy {
    fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError> {
        if self.fail {
            return Err(EntropyError);
        }
        for b in buf {
            // splitmix64
            self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            *b = (z ^ (z >> 31)) as u8;
        }
        Ok(())
    }
}

/// Ideal board: the encoders return the integral of the commanded motor rates.
#[derive(Clone, Copy, Debug, Default)]
pub struct Board {
    /// Wheel angles, rad.
    pub wheel: [f32; omnikin::MAX_WHEELS],
    /// Steer angles, rad.
    pub steer: [f32; omnikin::MAX_WHEELS],
    /// Last command.
    pub command: Option<MotorCommand<f32>>,
}

impl Encoders<f32> for Board {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<EncoderAngles<f32>, Self::Error> {
        Ok(EncoderAngles {
            wheel: self.wheel,
            steer: self.steer,
        })
    }
}

impl MotorOutputs<f32> for Board {
    type Error = core::convert::Infallible;
    fn set_rates(&mut self, command: &MotorCommand<f32>) -> Result<(), Self::Error> {
        self.command = Some(*command);
        Ok(())
    }
}

/// A small reader over the fuzzer's bytes; reads past the end yield zeros/empty.
pub struct Cursor<'a> {
    data: &'a [u8],
}

impl<'a> Cursor<'a> {
    /// Over `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Self { data }
    }
    /// Whether nothing is left.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
    /// Next byte (0 past the end).
    pub fn u8(&mut self) -> u8 {
        self.take(1).first().copied().unwrap_or(0)
    }
    /// Next `u16` LE.
    pub fn u16(&mut self) -> u16 {
        let b = self.take(2);
        u16::from_le_bytes([
            b.first().copied().unwrap_or(0),
            b.get(1).copied().unwrap_or(0),
        ])
    }
    /// Next `u32` LE.
    pub fn u32(&mut self) -> u32 {
        let b = self.take(4);
        let mut a = [0u8; 4];
        a[..b.len()].copy_from_slice(b);
        u32::from_le_bytes(a)
    }
    /// Next `u64` LE.
    pub fn u64(&mut self) -> u64 {
        let b = self.take(8);
        let mut a = [0u8; 8];
        a[..b.len()].copy_from_slice(b);
        u64::from_le_bytes(a)
    }
    /// Next 16 bytes (zero-filled past the end).
    pub fn nonce(&mut self) -> [u8; NONCE_LEN] {
        let b = self.take(NONCE_LEN);
        let mut a = [0u8; NONCE_LEN];
        a[..b.len()].copy_from_slice(b);
        a
    }
    /// Up to `n` bytes.
    pub fn take(&mut self, n: usize) -> &'a [u8] {
        let (a, b) = self.data.split_at(n.min(self.data.len()));
        self.data = b;
        a
    }
}

/// An open frame as the harness built it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct OpenSent {
    client_nonce: [u8; NONCE_LEN],
    epoch: u32,
    take_over: bool,
}

/// What the harness knows a frame to be, for the checks after delivery.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Sent {
    /// A Hello with this nonce: `auth_ok` its tag as the robot wants it, `body_len` its padded
    /// body, `protocol` the version it names; the robot's entropy fails for it; the host
    /// throttles it.
    Hello {
        nonce: [u8; NONCE_LEN],
        auth_ok: bool,
        body_len: usize,
        protocol: u8,
        entropy_fails: bool,
        throttled: bool,
    },
    /// A session frame (`open: None`) or an open frame to known session `k` (index into
    /// `known`), tag under K_s as the robot wants it (`auth_ok`).
    Frame {
        k: usize,
        auth_ok: bool,
        open: Option<OpenSent>,
    },
    /// Anything else (only counted, and never accepted unless it is a valid frame).
    Other,
}

/// What the model predicts for a frame past its envelope.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Want {
    Drop(Reason),
    /// A message of the active session, or of a session it opens.
    Message {
        new_session: bool,
    },
    /// A Busy answer.
    Busy,
    /// A HelloAck.
    Hello,
}

/// One frame's result from [`Session::deliver`]: the event, and where its reply is in the
/// reply arena.
type Got = (Result<RobotEvent, Reason>, usize, usize);

/// Whether an accepted e-stop with a higher sequence number voids `m` (the module docs of
/// `omnikin::link`, "E-stop ordering": a clear, or a motion command — velocity, the plan
/// messages, set-pose).
fn voided_by_estop(m: &Message) -> bool {
    matches!(
        m,
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

/// One fuzz input's run: a robot's link and runtime, and what the harness knows.
pub struct Session {
    keyed: bool,
    datagram: bool,
    caster: bool,
    link: RobotLink,
    info: RobotInfo,
    rng: FuzzEntropy,
    reader: FrameReader<MAX_FRAME>,
    runtime: Runtime<f32, PLAN_POINTS>,
    board: Board,
    /// The robot's handshake epochs, modelled.
    epochs: Epochs,
    /// Every HelloAck's session, in the order first answered.
    known: Vec<Known>,
    /// Every HelloAck seen, by (epoch, client nonce): a repeat must be identical.
    answers: BTreeMap<(u32, [u8; NONCE_LEN]), Vec<u8>>,
    /// Index into `known` of the robot's active session.
    active: Option<usize>,
    /// Robot time the active session opened and last had a frame accepted, µs.
    opened_us: u64,
    heard_us: u64,
    /// The active session's newest frame was a `Bye`: not live.
    left: bool,
    /// Sessions that were taken over: never again accepted.
    dead: BTreeSet<u64>,
    /// Every (session, seq) the robot accepted.
    accepted_seqs: BTreeSet<(u64, u64)>,
    /// Model of the telemetry's `ack_seq`, `estop_seq` and `clear_seq`, and of the e-stop
    /// barrier (the highest accepted e-stop of the active session).
    ack_seq: u64,
    estop_seq: u64,
    clear_seq: u64,
    barrier: u64,
    now_us: u64,
    wire: Vec<u8>,
    reply: Vec<u8>,
    /// The replies of one delivery, back to back.
    replies: Vec<u8>,
    /// The host throttles Hellos in the next delivery.
    throttle: bool,
    /// Undelimited junk is waiting in the stream reader.
    pending: bool,
    /// Frames accepted so far.
    pub accepted: u32,
    /// Busy answers so far.
    pub busy: u32,
}

impl Session {
    /// From the setup byte (see the module docs).
    pub fn new(setup: u8) -> Self {
        let keyed = setup & 1 != 0;
        let robot = presets()[usize::from(((setup >> 2) & 3).min(2))];
        let caster = matches!(robot, Robot::Caster(_));
        let mut cfg = Config::new(RATE_HZ);
        cfg.rate_limits = RateLimits {
            wheel: Some(WHEEL_LIMIT),
            steer: caster.then_some(STEER_LIMIT),
        };
        let key = keyed.then(|| Key::new(FUZZ_KEY).expect("key length"));
        let runtime = Runtime::new(robot, cfg, Pose2::default()).expect("valid config");
        let info = robot_info(&runtime, keyed);
        Self {
            keyed,
            datagram: setup & 2 != 0,
            caster,
            link: RobotLink::new(key),
            info,
            rng: FuzzEntropy::default(),
            reader: FrameReader::new(),
            runtime,
            board: Board::default(),
            epochs: Epochs::default(),
            known: Vec::new(),
            answers: BTreeMap::new(),
            active: None,
            opened_us: 0,
            heard_us: 0,
            left: false,
            dead: BTreeSet::new(),
            accepted_seqs: BTreeSet::new(),
            ack_seq: 0,
            estop_seq: 0,
            clear_seq: 0,
            barrier: 0,
            now_us: 1,
            wire: Vec::with_capacity(2 * MAX_FRAME),
            reply: vec![0u8; MAX_FRAME],
            replies: Vec::new(),
            throttle: false,
            pending: false,
            accepted: 0,
            busy: 0,
        }
    }

    fn psk(&self) -> &'static [u8] {
        if self.keyed { FUZZ_KEY } else { &[] }
    }

    /// Runs every record of `c`, checking each.
    pub fn run(&mut self, c: &mut Cursor<'_>) {
        while !c.is_empty() {
            let op = c.u8();
            match op & 7 {
                0 => self.hello(op, c),
                2 => self.any_frame(op, c),
                3 => {
                    for _ in 0..(c.u8() & 15) + 1 {
                        self.cycle();
                    }
                }
                4 => {
                    let n = usize::from(c.u8());
                    let mut junk = c.take(n).to_vec();
                    if op & 8 == 0 {
                        junk.push(0);
                    }
                    let results = self.deliver(&junk);
                    self.check_unpredicted(results);
                }
                6 => self.frame(op, c, true),
                7 => {
                    let dt = match (op >> 3) & 3 {
                        0 => u64::from(c.u8()) * 1_000,
                        1 => u64::from(c.u8()) * 100_000,
                        2 => u64::from(c.u8()) * 1_000_000,
                        _ => u64::from(c.u32()),
                    };
                    self.now_us += dt;
                }
                _ => self.frame(op, c, false),
            }
        }
    }

    fn tagged_kind(&self, kind: u8, op: u8) -> u8 {
        let mut k = kind | if self.keyed { KIND_TAGGED } else { 0 };
        if op & 32 != 0 {
            k ^= KIND_TAGGED;
        }
        k
    }

    fn hello(&mut self, op: u8, c: &mut Cursor<'_>) {
        let nonce = c.nonce();
        let (protocol, pad, host) = if op & 128 != 0 {
            (c.u8(), usize::from(c.u8()), c.u8())
        } else {
            (PROTOCOL_VERSION, HANDSHAKE_BODY, 0)
        };
        let hello = omnikin::link::Hello {
            protocol,
            client_nonce: nonce,
        };
        let mut body = postcard::to_allocvec(&hello).expect("a Hello encodes");
        if body.len() < pad {
            body.resize(pad, 0);
        }
        let kind = self.tagged_kind(KIND_HELLO, op);
        let spec = FrameSpec {
            version: PROTOCOL_VERSION,
            kind,
            session: 0,
            seq: 0,
            opening: None,
            body: &body,
            mac_key: FUZZ_KEY,
            tag_ok: op & 16 == 0,
            crc_ok: op & 8 == 0,
        };
        let tagged = kind & KIND_TAGGED != 0;
        let auth_ok = if self.keyed {
            tagged && spec.tag_ok
        } else {
            !tagged
        };
        self.rng.fail = op & 64 != 0;
        self.throttle = host & 1 != 0;
        let sent = Sent::Hello {
            nonce,
            auth_ok,
            body_len: body.len(),
            protocol,
            entropy_fails: self.rng.fail,
            throttled: self.throttle,
        };
        self.send(&spec, sent);
        self.rng.fail = false;
        self.throttle = false;
    }

    /// A session frame, or an open frame (`open`), to a known session.
    fn frame(&mut self, op: u8, c: &mut Cursor<'_>, open: bool) {
        let back = usize::from(c.u8());
        let seq_abs = (op & 64 != 0).then(|| c.u64());
        let delta = if seq_abs.is_none() { c.u8() as i8 } else { 0 };
        let (flags, epoch_delta) = if open { (c.u8(), c.u8() as i8) } else { (0, 0) };
        let len = usize::from(c.u16()).min(MAX_SPEC_BODY);
        let body = c.take(len);
        if self.known.is_empty() {
            return;
        }
        let k = self.known.len() - 1 - back % self.known.len();
        let s = &mut self.known[k];
        let seq = seq_abs.unwrap_or_else(|| s.last_seq.wrapping_add_signed(i64::from(delta)));
        s.last_seq = seq;
        let (id, ks) = (s.id, s.key);
        let opened = open.then(|| {
            let mut client_nonce = s.client_nonce;
            if flags & 2 != 0 {
                client_nonce[0] ^= 1;
            }
            OpenSent {
                client_nonce,
                epoch: s.epoch.wrapping_add_signed(i32::from(epoch_delta)),
                take_over: flags & 1 != 0,
            }
        });
        let opening = opened.map(|o| {
            let wire_flags = u8::from(o.take_over) | if flags & 4 != 0 { 0x80 } else { 0 };
            opening_bytes(&o.client_nonce, o.epoch, wire_flags)
        });
        let kind = self.tagged_kind(if open { KIND_OPEN } else { KIND_SESSION }, op);
        let psk_tag = op & 128 != 0;
        let spec = FrameSpec {
            version: PROTOCOL_VERSION,
            kind,
            session: id,
            seq,
            opening,
            body,
            mac_key: if psk_tag { FUZZ_KEY } else { &ks },
            tag_ok: op & 16 == 0,
            crc_ok: op & 8 == 0,
        };
        let auth_ok = if self.keyed {
            kind & KIND_TAGGED != 0 && spec.tag_ok && !psk_tag
        } else {
            kind & KIND_TAGGED == 0
        };
        self.send(
            &spec,
            Sent::Frame {
                k,
                auth_ok,
                open: opened,
            },
        );
    }

    fn any_frame(&mut self, op: u8, c: &mut Cursor<'_>) {
        let version = c.u8();
        let kind = c.u8();
        let session = c.u64();
        let seq = c.u64();
        let key_sel = c.u8();
        let len = usize::from(c.u16()).min(MAX_SPEC_BODY);
        let body = c.take(len);
        let ks = match (key_sel & 1, self.known.last()) {
            (1, Some(s)) => s.key,
            _ => [0u8; 32],
        };
        let spec = FrameSpec {
            version,
            kind,
            session,
            seq,
            opening: None,
            body,
            mac_key: if key_sel & 1 == 1 && !self.known.is_empty() {
                &ks
            } else {
                FUZZ_KEY
            },
            tag_ok: op & 16 == 0,
            crc_ok: op & 8 == 0,
        };
        self.send(&spec, Sent::Other);
    }

    /// The verdict on a frame's tag, sequence number and body in a session whose replay
    /// window is `window` (the robot's order: tag, window, body, direction).
    fn verdict(auth_ok: bool, window: &ReplayModel, seq: u64, body: &[u8]) -> Option<Reason> {
        if !auth_ok {
            Some(Reason::Auth)
        } else if !window.fresh(seq) {
            Some(Reason::Replay)
        } else {
            match omnikin::link::decode_message(body) {
                Err(_) => Some(Reason::Malformed),
                // A message for the other end (a robot's telemetry reflected back to it)
                // verifies under the shared K_s but is dropped as malformed before it can
                // move the replay window.
                Ok(
                    Message::Telemetry(_)
                    | Message::SessionEnd(_)
                    | Message::Estimate(_)
                    | Message::Truth(_)
                    | Message::Busy(_),
                ) => Some(Reason::Malformed),
                Ok(_) => None,
            }
        }
    }

    /// Whether the active session is live (a frame accepted within [`LIVE_US`], its newest
    /// not a `Bye`).
    fn live(&self) -> bool {
        self.active.is_some() && !self.left && self.now_us.saturating_sub(self.heard_us) < LIVE_US
    }

    /// The model's prediction for a session or open frame to known session `k`.
    fn predict(
        &self,
        spec: &FrameSpec<'_>,
        k: usize,
        auth_ok: bool,
        open: Option<OpenSent>,
    ) -> Want {
        let s = &self.known[k];
        let drop_or = |r: Option<Reason>, w: Want| r.map_or(w, Want::Drop);
        if self.active == Some(k) {
            // The active session's frames, open or not: the opening plays no part.
            return drop_or(
                Self::verdict(auth_ok, &s.window, spec.seq, spec.body),
                Want::Message { new_session: false },
            );
        }
        let Some(o) = open else {
            return Want::Drop(Reason::Session);
        };
        // Cheap refusals first: an epoch that is not live, a used nonce; then the session id
        // the opening gives, then key confirmation.
        let Some(e) = self.epochs.live(o.epoch, self.now_us) else {
            return Want::Drop(Reason::Session);
        };
        let e = &self.epochs.all[e];
        if e.used.contains(&o.client_nonce) {
            return Want::Drop(Reason::Replay);
        }
        let rn = robot_nonce(&e.secret.expect("live"), &o.client_nonce);
        if derive(self.psk(), &o.client_nonce, &rn).0 != spec.session {
            return Want::Drop(Reason::Session);
        }
        if let Some(r) = Self::verdict(auth_ok, &ReplayModel::default(), spec.seq, spec.body) {
            return Want::Drop(r);
        }
        if self.live() && !o.take_over {
            Want::Busy
        } else {
            Want::Message { new_session: true }
        }
    }

    /// Fixes `spec` up, delivers it and checks the outcome.
    fn send(&mut self, spec: &FrameSpec<'_>, sent: Sent) {
        let mut wire = std::mem::take(&mut self.wire);
        let raw_len = fixup(spec, &mut wire);
        let unpredictable = self.pending;
        let results = self.deliver(&wire);
        let stuffed = wire.len() - 1;
        self.wire = wire;
        if unpredictable {
            // The junk before it made it another frame: only its counting is checked.
            self.check_unpredicted(results);
            return;
        }
        let [(got, start, n)] = results.as_slice() else {
            panic!("one frame, {} results", results.len());
        };
        let (got, reply) = (got.clone(), self.replies[*start..*start + *n].to_vec());
        let env = envelope(spec, &self.wire, raw_len);
        let want = match sent {
            Sent::Hello {
                throttled: true, ..
            } => {
                // The host looks at the kind only (a Hello is visibly one, corrupt or not).
                assert_eq!(
                    peek_kind(&self.wire[..stuffed]),
                    Some(FrameKind::Hello),
                    "peek_kind of a Hello"
                );
                Want::Drop(Reason::Throttled)
            }
            _ if env.is_some() => Want::Drop(env.expect("some")),
            Sent::Hello {
                auth_ok,
                body_len,
                protocol,
                entropy_fails,
                ..
            } => {
                if !auth_ok {
                    Want::Drop(Reason::Auth)
                } else if body_len < HANDSHAKE_BODY {
                    Want::Drop(Reason::Malformed)
                } else if protocol != PROTOCOL_VERSION {
                    Want::Drop(Reason::Version)
                } else if entropy_fails && self.epochs.due(self.now_us) {
                    Want::Drop(Reason::Entropy)
                } else {
                    Want::Hello
                }
            }
            Sent::Frame { k, auth_ok, open } => self.predict(spec, k, auth_ok, open),
            Sent::Other => {
                // Only its counting and what any accepted frame must satisfy.
                self.check_result(got, &reply, Some(spec), Some(stuffed));
                self.check_state();
                return;
            }
        };
        match (&got, want) {
            (Err(r), Want::Drop(w)) => assert_eq!(*r, w, "{spec:?}"),
            (Ok(RobotEvent::Hello(_)), Want::Hello) => {
                let Sent::Hello { nonce, .. } = sent else {
                    unreachable!("a Hello was sent")
                };
                self.check_ack(&reply, Some(stuffed), nonce);
            }
            (Ok(RobotEvent::Busy(_)), Want::Busy) => {
                let Sent::Frame { k, .. } = sent else {
                    unreachable!("a frame was sent")
                };
                self.check_busy(k, &reply, Some(spec.seq), stuffed);
            }
            (Ok(RobotEvent::Message { new_session, .. }), Want::Message { new_session: n }) => {
                assert_eq!(*new_session, n, "new_session of {spec:?}");
                self.check_result(got, &reply, Some(spec), Some(stuffed));
            }
            (got, want) => panic!("{spec:?}\n{sent:?}\ngot {got:?}, the model wants {want:?}"),
        }
        self.check_state();
    }

    /// After every delivery: the robot's active session is the model's, and the robot drew
    /// exactly the entropy the model did.
    fn check_state(&self) {
        assert_eq!(
            self.link.session_id(),
            self.active.map(|k| self.known[k].id),
            "the active session"
        );
        assert_eq!(
            self.rng.state, self.epochs.rng.state,
            "the robot drew other entropy than the model's epochs"
        );
    }

    /// The HelloAck `reply` for a Hello with `nonce` of `hello_len` stuffed bytes: no larger
    /// than the Hello; decodes under the PSK with session and seq 0; echoes the nonce; names
    /// this robot and the model's current epoch; carries the model's robot nonce; identical to
    /// every earlier answer to that nonce in that epoch. Learns the session it offers.
    fn check_ack(&mut self, reply: &[u8], hello_len: Option<usize>, nonce: [u8; NONCE_LEN]) {
        let (epoch, secret) = self
            .epochs
            .answer(self.now_us, false)
            .expect("an answered Hello had its epoch");
        if let Some(h) = hello_len {
            assert!(
                reply.len() - 1 <= h,
                "HelloAck of {} bytes for a Hello of {h}",
                reply.len()
            );
        }
        let psk = self.psk();
        let (kind, session, seq, body) =
            unwrap(reply, self.keyed.then_some(psk)).expect("the HelloAck decodes under the PSK");
        assert_eq!((kind, session, seq), (KIND_HELLO_ACK, 0, 0));
        let ack: HelloAck = postcard::from_bytes(&body).expect("a HelloAck body");
        assert_eq!(ack.client_nonce, nonce);
        assert_eq!(ack.info, self.info);
        assert_eq!(ack.epoch, epoch, "the HelloAck's epoch");
        assert_eq!(
            ack.robot_nonce,
            robot_nonce(&secret, &nonce),
            "the robot nonce is the documented PRF of the epoch's secret"
        );
        match self.answers.get(&(epoch, nonce)) {
            Some(before) => assert_eq!(
                before.as_slice(),
                reply,
                "two identical Hellos in one epoch got different answers"
            ),
            None => {
                self.answers.insert((epoch, nonce), reply.to_vec());
            }
        }
        let (id, key) = derive(psk, &nonce, &ack.robot_nonce);
        if !self.known.iter().any(|s| s.id == id) {
            self.known.push(Known {
                id,
                key,
                client_nonce: nonce,
                epoch,
                window: ReplayModel::default(),
                last_seq: 0,
                rx_top: 0,
            });
        }
    }

    /// A Busy answer `reply` to an authentic open frame of known session `k` (seq `seq` if
    /// known, `frame_len` stuffed bytes): the active session is live and stays; the answer is
    /// smaller than the frame, in session `k` under its key at the frame's seq, and names the
    /// holder, its idle time and how long it has held the robot.
    fn check_busy(&mut self, k: usize, reply: &[u8], seq: Option<u64>, frame_len: usize) {
        let a = self.active.expect("Busy without an active session");
        assert!(self.live(), "Busy although the active session is not live");
        assert!(
            reply.len() - 1 < frame_len,
            "a Busy answer of {} bytes to a frame of {frame_len}",
            reply.len()
        );
        let s = &self.known[k];
        let (kind, session, rseq, body) = unwrap(reply, self.keyed.then_some(&s.key[..]))
            .expect("Busy decodes under the new session's key");
        assert_eq!((kind, session), (KIND_SESSION, s.id));
        if let Some(seq) = seq {
            assert_eq!(rseq, seq, "Busy echoes the open frame's seq");
        }
        self.busy += 1;
        // A Busy answer uses the handshake up: its nonce opens nothing later.
        let (epoch, nonce) = (s.epoch, s.client_nonce);
        let e = self
            .epochs
            .live(epoch, self.now_us)
            .expect("a Busy answer in an epoch that is not live");
        let e = &mut self.epochs.all[e];
        assert!(!e.used.contains(&nonce), "Busy to a used client nonce");
        e.used.push(nonce);
        if e.used.len() >= USED_PER_EPOCH {
            e.secret = None;
        }
        let m: Message = postcard::from_bytes(&body).expect("a message");
        let want = Busy {
            holder: self.known[a].id,
            idle_ms: (self.now_us.saturating_sub(self.heard_us) / 1_000) as u32,
            held_s: (self.now_us.saturating_sub(self.opened_us) / 1_000_000) as u32,
        };
        assert_eq!(m, Message::Busy(want));
    }

    /// Checks what any result must satisfy, and updates the model.
    fn check_result(
        &mut self,
        got: Result<RobotEvent, Reason>,
        reply: &[u8],
        spec: Option<&FrameSpec<'_>>,
        frame_len: Option<usize>,
    ) {
        match got {
            Ok(RobotEvent::Hello(_)) => {
                // Learn the session from the answer (its nonce is the Hello's).
                let (_, _, _, body) =
                    unwrap(reply, self.keyed.then_some(self.psk())).expect("HelloAck");
                let ack: HelloAck = postcard::from_bytes(&body).expect("a HelloAck body");
                self.check_ack(reply, frame_len, ack.client_nonce);
            }
            Ok(RobotEvent::Busy(_)) => {
                let k = (0..self.known.len())
                    .find(|&k| {
                        unwrap(reply, self.keyed.then_some(&self.known[k].key[..]))
                            .is_some_and(|(_, id, _, _)| id == self.known[k].id)
                    })
                    .expect("Busy in a session a Hello was answered for");
                self.check_busy(
                    k,
                    reply,
                    spec.map(|s| s.seq),
                    frame_len.unwrap_or(MAX_FRAME),
                );
            }
            Ok(RobotEvent::Message {
                seq,
                msg,
                new_session,
                replaced,
            }) => {
                let id = self
                    .link
                    .session_id()
                    .expect("a message leaves an active session");
                let k = self
                    .known
                    .iter()
                    .position(|s| s.id == id)
                    .expect("accepted a frame of a session no Hello was answered for");
                assert!(
                    !self.dead.contains(&id),
                    "accepted a frame of a session that was taken over"
                );
                assert!(
                    self.accepted_seqs.insert((id, seq)),
                    "accepted ({id:#x}, {seq}) twice"
                );
                assert!(
                    self.known[k].window.fresh(seq),
                    "accepted a stale seq {seq}"
                );
                if let Some(spec) = spec {
                    assert_eq!((spec.session, spec.seq), (id, seq));
                    if self.keyed {
                        assert_eq!(spec.mac_key, self.known[k].key, "accepted a wrong key");
                        assert!(spec.tag_ok, "accepted a corrupt tag");
                    }
                    // Canonical or not, what decodes re-encodes to at most its bytes, and
                    // that encoding is a fixed point.
                    let enc = postcard::to_allocvec(&msg).expect("encodes");
                    assert!(enc.len() <= spec.body.len());
                    let back: Message = postcard::from_bytes(&enc).expect("decodes");
                    assert_eq!(postcard::to_allocvec(&back).expect("encodes"), enc);
                }
                assert_eq!(new_session, self.active != Some(k), "new_session flag");
                self.known[k].window.accept(seq);
                self.accepted += 1;
                if new_session {
                    // Only a first frame in a live epoch whose nonce opened nothing yet.
                    let (epoch, nonce) = (self.known[k].epoch, self.known[k].client_nonce);
                    let e = self
                        .epochs
                        .live(epoch, self.now_us)
                        .expect("a session opened in an epoch that is not live");
                    let e = &mut self.epochs.all[e];
                    assert!(
                        !e.used.contains(&nonce),
                        "a used client nonce opened a session again"
                    );
                    e.used.push(nonce);
                    if e.used.len() >= USED_PER_EPOCH {
                        e.secret = None;
                    }
                    if let Some(old) = self.active {
                        let n = replaced.expect("a takeover tells the previous operator");
                        assert!(n > 0);
                        let old = self.known[old].clone();
                        let (kind, session, oseq, body) =
                            unwrap(reply, self.keyed.then_some(&old.key[..]))
                                .expect("SessionEnd decodes under the old session's key");
                        assert_eq!((kind, session), (KIND_SESSION, old.id));
                        assert!(oseq > old.rx_top);
                        let m: Message = postcard::from_bytes(&body).expect("a message");
                        assert_eq!(m, Message::SessionEnd(EndReason::TakenOver));
                        self.dead.insert(old.id);
                    } else {
                        assert!(replaced.is_none());
                    }
                    self.active = Some(k);
                    self.opened_us = self.now_us;
                    self.heard_us = self.now_us;
                    self.left = matches!(msg, Message::Bye);
                    self.ack_seq = seq;
                    self.estop_seq = 0;
                    self.clear_seq = 0;
                    self.barrier = 0;
                } else {
                    assert!(replaced.is_none());
                    self.ack_seq = self.ack_seq.max(seq);
                    self.heard_us = self.heard_us.max(self.now_us);
                    self.left = matches!(msg, Message::Bye);
                }
                self.serve(seq, &msg);
            }
            Err(Reason::Entropy) => {
                assert!(
                    self.rng.fail && self.epochs.due(self.now_us),
                    "Entropy without a failing source or a due epoch"
                );
            }
            Err(_) => {}
        }
    }

    fn check_unpredicted(&mut self, results: Vec<Got>) {
        for (r, start, n) in results {
            let reply = self.replies[start..start + n].to_vec();
            self.check_result(r, &reply, None, None);
        }
        self.check_state();
    }

    /// Feeds `bytes` to the reader and each frame to the robot (or, for a Hello while the host
    /// throttles, to its counter); returns what it reported, after checking that every frame
    /// was counted in exactly one counter, that the receive path did not allocate and that
    /// the replies, together, are no larger than the frames.
    fn deliver(&mut self, bytes: &[u8]) -> Vec<Got> {
        let before = *self.link.counters();
        // Room for every frame `bytes` can hold, and for their replies, so that collecting
        // does not allocate.
        let mut results = Vec::with_capacity(bytes.len() + 1);
        self.replies.clear();
        self.replies.reserve(bytes.len() + MAX_FRAME);
        let link = &mut self.link;
        let (info, rng, reply) = (&self.info, &mut self.rng, &mut self.reply);
        let (datagram, throttle, now) = (self.datagram, self.throttle, self.now_us);
        let reader = &mut self.reader;
        let replies = &mut self.replies;
        let (tail, usage) = measure(|| {
            reader.feed(bytes, |f| match f {
                Some(f) if throttle && peek_kind(f) == Some(FrameKind::Hello) => {
                    link.count_throttled();
                    results.push((Err(Reason::Throttled), 0, 0));
                }
                Some(f) => {
                    let r = link.receive(f, now, &[], info, rng, &mut reply[..]);
                    let n = match &r {
                        Ok(RobotEvent::Hello(n) | RobotEvent::Busy(n)) => *n,
                        Ok(RobotEvent::Message {
                            replaced: Some(n), ..
                        }) => *n,
                        _ => 0,
                    };
                    let start = replies.len();
                    assert!(
                        start + n <= replies.capacity(),
                        "the replies outgrew the frames they answer"
                    );
                    replies.extend_from_slice(&reply[..n]);
                    results.push((r.map_err(|e| Reason::from(&e)), start, n));
                }
                None => {
                    link.count_framing_drop();
                    results.push((Err(Reason::Framing), 0, 0));
                }
            });
            if datagram && reader.end_of_datagram() {
                link.count_framing_drop();
                1
            } else {
                0
            }
        });
        assert_eq!(usage.allocations, 0, "the receive path allocated");
        let after = *self.link.counters();
        assert_eq!(
            total(&after) - total(&before),
            results.len() as u64 + tail,
            "every frame counted in exactly one counter ({before:?} -> {after:?})"
        );
        assert_eq!(
            u64::from(after.ok) + u64::from(after.dropped()),
            total(&after),
            "dropped() sums the drop counters"
        );
        assert_eq!(after.stale, before.stale, "receive counted a frame stale");
        if let [(r, _, _)] = results.as_slice()
            && tail == 0
        {
            let r = r.as_ref().err().copied();
            assert_eq!(counter(&after, r), counter(&before, r) + 1, "{r:?}");
        }
        if let Some(&last) = bytes.last() {
            self.pending = !self.datagram && last != 0;
        }
        results
    }

    /// Hands an accepted message to the runtime through `serve`: a clear or motion command
    /// below the e-stop barrier is stale — counted, and nothing in the runtime changes.
    fn serve(&mut self, seq: u64, m: &Message) {
        let before = *self.link.counters();
        let (mode, rejected) = (self.runtime.mode(), self.runtime.rejected());
        let stale = voided_by_estop(m) && seq < self.barrier;
        let r = serve(&mut self.runtime, &mut self.link, seq, m, self.now_us);
        let after = *self.link.counters();
        assert_eq!(
            r == Served::Stale,
            stale,
            "{m:?} at {seq}, barrier {}",
            self.barrier
        );
        assert_eq!(
            after.stale - before.stale,
            u32::from(stale),
            "the stale counter"
        );
        assert_eq!(total(&after), total(&before), "serve counted a frame");
        if matches!(m, Message::EStop) {
            // Every authentic e-stop raises the barrier, taken by the runtime or not.
            self.barrier = self.barrier.max(seq);
        }
        match r {
            Served::Ignored if matches!(m, Message::Bye) => {}
            Served::Ignored => panic!("an accepted operator message was ignored: {m:?}"),
            Served::Stale => {
                assert_eq!(self.runtime.mode(), mode, "a stale {m:?} changed the mode");
                assert_eq!(self.runtime.rejected(), rejected);
            }
            Served::Accepted => match m {
                Message::EStop => {
                    self.estop_seq = seq;
                }
                Message::Clear => {
                    if self.estop_seq != 0 {
                        self.clear_seq = seq;
                    }
                    self.estop_seq = 0;
                }
                _ => {}
            },
            Served::Rejected(_) => {}
        }
    }

    fn cycle(&mut self) {
        let dt_us = (1e6 / RATE_HZ) as u64;
        self.now_us += dt_us;
        let mut board = self.board;
        self.runtime
            .cycle(self.now_us, &mut board, &mut NoImu, &mut self.board);
        let st = self.runtime.status();
        let cmd = self.board.command.expect("cycle sets the motors");
        assert_eq!(cmd, st.motors);
        let dt = 1.0 / RATE_HZ;
        for i in 0..omnikin::MAX_WHEELS {
            let (w, s) = (cmd.wheel[i], cmd.steer[i]);
            assert!(w.is_finite() && s.is_finite(), "motor command {cmd:?}");
            assert!(w.abs() <= WHEEL_LIMIT * 1.0001, "wheel {w} over the limit");
            if self.caster {
                assert!(s.abs() <= STEER_LIMIT * 1.0001, "steer {s} over the limit");
            } else {
                assert_eq!(s, 0.0);
            }
            self.board.wheel[i] += w * dt;
            self.board.steer[i] += s * dt;
        }
        assert!(st.pose.x.is_finite() && st.pose.y.is_finite() && st.pose.heading.is_finite());
        if self.estop_seq != 0 {
            // Latched by an accepted e-stop and not cleared by a newer clear: nothing older
            // (held back, replayed) undid it.
            assert_eq!(
                st.mode,
                Mode::EStop,
                "the e-stop of seq {} was undone",
                self.estop_seq
            );
            assert!(cmd.wheel.iter().all(|&w| w == 0.0), "motors run in e-stop");
        }
        // Telemetry goes to the active session only, under its key, with fresh seqs, and
        // says which command it has seen, which e-stop it confirms and which clear ended one.
        let t = self.link.telemetry(&st);
        let mut out = [0u8; MAX_FRAME];
        let r = self.link.encode(&Message::Telemetry(t), &mut out);
        let Some(a) = self.active else {
            assert!(r.is_err(), "telemetry without a session");
            return;
        };
        let n = r.expect("telemetry encodes in the active session");
        let s = &mut self.known[a];
        let (kind, session, seq, body) = unwrap(&out[..n], self.keyed.then_some(&s.key[..]))
            .expect("telemetry decodes under K_s");
        assert_eq!((kind, session), (KIND_SESSION, s.id));
        assert!(seq > s.rx_top, "telemetry seq {seq} not above {}", s.rx_top);
        s.rx_top = seq;
        let Message::Telemetry(t) = postcard::from_bytes(&body).expect("a message") else {
            panic!("not telemetry");
        };
        assert_eq!(t.ack_seq, self.ack_seq, "ack_seq");
        let estop = if st.mode == Mode::EStop {
            self.estop_seq
        } else {
            0
        };
        assert_eq!(t.estop_seq, estop, "estop_seq");
        assert_eq!(t.clear_seq, self.clear_seq, "clear_seq");
        assert_eq!(t.link, *self.link.counters(), "the telemetry's counters");
    }
}

/// The three presets in `f32`, built once (parsing their TOML per input would dominate).
fn presets() -> &'static [Robot<f32>; 3] {
    static P: std::sync::OnceLock<[Robot<f32>; 3]> = std::sync::OnceLock::new();
    P.get_or_init(|| {
        ["sphere-omni", "ballbot", "caster3"].map(|n| {
            omnikin::description::RobotDescription::preset(n)
                .expect("preset")
                .build()
                .expect("preset builds")
        })
    })
}

/// The robot the raw `frame_decoder` target serves.
pub fn raw_info() -> RobotInfo {
    RobotInfo {
        protocol: PROTOCOL_VERSION,
        kind: omnikin::link::RobotKind::Sphere,
        plan_capacity: 256,
        rate_hz: 100.0,
        watchdog: 0.5,
        authenticated: false,
        limits: omnikin::link::RobotLimits {
            max_accel: 1.0,
            max_yaw_accel: 4.0,
            max_jerk: f32::INFINITY,
        },
    }
}

/// Bytes of a Hello record with `nonce`, valid.
pub fn hello_record(nonce: u8) -> Vec<u8> {
    let mut r = vec![0u8];
    r.extend_from_slice(&[nonce; NONCE_LEN]);
    r
}

/// Bytes of a valid session-frame record to handshake `back` (0: the newest) with an absolute
/// `seq`.
pub fn record_to(back: u8, msg: &Message, seq: u64) -> Vec<u8> {
    let body = postcard::to_allocvec(msg).expect("seed message encodes");
    let mut r = vec![1u8 | 64, back];
    r.extend_from_slice(&seq.to_le_bytes());
    r.extend_from_slice(&(body.len() as u16).to_le_bytes());
    r.extend_from_slice(&body);
    r
}

/// Bytes of a valid session-frame record to the newest handshake with an absolute `seq`.
pub fn record(msg: &Message, seq: u64) -> Vec<u8> {
    record_to(0, msg, seq)
}

/// Bytes of a valid open-frame record (the first frames of a session) to handshake `back`
/// (0: the newest) with an absolute `seq`, asking to take over or not.
pub fn open_record(back: u8, msg: &Message, seq: u64, take_over: bool) -> Vec<u8> {
    let body = postcard::to_allocvec(msg).expect("seed message encodes");
    let mut r = vec![6u8 | 64, back];
    r.extend_from_slice(&seq.to_le_bytes());
    r.extend_from_slice(&[u8::from(take_over), 0]);
    r.extend_from_slice(&(body.len() as u16).to_le_bytes());
    r.extend_from_slice(&body);
    r
}

/// A cycle record of `n` (1–16) control periods.
pub fn cycles(n: u8) -> [u8; 2] {
    [3, n.clamp(1, 16) - 1]
}

/// A clock record: the robot's clock advances `tenths` × 100 ms.
pub fn clock(tenths: u8) -> [u8; 2] {
    [7 | (1 << 3), tenths]
}

/// A clock record: the robot's clock advances `us` µs.
pub fn clock_us(us: u32) -> Vec<u8> {
    let mut r = vec![7 | (3 << 3)];
    r.extend_from_slice(&us.to_le_bytes());
    r
}

/// What one input's run came to (for checking that a seed reaches its path).
#[derive(Clone, Copy, Debug)]
pub struct Summary {
    /// Frames accepted (messages of a session).
    pub accepted: u32,
    /// Busy answers.
    pub busy: u32,
    /// The robot's counters at the end.
    pub counters: LinkCounters,
}

/// Runs one structured input, checking every frame; what it came to.
pub fn run_summary(data: &[u8]) -> Summary {
    let mut c = Cursor::new(data);
    let mut s = Session::new(c.u8());
    s.run(&mut c);
    Summary {
        accepted: s.accepted,
        busy: s.busy,
        counters: *s.link.counters(),
    }
}

/// Runs one structured input (the `link_session` target); returns the frames accepted.
pub fn run_session(data: &[u8]) -> u32 {
    run_summary(data).accepted
}
