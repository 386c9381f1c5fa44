//! `omnikin console` without a browser: the access rules over real sockets (token, Host,
//! Origin, refusals as 403), and the websocket relay to `omnikin robot --sim` — telemetry
//! reaches the page, dead-man teleop moves the robot and stops when its repeats stop, the
//! e-stop is confirmed, plans are previewed and driven; hostile messages and connections are
//! answered or dropped while the console keeps serving.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::{BIN, Robot};
use serde_json::{Value, json};
use tungstenite::client::IntoClientRequest;
use tungstenite::{Message, WebSocket};

mod common;

/// A running `omnikin console` on a free loopback port, killed on drop.
struct Console {
    child: Child,
    /// The printed URL, `http://127.0.0.1:PORT/?token=…`.
    url: String,
    /// `127.0.0.1:PORT`.
    host: String,
    token: String,
}

impl Console {
    fn start(robot: &str) -> Self {
        Self::start_with(robot, &[])
    }

    fn start_with(robot: &str, extra: &[&str]) -> Self {
        let mut child = Command::new(BIN)
            .args(["console", "--connect", robot, "--listen", "127.0.0.1:0"])
            .args(extra)
            // The robot runs 8x real time (common::Robot): heartbeats at 100 Hz wall clock
            // are 12.5 Hz of robot time, well inside its 0.5 s watchdog.
            .args(["--for", "60", "--heartbeat", "100"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let out = child.stdout.take().unwrap();
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            let _ = BufReader::new(out).read_line(&mut line);
            let _ = tx.send(line);
        });
        let line = rx
            .recv_timeout(Duration::from_secs(10))
            .expect("console printed its URL");
        let url = line
            .trim()
            .strip_prefix("console: open ")
            .expect("URL line")
            .to_string();
        let rest = url.strip_prefix("http://").unwrap();
        let (host, q) = rest.split_once("/?token=").unwrap();
        assert_eq!(q.len(), 32, "16 random bytes in hex: {q}");
        assert!(q.bytes().all(|b| b.is_ascii_hexdigit()));
        Console {
            child,
            url: url.clone(),
            host: host.to_string(),
            token: q.to_string(),
        }
    }

    /// One raw HTTP exchange: the status code and the body.
    fn get(&self, target: &str, extra: &str) -> (u16, String) {
        let mut s = TcpStream::connect(&self.host).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        write!(
            s,
            "GET {target} HTTP/1.1\r\nHost: {}\r\n{extra}\r\n",
            self.host
        )
        .unwrap();
        let mut r = String::new();
        let _ = s.read_to_string(&mut r);
        let code = r
            .split(' ')
            .nth(1)
            .and_then(|c| c.parse().ok())
            .unwrap_or(0);
        (code, r)
    }

    /// A websocket to the page's endpoint with this Origin.
    fn ws(&self, origin: &str) -> Result<WebSocket<TcpStream>, u16> {
        let mut req = format!("ws://{}/ws?token={}", self.host, self.token)
            .into_client_request()
            .unwrap();
        req.headers_mut().insert("Origin", origin.parse().unwrap());
        let s = TcpStream::connect(&self.host).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        match tungstenite::client(req, s) {
            Ok((ws, _)) => Ok(ws),
            Err(tungstenite::HandshakeError::Failure(tungstenite::Error::Http(r))) => {
                Err(r.status().as_u16())
            }
            Err(e) => panic!("handshake: {e}"),
        }
    }

    fn page(&self) -> Page {
        let ws = self.ws(&format!("http://{}", self.host)).expect("upgrade");
        ws.get_ref()
            .set_read_timeout(Some(Duration::from_millis(50)))
            .unwrap();
        Page { ws, last: None }
    }
}

impl Drop for Console {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A page's websocket: sends JSON, keeps the newest telemetry.
struct Page {
    ws: WebSocket<TcpStream>,
    last: Option<Value>,
}

impl Page {
    fn send(&mut self, v: Value) {
        self.ws.send(Message::text(v.to_string())).unwrap();
    }

    /// Reads for up to `d`, returning every message (telemetry also kept in `last`).
    fn read_for(&mut self, d: Duration) -> Vec<Value> {
        let end = Instant::now() + d;
        let mut out = vec![];
        while Instant::now() < end {
            match self.ws.read() {
                Ok(Message::Text(t)) => {
                    let v: Value = serde_json::from_str(t.as_str()).unwrap();
                    if v["type"] == "telemetry" {
                        self.last = Some(v.clone());
                    }
                    out.push(v);
                }
                Ok(_) => {}
                Err(tungstenite::Error::Io(e))
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(e) => panic!("page socket: {e}"),
            }
        }
        out
    }

    /// Reads until `f` holds for a message (bounded by `d`); that message.
    fn wait_for(&mut self, d: Duration, what: &str, f: impl Fn(&Value) -> bool) -> Value {
        let end = Instant::now() + d;
        while Instant::now() < end {
            for m in self.read_for(Duration::from_millis(50)) {
                if f(&m) {
                    return m;
                }
            }
        }
        panic!("no {what} within {d:?}; last telemetry {:?}", self.last);
    }

    fn pose(&self) -> [f64; 3] {
        let p = &self.last.as_ref().expect("telemetry")["pose"];
        [0, 1, 2].map(|i| p[i].as_f64().unwrap())
    }
}

/// Reads a recording back with the `mcap` crate's reader: one `/pose` message per telemetry
/// frame the console counted, the plan on `/plan`, Foxglove schema names, monotonic log times.
fn check_recording(event: &str) {
    // "recorded N telemetry frames to PATH"
    let rest = event.strip_prefix("recorded ").unwrap();
    let (n, path) = rest.split_once(" telemetry frames to ").unwrap();
    let n: usize = n.parse().unwrap();
    let bytes = std::fs::read(path).unwrap();
    let mut count = std::collections::HashMap::<String, usize>::new();
    let mut last = std::collections::HashMap::<String, u64>::new();
    let mut schemas = std::collections::HashMap::<String, String>::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let topic = m.channel.topic.clone();
        let prev = last.insert(topic.clone(), m.log_time).unwrap_or(0);
        assert!(m.log_time >= prev, "{topic}: log time goes back");
        *count.entry(topic.clone()).or_default() += 1;
        schemas.insert(topic, m.channel.schema.as_ref().unwrap().name.clone());
    }
    assert!(n > 50, "{event}");
    assert_eq!(count.get("/pose"), Some(&n), "{count:?}");
    assert_eq!(count.get("/plan"), Some(&1), "{count:?}");
    // `robot --sim` sends its plant's truth with every telemetry frame (UDP on loopback: a
    // frame may still go missing, so not an exact count).
    let truth = count.get("/truth").copied().unwrap_or(0);
    assert!(
        truth * 10 >= n * 9 && truth <= n,
        "/truth {truth} of {n}: {count:?}"
    );
    assert_eq!(schemas["/pose"], "foxglove.PoseInFrame");
    assert_eq!(schemas["/tf"], "foxglove.FrameTransform");
}

#[test]
fn every_request_needs_the_token_and_upgrades_need_the_page_origin() {
    let robot = Robot::start(&["--max-time", "120"]);
    let c = Console::start(&robot.addr);
    let t = &c.token;
    for target in ["/", "/app.js", "/style.css", "/ws", "/favicon.ico"] {
        assert_eq!(c.get(target, "").0, 403, "{target} without a token");
        assert_eq!(
            c.get(&format!("{target}?token=00{}", &t[2..]), "").0,
            403,
            "{target}, wrong token"
        );
    }
    let (code, body) = c.get(&format!("/?token={t}"), "");
    assert_eq!(code, 200);
    assert!(body.contains("data-testid=\"estop\"") && body.contains(&format!("app.js?token={t}")));
    assert!(
        body.contains("Content-Security-Policy") && body.contains("Referrer-Policy: no-referrer")
    );
    let (code, body) = c.get(&format!("/app.js?token={t}"), "");
    assert_eq!(code, 200);
    assert!(body.contains("text/javascript"));
    // A DNS-rebinding page reaches 127.0.0.1 under its own name: refused by the Host header.
    let mut s = TcpStream::connect(&c.host).unwrap();
    write!(
        s,
        "GET /?token={t} HTTP/1.1\r\nHost: rebound.example:80\r\n\r\n"
    )
    .unwrap();
    let mut r = String::new();
    let _ = s.read_to_string(&mut r);
    assert!(r.starts_with("HTTP/1.1 403"), "{r}");
    // Another method.
    let mut s = TcpStream::connect(&c.host).unwrap();
    write!(
        s,
        "POST /?token={t} HTTP/1.1\r\nHost: {}\r\nContent-Length: 0\r\n\r\n",
        c.host
    )
    .unwrap();
    let mut r = String::new();
    let _ = s.read_to_string(&mut r);
    assert!(r.starts_with("HTTP/1.1 405"), "{r}");
    // Websocket upgrades: the token and the page's own origin.
    for origin in [
        "http://evil.example",
        "null",
        "https://127.0.0.1",
        "http://localhost:1",
    ] {
        assert_eq!(c.ws(origin).err(), Some(403), "{origin}");
    }
    let mut req = format!("ws://{}/ws?token=nope", c.host)
        .into_client_request()
        .unwrap();
    req.headers_mut()
        .insert("Origin", format!("http://{}", c.host).parse().unwrap());
    let s = TcpStream::connect(&c.host).unwrap();
    assert!(matches!(
        tungstenite::client(req, s),
        Err(tungstenite::HandshakeError::Failure(tungstenite::Error::Http(r))) if r.status() == 403
    ));
    // The right origin gets the stream, starting with the sticky state.
    let mut p = c.page();
    p.wait_for(Duration::from_secs(10), "connected link state", |m| {
        m["type"] == "link" && m["state"] == "connected"
    });
    p.wait_for(Duration::from_secs(5), "telemetry", |m| {
        m["type"] == "telemetry"
    });
    assert!(c.url.starts_with("http://127.0.0.1:"));
}

#[test]
fn relay_drives_the_robot_and_survives_hostile_pages() {
    let robot = Robot::start(&["--max-time", "120"]);
    let rec_dir = common::tmp("console", "recordings");
    let c = Console::start_with(&robot.addr, &["--record-dir", rec_dir.to_str().unwrap()]);
    let mut p = c.page();
    p.wait_for(Duration::from_secs(10), "telemetry", |m| {
        m["type"] == "telemetry"
    });
    // A simulated robot's telemetry comes with its plant's truth (ideal plant: the estimate).
    let m = p.wait_for(Duration::from_secs(5), "telemetry with the truth", |m| {
        m["type"] == "telemetry" && m["truth"].is_array()
    });
    let (q, truth) = (&m["pose"], &m["truth"]);
    let d = (q[0].as_f64().unwrap() - truth[0].as_f64().unwrap())
        .hypot(q[1].as_f64().unwrap() - truth[1].as_f64().unwrap());
    assert!(d < 0.01, "estimate {q} vs truth {truth}");
    let x0 = p.pose()[0];

    // Hostile page messages: each answered with an error to that page, none obeyed.
    for bad in [
        "not json",
        r#"{"type":"teleop","vx":1e999,"vy":0,"yaw":0}"#,
        r#"{"type":"teleop","vx":null,"vy":0,"yaw":0}"#,
        r#"{"type":"warp","to":"mars"}"#,
        r#"{"type":"plan","name":"x.csv","csv":"t,x,y\n0,0,0\n"}"#,
    ] {
        p.ws.send(Message::text(bad)).unwrap();
        p.wait_for(Duration::from_secs(3), "an error answer", |m| {
            m["type"] == "error"
        });
    }
    // A hostile connection that never finishes its request does not block the others.
    let mut slow = TcpStream::connect(&c.host).unwrap();
    slow.write_all(b"GET /?token=").unwrap();
    let mut slow_ws = c.page();

    // Dead-man teleop: full forward is the console's --speed (0.2 m/s), repeated at 20 Hz.
    let start = Instant::now();
    while start.elapsed() < Duration::from_millis(500) {
        p.send(json!({"type": "teleop", "vx": 5.0, "vy": 0, "yaw": 0}));
        p.read_for(Duration::from_millis(50));
    }
    let moving = p.last.clone().unwrap();
    assert_eq!(moving["mode"], "velocity", "{moving}");
    // Clamped to full scale: commanded 0.2 m/s, not 5 × 0.2.
    let cmd = moving["command"][0].as_f64().unwrap();
    assert!((cmd - 0.2).abs() < 1e-3, "commanded vx {cmd}");
    assert!(p.pose()[0] > x0 + 0.05, "moved: {:?}", p.pose());
    // Repeats stop (page gone quiet, no stop message): the console stops the robot once the
    // last command is older than its 0.3 s wall-clock hold (2.4 s of robot time at 8x), then
    // the robot brakes (0.2 m/s at the sphere's body limit, 22.9 m/s²: 9 ms).
    let t_last = moving["t"].as_f64().unwrap();
    let idle = p.wait_for(Duration::from_secs(5), "idle", |m| {
        m["type"] == "telemetry" && m["mode"] == "idle"
    });
    let dt = idle["t"].as_f64().unwrap() - t_last;
    // Loosely bounded for a loaded CI machine: 6 s of robot time is 0.75 s of wall clock.
    assert!(
        dt < 6.0,
        "stopped {dt} s (robot time, 8x) after the last repeat"
    );

    // E-stop from the second page, confirmed by the robot in telemetry of this session.
    slow_ws.send(json!({"type": "estop"}));
    // The relay's event comes just before the telemetry that confirmed it.
    p.wait_for(Duration::from_secs(5), "confirmation event", |m| {
        m["type"] == "event"
            && m["text"]
                .as_str()
                .is_some_and(|t| t.contains("e-stop confirmed"))
    });
    p.wait_for(Duration::from_secs(5), "estop mode", |m| {
        m["type"] == "telemetry" && m["mode"] == "estop" && m["estop_seq"].as_u64() > Some(0)
    });
    // Teleop is refused while latched; a plan run is refused too.
    p.send(json!({"type": "teleop", "vx": 1, "vy": 0, "yaw": 0}));
    let still = p.wait_for(Duration::from_secs(2), "telemetry", |m| {
        m["type"] == "telemetry"
    });
    assert_eq!(still["mode"], "estop");
    p.send(json!({"type": "clear"}));
    p.wait_for(Duration::from_secs(5), "cleared", |m| {
        m["type"] == "telemetry" && m["mode"] == "idle" && m["fault_history"] == "none"
    });

    // A plan: preview, then run with the pose set to its start; it ends where it began.
    let dir = common::tmp("console", "plan");
    let plan = common::square_plan(&dir);
    let csv = std::fs::read_to_string(&plan).unwrap();
    // Recorded to MCAP while it is driven.
    p.send(json!({"type": "record", "on": true}));
    p.wait_for(Duration::from_secs(5), "recording", |m| {
        m["type"] == "record" && m["on"] == true
    });
    p.send(json!({"type": "plan", "name": "square.csv", "csv": csv}));
    let preview = p.wait_for(Duration::from_secs(5), "preview", |m| m["type"] == "plan");
    let rows = csv.lines().count() - 1;
    assert_eq!(preview["samples"].as_u64(), Some(rows as u64));
    p.send(json!({"type": "plan_run", "set_pose": true}));
    p.wait_for(Duration::from_secs(10), "running", |m| {
        m["type"] == "plan_status" && m["state"] == "running"
    });
    let done = p.wait_for(Duration::from_secs(30), "done", |m| {
        m["type"] == "plan_status" && (m["state"] == "done" || m["state"] == "failed")
    });
    assert_eq!(done["state"], "done", "{done}");
    let end = p.pose();
    assert!(end[0].hypot(end[1]) < 0.05, "square closes: {end:?}");
    p.send(json!({"type": "record", "on": false}));
    let ev = p.wait_for(Duration::from_secs(5), "recorded event", |m| {
        m["type"] == "event"
            && m["text"]
                .as_str()
                .is_some_and(|t| t.starts_with("recorded "))
    });
    check_recording(ev["text"].as_str().unwrap());

    // An oversized message (over the 8 MiB limit) drops that page, not the console.
    let mut big = c.page();
    let _ = big.ws.send(Message::text("x".repeat(9 * 1024 * 1024)));
    let _ = big.ws.read();
    let mut again = c.page();
    again.wait_for(Duration::from_secs(5), "telemetry after the big one", |m| {
        m["type"] == "telemetry"
    });
    drop(slow);
}

/// Kills a child process on drop.
struct Kill(Child);
impl Drop for Kill {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn an_estop_asked_before_the_robot_answers_is_sent_once_it_does() {
    let addr = format!("127.0.0.1:{}", common::free_port());
    let c = Console::start(&addr);
    let mut p = c.page();
    // Nobody there yet: the page sees the link as not connected, the e-stop is kept.
    p.send(json!({"type": "estop"}));
    std::thread::sleep(Duration::from_millis(300));
    let _robot = Kill(
        Command::new(BIN)
            .args([
                "robot",
                "--sim",
                "--robot",
                "sphere-omni",
                "--listen",
                &addr,
            ])
            .args(["--time-scale", "8", "--max-time", "120"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    p.wait_for(Duration::from_secs(15), "confirmation event", |m| {
        m["type"] == "event"
            && m["text"]
                .as_str()
                .is_some_and(|t| t.contains("e-stop confirmed"))
    });
    let t = p.wait_for(Duration::from_secs(5), "telemetry", |m| {
        m["type"] == "telemetry"
    });
    assert_eq!(t["mode"], "estop", "{t}");
}

#[test]
fn foxglove_clients_get_the_mcap_channels_live() {
    let robot = Robot::start(&["--max-time", "120"]);
    let mut child = Kill(
        Command::new(BIN)
            .args([
                "console",
                "--connect",
                &robot.addr,
                "--listen",
                "127.0.0.1:0",
            ])
            .args([
                "--foxglove",
                "127.0.0.1:0",
                "--for",
                "60",
                "--heartbeat",
                "100",
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let out = child.0.stdout.take().unwrap();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut r = BufReader::new(out);
        for _ in 0..2 {
            let mut line = String::new();
            let _ = r.read_line(&mut line);
            let _ = tx.send(line);
        }
    });
    let _page = rx.recv_timeout(Duration::from_secs(10)).unwrap();
    let fox = rx.recv_timeout(Duration::from_secs(10)).unwrap();
    let url = fox
        .trim()
        .strip_prefix("console: foxglove ")
        .expect("foxglove URL line")
        .to_string();
    let host = url
        .strip_prefix("ws://")
        .unwrap()
        .split('/')
        .next()
        .unwrap()
        .to_string();
    // Without the token: refused.
    let bare = format!("ws://{host}/").into_client_request().unwrap();
    assert!(matches!(
        tungstenite::client(bare, TcpStream::connect(&host).unwrap()),
        Err(tungstenite::HandshakeError::Failure(tungstenite::Error::Http(r))) if r.status() == 403
    ));
    let mut req = url.as_str().into_client_request().unwrap();
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().unwrap(),
    );
    let s = TcpStream::connect(&host).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let (mut ws, resp) = tungstenite::client(req, s).unwrap();
    assert_eq!(
        resp.headers().get("Sec-WebSocket-Protocol").unwrap(),
        "foxglove.websocket.v1"
    );
    let text = |ws: &mut WebSocket<TcpStream>| -> Value {
        match ws.read().unwrap() {
            Message::Text(t) => serde_json::from_str(t.as_str()).unwrap(),
            m => panic!("{m:?}"),
        }
    };
    assert_eq!(text(&mut ws)["op"], "serverInfo");
    let adv = text(&mut ws);
    assert_eq!(adv["op"], "advertise");
    let chans = adv["channels"].as_array().unwrap();
    let id = |topic: &str| {
        chans.iter().find(|c| c["topic"] == topic).unwrap()["id"]
            .as_u64()
            .unwrap()
    };
    let pose = chans.iter().find(|c| c["topic"] == "/pose").unwrap();
    assert_eq!(pose["schemaName"], "foxglove.PoseInFrame");
    assert_eq!(pose["encoding"], "json");
    ws.send(Message::text(
        json!({"op": "subscribe", "subscriptions": [
            {"id": 10, "channelId": id("/pose")}, {"id": 11, "channelId": id("/wheels")}]})
        .to_string(),
    ))
    .unwrap();
    let (mut n10, mut n11, mut last_ns) = (0, 0, 0u64);
    let end = Instant::now() + Duration::from_secs(10);
    while (n10 < 5 || n11 < 5) && Instant::now() < end {
        if let Message::Binary(b) = ws.read().unwrap() {
            assert_eq!(b[0], 1, "messageData");
            let sub = u32::from_le_bytes(b[1..5].try_into().unwrap());
            let ns = u64::from_le_bytes(b[5..13].try_into().unwrap());
            let v: Value = serde_json::from_slice(&b[13..]).unwrap();
            match sub {
                10 => {
                    n10 += 1;
                    assert!(ns >= last_ns, "log times go forward");
                    last_ns = ns;
                    assert_eq!(v["frame_id"], "world", "{v}");
                }
                11 => n11 += 1,
                s => panic!("subscription {s} was never asked for"),
            }
        }
    }
    assert!(n10 >= 5 && n11 >= 5, "pose {n10}, wheels {n11}");
}

#[test]
fn the_map_reaches_the_page_and_a_bad_map_is_refused_naming_its_line() {
    let robot = Robot::start(&["--max-time", "60"]);
    let map = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/maps/hall.toml");
    let c = Console::start_with(&robot.addr, &["--map", map]);
    let mut p = c.page();
    let m = p.wait_for(Duration::from_secs(10), "the map", |m| m["type"] == "map");
    assert_eq!(m["keep_out"].as_array().map(Vec::len), Some(4), "{m}");
    assert_eq!(m["keep_out"][0]["circle"], json!([1.2, 0.4, 0.3]));
    assert_eq!(m["keep_in"][1], json!([4.5, -0.5]));
    let bad = common::tmp("console", "bad-map");
    let f = bad.join("bad.toml");
    std::fs::write(&f, "[[keep_out]]\ncircle = [1, 2]\n").unwrap();
    let out = Command::new(BIN)
        .args([
            "console",
            "--connect",
            &robot.addr,
            "--listen",
            "127.0.0.1:0",
        ])
        .args(["--map", f.to_str().unwrap(), "--for", "1"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.toml:2"), "{err}");
}
