//! `PoseFusion` properties: a late fix lands where an on-time one would; the history covers
//! `max_latency` at any step rate and counts older fixes as too late; a run of rejections
//! always ends within `recovery_count` fixes (agreeing → re-initialised, scattered →
//! inflated); the first fix of `awaiting_fix` sets the pose; f32 works.

use omnikin::estimate::fix::Fix;
use omnikin::estimate::fusion::{
    FusionConfig, FusionError, FusionOutcome, PoseFusion, Recovery, StepHeading,
};
use omnikin::nalgebra::Matrix3;
use omnikin::{Pose2, Twist2, se2};
use proptest::prelude::*;

type Filter = PoseFusion<f64, 64>;

fn filter() -> Filter {
    PoseFusion::new(
        0.0,
        Pose2::new(0.0, 0.0, 0.0),
        Matrix3::identity() * 1e-4,
        FusionConfig::default(),
    )
    .unwrap()
}

/// Steps of a gentle curve at `rate` Hz up to `until` s; the true pose along it. Returns the
/// last step's time.
fn drive(f: &mut Filter, rate: f64, from: f64, until: f64, truth: &mut Pose2<f64>) -> f64 {
    let tw = Twist2::new(0.3, 0.05, 0.2);
    let mut k = (from * rate).round() as usize;
    while (k as f64) / rate < until - 1e-12 {
        k += 1;
        let delta = se2::twist_exp(tw, 1.0 / rate);
        *truth = se2::compose(*truth, delta);
        f.predict(k as f64 / rate, delta, StepHeading::Wheels)
            .unwrap();
    }
    k as f64 / rate
}

fn fix(t: f64, x: f64, y: f64) -> Fix<f64> {
    Fix::position(t, x, y, 0.01)
}

#[test]
fn a_late_fix_lands_where_an_on_time_one_would() {
    let (mut on_time, mut late) = (filter(), filter());
    let (mut a, mut b) = (Pose2::new(0.0, 0.0, 0.0), Pose2::new(0.0, 0.0, 0.0));
    drive(&mut on_time, 1000.0, 0.0, 2.0, &mut a);
    drive(&mut late, 1000.0, 0.0, 2.0, &mut b);
    // A fix 5 cm off the odometry, taken at 2.0 s: on time, or 0.3 s late.
    let f = fix(2.0, a.x + 0.05, a.y - 0.03);
    assert!(matches!(
        on_time.add_fix(&f),
        Ok(FusionOutcome::Accepted { .. })
    ));
    drive(&mut on_time, 1000.0, 2.0, 2.3, &mut a);
    drive(&mut late, 1000.0, 2.0, 2.3, &mut b);
    assert!(matches!(
        late.add_fix(&f),
        Ok(FusionOutcome::Accepted { .. })
    ));
    let (p, q) = (on_time.pose(), late.pose());
    let d = (p.x - q.x).hypot(p.y - q.y);
    // Equal up to the merging of 1 ms steps into 7.8 ms history entries.
    assert!(d < 1e-4 && (p.heading - q.heading).abs() < 1e-4, "{d}");
    // And it moved the estimate: the fix was not dropped.
    let moved = (p.x - a.x).hypot(p.y - a.y);
    assert!(moved > 0.01, "{moved}");
}

#[test]
fn the_history_covers_max_latency_at_any_rate() {
    for rate in [50.0, 1000.0, 5000.0] {
        let mut f = filter();
        let mut truth = Pose2::new(0.0, 0.0, 0.0);
        drive(&mut f, rate, 0.0, 3.0, &mut truth);
        // max_latency 1 s: 0.95 s old is fused, 1.05 s old is too late.
        assert!(f.oldest_time() <= 2.0 + 1e-9, "{rate}: {}", f.oldest_time());
        assert!(f.add_fix(&fix(2.05, 0.0, 0.0)).is_ok(), "{rate} Hz");
        assert!(matches!(
            f.add_fix(&fix(1.95 - 1.0 / rate, 0.0, 0.0)),
            Err(FusionError::TooLate { .. })
        ));
        assert!(matches!(
            f.add_fix(&fix(3.1, 0.0, 0.0)),
            Err(FusionError::InFuture { .. })
        ));
    }
}

#[test]
fn the_first_fix_sets_the_pose_of_a_filter_awaiting_one() {
    let mut f = Filter::awaiting_fix(0.0, 0.0, FusionConfig::default()).unwrap();
    assert!(!f.initialised());
    let mut truth = Pose2::new(0.0, 0.0, 0.0);
    drive(&mut f, 100.0, 0.0, 0.5, &mut truth);
    assert_eq!(
        f.add_fix(&fix(0.3, 40.0, -25.0)).unwrap(),
        FusionOutcome::Initialised
    );
    assert!(f.initialised());
    // Pose at 0.3 s is the fix; 0.2 s of odometry (6 cm) follow it.
    let p = f.pose();
    assert!((p.x - 40.0).hypot(p.y + 25.0) < 0.1, "{p:?}");
}

#[test]
fn agreeing_rejections_reinitialise_after_recovery_count() {
    let mut f = filter();
    let mut truth = Pose2::new(0.0, 0.0, 0.0);
    drive(&mut f, 100.0, 0.0, 1.0, &mut truth);
    // The robot was carried 2 m: every fix is 2 m off the odometry, consistently.
    let mut outcomes = Vec::new();
    for i in 0..8 {
        let t = 1.1 + 0.1 * i as f64;
        let t = drive(&mut f, 100.0, t - 0.1, t, &mut truth);
        outcomes.push(f.add_fix(&fix(t, truth.x + 2.0, truth.y)).unwrap());
    }
    let n = FusionConfig::<f64>::default().recovery_count as usize;
    for o in &outcomes[..n - 1] {
        assert!(matches!(o, FusionOutcome::Rejected { .. }), "{o:?}");
    }
    assert_eq!(
        outcomes[n - 1],
        FusionOutcome::Recovered {
            recovery: Recovery::Reinitialised,
            rejected: n as u32 - 1
        }
    );
    for o in &outcomes[n..] {
        assert!(matches!(o, FusionOutcome::Accepted { .. }), "{o:?}");
    }
    let p = f.pose();
    assert!((p.x - truth.x - 2.0).hypot(p.y - truth.y) < 0.03, "{p:?}");
}

proptest! {
    /// Whatever the fixes (outliers anywhere within ±100 m), no run of rejections is longer
    /// than `recovery_count − 1`: the next fix recovers.
    #[test]
    fn rejection_never_lasts(
        fixes in prop::collection::vec((-100.0f64..100.0, -100.0f64..100.0), 1..40),
        count in 1u32..=8,
    ) {
        let config = FusionConfig { recovery_count: count, ..FusionConfig::default() };
        let mut f = Filter::new(0.0, Pose2::new(0.0, 0.0, 0.0), Matrix3::identity() * 1e-4, config)
            .unwrap();
        let mut truth = Pose2::new(0.0, 0.0, 0.0);
        let mut run = 0u32;
        for (i, (x, y)) in fixes.iter().enumerate() {
            let t = 0.1 * (i + 1) as f64;
            let t = drive(&mut f, 100.0, t - 0.1, t, &mut truth);
            match f.add_fix(&fix(t, *x, *y)).unwrap() {
                FusionOutcome::Rejected { .. } => run += 1,
                FusionOutcome::Recovered { rejected, .. } => {
                    prop_assert_eq!(rejected, run);
                    run = 0;
                }
                _ => run = 0,
            }
            prop_assert!(run < count, "{} rejections in a row", run);
            let p = f.pose();
            prop_assert!(p.x.is_finite() && p.y.is_finite() && p.heading.is_finite());
        }
    }
}

#[test]
fn scattered_rejections_inflate_then_fuse() {
    let mut f = filter();
    let mut truth = Pose2::new(0.0, 0.0, 0.0);
    let mut last = None;
    for (i, (x, y)) in [
        (5.0, 0.0),
        (-5.0, 3.0),
        (0.0, -6.0),
        (7.0, 7.0),
        (-3.0, -3.0),
    ]
    .iter()
    .enumerate()
    {
        let t = 0.1 * (i + 1) as f64;
        let t = drive(&mut f, 100.0, t - 0.1, t, &mut truth);
        last = Some(f.add_fix(&fix(t, *x, *y)).unwrap());
    }
    assert_eq!(
        last,
        Some(FusionOutcome::Recovered {
            recovery: Recovery::Inflated,
            rejected: 4
        })
    );
}

#[test]
fn gyro_bias_is_estimated_in_f32() {
    // Standing still with a gyro reading 0.02 rad/s and heading fixes: the bias is found.
    let mut f = PoseFusion::<f32, 32>::new(
        0.0,
        Pose2::new(0.0, 0.0, 0.0),
        Matrix3::identity() * 1e-4,
        FusionConfig::default(),
    )
    .unwrap();
    for k in 1..=2000 {
        let t = k as f32 * 0.01;
        f.predict(t, Pose2::new(0.0, 0.0, 0.02 * 0.01), StepHeading::Gyro)
            .unwrap();
        if k % 10 == 0 {
            let mut x = Fix::position(t, 0.0, 0.0, 0.01);
            x.heading = Some(0.0);
            x.std_heading = 0.01;
            f.add_fix(&x).unwrap();
        }
    }
    let (b, sb) = f.gyro_bias();
    assert!((b - 0.02).abs() < 3.0 * sb && sb < 0.005, "{b} ± {sb}");
}

#[test]
fn bad_inputs_are_refused() {
    let bad = FusionConfig {
        max_latency: 0.0,
        ..FusionConfig::default()
    };
    assert!(matches!(
        Filter::new(0.0, Pose2::new(0.0, 0.0, 0.0), Matrix3::zeros(), bad),
        Err(FusionError::BadParameter {
            field: "max_latency",
            ..
        })
    ));
    let bad = FusionConfig {
        recovery_count: 0,
        ..FusionConfig::default()
    };
    assert!(Filter::new(0.0, Pose2::new(0.0, 0.0, 0.0), Matrix3::zeros(), bad).is_err());
    let mut f = filter();
    assert!(matches!(
        f.predict(f64::NAN, Pose2::new(0.0, 0.0, 0.0), StepHeading::Wheels),
        Err(FusionError::NonFinite { field: "t" })
    ));
    assert!(matches!(
        f.predict(0.0, Pose2::new(0.0, 0.0, 0.0), StepHeading::Wheels),
        Err(FusionError::NonMonotonicTime { .. })
    ));
    f.predict(0.1, Pose2::new(0.0, 0.0, 0.0), StepHeading::Wheels)
        .unwrap();
    assert!(matches!(
        f.add_fix(&Fix::position(0.05, 0.0, 0.0, 0.0)),
        Err(FusionError::BadParameter {
            field: "fix.std_xy",
            ..
        })
    ));
}

proptest! {
    /// Any interleaving of steps (irregular rates) and fixes (any latency, duplicates, far
    /// outliers, with and without heading) in a tiny 8-entry history: no panic, a finite state
    /// with a symmetric covariance of non-negative diagonal, and the only refusals are the
    /// documented ones.
    #[test]
    fn any_sequence_keeps_a_sane_state(
        ops in prop::collection::vec(
            (0u8..3, 1e-4f64..0.2, -1.5f64..0.1, -3.0f64..3.0, -3.0f64..3.0, any::<bool>()),
            1..200,
        ),
        awaiting in any::<bool>(),
    ) {
        let config = FusionConfig { max_latency: 0.5, ..FusionConfig::default() };
        let mut f = if awaiting {
            PoseFusion::<f64, 8>::awaiting_fix(0.0, 0.0, config).unwrap()
        } else {
            PoseFusion::<f64, 8>::new(0.0, Pose2::new(0.0, 0.0, 0.0), Matrix3::identity() * 1e-4, config)
                .unwrap()
        };
        let mut t = 0.0;
        for (op, dt, age, x, y, with_heading) in ops {
            if op < 2 {
                t += dt;
                let d = se2::twist_exp(Twist2::new(x * 0.1, y * 0.1, x * 0.3), dt);
                let kind = if op == 0 { StepHeading::Gyro } else { StepHeading::Wheels };
                f.predict(t, d, kind).unwrap();
            } else {
                let mut fx = Fix::position((t + age).min(t), x, y, 0.01);
                if with_heading {
                    fx.heading = Some(x * 2.0);
                    fx.std_heading = 0.05;
                }
                match f.add_fix(&fx) {
                    Ok(_) => {}
                    Err(FusionError::TooLate { t: ft, oldest }) => prop_assert!(ft < oldest),
                    Err(e) => prop_assert!(false, "{e}"),
                }
            }
            let (x, p) = f.state();
            prop_assert!(x.iter().all(|v| v.is_finite()));
            prop_assert!(p.iter().all(|v| v.is_finite()));
            prop_assert!((p - p.transpose()).abs().max() <= 1e-9 * (1.0 + p.abs().max()));
            prop_assert!((0..5).all(|i| p[(i, i)] >= -1e-12));
            prop_assert!(f.oldest_time() <= t);
        }
    }
}

/// The covariance step runs once per history entry: the variances read every cycle (the
/// sparse quadratic forms of `pose_variances`) equal the diagonal of the full covariance step
/// at every step, with the wheels' and a gyro's heading, before and after a fix; the settled
/// variances are never ahead of them.
#[test]
fn variances_every_step_equal_the_full_covariance_step() {
    for heading in [StepHeading::Wheels, StepHeading::Gyro] {
        let mut f = filter();
        let tw = Twist2::new(0.4, -0.1, 0.7);
        let mut truth = Pose2::new(0.0, 0.0, 0.0);
        for k in 1..=3000u32 {
            let t = f64::from(k) * 1e-3;
            let delta = se2::twist_exp(tw, 1e-3);
            truth = se2::compose(truth, delta);
            f.predict(t, delta, heading).unwrap();
            if k == 1500 {
                f.add_fix(&fix(t, truth.x + 0.02, truth.y)).unwrap();
            }
            let full = f.pose_covariance();
            let fast = f.pose_variances();
            let settled = f.settled_pose_variances();
            for i in 0..3 {
                let d = full[(i, i)];
                assert!(
                    (fast[i] - d).abs() <= 1e-12 * d.abs().max(1e-12),
                    "{heading:?} step {k} [{i}]: {} vs {d}",
                    fast[i]
                );
                assert!(
                    settled[i] <= d * (1.0 + 1e-12),
                    "{heading:?} step {k} [{i}]"
                );
            }
        }
    }
}

/// `restart` (the runtime's `SetPose`, in place) leaves the filter as `new` builds it, and a
/// bad input leaves it unchanged.
#[test]
fn restart_in_place_equals_a_new_filter() {
    let mut f = filter();
    let mut truth = Pose2::new(0.0, 0.0, 0.0);
    let t = drive(&mut f, 1000.0, 0.0, 1.0, &mut truth);
    f.add_fix(&fix(t, truth.x + 0.01, truth.y)).unwrap();
    let before = f.state();
    assert!(matches!(
        f.restart(t, Pose2::new(f64::NAN, 0.0, 0.0), Matrix3::zeros()),
        Err(FusionError::NonFinite { field: "pose.x" })
    ));
    assert_eq!(f.state(), before);
    let (pose, cov) = (Pose2::new(1.0, -2.0, 0.5), Matrix3::identity() * 1e-3);
    f.restart(t, pose, cov).unwrap();
    let fresh = Filter::new(t, pose, cov, FusionConfig::default()).unwrap();
    assert_eq!(f.state(), fresh.state());
    assert_eq!(
        (f.time(), f.oldest_time()),
        (fresh.time(), fresh.oldest_time())
    );
    // Both go on alike.
    let (mut a, mut b) = (Pose2::new(0.0, 0.0, 0.0), Pose2::new(0.0, 0.0, 0.0));
    let mut g = fresh;
    drive(&mut f, 1000.0, t, t + 0.5, &mut a);
    drive(&mut g, 1000.0, t, t + 0.5, &mut b);
    assert_eq!(f.state(), g.state());
}
