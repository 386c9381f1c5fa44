//! Plans for every robot kind (every preset: sphere-omni, ballbot, caster3, kiwi, x-drive,
//! mecanum, swerve4), checked against the core's uniform API, not the planner's internals:
//! each sample's motor rates are the core inverse of its sampled twist, every motor channel
//! stays within its limit, the plan CSV carries one column per wheel (and steer motor) and
//! reads back unchanged, and a swerve's steer angles are the inverse's set-points with steer
//! rates that are the time derivative of its angles.

use omnikin::description::{PRESETS, RobotDescription};
use omnikin::{Actuators, wrap_angle};
use omnikin_plan::generators::{Circle, Square};
use omnikin_plan::heading::HeadingLaw;
use omnikin_plan::path::{Corners, Path};
use omnikin_plan::planner::{InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing, plan};
use omnikin_plan::profile::ProfileKind;
use omnikin_plan::{Plan, RobotModel, per_wheel};

fn robot(name: &str) -> RobotModel {
    RobotModel::from_description(&RobotDescription::preset(name).unwrap()).unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

/// The plans every kind must make: paper 000's square (at a speed that needs re-timing for
/// some robots) and circle, a spline under the tangent law (time-optimal) and a filleted
/// polyline under a constant heading.
fn plans(robot: &RobotModel, rate: f64) -> Vec<(&'static str, Plan)> {
    let mut out = Vec::new();
    let sq = Square::paper(2.0);
    let p = plan(
        &sq.path().unwrap(),
        &sq.heading(),
        robot,
        &sq.options(rate, OnLimit::Retime),
    )
    .unwrap();
    out.push(("square", p.plan));
    let fast = Square {
        speed: 4.0,
        ..Square::paper(1.0)
    };
    let p = plan(
        &fast.path().unwrap(),
        &fast.heading(),
        robot,
        &fast.options(rate, OnLimit::Retime),
    )
    .unwrap();
    out.push(("fast square", p.plan));
    let c = Circle {
        ramp: Some(1.0),
        ..Circle::paper(2.0)
    };
    let p = plan(&c.path().unwrap(), &c.heading(), robot, &c.options(rate)).unwrap();
    out.push(("circle", p.plan));
    let wps = [[0.0, 0.0], [0.5, 0.2], [1.0, -0.1], [1.4, 0.4], [1.2, 0.9]];
    let limits = MotionLimits {
        max_speed: 0.5,
        max_accel: 1.0,
        ..MotionLimits::default()
    };
    let opts = |timing| PlanOptions {
        timing,
        on_limit: OnLimit::Retime,
        rate,
        initial_steer: InitialSteer::Aligned,
    };
    let p = plan(
        &Path::spline(&wps).unwrap(),
        &HeadingLaw::Tangent { offset: 0.2 },
        robot,
        &opts(Timing::TimeOptimal { limits }),
    )
    .unwrap();
    out.push(("spline", p.plan));
    let p = plan(
        &Path::polyline(&wps, Corners::Fillet { radius: 0.15 }).unwrap(),
        &HeadingLaw::Constant(0.4),
        robot,
        &opts(Timing::Profile {
            kind: ProfileKind::SCurve,
            limits,
        }),
    )
    .unwrap();
    out.push(("fillets", p.plan));
    out
}

#[test]
fn every_kind_plans_rates_equal_to_the_core_inverse_within_its_limits() {
    for (name, _) in PRESETS {
        let robot = robot(name);
        let n = robot.wheels();
        let set_point = robot.model.kind().steer_is_set_point();
        for (what, p) in plans(&robot, 100.0) {
            assert_eq!(p.wheels, n, "{name} {what}");
            assert_eq!(p.steerable(), robot.steerable(), "{name} {what}");
            assert!(p.samples.len() > 100, "{name} {what}");
            let mut moved = 0.0_f64;
            for (k, s) in p.samples.iter().enumerate() {
                let body = s.twist.to_robot(s.pose.heading);
                // The steer state the inverse starts from: a caster's angles are the state
                // the sample carries; a swerve's current angles are the previous sample's.
                let current = match s.steer {
                    Some((g, _)) if !set_point => Actuators::at_steer(&g[..n]),
                    Some((g, _)) => {
                        let prev = p.samples[k.saturating_sub(1)].steer.unwrap().0;
                        Actuators::at_steer(&if k == 0 { g } else { prev }[..n])
                    }
                    None => Actuators::zero(),
                };
                let want = robot.model.inverse(body, &current).unwrap();
                for i in 0..n {
                    assert!(
                        close(s.wheel_rates[i], want.wheel_rates[i], 1e-12),
                        "{name} {what} t {} wheel {}: {} vs {}",
                        s.t,
                        i + 1,
                        s.wheel_rates[i],
                        want.wheel_rates[i]
                    );
                }
                assert!(s.wheel_rates[n..].iter().all(|&w| w == 0.0));
                match s.steer {
                    // At rest a swerve's modules follow the planner's re-steer (see the
                    // test below), which the inverse at zero twist (hold the angle) is not.
                    Some((_, sd)) if set_point && body == omnikin::Twist2::new(0.0, 0.0, 0.0) => {
                        assert!(sd[n..].iter().all(|&r| r == 0.0));
                    }
                    Some((g, sd)) if set_point => {
                        for i in 0..n {
                            let d = wrap_angle(g[i] - want.steer_angles[i]);
                            assert!(d.abs() <= 1e-12, "{name} {what} t {} steer {}", s.t, i + 1);
                        }
                        assert!(sd[n..].iter().all(|&r| r == 0.0));
                    }
                    Some((_, sd)) => {
                        for i in 0..n {
                            assert!(
                                close(sd[i], want.steer_rates[i], 1e-12),
                                "{name} {what} t {} steer rate {}: {} vs {}",
                                s.t,
                                i + 1,
                                sd[i],
                                want.steer_rates[i]
                            );
                        }
                    }
                    None => assert!(!robot.steerable()),
                }
                moved = moved.max(s.wheel_rates[..n].iter().fold(0.0, |a, w| a.max(w.abs())));
            }
            assert!(moved > 0.1, "{name} {what}: no wheel turns");
            // Every channel within its limit: rates at the samples, accelerations as
            // differences of consecutive samples.
            let value = |s: &omnikin_plan::Sample, ch: usize| {
                if ch < n {
                    s.wheel_rates[ch]
                } else {
                    s.steer.unwrap().1[ch - n]
                }
            };
            let chans = if robot.steerable() { 2 * n } else { n };
            let l = robot.limits;
            for ch in 0..chans {
                let (rate_limit, accel_limit) = if ch < n {
                    (l.max_wheel_rate, l.max_wheel_accel)
                } else {
                    (l.max_steer_rate, l.max_steer_accel)
                };
                for w in p.samples.windows(2) {
                    if let Some(lim) = rate_limit {
                        assert!(
                            value(&w[1], ch).abs() <= lim * (1.0 + 1e-9),
                            "{name} {what} channel {ch} rate {} > {lim}",
                            value(&w[1], ch)
                        );
                    }
                    if let Some(lim) = accel_limit {
                        let a = (value(&w[1], ch) - value(&w[0], ch)) / (w[1].t - w[0].t);
                        assert!(
                            a.abs() <= lim * (1.0 + 1e-9),
                            "{name} {what} channel {ch} accel {a} > {lim} at t {}",
                            w[1].t
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn a_limited_square_is_slowed_to_a_motor_limit_for_every_kind() {
    // The fast square needs more than some motor limit of every preset at the requested speed:
    // re-timed, some channel's peak rate or acceleration is close to its limit (a limit that
    // binds, not a slack one) and none is over.
    for (name, _) in PRESETS {
        let robot = robot(name);
        let (_, p) = plans(&robot, 100.0).remove(1);
        let l = robot.limits;
        let mut worst = 0.0_f64;
        for w in p.samples.windows(2) {
            for i in 0..robot.wheels() {
                let a = (w[1].wheel_rates[i] - w[0].wheel_rates[i]) / (w[1].t - w[0].t);
                worst = worst.max(w[1].wheel_rates[i].abs() / l.max_wheel_rate.unwrap());
                worst = worst.max(a.abs() / l.max_wheel_accel.unwrap());
            }
        }
        assert!(worst <= 1.0 + 1e-9, "{name}: {worst}");
        assert!(worst >= 0.5, "{name}: every limit slack ({worst})");
    }
}

#[test]
fn plan_files_have_one_column_per_motor_and_read_back() {
    for (name, _) in PRESETS {
        let robot = robot(name);
        let n = robot.wheels();
        for (what, p) in plans(&robot, 50.0) {
            let mut csv = Vec::new();
            p.write_csv(&mut csv).unwrap();
            let text = String::from_utf8(csv.clone()).unwrap();
            let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
            let mut want = vec!["t", "x", "y", "heading", "vx", "vy", "yaw_rate"]
                .into_iter()
                .map(String::from)
                .collect::<Vec<_>>();
            want.extend((1..=n).map(|i| format!("w{i}")));
            if robot.steerable() {
                want.extend((1..=n).map(|i| format!("s{i}")));
                want.extend((1..=n).map(|i| format!("sd{i}")));
            }
            assert_eq!(header, want, "{name} {what}");
            let back = Plan::read_csv(&csv[..], "plan.csv").unwrap();
            assert_eq!(back, p, "{name} {what}: CSV round trip");
        }
    }
}

#[test]
fn swerve_steer_rates_are_the_derivative_of_its_steer_angles() {
    let robot = robot("swerve4");
    let dt = 1e-3;
    for (what, p) in plans(&robot, 1.0 / dt) {
        let mut checked = 0;
        let mut turning = 0.0_f64;
        for w in p.samples.windows(3) {
            let (g0, _) = w[0].steer.unwrap();
            let (g2, _) = w[2].steer.unwrap();
            let (_, sd) = w[1].steer.unwrap();
            let (sd0, sd2) = (w[0].steer.unwrap().1, w[2].steer.unwrap().1);
            // Where the curvature jumps (a fillet meets a leg) the steer rate jumps too.
            let smooth = (0..4).all(|i| (sd0[i] - 2.0 * sd[i] + sd2[i]).abs() < 1e-3);
            // Away from stops (where a module is re-aimed at rest) and the end sample.
            let slow = w
                .iter()
                .any(|s| s.wheel_rates[..4].iter().any(|r| r.abs() < 0.2));
            if slow || !smooth || (w[2].t - w[0].t - 2.0 * dt).abs() > 1e-9 {
                continue;
            }
            for i in 0..4 {
                let fd = wrap_angle(g2[i] - g0[i]) / (2.0 * dt);
                assert!(
                    (fd - sd[i]).abs() <= 2e-3 * (1.0 + sd[i].abs()),
                    "{what} t {} module {}: d/dt of the angle {fd} vs steer rate {}",
                    w[1].t,
                    i + 1,
                    sd[i]
                );
                turning = turning.max(sd[i].abs());
            }
            checked += 1;
        }
        assert!(checked > 100, "{what}: {checked} samples checked");
        // Under a constant heading the modules turn with the path's direction.
        if what == "fillets" {
            assert!(turning > 0.05, "{what}: the modules never turn ({turning})");
        }
    }
}

#[test]
fn given_initial_steer_angles_start_every_steerable_plan() {
    for name in ["caster3", "swerve4"] {
        let robot = robot(name);
        let n = robot.wheels();
        let given: Vec<f64> = (0..n).map(|i| 0.3 * i as f64 - 0.4).collect();
        let sq = Square::paper(1.0);
        let mut opts = sq.options(100.0, OnLimit::Retime);
        opts.initial_steer = InitialSteer::Given(per_wheel(&given));
        let p = plan(&sq.path().unwrap(), &sq.heading(), &robot, &opts)
            .unwrap()
            .plan;
        let (g, _) = p.samples[0].steer.unwrap();
        assert_eq!(&g[..n], &given[..], "{name}");
        // Aligned: the swerve's modules point along the first leg (+y) from the start.
        let aligned = plan(
            &sq.path().unwrap(),
            &sq.heading(),
            &robot,
            &sq.options(100.0, OnLimit::Retime),
        )
        .unwrap()
        .plan;
        if robot.model.kind().steer_is_set_point() {
            let (g, _) = aligned.samples[0].steer.unwrap();
            for gi in &g[..n] {
                assert!(
                    (gi - std::f64::consts::FRAC_PI_2).abs() < 1e-12,
                    "{name}: {gi}"
                );
            }
        }
    }
}

#[test]
fn swerve_modules_turn_only_as_fast_as_their_steer_rates_say_even_at_stops() {
    // Squares stop at their corners and turn the modules at rest (a re-steer move); a
    // tangent-law polyline also turns in place. Between any two samples each module's angle
    // changes by no more than its steer rates allow, and every re-steer stays within the
    // steer-rate limit.
    for optimize in [false, true] {
        let mut d = RobotDescription::preset("swerve4").unwrap();
        if let omnikin::description::Geometry::Swerve { optimize: o, .. } = &mut d.geometry {
            *o = optimize;
        }
        let robot = RobotModel::from_description(&d).unwrap();
        let dt = 1e-3;
        let mut all = plans(&robot, 1.0 / dt);
        let wps = [[0.0, 0.0], [0.5, 0.0], [0.5, 0.5], [-0.2, 0.1]];
        let stop = PlanOptions {
            timing: Timing::Profile {
                kind: ProfileKind::Trapezoid,
                limits: MotionLimits::default(),
            },
            on_limit: OnLimit::Retime,
            rate: 1.0 / dt,
            initial_steer: InitialSteer::Given(per_wheel(&[0.3, -2.0, 3.0, 0.0])),
        };
        let p = plan(
            &Path::polyline(&wps, Corners::Stop).unwrap(),
            &HeadingLaw::Tangent { offset: 0.0 },
            &robot,
            &stop,
        )
        .unwrap();
        all.push(("tangent polyline", p.plan));
        let optimal = PlanOptions {
            timing: Timing::TimeOptimal {
                limits: MotionLimits::default(),
            },
            ..stop
        };
        let p = plan(
            &Path::polyline(&wps, Corners::Stop).unwrap(),
            &HeadingLaw::Constant(0.3),
            &robot,
            &optimal,
        )
        .unwrap();
        all.push(("time-optimal polyline", p.plan));
        let limit = robot.limits.max_steer_rate;
        for (what, p) in &all {
            let mut largest = 0.0_f64;
            for w in p.samples.windows(2) {
                let (g0, sd0) = w[0].steer.unwrap();
                let (g1, sd1) = w[1].steer.unwrap();
                let h = w[1].t - w[0].t;
                for i in 0..4 {
                    let step = wrap_angle(g1[i] - g0[i]).abs();
                    let allowed = sd0[i].abs().max(sd1[i].abs()) * h;
                    // A step is a quarter turn or so; the slack covers the change of the
                    // steer rate within a sample interval on curved paths.
                    assert!(
                        step <= 1.1 * allowed + 1e-4,
                        "{what} (optimize {optimize}) t {}: module {} turns {step} rad, its \
                         steer rates allow {allowed}",
                        w[0].t,
                        i + 1
                    );
                    largest = largest.max(sd0[i].abs());
                }
            }
            if let Some(l) = limit {
                assert!(
                    largest <= l * (1.0 + 1e-9),
                    "{what}: steer rate {largest} > {l}"
                );
            }
        }
    }
}
