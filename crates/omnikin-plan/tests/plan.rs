//! End-to-end checks of sampled plans against the core kinematics, written from the
//! conventions and paper 000, not from the planner's internals: differentiating the samples,
//! recomputing the wheel rates, integrating them back through the forward kinematics.

use omnikin::description::RobotDescription;
use omnikin::{Pose2, Robot, Twist2, se2};
use omnikin_plan::generators::{Circle, PAPER_K, Square};
use omnikin_plan::heading::{HeadingLaw, HeadingProfile};
use omnikin_plan::path::{Corners, Path};
use omnikin_plan::planner::{
    InitialSteer, Limiter, MotionLimits, OnLimit, PlanOptions, Planned, Timing, plan,
};
use omnikin_plan::profile::ProfileKind;
use omnikin_plan::{Plan, PlanningError, Quantity, RobotModel};

fn robot(name: &str) -> RobotModel {
    RobotModel::from_description(&RobotDescription::preset(name).unwrap()).unwrap()
}

fn square(k: f64, robot_name: &str) -> Planned {
    let sq = Square::paper(k);
    plan(
        &sq.path().unwrap(),
        &sq.heading(),
        &robot(robot_name),
        &sq.options(100.0, OnLimit::Reject),
    )
    .unwrap()
}

fn circle(k: f64) -> Planned {
    let c = Circle::paper(k);
    plan(
        &c.path().unwrap(),
        &c.heading(),
        &robot("sphere-omni"),
        &c.options(100.0),
    )
    .unwrap()
}

fn spline_plan(robot_name: &str, heading: HeadingLaw, timing: Timing) -> Planned {
    let path =
        Path::spline(&[[0.0, 0.0], [0.6, 0.2], [1.0, 0.9], [0.3, 1.4], [-0.4, 1.0]]).unwrap();
    let opts = PlanOptions {
        timing,
        on_limit: OnLimit::Retime,
        rate: 200.0,
        initial_steer: InitialSteer::Aligned,
    };
    plan(&path, &heading, &robot(robot_name), &opts).unwrap()
}

fn profile(v: f64, a: f64) -> Timing {
    Timing::Profile {
        kind: ProfileKind::Trapezoid,
        limits: MotionLimits {
            max_speed: v,
            max_accel: a,
            ..MotionLimits::default()
        },
    }
}

/// A representative set of plans: every robot, every heading law, every timing.
fn assorted() -> Vec<(String, RobotModel, Planned)> {
    let mut out = Vec::new();
    for k in PAPER_K {
        out.push((
            format!("square k={k}"),
            robot("sphere-omni"),
            square(k, "sphere-omni"),
        ));
        out.push((format!("circle k={k}"), robot("sphere-omni"), circle(k)));
    }
    for name in ["sphere-omni", "ballbot", "caster3"] {
        out.push((
            format!("{name} spline tangent"),
            robot(name),
            spline_plan(name, HeadingLaw::Tangent { offset: 0.0 }, profile(0.4, 1.0)),
        ));
        out.push((
            format!("{name} spline spin, time-optimal"),
            robot(name),
            spline_plan(
                name,
                HeadingLaw::Profile(HeadingProfile::new(&[(0.0, 0.0), (2.0, 3.0)]).unwrap()),
                Timing::TimeOptimal {
                    limits: MotionLimits {
                        max_speed: 1.0,
                        max_accel: 2.0,
                        ..MotionLimits::default()
                    },
                },
            ),
        ));
        out.push((format!("{name} square s-curve tangent"), robot(name), {
            let path =
                Path::polyline(&[[0.0, 0.0], [0.5, 0.0], [0.5, 0.5]], Corners::Stop).unwrap();
            let opts = PlanOptions {
                timing: Timing::Profile {
                    kind: ProfileKind::SCurve,
                    limits: MotionLimits::default(),
                },
                on_limit: OnLimit::Retime,
                rate: 100.0,
                initial_steer: InitialSteer::Aligned,
            };
            plan(
                &path,
                &HeadingLaw::Tangent { offset: 0.0 },
                &robot(name),
                &opts,
            )
            .unwrap()
        }));
    }
    out
}

/// Largest `|Δv/Δt|` between samples of a velocity component.
fn max_rate_of_change(p: &Plan, f: impl Fn(&omnikin_plan::Sample) -> f64) -> f64 {
    p.samples
        .windows(2)
        .map(|w| ((f(&w[1]) - f(&w[0])) / (w[1].t - w[0].t)).abs())
        .fold(0.0, f64::max)
}

#[test]
fn differentiating_positions_reproduces_velocities() {
    for (name, _, planned) in assorted() {
        let p = &planned.plan;
        type Get = fn(&omnikin_plan::Sample) -> f64;
        let comps: [(&str, Get, Get); 3] = [
            ("x", |s| s.pose.x, |s| s.twist.vx),
            ("y", |s| s.pose.y, |s| s.twist.vy),
            ("heading", |s| s.pose.heading, |s| s.twist.yaw_rate),
        ];
        for (label, pos, vel) in comps {
            // Central difference over uniform steps; its error is bounded by the largest
            // acceleration times the step (velocity kinks) plus the curvature term.
            let acc = max_rate_of_change(p, vel);
            for w in p.samples.windows(3) {
                let (h1, h2) = (w[1].t - w[0].t, w[2].t - w[1].t);
                if (h1 - h2).abs() > 1e-9 {
                    continue;
                }
                let d = (pos(&w[2]) - pos(&w[0])) / (h1 + h2);
                let tol = 1e-9 + acc * h1;
                assert!(
                    (d - vel(&w[1])).abs() <= tol,
                    "{name}: d{label}/dt {d} vs {} at t = {} (tol {tol})",
                    vel(&w[1]),
                    w[1].t
                );
            }
        }
    }
}

#[test]
fn wheel_rates_equal_the_core_inverse_kinematics_of_the_sampled_twist() {
    for (name, r, planned) in assorted() {
        for s in &planned.plan.samples {
            let (want, steer_want) = match &r.model {
                Robot::Sphere(m) => (
                    m.wheel_rates(s.twist.to_robot(s.pose.heading), 0.0)
                        .unwrap(),
                    None,
                ),
                Robot::Ballbot(m) => (
                    m.wheel_rates(s.twist.to_robot(s.pose.heading), 0.0)
                        .unwrap(),
                    None,
                ),
                Robot::Caster(m) => {
                    let (g, _) = s.steer.expect("caster plans carry steer columns");
                    let rr = m
                        .motor_rates(s.twist, s.pose.heading, [g[0], g[1], g[2]])
                        .unwrap();
                    (rr.roll, Some(rr.steer))
                }
                _ => unreachable!("assorted() plans sphere, ballbot and caster"),
            };
            for i in 0..3 {
                assert!(
                    (s.wheel_rates[i] - want[i]).abs() <= 1e-12 * (1.0 + want[i].abs()),
                    "{name} t {}",
                    s.t
                );
            }
            if let Some(sw) = steer_want {
                let (_, sd) = s.steer.unwrap();
                for i in 0..3 {
                    assert!(
                        (sd[i] - sw[i]).abs() <= 1e-12 * (1.0 + sw[i].abs()),
                        "{name} t {}",
                        s.t
                    );
                }
            } else {
                assert!(
                    s.steer.is_none(),
                    "{name}: only the caster has steer columns"
                );
            }
        }
    }
}

#[test]
fn limits_hold_at_every_sample() {
    for (name, r, planned) in assorted() {
        let l = r.limits;
        let p = &planned.plan;
        for s in &p.samples {
            for w in s.wheel_rates {
                assert!(
                    w.abs() <= l.max_wheel_rate.unwrap() * (1.0 + 1e-9),
                    "{name}: wheel rate {w} at t {}",
                    s.t
                );
            }
            if let (Some((_, sd)), Some(lim)) = (s.steer, l.max_steer_rate) {
                for w in sd {
                    assert!(
                        w.abs() <= lim * (1.0 + 1e-9),
                        "{name}: steer rate {w} at t {}",
                        s.t
                    );
                }
            }
        }
        for w in p.samples.windows(2) {
            let dt = w[1].t - w[0].t;
            for i in 0..3 {
                let acc = (w[1].wheel_rates[i] - w[0].wheel_rates[i]) / dt;
                assert!(
                    acc.abs() <= l.max_wheel_accel.unwrap() * (1.0 + 1e-9),
                    "{name}: wheel {} accel {acc} at t {}",
                    i + 1,
                    w[1].t
                );
            }
            if let (Some((_, a)), Some((_, b)), Some(lim)) =
                (w[0].steer, w[1].steer, l.max_steer_accel)
            {
                for i in 0..3 {
                    let acc = (b[i] - a[i]) / dt;
                    assert!(
                        acc.abs() <= lim * (1.0 + 1e-9),
                        "{name}: steer {} accel {acc} at t {}",
                        i + 1,
                        w[1].t
                    );
                }
            }
        }
    }
}

#[test]
fn heading_is_continuous() {
    for (name, _, planned) in assorted() {
        let p = &planned.plan;
        let max_rate = p
            .samples
            .iter()
            .map(|s| s.twist.yaw_rate.abs())
            .fold(0.0, f64::max);
        for w in p.samples.windows(2) {
            let dpsi = (w[1].pose.heading - w[0].pose.heading).abs();
            assert!(
                // 1 % over the largest sampled rate: the rate may peak between samples, a jump
                // (a wrap, a missed turn) is far larger.
                dpsi <= 1.01 * max_rate * (w[1].t - w[0].t) + 1e-9,
                "{name}: heading jumps by {dpsi} at t {} (max rate {max_rate}, rates {} {})",
                w[1].t,
                w[0].twist.yaw_rate,
                w[1].twist.yaw_rate
            );
        }
    }
}

#[test]
fn square_stops_at_each_corner_and_keeps_its_heading() {
    for k in PAPER_K {
        let planned = square(k, "sphere-omni");
        let p = &planned.plan;
        let l = 0.4;
        // Eq. 6.1: legs +y, +x, −y, −x from the origin.
        for corner in [[0.0, 0.0], [0.0, l], [l, l], [l, 0.0], [0.0, 0.0]] {
            let at_rest = p.samples.iter().any(|s| {
                (s.pose.x - corner[0]).hypot(s.pose.y - corner[1]) < 1e-9
                    && s.twist.vx.hypot(s.twist.vy) < 1e-9
                    && s.wheel_rates.iter().all(|w| w.abs() < 1e-9)
            });
            assert!(at_rest, "k={k}: no sample at rest at corner {corner:?}");
        }
        // Direction of each leg at its middle (t = (j + 0.5) · leg time).
        let leg = (1.0 + 0.05) * l / (0.1 * k);
        for (j, dir) in [[0.0, 1.0], [1.0, 0.0], [0.0, -1.0], [-1.0, 0.0]]
            .iter()
            .enumerate()
        {
            let t = (j as f64 + 0.5) * leg;
            let s = p
                .samples
                .iter()
                .min_by(|a, b| (a.t - t).abs().total_cmp(&(b.t - t).abs()))
                .unwrap();
            assert!(
                (s.twist.vx - 0.1 * k * dir[0]).abs() < 1e-9
                    && (s.twist.vy - 0.1 * k * dir[1]).abs() < 1e-9,
                "k={k} leg {j}: {:?}",
                s.twist
            );
        }
        assert!(
            p.samples
                .iter()
                .all(|s| s.pose.heading == 0.0 && s.twist.yaw_rate == 0.0)
        );
        assert!((planned.report.duration - 4.0 * leg).abs() < 1e-9);
    }
}

#[test]
fn circle_closes_on_itself_and_follows_eq_6_3() {
    for k in PAPER_K {
        let planned = circle(k);
        let (w0, rt) = (0.5 * k, 0.2);
        let p = &planned.plan;
        let (a, b) = (p.samples.first().unwrap(), p.samples.last().unwrap());
        assert!(
            (a.pose.x - b.pose.x).abs() < 1e-9 && (a.pose.y - b.pose.y).abs() < 1e-9,
            "k={k}: {a:?} vs {b:?}"
        );
        assert!((b.pose.heading - a.pose.heading - std::f64::consts::TAU).abs() < 1e-9);
        // x = Rt cos ω0 t, y = Rt sin ω0 t, ψ = ω0 t at every sample.
        for s in &p.samples {
            let th = w0 * s.t;
            assert!(
                (s.pose.x - rt * th.cos()).abs() < 1e-9 && (s.pose.y - rt * th.sin()).abs() < 1e-9,
                "k={k} t={}",
                s.t
            );
            assert!(
                (s.pose.heading - th).abs() < 1e-9,
                "k={k} t={}: ψ {}",
                s.t,
                s.pose.heading
            );
        }
        assert!(planned.report.starts_moving);
    }
}

/// End-point and largest along-the-way position errors (m) of a replay.
struct Replay {
    end_mid: f64,
    max_mid: f64,
    end_hold: f64,
    max_hold: f64,
}

/// Integrates the planned wheel rates through the core forward kinematics
/// (`SphereOmni::body_twist` + `se2::integrate`) from the first sample's pose, holding over each
/// step either the mean of the two samples' rates (`mid`) or the earlier sample's (`hold`,
/// zero-order hold, as a controller updating at the sample rate would), and compares every
/// reached pose with the plan's.
fn replay(r: &RobotModel, p: &Plan) -> Replay {
    let Robot::Sphere(m) = &r.model else {
        panic!("sphere only")
    };
    let mut mid = p.samples[0].pose;
    let mut hold = mid;
    let (mut max_mid, mut max_hold) = (0.0_f64, 0.0_f64);
    let err = |q: Pose2<f64>, want: Pose2<f64>| (q.x - want.x).hypot(q.y - want.y);
    for w in p.samples.windows(2) {
        let dt = w[1].t - w[0].t;
        let avg: [f64; 3] =
            core::array::from_fn(|i| 0.5 * (w[0].wheel_rates[i] + w[1].wheel_rates[i]));
        mid = se2::integrate(mid, m.body_twist(avg, 0.0).unwrap(), dt);
        let w0 = w[0].wheel_rates;
        hold = se2::integrate(hold, m.body_twist([w0[0], w0[1], w0[2]], 0.0).unwrap(), dt);
        max_mid = max_mid.max(err(mid, w[1].pose));
        max_hold = max_hold.max(err(hold, w[1].pose));
    }
    let end = p.samples.last().unwrap().pose;
    Replay {
        end_mid: err(mid, end),
        max_mid,
        end_hold: err(hold, end),
        max_hold,
    }
}

#[test]
fn forward_kinematics_of_the_planned_wheel_rates_reproduce_the_path() {
    let r = robot("sphere-omni");
    println!(
        "replaying the planned wheel rates through the forward kinematics (sphere-omni, 100 Hz)"
    );
    println!(
        "{:<8} {:>9} {:>14} {:>14} {:>14} {:>14}",
        "plan", "V [m/s]", "end, mean [m]", "max, mean [m]", "end, hold [m]", "max, hold [m]"
    );
    for k in PAPER_K {
        for (name, planned) in [("square", square(k, "sphere-omni")), ("circle", circle(k))] {
            let e = replay(&r, &planned.plan);
            println!(
                "{name:<8} {:>9.1} {:>14.2e} {:>14.2e} {:>14.2e} {:>14.2e}",
                0.1 * k,
                e.end_mid,
                e.max_mid,
                e.end_hold,
                e.max_hold
            );
            // Straight legs with ramps that start and end on samples, and a constant twist on
            // the circle: the mean-rate replay is exact to rounding; the hold replay lags by
            // at most one step's travel.
            assert!(
                e.end_mid < 1e-9 && e.max_mid < 1e-9,
                "{name} k={k}: {}",
                e.max_mid
            );
            assert!(
                e.max_hold <= 0.1 * k * 0.01 + 1e-9,
                "{name} k={k}: {}",
                e.max_hold
            );
        }
    }
    // Off-grid ramps and a curved path: a spline sampled at 90 Hz on the ballbot-free sphere.
    let path = Path::spline(&[[0.0, 0.0], [0.5, 0.3], [1.0, 0.0], [1.5, 0.4]]).unwrap();
    let opts = PlanOptions {
        timing: profile(0.3, 0.7),
        on_limit: OnLimit::Retime,
        rate: 90.0,
        initial_steer: InitialSteer::Aligned,
    };
    let planned = plan(&path, &HeadingLaw::Tangent { offset: 0.0 }, &r, &opts).unwrap();
    let e = replay(&r, &planned.plan);
    println!(
        "spline, tangent heading, 90 Hz: end {:.2e} m, max {:.2e} m (mean rates); end {:.2e} m, max {:.2e} m (hold)",
        e.end_mid, e.max_mid, e.end_hold, e.max_hold
    );
    assert!(e.max_mid < 2e-4, "{}", e.max_mid);
}

#[test]
fn too_fast_circle_is_rejected_with_the_exact_reason() {
    let r = robot("sphere-omni");
    let c = Circle {
        radius: 0.2,
        omega: 3.5,
        turns: 1.0,
        ramp: None,
        face_motion: false,
    };
    let e = plan(&c.path().unwrap(), &c.heading(), &r, &c.options(100.0)).unwrap_err();
    // Independent value: platform-frame twist (0, Rt ω0, ω0) (eq. 6.3 in the platform frame).
    let Robot::Sphere(m) = &r.model else {
        unreachable!()
    };
    let w = m
        .wheel_rates(Twist2::new(0.0, 0.2 * 3.5, 3.5), 0.0)
        .unwrap();
    let (i, peak) = w
        .iter()
        .enumerate()
        .map(|(i, v)| (i, v.abs()))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    let PlanningError::LimitExceeded(v) = &e else {
        panic!("expected a limit error, got {e}")
    };
    assert_eq!(v.quantity, Quantity::WheelRate);
    assert_eq!(v.motor, i + 1);
    assert!((v.needed - peak).abs() < 1e-9, "{} vs {peak}", v.needed);
    let msg = e.to_string();
    let want = format!("wheel {} needs {:.2} rad/s at t = ", i + 1, peak);
    assert!(msg.starts_with(&want), "{msg}");
    assert!(
        msg.contains(&format!(
            "limit 12 rad/s (+{:.1} %",
            (peak / 12.0 - 1.0) * 100.0
        )),
        "{msg}"
    );
}

#[test]
fn too_fast_square_is_retimed_and_says_why() {
    let r = robot("sphere-omni");
    let sq = Square {
        side: 1.0,
        speed: 1.2,
        ramp_fraction: 0.2,
        profile: ProfileKind::Trapezoid,
    };
    let planned = plan(
        &sq.path().unwrap(),
        &sq.heading(),
        &r,
        &sq.options(100.0, OnLimit::Retime),
    )
    .unwrap();
    let rep = &planned.report;
    assert_eq!(rep.retimed.len(), 4, "{rep:?}");
    for rt in &rep.retimed {
        assert!(rt.factor < 1.0);
        assert!(
            matches!(
                rt.limiter,
                Limiter::Motor {
                    quantity: Quantity::WheelRate,
                    ..
                }
            ),
            "{rt:?}"
        );
    }
    // The fastest leg direction of the sphere (`omnikin check`): about 0.69–0.76 m/s at 12 rad/s.
    let v_peak = planned
        .plan
        .samples
        .iter()
        .map(|s| s.twist.vx.hypot(s.twist.vy))
        .fold(0.0, f64::max);
    assert!(v_peak > 0.6 && v_peak < 0.76, "{v_peak}");
    let peak = rep
        .peaks
        .iter()
        .find(|p| p.quantity == Quantity::WheelRate)
        .unwrap();
    assert!(peak.value <= 12.0 && peak.value > 11.9, "{peak:?}");
    // Rejecting instead names the wheel.
    let e = plan(
        &sq.path().unwrap(),
        &sq.heading(),
        &r,
        &sq.options(100.0, OnLimit::Reject),
    )
    .unwrap_err();
    assert!(e.to_string().contains("limit 12 rad/s"), "{e}");
}

#[test]
fn time_optimal_is_no_slower_than_a_profile_and_uses_the_motor_limits() {
    for name in ["sphere-omni", "ballbot", "caster3"] {
        let lim = MotionLimits {
            max_speed: 5.0,
            max_accel: 5.0,
            ..MotionLimits::default()
        };
        let fast = spline_plan(
            name,
            HeadingLaw::Tangent { offset: 0.0 },
            Timing::TimeOptimal { limits: lim },
        );
        let prof = spline_plan(
            name,
            HeadingLaw::Tangent { offset: 0.0 },
            Timing::Profile {
                kind: ProfileKind::Trapezoid,
                limits: lim,
            },
        );
        assert!(
            fast.report.duration <= prof.report.duration * 1.001,
            "{name}: {} vs {}",
            fast.report.duration,
            prof.report.duration
        );
        assert!(
            fast.report
                .active
                .iter()
                .any(|(l, share)| matches!(l, Limiter::Motor { .. }) && *share > 0.2),
            "{name}: {:?}",
            fast.report.active
        );
        // Some motor limit is nearly reached (the timing is not needlessly slow).
        let r = robot(name);
        let near = fast
            .report
            .peaks
            .iter()
            .any(|p| p.limit.is_some_and(|l| p.value > 0.95 * l));
        assert!(near, "{name}: {:?} {:?}", fast.report.peaks, r.limits);
    }
}

#[test]
fn caster_steer_angles_integrate_their_rates_and_start_aligned() {
    let planned = spline_plan(
        "caster3",
        HeadingLaw::Tangent { offset: 0.0 },
        profile(0.3, 0.5),
    );
    let p = &planned.plan;
    // Aligned start: the first motion needs no steering.
    let s1 = &p.samples[1];
    let (_, sd) = s1.steer.unwrap();
    let v = s1.twist.vx.hypot(s1.twist.vy);
    assert!(
        sd.iter().all(|r| r.abs() < 1e-3 * v / 0.04 + 1e-9),
        "{sd:?} at speed {v}"
    );
    // Trapezoidal integration of the steer rates reproduces the steer angles.
    let mut g = p.samples[0].steer.unwrap().0;
    for w in p.samples.windows(2) {
        let (a, b) = (w[0].steer.unwrap().1, w[1].steer.unwrap().1);
        let dt = w[1].t - w[0].t;
        for i in 0..3 {
            g[i] += 0.5 * (a[i] + b[i]) * dt;
        }
    }
    let end = p.samples.last().unwrap().steer.unwrap().0;
    for i in 0..3 {
        assert!(
            (g[i] - end[i]).abs() < 1e-3,
            "steer {}: {} vs {}",
            i + 1,
            g[i],
            end[i]
        );
    }
    // Given initial steer angles are used as given.
    let path = Path::polyline(&[[0.0, 0.0], [0.3, 0.0]], Corners::Stop).unwrap();
    let opts = PlanOptions {
        timing: profile(0.2, 0.5),
        on_limit: OnLimit::Retime,
        rate: 100.0,
        initial_steer: InitialSteer::Given(omnikin_plan::per_wheel(&[0.1, -0.2, 0.3])),
    };
    let p = plan(&path, &HeadingLaw::Constant(0.0), &robot("caster3"), &opts)
        .unwrap()
        .plan;
    assert_eq!(p.samples[0].steer.unwrap().0[..3], [0.1, -0.2, 0.3]);
}

#[test]
fn tangent_heading_turns_in_place_at_a_stop() {
    let path = Path::polyline(&[[0.0, 0.0], [0.5, 0.0], [0.5, 0.5]], Corners::Stop).unwrap();
    let opts = PlanOptions {
        timing: profile(0.2, 0.5),
        on_limit: OnLimit::Retime,
        rate: 100.0,
        initial_steer: InitialSteer::Aligned,
    };
    let planned = plan(
        &path,
        &HeadingLaw::Tangent { offset: 0.0 },
        &robot("sphere-omni"),
        &opts,
    )
    .unwrap();
    assert_eq!(planned.report.moves.len(), 3);
    let p = &planned.plan;
    assert_eq!(p.samples[0].pose.heading, 0.0);
    assert!((p.samples.last().unwrap().pose.heading - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    // While turning, the centre stays at the corner.
    for s in &p.samples {
        if s.twist.yaw_rate.abs() > 1e-9 {
            assert!((s.pose.x - 0.5).abs() < 1e-12 && s.pose.y.abs() < 1e-12);
        }
    }
}

#[test]
fn fillets_with_tangent_heading_stop_where_the_curvature_jumps() {
    let pts = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
    let path = Path::polyline(&pts, Corners::Fillet { radius: 0.2 }).unwrap();
    let opts = PlanOptions {
        timing: profile(0.3, 0.5),
        on_limit: OnLimit::Retime,
        rate: 100.0,
        initial_steer: InitialSteer::Aligned,
    };
    let tangent = plan(
        &path,
        &HeadingLaw::Tangent { offset: 0.0 },
        &robot("sphere-omni"),
        &opts,
    )
    .unwrap();
    assert_eq!(tangent.report.moves.len(), 3);
    let constant = plan(
        &path,
        &HeadingLaw::Constant(0.0),
        &robot("sphere-omni"),
        &opts,
    )
    .unwrap();
    assert_eq!(constant.report.moves.len(), 1);
    // The fillet is tangent to both legs and ends on the second one.
    let end = constant.plan.samples.last().unwrap().pose;
    assert!((end.x - 1.0).abs() < 1e-9 && (end.y - 1.0).abs() < 1e-9);
    let e = Path::polyline(&pts, Corners::Fillet { radius: 2.0 })
        .unwrap_err()
        .to_string();
    assert!(e.contains("does not fit on leg 1"), "{e}");
}
