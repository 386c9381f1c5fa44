//! Reusable SVG drawing helpers (pure Rust, `plotters` SVG backend, no system fonts): an XY
//! panel with equal axis scales that draws several paths solid or dashed, shaded bands
//! (filled polygons, e.g. a confidence band) and direction arrows; and a time-series panel.
//! Axes carry labels with units, every series a legend entry.

use anyhow::{Context, Result, anyhow};
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

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

/// Most points drawn per polyline or band outline. A panel is ~700 px wide, so more points add
/// nothing visible and only grow the SVG: a plan of 10⁷ samples drew four 10⁷-point lines (a
/// 500 MB file and ~1.5 GB of memory). Longer lines are thinned to this many by [`decimate`];
/// 3 000 drew visible chords on a run of many laps, 10 000 does not.
pub const MAX_FIGURE_POINTS: usize = 10_000;

/// `points` thinned to at most [`MAX_FIGURE_POINTS`], in order, keeping the shape: the points
/// are cut into consecutive chunks, and each chunk keeps its first and last point and its
/// extremes in x and in y (so spikes and the outline stay where they are). O(n). Shorter lines
/// are returned as they are.
pub fn decimate(points: &[(f64, f64)]) -> std::borrow::Cow<'_, [(f64, f64)]> {
    let n = points.len();
    if n <= MAX_FIGURE_POINTS {
        return std::borrow::Cow::Borrowed(points);
    }
    let chunk = n.div_ceil(MAX_FIGURE_POINTS / 6);
    let mut out = Vec::with_capacity(MAX_FIGURE_POINTS);
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
    std::borrow::Cow::Owned(out)
}

/// The chart type of the panels.
type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

fn draw_lines<'a>(chart: &mut Chart<'a, 'a>, series: &[Series]) -> Result<()> {
    for s in series {
        let style = s.color.stroke_width(s.width);
        let color = s.color;
        let anno = if s.dashed {
            chart
                .draw_series(DashedLineSeries::new(
                    finite_points(&decimate(&s.points)),
                    8,
                    5,
                    style,
                ))
                .map_err(draw_err)?
        } else {
            chart
                .draw_series(LineSeries::new(finite_points(&decimate(&s.points)), style))
                .map_err(draw_err)?
        };
        if !s.label.is_empty() {
            let dashed = s.dashed;
            anno.label(svg_text(&s.label)).legend(move |(x, y)| {
                if dashed {
                    PathElement::new(vec![(x, y), (x + 7, y)], color.stroke_width(2)).into_dyn()
                } else {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)).into_dyn()
                }
            });
        }
    }
    Ok(())
}

/// Draws an XY panel with **equal scales** on both axes (a circle looks round): `bands`
/// first, then `series` (solid or dashed), then `arrows`; axis labels `x_label`, `y_label`
/// (with units), a title, and a legend.
pub fn xy_panel(
    area: &Area,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    bands: &[Band],
    arrows: &[Arrow],
) -> Result<()> {
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
    let mut chart = ChartBuilder::on(area)
        .caption(svg_text(title), (FONT, 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc(svg_text(x_label))
        .y_desc(svg_text(y_label))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(draw_err)?;
    for b in bands {
        let color = b.color;
        let anno = chart
            .draw_series(std::iter::once(Polygon::new(
                finite_points(&decimate(&b.polygon)),
                color.mix(0.25).filled(),
            )))
            .map_err(draw_err)?;
        if !b.label.is_empty() {
            anno.label(svg_text(&b.label)).legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 18, y + 5)], color.mix(0.25).filled())
            });
        }
    }
    draw_lines(&mut chart, series)?;
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
        let style = a.color.stroke_width(2);
        chart
            .draw_series([
                PathElement::new(vec![tail, tip], style),
                PathElement::new(vec![barb(1.0), tip, barb(-1.0)], style),
            ])
            .map_err(draw_err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.5))
        .draw()
        .map_err(draw_err)?;
    Ok(())
}

/// Draws a time-series panel: `series` against time (s) with the y label `y_label` (with
/// units), optional `bands` underneath and dashed horizontal `limits` lines (e.g. `±max_rate`,
/// labelled once), a title and a legend.
pub fn time_panel(
    area: &Area,
    title: &str,
    y_label: &str,
    series: &[Series],
    bands: &[Band],
    limits: Option<(f64, &str)>,
) -> Result<()> {
    let ts = series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let (t0, t1) = range(ts, 0.0, 1e-6, &format!("panel \"{title}\", time"))?;
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
    let mut chart = ChartBuilder::on(area)
        .caption(svg_text(title), (FONT, 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(t0..t1, y0..y1)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("time t [s]")
        .y_desc(svg_text(y_label))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(draw_err)?;
    for b in bands {
        let color = b.color;
        let anno = chart
            .draw_series(std::iter::once(Polygon::new(
                finite_points(&decimate(&b.polygon)),
                color.mix(0.25).filled(),
            )))
            .map_err(draw_err)?;
        if !b.label.is_empty() {
            anno.label(svg_text(&b.label)).legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 18, y + 5)], color.mix(0.25).filled())
            });
        }
    }
    if let Some((l, label)) = limits {
        let mut lines = vec![
            Series::dashed(label, vec![(t0, l), (t1, l)], BLACK),
            Series::dashed("", vec![(t0, -l), (t1, -l)], BLACK),
        ];
        for s in &mut lines {
            s.width = 1;
        }
        draw_lines(&mut chart, &lines)?;
    }
    draw_lines(&mut chart, series)?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.5))
        .draw()
        .map_err(draw_err)?;
    Ok(())
}

/// Draws an SVG figure of `size` pixels in memory with `draw`, then writes it as the output
/// `path` (named by `flag` in messages) under the output rules (temporary file, rename; see
/// [`crate::output`]). A figure that cannot be drawn leaves no file behind.
pub fn svg_file(
    flag: &str,
    path: &std::path::Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Result<()>,
) -> Result<()> {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        draw(&root).with_context(|| format!("{flag} {}", path.display()))?;
        root.present().map_err(draw_err)?;
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
    crate::output::write_file(flag, path, |w| {
        std::io::Write::write_all(w, text.as_bytes())
    })
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
        let d = decimate(&pts);
        assert!(d.len() <= MAX_FIGURE_POINTS, "{}", d.len());
        assert_eq!(d.first(), pts.first());
        assert_eq!(d.last(), pts.last());
        assert!(d.contains(&(123.457, 5.0)) && d.contains(&(654.321, -7.0)));
        // In order: time never goes back.
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
        let short = &pts[..MAX_FIGURE_POINTS];
        assert_eq!(&*decimate(short), short);
    }
}
