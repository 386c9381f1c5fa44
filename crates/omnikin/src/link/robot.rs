//! The robot's end of the link ([`RobotLink`]): answers Hellos without keeping state, opens a
//! session on an open frame that proves the key, refuses replayed first frames, keeps a live
//! session unless the newcomer asks to take over, and orders e-stops before older commands;
//! and [`serve`], which hands a session's messages to the runtime (either kind,
//! [`Operated`]).

use super::session::Session;
use super::{
    Busy, CHUNK_POINTS, DropReason, EncodeError, EndReason, FirstFrame, FrameKind,
    HandshakeSecrets, HelloAck, Key, LinkCounters, Message, PROTOCOL_VERSION, RobotInfo, Telemetry,
    TelemetrySource, decode_hello, encode_frame_with, parse_frame, postcard_body, v1,
};
use crate::Real;
use crate::runtime::hal::Entropy;
use crate::runtime::{Mode, Operated, PlanPoint};

/// What [`RobotLink::receive`] got.
// No heap in the core: the large variant is a value, not a Box.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum RobotEvent {
    /// A valid Hello: `reply[..n]` holds the HelloAck for its sender (never larger than the
    /// Hello). Nothing else changed: the robot keeps no state for a Hello.
    Hello(usize),
    /// An authentic open frame of a session that did not take over because another session is
    /// live: `reply[..n]` holds the [`Message::Busy`] answer for its sender (smaller than the
    /// frame). The handshake is used up (its first frames are refused from now on: the
    /// operator starts a new one to try again); nothing else changed.
    Busy(usize),
    /// A message of the active session.
    Message {
        /// Its sequence number.
        seq: u64,
        /// The message.
        msg: Message,
        /// This frame proved the session key of a new session, which is now the active one:
        /// its sender's address (the one that received the HelloAck) is the session's address.
        new_session: bool,
        /// The new session took over from another: `reply[..n]` holds the previous operator's
        /// [`Message::SessionEnd`], to be sent to that operator's address.
        replaced: Option<usize>,
    },
}

/// Robot time after its newest frame during which a session counts as live, µs: an open frame
/// without [`Opening::take_over`](super::Opening::take_over) does not replace a live session.
/// A session whose operator said [`Message::Bye`] is not live.
pub const LIVE_US: u64 = 1_000_000;

/// The robot's end of the link: the active session, the handshake secrets, the e-stop
/// ordering, the counters.
#[derive(Clone, Debug)]
pub struct RobotLink {
    key: Option<Key>,
    active: Option<Session>,
    secrets: HandshakeSecrets,
    /// Robot time the active session opened and its newest frame arrived, µs.
    opened_us: u64,
    heard_us: u64,
    /// The active session's operator said [`Message::Bye`]: it is not live.
    left: bool,
    counters: LinkCounters,
    ack_seq: u64,
    /// The latched e-stop's sequence number (0: none latched by this session).
    estop_seq: u64,
    /// The newest accepted e-stop of this session: older clears and motion commands are void.
    estop_barrier: u64,
    /// The clear that ended this session's last e-stop.
    clear_seq: u64,
    v1_seq: u64,
}

impl RobotLink {
    /// A robot end with an optional pre-shared key.
    pub fn new(key: Option<Key>) -> Self {
        Self {
            key,
            active: None,
            secrets: HandshakeSecrets::new(),
            opened_us: 0,
            heard_us: 0,
            left: false,
            counters: LinkCounters::default(),
            ack_seq: 0,
            estop_seq: 0,
            estop_barrier: 0,
            clear_seq: 0,
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

    /// Counts a frame dropped before decoding (cut off at the end of a datagram, or longer
    /// than the receive buffer).
    pub fn count_framing_drop(&mut self) {
        self.counters.framing = self.counters.framing.saturating_add(1);
    }

    /// Counts a Hello that the host dropped unread because its sender is over its rate.
    pub fn count_throttled(&mut self) {
        self.counters.throttled = self.counters.throttled.saturating_add(1);
    }

    /// Decodes one frame (the bytes between two delimiters, without them; decoded in place)
    /// received at robot time `now_us` from transport address `peer` (its bytes, e.g. IP and
    /// port; empty on a point-to-point link) and runs the session logic; `info` goes into a
    /// HelloAck, `rng` draws a new handshake secret when an epoch begins, `reply` (at least
    /// [`MAX_FRAME`](super::MAX_FRAME) bytes) receives the frame to send back, if any (see
    /// [`RobotEvent`]). Counts the frame in exactly one counter.
    ///
    /// A Hello is answered from the handshake secret alone: a repeat from the same address
    /// gets the same answer within an epoch, and nothing is stored. An open frame opens a
    /// session only when its epoch is live, its client nonce has not opened one before, its
    /// session id is the one derived from them and the address it came from (so it came from
    /// the address the HelloAck went to), and its tag verifies under the derived key.
    ///
    /// # Errors
    /// [`DropReason`]: the frame was dropped and must not be acted upon.
    pub fn receive(
        &mut self,
        frame: &mut [u8],
        now_us: u64,
        peer: &[u8],
        info: &RobotInfo,
        rng: &mut impl Entropy,
        reply: &mut [u8],
    ) -> Result<RobotEvent, DropReason> {
        let r = self.receive_inner(frame, now_us, peer, info, rng, reply);
        self.counters.count(&r);
        r
    }

    fn receive_inner(
        &mut self,
        frame: &mut [u8],
        now_us: u64,
        peer: &[u8],
        info: &RobotInfo,
        rng: &mut impl Entropy,
        reply: &mut [u8],
    ) -> Result<RobotEvent, DropReason> {
        let received = frame.len();
        let p = parse_frame(frame)?;
        match p.header.kind {
            FrameKind::Hello => {
                p.verify(self.key.as_ref().map(Key::mac))?;
                if p.header.session != 0 || p.header.seq != 0 {
                    return Err(DropReason::Malformed);
                }
                let hello = decode_hello(p.body)?;
                if hello.protocol != PROTOCOL_VERSION {
                    return Err(DropReason::Version(hello.protocol));
                }
                let (epoch, robot_nonce) = self
                    .secrets
                    .answer(now_us, &hello.client_nonce, peer, rng)
                    .map_err(|_| DropReason::Entropy)?;
                let ack = HelloAck {
                    info: *info,
                    client_nonce: hello.client_nonce,
                    robot_nonce,
                    epoch,
                };
                let n = encode_frame_with(
                    FrameKind::HelloAck,
                    0,
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
                Ok(RobotEvent::Hello(n))
            }
            FrameKind::HelloAck => Err(DropReason::Malformed),
            FrameKind::Session | FrameKind::Open => {
                let id = p.header.session;
                if let Some(a) = self.active.as_mut().filter(|a| a.id == id) {
                    let (seq, msg) = a.open(&p, true)?;
                    self.ack_seq = self.ack_seq.max(seq);
                    self.heard_us = self.heard_us.max(now_us);
                    self.left = matches!(msg, Message::Bye);
                    return Ok(RobotEvent::Message {
                        seq,
                        msg,
                        new_session: false,
                        replaced: None,
                    });
                }
                let Some(o) = p.opening else {
                    return Err(DropReason::Session(id));
                };
                // Cheap refusals first: an expired, retired or unknown epoch, a used nonce.
                let robot_nonce = match self.secrets.check(o.epoch, &o.client_nonce, peer, now_us) {
                    FirstFrame::Fresh(n) => n,
                    FirstFrame::Used => return Err(DropReason::Replay(p.header.seq)),
                    FirstFrame::UnknownEpoch => return Err(DropReason::Session(id)),
                };
                let (derived, ks) =
                    Session::derive(self.key.as_ref(), &o.client_nonce, &robot_nonce);
                if derived != id {
                    return Err(DropReason::Session(id));
                }
                // Key confirmation: the tag proves the sender holds K_s.
                let mut session = Session::new(id, &ks, self.key.is_some());
                let (seq, msg) = session.open(&p, true)?;
                if let Some(a) = self.active.as_ref()
                    && !o.take_over
                    && !self.left
                    && now_us.saturating_sub(self.heard_us) < LIVE_US
                {
                    let busy = Busy {
                        holder: a.id,
                        idle_ms: (now_us.saturating_sub(self.heard_us) / 1000) as u32,
                        held_s: (now_us.saturating_sub(self.opened_us) / 1_000_000)
                            .min(u32::MAX as u64) as u32,
                    };
                    // One answer per handshake: its nonce is used up, so a copy of this frame
                    // replayed later (when the holder goes quiet) opens nothing; the operator
                    // starts a new handshake to try again.
                    if !self.secrets.mark_used(o.epoch, &o.client_nonce, now_us) {
                        return Err(DropReason::Session(id));
                    }
                    let n = session
                        .encode_at(seq, &Message::Busy(busy), reply)
                        .map_err(|_| DropReason::Malformed)?;
                    return Ok(RobotEvent::Busy(n));
                }
                if !self.secrets.mark_used(o.epoch, &o.client_nonce, now_us) {
                    return Err(DropReason::Session(id));
                }
                let replaced = match self.active.take() {
                    Some(mut old) => old
                        .encode(&Message::SessionEnd(EndReason::TakenOver), reply)
                        .ok(),
                    None => None,
                };
                self.active = Some(session);
                self.opened_us = now_us;
                self.heard_us = now_us;
                self.left = matches!(msg, Message::Bye);
                self.ack_seq = seq;
                self.estop_seq = 0;
                self.estop_barrier = 0;
                self.clear_seq = 0;
                Ok(RobotEvent::Message {
                    seq,
                    msg,
                    new_session: true,
                    replaced,
                })
            }
        }
    }

    /// Whether message `seq` of the active session is void because an e-stop with a higher
    /// sequence number was accepted before it ([`Message::ordered_after_estop`]); counts it
    /// ([`LinkCounters::stale`]). [`serve`] calls it before the runtime sees the message.
    pub fn stale(&mut self, seq: u64, msg: &Message) -> bool {
        let stale = seq < self.estop_barrier && msg.ordered_after_estop();
        if stale {
            self.counters.stale = self.counters.stale.saturating_add(1);
        }
        stale
    }

    /// Records what the runtime did with message `seq` of the active session (for the
    /// telemetry's `estop_seq`). [`serve`] calls it.
    pub fn note(&mut self, seq: u64, msg: &Message, accepted: bool) {
        match msg {
            Message::EStop => {
                // Every authentic e-stop is a barrier, whether the runtime took it or was in
                // e-stop already.
                self.estop_barrier = self.estop_barrier.max(seq);
                if accepted {
                    self.estop_seq = seq;
                }
            }
            Message::Clear if accepted => {
                if self.estop_seq != 0 {
                    self.clear_seq = seq;
                }
                self.estop_seq = 0;
            }
            _ => {}
        }
    }

    /// Telemetry for the active session: the status, the counters, `ack_seq`, `estop_seq`
    /// (0 unless the runtime is in e-stop) and `clear_seq`.
    pub fn telemetry<S: TelemetrySource>(&self, s: &S) -> Telemetry {
        let mut t = s.telemetry(&self.counters);
        t.ack_seq = self.ack_seq;
        t.estop_seq = if t.mode == Mode::EStop {
            self.estop_seq
        } else {
            0
        };
        t.clear_seq = self.clear_seq;
        t
    }

    /// Encodes `msg` (telemetry) in the active session into `out` (at least [`MAX_FRAME`](super::MAX_FRAME)
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
    /// says this robot's protocol ([`PROTOCOL_VERSION`]), tagged the v1 way with the PSK, so a
    /// v1 operator prints "robot speaks protocol version 4" (the limits are not in it). The caller bounds how often it is sent (it is larger than
    /// the smallest v1 frame: send it only within the sender's anti-amplification budget).
    ///
    /// # Errors
    /// [`EncodeError::TooLarge`] when `out` is too small.
    pub fn version_reply(
        &mut self,
        info: &RobotInfo,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let mut i = v1::V1RobotInfo::from(info);
        i.protocol = PROTOCOL_VERSION;
        let n = v1::encode_hello_ack(&i, self.v1_seq, self.key.as_ref(), out)?;
        self.v1_seq = self.v1_seq.saturating_add(1);
        Ok(n)
    }
}

/// What [`serve`] did with a message.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Served {
    /// Executed (or accepted) by the runtime.
    Accepted,
    /// Not handed to the runtime: a clear or motion command older than an accepted e-stop
    /// ([`RobotLink::stale`]).
    Stale,
    /// The runtime rejected it (counted there).
    Rejected(crate::runtime::CommandError),
    /// Not a command (a robot → operator message); ignored.
    Ignored,
}

/// Who this runtime is, for the HelloAck.
pub fn robot_info<T: Real, R: Operated<T>>(runtime: &R, authenticated: bool) -> RobotInfo {
    RobotInfo {
        protocol: PROTOCOL_VERSION,
        kind: runtime.kind(),
        plan_capacity: runtime.plan_capacity().min(u16::MAX as usize) as u16,
        rate_hz: runtime.rate_hz().to_f64() as f32,
        watchdog: runtime.watchdog().to_f64() as f32,
        authenticated,
        limits: runtime.body_limits(),
    }
}

/// Robot side: hands message `seq` of the active session (from [`RobotEvent::Message`]) to the
/// runtime at clock time `now_us` — unless an accepted e-stop voids it ([`Served::Stale`]) —
/// and records the outcome in `link` (e-stop and clear confirmation).
pub fn serve<T: Real, R: Operated<T>>(
    runtime: &mut R,
    link: &mut RobotLink,
    seq: u64,
    msg: &Message,
    now_us: u64,
) -> Served {
    let mut buf = [PlanPoint::zero(); CHUNK_POINTS];
    if link.stale(seq, msg) {
        return Served::Stale;
    }
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
