//! Plans that start moving ([`plan_from_velocity`]): from rest they are [`plan`]'s bit for
//! bit; from a speed along the path their first sample moves at it, every motor limit holds,
//! they are never slower than from rest; a start the limits do not allow, off the path's
//! tangent or with another yaw rate than the heading law's is refused with the limit and the
//! excess. (Optimality against an independent solver: `tests/reference.rs`.)

use omnikin::description::{PRESETS, RobotDescription};
use omnikin_plan::RobotModel;
use omnikin_plan::heading::{HeadingLaw, HeadingProfile};
use omnikin_plan::path::{Corners, Path};
use omnikin_plan::planner::{
    InitialSteer, MotionLimits, OnLimit, PlanOptions, Planned, START_TOLERANCE, StartVelocity,
    Timing, plan, plan_from_velocity, plan_peaks,
};
use proptest::prelude::*;

fn robot(name: &str) -> RobotModel {
    RobotModel::from_description(&RobotDescription::preset(name).expect("preset")).expect("model")
}

fn opts(max_speed: f64) -> PlanOptions {
    PlanOptions {
        timing: Timing::TimeOptimal {
            limits: MotionLimits {
                max_speed,
                max_accel: 1.0,
                ..MotionLimits::default()
            },
        },
        on_limit: OnLimit::Retime,
        rate: 100.0,
        initial_steer: InitialSteer::Aligned,
    }
}

/// A bent spline 2.2 m long, leaving the origin along +x (its first chord's direction is not
/// the tangent: the end parabola's is).
fn spline() -> Path {
    Path::spline(&[[0.0, 0.0], [0.6, 0.0], [1.2, 0.3], [1.8, 0.2]]).expect("spline")
}

fn spin(path: &Path) -> HeadingLaw {
    HeadingLaw::Profile(HeadingProfile::new(&[(0.0, 0.3), (path.length(), 1.5)]).unwrap())
}

fn start_along(path: &Path, v: f64, yaw_rate: Option<f64>) -> StartVelocity {
    let t = path.at(0.0).tangent;
    StartVelocity {
        vx: v * t[0],
        vy: v * t[1],
        yaw_rate,
    }
}

fn within_limits(planned: &Planned, robot: &RobotModel) -> Result<(), String> {
    for p in plan_peaks(&planned.plan, robot) {
        if let Some(l) = p.limit
            && p.value > l * (1.0 + 1e-9)
        {
            return Err(format!("{p:?}"));
        }
    }
    Ok(())
}

#[test]
fn from_rest_it_is_the_plan_of_today_bit_for_bit() {
    let path = spline();
    for (name, _) in PRESETS {
        let r = robot(name);
        for law in [HeadingLaw::Constant(0.2), spin(&path)] {
            let a = plan(&path, &law, &r, &opts(1.0)).unwrap();
            for rest in [
                StartVelocity::REST,
                StartVelocity {
                    yaw_rate: Some(0.0),
                    ..StartVelocity::REST
                },
            ] {
                let b = plan_from_velocity(&path, &law, &r, &opts(1.0), rest).unwrap();
                assert_eq!(a.plan, b.plan, "{name} {law:?}");
            }
        }
    }
}

#[test]
fn every_kind_starts_at_the_given_velocity_within_the_limits_and_no_slower() {
    let path = spline();
    for (name, _) in PRESETS {
        let r = robot(name);
        let law = spin(&path);
        let rest = plan(&path, &law, &r, &opts(1.0)).unwrap();
        // Half the speed the from-rest plan reaches at its fastest.
        let top = rest
            .plan
            .samples
            .iter()
            .map(|s| s.twist.vx.hypot(s.twist.vy))
            .fold(0.0, f64::max);
        let dpsi = 1.2 / path.length();
        let start = start_along(&path, 0.5 * top, Some(dpsi * 0.5 * top));
        let moving = plan_from_velocity(&path, &law, &r, &opts(1.0), start)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let s0 = moving.plan.samples[0];
        assert_eq!(s0.t, 0.0);
        assert!((s0.twist.vx - start.vx).abs() <= START_TOLERANCE, "{name}");
        assert!((s0.twist.vy - start.vy).abs() <= START_TOLERANCE, "{name}");
        assert!(
            (s0.twist.yaw_rate - start.yaw_rate.unwrap()).abs() <= START_TOLERANCE,
            "{name}: {} rad/s",
            s0.twist.yaw_rate
        );
        within_limits(&moving, &r).unwrap_or_else(|e| panic!("{name}: {e}"));
        let (d, d0) = (moving.plan.duration(), rest.plan.duration());
        assert!(
            d < d0,
            "{name}: {d} s from {} m/s, {d0} s from rest",
            0.5 * top
        );
        // It still ends at rest at the path's end.
        let last = moving.plan.samples.last().unwrap();
        assert!(
            last.twist.vx.hypot(last.twist.vy) < 1e-12,
            "{name}: {last:?}"
        );
    }
}

#[test]
fn a_start_off_the_tangent_is_refused_with_the_angle() {
    let path = spline();
    let r = robot("kiwi");
    let law = HeadingLaw::Constant(0.0);
    // 1e-6 m/s across the tangent.
    let t = path.at(0.0).tangent;
    let mut s = start_along(&path, 0.3, None);
    s.vx -= 1e-6 * t[1];
    s.vy += 1e-6 * t[0];
    let e = plan_from_velocity(&path, &law, &r, &opts(1.0), s)
        .unwrap_err()
        .to_string();
    assert!(e.contains("off the path's first tangent"), "{e}");
    assert!(e.contains("1.000e-6 m/s"), "{e}");
    // Backwards along the tangent.
    let s = start_along(&path, -0.3, None);
    let e = plan_from_velocity(&path, &law, &r, &opts(1.0), s)
        .unwrap_err()
        .to_string();
    assert!(e.contains("180.0000°"), "{e}");
}

#[test]
fn a_yaw_rate_the_heading_law_does_not_give_is_refused() {
    let path = spline();
    let r = robot("kiwi");
    let e = plan_from_velocity(
        &path,
        &HeadingLaw::Constant(0.0),
        &r,
        &opts(1.0),
        start_along(&path, 0.3, Some(0.1)),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("not the heading law's 0.000000000 rad/s"), "{e}");
    let e = plan_from_velocity(
        &path,
        &HeadingLaw::Constant(0.0),
        &r,
        &opts(1.0),
        StartVelocity {
            vx: 0.0,
            vy: 0.0,
            yaw_rate: Some(0.5),
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("needs a start speed"), "{e}");
}

#[test]
fn a_start_above_the_max_speed_names_it_and_the_excess() {
    let path = spline();
    let r = robot("kiwi");
    let e = plan_from_velocity(
        &path,
        &HeadingLaw::Constant(0.0),
        &r,
        &opts(0.4),
        start_along(&path, 0.5, None),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("start speed 0.500000 m/s is above the 0.400000 m/s that max speed allows")
            && e.contains("by 25.000 %"),
        "{e}"
    );
}

#[test]
fn a_start_too_fast_to_stop_by_the_end_names_the_braking_limit() {
    // 0.3 m straight at 1 m/s² braking: at most √(2 · 1 · 0.3) = 0.7746 m/s.
    let path = Path::polyline(&[[0.0, 0.0], [0.3, 0.0]], Corners::Stop).unwrap();
    let r = robot("kiwi");
    let e = plan_from_velocity(
        &path,
        &HeadingLaw::Constant(0.0),
        &r,
        &opts(2.0),
        start_along(&path, 0.9, None),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("above the 0.774")
            && e.contains("can still end at rest within max acceleration"),
        "{e}"
    );
    // Just below it, it plans, and brakes all the way.
    let ok = plan_from_velocity(
        &path,
        &HeadingLaw::Constant(0.0),
        &r,
        &opts(2.0),
        start_along(&path, 0.77, None),
    )
    .unwrap();
    assert!(
        (ok.plan.duration() - 0.77).abs() < 0.02,
        "{}",
        ok.plan.duration()
    );
}

#[test]
fn a_start_velocity_needs_the_time_optimal_timing() {
    let path = spline();
    let r = robot("kiwi");
    let mut o = opts(1.0);
    o.timing = Timing::ConstantSpeed { speed: 0.3 };
    let e = plan_from_velocity(
        &path,
        &HeadingLaw::Constant(0.0),
        &r,
        &o,
        start_along(&path, 0.3, None),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("needs the time-optimal timing"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    /// Any start speed up to the largest the planner accepts on a filleted route with a
    /// heading profile (found by bisection: at the start the spin's wheel rates cap it below
    /// the from-rest plan's top speed — sphere-omni 0.753 of 0.79 m/s): the first sample moves
    /// at it, the limits hold, no slower than from rest.
    #[test]
    fn random_start_speeds(frac in 0.0..1.0f64, name in prop::sample::select(vec!["kiwi", "mecanum", "sphere-omni", "swerve4"])) {
        let path = Path::polyline(
            &[[0.0, 0.0], [1.0, 0.2], [1.5, 1.0], [2.5, 1.2]],
            Corners::Fillet { radius: 0.3 },
        ).unwrap();
        let law = spin(&path);
        let r = robot(name);
        let rest = plan(&path, &law, &r, &opts(1.5)).unwrap();
        let top = rest.plan.samples.iter().map(|s| s.twist.vx.hypot(s.twist.vy)).fold(0.0, f64::max);
        let accepted = |v: f64| {
            plan_from_velocity(&path, &law, &r, &opts(1.5), start_along(&path, v, None)).is_ok()
        };
        let (mut lo, mut hi) = (0.0, top);
        if accepted(top) {
            lo = top;
        } else {
            for _ in 0..40 {
                let mid = 0.5 * (lo + hi);
                if accepted(mid) { lo = mid } else { hi = mid }
            }
        }
        // The cap is the start's, not a collapse of the planner: most of the top speed.
        prop_assert!(lo > 0.5 * top, "{name}: largest accepted start {lo} of top speed {top}");
        let v = frac * lo;
        let start = start_along(&path, v, None);
        let moving = plan_from_velocity(&path, &law, &r, &opts(1.5), start);
        let moving = match moving {
            Ok(p) => p,
            Err(e) => return Err(TestCaseError::fail(format!("{name} from {v} m/s: {e}"))),
        };
        let s0 = moving.plan.samples[0];
        prop_assert!((s0.twist.vx - start.vx).abs() <= START_TOLERANCE);
        prop_assert!((s0.twist.vy - start.vy).abs() <= START_TOLERANCE);
        prop_assert!(within_limits(&moving, &r).is_ok(), "{:?}", within_limits(&moving, &r));
        prop_assert!(moving.plan.duration() <= rest.plan.duration() + 1e-9);
    }
}

/// A swerve stops where a fillet meets a straight, so a moving goal start must brake on the
/// straight before the first fillet: `moving_goal_path` lengthens its lead-in for it (not for a
/// kiwi, which passes the fillet's ends at speed), and the plan starts at the velocity. Before
/// the lengthening this start was refused (0.168 m/s at most on a 0.028 m first move).
#[test]
fn a_swerve_goal_start_brakes_before_the_first_fillet() {
    use omnikin_plan::map::Map;
    use omnikin_plan::splice::{moving_goal_path, start_heading};
    let map = Map::from_toml("[[keep_out]]\ncircle = [5.0, 5.0, 0.3]\n", "open.toml").unwrap();
    let mut o = opts(0.5);
    let Timing::TimeOptimal { limits } = &mut o.timing else {
        unreachable!()
    };
    limits.max_accel = 0.5;
    let (v, w) = ([0.2, 0.1], 0.05);
    let speed = f64::hypot(v[0], v[1]);
    let braking = 1.25 * speed * speed / (2.0 * 0.5);
    for (name, lengthened) in [("swerve4", true), ("kiwi", false)] {
        let r = robot(name);
        let (way, lead) = moving_goal_path(&map, 0.5, [0.0, 0.0], v, [3.0, 1.0], 0.5, &r).unwrap();
        let path = &way.smoothed.path;
        assert_eq!(
            lead > braking * (1.0 + 1e-9),
            lengthened,
            "{name}: lead-in {lead} m"
        );
        let law = start_heading(0.0, w / speed, 0.5, path.length()).unwrap();
        let start = StartVelocity {
            vx: v[0],
            vy: v[1],
            yaw_rate: Some(w),
        };
        let planned =
            plan_from_velocity(path, &law, &r, &o, start).unwrap_or_else(|e| panic!("{name}: {e}"));
        let s0 = planned.plan.samples[0].twist;
        assert!((s0.vx - v[0]).abs() <= START_TOLERANCE, "{name}");
        assert!((s0.vy - v[1]).abs() <= START_TOLERANCE, "{name}");
        assert!((s0.yaw_rate - w).abs() <= START_TOLERANCE, "{name}");
        within_limits(&planned, &r).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}
