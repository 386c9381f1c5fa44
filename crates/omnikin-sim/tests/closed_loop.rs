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
        gravity_only_imu: false,
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

/// The preset as loaded (the fitted `com_depth`, the vinyl floor): what paper 000's series
/// and the targets are measured on.
fn fitted() -> SphereDynamics {
    SphereDynamics::from_description(&preset()).unwrap()
}

/// [`options`] on the fitted preset with the dynamic profile's hardware variation, and the
/// tilt feedback designed from `model` (`None`: off).
fn tilted(
    camera: Option<(CameraProfile, CameraGaps)>,
    model: Option<SphereDynamics>,
) -> ClosedLoopOptions {
    let mut o = options(camera);
    o.profile = DynamicProfile::hardware(fitted());
    o.config.tilt = model.map(|m| closed_loop::tilt_feedback(&m));
    o
}

/// Max deviation (% of the path) and fitted radius ratio over `trials` trials, seed 7.
fn score(plan: &Plan, opts: &ClosedLoopOptions, trials: usize) -> (f64, Option<f64>) {
    let robot = preset().build::<f64>().unwrap();
    let runs: Vec<Run> = (0..trials)
        .map(|i| Run {
            xy: closed_loop::run(robot, plan, opts, 7, i)
                .unwrap()
                .trial
                .tracked,
            heading: None,
        })
        .collect();
    let m = evaluate(plan, &runs).unwrap().metrics;
    (m.max_deviation_pct_of_path, m.radius_ratio)
}

/// The targets on paper 000's fast circles (4 trials each with the hardware variation, the
/// camera position-only as the paper's video): with the tilt feedback designed from the
/// linearised dynamics the 0.4 and 0.5 m/s circles land within 3 % of the 0.2 m radius and 7 %
/// of the path; without it (the premise) they land ≥ 10 % too large.
#[test]
fn tilt_feedback_lands_the_fast_circles() {
    for name in ["circle-0.4", "circle-0.5"] {
        let plan = series(name);
        let (dev, ratio) = score(&plan, &tilted(paper_camera(), Some(fitted())), 4);
        let ratio = ratio.unwrap();
        println!("{name}: {dev:.2} % / {ratio:.3}");
        assert!(
            dev < 7.0 && (ratio - 1.0).abs() < 0.03,
            "{name}: {dev} % / {ratio}"
        );
        let (_, without) = score(&plan, &tilted(paper_camera(), None), 2);
        assert!(without.unwrap() > 1.1, "the premise on {name}: {without:?}");
    }
}

/// Every series of paper 000 within 7 % of the path in closed loop (camera, tilt feedback,
/// 3 trials each), and within 10 % with the controller's centre-of-mass depth 20 % wrong either
/// way (the plant keeps the fitted one).
#[test]
fn every_series_within_seven_percent_and_ten_with_the_depth_wrong() {
    let names = [
        "square-0.1",
        "square-0.2",
        "square-0.4",
        "square-0.5",
        "circle-0.1",
        "circle-0.2",
        "circle-0.4",
        "circle-0.5",
    ];
    for name in names {
        let plan = series(name);
        let (dev, _) = score(&plan, &tilted(paper_camera(), Some(fitted())), 3);
        assert!(dev < 7.0, "{name}: {dev} %");
    }
    for f in [0.8, 1.2] {
        let mut m = fitted();
        m.com_depth *= f;
        for name in ["square-0.5", "circle-0.4", "circle-0.5"] {
            let (dev, ratio) = score(&series(name), &tilted(paper_camera(), Some(m)), 2);
            println!("com_depth x{f}: {name}: {dev:.2} % / {ratio:?}");
            assert!(dev < 10.0, "com_depth x{f}: {name}: {dev} %");
        }
    }
}

/// The camera gone for 2 s in the middle of the 0.5 m/s circle (3 turns, from 2.75 s), tilt
/// feedback on. Paper 000's measure is the deviation in % of the distance travelled; on a
/// three-turn run that would allow 26 cm, so the bound here is 7 % of **one** turn's path
/// (1.257 m: 88 mm, the single-turn series' allowance): the tracked point's distance from the
/// planned circle stays under it while the camera is gone (bounded), and from 2 s after the
/// return it is under it and within 1.5 cm of the uninterrupted run's over the same time
/// (measured: 58 mm during, 40 mm after against 39 mm uninterrupted; the uninterrupted run
/// rides 4–6 cm off the circle at this speed, see docs/closed-loop.md).
#[test]
fn with_tilt_feedback_a_camera_outage_stays_bounded_and_recovers_within_two_seconds() {
    let plan = circle(5.0, 3.0);
    let gaps = CameraGaps {
        dropout_probability: 0.0,
        outage: Some([2.75, 4.75]),
    };
    let out = run(
        &plan,
        &tilted(Some((CameraProfile::paper_000(), gaps)), Some(fitted())),
        1,
    );
    let full = run(&plan, &tilted(paper_camera(), Some(fitted())), 1);
    let end = plan.samples.last().unwrap().t + 1.0;
    let (off, off_full) = (
        off_circle(&plan, &out.trial),
        off_circle(&plan, &full.trial),
    );
    let allowance = 0.07 * 2.0 * std::f64::consts::PI * 0.2;
    let during = max_over(&plan, &off, 2.75, 4.79);
    let after = max_over(&plan, &off, 6.79, end);
    let after_full = max_over(&plan, &off_full, 6.79, end);
    println!(
        "off the circle: during {during:.4} m, from 2 s after {after:.4} m (uninterrupted {after_full:.4} m)"
    );
    assert!(during < allowance, "{during}");
    assert!(
        after < allowance && after < after_full + 0.015,
        "{after} vs {after_full}"
    );
}

/// The tilt feedback's design and `check`'s figures agree with the plant's own rocking
/// (`SphereDynamics::rocking_frequency`, a separate code path for `J`): the designed damping
/// ratio is [`closed_loop::TILT_DAMPING_RATIO`], the crossover lies above the rocking, and the
/// delay margin exceeds the 100 Hz loop's own delay (≈ 15 ms) several times.
#[test]
fn the_tilt_design_matches_the_plants_rocking() {
    let p = fitted();
    let tf = closed_loop::tilt_feedback(&p);
    let m = closed_loop::tilt_margins(&p, &tf);
    assert!((m.open_frequency - p.rocking_frequency(0)).abs() < 1e-9 * m.open_frequency);
    assert!((m.damping_ratio - closed_loop::TILT_DAMPING_RATIO).abs() < 1e-12);
    assert!(m.crossover > m.open_frequency);
    assert!(m.delay_margin > 4.0 * 0.015, "{m:?}");
    // The same gain on a plant whose centre of mass is 20 % deeper: a stiffer pendulum (m_p g h
    // up, J down) and less leverage (B = M R² + I_s − m_p h R down) damp less, ζ ≈ 0.59.
    let mut deeper = p;
    deeper.com_depth *= 1.2;
    let z = closed_loop::tilt_margins(&deeper, &tf).damping_ratio;
    assert!(z < m.damping_ratio && z > 0.5, "{z}");
}
