//! The operator's end of the link ([`OperatorLink`]): its handshake and its one session, sent
//! as open frames until the robot's first frame in it confirms it.

use super::session::Session;
use super::{
    Busy, DropReason, EncodeError, EndReason, FrameKind, Hello, HelloAck, Key, LinkCounters,
    Message, NONCE_LEN, Opening, PROTOCOL_VERSION, RobotInfo, encode_hello, parse_frame,
};
use crate::runtime::hal::Entropy;

/// What [`OperatorLink::receive`] got.
// No heap in the core: the large variant is a value, not a Box.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum OperatorEvent {
    /// The robot answered this operator's Hello: the session is established on this end; the
    /// robot opens it when the first open frame reaches it (see [`OperatorLink::confirmed`]).
    Established(RobotInfo),
    /// The robot did not open the session: another operator's session is live and this
    /// operator did not ask to take over ([`OperatorLink::set_take_over`]). The handshake is
    /// over: the next [`OperatorLink::hello`] starts a new one.
    Busy(Busy),
    /// A message of this operator's session.
    Message {
        /// Its sequence number.
        seq: u64,
        /// The message.
        msg: Message,
    },
}

// No heap in the core: the large variant is a value, not a Box.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum OpState {
    Idle,
    Handshaking([u8; NONCE_LEN]),
    Established {
        session: Session,
        opening: Opening,
        info: RobotInfo,
        /// A frame of the robot in this session arrived: the robot opened it.
        confirmed: bool,
    },
}

/// The operator's end of the link: its handshake and its one session.
#[derive(Clone, Debug)]
pub struct OperatorLink {
    key: Option<Key>,
    state: OpState,
    ended: Option<EndReason>,
    busy: Option<Busy>,
    take_over: bool,
    counters: LinkCounters,
}

impl OperatorLink {
    /// An operator end with an optional pre-shared key. It does not take the robot over from
    /// a live session unless told ([`OperatorLink::set_take_over`]).
    pub fn new(key: Option<Key>) -> Self {
        Self {
            key,
            state: OpState::Idle,
            ended: None,
            busy: None,
            take_over: false,
            counters: LinkCounters::default(),
        }
    }

    /// Whether this operator's open frames ask the robot to end another operator's live
    /// session (an explicit act of its user: `drive`, a console's control). Takes effect with
    /// the next open frame.
    pub fn set_take_over(&mut self, take_over: bool) {
        self.take_over = take_over;
        if let OpState::Established { opening, .. } = &mut self.state {
            opening.take_over = take_over;
        }
    }

    /// Whether the robot opened this operator's session (a frame of the robot in it arrived).
    pub fn confirmed(&self) -> bool {
        matches!(
            self.state,
            OpState::Established {
                confirmed: true,
                ..
            }
        )
    }

    /// The robot's newest [`Message::Busy`] answer, until the next handshake begins.
    pub fn busy(&self) -> Option<Busy> {
        self.busy
    }

    /// Receive statistics.
    pub fn counters(&self) -> &LinkCounters {
        &self.counters
    }

    /// The session id once established.
    pub fn session_id(&self) -> Option<u64> {
        match &self.state {
            OpState::Established { session, .. } => Some(session.id),
            _ => None,
        }
    }

    /// The robot's answer to the handshake, once established.
    pub fn info(&self) -> Option<RobotInfo> {
        match &self.state {
            OpState::Established { info, .. } => Some(*info),
            _ => None,
        }
    }

    /// The sequence number the next session frame will carry (`None` before the handshake).
    pub fn next_seq(&self) -> Option<u64> {
        match &self.state {
            OpState::Established { session, .. } => Some(session.tx_seq),
            _ => None,
        }
    }

    /// Why the robot ended this session, if it did ([`Message::SessionEnd`]).
    pub fn ended(&self) -> Option<EndReason> {
        self.ended
    }

    /// Counts a frame dropped before decoding.
    pub fn count_framing_drop(&mut self) {
        self.counters.framing = self.counters.framing.saturating_add(1);
    }

    /// Encodes a Hello into `out`: a fresh nonce from `rng` for a new handshake, the same one
    /// for a retransmission while waiting for the answer. Returns the bytes written.
    ///
    /// # Errors
    /// [`EncodeError::Entropy`], [`EncodeError::TooLarge`].
    pub fn hello(&mut self, rng: &mut impl Entropy, out: &mut [u8]) -> Result<usize, EncodeError> {
        let nonce = match self.state {
            OpState::Handshaking(n) => n,
            _ => {
                let mut n = [0u8; NONCE_LEN];
                rng.fill(&mut n)?;
                self.state = OpState::Handshaking(n);
                self.ended = None;
                self.busy = None;
                n
            }
        };
        let h = Hello {
            protocol: PROTOCOL_VERSION,
            client_nonce: nonce,
        };
        encode_hello(&h, self.key.as_ref(), out)
    }

    /// Encodes `msg` in this operator's session: as an open frame (with the handshake's
    /// [`Opening`]) until the robot confirmed the session, as a session frame after.
    ///
    /// # Errors
    /// [`EncodeError::NoSession`] before the handshake, [`EncodeError::TooLarge`].
    pub fn encode(&mut self, msg: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
        match &mut self.state {
            OpState::Established {
                session,
                confirmed: true,
                ..
            } => session.encode(msg, out),
            OpState::Established {
                session, opening, ..
            } => session.encode_opening(msg, opening, out),
            _ => Err(EncodeError::NoSession),
        }
    }

    /// Decodes one frame (decoded in place): the answer to this operator's Hello, or a
    /// message of its session. Counts the frame in exactly one counter.
    ///
    /// # Errors
    /// [`DropReason`]: the frame was dropped.
    pub fn receive(&mut self, frame: &mut [u8]) -> Result<OperatorEvent, DropReason> {
        let r = self.receive_inner(frame);
        self.counters.count(&r);
        r
    }

    fn receive_inner(&mut self, frame: &mut [u8]) -> Result<OperatorEvent, DropReason> {
        let p = parse_frame(frame)?;
        match p.header.kind {
            FrameKind::Hello | FrameKind::Open => Err(DropReason::Malformed),
            FrameKind::HelloAck => {
                p.verify(self.key.as_ref().map(Key::mac))?;
                if p.header.session != 0 || p.header.seq != 0 {
                    return Err(DropReason::Malformed);
                }
                let ack = match postcard::take_from_bytes::<HelloAck>(p.body) {
                    Ok((a, [])) => a,
                    _ => return Err(DropReason::Malformed),
                };
                match &self.state {
                    OpState::Handshaking(n) if *n == ack.client_nonce => {
                        let (id, ks) = Session::derive(self.key.as_ref(), n, &ack.robot_nonce);
                        self.state = OpState::Established {
                            session: Session::new(id, &ks, self.key.is_some()),
                            opening: Opening {
                                client_nonce: *n,
                                epoch: ack.epoch,
                                take_over: self.take_over,
                            },
                            info: ack.info,
                            confirmed: false,
                        };
                        Ok(OperatorEvent::Established(ack.info))
                    }
                    // A retransmitted answer to the Hello this session came from.
                    OpState::Established { opening, .. }
                        if opening.client_nonce == ack.client_nonce =>
                    {
                        Err(DropReason::Replay(0))
                    }
                    _ => Err(DropReason::Session(p.header.session)),
                }
            }
            FrameKind::Session => match &mut self.state {
                OpState::Established {
                    session, confirmed, ..
                } if session.id == p.header.session => {
                    if !*confirmed {
                        // Before the robot opened the session, its only frames in it are Busy
                        // answers (at the open frames' numbers): they must not move the window.
                        let msg = session.peek(&p)?;
                        if let Message::Busy(b) = msg {
                            // The robot used this handshake up: the next `hello` starts anew.
                            self.busy = Some(b);
                            self.state = OpState::Idle;
                            return Ok(OperatorEvent::Busy(b));
                        }
                    }
                    let (seq, msg) = session.open(&p, false)?;
                    if matches!(msg, Message::Busy(_)) {
                        // A (delayed) Busy answer after the session opened: stale.
                        return Err(DropReason::Replay(seq));
                    }
                    *confirmed = true;
                    self.busy = None;
                    if let Message::SessionEnd(r) = msg {
                        self.ended = Some(r);
                    }
                    Ok(OperatorEvent::Message { seq, msg })
                }
                _ => Err(DropReason::Session(p.header.session)),
            },
        }
    }
}
