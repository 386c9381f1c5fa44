//! End to end over loopback UDP: `omnikin robot --sim` (runtime + simulated plant, run 8×
//! faster than real time) driven by `omnikin drive`. Every robot process stops by itself
//! (`--max-time`) and is killed on drop; every test takes a few seconds.

mod common;

use std::path::Path;
use std::process::{Command, Output, Stdio};

use common::{BIN, Robot, num, read_rows, square_plan};

fn tmp(name: &str) -> common::test_dir::TestDir {
    common::tmp("robot", name)
}

fn drive(addr: &str, args: &[&str]) -> Output {
    common::drive(addr, "2", args)
}

/// (t, x, y) of a plan CSV, and its position at time t (linear between samples).
struct PlanXY(Vec<(f64, f64, f64)>);
impl PlanXY {
    fn load(path: &Path) -> Self {
        PlanXY(
            read_rows(path)
                .iter()
                .map(|r| (num(r, "t"), num(r, "x"), num(r, "y")))
                .collect(),
        )
    }
    fn at(&self, t: f64) -> (f64, f64) {
        let p = &self.0;
        let i = p.partition_point(|s| s.0 <= t).clamp(1, p.len() - 1);
        let (a, b) = (p[i - 1], p[i]);
        let s = ((t - a.0) / (b.0 - a.0)).clamp(0.0, 1.0);
        (a.1 + s * (b.1 - a.1), a.2 + s * (b.2 - a.2))
    }
}

/// Largest distance between `(xk, yk)` of the trajectory-mode rows and the plan at `plan_time`.
fn max_deviation(
    rows: &[std::collections::HashMap<String, String>],
    plan: &PlanXY,
    xk: &str,
    yk: &str,
) -> (f64, usize) {
    let mut m = 0.0f64;
    let mut n = 0;
    for r in rows.iter().filter(|r| r["mode"] == "trajectory") {
        let (x, y) = plan.at(num(r, "plan_time"));
        m = m.max((num(r, xk) - x).hypot(num(r, yk) - y));
        n += 1;
    }
    (m, n)
}

#[test]
fn square_plan_is_followed_over_the_link() {
    let dir = tmp("square");
    let plan_csv = square_plan(&dir);
    let log = dir.join("robot.csv");
    let tele = dir.join("telemetry.csv");
    let robot = Robot::start(&["--max-time", "24", "--log", log.to_str().unwrap()]);
    let out = drive(
        &robot.addr,
        &[
            "plan",
            plan_csv.to_str().unwrap(),
            "--out",
            tele.to_str().unwrap(),
        ],
    );
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("uploaded plan") && stdout.contains("plan done"),
        "{stdout}"
    );
    let summary = robot.summary();
    assert_eq!(summary["plan"]["done"], true);
    assert_eq!(summary["link"]["dropped"], 0);
    assert_eq!(summary["rejected"], 0);

    let plan = PlanXY::load(&plan_csv);
    // Telemetry (f32 on the wire) against the plan: disturbances off → near exact.
    let (dev, n) = max_deviation(&read_rows(&tele), &plan, "x", "y");
    println!("ideal plant: telemetry pose vs plan: max {dev:.2e} m over {n} frames");
    assert!(n > 200, "only {n} telemetry frames in trajectory mode");
    assert!(dev < 1e-4, "telemetry deviates {dev} m from the plan");
    // The simulator's true pose, every control cycle.
    let (dev, n) = max_deviation(&read_rows(&log), &plan, "true_x", "true_y");
    println!("ideal plant: true pose vs plan: max {dev:.2e} m over {n} cycles");
    assert!(n >= 1600 && dev < 1e-4, "{dev} m over {n}");
    let tp = &summary["true_pose"];
    assert!(tp[0].as_f64().unwrap().abs() < 1e-4 && tp[1].as_f64().unwrap().abs() < 1e-4);
}

/// A plan whose start is 0.5 m from the robot: without --set-pose, `drive plan` refuses it
/// (stdin is not a terminal, so it cannot ask) and the robot does not move; --yes drives it.
#[test]
fn a_plan_far_from_the_robot_is_asked_for() {
    let dir = tmp("far");
    let square = square_plan(&dir);
    // The square moved 0.5 m along +x (the robot starts at the origin).
    let text = std::fs::read_to_string(&square).unwrap();
    let mut lines = text.lines();
    let head = lines.next().unwrap();
    let ix = head.split(',').position(|c| c == "x").unwrap();
    let mut far = format!("{head}\n");
    for l in lines {
        let mut c: Vec<String> = l.split(',').map(str::to_string).collect();
        c[ix] = (c[ix].parse::<f64>().unwrap() + 0.5).to_string();
        far.push_str(&c.join(","));
        far.push('\n');
    }
    let far_csv = dir.join("far.csv");
    std::fs::write(&far_csv, far).unwrap();
    let robot = Robot::start(&["--max-time", "24"]);
    let out = drive(&robot.addr, &["plan", far_csv.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains(
            "is 0.500 m from the plan's start (0.500, 0.000), more than --start-tolerance 0.1 m"
        ) && err.contains("--set-pose")
            && err.contains("--yes"),
        "{err}"
    );
    assert!(!String::from_utf8_lossy(&out.stdout).contains("uploaded plan"));
    // A larger tolerance, or --yes: driven (the robot first drives itself to the start).
    let out = drive(&robot.addr, &["plan", far_csv.to_str().unwrap(), "--yes"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("--yes: driving anyway"));
    let summary = robot.summary();
    assert_eq!(summary["plan"]["done"], true);
    let tp = &summary["true_pose"];
    assert!(
        (tp[0].as_f64().unwrap() - 0.5).abs() < 0.05 && tp[1].as_f64().unwrap().abs() < 0.05,
        "ends at the far square's start: {tp}"
    );
}

/// An e-stop at speed stops the wheels at once: braking the robot commanded, not a collision
/// (it was reported as one: `faults estop|collision`, `events: {collisions: 1}`). The obstacle
/// test in mcap.rs keeps a real blow at exactly one.
#[test]
fn an_estop_at_speed_is_no_collision() {
    let robot = Robot::start(&["--max-time", "40"]);
    let a = robot.addr.clone();
    // A drive at 0.3 m/s (8x real time), e-stopped by a second operator while it moves.
    let mut moving = Command::new(BIN)
        .args(["drive", "--connect", &a, "--timeout", "2"])
        .args(["velocity", "--vx", "0.3", "--for", "5"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(800));
    let out = drive(&a, &["estop"]);
    let _ = moving.kill();
    let _ = moving.wait();
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("mode estop"), "{s}");
    assert!(!s.contains("collision"), "{s}");
    let summary = robot.summary();
    let tp = &summary["true_pose"];
    assert!(tp[0].as_f64().unwrap() > 0.1, "it was moving: {tp}");
    assert_eq!(summary["events"]["collisions"], 0, "{summary}");
}

#[test]
fn hardware_disturbances_odometry_follows_truth_drifts() {
    let dir = tmp("hardware");
    let plan_csv = square_plan(&dir);
    let log = dir.join("robot.csv");
    let robot = Robot::start(&[
        "--max-time",
        "24",
        "--log",
        log.to_str().unwrap(),
        "--disturbances",
        "hardware",
    ]);
    assert!(
        drive(&robot.addr, &["plan", plan_csv.to_str().unwrap()])
            .status
            .success()
    );
    robot.summary();
    let plan = PlanXY::load(&plan_csv);
    let rows = read_rows(&log);
    let (est, _) = max_deviation(&rows, &plan, "x", "y");
    let (truth, _) = max_deviation(&rows, &plan, "true_x", "true_y");
    println!("hardware profile: estimate vs plan {est:.4} m, truth vs plan {truth:.4} m");
    // Pose feedback keeps the *estimate* on the path despite stepper quantisation, lag and
    // speed fluctuation; what the encoders cannot see (radius errors, floor slip, shell spin)
    // moves the true pose, within the paper's "7 % of the distance" (1.6 m → 0.11 m).
    assert!(est < 1e-3, "estimate {est}");
    assert!(truth > est && truth < 0.05, "truth {truth}");
}

#[test]
fn an_estop_in_the_robots_log_is_marked_by_evaluate() {
    // The robot's --log has a `mode` column; evaluated as a tracked run (its x, y: the
    // estimate), each change into `estop` becomes a mark on the plan's clock, in metrics.json
    // and in the figure.
    let dir = tmp("estop-log");
    let plan_csv = square_plan(&dir);
    let log = dir.join("robot.csv");
    let robot = Robot::start(&["--max-time", "24", "--log", log.to_str().unwrap()]);
    assert!(
        drive(&robot.addr, &["plan", plan_csv.to_str().unwrap()])
            .status
            .success()
    );
    assert!(drive(&robot.addr, &["estop"]).status.success());
    assert!(drive(&robot.addr, &["clear"]).status.success());
    robot.summary();
    let out = dir.join("eval");
    let run = std::process::Command::new(BIN)
        .args(["evaluate", "--plan"])
        .args([&plan_csv, &log])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    assert!(err.contains("e-stops (from the runs' mode column"), "{err}");
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap()).unwrap();
    let stops = m["evaluation"]["estops"].as_array().unwrap();
    assert_eq!(stops.len(), 1, "{m}");
    // After the plan had ended, at rest near its end point.
    let plan = PlanXY::load(&plan_csv);
    let (t_end, x_end, y_end) = *plan.0.last().unwrap();
    let t = stops[0]["t"].as_f64().unwrap();
    assert!(
        t > t_end - 0.1,
        "e-stop at plan time {t}, the plan ends at {t_end}"
    );
    let (x, y) = (
        stops[0]["x"].as_f64().unwrap(),
        stops[0]["y"].as_f64().unwrap(),
    );
    assert!((x - x_end).hypot(y - y_end) < 0.01, "({x}, {y})");
    let svg = std::fs::read_to_string(out.join("figure.svg")).unwrap();
    // On the path's panel only: the time panels cover the plan's time, the stop came after it.
    assert_eq!(
        svg.matches("\ne-stop\n").count(),
        1,
        "the path's legend names the mark"
    );
}

#[test]
fn velocity_stop_estop_and_clear() {
    let dir = tmp("velocity");
    let tele = dir.join("v.csv");
    let robot = Robot::start(&["--max-time", "40"]);
    let a = robot.addr.clone();
    let out = drive(&a, &["hello"]);
    assert!(
        String::from_utf8_lossy(&out.stdout)
            .contains("protocol 4, model Sphere, plan capacity 4096")
    );
    let out = drive(
        &a,
        &[
            "velocity",
            "--vx",
            "0.2",
            "--vy",
            "-0.1",
            "--for",
            "0.4",
            "--out",
            tele.to_str().unwrap(),
        ],
    );
    assert!(out.status.success());
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("mode idle"), "{s}");
    let rows = read_rows(&tele);
    let fastest = rows.iter().map(|r| num(r, "cmd_vx")).fold(0.0, f64::max);
    assert!((fastest - 0.2).abs() < 1e-6, "{fastest}");
    let last = rows.last().unwrap();
    assert!(num(last, "x") > 0.05 && num(last, "y") < -0.02);

    let out = drive(&a, &["estop"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("mode estop"));
    // Latched: a velocity command is rejected.
    let out = drive(&a, &["velocity", "--vx", "0.1", "--for", "0.2"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("did not take the command"));
    let out = drive(&a, &["clear"]);
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("mode idle") && s.contains("history none"), "{s}");
    assert!(
        drive(&a, &["velocity", "--yaw-rate", "0.5", "--for", "0.2"])
            .status
            .success()
    );
    assert!(drive(&a, &["stop"]).status.success());
}

#[test]
fn wrong_key_is_dropped_and_nothing_moves() {
    let dir = tmp("keys");
    let k1 = dir.join("robot.key");
    let k2 = dir.join("other.key");
    std::fs::write(&k1, "0123456789abcdef0123456789abcdef\n").unwrap();
    std::fs::write(&k2, "fedcba9876543210fedcba9876543210\n").unwrap();
    // 6 s of wall time: each rejected drive waits its 2 s timeout.
    let robot = Robot::start(&["--max-time", "48", "--key", k1.to_str().unwrap()]);
    let a = robot.addr.clone();
    // Right key: works.
    let out = drive(&a, &["--key", k1.to_str().unwrap(), "hello"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("authenticated"));
    // Wrong key and no key: the Hello is dropped, no session opens, the robot never moves, and
    // drive names the cause (the robot answers its v1 probe, so it is there and speaks v2).
    for (key, cause) in [
        (Some(&k2), "--key is not the robot's key"),
        (None, "requires a key"),
    ] {
        let mut args = vec![];
        if let Some(k) = key {
            args.extend(["--key", k.to_str().unwrap()]);
        }
        args.extend(["velocity", "--vx", "0.3", "--for", "0.3"]);
        let out = drive(&a, &args);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("authentication failed") && err.contains(cause),
            "{err}"
        );
    }
    let s = robot.summary();
    println!("{s}");
    let auth = s["link"]["auth"].as_u64().unwrap();
    let version = s["link"]["version"].as_u64().unwrap();
    assert!(auth >= 20, "auth drops {auth}");
    assert!(version >= 2, "the v1 probes: {version}");
    let throttled = s["link"]["throttled"].as_u64().unwrap();
    assert_eq!(
        s["link"]["dropped"].as_u64().unwrap(),
        auth + version + throttled,
        "every drop is an auth drop, a v1 probe or a Hello over the sender's rate"
    );
    assert_eq!(
        s["link"]["sessions"], 1,
        "only the right key opened a session"
    );
    assert_eq!(s["true_pose"][0], 0.0);
    assert_eq!(s["mode"], "idle");
}

#[test]
fn bad_arguments_name_the_field() {
    let out = Command::new(BIN)
        .args(["robot", "--robot", "sphere-omni", "--listen", "127.0.0.1:1"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("--sim is required"));
    let out = Command::new(BIN)
        .args([
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            "nowhere",
        ])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("--listen: expected HOST:PORT"));
    let out = Command::new(BIN)
        .args([
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            "127.0.0.1:0",
            "--watchdog",
            "-1",
        ])
        .output()
        .unwrap();
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--watchdog: must be finite and > 0"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Unauthenticated off loopback: refused unless --insecure, which warns at start-up.
    let out = Command::new(BIN)
        .args([
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            "0.0.0.0:0",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("without --key") && err.contains("--insecure"),
        "{err}"
    );
    let out = Command::new(BIN)
        .args([
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            "0.0.0.0:0",
        ])
        .args(["--insecure", "--max-time", "0.05", "--time-scale", "8"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("the link is UNAUTHENTICATED"), "{err}");
    let dir = tmp("badkey");
    let k = dir.join("short.key");
    std::fs::write(&k, "short").unwrap();
    let out = Command::new(BIN)
        .args([
            "drive",
            "--connect",
            "127.0.0.1:9",
            "--key",
            k.to_str().unwrap(),
            "stop",
        ])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("key must be 16 to 64 bytes"));
    let out = Command::new(BIN)
        .args([
            "drive",
            "--connect",
            "127.0.0.1:9",
            "velocity",
            "--vx",
            "-0.1",
            "--for",
            "0.1",
            "--timeout",
            "0.3",
        ])
        .output()
        .unwrap();
    // Negative values straight after a flag parse (conventions); no robot there: a clear error.
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("no answer from the robot"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = Command::new(BIN)
        .args(["drive", "--connect", "127.0.0.1:9", "teleop"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("interactive terminal"));
}

/// A straight plan at 0.1 m/s along +x for 1.5 s, in the plan CSV of `wheels` wheels: for
/// mecanum and swerve4 (r = 0.05 m) the inverse of a pure `vx` is `vx / r` = 2 rad/s on every
/// wheel with the swerve modules at 0 rad, written out here.
fn straight_plan(dir: &Path, wheels: usize, steer: bool) -> std::path::PathBuf {
    let mut head = String::from("t,x,y,heading,vx,vy,yaw_rate");
    for i in 1..=wheels {
        head.push_str(&format!(",w{i}"));
    }
    if steer {
        for p in ["s", "sd"] {
            for i in 1..=wheels {
                head.push_str(&format!(",{p}{i}"));
            }
        }
    }
    let mut text = head + "\n";
    for k in 0..=150 {
        let t = k as f64 * 0.01;
        let mut row = format!("{t},{},0,0,0.1,0,0", 0.1 * t);
        row.push_str(&",2".repeat(wheels));
        if steer {
            row.push_str(&",0".repeat(2 * wheels));
        }
        text.push_str(&row);
        text.push('\n');
    }
    let p = dir.join(format!("straight{wheels}.csv"));
    std::fs::write(&p, text).unwrap();
    p
}

/// `robot --sim` of the N-wheel kinds with `drive velocity` and a plan upload. Needs the
/// N-wheel plant step of the simulator (branch `sim-n`), which this branch does not have yet.
#[test]
fn mecanum_and_swerve_drive_velocity_and_plans_over_the_link() {
    for (name, wheels, steer) in [("mecanum", 4, false), ("swerve4", 4, true)] {
        let dir = tmp(&format!("kinds-{name}"));
        let tele = dir.join("v.csv");
        let robot = Robot::start_robot(name, &["--max-time", "30"]);
        let a = robot.addr.clone();
        let out = drive(
            &a,
            &[
                "velocity",
                "--vx",
                "0.2",
                "--vy",
                "-0.1",
                "--yaw-rate",
                "0.3",
                "--for",
                "0.6",
                "--out",
                tele.to_str().unwrap(),
            ],
        );
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let rows = read_rows(&tele);
        assert!(
            rows[0].contains_key(&format!("w{wheels}")),
            "{name}: wheel columns"
        );
        // One column per wheel the robot has, steer columns only for kinds with steer motors.
        assert!(!rows[0].contains_key(&format!("w{}", wheels + 1)), "{name}");
        assert!(!rows[0].contains_key(&format!("q{}", wheels + 1)), "{name}");
        assert_eq!(rows[0].contains_key(&format!("s{wheels}")), steer, "{name}");
        assert_eq!(rows[0].contains_key("s1"), steer, "{name}");
        let fastest = rows.iter().map(|r| num(r, "vx")).fold(0.0, f64::max);
        assert!(
            (fastest - 0.2).abs() < 2e-3,
            "{name}: measured vx {fastest}"
        );
        let last = rows.last().unwrap();
        assert!(num(last, "x") > 0.05, "{name}: moved");

        let plan = straight_plan(&dir, wheels, steer);
        let ptele = dir.join("p.csv");
        let out = drive(
            &a,
            &[
                "plan",
                plan.to_str().unwrap(),
                "--set-pose",
                "--out",
                ptele.to_str().unwrap(),
            ],
        );
        let s = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success() && s.contains("plan done"),
            "{name}: {s}"
        );
        let summary = robot.summary();
        assert_eq!(summary["plan"]["done"], true, "{name}");
        assert_eq!(summary["rejected"], 0, "{name}");
        // Driving within the limits is no collision (the event detector's thresholds are the
        // robot file's [events] defaults), and no slip for mecanum. The swerve's modules start
        // each motion from rest pointing elsewhere: while they steer (k_steer = 20/s, ~0.1 s)
        // the wheels already drive and scrub — a real slip of the plant, reported once per
        // start from rest (the velocity command and the plan: at most 2).
        let ev = &summary["events"];
        assert_eq!(ev["collisions"], 0, "{name}: {ev}");
        let slips = ev["slips"].as_u64().unwrap();
        assert!(if steer { slips <= 2 } else { slips == 0 }, "{name}: {ev}");
    }
}
