//! `--figure-format svg|png|pdf` of `simulate`, `evaluate` and `reproduce`: the figure is written as
//! `figure.<format>` in that format (checked by the file's magic bytes, not its name), the
//! default stays `figure.svg`, and a bad value is refused naming the flag.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use predicates::prelude::*;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

/// The repository's examples directory (plans and tracked runs).
fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn simulate(out: &Path, format: Option<&str>) -> assert_cmd::assert::Assert {
    let plan = examples().join("plans/circle-sphere.csv");
    let mut c = omnikin();
    c.args(["simulate", plan.to_str().unwrap(), "--robot", "sphere-omni"])
        .args(["--trials", "2", "--out", out.to_str().unwrap()]);
    if let Some(f) = format {
        c.args(["--figure-format", f]);
    }
    c.assert()
}

/// The first bytes of `path`.
fn head(path: &Path, n: usize) -> Vec<u8> {
    let b = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    b[..n.min(b.len())].to_vec()
}

const PNG_MAGIC: &[u8] = b"\x89PNG\r\n\x1a\n";

#[test]
fn simulate_writes_a_png_figure_when_asked() {
    let d = TestDir::new("figure-format", "sim-png");
    let out = d.join("out");
    simulate(&out, Some("png"))
        .success()
        .stderr(predicate::str::contains("figure.png"));
    assert_eq!(head(&out.join("figure.png"), 8), PNG_MAGIC);
    assert!(!out.join("figure.svg").exists(), "only the asked format");
}

#[test]
fn simulate_writes_a_pdf_figure_when_asked() {
    let d = TestDir::new("figure-format", "sim-pdf");
    let out = d.join("out");
    simulate(&out, Some("pdf")).success();
    assert_eq!(head(&out.join("figure.pdf"), 5), b"%PDF-");
}

#[test]
fn simulate_default_figure_stays_svg() {
    let d = TestDir::new("figure-format", "sim-default");
    let out = d.join("out");
    simulate(&out, None).success();
    let svg = std::fs::read_to_string(out.join("figure.svg")).unwrap();
    assert!(
        svg.trim_start().starts_with("<svg"),
        "{}",
        &svg[..svg.len().min(80)]
    );
}

#[test]
fn evaluate_writes_a_pdf_figure_when_asked() {
    let d = TestDir::new("figure-format", "eval-pdf");
    let out = d.join("out");
    let ex = examples();
    omnikin()
        .args(["evaluate", "--plan"])
        .arg(ex.join("plans/circle-sphere.csv"))
        .arg(ex.join("tracked/run1.csv"))
        .arg(ex.join("tracked/run2.csv"))
        .args(["--figure-format", "pdf", "--out"])
        .arg(&out)
        .assert()
        .success();
    assert_eq!(head(&out.join("figure.pdf"), 5), b"%PDF-");
}

#[test]
fn a_bad_figure_format_is_refused_naming_the_flag() {
    let d = TestDir::new("figure-format", "bad");
    let out = d.join("out");
    simulate(&out, Some("jpg"))
        .failure()
        .stderr(predicate::str::contains("--figure-format").and(predicate::str::contains("jpg")));
    assert!(
        !out.exists(),
        "nothing written before the arguments are checked"
    );
}

#[test]
fn reproduce_writes_png_figures_when_asked() {
    let d = TestDir::new("figure-format", "reproduce-png");
    let out = d.join("out");
    omnikin()
        .args([
            "reproduce",
            "sphere-2019",
            "--trials",
            "1",
            "--profiles",
            "hardware",
        ])
        .args(["--figure-format", "png", "--out"])
        .arg(&out)
        .assert()
        .success();
    let figures: Vec<PathBuf> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "png" || e == "svg"))
        .collect();
    assert!(!figures.is_empty(), "no figures in {}", out.display());
    for f in &figures {
        assert_eq!(f.extension().unwrap(), "png", "{}", f.display());
        assert_eq!(head(f, 8), PNG_MAGIC, "{}", f.display());
    }
}

#[test]
fn merge_writes_the_figure_in_the_asked_format() {
    let d = TestDir::new("figure-format", "merge-pdf");
    let plan = examples().join("plans/circle-sphere.csv");
    let shards: Vec<PathBuf> = (1..=2).map(|k| d.join(format!("shard-{k}"))).collect();
    for (k, dir) in shards.iter().enumerate() {
        omnikin()
            .args(["simulate", plan.to_str().unwrap(), "--robot", "sphere-omni"])
            .args(["--trials", "2", "--shard", &format!("{}/2", k + 1), "--out"])
            .arg(dir)
            .assert()
            .success();
    }
    let out = d.join("merged");
    omnikin()
        .arg("merge")
        .args(&shards)
        .args(["--figure-format", "pdf", "--out"])
        .arg(&out)
        .assert()
        .success();
    assert_eq!(head(&out.join("figure.pdf"), 5), b"%PDF-");
    assert!(!out.join("figure.svg").exists(), "only the asked format");
}
