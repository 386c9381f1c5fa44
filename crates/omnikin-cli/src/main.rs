//! `omnikin`: kinematics of three-wheeled omnidirectional robots from the terminal.
//!
//! Thin glue over the `omnikin` library: argument parsing and validation here, physics there.
//! The command-line contract (command names, flags, JSON keys) is fixed by the project's
//! conventions because scripts depend on it.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod args;
mod drive;
mod figures;
mod kinematics;
mod link_io;
mod odometry;
mod plan;
mod plot;
mod robot;
mod sim;
mod teleop;

use args::{Triple, finite_f64};

/// Kinematics of three-wheeled omnidirectional robots: a sphere rolled by an internal
/// omni-wheel platform (sphere-omni), a ball-balancing robot (ballbot) and a base on three
/// off-centred steerable wheels (caster3).
///
/// ROBOT is a preset name (sphere-omni, ballbot, caster3) or the path of a TOML robot
/// description (see robots/*.toml). Units are SI: m, s, rad, rad/s, N·m. Frames: x forward,
/// y left, z up, angles counter-clockwise.
#[derive(Parser, Debug)]
#[command(name = "omnikin", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Wheel (and steer) rates that produce a body motion (inverse kinematics).
    ///
    /// sphere-omni: shell-centre velocity and platform yaw rate (paper 000, eqs. 5.6-5.7).
    /// ballbot: ball-centre velocity and body yaw rate (paper 001). caster3: roll and steer
    /// rates for the given steer angles (paper 003, eq. 2).
    Inverse(InverseArgs),
    /// Body motion produced by wheel (and steer) rates (forward kinematics).
    ///
    /// caster3 needs all six motor rates and fits the motion by least squares; the slip
    /// residual (m/s) says how inconsistent the rates are.
    Forward(ForwardArgs),
    /// Ballbot torque maps: model torques (Tx, Ty, Tz) <-> wheel torques (T1, T2, T3)
    /// (paper 001, corrected per errata E2-E3).
    Torques(TorquesArgs),
    /// Validate a robot description and print its derived geometry, conditioning and limits.
    Check(CheckArgs),
    /// Plan a trajectory (paper 000's square or circle, or a path through waypoints) within
    /// the robot file's motor limits and write its wheel commands as CSV or JSON.
    Plan(plan::PlanArgs),
    /// Monte-Carlo simulation of a plan under motor and slip disturbances, with the paper's
    /// metrics and figure (paper 000 §6, paper 003 §4).
    Simulate(sim::SimulateArgs),
    /// The same metrics and figure for real tracked runs (CSV t,x,y[,heading]) against a plan.
    Evaluate(sim::EvaluateArgs),
    /// Re-run a paper's whole experiment design in simulation and tabulate our figures next
    /// to the paper's (sphere-2019: paper 000's squares and circles at four speeds).
    Reproduce(sim::ReproduceArgs),
    /// Wheel odometry over an encoder log (t,q1,q2,q3[,s1,s2,s3][,gyro_z][,yaw]), optionally
    /// with the IMU heading and fused with camera fixes; writes t,x,y,heading.
    Odometry(odometry::OdometryArgs),
    /// Run the robot side of the link: the fixed-rate control loop (limits, watchdog, e-stop)
    /// over UDP or a serial port, on a simulated plant with `--sim`.
    Robot(robot::RobotArgs),
    /// Drive a robot over the link from the PC: hello, velocity, plan upload, stop, e-stop,
    /// clear, telemetry and keyboard teleop.
    Drive(drive::DriveArgs),
}

/// `omnikin inverse`.
#[derive(clap::Args, Debug)]
pub struct InverseArgs {
    /// Robot: preset name (sphere-omni, ballbot, caster3) or path to a TOML description.
    pub robot: String,
    /// Velocity along x, m/s (robot frame; world frame with --world).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub vx: f64,
    /// Velocity along y, m/s (robot frame; world frame with --world).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub vy: f64,
    /// Yaw rate of the robot frame, rad/s (counter-clockwise positive).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub yaw_rate: f64,
    /// Interpret --vx/--vy in the world frame (uses --heading).
    #[arg(long)]
    pub world: bool,
    /// Heading (yaw of the robot frame in the world frame), rad.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub heading: f64,
    /// Spin of the shell (sphere-omni) or ball (ballbot) about the vertical, rad/s.
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub shell_spin: Option<f64>,
    /// caster3 only: steer angles G1,G2,G3 relative to the body, rad (default 0,0,0).
    #[arg(long, allow_hyphen_values = true, value_name = "G1,G2,G3")]
    pub steer: Option<Triple>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `omnikin forward`.
#[derive(clap::Args, Debug)]
pub struct ForwardArgs {
    /// Robot: preset name (sphere-omni, ballbot, caster3) or path to a TOML description.
    pub robot: String,
    /// Wheel rates W1,W2,W3, rad/s (caster3: roll rates).
    #[arg(
        long,
        required = true,
        allow_hyphen_values = true,
        value_name = "W1,W2,W3"
    )]
    pub wheel_rates: Triple,
    /// caster3 only: steer angles G1,G2,G3, rad (default 0,0,0).
    #[arg(long, allow_hyphen_values = true, value_name = "G1,G2,G3")]
    pub steer: Option<Triple>,
    /// caster3 only (required there): steer rates S1,S2,S3, rad/s.
    #[arg(long, allow_hyphen_values = true, value_name = "S1,S2,S3")]
    pub steer_rates: Option<Triple>,
    /// Heading, rad: report the twist in the world frame (default: robot frame).
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub heading: Option<f64>,
    /// Assumed spin of the shell (sphere-omni) or ball (ballbot) about the vertical, rad/s
    /// (default 0: not observable from the wheels).
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub shell_spin: Option<f64>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `omnikin torques`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["model", "wheels"])))]
pub struct TorquesArgs {
    /// Robot: ballbot preset or a ballbot description file.
    pub robot: String,
    /// Model torques TX,TY,TZ, N·m -> wheel torques.
    #[arg(long, allow_hyphen_values = true, value_name = "TX,TY,TZ")]
    pub model: Option<Triple>,
    /// Wheel torques T1,T2,T3, N·m -> model torques.
    #[arg(long, allow_hyphen_values = true, value_name = "T1,T2,T3")]
    pub wheels: Option<Triple>,
    /// Body yaw, rad: model torques are in the frame rotated by it (0: body frame).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub yaw: f64,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `omnikin check`.
#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// Robot: preset name (sphere-omni, ballbot, caster3) or path to a TOML description.
    pub robot: String,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Inverse(a) => kinematics::inverse(&a),
        Command::Forward(a) => kinematics::forward(&a),
        Command::Torques(a) => kinematics::torques(&a),
        Command::Check(a) => kinematics::check(&a),
        Command::Plan(a) => plan::run(&a),
        Command::Simulate(a) => sim::simulate(&a),
        Command::Evaluate(a) => sim::evaluate_tracks(&a),
        Command::Reproduce(a) => sim::reproduce(&a),
        Command::Odometry(a) => odometry::run(&a),
        Command::Robot(a) => robot::run(&a),
        Command::Drive(a) => drive::run(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
