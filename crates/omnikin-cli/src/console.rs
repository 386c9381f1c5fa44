//! `omnikin console`: a local web page that shows and drives the robot, relayed over the
//! operator link (`drive`'s session). The server, its access rules and the relay are
//! omnikin-host's ([`omnikin_host::console::server`]); this is the command's flags and glue.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use omnikin_host::console::server::{ConsoleOptions, ConsoleServer};

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

/// `HOST:PORT` of `flag`, with the example the error shows.
fn socket_address(flag: &str, addr: &str, example: &str) -> Result<std::net::SocketAddr> {
    addr.parse()
        .with_context(|| format!("{flag}: expected HOST:PORT (e.g. {example}), got \"{addr}\""))
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
    let listen = socket_address("--listen", &a.listen, "127.0.0.1:8090")?;
    let foxglove = match &a.foxglove {
        Some(f) => Some(socket_address("--foxglove", f, "127.0.0.1:8765")?),
        None => None,
    };
    let server = ConsoleServer::bind(ConsoleOptions {
        connect: a.connect.clone(),
        key: a.key.clone(),
        listen,
        heartbeat_hz: a.heartbeat,
        timeout_s: a.timeout,
        speed: a.speed,
        turn: a.turn,
        record_dir: a.record_dir.clone(),
        foxglove,
        start_tolerance_m: a.start_tolerance,
        robot_limits,
        map,
    })?;
    crate::output::catch_signals()?;
    for w in server.warnings() {
        crate::errln!("console: WARNING: {w}");
    }
    crate::outln!("console: open {}", server.url()?)?;
    if let Some(url) = server.foxglove_url()? {
        crate::outln!("console: foxglove {url}")?;
    }
    crate::output::flush_stdout()?;
    crate::errln!(
        "console: relaying to the robot at {} (Ctrl-C stops)",
        a.connect
    );
    let until = match a.duration {
        Some(s) => Some(Instant::now() + crate::args::duration("--for", s)?),
        None => None,
    };
    let summary = server.run(until, None)?;
    if summary.evicted > 0 {
        crate::errln!(
            "console: closed {} connections on --listen that had not finished their request head when newer ones came (a slowloris attack, or a very slow link)",
            summary.evicted
        );
    }
    match summary.interrupted {
        Some(sig) => Err(sig.into()),
        None => Ok(()),
    }
}
