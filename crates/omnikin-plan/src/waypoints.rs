//! Waypoint files: CSV `x,y[,heading]` or TOML `[[waypoint]]` tables, validated with
//! `file:line` errors.
//!
//! CSV: one waypoint per line, `x,y` or `x,y,heading` (m, m, rad; world frame), every line
//! with the same number of columns. An optional header line names the columns exactly
//! (`x,y` or `x,y,heading`); blank lines and lines starting with `#` are ignored. A leading
//! UTF-8 byte-order mark is skipped (CSV and TOML). Coordinates are at most
//! [`crate::limits::MAX_COORDINATE`] and headings [`crate::limits::MAX_HEADING`] in
//! magnitude; a file has at most [`crate::limits::MAX_WAYPOINTS`] waypoints.
//!
//! TOML:
//! ```toml
//! [[waypoint]]
//! x = 0.0          # m
//! y = 0.0          # m
//! heading = 0.0    # rad, optional: all waypoints or none
//! ```

use serde::Deserialize;

use crate::PlanningError;
use crate::limits::{MAX_COORDINATE, MAX_HEADING, MAX_WAYPOINTS};

/// `text` without a leading UTF-8 byte-order mark (editors on Windows write one).
pub(crate) fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// Checks a waypoint value against its range in [`crate::limits`]; `Err` is the message.
fn check_value(name: &str, v: f64) -> Result<(), String> {
    let (max, unit, limit) = if name == "heading" {
        (MAX_HEADING, "rad", "MAX_HEADING")
    } else {
        (MAX_COORDINATE, "m", "MAX_COORDINATE")
    };
    if v.abs() <= max {
        Ok(())
    } else {
        Err(format!(
            "{name} = {} {unit} is outside the plausible range [-{max:e}, {max:e}] {unit} \
             (omnikin_plan::limits::{limit})",
            crate::error::num(v)
        ))
    }
}

fn too_many(file: &str, line: Option<usize>) -> PlanningError {
    err(
        file,
        line,
        format!(
            "more than {MAX_WAYPOINTS} waypoints (the limit MAX_WAYPOINTS of \
             omnikin_plan::limits); cut the path into several files"
        ),
    )
}

/// Waypoints read from a file, with the line each came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Waypoints {
    /// Positions, world frame, m.
    pub points: Vec<[f64; 2]>,
    /// Headings at the waypoints (rad, used as given), when the file has them.
    pub headings: Option<Vec<f64>>,
    /// 1-based line of each waypoint in the file.
    pub lines: Vec<usize>,
}

fn err(file: &str, line: Option<usize>, message: String) -> PlanningError {
    PlanningError::Waypoints {
        file: file.to_string(),
        line,
        message,
    }
}

impl Waypoints {
    /// Reads a waypoint file: TOML if its name ends in `.toml`, CSV otherwise.
    ///
    /// # Errors
    /// [`PlanningError::Waypoints`] naming the file, the line and the problem.
    pub fn load(path: &std::path::Path) -> Result<Self, PlanningError> {
        let name = path.display().to_string();
        let toml = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
        // The TOML parser needs up to ~1 KB of heap per input byte (nested inline tables), so
        // a TOML waypoint file has the 1 MiB cap of every TOML input; CSV may be larger.
        let (max, limit) = if toml {
            (
                omnikin::description::MAX_TOML_BYTES,
                "MAX_TOML_BYTES of omnikin::description",
            )
        } else {
            (
                crate::limits::MAX_WAYPOINT_FILE_BYTES,
                "MAX_WAYPOINT_FILE_BYTES of omnikin_plan::limits",
            )
        };
        let text = omnikin::description::read_text_limited(path, max, limit)
            .map_err(|e| err(&name, None, format!("cannot read: {e}")))?;
        if toml {
            Self::from_toml(&text, &name)
        } else {
            Self::from_csv(&text, &name)
        }
    }

    /// Parses CSV text (see the module docs); `file` names it in errors.
    ///
    /// # Errors
    /// [`PlanningError::Waypoints`] for a bad header, a wrong number of columns, a value that
    /// is not a finite number or is outside its range ([`crate::limits::MAX_COORDINATE`],
    /// [`crate::limits::MAX_HEADING`]), more than [`crate::limits::MAX_WAYPOINTS`] waypoints, fewer than two waypoints or a waypoint repeating the previous one.
    pub fn from_csv(text: &str, file: &str) -> Result<Self, PlanningError> {
        let text = strip_bom(text);
        let mut points = Vec::new();
        let mut headings: Vec<f64> = Vec::new();
        let mut lines = Vec::new();
        let mut width: Option<usize> = None;
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let trimmed = raw.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            let rec: Vec<&str> = trimmed.split(',').map(str::trim).collect();
            let is_header = points.is_empty() && width.is_none() && rec[0].parse::<f64>().is_err();
            if is_header {
                match rec.as_slice() {
                    ["x", "y"] => width = Some(2),
                    ["x", "y", "heading"] => width = Some(3),
                    _ => {
                        return Err(err(
                            file,
                            Some(line),
                            format!(
                                "header \"{}\" must be exactly x,y or x,y,heading",
                                rec.join(",")
                            ),
                        ));
                    }
                }
                continue;
            }
            let n = rec.len();
            if !(n == 2 || n == 3) {
                return Err(err(
                    file,
                    Some(line),
                    format!("expected 2 or 3 columns (x,y[,heading]), got {n}"),
                ));
            }
            match width {
                Some(w) if w != n => {
                    return Err(err(
                        file,
                        Some(line),
                        format!("expected {w} columns like the lines above, got {n}"),
                    ));
                }
                _ => width = Some(n),
            }
            const NAMES: [&str; 3] = ["x", "y", "heading"];
            let mut v = [0.0; 3];
            for (c, &field) in rec.iter().enumerate() {
                let x: f64 = field.parse().map_err(|_| {
                    err(
                        file,
                        Some(line),
                        format!(
                            "column {}: \"{}\" is not a number",
                            NAMES[c],
                            omnikin::description::excerpt(field)
                        ),
                    )
                })?;
                if !x.is_finite() {
                    return Err(err(
                        file,
                        Some(line),
                        format!("column {}: {field} is not finite", NAMES[c]),
                    ));
                }
                check_value(NAMES[c], x)
                    .map_err(|m| err(file, Some(line), format!("column {m}")))?;
                v[c] = x;
            }
            if points.len() == MAX_WAYPOINTS {
                return Err(too_many(file, Some(line)));
            }
            points.push([v[0], v[1]]);
            if n == 3 {
                headings.push(v[2]);
            }
            lines.push(line);
        }
        let has_heading = width == Some(3);
        Self::finish(file, points, has_heading.then_some(headings), lines)
    }

    /// Parses TOML text (see the module docs); `file` names it in errors.
    ///
    /// # Errors
    /// [`PlanningError::Waypoints`] for a syntax or schema error (unknown key, missing `x`/`y`,
    /// wrong type), non-finite values, headings on some waypoints only, fewer than two
    /// waypoints or a repeated waypoint.
    pub fn from_toml(text: &str, file: &str) -> Result<Self, PlanningError> {
        let text = strip_bom(text);
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Wp {
            x: toml::Spanned<f64>,
            y: toml::Spanned<f64>,
            heading: Option<toml::Spanned<f64>>,
        }
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct FileDoc {
            waypoint: Vec<toml::Spanned<Wp>>,
        }
        let line_of = |offset: usize| 1 + text[..offset.min(text.len())].matches('\n').count();
        let doc: FileDoc = toml::from_str(text).map_err(|e| {
            err(
                file,
                e.span().map(|s| line_of(s.start)),
                e.message().trim().to_string(),
            )
        })?;
        if doc.waypoint.len() > MAX_WAYPOINTS {
            let line = line_of(doc.waypoint[MAX_WAYPOINTS].span().start);
            return Err(too_many(file, Some(line)));
        }
        let mut points = Vec::new();
        let mut headings = Vec::new();
        let mut lines = Vec::new();
        let with_heading = doc
            .waypoint
            .first()
            .is_some_and(|w| w.get_ref().heading.is_some());
        for (i, w) in doc.waypoint.iter().enumerate() {
            // The waypoint's own line (its `[[waypoint]]` header or inline table) identifies
            // it; an error about one value names that value's line.
            let line = line_of(w.span().start);
            let wp = w.get_ref();
            let values = [Some(("x", &wp.x)), Some(("y", &wp.y))]
                .into_iter()
                .chain([wp.heading.as_ref().map(|h| ("heading", h))]);
            for (name, v) in values.flatten() {
                let (at, v) = (Some(line_of(v.span().start)), *v.get_ref());
                if !v.is_finite() {
                    return Err(err(
                        file,
                        at,
                        format!("waypoint {}: {name} = {v} is not finite", i + 1),
                    ));
                }
                check_value(name, v)
                    .map_err(|m| err(file, at, format!("waypoint {}: {m}", i + 1)))?;
            }
            if wp.heading.is_some() != with_heading {
                return Err(err(
                    file,
                    wp.heading
                        .as_ref()
                        .map_or(Some(line), |h| Some(line_of(h.span().start))),
                    format!(
                        "waypoint {}: give a heading on every waypoint or on none (waypoint 1 {})",
                        i + 1,
                        if with_heading { "has one" } else { "has none" }
                    ),
                ));
            }
            points.push([*wp.x.get_ref(), *wp.y.get_ref()]);
            headings.push(wp.heading.as_ref().map_or(0.0, |h| *h.get_ref()));
            lines.push(line);
        }
        Self::finish(file, points, with_heading.then_some(headings), lines)
    }

    fn finish(
        file: &str,
        points: Vec<[f64; 2]>,
        headings: Option<Vec<f64>>,
        lines: Vec<usize>,
    ) -> Result<Self, PlanningError> {
        if points.len() < 2 {
            return Err(err(
                file,
                None,
                format!("needs at least 2 waypoints, found {}", points.len()),
            ));
        }
        for k in 1..points.len() {
            let (a, b) = (points[k - 1], points[k]);
            if (b[0] - a[0]).hypot(b[1] - a[1]) <= 1e-9 {
                return Err(err(
                    file,
                    Some(lines[k]),
                    format!(
                        "waypoint ({}, {}) repeats the previous one (line {}); consecutive waypoints must differ",
                        b[0],
                        b[1],
                        lines[k - 1]
                    ),
                ));
            }
        }
        Ok(Self {
            points,
            headings,
            lines,
        })
    }

    /// Maps a path error that names a waypoint (`waypoint N ...`) to this file's line.
    pub fn locate(&self, file: &str, e: PlanningError) -> PlanningError {
        if let PlanningError::InvalidPath(msg) = &e
            && let Some(rest) = msg.strip_prefix("waypoint ")
            && let Some(n) = rest
                .split([' ', ':'])
                .next()
                .and_then(|n| n.parse::<usize>().ok())
            && let Some(&line) = self.lines.get(n.wrapping_sub(1))
        {
            return err(file, Some(line), msg.clone());
        }
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_with_and_without_header() {
        let w = Waypoints::from_csv("# a path\nx,y,heading\n0,0,0\n1,0,0.5\n\n1,1,1\n", "w.csv")
            .unwrap();
        assert_eq!(w.points, vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]);
        assert_eq!(w.headings, Some(vec![0.0, 0.5, 1.0]));
        assert_eq!(w.lines, vec![3, 4, 6]);
        let w = Waypoints::from_csv("0,0\n-1,2\n", "w.csv").unwrap();
        assert_eq!(w.headings, None);
    }

    #[test]
    fn csv_errors_name_file_and_line() {
        let e = Waypoints::from_csv("x,y\n0,0\n1,abc\n", "w.csv")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "w.csv:3: column y: \"abc\" is not a number");
        let e = Waypoints::from_csv("0,0\n1,0,2\n", "w.csv")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "w.csv:2: expected 2 columns like the lines above, got 3");
        let e = Waypoints::from_csv("x,z\n0,0\n", "w.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("w.csv:1: header"), "{e}");
        let e = Waypoints::from_csv("0,0\n0,0\n", "w.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("w.csv:2: waypoint (0, 0) repeats"), "{e}");
        let e = Waypoints::from_csv("0,0\n", "w.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least 2"), "{e}");
        let e = Waypoints::from_csv("0,0\n1,inf\n", "w.csv")
            .unwrap_err()
            .to_string();
        assert_eq!(e, "w.csv:2: column y: inf is not finite");
    }

    #[test]
    fn toml_waypoints_and_errors() {
        let ok = "[[waypoint]]\nx = 0.0\ny = 0.0\n\n[[waypoint]]\nx = 1.0\ny = 0.5\n";
        let w = Waypoints::from_toml(ok, "w.toml").unwrap();
        assert_eq!(w.points, vec![[0.0, 0.0], [1.0, 0.5]]);
        assert_eq!(w.lines, vec![1, 5]);
        let bad = "[[waypoint]]\nx = 0.0\ny = 0.0\n[[waypoint]]\nx = 1.0\nz = 0.5\n";
        let e = Waypoints::from_toml(bad, "w.toml").unwrap_err().to_string();
        assert!(e.starts_with("w.toml:6: unknown field `z`"), "{e}");
        let mixed =
            "[[waypoint]]\nx = 0.0\ny = 0.0\nheading = 1.0\n[[waypoint]]\nx = 1.0\ny = 0.5\n";
        let e = Waypoints::from_toml(mixed, "w.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("w.toml:5: waypoint 2: give a heading"), "{e}");
    }

    /// An error about one value names that value's line, not its `[[waypoint]]` header's.
    #[test]
    fn toml_value_errors_name_the_value_line() {
        let e = Waypoints::from_toml(
            "[[waypoint]]\nx = 0.0\ny = 0.0\n\n[[waypoint]]\nx = 1.0\n\ny = nan\n",
            "w.toml",
        )
        .unwrap_err()
        .to_string();
        assert_eq!(e, "w.toml:8: waypoint 2: y = NaN is not finite");
        let e = Waypoints::from_toml(
            "[[waypoint]]\n# start\nx = 0.0\ny = 0.0\nheading = 0.0\n[[waypoint]]\n\
             y = 0.5\nx = 1.0\nheading = 1e9\n",
            "w.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("w.toml:9: waypoint 2: heading = "), "{e}");
        // A waypoint-level error still names the waypoint's header.
        let e = Waypoints::from_toml(
            "[[waypoint]]\nx = 0.0\ny = 0.0\n[[waypoint]]\nx = 0.0\ny = 0.0\n",
            "w.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("w.toml:4: waypoint (0, 0) repeats"), "{e}");
    }
}
