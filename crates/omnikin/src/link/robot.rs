//! The robot's end of the link ([`RobotLink`]): answers Hellos, keeps pending handshakes,
//! confirms and switches the active session; and [`serve`], which hands a session's messages
//! to the runtime (either kind, [`Operated`]).

use super::session::{Pending, Session};
use super::{
    CHUNK_POINTS, DropReason, EncodeError, EndReason, HelloAck, Key, Kind, LinkCounters, Message,
    NONCE_LEN, PROTOCOL_VERSION, RobotInfo, RobotKind, Telemetry, TelemetrySource, decode_hello,
    encode_frame_with, parse_frame, postcard_body, v1,
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
    /// Hello). The active session is untouched; the new one is pending until its operator's
    /// first session frame verifies.
    Hello(usize),
    /// A message of the active session.
    Message {
        /// Its sequence number.
        seq: u64,
        /// The message.
        msg: Message,
        /// This frame confirmed a new session, which is now the active one.
        new_session: bool,
        /// The new session took over from another: `reply[..n]` holds the previous operator's
        /// [`Message::SessionEnd`], to be sent to that operator's address.
        replaced: Option<usize>,
    },
}

/// Handshakes a robot keeps pending at once: a legitimate handshake completes unless this many
/// other Hellos (a flood of spoofed or replayed ones) arrive within its round trip.
pub const PENDING_SLOTS: usize = 4;

/// The robot's end of the link: the active session, up to [`PENDING_SLOTS`] pending ones, the
/// counters.
#[derive(Clone, Debug)]
pub struct RobotLink {
    key: Option<Key>,
    active: Option<Session>,
    /// The client nonce of the Hello that opened the active session.
    active_nonce: [u8; NONCE_LEN],
    pending: [Option<Pending>; PENDING_SLOTS],
    /// Hellos answered, and the count at which each slot was filled (the oldest is replaced).
    hellos: u64,
    pending_since: [u64; PENDING_SLOTS],
    counters: LinkCounters,
    ack_seq: u64,
    estop_seq: u64,
    v1_seq: u64,
}

impl RobotLink {
    /// A robot end with an optional pre-shared key.
    pub fn new(key: Option<Key>) -> Self {
        Self {
            key,
            active: None,
            active_nonce: [0; NONCE_LEN],
            pending: [const { None }; PENDING_SLOTS],
            hellos: 0,
            pending_since: [0; PENDING_SLOTS],
            counters: LinkCounters::default(),
            ack_seq: 0,
            estop_seq: 0,
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

    /// The newest pending (handshaken, not yet confirmed) session's id, if any.
    pub fn pending_id(&self) -> Option<u64> {
        (0..PENDING_SLOTS)
            .filter(|&i| self.pending[i].is_some())
            .max_by_key(|&i| self.pending_since[i])
            .and_then(|i| self.pending[i].as_ref().map(|p| p.id))
    }

    /// Counts a frame dropped before decoding (cut off at the end of a datagram, or longer
    /// than the receive buffer).
    pub fn count_framing_drop(&mut self) {
        self.counters.framing = self.counters.framing.saturating_add(1);
    }

    /// Decodes one frame (the bytes between two delimiters, without them; decoded in place)
    /// and runs the session logic; `info` goes into a HelloAck, `rng` makes its nonce, `reply`
    /// (at least [`MAX_FRAME`](super::MAX_FRAME) bytes) receives the frame to send back, if any (see
    /// [`RobotEvent`]). Counts the frame in exactly one counter. A repeat of a pending Hello
    /// (a retransmission after a lost HelloAck, a duplicate) is answered again with the same
    /// answer and counts as `ok` (it is not dropped); a repeat of the Hello that opened the
    /// active session is dropped as a replay, unanswered.
    ///
    /// # Errors
    /// [`DropReason`]: the frame was dropped and must not be acted upon.
    pub fn receive(
        &mut self,
        frame: &mut [u8],
        info: &RobotInfo,
        rng: &mut impl Entropy,
        reply: &mut [u8],
    ) -> Result<RobotEvent, DropReason> {
        let r = self.receive_inner(frame, info, rng, reply);
        self.counters.count(&r);
        r
    }

    fn receive_inner(
        &mut self,
        frame: &mut [u8],
        info: &RobotInfo,
        rng: &mut impl Entropy,
        reply: &mut [u8],
    ) -> Result<RobotEvent, DropReason> {
        let received = frame.len();
        let p = parse_frame(frame)?;
        match p.header.kind {
            Kind::Hello => {
                p.verify(self.key.as_ref().map(Key::mac))?;
                if p.header.session != 0 || p.header.seq != 0 {
                    return Err(DropReason::Malformed);
                }
                let hello = decode_hello(p.body)?;
                if hello.protocol != PROTOCOL_VERSION {
                    return Err(DropReason::Version(hello.protocol));
                }
                if self.active.is_some() && hello.client_nonce == self.active_nonce {
                    return Err(DropReason::Replay(0));
                }
                // A retransmitted Hello gets the same answer (the same pending session);
                // another Hello takes a free slot, or replaces the oldest pending one.
                let same = self.pending.iter().position(|p| {
                    p.as_ref()
                        .is_some_and(|p| p.client_nonce == hello.client_nonce)
                });
                let (slot, robot_nonce) = match same {
                    Some(i) => (
                        i,
                        self.pending[i]
                            .as_ref()
                            .map_or([0; NONCE_LEN], |p| p.robot_nonce),
                    ),
                    None => {
                        let mut rn = [0u8; NONCE_LEN];
                        rng.fill(&mut rn).map_err(|_| DropReason::Entropy)?;
                        let free = self.pending.iter().position(Option::is_none);
                        let oldest = (0..PENDING_SLOTS)
                            .min_by_key(|&i| self.pending_since[i])
                            .unwrap_or(0);
                        (free.unwrap_or(oldest), rn)
                    }
                };
                let (id, ks) =
                    Session::derive(self.key.as_ref(), &hello.client_nonce, &robot_nonce);
                let ack = HelloAck {
                    info: *info,
                    client_nonce: hello.client_nonce,
                    robot_nonce,
                };
                let n = encode_frame_with(
                    Kind::HelloAck,
                    id,
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
                if same.is_none() {
                    self.hellos += 1;
                    self.pending_since[slot] = self.hellos;
                }
                self.pending[slot] = Some(Pending {
                    id,
                    ks,
                    client_nonce: hello.client_nonce,
                    robot_nonce,
                });
                Ok(RobotEvent::Hello(n))
            }
            Kind::HelloAck => Err(DropReason::Malformed),
            Kind::Session => {
                let id = p.header.session;
                if let Some(a) = self.active.as_mut().filter(|a| a.id == id) {
                    let (seq, msg) = a.open(&p, true)?;
                    self.ack_seq = self.ack_seq.max(seq);
                    return Ok(RobotEvent::Message {
                        seq,
                        msg,
                        new_session: false,
                        replaced: None,
                    });
                }
                let Some(slot) = self
                    .pending
                    .iter()
                    .position(|pd| pd.as_ref().is_some_and(|pd| pd.id == id))
                else {
                    return Err(DropReason::Session(id));
                };
                // Key confirmation: the new operator proved it holds K_s.
                let Some(pd) = self.pending[slot].as_ref() else {
                    return Err(DropReason::Session(id));
                };
                let mut session = Session::new(id, &pd.ks, self.key.is_some());
                let (seq, msg) = session.open(&p, true)?;
                // The other pending handshakes stay (they may still confirm and take over).
                if let Some(pd) = self.pending[slot].take() {
                    self.active_nonce = pd.client_nonce;
                }
                let new = Some(session);
                let replaced = match self.active.take() {
                    Some(mut old) => old
                        .encode(&Message::SessionEnd(EndReason::TakenOver), reply)
                        .ok(),
                    None => None,
                };
                self.active = new;
                self.ack_seq = seq;
                self.estop_seq = 0;
                Ok(RobotEvent::Message {
                    seq,
                    msg,
                    new_session: true,
                    replaced,
                })
            }
        }
    }

    /// Records what the runtime did with message `seq` of the active session (for the
    /// telemetry's `estop_seq`). [`serve`] calls it.
    pub fn note(&mut self, seq: u64, msg: &Message, accepted: bool) {
        match msg {
            Message::EStop if accepted => self.estop_seq = seq,
            Message::Clear if accepted => self.estop_seq = 0,
            _ => {}
        }
    }

    /// Telemetry for the active session: the status, the counters, `ack_seq` and `estop_seq`
    /// (the latter 0 unless the runtime is in e-stop).
    pub fn telemetry<S: TelemetrySource>(&self, s: &S) -> Telemetry {
        let mut t = s.telemetry(&self.counters);
        t.ack_seq = self.ack_seq;
        t.estop_seq = if t.mode == Mode::EStop {
            self.estop_seq
        } else {
            0
        };
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
    /// says `protocol: 2`, tagged the v1 way with the PSK, so a v1 operator prints "robot
    /// speaks protocol version 2". The caller bounds how often it is sent (it is larger than
    /// the smallest v1 frame: send it only within the sender's anti-amplification budget).
    ///
    /// # Errors
    /// [`EncodeError::TooLarge`] when `out` is too small.
    pub fn version_reply(
        &mut self,
        info: &RobotInfo,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let mut i = *info;
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
    /// The runtime rejected it (counted there).
    Rejected(crate::runtime::CommandError),
    /// Not a command (a robot → operator message); ignored.
    Ignored,
}

/// Who this runtime is, for the HelloAck.
pub fn robot_info<T: Real, R: Operated<T>>(runtime: &R, authenticated: bool) -> RobotInfo {
    RobotInfo {
        protocol: PROTOCOL_VERSION,
        kind: RobotKind::of(runtime.kind()),
        plan_capacity: runtime.plan_capacity().min(u16::MAX as usize) as u16,
        rate_hz: runtime.rate_hz().to_f64() as f32,
        watchdog: runtime.watchdog().to_f64() as f32,
        authenticated,
    }
}

/// Robot side: hands message `seq` of the active session (from [`RobotEvent::Message`]) to the
/// runtime at clock time `now_us`, and records the outcome in `link` (e-stop confirmation).
pub fn serve<T: Real, R: Operated<T>>(
    runtime: &mut R,
    link: &mut RobotLink,
    seq: u64,
    msg: &Message,
    now_us: u64,
) -> Served {
    let mut buf = [PlanPoint::zero(); CHUNK_POINTS];
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
