//! The console's web server — `omnikin console` and any other front end: a local web page that
//! shows and drives the robot, relayed over the operator link (`drive`'s session).
//!
//! Threads, no async runtime: one [`gate::HeadGate`] per listening socket (the page's on the
//! caller's thread in [`ConsoleServer::run`], Foxglove's on its own) reads the request heads of
//! every new connection without a thread each; a head that passes the access rules gets a
//! worker thread, one per HTTP exchange or websocket ([`http`], [`ws`], [`foxglove_ws`]); the
//! relay owns the robot link ([`relay`]); they meet in the [`Hub`]. A connection that never
//! finishes its head costs a socket and a bounded buffer for at most [`gate::HEAD_TIMEOUT`],
//! never a worker. The page and its script and style are embedded
//! (`crates/omnikin-host/console/`).
//!
//! Access: a random per-start token (16 bytes from the OS) is required on every request
//! (403 without it); the websocket upgrade must also come from the page's own Origin; bound to
//! loopback (the default), only loopback Host names are answered, so a web site that rebinds
//! its name to 127.0.0.1 is refused too. Every wait is finite, every buffer bounded.
//!
//! [`ConsoleServer::bind`] checks and binds (errors come back before anything is served, so a
//! front end reports them and can print [`ConsoleServer::url`]); [`ConsoleServer::run`] serves
//! until its end time, a signal (the front end installs the handlers:
//! `omnikin_io::output::catch_signals`), its stop flag or the relay's end.

use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use omnikin::description::BodyLimits;
use omnikin_io::errln;

use super::hub::Hub;
use super::{foxglove_ws, gate, http, relay, ws};
use crate::console_operator::ConsoleOperator;

/// At most this many HTTP exchanges at once, counted after the access rules (more get 503).
pub const MAX_HTTP: usize = 16;
/// At most this many pages connected at once (more get 503).
pub const MAX_PAGES: usize = 8;
/// At most this many Foxglove clients at once, counted after the access rules (more get 503).
pub const MAX_FOXGLOVE: usize = 4;

/// What the console serves and how it drives the robot (`omnikin console`'s flags).
#[derive(Clone, Debug)]
pub struct ConsoleOptions {
    /// The robot: `HOST:PORT` (UDP), `udp:HOST:PORT` or `serial:PATH[@BAUD]`.
    pub connect: String,
    /// Shared key file (16–64 bytes), the same as the robot's.
    pub key: Option<PathBuf>,
    /// Where to serve the page (port 0: any free port). Loopback unless told otherwise.
    pub listen: SocketAddr,
    /// Heartbeat / command repeat rate to the robot, Hz (wall clock).
    pub heartbeat_hz: f64,
    /// Give up a session after this many seconds without telemetry (then retry), s.
    pub timeout_s: f64,
    /// Teleop speed at full key / stick, m/s.
    pub speed: f64,
    /// Teleop yaw rate at full key / stick, rad/s.
    pub turn: f64,
    /// Where the page's "Record MCAP" writes its files (an existing directory).
    pub record_dir: PathBuf,
    /// Also serve the telemetry over the Foxglove WebSocket protocol on this address.
    pub foxglove: Option<SocketAddr>,
    /// A plan whose start is farther than this from the robot's estimate runs only after a
    /// second click on the page, m.
    pub start_tolerance_m: f64,
    /// The robot's name and body limits: an uploaded plan asking more is refused.
    pub robot_limits: Option<(String, BodyLimits)>,
    /// A map drawn under the robot (its keep-out shapes and keep-in boundary).
    pub map: Option<omnikin_plan::map::Map>,
}

/// A console bound to its sockets, the robot's address and key checked, not yet serving.
pub struct ConsoleServer {
    options: ConsoleOptions,
    listener: TcpListener,
    policy: Arc<http::Policy>,
    foxglove: Option<(TcpListener, http::Policy)>,
    first: ConsoleOperator,
    warnings: Vec<String>,
}

/// How a console run ended.
#[derive(Debug, Default)]
pub struct ConsoleSummary {
    /// Connections on the page's socket closed before they finished their request head
    /// because newer ones came (a slowloris attack, or a very slow link).
    pub evicted: u64,
    /// The signal that ended it, if one did.
    pub interrupted: Option<omnikin_io::output::Interrupted>,
}

/// A random token: 16 bytes from the operating system, as 32 lower-case hex digits.
///
/// # Errors
/// When the operating system gives no random bytes.
pub fn token() -> Result<String> {
    let mut b = [0u8; 16];
    getrandom::fill(&mut b).map_err(|e| anyhow::anyhow!("no random bytes from the OS: {e}"))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

/// The address a browser can open: an unspecified address (0.0.0.0, ::) shown as 127.0.0.1.
fn shown(local: SocketAddr) -> SocketAddr {
    if local.ip().is_unspecified() {
        SocketAddr::new(std::net::Ipv4Addr::LOCALHOST.into(), local.port())
    } else {
        local
    }
}

fn policy_for(l: &TcpListener, token: &str) -> Result<http::Policy> {
    let local = l.local_addr()?;
    Ok(http::Policy {
        token: token.to_string(),
        port: local.port(),
        loopback: local.ip().is_loopback(),
    })
}

impl ConsoleServer {
    /// Checks the options, the robot's address and key, and binds the page's socket (and
    /// Foxglove's).
    ///
    /// # Errors
    /// `--record-dir` not a directory, a bad address or key file (the same errors as
    /// `drive`), a socket that cannot be bound or the OS giving no random bytes.
    pub fn bind(options: ConsoleOptions) -> Result<Self> {
        if !options.record_dir.is_dir() {
            bail!(
                "--record-dir {}: not a directory (recordings go there)",
                options.record_dir.display()
            );
        }
        let first = ConsoleOperator::open(
            &options.connect,
            options.key.as_deref(),
            options.heartbeat_hz,
            options.timeout_s,
        )?;
        let listen = options.listen;
        let listener =
            TcpListener::bind(listen).with_context(|| format!("--listen {listen}: cannot bind"))?;
        let token = token()?;
        let policy = Arc::new(policy_for(&listener, &token)?);
        let mut warnings = Vec::new();
        if !policy.loopback {
            warnings.push(format!(
                "--listen {listen} is not a loopback address: anyone on that network who learns the URL (it is sent in clear over plain HTTP) can drive the robot; prefer 127.0.0.1 and an SSH tunnel"
            ));
        }
        let foxglove = match options.foxglove {
            Some(at) => {
                let l = TcpListener::bind(at)
                    .with_context(|| format!("--foxglove {at}: cannot bind"))?;
                let p = policy_for(&l, &token)?;
                if !p.loopback {
                    warnings.push(format!(
                        "--foxglove {at} is not a loopback address: anyone on that network who learns the URL can watch the robot"
                    ));
                }
                Some((l, p))
            }
            None => None,
        };
        Ok(Self {
            options,
            listener,
            policy,
            foxglove,
            first,
            warnings,
        })
    }

    /// The page's URL with its token (`http://127.0.0.1:PORT/?token=…`).
    ///
    /// # Errors
    /// When the socket has no local address.
    pub fn url(&self) -> Result<String> {
        Ok(format!(
            "http://{}/?token={}",
            shown(self.listener.local_addr()?),
            self.policy.token
        ))
    }

    /// The Foxglove WebSocket URL with the token, when `foxglove` was given.
    ///
    /// # Errors
    /// When the socket has no local address.
    pub fn foxglove_url(&self) -> Result<Option<String>> {
        match &self.foxglove {
            Some((l, p)) => Ok(Some(format!(
                "ws://{}/?token={}",
                shown(l.local_addr()?),
                p.token
            ))),
            None => Ok(None),
        }
    }

    /// What the front end should warn about before serving (addresses that are not loopback).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// Serves until `until` (wall clock), a signal, `stop` set or the relay's end; then stops
    /// the relay (it sends a stop if it was driving) within 2 s.
    ///
    /// # Errors
    /// A socket that cannot be polled, a thread that cannot be started. A signal is not an
    /// error: it ends the run and is in [`ConsoleSummary::interrupted`].
    pub fn run(self, until: Option<Instant>, stop: Option<&AtomicBool>) -> Result<ConsoleSummary> {
        let o = &self.options;
        let (hub, rx) = Hub::new();
        if let Some(l) = o.robot_limits.clone() {
            let _ = hub.robot_limits.set(l);
        }
        hub.publish(
            &serde_json::json!({"type": "config", "speed": o.speed, "turn": o.turn,
                "heartbeat_hz": o.heartbeat_hz, "mcap": true, "start_tolerance_m": o.start_tolerance_m,
                "record_dir": o.record_dir.display().to_string()}),
            Some("config"),
        );
        if let Some(m) = &o.map {
            hub.publish(&super::map_view::map_message(m), Some("map"));
        }
        let fox_hub = self
            .foxglove
            .as_ref()
            .map(|_| Arc::new(foxglove_ws::FoxHub::default()));
        let cfg = relay::RelayConfig {
            connect: o.connect.clone(),
            key: o.key.clone(),
            heartbeat_hz: o.heartbeat_hz,
            timeout_s: o.timeout_s,
            speed: o.speed,
            turn: o.turn,
            record_dir: o.record_dir.clone(),
            fox: fox_hub.clone(),
        };
        let first = self.first;
        let relay: JoinHandle<()> = {
            let hub = hub.clone();
            std::thread::Builder::new()
                .name("relay".into())
                .spawn(move || relay::run(hub, rx, cfg, first))?
        };
        if let (Some((listener, policy)), Some(fox)) = (self.foxglove, fox_hub) {
            let hub = hub.clone();
            std::thread::Builder::new()
                .name("foxglove".into())
                .spawn(move || foxglove_accept(listener, policy, hub, fox))?;
        }
        let mut gate =
            gate::HeadGate::new(self.listener).context("--listen: cannot poll the socket")?;
        let http_slots = Arc::new(AtomicUsize::new(0));
        let page_slots = Arc::new(AtomicUsize::new(0));
        let policy = self.policy;
        let mut interrupted = None;
        let result = loop {
            if let Some(sig) = omnikin_io::output::interrupted() {
                interrupted = Some(sig);
                break Ok(());
            }
            if until.is_some_and(|e| Instant::now() >= e)
                || stop.is_some_and(|s| s.load(Ordering::Relaxed))
                || relay.is_finished()
            {
                break Ok(());
            }
            let turned = gate.turn(Duration::from_millis(20), &mut |h| {
                page_head(h, &policy, &hub, &http_slots, &page_slots);
            });
            if let Err(e) = turned {
                break Err(e).context("--listen: polling the socket failed");
            }
        };
        hub.shutdown.store(true, Ordering::SeqCst);
        // The relay sends a stop if it was driving; its receive slices are short.
        let deadline = Instant::now() + Duration::from_secs(2);
        while !relay.is_finished() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(10));
        }
        result.map(|()| ConsoleSummary {
            evicted: gate.evicted(),
            interrupted,
        })
    }
}

/// Counts a live thread of a kind; the count goes down when it is dropped.
struct Slot(Arc<AtomicUsize>);
impl Slot {
    fn take(c: &Arc<AtomicUsize>, max: usize) -> Option<Self> {
        c.fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
            (n < max).then_some(n + 1)
        })
        .ok()
        .map(|_| Slot(c.clone()))
    }
}
impl Drop for Slot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// A best-effort answer written at once on the gate's thread (the socket is non-blocking; a
/// short refusal fits any send buffer), then the close.
fn refuse(mut stream: TcpStream, status: u16, why: &str) {
    let _ = http::respond(
        &mut stream,
        status,
        "text/plain; charset=utf-8",
        format!("{why}\n").as_bytes(),
    );
}

/// A complete head on the page's port: the access rules, then a worker for what they allow
/// (at most [`MAX_HTTP`]).
fn page_head(
    h: gate::Head,
    policy: &Arc<http::Policy>,
    hub: &Arc<Hub>,
    http_slots: &Arc<AtomicUsize>,
    pages: &Arc<AtomicUsize>,
) {
    let Some(req) = http::parse(&h.head) else {
        return refuse(h.stream, 400, "bad request");
    };
    let route = match http::route(&req, policy) {
        Ok(r) => r,
        Err((status, why)) => return refuse(h.stream, status, why),
    };
    let Some(slot) = Slot::take(http_slots, MAX_HTTP) else {
        return refuse(
            h.stream,
            503,
            "the console is busy: too many requests at once",
        );
    };
    let (hub, policy, pages) = (hub.clone(), policy.clone(), pages.clone());
    let spawned = std::thread::Builder::new()
        .name("http".into())
        .spawn(move || exchange(h.stream, route, h.rest, slot, &policy, hub, &pages));
    if spawned.is_err() {
        errln!("console: cannot start a thread for a connection");
    }
}

/// One admitted request on its worker: the response, or the websocket of a page.
fn exchange(
    mut stream: TcpStream,
    route: http::PageRoute,
    rest: Vec<u8>,
    slot: Slot,
    policy: &http::Policy,
    hub: Arc<Hub>,
    pages: &Arc<AtomicUsize>,
) {
    if stream.set_nonblocking(false).is_err()
        || stream.set_write_timeout(Some(ws::WRITE_TIMEOUT)).is_err()
    {
        return;
    }
    match route {
        http::PageRoute::Page => {
            let _ = http::respond(
                &mut stream,
                200,
                "text/html; charset=utf-8",
                http::page(&policy.token).as_bytes(),
            );
        }
        http::PageRoute::Asset(ctype, body) => {
            let _ = http::respond(&mut stream, 200, ctype, body.as_bytes());
        }
        http::PageRoute::WebSocket(key) => {
            let Some(_page) = Slot::take(pages, MAX_PAGES) else {
                let _ = http::respond(&mut stream, 503, "text/plain", b"too many pages open\n");
                return;
            };
            use std::io::Write;
            if stream
                .write_all(http::upgrade_response(&key).as_bytes())
                .and_then(|()| stream.flush())
                .is_err()
            {
                return;
            }
            // A page is not an HTTP exchange: free that slot for the next request.
            drop(slot);
            hub.clients.fetch_add(1, Ordering::SeqCst);
            ws::serve(stream, rest, hub.clone());
            hub.clients.fetch_sub(1, Ordering::SeqCst);
        }
    }
}

/// The Foxglove port's gate until the console shuts down: the access rules for each complete
/// head, then a worker per admitted client (at most [`MAX_FOXGLOVE`]).
fn foxglove_accept(
    l: TcpListener,
    policy: http::Policy,
    hub: Arc<Hub>,
    fox: Arc<foxglove_ws::FoxHub>,
) {
    let mut gate = match gate::HeadGate::new(l) {
        Ok(g) => g,
        Err(e) => {
            errln!("console: --foxglove: cannot poll the socket: {e}");
            return;
        }
    };
    let slots = Arc::new(AtomicUsize::new(0));
    while !hub.shutdown.load(Ordering::SeqCst) {
        let turned = gate.turn(Duration::from_millis(50), &mut |h| {
            let answer = match foxglove_ws::admit(&h.head, &policy) {
                Ok(a) => a,
                Err((status, why)) => return refuse(h.stream, status, why),
            };
            let Some(slot) = Slot::take(&slots, MAX_FOXGLOVE) else {
                return refuse(h.stream, 503, "too many Foxglove clients at once");
            };
            let (hub, fox) = (hub.clone(), fox.clone());
            let _ = std::thread::Builder::new()
                .name("foxglove-client".into())
                .spawn(move || {
                    let _slot = slot;
                    foxglove_ws::exchange(h.stream, &answer, h.rest, &hub, &fox);
                });
        });
        if let Err(e) = turned {
            errln!("console: --foxglove: polling the socket failed: {e}");
            return;
        }
    }
}
