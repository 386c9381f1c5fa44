//! The time-optimal planner against an independent reference: a second, simple solver written
//! from the specification in `docs/planning.md` (motor rates `w = A(s) ṡ`, accelerations
//! `ẇ = A(s) s̈ + A'(s) ṡ²`, limits on `|w|`, `|ẇ|`, `ṡ` and `|s̈|`), sharing none of the
//! planner's timing code: `A(s)` from the core inverse kinematics on a 1 mm grid, `A'` by
//! central differences, the largest admissible `x = ṡ²` at each node by bisection, then the
//! classic forward (accelerate) and backward (brake) passes on `x`. Random seeded waypoints,
//! heading laws, robots without steering and limits; paths without stops (splines, and
//! fillets under heading laws whose rate does not jump), so neither solver cuts the path.

use omnikin::description::RobotDescription;
use omnikin::{Actuators, Twist2};
use omnikin_plan::RobotModel;
use omnikin_plan::heading::{HeadingLaw, HeadingProfile, Side};
use omnikin_plan::path::{Corners, Path};
use omnikin_plan::planner::{InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing, plan};

/// Grid step of the reference, m.
const H: f64 = 1e-3;

/// A small deterministic generator (xorshift64*), so the cases are the same on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// Wheel rates per unit speed `A(s)` of `robot` at arc length `s` under `law`: the core
/// inverse of the robot-frame twist `(Rᵀ(ψ) dr/ds, dψ/ds)`.
fn a_of(robot: &RobotModel, path: &Path, law: &HeadingLaw, s: f64) -> Vec<f64> {
    let p = path.at(s);
    let (psi, dpsi) = match law {
        HeadingLaw::Constant(c) => (*c, 0.0),
        HeadingLaw::Tangent { offset } => (p.tangent[1].atan2(p.tangent[0]) + offset, p.curvature),
        HeadingLaw::Profile(prof) => prof.at(s, Side::After),
    };
    let twist = Twist2::new(p.tangent[0], p.tangent[1], dpsi).to_robot(psi);
    let w = robot
        .model
        .inverse(twist, &Actuators::zero())
        .expect("inverse")
        .wheel_rates;
    w[..robot.model.wheels()].to_vec()
}

/// The interval of admissible `s̈` at a node with rates per speed `a`, their derivative `b`
/// and `x = ṡ²` (empty when `lo > hi`).
fn accel_range(a: &[f64], b: &[f64], x: f64, a_user: f64, limit: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (-a_user, a_user);
    for (&ai, &bi) in a.iter().zip(b) {
        // |ai s̈ + bi x| ≤ limit.
        if ai.abs() < 1e-12 {
            if (bi * x).abs() > limit {
                return (1.0, -1.0);
            }
            continue;
        }
        let (p, q) = ((-limit - bi * x) / ai, (limit - bi * x) / ai);
        lo = lo.max(p.min(q));
        hi = hi.min(p.max(q));
    }
    (lo, hi)
}

/// The reference duration (s) of `path` under `law` for `robot` within `v_user`, `a_user`
/// and the robot's wheel rate and acceleration limits, from rest to rest.
fn reference_duration(
    robot: &RobotModel,
    path: &Path,
    law: &HeadingLaw,
    v_user: f64,
    a_user: f64,
) -> f64 {
    reference_from(robot, path, law, v_user, a_user, Some(0.0)).0
}

/// [`reference_duration`] from the start speed `x0 = ṡ²` (m²/s²) to rest: the duration, and
/// the largest start `x` from which the end is reachable (the backward pass's first node when
/// `x0` is `None`, which then also starts the forward pass).
fn reference_from(
    robot: &RobotModel,
    path: &Path,
    law: &HeadingLaw,
    v_user: f64,
    a_user: f64,
    x0: Option<f64>,
) -> (f64, f64) {
    let len = path.length();
    let n = (len / H).ceil() as usize;
    let h = len / n as f64;
    let s: Vec<f64> = (0..=n).map(|i| (i as f64 * h).min(len)).collect();
    let a: Vec<Vec<f64>> = s.iter().map(|&s| a_of(robot, path, law, s)).collect();
    let b: Vec<Vec<f64>> = (0..=n)
        .map(|i| {
            let (i0, i1) = (i.saturating_sub(1), (i + 1).min(n));
            let d = s[i1] - s[i0];
            a[i1].iter().zip(&a[i0]).map(|(p, q)| (p - q) / d).collect()
        })
        .collect();
    let rate = robot.limits.max_wheel_rate.unwrap_or(f64::INFINITY);
    let accel = robot.limits.max_wheel_accel.unwrap_or(f64::INFINITY);
    // The largest x at each node: the speed caps, then the largest x at which some s̈ is
    // admissible (the admissible set is convex and holds x = 0, so bisection finds its end).
    let mut x: Vec<f64> = (0..=n)
        .map(|i| {
            let peak = a[i].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            let mut cap = v_user * v_user;
            if peak > 0.0 {
                cap = cap.min((rate / peak).powi(2));
            }
            let ok = |x: f64| {
                let (lo, hi) = accel_range(&a[i], &b[i], x, a_user, accel);
                lo <= hi
            };
            if ok(cap) {
                return cap;
            }
            let (mut lo, mut hi) = (0.0, cap);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if ok(mid) { lo = mid } else { hi = mid }
            }
            lo
        })
        .collect();
    if let Some(x0) = x0 {
        x[0] = x0;
    }
    x[n] = 0.0;
    // Forward: accelerate as hard as the start node of each step allows.
    for i in 0..n {
        let (_, hi) = accel_range(&a[i], &b[i], x[i], a_user, accel);
        x[i + 1] = x[i + 1].min(x[i] + 2.0 * h * hi.max(0.0));
    }
    // Backward: brake as hard as the end node of each step allows.
    for i in (0..n).rev() {
        let (lo, _) = accel_range(&a[i + 1], &b[i + 1], x[i + 1], a_user, accel);
        x[i] = x[i].min(x[i + 1] - 2.0 * h * lo.min(0.0));
    }
    let duration = (0..n)
        .map(|i| 2.0 * (s[i + 1] - s[i]) / (x[i].sqrt() + x[i + 1].sqrt()))
        .sum();
    (duration, x[0])
}

/// Waypoints as a random walk: steps of 0.4–1.2 m, turning at most 90° each time.
fn waypoints(rng: &mut Rng) -> Vec<[f64; 2]> {
    let count = 3 + (rng.next() * 4.0) as usize;
    let mut p = [0.0, 0.0];
    let mut dir = rng.range(-3.0, 3.0);
    let mut out = vec![p];
    for _ in 1..count {
        dir += rng.range(-1.5, 1.5);
        let l = rng.range(0.4, 1.2);
        p = [p[0] + l * dir.cos(), p[1] + l * dir.sin()];
        out.push(p);
    }
    out
}

#[test]
fn time_optimal_durations_are_within_one_percent_of_the_reference() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let robots = ["kiwi", "x-drive", "mecanum", "sphere-omni", "ballbot"];
    let mut rows: Vec<(f64, String)> = Vec::new();
    while rows.len() < 40 {
        let pts = waypoints(&mut rng);
        let fillet = rng.next() < 0.3;
        let path = if fillet {
            Path::polyline(
                &pts,
                Corners::Fillet {
                    radius: rng.range(0.1, 0.3),
                },
            )
        } else {
            Path::spline(&pts)
        };
        // A random walk can make a spline cusp or a fillet that does not fit.
        let Ok(path) = path else { continue };
        let law_i = (rng.next() * 4.0) as usize;
        let headings: Vec<f64> = pts.iter().map(|_| rng.range(-2.0, 2.0)).collect();
        let at_waypoints: Vec<(f64, f64)> = path
            .waypoint_arc_lengths()
            .iter()
            .copied()
            .zip(headings)
            .collect();
        let (law_name, law) = match law_i {
            0 => ("constant", HeadingLaw::Constant(rng.range(-3.0, 3.0))),
            // Under the tangent law a fillet's ends are stops; splines only.
            1 if !fillet => (
                "tangent",
                HeadingLaw::Tangent {
                    offset: rng.range(-1.0, 1.0),
                },
            ),
            1 | 2 => (
                "spin",
                HeadingLaw::Profile(
                    HeadingProfile::new(&[(0.0, 0.0), (path.length(), rng.range(-6.0, 6.0))])
                        .unwrap(),
                ),
            ),
            _ => (
                "waypoints",
                HeadingLaw::Profile(HeadingProfile::new(&at_waypoints).unwrap()),
            ),
        };
        let name = robots[(rng.next() * robots.len() as f64) as usize];
        let robot = RobotModel::from_description(&RobotDescription::preset(name).unwrap()).unwrap();
        let (v, a) = (rng.range(0.3, 3.0), rng.range(0.5, 6.0));
        let opts = PlanOptions {
            timing: Timing::TimeOptimal {
                limits: MotionLimits {
                    max_speed: v,
                    max_accel: a,
                    ..MotionLimits::default()
                },
            },
            on_limit: OnLimit::Retime,
            rate: 100.0,
            initial_steer: InitialSteer::Aligned,
        };
        let what = format!(
            "{} {} waypoints, {law_name}, {name}, {v:.2} m/s, {a:.2} m/s²",
            if fillet { "fillet" } else { "spline" },
            pts.len()
        );
        let planned = plan(&path, &law, &robot, &opts).unwrap_or_else(|e| panic!("{what}: {e}"));
        let got = planned.plan.duration();
        let want = reference_duration(&robot, &path, &law, v, a);
        rows.push((
            got / want - 1.0,
            format!("{what}: {got:.4} s vs reference {want:.4} s"),
        ));
    }
    let mut d: Vec<f64> = rows.iter().map(|r| r.0).collect();
    d.sort_by(f64::total_cmp);
    let median = d[d.len() / 2];
    let (worst, worst_what) = rows
        .iter()
        .max_by(|p, q| p.0.abs().total_cmp(&q.0.abs()))
        .unwrap();
    for (r, what) in &rows {
        println!("{:+.3} %  {what}", 100.0 * r);
    }
    println!(
        "median {:+.3} %, worst {:+.3} % ({worst_what})",
        100.0 * median,
        100.0 * worst
    );
    assert!(
        worst.abs() <= 0.01,
        "worst {:+.3} %: {worst_what}",
        100.0 * worst
    );
}

/// A plan that starts moving ([`plan_from_velocity`]) against the reference from the same
/// start speed: random start speeds between 5 % and 95 % of the largest start from which the
/// reference can still stop at the end, along the path's first tangent. Each plan's first
/// sample moves at the given velocity (within 1e-9), every motor limit holds at the samples,
/// the plan is no slower than the same path from rest, and its duration is within 1 % of the
/// reference's.
#[test]
fn moving_starts_are_within_one_percent_of_the_reference() {
    use omnikin_plan::planner::{START_TOLERANCE, StartVelocity, plan_from_velocity, plan_peaks};
    let mut rng = Rng(0xD1B5_4A32_D192_ED03);
    let robots = ["kiwi", "x-drive", "mecanum", "sphere-omni", "ballbot"];
    let mut rows: Vec<(f64, String)> = Vec::new();
    while rows.len() < 24 {
        let pts = waypoints(&mut rng);
        let Ok(path) = Path::spline(&pts) else {
            continue;
        };
        let law = match (rng.next() * 3.0) as usize {
            0 => HeadingLaw::Constant(rng.range(-3.0, 3.0)),
            1 => HeadingLaw::Tangent {
                offset: rng.range(-1.0, 1.0),
            },
            _ => HeadingLaw::Profile(
                HeadingProfile::new(&[(0.0, 0.0), (path.length(), rng.range(-6.0, 6.0))]).unwrap(),
            ),
        };
        let name = robots[(rng.next() * robots.len() as f64) as usize];
        let robot = RobotModel::from_description(&RobotDescription::preset(name).unwrap()).unwrap();
        let (v, a) = (rng.range(0.3, 3.0), rng.range(0.5, 6.0));
        let opts = PlanOptions {
            timing: Timing::TimeOptimal {
                limits: MotionLimits {
                    max_speed: v,
                    max_accel: a,
                    ..MotionLimits::default()
                },
            },
            on_limit: OnLimit::Retime,
            rate: 100.0,
            initial_steer: InitialSteer::Aligned,
        };
        let (_, x_max) = reference_from(&robot, &path, &law, v, a, None);
        let v0 = rng.range(0.05, 0.95) * x_max.sqrt();
        let t = path.at(0.0).tangent;
        let start = StartVelocity {
            vx: v0 * t[0],
            vy: v0 * t[1],
            yaw_rate: None,
        };
        let what = format!(
            "spline {} waypoints, {law:?}, {name}, {v:.2} m/s, {a:.2} m/s², from {v0:.4} m/s \
             (largest {:.4})",
            pts.len(),
            x_max.sqrt()
        );
        let planned = plan_from_velocity(&path, &law, &robot, &opts, start)
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        let first = planned.plan.samples[0].twist;
        assert!(
            (first.vx - start.vx).abs() <= START_TOLERANCE
                && (first.vy - start.vy).abs() <= START_TOLERANCE,
            "{what}: first sample {first:?}"
        );
        for p in plan_peaks(&planned.plan, &robot) {
            if let Some(l) = p.limit {
                assert!(p.value <= l * (1.0 + 1e-9), "{what}: {p:?}");
            }
        }
        let got = planned.plan.duration();
        let rest = plan(&path, &law, &robot, &opts).unwrap().plan.duration();
        assert!(got <= rest + 1e-9, "{what}: {got} s, from rest {rest} s");
        let want = reference_from(&robot, &path, &law, v, a, Some(v0 * v0)).0;
        rows.push((
            got / want - 1.0,
            format!("{what}: {got:.4} s vs reference {want:.4} s (from rest {rest:.4} s)"),
        ));
    }
    let (worst, worst_what) = rows
        .iter()
        .max_by(|p, q| p.0.abs().total_cmp(&q.0.abs()))
        .unwrap();
    for (r, what) in &rows {
        println!("{:+.3} %  {what}", 100.0 * r);
    }
    assert!(
        worst.abs() <= 0.01,
        "worst {:+.3} %: {worst_what}",
        100.0 * worst
    );
}
