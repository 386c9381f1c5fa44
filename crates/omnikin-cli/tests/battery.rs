//! The bad-input battery (issue 12, observations 4–9): the built `omnikin` binary is run with
//! every odd input we know of — files that are also outputs, existing outputs, directories as
//! files, empty/garbage/BOM files, NaN/inf/huge/negative numbers in every numeric flag,
//! out-of-range durations and thread counts, a full or closed stdout — each under a wall-clock
//! limit (a hang is a failure: the process is killed) and a 3 GiB address-space limit
//! (`prlimit --as`, as in the issue). Every run must end with exit status 0, or non-zero with
//! an `error:` message on stderr; never `panicked at`, never a signal death, and no input file
//! may change (compared byte for byte before and after).
//!
//! Two tests split the cases: [`battery_own_lane`] (output rules, durations, plots, stdout,
//! threads, and the number sweep) and [`battery_limits_and_metrics`] (observations 5, 6, 7 and
//! 9: memory and work bounds, hangs, quadratic metrics, quietly wrong inputs).

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_omnikin");

/// Address-space limit of every run (the 3 GiB).
const AS_LIMIT: u64 = 3 << 30;

/// Wall-clock limit of a run: long enough for a debug build on a busy 2-core machine, short
/// enough that a hang fails the battery quickly.
const WALL: Duration = Duration::from_secs(20);

/// Where the command's stdout goes.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Stdout {
    /// A file (read afterwards).
    File,
    /// `/dev/full`: every write fails with ENOSPC.
    Full,
    /// A pipe whose reader is already closed: writes fail with EPIPE.
    Closed,
}

/// What a case must end with (besides the battery's rules).
#[derive(Clone, Debug)]
enum Expect {
    /// Exit status 0.
    Ok,
    /// A non-zero exit and stderr containing every one of these (case-insensitive).
    Err(Vec<&'static str>),
    /// Either, as long as the battery's rules hold.
    Any,
    /// The conventional quiet exit of a closed pipe: 141.
    BrokenPipe,
}

/// One run of the binary.
#[derive(Clone, Debug)]
struct Case {
    name: String,
    args: Vec<String>,
    stdout: Stdout,
    expect: Expect,
}

fn case(name: impl Into<String>, args: &[&str], expect: Expect) -> Case {
    Case {
        name: name.into(),
        args: args.iter().map(|s| s.to_string()).collect(),
        stdout: Stdout::File,
        expect,
    }
}

fn err(parts: &[&'static str]) -> Expect {
    Expect::Err(parts.to_vec())
}

/// The outcome of a run.
struct Run {
    code: Option<i32>,
    signal: Option<i32>,
    timed_out: bool,
    stderr: String,
}

/// Runs `args` under the limits; stdout per `stdout`, stderr captured.
fn run(dir: &Path, args: &[String], stdout: Stdout) -> Run {
    let mut cmd = if which("prlimit") {
        let mut c = Command::new("prlimit");
        c.arg(format!("--as={AS_LIMIT}")).arg("--").arg(BIN);
        c
    } else {
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(|| {
            eprintln!(
                "note: prlimit (util-linux) not found: the battery runs without the 3 GiB limit"
            )
        });
        Command::new(BIN)
    };
    cmd.args(args).current_dir(dir).stdin(Stdio::null());
    let err_path = dir.join(format!(".stderr-{}", std::process::id()));
    cmd.stderr(std::fs::File::create(&err_path).unwrap());
    match stdout {
        Stdout::File => {
            cmd.stdout(std::fs::File::create(dir.join(".stdout")).unwrap());
        }
        Stdout::Full => {
            cmd.stdout(
                std::fs::OpenOptions::new()
                    .write(true)
                    .open("/dev/full")
                    .unwrap(),
            );
        }
        Stdout::Closed => {
            // A pipe without a reader from the start: the first write fails with EPIPE.
            let (reader, writer) = std::io::pipe().unwrap();
            drop(reader);
            cmd.stdout(writer);
        }
    }
    let mut child = cmd.spawn().expect("spawn omnikin");
    let start = Instant::now();
    let mut timed_out = false;
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > WALL {
            timed_out = true;
            let _ = child.kill();
            break child.wait().unwrap();
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    use std::os::unix::process::ExitStatusExt;
    Run {
        code: status.code(),
        signal: status.signal(),
        timed_out,
        stderr: std::fs::read_to_string(&err_path).unwrap_or_default(),
    }
}

fn which(prog: &str) -> bool {
    std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).any(|d| d.join(prog).is_file()))
        .unwrap_or(false)
}

/// Every regular file under `dir` (the fixtures: all of them are inputs of some case).
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let m = std::fs::symlink_metadata(&p).unwrap();
            if m.is_dir() {
                stack.push(p);
            } else if m.is_file() {
                out.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

/// Runs each case in a fresh copy of the fixtures and returns the failures (one line each).
/// `extra` writes more fixtures into `in/` first.
fn battery(tag: &str, cases: &[Case], extra: Option<fn(&Path)>) -> Vec<String> {
    let mut failures = Vec::new();
    for (i, c) in cases.iter().enumerate() {
        // A directory per test and case: the two battery tests run in parallel.
        let dir = fixtures(&format!("{tag}-{i:03}"));
        if let Some(f) = extra {
            f(&dir);
        }
        let protected = snapshot(&dir.join("in"));
        let r = run(&dir, &c.args, c.stdout);
        let mut why = Vec::new();
        if r.timed_out {
            why.push(format!("did not finish within {WALL:?} (a hang)"));
        } else if let Some(s) = r.signal {
            why.push(format!("killed by signal {s}"));
        }
        if r.stderr.contains("panicked at") || r.code == Some(101) {
            why.push("panicked".into());
        }
        let lower = r.stderr.to_lowercase();
        match (&c.expect, r.code) {
            (_, None) => {}
            (Expect::BrokenPipe, Some(code)) if code != 141 => {
                why.push(format!(
                    "exit {code}, expected the quiet 141 of a closed pipe"
                ));
            }
            (Expect::Ok, Some(code)) if code != 0 => {
                why.push(format!("exit {code}, expected 0"));
            }
            (Expect::Err(_), Some(0)) => why.push("exit 0, expected an error".into()),
            (Expect::Err(parts), Some(_)) => {
                for p in parts {
                    if !lower.contains(&p.to_lowercase()) {
                        why.push(format!("stderr lacks \"{p}\""));
                    }
                }
            }
            _ => {}
        }
        if let Some(code) = r.code
            && code != 0
            && !matches!(c.expect, Expect::BrokenPipe)
            && !lower.contains("error")
        {
            why.push(format!("exit {code} without an error message"));
        }
        let after = snapshot(&dir.join("in"));
        for (p, bytes) in &protected {
            match after.iter().find(|(q, _)| q == p) {
                Some((_, b)) if b == bytes => {}
                Some(_) => why.push(format!("input {} changed", p.display())),
                None => why.push(format!("input {} disappeared", p.display())),
            }
        }
        if !why.is_empty() {
            failures.push(format!(
                "[{}] omnikin {}: {}\n    stderr: {}",
                c.name,
                c.args.join(" "),
                why.join("; "),
                r.stderr
                    .trim()
                    .lines()
                    .take(4)
                    .collect::<Vec<_>>()
                    .join("\n            ")
            ));
        }
    }
    failures
}

const WAYPOINTS: &str = "x,y\n0,0\n0.3,0\n0.3,0.3\n";
const TRACK: &str = "t,x,y\n0,0,0\n1,0.05,0\n2,0.1,0.01\n3,0.2,0.02\n";
const FIXES: &str = "t,x,y\n0.05,0,0\n0.1,0.001,0\n";

fn encoder_log() -> String {
    let mut s = String::from("t,q1,q2,q3\n");
    for k in 0..20 {
        let t = k as f64 * 0.01;
        s.push_str(&format!("{t},{},{},{}\n", 0.5 * t, -0.3 * t, 0.2 * t));
    }
    s
}

/// A plan made once by the binary itself (the square of paper 000), shared by all cases.
fn plan_csv() -> &'static str {
    static PLAN: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    PLAN.get_or_init(|| {
        let out = Command::new(BIN)
            .args(["plan", "square", "--robot", "sphere-omni", "--rate", "20"])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    })
}

/// A fresh working directory: `in/` holds every input (checked unchanged after each run),
/// `out/` is an empty output directory, `full/` a non-empty one.
fn fixtures(name: &str) -> TestDir {
    let d = TestDir::new("battery", name);
    let i = d.join("in");
    std::fs::create_dir_all(i.join("dir")).unwrap();
    std::fs::create_dir_all(d.join("out")).unwrap();
    std::fs::create_dir_all(d.join("full")).unwrap();
    std::fs::write(d.join("full/keep.txt"), "not ours\n").unwrap();
    let w = |n: &str, s: &[u8]| std::fs::write(i.join(n), s).unwrap();
    w("P.csv", WAYPOINTS.as_bytes());
    w(
        "P.toml",
        b"[[waypoint]]\nx = 0\ny = 0\n[[waypoint]]\nx = 0.3\ny = 0\n",
    );
    w("plan.csv", plan_csv().as_bytes());
    w("track.csv", TRACK.as_bytes());
    w("log.csv", encoder_log().as_bytes());
    w("fixes.csv", FIXES.as_bytes());
    w("key", b"0123456789abcdef0123456789abcdef\n");
    w(
        "robot.toml",
        &std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../robots/sphere-omni.toml"
        ))
        .unwrap(),
    );
    w("existing.csv", b"precious,data\n1,2\n");
    w("empty.csv", b"");
    w(
        "garbage.bin",
        &(0..=255u8).cycle().take(3000).collect::<Vec<_>>(),
    );
    w("bom.csv", "\u{feff}x,y\n0,0\n0.3,0\n".as_bytes());
    w("header_only.csv", b"t,x,y\n");
    w("log_no_q3.csv", b"t,q1,q2\n0,0,0\n0.1,0.1,0.1\n");
    w("track_no_y.csv", b"t,x\n0,0\n1,1\n");
    w("nan_track.csv", b"t,x,y\n0,0,0\n1,NaN,0\n2,inf,0\n");
    w(
        "huge_track.csv",
        b"t,x,y\n0,0,0\n1,1e300,0\n2,-1e300,1e300\n",
    );
    w("crlf.csv", b"x,y\r\n0,0\r\n0.3,0\r\n");
    w("dir/runs.csv", TRACK.as_bytes());
    std::os::unix::fs::symlink(i.join("P.csv"), i.join("link-to-P.csv")).unwrap();
    std::fs::hard_link(i.join("P.csv"), i.join("hardlink-to-P.csv")).unwrap();
    d
}

/// `plan square` with the preset and an output file.
fn square(extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = ["plan", "square", "--robot", "sphere-omni", "--rate", "20"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    v.extend(extra.iter().map(|s| s.to_string()));
    v
}

fn owned(name: impl Into<String>, args: Vec<String>, expect: Expect) -> Case {
    Case {
        name: name.into(),
        args,
        stdout: Stdout::File,
        expect,
    }
}

/// The cases this branch fixes (output rules, durations, plots, stdout, threads) plus the
/// odd inputs every command must survive.
fn own_cases() -> Vec<Case> {
    sweep_cases()
        .into_iter()
        .filter(|c| !PENDING_NUMBERS.contains(&c.name.as_str()))
        .collect()
}

/// Cases of the number sweep whose fix is a memory bound in planning (`input-limits`):
/// without it each asks for 4 GiB and aborts under the 3 GiB limit.
const PENDING_NUMBERS: &[&str] = &[
    "number: plan square --ramp-fraction \"1e-308\"",
    "number: plan waypoints --spin \"1e308\"",
    "number: plan waypoints --spin \"-1e308\"",
    "number: plan waypoints --max-accel \"1e308\"",
    "number: plan waypoints --max-jerk \"1e-308\"",
    "number: plan circle --omega \"1e-308\"",
    "number: plan waypoints --max-speed \"1e-308\"",
];

/// Every case of this branch's lane, including the few of [`PENDING_NUMBERS`].
fn sweep_cases() -> Vec<Case> {
    let mut v = Vec::new();
    let input_rule = || err(&["is also the input", "never overwritten"]);
    let exists_rule = || err(&["exists", "--force"]);
    // Observation 4: an output that is also an input.
    v.push(case(
        "4: plan waypoints P.csv --out P.csv",
        &[
            "plan",
            "waypoints",
            "in/P.csv",
            "--robot",
            "sphere-omni",
            "--out",
            "in/P.csv",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: --out P.csv --force still refuses an input",
        &[
            "plan",
            "waypoints",
            "in/P.csv",
            "--robot",
            "sphere-omni",
            "--out",
            "in/P.csv",
            "--force",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: --plot naming the input",
        &[
            "plan",
            "waypoints",
            "in/P.csv",
            "--robot",
            "sphere-omni",
            "--out",
            "out/p.csv",
            "--plot",
            "in/P.csv",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: --out a symlink to the input",
        &[
            "plan",
            "waypoints",
            "in/P.csv",
            "--robot",
            "sphere-omni",
            "--out",
            "in/link-to-P.csv",
            "--force",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: --out a hard link to the input",
        &[
            "plan",
            "waypoints",
            "in/P.csv",
            "--robot",
            "sphere-omni",
            "--out",
            "in/hardlink-to-P.csv",
            "--force",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: --out the robot file",
        &[
            "plan",
            "square",
            "--robot",
            "in/robot.toml",
            "--out",
            "in/robot.toml",
            "--force",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: --out a toml waypoint file via ./",
        &[
            "plan",
            "waypoints",
            "in/P.toml",
            "--robot",
            "sphere-omni",
            "--out",
            "./in/../in/P.toml",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: odometry --out LOG",
        &[
            "odometry",
            "in/log.csv",
            "--robot",
            "sphere-omni",
            "--out",
            "in/log.csv",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: odometry --plot LOG",
        &[
            "odometry",
            "in/log.csv",
            "--robot",
            "sphere-omni",
            "--out",
            "out/p.csv",
            "--plot",
            "in/log.csv",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: odometry --out the fixes",
        &[
            "odometry",
            "in/log.csv",
            "--robot",
            "sphere-omni",
            "--fixes",
            "in/fixes.csv",
            "--out",
            "in/fixes.csv",
            "--force",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: robot --log naming the robot file",
        &[
            "robot",
            "--sim",
            "--robot",
            "in/robot.toml",
            "--listen",
            "127.0.0.1:0",
            "--max-time",
            "0.1",
            "--log",
            "in/robot.toml",
            "--force",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: robot --log naming the key",
        &[
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--key",
            "in/key",
            "--listen",
            "127.0.0.1:0",
            "--max-time",
            "0.1",
            "--log",
            "in/key",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: drive plan P --out P",
        &[
            "drive",
            "--connect",
            "127.0.0.1:9",
            "plan",
            "in/plan.csv",
            "--out",
            "in/plan.csv",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: drive telemetry --out the key",
        &[
            "drive",
            "--connect",
            "127.0.0.1:9",
            "--key",
            "in/key",
            "telemetry",
            "--out",
            "in/key",
        ],
        input_rule(),
    ));
    v.push(case(
        "4: evaluate --out DIR --force holding a track named like an output",
        &[
            "evaluate",
            "--plan",
            "in/plan.csv",
            "in/dir/runs.csv",
            "--out",
            "in/dir",
            "--force",
        ],
        input_rule(),
    ));
    // Observation 4: existing outputs and directories.
    v.push(owned(
        "4: plan --out existing",
        square(&["--out", "in/existing.csv"]),
        exists_rule(),
    ));
    v.push(owned(
        "4: plan --plot existing",
        square(&["--out", "out/a.csv", "--plot", "in/existing.csv"]),
        exists_rule(),
    ));
    v.push(case(
        "4: odometry --out existing",
        &[
            "odometry",
            "in/log.csv",
            "--robot",
            "sphere-omni",
            "--out",
            "in/existing.csv",
        ],
        exists_rule(),
    ));
    v.push(case(
        "4: robot --log existing",
        &[
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            "127.0.0.1:0",
            "--max-time",
            "0.1",
            "--log",
            "in/existing.csv",
        ],
        exists_rule(),
    ));
    v.push(case(
        "4: drive telemetry --out existing",
        &[
            "drive",
            "--connect",
            "127.0.0.1:9",
            "telemetry",
            "--out",
            "in/existing.csv",
            "--for",
            "0",
        ],
        exists_rule(),
    ));
    v.push(owned(
        "4: --out X --plot X",
        square(&["--out", "out/x", "--plot", "out/./x"]),
        err(&["same file"]),
    ));
    v.push(owned(
        "4: plan --out a directory",
        square(&["--out", "out"]),
        err(&["is a directory"]),
    ));
    v.push(owned(
        "4: plan --out into a missing directory",
        square(&["--out", "nowhere/x.csv"]),
        err(&["--out", "nowhere"]),
    ));
    v.push(owned(
        "4: plan --out /dev/null is written, not replaced",
        square(&["--out", "/dev/null"]),
        Expect::Ok,
    ));
    v.push(case(
        "4: simulate --out a non-empty directory",
        &[
            "simulate",
            "in/plan.csv",
            "--robot",
            "sphere-omni",
            "--trials",
            "1",
            "--out",
            "full",
        ],
        err(&["not empty", "--force"]),
    ));
    v.push(case(
        "4: evaluate --out a non-empty directory",
        &[
            "evaluate",
            "--plan",
            "in/plan.csv",
            "in/track.csv",
            "--out",
            "full",
        ],
        err(&["not empty", "--force"]),
    ));
    v.push(case(
        "4: reproduce --out a non-empty directory",
        &["reproduce", "sphere-2019", "--trials", "1", "--out", "full"],
        err(&["not empty", "--force"]),
    ));
    v.push(case(
        "4: simulate --out a file",
        &[
            "simulate",
            "in/plan.csv",
            "--robot",
            "sphere-omni",
            "--trials",
            "1",
            "--out",
            "in/existing.csv",
            "--force",
        ],
        err(&["not a directory"]),
    ));
    v.push(case(
        "4: evaluate into an empty directory works",
        &[
            "evaluate",
            "--plan",
            "in/plan.csv",
            "in/track.csv",
            "--out",
            "out",
        ],
        Expect::Ok,
    ));
    // Observation 8: durations from user values.
    for (flag, vals) in [
        (
            "--timeout",
            &["1e300", "1e-300", "-1", "0", "NaN", "inf", "3601"][..],
        ),
        (
            "--heartbeat",
            &["1e-300", "1e300", "-1", "0", "NaN", "inf"][..],
        ),
    ] {
        for val in vals {
            v.push(case(
                format!("8: drive {flag} {val}"),
                &["drive", "--connect", "127.0.0.1:9", flag, val, "hello"],
                err(&[flag]),
            ));
        }
    }
    for val in ["1e300", "-1", "NaN", "inf", "604801"] {
        v.push(case(
            format!("8: drive velocity --for {val}"),
            &[
                "drive",
                "--connect",
                "127.0.0.1:9",
                "velocity",
                "--vx",
                "0.1",
                "--for",
                val,
            ],
            err(&["--for"]),
        ));
        v.push(case(
            format!("8: drive telemetry --for {val}"),
            &[
                "drive",
                "--connect",
                "127.0.0.1:9",
                "telemetry",
                "--out",
                "out/t.csv",
                "--for",
                val,
            ],
            err(&["--for"]),
        ));
    }
    for (flag, vals) in [
        ("--time-scale", &["1e-300", "1e300", "0", "-1", "NaN"][..]),
        ("--rate", &["1e-300", "1e9", "1e300", "0", "-1", "inf"][..]),
        ("--telemetry-rate", &["1e-300", "1e300", "0"][..]),
    ] {
        for val in vals {
            v.push(case(
                format!("8/6: robot {flag} {val}"),
                &[
                    "robot",
                    "--sim",
                    "--robot",
                    "sphere-omni",
                    "--listen",
                    "127.0.0.1:0",
                    "--max-time",
                    "0.2",
                    flag,
                    val,
                ],
                err(&[flag]),
            ));
        }
    }
    v.push(case(
        "8: robot --watchdog 1e300 (robot time, no wait): runs",
        &[
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            "127.0.0.1:0",
            "--max-time",
            "0.2",
            "--time-scale",
            "10",
            "--watchdog",
            "1e300",
        ],
        Expect::Any,
    ));
    // Observation 6: plot ticks and thread counts.
    v.push(case(
        "6: evaluate --tracking-offset 1e308,0 (plot ticks)",
        &[
            "evaluate",
            "--plan",
            "in/plan.csv",
            "in/track.csv",
            "--tracking-offset",
            "1e308,0",
            "--out",
            "out",
        ],
        // Refused at the flag (it used to hang in the plot's tick loop).
        err(&["--tracking-offset", "within"]),
    ));
    v.push(case(
        "6: evaluate --tracking-offset -1e300,1e300",
        &[
            "evaluate",
            "--plan",
            "in/plan.csv",
            "in/track.csv",
            "--tracking-offset",
            "-1e300,1e300",
            "--out",
            "out",
        ],
        err(&["--tracking-offset", "within"]),
    ));
    v.push(case(
        "8: evaluate a track of 1e300s (plot range)",
        &[
            "evaluate",
            "--plan",
            "in/plan.csv",
            "in/huge_track.csv",
            "--out",
            "out",
        ],
        Expect::Any,
    ));
    v.push(case(
        "8: evaluate a track with NaN/inf",
        &[
            "evaluate",
            "--plan",
            "in/plan.csv",
            "in/nan_track.csv",
            "--out",
            "out",
        ],
        Expect::Any,
    ));
    for val in ["100000", "0", "-1", "1e3", "x"] {
        v.push(case(
            format!("6: simulate --threads {val}"),
            &[
                "simulate",
                "in/plan.csv",
                "--robot",
                "sphere-omni",
                "--trials",
                "1",
                "--threads",
                val,
                "--out",
                "out",
            ],
            threads_err(val),
        ));
        v.push(case(
            format!("6: reproduce --threads {val}"),
            &[
                "reproduce",
                "sphere-2019",
                "--trials",
                "1",
                "--threads",
                val,
                "--out",
                "out",
            ],
            threads_err(val),
        ));
    }
    // Observation 8: stdout that fails.
    let full: [&[&str]; 9] = [
        &["check", "sphere-omni"],
        &["check", "caster3", "--json"],
        &["inverse", "sphere-omni", "--vx", "0.1"],
        &["forward", "ballbot", "--wheel-rates", "1,2,3"],
        &["torques", "ballbot", "--model", "1,0,0"],
        &["plan", "square", "--robot", "sphere-omni"],
        &[
            "plan",
            "circle",
            "--robot",
            "sphere-omni",
            "--omega",
            "0.5",
            "--format",
            "json",
        ],
        &["--help"],
        &["--version"],
    ];
    for args in full {
        let mut c = case(
            format!("8: stdout /dev/full: {}", args.join(" ")),
            args,
            err(&["stdout"]),
        );
        c.stdout = Stdout::Full;
        v.push(c);
        let mut c = case(
            format!("8: stdout closed: {}", args.join(" ")),
            args,
            Expect::BrokenPipe,
        );
        c.stdout = Stdout::Closed;
        v.push(c);
    }
    let mut c = case(
        "8: stdout /dev/full: robot summary",
        &[
            "robot",
            "--sim",
            "--robot",
            "sphere-omni",
            "--listen",
            "127.0.0.1:0",
            "--max-time",
            "0.1",
            "--time-scale",
            "10",
        ],
        err(&["stdout"]),
    );
    c.stdout = Stdout::Full;
    v.push(c);
    // Odd files where an input is expected: every command that reads one.
    let file_inputs: [(&str, &[&str]); 7] = [
        (
            "plan waypoints",
            &[
                "plan",
                "waypoints",
                "@",
                "--robot",
                "sphere-omni",
                "--out",
                "out/x.csv",
            ],
        ),
        (
            "simulate",
            &[
                "simulate",
                "@",
                "--robot",
                "sphere-omni",
                "--trials",
                "1",
                "--out",
                "out",
            ],
        ),
        (
            "evaluate plan",
            &["evaluate", "--plan", "@", "in/track.csv", "--out", "out"],
        ),
        (
            "evaluate track",
            &["evaluate", "--plan", "in/plan.csv", "@", "--out", "out"],
        ),
        (
            "odometry log",
            &[
                "odometry",
                "@",
                "--robot",
                "sphere-omni",
                "--out",
                "out/p.csv",
            ],
        ),
        (
            "odometry fixes",
            &[
                "odometry",
                "in/log.csv",
                "--robot",
                "sphere-omni",
                "--fixes",
                "@",
                "--out",
                "out/p.csv",
            ],
        ),
        ("check robot file", &["check", "@"]),
    ];
    for (what, args) in file_inputs {
        for file in [
            "in/empty.csv",
            "in/garbage.bin",
            "in/header_only.csv",
            "in/dir",
            "in/missing.csv",
            "in/crlf.csv",
        ] {
            let a: Vec<String> = args
                .iter()
                .map(|s| {
                    if *s == "@" {
                        file.to_string()
                    } else {
                        s.to_string()
                    }
                })
                .collect();
            v.push(owned(format!("odd file: {what} {file}"), a, Expect::Any));
        }
    }
    for (what, args) in [
        (
            "simulate --disturbances",
            &[
                "simulate",
                "in/plan.csv",
                "--robot",
                "sphere-omni",
                "--trials",
                "1",
                "--out",
                "out",
                "--disturbances",
                "@",
            ][..],
        ),
        (
            "robot --key",
            &[
                "robot",
                "--sim",
                "--robot",
                "sphere-omni",
                "--listen",
                "127.0.0.1:0",
                "--max-time",
                "0.1",
                "--key",
                "@",
            ][..],
        ),
        (
            "drive --key",
            &[
                "drive",
                "--connect",
                "127.0.0.1:9",
                "--key",
                "@",
                "--timeout",
                "0.2",
                "hello",
            ][..],
        ),
        ("plan --robot FILE", &["plan", "square", "--robot", "@"][..]),
    ] {
        // An empty disturbance profile is valid (all defaults); the other files are errors.
        for file in ["in/empty.csv", "in/garbage.bin", "in/dir"] {
            let expect = if file.ends_with("empty.csv") && what.contains("disturbances") {
                Expect::Any
            } else {
                err(&[])
            };
            let a: Vec<String> = args
                .iter()
                .map(|s| {
                    if *s == "@" {
                        file.to_string()
                    } else {
                        s.to_string()
                    }
                })
                .collect();
            v.push(owned(format!("odd file: {what} {file}"), a, expect));
        }
    }
    // Directories where an output file is expected, and link addresses that are files.
    for (what, args) in [
        (
            "odometry --out",
            &[
                "odometry",
                "in/log.csv",
                "--robot",
                "sphere-omni",
                "--out",
                "in/dir",
            ][..],
        ),
        (
            "robot --log",
            &[
                "robot",
                "--sim",
                "--robot",
                "sphere-omni",
                "--listen",
                "127.0.0.1:0",
                "--max-time",
                "0.1",
                "--log",
                "out",
            ][..],
        ),
        (
            "drive telemetry --out",
            &[
                "drive",
                "--connect",
                "127.0.0.1:9",
                "telemetry",
                "--out",
                "out",
                "--for",
                "0",
            ][..],
        ),
        (
            "plan --plot",
            &["plan", "square", "--robot", "sphere-omni", "--plot", "out"][..],
        ),
    ] {
        v.push(owned(
            format!("directory as output: {what}"),
            args.iter().map(|s| s.to_string()).collect(),
            err(&["is a directory"]),
        ));
    }
    for addr in [
        "serial:in/P.csv",
        "serial:in/dir",
        "serial:",
        "serial:/dev/null@0",
        "[::1",
        "127.0.0.1:99999",
        "",
    ] {
        v.push(case(
            format!("odd address: drive --connect {addr:?}"),
            &["drive", "--connect", addr, "--timeout", "0.2", "hello"],
            err(&[]),
        ));
        v.push(case(
            format!("odd address: robot --listen {addr:?}"),
            &[
                "robot",
                "--sim",
                "--robot",
                "sphere-omni",
                "--listen",
                addr,
                "--max-time",
                "0.1",
            ],
            err(&[]),
        ));
    }
    // A full disk: every output to /dev/full is an error naming the flag.
    for (what, args, flag) in [
        (
            "plan --out",
            &[
                "plan",
                "square",
                "--robot",
                "sphere-omni",
                "--out",
                "/dev/full",
            ][..],
            "--out",
        ),
        (
            "plan --plot",
            &[
                "plan",
                "square",
                "--robot",
                "sphere-omni",
                "--out",
                "out/a.csv",
                "--plot",
                "/dev/full",
            ][..],
            "--plot",
        ),
        (
            "odometry --out",
            &[
                "odometry",
                "in/log.csv",
                "--robot",
                "sphere-omni",
                "--out",
                "/dev/full",
            ][..],
            "--out",
        ),
        (
            "robot --log",
            &[
                "robot",
                "--sim",
                "--robot",
                "sphere-omni",
                "--listen",
                "127.0.0.1:0",
                "--max-time",
                "0.5",
                "--time-scale",
                "10",
                "--log",
                "/dev/full",
            ][..],
            "--log",
        ),
        (
            "drive telemetry --out",
            &[
                "drive",
                "--connect",
                "127.0.0.1:9",
                "telemetry",
                "--out",
                "/dev/full",
                "--for",
                "0",
                "--timeout",
                "0.2",
            ][..],
            "--out",
        ),
    ] {
        v.push(owned(
            format!("full disk: {what} /dev/full"),
            args.iter().map(|s| s.to_string()).collect(),
            err(&[flag]),
        ));
    }
    // More numbers: counts, seeds, poses, thresholds.
    for (what, args) in [
        (
            "odometry --counts-per-rev 0",
            &[
                "odometry",
                "in/log.csv",
                "--robot",
                "sphere-omni",
                "--counts-per-rev",
                "0",
                "--out",
                "out/p.csv",
            ][..],
        ),
        (
            "odometry --counts-per-rev 1e9",
            &[
                "odometry",
                "in/log.csv",
                "--robot",
                "sphere-omni",
                "--counts-per-rev",
                "1e9",
                "--out",
                "out/p.csv",
            ][..],
        ),
        (
            "odometry --initial-pose 1e308",
            &[
                "odometry",
                "in/log.csv",
                "--robot",
                "sphere-omni",
                "--initial-pose",
                "1e308,-1e308,1e308",
                "--out",
                "out/p.csv",
            ][..],
        ),
        (
            "odometry --initial-pose 1e308 --plot",
            &[
                "odometry",
                "in/log.csv",
                "--robot",
                "sphere-omni",
                "--initial-pose",
                "1e308,0,0",
                "--out",
                "out/p.csv",
                "--plot",
                "out/p.svg",
            ][..],
        ),
        (
            "simulate --trials 0",
            &[
                "simulate",
                "in/plan.csv",
                "--robot",
                "sphere-omni",
                "--trials",
                "0",
                "--out",
                "out",
            ][..],
        ),
        (
            "simulate --trials 1e9",
            &[
                "simulate",
                "in/plan.csv",
                "--robot",
                "sphere-omni",
                "--trials",
                "1000000000",
                "--out",
                "out",
            ][..],
        ),
        (
            "simulate --seed -1",
            &[
                "simulate",
                "in/plan.csv",
                "--robot",
                "sphere-omni",
                "--trials",
                "1",
                "--seed",
                "-1",
                "--out",
                "out",
            ][..],
        ),
        (
            "reproduce --trials 0",
            &["reproduce", "sphere-2019", "--trials", "0", "--out", "out"][..],
        ),
        (
            "reproduce --rate NaN",
            &[
                "reproduce",
                "sphere-2019",
                "--trials",
                "1",
                "--rate",
                "NaN",
                "--out",
                "out",
            ][..],
        ),
        (
            "evaluate --motion-threshold 1e308",
            &[
                "evaluate",
                "--plan",
                "in/plan.csv",
                "in/track.csv",
                "--motion-threshold",
                "1e308",
                "--out",
                "out",
            ][..],
        ),
        (
            "plan --initial-steer on a sphere",
            &[
                "plan",
                "square",
                "--robot",
                "sphere-omni",
                "--initial-steer",
                "1,2,3",
            ][..],
        ),
        (
            "plan caster3 --initial-steer 1e308",
            &[
                "plan",
                "square",
                "--robot",
                "caster3",
                "--initial-steer",
                "1e308,0,0",
                "--rate",
                "20",
            ][..],
        ),
        (
            "drive velocity --vx 1e308",
            &[
                "drive",
                "--connect",
                "127.0.0.1:9",
                "--timeout",
                "0.2",
                "velocity",
                "--vx",
                "1e308",
                "--for",
                "0.1",
            ][..],
        ),
        (
            "drive teleop --speed NaN",
            &[
                "drive",
                "--connect",
                "127.0.0.1:9",
                "teleop",
                "--speed",
                "NaN",
            ][..],
        ),
    ] {
        v.push(owned(
            format!("number: {what}"),
            args.iter().map(|s| s.to_string()).collect(),
            Expect::Any,
        ));
    }
    v.push(case(
        "missing column: odometry without q3",
        &[
            "odometry",
            "in/log_no_q3.csv",
            "--robot",
            "sphere-omni",
            "--out",
            "out/p.csv",
        ],
        err(&["q3"]),
    ));
    v.push(case(
        "missing column: evaluate track without y",
        &[
            "evaluate",
            "--plan",
            "in/plan.csv",
            "in/track_no_y.csv",
            "--out",
            "out",
        ],
        err(&[]),
    ));
    // Numbers in every numeric flag: NaN, infinities, huge, tiny, negative, zero, not a number.
    // (Magnitudes whose fix is a memory or time bound are in the pending list.)
    let odd = [
        "NaN", "inf", "-inf", "-1", "0", "abc", "", "1e308", "-1e308", "1e-308",
    ];
    let numeric: Vec<(&str, &[&str])> = vec![
        ("inverse --vx", &["inverse", "sphere-omni", "--vx", "@"]),
        (
            "inverse --heading",
            &[
                "inverse",
                "caster3",
                "--world",
                "--heading",
                "@",
                "--vx",
                "0.1",
            ],
        ),
        (
            "forward --wheel-rates",
            &["forward", "sphere-omni", "--wheel-rates", "1,@,3"],
        ),
        (
            "torques --yaw",
            &["torques", "ballbot", "--model", "1,2,3", "--yaw", "@"],
        ),
        (
            "plan square --side",
            &["plan", "square", "--robot", "sphere-omni", "--side", "@"],
        ),
        (
            "plan square --speed",
            &["plan", "square", "--robot", "sphere-omni", "--speed", "@"],
        ),
        (
            "plan circle --omega",
            &["plan", "circle", "--robot", "sphere-omni", "--omega", "@"],
        ),
        (
            "plan waypoints --max-speed",
            &[
                "plan",
                "waypoints",
                "in/P.csv",
                "--robot",
                "sphere-omni",
                "--max-speed",
                "@",
            ],
        ),
        (
            "evaluate --motion-threshold",
            &[
                "evaluate",
                "--plan",
                "in/plan.csv",
                "in/track.csv",
                "--motion-threshold",
                "@",
                "--out",
                "out",
            ],
        ),
        (
            "odometry --fix-std",
            &[
                "odometry",
                "in/log.csv",
                "--robot",
                "sphere-omni",
                "--fixes",
                "in/fixes.csv",
                "--fix-std",
                "@",
                "--out",
                "out/p.csv",
            ],
        ),
        (
            "odometry --gyro-bias",
            &[
                "odometry",
                "in/log.csv",
                "--robot",
                "sphere-omni",
                "--imu",
                "--gyro-bias",
                "@",
                "--out",
                "out/p.csv",
            ],
        ),
        (
            "robot --max-speed",
            &[
                "robot",
                "--sim",
                "--robot",
                "sphere-omni",
                "--listen",
                "127.0.0.1:0",
                "--max-time",
                "0.1",
                "--time-scale",
                "10",
                "--max-speed",
                "@",
            ],
        ),
    ];
    // The remaining numeric flags, one representative command each.
    const SQ: &[&str] = &["plan", "square", "--robot", "sphere-omni", "--rate", "20"];
    const WP: &[&str] = &[
        "plan",
        "waypoints",
        "in/P.csv",
        "--robot",
        "sphere-omni",
        "--rate",
        "20",
    ];
    const CI: &[&str] = &[
        "plan",
        "circle",
        "--robot",
        "sphere-omni",
        "--omega",
        "0.5",
        "--rate",
        "20",
    ];
    const RB: &[&str] = &[
        "robot",
        "--sim",
        "--robot",
        "sphere-omni",
        "--listen",
        "127.0.0.1:0",
        "--max-time",
        "0.1",
        "--time-scale",
        "10",
    ];
    const DV: &[&str] = &[
        "drive",
        "--connect",
        "127.0.0.1:9",
        "--timeout",
        "0.2",
        "velocity",
        "--for",
        "0.1",
    ];
    let more: &[(&[&str], &[&str])] = &[
        (SQ, &["--ramp-fraction"]),
        (CI, &["--radius"]),
        (CI, &["--turns"]),
        (CI, &["--ramp"]),
        (WP, &["--corners", "fillet", "--fillet-radius"]),
        (WP, &["--heading"]),
        (WP, &["--spin"]),
        (WP, &["--heading-law", "tangent", "--heading-offset"]),
        (WP, &["--max-accel"]),
        (WP, &["--profile", "s-curve", "--max-jerk"]),
        (WP, &["--max-yaw-rate"]),
        (WP, &["--max-yaw-accel"]),
        (&["inverse", "sphere-omni"], &["--vy"]),
        (&["inverse", "sphere-omni"], &["--yaw-rate"]),
        (&["inverse", "ballbot"], &["--shell-spin"]),
        (&["inverse", "caster3", "--steer"], &[]),
        (
            &[
                "forward",
                "caster3",
                "--wheel-rates",
                "1,1,1",
                "--steer-rates",
            ],
            &[],
        ),
        (
            &[
                "forward",
                "caster3",
                "--wheel-rates",
                "1,1,1",
                "--steer-rates",
                "0,0,0",
                "--steer",
            ],
            &[],
        ),
        (
            &["forward", "sphere-omni", "--wheel-rates", "1,1,1"],
            &["--heading"],
        ),
        (
            &["forward", "sphere-omni", "--wheel-rates", "1,1,1"],
            &["--shell-spin"],
        ),
        (&["torques", "ballbot", "--wheels"], &[]),
        (
            &[
                "odometry",
                "in/log.csv",
                "--robot",
                "sphere-omni",
                "--out",
                "out/p.csv",
                "--fixes",
                "in/fixes.csv",
            ],
            &["--fix-heading-std"],
        ),
        (RB, &["--max-accel"]),
        (RB, &["--max-yaw-accel"]),
        (RB, &["--max-jerk"]),
        (RB, &["--max-yaw-rate"]),
        (
            &[
                "robot",
                "--sim",
                "--robot",
                "sphere-omni",
                "--listen",
                "127.0.0.1:0",
                "--time-scale",
                "10",
            ],
            &["--max-time"],
        ),
        (RB, &["--watchdog"]),
        (RB, &["--seed"]),
        (DV, &["--vy"]),
        (DV, &["--yaw-rate"]),
        (
            &["drive", "--connect", "127.0.0.1:9", "teleop"],
            &["--turn"],
        ),
    ];
    for (base, flag) in more {
        // The value goes last (after the flag, or completes a triple such as --steer).
        let mut a: Vec<&str> = base.to_vec();
        a.extend_from_slice(flag);
        let is_triple = flag.is_empty();
        for val in odd {
            if flag == &["--max-time"] && val == "1e308" {
                continue; // 1e308 s of robot time is "until stopped", like no --max-time
            }
            let mut args: Vec<String> = a.iter().map(|s| s.to_string()).collect();
            args.push(if is_triple {
                format!("{val},0,0")
            } else {
                val.to_string()
            });
            v.push(owned(
                format!(
                    "number: {} {val:?}",
                    a[..a.len().min(2)].join(" ") + " " + a.last().unwrap()
                ),
                args,
                Expect::Any,
            ));
        }
    }
    for (what, args) in numeric {
        for val in odd {
            let a: Vec<String> = args.iter().map(|s| s.replace('@', val)).collect();
            v.push(owned(format!("number: {what} {val:?}"), a, Expect::Any));
        }
    }
    for val in ["1e308", "-1e308", "1e-308"] {
        for (what, args) in [
            ("inverse --vx", &["inverse", "sphere-omni", "--vx", "@"][..]),
            (
                "forward --wheel-rates",
                &[
                    "forward",
                    "caster3",
                    "--wheel-rates",
                    "@,1,1",
                    "--steer-rates",
                    "0,0,0",
                ][..],
            ),
            (
                "torques --model",
                &["torques", "ballbot", "--model", "@,@,@"][..],
            ),
            (
                "inverse --heading",
                &[
                    "inverse",
                    "sphere-omni",
                    "--world",
                    "--heading",
                    "@",
                    "--vx",
                    "1",
                ][..],
            ),
        ] {
            let a: Vec<String> = args.iter().map(|s| s.replace('@', val)).collect();
            v.push(owned(format!("number: {what} {val}"), a, Expect::Any));
        }
    }
    v
}

/// `--threads -1` is an unknown argument to clap (no negative numbers there); the others name
/// the flag.
fn threads_err(val: &str) -> Expect {
    if val.starts_with('-') {
        err(&["-1"])
    } else {
        err(&["--threads"])
    }
}

/// Observations 5, 6, 7 and 9: memory and work bounds, hangs, quadratic metrics and quietly
/// wrong inputs (with the number-sweep cases that hit a planning memory bound).
#[allow(clippy::vec_init_then_push)] // one case per push, commented by observation
fn pending_other_branches() -> Vec<Case> {
    let mut v: Vec<Case> = sweep_cases()
        .into_iter()
        .filter(|c| PENDING_NUMBERS.contains(&c.name.as_str()))
        .collect();
    assert_eq!(
        v.len(),
        PENDING_NUMBERS.len(),
        "every pending name is a case"
    );
    // Observation 5: unbounded memory under the 3 GiB limit.
    v.push(owned(
        "5: plan --speed 1e-9",
        square(&["--speed", "1e-9"]),
        err(&[]),
    ));
    v.push(owned(
        "5: plan --rate 1e12",
        ["plan", "square", "--robot", "sphere-omni", "--rate", "1e12"]
            .iter()
            .map(|s| s.to_string())
            .collect(),
        err(&["--rate"]),
    ));
    v.push(case(
        "5: circle --omega 1e-9",
        &[
            "plan",
            "circle",
            "--robot",
            "sphere-omni",
            "--omega",
            "1e-9",
        ],
        err(&[]),
    ));
    v.push(case(
        "5: reproduce --rate 1e9",
        &[
            "reproduce",
            "sphere-2019",
            "--trials",
            "1",
            "--rate",
            "1e9",
            "--out",
            "out",
        ],
        err(&[]),
    ));
    v.push(owned(
        "5: plan --side 1e308",
        square(&["--side", "1e308"]),
        err(&[]),
    ));
    v.push(case(
        "5: waypoint heading 1e300",
        &[
            "plan",
            "waypoints",
            "in/heading_1e300.csv",
            "--robot",
            "sphere-omni",
        ],
        err(&[]),
    ));
    v.push(case(
        "5: [limits] max_wheel_rate = 1e-308",
        &["plan", "square", "--robot", "in/tiny_limit.toml"],
        err(&[]),
    ));
    // Observation 6: hangs.
    v.push(case(
        "6: simulate a plan whose last t is 1e300",
        &[
            "simulate",
            "in/plan_t1e300.csv",
            "--robot",
            "sphere-omni",
            "--trials",
            "1",
            "--out",
            "out",
        ],
        err(&[]),
    ));
    // Observation 7: quadratic metrics (100 000 rows must not take minutes).
    v.push(case(
        "7: evaluate 100 000 rows",
        &[
            "evaluate",
            "--plan",
            "in/plan_100k.csv",
            "in/track_100k.csv",
            "--out",
            "out",
        ],
        Expect::Ok,
    ));
    // Observation 9: quietly wrong.
    v.push(case(
        "9: --ramp 1e300 (a 1-sample plan) is an error",
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
        err(&["--ramp"]),
    ));
    v.push(case(
        "9: a 4th azimuth is an error",
        &["check", "in/four_azimuths.toml"],
        err(&["azimuths"]),
    ));
    v.push(case(
        "9: a UTF-8 BOM in waypoints",
        &["plan", "waypoints", "in/bom.csv", "--robot", "sphere-omni"],
        Expect::Ok,
    ));
    v.push(case(
        "9: a run that never moves",
        &[
            "evaluate",
            "--plan",
            "in/plan.csv",
            "in/still_track.csv",
            "--out",
            "out",
        ],
        err(&[]),
    ));
    v
}

/// Extra fixtures of the pending cases (written into `in/` of every pending run).
fn pending_fixtures(dir: &Path) {
    let i = dir.join("in");
    std::fs::write(
        i.join("heading_1e300.csv"),
        "x,y,heading\n0,0,0\n0.3,0,1e300\n",
    )
    .unwrap();
    let robot = std::fs::read_to_string(i.join("robot.toml")).unwrap();
    std::fs::write(
        i.join("tiny_limit.toml"),
        robot.replace("max_wheel_rate = 12.0", "max_wheel_rate = 1e-308"),
    )
    .unwrap();
    std::fs::write(
        i.join("four_azimuths.toml"),
        robot.replace("[0.0, 120.0, 240.0]", "[0.0, 120.0, 240.0, 300.0]"),
    )
    .unwrap();
    let plan = plan_csv();
    let mut lines: Vec<&str> = plan.lines().collect();
    let last = lines.pop().unwrap().to_string();
    let mut cells: Vec<&str> = last.split(',').collect();
    cells[0] = "1e300";
    let mut p = lines.join("\n");
    p.push('\n');
    p.push_str(&cells.join(","));
    p.push('\n');
    std::fs::write(i.join("plan_t1e300.csv"), p).unwrap();
    let mut big_plan = String::from("t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3\n");
    let mut big_track = String::from("t,x,y\n");
    for k in 0..100_000 {
        let t = k as f64 * 0.01;
        let x = 0.001 * k as f64;
        big_plan.push_str(&format!("{t},{x},0,0,0.1,0,0,0,0,0\n"));
        big_track.push_str(&format!("{t},{x},0.001\n"));
    }
    std::fs::write(i.join("plan_100k.csv"), big_plan).unwrap();
    std::fs::write(i.join("track_100k.csv"), big_track).unwrap();
    std::fs::write(i.join("still_track.csv"), "t,x,y\n0,0,0\n1,0,0\n2,0,0\n").unwrap();
}

fn report(failures: &[String], total: usize) {
    assert!(
        failures.is_empty(),
        "{} of {total} battery cases failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn battery_own_lane() {
    let cases = own_cases();
    let failures = battery("own", &cases, None);
    report(&failures, cases.len());
}

#[test]
fn battery_limits_and_metrics() {
    let cases = pending_other_branches();
    let failures = battery("limits", &cases, Some(pending_fixtures));
    report(&failures, cases.len());
}

/// `--force` replaces an existing output (and only then); no temporary file is left behind;
/// in an existing directory only the command's own files are replaced.
#[test]
fn force_replaces_outputs_and_nothing_else() {
    let dir = fixtures("force");
    let run_ok = |args: &[String]| {
        let r = run(&dir, args, Stdout::File);
        assert_eq!(r.code, Some(0), "omnikin {}: {}", args.join(" "), r.stderr);
    };
    let existing = dir.join("in/existing.csv");
    let before = std::fs::read(&existing).unwrap();
    let r = run(&dir, &square(&["--out", "in/existing.csv"]), Stdout::File);
    assert_ne!(r.code, Some(0));
    assert_eq!(
        std::fs::read(&existing).unwrap(),
        before,
        "refused: unchanged"
    );
    run_ok(&square(&["--out", "in/existing.csv", "--force"]));
    let after = std::fs::read_to_string(&existing).unwrap();
    assert!(
        after.starts_with("t,x,y,heading"),
        "replaced by the plan: {after:.40}"
    );
    // Through a symlink, the link stays and its target is the output.
    std::os::unix::fs::symlink("existing.csv", dir.join("in/link.csv")).unwrap();
    run_ok(&square(&[
        "--out",
        "in/link.csv",
        "--force",
        "--side",
        "0.2",
    ]));
    assert!(
        std::fs::symlink_metadata(dir.join("in/link.csv"))
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_ne!(std::fs::read_to_string(&existing).unwrap(), after);
    // An existing, non-empty directory with --force: the command's files, nothing else.
    let args = |force: bool| {
        let mut a: Vec<String> = [
            "evaluate",
            "--plan",
            "in/plan.csv",
            "in/track.csv",
            "--out",
            "full",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        if force {
            a.push("--force".into());
        }
        a
    };
    let r = run(&dir, &args(false), Stdout::File);
    assert_ne!(r.code, Some(0), "{}", r.stderr);
    assert!(
        !dir.join("full/metrics.json").exists(),
        "refused before writing"
    );
    run_ok(&args(true));
    assert!(dir.join("full/metrics.json").exists());
    assert_eq!(
        std::fs::read_to_string(dir.join("full/keep.txt")).unwrap(),
        "not ours\n"
    );
    run_ok(&args(true)); // again: replaces its own files
    // /dev/null stays a device.
    run_ok(&square(&["--out", "/dev/null"]));
    use std::os::unix::fs::FileTypeExt;
    assert!(
        std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device()
    );
    for d in ["in", "full", "out"] {
        for e in std::fs::read_dir(dir.join(d)).unwrap() {
            let n = e.unwrap().file_name().to_string_lossy().to_string();
            assert!(!n.ends_with(".tmp"), "temporary file left: {d}/{n}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Ctrl-C (SIGINT) and SIGTERM during `robot --log`: the loop stops, the log is flushed and
/// moved into place with every row so far, the summary is printed, and the exit status is
/// 128 + the signal.
#[test]
fn robot_log_survives_sigint_and_sigterm() {
    for (sig, status) in [("INT", 130), ("TERM", 143)] {
        let dir = fixtures(&format!("signal-{sig}"));
        let log = dir.join("out/robot.csv");
        let mut child = Command::new(BIN)
            .args([
                "robot",
                "--sim",
                "--robot",
                "sphere-omni",
                "--listen",
                "127.0.0.1:0",
            ])
            .arg("--log")
            .arg(&log)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Wait until the robot has logged some cycles (its temporary log grows), then signal.
        let start = Instant::now();
        loop {
            let grown = std::fs::read_dir(dir.join("out")).unwrap().any(|e| {
                let e = e.unwrap();
                e.file_name().to_string_lossy().ends_with(".tmp") && e.metadata().unwrap().len() > 0
            });
            if grown && start.elapsed() > Duration::from_millis(700) {
                break;
            }
            assert!(start.elapsed() < WALL, "the robot never started logging");
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(
            !log.exists(),
            "the log appears under its name only when complete"
        );
        let killed = Command::new("kill")
            .arg(format!("-{sig}"))
            .arg(child.id().to_string())
            .status()
            .unwrap();
        assert!(killed.success());
        let start = Instant::now();
        let code = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s.code();
            }
            if start.elapsed() > WALL {
                let _ = child.kill();
                panic!("SIG{sig}: the robot did not stop");
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(code, Some(status), "SIG{sig}: {stderr}");
        // A stop that was asked for and carried out is a note, not an error.
        assert!(
            stderr.contains(&format!("note: stopped by SIG{sig}")),
            "{stderr}"
        );
        assert!(!stderr.lines().any(|l| l.starts_with("error:")), "{stderr}");
        let text = std::fs::read_to_string(&log).expect("the log is in place");
        let rows: Vec<&str> = text.lines().collect();
        assert!(rows[0].starts_with("t,x,y,heading"), "{}", rows[0]);
        assert!(rows.len() > 10, "SIG{sig}: only {} rows kept", rows.len());
        let last_t: f64 = rows[rows.len() - 1]
            .split(',')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        let summary: serde_json::Value =
            serde_json::from_slice(&out.stdout).expect("the summary is printed");
        let end = summary["time_s"].as_f64().unwrap();
        // The last row is the last cycle run: nothing buffered was lost.
        assert!(
            (end - last_t - 0.01).abs() < 1e-6,
            "log ends at {last_t}, robot at {end}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Ctrl-C while `drive telemetry --out` waits for a robot: the telemetry log (header and any
/// rows) is moved into place and the exit status is 130.
#[test]
fn drive_log_survives_sigint() {
    let dir = fixtures("drive-signal");
    let log = dir.join("out/telemetry.csv");
    let port = std::net::UdpSocket::bind("127.0.0.1:0").unwrap(); // a robot that never answers
    let addr = port.local_addr().unwrap().to_string();
    let mut child = Command::new(BIN)
        .args([
            "drive",
            "--connect",
            &addr,
            "--timeout",
            "600",
            "telemetry",
            "--for",
            "600",
        ])
        .arg("--out")
        .arg(&log)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Its hello reaches the socket: the process is in its wait loop.
    port.set_read_timeout(Some(WALL)).unwrap();
    let mut buf = [0u8; 512];
    port.recv_from(&mut buf).expect("drive sends hello");
    assert!(!log.exists());
    assert!(
        Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .status()
            .unwrap()
            .success()
    );
    let start = Instant::now();
    let code = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s.code();
        }
        if start.elapsed() > WALL {
            let _ = child.kill();
            panic!("drive did not stop on SIGINT");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let stderr = String::from_utf8_lossy(&child.wait_with_output().unwrap().stderr).to_string();
    assert_eq!(code, Some(130), "{stderr}");
    let text = std::fs::read_to_string(&log).expect("the log is in place");
    assert!(text.starts_with("t,x,y,heading"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Observation 9, the figure's side: a robot name with control characters and markup gives a
/// well-formed SVG (no control character, markup escaped).
#[test]
fn figure_text_from_files_is_valid_svg() {
    let dir = fixtures("svg-text");
    let robot = std::fs::read_to_string(dir.join("in/robot.toml")).unwrap();
    let evil = robot.replace(
        "name = \"sphere-omni\"",
        "name = \"evil <b>&amp; \\u0007 \\u001b[31m x\"",
    );
    assert_ne!(robot, evil);
    std::fs::write(dir.join("in/evil.toml"), evil).unwrap();
    let args: Vec<String> = [
        "plan",
        "square",
        "--robot",
        "in/evil.toml",
        "--rate",
        "20",
        "--out",
        "out/p.csv",
        "--plot",
        "out/p.svg",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let r = run(&dir, &args, Stdout::File);
    if r.code == Some(0) {
        let svg = std::fs::read_to_string(dir.join("out/p.svg")).unwrap();
        let bad: Vec<char> = svg
            .chars()
            .filter(|c| c.is_control() && !matches!(c, '\t' | '\n' | '\r'))
            .collect();
        assert!(bad.is_empty(), "control characters in the SVG: {bad:?}");
        assert!(svg.contains("evil &lt;b&gt;"), "markup escaped");
    } else {
        // Rejecting such a name at the edge (input-limits) is fine too.
        assert!(r.stderr.contains("error"), "{}", r.stderr);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
