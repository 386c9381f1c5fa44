//! The figure of `omnikin identify --plot`: per run (one row each), the pose residuals against
//! time before the fit (the prior robot, dashed) and after it (the estimate, solid) — the
//! position residual's length in one panel and, when the run's reference has headings, the
//! heading residual beside it.

use std::path::Path;

use anyhow::Result;
use omnikin_sim::identify::residual_series::{PoseResiduals, RunResiduals};

use super::{PALETTE, Series, time_panel};

/// Pixel height of one run's row.
const ROW: u32 = 330;

/// `|Δp|` per sample, m.
fn lengths(r: &PoseResiduals) -> Vec<(f64, f64)> {
    r.t.iter()
        .zip(&r.position)
        .map(|(t, p)| (*t, p[0].hypot(p[1])))
        .collect()
}

/// The heading residuals per sample, rad (none without headings).
fn headings(r: &PoseResiduals) -> Vec<(f64, f64)> {
    r.heading
        .as_ref()
        .map(|h| r.t.iter().copied().zip(h.iter().copied()).collect())
        .unwrap_or_default()
}

/// The before/after pair of one quantity, labelled with each one's RMS in `unit`.
fn pair(
    before: Vec<(f64, f64)>,
    after: Vec<(f64, f64)>,
    unit: &str,
    rms: impl Fn(&[(f64, f64)]) -> f64,
) -> [Series; 2] {
    [
        Series::dashed(
            format!("before (prior), RMS {:.3e} {unit}", rms(&before)),
            before,
            PALETTE[3],
        ),
        Series::solid(
            format!("after (estimate), RMS {:.3e} {unit}", rms(&after)),
            after,
            PALETTE[0],
        ),
    ]
}

fn rms(v: &[(f64, f64)]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    (v.iter().map(|p| p.1 * p.1).sum::<f64>() / v.len() as f64).sqrt()
}

/// Writes the residual figure of `series` to `path` (`flag` names it in messages; the
/// extension chooses SVG, PNG or PDF).
pub fn write(flag: &str, path: &Path, series: &[RunResiduals]) -> Result<()> {
    let headed = series.iter().any(|r| r.after.heading.is_some());
    let cols = if headed { 2 } else { 1 };
    let rows = series.len().max(1);
    let height = ROW * u32::try_from(rows).unwrap_or(u32::MAX / ROW).min(64);
    super::svg_file(flag, path, (700 * cols as u32, height), |root| {
        let cells = root.split_evenly((rows, cols));
        for (i, run) in series.iter().enumerate() {
            // The encoder log names the run (the reference's name would clip the title).
            time_panel(
                &cells[i * cols],
                &format!("run {}: {}", i + 1, run.encoders),
                "position residual |Δp| [m]",
                &pair(lengths(&run.before), lengths(&run.after), "m", rms),
                &[],
                None,
            )?;
            if headed {
                time_panel(
                    &cells[i * cols + 1],
                    &format!("run {}: heading", i + 1),
                    "heading residual Δψ [rad]",
                    &pair(headings(&run.before), headings(&run.after), "rad", rms),
                    &[],
                    None,
                )?;
            }
        }
        Ok(())
    })
}
