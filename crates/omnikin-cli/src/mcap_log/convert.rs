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
//! chunk, with a warning.
//!
//! CSV → MCAP (`convert IN --mcap out.mcap`): IN is a directory of such files (the round trip),
//! or one CSV log: `robot --log`, `drive … --out`, `simulate`'s `trials.csv` or a pose CSV
//! `t,x,y,heading` (`odometry --out`); its columns say what it has.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use omnikin::Pose2;
use omnikin::runtime::{Faults, Mode};
use serde_json::Value;

use super::foxglove::{self as fg, Counters, Topic};
use super::{McapLog, Sample};

/// Largest input file, bytes (read whole): 1 GiB, as the other logs' limit.
pub const MAX_INPUT_BYTES: u64 = omnikin_sim::limits::MAX_LOG_BYTES as u64;

/// `omnikin convert`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("to").required(true).args(["csv", "mcap"])))]
pub struct ConvertArgs {
    /// An MCAP file (with --csv); a CSV log or a directory of `convert --csv` files (with
    /// --mcap).
    pub input: PathBuf,
    /// Write each channel of the MCAP input to DIR/CHANNEL.csv (directory created; new or
    /// empty unless --force).
    #[arg(long, value_name = "DIR")]
    pub csv: Option<PathBuf>,
    /// Write the CSV input (a log, or a directory of `convert --csv` files) as MCAP.
    #[arg(long, value_name = "FILE")]
    pub mcap: Option<PathBuf>,
}

/// Runs `omnikin convert`.
pub fn run(a: &ConvertArgs) -> Result<()> {
    match (&a.csv, &a.mcap) {
        (Some(dir), None) => to_csv(&a.input, dir),
        (None, Some(out)) => to_mcap(&a.input, out),
        _ => bail!("give exactly one of --csv DIR (MCAP to CSV) and --mcap FILE (CSV to MCAP)"),
    }
}

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

/// One message of an MCAP file: its channel and its bytes (borrowed from the file where the
/// chunk is uncompressed), parsed as JSON only when its channel's CSV is written, so the
/// memory of a conversion is the file and one channel's CSV text.
pub struct Decoded<'a> {
    /// Log time, ns.
    pub log_time: u64,
    /// The channel (topic, schema, encoding).
    pub channel: Arc<mcap::Channel<'a>>,
    /// The message bytes.
    pub data: Cow<'a, [u8]>,
}

impl Decoded<'_> {
    /// The topic.
    pub fn topic(&self) -> &str {
        &self.channel.topic
    }
    /// The schema name (empty without a schema).
    pub fn schema(&self) -> &str {
        self.channel.schema.as_ref().map_or("", |s| s.name.as_str())
    }
    /// The JSON message (`Null` if it is not JSON).
    pub fn value(&self) -> Value {
        if self.channel.message_encoding == fg::MESSAGE_ENCODING {
            serde_json::from_slice(&self.data).unwrap_or(Value::Null)
        } else {
            Value::Null
        }
    }
}

/// Every message of the MCAP file `buf` (named `shown` in errors) in file order, and why
/// reading stopped early, if it did (a truncated or damaged file: the messages before the
/// damage are returned).
pub fn read_mcap<'a>(buf: &'a [u8], shown: &str) -> Result<(Vec<Decoded<'a>>, Option<String>)> {
    if buf.len() < mcap::MAGIC.len() || buf[..mcap::MAGIC.len()] != *mcap::MAGIC {
        bail!("{shown}: not an MCAP file (it does not start with the MCAP magic)");
    }
    let stream = mcap::MessageStream::new(buf).with_context(|| format!("{shown}: not MCAP"))?;
    let mut out = Vec::new();
    let mut stopped = None;
    for m in stream {
        match m {
            Ok(m) => out.push(Decoded {
                log_time: m.log_time,
                channel: m.channel,
                data: m.data,
            }),
            Err(e) => {
                stopped = Some(e.to_string());
                break;
            }
        }
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

/// The CSV header of `/link`: the telemetry log's names.
const LINK_COLUMNS: [&str; 11] = [
    "rx_ok",
    "rx_framing",
    "rx_crc",
    "rx_version",
    "rx_auth",
    "rx_replay",
    "rx_malformed",
    "rx_session",
    "rx_entropy",
    "rx_dropped",
    "rejected",
];

/// One of the rate arrays of a [`fg::WheelRates`].
type RatesField = fn(&fg::WheelRates) -> &Option<Vec<f64>>;

/// The CSV text of one channel's messages (see the module docs for the columns).
fn channel_csv(topic: Topic, msgs: &[&Decoded]) -> Result<String> {
    let t = |m: &Decoded| fg::seconds(m.log_time);
    let bad = |m: &Decoded| {
        anyhow::anyhow!(
            "{} at log time {} ns: not a {} message",
            m.topic(),
            m.log_time,
            topic.schema.name
        )
    };
    let mut s = String::new();
    match topic.schema.name {
        "foxglove.PoseInFrame" => {
            s.push_str("t,x,y,heading\n");
            let mut prev = None;
            for m in msgs {
                let p = fg::decode_pose_in_frame(&m.value()).ok_or_else(|| bad(m))?;
                let h = unwrap(p.heading, prev);
                prev = Some(h);
                let _ = writeln!(s, "{},{},{},{h}", t(m), p.x, p.y);
            }
        }
        "foxglove.FrameTransform" => {
            s.push_str("t,x,y,heading,parent_frame_id,child_frame_id\n");
            let mut prev = None;
            for m in msgs {
                let (p, parent, child) = {
                    let v = m.value();
                    fg::decode_frame_transform(&v)
                        .map(|(p, a, b)| (p, a.to_string(), b.to_string()))
                }
                .ok_or_else(|| bad(m))?;
                let h = unwrap(p.heading, prev);
                prev = Some(h);
                let _ = writeln!(
                    s,
                    "{},{},{},{h},{},{}",
                    t(m),
                    p.x,
                    p.y,
                    cell(&parent),
                    cell(&child)
                );
            }
        }
        "foxglove.PosesInFrame" => {
            s.push_str("t,i,x,y,heading\n");
            for m in msgs {
                let poses = fg::decode_poses_in_frame(&m.value()).ok_or_else(|| bad(m))?;
                let mut prev = None;
                for (i, p) in poses.iter().enumerate() {
                    let h = unwrap(p.heading, prev);
                    prev = Some(h);
                    let _ = writeln!(s, "{},{i},{},{},{h}", t(m), p.x, p.y);
                }
            }
        }
        "foxglove.Log" => {
            s.push_str("t,level,name,message\n");
            for m in msgs {
                let (level, name, text) = {
                    let v = m.value();
                    fg::decode_log(&v).map(|(l, n, t)| (l, n.to_string(), t.to_string()))
                }
                .ok_or_else(|| bad(m))?;
                let _ = writeln!(s, "{},{level},{},{}", t(m), cell(&name), cell(&text));
            }
        }
        "omnikin.WheelRates" => {
            let rows: Vec<fg::WheelRates> = msgs
                .iter()
                .map(|m| fg::decode_wheel_rates(&m.value()).ok_or_else(|| bad(m)))
                .collect::<Result<_>>()?;
            let width = |f: RatesField| {
                rows.iter()
                    .filter_map(|r| f(r).as_ref().map(Vec::len))
                    .max()
                    .unwrap_or(0)
            };
            let groups: [(&str, RatesField); 4] = [
                ("w", |r| &r.commanded),
                ("sd", |r| &r.commanded_steer),
                ("mw", |r| &r.measured),
                ("msd", |r| &r.measured_steer),
            ];
            let widths: Vec<usize> = groups.iter().map(|(_, f)| width(*f)).collect();
            s.push('t');
            for ((p, _), n) in groups.iter().zip(&widths) {
                for i in 1..=*n {
                    let _ = write!(s, ",{p}{i}");
                }
            }
            s.push('\n');
            for (m, r) in msgs.iter().zip(&rows) {
                let _ = write!(s, "{}", t(m));
                for ((_, f), n) in groups.iter().zip(&widths) {
                    let v = f(r);
                    for i in 0..*n {
                        let _ = write!(s, ",{}", opt(v.as_ref().and_then(|v| v.get(i).copied())));
                    }
                }
                s.push('\n');
            }
        }
        "omnikin.LinkCounters" => {
            s.push('t');
            for c in LINK_COLUMNS {
                let _ = write!(s, ",{c}");
            }
            s.push('\n');
            for m in msgs {
                let c = fg::decode_link_counters(&m.value()).ok_or_else(|| bad(m))?;
                let _ = write!(s, "{}", t(m));
                for v in c.values() {
                    let _ = write!(s, ",{}", v.map(|v| v.to_string()).unwrap_or_default());
                }
                s.push('\n');
            }
        }
        other => bail!("no CSV form for schema {other}"),
    }
    Ok(s)
}

fn to_csv(input: &Path, dir: &Path) -> Result<()> {
    let buf = read_limited(input)?;
    let (msgs, stopped) = read_mcap(&buf, &input.display().to_string())?;
    if let Some(why) = &stopped {
        if msgs.is_empty() {
            bail!("{}: no message could be read: {why}", input.display());
        }
        crate::errln!(
            "warning: {}: the file ends early or is damaged ({why}); converted the {} messages before that (up to the last complete chunk)",
            input.display(),
            msgs.len()
        );
    }
    // By topic, in order of first appearance; unknown channels are reported and skipped.
    let mut by_topic: BTreeMap<String, (Topic, Vec<&Decoded>)> = BTreeMap::new();
    let mut skipped: BTreeMap<String, usize> = BTreeMap::new();
    for m in &msgs {
        match fg::topic(m.topic()).filter(|t| t.schema.name == m.schema()) {
            Some(t) => by_topic
                .entry(m.topic().to_string())
                .or_insert((t, vec![]))
                .1
                .push(m),
            None => {
                *skipped
                    .entry(format!("{} ({})", m.topic(), m.schema()))
                    .or_default() += 1
            }
        }
    }
    for (k, n) in &skipped {
        crate::errln!("warning: channel {k}: not an omnikin channel, {n} messages skipped");
    }
    let names: Vec<String> = by_topic.keys().map(|t| file_name(t)).collect();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    crate::output::create_dir("--csv", dir)?;
    for n in &refs {
        crate::output::check_file("--csv", &dir.join(n))?;
    }
    for ((topic, (t, list)), name) in by_topic.iter().zip(&names) {
        let text = channel_csv(*t, list).with_context(|| format!("{}", input.display()))?;
        crate::output::write_file("--csv", &dir.join(name), |w| {
            std::io::Write::write_all(w, text.as_bytes())
        })?;
        crate::errln!(
            "{topic}: {} messages -> {}",
            list.len(),
            dir.join(name).display()
        );
    }
    Ok(())
}

/// A CSV file as text cells: header, `(line, cells)` rows.
struct Table {
    file: String,
    header: Vec<String>,
    rows: Vec<(usize, Vec<String>)>,
}

impl Table {
    fn load(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        let text = String::from_utf8(read_limited(path)?)
            .map_err(|_| anyhow::anyhow!("{file}: not UTF-8 text"))?;
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let Some((_, head)) = lines.next() else {
            bail!("{file}:1: empty file, expected a header row");
        };
        let header: Vec<String> = head
            .trim_start_matches('\u{feff}')
            .split(',')
            .map(|h| h.trim().to_string())
            .collect();
        let mut rows = Vec::new();
        for (i, l) in lines {
            let cells =
                split_csv(l).with_context(|| format!("{file}:{}: unterminated quote", i + 1))?;
            if cells.len() != header.len() {
                bail!(
                    "{file}:{}: {} values, but the header has {} columns",
                    i + 1,
                    cells.len(),
                    header.len()
                );
            }
            rows.push((i + 1, cells));
        }
        Ok(Self { file, header, rows })
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
fn log_to_mcap(t: &Table, log: &mut McapLog) -> Result<usize> {
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
    for (line, cells) in &t.rows {
        let r = Row {
            t,
            line: *line,
            cells,
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
            let mut v = [None; 11];
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
            &Sample {
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
    Ok(t.rows.len())
}

/// One `convert --csv` file back to messages `(log time, topic, value)`.
fn channel_messages(t: &Table, prefix: &str, topic: Topic) -> Result<Vec<(u64, String, Value)>> {
    let name = format!("{prefix}{}", topic.name);
    let mut out = Vec::new();
    let what = format!("the {name} CSV");
    match topic.schema.name {
        "foxglove.PoseInFrame" => {
            let c = require(t, &["t", "x", "y", "heading"], &what)?;
            for (line, cells) in &t.rows {
                let r = Row {
                    t,
                    line: *line,
                    cells,
                };
                let ns = r.ns(c[0])?;
                out.push((
                    ns,
                    name.clone(),
                    fg::pose_in_frame(ns, r.pose([c[1], c[2], c[3]])?),
                ));
            }
        }
        "foxglove.FrameTransform" => {
            let c = require(t, &["t", "x", "y", "heading"], &what)?;
            for (line, cells) in &t.rows {
                let r = Row {
                    t,
                    line: *line,
                    cells,
                };
                let ns = r.ns(c[0])?;
                let mut v = fg::frame_transform(ns, r.pose([c[1], c[2], c[3]])?);
                for k in ["parent_frame_id", "child_frame_id"] {
                    if let Some(i) = t.col(k) {
                        v[k] = Value::from(r.text(i));
                    }
                }
                out.push((ns, name.clone(), v));
            }
        }
        "foxglove.PosesInFrame" => {
            let c = require(t, &["t", "i", "x", "y", "heading"], &what)?;
            let mut cur: Option<(u64, Vec<Pose2<f64>>)> = None;
            for (line, cells) in &t.rows {
                let r = Row {
                    t,
                    line: *line,
                    cells,
                };
                let ns = r.ns(c[0])?;
                let i = r.count(c[1])?.ok_or_else(|| r.err(c[1], "is empty"))?;
                let p = r.pose([c[2], c[3], c[4]])?;
                match &mut cur {
                    Some((n, poses)) if *n == ns && i == poses.len() as u64 => poses.push(p),
                    _ => {
                        if i != 0 {
                            return Err(r.err(c[1], "must be 0 where a plan starts, then count up"));
                        }
                        if let Some((n, poses)) = cur.take() {
                            out.push((n, name.clone(), fg::poses_in_frame(n, &poses)));
                        }
                        cur = Some((ns, vec![p]));
                    }
                }
            }
            if let Some((n, poses)) = cur {
                out.push((n, name.clone(), fg::poses_in_frame(n, &poses)));
            }
        }
        "foxglove.Log" => {
            let c = require(t, &["t", "level", "name", "message"], &what)?;
            for (line, cells) in &t.rows {
                let r = Row {
                    t,
                    line: *line,
                    cells,
                };
                let ns = r.ns(c[0])?;
                let level = r
                    .count(c[1])?
                    .filter(|l| *l <= 5)
                    .ok_or_else(|| r.err(c[1], "is not a log level 0-5"))?;
                out.push((
                    ns,
                    name.clone(),
                    serde_json::json!({
                        "timestamp": fg::timestamp(ns), "level": level,
                        "message": r.text(c[3]), "name": r.text(c[2]), "file": "", "line": 0,
                    }),
                ));
            }
        }
        "omnikin.WheelRates" => {
            let tc = require(t, &["t"], &what)?[0];
            let g = [
                t.numbered("w"),
                t.numbered("sd"),
                t.numbered("mw"),
                t.numbered("msd"),
            ];
            for (line, cells) in &t.rows {
                let r = Row {
                    t,
                    line: *line,
                    cells,
                };
                let ns = r.ns(tc)?;
                let w = fg::WheelRates {
                    commanded: r.list(&g[0])?,
                    commanded_steer: r.list(&g[1])?,
                    measured: r.list(&g[2])?,
                    measured_steer: r.list(&g[3])?,
                };
                out.push((ns, name.clone(), fg::wheel_rates(ns, &w)));
            }
        }
        "omnikin.LinkCounters" => {
            let tc = require(t, &["t"], &what)?[0];
            let cols: Vec<Option<usize>> = LINK_COLUMNS.iter().map(|c| t.col(c)).collect();
            for (line, cells) in &t.rows {
                let r = Row {
                    t,
                    line: *line,
                    cells,
                };
                let ns = r.ns(tc)?;
                let mut v = [None; 11];
                for (o, c) in v.iter_mut().zip(&cols) {
                    if let Some(c) = c {
                        *o = r.count(*c)?;
                    }
                }
                out.push((
                    ns,
                    name.clone(),
                    fg::link_counters(ns, &Counters::from_values(v)),
                ));
            }
        }
        other => bail!("no CSV form for schema {other}"),
    }
    Ok(out)
}

fn to_mcap(input: &Path, out: &Path) -> Result<()> {
    if input.is_dir() {
        let mut files: Vec<(String, String, Topic)> = Vec::new();
        for e in
            std::fs::read_dir(input).with_context(|| format!("{}: cannot list", input.display()))?
        {
            let e = e.with_context(|| format!("{}: cannot list", input.display()))?;
            let name = e.file_name().to_string_lossy().to_string();
            match topic_of(&name) {
                Some((prefix, t)) => files.push((name, prefix, t)),
                None if name.ends_with(".csv") => {
                    crate::errln!("warning: {name}: not a channel file of `convert --csv`, skipped")
                }
                None => {}
            }
        }
        if files.is_empty() {
            bail!(
                "{}: no channel CSV files (pose.csv, tf.csv, wheels.csv, … as `omnikin convert --csv` writes them)",
                input.display()
            );
        }
        // Channels in the canonical order, then all messages by log time (stable).
        files.sort_by_key(|(n, p, t)| {
            (p.clone(), fg::TOPICS.iter().position(|x| x == t), n.clone())
        });
        for (name, _, _) in &files {
            crate::output::input("IN", &input.join(name));
        }
        let mut log = McapLog::create("--mcap", out, "omnikin convert", false)?;
        let mut msgs = Vec::new();
        for (name, prefix, topic) in &files {
            let t = Table::load(&input.join(name))?;
            msgs.extend(channel_messages(&t, prefix, *topic)?);
        }
        msgs.sort_by_key(|m| m.0);
        let n = msgs.len();
        for (ns, topic, v) in msgs {
            let (prefix, t) = match topic.rfind('/') {
                Some(i) if i > 0 => (&topic[..i], fg::topic(&topic)),
                _ => ("", fg::topic(&topic)),
            };
            let t = t.with_context(|| format!("topic {topic}"))?;
            log.message(prefix, t, ns, &v)?;
        }
        log.finish()?;
        crate::errln!(
            "{n} messages from {} files -> {}",
            files.len(),
            out.display()
        );
    } else {
        let t = Table::load(input)?;
        let mut log = McapLog::create("--mcap", out, "omnikin convert", false)?;
        let n = log_to_mcap(&t, &mut log)?;
        log.finish()?;
        crate::errln!("{n} rows of {} -> {}", input.display(), out.display());
    }
    Ok(())
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
