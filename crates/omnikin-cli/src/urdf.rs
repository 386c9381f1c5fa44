//! `omnikin urdf ROBOT`: the robot file as a URDF for `robot_state_publisher` and RViz
//! (omnikin_ros2::urdf).

use std::io::Write as _;
use std::path::PathBuf;

use anyhow::Result;
use omnikin_ros2::urdf::Model;

use crate::output;

/// `omnikin urdf`.
#[derive(clap::Args, Debug)]
pub struct UrdfArgs {
    /// Robot: preset name (sphere-omni, ballbot, caster3, kiwi, x-drive, mecanum, swerve4) or
    /// path to a TOML description.
    pub robot: String,
    /// Write the URDF to this file (temp file + rename; an existing file only with --force)
    /// instead of stdout.
    #[arg(long, value_name = "FILE.urdf")]
    pub out: Option<PathBuf>,
}

/// Runs `omnikin urdf`.
pub fn run(a: &UrdfArgs) -> Result<()> {
    let d = crate::kinematics::resolve_robot(&a.robot)?;
    let model = Model::of(&d);
    let xml = model.to_xml(&d.source_name);
    match &a.out {
        Some(path) => {
            output::write_file("--out", path, |f| f.write_all(xml.as_bytes()))?;
            let wheels = model
                .joints
                .iter()
                .filter(|j| j.name.starts_with("wheel_"))
                .count();
            let steer = model
                .joints
                .iter()
                .filter(|j| j.name.starts_with("steer_"))
                .count();
            output::stdout_line(format_args!(
                "urdf: {} ({}): {wheels} wheel joints, {steer} steer joints -> {}",
                d.name,
                d.kind(),
                path.display()
            ))
        }
        None => output::stdout_line(format_args!("{}", xml.trim_end())),
    }
}
