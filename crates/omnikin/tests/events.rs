//! The event detector on merged odometry steps (`EventDecimator`, what the runtime feeds it at
//! 1 kHz): a merged sample is the one long step it stands for, and a slip is flagged at most
//! one merge period after the per-step detector flags it.

use omnikin::estimate::events::{EventDecimator, EventDetector, EventThresholds};
use omnikin::estimate::odometry::OdometryStep;
use omnikin::{MAX_WHEELS, Pose2, Twist2};

fn step(t: f64, dt: f64, twist: Twist2<f64>, residual: f64) -> OdometryStep<f64> {
    OdometryStep {
        t,
        dt,
        pose: Pose2::new(0.0, 0.0, 0.0),
        delta: Pose2::new(twist.vx * dt, twist.vy * dt, twist.yaw_rate * dt),
        twist,
        wheel_heading_change: twist.yaw_rate * dt,
        slip_residual: residual,
        wheel_slip: [0.0; MAX_WHEELS],
        shell_spin: None,
    }
}

#[test]
fn merged_steps_are_the_long_step_they_stand_for() {
    let mut d = EventDecimator::new(0.0025);
    let tw = Twist2::new(0.3, -0.4, 0.5);
    assert!(d.push(&step(0.001, 0.001, tw, 0.02), Some(0.7)).is_none());
    assert!(d.push(&step(0.002, 0.001, tw, 0.04), Some(0.9)).is_none());
    let (s, gyro) = d.push(&step(0.003, 0.001, tw, 0.06), Some(0.8)).unwrap();
    assert!((s.t - 0.003).abs() < 1e-15 && (s.dt - 0.003).abs() < 1e-15);
    assert!((s.speed - 0.5).abs() < 1e-12, "{}", s.speed);
    assert!((s.slip_residual - 0.04).abs() < 1e-12);
    assert!((s.wheel_heading_change - 0.0015).abs() < 1e-15);
    assert!((gyro.unwrap() - 0.8).abs() < 1e-12);
    // A step without the IMU's rate: the merged sample has none; the first sample (dt = 0)
    // is no step.
    assert!(d.push(&step(0.003, 0.0, tw, 0.0), Some(0.8)).is_none());
    d.push(&step(0.004, 0.001, tw, 0.0), Some(0.8));
    d.push(&step(0.005, 0.001, tw, 0.0), None);
    let (_, gyro) = d.push(&step(0.006, 0.001, tw, 0.0), Some(0.8)).unwrap();
    assert_eq!(gyro, None);
}

#[test]
fn a_slip_is_flagged_within_one_merge_period_of_the_per_step_detector() {
    let th = EventThresholds::standard();
    let (mut every, mut merged) = (EventDetector::new(th, false), EventDetector::new(th, false));
    let mut dec = EventDecimator::new(0.0025);
    let tw = Twist2::new(0.2, 0.0, 0.1);
    let (mut first_every, mut first_merged) = (None, None);
    for k in 1..=400u32 {
        let t = f64::from(k) * 1e-3;
        // From 0.2 s the gyro disagrees with the wheels by 1 rad/s.
        let gyro = if t > 0.2 { 1.1 } else { 0.1 };
        let s = step(t, 1e-3, tw, 0.0);
        if every.step(&s, Some(gyro)).slipping && first_every.is_none() {
            first_every = Some(t);
        }
        if let Some((m, g)) = dec.push(&s, Some(gyro))
            && merged.sample(&m, g).slipping
            && first_merged.is_none()
        {
            first_merged = Some(t);
        }
    }
    let (a, b) = (first_every.unwrap(), first_merged.unwrap());
    assert!(
        a > 0.2 && b >= a - 1e-12 && b - a <= 0.0025 + 1e-9,
        "{a} {b}"
    );
    assert_eq!((every.counters().slips, merged.counters().slips), (1, 1));
}

/// 1 kHz steps at 0.3 m/s that drop to rest in one step at 0.5 s, merged as the runtime does:
/// the number of collisions, with the commanded speed dropping at the same step (`stop_cmd`),
/// one step earlier (the runtime's command precedes the wheels by a cycle) or never.
fn collisions_when_stopped(commanded: impl Fn(f64) -> Option<f64>) -> u32 {
    let mut d = EventDecimator::new(0.0025);
    let mut det = EventDetector::new(EventThresholds::standard(), false);
    for k in 1..=1000 {
        let t = k as f64 * 1e-3;
        let v = if t <= 0.5 { 0.3 } else { 0.0 };
        let s = step(t, 1e-3, Twist2::new(v, 0.0, 0.0), 0.0);
        if let Some((mut sample, gyro)) = d.push(&s, None) {
            sample.commanded_speed = commanded(t);
            det.sample(&sample, gyro);
        }
    }
    det.finish();
    det.counters().collisions
}

#[test]
fn braking_the_robot_commanded_is_no_collision_an_unexplained_stop_is_one() {
    // No commands (a log): the stop is a collision, as before.
    assert_eq!(collisions_when_stopped(|_| None), 1);
    // Commanded on, then zero (an e-stop) one step before the wheels stop: none.
    assert_eq!(
        collisions_when_stopped(|t| Some(if t <= 0.499 { 0.3 } else { 0.0 })),
        0
    );
    // ... or at the same step: none.
    assert_eq!(
        collisions_when_stopped(|t| Some(if t <= 0.5 { 0.3 } else { 0.0 })),
        0
    );
    // Commanded 0.3 m/s throughout (an obstacle stops the wheels): one.
    assert_eq!(collisions_when_stopped(|_| Some(0.3)), 1);
}
