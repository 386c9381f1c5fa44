//! `omnikin console` under a slowloris attack (issue 30, observation 5), in its own test binary
//! so that its 100 attacking sockets never share the machine with the other console tests.
//!
//! 50 connections to the page's port and 50 to the Foxglove port, none with the token, each
//! sending one byte of a request head that never ends every 200 ms, and reopened whenever the
//! console drops it (what slowloris does). Meanwhile a legitimate client loads the page (HTML,
//! script, style) 10 times and opens 10 Foxglove connections: at least 9 of each must succeed,
//! and a page opened before the attack keeps receiving telemetry through it.
//! Every wait is bounded (5 s per request, 45 s for all of them); about 12 s in all.

use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::{BIN, Robot};
use serde_json::Value;
use tungstenite::Message;
use tungstenite::client::IntoClientRequest;

mod common;

/// Slowloris connections held open on each port.
const ATTACKERS: usize = 50;
/// How long a legitimate request may take.
const REQUEST: Duration = Duration::from_secs(5);

/// Kills a child process on drop.
struct Kill(Child);
impl Drop for Kill {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Stops the attacker thread on drop (also when an assertion fails).
struct Stop(Arc<AtomicBool>);
impl Drop for Stop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::SeqCst);
    }
}

/// One slowloris connection: a request line and the start of a header that never ends.
fn open_slow(addr: &str) -> Option<TcpStream> {
    let mut s = TcpStream::connect_timeout(&addr.parse().ok()?, REQUEST).ok()?;
    s.set_nonblocking(true).ok()?;
    s.write_all(b"GET / HTTP/1.1\r\nX-Slow: ").ok()?;
    Some(s)
}

/// Whether the console has closed (or answered) this connection.
fn dropped(s: &mut TcpStream) -> bool {
    let mut b = [0u8; 256];
    match s.read(&mut b) {
        Ok(_) => true, // end of stream, or a 408 before the close
        Err(e) if e.kind() == ErrorKind::WouldBlock => s.write_all(b"a").is_err(),
        Err(_) => true,
    }
}

/// A page's websocket opened before the attack: counts the telemetry messages it receives
/// until `stop` (reading all the time, as a browser does, so the console never drops it).
fn watch_page(host: &str, token: &str, stop: Arc<AtomicBool>, seen: Arc<AtomicUsize>) {
    let mut req = format!("ws://{host}/ws?token={token}")
        .into_client_request()
        .unwrap();
    req.headers_mut()
        .insert("Origin", format!("http://{host}").parse().unwrap());
    let s = TcpStream::connect(host).unwrap();
    s.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let (mut ws, _) = tungstenite::client(req, s).expect("page upgrade before the attack");
    while !stop.load(Ordering::SeqCst) {
        match ws.read() {
            Ok(Message::Text(t)) => {
                let v: Value = serde_json::from_str(t.as_str()).unwrap();
                if v["type"] == "telemetry" {
                    seen.fetch_add(1, Ordering::SeqCst);
                }
            }
            Ok(_) => {}
            Err(tungstenite::Error::Io(e))
                if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(e) => panic!("the open page lost its socket: {e}"),
        }
    }
}

/// Holds [`ATTACKERS`] slow connections on each address until `stop`; counts the reopenings.
fn attack(addrs: Vec<String>, stop: Arc<AtomicBool>, reopened: Arc<AtomicUsize>) {
    let mut conns: Vec<Vec<Option<TcpStream>>> = addrs
        .iter()
        .map(|a| (0..ATTACKERS).map(|_| open_slow(a)).collect())
        .collect();
    while !stop.load(Ordering::SeqCst) {
        for (addr, set) in addrs.iter().zip(&mut conns) {
            for c in set.iter_mut() {
                if c.as_mut().is_none_or(dropped) {
                    *c = open_slow(addr);
                    reopened.fetch_add(1, Ordering::SeqCst);
                }
            }
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// One page load: the HTML, its script and its style, each on its own connection.
fn load_page(host: &str, token: &str) -> Result<(), String> {
    for (path, needle) in [
        ("/", "data-testid=\"estop\""),
        ("/app.js", "WebSocket"),
        ("/style.css", "{"),
    ] {
        let mut s = TcpStream::connect_timeout(&host.parse().unwrap(), REQUEST)
            .map_err(|e| format!("{path}: connect: {e}"))?;
        s.set_read_timeout(Some(REQUEST)).unwrap();
        s.set_write_timeout(Some(REQUEST)).unwrap();
        write!(
            s,
            "GET {path}?token={token} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"
        )
        .map_err(|e| format!("{path}: write: {e}"))?;
        let mut r = Vec::new();
        s.read_to_end(&mut r)
            .map_err(|e| format!("{path}: read: {e}"))?;
        let r = String::from_utf8_lossy(&r);
        if !r.starts_with("HTTP/1.1 200") || !r.contains(needle) {
            return Err(format!(
                "{path}: {}",
                r.lines().next().unwrap_or("no answer")
            ));
        }
    }
    Ok(())
}

/// One Foxglove connection: the upgrade, `serverInfo` and `advertise`, then a clean close
/// (waited for, so the console has freed the client's slot before the next one).
fn open_foxglove(url: &str, host: &str) -> Result<(), String> {
    let mut req = url.into_client_request().unwrap();
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.websocket.v1".parse().unwrap(),
    );
    let s = TcpStream::connect_timeout(&host.parse().unwrap(), REQUEST)
        .map_err(|e| format!("connect: {e}"))?;
    s.set_read_timeout(Some(REQUEST)).unwrap();
    s.set_write_timeout(Some(REQUEST)).unwrap();
    let (mut ws, _) = tungstenite::client(req, s).map_err(|e| format!("upgrade: {e}"))?;
    for op in ["serverInfo", "advertise"] {
        match ws.read() {
            Ok(Message::Text(t)) => {
                let v: Value = serde_json::from_str(t.as_str()).map_err(|e| e.to_string())?;
                if v["op"] != op {
                    return Err(format!("expected {op}, got {v}"));
                }
            }
            other => return Err(format!("expected {op}, got {other:?}")),
        }
    }
    ws.close(None).map_err(|e| format!("close: {e}"))?;
    let end = Instant::now() + REQUEST;
    while Instant::now() < end {
        match ws.read() {
            Ok(_) => {}
            Err(tungstenite::Error::ConnectionClosed) => return Ok(()),
            Err(e) => return Err(format!("closing: {e}")),
        }
    }
    Err("no close answer".into())
}

#[test]
fn slowloris_without_the_token_does_not_lock_out_the_page_or_foxglove() {
    let robot = Robot::start(&["--max-time", "200"]);
    let mut child = Kill(
        Command::new(BIN)
            .args(["console", "--connect", &robot.addr])
            .args(["--listen", "127.0.0.1:0", "--foxglove", "127.0.0.1:0"])
            .args(["--for", "90", "--heartbeat", "100"])
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
    let page = rx.recv_timeout(Duration::from_secs(10)).unwrap();
    let fox = rx.recv_timeout(Duration::from_secs(10)).unwrap();
    let page = page.trim().strip_prefix("console: open http://").unwrap();
    let (host, token) = page.split_once("/?token=").unwrap();
    let fox_url = fox.trim().strip_prefix("console: foxglove ").unwrap();
    let fox_host = fox_url
        .strip_prefix("ws://")
        .and_then(|r| r.split('/').next())
        .unwrap();

    let stop = Arc::new(AtomicBool::new(false));
    let _stop = Stop(stop.clone());
    let telemetry = Arc::new(AtomicUsize::new(0));
    let watcher = {
        let (host, token, stop, seen) = (
            host.to_string(),
            token.to_string(),
            stop.clone(),
            telemetry.clone(),
        );
        std::thread::spawn(move || watch_page(&host, &token, stop, seen))
    };
    let end = Instant::now() + Duration::from_secs(15);
    while telemetry.load(Ordering::SeqCst) == 0 && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(
        telemetry.load(Ordering::SeqCst) > 0,
        "no telemetry on the page before the attack"
    );
    let reopened = Arc::new(AtomicUsize::new(0));
    let attacker = {
        let (addrs, stop, reopened) = (
            vec![host.to_string(), fox_host.to_string()],
            stop.clone(),
            reopened.clone(),
        );
        std::thread::spawn(move || attack(addrs, stop, reopened))
    };
    // Let the attack take hold: every slot a slow connection can take is taken by now.
    std::thread::sleep(Duration::from_secs(1));

    let before = telemetry.load(Ordering::SeqCst);
    let all = Instant::now() + Duration::from_secs(45);
    let (mut pages, mut foxes, mut failures) = (0, 0, Vec::new());
    for i in 0..10 {
        if Instant::now() >= all {
            failures.push(format!("round {i}: out of time"));
            break;
        }
        match load_page(host, token) {
            Ok(()) => pages += 1,
            Err(e) => failures.push(format!("page {i}: {e}")),
        }
        match open_foxglove(fox_url, fox_host) {
            Ok(()) => foxes += 1,
            Err(e) => failures.push(format!("foxglove {i}: {e}")),
        }
        // Spread over about 10 s, so slow connections time out and are reopened meanwhile.
        std::thread::sleep(Duration::from_millis(800));
    }
    let during = telemetry.load(Ordering::SeqCst) - before;
    stop.store(true, Ordering::SeqCst);
    attacker.join().unwrap();
    watcher.join().unwrap();
    eprintln!(
        "pages {pages}/10, foxglove {foxes}/10, telemetry on the open page {during}, slow connections reopened {}; {failures:?}",
        reopened.load(Ordering::SeqCst)
    );
    assert!(
        pages >= 9 && foxes >= 9,
        "pages {pages}/10, foxglove {foxes}/10: {failures:?}"
    );
    // About 10 s of attack at the robot's telemetry rate (tens per second): a handful at least.
    assert!(
        during >= 10,
        "the open page got {during} telemetry messages during the attack"
    );
}
