//! The sphere in closed loop (issue 36): the core runtime on the dynamic plant with the
//! simulated camera lands paper 000's fast circle where open loop misses it, rides out a
//! camera outage, and is deterministic for a seed.

use omnikin::description::RobotDescription;
use omnikin_plan::generators::Circle;
use omnikin_plan::planner::plan;
use omnikin_plan::{Plan, RobotModel};
use omnikin_sim::closed_loop::{self, ClosedLoopOptions, ClosedLoopTrial};
use omnikin_sim::dynamics::sphere::{DynamicProfile, SphereDynamics, simulate_plan};
use omnikin_sim::metrics::{Metrics, Run, evaluate, fit_circle};
use omnikin_sim::reproduce::sphere_2019_series;
use omnikin_sim::sensors::{CameraGaps, CameraProfile};

fn preset() -> RobotDescription {
    RobotDescription::preset("sphere-omni").unwrap()
}

/// Paper 000's series `name` (as `reproduce sphere-2019` plans it, 100 Hz).
fn series(name: &str) -> Plan {
    sphere_2019_series(&preset(), 100.0)
        .unwrap()
        .into_iter()
        .find(|s| s.name == name)
        .unwrap()
        .plan
}

/// The plant these tests' bounds were measured on: the preset's dynamics with the centre-of-mass
/// depth at its parts estimate (0.08 m) and the hard floor's pivot friction (0.005 N·m), the
/// preset of the day the bounds were set. Pinned, so that re-fitting the preset (`reproduce
/// --fit-to-paper` moved `com_depth` to 0.0872 m and the floor to vinyl's 0.021 N·m) does not
/// move the tests: on that preset the 0.4 m/s circle's open loop grows ×1.400 and the closed
/// loop lands ×1.211 (53 % of the growth left, against ×1.89 → ×1.25 here).
fn params() -> SphereDynamics {
    let mut p = SphereDynamics::from_description(&preset()).unwrap();
    p.com_depth = 0.08;
    p.pivot_friction = 0.005;
    p
}

fn options(camera: Option<(CameraProfile, CameraGaps)>) -> ClosedLoopOptions {
    let d = preset();
    let body = d.body_limits();
    ClosedLoopOptions {
        config: closed_loop::config(
            100.0,
            d.limits.max_wheel_rate,
            d.limits.max_wheel_accel,
            body.max_accel,
            body.max_yaw_accel,
        ),
        profile: DynamicProfile::exact(params()),
        camera,
    }
}

fn paper_camera() -> Option<(CameraProfile, CameraGaps)> {
    Some((CameraProfile::paper_000(), CameraGaps::default()))
}

fn run(plan: &Plan, opts: &ClosedLoopOptions, seed: u64) -> ClosedLoopTrial {
    let robot = preset().build::<f64>().unwrap();
    closed_loop::run(robot, plan, opts, seed, 0).unwrap()
}

fn metrics(plan: &Plan, trial: &omnikin_sim::Trial) -> Metrics {
    let runs = [Run {
        xy: trial.tracked.clone(),
        heading: None,
    }];
    evaluate(plan, &runs).unwrap().metrics
}

/// Paper 000's circle at `k` (speed 0.1·k m/s, radius 0.2 m) for `turns` turns.
fn circle(k: f64, turns: f64) -> Plan {
    let mut c = Circle::paper(k);
    c.turns = turns;
    let model = RobotModel::from_description(&preset()).unwrap();
    plan(&c.path().unwrap(), &c.heading(), &model, &c.options(100.0))
        .unwrap()
        .plan
}

/// Distance of each tracked point from the plan's circle (centre and radius of the plan's
/// path), m.
fn off_circle(plan: &Plan, trial: &omnikin_sim::Trial) -> Vec<f64> {
    let pts: Vec<[f64; 2]> = plan.samples.iter().map(|s| [s.pose.x, s.pose.y]).collect();
    let c = fit_circle(&pts).unwrap();
    trial
        .tracked
        .iter()
        .map(|p| ((p[0] - c.center[0]).hypot(p[1] - c.center[1]) - c.radius).abs())
        .collect()
}

fn max_over(plan: &Plan, v: &[f64], from: f64, to: f64) -> f64 {
    plan.samples
        .iter()
        .zip(v)
        .filter(|(s, _)| s.t >= from && s.t < to)
        .map(|(_, e)| *e)
        .fold(0.0, f64::max)
}

/// Paper 000's 0.4 m/s circle grows ×1.89 open loop on [`params`] (the lean law plus the
/// start's rocking); the runtime on the same plant — its trajectory loop with its default
/// gains, the heading from the platform's gyro, the camera fused — lands 1.25 (measured,
/// seed 1). The bound asks for at least half of the growth removed, relative to the open loop
/// of the same model, with room (0.25 of 0.89 measured against 0.5 asked) for a change of the
/// plant's damping. (It is not independent of the parameters: on the re-fitted preset half of
/// the growth is not quite removed, see [`params`].)
#[test]
fn closed_loop_removes_most_of_the_fast_circles_growth() {
    let plan = series("circle-0.4");
    let open = metrics(&plan, &simulate_plan(params(), &plan).unwrap().trial)
        .radius_ratio
        .unwrap();
    let cam = run(&plan, &options(paper_camera()), 1);
    let closed = metrics(&plan, &cam.trial).radius_ratio.unwrap();
    assert!(open - 1.0 > 0.3, "the premise: open loop misses ({open})");
    assert!(
        (closed - 1.0).abs() < 0.5 * (open - 1.0),
        "closed loop {closed} against open loop {open}"
    );
    // The camera's fixes reach the fusion and pass its gate.
    assert!(
        cam.fixes_sent > 70 && cam.fixes.accepted as u64 == cam.fixes_sent,
        "{cam:?}"
    );
}

/// The 0.5 m/s circle, three turns, the camera gone for 2 s from 2.75 s: while it is gone the
/// estimate drifts (more than with the camera: the fixes were doing something) but stays
/// within 0.5 m; from 0.5 s after its return the estimate is as good as the uninterrupted
/// run's (within 3 cm: at this speed the rocking keeps even that one's error near 9 cm), and
/// the path is no worse than the uninterrupted run's by more than 5 cm.
#[test]
fn a_camera_outage_stays_bounded_and_recovers() {
    let plan = circle(5.0, 3.0);
    let full = run(&plan, &options(paper_camera()), 1);
    let gaps = CameraGaps {
        dropout_probability: 0.0,
        outage: Some([2.75, 4.75]),
    };
    let out = run(&plan, &options(Some((CameraProfile::paper_000(), gaps))), 1);
    let end = plan.samples.last().unwrap().t + 1.0;
    let during = max_over(&plan, &out.estimate_error, 2.75, 4.79);
    let during_full = max_over(&plan, &full.estimate_error, 2.75, 4.79);
    let after = max_over(&plan, &out.estimate_error, 5.29, end);
    let after_full = max_over(&plan, &full.estimate_error, 5.29, end);
    let (df, dout) = (
        off_circle(&plan, &full.trial),
        off_circle(&plan, &out.trial),
    );
    let path_full = max_over(&plan, &df, 4.79, end);
    let path_out = max_over(&plan, &dout, 4.79, end);
    println!(
        "during {during} (full {during_full}) after {after} (full {after_full}) path {path_out} (full {path_full})"
    );
    assert_eq!(
        full.fixes_sent - out.fixes_sent,
        50,
        "2 s of 25 frames/s lost"
    );
    assert!(
        during > during_full && during < 0.5,
        "{during} vs {during_full}"
    );
    assert!(after < after_full + 0.03, "{after} vs {after_full}");
    assert!(path_out < path_full + 0.05, "{path_out} vs {path_full}");
}

/// One seed, one run (the robot's draws, the wheel fluctuation, the camera's noise); another
/// seed, another run.
#[test]
fn a_seed_gives_one_run() {
    let plan = series("square-0.2");
    let mut o = options(paper_camera());
    o.profile = DynamicProfile::hardware(o.profile.params);
    let a = run(&plan, &o, 3);
    assert_eq!(a, run(&plan, &o, 3));
    assert_ne!(a.trial, run(&plan, &o, 4).trial);
}
