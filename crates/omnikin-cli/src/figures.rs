//! Evaluation figures in the Sphere paper's style: theoretical path dashed, mean path solid, 95 %
//! confidence band shaded — or, with fewer than [`MIN_RUNS_FOR_CI`] runs, their min/max
//! envelope, and the legend says which (SVG, pure Rust).

use std::path::Path;

use anyhow::Result;
use omnikin_plan::Plan;
use omnikin_sim::metrics::{MeanTrajectory, Run};
use plotters::prelude::*;

use crate::plot::{Arrow, Band, PALETTE, Series, draw_err, time_panel, xy_panel};

const RUN_GREY: RGBColor = RGBColor(185, 185, 185);

/// One border of a band: points in data units.
type Border = Vec<(f64, f64)>;

/// Fewer runs than this draw their min/max envelope instead of a 95 % band: with n runs the
/// band's half-width is t(0.975, n − 1)·s/√n, and t is 4.3 for 3 runs and 2.8 for 5 (2.26 for
/// 10), so a band from a handful of runs says more about the t factor than about the runs
/// (and outgrew the curvature of a 0.2 m circle, folding over itself).
pub const MIN_RUNS_FOR_CI: usize = 10;

/// Unit normals (left of the direction of motion) along `path`, by central differences; where
/// the path stands still (a stop) the last normal is kept, before the first motion the first.
fn normals(path: &[(f64, f64)]) -> Vec<[f64; 2]> {
    let n = path.len();
    let mut out: Vec<Option<[f64; 2]>> = (0..n)
        .map(|k| {
            let (a, b) = (path[k.saturating_sub(1)], path[(k + 1).min(n - 1)]);
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let len = dx.hypot(dy);
            (len > 1e-9).then(|| [-dy / len, dx / len])
        })
        .collect();
    let first = out.iter().flatten().next().copied().unwrap_or([0.0, 1.0]);
    let mut last = first;
    for v in &mut out {
        match v {
            Some(x) => last = *x,
            None => *v = Some(last),
        }
    }
    out.into_iter().map(|v| v.unwrap_or(first)).collect()
}

/// The band around a 2-D mean path, across the path: at each sample the offsets `(lo, hi)`
/// along the normal of the **plan** (smooth, unlike the normal of a noisy mean) give the two
/// borders `mean + lo·n` and `mean + hi·n`.
fn band_borders(mean: &[[f64; 2]], normal: &[[f64; 2]], off: &[(f64, f64)]) -> (Border, Border) {
    let mut left = Vec::with_capacity(mean.len());
    let mut right = Vec::with_capacity(mean.len());
    for ((m, n), (lo, hi)) in mean.iter().zip(normal).zip(off) {
        left.push((m[0] + hi * n[0], m[1] + hi * n[1]));
        right.push((m[0] + lo * n[0], m[1] + lo * n[1]));
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
    // Few runs: their min/max, said so in the legend; many: the 95 % band of the mean.
    let envelope = runs.len() < MIN_RUNS_FOR_CI;
    let band_label = if envelope {
        format!(
            "min/max of the {} runs (fewer than {MIN_RUNS_FOR_CI}: too few for a 95 % band)",
            runs.len()
        )
    } else {
        "95 % band of the mean".to_string()
    };
    let aligned =
        mean.mean.len() == plan_xy.len() && runs.iter().all(|r| r.xy.len() == mean.mean.len());
    if several && aligned {
        series.push(Series::solid(
            "mean of runs",
            mean.mean.iter().map(|p| (p[0], p[1])).collect(),
            blue,
        ));
        let normal = normals(&plan_xy);
        let off: Vec<(f64, f64)> = (0..mean.mean.len())
            .map(|k| {
                let (m, n) = (mean.mean[k], normal[k]);
                if envelope {
                    runs.iter().fold((0.0_f64, 0.0_f64), |(lo, hi), r| {
                        let d = (r.xy[k][0] - m[0]) * n[0] + (r.xy[k][1] - m[1]) * n[1];
                        (lo.min(d), hi.max(d))
                    })
                } else {
                    let h = mean.half_width[k];
                    let w = n[0].abs() * h[0] + n[1].abs() * h[1];
                    (-w, w)
                }
            })
            .collect();
        let (upper, lower) = band_borders(&mean.mean, &normal, &off);
        bands.push(Band::between(band_label.clone(), &upper, &lower, blue));
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
        if several && aligned {
            let m: Vec<(f64, f64)> = t.clone().zip(&mean.mean).map(|(t, p)| (t, p[c])).collect();
            let (up, lo): (Border, Border) = t
                .enumerate()
                .map(|(k, t)| {
                    let (lo, hi) = if envelope {
                        runs.iter()
                            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
                                (lo.min(r.xy[k][c]), hi.max(r.xy[k][c]))
                            })
                    } else {
                        let (m, h) = (mean.mean[k][c], mean.half_width[k][c]);
                        (m - h, m + h)
                    };
                    ((t, hi), (t, lo))
                })
                .unzip();
            let label = if envelope {
                "min/max of the runs"
            } else {
                "95 % band"
            };
            bands.push(Band::between(label, &up, &lo, blue));
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
