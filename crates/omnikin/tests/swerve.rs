//! Tests of the centred swerve drive (`drive::swerve`): WPILib's `ToSwerveModuleStates`,
//! `ToChassisSpeeds` and `Optimize` written out independently, named physical situations, the
//! zero-speed case, property tests over random layouts (inverse∘forward, least squares,
//! frame invariance, optimisation, desaturation, steer rates, exact odometry on arcs, f32
//! against f64), rank-deficient rejection, input errors and zero allocation.

use omnikin_testkit::allocation_count;

use core::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use omnikin::Robot;
use omnikin::drive::swerve::{Swerve, SwerveModule, SwerveState, swerve4};
use omnikin::drive::{Drive, Rot2, Wrench2};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::{GeometryError, InputError, Pose2, Twist2};
use proptest::prelude::*;

fn preset() -> Swerve<f64, 4> {
    Swerve::new(swerve4()).unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + b.abs())
}

/// `a − b` wrapped into (−π, π].
fn angle_diff(a: f64, b: f64) -> f64 {
    omnikin::wrap_angle(a - b)
}

fn assert_twist(a: Twist2<f64>, b: Twist2<f64>, tol: f64) {
    assert!(
        close(a.vx, b.vx, tol) && close(a.vy, b.vy, tol) && close(a.yaw_rate, b.yaw_rate, tol),
        "{a:?} vs {b:?}"
    );
}

/// WPILib `ToSwerveModuleStates` for modules at `pos`: speed `|(vx − ω y, vy + ω x)|`, angle
/// `atan2` of it (m/s, rad).
fn wpilib_states(pos: &[[f64; 2]], t: Twist2<f64>) -> Vec<(f64, f64)> {
    pos.iter()
        .map(|p| {
            let (u, w) = (t.vx - t.yaw_rate * p[1], t.vy + t.yaw_rate * p[0]);
            (u.hypot(w), w.atan2(u))
        })
        .collect()
}

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

const REST: [Rot2<f64>; 4] = [Rot2 { cos: 1.0, sin: 0.0 }; 4];

#[test]
fn inverse_equals_wpilib_to_swerve_module_states_over_r() {
    let s = preset();
    let pos: Vec<[f64; 2]> = s.modules().iter().map(|m| m.position).collect();
    for t in [
        Twist2::new(0.3, 0.1, 0.5),
        Twist2::new(-1.0, 0.4, -2.5),
        Twist2::new(0.0, 0.0, 1.0),
        Twist2::new(2.0, -3.0, 0.0),
    ] {
        let st = s.module_states(t, &REST).unwrap();
        for (i, (speed, angle)) in wpilib_states(&pos, t).into_iter().enumerate() {
            assert!(close(st.wheel_rates[i], speed / 0.05, 1e-12), "{i}");
            assert!(st.wheel_rates[i] >= 0.0);
            assert!(angle_diff(st.steer[i].angle(), angle).abs() < 1e-12, "{i}");
        }
        assert_twist(s.body_twist(&st).unwrap(), t, 1e-12);
    }
}

#[test]
fn forward_equals_wpilib_pseudo_inverse() {
    // ToChassisSpeeds: the SVD pseudo-inverse of the 8×3 matrix [[1, 0, −y_i], [0, 1, x_i]]
    // applied to the module velocities (nalgebra's SVD here, not the normal equations).
    let s = preset();
    let b = nalgebra::SMatrix::<f64, 8, 3>::from_fn(|r, c| {
        let p = s.modules()[r / 2].position;
        match (r % 2, c) {
            (0, 0) | (1, 1) => 1.0,
            (0, 2) => -p[1],
            (1, 2) => p[0],
            _ => 0.0,
        }
    });
    let pinv = b.pseudo_inverse(1e-12).unwrap();
    let st = SwerveState::from_angles([10.0, 3.0, -4.0, 7.0], [0.3, -2.0, 1.0, 2.9]);
    let u = nalgebra::SVector::<f64, 8>::from_fn(|r, _| {
        let i = r / 2;
        let v = st.wheel_rates[i] * 0.05;
        if r % 2 == 0 {
            v * st.steer[i].cos
        } else {
            v * st.steer[i].sin
        }
    });
    let x = pinv * u;
    let f = s.body_fit(&st).unwrap();
    assert_twist(f.twist, Twist2::new(x[0], x[1], x[2]), 1e-12);
    assert!(close(f.slip_residual, (b * x - u).norm(), 1e-10));
}

#[test]
fn straight_strafe_spin_corner_and_stop() {
    let s = preset();
    let st = s.module_states(Twist2::new(0.5, 0.0, 0.0), &REST).unwrap();
    assert!(st.wheel_rates.iter().all(|&w| close(w, 10.0, 1e-12)));
    assert!(st.steer.iter().all(|r| r.angle().abs() < 1e-12));
    let st = s.module_states(Twist2::new(0.0, -0.5, 0.0), &REST).unwrap();
    assert!(st.steer.iter().all(|r| close(r.angle(), -FRAC_PI_2, 1e-12)));
    // Spin: every module tangent to the circle through it, FL at 135°, FR 45°, RL −135°,
    // RR −45°, all at 0.3·√2·ω / r.
    let st = s.module_states(Twist2::new(0.0, 0.0, 1.0), &REST).unwrap();
    let want = [3.0 * FRAC_PI_4, FRAC_PI_4, -3.0 * FRAC_PI_4, -FRAC_PI_4];
    for i in 0..4 {
        assert!(
            angle_diff(st.steer[i].angle(), want[i]).abs() < 1e-12,
            "{i}"
        );
        assert!(close(st.wheel_rates[i], 0.3 * 2f64.sqrt() / 0.05, 1e-12));
    }
    // Turn about the front-left module: it stands still and keeps its steering; the far
    // corner (RR) runs fastest.
    let prev = [Rot2::from_angle(0.7); 4];
    let om = 1.2;
    let st = s
        .module_states(Twist2::new(om * 0.3, -om * 0.3, om), &prev)
        .unwrap();
    assert!(st.wheel_rates[0].abs() < 1e-12);
    assert_eq!(st.steer[0], prev[0]);
    assert!(st.wheel_rates[3] > st.wheel_rates[1] && st.wheel_rates[3] > st.wheel_rates[2]);
    // Stop: every module keeps its previous steering (WPILib keeps its module headings).
    let prev: [Rot2<f64>; 4] = core::array::from_fn(|i| Rot2::from_angle(0.3 * i as f64 - 1.0));
    let st = s.module_states(Twist2::new(0.0, 0.0, 0.0), &prev).unwrap();
    assert_eq!(st.steer, prev);
    assert_eq!(st.wheel_rates, [0.0; 4]);
    // Through the trait: `current` carries the steering.
    let cur = SwerveState {
        wheel_rates: [1.0; 4],
        steer: prev,
    };
    assert_eq!(s.inverse(Twist2::default(), &cur).unwrap().steer, prev);
}

#[test]
fn torques_straight_spin_and_singular_steering() {
    let s = preset();
    // All modules forward, 1 N·m each at r = 0.05: 80 N forward.
    let fwd = [Rot2::identity(); 4];
    let w = s.body_wrench(&[1.0; 4], &fwd).unwrap();
    assert!(close(w.fx, 80.0, 1e-12) && w.fy.abs() < 1e-12 && w.mz.abs() < 1e-12);
    // All parallel: no side force possible.
    assert!(matches!(
        s.wheel_torques(Wrench2::new(0.0, 10.0, 0.0), &fwd),
        Err(InputError::Singular { .. })
    ));
    // Spin steering (tangent), a pure moment: equal torques, M = 4 · τ/r · 0.3√2.
    let spin = s
        .module_states(Twist2::new(0.0, 0.0, 1.0), &REST)
        .unwrap()
        .steer;
    let m = s.body_wrench(&[1.0; 4], &spin).unwrap();
    let mz = 4.0 * 20.0 * 0.3 * 2f64.sqrt();
    assert!(close(m.mz, mz, 1e-12) && m.fx.abs() < 1e-12 && m.fy.abs() < 1e-12);
    let t = s.wheel_torques(Wrench2::new(0.0, 0.0, mz), &spin).unwrap();
    assert!(t.iter().all(|&x| close(x, 1.0, 1e-12)), "{t:?}");
    // Every module aimed at one point (all wheel lines through the centre: radial steering):
    // no moment is possible.
    let radial: [Rot2<f64>; 4] = core::array::from_fn(|i| {
        let p = s.modules()[i].position;
        Rot2::from_vector(p[0], p[1]).unwrap()
    });
    assert!(matches!(
        s.wheel_torques(Wrench2::new(0.0, 0.0, 1.0), &radial),
        Err(InputError::Singular { .. })
    ));
    // A generic steering works both ways.
    let st = s
        .module_states(Twist2::new(0.3, 0.1, 0.5), &REST)
        .unwrap()
        .steer;
    let want = Wrench2::new(3.0, -2.0, 0.7);
    let t = s.wheel_torques(want, &st).unwrap();
    let back = s.body_wrench(&t, &st).unwrap();
    assert!(close(back.fx, 3.0, 1e-9) && close(back.fy, -2.0, 1e-9) && close(back.mz, 0.7, 1e-9));
}

#[test]
fn optimisation_flips_and_reverses_like_wpilib() {
    // WPILib Optimize: if |target − current| > 90°, speed = −speed and angle += 180°.
    let s = preset().with_optimization(true);
    assert!(s.optimizes());
    let t = Twist2::new(-0.5, 0.0, 0.0); // every module wants 180°
    let cur = SwerveState {
        wheel_rates: [0.0; 4],
        steer: [Rot2::from_angle(0.2); 4],
    };
    let st = s.inverse(t, &cur).unwrap();
    for i in 0..4 {
        assert!(close(st.wheel_rates[i], -10.0, 1e-12));
        assert!(st.steer[i].angle().abs() < 1e-12);
    }
    assert_twist(s.body_twist(&st).unwrap(), t, 1e-12);
    // Within 90°: unchanged.
    let cur = SwerveState {
        wheel_rates: [0.0; 4],
        steer: [Rot2::from_angle(PI - 0.2); 4],
    };
    let st = s.inverse(t, &cur).unwrap();
    assert!(st.wheel_rates.iter().all(|&w| close(w, 10.0, 1e-12)));
    // Without the option the trait inverse does not optimise.
    let plain = preset().inverse(t, &cur).unwrap();
    assert!(plain.wheel_rates.iter().all(|&w| w >= 0.0));
}

#[test]
fn rank_deficient_and_bad_modules_are_rejected() {
    let one = [swerve4::<f64>()[0]];
    assert!(matches!(
        Swerve::new(one),
        Err(GeometryError::IllConditioned { what, .. }) if what.contains("fewer than 2")
    ));
    let m = SwerveModule {
        position: [0.2, 0.1],
        wheel_radius: 0.05,
    };
    assert!(matches!(
        Swerve::new([m, m, m]),
        Err(GeometryError::IllConditioned { what, .. }) if what.contains("one point")
    ));
    let o = SwerveModule {
        position: [0.0, 0.0],
        wheel_radius: 0.05,
    };
    assert!(matches!(
        Swerve::new([o, o]),
        Err(GeometryError::IllConditioned { .. })
    ));
    // Two modules at distinct points are enough.
    assert!(Swerve::new([m, o]).is_ok());
    let mut ms = swerve4::<f64>();
    ms[2].wheel_radius = -0.05;
    assert_eq!(
        Swerve::new(ms),
        Err(GeometryError::NotPositive {
            field: "modules[2].wheel_radius",
            value: -0.05
        })
    );
    let mut ms = swerve4::<f64>();
    ms[3].position[0] = f64::INFINITY;
    assert_eq!(
        Swerve::new(ms),
        Err(GeometryError::NonFinite {
            field: "modules[3].position"
        })
    );
}

#[test]
fn bad_inputs_are_named() {
    let s = preset();
    assert_eq!(
        s.module_states(Twist2::new(0.0, 0.0, f64::NAN), &REST),
        Err(InputError::NonFinite { field: "yaw_rate" })
    );
    let mut st = SwerveState::from_angles([1.0; 4], [0.0; 4]);
    st.steer[1].sin = f64::NAN;
    assert_eq!(
        s.body_twist(&st),
        Err(InputError::NonFinite { field: "steer[1]" })
    );
    let st = SwerveState::from_angles([1.0, 1.0, 1.0, f64::INFINITY], [0.0; 4]);
    assert_eq!(
        s.body_twist(&st),
        Err(InputError::NonFinite {
            field: "wheel_rates[3]"
        })
    );
    assert_eq!(
        s.module_states(Twist2::new(1e300, 1e300, 0.0), &REST),
        Err(InputError::Overflow {
            quantity: "wheel_rates"
        })
    );
}

// ---------------------------------------------------------------------------------------------
// Property tests.

fn module() -> impl Strategy<Value = SwerveModule<f64>> {
    (-0.5..0.5_f64, -0.5..0.5_f64, 0.02..0.1_f64).prop_map(|(x, y, r)| SwerveModule {
        position: [x, y],
        wheel_radius: r,
    })
}

fn layout<const N: usize>() -> impl Strategy<Value = Swerve<f64, N>> {
    proptest::array::uniform(module())
        .prop_filter_map("ill-conditioned layout", |m: [SwerveModule<f64>; N]| {
            Swerve::new(m).ok().filter(|s| s.condition() < 100.0)
        })
}

fn twist() -> impl Strategy<Value = Twist2<f64>> {
    (-2.0..2.0_f64, -2.0..2.0_f64, -4.0..4.0_f64).prop_map(|(a, b, c)| Twist2::new(a, b, c))
}

fn rot(a: f64, v: [f64; 2]) -> [f64; 2] {
    let (s, c) = a.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

fn check_layout<const N: usize>(s: &Swerve<f64, N>, t: Twist2<f64>, noise: [f64; N]) {
    let rest = [Rot2::identity(); N];
    let st = s.module_states(t, &rest).unwrap();
    let pos: Vec<[f64; 2]> = s.modules().iter().map(|m| m.position).collect();
    for (i, (speed, angle)) in wpilib_states(&pos, t).into_iter().enumerate() {
        assert!(close(
            st.wheel_rates[i] * s.modules()[i].wheel_radius,
            speed,
            1e-12
        ));
        if speed > 1e-6 {
            assert!(angle_diff(st.steer[i].angle(), angle).abs() < 1e-9);
        }
    }
    let f = s.body_fit(&st).unwrap();
    assert_twist(f.twist, t, 1e-9);
    assert!(f.slip_residual < 1e-9);
    // Perturbed wheel rates: the normal equations hold, Σ B_iᵀ e_i = 0.
    let mut noisy = st;
    for i in 0..N {
        noisy.wheel_rates[i] += noise[i];
    }
    let f = s.body_fit(&noisy).unwrap();
    let mut normal = [0.0; 3];
    for (i, m) in s.modules().iter().enumerate() {
        let [px, py] = m.position;
        let v = noisy.wheel_rates[i] * m.wheel_radius;
        let eu = f.twist.vx - f.twist.yaw_rate * py - v * noisy.steer[i].cos;
        let ew = f.twist.vy + f.twist.yaw_rate * px - v * noisy.steer[i].sin;
        normal[0] += eu;
        normal[1] += ew;
        normal[2] += -py * eu + px * ew;
        assert!(close(f.module_slip[i], eu.hypot(ew), 1e-9));
    }
    assert!(normal.iter().all(|x| x.abs() < 1e-9), "{normal:?}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn inverse_forward_and_least_squares_2(s in layout::<2>(), t in twist(),
                                           n in proptest::array::uniform2(-3.0..3.0_f64)) {
        check_layout(&s, t, n);
    }

    #[test]
    fn inverse_forward_and_least_squares_4(s in layout::<4>(), t in twist(),
                                           n in proptest::array::uniform4(-3.0..3.0_f64)) {
        check_layout(&s, t, n);
    }

    #[test]
    fn inverse_forward_and_least_squares_5(s in layout::<5>(), t in twist(),
                                           n in proptest::array::uniform5(-3.0..3.0_f64)) {
        check_layout(&s, t, n);
    }

    /// Rotating the layout by `a` and the twist with it: the same wheel rates, every steering
    /// direction turned by `a`.
    #[test]
    fn frame_invariance(s in layout::<4>(), t in twist(), a in -PI..PI) {
        let turned = s.modules().map(|m| SwerveModule { position: rot(a, m.position), ..m });
        let st_turned = Swerve::new(turned).unwrap();
        let st = s.module_states(t, &REST).unwrap();
        let sr = st_turned.module_states(t.rotated(a), &REST).unwrap();
        for i in 0..4 {
            prop_assert!(close(st.wheel_rates[i], sr.wheel_rates[i], 1e-9));
            if st.wheel_rates[i] > 1e-6 {
                prop_assert!(angle_diff(sr.steer[i].angle(), st.steer[i].angle() + a).abs() < 1e-9);
            }
        }
    }

    /// Optimisation: no module turns by more than 90° from where it is, the motion is the
    /// same, and a module is flipped exactly when WPILib's rule says so.
    #[test]
    fn optimisation_keeps_the_motion(s in layout::<4>(), t in twist(),
                                     cur in proptest::array::uniform4(-PI..PI)) {
        let cur = cur.map(Rot2::from_angle);
        let plain = s.module_states(t, &cur).unwrap();
        let opt = Swerve::optimize(plain, &cur);
        for i in 0..4 {
            let delta = angle_diff(plain.steer[i].angle(), cur[i].angle());
            let flipped = opt.wheel_rates[i] != plain.wheel_rates[i];
            if (delta.abs() - FRAC_PI_2).abs() > 1e-9 && plain.wheel_rates[i] != 0.0 {
                prop_assert_eq!(flipped, delta.abs() > FRAC_PI_2);
            }
            prop_assert!(angle_diff(opt.steer[i].angle(), cur[i].angle()).abs() <= FRAC_PI_2 + 1e-9);
        }
        assert_twist(s.body_twist(&opt).unwrap(), s.body_twist(&plain).unwrap(), 1e-9);
    }

    /// Desaturation keeps every steering direction and scales the twist.
    #[test]
    fn desaturation_preserves_direction(s in layout::<4>(), t in twist(), max in 0.5..50.0_f64) {
        let st = s.module_states(t, &REST).unwrap();
        let d = s.desaturate(st, max).unwrap();
        prop_assert_eq!(d.actuators.steer, st.steer);
        prop_assert!(d.actuators.wheel_rates.iter().all(|w| w.abs() <= max * (1.0 + 1e-12)));
        let k = d.scale;
        assert_twist(s.body_twist(&d.actuators).unwrap(),
                     Twist2::new(t.vx * k, t.vy * k, t.yaw_rate * k), 1e-9);
    }

    /// Steer rates and wheel accelerations equal the central difference of the inverse along
    /// `t + τ·ṫ`.
    #[test]
    fn steer_rates_are_the_derivative(s in layout::<4>(), t in twist(), dt in twist()) {
        let h = 1e-6;
        let at = |tau: f64| Twist2::new(t.vx + tau * dt.vx, t.vy + tau * dt.vy,
                                        t.yaw_rate + tau * dt.yaw_rate);
        let (a, b) = (s.module_states(at(-h), &REST).unwrap(), s.module_states(at(h), &REST).unwrap());
        let r = s.steer_rates(t, dt).unwrap();
        let st = s.module_states(t, &REST).unwrap();
        for i in 0..4 {
            let speed = st.wheel_rates[i] * s.modules()[i].wheel_radius;
            prop_assume!(speed > 1e-2);
            let ds = angle_diff(b.steer[i].angle(), a.steer[i].angle()) / (2.0 * h);
            let dw = (b.wheel_rates[i] - a.wheel_rates[i]) / (2.0 * h);
            prop_assert!((r.steer_rates[i] - ds).abs() < 1e-4 * (1.0 + ds.abs()), "{i}");
            prop_assert!((r.wheel_accels[i] - dw).abs() < 1e-4 * (1.0 + dw.abs()), "{i}");
        }
    }

    /// Odometry on an arc is exact whatever the step, with and without a gyro.
    #[test]
    fn odometry_is_exact_on_arcs(s in layout::<4>(), t in twist(), steps in 1usize..40,
                                 total in 0.1..3.0_f64, yaw0 in -PI..PI) {
        let st = s.module_states(t, &REST).unwrap();
        let at = |k: usize, dt: f64| EncoderReading::with_steer(
            dt * k as f64,
            st.wheel_rates.map(|w| w * dt * k as f64),
            st.steer_angles(),
        );
        let start = Pose2::new(0.0, 0.0, 0.0);
        let mut odo = Odometry::new(Robot::Swerve4(s), start);
        let mut gyro = Odometry::new(Robot::Swerve4(s), start);
        let dt = total / steps as f64;
        odo.update(&at(0, dt), HeadingInput::Wheels).unwrap();
        gyro.update(&at(0, dt), HeadingInput::Absolute(yaw0)).unwrap();
        for k in 1..=steps {
            odo.update(&at(k, dt), HeadingInput::Wheels).unwrap();
            gyro.update(&at(k, dt), HeadingInput::Absolute(yaw0 + t.yaw_rate * dt * k as f64))
                .unwrap();
        }
        let want = arc_pose(t, total);
        let both = [odo.pose(), gyro.pose()];
        let n = if (t.yaw_rate * dt).abs() < 3.0 { 2 } else { 1 };
        for &p in &both[..n] {
            prop_assert!((p.x - want.x).abs() < 1e-9 && (p.y - want.y).abs() < 1e-9,
                         "{p:?} vs {want:?}");
            prop_assert!(angle_diff(p.heading, want.heading).abs() < 1e-9);
        }
    }

    /// Torques: virtual work `τ·ω = W·t` at the steering of the motion, minimum-norm torques
    /// give the wrench back and are orthogonal to the wrench-free torques.
    #[test]
    fn torques_are_dual_and_minimum_norm(s in layout::<4>(), t in twist(),
                                         tau in proptest::array::uniform4(-2.0..2.0_f64)) {
        let st = s.module_states(t, &REST).unwrap();
        let wr = s.body_wrench(&tau, &st.steer).unwrap();
        let p_wheels: f64 = tau.iter().zip(st.wheel_rates).map(|(a, b)| a * b).sum();
        let p_body = wr.fx * t.vx + wr.fy * t.vy + wr.mz * t.yaw_rate;
        prop_assert!(close(p_wheels, p_body, 1e-9), "{p_wheels} vs {p_body}");
        match s.wheel_torques(wr, &st.steer) {
            Ok(tmin) => {
                let back = s.body_wrench(&tmin, &st.steer).unwrap();
                prop_assert!(close(back.fx, wr.fx, 1e-7) && close(back.fy, wr.fy, 1e-7)
                             && close(back.mz, wr.mz, 1e-7), "{back:?} vs {wr:?}");
                let dot: f64 = tau.iter().zip(tmin).map(|(a, b)| (a - b) * b).sum();
                let scale = 1.0 + tau.iter().map(|x| x * x).sum::<f64>();
                prop_assert!(dot.abs() < 1e-7 * scale, "{dot}");
            }
            Err(e) => prop_assert!(matches!(e, InputError::Singular { .. }), "{e:?}"),
        }
    }

    #[test]
    fn f32_agrees_with_f64(s in layout::<4>(), t in twist()) {
        let m32 = s.modules().map(|m| SwerveModule {
            position: m.position.map(|x| x as f32),
            wheel_radius: m.wheel_radius as f32,
        });
        let s32 = Swerve::<f32, 4>::new(m32).unwrap();
        let t32 = Twist2::new(t.vx as f32, t.vy as f32, t.yaw_rate as f32);
        let st = s.module_states(t, &REST).unwrap();
        let st32 = s32.module_states(t32, &[Rot2::identity(); 4]).unwrap();
        let scale = 1.0 + st.wheel_rates.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        for i in 0..4 {
            prop_assert!((st.wheel_rates[i] - st32.wheel_rates[i] as f64).abs() < 1e-4 * scale);
            if st.wheel_rates[i] > 1e-2 * scale {
                prop_assert!(angle_diff(st.steer[i].angle(), st32.steer[i].angle() as f64).abs() < 1e-3);
            }
        }
        let b = s32.body_twist(&st32).unwrap();
        let ts = 1.0 + t.vx.abs() + t.vy.abs() + t.yaw_rate.abs();
        prop_assert!((b.vx as f64 - t.vx).abs() < 1e-3 * ts);
        prop_assert!((b.vy as f64 - t.vy).abs() < 1e-3 * ts);
        prop_assert!((b.yaw_rate as f64 - t.yaw_rate).abs() < 1e-3 * ts);
    }
}

// ---------------------------------------------------------------------------------------------
// No allocation (as tests/no_alloc.rs).

#[global_allocator]
static GLOBAL: omnikin_testkit::Counting = omnikin_testkit::Counting;

#[test]
fn swerve_calls_allocate_nothing() {
    let before = allocation_count();
    let acc = std::hint::black_box({
        let mut acc = 0.0f64;
        let s = Swerve::new(swerve4::<f64>())
            .unwrap()
            .with_optimization(true);
        let t = Twist2::new(0.3, 0.1, 0.5);
        let st = s.inverse(t, &s.rest()).unwrap();
        acc += s.body_fit(&st).unwrap().slip_residual + s.forward(&st).unwrap().vx;
        acc += s.desaturate(st, 1.0).unwrap().scale;
        acc += s.steer_rates(t, t).unwrap().steer_rates[0];
        acc += s
            .module_states(Twist2::new(f64::NAN, 0.0, 0.0), &REST)
            .is_err() as u8 as f64;
        let mut odo = Odometry::new(Robot::Swerve4(s), Pose2::default());
        let zero = EncoderReading::with_steer(0.0, [0.0; 4], st.steer_angles());
        odo.update(&zero, HeadingInput::Absolute(0.0)).unwrap();
        let p = EncoderReading::with_steer(1.0, st.wheel_rates, st.steer_angles());
        acc += odo.update(&p, HeadingInput::Absolute(0.2)).unwrap().pose.x;
        let s32 = Swerve::new(swerve4::<f32>()).unwrap();
        acc += s32.forward(&s32.rest()).unwrap().vx as f64;
        acc
    });
    assert!(acc.is_finite());
    assert_eq!(allocation_count() - before, 0);
}

/// robots/swerve4.toml (the schema proposed in `drive`'s docs) describes `swerve4()`.
#[cfg(feature = "std")]
#[test]
fn preset_file_matches_the_preset() {
    let v: toml::Value = toml::from_str(include_str!("../../../robots/swerve4.toml")).unwrap();
    assert_eq!(v["kind"].as_str(), Some("swerve"));
    assert_eq!(v["geometry"]["optimize_steering"].as_bool(), Some(false));
    let modules = v["geometry"]["modules"].as_array().unwrap();
    assert_eq!(modules.len(), 4);
    for (m, want) in modules.iter().zip(swerve4::<f64>()) {
        let p = m["position"].as_array().unwrap();
        assert_eq!(
            [p[0].as_float().unwrap(), p[1].as_float().unwrap()],
            want.position
        );
        assert_eq!(m["wheel_radius"].as_float().unwrap(), want.wheel_radius);
    }
}
