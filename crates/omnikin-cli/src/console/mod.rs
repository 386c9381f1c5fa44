//! `omnikin console`: a local web page that shows and drives the robot, relayed over the
//! operator link (`drive`'s session).
//!
//! Threads, no async runtime: one [`gate::Gate`] per listening socket (the page's on the main
//! thread, Foxglove's on its own) reads the request heads of every new connection without a
//! thread each; a head that passes the access rules gets a worker thread, one per HTTP
//! exchange or websocket ([`http`], [`ws`], [`foxglove_ws`]); the relay owns the robot link
//! ([`relay`]); they meet in the [`hub::Hub`]. A connection that never finishes its head costs
//! a socket and a bounded buffer for at most [`gate::HEAD_TIMEOUT`], never a worker. The page
//! and its script and style are embedded in the binary (`crates/omnikin-cli/console/`).
//!
//! Access: a random per-start token (16 bytes from the OS) is required on every request
//! (403 without it); the websocket upgrade must also come from the page's own Origin; bound to
//! loopback (the default), only loopback Host names are answered, so a web site that rebinds
//! its name to 127.0.0.1 is refused too. Every wait is finite, every buffer bounded.

use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};

pub mod foxglove_ws;
pub mod gate;
pub mod http;
pub mod ws;
// The hub and the relay are the host library's (crates/omnikin-host/src/console/).
pub use omnikin_host::console::{hub, relay};

use hub::Hub;

/// At most this many HTTP exchanges at once, counted after the access rules (more get 503).
pub const MAX_HTTP: usize = 16;
/// At most this many pages connected at once (more get 503).
pub const MAX_PAGES: usize = 8;

/// `omnikin console`.
#[derive(clap::Args, Debug)]
pub struct ConsoleArgs {
    /// The robot: HOST:PORT (UDP), udp:HOST:PORT or serial:PATH[@BAUD] (as `drive --connect`).
    #[arg(long, value_name = "ADDR")]
    pub connect: String,
    /// Shared key file (16-64 bytes), the same as the robot's --key.
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// Where to serve the page, HOST:PORT (port 0: any free port). Loopback unless told
    /// otherwise: any other address lets everyone on that network who has the URL drive.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:8090")]
    pub listen: String,
    /// Heartbeat / command repeat rate to the robot, Hz (wall clock).
    #[arg(long, default_value_t = 20.0, allow_hyphen_values = true, value_parser = crate::args::message_rate_hz)]
    pub heartbeat: f64,
    /// Give up a session after this many seconds without telemetry (then retry).
    #[arg(long, default_value_t = 3.0, allow_hyphen_values = true, value_parser = crate::args::timeout_s)]
    pub timeout: f64,
    /// Teleop speed at full key / stick, m/s.
    #[arg(long, default_value_t = 0.2, allow_hyphen_values = true, value_parser = teleop_scale)]
    pub speed: f64,
    /// Teleop yaw rate at full key / stick, rad/s.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = teleop_scale)]
    pub turn: f64,
    /// Where the page's "Record MCAP" writes its files (console-<unix time>.mcap, with the
    /// channels of `drive --mcap`, docs/seeing-the-robot.md).
    #[arg(long, value_name = "DIR", default_value = ".")]
    pub record_dir: PathBuf,
    /// Also serve the telemetry live over the Foxglove WebSocket protocol on this address
    /// (e.g. 127.0.0.1:8765; port 0: any free port), with the channels of the MCAP logs.
    #[arg(long, value_name = "ADDR")]
    pub foxglove: Option<String>,
    /// A plan whose start is farther than this from the robot's estimate (m) runs only after
    /// a second click on the page (the robot would first drive itself there), unless "set
    /// pose to the plan's start" is ticked.
    #[arg(long, value_name = "METERS", default_value_t = 0.1, allow_hyphen_values = true, value_parser = crate::args::start_tolerance_m)]
    pub start_tolerance: f64,
    /// A map (the format of `omnikin plan goal --map`) drawn under the robot: its keep-out
    /// shapes and keep-in boundary.
    #[arg(long, value_name = "MAP.toml")]
    pub map: Option<PathBuf>,
    /// The robot being driven (preset or robot file, as its `omnikin robot --robot`): an
    /// uploaded plan asking more than its body limits (`omnikin check`) is refused, naming the
    /// limit and the plan's peak.
    #[arg(long)]
    pub robot: Option<String>,
    /// Stop after this many seconds (wall clock; default: until Ctrl-C).
    #[arg(long = "for", value_name = "SECONDS", allow_hyphen_values = true, value_parser = crate::args::run_for_s)]
    pub duration: Option<f64>,
}

/// `--speed`, `--turn`: 0 to 10 (m/s or rad/s).
fn teleop_scale(s: &str) -> Result<f64, String> {
    crate::args::in_range(s, 0.0, 10.0, "(m/s or rad/s)")
}

/// A random token: 16 bytes from the operating system, as 32 lower-case hex digits.
pub fn token() -> Result<String> {
    let mut b = [0u8; 16];
    getrandom::fill(&mut b).map_err(|e| anyhow::anyhow!("no random bytes from the OS: {e}"))?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
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

/// Runs the console until Ctrl-C or `--for`.
pub fn run(a: &ConsoleArgs) -> Result<()> {
    // `--map`: read first (a bad map fails here, naming the line).
    let map = a
        .map
        .as_deref()
        .map(omnikin_plan::map::Map::load)
        .transpose()?;
    // `--robot`: its body limits, checked at every plan upload (a bad file fails here).
    let robot_limits = match &a.robot {
        Some(r) => {
            let d = crate::kinematics::resolve_robot(r)?;
            Some((d.name.clone(), d.body_limits()))
        }
        None => None,
    };
    let listen: SocketAddr = a.listen.parse().with_context(|| {
        format!(
            "--listen: expected HOST:PORT (e.g. 127.0.0.1:8090), got \"{}\"",
            a.listen
        )
    })?;
    if !a.record_dir.is_dir() {
        anyhow::bail!(
            "--record-dir {}: not a directory (recordings go there)",
            a.record_dir.display()
        );
    }
    // Address and key are checked before anything is served (the same errors as `drive`).
    let first = omnikin_host::console_operator::ConsoleOperator::open(
        &a.connect,
        a.key.as_deref(),
        a.heartbeat,
        a.timeout,
    )?;
    let listener =
        TcpListener::bind(listen).with_context(|| format!("--listen {listen}: cannot bind"))?;
    let local = listener.local_addr()?;
    let token = token()?;
    let loopback = local.ip().is_loopback();
    let policy = Arc::new(http::Policy {
        token: token.clone(),
        port: local.port(),
        loopback,
    });
    crate::output::catch_signals()?;
    if !loopback {
        crate::errln!(
            "console: WARNING: --listen {listen} is not a loopback address: anyone on that network who learns the URL (it is sent in clear over plain HTTP) can drive the robot; prefer 127.0.0.1 and an SSH tunnel"
        );
    }
    let shown = if local.ip().is_unspecified() {
        SocketAddr::new(std::net::Ipv4Addr::LOCALHOST.into(), local.port())
    } else {
        local
    };
    crate::outln!("console: open http://{shown}/?token={token}")?;
    let fox = match &a.foxglove {
        Some(f) => Some(foxglove_listener(f, &token)?),
        None => None,
    };
    crate::output::flush_stdout()?;
    crate::errln!(
        "console: relaying to the robot at {} (Ctrl-C stops)",
        a.connect
    );

    let (hub, rx) = Hub::new();
    if let Some(l) = robot_limits {
        let _ = hub.robot_limits.set(l);
    }
    hub.publish(
        &serde_json::json!({"type": "config", "speed": a.speed, "turn": a.turn,
            "heartbeat_hz": a.heartbeat, "mcap": true, "start_tolerance_m": a.start_tolerance,
            "record_dir": a.record_dir.display().to_string()}),
        Some("config"),
    );
    if let Some(m) = &map {
        hub.publish(
            &omnikin_host::console::map_view::map_message(m),
            Some("map"),
        );
    }
    let cfg = relay::RelayConfig {
        connect: a.connect.clone(),
        key: a.key.clone(),
        heartbeat_hz: a.heartbeat,
        timeout_s: a.timeout,
        speed: a.speed,
        turn: a.turn,
        record_dir: a.record_dir.clone(),
        fox: fox.as_ref().map(|(_, h)| h.clone()),
    };
    let relay = {
        let hub = hub.clone();
        std::thread::Builder::new()
            .name("relay".into())
            .spawn(move || relay::run(hub, rx, cfg, first))?
    };
    if let Some((listener, fox)) = fox {
        let (hub, policy) = (hub.clone(), policy_for(&listener, &token)?);
        std::thread::Builder::new()
            .name("foxglove".into())
            .spawn(move || foxglove_accept(listener, policy, hub, fox))?;
    }
    let end = match a.duration {
        Some(s) => Some(Instant::now() + crate::args::duration("--for", s)?),
        None => None,
    };
    let mut gate = gate::Gate::new(listener).context("--listen: cannot poll the socket")?;
    let http_slots = Arc::new(AtomicUsize::new(0));
    let page_slots = Arc::new(AtomicUsize::new(0));
    let result = loop {
        if let Some(sig) = crate::output::interrupted() {
            break Err(sig.into());
        }
        if end.is_some_and(|e| Instant::now() >= e) || relay.is_finished() {
            break Ok(());
        }
        let turned = gate.turn(Duration::from_millis(20), &mut |h| {
            page_head(h, &policy, &hub, &http_slots, &page_slots);
        });
        if let Err(e) = turned {
            break Err(e).context("--listen: polling the socket failed");
        }
    };
    if gate.evicted() > 0 {
        crate::errln!(
            "console: closed {} connections on --listen that had not finished their request head when newer ones came (a slowloris attack, or a very slow link)",
            gate.evicted()
        );
    }
    hub.shutdown.store(true, Ordering::SeqCst);
    // The relay sends a stop if it was driving; its receive slices are short.
    let deadline = Instant::now() + Duration::from_secs(2);
    while !relay.is_finished() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
    result
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
        crate::errln!("console: cannot start a thread for a connection");
    }
}

/// One admitted request on its worker: the response, or the websocket of a page.
fn exchange(
    mut stream: TcpStream,
    route: http::Route,
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
        http::Route::Page => {
            let _ = http::respond(
                &mut stream,
                200,
                "text/html; charset=utf-8",
                http::page(&policy.token).as_bytes(),
            );
        }
        http::Route::Asset(ctype, body) => {
            let _ = http::respond(&mut stream, 200, ctype, body.as_bytes());
        }
        http::Route::WebSocket(key) => {
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

/// Binds `--foxglove` and prints its URL (with the console's token).
fn foxglove_listener(addr: &str, token: &str) -> Result<(TcpListener, Arc<foxglove_ws::FoxHub>)> {
    let at: SocketAddr = addr.parse().with_context(|| {
        format!("--foxglove: expected HOST:PORT (e.g. 127.0.0.1:8765), got \"{addr}\"")
    })?;
    let l = TcpListener::bind(at).with_context(|| format!("--foxglove {at}: cannot bind"))?;
    let local = l.local_addr()?;
    if !local.ip().is_loopback() {
        crate::errln!(
            "console: WARNING: --foxglove {at} is not a loopback address: anyone on that network who learns the URL can watch the robot"
        );
    }
    let shown = if local.ip().is_unspecified() {
        SocketAddr::new(std::net::Ipv4Addr::LOCALHOST.into(), local.port())
    } else {
        local
    };
    crate::outln!("console: foxglove ws://{shown}/?token={token}")?;
    Ok((l, Arc::new(foxglove_ws::FoxHub::default())))
}

fn policy_for(l: &TcpListener, token: &str) -> Result<http::Policy> {
    let local = l.local_addr()?;
    Ok(http::Policy {
        token: token.to_string(),
        port: local.port(),
        loopback: local.ip().is_loopback(),
    })
}

/// At most this many Foxglove clients at once, counted after the access rules (more get 503).
const MAX_FOXGLOVE: usize = 4;

/// The Foxglove port's gate until the console shuts down: the access rules for each complete
/// head, then a worker per admitted client (at most [`MAX_FOXGLOVE`]).
fn foxglove_accept(
    l: TcpListener,
    policy: http::Policy,
    hub: Arc<Hub>,
    fox: Arc<foxglove_ws::FoxHub>,
) {
    let mut gate = match gate::Gate::new(l) {
        Ok(g) => g,
        Err(e) => {
            crate::errln!("console: --foxglove: cannot poll the socket: {e}");
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
            crate::errln!("console: --foxglove: polling the socket failed: {e}");
            return;
        }
    }
}
