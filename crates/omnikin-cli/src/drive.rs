//! `omnikin drive`: the operator's side of the link — velocity commands, plan upload and
//! following, stop / e-stop / clear, telemetry logging and keyboard teleoperation.
//!
//! Shape: `omnikin drive --connect ADDR [--key FILE] [--heartbeat HZ] ACTION`, with ACTION one
//! of `hello`, `velocity --vx --vy --yaw-rate [--world] --for S`, `plan PLAN.csv`, `stop`,
//! `estop`, `clear`, `telemetry --out LOG.csv [--for S]`, `teleop`. `velocity`, `plan` and
//! `telemetry` take `--out LOG.csv` to record every telemetry frame, and `--fixes FILE|-` to
//! forward camera fixes while they run ([`omnikin_host::fixes`]).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use omnikin::link::{CHUNK_POINTS, Estimate, Message, Telemetry};
use omnikin::runtime::{Frame, Mode};
use omnikin_plan::Plan;

use crate::args::finite_f64;
use crate::link_io::epoch_seq;
use omnikin_host::operator::Session;
use omnikin_host::wire_plan::plan_points;

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

/// Runs one `drive` action.
pub fn run(a: &DriveArgs) -> Result<()> {
    let mut s = Session::open(
        &a.connect,
        a.key.as_deref(),
        a.heartbeat,
        a.timeout,
        a.mcap.as_deref(),
    )?;
    if let Some(path) = &a.fixes {
        if !matches!(
            a.action,
            DriveAction::Velocity { .. } | DriveAction::Plan { .. } | DriveAction::Telemetry { .. }
        ) {
            bail!(
                "--fixes forwards fixes while velocity, plan or telemetry runs; not with this action"
            );
        }
        s.fixes = Some(omnikin_host::fixes::FixFeeder::open(
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
                print_status(&s)?;
                bail!(
                    "the robot did not take the command (mode {}, rejected {})",
                    t.mode,
                    t.rejected
                );
            }
            stop(&mut s)?;
            print_status(&s)?;
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
            print_status(&s)?;
        }
        DriveAction::Estop => {
            s.hello()?;
            // Confirmed only by telemetry of this session naming one of this run's EStops.
            let first = s.next_seq();
            s.until(&Message::EStop, "the e-stop", |s| {
                s.latest
                    .is_some_and(|t| t.mode == Mode::EStop && t.estop_seq >= first)
            })?;
            print_status(&s)?;
        }
        DriveAction::Clear => {
            s.hello()?;
            let first = s.next_seq();
            s.until(&Message::Clear, "clear", |s| {
                s.latest.is_some_and(|t| {
                    t.ack_seq >= first && t.mode != Mode::EStop && t.fault_history.is_empty()
                })
            })?;
            print_status(&s)?;
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
            print_status(&s)?;
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
                print_status(s)?;
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
    print_status(s)?;
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
            print_status(s)?;
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
    print_status(s)?;
    Ok(())
}

/// What the robot says at the end of an action: the fixes forwarded, its estimate (once fixes
/// are in play), its mode, pose and faults, its link counters.
fn print_status(s: &Session) -> Result<()> {
    if let Some(f) = &s.fixes {
        crate::outln!("{}", f.report(s.estimate.map(|e| e.fixes)))?;
    }
    // The estimate line once fixes are in play (this run forwards them, or the robot has
    // had some): before that the pose is the wheel odometry and the line says nothing new.
    let fixes_seen = |e: &Estimate| {
        let f = e.fixes;
        s.fixes.is_some() || f.accepted + f.rejected + f.too_late > 0
    };
    if let (Some(e), Some(t)) = (s.estimate.as_ref().filter(|e| fixes_seen(e)), &s.latest) {
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
    if let Some(t) = &s.latest {
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
