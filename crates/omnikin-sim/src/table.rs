//! Numeric CSV tables with named columns: the encoder logs and camera fixes that
//! `omnikin odometry` reads (conventions.md, "Encoder log CSV for odometry").
//!
//! A header row names the columns (a UTF-8 byte-order mark before it is ignored), then one
//! row per sample with exactly as many comma-separated values; every value must be a finite
//! number, a column `t` (s) is required and must increase strictly; blank lines are skipped.
//! Errors name `FILE:LINE`, the column and the rule.

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

use omnikin_plan::limits::LineLimit;

/// A numeric CSV table: header names and rows (with their 1-based line numbers).
#[derive(Clone, Debug, PartialEq)]
pub struct NumericTable {
    /// The file, as named in errors.
    pub file: String,
    /// Column names, trimmed.
    pub header: Vec<String>,
    /// `(line, values)` per sample row, values in header order.
    pub rows: Vec<(usize, Vec<f64>)>,
}

/// A table that could not be read: file, line and what is wrong (column and rule).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}:{line}: {message}")]
pub struct TableError {
    /// The file.
    pub file: String,
    /// 1-based line (the header is line 1).
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

impl NumericTable {
    /// Reads and parses `path` whole (see [`NumericTable::parse`]); a file is streamed instead
    /// by [`NumericRows::open`], which this uses.
    ///
    /// # Errors
    /// [`TableError`] when the file cannot be read or is malformed.
    pub fn load(path: &Path) -> Result<Self, TableError> {
        Self::collect(NumericRows::open(path)?)
    }

    /// Parses CSV text (see the module docs); `file` names it in errors.
    ///
    /// # Errors
    /// [`TableError`] for an empty file, more than [`crate::limits::MAX_TRACK_ROWS`] rows, a row
    /// whose width differs from the header's, a value
    /// that is not a finite number, a missing `t` column or a time that does not increase.
    pub fn parse(text: &str, file: &str) -> Result<Self, TableError> {
        Self::collect(NumericRows::new(text.as_bytes(), file)?)
    }

    /// Every row of `rows`, held.
    fn collect<R: BufRead>(mut rows: NumericRows<R>) -> Result<Self, TableError> {
        let mut held = Vec::new();
        while let Some((line, v)) = rows.next_row()? {
            held.push((line, v.to_vec()));
        }
        Ok(Self {
            file: rows.file,
            header: rows.header,
            rows: held,
        })
    }

    /// Index of column `name`, if the header has it.
    pub fn col(&self, name: &str) -> Option<usize> {
        col(&self.header, name)
    }

    /// Indices of required columns, or an error naming all missing ones and `why`.
    ///
    /// # Errors
    /// [`TableError`] on line 1 listing every missing column.
    pub fn require(&self, names: &[&str], why: &str) -> Result<Vec<usize>, TableError> {
        require(&self.file, &self.header, names, why)
    }
}

fn error(file: &str, line: usize, message: String) -> TableError {
    TableError {
        file: file.to_string(),
        line,
        message,
    }
}

/// Line `line` of `file`, `bytes`, as text.
fn utf8<'a>(bytes: &'a [u8], file: &str, line: usize) -> Result<&'a str, TableError> {
    std::str::from_utf8(bytes).map_err(|_| {
        error(
            file,
            line,
            "cannot read: stream did not contain valid UTF-8".into(),
        )
    })
}

fn col(header: &[String], name: &str) -> Option<usize> {
    header.iter().position(|h| h == name)
}

pub(crate) fn require(
    file: &str,
    header: &[String],
    names: &[&str],
    why: &str,
) -> Result<Vec<usize>, TableError> {
    let missing: Vec<&str> = names
        .iter()
        .copied()
        .filter(|n| col(header, n).is_none())
        .collect();
    if !missing.is_empty() {
        return Err(TableError {
            file: file.to_string(),
            line: 1,
            message: format!("missing column(s) {} ({why})", missing.join(", ")),
        });
    }
    Ok(names.iter().filter_map(|n| col(header, n)).collect())
}

/// A numeric CSV table read one row at a time, under the rules of the module docs: the memory
/// is one line and one row of values, whatever the number of rows (a whole 10⁷-row encoder log
/// held as a [`NumericTable`] took some 900 MB).
///
/// The header is read by [`NumericRows::new`] (so a missing `t` column is an error before any
/// row); each [`next_row`](Self::next_row) checks one row (its width, its values, its time
/// against the previous row's, the row limit) and returns it, so the first fault in file
/// order is the one reported.
#[derive(Debug)]
pub struct NumericRows<R> {
    /// The file, as named in errors.
    pub file: String,
    /// Column names, trimmed.
    pub header: Vec<String>,
    input: R,
    /// Index of the `t` column.
    t: usize,
    /// Lines read so far (the 1-based number of the last line read).
    line: usize,
    /// Rows returned so far.
    rows: usize,
    /// The previous row's time and line.
    previous: Option<(f64, usize)>,
    text: Vec<u8>,
    values: Vec<f64>,
}

impl NumericRows<BufReader<LineLimit<File>>> {
    /// Opens `path` for reading row by row. A file over
    /// [`MAX_LOG_BYTES`](crate::limits::MAX_LOG_BYTES) is refused before it is read, and a line
    /// over [`MAX_CSV_LINE`](omnikin_plan::limits::MAX_CSV_LINE) when it is reached.
    ///
    /// # Errors
    /// [`TableError`] when the file cannot be opened, is too large or its header is malformed.
    pub fn open(path: &Path) -> Result<Self, TableError> {
        let file = path.display().to_string();
        let cannot = |e: std::io::Error| TableError {
            file: file.clone(),
            line: 1,
            message: format!("cannot read: {e}"),
        };
        let f = File::open(path).map_err(cannot)?;
        let len = f.metadata().map(|m| m.len()).unwrap_or(0);
        let max = crate::limits::MAX_LOG_BYTES;
        if len > max as u64 {
            return Err(cannot(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "larger than {max} bytes (the limit MAX_LOG_BYTES of omnikin_sim::limits): \
                     is this the right file?"
                ),
            )));
        }
        let limited = LineLimit::new(f, omnikin_plan::limits::MAX_CSV_LINE);
        Self::new(BufReader::with_capacity(64 * 1024, limited), &file)
    }
}

impl<R: BufRead> NumericRows<R> {
    /// Reads the header of `input` (blank lines before it are skipped, a UTF-8 byte-order mark
    /// is ignored); `file` names it in errors.
    ///
    /// # Errors
    /// [`TableError`] for an empty input, a header without a `t` column, or a read error.
    pub fn new(input: R, file: &str) -> Result<Self, TableError> {
        let mut rows = Self {
            file: file.to_string(),
            header: Vec::new(),
            input,
            t: 0,
            line: 0,
            rows: 0,
            previous: None,
            text: Vec::new(),
            values: Vec::new(),
        };
        if !rows.next_line()? {
            return Err(rows.error(1, "empty file, expected a header row".into()));
        }
        rows.header = rows
            .line_text()?
            .trim_start_matches('\u{feff}')
            .split(',')
            .map(|h| h.trim().to_string())
            .collect();
        let Some(t) = col(&rows.header, "t") else {
            return Err(rows.error(1, "missing column t".into()));
        };
        rows.t = t;
        Ok(rows)
    }

    /// Index of column `name`, if the header has it.
    pub fn col(&self, name: &str) -> Option<usize> {
        col(&self.header, name)
    }

    /// Indices of required columns, or an error naming all missing ones and `why`.
    ///
    /// # Errors
    /// [`TableError`] on line 1 listing every missing column.
    pub fn require(&self, names: &[&str], why: &str) -> Result<Vec<usize>, TableError> {
        require(&self.file, &self.header, names, why)
    }

    /// The next row, `(line, values in header order)`, or `None` at the end of the input.
    /// The values are valid until the next call.
    ///
    /// # Errors
    /// [`TableError`] naming the line: more than [`crate::limits::MAX_TRACK_ROWS`] rows, a row
    /// whose width differs from the header's, a value that is not a finite number, a time that
    /// does not increase, a line that is too long or not UTF-8.
    pub fn next_row(&mut self) -> Result<Option<(usize, &[f64])>, TableError> {
        if !self.next_line()? {
            return Ok(None);
        }
        let n = self.line;
        if self.rows == crate::limits::MAX_TRACK_ROWS {
            return Err(self.error(
                n,
                format!(
                    "more than {} rows (the limit MAX_TRACK_ROWS of omnikin_sim::limits); \
                     cut the log into several files",
                    crate::limits::MAX_TRACK_ROWS
                ),
            ));
        }
        let Self {
            file,
            header,
            text,
            values,
            ..
        } = self;
        let text = utf8(text, file, n)?;
        let width = text.split(',').count();
        if width != header.len() {
            return Err(error(
                file,
                n,
                format!(
                    "{width} values, but the header has {} columns",
                    header.len()
                ),
            ));
        }
        values.clear();
        for (c, name) in text.split(',').map(str::trim).zip(header.iter()) {
            let x: f64 = c.parse().map_err(|_| {
                error(
                    file,
                    n,
                    format!(
                        "column {}: \"{}\" is not a number",
                        omnikin::description::excerpt(name),
                        omnikin::description::excerpt(c)
                    ),
                )
            })?;
            if !x.is_finite() {
                return Err(error(file, n, format!("column {name}: {c} is not finite")));
            }
            values.push(x);
        }
        // Time must increase strictly.
        let t = self.values[self.t];
        if let Some((previous, line)) = self.previous
            && t <= previous
        {
            return Err(self.error(
                n,
                format!(
                    "column t: time {t} does not increase (previous {previous} on line {line})"
                ),
            ));
        }
        self.previous = Some((t, n));
        self.rows += 1;
        Ok(Some((n, &self.values)))
    }

    /// The number of rows left (the non-blank lines), without parsing them: what the
    /// [`next_row`](Self::next_row) calls would return if every row is valid (for a caller
    /// that sizes something by the row count before it reads the rows).
    ///
    /// # Errors
    /// [`TableError`] for a line that cannot be read (too long, not UTF-8).
    pub fn count_rows(mut self) -> Result<usize, TableError> {
        let mut n = 0;
        while self.next_line()? {
            n += 1;
        }
        Ok(n)
    }

    /// Reads the next non-blank line into `text` (without its line end); `false` at the end.
    fn next_line(&mut self) -> Result<bool, TableError> {
        loop {
            self.text.clear();
            let read = self.input.read_until(b'\n', &mut self.text);
            let next = self.line + 1;
            match read {
                Ok(0) => return Ok(false),
                Ok(_) => self.line = next,
                Err(e) => return Err(self.error(next, format!("cannot read: {e}"))),
            }
            if self.text.last() == Some(&b'\n') {
                self.text.pop();
            }
            if !self.line_text()?.trim().is_empty() {
                return Ok(true);
            }
        }
    }

    /// The line read last, as text.
    fn line_text(&self) -> Result<&str, TableError> {
        utf8(&self.text, &self.file, self.line)
    }

    fn error(&self, line: usize, message: String) -> TableError {
        error(&self.file, line, message)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_rows_with_their_lines_and_skips_blank_lines() {
        let t = NumericTable::parse("\u{feff}t, q1\n\n0,1.5\n1, -2\n", "log.csv").unwrap();
        assert_eq!(t.header, ["t", "q1"]);
        assert_eq!(t.rows, vec![(3, vec![0.0, 1.5]), (4, vec![1.0, -2.0])]);
        assert_eq!(t.col("q1"), Some(1));
        assert_eq!(t.require(&["t", "q1"], "x").unwrap(), [0, 1]);
    }

    #[test]
    fn a_huge_bad_value_is_quoted_in_part() {
        // A malformed megabyte field was echoed whole into the message.
        let text = format!("t,x\n0,{}\n", "9".repeat(40) + &"z".repeat(1 << 20));
        let e = NumericTable::parse(&text, "f.csv").unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "f.csv:2: column x: \"{}… ({} bytes)\" is not a number",
                "9".repeat(40),
                40 + (1 << 20)
            )
        );
    }

    #[test]
    fn errors_name_the_line_the_column_and_the_rule() {
        let e = |text: &str| NumericTable::parse(text, "f.csv").unwrap_err().to_string();
        assert_eq!(e(""), "f.csv:1: empty file, expected a header row");
        assert_eq!(
            e("t,x\n0,1\n1"),
            "f.csv:3: 1 values, but the header has 2 columns"
        );
        assert_eq!(
            e("t,x\n0,abc"),
            "f.csv:2: column x: \"abc\" is not a number"
        );
        assert_eq!(e("t,x\n0,inf"), "f.csv:2: column x: inf is not finite");
        assert_eq!(e("s,x\n0,1"), "f.csv:1: missing column t");
        assert_eq!(
            e("t\n1\n\n1"),
            "f.csv:4: column t: time 1 does not increase (previous 1 on line 2)"
        );
        let t = NumericTable::parse("t\n0", "f.csv").unwrap();
        assert_eq!(
            t.require(&["t", "q1", "q2"], "a log needs q")
                .unwrap_err()
                .to_string(),
            "f.csv:1: missing column(s) q1, q2 (a log needs q)"
        );
    }
}
