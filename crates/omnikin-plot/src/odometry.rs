//! The odometry figure (`omnikin odometry --plot`): the estimated path in the world frame
//! (wheel odometry, fused estimate, the fixes by their fate, an optional ground truth) beside
//! the heading over time. The lines are thinned as the rows come ([`Decimator`]), so a log of
//! any length is drawn from a bounded number of points.

use std::path::Path;

use anyhow::Result;
use omnikin_sim::odometry::{FixRecord, FixResult, OdometryRow};
use omnikin_sim::track::Track;
use plotters::prelude::*;

use crate::{Area, Decimator, Marker, PALETTE, Series, draw_err, svg_file, time_panel, xy_panel};

/// The figure's lines, thinned as the rows come: the same points as the whole lines thinned
/// at drawing time.
pub struct OdometryFigure {
    /// The wheel odometry: path (x, y; m) and heading (t, heading; s, rad).
    odometry: [Decimator; 2],
    /// The fused estimate, when there are fixes: path and heading.
    fused: Option<[Decimator; 2]>,
}

impl OdometryFigure {
    /// Lines of `rows` points (0: not known, every point kept and thinned when drawn); the
    /// fused ones only when `fused` (there are fixes).
    pub fn new(rows: usize, fused: bool) -> Self {
        let pair = || [Decimator::new(rows), Decimator::new(rows)];
        Self {
            odometry: pair(),
            fused: fused.then(pair),
        }
    }

    /// One row of the odometry stream.
    pub fn push(&mut self, row: &OdometryRow) {
        let (o, e) = (row.odometry, row.estimate);
        self.odometry[0].push((o.x, o.y));
        self.odometry[1].push((row.t, o.heading));
        if let Some(f) = self.fused.as_mut() {
            f[0].push((e.x, e.y));
            f[1].push((row.t, e.heading));
        }
    }

    /// Draws the figure to `path` (.svg, .png or .pdf; errors name `flag`), with the fixes by
    /// their fate and `truth` as a dashed black line.
    ///
    /// # Errors
    /// An unknown extension or a file that cannot be written.
    pub fn write(
        self,
        flag: &str,
        path: &Path,
        fixes: &[FixRecord],
        truth: Option<&Track>,
    ) -> Result<()> {
        svg_file(flag, path, (1300, 640), |root| {
            self.draw(root, fixes, truth)
        })
    }

    fn draw(self, root: &Area, fixes: &[FixRecord], truth: Option<&Track>) -> Result<()> {
        root.fill(&WHITE).map_err(draw_err)?;
        let title = if self.fused.is_some() {
            "odometry fused with camera fixes"
        } else {
            "wheel odometry"
        };
        let root = root.titled(title, ("sans-serif", 22)).map_err(draw_err)?;
        let (left, right) = root.split_horizontally(700);
        let [odometry_path, odometry_heading] = self.odometry.map(Decimator::finish);
        let mut paths = vec![Series::solid("wheel odometry", odometry_path, PALETTE[0])];
        let mut headings = vec![Series::solid(
            "wheel odometry",
            odometry_heading,
            PALETTE[0],
        )];
        if let Some(f) = self.fused {
            let [path, heading] = f.map(Decimator::finish);
            paths.push(Series::solid("fused with fixes", path, PALETTE[1]));
            headings.push(Series::solid("fused with fixes", heading, PALETTE[1]));
            paths.extend(fix_marks(fixes));
        }
        if let Some(t) = truth {
            let path = t.xy.iter().map(|p| (p[0], p[1])).collect();
            paths.insert(0, Series::dashed("ground truth", path, BLACK));
            if let Some(h) = &t.heading {
                let heading = t.t.iter().copied().zip(h.iter().copied()).collect();
                headings.insert(0, Series::dashed("ground truth", heading, BLACK));
            }
        }
        xy_panel(
            &left,
            "estimated path (world frame)",
            "x [m]",
            "y [m]",
            &paths,
            &[],
            &[],
        )?;
        time_panel(&right, "heading", "heading [rad]", &headings, &[], None)?;
        Ok(())
    }
}

/// The fixes' marks, by what became of them: fused (dots), rejected by the gate (crosses), and
/// never used (rings: too late, or after the log). Empty groups are left out.
fn fix_marks(fixes: &[FixRecord]) -> Vec<Series> {
    let group = |keep: fn(&FixResult) -> bool| -> Vec<(f64, f64)> {
        fixes
            .iter()
            .filter(|f| keep(&f.result))
            .map(|f| (f.x, f.y))
            .collect()
    };
    let fused = group(|r| {
        matches!(
            r,
            FixResult::Accepted { .. } | FixResult::Initialised | FixResult::Recovered { .. }
        )
    });
    let rejected = group(|r| matches!(r, FixResult::Rejected { .. }));
    let unused = group(|r| matches!(r, FixResult::TooLate | FixResult::AfterLog));
    [
        (fused, "fixes fused", PALETTE[2], Marker::Dot),
        (
            rejected,
            "fixes rejected (outliers)",
            PALETTE[3],
            Marker::Cross,
        ),
        (
            unused,
            "fixes not used (too late or after the log)",
            PALETTE[5],
            Marker::Ring,
        ),
    ]
    .into_iter()
    .filter(|(p, ..)| !p.is_empty())
    .map(|(p, label, colour, marker)| Series::marks(label, p, colour, marker))
    .collect()
}
