//! The MCAP harness: `omnikin convert`'s pre-scan (`crates/omnikin-cli/src/mcap_log/scan.rs`,
//! compiled here from its source: the CLI is a binary crate) and the `mcap` crate behind it.
//!
//! Properties, for any bytes: the scan never panics and allocates at most
//! [`text_budget`](crate::alloc::text_budget); what it passes on (`buf[..end]`) the crate's
//! `MessageStream` reads without a panic and within the same budget; the scan's message walk
//! finds every message the crate returns, on the same channels, in the same order.

#[path = "../../crates/omnikin-cli/src/mcap_log/scan.rs"]
#[allow(dead_code)]
pub mod scan;

use crate::alloc::{measure, text_budget};

/// Fuzzes the scan and the crate behind it (see the module docs).
pub fn mcap_files(data: &[u8]) {
    let budget = text_budget(data.len());
    let (scanned, usage) = measure(|| scan::scan(data));
    assert!(usage.peak <= budget, "the scan took {} bytes", usage.peak);
    let Ok(s) = scanned else { return };
    assert!(s.end <= data.len());
    assert!(s.damage.is_some() || s.end == data.len());
    let (channels, usage) = measure(|| {
        let mut ids = Vec::new();
        if let Ok(stream) = mcap::MessageStream::new(&data[..s.end]) {
            for m in stream {
                match m {
                    Ok(m) => ids.push(m.channel.id),
                    Err(_) => break,
                }
            }
        }
        ids
    });
    assert!(usage.peak <= budget, "the crate took {} bytes", usage.peak);
    let mut walked = Vec::new();
    scan::messages(data, s.end, channels.len(), |id, _| walked.push(id));
    assert_eq!(walked, channels, "the scan's walk and the crate disagree");
}

// ---------------------------------------------------------------------------------------------
// Seeds: MCAP bytes as the specification lays them out (https://mcap.dev/spec).

const MAGIC: &[u8] = b"\x89MCAP0\r\n";

fn record_len(op: u8, body: &[u8], len: u64) -> Vec<u8> {
    let mut r = vec![op];
    r.extend_from_slice(&len.to_le_bytes());
    r.extend_from_slice(body);
    r
}

fn record(op: u8, body: &[u8]) -> Vec<u8> {
    record_len(op, body, body.len() as u64)
}

fn string(s: &[u8]) -> Vec<u8> {
    let mut v = (s.len() as u32).to_le_bytes().to_vec();
    v.extend_from_slice(s);
    v
}

fn file(records: &[Vec<u8>]) -> Vec<u8> {
    [MAGIC.to_vec(), records.concat()].concat()
}

fn chunk(compression: &[u8], records: &[u8]) -> Vec<u8> {
    [
        vec![0; 16],
        (records.len() as u64).to_le_bytes().to_vec(),
        vec![0; 4],
        string(compression),
        (records.len() as u64).to_le_bytes().to_vec(),
        records.to_vec(),
    ]
    .concat()
}

/// A valid file: a schema, a `/pose` channel and two messages in a chunk, the summary's
/// schema and channel, footer and magic.
fn valid() -> Vec<u8> {
    let schema = record(
        0x03,
        &[
            1u16.to_le_bytes().to_vec(),
            string(b"foxglove.PoseInFrame"),
            string(b"jsonschema"),
            string(b"{}"),
        ]
        .concat(),
    );
    let channel = record(
        0x04,
        &[
            1u16.to_le_bytes().to_vec(),
            1u16.to_le_bytes().to_vec(),
            string(b"/pose"),
            string(b"json"),
            0u32.to_le_bytes().to_vec(),
        ]
        .concat(),
    );
    let message = |t: u64| {
        record(
            0x05,
            &[
                1u16.to_le_bytes().to_vec(),
                0u32.to_le_bytes().to_vec(),
                t.to_le_bytes().to_vec(),
                t.to_le_bytes().to_vec(),
                br#"{"pose":{"position":{"x":1,"y":2}}}"#.to_vec(),
            ]
            .concat(),
        )
    };
    let inner = [schema.clone(), channel.clone(), message(0), message(1)].concat();
    file(&[
        record(0x01, &[string(b""), string(b"omnikin")].concat()),
        record(0x06, &chunk(b"", &inner)),
        record(0x0F, &[0; 4]),
        schema,
        channel,
        record(0x02, &[0; 20]),
        MAGIC.to_vec(),
    ])
}

/// The seeds: a valid file, and the crafted files of issue 31 (tests/file_inputs.rs).
pub fn seeds() -> Vec<(&'static str, Vec<u8>)> {
    let header = record(0x01, &[string(b""), string(b"")].concat());
    let end = [record(0x02, &[0; 20]), MAGIC.to_vec()].concat();
    let mut wrap = file(&[header.clone(), record_len(0x04, &[], u64::MAX - 7)]);
    wrap.resize(77, 0);
    let mut schema = 1u16.to_le_bytes().to_vec();
    schema.extend_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
    schema.resize(46, b'x');
    let mut schema94 = file(&[header.clone(), record(0x03, &schema)]);
    schema94.resize(94, 0);
    let attachment = [vec![0; 16], string(b"a"), string(b"b"), vec![0; 8]].concat();
    let entries: Vec<u8> = (0..5000).flat_map(|_| [0u8; 8]).collect();
    let metadata = [
        string(b"m"),
        (entries.len() as u32).to_le_bytes().to_vec(),
        entries,
    ]
    .concat();
    let v = valid();
    vec![
        ("valid", v.clone()),
        ("truncated", v[..v.len() / 2].to_vec()),
        ("wrap77", wrap),
        ("schema94", schema94),
        (
            "attachment",
            file(&[header.clone(), record(0x09, &attachment), end.clone()]),
        ),
        (
            "chunk-inner",
            file(&[
                header.clone(),
                record(0x06, &chunk(b"", &record_len(0x05, &[0; 22], 1 << 40))),
                end.clone(),
            ]),
        ),
        (
            "zstd",
            file(&[
                header.clone(),
                record(0x06, &chunk(b"zstd", &[0; 16])),
                end.clone(),
            ]),
        ),
        (
            "metadata-map",
            file(&[header, record(0x0C, &metadata), end]),
        ),
    ]
}
