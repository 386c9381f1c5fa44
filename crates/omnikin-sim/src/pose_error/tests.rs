//! ATE/RPE on trajectories whose errors are known by construction.

use super::*;

/// A track sampled at `dt` from `f(t) = (x, y, heading)` over `[t0, t1]`.
fn track(t0: f64, t1: f64, dt: f64, f: impl Fn(f64) -> (f64, f64, f64)) -> Track {
    let n = ((t1 - t0) / dt).round() as usize;
    let t: Vec<f64> = (0..=n).map(|k| t0 + k as f64 * dt).collect();
    let p: Vec<_> = t.iter().map(|&t| f(t)).collect();
    Track {
        xy: p.iter().map(|p| [p.0, p.1]).collect(),
        heading: Some(p.iter().map(|p| p.2).collect()),
        t,
        estops: Vec::new(),
    }
}

/// A curved truth: a circle of radius 1 m at 0.5 rad/s, heading along the path.
fn circle(t: f64) -> (f64, f64, f64) {
    let a = 0.5 * t;
    (a.sin(), 1.0 - a.cos(), a)
}

fn close(a: f64, b: f64, tol: f64) {
    assert!((a - b).abs() <= tol, "{a} vs {b} (tolerance {tol})");
}

#[test]
fn a_constant_offset_is_its_length_everywhere_and_no_relative_error() {
    let truth = track(0.0, 8.0, 0.01, circle);
    let est = track(0.0, 8.0, 0.01, |t| {
        let (x, y, h) = circle(t);
        (x + 0.003, y - 0.004, h)
    });
    let s = evaluate_run(&truth, &est, &PoseErrorOptions::default())
        .unwrap()
        .summary();
    let ate = s.ate_m.unwrap();
    assert_eq!(ate.count, 801);
    for v in [ate.rms, ate.mean, ate.median, ate.max] {
        close(v, 0.005, 1e-12);
    }
    close(s.rpe_translation_m.unwrap().max, 0.0, 1e-12);
    close(s.rpe_rotation_rad.unwrap().max, 0.0, 1e-12);
    // SE(2) alignment removes a rigid offset.
    let opts = PoseErrorOptions {
        alignment: Alignment::Se2,
        ..Default::default()
    };
    let r = evaluate_run(&truth, &est, &opts).unwrap();
    close(r.summary().ate_m.unwrap().max, 0.0, 1e-9);
    close(r.alignment.translation_m[0], -0.003, 1e-9);
    close(r.alignment.translation_m[1], 0.004, 1e-9);
}

#[test]
fn se2_alignment_recovers_a_rigid_motion_of_the_truth() {
    // The estimate is the truth seen in a frame rotated by 0.3 rad and shifted.
    let (a, tx, ty) = (0.3_f64, 0.2, -0.1);
    let truth = track(0.0, 8.0, 0.01, circle);
    let est = track(0.0, 8.0, 0.01, |t| {
        let (x, y, h) = circle(t);
        let (s, c) = (-a).sin_cos();
        (
            c * (x - tx) - s * (y - ty),
            s * (x - tx) + c * (y - ty),
            h - a,
        )
    });
    let none = evaluate_run(&truth, &est, &PoseErrorOptions::default()).unwrap();
    assert!(none.summary().ate_m.unwrap().rms > 0.1);
    // The relative motion is the same in any frame.
    close(none.summary().rpe_translation_m.unwrap().max, 0.0, 1e-12);
    let opts = PoseErrorOptions {
        alignment: Alignment::Se2,
        ..Default::default()
    };
    let r = evaluate_run(&truth, &est, &opts).unwrap();
    close(r.alignment.rotation_rad, a, 1e-9);
    close(r.alignment.translation_m[0], tx, 1e-9);
    close(r.alignment.translation_m[1], ty, 1e-9);
    let s = r.summary();
    close(s.ate_m.unwrap().max, 0.0, 1e-9);
    close(s.heading_error_rad.unwrap().max, 0.0, 1e-9);
}

#[test]
fn the_truth_is_interpolated_at_the_estimate_times() {
    // Truth at 10 Hz on x = t; the estimate, exact, between its samples (nearest-sample
    // association would report 0.05 m).
    let truth = track(0.0, 2.0, 0.1, |t| (t, 0.0, 0.0));
    let est = track(0.05, 1.95, 0.1, |t| (t, 0.0, 0.0));
    let s = evaluate_run(&truth, &est, &PoseErrorOptions::default())
        .unwrap()
        .summary();
    assert_eq!(s.samples, 20);
    close(s.ate_m.unwrap().max, 0.0, 1e-12);
}

#[test]
fn samples_outside_the_truth_are_counted_not_scored_and_no_overlap_is_an_error() {
    let truth = track(1.0, 2.0, 0.1, |t| (t, 0.0, 0.0));
    let est = track(0.0, 3.0, 0.1, |t| (t, 0.0, 0.0));
    let s = evaluate_run(&truth, &est, &PoseErrorOptions::default())
        .unwrap()
        .summary();
    assert_eq!(s.samples + s.outside_truth, 31);
    assert_eq!(s.samples, 11);
    let late = track(5.0, 6.0, 0.1, |t| (t, 0.0, 0.0));
    let e = evaluate_run(&truth, &late, &PoseErrorOptions::default()).unwrap_err();
    assert!(matches!(e, PoseErrorError::NoOverlap { .. }));
    assert!(e.to_string().contains("do not overlap"), "{e}");
}

#[test]
fn rpe_of_a_scale_error_is_the_scale_times_the_step() {
    // Straight line at 0.5 m/s; the estimate over-reads its travel by 10 %: over 1 s it is
    // 0.05 m too far, over 0.2 m of path 0.02 m, whatever the start.
    let truth = track(0.0, 4.0, 0.01, |t| (0.5 * t, 0.0, 0.0));
    let est = track(0.0, 4.0, 0.01, |t| (0.55 * t, 0.0, 0.0));
    let s = evaluate_run(&truth, &est, &PoseErrorOptions::default())
        .unwrap()
        .summary();
    let r = s.rpe_translation_m.unwrap();
    assert_eq!(r.count, 301);
    close(r.median, 0.05, 1e-9);
    close(r.mean, 0.05, 1e-9);
    close(r.max, 0.05, 1e-9);
    let opts = PoseErrorOptions {
        rpe_delta: RpeDelta::DistanceM(0.2),
        ..Default::default()
    };
    let r = evaluate_run(&truth, &est, &opts)
        .unwrap()
        .summary()
        .rpe_translation_m
        .unwrap();
    close(r.median, 0.02, 1e-9);
    close(r.max, 0.02, 1e-9);
    // ATE grows with time: 0.05 t, max at t = 4 s.
    close(s.ate_m.unwrap().max, 0.2, 1e-9);
}

#[test]
fn rpe_rotation_is_the_heading_drift_over_the_step() {
    // A gyro bias of 0.01 rad/s: 0.01 rad per second of step, in any frame.
    let truth = track(0.0, 8.0, 0.01, circle);
    let est = track(0.0, 8.0, 0.01, |t| {
        let (x, y, h) = circle(t);
        (x, y, h + 0.01 * t)
    });
    let opts = PoseErrorOptions {
        rpe_delta: RpeDelta::TimeS(2.0),
        ..Default::default()
    };
    let s = evaluate_run(&truth, &est, &opts).unwrap().summary();
    let r = s.rpe_rotation_rad.unwrap();
    close(r.mean, 0.02, 1e-9);
    close(r.max, 0.02, 1e-9);
    close(s.heading_error_rad.unwrap().max, 0.08, 1e-9);
}

#[test]
fn stats_median_pooling_and_bad_steps() {
    let mut v = [4.0, 1.0, 3.0, 2.0];
    let s = ErrorStats::of(&mut v).unwrap();
    assert_eq!((s.median, s.mean, s.max), (2.5, 2.5, 4.0));
    close(s.rms, (30.0_f64 / 4.0).sqrt(), 1e-15);
    assert_eq!(ErrorStats::of(&mut []), None);
    let truth = track(0.0, 1.0, 0.1, |t| (t, 0.0, 0.0));
    let a = track(0.0, 1.0, 0.1, |t| (t, 0.001, 0.0));
    let b = track(0.0, 1.0, 0.1, |t| (t, 0.002, 0.0));
    let opts = PoseErrorOptions::default();
    let runs = [
        evaluate_run(&truth, &a, &opts).unwrap(),
        evaluate_run(&truth, &b, &opts).unwrap(),
    ];
    let all = summarize(&runs).ate_m.unwrap();
    assert_eq!(all.count, 22);
    close(all.mean, 0.0015, 1e-12);
    close(all.rms, ((1e-6 + 4e-6) / 2.0_f64).sqrt(), 1e-12);
    for d in [0.0, -1.0, f64::NAN] {
        let o = PoseErrorOptions {
            rpe_delta: RpeDelta::TimeS(d),
            ..Default::default()
        };
        assert!(matches!(
            evaluate_run(&truth, &a, &o),
            Err(PoseErrorError::BadDelta(_))
        ));
    }
}
