//! `omnikin plan`: the paper's experiments from one command each, waypoint files, output
//! formats, figures, and errors that name the file, line, wheel and excess.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use assert_cmd::Command;
use omnikin::Twist2;
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin_plan::Plan;
use predicates::prelude::*;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

/// The output file `name` in a directory of its own, removed when the test passes.
fn tmp(name: &str) -> TestDir {
    TestDir::file("plan-cli", name)
}

/// Runs a plan command that writes CSV to stdout and reads the plan back.
fn plan_stdout(args: &[&str]) -> (Plan, String) {
    let out = omnikin().args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{args:?}: {stderr}");
    (Plan::read_csv(&out.stdout[..], "stdout").unwrap(), stderr)
}

fn peak_wheel_rate(p: &Plan) -> f64 {
    p.samples
        .iter()
        .flat_map(|s| s.wheel_rates)
        .fold(0.0, |a, w| a.max(w.abs()))
}

#[test]
fn paper_series_plan_from_one_command_each() {
    for (speed, omega) in [("0.1", "0.5"), ("0.2", "1"), ("0.4", "2"), ("0.5", "2.5")] {
        let (sq, err) = plan_stdout(&[
            "plan",
            "square",
            "--robot",
            "sphere-omni",
            "--side",
            "0.4",
            "--speed",
            speed,
            "--rate",
            "100",
        ]);
        let v: f64 = speed.parse().unwrap();
        // Four legs of 0.4/V s plus 5 % ramps.
        assert!(
            (sq.duration() - 4.0 * 1.05 * 0.4 / v).abs() < 1e-9,
            "{}",
            sq.duration()
        );
        assert!((sq.path_length() - 1.6).abs() < 1e-9);
        assert!(peak_wheel_rate(&sq) <= 12.0);
        assert!(
            err.contains("peak wheel rate") && err.contains("limit 12 rad/s"),
            "{err}"
        );
        assert!(err.contains("no motor limit was active"), "{err}");

        let (c, err) = plan_stdout(&[
            "plan",
            "circle",
            "--robot",
            "sphere-omni",
            "--radius",
            "0.2",
            "--omega",
            omega,
            "--rate",
            "100",
        ]);
        let w0: f64 = omega.parse().unwrap();
        assert!((c.duration() - std::f64::consts::TAU / w0).abs() < 1e-9);
        // Constant wheel rates equal to the core's for the platform-frame twist (0, Rt ω0, ω0).
        let m = SphereOmni::<f64>::new(SphereParams::preset()).unwrap();
        let want = m.wheel_rates(Twist2::new(0.0, 0.2 * w0, w0), 0.0).unwrap();
        for s in &c.samples {
            for i in 0..3 {
                assert!(
                    (s.wheel_rates[i] - want[i]).abs() < 1e-9,
                    "{omega}: {:?} vs {want:?}",
                    s.wheel_rates
                );
            }
        }
        assert!(err.contains("starts at full speed"), "{err}");
    }
}

#[test]
fn too_fast_circle_is_rejected_naming_wheel_rate_and_excess() {
    let m = SphereOmni::<f64>::new(SphereParams::preset()).unwrap();
    let w = m
        .wheel_rates(Twist2::new(0.0, 0.2 * 3.5, 3.5), 0.0)
        .unwrap();
    let peak = w.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let wheel = w.iter().position(|v| v.abs() == peak).unwrap() + 1;
    omnikin()
        .args(["plan", "circle", "--robot", "sphere-omni", "--radius", "0.2", "--omega", "3.5"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(format!(
            "error: circle with omega 3.5 rad/s (radius 0.2 m) is too fast for sphere-omni: wheel {wheel} needs {peak:.2} rad/s at t = 0.00 s, limit 12 rad/s (+{:.1} %",
            (peak / 12.0 - 1.0) * 100.0
        )));
}

#[test]
fn too_fast_square_is_retimed_or_rejected() {
    let out = tmp("fast-square.csv");
    omnikin()
        .args([
            "plan",
            "square",
            "--robot",
            "sphere-omni",
            "--side",
            "1",
            "--speed",
            "1.5",
            "--out",
        ])
        .arg(out.path())
        .assert()
        .success()
        .stderr(
            predicate::str::contains("re-timed: move 1")
                .and(predicate::str::contains("limits.max_wheel_rate")),
        );
    let p = Plan::load_csv(&out).unwrap();
    assert!(peak_wheel_rate(&p) <= 12.0 && peak_wheel_rate(&p) > 11.5);
    omnikin()
        .args([
            "plan",
            "square",
            "--robot",
            "sphere-omni",
            "--side",
            "1",
            "--speed",
            "1.5",
            "--no-retime",
        ])
        .assert()
        .failure()
        .stderr(
            predicate::str::contains("is too fast for sphere-omni: wheel")
                .and(predicate::str::contains("limit 12 rad/s")),
        );
}

#[test]
fn waypoints_csv_and_toml_with_json_and_plot() {
    let csv = tmp("wp.csv");
    std::fs::write(&csv, "# an S\nx,y\n0,0\n0.5,0.2\n1.0,-0.1\n1.5,0.3\n").unwrap();
    let json = tmp("wp.json");
    let svg = tmp("wp.svg");
    omnikin()
        .args(["plan", "waypoints"])
        .arg(csv.path())
        .args([
            "--robot",
            "ballbot",
            "--path",
            "spline",
            "--heading-law",
            "tangent",
            "--time-optimal",
            "--max-speed",
            "1.5",
            "--format",
            "json",
            "--out",
        ])
        .arg(json.path())
        .arg("--plot")
        .arg(svg.path())
        .assert()
        .success()
        .stderr(
            predicate::str::contains("time-optimal")
                .and(predicate::str::contains("timing limited by")),
        );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let cols: Vec<&str> = v["columns"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_str().unwrap())
        .collect();
    assert_eq!(
        cols,
        [
            "t", "x", "y", "heading", "vx", "vy", "yaw_rate", "w1", "w2", "w3"
        ]
    );
    let rows = v["samples"].as_array().unwrap();
    let last = rows.last().unwrap().as_array().unwrap();
    assert!(
        (last[1].as_f64().unwrap() - 1.5).abs() < 1e-9
            && (last[2].as_f64().unwrap() - 0.3).abs() < 1e-9
    );
    let fig = std::fs::read_to_string(&svg).unwrap();
    for text in [
        "x [m]",
        "y [m]",
        "time t [s]",
        "rate [rad/s]",
        "w1",
        "w3",
        "max_wheel_rate",
    ] {
        assert!(fig.contains(text), "figure lacks \"{text}\"");
    }

    let toml = tmp("wp.toml");
    std::fs::write(
        &toml,
        "[[waypoint]]\nx = 0.0\ny = 0.0\nheading = 0.0\n\n[[waypoint]]\nx = 0.6\ny = 0.0\nheading = 1.5\n\n[[waypoint]]\nx = 0.6\ny = 0.6\nheading = -1.0\n",
    )
    .unwrap();
    let (p, err) = plan_stdout(&[
        "plan",
        "waypoints",
        toml.to_str().unwrap(),
        "--robot",
        "caster3",
        "--corners",
        "fillet",
        "--fillet-radius",
        "0.2",
    ]);
    assert!(err.contains("the file's headings"), "{err}");
    let last = p.samples.last().unwrap();
    assert!(
        (last.pose.heading + 1.0).abs() < 1e-9,
        "{}",
        last.pose.heading
    );
    assert!(p.steerable());
}

#[test]
fn bad_waypoint_files_name_file_and_line() {
    let bad = tmp("bad.csv");
    std::fs::write(&bad, "x,y\n0,0\n1,oops\n").unwrap();
    omnikin()
        .args(["plan", "waypoints"])
        .arg(bad.path())
        .args(["--robot", "sphere-omni"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(format!(
            "{}:3: column y: \"oops\" is not a number",
            bad.display()
        )));
    let dup = tmp("dup.csv");
    std::fs::write(&dup, "0,0\n1,0\n\n1,0\n").unwrap();
    omnikin()
        .args(["plan", "waypoints"])
        .arg(dup.path())
        .args(["--robot", "sphere-omni"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(format!(
            "{}:4: waypoint (1, 0) repeats the previous one (line 2)",
            dup.display()
        )));
    let badtoml = tmp("bad.toml");
    std::fs::write(
        &badtoml,
        "[[waypoint]]\nx = 0.0\ny = 0.0\n[[waypoint]]\nx = 1.0\nwhy = 2.0\n",
    )
    .unwrap();
    omnikin()
        .args(["plan", "waypoints"])
        .arg(badtoml.path())
        .args(["--robot", "sphere-omni"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(format!(
            "{}:6: unknown field `why`",
            badtoml.display()
        )));
    // A reversal cannot be filleted: the error points at the waypoint's line.
    let rev = tmp("rev.csv");
    std::fs::write(&rev, "0,0\n1,0\n0,0\n").unwrap();
    omnikin()
        .args(["plan", "waypoints"])
        .arg(rev.path())
        .args(["--robot", "sphere-omni", "--corners", "fillet"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(format!(
            "{}:2: waypoint 2 (1, 0) turns by 180.0°",
            rev.display()
        )));
    omnikin()
        .args([
            "plan",
            "waypoints",
            "/nonexistent/w.csv",
            "--robot",
            "sphere-omni",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("/nonexistent/w.csv: cannot read"));
}

#[test]
fn negative_values_after_flags_and_caster_steer() {
    // Clockwise circle: ω0 < 0 right after its flag.
    let (p, _) = plan_stdout(&[
        "plan",
        "circle",
        "--robot",
        "sphere-omni",
        "--omega",
        "-0.5",
        "--rate",
        "50",
    ]);
    assert!(p.samples[10].pose.y < 0.0 && p.samples[10].pose.heading < 0.0);
    let csv = tmp("line.csv");
    std::fs::write(&csv, "0,0\n0.5,0\n").unwrap();
    let (p, err) = plan_stdout(&[
        "plan",
        "waypoints",
        csv.to_str().unwrap(),
        "--robot",
        "caster3",
        "--heading",
        "-0.3",
        "--initial-steer",
        "-0.1,0.2,-3",
    ]);
    assert_eq!(p.samples[0].pose.heading, -0.3);
    assert_eq!(p.samples[0].steer.unwrap().0[..3], [-0.1, 0.2, -3.0]);
    assert!(
        err.contains("initial steer angles: -0.1000, 0.2000, -3.0000 rad"),
        "{err}"
    );
    omnikin()
        .args([
            "plan",
            "waypoints",
            csv.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--initial-steer",
            "0,0,0",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "applies only to robot kinds with steering",
        ));
    omnikin()
        .args([
            "plan",
            "waypoints",
            csv.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--time-optimal",
            "--profile",
            "s-curve",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("cannot be used with"));
    omnikin()
        .args(["plan", "square", "--robot", "sphere-omni", "--speed", "-1"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("must be > 0"));
}

/// The CSV header of a plan written to stdout.
fn header(args: &[&str]) -> (Vec<String>, Plan, String) {
    let out = omnikin().args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{args:?}: {stderr}");
    let text = String::from_utf8(out.stdout.clone()).unwrap();
    let head = text
        .lines()
        .next()
        .unwrap()
        .split(',')
        .map(String::from)
        .collect();
    (
        head,
        Plan::read_csv(&out.stdout[..], "stdout").unwrap(),
        stderr,
    )
}

#[test]
fn kiwi_and_mecanum_squares_have_one_column_per_wheel() {
    for (robot, n) in [("kiwi", 3), ("mecanum", 4), ("x-drive", 4)] {
        let svg = tmp(&format!("{robot}-square.svg"));
        let (head, p, err) = header(&[
            "plan",
            "square",
            "--robot",
            robot,
            "--side",
            "0.4",
            "--speed",
            "0.2",
            "--plot",
            svg.to_str().unwrap(),
        ]);
        let mut want: Vec<String> = ["t", "x", "y", "heading", "vx", "vy", "yaw_rate"]
            .map(String::from)
            .to_vec();
        want.extend((1..=n).map(|i| format!("w{i}")));
        assert_eq!(head, want, "{robot}");
        assert_eq!(p.wheels, n);
        assert!((p.path_length() - 1.6).abs() < 1e-9, "{robot}");
        // The square's corners are reached, and every wheel turns.
        let end = p.samples.last().unwrap().pose;
        assert!(end.x.abs() < 1e-9 && end.y.abs() < 1e-9, "{robot}: {end:?}");
        for i in 0..n {
            assert!(
                p.samples.iter().any(|s| s.wheel_rates[i].abs() > 0.5),
                "{robot}: wheel {} never turns",
                i + 1
            );
        }
        assert!(err.contains(&format!("robot: {robot} (omni,")), "{err}");
        assert!(err.contains(&format!("w{n} ")), "{err}");
        let fig = std::fs::read_to_string(&svg).unwrap();
        for i in 1..=n {
            let label = format!("w{i}");
            assert!(
                fig.lines().any(|l| l.trim() == label),
                "{robot}: figure lacks the series {label}"
            );
        }
    }
}

#[test]
fn swerve_plans_carry_steer_columns_and_take_one_initial_angle_per_module() {
    let (head, p, err) = header(&[
        "plan",
        "square",
        "--robot",
        "swerve4",
        "--initial-steer",
        "0.1,-0.2,0.3,-0.4",
    ]);
    assert_eq!(head.len(), 7 + 3 * 4);
    assert_eq!(
        &head[7..],
        [
            "w1", "w2", "w3", "w4", "s1", "s2", "s3", "s4", "sd1", "sd2", "sd3", "sd4"
        ]
    );
    let g = p.samples[0].steer.unwrap().0;
    for (got, want) in g.iter().zip([0.1, -0.2, 0.3, -0.4]) {
        assert!((got - want).abs() < 1e-15, "{g:?}");
    }
    assert!(
        err.contains("initial steer angles: 0.1000, -0.2000, 0.3000, -0.4000 rad"),
        "{err}"
    );
    assert!(err.contains("peak steer rate"), "{err}");
    omnikin()
        .args([
            "plan",
            "square",
            "--robot",
            "swerve4",
            "--initial-steer",
            "0,0,0",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "--initial-steer: expected 4 values",
        ));
    omnikin()
        .args([
            "plan",
            "square",
            "--robot",
            "kiwi",
            "--initial-steer",
            "0,0,0",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "applies only to robot kinds with steering",
        ));
}
