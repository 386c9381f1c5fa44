//! The time-optimal timing against the other timings of the same request: across the presets,
//! two splines and a slow and a motor-limited speed, it must not be slower than a trapezoidal
//! profile with the same speed and acceleration limits (which the planner slows to the motor
//! limits too, so it is a feasible timing) by more than the grid's discretization of the speed
//! switches ([`SWITCH_LOSS`]), and it must keep every motor within its limits at every sample
//! (the planner's final check; re-checked here).

use omnikin::description::{PRESETS, RobotDescription};
use omnikin_plan::RobotModel;
use omnikin_plan::heading::HeadingLaw;
use omnikin_plan::path::Path;
use omnikin_plan::planner::{
    InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing, plan, plan_peaks,
};
use omnikin_plan::profile::ProfileKind;

fn splines() -> [Vec<[f64; 2]>; 2] {
    let long = (0..20)
        .map(|k| {
            let k = k as f64;
            [0.5 * k, 0.4 * (0.9 * k).sin() + 0.1 * (2.3 * k).cos()]
        })
        .collect();
    let bent = vec![[0.0, 0.0], [0.5, 0.2], [1.0, -0.1], [1.4, 0.4], [1.2, 0.9]];
    [long, bent]
}

/// How much longer than the profile the time-optimal plan may be: where the speed switches
/// between accelerating and cruising inside a grid cell, the pass's constant path
/// acceleration per cell reaches the cruise speed late (15 cm cells with 4× finer cells at the
/// switches, at 0.5 m/s where the motors are far from their limits: at most 0.006 % on the
/// long spline and 0.048 % on the short one, measured 4 Dec 2026; the bound keeps the margin
/// of the coarser grids it was set for). At 3 m/s, where the motor limits bind, the
/// time-optimal plans take 54–86 % of the profile's time.
const SWITCH_LOSS: f64 = 7.5e-3;

#[test]
fn time_optimal_plans_are_never_slower_than_a_profile_and_stay_within_the_limits() {
    let mut compared = 0;
    for (name, _) in PRESETS {
        let robot = RobotModel::from_description(&RobotDescription::preset(name).expect("preset"))
            .expect("model");
        for wps in splines() {
            let path = Path::spline(&wps).expect("spline");
            for speed in [0.5, 3.0] {
                let limits = MotionLimits {
                    max_speed: speed,
                    max_accel: 1.0,
                    ..MotionLimits::default()
                };
                let opts = |timing| PlanOptions {
                    timing,
                    on_limit: OnLimit::Retime,
                    rate: 1000.0,
                    initial_steer: InitialSteer::Aligned,
                };
                let laws = [
                    HeadingLaw::Tangent { offset: 0.2 },
                    HeadingLaw::Constant(0.4),
                ];
                for law in &laws {
                    let fast = plan(&path, law, &robot, &opts(Timing::TimeOptimal { limits }))
                        .expect("time-optimal plan");
                    let profile = plan(
                        &path,
                        law,
                        &robot,
                        &opts(Timing::Profile {
                            kind: ProfileKind::Trapezoid,
                            limits,
                        }),
                    )
                    .expect("profile plan");
                    let (t_fast, t_profile) = (fast.report.duration, profile.report.duration);
                    assert!(
                        t_fast <= t_profile * (1.0 + SWITCH_LOSS),
                        "{name} {} waypoints {speed} m/s {law:?}: time-optimal {t_fast} s, \
                         profile {t_profile} s",
                        wps.len()
                    );
                    for p in plan_peaks(&fast.plan, &robot) {
                        if let Some(l) = p.limit {
                            assert!(
                                p.value <= l * (1.0 + 1e-9),
                                "{name} {speed} m/s {law:?}: {p:?}"
                            );
                        }
                    }
                    compared += 1;
                }
            }
        }
    }
    assert!(compared >= 50, "{compared} plans compared");
}

/// A set-point swerve under the tangent law along the 20-waypoint C² spline, time-optimal:
/// its steer rates per unit speed follow the curvature's derivative, which jumps at every
/// waypoint. The planner once kept slowing such a plan without end (87 s at 50 Hz, 663 s at
/// 200 Hz, too many samples at 1 kHz, against 18.66 s under a constant heading; bench/README.md,
/// 3 Dec 2026); it now stops the robot where the steer rates per unit speed jump (`moves.rs`,
/// the heading acceleration among the cut criteria), so the plan is the same at every sampling
/// rate, every sample within every limit, and the stops cost what braking and starting again
/// cost.
#[test]
fn a_swerve_under_the_tangent_law_plans_a_c2_spline_the_same_at_every_rate() {
    let robot = RobotModel::from_description(&RobotDescription::preset("swerve4").expect("preset"))
        .expect("model");
    let path = Path::spline(&splines()[0]).expect("spline");
    let limits = MotionLimits {
        max_speed: 0.6,
        max_accel: 1.0,
        ..MotionLimits::default()
    };
    let law = HeadingLaw::Tangent { offset: 0.0 };
    let mut durations = Vec::new();
    for rate in [50.0, 200.0, 1000.0] {
        let opts = PlanOptions {
            timing: Timing::TimeOptimal { limits },
            on_limit: OnLimit::Retime,
            rate,
            initial_steer: InitialSteer::Aligned,
        };
        let planned = plan(&path, &law, &robot, &opts).expect("time-optimal plan");
        for p in plan_peaks(&planned.plan, &robot) {
            if let Some(l) = p.limit {
                assert!(p.value <= l * (1.0 + 1e-9), "{rate} Hz: {p:?}");
            }
        }
        durations.push(planned.report.duration);
    }
    let (lo, hi) = durations
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), &d| {
            (lo.min(d), hi.max(d))
        });
    // The continuous timing does not depend on the sampling rate (29.462 s at all three).
    assert!(hi - lo <= 1e-6 * hi, "durations {durations:?} s");
    // Against the same plan under a constant heading (18.66 s, no stops): each of the 18
    // interior waypoints is now a stop, a brake from and a start to 0.6 m/s at 1 m/s², which
    // costs v/a = 0.6 s against cruising through (the defect's plans took 87–663 s).
    let opts = PlanOptions {
        timing: Timing::TimeOptimal { limits },
        on_limit: OnLimit::Retime,
        rate: 50.0,
        initial_steer: InitialSteer::Aligned,
    };
    let constant = plan(&path, &HeadingLaw::Constant(0.0), &robot, &opts)
        .expect("constant-heading plan")
        .report
        .duration;
    let stops = 18.0 * limits.max_speed / limits.max_accel;
    assert!(
        (hi - (constant + stops)).abs() <= 5e-3 * hi,
        "tangent {durations:?} s, constant {constant} s + stops {stops} s"
    );
}
