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

/// Data drawn with sub-pixel coordinates. plotters maps every data point to whole pixels
/// (`BackendCoord` is `(i32, i32)`), which draws a 0.2 m circle as a staircase; so while
/// [`svg_file`] draws a figure, the panels compute the pixel position of each point in `f64`
/// themselves and collect the lines, bands and arrows here as SVG elements (clipped to their
/// panel), which [`svg_file`] appends to the document. Outside [`svg_file`] (no collector) the
/// panels draw through plotters as before.
mod overlay {
    use std::cell::RefCell;
    use std::fmt::Write;

    thread_local! {
        static ELEMENTS: RefCell<Option<Vec<String>>> = const { RefCell::new(None) };
    }

    /// Starts collecting (a figure begins).
    pub fn start() {
        ELEMENTS.with(|e| *e.borrow_mut() = Some(Vec::new()));
    }

    /// Stops collecting and returns what was collected.
    pub fn finish() -> Vec<String> {
        ELEMENTS.with(|e| e.borrow_mut().take()).unwrap_or_default()
    }

    /// Whether a figure is collecting.
    pub fn active() -> bool {
        ELEMENTS.with(|e| e.borrow().is_some())
    }

    /// Adds one element.
    pub fn push(element: String) {
        ELEMENTS.with(|e| {
            if let Some(v) = e.borrow_mut().as_mut() {
                v.push(element);
            }
        });
    }

    /// A clip path for a panel's plotting area (pixels); returns its id.
    pub fn clip(x: f64, y: f64, w: f64, h: f64) -> String {
        let id = ELEMENTS.with(|e| e.borrow().as_ref().map_or(0, Vec::len));
        let id = format!("omnikin-clip-{id}");
        push(format!(
            r#"<clipPath id="{id}"><rect x="{x}" y="{y}" width="{w}" height="{h}"/></clipPath>"#
        ));
        id
    }

    /// `x,y x,y …` with two decimals (a hundredth of a pixel).
    pub fn points(p: &[(f64, f64)]) -> String {
        let mut s = String::with_capacity(p.len() * 16);
        for (i, (x, y)) in p.iter().enumerate() {
            let _ = write!(s, "{}{x:.2},{y:.2}", if i == 0 { "" } else { " " });
        }
        s
    }
}

/// `#rrggbb` of a colour.
fn hex(c: RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
}

/// Maps data coordinates of a chart to `f64` pixels, exactly where plotters puts the ends of
/// both axes (it floors each point to a whole pixel in between).
struct PixelMap {
    x: (f64, f64, f64, f64),
    y: (f64, f64, f64, f64),
    clip: String,
}

impl PixelMap {
    fn new(chart: &Chart<'_, '_>, (x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> Self {
        let (a, b) = (
            chart.backend_coord(&(x0, y0)),
            chart.backend_coord(&(x1, y1)),
        );
        let (px0, px1, py0, py1) = (a.0 as f64, b.0 as f64, a.1 as f64, b.1 as f64);
        let clip = overlay::clip(
            px0.min(px1),
            py0.min(py1),
            (px1 - px0).abs(),
            (py1 - py0).abs(),
        );
        Self {
            x: (x0, x1, px0, px1),
            y: (y0, y1, py0, py1),
            clip,
        }
    }

    fn map(&self, p: (f64, f64)) -> (f64, f64) {
        let f = |v: f64, (a, b, pa, pb): (f64, f64, f64, f64)| pa + (v - a) / (b - a) * (pb - pa);
        (f(p.0, self.x), f(p.1, self.y))
    }

    fn line(&self, points: &[(f64, f64)], color: RGBColor, width: f64, dashed: bool) {
        let px: Vec<(f64, f64)> = points.iter().map(|&p| self.map(p)).collect();
        if px.len() < 2 {
            return;
        }
        overlay::push(format!(
            r#"<polyline fill="none" stroke="{}" stroke-width="{width}" stroke-linejoin="round" stroke-linecap="round"{} clip-path="url(#{})" points="{}"/>"#,
            hex(color),
            if dashed {
                r#" stroke-dasharray="8 5""#
            } else {
                ""
            },
            self.clip,
            overlay::points(&px)
        ));
    }

    fn dots(&self, points: &[(f64, f64)], color: RGBColor) {
        let mut d = String::new();
        for &p in points {
            let (x, y) = self.map(p);
            d.push_str(&format!(
                "M{:.2},{:.2}m-3,0a3,3 0 1,0 6,0a3,3 0 1,0 -6,0",
                x, y
            ));
        }
        overlay::push(format!(
            r#"<path fill="{}" stroke="none" clip-path="url(#{})" d="{d}"/>"#,
            hex(color),
            self.clip
        ));
    }

    fn polygon(&self, points: &[(f64, f64)], color: RGBColor) {
        let px: Vec<(f64, f64)> = points.iter().map(|&p| self.map(p)).collect();
        if px.len() < 3 {
            return;
        }
        overlay::push(format!(
            r#"<polygon fill="{}" fill-opacity="0.25" stroke="none" clip-path="url(#{})" points="{}"/>"#,
            hex(color),
            self.clip,
            overlay::points(&px)
        ));
    }
}

/// One legend entry: a line sample (solid or dashed) or a filled box (a band).
struct LegendEntry {
    label: String,
    color: RGBColor,
    kind: LegendKind,
}

#[derive(Clone, Copy, PartialEq)]
enum LegendKind {
    Solid,
    Dashed,
    Dots,
    Fill,
}

/// Height of one legend row, px; entries are laid out left to right and wrap.
const LEGEND_ROW: u32 = 20;

/// Approximate width of a legend entry, px (sample, gap, text at 14 px).
fn legend_width(e: &LegendEntry) -> u32 {
    26 + (e.label.chars().count() as u32) * 15 / 2 + 18
}

fn legend_rows(entries: &[LegendEntry], width: u32) -> u32 {
    let (mut rows, mut x) = (0, u32::MAX);
    for e in entries {
        let w = legend_width(e);
        if x.saturating_add(w) > width {
            rows += 1;
            x = 0;
        }
        x += w;
    }
    rows
}

/// Splits `area` into the panel and a legend strip under it (outside the data area), sized for
/// `entries`.
fn split_legend<'a>(area: &Area<'a>, entries: &[LegendEntry]) -> (Area<'a>, Option<Area<'a>>) {
    let (w, h) = area.dim_in_pixel();
    let rows = legend_rows(entries, w.saturating_sub(70));
    if rows == 0 || h < 200 {
        return (area.clone(), None);
    }
    let strip = rows * LEGEND_ROW + 8;
    let (top, bottom) = area.split_vertically(h - strip);
    (top, Some(bottom))
}

fn draw_legend(area: &Area, entries: &[LegendEntry]) -> Result<()> {
    let (w, _) = area.dim_in_pixel();
    let (mut x, mut y) = (i32::MAX, -(LEGEND_ROW as i32) + 2);
    let left = 60;
    for e in entries {
        let ew = legend_width(e) as i32;
        if x.saturating_add(ew) > w as i32 - 10 {
            x = left;
            y += LEGEND_ROW as i32;
        }
        let cy = y + LEGEND_ROW as i32 / 2;
        match e.kind {
            LegendKind::Fill => area
                .draw(&Rectangle::new(
                    [(x, cy - 6), (x + 20, cy + 6)],
                    e.color.mix(0.25).filled(),
                ))
                .map_err(draw_err)?,
            LegendKind::Solid => area
                .draw(&PathElement::new(
                    vec![(x, cy), (x + 20, cy)],
                    e.color.stroke_width(2),
                ))
                .map_err(draw_err)?,
            LegendKind::Dots => {
                for k in 0..2 {
                    area.draw(&Circle::new((x + 4 + k * 12, cy), 3, e.color.filled()))
                        .map_err(draw_err)?;
                }
            }
            LegendKind::Dashed => {
                for k in 0..2 {
                    area.draw(&PathElement::new(
                        vec![(x + k * 12, cy), (x + k * 12 + 7, cy)],
                        e.color.stroke_width(2),
                    ))
                    .map_err(draw_err)?;
                }
            }
        }
        area.draw(&Text::new(
            svg_text(&e.label),
            (x + 26, cy - 7),
            (FONT, 14).into_font(),
        ))
        .map_err(draw_err)?;
        x += ew;
    }
    Ok(())
}

fn legend_of(series: &[Series], bands: &[Band]) -> Vec<LegendEntry> {
    let mut v: Vec<LegendEntry> = series
        .iter()
        .filter(|s| !s.label.is_empty())
        .map(|s| LegendEntry {
            label: s.label.clone(),
            color: s.color,
            kind: if s.markers {
                LegendKind::Dots
            } else if s.dashed {
                LegendKind::Dashed
            } else {
                LegendKind::Solid
            },
        })
        .collect();
    v.extend(
        bands
            .iter()
            .filter(|b| !b.label.is_empty())
            .map(|b| LegendEntry {
                label: b.label.clone(),
                color: b.color,
                kind: LegendKind::Fill,
            }),
    );
    v
}

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
    /// Points as dots, not joined (e.g. camera fixes, where a line would join an outlier to
    /// its neighbours).
    pub markers: bool,
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
            markers: false,
        }
    }

    /// Unjoined dots of 3 px radius.
    pub fn markers(label: impl Into<String>, points: Vec<(f64, f64)>, color: RGBColor) -> Self {
        Self {
            markers: true,
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

/// Most points drawn per polyline or band outline. A panel is ~700 px wide, so more points add
/// nothing visible and only grow the SVG: a plan of 10⁷ samples drew four 10⁷-point lines (a
/// 500 MB file and ~1.5 GB of memory). Longer lines are thinned to this many by [`decimate`];
/// 3 000 drew visible chords on a run of many laps, 10 000 does not.
pub const MAX_FIGURE_POINTS: usize = 10_000;

/// `points` thinned to at most [`MAX_FIGURE_POINTS`], in order, keeping the shape: the points
/// are cut into consecutive chunks, and each chunk keeps its first and last point and its
/// extremes in x and in y (so spikes and the outline stay where they are). O(n). Shorter lines
/// are returned as they are. [`Decimator`] does the same one point at a time.
pub fn decimate(points: &[(f64, f64)]) -> std::borrow::Cow<'_, [(f64, f64)]> {
    if points.len() <= MAX_FIGURE_POINTS {
        return std::borrow::Cow::Borrowed(points);
    }
    let mut d = Decimator::new(points.len());
    for &p in points {
        d.push(p);
    }
    std::borrow::Cow::Owned(d.finish())
}

/// [`decimate`] of a line whose points come one at a time (a log too long to hold), given
/// their number `n` up front: it keeps the same points, holding one chunk (at most
/// `n / 1 666 + 1` points) and the result (at most [`MAX_FIGURE_POINTS`]). Points beyond `n`
/// are thinned in further chunks of the same size; a line of at most [`MAX_FIGURE_POINTS`] is
/// kept whole.
#[derive(Clone, Debug)]
pub struct Decimator {
    /// Points per chunk (`usize::MAX`: keep every point).
    chunk: usize,
    part: Vec<(f64, f64)>,
    out: Vec<(f64, f64)>,
}

impl Decimator {
    /// A decimator for a line of `n` points. With `n` ≤ [`MAX_FIGURE_POINTS`] (0 when the
    /// number is not known) every point is kept, for [`decimate`] to thin when drawn.
    pub fn new(n: usize) -> Self {
        let chunk = if n <= MAX_FIGURE_POINTS {
            usize::MAX
        } else {
            n.div_ceil(MAX_FIGURE_POINTS / 6)
        };
        Self {
            chunk,
            part: Vec::new(),
            out: Vec::new(),
        }
    }

    /// Takes the next point of the line.
    pub fn push(&mut self, p: (f64, f64)) {
        if self.chunk == usize::MAX {
            self.out.push(p);
            return;
        }
        self.part.push(p);
        if self.part.len() == self.chunk {
            keep_extremes(&self.part, &mut self.out);
            self.part.clear();
        }
    }

    /// The thinned line.
    pub fn finish(mut self) -> Vec<(f64, f64)> {
        if !self.part.is_empty() {
            keep_extremes(&self.part, &mut self.out);
        }
        self.out
    }
}

/// Appends to `out` the first and last points of `part` and its extremes in x and y, in order
/// and once each.
fn keep_extremes(part: &[(f64, f64)], out: &mut Vec<(f64, f64)>) {
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
            out.push(part[i]);
            last = i;
        }
    }
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
            if s.markers {
                m.dots(&points, s.color);
            } else {
                m.line(&points, s.color, s.width as f64, s.dashed);
            }
            continue;
        }
        let style = s.color.stroke_width(s.width);
        if s.markers {
            chart
                .draw_series(
                    points
                        .into_iter()
                        .map(|p| Circle::new(p, 3, s.color.filled())),
                )
                .map_err(draw_err)?;
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
    chart
        .configure_mesh()
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
    chart
        .configure_mesh()
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
