//! Spherical robot (paper 000): reference value, contact no-slip, identities, erratum E1.

use nalgebra::Vector3;
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{GeometryError, InputError, Twist2};
use proptest::prelude::*;

const DEG: f64 = core::f64::consts::PI / 180.0;

fn preset() -> SphereOmni<f64> {
    SphereOmni::new(SphereParams::preset()).unwrap()
}

/// The reference value of conventions.md: V = (0.1, 0) m/s, ψ̇ = 0, Ω3 = 0.
#[test]
fn reference_value_of_the_conventions() {
    let w = preset()
        .wheel_rates(Twist2::new(0.1, 0.0, 0.0), 0.0)
        .unwrap();
    let expected = [-1.428571, 1.589103, -0.160532];
    for i in 0..3 {
        assert!(
            (w[i] - expected[i]).abs() < 5e-7,
            "wheel {}: {} vs {}",
            i + 1,
            w[i],
            expected[i]
        );
    }
    // And in single precision, as on the robot's microcontroller.
    let w32 = SphereOmni::<f32>::new(SphereParams::preset())
        .unwrap()
        .wheel_rates(Twist2::new(0.1, 0.0, 0.0), 0.0)
        .unwrap();
    for i in 0..3 {
        assert!((w32[i] as f64 - expected[i]).abs() < 2e-6);
    }
}

/// Closed forms of the digest for the preset: `s_i·n_i = (R − R_i) sin ξ`; a pure turn of the
/// platform with no shell spin turns all wheels equally (three-fold symmetry).
#[test]
fn preset_geometry_and_pure_turn() {
    let m = preset();
    for sn in m.s_dot_n() {
        assert!((sn - 0.08 * (45.0 * DEG).sin()).abs() < 1e-15);
    }
    for i in 0..3 {
        assert!((m.wheel_axes()[i].norm() - 1.0).abs() < 1e-15);
        assert!((m.roller_axes()[i].norm() - 1.0).abs() < 1e-15);
        assert!(m.wheel_axes()[i].dot(&m.wheel_centres()[i]).abs() < 1e-15);
        assert!((m.wheel_axes()[i].dot(&m.roller_axes()[i]) - (45.0 * DEG).cos()).abs() < 1e-15);
    }
    let w = m.wheel_rates(Twist2::new(0.0, 0.0, 1.0), 0.0).unwrap();
    assert!((w[0] - w[1]).abs() < 1e-12 && (w[1] - w[2]).abs() < 1e-12);
    assert!(w[0].abs() > 0.1);
    assert!(m.condition_number() < 3.0, "{}", m.condition_number());
}

/// Velocity of the wheel's material and of the shell's material at wheel i's contact
/// (paper 000, eqs. 4.1–4.2), computed from first principles in the platform frame.
fn contact_velocities(
    m: &SphereOmni<f64>,
    i: usize,
    v: Vector3<f64>,
    omega: Vector3<f64>,
    shell: Vector3<f64>,
    chi_dot: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let p = m.params();
    let big_r = p.shell_radius;
    let ri = p.wheel_radius[i];
    let r = m.wheel_centres()[i];
    let n = m.wheel_axes()[i];
    let contact = r * (big_r / (big_r - ri));
    let wheel = v + omega.cross(&contact) + (n * chi_dot).cross(&(r * (ri / (big_r - ri))));
    let shell_pt = v + shell.cross(&contact);
    (wheel, shell_pt)
}

fn geometry() -> impl Strategy<Value = SphereParams<f64>> {
    (
        0.05..1.0f64,
        0.1..0.7f64,
        15.0..75.0f64,
        15.0..75.0f64,
        prop::array::uniform3(-15.0..15.0f64),
    )
        .prop_map(|(r, frac, tilt, xi, jitter)| SphereParams {
            shell_radius: r,
            wheel_radius: [r * frac; 3],
            tilt: tilt * DEG,
            roller_angle: xi * DEG,
            azimuths: [
                jitter[0] * DEG,
                (120.0 + jitter[1]) * DEG,
                (240.0 + jitter[2]) * DEG,
            ],
        })
}

fn twist() -> impl Strategy<Value = Twist2<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -3.0..3.0f64).prop_map(|(x, y, w)| Twist2::new(x, y, w))
}

proptest! {
    /// The floor contact is at rest and wheel and shell agree along every roller axis.
    #[test]
    fn no_slip_at_every_contact(p in geometry(), tw in twist(), spin in -2.0..2.0f64) {
        let m = SphereOmni::new(p).unwrap();
        let chi = m.wheel_rates(tw, spin).unwrap();
        let v = Vector3::new(tw.vx, tw.vy, 0.0);
        let shell = m.shell_angular_velocity(tw, spin).unwrap();
        let floor = v + shell.cross(&(-Vector3::z() * p.shell_radius));
        prop_assert!(floor.norm() < 1e-12, "floor contact slides at {floor:?}");
        let omega = Vector3::new(0.0, 0.0, tw.yaw_rate);
        for i in 0..3 {
            let (wheel, shell_pt) = contact_velocities(&m, i, v, omega, shell, chi[i]);
            let slip = (wheel - shell_pt).dot(&m.roller_axes()[i]);
            prop_assert!(slip.abs() < 1e-12, "wheel {i} slips along its roller at {slip}");
        }
    }

    #[test]
    fn forward_inverts_inverse(p in geometry(), tw in twist(), spin in -2.0..2.0f64) {
        let m = SphereOmni::new(p).unwrap();
        let back = m.body_twist(m.wheel_rates(tw, spin).unwrap(), spin).unwrap();
        prop_assert!((back.vx - tw.vx).abs() < 1e-10);
        prop_assert!((back.vy - tw.vy).abs() < 1e-10);
        prop_assert!((back.yaw_rate - tw.yaw_rate).abs() < 1e-10);
        // The shell spin is recovered when the yaw rate is measured (gyro).
        let chi = m.wheel_rates(tw, spin).unwrap();
        prop_assert!((m.shell_spin(chi, tw.yaw_rate).unwrap() - spin).abs() < 1e-10);
    }

    #[test]
    fn inverse_inverts_forward(p in geometry(), w in prop::array::uniform3(-20.0..20.0f64), spin in -2.0..2.0f64) {
        let m = SphereOmni::new(p).unwrap();
        let back = m.wheel_rates(m.body_twist(w, spin).unwrap(), spin).unwrap();
        for i in 0..3 {
            prop_assert!((back[i] - w[i]).abs() < 1e-9 * (1.0 + w[i].abs()));
        }
        let rel = m.relative_rate_from_wheels(w).unwrap();
        let again = m.wheel_rates_from_relative(rel).unwrap();
        for i in 0..3 {
            prop_assert!((again[i] - w[i]).abs() < 1e-9 * (1.0 + w[i].abs()));
        }
    }

    /// Rotating the world frame by `a` rotates the world velocity and the heading together;
    /// the wheel rates do not change.
    #[test]
    fn frame_invariance(tw in twist(), heading in -7.0..7.0f64, a in -7.0..7.0f64) {
        let m = preset();
        let w0 = m.wheel_rates_world(tw, heading, 0.0).unwrap();
        let w1 = m.wheel_rates_world(tw.rotated(a), heading + a, 0.0).unwrap();
        for i in 0..3 {
            prop_assert!((w0[i] - w1[i]).abs() < 1e-12);
        }
        // ... and the world-frame call is the platform-frame call with V = Qᵀ ṙ_C.
        let wp = m.wheel_rates(tw.to_robot(heading), 0.0).unwrap();
        for i in 0..3 {
            prop_assert!((w0[i] - wp[i]).abs() < 1e-12);
        }
    }

    /// Single precision (firmware) agrees with double precision (PC) to 1e-5 relative.
    #[test]
    fn f32_agrees_with_f64(p in geometry(), tw in twist()) {
        let m64 = SphereOmni::new(p).unwrap();
        let p32 = SphereParams {
            shell_radius: p.shell_radius as f32,
            wheel_radius: p.wheel_radius.map(|x| x as f32),
            tilt: p.tilt as f32,
            roller_angle: p.roller_angle as f32,
            azimuths: p.azimuths.map(|x| x as f32),
        };
        let m32 = SphereOmni::new(p32).unwrap();
        let w64 = m64.wheel_rates(tw, 0.0).unwrap();
        let w32 = m32
            .wheel_rates(Twist2::new(tw.vx as f32, tw.vy as f32, tw.yaw_rate as f32), 0.0)
            .unwrap();
        let scale = w64.iter().fold(1.0f64, |a, x| a.max(x.abs()));
        for i in 0..3 {
            prop_assert!((w32[i] as f64 - w64[i]).abs() < 1e-5 * scale, "{w32:?} vs {w64:?}");
        }
    }
}

/// Erratum E1: the printed `Ω = (1/R) V × γ + Ω3 γ` leaves the floor contact moving at `2V`
/// and drives the mirror path (translation wheel rates flip sign); the implemented one does
/// neither.
#[test]
fn erratum_e1_printed_shell_rate_fails_floor_no_slip() {
    let m = preset();
    let big_r = 0.15;
    let tw = Twist2::new(0.1, 0.05, 0.0);
    let v = Vector3::new(tw.vx, tw.vy, 0.0);
    let gamma = Vector3::z();
    let printed = v.cross(&gamma) / big_r;
    let floor_printed = v + printed.cross(&(-gamma * big_r));
    assert!(
        (floor_printed - v * 2.0).norm() < 1e-15,
        "printed formula gives 2V"
    );
    let ours = m.shell_angular_velocity(tw, 0.0).unwrap();
    assert!((v + ours.cross(&(-gamma * big_r))).norm() < 1e-15);
    // Wheel rates from the printed ω̃ are the negated translation rates.
    let w_printed = m.wheel_rates_from_relative(printed).unwrap();
    let w = m.wheel_rates(tw, 0.0).unwrap();
    for i in 0..3 {
        assert!((w_printed[i] + w[i]).abs() < 1e-12);
    }
    // The reference value pins the sign: wheel 1 turns negatively for +x.
    assert!(m.wheel_rates(Twist2::new(0.1, 0.0, 0.0), 0.0).unwrap()[0] < 0.0);
}

#[test]
fn bad_geometry_is_rejected_with_the_reason() {
    let p = SphereParams::<f64>::preset();
    let e = SphereOmni::new(SphereParams {
        roller_angle: 0.0,
        ..p
    })
    .unwrap_err();
    assert!(
        matches!(e, GeometryError::DeadWheel { wheel: 1, .. }),
        "{e}"
    );
    // δ = 0: all s_i horizontal, coplanar.
    let e = SphereOmni::new(SphereParams { tilt: 0.0, ..p }).unwrap_err();
    match e {
        GeometryError::IllConditioned { condition, .. } => assert!(condition > 1e3),
        _ => panic!("{e}"),
    }
    assert!(e.to_string().contains("condition number"));
    let e = SphereOmni::new(SphereParams {
        wheel_radius: [0.07, 0.16, 0.07],
        ..p
    })
    .unwrap_err();
    assert!(
        matches!(e, GeometryError::WheelTooLarge { wheel: 2, .. }),
        "{e}"
    );
    let e = SphereOmni::new(SphereParams {
        shell_radius: -0.15,
        ..p
    })
    .unwrap_err();
    assert!(
        matches!(
            e,
            GeometryError::NotPositive {
                field: "shell_radius",
                ..
            }
        ),
        "{e}"
    );
    let e = SphereOmni::new(SphereParams {
        tilt: f64::NAN,
        ..p
    })
    .unwrap_err();
    assert_eq!(e, GeometryError::NonFinite { field: "tilt" });
    // Two wheels at the same azimuth: singular.
    let e = SphereOmni::new(SphereParams {
        azimuths: [0.0, 0.0, 4.0],
        ..p
    })
    .unwrap_err();
    assert!(matches!(e, GeometryError::IllConditioned { .. }), "{e}");
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let m = preset();
    assert_eq!(
        m.wheel_rates(Twist2::new(f64::NAN, 0.0, 0.0), 0.0),
        Err(InputError::NonFinite { field: "vx" })
    );
    assert_eq!(
        m.wheel_rates(Twist2::new(0.0, 0.0, 0.0), f64::INFINITY),
        Err(InputError::NonFinite {
            field: "shell_spin"
        })
    );
    assert_eq!(
        m.body_twist([0.0, f64::NAN, 0.0], 0.0),
        Err(InputError::NonFinite {
            field: "wheel_rates[1]"
        })
    );
    assert_eq!(
        m.wheel_rates_world(Twist2::new(0.0, 0.0, 0.0), f64::NAN, 0.0),
        Err(InputError::NonFinite { field: "heading" })
    );
}

/// Finite inputs whose result overflows are an error, not ±∞ or NaN in the output.
#[test]
fn overflow_is_an_error() {
    let m = preset();
    assert_eq!(
        m.wheel_rates(Twist2::new(1e308, 0.0, 0.0), 0.0),
        Err(InputError::Overflow {
            quantity: "relative rate"
        })
    );
    // Whatever the magnitude: a finite answer or an Overflow error, never ±∞/NaN in Ok.
    for big in [1e300, 1e307, f64::MAX] {
        for w in [[big, -big, big], [big, big, big], [-big, 0.0, big]] {
            match m.body_twist(w, 0.0) {
                Ok(t) => assert!(t.is_finite(), "{t:?}"),
                Err(e) => assert!(matches!(e, InputError::Overflow { .. }), "{e}"),
            }
            match m.wheel_rates(Twist2::new(w[0], w[1], w[2]), 0.0) {
                Ok(r) => assert!(r.iter().all(|x| x.is_finite())),
                Err(e) => assert!(matches!(e, InputError::Overflow { .. }), "{e}"),
            }
        }
    }
}

/// The digest's closed form of `s_i` (paper 000, §4) at angles other than 45° (where
/// sin = cos would hide a swap), and `s_i·n_i = (R − R_i) sin ξ`.
#[test]
fn levers_match_the_closed_form_at_other_angles() {
    let (big_r, rw, delta, xi) = (0.2, 0.05, 30.0 * DEG, 60.0 * DEG);
    let phi = [10.0 * DEG, 130.0 * DEG, 250.0 * DEG];
    let m = SphereOmni::new(SphereParams {
        shell_radius: big_r,
        wheel_radius: [rw; 3],
        tilt: delta,
        roller_angle: xi,
        azimuths: phi,
    })
    .unwrap();
    let l = big_r - rw;
    for i in 0..3 {
        let (sp, cp) = phi[i].sin_cos();
        let (sd, cd) = delta.sin_cos();
        let (sx, cx) = xi.sin_cos();
        let s = Vector3::new(sp * cx + cp * cd * sx, -(cp * cx - cd * sp * sx), sd * sx) * l;
        assert!(
            (m.levers()[i] - s).norm() < 1e-15,
            "wheel {i}: {:?} vs {s:?}",
            m.levers()[i]
        );
        assert!((m.s_dot_n()[i] - l * sx).abs() < 1e-15);
        let r = Vector3::new(sd * cp, sd * sp, -cd) * l;
        assert!((m.wheel_centres()[i] - r).norm() < 1e-15);
    }
    // And the wheel rate of eq. 5.7 computed by hand for wheel 1, V = (0.1, 0.2), ψ̇ = 0.3.
    let (v, yaw) = ([0.1, 0.2], 0.3);
    let w_rel = Vector3::new(-v[1] / big_r, v[0] / big_r, -yaw);
    let s1 = m.levers()[0];
    let expected = (big_r / rw) * s1.dot(&w_rel) / (l * xi.sin());
    let got = m.wheel_rates(Twist2::new(v[0], v[1], yaw), 0.0).unwrap()[0];
    assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
}
