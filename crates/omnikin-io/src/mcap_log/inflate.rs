//! Compressed MCAP chunks made plain, with bounded memory, before the pre-scan sees the file.
//!
//! omnikin writes its logs with zstd-compressed chunks (<https://mcap.dev/spec>: a chunk record
//! is `message_start_time u64, message_end_time u64, uncompressed_size u64,
//! uncompressed_crc u32, compression string, records u64-length bytes`). [`inflate`] walks the
//! file's top-level records and returns a copy in which every zstd chunk is replaced by the
//! same chunk uncompressed (compression `""`, the same times, size and CRC: the CRC is of the
//! uncompressed records), so [`super::scan`] checks the records inside every chunk and the
//! reader indexes messages in place. Before a chunk is decompressed:
//!
//! - its declared uncompressed size must be at most [`MAX_CHUNK_BYTES`] (a chunk that declares
//!   more is refused before anything is allocated), and the copy as a whole at most
//!   [`MAX_INFLATED_BYTES`];
//! - the decompressor writes into a buffer of exactly the declared size and fails when the
//!   data would need more (a zstd bomb, or a chunk that lies about its size); fewer bytes than
//!   declared is a lie as well.
//!
//! So the memory is the file, plus the copy (at most [`MAX_INFLATED_BYTES`]) when the file has
//! compressed chunks. A file without any is returned as it is (borrowed). A chunk that breaks a
//! rule ends the copy before it, as damage that names the chunk's byte offset in the file and
//! the rule (the records before it are read, as for a truncated file); a broken limit refuses
//! the file. Records are otherwise copied as they are: the pre-scan checks them. Once a chunk
//! was decompressed, a record that runs past the end of the file and a file without a footer
//! are named here, at the file's byte offsets; other damage the pre-scan names at offsets in
//! the copy.
//! The copy is for reading in file order only: the summary section's offsets (chunk indexes)
//! still point into the original file, and the data section CRC is cleared (0: "not
//! computed").

use std::borrow::Cow;

use mcap::records::op;

/// Largest declared uncompressed size of one chunk, bytes: 16 MiB (omnikin writes 64 KiB
/// chunks, [`super::CHUNK_SIZE`]; other writers use up to a few MiB).
pub const MAX_CHUNK_BYTES: u64 = 16 << 20;
/// Largest decompressed copy of a file, bytes: [`super::MAX_INPUT_BYTES`] (1 GiB), so message
/// offsets in it fit the reader's `u32`.
pub const MAX_INFLATED_BYTES: u64 = super::MAX_INPUT_BYTES;

/// Size of a record's opcode and length.
const RECORD_HEAD: usize = 9;
/// A chunk body's fixed fields before the compression string: two times, size, CRC.
const CHUNK_FIXED: usize = 28;

/// What [`inflate`] made of a file.
#[derive(Debug)]
pub struct Inflated<'a> {
    /// The file with its zstd chunks uncompressed (the file itself when it has none); on
    /// damage, the records before the broken chunk.
    pub bytes: Cow<'a, [u8]>,
    /// The first chunk that could not be decompressed: its byte offset in the file and the
    /// rule it broke.
    pub damage: Option<String>,
}

/// The fields of a chunk body `b` that [`inflate`] needs: uncompressed size, compression and
/// the records; `None` when they do not fit in the body (left to the pre-scan to name).
fn chunk_fields(b: &[u8]) -> Option<(u64, &[u8], &[u8])> {
    let size = u64::from_le_bytes(b.get(16..24)?.try_into().ok()?);
    let n = u32::from_le_bytes(b.get(CHUNK_FIXED..CHUNK_FIXED + 4)?.try_into().ok()?);
    let at = CHUNK_FIXED + 4;
    let end = at.checked_add(usize::try_from(n).ok()?)?;
    let compression = b.get(at..end)?;
    let len = u64::from_le_bytes(b.get(end..end + 8)?.try_into().ok()?);
    let records = b.get(end + 8..(end + 8).checked_add(usize::try_from(len).ok()?)?)?;
    Some((size, compression, records))
}

/// The uncompressed records of a zstd chunk that declares `size` bytes, or the rule broken.
fn decompress(records: &[u8], size: u64) -> Result<Vec<u8>, String> {
    // `size` ≤ MAX_CHUNK_BYTES was checked by the caller: this is the only allocation.
    let capacity = usize::try_from(size).map_err(|_| "too large".to_string())?;
    let out = zstd::bulk::decompress(records, capacity).map_err(|e| {
        format!("its zstd data does not decompress into the {size} bytes it declares ({e})")
    })?;
    if out.len() as u64 != size {
        return Err(format!(
            "its zstd data decompresses to {} bytes, but it declares {size}",
            out.len()
        ));
    }
    Ok(out)
}

/// The file `buf` with its zstd chunks uncompressed (see the module docs). An error when a
/// chunk declares more than [`MAX_CHUNK_BYTES`] or the copy would exceed
/// [`MAX_INFLATED_BYTES`]; a chunk that cannot be decompressed is [`Inflated::damage`].
pub fn inflate(buf: &[u8]) -> Result<Inflated<'_>, String> {
    let magic = mcap::MAGIC.len();
    let mut out: Option<Vec<u8>> = None;
    let mut at = magic.min(buf.len());
    let mut damage = None;
    let mut footer = false;
    while let Some(head) = buf.get(at..at + RECORD_HEAD) {
        let opcode = head[0];
        footer |= opcode == op::FOOTER;
        let len = u64::from_le_bytes(head[1..].try_into().unwrap_or([0; 8]));
        let body_at = at + RECORD_HEAD;
        let Some(end) = usize::try_from(len)
            .ok()
            .and_then(|l| body_at.checked_add(l))
            .filter(|&e| e <= buf.len())
        else {
            if out.is_some() {
                // Offsets in the copy no longer are the file's: name the damage here.
                damage = Some(format!(
                    "the {} at byte {at}: its length {len} runs past the end of the file ({} bytes left)",
                    super::scan::name(opcode),
                    buf.len() - body_at
                ));
            }
            break; // Otherwise copied as it is, for the pre-scan to name.
        };
        let body = &buf[body_at..end];
        let fields = (opcode == op::CHUNK)
            .then(|| chunk_fields(body))
            .flatten()
            .filter(|(_, c, _)| !c.is_empty());
        let Some((size, compression, records)) = fields else {
            if opcode == op::DATA_END
                && body.len() == 4
                && let Some(o) = out.as_mut()
            {
                // The data section changed: its CRC is "not computed" (0).
                o.extend_from_slice(head);
                o.extend_from_slice(&[0; 4]);
                at = end;
                continue;
            }
            if let Some(o) = out.as_mut() {
                o.extend_from_slice(&buf[at..end]);
            }
            at = end;
            continue;
        };
        if compression != b"zstd" {
            damage = Some(format!(
                "the chunk record at byte {at}: compression {:?}: omnikin reads zstd and uncompressed chunks",
                String::from_utf8_lossy(compression)
            ));
            break;
        }
        if size > MAX_CHUNK_BYTES {
            return Err(format!(
                "the chunk record at byte {at}: it declares {size} uncompressed bytes, more than {MAX_CHUNK_BYTES} (MAX_CHUNK_BYTES of omnikin convert)"
            ));
        }
        let o = out.get_or_insert_with(|| buf[..at].to_vec());
        // The new chunk: head, fixed fields, empty compression (4), records length (8), records.
        let grown = o.len() as u64 + (RECORD_HEAD + CHUNK_FIXED + 12) as u64 + size;
        let rest = (buf.len() - end) as u64;
        if grown + rest > MAX_INFLATED_BYTES {
            return Err(format!(
                "the chunk record at byte {at}: decompressed, the file would exceed {MAX_INFLATED_BYTES} bytes (MAX_INFLATED_BYTES of omnikin convert)"
            ));
        }
        let plain = match decompress(records, size) {
            Ok(p) => p,
            Err(e) => {
                damage = Some(format!("the chunk record at byte {at}: {e}"));
                break;
            }
        };
        let body_len = (CHUNK_FIXED + 12 + plain.len()) as u64;
        o.push(op::CHUNK);
        o.extend_from_slice(&body_len.to_le_bytes());
        o.extend_from_slice(&body[..CHUNK_FIXED]);
        o.extend_from_slice(&0u32.to_le_bytes());
        o.extend_from_slice(&size.to_le_bytes());
        o.extend_from_slice(&plain);
        at = end;
    }
    if damage.is_none() && out.is_some() && !footer {
        // A file cut at a record boundary (or inside a record's opcode and length).
        damage = Some(format!(
            "byte {at}: the file ends before its footer record and closing magic"
        ));
    }
    let bytes = match out {
        Some(mut o) => {
            if damage.is_none() {
                o.extend_from_slice(&buf[at..]);
            }
            Cow::Owned(o)
        }
        None if damage.is_some() => Cow::Borrowed(&buf[..at]),
        None => Cow::Borrowed(buf),
    };
    Ok(Inflated { bytes, damage })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file from the `mcap` crate's writer: `n` JSON messages on `/pose`, `compression`.
    fn written(n: u64, compression: Option<mcap::Compression>) -> Vec<u8> {
        crate::mcap_log::scan::tests::written_with(n, 4096, compression)
    }

    /// The messages `(log time, data)` of a plain file, through the pre-scan's walk.
    fn messages(buf: &[u8]) -> Vec<(u64, Vec<u8>)> {
        let s = super::super::scan::scan(buf).unwrap();
        assert_eq!(s.damage, None);
        let mut out = Vec::new();
        super::super::scan::messages(buf, s.end, usize::MAX, |_, o| {
            out.push((
                super::super::scan::log_time(buf, o),
                super::super::scan::data(buf, o).to_vec(),
            ))
        });
        out
    }

    #[test]
    fn a_zstd_file_inflates_to_the_messages_of_the_plain_one() {
        let plain = written(500, None);
        let packed = written(500, Some(mcap::Compression::Zstd));
        assert!(packed.len() < plain.len(), "zstd makes it smaller");
        // The pre-scan alone refuses compressed chunks: inflating is what lets it in.
        assert!(super::super::scan::scan(&packed).unwrap().damage.is_some());
        let i = inflate(&packed).unwrap();
        assert_eq!(i.damage, None);
        assert!(matches!(i.bytes, Cow::Owned(_)));
        assert_eq!(messages(&i.bytes), messages(&plain));
        assert_eq!(messages(&plain).len(), 500);
        // The crate reads the copy too, every chunk CRC checked.
        let n = mcap::MessageStream::new_with_options(
            &i.bytes,
            mcap::read::Options::ValidateChunkCrcs.into(),
        )
        .unwrap()
        .inspect(|m| assert!(m.is_ok(), "{m:?}"))
        .count();
        assert_eq!(n, 500);
        // A plain file is not copied.
        assert!(matches!(inflate(&plain).unwrap().bytes, Cow::Borrowed(_)));
    }

    /// The byte offset of the first chunk's uncompressed-size field in `buf`.
    fn first_chunk_size_field(buf: &[u8]) -> usize {
        let mut at = mcap::MAGIC.len();
        while buf[at] != op::CHUNK {
            let len = u64::from_le_bytes(buf[at + 1..at + 9].try_into().unwrap());
            at += RECORD_HEAD + len as usize;
        }
        at + RECORD_HEAD + 16
    }

    #[test]
    fn a_chunk_that_lies_about_its_size_is_damage_at_its_offset() {
        let packed = written(500, Some(mcap::Compression::Zstd));
        let f = first_chunk_size_field(&packed);
        let size = u64::from_le_bytes(packed[f..f + 8].try_into().unwrap());
        for lie in [size - 1, size + 1, 1] {
            let mut bad = packed.clone();
            bad[f..f + 8].copy_from_slice(&lie.to_le_bytes());
            let i = inflate(&bad).unwrap();
            let d = i.damage.expect("a lie is damage");
            let chunk_at = f - 16 - RECORD_HEAD;
            assert!(
                d.contains(&format!("chunk record at byte {chunk_at}")) && d.contains("declares"),
                "{d}"
            );
            // Nothing of the broken chunk is kept.
            assert_eq!(i.bytes.len(), chunk_at);
        }
    }

    #[test]
    fn a_chunk_declaring_more_than_the_limit_is_refused_before_allocating() {
        let packed = written(50, Some(mcap::Compression::Zstd));
        let f = first_chunk_size_field(&packed);
        for huge in [MAX_CHUNK_BYTES + 1, u64::MAX] {
            let mut bad = packed.clone();
            bad[f..f + 8].copy_from_slice(&huge.to_le_bytes());
            let e = inflate(&bad).unwrap_err();
            assert!(e.contains("MAX_CHUNK_BYTES"), "{e}");
        }
    }

    #[test]
    fn a_zstd_bomb_stops_at_its_declared_size() {
        // 64 MiB of zeros compress to a few KiB; the chunk declares 1 KiB.
        let bomb = zstd::bulk::compress(&vec![0u8; 64 << 20], 19).unwrap();
        assert!(bomb.len() < 8 << 10, "{} bytes", bomb.len());
        let mut body = Vec::new();
        body.extend_from_slice(&[0; 16]);
        body.extend_from_slice(&1024u64.to_le_bytes());
        body.extend_from_slice(&[0; 4]);
        body.extend_from_slice(&4u32.to_le_bytes());
        body.extend_from_slice(b"zstd");
        body.extend_from_slice(&(bomb.len() as u64).to_le_bytes());
        body.extend_from_slice(&bomb);
        let mut file = mcap::MAGIC.to_vec();
        file.push(op::CHUNK);
        file.extend_from_slice(&(body.len() as u64).to_le_bytes());
        file.extend_from_slice(&body);
        let i = inflate(&file).unwrap();
        let d = i.damage.expect("a bomb is damage");
        assert!(d.contains("1024 bytes it declares"), "{d}");
        assert_eq!(&i.bytes[..], mcap::MAGIC);
    }

    #[test]
    fn lz4_is_named_and_framing_damage_is_left_to_the_scan() {
        let packed = written(50, Some(mcap::Compression::Zstd));
        let f = first_chunk_size_field(&packed);
        // The compression string follows the size (8) and the CRC (4): "zstd" -> "lz4!".
        let mut bad = packed.clone();
        bad[f + 16..f + 20].copy_from_slice(b"lz4!");
        let d = inflate(&bad).unwrap().damage.unwrap();
        assert!(
            d.contains("\"lz4!\"") && d.contains("zstd and uncompressed"),
            "{d}"
        );
        // Every cut: never a panic; once a chunk was decompressed, the damage is named at a
        // byte of the cut file, not of the larger copy.
        for cut in 0..packed.len() {
            let i = inflate(&packed[..cut]).unwrap();
            assert!(i.bytes.len() as u64 <= MAX_INFLATED_BYTES);
            if let (Cow::Owned(_), Some(d)) = (&i.bytes, &i.damage) {
                let at: usize = d
                    .split("byte ")
                    .nth(1)
                    .and_then(|r| r.split(|c: char| !c.is_ascii_digit()).next())
                    .and_then(|n| n.parse().ok())
                    .unwrap_or_else(|| panic!("cut {cut}: {d}"));
                assert!(at <= cut, "cut {cut}: {d}");
            }
        }
        // Cut before its footer record (29 bytes) and closing magic (8): damage, though every
        // record left is whole.
        let d = inflate(&packed[..packed.len() - 37])
            .unwrap()
            .damage
            .unwrap();
        assert!(d.contains("ends before its footer"), "{d}");
    }
}
