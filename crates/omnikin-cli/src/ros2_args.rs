//! The ROS 2 node's flags (`robot --sim … --ros2` and `omnikin ros2`), apart from the command
//! that runs the node so that `robot`'s flags can hold them without importing it.

use crate::args::finite_f64;

/// The node's flags, shared by `robot --ros2` and `ros2`.
#[derive(clap::Args, Debug, Clone)]
pub struct NodeArgs {
    /// Zenoh endpoint to connect to: rmw_zenoh's router (`ros2 run rmw_zenoh_cpp rmw_zenohd`)
    /// or a peer; repeat for more.
    #[arg(
        long = "zenoh",
        value_name = "ENDPOINT",
        default_value = "tcp/127.0.0.1:7447"
    )]
    pub zenoh: Vec<String>,
    /// Zenoh endpoint to listen on, for peers that connect to this node [default:
    /// tcp/127.0.0.1:0].
    #[arg(long, value_name = "ENDPOINT")]
    pub zenoh_listen: Vec<String>,
    /// Also find Zenoh peers by UDP multicast scouting (off: only --zenoh and what the router
    /// tells).
    #[arg(long)]
    pub zenoh_multicast: bool,
    /// ROS domain id (ROS_DOMAIN_ID), 0-232.
    #[arg(long, default_value_t = 0)]
    pub domain: u32,
    /// Namespace of the node, its relative topics (cmd_vel, odom, joint_states, imu) and its
    /// services (estop, clear); tf, diagnostics and clock stay absolute.
    #[arg(long, default_value = "")]
    pub namespace: String,
    /// Node name.
    #[arg(long, default_value = "omnikin")]
    pub node_name: String,
    /// cmd_vel is geometry_msgs/msg/TwistStamped (nav2's enable_stamped_cmd_vel) instead of
    /// Twist.
    #[arg(long)]
    pub stamped: bool,
    /// Largest rate of odom, tf, joint_states and imu, Hz (robot time) [default: every
    /// telemetry frame; `robot --ros2` sends telemetry at the control rate].
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pub ros2_rate: Option<f64>,
    /// cmd_vel silence (s) after which the robot is brought to a controlled stop.
    #[arg(long, default_value_t = 0.5, allow_hyphen_values = true, value_parser = finite_f64)]
    pub cmd_timeout: f64,
}
