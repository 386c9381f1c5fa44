//! `omnikin`: kinematics of omnidirectional wheeled robots from the terminal.
//!
//! Thin glue over the `omnikin` library: argument parsing and validation here, physics there.
//! The command-line contract (command names, flags, JSON keys) is fixed by the project's
//! conventions because scripts depend on it.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod args;
// The output rules and the MCAP logs live in omnikin-io (shared with the other front ends);
// `crate::output`, `crate::mcap_log`, `crate::errln!` and `crate::outln!` keep their paths.
use omnikin_io::{errln, mcap_log, outln, output};
// The figures (crates/omnikin-plot) under the paths the commands name them by.
use omnikin_plot as plot;
use omnikin_plot::figures;
// The host side of the link (crates/omnikin-host) under the paths the commands name it by.
use omnikin_host::{body_limits, link_io};
mod console;
mod convert;
mod data_dir;
mod drive;
mod evaluate_truth;
mod fit_to_paper;
mod identify;
mod kinematics;
mod odometry;
mod plan;
mod robot;
mod robot_args;
mod ros2;
mod ros2_args;
mod shard;
mod shell;
mod sim;
mod sim_args;
mod sim_ballbot;
mod sim_closed_loop;
mod sim_report;
mod teleop;
mod urdf;

use args::{List, Triple, finite_f64};
// The steer-step check lives in omnikin-plan (the Python package applies it too).
use omnikin_plan::steer_steps;

/// Kinematics of omnidirectional wheeled robots: a sphere rolled by an internal omni-wheel
/// platform (sphere-omni), a ball-balancing robot (ballbot), a base on three off-centred
/// steerable wheels (caster3), N omni or mecanum wheels (omni: kiwi, x-drive, mecanum) and N
/// centred swerve modules (swerve: swerve4).
///
/// ROBOT is a preset name (sphere-omni, ballbot, caster3, kiwi, x-drive, mecanum, swerve4) or
/// the path of a TOML robot description (see robots/*.toml). Units are SI: m, s, rad, rad/s, N·m. Frames: x forward,
/// y left, z up, angles counter-clockwise.
#[derive(Parser, Debug)]
#[command(name = "omnikin", version, about, long_about)]
struct Cli {
    /// Replace existing output files (and files in an existing, non-empty output directory).
    /// Inputs are never overwritten, with or without --force.
    #[arg(long, global = true)]
    force: bool,
    /// What every MCAP log of this command holds (--mcap, --record-dir): `foxglove`
    /// (Foxglove's schemas in protobuf: /pose, /tf, /wheels, /link, /events, /plan) or `ros2`
    /// (ROS 2 messages in CDR, the MCAP ROS 2 profile: /odom, /tf, /joint_states, /diagnostics,
    /// /truth, /reference; read by `ros2 bag play`, RViz and Foxglove's ROS views).
    #[arg(long, global = true, value_enum, default_value_t = McapProfile::Foxglove)]
    mcap_profile: McapProfile,
    #[command(subcommand)]
    command: Command,
}

/// `--mcap-profile`.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum McapProfile {
    /// Foxglove's schemas, protobuf.
    Foxglove,
    /// ROS 2 messages, CDR.
    Ros2,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Wheel (and steer) rates that produce a body motion (inverse kinematics).
    ///
    /// sphere-omni: shell-centre velocity and platform yaw rate (Sphere paper, eqs. 5.6-5.7).
    /// ballbot: ball-centre velocity and body yaw rate (Ballbot paper). caster3: roll and steer
    /// rates for the given steer angles (Caster paper, eq. 2). omni: one rate per wheel. swerve:
    /// wheel rates (≥ 0 unless the file optimises steering) and steer angles per module.
    Inverse(InverseArgs),
    /// Body motion produced by wheel (and steer) rates (forward kinematics).
    ///
    /// caster3 needs all six motor rates, omni bases with more than three wheels and swerve
    /// drives are over-determined too: the motion is the least-squares fit, and the slip
    /// residual (m/s) says how inconsistent the rates are.
    Forward(ForwardArgs),
    /// Torque maps: the ballbot's model torques (Tx, Ty, Tz) <-> wheel torques (T1, T2, T3)
    /// (Ballbot paper, corrected per errata E2-E3), or an omni/swerve base's body wrench
    /// (Fx, Fy, Mz) <-> wheel torques (T1, …, TN).
    Torques(TorquesArgs),
    /// Validate a robot description and print its derived geometry, conditioning and limits.
    Check(CheckArgs),
    /// Plan a trajectory (the Sphere paper's square or circle, or a path through waypoints) within
    /// the robot file's motor limits and write its wheel commands as CSV or JSON.
    Plan(plan::PlanArgs),
    /// Monte-Carlo simulation of a plan under motor and slip disturbances, with the paper's
    /// metrics and figure (Sphere paper §6, Caster paper §4).
    Simulate(sim_args::SimulateArgs),
    /// The same metrics and figure for real tracked runs (CSV t,x,y[,heading]) against a plan;
    /// or pose estimates against ground truth (--truth): ATE and RPE, per run and overall.
    Evaluate(sim_args::EvaluateArgs),
    /// Re-run a paper's whole experiment design in simulation and tabulate our figures next
    /// to the paper's (sphere-2019: the Sphere paper's squares and circles at four speeds).
    Reproduce(sim_args::ReproduceArgs),
    /// Combine the shard directories of `simulate … --shard K/N` or `reproduce … --shard K/N`
    /// (all N, from any machines) into exactly what one run writes, bit for bit.
    Merge(shard::MergeArgs),
    /// Wheel odometry over an encoder log (t,q1..qN[,s1..sN][,gyro_z][,yaw]), optionally
    /// with the IMU heading and fused with camera fixes; writes t,x,y,heading.
    Odometry(odometry::OdometryArgs),
    /// Fit the robot file's wheel geometry (radius scales, positions, drive angles; caster
    /// mount radius and eccentricity) and the gyro's bias and scale to recorded runs, with 1σ;
    /// writes the robot file with the fitted values (plans: `plan sysid`).
    Identify(identify::IdentifyArgs),
    /// The robot file as a URDF (base_link, joints wheel_i and steer_i with omnikin's wheel
    /// rate signs) for robot_state_publisher and RViz; stdout, or --out FILE.
    Urdf(urdf::UrdfArgs),
    /// Run the robot side of the link: the fixed-rate control loop (limits, watchdog, e-stop)
    /// over UDP or a serial port, on a simulated plant with `--sim`.
    Robot(robot_args::RobotArgs),
    /// Drive a robot over the link from the PC: hello, velocity, plan upload, stop, e-stop,
    /// clear, telemetry and keyboard teleop.
    Drive(drive::DriveArgs),
    /// A local web page that shows the robot (map, plan, pose, wheel rates, link, events)
    /// and drives it (dead-man teleop by keyboard or gamepad, e-stop, plan upload), relayed
    /// over the same link as `drive`. Prints the URL to open, with its per-start token.
    Console(console::ConsoleArgs),
    /// The robot on a link as a native ROS 2 node over Zenoh (rmw_zenoh's keys, no ROS
    /// installation): cmd_vel in; odom, tf, joint_states, imu, diagnostics out (docs/ros2.md;
    /// needs the `ros2` cargo feature).
    Ros2(ros2::Ros2Args),
    /// Convert an MCAP log (--mcap of simulate, odometry, robot, drive) to one CSV file per
    /// channel, or CSV logs back to MCAP.
    Convert(convert::ConvertArgs),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    Completions(shell::CompletionsArgs),
    /// Print the man page, or write one page per command with `--out DIR`.
    Man(shell::ManArgs),
}

/// `omnikin inverse`.
#[derive(clap::Args, Debug)]
pub struct InverseArgs {
    /// Robot: preset name (sphere-omni, ballbot, caster3, kiwi, x-drive, mecanum, swerve4) or
    /// path to a TOML description.
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
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = args::angle_rad)]
    pub heading: f64,
    /// Spin of the shell (sphere-omni) or ball (ballbot) about the vertical, rad/s.
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub shell_spin: Option<f64>,
    /// Steerable kinds only: the current steer angles G1,…,GN, rad (default 0). caster3: the
    /// steer state the rates are for; swerve: the angles a stopped module keeps (and the
    /// reference of steering optimisation).
    #[arg(long, allow_hyphen_values = true, value_name = "G1,…,GN")]
    pub steer: Option<List>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `omnikin forward`.
#[derive(clap::Args, Debug)]
pub struct ForwardArgs {
    /// Robot: preset name (sphere-omni, ballbot, caster3, kiwi, x-drive, mecanum, swerve4) or
    /// path to a TOML description.
    pub robot: String,
    /// Wheel rates W1,…,WN, rad/s, one per wheel in the robot file's order (caster3: roll
    /// rates).
    #[arg(
        long,
        required = true,
        allow_hyphen_values = true,
        value_name = "W1,…,WN"
    )]
    pub wheel_rates: List,
    /// Steerable kinds only: steer angles G1,…,GN, rad (default 0).
    #[arg(long, allow_hyphen_values = true, value_name = "G1,…,GN")]
    pub steer: Option<List>,
    /// caster3 only (required there): steer rates S1,S2,S3, rad/s.
    #[arg(long, allow_hyphen_values = true, value_name = "S1,S2,S3")]
    pub steer_rates: Option<List>,
    /// Heading, rad: report the twist in the world frame (default: robot frame).
    #[arg(long, allow_hyphen_values = true, value_parser = args::angle_rad)]
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
#[command(group(clap::ArgGroup::new("input").required(true).args(["model", "wrench", "wheels"])))]
pub struct TorquesArgs {
    /// Robot with a torque map: ballbot (model torques) or an omni/swerve drive (body wrench).
    pub robot: String,
    /// ballbot: model torques TX,TY,TZ, N·m -> wheel torques.
    #[arg(long, allow_hyphen_values = true, value_name = "TX,TY,TZ")]
    pub model: Option<Triple>,
    /// omni, swerve: body wrench FX,FY,MZ (N, N, N·m, robot frame) -> minimum-norm wheel
    /// torques.
    #[arg(long, allow_hyphen_values = true, value_name = "FX,FY,MZ")]
    pub wrench: Option<Triple>,
    /// Wheel torques T1,…,TN, N·m -> model torques (ballbot) or body wrench (omni, swerve).
    #[arg(long, allow_hyphen_values = true, value_name = "T1,…,TN")]
    pub wheels: Option<List>,
    /// ballbot: body yaw, rad: model torques are in the frame rotated by it (0: body frame).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = args::angle_rad)]
    pub yaw: f64,
    /// swerve only: steer angles G1,…,GN, rad (default 0).
    #[arg(long, allow_hyphen_values = true, value_name = "G1,…,GN")]
    pub steer: Option<List>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `omnikin check`.
#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// Robot: preset name (sphere-omni, ballbot, caster3, kiwi, x-drive, mecanum, swerve4) or
    /// path to a TOML description.
    pub robot: String,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `ROBOT` or `--disturbances` may name a preset or a file: only a file is an input.
fn named_file(s: &str) -> Option<&std::path::Path> {
    let p = std::path::Path::new(s);
    p.is_file().then_some(p)
}

/// Every file the command reads, registered for the output rules (an input is never
/// overwritten), and every output, checked against those rules before any work is done.
fn io_rules(c: &Command) -> anyhow::Result<()> {
    use std::path::Path;
    let mut inputs: Vec<(&str, &Path)> = Vec::new();
    let mut files: Vec<(&str, &Path)> = Vec::new();
    let mut dirs: Vec<(&str, &Path)> = Vec::new();
    fn robot(r: &str) -> Option<(&'static str, &std::path::Path)> {
        named_file(r).map(|p| ("ROBOT", p))
    }
    match c {
        Command::Inverse(a) => inputs.extend(robot(&a.robot)),
        Command::Forward(a) => inputs.extend(robot(&a.robot)),
        Command::Torques(a) => inputs.extend(robot(&a.robot)),
        Command::Check(a) => inputs.extend(robot(&a.robot)),
        Command::Urdf(a) => {
            inputs.extend(robot(&a.robot));
            files.extend(a.out.as_deref().map(|p| ("--out", p)));
        }
        Command::Plan(a) => {
            let (common, file) = match &a.kind {
                plan::PlanKind::Square(s) => (&s.common, None),
                plan::PlanKind::Circle(c) => (&c.common, None),
                plan::PlanKind::Waypoints(w) => (&w.common, Some(w.file.as_path())),
                plan::PlanKind::Goal(g) => (&g.common, Some(g.map.as_path())),
                plan::PlanKind::Sysid(s) => {
                    inputs.extend(robot(&s.robot));
                    dirs.push(("--out", &s.out));
                    return check_io(inputs, files, dirs);
                }
            };
            if let plan::PlanKind::Waypoints(w) = &a.kind {
                inputs.extend(w.map.as_deref().map(|p| ("--map", p)));
            }
            inputs.extend(robot(&common.robot));
            inputs.extend(file.map(|f| ("FILE", f)));
            files.extend(common.out.as_deref().map(|p| ("--out", p)));
            files.extend(common.plot.as_deref().map(|p| ("--plot", p)));
        }
        Command::Simulate(a) => {
            inputs.extend(robot(&a.robot));
            inputs.push(("PLAN", &a.plan));
            inputs.extend(a.disturbances.as_deref().map(|p| ("--disturbances", p)));
            inputs.extend(a.sensors.as_deref().map(|p| ("--sensors", p)));
            dirs.push(("--out", &a.out));
            files.extend(a.mcap.as_deref().map(|p| ("--mcap", p)));
        }
        Command::Evaluate(a) => {
            inputs.extend(a.plan.as_deref().map(|p| ("--plan", p)));
            inputs.extend(a.truth.as_deref().map(|p| ("--truth", p)));
            inputs.extend(a.tracks.iter().map(|t| ("TRACK", t.as_path())));
            dirs.extend(a.out.as_deref().map(|p| ("--out", p)));
        }
        Command::Reproduce(a) => dirs.extend(a.out.as_deref().map(|p| ("--out", p))),
        Command::Merge(a) => {
            for f in shard::input_files(a) {
                output::input("SHARD_DIR", &f);
            }
            dirs.push(("--out", &a.out));
        }
        Command::Man(a) => dirs.extend(a.out.as_deref().map(|p| ("--out", p))),
        Command::Completions(_) => {}
        Command::Odometry(a) => {
            inputs.extend(robot(&a.robot));
            inputs.push(("LOG", &a.log));
            inputs.extend(a.fixes.as_deref().map(|p| ("--fixes", p)));
            inputs.extend(a.truth.as_deref().map(|p| ("--truth", p)));
            files.push(("--out", &a.out));
            files.extend(a.plot.as_deref().map(|p| ("--plot", p)));
            files.extend(a.mcap.as_deref().map(|p| ("--mcap", p)));
        }
        Command::Identify(a) => {
            inputs.extend(robot(&a.robot));
            for (flag, list) in [
                ("--encoders", &a.encoders),
                ("--fixes", &a.fixes),
                ("--tracked", &a.tracked),
                ("--imu", &a.imu),
            ] {
                inputs.extend(list.iter().map(|p| (flag, p.as_path())));
            }
            files.push(("--out", &a.out));
        }
        Command::Robot(a) => {
            inputs.extend(robot(&a.robot));
            inputs.extend(
                a.disturbances
                    .as_deref()
                    .and_then(named_file)
                    .map(|p| ("--disturbances", p)),
            );
            inputs.extend(a.key.as_deref().map(|p| ("--key", p)));
            files.extend(a.log.as_deref().map(|p| ("--log", p)));
            files.extend(a.mcap.as_deref().map(|p| ("--mcap", p)));
        }
        Command::Drive(a) => {
            inputs.extend(a.key.as_deref().map(|p| ("--key", p)));
            // `--fixes -` is stdin, not a file.
            inputs.extend(
                a.fixes
                    .as_deref()
                    .filter(|p| *p != Path::new("-"))
                    .map(|p| ("--fixes", p)),
            );
            files.extend(a.mcap.as_deref().map(|p| ("--mcap", p)));
            match &a.action {
                drive::DriveAction::Velocity { out, .. } => {
                    files.extend(out.as_deref().map(|p| ("--out", p)));
                }
                drive::DriveAction::Plan { plan, out, .. } => {
                    inputs.push(("PLAN", plan));
                    files.extend(out.as_deref().map(|p| ("--out", p)));
                }
                drive::DriveAction::Telemetry { out, .. } => files.push(("--out", out)),
                drive::DriveAction::Goal { map, out, .. } => {
                    inputs.push(("--map", map));
                    files.extend(out.as_deref().map(|p| ("--out", p)));
                }
                _ => {}
            }
        }
        Command::Console(a) => inputs.extend(a.key.as_deref().map(|p| ("--key", p))),
        Command::Ros2(a) => inputs.extend(a.key.as_deref().map(|p| ("--key", p))),
        Command::Convert(a) => {
            inputs.push(("IN", &a.input));
            files.extend(a.mcap.as_deref().map(|p| ("--mcap", p)));
            if let Some(d) = a.csv.as_deref().filter(|d| output::is_file_like(d)) {
                output::check_dir("--csv", d)?;
            }
        }
    }
    check_io(inputs, files, dirs)
}

/// Applies the output rules to the inputs, files and directories [`io_rules`] collected.
fn check_io(
    inputs: Vec<(&str, &std::path::Path)>,
    files: Vec<(&str, &std::path::Path)>,
    dirs: Vec<(&str, &std::path::Path)>,
) -> anyhow::Result<()> {
    for (flag, p) in inputs {
        output::input(flag, p);
    }
    for (flag, p) in &files {
        output::check_file(flag, p)?;
    }
    // Output directories are checked by `output::create_dir` once the inputs are read (so a
    // bad input is reported first) and before any simulation runs.
    for (flag, p) in &dirs {
        if output::is_file_like(p) {
            output::check_dir(flag, p)?;
        }
    }
    output::check_distinct(&files)?;
    // A figure format is known before anything runs (`--plot out/sq.jpg` fails at once), after
    // the rules that protect files (an input named as the figure is reported as such).
    for (flag, p) in &files {
        if *flag == "--plot" {
            plot::FigureFormat::of(flag, p)?;
        }
    }
    Ok(())
}

fn run(command: Command) -> anyhow::Result<()> {
    io_rules(&command)?;
    match command {
        Command::Inverse(a) => kinematics::inverse(&a),
        Command::Forward(a) => kinematics::forward(&a),
        Command::Torques(a) => kinematics::torques(&a),
        Command::Check(a) => kinematics::check(&a),
        Command::Plan(a) => plan::run(&a),
        Command::Simulate(a) => sim::simulate(&a),
        Command::Evaluate(a) => sim::evaluate_tracks(&a),
        Command::Reproduce(a) => sim::reproduce(&a),
        Command::Merge(a) => shard::merge(&a),
        Command::Odometry(a) => odometry::run(&a),
        Command::Identify(a) => identify::run(&a),
        Command::Urdf(a) => urdf::run(&a),
        Command::Robot(a) => robot::run(&a),
        Command::Drive(a) => drive::run(&a),
        Command::Console(a) => console::run(&a),
        Command::Ros2(a) => ros2::connect(&a),
        Command::Convert(a) => convert::run(&a),
        Command::Completions(a) => shell::completions(&a),
        Command::Man(a) => shell::man(&a),
    }?;
    output::flush_stdout()
}

/// Exit status when stdout is a closed pipe: 128 + SIGPIPE, as if killed by it.
const EXIT_BROKEN_PIPE: u8 = 141;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            // Help and version go to stdout, usage errors to stderr; neither may panic.
            let code = match e.print() {
                Err(w) if !e.use_stderr() && w.kind() == std::io::ErrorKind::BrokenPipe => {
                    EXIT_BROKEN_PIPE
                }
                Err(w) if !e.use_stderr() => {
                    errln!("error: cannot write to stdout: {w}");
                    1
                }
                _ => e.exit_code().clamp(0, 255) as u8,
            };
            return ExitCode::from(code);
        }
    };
    output::set_force(cli.force);
    mcap_log::set_profile(match cli.mcap_profile {
        McapProfile::Foxglove => mcap_log::ros2::LogProfile::Foxglove,
        McapProfile::Ros2 => mcap_log::ros2::LogProfile::Ros2,
    });
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(_) if output::stdout_broken() => ExitCode::from(EXIT_BROKEN_PIPE),
        Err(e) => match output::interrupted() {
            // A signal can also surface as another error (a wait cut short with EINTR).
            Some(sig) => {
                if e.downcast_ref::<output::Interrupted>().is_some() {
                    // The stop the operator asked for, carried out (logs flushed, summary
                    // printed): not an error. The status stays 128 + signal, as for any
                    // program stopped by a signal, so scripts still see that it was stopped.
                    errln!("note: {e:#}");
                } else {
                    errln!("error: {sig} ({e:#})");
                }
                ExitCode::from(sig.exit_status())
            }
            None => {
                errln!("error: {e:#}");
                ExitCode::FAILURE
            }
        },
    }
}
