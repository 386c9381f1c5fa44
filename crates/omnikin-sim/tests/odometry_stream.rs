//! The odometry pipeline's memory per row (issue 31, observation 3): `omnikin odometry` held
//! a whole 10⁷-row log and ten columns per row (some 1.7 GB). Read by `NumericRows` and run by
//! `OdometryStream`, a row costs no memory that stays: the heap in use after 10⁵ rows is the
//! heap after 10³ rows, up to the one structure that grows with the log's duration (one `f64`
//! per second of a shell spin, for the sphere and the ballbot with `--imu`).
//!
//! The heap is counted by a global allocator (this test binary only): bytes allocated minus
//! bytes freed by the test's own thread. Counts, not timings.

use omnikin_testkit::in_use;
use std::io::Read;

use omnikin::description::RobotDescription;
use omnikin_sim::odometry::{OdometryOptions, OdometryStream};
use omnikin_sim::table::NumericRows;

#[global_allocator]
static GLOBAL: omnikin_testkit::Counting = omnikin_testkit::Counting;

/// Bytes the count may grow by without a row being kept (a buffer that grows to a longer
/// line). A row that kept even one byte would add 99 000 over the measured rows.
const SLACK: isize = 1024;

/// An encoder log made as it is read (never held whole): `t,q1,q2,q3,gyro_z` at 100 Hz, the
/// wheels of a slow drive with a turn.
struct Log {
    row: usize,
    rows: usize,
    line: Vec<u8>,
    at: usize,
}

impl Log {
    fn new(rows: usize) -> Self {
        Self {
            row: 0,
            rows,
            line: b"t,q1,q2,q3,gyro_z\n".to_vec(),
            at: 0,
        }
    }
}

impl Read for Log {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.at == self.line.len() {
            if self.row == self.rows {
                return Ok(0);
            }
            let t = self.row as f64 * 0.01;
            let q = [-2.0 * t, 2.0 * t + 0.1 * t.sin(), 0.1 * t.sin()];
            self.line.clear();
            use std::io::Write;
            writeln!(
                self.line,
                "{t:.2},{:.5},{:.5},{:.5},{:.5}",
                q[0],
                q[1],
                q[2],
                0.01 * t.cos()
            )?;
            self.at = 0;
            self.row += 1;
        }
        let n = buf.len().min(self.line.len() - self.at);
        buf[..n].copy_from_slice(&self.line[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// Heap bytes in use after 10³ rows and after `rows` rows of `robot`'s stream over [`Log`].
fn heap_after(robot: &str, imu: bool, rows: usize) -> (isize, isize) {
    let description = RobotDescription::resolve(robot).unwrap();
    let mut log = NumericRows::new(std::io::BufReader::new(Log::new(rows)), "log.csv").unwrap();
    let options = OdometryOptions {
        imu,
        ..OdometryOptions::default()
    };
    let mut stream =
        OdometryStream::new(&description, &log.file, &log.header, None, &options).unwrap();
    let mut early = 0;
    let mut last = None;
    while let Some((line, values)) = log.next_row().unwrap() {
        last = Some(stream.push(line, values).unwrap());
        if stream.rows() == 1000 {
            early = in_use();
        }
    }
    let late = in_use();
    assert_eq!(stream.rows(), rows);
    assert!(last.is_some_and(|r| r.estimate.x.is_finite()));
    let end = stream.finish().unwrap();
    assert_eq!(end.summary.samples, rows);
    (early, late)
}

#[test]
fn a_row_costs_no_memory_that_stays() {
    // 10⁵ rows: the whole-log version held some 17 MB for them (174 bytes per row).
    let (early, late) = heap_after("kiwi", true, 100_000);
    assert!(
        late - early <= SLACK,
        "the heap grew by {} bytes over 99 000 rows (from {early} to {late})",
        late - early
    );
}

#[test]
fn the_shell_spin_summary_grows_with_the_log_seconds_only() {
    // The sphere with --imu keeps one f64 per second of log (1 000 s here) for the scatter of
    // Ω3: at most 16 bytes per second with the vector's doubling, and nothing per row.
    let rows = 100_000;
    let (early, late) = heap_after("sphere-omni", true, rows);
    let seconds = (rows / 100) as isize;
    assert!(
        late - early <= 16 * seconds + SLACK,
        "the heap grew by {} bytes over {} rows ({seconds} s of log)",
        late - early,
        rows - 1000
    );
}

/// `t,q1` rows `i,0` for i = 0, 1, …: cheap to make and to read, for the row limit.
struct Counter {
    row: u64,
    line: Vec<u8>,
    at: usize,
}

impl Read for Counter {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.at == self.line.len() {
            self.line.clear();
            use std::io::Write;
            writeln!(self.line, "{},0", self.row)?;
            self.at = 0;
            self.row += 1;
        }
        let n = buf.len().min(self.line.len() - self.at);
        buf[..n].copy_from_slice(&self.line[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

#[test]
fn the_row_after_the_documented_limit_is_an_error_naming_it() {
    // An endless log: the reader stops at MAX_TRACK_ROWS (10⁷) with an error naming the line
    // and the limit, having held one line at a time.
    let input = Counter {
        row: 0,
        line: b"t,q1\n".to_vec(),
        at: 0,
    };
    let mut rows = NumericRows::new(std::io::BufReader::new(input), "endless.csv").unwrap();
    let max = omnikin_sim::limits::MAX_TRACK_ROWS;
    // The heap in use after 10³ rows and after the last row read.
    let (mut early, mut late) = (0, 0);
    let mut n = 0usize;
    let e = loop {
        match rows.next_row() {
            Ok(Some(_)) => n += 1,
            Ok(None) => panic!("an endless input ended"),
            Err(e) => break e,
        }
        if n == 1000 {
            early = in_use();
        } else if n == max {
            late = in_use();
        }
    };
    assert_eq!(n, max);
    let held = late - early;
    assert!(
        held <= SLACK,
        "the reader held {held} more bytes after {n} rows than after 1000"
    );
    assert_eq!(
        e.to_string(),
        format!(
            "endless.csv:{}: more than {max} rows (the limit MAX_TRACK_ROWS of \
             omnikin_sim::limits); cut the log into several files",
            max + 2
        )
    );
}
