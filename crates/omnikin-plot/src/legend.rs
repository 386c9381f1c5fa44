//! Legends: entries (a line sample, dots or a filled box, and the label) laid out left to
//! right in a strip under a panel, wrapping; never over the data.

use anyhow::Result;
use plotters::prelude::*;

use super::{Area, Band, FONT, Marker, Series, draw_err, svg_text};

/// One legend entry: a line sample (solid or dashed) or a filled box (a band).
pub(super) struct LegendEntry {
    label: String,
    color: RGBColor,
    kind: LegendKind,
}

#[derive(Clone, Copy, PartialEq)]
enum LegendKind {
    Solid,
    Dashed,
    Marks(Marker),
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
pub(super) fn split_legend<'a>(
    area: &Area<'a>,
    entries: &[LegendEntry],
) -> (Area<'a>, Option<Area<'a>>) {
    let (w, h) = area.dim_in_pixel();
    let rows = legend_rows(entries, w.saturating_sub(70));
    if rows == 0 || h < 200 {
        return (area.clone(), None);
    }
    let strip = rows * LEGEND_ROW + 8;
    let (top, bottom) = area.split_vertically(h - strip);
    (top, Some(bottom))
}

pub(super) fn draw_legend(area: &Area, entries: &[LegendEntry]) -> Result<()> {
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
            LegendKind::Marks(marker) => {
                for k in 0..2 {
                    let c = (x + 4 + k * 12, cy);
                    match marker {
                        Marker::Dot => area.draw(&Circle::new(c, 3, e.color.filled())),
                        Marker::Ring => area.draw(&Circle::new(c, 3, e.color.stroke_width(1))),
                        Marker::Cross => area.draw(&Cross::new(c, 4, e.color.stroke_width(2))),
                    }
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

pub(super) fn legend_of(series: &[Series], bands: &[Band]) -> Vec<LegendEntry> {
    let mut v: Vec<LegendEntry> = series
        .iter()
        .filter(|s| !s.label.is_empty())
        .map(|s| LegendEntry {
            label: s.label.clone(),
            color: s.color,
            kind: if let Some(m) = s.marker {
                LegendKind::Marks(m)
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
