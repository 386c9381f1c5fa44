//! The robot's handshake secrets ([`HandshakeSecrets`]): a stateless answer to a Hello, and
//! the bounded memory that refuses a replayed first frame.
//!
//! The robot keeps **no state for an unproven peer** (DTLS 1.3 cookies, QUIC Retry tokens and
//! WireGuard's cookie reply rest on the same idea). Its nonce for a Hello is not random but
//! derived: `robot_nonce = HMAC(secret_e, "omnikin-v3 robot nonce" | client_nonce | len(peer)
//! | peer)[..16]` with the secret of the current epoch `e` and the sender's transport address
//! `peer` (empty on a point-to-point link such as a serial port). The HelloAck names `e`; the
//! operator's first session frames ([`FrameKind::Open`](super::FrameKind::Open)) carry `client_nonce`
//! and `e` back, so the robot re-derives the nonce — for the address the open frame came from
//! — the session id and the session key, and verifies the frame's tag under that key: the
//! proof that the sender holds the pre-shared key *and* received the HelloAck at that address
//! (DTLS binds its cookie to the client's address the same way). Only then does a session
//! exist.
//!
//! Secrets rotate: an epoch lasts [`EPOCH_US`] of robot time, and a first frame is taken only
//! in the current epoch or the one before it while that is younger than two epochs — a
//! handshake has between one and two epochs to complete, a recorded first frame is useless
//! after that. Within those two epochs, each epoch remembers the client nonces of the sessions
//! it opened ([`USED_PER_EPOCH`] at most): a replayed first frame of a session that was opened
//! (and perhaps since replaced) is refused as a replay before any cryptography is done. An
//! epoch whose list is full is retired at once (nothing more can open in it) and a new one
//! starts with the next Hello, so the list never has to forget a nonce while its secret lives.
//! Epoch numbers start at a random value at boot: a first frame recorded before a restart names
//! an epoch the robot does not have.

use super::{MacKey, NONCE_LEN};
use crate::runtime::hal::{Entropy, EntropyError};

/// Robot time an epoch of the handshake secret lasts, µs: a HelloAck is good for between one
/// and two epochs (10–20 s).
pub const EPOCH_US: u64 = 10_000_000;

/// Sessions one epoch can open; the epoch retires when they are used up.
pub const USED_PER_EPOCH: usize = 8;

#[derive(Clone, Debug)]
struct Epoch {
    number: u32,
    /// `None`: retired (full) or never started.
    secret: Option<MacKey>,
    started_us: u64,
    used: [[u8; NONCE_LEN]; USED_PER_EPOCH],
    n_used: usize,
}

impl Epoch {
    const EMPTY: Epoch = Epoch {
        number: 0,
        secret: None,
        started_us: 0,
        used: [[0; NONCE_LEN]; USED_PER_EPOCH],
        n_used: 0,
    };

    fn is_used(&self, client_nonce: &[u8; NONCE_LEN]) -> bool {
        self.used[..self.n_used].iter().any(|u| u == client_nonce)
    }
}

/// The robot's two live handshake epochs (current and previous): their secrets and the client
/// nonces each has opened a session for.
#[derive(Clone, Debug)]
pub struct HandshakeSecrets {
    /// `epochs[current]` is the current epoch, the other one the previous.
    epochs: [Epoch; 2],
    current: usize,
    /// Whether the first epoch has been started (its number drawn).
    started: bool,
}

impl Default for HandshakeSecrets {
    fn default() -> Self {
        Self::new()
    }
}

/// What [`HandshakeSecrets::check`] found for a first frame's epoch and client nonce.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FirstFrame {
    /// The epoch is live and the nonce unused: the robot's nonce for it.
    Fresh([u8; NONCE_LEN]),
    /// The epoch opened a session for this nonce already: a replay.
    Used,
    /// No live epoch of that number (expired, retired, from before a restart, or forged).
    UnknownEpoch,
}

impl HandshakeSecrets {
    /// No epoch yet: the first Hello starts one.
    pub const fn new() -> Self {
        Self {
            epochs: [Epoch::EMPTY, Epoch::EMPTY],
            current: 0,
            started: false,
        }
    }

    fn robot_nonce(
        secret: &MacKey,
        client_nonce: &[u8; NONCE_LEN],
        peer: &[u8],
    ) -> [u8; NONCE_LEN] {
        let len = (peer.len() as u32).to_le_bytes();
        let full = secret.full(&[b"omnikin-v3 robot nonce", client_nonce, &len, peer]);
        let mut n = [0u8; NONCE_LEN];
        n.copy_from_slice(&full[..NONCE_LEN]);
        n
    }

    /// The epoch a Hello from transport address `peer` is answered in at robot time `now_us`,
    /// and the robot's nonce for `client_nonce` and `peer`: the current epoch, or a new one (secret drawn from `rng`) when the
    /// current is older than [`EPOCH_US`], retired, or none has started.
    ///
    /// # Errors
    /// [`EntropyError`] when a new secret is needed and `rng` fails (the Hello is then not
    /// answered).
    pub fn answer(
        &mut self,
        now_us: u64,
        client_nonce: &[u8; NONCE_LEN],
        peer: &[u8],
        rng: &mut impl Entropy,
    ) -> Result<(u32, [u8; NONCE_LEN]), EntropyError> {
        let cur = &self.epochs[self.current];
        // A clock that went back (set, or a boot at 0 after a correction) ends the epoch too:
        // an age is never taken as 0 for a time before the epoch began.
        let due = !self.started
            || cur.secret.is_none()
            || now_us < cur.started_us
            || now_us - cur.started_us >= EPOCH_US;
        if due {
            self.rotate(now_us, rng)?;
        }
        let cur = &self.epochs[self.current];
        match &cur.secret {
            Some(s) => Ok((cur.number, Self::robot_nonce(s, client_nonce, peer))),
            None => Err(EntropyError),
        }
    }

    /// Starts a new epoch at `now_us`: the current one becomes the previous, the previous is
    /// forgotten.
    fn rotate(&mut self, now_us: u64, rng: &mut impl Entropy) -> Result<(), EntropyError> {
        let mut key = [0u8; 32];
        rng.fill(&mut key)?;
        let number = if self.started {
            self.epochs[self.current].number.wrapping_add(1)
        } else {
            let mut b = [0u8; 4];
            rng.fill(&mut b)?;
            u32::from_le_bytes(b)
        };
        let next = 1 - self.current;
        self.epochs[next] = Epoch {
            number,
            secret: Some(MacKey::new(&key)),
            started_us: now_us,
            ..Epoch::EMPTY
        };
        self.current = next;
        self.started = true;
        Ok(())
    }

    /// The live epoch numbered `epoch` at `now_us`: the current one, or the previous one while
    /// the current is younger than one epoch (so the previous is younger than two).
    fn live(&self, epoch: u32, now_us: u64) -> Option<usize> {
        if !self.started {
            return None;
        }
        let cur = self.current;
        let prev = 1 - cur;
        // `None` for a time before the epoch began (a clock that went back): not live.
        let age = |i: usize| now_us.checked_sub(self.epochs[i].started_us);
        [cur, prev].into_iter().find(|&i| {
            let e = &self.epochs[i];
            e.secret.is_some()
                && e.number == epoch
                && age(i).is_some_and(|a| a < 2 * EPOCH_US)
                && (i == cur || age(cur).is_some_and(|a| a < EPOCH_US))
        })
    }

    /// Checks a first frame's `epoch` and `client_nonce`, received from `peer` at `now_us` (no
    /// state changes): one table look-up and, if the epoch is live and the nonce unused, one
    /// HMAC.
    pub fn check(
        &self,
        epoch: u32,
        client_nonce: &[u8; NONCE_LEN],
        peer: &[u8],
        now_us: u64,
    ) -> FirstFrame {
        let Some(i) = self.live(epoch, now_us) else {
            return FirstFrame::UnknownEpoch;
        };
        let e = &self.epochs[i];
        if e.is_used(client_nonce) {
            return FirstFrame::Used;
        }
        match &e.secret {
            Some(s) => FirstFrame::Fresh(Self::robot_nonce(s, client_nonce, peer)),
            None => FirstFrame::UnknownEpoch,
        }
    }

    /// Records that `epoch` opened a session for `client_nonce` (after its first frame was
    /// verified); an epoch whose list is then full retires (its secret is dropped). Returns
    /// `false` — and records nothing — when the epoch is not live.
    pub fn mark_used(&mut self, epoch: u32, client_nonce: &[u8; NONCE_LEN], now_us: u64) -> bool {
        let Some(i) = self.live(epoch, now_us) else {
            return false;
        };
        let e = &mut self.epochs[i];
        if e.n_used < USED_PER_EPOCH && !e.is_used(client_nonce) {
            e.used[e.n_used] = *client_nonce;
            e.n_used += 1;
        }
        if e.n_used >= USED_PER_EPOCH {
            // Nothing more can open in it: forget the secret, so no replay of its first
            // frames can ever be taken (the used list cannot grow to remember more).
            e.secret = None;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Counter(u8);
    impl Entropy for Counter {
        fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError> {
            for b in buf {
                self.0 = self.0.wrapping_add(1);
                *b = self.0;
            }
            Ok(())
        }
    }

    #[test]
    fn an_answer_is_stateless_and_repeatable_within_an_epoch() {
        let mut s = HandshakeSecrets::new();
        let mut rng = Counter(0);
        let cn = [7u8; NONCE_LEN];
        let (e, a) = s.answer(0, &cn, b"a", &mut rng).unwrap();
        let (e2, b) = s.answer(EPOCH_US - 1, &cn, b"a", &mut rng).unwrap();
        assert_eq!((e, a), (e2, b));
        assert_eq!(s.check(e, &cn, b"a", EPOCH_US - 1), FirstFrame::Fresh(a));
        // Another nonce, or another address, another robot nonce.
        let (_, c) = s.answer(1, &[8u8; NONCE_LEN], b"a", &mut rng).unwrap();
        assert_ne!(a, c);
        let (_, d) = s.answer(1, &cn, b"b", &mut rng).unwrap();
        assert_ne!(a, d);
        assert_ne!(s.check(e, &cn, b"b", 2), FirstFrame::Fresh(a));
        let (_, x) = s.answer(1, &cn, b"", &mut rng).unwrap();
        assert_ne!(a, x);
    }

    #[test]
    fn epochs_expire_and_used_nonces_are_refused() {
        let mut s = HandshakeSecrets::new();
        let mut rng = Counter(0);
        let cn = [1u8; NONCE_LEN];
        let (e0, n0) = s.answer(0, &cn, b"a", &mut rng).unwrap();
        assert!(s.mark_used(e0, &cn, 5));
        assert_eq!(s.check(e0, &cn, b"", 6), FirstFrame::Used);
        // The next epoch: e0 is the previous one, still live for one epoch.
        let (e1, _) = s.answer(EPOCH_US, &[2; NONCE_LEN], b"", &mut rng).unwrap();
        assert_eq!(e1, e0.wrapping_add(1));
        assert_eq!(s.check(e0, &cn, b"", EPOCH_US + 1), FirstFrame::Used);
        assert_eq!(
            s.check(e0, &[3; NONCE_LEN], b"", EPOCH_US + 1),
            FirstFrame::Fresh(HandshakeSecrets::robot_nonce(
                s.epochs[1 - s.current].secret.as_ref().unwrap(),
                &[3; NONCE_LEN],
                b""
            ))
        );
        let _ = n0;
        // Two epochs after it started, e0 is gone even without another Hello.
        assert_eq!(
            s.check(e0, &[3; NONCE_LEN], b"", 2 * EPOCH_US),
            FirstFrame::UnknownEpoch
        );
        // A number no live epoch has.
        assert_eq!(
            s.check(e1.wrapping_add(5), &cn, b"", EPOCH_US + 1),
            FirstFrame::UnknownEpoch
        );
    }

    #[test]
    fn a_full_epoch_retires_and_the_next_hello_starts_another() {
        let mut s = HandshakeSecrets::new();
        let mut rng = Counter(0);
        let (e0, _) = s.answer(0, &[0; NONCE_LEN], b"", &mut rng).unwrap();
        for i in 0..USED_PER_EPOCH as u8 {
            assert!(s.mark_used(e0, &[i; NONCE_LEN], 1));
        }
        // Retired: neither used nor unused nonces of it are taken any more.
        assert_eq!(
            s.check(e0, &[0; NONCE_LEN], b"", 2),
            FirstFrame::UnknownEpoch
        );
        assert_eq!(
            s.check(e0, &[99; NONCE_LEN], b"", 2),
            FirstFrame::UnknownEpoch
        );
        let (e1, _) = s.answer(3, &[99; NONCE_LEN], b"", &mut rng).unwrap();
        assert_ne!(e1, e0);
        assert!(matches!(
            s.check(e1, &[99; NONCE_LEN], b"", 4),
            FirstFrame::Fresh(_)
        ));
    }

    #[test]
    fn a_clock_that_goes_back_ends_the_epoch() {
        let mut s = HandshakeSecrets::new();
        let mut rng = Counter(0);
        let cn = [5u8; NONCE_LEN];
        let (e0, _) = s.answer(5 * EPOCH_US, &cn, b"", &mut rng).unwrap();
        assert!(matches!(
            s.check(e0, &cn, b"", 5 * EPOCH_US),
            FirstFrame::Fresh(_)
        ));
        // Back to boot time: the epoch is not live, and the next Hello starts another.
        assert_eq!(s.check(e0, &cn, b"", 0), FirstFrame::UnknownEpoch);
        let (e1, _) = s.answer(0, &cn, b"", &mut rng).unwrap();
        assert_ne!(e1, e0);
        assert_eq!(s.check(e0, &cn, b"", 1), FirstFrame::UnknownEpoch);
    }

    #[test]
    fn entropy_failure_answers_nothing() {
        struct Broken;
        impl Entropy for Broken {
            fn fill(&mut self, _: &mut [u8]) -> Result<(), EntropyError> {
                Err(EntropyError)
            }
        }
        let mut s = HandshakeSecrets::new();
        assert!(s.answer(0, &[0; NONCE_LEN], b"", &mut Broken).is_err());
        assert_eq!(
            s.check(0, &[0; NONCE_LEN], b"", 0),
            FirstFrame::UnknownEpoch
        );
    }
}
