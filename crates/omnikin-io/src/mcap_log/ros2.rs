//! The `ros2` MCAP profile (`--mcap-profile ros2`): the same rows as ROS 2 messages, so
//! `ros2 bag play`, `ros2 bag info`, RViz and Foxglove's ROS 2 views read omnikin's logs.
//!
//! The MCAP ROS 2 profile: header profile `ros2`, schema encoding `ros2msg` (the `.msg` text
//! with its dependencies, [`RosMessage::MSGDEF`]), message encoding `cdr`, and per channel the
//! metadata rosbag2's MCAP storage reads: `offered_qos_profiles` (the QoS rosbag2 records, as
//! YAML: reliable, volatile, keep-last history of the publisher unknown) and `topic_type_hash`
//! (the RIHS01 hash). A [`LogRow`] becomes, in `conventions.md`'s ROS 2 names and REP-105 frames:
//!
//! | channel | type | from |
//! |---|---|---|
//! | `odom` | `nav_msgs/msg/Odometry`, `odom` → `base_link` | the estimate; its twist (robot frame) from the change of the estimate since the previous row; covariance unknown (zeros) |
//! | `tf` | `tf2_msgs/msg/TFMessage` | the same transform `odom` → `base_link` |
//! | `truth`, `reference` | `nav_msgs/msg/Odometry`, child frames `truth`, `reference` | the simulation's true pose, the plan's reference |
//! | `joint_states` | `sensor_msgs/msg/JointState`, `wheel_i`, `steer_i` | encoder angles and their rates; without encoders the commanded rates |
//! | `diagnostics` | `diagnostic_msgs/msg/DiagnosticArray` | mode changes and faults (`/events` of the Foxglove profile): OK, WARN or ERROR |
//! | `plan` | `nav_msgs/msg/Path` in `odom` | the planned path, when a plan is uploaded or simulated ([`plan`]) |
//!
//! Topics are absolute (`/odom`); the Monte-Carlo trials of `simulate` go under a namespace
//! `/trial_NNN` (a ROS name has no `-`). The Foxglove profile's `/link` (the link's counters)
//! has no message here yet and is not written.

use omnikin::Pose2;
use omnikin_ros2::msg::{
    DiagnosticArray, DiagnosticStatus, Header, JointState, KeyValue, Odometry, Path, Pose,
    PoseStamped, PoseWithCovariance, Quaternion, RosMessage, TfMessage, Time, Transform,
    TransformStamped, Twist, TwistWithCovariance, Vector3, to_cdr,
};

use super::LogRow;
use super::foxglove::Level;

/// Which messages an MCAP log holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LogProfile {
    /// Foxglove's schemas (protobuf), the default: `/pose`, `/tf`, `/truth`, `/reference`,
    /// `/wheels`, `/link`, `/events`, `/plan`.
    #[default]
    Foxglove,
    /// ROS 2 messages in CDR (this module's table).
    Ros2,
}

/// The QoS rosbag2 records for a topic it offered (`offered_qos_profiles`): reliable, volatile,
/// history unknown, no deadline, lifespan or lease (ROS 2 Jazzy's YAML form).
pub const OFFERED_QOS: &str = "- history: 3
  depth: 0
  reliability: 1
  durability: 2
  deadline:
    sec: 2147483647
    nsec: 4294967295
  lifespan:
    sec: 2147483647
    nsec: 4294967295
  liveliness: 1
  liveliness_lease_duration:
    sec: 2147483647
    nsec: 4294967295
  avoid_ros_namespace_conventions: false
";

/// One message of the profile: channel (topic), type name, type hash, schema text, CDR bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    /// The topic, e.g. `/odom` or `/trial_002/odom`.
    pub topic: String,
    /// `package/msg/Name`.
    pub type_name: &'static str,
    /// The RIHS01 type hash.
    pub type_hash: &'static str,
    /// The `ros2msg` schema text.
    pub schema: &'static str,
    /// The CDR payload (encapsulation header included).
    pub data: Vec<u8>,
}

fn message<M: RosMessage>(prefix: &str, topic: &str, m: &M) -> Message {
    Message {
        topic: format!("{}/{topic}", ros_namespace(prefix)),
        type_name: M::TYPE_NAME,
        type_hash: M::TYPE_HASH,
        schema: M::MSGDEF,
        data: to_cdr(m),
    }
}

/// The ROS namespace of a channel prefix: `""` stays `""`, `/trial-002` becomes `/trial_002`.
pub fn ros_namespace(prefix: &str) -> String {
    prefix.replace('-', "_")
}

/// Log time `ns` as a ROS time stamp (exact: seconds and nanoseconds of the integer).
pub fn stamp(ns: u64) -> Time {
    Time {
        sec: i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX),
        nanosec: (ns % 1_000_000_000) as u32,
    }
}

fn header(ns: u64, frame: &str) -> Header {
    Header {
        stamp: stamp(ns),
        frame_id: frame.into(),
    }
}

/// An `Odometry` in `odom` of `pose` (world frame) with the robot-frame `twist`.
fn odometry(ns: u64, child: &str, pose: Pose2<f64>, twist: [f64; 3]) -> Odometry {
    Odometry {
        header: header(ns, "odom"),
        child_frame_id: child.into(),
        pose: PoseWithCovariance {
            pose: Pose {
                position: Vector3 {
                    x: pose.x,
                    y: pose.y,
                    z: 0.0,
                },
                orientation: Quaternion::yaw(pose.heading),
            },
            covariance: [0.0; 36],
        },
        twist: TwistWithCovariance {
            twist: Twist {
                linear: Vector3 {
                    x: twist[0],
                    y: twist[1],
                    z: 0.0,
                },
                angular: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: twist[2],
                },
            },
            covariance: [0.0; 36],
        },
    }
}

/// The robot-frame twist `(vx, vy, yaw_rate)` that moves `before` to `now` in `dt` s (the
/// world displacement over `dt` rotated into the frame at the mean heading); zero without a
/// previous pose.
pub fn body_twist(before: Option<Pose2<f64>>, now: Pose2<f64>, dt: f64) -> [f64; 3] {
    match before {
        Some(b) if dt > 0.0 => {
            let (dx, dy) = ((now.x - b.x) / dt, (now.y - b.y) / dt);
            let dh = omnikin::wrap_angle(now.heading - b.heading);
            let (s, c) = (b.heading + 0.5 * dh).sin_cos();
            [c * dx + s * dy, -s * dx + c * dy, dh / dt]
        }
        _ => [0.0; 3],
    }
}

/// The messages of one row under `prefix` at log time `ns`: `odom`, `tf`, then `truth`,
/// `reference`, `joint_states` when the row has them, and one `diagnostics` message holding
/// `events` (the mode changes and faults since the previous row) when there are any. `before`
/// is the previous row's estimate and `dt` the time since it; `measured` the encoder rates
/// (wheels then steering), when known; `name` the process.
#[allow(clippy::too_many_arguments)]
pub fn messages(
    prefix: &str,
    s: &LogRow,
    ns: u64,
    before: Option<Pose2<f64>>,
    dt: f64,
    measured: (Option<Vec<f64>>, Option<Vec<f64>>),
    events: &[(Level, String)],
    name: &str,
) -> Vec<Message> {
    let mut out = vec![
        message(
            prefix,
            "odom",
            &odometry(ns, "base_link", s.pose, body_twist(before, s.pose, dt)),
        ),
        message(
            prefix,
            "tf",
            &TfMessage {
                transforms: vec![TransformStamped {
                    header: header(ns, "odom"),
                    child_frame_id: "base_link".into(),
                    transform: Transform {
                        translation: Vector3 {
                            x: s.pose.x,
                            y: s.pose.y,
                            z: 0.0,
                        },
                        rotation: Quaternion::yaw(s.pose.heading),
                    },
                }],
            },
        ),
    ];
    if let Some(p) = s.truth {
        out.push(message(
            prefix,
            "truth",
            &odometry(ns, "truth", p, [0.0; 3]),
        ));
    }
    if let Some(p) = s.reference {
        out.push(message(
            prefix,
            "reference",
            &odometry(ns, "reference", p, [0.0; 3]),
        ));
    }
    if let Some(j) = joint_states(s, ns, measured) {
        out.push(message(prefix, "joint_states", &j));
    }
    if !events.is_empty() {
        let mode = s.state.map(|(m, _)| m.name()).unwrap_or_default();
        let faults = s.state.map(|(_, f)| f.to_string()).unwrap_or_default();
        let status = events
            .iter()
            .map(|(level, text)| DiagnosticStatus {
                level: match level {
                    Level::Info => 0,
                    Level::Warning => 1,
                    Level::Error => 2,
                },
                name: name.into(),
                message: text.clone(),
                hardware_id: String::new(),
                values: vec![
                    KeyValue {
                        key: "mode".into(),
                        value: mode.into(),
                    },
                    KeyValue {
                        key: "faults".into(),
                        value: faults.clone(),
                    },
                ],
            })
            .collect();
        out.push(message(
            prefix,
            "diagnostics",
            &DiagnosticArray {
                header: header(ns, ""),
                status,
            },
        ));
    }
    out
}

/// The planned path `poses` (world frame) at log time `ns` on `/plan`, in `odom`.
pub fn plan(ns: u64, poses: &[Pose2<f64>]) -> Message {
    let pose = |p: &Pose2<f64>| PoseStamped {
        header: header(ns, "odom"),
        pose: Pose {
            position: Vector3 {
                x: p.x,
                y: p.y,
                z: 0.0,
            },
            orientation: Quaternion::yaw(p.heading),
        },
    };
    message(
        "",
        "plan",
        &Path {
            header: header(ns, "odom"),
            poses: poses.iter().map(pose).collect(),
        },
    )
}

/// The row's joints: `wheel_i` then `steer_i`; positions are the encoder angles, velocities
/// their rates (`measured`) or, without encoders, the commanded rates.
fn joint_states(
    s: &LogRow,
    ns: u64,
    measured: (Option<Vec<f64>>, Option<Vec<f64>>),
) -> Option<JointState> {
    let wheels = s
        .wheel_angles
        .as_ref()
        .or(s.commanded.as_ref())
        .map(Vec::len)?;
    let steers = s
        .steer_angles
        .as_ref()
        .or(s.commanded_steer.as_ref())
        .map_or(0, Vec::len);
    let mut name: Vec<String> = (1..=wheels).map(|i| format!("wheel_{i}")).collect();
    name.extend((1..=steers).map(|i| format!("steer_{i}")));
    let position = match (&s.wheel_angles, &s.steer_angles) {
        (Some(w), Some(st)) if st.len() == steers => w.iter().chain(st).copied().collect(),
        (Some(w), None) if steers == 0 => w.clone(),
        _ => Vec::new(),
    };
    let velocity = match measured {
        (Some(w), Some(st)) if w.len() == wheels && st.len() == steers => {
            w.into_iter().chain(st).collect()
        }
        (Some(w), None) if w.len() == wheels && steers == 0 => w,
        _ => match (&s.commanded, &s.commanded_steer) {
            (Some(w), Some(st)) if w.len() == wheels && st.len() == steers => {
                w.iter().chain(st).copied().collect()
            }
            (Some(w), None) if w.len() == wheels && steers == 0 => w.clone(),
            _ => Vec::new(),
        },
    };
    Some(JointState {
        header: header(ns, ""),
        name,
        position,
        velocity,
        effort: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use omnikin_ros2::msg::from_cdr;

    #[test]
    fn a_twist_from_two_poses_is_in_the_robot_frame() {
        // Heading 90°: moving +y in the world is forward for the robot.
        let a = Pose2::new(1.0, 2.0, core::f64::consts::FRAC_PI_2);
        let b = Pose2::new(1.0, 2.1, core::f64::consts::FRAC_PI_2 + 0.02);
        let v = body_twist(Some(a), b, 0.1);
        // 1 m/s along world y, seen from the mean heading 90° + 0.01 rad.
        assert!((v[0] - 0.01f64.cos()).abs() < 1e-12, "{v:?}");
        assert!((v[1] + 0.01f64.sin()).abs() < 1e-12, "{v:?}");
        assert!((v[2] - 0.2).abs() < 1e-12);
        assert_eq!(body_twist(None, b, 0.1), [0.0; 3]);
        // Across ±π the yaw rate is the short way round.
        let c = Pose2::new(0.0, 0.0, 3.1);
        let d = Pose2::new(0.0, 0.0, -3.1);
        assert!(
            (body_twist(Some(c), d, 1.0)[2] - (2.0 * core::f64::consts::PI - 6.2)).abs() < 1e-12
        );
    }

    #[test]
    fn stamps_are_exact_and_trials_are_ros_names() {
        assert_eq!(
            stamp(3_250_000_001),
            Time {
                sec: 3,
                nanosec: 250_000_001
            }
        );
        assert_eq!(ros_namespace("/trial-002"), "/trial_002");
        assert_eq!(ros_namespace(""), "");
    }

    #[test]
    fn a_row_becomes_odometry_tf_joints_and_diagnostics() {
        let s = LogRow {
            t: 1.5,
            pose: Pose2::new(0.5, -0.25, 0.3),
            truth: Some(Pose2::new(0.51, -0.25, 0.3)),
            wheel_angles: Some(vec![1.0, 2.0, 3.0]),
            commanded: Some(vec![0.1, 0.2, 0.3]),
            ..LogRow::default()
        };
        let ev = vec![(Level::Error, "e-stop".to_string())];
        let m = messages(
            "/trial-001",
            &s,
            1_500_000_000,
            Some(Pose2::new(0.4, -0.25, 0.3)),
            0.5,
            (Some(vec![4.0, 5.0, 6.0]), None),
            &ev,
            "omnikin robot",
        );
        let topics: Vec<&str> = m.iter().map(|m| m.topic.as_str()).collect();
        assert_eq!(
            topics,
            [
                "/trial_001/odom",
                "/trial_001/tf",
                "/trial_001/truth",
                "/trial_001/joint_states",
                "/trial_001/diagnostics"
            ]
        );
        let odom: Odometry = from_cdr(&m[0].data).unwrap();
        assert_eq!(odom.header.frame_id, "odom");
        assert_eq!(odom.child_frame_id, "base_link");
        assert_eq!(odom.pose.pose.position.x, 0.5);
        assert!((odom.pose.pose.orientation.z - (0.15f64).sin()).abs() < 1e-15);
        let v = odom.twist.twist.linear;
        assert!(
            (v.x - 0.2 * 0.3f64.cos()).abs() < 1e-12 && (v.y + 0.2 * 0.3f64.sin()).abs() < 1e-12
        );
        let j: JointState = from_cdr(&m[3].data).unwrap();
        assert_eq!(j.name, ["wheel_1", "wheel_2", "wheel_3"]);
        assert_eq!(j.position, [1.0, 2.0, 3.0]);
        assert_eq!(j.velocity, [4.0, 5.0, 6.0]);
        let d: DiagnosticArray = from_cdr(&m[4].data).unwrap();
        assert_eq!(d.status[0].level, 2);
        assert_eq!(d.status[0].message, "e-stop");
        assert_eq!(m[0].type_name, "nav_msgs/msg/Odometry");
        assert!(m[0].schema.starts_with("std_msgs/Header header\n"));
    }
}
