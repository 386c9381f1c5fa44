//! omnikin's figures, for every front end: the trajectory figures of plans, simulations and
//! evaluations in the Sphere paper's style ([`figures`]), a plan's path, wheel and steer rates
//! ([`plan`]), the odometry's path and heading ([`odometry`]), the identification residuals
//! ([`identify`]), and the drawing helpers beneath them.
//!
//! The helpers (pure Rust, `plotters` SVG backend, no system fonts, the DejaVu Sans of
//! `assets/fonts/` embedded): an XY
//! panel with equal axis scales that draws several paths solid or dashed, shaded bands
//! (filled polygons, e.g. a confidence band) and direction arrows; and a time-series panel.
//! Axes carry labels with units and clean ticks (`ticks`), every series a legend entry
//! (`legend`); long lines are thinned (`decimate`), data drawn with sub-pixel coordinates
//! (`overlay`), and [`svg_file`] writes the figure as SVG, PNG or PDF (`file`).

use anyhow::{Context, Result, anyhow};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

mod decimate;
pub mod figures;
mod file;
pub mod identify;
mod legend;
pub mod odometry;
mod overlay;
pub mod plan;
pub mod ticks;

pub use decimate::{Decimator, decimate};
pub use file::FigureFormat;
use legend::{draw_legend, legend_of, split_legend};
use overlay::PixelMap;

/// The drawing area type of the helpers (an SVG file or part of one).
pub type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// Colours for series 1, 2, 3, … (matplotlib's "tab10").
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

/// Text for an SVG figure: the backend escapes `<`, `>`, `&` and quotes, but control
/// characters are not allowed in XML at all (not even as character references), so each one
/// becomes U+FFFD. Robot names are validated on load; this also covers file names and other
/// text that reaches a title.
pub fn svg_text(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_control() { '\u{fffd}' } else { c })
        .collect()
}

/// Font of titles, axis labels and legends.
const FONT: &str = "sans-serif";

/// A drawing error as an `anyhow` error.
pub fn draw_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("drawing the figure failed: {e}")
}

/// One polyline to draw: `(x, y)` points in data units.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text (empty: no legend entry).
    pub label: String,
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// Line colour.
    pub color: RGBColor,
    /// Dashed instead of solid.
    pub dashed: bool,
    /// Line width, px.
    pub width: u32,
    /// Points as marks, not joined (e.g. camera fixes, where a line would join an outlier to
    /// its neighbours); `None`: a line.
    pub marker: Option<Marker>,
}

/// The mark drawn at each point of a [`Series`] of unjoined points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    /// A filled dot, 3 px radius.
    Dot,
    /// A diagonal cross, 8 px (e.g. a rejected measurement).
    Cross,
    /// A hollow ring, 3 px radius (e.g. a measurement that was never used).
    Ring,
}

impl Series {
    /// A solid 2 px line.
    pub fn solid(label: impl Into<String>, points: Vec<(f64, f64)>, color: RGBColor) -> Self {
        Self {
            label: label.into(),
            points,
            color,
            dashed: false,
            width: 2,
            marker: None,
        }
    }

    /// Unjoined marks of the kind `marker`.
    pub fn marks(
        label: impl Into<String>,
        points: Vec<(f64, f64)>,
        color: RGBColor,
        marker: Marker,
    ) -> Self {
        Self {
            marker: Some(marker),
            ..Self::solid(label, points, color)
        }
    }

    /// A dashed 2 px line.
    pub fn dashed(label: impl Into<String>, points: Vec<(f64, f64)>, color: RGBColor) -> Self {
        Self {
            dashed: true,
            ..Self::solid(label, points, color)
        }
    }
}

/// A filled polygon (e.g. a 95 % confidence band around a mean path), drawn translucent under
/// the lines.
#[derive(Clone, Debug)]
pub struct Band {
    /// Legend text (empty: none).
    pub label: String,
    /// Closed outline in data units (the last point joins the first).
    pub polygon: Vec<(f64, f64)>,
    /// Fill colour (drawn at 25 % opacity).
    pub color: RGBColor,
}

impl Band {
    /// The band between two curves: `upper` forwards, then `lower` backwards (e.g. `mean ± h`
    /// in a time series, or the left and right borders of a path band).
    pub fn between(
        label: impl Into<String>,
        upper: &[(f64, f64)],
        lower: &[(f64, f64)],
        color: RGBColor,
    ) -> Self {
        let mut polygon = upper.to_vec();
        polygon.extend(lower.iter().rev());
        Self {
            label: label.into(),
            polygon,
            color,
        }
    }
}

/// A direction arrow at `at` pointing along `dir` (any length; drawn `size` data units long).
#[derive(Clone, Copy, Debug)]
pub struct Arrow {
    /// Position of the arrow's middle, data units.
    pub at: (f64, f64),
    /// Direction (need not be unit).
    pub dir: (f64, f64),
    /// Colour.
    pub color: RGBColor,
}

/// The largest |value| a figure draws. Beyond it an axis cannot be stepped through at f64
/// resolution (plotters' tick loop would not advance, or the span overflows to infinity), so
/// such data is an error naming the panel, not a hang or a panic.
pub const MAX_AXIS: f64 = 1e12;

/// `(lo, hi)` covering all finite `values`, padded by `pad` of the span on each side and at
/// least `min_span` wide (and at least 1e-9 of the largest |value|, so the ticks can advance).
/// Non-finite values are left out (and not drawn); no finite value gives `(-1, 1)`. Values
/// beyond ±[`MAX_AXIS`] are an error naming `what` (the panel and axis).
pub fn range(
    values: impl Iterator<Item = f64>,
    pad: f64,
    min_span: f64,
    what: &str,
) -> Result<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return Ok((-1.0, 1.0));
    }
    let big = lo.abs().max(hi.abs());
    if big > MAX_AXIS {
        return Err(anyhow!(
            "cannot draw the figure: {what} reaches {big:e}, beyond the ±{MAX_AXIS:e} a figure can show (check the inputs for an absurd value or a wrong unit)"
        ));
    }
    let span = (hi - lo).max(min_span).max(big * 1e-9);
    let mid = 0.5 * (lo + hi);
    let half = 0.5 * span * (1.0 + 2.0 * pad);
    Ok((mid - half, mid + half))
}

/// The finite points of `points` (a NaN or infinite point is not drawn).
fn finite_points(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    points
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect()
}

/// The chart type of the panels.
type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws `series` on `chart`: with sub-pixel coordinates through `map` inside [`svg_file`],
/// through plotters otherwise.
fn draw_lines<'a>(
    chart: &mut Chart<'a, 'a>,
    map: Option<&PixelMap>,
    series: &[Series],
) -> Result<()> {
    for s in series {
        let points = finite_points(&decimate(&s.points));
        if let Some(m) = map {
            if let Some(marker) = s.marker {
                m.marks(&points, s.color, marker);
            } else {
                m.line(&points, s.color, s.width as f64, s.dashed);
            }
            continue;
        }
        let style = s.color.stroke_width(s.width);
        if let Some(marker) = s.marker {
            for p in points {
                match marker {
                    Marker::Dot => {
                        chart.draw_series(std::iter::once(Circle::new(p, 3, s.color.filled())))
                    }
                    Marker::Ring => chart.draw_series(std::iter::once(Circle::new(
                        p,
                        3,
                        s.color.stroke_width(1),
                    ))),
                    Marker::Cross => chart.draw_series(std::iter::once(Cross::new(
                        p,
                        4,
                        s.color.stroke_width(2),
                    ))),
                }
                .map_err(draw_err)?;
            }
        } else if s.dashed {
            chart
                .draw_series(DashedLineSeries::new(points, 8, 5, style))
                .map_err(draw_err)?;
        } else {
            chart
                .draw_series(LineSeries::new(points, style))
                .map_err(draw_err)?;
        }
    }
    Ok(())
}

fn draw_bands<'a>(chart: &mut Chart<'a, 'a>, map: Option<&PixelMap>, bands: &[Band]) -> Result<()> {
    for b in bands {
        let points = finite_points(&decimate(&b.polygon));
        if let Some(m) = map {
            m.polygon(&points, b.color);
        } else {
            chart
                .draw_series(std::iter::once(Polygon::new(
                    points,
                    b.color.mix(0.25).filled(),
                )))
                .map_err(draw_err)?;
        }
    }
    Ok(())
}

/// Draws an XY panel with **equal scales** on both axes (a circle looks round): `bands`
/// first, then `series` (solid or dashed), then `arrows`; axis labels `x_label`, `y_label`
/// (with units), a title, and a legend under the plotting area (never over the data).
pub fn xy_panel(
    area: &Area,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    bands: &[Band],
    arrows: &[Arrow],
) -> Result<()> {
    let entries = legend_of(series, bands);
    let (area, legend) = split_legend(area, &entries);
    let xs = series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let xb = bands.iter().flat_map(|b| b.polygon.iter().map(|p| p.0));
    let (mut x0, mut x1) = range(xs.chain(xb), 0.08, 1e-3, &format!("panel \"{title}\", x"))?;
    let ys = series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let yb = bands.iter().flat_map(|b| b.polygon.iter().map(|p| p.1));
    let (mut y0, mut y1) = range(ys.chain(yb), 0.08, 1e-3, &format!("panel \"{title}\", y"))?;
    // Plot area in pixels (the area minus label space), then widen one range to equal scales.
    let (w, h) = area.dim_in_pixel();
    let (pw, ph) = ((w as f64 - 95.0).max(10.0), (h as f64 - 95.0).max(10.0));
    let (sx, sy) = ((x1 - x0) / pw, (y1 - y0) / ph);
    if sx > sy {
        let extra = (sx * ph - (y1 - y0)) / 2.0;
        y0 -= extra;
        y1 += extra;
    } else {
        let extra = (sy * pw - (x1 - x0)) / 2.0;
        x0 -= extra;
        x1 += extra;
    }
    let mut chart = ChartBuilder::on(&area)
        .caption(svg_text(title), (FONT, 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(draw_err)?;
    let (fx, fy) = (ticks::formatter(x0, x1), ticks::formatter(y0, y1));
    chart
        .configure_mesh()
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .x_desc(svg_text(x_label))
        .y_desc(svg_text(y_label))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(draw_err)?;
    let map = overlay::active().then(|| PixelMap::new(&chart, (x0, x1), (y0, y1)));
    draw_bands(&mut chart, map.as_ref(), bands)?;
    draw_lines(&mut chart, map.as_ref(), series)?;
    // Arrows: a shaft and two barbs, sized in data units (the scales are equal).
    let size = 0.045 * (x1 - x0).min(y1 - y0);
    for a in arrows {
        let n = a.dir.0.hypot(a.dir.1);
        if n.is_nan() || n <= 0.0 {
            continue;
        }
        let (ux, uy) = (a.dir.0 / n, a.dir.1 / n);
        let tip = (a.at.0 + 0.5 * size * ux, a.at.1 + 0.5 * size * uy);
        let tail = (a.at.0 - 0.5 * size * ux, a.at.1 - 0.5 * size * uy);
        let barb = |sign: f64| {
            let (c, s) = (0.5_f64.cos(), sign * 0.5_f64.sin());
            let (bx, by) = (-(ux * c - uy * s), -(ux * s + uy * c));
            (tip.0 + 0.5 * size * bx, tip.1 + 0.5 * size * by)
        };
        let parts = [
            Series::solid("", vec![tail, tip], a.color),
            Series::solid("", vec![barb(1.0), tip, barb(-1.0)], a.color),
        ];
        draw_lines(&mut chart, map.as_ref(), &parts)?;
    }
    if let Some(l) = legend {
        draw_legend(&l, &entries)?;
    }
    Ok(())
}

/// Draws a time-series panel: `series` against time (s) with the y label `y_label` (with
/// units), optional `bands` underneath and dashed horizontal `limits` lines (e.g. `±max_rate`,
/// labelled once), a title and a legend under the plotting area.
pub fn time_panel(
    area: &Area,
    title: &str,
    y_label: &str,
    series: &[Series],
    bands: &[Band],
    limits: Option<(f64, &str)>,
) -> Result<()> {
    time_panel_on(
        area,
        title,
        y_label,
        series,
        bands,
        limits,
        &TimeAxis::default(),
    )
}

/// An instant marked on a time panel (a push, an e-stop, an event's start): a vertical dashed
/// line across the panel, with `label` in the legend.
#[derive(Clone, Debug)]
pub struct TimeMark {
    /// When, s (on the panel's time axis).
    pub t: f64,
    /// Legend text (empty: none; several marks may share one entry).
    pub label: String,
    /// Colour.
    pub color: RGBColor,
}

/// The time axis of a panel: its range (`None`: the data's), so that the panels of one figure
/// share one axis, and the instants to mark on it.
#[derive(Clone, Debug, Default)]
pub struct TimeAxis {
    /// `(first, last)` time shown, s.
    pub range: Option<(f64, f64)>,
    /// Instants marked.
    pub marks: Vec<TimeMark>,
}

/// [`time_panel`] on the time axis `axis` (a given range, marked instants).
pub fn time_panel_on(
    area: &Area,
    title: &str,
    y_label: &str,
    series: &[Series],
    bands: &[Band],
    limits: Option<(f64, &str)>,
    axis: &TimeAxis,
) -> Result<()> {
    let ts = series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let (t0, t1) = match axis.range {
        Some((a, b)) => range(
            [a, b].into_iter(),
            0.0,
            1e-6,
            &format!("panel \"{title}\", time"),
        )?,
        None => range(ts, 0.0, 1e-6, &format!("panel \"{title}\", time"))?,
    };
    let mut ys: Vec<f64> = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .collect();
    ys.extend(bands.iter().flat_map(|b| b.polygon.iter().map(|p| p.1)));
    if let Some((l, _)) = limits {
        ys.extend([l, -l]);
    }
    let (y0, y1) = range(
        ys.into_iter(),
        0.08,
        1e-6,
        &format!("panel \"{title}\", {y_label}"),
    )?;
    let mut lines = Vec::new();
    if let Some((l, label)) = limits {
        lines = vec![
            Series::dashed(label, vec![(t0, l), (t1, l)], BLACK),
            Series::dashed("", vec![(t0, -l), (t1, -l)], BLACK),
        ];
        for s in &mut lines {
            s.width = 1;
        }
    }
    for k in axis.marks.iter().filter(|k| k.t >= t0 && k.t <= t1) {
        lines.push(Series {
            width: 1,
            ..Series::dashed(k.label.clone(), vec![(k.t, y0), (k.t, y1)], k.color)
        });
    }
    let mut entries = legend_of(series, bands);
    entries.extend(legend_of(&lines, &[]));
    let (area, legend) = split_legend(area, &entries);
    let mut chart = ChartBuilder::on(&area)
        .caption(svg_text(title), (FONT, 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(t0..t1, y0..y1)
        .map_err(draw_err)?;
    let (fx, fy) = (ticks::formatter(t0, t1), ticks::formatter(y0, y1));
    chart
        .configure_mesh()
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .x_desc("time t [s]")
        .y_desc(svg_text(y_label))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(draw_err)?;
    let map = overlay::active().then(|| PixelMap::new(&chart, (t0, t1), (y0, y1)));
    draw_bands(&mut chart, map.as_ref(), bands)?;
    draw_lines(&mut chart, map.as_ref(), &lines)?;
    draw_lines(&mut chart, map.as_ref(), series)?;
    if let Some(l) = legend {
        draw_legend(&l, &entries)?;
    }
    Ok(())
}

/// Draws an SVG figure of `size` pixels in memory with `draw`, then writes it as the output
/// `path` (named by `flag` in messages) in the format its extension chooses
/// ([`FigureFormat::of`]: SVG, PNG or PDF) under the output rules (temporary file, rename; see
/// [`omnikin_io::output`]). A figure that cannot be drawn or encoded leaves no file behind.
pub fn svg_file(
    flag: &str,
    path: &std::path::Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Result<()>,
) -> Result<()> {
    let format = FigureFormat::of(flag, path)?;
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        overlay::start();
        let drawn = draw(&root).with_context(|| format!("{flag} {}", path.display()));
        let extra = overlay::finish();
        drawn?;
        root.present().map_err(draw_err)?;
        drop(root);
        // The sub-pixel data elements go last (on top of the axes; the legends are outside
        // the plotting areas, so nothing of them is covered).
        if let Some(end) = text.rfind("</svg>") {
            text.insert_str(end, &(extra.join("\n") + "\n"));
        }
    }
    // Text in a figure comes from files (a robot's name): a control character would make the
    // SVG invalid XML (plotters escapes only <, > and &), so it is shown as U+FFFD.
    let text: String = text
        .chars()
        .map(|c| {
            if c.is_control() && !matches!(c, '\t' | '\n' | '\r') {
                '\u{FFFD}'
            } else {
                c
            }
        })
        .collect();
    let bytes =
        file::encode(&text, format).with_context(|| format!("{flag} {}", path.display()))?;
    omnikin_io::output::write_file(flag, path, |w| std::io::Write::write_all(w, &bytes))
}
