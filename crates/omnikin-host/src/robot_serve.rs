//! The robot's side of the link for a simulated robot — `omnikin robot --sim` and Python's
//! `omnikin.SimRobot`: a [`SimRobot`] served over UDP or a serial port in real time (or
//! `time_scale` times faster), with the robot's defences against an outsider (a Hello rate
//! limit per sender, QUIC's anti-amplification rule), telemetry to the operator that opened
//! the session, and the `--log` CSV and `--mcap` logs kept on every exit.
//!
//! [`RobotServer::new`] checks and binds (errors come back before anything runs: a
//! front end can report them, or read [`RobotServer::local_addr`] when it asked for port 0);
//! [`RobotServer::run`] serves until the robot time reaches `max_time`, a signal arrives (the
//! front end installs the handlers: `omnikin_io::output::catch_signals`) or its stop flag is
//! set, and returns the run's summary.

use std::collections::HashMap;
use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin::link::{
    DropReason, FrameKind, Key, MAX_FRAME, Message, RobotEvent, RobotLink, SimTruth, peek_kind,
};
use omnikin_io::errln;
use omnikin_io::mcap_log::McapLog;
use omnikin_io::output::{Interrupted, OutFile};

use crate::link_io::{Address, Link, OsEntropy, Transport, load_key, parse_address};
use crate::names::OptionNames;
use crate::sim_robot::{SimOptions, SimRobot};

/// Robot time (s) without a frame of the active session after which telemetry stops (or four
/// watchdog periods, if longer); the next frame of the session resumes it.
pub const TELEMETRY_IDLE_S: f64 = 2.0;

/// How the robot is served (`omnikin robot`'s link and log flags).
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// Where to serve the link: `HOST:PORT` (UDP; port 0 picks a free one) or
    /// `serial:PATH[@BAUD]`.
    pub listen: String,
    /// Shared key file: only an operator with the same key opens a session.
    pub key: Option<PathBuf>,
    /// Without a key, listen on a UDP address that is not loopback anyway.
    pub insecure: bool,
    /// Telemetry rate, Hz (robot time).
    pub telemetry_rate: f64,
    /// Robot time per wall-clock time (1: real time).
    pub time_scale: f64,
    /// Stop after this much robot time, s (`None`: until stopped).
    pub max_time: Option<f64>,
    /// One CSV row per control cycle ([`SimRobot::log_header`]).
    pub log: Option<PathBuf>,
    /// The same as MCAP with Foxglove schemas.
    pub mcap: Option<PathBuf>,
    /// How the front end names these options in its errors.
    pub names: OptionNames,
}

impl ServeOptions {
    /// Serving on `listen` at `omnikin robot`'s defaults: 20 Hz telemetry, real time, no
    /// logs, no key.
    pub fn new(listen: impl Into<String>) -> Self {
        ServeOptions {
            listen: listen.into(),
            key: None,
            insecure: false,
            telemetry_rate: 20.0,
            time_scale: 1.0,
            max_time: None,
            log: None,
            mcap: None,
            names: OptionNames::CLI,
        }
    }
}

/// How a [`RobotServer::run`] ended.
#[derive(Debug)]
pub struct ServeSummary {
    /// The run's summary: robot time, the link's counters, sessions, and the runtime's fields
    /// ([`SimRobot::summary`]) — what `omnikin robot --max-time` prints.
    pub summary: serde_json::Value,
    /// The signal that ended it, if one did.
    pub interrupted: Option<Interrupted>,
}

/// A simulated robot bound to its address, ready to serve (module doc).
pub struct RobotServer {
    sim: SimRobot,
    link: Link,
    robot_link: RobotLink,
    info: omnikin::link::RobotInfo,
    local: Option<SocketAddr>,
    log: Option<OutFile>,
    mcap: Option<McapLog>,
    options: ServeOptions,
    watchdog: f64,
}

impl RobotServer {
    /// Builds the simulated robot, loads the key, checks the address (without a key, only a
    /// loopback address or a serial port unless `insecure`) and binds it, and opens the logs.
    ///
    /// # Errors
    /// Bad options (named by their flag), a key file that cannot be read, an address that
    /// cannot be bound, a log that cannot be created.
    pub fn new(desc: &RobotDescription, sim: &SimOptions, options: ServeOptions) -> Result<Self> {
        let robot = SimRobot::new(sim, desc)?;
        let n = options.names;
        let key: Option<Key> = options
            .key
            .as_deref()
            .map(|k| load_key(k, n.key))
            .transpose()?;
        let addr = parse_address(&options.listen, n.listen)?;
        if key.is_none()
            && !options.insecure
            && matches!(addr, Address::Udp(u) if !u.ip().is_loopback())
        {
            if n == OptionNames::CLI {
                bail!(
                    "--listen {}: without --key the link is unauthenticated, so the robot listens only on a loopback address (127.0.0.1:PORT) or a serial port; give --key FILE (the same file as the operator's), or --insecure to let anyone who reaches this address drive the robot",
                    options.listen
                );
            }
            bail!(
                "{} {}: without {k} the link is unauthenticated, so the robot listens only on a loopback address (127.0.0.1:PORT) or a serial port; give {k} (a key file, the same as the operator's)",
                n.listen,
                options.listen,
                k = n.key
            );
        }
        let transport = Transport::open(&addr, true, n.listen)?;
        let local = match &transport {
            Transport::Udp { socket, .. } => socket.local_addr().ok(),
            Transport::Serial(_) => None,
        };
        let auth = key.is_some();
        let info = robot.info(auth);
        // The log is kept on every exit path: errors drop it (renamed into place with what it
        // has), a signal or the stop flag ends the loop (see omnikin_io::output).
        let log = match &options.log {
            Some(p) => {
                let mut w = OutFile::log(n.log, p)?;
                writeln!(w, "{}", robot.log_header())
                    .with_context(|| format!("{}: cannot write", n.log))?;
                Some(w)
            }
            None => None,
        };
        let mcap = options
            .mcap
            .as_deref()
            .map(|p| McapLog::create(n.mcap, p, "omnikin robot", true))
            .transpose()?;
        errln!(
            "robot: {} ({}) simulated, {} Hz control, listening on {} (protocol v{}, {}), {}",
            desc.name,
            desc.kind(),
            robot.rate_hz(),
            local.map_or_else(|| options.listen.clone(), |a| a.to_string()),
            omnikin::link::PROTOCOL_VERSION,
            if auth { "authenticated" } else { "no key" },
            robot.plant_name(sim.disturbances.as_deref()),
        );
        if !auth {
            errln!(
                "robot: WARNING: the link is UNAUTHENTICATED (no {}): anyone who can send to {} can open a session and drive this robot",
                n.key,
                local.map_or_else(|| options.listen.clone(), |a| a.to_string())
            );
        }
        Ok(RobotServer {
            sim: robot,
            link: Link::new(transport),
            robot_link: RobotLink::new(key),
            info,
            local,
            log,
            mcap,
            options,
            watchdog: sim.watchdog,
        })
    }

    /// The bound UDP address (`None` on a serial port).
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.local
    }

    /// Serves until `max_time` of robot time, a signal (when the front end catches them) or
    /// `stop` set; writes the logs and returns the summary.
    ///
    /// # Errors
    /// The transport failing, a log that cannot be written, the plant's errors.
    pub fn run(self, stop: Option<&AtomicBool>) -> Result<ServeSummary> {
        let RobotServer {
            mut sim,
            mut link,
            mut robot_link,
            info,
            mut log,
            mut mcap,
            options: a,
            watchdog,
            ..
        } = self;
        let rate = sim.rate_hz();
        let period = 1.0 / rate;
        let tele_every = ((rate / a.telemetry_rate).round() as u64).max(1);
        let start = Instant::now();
        let mut k: u64 = 0;
        let mut stopped_by = None;
        // Where telemetry goes: the address that proved the session key — the source of the open
        // frame that opened the session, which the core also checked received the HelloAck (the
        // robot's nonce is bound to the address). Fixed for the session: never moved by a Hello or
        // by a frame from elsewhere (an operator whose address changes opens a new session).
        let mut active: Option<SocketAddr> = None;
        let mut amp = AmplificationBudget::default();
        let mut hellos = HelloLimiter::default();
        let mut sessions = 0u32;
        let mut takeovers = 0u32;
        let mut refused = 0u32;
        let mut reply = [0u8; MAX_FRAME];
        // Robot time of the active session's newest frame: telemetry stops after
        // `TELEMETRY_IDLE_S` of silence (nobody is listening, or the address changed hands).
        let mut last_heard_us = 0u64;
        loop {
            let now = sim.time_us();
            // Frames that arrived since the last cycle (the newest valid command wins).
            let mut ack = false;
            for f in link.poll(Duration::ZERO)? {
                let Some(mut bytes) = f.bytes else {
                    robot_link.count_framing_drop();
                    continue;
                };
                amp.received(f.from, bytes.len() + 1);
                // A Hello costs three MACs and an answer: a sender over its rate is dropped
                // unread (a flood of replayed Hellos; WireGuard's handshake rate limit).
                if peek_kind(&bytes) == Some(FrameKind::Hello) && !hellos.allow(f.from) {
                    robot_link.count_throttled();
                    continue;
                }
                let (peer, peer_len) = crate::link_io::peer_bytes(f.from);
                match robot_link.receive(
                    &mut bytes,
                    now,
                    &peer[..peer_len],
                    &info,
                    &mut OsEntropy,
                    &mut reply,
                ) {
                    Ok(RobotEvent::Hello(n)) => {
                        // Never larger than the Hello it answers (the core checks it).
                        amp.sent(f.from, n);
                        link.transport.send_to(&reply[..n], f.from)?;
                    }
                    Ok(RobotEvent::Busy(n)) => {
                        // The sender proved the key; one answer smaller than its frame.
                        amp.sent(f.from, n);
                        refused += 1;
                        link.transport.send_to(&reply[..n], f.from)?;
                    }
                    Ok(RobotEvent::Message {
                        seq,
                        msg,
                        new_session,
                        replaced,
                    }) => {
                        if new_session {
                            if let Some(n) = replaced {
                                // The previous operator's address was validated by its session.
                                link.transport.send_to(&reply[..n], active)?;
                                takeovers += 1;
                            }
                            sessions += 1;
                            active = f.from;
                            // Telemetry at once: its first frame confirms the session to the
                            // operator.
                            ack = true;
                            errln!(
                                "robot: session {:016x} opened{}{}",
                                robot_link.session_id().unwrap_or(0),
                                active.map(|a| format!(" by {a}")).unwrap_or_default(),
                                if replaced.is_some() {
                                    " (replacing the previous session, whose operator is told)"
                                } else {
                                    ""
                                }
                            );
                        }
                        last_heard_us = now;
                        sim.serve(&mut robot_link, seq, &msg, now);
                        ack |= matches!(
                            msg,
                            Message::PlanBegin { .. }
                                | Message::PlanSplice { .. }
                                | Message::PlanSpliceRebased { .. }
                                | Message::PlanChunk { .. }
                                | Message::PlanStart { .. }
                        );
                    }
                    // A v1 peer: one v1 answer it can print ("protocol 4"), within its budget.
                    Err(DropReason::Version(1)) => {
                        if let Ok(n) = robot_link.version_reply(&info, &mut reply)
                            && amp.allow_reply(f.from, n)
                        {
                            link.transport.send_to(&reply[..n], f.from)?;
                        }
                    }
                    Err(_) => {}
                }
            }
            sim.cycle();
            let heard = sim.time_us().saturating_sub(last_heard_us) as f64 * 1e-6;
            if robot_link.session_id().is_some()
                && heard <= TELEMETRY_IDLE_S.max(4.0 * watchdog)
                && (ack || k.is_multiple_of(tele_every))
                && let Some(t) = sim.telemetry(&robot_link)
            {
                let mut buf = [0u8; MAX_FRAME];
                // The estimate first, so that an operator has it when the telemetry of the same
                // cycle arrives.
                if let Some(e) = sim.estimate()
                    && let Ok(n) = robot_link.encode(&Message::Estimate(e), &mut buf)
                {
                    link.transport.send_to(&buf[..n], active)?;
                }
                // A simulation knows the truth: the operator can draw it against the estimate.
                let p = sim.true_pose();
                let truth = SimTruth {
                    time_us: t.time_us,
                    pose: [p.x as f32, p.y as f32, p.heading as f32],
                };
                if let Ok(n) = robot_link.encode(&Message::Truth(truth), &mut buf) {
                    link.transport.send_to(&buf[..n], active)?;
                }
                if let Ok(n) = robot_link.encode(&Message::Telemetry(t), &mut buf) {
                    link.transport.send_to(&buf[..n], active)?;
                }
            }
            if let Some(w) = log.as_mut()
                && let Some(row) = sim.log_row(robot_link.counters())
            {
                writeln!(w, "{row}").with_context(|| format!("{}: cannot write", a.names.log))?;
            }
            if let Some(m) = mcap.as_mut() {
                sim.mcap_cycle(m, robot_link.counters())?;
            }
            sim.advance(period)?;
            k += 1;
            if a.max_time.is_some_and(|m| sim.time_us() as f64 * 1e-6 >= m) {
                break;
            }
            if let Some(sig) = omnikin_io::output::interrupted() {
                stopped_by = Some(sig);
                break;
            }
            if stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
                break;
            }
            let due =
                crate::operator::duration("--rate/--time-scale", k as f64 * period / a.time_scale)
                    .ok()
                    .and_then(|d| start.checked_add(d))
                    .context("--rate/--time-scale: the cycle schedule overflows")?;
            let now_wall = Instant::now();
            if due > now_wall {
                std::thread::sleep(due - now_wall);
            }
        }
        if let Some(w) = log {
            w.commit()?;
        }
        if let Some(m) = mcap {
            m.finish()?;
        }
        let c = robot_link.counters();
        let mut summary = serde_json::json!({
            "time_s": sim.time_us() as f64 * 1e-6,
            "link": {"ok": c.ok, "framing": c.framing, "crc": c.crc, "version": c.version, "auth": c.auth, "replay": c.replay, "malformed": c.malformed, "session": c.session, "entropy": c.entropy, "throttled": c.throttled, "stale": c.stale, "dropped": c.dropped(), "sessions": sessions, "takeovers": takeovers, "refused_busy": refused},
        });
        if let (Some(o), serde_json::Value::Object(r)) = (summary.as_object_mut(), sim.summary()) {
            o.extend(r);
        }
        Ok(ServeSummary {
            summary,
            interrupted: stopped_by,
        })
    }
}

/// Hellos answered per sender: a token bucket per address ([`HelloLimiter::PER_SECOND`] a
/// second, bursts of [`HelloLimiter::BURST`]), as WireGuard limits handshake initiations. An
/// operator retransmits its Hello at its heartbeat rate until answered, well inside it; a
/// flood from one socket is dropped unread. At most [`HelloLimiter::MAX_ADDRESSES`] senders are
/// tracked; the table is cleared when full (every sender starts with a full bucket again),
/// which keeps the work per frame constant under a spoofed-address flood.
#[derive(Default)]
struct HelloLimiter {
    buckets: HashMap<Option<SocketAddr>, (f64, Instant)>,
}

impl HelloLimiter {
    const PER_SECOND: f64 = 20.0;
    const BURST: f64 = 5.0;
    const MAX_ADDRESSES: usize = 4096;

    /// Takes a token for a Hello from `from`; `false` when its bucket is empty.
    fn allow(&mut self, from: Option<SocketAddr>) -> bool {
        let now = Instant::now();
        if self.buckets.len() >= Self::MAX_ADDRESSES && !self.buckets.contains_key(&from) {
            self.buckets.clear();
        }
        let (tokens, last) = self.buckets.entry(from).or_insert((Self::BURST, now));
        *tokens =
            (*tokens + now.duration_since(*last).as_secs_f64() * Self::PER_SECOND).min(Self::BURST);
        *last = now;
        if *tokens >= 1.0 {
            *tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

/// Anti-amplification for the answers the robot sends before an address has proved itself
/// (QUIC's rule, RFC 9000 §8, with a factor of 1 instead of 3): per sender, the bytes sent
/// never exceed the bytes received, and version-mismatch answers go out at most every
/// [`AmplificationBudget::MIN_GAP`]. At most [`AmplificationBudget::MAX_ADDRESSES`] senders are
/// tracked; a new one beyond that forgets the oldest (whose budget is then zero again).
#[derive(Default)]
struct AmplificationBudget {
    /// Per sender: bytes received, bytes sent, order of first contact.
    peers: HashMap<Option<SocketAddr>, (u64, u64, u64)>,
    next: u64,
    last_reply: Option<Instant>,
}

impl AmplificationBudget {
    const MAX_ADDRESSES: usize = 1024;
    const MIN_GAP: Duration = Duration::from_millis(100);

    fn received(&mut self, from: Option<SocketAddr>, n: usize) {
        if !self.peers.contains_key(&from) && self.peers.len() >= Self::MAX_ADDRESSES {
            let oldest = self.peers.iter().min_by_key(|(_, v)| v.2).map(|(k, _)| *k);
            if let Some(o) = oldest {
                self.peers.remove(&o);
            }
        }
        self.next += 1;
        let next = self.next;
        let e = self.peers.entry(from).or_insert((0, 0, next));
        e.0 += n as u64;
    }

    fn sent(&mut self, to: Option<SocketAddr>, n: usize) {
        if let Some(e) = self.peers.get_mut(&to) {
            e.1 += n as u64;
        }
    }

    /// Whether an `n`-byte answer to `to` fits its budget and the rate limit (and books it).
    fn allow_reply(&mut self, to: Option<SocketAddr>, n: usize) -> bool {
        let now = Instant::now();
        if self
            .last_reply
            .is_some_and(|t| now.duration_since(t) < Self::MIN_GAP)
        {
            return false;
        }
        match self.peers.get_mut(&to) {
            Some(e) if e.1 + n as u64 <= e.0 => {
                e.1 += n as u64;
                self.last_reply = Some(now);
                true
            }
            _ => false,
        }
    }
}
