//! The plan's continuous timing between its samples: every motor's rate and acceleration
//! evaluated densely (20 kHz) along the timed moves of a plan made at 100 Hz and at 1 kHz,
//! with the core inverse kinematics at every point. An acceleration is the difference of two
//! rates 50 µs apart over that time, the mean of the true acceleration over the interval, so
//! it never overstates the peak and approaches it as the interval shrinks.

use super::*;
use crate::heading::HeadingProfile;
use crate::path::Corners;
use crate::waypoints::Waypoints;

/// The rate the continuous timing is evaluated at, Hz.
const DENSE: f64 = 20_000.0;

/// The largest motor rate and acceleration of the moves' continuous timing over their limits
/// (1 = at the limit), with the time and the channel of the worst.
fn dense_peak(ctx: &Ctx, moves: &[Move]) -> (f64, f64, usize) {
    let robot = ctx.robot;
    let n = robot.wheels();
    let p = sample(ctx, moves, DENSE).expect("dense samples");
    let mut worst = (0.0_f64, 0.0, 0);
    for ch in 0..robot.channels() {
        let value = |s: &crate::plan::Sample| report::channel_value(s, n, ch);
        if let Some(l) = robot.rate_limit(ch) {
            for s in &p.samples {
                let r = value(s).abs() / l;
                if r > worst.0 {
                    worst = (r, s.t, ch);
                }
            }
        }
        if let Some(l) = robot.accel_limit(ch) {
            for w in p.samples.windows(2) {
                let r = ((value(&w[1]) - value(&w[0])) / (w[1].t - w[0].t)).abs() / l;
                if r > worst.0 {
                    worst = (r, w[1].t, ch);
                }
            }
        }
    }
    worst
}

fn shipped() -> Waypoints {
    let file =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/waypoints.toml");
    Waypoints::load(&file).expect("examples/waypoints.toml")
}

#[test]
fn no_motor_exceeds_its_limit_between_the_samples() {
    let w = shipped();
    let mut report = Vec::new();
    let mut failed = Vec::new();
    for (pk, path) in [
        ("spline", Path::spline(&w.points)),
        (
            "fillet",
            Path::polyline(&w.points, Corners::Fillet { radius: 0.15 }),
        ),
        ("stop", Path::polyline(&w.points, Corners::Stop)),
    ] {
        let path = path.expect("path");
        let at_waypoints: Vec<(f64, f64)> = path
            .waypoint_arc_lengths()
            .iter()
            .copied()
            .zip(w.headings.clone().expect("headings"))
            .collect();
        for (law_name, law) in [
            ("constant", HeadingLaw::Constant(0.0)),
            ("tangent", HeadingLaw::Tangent { offset: 0.0 }),
            (
                "waypoints",
                HeadingLaw::Profile(HeadingProfile::new(&at_waypoints).expect("profile")),
            ),
        ] {
            for name in [
                "kiwi",
                "x-drive",
                "mecanum",
                "swerve4",
                "sphere-omni",
                "ballbot",
                "caster3",
            ] {
                let robot = RobotModel::from_description(
                    &omnikin::description::RobotDescription::preset(name).expect("preset"),
                )
                .expect("model");
                for rate in [100.0, 1000.0] {
                    let opts = PlanOptions {
                        timing: Timing::TimeOptimal {
                            limits: MotionLimits {
                                max_speed: 2.0,
                                max_accel: 4.0,
                                ..MotionLimits::default()
                            },
                        },
                        on_limit: OnLimit::Retime,
                        rate,
                        initial_steer: InitialSteer::Aligned,
                    };
                    let what = format!("{pk} {law_name} {name} {rate} Hz");
                    let (moves, _) = plan_moves(&path, &law, &robot, &opts, 0.0)
                        .unwrap_or_else(|e| panic!("{what}: {e}"));
                    let ctx = context(&path, &law, &robot, &opts);
                    let (ratio, t, ch) = dense_peak(&ctx, &moves);
                    let line =
                        format!("{what}: {ratio:.4} of the limit at t {t:.4} s, channel {ch}");
                    if ratio > 1.001 {
                        failed.push(line.clone());
                    }
                    report.push(line);
                }
            }
        }
    }
    println!("{}", report.join("\n"));
    assert!(
        failed.is_empty(),
        "above a limit by more than 0.1 %:\n{}",
        failed.join("\n")
    );
}
