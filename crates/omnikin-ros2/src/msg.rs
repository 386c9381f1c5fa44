//! The standard ROS 2 messages omnikin speaks (`conventions.md`, "ROS 2"), field for field as
//! their `.msg` definitions (ROS 2 Jazzy), with their type names, the DDS names rmw_zenoh puts
//! in its key expressions, their RIHS01 type hashes, and CDR encoding.
//!
//! CDR here is XCDR1 little-endian with the 4-byte encapsulation header `00 01 00 00`, the
//! encoding of every ROS 2 RMW: primitives aligned to their size from the end of the header,
//! strings as a `u32` length counting a closing NUL, sequences as a `u32` count, fixed arrays
//! without a count. The type hashes are constants of the message definitions; the tests compare
//! them and the encodings with `rosbags`, an independent implementation
//! (`tests/messages.rs` against `tests/golden/cdr.json`, which
//! `crates/omnikin-py/tests/test_ros2_messages.py` re-makes with rosbags).

use serde::{Deserialize, Serialize};
use serde_big_array::BigArray;

/// A ROS 2 message type: its names and type hash.
pub trait RosMessage: Serialize + for<'de> Deserialize<'de> {
    /// `package/msg/Name`, e.g. `geometry_msgs/msg/Twist`.
    const TYPE_NAME: &'static str;
    /// The RIHS01 type hash (`RIHS01_` and 64 hex digits, SHA-256 of the type description).
    const TYPE_HASH: &'static str;
    /// The definition as MCAP's `ros2msg` schema encoding holds it (what `ros2 bag record`
    /// writes as a channel's schema): the `.msg` fields, then each type it uses after a line
    /// of 80 `=` and `MSG: package/Name` (`src/msgdef/`, made by `rosbags`).
    const MSGDEF: &'static str;

    /// The DDS type name rmw_zenoh writes in key expressions: `package::msg::dds_::Name_`.
    fn dds_type_name() -> String {
        let mut parts = Self::TYPE_NAME.split('/');
        let (pkg, kind, name) = (
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
        );
        format!("{pkg}::{kind}::dds_::{name}_")
    }
}

/// The encapsulation header of little-endian plain CDR (`CDR_LE`), which ROS 2 writes.
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];
/// The encapsulation header of big-endian plain CDR (`CDR_BE`), which readers must accept.
pub const CDR_BE: [u8; 4] = [0x00, 0x00, 0x00, 0x00];

/// Why a CDR payload was refused.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    /// Shorter than the 4-byte encapsulation header.
    #[error("{0} bytes: shorter than the 4-byte CDR encapsulation header")]
    Short(usize),
    /// An encapsulation other than plain CDR (e.g. XCDR2, parameter lists).
    #[error("encapsulation {0:02x}{1:02x} is not plain CDR (0000 big-endian, 0001 little-endian)")]
    Encapsulation(u8, u8),
    /// The body does not decode as the type (truncated, a length past the end, bad UTF-8).
    #[error("{0}")]
    Body(#[from] cdr_encoding::Error),
}

/// CDR bytes of `m`: the `CDR_LE` header and the little-endian body.
pub fn to_cdr<M: RosMessage>(m: &M) -> Vec<u8> {
    let mut out = CDR_LE.to_vec();
    // These types hold only numbers, strings, fixed arrays and sequences: serialising cannot
    // fail (the codec errs only on unsupported serde shapes such as maps).
    if let Ok(body) = cdr_encoding::to_vec::<M, byteorder::LittleEndian>(m) {
        out.extend_from_slice(&body);
    }
    out
}

/// Decodes CDR `bytes` (encapsulation header included, either byte order) as `M`. Reads only
/// from `bytes`: a string or sequence length beyond the payload is an error before anything
/// is allocated for it (serde caps a sequence's pre-allocation), never a panic.
///
/// # Errors
/// [`CdrError`].
pub fn from_cdr<M: RosMessage>(bytes: &[u8]) -> Result<M, CdrError> {
    let (head, body) = bytes
        .split_first_chunk::<4>()
        .ok_or(CdrError::Short(bytes.len()))?;
    let m = match [head[0], head[1]] {
        [0x00, 0x01] => cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(body)?.0,
        [0x00, 0x00] => cdr_encoding::from_bytes::<M, byteorder::BigEndian>(body)?.0,
        [a, b] => return Err(CdrError::Encapsulation(a, b)),
    };
    Ok(m)
}

/// `builtin_interfaces/msg/Time`: seconds and nanoseconds since the clock's epoch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, 0..1e9.
    pub nanosec: u32,
}

impl Time {
    /// `t` seconds (≥ 0, finite; others saturate) as `(sec, nanosec)`.
    pub fn from_secs(t: f64) -> Self {
        let t = if t.is_finite() { t.max(0.0) } else { 0.0 };
        let sec = t.floor().min(i32::MAX as f64);
        let nanosec = ((t - sec) * 1e9).round().min(999_999_999.0) as u32;
        Self {
            sec: sec as i32,
            nanosec,
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// When the data was valid.
    pub stamp: Time,
    /// The frame the data is in (`odom`, `base_link`, …).
    pub frame_id: String,
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/msg/Point` (m).
pub type Point = Vector3;

/// `geometry_msgs/msg/Quaternion` (x, y, z, w).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self::yaw(0.0)
    }
}

impl Quaternion {
    /// A rotation by `yaw` (rad) about +z.
    pub fn yaw(yaw: f64) -> Self {
        let (s, c) = (0.5 * yaw).sin_cos();
        Self {
            x: 0.0,
            y: 0.0,
            z: s,
            w: c,
        }
    }
}

/// `geometry_msgs/msg/Twist`: linear (m/s) and angular (rad/s) velocity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity, m/s.
    pub linear: Vector3,
    /// Angular velocity, rad/s.
    pub angular: Vector3,
}

impl RosMessage for Twist {
    const MSGDEF: &'static str = include_str!("msgdef/geometry_msgs__Twist.msg");
    const TYPE_NAME: &'static str = "geometry_msgs/msg/Twist";
    const TYPE_HASH: &'static str =
        "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a";
}

/// `geometry_msgs/msg/TwistStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The twist.
    pub twist: Twist,
}

impl RosMessage for TwistStamped {
    const MSGDEF: &'static str = include_str!("msgdef/geometry_msgs__TwistStamped.msg");
    const TYPE_NAME: &'static str = "geometry_msgs/msg/TwistStamped";
    const TYPE_HASH: &'static str =
        "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64";
}

/// `geometry_msgs/msg/Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position, m.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/msg/PoseWithCovariance`: row-major 6×6 covariance over (x, y, z, roll,
/// pitch, yaw).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Covariance, row-major 6×6.
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

/// `geometry_msgs/msg/TwistWithCovariance`: row-major 6×6 covariance over (vx, vy, vz, wx,
/// wy, wz).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: Twist,
    /// Covariance, row-major 6×6.
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

/// `nav_msgs/msg/Odometry`: the pose in `header.frame_id` (`odom`), the twist in
/// `child_frame_id` (`base_link`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp and the pose's frame.
    pub header: Header,
    /// The twist's frame.
    pub child_frame_id: String,
    /// Pose and covariance.
    pub pose: PoseWithCovariance,
    /// Twist and covariance.
    pub twist: TwistWithCovariance,
}

impl RosMessage for Odometry {
    const MSGDEF: &'static str = include_str!("msgdef/nav_msgs__Odometry.msg");
    const TYPE_NAME: &'static str = "nav_msgs/msg/Odometry";
    const TYPE_HASH: &'static str =
        "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0";
}

/// `geometry_msgs/msg/PoseStamped`: a pose with its time and frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Time and frame of the pose.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

/// `nav_msgs/msg/Path`: a path as stamped poses (a planned path for RViz's Path display).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Path {
    /// Time and frame of the path.
    pub header: Header,
    /// The poses along it.
    pub poses: Vec<PoseStamped>,
}

impl RosMessage for Path {
    const MSGDEF: &'static str = include_str!("msgdef/nav_msgs__Path.msg");
    const TYPE_NAME: &'static str = "nav_msgs/msg/Path";
    const TYPE_HASH: &'static str =
        "RIHS01_1957a5bb3cee5da65c4e52e52b65a93df227efce4c20f8458b36e73066ca334b";
}

/// `geometry_msgs/msg/Transform`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation, m.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/msg/TransformStamped`: `child_frame_id` in `header.frame_id`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent.
    pub transform: Transform,
}

/// `tf2_msgs/msg/TFMessage`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

impl RosMessage for TfMessage {
    const MSGDEF: &'static str = include_str!("msgdef/tf2_msgs__TFMessage.msg");
    const TYPE_NAME: &'static str = "tf2_msgs/msg/TFMessage";
    const TYPE_HASH: &'static str =
        "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087";
}

/// `sensor_msgs/msg/JointState`: positions (rad), velocities (rad/s), efforts (N·m) by name.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Stamp.
    pub header: Header,
    /// Joint names (`wheel_1 …`, `steer_1 …`).
    pub name: Vec<String>,
    /// Positions, rad.
    pub position: Vec<f64>,
    /// Velocities, rad/s.
    pub velocity: Vec<f64>,
    /// Efforts, N·m (empty when not measured).
    pub effort: Vec<f64>,
}

impl RosMessage for JointState {
    const MSGDEF: &'static str = include_str!("msgdef/sensor_msgs__JointState.msg");
    const TYPE_NAME: &'static str = "sensor_msgs/msg/JointState";
    const TYPE_HASH: &'static str =
        "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e";
}

/// `sensor_msgs/msg/Imu` (covariance `[-1, 0, …]` marks a quantity as not provided).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Imu {
    /// Stamp and the IMU's frame.
    pub header: Header,
    /// Orientation.
    pub orientation: Quaternion,
    /// Its covariance, row-major 3×3.
    pub orientation_covariance: [f64; 9],
    /// Angular velocity, rad/s.
    pub angular_velocity: Vector3,
    /// Its covariance.
    pub angular_velocity_covariance: [f64; 9],
    /// Linear acceleration, m/s².
    pub linear_acceleration: Vector3,
    /// Its covariance.
    pub linear_acceleration_covariance: [f64; 9],
}

impl RosMessage for Imu {
    const MSGDEF: &'static str = include_str!("msgdef/sensor_msgs__Imu.msg");
    const TYPE_NAME: &'static str = "sensor_msgs/msg/Imu";
    const TYPE_HASH: &'static str =
        "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b";
}

/// `diagnostic_msgs/msg/KeyValue`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct KeyValue {
    /// Key.
    pub key: String,
    /// Value.
    pub value: String,
}

/// `diagnostic_msgs/msg/DiagnosticStatus`; `level` is 0 OK, 1 WARN, 2 ERROR, 3 STALE.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// Level.
    pub level: u8,
    /// Component name.
    pub name: String,
    /// Human-readable status.
    pub message: String,
    /// Hardware identifier.
    pub hardware_id: String,
    /// Key–value details.
    pub values: Vec<KeyValue>,
}

/// `diagnostic_msgs/msg/DiagnosticArray`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Stamp.
    pub header: Header,
    /// Statuses.
    pub status: Vec<DiagnosticStatus>,
}

impl RosMessage for DiagnosticArray {
    const MSGDEF: &'static str = include_str!("msgdef/diagnostic_msgs__DiagnosticArray.msg");
    const TYPE_NAME: &'static str = "diagnostic_msgs/msg/DiagnosticArray";
    const TYPE_HASH: &'static str =
        "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e";
}

/// `std_msgs/msg/Empty`: no fields. CDR writes the one byte every C++ ROS 2 type support
/// writes for an empty structure (`structure_needs_at_least_one_field`, 0), so its payload is
/// `00 01 00 00 00` (as `rosbags` writes it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Empty {
    /// Always 0; any value is accepted on reading.
    pub structure_needs_at_least_one_field: u8,
}

impl RosMessage for Empty {
    const MSGDEF: &'static str = "";
    const TYPE_NAME: &'static str = "std_msgs/msg/Empty";
    const TYPE_HASH: &'static str =
        "RIHS01_20b625256f32d5dbc0d04fee44f43c41e51c70d3502f84b4a08e7a9c26a96312";
}

/// `rosgraph_msgs/msg/Clock`: the time that nodes with `use_sim_time` take as "now".
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    /// The current time.
    pub clock: Time,
}

impl RosMessage for Clock {
    const MSGDEF: &'static str = "builtin_interfaces/Time clock\n\
================================================================================\n\
MSG: builtin_interfaces/Time\n\
int32 sec\n\
uint32 nanosec\n";
    const TYPE_NAME: &'static str = "rosgraph_msgs/msg/Clock";
    const TYPE_HASH: &'static str =
        "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564";
}

/// A ROS 2 service type: its name, the DDS name rmw_zenoh writes in key expressions and
/// liveliness tokens, its RIHS01 hash, and its request and response messages.
pub trait RosService {
    /// `package/srv/Name`, e.g. `std_srvs/srv/Trigger`.
    const TYPE_NAME: &'static str;
    /// The RIHS01 hash of the *service's* type description (REP 2011): the structure with
    /// fields `request_message`, `response_message` and `event_message`, which references
    /// `_Request`, `_Response`, `_Event`, `service_msgs/msg/ServiceEventInfo` and
    /// `builtin_interfaces/msg/Time` — what rmw_zenoh puts in a service's key and token.
    const TYPE_HASH: &'static str;
    /// The request.
    type Request: RosMessage;
    /// The response.
    type Response: RosMessage;

    /// The DDS type name rmw_zenoh writes: the response's, `package::srv::dds_::Name_Response_`,
    /// without its `Response_` (`rmw_service_data.cpp`), i.e. `package::srv::dds_::Name_`.
    fn dds_type_name() -> String {
        let mut parts = Self::TYPE_NAME.split('/');
        let (pkg, kind, name) = (
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
        );
        format!("{pkg}::{kind}::dds_::{name}_")
    }
}

/// `std_srvs/srv/Trigger_Request`: no fields; CDR carries the one byte of an empty structure
/// (`structure_needs_at_least_one_member`), `00 01 00 00 00` with its header.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TriggerRequest {
    /// Always 0; any value is accepted on reading.
    pub structure_needs_at_least_one_member: u8,
}

impl RosMessage for TriggerRequest {
    const MSGDEF: &'static str = "";
    const TYPE_NAME: &'static str = "std_srvs/srv/Trigger_Request";
    const TYPE_HASH: &'static str =
        "RIHS01_d010825374ce8918e72bfd826c82603e60f45419e932ea976f807b74a863a199";
}

/// `std_srvs/srv/Trigger_Response`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TriggerResponse {
    /// Whether the service did what it was asked.
    pub success: bool,
    /// What happened, for a person.
    pub message: String,
}

impl RosMessage for TriggerResponse {
    const MSGDEF: &'static str = "bool success\nstring message\n";
    const TYPE_NAME: &'static str = "std_srvs/srv/Trigger_Response";
    const TYPE_HASH: &'static str =
        "RIHS01_2d946c21e2fc3f1e9ca6986a8191d85fcc70097a8bb7771a053564bc47009cdf";
}

/// `std_srvs/srv/Trigger`: an empty request, a `(success, message)` response.
///
/// Its RIHS01 hash was computed with `rosbags` from the type descriptions REP 2011 gives a
/// service (module doc of [`RosService::TYPE_HASH`]), with `ServiceEventInfo.client_gid` as
/// `uint8[16]` — `char` in a `.msg` is `uint8` in rosidl's IDL, while rosbags' bundled
/// definition types it as `char` (type id 13), which gives another hash. With `uint8`,
/// `service_msgs/msg/ServiceEventInfo` hashes to the `RIHS01_41bcbbe0…` that independent ROS 2
/// client libraries carry, and the service to the hash below, which a third-party rmw_zenoh
/// client has in its `Trigger` key (`crates/omnikin-py/tests/test_ros2_node.py` re-computes
/// it with rosbags).
#[derive(Clone, Copy, Debug)]
pub struct Trigger;

impl RosService for Trigger {
    const TYPE_NAME: &'static str = "std_srvs/srv/Trigger";
    const TYPE_HASH: &'static str =
        "RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f";
    type Request = TriggerRequest;
    type Response = TriggerResponse;
}

#[cfg(test)]
mod empty_tests {
    use super::*;

    #[test]
    fn an_empty_message_is_one_zero_byte_as_rosbags_writes_it() {
        assert_eq!(to_cdr(&Empty::default()), [0, 1, 0, 0, 0]);
        assert_eq!(
            from_cdr::<Empty>(&[0, 1, 0, 0, 0]).ok(),
            Some(Empty::default())
        );
        assert_eq!(Empty::dds_type_name(), "std_msgs::msg::dds_::Empty_");
    }

    #[test]
    fn a_clock_is_a_time() {
        let c = Clock {
            clock: Time { sec: 2, nanosec: 5 },
        };
        assert_eq!(to_cdr(&c), [0, 1, 0, 0, 2, 0, 0, 0, 5, 0, 0, 0]);
        assert_eq!(Clock::dds_type_name(), "rosgraph_msgs::msg::dds_::Clock_");
        assert!(Clock::MSGDEF.starts_with("builtin_interfaces/Time clock\n====="));
    }

    #[test]
    fn a_trigger_is_an_empty_request_and_a_flag_and_text_response() {
        assert_eq!(Trigger::dds_type_name(), "std_srvs::srv::dds_::Trigger_");
        assert_eq!(to_cdr(&TriggerRequest::default()), [0, 1, 0, 0, 0]);
        let r = TriggerResponse {
            success: true,
            message: "ok".into(),
        };
        // bool, 3 bytes of padding to the string's u32 length (3: "ok" and its NUL).
        assert_eq!(
            to_cdr(&r),
            [0, 1, 0, 0, 1, 0, 0, 0, 3, 0, 0, 0, b'o', b'k', 0]
        );
        assert_eq!(from_cdr::<TriggerResponse>(&to_cdr(&r)).ok(), Some(r));
    }
}
