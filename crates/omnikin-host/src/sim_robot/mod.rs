//! The simulated robot behind `omnikin robot --sim` and Python's `omnikin.SimRobot`: a
//! runtime on its simulated board.
//!
//! - **Rate** ([`SimRobot::Rate`]): the rate runtime ([`Runtime`]) on the kinematic plant (with
//!   `--disturbances`) or, for `sphere-omni --plant dynamic`, on the shell + platform dynamics
//!   ([`SilPlant`]). Every kind.
//! - **Balance** ([`SimRobot::Balance`]): `ballbot --plant dynamic`, the balance runtime
//!   ([`BalanceRuntime`]: the core's LQR balance controller on the AHRS and the wheel odometry,
//!   wheel torques through the HAL's torque interface) on the 3D ballbot model with seeded
//!   sensor noise ([`BallbotSil`]). It falls if it is not balanced.
//!
//! Both take the operator link's commands through [`Operated`](omnikin::runtime::Operated) and report through the link's
//! [`TelemetrySource`](omnikin::link::TelemetrySource); the serve loop
//! ([`crate::robot_serve`]) does not know which one it runs. [`SimOptions`] says what to build.

pub mod options;

pub use options::{PlantKind, SimOptions};

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin::link::{
    Estimate, LinkCounters, Message, RobotInfo, RobotLink, Telemetry, robot_info, serve,
};
use omnikin::runtime::{BalanceRuntime, BalanceRuntimeConfig, BalanceStatus, Runtime, Status};
use omnikin::{Pose2, Robot};
use omnikin_sim::dynamics::ballbot::sil::BallbotSil;
use omnikin_sim::dynamics::ballbot::{BallbotDynamics, BallbotPlant, capability};
use omnikin_sim::sil::SilPlant;
use serde_json::{Value, json};

use omnikin_io::errln;
use omnikin_io::mcap_log::{self, McapLog};

use options::SIM_PLAN_CAPACITY;

/// A runtime on its simulated board (module doc).
// One per process: the statuses stay inline rather than boxed.
#[allow(clippy::large_enum_variant)]
pub enum SimRobot {
    /// The rate runtime on the kinematic or the sphere's dynamic plant.
    Rate {
        /// The runtime.
        rt: Box<Runtime<f64, SIM_PLAN_CAPACITY>>,
        /// The board.
        plant: Box<SilPlant>,
        /// The robot (wheel count, steering).
        robot: Robot<f64>,
        /// The last cycle's status.
        status: Option<Status<f64>>,
        /// The sphere's largest platform tilt so far, rad.
        max_tilt: f64,
    },
    /// The balance runtime on the 3D ballbot.
    Balance {
        /// The runtime.
        rt: Box<BalanceRuntime<f64>>,
        /// The board.
        board: Box<BallbotSil>,
        /// The last cycle's status.
        status: Option<BalanceStatus<f64>>,
        /// Tilt figures so far.
        tilt: TiltRecord,
    },
}

/// The balancing robot's tilt over the run (true values from the model, the estimate from
/// the runtime's AHRS).
#[derive(Clone, Copy, Debug, Default)]
pub struct TiltRecord {
    /// Largest true tilt, rad.
    pub max: f64,
    /// Largest true tilt while balancing: the motors on (not e-stopped, no fall latched), rad.
    pub max_balancing: f64,
    /// Largest estimated tilt, rad.
    pub max_estimated: f64,
    /// Robot time of the first cycle the controller reported a fall, s.
    pub fall_time: Option<f64>,
    /// Cycles in which the torque limit scaled the request down.
    pub saturated_cycles: u64,
}

impl SimRobot {
    /// The simulated robot the options ask for: the balance runtime for `ballbot --plant
    /// dynamic`, the rate runtime otherwise.
    ///
    /// # Errors
    /// Bad options for the runtime or the plant, named by their flag.
    pub fn new(a: &SimOptions, desc: &RobotDescription) -> Result<Self> {
        let robot: Robot<f64> = desc.build()?;
        let dynamic = a.plant == PlantKind::Dynamic;
        if dynamic && a.disturbances.is_some() {
            bail!("--plant dynamic takes no --disturbances (the dynamic plant is deterministic)");
        }
        if dynamic && a.obstacle.is_some() {
            bail!("--obstacle needs the kinematic plant (--plant kinematic)");
        }
        if dynamic && desc.robot_kind().balances() {
            return Self::balance(a, desc);
        }
        let cfg = options::config(a, desc)?;
        let rt = Box::new(
            Runtime::new(robot, cfg, Pose2::default()).map_err(|e| anyhow::anyhow!("{e}"))?,
        );
        let plant = if dynamic {
            let params = omnikin_sim::dynamics::sphere::SphereDynamics::from_description(desc)
                .with_context(|| format!("--plant dynamic: robot {}", desc.name))?;
            if let Some(note) = omnikin_sim::dynamics::sphere::floor_override_note(desc, &params) {
                errln!("note: robot {}: {note}", desc.name);
            }
            SilPlant::dynamic(robot, params, Pose2::default())
                .with_context(|| format!("--plant dynamic: robot {}", desc.name))?
        } else {
            let prof = options::profile(a.disturbances.as_deref())?;
            // A profile file that does not fit the robot (the built-in ones are for every kind).
            if let Some(file) = a.disturbances.as_deref()
                && !["ideal", "hardware", "spin-slip"].contains(&file)
            {
                for w in prof.unused_sections(&robot) {
                    errln!("warning: {file}: {w}");
                }
            }
            let mut p = SilPlant::new(robot, prof, a.seed, Pose2::default());
            if let Some((at, dur)) = a.obstacle {
                p.set_obstacle(at, dur);
            }
            p
        };

        Ok(SimRobot::Rate {
            rt,
            plant: Box::new(plant),
            robot,
            status: None,
            max_tilt: 0.0,
        })
    }

    /// `ballbot --plant dynamic`: the balance runtime at the robot file's `[dynamics]`
    /// (control rate `control_rate_hz` unless `--rate` is given; acceleration the robot's body
    /// limit, at most the lean limit's, or `--max-accel` if lower).
    fn balance(a: &SimOptions, desc: &RobotDescription) -> Result<Self> {
        if a.gyro_heading {
            bail!(
                "--gyro-heading: the balance runtime (ballbot --plant dynamic) always takes its attitude and heading from the IMU"
            );
        }
        if a.max_jerk.is_some() {
            bail!(
                "--max-jerk: the balance runtime (ballbot --plant dynamic) slews its velocity command at the lean limit's acceleration; it takes no jerk limit"
            );
        }
        let mut c = desc
            .balance_config::<f64>()
            .context("--plant dynamic: the robot file has no ballbot geometry")?;
        if let Some(r) = a.rate {
            c.rate_hz = r;
        }
        let (lean_accel, max_tilt_deg, lean_margin) = desc
            .lean_acceleration_limit()
            .context("--plant dynamic: the robot file has no ballbot geometry")?;
        // The robot's body limit (the lean limit, or lower from the wheel limits or the
        // file), lowered by --max-accel; a flag above it is refused.
        let body = desc.body_limits();
        let accel = crate::body_limits::flag(
            "--max-accel",
            a.max_accel,
            body.max_accel.min(lean_accel),
            body.max_accel_source,
            "max_accel",
            "m/s²",
            desc,
        )?;
        let mut cfg = BalanceRuntimeConfig::new(c, accel);
        // The library's limits (1 m/s, 1 rad/s) unless given; either way checked against what
        // the robot's model holds before it starts (issue 31).
        if let Some(v) = a.max_speed {
            cfg.max_speed = v;
        }
        if let Some(w) = a.max_yaw_rate {
            cfg.max_yaw_rate = w;
        }
        cfg.watchdog = a.watchdog;
        // The robot file's [events] (only the collision test applies to this runtime).
        let ev = desc.events.thresholds();
        cfg.events.slip_yaw_rate = ev.slip_yaw_rate;
        cfg.events.slip_residual = ev.slip_residual;
        cfg.events.collision_decel = ev.collision_decel;
        // The runtime's own rules first (positive, finite), a ceiling no ballbot reaches (its
        // simulated check is not to be trusted for absurd values), then what the model holds.
        for (flag, v, unit) in [
            ("--max-yaw-rate", cfg.max_yaw_rate, "rad/s"),
            ("--max-speed", cfg.max_speed, "m/s"),
        ] {
            if v > capability::SEARCH_CEILING {
                bail!(
                    "{flag} {v:e}: robot {}: beyond any balancing ballbot (at most {} {unit} is checked against its model; a unit error?)",
                    desc.name,
                    capability::SEARCH_CEILING
                );
            }
        }
        let rt = BalanceRuntime::new(cfg, Pose2::default()).map_err(|e| {
            anyhow::anyhow!(
                "--plant dynamic: robot {}: balance controller: {e}",
                desc.name
            )
        })?;
        capability::check_limits(&cfg, max_tilt_deg.to_radians(), lean_margin).map_err(|e| {
            let flag = match e.limit {
                capability::Limit::YawRate => "--max-yaw-rate",
                capability::Limit::Speed => "--max-speed",
            };
            anyhow::anyhow!("{flag} {}: robot {}: {e}", e.value, desc.name)
        })?;
        let plant = BallbotPlant::new(BallbotDynamics::from_config(&c))
            .map_err(|e| anyhow::anyhow!("--plant dynamic: robot {}: {e}", desc.name))?;
        let s0 = plant.upright(0.0);
        Ok(SimRobot::Balance {
            rt: Box::new(rt),
            board: Box::new(BallbotSil::new(plant, s0, a.seed)),
            status: None,
            tilt: TiltRecord::default(),
        })
    }

    /// Control rate, Hz.
    pub fn rate_hz(&self) -> f64 {
        match self {
            SimRobot::Rate { rt, .. } => rt.config().rate_hz,
            SimRobot::Balance { rt, .. } => 1.0 / rt.controller().period(),
        }
    }

    /// What the plant is, for the start-up line.
    pub fn plant_name(&self, disturbances: Option<&str>) -> String {
        match self {
            SimRobot::Rate { plant, .. } if plant.is_dynamic() => {
                "dynamic plant (shell + platform)".into()
            }
            SimRobot::Rate { .. } => format!("disturbances {}", disturbances.unwrap_or("ideal")),
            SimRobot::Balance { rt, .. } => format!(
                "dynamic plant (3D ballbot), balance runtime: LQR on the torque interface, commands slewed at {:.3} m/s²",
                rt_max_accel(rt)
            ),
        }
    }

    /// The link's HelloAck information.
    pub fn info(&self, authenticated: bool) -> RobotInfo {
        match self {
            SimRobot::Rate { rt, .. } => robot_info(&**rt, authenticated),
            SimRobot::Balance { rt, .. } => robot_info(&**rt, authenticated),
        }
    }

    /// Hands message `seq` of the active session to the runtime at `now_us`.
    pub fn serve(&mut self, link: &mut RobotLink, seq: u64, msg: &Message, now_us: u64) {
        match self {
            SimRobot::Rate { rt, .. } => {
                serve(&mut **rt, link, seq, msg, now_us);
            }
            SimRobot::Balance { rt, .. } => {
                serve(&mut **rt, link, seq, msg, now_us);
            }
        }
    }

    /// Simulated time, µs.
    pub fn time_us(&self) -> u64 {
        match self {
            SimRobot::Rate { plant, .. } => plant.time_us(),
            SimRobot::Balance { board, .. } => board.time_us(),
        }
    }

    /// One control cycle on the board (does not advance time).
    pub fn cycle(&mut self) {
        match self {
            SimRobot::Rate {
                rt, plant, status, ..
            } => *status = Some(plant.run_cycle(rt)),
            SimRobot::Balance {
                rt,
                board,
                status,
                tilt,
            } => {
                let s = board.run_cycle(rt);
                tilt.max_estimated = tilt.max_estimated.max(s.tilt);
                if s.saturated {
                    tilt.saturated_cycles += 1;
                }
                if s.fallen && tilt.fall_time.is_none() {
                    tilt.fall_time = Some(s.time_us as f64 * 1e-6);
                    errln!(
                        "robot: FALLEN at t = {:.3} s (tilt past the controller's fall threshold): motors off; `drive clear` resets the latch",
                        s.time_us as f64 * 1e-6
                    );
                }
                *status = Some(s);
            }
        }
    }

    /// Advances the plant by `dt` seconds.
    ///
    /// # Errors
    /// The kinematic plant's errors (a kinematics singularity).
    pub fn advance(&mut self, dt: f64) -> Result<()> {
        match self {
            SimRobot::Rate {
                plant, max_tilt, ..
            } => {
                plant.advance(dt)?;
                if let Some(d) = plant.dynamics() {
                    *max_tilt = max_tilt.max(d.state().tilt());
                }
            }
            SimRobot::Balance {
                board,
                tilt,
                status,
                ..
            } => {
                board.advance(dt);
                tilt.max = tilt.max.max(board.tilt());
                if status.is_some_and(|s| !s.estop && !s.fallen) {
                    tilt.max_balancing = tilt.max_balancing.max(board.tilt());
                }
            }
        }
        Ok(())
    }

    /// The last cycle's telemetry (`None` before the first cycle).
    pub fn telemetry(&self, link: &RobotLink) -> Option<Telemetry> {
        match self {
            SimRobot::Rate { status, .. } => status.as_ref().map(|s| link.telemetry(s)),
            SimRobot::Balance { status, .. } => status.as_ref().map(|s| link.telemetry(s)),
        }
    }

    /// The last cycle's estimate message (the rate runtime's fusion; `None` for the balance
    /// runtime, which has no fusion, and before the first cycle).
    pub fn estimate(&self) -> Option<Estimate> {
        match self {
            SimRobot::Rate { status, rt, .. } => status.as_ref().map(|s| {
                let f = rt.fusion();
                Estimate::new(s, f.gyro_bias().0, f.wheel_scale().0)
            }),
            SimRobot::Balance { .. } => None,
        }
    }

    /// The true pose (world; m, m, rad): the robot's, or the ball's position with the body's
    /// yaw.
    pub fn true_pose(&self) -> Pose2<f64> {
        match self {
            SimRobot::Rate { plant, .. } => plant.true_pose(),
            SimRobot::Balance { board, .. } => {
                let (_, _, yaw) = board.state().orientation.euler_angles();
                let p = board.state().position;
                Pose2::new(p[0], p[1], yaw)
            }
        }
    }

    /// The last cycle into the `--mcap` log (nothing before the first cycle): the rate
    /// runtime's status, or the balance runtime's as its telemetry (zero wheel-rate commands:
    /// it commands torques), with the true pose on `/truth`.
    pub fn mcap_cycle(&self, m: &mut McapLog, c: &LinkCounters) -> Result<()> {
        let truth = self.true_pose();
        match self {
            SimRobot::Rate {
                status: Some(s),
                robot,
                ..
            } => mcap_log::runtime_cycle(m, s, truth, c, robot.steerable()),
            SimRobot::Balance {
                status: Some(s), ..
            } => {
                let mut sample = mcap_log::telemetry_sample(&Telemetry::from_balance(s, c));
                sample.truth = Some(truth);
                m.sample(&sample)
            }
            _ => Ok(()),
        }
    }

    /// The `--log` header: one row per control cycle ([`crate::robot_serve`]).
    pub fn log_header(&self) -> String {
        match self {
            SimRobot::Rate { robot, .. } => rate_log_header(robot.wheels(), robot.steerable()),
            SimRobot::Balance { .. } => "t,x,y,heading,true_x,true_y,true_heading,cmd_vx,cmd_vy,cmd_yaw_rate,tau1,tau2,tau3,tilt_deg,true_tilt_deg,mode,faults,last_command_t,rejected,rx_ok,rx_dropped,collision_events".into(),
        }
    }

    /// The last cycle's `--log` row (`None` before the first cycle).
    pub fn log_row(&self, c: &LinkCounters) -> Option<String> {
        let tp = self.true_pose();
        let head = |t: u64, p: Pose2<f64>, cmd: [f64; 3]| {
            format!(
                "{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},",
                t as f64 * 1e-6,
                p.x,
                p.y,
                p.heading,
                tp.x,
                tp.y,
                tp.heading,
                cmd[0],
                cmd[1],
                cmd[2]
            )
        };
        match self {
            SimRobot::Rate { robot, status, .. } => {
                let s = status.as_ref()?;
                let n = robot.wheels();
                let mut row = head(
                    s.time_us,
                    s.pose,
                    [s.command.vx, s.command.vy, s.command.yaw_rate],
                );
                for r in &s.motors.wheel[..n] {
                    row += &format!("{r:.6},");
                }
                if robot.steerable() {
                    for r in &s.motors.steer[..n] {
                        row += &format!("{r:.6},");
                    }
                }
                row += &format!(
                    "{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{},{},{},{:.6},{:.6},{:.6},{:.3e},{:.3e},{:.3e},{},{},{},{},{},{}",
                    s.mode,
                    s.faults,
                    s.plan_time,
                    s.reference.x,
                    s.reference.y,
                    s.reference.heading,
                    s.last_command_us as f64 * 1e-6,
                    s.rejected,
                    c.ok,
                    c.dropped(),
                    s.odometry.x,
                    s.odometry.y,
                    s.odometry.heading,
                    s.covariance[0],
                    s.covariance[1],
                    s.covariance[2],
                    s.fixes.accepted,
                    s.fixes.rejected,
                    s.fixes.too_late,
                    s.fixes.recoveries,
                    s.events.slips,
                    s.events.collisions,
                );
                Some(row)
            }
            SimRobot::Balance { status, board, .. } => {
                let s = status.as_ref()?;
                let (sn, cs) = s.pose.heading.sin_cos();
                let cmd = [
                    cs * s.command[0] + sn * s.command[1],
                    -sn * s.command[0] + cs * s.command[1],
                    s.command_yaw_rate,
                ];
                let mut row = head(s.time_us, s.pose, cmd);
                for t in s.torques {
                    row += &format!("{t:.6},");
                }
                row += &format!(
                    "{:.4},{:.4},{},{},{:.6},{},{},{},{}",
                    s.tilt.to_degrees(),
                    board.tilt().to_degrees(),
                    s.mode,
                    s.faults,
                    s.last_command_us as f64 * 1e-6,
                    s.rejected,
                    c.ok,
                    c.dropped(),
                    s.events.collisions,
                );
                Some(row)
            }
        }
    }

    /// The summary's runtime fields: `mode`, `pose`, `true_pose`, `fault_history`,
    /// `rejected`, `plan`, `dynamics` (the sphere's platform tilt; the ballbot's tilt figures,
    /// named as `simulate --plant dynamic`'s `metrics.json`).
    pub fn summary(&self) -> Value {
        let tp = self.true_pose();
        // The fields both runtimes report, from whichever status the last cycle left.
        let common = |mode: Option<&str>,
                      pose: Option<Pose2<f64>>,
                      history: Option<String>,
                      rejected: Option<u32>| {
            json!({
                "mode": mode,
                "pose": pose.map(|p| [p.x, p.y, p.heading]),
                "true_pose": [tp.x, tp.y, tp.heading],
                "fault_history": history,
                "rejected": rejected,
            })
        };
        let (mut out, plan, dynamics) = match self {
            SimRobot::Rate {
                status,
                plant,
                max_tilt,
                ..
            } => {
                let s = status.as_ref();
                (
                    common(
                        s.map(|s| s.mode.name()),
                        s.map(|s| s.pose),
                        s.map(|s| s.fault_history.to_string()),
                        s.map(|s| s.rejected),
                    ),
                    s.map_or(Value::Null, |s| json!({"id": s.plan.id, "received": s.plan.received, "len": s.plan.len, "done": s.plan.done})),
                    plant.dynamics().map_or(Value::Null, |d| json!({
                        "max_tilt_rad": max_tilt, "pull_outs": d.pull_outs(),
                    })),
                )
            }
            SimRobot::Balance {
                status,
                board,
                tilt,
                ..
            } => {
                let s = status.as_ref();
                (
                    common(
                        s.map(|s| s.mode.name()),
                        s.map(|s| s.pose),
                        s.map(|s| s.fault_history.to_string()),
                        s.map(|s| s.rejected),
                    ),
                    Value::Null,
                    json!({
                        "max_tilt_deg": tilt.max.to_degrees(),
                        "max_tilt_balancing_deg": tilt.max_balancing.to_degrees(),
                        "final_tilt_deg": board.tilt().to_degrees(),
                        "max_estimated_tilt_deg": tilt.max_estimated.to_degrees(),
                        "fallen": tilt.fall_time.is_some(),
                        "fall_time_s": tilt.fall_time,
                        "saturated_cycles": tilt.saturated_cycles,
                    }),
                )
            }
        };
        out["plan"] = plan;
        out["dynamics"] = dynamics;
        if let SimRobot::Balance {
            status: Some(s), ..
        } = self
        {
            out["events"] = json!({
                "slips": s.events.slips, "collisions": s.events.collisions,
            });
        }
        if let SimRobot::Rate {
            status: Some(s),
            rt,
            ..
        } = self
        {
            let f = s.fixes;
            out["fixes"] = json!({
                "accepted": f.accepted, "rejected": f.rejected, "too_late": f.too_late,
                "recoveries": f.recoveries,
                "odometry_pose": [s.odometry.x, s.odometry.y, s.odometry.heading],
                "covariance": s.covariance,
                "gyro_bias": rt.fusion().gyro_bias().0,
                "wheel_scale": rt.fusion().wheel_scale().0,
            });
            out["events"] = json!({
                "slips": s.events.slips, "collisions": s.events.collisions,
            });
        }
        out
    }
}

fn rt_max_accel(rt: &BalanceRuntime<f64>) -> f64 {
    rt.config().max_accel
}

/// The rate runtime's `--log` header: one wheel-rate command `w1..wN` per wheel, and for kinds
/// with steering one steer-rate command `sd1..sdN` per module.
fn rate_log_header(wheels: usize, steer: bool) -> String {
    let mut h = String::from("t,x,y,heading,true_x,true_y,true_heading,cmd_vx,cmd_vy,cmd_yaw_rate");
    for i in 1..=wheels {
        h += &format!(",w{i}");
    }
    if steer {
        for i in 1..=wheels {
            h += &format!(",sd{i}");
        }
    }
    h + ",mode,faults,plan_time,ref_x,ref_y,ref_heading,last_command_t,rejected,rx_ok,rx_dropped,odo_x,odo_y,odo_heading,var_x,var_y,var_heading,fix_accepted,fix_rejected,fix_too_late,fix_recoveries,slip_events,collision_events"
}
