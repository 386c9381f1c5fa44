//! `omnikin drive`: the operator's side of the link — velocity commands, plan upload and
//! following, stop / e-stop / clear, telemetry logging and keyboard teleoperation.
//!
//! Shape: `omnikin drive --connect ADDR [--key FILE] [--heartbeat HZ] ACTION`, with ACTION one
//! of `hello`, `velocity --vx --vy --yaw-rate [--world] --for S`, `plan PLAN.csv`, `stop`,
//! `estop`, `clear`, `telemetry --out LOG.csv [--for S]`, `teleop`, `goal X,Y[,H] --map
//! MAP.toml --robot R` (re-planned on the way: [`omnikin_host::goal_run`]) and `obstacle
//! --circle X,Y,R | --polygon …` (sent to a running `drive goal`, which needs no `--connect`). `velocity`, `plan` and
//! `telemetry` take `--out LOG.csv` to record every telemetry frame, and `--fixes FILE|-` to
//! forward camera fixes while they run ([`omnikin_host::fixes`]).

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use omnikin::link::{Message, Telemetry};
use omnikin::runtime::Frame;
use omnikin_plan::Plan;

use crate::args::finite_f64;
use crate::link_io::epoch_seq;
use omnikin_host::actions::RobotRefused;
use omnikin_host::operator::Session;
use omnikin_host::wire_plan::plan_points;

/// `omnikin drive`.
#[derive(clap::Args, Debug)]
pub struct DriveArgs {
    /// The robot: HOST:PORT (UDP), udp:HOST:PORT or serial:PATH[@BAUD] (every action but
    /// `obstacle`).
    #[arg(long, value_name = "ADDR")]
    pub connect: Option<String>,
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
    /// Forward camera fixes while `velocity`, `plan`, `goal` or `telemetry` runs: a CSV
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
    /// Drive to a goal across a map: plan from the robot's estimate around the shapes, upload,
    /// and while it runs re-plan: when `drive obstacle` adds a shape, by splicing a new plan
    /// onto the running one at its reference, which the robot takes without stopping; when the
    /// estimate drifts more than --replan-tolerance from the reference, by a splice from the
    /// estimate that the robot takes with its reference re-based where it is, also without
    /// stopping.
    Goal {
        /// The goal X,Y[,H] (world frame; m, m, rad; heading default: kept).
        #[arg(allow_hyphen_values = true, value_name = "X,Y[,H]")]
        goal: crate::args::List,
        /// The map (the format of `omnikin plan goal --map`).
        #[arg(long, value_name = "MAP.toml")]
        map: PathBuf,
        /// The robot being driven (preset or robot file, as its `omnikin robot --robot`):
        /// its wheel limits time the plans, its footprint keeps them off the shapes.
        #[arg(long)]
        robot: String,
        /// Footprint radius, m [default: the robot's, as `omnikin check` prints it].
        #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
        footprint_radius: Option<f64>,
        /// Extra clearance the plans keep beyond the footprint, m: room for tracking errors
        /// (a plan touches the inflated shapes, so without it any error is a touch).
        #[arg(long, default_value_t = 0.05, allow_hyphen_values = true, value_parser = finite_f64)]
        margin: f64,
        /// Max speed along the path, m/s.
        #[arg(long, default_value_t = 0.2, allow_hyphen_values = true, value_parser = finite_f64)]
        max_speed: f64,
        /// Max acceleration, m/s² [default: 0.5, or the robot's body limit if lower].
        #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
        max_accel: Option<f64>,
        /// Max yaw rate, rad/s.
        #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = finite_f64)]
        max_yaw_rate: f64,
        /// Re-plan when the robot's estimate is farther than this from the plan's reference, m.
        #[arg(long, value_name = "METERS", default_value_t = omnikin_host::goal_run::DEFAULT_REPLAN_TOLERANCE, allow_hyphen_values = true, value_parser = finite_f64)]
        replan_tolerance: f64,
        /// Where to take obstacles from `drive obstacle` (a loopback HOST:PORT).
        #[arg(long, value_name = "ADDR", default_value = omnikin_host::goal_run::DEFAULT_CONTROL)]
        control: String,
        /// First set the robot's pose estimate to X,Y[,H] (m, m, rad; heading default 0).
        #[arg(long, allow_hyphen_values = true, value_name = "X,Y[,H]")]
        set_pose: Option<crate::args::List>,
        /// Record telemetry to this CSV file.
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Add a keep-out shape to the map of a running `drive goal` (which re-plans around it
    /// without stopping, and answers what it did). No `--connect`: it talks to the goal run.
    Obstacle {
        /// A circle X,Y,R (world frame, m).
        #[arg(long, allow_hyphen_values = true, value_name = "X,Y,R")]
        circle: Option<crate::args::List>,
        /// A polygon X1,Y1,X2,Y2,X3,Y3[,…] (world frame, m, counter-clockwise).
        #[arg(long, allow_hyphen_values = true, value_name = "X1,Y1,X2,Y2,…")]
        polygon: Option<String>,
        /// The running `drive goal`'s --control address.
        #[arg(long, value_name = "ADDR", default_value = omnikin_host::goal_run::DEFAULT_CONTROL)]
        control: String,
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
    if let DriveAction::Obstacle {
        circle,
        polygon,
        control,
    } = &a.action
    {
        let toml = omnikin_host::goal_run::obstacle_toml(
            circle.as_ref().map(|c| c.0.as_slice()),
            polygon.as_deref(),
        )?;
        let answer = omnikin_host::goal_run::send_obstacle(
            control,
            &toml,
            crate::args::duration("--timeout", a.timeout)?,
        )?;
        return crate::outln!("drive goal at {control}: {answer}");
    }
    let Some(connect) = &a.connect else {
        bail!("--connect ADDR (the robot's address) is required for this action");
    };
    let mut s = Session::open(
        connect,
        a.key.as_deref(),
        a.heartbeat,
        a.timeout,
        a.mcap.as_deref(),
        omnikin_host::names::OptionNames::CLI,
    )?;
    if let Some(path) = &a.fixes {
        if !matches!(
            a.action,
            DriveAction::Velocity { .. }
                | DriveAction::Plan { .. }
                | DriveAction::Telemetry { .. }
                | DriveAction::Goal { .. }
        ) {
            bail!(
                "--fixes forwards fixes while velocity, plan, goal or telemetry runs; not with this action"
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
            s.first_telemetry("the session")?;
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
            let frame = if *world { Frame::World } else { Frame::Robot };
            let dur = crate::args::duration("--for", *duration)?;
            let r = s.velocity(frame, [*vx, *vy, *yaw_rate], dur);
            refused(&s, r)?;
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
            s.stop()?;
            print_status(&s)?;
        }
        DriveAction::Estop => {
            s.hello()?;
            s.estop()?;
            print_status(&s)?;
        }
        DriveAction::Clear => {
            s.hello()?;
            s.clear()?;
            print_status(&s)?;
        }
        DriveAction::Telemetry { out, duration } => {
            s.record(Some(out))?;
            s.hello()?;
            // Heartbeats keep the session (and the watchdog) alive without commanding.
            s.repeat(
                &Message::Heartbeat,
                crate::args::duration("--for", *duration)?,
            )?;
            crate::outln!("{} telemetry frames written to {}", s.frames, out.display())?;
            if s.frames == 0 {
                bail!("no telemetry of this session arrived in {duration} s: nothing was recorded");
            }
            print_status(&s)?;
        }
        DriveAction::Goal {
            goal,
            map,
            robot,
            footprint_radius,
            margin,
            max_speed,
            max_accel,
            max_yaw_rate,
            replan_tolerance,
            control,
            set_pose,
            out,
        } => {
            let g = GoalFlags {
                goal,
                map,
                robot,
                footprint_radius: *footprint_radius,
                margin: *margin,
                max_speed: *max_speed,
                max_accel: *max_accel,
                max_yaw_rate: *max_yaw_rate,
                replan_tolerance: *replan_tolerance,
                control,
                set_pose: set_pose.as_ref(),
            };
            s.record(out.as_deref())?;
            drive_goal(&mut s, &g)?;
        }
        DriveAction::Obstacle { .. } => unreachable!("handled before the session"),
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

/// `r`, with the robot's status printed first when the robot refused ([`RobotRefused`]).
fn refused<T>(s: &Session, r: Result<T>) -> Result<T> {
    if let Err(e) = &r
        && e.downcast_ref::<RobotRefused>().is_some()
    {
        print_status(s)?;
    }
    r
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
    let d = s.distance_to(start)?;
    if c.set_pose {
        return Ok(());
    }
    let t = s.latest.context("no telemetry")?;
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
    let file = file.as_ref().map(|(n, l)| (n.as_str(), l));
    let label = format!("plan {}", path.display());
    if let Some(line) = omnikin_host::body_limits::check_upload(&plan, &label, file, &info.limits)?
    {
        crate::outln!("{line}")?;
    }
    let p0 = plan.samples[0].pose;
    check_plan_start(s, [p0.x, p0.y], start)?;
    if info.plan_capacity == 0 {
        crate::outln!(
            "the robot takes no plans (plan capacity 0): streaming the plan's {:.2} s of world twists as velocity commands",
            plan.duration()
        )?;
        let r = s.stream_plan(&plan, set_pose);
        let r = refused(s, r)?;
        let last = plan.samples[plan.samples.len() - 1].pose;
        let e = r.end_pose;
        crate::outln!(
            "plan streamed: {}end pose ({:.4}, {:.4}, {:.4}), plan end ({:.4}, {:.4}, {:.4})",
            r.deviation.map_or(String::new(), |(max_dev, max_path_dev)| format!(
                "max |pose - plan pose| {max_dev:.4} m (lag included), max distance to the path {max_path_dev:.4} m while streaming; "
            )),
            e[0],
            e[1],
            e[2],
            last.x,
            last.y,
            last.heading
        )?;
        return print_status(s);
    }
    let pts = plan_points(&plan, info.plan_capacity as usize);
    let end = pts[pts.len() - 1].pose;
    let id = (epoch_seq() & 0xffff) as u16;
    let up = s.upload_plan(id, pts, set_pose)?;
    crate::outln!(
        "uploaded plan {id}: {} points ({} samples in the file) in {} chunks, {:.2} s",
        up.points,
        plan.samples.len(),
        up.chunks,
        up.secs
    )?;
    let f = s.follow_plan();
    let f = refused(s, f)?;
    let e = f.end_pose;
    crate::outln!(
        "plan done: max |pose - reference| {:.4} m while following; end pose ({:.4}, {:.4}, {:.4}), plan end ({:.4}, {:.4}, {:.4})",
        f.max_deviation,
        e[0],
        e[1],
        e[2],
        end[0],
        end[1],
        end[2]
    )?;
    print_status(s)?;
    Ok(())
}

/// `drive goal`'s flags.
struct GoalFlags<'a> {
    goal: &'a crate::args::List,
    map: &'a Path,
    robot: &'a str,
    footprint_radius: Option<f64>,
    margin: f64,
    max_speed: f64,
    max_accel: Option<f64>,
    max_yaw_rate: f64,
    replan_tolerance: f64,
    control: &'a str,
    set_pose: Option<&'a crate::args::List>,
}

/// `drive goal`: the flags read and checked, the obstacle socket bound, then the goal run of
/// [`omnikin_host::goal_run`].
fn drive_goal(s: &mut Session, g: &GoalFlags<'_>) -> Result<()> {
    use omnikin_host::goal_run::{GoalNumbers, GoalSpec, ObstacleListener};
    use omnikin_plan::map::Map;
    use omnikin_plan::planner::{InitialSteer, OnLimit, PlanOptions, Timing};
    let (goal, heading) = crate::plan::goal::pose(g.goal, "goal")?;
    omnikin_host::goal_run::check_goal_numbers(&GoalNumbers {
        margin: g.margin,
        replan_tolerance: g.replan_tolerance,
        max_speed: g.max_speed,
        max_accel: g.max_accel,
        max_yaw_rate: g.max_yaw_rate,
        footprint_radius: g.footprint_radius,
    })?;
    let d = crate::kinematics::resolve_robot(g.robot)?;
    let model = omnikin_plan::RobotModel::from_description(&d)?;
    let map = Map::load(g.map)?;
    let (f, source) = omnikin_plan::map::footprint::checked_footprint(
        &d,
        g.footprint_radius,
        "--footprint-radius",
    )?;
    let limits = crate::plan::setup::motion_limits(
        &d,
        g.max_speed,
        g.max_accel,
        omnikin_plan::planner::MotionLimits::default().max_jerk,
        g.max_yaw_rate,
        None,
    )?;
    map.check_point(goal, f + g.margin, "the goal")?;
    let mut spec = GoalSpec {
        map,
        goal,
        heading,
        clearance: f + g.margin,
        robot: model,
        options: PlanOptions {
            timing: Timing::TimeOptimal { limits },
            on_limit: OnLimit::Retime,
            rate: 20.0,
            initial_steer: InitialSteer::Aligned,
        },
        replan_tolerance: g.replan_tolerance,
    };
    let (listener, obstacles) = ObstacleListener::bind(g.control, "--control")?;
    if let Some(p) = g.set_pose {
        let (xy, h) = crate::plan::goal::pose(p, "--set-pose")?;
        s.hello()?;
        s.set_pose([xy[0], xy[1], h.unwrap_or(0.0)])?;
    }
    crate::outln!(
        "drive goal: footprint {f} m ({}) + margin {} m; obstacles: omnikin drive obstacle --control {} --circle X,Y,R",
        source.describe(),
        g.margin,
        listener.local_addr()
    )?;
    // Each line as the run goes (a closed stdout is noticed at the end).
    let r = s.drive_goal(&mut spec, &obstacles, &mut |line| {
        let _ = crate::outln!("{line}");
    });
    let r = refused(s, r)?;
    let e = r.end_pose;
    crate::outln!(
        "goal reached: {} re-plan(s) spliced without stopping, {} with a stop; max |pose - reference| {:.4} m while following; end pose ({:.4}, {:.4}, {:.4}), {:.4} m from the goal",
        r.splices.len(),
        r.stops,
        r.max_deviation,
        e[0],
        e[1],
        e[2],
        (f64::from(e[0]) - goal[0]).hypot(f64::from(e[1]) - goal[1])
    )?;
    print_status(s)
}

/// What the robot says at the end of an action ([`Session::status_lines`]).
fn print_status(s: &Session) -> Result<()> {
    for line in s.status_lines() {
        crate::outln!("{line}")?;
    }
    Ok(())
}
