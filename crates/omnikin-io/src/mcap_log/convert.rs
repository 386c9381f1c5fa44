//! `omnikin convert`: MCAP logs to CSV (one file per channel) and CSV logs back to MCAP.
//!
//! MCAP → CSV (`convert run.mcap --csv DIR`): each channel of [`super::foxglove::TOPICS`] (also
//! under a `/trial-NNN` prefix) becomes `DIR/NAME.csv` (`/pose` → `pose.csv`,
//! `/trial-002/pose` → `trial-002-pose.csv`) with the columns of the CSV logs:
//! poses `t,x,y,heading` (the pose CSV of conventions.md; heading unwrapped along the channel),
//! `/tf` `t,x,y,heading,parent_frame_id,child_frame_id`, `/plan` `t,i,x,y,heading` (one row per
//! pose of each plan message), `/wheels` `t,w1..wN,sd1..sdN` (commanded, as in the robot log)
//! then `mw1..mwN,msd1..msdN` (measured), `/link` `t,rx_ok,…,rx_entropy,rx_dropped,rejected`
//! (as in the telemetry log), `/events` `t,level,name,message`. A cell the message does not
//! have is empty. A truncated file (a killed process) is converted up to its last complete
//! chunk, with a warning. zstd chunks (what omnikin writes) are decompressed first, each
//! bounded by its declared size ([`super::inflate`]). Messages may be protobuf (what omnikin
//! writes) or JSON (what it wrote before), per channel ([`super::proto::Encoding`]); a message
//! that does not decode is named by its channel, log time and offset.
//!
//! CSV → MCAP (`convert IN --mcap out.mcap`): IN is a directory of such files (the round trip),
//! or one CSV log: `robot --log`, `drive … --out`, `simulate`'s `trials.csv` or a pose CSV
//! `t,x,y,heading` (`odometry --out`); its columns say what it has.

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::io::Read;
use std::path::Path;

use anyhow::{Context, Result, bail};
use omnikin::Pose2;
use omnikin::runtime::{Faults, Mode};
use serde_json::Value;

use super::foxglove::{self as fg, Counters, Topic};
use super::proto::Encoding;
use super::{LogRow, McapLog};

pub use super::MAX_INPUT_BYTES;

fn read_limited(path: &Path) -> Result<Vec<u8>> {
    let shown = path.display();
    let f = std::fs::File::open(path).with_context(|| format!("{shown}: cannot open"))?;
    let mut buf = Vec::new();
    f.take(MAX_INPUT_BYTES + 1)
        .read_to_end(&mut buf)
        .with_context(|| format!("{shown}: cannot read"))?;
    if buf.len() as u64 > MAX_INPUT_BYTES {
        bail!("{shown}: larger than {MAX_INPUT_BYTES} bytes (MAX_INPUT_BYTES of omnikin convert)");
    }
    Ok(buf)
}

/// One message of an MCAP file: its log time and its bytes, borrowed from the file.
#[derive(Clone, Copy, Debug)]
pub struct Decoded<'a> {
    /// Log time, ns.
    pub log_time: u64,
    /// The message bytes.
    pub data: &'a [u8],
    /// Where its record body starts in the (inflated) file.
    pub offset: u32,
}

impl<'a> Decoded<'a> {
    /// The message whose record body starts at `offset` of `buf` (an offset of
    /// [`Channels::ours`]).
    pub fn at(buf: &'a [u8], offset: u32) -> Self {
        let o = offset as usize;
        Self {
            log_time: super::scan::log_time(buf, o),
            data: super::scan::data(buf, o),
            offset,
        }
    }
}

// Message offsets are kept as u32: the input is at most MAX_INPUT_BYTES.
const _: () = assert!(MAX_INPUT_BYTES < u32::MAX as u64);

/// The channels of an MCAP file as [`read_mcap`] returns them.
#[derive(Default)]
pub struct Channels {
    /// omnikin's channels, sorted by topic (also under `/trial-NNN`): topic, its [`Topic`],
    /// its messages' encoding, the offsets of its messages' records in the file, in file order
    /// ([`Decoded::at`]).
    pub ours: Vec<(String, Topic, Encoding, Vec<u32>)>,
    /// Other channels: `topic (schema)` with control characters escaped, and how many messages
    /// they have.
    pub skipped: BTreeMap<String, usize>,
    /// Messages in all.
    pub messages: usize,
}

/// Every message of the MCAP file `buf` (at most [`MAX_INPUT_BYTES`]; named `shown` in
/// errors; uncompressed chunks only, so a file with zstd chunks goes through
/// [`super::inflate::inflate`] first), by channel, and why reading stopped early, if it did (a truncated or damaged file:
/// the messages before the damage are returned).
///
/// Three passes, none of which trusts a length it has not checked: [`super::scan::scan`]
/// checks the file's framing, lengths and counts ([`super::scan::MAX_CHANNELS`] channels at
/// most) and finds where the whole records end; the `mcap` crate reads those records (schemas,
/// channels, CRCs, every message linked to its channel) and says how many messages are good;
/// [`super::scan::messages`] then indexes those messages in place (the crate copies each one,
/// so its output is not kept). The memory is the file and 4 bytes per message.
pub fn read_mcap(buf: &[u8], shown: &str) -> Result<(Channels, Option<String>)> {
    if buf.len() as u64 > MAX_INPUT_BYTES {
        bail!("{shown}: larger than {MAX_INPUT_BYTES} bytes (MAX_INPUT_BYTES of omnikin convert)");
    }
    let scan = super::scan::scan(buf).map_err(|e| anyhow::anyhow!("{shown}: {e}"))?;
    let stream =
        mcap::MessageStream::new(&buf[..scan.end]).with_context(|| format!("{shown}: not MCAP"))?;
    let mut out = Channels::default();
    let mut stopped = None;
    // Channel id -> where its messages go: Ok(index in `ours`) or Err(key in `skipped`).
    let mut by_id: HashMap<u16, std::result::Result<usize, String>> = HashMap::new();
    let mut by_topic: HashMap<String, usize> = HashMap::new();
    for (i, m) in stream.enumerate() {
        if i.is_multiple_of(4096) {
            crate::output::check_interrupted()?;
        }
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                stopped = Some(e.to_string());
                break;
            }
        };
        let slot = by_id.entry(m.channel.id).or_insert_with(|| {
            let c = &m.channel;
            let schema = c.schema.as_ref().map_or("", |s| s.name.as_str());
            let encoding = c
                .schema
                .as_ref()
                .and_then(|s| Encoding::of(&c.message_encoding, &s.encoding));
            match fg::topic(&c.topic)
                .filter(|t| t.schema.name == schema)
                .zip(encoding)
            {
                Some((t, e)) => Ok(*by_topic.entry(c.topic.clone()).or_insert_with(|| {
                    out.ours.push((c.topic.clone(), t, e, Vec::new()));
                    out.ours.len() - 1
                })),
                None => Err(format!("{} ({schema})", c.topic.escape_debug())),
            }
        });
        out.messages += 1;
        if let Err(key) = slot {
            *out.skipped.entry(key.clone()).or_default() += 1;
        }
    }
    super::scan::messages(buf, scan.end, out.messages, |id, offset| {
        if let Some(Ok(k)) = by_id.get(&id) {
            out.ours[*k].3.push(offset as u32);
        }
    });
    out.ours.sort_by(|a, b| a.0.cmp(&b.0));
    // The scan's account of damage names the record and its offset; the crate's only the rule.
    if let Some(d) = scan.damage {
        stopped = Some(d);
    }
    Ok((out, stopped))
}

/// The CSV file name of a topic: `/pose` → `pose.csv`, `/trial-002/pose` → `trial-002-pose.csv`.
fn file_name(topic: &str) -> String {
    format!("{}.csv", topic.trim_start_matches('/').replace('/', "-"))
}

/// The topic of a CSV file name (the inverse of [`file_name`]), if it is one of ours.
fn topic_of(file: &str) -> Option<(String, Topic)> {
    let stem = file.strip_suffix(".csv")?;
    let (prefix, base) = match stem.strip_prefix("trial-") {
        Some(rest) => {
            let (n, base) = rest.split_once('-')?;
            if n.is_empty() || !n.bytes().all(|b| b.is_ascii_digit()) {
                return None;
            }
            (format!("/trial-{n}"), base)
        }
        None => (String::new(), stem),
    };
    let t = fg::topic(&format!("/{base}"))?;
    Some((prefix, t))
}

/// A CSV cell: quoted (RFC 4180) when it holds a comma or a quote; line breaks become spaces.
fn cell(s: &str) -> String {
    let s = s.replace(['\n', '\r'], " ");
    if s.contains([',', '"']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s
    }
}

/// Splits one CSV line into cells (RFC 4180 quotes), or `None` for an unterminated quote.
fn split_csv(line: &str) -> Option<Vec<String>> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                cur.push('"');
            }
            ('"', true) => quoted = false,
            ('"', false) if cur.is_empty() => quoted = true,
            (',', false) => out.push(std::mem::take(&mut cur)),
            (c, _) => cur.push(c),
        }
    }
    if quoted {
        return None;
    }
    out.push(cur);
    Some(out)
}

/// Unwraps a heading in (-π, π] to the one nearest `prev` (continuous along a channel).
fn unwrap(h: f64, prev: Option<f64>) -> f64 {
    match prev {
        Some(p) => {
            let tau = std::f64::consts::TAU;
            h + ((p - h) / tau).round() * tau
        }
        None => h,
    }
}

fn opt(x: Option<f64>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

/// The CSV columns of `/link`: the telemetry log's names for [`Counters::NAMES`] (the
/// receive counters with its `rx_` prefix, `rx_dropped`, `rejected`; from
/// [`crate::telemetry_schema`]).
static LINK_COLUMNS: std::sync::LazyLock<[String; fg::COUNTER_COUNT]> =
    std::sync::LazyLock::new(|| {
        Counters::NAMES.map(|n| match n {
            "rejected" => n.to_string(),
            _ => format!("{}{n}", crate::telemetry_schema::RX_PREFIX),
        })
    });

/// One of the rate arrays of a [`fg::WheelRates`].
type RatesField = fn(&fg::WheelRates) -> &Option<Vec<f64>>;

/// Writes the CSV of one channel's messages to `w`, row by row (see the module docs for the
/// columns); a wheel-rate list longer than [`omnikin::MAX_WHEELS`] is an error.
fn channel_csv(
    topic: Topic,
    encoding: Encoding,
    buf: &[u8],
    offsets: &[u32],
    w: &mut dyn std::io::Write,
) -> Result<()> {
    let msgs = || offsets.iter().map(|&o| Decoded::at(buf, o));
    let t = |m: &Decoded| fg::seconds(m.log_time);
    // A message that does not decode, or decodes to something that is not its schema's.
    let bad = |m: &Decoded| {
        let why = match encoding.decode(topic, m.data) {
            Err(e) => e,
            Ok(_) => format!("not a {} message", topic.schema.name),
        };
        anyhow::anyhow!(
            "{} message at log time {} ns (record at offset {} of the decompressed file): {why}",
            topic.name,
            m.log_time,
            m.offset
        )
    };
    let value = |m: &Decoded| encoding.decode(topic, m.data).unwrap_or(Value::Null);
    // One row at a time: `s` holds it until it is written.
    let mut s = String::new();
    let mut row = |s: &mut String, i: usize| -> Result<()> {
        if i.is_multiple_of(4096) {
            crate::output::check_interrupted()?;
        }
        w.write_all(s.as_bytes())?;
        s.clear();
        Ok(())
    };
    match topic.schema.name {
        "foxglove.PoseInFrame" => {
            s.push_str("t,x,y,heading\n");
            let mut prev = None;
            for (i, m) in msgs().enumerate() {
                let p = fg::decode_pose_in_frame(&value(&m)).ok_or_else(|| bad(&m))?;
                let h = unwrap(p.heading, prev);
                prev = Some(h);
                let _ = writeln!(s, "{},{},{},{h}", t(&m), p.x, p.y);
                row(&mut s, i)?;
            }
        }
        "foxglove.FrameTransform" => {
            s.push_str("t,x,y,heading,parent_frame_id,child_frame_id\n");
            let mut prev = None;
            for (i, m) in msgs().enumerate() {
                let v = value(&m);
                let (p, parent, child) = fg::decode_frame_transform(&v).ok_or_else(|| bad(&m))?;
                let h = unwrap(p.heading, prev);
                prev = Some(h);
                let _ = writeln!(
                    s,
                    "{},{},{},{h},{},{}",
                    t(&m),
                    p.x,
                    p.y,
                    cell(parent),
                    cell(child)
                );
                row(&mut s, i)?;
            }
        }
        "foxglove.PosesInFrame" => {
            s.push_str("t,i,x,y,heading\n");
            for (i, m) in msgs().enumerate() {
                let poses = fg::decode_poses_in_frame(&value(&m)).ok_or_else(|| bad(&m))?;
                let mut prev = None;
                for (k, p) in poses.iter().enumerate() {
                    let h = unwrap(p.heading, prev);
                    prev = Some(h);
                    let _ = writeln!(s, "{},{k},{},{},{h}", t(&m), p.x, p.y);
                    row(&mut s, i)?;
                }
            }
        }
        "foxglove.Log" => {
            s.push_str("t,level,name,message\n");
            for (i, m) in msgs().enumerate() {
                let v = value(&m);
                let (level, name, text) = fg::decode_log(&v).ok_or_else(|| bad(&m))?;
                let _ = writeln!(s, "{},{level},{},{}", t(&m), cell(name), cell(text));
                row(&mut s, i)?;
            }
        }
        "omnikin.WheelRates" => {
            let groups: [(&str, RatesField); 4] = [
                ("w", |r| &r.commanded),
                ("sd", |r| &r.commanded_steer),
                ("mw", |r| &r.measured),
                ("msd", |r| &r.measured_steer),
            ];
            // Two passes: the widest list of each group sets the columns.
            let mut widths = [0usize; 4];
            for m in msgs() {
                let r = fg::decode_wheel_rates(&value(&m)).ok_or_else(|| bad(&m))?;
                for ((p, f), n) in groups.iter().zip(&mut widths) {
                    let k = f(&r).as_ref().map_or(0, Vec::len);
                    if k > omnikin::MAX_WHEELS {
                        bail!(
                            "{} message at log time {} ns: {k} values in {p}, more than the {} wheels a robot may have (MAX_WHEELS)",
                            topic.name,
                            m.log_time,
                            omnikin::MAX_WHEELS
                        );
                    }
                    *n = (*n).max(k);
                }
            }
            s.push('t');
            for ((p, _), n) in groups.iter().zip(&widths) {
                for i in 1..=*n {
                    let _ = write!(s, ",{p}{i}");
                }
            }
            s.push('\n');
            for (i, m) in msgs().enumerate() {
                let r = fg::decode_wheel_rates(&value(&m)).ok_or_else(|| bad(&m))?;
                let _ = write!(s, "{}", t(&m));
                for ((_, f), n) in groups.iter().zip(&widths) {
                    let v = f(&r);
                    for i in 0..*n {
                        let _ = write!(s, ",{}", opt(v.as_ref().and_then(|v| v.get(i).copied())));
                    }
                }
                s.push('\n');
                row(&mut s, i)?;
            }
        }
        "omnikin.LinkCounters" => {
            s.push('t');
            for c in LINK_COLUMNS.iter() {
                let _ = write!(s, ",{c}");
            }
            s.push('\n');
            for (i, m) in msgs().enumerate() {
                let c = fg::decode_link_counters(&value(&m)).ok_or_else(|| bad(&m))?;
                let _ = write!(s, "{}", t(&m));
                for v in c.values() {
                    let _ = write!(s, ",{}", v.map(|v| v.to_string()).unwrap_or_default());
                }
                s.push('\n');
                row(&mut s, i)?;
            }
        }
        other => bail!("no CSV form for schema {other}"),
    }
    // A channel without messages still gets its header.
    w.write_all(s.as_bytes())?;
    Ok(())
}

/// An MCAP file read for conversion: the decompressed bytes, its channels, and the warnings
/// a reader should see (a damaged or truncated file, channels that are not omnikin's).
struct ReadLog {
    shown: String,
    bytes: Vec<u8>,
    channels: Channels,
    warnings: Vec<String>,
}

/// Reads, decompresses and indexes the MCAP file `input` (at most [`MAX_INPUT_BYTES`]).
fn read_log(input: &Path) -> Result<ReadLog> {
    let shown = input.display().to_string();
    let raw = read_limited(input)?;
    let inflated = super::inflate::inflate(&raw).map_err(|e| anyhow::anyhow!("{shown}: {e}"))?;
    let (channels, mut stopped) = read_mcap(&inflated.bytes, &shown)?;
    // A chunk that could not be decompressed ends the copy: that is the first damage.
    if inflated.damage.is_some() {
        stopped.clone_from(&inflated.damage);
    }
    let mut warnings = Vec::new();
    if let Some(why) = &stopped {
        if channels.messages == 0 {
            bail!("{shown}: no message could be read: {why}");
        }
        warnings.push(format!(
            "{shown}: the file ends early or is damaged ({why}); converted the {} messages before that (up to the last complete chunk)",
            channels.messages
        ));
    }
    for (k, n) in &channels.skipped {
        warnings.push(format!(
            "channel {k}: not an omnikin channel, {n} messages skipped"
        ));
    }
    // A file without compressed chunks comes back borrowed, as a prefix of the input: keep
    // the input (cut to it) rather than copy it.
    let bytes = match inflated.bytes {
        std::borrow::Cow::Owned(v) => v,
        std::borrow::Cow::Borrowed(b) => {
            let n = b.len();
            let mut raw = raw;
            raw.truncate(n);
            raw
        }
    };
    Ok(ReadLog {
        shown,
        bytes,
        channels,
        warnings,
    })
}

/// The omnikin channels of an MCAP file as CSV tables, in memory: what [`to_csv`] writes, for
/// a front end that wants the columns (Python's `omnikin.read_mcap`).
pub struct Tables {
    /// Per channel, sorted by topic: the topic (`/pose`, `/trial-002/pose`, …), its message
    /// count and its CSV text (header and rows, the columns of the module docs).
    pub channels: Vec<(String, usize, String)>,
    /// What the reader should be told: a damaged or truncated file (the messages before the
    /// damage are converted), channels that are not omnikin's (skipped).
    pub warnings: Vec<String>,
}

/// Each omnikin channel of the MCAP file `input` as its CSV table (see [`Tables`]). The memory
/// is the file (at most [`MAX_INPUT_BYTES`]) and the tables.
pub fn tables(input: &Path) -> Result<Tables> {
    let log = read_log(input)?;
    let mut channels = Vec::with_capacity(log.channels.ours.len());
    for (topic, t, e, list) in &log.channels.ours {
        let mut text = Vec::new();
        channel_csv(*t, *e, &log.bytes, list, &mut text)
            .with_context(|| format!("{}: channel {topic}", log.shown))?;
        let text = String::from_utf8(text)
            .map_err(|_| anyhow::anyhow!("{}: channel {topic}: not UTF-8", log.shown))?;
        channels.push((topic.clone(), list.len(), text));
    }
    Ok(Tables {
        channels,
        warnings: log.warnings,
    })
}

/// `omnikin convert IN.mcap --csv DIR`: each channel of the MCAP file `input` to
/// `DIR/CHANNEL.csv` (directory created; new or empty unless `--force`).
pub fn to_csv(input: &Path, dir: &Path) -> Result<()> {
    crate::output::catch_signals()?;
    let log = read_log(input)?;
    for w in &log.warnings {
        crate::errln!("warning: {w}");
    }
    let (shown, buf, channels) = (&log.shown, &log.bytes[..], &log.channels);
    let names: Vec<String> = channels
        .ours
        .iter()
        .map(|(t, _, _, _)| file_name(t))
        .collect();
    // Topics are checked (`/trial-` digits, then one of the TOPICS), so names cannot collide;
    // still, no file is written twice.
    let distinct: std::collections::HashSet<&String> = names.iter().collect();
    if distinct.len() != names.len() {
        bail!("{shown}: two channels map to one CSV file name");
    }
    crate::output::create_dir("--csv", dir)?;
    for n in &names {
        crate::output::check_file("--csv", &dir.join(n))?;
    }
    for ((topic, t, e, list), name) in channels.ours.iter().zip(&names) {
        let path = dir.join(name);
        let mut out = crate::output::OutFile::create("--csv", &path)?;
        channel_csv(*t, *e, buf, list, &mut out)
            .with_context(|| format!("{shown} -> {}", path.display()))?;
        crate::output::check_interrupted()?;
        out.commit()?;
        crate::errln!("{topic}: {} messages -> {}", list.len(), path.display());
    }
    Ok(())
}

/// Most data rows of one CSV input of `convert --mcap`: 10⁷, the row limit of the other logs
/// (`MAX_TRACK_ROWS`).
pub const MAX_CSV_ROWS: usize = omnikin_sim::limits::MAX_TRACK_ROWS;

/// A CSV file read as a stream: its header, then one row of text cells at a time
/// ([`next_row`](Self::next_row)), so the memory is one line (at most `MAX_CSV_LINE`), whatever
/// the file's size.
struct Table {
    file: String,
    header: Vec<String>,
    lines: std::io::BufReader<omnikin_plan::limits::LineLimit<Box<dyn std::io::Read + Send>>>,
    /// The line number of the last line read (1-based).
    line: usize,
    rows: usize,
    buf: String,
}

impl Table {
    /// Opens `path` (at most [`MAX_INPUT_BYTES`]) and reads its header row.
    fn open(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        let f = std::fs::File::open(path).with_context(|| format!("{file}: cannot open"))?;
        let size = f
            .metadata()
            .with_context(|| format!("{file}: cannot read"))?
            .len();
        if size > MAX_INPUT_BYTES {
            bail!(
                "{file}: larger than {MAX_INPUT_BYTES} bytes (MAX_INPUT_BYTES of omnikin convert)"
            );
        }
        Self::from_reader(file, Box::new(f))
    }

    /// A table read from `text` (a channel handed over in memory), named `name` in errors.
    fn from_text(name: String, text: Vec<u8>) -> Result<Self> {
        if text.len() as u64 > MAX_INPUT_BYTES {
            bail!(
                "{name}: larger than {MAX_INPUT_BYTES} bytes (MAX_INPUT_BYTES of omnikin convert)"
            );
        }
        Self::from_reader(name, Box::new(std::io::Cursor::new(text)))
    }

    /// Reads the header row from `source`.
    fn from_reader(file: String, source: Box<dyn std::io::Read + Send>) -> Result<Self> {
        let limited =
            omnikin_plan::limits::LineLimit::new(source, omnikin_plan::limits::MAX_CSV_LINE);
        let mut t = Self {
            file,
            header: Vec::new(),
            lines: std::io::BufReader::new(limited),
            line: 0,
            rows: 0,
            buf: String::new(),
        };
        if !t.next_line()? {
            bail!("{}:1: empty file, expected a header row", t.file);
        }
        t.header = t
            .buf
            .trim_start_matches('\u{feff}')
            .split(',')
            .map(|h| h.trim().to_string())
            .collect();
        Ok(t)
    }

    /// Reads the next line that is not blank into `buf` (without its line break); `false` at
    /// the end of the file.
    fn next_line(&mut self) -> Result<bool> {
        use std::io::BufRead;
        loop {
            self.buf.clear();
            self.line += 1;
            let n = self.lines.read_line(&mut self.buf).map_err(|e| {
                if e.kind() == std::io::ErrorKind::InvalidData {
                    anyhow::anyhow!("{}:{}: {e} (or not UTF-8 text)", self.file, self.line)
                } else {
                    anyhow::anyhow!("{}:{}: cannot read: {e}", self.file, self.line)
                }
            })?;
            if n == 0 {
                return Ok(false);
            }
            let l = self.buf.trim_end_matches(['\n', '\r']).len();
            self.buf.truncate(l);
            if !self.buf.trim().is_empty() {
                return Ok(true);
            }
        }
    }

    /// The next row `(line, cells)`, `None` at the end of the file; an error for a row whose
    /// cell count differs from the header's, an unterminated quote, or more than
    /// [`MAX_CSV_ROWS`] rows.
    fn next_row(&mut self) -> Result<Option<(usize, Vec<String>)>> {
        if !self.next_line()? {
            return Ok(None);
        }
        if self.rows.is_multiple_of(4096) {
            crate::output::check_interrupted()?;
        }
        self.rows += 1;
        if self.rows > MAX_CSV_ROWS {
            bail!(
                "{}:{}: more than {MAX_CSV_ROWS} rows (the limit MAX_CSV_ROWS of omnikin convert); split the log",
                self.file,
                self.line
            );
        }
        let cells = split_csv(&self.buf)
            .with_context(|| format!("{}:{}: unterminated quote", self.file, self.line))?;
        if cells.len() != self.header.len() {
            bail!(
                "{}:{}: {} values, but the header has {} columns",
                self.file,
                self.line,
                cells.len(),
                self.header.len()
            );
        }
        Ok(Some((self.line, cells)))
    }

    fn col(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// The columns `p1, p2, …` that exist, in order.
    fn numbered(&self, p: &str) -> Vec<usize> {
        (1..).map_while(|i| self.col(&format!("{p}{i}"))).collect()
    }
}

/// One row of a [`Table`]: typed access to its cells, errors naming `FILE:LINE: column C`.
struct Row<'a> {
    t: &'a Table,
    line: usize,
    cells: &'a [String],
}

impl Row<'_> {
    fn err(&self, col: usize, rule: &str) -> anyhow::Error {
        anyhow::anyhow!(
            "{}:{}: column {}: {:?} {rule}",
            self.t.file,
            self.line,
            self.t.header[col],
            self.cells[col]
        )
    }
    fn num(&self, col: usize) -> Result<f64> {
        self.cells[col]
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.err(col, "is not a finite number"))
    }
    fn opt_num(&self, col: usize) -> Result<Option<f64>> {
        if self.cells[col].trim().is_empty() {
            Ok(None)
        } else {
            self.num(col).map(Some)
        }
    }
    fn count(&self, col: usize) -> Result<Option<u64>> {
        let c = self.cells[col].trim();
        if c.is_empty() {
            return Ok(None);
        }
        c.parse::<u64>()
            .map(Some)
            .map_err(|_| self.err(col, "is not a whole number ≥ 0"))
    }
    fn text(&self, col: usize) -> &str {
        &self.cells[col]
    }
    fn list(&self, cols: &[usize]) -> Result<Option<Vec<f64>>> {
        if cols.is_empty() {
            return Ok(None);
        }
        let v: Vec<Option<f64>> = cols
            .iter()
            .map(|&c| self.opt_num(c))
            .collect::<Result<_>>()?;
        Ok(v.into_iter().collect())
    }
    fn pose(&self, c: [usize; 3]) -> Result<Pose2<f64>> {
        Ok(Pose2::new(
            self.num(c[0])?,
            self.num(c[1])?,
            self.num(c[2])?,
        ))
    }
    fn ns(&self, col: usize) -> Result<u64> {
        let t = self.num(col)?;
        fg::time_ns(t).ok_or_else(|| self.err(col, "is not a time ≥ 0 s"))
    }
}

fn mode_of(name: &str) -> Option<Mode> {
    [
        Mode::Idle,
        Mode::Velocity,
        Mode::Trajectory,
        Mode::Stopping,
        Mode::EStop,
    ]
    .into_iter()
    .find(|m| m.name() == name.trim())
}

fn faults_of(s: &str) -> Option<Faults> {
    let s = s.trim();
    let mut f = Faults::NONE;
    if s == "none" || s.is_empty() {
        return Some(f);
    }
    for part in s.split('|') {
        let (flag, _) = Faults::ALL.iter().find(|(_, n)| *n == part)?;
        f.insert(*flag);
    }
    Some(f)
}

fn require(t: &Table, cols: &[&str], what: &str) -> Result<Vec<usize>> {
    cols.iter()
        .map(|c| {
            t.col(c).with_context(|| {
                format!(
                    "{}:1: no column {c}: {what} needs {} (header: {})",
                    t.file,
                    cols.join(","),
                    t.header.join(",")
                )
            })
        })
        .collect()
}

/// One CSV log (robot, drive telemetry, trials.csv, a pose CSV) as samples on `log`.
fn log_to_mcap(t: &mut Table, log: &mut McapLog) -> Result<usize> {
    let base = require(t, &["t", "x", "y", "heading"], "a CSV log")?;
    let tri = |a: &str, b: &str, c: &str| -> Option<[usize; 3]> {
        Some([t.col(a)?, t.col(b)?, t.col(c)?])
    };
    let truth_cols = tri("true_x", "true_y", "true_heading");
    let ref_cols = tri("ref_x", "ref_y", "ref_heading");
    let tracked = t.col("tracked_x").zip(t.col("tracked_y"));
    let trial = t.col("trial");
    let (w, sd, q, s) = (
        t.numbered("w"),
        t.numbered("sd"),
        t.numbered("q"),
        t.numbered("s"),
    );
    let mode = t.col("mode").zip(t.col("faults"));
    let link: Vec<Option<usize>> = LINK_COLUMNS.iter().map(|c| t.col(c)).collect();
    let has_link = t.col("rx_ok").is_some();
    while let Some((line, cells)) = t.next_row()? {
        let r = Row {
            t: &*t,
            line,
            cells: &cells,
        };
        let time = r.num(base[0])?;
        r.ns(base[0])?;
        let est = r.pose([base[1], base[2], base[3]])?;
        let (pose, truth) = match (tracked, truth_cols) {
            // trials.csv: x, y, heading are the plant's; the tracker saw tracked_x, tracked_y.
            (Some((tx, ty)), _) => (Pose2::new(r.num(tx)?, r.num(ty)?, est.heading), Some(est)),
            (None, Some(c)) => (est, Some(r.pose(c)?)),
            (None, None) => (est, None),
        };
        let state = match mode {
            Some((m, f)) => Some((
                mode_of(r.text(m)).ok_or_else(|| {
                    r.err(
                        m,
                        "is not a mode (idle, velocity, trajectory, stopping, estop)",
                    )
                })?,
                faults_of(r.text(f))
                    .ok_or_else(|| r.err(f, "is not a fault set (none, or names joined by |)"))?,
            )),
            None => None,
        };
        let reference = match (ref_cols, state) {
            (Some(c), Some((Mode::Trajectory, _))) => Some(r.pose(c)?),
            _ => None,
        };
        let link = if has_link {
            let mut v = [None; fg::COUNTER_COUNT];
            for (o, c) in v.iter_mut().zip(&link) {
                if let Some(c) = c {
                    *o = r.count(*c)?;
                }
            }
            Some(Counters::from_values(v))
        } else {
            None
        };
        let prefix = match trial {
            Some(c) => match r.count(c)? {
                Some(0) | None => String::new(),
                Some(k) => format!("/trial-{k:03}"),
            },
            None => String::new(),
        };
        log.sample_under(
            &prefix,
            &LogRow {
                t: time,
                pose,
                truth,
                reference,
                commanded: r.list(&w)?,
                commanded_steer: r.list(&sd)?,
                wheel_angles: r.list(&q)?,
                steer_angles: r.list(&s)?,
                link,
                state,
            },
        )?;
    }
    Ok(t.rows)
}

/// Most poses in one `/plan` message read back from a `plan.csv`: the plan sample limit
/// (`MAX_PLAN_SAMPLES`, 2·10⁶).
pub const MAX_PLAN_POSES: usize = omnikin_plan::limits::MAX_PLAN_SAMPLES;

/// One `convert --csv` file read back as messages, one at a time
/// ([`next_message`](Self::next_message)).
struct ChannelSource {
    t: Table,
    topic: Topic,
    /// The columns the topic needs (see [`ChannelSource::open`]).
    cols: Vec<usize>,
    /// Wheel-rate groups `w`, `sd`, `mw`, `msd`, or the link counters' columns.
    groups: Vec<Vec<usize>>,
    link: Vec<Option<usize>>,
    /// `/plan`: the first pose of the next plan message, read ahead.
    ahead: Option<(u64, Pose2<f64>)>,
}

impl ChannelSource {
    /// Opens the channel file `path` of `prefix` + `topic` and checks its header.
    fn open(path: &Path, prefix: &str, topic: Topic) -> Result<Self> {
        Self::new(Table::open(path)?, prefix, topic)
    }

    /// The channel `prefix` + `topic` read from the table `t`; checks its header.
    fn new(t: Table, prefix: &str, topic: Topic) -> Result<Self> {
        let name = format!("{prefix}{}", topic.name);
        let what = format!("the {name} CSV");
        let need: &[&str] = match topic.schema.name {
            "foxglove.PoseInFrame" | "foxglove.FrameTransform" => &["t", "x", "y", "heading"],
            "foxglove.PosesInFrame" => &["t", "i", "x", "y", "heading"],
            "foxglove.Log" => &["t", "level", "name", "message"],
            "omnikin.WheelRates" | "omnikin.LinkCounters" => &["t"],
            other => bail!("no CSV form for schema {other}"),
        };
        let cols = require(&t, need, &what)?;
        let groups = ["w", "sd", "mw", "msd"].map(|p| t.numbered(p)).to_vec();
        let link = LINK_COLUMNS.iter().map(|c| t.col(c)).collect();
        Ok(Self {
            t,
            topic,
            cols,
            groups,
            link,
            ahead: None,
        })
    }

    /// The next message `(log time, value)`, `None` at the end of the file.
    fn next_message(&mut self) -> Result<Option<(u64, Value)>> {
        if self.topic.schema.name == "foxglove.PosesInFrame" {
            return self.next_plan();
        }
        let Some((line, cells)) = self.t.next_row()? else {
            return Ok(None);
        };
        let r = Row {
            t: &self.t,
            line,
            cells: &cells,
        };
        let c = &self.cols;
        let ns = r.ns(c[0])?;
        let v = match self.topic.schema.name {
            "foxglove.PoseInFrame" => fg::pose_in_frame(ns, r.pose([c[1], c[2], c[3]])?),
            "foxglove.FrameTransform" => {
                let mut v = fg::frame_transform(ns, r.pose([c[1], c[2], c[3]])?);
                for k in ["parent_frame_id", "child_frame_id"] {
                    if let Some(i) = self.t.col(k) {
                        v[k] = Value::from(r.text(i));
                    }
                }
                v
            }
            "foxglove.Log" => {
                let level = r
                    .count(c[1])?
                    .filter(|l| *l <= 5)
                    .ok_or_else(|| r.err(c[1], "is not a log level 0-5"))?;
                serde_json::json!({
                    "timestamp": fg::timestamp(ns), "level": level,
                    "message": r.text(c[3]), "name": r.text(c[2]), "file": "", "line": 0,
                })
            }
            "omnikin.WheelRates" => {
                let g = &self.groups;
                let w = fg::WheelRates {
                    commanded: r.list(&g[0])?,
                    commanded_steer: r.list(&g[1])?,
                    measured: r.list(&g[2])?,
                    measured_steer: r.list(&g[3])?,
                };
                fg::wheel_rates(ns, &w)
            }
            _ => {
                let mut v = [None; fg::COUNTER_COUNT];
                for (o, c) in v.iter_mut().zip(&self.link) {
                    if let Some(c) = c {
                        *o = r.count(*c)?;
                    }
                }
                fg::link_counters(ns, &Counters::from_values(v))
            }
        };
        Ok(Some((ns, v)))
    }

    /// `/plan`: the rows of one plan message (same `t`, `i` counting up from 0), read up to
    /// the first row of the next.
    fn next_plan(&mut self) -> Result<Option<(u64, Value)>> {
        let c = self.cols.clone();
        let mut cur: Option<(u64, Vec<Pose2<f64>>)> = self.ahead.take().map(|(n, p)| (n, vec![p]));
        while let Some((line, cells)) = self.t.next_row()? {
            let r = Row {
                t: &self.t,
                line,
                cells: &cells,
            };
            let ns = r.ns(c[0])?;
            let i = r.count(c[1])?.ok_or_else(|| r.err(c[1], "is empty"))?;
            let p = r.pose([c[2], c[3], c[4]])?;
            match &mut cur {
                Some((n, poses)) if *n == ns && i == poses.len() as u64 => {
                    if poses.len() == MAX_PLAN_POSES {
                        return Err(r.err(
                            c[1],
                            &format!("is beyond the {MAX_PLAN_POSES} poses a plan may have (MAX_PLAN_POSES)"),
                        ));
                    }
                    poses.push(p);
                }
                _ => {
                    if i != 0 {
                        return Err(r.err(c[1], "must be 0 where a plan starts, then count up"));
                    }
                    match cur {
                        Some((n, poses)) => {
                            self.ahead = Some((ns, p));
                            return Ok(Some((n, fg::poses_in_frame(n, &poses))));
                        }
                        None => cur = Some((ns, vec![p])),
                    }
                }
            }
        }
        Ok(cur.map(|(n, poses)| (n, fg::poses_in_frame(n, &poses))))
    }
}

/// `omnikin convert IN --mcap OUT.mcap`: a CSV log, or a directory of `convert --csv` files,
/// written as MCAP.
pub fn to_mcap(input: &Path, out: &Path) -> Result<()> {
    crate::output::catch_signals()?;
    if !input.is_dir() {
        let mut t = Table::open(input)?;
        let mut log = McapLog::create("--mcap", out, "omnikin convert", false)?;
        let n = log_to_mcap(&mut t, &mut log)?;
        // A signal during the last rows: the temporary file goes with `log`.
        crate::output::check_interrupted()?;
        log.finish()?;
        crate::errln!("{n} rows of {} -> {}", input.display(), out.display());
        return Ok(());
    }
    let mut files: Vec<(String, String, Topic)> = Vec::new();
    for e in
        std::fs::read_dir(input).with_context(|| format!("{}: cannot list", input.display()))?
    {
        let e = e.with_context(|| format!("{}: cannot list", input.display()))?;
        let name = e.file_name().to_string_lossy().to_string();
        match topic_of(&name) {
            Some((prefix, t)) => {
                if files.len() == super::scan::MAX_CHANNELS {
                    bail!(
                        "{}: more than {} channel CSV files (MAX_CHANNELS of omnikin convert)",
                        input.display(),
                        super::scan::MAX_CHANNELS
                    );
                }
                files.push((name, prefix, t))
            }
            None if name.ends_with(".csv") => crate::errln!(
                "warning: {}: not a channel file of `convert --csv`, skipped",
                name.escape_debug()
            ),
            None => {}
        }
    }
    if files.is_empty() {
        bail!(
            "{}: no channel CSV files (pose.csv, tf.csv, wheels.csv, … as `omnikin convert --csv` writes them)",
            input.display()
        );
    }
    for (name, _, _) in &files {
        crate::output::input("IN", &input.join(name));
    }
    let mut log = McapLog::create("--mcap", out, "omnikin convert", false)?;
    let count = files.len();
    let n = write_channels(
        &mut log,
        files,
        |(_, prefix, topic)| (prefix, *topic),
        |(name, prefix, topic)| ChannelSource::open(&input.join(name), prefix, *topic),
    )?;
    log.finish()?;
    crate::errln!("{n} messages from {} files -> {}", count, out.display());
    Ok(())
}

/// Writes channels into `log`: grouped by prefix (trial 0, then each `/trial-NNN` in turn, as
/// `simulate` writes them), and within a prefix merged by log time — the next message is the
/// earliest of the channels' next ones, ties in the canonical channel order. `key` gives an
/// item's prefix and topic, `open` its source. The number of messages written.
fn write_channels<I>(
    log: &mut McapLog,
    mut items: Vec<I>,
    key: impl Fn(&I) -> (&String, Topic),
    open: impl Fn(&I) -> Result<ChannelSource>,
) -> Result<usize> {
    items.sort_by_key(|i| {
        let (p, t) = key(i);
        (p.clone(), fg::TOPICS.iter().position(|x| *x == t))
    });
    let mut n = 0usize;
    for group in items.chunk_by(|a, b| key(a).0 == key(b).0) {
        let mut sources = group.iter().map(&open).collect::<Result<Vec<_>>>()?;
        let mut next = sources
            .iter_mut()
            .map(ChannelSource::next_message)
            .collect::<Result<Vec<_>>>()?;
        while let Some(k) = (0..next.len())
            .filter(|&k| next[k].is_some())
            .min_by_key(|&k| next[k].as_ref().map(|m| m.0))
        {
            if let Some((ns, v)) = next[k].take() {
                log.message(key(&group[k]).0, sources[k].topic, ns, &v)?;
                n += 1;
            }
            next[k] = sources[k].next_message()?;
        }
    }
    Ok(n)
}

/// A channel's topic as [`Tables`] names it (`/pose`, `/trial-002/wheels`) → its prefix
/// (``, `/trial-002`) and omnikin topic; `None` for a name that is not one of ours.
pub fn channel_of(topic: &str) -> Option<(String, Topic)> {
    let file = format!("{}.csv", topic.strip_prefix('/')?.replacen('/', "-", 1));
    topic_of(&file)
}

/// Writes the channels `channels` — `(topic, CSV text)` in the columns [`tables`] gives, e.g.
/// Python's `omnikin.write_mcap` of what `omnikin.read_mcap` returned — to the MCAP file
/// `out` (the output rules of `flag`), as `convert DIR --mcap` writes a directory of channel
/// files. The number of messages written.
///
/// # Errors
/// A topic that is not one of omnikin's (named, with the accepted ones), two channels of one
/// topic, a CSV whose header lacks the topic's columns or a bad cell (named by channel and
/// line), an output that cannot be written.
pub fn tables_to_mcap(flag: &str, channels: Vec<(String, String)>, out: &Path) -> Result<usize> {
    if channels.len() > super::scan::MAX_CHANNELS {
        bail!(
            "{} channels: more than {} (MAX_CHANNELS of omnikin convert)",
            channels.len(),
            super::scan::MAX_CHANNELS
        );
    }
    let mut items = Vec::with_capacity(channels.len());
    let mut seen = std::collections::HashSet::new();
    for (topic, text) in channels {
        let Some((prefix, t)) = channel_of(&topic) else {
            let names: Vec<&str> = fg::TOPICS.iter().map(|t| t.name).collect();
            bail!(
                "channel {:?}: not an omnikin topic (one of {}, optionally under /trial-NNN)",
                topic,
                names.join(", ")
            );
        };
        if !seen.insert(topic.clone()) {
            bail!("channel {topic}: given twice");
        }
        items.push((prefix, t, topic, text));
    }
    let mut log = McapLog::create(flag, out, "omnikin write_mcap", false)?;
    let n = write_channels(
        &mut log,
        items,
        |(p, t, _, _)| (p, *t),
        |(p, t, topic, text)| {
            let table = Table::from_text(format!("channel {topic}"), text.clone().into_bytes())?;
            ChannelSource::new(table, p, *t)
        },
    )?;
    log.finish()?;
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_cells_round_trip() {
        for s in ["plain", "a, b", "say \"hi\"", ""] {
            let line = format!("{},{}", cell(s), cell("x"));
            assert_eq!(
                split_csv(&line).unwrap(),
                vec![s.to_string(), "x".to_string()]
            );
        }
        assert_eq!(split_csv("\"open"), None);
    }

    #[test]
    fn file_names_and_topics() {
        for (topic, file) in [
            ("/pose", "pose.csv"),
            ("/trial-002/wheels", "trial-002-wheels.csv"),
        ] {
            assert_eq!(file_name(topic), file);
            let (p, t) = topic_of(file).unwrap();
            assert_eq!(format!("{p}{}", t.name), topic);
        }
        assert!(topic_of("trials.csv").is_none());
        assert!(topic_of("trial-x-pose.csv").is_none());
    }

    #[test]
    fn unwrap_follows_the_previous_heading() {
        let tau = std::f64::consts::TAU;
        assert!((unwrap(-3.0, Some(3.2)) - (tau - 3.0)).abs() < 1e-12);
        assert_eq!(unwrap(1.0, None), 1.0);
        assert!((unwrap(0.1, Some(4.0 * tau)) - (4.0 * tau + 0.1)).abs() < 1e-12);
    }

    #[test]
    fn mode_and_fault_names() {
        assert_eq!(mode_of("estop"), Some(Mode::EStop));
        assert_eq!(mode_of("flying"), None);
        let f = faults_of("limit|slip").unwrap();
        assert_eq!(f.to_string(), "limit|slip");
        assert_eq!(faults_of("none"), Some(Faults::NONE));
        assert_eq!(faults_of("bogus"), None);
    }
}
