//! Consistent Overhead Byte Stuffing: removes every `0x00` from a frame so that one `0x00`
//! delimits frames on the byte stream.

/// COBS-decodes `buf` in place (one frame, without its delimiter); returns the decoded length,
/// or `None` for a zero byte or a block running past the end. A byte loop without the `cobs`
/// crate's per-byte state machine (the link's hottest code: see `bench/instructions.sh
/// link-open`); property-tested against the `cobs` crate in both directions.
pub fn cobs_decode_in_place(buf: &mut [u8]) -> Option<usize> {
    let n = buf.len();
    let (mut r, mut w) = (0usize, 0usize);
    while r < n {
        let code = buf[r] as usize;
        if code == 0 {
            return None;
        }
        let end = r + code;
        if end > n {
            return None;
        }
        r += 1;
        while r < end {
            let b = buf[r];
            if b == 0 {
                return None;
            }
            buf[w] = b;
            w += 1;
            r += 1;
        }
        if code != 0xFF && r < n {
            buf[w] = 0;
            w += 1;
        }
    }
    Some(w)
}

/// COBS-encodes `src` into `out` (no delimiter); returns the encoded length, or `None` when
/// `out` is shorter than [`cobs_max_len`]`(src.len())`.
pub fn cobs_encode(src: &[u8], out: &mut [u8]) -> Option<usize> {
    if out.len() < cobs_max_len(src.len()) {
        return None;
    }
    let (mut code_at, mut w, mut code) = (0usize, 1usize, 1u8);
    for &b in src {
        if b == 0 {
            out[code_at] = code;
            code_at = w;
            w += 1;
            code = 1;
        } else {
            out[w] = b;
            w += 1;
            code += 1;
            if code == 0xFF {
                out[code_at] = code;
                code_at = w;
                w += 1;
                code = 1;
            }
        }
    }
    out[code_at] = code;
    Some(w)
}

/// The longest COBS encoding of `n` bytes: one code byte per started 254-byte block, plus one.
pub const fn cobs_max_len(n: usize) -> usize {
    n + n / 254 + 1
}
