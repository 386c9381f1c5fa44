//! Numeric CSV tables with named columns: the encoder logs and camera fixes that
//! `omnikin odometry` reads (conventions.md, "Encoder log CSV for odometry").
//!
//! A header row names the columns (a UTF-8 byte-order mark before it is ignored), then one
//! row per sample with exactly as many comma-separated values; every value must be a finite
//! number, a column `t` (s) is required and must increase strictly; blank lines are skipped.
//! Errors name `FILE:LINE`, the column and the rule.

use std::path::Path;

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
    /// Reads and parses `path` (see [`NumericTable::parse`]).
    ///
    /// # Errors
    /// [`TableError`] when the file cannot be read or is malformed.
    pub fn load(path: &Path) -> Result<Self, TableError> {
        let file = path.display().to_string();
        let text = omnikin::description::read_text_limited(
            path,
            crate::limits::MAX_LOG_BYTES,
            "MAX_LOG_BYTES of omnikin_sim::limits",
        )
        .map_err(|e| TableError {
            file: file.clone(),
            line: 1,
            message: format!("cannot read: {e}"),
        })?;
        Self::parse(&text, &file)
    }

    /// Parses CSV text (see the module docs); `file` names it in errors.
    ///
    /// # Errors
    /// [`TableError`] for an empty file, more than [`crate::limits::MAX_TRACK_ROWS`] rows, a row
    /// whose width differs from the header's, a value
    /// that is not a finite number, a missing `t` column or a time that does not increase.
    pub fn parse(text: &str, file: &str) -> Result<Self, TableError> {
        let err = |line: usize, message: String| TableError {
            file: file.to_string(),
            line,
            message,
        };
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let Some((_, head)) = lines.next() else {
            return Err(err(1, "empty file, expected a header row".into()));
        };
        let header: Vec<String> = head
            .trim_start_matches('\u{feff}')
            .split(',')
            .map(|h| h.trim().to_string())
            .collect();
        let mut rows = Vec::new();
        for (i, line) in lines {
            let n = i + 1;
            if rows.len() == crate::limits::MAX_TRACK_ROWS {
                return Err(err(
                    n,
                    format!(
                        "more than {} rows (the limit MAX_TRACK_ROWS of omnikin_sim::limits); \
                         cut the log into several files",
                        crate::limits::MAX_TRACK_ROWS
                    ),
                ));
            }
            let cells: Vec<&str> = line.split(',').map(str::trim).collect();
            if cells.len() != header.len() {
                return Err(err(
                    n,
                    format!(
                        "{} values, but the header has {} columns",
                        cells.len(),
                        header.len()
                    ),
                ));
            }
            let mut v = Vec::with_capacity(cells.len());
            for (c, name) in cells.iter().zip(&header) {
                let x: f64 = c.parse().map_err(|_| {
                    err(
                        n,
                        format!(
                            "column {}: \"{}\" is not a number",
                            omnikin::description::excerpt(name),
                            omnikin::description::excerpt(c)
                        ),
                    )
                })?;
                if !x.is_finite() {
                    return Err(err(n, format!("column {name}: {c} is not finite")));
                }
                v.push(x);
            }
            rows.push((n, v));
        }
        // Time must increase strictly.
        let t = header
            .iter()
            .position(|h| h == "t")
            .ok_or_else(|| err(1, "missing column t".into()))?;
        for w in rows.windows(2) {
            if w[1].1[t] <= w[0].1[t] {
                return Err(err(
                    w[1].0,
                    format!(
                        "column t: time {} does not increase (previous {} on line {})",
                        w[1].1[t], w[0].1[t], w[0].0
                    ),
                ));
            }
        }
        Ok(Self {
            file: file.to_string(),
            header,
            rows,
        })
    }

    /// Index of column `name`, if the header has it.
    pub fn col(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Indices of required columns, or an error naming all missing ones and `why`.
    ///
    /// # Errors
    /// [`TableError`] on line 1 listing every missing column.
    pub fn require(&self, names: &[&str], why: &str) -> Result<Vec<usize>, TableError> {
        let missing: Vec<&str> = names
            .iter()
            .copied()
            .filter(|n| self.col(n).is_none())
            .collect();
        if !missing.is_empty() {
            return Err(TableError {
                file: self.file.clone(),
                line: 1,
                message: format!("missing column(s) {} ({why})", missing.join(", ")),
            });
        }
        Ok(names.iter().filter_map(|n| self.col(n)).collect())
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
