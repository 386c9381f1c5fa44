//! The uniform robot API (`omnikin::Robot`) over every kind: properties that hold for every
//! preset and for random twists, so a kind added to the enum is tested by adding its preset.

use omnikin::description::{PRESETS, RobotDescription};
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::{Actuators, EncoderAngles, Kind, Pose2, Robot, Twist2};
use proptest::prelude::*;

fn presets() -> Vec<(&'static str, Robot<f64>)> {
    PRESETS
        .iter()
        .map(|(n, _)| (*n, RobotDescription::preset(n).unwrap().build().unwrap()))
        .collect()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

fn twist_close(a: Twist2<f64>, b: Twist2<f64>, tol: f64) -> bool {
    close(a.vx, b.vx, tol) && close(a.vy, b.vy, tol) && close(a.yaw_rate, b.yaw_rate, tol)
}

/// The steer state a robot is in after driving `twist` (the caster's steering is a state it
/// keeps; a swerve's follows the twist; the others have none).
fn settled(robot: &Robot<f64>, steer: [f64; 3]) -> Actuators<f64> {
    match robot.kind() {
        Kind::Caster => Actuators::at_steer(&steer),
        _ => Actuators::zero(),
    }
}

#[test]
fn every_preset_reports_its_kind_wheels_and_motors() {
    let want = [
        ("sphere-omni", Kind::Sphere, 3, 3),
        ("ballbot", Kind::Ballbot, 3, 3),
        ("caster3", Kind::Caster, 3, 6),
        ("kiwi", Kind::Omni, 3, 3),
        ("x-drive", Kind::Omni, 4, 4),
        ("mecanum", Kind::Omni, 4, 4),
        ("swerve4", Kind::Swerve, 4, 8),
    ];
    let got = presets();
    assert_eq!(got.len(), want.len());
    for ((name, r), (wn, k, w, m)) in got.iter().zip(want) {
        assert_eq!(*name, wn);
        assert_eq!(r.kind(), k, "{name}");
        assert_eq!(r.wheels(), w, "{name}");
        assert_eq!(r.motors(), m, "{name}");
        assert_eq!(Kind::from_name(r.kind().name()), Some(k));
        let d = RobotDescription::preset(name).unwrap();
        assert_eq!(d.kind(), k.name(), "{name}");
    }
}

#[test]
fn kiwi_matches_the_issue_formula() {
    // ω_i = (−sin θ_i vx + cos θ_i vy + L ω)/r, θ_i = 0°, 120°, 240°, L = 0.15, r = 0.05.
    let r: Robot<f64> = RobotDescription::preset("kiwi").unwrap().build().unwrap();
    let t = Twist2::new(0.3, -0.2, 0.7);
    let a = r.inverse(t, &Actuators::zero()).unwrap();
    for i in 0..3 {
        let th = (i as f64 * 120.0f64).to_radians();
        let want = (-th.sin() * t.vx + th.cos() * t.vy + 0.15 * t.yaw_rate) / 0.05;
        assert!(close(a.wheel_rates[i], want, 1e-12), "wheel {i}");
    }
    assert_eq!(&a.wheel_rates[3..], &[0.0; 3]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// forward ∘ inverse = identity with zero slip, for every kind.
    #[test]
    fn forward_of_inverse_is_the_twist(vx in -2.0..2.0f64, vy in -2.0..2.0f64,
                                       w in -3.0..3.0f64, g0 in -1.0..1.0f64) {
        let t = Twist2::new(vx, vy, w);
        for (name, r) in presets() {
            let cur = settled(&r, [g0, -0.5 * g0, 0.3]);
            let a = r.inverse(t, &cur).unwrap();
            let m = r.forward(&a).unwrap();
            prop_assert!(twist_close(m.twist, t, 1e-9), "{name}: {:?} vs {t:?}", m.twist);
            prop_assert!(m.slip_residual.abs() < 1e-9, "{name}: slip {}", m.slip_residual);
            for i in r.wheels()..omnikin::MAX_WHEELS {
                prop_assert_eq!(a.wheel_rates[i], 0.0);
            }
        }
    }

    /// Frame invariance: a world twist at heading ψ drives the same motors as its robot-frame
    /// version.
    #[test]
    fn world_inverse_is_robot_inverse_of_the_rotated_twist(vx in -2.0..2.0f64, vy in -2.0..2.0f64,
                                                           w in -3.0..3.0f64, psi in -7.0..7.0f64) {
        let t = Twist2::new(vx, vy, w);
        for (name, r) in presets() {
            let cur = settled(&r, [0.2, 0.1, -0.4]);
            let a = r.inverse(t, &cur).unwrap();
            let b = r.inverse_world(t.to_world(psi), psi, &cur).unwrap();
            for i in 0..r.wheels() {
                prop_assert!(close(a.wheel_rates[i], b.wheel_rates[i], 1e-9), "{name} {i}");
                prop_assert!(close(a.steer_rates[i], b.steer_rates[i], 1e-9), "{name} {i}");
            }
        }
    }

    /// Desaturation scales every wheel rate by one factor, so the driven twist is the
    /// request scaled: direction and curvature are kept.
    #[test]
    fn desaturation_keeps_the_direction(vx in -5.0..5.0f64, vy in -5.0..5.0f64,
                                        w in -8.0..8.0f64, lim in 1.0..30.0f64) {
        let t = Twist2::new(vx, vy, w);
        for (name, r) in presets() {
            let cur = settled(&r, [0.2, 0.1, -0.4]);
            let a = r.inverse(t, &cur).unwrap();
            let d = r.desaturate(a, lim).unwrap();
            let peak = d.actuators.wheel_rates.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            prop_assert!(peak <= lim * (1.0 + 1e-12), "{name}: {peak} > {lim}");
            prop_assert!(d.scale > 0.0 && d.scale <= 1.0);
            let driven = r.forward(&d.actuators).unwrap().twist;
            let want = Twist2::new(t.vx * d.scale, t.vy * d.scale, t.yaw_rate * d.scale);
            prop_assert!(twist_close(driven, want, 1e-9), "{name}: {driven:?} vs {want:?}");
        }
    }
}

/// Odometry through the uniform API is exact on a circular arc (constant robot twist), for
/// every kind whose wheel angles grow linearly on an arc (all but the caster, whose steering
/// must settle first: its arc needs the steer angles of the twist, constant along it).
#[test]
fn odometry_is_exact_on_arcs_for_every_kind() {
    let t = Twist2::new(0.4, 0.1, 0.6);
    for (name, r) in presets() {
        // The steer state that drives t with zero steer rate (caster) or the module angles.
        let cur = match r.kind() {
            Kind::Caster => {
                // Steer angles fixed under a constant twist: solve γ̇ = 0 by iteration.
                let mut a = Actuators::<f64>::zero();
                for _ in 0..200 {
                    let b = r.inverse(t, &a).unwrap();
                    for i in 0..3 {
                        a.steer_angles[i] += 0.05 * b.steer_rates[i];
                    }
                }
                a
            }
            _ => Actuators::zero(),
        };
        let a = r.inverse(t, &cur).unwrap();
        if r.kind() == Kind::Caster && a.steer_rates[..3].iter().any(|s| s.abs() > 1e-9) {
            panic!("caster steering did not settle: {:?}", a.steer_rates);
        }
        for steps in [1usize, 7, 100] {
            let dur = 2.0;
            let mut odo = Odometry::new(r, Pose2::new(1.0, -2.0, 0.3));
            let reading = |k: usize| {
                let tau = dur * k as f64 / steps as f64;
                let w: Vec<f64> = (0..r.wheels()).map(|i| a.wheel_rates[i] * tau).collect();
                let e = EncoderAngles::new(&w, &a.steer_angles[..r.wheels()]);
                EncoderReading {
                    t: tau,
                    wheel_angles: e.wheel,
                    steer_angles: e.steer,
                }
            };
            for k in 0..=steps {
                odo.update(&reading(k), HeadingInput::Wheels).unwrap();
            }
            let want =
                omnikin::se2::compose(Pose2::new(1.0, -2.0, 0.3), omnikin::se2::twist_exp(t, dur));
            let p = odo.pose();
            assert!(
                (p.x - want.x).abs() < 1e-9
                    && (p.y - want.y).abs() < 1e-9
                    && (p.heading - want.heading).abs() < 1e-9,
                "{name} {steps} steps: {p:?} vs {want:?}"
            );
        }
    }
}

#[test]
fn torque_maps_are_dual_to_the_velocity_maps() {
    // Power balance: Σ τ_i ω_i = g · v for the generalized forces of τ, on every kind that
    // has a torque map (ballbot: model torques against model rates are tested in ballbot.rs;
    // here the body-wrench kinds).
    for (name, r) in presets() {
        let Some(space) = r.torque_space() else {
            continue;
        };
        if space != omnikin::drive::TorqueSpace::BodyWrench {
            continue;
        }
        let t = Twist2::new(0.3, -0.4, 0.9);
        let cur = Actuators::<f64>::zero();
        let a = r.inverse(t, &cur).unwrap();
        let mut tau = [0.0; omnikin::MAX_WHEELS];
        for (i, v) in tau.iter_mut().enumerate().take(r.wheels()) {
            *v = 0.1 * (i as f64 + 1.0) - 0.2;
        }
        let g = r
            .generalized_forces(&tau, &a.steer_angles)
            .unwrap()
            .unwrap();
        let p_wheels: f64 = (0..r.wheels()).map(|i| tau[i] * a.wheel_rates[i]).sum();
        let p_body = g[0] * t.vx + g[1] * t.vy + g[2] * t.yaw_rate;
        assert!(
            close(p_wheels, p_body, 1e-9),
            "{name}: {p_wheels} vs {p_body}"
        );
        // And back: the minimum-norm torques reproduce the wrench.
        let back = r.wheel_torques(g, &a.steer_angles).unwrap().unwrap();
        let g2 = r
            .generalized_forces(&back, &a.steer_angles)
            .unwrap()
            .unwrap();
        for j in 0..3 {
            assert!(close(g[j], g2[j], 1e-9), "{name} {j}");
        }
    }
}

#[test]
fn wheel_counts_outside_the_supported_range_are_rejected() {
    let w = omnikin::drive::omni::OmniWheel::at_angle([0.1, 0.0], 1.0, 0.0, 0.05);
    let e = Robot::<f64>::omni(&[w; 7]).unwrap_err();
    assert!(e.to_string().contains("7 given"), "{e}");
    let e = Robot::<f64>::omni(&[w; 2]).unwrap_err();
    assert!(e.to_string().contains("supports 3 to 6"), "{e}");
    let text =
        "kind = \"swerve\"\n[[geometry.modules]]\nposition = [0.3, 0.3]\nwheel_radius = 0.05\n";
    let e = RobotDescription::from_toml_str(text, "t")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("geometry.modules") && e.contains("1 given"),
        "{e}"
    );
}

#[test]
fn rank_deficient_omni_file_names_the_rule() {
    // Three wheels all driving along x: the yaw and y motions are not controllable.
    let mut text = String::from("kind = \"omni\"\n");
    for y in [-0.2, 0.0, 0.2] {
        text += &format!(
            "[[geometry.wheels]]\nposition = [0.0, {y}]\ndrive_angle_deg = 0.0\nroller_angle_deg = 0.0\nradius = 0.05\n"
        );
    }
    let e = RobotDescription::from_toml_str(&text, "t")
        .unwrap_err()
        .to_string();
    assert!(e.contains("geometry.wheels"), "{e}");
    assert!(e.contains("parallel") || e.contains("condition"), "{e}");
}

#[test]
fn f32_and_f64_agree_for_every_kind() {
    for (name, _) in PRESETS {
        let d = RobotDescription::preset(name).unwrap();
        let r64: Robot<f64> = d.build().unwrap();
        let r32: Robot<f32> = d.build().unwrap();
        let t = Twist2::new(0.3, -0.1, 0.5);
        let a64 = r64.inverse(t, &Actuators::zero()).unwrap();
        let a32 = r32
            .inverse(Twist2::new(0.3f32, -0.1, 0.5), &Actuators::zero())
            .unwrap();
        for i in 0..r64.wheels() {
            assert!(
                (a64.wheel_rates[i] - a32.wheel_rates[i] as f64).abs()
                    < 1e-5 * (1.0 + a64.wheel_rates[i].abs()),
                "{name} {i}"
            );
        }
    }
}

#[test]
fn every_kind_describes_itself_and_its_reach() {
    for (name, r) in presets() {
        let mut text = String::new();
        r.describe(&mut text).unwrap();
        assert!(text.lines().count() >= 2, "{name}: {text}");
        assert!(text.contains("geometry:"), "{name}: {text}");
        let reach = r.reach(10.0, Some(5.0)).unwrap();
        // The reach is the largest speed whose wheel rates stay within the limit: at it, the
        // fastest wheel turns exactly at the limit (the caster's closed form included).
        for (k, v) in reach.speed.iter().enumerate() {
            assert!(*v > 0.0 && v.is_finite(), "{name} {k}");
            if r.kind() != Kind::Caster {
                let (s, c) = (45.0 * k as f64).to_radians().sin_cos();
                let a = r
                    .inverse(Twist2::new(c * v, s * v, 0.0), &Actuators::zero())
                    .unwrap();
                let peak = a.wheel_rates.iter().fold(0.0f64, |m, w| m.max(w.abs()));
                assert!(close(peak, 10.0, 1e-12), "{name} {k}: {peak}");
            }
        }
        assert!(r.reach(0.0, None).is_none() && r.reach(f64::NAN, None).is_none());
    }
}

proptest! {
    /// `aligned_steer`: the caster's trailing configuration starts the motion with zero steer
    /// rates and positive roll rates (the wheel trails); a swerve's is the inverse's module
    /// directions; the others have none.
    #[test]
    fn aligned_steer_starts_the_motion_without_re_steering(
        vx in -2.0..2.0f64, vy in -2.0..2.0f64, w in -3.0..3.0f64,
    ) {
        let twist = Twist2::new(vx, vy, w);
        prop_assume!(vx.hypot(vy) > 0.05);
        for (name, robot) in presets() {
            let n = robot.wheels();
            let g = robot.aligned_steer(twist).unwrap();
            prop_assert!(g[n..].iter().all(|&x| x == 0.0), "{}", name);
            match robot.kind() {
                Kind::Caster => {
                    // A zero steer rate exists when |ω| d < |v_F|, which |ω| (D + d) < |v|
                    // guarantees (|v_F| ≥ |v| − |ω| D).
                    let d = RobotDescription::preset(name).unwrap();
                    let omnikin::description::Geometry::Caster(p) = d.geometry else {
                        panic!("{name}: caster without caster geometry")
                    };
                    if w.abs() * (p.mount_radius + p.eccentricity) >= 0.9 * vx.hypot(vy) {
                        continue;
                    }
                    let a = robot.inverse(twist, &Actuators::at_steer(&g)).unwrap();
                    for i in 0..n {
                        prop_assert!(a.steer_rates[i].abs() < 1e-9, "{} steer {}: {}", name, i, a.steer_rates[i]);
                        prop_assert!(a.wheel_rates[i] >= -1e-9, "{} roll {}: {}", name, i, a.wheel_rates[i]);
                        prop_assert!(g[i].abs() <= std::f64::consts::PI + 1e-12);
                    }
                }
                Kind::Swerve => {
                    let a = robot.inverse(twist, &Actuators::zero()).unwrap();
                    for i in 0..n {
                        prop_assert!(close(g[i], a.steer_angles[i], 1e-12), "{}", name);
                    }
                }
                _ => prop_assert!(g.iter().all(|&x| x == 0.0), "{}", name),
            }
        }
    }
}

#[test]
fn steer_length_is_the_casters_eccentricity_only() {
    for (name, robot) in presets() {
        let d = RobotDescription::preset(name).unwrap();
        match (robot.kind(), &d.geometry) {
            (Kind::Caster, omnikin::description::Geometry::Caster(p)) => {
                assert_eq!(robot.steer_length(), Some(p.eccentricity), "{name}")
            }
            (Kind::Caster, _) => panic!("{name}: caster without caster geometry"),
            _ => assert_eq!(robot.steer_length(), None, "{name}"),
        }
    }
    let bad = Twist2::new(f64::NAN, 0.0, 0.0);
    for (name, robot) in presets() {
        assert!(robot.aligned_steer(bad).is_err(), "{name}");
    }
}
