//! `omnikin drive`: the operator's side of the link — velocity commands, plan upload and
//! following, stop / e-stop / clear, telemetry logging and keyboard teleoperation.
//!
//! Shape: `omnikin drive --connect ADDR [--key FILE] [--heartbeat HZ] ACTION`, with ACTION one
//! of `hello`, `velocity --vx --vy --yaw-rate [--world] --for S`, `plan PLAN.csv`, `stop`,
//! `estop`, `clear`, `telemetry --out LOG.csv [--for S]`, `teleop`. `velocity`, `plan` and
//! `telemetry` take `--out LOG.csv` to record every telemetry frame, and `--fixes FILE|-` to
//! forward camera fixes while they run ([`crate::drive_fixes`]).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use omnikin::link::{
    CHUNK_POINTS, DropReason, EndReason, Estimate, Key, MAX_FRAME, Message, OperatorEvent,
    OperatorLink, PROTOCOL_VERSION, RobotInfo, SimTruth, Telemetry, WirePoint, v1,
};
use omnikin::runtime::{Frame, Mode};
use omnikin_plan::Plan;

use crate::args::finite_f64;
use crate::link_io::{Link, OsEntropy, Transport, epoch_seq, load_key, parse_address};

/// `omnikin drive`.
#[derive(clap::Args, Debug)]
pub struct DriveArgs {
    /// The robot: HOST:PORT (UDP), udp:HOST:PORT or serial:PATH[@BAUD].
    #[arg(long, value_name = "ADDR")]
    pub connect: String,
    /// Shared key file (16-64 bytes), the same as the robot's --key.
    #[arg(long, value_name = "FILE", global = true)]
    pub key: Option<PathBuf>,
    /// Heartbeat / command repeat rate, Hz (wall clock). Must comfortably beat the robot's
    /// watchdog.
    #[arg(long, default_value_t = 20.0, global = true, allow_hyphen_values = true, value_parser = crate::args::message_rate_hz)]
    pub heartbeat: f64,
    /// Give up waiting for the robot after this many seconds without an answer.
    #[arg(long, default_value_t = 3.0, global = true, allow_hyphen_values = true, value_parser = crate::args::timeout_s)]
    pub timeout: f64,
    /// Record every telemetry frame (and an uploaded plan) as MCAP with Foxglove schemas
    /// (docs/seeing-the-robot.md), kept on every exit path like --out.
    #[arg(long, value_name = "FILE", global = true)]
    pub mcap: Option<PathBuf>,
    /// Forward camera fixes while `velocity`, `plan` or `telemetry` runs: a CSV
    /// `t,x,y[,heading][,arrival]` (t = capture time in the robot's clock, s; `-` reads stdin),
    /// each sent when the robot's clock reaches its arrival time (default t).
    #[arg(long, value_name = "FILE|-", global = true)]
    pub fixes: Option<PathBuf>,
    /// Standard deviation sent with each fix's position, m.
    #[arg(long, default_value_t = 0.01, global = true, allow_hyphen_values = true, value_parser = finite_f64)]
    pub fix_std: f64,
    /// Standard deviation sent with each fix's heading, rad.
    #[arg(long, default_value_t = 0.05, global = true, allow_hyphen_values = true, value_parser = finite_f64)]
    pub fix_heading_std: f64,
    /// What to do.
    #[command(subcommand)]
    pub action: DriveAction,
}

/// Actions of `omnikin drive`.
#[derive(clap::Subcommand, Debug)]
pub enum DriveAction {
    /// Ask the robot who it is (protocol version, model, plan capacity, rates).
    Hello,
    /// Drive with a velocity for a while, then stop.
    Velocity {
        /// Velocity along x, m/s (robot frame; world frame with --world).
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
        vx: f64,
        /// Velocity along y, m/s.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
        vy: f64,
        /// Yaw rate, rad/s (counter-clockwise positive).
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
        yaw_rate: f64,
        /// --vx/--vy are in the world frame.
        #[arg(long)]
        world: bool,
        /// How long to keep commanding, s (wall clock); then a controlled stop.
        #[arg(long = "for", value_name = "SECONDS", allow_hyphen_values = true, value_parser = crate::args::run_for_s)]
        duration: f64,
        /// Record telemetry to this CSV file.
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Upload a plan (CSV of `omnikin plan`), start it and follow it to the end.
    Plan {
        /// The plan CSV (t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3[,...]).
        plan: PathBuf,
        /// Record telemetry to this CSV file.
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
        /// Before starting, set the robot's pose estimate to the plan's first pose.
        #[arg(long)]
        set_pose: bool,
        /// Without --set-pose, a robot whose estimate is farther than this from the plan's
        /// start (m) would first drive itself there: `drive` asks before it does (or refuses
        /// when it cannot ask: stdin is not a terminal), unless --yes.
        #[arg(long, value_name = "METERS", default_value_t = 0.1, allow_hyphen_values = true, value_parser = crate::args::start_tolerance_m)]
        start_tolerance: f64,
        /// Drive a plan whose start is beyond --start-tolerance without asking.
        #[arg(long)]
        yes: bool,
        /// The robot being driven (preset or robot file, as its `omnikin robot --robot`):
        /// the plan is checked against its body limits (`omnikin check` prints them) before
        /// it is uploaded, and refused, naming the limit and the plan's peak, when it asks for
        /// more than the robot will do (the robot would lag behind it).
        #[arg(long)]
        robot: Option<String>,
    },
    /// Controlled stop within the acceleration limits.
    Stop,
    /// Emergency stop (motors off at once; latched until `clear`).
    Estop,
    /// Clear the e-stop latch and the fault history.
    Clear,
    /// Record telemetry.
    Telemetry {
        /// The CSV file.
        #[arg(long, value_name = "FILE")]
        out: PathBuf,
        /// How long, s (wall clock).
        #[arg(long = "for", value_name = "SECONDS", default_value_t = 5.0, allow_hyphen_values = true, value_parser = crate::args::run_for_s)]
        duration: f64,
    },
    /// Interactive keyboard driving (needs a terminal): w/s forward/back, a/d left/right,
    /// q/e turn, space stop, x e-stop, c clear, Esc or Ctrl-C quits (with a stop).
    Teleop {
        /// Speed per key, m/s.
        #[arg(long, default_value_t = 0.1, allow_hyphen_values = true, value_parser = finite_f64)]
        speed: f64,
        /// Yaw rate per key, rad/s.
        #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = finite_f64)]
        turn: f64,
    },
}

/// Telemetry CSV header for a robot of `wheels` wheels (`steer`: with steer motors): pose
/// columns first (the pose CSV of the conventions), commanded wheel rates `w1..wN`, encoder
/// wheel angles `q1..qN` and, for kinds with steer motors, steer angles `s1..sN` (so the log
/// is an encoder log for `omnikin odometry`), then the rest.
pub fn telemetry_header(wheels: usize, steer: bool) -> String {
    let mut h = String::from("t,x,y,heading,vx,vy,yaw_rate,cmd_vx,cmd_vy,cmd_yaw_rate");
    let mut cols = |p: &str| {
        for i in 1..=wheels {
            h.push_str(&format!(",{p}{i}"));
        }
    };
    cols("w");
    cols("q");
    if steer {
        cols("s");
    }
    h.push_str(",gyro_z,mode,faults,fault_history,plan_id,plan_received,plan_len,plan_time,ref_x,ref_y,ref_heading,rejected,last_command_t,rx_ok,rx_framing,rx_crc,rx_version,rx_auth,rx_replay,rx_malformed,rx_session,rx_entropy");
    h.push_str(ESTIMATE_COLUMNS);
    h
}

/// The estimate columns at the end of a telemetry row (empty when the robot sends no
/// estimate): the uncorrected wheel odometry, the fused pose's variances, the fix counters.
const ESTIMATE_COLUMNS: &str = ",odo_x,odo_y,odo_heading,var_x,var_y,var_heading,fix_accepted,fix_rejected,fix_too_late,fix_recoveries,slip_events,collision_events";

/// The [`ESTIMATE_COLUMNS`] of `e` (empty cells for `None`).
fn estimate_cells(e: Option<&Estimate>) -> String {
    match e {
        Some(e) => format!(
            ",{},{},{},{:e},{:e},{:e},{},{},{},{},{},{}",
            e.odometry[0],
            e.odometry[1],
            e.odometry[2],
            e.covariance[0],
            e.covariance[1],
            e.covariance[2],
            e.fixes.accepted,
            e.fixes.rejected,
            e.fixes.too_late,
            e.fixes.recoveries,
            e.events.slips,
            e.events.collisions
        ),
        None => ",".repeat(12),
    }
}

/// One telemetry CSV row in the columns of [`telemetry_header`].
fn telemetry_row(t: &Telemetry, wheels: usize, steer: bool) -> String {
    let l = &t.link;
    let mut r = format!(
        "{:.6},{},{},{},{},{},{},{},{},{}",
        t.time_us as f64 * 1e-6,
        t.pose[0],
        t.pose[1],
        t.pose[2],
        t.twist[0],
        t.twist[1],
        t.twist[2],
        t.command[0],
        t.command[1],
        t.command[2],
    );
    let mut cols = |v: &[f32]| {
        for x in v.iter().take(wheels) {
            r.push_str(&format!(",{x}"));
        }
    };
    cols(&t.wheel_rates);
    cols(&t.wheel_angles);
    if steer {
        cols(&t.steer_angles);
    }
    r.push_str(&format!(
        ",{},{},{},{},{},{},{},{},{},{},{},{},{:.6},{},{},{},{},{},{},{},{},{}",
        t.gyro[2],
        t.mode,
        t.faults,
        t.fault_history,
        t.plan.id,
        t.plan.received,
        t.plan.len,
        t.plan_time,
        t.reference[0],
        t.reference[1],
        t.reference[2],
        t.rejected,
        t.last_command_us as f64 * 1e-6,
        l.ok,
        l.framing,
        l.crc,
        l.version,
        l.auth,
        l.replay,
        l.malformed,
        l.session,
        l.entropy,
    ));
    r
}

/// A v1 HelloAck (the robot's answer to the v1 probe, or a v1 robot's answer).
#[derive(Clone, Copy, Debug)]
struct V1Answer {
    /// The protocol it names.
    protocol: u8,
    /// It says the robot has a key.
    robot_keyed: bool,
    /// Its tag verified under this operator's key: the robot (or a holder of the key) sent it.
    /// Otherwise it is only known to come from the robot's address, which anyone can forge.
    proven: bool,
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
struct Session {
    link: Link,
    op: OperatorLink,
    key: Option<Key>,
    addr: String,
    latest: Option<Telemetry>,
    /// The newest estimate of this session (robots that fuse fixes send one per telemetry).
    estimate: Option<Estimate>,
    /// The newest true pose of this session (`robot --sim` sends one per telemetry).
    truth: Option<SimTruth>,
    /// `--fixes`: the fixes to forward.
    fixes: Option<crate::drive_fixes::FixFeeder>,
    /// When the newest telemetry frame of this session arrived.
    last_telemetry: Option<Instant>,
    /// What a v1 HelloAck said (the answer to the v1 probe), if it was authenticated by this
    /// operator's key or came from the robot's own address.
    v1_answer: Option<V1Answer>,
    log: Option<crate::output::OutFile>,
    /// The `--out` log's columns: (wheels, steer motors), from the first telemetry frame and
    /// the robot's kind; the header is written then.
    log_layout: Option<(usize, bool)>,
    mcap: Option<crate::mcap_log::McapLog>,
    frames: u64,
    heartbeat: Duration,
    timeout: Duration,
}

impl Drop for Session {
    /// On every other exit path (an error, Ctrl-C): the log's header if it has none yet; the
    /// log itself is then kept by its own drop (crate::output).
    fn drop(&mut self) {
        if let Err(e) = self.log_header_if_none() {
            crate::errln!("warning: --out: cannot write: {e}");
        }
    }
}

impl Session {
    fn open(a: &DriveArgs) -> Result<Self> {
        if a.heartbeat <= 0.0 {
            bail!("--heartbeat must be > 0 Hz (got {})", a.heartbeat);
        }
        if a.timeout <= 0.0 {
            bail!("--timeout must be > 0 s (got {})", a.timeout);
        }
        let key = a.key.as_deref().map(load_key).transpose()?;
        let addr = parse_address(&a.connect, "--connect")?;
        let link = Link::new(Transport::open(&addr, false)?);
        let mcap = crate::mcap_log::McapLog::for_flag(a.mcap.as_deref(), "omnikin drive", true)?;
        if mcap.is_some() {
            crate::output::catch_signals()?;
        }
        // `drive` is its user's act: it takes the robot over from another operator (who is
        // told). The console asks first (ConsoleOperator::set_take_over).
        let mut op = OperatorLink::new(key.clone());
        op.set_take_over(true);
        Ok(Self {
            link,
            op,
            key,
            addr: a.connect.clone(),
            latest: None,
            estimate: None,
            truth: None,
            fixes: None,
            last_telemetry: None,
            v1_answer: None,
            log: None,
            log_layout: None,
            mcap,
            frames: 0,
            heartbeat: crate::args::duration("--heartbeat", 1.0 / a.heartbeat)?,
            timeout: crate::args::duration("--timeout", a.timeout)?,
        })
    }

    fn record(&mut self, out: Option<&Path>) -> Result<()> {
        if let Some(p) = out {
            // The log is kept on every exit path, Ctrl-C included (see crate::output). Its
            // header waits for the first telemetry frame: one column per wheel the robot has
            // (telemetry's `wheels`), steer columns only for kinds with steer motors.
            self.log = Some(crate::output::OutFile::log("--out", p)?);
            crate::output::catch_signals()?;
        }
        Ok(())
    }

    /// Sends `m` in this operator's session.
    fn send(&mut self, m: &Message) -> Result<()> {
        let mut buf = [0u8; MAX_FRAME];
        let n = self.op.encode(m, &mut buf)?;
        self.link.transport.send(&buf[..n])
    }

    /// Receives for `dur`; returns `true` if a new telemetry frame of this session arrived.
    /// Sends `m` when the heartbeat `next` is due (then the next one is a period later), and
    /// receives until the next one is due or frames arrive. A loop around it sends at the
    /// heartbeat rate however many frames the robot sends (telemetry, estimate, truth), and
    /// still sees every batch of them as it arrives.
    fn beat(&mut self, next: &mut Instant, m: &Message) -> Result<bool> {
        if Instant::now() >= *next {
            self.send(m)?;
            *next = Instant::now() + self.heartbeat;
        }
        self.pump(next.saturating_duration_since(Instant::now()))
    }

    fn pump(&mut self, dur: Duration) -> Result<bool> {
        let mut fresh = false;
        if let Some(sig) = crate::output::interrupted() {
            return Err(sig.into());
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
                    if let Some(w) = self.log.as_mut() {
                        let (wheels, steer) = match self.log_layout {
                            Some(l) => l,
                            None => {
                                let steer = self.op.info().is_some_and(|i| i.kind.steerable());
                                let l = (usize::from(t.wheels).min(omnikin::MAX_WHEELS), steer);
                                writeln!(w, "{}", telemetry_header(l.0, l.1))
                                    .context("--out: cannot write")?;
                                self.log_layout = Some(l);
                                l
                            }
                        };
                        let e = self.estimate.as_ref().filter(|e| e.time_us == t.time_us);
                        writeln!(
                            w,
                            "{}{}",
                            telemetry_row(&t, wheels, steer),
                            estimate_cells(e)
                        )
                        .context("--out: cannot write")?;
                    }
                    if let Some(m) = self.mcap.as_mut() {
                        m.sample(&crate::mcap_log::telemetry_sample_with_truth(
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
                            Some((_, v1::Frame::HelloAck(i))) => Some(i),
                            _ => None,
                        }
                    });
                    let plain = match v1::parse(&mut copy.clone(), None) {
                        Some((_, v1::Frame::HelloAck(i))) if from_robot => Some(i),
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
    fn alive(&self) -> Result<()> {
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
    fn until(
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
    fn hello(&mut self) -> Result<RobotInfo> {
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
                        "version mismatch: the robot at {} speaks protocol v{} (its answer was authenticated by --key), this omnikin speaks v{PROTOCOL_VERSION}; run the same omnikin version on both ends",
                        self.addr,
                        a.protocol
                    );
                }
            }
            if start.elapsed() > self.timeout {
                return Err(self.no_session_error());
            }
        }
    }

    /// Why the handshake did not complete, as precisely as the evidence allows.
    fn no_session_error(&self) -> anyhow::Error {
        let t = self.timeout.as_secs_f64();
        let c = self.op.counters();
        if self.op.info().is_some() {
            return anyhow::anyhow!(
                "the robot at {} answered the handshake but did not open the session: no frame of it in {t:.1} s (frames lost on the way; try again)",
                self.addr
            );
        }
        let how = |a: &V1Answer| {
            if a.proven {
                "authenticated by --key"
            } else {
                "unauthenticated, from the robot's address"
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
                "authentication failed: the robot at {} (protocol v{PROTOCOL_VERSION}) rejects this operator's Hello — --key is not the robot's key",
                self.addr
            ),
            (Some(a), false) if a.robot_keyed => anyhow::anyhow!(
                "authentication failed: the robot at {} requires a key; pass --key FILE (the robot's key file)",
                self.addr
            ),
            (Some(a), true) if !a.robot_keyed => anyhow::anyhow!(
                "authentication failed: the robot at {} has no key but this operator sends --key; drop --key (or start the robot with the same --key)",
                self.addr
            ),
            _ if c.auth > 0 => anyhow::anyhow!(
                "authentication failed: {} answers from {} carried no valid tag for this --key",
                c.auth,
                self.addr
            ),
            _ => anyhow::anyhow!(
                "no answer from the robot at {} within {t:.1} s: nothing came back (is `omnikin robot` running there, is --connect right?)",
                self.addr
            ),
        }
    }

    fn finish(&mut self) -> Result<()> {
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

    fn print_status(&self) -> Result<()> {
        if let Some(f) = &self.fixes {
            crate::outln!("{}", f.report(self.estimate.map(|e| e.fixes)))?;
        }
        // The estimate line once fixes are in play (this run forwards them, or the robot has
        // had some): before that the pose is the wheel odometry and the line says nothing new.
        let fixes_seen = |e: &Estimate| {
            let f = e.fixes;
            self.fixes.is_some() || f.accepted + f.rejected + f.too_late > 0
        };
        if let (Some(e), Some(t)) = (
            self.estimate.as_ref().filter(|e| fixes_seen(e)),
            &self.latest,
        ) {
            crate::outln!(
                "robot estimate: pose ({:.4} m, {:.4} m, {:.4} rad) ± ({:.4} m, {:.4} m, {:.4} rad) 1σ; wheel odometry ({:.4} m, {:.4} m, {:.4} rad)",
                t.pose[0],
                t.pose[1],
                t.pose[2],
                e.covariance[0].max(0.0).sqrt(),
                e.covariance[1].max(0.0).sqrt(),
                e.covariance[2].max(0.0).sqrt(),
                e.odometry[0],
                e.odometry[1],
                e.odometry[2]
            )?;
        }
        if let Some(t) = &self.latest {
            crate::outln!(
                "robot t {:.3} s: mode {}, pose ({:.4} m, {:.4} m, {:.4} rad), faults {}, history {}",
                t.time_us as f64 * 1e-6,
                t.mode,
                t.pose[0],
                t.pose[1],
                t.pose[2],
                t.faults,
                t.fault_history
            )?;
            let l = &t.link;
            crate::outln!(
                "robot link: {} frames ok, dropped {} (framing {}, crc {}, version {}, auth {}, replay {}, malformed {}, session {}, entropy {}); commands rejected {}",
                l.ok,
                l.dropped(),
                l.framing,
                l.crc,
                l.version,
                l.auth,
                l.replay,
                l.malformed,
                l.session,
                l.entropy,
                t.rejected
            )?;
        }
        Ok(())
    }

    /// The sequence number the next command will carry.
    fn next_seq(&self) -> u64 {
        self.op.next_seq().unwrap_or(u64::MAX)
    }
}

/// Runs one `drive` action.
pub fn run(a: &DriveArgs) -> Result<()> {
    let mut s = Session::open(a)?;
    if let Some(path) = &a.fixes {
        if !matches!(
            a.action,
            DriveAction::Velocity { .. } | DriveAction::Plan { .. } | DriveAction::Telemetry { .. }
        ) {
            bail!(
                "--fixes forwards fixes while velocity, plan or telemetry runs; not with this action"
            );
        }
        s.fixes = Some(crate::drive_fixes::FixFeeder::open(
            path,
            a.fix_std,
            a.fix_heading_std,
        )?);
    }
    match &a.action {
        DriveAction::Hello => {
            let i = s.hello()?;
            // Wait for the first telemetry: the robot took the session.
            s.until(&Message::Heartbeat, "the session", |s| s.latest.is_some())?;
            crate::outln!(
                "robot: protocol {}, model {:?}, plan capacity {} points, control {} Hz, watchdog {} s, {}",
                i.protocol,
                i.kind,
                i.plan_capacity,
                i.rate_hz,
                i.watchdog,
                if i.authenticated {
                    "authenticated"
                } else {
                    "no key"
                }
            )?;
            crate::outln!("robot: {}", crate::body_limits::told_line(&i.limits))?;
        }
        DriveAction::Velocity {
            vx,
            vy,
            yaw_rate,
            world,
            duration,
            out,
        } => {
            s.record(out.as_deref())?;
            s.hello()?;
            let m = Message::SetVelocity {
                frame: if *world { Frame::World } else { Frame::Robot },
                vx: *vx as f32,
                vy: *vy as f32,
                yaw_rate: *yaw_rate as f32,
            };
            let end = Instant::now() + crate::args::duration("--for", *duration)?;
            let mut beat = Instant::now();
            while Instant::now() < end {
                s.beat(&mut beat, &m)?;
                s.alive()?;
            }
            if let Some(t) = s.latest
                && t.mode != Mode::Velocity
            {
                s.print_status()?;
                bail!(
                    "the robot did not take the command (mode {}, rejected {})",
                    t.mode,
                    t.rejected
                );
            }
            stop(&mut s)?;
            s.print_status()?;
        }
        DriveAction::Plan {
            plan,
            out,
            set_pose,
            start_tolerance,
            yes,
            robot,
        } => {
            s.record(out.as_deref())?;
            let start = StartCheck {
                set_pose: *set_pose,
                tolerance_m: *start_tolerance,
                yes: *yes,
            };
            follow_plan(&mut s, plan, start, robot.as_deref())?;
        }
        DriveAction::Stop => {
            s.hello()?;
            stop(&mut s)?;
            s.print_status()?;
        }
        DriveAction::Estop => {
            s.hello()?;
            // Confirmed only by telemetry of this session naming one of this run's EStops.
            let first = s.next_seq();
            s.until(&Message::EStop, "the e-stop", |s| {
                s.latest
                    .is_some_and(|t| t.mode == Mode::EStop && t.estop_seq >= first)
            })?;
            s.print_status()?;
        }
        DriveAction::Clear => {
            s.hello()?;
            let first = s.next_seq();
            s.until(&Message::Clear, "clear", |s| {
                s.latest.is_some_and(|t| {
                    t.ack_seq >= first && t.mode != Mode::EStop && t.fault_history.is_empty()
                })
            })?;
            s.print_status()?;
        }
        DriveAction::Telemetry { out, duration } => {
            s.record(Some(out))?;
            s.hello()?;
            let end = Instant::now() + crate::args::duration("--for", *duration)?;
            let mut beat = Instant::now();
            while Instant::now() < end {
                // Heartbeats keep the session (and the watchdog) alive without commanding.
                s.beat(&mut beat, &Message::Heartbeat)?;
                s.alive()?;
            }
            crate::outln!("{} telemetry frames written to {}", s.frames, out.display())?;
            if s.frames == 0 {
                bail!("no telemetry of this session arrived in {duration} s: nothing was recorded");
            }
            s.print_status()?;
        }
        DriveAction::Teleop { speed, turn } => {
            if !std::io::IsTerminal::is_terminal(&std::io::stdin()) {
                bail!("teleop needs an interactive terminal (stdin is not a TTY)");
            }
            s.hello()?;
            let period = s.heartbeat;
            crate::teleop::run(&mut s, *speed, *turn, period)?;
        }
    }
    s.finish()
}

impl crate::teleop::Operator for Session {
    fn send(&mut self, m: &Message) -> Result<()> {
        Session::send(self, m)
    }
    fn poll(&mut self, d: Duration) -> Result<Option<Telemetry>> {
        self.pump(d)?;
        self.alive()?;
        Ok(self.latest)
    }
}

fn stop(s: &mut Session) -> Result<()> {
    let first = s.next_seq();
    s.until(&Message::Stop, "the stop", |s| {
        s.latest
            .is_some_and(|t| t.ack_seq >= first && matches!(t.mode, Mode::Idle | Mode::EStop))
    })
}

/// The plan's points, decimated evenly (keeping the last) to at most `cap`.
pub fn plan_points(plan: &Plan, cap: usize) -> Vec<WirePoint> {
    let n = plan.samples.len();
    let step = n.div_ceil(cap.max(2) - 1).max(1);
    let mut idx: Vec<usize> = (0..n).step_by(step).collect();
    if idx.last() != Some(&(n - 1)) {
        idx.push(n - 1);
    }
    idx.iter()
        .map(|&i| {
            let p = &plan.samples[i];
            WirePoint {
                t: p.t as f32,
                pose: [p.pose.x as f32, p.pose.y as f32, p.pose.heading as f32],
                twist: [
                    p.twist.vx as f32,
                    p.twist.vy as f32,
                    p.twist.yaw_rate as f32,
                ],
            }
        })
        .collect()
}

/// How `drive plan` treats a plan that does not start where the robot is.
#[derive(Debug, Clone, Copy)]
struct StartCheck {
    /// `--set-pose`: the pose estimate becomes the plan's start (nothing to check).
    set_pose: bool,
    /// `--start-tolerance`, m.
    tolerance_m: f64,
    /// `--yes`: drive without asking.
    yes: bool,
}

/// Before a plan is driven without `--set-pose`: the robot's estimate (from its telemetry)
/// against the plan's first pose. Beyond the tolerance the robot would first drive itself
/// across to the start, so the operator is asked (a terminal) or the run is refused.
/// Waits for the robot's telemetry first (its pose, and its clock for the `/plan` message of
/// `--mcap`).
fn check_plan_start(s: &mut Session, start: [f64; 2], c: StartCheck) -> Result<()> {
    s.until(&Message::Heartbeat, "telemetry (the robot's pose)", |s| {
        s.latest.is_some()
    })?;
    if c.set_pose {
        return Ok(());
    }
    let t = s.latest.context("no telemetry")?;
    let d = (f64::from(t.pose[0]) - start[0]).hypot(f64::from(t.pose[1]) - start[1]);
    if d <= c.tolerance_m {
        return Ok(());
    }
    let what = format!(
        "the robot's estimate ({:.3}, {:.3}) is {d:.3} m from the plan's start ({:.3}, {:.3}), more than --start-tolerance {} m: it would first drive itself there",
        t.pose[0], t.pose[1], start[0], start[1], c.tolerance_m
    );
    if c.yes {
        crate::errln!("drive: {what} (--yes: driving anyway)");
        return Ok(());
    }
    use std::io::IsTerminal;
    if !std::io::stdin().is_terminal() {
        bail!(
            "{what}. Refused: pass --set-pose to start from the plan's first pose, --yes to drive there, or a larger --start-tolerance"
        );
    }
    crate::errln!("drive: {what}. Drive anyway? [y/N] ");
    let mut answer = String::new();
    // The robot's watchdog stops it while we wait: nothing moves before the answer.
    std::io::stdin()
        .read_line(&mut answer)
        .context("reading the answer")?;
    if !matches!(answer.trim(), "y" | "Y" | "yes") {
        bail!("not driven: the plan's start is {d:.3} m from the robot");
    }
    Ok(())
}

fn follow_plan(s: &mut Session, path: &Path, start: StartCheck, robot: Option<&str>) -> Result<()> {
    let set_pose = start.set_pose;
    let plan = Plan::load_csv(path).with_context(|| format!("plan {}", path.display()))?;
    if plan.samples.len() < 2 {
        bail!("plan {}: needs at least 2 samples", path.display());
    }
    // The robot file's limits (`--robot`, read before the link is opened) and the robot's own
    // (its handshake): the plan is held to the stricter of each.
    let file = robot
        .map(crate::kinematics::resolve_robot)
        .transpose()?
        .map(|d| (format!("{}'s", d.name), d.body_limits()));
    let info = s.hello()?;
    if let Some(limits) =
        crate::body_limits::held(file.as_ref().map(|(_, l)| l), Some(&info.limits))
    {
        let peaks = crate::body_limits::peaks(&plan);
        let excess = crate::body_limits::plan_excess(&limits, &peaks);
        if !excess.is_empty() {
            bail!(
                "plan {}: not uploaded: {}; the robot would lag behind it (re-plan slower, e.g. a longer --ramp-fraction or a lower --max-accel)",
                path.display(),
                excess.join("; ")
            );
        }
        let name = file.as_ref().map_or("the robot's", |(n, _)| n.as_str());
        crate::outln!("{}", crate::body_limits::within_line(name, &limits, &peaks))?;
    }
    let p0 = plan.samples[0].pose;
    check_plan_start(s, [p0.x, p0.y], start)?;
    if info.plan_capacity == 0 {
        return stream_plan(s, &plan, set_pose);
    }
    let pts = plan_points(&plan, info.plan_capacity as usize);
    if let Some(m) = s.mcap.as_mut() {
        crate::mcap_log::drive_plan(m, s.latest.map_or(0, |t| t.time_us), &pts)?;
    }
    let n = pts.len() as u16;
    let id = (epoch_seq() & 0xffff) as u16;
    if set_pose {
        let p = pts[0].pose;
        let m = Message::SetPose {
            x: p[0],
            y: p[1],
            heading: p[2],
        };
        s.until(&m, "set-pose", |s| {
            s.latest
                .is_some_and(|t| (t.pose[0] - p[0]).abs() < 1e-4 && (t.pose[1] - p[1]).abs() < 1e-4)
        })?;
    }
    let t0 = Instant::now();
    s.until(&Message::PlanBegin { id, len: n }, "plan begin", |s| {
        s.latest.is_some_and(|t| t.plan.id == id && t.plan.len == n)
    })?;
    // Stop-and-wait: the robot acknowledges every plan message with telemetry; a lost chunk or
    // a lost acknowledgement is simply re-sent (chunks are idempotent).
    let mut sent = 0u32;
    loop {
        let have = s
            .latest
            .map_or(0, |t| if t.plan.id == id { t.plan.received } else { 0 });
        if have >= n {
            break;
        }
        let off = have as usize;
        let end = (off + CHUNK_POINTS).min(pts.len());
        let chunk = Message::PlanChunk {
            id,
            offset: have,
            points: omnikin::link::heapless::Vec::from_slice(&pts[off..end])
                .map_err(|_| anyhow::anyhow!("chunk"))?,
        };
        s.until(&chunk, "plan chunk", |s| {
            s.latest
                .is_some_and(|t| t.plan.id == id && t.plan.received > have)
        })?;
        sent += 1;
    }
    crate::outln!(
        "uploaded plan {id}: {n} points ({} samples in the file) in {sent} chunks, {:.2} s",
        plan.samples.len(),
        t0.elapsed().as_secs_f64()
    )?;
    s.until(&Message::PlanStart { id }, "plan start", |s| {
        s.latest
            .is_some_and(|t| t.mode == Mode::Trajectory || (t.plan.done && t.plan.id == id))
    })?;
    // Follow: heartbeats until the plan is done.
    let mut max_dev = 0.0f32;
    let mut last_seen = Instant::now();
    let mut last_t = 0u64;
    let mut beat = Instant::now();
    loop {
        s.beat(&mut beat, &Message::Heartbeat)?;
        let Some(t) = s.latest else { continue };
        if t.time_us != last_t {
            last_t = t.time_us;
            last_seen = Instant::now();
        }
        if t.mode == Mode::Trajectory {
            let d = (t.pose[0] - t.reference[0]).hypot(t.pose[1] - t.reference[1]);
            max_dev = max_dev.max(d);
        }
        if t.mode != Mode::Trajectory {
            if t.plan.done && t.mode == Mode::Idle {
                break;
            }
            if !t.plan.done {
                s.print_status()?;
                bail!(
                    "the robot left the plan (mode {}, faults {})",
                    t.mode,
                    t.fault_history
                );
            }
        }
        s.alive()?;
        if last_seen.elapsed() > s.timeout {
            bail!(
                "telemetry stopped for {:.1} s while following the plan",
                s.timeout.as_secs_f64()
            );
        }
    }
    let t = s.latest.context("no telemetry")?;
    let end = pts[pts.len() - 1].pose;
    crate::outln!(
        "plan done: max |pose - reference| {:.4} m while following; end pose ({:.4}, {:.4}, {:.4}), plan end ({:.4}, {:.4}, {:.4})",
        max_dev,
        t.pose[0],
        t.pose[1],
        t.pose[2],
        end[0],
        end[1],
        end[2]
    )?;
    s.print_status()?;
    Ok(())
}

/// `drive plan` for a robot that takes no plans (plan capacity 0: a balancing ballbot follows
/// velocity commands): the plan's world twist at the robot's time since the start, sent as a
/// world-frame velocity command every heartbeat, then a stop. The robot's own limits (the
/// ballbot's lean-limited slew) shape it; nothing closes the loop on the plan's poses, so the
/// end pose shows the drift of the robot's velocity tracking.
fn stream_plan(s: &mut Session, plan: &Plan, set_pose: bool) -> Result<()> {
    crate::outln!(
        "the robot takes no plans (plan capacity 0): streaming the plan's {:.2} s of world twists as velocity commands",
        plan.duration()
    )?;
    let first = plan.samples[0].pose;
    if set_pose {
        let m = Message::SetPose {
            x: first.x as f32,
            y: first.y as f32,
            heading: first.heading as f32,
        };
        s.until(&m, "set-pose", |s| {
            s.latest.is_some_and(|t| {
                (t.pose[0] as f64 - first.x).abs() < 1e-4
                    && (t.pose[1] as f64 - first.y).abs() < 1e-4
            })
        })?;
    }
    s.until(&Message::Heartbeat, "the session", |s| s.latest.is_some())?;
    let t0 = s.latest.context("no telemetry")?.time_us;
    let end = plan.duration();
    let (mut max_dev, mut max_path_dev) = (0.0f64, 0.0f64);
    let mut beat = Instant::now();
    loop {
        let t = s.latest.context("no telemetry")?;
        let now = t.time_us.saturating_sub(t0) as f64 * 1e-6;
        if now > end {
            break;
        }
        let i = plan
            .samples
            .partition_point(|p| p.t <= now)
            .saturating_sub(1);
        let p = &plan.samples[i];
        if set_pose {
            let (x, y) = (t.pose[0] as f64, t.pose[1] as f64);
            max_dev = max_dev.max((x - p.pose.x).hypot(y - p.pose.y));
            // Distance to the path, whenever it is passed (the lag along it left out).
            let d = plan
                .samples
                .iter()
                .map(|q| (x - q.pose.x).hypot(y - q.pose.y))
                .fold(f64::INFINITY, f64::min);
            max_path_dev = max_path_dev.max(d);
        }
        let m = Message::SetVelocity {
            frame: Frame::World,
            vx: p.twist.vx as f32,
            vy: p.twist.vy as f32,
            yaw_rate: p.twist.yaw_rate as f32,
        };
        s.beat(&mut beat, &m)?;
        s.alive()?;
        if let Some(t) = s.latest
            && t.mode == Mode::EStop
        {
            s.print_status()?;
            bail!(
                "the robot stopped following (mode {}, faults {})",
                t.mode,
                t.fault_history
            );
        }
    }
    stop(s)?;
    let t = s.latest.context("no telemetry")?;
    let last = plan.samples[plan.samples.len() - 1].pose;
    crate::outln!(
        "plan streamed: {}end pose ({:.4}, {:.4}, {:.4}), plan end ({:.4}, {:.4}, {:.4})",
        if set_pose {
            format!(
                "max |pose - plan pose| {max_dev:.4} m (lag included), max distance to the path {max_path_dev:.4} m while streaming; "
            )
        } else {
            String::new()
        },
        t.pose[0],
        t.pose[1],
        t.pose[2],
        last.x,
        last.y,
        last.heading
    )?;
    s.print_status()?;
    Ok(())
}

/// The operator session of `drive`, for `omnikin console`: the same handshake (with its v1
/// probe and its diagnosis of a failed handshake), the same session frames and the same
/// telemetry bookkeeping, driven from the console's own event loop instead of a `drive`
/// action.
pub(crate) struct ConsoleOperator(Session);

impl ConsoleOperator {
    /// Opens the transport to `connect` (an address as `drive --connect` takes it) with an
    /// optional key file; `heartbeat_hz` and `timeout_s` as `drive --heartbeat/--timeout`.
    pub(crate) fn open(
        connect: &str,
        key: Option<&Path>,
        heartbeat_hz: f64,
        timeout_s: f64,
    ) -> Result<Self> {
        let mut s = Session::open(&DriveArgs {
            connect: connect.to_string(),
            key: key.map(Path::to_path_buf),
            heartbeat: heartbeat_hz,
            timeout: timeout_s,
            mcap: None,
            fixes: None,
            fix_std: 0.01,
            fix_heading_std: 0.05,
            action: DriveAction::Hello,
        })?;
        // A console watches: it opens a session only while nobody else's is live.
        s.op.set_take_over(false);
        Ok(Self(s))
    }

    /// The handshake (blocks up to the timeout): the robot's answer. Fails with [`RobotBusy`]
    /// when another operator holds the robot and this one does not take over.
    pub(crate) fn hello(&mut self) -> Result<RobotInfo> {
        self.0.hello()
    }

    /// Whether this console's next handshake takes the robot over from a live session (only
    /// when its user acts; `drive` always does).
    pub(crate) fn set_take_over(&mut self, take_over: bool) {
        self.0.op.set_take_over(take_over);
    }

    /// Sends `m` in the session.
    pub(crate) fn send(&mut self, m: &Message) -> Result<()> {
        self.0.send(m)
    }

    /// Receives for up to `d`; `true` if a new telemetry frame of this session arrived.
    pub(crate) fn pump(&mut self, d: Duration) -> Result<bool> {
        self.0.pump(d)
    }

    /// Fails when the session is over (taken over, or silent for the timeout).
    pub(crate) fn alive(&self) -> Result<()> {
        self.0.alive()
    }

    /// The newest telemetry of this session.
    pub(crate) fn latest(&self) -> Option<Telemetry> {
        self.0.latest
    }

    /// The newest true pose of this session (simulated robots only).
    pub(crate) fn truth(&self) -> Option<SimTruth> {
        self.0.truth
    }

    /// The sequence number the next message will carry.
    pub(crate) fn next_seq(&self) -> u64 {
        self.0.next_seq()
    }

    /// This end's receive counters.
    pub(crate) fn counters(&self) -> omnikin::link::LinkCounters {
        *self.0.op.counters()
    }

    /// Telemetry frames of this session received.
    pub(crate) fn frames(&self) -> u64 {
        self.0.frames
    }

    /// The session id, once established.
    pub(crate) fn session_id(&self) -> Option<u64> {
        self.0.op.session_id()
    }

    /// The heartbeat period and the timeout.
    pub(crate) fn periods(&self) -> (Duration, Duration) {
        (self.0.heartbeat, self.0.timeout)
    }
}
