//! The host side of omnikin's link — what a program on a PC needs to talk to a robot, whatever
//! its front end (the `omnikin` binary today; Python and the ROS 2 node next).
//!
//! * [`link_io`]: the transports (UDP, a serial port), the key file, the operating system's
//!   entropy for the handshake's nonces, and the framing loop shared by `omnikin robot` and
//!   `omnikin drive`; the protocol itself is the core's `omnikin::link`.
//! * [`names`]: how a front end names the link's options in errors (the CLI's flags,
//!   Python's keywords).
//! * [`body_limits`]: the limits a plan is held to before it is driven or simulated — the robot
//!   file's, lowered (never raised) by a flag, and the stricter of those and what the robot
//!   says it will do.
//!
//! * [`operator`]: the operator's session with a robot — the handshake (and the diagnosis of a
//!   failed one), session frames at the heartbeat rate, the newest telemetry, estimate and true
//!   pose, the telemetry logs ([`telemetry_log`] CSV, MCAP), camera fixes forwarded as they fall
//!   due ([`fixes`]); [`console_operator`] is the same session driven from the console's loop;
//!   [`wire_plan`] a plan as the link carries it.
//!
//! * [`session_status`]: the session's status in lines for a person (what `drive` prints
//!   after every action).
//! * [`actions`]: what an operator asks in its session, each confirmed by telemetry — stop,
//!   e-stop, clear, a velocity for a while, listening; [`plan_run`]: a plan driven (the start
//!   checked, uploaded, followed to its end, or streamed as velocities to a robot that takes no
//!   plans); [`plan_upload`]: the upload's steps as one state machine, which the console's
//!   relay runs too; [`goal_run`]: a goal reached across a map, re-planned on the way (an
//!   obstacle added, a drift) by splices the robot takes without stopping.
//!
//! * [`console`]: the console without its web server — the hub where the pages and the robot
//!   meet, the relay that owns the robot link, the Foxglove stream.
//!
//! * [`sim_robot`]: a runtime on its simulated board (the kinematic plant with disturbances,
//!   the sphere's dynamics, the balancing ballbot), built from [`sim_robot::SimOptions`];
//!   [`robot_serve`]: the robot's side of the link that serves it (`omnikin robot --sim`,
//!   Python's `omnikin.SimRobot`).
//!
//! * `ros2_node` (feature `ros2`): the robot as a native ROS 2 node over Zenoh, an operator of
//!   the link like `drive` (`omnikin robot --sim --ros2`, `omnikin ros2 --connect`).

pub mod actions;
pub mod body_limits;
pub mod console;
pub mod console_operator;
pub mod fixes;
pub mod goal_run;
pub mod link_io;
pub mod names;
pub mod operator;
pub mod plan_run;
pub mod plan_upload;
pub mod robot_serve;
#[cfg(feature = "ros2")]
pub mod ros2_node;
pub mod session_status;
pub mod sim_robot;
pub mod telemetry_log;
pub mod wire_plan;

#[cfg(test)]
mod test_support;
