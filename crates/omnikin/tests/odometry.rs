//! Wheel odometry against analytic motion: encoder angles generated from the inverse kinematics
//! of a planned path (lines, arcs, turning in place) must give the path back for all three
//! robots; the exact SE(2) step beats Euler on an arc; gyro/absolute-yaw heading sources; shell
//! spin recovered from wheels + gyro; caster slip residual flags a slipping wheel; bad input is
//! rejected without changing the state.

use core::f64::consts::{FRAC_PI_2, PI, TAU};

use omnikin::ballbot::{Ballbot, BallbotParams};
use omnikin::caster::{Caster3, CasterParams};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry, OdometryError};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Robot, Twist2};

/// One segment of a plan: a constant robot-frame twist (m/s, m/s, rad/s) held for `duration` s.
#[derive(Clone, Copy)]
struct Segment {
    twist: Twist2<f64>,
    duration: f64,
}

fn seg(vx: f64, vy: f64, w: f64, duration: f64) -> Segment {
    Segment {
        twist: Twist2::new(vx, vy, w),
        duration,
    }
}

/// A path with lines, arcs in both directions, a sideways arc and turns in place.
fn mixed_path() -> Vec<Segment> {
    vec![
        seg(0.2, 0.0, 0.0, 2.0),       // line
        seg(0.2, 0.0, 0.5, PI),        // quarter... half-turn arc (radius 0.4 m)
        seg(0.0, 0.0, 1.0, FRAC_PI_2), // turn in place
        seg(0.1, -0.15, -0.7, 3.0),    // sideways arc, clockwise
        seg(0.0, 0.0, -2.0, PI),       // a full turn in place clockwise
        seg(-0.15, 0.05, 0.3, 2.5),    // backwards arc
    ]
}

/// Closed-form pose after holding a robot-frame twist for `t` seconds from `p` (written out
/// here, independently of `omnikin::se2`): `∫ R(θ0 + ωs) v ds`.
fn exact(p: Pose2<f64>, tw: Twist2<f64>, t: f64) -> Pose2<f64> {
    let th = tw.yaw_rate * t;
    let (a, b) = if tw.yaw_rate.abs() < 1e-12 {
        (t, 0.0)
    } else {
        (th.sin() / tw.yaw_rate, (1.0 - th.cos()) / tw.yaw_rate)
    };
    // Displacement in the start frame.
    let dx = a * tw.vx - b * tw.vy;
    let dy = b * tw.vx + a * tw.vy;
    let (s, c) = p.heading.sin_cos();
    Pose2::new(p.x + c * dx - s * dy, p.y + s * dx + c * dy, p.heading + th)
}

/// Samples of the true pose and the encoder readings at `rate` Hz along `path`, for robots whose
/// wheel rates are constant under a constant body twist (sphere, ballbot): `q(t) = q0 + w·t`.
fn omni_log(
    path: &[Segment],
    rate: f64,
    wheel_rates: impl Fn(Twist2<f64>) -> [f64; 3],
) -> (Vec<EncoderReading<f64>>, Vec<Pose2<f64>>, Vec<f64>) {
    let mut readings = vec![EncoderReading::new(0.0, [0.0; 3])];
    let mut truth = vec![Pose2::new(0.0, 0.0, 0.0)];
    let mut yaw_rates = vec![path[0].twist.yaw_rate];
    let (mut t0, mut q0, mut p0) = (0.0, [0.0; 3], Pose2::new(0.0, 0.0, 0.0));
    for s in path {
        let w = wheel_rates(s.twist);
        let n = (s.duration * rate).round() as usize;
        let dt = s.duration / n as f64;
        for k in 1..=n {
            let tau = k as f64 * dt;
            readings.push(EncoderReading::new(
                t0 + tau,
                core::array::from_fn::<_, 3, _>(|i| q0[i] + w[i] * tau),
            ));
            truth.push(exact(p0, s.twist, tau));
            yaw_rates.push(s.twist.yaw_rate);
        }
        t0 += s.duration;
        q0 = core::array::from_fn(|i| q0[i] + w[i] * s.duration);
        p0 = exact(p0, s.twist, s.duration);
    }
    (readings, truth, yaw_rates)
}

fn run(odo: &mut Odometry<f64>, log: &[EncoderReading<f64>]) -> Vec<Pose2<f64>> {
    log.iter()
        .map(|r| odo.update(r, HeadingInput::Wheels).unwrap().pose)
        .collect()
}

fn worst(a: &[Pose2<f64>], b: &[Pose2<f64>]) -> (f64, f64) {
    a.iter().zip(b).fold((0.0f64, 0.0f64), |(p, h), (x, y)| {
        (
            p.max((x.x - y.x).hypot(x.y - y.y)),
            h.max((x.heading - y.heading).abs()),
        )
    })
}

fn path_length(path: &[Segment]) -> f64 {
    path.iter()
        .map(|s| s.twist.vx.hypot(s.twist.vy) * s.duration)
        .sum()
}

#[test]
fn sphere_noise_free_encoders_give_the_path_back() {
    let m = SphereOmni::new(SphereParams::preset()).unwrap();
    let (log, truth, _) = omni_log(&mixed_path(), 100.0, |tw| m.wheel_rates(tw, 0.0).unwrap());
    let mut odo = Odometry::new(Robot::Sphere(m), Pose2::new(0.0, 0.0, 0.0));
    let poses = run(&mut odo, &log);
    let (pos, head) = worst(&poses, &truth);
    println!(
        "sphere: path {:.2} m, worst position error {pos:.2e} m, heading {head:.2e} rad",
        path_length(&mixed_path())
    );
    assert!(pos < 1e-9 && head < 1e-9, "{pos:e} {head:e}");
    // The path really went somewhere and turned (guards against a vacuous comparison).
    let end = truth.last().unwrap();
    assert!(
        end.x.hypot(end.y) > 0.3 && end.heading.abs() > 1.0,
        "{end:?}"
    );
}

#[test]
fn ballbot_noise_free_encoders_give_the_path_back() {
    let m = Ballbot::new(BallbotParams::preset()).unwrap();
    let (log, truth, _) = omni_log(&mixed_path(), 100.0, |tw| m.wheel_rates(tw, 0.0).unwrap());
    let mut odo = Odometry::new(Robot::Ballbot(m), Pose2::new(0.0, 0.0, 0.0));
    let poses = run(&mut odo, &log);
    let (pos, head) = worst(&poses, &truth);
    println!("ballbot: worst position error {pos:.2e} m, heading {head:.2e} rad");
    assert!(pos < 1e-9 && head < 1e-9, "{pos:e} {head:e}");
}

#[test]
fn ballbot_turning_in_place_does_not_move_the_ball() {
    // Paper 001: the body's own rotation turns every wheel (through sin α) but moves nothing.
    let m = Ballbot::new(BallbotParams::preset()).unwrap();
    let (log, _, _) = omni_log(&[seg(0.0, 0.0, 3.0, 4.0)], 50.0, |tw| {
        m.wheel_rates(tw, 0.0).unwrap()
    });
    assert!(
        log.last().unwrap().wheel_angles[0].abs() > 1.0,
        "wheels did turn"
    );
    let mut odo = Odometry::new(Robot::Ballbot(m), Pose2::new(1.0, 2.0, 0.5));
    let end = *run(&mut odo, &log).last().unwrap();
    assert!(
        (end.x - 1.0).abs() < 1e-12 && (end.y - 2.0).abs() < 1e-12,
        "{end:?}"
    );
    assert!((end.heading - (0.5 + 12.0)).abs() < 1e-9);
}

/// Caster encoder log for a constant body twist: the steer angles evolve by the no-slip
/// constraint `γ̇ = J2(γ) q̇` (robot frame, heading 0) and the roll angles by `φ̇ = J1(γ) q̇`;
/// integrated here with RK4 at 20 kHz and sampled at `rate` Hz.
fn caster_log(
    m: &Caster3<f64>,
    path: &[Segment],
    steer0: [f64; 3],
    rate: f64,
) -> (Vec<EncoderReading<f64>>, Vec<Pose2<f64>>) {
    let f = |tw: Twist2<f64>, g: [f64; 3]| -> [f64; 6] {
        let r = m.motor_rates(tw, 0.0, g).unwrap();
        [
            r.roll[0], r.roll[1], r.roll[2], r.steer[0], r.steer[1], r.steer[2],
        ]
    };
    let mut x = [0.0, 0.0, 0.0, steer0[0], steer0[1], steer0[2]];
    let reading = |t: f64, x: &[f64; 6]| {
        EncoderReading::with_steer(t, [x[0], x[1], x[2]], [x[3], x[4], x[5]])
    };
    let mut log = vec![reading(0.0, &x)];
    let mut truth = vec![Pose2::new(0.0, 0.0, 0.0)];
    let (mut t0, mut p0) = (0.0, Pose2::new(0.0, 0.0, 0.0));
    let sub = (20_000.0 / rate) as usize;
    for s in path {
        let n = (s.duration * rate).round() as usize;
        let dt = s.duration / (n * sub) as f64;
        let add = |x: &[f64; 6], k: &[f64; 6], h: f64| -> [f64; 6] {
            core::array::from_fn(|i| x[i] + h * k[i])
        };
        for k in 1..=n {
            for _ in 0..sub {
                let g = |x: &[f64; 6]| [x[3], x[4], x[5]];
                let k1 = f(s.twist, g(&x));
                let k2 = f(s.twist, g(&add(&x, &k1, dt / 2.0)));
                let k3 = f(s.twist, g(&add(&x, &k2, dt / 2.0)));
                let k4 = f(s.twist, g(&add(&x, &k3, dt)));
                x = core::array::from_fn(|i| {
                    x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
                });
            }
            let tau = k as f64 * s.duration / n as f64;
            log.push(reading(t0 + tau, &x));
            truth.push(exact(p0, s.twist, tau));
        }
        t0 += s.duration;
        p0 = exact(p0, s.twist, s.duration);
    }
    (log, truth)
}

#[test]
fn caster_noise_free_encoders_give_the_path_back() {
    let m = Caster3::new(CasterParams::preset()).unwrap();
    // Slower turns than the omni robots: the steering must follow (γ̇ = J2 q̇).
    let path = vec![
        seg(0.2, 0.0, 0.0, 2.0),
        seg(0.2, 0.0, 0.4, 3.0),
        seg(0.0, 0.0, 0.8, 2.0),
        seg(0.05, -0.12, -0.3, 3.0),
        seg(-0.1, 0.05, 0.2, 2.0),
    ];
    let run_at = |rate: f64| {
        let (log, truth) = caster_log(&m, &path, [0.0, 0.3, -0.3], rate);
        let mut odo = Odometry::new(Robot::Caster(m), Pose2::new(0.0, 0.0, 0.0));
        let mut max_slip = 0.0f64;
        let poses: Vec<Pose2<f64>> = log
            .iter()
            .map(|r| {
                let s = odo.update(r, HeadingInput::Wheels).unwrap();
                max_slip = max_slip.max(s.slip_residual);
                s.pose
            })
            .collect();
        let (pos, head) = worst(&poses, &truth);
        println!(
            "caster at {rate} Hz: path {:.2} m, worst position error {pos:.2e} m, heading {head:.2e} rad, max slip residual {max_slip:.2e} m/s",
            path_length(&path)
        );
        (pos, head, max_slip)
    };
    let (pos, head, max_slip) = run_at(100.0);
    // Steer angles change within each 10 ms step; the mid-step evaluation is second order.
    assert!(pos < 2e-5 && head < 1e-4, "{pos:e} {head:e}");
    assert!(
        max_slip < 1e-3,
        "consistent encoders, slip residual {max_slip:e}"
    );
    // … and converges like dt²: twice the rate, a quarter of the error.
    let (pos2, head2, _) = run_at(200.0);
    assert!(pos2 < pos / 3.0 && head2 < head / 3.0, "{pos2:e} {head2:e}");
}

#[test]
fn caster_slip_on_one_wheel_raises_that_steps_residual() {
    let m = Caster3::new(CasterParams::preset()).unwrap();
    let (mut log, _) = caster_log(&m, &[seg(0.2, 0.05, 0.3, 1.0)], [0.1, 0.0, -0.1], 100.0);
    // Wheel 2 spins 0.2 rad further than the motion needs during step 50 (and keeps the
    // offset: cumulative angles), e.g. it lost grip.
    for r in log.iter_mut().skip(50) {
        r.wheel_angles[1] += 0.2;
    }
    let mut odo = Odometry::new(Robot::Caster(m), Pose2::new(0.0, 0.0, 0.0));
    let steps: Vec<_> = log
        .iter()
        .map(|r| odo.update(r, HeadingInput::Wheels).unwrap())
        .collect();
    let normal = steps
        .iter()
        .enumerate()
        .filter(|(k, _)| *k != 50)
        .map(|(_, s)| s.slip_residual)
        .fold(0.0f64, f64::max);
    let slipped = &steps[50];
    println!(
        "caster slip: residual {:.4} m/s at the slipping step vs ≤ {normal:.2e} m/s elsewhere; per wheel {:?}",
        slipped.slip_residual, slipped.wheel_slip
    );
    // 0.2 rad × r = 0.01 m in 10 ms = 1 m/s of wheel-2 mismatch, partly absorbed by the fit.
    assert!(slipped.slip_residual > 0.3, "{}", slipped.slip_residual);
    assert!(normal < 1e-3, "{normal}");
    let w = slipped.wheel_slip;
    assert!(w[1] > w[0] && w[1] > w[2], "wheel 2 is the culprit: {w:?}");
}

#[test]
fn exact_integration_beats_euler_on_an_arc() {
    // The sphere on a circle of radius 0.5 m at 0.5 m/s, encoders at 20 Hz, one full lap.
    let m = SphereOmni::new(SphereParams::preset()).unwrap();
    let tw = Twist2::new(0.5, 0.0, 1.0);
    let (log, truth, _) = omni_log(&[seg(0.5, 0.0, 1.0, TAU)], 20.0, |t| {
        m.wheel_rates(t, 0.0).unwrap()
    });
    let mut odo = Odometry::new(Robot::Sphere(m), Pose2::new(0.0, 0.0, 0.0));
    let mut euler = Pose2::new(0.0f64, 0.0, 0.0);
    let (mut worst_exact, mut worst_euler) = (0.0f64, 0.0f64);
    for (r, p) in log.iter().zip(&truth) {
        let s = odo.update(r, HeadingInput::Wheels).unwrap();
        // Euler with the same per-step twist: move along the start heading, then turn.
        let (sn, c) = euler.heading.sin_cos();
        euler = Pose2::new(
            euler.x + (c * s.twist.vx - sn * s.twist.vy) * s.dt,
            euler.y + (sn * s.twist.vx + c * s.twist.vy) * s.dt,
            euler.heading + s.twist.yaw_rate * s.dt,
        );
        assert!(s.dt == 0.0 || (s.twist.vx - tw.vx).abs() < 1e-12);
        worst_exact = worst_exact.max((s.pose.x - p.x).hypot(s.pose.y - p.y));
        worst_euler = worst_euler.max((euler.x - p.x).hypot(euler.y - p.y));
    }
    println!(
        "arc r = 0.5 m at 0.5 m/s, 20 Hz, one lap: worst error exact {worst_exact:.2e} m, Euler {worst_euler:.2e} m"
    );
    assert!(worst_exact < 1e-12, "{worst_exact:e}");
    // Euler's polygon of chords along the start tangents lies on a circle whose centre is
    // shifted by about r·ω·dt/2, so the worst error, half a lap on, is r·ω·dt = 25 mm (the
    // polygon closes by symmetry, so the end point alone would hide it).
    assert!((worst_euler - 0.025).abs() < 0.003, "{worst_euler:e}");
}

#[test]
fn gyro_and_absolute_yaw_heading_sources() {
    let m = SphereOmni::new(SphereParams::preset()).unwrap();
    let path = mixed_path();
    let (log, truth, yaw_rates) = omni_log(&path, 100.0, |tw| m.wheel_rates(tw, 0.0).unwrap());

    // Gyro: the true yaw rate at each sample (piecewise constant; trapezoid is exact except at
    // the segment boundaries, where the rate jumps between samples).
    let mut odo = Odometry::new(Robot::Sphere(m), Pose2::new(0.0, 0.0, 0.0));
    let mut last = Pose2::new(0.0, 0.0, 0.0);
    for (r, &w) in log.iter().zip(&yaw_rates) {
        last = odo.update(r, HeadingInput::GyroRate(w)).unwrap().pose;
    }
    let end = truth.last().unwrap();
    // At the 5 rate jumps the trapezoid averages the old and new rates over one 10 ms step.
    assert!(
        (last.heading - end.heading).abs() < 0.05,
        "{last:?} {end:?}"
    );

    // Absolute yaw, wrapped into (−π, π] as an AHRS reports it: heading stays unwrapped.
    let mut odo = Odometry::new(Robot::Sphere(m), Pose2::new(0.0, 0.0, 0.0));
    let mut poses = Vec::new();
    for (r, p) in log.iter().zip(&truth) {
        let yaw = omnikin::wrap_angle(p.heading);
        poses.push(odo.update(r, HeadingInput::Absolute(yaw)).unwrap().pose);
    }
    let (pos, head) = worst(&poses, &truth);
    assert!(pos < 1e-9 && head < 1e-9, "{pos:e} {head:e}");
    assert!(
        truth.iter().any(|p| p.heading.abs() > PI),
        "the path crosses ±π"
    );
}

#[test]
fn sphere_shell_spin_is_recovered_with_a_gyro() {
    // The shell spins at Ω3 = 0.4 rad/s: the wheels see ω̃_z = Ω3 − ψ̇, wheels-only odometry
    // gets the heading wrong, the gyro fixes it and Ω3 = ω̃_z + ψ̇ comes out.
    let m = SphereOmni::new(SphereParams::preset()).unwrap();
    let spin = 0.4;
    let path = [seg(0.2, 0.0, 0.5, 4.0), seg(0.1, 0.1, -0.3, 3.0)];
    let (log, truth, yaw_rates) = omni_log(&path, 100.0, |tw| m.wheel_rates(tw, spin).unwrap());
    let mut wheels = Odometry::new(Robot::Sphere(m), Pose2::new(0.0, 0.0, 0.0));
    let mut gyro = Odometry::new(Robot::Sphere(m), Pose2::new(0.0, 0.0, 0.0));
    let mut spins = Vec::new();
    for (r, &w) in log.iter().zip(&yaw_rates).take(401) {
        let s = gyro.update(r, HeadingInput::GyroRate(w)).unwrap();
        wheels.update(r, HeadingInput::Wheels).unwrap();
        if let Some(x) = s.shell_spin {
            spins.push(x);
        }
        let sw = wheels.update(r, HeadingInput::Wheels);
        assert!(matches!(sw, Err(OdometryError::NonMonotonicTime { .. })));
    }
    let truth_4s = truth[400];
    let e_gyro = (gyro.pose().x - truth_4s.x).hypot(gyro.pose().y - truth_4s.y);
    let e_wheels = (wheels.pose().x - truth_4s.x).hypot(wheels.pose().y - truth_4s.y);
    println!(
        "shell spin 0.4 rad/s: end error with gyro {e_gyro:.2e} m, wheels only {e_wheels:.3} m"
    );
    assert!(e_gyro < 1e-9, "{e_gyro:e}");
    assert!(e_wheels > 0.1, "{e_wheels}");
    assert_eq!(spins.len(), 400, "spin measured from the second sample on");
    for x in spins {
        assert!((x - spin).abs() < 1e-9, "{x}");
    }
    // Wheels-only: the spin is assumed, not measured.
    let mut odo =
        Odometry::new(Robot::Sphere(m), Pose2::new(0.0, 0.0, 0.0)).with_assumed_spin(spin);
    let mut last = None;
    for r in log.iter().take(401) {
        let s = odo.update(r, HeadingInput::Wheels).unwrap();
        assert_eq!(s.shell_spin, None);
        last = Some(s.pose);
    }
    let p = last.unwrap();
    assert!(
        (p.x - truth_4s.x).hypot(p.y - truth_4s.y) < 1e-9,
        "known spin assumed"
    );
}

#[test]
fn f32_odometry_on_a_circle() {
    let m = SphereOmni::<f32>::new(SphereParams::preset()).unwrap();
    let w = m.wheel_rates(Twist2::new(0.2, 0.0, 0.5), 0.0).unwrap();
    let mut odo = Odometry::new(Robot::Sphere(m), Pose2::new(0.0, 0.0, 0.0));
    let n = 100 * 13; // 13 s at 100 Hz ≈ one lap (4π/… ) of radius 0.4 m
    for k in 0..=n {
        let t = k as f32 / 100.0;
        odo.update(
            &EncoderReading::new(t, [w[0] * t, w[1] * t, w[2] * t]),
            HeadingInput::Wheels,
        )
        .unwrap();
    }
    let truth = exact(Pose2::new(0.0, 0.0, 0.0), Twist2::new(0.2, 0.0, 0.5), 13.0);
    let p = odo.pose();
    let e = (p.x as f64 - truth.x).hypot(p.y as f64 - truth.y);
    assert!(e < 1e-4, "f32 end error {e:e}");
}

#[test]
fn bad_input_is_rejected_and_leaves_the_state_alone() {
    let m = Caster3::new(CasterParams::preset()).unwrap();
    let mut odo = Odometry::new(Robot::Caster(m), Pose2::new(0.0, 0.0, 0.0));
    let r0 = EncoderReading::with_steer(1.0, [0.0; 3], [0.0; 3]);
    let first = odo.update(&r0, HeadingInput::Wheels).unwrap();
    assert_eq!(first.dt, 0.0);
    let before = odo;
    let r = |t: f64, q: f64, s: f64| EncoderReading::with_steer(t, [q, 0.0, 0.0], [0.0, s, 0.0]);
    assert_eq!(
        odo.update(&r(1.0, 0.1, 0.0), HeadingInput::Wheels),
        Err(OdometryError::NonMonotonicTime {
            t: 1.0,
            previous: 1.0
        })
    );
    assert_eq!(
        odo.update(&r(0.5, 0.1, 0.0), HeadingInput::Wheels),
        Err(OdometryError::NonMonotonicTime {
            t: 0.5,
            previous: 1.0
        })
    );
    assert_eq!(
        odo.update(&r(f64::NAN, 0.1, 0.0), HeadingInput::Wheels),
        Err(OdometryError::NonFinite { field: "t" })
    );
    assert_eq!(
        odo.update(&r(1.1, f64::INFINITY, 0.0), HeadingInput::Wheels),
        Err(OdometryError::NonFinite {
            field: "wheel_angles[0]"
        })
    );
    assert_eq!(
        odo.update(&r(1.1, 0.0, f64::NAN), HeadingInput::Wheels),
        Err(OdometryError::NonFinite {
            field: "steer_angles[1]"
        })
    );
    assert_eq!(
        odo.update(&r(1.1, 0.0, 0.0), HeadingInput::GyroRate(f64::NAN)),
        Err(OdometryError::NonFinite { field: "gyro_rate" })
    );
    assert_eq!(odo, before, "errors must not change the state");
    // The messages name the field and the times.
    let e = odo
        .update(&r(0.5, 0.1, 0.0), HeadingInput::Wheels)
        .unwrap_err();
    assert_eq!(
        e.to_string(),
        "time 0.5 s does not increase (previous sample at 1 s)"
    );
}

#[test]
fn errors_name_the_first_bad_field_and_overflowing_increments() {
    use omnikin::InputError;
    let m = Caster3::new(CasterParams::preset()).unwrap();
    let big = f64::MAX;
    let mut odo = Odometry::new(Robot::Caster(m), Pose2::new(0.0, 0.0, 0.0));
    odo.update(
        &EncoderReading::with_steer(1.0, [-big, 0.0, 0.0], [0.0, -big, 0.0]),
        HeadingInput::Absolute(0.0),
    )
    .unwrap();
    let before = odo;
    let r = |t: f64, q: [f64; 3], s: [f64; 3]| EncoderReading::with_steer(t, q, s);
    let yaw = HeadingInput::Absolute(0.1);
    // Several bad fields: time first, then wheel i before steer i before wheel i + 1, then the
    // heading input.
    let cases = [
        (r(f64::NAN, [f64::NAN; 3], [0.0, -big, 0.0]), yaw, "t"),
        (
            r(f64::INFINITY, [-big, 0.0, 0.0], [0.0, -big, 0.0]),
            yaw,
            "t",
        ),
        (
            r(1.1, [-big, 0.0, f64::NAN], [f64::NAN, -big, 0.0]),
            yaw,
            "steer_angles[0]",
        ),
        (
            r(1.1, [-big, f64::NEG_INFINITY, 0.0], [0.0, -big, 0.0]),
            HeadingInput::Absolute(f64::NAN),
            "wheel_angles[1]",
        ),
        (
            r(1.1, [-big, 0.0, 0.0], [0.0, -big, f64::INFINITY]),
            yaw,
            "steer_angles[2]",
        ),
        (
            r(1.1, [-big, 0.0, 0.0], [0.0, -big, 0.0]),
            HeadingInput::Absolute(f64::INFINITY),
            "yaw",
        ),
    ];
    for (reading, heading, field) in cases {
        assert_eq!(
            odo.update(&reading, heading),
            Err(OdometryError::NonFinite { field }),
            "{reading:?} {heading:?}"
        );
    }
    // Finite angles whose increments overflow: the forward kinematics name the rate.
    assert_eq!(
        odo.update(&r(1.1, [big, 0.0, 0.0], [0.0, -big, 0.0]), yaw),
        Err(OdometryError::Kinematics(InputError::NonFinite {
            field: "roll_rates[0]"
        }))
    );
    assert_eq!(
        odo.update(&r(1.1, [-big, 0.0, 0.0], [0.0, big, 0.0]), yaw),
        Err(OdometryError::Kinematics(InputError::NonFinite {
            field: "steer_rates[1]"
        }))
    );
    assert_eq!(odo, before, "errors must not change the state");
    // A good sample still goes through.
    let s = odo
        .update(&r(1.1, [-big, 0.0, 0.0], [0.0, -big, 0.0]), yaw)
        .unwrap();
    assert!((s.pose.heading - 0.1).abs() < 1e-15, "{s:?}");
}

/// `Odometry::update_angles` (the control cycle's path, angles read in place) is
/// `Odometry::update` bit for bit: the same steps, poses and errors (naming the same field),
/// and the same state after each, for every preset kind and heading source, with wrapped
/// steer angles, a non-finite angle and a repeated time in the sequence.
#[test]
fn update_angles_is_update_bit_for_bit() {
    use omnikin::EncoderAngles;
    let robots = [
        Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap()),
        Robot::Ballbot(Ballbot::new(BallbotParams::preset()).unwrap()),
        Robot::Caster(Caster3::new(CasterParams::preset()).unwrap()),
    ];
    for robot in robots {
        for h in 0..3 {
            let start = Pose2::new(0.3, -1.2, 2.6);
            let mut by_reading = Odometry::new(robot, start);
            let mut by_angles = Odometry::new(robot, start);
            for k in 0..300 {
                let f = k as f64;
                let mut wheel = [0.21 * f, -0.05 * f - 1e-3 * f * f, 0.3 * (0.07 * f).sin()];
                let steer = [
                    (0.9 * f).rem_euclid(TAU) - PI,
                    0.4 * (0.05 * f).cos(),
                    -0.02 * f,
                ];
                if k == 97 {
                    wheel[1] = f64::NAN;
                }
                // A repeated time (refused) at k = 150.
                let t = if k == 150 { 149e-3 } else { f * 1e-3 };
                let heading = match h {
                    0 => HeadingInput::Wheels,
                    1 => HeadingInput::GyroRate(0.8 * (0.03 * f).sin()),
                    _ => HeadingInput::Absolute((0.01 * f).rem_euclid(TAU) - PI),
                };
                let reading = EncoderReading::with_steer(t, wheel, steer);
                let angles = EncoderAngles::new(&wheel, &steer);
                let a = by_reading.update(&reading, heading);
                let b = by_angles.update_angles(t, &angles, heading);
                // Debug formatting shows every bit of a float (shortest round trip) and NaN.
                assert_eq!(
                    format!("{a:?}"),
                    format!("{b:?}"),
                    "step {k}, heading source {h}"
                );
                assert_eq!(
                    by_reading, by_angles,
                    "state after step {k}, heading source {h}"
                );
            }
            assert!(
                by_reading.pose().x != start.x,
                "the sequence moved the robot"
            );
        }
    }
}
