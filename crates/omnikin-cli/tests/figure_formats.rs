//! Figure files: the extension of `--plot` chooses SVG, PNG or PDF (the bytes are that format,
//! not SVG under another name), an unknown extension fails before anything is written, an
//! existing figure is not replaced without `--force`, and tick labels are clean (no `-0.0`).

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::Path;
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_omnikin");

/// `omnikin plan circle` on the sphere with `--out OUT --plot PLOT` (and `extra` flags first).
fn plan_circle(extra: &[&str], out: &Path, plot: &Path) -> Output {
    Command::new(BIN)
        .args(extra)
        .args([
            "plan",
            "circle",
            "--robot",
            "sphere-omni",
            "--radius",
            "0.2",
        ])
        .args(["--omega", "0.5", "--out"])
        .arg(out)
        .arg("--plot")
        .arg(plot)
        .output()
        .unwrap()
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The plan figure is drawn 1300 × 640 (plan/figure.rs); a PNG has twice the pixels each way.
const FIGURE_SIZE: (u32, u32) = (1300, 640);

#[test]
fn png_by_extension_is_a_png_at_twice_the_figure_size() {
    let d = TestDir::new("figure-formats", "png");
    let plot = d.join("circle.png");
    ok(&plan_circle(&[], &d.join("c.csv"), &plot));
    let bytes = std::fs::read(&plot).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    assert_eq!(&bytes[12..16], b"IHDR");
    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    assert_eq!((w, h), (2 * FIGURE_SIZE.0, 2 * FIGURE_SIZE.1));
    // Upper case works too.
    let upper = d.join("CIRCLE.PNG");
    ok(&plan_circle(&[], &d.join("c2.csv"), &upper));
    assert_eq!(&std::fs::read(&upper).unwrap()[..4], b"\x89PNG");
}

#[test]
fn pdf_by_extension_is_a_pdf_with_its_font_embedded() {
    let d = TestDir::new("figure-formats", "pdf");
    let plot = d.join("circle.pdf");
    ok(&plan_circle(&[], &d.join("c.csv"), &plot));
    let bytes = std::fs::read(&plot).unwrap();
    assert!(bytes.starts_with(b"%PDF-1."), "PDF header");
    let text = String::from_utf8_lossy(&bytes);
    assert!(text.trim_end().ends_with("%%EOF"), "PDF trailer");
    assert!(text.contains("/FontFile2"), "font embedded");
    // One page the size the SVG has on screen: CSS pixels are 1/96 inch, PDF points 1/72.
    let mediabox: Vec<f64> = text
        .split("/MediaBox [")
        .nth(1)
        .expect("a /MediaBox")
        .split(']')
        .next()
        .unwrap()
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    let points = |px: u32| f64::from(px) * 72.0 / 96.0;
    assert_eq!(
        mediabox,
        [0.0, 0.0, points(FIGURE_SIZE.0), points(FIGURE_SIZE.1)]
    );
}

#[test]
fn svg_stays_svg() {
    let d = TestDir::new("figure-formats", "svg");
    let plot = d.join("circle.svg");
    ok(&plan_circle(&[], &d.join("c.csv"), &plot));
    let text = std::fs::read_to_string(&plot).unwrap();
    assert!(text.starts_with("<svg "), "{}", &text[..40]);
}

#[test]
fn an_unknown_extension_fails_first_naming_the_accepted_ones() {
    let d = TestDir::new("figure-formats", "jpg");
    let (out, plot) = (d.join("c.csv"), d.join("circle.jpg"));
    let o = plan_circle(&[], &out, &plot);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--plot") && err.contains("\".jpg\""), "{err}");
    assert!(err.contains(".svg, .png or .pdf"), "{err}");
    // Found before the plan is written: nothing is left behind.
    assert!(!out.exists() && !plot.exists());
    assert_eq!(std::fs::read_dir(&*d).unwrap().count(), 0);
}

#[test]
fn an_existing_figure_is_replaced_only_with_force() {
    let d = TestDir::new("figure-formats", "force");
    let plot = d.join("circle.png");
    std::fs::write(&plot, b"earlier figure").unwrap();
    let o = plan_circle(&[], &d.join("c.csv"), &plot);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--force"), "{err}");
    assert_eq!(std::fs::read(&plot).unwrap(), b"earlier figure");
    ok(&plan_circle(&["--force"], &d.join("c.csv"), &plot));
    assert_eq!(&std::fs::read(&plot).unwrap()[..4], b"\x89PNG");
}

/// The text of every `<text>` element of an SVG written by plotters (the text on its own line).
fn labels(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let body = t.split_once('>')?.1;
            Some(body.split("</text>").next()?.trim().to_string())
        })
        .collect()
}

#[test]
fn tick_labels_have_no_negative_zero_and_one_precision_per_axis() {
    let d = TestDir::new("figure-formats", "ticks");
    let plot = d.join("circle.svg");
    ok(&plan_circle(&[], &d.join("c.csv"), &plot));
    let labels = labels(&std::fs::read_to_string(&plot).unwrap());
    let numbers: Vec<&String> = labels.iter().filter(|l| l.parse::<f64>().is_ok()).collect();
    assert!(numbers.len() > 20, "{labels:?}");
    for l in &numbers {
        let v: f64 = l.parse().unwrap();
        assert!(
            !(v == 0.0 && l.starts_with('-')),
            "tick label {l:?} (all labels: {labels:?})"
        );
        assert!(l.len() <= 8, "tick label {l:?} is not rounded");
    }
    // The circle's x axis runs from about -0.25 to 0.25 in steps of 0.05 (two decimals each):
    // "0.00" and "0.10", not "0.0" and "0.1" beside "0.05".
    assert!(numbers.iter().any(|l| *l == "0.05"), "{labels:?}");
    assert!(numbers.iter().any(|l| *l == "0.10"), "{labels:?}");
}
