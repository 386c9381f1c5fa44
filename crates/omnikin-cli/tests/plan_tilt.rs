//! `omnikin plan` on a sphere: the quasi-static platform tilt in the summary, the warning past
//! the robot file's `dynamics.max_tilt_deg`, and `--max-tilt`, which slows the plan.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use assert_cmd::Command;
use omnikin_plan::Plan;
use predicates::prelude::*;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

fn tmp(name: &str) -> TestDir {
    TestDir::new("plan-tilt", name)
}

fn circle(out: &std::path::Path, extra: &[&str]) -> String {
    let mut args = vec![
        "plan",
        "circle",
        "--robot",
        "sphere-omni",
        "--omega",
        "2.5",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let a = omnikin().args(&args).assert().success();
    String::from_utf8_lossy(&a.get_output().stderr).to_string()
}

#[test]
fn the_fast_circle_warns_and_max_tilt_slows_it() {
    let d = tmp("circle");
    // Quasi-static lean of a = v²/r = 1.25 m/s² with the preset's [dynamics], from the moment
    // balance about the floor contact: sin(θ + atan k)·√(1 + k²) = k (M R + I_s/R)/(m_p h),
    // k = a/g (10.68 deg with com_depth 0.0872 m), above its max_tilt_deg = 10.
    let p = omnikin_sim::dynamics::sphere::SphereDynamics::from_description(
        &omnikin::description::RobotDescription::preset("sphere-omni").unwrap(),
    )
    .unwrap();
    let k = 1.25 / p.gravity;
    let r = p.geometry.shell_radius;
    let rhs = k * (p.total_mass() * r + p.shell_inertia / r) / (p.platform_mass * p.com_depth);
    let lean = ((rhs / (1.0 + k * k).sqrt()).asin() - k.atan()).to_degrees();
    assert!(
        lean > 10.0,
        "the premise: the fast circle leans past 10 deg ({lean})"
    );
    let err = circle(&d.join("fast.csv"), &[]);
    assert!(
        err.contains(&format!(
            "largest platform tilt (quasi-static, [dynamics]) {lean:.2} deg"
        )),
        "{lean:.2}: {err}"
    );
    assert!(
        err.contains(&format!(
            "warning: the plan tilts the platform by {lean:.2} deg"
        )),
        "{err}"
    );
    let err = circle(&d.join("slow.csv"), &["--max-tilt", "8"]);
    assert!(
        err.contains("tilt-limited: move(s) 1..1 slowed to"),
        "{err}"
    );
    assert!(
        err.contains("largest platform tilt (quasi-static, [dynamics]) 8.00 deg"),
        "{err}"
    );
    assert!(!err.contains("warning: the plan tilts"), "{err}");
    let fast = Plan::load_csv(&d.join("fast.csv")).unwrap();
    let slow = Plan::load_csv(&d.join("slow.csv")).unwrap();
    // The same path, slower: same samples, longer duration, lower speed.
    assert_eq!(fast.samples.len(), slow.samples.len());
    let (tf, ts) = (
        fast.samples.last().unwrap().t,
        slow.samples.last().unwrap().t,
    );
    assert!(ts > 1.1 * tf, "{tf} -> {ts}");
    let speed = |p: &Plan| p.samples[10].twist.vx.hypot(p.samples[10].twist.vy);
    assert!((speed(&slow) / speed(&fast) - tf / ts).abs() < 1e-6);
}

#[test]
fn max_tilt_is_for_spheres_and_inside_its_range() {
    let d = tmp("bad");
    let out = d.join("p.csv");
    omnikin()
        .args([
            "plan",
            "circle",
            "--robot",
            "kiwi",
            "--omega",
            "1",
            "--max-tilt",
            "8",
        ])
        .args(["--out", out.to_str().unwrap()])
        .assert()
        .failure()
        .stderr(predicate::str::contains("only a sphere-omni robot"));
    omnikin()
        .args([
            "plan",
            "circle",
            "--robot",
            "sphere-omni",
            "--omega",
            "1",
            "--max-tilt",
            "95",
        ])
        .args(["--out", out.to_str().unwrap()])
        .assert()
        .failure()
        .stderr(predicate::str::contains("strictly between 0 and 90"));
}
