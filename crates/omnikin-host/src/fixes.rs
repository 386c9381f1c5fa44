//! `omnikin drive --fixes FILE|-`: forwards camera fixes to the robot while an action runs.
//!
//! The input is the conventions' camera fixes CSV: a header naming `t,x,y` (capture time in
//! the **robot's** clock, s — the clock of the telemetry's `t`; world position, m), optional
//! `heading` (rad) and `arrival` (s, robot clock, when the fix may be sent; default `t`).
//! Other columns are ignored. A reader thread parses and validates each line (errors name
//! `file:line` and the column) and hands the fixes through a bounded channel, so a stream on
//! stdin is held in constant memory and never blocks the link. Each fix is sent
//! ([`Message::Fix`]) once the robot's clock, from the newest telemetry, reaches its
//! arrival time; the rows must be sorted by arrival.

use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError, sync_channel};

use anyhow::{Result, bail};
use omnikin::link::{Message, WireFix};
use omnikin::runtime::{FIX_MAX_COORDINATE, FixCounters};

/// Fixes read ahead of their arrival time (the channel's bound).
const READ_AHEAD: usize = 256;
/// Longest accepted line, bytes (a longer one is an error, not unbounded memory).
const MAX_LINE: usize = 4096;

/// One validated fix and its arrival time.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Row {
    /// When it may be sent, robot clock µs.
    arrival_us: u64,
    fix: WireFix,
}

/// What the reader thread sends.
enum Item {
    Row(Row),
    /// A bad line: the message names file:line.
    Error(String),
    End,
}

/// The forwarding state of one `drive` run.
pub struct FixFeeder {
    name: String,
    rx: Receiver<Item>,
    next: Option<Row>,
    ended: bool,
    /// Fixes sent.
    pub sent: u64,
}

/// The column indices of the header.
struct Columns {
    t: usize,
    x: usize,
    y: usize,
    heading: Option<usize>,
    arrival: Option<usize>,
    count: usize,
}

fn columns(name: &str, header: &str) -> Result<Columns> {
    let names: Vec<&str> = header.trim().split(',').map(str::trim).collect();
    let find = |c: &str| names.iter().position(|n| *n == c);
    let need = |c: &str| {
        find(c).ok_or_else(|| {
            anyhow::anyhow!(
                "{name}:1: the header has no `{c}` column (camera fixes need t,x,y[,heading][,arrival]; got `{}`)",
                header.trim()
            )
        })
    };
    Ok(Columns {
        t: need("t")?,
        x: need("x")?,
        y: need("y")?,
        heading: find("heading"),
        arrival: find("arrival"),
        count: names.len(),
    })
}

/// Parses one data line (1-based `line`) with the standard deviations to send.
fn parse_row(
    name: &str,
    line: usize,
    text: &str,
    c: &Columns,
    std: (f32, f32),
    previous_arrival: Option<u64>,
) -> Result<Row, String> {
    let cells: Vec<&str> = text.split(',').map(str::trim).collect();
    if cells.len() != c.count {
        return Err(format!(
            "{name}:{line}: {} values, the header names {}",
            cells.len(),
            c.count
        ));
    }
    let num = |i: usize, col: &str| -> Result<f64, String> {
        let v: f64 = cells[i].parse().map_err(|_| {
            format!(
                "{name}:{line}: column {col}: `{}` is not a number",
                cells[i]
            )
        })?;
        if !v.is_finite() {
            return Err(format!("{name}:{line}: column {col}: must be finite"));
        }
        Ok(v)
    };
    let t = num(c.t, "t")?;
    // Robot clock: whole microseconds from 0, at most ~31 years.
    if !(0.0..=1e9).contains(&t) {
        return Err(format!(
            "{name}:{line}: column t: {t} s is not a robot clock time (0 to 1e9 s)"
        ));
    }
    let arrival = match c.arrival {
        Some(i) => num(i, "arrival")?,
        None => t,
    };
    if arrival < t {
        return Err(format!(
            "{name}:{line}: column arrival: {arrival} is before the fix was taken (t = {t})"
        ));
    }
    if arrival > 1e9 {
        return Err(format!(
            "{name}:{line}: column arrival: {arrival} s is not a robot clock time (0 to 1e9 s)"
        ));
    }
    let x = num(c.x, "x")?;
    let y = num(c.y, "y")?;
    for (v, col) in [(x, "x"), (y, "y")] {
        if v.abs() > FIX_MAX_COORDINATE {
            return Err(format!(
                "{name}:{line}: column {col}: |{}| m exceeds {FIX_MAX_COORDINATE} m (the robot refuses it)",
                omnikin_io::num(v)
            ));
        }
    }
    let heading = match c.heading {
        Some(i) if !cells[i].is_empty() => Some(num(i, "heading")? as f32),
        _ => None,
    };
    let arrival_us = (arrival * 1e6).round() as u64;
    if let Some(p) = previous_arrival
        && arrival_us < p
    {
        return Err(format!(
            "{name}:{line}: column arrival: {arrival} s is before the previous fix's {} s (fixes must be sorted by arrival)",
            p as f64 * 1e-6
        ));
    }
    Ok(Row {
        arrival_us,
        fix: WireFix {
            capture_us: (t * 1e6).round() as u64,
            x: x as f32,
            y: y as f32,
            heading,
            std_xy: std.0,
            std_heading: std.1,
        },
    })
}

/// Reads lines from `input` and sends them to `tx` until the end, an error, or the receiver
/// goes away.
fn read_all(name: String, input: Box<dyn Read + Send>, std: (f32, f32), tx: SyncSender<Item>) {
    let mut r = BufReader::new(input);
    let mut buf = Vec::new();
    let mut line = 0usize;
    let mut cols: Option<Columns> = None;
    let mut previous = None;
    loop {
        buf.clear();
        line += 1;
        let n = match (&mut r)
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut buf)
        {
            Ok(n) => n,
            Err(e) => {
                let _ = tx.send(Item::Error(format!("{name}:{line}: cannot read: {e}")));
                return;
            }
        };
        if n == 0 {
            let item = if cols.is_none() {
                Item::Error(format!("{name}: empty: camera fixes need a header t,x,y"))
            } else {
                Item::End
            };
            let _ = tx.send(item);
            return;
        }
        if buf.len() > MAX_LINE {
            let _ = tx.send(Item::Error(format!(
                "{name}:{line}: longer than {MAX_LINE} bytes"
            )));
            return;
        }
        let Ok(text) = std::str::from_utf8(&buf) else {
            let _ = tx.send(Item::Error(format!("{name}:{line}: not UTF-8 text")));
            return;
        };
        let text = text.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let item = match &cols {
            None => match columns(&name, text) {
                Ok(c) => {
                    cols = Some(c);
                    continue;
                }
                Err(e) => Item::Error(e.to_string()),
            },
            Some(c) => match parse_row(&name, line, text, c, std, previous) {
                Ok(row) => {
                    previous = Some(row.arrival_us);
                    Item::Row(row)
                }
                Err(e) => Item::Error(e),
            },
        };
        let stop = matches!(item, Item::Error(_));
        if tx.send(item).is_err() || stop {
            return;
        }
    }
}

impl FixFeeder {
    /// Starts reading `path` (`-`: stdin) with the standard deviations `std_xy` (m) and
    /// `std_heading` (rad) sent with every fix.
    ///
    /// # Errors
    /// A file that cannot be opened, standard deviations out of range.
    pub fn open(path: &Path, std_xy: f64, std_heading: f64) -> Result<Self> {
        if !(std_xy > 0.0 && std_xy <= omnikin::runtime::FIX_MAX_STD_XY) {
            bail!("--fix-std must be in (0, 100] m (got {std_xy})");
        }
        if !(std_heading > 0.0 && std_heading <= std::f64::consts::PI) {
            bail!("--fix-heading-std must be in (0, pi] rad (got {std_heading})");
        }
        let (name, input): (String, Box<dyn Read + Send>) = if path == Path::new("-") {
            ("stdin".into(), Box::new(std::io::stdin()))
        } else {
            let f = std::fs::File::open(path)
                .map_err(|e| anyhow::anyhow!("--fixes: cannot open {}: {e}", path.display()))?;
            (path.display().to_string(), Box::new(f))
        };
        let (tx, rx) = sync_channel(READ_AHEAD);
        let std = (std_xy as f32, std_heading as f32);
        let n = name.clone();
        std::thread::Builder::new()
            .name("fixes".into())
            .spawn(move || read_all(n, input, std, tx))?;
        Ok(Self {
            name,
            rx,
            next: None,
            ended: false,
            sent: 0,
        })
    }

    /// The fixes due at robot time `now_us` (their arrival reached), in order.
    ///
    /// # Errors
    /// A bad line of the input (file:line and the rule).
    pub fn due(&mut self, now_us: u64) -> Result<Vec<Message>> {
        let mut out = Vec::new();
        loop {
            if self.next.is_none() && !self.ended {
                match self.rx.try_recv() {
                    Ok(Item::Row(r)) => self.next = Some(r),
                    Ok(Item::Error(e)) => bail!("--fixes: {e}"),
                    Ok(Item::End) | Err(TryRecvError::Disconnected) => self.ended = true,
                    Err(TryRecvError::Empty) => return Ok(out),
                }
            }
            match self.next {
                Some(r) if r.arrival_us <= now_us => {
                    out.push(Message::Fix(r.fix));
                    self.sent += 1;
                    self.next = None;
                }
                _ => return Ok(out),
            }
        }
    }

    /// Whether the input is exhausted and every fix was sent.
    pub fn done(&self) -> bool {
        self.ended && self.next.is_none()
    }

    /// The end-of-run report: fixes sent, and the robot's counters (`None`: the robot never
    /// sent its estimate).
    pub fn report(&self, robot: Option<FixCounters>) -> String {
        let pending = if self.done() {
            String::new()
        } else {
            "; the input had more fixes, not yet due when the run ended".into()
        };
        match robot {
            Some(c) => format!(
                "fixes: {} sent from {}; robot: accepted {}, rejected {}, too late {}, recoveries {}{pending}",
                self.sent, self.name, c.accepted, c.rejected, c.too_late, c.recoveries
            ),
            None => format!(
                "fixes: {} sent from {}; the robot reported no estimate: it predates camera fixes (its omnikin drops Fix messages as malformed); run the same omnikin version on both ends{pending}",
                self.sent, self.name
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cols(h: &str) -> Columns {
        columns("f.csv", h).unwrap()
    }

    #[test]
    fn rows_are_validated_with_file_and_line() {
        let c = cols("t,x,y,heading,arrival");
        let r = parse_row("f.csv", 2, "1.5,0.1,0.2,0.3,1.8", &c, (0.01, 0.05), None).unwrap();
        assert_eq!(r.arrival_us, 1_800_000);
        assert_eq!(r.fix.capture_us, 1_500_000);
        assert_eq!(r.fix.heading, Some(0.3));
        for (line, want) in [
            ("1.5,0.1,nan,0.3,1.8", "f.csv:7: column y: must be finite"),
            (
                "1.5,0.1,0.2,0.3,1.0",
                "f.csv:7: column arrival: 1 is before",
            ),
            ("1.5,0.1,0.2", "f.csv:7: 3 values, the header names 5"),
            (
                "1.5,2e4,0.2,0.3,1.8",
                "f.csv:7: column x: |20000| m exceeds",
            ),
            (
                "-1,0,0,0,0",
                "f.csv:7: column t: -1 s is not a robot clock time",
            ),
            (
                "1.5,a,0.2,0.3,1.8",
                "f.csv:7: column x: `a` is not a number",
            ),
        ] {
            let e = parse_row("f.csv", 7, line, &c, (0.01, 0.05), None).unwrap_err();
            assert!(e.starts_with(want), "{line}: {e}");
        }
        let e = parse_row(
            "f.csv",
            9,
            "1.5,0,0,0,1.8",
            &c,
            (0.01, 0.05),
            Some(2_000_000),
        )
        .unwrap_err();
        assert!(e.contains("sorted by arrival"), "{e}");
        assert!(columns("f.csv", "time,x,y").is_err());
    }
}
