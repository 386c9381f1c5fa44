//! `omnikin robot --sim … --ros2` and `omnikin ros2 --connect ROBOT`: the robot as a native
//! ROS 2 node over Zenoh (`omnikin_host::ros2_node`, cargo feature `ros2`). The simulated
//! robot is served on a loopback link as `robot --sim` serves it, and the node is its operator,
//! exactly as it is of a real robot with `ros2 --connect`.

use std::path::PathBuf;

use anyhow::Result;

use crate::args::finite_f64;

pub use crate::ros2_args::NodeArgs;

/// `omnikin ros2`.
#[derive(clap::Args, Debug)]
pub struct Ros2Args {
    /// The robot's link address: HOST:PORT (UDP) or serial:PATH[@BAUD].
    #[arg(long, value_name = "ROBOT_ADDR")]
    pub connect: String,
    /// Shared key file (the robot's): the session is authenticated.
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// Heartbeat (command repeat) rate, Hz.
    #[arg(long, default_value_t = 20.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub heartbeat: f64,
    /// No telemetry for this long (s): the session is lost and the command fails.
    #[arg(long, default_value_t = 2.0, allow_hyphen_values = true, value_parser = finite_f64)]
    pub timeout: f64,
    #[command(flatten)]
    /// The node.
    pub node: NodeArgs,
}

#[cfg(feature = "ros2")]
mod imp {
    use std::sync::atomic::AtomicBool;

    use anyhow::Result;
    use omnikin_host::names::OptionNames;
    use omnikin_host::operator::Session;
    use omnikin_host::robot_serve::RobotServer;
    use omnikin_host::ros2_node::{self, Ros2Node, Ros2Options};

    use super::{NodeArgs, Ros2Args};
    use crate::robot_args::RobotArgs;

    fn options(n: &NodeArgs) -> Ros2Options {
        let mut o = Ros2Options::new();
        o.connect.clone_from(&n.zenoh);
        if !n.zenoh_listen.is_empty() {
            o.listen.clone_from(&n.zenoh_listen);
        }
        o.multicast = n.zenoh_multicast;
        o.domain = n.domain;
        o.namespace.clone_from(&n.namespace);
        o.node_name.clone_from(&n.node_name);
        o.stamped = n.stamped;
        o.rate = n.ros2_rate;
        o.cmd_timeout = n.cmd_timeout;
        o
    }

    /// The node; `clock`: it publishes `/clock` (the simulated robot's time, which runs at
    /// `--time-scale` × the wall clock).
    fn open_node(n: &NodeArgs, clock: bool) -> Result<Ros2Node> {
        if n.cmd_timeout.is_nan() || n.cmd_timeout <= 0.0 {
            anyhow::bail!("--cmd-timeout must be > 0 s (got {})", n.cmd_timeout);
        }
        let mut o = options(n);
        o.clock = clock;
        let node = Ros2Node::open(&o)?;
        let (cmd, odom) = node.keys();
        let i = node.info();
        omnikin_io::errln!(
            "ros2: node {}{}{} on domain {} (zenoh {}, connecting to {}): cmd_vel on {cmd}, odom on {odom}",
            i.namespace,
            if i.namespace.ends_with('/') { "" } else { "/" },
            i.name,
            i.domain,
            i.zid,
            n.zenoh.join(", ")
        );
        Ok(node)
    }

    /// `robot --sim … --ros2`.
    pub fn robot(a: &RobotArgs) -> Result<()> {
        let desc = crate::kinematics::resolve_robot(&a.robot)?;
        let mut serve = a.serve_options();
        // The node publishes at the control rate unless --ros2-rate says otherwise.
        let control = a.rate.unwrap_or(100.0);
        serve.telemetry_rate = a.node.ros2_rate.unwrap_or(control).max(a.telemetry_rate);
        let key = serve.key.clone();
        let server = RobotServer::new(&desc, &a.sim_options(), serve)?;
        crate::output::catch_signals()?;
        let served = ros2_node::serve_simulated(
            server,
            key.as_deref(),
            || open_node(&a.node, true),
            &AtomicBool::new(false),
        )?;
        crate::outln!("{}", served.summary)?;
        match served.interrupted {
            Some(sig) => Err(sig.into()),
            None => Ok(()),
        }
    }

    /// `ros2 --connect`.
    pub fn connect(a: &Ros2Args) -> Result<()> {
        let mut s = Session::open(
            &a.connect,
            a.key.as_deref(),
            a.heartbeat,
            a.timeout,
            None,
            OptionNames::CLI,
        )?;
        let mut node = open_node(&a.node, false)?;
        crate::output::catch_signals()?;
        // The loop ends at the signal's flag; a receive the signal cut short (EINTR) ends it
        // too, as the same stop, not as a link error.
        let r = ros2_node::run(&mut s, &mut node, &|| {
            crate::output::interrupted().is_some()
        });
        crate::outln!("{}", serde_json::json!({ "ros2": node.counters }))?;
        match crate::output::interrupted() {
            // The stop asked for, carried out (robot stopped, session left, calls answered):
            // `main` says so in a note and exits with 128 + the signal, as `robot --sim` does.
            Some(sig) => Err(sig.into()),
            None => r.map(|_| ()),
        }
    }
}

#[cfg(not(feature = "ros2"))]
mod imp {
    use anyhow::{Result, bail};

    use super::Ros2Args;
    use crate::robot_args::RobotArgs;

    const MISSING: &str = "this omnikin was built without the ROS 2 node: build it with `cargo build -p omnikin-cli --features ros2` (or `cargo install … --features ros2`)";

    pub fn robot(_: &RobotArgs) -> Result<()> {
        bail!("--ros2: {MISSING}")
    }

    pub fn connect(_: &Ros2Args) -> Result<()> {
        bail!("ros2: {MISSING}")
    }
}

/// `robot --sim … --ros2`: the simulated robot and its node until `--max-time` or a signal;
/// the robot's JSON summary (with the node's counters under `ros2`) on stdout.
pub fn robot(a: &crate::robot_args::RobotArgs) -> Result<()> {
    imp::robot(a)
}

/// `ros2 --connect ROBOT_ADDR`: the node for a robot on the link, until a signal or the
/// session is lost; the node's counters (`{"ros2": {…}}`) on stdout.
pub fn connect(a: &Ros2Args) -> Result<()> {
    imp::connect(a)
}
