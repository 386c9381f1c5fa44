//! Issue 12, observations 5, 6 and 9 as the user typed them: each command below was killed
//! under a 3 GiB memory limit, hung, or quietly did the wrong thing. Now each is a clear
//! error naming the limit or range and what to change (or, for the BOM, simply works).
//!
//! Every command runs under the same 3 GiB address-space limit (`ulimit -v`) and a generous
//! timeout, so a regression fails the test instead of taking the machine down or hanging.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::Duration;

const BIN: &str = env!("CARGO_BIN_EXE_omnikin");

fn tmp(name: &str) -> TestDir {
    TestDir::new("limits", name)
}

/// Runs `omnikin ARGS` with at most 3 GiB of address space and a 300 s guard.
fn run(args: &[&str]) -> Output {
    let mut cmd = assert_cmd::Command::new("sh");
    cmd.arg("-c")
        .arg("ulimit -v 3145728 && exec \"$0\" \"$@\"")
        .arg(BIN)
        .args(args)
        .timeout(Duration::from_secs(300));
    cmd.output().unwrap()
}

/// Runs a command that must fail with a message containing every one of `needles`.
fn fails_with(args: &[&str], needles: &[&str]) {
    let out = run(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} succeeded; stderr: {err}");
    // 1: an error of the command; 2: a flag refused by its parser (clap's usage error).
    assert!(
        matches!(out.status.code(), Some(1 | 2)),
        "{args:?}: {:?}: {err}",
        out.status.code()
    );
    for n in needles {
        assert!(err.contains(n), "{args:?}: missing {n:?} in: {err}");
    }
    assert!(!err.contains("panicked"), "{args:?}: {err}");
}

fn write(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
}

fn sphere_file(dir: &Path, file: &str, replace: (&str, &str)) -> PathBuf {
    let text = include_str!("../../../robots/sphere-omni.toml");
    assert!(text.contains(replace.0));
    let p = dir.join(file);
    write(&p, &text.replacen(replace.0, replace.1, 1));
    p
}

/// The 1-based line of the file at `path` that starts with `start` (the line an error about
/// that value names).
fn line_of(path: &Path, start: &str) -> usize {
    let text = std::fs::read_to_string(path).unwrap();
    1 + text
        .lines()
        .position(|l| l.starts_with(start))
        .unwrap_or_else(|| panic!("{}: no line starts with {start}", path.display()))
}

#[test]
fn plans_that_would_not_fit_in_memory_are_refused() {
    fails_with(
        &[
            "plan",
            "square",
            "--robot",
            "sphere-omni",
            "--speed",
            "1e-9",
        ],
        &[
            "speed = 1e-9 m/s is outside the plausible range",
            "omnikin_plan::limits",
        ],
    );
    fails_with(
        &["plan", "square", "--robot", "sphere-omni", "--rate", "1e12"],
        &["rate = 1e12 Hz is outside the plausible range"],
    );
    fails_with(
        &[
            "plan",
            "circle",
            "--robot",
            "sphere-omni",
            "--omega",
            "1e-9",
        ],
        &["|omega| = 1e-9 rad/s is outside the plausible range"],
    );
    // Every value in range, the product too large: the limit, the count and the flag.
    fails_with(
        &[
            "plan",
            "square",
            "--robot",
            "sphere-omni",
            "--speed",
            "1e-4",
            "--rate",
            "1000",
        ],
        &[
            "needs 1.6800e7 samples",
            "MAX_PLAN_SAMPLES = 2000000",
            "lower the sampling rate (--rate)",
        ],
    );
    let d = tmp("memory");
    let slow = sphere_file(
        &d,
        "slow.toml",
        ("max_wheel_rate = 12.0", "max_wheel_rate = 1e-308"),
    );
    fails_with(
        &["plan", "square", "--robot", slow.to_str().unwrap()],
        &[&format!(
            "slow.toml:{}: limits.max_wheel_rate: 1e-308 rad/s is outside the plausible range",
            line_of(&slow, "max_wheel_rate = 1e-308")
        )],
    );
    let wp = d.join("w.csv");
    write(&wp, "x,y,heading\n0,0,0\n1,0,1e300\n");
    fails_with(
        &[
            "plan",
            "waypoints",
            wp.to_str().unwrap(),
            "--robot",
            "sphere-omni",
        ],
        &["w.csv:3: column heading = 1e300 rad is outside the plausible range"],
    );
    let out = d.join("reproduce");
    fails_with(
        &[
            "reproduce",
            "sphere-2019",
            "--rate",
            "1e9",
            "--out",
            out.to_str().unwrap(),
        ],
        &["rate = 1e9 Hz (reproduce) is outside the plausible range [1, 10000]"],
    );
    assert!(!out.exists(), "nothing is written for a refused request");
}

#[test]
fn waits_and_loops_are_bounded() {
    // A plan whose last t is 1e300: `simulate` looped for ever.
    let d = tmp("hangs");
    let plan = d.join("far.csv");
    write(
        &plan,
        "t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3\n0,0,0,0,0,0,0,0,0,0\n0.01,0,0,0,0,0,0,0,0,0\n1e300,0,0,0,0,0,0,0,0,0\n",
    );
    let out = d.join("sim");
    fails_with(
        &[
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--trials",
            "1",
            "--out",
            out.to_str().unwrap(),
        ],
        &["needs 1.0000e303 plant steps", "MAX_PLANT_STEPS = 1e8"],
    );
    // `robot --rate 1e9` never reached its robot time; `--rate 1e-300` waited 1e300 s.
    for rate in ["1e9", "1e-300"] {
        fails_with(
            &[
                "robot",
                "--sim",
                "--robot",
                "sphere-omni",
                "--listen",
                "127.0.0.1:0",
                "--rate",
                rate,
                "--max-time",
                "1",
            ],
            &["--rate", "must be between 1 and 10000 Hz"],
        );
    }
    fails_with(
        &[
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            "127.0.0.1:0",
            "--time-scale",
            "1e-300",
            "--max-time",
            "1",
        ],
        &["--time-scale", "must be between 0.01 and 1000"],
    );
    fails_with(
        &[
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            "127.0.0.1:0",
            "--watchdog",
            "1e300",
            "--max-time",
            "1",
        ],
        &["--watchdog: must be between 1e-3 and 1e3 s"],
    );
}

#[test]
fn quietly_wrong_inputs_are_errors() {
    let d = tmp("quiet");
    // A fourth azimuth was silently dropped.
    let four = sphere_file(
        &d,
        "four.toml",
        (
            "azimuths_deg = [0.0, 120.0, 240.0]",
            "azimuths_deg = [0.0, 120.0, 240.0, 300.0]",
        ),
    );
    fails_with(
        &["check", four.to_str().unwrap()],
        &[
            "four.toml:",
            "geometry.azimuths_deg: expected 3 values (one per wheel), got 4",
        ],
    );
    // noise_std = 1e308 was a valid profile.
    let plan = d.join("square.csv");
    let ok = run(&[
        "plan",
        "square",
        "--robot",
        "sphere-omni",
        "--out",
        plan.to_str().unwrap(),
    ]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let profile = d.join("noisy.toml");
    write(&profile, "[tracking]\nnoise_std = 1e308\n");
    fails_with(
        &[
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--disturbances",
            profile.to_str().unwrap(),
            "--out",
            d.join("sim").to_str().unwrap(),
        ],
        &["noisy.toml: tracking.noise_std: 1e308 m is outside the plausible range [0, 10] m"],
    );
    // --ramp 1e300 gave a degenerate plan.
    fails_with(
        &[
            "plan",
            "circle",
            "--robot",
            "sphere-omni",
            "--omega",
            "0.5",
            "--ramp",
            "1e300",
        ],
        &["ramp = 1e300 s is outside the plausible range"],
    );
    // Implausible evaluation flags.
    let track = d.join("track.csv");
    write(&track, "t,x,y\n0,0,0\n0.1,0.01,0\n0.2,0.02,0\n");
    fails_with(
        &[
            "evaluate",
            "--plan",
            plan.to_str().unwrap(),
            track.to_str().unwrap(),
            "--tracking-offset",
            "1e308,0",
            "--out",
            d.join("eval").to_str().unwrap(),
        ],
        &["--tracking-offset 1e308,0", "MAX_TRACKING_OFFSET"],
    );
}

#[test]
fn a_byte_order_mark_is_accepted_everywhere() {
    let d = tmp("bom");
    let plain = d.join("plain.csv");
    let bom = d.join("bom.csv");
    write(&plain, "x,y\n0,0\n0.5,0\n0.5,0.5\n");
    write(&bom, "\u{feff}x,y\n0,0\n0.5,0\n0.5,0.5\n");
    let a = run(&[
        "plan",
        "waypoints",
        plain.to_str().unwrap(),
        "--robot",
        "sphere-omni",
    ]);
    let b = run(&[
        "plan",
        "waypoints",
        bom.to_str().unwrap(),
        "--robot",
        "sphere-omni",
    ]);
    assert!(b.status.success(), "{}", String::from_utf8_lossy(&b.stderr));
    assert_eq!(a.stdout, b.stdout);
    let toml = d.join("bom.toml");
    write(
        &toml,
        "\u{feff}[[waypoint]]\nx = 0.0\ny = 0.0\n[[waypoint]]\nx = 0.5\ny = 0.0\n[[waypoint]]\nx = 0.5\ny = 0.5\n",
    );
    let c = run(&[
        "plan",
        "waypoints",
        toml.to_str().unwrap(),
        "--robot",
        "sphere-omni",
    ]);
    assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
    assert_eq!(a.stdout, c.stdout);
    let robot = d.join("robot.toml");
    write(
        &robot,
        &format!("\u{feff}{}", include_str!("../../../robots/ballbot.toml")),
    );
    let e = run(&["check", robot.to_str().unwrap()]);
    assert!(e.status.success(), "{}", String::from_utf8_lossy(&e.stderr));
    // A plan file with a BOM simulates.
    let plan = d.join("plan.csv");
    let mut text = b"\xef\xbb\xbf".to_vec();
    text.extend_from_slice(&a.stdout);
    std::fs::write(&plan, text).unwrap();
    let s = run(&[
        "simulate",
        plan.to_str().unwrap(),
        "--robot",
        "sphere-omni",
        "--trials",
        "1",
        "--out",
        d.join("sim").to_str().unwrap(),
    ]);
    assert!(s.status.success(), "{}", String::from_utf8_lossy(&s.stderr));
}

#[test]
fn robot_names_and_figure_text_cannot_break_the_svg() {
    let d = tmp("svg");
    // Control characters in a name are refused at load.
    let bell = sphere_file(
        &d,
        "bell.toml",
        ("name = \"sphere-omni\"", "name = \"bell\\u0007\""),
    );
    fails_with(
        &["check", bell.to_str().unwrap()],
        &[&format!(
            "bell.toml:{}: name: must be printable: contains the control character U+0007",
            line_of(&bell, "name = ")
        )],
    );
    // XML-special characters are allowed in a name and escaped in the figure.
    let special = sphere_file(
        &d,
        "special.toml",
        (
            "name = \"sphere-omni\"",
            "name = \"Kugel <β> & \\\"co\\\"\"",
        ),
    );
    let svg = d.join("special.svg");
    let out = run(&[
        "plan",
        "square",
        "--robot",
        special.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
        "--out",
        d.join("special.csv").to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(
        text.contains("Kugel &lt;β&gt; &amp; &quot;co&quot;"),
        "name not escaped"
    );
    assert!(!text.contains("<β>"));
    // Other text that reaches a title (here a file name with a control character) is made
    // printable: XML forbids control characters even as character references.
    let wp = d.join("bell\u{7}.csv");
    write(&wp, "x,y\n0,0\n0.5,0\n");
    let svg = d.join("bell.svg");
    let out = run(&[
        "plan",
        "waypoints",
        wp.to_str().unwrap(),
        "--robot",
        "sphere-omni",
        "--plot",
        svg.to_str().unwrap(),
        "--out",
        d.join("bell-plan.csv").to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("bell\u{fffd}.csv"), "title lost");
    assert!(
        !text
            .chars()
            .any(|c| c.is_control() && !matches!(c, '\n' | '\r' | '\t')),
        "a control character reached the SVG"
    );
}

#[test]
fn figures_of_long_plans_are_thinned_not_gigabytes() {
    // A 10⁷-sample plan drew four 10⁷-point polylines: a 500 MB SVG and ~1.5 GB of memory on
    // top of the plan. Here 168 001 samples; every polyline is thinned to the figure limit,
    // keeping each bucket's extremes, so the peak wheel rate is still drawn.
    let d = tmp("figure");
    let svg = d.join("long.svg");
    let out = run(&[
        "plan",
        "square",
        "--robot",
        "sphere-omni",
        "--rate",
        "10000",
        "--plot",
        svg.to_str().unwrap(),
        "--out",
        d.join("long.csv").to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    let mut lines = 0;
    for poly in text.split("<polyline").skip(1) {
        let pts = poly
            .split("points=\"")
            .nth(1)
            .and_then(|p| p.split('"').next())
            .unwrap_or("");
        let n = pts.split_whitespace().count();
        assert!(n <= 20_002, "a polyline with {n} points");
        lines += 1;
    }
    assert!(lines >= 4, "{lines} polylines");
    assert!(text.len() < 8_000_000, "{} bytes", text.len());
}

#[test]
fn input_files_read_whole_are_bounded_before_they_are_read() {
    // Files larger than anything their format needs (sparse: no disk used). Each was read
    // whole and parsed: at 2.5 GB, odometry and plan waypoints aborted (allocation failure),
    // and a robot or profile TOML needed 7x its size — aborted too. Now each is refused by
    // its size first, naming the limit.
    let d = tmp("big-files");
    let sparse = |name: &str, len: u64| {
        let p = d.join(name);
        std::fs::File::create(&p).unwrap().set_len(len).unwrap();
        p.to_str().unwrap().to_string()
    };
    let toml = sparse("robot.toml", (1 << 20) + 1);
    let out = d.join("o.csv");
    let o = out.to_str().unwrap();
    fails_with(
        &["plan", "square", "--robot", &toml, "--out", o],
        &["MAX_TOML_BYTES"],
    );
    let plan = d.join("p.csv");
    assert!(
        run(&[
            "plan",
            "square",
            "--robot",
            "sphere-omni",
            "--out",
            plan.to_str().unwrap()
        ])
        .status
        .success()
    );
    let s = d.join("sim");
    fails_with(
        &[
            "simulate",
            plan.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--disturbances",
            &toml,
            "--out",
            s.to_str().unwrap(),
        ],
        &["MAX_TOML_BYTES"],
    );
    let wp = sparse("w.csv", (64 << 20) + 1);
    fails_with(
        &[
            "plan",
            "waypoints",
            &wp,
            "--robot",
            "sphere-omni",
            "--out",
            o,
        ],
        &["MAX_WAYPOINT_FILE_BYTES"],
    );
    let log = sparse("enc.csv", (1 << 30) + 1);
    fails_with(
        &["odometry", &log, "--robot", "sphere-omni", "--out", o],
        &["MAX_LOG_BYTES"],
    );
}

#[test]
fn a_key_file_is_not_read_past_what_a_key_can_be() {
    // `--key /dev/zero` read until memory ran out (2 GB) before failing "out of memory".
    fails_with(
        &[
            "drive",
            "--connect",
            "127.0.0.1:9",
            "--key",
            "/dev/zero",
            "hello",
        ],
        &["--key /dev/zero", "16 to 64 bytes"],
    );
    fails_with(
        &[
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            "127.0.0.1:9",
            "--key",
            "/dev/zero",
        ],
        &["--key /dev/zero", "16 to 64 bytes"],
    );
}

#[test]
fn force_into_a_directory_holding_an_input_under_an_output_name_writes_nothing() {
    // `--force simulate DIR/mean.csv --out DIR`: mean.csv (the plan) was refused only when
    // its turn came, after metrics.json and trials.csv had been replaced — a failed command
    // leaving new results beside an old figure.
    let d = tmp("force-input-in-dir");
    let out = d.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let plan = out.join("mean.csv");
    assert!(
        run(&[
            "plan",
            "square",
            "--robot",
            "sphere-omni",
            "--out",
            plan.to_str().unwrap()
        ])
        .status
        .success()
    );
    write(&out.join("metrics.json"), "old\n");
    write(&out.join("trials.csv"), "old\n");
    for cmd in [
        vec!["simulate", "--trials", "1", "--robot", "sphere-omni"],
        vec!["evaluate", "--plan", plan.to_str().unwrap()],
    ] {
        let mut args = vec!["--force"];
        args.extend(cmd);
        args.extend([plan.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        fails_with(&args, &["is also the input"]);
        for f in ["metrics.json", "trials.csv"] {
            assert_eq!(
                std::fs::read_to_string(out.join(f)).unwrap(),
                "old\n",
                "{args:?}: {f} untouched"
            );
        }
        assert!(!out.join("figure.svg").exists() && !out.join("runs.csv").exists());
    }
}
