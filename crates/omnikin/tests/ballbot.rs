//! Ballbot (paper 001): velocity map, torque maps (errata E2–E4), duality, odometry step.

use nalgebra::{Matrix3, Vector3};
use omnikin::ballbot::{Ballbot, BallbotParams};
use omnikin::{GeometryError, InputError, Twist2};
use proptest::prelude::*;

const DEG: f64 = core::f64::consts::PI / 180.0;

fn preset() -> Ballbot<f64> {
    Ballbot::new(BallbotParams::preset()).unwrap()
}

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() <= tol * (1.0 + b[i].abs()))
}

/// Known values from the convention's formula with R_b/r_w = 2.4, α = 45°.
#[test]
fn known_values() {
    let m = preset();
    let k = 0.12 / 0.05;
    let c = (45.0 * DEG).cos();
    // Body turning at 1 rad/s over a still ball: ω = (0, 0, −1), all wheels −k sinα.
    let w = m.wheel_rates(Twist2::new(0.0, 0.0, 1.0), 0.0).unwrap();
    assert!(close(w, [-k * c; 3], 1e-14), "{w:?}");
    // Rolling forward (+x) at 0.12 m/s: ω = (0, 1, 0) rad/s; ψ̇_i = −k cosα sinβ_i.
    let w = m.wheel_rates(Twist2::new(0.12, 0.0, 0.0), 0.0).unwrap();
    let s120 = (120.0 * DEG).sin();
    assert!(close(w, [0.0, -k * c * s120, k * c * s120], 1e-14), "{w:?}");
    // Sideways (+y): ω = (−1, 0, 0); ψ̇_i = k cosα cosβ_i.
    let w = m.wheel_rates(Twist2::new(0.0, 0.12, 0.0), 0.0).unwrap();
    assert!(
        close(w, [k * c, -0.5 * k * c, -0.5 * k * c], 1e-14),
        "{w:?}"
    );
}

fn geometry() -> impl Strategy<Value = BallbotParams<f64>> {
    (
        0.05..0.5f64,
        0.01..0.2f64,
        15.0..75.0f64,
        prop::array::uniform3(-20.0..20.0f64),
    )
        .prop_map(|(rb, rw, zen, j)| BallbotParams {
            ball_radius: rb,
            wheel_radius: rw,
            zenith: zen * DEG,
            azimuths: [j[0] * DEG, (120.0 + j[1]) * DEG, (-120.0 + j[2]) * DEG],
        })
}

fn twist() -> impl Strategy<Value = Twist2<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -3.0..3.0f64).prop_map(|(x, y, w)| Twist2::new(x, y, w))
}

proptest! {
    #[test]
    fn forward_and_inverse_are_inverses(p in geometry(), tw in twist(), spin in -2.0..2.0f64,
                                        w in prop::array::uniform3(-30.0..30.0f64)) {
        let m = Ballbot::new(p).unwrap();
        let back = m.body_twist(m.wheel_rates(tw, spin).unwrap(), spin).unwrap();
        prop_assert!(close(back.to_array(), tw.to_array(), 1e-10));
        let back = m.wheel_rates(m.body_twist(w, spin).unwrap(), spin).unwrap();
        prop_assert!(close(back, w, 1e-9));
    }

    /// No slip along each wheel's drive direction, computed from first principles: the ball's
    /// surface velocity relative to the body at the contact, along t_i, equals r_w ψ̇_i.
    #[test]
    fn no_slip_along_drive_directions(p in geometry(), tw in twist(), spin in -2.0..2.0f64) {
        let m = Ballbot::new(p).unwrap();
        let w = m.wheel_rates(tw, spin).unwrap();
        // Ball absolute rate from rolling: v = Ω × (R e3) ⇒ Ω_x = −v_y/R, Ω_y = v_x/R.
        let omega_ball = Vector3::new(-tw.vy / p.ball_radius, tw.vx / p.ball_radius, spin);
        let omega_rel = omega_ball - Vector3::new(0.0, 0.0, tw.yaw_rate);
        let floor = Vector3::new(tw.vx, tw.vy, 0.0) + omega_ball.cross(&(-Vector3::z() * p.ball_radius));
        prop_assert!(floor.norm() < 1e-12);
        for i in 0..3 {
            let contact = m.contact_directions()[i] * p.ball_radius;
            let surface = omega_rel.cross(&contact);
            let along = surface.dot(&m.drive_directions()[i]);
            prop_assert!((along - p.wheel_radius * w[i]).abs() < 1e-12);
        }
    }

    /// The torque map and the velocity map are exact duals: wheel power equals model power,
    /// and equals the mechanical power delivered to the ball, τ_ball·ω_rel, with τ_ball
    /// computed from the contact forces by cross products.
    #[test]
    fn power_balance(p in geometry(), t in prop::array::uniform3(-5.0..5.0f64),
                     w in prop::array::uniform3(-30.0..30.0f64), yaw in -7.0..7.0f64) {
        let m = Ballbot::new(p).unwrap();
        let wheel_power: f64 = (0..3).map(|i| t[i] * w[i]).sum();
        let tm = m.model_torques(t, yaw).unwrap();
        let vm = m.model_rates(w, yaw).unwrap();
        let model_power: f64 = (0..3).map(|i| tm[i] * vm[i]).sum();
        prop_assert!((wheel_power - model_power).abs() < 1e-9 * (1.0 + wheel_power.abs()));
        // Contact force of wheel i on the ball: (T_i / r_w) t_i at R_b p̂_i.
        let mut tau = Vector3::zeros();
        for i in 0..3 {
            let force = m.drive_directions()[i] * (t[i] / p.wheel_radius);
            tau += (m.contact_directions()[i] * p.ball_radius).cross(&force);
        }
        let omega_rel = m.relative_rate_from_wheels(w).unwrap();
        prop_assert!((tau.dot(&omega_rel) - wheel_power).abs() < 1e-9 * (1.0 + wheel_power.abs()));
        // Round trips.
        prop_assert!(close(m.wheel_torques(tm, yaw).unwrap(), t, 1e-10));
        prop_assert!(close(m.wheel_rates_from_model(vm, yaw).unwrap(), w, 1e-9));
    }

    /// Erratum E3: A(β) = Rz(β) A(0), a proper rotation of (Tx, Ty); Tz unchanged.
    #[test]
    fn model_torques_rotate_with_yaw(t in prop::array::uniform3(-5.0..5.0f64), yaw in -7.0..7.0f64) {
        let m = preset();
        let t0 = m.model_torques(t, 0.0).unwrap();
        let tb = m.model_torques(t, yaw).unwrap();
        let (s, c) = yaw.sin_cos();
        prop_assert!(close(tb, [c * t0[0] - s * t0[1], s * t0[0] + c * t0[1], t0[2]], 1e-12));
    }

    /// World-frame inverse is frame invariant, and the odometry step rotates with the world.
    #[test]
    fn frame_invariance(tw in twist(), yaw in -7.0..7.0f64, a in -7.0..7.0f64,
                        dq in prop::array::uniform3(-1.0..1.0f64), dyaw in -0.5..0.5f64) {
        let m = preset();
        let w0 = m.wheel_rates_world(tw, yaw, 0.0).unwrap();
        let w1 = m.wheel_rates_world(tw.rotated(a), yaw + a, 0.0).unwrap();
        prop_assert!(close(w0, w1, 1e-12));
        let d0 = m.ball_displacement(dq, yaw, yaw + dyaw).unwrap();
        let d1 = m.ball_displacement(dq, yaw + a, yaw + a + dyaw).unwrap();
        let (s, c) = a.sin_cos();
        prop_assert!((c * d0[0] - s * d0[1] - d1[0]).abs() < 1e-12);
        prop_assert!((s * d0[0] + c * d0[1] - d1[1]).abs() < 1e-12);
    }

    #[test]
    fn f32_agrees_with_f64(tw in twist(), t in prop::array::uniform3(-5.0..5.0f64), yaw in -3.2..3.2f64) {
        let m64 = preset();
        let m32 = Ballbot::<f32>::new(BallbotParams::preset()).unwrap();
        let w64 = m64.wheel_rates(tw, 0.0).unwrap();
        let w32 = m32.wheel_rates(Twist2::new(tw.vx as f32, tw.vy as f32, tw.yaw_rate as f32), 0.0).unwrap();
        let t64 = m64.wheel_torques(t, yaw).unwrap();
        let t32 = m32.wheel_torques(t.map(|x| x as f32), yaw as f32).unwrap();
        for i in 0..3 {
            prop_assert!((w32[i] as f64 - w64[i]).abs() < 1e-5 * (1.0 + w64[i].abs()));
            prop_assert!((t32[i] as f64 - t64[i]).abs() < 1e-5 * (1.0 + t64[i].abs()));
        }
    }
}

/// Erratum E2: the closed-form inverse of the digest matches ours; the printed one (with Tx
/// and Ty swapped) does not return the input.
#[test]
fn erratum_e2_inverse_torque_map() {
    let m = preset();
    let (sa, ca) = (45.0 * DEG).sin_cos();
    let s3 = 3.0f64.sqrt();
    let (tx, ty, tz) = (0.3, -0.7, 0.2);
    let correct = [
        (tz / sa + 2.0 * tx / ca) / 3.0,
        (tz / sa - tx / ca + s3 * ty / ca) / 3.0,
        (tz / sa - tx / ca - s3 * ty / ca) / 3.0,
    ];
    let ours = m.wheel_torques([tx, ty, tz], 0.0).unwrap();
    assert!(close(ours, correct, 1e-13), "{ours:?} vs {correct:?}");
    let printed = [
        (tz / sa + 2.0 * ty / ca) / 3.0,
        (tz / sa - ty / ca + s3 * tx / ca) / 3.0,
        (tz / sa - ty / ca - s3 * tx / ca) / 3.0,
    ];
    let round_trip = m.model_torques(printed, 0.0).unwrap();
    assert!(
        !close(round_trip, [tx, ty, tz], 1e-3),
        "printed inverse must fail"
    );
    // The forward map at β = 0 in the paper's expanded form.
    let t = [0.4, -0.1, 0.25];
    let f = m.model_torques(t, 0.0).unwrap();
    let expanded = [
        ca * (t[0] - t[1] / 2.0 - t[2] / 2.0),
        ca * s3 / 2.0 * (t[1] - t[2]),
        sa * (t[0] + t[1] + t[2]),
    ];
    assert!(close(f, expanded, 1e-14));
    // E4: Σ T_i = Σ model torques does not hold in general.
    let lhs: f64 = t.iter().sum();
    let rhs: f64 = f.iter().sum();
    assert!((lhs - rhs).abs() > 1e-3);
}

/// Erratum E3: the printed yaw projection is not a rotation (its determinant is sin²β − cos²β).
#[test]
fn erratum_e3_printed_projection_is_not_a_rotation() {
    let beta = 0.3f64;
    let printed = Matrix3::new(
        beta.sin(),
        beta.cos(),
        0.0,
        beta.cos(),
        beta.sin(),
        0.0,
        0.0,
        0.0,
        1.0,
    );
    let det = printed.determinant();
    assert!((det - (beta.sin().powi(2) - beta.cos().powi(2))).abs() < 1e-15);
    assert!((det - 1.0).abs() > 0.1);
    // Ours preserves the horizontal torque magnitude at every yaw.
    let m = preset();
    let t = [0.4, -0.1, 0.25];
    let a = m.model_torques(t, 0.0).unwrap();
    let b = m.model_torques(t, beta).unwrap();
    assert!((a[0].hypot(a[1]) - b[0].hypot(b[1])).abs() < 1e-15);
}

/// Model rates are the relative ball rate scaled and sign-flipped as documented.
#[test]
fn model_rates_in_the_body_frame() {
    let m = preset();
    let tw = Twist2::new(0.2, -0.1, 0.5);
    let w = m.wheel_rates(tw, 0.0).unwrap();
    let omega = m.relative_rate(tw, 0.0).unwrap();
    let v = m.model_rates(w, 0.0).unwrap();
    let k = 0.12 / 0.05;
    assert!(close(v, [-k * omega.x, -k * omega.y, k * omega.z], 1e-12));
}

/// Odometry building block: a turn on the spot moves nothing; rolling moves the ball by
/// R_b times the rolling angle in the world direction of the body-frame motion.
#[test]
fn ball_displacement_known_cases() {
    let m = preset();
    // Body turns by 0.4 rad over a still ball: the wheels turn, the ball does not move.
    let turn = m.wheel_rates(Twist2::new(0.0, 0.0, 0.4), 0.0).unwrap();
    let d = m.ball_displacement(turn, 1.0, 1.4).unwrap();
    assert!(d[0].abs() < 1e-15 && d[1].abs() < 1e-15, "{d:?}");
    // Roll 0.3 m forward in the body frame while the body faces 90°: world +y.
    let roll = m.wheel_rates(Twist2::new(0.3, 0.0, 0.0), 0.0).unwrap();
    let d = m.ball_displacement(roll, 90.0 * DEG, 90.0 * DEG).unwrap();
    assert!(d[0].abs() < 1e-14 && (d[1] - 0.3).abs() < 1e-14, "{d:?}");
    // Quarter circle: body-frame velocity constant while turning 90°: chord of the arc.
    let arc = m
        .wheel_rates(
            Twist2::new(0.5 * core::f64::consts::PI, 0.0, 90.0 * DEG),
            0.0,
        )
        .unwrap();
    let d = m.ball_displacement(arc, 0.0, 90.0 * DEG).unwrap();
    assert!(
        (d[0] - 1.0).abs() < 1e-12 && (d[1] - 1.0).abs() < 1e-12,
        "{d:?}"
    );
}

#[test]
fn bad_geometry_and_input() {
    let p = BallbotParams::<f64>::preset();
    let e = Ballbot::new(BallbotParams { zenith: 0.0, ..p }).unwrap_err();
    assert!(
        matches!(
            e,
            GeometryError::AngleOutOfRange {
                field: "zenith",
                ..
            }
        ),
        "{e}"
    );
    let e = Ballbot::new(BallbotParams {
        zenith: 90.0 * DEG,
        ..p
    })
    .unwrap_err();
    assert!(matches!(e, GeometryError::AngleOutOfRange { .. }), "{e}");
    let e = Ballbot::new(BallbotParams {
        azimuths: [0.0, 0.0, 2.0],
        ..p
    })
    .unwrap_err();
    assert!(matches!(e, GeometryError::IllConditioned { .. }), "{e}");
    let e = Ballbot::new(BallbotParams {
        wheel_radius: 0.0,
        ..p
    })
    .unwrap_err();
    assert!(
        matches!(
            e,
            GeometryError::NotPositive {
                field: "wheel_radius",
                ..
            }
        ),
        "{e}"
    );
    let m = preset();
    assert_eq!(
        m.model_torques([0.0, 0.0, f64::NAN], 0.0),
        Err(InputError::NonFinite {
            field: "wheel_torques[2]"
        })
    );
    assert_eq!(
        m.ball_displacement([0.0; 3], f64::NAN, 0.0),
        Err(InputError::NonFinite { field: "yaw_start" })
    );
}

/// At α = 30° (sin α ≠ cos α) the projection matrix and the velocity map follow paper 001's
/// formulas written out here independently: `A(β)` rows `cos α cos β_i`, `cos α sin β_i`,
/// `sin α`; wheel rates `ψ̇ = A(β)ᵀ v` with model rates `v = (R_b/r_w)(−ω_x, −ω_y, ω_z)`
/// (world-yaw frame), and the E2 closed-form inverse.
#[test]
fn maps_at_a_zenith_other_than_45_degrees() {
    let alpha = 30.0 * DEG;
    let (rb, rw) = (0.1, 0.04);
    let m = Ballbot::new(BallbotParams {
        ball_radius: rb,
        wheel_radius: rw,
        zenith: alpha,
        azimuths: [0.0, 120.0 * DEG, -120.0 * DEG],
    })
    .unwrap();
    let (sa, ca) = alpha.sin_cos();
    let yaw = 0.7;
    let az = [yaw, yaw + 120.0 * DEG, yaw - 120.0 * DEG];
    let t = [0.3, -0.2, 0.5];
    let expected: [f64; 3] = [
        ca * (0..3).map(|i| t[i] * az[i].cos()).sum::<f64>(),
        ca * (0..3).map(|i| t[i] * az[i].sin()).sum::<f64>(),
        sa * t.iter().sum::<f64>(),
    ];
    assert!(close(m.model_torques(t, yaw).unwrap(), expected, 1e-14));
    // E2 closed form at β = 0 with sin α ≠ cos α.
    let (tx, ty, tz) = (0.3, -0.7, 0.2);
    let s3 = 3f64.sqrt();
    let inv = [
        (tz / sa + 2.0 * tx / ca) / 3.0,
        (tz / sa - tx / ca + s3 * ty / ca) / 3.0,
        (tz / sa - tx / ca - s3 * ty / ca) / 3.0,
    ];
    assert!(close(
        m.wheel_torques([tx, ty, tz], 0.0).unwrap(),
        inv,
        1e-13
    ));
    // Velocity duality: wheel rates of a world-frame motion equal A(β)ᵀ v.
    let tw_world = Twist2::new(0.2, -0.3, 0.4);
    let tw_body = tw_world.to_robot(yaw);
    let omega_body = Vector3::new(-tw_body.vy / rb, tw_body.vx / rb, -tw_body.yaw_rate);
    let k = rb / rw;
    let (s, c) = yaw.sin_cos();
    // Model rates in the world-yaw frame: rotate the body-frame (−kω_x, −kω_y) by β.
    let vb = [-k * omega_body.x, -k * omega_body.y];
    let v = [
        c * vb[0] - s * vb[1],
        s * vb[0] + c * vb[1],
        k * omega_body.z,
    ];
    let psi: [f64; 3] =
        core::array::from_fn(|i| ca * az[i].cos() * v[0] + ca * az[i].sin() * v[1] + sa * v[2]);
    assert!(close(
        m.wheel_rates_world(tw_world, yaw, 0.0).unwrap(),
        psi,
        1e-12
    ));
    assert!(close(m.wheel_rates_from_model(v, yaw).unwrap(), psi, 1e-12));
}
