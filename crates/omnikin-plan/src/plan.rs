//! A sampled plan and its file formats.

use std::io::{Read, Write};
use std::path::Path;

use omnikin::{Pose2, Twist2};

use crate::limits::MAX_PLAN_ROWS;

/// One sample of a plan: world pose and velocity, wheel rates, and for the caster base its
/// steer angles and steer rates. SI units (m, rad, s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Time since the start of the plan, s.
    pub t: f64,
    /// World-frame pose; `heading` unwrapped (continuous, no 2π jumps).
    pub pose: Pose2<f64>,
    /// World-frame velocity `(ẋ, ẏ)` (m/s) and yaw rate (rad/s).
    pub twist: Twist2<f64>,
    /// Wheel rates `w1, w2, w3`, rad/s (caster: roll rates `φ̇_i`).
    pub wheel_rates: [f64; 3],
    /// Caster only: steer angles `γ_i` (rad) and steer rates `γ̇_i` (rad/s).
    pub steer: Option<([f64; 3], [f64; 3])>,
}

/// A sampled plan: samples in strictly increasing time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    /// The samples.
    pub samples: Vec<Sample>,
}

/// Columns of a plan CSV, in order (conventions.md, "Files").
pub const COLUMNS: [&str; 10] = [
    "t", "x", "y", "heading", "vx", "vy", "yaw_rate", "w1", "w2", "w3",
];
/// Extra columns of a caster plan.
pub const CASTER_COLUMNS: [&str; 6] = ["s1", "s2", "s3", "sd1", "sd2", "sd3"];

/// A plan file that could not be read, written or validated: where and why.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A file could not be opened, read or written.
    #[error("{file}: {source}")]
    Io {
        /// The file.
        file: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The content is malformed.
    #[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Format {
        /// The file.
        file: String,
        /// 1-based line (the header is line 1), when known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
}

impl Plan {
    /// `true` when the samples carry caster steer columns.
    pub fn is_caster(&self) -> bool {
        self.samples.first().is_some_and(|s| s.steer.is_some())
    }

    /// Duration of the plan, s (0 for fewer than two samples).
    pub fn duration(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        }
    }

    /// Length of the sampled path (sum of chord lengths), m.
    pub fn path_length(&self) -> f64 {
        self.samples
            .windows(2)
            .map(|w| (w[1].pose.x - w[0].pose.x).hypot(w[1].pose.y - w[0].pose.y))
            .sum()
    }

    /// Writes the plan as CSV with the conventions' header.
    pub fn write_csv<W: Write>(&self, out: W) -> std::io::Result<()> {
        let mut w = csv::Writer::from_writer(out);
        let caster = self.is_caster();
        let mut header: Vec<&str> = COLUMNS.to_vec();
        if caster {
            header.extend(CASTER_COLUMNS);
        }
        w.write_record(&header)?;
        let mut row: Vec<String> = Vec::with_capacity(16);
        for s in &self.samples {
            row.clear();
            let p = s.pose;
            let v = s.twist;
            for x in [s.t, p.x, p.y, p.heading, v.vx, v.vy, v.yaw_rate] {
                row.push(fmt(x));
            }
            row.extend(s.wheel_rates.iter().map(|&x| fmt(x)));
            if caster {
                let (g, gd) = s.steer.unwrap_or(([f64::NAN; 3], [f64::NAN; 3]));
                row.extend(g.iter().chain(gd.iter()).map(|&x| fmt(x)));
            }
            w.write_record(&row)?;
        }
        w.flush()
    }

    /// Writes the plan as JSON: `{"columns": [...], "samples": [[...], ...]}` with the same
    /// columns as the CSV.
    pub fn to_json(&self) -> serde_json::Value {
        let caster = self.is_caster();
        let mut cols: Vec<&str> = COLUMNS.to_vec();
        if caster {
            cols.extend(CASTER_COLUMNS);
        }
        let rows: Vec<Vec<f64>> = self
            .samples
            .iter()
            .map(|s| {
                let mut r = vec![
                    s.t,
                    s.pose.x,
                    s.pose.y,
                    s.pose.heading,
                    s.twist.vx,
                    s.twist.vy,
                    s.twist.yaw_rate,
                ];
                r.extend(s.wheel_rates);
                if let Some((g, gd)) = s.steer {
                    r.extend(g);
                    r.extend(gd);
                }
                r
            })
            .collect();
        serde_json::json!({ "columns": cols, "samples": rows })
    }

    /// Writes the JSON of [`Plan::to_json`] to `out` row by row, without building the whole
    /// document in memory first (a `serde_json::Value` costs ~30 bytes a number: a plan of
    /// [`crate::limits::MAX_PLAN_SAMPLES`] would need gigabytes).
    pub fn write_json<W: Write>(&self, out: W) -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(out);
        let mut cols: Vec<&str> = COLUMNS.to_vec();
        if self.is_caster() {
            cols.extend(CASTER_COLUMNS);
        }
        w.write_all(b"{\"columns\":")?;
        serde_json::to_writer(&mut w, &cols)?;
        w.write_all(b",\"samples\":[")?;
        for (k, s) in self.samples.iter().enumerate() {
            if k > 0 {
                w.write_all(b",")?;
            }
            let mut r = [0.0; 16];
            r[..7].copy_from_slice(&[
                s.t,
                s.pose.x,
                s.pose.y,
                s.pose.heading,
                s.twist.vx,
                s.twist.vy,
                s.twist.yaw_rate,
            ]);
            r[7..10].copy_from_slice(&s.wheel_rates);
            let n = match s.steer {
                Some((g, gd)) => {
                    r[10..13].copy_from_slice(&g);
                    r[13..16].copy_from_slice(&gd);
                    16
                }
                None => 10,
            };
            serde_json::to_writer(&mut w, &r[..n])?;
        }
        w.write_all(b"]}")?;
        w.flush()
    }

    /// Writes CSV to `path`.
    pub fn save_csv(&self, path: &Path) -> Result<(), PlanError> {
        let io = |source| PlanError::Io {
            file: path.display().to_string(),
            source,
        };
        let f = std::fs::File::create(path).map_err(io)?;
        self.write_csv(std::io::BufWriter::new(f)).map_err(io)
    }

    /// Reads a plan CSV file (see [`Plan::read_csv`]).
    pub fn load_csv(path: &Path) -> Result<Self, PlanError> {
        let name = path.display().to_string();
        let f = std::fs::File::open(path).map_err(|source| PlanError::Io {
            file: name.clone(),
            source,
        })?;
        Self::read_csv(f, &name)
    }

    /// Reads a plan CSV: a header naming at least the columns of [`COLUMNS`] (any order, extra
    /// columns ignored; the caster's [`CASTER_COLUMNS`] all or none), then one sample per row.
    /// Every value must be a finite number and time must increase strictly; errors name the
    /// file, the line and the column. At most [`crate::limits::MAX_PLAN_ROWS`] rows; a leading
    /// UTF-8 byte-order mark is skipped.
    pub fn read_csv<R: Read>(input: R, file: &str) -> Result<Self, PlanError> {
        let err = |line: Option<usize>, message: String| PlanError::Format {
            file: file.to_string(),
            line,
            message,
        };
        let mut r = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(
            crate::limits::LineLimit::new(input, crate::limits::MAX_CSV_LINE),
        );
        let header = r
            .headers()
            .map_err(|e| err(Some(1), format!("cannot read the header: {e}")))?
            .clone();
        let find = |name: &str| header.iter().position(|h| h == name);
        let mut idx = [0usize; 10];
        let mut missing = Vec::new();
        for (k, c) in COLUMNS.iter().enumerate() {
            match find(c) {
                Some(i) => idx[k] = i,
                None => missing.push(*c),
            }
        }
        if !missing.is_empty() {
            return Err(err(
                Some(1),
                format!(
                    "missing column(s) {}; a plan needs {} (caster adds {})",
                    missing.join(", "),
                    COLUMNS.join(","),
                    CASTER_COLUMNS.join(",")
                ),
            ));
        }
        let caster_idx: Vec<Option<usize>> = CASTER_COLUMNS.iter().map(|c| find(c)).collect();
        let n_caster = caster_idx.iter().filter(|i| i.is_some()).count();
        if n_caster != 0 && n_caster != 6 {
            return Err(err(
                Some(1),
                format!(
                    "caster columns must be all of {} or none",
                    CASTER_COLUMNS.join(",")
                ),
            ));
        }
        let mut samples = Vec::new();
        for (k, rec) in r.records().enumerate() {
            // The reader's own line numbers: blank lines are skipped, not counted out.
            let rec = rec.map_err(|e| {
                let line = e.position().map_or(k + 2, |p| p.line() as usize);
                err(Some(line), format!("{e}"))
            })?;
            let line = rec.position().map_or(k + 2, |p| p.line() as usize);
            if samples.len() == MAX_PLAN_ROWS {
                return Err(err(
                    Some(line),
                    format!(
                        "more than {MAX_PLAN_ROWS} rows (the limit MAX_PLAN_ROWS of \
                         omnikin_plan::limits); cut the plan into several files or plan it at \
                         a lower rate"
                    ),
                ));
            }
            let get = |i: usize, name: &str| -> Result<f64, PlanError> {
                let s = rec
                    .get(i)
                    .ok_or_else(|| err(Some(line), format!("column {name}: missing value")))?;
                let v: f64 = s.parse().map_err(|_| {
                    err(
                        Some(line),
                        format!(
                            "column {name}: \"{}\" is not a number",
                            omnikin::description::excerpt(s)
                        ),
                    )
                })?;
                if v.is_finite() {
                    Ok(v)
                } else {
                    Err(err(Some(line), format!("column {name}: {s} is not finite")))
                }
            };
            let mut v = [0.0; 10];
            for c in 0..10 {
                v[c] = get(idx[c], COLUMNS[c])?;
            }
            let steer = if n_caster == 6 {
                let mut g = [0.0; 6];
                for c in 0..6 {
                    g[c] = get(caster_idx[c].unwrap_or(0), CASTER_COLUMNS[c])?;
                }
                Some(([g[0], g[1], g[2]], [g[3], g[4], g[5]]))
            } else {
                None
            };
            if let Some(prev) = samples.last().map(|s: &Sample| s.t)
                && v[0] <= prev
            {
                return Err(err(
                    Some(line),
                    format!(
                        "column t: time {} does not increase (previous {prev})",
                        v[0]
                    ),
                ));
            }
            samples.push(Sample {
                t: v[0],
                pose: Pose2::new(v[1], v[2], v[3]),
                twist: Twist2::new(v[4], v[5], v[6]),
                wheel_rates: [v[7], v[8], v[9]],
                steer,
            });
        }
        if samples.is_empty() {
            return Err(err(None, "no samples after the header".into()));
        }
        Ok(Self { samples })
    }
}

/// Shortest representation that reads back exactly.
fn fmt(x: f64) -> String {
    let mut s = format!("{x}");
    if s == "-0" {
        s = "0".into();
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: f64, caster: bool) -> Sample {
        Sample {
            t,
            pose: Pose2::new(t * 0.1, -0.2, 0.3 + t),
            twist: Twist2::new(0.1, 0.0, 1.0),
            wheel_rates: [1.0 / 3.0, -2.0, 1e-9],
            steer: caster.then_some(([0.1, 0.2, 0.3], [-1.0, 0.0, 1.0])),
        }
    }

    #[test]
    fn csv_round_trips_exactly() {
        for caster in [false, true] {
            let plan = Plan {
                samples: (0..5).map(|k| sample(k as f64 * 0.01, caster)).collect(),
            };
            let mut buf = Vec::new();
            plan.write_csv(&mut buf).unwrap();
            let text = String::from_utf8(buf.clone()).unwrap();
            assert!(text.starts_with(if caster {
                "t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3,s1,s2,s3,sd1,sd2,sd3\n"
            } else {
                "t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3\n"
            }));
            let back = Plan::read_csv(&buf[..], "mem").unwrap();
            assert_eq!(back, plan);
        }
    }

    #[test]
    fn streamed_json_is_the_json_document() {
        for caster in [false, true] {
            let plan = Plan {
                samples: (0..4).map(|k| sample(k as f64 * 0.01, caster)).collect(),
            };
            let mut buf = Vec::new();
            plan.write_json(&mut buf).unwrap();
            let streamed: serde_json::Value = serde_json::from_slice(&buf).unwrap();
            assert_eq!(streamed, plan.to_json());
            assert_eq!(
                String::from_utf8(buf).unwrap(),
                serde_json::to_string(&plan.to_json()).unwrap()
            );
        }
    }

    #[test]
    fn a_byte_order_mark_is_skipped() {
        let plan = Plan {
            samples: (0..3).map(|k| sample(k as f64 * 0.01, false)).collect(),
        };
        let mut buf = "\u{feff}".as_bytes().to_vec();
        plan.write_csv(&mut buf).unwrap();
        assert_eq!(Plan::read_csv(&buf[..], "bom.csv").unwrap(), plan);
    }

    #[test]
    fn malformed_plans_name_file_line_and_column() {
        let head = "t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3\n";
        let e = Plan::read_csv("t,x,y\n0,0,0\n".as_bytes(), "p.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("p.csv:1: missing column(s) heading"), "{e}");
        let e = Plan::read_csv(
            format!("{head}0,0,0,0,0,0,0,0,0,0\n0.1,0,abc,0,0,0,0,0,0,0\n").as_bytes(),
            "p.csv",
        )
        .unwrap_err()
        .to_string();
        assert_eq!(e, "p.csv:3: column y: \"abc\" is not a number");
        let e = Plan::read_csv(format!("{head}0,0,0,0,0,0,0,0,0,NaN\n").as_bytes(), "p.csv")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "p.csv:2: column w3: NaN is not finite");
        let e = Plan::read_csv(
            format!("{head}0.1,0,0,0,0,0,0,0,0,0\n0.1,0,0,0,0,0,0,0,0,0\n").as_bytes(),
            "p.csv",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("p.csv:3: column t: time 0.1 does not increase"),
            "{e}"
        );
        let e = Plan::read_csv(format!("{head}0,0,0\n").as_bytes(), "p.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("p.csv:2:"), "{e}");
        let e = Plan::read_csv(head.as_bytes(), "p.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no samples"), "{e}");
        let e = Plan::read_csv(
            "t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3,s1\n".as_bytes(),
            "p.csv",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("caster columns"), "{e}");
    }
}
