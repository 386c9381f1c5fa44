//! The link harness: a structured input (frames whose header fields and body bytes the fuzzer
//! chooses) that [`fixup`] turns into wire frames with a correct MAC, CRC and COBS stuffing,
//! so that mutated inputs reach the postcard body decoder, the replay window and the robot
//! runtime instead of dying at the CRC check. [`Session`] runs one input against a robot-side
//! [`Endpoint`] and a [`Runtime`] and checks, frame by frame, the outcome the format
//! specification predicts (the reference in [`expected`]).
//!
//! ## Input format
//! ```text
//! setup:u8  (bit 0: keyed endpoint; bit 1: datagram transport; bits 2-3: robot 0 sphere,
//!            1 ballbot, 2-3 caster)
//! record*   op:u8, then by op & 3:
//!   0, 1  frame:  seq (bit 2 set: u64 LE; clear: i8 delta from the previous frame's seq),
//!                 [version:u8 if bit 6], [flags:u8 if bit 7], len:u16 LE, body[len]
//!                 bit 3: corrupt the CRC; bit 4: corrupt the tag; bit 5: toggle the AUTH
//!                 flag (a tag is appended exactly when the flag is set)
//!   2     cycle:  n:u8 — advance the clock by (n & 15) + 1 control periods, one cycle each
//!   3     junk:   len:u8, bytes[len] — fed to the reader as they are, then a 0x00 unless
//!                 bit 2 is set (on a stream the next frame then starts with them)
//! ```
//! Everything the fix-up computes (tag, CRC, stuffing, delimiter) is the one function
//! [`fixup`]; retargeting the harness to another wire version means rewriting it, [`expected`]
//! and the seeds, not the targets.

use std::collections::BTreeSet;

use hmac::{Hmac, Mac};
use omnikin::link::{
    DropReason, Endpoint, FLAG_AUTH, FrameReader, HEADER_LEN, Key, LinkCounters, MAX_FRAME,
    Message, PROTOCOL_VERSION, Served, TAG_LEN, encode_frame, serve,
};
use omnikin::runtime::hal::{EncoderAngles, Encoders, MotorCommand, MotorOutputs, NoImu};
use omnikin::runtime::limits::RateLimits;
use omnikin::runtime::{Config, Runtime};
use omnikin::{Pose2, Robot};
use sha2::Sha256;

use crate::alloc::measure;

/// The pre-shared key of keyed sessions (any 1–64 bytes).
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

/// What the fuzzer chooses in one frame; the rest is computed by [`fixup`].
#[derive(Clone, Copy, Debug)]
pub struct FrameSpec<'a> {
    /// Version byte.
    pub version: u8,
    /// Flags byte (a tag is appended exactly when `flags & FLAG_AUTH`).
    pub flags: u8,
    /// Sequence number.
    pub seq: u64,
    /// Postcard body, as the fuzzer wrote it.
    pub body: &'a [u8],
    /// `false`: one tag bit is flipped after the MAC is computed.
    pub tag_ok: bool,
    /// `false`: one CRC bit is flipped after the CRC is computed.
    pub crc_ok: bool,
}

fn mac(data: &[u8]) -> [u8; TAG_LEN] {
    let mut m = <Hmac<Sha256> as Mac>::new_from_slice(FUZZ_KEY).expect("HMAC takes any key");
    m.update(data);
    let full = m.finalize().into_bytes();
    let mut t = [0u8; TAG_LEN];
    t.copy_from_slice(&full[..TAG_LEN]);
    t
}

/// The fix-up: the wire bytes of `spec` — header, body, tag (HMAC-SHA256 with [`FUZZ_KEY`]
/// over header and body, truncated) when the AUTH flag is set, CRC-32C, COBS, `0x00` —
/// corrupted only where the spec asks. Returns the unstuffed length (header … CRC).
pub fn fixup(spec: &FrameSpec<'_>, out: &mut Vec<u8>) -> usize {
    let mut raw = Vec::with_capacity(HEADER_LEN + spec.body.len() + TAG_LEN + 4);
    raw.push(spec.version);
    raw.push(spec.flags);
    raw.extend_from_slice(&spec.seq.to_le_bytes());
    raw.extend_from_slice(spec.body);
    if spec.flags & FLAG_AUTH != 0 {
        let mut t = mac(&raw);
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
        }
    }
}

/// The counter a reason lands in (`None`: accepted, `ok`).
pub fn counter(c: &LinkCounters, r: Option<Reason>) -> u32 {
    match r {
        None => c.ok,
        Some(Reason::Framing) => c.framing,
        Some(Reason::Crc) => c.crc,
        Some(Reason::Version) => c.version,
        Some(Reason::Auth) => c.auth,
        Some(Reason::Replay) => c.replay,
        Some(Reason::Malformed) => c.malformed,
    }
}

fn total(c: &LinkCounters) -> u64 {
    [
        c.ok,
        c.framing,
        c.crc,
        c.version,
        c.auth,
        c.replay,
        c.malformed,
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
    /// Fresh per the module docs of `omnikin::link`: not 0, and above the highest accepted or
    /// within the 64 below it and not accepted before.
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

/// The outcome the v1 format predicts for `spec` on a receiver (`keyed`: with [`FUZZ_KEY`]),
/// given its wire bytes: `Err(reason)` or the decoded message.
pub fn expected(
    spec: &FrameSpec<'_>,
    wire: &[u8],
    raw_len: usize,
    keyed: bool,
    replay: &ReplayModel,
) -> Result<Message, Reason> {
    let stuffed = wire.len() - 1;
    if stuffed > MAX_FRAME || raw_len < HEADER_LEN + 4 + 1 {
        return Err(Reason::Framing);
    }
    if !spec.crc_ok {
        return Err(Reason::Crc);
    }
    if spec.version != PROTOCOL_VERSION {
        return Err(Reason::Version);
    }
    let auth = spec.flags & FLAG_AUTH != 0;
    if auth && raw_len - 4 < HEADER_LEN + TAG_LEN + 1 {
        return Err(Reason::Framing);
    }
    if keyed && (!auth || !spec.tag_ok) {
        return Err(Reason::Auth);
    }
    let msg = match postcard::take_from_bytes::<Message>(spec.body) {
        Ok((m, [])) => m,
        _ => return Err(Reason::Malformed),
    };
    if !replay.fresh(spec.seq) {
        return Err(Reason::Replay);
    }
    Ok(msg)
}

/// Ideal board: the encoders return the integral of the commanded motor rates.
#[derive(Clone, Copy, Debug, Default)]
pub struct Board {
    /// Wheel angles, rad.
    pub wheel: [f32; 3],
    /// Steer angles, rad.
    pub steer: [f32; 3],
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
    /// Up to `n` bytes.
    pub fn take(&mut self, n: usize) -> &'a [u8] {
        let (a, b) = self.data.split_at(n.min(self.data.len()));
        self.data = b;
        a
    }
}

/// One fuzz input's run: a robot-side endpoint, reader and runtime, with the reference model.
pub struct Session {
    keyed: bool,
    datagram: bool,
    caster: bool,
    endpoint: Endpoint,
    reader: FrameReader<MAX_FRAME>,
    runtime: Runtime<f32, PLAN_POINTS>,
    board: Board,
    replay: ReplayModel,
    now_us: u64,
    last_seq: u64,
    wire: Vec<u8>,
    /// Undelimited junk is waiting in the stream reader.
    pending: bool,
    /// Frames accepted so far.
    pub accepted: u32,
}

impl Session {
    /// From the setup byte (see the module docs).
    pub fn new(setup: u8) -> Self {
        let keyed = setup & 1 != 0;
        let datagram = setup & 2 != 0;
        let robot = match (setup >> 2) & 3 {
            0 => "sphere-omni",
            1 => "ballbot",
            _ => "caster3",
        };
        let d = omnikin::description::RobotDescription::preset(robot).expect("preset");
        let robot: Robot<f32> = d.build().expect("preset builds");
        let caster = matches!(robot, Robot::Caster(_));
        let mut cfg = Config::new(RATE_HZ);
        cfg.rate_limits = RateLimits {
            wheel: Some(WHEEL_LIMIT),
            steer: caster.then_some(STEER_LIMIT),
        };
        let key = keyed.then(|| Key::new(FUZZ_KEY).expect("key length"));
        Self {
            keyed,
            datagram,
            caster,
            endpoint: Endpoint::new(key, 1),
            reader: FrameReader::new(),
            runtime: Runtime::new(robot, cfg, Pose2::default()).expect("valid config"),
            board: Board::default(),
            replay: ReplayModel::default(),
            now_us: 1,
            last_seq: 0,
            wire: Vec::with_capacity(2 * MAX_FRAME),
            pending: false,
            accepted: 0,
        }
    }

    /// Runs every record of `c`, checking each.
    pub fn run(&mut self, c: &mut Cursor<'_>) {
        while !c.is_empty() {
            let op = c.u8();
            match op & 3 {
                0 | 1 => self.frame(op, c),
                2 => {
                    let n = (c.u8() & 15) + 1;
                    for _ in 0..n {
                        self.cycle();
                    }
                }
                _ => {
                    let n = usize::from(c.u8());
                    let junk = c.take(n).to_vec();
                    self.junk(&junk, op & 4 == 0);
                }
            }
        }
    }

    fn frame(&mut self, op: u8, c: &mut Cursor<'_>) {
        let seq = if op & 4 != 0 {
            c.u64()
        } else {
            self.last_seq.wrapping_add_signed(i64::from(c.u8() as i8))
        };
        self.last_seq = seq;
        let version = if op & 64 != 0 {
            c.u8()
        } else {
            PROTOCOL_VERSION
        };
        let correct = if self.keyed { FLAG_AUTH } else { 0 };
        let mut flags = if op & 128 != 0 { c.u8() } else { correct };
        if op & 32 != 0 {
            flags ^= FLAG_AUTH;
        }
        let len = usize::from(c.u16()).min(MAX_SPEC_BODY);
        let body = c.take(len);
        let spec = FrameSpec {
            version,
            flags,
            seq,
            body,
            tag_ok: op & 16 == 0,
            crc_ok: op & 8 == 0,
        };
        let mut wire = std::mem::take(&mut self.wire);
        let raw_len = fixup(&spec, &mut wire);
        let want = expected(&spec, &wire, raw_len, self.keyed, &self.replay);
        let unpredictable = self.pending;
        let got = self.deliver(&wire, true);
        if unpredictable {
            // The junk before it made the frame another one: only its counting is checked.
            for r in got {
                self.accepted_unpredicted(r);
            }
            self.wire = wire;
            return;
        }
        match (&want, &got[0]) {
            (Err(w), Err(g)) => assert_eq!(*w, *g, "frame {spec:?}"),
            (Ok(_), Ok((s, m))) => {
                assert_eq!(*s, seq);
                self.replay.accept(seq);
                self.accepted += 1;
                // What decodes re-encodes, to at most the bytes it came from (postcard also
                // accepts overlong varints, so the body need not be the canonical encoding),
                // and that encoding decodes and re-encodes to itself.
                let mut again = [0u8; omnikin::link::MAX_BODY];
                let enc = postcard::to_slice(m, &mut again).expect("a decoded message encodes");
                assert!(enc.len() <= spec.body.len());
                let back: Message = postcard::from_bytes(enc).expect("its encoding decodes");
                let mut third = [0u8; omnikin::link::MAX_BODY];
                let enc2 = postcard::to_slice(&back, &mut third).expect("encodes");
                assert_eq!(enc, enc2, "encode∘decode∘encode = encode");
                let canonical = enc == spec.body;
                // The encoder reproduces the very frame when the header and body are the ones
                // it writes.
                if flags == correct && canonical {
                    let key = self.keyed.then(|| Key::new(FUZZ_KEY).expect("key"));
                    let mut out = [0u8; MAX_FRAME];
                    let n = encode_frame(m, seq, key.as_ref(), &mut out).expect("encodes");
                    assert_eq!(
                        &out[..n],
                        wire.as_slice(),
                        "encode_frame reproduces the frame"
                    );
                }
                let m = m.clone();
                self.serve(&m);
            }
            (w, g) => panic!(
                "frame {spec:?}: expected {:?}, got {:?}",
                w.as_ref().map(|_| "accepted"),
                g.as_ref().map(|_| "accepted")
            ),
        }
        self.wire = wire;
    }

    /// Feeds `bytes` to the reader; returns what it reported, after checking that every frame
    /// was counted in exactly one counter and that the receive path did not allocate.
    fn deliver(&mut self, bytes: &[u8], frame: bool) -> Vec<Result<(u64, Message), Reason>> {
        let before = *self.endpoint.counters();
        // Room for every frame `bytes` can hold, so that collecting does not allocate.
        let mut results = Vec::with_capacity(bytes.len() + 1);
        let (tail, usage) = measure(|| {
            self.reader.feed(bytes, &mut self.endpoint, |r| {
                results.push(r.map_err(|e| Reason::from(&e)));
            });
            if self.datagram {
                u64::from(self.reader.end_of_datagram(&mut self.endpoint))
            } else {
                0
            }
        });
        assert_eq!(usage.allocations, 0, "the receive path allocated");
        let after = *self.endpoint.counters();
        assert_eq!(
            total(&after) - total(&before),
            results.len() as u64 + tail,
            "every frame counted in exactly one counter ({before:?} -> {after:?})"
        );
        // And in the counter its result names.
        if let [r] = results.as_slice()
            && tail == 0
        {
            let r = r.as_ref().err().copied();
            assert_eq!(counter(&after, r), counter(&before, r) + 1, "{r:?}");
        }
        if frame && !self.pending {
            assert_eq!(results.len(), 1, "one frame, one result");
        }
        if let Some(&last) = bytes.last() {
            self.pending = !self.datagram && last != 0;
        }
        results
    }

    /// Junk: bytes fed as they are, then (op bit 2 clear) a delimiter. Without one, on a
    /// stream, the bytes prefix the next frame, whose outcome is then only counted.
    fn junk(&mut self, bytes: &[u8], delimit: bool) {
        let mut framed = bytes.to_vec();
        if delimit {
            framed.push(0);
        }
        for r in self.deliver(&framed, false) {
            self.accepted_unpredicted(r);
        }
    }

    fn accepted_unpredicted(&mut self, r: Result<(u64, Message), Reason>) {
        if let Ok((seq, m)) = r {
            assert!(self.replay.fresh(seq), "accepted a stale seq {seq}");
            self.replay.accept(seq);
            self.accepted += 1;
            self.serve(&m);
        }
    }

    fn serve(&mut self, m: &Message) {
        match serve(&mut self.runtime, m, self.keyed, self.now_us) {
            Served::Hello(info) => {
                assert_eq!(info.protocol, PROTOCOL_VERSION);
                assert_eq!(info.authenticated, self.keyed);
                assert_eq!(usize::from(info.plan_capacity), PLAN_POINTS);
            }
            Served::Ignored => assert!(matches!(m, Message::HelloAck(_) | Message::Telemetry(_))),
            Served::Accepted | Served::Rejected(_) => {}
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
        for i in 0..3 {
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
    }
}

/// Bytes of one frame record (see the module docs) with an absolute `seq`, correct header,
/// tag and CRC: what the seed corpora are made of.
pub fn record(msg: &Message, seq: u64) -> Vec<u8> {
    let mut body = [0u8; 512];
    let body = postcard::to_slice(msg, &mut body).expect("seed message encodes");
    let mut r = vec![4u8];
    r.extend_from_slice(&seq.to_le_bytes());
    r.extend_from_slice(&(body.len() as u16).to_le_bytes());
    r.extend_from_slice(body);
    r
}

/// A cycle record of `n` (1–16) control periods.
pub fn cycles(n: u8) -> [u8; 2] {
    [2, n.clamp(1, 16) - 1]
}

/// Runs one structured input (the `link_session` target).
pub fn run_session(data: &[u8]) -> u32 {
    let mut c = Cursor::new(data);
    let mut s = Session::new(c.u8());
    s.run(&mut c);
    s.accepted
}
