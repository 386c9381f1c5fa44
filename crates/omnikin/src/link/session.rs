//! One established session as both ends hold it: the key derivation of the handshake, the
//! session's MAC state, outgoing sequence numbers and incoming replay window.

use super::{
    DropReason, EncodeError, Key, MacKey, Message, NONCE_LEN, Opening, Parsed, ReplayWindow,
    decode_message, encode_message, encode_open,
};

/// One direction-pair of an established session: its id, MAC key, outgoing sequence numbers
/// and incoming replay window.
#[derive(Clone, Debug)]
pub(super) struct Session {
    pub(super) id: u64,
    pub(super) mac: Option<MacKey>,
    pub(super) tx_seq: u64,
    pub(super) window: ReplayWindow,
}

impl Session {
    /// The session id and key `K_s` of a handshake.
    pub(super) fn derive(
        psk: Option<&Key>,
        client: &[u8; NONCE_LEN],
        robot: &[u8; NONCE_LEN],
    ) -> (u64, [u8; 32]) {
        let empty;
        let base = match psk {
            Some(k) => &k.mac,
            None => {
                empty = MacKey::new(&[]);
                &empty
            }
        };
        let prk = MacKey::new(&base.full(&[b"omnikin-v2 session", client, robot]));
        let ks = prk.full(&[b"omnikin-v2 key"]);
        let idb = prk.full(&[b"omnikin-v2 id"]);
        let mut id = [0u8; 8];
        id.copy_from_slice(&idb[..8]);
        (u64::from_le_bytes(id).max(1), ks)
    }

    /// A fresh session (keyed MAC state built here, once).
    pub(super) fn new(id: u64, ks: &[u8; 32], keyed: bool) -> Self {
        Session {
            id,
            mac: keyed.then(|| MacKey::new(ks)),
            tx_seq: 1,
            window: ReplayWindow::default(),
        }
    }

    pub(super) fn encode(&mut self, msg: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
        let n = encode_message(self.id, self.tx_seq, msg, self.mac.as_ref(), out)?;
        self.tx_seq = self.tx_seq.saturating_add(1);
        Ok(n)
    }

    /// An operator's open frame: `msg` with the handshake's `opening` (next sequence number).
    pub(super) fn encode_opening(
        &mut self,
        msg: &Message,
        opening: &Opening,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        let n = encode_open(self.id, self.tx_seq, opening, msg, self.mac.as_ref(), out)?;
        self.tx_seq = self.tx_seq.saturating_add(1);
        Ok(n)
    }

    /// `msg` at sequence number `seq`, without touching the outgoing counter (a robot's
    /// [`Message::Busy`] answer in a session it does not open: it echoes the open frame's
    /// number).
    pub(super) fn encode_at(
        &self,
        seq: u64,
        msg: &Message,
        out: &mut [u8],
    ) -> Result<usize, EncodeError> {
        encode_message(self.id, seq, msg, self.mac.as_ref(), out)
    }

    /// Verifies the tag and decodes `p` without the replay window (a [`Message::Busy`] answer
    /// before the session is confirmed, which must not move the window).
    pub(super) fn peek(&self, p: &Parsed<'_>) -> Result<Message, DropReason> {
        p.verify(self.mac.as_ref())?;
        decode_message(p.body)
    }

    /// Verifies, checks freshness and decodes a frame of this session; `to_robot` says which
    /// end is receiving. Both directions share `K_s`, so a message for the other end (a
    /// robot's own telemetry reflected back to it, an operator's command sent back to the
    /// operator) carries a valid tag: it is dropped as malformed before it can move the
    /// replay window (which would lock out the peer's lower sequence numbers) or `ack_seq`.
    pub(super) fn open(
        &mut self,
        p: &Parsed<'_>,
        to_robot: bool,
    ) -> Result<(u64, Message), DropReason> {
        p.verify(self.mac.as_ref())?;
        let seq = p.header.seq;
        if !self.window.is_fresh(seq) {
            return Err(DropReason::Replay(seq));
        }
        let msg = decode_message(p.body)?;
        if msg.for_robot() != to_robot {
            return Err(DropReason::Malformed);
        }
        self.window.accept(seq);
        Ok((seq, msg))
    }
}
