//! A sampled plan and its file formats.

use std::io::{Read, Write};
use std::path::Path;

use omnikin::{MAX_WHEELS, Pose2, Twist2};

use crate::limits::MAX_PLAN_ROWS;

/// One sample of a plan: world pose and velocity, wheel rates, and for kinds with steering
/// (caster, swerve) the steer angles and steer rates. SI units (m, rad, s). Per-wheel arrays
/// have the capacity [`MAX_WHEELS`]; entries `0..plan.wheels` are used, the rest are 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Time since the start of the plan, s.
    pub t: f64,
    /// World-frame pose; `heading` unwrapped (continuous, no 2π jumps).
    pub pose: Pose2<f64>,
    /// World-frame velocity `(ẋ, ẏ)` (m/s) and yaw rate (rad/s).
    pub twist: Twist2<f64>,
    /// Wheel rates `w1 … wN`, rad/s (caster: roll rates `φ̇_i`).
    pub wheel_rates: [f64; MAX_WHEELS],
    /// Kinds with steering only: steer angles `γ_i` (rad) and steer rates `γ̇_i` (rad/s).
    pub steer: Option<([f64; MAX_WHEELS], [f64; MAX_WHEELS])>,
}

/// A per-wheel array of [`MAX_WHEELS`] entries from one value per wheel (the rest 0; values
/// past the capacity are ignored).
pub fn per_wheel(v: &[f64]) -> [f64; MAX_WHEELS] {
    let mut a = [0.0; MAX_WHEELS];
    for (d, s) in a.iter_mut().zip(v) {
        *d = *s;
    }
    a
}

impl Sample {
    /// A sample with `wheel_rates` (and steering) given as slices of one value per wheel
    /// (at most [`MAX_WHEELS`]; the rest are 0).
    pub fn new(
        t: f64,
        pose: Pose2<f64>,
        twist: Twist2<f64>,
        wheel_rates: &[f64],
        steer: Option<(&[f64], &[f64])>,
    ) -> Self {
        let pad = per_wheel;
        Self {
            t,
            pose,
            twist,
            wheel_rates: pad(wheel_rates),
            steer: steer.map(|(g, gd)| (pad(g), pad(gd))),
        }
    }
}

/// A sampled plan: samples in strictly increasing time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    /// Number of wheels (modules) of the robot it was made for: the used length of every
    /// sample's per-wheel arrays, and the number of `w`, `s`, `sd` columns of its files.
    pub wheels: usize,
    /// The samples.
    pub samples: Vec<Sample>,
}

/// Columns of a plan CSV before the wheel columns, in order (conventions.md, "Files"); then
/// `w1 … wN`, and for kinds with steering `s1 … sN, sd1 … sdN`.
pub const COLUMNS: [&str; 7] = ["t", "x", "y", "heading", "vx", "vy", "yaw_rate"];

/// The names of the per-wheel columns of a plan of `wheels` wheels: `w1 … wN`, then with
/// `steer` `s1 … sN, sd1 … sdN`.
pub fn wheel_columns(wheels: usize, steer: bool) -> Vec<String> {
    let mut c: Vec<String> = (1..=wheels).map(|i| format!("w{i}")).collect();
    if steer {
        c.extend((1..=wheels).map(|i| format!("s{i}")));
        c.extend((1..=wheels).map(|i| format!("sd{i}")));
    }
    c
}

/// A plan file that could not be read, written or validated: where and why.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A file could not be opened, read or written.
    #[error("{file}: {error}")]
    Io {
        /// The file.
        file: String,
        /// The I/O error. The message already shows it, so it is not also the error's
        /// `source()`: a chain printer (anyhow's `{:#}`) would print it twice.
        error: std::io::Error,
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
    /// `true` when the samples carry steer columns (kinds with steering).
    pub fn steerable(&self) -> bool {
        self.samples.first().is_some_and(|s| s.steer.is_some())
    }

    /// Every column of the plan's files, in order.
    pub fn columns(&self) -> Vec<String> {
        let mut c: Vec<String> = COLUMNS.iter().map(|s| s.to_string()).collect();
        c.extend(wheel_columns(self.wheels, self.steerable()));
        c
    }

    /// One row of the plan's files: the values of [`Plan::columns`] for sample `s`.
    fn row(&self, s: &Sample, out: &mut Vec<f64>) {
        let n = self.wheels;
        out.clear();
        out.extend([
            s.t,
            s.pose.x,
            s.pose.y,
            s.pose.heading,
            s.twist.vx,
            s.twist.vy,
            s.twist.yaw_rate,
        ]);
        out.extend(&s.wheel_rates[..n]);
        if self.steerable() {
            let (g, gd) = s
                .steer
                .unwrap_or(([f64::NAN; MAX_WHEELS], [f64::NAN; MAX_WHEELS]));
            out.extend(&g[..n]);
            out.extend(&gd[..n]);
        }
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
        w.write_record(self.columns())?;
        let mut row: Vec<f64> = Vec::with_capacity(7 + 3 * MAX_WHEELS);
        let mut text: Vec<String> = Vec::with_capacity(7 + 3 * MAX_WHEELS);
        for s in &self.samples {
            self.row(s, &mut row);
            text.clear();
            text.extend(row.iter().map(|&x| fmt(x)));
            w.write_record(&text)?;
        }
        w.flush()
    }

    /// Writes the plan as JSON: `{"columns": [...], "samples": [[...], ...]}` with the same
    /// columns as the CSV.
    pub fn to_json(&self) -> serde_json::Value {
        let mut row = Vec::new();
        let rows: Vec<Vec<f64>> = self
            .samples
            .iter()
            .map(|s| {
                self.row(s, &mut row);
                row.clone()
            })
            .collect();
        serde_json::json!({ "columns": self.columns(), "samples": rows })
    }

    /// Writes the JSON of [`Plan::to_json`] to `out` row by row, without building the whole
    /// document in memory first (a `serde_json::Value` costs ~30 bytes a number: a plan of
    /// [`crate::limits::MAX_PLAN_SAMPLES`] would need gigabytes).
    pub fn write_json<W: Write>(&self, out: W) -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(out);
        w.write_all(b"{\"columns\":")?;
        serde_json::to_writer(&mut w, &self.columns())?;
        w.write_all(b",\"samples\":[")?;
        let mut row = Vec::with_capacity(7 + 3 * MAX_WHEELS);
        for (k, s) in self.samples.iter().enumerate() {
            if k > 0 {
                w.write_all(b",")?;
            }
            self.row(s, &mut row);
            serde_json::to_writer(&mut w, &row)?;
        }
        w.write_all(b"]}")?;
        w.flush()
    }

    /// Writes CSV to `path`.
    pub fn save_csv(&self, path: &Path) -> Result<(), PlanError> {
        let io = |error| PlanError::Io {
            file: path.display().to_string(),
            error,
        };
        let f = std::fs::File::create(path).map_err(io)?;
        self.write_csv(std::io::BufWriter::new(f)).map_err(io)
    }

    /// Reads a plan CSV file (see [`Plan::read_csv`]).
    pub fn load_csv(path: &Path) -> Result<Self, PlanError> {
        let name = path.display().to_string();
        let f = std::fs::File::open(path).map_err(|error| PlanError::Io {
            file: name.clone(),
            error,
        })?;
        Self::read_csv(f, &name)
    }

    /// Reads a plan CSV: a header naming at least the columns of [`COLUMNS`] and `w1 … wN`
    /// (any order, extra columns ignored; the steer columns `s1 … sN, sd1 … sdN` all or none),
    /// then one sample per row.
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
        let mut idx = [0usize; 7];
        let mut missing = Vec::new();
        for (k, c) in COLUMNS.iter().enumerate() {
            match find(c) {
                Some(i) => idx[k] = i,
                None => missing.push(*c),
            }
        }
        // The wheel count is the number of consecutive `w1, w2, …` columns.
        let wheels = (1..=MAX_WHEELS)
            .take_while(|i| find(&format!("w{i}")).is_some())
            .count();
        if wheels == 0 {
            missing.push("w1");
        }
        if !missing.is_empty() {
            return Err(err(
                Some(1),
                format!(
                    "missing column(s) {}; a plan needs {},w1,…,wN (kinds with steering add \
                     s1,…,sN,sd1,…,sdN)",
                    missing.join(", "),
                    COLUMNS.join(",")
                ),
            ));
        }
        if find(&format!("w{}", wheels + 1)).is_some() {
            return Err(err(
                Some(1),
                format!("more than {MAX_WHEELS} wheel columns (the most of any robot kind)"),
            ));
        }
        let names = wheel_columns(wheels, true);
        let wheel_idx: Vec<usize> = names[..wheels].iter().filter_map(|c| find(c)).collect();
        let steer_idx: Vec<Option<usize>> = names[wheels..].iter().map(|c| find(c)).collect();
        let n_steer = steer_idx.iter().filter(|i| i.is_some()).count();
        if n_steer != 0 && n_steer != 2 * wheels {
            return Err(err(
                Some(1),
                format!(
                    "steer columns must be all of {} or none",
                    names[wheels..].join(",")
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
                if !v.is_finite() {
                    return Err(err(Some(line), format!("column {name}: {s} is not finite")));
                }
                // Finite but implausible values (a steer rate of 1e308 rad/s was simulated
                // without a word): each column is held to the bound of what it means.
                let (max, unit, limit) = column_bound(name);
                if v.abs() > max {
                    return Err(err(
                        Some(line),
                        format!(
                            "column {name}: {} {unit} is outside the plausible range [-{max:e}, \
                             {max:e}] {unit} (the limit {limit} of omnikin_plan::limits)",
                            omnikin::description::excerpt(s)
                        ),
                    ));
                }
                Ok(v)
            };
            let mut v = [0.0; 7];
            for c in 0..7 {
                v[c] = get(idx[c], COLUMNS[c])?;
            }
            let mut w = [0.0; MAX_WHEELS];
            for i in 0..wheels {
                w[i] = get(wheel_idx[i], &names[i])?;
            }
            let steer = if n_steer > 0 {
                let (mut g, mut gd) = ([0.0; MAX_WHEELS], [0.0; MAX_WHEELS]);
                for i in 0..wheels {
                    g[i] = get(steer_idx[i].unwrap_or(0), &names[wheels + i])?;
                    gd[i] = get(steer_idx[wheels + i].unwrap_or(0), &names[2 * wheels + i])?;
                }
                Some((g, gd))
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
                wheel_rates: w,
                steer,
            });
        }
        if samples.is_empty() {
            return Err(err(None, "no samples after the header".into()));
        }
        Ok(Self { wheels, samples })
    }
}

/// The magnitude bound of a plan column, its unit and the constant's name: positions and
/// velocities [`crate::limits::MAX_COORDINATE`], headings and steer angles
/// [`crate::limits::MAX_HEADING`], rates [`crate::limits::MAX_PLAN_RATE`]; `t` is unbounded
/// here (the simulator bounds the work a duration needs).
fn column_bound(name: &str) -> (f64, &'static str, &'static str) {
    use crate::limits::{MAX_COORDINATE, MAX_HEADING, MAX_PLAN_RATE};
    match name {
        "t" => (f64::INFINITY, "s", "none"),
        "x" | "y" => (MAX_COORDINATE, "m", "MAX_COORDINATE"),
        "vx" | "vy" => (MAX_COORDINATE, "m/s", "MAX_COORDINATE"),
        "heading" => (MAX_HEADING, "rad", "MAX_HEADING"),
        n if n.starts_with("sd") || n.starts_with('w') || n == "yaw_rate" => {
            (MAX_PLAN_RATE, "rad/s", "MAX_PLAN_RATE")
        }
        _ => (MAX_HEADING, "rad", "MAX_HEADING"),
    }
}

/// Shortest representation that reads back exactly (see [`crate::csv_number`]).
fn fmt(x: f64) -> String {
    crate::CsvFloat(x).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: f64, caster: bool) -> Sample {
        Sample {
            t,
            pose: Pose2::new(t * 0.1, -0.2, 0.3 + t),
            twist: Twist2::new(0.1, 0.0, 1.0),
            wheel_rates: [1.0 / 3.0, -2.0, 1e-9, 0.0, 0.0, 0.0],
            steer: caster.then_some((
                [0.1, 0.2, 0.3, 0.0, 0.0, 0.0],
                [-1.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            )),
        }
    }

    #[test]
    fn four_wheel_plans_round_trip_with_their_columns() {
        for steer in [false, true] {
            let plan = Plan {
                wheels: 4,
                samples: (0..3)
                    .map(|k| {
                        let t = k as f64 * 0.1;
                        Sample::new(
                            t,
                            Pose2::new(t, 0.0, 0.0),
                            Twist2::new(1.0, 0.0, 0.0),
                            &[1.0, -2.0, 3.5, t],
                            steer.then_some((&[0.1, 0.2, 0.3, 0.4][..], &[0.0, 1.0, -1.0, t][..])),
                        )
                    })
                    .collect(),
            };
            let mut buf = Vec::new();
            plan.write_csv(&mut buf).unwrap();
            let text = String::from_utf8(buf.clone()).unwrap();
            assert!(
                text.starts_with(if steer {
                    "t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3,w4,s1,s2,s3,s4,sd1,sd2,sd3,sd4\n"
                } else {
                    "t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3,w4\n"
                }),
                "{text}"
            );
            assert_eq!(Plan::read_csv(&buf[..], "mem").unwrap(), plan);
        }
    }

    #[test]
    fn csv_round_trips_exactly() {
        for caster in [false, true] {
            let plan = Plan {
                wheels: 3,
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
    fn tiny_values_are_written_with_an_exponent_and_read_back_exactly() {
        // sin(pi) is the floating-point rest of a zero (a heading of pi on a leg along -x);
        // Rust's `{}` would print it as 0.00000000000000012246467991473532.
        let tiny = std::f64::consts::PI.sin();
        let mut s = sample(0.0, false);
        s.pose.y = tiny;
        s.twist.vy = -tiny;
        s.wheel_rates[2] = 2.5e-300;
        let plan = Plan {
            wheels: 3,
            samples: vec![s],
        };
        let mut buf = Vec::new();
        plan.write_csv(&mut buf).unwrap();
        let text = String::from_utf8(buf.clone()).unwrap();
        let row = text.lines().nth(1).unwrap();
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells[2], "1.2246467991473532e-16", "{row}");
        assert_eq!(cells[5], "-1.2246467991473532e-16", "{row}");
        assert_eq!(cells[9], "2.5e-300", "{row}");
        assert!(row.len() < 120, "{row}");
        assert_eq!(Plan::read_csv(&buf[..], "mem").unwrap(), plan);
    }

    #[test]
    fn a_missing_file_is_reported_once() {
        let path = std::env::temp_dir().join("omnikin-plan-no-such-dir/none.csv");
        let e = Plan::load_csv(&path).unwrap_err();
        // What a chain printer (anyhow's `{:#}`, as the CLI prints errors) shows.
        let mut shown = e.to_string();
        let mut cause = std::error::Error::source(&e);
        while let Some(c) = cause {
            shown.push_str(&format!(": {c}"));
            cause = c.source();
        }
        let os = std::fs::File::open(&path).unwrap_err().to_string();
        assert!(shown.starts_with(&path.display().to_string()), "{shown}");
        assert_eq!(shown.matches(&os).count(), 1, "{shown}");
    }

    #[test]
    fn streamed_json_is_the_json_document() {
        for caster in [false, true] {
            let plan = Plan {
                wheels: 3,
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
            wheels: 3,
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
        assert!(e.contains("steer columns"), "{e}");
    }
}
