//! Every figure kind (plan, simulate, evaluate, odometry, reproduce) drawn from the inputs of
//! `examples/`, rendered to PNG with `resvg` (a dev-dependency) and checked: the PNG has the
//! SVG's size, is not blank (enough non-white pixels, several colours), its data lines have
//! sub-pixel coordinates, and the legends sit outside the plotting areas. The PNGs are kept in
//! `target/figures-png/` to be looked at.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_omnikin");
const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

fn examples() -> PathBuf {
    Path::new(ROOT).join("examples")
}

fn out_dir() -> TestDir {
    TestDir::new("figures", "png")
}

fn omnikin(args: &[&str]) {
    let o = Command::new(BIN)
        .args(args)
        .current_dir(examples())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "omnikin {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Renders `svg` to a PNG in `target/figures-png/NAME.png`; returns (width, height, RGBA).
fn render(svg: &Path, name: &str) -> (u32, u32, Vec<u8>) {
    let text = std::fs::read_to_string(svg).unwrap();
    let mut opt = resvg::usvg::Options::default();
    opt.fontdb_mut().load_system_fonts();
    // The figures ask for the generic `sans-serif`; fontdb maps it to Arial, which a Linux
    // machine rarely has. DejaVu Sans is the usual one (no font: the text is not drawn, and
    // the checks below do not depend on it).
    opt.fontdb_mut().set_sans_serif_family("DejaVu Sans");
    let tree = resvg::usvg::Tree::from_str(&text, &opt).unwrap();
    let size = tree.size().to_int_size();
    let mut pixmap = resvg::tiny_skia::Pixmap::new(size.width(), size.height()).unwrap();
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::default(),
        &mut pixmap.as_mut(),
    );
    let dir = Path::new(ROOT).join("target/figures-png");
    std::fs::create_dir_all(&dir).unwrap();
    pixmap.save_png(dir.join(format!("{name}.png"))).unwrap();
    (size.width(), size.height(), pixmap.data().to_vec())
}

/// The width and height attributes of the SVG root.
fn svg_size(svg: &str) -> (u32, u32) {
    let attr = |name: &str| -> u32 {
        let i = svg.find(&format!("{name}=\"")).unwrap() + name.len() + 2;
        svg[i..].split('"').next().unwrap().parse().unwrap()
    };
    (attr("width"), attr("height"))
}

fn check(svg: &Path, name: &str) {
    let text = std::fs::read_to_string(svg).unwrap();
    let (w, h, rgba) = render(svg, name);
    assert_eq!((w, h), svg_size(&text), "{name}: PNG size");
    assert!(w >= 800 && h >= 500, "{name}: {w}x{h} is too small to read");
    let pixels = rgba.len() / 4;
    let ink = rgba
        .chunks(4)
        .filter(|p| p[3] > 0 && (p[0] < 235 || p[1] < 235 || p[2] < 235))
        .count();
    let share = ink as f64 / pixels as f64;
    assert!(
        (0.01..0.6).contains(&share),
        "{name}: {:.1} % of the pixels are drawn (blank or flooded)",
        100.0 * share
    );
    let mut colours: Vec<[u8; 3]> = rgba
        .chunks(4)
        .filter(|p| p[3] > 0)
        .map(|p| [p[0] >> 4, p[1] >> 4, p[2] >> 4])
        .collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() >= 8, "{name}: only {} colours", colours.len());
    // Data lines with sub-pixel coordinates (plotters alone puts every point on a whole pixel).
    let fractional = text
        .split("points=\"")
        .skip(1)
        .flat_map(|p| p.split('"').next().unwrap().split([' ', ',']))
        .filter(|v| v.parse::<f64>().is_ok_and(|v| v.fract() != 0.0))
        .count();
    assert!(fractional > 20, "{name}: data lines on whole pixels only");
    // Legends outside the data: no legend text inside a plotting area (clip rectangle).
    let clips: Vec<[f64; 4]> = text
        .split("<clipPath ")
        .skip(1)
        .map(|c| {
            let num = |k: &str| -> f64 {
                let i = c.find(&format!(" {k}=\"")).unwrap() + k.len() + 3;
                c[i..].split('"').next().unwrap().parse().unwrap()
            };
            [num("x"), num("y"), num("width"), num("height")]
        })
        .collect();
    assert!(!clips.is_empty(), "{name}: no plotting areas found");
    for t in text.split("<text ").skip(1) {
        let attr = |k: &str| -> Option<f64> {
            let i = t.find(&format!("{k}=\""))? + k.len() + 2;
            t[i..].split('"').next()?.parse().ok()
        };
        let (Some(x), Some(y)) = (attr("x"), attr("y")) else {
            continue;
        };
        let label = t
            .split('>')
            .nth(1)
            .unwrap_or("")
            .split('<')
            .next()
            .unwrap_or("");
        let legendish =
            label.contains("mean") || label.contains("planned") || label.contains("run");
        for c in &clips {
            let inside =
                x > c[0] + 2.0 && x < c[0] + c[2] - 2.0 && y > c[1] + 2.0 && y < c[1] + c[3] - 2.0;
            assert!(
                !(inside && legendish),
                "{name}: legend text {label:?} at ({x}, {y}) is inside a plotting area {c:?}"
            );
        }
    }
}

#[test]
fn every_figure_kind_renders_to_a_readable_png() {
    let d = out_dir();
    let p = |f: &str| d.join(f).to_str().unwrap().to_string();
    omnikin(&[
        "plan",
        "waypoints",
        "waypoints.csv",
        "--robot",
        "caster3",
        "--path",
        "spline",
        "--heading-law",
        "tangent",
        "--time-optimal",
        "--max-speed",
        "1",
        "--max-accel",
        "2",
        "--out",
        &p("tour.csv"),
        "--plot",
        &p("plan.svg"),
    ]);
    check(&d.join("plan.svg"), "plan");
    omnikin(&[
        "plan",
        "circle",
        "--robot",
        "sphere-omni",
        "--radius",
        "0.2",
        "--omega",
        "0.5",
        "--out",
        &p("circle.csv"),
        "--plot",
        &p("plan-circle.svg"),
    ]);
    check(&d.join("plan-circle.svg"), "plan-circle");
    omnikin(&[
        "simulate",
        "plans/circle-sphere.csv",
        "--robot",
        "sphere-omni",
        "--disturbances",
        "profiles/noisy.toml",
        "--trials",
        "20",
        "--seed",
        "1",
        "--out",
        &p("sim"),
    ]);
    check(&d.join("sim/figure.svg"), "simulate");
    omnikin(&[
        "evaluate",
        "--plan",
        "plans/circle-sphere.csv",
        "tracked/run1.csv",
        "tracked/run2.csv",
        "tracked/run3.csv",
        "--out",
        &p("eval"),
    ]);
    check(&d.join("eval/figure.svg"), "evaluate");
    let eval = std::fs::read_to_string(d.join("eval/figure.svg")).unwrap();
    assert!(
        eval.contains("too few for a 95 % band"),
        "three runs: the figure says it draws min/max"
    );
    omnikin(&[
        "odometry",
        "--robot",
        "kiwi",
        "logs/kiwi-encoders.csv",
        "--fixes",
        "logs/kiwi-fixes.csv",
        "--initial-pose",
        "0,0,0",
        "--out",
        &p("poses.csv"),
        "--plot",
        &p("odometry.svg"),
    ]);
    check(&d.join("odometry.svg"), "odometry");
    omnikin(&[
        "reproduce",
        "sphere-2019",
        "--profiles",
        "ideal,hardware",
        "--trials",
        "3",
        "--out",
        &p("reproduce"),
    ]);
    check(&d.join("reproduce/circle-0.4-hardware.svg"), "reproduce");
    let _ = std::fs::remove_dir_all(&d);
}
