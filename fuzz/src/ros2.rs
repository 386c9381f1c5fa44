//! The ROS 2 CDR decoder of `omnikin_ros2::msg::from_cdr` (what a ROS 2 node decodes from the
//! network: `cmd_vel` as `Twist` or `TwistStamped`, and every other message type it knows).
//!
//! Input: one byte picks the type, the rest is the sample (encapsulation header included).
//! Properties: decoding never panics and never allocates more than [`text_budget`] of the
//! sample's length (a forged string or sequence length must not allocate what it claims); a
//! decoded message re-encodes to a sample that decodes to the same message.

use omnikin_ros2::msg::{
    DiagnosticArray, Imu, JointState, Odometry, RosMessage, TfMessage, Twist, TwistStamped,
    from_cdr, to_cdr,
};

use crate::alloc::{measure, text_budget};

fn one<M: RosMessage + PartialEq + std::fmt::Debug>(sample: &[u8]) {
    let (decoded, usage) = measure(|| from_cdr::<M>(sample));
    let budget = text_budget(sample.len());
    assert!(
        usage.peak <= budget,
        "{}: decoding {} bytes took {} bytes",
        M::TYPE_NAME,
        sample.len(),
        usage.peak
    );
    if let Ok(m) = decoded {
        let again = from_cdr::<M>(&to_cdr(&m));
        assert!(
            matches!(&again, Ok(a) if *a == m || format!("{a:?}") == format!("{m:?}")),
            "{}: the encoder's own bytes do not decode to the message: {again:?}",
            M::TYPE_NAME
        );
    }
}

/// Fuzzes one sample (see the module docs).
pub fn ros2_cdr(data: &[u8]) {
    let Some((&pick, sample)) = data.split_first() else {
        return;
    };
    match pick % 7 {
        0 => one::<Twist>(sample),
        1 => one::<TwistStamped>(sample),
        2 => one::<Odometry>(sample),
        3 => one::<TfMessage>(sample),
        4 => one::<JointState>(sample),
        5 => one::<Imu>(sample),
        _ => one::<DiagnosticArray>(sample),
    }
}

/// Seeds: one valid sample of each type (its pick byte first), and a TwistStamped whose
/// frame_id claims 4 GiB.
pub fn seeds() -> Vec<(String, Vec<u8>)> {
    let with = |pick: u8, bytes: Vec<u8>| {
        let mut v = vec![pick];
        v.extend(bytes);
        v
    };
    let mut s = vec![
        (
            "twist-valid".to_string(),
            with(0, to_cdr(&Twist::default())),
        ),
        (
            "twist-stamped-valid".into(),
            with(1, to_cdr(&TwistStamped::default())),
        ),
        (
            "tf-valid".into(),
            with(
                3,
                to_cdr(&TfMessage {
                    transforms: vec![Default::default(); 2],
                }),
            ),
        ),
        (
            "joint-state-valid".into(),
            with(
                4,
                to_cdr(&JointState {
                    name: vec!["wheel_1".into()],
                    position: vec![1.0],
                    ..Default::default()
                }),
            ),
        ),
        ("imu-valid".into(), with(5, to_cdr(&Imu::default()))),
        (
            "diagnostics-valid".into(),
            with(6, to_cdr(&DiagnosticArray::default())),
        ),
    ];
    let mut forged = vec![1, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0];
    forged.extend_from_slice(&[0xff, 0xff, 0xff, 0xff, b'o', 0]);
    s.push(("twist-stamped-forged-length".into(), forged));
    s
}
