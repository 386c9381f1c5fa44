//! The operator's end of the link ([`OperatorLink`]): its handshake and its one session.

use super::session::Session;
use super::{
    DropReason, EncodeError, EndReason, Hello, HelloAck, Key, Kind, LinkCounters, Message,
    NONCE_LEN, PROTOCOL_VERSION, RobotInfo, encode_hello, parse_frame,
};
use crate::runtime::hal::Entropy;

/// What [`OperatorLink::receive`] got.
// No heap in the core: the large variant is a value, not a Box.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum OperatorEvent {
    /// The robot answered this operator's Hello: the session is established (the robot takes
    /// it over once the first session frame reaches it).
    Established(RobotInfo),
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
        client_nonce: [u8; NONCE_LEN],
        info: RobotInfo,
    },
}

/// The operator's end of the link: its handshake and its one session.
#[derive(Clone, Debug)]
pub struct OperatorLink {
    key: Option<Key>,
    state: OpState,
    ended: Option<EndReason>,
    counters: LinkCounters,
}

impl OperatorLink {
    /// An operator end with an optional pre-shared key.
    pub fn new(key: Option<Key>) -> Self {
        Self {
            key,
            state: OpState::Idle,
            ended: None,
            counters: LinkCounters::default(),
        }
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
                n
            }
        };
        let h = Hello {
            protocol: PROTOCOL_VERSION,
            client_nonce: nonce,
        };
        encode_hello(&h, self.key.as_ref(), out)
    }

    /// Encodes `msg` in this operator's session.
    ///
    /// # Errors
    /// [`EncodeError::NoSession`] before the handshake, [`EncodeError::TooLarge`].
    pub fn encode(&mut self, msg: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
        match &mut self.state {
            OpState::Established { session, .. } => session.encode(msg, out),
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
            Kind::Hello => Err(DropReason::Malformed),
            Kind::HelloAck => {
                p.verify(self.key.as_ref().map(Key::mac))?;
                let ack = match postcard::take_from_bytes::<HelloAck>(p.body) {
                    Ok((a, [])) => a,
                    _ => return Err(DropReason::Malformed),
                };
                match &self.state {
                    OpState::Handshaking(n) if *n == ack.client_nonce => {
                        let (id, ks) = Session::derive(self.key.as_ref(), n, &ack.robot_nonce);
                        if id != p.header.session {
                            return Err(DropReason::Session(p.header.session));
                        }
                        self.state = OpState::Established {
                            session: Session::new(id, &ks, self.key.is_some()),
                            client_nonce: *n,
                            info: ack.info,
                        };
                        Ok(OperatorEvent::Established(ack.info))
                    }
                    // A retransmitted answer to the Hello this session came from.
                    OpState::Established { client_nonce, .. }
                        if *client_nonce == ack.client_nonce =>
                    {
                        Err(DropReason::Replay(0))
                    }
                    _ => Err(DropReason::Session(p.header.session)),
                }
            }
            Kind::Session => match &mut self.state {
                OpState::Established { session, .. } if session.id == p.header.session => {
                    let (seq, msg) = session.open(&p, false)?;
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
