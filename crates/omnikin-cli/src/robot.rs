//! `omnikin robot --sim`: the simulated robot served over the link
//! (`omnikin_host::robot_serve`), its JSON summary on stdout.

use anyhow::{Result, bail};
use omnikin_host::robot_serve::RobotServer;

use crate::robot_args::RobotArgs;

/// Runs the simulated robot until `--max-time` (or a signal).
pub fn run(a: &RobotArgs) -> Result<()> {
    if !a.sim {
        bail!(
            "--sim is required: on a real robot the runtime runs in firmware (examples/firmware-cortex-m4)"
        );
    }
    if a.ros2 {
        return crate::ros2::robot(a);
    }
    let desc = crate::kinematics::resolve_robot(&a.robot)?;
    let server = RobotServer::new(&desc, &a.sim_options(), a.serve_options())?;
    crate::output::catch_signals()?;
    let served = server.run(None)?;
    crate::outln!("{}", served.summary)?;
    match served.interrupted {
        Some(sig) => Err(sig.into()),
        None => Ok(()),
    }
}
