//! What the figures show: simulate's error-against-time panel and its two bands named for what
//! they are, odometry's rejected fixes drawn apart from the fused ones and the ground truth,
//! and the ballbot's tilt and distance panels on one time axis with the push marked.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::Path;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_omnikin");
const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

fn omnikin(args: &[&str]) -> String {
    let o = Command::new(BIN)
        .args(args)
        .current_dir(Path::new(ROOT).join("examples"))
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "omnikin {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// One `<text>` element of a plotters SVG: its `x`, `y` attributes and its text.
struct Label {
    y: f64,
    text: String,
}

fn labels(svg: &str) -> Vec<Label> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let (attrs, body) = t.split_once('>')?;
            let attr = |k: &str| -> Option<f64> {
                let i = attrs.find(&format!(" {k}=\""))? + k.len() + 3;
                attrs[i..].split('"').next()?.parse().ok()
            };
            Some(Label {
                y: attr("y")?,
                text: body
                    .split("</text>")
                    .next()?
                    .trim()
                    .replace("&apos;", "'")
                    .replace("&quot;", "\"")
                    .replace("&lt;", "<")
                    .replace("&gt;", ">")
                    .replace("&amp;", "&"),
            })
        })
        .collect()
}

/// The time-axis tick labels of the panel titled `title`: the numbers after its title (up to
/// the next title), in the row that holds most of them (the x axis is one row of labels; the
/// y axis's labels each have their own row).
fn time_ticks(labels: &[Label], title: &str, next_title: Option<&str>) -> Vec<String> {
    let start = labels
        .iter()
        .position(|l| l.text == title)
        .unwrap_or_else(|| panic!("no panel {title:?}"));
    let end = next_title
        .and_then(|n| labels.iter().position(|l| l.text == n))
        .unwrap_or(labels.len());
    let numbers: Vec<&Label> = labels[start..end]
        .iter()
        .filter(|l| l.text.parse::<f64>().is_ok())
        .collect();
    let row = numbers
        .iter()
        .map(|l| l.y)
        .max_by_key(|y| numbers.iter().filter(|l| l.y == *y).count())
        .expect("tick labels");
    numbers
        .iter()
        .filter(|l| l.y == row)
        .map(|l| l.text.clone())
        .collect()
}

#[test]
fn simulate_draws_the_error_against_time_and_names_both_bands() {
    let d = TestDir::new("figure-panels", "simulate");
    let out = d.join("sim");
    omnikin(&[
        "simulate",
        "plans/circle-sphere.csv",
        "--robot",
        "sphere-omni",
        "--disturbances",
        "profiles/noisy.toml",
        "--trials",
        "12",
        "--seed",
        "3",
        "--out",
        out.to_str().unwrap(),
    ]);
    let svg = std::fs::read_to_string(out.join("figure.svg")).unwrap();
    let text: Vec<String> = labels(&svg).into_iter().map(|l| l.text).collect();
    for want in [
        "error against time: |position − plan| at the same time",
        "|position − plan| [mm]",
        "x − x_plan [mm]",
        "y − y_plan [mm]",
        "runs' 95 % spread (prediction interval)",
        "95 % confidence interval of the mean",
    ] {
        assert!(text.iter().any(|t| t == want), "no {want:?} in {text:?}");
    }
    assert!(
        !text
            .iter()
            .any(|t| t == "95 % band of the mean" || t == "95 % band"),
        "an unnamed band: {text:?}"
    );
}

#[test]
fn odometry_draws_rejected_fixes_apart_and_the_truth() {
    let d = TestDir::new("figure-panels", "odometry");
    let (poses, plot) = (d.join("poses.csv"), d.join("odometry.svg"));
    let stderr = omnikin(&[
        "odometry",
        "--robot",
        "kiwi",
        "logs/kiwi-encoders.csv",
        "--fixes",
        "logs/kiwi-fixes.csv",
        "--initial-pose",
        "0,0,0",
        "--truth",
        "logs/kiwi-truth.csv",
        "--out",
        poses.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
    ]);
    let svg = std::fs::read_to_string(&plot).unwrap();
    let text: Vec<String> = labels(&svg).into_iter().map(|l| l.text).collect();
    assert!(text.iter().any(|t| t == "ground truth"), "{text:?}");
    assert!(text.iter().any(|t| t == "fixes fused"), "{text:?}");
    // The example's fixes include outliers (stderr says so); they get their own marks.
    let rejected = stderr.matches("rejected as an outlier").count();
    assert!(rejected > 0, "the example has no rejected fix: {stderr}");
    assert!(
        text.iter().any(|t| t == "fixes rejected (outliers)"),
        "{text:?}"
    );
    // One cross (two strokes) per rejected fix, drawn as one path of `l8,8m0,-8l-8,8` marks.
    assert_eq!(svg.matches("l8,8m0,-8l-8,8").count(), rejected);
}

#[test]
fn ballbot_panels_share_one_time_axis_and_mark_the_push() {
    let d = TestDir::new("figure-panels", "ballbot");
    let out = d.join("ballbot");
    omnikin(&[
        "simulate",
        "plans/square-ballbot.csv",
        "--robot",
        "ballbot",
        "--plant",
        "dynamic",
        "--push",
        "12@2.0",
        "--out",
        out.to_str().unwrap(),
    ]);
    let svg = std::fs::read_to_string(out.join("figure.svg")).unwrap();
    let l = labels(&svg);
    let tilt = time_ticks(
        &l,
        "body tilt (angle from the vertical)",
        Some("distance from the plan"),
    );
    let distance = time_ticks(&l, "distance from the plan", None);
    // Each panel used to take its data's range: the tilt from -1 s (the lead-in before the
    // plan), the distance from 0 s, with different ticks.
    assert_eq!(tilt, distance, "one time axis");
    assert!(l.iter().any(|l| l.text == "push (impulse)"));
    assert!(l.iter().any(|l| l.text == "pushed here"));
}
