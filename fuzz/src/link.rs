//! The link harness (wire v2): a structured input — handshakes and session frames whose
//! header fields, nonces and body bytes the fuzzer chooses — that [`fixup`] turns into wire
//! frames with a correct tag (under the PSK for handshake frames, under the session key K_s
//! for session frames), CRC and COBS stuffing. So mutated inputs get past the CRC and the MAC
//! and reach the handshake, the session lookup, the replay windows, the postcard body decoder
//! and the robot runtime. [`Session`] runs one input against a robot's [`RobotLink`] and
//! [`Runtime`] and checks every frame against a model of the protocol written from the
//! format's documentation (`omnikin::link` module docs), with its own HMAC key derivation.
//!
//! ## Input format
//! ```text
//! setup:u8  bit 0 keyed (PSK FUZZ_KEY), bit 1 datagram transport, bits 2-3 robot
//!           (0 sphere, 1 ballbot, 2-3 caster)
//! record*   op:u8, then by op & 7:
//!   0     Hello: client_nonce[16]; [protocol:u8, pad:u8 if bit 7];
//!         bit 6: the robot's entropy source fails for this one
//!   1, 5-7 session frame to handshake k (k:u8, 0 = the newest answered Hello): seq (bit 6:
//!         u64 LE; else i8 delta from the last seq sent in that session), len:u16 LE,
//!         body[len]; bit 7: tagged under the PSK instead of K_s
//!   2     any frame: version:u8, kind:u8, session:u64, seq:u64, key:u8 (0 PSK, 1 newest
//!         K_s), len:u16 LE, body[len]
//!   3     cycles: n:u8 -> (n & 15) + 1 control periods, each followed by a telemetry frame
//!   4     junk: len:u8, bytes[len], fed as they are; then a 0x00 unless bit 3 is set (on a
//!         stream the next frame then starts with them)
//! Hello, session and any frame: bit 3 corrupts the CRC, bit 4 the tag, bit 5 toggles the
//! tag's presence (a keyed robot wants one, an unkeyed one none).
//! ```
//! Everything computed rather than chosen — tag, CRC, stuffing, delimiter — is the one
//! function [`fixup`].

use std::collections::BTreeSet;

use hmac::{Hmac, Mac};
use omnikin::link::{
    DropReason, EndReason, FrameReader, HANDSHAKE_BODY, HEADER_LEN, HelloAck, KIND_TAGGED, Key,
    LinkCounters, MAX_FRAME, Message, NONCE_LEN, PENDING_SLOTS, PROTOCOL_VERSION, RobotEvent,
    RobotInfo, RobotLink, Served, TAG_LEN, robot_info, serve,
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
    /// Body, as the fuzzer (or the harness) wrote it.
    pub body: &'a [u8],
    /// The MAC key of the tag: the PSK or a session key.
    pub mac_key: &'a [u8],
    /// `false`: one tag bit is flipped after the MAC is computed.
    pub tag_ok: bool,
    /// `false`: one CRC bit is flipped after the CRC is computed.
    pub crc_ok: bool,
}

/// The fix-up: the wire bytes of `spec` — header, body, tag (the first [`TAG_LEN`] bytes of
/// HMAC-SHA256 under `spec.mac_key` over header and body) when the kind says so, CRC-32C,
/// COBS, `0x00` — corrupted only where the spec asks. Returns the unstuffed length.
pub fn fixup(spec: &FrameSpec<'_>, out: &mut Vec<u8>) -> usize {
    let mut raw = Vec::with_capacity(HEADER_LEN + spec.body.len() + TAG_LEN + 4);
    raw.push(spec.version);
    raw.push(spec.kind);
    raw.extend_from_slice(&spec.session.to_le_bytes());
    raw.extend_from_slice(&spec.seq.to_le_bytes());
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

/// Undoes [`fixup`] for a frame the robot sent: `(kind, session, seq, body)` if COBS, CRC,
/// version and the tag under `mac_key` (required iff `tagged`) check out.
pub fn unwrap(wire: &[u8], mac_key: Option<&[u8]>) -> Option<(u8, u64, u64, Vec<u8>)> {
    let stuffed = wire.strip_suffix(&[0])?;
    let mut raw = vec![0u8; stuffed.len()];
    let n = cobs::decode(stuffed, &mut raw).ok()?;
    let raw = &raw[..n];
    let (data, crc) = raw.split_at(n.checked_sub(4)?);
    if CRC.checksum(data).to_le_bytes() != crc || data.first() != Some(&PROTOCOL_VERSION) {
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
        signed[HEADER_LEN..].to_vec(),
    ))
}

/// Why a frame should be dropped, as [`DropReason`] without its payload.
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
    }
}

fn total(c: &LinkCounters) -> u64 {
    u64::from(c.ok) + u64::from(c.dropped())
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
        let top = self.seen.last().copied().unwrap_or(0);
        seq != 0 && (seq > top || (top - seq < 64 && !self.seen.contains(&seq)))
    }
    /// Records an accepted `seq` (forgets what fell out of the window).
    pub fn accept(&mut self, seq: u64) {
        self.seen.insert(seq);
        let top = self.seen.last().copied().unwrap_or(0);
        self.seen = self.seen.split_off(&top.saturating_sub(63));
    }
}

/// The envelope checks of `parse_frame`, predicted from the spec: `Some(reason)` if the frame
/// dies there.
fn envelope(spec: &FrameSpec<'_>, wire: &[u8], raw_len: usize) -> Option<Reason> {
    let data_len = raw_len - 4;
    let tagged = spec.kind & KIND_TAGGED != 0;
    if wire.len() - 1 > MAX_FRAME || raw_len < 15 {
        Some(Reason::Framing)
    } else if !spec.crc_ok {
        Some(Reason::Crc)
    } else if spec.version != PROTOCOL_VERSION {
        Some(Reason::Version)
    } else if data_len < HEADER_LEN + 1 {
        Some(Reason::Framing)
    } else if !matches!(spec.kind & !KIND_TAGGED, 1..=3) {
        Some(Reason::Malformed)
    } else if tagged && data_len < HEADER_LEN + TAG_LEN + 1 {
        Some(Reason::Framing)
    } else {
        None
    }
}

/// A session the robot answered a Hello for (as the operator that sent the Hello knows it).
#[derive(Clone, Debug)]
struct Known {
    id: u64,
    key: [u8; 32],
    client_nonce: [u8; NONCE_LEN],
    window: ReplayModel,
    /// Last seq the harness sent in it (for delta-coded seqs).
    last_seq: u64,
    /// Robot → operator: highest telemetry seq seen.
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

/// What the harness knows a frame to be, for the checks after delivery.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Sent {
    /// A Hello with this nonce; `valid`: tag, padding and protocol as the robot wants them.
    Hello {
        nonce: [u8; NONCE_LEN],
        auth_ok: bool,
        valid: bool,
        entropy_fails: bool,
    },
    /// A session frame to known session `k` (index into `known`), tag under K_s as the robot
    /// wants it (`auth_ok`).
    Session { k: usize, auth_ok: bool },
    /// Anything else (only counted, and never accepted unless it is a valid frame).
    Other,
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
    known: Vec<Known>,
    /// Index into `known` of the robot's active session.
    active: Option<usize>,
    /// Indices into `known` of the pending sessions, oldest first (at most
    /// [`PENDING_SLOTS`]; a new one replaces the oldest).
    pending_sessions: Vec<usize>,
    /// Sessions that were taken over: never again accepted.
    dead: BTreeSet<u64>,
    /// Every (session, seq) the robot accepted.
    accepted_seqs: BTreeSet<(u64, u64)>,
    /// Model of the telemetry's `ack_seq` and `estop_seq`.
    ack_seq: u64,
    estop_seq: u64,
    now_us: u64,
    wire: Vec<u8>,
    reply: Vec<u8>,
    /// Undelimited junk is waiting in the stream reader.
    pending: bool,
    /// Frames accepted so far.
    pub accepted: u32,
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
            known: Vec::new(),
            active: None,
            pending_sessions: Vec::new(),
            dead: BTreeSet::new(),
            accepted_seqs: BTreeSet::new(),
            ack_seq: 0,
            estop_seq: 0,
            now_us: 1,
            wire: Vec::with_capacity(2 * MAX_FRAME),
            reply: vec![0u8; MAX_FRAME],
            pending: false,
            accepted: 0,
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
                _ => self.session_frame(op, c),
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
        let (protocol, pad) = if op & 128 != 0 {
            (c.u8(), usize::from(c.u8()))
        } else {
            (PROTOCOL_VERSION, HANDSHAKE_BODY)
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
        let valid = auth_ok && body.len() >= HANDSHAKE_BODY && protocol == PROTOCOL_VERSION;
        self.rng.fail = op & 64 != 0;
        let sent = Sent::Hello {
            nonce,
            auth_ok,
            valid,
            entropy_fails: self.rng.fail,
        };
        self.send(&spec, sent);
        self.rng.fail = false;
    }

    fn session_frame(&mut self, op: u8, c: &mut Cursor<'_>) {
        let back = usize::from(c.u8());
        let seq_abs = (op & 64 != 0).then(|| c.u64());
        let delta = if seq_abs.is_none() { c.u8() as i8 } else { 0 };
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
        let kind = self.tagged_kind(KIND_SESSION, op);
        let psk_tag = op & 128 != 0;
        let spec = FrameSpec {
            version: PROTOCOL_VERSION,
            kind,
            session: id,
            seq,
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
        self.send(&spec, Sent::Session { k, auth_ok });
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
        let [(got, reply_len)] = results.as_slice() else {
            panic!("one frame, {} results", results.len());
        };
        let got = got.clone();
        let reply_len = *reply_len;
        if let Some(want) = envelope(spec, &self.wire, raw_len) {
            assert_eq!(got.as_ref().err(), Some(&want), "envelope of {spec:?}");
            return;
        }
        match sent {
            Sent::Hello {
                nonce,
                auth_ok,
                valid,
                entropy_fails,
            } => {
                let repeat_of_active = self
                    .active
                    .is_some_and(|a| self.known[a].client_nonce == nonce);
                let want = if !auth_ok {
                    Some(Reason::Auth)
                } else if !valid {
                    None // Auth, Malformed or Version: a bad Hello; checked below
                } else if repeat_of_active {
                    Some(Reason::Replay)
                } else {
                    None
                };
                if let Some(w) = want {
                    assert_eq!(got.as_ref().err(), Some(&w), "Hello {spec:?}");
                }
                match &got {
                    Ok(RobotEvent::Hello(_)) => {
                        assert!(valid, "a bad Hello was answered: {spec:?}");
                        self.check_ack(reply_len, Some(stuffed), nonce);
                    }
                    Ok(e) => panic!("a Hello gave {e:?}"),
                    Err(r) if valid && !repeat_of_active => assert!(
                        *r == Reason::Entropy && entropy_fails,
                        "a valid Hello was refused ({r:?})"
                    ),
                    Err(r) => assert!(
                        matches!(
                            r,
                            Reason::Auth | Reason::Malformed | Reason::Version | Reason::Replay
                        ),
                        "{r:?}"
                    ),
                }
            }
            Sent::Session { k, auth_ok } => {
                // The robot's session lookup, tag, replay window and body, in that order.
                let s = &self.known[k];
                let live = self.active == Some(k) || self.pending_sessions.contains(&k);
                let want = if !live {
                    Some(Reason::Session)
                } else if !auth_ok {
                    Some(Reason::Auth)
                } else if !s.window.fresh(spec.seq) {
                    Some(Reason::Replay)
                } else {
                    match omnikin::link::decode_message(spec.body) {
                        Err(_) => Some(Reason::Malformed),
                        // A message for the other end (a robot's telemetry reflected back to
                        // it) verifies under the shared K_s but is dropped as malformed before
                        // it can move the replay window.
                        Ok(
                            Message::Telemetry(_)
                            | Message::SessionEnd(_)
                            | Message::Estimate(_)
                            | Message::Truth(_),
                        ) => Some(Reason::Malformed),
                        Ok(_) => None,
                    }
                };
                assert_eq!(got.as_ref().err(), want.as_ref(), "session frame {spec:?}");
                self.check_result(got, Some(spec), Some(stuffed));
            }
            Sent::Other => self.check_result(got, Some(spec), Some(stuffed)),
        }
    }

    /// The HelloAck in `reply[..n]`: decodes under the PSK, echoes the nonce, names this
    /// robot, carries the session id both ends derive, and is no larger than the Hello.
    fn check_ack(&mut self, n: usize, hello_len: Option<usize>, nonce: [u8; NONCE_LEN]) {
        if let Some(h) = hello_len {
            assert!(n - 1 <= h, "HelloAck of {n} bytes for a Hello of {h}");
        }
        let psk = self.psk();
        let (kind, session, seq, body) = unwrap(&self.reply[..n], self.keyed.then_some(psk))
            .expect("the HelloAck decodes under the PSK");
        assert_eq!((kind, seq), (KIND_HELLO_ACK, 0));
        let ack: HelloAck = postcard::from_bytes(&body).expect("a HelloAck body");
        assert_eq!(ack.client_nonce, nonce);
        assert_eq!(ack.info, self.info);
        let (id, key) = derive(psk, &nonce, &ack.robot_nonce);
        assert_eq!(
            session, id,
            "the session id is the one the documented KDF gives"
        );
        let last = self.known.iter().rposition(|s| s.client_nonce == nonce);
        if let Some(i) = last
            && self.pending_sessions.contains(&i)
        {
            assert_eq!(
                self.known[i].id, id,
                "a repeated pending Hello got another answer"
            );
        } else {
            // A new Hello, or the nonce of a session the robot no longer holds (taken over,
            // or its pending slot reused): a new session in a free slot or the oldest one.
            assert!(
                last.is_none_or(|i| self.active != Some(i)),
                "the active session's Hello was answered"
            );
            if self.pending_sessions.len() == PENDING_SLOTS {
                let old = self.pending_sessions.remove(0);
                self.dead.insert(self.known[old].id);
            }
            self.pending_sessions.push(self.known.len());
            self.known.push(Known {
                id,
                key,
                client_nonce: nonce,
                window: ReplayModel::default(),
                last_seq: 0,
                rx_top: 0,
            });
        }
    }

    /// Checks what any accepted session frame must satisfy, and updates the model.
    fn check_result(
        &mut self,
        got: Result<RobotEvent, Reason>,
        spec: Option<&FrameSpec<'_>>,
        frame_len: Option<usize>,
    ) {
        match got {
            Ok(RobotEvent::Hello(n)) => {
                // Only from an "any frame": learn the session from the answer.
                let psk = self.psk();
                let (_, _, _, body) =
                    unwrap(&self.reply[..n], self.keyed.then_some(psk)).expect("HelloAck");
                let ack: HelloAck = postcard::from_bytes(&body).expect("a HelloAck body");
                self.check_ack(n, frame_len, ack.client_nonce);
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
                    "accepted a frame of a session it dropped"
                );
                assert!(
                    self.active == Some(k) || self.pending_sessions.contains(&k),
                    "accepted a frame of a session that is neither active nor pending"
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
                self.known[k].window.accept(seq);
                self.accepted += 1;
                assert_eq!(new_session, self.active != Some(k), "new_session flag");
                if new_session {
                    if let Some(old) = self.active {
                        let n = replaced.expect("a takeover tells the previous operator");
                        let old = self.known[old].clone();
                        let (kind, session, oseq, body) =
                            unwrap(&self.reply[..n], self.keyed.then_some(&old.key[..]))
                                .expect("SessionEnd decodes under the old session's key");
                        assert_eq!((kind, session), (KIND_SESSION, old.id));
                        assert!(oseq > old.rx_top);
                        let m: Message = postcard::from_bytes(&body).expect("a message");
                        assert_eq!(m, Message::SessionEnd(EndReason::TakenOver));
                        self.dead.insert(old.id);
                    } else {
                        assert!(replaced.is_none());
                    }
                    self.pending_sessions.retain(|&i| i != k);
                    self.active = Some(k);
                    self.ack_seq = seq;
                    self.estop_seq = 0;
                } else {
                    assert!(replaced.is_none());
                    self.ack_seq = self.ack_seq.max(seq);
                }
                self.serve(seq, &msg);
            }
            Err(_) => {}
        }
    }

    fn check_unpredicted(&mut self, results: Vec<(Result<RobotEvent, Reason>, usize)>) {
        for (r, _) in results {
            self.check_result(r, None, None);
        }
    }

    /// Feeds `bytes` to the reader and each frame to the robot; returns what it reported (and
    /// the reply length), after checking that every frame was counted in exactly one counter
    /// and that the receive path did not allocate.
    fn deliver(&mut self, bytes: &[u8]) -> Vec<(Result<RobotEvent, Reason>, usize)> {
        let before = *self.link.counters();
        // Room for every frame `bytes` can hold, so that collecting does not allocate.
        let mut results = Vec::with_capacity(bytes.len() + 1);
        let link = &mut self.link;
        let (info, rng, reply) = (&self.info, &mut self.rng, &mut self.reply);
        let datagram = self.datagram;
        let reader = &mut self.reader;
        let (tail, usage) = measure(|| {
            reader.feed(bytes, |f| match f {
                Some(f) => {
                    let r = link.receive(f, info, rng, &mut reply[..]);
                    let n = match &r {
                        Ok(RobotEvent::Hello(n)) => *n,
                        Ok(RobotEvent::Message {
                            replaced: Some(n), ..
                        }) => *n,
                        _ => 0,
                    };
                    results.push((r.map_err(|e| Reason::from(&e)), n));
                }
                None => {
                    link.count_framing_drop();
                    results.push((Err(Reason::Framing), 0));
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
        if let [(Err(r), _)] = results.as_slice()
            && tail == 0
        {
            assert_eq!(
                counter(&after, Some(*r)),
                counter(&before, Some(*r)) + 1,
                "{r:?}"
            );
        }
        if let Some(&last) = bytes.last() {
            self.pending = !self.datagram && last != 0;
        }
        results
    }

    fn serve(&mut self, seq: u64, m: &Message) {
        match serve(&mut self.runtime, &mut self.link, seq, m, self.now_us) {
            Served::Ignored => {
                assert!(matches!(
                    m,
                    Message::Telemetry(_)
                        | Message::SessionEnd(_)
                        | Message::Estimate(_)
                        | Message::Truth(_)
                ))
            }
            Served::Accepted => match m {
                Message::EStop => self.estop_seq = seq,
                Message::Clear => self.estop_seq = 0,
                _ => {}
            },
            Served::Rejected(_) => {}
        }
    }

    fn cycle(&mut self) {
        let dt_us = (1e6 / RATE_HZ) as u64;
        self.now_us += dt_us;
        let mut board = self.board;
        let st = self
            .runtime
            .cycle(self.now_us, &mut board, &mut NoImu, &mut self.board);
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
        // Telemetry goes to the active session only, under its key, with fresh seqs, and
        // says which command it has seen and which e-stop it confirms.
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
    }
}

/// Bytes of a Hello record with `nonce`, valid.
pub fn hello_record(nonce: u8) -> Vec<u8> {
    let mut r = vec![0u8];
    r.extend_from_slice(&[nonce; NONCE_LEN]);
    r
}

/// Bytes of a valid session-frame record to the newest handshake with an absolute `seq`.
pub fn record(msg: &Message, seq: u64) -> Vec<u8> {
    let body = postcard::to_allocvec(msg).expect("seed message encodes");
    let mut r = vec![1u8 | 64, 0];
    r.extend_from_slice(&seq.to_le_bytes());
    r.extend_from_slice(&(body.len() as u16).to_le_bytes());
    r.extend_from_slice(&body);
    r
}

/// A cycle record of `n` (1–16) control periods.
pub fn cycles(n: u8) -> [u8; 2] {
    [3, n.clamp(1, 16) - 1]
}

/// Runs one structured input (the `link_session` target); returns the frames accepted.
pub fn run_session(data: &[u8]) -> u32 {
    let mut c = Cursor::new(data);
    let mut s = Session::new(c.u8());
    s.run(&mut c);
    s.accepted
}
