//! Authentication and freshness: the HMAC-SHA256 key state ([`MacKey`]), the pre-shared key
//! ([`Key`]) and the sliding replay window over sequence numbers ([`ReplayWindow`]).

use hmac::{Hmac, Mac};
use sha2::Sha256;

use super::TAG_LEN;

/// An HMAC-SHA256 key with its key schedule done once: each tag clones the keyed state
/// (inner and outer hash primed with the padded key) instead of hashing the key again.
#[derive(Clone)]
pub struct MacKey {
    mac: Hmac<Sha256>,
}

impl core::fmt::Debug for MacKey {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("MacKey(..)")
    }
}

impl MacKey {
    /// The keyed state of `key` (any length; HMAC hashes keys longer than 64 bytes).
    pub fn new(key: &[u8]) -> Self {
        let mac = match Hmac::<Sha256>::new_from_slice(key) {
            Ok(m) => m,
            // Unreachable: HMAC takes keys of any length.
            Err(_) => <Hmac<Sha256> as hmac::digest::KeyInit>::new(&Default::default()),
        };
        Self { mac }
    }

    /// The full 32-byte HMAC of the concatenation of `parts`.
    pub fn full(&self, parts: &[&[u8]]) -> [u8; 32] {
        let mut m = self.mac.clone();
        for p in parts {
            m.update(p);
        }
        m.finalize().into_bytes().into()
    }

    /// The [`TAG_LEN`]-byte tag of `data`.
    pub fn tag(&self, data: &[u8]) -> [u8; TAG_LEN] {
        let full = self.full(&[data]);
        let mut out = [0u8; TAG_LEN];
        out.copy_from_slice(&full[..TAG_LEN]);
        out
    }
}

/// A pre-shared key (PSK, 1–64 bytes; use at least 16 random bytes), kept as its keyed MAC
/// state.
#[derive(Clone)]
pub struct Key {
    pub(super) mac: MacKey,
    len: usize,
}

impl core::fmt::Debug for Key {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "Key({} bytes)", self.len)
    }
}

/// A key of the wrong length.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("key must be 1 to 64 bytes (got {len})")]
pub struct KeyError {
    /// The length given.
    pub len: usize,
}

impl Key {
    /// A key from its bytes.
    ///
    /// # Errors
    /// [`KeyError`] when `bytes` is empty or longer than 64 bytes.
    pub fn new(bytes: &[u8]) -> Result<Self, KeyError> {
        if bytes.is_empty() || bytes.len() > 64 {
            return Err(KeyError { len: bytes.len() });
        }
        Ok(Self {
            mac: MacKey::new(bytes),
            len: bytes.len(),
        })
    }

    /// The keyed MAC state of the PSK (tags of handshake frames).
    pub fn mac(&self) -> &MacKey {
        &self.mac
    }
}

/// Sliding-window replay filter over 64-bit sequence numbers (RFC 4303 style, 64 frames).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReplayWindow {
    top: u64,
    bits: u64,
}

impl ReplayWindow {
    /// `true` if `seq` is fresh: above the highest seen, or within the 64 below it and not yet
    /// seen. `seq = 0` is never fresh.
    pub fn is_fresh(&self, seq: u64) -> bool {
        if seq == 0 {
            return false;
        }
        if seq > self.top {
            return true;
        }
        let back = self.top - seq;
        back < 64 && self.bits & (1u64 << back) == 0
    }

    /// Records `seq` as seen (call only after [`ReplayWindow::is_fresh`] and authentication).
    pub fn accept(&mut self, seq: u64) {
        if seq > self.top {
            let shift = seq - self.top;
            self.bits = if shift >= 64 { 0 } else { self.bits << shift };
            self.bits |= 1;
            self.top = seq;
        } else {
            let back = self.top - seq;
            if back < 64 {
                self.bits |= 1u64 << back;
            }
        }
    }

    /// Highest sequence number accepted so far (0: none).
    pub fn top(&self) -> u64 {
        self.top
    }
}
