//! Every heading law on every path kind and every robot preset, with interior waypoints and
//! headings (the shipped `examples/waypoints.toml` among them): each plans without error,
//! respects every motor limit at every sample, moves forward along the path (never back) and
//! ends at rest on the last waypoint. Checked from the samples alone.

use omnikin::description::RobotDescription;
use omnikin_plan::heading::{HeadingLaw, HeadingProfile};
use omnikin_plan::path::{Corners, Path};
use omnikin_plan::planner::{InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing, plan};
use omnikin_plan::profile::ProfileKind;
use omnikin_plan::waypoints::Waypoints;
use omnikin_plan::{Plan, RobotModel};

const PRESETS: [&str; 7] = [
    "kiwi",
    "x-drive",
    "mecanum",
    "swerve4",
    "sphere-omni",
    "ballbot",
    "caster3",
];

fn robot(name: &str) -> RobotModel {
    RobotModel::from_description(&RobotDescription::preset(name).unwrap()).unwrap()
}

/// The waypoints (and headings) of the shipped example file.
fn shipped() -> Waypoints {
    let file =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/waypoints.toml");
    Waypoints::load(&file).unwrap()
}

/// A second set whose headings turn both ways, on a path with a sharp and a shallow corner.
fn zigzag() -> Waypoints {
    Waypoints {
        points: vec![[0.0, 0.0], [0.7, 0.3], [1.1, -0.2], [1.9, 0.1], [2.2, 0.8]],
        headings: Some(vec![0.0, 0.8, -0.4, 0.3, 2.0]),
        lines: vec![1, 2, 3, 4, 5],
    }
}

fn paths(w: &Waypoints) -> Vec<(&'static str, Path)> {
    vec![
        ("stop", Path::polyline(&w.points, Corners::Stop).unwrap()),
        (
            "fillet",
            Path::polyline(&w.points, Corners::Fillet { radius: 0.15 }).unwrap(),
        ),
        ("spline", Path::spline(&w.points).unwrap()),
    ]
}

fn laws(path: &Path, w: &Waypoints) -> Vec<(&'static str, HeadingLaw)> {
    let at_waypoints: Vec<(f64, f64)> = path
        .waypoint_arc_lengths()
        .iter()
        .copied()
        .zip(w.headings.clone().unwrap())
        .collect();
    let l = path.length();
    vec![
        ("constant", HeadingLaw::Constant(0.3)),
        ("tangent", HeadingLaw::Tangent { offset: 0.0 }),
        (
            "spin",
            HeadingLaw::Profile(HeadingProfile::new(&[(0.0, 0.0), (l, 1.5)]).unwrap()),
        ),
        (
            "waypoints",
            HeadingLaw::Profile(HeadingProfile::new(&at_waypoints).unwrap()),
        ),
    ]
}

fn timings() -> Vec<(&'static str, Timing)> {
    let limits = MotionLimits {
        max_speed: 2.0,
        max_accel: 4.0,
        ..MotionLimits::default()
    };
    vec![
        ("time-optimal", Timing::TimeOptimal { limits }),
        (
            "trapezoid",
            Timing::Profile {
                kind: ProfileKind::Trapezoid,
                limits: MotionLimits {
                    max_speed: 0.5,
                    max_accel: 1.0,
                    ..MotionLimits::default()
                },
            },
        ),
    ]
}

/// Every motor limit at every sample (rates) and between consecutive samples (accelerations
/// as differences), each with a relative tolerance of 1e-9.
fn check_limits(what: &str, r: &RobotModel, p: &Plan) {
    let l = r.limits;
    let n = p.wheels;
    let lim = |x: Option<f64>| x.unwrap_or(f64::INFINITY) * (1.0 + 1e-9);
    for s in &p.samples {
        for w in &s.wheel_rates[..n] {
            assert!(
                w.abs() <= lim(l.max_wheel_rate),
                "{what}: wheel rate {w} at t {}",
                s.t
            );
        }
        if let Some((_, sd)) = s.steer {
            for w in &sd[..n] {
                assert!(
                    w.abs() <= lim(l.max_steer_rate),
                    "{what}: steer rate {w} at t {}",
                    s.t
                );
            }
        }
    }
    for w in p.samples.windows(2) {
        let dt = w[1].t - w[0].t;
        assert!(dt > 0.0, "{what}: time does not increase at t {}", w[1].t);
        for i in 0..n {
            let acc = (w[1].wheel_rates[i] - w[0].wheel_rates[i]) / dt;
            assert!(
                acc.abs() <= lim(l.max_wheel_accel),
                "{what}: wheel {} accel {acc} at t {}",
                i + 1,
                w[1].t
            );
        }
    }
}

#[test]
fn every_heading_law_plans_on_every_path_kind_and_robot() {
    let mut failures = Vec::new();
    for (set, w) in [("examples/waypoints.toml", shipped()), ("zigzag", zigzag())] {
        let goal = *w.points.last().unwrap();
        for (pk, path) in paths(&w) {
            for (law_name, law) in laws(&path, &w) {
                for name in PRESETS {
                    let r = robot(name);
                    for (tn, timing) in timings() {
                        let what = format!("{set} {pk} {law_name} {name} {tn}");
                        let opts = PlanOptions {
                            timing,
                            on_limit: OnLimit::Retime,
                            rate: 100.0,
                            initial_steer: InitialSteer::Aligned,
                        };
                        let p = match plan(&path, &law, &r, &opts) {
                            Ok(p) => p.plan,
                            Err(e) => {
                                failures.push(format!("{what}: {e}"));
                                continue;
                            }
                        };
                        check_limits(&what, &r, &p);
                        // Forward along the path only: the distance travelled between samples
                        // adds up to (at most) the path's length; an arc length jumping back
                        // and forth would add more.
                        let travelled: f64 = p
                            .samples
                            .windows(2)
                            .map(|s| (s[1].pose.x - s[0].pose.x).hypot(s[1].pose.y - s[0].pose.y))
                            .sum();
                        assert!(
                            travelled <= path.length() * (1.0 + 1e-6),
                            "{what}: travelled {travelled} m on a {} m path",
                            path.length()
                        );
                        let end = p.samples.last().unwrap();
                        assert!(
                            (end.pose.x - goal[0]).abs() < 1e-9
                                && (end.pose.y - goal[1]).abs() < 1e-9,
                            "{what}: ends at ({}, {})",
                            end.pose.x,
                            end.pose.y
                        );
                        assert!(
                            end.wheel_rates.iter().all(|v| v.abs() < 1e-9),
                            "{what}: not at rest at the end"
                        );
                    }
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} plans failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
