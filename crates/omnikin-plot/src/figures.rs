//! Trajectory figures in the Sphere paper's style: theoretical path dashed, mean path solid, and two
//! bands named for what they are — the **runs' 95 % spread** (where 95 % of runs fall: the
//! prediction interval mean ± t·s·√(1 + 1/n)) and the **95 % confidence interval of the mean**
//! (mean ± t·s/√n, √(n + 1) times narrower); with fewer than [`MIN_RUNS_FOR_CI`] runs, their
//! min/max envelope instead, and the legend says which. Beside the path: the deviation from the
//! plan in x and y over time, and the distance |position − plan| over time, in mm, so that a
//! 1 cm error fills a panel instead of a pixel. A tracked run's emergency stops (its `mode`
//! column) are marked: a cross on the path where the robot was, a dashed line at the instant in
//! every time panel.

use std::path::Path;

use anyhow::Result;
use omnikin_plan::Plan;
use omnikin_sim::metrics::{MeanTrajectory, Run};
use omnikin_sim::track::EStopMark;
use plotters::prelude::*;

use crate::{
    Arrow, Band, Marker, PALETTE, Series, TimeAxis, TimeMark, draw_err, time_panel_on, xy_panel,
};

/// Colour of the emergency-stop marks.
const ESTOP_RED: RGBColor = RGBColor(200, 30, 30);

const RUN_GREY: RGBColor = RGBColor(185, 185, 185);

/// Colour of the runs' spread band (the confidence interval of the mean is drawn in the mean's
/// blue).
const SPREAD: RGBColor = PALETTE[1];

/// Millimetres per metre (the time panels are in mm).
const MM: f64 = 1000.0;

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

/// A band drawn around the mean: what it is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum BandKind {
    /// Where 95 % of runs fall: mean ± t·s·√(1 + 1/n) (the prediction interval).
    Spread,
    /// The 95 % confidence interval of the mean: mean ± t·s/√n.
    MeanCi,
    /// Fewer than [`MIN_RUNS_FOR_CI`] runs: their min/max.
    Envelope,
}

/// The bands of the runs around their mean at each plan sample.
struct Bands<'a> {
    runs: &'a [Run],
    mean: &'a MeanTrajectory,
    /// Runs behind `mean` (at least `runs.len()`: a large simulation draws its first runs).
    n_runs: usize,
}

impl Bands<'_> {
    /// The bands to draw, widest first, with their legend text and colour.
    fn layers(&self) -> Vec<(BandKind, String, RGBColor)> {
        if self.n_runs < MIN_RUNS_FOR_CI {
            return vec![(
                BandKind::Envelope,
                format!(
                    "min/max of the {} runs (fewer than {MIN_RUNS_FOR_CI}: too few for a 95 % band)",
                    self.n_runs
                ),
                PALETTE[0],
            )];
        }
        vec![
            (
                BandKind::Spread,
                "runs' 95 % spread (prediction interval)".to_string(),
                SPREAD,
            ),
            (
                BandKind::MeanCi,
                "95 % confidence interval of the mean".to_string(),
                PALETTE[0],
            ),
        ]
    }

    /// The band's offsets `(lo, hi)` from the mean at sample `k` along the unit direction `n`
    /// (a path's normal, or a coordinate axis), m. The statistical half-widths are per
    /// coordinate, so across a path the band is `|n_x| h_x + |n_y| h_y` (conservative); the
    /// spread follows from the confidence half-width `h = t·s/√n` as `h·√(n + 1)`.
    fn offset(&self, kind: BandKind, k: usize, n: [f64; 2]) -> (f64, f64) {
        let h = self.mean.half_width[k];
        let across = |scale: f64| {
            let w = scale * (n[0].abs() * h[0] + n[1].abs() * h[1]);
            (-w, w)
        };
        match kind {
            BandKind::MeanCi => across(1.0),
            BandKind::Spread => across(((self.n_runs + 1) as f64).sqrt()),
            BandKind::Envelope => {
                let m = self.mean.mean[k];
                self.runs.iter().fold((0.0_f64, 0.0_f64), |(lo, hi), r| {
                    let d = (r.xy[k][0] - m[0]) * n[0] + (r.xy[k][1] - m[1]) * n[1];
                    (lo.min(d), hi.max(d))
                })
            }
        }
    }
}

/// Draws the trajectory figure of `runs` (those drawn) and `mean` (over `n_runs` runs, at
/// least as many): the XY path (runs faint, plan dashed, mean solid, bands shaded, an arrow at
/// the start), the deviation from the plan in x and in y against time, and the distance from
/// the plan against time.
pub fn trajectory_figure(
    flag: &str,
    path: &Path,
    title: &str,
    plan: &Plan,
    runs: &[Run],
    mean: &MeanTrajectory,
    n_runs: usize,
) -> Result<()> {
    trajectory_figure_with_stops(flag, path, title, plan, runs, mean, n_runs, &[])
}

/// [`trajectory_figure`] with the runs' emergency stops marked (on the plan's clock and frame,
/// [`omnikin_sim::track::Track::estops_on`]): a red cross on the path, a dashed red line in
/// each time panel, "e-stop" in the legends.
#[allow(clippy::too_many_arguments)]
pub fn trajectory_figure_with_stops(
    flag: &str,
    path: &Path,
    title: &str,
    plan: &Plan,
    runs: &[Run],
    mean: &MeanTrajectory,
    n_runs: usize,
    estops: &[EStopMark],
) -> Result<()> {
    crate::svg_file(flag, path, (1400, 960), |root| {
        draw_trajectories(
            root,
            title,
            plan,
            runs,
            mean,
            n_runs.max(runs.len()),
            estops,
        )
    })
}

fn draw_trajectories(
    root: &crate::Area,
    title: &str,
    plan: &Plan,
    runs: &[Run],
    mean: &MeanTrajectory,
    n_runs: usize,
    estops: &[EStopMark],
) -> Result<()> {
    root.fill(&WHITE).map_err(draw_err)?;
    let root = root
        .titled(&crate::svg_text(title), ("sans-serif", 22))
        .map_err(draw_err)?;
    let (left, right) = root.split_horizontally(700);
    let blue = PALETTE[0];
    let several = runs.len() >= 2;
    let plan_xy: Vec<(f64, f64)> = plan.samples.iter().map(|s| (s.pose.x, s.pose.y)).collect();
    let ts: Vec<f64> = plan.samples.iter().map(|s| s.t).collect();
    // Runs on the plan's time grid (one position per plan sample) can be compared with it.
    let on_grid: Vec<&Run> = runs.iter().filter(|r| r.xy.len() == ts.len()).collect();
    let aligned = mean.mean.len() == ts.len() && on_grid.len() == runs.len();
    let with_mean = several && aligned;

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
    let stats = Bands { runs, mean, n_runs };
    let layers = if with_mean {
        stats.layers()
    } else {
        Vec::new()
    };
    let mut bands = Vec::new();
    if with_mean {
        series.push(Series::solid(
            "mean of runs",
            mean.mean.iter().map(|p| (p[0], p[1])).collect(),
            blue,
        ));
        let normal = normals(&plan_xy);
        for (kind, label, colour) in &layers {
            let off: Vec<(f64, f64)> = (0..mean.mean.len())
                .map(|k| stats.offset(*kind, k, normal[k]))
                .collect();
            let (upper, lower) = band_borders(&mean.mean, &normal, &off);
            bands.push(Band::between(label.clone(), &upper, &lower, *colour));
        }
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
    if !estops.is_empty() {
        series.push(Series::marks(
            "e-stop",
            estops.iter().map(|m| (m.xy[0], m.xy[1])).collect(),
            ESTOP_RED,
            Marker::Cross,
        ));
    }
    let axis = TimeAxis {
        range: None,
        marks: estops
            .iter()
            .enumerate()
            .map(|(i, m)| TimeMark {
                t: m.t,
                label: if i == 0 {
                    "e-stop".into()
                } else {
                    String::new()
                },
                color: ESTOP_RED,
            })
            .collect(),
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

    let panels = right.split_evenly((3, 1));
    for (c, name) in ["x", "y"].into_iter().enumerate() {
        let planned = |k: usize| if c == 0 { plan_xy[k].0 } else { plan_xy[k].1 };
        let mut series = Vec::new();
        let mut bands = Vec::new();
        if with_mean {
            for (i, r) in on_grid.iter().enumerate() {
                series.push(Series {
                    width: 1,
                    ..Series::solid(
                        if i == 0 { "individual runs" } else { "" },
                        ts.iter()
                            .enumerate()
                            .map(|(k, t)| (*t, MM * (r.xy[k][c] - planned(k))))
                            .collect(),
                        RUN_GREY,
                    )
                });
            }
            let axis = if c == 0 { [1.0, 0.0] } else { [0.0, 1.0] };
            for (kind, label, colour) in &layers {
                let (up, lo): (Border, Border) = ts
                    .iter()
                    .enumerate()
                    .map(|(k, t)| {
                        let m = MM * (mean.mean[k][c] - planned(k));
                        let (lo, hi) = stats.offset(*kind, k, axis);
                        ((*t, m + MM * hi), (*t, m + MM * lo))
                    })
                    .unzip();
                bands.push(Band::between(label.clone(), &up, &lo, *colour));
            }
            series.push(Series::solid(
                "mean",
                ts.iter()
                    .enumerate()
                    .map(|(k, t)| (*t, MM * (mean.mean[k][c] - planned(k))))
                    .collect(),
                blue,
            ));
        } else if let Some(r) = on_grid.first() {
            series.push(Series::solid(
                "run",
                ts.iter()
                    .enumerate()
                    .map(|(k, t)| (*t, MM * (r.xy[k][c] - planned(k))))
                    .collect(),
                blue,
            ));
        }
        if let (Some(t0), Some(t1)) = (ts.first(), ts.last()) {
            series.push(Series {
                width: 1,
                ..Series::dashed("plan", vec![(*t0, 0.0), (*t1, 0.0)], BLACK)
            });
        }
        time_panel_on(
            &panels[c],
            &format!("deviation from the plan in {name}: {name}(t) − {name}_plan(t)"),
            &format!("{name} − {name}_plan [mm]"),
            &series,
            &bands,
            None,
            &axis,
        )?;
    }
    // |position − plan| against time: every run, and their mean distance.
    let mut series: Vec<Series> = on_grid
        .iter()
        .enumerate()
        .map(|(i, r)| Series {
            width: 1,
            ..Series::solid(
                match (i, several) {
                    (0, true) => "individual runs",
                    (0, false) => "run",
                    _ => "",
                },
                distance(&ts, &plan_xy, &r.xy),
                if several { RUN_GREY } else { blue },
            )
        })
        .collect();
    if several && !on_grid.is_empty() {
        let mean_distance: Vec<(f64, f64)> = (0..ts.len())
            .map(|k| {
                let sum: f64 = on_grid
                    .iter()
                    .map(|r| (r.xy[k][0] - plan_xy[k].0).hypot(r.xy[k][1] - plan_xy[k].1))
                    .sum();
                (ts[k], MM * sum / on_grid.len() as f64)
            })
            .collect();
        series.push(Series::solid("mean over the runs", mean_distance, blue));
    }
    time_panel_on(
        &panels[2],
        "error against time: |position − plan| at the same time",
        "|position − plan| [mm]",
        &series,
        &[],
        None,
        &axis,
    )
}

/// `(t, |p − plan| in mm)` at each plan sample.
fn distance(ts: &[f64], plan_xy: &[(f64, f64)], xy: &[[f64; 2]]) -> Vec<(f64, f64)> {
    ts.iter()
        .zip(plan_xy)
        .zip(xy)
        .map(|((t, q), p)| (*t, MM * (p[0] - q.0).hypot(p[1] - q.1)))
        .collect()
}

/// The simulation report's figures ([`omnikin_io::sim_output`]) in this format, drawn by
/// [`trajectory_figure`] (errors name `--out`).
impl omnikin_io::sim_output::RunFigures for crate::FigureFormat {
    fn file_name(&self, stem: &str) -> String {
        crate::FigureFormat::file_name(*self, stem)
    }

    fn draw(
        &self,
        path: &Path,
        title: &str,
        plan: &Plan,
        runs: &[Run],
        mean: &MeanTrajectory,
        n_runs: usize,
    ) -> Result<()> {
        trajectory_figure("--out", path, title, plan, runs, mean, n_runs)
    }
}
