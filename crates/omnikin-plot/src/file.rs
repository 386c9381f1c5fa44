//! Figure files: a figure is drawn once, as SVG, and written in the format its file name's
//! extension asks for — `.svg` as drawn, `.png` rasterised by `resvg`, `.pdf` converted by
//! `svg2pdf` (vector, fonts embedded). Both read the SVG with one embedded font, DejaVu Sans
//! (its licence, which allows embedding and redistribution, is next to it in `assets/fonts/`),
//! so no system font is looked up and a figure looks the same on every machine. Any other
//! extension is an error naming the accepted ones, found before anything runs
//! ([`FigureFormat::of`]).
//!
//! Why convert the SVG rather than draw with plotters' bitmap backend: the panels draw their
//! data with sub-pixel coordinates as SVG elements (`overlay`), which the bitmap backend has no
//! way to take; converting keeps one drawing, so the three formats show the same figure.

use std::path::Path;
use std::sync::{Arc, OnceLock};

use anyhow::{Result, anyhow, bail};

/// The font every PNG and PDF figure is set in (DejaVu Sans 2.37, Bitstream Vera licence
/// with the DejaVu changes in the public domain: `assets/fonts/DejaVuSans-LICENSE.txt`).
const FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

/// The font family name inside [`FONT`], which the SVG's generic `sans-serif` maps to.
const FONT_FAMILY: &str = "DejaVu Sans";

/// Pixels of a PNG per SVG pixel: 2, so that a 1400 × 700 figure is a 2800 × 1400 image
/// (sharp in a paper or on a high-density screen).
pub const PNG_SCALE: f32 = 2.0;

/// Pixels per inch of an SVG's user units (CSS pixels), which sets a PDF page's size.
pub const CSS_DPI: f32 = 96.0;

/// The file format of a figure, chosen by the file name's extension (`--plot`) or, for the
/// commands that name their figures themselves (`simulate`, `evaluate`), by
/// `--figure-format svg|png|pdf` (a `clap` value with the `clap` feature).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum FigureFormat {
    /// `.svg`: the drawing itself (vector, text as text, sans-serif).
    Svg,
    /// `.png`: the drawing rasterised at [`PNG_SCALE`] pixels per SVG pixel, 8-bit RGBA.
    Png,
    /// `.pdf`: the drawing as a one-page vector PDF with the font embedded (subset), the page
    /// the SVG's size at [`CSS_DPI`].
    Pdf,
}

impl FigureFormat {
    /// The extensions accepted, as the error message lists them.
    pub const ACCEPTED: &'static str = ".svg, .png or .pdf";

    /// The file extension of the format, without the dot (`svg`, `png`, `pdf`).
    pub fn extension(self) -> &'static str {
        match self {
            Self::Svg => "svg",
            Self::Png => "png",
            Self::Pdf => "pdf",
        }
    }

    /// The file name `stem.<extension>` (e.g. `figure.png`).
    pub fn file_name(self, stem: &str) -> String {
        format!("{stem}.{}", self.extension())
    }

    /// The format of the figure file `path` (named by `flag` in the message) from its
    /// extension, in any case (`.PNG` too); an unknown or missing extension is an error that
    /// names the file, the extension and the accepted ones.
    pub fn of(flag: &str, path: &Path) -> Result<Self> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_lowercase());
        match ext.as_deref() {
            Some("svg") => Ok(Self::Svg),
            Some("png") => Ok(Self::Png),
            Some("pdf") => Ok(Self::Pdf),
            Some(other) => bail!(
                "{flag} {}: unknown figure format \".{other}\"; the extension chooses the \
                 format: {}",
                path.display(),
                Self::ACCEPTED
            ),
            None => bail!(
                "{flag} {}: no file extension; the extension chooses the figure format: {}",
                path.display(),
                Self::ACCEPTED
            ),
        }
    }
}

/// The bytes of the figure `svg` in `format`.
pub fn encode(svg: &str, format: FigureFormat) -> Result<Vec<u8>> {
    match format {
        FigureFormat::Svg => Ok(svg.as_bytes().to_vec()),
        FigureFormat::Png => png(svg),
        FigureFormat::Pdf => pdf(svg),
    }
}

/// The SVG read into a tree with the embedded font (loaded once) as its only font.
fn tree(svg: &str, what: &str) -> Result<svg2pdf::usvg::Tree> {
    use svg2pdf::usvg;
    static FONTS: OnceLock<Arc<usvg::fontdb::Database>> = OnceLock::new();
    let fonts = FONTS.get_or_init(|| {
        let mut db = usvg::fontdb::Database::new();
        db.load_font_data(FONT.to_vec());
        db.set_sans_serif_family(FONT_FAMILY);
        Arc::new(db)
    });
    let opt = usvg::Options {
        font_family: FONT_FAMILY.to_string(),
        fontdb: fonts.clone(),
        ..usvg::Options::default()
    };
    usvg::Tree::from_str(svg, &opt).map_err(|e| anyhow!("{what}: reading the SVG drawing: {e}"))
}

fn png(svg: &str) -> Result<Vec<u8>> {
    use resvg::tiny_skia;
    let tree = tree(svg, "PNG")?;
    let size = tree
        .size()
        .to_int_size()
        .scale_by(PNG_SCALE)
        .ok_or_else(|| anyhow!("PNG: the figure has no size"))?;
    let mut pixmap = tiny_skia::Pixmap::new(size.width(), size.height())
        .ok_or_else(|| anyhow!("PNG: cannot allocate {size:?} pixels"))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        tiny_skia::Transform::from_scale(PNG_SCALE, PNG_SCALE),
        &mut pixmap.as_mut(),
    );
    pixmap
        .encode_png()
        .map_err(|e| anyhow!("PNG: encoding failed: {e}"))
}

fn pdf(svg: &str) -> Result<Vec<u8>> {
    // The page has the size the SVG has on screen: CSS pixels are 1/96 inch (svg2pdf's default
    // of 72 would make a pixel a point, a 1400 px figure 49 cm wide).
    svg2pdf::to_pdf(
        &tree(svg, "PDF")?,
        svg2pdf::ConversionOptions::default(),
        svg2pdf::PageOptions { dpi: CSS_DPI },
    )
    .map_err(|e| anyhow!("PDF: conversion failed: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    const SVG: &str = r##"<svg xmlns="http://www.w3.org/2000/svg" width="200" height="100" viewBox="0 0 200 100"><rect width="200" height="100" fill="#FFFFFF"/><polyline fill="none" stroke="#1F77B4" stroke-width="2" points="10.5,90.25 190.75,10.5"/><text x="20" y="50" font-family="sans-serif" font-size="14">x [m] −0.5</text></svg>"##;

    #[test]
    fn the_extension_chooses_the_format() {
        for (name, f) in [
            ("a.svg", FigureFormat::Svg),
            ("out/b.png", FigureFormat::Png),
            ("C.PDF", FigureFormat::Pdf),
        ] {
            assert_eq!(FigureFormat::of("--plot", Path::new(name)).unwrap(), f);
        }
        let e = FigureFormat::of("--plot", Path::new("out/sq.jpg")).unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains("--plot out/sq.jpg") && m.contains("\".jpg\""),
            "{m}"
        );
        assert!(m.contains(".svg, .png or .pdf"), "{m}");
        let m = FigureFormat::of("--plot", Path::new("figure"))
            .unwrap_err()
            .to_string();
        assert!(m.contains("no file extension"), "{m}");
    }

    #[test]
    fn png_is_a_png_of_twice_the_size_with_the_text_drawn() {
        let bytes = encode(SVG, FigureFormat::Png).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        // IHDR: width and height, big-endian, at bytes 16..24.
        let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
        let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
        assert_eq!((w, h), (400, 200));
        // The text is drawn with the embedded font: the same SVG without its text encodes to
        // a different image.
        let no_text = SVG.replace("x [m] −0.5", "");
        assert_ne!(encode(&no_text, FigureFormat::Png).unwrap(), bytes);
    }

    #[test]
    fn pdf_is_a_pdf_with_the_font_embedded() {
        let bytes = encode(SVG, FigureFormat::Pdf).unwrap();
        assert!(bytes.starts_with(b"%PDF-1."), "{:?}", &bytes[..8]);
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.trim_end().ends_with("%%EOF"));
        assert!(text.contains("/FontFile2"), "the font is embedded");
        assert!(text.contains("DejaVuSans"), "the font is DejaVu Sans");
    }
}
