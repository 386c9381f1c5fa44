//! What a simulated robot is made of: the plant, its disturbances, the runtime's rates and
//! limits — `omnikin robot --sim`'s flags and Python's `omnikin.SimRobot` keywords, as one
//! plain struct — and the runtime configuration and disturbance profile they give.
//!
//! Errors name the CLI's flags (`--max-accel`, …); Python's keywords are the same words with
//! underscores.

use anyhow::{Context, Result};
use omnikin::description::RobotDescription;
use omnikin::runtime::Config;
pub use omnikin_sim::plant_step::PlantKind;
use omnikin_sim::profile::Profile;
use omnikin_sim::reproduce::{hardware_profile, spin_slip_profile};

/// Plan buffer capacity of the simulated robot, points (a firmware picks its own).
pub const SIM_PLAN_CAPACITY: usize = 4096;

/// Control rate when none is given (the rate runtime), Hz.
pub const DEFAULT_RATE_HZ: f64 = 100.0;

/// Largest commanded speed of the rate runtime when none is given, m/s.
pub const DEFAULT_MAX_SPEED: f64 = 2.0;

/// Largest commanded yaw rate of the rate runtime when none is given, rad/s.
pub const DEFAULT_MAX_YAW_RATE: f64 = 10.0;

/// A simulated robot's settings (module doc). `Default` is `omnikin robot --sim`'s defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct SimOptions {
    /// The plant.
    pub plant: PlantKind,
    /// Disturbances of the kinematic plant: `ideal` (`None`), `hardware`, `spin-slip` or a
    /// profile TOML file.
    pub disturbances: Option<String>,
    /// Control rate, Hz [`DEFAULT_RATE_HZ`]; the ballbot's balance runtime: the robot file's
    /// `control_rate_hz`).
    pub rate: Option<f64>,
    /// Watchdog: no valid command or heartbeat for this long (s, robot time) → controlled stop.
    pub watchdog: f64,
    /// Largest linear acceleration, m/s² (default the robot file's body limit; larger refused).
    pub max_accel: Option<f64>,
    /// Largest yaw acceleration, rad/s² (default the robot file's; larger refused).
    pub max_yaw_accel: Option<f64>,
    /// Largest linear jerk, m/s³ (default the robot file's, else unlimited).
    pub max_jerk: Option<f64>,
    /// Commands faster than this are refused as malformed, m/s [`DEFAULT_MAX_SPEED`].
    pub max_speed: Option<f64>,
    /// Commands with a larger yaw rate are refused as malformed, rad/s
    /// [`DEFAULT_MAX_YAW_RATE`].
    pub max_yaw_rate: Option<f64>,
    /// Heading from the simulated gyro instead of the wheels.
    pub gyro_heading: bool,
    /// Seed of the disturbance draws (and the ballbot's sensor noise).
    pub seed: u64,
    /// An obstacle in the robot's way from `AT` for `FOR` seconds of robot time (kinematic
    /// plant): the robot stops dead and its wheels are blocked.
    pub obstacle: Option<(f64, f64)>,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            plant: PlantKind::Kinematic,
            disturbances: None,
            rate: None,
            watchdog: 0.5,
            max_accel: None,
            max_yaw_accel: None,
            max_jerk: None,
            max_speed: None,
            max_yaw_rate: None,
            gyro_heading: false,
            seed: 1,
            obstacle: None,
        }
    }
}

/// The disturbance profile `name` names (`None` or `ideal`, `hardware`, `spin-slip`, a file).
///
/// # Errors
/// A profile file that cannot be read or is not valid, named as `--disturbances`.
pub fn profile(name: Option<&str>) -> Result<Profile> {
    Ok(match name {
        None | Some("ideal") => Profile::default(),
        Some("hardware") => hardware_profile(),
        Some("spin-slip") => spin_slip_profile(),
        Some(path) => Profile::load(std::path::Path::new(path)).with_context(|| {
            format!("--disturbances {path} (ideal, hardware, spin-slip or a TOML file)")
        })?,
    })
}

/// The rate runtime's configuration from the options and the robot file's limits: one set of
/// body limits (the file's, what `plan` plans within), lowered — never raised — by an option.
///
/// # Errors
/// An option above the robot's limit, or a configuration the runtime refuses, named by flag.
pub fn config(a: &SimOptions, desc: &RobotDescription) -> Result<Config<f64>> {
    let rate = a.rate.unwrap_or(DEFAULT_RATE_HZ);
    let mut c = Config::new(rate);
    c.rate_limits.wheel = desc.limits.max_wheel_rate;
    c.rate_limits.steer = desc.limits.max_steer_rate;
    c.wheel_accel = desc.limits.max_wheel_accel;
    c.steer_accel = desc.limits.max_steer_accel;
    let body = desc.body_limits();
    let flag = crate::body_limits::flag;
    c.slew.accel = flag(
        "--max-accel",
        a.max_accel,
        body.max_accel,
        body.max_accel_source,
        "max_accel",
        "m/s²",
        desc,
    )?;
    c.slew.yaw_accel = flag(
        "--max-yaw-accel",
        a.max_yaw_accel,
        body.max_yaw_accel,
        body.max_yaw_accel_source,
        "max_yaw_accel",
        "rad/s²",
        desc,
    )?;
    c.slew.jerk = match body.max_jerk {
        Some(j) => Some(flag(
            "--max-jerk",
            a.max_jerk,
            j,
            omnikin::description::LimitSource::File,
            "max_jerk",
            "m/s³",
            desc,
        )?),
        None => a.max_jerk,
    };
    c.max_speed = a.max_speed.unwrap_or(DEFAULT_MAX_SPEED);
    c.max_yaw_rate = a.max_yaw_rate.unwrap_or(DEFAULT_MAX_YAW_RATE);
    c.watchdog = a.watchdog;
    c.heading_from_gyro = a.gyro_heading;
    // Slip and collision thresholds: the robot file's [events] (defaults where absent), the
    // same ones `omnikin odometry` uses offline.
    let ev = desc.events.thresholds();
    c.events.slip_yaw_rate = ev.slip_yaw_rate;
    c.events.slip_residual = ev.slip_residual;
    c.events.collision_decel = ev.collision_decel;
    c.validate().map_err(|e| {
        let flag = match e.field {
            "rate_hz" => format!("rate {rate}"),
            "max_wheel_rate" | "max_steer_rate" | "max_wheel_accel" | "max_steer_accel" => {
                format!("{} limits.{}", desc.name, e.field)
            }
            f => f.replace('_', "-"),
        };
        anyhow::anyhow!("--{flag}: {}", e.rule)
    })?;
    Ok(c)
}
