//! Evaluation figures in paper 000's style: theoretical path dashed, mean path solid, 95 %
//! confidence band shaded (SVG, pure Rust).

use std::path::Path;

use anyhow::Result;
use omnikin_plan::Plan;
use omnikin_sim::metrics::{MeanTrajectory, Run};
use plotters::prelude::*;

use crate::plot::{Arrow, Band, PALETTE, Series, draw_err, time_panel, xy_panel};

const RUN_GREY: RGBColor = RGBColor(185, 185, 185);

/// Most points drawn per line or band border: a panel is 700 px wide, so more add nothing
/// visible and only grow the SVG (10^6 samples would write ~100 MB).
const MAX_DRAWN: usize = 10_000;

/// `points` thinned to at most [`MAX_DRAWN`], in order, keeping the shape: the points are cut
/// into consecutive chunks, and each chunk keeps its first and last point and its extremes in x
/// and in y (so spikes and the outline stay where they are). O(n).
fn decimate(points: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    let n = points.len();
    if n <= MAX_DRAWN {
        return points;
    }
    let chunk = n.div_ceil(MAX_DRAWN / 6);
    let mut out = Vec::with_capacity(MAX_DRAWN);
    for (c, part) in points.chunks(chunk).enumerate() {
        let arg = |key: fn(&(f64, f64)) -> f64, better: fn(f64, f64) -> bool| {
            let mut best = 0;
            for (i, p) in part.iter().enumerate() {
                if better(key(p), key(&part[best])) {
                    best = i;
                }
            }
            best
        };
        let mut keep = [
            0,
            part.len() - 1,
            arg(|p| p.0, |a, b| a < b),
            arg(|p| p.0, |a, b| a > b),
            arg(|p| p.1, |a, b| a < b),
            arg(|p| p.1, |a, b| a > b),
        ];
        keep.sort_unstable();
        let mut last = usize::MAX;
        for i in keep {
            if i != last {
                out.push(points[c * chunk + i]);
                last = i;
            }
        }
    }
    out
}

/// The band around a 2-D mean path: at each sample the per-axis half-widths `(hx, hy)` are
/// projected on the path normal (`|n_x| hx + |n_y| hy`), giving the left and right borders.
/// One border of a band: points in data units.
type Border = Vec<(f64, f64)>;

fn band_polygon(mean: &[[f64; 2]], half: &[[f64; 2]]) -> (Border, Border) {
    let n = mean.len();
    let mut left = Vec::with_capacity(n);
    let mut right = Vec::with_capacity(n);
    let mut normal = [0.0, 1.0];
    for k in 0..n {
        let (a, b) = (mean[k.saturating_sub(1)], mean[(k + 1).min(n - 1)]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = dx.hypot(dy);
        if len > 1e-9 {
            normal = [-dy / len, dx / len];
        }
        let w = normal[0].abs() * half[k][0] + normal[1].abs() * half[k][1];
        left.push((mean[k][0] + w * normal[0], mean[k][1] + w * normal[1]));
        right.push((mean[k][0] - w * normal[0], mean[k][1] - w * normal[1]));
    }
    (left, right)
}

/// Draws the trajectory figure: the XY path (runs faint, plan dashed, mean solid, band shaded,
/// an arrow at the start) and x(t), y(t) with their bands.
pub fn trajectory_figure(
    flag: &str,
    path: &Path,
    title: &str,
    plan: &Plan,
    runs: &[Run],
    mean: &MeanTrajectory,
) -> Result<()> {
    crate::plot::svg_file(flag, path, (1400, 700), |root| {
        draw_trajectories(root, title, plan, runs, mean)
    })
}

fn draw_trajectories(
    root: &crate::plot::Area,
    title: &str,
    plan: &Plan,
    runs: &[Run],
    mean: &MeanTrajectory,
) -> Result<()> {
    root.fill(&WHITE).map_err(draw_err)?;
    let root = root
        .titled(&crate::plot::svg_text(title), ("sans-serif", 22))
        .map_err(draw_err)?;
    let (left, right) = root.split_horizontally(700);
    let blue = PALETTE[0];
    let several = runs.len() >= 2;
    let plan_xy: Vec<(f64, f64)> = plan.samples.iter().map(|s| (s.pose.x, s.pose.y)).collect();

    let mut series: Vec<Series> = runs
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let label = match (i, several) {
                (0, true) => "individual runs",
                (0, false) => "run",
                _ => "",
            };
            Series {
                width: 1,
                ..Series::solid(
                    label,
                    decimate(r.xy.iter().map(|p| (p[0], p[1])).collect()),
                    RUN_GREY,
                )
            }
        })
        .collect();
    series.push(Series::dashed(
        "planned (theoretical)",
        decimate(plan_xy.clone()),
        BLACK,
    ));
    let mut bands = Vec::new();
    if several {
        series.push(Series::solid(
            "mean of runs",
            decimate(mean.mean.iter().map(|p| (p[0], p[1])).collect()),
            blue,
        ));
        let (upper, lower) = band_polygon(&mean.mean, &mean.half_width);
        let (upper, lower) = (decimate(upper), decimate(lower));
        bands.push(Band::between("95 % band of the mean", &upper, &lower, blue));
    }
    let arrows: Vec<Arrow> = match (
        plan_xy.first(),
        plan_xy
            .iter()
            .find(|p| (p.0 - plan_xy[0].0).hypot(p.1 - plan_xy[0].1) > 1e-6),
    ) {
        (Some(a), Some(b)) => vec![Arrow {
            at: *a,
            dir: (b.0 - a.0, b.1 - a.1),
            color: BLACK,
        }],
        _ => Vec::new(),
    };
    xy_panel(
        &left,
        "path (world frame; arrow: start)",
        "x [m]",
        "y [m]",
        &series,
        &bands,
        &arrows,
    )?;

    let panels = right.split_evenly((2, 1));
    for (c, (panel, name)) in panels.iter().zip(["x", "y"]).enumerate() {
        let t = plan.samples.iter().map(|s| s.t);
        let planned: Vec<(f64, f64)> = plan
            .samples
            .iter()
            .map(|s| (s.t, if c == 0 { s.pose.x } else { s.pose.y }))
            .collect();
        let mut series = vec![Series::dashed("planned", decimate(planned), BLACK)];
        let mut bands = Vec::new();
        if several {
            let m: Vec<(f64, f64)> = t.clone().zip(&mean.mean).map(|(t, p)| (t, p[c])).collect();
            let up: Vec<(f64, f64)> = t
                .clone()
                .enumerate()
                .map(|(k, t)| (t, mean.mean[k][c] + mean.half_width[k][c]))
                .collect();
            let lo: Vec<(f64, f64)> = t
                .enumerate()
                .map(|(k, t)| (t, mean.mean[k][c] - mean.half_width[k][c]))
                .collect();
            bands.push(Band::between(
                "95 % band",
                &decimate(up),
                &decimate(lo),
                blue,
            ));
            series.push(Series::solid("mean", decimate(m), blue));
        } else if let Some(r) = runs.first() {
            series.push(Series {
                width: 1,
                ..Series::solid(
                    "run",
                    decimate(t.zip(&r.xy).map(|(t, p)| (t, p[c])).collect()),
                    RUN_GREY,
                )
            });
        }
        time_panel(
            panel,
            &format!("{name}(t)"),
            &format!("{name} [m]"),
            &series,
            &bands,
            None,
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_bounds_the_points_and_keeps_ends_and_extremes() {
        let n = 1_000_003;
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let t = k as f64 * 1e-3;
                (t, (t * 0.7).sin())
            })
            .collect();
        pts[123_457] = (123.457, 5.0); // a one-sample spike
        pts[654_321] = (654.321, -7.0);
        let d = decimate(pts.clone());
        assert!(d.len() <= MAX_DRAWN, "{}", d.len());
        assert_eq!(d.first(), pts.first());
        assert_eq!(d.last(), pts.last());
        assert!(d.contains(&(123.457, 5.0)) && d.contains(&(654.321, -7.0)));
        // In order: time never goes back.
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
        let short = pts[..MAX_DRAWN].to_vec();
        assert_eq!(decimate(short.clone()), short);
    }
}
