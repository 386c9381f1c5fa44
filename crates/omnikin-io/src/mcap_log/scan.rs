//! A bounded pre-scan of an MCAP file: every record's framing and every length and count in
//! it checked against the bytes that hold it, before the `mcap` crate reads a byte.
//!
//! The crate trusts the lengths it reads: a record length near 2⁶⁴ overflows its `9 + len`
//! (a panic in `linear_reader.rs`), an attachment shorter than its fixed fields is sliced out
//! of range, and a string or map length of 0xFFFFFFF0 in a 94-byte file asks for a 4 GB
//! allocation. [`scan`] walks the file as the MCAP specification lays it out
//! (<https://mcap.dev/spec>: magic, then records of `opcode u8, length u64, body`, chunks
//! holding records of their own) and checks, for every record:
//!
//! - its length fits in the bytes left in the file (or in its chunk);
//! - every string, byte array and map inside it fits in the record's body, strings are UTF-8,
//!   maps hold whole entries and at most [`MAX_MAP_ENTRIES`] of them;
//! - a chunk is uncompressed (`omnikin convert` first replaces zstd chunks by their
//!   uncompressed records, with bounded memory: [`super::inflate`]), its records field fills the rest of its body and equals its
//!   uncompressed size, and it holds only schema, channel and message records;
//! - at most [`MAX_CHANNELS`] distinct channel ids and [`MAX_SCHEMAS`] distinct schema ids,
//!   with at most [`MAX_SCHEMA_BYTES`] of schema data in all (the crate keeps a copy of each);
//! - after the footer comes the closing magic and nothing else.
//!
//! A file over a limit is refused. Otherwise the first record that breaks a rule ends the
//! scan: [`Scan::end`] is where that record starts, so the bytes before it (whole, checked
//! records) can be read as a truncated file, and [`Scan::damage`] names the record, its byte
//! offset and the rule. So the crate only ever sees records whose lengths hold, and the memory
//! it can take is bounded by the file's size.

use mcap::records::op;

/// Most distinct channel ids in one MCAP file that `omnikin convert` reads (and so the most
/// CSV files it writes from one): 4 096, room for `simulate --mcap-trials 1000` (four
/// channels per trial, and `/plan`).
pub const MAX_CHANNELS: usize = 4096;
/// Most distinct schema ids in one MCAP file.
pub const MAX_SCHEMAS: usize = 4096;
/// Most schema data in one file, bytes (all schema records together): 16 MiB.
pub const MAX_SCHEMA_BYTES: u64 = 16 << 20;
/// Most entries in one map of a record (channel and metadata maps, index maps).
pub const MAX_MAP_ENTRIES: usize = 4096;

/// What every message of a broken limit contains (the limit's name follows it): such a file
/// is refused as a whole rather than read up to the record.
const LIMIT_TAG: &str = "(MAX_";

/// Size of a record's opcode and length.
const RECORD_HEAD: usize = 9;

/// What [`scan`] found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Scan {
    /// The bytes `buf[..end]` are the magic and whole records that passed every check (the
    /// whole file when [`damage`](Self::damage) is `None`).
    pub end: usize,
    /// The first broken rule, naming the record, its byte offset and the rule; `None` for a
    /// whole, well-formed file.
    pub damage: Option<String>,
    /// Distinct channel ids seen before [`end`](Self::end).
    pub channels: usize,
}

/// The name of a record opcode in messages.
pub fn name(opcode: u8) -> String {
    let n = match opcode {
        op::HEADER => "header",
        op::FOOTER => "footer",
        op::SCHEMA => "schema",
        op::CHANNEL => "channel",
        op::MESSAGE => "message",
        op::CHUNK => "chunk",
        op::MESSAGE_INDEX => "message index",
        op::CHUNK_INDEX => "chunk index",
        op::ATTACHMENT => "attachment",
        op::ATTACHMENT_INDEX => "attachment index",
        op::STATISTICS => "statistics",
        op::METADATA => "metadata",
        op::METADATA_INDEX => "metadata index",
        op::SUMMARY_OFFSET => "summary offset",
        op::DATA_END => "data end",
        _ => "unknown",
    };
    format!("{n} record (opcode 0x{opcode:02x})")
}

/// A cursor over one record's body: each read checks that its bytes are there.
struct Body<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Body<'a> {
    fn take(&mut self, n: u64, what: &str) -> Result<&'a [u8], String> {
        let left = (self.b.len() - self.at) as u64;
        if n > left {
            return Err(format!(
                "{what} needs {n} bytes at body offset {}, but only {left} are left in the record",
                self.at
            ));
        }
        let s = &self.b[self.at..self.at + n as usize];
        self.at += n as usize;
        Ok(s)
    }
    fn fixed(&mut self, n: u64, what: &str) -> Result<(), String> {
        self.take(n, what).map(|_| ())
    }
    fn u16(&mut self, what: &str) -> Result<u16, String> {
        let s = self.take(2, what)?;
        Ok(u16::from_le_bytes([s[0], s[1]]))
    }
    fn u32(&mut self, what: &str) -> Result<u32, String> {
        let s = self.take(4, what)?;
        Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }
    fn u64(&mut self, what: &str) -> Result<u64, String> {
        let s = self.take(8, what)?;
        let mut a = [0; 8];
        a.copy_from_slice(s);
        Ok(u64::from_le_bytes(a))
    }
    fn string(&mut self, what: &str) -> Result<&'a str, String> {
        let n = self.u32(&format!("the length of {what}"))?;
        let s = self.take(u64::from(n), &format!("{what} (length {n})"))?;
        std::str::from_utf8(s).map_err(|_| format!("{what} is not UTF-8"))
    }
    /// A `u32`-length-prefixed byte array.
    fn bytes32(&mut self, what: &str) -> Result<&'a [u8], String> {
        let n = self.u32(&format!("the length of {what}"))?;
        self.take(u64::from(n), &format!("{what} (length {n})"))
    }
    /// A `u64`-length-prefixed byte array.
    fn bytes64(&mut self, what: &str) -> Result<&'a [u8], String> {
        let n = self.u64(&format!("the length of {what}"))?;
        self.take(n, &format!("{what} (length {n})"))
    }
    /// A map (`u32` byte length, then entries read by `entry`), whole entries only.
    fn map(
        &mut self,
        what: &str,
        entry: impl Fn(&mut Body<'a>) -> Result<(), String>,
    ) -> Result<(), String> {
        let bytes = self.bytes32(what)?;
        let mut m = Body { b: bytes, at: 0 };
        let mut n = 0usize;
        while m.at < bytes.len() {
            n += 1;
            if n > MAX_MAP_ENTRIES {
                return Err(format!(
                    "{what} has more than {MAX_MAP_ENTRIES} entries (MAX_MAP_ENTRIES)"
                ));
            }
            entry(&mut m).map_err(|e| format!("{what}, entry {n}: {e}"))?;
        }
        Ok(())
    }
}

/// The string-to-string map entry.
fn string_pair(m: &mut Body) -> Result<(), String> {
    m.string("the key")?;
    m.string("the value").map(|_| ())
}

/// The `u16`-to-`u64` map entry (index maps).
fn id_offset(m: &mut Body) -> Result<(), String> {
    m.fixed(10, "a (u16, u64) entry")
}

/// The running counts of a scan.
struct Counts {
    channels: Box<[u64; 1024]>,
    schemas: Box<[u64; 1024]>,
    n_channels: usize,
    n_schemas: usize,
    schema_bytes: u64,
}

impl Counts {
    /// Marks `id` in `set`; `true` when it is new.
    fn mark(set: &mut [u64; 1024], id: u16) -> bool {
        let (w, b) = (usize::from(id / 64), id % 64);
        let new = set[w] & (1 << b) == 0;
        set[w] |= 1 << b;
        new
    }
}

/// Checks one record's body (`in_chunk`: a record inside a chunk).
fn record(opcode: u8, b: &[u8], in_chunk: bool, c: &mut Counts) -> Result<(), String> {
    let mut r = Body { b, at: 0 };
    if in_chunk && !matches!(opcode, op::SCHEMA | op::CHANNEL | op::MESSAGE) {
        return Err("a chunk may hold only schema, channel and message records".into());
    }
    match opcode {
        op::HEADER => {
            r.string("the profile")?;
            r.string("the library")?;
        }
        op::FOOTER => r.fixed(20, "the footer's offsets and CRC")?,
        op::SCHEMA => {
            let id = r.u16("the schema id")?;
            r.string("the schema name")?;
            r.string("the schema encoding")?;
            let data = r.bytes32("the schema data")?;
            if id != 0 && Counts::mark(&mut c.schemas, id) {
                c.n_schemas += 1;
                c.schema_bytes += data.len() as u64;
                if c.n_schemas > MAX_SCHEMAS {
                    return Err(format!(
                        "more than {MAX_SCHEMAS} schemas in one file (MAX_SCHEMAS)"
                    ));
                }
                if c.schema_bytes > MAX_SCHEMA_BYTES {
                    return Err(format!(
                        "more than {MAX_SCHEMA_BYTES} bytes of schema data in one file (MAX_SCHEMA_BYTES)"
                    ));
                }
            }
        }
        op::CHANNEL => {
            let id = r.u16("the channel id")?;
            r.u16("the schema id")?;
            r.string("the topic")?;
            r.string("the message encoding")?;
            r.map("the channel metadata", string_pair)?;
            if Counts::mark(&mut c.channels, id) {
                c.n_channels += 1;
                if c.n_channels > MAX_CHANNELS {
                    return Err(format!(
                        "more than {MAX_CHANNELS} channels in one file (MAX_CHANNELS of omnikin convert)"
                    ));
                }
            }
        }
        op::MESSAGE => r.fixed(22, "the message header")?,
        op::CHUNK => {
            r.fixed(28, "the chunk's times, size and CRC")?;
            let uncompressed = u64::from_le_bytes(b[16..24].try_into().unwrap_or([0; 8]));
            let compression = r.string("the compression")?;
            if !compression.is_empty() {
                return Err(format!(
                    "compression {compression:?}: the pre-scan reads only uncompressed chunks (zstd chunks are decompressed before it)"
                ));
            }
            let records = r.bytes64("the chunk's records")?;
            if records.len() as u64 != uncompressed {
                return Err(format!(
                    "an uncompressed chunk's records are {} bytes, but its uncompressed size says {uncompressed}",
                    records.len()
                ));
            }
            if r.at != b.len() {
                return Err(format!(
                    "{} bytes after the chunk's records",
                    b.len() - r.at
                ));
            }
            let mut at = 0;
            while at < records.len() {
                let left = records.len() - at;
                if left < RECORD_HEAD {
                    return Err(format!(
                        "the chunk ends {left} bytes into a record's opcode and length (chunk offset {at})"
                    ));
                }
                let inner = records[at];
                let mut len = [0; 8];
                len.copy_from_slice(&records[at + 1..at + RECORD_HEAD]);
                let len = u64::from_le_bytes(len);
                if len > (left - RECORD_HEAD) as u64 {
                    return Err(format!(
                        "the {} at chunk offset {at} has length {len}, more than the {} bytes left in the chunk",
                        name(inner),
                        left - RECORD_HEAD
                    ));
                }
                let body = &records[at + RECORD_HEAD..at + RECORD_HEAD + len as usize];
                record(inner, body, true, c)
                    .map_err(|e| format!("the {} at chunk offset {at}: {e}", name(inner)))?;
                at += RECORD_HEAD + len as usize;
            }
        }
        op::MESSAGE_INDEX => {
            r.fixed(2, "the channel id")?;
            let n = r.bytes32("the index entries")?;
            if !n.len().is_multiple_of(16) {
                return Err(format!(
                    "the index entries are {} bytes, not a whole number of 16-byte entries",
                    n.len()
                ));
            }
        }
        op::CHUNK_INDEX => {
            r.fixed(32, "the chunk's times, offset and length")?;
            r.map("the message index offsets", id_offset)?;
            r.fixed(8, "the message index length")?;
            r.string("the compression")?;
            r.fixed(16, "the compressed and uncompressed sizes")?;
        }
        op::ATTACHMENT => {
            r.fixed(16, "the attachment's times")?;
            r.string("the attachment name")?;
            r.string("the media type")?;
            r.bytes64("the attachment data")?;
            r.fixed(4, "the attachment CRC")?;
        }
        op::ATTACHMENT_INDEX => {
            r.fixed(40, "the attachment's offset, length, times and size")?;
            r.string("the attachment name")?;
            r.string("the media type")?;
        }
        op::STATISTICS => {
            // message count u64, schema count u16, four u32 counts, start and end times u64.
            r.fixed(8 + 2 + 4 * 4 + 8 + 8, "the counts and times")?;
            r.map("the channel message counts", id_offset)?;
        }
        op::METADATA => {
            r.string("the metadata name")?;
            r.map("the metadata", string_pair)?;
        }
        op::METADATA_INDEX => {
            r.fixed(16, "the metadata's offset and length")?;
            r.string("the metadata name")?;
        }
        op::SUMMARY_OFFSET => r.fixed(17, "the group opcode, start and length")?,
        op::DATA_END => r.fixed(4, "the data section CRC")?,
        _ => {}
    }
    Ok(())
}

/// Scans the MCAP file `buf` (see the module docs). An error when `buf` does not start with
/// the MCAP magic or breaks one of the limits ([`MAX_CHANNELS`], [`MAX_SCHEMAS`],
/// [`MAX_SCHEMA_BYTES`], [`MAX_MAP_ENTRIES`]); damage is [`Scan::damage`].
pub fn scan(buf: &[u8]) -> Result<Scan, String> {
    let magic = mcap::MAGIC;
    if buf.len() < magic.len() || buf[..magic.len()] != *magic {
        return Err("not an MCAP file (it does not start with the MCAP magic)".into());
    }
    let mut c = Counts {
        channels: Box::new([0; 1024]),
        schemas: Box::new([0; 1024]),
        n_channels: 0,
        n_schemas: 0,
        schema_bytes: 0,
    };
    let mut at = magic.len();
    let mut damage = None;
    let mut footer = false;
    let mut closed = false;
    while at < buf.len() {
        let left = buf.len() - at;
        if footer {
            if buf[at..] == *magic {
                at = buf.len();
                closed = true;
            } else {
                damage = Some(format!(
                    "byte {at}: after the footer record comes the closing magic and the end of the file, not these {left} bytes"
                ));
            }
            break;
        }
        if left < RECORD_HEAD {
            damage = Some(format!(
                "byte {at}: the file ends {left} bytes into a record's opcode and length"
            ));
            break;
        }
        let opcode = buf[at];
        let mut len = [0; 8];
        len.copy_from_slice(&buf[at + 1..at + RECORD_HEAD]);
        let len = u64::from_le_bytes(len);
        if len > (left - RECORD_HEAD) as u64 {
            damage = Some(format!(
                "the {} at byte {at}: its length {len} runs past the end of the file ({} bytes left)",
                name(opcode),
                left - RECORD_HEAD
            ));
            break;
        }
        let body = &buf[at + RECORD_HEAD..at + RECORD_HEAD + len as usize];
        if let Err(e) = record(opcode, body, false, &mut c) {
            let e = format!("the {} at byte {at}: {e}", name(opcode));
            // A limit is not damage: the file is refused, not read up to it.
            if e.contains(LIMIT_TAG) {
                return Err(e);
            }
            damage = Some(e);
            break;
        }
        footer = opcode == op::FOOTER;
        at += RECORD_HEAD + len as usize;
    }
    if damage.is_none() && !closed {
        // Whole records up to here, then the end of the file: a truncated file.
        damage = Some(if footer {
            format!("byte {at}: the file ends after its footer record, without the closing magic")
        } else {
            format!("byte {at}: the file ends before its footer record and closing magic")
        });
    }
    Ok(Scan {
        end: at,
        damage,
        channels: c.n_channels,
    })
}

/// The records of `buf[from..to]`: `(opcode, body start, body end)`, ending early at a record
/// it cannot frame (never indexing out of range).
fn records(buf: &[u8], from: usize, to: usize) -> impl Iterator<Item = (u8, usize, usize)> + '_ {
    let to = to.min(buf.len());
    let mut at = from;
    std::iter::from_fn(move || {
        let head = buf.get(at..at.checked_add(RECORD_HEAD)?.min(to))?;
        if head.len() < RECORD_HEAD {
            return None;
        }
        let mut len = [0; 8];
        len.copy_from_slice(&head[1..]);
        let body = at + RECORD_HEAD;
        let end = usize::try_from(u64::from_le_bytes(len))
            .ok()
            .and_then(|l| body.checked_add(l))
            .filter(|&e| e <= to)?;
        at = end;
        Some((head[0], body, end))
    })
}

/// Calls `each(channel id, offset)` for the first `limit` message records of `buf[..end]` in
/// file order (also inside chunks), `offset` being where the record's body starts in `buf`
/// (channel id u16, sequence u32, log time u64, publish time u64, then the data). `end` comes
/// from [`scan`] of the same `buf`, whose checks the walk relies on.
pub fn messages(buf: &[u8], end: usize, limit: usize, mut each: impl FnMut(u16, usize)) {
    let mut n = 0;
    let mut message = |body: usize, body_end: usize| {
        if n < limit && body_end - body >= 22 {
            each(u16::from_le_bytes([buf[body], buf[body + 1]]), body);
            n += 1;
        }
    };
    for (opcode, body, body_end) in records(buf, mcap::MAGIC.len(), end) {
        match opcode {
            op::MESSAGE => message(body, body_end),
            op::CHUNK => {
                // Times, size and CRC (28 bytes), the empty compression string (4: the scan
                // allows no other), the records' u64 length (8), then the records.
                for (inner, b, e) in records(buf, body + 40, body_end) {
                    if inner == op::MESSAGE {
                        message(b, e);
                    }
                }
            }
            _ => {}
        }
    }
}

/// The log time of the message record whose body starts at `offset` (see [`messages`]).
pub fn log_time(buf: &[u8], offset: usize) -> u64 {
    let mut t = [0; 8];
    if let Some(b) = buf.get(offset + 6..offset + 14) {
        t.copy_from_slice(b);
    }
    u64::from_le_bytes(t)
}

/// The data of the message record whose body starts at `offset` (see [`messages`]).
pub fn data(buf: &[u8], offset: usize) -> &[u8] {
    let mut len = [0; 8];
    if let Some(b) = offset.checked_sub(8).and_then(|s| buf.get(s..offset)) {
        len.copy_from_slice(b);
    }
    let len = usize::try_from(u64::from_le_bytes(len)).unwrap_or(0);
    buf.get(offset + 22..offset + len).unwrap_or(&[])
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A file from the `mcap` crate's writer: `n` JSON messages on `/pose`, chunks of `chunk`
    /// bytes, uncompressed.
    fn written(n: u64, chunk: u64) -> Vec<u8> {
        written_with(n, chunk, None)
    }

    /// [`written`] with chunks compressed by `compression` (also the inflate tests' file).
    pub(in crate::mcap_log) fn written_with(
        n: u64,
        chunk: u64,
        compression: Option<mcap::Compression>,
    ) -> Vec<u8> {
        let mut buf = Vec::new();
        let mut w = mcap::WriteOptions::new()
            .compression(compression)
            .chunk_size(Some(chunk))
            .create(std::io::Cursor::new(&mut buf))
            .unwrap();
        let s = w.add_schema("s", "jsonschema", b"{}").unwrap();
        let c = w
            .add_channel(s, "/pose", "json", &Default::default())
            .unwrap();
        for i in 0..n {
            let h = mcap::records::MessageHeader {
                channel_id: c,
                sequence: i as u32,
                log_time: 1000 + i,
                publish_time: 0,
            };
            w.write_to_known_channel(&h, format!("{{\"i\":{i}}}").as_bytes())
                .unwrap();
        }
        w.finish().unwrap();
        drop(w);
        buf
    }

    #[test]
    fn a_whole_file_scans_whole_and_its_messages_are_found_in_place() {
        let buf = written(50, 200);
        let s = scan(&buf).unwrap();
        assert_eq!((s.end, s.damage.clone(), s.channels), (buf.len(), None, 1));
        let mut found = Vec::new();
        messages(&buf, s.end, usize::MAX, |id, o| {
            found.push((id, log_time(&buf, o), data(&buf, o).to_vec()))
        });
        assert_eq!(found.len(), 50);
        for (i, (id, t, d)) in found.iter().enumerate() {
            assert_eq!((*id, *t), (1, 1000 + i as u64));
            assert_eq!(d, format!("{{\"i\":{i}}}").as_bytes());
        }
        let mut limited = 0;
        messages(&buf, s.end, 7, |_, _| limited += 1);
        assert_eq!(limited, 7);
    }

    #[test]
    fn every_cut_ends_at_a_record_and_says_where() {
        let buf = written(20, 150);
        let whole = {
            let mut n = 0;
            messages(&buf, buf.len(), usize::MAX, |_, _| n += 1);
            n
        };
        let mut before = 0;
        for cut in mcap::MAGIC.len()..buf.len() {
            let s = scan(&buf[..cut]).unwrap();
            assert!(s.end <= cut);
            let d = s.damage.expect("a cut file is damaged");
            assert!(d.contains("byte "), "{d}");
            let mut n = 0;
            messages(&buf[..cut], s.end, usize::MAX, |_, _| n += 1);
            // Whole chunks only, so the count never falls as the cut moves on.
            assert!(n >= before && n <= whole, "cut {cut}: {n} messages");
            before = n;
        }
        assert!(scan(b"not mcap").is_err());
    }
}
