//! Tests of the N-wheel omni/mecanum drive (`drive::omni`): the kiwi formula of issue 13, the
//! WPILib mecanum formulas, named physical situations, property tests over random layouts
//! (inverse∘forward, least squares against an independent pseudo-inverse, frame invariance,
//! desaturation, exact odometry on arcs, f32 against f64), rank-deficient rejection, input
//! errors and zero allocation.

use omnikin_testkit::allocation_count;

use core::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use omnikin::Robot;
use omnikin::drive::omni::{Omni, OmniWheel, presets};
use omnikin::drive::{Drive, Wrench2};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::{GeometryError, InputError, Pose2, Twist2};
use proptest::prelude::*;

fn kiwi() -> Omni<f64, 3> {
    Omni::new(presets::kiwi()).unwrap()
}

fn mecanum() -> Omni<f64, 4> {
    Omni::new(presets::mecanum()).unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + b.abs())
}

fn assert_twist(a: Twist2<f64>, b: Twist2<f64>, tol: f64) {
    assert!(
        close(a.vx, b.vx, tol) && close(a.vy, b.vy, tol) && close(a.yaw_rate, b.yaw_rate, tol),
        "{a:?} vs {b:?}"
    );
}

/// The pose after holding the robot-frame twist `t` for `time` from the origin, written from
/// the closed-form circular arc (not through `se2`).
fn arc_pose(t: Twist2<f64>, time: f64) -> Pose2<f64> {
    let th = t.yaw_rate * time;
    if t.yaw_rate.abs() < 1e-12 {
        return Pose2::new(t.vx * time, t.vy * time, th);
    }
    let w = t.yaw_rate;
    Pose2::new(
        (t.vx * th.sin() - t.vy * (1.0 - th.cos())) / w,
        (t.vx * (1.0 - th.cos()) + t.vy * th.sin()) / w,
        th,
    )
}

// ---------------------------------------------------------------------------------------------
// The formulas the issue and WPILib state.

#[test]
fn kiwi_is_the_formula_of_the_issue() {
    // ω_i = (−sin θ_i·vx + cos θ_i·vy + L·ω)/r, θ_i = 0°, 120°, 240°, L = 0.15, r = 0.05.
    let k = kiwi();
    for t in [
        Twist2::new(0.3, 0.0, 0.0),
        Twist2::new(0.0, -0.2, 0.0),
        Twist2::new(0.0, 0.0, 1.5),
        Twist2::new(0.3, 0.1, 0.5),
        Twist2::new(-1.1, 0.7, -2.0),
    ] {
        let w = k.wheel_rates(t).unwrap();
        for i in 0..3 {
            let th = (i as f64) * 2.0 * PI / 3.0;
            let want = (-th.sin() * t.vx + th.cos() * t.vy + 0.15 * t.yaw_rate) / 0.05;
            assert!(close(w[i], want, 1e-12), "wheel {i}: {} vs {want}", w[i]);
        }
        // Three wheels: the forward is the exact inverse, no slip.
        let f = k.body_fit(&w).unwrap();
        assert_twist(f.twist, t, 1e-12);
        assert!(f.slip_residual < 1e-12);
    }
}

/// WPILib `MecanumDriveKinematics` wheel-speed rows for a wheel at (x, y): FL and RR
/// `[1, −1, −(x + y)]`, FR and RL `[1, 1, x − y]` (m/s per unit chassis speed).
fn wpilib_mecanum_rows() -> [[f64; 3]; 4] {
    let (fl, fr, rl, rr) = ((0.25, 0.2), (0.25, -0.2), (-0.25, 0.2), (-0.25, -0.2));
    [
        [1.0, -1.0, -(fl.0 + fl.1)],
        [1.0, 1.0, fr.0 - fr.1],
        [1.0, 1.0, rl.0 - rl.1],
        [1.0, -1.0, -(rr.0 + rr.1)],
    ]
}

#[test]
fn mecanum_matches_wpilib_to_wheel_speeds_over_r() {
    let m = mecanum();
    let rows = wpilib_mecanum_rows();
    for t in [
        Twist2::new(0.3, 0.1, 0.5),
        Twist2::new(-0.4, 0.9, -1.3),
        Twist2::new(0.0, 0.0, 2.0),
    ] {
        let w = m.wheel_rates(t).unwrap();
        for i in 0..4 {
            let want = (rows[i][0] * t.vx + rows[i][1] * t.vy + rows[i][2] * t.yaw_rate) / 0.05;
            assert!(close(w[i], want, 1e-12), "wheel {i}: {} vs {want}", w[i]);
        }
    }
}

#[test]
fn mecanum_forward_is_the_pseudo_inverse_of_wpilibs_matrix() {
    let m = mecanum();
    let rows = wpilib_mecanum_rows();
    let a = nalgebra::SMatrix::<f64, 4, 3>::from_fn(|i, j| rows[i][j]);
    let pinv = a.pseudo_inverse(1e-12).unwrap();
    // Inconsistent wheel rates (the wheels fight): least squares, residual = slip.
    for w in [
        [1.0, 2.0, 3.0, 4.0],
        [-5.0, 0.5, 2.0, 7.0],
        [0.0, 0.0, 0.0, 1.0],
    ] {
        let speeds = nalgebra::Vector4::from_iterator(w.iter().map(|x| x * 0.05));
        let want = pinv * speeds;
        let f = m.body_fit(&w).unwrap();
        assert_twist(f.twist, Twist2::new(want[0], want[1], want[2]), 1e-12);
        // The residual along the roller axes is WPILib's wheel-speed residual times cos 45°.
        let res = (a * want - speeds).norm() * FRAC_PI_4.cos();
        assert!(
            close(f.slip_residual, res, 1e-10),
            "{} vs {res}",
            f.slip_residual
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Named physical situations.

#[test]
fn mecanum_straight_strafe_spin_and_corner() {
    let m = mecanum();
    let r = 0.05;
    // Straight: every wheel turns forward at v/r.
    let w = m.wheel_rates(Twist2::new(0.5, 0.0, 0.0)).unwrap();
    assert!(w.iter().all(|&x| close(x, 0.5 / r, 1e-12)), "{w:?}");
    // Strafe left: FL and RR backwards, FR and RL forwards.
    let w = m.wheel_rates(Twist2::new(0.0, 0.5, 0.0)).unwrap();
    let want = [-10.0, 10.0, 10.0, -10.0];
    assert!(
        w.iter().zip(want).all(|(&a, b)| close(a, b, 1e-12)),
        "{w:?}"
    );
    // Spin counter-clockwise: left side backwards, right side forwards, |x| + |y| = 0.45 m.
    let w = m.wheel_rates(Twist2::new(0.0, 0.0, 1.0)).unwrap();
    let want = [-9.0, 9.0, -9.0, 9.0];
    assert!(
        w.iter().zip(want).all(|(&a, b)| close(a, b, 1e-12)),
        "{w:?}"
    );
    // Turn about the front-left wheel: its contact does not move, so it does not turn.
    let (px, py, om) = (0.25, 0.2, 0.8);
    let w = m.wheel_rates(Twist2::new(om * py, -om * px, om)).unwrap();
    assert!(w[0].abs() < 1e-12, "{w:?}");
    assert!(w[1..].iter().all(|x| x.abs() > 1.0), "{w:?}");
}

#[test]
fn kiwi_and_x_drive_situations() {
    let k = kiwi();
    // Spin: all three wheels at L ω / r.
    let w = k.wheel_rates(Twist2::new(0.0, 0.0, 1.0)).unwrap();
    assert!(w.iter().all(|&x| close(x, 3.0, 1e-12)), "{w:?}");
    // Straight ahead: wheel 1 (θ = 0, driving along +y) does not turn; the other two turn
    // opposite ways at sin 60° v/r.
    let w = k.wheel_rates(Twist2::new(0.1, 0.0, 0.0)).unwrap();
    let s = (2.0 * PI / 3.0).sin() * 0.1 / 0.05;
    assert!(
        w[0].abs() < 1e-12 && close(w[1], -s, 1e-12) && close(w[2], s, 1e-12),
        "{w:?}"
    );
    // Turn about wheel 2 (θ = 120°): its contact stands still, so it does not turn, while the
    // forward kinematics still recovers the motion from the other two.
    let p = [0.15 * (2.0 * PI / 3.0).cos(), 0.15 * (2.0 * PI / 3.0).sin()];
    let om = -0.9;
    let t = Twist2::new(om * p[1], -om * p[0], om);
    let w = k.wheel_rates(t).unwrap();
    assert!(
        w[1].abs() < 1e-12 && w[0].abs() > 0.1 && w[2].abs() > 0.1,
        "{w:?}"
    );
    assert_twist(k.body_twist(&w).unwrap(), t, 1e-12);
    // X-drive straight ahead: the front wheels (45°, 315°) turn opposite ways, as do the rear.
    let x = Omni::<f64, 4>::new(presets::x_drive()).unwrap();
    let w = x.wheel_rates(Twist2::new(0.2, 0.0, 0.0)).unwrap();
    let s = FRAC_PI_4.sin() * 0.2 / 0.05;
    let want = [-s, -s, s, s];
    assert!(
        w.iter().zip(want).all(|(&a, b)| close(a, b, 1e-12)),
        "{w:?}"
    );
    let f = x.body_fit(&w).unwrap();
    assert_twist(f.twist, Twist2::new(0.2, 0.0, 0.0), 1e-12);
    assert!(f.slip_residual < 1e-12);
    // One X-drive wheel turning alone: the others would have to slip.
    let f = x.body_fit(&[1.0, 0.0, 0.0, 0.0]).unwrap();
    assert!(f.slip_residual > 1e-3 && f.wheel_slip.iter().all(|s| s.abs() > 1e-3));
}

#[test]
fn mecanum_torques_push_as_expected() {
    // 1 N·m on every wheel, r = 0.05: 20 N each along +x, 80 N forward, no side force, no
    // moment (the rollers cancel the sideways parts pairwise).
    let m = mecanum();
    let w = m.body_wrench(&[1.0; 4]).unwrap();
    assert!(
        close(w.fx, 80.0, 1e-12) && w.fy.abs() < 1e-12 && w.mz.abs() < 1e-12,
        "{w:?}"
    );
    // And back: a pure forward force takes equal torques.
    let t = m.wheel_torques(Wrench2::new(80.0, 0.0, 0.0)).unwrap();
    assert!(t.iter().all(|&x| close(x, 1.0, 1e-12)), "{t:?}");
}

#[test]
fn drive_trait_world_frame_goes_through_the_heading() {
    let m = mecanum();
    let t_robot = Twist2::new(0.3, -0.1, 0.4);
    let heading = 0.7;
    let w = m
        .inverse_world(t_robot.to_world(heading), heading, &m.rest())
        .unwrap();
    let direct = m.inverse(t_robot, &m.rest()).unwrap();
    assert!(w.iter().zip(direct).all(|(&a, b)| close(a, b, 1e-12)));
    let back = m.forward_world(&w, heading).unwrap();
    assert_twist(back, t_robot.to_world(heading), 1e-12);
    assert_eq!(
        m.inverse_world(t_robot, f64::NAN, &m.rest()),
        Err(InputError::NonFinite { field: "heading" })
    );
}

// ---------------------------------------------------------------------------------------------
// Rejections.

#[test]
fn rank_deficient_layouts_are_rejected() {
    // All drive directions parallel (omni rollers along x): nothing sees a sideways motion.
    let par: [OmniWheel<f64>; 3] = core::array::from_fn(|i| {
        OmniWheel::at_angle([0.1 * i as f64, 0.2 - 0.1 * i as f64], 0.0, 0.0, 0.05)
    });
    match Omni::new(par) {
        Err(GeometryError::IllConditioned {
            what, condition, ..
        }) => {
            assert!(what.contains("parallel") && condition > 1e3, "{what}")
        }
        other => panic!("{other:?}"),
    }
    // Kiwi with the wheels turned to drive radially: every constraint line passes through the
    // centre, a spin is invisible.
    let radial: [OmniWheel<f64>; 3] = core::array::from_fn(|i| {
        let th = i as f64 * 2.0 * PI / 3.0;
        OmniWheel::at_angle([0.15 * th.cos(), 0.15 * th.sin()], th, 0.0, 0.05)
    });
    match Omni::new(radial) {
        Err(GeometryError::IllConditioned { what, .. }) => {
            assert!(what.contains("one point"), "{what}")
        }
        other => panic!("{other:?}"),
    }
    // Lines through one point off the centre, (0.3, 0.1): four wheels aimed at it.
    let q = [0.3, 0.1];
    let aimed: [OmniWheel<f64>; 4] = core::array::from_fn(|i| {
        let p = [[0.2, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.2, -0.2]][i];
        OmniWheel {
            position: p,
            drive: [q[0] - p[0], q[1] - p[1]],
            roller_angle: 0.0,
            radius: 0.05,
        }
    });
    assert!(matches!(
        Omni::new(aimed),
        Err(GeometryError::IllConditioned { .. })
    ));
    // Mecanum with all rollers the same way: FL/RR and FR/RL rows coincide pairwise, rank 2.
    let mut same = presets::mecanum::<f64>();
    for w in &mut same {
        w.roller_angle = FRAC_PI_4;
    }
    assert!(matches!(
        Omni::new(same),
        Err(GeometryError::IllConditioned { .. })
    ));
    // Fewer than three wheels.
    let two = [presets::kiwi::<f64>()[0], presets::kiwi::<f64>()[1]];
    assert!(matches!(
        Omni::new(two),
        Err(GeometryError::IllConditioned { what, .. }) if what.contains("fewer than 3")
    ));
}

#[test]
fn bad_wheels_are_named() {
    let mut w = presets::mecanum::<f64>();
    w[1].radius = 0.0;
    assert_eq!(
        Omni::new(w),
        Err(GeometryError::NotPositive {
            field: "wheels[1].radius",
            value: 0.0
        })
    );
    let mut w = presets::mecanum::<f64>();
    w[2].position[1] = f64::NAN;
    assert_eq!(
        Omni::new(w),
        Err(GeometryError::NonFinite {
            field: "wheels[2].position"
        })
    );
    let mut w = presets::mecanum::<f64>();
    w[3].drive = [0.0, 0.0];
    assert!(matches!(
        Omni::new(w),
        Err(GeometryError::DeadWheel { wheel: 4, .. })
    ));
    let mut w = presets::mecanum::<f64>();
    w[0].roller_angle = FRAC_PI_2;
    assert!(matches!(
        Omni::new(w),
        Err(GeometryError::AngleOutOfRange {
            field: "wheels[0].roller_angle",
            ..
        })
    ));
    // A drive direction of any length is normalised.
    let mut w = presets::mecanum::<f64>();
    for wh in &mut w {
        wh.drive = [7.0, 0.0];
    }
    let m = Omni::new(w).unwrap();
    assert_eq!(m.wheels()[0].drive, [1.0, 0.0]);
    assert_eq!(m, mecanum());
}

#[test]
fn bad_inputs_are_named() {
    let m = mecanum();
    assert_eq!(
        m.wheel_rates(Twist2::new(0.0, f64::INFINITY, 0.0)),
        Err(InputError::NonFinite { field: "vy" })
    );
    assert_eq!(
        m.body_twist(&[0.0, 1.0, f64::NAN, 0.0]),
        Err(InputError::NonFinite {
            field: "wheel_rates[2]"
        })
    );
    assert_eq!(
        m.wheel_rates(Twist2::new(1e308, 1e308, 0.0)),
        Err(InputError::Overflow {
            quantity: "wheel_rates"
        })
    );
    assert_eq!(
        m.displacement(&[0.0; 4], &[0.0, 0.0, 0.0, f64::NEG_INFINITY]),
        Err(InputError::NonFinite {
            field: "wheel_angles[3]"
        })
    );
    // Huge but finite rates whose sum overflows are still accepted (the fast finiteness test
    // sums the rates; its slow path checks them one by one).
    let w = m.wheel_rates(Twist2::new(4e306, 0.0, 0.0)).unwrap();
    assert!(w.iter().all(|&x| close(x, 8e307, 1e-12)), "{w:?}");
    assert_eq!(
        m.wheel_torques(Wrench2::new(0.0, f64::NAN, 0.0)),
        Err(InputError::NonFinite { field: "fy" })
    );
    assert_eq!(
        m.body_wrench(&[0.0, 0.0, f64::INFINITY, 0.0]),
        Err(InputError::NonFinite {
            field: "wheel_torques[2]"
        })
    );
    assert!(matches!(
        m.desaturate([1.0; 4], 0.0),
        Err(InputError::Singular { .. })
    ));
}

// ---------------------------------------------------------------------------------------------
// Property tests over random layouts.

fn wheel() -> impl Strategy<Value = OmniWheel<f64>> {
    (
        -0.5..0.5_f64,
        -0.5..0.5_f64,
        -PI..PI,
        prop_oneof![Just(0.0), Just(FRAC_PI_4), Just(-FRAC_PI_4), -1.2..1.2_f64],
        0.02..0.1_f64,
    )
        .prop_map(|(x, y, a, rho, r)| OmniWheel::at_angle([x, y], a, rho, r))
}

fn layout<const N: usize>() -> impl Strategy<Value = Omni<f64, N>> {
    proptest::array::uniform(wheel())
        .prop_filter_map("ill-conditioned layout", |w: [OmniWheel<f64>; N]| {
            Omni::new(w).ok().filter(|o| o.condition() < 100.0)
        })
}

fn twist() -> impl Strategy<Value = Twist2<f64>> {
    (-2.0..2.0_f64, -2.0..2.0_f64, -4.0..4.0_f64).prop_map(|(a, b, c)| Twist2::new(a, b, c))
}

/// Independent least squares from the public constraint rows: the normal equations
/// `AᵀA x = Aᵀ b`, right-hand side `b_i = k_i ω_i`, solved by LU (unscaled).
fn reference_fit<const N: usize>(o: &Omni<f64, N>, w: &[f64; N]) -> Twist2<f64> {
    let mut ata = nalgebra::Matrix3::<f64>::zeros();
    let mut atb = nalgebra::Vector3::<f64>::zeros();
    for i in 0..N {
        let (r, k) = o.constraint(i).unwrap();
        let a = nalgebra::Vector3::from(r);
        ata += a * a.transpose();
        atb += a * (k * w[i]);
    }
    let x = ata.lu().solve(&atb).unwrap();
    Twist2::new(x[0], x[1], x[2])
}

/// `(x, y)` rotated by `a`.
fn rot(a: f64, v: [f64; 2]) -> [f64; 2] {
    let (s, c) = a.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

fn check_layout<const N: usize>(o: &Omni<f64, N>, t: Twist2<f64>, noise: [f64; N]) {
    // inverse∘forward = identity, with no slip.
    let w = o.wheel_rates(t).unwrap();
    let f = o.body_fit(&w).unwrap();
    assert_twist(f.twist, t, 1e-9);
    assert!(f.slip_residual < 1e-9, "{}", f.slip_residual);
    // Inconsistent rates: the fit equals an independent pseudo-inverse, and the slip vector is
    // orthogonal to the columns of A (the normal equations).
    let wn: [f64; N] = core::array::from_fn(|i| w[i] + noise[i]);
    let f = o.body_fit(&wn).unwrap();
    assert_twist(f.twist, reference_fit(o, &wn), 1e-9);
    for j in 0..3 {
        let dot: f64 = (0..N)
            .map(|i| o.constraint(i).unwrap().0[j] * f.wheel_slip[i])
            .sum();
        assert!(dot.abs() < 1e-9, "column {j}: {dot}");
    }
    let rss = f.wheel_slip.iter().map(|s| s * s).sum::<f64>().sqrt();
    assert!(close(f.slip_residual, rss, 1e-12));
    if N == 3 {
        // Square: forward∘inverse = identity too, and the noise cannot show as slip.
        let back = o.wheel_rates(f.twist).unwrap();
        assert!(back.iter().zip(wn).all(|(&a, b)| close(a, b, 1e-8)));
        assert!(f.slip_residual < 1e-9);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn inverse_forward_and_least_squares_3(o in layout::<3>(), t in twist(),
                                           n in proptest::array::uniform3(-3.0..3.0_f64)) {
        check_layout(&o, t, n);
    }

    #[test]
    fn inverse_forward_and_least_squares_4(o in layout::<4>(), t in twist(),
                                           n in proptest::array::uniform4(-3.0..3.0_f64)) {
        check_layout(&o, t, n);
    }

    #[test]
    fn inverse_forward_and_least_squares_6(o in layout::<6>(), t in twist(),
                                           n in proptest::array::uniform6(-3.0..3.0_f64)) {
        check_layout(&o, t, n);
    }

    /// Rotating the whole layout (positions and drive directions) by `a` and the twist with it
    /// leaves every wheel rate unchanged; the condition number is unchanged too.
    #[test]
    fn frame_invariance(o in layout::<4>(), t in twist(), a in -PI..PI) {
        let turned: [OmniWheel<f64>; 4] = o.wheels().map(|w| OmniWheel {
            position: rot(a, w.position),
            drive: rot(a, w.drive),
            ..w
        });
        let ot = Omni::new(turned).unwrap();
        let w = o.wheel_rates(t).unwrap();
        let wt = ot.wheel_rates(t.rotated(a)).unwrap();
        for i in 0..4 {
            prop_assert!(close(w[i], wt[i], 1e-9), "{i}: {w:?} vs {wt:?}");
        }
        prop_assert!(close(o.condition(), ot.condition(), 1e-6));
        let back = ot.body_twist(&wt).unwrap();
        assert_twist(back, t.rotated(a), 1e-9);
    }

    /// Desaturation scales every rate by one factor: the largest is at the limit and the
    /// forward kinematics gives the same twist scaled, so direction and curvature are kept.
    #[test]
    fn desaturation_preserves_direction(o in layout::<4>(), t in twist(), max in 0.5..50.0_f64) {
        let w = o.wheel_rates(t).unwrap();
        let d = o.desaturate(w, max).unwrap();
        let peak = w.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let dpeak = d.actuators.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        prop_assert!(d.scale > 0.0 && d.scale <= 1.0);
        if peak > max {
            prop_assert!(close(dpeak, max, 1e-12));
        } else {
            prop_assert_eq!(d.scale, 1.0);
            prop_assert_eq!(d.actuators, w);
        }
        let f = o.body_twist(&d.actuators).unwrap();
        let s = d.scale;
        assert_twist(f, Twist2::new(t.vx * s, t.vy * s, t.yaw_rate * s), 1e-9);
    }

    /// Odometry on a circular arc is exact whatever the step: the encoder angles of a constant
    /// twist, fed in `steps` samples, land on the closed-form arc; with a gyro too.
    #[test]
    fn odometry_is_exact_on_arcs(o in layout::<4>(), t in twist(), steps in 1usize..40,
                                 total in 0.1..3.0_f64, yaw0 in -PI..PI) {
        let w = o.wheel_rates(t).unwrap();
        let start = Pose2::new(0.0, 0.0, 0.0);
        let mut odo = Odometry::new(Robot::Omni4(o), start);
        let mut gyro = Odometry::new(Robot::Omni4(o), start);
        odo.update(&EncoderReading::new(0.0, [0.0; 4]), HeadingInput::Wheels).unwrap();
        gyro.update(&EncoderReading::new(0.0, [0.0; 4]), HeadingInput::Absolute(yaw0)).unwrap();
        let dt = total / steps as f64;
        for k in 1..=steps {
            let q = EncoderReading::new(dt * k as f64, w.map(|x| x * dt * k as f64));
            odo.update(&q, HeadingInput::Wheels).unwrap();
            gyro.update(&q, HeadingInput::Absolute(yaw0 + t.yaw_rate * dt * k as f64)).unwrap();
        }
        let want = arc_pose(t, total);
        // A gyro sampled once per step cannot tell a turn of more than π per step from its
        // wrapped complement; the wheels can.
        let both = [odo.pose(), gyro.pose()];
        let n = if (t.yaw_rate * dt).abs() < 3.0 { 2 } else { 1 };
        for &p in &both[..n] {
            prop_assert!((p.x - want.x).abs() < 1e-9 && (p.y - want.y).abs() < 1e-9,
                         "{p:?} vs {want:?}");
            let e = (p.heading - want.heading).sin().abs() + (1.0 - (p.heading - want.heading).cos());
            prop_assert!(e < 1e-9, "{p:?} vs {want:?}");
        }
    }

    /// The torque map is the dual of the velocity map (virtual work `τ·ω = W·t`), the
    /// minimum-norm torques give the wrench back, and they are orthogonal to every torque
    /// vector that exerts no wrench (so no other torques for that wrench are smaller).
    #[test]
    fn torques_are_dual_and_minimum_norm(o in layout::<4>(), t in twist(),
                                         tau in proptest::array::uniform4(-2.0..2.0_f64)) {
        let w = o.wheel_rates(t).unwrap();
        let wr = o.body_wrench(&tau).unwrap();
        let p_wheels: f64 = tau.iter().zip(w).map(|(a, b)| a * b).sum();
        let p_body = wr.fx * t.vx + wr.fy * t.vy + wr.mz * t.yaw_rate;
        prop_assert!(close(p_wheels, p_body, 1e-9), "{p_wheels} vs {p_body}");
        let tmin = o.wheel_torques(wr).unwrap();
        let back = o.body_wrench(&tmin).unwrap();
        prop_assert!(close(back.fx, wr.fx, 1e-9) && close(back.fy, wr.fy, 1e-9)
                     && close(back.mz, wr.mz, 1e-9), "{back:?} vs {wr:?}");
        let null: Vec<f64> = tau.iter().zip(tmin).map(|(a, b)| a - b).collect();
        let dot: f64 = null.iter().zip(tmin).map(|(a, b)| a * b).sum();
        let scale = 1.0 + tau.iter().map(|x| x * x).sum::<f64>();
        prop_assert!(dot.abs() < 1e-9 * scale, "{dot}");
        prop_assert!(tmin.iter().map(|x| x * x).sum::<f64>() <= scale - 1.0 + 1e-9);
    }

    /// Single precision agrees with double to f32 accuracy (relative to the rates' size).
    #[test]
    fn f32_agrees_with_f64(o in layout::<4>(), t in twist()) {
        let w32: [OmniWheel<f32>; 4] = o.wheels().map(|w| OmniWheel {
            position: w.position.map(|x| x as f32),
            drive: w.drive.map(|x| x as f32),
            roller_angle: w.roller_angle as f32,
            radius: w.radius as f32,
        });
        let o32 = Omni::<f32, 4>::new(w32).unwrap();
        let w = o.wheel_rates(t).unwrap();
        let w32 = o32
            .wheel_rates(Twist2::new(t.vx as f32, t.vy as f32, t.yaw_rate as f32))
            .unwrap();
        let scale = 1.0 + w.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        for i in 0..4 {
            prop_assert!((w[i] - w32[i] as f64).abs() < 1e-4 * scale, "{i}");
        }
        let b = o32.body_twist(&w32).unwrap();
        let tscale = 1.0 + t.vx.abs() + t.vy.abs() + t.yaw_rate.abs();
        prop_assert!((b.vx as f64 - t.vx).abs() < 1e-3 * tscale);
        prop_assert!((b.vy as f64 - t.vy).abs() < 1e-3 * tscale);
        prop_assert!((b.yaw_rate as f64 - t.yaw_rate).abs() < 1e-3 * tscale);
    }
}

// ---------------------------------------------------------------------------------------------
// No allocation (as tests/no_alloc.rs).

#[global_allocator]
static GLOBAL: omnikin_testkit::Counting = omnikin_testkit::Counting;

#[test]
fn omni_calls_allocate_nothing() {
    let before = allocation_count();
    let acc = std::hint::black_box({
        let mut acc = 0.0f64;
        let m = Omni::new(presets::mecanum::<f64>()).unwrap();
        let k = Omni::new(presets::kiwi::<f32>()).unwrap();
        let t = Twist2::new(0.3, 0.1, 0.5);
        let w = m.wheel_rates(t).unwrap();
        acc += m.body_fit(&w).unwrap().slip_residual + m.body_twist(&w).unwrap().vx;
        acc += m.desaturate(w, 1.0).unwrap().scale;
        acc += m.wheel_rates(Twist2::new(f64::NAN, 0.0, 0.0)).is_err() as u8 as f64;
        acc += m.body_twist(&[0.0, f64::NAN, 0.0, 0.0]).is_err() as u8 as f64;
        acc += k.wheel_rates(Twist2::new(0.1, 0.0, 0.2)).unwrap()[0] as f64;
        let mut odo = Odometry::new(Robot::Omni4(m), Pose2::default());
        odo.update(
            &EncoderReading::new(0.0, [0.0; 4]),
            HeadingInput::Absolute(0.0),
        )
        .unwrap();
        acc += odo
            .update(&EncoderReading::new(1.0, w), HeadingInput::Absolute(0.1))
            .unwrap()
            .pose
            .x;
        let mut bad = presets::mecanum::<f64>();
        bad[0].radius = -1.0;
        acc += Omni::new(bad).is_err() as u8 as f64;
        acc
    });
    assert!(acc.is_finite());
    assert_eq!(allocation_count() - before, 0);
}

// ---------------------------------------------------------------------------------------------
// The preset files (robots/*.toml, the schema proposed in `drive`'s docs) describe the same
// robots as `presets`.

/// The wheels of an `omni` robot file: `[[geometry.wheels]]` with `position`,
/// `drive_angle_deg`, `roller_angle_deg`, `radius`.
#[cfg(feature = "std")]
fn wheels_of_file<const N: usize>(text: &str) -> [OmniWheel<f64>; N] {
    let v: toml::Value = toml::from_str(text).unwrap();
    assert_eq!(v["kind"].as_str(), Some("omni"));
    let wheels = v["geometry"]["wheels"].as_array().unwrap();
    assert_eq!(wheels.len(), N);
    core::array::from_fn(|i| {
        let w = &wheels[i];
        let p = w["position"].as_array().unwrap();
        OmniWheel::at_angle(
            [p[0].as_float().unwrap(), p[1].as_float().unwrap()],
            w["drive_angle_deg"].as_float().unwrap().to_radians(),
            w["roller_angle_deg"].as_float().unwrap().to_radians(),
            w["radius"].as_float().unwrap(),
        )
    })
}

#[cfg(feature = "std")]
#[test]
fn preset_files_match_the_presets() {
    let files = omnikin::description::PRESETS
        .into_iter()
        .filter(|(name, _)| ["kiwi", "x-drive", "mecanum"].contains(name))
        .collect::<Vec<_>>();
    assert_eq!(
        files.len(),
        3,
        "the omni presets are kiwi, x-drive, mecanum"
    );
    let twists = [
        Twist2::new(0.3, 0.1, 0.5),
        Twist2::new(-0.2, 0.4, -1.0),
        Twist2::new(0.0, 0.0, 1.0),
    ];
    for (name, text) in files {
        let v: toml::Value = toml::from_str(text).unwrap();
        assert_eq!(v["name"].as_str(), Some(name));
        if name == "kiwi" {
            let a = Omni::new(wheels_of_file::<3>(text)).unwrap();
            for t in twists {
                let (x, y) = (a.wheel_rates(t).unwrap(), kiwi().wheel_rates(t).unwrap());
                assert!(x.iter().zip(y).all(|(&p, q)| close(p, q, 1e-12)), "{name}");
            }
        } else {
            let a = Omni::new(wheels_of_file::<4>(text)).unwrap();
            let b = if name == "mecanum" {
                mecanum()
            } else {
                Omni::new(presets::x_drive()).unwrap()
            };
            for t in twists {
                let (x, y) = (a.wheel_rates(t).unwrap(), b.wheel_rates(t).unwrap());
                assert!(x.iter().zip(y).all(|(&p, q)| close(p, q, 1e-12)), "{name}");
            }
        }
    }
}
