//! # omnikin in a ROS 2 system
//!
//! What a ROS 2 user needs from a robot file, without a ROS installation:
//!
//! | module | in | out |
//! |---|---|---|
//! | [`msg`] | omnikin's state and commands | the standard ROS 2 messages (`Twist`, `Odometry`, `TFMessage`, `JointState`, `Imu`, `DiagnosticArray`) with their type names, RIHS01 hashes and CDR encoding |
//! | [`rmw`] | a node's name, namespace, domain and topics | rmw_zenoh's key expressions, liveliness tokens (`@ros2_lv/…`), QoS text and sample attachment |
//! | [`node`] | the link's telemetry and estimate; `cmd_vel` | `odom`, `tf`, `joint_states`, `imu`, `diagnostics`; the robot-frame velocity command |
//! | [`urdf`] | a validated robot description | a URDF: `base_link`, one continuous joint per wheel (`wheel_i`) and per steering axis (`steer_i`), the sphere's shell and platform, the ballbot's ball and body |
//!
//! Frames and names follow `conventions.md` ("ROS 2"): REP-103 axes and units, REP-105's
//! `base_link` as the robot frame, joints `wheel_1 … wheel_N` and `steer_1 … steer_N` in the
//! robot file's order, so the `joint_states` a node publishes drive this URDF in
//! `robot_state_publisher` and RViz.

pub mod msg;
pub mod node;
pub mod rmw;
pub mod urdf;
