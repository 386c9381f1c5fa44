//! Fault injection on the operator link, over loopback UDP: a proxy between `omnikin drive`
//! and `omnikin robot --sim` loses, corrupts, truncates, duplicates and replays datagrams, or
//! cuts the link mid-motion; a hand-made client sends malformed commands and replays. The robot
//! must never panic, never execute what it should not, and count every drop. Robots stop by
//! themselves (`--max-time`), the proxy by a deadline.

use std::net::{SocketAddr, UdpSocket};
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use common::{BIN, Robot, num, read_rows, square_plan};
use omnikin::link::{Endpoint, FrameReader, MAX_FRAME, Message, Telemetry, WirePoint, heapless};
use omnikin::runtime::{Frame, Mode};

mod common;

fn tmp(name: &str) -> PathBuf {
    common::tmp("link", name)
}

fn drive(addr: &str, args: &[&str]) -> Output {
    common::drive(addr, "3", args)
}

fn drive_with(addr: &str, timeout: &str, args: &[&str]) -> Output {
    common::drive(addr, timeout, args)
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// What the proxy does to each operator → robot datagram (mutually exclusive, by probability),
/// and the loss probability of robot → operator datagrams.
#[derive(Clone, Copy, Default)]
struct FaultModel {
    loss: f64,
    corrupt: f64,
    truncate: f64,
    duplicate: f64,
    replay: f64,
    loss_back: f64,
}

#[derive(Clone, Copy, Debug, Default)]
struct ProxyStats {
    forwarded: u64,
    lost: u64,
    corrupted: u64,
    truncated: u64,
    duplicated: u64,
    replayed: u64,
    lost_back: u64,
}

/// A UDP proxy in front of `robot`; `cut` drops everything both ways while set. Runs until
/// `stop` is set or 30 s pass.
fn proxy(
    robot: SocketAddr,
    model: FaultModel,
    cut: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
) -> (String, JoinHandle<ProxyStats>) {
    let front = UdpSocket::bind("127.0.0.1:0").unwrap();
    let back = UdpSocket::bind("127.0.0.1:0").unwrap();
    let addr = front.local_addr().unwrap().to_string();
    front.set_nonblocking(true).unwrap();
    back.set_nonblocking(true).unwrap();
    let h = std::thread::spawn(move || {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut st = ProxyStats::default();
        let mut operator: Option<SocketAddr> = None;
        let mut history: Vec<Vec<u8>> = vec![];
        let mut buf = [0u8; 4096];
        let deadline = Instant::now() + Duration::from_secs(30);
        while !stop.load(Ordering::Relaxed) && Instant::now() < deadline {
            let mut idle = true;
            while let Ok((n, from)) = front.recv_from(&mut buf) {
                idle = false;
                operator = Some(from);
                if cut.load(Ordering::Relaxed) {
                    continue;
                }
                let d = buf[..n].to_vec();
                let r = rng.unit();
                let mut p = model.loss;
                if r < p {
                    st.lost += 1;
                    continue;
                }
                p += model.corrupt;
                if r < p && n > 2 {
                    // Change one byte before the delimiter to another non-zero value, so the
                    // datagram stays exactly one (corrupt) frame.
                    let mut c = d.clone();
                    let i = rng.below(n - 1);
                    let mut v = c[i] ^ (1 + rng.below(255) as u8);
                    if v == 0 {
                        v = c[i] ^ 0x80;
                    }
                    c[i] = v;
                    back.send_to(&c, robot).unwrap();
                    st.corrupted += 1;
                    continue;
                }
                p += model.truncate;
                if r < p && n > 2 {
                    let cut_at = 1 + rng.below(n - 2);
                    back.send_to(&d[..cut_at], robot).unwrap();
                    st.truncated += 1;
                    continue;
                }
                back.send_to(&d, robot).unwrap();
                st.forwarded += 1;
                p += model.duplicate;
                if r < p {
                    back.send_to(&d, robot).unwrap();
                    st.duplicated += 1;
                } else if r < p + model.replay && !history.is_empty() {
                    let old = &history[rng.below(history.len())];
                    back.send_to(old, robot).unwrap();
                    st.replayed += 1;
                }
                history.push(d);
            }
            while let Ok((n, _)) = back.recv_from(&mut buf) {
                idle = false;
                if cut.load(Ordering::Relaxed) {
                    continue;
                }
                if rng.unit() < model.loss_back {
                    st.lost_back += 1;
                    continue;
                }
                if let Some(o) = operator {
                    let _ = front.send_to(&buf[..n], o);
                }
            }
            if idle {
                std::thread::sleep(Duration::from_micros(300));
            }
        }
        st
    });
    (addr, h)
}

fn link_counts(s: &serde_json::Value) -> [u64; 7] {
    [
        "ok",
        "framing",
        "crc",
        "version",
        "auth",
        "replay",
        "malformed",
    ]
    .map(|k| s["link"][k].as_u64().unwrap())
}

#[test]
fn twenty_percent_packet_loss_plan_still_followed() {
    let dir = tmp("loss");
    let plan_csv = square_plan(&dir);
    let robot = Robot::start(&["--max-time", "36", "--watchdog", "2"]);
    let (cut, stop) = (
        Arc::new(AtomicBool::new(false)),
        Arc::new(AtomicBool::new(false)),
    );
    let model = FaultModel {
        loss: 0.2,
        loss_back: 0.2,
        ..Default::default()
    };
    let (addr, h) = proxy(robot.socket_addr(), model, cut, stop.clone());
    let tele = dir.join("t.csv");
    let out = drive(
        &addr,
        &[
            "plan",
            plan_csv.to_str().unwrap(),
            "--out",
            tele.to_str().unwrap(),
        ],
    );
    stop.store(true, Ordering::Relaxed);
    let st = h.join().unwrap();
    println!("proxy: {st:?}");
    assert!(out.status.success());
    let lost = st.lost as f64 / (st.lost + st.forwarded) as f64;
    assert!((0.15..0.25).contains(&lost), "loss rate {lost}");
    let s = robot.summary();
    assert_eq!(s["plan"]["done"], true);
    assert_eq!(
        s["rejected"], 0,
        "a lost chunk is re-sent, never out of place"
    );
    assert_eq!(s["link"]["dropped"], 0, "lost frames never reach the robot");
    // The plan was followed as without loss (feedback is on the robot, not over the link).
    let rows = read_rows(&tele);
    let dev = rows
        .iter()
        .filter(|r| r["mode"] == "trajectory")
        .map(|r| (num(r, "x") - num(r, "ref_x")).hypot(num(r, "y") - num(r, "ref_y")))
        .fold(0.0, f64::max);
    println!(
        "20 % loss: {} telemetry frames, max |pose - reference| {dev:.2e} m",
        rows.len()
    );
    assert!(dev < 1e-4);
}

#[test]
fn corrupt_truncated_duplicated_and_replayed_frames_are_dropped_and_counted() {
    let dir = tmp("corrupt");
    let plan_csv = square_plan(&dir);
    let robot = Robot::start(&["--max-time", "36", "--watchdog", "2"]);
    let (cut, stop) = (
        Arc::new(AtomicBool::new(false)),
        Arc::new(AtomicBool::new(false)),
    );
    let model = FaultModel {
        corrupt: 0.1,
        truncate: 0.1,
        duplicate: 0.1,
        replay: 0.1,
        ..Default::default()
    };
    let (addr, h) = proxy(robot.socket_addr(), model, cut, stop.clone());
    let out = drive(&addr, &["plan", plan_csv.to_str().unwrap()]);
    stop.store(true, Ordering::Relaxed);
    let st = h.join().unwrap();
    println!("proxy: {st:?}");
    assert!(out.status.success());
    let s = robot.summary();
    println!("robot: {s}");
    let [ok, framing, crc, version, auth, replay, malformed] = link_counts(&s);
    assert!(st.corrupted > 20 && st.truncated > 20 && st.duplicated > 20 && st.replayed > 20);
    // Every injected fault is one counted drop, in the right counters; nothing else dropped.
    assert_eq!(replay, st.duplicated + st.replayed);
    assert_eq!(framing + crc + malformed, st.corrupted + st.truncated);
    assert!(framing >= st.truncated);
    assert_eq!(version + auth, 0);
    assert_eq!(ok, st.forwarded);
    // Nothing was executed twice or out of place: no rejected command, the plan completed.
    assert_eq!(s["rejected"], 0);
    assert_eq!(s["plan"]["done"], true);
    let tp = &s["true_pose"];
    assert!(tp[0].as_f64().unwrap().abs() < 1e-4 && tp[1].as_f64().unwrap().abs() < 1e-4);
}

#[test]
fn link_cut_mid_motion_stops_within_watchdog_plus_braking() {
    let dir = tmp("cut");
    let log = dir.join("robot.csv");
    // Watchdog 0.5 s, 1 m/s²: from 0.3 m/s the robot must be at rest 0.5 + 0.3 s after the
    // last valid command (robot time), give or take a control cycle.
    let robot = Robot::start(&[
        "--max-time",
        "8",
        "--watchdog",
        "0.5",
        "--max-accel",
        "1",
        "--log",
        log.to_str().unwrap(),
    ]);
    let (cut, stop) = (
        Arc::new(AtomicBool::new(false)),
        Arc::new(AtomicBool::new(false)),
    );
    let (addr, h) = proxy(
        robot.socket_addr(),
        FaultModel::default(),
        cut.clone(),
        stop.clone(),
    );
    let d = std::thread::spawn(move || {
        drive_with(&addr, "0.5", &["velocity", "--vx", "0.3", "--for", "1.5"])
    });
    std::thread::sleep(Duration::from_millis(500));
    cut.store(true, Ordering::Relaxed);
    let out = d.join().unwrap();
    assert!(
        !out.status.success(),
        "the stop cannot get through a cut link"
    );
    stop.store(true, Ordering::Relaxed);
    h.join().unwrap();
    let s = robot.summary();
    assert!(s["fault_history"].as_str().unwrap().contains("link_lost"));
    let rows = read_rows(&log);
    let last_cmd = rows
        .iter()
        .map(|r| num(r, "last_command_t"))
        .fold(0.0, f64::max);
    let moving_before = rows
        .iter()
        .filter(|r| num(r, "t") < last_cmd)
        .any(|r| (num(r, "cmd_vx") - 0.3).abs() < 1e-9);
    assert!(moving_before, "the robot was at 0.3 m/s before the cut");
    let idle = rows
        .iter()
        .find(|r| num(r, "t") > last_cmd && r["mode"] == "idle")
        .expect("the robot must stop");
    let stop_time = num(idle, "t") - last_cmd;
    println!(
        "link cut: at rest {stop_time:.3} s after the last valid command (watchdog 0.5 s + braking 0.3 s)"
    );
    // The watchdog trips on the first cycle past 0.5 s and braking takes 30 cycles: at most
    // two cycles (and the log's µs rounding) after 0.8 s.
    assert!((0.8..=0.825).contains(&stop_time), "{stop_time}");
    // Braking stayed within the acceleration limit and the plant really stopped.
    let after: Vec<_> = rows
        .iter()
        .filter(|r| num(r, "t") >= num(idle, "t"))
        .collect();
    let (x0, x1) = (
        num(after[0], "true_x"),
        num(after[after.len() - 1], "true_x"),
    );
    assert!(
        (x1 - x0).abs() < 1e-9,
        "still moving after the stop: {x0} → {x1}"
    );
    for w in rows.windows(2) {
        assert!((num(&w[1], "cmd_vx") - num(&w[0], "cmd_vx")).abs() <= 0.01 + 1e-6);
    }
}

/// A hand-made operator: sends frames built with the library, reads telemetry.
struct Client {
    sock: UdpSocket,
    robot: SocketAddr,
    end: Endpoint,
    reader: FrameReader<MAX_FRAME>,
    latest: Option<Telemetry>,
}

impl Client {
    fn new(robot: SocketAddr) -> Self {
        let sock = UdpSocket::bind("127.0.0.1:0").unwrap();
        sock.set_nonblocking(true).unwrap();
        Client {
            sock,
            robot,
            end: Endpoint::new(None, 1_000),
            reader: FrameReader::new(),
            latest: None,
        }
    }
    fn frame(&mut self, m: &Message) -> Vec<u8> {
        let mut buf = [0u8; MAX_FRAME];
        let n = self.end.encode(m, &mut buf).unwrap();
        buf[..n].to_vec()
    }
    fn raw(&mut self, bytes: &[u8]) {
        self.sock.send_to(bytes, self.robot).unwrap();
    }
    fn send(&mut self, m: &Message) {
        let f = self.frame(m);
        self.raw(&f);
    }
    /// Heartbeats and telemetry for `ms` wall milliseconds.
    fn wait(&mut self, ms: u64) -> Telemetry {
        let end = Instant::now() + Duration::from_millis(ms);
        let mut buf = [0u8; 2048];
        while Instant::now() < end {
            self.send(&Message::Heartbeat);
            while let Ok((n, _)) = self.sock.recv_from(&mut buf) {
                let mut got = vec![];
                self.reader.feed(&buf[..n], &mut self.end, |r| got.push(r));
                self.reader.end_of_datagram(&mut self.end);
                for r in got {
                    if let Ok((_, Message::Telemetry(t))) = r {
                        self.latest = Some(t);
                    }
                }
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        self.latest.expect("telemetry")
    }
}

#[test]
fn malformed_and_replayed_commands_are_never_executed() {
    let robot = Robot::start(&["--max-time", "24"]);
    let mut c = Client::new(robot.socket_addr());
    c.send(&Message::Hello { protocol: 1 });
    let t = c.wait(100);
    assert_eq!((t.mode, t.rejected), (Mode::Idle, 0));
    let vel = |vx: f32, yaw_rate: f32| Message::SetVelocity {
        frame: Frame::Robot,
        vx,
        vy: 0.0,
        yaw_rate,
    };
    c.send(&vel(f32::NAN, 0.0));
    c.send(&vel(0.0, f32::INFINITY));
    c.send(&vel(5.0, 0.0)); // beyond --max-speed 2 m/s
    c.send(&vel(0.0, -40.0)); // beyond --max-yaw-rate 10 rad/s
    c.send(&Message::PlanBegin { id: 9, len: 9000 }); // beyond the 4096-point buffer
    c.send(&Message::PlanBegin { id: 9, len: 2 });
    let bad = WirePoint {
        t: 0.0,
        pose: [f32::NAN, 0.0, 0.0],
        twist: [0.0; 3],
    };
    c.send(&Message::PlanChunk {
        id: 9,
        offset: 0,
        points: heapless::Vec::from_slice(&[bad]).unwrap(),
    });
    c.send(&Message::PlanStart { id: 9 }); // incomplete
    c.send(&Message::SetPose {
        x: f32::NAN,
        y: 0.0,
        heading: 0.0,
    });
    let t = c.wait(300);
    assert_eq!(t.rejected, 8, "{t:?}");
    assert_eq!(t.mode, Mode::Idle);
    assert_eq!(t.pose, [0.0; 3]);
    assert!(t.fault_history.contains(omnikin::runtime::Faults::REJECTED));

    // A recorded e-stop replayed after a clear is dropped, not executed.
    let estop = c.frame(&Message::EStop);
    c.raw(&estop);
    assert_eq!(c.wait(100).mode, Mode::EStop);
    c.send(&Message::Clear);
    assert_eq!(c.wait(100).mode, Mode::Idle);
    c.raw(&estop);
    c.raw(&estop);
    let t = c.wait(150);
    assert_eq!(t.mode, Mode::Idle, "a replayed e-stop must not execute");
    assert_eq!(t.link.replay, 2);
    // Garbage and a frame of a foreign protocol version: counted, no effect.
    c.raw(&[0x13; 50]);
    c.raw(&[1, 2, 3, 0]);
    let t = c.wait(100);
    assert_eq!(t.link.dropped(), 4, "{:?}", t.link);
    // And a valid command still works.
    c.send(&vel(0.2, 0.0));
    let t = c.wait(200);
    assert_eq!(t.mode, Mode::Velocity);
    assert!(t.pose[0] > 0.0);
    drop(c);
    let s = robot.summary();
    assert_eq!(s["rejected"], 8);
}

/// Two pseudo-terminals joined by a small Python bridge stand in for a serial cable.
const PTY_BRIDGE: &str = r#"
import os, select, sys, time, tty
a_m, a_s = os.openpty(); b_m, b_s = os.openpty()
for fd in (a_s, b_s): tty.setraw(fd)
for fd in (a_m, b_m): os.set_blocking(fd, False)
print(os.ttyname(a_s), os.ttyname(b_s), flush=True)
end = time.time() + float(sys.argv[1])
while time.time() < end:
    r, _, _ = select.select([a_m, b_m], [], [], 0.1)
    for fd in r:
        try: d = os.read(fd, 4096)
        except OSError: continue
        try: os.write(b_m if fd == a_m else a_m, d)
        except OSError: pass  # nobody reading the other end: bytes are lost, like a cable
"#;

#[test]
fn serial_transport_over_a_pty_pair() {
    use std::io::BufRead;
    let Ok(mut bridge) = Command::new("python3")
        .args(["-c", PTY_BRIDGE, "15"])
        .stdout(Stdio::piped())
        .spawn()
    else {
        eprintln!("SKIPPED: python3 is needed for the pseudo-terminal bridge");
        return;
    };
    let mut line = String::new();
    std::io::BufReader::new(bridge.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let ptys: Vec<&str> = line.split_whitespace().collect();
    assert_eq!(ptys.len(), 2, "bridge printed {line:?}");
    let robot_side = format!("serial:{}@115200", ptys[0]);
    let mut robot = Command::new(BIN)
        .args(["robot", "--sim", "--robot", "caster3", "--time-scale", "8"])
        .args(["--listen", &robot_side, "--max-time", "16"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(150));
    let op = format!("serial:{}", ptys[1]);
    let out = drive(&op, &["hello"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("model Caster"));
    let out = drive(
        &op,
        &["velocity", "--vx", "0.1", "--vy", "0.1", "--for", "0.3"],
    );
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("mode idle"));
    let end = Instant::now() + Duration::from_secs(10);
    while robot.try_wait().unwrap().is_none() && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = robot.kill();
    let _ = bridge.kill();
    let out = robot.wait_with_output().unwrap();
    let _ = bridge.wait();
    let s: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "robot summary: {e}; stderr: {}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    println!("serial: {s}");
    assert_eq!(s["link"]["dropped"], 0);
    let p = &s["true_pose"];
    assert!(p[0].as_f64().unwrap() > 0.1 && p[1].as_f64().unwrap() > 0.1);
}
