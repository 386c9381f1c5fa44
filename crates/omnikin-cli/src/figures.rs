//! Evaluation figures in paper 000's style: theoretical path dashed, mean path solid, 95 %
//! confidence band shaded (SVG, pure Rust).

use std::path::Path;

use anyhow::{Result, anyhow};
use omnikin_plan::Plan;
use omnikin_sim::metrics::{MeanTrajectory, Run};
use plotters::prelude::*;

const BAND: RGBColor = RGBColor(31, 119, 180);

fn err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("drawing the figure failed: {e}")
}

/// `(lo, hi)` of `values`, padded by `pad` of the span (and at least `min_span` wide).
fn range(values: impl Iterator<Item = f64>, pad: f64, min_span: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let span = (hi - lo).max(min_span);
    let mid = 0.5 * (lo + hi);
    (
        mid - 0.5 * span * (1.0 + 2.0 * pad),
        mid + 0.5 * span * (1.0 + 2.0 * pad),
    )
}

/// The band around a 2-D mean path: at each sample the per-axis half-widths `(hx, hy)` are
/// projected on the path normal (`|n_x| hx + |n_y| hy`), giving the left and right borders.
fn band_polygon(mean: &[[f64; 2]], half: &[[f64; 2]]) -> Vec<(f64, f64)> {
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
    right.reverse();
    left.extend(right);
    left
}

/// Draws the trajectory figure: the XY path (plan dashed, runs faint, mean solid, band shaded)
/// and x(t), y(t) with their bands.
pub fn trajectory_figure(
    path: &Path,
    title: &str,
    plan: &Plan,
    runs: &[Run],
    mean: &MeanTrajectory,
) -> Result<()> {
    let root = SVGBackend::new(path, (1400, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(err)?;
    let (left, right) = root.split_horizontally(700);
    let plan_xy: Vec<(f64, f64)> = plan.samples.iter().map(|s| (s.pose.x, s.pose.y)).collect();
    let all_x = plan_xy
        .iter()
        .map(|p| p.0)
        .chain(runs.iter().flat_map(|r| r.xy.iter().map(|p| p[0])));
    let all_y = plan_xy
        .iter()
        .map(|p| p.1)
        .chain(runs.iter().flat_map(|r| r.xy.iter().map(|p| p[1])));
    let (x0, x1) = range(all_x, 0.08, 0.05);
    let (y0, y1) = range(all_y, 0.08, 0.05);
    // Equal scale on both axes, with headroom above the path for the legend.
    let span = (x1 - x0).max(y1 - y0) * 1.3;
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1) + 0.12 * span);
    let mut xy = ChartBuilder::on(&left)
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(65)
        .caption("path (world frame)", ("sans-serif", 18))
        .build_cartesian_2d(
            cx - span / 2.0..cx + span / 2.0,
            cy - span / 2.0..cy + span / 2.0,
        )
        .map_err(err)?;
    xy.configure_mesh()
        .x_desc("x [m]")
        .y_desc("y [m]")
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(err)?;
    for (i, r) in runs.iter().enumerate() {
        let s = xy
            .draw_series(LineSeries::new(
                r.xy.iter().map(|p| (p[0], p[1])),
                RGBColor(190, 190, 190).stroke_width(1),
            ))
            .map_err(err)?;
        if i == 0 {
            s.label(if runs.len() == 1 {
                "run"
            } else {
                "individual runs"
            })
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(190, 190, 190)));
        }
    }
    if runs.len() >= 2 {
        xy.draw_series(std::iter::once(Polygon::new(
            band_polygon(&mean.mean, &mean.half_width),
            BAND.mix(0.25).filled(),
        )))
        .map_err(err)?
        .label("95 % band of the mean")
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], BAND.mix(0.25).filled()));
    }
    xy.draw_series(DashedLineSeries::new(
        plan_xy.clone(),
        8,
        5,
        BLACK.stroke_width(2),
    ))
    .map_err(err)?
    .label("planned (theoretical)")
    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    if runs.len() >= 2 {
        xy.draw_series(LineSeries::new(
            mean.mean.iter().map(|p| (p[0], p[1])),
            BAND.stroke_width(2),
        ))
        .map_err(err)?
        .label("mean of runs")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BAND.stroke_width(2)));
    }
    if let Some(&(sx, sy)) = plan_xy.first() {
        xy.draw_series(std::iter::once(Circle::new((sx, sy), 5, BLACK.filled())))
            .map_err(err)?
            .label("start")
            .legend(|(x, y)| Circle::new((x + 10, y), 4, BLACK.filled()));
    }
    xy.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(err)?;

    let panels = right.split_evenly((2, 1));
    let t: Vec<f64> = plan.samples.iter().map(|s| s.t).collect();
    let (t0, t1) = (
        t.first().copied().unwrap_or(0.0),
        t.last()
            .copied()
            .unwrap_or(1.0)
            .max(t.first().copied().unwrap_or(0.0) + 1e-3),
    );
    for (c, (panel, name)) in panels.iter().zip(["x", "y"]).enumerate() {
        let planned: Vec<(f64, f64)> = plan
            .samples
            .iter()
            .map(|s| (s.t, if c == 0 { s.pose.x } else { s.pose.y }))
            .collect();
        let vals = planned.iter().map(|p| p.1).chain(
            mean.mean
                .iter()
                .zip(&mean.half_width)
                .flat_map(|(m, h)| [m[c] - h[c], m[c] + h[c]]),
        );
        let (v0, v1) = range(vals, 0.08, 0.02);
        let mut ch = ChartBuilder::on(panel)
            .margin(15)
            .x_label_area_size(40)
            .y_label_area_size(65)
            .caption(format!("{name}(t)"), ("sans-serif", 16))
            .build_cartesian_2d(t0..t1, v0..v1)
            .map_err(err)?;
        ch.configure_mesh()
            .x_desc("t [s]")
            .y_desc(format!("{name} [m]"))
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(err)?;
        if runs.len() >= 2 {
            let upper = t
                .iter()
                .enumerate()
                .map(|(k, &tk)| (tk, mean.mean[k][c] + mean.half_width[k][c]));
            let lower: Vec<(f64, f64)> = t
                .iter()
                .enumerate()
                .map(|(k, &tk)| (tk, mean.mean[k][c] - mean.half_width[k][c]))
                .collect();
            let poly: Vec<(f64, f64)> = upper.chain(lower.into_iter().rev()).collect();
            ch.draw_series(std::iter::once(Polygon::new(poly, BAND.mix(0.25).filled())))
                .map_err(err)?;
            ch.draw_series(LineSeries::new(
                t.iter().enumerate().map(|(k, &tk)| (tk, mean.mean[k][c])),
                BAND.stroke_width(2),
            ))
            .map_err(err)?;
        } else if let Some(r) = runs.first() {
            ch.draw_series(LineSeries::new(
                t.iter().zip(&r.xy).map(|(&tk, p)| (tk, p[c])),
                RGBColor(150, 150, 150).stroke_width(1),
            ))
            .map_err(err)?;
        }
        ch.draw_series(DashedLineSeries::new(planned, 8, 5, BLACK.stroke_width(2)))
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}
