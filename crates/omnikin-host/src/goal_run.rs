//! `drive goal`: a goal reached across a map, re-planned on the way without stopping.
//!
//! 1. **The first plan** runs from the robot's estimate (its telemetry pose, at rest) to the
//!    goal around the map's shapes for the planned clearance (the footprint and a margin),
//!    timed time-optimally ([`omnikin_plan::map::goal`]), held to the body limits the robot
//!    names in its handshake, and uploaded with at most half the robot's plan buffer (so that
//!    a replacement always fits the free half while it runs).
//! 2. **While it runs**, a re-plan is triggered by an obstacle added to the map
//!    ([`ObstacleRequest`]: map TOML with `[[keep_out]]` tables, from `drive obstacle` through
//!    [`ObstacleListener`]) or by the estimate drifting more than the tolerance from the
//!    plan's reference (again only after the drift has fallen below half the tolerance).
//! 3. **The replacement is a splice** ([`omnikin_plan::splice::splice_to_goal`]): it starts
//!    on the running plan's reference at a splice time `t_s` a little ahead of the robot's plan
//!    time — position, heading, velocity and yaw rate, computed from the very points the robot
//!    holds — and the robot switches to it at `t_s` without slowing down. A **drift**, where
//!    the robot is away from that reference, is re-planned from where the robot will be: the
//!    plan time `τ` whose reference is nearest the estimate, the reference and velocity at
//!    `τ + (t_s − now)` moved by the estimate's offset from the reference at `τ` — and uploaded
//!    as a re-based splice
//!    ([`Message::PlanSpliceRebased`]; the runtime takes it at `t_s` with its reference
//!    re-based on the measured pose, so the position loop does not pull the robot back across
//!    whatever lies between — a splice on the reference did, 9.7 cm into a shape after a
//!    0.45 m lag). A robot **held up** (moving at under half its reference's speed) is stopped
//!    and re-planned at rest instead: it is not going on along its path as the prediction
//!    assumes, and until a splice takes over the running plan would drive it across a corner.
//!    If no splice can be laid (the predicted start within the clearance of a shape, refusals,
//!    the plan ending), the robot is stopped and re-planned at rest (step 4).
//!    `t_s` leaves room for the planning and the upload, both measured (robot time from the
//!    telemetry clock's rate); a splice the robot refuses (its `rejected` count grows: too
//!    late, off the plan, no room) is retried twice with twice the lead.
//! 4. **When no splice can be laid** (the motion heads into a new shape closer than the
//!    lead-in, three refusals, or the plan ends too soon for one while its rest comes closer
//!    than the clearance to a new shape; a rest that keeps clear is left to run), the robot
//!    is stopped and a fresh plan uploaded from its
//!    estimate at rest ([`GoalDriven::stops`] counts these).

use std::net::{SocketAddr, UdpSocket};
use std::sync::mpsc::{self, Receiver, Sender};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use omnikin::link::{Message, WirePoint};
use omnikin::runtime::{Mode, PlanPoint};
use omnikin::{Pose2, Twist2, wrap_angle};
use omnikin_plan::map::goal::{goal_heading, goal_path};
use omnikin_plan::map::{Map, Obstacle, Shape};
use omnikin_plan::planner::{PlanOptions, Timing, plan};
use omnikin_plan::splice::{splice_from, splice_start};
use omnikin_plan::{Plan, RobotModel};

use crate::actions::RobotRefused;
use crate::operator::Session;
use crate::plan_upload::{PlanUpload, Progress, UploadStep};
use crate::wire_plan::plan_points;

/// `drive goal --replan-tolerance`'s default, m: a drift of the estimate from the plan's
/// reference beyond this re-plans.
pub const DEFAULT_REPLAN_TOLERANCE: f64 = 0.1;

/// `drive goal --control`'s default: where a running `drive goal` takes obstacles.
pub const DEFAULT_CONTROL: &str = "127.0.0.1:7480";

/// Largest obstacle message, bytes (a datagram of map TOML).
pub const MAX_OBSTACLE_BYTES: usize = 8192;

/// Splice attempts for one re-plan before the robot is stopped and re-planned at rest.
const SPLICE_ATTEMPTS: usize = 3;

/// What a goal run needs: the map, the goal, the robot and how to plan.
#[derive(Clone, Debug)]
pub struct GoalSpec {
    /// The map; obstacles added on the way are appended to its keep-out shapes.
    pub map: Map,
    /// The goal, world frame, m.
    pub goal: [f64; 2],
    /// The goal heading, rad (`None`: keep the heading).
    pub heading: Option<f64>,
    /// The planned clearance from every shape, m: the footprint radius and a margin.
    pub clearance: f64,
    /// The robot's model (for the planner's wheel limits).
    pub robot: RobotModel,
    /// The planner's options; the timing must be time-optimal (a splice starts moving).
    pub options: PlanOptions,
    /// Re-plan when the estimate is farther than this from the plan's reference, m.
    pub replan_tolerance: f64,
}

/// A goal request's numbers as a front end takes them (`drive goal`'s flags; m, m/s, m/s²,
/// rad/s), checked by [`check_goal_numbers`] before anything is planned.
#[derive(Clone, Copy, Debug)]
pub struct GoalNumbers {
    /// `--margin`: clearance added to the footprint, m.
    pub margin: f64,
    /// `--replan-tolerance`: drift from the reference that triggers a re-plan, m.
    pub replan_tolerance: f64,
    /// `--max-speed`, m/s.
    pub max_speed: f64,
    /// `--max-accel`, m/s² (`None`: the robot's body limit).
    pub max_accel: Option<f64>,
    /// `--max-yaw-rate`, rad/s.
    pub max_yaw_rate: f64,
    /// `--footprint-radius`, m (`None`: the robot file's).
    pub footprint_radius: Option<f64>,
}

/// Refuses, naming the flag and the range, a margin or re-plan tolerance outside 0–10 m (the
/// tolerance > 0), a speed, yaw rate or acceleration outside its plausible range (bounded
/// below too: a plan at a crawl would have unbounded samples), a footprint radius outside
/// (0, 100] m.
///
/// # Errors
/// The first number out of its range.
pub fn check_goal_numbers(g: &GoalNumbers) -> Result<()> {
    for (flag, v) in [
        ("--margin", g.margin),
        ("--replan-tolerance", g.replan_tolerance),
    ] {
        if !(0.0..=10.0).contains(&v) {
            bail!("{flag} {v}: must be between 0 and 10 m");
        }
    }
    if g.replan_tolerance == 0.0 {
        bail!("--replan-tolerance 0: must be > 0 m");
    }
    for (flag, v, lo, hi, unit) in [
        ("--max-speed", Some(g.max_speed), 1e-3, 100.0, "m/s"),
        (
            "--max-yaw-rate",
            Some(g.max_yaw_rate),
            1e-3,
            1000.0,
            "rad/s",
        ),
        ("--max-accel", g.max_accel, 1e-3, 1000.0, "m/s²"),
    ] {
        if let Some(v) = v
            && !(lo..=hi).contains(&v)
        {
            bail!("{flag} {v}: must be between {lo} and {hi} {unit}");
        }
    }
    if let Some(r) = g.footprint_radius
        && !(r > 0.0 && r <= 100.0)
    {
        bail!("--footprint-radius {r}: must be > 0 and at most 100 m");
    }
    Ok(())
}

/// Why a plan was replaced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ReplanReason {
    /// An obstacle was added to the map (its 1-based number among the added ones).
    Obstacle(usize),
    /// The estimate drifted this far from the reference, m.
    Drift(f64),
}

impl std::fmt::Display for ReplanReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Obstacle(n) => write!(f, "obstacle {n} added"),
            Self::Drift(d) => write!(f, "drift {d:.3} m from the reference"),
        }
    }
}

/// A replacement the robot took.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpliceRecord {
    /// Why.
    pub reason: ReplanReason,
    /// The splice time on the robot's plan clock, s.
    pub t_s: f64,
    /// The plan time when it was asked for, s.
    pub asked_at: f64,
    /// The robot's clock at the same moment (its telemetry), s: the splice takes over at
    /// robot time `asked_robot_time + t_s - asked_at`.
    pub asked_robot_time: f64,
    /// The reference speed at `t_s`, m/s.
    pub speed: f64,
    /// Points uploaded.
    pub points: usize,
    /// Refusals before it was taken.
    pub retries: usize,
}

/// A goal reached.
#[derive(Clone, Debug, PartialEq)]
pub struct GoalDriven {
    /// The first plan: points uploaded, duration (s), path length (m).
    pub first: (usize, f64, f64),
    /// The splices the robot took, in order.
    pub splices: Vec<SpliceRecord>,
    /// Re-plans that had to stop the robot (no splice could be laid).
    pub stops: usize,
    /// Largest distance between the estimate and the reference while following, m.
    pub max_deviation: f32,
    /// The robot's estimate at the end `[x, y, heading]`.
    pub end_pose: [f32; 3],
}

/// An obstacle for a running goal: map TOML holding `[[keep_out]]` tables (the map file's
/// format), and where to send the answer (a line saying what became of it, or the error).
#[derive(Debug)]
pub struct ObstacleRequest {
    /// The TOML text.
    pub toml: String,
    /// Names it in errors (`drive obstacle from 127.0.0.1:5000`).
    pub source: String,
    /// The answer: `Ok(what was done)` or `Err(why it was refused)`.
    pub reply: Option<Sender<std::result::Result<String, String>>>,
}

/// The map TOML of one obstacle: a circle `[x, y, r]` or a polygon `x1,y1,x2,y2,…` (m,
/// counter-clockwise), exactly one of them. The values are checked again by the map parser
/// on the receiving side (with the map file's rules).
///
/// # Errors
/// Neither or both, a circle without three numbers, a polygon with an odd count or fewer
/// than three vertices, a non-finite number.
pub fn obstacle_toml(circle: Option<&[f64]>, polygon: Option<&str>) -> Result<String> {
    let num = |v: f64| -> Result<String> {
        if v.is_finite() {
            Ok(format!("{v:?}"))
        } else {
            bail!("{v} is not a finite number")
        }
    };
    match (circle, polygon) {
        (Some(c), None) => {
            let [x, y, r] = c else {
                bail!("--circle: expected X,Y,R (m), got {} values", c.len());
            };
            Ok(format!(
                "[[keep_out]]\ncircle = [{}, {}, {}]\n",
                num(*x)?,
                num(*y)?,
                num(*r)?
            ))
        }
        (None, Some(p)) => {
            let parts: Vec<&str> = p.split(',').map(str::trim).collect();
            if parts.len() > 2 * 256 {
                bail!("--polygon: at most 256 vertices");
            }
            let mut v = Vec::with_capacity(parts.len());
            for (i, s) in parts.iter().enumerate() {
                let x: f64 = s.parse().map_err(|_| {
                    anyhow::anyhow!("--polygon: item {}: {s:?} is not a number", i + 1)
                })?;
                v.push(num(x).with_context(|| format!("--polygon: item {}", i + 1))?);
            }
            if v.len() % 2 != 0 || v.len() < 6 {
                bail!(
                    "--polygon: expected X1,Y1,X2,Y2,X3,Y3[,…] (at least three vertices, m, counter-clockwise), got {} values",
                    v.len()
                );
            }
            let pts: Vec<String> = v
                .chunks(2)
                .map(|c| format!("[{}, {}]", c[0], c[1]))
                .collect();
            Ok(format!("[[keep_out]]\npolygon = [{}]\n", pts.join(", ")))
        }
        _ => {
            bail!("drive obstacle: give exactly one of --circle X,Y,R and --polygon X1,Y1,X2,Y2,…")
        }
    }
}

/// The loopback UDP socket where a running `drive goal` takes obstacles ([`send_obstacle`]
/// sends them): one datagram of map TOML in, one answer out (`ok: …` or `error: …`).
pub struct ObstacleListener {
    addr: SocketAddr,
}

impl ObstacleListener {
    /// Binds `addr` (a loopback address: obstacles are not authenticated) and starts a thread
    /// that forwards each datagram to the returned receiver and sends back the goal run's
    /// answer (or, after 5 s without one, that none came).
    ///
    /// # Errors
    /// An address that is not `HOST:PORT`, not loopback, or cannot be bound (another `drive
    /// goal` holds it).
    pub fn bind(addr: &str, flag: &str) -> Result<(Self, Receiver<ObstacleRequest>)> {
        let a: SocketAddr = addr.parse().map_err(|_| {
            anyhow::anyhow!(
                "{flag} {addr}: expected HOST:PORT with a loopback IP, e.g. 127.0.0.1:7480"
            )
        })?;
        if !a.ip().is_loopback() {
            bail!(
                "{flag} {addr}: obstacles are not authenticated, so they are taken only on a loopback address (127.0.0.1:PORT)"
            );
        }
        let socket = UdpSocket::bind(a)
            .with_context(|| format!("{flag} {addr}: cannot bind (another drive goal running?)"))?;
        let local = socket.local_addr()?;
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || listen(&socket, &tx));
        Ok((Self { addr: local }, rx))
    }

    /// The bound address.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }
}

fn listen(socket: &UdpSocket, tx: &Sender<ObstacleRequest>) {
    let mut buf = vec![0u8; MAX_OBSTACLE_BYTES + 1];
    loop {
        let Ok((n, from)) = socket.recv_from(&mut buf) else {
            return;
        };
        let answer = if n > MAX_OBSTACLE_BYTES {
            format!("error: obstacle message over {MAX_OBSTACLE_BYTES} bytes")
        } else if let Ok(text) = std::str::from_utf8(&buf[..n]) {
            let (rtx, rrx) = mpsc::channel();
            let req = ObstacleRequest {
                toml: text.to_string(),
                source: format!("drive obstacle from {from}"),
                reply: Some(rtx),
            };
            if tx.send(req).is_err() {
                return;
            }
            match rrx.recv_timeout(Duration::from_secs(5)) {
                Ok(Ok(s)) => format!("ok: {s}"),
                Ok(Err(e)) => format!("error: {e}"),
                Err(_) => "error: the goal run did not answer in 5 s".into(),
            }
        } else {
            "error: the obstacle message is not UTF-8".into()
        };
        let _ = socket.send_to(answer.as_bytes(), from);
    }
}

/// Sends one obstacle (map TOML) to the `drive goal` listening at `addr` and waits at most
/// `timeout` for its answer.
///
/// # Errors
/// No answer in time (no `drive goal` there), or the goal run's refusal.
pub fn send_obstacle(addr: &str, toml: &str, timeout: Duration) -> Result<String> {
    let to: SocketAddr = addr.parse().map_err(|_| {
        anyhow::anyhow!("--control {addr}: expected HOST:PORT, e.g. 127.0.0.1:7480")
    })?;
    let bind = if to.is_ipv4() {
        "127.0.0.1:0"
    } else {
        "[::1]:0"
    };
    let socket = UdpSocket::bind(bind).context("binding a local UDP socket")?;
    socket.set_read_timeout(Some(timeout))?;
    socket
        .send_to(toml.as_bytes(), to)
        .with_context(|| format!("--control {addr}: cannot send"))?;
    let mut buf = vec![0u8; 4096];
    loop {
        let (n, from) = socket.recv_from(&mut buf).map_err(|_| {
            anyhow::anyhow!(
                "no answer from a drive goal at {addr} in {:.1} s (is one running, with --control {addr}?)",
                timeout.as_secs_f64()
            )
        })?;
        if from != to {
            continue;
        }
        let text = String::from_utf8_lossy(&buf[..n]).into_owned();
        return match text.strip_prefix("error: ") {
            Some(e) => bail!("{e}"),
            None => Ok(text.strip_prefix("ok: ").unwrap_or(&text).to_string()),
        };
    }
}

/// The wire points as the robot holds them (f32 read back as f64).
fn held(points: &[WirePoint]) -> Vec<PlanPoint<f64>> {
    points
        .iter()
        .map(|p| PlanPoint {
            t: f64::from(p.t),
            pose: Pose2::new(
                f64::from(p.pose[0]),
                f64::from(p.pose[1]),
                f64::from(p.pose[2]),
            ),
            twist: Twist2::new(
                f64::from(p.twist[0]),
                f64::from(p.twist[1]),
                f64::from(p.twist[2]),
            ),
        })
        .collect()
}

/// Where a drifted robot at `est` (world, m) at plan time `now` will be at `t_s`, and how it
/// will move there, on the running plan `points`: the plan time `τ` whose reference is nearest
/// `est` (closest point of the points' polyline, times up to `t_s`), then the reference at
/// `τ + (t_s − now)` — position and world velocity — moved by `est`'s offset from the reference
/// at `τ`. A robot held up is behind on its path, one pushed is beside it: either way it goes
/// on along the path from where it is (module docs, step 3).
fn predict_drifted(
    points: &[PlanPoint<f64>],
    est: [f64; 2],
    now: f64,
    t_s: f64,
) -> ([f64; 2], [f64; 2]) {
    let mut best = (f64::INFINITY, now);
    for w in points.windows(2).filter(|w| w[0].t <= t_s) {
        let (a, b) = (w[0].pose, w[1].pose);
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let l2 = dx * dx + dy * dy;
        let u = if l2 > 0.0 {
            (((est[0] - a.x) * dx + (est[1] - a.y) * dy) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d = (a.x + u * dx - est[0]).hypot(a.y + u * dy - est[1]);
        if d < best.0 {
            best = (d, w[0].t + u * (w[1].t - w[0].t));
        }
    }
    let tau = best.1;
    let at = |t: f64| omnikin::runtime::plan_reference(points, t);
    match (at(tau), at(tau + (t_s - now))) {
        (Some((here, _)), Some((there, v))) => (
            [there.x + est[0] - here.x, there.y + est[1] - here.y],
            [v.vx, v.vy],
        ),
        _ => (est, [0.0, 0.0]),
    }
}

/// A plan of `spec` from `from` at rest, heading `h0`.
fn plan_at_rest(spec: &GoalSpec, from: [f64; 2], h0: f64) -> Result<(Plan, f64)> {
    let way = goal_path(&spec.map, spec.clearance, from, spec.goal)?;
    let len = way.smoothed.path.length();
    let h1 = spec.heading.map(|h| h0 + wrap_angle(h - h0));
    let law = goal_heading(Some(h0), h1, len)?;
    let p = plan(&way.smoothed.path, &law, &spec.robot, &spec.options)?.plan;
    Ok((p, len))
}

/// Why a splice could not be laid.
enum SpliceFailed {
    /// The planner could not (its reason).
    Plan(String),
    /// The robot refused it every time.
    Refused,
    /// The running plan ends before a splice could reach the robot.
    TooLate,
}

/// The state of a goal run between telemetry frames.
struct Run<'a> {
    spec: &'a mut GoalSpec,
    cap: usize,
    /// The running plan as the robot holds it.
    running: Vec<PlanPoint<f64>>,
    next_id: u16,
    /// Wall seconds a plan took to compute and upload, the larger of the last ones.
    plan_secs: f64,
    upload_secs_per_point: f64,
    /// Robot seconds per wall second, from the telemetry clock.
    clock: Option<(Instant, u64)>,
    added: usize,
}

impl Run<'_> {
    fn id(&mut self) -> u16 {
        self.next_id = self.next_id.wrapping_add(1).max(1);
        self.next_id
    }

    /// Robot seconds per wall second (1 until measured).
    fn rate(&self, s: &Session) -> f64 {
        match (self.clock, s.latest) {
            (Some((w0, t0)), Some(t)) if w0.elapsed().as_secs_f64() > 0.2 => {
                (t.time_us.saturating_sub(t0) as f64 * 1e-6 / w0.elapsed().as_secs_f64()).max(0.1)
            }
            _ => 1.0,
        }
    }
}

impl Session {
    /// Drives to `spec`'s goal (module docs), taking obstacles from `obstacles` on the way;
    /// `say` gets a line for every plan, obstacle and splice.
    ///
    /// # Errors
    /// No path from the estimate (the map's reason); a plan over the robot's body limits; a
    /// robot without a plan buffer; [`RobotRefused`] when the robot leaves the plan (an
    /// e-stop, a fault); the link's errors.
    pub fn drive_goal(
        &mut self,
        spec: &mut GoalSpec,
        obstacles: &Receiver<ObstacleRequest>,
        say: &mut dyn FnMut(String),
    ) -> Result<GoalDriven> {
        if !matches!(spec.options.timing, Timing::TimeOptimal { .. }) {
            bail!("drive goal needs the time-optimal timing (a re-plan starts moving)");
        }
        let info = self.hello()?;
        if info.plan_capacity < 8 {
            bail!(
                "the robot holds {} plan points: drive goal needs a plan buffer (a balancing ballbot takes velocities only)",
                info.plan_capacity
            );
        }
        self.first_telemetry("telemetry (the robot's pose)")?;
        let t = self.latest.context("no telemetry")?;
        let from = [f64::from(t.pose[0]), f64::from(t.pose[1])];
        if (from[0] - spec.goal[0]).hypot(from[1] - spec.goal[1]) < 1e-3 {
            bail!(
                "the robot's estimate ({:.4}, {:.4}) is already at the goal (within 1 mm): nothing to drive",
                from[0],
                from[1]
            );
        }
        let t0 = Instant::now();
        let (p, len) = plan_at_rest(spec, from, f64::from(t.pose[2])).with_context(|| {
            format!("from the robot's estimate ({:.3}, {:.3})", from[0], from[1])
        })?;
        let label = format!("the plan to ({}, {})", spec.goal[0], spec.goal[1]);
        if let Some(line) = crate::body_limits::check_upload(&p, &label, None, &info.limits)? {
            say(line);
        }
        let mut run = Run {
            spec,
            cap: (usize::from(info.plan_capacity) / 2).max(2),
            running: Vec::new(),
            next_id: (crate::link_io::epoch_seq() & 0x7fff) as u16,
            plan_secs: t0.elapsed().as_secs_f64(),
            upload_secs_per_point: 0.0,
            clock: None,
            added: 0,
        };
        let pts = plan_points(&p, run.cap);
        let id = run.id();
        let up = self.upload_plan(id, pts.clone(), false)?;
        run.upload_secs_per_point = up.secs / pts.len() as f64;
        let first = (pts.len(), p.duration(), len);
        say(format!(
            "plan {id}: ({:.3}, {:.3}) to ({}, {}) across {}, {len:.3} m in {:.2} s, {} points uploaded in {:.2} s",
            from[0],
            from[1],
            run.spec.goal[0],
            run.spec.goal[1],
            run.spec.map.source_name,
            p.duration(),
            pts.len(),
            up.secs
        ));
        run.running = held(&pts);
        let mut out = GoalDriven {
            first,
            splices: Vec::new(),
            stops: 0,
            max_deviation: 0.0,
            end_pose: t.pose,
        };
        let mut drift_armed = true;
        let mut last_seen = Instant::now();
        let mut last_t = 0u64;
        let mut beat = Instant::now();
        loop {
            self.beat(&mut beat, &Message::Heartbeat)?;
            let Some(t) = self.latest else { continue };
            if run.clock.is_none() {
                run.clock = Some((Instant::now(), t.time_us));
            }
            if t.time_us != last_t {
                last_t = t.time_us;
                last_seen = Instant::now();
            }
            while let Ok(req) = obstacles.try_recv() {
                let answer = self.add_obstacle(&mut run, &req, &mut out, say);
                if let Err(e) = &answer {
                    say(format!("obstacle from {} refused: {e}", req.source));
                }
                if let Some(r) = &req.reply {
                    let _ = r.send(answer.map_err(|e| format!("{e:#}")));
                }
            }
            let Some(t) = self.latest else { continue };
            if t.mode == Mode::Trajectory {
                let d = (t.pose[0] - t.reference[0]).hypot(t.pose[1] - t.reference[1]);
                out.max_deviation = out.max_deviation.max(d);
                let d = f64::from(d);
                if d > run.spec.replan_tolerance && drift_armed {
                    drift_armed = false;
                    self.replan(&mut run, ReplanReason::Drift(d), &mut out, say)?;
                } else if d < run.spec.replan_tolerance / 2.0 {
                    drift_armed = true;
                }
            } else if t.plan.done && t.mode == Mode::Idle {
                out.end_pose = t.pose;
                return Ok(out);
            } else if !t.plan.done {
                return Err(RobotRefused(format!(
                    "the robot left the plan (mode {}, faults {})",
                    t.mode, t.fault_history
                ))
                .into());
            }
            self.alive()?;
            if last_seen.elapsed() > self.timeout {
                bail!(
                    "telemetry stopped for {:.1} s while following the plan",
                    self.timeout.as_secs_f64()
                );
            }
        }
    }

    /// Adds the obstacle of `req` to the map and re-plans; the answer says what was done.
    fn add_obstacle(
        &mut self,
        run: &mut Run<'_>,
        req: &ObstacleRequest,
        out: &mut GoalDriven,
        say: &mut dyn FnMut(String),
    ) -> Result<String> {
        let extra = Map::from_toml(&req.toml, &req.source)?;
        if extra.keep_in.is_some() {
            bail!(
                "{}: an added obstacle has no [keep_in] (only [[keep_out]] tables)",
                req.source
            );
        }
        if extra.keep_out.is_empty() {
            bail!("{}: no [[keep_out]] table", req.source);
        }
        let t = self.latest.context("no telemetry")?;
        let f = run.spec.clearance;
        for o in &extra.keep_out {
            let one = Map {
                source_name: req.source.clone(),
                keep_out: vec![o.clone()],
                keep_in: None,
            };
            one.check_point(
                [f64::from(t.pose[0]), f64::from(t.pose[1])],
                f,
                "the robot's estimate",
            )?;
            one.check_point(
                [f64::from(t.reference[0]), f64::from(t.reference[1])],
                f,
                "the plan's reference",
            )?;
            one.check_point(run.spec.goal, f, "the goal")?;
        }
        for o in extra.keep_out {
            run.added += 1;
            let line = run
                .spec
                .map
                .keep_out
                .iter()
                .map(|o| o.line)
                .max()
                .unwrap_or(0);
            let shape = describe(&o.shape);
            run.spec.map.keep_out.push(Obstacle {
                shape: o.shape,
                line: line.max(o.line),
            });
            say(format!("obstacle {}: {shape} added", run.added));
        }
        let n = out.splices.len();
        let stops = out.stops;
        self.replan(run, ReplanReason::Obstacle(run.added), out, say)?;
        Ok(if out.stops > stops {
            "added; the robot stopped and re-planned at rest".into()
        } else if out.splices.len() > n {
            let s = out.splices[n];
            format!(
                "added; re-planned, spliced at plan time {:.3} s at {:.3} m/s",
                s.t_s, s.speed
            )
        } else {
            "added; the plan was ending, not re-planned".into()
        })
    }

    /// Replaces the running plan by a splice (or, when none can be laid, stops and plans
    /// afresh at rest).
    fn replan(
        &mut self,
        run: &mut Run<'_>,
        reason: ReplanReason,
        out: &mut GoalDriven,
        say: &mut dyn FnMut(String),
    ) -> Result<()> {
        let drift = matches!(reason, ReplanReason::Drift(_));
        if drift && let Some(t) = self.latest {
            // A robot held up (moving at under half its reference's speed) is not going on
            // along its path as a splice from the estimate predicts; until the splice takes
            // over, the running plan's feed-forward — the direction of a reference that may be
            // past a corner — and its position loop would drive it across the corner
            // (measured: held 1.5 s at 5x real time, a re-based splice 2 s of robot time ahead
            // left the true shell 3.8 cm inside a shape). It is not moving: stop and re-plan.
            let v = f64::from(t.twist[0]).hypot(f64::from(t.twist[1]));
            let v_ref = omnikin::runtime::plan_reference(&run.running, f64::from(t.plan_time))
                .map_or(0.0, |(_, w)| w.vx.hypot(w.vy));
            if v < 0.5 * v_ref {
                say(format!(
                    "re-plan ({reason}): the robot is held up ({v:.3} m/s against its reference's {v_ref:.3} m/s); stopping to re-plan from the estimate"
                ));
                return self.restart(run, out, say);
            }
        }
        match self.splice(run, reason, out, say)? {
            Ok(()) => Ok(()),
            // A drifted robot is not on the rest of the plan: the rest being clear says nothing.
            Err(SpliceFailed::TooLate) if !drift && self.rest_is_clear(run) => {
                say(format!(
                    "re-plan ({reason}): the plan ends before a splice could reach the robot, and its rest keeps clear of the map: left as it is"
                ));
                Ok(())
            }
            Err(why) => {
                let why = match why {
                    SpliceFailed::Plan(e) => e,
                    SpliceFailed::TooLate => {
                        "the plan ends too soon for one, and its rest comes too close to a shape"
                            .into()
                    }
                    SpliceFailed::Refused => format!("the robot refused {SPLICE_ATTEMPTS} splices"),
                };
                say(format!(
                    "re-plan ({reason}): no splice ({why}); stopping to re-plan at rest"
                ));
                self.restart(run, out, say)
            }
        }
    }

    /// Stops the robot and uploads a fresh plan from its estimate at rest.
    fn restart(
        &mut self,
        run: &mut Run<'_>,
        out: &mut GoalDriven,
        say: &mut dyn FnMut(String),
    ) -> Result<()> {
        self.stop()?;
        let t = self.latest.context("no telemetry")?;
        let from = [f64::from(t.pose[0]), f64::from(t.pose[1])];
        let (p, len) = plan_at_rest(run.spec, from, f64::from(t.pose[2])).with_context(|| {
            format!("from the robot's estimate ({:.3}, {:.3})", from[0], from[1])
        })?;
        let pts = plan_points(&p, run.cap);
        let id = run.id();
        let up = self.upload_plan(id, pts.clone(), false)?;
        run.running = held(&pts);
        out.stops += 1;
        say(format!(
            "plan {id}: from rest at ({:.3}, {:.3}), {len:.3} m in {:.2} s, {} points uploaded in {:.2} s",
            from[0],
            from[1],
            p.duration(),
            pts.len(),
            up.secs
        ));
        Ok(())
    }

    /// Whether the running plan, from the robot's plan time on, keeps the planned clearance
    /// from every shape of the map (within the route's tolerance), sampled every 2 cm.
    fn rest_is_clear(&self, run: &Run<'_>) -> bool {
        let now = self.latest.map_or(0.0, |t| f64::from(t.plan_time));
        let f = run.spec.clearance * (1.0 - omnikin_plan::map::route::CLEAR_TOLERANCE);
        run.running.windows(2).filter(|w| w[1].t >= now).all(|w| {
            let (a, b) = (w[0].pose, w[1].pose);
            let n = ((b.x - a.x).hypot(b.y - a.y) / 0.02).ceil().max(1.0) as usize;
            (0..=n).all(|k| {
                let u = k as f64 / n as f64;
                run.spec
                    .map
                    .clearance([a.x + u * (b.x - a.x), a.y + u * (b.y - a.y)])
                    >= f
            })
        })
    }

    /// Plans and uploads a splice, retrying with a longer lead when the robot refuses it. For
    /// a drift, a re-based splice from the estimate moved along the reference to `t_s`.
    fn splice(
        &mut self,
        run: &mut Run<'_>,
        reason: ReplanReason,
        out: &mut GoalDriven,
        say: &mut dyn FnMut(String),
    ) -> Result<std::result::Result<(), SpliceFailed>> {
        let rate = run.rate(self);
        let expected = run.running.len() as f64;
        let mut lead_wall = 1.5 * (run.plan_secs + run.upload_secs_per_point * expected)
            + 2.0 * self.heartbeat.as_secs_f64()
            + 0.05;
        for retries in 0..SPLICE_ATTEMPTS {
            let t = self.latest.context("no telemetry")?;
            let now = f64::from(t.plan_time);
            let t_s = now + (rate * lead_wall).max(0.05);
            let end = run.running.last().map_or(0.0, |p| p.t);
            if t_s >= end - 0.05 {
                return Ok(Err(SpliceFailed::TooLate));
            }
            let w0 = Instant::now();
            // The clearance, then 1 mm less: a start on a curve that hugs an inflated shape
            // has a straight lead-in that leaves the clearance by micrometres.
            let c = run.spec.clearance;
            let mut tries = vec![c];
            if c > 2e-3 {
                tries.push(c - 1e-3);
            }
            let mut found = None;
            let mut why = String::new();
            let mut start = match splice_start(&run.running, t_s) {
                Ok(s) => s,
                Err(e) => return Ok(Err(SpliceFailed::Plan(e.to_string()))),
            };
            let rebased = matches!(reason, ReplanReason::Drift(_));
            if rebased {
                let est = [f64::from(t.pose[0]), f64::from(t.pose[1])];
                let (position, velocity) = predict_drifted(&run.running, est, now, t_s);
                start.position = position;
                start.velocity = velocity;
            }
            for clearance in tries {
                match splice_from(
                    start,
                    run.spec.goal,
                    run.spec.heading,
                    &run.spec.map,
                    clearance,
                    &run.spec.robot,
                    &run.spec.options,
                ) {
                    Ok(s) => {
                        found = Some((s, clearance));
                        break;
                    }
                    Err(e) => why = e.to_string(),
                }
            }
            let Some((spliced, kept)) = found else {
                return Ok(Err(SpliceFailed::Plan(why)));
            };
            run.plan_secs = run.plan_secs.max(w0.elapsed().as_secs_f64());
            let pts = plan_points(&spliced.planned.plan, run.cap);
            let id = run.id();
            let u0 = Instant::now();
            let taken = self.upload_splice(id, pts.clone(), rebased)?;
            let secs = u0.elapsed().as_secs_f64();
            run.upload_secs_per_point = run.upload_secs_per_point.max(secs / pts.len() as f64);
            let [vx, vy] = spliced.start.velocity;
            if taken {
                run.running = held(&pts);
                let rec = SpliceRecord {
                    reason,
                    t_s,
                    asked_at: now,
                    asked_robot_time: t.time_us as f64 * 1e-6,
                    speed: vx.hypot(vy),
                    points: pts.len(),
                    retries,
                };
                say(format!(
                    "re-plan ({reason}) at plan time {now:.3} s: plan {id} spliced{} at {t_s:.3} s at {:.3} m/s, {:.3} m in {:.2} s to the goal (clearance {kept:.3} m), {} points uploaded in {secs:.2} s",
                    if rebased {
                        format!(
                            " from the estimate ({:.3}, {:.3})",
                            start.position[0], start.position[1]
                        )
                    } else {
                        String::new()
                    },
                    rec.speed,
                    spliced.smoothed.path.length(),
                    spliced.planned.plan.duration(),
                    pts.len()
                ));
                out.splices.push(rec);
                return Ok(Ok(()));
            }
            say(format!(
                "re-plan ({reason}): the robot refused the splice at {t_s:.3} s (plan time {:.3} s when asked); retrying with twice the lead",
                now
            ));
            lead_wall *= 2.0;
        }
        Ok(Err(SpliceFailed::Refused))
    }

    /// Uploads `points` as a splice `id` of the running plan and arms it: `Ok(true)` when the
    /// robot took it, `Ok(false)` when it refused a step (its `rejected` count grew).
    /// `rebased`: a splice planned from where the robot is ([`Message::PlanSpliceRebased`]),
    /// otherwise from the running plan's reference ([`Message::PlanSplice`]).
    ///
    /// # Errors
    /// The link's (no confirmation within the timeout, the session lost).
    pub fn upload_splice(
        &mut self,
        id: u16,
        points: Vec<WirePoint>,
        rebased: bool,
    ) -> Result<bool> {
        let rejected = |s: &Session| s.latest.map_or(0, |t| t.rejected);
        let n = points.len() as u16;
        // The session's MCAP log gets the replacement on `/plan`, as the first plan.
        if let Some(m) = self.mcap.as_mut() {
            omnikin_io::mcap_log::drive_plan(m, self.latest.map_or(0, |t| t.time_us), &points)?;
        }
        let mut up = PlanUpload::new(id, points, false, false);
        loop {
            let before = rejected(self);
            let first = self.next_seq();
            if up.step() == UploadStep::Start {
                let m = Message::PlanStart { id };
                self.until(&m, "splice start", |s| {
                    s.latest.is_some_and(|t| t.ack_seq >= first)
                })?;
                let t = self.latest.context("no telemetry")?;
                return Ok(t.rejected == before && t.plan.id == id && t.plan.received == n);
            }
            let m = match up.step() {
                UploadStep::Begin if rebased => Message::PlanSpliceRebased { id, len: n },
                UploadStep::Begin => Message::PlanSplice { id, len: n },
                _ => up.message(),
            };
            self.until(&m, up.step().name(), |s| {
                s.latest.is_some_and(|t| {
                    up.confirmed_by(&t) || (t.ack_seq >= first && t.rejected > before)
                })
            })?;
            let t = self.latest.context("no telemetry")?;
            if up.advance(&t) == Progress::Waiting {
                return Ok(false);
            }
        }
    }
}

/// A shape in a line (`circle (3, 4) r 0.3`).
fn describe(s: &Shape) -> String {
    match s {
        Shape::Circle { centre, radius } => {
            format!("circle at ({}, {}) radius {radius} m", centre[0], centre[1])
        }
        Shape::Polygon(v) => format!("polygon of {} vertices", v.len()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obstacles_become_map_toml_that_the_map_rules_check() {
        let t = obstacle_toml(Some(&[1.0, 2.0, 0.25]), None).unwrap();
        let m = Map::from_toml(&t, "x").unwrap();
        assert_eq!(
            m.keep_out[0].shape,
            Shape::Circle {
                centre: [1.0, 2.0],
                radius: 0.25
            }
        );
        let t = obstacle_toml(None, Some("0,0, 1,0, 1,1")).unwrap();
        assert!(
            matches!(&Map::from_toml(&t, "x").unwrap().keep_out[0].shape, Shape::Polygon(v) if v.len() == 3)
        );
        // Clockwise: the map's rule names it.
        let t = obstacle_toml(None, Some("0,0,1,1,1,0")).unwrap();
        let e = Map::from_toml(&t, "x").unwrap_err().to_string();
        assert!(e.contains("clockwise"), "{e}");
        let e = obstacle_toml(Some(&[1.0, 2.0]), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--circle: expected X,Y,R"), "{e}");
        let e = obstacle_toml(None, Some("0,0,1,x,1,1"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("--polygon: item 4"), "{e}");
        let e = format!(
            "{:#}",
            obstacle_toml(Some(&[f64::NAN, 0.0, 1.0]), None).unwrap_err()
        );
        assert!(e.contains("finite"), "{e}");
        assert!(obstacle_toml(None, None).is_err());
    }

    #[test]
    fn an_obstacle_travels_to_the_listener_and_its_answer_back() {
        let (l, rx) = ObstacleListener::bind("127.0.0.1:0", "--control").unwrap();
        let addr = l.local_addr().to_string();
        let goal = std::thread::spawn(move || {
            let req = rx.recv_timeout(Duration::from_secs(5)).unwrap();
            assert!(req.toml.contains("circle"));
            req.reply.unwrap().send(Ok("added".into())).unwrap();
            let req = rx.recv_timeout(Duration::from_secs(5)).unwrap();
            req.reply
                .unwrap()
                .send(Err("covers the goal".into()))
                .unwrap();
        });
        let t = obstacle_toml(Some(&[1.0, 2.0, 0.25]), None).unwrap();
        assert_eq!(
            send_obstacle(&addr, &t, Duration::from_secs(5)).unwrap(),
            "added"
        );
        let e = send_obstacle(&addr, &t, Duration::from_secs(5)).unwrap_err();
        assert_eq!(e.to_string(), "covers the goal");
        goal.join().unwrap();
        let e = ObstacleListener::bind("192.0.2.1:7480", "--control")
            .err()
            .unwrap();
        assert!(e.to_string().contains("loopback"), "{e}");
    }
}
