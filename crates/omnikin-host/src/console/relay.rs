//! The relay: one thread that owns the operator session with the robot (`drive`'s session,
//! [`ConsoleOperator`]) and turns the pages' commands into link messages, and telemetry into
//! JSON for the pages.
//!
//! Every heartbeat period it sends exactly one message, by priority: an unconfirmed e-stop,
//! an unconfirmed clear, the current step of a plan upload, the dead-man teleop command
//! (valid for [`TELEOP_HOLD`] after the page's last one), an unconfirmed stop, else a
//! heartbeat. An e-stop request is also sent the moment it is seen (it is checked between
//! receives, every [`SLICE`] at most), and cancels teleop and uploads. A lost session is
//! re-opened after [`RETRY`].
//!
//! The console never takes the robot from another operator on its own: its handshakes do not
//! ask to take over, so while another operator's session is live the robot answers Busy and
//! the page shows who holds it (state `held`). Only its user's act — a teleop, stop, clear,
//! plan run or e-stop from a page — makes the next handshake take over (and an e-stop then
//! goes out in the new session at once).

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, TryRecvError};
use std::time::{Duration, Instant};

use anyhow::Result;
use omnikin::link::{LinkCounters, Message, RobotInfo, SimTruth, Telemetry};
use omnikin::runtime::{Faults, Frame, Mode};
use omnikin_plan::Plan;
use serde_json::{Value, json};

use super::hub::{Hub, HubCommand};
use crate::console_operator::ConsoleOperator;
use crate::operator::RobotBusy;
use crate::plan_upload::{PlanUpload, Progress};
use crate::wire_plan::plan_points;
use omnikin_io::mcap_log::McapLog;
use omnikin_io::telemetry_schema;

/// How long a page's teleop command stays valid: the page repeats it every 50 ms while the
/// dead-man is held; without a repeat for this long the relay stops the robot.
pub const TELEOP_HOLD: Duration = Duration::from_millis(300);
/// Longest wait inside one receive, so an e-stop request is sent within this.
pub const SLICE: Duration = Duration::from_millis(5);
/// Wait before re-opening a lost session.
pub const RETRY: Duration = Duration::from_secs(1);
/// Most plan points drawn by the page (the plan is decimated for the preview only).
const PREVIEW_POINTS: usize = 2000;
/// Commands taken from the queue per receive slice.
const BATCH: usize = 16;

/// The relay's configuration.
pub struct RelayConfig {
    /// `--connect`.
    pub connect: String,
    /// `--key`.
    pub key: Option<std::path::PathBuf>,
    /// `--heartbeat`, Hz.
    pub heartbeat_hz: f64,
    /// `--timeout`, s.
    pub timeout_s: f64,
    /// Full-scale teleop speed, m/s.
    pub speed: f64,
    /// Full-scale teleop yaw rate, rad/s.
    pub turn: f64,
    /// Where recordings go (`--record-dir`).
    pub record_dir: std::path::PathBuf,
    /// The live Foxglove stream (`--foxglove`).
    pub fox: Option<Arc<super::foxglove_hub::FoxHub>>,
}

/// A recording to MCAP (the MCAP writer of `drive --mcap`): one message per channel and
/// telemetry frame, the uploaded plans on `/plan`.
struct Recording {
    log: McapLog,
    path: std::path::PathBuf,
    frames: u64,
}

/// A plan upload in progress ([`PlanUpload`], the machine `drive plan` runs too): the
/// machine, when its current step was first sent and when the upload began.
struct Upload {
    plan: PlanUpload,
    since: Instant,
    began: Instant,
}

/// A plan being followed: its id and the largest distance from its reference so far.
struct Follow {
    id: u16,
    max_dev: f32,
    /// Robot time when the robot began the plan, µs.
    start_us: u64,
    /// The plan's duration, s (its last point's time).
    duration_s: f64,
    /// Plan time of the last progress sent to the pages, s.
    shown_s: f64,
}

/// Progress along a plan is sent to the pages at most this often, s of plan time.
const PROGRESS_EVERY_S: f64 = 0.1;

/// A message sent until telemetry confirms it: the first sequence number it went out with.
#[derive(Clone, Copy)]
struct Pending {
    first: u64,
    since: Instant,
    warned: bool,
}

/// The relay's state across sessions.
struct Relay {
    hub: Arc<Hub>,
    cfg: RelayConfig,
    teleop: Option<([f32; 3], Instant)>,
    estop: Option<Pending>,
    clear: Option<Pending>,
    stop: Option<Pending>,
    upload: Option<Upload>,
    follow: Option<Follow>,
    plan: Option<(String, Plan)>,
    prev: Option<Telemetry>,
    info: Option<RobotInfo>,
    rec: Option<Recording>,
    /// Telemetry to Foxglove messages for `--foxglove` (per session: measured rates and
    /// events compare consecutive frames).
    enc: omnikin_io::mcap_log::Encoder,
    /// Another operator held the robot at the last handshake.
    held: Option<RobotBusy>,
    /// The next handshake takes the robot over (the user acted while it was held).
    take_over: bool,
    /// A plan run before the robot's clock was known: `/plan` waits for it.
    plan_msg: PlanMessage,
}

/// `/plan` (Foxglove and the recording) at the robot's clock: the plan's poses are held until
/// a telemetry frame of the session says what time it is on the robot (issue 33: a plan run
/// before any telemetry was stamped at t = 0), then stamped at that frame's time.
#[derive(Debug, Default)]
struct PlanMessage(Option<Vec<omnikin::Pose2<f64>>>);

impl PlanMessage {
    /// A plan is run at robot time `now_us` (`None`: no telemetry yet): the `(time, poses)` to
    /// write now, or `None` when they wait for [`telemetry`](Self::telemetry).
    fn run(
        &mut self,
        now_us: Option<u64>,
        poses: Vec<omnikin::Pose2<f64>>,
    ) -> Option<(u64, Vec<omnikin::Pose2<f64>>)> {
        match now_us {
            Some(t) => {
                self.0 = None;
                Some((t, poses))
            }
            None => {
                self.0 = Some(poses);
                None
            }
        }
    }

    /// A telemetry frame at robot time `time_us`: the held plan stamped at it, once.
    fn telemetry(&mut self, time_us: u64) -> Option<(u64, Vec<omnikin::Pose2<f64>>)> {
        self.0.take().map(|p| (time_us, p))
    }
}

/// Runs the relay until the hub shuts down. `first` is the session opened (and its address
/// and key checked) before the server started.
pub fn run(hub: Arc<Hub>, rx: Receiver<HubCommand>, cfg: RelayConfig, first: ConsoleOperator) {
    let mut r = Relay {
        hub,
        cfg,
        teleop: None,
        estop: None,
        clear: None,
        stop: None,
        upload: None,
        follow: None,
        plan: None,
        prev: None,
        info: None,
        rec: None,
        enc: omnikin_io::mcap_log::Encoder::new("omnikin console"),
        held: None,
        take_over: false,
        plan_msg: PlanMessage::default(),
    };
    r.record_status();
    let mut op = Some(first);
    let mut last_error = String::new();
    while !r.hub.shutdown.load(Ordering::SeqCst) {
        let mut o = match op.take() {
            Some(o) => o,
            None => match ConsoleOperator::open(
                &r.cfg.connect,
                r.cfg.key.as_deref(),
                r.cfg.heartbeat_hz,
                r.cfg.timeout_s,
            ) {
                Ok(o) => o,
                Err(e) => {
                    r.lost(&mut last_error, &format!("{e:#}"));
                    r.wait(RETRY, &rx);
                    continue;
                }
            },
        };
        r.link_state(
            "connecting",
            &format!("handshake with {}", r.cfg.connect),
            None,
        );
        o.set_take_over(r.take_over);
        let info = match o.hello() {
            Ok(i) => i,
            Err(e) => {
                if let Some(b) = e.downcast_ref::<RobotBusy>() {
                    if r.held.is_none() {
                        omnikin_io::errln!("console: {b}");
                        r.event("warn", &format!("{b}"));
                    }
                    r.held = Some(*b);
                    r.link_state("held", &b.to_string(), None);
                } else {
                    r.held = None;
                    r.lost(&mut last_error, &format!("{e:#}"));
                }
                r.wait(RETRY, &rx);
                continue;
            }
        };
        if r.take_over && r.held.is_some() {
            r.event("warn", "took control of the robot from the other operator");
        }
        // Taken once for the user's act: if another operator takes the robot later, this
        // console does not take it back on its own.
        r.take_over = false;
        r.held = None;
        last_error.clear();
        r.info = Some(info);
        r.prev = None;
        // A plan held for the last session's clock is not this session's.
        r.plan_msg = PlanMessage::default();
        r.enc = omnikin_io::mcap_log::Encoder::new("omnikin console");
        // An e-stop asked for before this session is sent in it, and confirmed by it
        // (sequence numbers start again with every session).
        if let Some(p) = r.estop.as_mut() {
            p.first = o.next_seq();
            p.since = Instant::now();
        }
        r.link_state("connected", "session open", Some(&o));
        r.event("info", &format!("session with {} open", r.cfg.connect));
        let result = r.session(&mut o, &rx);
        // A recording is one session's: robot time starts again with the next one.
        r.record(false);
        if let Err(e) = result {
            // Leaving a session: nothing in flight survives it (the robot's watchdog stops
            // it; a new session starts from a clean slate, except an e-stop request).
            r.teleop = None;
            r.stop = None;
            r.clear = None;
            if r.upload.take().is_some() || r.follow.take().is_some() {
                r.plan_status("failed", "the session was lost", None);
            }
            if r.hub.shutdown.load(Ordering::SeqCst) {
                break;
            }
            r.lost(&mut last_error, &format!("{e:#}"));
            r.wait(RETRY, &rx);
        } else {
            break;
        }
    }
}

impl Relay {
    /// Waits `d` (shutdown checked), answering commands that need no session. While another
    /// operator holds the robot, a control command or an e-stop from a page is its user's act:
    /// the wait ends at once and the next handshake takes over (an e-stop is then sent in the
    /// new session; a teleop command is kept for it).
    fn wait(&mut self, d: Duration, rx: &Receiver<HubCommand>) {
        let end = Instant::now() + d;
        while Instant::now() < end && !self.hub.shutdown.load(Ordering::SeqCst) {
            if self.held.is_some() && self.hub.estop.load(Ordering::SeqCst) {
                self.take_control("e-stop");
                return;
            }
            while let Ok(c) = rx.try_recv() {
                match c {
                    HubCommand::Plan { name, plan } => self.preview(name, *plan),
                    HubCommand::Teleop { vx, vy, yaw } if self.held.is_some() => {
                        let v = [
                            (vx * self.cfg.speed) as f32,
                            (vy * self.cfg.speed) as f32,
                            (yaw * self.cfg.turn) as f32,
                        ];
                        self.teleop = Some((v, Instant::now() + TELEOP_HOLD));
                        self.take_control("teleop");
                        return;
                    }
                    HubCommand::Stop | HubCommand::Clear | HubCommand::PlanRun { .. }
                        if self.held.is_some() =>
                    {
                        self.take_control("a command (send it again once connected)");
                        return;
                    }
                    HubCommand::Teleop { .. }
                    | HubCommand::Stop
                    | HubCommand::Clear
                    | HubCommand::PlanRun { .. }
                    | HubCommand::Record(_) => {
                        self.event("warn", "not connected to the robot: command ignored");
                    }
                }
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The user acted while another operator held the robot: the next handshake takes over.
    fn take_control(&mut self, why: &str) {
        self.take_over = true;
        self.event(
            "warn",
            &format!("taking control of the robot from the other operator ({why})"),
        );
    }

    fn lost(&mut self, last: &mut String, why: &str) {
        if why != last.as_str() {
            omnikin_io::errln!("console: {why}");
            self.event("error", why);
            *last = why.to_string();
        }
        self.link_state("lost", why, None);
    }

    /// One session: until it fails (the error says why) or the hub shuts down (`Ok`).
    fn session(&mut self, o: &mut ConsoleOperator, rx: &Receiver<HubCommand>) -> Result<()> {
        let (period, timeout) = o.periods();
        let mut tick = Instant::now();
        let mut last_link = Instant::now();
        loop {
            if self.hub.shutdown.load(Ordering::SeqCst) {
                if self.teleop.is_some() || self.upload.is_some() || self.follow.is_some() {
                    o.send(&Message::Stop)?;
                }
                o.send(&Message::Bye)?;
                return Ok(());
            }
            if let Some(sig) = omnikin_io::output::interrupted() {
                o.send(&Message::Stop)?;
                return Err(sig.into());
            }
            self.take_estop(o)?;
            for _ in 0..BATCH {
                match rx.try_recv() {
                    Ok(c) => self.command(c, o)?,
                    Err(TryRecvError::Empty | TryRecvError::Disconnected) => break,
                }
            }
            let now = Instant::now();
            if now >= tick {
                let m = self.due(o, now, timeout);
                o.send(&m)?;
                tick = now + period;
            }
            if o.pump(SLICE)?
                && let Some(t) = o.latest()
                && let Some(m) = self.telemetry(t, o)
            {
                // The upload moved on: its next message goes now, not at the tick.
                o.send(&m)?;
                tick = Instant::now() + period;
            }
            o.alive()?;
            if last_link.elapsed() > Duration::from_millis(500) {
                self.link_state("connected", "session open", Some(o));
                last_link = Instant::now();
            }
        }
    }

    /// An e-stop request from a page: sent now, and kept until the robot confirms it.
    fn take_estop(&mut self, o: &mut ConsoleOperator) -> Result<()> {
        if self.hub.estop.swap(false, Ordering::SeqCst) {
            self.teleop = None;
            self.stop = None;
            if self.upload.take().is_some() {
                self.plan_status("failed", "cancelled by the e-stop", None);
            }
            if self.estop.is_none() {
                self.estop = Some(Pending {
                    first: o.next_seq(),
                    since: Instant::now(),
                    warned: false,
                });
            }
            o.send(&Message::EStop)?;
            self.event("warn", "e-stop sent");
        }
        Ok(())
    }

    fn command(&mut self, c: HubCommand, o: &mut ConsoleOperator) -> Result<()> {
        match c {
            HubCommand::Teleop { vx, vy, yaw } => {
                // Latched (or being latched): the robot would reject it; the page shows why.
                if self.estop.is_some() || self.prev.is_some_and(|t| t.mode == Mode::EStop) {
                    return Ok(());
                }
                if self.upload.take().is_some() {
                    self.plan_status("failed", "cancelled by teleop", None);
                }
                let v = [
                    (vx * self.cfg.speed) as f32,
                    (vy * self.cfg.speed) as f32,
                    (yaw * self.cfg.turn) as f32,
                ];
                self.teleop = Some((v, Instant::now() + TELEOP_HOLD));
                self.stop = None;
            }
            HubCommand::Stop => {
                if self.upload.take().is_some() {
                    self.plan_status("failed", "cancelled by stop", None);
                }
                let was = self.teleop.take().is_some();
                self.stop = Some(Pending {
                    first: o.next_seq(),
                    since: Instant::now(),
                    warned: false,
                });
                o.send(&Message::Stop)?;
                if !was {
                    self.event("info", "stop sent");
                }
            }
            HubCommand::Clear => {
                self.clear = Some(Pending {
                    first: o.next_seq(),
                    since: Instant::now(),
                    warned: false,
                });
                o.send(&Message::Clear)?;
            }
            HubCommand::Plan { name, plan } => self.preview(name, *plan),
            HubCommand::Record(on) => self.record(on),
            HubCommand::PlanRun { set_pose } => {
                let cap = self.info.map_or(2, |i| i.plan_capacity as usize).max(2);
                let Some((name, pts)) = self
                    .plan
                    .as_ref()
                    .map(|(name, plan)| (name.clone(), plan_points(plan, cap)))
                else {
                    self.event("warn", "run plan: no plan loaded");
                    return Ok(());
                };
                if self.estop.is_some() || self.prev.is_some_and(|t| t.mode == Mode::EStop) {
                    self.event("warn", "run plan: the e-stop is latched (clear it first)");
                    return Ok(());
                }
                if let Some(why) = self.beyond_limits() {
                    self.event("error", &format!("run plan {name}: refused: {why}"));
                    return Ok(());
                }
                let id = (crate::link_io::epoch_seq() & 0xffff) as u16;
                let poses = pts
                    .iter()
                    .map(|w| {
                        omnikin::Pose2::new(w.pose[0].into(), w.pose[1].into(), w.pose[2].into())
                    })
                    .collect();
                if let Some((us, poses)) = self.plan_msg.run(self.prev.map(|t| t.time_us), poses) {
                    self.write_plan(us, &poses);
                }
                self.event(
                    "info",
                    &format!("uploading plan {name} as id {id}: {} points", pts.len()),
                );
                let now = Instant::now();
                self.teleop = None;
                self.stop = None;
                self.follow = None;
                self.upload = Some(Upload {
                    plan: PlanUpload::new(id, pts, set_pose, true),
                    since: now,
                    began: now,
                });
                self.plan_status("uploading", "", Some((0, 0)));
            }
        }
        Ok(())
    }

    /// The message of this heartbeat tick.
    fn due(&mut self, o: &ConsoleOperator, now: Instant, timeout: Duration) -> Message {
        if let Some(p) = self.estop.as_mut() {
            let warn = !p.warned && p.since.elapsed() > timeout;
            p.warned |= warn;
            if warn {
                self.event(
                    "error",
                    "the robot has not confirmed the e-stop yet: still sending it",
                );
            }
            return Message::EStop;
        }
        if self.clear.is_some() {
            return Message::Clear;
        }
        if let Some(u) = &self.upload {
            if u.since.elapsed() > timeout {
                let step = u.plan.step().name();
                self.upload = None;
                self.plan_status(
                    "failed",
                    &format!(
                        "the robot did not confirm {step} within {:.1} s",
                        timeout.as_secs_f64()
                    ),
                    None,
                );
                return Message::Heartbeat;
            }
            return u.plan.message();
        }
        if let Some((v, until)) = self.teleop {
            if now < until {
                return Message::SetVelocity {
                    frame: Frame::Robot,
                    vx: v[0],
                    vy: v[1],
                    yaw_rate: v[2],
                };
            }
            // The page stopped repeating (dead-man released without a stop, page closed).
            self.teleop = None;
            self.stop = Some(Pending {
                first: o.next_seq(),
                since: now,
                warned: false,
            });
            self.event("info", "teleop expired (no dead-man repeat): stop");
        }
        if let Some(p) = &self.stop {
            if p.since.elapsed() <= timeout {
                return Message::Stop;
            }
            self.stop = None;
        }
        Message::Heartbeat
    }

    /// Handles new telemetry: confirmations, upload progress, events, the pages' JSON.
    /// Returns the upload's next message when the upload moved on.
    fn telemetry(&mut self, t: Telemetry, o: &ConsoleOperator) -> Option<Message> {
        if self.prev.is_some_and(|p| t.time_us < p.time_us) {
            return None;
        }
        let prev = self.prev.replace(t);
        if let Some(p) = self.estop
            && t.mode == Mode::EStop
            && t.estop_seq >= p.first
        {
            self.estop = None;
            self.follow = None;
            self.event(
                "warn",
                &format!(
                    "e-stop confirmed by the robot at t {:.2} s",
                    t.time_us as f64 * 1e-6
                ),
            );
        }
        if let Some(p) = self.clear
            && t.ack_seq >= p.first
            && t.mode != Mode::EStop
            && t.fault_history.is_empty()
        {
            self.clear = None;
            self.event("info", "cleared: e-stop latch and fault history");
        }
        if let Some(p) = self.stop
            && t.ack_seq >= p.first
            && matches!(t.mode, Mode::Idle | Mode::EStop | Mode::Stopping)
        {
            self.stop = None;
        }
        if let Some(pr) = prev {
            self.events_between(&pr, &t);
        }
        if let Some((us, poses)) = self.plan_msg.telemetry(t.time_us) {
            self.write_plan(us, &poses);
        }
        let next = self.advance_upload(&t);
        if let Some(f) = &mut self.follow {
            if t.mode == Mode::Trajectory {
                let d = (t.pose[0] - t.reference[0]).hypot(t.pose[1] - t.reference[1]);
                f.max_dev = f.max_dev.max(d);
                // Progress in plan time: the robot's clock since it began the plan.
                let elapsed =
                    (t.time_us.saturating_sub(f.start_us) as f64 * 1e-6).min(f.duration_s);
                if elapsed - f.shown_s >= PROGRESS_EVERY_S {
                    f.shown_s = elapsed;
                    let (elapsed_s, duration_s) = (elapsed, f.duration_s);
                    self.hub.publish(
                        &json!({"type": "plan_status", "state": "running", "detail": "",
                            "received": t.plan.received, "len": t.plan.len,
                            "elapsed_s": elapsed_s, "duration_s": duration_s}),
                        Some("plan_status"),
                    );
                }
            } else if t.plan.id == f.id && t.plan.done && t.mode == Mode::Idle {
                let msg = format!(
                    "plan {} done: max |pose - reference| {:.4} m; end pose ({:.3}, {:.3}, {:.3})",
                    f.id, f.max_dev, t.pose[0], t.pose[1], t.pose[2]
                );
                self.follow = None;
                self.plan_status("done", &msg, Some((t.plan.received, t.plan.len)));
                self.event("info", &msg);
            } else if !t.plan.done
                && t.mode != Mode::Trajectory
                && !matches!(t.mode, Mode::Stopping)
            {
                let msg = format!(
                    "the robot left the plan (mode {}, faults {})",
                    t.mode, t.fault_history
                );
                self.follow = None;
                self.plan_status("failed", &msg, None);
            }
        }
        if let Some(fox) = &self.cfg.fox {
            let s = omnikin_io::mcap_log::telemetry_sample_with_truth(&t, o.truth());
            if let Some(ns) = omnikin_io::mcap_log::foxglove::time_ns(s.t) {
                for (topic, v) in self.enc.messages("", &s, ns) {
                    fox.publish(topic, ns, &v);
                }
            }
        }
        if let Some(r) = self.rec.as_mut() {
            match r
                .log
                .sample(&omnikin_io::mcap_log::telemetry_sample_with_truth(
                    &t,
                    o.truth(),
                )) {
                Ok(()) => r.frames += 1,
                Err(e) => {
                    self.event("error", &format!("recording: {e:#}"));
                    self.record(false);
                }
            }
        }
        let steer = self.info.is_some_and(|i| i.kind.steerable());
        self.hub.publish(
            &telemetry_json(
                &t,
                prev.as_ref(),
                o.truth().filter(|x| x.time_us == t.time_us),
                steer,
                &o.counters(),
                o.frames(),
            ),
            Some("telemetry"),
        );
        next
    }

    /// Moves the upload on when telemetry confirms its current step.
    fn advance_upload(&mut self, t: &Telemetry) -> Option<Message> {
        let u = self.upload.as_mut()?;
        match u.plan.advance(t) {
            Progress::Waiting => return None,
            Progress::Started => {
                let (id, secs) = (u.plan.id(), u.began.elapsed().as_secs_f64());
                let pts = u.plan.points();
                let duration_s = pts.last().map_or(0.0, |p| f64::from(p.t - pts[0].t));
                self.upload = None;
                self.follow = Some(Follow {
                    id,
                    max_dev: 0.0,
                    start_us: t.time_us,
                    duration_s,
                    shown_s: 0.0,
                });
                self.event(
                    "info",
                    &format!("plan {id} uploaded in {secs:.2} s and started"),
                );
                self.plan_status("running", "", Some((t.plan.received, t.plan.len)));
                return None;
            }
            Progress::Moved { pose_set } => {
                if pose_set {
                    // The estimate jumped on purpose: the pages break the trail here.
                    let p = u.plan.points()[0].pose;
                    self.hub
                        .publish(&json!({"type": "pose_set", "pose": p}), None);
                }
            }
        }
        let u = self.upload.as_mut()?;
        u.since = Instant::now();
        let m = u.plan.message();
        let (got, len) = (t.plan.received, t.plan.len);
        self.plan_status("uploading", "", Some((got, len)));
        Some(m)
    }

    /// Events from two consecutive telemetry frames: mode changes and new faults.
    fn events_between(&mut self, a: &Telemetry, b: &Telemetry) {
        if a.mode != b.mode {
            self.event("info", &format!("mode {} → {}", a.mode, b.mode));
        }
        let new = new_faults(a, b);
        for (flag, name) in Faults::ALL {
            // LIMIT is routine; ESTOP is reported by its confirmation and the mode change.
            if new.contains(flag) && flag != Faults::LIMIT && flag != Faults::ESTOP {
                let text = match flag {
                    Faults::LINK_LOST => {
                        "watchdog: no command in time, the robot stopped".to_string()
                    }
                    Faults::SLIP => {
                        format!("wheel slip detected (residual {:.3} m/s)", b.slip_residual)
                    }
                    Faults::COLLISION => {
                        "collision: the wheels stopped suddenly (events.collision_decel)"
                            .to_string()
                    }
                    Faults::REJECTED => format!("a command was rejected ({} so far)", b.rejected),
                    _ => format!("fault: {name}"),
                };
                let level = if flag == Faults::HARDWARE {
                    "error"
                } else {
                    "warn"
                };
                self.event(level, &text);
            }
        }
    }

    /// What the loaded plan asks beyond the stricter of the robot file's limits (`--robot`)
    /// and the robot's own (its handshake), or `None` when it is within them.
    fn beyond_limits(&self) -> Option<String> {
        let (_, plan) = self.plan.as_ref()?;
        let file = self.hub.robot_limits.get();
        let limits =
            crate::body_limits::held(file.map(|(_, l)| l), self.info.as_ref().map(|i| &i.limits))?;
        let excess = crate::body_limits::plan_excess(&limits, &crate::body_limits::peaks(plan));
        (!excess.is_empty())
            .then(|| format!("{}; the robot would lag behind it", excess.join("; ")))
    }

    fn preview(&mut self, name: String, plan: Plan) {
        let pts = plan_points(&plan, PREVIEW_POINTS);
        let msg = json!({
            "type": "plan",
            "name": name,
            "samples": plan.samples.len(),
            "duration_s": plan.duration(),
            "length_m": plan.path_length(),
            "points": pts.iter().map(|p| [p.pose[0], p.pose[1], p.pose[2]]).collect::<Vec<_>>(),
        });
        self.event(
            "info",
            &format!(
                "plan {name} loaded: {} samples, {:.1} s, {:.2} m",
                plan.samples.len(),
                plan.duration(),
                plan.path_length()
            ),
        );
        self.hub.publish(&msg, Some("plan"));
        self.plan_status("preview", "", None);
        self.plan = Some((name, plan));
    }

    /// Starts or stops the recording (a new file `console-<unix time>.mcap` in the record
    /// directory each time, never overwriting one).
    /// `/plan` at robot time `time_us`: to Foxglove (`--foxglove`) and the recording.
    fn write_plan(&mut self, time_us: u64, poses: &[omnikin::Pose2<f64>]) {
        let ns = time_us.saturating_mul(1000);
        if let Some(fox) = &self.cfg.fox {
            use omnikin_io::mcap_log::foxglove as fg;
            fox.publish(fg::PLAN, ns, &fg::poses_in_frame(ns, poses));
        }
        if let Some(r) = self.rec.as_mut()
            && let Err(e) = r
                .log
                .plan(omnikin_io::mcap_log::foxglove::seconds(ns), poses)
        {
            self.event("error", &format!("recording: {e:#}"));
            self.record(false);
        }
    }

    fn record(&mut self, on: bool) {
        match (on, self.rec.take()) {
            (true, Some(r)) => self.rec = Some(r),
            (true, None) => {
                let secs = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_secs());
                let path = self.cfg.record_dir.join(format!("console-{secs}.mcap"));
                match McapLog::create("--record-dir", &path, "omnikin console", true) {
                    Ok(log) => {
                        self.event("info", &format!("recording to {}", path.display()));
                        self.rec = Some(Recording {
                            log,
                            path,
                            frames: 0,
                        });
                    }
                    Err(e) => self.event("error", &format!("recording: {e:#}")),
                }
            }
            (false, Some(r)) => {
                let (path, frames) = (r.path.display().to_string(), r.frames);
                match r.log.finish() {
                    Ok(()) => self.event(
                        "info",
                        &format!("recorded {frames} telemetry frames to {path}"),
                    ),
                    Err(e) => self.event("error", &format!("recording {path}: {e:#}")),
                }
            }
            (false, None) => {}
        }
        self.record_status();
    }

    fn record_status(&self) {
        self.hub.publish(
            &json!({"type": "record", "on": self.rec.is_some(),
                "path": self.rec.as_ref().map(|r| r.path.display().to_string())}),
            Some("record"),
        );
    }

    fn plan_status(&mut self, state: &str, detail: &str, progress: Option<(u16, u16)>) {
        if state == "failed" {
            self.event("error", &format!("plan: {detail}"));
        }
        self.hub.publish(
            &json!({"type": "plan_status", "state": state, "detail": detail,
                "received": progress.map(|p| p.0), "len": progress.map(|p| p.1)}),
            Some("plan_status"),
        );
    }

    fn link_state(&self, state: &str, detail: &str, o: Option<&ConsoleOperator>) {
        let robot = self.info.map(|i| {
            json!({"protocol": i.protocol, "kind": format!("{:?}", i.kind), "plan_capacity": i.plan_capacity,
                "rate_hz": i.rate_hz, "watchdog_s": i.watchdog, "authenticated": i.authenticated})
        });
        self.hub.publish(
            &json!({"type": "link", "state": state, "detail": detail, "addr": self.cfg.connect,
                "session": o.and_then(ConsoleOperator::session_id).map(|s| format!("{s:016x}")),
                "robot": if state == "connected" { robot } else { None },
                "clients": self.hub.clients.load(Ordering::SeqCst)}),
            Some("link"),
        );
    }

    fn event(&self, level: &str, text: &str) {
        let wall = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        let robot_t = self.prev.map(|t| t.time_us as f64 * 1e-6);
        self.hub.publish(
            &json!({"type": "event", "level": level, "text": text, "wall": wall, "robot_t": robot_t}),
            None,
        );
    }
}

/// Measured wheel rates, rad/s: the encoder angles' difference over the robot time between
/// two telemetry frames (`None` without a previous frame or when no time passed).
pub fn measured_rates(a: &Telemetry, b: &Telemetry) -> Option<Vec<f64>> {
    let dt = b.time_us.checked_sub(a.time_us)? as f64 * 1e-6;
    if dt <= 0.0 {
        return None;
    }
    let n = (b.wheels as usize).min(omnikin::MAX_WHEELS);
    Some(
        (0..n)
            .map(|i| (b.wheel_angles[i] as f64 - a.wheel_angles[i] as f64) / dt)
            .collect(),
    )
}

/// The pages' telemetry message: the frame's fields as [`omnikin_io::telemetry_schema`] names
/// them, and what the console derives (the true pose in simulation, the measured wheel rates,
/// the tracking and twist errors, its own link counters and frame count).
fn telemetry_json(
    t: &Telemetry,
    prev: Option<&Telemetry>,
    truth: Option<SimTruth>,
    steer: bool,
    op: &LinkCounters,
    frames: u64,
) -> Value {
    let twist_err =
        ((t.command[0] - t.twist[0]).powi(2) + (t.command[1] - t.twist[1]).powi(2)).sqrt();
    let mut m = telemetry_schema::json_fields(t, steer);
    let derived = json!({
        "type": "telemetry",
        "truth": truth.map(|x| x.pose),
        "wheel_meas": prev.and_then(|p| measured_rates(p, t)),
        "tracking_error_m": (t.mode == Mode::Trajectory)
            .then(|| (t.pose[0] - t.reference[0]).hypot(t.pose[1] - t.reference[1])),
        "twist_error": twist_err,
        "console_link": telemetry_schema::counters_json(op),
        "frames": frames,
    });
    if let Value::Object(d) = derived {
        m.extend(d);
    }
    Value::Object(m)
}

/// The faults to report between two consecutive telemetry frames: new in the history, and —
/// for the slip and collision events, whose flags stay up for a whole episode (at least the
/// 0.2 s hold, several telemetry frames) — every rising edge, so a second slip or collision
/// after a first is reported too.
fn new_faults(a: &Telemetry, b: &Telemetry) -> Faults {
    let episodes = Faults::SLIP.0 | Faults::COLLISION.0;
    Faults((b.fault_history.0 & !a.fault_history.0) | (b.faults.0 & !a.faults.0 & episodes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_collision_episode_is_reported_once() {
        let frame = |faults: Faults, history: Faults| Telemetry {
            faults,
            fault_history: history,
            ..tel(0, [0.0; 3])
        };
        let c = Faults::COLLISION;
        let frames = [
            frame(Faults::NONE, Faults::NONE),
            frame(c, c),
            frame(c, c),
            frame(Faults::NONE, c),
            frame(c, c),
            frame(Faults::NONE, c),
        ];
        let reported: Vec<bool> = frames
            .windows(2)
            .map(|w| new_faults(&w[0], &w[1]).contains(c))
            .collect();
        assert_eq!(reported, [true, false, false, true, false]);
        // A sticky fault is reported once, when it enters the history.
        let l = Faults::LINK_LOST;
        assert!(new_faults(&frame(Faults::NONE, Faults::NONE), &frame(l, l)).contains(l));
        assert!(new_faults(&frame(Faults::NONE, l), &frame(l, l)).is_empty());
    }

    fn tel(time_us: u64, q: [f32; 3]) -> Telemetry {
        let mut t = crate::test_support::telemetry(time_us);
        t.wheel_angles[..3].copy_from_slice(&q);
        t
    }

    #[test]
    fn plan_waits_for_the_robot_clock() {
        let poses = vec![omnikin::Pose2::new(1.0, 2.0, 0.5)];
        let mut m = PlanMessage::default();
        // No telemetry yet: nothing at t = 0; the first frame stamps it, once.
        assert_eq!(m.run(None, poses.clone()), None);
        assert_eq!(m.telemetry(2_050_000), Some((2_050_000, poses.clone())));
        assert_eq!(m.telemetry(2_060_000), None);
        // The clock known: at once, at that time, and nothing held.
        assert_eq!(
            m.run(Some(3_000_000), poses.clone()),
            Some((3_000_000, poses))
        );
        assert_eq!(m.telemetry(3_010_000), None);
    }

    #[test]
    fn measured_rates_are_encoder_differences() {
        // 0.05 s apart: 0.1 rad → 2 rad/s, -0.05 rad → -1 rad/s.
        let a = tel(1_000_000, [1.0, 2.0, 0.0]);
        let b = tel(1_050_000, [1.1, 1.95, 0.0]);
        let r = measured_rates(&a, &b).unwrap();
        assert!(
            (r[0] - 2.0).abs() < 1e-4 && (r[1] + 1.0).abs() < 1e-4 && r[2] == 0.0,
            "{r:?}"
        );
        assert!(measured_rates(&b, &a).is_none());
        assert!(measured_rates(&a, &a).is_none());
    }
}
