//! An outsider's attack on the layouts of issue 13 (`omni` and `swerve` robot files, the
//! presets kiwi, x-drive, mecanum, swerve4, and every command over them). Each test is one
//! finding: the input that was accepted, misreported or quietly wrong before, and the rule the
//! edge now enforces (an error naming the file, the line or field, and the rule; exit code
//! non-zero; no output written from bad input).

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::Path;

use assert_cmd::Command;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

/// A fresh directory for one test's files.
fn tmp(name: &str) -> TestDir {
    TestDir::new("attack", name)
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs the command, which must fail; returns its stderr.
fn error_of(args: &[&str]) -> String {
    let out = omnikin().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} should fail; stderr: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    err
}

/// Runs the command, which must succeed; returns (stdout, stderr).
fn ok_of(args: &[&str]) -> (String, String) {
    let out = omnikin().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{args:?} failed: {err}");
    (String::from_utf8_lossy(&out.stdout).into_owned(), err)
}

/// An omni robot file: one `[[geometry.wheels]]` table per `(x, y, drive_deg, roller_deg,
/// radius)`, each value written as given (so `nan`, `1e308` reach the parser).
fn omni_file(wheels: &[[&str; 5]]) -> String {
    let mut s = String::from("kind = \"omni\"\n");
    for w in wheels {
        s += &format!(
            "\n[[geometry.wheels]]\nposition = [{}, {}]\ndrive_angle_deg = {}\nroller_angle_deg = {}\nradius = {}\n",
            w[0], w[1], w[2], w[3], w[4]
        );
    }
    s
}

/// The kiwi preset's wheels as strings, with wheel `i`'s field `f` replaced by `v`.
fn kiwi_with(i: usize, f: usize, v: &'static str) -> Vec<[&'static str; 5]> {
    let mut w = vec![
        ["0.15", "0.0", "90.0", "0.0", "0.05"],
        ["-0.075", "0.1299038105676658", "210.0", "0.0", "0.05"],
        ["-0.075", "-0.1299038105676658", "330.0", "0.0", "0.05"],
    ];
    w[i][f] = v;
    w
}

fn swerve_file(modules: &[[&str; 3]]) -> String {
    let mut s = String::from("kind = \"swerve\"\n");
    for m in modules {
        s += &format!(
            "\n[[geometry.modules]]\nposition = [{}, {}]\nwheel_radius = {}\n",
            m[0], m[1], m[2]
        );
    }
    s
}

/// Finding: implausible wheel values were only caught by the model's rank test, so a
/// 1e308 m radius read "omni torque map JᵀJ (wheel radii too different) is singular", a wheel
/// 1e308 m away "the lines … meet in one point", a roller at 720° (the documented rule is
/// |ρ| < 90°) was accepted, and a drive angle of 1e20° (no precision left) read "all roller
/// axes are parallel". Now each is refused by name, with the wheel's line, before any model
/// is built.
#[test]
fn omni_wheel_values_are_checked_by_name_and_line_before_the_model() {
    let d = tmp("omni-values");
    // (wheel, field, value, key in the message, rule fragment)
    let cases: &[(usize, usize, &str, &str, &str)] = &[
        (
            0,
            4,
            "1e308",
            "geometry.wheels[0].radius",
            "plausible range",
        ),
        (
            1,
            4,
            "1e-300",
            "geometry.wheels[1].radius",
            "plausible range",
        ),
        (2, 4, "nan", "geometry.wheels[2].radius", "finite"),
        (1, 4, "-0.05", "geometry.wheels[1].radius", "> 0"),
        (
            0,
            0,
            "1e308",
            "geometry.wheels[0].position",
            "plausible range",
        ),
        (2, 1, "nan", "geometry.wheels[2].position", "finite"),
        (
            1,
            3,
            "720.0",
            "geometry.wheels[1].roller_angle_deg",
            "(-90, 90)",
        ),
        (
            0,
            3,
            "90.0",
            "geometry.wheels[0].roller_angle_deg",
            "(-90, 90)",
        ),
        (
            2,
            3,
            "-90.0",
            "geometry.wheels[2].roller_angle_deg",
            "(-90, 90)",
        ),
        (
            1,
            3,
            "inf",
            "geometry.wheels[1].roller_angle_deg",
            "(-90, 90)",
        ),
        (
            0,
            2,
            "1e20",
            "geometry.wheels[0].drive_angle_deg",
            "[-720, 720]",
        ),
        (
            2,
            2,
            "nan",
            "geometry.wheels[2].drive_angle_deg",
            "[-720, 720]",
        ),
    ];
    for &(i, f, v, key, rule) in cases {
        let file = d.join(format!("w{i}-{f}-{v}.toml"));
        std::fs::write(&file, omni_file(&kiwi_with(i, f, v))).unwrap();
        let err = error_of(&["check", path(&file)]);
        // Wheel i's table starts on line 3 + 6 i; the error names the line of the bad value
        // (position, drive angle, roller angle, radius on the next four lines), not the
        // table's header.
        let line = format!(".toml:{}: {key}: ", 3 + 6 * i + f.max(1));
        assert!(err.contains(&line), "{v} in wheel {i}: {err}");
        assert!(err.contains(rule), "{v} in wheel {i}: {err}");
        assert!(!err.contains("singular"), "{v} in wheel {i}: {err}");
    }
    // Within the rules: a roller at 89° and a drive angle of 398° (θ + 90° for θ = 308°) load.
    for (f, v) in [(3, "89.0"), (2, "398.0")] {
        let file = d.join(format!("ok-{f}.toml"));
        std::fs::write(&file, omni_file(&kiwi_with(0, f, v))).unwrap();
        ok_of(&["check", path(&file)]);
    }
}

/// Finding: two swerve modules at the same point (a table copied without editing it) were
/// accepted as a valid swerve4, and a layout 2 nm across loaded with condition number 1 (the
/// rank test is scale-free) and then turned wheel rates 1,2,3,4 into a yaw rate of
/// −2.5·10⁷ rad/s. Contact points must now be at least 0.1 mm apart; the error names both.
#[test]
fn coincident_or_microscopic_layouts_are_refused_naming_both_wheels() {
    let d = tmp("coincident");
    let dup = d.join("dup.toml");
    std::fs::write(
        &dup,
        swerve_file(&[
            ["0.3", "0.3", "0.05"],
            ["0.3", "0.3", "0.05"],
            ["-0.3", "-0.3", "0.05"],
            ["-0.3", "0.3", "0.05"],
        ]),
    )
    .unwrap();
    let err = error_of(&["check", path(&dup)]);
    assert!(
        err.contains("dup.toml:8: geometry.modules[1].position: is 0 m from geometry.modules[0].position (line 4)"),
        "{err}"
    );
    let tiny = d.join("tiny.toml");
    std::fs::write(
        &tiny,
        swerve_file(&[
            ["1e-9", "1e-9", "0.05"],
            ["1e-9", "-1e-9", "0.05"],
            ["-1e-9", "1e-9", "0.05"],
            ["-1e-9", "-1e-9", "0.05"],
        ]),
    )
    .unwrap();
    let err = error_of(&["forward", path(&tiny), "--wheel-rates", "1,2,3,4", "--json"]);
    assert!(err.contains("geometry.modules[1].position"), "{err}");
    assert!(err.contains("at least 1e-4 m apart"), "{err}");
    // An omni layout with three wheels on one spot (distinct drive directions).
    let one = d.join("one-spot.toml");
    std::fs::write(
        &one,
        omni_file(&[
            ["0.1", "0.0", "0.0", "0.0", "0.05"],
            ["0.1", "0.0", "120.0", "0.0", "0.05"],
            ["0.1", "0.0", "240.0", "0.0", "0.05"],
        ]),
    )
    .unwrap();
    let err = error_of(&["check", path(&one)]);
    assert!(err.contains("geometry.wheels[1].position"), "{err}");
}

/// Finding: a rank-deficient layout's message ended with the paper robots' "(wheels nearly
/// coplanar or parallel)" after a run-on sentence; it now says "rank-deficient layout" and
/// which rule. And a file of 1000 wheels is refused by its count before any per-wheel work.
#[test]
fn rank_and_count_errors_say_what_the_layout_breaks() {
    let d = tmp("rank");
    let parallel = d.join("parallel.toml");
    std::fs::write(
        &parallel,
        omni_file(&[
            ["0.2", "0.0", "0.0", "0.0", "0.05"],
            ["0.0", "0.2", "0.0", "0.0", "0.05"],
            ["-0.2", "0.0", "0.0", "0.0", "0.05"],
            ["0.0", "-0.2", "0.0", "0.0", "0.05"],
        ]),
    )
    .unwrap();
    let err = error_of(&["check", path(&parallel)]);
    assert!(
        err.contains("geometry.wheels: rank-deficient layout") && err.contains("parallel"),
        "{err}"
    );
    assert!(!err.contains("coplanar"), "{err}");
    let many = d.join("many.toml");
    let wheels: Vec<[&str; 5]> = (0..1000)
        .map(|_| ["0.1", "0.0", "1e20", "720.0", "nan"])
        .collect();
    std::fs::write(&many, omni_file(&wheels)).unwrap();
    let err = error_of(&["check", path(&many)]);
    assert!(
        err.contains("geometry.wheels: wheels: 1000 given, this kind supports 3 to 6"),
        "{err}"
    );
}

/// Finding: `plan square --robot swerve4` re-steers the modules at each corner between two
/// samples with `sd = 0` (and reports "peak steer rate 0.000 rad/s"); the simulator turns the
/// steer motors by `sd`, so on the ideal plant the robot never turned and the square ended
/// 1.6 m from its end point (max deviation 75 % of the path), exit code 0. `plan` now warns
/// and `simulate` refuses such a plan, naming the module, the times and the rate it would
/// need; a swerve plan without stops still simulates to the millimetre.
#[test]
fn a_swerve_plan_that_re_steers_between_two_samples_is_not_simulated_as_if_it_did_not() {
    let d = tmp("steer-step");
    let square = d.join("square.csv");
    let (_, err) = ok_of(&[
        "plan",
        "square",
        "--robot",
        "swerve4",
        "--out",
        path(&square),
    ]);
    // The planner turns the modules at rest at each corner (a re-steer move), so its own plan
    // has no step: no warning, and the simulation follows it.
    assert!(err.contains("3 re-steer(s) at rest"), "{err}");
    assert!(!err.contains("warning"), "{err}");
    let out = d.join("sim");
    ok_of(&[
        "simulate",
        path(&square),
        "--robot",
        "swerve4",
        "--trials",
        "1",
        "--out",
        path(&out),
    ]);
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    let dev = m["max_deviation_m"].as_f64().unwrap();
    assert!(dev < 1e-3, "the re-steered square is followed: {dev} m");
    // A plan whose s1 steps between two samples (the module turned by a quarter turn from one
    // sample to the next, its steer rate saying nothing of it) is refused.
    let text = std::fs::read_to_string(&square).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let col = lines[0].split(',').position(|c| c == "s1").unwrap();
    for line in lines.iter_mut().skip(200) {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        let v: f64 = cells[col].parse().unwrap();
        cells[col] = format!("{}", v - std::f64::consts::FRAC_PI_2);
        *line = cells.join(",");
    }
    let stepped = d.join("stepped.csv");
    std::fs::write(&stepped, lines.join("\n") + "\n").unwrap();
    let out = d.join("sim-stepped");
    let err = error_of(&[
        "simulate",
        path(&stepped),
        "--robot",
        "swerve4",
        "--trials",
        "1",
        "--out",
        path(&out),
    ]);
    assert!(
        err.contains("stepped.csv: s1 steps by -1.5708 rad") && err.contains("sd1"),
        "{err}"
    );
    assert!(!out.join("metrics.json").exists());
    // The same square with filleted corners has no stop: simulated, it follows the plan.
    let wp = d.join("square-wp.csv");
    std::fs::write(&wp, "0,0\n0.4,0\n0.4,0.4\n0,0.4\n0,0\n").unwrap();
    let fillet = d.join("fillet.csv");
    let (_, err) = ok_of(&[
        "plan",
        "waypoints",
        path(&wp),
        "--corners",
        "fillet",
        "--robot",
        "swerve4",
        "--out",
        path(&fillet),
    ]);
    assert!(!err.contains("warning"), "{err}");
    let out = d.join("sim-fillet");
    ok_of(&[
        "simulate",
        path(&fillet),
        "--robot",
        "swerve4",
        "--trials",
        "1",
        "--out",
        path(&out),
    ]);
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    let dev = m["max_deviation_m"].as_f64().unwrap();
    assert!(dev < 0.01, "max deviation {dev} m");
    // A kink of the steer rate between two samples (a spline waypoint under the tangent law,
    // a module near the centre of rotation: sd1 −2.5 → +2.9 rad/s in 10 ms) is not a re-steer.
    let two = d.join("two.toml");
    std::fs::write(
        &two,
        swerve_file(&[["0.2866", "0.0887", "0.05"], ["-0.2866", "-0.0887", "0.05"]]),
    )
    .unwrap();
    let spline = d.join("spline.csv");
    let (_, err) = ok_of(&[
        "plan",
        "waypoints",
        path(&wp),
        "--path",
        "spline",
        "--heading-law",
        "tangent",
        "--robot",
        path(&two),
        "--out",
        path(&spline),
    ]);
    assert!(!err.contains("warning"), "{err}");
    let out = d.join("sim-spline");
    let (_, err) = ok_of(&[
        "simulate",
        path(&spline),
        "--robot",
        path(&two),
        "--trials",
        "1",
        "--out",
        path(&out),
    ]);
    assert!(!err.contains("warning"), "{err}");
}

/// Finding: a plan CSV's values only had to be finite: a steer rate `sd2 = 1e308` rad/s, a
/// steer angle `s2 = 1e308` rad or a heading of 1e308 rad were simulated without a word (exit
/// 0, metrics of nonsense), and a wheel rate of 1e308 rad/s ended in an overflow error that
/// quoted a 309-digit number. Each column is now held to the bound of what it means, and the
/// error names the file, the line, the column and the limit.
#[test]
fn plan_columns_are_held_to_plausible_bounds() {
    let d = tmp("plan-bounds");
    let plan = d.join("square.csv");
    ok_of(&["plan", "square", "--robot", "swerve4", "--out", path(&plan)]);
    let text = std::fs::read_to_string(&plan).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    for (column, value, rule) in [
        ("sd2", "1e308", "[-1e5, 1e5] rad/s (the limit MAX_PLAN_RATE"),
        ("w4", "-2e5", "[-1e5, 1e5] rad/s (the limit MAX_PLAN_RATE"),
        ("s2", "1e308", "[-1e6, 1e6] rad (the limit MAX_HEADING"),
        ("heading", "1e300", "[-1e6, 1e6] rad (the limit MAX_HEADING"),
        ("x", "-1e9", "[-1e6, 1e6] m (the limit MAX_COORDINATE"),
        ("vy", "1e200", "[-1e6, 1e6] m/s (the limit MAX_COORDINATE"),
    ] {
        let k = header.iter().position(|h| *h == column).unwrap();
        // Row 11 of the file (the 10th sample) gets the value.
        let bad: Vec<String> = text
            .lines()
            .enumerate()
            .map(|(i, l)| {
                if i != 10 {
                    return l.to_string();
                }
                let mut f: Vec<&str> = l.split(',').collect();
                f[k] = value;
                f.join(",")
            })
            .collect();
        let file = d.join(format!("bad-{column}.csv"));
        std::fs::write(&file, bad.join("\n") + "\n").unwrap();
        let out = d.join(format!("out-{column}"));
        let err = error_of(&[
            "simulate",
            path(&file),
            "--robot",
            "swerve4",
            "--trials",
            "1",
            "--out",
            path(&out),
        ]);
        assert!(
            err.contains(&format!("bad-{column}.csv:11: column {column}: {value} ")),
            "{column}: {err}"
        );
        assert!(err.contains(rule), "{column}: {err}");
        assert!(!out.exists());
    }
}

/// Finding: `odometry --robot mecanum` over a swerve4 encoder log (q1..q4 and s1..s4) ignored
/// the steer angles and wrote a 2.8 m path for a closed circle, exit 0; a kiwi over a 4-wheel
/// log ignored q4; a steer angle of 1e308 rad was used as is. The log of another robot is now
/// refused at its header, and steer angles and yaw are held to the plan file's bounds, naming
/// the line and column.
#[test]
fn odometry_refuses_the_log_of_another_robot_and_meaningless_angles() {
    let d = tmp("odometry");
    let swerve_log = d.join("swerve.csv");
    std::fs::write(
        &swerve_log,
        "t,q1,q2,q3,q4,s1,s2,s3,s4,gyro_z\n0,0,0,0,0,1,1,1,1,0\n0.1,1,1,1,1,1,1,1,1,0\n",
    )
    .unwrap();
    let poses = d.join("poses.csv");
    for (robot, col, what) in [
        (
            "mecanum",
            "s1",
            "mecanum (omni) has 4 wheels and no steering, but the log has s1",
        ),
        (
            "kiwi",
            "q4",
            "kiwi (omni) has 3 wheels and no steering, but the log has q4",
        ),
    ] {
        let err = error_of(&[
            "odometry",
            path(&swerve_log),
            "--robot",
            robot,
            "--out",
            path(&poses),
        ]);
        assert!(
            err.contains(&format!("swerve.csv:1: column {col}: {what}")),
            "{robot}: {err}"
        );
        assert!(!poses.exists());
    }
    // The right robot reads it.
    ok_of(&[
        "odometry",
        path(&swerve_log),
        "--robot",
        "swerve4",
        "--out",
        path(&poses),
    ]);
    let bad = d.join("bad-steer.csv");
    std::fs::write(
        &bad,
        "t,q1,q2,q3,q4,s1,s2,s3,s4,yaw\n0,0,0,0,0,1,1,1,1,0\n0.1,1,1,1,1,1,1e308,1,1,0\n",
    )
    .unwrap();
    let out = d.join("out.csv");
    let err = error_of(&[
        "odometry",
        path(&bad),
        "--robot",
        "swerve4",
        "--out",
        path(&out),
    ]);
    assert!(
        err.contains("bad-steer.csv:3: column s2: 1e308 rad is outside the plausible range"),
        "{err}"
    );
    let yaw = d.join("bad-yaw.csv");
    std::fs::write(
        &yaw,
        "t,q1,q2,q3,q4,s1,s2,s3,s4,yaw\n0,0,0,0,0,1,1,1,1,-1e300\n0.1,1,1,1,1,1,1,1,1,0\n",
    )
    .unwrap();
    let err = error_of(&[
        "odometry",
        path(&yaw),
        "--robot",
        "swerve4",
        "--imu",
        "--out",
        path(&out),
    ]);
    assert!(
        err.contains("bad-yaw.csv:2: column yaw: -1e300 rad"),
        "{err}"
    );
    assert!(!out.exists());
}

/// Finding: `robot --sim --log` wrote `w1,w2,w3` for every kind: a mecanum's or swerve's
/// fourth wheel and every steer motor command were not recorded. The log now has one `w` per
/// wheel and, for kinds with steering, one `sd` per module.
#[test]
fn the_robot_log_records_every_wheel_and_steer_motor() {
    let d = tmp("robot-log");
    let log = d.join("robot.csv");
    let addr = format!(
        "127.0.0.1:{}",
        std::net::UdpSocket::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port()
    );
    let mut robot = std::process::Command::new(env!("CARGO_BIN_EXE_omnikin"))
        .args(["robot", "--sim", "--robot", "swerve4", "--listen", &addr])
        .args(["--time-scale", "4", "--max-time", "12", "--log", path(&log)])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(200));
    let drive = omnikin()
        .args(["drive", "--connect", &addr, "velocity"])
        .args([
            "--vx",
            "0.2",
            "--vy",
            "0.1",
            "--yaw-rate",
            "0.3",
            "--for",
            "0.5",
        ])
        .output()
        .unwrap();
    let status = robot.wait().unwrap();
    assert!(
        drive.status.success(),
        "{}",
        String::from_utf8_lossy(&drive.stderr)
    );
    assert!(status.success());
    let text = std::fs::read_to_string(&log).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("no {name} in {header:?}"))
    };
    let (w4, sd1) = (col("w4"), col("sd1"));
    col("sd4");
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), header.len(), "{l}");
            vec![f[w4].parse().unwrap(), f[sd1].parse().unwrap()]
        })
        .collect();
    assert!(rows.iter().any(|r| r[0].abs() > 0.1), "w4 never moved");
    assert!(rows.iter().any(|r| r[1].abs() > 1e-3), "sd1 never moved");
}

/// Finding: `torques kiwi --wrench 1,2` answered "expected three comma-separated numbers …
/// (one per wheel)" — a wrench is three components whatever the wheel count, and so are
/// `--model` and `--initial-pose`; and `omnikin --help` still described "three-wheeled"
/// robots and presets without the layouts, `odometry` a log of `t,q1,q2,q3`.
#[test]
fn three_component_flags_and_help_do_not_speak_of_three_wheels() {
    for args in [
        &["torques", "kiwi", "--wrench", "1,2"][..],
        &["torques", "mecanum", "--wrench", "1,2,3,4"][..],
        &["torques", "ballbot", "--model", "1"][..],
    ] {
        let err = error_of(args);
        assert!(
            err.contains("expected three comma-separated numbers"),
            "{err}"
        );
        assert!(!err.contains("one per wheel"), "{args:?}: {err}");
    }
    let (help, _) = ok_of(&["--help"]);
    assert!(!help.contains("three-wheeled"), "{help}");
    for word in ["kiwi", "x-drive", "mecanum", "swerve4", "t,q1..qN"] {
        assert!(help.contains(word), "{word} not in {help}");
    }
}

/// Finding: `inverse/forward/torques swerve4 --steer 0,0,1e308,0` were accepted (1e308 rad
/// wrapped to an arbitrary direction) while `plan --initial-steer` refused the same value.
/// Now every `--steer` list is held to the same bound, naming the item.
#[test]
fn steer_lists_are_held_to_the_plan_bound() {
    for args in [
        &[
            "inverse",
            "swerve4",
            "--vx",
            "0.1",
            "--steer",
            "0,0,1e308,0",
        ][..],
        &[
            "forward",
            "swerve4",
            "--wheel-rates",
            "1,1,1,1",
            "--steer",
            "0,0,1e308,0",
        ][..],
        &[
            "torques",
            "swerve4",
            "--wheels",
            "1,1,1,1",
            "--steer",
            "0,0,1e308,0",
        ][..],
    ] {
        let err = error_of(args);
        assert!(
            err.contains("--steer: item 3: 1e308 rad is outside the plausible range"),
            "{args:?}: {err}"
        );
    }
    // Angles near ±π are ordinary.
    ok_of(&[
        "forward",
        "swerve4",
        "--wheel-rates",
        "1,1,1,1",
        "--steer",
        "3.14159265,-3.14159265,3.1416,-3.1416",
        "--json",
    ]);
}

/// Finding: `position = [0.15, 0.0, 7.0]` (a z, or a typo) loaded as (0.15, 0.0): the
/// fixed-size array dropped the third value without a word, for wheels and modules alike.
#[test]
fn a_position_has_exactly_two_values() {
    let d = tmp("position");
    let kiwi = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../robots/kiwi.toml"
    ))
    .unwrap()
    .replacen("position = [0.15, 0.0]", "position = [0.15, 0.0, 7.0]", 1);
    let file = d.join("kiwi3.toml");
    std::fs::write(&file, kiwi).unwrap();
    let err = error_of(&["check", path(&file)]);
    assert!(
        err.contains("kiwi3.toml:9: geometry.wheels[0].position: expected 2 values [x, y] (m, robot frame), got 3"),
        "{err}"
    );
    let file = d.join("swerve1.toml");
    std::fs::write(
        &file,
        swerve_file(&[["0.3", "0.3", "0.05"], ["-0.3", "-0.3", "0.05"]]).replacen(
            "position = [-0.3, -0.3]",
            "position = [-0.3]",
            1,
        ),
    )
    .unwrap();
    let err = error_of(&["check", path(&file)]);
    assert!(
        err.contains("swerve1.toml:8: geometry.modules[1].position: expected 2 values [x, y] (m, robot frame), got 1"),
        "{err}"
    );
}

/// Finding: a disturbance profile's `[shell_spin]` on a mecanum, or `[steer_motor]` on a
/// kiwi, was ignored without a word (the kiwi "with steer-motor lag" ran as the ideal plant).
/// `simulate` now says which section the robot's kind does not simulate.
#[test]
fn profile_sections_the_kind_does_not_simulate_are_named() {
    let d = tmp("profile");
    let plan = d.join("kiwi.csv");
    ok_of(&["plan", "square", "--robot", "kiwi", "--out", path(&plan)]);
    let profile = d.join("p.toml");
    std::fs::write(
        &profile,
        "[shell_spin]\nstd = 0.5\n[steer_motor]\nlag_time_constant = 0.05\n[floor]\nrel_std = 0.01\n",
    )
    .unwrap();
    let out = d.join("sim");
    let (_, err) = ok_of(&[
        "simulate",
        path(&plan),
        "--robot",
        "kiwi",
        "--disturbances",
        path(&profile),
        "--trials",
        "1",
        "--out",
        path(&out),
    ]);
    assert!(
        err.contains("p.toml: [shell_spin] applies to sphere-omni and ballbot only; robot kind omni ignores it"),
        "{err}"
    );
    assert!(
        err.contains("p.toml: [steer_motor] applies to kinds with steering"),
        "{err}"
    );
    assert!(!err.contains(": [floor] applies"), "{err}");
}

/// Finding: `forward swerve4 --heading 1e308` and `inverse kiwi --world --heading 1e308`
/// rotated the twist by an angle with no direction left in it (finite output, exit 0), and
/// `inverse kiwi --vx 1e200` warned about "wheel 1 = 300000…(200 digits)…000 rad/s". Angle
/// flags are now held to ±1e6 rad and huge numbers are quoted as 3e200.
#[test]
fn angle_flags_are_bounded_and_huge_numbers_are_quoted_short() {
    for args in [
        &[
            "forward",
            "swerve4",
            "--wheel-rates",
            "1,1,1,1",
            "--heading",
            "1e308",
        ][..],
        &[
            "inverse",
            "kiwi",
            "--vx",
            "1",
            "--world",
            "--heading",
            "-1e308",
        ][..],
        &["torques", "ballbot", "--model", "1,2,3", "--yaw", "1e300"][..],
    ] {
        let err = error_of(args);
        assert!(
            err.contains("rad is outside the plausible range [-1e6, 1e6] rad"),
            "{args:?}: {err}"
        );
    }
    let (_, err) = ok_of(&["inverse", "kiwi", "--vx", "1e200", "--json"]);
    assert!(
        err.contains("wheel 2 = -1.7320508075688772e201 rad/s exceeds"),
        "{err}"
    );
    assert!(err.lines().all(|l| l.len() < 200), "{err}");
}
