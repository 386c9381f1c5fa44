//! The one kind enum (`omnikin::Kind`): the link carries it with the indices protocol 4 fixed,
//! its names are the robot files' `kind` keys, and its capability answers agree with what the
//! models and the description loader actually do.
#![cfg(feature = "std")]

use omnikin::description::{PRESETS, RobotDescription};
use omnikin::link::RobotKind;
use omnikin::{Actuators, Kind, Twist2};

/// Protocol 4's encoding of a robot kind in `RobotInfo` (postcard: the variant index as one
/// varint byte). Appending a kind adds a row; these five must never change.
const WIRE: [(Kind, u8); 5] = [
    (Kind::Sphere, 0),
    (Kind::Ballbot, 1),
    (Kind::Caster, 2),
    (Kind::Omni, 3),
    (Kind::Swerve, 4),
];

#[test]
fn wire_encoding_of_each_kind_is_protocol_4s() {
    for (kind, byte) in WIRE {
        let mut buf = [0u8; 8];
        let bytes = postcard::to_slice(&kind, &mut buf).unwrap();
        assert_eq!(bytes, &[byte], "{kind:?}");
        let back: RobotKind = postcard::from_bytes(&[byte]).unwrap();
        assert_eq!(back, kind);
    }
    // A byte past the last kind is refused, not mapped to some kind.
    let past = Kind::ALL.len() as u8;
    assert!(postcard::from_bytes::<RobotKind>(&[past]).is_err());
}

#[test]
fn names_round_trip_and_every_kind_is_listed() {
    for (i, k) in Kind::ALL.iter().enumerate() {
        assert_eq!(Kind::from_name(k.name()), Some(*k));
        // ALL is in declaration (wire) order.
        let mut buf = [0u8; 8];
        assert_eq!(postcard::to_slice(k, &mut buf).unwrap(), &[i as u8]);
    }
    assert_eq!(Kind::from_name("Sphere"), None);
}

/// `steerable` is what the model does: a sideways-and-turning twist from rest sets steer angles
/// or rates exactly for the kinds that say they steer.
#[test]
fn steerable_matches_the_models_steer_outputs() {
    for (name, _) in PRESETS {
        let d = RobotDescription::preset(name).unwrap();
        let robot = d.build::<f64>().unwrap();
        let a = robot
            .inverse(Twist2::new(0.1, 0.05, 0.3), &Actuators::zero())
            .unwrap();
        let steers = a
            .steer_angles
            .iter()
            .chain(&a.steer_rates)
            .any(|s| s.abs() > 1e-9);
        assert_eq!(steers, d.robot_kind().steerable(), "{name}");
        assert_eq!(robot.kind(), d.robot_kind(), "{name}");
    }
}

/// `has_dynamics` is what the loader reads: the presets that carry a `[dynamics]` table are
/// exactly those of kinds with a dynamic model, and `balances` only where the loaded dynamics
/// are the ballbot's.
#[test]
fn dynamics_capabilities_match_the_loaded_presets() {
    for (name, text) in PRESETS {
        let d = RobotDescription::preset(name).unwrap();
        let k = d.robot_kind();
        let has_table = text.lines().any(|l| l.trim() == "[dynamics]");
        assert_eq!(has_table, k.has_dynamics(), "{name}");
        let loaded = d.sphere_dynamics.is_some() || d.ballbot_dynamics.is_some();
        assert_eq!(loaded, k.has_dynamics(), "{name}");
        assert_eq!(d.ballbot_dynamics.is_some(), k.balances(), "{name}");
    }
}
