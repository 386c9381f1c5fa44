//! The ROS 2 messages against `rosbags` (tests/golden/cdr.json, written by
//! tests/golden/make_golden.py and re-checked by the Python tests): the same values encode to
//! the same CDR bytes and decode back, the type hashes are rosbags' RIHS01 hashes, the DDS
//! names are rmw_zenoh's form, and a truncated or corrupted payload is an error, never a panic.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use omnikin_ros2::msg::*;

/// Records the largest single allocation (bytes), to show a forged length allocates nothing big.
struct Largest;
static LARGEST: AtomicUsize = AtomicUsize::new(0);
unsafe impl GlobalAlloc for Largest {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}
#[global_allocator]
static GLOBAL: Largest = Largest;

fn golden() -> serde_json::Value {
    serde_json::from_str(include_str!("golden/cdr.json")).unwrap()
}

fn header(sec: i32, nanosec: u32, frame: &str) -> Header {
    Header {
        stamp: Time { sec, nanosec },
        frame_id: frame.into(),
    }
}

fn v3(x: f64, y: f64, z: f64) -> Vector3 {
    Vector3 { x, y, z }
}

fn twist(a: [f64; 3], b: [f64; 3]) -> Twist {
    Twist {
        linear: v3(a[0], a[1], a[2]),
        angular: v3(b[0], b[1], b[2]),
    }
}

const Q45: Quaternion = Quaternion {
    x: 0.0,
    y: 0.0,
    z: 0.3826834323650898,
    w: 0.9238795325112867,
};

fn cov36(scale: f64) -> [f64; 36] {
    core::array::from_fn(|i| {
        if i % 7 == 0 {
            0.001 * (i + 1) as f64 * scale
        } else {
            0.0
        }
    })
}

fn check<M: RosMessage + PartialEq + std::fmt::Debug>(m: &M) {
    let g = &golden()[M::TYPE_NAME];
    assert_eq!(g["hash"], M::TYPE_HASH, "{}", M::TYPE_NAME);
    let bytes = to_cdr(m);
    let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    assert_eq!(hex, g["cdr"].as_str().unwrap(), "{}", M::TYPE_NAME);
    assert_eq!(&from_cdr::<M>(&bytes).unwrap(), m);
    // Every truncation is an error (or, past the last field, the same message), never a panic.
    for n in 0..bytes.len() {
        if let Ok(back) = from_cdr::<M>(&bytes[..n]) {
            assert_eq!(&back, m, "{} truncated to {n}", M::TYPE_NAME);
        }
    }
    // A forged sequence or string length does not allocate beyond the payload.
    let mut forged = bytes.clone();
    for b in forged.iter_mut().skip(4).take(16) {
        *b = 0xff;
    }
    let _ = from_cdr::<M>(&forged);
}

#[test]
fn every_message_encodes_as_rosbags_does() {
    check(&twist([0.25, -0.1, 0.0], [0.0, 0.0, 0.5]));
    check(&TwistStamped {
        header: header(12, 500_000_000, "base_link"),
        twist: twist([0.1, 0.0, 0.0], [0.0, 0.0, -0.2]),
    });
    check(&Odometry {
        header: header(3, 250_000_000, "odom"),
        child_frame_id: "base_link".into(),
        pose: PoseWithCovariance {
            pose: Pose {
                position: v3(1.5, -0.5, 0.0),
                orientation: Q45,
            },
            covariance: cov36(1.0),
        },
        twist: TwistWithCovariance {
            twist: twist([0.2, 0.05, 0.0], [0.0, 0.0, 0.1]),
            covariance: cov36(2.0),
        },
    });
    check(&TfMessage {
        transforms: vec![
            TransformStamped {
                header: header(3, 250_000_000, "odom"),
                child_frame_id: "base_link".into(),
                transform: Transform {
                    translation: v3(1.5, -0.5, 0.0),
                    rotation: Q45,
                },
            },
            TransformStamped {
                header: header(3, 250_000_000, "base_link"),
                child_frame_id: "platform".into(),
                transform: Transform {
                    translation: v3(0.0, 0.0, 0.15),
                    rotation: Quaternion::default(),
                },
            },
        ],
    });
    check(&JointState {
        header: header(7, 1, ""),
        name: vec!["wheel_1".into(), "wheel_2".into(), "wheel_3".into()],
        position: vec![0.5, -1.25, 3.0],
        velocity: vec![1.0, 2.0, -3.0],
        effort: vec![],
    });
    let diag3 = |v: f64| [v, 0.0, 0.0, 0.0, v, 0.0, 0.0, 0.0, v];
    check(&Imu {
        header: header(9, 999_999_999, "imu"),
        orientation: Quaternion::default(),
        orientation_covariance: [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        angular_velocity: v3(0.01, -0.02, 0.5),
        angular_velocity_covariance: diag3(1e-4),
        linear_acceleration: v3(0.1, 0.0, 9.81),
        linear_acceleration_covariance: diag3(0.01),
    });
    let stamped = |x: f64, y: f64, q: Quaternion| PoseStamped {
        header: header(2, 5, "odom"),
        pose: Pose {
            position: v3(x, y, 0.0),
            orientation: q,
        },
    };
    check(&Path {
        header: header(2, 5, "odom"),
        poses: vec![
            stamped(0.0, 0.0, Quaternion::yaw(0.0)),
            stamped(
                0.5,
                0.25,
                Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.3826834323650898,
                    w: 0.9238795325112867,
                },
            ),
        ],
    });
    check(&DiagnosticArray {
        header: header(5, 0, ""),
        status: vec![DiagnosticStatus {
            level: 2,
            name: "omnikin: mode".into(),
            message: "e-stop".into(),
            hardware_id: "sim".into(),
            values: vec![
                KeyValue {
                    key: "fault".into(),
                    value: "none".into(),
                },
                KeyValue {
                    key: "watchdog".into(),
                    value: "ok".into(),
                },
            ],
        }],
    });
}

#[test]
fn a_forged_length_is_refused_without_allocating_it() {
    // A TwistStamped whose frame_id claims 4 GiB, and a JointState whose name list claims 2^32
    // strings, in a sample of a few dozen bytes.
    let mut stamped = CDR_LE.to_vec();
    stamped.extend_from_slice(&[1, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff, b'o', 0]);
    let mut joints = CDR_LE.to_vec();
    joints.extend_from_slice(&[1, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0]);
    joints.extend_from_slice(&[0xff, 0xff, 0xff, 0xff, 2, 0, 0, 0, b'a', 0]);
    LARGEST.store(0, Ordering::Relaxed);
    assert!(from_cdr::<TwistStamped>(&stamped).is_err());
    assert!(from_cdr::<JointState>(&joints).is_err());
    let largest = LARGEST.load(Ordering::Relaxed);
    assert!(largest < 1 << 20, "largest allocation {largest} bytes");
    // Other encapsulations and short payloads are named.
    let e = from_cdr::<Twist>(&[0, 2, 0, 0]).unwrap_err().to_string();
    assert!(e.contains("0002"), "{e}");
    assert!(
        from_cdr::<Twist>(&[0, 1])
            .unwrap_err()
            .to_string()
            .contains("2 bytes")
    );
}

#[test]
fn big_endian_samples_decode_too() {
    let t = twist([0.25, -0.1, 0.0], [0.0, 0.0, 0.5]);
    let mut be = CDR_BE.to_vec();
    for v in [0.25f64, -0.1, 0.0, 0.0, 0.0, 0.5] {
        be.extend_from_slice(&v.to_be_bytes());
    }
    assert_eq!(from_cdr::<Twist>(&be).unwrap(), t);
}

#[test]
fn dds_names_are_rmw_zenohs() {
    assert_eq!(Twist::dds_type_name(), "geometry_msgs::msg::dds_::Twist_");
    assert_eq!(
        TfMessage::dds_type_name(),
        "tf2_msgs::msg::dds_::TFMessage_"
    );
}

#[test]
fn time_from_seconds() {
    assert_eq!(
        Time::from_secs(3.25),
        Time {
            sec: 3,
            nanosec: 250_000_000
        }
    );
    assert_eq!(Time::from_secs(-1.0), Time::default());
    assert_eq!(Time::from_secs(f64::NAN), Time::default());
    assert_eq!(Time::from_secs(1e300).sec, i32::MAX);
    let q = Quaternion::yaw(std::f64::consts::FRAC_PI_2);
    assert!((q.z - 0.5f64.sqrt()).abs() < 1e-15 && (q.w - 0.5f64.sqrt()).abs() < 1e-15);
}
