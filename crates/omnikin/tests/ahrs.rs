//! Mahony AHRS against synthetic inertial data of a known 3-D motion: attitude converges from a
//! wrong start, the integral term recovers a gyro bias on all three axes, yaw follows the
//! REP-103 (east-north-up) convention, a magnetic disturbance does not tilt roll/pitch, and bad
//! input is rejected.

use core::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{UnitQuaternion, Vector3};
use omnikin::estimate::ahrs::{AhrsError, Mahony, MahonyGains};

/// Earth field in the world (ENU): 20 µT north (+y), 45 µT down.
fn field() -> Vector3<f64> {
    Vector3::new(0.0, 20.0, -45.0)
}

/// Sensor readings for the true orientation `q` (body → world), body rate `w`, gyro bias `b`:
/// accelerometer = specific force of a body at rest (`+g` up), magnetometer = field in body.
fn sense(
    q: &UnitQuaternion<f64>,
    w: Vector3<f64>,
    b: Vector3<f64>,
) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let inv = q.inverse();
    (
        (w + b).into(),
        (inv * Vector3::new(0.0, 0.0, 9.81)).into(),
        (inv * field()).into(),
    )
}

fn angle_between(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    a.angle_to(b)
}

#[test]
fn converges_from_a_wrong_start_and_yaw_is_enu() {
    // Robot facing north (yaw +90° in ENU), tilted 10° roll, −5° pitch, still.
    let truth = UnitQuaternion::from_euler_angles(0.1745, -0.0873, FRAC_PI_2);
    let mut f = Mahony::new(MahonyGains::default_gains(), FRAC_PI_2);
    let (g, a, m) = sense(&truth, Vector3::zeros(), Vector3::zeros());
    // 100 s: the integral term picks up part of the initial 90° yaw error as a bias and lets
    // go of it with the slow time constant kp/ki = 20 s.
    for _ in 0..10_000 {
        f.update(0.01, g, a, Some(m)).unwrap();
    }
    let err = angle_between(&f.quaternion(), &truth);
    let att = f.attitude();
    assert!(err < 1e-3, "attitude error {err} rad");
    assert!((att.yaw - FRAC_PI_2).abs() < 1e-3, "{att:?}");
    assert!((att.roll - 0.1745).abs() < 1e-3 && (att.pitch + 0.0873).abs() < 1e-3);

    // The one-shot initialisation agrees.
    let init = Mahony::from_accel_mag(MahonyGains::default_gains(), FRAC_PI_2, a, m).unwrap();
    assert!(angle_between(&init.quaternion(), &truth) < 1e-9);
}

#[test]
fn integral_term_estimates_the_gyro_bias() {
    // Constant body rate (a slow tumble) with a bias on every axis; 120 s at 100 Hz.
    let w = Vector3::new(0.05, -0.03, 0.4);
    let bias = Vector3::new(0.02, -0.015, 0.03);
    let mut truth = UnitQuaternion::from_euler_angles(0.05, 0.02, 0.3);
    let mut f = Mahony::new(MahonyGains::default_gains(), FRAC_PI_2);
    let dt = 0.01;
    let mut worst_late = 0.0f64;
    for k in 0..12_000 {
        truth *= UnitQuaternion::from_scaled_axis(w * dt);
        let (g, a, m) = sense(&truth, w, bias);
        f.update(dt, g, a, Some(m)).unwrap();
        if k > 9_000 {
            worst_late = worst_late.max(angle_between(&f.quaternion(), &truth));
        }
    }
    let b = f.gyro_bias();
    println!(
        "bias estimate {b:?} (true {bias:?}), attitude error over the last 30 s ≤ {worst_late:.2e} rad"
    );
    for i in 0..3 {
        assert!(
            (b[i] - bias[i]).abs() < 2e-3,
            "axis {i}: {} vs {}",
            b[i],
            bias[i]
        );
    }
    assert!(worst_late < 0.01, "{worst_late}");

    // Without the integral term the bias stays and shows up as a standing attitude error.
    let mut p = Mahony::new(MahonyGains { kp: 1.0, ki: 0.0 }, FRAC_PI_2);
    let mut truth = UnitQuaternion::identity();
    for _ in 0..6_000 {
        truth *= UnitQuaternion::from_scaled_axis(w * dt);
        let (g, a, m) = sense(&truth, w, bias);
        p.update(dt, g, a, Some(m)).unwrap();
    }
    assert_eq!(p.gyro_bias(), [0.0; 3]);
    assert!(angle_between(&p.quaternion(), &truth) > 0.01);
}

#[test]
fn magnetic_disturbance_only_moves_the_yaw() {
    let truth = UnitQuaternion::from_euler_angles(0.2, -0.1, 1.0);
    let (g, a, m0) = sense(&truth, Vector3::zeros(), Vector3::zeros());
    // Start at the truth (initialised from the undisturbed field).
    let mut f = Mahony::from_accel_mag(MahonyGains::default_gains(), FRAC_PI_2, a, m0).unwrap();
    // A field bent by nearby iron (other azimuth and dip), for 100 s.
    let bent = UnitQuaternion::from_euler_angles(0.3, 0.2, 0.5) * field();
    let m: [f64; 3] = (truth.inverse() * bent).into();
    let mut worst_tilt = 0.0f64;
    for _ in 0..10_000 {
        let att = f.update(0.01, g, a, Some(m)).unwrap();
        worst_tilt = worst_tilt.max((att.roll - 0.2).abs().max((att.pitch + 0.1).abs()));
    }
    let att = f.attitude();
    // During the yaw transient the bias integrator leaks a little into roll/pitch (< 0.5°)…
    assert!(worst_tilt < 0.01, "{worst_tilt}");
    assert!(
        (att.roll - 0.2).abs() < 1e-3 && (att.pitch + 0.1).abs() < 1e-3,
        "{att:?}"
    );
    assert!(
        (att.yaw - 1.0).abs() > 0.05,
        "yaw follows the bent field: {att:?}"
    );
}

#[test]
fn bad_input_is_rejected() {
    let mut f = Mahony::new(MahonyGains::default_gains(), FRAC_PI_2);
    let before = f;
    let ok = [0.0, 0.0, 9.81];
    assert_eq!(
        f.update(0.0, [0.0; 3], ok, None),
        Err(AhrsError::NonPositiveDt { dt: 0.0 })
    );
    assert_eq!(
        f.update(0.01, [f64::NAN, 0.0, 0.0], ok, None),
        Err(AhrsError::NonFinite { field: "gyro" })
    );
    assert_eq!(
        f.update(0.01, [0.0; 3], ok, Some([0.0, f64::INFINITY, 0.0])),
        Err(AhrsError::NonFinite { field: "mag" })
    );
    assert_eq!(f, before);
    assert_eq!(
        Mahony::from_accel_mag(MahonyGains::default_gains(), 0.0, [0.0; 3], [1.0, 0.0, 0.0]),
        Err(AhrsError::Degenerate { field: "accel" })
    );
    // Free fall (zero specific force): gyro-only propagation, no error.
    let att = f.update(0.01, [0.0, 0.0, PI], [0.0; 3], None).unwrap();
    assert!((att.yaw - 0.01 * PI).abs() < 1e-12);
}

#[test]
fn from_accel_gives_the_tilt_and_the_vertical_rate_of_a_tilted_turn() {
    for (roll, pitch, rate) in [(0.25, -0.15, 1.3), (0.0, 0.0, -2.0), (-0.6, 0.4, 0.7)] {
        let tilt = UnitQuaternion::from_euler_angles(roll, pitch, 0.0);
        // Still, turning about the world vertical: gravity and the rate in the body frame.
        let accel = tilt.inverse() * Vector3::new(0.0, 0.0, 9.81);
        let gyro = tilt.inverse() * Vector3::new(0.0, 0.0, rate);
        let f = Mahony::from_accel(MahonyGains::default_gains(), 0.0, accel.into()).unwrap();
        let expected = (f64::cos(roll) * f64::cos(pitch)).acos();
        assert!(
            (f.tilt() - expected).abs() < 1e-12,
            "{} vs {expected}",
            f.tilt()
        );
        let v = f.vertical_rate(gyro.into());
        assert!((v - rate).abs() < 1e-12, "{v} vs {rate}");
        // The gyro's z axis alone reads cos(tilt) of it.
        assert!((gyro.z - rate * expected.cos()).abs() < 1e-12);
        let up = f.up_in_body();
        assert!((Vector3::from(up) - accel / 9.81).norm() < 1e-12);
    }
    assert_eq!(
        Mahony::<f64>::from_accel(MahonyGains::default_gains(), 0.0, [0.0; 3]),
        Err(AhrsError::Degenerate { field: "accel" })
    );
    assert!(matches!(
        Mahony::<f64>::from_accel(MahonyGains::default_gains(), 0.0, [f64::NAN, 0.0, 9.8]),
        Err(AhrsError::NonFinite { .. })
    ));
}
