//! What goes wrong on the link: why a frame was not sent ([`EncodeError`]), why one was
//! dropped ([`DropReason`]), and the [`LinkCounters`] that count every frame in exactly one
//! field.

use serde::{Deserialize, Serialize};

use super::PROTOCOL_VERSION;
use crate::runtime::hal::EntropyError;

/// Link statistics: every dropped frame is counted in exactly one field.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkCounters {
    /// Frames accepted (decoded, authentic, fresh).
    pub ok: u32,
    /// Dropped: COBS error, too long, too short, or cut off (truncated) at the end of a
    /// datagram.
    pub framing: u32,
    /// Dropped: CRC mismatch.
    pub crc: u32,
    /// Dropped: other protocol version.
    pub version: u32,
    /// Dropped: missing or wrong authentication tag.
    pub auth: u32,
    /// Dropped: repeated or too-old sequence number (duplicate or replay), a repeat of the
    /// Hello that opened the active session, or a repeated answer to this operator's Hello.
    pub replay: u32,
    /// Dropped: body is not a valid message (postcard error, trailing bytes, unknown kind,
    /// unpadded Hello, a frame meant for the other end).
    pub malformed: u32,
    /// Dropped: a frame of a session that is not this endpoint's (a recording of an old
    /// session, a guessed id, a frame from before a restart) or an answer to a Hello this
    /// endpoint did not send.
    pub session: u32,
    /// Dropped: a Hello that could not be answered because the entropy source failed.
    pub entropy: u32,
    /// Dropped unread by the host: a Hello over its sender's rate (a flood; the host's
    /// limiter, [`RobotLink::count_throttled`](super::RobotLink::count_throttled)).
    pub throttled: u32,
    /// Not a drop — these frames are also counted in `ok`: authentic, fresh commands that were
    /// not executed because an e-stop with a higher sequence number was accepted before them
    /// (a clear or motion command held back and delivered late).
    pub stale: u32,
}

impl LinkCounters {
    /// Total frames dropped.
    pub fn dropped(&self) -> u32 {
        self.framing
            .saturating_add(self.crc)
            .saturating_add(self.version)
            .saturating_add(self.auth)
            .saturating_add(self.replay)
            .saturating_add(self.malformed)
            .saturating_add(self.session)
            .saturating_add(self.entropy)
            .saturating_add(self.throttled)
    }
}

/// Why a frame was not sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    /// The message does not fit [`MAX_BODY`](super::MAX_BODY) or the output buffer.
    #[error("message too large for one frame")]
    TooLarge,
    /// No established session to send it in (handshake first).
    #[error("no session: the handshake has not completed")]
    NoSession,
    /// The entropy source failed while making a nonce.
    #[error("the entropy source failed")]
    Entropy,
}

impl From<EntropyError> for EncodeError {
    fn from(_: EntropyError) -> Self {
        EncodeError::Entropy
    }
}

/// Why a frame was dropped (each maps to one [`LinkCounters`] field).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DropReason {
    /// COBS error, wrong length, or truncated.
    #[error("framing error")]
    Framing,
    /// CRC mismatch.
    #[error("CRC mismatch")]
    Crc,
    /// Other protocol version.
    #[error("protocol version {0}, expected {PROTOCOL_VERSION}")]
    Version(u8),
    /// Missing, unexpected or wrong tag.
    #[error("not authenticated")]
    Auth,
    /// Repeated or too-old sequence number.
    #[error("replayed or duplicate sequence number {0}")]
    Replay(u64),
    /// Body not a valid message, or a frame kind this end does not take.
    #[error("malformed message")]
    Malformed,
    /// A frame of a session that is not this endpoint's.
    #[error("frame of another session ({0:#018x})")]
    Session(u64),
    /// A Hello that could not be answered: no entropy.
    #[error("no entropy to answer a hello")]
    Entropy,
}

impl LinkCounters {
    pub(super) fn count<T>(&mut self, r: &Result<T, DropReason>) {
        let slot = match r {
            Ok(_) => &mut self.ok,
            Err(DropReason::Framing) => &mut self.framing,
            Err(DropReason::Crc) => &mut self.crc,
            Err(DropReason::Version(_)) => &mut self.version,
            Err(DropReason::Auth) => &mut self.auth,
            Err(DropReason::Replay(_)) => &mut self.replay,
            Err(DropReason::Malformed) => &mut self.malformed,
            Err(DropReason::Session(_)) => &mut self.session,
            Err(DropReason::Entropy) => &mut self.entropy,
        };
        *slot = slot.saturating_add(1);
    }
}
