//! The operator's session with a robot over the link: the handshake (with a v1 probe that
//! names a protocol mismatch, and the diagnosis of a failed handshake), the session frames at
//! the heartbeat rate, the newest telemetry, estimate and true pose of this session, the
//! telemetry logs (CSV, MCAP), and camera fixes forwarded as they fall due. `omnikin drive`
//! runs its actions on it; the console drives it from its own loop
//! ([`crate::console_operator`]).

use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use omnikin::link::{
    DropReason, EndReason, Estimate, Key, MAX_FRAME, Message, OperatorEvent, OperatorLink,
    PROTOCOL_VERSION, RobotInfo, SimTruth, Telemetry, v1,
};

use crate::link_io::{Link, OsEntropy, Transport, epoch_seq, load_key, parse_address};
use crate::names::OptionNames;
use crate::telemetry_log::{estimate_cells, telemetry_header, telemetry_row};

/// Seconds as a [`Duration`], or an error naming `what` (the flag or argument; never the
/// panic of `Duration::from_secs_f64` on a negative, huge or NaN value).
pub fn duration(what: &str, secs: f64) -> Result<Duration> {
    Duration::try_from_secs_f64(secs).map_err(|_| {
        anyhow::anyhow!("{what}: {secs} s is not a representable duration (0 to 1.8e19 s)")
    })
}

/// A v1 HelloAck (the robot's answer to the v1 probe, or a v1 robot's answer).
#[derive(Clone, Copy, Debug)]
pub struct V1Answer {
    /// The protocol it names.
    pub protocol: u8,
    /// It says the robot has a key.
    pub robot_keyed: bool,
    /// Its tag verified under this operator's key: the robot (or a holder of the key) sent it.
    /// Otherwise it is only known to come from the robot's address, which anyone can forge.
    pub proven: bool,
}

/// The robot did not open the session: another operator's session is live and this operator
/// did not ask to take over ([`Message::Busy`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RobotBusy {
    /// The live session's id.
    pub holder: u64,
    /// Robot time since that session's newest frame, ms.
    pub idle_ms: u32,
    /// Robot time since that session opened, s.
    pub held_s: u32,
}

impl std::fmt::Display for RobotBusy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the robot is held by another operator (session {:016x}, for {} s, last heard {} ms ago); take over to drive it",
            self.holder, self.held_s, self.idle_ms
        )
    }
}

impl std::error::Error for RobotBusy {}

/// An operator session: the link, the newest telemetry of this session, an optional CSV log.
pub struct Session {
    /// The transport and its framing.
    pub link: Link,
    /// The operator's end of the link protocol (handshake, session, counters).
    pub op: OperatorLink,
    /// The shared key, if the link is keyed.
    pub key: Option<Key>,
    /// The robot's address as given (`HOST:PORT`, `udp:…`, `serial:PATH[@BAUD]`).
    pub addr: String,
    /// The newest telemetry of this session (by robot time).
    pub latest: Option<Telemetry>,
    /// The newest estimate of this session (robots that fuse fixes send one per telemetry).
    pub estimate: Option<Estimate>,
    /// The newest true pose of this session (`robot --sim` sends one per telemetry).
    pub truth: Option<SimTruth>,
    /// `--fixes`: the fixes to forward.
    pub fixes: Option<crate::fixes::FixFeeder>,
    /// When the newest telemetry frame of this session arrived.
    pub last_telemetry: Option<Instant>,
    /// What a v1 HelloAck said (the answer to the v1 probe), if it was authenticated by this
    /// operator's key or came from the robot's own address.
    pub v1_answer: Option<V1Answer>,
    /// `--out`: the telemetry CSV log ([`crate::telemetry_log`]).
    pub log: Option<omnikin_io::output::OutFile>,
    /// The `--out` log's columns: (wheels, steer motors), from the first telemetry frame and
    /// the robot's kind; the header is written then.
    pub log_layout: Option<(usize, bool)>,
    /// The telemetry log kept in memory, in the CSV log's columns (Python's `omnikin.Link`).
    pub memory: Option<crate::telemetry_log::MemoryLog>,
    /// Asked between receives: an error ends the wait (Python's pending `KeyboardInterrupt`;
    /// the binary's SIGINT/SIGTERM are checked always).
    pub interrupt: Option<Box<dyn FnMut() -> Result<()> + Send>>,
    /// `--mcap`: the MCAP log.
    pub mcap: Option<omnikin_io::mcap_log::McapLog>,
    /// Telemetry frames of this session received.
    pub frames: u64,
    /// The heartbeat (command repeat) period.
    pub heartbeat: Duration,
    /// How long without an answer before giving up.
    pub timeout: Duration,
    /// How the front end names the options its errors point to.
    pub names: OptionNames,
}

impl Drop for Session {
    /// On every other exit path (an error, Ctrl-C): the log's header if it has none yet; the
    /// log itself is then kept by its own drop (omnikin_io::output).
    fn drop(&mut self) {
        if let Err(e) = self.log_header_if_none() {
            omnikin_io::errln!("warning: --out: cannot write: {e}");
        }
    }
}

impl Session {
    /// Opens the transport to `connect` (`HOST:PORT`, `udp:HOST:PORT` or
    /// `serial:PATH[@BAUD]`) with an optional key file, the heartbeat rate (Hz) and the
    /// timeout (s) as `drive --heartbeat/--timeout`, and an MCAP log at `mcap` (`--mcap`);
    /// `names`: how the front end calls these options in its errors. The
    /// session takes the robot over from another operator (its user's act); the console turns
    /// that off ([`crate::console_operator::ConsoleOperator`]). Nothing is sent yet: see
    /// [`Session::hello`].
    pub fn open(
        connect: &str,
        key: Option<&Path>,
        heartbeat_hz: f64,
        timeout_s: f64,
        mcap: Option<&Path>,
        names: OptionNames,
    ) -> Result<Self> {
        let n = names;
        if heartbeat_hz <= 0.0 {
            bail!("{} must be > 0 Hz (got {})", n.heartbeat, heartbeat_hz);
        }
        if timeout_s <= 0.0 {
            bail!("{} must be > 0 s (got {})", n.timeout, timeout_s);
        }
        let key = key.map(|k| load_key(k, n.key)).transpose()?;
        let addr = parse_address(connect, n.connect)?;
        let link = Link::new(Transport::open(&addr, false, n.connect)?);
        let mcap = mcap
            .map(|p| omnikin_io::mcap_log::McapLog::create(n.mcap, p, "omnikin drive", true))
            .transpose()?;
        if mcap.is_some() {
            omnikin_io::output::catch_signals()?;
        }
        // `drive` is its user's act: it takes the robot over from another operator (who is
        // told). The console asks first (ConsoleOperator::set_take_over).
        let mut op = OperatorLink::new(key.clone());
        op.set_take_over(true);
        Ok(Self {
            link,
            op,
            key,
            addr: connect.to_string(),
            latest: None,
            estimate: None,
            truth: None,
            fixes: None,
            last_telemetry: None,
            v1_answer: None,
            log: None,
            log_layout: None,
            memory: None,
            interrupt: None,
            mcap,
            frames: 0,
            heartbeat: duration(n.heartbeat, 1.0 / heartbeat_hz)?,
            timeout: duration(n.timeout, timeout_s)?,
            names,
        })
    }

    /// `--out`: records every telemetry frame of the session to the CSV log at `out`
    /// ([`crate::telemetry_log`]), kept on every exit path, Ctrl-C included.
    pub fn record(&mut self, out: Option<&Path>) -> Result<()> {
        if let Some(p) = out {
            // The log is kept on every exit path, Ctrl-C included (see omnikin_io::output). Its
            // header waits for the first telemetry frame: one column per wheel the robot has
            // (telemetry's `wheels`), steer columns only for kinds with steer motors.
            self.log = Some(omnikin_io::output::OutFile::log("--out", p)?);
            omnikin_io::output::catch_signals()?;
        }
        Ok(())
    }

    /// Sends `m` in this operator's session.
    pub fn send(&mut self, m: &Message) -> Result<()> {
        let mut buf = [0u8; MAX_FRAME];
        let n = self.op.encode(m, &mut buf)?;
        self.link.transport.send(&buf[..n])
    }

    /// Receives for `dur`; returns `true` if a new telemetry frame of this session arrived.
    /// Sends `m` when the heartbeat `next` is due (then the next one is a period later), and
    /// receives until the next one is due or frames arrive. A loop around it sends at the
    /// heartbeat rate however many frames the robot sends (telemetry, estimate, truth), and
    /// still sees every batch of them as it arrives.
    pub fn beat(&mut self, next: &mut Instant, m: &Message) -> Result<bool> {
        if Instant::now() >= *next {
            self.send(m)?;
            *next = Instant::now() + self.heartbeat;
        }
        self.pump(next.saturating_duration_since(Instant::now()))
    }

    /// Receives for up to `dur`: telemetry, estimates and true poses of this session (logged
    /// and kept as the newest), v1 answers (to name a version mismatch); forwards the fixes
    /// that are due. `true` if a new telemetry frame arrived. Fails on SIGINT/SIGTERM.
    pub fn pump(&mut self, dur: Duration) -> Result<bool> {
        let mut fresh = false;
        if let Some(sig) = omnikin_io::output::interrupted() {
            return Err(sig.into());
        }
        if let Some(f) = self.interrupt.as_mut() {
            f()?;
        }
        for f in self.link.poll(dur)? {
            let Some(mut bytes) = f.bytes else {
                self.op.count_framing_drop();
                continue;
            };
            let from_robot = match &self.link.transport {
                Transport::Udp { peer, .. } => f.from.is_some() && f.from == *peer,
                Transport::Serial(_) => true,
            };
            let copy = bytes.clone();
            match self.op.receive(&mut bytes) {
                Ok(OperatorEvent::Message {
                    msg: Message::Telemetry(t),
                    ..
                }) => {
                    if self.latest.is_none_or(|l| t.time_us >= l.time_us) {
                        self.latest = Some(t);
                    }
                    if self.log.is_some() || self.memory.is_some() {
                        let (wheels, steer) = self.layout(&t)?;
                        let e = self.estimate.as_ref().filter(|e| e.time_us == t.time_us);
                        let row =
                            format!("{}{}", telemetry_row(&t, wheels, steer), estimate_cells(e));
                        if let Some(w) = self.log.as_mut() {
                            writeln!(w, "{row}").context("--out: cannot write")?;
                        }
                        if let Some(m) = self.memory.as_mut() {
                            m.push(row);
                        }
                    }
                    if let Some(m) = self.mcap.as_mut() {
                        m.sample(&omnikin_io::mcap_log::telemetry_sample_with_truth(
                            &t, self.truth,
                        ))?;
                    }
                    self.last_telemetry = Some(Instant::now());
                    self.frames += 1;
                    fresh = true;
                    if let Some(f) = self.fixes.as_mut() {
                        let now = self.latest.map_or(0, |l| l.time_us);
                        for m in f.due(now)? {
                            self.send(&m)?;
                        }
                    }
                }
                Ok(OperatorEvent::Message {
                    msg: Message::Estimate(e),
                    ..
                }) if self.estimate.is_none_or(|l| e.time_us >= l.time_us) => {
                    self.estimate = Some(e);
                }
                Ok(OperatorEvent::Message {
                    msg: Message::Truth(x),
                    ..
                }) if self.truth.is_none_or(|l| x.time_us >= l.time_us) => {
                    self.truth = Some(x);
                }
                Err(DropReason::Version(1)) => {
                    // Only to name a mismatch. Authenticated by this operator's key it ends
                    // the handshake at once; otherwise it is kept only from the robot's own
                    // address, and named only if the handshake times out (a forged v1 answer
                    // ends nothing).
                    let proven = self.key.as_ref().and_then(|k| {
                        match v1::parse(&mut copy.clone(), Some(k)) {
                            Some((_, v1::V1Frame::HelloAck(i))) => Some(i),
                            _ => None,
                        }
                    });
                    let plain = match v1::parse(&mut copy.clone(), None) {
                        Some((_, v1::V1Frame::HelloAck(i))) if from_robot => Some(i),
                        _ => None,
                    };
                    if let Some(i) = proven.or(plain)
                        && self.v1_answer.is_none_or(|a| !a.proven)
                    {
                        self.v1_answer = Some(V1Answer {
                            protocol: i.protocol,
                            robot_keyed: i.authenticated,
                            proven: proven.is_some(),
                        });
                    }
                }
                _ => {}
            }
        }
        Ok(fresh)
    }

    /// Fails when the session is over: taken over by another operator, or no telemetry of
    /// this session for the timeout.
    pub fn alive(&self) -> Result<()> {
        if let Some(EndReason::TakenOver) = self.op.ended() {
            bail!(
                "session taken over: another operator completed a handshake with the robot at {} (one operator session at a time)",
                self.addr
            );
        }
        if let Some(t) = self.last_telemetry
            && t.elapsed() > self.timeout
        {
            if self.latest.is_none() {
                // The robot opened the session, but no telemetry of it ever came (lost).
                bail!(
                    "the robot at {} opened the session but sent no telemetry of it in {:.1} s (frames lost); try again",
                    self.addr,
                    self.timeout.as_secs_f64()
                );
            }
            bail!(
                "lost the session with the robot at {}: no telemetry of this session for {:.1} s (link down, or the robot restarted)",
                self.addr,
                self.timeout.as_secs_f64()
            );
        }
        Ok(())
    }

    /// Sends `m` every heartbeat period until `done` holds for the newest telemetry, or the
    /// timeout passes without it.
    pub fn until(
        &mut self,
        m: &Message,
        what: &str,
        mut done: impl FnMut(&Session) -> bool,
    ) -> Result<()> {
        let start = Instant::now();
        loop {
            self.send(m)?;
            let step_end = Instant::now() + self.heartbeat;
            while Instant::now() < step_end {
                self.pump(step_end.saturating_duration_since(Instant::now()))?;
                if done(self) {
                    return Ok(());
                }
                self.alive()?;
            }
            if start.elapsed() > self.timeout {
                bail!(
                    "the robot at {} did not confirm {what} within {:.1} s ({} telemetry frames of this session received)",
                    self.addr,
                    self.timeout.as_secs_f64(),
                    self.frames
                );
            }
        }
    }

    /// The handshake: Hello (retransmitted with the same nonce) until the robot's HelloAck,
    /// then the first session frames (a heartbeat in an open frame, repeated every heartbeat
    /// period) until the robot's first frame in the session shows it opened it. After half the
    /// timeout without an answer a v1 Hello probes for another protocol version; an answer to
    /// it authenticated by the key names a mismatch at once, an unauthenticated one from the
    /// robot's address names it if the handshake times out.
    ///
    /// # Errors
    /// [`RobotBusy`] when another operator holds the robot and this one does not take over;
    /// a version mismatch; no answer or no session within the timeout (the error says which).
    pub fn hello(&mut self) -> Result<RobotInfo> {
        let start = Instant::now();
        let mut buf = [0u8; MAX_FRAME];
        loop {
            match self.op.info() {
                None => {
                    let n = self.op.hello(&mut OsEntropy, &mut buf)?;
                    self.link.transport.send(&buf[..n])?;
                    if start.elapsed() > self.timeout / 2 {
                        let n = v1::encode_hello(epoch_seq(), self.key.as_ref(), &mut buf)?;
                        self.link.transport.send(&buf[..n])?;
                    }
                }
                Some(_) => self.send(&Message::Heartbeat)?,
            }
            let step_end = Instant::now() + self.heartbeat;
            while Instant::now() < step_end {
                let established = self.op.info().is_some();
                self.pump(step_end.saturating_duration_since(Instant::now()))?;
                if let Some(b) = self.op.busy() {
                    return Err(RobotBusy {
                        holder: b.holder,
                        idle_ms: b.idle_ms,
                        held_s: b.held_s,
                    }
                    .into());
                }
                if let Some(info) = self.op.info() {
                    if self.op.confirmed() {
                        self.last_telemetry = Some(Instant::now());
                        return Ok(info);
                    }
                    if !established {
                        // The answer came: the first open frame goes now.
                        self.send(&Message::Heartbeat)?;
                    }
                }
                if let Some(a) = self.v1_answer
                    && a.proven
                    && a.protocol != PROTOCOL_VERSION
                {
                    bail!(
                        "version mismatch: the robot at {} speaks protocol v{} (its answer was authenticated by {}), this omnikin speaks v{PROTOCOL_VERSION}; run the same omnikin version on both ends",
                        self.addr,
                        a.protocol,
                        self.names.key
                    );
                }
            }
            if start.elapsed() > self.timeout {
                return Err(self.no_session_error());
            }
        }
    }

    /// Why the handshake did not complete, as precisely as the evidence allows.
    /// Why no session was opened, as precisely as the answers allow.
    pub fn no_session_error(&self) -> anyhow::Error {
        let t = self.timeout.as_secs_f64();
        let c = self.op.counters();
        let n = self.names;
        if self.op.info().is_some() {
            return anyhow::anyhow!(
                "the robot at {} answered the handshake but did not open the session: no frame of it in {t:.1} s (frames lost on the way; try again)",
                self.addr
            );
        }
        let how = |a: &V1Answer| {
            if a.proven {
                format!("authenticated by {}", n.key)
            } else {
                "unauthenticated, from the robot's address".to_string()
            }
        };
        match (self.v1_answer, self.key.is_some()) {
            (Some(a), _) if a.protocol != PROTOCOL_VERSION => anyhow::anyhow!(
                "version mismatch: the robot at {} speaks protocol v{} (its answer to a v1 probe, {}), this omnikin speaks v{PROTOCOL_VERSION}; run the same omnikin version on both ends",
                self.addr,
                a.protocol,
                how(&a)
            ),
            // The robot speaks this version and answered the v1 probe but not the Hello: it
            // rejected the Hello.
            (Some(a), true) if a.robot_keyed && !a.proven => anyhow::anyhow!(
                "authentication failed: the robot at {} (protocol v{PROTOCOL_VERSION}) rejects this operator's Hello — {} is not the robot's key",
                self.addr,
                n.key
            ),
            (Some(a), false) if a.robot_keyed => anyhow::anyhow!(
                "authentication failed: the robot at {} requires a key; pass {} (the robot's key file)",
                self.addr,
                if n == OptionNames::CLI {
                    "--key FILE"
                } else {
                    n.key
                }
            ),
            (Some(a), true) if !a.robot_keyed => anyhow::anyhow!(
                "authentication failed: the robot at {} has no key but this operator sends {k}; drop {k} (or start the robot with the same key)",
                self.addr,
                k = n.key
            ),
            _ if c.auth > 0 => anyhow::anyhow!(
                "authentication failed: {} answers from {} carried no valid tag for this {}",
                c.auth,
                self.addr,
                n.key
            ),
            _ => anyhow::anyhow!(
                "no answer from the robot at {} within {t:.1} s: nothing came back (is {} running there, is {} right?)",
                self.addr,
                n.robot_program,
                n.connect
            ),
        }
    }

    /// Leaves the session (`Bye`) and closes the logs (committed under their names).
    pub fn finish(&mut self) -> Result<()> {
        // Leave the session: the robot is free for the next operator at once (not after the
        // 1 s during which a silent session still counts as live).
        if self.op.confirmed() {
            self.send(&Message::Bye)?;
        }
        if let Some(m) = self.mcap.take() {
            m.finish()?;
        }
        self.log_header_if_none().context("--out: cannot write")?;
        match self.log.take() {
            Some(w) => w.commit(),
            None => Ok(()),
        }
    }

    /// The logs' columns (wheels, steer motors), fixed by the first telemetry frame `t` and
    /// the robot's kind; the headers are written then.
    fn layout(&mut self, t: &Telemetry) -> Result<(usize, bool)> {
        if let Some(l) = self.log_layout {
            return Ok(l);
        }
        let steer = self.op.info().is_some_and(|i| i.kind.steerable());
        let l = (usize::from(t.wheels).min(omnikin::MAX_WHEELS), steer);
        let header = telemetry_header(l.0, l.1);
        if let Some(w) = self.log.as_mut() {
            writeln!(w, "{header}").context("--out: cannot write")?;
        }
        if let Some(m) = self.memory.as_mut() {
            m.header = Some(header);
        }
        self.log_layout = Some(l);
        Ok(l)
    }

    /// A log that never saw telemetry still gets a header (no wheel columns: none is known),
    /// so that an interrupted or failed run leaves a well-formed, empty CSV.
    fn log_header_if_none(&mut self) -> std::io::Result<()> {
        match (self.log.as_mut(), self.log_layout) {
            (Some(w), None) => {
                self.log_layout = Some((0, false));
                writeln!(w, "{}", telemetry_header(0, false))
            }
            _ => Ok(()),
        }
    }

    /// The sequence number the next command will carry.
    pub fn next_seq(&self) -> u64 {
        self.op.next_seq().unwrap_or(u64::MAX)
    }
}
