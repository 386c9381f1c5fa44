//! The flags of `omnikin robot`, and the simulated robot's and the serve loop's options they
//! make (`omnikin_host::sim_robot::SimOptions`, `omnikin_host::robot_serve::ServeOptions`).

use std::path::PathBuf;

use omnikin_host::robot_serve::ServeOptions;
use omnikin_host::sim_robot::SimOptions;

use crate::args::finite_f64;

/// `omnikin robot`.
#[derive(clap::Args, Debug)]
pub struct RobotArgs {
    /// Run the runtime against the simulated plant (software in the loop). Required: on a real
    /// robot the runtime runs in firmware (see examples/firmware-cortex-m4).
    #[arg(long)]
    pub sim: bool,
    /// Robot: preset name (sphere-omni, ballbot, caster3, kiwi, x-drive, mecanum, swerve4) or path to a TOML description. Its
    /// [limits] become the runtime's motor limits.
    #[arg(long)]
    pub robot: String,
    /// Where to serve the link: HOST:PORT (UDP, e.g. 127.0.0.1:7000) or serial:PATH[@BAUD]
    /// [with --ros2: default 127.0.0.1:0, a free loopback port].
    #[arg(long, value_name = "ADDR", required_unless_present = "ros2")]
    pub listen: Option<String>,
    /// Plant disturbances: ideal (default), hardware, spin-slip, or a profile TOML file.
    #[arg(long, value_name = "PROFILE")]
    pub disturbances: Option<String>,
    /// Shared key file (16-64 bytes): only an operator with the same key can open a session;
    /// every frame of it carries an HMAC tag under the session key.
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// Without --key, listen on a UDP address that is not loopback anyway (anyone on that
    /// network can then drive the robot).
    #[arg(long)]
    pub insecure: bool,
    /// Control rate, Hz [default: 100; ballbot --plant dynamic: the robot file's
    /// [dynamics] control_rate_hz, 200 for the preset].
    #[arg(long, allow_hyphen_values = true, value_parser = crate::args::control_rate_hz)]
    pub rate: Option<f64>,
    /// Telemetry rate, Hz (robot time).
    #[arg(long, default_value_t = 20.0, allow_hyphen_values = true, value_parser = crate::args::message_rate_hz)]
    pub telemetry_rate: f64,
    /// Watchdog: no valid command or heartbeat for this long (s, robot time) → controlled stop.
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = finite_f64)]
    pub watchdog: f64,
    /// Largest linear acceleration, m/s² [default: the robot file's body limit, [limits]
    /// max_accel or derived from max_wheel_accel (`omnikin check` prints it); a larger value is
    /// refused].
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub max_accel: Option<f64>,
    /// Largest yaw acceleration, rad/s² [default: the robot file's max_yaw_accel or derived
    /// from max_wheel_accel; a larger value is refused].
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub max_yaw_accel: Option<f64>,
    /// Largest linear jerk, m/s³ [default: the robot file's max_jerk, else unlimited; a value
    /// above the file's is refused].
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub max_jerk: Option<f64>,
    /// Commands faster than this (m/s) are rejected as malformed [default: 2; ballbot --plant
    /// dynamic: 1, and a larger value is refused unless the robot's model holds it].
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub max_speed: Option<f64>,
    /// Commands with a larger yaw rate (rad/s) are rejected as malformed [default: 10; ballbot
    /// --plant dynamic: 1, and a larger value is refused unless the robot's model holds it].
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub max_yaw_rate: Option<f64>,
    /// Heading from the simulated gyro instead of the wheels.
    #[arg(long)]
    pub gyro_heading: bool,
    /// Run the simulation this many times faster than real time (tests use 4-10).
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = crate::args::time_scale)]
    pub time_scale: f64,
    /// Stop after this much robot time (s) and print a JSON summary on stdout.
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub max_time: Option<f64>,
    /// Write one CSV row per control cycle: estimate, true pose, mode, faults, counters.
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Also write the log as MCAP with Foxglove schemas (/pose, /truth, /tf, /reference,
    /// /wheels, /link, /events; docs/seeing-the-robot.md), kept like --log on every exit.
    #[arg(long, value_name = "FILE")]
    pub mcap: Option<PathBuf>,
    /// Seed of the disturbance draws.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// An obstacle in the robot's way, AT:FOR (s, robot time; e.g. 3:0.5): from AT for FOR
    /// seconds the simulated robot stops dead and its wheels are blocked (kinematic plant), a
    /// collision for the runtime's event detector (the robot file's [events]) to report.
    #[arg(long, value_name = "AT:FOR", value_parser = obstacle)]
    pub obstacle: Option<(f64, f64)>,
    /// Plant: `kinematic` (the motors' motion through the forward kinematics, with
    /// --disturbances) or `dynamic` (the robot file's [dynamics], no --disturbances):
    /// sphere-omni's shell + platform dynamics, or the ballbot's 3D model balanced by the
    /// balance runtime (LQR on the torque interface, seeded IMU and encoder noise; plans are
    /// refused, drive it with velocity commands; it falls if e-stopped).
    #[arg(long, value_enum, default_value_t = crate::sim_args::PlantKind::Kinematic)]
    pub plant: crate::sim_args::PlantKind,
    /// Also be a ROS 2 node over Zenoh: cmd_vel in (through the runtime's limits and
    /// watchdog); odom, tf, joint_states, imu, diagnostics out at the control rate
    /// (docs/ros2.md; needs the `ros2` cargo feature).
    #[arg(long)]
    pub ros2: bool,
    /// The ROS 2 node (with --ros2).
    #[command(flatten)]
    pub node: crate::ros2_args::NodeArgs,
}

/// `--obstacle AT:FOR`: 0 ≤ AT ≤ 10⁶ s, 0 < FOR ≤ 10⁶ s.
fn obstacle(s: &str) -> Result<(f64, f64), String> {
    let (at, dur) = s
        .split_once(':')
        .ok_or_else(|| format!("expected AT:FOR in seconds (e.g. 3:0.5), got \"{s}\""))?;
    let at = crate::args::finite_f64(at).map_err(|e| format!("AT {e}"))?;
    let dur = crate::args::finite_f64(dur).map_err(|e| format!("FOR {e}"))?;
    if !(0.0..=1e6).contains(&at) {
        return Err(format!("AT must be within [0, 1e6] s, got {at}"));
    }
    if !(dur > 0.0 && dur <= 1e6) {
        return Err(format!("FOR must be within (0, 1e6] s, got {dur}"));
    }
    Ok((at, dur))
}

impl RobotArgs {
    /// The simulated robot these flags describe.
    pub fn sim_options(&self) -> SimOptions {
        SimOptions {
            plant: self.plant,
            disturbances: self.disturbances.clone(),
            rate: self.rate,
            watchdog: self.watchdog,
            max_accel: self.max_accel,
            max_yaw_accel: self.max_yaw_accel,
            max_jerk: self.max_jerk,
            max_speed: self.max_speed,
            max_yaw_rate: self.max_yaw_rate,
            gyro_heading: self.gyro_heading,
            seed: self.seed,
            obstacle: self.obstacle,
        }
    }

    /// How these flags serve it.
    pub fn serve_options(&self) -> ServeOptions {
        ServeOptions {
            listen: self.listen.clone().unwrap_or_else(|| "127.0.0.1:0".into()),
            key: self.key.clone(),
            insecure: self.insecure,
            telemetry_rate: self.telemetry_rate,
            time_scale: self.time_scale,
            max_time: self.max_time,
            log: self.log.clone(),
            mcap: self.mcap.clone(),
            names: omnikin_host::names::OptionNames::CLI,
        }
    }
}
