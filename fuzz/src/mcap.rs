//! The MCAP harnesses: `omnikin convert`'s reading path, compiled here from its sources (so the
//! bounds can be lowered for the fuzzer, see [`convert`]): the bounded decompression of zstd chunks
//! (`crates/omnikin-io/src/mcap_log/inflate.rs`), the pre-scan behind it (`scan.rs`), the
//! `mcap` crate behind both, and the protobuf messages' decoding (`proto.rs`, with the JSON
//! forms of `foxglove.rs`).
//!
//! Properties of [`mcap_files`], for any bytes: decompression never panics and allocates at
//! most its stated bound (per chunk [`inflate::MAX_CHUNK_BYTES`], per file
//! [`inflate::MAX_INFLATED_BYTES`], lowered here by [`MAX_INPUT_BYTES`] so a fuzzer
//! process stays small); a file without compressed chunks passes through unchanged; on what it
//! gives, the scan never panics and allocates at most [`text_budget`]; what the scan passes on
//! (`buf[..end]`) the crate's `MessageStream` reads without a panic and within the same budget;
//! the scan's message walk finds every message the crate returns, on the same channels, in the
//! same order.
//!
//! Properties of [`mcap_messages`], for any bytes: the first byte picks one of the log's topics,
//! the rest is decoded as that topic's protobuf message without a panic and within
//! [`text_budget`]; what decodes, re-encoded by the writer's encoder, decodes again (the
//! writer's own output is always readable).

#[path = "../../crates/omnikin-io/src/mcap_log/scan.rs"]
#[allow(dead_code)]
pub mod scan;

#[path = "../../crates/omnikin-io/src/mcap_log/inflate.rs"]
#[allow(dead_code)]
pub mod inflate;

#[path = "../../crates/omnikin-io/src/mcap_log/foxglove.rs"]
#[allow(dead_code)]
pub mod foxglove;

#[path = "../../crates/omnikin-io/src/mcap_log/proto.rs"]
#[allow(dead_code)]
pub mod proto;

/// Stands in for `mcap_log::MAX_INPUT_BYTES`, the input bound [`inflate`] takes as the largest
/// decompressed copy: the CLI allows 1 GiB; the fuzzer 32 MiB, so that a run stays within
/// libFuzzer's 2 GB memory limit (the bound's logic is the same; only its value is lower).
pub const MAX_INPUT_BYTES: u64 = 32 << 20;

/// Stands in for `mcap_log::CHUNK_SIZE` (named in [`inflate`]'s docs only).
pub const CHUNK_SIZE: u64 = 64 << 10;

use crate::alloc::{measure, text_budget};

/// The most [`inflate::inflate`] may allocate: its copy (a `Vec` grown by doubling: at most
/// twice [`inflate::MAX_INFLATED_BYTES`]), one chunk's output and zstd's decoder state.
pub const INFLATE_BUDGET: usize =
    2 * MAX_INPUT_BYTES as usize + inflate::MAX_CHUNK_BYTES as usize + (1 << 20);

/// Fuzzes decompression, the scan and the crate behind it (see the module docs).
pub fn mcap_files(data: &[u8]) {
    let (inflated, usage) = measure(|| inflate::inflate(data));
    assert!(
        usage.peak <= INFLATE_BUDGET,
        "inflate took {} bytes",
        usage.peak
    );
    let Ok(inflated) = inflated else { return };
    if !has_compressed_chunk(data) {
        assert!(
            inflated.bytes.as_ref() == data && inflated.damage.is_none(),
            "a file without compressed chunks was changed"
        );
    }
    scanned_as_the_crate_reads(&inflated.bytes);
}

/// Whether `data` holds a well-formed chunk record whose compression is not empty, found by a
/// walk over the top-level records independent of [`inflate`]'s.
fn has_compressed_chunk(data: &[u8]) -> bool {
    let mut at = MAGIC.len();
    while let Some(head) = data.get(at..at + 9) {
        let len = u64::from_le_bytes(head[1..9].try_into().expect("8 bytes"));
        let Some(end) = usize::try_from(len)
            .ok()
            .and_then(|l| (at + 9).checked_add(l))
            .filter(|&e| e <= data.len())
        else {
            return false;
        };
        if head[0] == 0x06 {
            let n = data
                .get(at + 9 + 28..at + 9 + 32)
                .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")));
            if n.is_some_and(|n| n > 0) {
                return true;
            }
        }
        at = end;
    }
    false
}

/// The scan's properties on an uncompressed file `data` (see the module docs).
fn scanned_as_the_crate_reads(data: &[u8]) {
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

/// Fuzzes the protobuf messages' decoding (see the module docs).
pub fn mcap_messages(data: &[u8]) {
    let Some((&pick, message)) = data.split_first() else {
        return;
    };
    let topic = foxglove::TOPICS[usize::from(pick) % foxglove::TOPICS.len()];
    let (decoded, usage) = measure(|| proto::to_json(topic, message));
    let budget = text_budget(message.len());
    assert!(usage.peak <= budget, "decoding took {} bytes", usage.peak);
    let Ok(v) = decoded else { return };
    if let Ok(again) = proto::encode(topic, &v) {
        let read = proto::to_json(topic, &again);
        assert!(
            read.is_ok(),
            "the writer's own {} does not read: {read:?}",
            topic.name
        );
    }
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
    chunk_of(compression, records.len() as u64, records)
}

/// A chunk body declaring `size` uncompressed bytes.
fn chunk_of(compression: &[u8], size: u64, records: &[u8]) -> Vec<u8> {
    [
        vec![0; 16],
        size.to_le_bytes().to_vec(),
        vec![0; 4],
        string(compression),
        (records.len() as u64).to_le_bytes().to_vec(),
        records.to_vec(),
    ]
    .concat()
}

/// A valid file: a schema, a `/pose` channel and two messages in a chunk (uncompressed, or
/// zstd-compressed when `zstd`), the summary's schema and channel, footer and magic.
fn valid(zstd: bool) -> Vec<u8> {
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
    let body = if zstd {
        let packed = zstd::bulk::compress(&inner, 3).expect("zstd compresses");
        chunk_of(b"zstd", inner.len() as u64, &packed)
    } else {
        chunk(b"", &inner)
    };
    file(&[
        record(0x01, &[string(b""), string(b"omnikin")].concat()),
        record(0x06, &body),
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
    let v = valid(false);
    let bomb = {
        // 4 KiB of zeros declared as 16 MiB: decompresses short of its declared size.
        let packed = zstd::bulk::compress(&[0; 4096], 19).expect("zstd compresses");
        file(&[
            header.clone(),
            record(0x06, &chunk_of(b"zstd", 16 << 20, &packed)),
            end.clone(),
        ])
    };
    vec![
        ("valid", v.clone()),
        ("zstd-valid", valid(true)),
        ("zstd-short", bomb),
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

/// Seeds of [`mcap_messages`]: each topic's message as the writer encodes it (the topic's
/// index in [`foxglove::TOPICS`], then the protobuf bytes), and an empty message per topic.
pub fn message_seeds() -> Vec<(String, Vec<u8>)> {
    use omnikin::Pose2;
    let ns = 2_050_000_000;
    let p = Pose2::new(1.25, -0.5, 0.75);
    let rates = foxglove::WheelRates {
        commanded: Some(vec![1.0, -2.5, 3.25]),
        commanded_steer: None,
        measured: Some(vec![0.99, -2.49, 3.26]),
        measured_steer: None,
    };
    let mut out = Vec::new();
    for (i, topic) in foxglove::TOPICS.iter().enumerate() {
        let json = match topic.schema.name {
            "foxglove.PoseInFrame" => foxglove::pose_in_frame(ns, p),
            "foxglove.PosesInFrame" => foxglove::poses_in_frame(ns, &[p, p]),
            "foxglove.FrameTransform" => foxglove::frame_transform(ns, p),
            "foxglove.Log" => foxglove::log(ns, foxglove::Level::Error, "runtime", "e-stop"),
            "omnikin.WheelRates" => foxglove::wheel_rates(ns, &rates),
            "omnikin.LinkCounters" => foxglove::link_counters(ns, &foxglove::Counters::default()),
            other => panic!("no seed for schema {other}"),
        };
        let bytes = proto::encode(*topic, &json).expect("the writer encodes its own message");
        let name = topic.name.trim_start_matches('/');
        out.push((format!("{name}-valid"), [vec![i as u8], bytes].concat()));
        out.push((format!("{name}-empty"), vec![i as u8]));
    }
    out
}
