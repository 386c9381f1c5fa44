//! Evaluation figures in paper 000's style: theoretical path dashed, mean path solid, 95 %
//! confidence band shaded (SVG, pure Rust).

use std::path::Path;

use anyhow::Result;
use omnikin_plan::Plan;
use omnikin_sim::metrics::{MeanTrajectory, Run};
use plotters::prelude::*;

use crate::plot::{Arrow, Band, PALETTE, Series, draw_err, time_panel, xy_panel};

const RUN_GREY: RGBColor = RGBColor(185, 185, 185);

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
                ..Series::solid(label, r.xy.iter().map(|p| (p[0], p[1])).collect(), RUN_GREY)
            }
        })
        .collect();
    series.push(Series::dashed(
        "planned (theoretical)",
        plan_xy.clone(),
        BLACK,
    ));
    let mut bands = Vec::new();
    if several {
        series.push(Series::solid(
            "mean of runs",
            mean.mean.iter().map(|p| (p[0], p[1])).collect(),
            blue,
        ));
        let (upper, lower) = band_polygon(&mean.mean, &mean.half_width);
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
        let mut series = vec![Series::dashed("planned", planned, BLACK)];
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
            bands.push(Band::between("95 % band", &(up), &(lo), blue));
            series.push(Series::solid("mean", m, blue));
        } else if let Some(r) = runs.first() {
            series.push(Series {
                width: 1,
                ..Series::solid(
                    "run",
                    t.zip(&r.xy).map(|(t, p)| (t, p[c])).collect(),
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
