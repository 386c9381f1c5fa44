//! Data drawn with sub-pixel coordinates. plotters maps every data point to whole pixels
//! (`BackendCoord` is `(i32, i32)`), which draws a 0.2 m circle as a staircase; so while
//! [`super::svg_file`] draws a figure, the panels compute the pixel position of each point in
//! `f64` themselves ([`PixelMap`]) and collect the lines, bands and arrows here as SVG elements
//! (clipped to their panel), which [`super::svg_file`] appends to the document. Outside it (no
//! collector) the panels draw through plotters as before.

use std::cell::RefCell;
use std::fmt::Write;

use plotters::prelude::RGBColor;

use super::{Chart, Marker};

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
pub fn svg_points(p: &[(f64, f64)]) -> String {
    let mut s = String::with_capacity(p.len() * 16);
    for (i, (x, y)) in p.iter().enumerate() {
        let _ = write!(s, "{}{x:.2},{y:.2}", if i == 0 { "" } else { " " });
    }
    s
}

/// `#rrggbb` of a colour.
fn hex(c: RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
}

/// Maps data coordinates of a chart to `f64` pixels, exactly where plotters puts the ends of
/// both axes (it floors each point to a whole pixel in between).
pub(super) struct PixelMap {
    x: (f64, f64, f64, f64),
    y: (f64, f64, f64, f64),
    clip: String,
}

impl PixelMap {
    pub(super) fn new(chart: &Chart<'_, '_>, (x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> Self {
        let (a, b) = (
            chart.backend_coord(&(x0, y0)),
            chart.backend_coord(&(x1, y1)),
        );
        let (px0, px1, py0, py1) = (a.0 as f64, b.0 as f64, a.1 as f64, b.1 as f64);
        let clip = clip(
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

    pub(super) fn line(&self, points: &[(f64, f64)], color: RGBColor, width: f64, dashed: bool) {
        let px: Vec<(f64, f64)> = points.iter().map(|&p| self.map(p)).collect();
        if px.len() < 2 {
            return;
        }
        push(format!(
            r#"<polyline fill="none" stroke="{}" stroke-width="{width}" stroke-linejoin="round" stroke-linecap="round"{} clip-path="url(#{})" points="{}"/>"#,
            hex(color),
            if dashed {
                r#" stroke-dasharray="8 5""#
            } else {
                ""
            },
            self.clip,
            svg_points(&px)
        ));
    }

    /// Unjoined marks at `points`: filled dots, hollow rings or diagonal crosses.
    pub(super) fn marks(&self, points: &[(f64, f64)], color: RGBColor, marker: Marker) {
        let mut d = String::new();
        for &p in points {
            let (x, y) = self.map(p);
            let _ = match marker {
                Marker::Dot | Marker::Ring => {
                    write!(d, "M{x:.2},{y:.2}m-3,0a3,3 0 1,0 6,0a3,3 0 1,0 -6,0")
                }
                Marker::Cross => write!(d, "M{:.2},{:.2}l8,8m0,-8l-8,8", x - 4.0, y - 4.0),
            };
        }
        let paint = match marker {
            Marker::Dot => format!(r#"fill="{}" stroke="none""#, hex(color)),
            Marker::Ring => format!(r#"fill="none" stroke="{}" stroke-width="1.2""#, hex(color)),
            Marker::Cross => format!(r#"fill="none" stroke="{}" stroke-width="2""#, hex(color)),
        };
        push(format!(
            r#"<path {paint} clip-path="url(#{})" d="{d}"/>"#,
            self.clip
        ));
    }

    pub(super) fn polygon(&self, points: &[(f64, f64)], color: RGBColor) {
        let px: Vec<(f64, f64)> = points.iter().map(|&p| self.map(p)).collect();
        if px.len() < 3 {
            return;
        }
        push(format!(
            r#"<polygon fill="{}" fill-opacity="0.25" stroke="none" clip-path="url(#{})" points="{}"/>"#,
            hex(color),
            self.clip,
            svg_points(&px)
        ));
    }
}
