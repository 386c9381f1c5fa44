//! MCAP logs (`--mcap` on robot, drive, simulate, odometry) read back with the `mcap` crate's
//! reader: schema names, one message per CSV row on each channel, monotonic log times, values
//! equal to the CSV log's; a file cut mid-way and a robot killed outright still read up to
//! the last complete chunk; `omnikin convert` round trips MCAP ↔ CSV.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{BIN, Robot, num, read_rows, square_plan};
use serde_json::Value;

fn tmp(name: &str) -> common::test_dir::TestDir {
    common::tmp("mcap", name)
}

/// One message as the reader sees it.
#[derive(Debug, Clone, PartialEq)]
struct Msg {
    topic: String,
    schema: String,
    encoding: String,
    log_time: u64,
    data: Vec<u8>,
}

impl Msg {
    /// The message in Foxglove's JSON form, decoded from protobuf: Foxglove's schemas with the
    /// Foxglove SDK's prost types, omnikin's with the declarations below (written from the
    /// `.proto` text of mcap_log/proto.rs, not shared with the writer).
    fn json(&self) -> Value {
        assert_eq!(self.encoding, "protobuf", "{}", self.topic);
        pb::to_json(&self.schema, &self.data)
    }
}

/// An independent protobuf reader of the logs' messages.
mod pb {
    use foxglove::messages as fm;
    use prost::Message;
    use serde_json::{Value, json};

    #[derive(Clone, PartialEq, Message)]
    pub struct WheelRates {
        #[prost(message, optional, tag = "1")]
        pub timestamp: Option<fm::Timestamp>,
        #[prost(float, repeated, tag = "2")]
        pub commanded: Vec<f32>,
        #[prost(float, repeated, tag = "3")]
        pub commanded_steer: Vec<f32>,
        #[prost(float, repeated, tag = "4")]
        pub measured: Vec<f32>,
        #[prost(float, repeated, tag = "5")]
        pub measured_steer: Vec<f32>,
    }

    #[derive(Clone, PartialEq, Message)]
    pub struct LinkCounters {
        #[prost(message, optional, tag = "1")]
        pub timestamp: Option<fm::Timestamp>,
        #[prost(uint64, optional, tag = "2")]
        pub ok: Option<u64>,
        #[prost(uint64, optional, tag = "11")]
        pub dropped: Option<u64>,
        #[prost(uint64, optional, tag = "12")]
        pub rejected: Option<u64>,
    }

    fn ts(t: Option<fm::Timestamp>) -> Value {
        let t = t.expect("a timestamp");
        json!({"sec": t.sec(), "nsec": t.nsec()})
    }

    fn pose(p: &fm::Pose) -> Value {
        let (x, q) = (p.position.unwrap(), p.orientation.unwrap());
        json!({"position": {"x": x.x, "y": x.y, "z": x.z},
               "orientation": {"x": q.x, "y": q.y, "z": q.z, "w": q.w}})
    }

    fn floats(key: &str, a: &[f32], v: &mut Value) {
        if !a.is_empty() {
            v[key] = a.iter().map(|x| f64::from(*x)).collect();
        }
    }

    pub fn to_json(schema: &str, data: &[u8]) -> Value {
        match schema {
            "foxglove.PoseInFrame" => {
                let m = fm::PoseInFrame::decode(data).unwrap();
                json!({"timestamp": ts(m.timestamp), "frame_id": m.frame_id,
                       "pose": pose(&m.pose.unwrap())})
            }
            "foxglove.PosesInFrame" => {
                let m = fm::PosesInFrame::decode(data).unwrap();
                let poses: Vec<Value> = m.poses.iter().map(pose).collect();
                json!({"timestamp": ts(m.timestamp), "frame_id": m.frame_id, "poses": poses})
            }
            "foxglove.FrameTransform" => {
                let m = fm::FrameTransform::decode(data).unwrap();
                let (x, q) = (m.translation.unwrap(), m.rotation.unwrap());
                json!({"timestamp": ts(m.timestamp), "parent_frame_id": m.parent_frame_id,
                       "child_frame_id": m.child_frame_id,
                       "translation": {"x": x.x, "y": x.y, "z": x.z},
                       "rotation": {"x": q.x, "y": q.y, "z": q.z, "w": q.w}})
            }
            "foxglove.Log" => {
                let m = fm::Log::decode(data).unwrap();
                json!({"timestamp": ts(m.timestamp), "level": m.level, "message": m.message,
                       "name": m.name})
            }
            "omnikin.WheelRates" => {
                let m = WheelRates::decode(data).unwrap();
                let mut v = json!({"timestamp": ts(m.timestamp)});
                floats("commanded", &m.commanded, &mut v);
                floats("commanded_steer", &m.commanded_steer, &mut v);
                floats("measured", &m.measured, &mut v);
                floats("measured_steer", &m.measured_steer, &mut v);
                v
            }
            "omnikin.LinkCounters" => {
                let m = LinkCounters::decode(data).unwrap();
                json!({"timestamp": ts(m.timestamp), "ok": m.ok, "dropped": m.dropped,
                       "rejected": m.rejected})
            }
            other => panic!("schema {other}"),
        }
    }
}

/// Every message of `bytes` in file order, and the reader's error if it stopped early.
fn read_bytes(bytes: &[u8]) -> (Vec<Msg>, Option<String>) {
    let mut out = Vec::new();
    for m in mcap::MessageStream::new(bytes).expect("starts like MCAP") {
        match m {
            Ok(m) => out.push(Msg {
                topic: m.channel.topic.clone(),
                schema: m.channel.schema.as_ref().unwrap().name.clone(),
                encoding: m.channel.message_encoding.clone(),
                log_time: m.log_time,
                data: m.data.to_vec(),
            }),
            Err(e) => return (out, Some(e.to_string())),
        }
    }
    (out, None)
}

/// A complete MCAP file: every message, and the summary agrees with them.
fn read(path: &Path) -> Vec<Msg> {
    let bytes = std::fs::read(path).unwrap();
    let (msgs, err) = read_bytes(&bytes);
    assert_eq!(err, None, "{}", path.display());
    let summary = mcap::Summary::read(&bytes)
        .unwrap()
        .expect("a summary section");
    let stats = summary.stats.expect("statistics");
    assert_eq!(stats.message_count, msgs.len() as u64);
    msgs
}

fn on<'a>(msgs: &'a [Msg], topic: &str) -> Vec<&'a Msg> {
    msgs.iter().filter(|m| m.topic == topic).collect()
}

/// Schema of every channel as named in the task, protobuf everywhere, log times never decreasing
/// along the file and along every channel.
fn check_channels(msgs: &[Msg]) -> BTreeMap<String, usize> {
    let mut counts = BTreeMap::new();
    let mut last: BTreeMap<&str, u64> = BTreeMap::new();
    for m in msgs {
        let base = match m.topic.strip_prefix("/trial-") {
            Some(r) => &r[r.find('/').unwrap()..],
            None => &m.topic,
        };
        let want = match base {
            "/pose" | "/truth" | "/reference" => "foxglove.PoseInFrame",
            "/tf" => "foxglove.FrameTransform",
            "/plan" => "foxglove.PosesInFrame",
            "/events" => "foxglove.Log",
            "/wheels" => "omnikin.WheelRates",
            "/link" => "omnikin.LinkCounters",
            t => panic!("unexpected channel {t}"),
        };
        assert_eq!(m.schema, want, "{}", m.topic);
        assert_eq!(m.encoding, "protobuf");
        let prev = last.insert(&m.topic, m.log_time).unwrap_or(0);
        assert!(m.log_time >= prev, "{}: log time goes back", m.topic);
        // The message's own timestamp is its log time.
        let ts = &m.json()["timestamp"];
        let ns = ts["sec"].as_u64().unwrap() * 1_000_000_000 + ts["nsec"].as_u64().unwrap();
        assert_eq!(ns, m.log_time, "{}", m.topic);
        *counts.entry(m.topic.clone()).or_insert(0) += 1;
    }
    counts
}

fn pose_of(m: &Msg) -> (f64, f64, f64) {
    let v = m.json();
    let p = &v["pose"];
    let q = &p["orientation"];
    let h = 2.0 * q["z"].as_f64().unwrap().atan2(q["w"].as_f64().unwrap());
    (
        p["position"]["x"].as_f64().unwrap(),
        p["position"]["y"].as_f64().unwrap(),
        h,
    )
}

/// Equal but for the last bits: JSON numbers are read back by serde_json's fast float parser,
/// which may be one unit in the last place off the value written.
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-14 * a.abs().max(b.abs()) || a == b
}

/// Two CSV files with the same header and cells, numbers equal to 1e-12 (a heading goes
/// through a quaternion and back).
fn same_csv(a: &Path, b: &Path) {
    let (ta, tb) = (
        std::fs::read_to_string(a).unwrap(),
        std::fs::read_to_string(b).unwrap(),
    );
    let (la, lb): (Vec<&str>, Vec<&str>) = (ta.lines().collect(), tb.lines().collect());
    assert_eq!(la.len(), lb.len(), "{}", a.display());
    assert_eq!(la[0], lb[0]);
    for (x, y) in la.iter().zip(&lb) {
        for (c, d) in x.split(',').zip(y.split(',')) {
            match (c.parse::<f64>(), d.parse::<f64>()) {
                (Ok(u), Ok(v)) => assert!((u - v).abs() <= 1e-12 * (1.0 + u.abs()), "{x} / {y}"),
                _ => assert_eq!(c, d, "{x} / {y}"),
            }
        }
    }
}

fn same_angle(a: f64, b: f64, tol: f64) -> bool {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d) <= tol
}

/// Rows' `t` (s) as log times (ns).
fn ns(t: f64) -> u64 {
    (t * 1e9).round() as u64
}

fn run(args: &[&str]) -> std::process::Output {
    let out = Command::new(BIN).args(args).output().unwrap();
    eprintln!(
        "omnikin {args:?}:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// Waits (bounded) until `dir` holds a temporary file of at least `bytes`.
fn wait_for_tmp(dir: &Path, bytes: u64) -> PathBuf {
    let start = Instant::now();
    loop {
        let found = std::fs::read_dir(dir).unwrap().find_map(|e| {
            let e = e.unwrap();
            let n = e.file_name().to_string_lossy().to_string();
            (n.ends_with(".tmp") && n.contains(".mcap.") && e.metadata().unwrap().len() >= bytes)
                .then(|| e.path())
        });
        if let Some(f) = found {
            return f;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the MCAP never grew"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn robot_and_drive_mcap_match_their_csv_logs_and_convert_round_trips() {
    let dir = tmp("robot");
    let (rlog, rmcap) = (dir.join("robot.csv"), dir.join("robot.mcap"));
    let robot = Robot::start_robot(
        "kiwi",
        &["--max-time", "16", "--log", p(&rlog), "--mcap", p(&rmcap)],
    );
    let (dlog, dmcap) = (dir.join("drive.csv"), dir.join("drive.mcap"));
    let out = common::drive(
        &robot.addr,
        "2",
        &[
            "--mcap",
            p(&dmcap),
            "velocity",
            "--vx",
            "0.2",
            "--yaw-rate",
            "0.5",
            "--for",
            "0.3",
            "--out",
            p(&dlog),
        ],
    );
    assert!(out.status.success());
    let out = common::drive(&robot.addr, "2", &["estop"]);
    assert!(out.status.success());
    robot.summary();

    // The robot: one message per row of its CSV log on every per-cycle channel.
    let rows = read_rows(&rlog);
    let msgs = read(&rmcap);
    let counts = check_channels(&msgs);
    for t in ["/pose", "/truth", "/tf", "/wheels", "/link"] {
        assert_eq!(counts[t], rows.len(), "{t}");
    }
    let poses = on(&msgs, "/pose");
    let truth = on(&msgs, "/truth");
    for ((r, m), tm) in rows.iter().zip(&poses).zip(&truth) {
        assert_eq!(m.log_time, ns(num(r, "t")));
        let (x, y, h) = pose_of(m);
        assert!((x - num(r, "x")).abs() < 2e-6 && (y - num(r, "y")).abs() < 2e-6);
        assert!(same_angle(h, num(r, "heading"), 2e-6));
        let (x, y, _) = pose_of(tm);
        assert!((x - num(r, "true_x")).abs() < 2e-6 && (y - num(r, "true_y")).abs() < 2e-6);
    }
    // The robot moved and turned, so the test compares something.
    let last = rows.last().unwrap();
    assert!(num(last, "x").hypot(num(last, "y")) > 0.02, "{last:?}");
    // Commanded wheel rates are the log's w1..w3.
    for (r, m) in rows.iter().zip(on(&msgs, "/wheels")) {
        let c = m.json()["commanded"].clone();
        for i in 0..3 {
            let w = c[i].as_f64().unwrap();
            assert!((w - num(r, &format!("w{}", i + 1))).abs() < 2e-6);
        }
    }
    // Measured rates are the encoders' angle differences: on the ideal plant a wheel turns
    // exactly at the rate commanded in the cycle before.
    let wheels = on(&msgs, "/wheels");
    assert!(
        wheels[0].json().get("measured").is_none(),
        "no rate before two rows"
    );
    let mut moving = 0;
    for (a, b) in wheels.iter().zip(&wheels[1..]) {
        let (c, m) = (a.json()["commanded"].clone(), b.json()["measured"].clone());
        for i in 0..3 {
            let (c, m) = (c[i].as_f64().unwrap(), m[i].as_f64().unwrap());
            // Equal to the f32 precision the rates are written (and sent on the link) in.
            assert!(
                (c - m).abs() <= 2.0 * f64::from(f32::EPSILON) * c.abs().max(1e-3),
                "{} s: wheel {i}: {c} then {m}",
                b.log_time
            );
            moving += usize::from(c.abs() > 0.1);
        }
    }
    assert!(moving > 50, "the wheels turned");
    // /link: frames received and commands rejected, as the log's counters.
    for (r, m) in rows.iter().zip(on(&msgs, "/link")) {
        let v = m.json();
        assert_eq!(v["ok"].as_f64().unwrap(), num(r, "rx_ok"));
        assert_eq!(v["dropped"].as_f64().unwrap(), num(r, "rx_dropped"));
        assert_eq!(v["rejected"].as_f64().unwrap(), num(r, "rejected"));
    }
    // /events: one line per mode change of the log (and the first mode), the e-stop an error
    // at the row where the mode became estop.
    let events = on(&msgs, "/events");
    let mut changes = Vec::new();
    for (i, r) in rows.iter().enumerate() {
        if i == 0 || rows[i - 1]["mode"] != r["mode"] {
            changes.push((ns(num(r, "t")), r["mode"].clone()));
        }
    }
    let mode_events: Vec<(u64, Value)> = events
        .iter()
        .map(|m| (m.log_time, m.json()))
        .filter(|(_, v)| {
            let s = v["message"].as_str().unwrap();
            s.starts_with("mode") || s.starts_with("e-stop")
        })
        .collect();
    assert_eq!(
        mode_events.len(),
        changes.len(),
        "{mode_events:?} {changes:?}"
    );
    for ((t, v), (ct, mode)) in mode_events.iter().zip(&changes) {
        assert_eq!(t, ct);
        let s = v["message"].as_str().unwrap();
        if mode == "estop" {
            assert!(s.starts_with("e-stop") && v["level"] == 4, "{v}");
        } else {
            assert!(s.ends_with(mode.as_str()), "{s} vs {mode}");
        }
    }
    assert!(changes.iter().any(|(_, m)| m == "estop"));

    // The operator: one message per telemetry row.
    let drows = read_rows(&dlog);
    let dmsgs = read(&dmcap);
    let dcounts = check_channels(&dmsgs);
    assert!(drows.len() > 5);
    for t in ["/pose", "/tf", "/wheels", "/link"] {
        assert_eq!(dcounts[t], drows.len(), "{t}");
    }
    for (r, m) in drows.iter().zip(on(&dmsgs, "/pose")) {
        assert_eq!(m.log_time, ns(num(r, "t")));
        let (x, _, _) = pose_of(m);
        assert!((x - num(r, "x")).abs() < 1e-6);
    }

    // convert: MCAP -> CSV -> MCAP -> CSV gives the same files and the same messages.
    let (c1, c2, back) = (dir.join("csv1"), dir.join("csv2"), dir.join("back.mcap"));
    assert!(
        run(&["convert", p(&rmcap), "--csv", p(&c1)])
            .status
            .success()
    );
    assert!(
        run(&["convert", p(&c1), "--mcap", p(&back)])
            .status
            .success()
    );
    assert!(
        run(&["convert", p(&back), "--csv", p(&c2)])
            .status
            .success()
    );
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
            .collect();
        v.sort();
        v
    };
    assert_eq!(
        names(&c1),
        [
            "events.csv",
            "link.csv",
            "pose.csv",
            "tf.csv",
            "truth.csv",
            "wheels.csv"
        ]
    );
    for n in names(&c1) {
        same_csv(&c1.join(&n), &c2.join(&n));
    }
    let again = read(&back);
    assert_eq!(check_channels(&again), counts);
    // pose.csv has the log's columns and rows.
    let pose_rows = read_rows(&c1.join("pose.csv"));
    assert_eq!(pose_rows.len(), rows.len());
    for (a, b) in pose_rows.iter().zip(&rows) {
        assert_eq!(ns(num(a, "t")), ns(num(b, "t")));
        assert!(
            (num(a, "heading") - num(b, "heading")).abs() < 2e-6,
            "unwrapped"
        );
    }
    // The robot's CSV log itself converts to the same channels and events.
    let from_log = dir.join("from-log.mcap");
    assert!(
        run(&["convert", p(&rlog), "--mcap", p(&from_log)])
            .status
            .success()
    );
    let fl = read(&from_log);
    let flc = check_channels(&fl);
    for t in ["/pose", "/truth", "/tf", "/wheels", "/link", "/events"] {
        assert_eq!(flc[t], counts[t], "{t}");
    }
    let texts = |v: &[&Msg]| -> Vec<(u64, Value)> {
        v.iter()
            .map(|m| (m.log_time, m.json()["message"].clone()))
            .collect()
    };
    assert_eq!(texts(&on(&fl, "/events")), texts(&events));
    // Output rules: an existing output is refused without --force, an input always.
    let out = run(&["convert", p(&rlog), "--mcap", p(&from_log)]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--force"));
    let out = run(&["--force", "convert", p(&rlog), "--mcap", p(&rlog)]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("input"));

    // A file cut mid-way reads up to its last complete chunk: a prefix of the full file.
    let bytes = std::fs::read(&rmcap).unwrap();
    let (part, err) = read_bytes(&bytes[..bytes.len() / 2]);
    assert!(err.is_some(), "a cut file ends early");
    assert!(
        !part.is_empty() && part.len() < msgs.len(),
        "{}",
        part.len()
    );
    assert_eq!(part[..], msgs[..part.len()]);
    let cut = dir.join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let out = run(&["convert", p(&cut), "--csv", p(&dir.join("cut"))]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("ends early"));
    // convert reads whole chunks only (its pre-scan ends at the cut chunk; a killed writer
    // leaves none cut, issue 31), the crate's stream also the whole records of a cut one:
    // the CSV is a non-empty prefix of the full file's, at most what the crate streamed.
    let cut_poses = read_rows(&dir.join("cut/pose.csv"));
    let all_poses = read_rows(&c1.join("pose.csv"));
    assert!(!cut_poses.is_empty() && cut_poses.len() <= on(&part, "/pose").len());
    assert_eq!(cut_poses[..], all_poses[..cut_poses.len()]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `drive plan --mcap`: the `/plan` message is stamped at the robot's clock when the plan
/// was sent, within the telemetry's times (issue 33 saw it at 0 while the robot's clock was at
/// 2.05 s; since protocol 3 the session is confirmed by telemetry, so the stamp is known, and
/// `drive plan` now waits for telemetry before it sends anything: this guards both).
#[test]
fn drive_plan_mcap_stamps_the_plan_at_robot_time() {
    let dir = tmp("drive-plan");
    let plan = square_plan(&dir);
    // 40 s of robot time: the plan takes ~17 s after a start that, at 8x real time, moves by
    // 8 s of robot time per second drive takes to start on a loaded machine (24 s was seen to
    // end the robot mid-plan under a load of 12 on 2 cores).
    let robot = Robot::start(&["--max-time", "40"]);
    // Let the robot's clock run (8x real time: about 2.4 s of robot time).
    std::thread::sleep(Duration::from_millis(300));
    let dmcap = dir.join("drive.mcap");
    let out = common::drive(
        &robot.addr,
        "2",
        &["--mcap", p(&dmcap), "plan", p(&plan), "--set-pose"],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    robot.summary();
    let msgs = read(&dmcap);
    let plans = on(&msgs, "/plan");
    assert_eq!(plans.len(), 1);
    let first_pose = on(&msgs, "/pose")[0].log_time;
    assert!(
        first_pose > 1_000_000_000 && plans[0].log_time >= first_pose,
        "/plan at {} ns, first /pose at {first_pose} ns",
        plans[0].log_time
    );
}

#[test]
fn killed_robot_leaves_an_mcap_readable_to_its_last_chunk() {
    let dir = tmp("kill");
    for sig in ["KILL", "TERM"] {
        let out_dir = dir.join(sig);
        std::fs::create_dir_all(&out_dir).unwrap();
        let mcap_path = out_dir.join("robot.mcap");
        let log = out_dir.join("robot.csv");
        let mut child = Command::new(BIN)
            .args([
                "robot",
                "--sim",
                "--robot",
                "kiwi",
                "--listen",
                "127.0.0.1:0",
            ])
            .args([
                "--time-scale",
                "8",
                "--log",
                p(&log),
                "--mcap",
                p(&mcap_path),
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // At least two chunks (64 KiB each) reached the file.
        let tmp_file = wait_for_tmp(&out_dir, 2 * 64 * 1024);
        assert!(!mcap_path.exists());
        assert!(
            Command::new("kill")
                .arg(format!("-{sig}"))
                .arg(child.id().to_string())
                .status()
                .unwrap()
                .success()
        );
        let status = child.wait().unwrap();
        if sig == "KILL" {
            // Killed outright: the temporary file is all there is, cut after a chunk (or
            // within one); the reader gets every message of the complete chunks.
            assert_eq!(status.code(), None);
            let bytes = std::fs::read(&tmp_file).unwrap();
            let (msgs, err) = read_bytes(&bytes);
            assert!(err.is_some(), "no summary after a kill");
            let counts = check_channels(&msgs);
            assert!(counts["/pose"] > 100, "{counts:?}");
            // Whole cycles but for the one a chunk boundary may split.
            for t in ["/truth", "/tf", "/wheels", "/link"] {
                assert!(counts[t].abs_diff(counts["/pose"]) <= 1, "{counts:?}");
            }
            let csv = out_dir.join("csv");
            let out = run(&["convert", p(&tmp_file), "--csv", p(&csv)]);
            assert!(out.status.success());
            assert_eq!(read_rows(&csv.join("pose.csv")).len(), counts["/pose"]);
        } else {
            // SIGTERM: closed properly, under its name, one message per row of the CSV log.
            assert_eq!(status.code(), Some(143));
            let msgs = read(&mcap_path);
            let counts = check_channels(&msgs);
            let rows = read_rows(&log);
            assert_eq!(counts["/pose"], rows.len());
            assert_eq!(counts["/link"], rows.len());
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn simulate_and_odometry_mcap_match_their_csv_outputs() {
    let dir = tmp("sim");
    let plan = square_plan(&dir);
    let out_dir = dir.join("out");
    let smcap = dir.join("sim.mcap");
    let out = run(&[
        "simulate",
        p(&plan),
        "--robot",
        "sphere-omni",
        "--trials",
        "3",
        "--threads",
        "1",
        "--out",
        p(&out_dir),
        "--emit-sensors",
        "--mcap",
        p(&smcap),
        "--mcap-trials",
        "2",
    ]);
    assert!(out.status.success());
    let msgs = read(&smcap);
    let counts = check_channels(&msgs);
    let rows = read_rows(&out_dir.join("trials.csv"));
    let trial = |k: &str| -> Vec<_> { rows.iter().filter(|r| r["trial"] == k).collect() };
    for (k, prefix) in [("0", ""), ("1", "/trial-001")] {
        let tr = trial(k);
        for t in ["/pose", "/truth", "/tf", "/wheels"] {
            assert_eq!(counts[&format!("{prefix}{t}")], tr.len(), "{prefix}{t}");
        }
        for (r, m) in tr.iter().zip(on(&msgs, &format!("{prefix}/truth"))) {
            assert_eq!(m.log_time, ns(num(r, "t")));
            let (x, y, h) = pose_of(m);
            assert!(
                close(x, num(r, "x")) && close(y, num(r, "y")),
                "{x} {y} {r:?}"
            );
            assert!(same_angle(h, num(r, "heading"), 1e-9));
        }
        for (r, m) in tr.iter().zip(on(&msgs, &format!("{prefix}/pose"))) {
            let (x, y, _) = pose_of(m);
            assert!(close(x, num(r, "tracked_x")) && close(y, num(r, "tracked_y")));
        }
    }
    assert!(
        !counts.keys().any(|t| t.starts_with("/trial-002")),
        "{counts:?}"
    );
    // /plan: the plan's path, once.
    let plan_rows = read_rows(&plan);
    let plans = on(&msgs, "/plan");
    assert_eq!(plans.len(), 1);
    let poses = plans[0].json()["poses"].as_array().unwrap().clone();
    assert_eq!(poses.len(), plan_rows.len());
    assert_eq!(
        poses[10]["position"]["x"].as_f64().unwrap(),
        num(&plan_rows[10], "x")
    );

    // odometry over trial 0's encoder log: /pose is the pose CSV, row for row.
    let enc = out_dir.join("sensors/trial-000/encoders.csv");
    let (poses_csv, omcap) = (dir.join("poses.csv"), dir.join("odo.mcap"));
    let out = run(&[
        "odometry",
        p(&enc),
        "--robot",
        "sphere-omni",
        "--out",
        p(&poses_csv),
        "--mcap",
        p(&omcap),
    ]);
    assert!(out.status.success());
    let msgs = read(&omcap);
    let counts = check_channels(&msgs);
    let rows = read_rows(&poses_csv);
    assert_eq!(counts["/pose"], rows.len());
    assert_eq!(counts["/tf"], rows.len());
    for (r, m) in rows.iter().zip(on(&msgs, "/pose")) {
        let (x, y, h) = pose_of(m);
        assert!(
            close(x, num(r, "x")) && close(y, num(r, "y")),
            "{x} {y} {r:?}"
        );
        assert!(same_angle(h, num(r, "heading"), 1e-9));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A simulated obstacle (`robot --obstacle AT:FOR`: the robot stops dead, its wheels blocked)
/// is exactly one collision event at its time, in every record of the run: the robot's CSV
/// log (the `collision` fault flag rises once, `collision_events` counts 1), its MCAP
/// `/events`, the telemetry `drive --out` writes, and the JSON summary — and no slip.
#[test]
fn an_obstacle_is_one_collision_event_in_every_log() {
    let dir = tmp("obstacle");
    let (rlog, rmcap, tele) = (
        dir.join("robot.csv"),
        dir.join("robot.mcap"),
        dir.join("tele.csv"),
    );
    let robot = Robot::start(&[
        "--max-time",
        "16",
        "--obstacle",
        "7:0.5",
        "--log",
        p(&rlog),
        "--mcap",
        p(&rmcap),
    ]);
    let out = common::drive(
        &robot.addr,
        "2",
        &["velocity", "--vx", "0.3", "--for", "1.4", "--out", p(&tele)],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary = robot.summary();
    assert_eq!(summary["events"]["collisions"], 1, "{summary}");
    assert_eq!(summary["events"]["slips"], 0, "{summary}");

    let rows = read_rows(&rlog);
    let flagged = |r: &std::collections::HashMap<String, String>| r["faults"].contains("collision");
    let rises: Vec<f64> = rows
        .windows(2)
        .filter(|w| !flagged(&w[0]) && flagged(&w[1]))
        .map(|w| num(&w[1], "t"))
        .collect();
    assert_eq!(rises.len(), 1, "{rises:?}");
    // Detected within two 10 ms cycles of the obstacle (7 s of robot time), moving at 0.3 m/s.
    assert!(
        (7.0..=7.03).contains(&rises[0]),
        "collision at {}",
        rises[0]
    );
    assert_eq!(num(rows.last().unwrap(), "collision_events"), 1.0);
    assert!(rows.iter().all(|r| num(r, "slip_events") == 0.0));

    let msgs = read(&rmcap);
    let lines: Vec<(f64, String)> = on(&msgs, "/events")
        .iter()
        .map(|m| (m.log_time as f64 * 1e-9, m.json()["message"].to_string()))
        .filter(|(_, text)| text.contains("collision"))
        .collect();
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!((lines[0].0 - rises[0]).abs() < 1e-6, "{lines:?}");

    let trows = read_rows(&tele);
    assert_eq!(num(trows.last().unwrap(), "collision_events"), 1.0);
}

/// Bound on `robot --mcap`'s size per hour of robot time at 100 Hz, bytes: issue 33's 50 MB
/// (JSON messages in zstd chunks measured 58.7 MB moving and 83 MB following a plan;
/// uncompressed JSON was 460 MB).
const MAX_BYTES_PER_HOUR: f64 = 50e6;

/// The MCAP file `path` of a `robot --mcap` run of `max_time` s of robot time: every chunk
/// zstd-compressed without message indexes, at most [`MAX_BYTES_PER_HOUR`].
fn compressed_within_bound(path: &Path, max_time: f64) {
    let bytes = std::fs::read(path).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
    assert!(!summary.chunk_indexes.is_empty());
    let (mut packed, mut plain) = (0, 0);
    for c in &summary.chunk_indexes {
        assert_eq!(c.compression, "zstd", "chunk at {}", c.chunk_start_offset);
        // No message index records (mcap_log/mod.rs: 16 bytes a message, uncompressed).
        assert!(c.message_index_offsets.is_empty());
        packed += c.compressed_size;
        plain += c.uncompressed_size;
    }
    // Compression pays over the file (the last chunk, a few messages, may not shrink).
    assert!(3 * packed < plain, "{packed} of {plain} bytes");
    let per_hour = bytes.len() as f64 * 3600.0 / max_time;
    eprintln!(
        "robot --mcap: {} bytes for {max_time} s, {:.1} MB per hour",
        bytes.len(),
        per_hour / 1e6
    );
    assert!(
        per_hour <= MAX_BYTES_PER_HOUR,
        "{:.1} MB per hour",
        per_hour / 1e6
    );
}

/// `robot --mcap` at 100 Hz following a plan (`/reference` on as well, the largest log: 83 MB
/// per hour as JSON): within [`MAX_BYTES_PER_HOUR`], and the plan was followed to its end.
#[test]
fn robot_mcap_following_a_plan_is_within_the_bound() {
    let dir = tmp("size-plan");
    let plan = square_plan(&dir);
    let rmcap = dir.join("robot.mcap");
    let max_time = 40.0;
    let robot = Robot::start(&["--max-time", "40", "--mcap", p(&rmcap)]);
    let out = common::drive(&robot.addr, "2", &["plan", p(&plan), "--set-pose"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    robot.summary();
    compressed_within_bound(&rmcap, max_time);
    let msgs = read(&rmcap);
    let reference = on(&msgs, "/reference");
    let poses = on(&msgs, "/pose");
    assert!(
        reference.len() * 3 > poses.len(),
        "{} /reference of {} /pose",
        reference.len(),
        poses.len()
    );
}

/// `robot --mcap` at 100 Hz (a moving robot with the hardware profile's sensor noise, so the
/// data is not constant): every chunk zstd-compressed, at most [`MAX_BYTES_PER_HOUR`] per hour
/// of robot time (issue 33: uncompressed JSON was ~460 MB), and `convert` reads the compressed
/// file back to one CSV row per control cycle.
#[test]
fn robot_mcap_is_zstd_compressed_and_converts() {
    let dir = tmp("size");
    let (rlog, rmcap) = (dir.join("robot.csv"), dir.join("robot.mcap"));
    let max_time = 30.0;
    let robot = Robot::start_robot(
        "kiwi",
        &[
            "--max-time",
            "30",
            "--disturbances",
            "hardware",
            "--log",
            p(&rlog),
            "--mcap",
            p(&rmcap),
        ],
    );
    let out = common::drive(
        &robot.addr,
        "2",
        &["velocity", "--vx", "0.2", "--yaw-rate", "0.5", "--for", "1"],
    );
    assert!(out.status.success());
    robot.summary();
    compressed_within_bound(&rmcap, max_time);
    let rows = read_rows(&rlog);
    // 100 Hz: one row per control cycle over the whole run.
    assert!(
        rows.len() as f64 >= 0.99 * 100.0 * max_time,
        "{}",
        rows.len()
    );
    // The compressed file converts: one /pose row per CSV log row, the same poses.
    let csv = dir.join("csv");
    let out = run(&["convert", p(&rmcap), "--csv", p(&csv)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let poses = read_rows(&csv.join("pose.csv"));
    assert_eq!(poses.len(), rows.len());
    for (a, b) in poses.iter().zip(&rows) {
        assert!((num(a, "t") - num(b, "t")).abs() < 1e-9);
        assert!((num(a, "x") - num(b, "x")).abs() < 2e-6);
        assert!((num(a, "y") - num(b, "y")).abs() < 2e-6);
    }
    let last = rows.last().unwrap();
    assert!(
        num(last, "x").hypot(num(last, "y")) > 0.01,
        "the robot moved"
    );
}
