//! What a ROS 2 node of an omnikin robot publishes and takes, without the transport: the
//! robot's telemetry (the link's `Telemetry` and `Estimate`) as `odom`, `tf`, `joint_states`,
//! `imu` and `diagnostics`, and `cmd_vel` as the robot-frame velocity command the link carries.
//! `omnikin_host::ros2_node` moves these over Zenoh with [`crate::rmw`]'s names.
//!
//! Frames (REP-105, `conventions.md` "ROS 2"): `odom` (the robot's estimate: continuous,
//! drifts) → `base_link` (the robot frame: x forward, y left, z up, on the floor).

use omnikin::link::{Estimate, Telemetry};
use omnikin::runtime::{Faults, Mode};

use crate::msg::{
    DiagnosticArray, DiagnosticStatus, Header, Imu, JointState, KeyValue, Odometry, Pose,
    PoseWithCovariance, Quaternion, TfMessage, Time, Transform, TransformStamped, Twist,
    TwistWithCovariance, Vector3,
};

/// `Time` of `ns` nanoseconds since the Unix epoch (saturating past 2038).
pub fn stamp_ns(ns: u64) -> Time {
    Time {
        sec: i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX),
        nanosec: (ns % 1_000_000_000) as u32,
    }
}

fn header(stamp: Time, frame: &str) -> Header {
    Header {
        stamp,
        frame_id: frame.into(),
    }
}

/// The robot-frame command `[vx, vy, yaw_rate]` (m/s, m/s, rad/s) of a `cmd_vel` twist: its
/// `linear.x`, `linear.y` and `angular.z` (a planar base ignores the others). `None` when one
/// of those is not finite; the runtime's limits judge the rest (too fast: rejected).
pub fn command(t: &Twist) -> Option<[f64; 3]> {
    let c = [t.linear.x, t.linear.y, t.angular.z];
    c.iter().all(|v| v.is_finite()).then_some(c)
}

/// `odom` → `base_link`: the estimated pose, the measured robot-frame twist, and the
/// covariance of the fusion filter when the robot sends one (`Estimate`: variances of x, y
/// and heading on the diagonal at (0,0), (1,1), (5,5); the planar z, roll and pitch are exact,
/// 0). Without an estimate the covariance is unknown: zeros. The twist covariance is zeros.
pub fn odometry(t: &Telemetry, e: Option<&Estimate>, stamp: Time, frames: &Frames) -> Odometry {
    let mut covariance = [0.0; 36];
    if let Some(e) = e {
        covariance[0] = f64::from(e.covariance[0]);
        covariance[7] = f64::from(e.covariance[1]);
        covariance[35] = f64::from(e.covariance[2]);
    }
    Odometry {
        header: header(stamp, &frames.odom),
        child_frame_id: frames.base.clone(),
        pose: PoseWithCovariance {
            pose: pose(t),
            covariance,
        },
        twist: TwistWithCovariance {
            twist: Twist {
                linear: Vector3 {
                    x: f64::from(t.twist[0]),
                    y: f64::from(t.twist[1]),
                    z: 0.0,
                },
                angular: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: f64::from(t.twist[2]),
                },
            },
            covariance: [0.0; 36],
        },
    }
}

fn pose(t: &Telemetry) -> Pose {
    Pose {
        position: Vector3 {
            x: f64::from(t.pose[0]),
            y: f64::from(t.pose[1]),
            z: 0.0,
        },
        orientation: Quaternion::yaw(f64::from(t.pose[2])),
    }
}

/// The frame names a node writes (`odom`, `base_link`; a `--namespace`d robot keeps them, as
/// nav2's `odom_frame_id`/`base_frame_id` defaults expect).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Frames {
    /// The odometry frame, `odom`.
    pub odom: String,
    /// The robot frame, `base_link`.
    pub base: String,
}

impl Default for Frames {
    fn default() -> Self {
        Frames {
            odom: "odom".into(),
            base: "base_link".into(),
        }
    }
}

/// `tf`: the one transform `odom` → `base_link` of the estimate.
pub fn tf(t: &Telemetry, stamp: Time, frames: &Frames) -> TfMessage {
    let p = pose(t);
    TfMessage {
        transforms: vec![TransformStamped {
            header: header(stamp, &frames.odom),
            child_frame_id: frames.base.clone(),
            transform: Transform {
                translation: p.position,
                rotation: p.orientation,
            },
        }],
    }
}

/// `joint_states`: `wheel_1 … wheel_N` then, when `steer`, `steer_1 … steer_N`; positions
/// are the encoder angles (rad), velocities the commanded rates (rad/s; the link carries no
/// measured rate). At most `MAX_WHEELS` of each, whatever the telemetry claims.
pub fn joint_states(t: &Telemetry, steer: bool, stamp: Time) -> JointState {
    let n = usize::from(t.wheels).min(omnikin::MAX_WHEELS);
    let mut name: Vec<String> = (1..=n).map(|i| format!("wheel_{i}")).collect();
    let mut position: Vec<f64> = t.wheel_angles[..n].iter().map(|&a| a.into()).collect();
    let mut velocity: Vec<f64> = t.wheel_rates[..n].iter().map(|&a| a.into()).collect();
    if steer {
        name.extend((1..=n).map(|i| format!("steer_{i}")));
        position.extend(t.steer_angles[..n].iter().map(|&a| f64::from(a)));
        velocity.extend(t.steer_rates[..n].iter().map(|&a| f64::from(a)));
    }
    JointState {
        header: header(stamp, ""),
        name,
        position,
        velocity,
        effort: Vec::new(),
    }
}

/// Whether the telemetry carries an IMU (a gyro or accelerometer reading not all zeros).
pub fn has_imu(t: &Telemetry) -> bool {
    t.gyro.iter().chain(&t.accel).any(|&v| v != 0.0)
}

/// `imu` in `base_link`: the gyro (rad/s) and accelerometer (m/s²); no orientation
/// (`orientation_covariance[0] = -1`, REP-145), the rate and acceleration covariances
/// unknown (zeros).
pub fn imu(t: &Telemetry, stamp: Time, frames: &Frames) -> Imu {
    let v = |a: [f32; 3]| Vector3 {
        x: a[0].into(),
        y: a[1].into(),
        z: a[2].into(),
    };
    let mut orientation_covariance = [0.0; 9];
    orientation_covariance[0] = -1.0;
    Imu {
        header: header(stamp, &frames.base),
        orientation: Quaternion::default(),
        orientation_covariance,
        angular_velocity: v(t.gyro),
        angular_velocity_covariance: [0.0; 9],
        linear_acceleration: v(t.accel),
        linear_acceleration_covariance: [0.0; 9],
    }
}

/// `diagnostics`: one status named `name` (the node), level OK in every mode but e-stop,
/// WARN with an active fault, ERROR in e-stop or with a hardware fault or fall; its values
/// `mode`, `faults` (active), `fault_history` (since the last clear), `rejected`.
pub fn diagnostics(t: &Telemetry, name: &str, stamp: Time) -> DiagnosticArray {
    let error = t.mode == Mode::EStop
        || t.faults.contains(Faults::HARDWARE)
        || t.faults.contains(Faults::FALLEN);
    let (level, message) = if error {
        (2, format!("{}: {}", t.mode, t.faults))
    } else if !t.faults.is_empty() {
        (1, format!("{}: {}", t.mode, t.faults))
    } else {
        (0, t.mode.name().to_string())
    };
    let kv = |k: &str, v: String| KeyValue {
        key: k.into(),
        value: v,
    };
    DiagnosticArray {
        header: header(stamp, ""),
        status: vec![DiagnosticStatus {
            level,
            name: name.into(),
            message,
            hardware_id: String::new(),
            values: vec![
                kv("mode", t.mode.name().into()),
                kv("faults", t.faults.to_string()),
                kv("fault_history", t.fault_history.to_string()),
                kv("rejected", t.rejected.to_string()),
            ],
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{from_cdr, to_cdr};

    fn telemetry() -> Telemetry {
        let mut w = [0.0f32; omnikin::MAX_WHEELS];
        w[..3].copy_from_slice(&[1.0, 2.0, 3.0]);
        let mut r = [0.0f32; omnikin::MAX_WHEELS];
        r[..3].copy_from_slice(&[4.0, 5.0, 6.0]);
        Telemetry {
            time_us: 0,
            mode: Mode::Velocity,
            faults: Faults::NONE,
            fault_history: Faults::NONE,
            pose: [1.0, 2.0, 0.5],
            twist: [0.2, -0.1, 0.3],
            command: [0.0; 3],
            wheels: 3,
            wheel_rates: r,
            steer_rates: [0.0; omnikin::MAX_WHEELS],
            wheel_angles: w,
            steer_angles: [0.0; omnikin::MAX_WHEELS],
            gyro: [0.0; 3],
            accel: [0.0; 3],
            plan: Default::default(),
            plan_time: 0.0,
            reference: [0.0; 3],
            slip_residual: 0.0,
            rejected: 0,
            last_command_us: 0,
            link: Default::default(),
            ack_seq: 0,
            estop_seq: 0,
            clear_seq: 0,
        }
    }

    #[test]
    fn odometry_is_odom_to_base_link_with_the_filter_covariance() {
        let t = telemetry();
        let e = Estimate {
            time_us: 0,
            covariance: [0.01, 0.02, 0.03],
            odometry: [0.0; 3],
            gyro_bias: 0.0,
            wheel_scale: 1.0,
            fixes: Default::default(),
            events: Default::default(),
        };
        let o = odometry(&t, Some(&e), stamp_ns(1_500_000_000), &Frames::default());
        assert_eq!(o.header.frame_id, "odom");
        assert_eq!(o.child_frame_id, "base_link");
        assert_eq!(o.header.stamp.sec, 1);
        assert_eq!(o.header.stamp.nanosec, 500_000_000);
        assert_eq!(o.pose.pose.position.x, 1.0);
        assert!((o.pose.pose.orientation.z - 0.25f64.sin()).abs() < 1e-7);
        assert!((o.pose.covariance[7] - 0.02).abs() < 1e-9);
        assert!((o.twist.twist.linear.y + 0.1).abs() < 1e-7);
        let back: Odometry = from_cdr(&to_cdr(&o)).unwrap();
        assert_eq!(back, o);
    }

    #[test]
    fn joints_diagnostics_and_commands() {
        let t = telemetry();
        let j = joint_states(&t, false, Time::default());
        assert_eq!(j.name, ["wheel_1", "wheel_2", "wheel_3"]);
        assert_eq!(j.velocity, [4.0, 5.0, 6.0]);
        let mut bad = t;
        bad.wheels = 200; // claims more than the arrays hold: clamped, no panic
        assert_eq!(
            joint_states(&bad, true, Time::default()).name.len(),
            2 * omnikin::MAX_WHEELS
        );
        let d = diagnostics(&t, "omnikin", Time::default());
        assert_eq!(d.status[0].level, 0);
        let mut s = t;
        s.mode = Mode::EStop;
        assert_eq!(
            diagnostics(&s, "omnikin", Time::default()).status[0].level,
            2
        );
        let tw = Twist {
            linear: Vector3 {
                x: 0.1,
                y: 0.2,
                z: 9.0,
            },
            angular: Vector3 {
                x: 0.0,
                y: 0.0,
                z: 0.3,
            },
        };
        assert_eq!(command(&tw), Some([0.1, 0.2, 0.3]));
        let mut nan = tw;
        nan.angular.z = f64::NAN;
        assert_eq!(command(&nan), None);
        assert!(!has_imu(&t));
    }
}
