//! Tests of the three-caster base (paper 003): hand-computed values, property tests over random
//! geometry, the special motions of §3 and the slip formulas of §4.

use core::f64::consts::PI;

use omnikin::caster::slip::{self, AccelerationRamp, Displacement, SpeedFluctuation, WheelStep};
use omnikin::caster::{Caster3, CasterParams, CasterRates, FixedSteerMotion};
use omnikin::{GeometryError, InputError, Twist2};
use proptest::prelude::*;

const TWO_THIRDS_PI: f64 = 2.0 * PI / 3.0;

fn preset() -> Caster3<f64> {
    Caster3::new(CasterParams::preset()).unwrap()
}

fn build(big_d: f64, d: f64, r: f64, alpha: [f64; 3]) -> Caster3<f64> {
    Caster3::new(CasterParams {
        mount_radius: big_d,
        eccentricity: d,
        wheel_radius: r,
        mount_angles: alpha,
    })
    .unwrap()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

fn assert_rates_close(a: &CasterRates<f64>, b: &CasterRates<f64>, tol: f64) {
    for i in 0..3 {
        assert!(
            close(a.roll[i], b.roll[i], tol),
            "roll[{i}]: {a:?} vs {b:?}"
        );
        assert!(
            close(a.steer[i], b.steer[i], tol),
            "steer[{i}]: {a:?} vs {b:?}"
        );
    }
}

fn max_abs_rates(a: &CasterRates<f64>) -> f64 {
    a.roll
        .iter()
        .chain(a.steer.iter())
        .fold(0.0_f64, |m, x| m.max(x.abs()))
}

/// Wheel-centre offsets `O_i − C = D u(α_i+θ) + d u(β_i)`, computed independently of the crate.
fn centres(p: &CasterParams<f64>, heading: f64, steer: [f64; 3]) -> [[f64; 2]; 3] {
    let mut o = [[0.0; 2]; 3];
    for i in 0..3 {
        let a = p.mount_angles[i] + heading;
        let b = a + steer[i];
        o[i] = [
            p.mount_radius * a.cos() + p.eccentricity * b.cos(),
            p.mount_radius * a.sin() + p.eccentricity * b.sin(),
        ];
    }
    o
}

/// `Σ |p_i − p̄|² / (D + d)²`: small when the wheel centres bunch up and the forward fit is
/// ill-conditioned.
fn spread(p: &CasterParams<f64>, heading: f64, steer: [f64; 3]) -> f64 {
    let o = centres(p, heading, steer);
    let mx = (o[0][0] + o[1][0] + o[2][0]) / 3.0;
    let my = (o[0][1] + o[1][1] + o[2][1]) / 3.0;
    let s: f64 = o
        .iter()
        .map(|q| (q[0] - mx).powi(2) + (q[1] - my).powi(2))
        .sum();
    s / (p.mount_radius + p.eccentricity).powi(2)
}

/// Size of a twist in m/s, with the yaw rate converted by the length `l`.
fn twist_scale(t: &Twist2<f64>, l: f64) -> f64 {
    t.vx.abs() + t.vy.abs() + l * t.yaw_rate.abs()
}

// ---------------------------------------------------------------------------------------------
// Hand-computed values (preset: D = 0.20, d = 0.04, r = 0.05, α = (0, −2π/3, 2π/3)).
// ---------------------------------------------------------------------------------------------

#[test]
fn known_translation_all_wheels_along_x() {
    // γ = (0, 2π/3, −2π/3) at θ = 0 makes every β_i = 0. Moving +x at 0.1 m/s:
    // φ̇_i = −cos 0 · 0.1 / r = −0.1/0.05 = −2 rad/s; γ̇_i = sin 0 · 0.1 / d = 0.
    let c = preset();
    let steer = [0.0, TWO_THIRDS_PI, -TWO_THIRDS_PI];
    let rates = c
        .motor_rates(Twist2::new(0.1, 0.0, 0.0), 0.0, steer)
        .unwrap();
    for i in 0..3 {
        assert!(close(rates.roll[i], -2.0, 1e-12), "{rates:?}");
        assert!(close(rates.steer[i], 0.0, 1e-12), "{rates:?}");
    }
}

#[test]
fn known_translation_radial_wheels() {
    // γ = 0, θ = 0: β_i = α_i. Moving +x at 0.1 m/s:
    // φ̇_i = −cos α_i · 0.1/0.05 = −2 cos α_i = (−2, 1, 1) rad/s;
    // γ̇_i = sin α_i · 0.1/0.04 = 2.5 sin α_i = (0, −2.5·√3/2, +2.5·√3/2) = (0, −2.16506, 2.16506).
    let c = preset();
    let rates = c
        .motor_rates(Twist2::new(0.1, 0.0, 0.0), 0.0, [0.0; 3])
        .unwrap();
    let s = 2.5 * 3.0_f64.sqrt() / 2.0;
    let want = CasterRates {
        roll: [-2.0, 1.0, 1.0],
        steer: [0.0, -s, s],
    };
    assert_rates_close(&rates, &want, 1e-12);
    // ... and the forward map recovers the twist with zero slip.
    let fwd = c.body_twist(&want, 0.0, [0.0; 3]).unwrap();
    assert!(close(fwd.twist.vx, 0.1, 1e-12) && close(fwd.twist.vy, 0.0, 1e-12));
    assert!(close(fwd.twist.yaw_rate, 0.0, 1e-12));
    assert!(fwd.slip_residual < 1e-12, "{fwd:?}");
}

#[test]
fn known_pure_yaw_radial_wheels() {
    // γ = 0, θ̇ = 1 rad/s, ẋ = ẏ = 0: φ̇_i = −(D/r) sin 0 = 0;
    // γ̇_i = −(D/d cos 0 + 1) θ̇ = −(0.2/0.04 + 1) = −6 rad/s.
    let c = preset();
    let rates = c
        .motor_rates(Twist2::new(0.0, 0.0, 1.0), 0.7, [0.0; 3])
        .unwrap();
    let want = CasterRates {
        roll: [0.0; 3],
        steer: [-6.0; 3],
    };
    assert_rates_close(&rates, &want, 1e-12);
    assert_rates_close(&c.turn_in_place([0.0; 3], 1.0).unwrap(), &want, 1e-12);
}

#[test]
fn known_m_and_n_matrices() {
    // Wheel 0 at θ = 0, γ = 0 (β = α = 0):
    // M = [−r, 0, 0; 0, −d, −D − d; 0, 0, 1] = [−0.05, 0, 0; 0, −0.04, −0.24; 0, 0, 1],
    // N = [−1/r, 0, 0; 0, −1/d, −D/d − 1; 0, 0, 1] = [−20, 0, 0; 0, −25, −6; 0, 0, 1].
    let c = preset();
    let m = c.m_matrix(0, 0.0, 0.0).unwrap();
    let n = c.n_matrix(0, 0.0, 0.0).unwrap();
    let m_want = [[-0.05, 0.0, 0.0], [0.0, -0.04, -0.24], [0.0, 0.0, 1.0]];
    let n_want = [[-20.0, 0.0, 0.0], [0.0, -25.0, -6.0], [0.0, 0.0, 1.0]];
    for i in 0..3 {
        for j in 0..3 {
            assert!(close(m[(i, j)], m_want[i][j], 1e-12), "M = {m}");
            assert!(close(n[(i, j)], n_want[i][j], 1e-12), "N = {n}");
        }
    }
    // Wheel 1 (α = −2π/3) at θ = 0.5, γ = 0.3: check the D-terms of M's third column,
    // D sin(α+θ) + d sin β and −D cos(α+θ) − d cos β.
    let (a, b) = (-TWO_THIRDS_PI + 0.5, -TWO_THIRDS_PI + 0.8);
    let m = c.m_matrix(1, 0.5, 0.3).unwrap();
    assert!(close(m[(0, 2)], 0.2 * a.sin() + 0.04 * b.sin(), 1e-15));
    assert!(close(m[(1, 2)], -0.2 * a.cos() - 0.04 * b.cos(), 1e-15));
    assert!(c.m_matrix(3, 0.0, 0.0).is_none() && c.n_matrix(3, 0.0, 0.0).is_none());
}

#[test]
fn known_slip_residual_for_one_bad_roll_rate() {
    // Preset, θ = 0, γ = 0: wheel centres p_i = (D + d) u(α_i), mean 0. Adding δ to φ̇_1 of
    // consistent rates changes wheel 1's implied point velocity by −r δ u(β_1) = −r δ (1, 0).
    // Least squares: mean shift −rδ/3 (1,0), and by symmetry no yaw change, so the residuals
    // are |e_1| = 2rδ/3, |e_2| = |e_3| = rδ/3 and the total rδ·sqrt(4/9 + 1/9 + 1/9) = rδ·√(2/3).
    // With r = 0.05, δ = 1 rad/s: (0.033333, 0.016667, 0.016667), total 0.040825 m/s.
    let c = preset();
    let twist = Twist2::new(0.3, -0.2, 0.5);
    let mut rates = c.motor_rates(twist, 0.0, [0.0; 3]).unwrap();
    rates.roll[0] += 1.0;
    let fwd = c.body_twist(&rates, 0.0, [0.0; 3]).unwrap();
    assert!(close(fwd.wheel_slip[0], 0.05 * 2.0 / 3.0, 1e-12), "{fwd:?}");
    assert!(close(fwd.wheel_slip[1], 0.05 / 3.0, 1e-12), "{fwd:?}");
    assert!(close(fwd.wheel_slip[2], 0.05 / 3.0, 1e-12), "{fwd:?}");
    assert!(close(
        fwd.slip_residual,
        0.05 * (2.0_f64 / 3.0).sqrt(),
        1e-12
    ));
    // The fit moves by the mean shift only: (0.3 − 0.05/3, −0.2, 0.5).
    assert!(close(fwd.twist.vx, 0.3 - 0.05 / 3.0, 1e-12), "{fwd:?}");
    assert!(close(fwd.twist.vy, -0.2, 1e-12) && close(fwd.twist.yaw_rate, 0.5, 1e-12));
}

#[test]
fn preset_values() {
    let p = CasterParams::<f64>::preset();
    assert_eq!(
        (p.mount_radius, p.eccentricity, p.wheel_radius),
        (0.20, 0.04, 0.05)
    );
    assert_eq!(p.mount_angles, [0.0, -TWO_THIRDS_PI, TWO_THIRDS_PI]);
    let c = preset();
    assert_eq!(c.params(), &p);
    let b = c.wheel_directions(0.25, [0.1, 0.2, 0.3]);
    assert!(close(b[1], -TWO_THIRDS_PI + 0.25 + 0.2, 1e-15));
}

// ---------------------------------------------------------------------------------------------
// Errors.
// ---------------------------------------------------------------------------------------------

#[test]
fn geometry_errors_name_the_field() {
    let base = CasterParams::<f64>::preset();
    let mut p = base;
    p.mount_radius = -1.0;
    assert!(matches!(
        Caster3::new(p),
        Err(GeometryError::NotPositive {
            field: "mount_radius",
            ..
        })
    ));
    let mut p = base;
    p.wheel_radius = f64::INFINITY;
    assert_eq!(
        Caster3::new(p),
        Err(GeometryError::NonFinite {
            field: "wheel_radius"
        })
    );
    let mut p = base;
    p.eccentricity = 0.0;
    assert!(matches!(
        Caster3::new(p),
        Err(GeometryError::NotPositive {
            field: "eccentricity",
            ..
        })
    ));
    let mut p = base;
    p.mount_angles[1] = f64::NAN;
    assert_eq!(
        Caster3::new(p),
        Err(GeometryError::NonFinite {
            field: "mount_angles[1]"
        })
    );
    // Two coincident steering axes (also modulo 2π).
    let mut p = base;
    p.mount_angles = [0.0, 1.0, 1.0 + 2.0 * PI];
    assert!(matches!(
        Caster3::new(p),
        Err(GeometryError::AngleOutOfRange {
            field: "mount_angles",
            ..
        })
    ));
    let mut p = base;
    p.mount_angles = [0.3, 0.3, 2.0];
    assert!(matches!(
        Caster3::new(p),
        Err(GeometryError::AngleOutOfRange {
            field: "mount_angles",
            ..
        })
    ));
    // Close but distinct axes are accepted.
    let mut p = base;
    p.mount_angles = [0.0, 0.01, 2.0];
    assert!(Caster3::new(p).is_ok());
}

#[test]
fn motor_rates_report_overflow_only_for_a_rate_that_overflows() {
    // The usual path tests the sum of the six rates; a sum that overflows while every rate is
    // finite must still be an answer, and one non-finite rate must be named as before.
    let c = preset();
    let p = CasterParams::<f64>::preset();
    // Every wheel pointing along x (β_i = 0): three roll rates of −0.7e308 rad/s, their sum −∞.
    let steer = p.mount_angles.map(|a| -a);
    let vx = 0.7e308 * p.wheel_radius;
    let r = c
        .motor_rates(Twist2::new(vx, 0.0, 0.0), 0.0, steer)
        .expect("every rate is finite");
    assert!(
        r.roll.iter().all(|v| v.is_finite() && *v < -0.6e308),
        "{r:?}"
    );
    assert!(r.steer.iter().all(|v| v.is_finite()), "{r:?}");
    // Every wheel across x (β_i = π/2): the roll rates stay finite, the steer rates v_x/d do not.
    let steer = p.mount_angles.map(|a| PI / 2.0 - a);
    assert!(1e308 / p.eccentricity > f64::MAX);
    assert_eq!(
        c.motor_rates(Twist2::new(1e308, 0.0, 0.0), 0.0, steer),
        Err(InputError::Overflow {
            quantity: "steer rates"
        })
    );
}

#[test]
fn input_errors_name_the_field() {
    let c = preset();
    let nan = f64::NAN;
    let ok = Twist2::new(0.1, 0.0, 0.0);
    assert_eq!(
        c.motor_rates(Twist2::new(nan, 0.0, 0.0), 0.0, [0.0; 3]),
        Err(InputError::NonFinite { field: "vx" })
    );
    assert_eq!(
        c.motor_rates(Twist2::new(0.0, 0.0, f64::INFINITY), 0.0, [0.0; 3]),
        Err(InputError::NonFinite { field: "yaw_rate" })
    );
    assert_eq!(
        c.motor_rates(ok, nan, [0.0; 3]),
        Err(InputError::NonFinite { field: "heading" })
    );
    assert_eq!(
        c.motor_rates(ok, 0.0, [0.0, 0.0, nan]),
        Err(InputError::NonFinite { field: "steer[2]" })
    );
    let mut rates = CasterRates::<f64>::default();
    rates.roll[1] = nan;
    assert_eq!(
        c.body_twist(&rates, 0.0, [0.0; 3]),
        Err(InputError::NonFinite {
            field: "roll_rates[1]"
        })
    );
    let mut rates = CasterRates::<f64>::default();
    rates.steer[2] = f64::NEG_INFINITY;
    assert_eq!(
        c.body_twist(&rates, 0.0, [0.0; 3]),
        Err(InputError::NonFinite {
            field: "steer_rates[2]"
        })
    );
    assert_eq!(
        c.body_twist(&CasterRates::default(), 0.0, [nan, 0.0, 0.0]),
        Err(InputError::NonFinite { field: "steer[0]" })
    );
    assert_eq!(
        c.fixed_steer_motion(nan, [0.0; 3]),
        Err(InputError::NonFinite { field: "heading" })
    );
    assert_eq!(
        c.turn_in_place([0.0; 3], nan),
        Err(InputError::NonFinite { field: "yaw_rate" })
    );
    assert_eq!(
        c.spin_in_place([0.0; 3], nan),
        Err(InputError::NonFinite {
            field: "steer_rate_1"
        })
    );
    assert_eq!(
        c.translation_from_wheel1(0.0, [0.0; 3], nan, 0.0),
        Err(InputError::NonFinite {
            field: "roll_rate_1"
        })
    );
}

#[test]
fn forward_is_singular_only_when_all_centres_coincide() {
    // d = D and every γ_i = π puts every O_i on C: the yaw rate is unobservable.
    let c = build(0.1, 0.1, 0.05, [0.0, -TWO_THIRDS_PI, TWO_THIRDS_PI]);
    let r = c.body_twist(&CasterRates::default(), 1.0, [PI; 3]);
    assert!(matches!(r, Err(InputError::Singular { .. })), "{r:?}");
    // Slightly off it the fit works again.
    assert!(
        c.body_twist(&CasterRates::default(), 1.0, [PI, PI, 3.0])
            .is_ok()
    );
}

// ---------------------------------------------------------------------------------------------
// Property tests over random geometry.
// ---------------------------------------------------------------------------------------------

/// (D, d, r, α): D ∈ [0.05, 0.5], d ∈ [0.005, 0.2], r ∈ [0.01, 0.2], α jittered ±0.3 rad.
fn geometry() -> impl Strategy<Value = CasterParams<f64>> {
    (
        0.05..0.5_f64,
        0.005..0.2_f64,
        0.01..0.2_f64,
        prop::array::uniform3(-0.3..0.3_f64),
    )
        .prop_map(|(big_d, d, r, j)| CasterParams {
            mount_radius: big_d,
            eccentricity: d,
            wheel_radius: r,
            mount_angles: [j[0], -TWO_THIRDS_PI + j[1], TWO_THIRDS_PI + j[2]],
        })
}

fn angle() -> impl Strategy<Value = f64> {
    -PI..PI
}

fn steer3() -> impl Strategy<Value = [f64; 3]> {
    prop::array::uniform3(-PI..PI)
}

fn twist() -> impl Strategy<Value = Twist2<f64>> {
    (-1.0..1.0_f64, -1.0..1.0_f64, -3.0..3.0_f64).prop_map(|(x, y, w)| Twist2::new(x, y, w))
}

/// Mostly ordinary values, often NaN, ±∞ or ±1e308 (for the error-precedence tests).
fn odd_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -10.0_f64..10.0,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(1e308),
        1 => Just(-1e308),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// (a) M_i · N_i = I for every wheel (paper 003, eqs. (1), (2) are inverses).
    #[test]
    fn m_times_n_is_identity(p in geometry(), th in angle(), g in steer3()) {
        let c = Caster3::new(p).unwrap();
        for (i, &gi) in g.iter().enumerate() {
            let m = c.m_matrix(i, th, gi).unwrap();
            let n = c.n_matrix(i, th, gi).unwrap();
            let e = m * n - nalgebra::Matrix3::identity();
            let e2 = n * m - nalgebra::Matrix3::identity();
            // N has entries up to D/d ≤ 100 and 1/d ≤ 200: allow for that.
            prop_assert!(e.amax() < 1e-12 && e2.amax() < 1e-12, "wheel {}: {} / {}", i, e, e2);
        }
    }

    /// (b) The rows of N_i satisfy the no-slip constraint, paper 003, eq. (3):
    /// (D cos γ_i + d) θ̇ + d γ̇_i = ẋ sin β_i − ẏ cos β_i, and J1/J2 are the stacked rows.
    #[test]
    fn n_rows_satisfy_constraint_3(p in geometry(), th in angle(), g in steer3(), t in twist()) {
        let c = Caster3::new(p).unwrap();
        let q = nalgebra::Vector3::new(t.vx, t.vy, t.yaw_rate);
        let (j1, j2) = (c.j1(th, g), c.j2(th, g));
        for i in 0..3 {
            let n = c.n_matrix(i, th, g[i]).unwrap();
            let w = n * q;
            let beta = p.mount_angles[i] + th + g[i];
            let lhs = (p.mount_radius * g[i].cos() + p.eccentricity) * t.yaw_rate
                + p.eccentricity * w[1];
            let rhs = t.vx * beta.sin() - t.vy * beta.cos();
            prop_assert!(close(lhs, rhs, 1e-12), "wheel {}: {} vs {}", i, lhs, rhs);
            prop_assert!(close(w[2], t.yaw_rate, 0.0));
            for k in 0..3 {
                prop_assert_eq!(j1[(i, k)], n[(0, k)]);
                prop_assert_eq!(j2[(i, k)], n[(1, k)]);
            }
        }
        prop_assert!(close(c.det_j2(th, g), j2.determinant(), 0.0));
    }

    /// (c) forward ∘ inverse = identity, with zero slip residual.
    #[test]
    fn forward_of_inverse_is_identity(p in geometry(), th in angle(), g in steer3(), t in twist()) {
        prop_assume!(spread(&p, th, g) > 1e-4);
        let c = Caster3::new(p).unwrap();
        let rates = c.motor_rates(t, th, g).unwrap();
        let fwd = c.body_twist(&rates, th, g).unwrap();
        let l = p.mount_radius + p.eccentricity;
        let tol = 1e-10 * (1.0 + twist_scale(&t, l));
        prop_assert!(close(fwd.twist.vx, t.vx, tol), "{:?} vs {:?}", fwd, t);
        prop_assert!(close(fwd.twist.vy, t.vy, tol), "{:?} vs {:?}", fwd, t);
        prop_assert!(close(l * fwd.twist.yaw_rate, l * t.yaw_rate, tol), "{:?} vs {:?}", fwd, t);
        prop_assert!(fwd.slip_residual < tol, "{:?}", fwd);
        prop_assert!(fwd.wheel_slip.iter().all(|&s| s < tol));
    }

    /// (d) inverse ∘ forward = identity for consistent rates. The consistent rates are built
    /// without `motor_rates`: a translation driven by wheel 1 (eq. (9)) plus a turn in place
    /// (eq. (7)); the kinematics are linear in q̇, so their sum is consistent.
    #[test]
    fn inverse_of_forward_is_identity(
        p in geometry(), th in angle(), g in steer3(),
        phi1 in -20.0..20.0_f64, gam1 in -20.0..20.0_f64, w in -3.0..3.0_f64,
    ) {
        prop_assume!(spread(&p, th, g) > 1e-4);
        let c = Caster3::new(p).unwrap();
        let (vt, tr) = c.translation_from_wheel1(th, g, phi1, gam1).unwrap();
        let spin = c.turn_in_place(g, w).unwrap();
        let mut rates = tr;
        for i in 0..3 {
            rates.roll[i] += spin.roll[i];
            rates.steer[i] += spin.steer[i];
        }
        let fwd = c.body_twist(&rates, th, g).unwrap();
        let scale = 1.0 + max_abs_rates(&rates);
        prop_assert!(fwd.slip_residual < 1e-10 * scale, "{:?}", fwd);
        prop_assert!(close(fwd.twist.vx, vt.vx, 1e-10 * scale));
        prop_assert!(close(fwd.twist.vy, vt.vy, 1e-10 * scale));
        prop_assert!(close(fwd.twist.yaw_rate, w, 1e-9 * scale));
        let back = c.motor_rates(fwd.twist, th, g).unwrap();
        assert_rates_close(&back, &rates, 1e-9 * scale);
    }

    /// (e) Frame invariance: rotating the world by `a` (twist rotated, heading + a, same steer
    /// angles) leaves the motor rates unchanged.
    #[test]
    fn motor_rates_are_frame_invariant(
        p in geometry(), th in angle(), g in steer3(), t in twist(), a in angle(),
    ) {
        let c = Caster3::new(p).unwrap();
        let r0 = c.motor_rates(t, th, g).unwrap();
        let r1 = c.motor_rates(t.rotated(a), th + a, g).unwrap();
        assert_rates_close(&r0, &r1, 1e-10 * (1.0 + max_abs_rates(&r0)));
        // The forward map rotates the twist back the same way.
        prop_assume!(spread(&p, th, g) > 1e-4);
        let f0 = c.body_twist(&r0, th, g).unwrap().twist.rotated(a);
        let f1 = c.body_twist(&r0, th + a, g).unwrap().twist;
        prop_assert!(close(f0.vx, f1.vx, 1e-10) && close(f0.vy, f1.vy, 1e-10));
        prop_assert!(close(f0.yaw_rate, f1.yaw_rate, 1e-9));
    }

    /// (f) f32 agrees with f64: relative 1e-4 of the largest rate for the inverse, and of the
    /// twist size for the forward on well-conditioned cases (wheel-centre spread ≥ 5 % of
    /// (D + d)²).
    #[test]
    fn f32_agrees_with_f64(p in geometry(), th in angle(), g in steer3(), t in twist()) {
        let c64 = Caster3::new(p).unwrap();
        let p32 = CasterParams::<f32> {
            mount_radius: p.mount_radius as f32,
            eccentricity: p.eccentricity as f32,
            wheel_radius: p.wheel_radius as f32,
            mount_angles: p.mount_angles.map(|a| a as f32),
        };
        let c32 = Caster3::new(p32).unwrap();
        let g32 = g.map(|x| x as f32);
        let t32 = Twist2::new(t.vx as f32, t.vy as f32, t.yaw_rate as f32);
        let r64 = c64.motor_rates(t, th, g).unwrap();
        let r32 = c32.motor_rates(t32, th as f32, g32).unwrap();
        let tol = 1e-4 * (1e-3 + max_abs_rates(&r64));
        for i in 0..3 {
            prop_assert!(close(r32.roll[i] as f64, r64.roll[i], tol), "{:?} vs {:?}", r32, r64);
            prop_assert!(close(r32.steer[i] as f64, r64.steer[i], tol), "{:?} vs {:?}", r32, r64);
        }
        prop_assume!(spread(&p, th, g) > 0.05);
        let f64_ = c64.body_twist(&r64, th, g).unwrap();
        let f32_ = c32.body_twist(&r32, th as f32, g32).unwrap();
        let l = p.mount_radius + p.eccentricity;
        let tol = 1e-4 * (1e-3 + twist_scale(&t, l));
        prop_assert!(close(f32_.twist.vx as f64, f64_.twist.vx, tol), "{:?} {:?}", f32_, f64_);
        prop_assert!(close(f32_.twist.vy as f64, f64_.twist.vy, tol), "{:?} {:?}", f32_, f64_);
        prop_assert!(close(l * f32_.twist.yaw_rate as f64, l * f64_.twist.yaw_rate, tol));
        prop_assert!((f32_.slip_residual as f64) < tol);
    }

    /// (g) An inconsistency δ on one wheel's roll rate gives a slip residual > 0 that grows
    /// (linearly) with |δ|, and that wheel's own slip is nonzero.
    #[test]
    fn inconsistency_shows_up_as_slip(
        p in geometry(), th in angle(), g in steer3(), t in twist(),
        k in 0usize..3, delta in prop_oneof![-5.0..-0.1_f64, 0.1..5.0_f64],
    ) {
        prop_assume!(spread(&p, th, g) > 1e-2);
        let c = Caster3::new(p).unwrap();
        let rates = c.motor_rates(t, th, g).unwrap();
        let mut residuals = [0.0; 3];
        let mut own = [0.0; 3];
        for (n, m) in [1.0, 2.0, 4.0].iter().enumerate() {
            let mut bad = rates;
            bad.roll[k] += m * delta;
            let fwd = c.body_twist(&bad, th, g).unwrap();
            residuals[n] = fwd.slip_residual;
            own[n] = fwd.wheel_slip[k];
            let rss = fwd.wheel_slip.iter().map(|s| s * s).sum::<f64>().sqrt();
            prop_assert!(close(rss, fwd.slip_residual, 1e-12));
        }
        // Removing one roll row never loses rank (that wheel's steer row and the other two
        // wheels still pin the motion), so the residual is a fixed nonzero fraction of r|δ|.
        let rd = p.wheel_radius * delta.abs();
        prop_assert!(residuals[0] > 1e-6 * rd, "{:?}", residuals);
        prop_assert!(own[0] > 1e-6 * rd, "{:?}", own);
        prop_assert!(residuals[1] > residuals[0] && residuals[2] > residuals[1]);
        prop_assert!(close(residuals[1], 2.0 * residuals[0], 1e-9 * (1.0 + residuals[1])));
        prop_assert!(close(residuals[2], 4.0 * residuals[0], 1e-9 * (1.0 + residuals[2])));
        // The residual never exceeds the injected velocity error r|δ|.
        prop_assert!(residuals[0] <= rd * (1.0 + 1e-9));
    }

    /// (h) Independent no-slip check: the wheel-centre velocity from the rigid-body formula
    /// v_Oi = v_C + θ̇ k × D u(α_i+θ) + β̇_i d k × u(β_i), β̇_i = γ̇_i + θ̇, equals the rolling
    /// velocity −r φ̇_i u(β_i) for the rates from `motor_rates`.
    #[test]
    fn rates_give_no_slip_at_wheel_centres(p in geometry(), th in angle(), g in steer3(), t in twist()) {
        let c = Caster3::new(p).unwrap();
        let rates = c.motor_rates(t, th, g).unwrap();
        let kx = |v: [f64; 2]| [-v[1], v[0]]; // k × v
        for (i, &gi) in g.iter().enumerate() {
            let a = p.mount_angles[i] + th;
            let b = a + gi;
            let fa = kx([p.mount_radius * a.cos(), p.mount_radius * a.sin()]);
            let ub = kx([p.eccentricity * b.cos(), p.eccentricity * b.sin()]);
            let beta_dot = rates.steer[i] + t.yaw_rate;
            let v_rigid = [
                t.vx + t.yaw_rate * fa[0] + beta_dot * ub[0],
                t.vy + t.yaw_rate * fa[1] + beta_dot * ub[1],
            ];
            let v_roll = [
                -p.wheel_radius * rates.roll[i] * b.cos(),
                -p.wheel_radius * rates.roll[i] * b.sin(),
            ];
            prop_assert!(close(v_rigid[0], v_roll[0], 1e-12), "wheel {}", i);
            prop_assert!(close(v_rigid[1], v_roll[1], 1e-12), "wheel {}", i);
        }
    }

    /// `motor_rates` tests its inputs only when a rate comes out non-finite; its answer must be
    /// the one of checking every input first (twist, heading, steer, in that order), then the
    /// rates: the same field named for any mix of NaN, ±∞ and huge finite values.
    #[test]
    fn motor_rate_errors_are_those_of_checking_inputs_first(
        vals in proptest::collection::vec(odd_value(), 7),
    ) {
        let c = preset();
        let twist = Twist2::new(vals[0], vals[1], vals[2]);
        let (heading, steer) = (vals[3], [vals[4], vals[5], vals[6]]);
        let got = c.motor_rates(twist, heading, steer);
        let names = ["vx", "vy", "yaw_rate", "heading", "steer[0]", "steer[1]", "steer[2]"];
        match vals.iter().position(|v| !v.is_finite()) {
            Some(i) => prop_assert_eq!(got, Err(InputError::NonFinite { field: names[i] })),
            None => match got {
                Ok(r) => prop_assert!(r.roll.iter().chain(&r.steer).all(|v| v.is_finite())),
                Err(e) => {
                    prop_assert!(matches!(e, InputError::Overflow { .. }), "{:?}", e);
                    prop_assert!(vals[..3].iter().any(|v| v.abs() >= 1e308));
                }
            },
        }
    }

    /// `body_twist` tests its inputs only when the fit fails or the heading is not finite; its
    /// answer must be the one of checking every input first (roll rates, steer rates, heading,
    /// steer angles), then the fit.
    #[test]
    fn body_twist_errors_are_those_of_checking_inputs_first(
        vals in proptest::collection::vec(odd_value(), 10),
    ) {
        let c = preset();
        let rates = CasterRates {
            roll: [vals[0], vals[1], vals[2]],
            steer: [vals[3], vals[4], vals[5]],
        };
        let got = c.body_twist(&rates, vals[6], [vals[7], vals[8], vals[9]]);
        let names = [
            "roll_rates[0]", "roll_rates[1]", "roll_rates[2]",
            "steer_rates[0]", "steer_rates[1]", "steer_rates[2]",
            "heading", "steer[0]", "steer[1]", "steer[2]",
        ];
        // The robot-frame fit: the same order without the heading, and the same answer turned
        // into the world frame.
        let robot = c.robot_twist(&rates, [vals[7], vals[8], vals[9]]);
        let no_heading: Vec<usize> = (0..10).filter(|&i| i != 6).collect();
        match no_heading.iter().find(|&&i| !vals[i].is_finite()) {
            Some(&i) => prop_assert_eq!(robot, Err(InputError::NonFinite { field: names[i] })),
            None => {
                if let (Ok(w), Ok(r)) = (&got, &robot) {
                    // The same fit (the wheel directions do not depend on the heading's lane),
                    // turned by the heading's sine and cosine: the crate's four-lane kernel
                    // there, `libm` in `to_world`, which may differ by an ulp or two.
                    prop_assert_eq!(w.wheel_slip, r.wheel_slip);
                    let want = r.twist.to_world(vals[6]);
                    let tol = 1e-14 * (r.twist.vx.abs() + r.twist.vy.abs());
                    prop_assert!((w.twist.vx - want.vx).abs() <= tol, "{:?} vs {:?}", w.twist, want);
                    prop_assert!((w.twist.vy - want.vy).abs() <= tol, "{:?} vs {:?}", w.twist, want);
                    prop_assert_eq!(w.twist.yaw_rate, want.yaw_rate);
                }
            }
        }
        match vals.iter().position(|v| !v.is_finite()) {
            Some(i) => prop_assert_eq!(got, Err(InputError::NonFinite { field: names[i] })),
            None => match got {
                Ok(f) => {
                    prop_assert!(f.twist.is_finite());
                    prop_assert!(f.slip_residual.is_finite());
                }
                Err(e) => {
                    prop_assert!(matches!(e, InputError::Singular { .. }), "{:?}", e);
                    prop_assert!(vals[..6].iter().any(|v| v.abs() >= 1e308));
                }
            },
        }
    }

    /// No call panics, whatever the input (NaN, ∞, huge values).
    #[test]
    fn never_panics(
        x in proptest::num::f64::ANY, y in proptest::num::f64::ANY, z in proptest::num::f64::ANY,
        w in proptest::num::f64::ANY, k in 0usize..5,
    ) {
        let c = preset();
        let g = [x, y, z];
        let _ = c.motor_rates(Twist2::new(x, y, z), w, g);
        let _ = c.body_twist(&CasterRates { roll: [x, y, z], steer: [w, x, y] }, z, [w, 0.0, x]);
        let _ = c.fixed_steer_motion(w, g);
        let _ = c.turn_in_place(g, w);
        let _ = c.spin_in_place(g, w);
        let _ = c.translation_from_wheel1(w, g, x, y);
        let _ = c.m_matrix(k, x, y);
        let _ = c.n_matrix(k, x, y);
        let _ = c.det_j2(x, g);
        let _ = slip::single_wheel_step(&WheelStep {
            wheel_radius: x, eccentricity: y, beta0: z, steer_rate: w, roll_rate: x, period: y,
        });
        let f = SpeedFluctuation {
            wheel_radius: x, eccentricity: y, beta1: z, steer_rate: w, roll_rate: x,
            steer_rate_error: y, roll_rate_error: z, period: w,
        };
        let _ = slip::speed_fluctuation(&f);
        let _ = slip::speed_fluctuation_full(&f);
        let _ = slip::acceleration_ramp(&AccelerationRamp {
            wheel_radius: x, beta0: y, initial_steer_rate: z, initial_roll_rate: w,
            steer_rate: x, roll_rate: y, duration: z,
        });
        let _ = Caster3::new(CasterParams {
            mount_radius: x, eccentricity: y, wheel_radius: z, mount_angles: [w, x, y],
        });
    }
}

// ---------------------------------------------------------------------------------------------
// Special motions (paper 003, §3).
// ---------------------------------------------------------------------------------------------

/// Steer angles that make every wheel point along the world direction `b` (β_i = b).
fn parallel_steer(p: &CasterParams<f64>, heading: f64, b: f64) -> [f64; 3] {
    [0, 1, 2].map(|i| b - p.mount_angles[i] - heading)
}

/// Steer angles whose wheel axles all pass through the world offset `icr` from C: wheel i's
/// axle is the line through O_i = F_i + d u(β_i) perpendicular to u(β_i), so it passes through
/// P when u(β_i)·(F_i − P) = −d, i.e. β_i = ψ_i ± acos(−d/|F_i − P|) with ψ_i the direction of
/// F_i − P. `None` if P is within d of a steering axis.
fn icr_steer(
    p: &CasterParams<f64>,
    heading: f64,
    icr: [f64; 2],
    sign: [f64; 3],
) -> Option<[f64; 3]> {
    let mut g = [0.0; 3];
    for i in 0..3 {
        let a = p.mount_angles[i] + heading;
        let f = [
            p.mount_radius * a.cos() - icr[0],
            p.mount_radius * a.sin() - icr[1],
        ];
        let rho = f[0].hypot(f[1]);
        if rho < 1.05 * p.eccentricity {
            return None;
        }
        let beta = f[1].atan2(f[0]) + sign[i] * (-p.eccentricity / rho).acos();
        g[i] = beta - a;
    }
    Some(g)
}

#[test]
fn fixed_steer_known_cases() {
    let c = preset();
    let p = *c.params();
    // All wheels along world +y at θ = 0.4: straight along (0, 1).
    let g = parallel_steer(&p, 0.4, PI / 2.0);
    match c.fixed_steer_motion(0.4, g).unwrap() {
        FixedSteerMotion::Straight { direction } => {
            assert!(close(direction[0], 0.0, 1e-9) && close(direction[1], 1.0, 1e-9))
        }
        other => panic!("{other:?}"),
    }
    // Radial wheels (γ = 0): axles do not share a point, the base is locked.
    assert_eq!(
        c.fixed_steer_motion(0.0, [0.0; 3]),
        Ok(FixedSteerMotion::Locked)
    );
    assert!(c.det_j2(0.0, [0.0; 3]).abs() > 1.0);
    // Wheels tangential (γ = π/2): each axle is the radial line through F_i shifted sideways by
    // d, so the three axles miss each other — locked too.
    assert_eq!(
        c.fixed_steer_motion(1.0, [PI / 2.0; 3]),
        Ok(FixedSteerMotion::Locked)
    );
    // cos γ_i = −d/D for every wheel: u(β_i)·(F_i − C) = D cos γ_i = −d, so every axle passes
    // through C — an arc about C (turn in place with the steering held: γ̇_i =
    // −(D/d cos γ_i + 1) θ̇ = 0 by eq. (7)).
    let g = [(-0.2_f64).acos(); 3];
    match c.fixed_steer_motion(1.0, g).unwrap() {
        FixedSteerMotion::Arc { icr } => {
            assert!(icr[0].abs() < 1e-9 && icr[1].abs() < 1e-9, "{icr:?}")
        }
        other => panic!("{other:?}"),
    }
    let r = c.turn_in_place(g, 1.0).unwrap();
    assert!(r.steer.iter().all(|s| s.abs() < 1e-12), "{r:?}");
    // Roll rates for it: φ̇_i = −(D/r) sin γ_i θ̇ = −4 sin(acos(−0.2)) = −4·√0.96.
    assert!(
        r.roll
            .iter()
            .all(|&x| close(x, -4.0 * 0.96_f64.sqrt(), 1e-12)),
        "{r:?}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// All-parallel wheels → Straight along the common direction (sign: along wheel 1), also
    /// when one wheel is flipped by π (anti-parallel). The roll motors alone drive that line:
    /// the steer rates for it are 0.
    #[test]
    fn fixed_steer_parallel_is_straight(
        p in geometry(), th in angle(), b in angle(), flip in 0usize..4, speed in 0.1..1.0_f64,
    ) {
        let c = Caster3::new(p).unwrap();
        let mut g = parallel_steer(&p, th, b);
        if flip < 3 {
            g[flip] += PI;
        }
        let dir = match c.fixed_steer_motion(th, g).unwrap() {
            FixedSteerMotion::Straight { direction } => direction,
            other => return Err(TestCaseError::fail(format!("{other:?}"))),
        };
        let u1 = [(p.mount_angles[0] + th + g[0]).cos(), (p.mount_angles[0] + th + g[0]).sin()];
        prop_assert!(close(dir[0], u1[0], 1e-7) && close(dir[1], u1[1], 1e-7), "{:?} {:?}", dir, u1);
        prop_assert!(close(dir[0].hypot(dir[1]), 1.0, 1e-12));
        let r = c.motor_rates(Twist2::new(speed * dir[0], speed * dir[1], 0.0), th, g).unwrap();
        prop_assert!(r.steer.iter().all(|s| s.abs() < 1e-9), "{:?}", r);
    }

    /// Axles through one chosen point → Arc with that ICR; the arc about it needs no steer rate.
    #[test]
    fn fixed_steer_common_icr_is_arc(
        p in geometry(), th in angle(),
        px in -2.0..2.0_f64, py in -2.0..2.0_f64,
        signs in prop::array::uniform3(prop::bool::ANY), w in 0.2..2.0_f64,
    ) {
        let sign = signs.map(|s| if s { 1.0 } else { -1.0 });
        let g = icr_steer(&p, th, [px, py], sign);
        prop_assume!(g.is_some());
        let g = g.unwrap();
        let c = Caster3::new(p).unwrap();
        let icr = match c.fixed_steer_motion(th, g).unwrap() {
            FixedSteerMotion::Arc { icr } => icr,
            other => return Err(TestCaseError::fail(format!("{other:?}"))),
        };
        let tol = 1e-6 * (1.0 + px.hypot(py));
        prop_assert!(close(icr[0], px, tol) && close(icr[1], py, tol), "{:?} vs ({}, {})", icr, px, py);
        // Rotation about P at rate w: v_C = w k × (C − P) = w (py, −px).
        let r = c.motor_rates(Twist2::new(w * py, -w * px, w), th, g).unwrap();
        prop_assert!(r.steer.iter().all(|s| s.abs() < 1e-8 * (1.0 + max_abs_rates(&r))), "{:?}", r);
    }

    /// Generic steer angles → Locked (det J2 ≠ 0); perturbing a straight configuration by
    /// 0.05 rad also locks it.
    #[test]
    fn fixed_steer_generic_is_locked(p in geometry(), th in angle(), b in angle(), k in 0usize..3) {
        let c = Caster3::new(p).unwrap();
        let mut g = parallel_steer(&p, th, b);
        g[k] += 0.05;
        prop_assert_eq!(c.fixed_steer_motion(th, g).unwrap(), FixedSteerMotion::Locked);
        prop_assert!(c.det_j2(th, g) != 0.0);
    }

    /// Turn in place driven by γ̇_1 (eq. (8)) equals eq. (7) at the yaw rate it reports, and
    /// equals `motor_rates` for the pure yaw twist; wheel 1's steer rate is the input.
    #[test]
    fn spin_in_place_agrees_with_turn_in_place(
        p in geometry(), th in angle(), g in steer3(), g1 in -5.0..5.0_f64,
    ) {
        let c = Caster3::new(p).unwrap();
        let denom = p.mount_radius / p.eccentricity * g[0].cos() + 1.0;
        prop_assume!(denom.abs() > 1e-3);
        let s = c.spin_in_place(g, g1).unwrap();
        prop_assert!(close(s.yaw_rate, -g1 / denom, 1e-12 * (1.0 + s.yaw_rate.abs())));
        let t = c.turn_in_place(g, s.yaw_rate).unwrap();
        let scale = 1e-12 * (1.0 + max_abs_rates(&t));
        assert_rates_close(&s.rates, &t, scale);
        prop_assert!(close(s.rates.steer[0], g1, scale));
        let m = c.motor_rates(Twist2::new(0.0, 0.0, s.yaw_rate), th, g).unwrap();
        assert_rates_close(&m, &t, scale);
    }

    /// Translation driven by wheel 1 (eq. (9)) agrees with `motor_rates` for the twist it returns,
    /// which has θ̇ = 0.
    #[test]
    fn translation_from_wheel1_agrees_with_motor_rates(
        p in geometry(), th in angle(), g in steer3(),
        phi1 in -20.0..20.0_f64, gam1 in -20.0..20.0_f64,
    ) {
        let c = Caster3::new(p).unwrap();
        let (t, rates) = c.translation_from_wheel1(th, g, phi1, gam1).unwrap();
        prop_assert_eq!(t.yaw_rate, 0.0);
        prop_assert_eq!((rates.roll[0], rates.steer[0]), (phi1, gam1));
        let m = c.motor_rates(t, th, g).unwrap();
        assert_rates_close(&m, &rates, 1e-10 * (1.0 + max_abs_rates(&m)));
    }
}

#[test]
fn spin_in_place_singular_when_cos_gamma1_is_minus_d_over_big_d() {
    let c = preset();
    // cos γ_1 = −d/D = −0.2 → D/d cos γ_1 + 1 = 0.
    for g1 in [(-0.2_f64).acos(), -(-0.2_f64).acos()] {
        match c.spin_in_place([g1, 0.3, -0.4], 1.0) {
            Err(InputError::Singular { reason }) => {
                assert!(reason.contains("cos γ_1 = −d/D"), "{reason}")
            }
            other => panic!("{other:?}"),
        }
    }
    // A little away from it, it works and the yaw rate is large but finite.
    let s = c
        .spin_in_place([(-0.2_f64).acos() + 0.01, 0.3, -0.4], 1.0)
        .unwrap();
    assert!(s.yaw_rate.is_finite() && s.yaw_rate.abs() > 1.0);
    // At that steer angle turn_in_place itself is fine, with γ̇_1 = 0.
    let t = c
        .turn_in_place([(-0.2_f64).acos(), 0.3, -0.4], 1.0)
        .unwrap();
    assert!(t.steer[0].abs() < 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Slip formulas (paper 003, §4).
// ---------------------------------------------------------------------------------------------

/// RK4 integration of eq. (11): ẋ = −r Ξ cos β + d Ρ sin β, ẏ = −r Ξ sin β − d Ρ cos β,
/// β = β0 + Ρ t.
fn rk4_step(s: &WheelStep<f64>, n: usize) -> [f64; 2] {
    let f = |t: f64| {
        let b = s.beta0 + s.steer_rate * t;
        [
            -s.wheel_radius * s.roll_rate * b.cos() + s.eccentricity * s.steer_rate * b.sin(),
            -s.wheel_radius * s.roll_rate * b.sin() - s.eccentricity * s.steer_rate * b.cos(),
        ]
    };
    let h = s.period / n as f64;
    let mut x = [0.0, 0.0];
    for k in 0..n {
        let t = k as f64 * h;
        let (k1, k2, k4) = (f(t), f(t + h / 2.0), f(t + h));
        for j in 0..2 {
            // The right-hand side does not depend on the state, so k2 = k3.
            x[j] += h / 6.0 * (k1[j] + 4.0 * k2[j] + k4[j]);
        }
    }
    x
}

/// Eqs. (12), (13) as printed (divides by Ρ).
fn printed_step(s: &WheelStep<f64>) -> [f64; 2] {
    let b0 = s.beta0;
    let b1 = b0 + s.steer_rate * s.period;
    let k = s.wheel_radius * s.roll_rate / s.steer_rate;
    [
        -k * (b1.sin() - b0.sin()) - s.eccentricity * (b1.cos() - b0.cos()),
        k * (b1.cos() - b0.cos()) - s.eccentricity * (b1.sin() - b0.sin()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn single_wheel_step_matches_rk4_and_printed_formula(
        r in 0.01..0.2_f64, d in 0.005..0.2_f64, b0 in angle(),
        rho in prop_oneof![-10.0..-0.01_f64, 0.01..10.0_f64], xi in -30.0..30.0_f64,
        t in 0.01..1.0_f64,
    ) {
        let s = WheelStep { wheel_radius: r, eccentricity: d, beta0: b0, steer_rate: rho, roll_rate: xi, period: t };
        let out = slip::single_wheel_step(&s).unwrap();
        let num = rk4_step(&s, 10_000);
        let printed = printed_step(&s);
        let tol = 1e-10 * (1.0 + r * xi.abs() * t + d);
        prop_assert!(close(out.displacement.dx, num[0], tol), "{:?} vs {:?}", out, num);
        prop_assert!(close(out.displacement.dy, num[1], tol), "{:?} vs {:?}", out, num);
        prop_assert!(close(out.displacement.dx, printed[0], tol) && close(out.displacement.dy, printed[1], tol));
        prop_assert!(close(out.beta1, b0 + rho * t, 1e-15 * (1.0 + out.beta1.abs())));
    }

    /// With the ratio unchanged the full fluctuation form is exactly the difference of two
    /// eq. (12)/(13) steps, and the linearised form (15)/(16) agrees with it to O((ΔΡ T)²).
    #[test]
    fn linearised_fluctuation_matches_full_form(
        r in 0.01..0.2_f64, d in 0.005..0.2_f64, b0 in angle(),
        rho in prop_oneof![-10.0..-0.5_f64, 0.5..10.0_f64], xi in -30.0..30.0_f64,
        t in 0.001..0.05_f64, rel in -0.01..0.01_f64,
    ) {
        let drho = rel * rho; // ΔΡ T ≤ 0.01·10·0.05 = 5e-3
        let dxi = rel * xi; // keeps (Ξ+ΔΞ)/(Ρ+ΔΡ) = Ξ/Ρ
        let nominal = slip::single_wheel_step(&WheelStep {
            wheel_radius: r, eccentricity: d, beta0: b0, steer_rate: rho, roll_rate: xi, period: t,
        }).unwrap();
        let perturbed = slip::single_wheel_step(&WheelStep {
            wheel_radius: r, eccentricity: d, beta0: b0, steer_rate: rho + drho, roll_rate: xi + dxi, period: t,
        }).unwrap();
        let f = SpeedFluctuation {
            wheel_radius: r, eccentricity: d, beta1: nominal.beta1, steer_rate: rho, roll_rate: xi,
            steer_rate_error: drho, roll_rate_error: dxi, period: t,
        };
        let full = slip::speed_fluctuation_full(&f).unwrap();
        let lin = slip::speed_fluctuation(&f).unwrap();
        let scale = r * (xi / rho).abs() + d;
        let exact = [
            perturbed.displacement.dx - nominal.displacement.dx,
            perturbed.displacement.dy - nominal.displacement.dy,
        ];
        prop_assert!(close(full.dx, exact[0], 1e-12 * (1.0 + scale)), "{:?} vs {:?}", full, exact);
        prop_assert!(close(full.dy, exact[1], 1e-12 * (1.0 + scale)), "{:?} vs {:?}", full, exact);
        let e = drho * t;
        let tol = scale * (e * e + 1e-14);
        prop_assert!(close(lin.dx, full.dx, tol), "{:?} vs {:?} (ΔΡT = {})", lin, full, e);
        prop_assert!(close(lin.dy, full.dy, tol), "{:?} vs {:?} (ΔΡT = {})", lin, full, e);
    }

    /// The ramp error (18)/(19) is the difference of two eq. (12)/(13) steps over the same sweep
    /// β0 → βσ: one with the ramp-averaged rates, one with the target ratio Ξ/Ρ.
    #[test]
    fn ramp_is_difference_of_averaged_and_target_steps(
        r in 0.01..0.2_f64, d in 0.005..0.2_f64, b0 in angle(),
        rho in prop_oneof![-10.0..-0.5_f64, 0.5..10.0_f64], xi in -30.0..30.0_f64,
        rho0 in -0.4..0.4_f64, xi0 in -30.0..30.0_f64, dt in 0.01..1.0_f64,
    ) {
        let ramp = slip::acceleration_ramp(&AccelerationRamp {
            wheel_radius: r, beta0: b0, initial_steer_rate: rho0, initial_roll_rate: xi0,
            steer_rate: rho, roll_rate: xi, duration: dt,
        }).unwrap();
        let rho_avg = (rho + rho0) / 2.0;
        let step = |roll| slip::single_wheel_step(&WheelStep {
            wheel_radius: r, eccentricity: d, beta0: b0, steer_rate: rho_avg, roll_rate: roll, period: dt,
        }).unwrap().displacement;
        let avg = step((xi + xi0) / 2.0);
        let target = step(rho_avg * xi / rho);
        let tol = 1e-12 * (1.0 + r * (xi.abs() + xi0.abs()) * dt);
        prop_assert!(close(ramp.dx, avg.dx - target.dx, tol), "{:?}", ramp);
        prop_assert!(close(ramp.dy, avg.dy - target.dy, tol), "{:?}", ramp);
    }
}

#[test]
fn single_wheel_step_is_continuous_at_zero_steer_rate() {
    // Ρ = 0: a straight line, −r Ξ T (cos β0, sin β0) = −0.05·10·0.5·(cos 1, sin 1).
    let base = WheelStep {
        wheel_radius: 0.05,
        eccentricity: 0.04,
        beta0: 1.0,
        steer_rate: 0.0,
        roll_rate: 10.0,
        period: 0.5,
    };
    let zero = slip::single_wheel_step(&base).unwrap();
    assert!(
        close(zero.displacement.dx, -0.25 * 1.0_f64.cos(), 1e-15),
        "{zero:?}"
    );
    assert!(
        close(zero.displacement.dy, -0.25 * 1.0_f64.sin(), 1e-15),
        "{zero:?}"
    );
    assert_eq!(zero.beta1, 1.0);
    // Tiny steer rates: continuous (change is O(Ρ T)), including across the series cut-off at
    // Ρ T / 2 = 1e-3 where the printed formula is still accurate to ~1e-13.
    for rho in [
        1e-300,
        1e-12,
        1e-8,
        1e-6,
        1e-4,
        1.999e-3 * 2.0,
        2.001e-3 * 2.0,
        1e-2,
    ] {
        let s = WheelStep {
            steer_rate: rho,
            ..base
        };
        let out = slip::single_wheel_step(&s).unwrap().displacement;
        let bound = 0.3 * rho * 0.5 + 1e-15;
        assert!(
            close(out.dx, zero.displacement.dx, bound)
                && close(out.dy, zero.displacement.dy, bound),
            "Ρ = {rho}: {out:?}"
        );
        if rho >= 1e-3 {
            let printed = printed_step(&s);
            assert!(close(out.dx, printed[0], 1e-12) && close(out.dy, printed[1], 1e-12));
        }
    }
    // Negative tiny steer rate: same limit.
    let out = slip::single_wheel_step(&WheelStep {
        steer_rate: -1e-9,
        ..base
    })
    .unwrap()
    .displacement;
    assert!(close(out.dx, zero.displacement.dx, 1e-9) && close(out.dy, zero.displacement.dy, 1e-9));
}

#[test]
fn known_speed_fluctuation() {
    // r = 0.05, d = 0.04, β1 = 0, Ρ = 2, Ξ = 10, ΔΡ = 0.1, T = 0.01 → ΔΡ T = 1e-3:
    // Δx1 = −r (Ξ/Ρ) ΔΡ T cos 0 + d ΔΡ T sin 0 = −0.05·5·1e-3 = −2.5e-4 m,
    // Δy1 = −r (Ξ/Ρ) ΔΡ T sin 0 − d ΔΡ T cos 0 = −0.04·1e-3 = −4e-5 m.
    let f = SpeedFluctuation {
        wheel_radius: 0.05,
        eccentricity: 0.04,
        beta1: 0.0,
        steer_rate: 2.0,
        roll_rate: 10.0,
        steer_rate_error: 0.1,
        roll_rate_error: 0.5,
        period: 0.01,
    };
    let lin = slip::speed_fluctuation(&f).unwrap();
    assert!(
        close(lin.dx, -2.5e-4, 1e-15) && close(lin.dy, -4e-5, 1e-15),
        "{lin:?}"
    );
    // Full form, same inputs (ΔΞ/ΔΡ = Ξ/Ρ = 5, ratio unchanged): within (ΔΡT)²·(r·5 + d).
    let full = slip::speed_fluctuation_full(&f).unwrap();
    assert!(
        close(full.dx, lin.dx, 3e-7) && close(full.dy, lin.dy, 3e-7),
        "{full:?}"
    );
    // Zero steer rates are rejected, not divided by.
    let bad = SpeedFluctuation {
        steer_rate: 0.0,
        ..f
    };
    assert!(matches!(
        slip::speed_fluctuation(&bad),
        Err(InputError::Singular { .. })
    ));
    let bad = SpeedFluctuation {
        steer_rate_error: -2.0,
        ..f
    };
    assert!(matches!(
        slip::speed_fluctuation_full(&bad),
        Err(InputError::Singular { .. })
    ));
    assert!(slip::speed_fluctuation(&bad).is_ok());
    let bad = SpeedFluctuation {
        period: f64::NAN,
        ..f
    };
    assert_eq!(
        slip::speed_fluctuation(&bad),
        Err(InputError::NonFinite { field: "period" })
    );
}

#[test]
fn known_acceleration_ramp() {
    // r = 0.05, β0 = 0, from (Ρ0, Ξ0) = (0, 10) to (Ρ, Ξ) = (2, 10) over 0.5 s:
    // (Ξ+Ξ0)/(Ρ+Ρ0) − Ξ/Ρ = 20/2 − 10/2 = 5, r·5 = 0.25; βσ = 0 + (2+0)/2·0.5 = 0.5;
    // Δx1 = 0.25 (sin 0 − sin 0.5) = −0.119856, Δy1 = 0.25 (cos 0.5 − cos 0) = −0.030604.
    let ramp = AccelerationRamp {
        wheel_radius: 0.05,
        beta0: 0.0,
        initial_steer_rate: 0.0,
        initial_roll_rate: 10.0,
        steer_rate: 2.0,
        roll_rate: 10.0,
        duration: 0.5,
    };
    let e = slip::acceleration_ramp(&ramp).unwrap();
    let want = Displacement {
        dx: 0.25 * (0.0 - 0.5_f64.sin()),
        dy: 0.25 * (0.5_f64.cos() - 1.0),
    };
    assert!(
        close(e.dx, want.dx, 1e-15) && close(e.dy, want.dy, 1e-15),
        "{e:?}"
    );
    assert!(
        close(e.dx, -0.119856, 1e-6) && close(e.dy, -0.030604, 1e-6),
        "{e:?}"
    );
    // Starting already at the target ratio (Ξ0/Ρ0 = Ξ/Ρ) gives no error.
    let same = slip::acceleration_ramp(&AccelerationRamp {
        initial_steer_rate: 1.0,
        initial_roll_rate: 5.0,
        ..ramp
    })
    .unwrap();
    assert!(same.dx.abs() < 1e-15 && same.dy.abs() < 1e-15, "{same:?}");
    // Ρ + Ρ0 = 0 and Ρ = 0 are rejected.
    for (rho0, rho) in [(-2.0, 2.0), (1.0, 0.0)] {
        let r = slip::acceleration_ramp(&AccelerationRamp {
            initial_steer_rate: rho0,
            steer_rate: rho,
            ..ramp
        });
        assert!(matches!(r, Err(InputError::Singular { .. })), "{r:?}");
    }
}
