//! The host side of omnikin's link — what a program on a PC needs to talk to a robot, whatever
//! its front end (the `omnikin` binary today; Python and the ROS 2 node next).
//!
//! * [`link_io`]: the transports (UDP, a serial port), the key file, the operating system's
//!   entropy for the handshake's nonces, and the framing loop shared by `omnikin robot` and
//!   `omnikin drive`; the protocol itself is the core's `omnikin::link`.
//! * [`body_limits`]: the limits a plan is held to before it is driven or simulated — the robot
//!   file's, lowered (never raised) by a flag, and the stricter of those and what the robot
//!   says it will do.
//!
//! Still in the binary and to come here: the operator session (`drive`), the robot's serve loop
//! and the simulated robot, the console's hub (docs/architecture.md).

pub mod body_limits;
pub mod link_io;
