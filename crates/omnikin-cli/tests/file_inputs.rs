//! Every file input bounded as documented (issue 31, observation 3): crafted MCAP files that
//! panicked inside the `mcap` crate or asked it for gigabytes, MCAP files with too many or
//! hostile channels, a CSV log whose every cell was kept as a `String`, and a signal during
//! `convert`. Each run of the built binary is under an address-space limit (`prlimit --as`,
//! 3 GiB as in the issue, less where the test is about memory) and a wall-clock deadline (a
//! safety net against a hang, not a timing assertion); it must end with exit status 0 or an
//! `error:` line, never `panicked at` or a signal death, and leave its input unchanged.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::io::Write;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_omnikin");

/// The issue's address-space limit.
const GIB3: u64 = 3 << 30;
/// Deadline of one run (a hang is killed and fails the test; no run comes near it).
const WALL: Duration = Duration::from_secs(120);

fn tmp(name: &str) -> TestDir {
    TestDir::new("files", name)
}

fn has_prlimit() -> bool {
    Command::new("prlimit")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// `omnikin ARGS` in `dir` under `prlimit --as=LIMIT` (when prlimit exists).
fn spawn(dir: &Path, args: &[&str], limit: u64, stdin: Stdio) -> Child {
    let mut c = if has_prlimit() {
        let mut c = Command::new("prlimit");
        c.arg(format!("--as={limit}")).arg(BIN);
        c
    } else {
        eprintln!("note: prlimit (util-linux) not found: runs without the memory limit");
        Command::new(BIN)
    };
    c.args(args)
        .current_dir(dir)
        .env("RUST_BACKTRACE", "0")
        .stdin(stdin)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Waits for `child` (killed after [`WALL`]): exit code (`None`: died of a signal), stderr.
fn wait(mut child: Child) -> (Option<i32>, String) {
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > WALL {
            let _ = child.kill();
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Runs `omnikin ARGS` in `dir`; checks: no panic, no signal death, an exit 0 or an `error:`
/// line, and the file `input` unchanged. Returns (exit code, stderr).
fn run(dir: &Path, args: &[&str], limit: u64, input: &Path) -> (i32, String) {
    let before = std::fs::read(input).unwrap();
    let (code, err) = wait(spawn(dir, args, limit, Stdio::null()));
    assert!(!err.contains("panicked"), "{args:?}: a panic:\n{err}");
    let Some(code) = code else {
        panic!("{args:?}: died of a signal (an abort: out of memory?):\n{err}");
    };
    assert!(
        code == 0 || err.contains("error:"),
        "{args:?}: exit {code} without an error line:\n{err}"
    );
    assert_eq!(
        std::fs::read(input).unwrap(),
        before,
        "{args:?}: the input changed"
    );
    (code, err)
}

// ---------------------------------------------------------------------------------------------
// MCAP bytes, as the specification lays them out (https://mcap.dev/spec).

const MAGIC: &[u8] = b"\x89MCAP0\r\n";

fn record(op: u8, body: &[u8]) -> Vec<u8> {
    record_len(op, body, body.len() as u64)
}

fn record_len(op: u8, body: &[u8], len: u64) -> Vec<u8> {
    let mut r = vec![op];
    r.extend_from_slice(&len.to_le_bytes());
    r.extend_from_slice(body);
    r
}

fn string(s: &[u8]) -> Vec<u8> {
    let mut v = (s.len() as u32).to_le_bytes().to_vec();
    v.extend_from_slice(s);
    v
}

fn header() -> Vec<u8> {
    record(0x01, &[string(b""), string(b"")].concat())
}

fn file(records: &[Vec<u8>]) -> Vec<u8> {
    [MAGIC.to_vec(), records.concat()].concat()
}

fn footer_and_magic() -> Vec<u8> {
    [record(0x02, &[0; 20]), MAGIC.to_vec()].concat()
}

/// The crafted files: (name, bytes, what the error must say).
fn crafted() -> Vec<(&'static str, Vec<u8>, &'static str)> {
    let mut out = Vec::new();
    // The issue's 77-byte file: a record length near 2^64 (the crate's `9 + len` overflowed).
    let mut f = file(&[header(), record_len(0x04, &[], u64::MAX - 7)]);
    f.resize(77, 0);
    out.push(("wrap77.mcap", f, "channel record (opcode 0x04) at byte 25"));
    // The issue's 94-byte file: a schema name of length 0xFFFFFFF0 (a 4 GB allocation).
    let mut body = 1u16.to_le_bytes().to_vec();
    body.extend_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
    body.resize(46, b'x');
    let f = file(&[header(), record(0x03, &body)]);
    assert_eq!(f.len(), 80);
    let mut f94 = f;
    f94.resize(94, 0);
    out.push(("schema94.mcap", f94, "the schema name (length 4294967280)"));
    // An attachment without room for its CRC (the crate sliced `body.len() - 4` past its
    // fields).
    let body = [
        vec![0; 16],
        string(b"a"),
        string(b"b"),
        0u64.to_le_bytes().to_vec(),
    ]
    .concat();
    let f = file(&[header(), record(0x09, &body), footer_and_magic()]);
    out.push(("attachment.mcap", f, "the attachment CRC"));
    // A chunk whose inner record claims more bytes than the chunk has.
    let inner = record_len(0x05, &[0; 22], 1 << 40);
    let chunk = |compression: &[u8], records: &[u8]| {
        [
            vec![0; 16],
            (records.len() as u64).to_le_bytes().to_vec(),
            vec![0; 4],
            string(compression),
            (records.len() as u64).to_le_bytes().to_vec(),
            records.to_vec(),
        ]
        .concat()
    };
    let f = file(&[
        header(),
        record(0x06, &chunk(b"", &inner)),
        footer_and_magic(),
    ]);
    out.push(("chunk-inner.mcap", f, "at chunk offset 0"));
    // A zstd chunk whose records are not zstd data.
    let f = file(&[
        header(),
        record(0x06, &chunk(b"zstd", &[0; 16])),
        footer_and_magic(),
    ]);
    out.push(("zstd.mcap", f, "its zstd data does not decompress"));
    // zstd chunks that lie about their uncompressed size (the size a decompressor would
    // allocate): more than MAX_CHUNK_BYTES is refused before anything is allocated; a small
    // lie is damage at the chunk (byte 25, after the magic and the header record).
    let zchunk = |declared: u64, plain: &[u8]| {
        let z = zstd::bulk::compress(plain, 3).unwrap();
        let mut c = chunk(b"zstd", &z);
        c[16..24].copy_from_slice(&declared.to_le_bytes());
        c
    };
    let plain = [record(0x05, &[0; 22]), record(0x05, &[0; 22])].concat();
    for (name, declared, says) in [
        ("zstd-huge.mcap", u64::MAX, "MAX_CHUNK_BYTES"),
        ("zstd-2tb.mcap", 1 << 41, "MAX_CHUNK_BYTES"),
        (
            "zstd-short.mcap",
            10,
            "does not decompress into the 10 bytes it declares",
        ),
        (
            "zstd-long.mcap",
            100,
            "decompresses to 62 bytes, but it declares 100",
        ),
    ] {
        let f = file(&[
            header(),
            record(0x06, &zchunk(declared, &plain)),
            footer_and_magic(),
        ]);
        out.push((name, f, says));
    }
    assert_eq!(plain.len(), 62, "the size zstd-long.mcap's error names");
    // A zstd bomb: 64 MiB of zeros in a few KiB, declared as 16 MiB (the largest chunk
    // allowed): the decompressor stops at the declared size.
    let f = file(&[
        header(),
        record(0x06, &zchunk(16 << 20, &vec![0; 64 << 20])),
        footer_and_magic(),
    ]);
    assert!(f.len() < 64 << 10, "{} bytes", f.len());
    out.push((
        "zstd-bomb.mcap",
        f,
        "does not decompress into the 16777216 bytes it declares",
    ));
    // A metadata record with more map entries than MAX_MAP_ENTRIES (each one a BTreeMap entry
    // of two Strings: ten times its bytes in memory).
    let entries: Vec<u8> = (0..5000)
        .flat_map(|_| [string(b""), string(b"")].concat())
        .collect();
    let body = [
        string(b"m"),
        (entries.len() as u32).to_le_bytes().to_vec(),
        entries,
    ]
    .concat();
    let f = file(&[header(), record(0x0C, &body), footer_and_magic()]);
    out.push(("metadata-map.mcap", f, "MAX_MAP_ENTRIES"));
    // A map whose byte length ends inside an entry.
    let body = [
        1u16.to_le_bytes().to_vec(),
        0u16.to_le_bytes().to_vec(),
        string(b"/pose"),
        string(b"json"),
        5u32.to_le_bytes().to_vec(),
        string(b"k"),
    ]
    .concat();
    let f = file(&[header(), record(0x04, &body), footer_and_magic()]);
    out.push(("channel-map.mcap", f, "the channel metadata, entry 1"));
    // Bytes after the footer other than the closing magic.
    let f = file(&[header(), record(0x02, &[0; 20]), b"garbage!".to_vec()]);
    out.push(("after-footer.mcap", f, "after the footer record"));
    // Junk right after the magic.
    out.push((
        "junk.mcap",
        file(&[vec![0xFF; 40]]),
        "unknown record (opcode 0xff) at byte 8",
    ));
    out
}

#[test]
fn crafted_mcap_files_are_clear_errors_within_3_gib() {
    let dir = tmp("crafted");
    for (name, bytes, says) in crafted() {
        std::fs::write(dir.join(name), &bytes).unwrap();
        let out = format!("{name}-csv");
        let (code, err) = run(
            &dir,
            &["convert", name, "--csv", &out],
            GIB3,
            &dir.join(name),
        );
        assert_ne!(code, 0, "{name}: accepted:\n{err}");
        assert!(
            err.contains(says),
            "{name}: the error does not say {says:?}:\n{err}"
        );
        assert!(
            err.contains(name),
            "{name}: the error does not name the file:\n{err}"
        );
        assert!(
            !dir.join(&out).exists(),
            "{name}: an output directory was created"
        );
    }
}

/// A valid MCAP file with one `/pose`-schema JSON message on each of `topics`.
fn mcap_with(topics: &[String]) -> Vec<u8> {
    let mut buf = Vec::new();
    {
        let mut w = mcap::WriteOptions::new()
            .compression(None)
            .create(std::io::Cursor::new(&mut buf))
            .unwrap();
        let schema = w
            .add_schema("foxglove.PoseInFrame", "jsonschema", b"{}")
            .unwrap();
        let msg = br#"{"timestamp":{"sec":0,"nsec":0},"frame_id":"world","pose":{"position":{"x":1,"y":2,"z":0},"orientation":{"x":0,"y":0,"z":0,"w":1}}}"#;
        for (i, t) in topics.iter().enumerate() {
            let id = w
                .add_channel(schema, t, "json", &Default::default())
                .unwrap();
            let h = mcap::records::MessageHeader {
                channel_id: id,
                sequence: i as u32,
                log_time: i as u64,
                publish_time: i as u64,
            };
            w.write_to_known_channel(&h, msg).unwrap();
        }
        w.finish().unwrap();
    }
    buf
}

#[test]
fn channels_are_limited_and_their_names_never_reach_a_file_name_unchecked() {
    let dir = tmp("channels");
    // 4 097 channels: one more than MAX_CHANNELS (the issue's file had 65 535).
    let many: Vec<String> = (0..4097).map(|i| format!("/trial-{i}/pose")).collect();
    std::fs::write(dir.join("many.mcap"), mcap_with(&many)).unwrap();
    let (code, err) = run(
        &dir,
        &["convert", "many.mcap", "--csv", "many"],
        GIB3,
        &dir.join("many.mcap"),
    );
    assert_ne!(code, 0);
    assert!(err.contains("MAX_CHANNELS"), "{err}");
    assert!(!dir.join("many").exists(), "files were written");

    // Hostile names beside two good ones: control characters, a newline, path separators,
    // `..`, a non-digit trial number.
    let topics: Vec<String> = [
        "/pose",
        "/trial-007/pose",
        "/trial-\n1/pose",
        "/trial-1\u{7}/pose",
        "/trial-1/../pose",
        "/trial-../pose",
        "/trial-a/pose",
        "/pose\n",
        "/trial-/pose",
        "/trial-1234567890/pose",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    std::fs::write(dir.join("names.mcap"), mcap_with(&topics)).unwrap();
    let (code, err) = run(
        &dir,
        &["convert", "names.mcap", "--csv", "names"],
        GIB3,
        &dir.join("names.mcap"),
    );
    assert_eq!(code, 0, "{err}");
    let mut files: Vec<String> = std::fs::read_dir(dir.join("names"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(files, ["pose.csv", "trial-007-pose.csv"], "{err}");
    // Each skipped channel is one warning line, its control characters escaped.
    let skipped: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("not an omnikin channel"))
        .collect();
    assert_eq!(skipped.len(), topics.len() - 2, "{err}");
    assert!(
        !err.contains('\u{7}'),
        "a raw control character reached stderr"
    );
    assert!(err.contains(r"/trial-\n1/pose"), "{err}");
}

#[test]
fn a_csv_log_is_streamed_not_held_cell_by_cell() {
    // 4 000 rows of 1 000 columns (4 MB): kept as one String per cell this took 113 MB and
    // aborted under a 64 MiB address-space limit; streamed, the conversion takes 16 MB.
    let dir = tmp("wide");
    let mut csv = String::from("t,x,y,heading");
    for i in 5..=1000 {
        csv.push_str(&format!(",c{i}"));
    }
    csv.push('\n');
    for i in 0..4000 {
        csv.push_str(&format!("{},0,0,0{}\n", i as f64 * 0.01, ",".repeat(996)));
    }
    std::fs::write(dir.join("wide.csv"), &csv).unwrap();
    let (code, err) = run(
        &dir,
        &["convert", "wide.csv", "--mcap", "wide.mcap"],
        96 << 20,
        &dir.join("wide.csv"),
    );
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("4000 rows"), "{err}");
    // The MCAP has a pose per row.
    let (code, err) = run(
        &dir,
        &["convert", "wide.mcap", "--csv", "back"],
        GIB3,
        &dir.join("wide.mcap"),
    );
    assert_eq!(code, 0, "{err}");
    let pose = std::fs::read_to_string(dir.join("back/pose.csv")).unwrap();
    assert_eq!(pose.lines().count(), 4001);
}

/// The temporary files (`.NAME.PID-N.tmp`) in `dir`.
fn temp_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

#[test]
fn sigterm_and_sigint_during_convert_remove_its_temporary_file() {
    for (sig, status) in [("-TERM", 143), ("-INT", 130)] {
        let dir = tmp(&format!("signal{status}"));
        // The input is a FIFO: convert blocks on it with its output open, deterministically.
        let fifo = dir.join("in.csv");
        assert!(
            Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        let child = spawn(
            &dir,
            &["convert", "in.csv", "--mcap", "out.mcap"],
            GIB3,
            Stdio::null(),
        );
        let mut w = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
        w.write_all(b"t,x,y,heading\n0,0,0,0\n0.01,0.1,0,0\n")
            .unwrap();
        w.flush().unwrap();
        // The temporary output appears once the header is read (deadline, not a timing
        // assertion).
        let start = Instant::now();
        while temp_files(&dir).is_empty() {
            assert!(start.elapsed() < WALL, "no temporary file appeared");
            std::thread::sleep(Duration::from_millis(20));
        }
        // prlimit execs the binary, so the child's pid is the binary's.
        let ok = Command::new("kill")
            .args([sig, &child.id().to_string()])
            .status()
            .unwrap()
            .success();
        assert!(ok);
        // End of input: convert finds the signal before it finishes the file.
        drop(w);
        let (code, err) = wait(child);
        assert_eq!(code, Some(status), "{err}");
        assert!(err.contains("stopped by SIG"), "{err}");
        assert_eq!(
            temp_files(&dir),
            Vec::<String>::new(),
            "temporary file left"
        );
        assert!(!dir.join("out.mcap").exists(), "a partial output was kept");
    }
}

/// A kiwi encoder log of `rows` samples at 100 Hz (`t,q1,q2,q3`: a slow drive with a turn),
/// written row by row.
fn kiwi_log(path: &Path, rows: usize) {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    w.write_all(b"t,q1,q2,q3\n").unwrap();
    for i in 0..rows {
        let t = i as f64 * 0.01;
        // Wheel angles (rad) of a drive forward with a slow turn.
        let q = [-2.0 * t, 2.0 * t + 0.1 * t.sin(), 0.1 * t.sin()];
        writeln!(w, "{t:.2},{:.5},{:.5},{:.5}", q[0], q[1], q[2]).unwrap();
    }
    w.flush().unwrap();
}

/// `odometry` held the whole log and ten columns per row: 174 MB of RSS at 10⁶ rows, some 1.7
/// GB at the documented limit of 10⁷ (MAX_TRACK_ROWS). Streamed, a 10⁶-row log with the figure
/// runs in 16 MiB of address space (measured; 10⁷ rows peak at 11 MB of RSS); the test allows
/// 48 MiB, which the whole-log version exceeded (it aborted even at 64 MiB).
#[test]
fn odometry_streams_a_large_log_in_bounded_memory() {
    let dir = tmp("odometry-large");
    let rows = 1_000_000;
    kiwi_log(&dir.join("log.csv"), rows);
    let (code, err) = run(
        &dir,
        &[
            "odometry",
            "log.csv",
            "--robot",
            "kiwi",
            "--out",
            "poses.csv",
            "--plot",
            "o.svg",
        ],
        48 << 20,
        &dir.join("log.csv"),
    );
    assert_eq!(code, 0, "{err}");
    assert!(err.contains(&format!("{rows} samples")), "{err}");
    let poses = std::fs::read_to_string(dir.join("poses.csv")).unwrap();
    assert_eq!(poses.lines().count(), rows + 1);
    assert!(poses.starts_with("t,x,y,heading\n0,"), "{}", &poses[..40]);
    assert!(std::fs::metadata(dir.join("o.svg")).unwrap().len() > 0);
}

#[test]
fn sigterm_and_sigint_during_odometry_remove_its_temporary_files() {
    for (sig, status) in [("-TERM", 143), ("-INT", 130)] {
        let dir = tmp(&format!("odometry-signal{status}"));
        // The log is a FIFO: odometry blocks on it with its outputs open, deterministically.
        let fifo = dir.join("log.csv");
        assert!(
            Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        let child = spawn(
            &dir,
            &[
                "odometry", "log.csv", "--robot", "kiwi", "--out", "o.csv", "--mcap", "o.mcap",
            ],
            GIB3,
            Stdio::null(),
        );
        let mut w = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
        w.write_all(b"t,q1,q2,q3\n0,0,0,0\n0.01,0.001,0.001,0.001\n")
            .unwrap();
        w.flush().unwrap();
        // Both temporary outputs appear once the header is read (deadline, not a timing
        // assertion).
        let start = Instant::now();
        while temp_files(&dir).len() < 2 {
            assert!(start.elapsed() < WALL, "no temporary files appeared");
            std::thread::sleep(Duration::from_millis(20));
        }
        let ok = Command::new("kill")
            .args([sig, &child.id().to_string()])
            .status()
            .unwrap()
            .success();
        assert!(ok);
        // End of input: odometry finds the signal before it finishes the files.
        drop(w);
        let (code, err) = wait(child);
        assert_eq!(code, Some(status), "{err}");
        assert!(err.contains("stopped by SIG"), "{err}");
        assert_eq!(
            temp_files(&dir),
            Vec::<String>::new(),
            "temporary file left"
        );
        assert!(!dir.join("o.csv").exists(), "a partial output was kept");
        assert!(!dir.join("o.mcap").exists(), "a partial output was kept");
    }
}

/// `--plot` counts the log's rows in a first pass to thin the figure as the rows come; a
/// pipe cannot be read twice, so its figure lines are kept and thinned when drawn.
#[test]
fn odometry_of_a_fifo_log_with_a_figure_reads_it_once() {
    let dir = tmp("odometry-fifo-plot");
    let fifo = dir.join("log.csv");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let child = spawn(
        &dir,
        &[
            "odometry", "log.csv", "--robot", "kiwi", "--out", "o.csv", "--plot", "o.svg",
        ],
        GIB3,
        Stdio::null(),
    );
    // More rows than a figure line draws (MAX_FIGURE_POINTS = 10 000).
    let rows = 20_000;
    let mut w =
        std::io::BufWriter::new(std::fs::OpenOptions::new().write(true).open(&fifo).unwrap());
    w.write_all(b"t,q1,q2,q3\n").unwrap();
    for i in 0..rows {
        let t = i as f64 * 0.01;
        writeln!(w, "{t:.2},{:.5},{:.5},0", -2.0 * t, 2.0 * t).unwrap();
    }
    drop(w);
    let (code, err) = wait(child);
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains(&format!("{rows} samples")), "{err}");
    let poses = std::fs::read_to_string(dir.join("o.csv")).unwrap();
    assert_eq!(poses.lines().count(), rows + 1);
    assert!(std::fs::metadata(dir.join("o.svg")).unwrap().len() > 0);
}
