//! Tracked trajectories (e.g. from video): reading `t,x,y[,heading][,mode]` CSV files, aligning
//! them in time with a plan (start of motion), and resampling them onto the plan's time grid.
//! A `mode` column (the runtime's mode names, as `omnikin robot --log` writes them) marks the
//! run's emergency stops, so that figures can show where and when the robot was stopped.

use std::io::Read;
use std::path::Path;

use omnikin_plan::Plan;

use crate::metrics::Run;

/// A tracked run as recorded: strictly increasing times with positions (and headings).
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// Times, s.
    pub t: Vec<f64>,
    /// Positions, m (world frame).
    pub xy: Vec<[f64; 2]>,
    /// Headings, rad, when the file has a `heading` column.
    pub heading: Option<Vec<f64>>,
    /// Indices of the samples where an emergency stop began (the `mode` column turns to
    /// `estop` from any other mode, or the first row is already `estop`); empty without a
    /// `mode` column.
    pub estops: Vec<usize>,
}

/// An emergency stop of a tracked run, put on the plan's clock and frame
/// ([`Track::estops_on`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EStopMark {
    /// When the stop began, s, on the plan's time axis.
    pub t: f64,
    /// Where the robot was, m (world frame, translated like the resampled run).
    pub xy: [f64; 2],
}

/// The names a `mode` column may hold: the runtime's modes ([`omnikin::runtime::Mode::name`]).
const MODE_NAMES: [omnikin::runtime::Mode; 5] = [
    omnikin::runtime::Mode::Idle,
    omnikin::runtime::Mode::Velocity,
    omnikin::runtime::Mode::Trajectory,
    omnikin::runtime::Mode::Stopping,
    omnikin::runtime::Mode::EStop,
];

/// A tracked file that could not be read: file, line, column, rule.
#[derive(Debug, thiserror::Error)]
#[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct TrackError {
    /// The file.
    pub file: String,
    /// 1-based line (the header is line 1), when known.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

/// How a track is put on the plan's clock and frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackAlignment {
    /// Displacement from the first position that counts as "moving", m.
    pub motion_threshold_m: f64,
    /// Also translate the track so its position at the start of motion is the plan's.
    pub align_position: bool,
}

impl Default for TrackAlignment {
    fn default() -> Self {
        Self {
            motion_threshold_m: 0.005,
            align_position: true,
        }
    }
}

/// Removes the 2π jumps of a heading in place (trackers often report it in (−π, π]).
fn unwrap_heading(h: &mut [f64]) {
    for k in 1..h.len() {
        let d = h[k] - h[k - 1];
        h[k] = h[k - 1] + d - core::f64::consts::TAU * (d / core::f64::consts::TAU).round();
    }
}

impl Track {
    /// Reads a tracked CSV file (see [`Track::read_csv`]).
    pub fn load(path: &Path) -> Result<Self, TrackError> {
        let file = path.display().to_string();
        let f = std::fs::File::open(path).map_err(|e| TrackError {
            file: file.clone(),
            line: None,
            message: format!("cannot open: {e}"),
        })?;
        Self::read_csv(f, &file)
    }

    /// Reads `t,x,y` with optional `heading` and `mode` columns (any order, extra columns
    /// ignored). Every value must be a finite number and time must increase strictly; a `mode`
    /// is one of the runtime's mode names (`idle`, `velocity`, `trajectory`, `stopping`,
    /// `estop`), and each change into `estop` is recorded in [`Track::estops`]. At most
    /// [`crate::limits::MAX_TRACK_ROWS`] rows; a leading UTF-8 byte-order mark is skipped.
    pub fn read_csv<R: Read>(input: R, file: &str) -> Result<Self, TrackError> {
        let err = |line: Option<usize>, message: String| TrackError {
            file: file.to_string(),
            line,
            message,
        };
        let mut r = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(
            omnikin_plan::limits::LineLimit::new(input, omnikin_plan::limits::MAX_CSV_LINE),
        );
        let header = r
            .headers()
            .map_err(|e| err(Some(1), format!("cannot read the header: {e}")))?
            .clone();
        let find = |n: &str| header.iter().position(|h| h == n);
        let (Some(it), Some(ix), Some(iy)) = (find("t"), find("x"), find("y")) else {
            return Err(err(
                Some(1),
                format!(
                    "the header must name columns t,x,y (optional heading, mode); found \"{}\"",
                    header.iter().collect::<Vec<_>>().join(",")
                ),
            ));
        };
        let ih = find("heading");
        let im = find("mode");
        let mut track = Track {
            t: Vec::new(),
            xy: Vec::new(),
            heading: ih.map(|_| Vec::new()),
            estops: Vec::new(),
        };
        let mut was_estop = false;
        for (k, rec) in r.records().enumerate() {
            // The reader's own line numbers: blank lines are skipped, not counted out.
            let rec = rec.map_err(|e| {
                let line = e.position().map_or(k + 2, |p| p.line() as usize);
                err(Some(line), e.to_string())
            })?;
            let line = rec.position().map_or(k + 2, |p| p.line() as usize);
            if track.t.len() == crate::limits::MAX_TRACK_ROWS {
                return Err(err(
                    Some(line),
                    format!(
                        "more than {} rows (the limit MAX_TRACK_ROWS of omnikin_sim::limits); \
                         cut the run into several files or resample it",
                        crate::limits::MAX_TRACK_ROWS
                    ),
                ));
            }
            let get = |i: usize, name: &str| -> Result<f64, TrackError> {
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
            let t = get(it, "t")?;
            if let Some(&prev) = track.t.last()
                && t <= prev
            {
                return Err(err(
                    Some(line),
                    format!("column t: time {t} does not increase (previous {prev})"),
                ));
            }
            track.t.push(t);
            track.xy.push([get(ix, "x")?, get(iy, "y")?]);
            if let (Some(i), Some(h)) = (ih, track.heading.as_mut()) {
                h.push(get(i, "heading")?);
            }
            if let Some(i) = im {
                let s = rec
                    .get(i)
                    .ok_or_else(|| err(Some(line), "column mode: missing value".into()))?;
                let Some(mode) = MODE_NAMES.iter().find(|m| m.name() == s) else {
                    return Err(err(
                        Some(line),
                        format!(
                            "column mode: \"{}\" is not a mode (one of {})",
                            omnikin::description::excerpt(s),
                            MODE_NAMES.map(|m| m.name()).join(", ")
                        ),
                    ));
                };
                let estop = *mode == omnikin::runtime::Mode::EStop;
                if estop && !was_estop {
                    track.estops.push(track.t.len() - 1);
                }
                was_estop = estop;
            }
        }
        // Unwrap the heading (trackers often report it in (−π, π]).
        if let Some(h) = track.heading.as_mut() {
            unwrap_heading(h);
        }
        if track.t.len() < 2 {
            return Err(err(None, "needs at least two samples".into()));
        }
        Ok(track)
    }

    /// A track from columns in memory (Python's arrays and data frames), with the rules of
    /// [`Track::read_csv`]: equal lengths, finite values, strictly increasing time, at least
    /// two and at most [`crate::limits::MAX_TRACK_ROWS`] samples. An error's line is the
    /// row's line in the equivalent CSV (row 0 is line 2). The heading is unwrapped.
    pub fn from_columns(
        name: &str,
        t: &[f64],
        x: &[f64],
        y: &[f64],
        heading: Option<&[f64]>,
    ) -> Result<Self, TrackError> {
        let err = |line: Option<usize>, message: String| TrackError {
            file: name.to_string(),
            line,
            message,
        };
        let n = t.len();
        if x.len() != n || y.len() != n || heading.is_some_and(|h| h.len() != n) {
            return Err(err(
                None,
                format!(
                    "the columns t, x, y{} must have the same length (got {n}, {}, {}{})",
                    if heading.is_some() { ", heading" } else { "" },
                    x.len(),
                    y.len(),
                    heading
                        .map(|h| format!(", {}", h.len()))
                        .unwrap_or_default()
                ),
            ));
        }
        if n > crate::limits::MAX_TRACK_ROWS {
            return Err(err(
                None,
                format!(
                    "more than {} rows (the limit MAX_TRACK_ROWS of omnikin_sim::limits)",
                    crate::limits::MAX_TRACK_ROWS
                ),
            ));
        }
        for k in 0..n {
            let cols = [("t", t[k]), ("x", x[k]), ("y", y[k])];
            for (c, v) in cols.into_iter().chain(heading.map(|h| ("heading", h[k]))) {
                if !v.is_finite() {
                    return Err(err(Some(k + 2), format!("column {c}: {v} is not finite")));
                }
            }
            if k > 0 && t[k] <= t[k - 1] {
                return Err(err(
                    Some(k + 2),
                    format!(
                        "column t: time {} does not increase (previous {})",
                        t[k],
                        t[k - 1]
                    ),
                ));
            }
        }
        if n < 2 {
            return Err(err(None, "needs at least two samples".into()));
        }
        let mut track = Track {
            t: t.to_vec(),
            xy: x.iter().zip(y).map(|(&x, &y)| [x, y]).collect(),
            heading: heading.map(<[f64]>::to_vec),
            estops: Vec::new(),
        };
        if let Some(h) = track.heading.as_mut() {
            unwrap_heading(h);
        }
        Ok(track)
    }

    /// Index of the first sample farther than `threshold` from the first position.
    fn motion_start(xy: &[[f64; 2]], threshold: f64) -> usize {
        let p0 = xy[0];
        xy.iter()
            .position(|p| (p[0] - p0[0]).hypot(p[1] - p0[1]) > threshold)
            .unwrap_or(0)
            .saturating_sub(1)
    }

    /// Largest distance of a tracked position from the first one, m.
    pub fn max_displacement(&self) -> f64 {
        let p0 = self.xy[0];
        self.xy
            .iter()
            .map(|p| (p[0] - p0[0]).hypot(p[1] - p0[1]))
            .fold(0.0, f64::max)
    }

    /// Why this track cannot be evaluated against `plan`, if it cannot: it never gets farther
    /// than `align.motion_threshold_m` from its first position while the plan does. Such a
    /// run has no start of motion to align on, and it would sit on the plan's start point — on
    /// the path, so its deviation from the path would be 0: a robot that did not move would
    /// score a perfect run. (A plan that does not move either, e.g. a turn on the spot, is
    /// fine.)
    pub fn did_not_move(&self, plan: &Plan, align: TrackAlignment) -> Option<String> {
        let moved = self.max_displacement();
        let plan_moves = plan.samples.first().map_or(0.0, |s0| {
            plan.samples
                .iter()
                .map(|s| (s.pose.x - s0.pose.x).hypot(s.pose.y - s0.pose.y))
                .fold(0.0, f64::max)
        });
        (moved <= align.motion_threshold_m && plan_moves > align.motion_threshold_m).then(|| {
            format!(
                "the run did not move: it never got farther than {moved:.4} m from its first                  position (the start of motion is a displacement above {} m), while the plan                  moves up to {plan_moves:.4} m from its start; check that this is the right                  file, or lower --motion-threshold",
                align.motion_threshold_m
            )
        })
    }

    /// Puts the track on the plan's time grid: the track's start of motion is matched to the
    /// plan's, positions (and headings) are linearly interpolated at every plan sample time
    /// (held at the ends), and with `align_position` the track is translated so that both start
    /// moving from the same point.
    pub fn resample(&self, plan: &Plan, align: TrackAlignment) -> Run {
        let (shift, offset) = self.alignment_on(plan, align);
        let mut j = 0usize;
        let mut xy = Vec::with_capacity(plan.samples.len());
        let mut heading = self
            .heading
            .as_ref()
            .map(|_| Vec::with_capacity(plan.samples.len()));
        for s in &plan.samples {
            let t = s.t + shift;
            while j + 1 < self.t.len() - 1 && self.t[j + 1] <= t {
                j += 1;
            }
            let (t0, t1) = (self.t[j], self.t[j + 1]);
            let f = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
            let (a, b) = (self.xy[j], self.xy[j + 1]);
            xy.push([
                a[0] + f * (b[0] - a[0]) + offset[0],
                a[1] + f * (b[1] - a[1]) + offset[1],
            ]);
            if let (Some(h), Some(out)) = (&self.heading, heading.as_mut()) {
                out.push(h[j] + f * (h[j + 1] - h[j]));
            }
        }
        Run { xy, heading }
    }

    /// The track's clock shift (track time − plan time, s) and translation (m) that
    /// [`Track::resample`] applies: start of motion matched to the plan's.
    fn alignment_on(&self, plan: &Plan, align: TrackAlignment) -> (f64, [f64; 2]) {
        let plan_xy: Vec<[f64; 2]> = plan.samples.iter().map(|s| [s.pose.x, s.pose.y]).collect();
        let kp = Self::motion_start(&plan_xy, align.motion_threshold_m);
        let kt = Self::motion_start(&self.xy, align.motion_threshold_m);
        let shift = self.t[kt] - plan.samples[kp].t;
        let offset = if align.align_position {
            [
                plan_xy[kp][0] - self.xy[kt][0],
                plan_xy[kp][1] - self.xy[kt][1],
            ]
        } else {
            [0.0, 0.0]
        };
        (shift, offset)
    }

    /// The run's emergency stops ([`Track::estops`]) on the plan's clock and frame, with the
    /// alignment [`Track::resample`] uses — a stop before the plan's start or after its end
    /// keeps its time (a figure shows what its axis covers).
    pub fn estops_on(&self, plan: &Plan, align: TrackAlignment) -> Vec<EStopMark> {
        if self.estops.is_empty() {
            return Vec::new();
        }
        let (shift, offset) = self.alignment_on(plan, align);
        self.estops
            .iter()
            .map(|&k| EStopMark {
                t: self.t[k] - shift,
                xy: [self.xy[k][0] + offset[0], self.xy[k][1] + offset[1]],
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use omnikin::{Pose2, Twist2};
    use omnikin_plan::Sample;

    fn line_plan() -> Plan {
        // Still for 1 s, then 0.1 m/s along x for 2 s, sampled at 10 Hz.
        Plan {
            wheels: 3,
            samples: (0..=30)
                .map(|k| {
                    let t = k as f64 * 0.1;
                    let x = if t <= 1.0 { 0.0 } else { 0.1 * (t - 1.0) };
                    Sample {
                        t,
                        pose: Pose2::new(x, 0.0, 0.0),
                        twist: Twist2::default(),
                        wheel_rates: [0.0; omnikin::MAX_WHEELS],
                        steer: None,
                    }
                })
                .collect(),
        }
    }

    #[test]
    fn alignment_matches_start_of_motion_and_position() {
        // The same motion recorded by a camera that started 3.5 s earlier, 2 m away.
        let text: String = std::iter::once("t,x,y\n".to_string())
            .chain((0..=70).map(|k| {
                let t = k as f64 * 0.1;
                let x = if t <= 4.5 { 0.0 } else { 0.1 * (t - 4.5) };
                format!("{t},{},{}\n", 2.0 + x, 1.0)
            }))
            .collect();
        let track = Track::read_csv(text.as_bytes(), "cam.csv").unwrap();
        let run = track.resample(&line_plan(), TrackAlignment::default());
        let plan = line_plan();
        for (p, s) in run.xy.iter().zip(&plan.samples) {
            assert!(
                (p[0] - s.pose.x).abs() < 1e-9 && p[1].abs() < 1e-9,
                "{p:?} vs {:?}",
                s.pose
            );
        }
    }

    #[test]
    fn a_mode_column_marks_each_emergency_stop_on_the_plans_clock() {
        // The line plan's motion recorded 3.5 s late and 2 m away; e-stopped at 5.0 s (plan
        // time 1.5 s), cleared, moving again, e-stopped at 6.0 s (plan 2.5 s).
        let text: String = std::iter::once("t,x,y,mode\n".to_string())
            .chain((0..=70).map(|k| {
                let t = k as f64 * 0.1;
                let x = if t <= 4.5 { 0.0 } else { 0.1 * (t - 4.5) };
                let mode = match k {
                    50..=52 | 60..=70 => "estop",
                    53..=54 => "idle",
                    _ => "trajectory",
                };
                format!("{t},{},1,{mode}\n", 2.0 + x)
            }))
            .collect();
        let track = Track::read_csv(text.as_bytes(), "log.csv").unwrap();
        assert_eq!(track.estops, vec![50, 60]);
        let marks = track.estops_on(&line_plan(), TrackAlignment::default());
        assert_eq!(marks.len(), 2);
        for (m, (t, x)) in marks.iter().zip([(1.5, 0.05), (2.5, 0.15)]) {
            assert!((m.t - t).abs() < 1e-9, "{m:?}");
            assert!((m.xy[0] - x).abs() < 1e-9 && m.xy[1].abs() < 1e-9, "{m:?}");
        }
        // Without alignment the position stays the recorded one, the clock is still aligned.
        let raw = TrackAlignment {
            align_position: false,
            ..TrackAlignment::default()
        };
        let m = track.estops_on(&line_plan(), raw)[0];
        assert!((m.xy[0] - 2.05).abs() < 1e-9 && (m.xy[1] - 1.0).abs() < 1e-9);
        // A log that starts e-stopped has its stop at the first row; no mode column, no stops.
        let t = Track::read_csv("t,x,y,mode\n0,0,0,estop\n1,0,0,estop\n".as_bytes(), "a").unwrap();
        assert_eq!(t.estops, vec![0]);
        let t = Track::read_csv("t,x,y\n0,0,0\n1,0,0\n".as_bytes(), "a").unwrap();
        assert!(t.estops.is_empty());
        // An unknown mode names its line and the accepted names.
        let e = Track::read_csv("t,x,y,mode\n0,0,0,idle\n1,0,0,halt\n".as_bytes(), "a.csv")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "a.csv:3: column mode: \"halt\" is not a mode (one of idle, velocity, \
             trajectory, stopping, estop)"
        );
    }

    #[test]
    fn a_track_that_never_moves_is_refused_while_the_plan_moves() {
        let plan = line_plan();
        let still: String = std::iter::once("t,x,y\n".to_string())
            .chain((0..=30).map(|k| format!("{},{},0\n", k as f64 * 0.1, 0.001 * (k % 3) as f64)))
            .collect();
        let track = Track::read_csv(still.as_bytes(), "still.csv").unwrap();
        let why = track
            .did_not_move(&plan, TrackAlignment::default())
            .unwrap();
        assert!(
            why.contains("did not move") && why.contains("0.2000 m"),
            "{why}"
        );
        // A lower threshold sees the 2 mm as motion.
        let low = TrackAlignment {
            motion_threshold_m: 0.001,
            ..TrackAlignment::default()
        };
        assert_eq!(track.did_not_move(&plan, low), None);
        // A plan that does not move either is fine.
        let mut spot = plan.clone();
        for s in &mut spot.samples {
            s.pose.x = 0.0;
        }
        assert_eq!(track.did_not_move(&spot, TrackAlignment::default()), None);
    }

    #[test]
    fn blank_lines_keep_line_numbers_and_headings_unwrap() {
        let e = Track::read_csv("t,x,y\n0,0,0\n\n0.1,0,0\n0.2,bad,0\n".as_bytes(), "a.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("a.csv:5: column x"), "{e}");
        let t = Track::read_csv(
            "t,x,y,heading\n0,0,0,3.1\n0.1,0,0,-3.1\n0.2,0,0,-3.0\n".as_bytes(),
            "a.csv",
        )
        .unwrap();
        let h = t.heading.unwrap();
        assert!(
            (h[1] - (2.0 * core::f64::consts::PI - 3.1)).abs() < 1e-12,
            "{h:?}"
        );
        assert!(
            (h[2] - (2.0 * core::f64::consts::PI - 3.0)).abs() < 1e-12,
            "{h:?}"
        );
    }

    #[test]
    fn malformed_tracks_name_file_and_line() {
        let e = Track::read_csv("time,x,y\n0,0,0\n".as_bytes(), "a.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("a.csv:1: the header must name columns t,x,y"),
            "{e}"
        );
        let e = Track::read_csv("t,x,y\n0,0,0\n0.1,zero,0\n".as_bytes(), "a.csv")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "a.csv:3: column x: \"zero\" is not a number");
        let e = Track::read_csv("t,x,y\n0,0,0\n0,1,0\n".as_bytes(), "a.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("a.csv:3: column t: time 0 does not increase"),
            "{e}"
        );
        let e = Track::read_csv("t,x,y,heading\n0,0,0,inf\n".as_bytes(), "a.csv")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "a.csv:2: column heading: inf is not finite");
        let e = Track::read_csv("t,x,y\n0,0,0\n".as_bytes(), "a.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least two"), "{e}");
        let e = Track::read_csv("t,x,y\n0,0\n".as_bytes(), "a.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("a.csv:2:"), "{e}");
    }

    #[test]
    fn columns_follow_the_csv_rules_and_name_the_row() {
        let t = Track::from_columns(
            "est",
            &[0.0, 0.1, 0.2],
            &[0.0; 3],
            &[0.0; 3],
            Some(&[3.1, -3.1, 3.1]),
        )
        .unwrap();
        // Unwrapped as a file's heading is: −3.1 follows 3.1 as 2π − 3.1.
        let h = t.heading.unwrap();
        assert!(
            (h[1] - (std::f64::consts::TAU - 3.1)).abs() < 1e-12,
            "{h:?}"
        );
        let e = Track::from_columns("est", &[0.0, 0.1, 0.1], &[0.0; 3], &[0.0; 3], None)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("est:4: column t: time 0.1 does not increase"),
            "{e}"
        );
        let e = Track::from_columns("est", &[0.0, 0.1], &[0.0, f64::NAN], &[0.0; 2], None)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("est:3: column x: NaN is not finite"), "{e}");
        let e = Track::from_columns("est", &[0.0, 0.1], &[0.0], &[0.0; 2], None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("same length (got 2, 1, 2)"), "{e}");
        assert!(Track::from_columns("est", &[0.0], &[0.0], &[0.0], None).is_err());
    }
}
