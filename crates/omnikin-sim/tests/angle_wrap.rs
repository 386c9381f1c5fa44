//! One angle-wrap helper for the workspace: [`omnikin::wrap_angle`] folds into `(−π, π]`, and
//! the helpers it replaced — the runtime's heading-error wrap, the planner's `wrap_pi`, the
//! simulated yaw sensor's wrap and `metrics::angle_diff` — now all give its answer. Their call
//! sites call `wrap_angle` itself; here the one public survivor (`angle_diff`) and the former
//! formulas, re-written as independent oracles, are checked against it on a grid of angles.

use core::f64::consts::{PI, TAU};

use omnikin::wrap_angle;
use omnikin_sim::metrics::angle_diff;

/// The runtime's former `wrap` (and the odometry's general path): nearest multiple of 2π.
fn old_round(x: f64) -> f64 {
    let mut y = x - TAU * (x / TAU).round();
    if y <= -PI {
        y += TAU;
    } else if y > PI {
        y -= TAU;
    }
    y
}

/// The planner's former `wrap_pi`.
fn old_rem_euclid(a: f64) -> f64 {
    let mut r = a.rem_euclid(TAU);
    if r > PI {
        r -= TAU;
    }
    r
}

/// The simulated yaw sensor's former `wrap`.
fn old_shifted(x: f64) -> f64 {
    let y = (x + PI).rem_euclid(TAU) - PI;
    if y <= -PI { y + TAU } else { y }
}

/// `metrics::angle_diff`'s former body, which gave −π for a half-turn.
fn old_metrics(d: f64) -> f64 {
    d - TAU * (d / TAU).round()
}

fn grid() -> Vec<f64> {
    let mut g: Vec<f64> = (-2000..=2000).map(|i| i as f64 * 0.01).collect();
    for k in -9..=9 {
        let x = k as f64 * PI;
        g.extend([x, x + 1e-9, x - 1e-9]);
    }
    g
}

#[test]
fn a_half_turn_wraps_to_plus_pi() {
    assert_eq!(wrap_angle(PI), PI);
    assert_eq!(wrap_angle(-PI), PI);
    assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
    assert!((wrap_angle(-3.0 * PI) - PI).abs() < 1e-12);
    assert_eq!(wrap_angle(core::f32::consts::PI), core::f32::consts::PI);
    assert_eq!(wrap_angle(-core::f32::consts::PI), core::f32::consts::PI);
    // `angle_diff` returned −π for these before it called `wrap_angle`.
    assert_eq!(angle_diff(PI, 0.0), PI);
    assert_eq!(angle_diff(0.0, PI), PI);
    assert_eq!(angle_diff(0.0, -PI), PI);
    assert!(wrap_angle(f64::NAN).is_nan());
    assert!(wrap_angle(f64::INFINITY).is_nan());
}

#[test]
fn every_former_helper_agrees_on_a_grid() {
    for x in grid() {
        let w = wrap_angle(x);
        assert!(w > -PI && w <= PI, "{x} -> {w}");
        let turns = (x - w) / TAU;
        assert!((turns - turns.round()).abs() < 1e-12, "{x} -> {w}");
        // In range: returned unchanged.
        if x > -PI && x <= PI {
            assert_eq!(w, x);
        }
        assert_eq!(angle_diff(x, 0.0), w, "angle_diff({x}, 0)");
        assert_eq!(old_round(x), w, "runtime wrap({x})");
        // The rem_euclid forms round differently by an ulp, and at the boundary.
        let near_boundary = PI - w.abs() < 1e-6;
        for (name, old) in [
            ("planner wrap_pi", old_rem_euclid(x)),
            ("sensor wrap", old_shifted(x)),
            ("metrics angle_diff", old_metrics(x)),
        ] {
            let same = (old - w).abs() < 1e-12;
            let other_end = near_boundary && (old + w).abs() < 1e-12;
            assert!(same || other_end, "{name}({x}) = {old}, wrap_angle = {w}");
        }
        if !near_boundary {
            let w32 = wrap_angle(x as f32) as f64;
            assert!((w32 - w).abs() < 1e-4, "f32 {x} -> {w32} vs {w}");
        }
    }
}

#[test]
fn angle_diff_is_the_wrapped_difference() {
    for &b in &[-7.0, -PI, -0.3, 0.0, 0.3, PI, 7.0] {
        for a in grid().into_iter().step_by(37) {
            let d = angle_diff(a, b);
            assert_eq!(d, wrap_angle(a - b));
            assert!(d > -PI && d <= PI);
        }
    }
}
