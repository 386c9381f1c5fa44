//! `omnikin drive`: the operator's side of the link — velocity commands, plan upload and
//! following, stop / e-stop / clear, telemetry logging and keyboard teleoperation.
//!
//! Shape: `omnikin drive --connect ADDR [--key FILE] [--heartbeat HZ] ACTION`, with ACTION one
//! of `hello`, `velocity --vx --vy --yaw-rate [--world] --for S`, `plan PLAN.csv`, `stop`,
//! `estop`, `clear`, `telemetry --out LOG.csv [--for S]`, `teleop`. `velocity`, `plan` and
//! `telemetry` take `--out LOG.csv` to record every telemetry frame.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use omnikin::link::{
    CHUNK_POINTS, Endpoint, Message, PROTOCOL_VERSION, RobotInfo, Telemetry, WirePoint,
};
use omnikin::runtime::{Frame, Mode};
use omnikin_plan::Plan;

use crate::args::finite_f64;
use crate::link_io::{Link, Transport, epoch_seq, load_key, parse_address};

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

/// Telemetry CSV header: pose columns first (the pose CSV of the conventions), then the rest.
pub const TELEMETRY_HEADER: &str = "t,x,y,heading,vx,vy,yaw_rate,cmd_vx,cmd_vy,cmd_yaw_rate,w1,w2,w3,q1,q2,q3,gyro_z,mode,faults,fault_history,plan_id,plan_received,plan_len,plan_time,ref_x,ref_y,ref_heading,rejected,last_command_t,rx_ok,rx_framing,rx_crc,rx_version,rx_auth,rx_replay,rx_malformed";

fn telemetry_row(t: &Telemetry) -> String {
    let l = &t.link;
    format!(
        "{:.6},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.6},{},{},{},{},{},{},{}",
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
        t.wheel_rates[0],
        t.wheel_rates[1],
        t.wheel_rates[2],
        t.wheel_angles[0],
        t.wheel_angles[1],
        t.wheel_angles[2],
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
    )
}

/// An operator session: the link, the newest telemetry, an optional CSV log.
struct Session {
    link: Link,
    latest: Option<Telemetry>,
    info: Option<RobotInfo>,
    log: Option<crate::output::OutFile>,
    frames: u64,
    heartbeat: Duration,
    timeout: Duration,
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
        let link = Link::new(
            Transport::open(&addr, false)?,
            Endpoint::new(key, epoch_seq()),
        );
        Ok(Self {
            link,
            latest: None,
            info: None,
            log: None,
            frames: 0,
            heartbeat: crate::args::duration("--heartbeat", 1.0 / a.heartbeat)?,
            timeout: crate::args::duration("--timeout", a.timeout)?,
        })
    }

    fn record(&mut self, out: Option<&Path>) -> Result<()> {
        if let Some(p) = out {
            // The log is kept on every exit path, Ctrl-C included (see crate::output).
            let mut w = crate::output::OutFile::log("--out", p)?;
            writeln!(w, "{TELEMETRY_HEADER}").context("--out: cannot write")?;
            self.log = Some(w);
            crate::output::catch_signals()?;
        }
        Ok(())
    }

    fn send(&mut self, m: &Message) -> Result<()> {
        self.link.send(m)
    }

    /// Receives for `dur`; returns `true` if a new telemetry frame arrived.
    fn pump(&mut self, dur: Duration) -> Result<bool> {
        let mut fresh = false;
        if let Some(sig) = crate::output::interrupted() {
            return Err(sig.into());
        }
        for r in self.link.poll(dur)? {
            match r.result {
                Ok((_, Message::Telemetry(t))) => {
                    if self.latest.is_none_or(|l| t.time_us >= l.time_us) {
                        self.latest = Some(t);
                    }
                    if let Some(w) = self.log.as_mut() {
                        writeln!(w, "{}", telemetry_row(&t)).context("--out: cannot write")?;
                    }
                    self.frames += 1;
                    fresh = true;
                }
                Ok((_, Message::HelloAck(info))) => self.info = Some(info),
                _ => {}
            }
        }
        Ok(fresh)
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
            }
            if start.elapsed() > self.timeout {
                bail!(
                    "no answer from the robot to {what} within {:.1} s (check --connect, --key and that `omnikin robot` runs)",
                    self.timeout.as_secs_f64()
                );
            }
        }
    }

    fn hello(&mut self) -> Result<RobotInfo> {
        self.until(
            &Message::Hello {
                protocol: PROTOCOL_VERSION,
            },
            "hello",
            |s| s.info.is_some(),
        )?;
        let info = self.info.context("no hello answer")?;
        if info.protocol != PROTOCOL_VERSION {
            bail!(
                "robot speaks protocol version {}, this drive speaks {PROTOCOL_VERSION}",
                info.protocol
            );
        }
        Ok(info)
    }

    fn finish(&mut self) -> Result<()> {
        match self.log.take() {
            Some(w) => w.commit(),
            None => Ok(()),
        }
    }

    fn print_status(&self) -> Result<()> {
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
                "robot link: {} frames ok, dropped {} (framing {}, crc {}, version {}, auth {}, replay {}, malformed {}); commands rejected {}",
                l.ok,
                l.dropped(),
                l.framing,
                l.crc,
                l.version,
                l.auth,
                l.replay,
                l.malformed,
                t.rejected
            )?;
        }
        Ok(())
    }
}

/// Runs one `drive` action.
pub fn run(a: &DriveArgs) -> Result<()> {
    let mut s = Session::open(a)?;
    match &a.action {
        DriveAction::Hello => {
            let i = s.hello()?;
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
            while Instant::now() < end {
                s.send(&m)?;
                s.pump(s.heartbeat)?;
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
        } => {
            s.record(out.as_deref())?;
            follow_plan(&mut s, plan, *set_pose)?;
        }
        DriveAction::Stop => {
            s.hello()?;
            stop(&mut s)?;
            s.print_status()?;
        }
        DriveAction::Estop => {
            s.until(&Message::EStop, "estop", |s| {
                s.latest.is_some_and(|t| t.mode == Mode::EStop)
            })?;
            s.print_status()?;
        }
        DriveAction::Clear => {
            s.until(&Message::Clear, "clear", |s| {
                s.latest
                    .is_some_and(|t| t.mode != Mode::EStop && t.fault_history.is_empty())
            })?;
            s.print_status()?;
        }
        DriveAction::Telemetry { out, duration } => {
            s.record(Some(out))?;
            s.hello()?;
            let end = Instant::now() + crate::args::duration("--for", *duration)?;
            while Instant::now() < end {
                // Hello keeps this operator the robot's telemetry peer without commanding.
                s.send(&Message::Heartbeat)?;
                s.pump(s.heartbeat)?;
            }
            crate::outln!("{} telemetry frames written to {}", s.frames, out.display())?;
            s.print_status()?;
        }
        DriveAction::Teleop { speed, turn } => {
            let period = s.heartbeat;
            crate::teleop::run(&mut s, *speed, *turn, period)?;
        }
    }
    s.finish()
}

impl crate::teleop::Operator for Session {
    fn send(&mut self, m: &Message) -> Result<()> {
        self.link.send(m)
    }
    fn poll(&mut self, d: Duration) -> Result<Option<Telemetry>> {
        self.pump(d)?;
        Ok(self.latest)
    }
}

fn stop(s: &mut Session) -> Result<()> {
    s.until(&Message::Stop, "stop", |s| {
        s.latest
            .is_some_and(|t| matches!(t.mode, Mode::Idle | Mode::EStop))
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

fn follow_plan(s: &mut Session, path: &Path, set_pose: bool) -> Result<()> {
    let plan = Plan::load_csv(path).with_context(|| format!("plan {}", path.display()))?;
    if plan.samples.len() < 2 {
        bail!("plan {}: needs at least 2 samples", path.display());
    }
    let info = s.hello()?;
    let pts = plan_points(&plan, info.plan_capacity as usize);
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
    loop {
        s.send(&Message::Heartbeat)?;
        s.pump(s.heartbeat)?;
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
