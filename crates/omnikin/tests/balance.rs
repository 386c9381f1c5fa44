//! The balance controller (issue 15): LQR design, closed-loop poles, feed-forward, saturation,
//! fall detection, input errors, f32 against f64.

use omnikin::InputError;
use omnikin::ballbot::Ballbot;
use omnikin::control::lqr::{self, LqrError};
use omnikin::control::{
    BalanceCommand, BalanceConfig, BalanceController, BalanceError, BalanceState, Lean,
    Measurement, PlanarModel, Plane, PlantParams,
};
use omnikin::nalgebra::{Matrix1, Matrix2, Matrix4, SMatrix, UnitQuaternion, Vector2, Vector3};

const DEG: f64 = std::f64::consts::PI / 180.0;

fn controller() -> BalanceController<f64> {
    BalanceController::new(BalanceConfig::preset()).unwrap()
}

fn still() -> Measurement<f64> {
    Measurement {
        tilt: [0.0; 2],
        tilt_rate: [0.0; 2],
        yaw: 0.0,
        yaw_rate: 0.0,
        ball_position: [0.0; 2],
        ball_velocity: [0.0; 2],
    }
}

#[test]
fn every_planar_closed_loop_is_stable_and_its_riccati_solution_checks() {
    let c = controller();
    for d in c.designs() {
        let n = d.states;
        let (a, b, k) = if n == 4 {
            (d.a, d.b, d.gain)
        } else {
            let mut a = Matrix4::zeros();
            a.fixed_view_mut::<2, 2>(0, 0)
                .copy_from(&d.a.fixed_view::<2, 2>(0, 0));
            (a, d.b, d.gain)
        };
        let closed = a - b * k.transpose();
        let poles = closed
            .fixed_view::<4, 4>(0, 0)
            .into_owned()
            .complex_eigenvalues();
        let rho = poles
            .iter()
            .take(n)
            .map(|p| p.re.hypot(p.im))
            .fold(0.0, f64::max);
        let poles: Vec<_> = if n == 4 {
            poles.iter().copied().collect()
        } else {
            closed
                .fixed_view::<2, 2>(0, 0)
                .into_owned()
                .complex_eigenvalues()
                .iter()
                .copied()
                .collect()
        };
        let rho_n = poles.iter().map(|p| p.re.hypot(p.im)).fold(0.0, f64::max);
        eprintln!(
            "{}: K = {:?}, poles {:?}, ρ = {rho_n:.6} ({} doubling iterations)",
            d.plane.name(),
            &k.as_slice()[..n],
            poles.iter().map(|p| (p.re, p.im)).collect::<Vec<_>>(),
            d.iterations
        );
        assert!(rho_n < 1.0, "{:?} unstable: {rho_n}", d.plane);
        assert!(rho <= 1.0);
        // Gelfand's estimate in the core agrees with the eigenvalues.
        assert!(
            (d.spectral_radius - rho_n).abs() < 1e-6,
            "{} vs {rho_n}",
            d.spectral_radius
        );
        // Balancing needs feedback on the tilt with the sign that rolls the ball under the
        // body: a real, non-zero gain.
        assert!(k.iter().take(n).all(|g| g.is_finite()) && k[1] != 0.0);
    }
}

#[test]
fn dare_solution_satisfies_the_riccati_equation_and_is_optimal() {
    let p = PlantParams::<f64>::preset();
    let m = PlanarModel::new(&p, Plane::Sagittal);
    let (a, b) = lqr::discretize(&m.a, &m.b, 0.005).unwrap();
    let q = Matrix4::from_diagonal(&[10.0, 3000.0, 1.0, 100.0].into());
    let r = Matrix1::new(1.0);
    let d = lqr::dare(&a, &b, &q, &r, 1e-13).unwrap();
    let pm = d.riccati;
    let s = r + b.transpose() * pm * b;
    let k = s.try_inverse().unwrap() * b.transpose() * pm * a;
    let residual = q + a.transpose() * pm * a - a.transpose() * pm * b * k - pm;
    let rel = residual.amax() / pm.amax();
    eprintln!(
        "DARE residual {rel:.2e} relative after {} iterations",
        d.iterations
    );
    assert!(rel < 1e-9);
    assert!((k - d.gain).amax() < 1e-9 * k.amax());
    // Optimality: the cost x0ᵀ P x0 is the cost of the LQR loop, and perturbing the gain
    // costs more.
    let x0 = SMatrix::<f64, 4, 1>::new(0.0, 5.0 * DEG, 0.0, 0.0);
    let cost = |k: &SMatrix<f64, 1, 4>| {
        let mut x = x0;
        let mut j = 0.0;
        for _ in 0..20_000 {
            let u = -(k * x);
            j += (x.transpose() * q * x)[0] + (u.transpose() * r * u)[0];
            x = a * x + b * u;
        }
        j
    };
    let j_opt = (x0.transpose() * pm * x0)[0];
    assert!((cost(&d.gain) - j_opt).abs() < 1e-6 * j_opt);
    for i in 0..4 {
        let mut kp = d.gain;
        kp[i] *= 1.05;
        assert!(cost(&kp) > j_opt, "perturbing K[{i}] lowered the cost");
    }
}

#[test]
fn discretization_matches_the_matrix_exponential() {
    let p = PlantParams::<f64>::preset();
    for plane in Plane::ALL {
        let m = PlanarModel::new(&p, plane);
        for dt in [0.001, 0.005, 0.2] {
            let (ad, bd) = lqr::discretize(&m.a, &m.b, dt).unwrap();
            // Independently: RK4 with 2000 steps of ẋ = A x (+ B) from e_i (from 0).
            let rk4 = |x0: SMatrix<f64, 4, 1>, u: f64| {
                let f = |x: &SMatrix<f64, 4, 1>| m.a * x + m.b * u;
                let h = dt / 2000.0;
                let mut x = x0;
                for _ in 0..2000 {
                    let k1 = f(&x);
                    let k2 = f(&(x + k1 * (h / 2.0)));
                    let k3 = f(&(x + k2 * (h / 2.0)));
                    let k4 = f(&(x + k3 * h));
                    x += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
                }
                x
            };
            let mut ea = Matrix4::zeros();
            for i in 0..4 {
                let mut e = SMatrix::<f64, 4, 1>::zeros();
                e[i] = 1.0;
                ea.set_column(i, &rk4(e, 0.0));
            }
            let eb = rk4(SMatrix::zeros(), 1.0);
            assert!(
                (ea - ad).amax() < 1e-10 * ea.amax(),
                "{plane:?} dt {dt}: A_d"
            );
            assert!(
                (eb - bd).amax() < 1e-10 * eb.amax(),
                "{plane:?} dt {dt}: B_d"
            );
        }
    }
}

#[test]
fn lqr_reports_precise_errors() {
    // An unstable mode the input cannot reach: no stabilising gain exists.
    let a = Matrix2::new(1.1, 0.0, 0.0, 0.5);
    let b = Vector2::new(0.0, 1.0);
    let q = Matrix2::identity();
    let r = Matrix1::new(1.0);
    let e = lqr::dare(&a, &b, &q, &r, 1e-12).unwrap_err();
    assert!(matches!(e, LqrError::Diverged { .. }), "{e:?}");
    eprintln!("unstabilisable: {e}");
    // A stable but uncontrolled mode is fine (the gain leaves it alone).
    let a_ok = Matrix2::new(0.9, 0.0, 0.0, 1.2);
    assert!(lqr::dare(&a_ok, &b, &q, &r, 1e-12).is_ok());
    assert_eq!(
        lqr::dare(&a_ok, &b, &q, &Matrix1::new(0.0), 1e-12).unwrap_err(),
        LqrError::BadWeight {
            what: "R",
            rule: "symmetric positive definite"
        }
    );
    assert!(matches!(
        lqr::dare(&a_ok, &b, &Matrix2::new(1.0, 0.5, 0.0, 1.0), &r, 1e-12),
        Err(LqrError::BadWeight { what: "Q", .. })
    ));
    assert!(matches!(
        lqr::dare(&Matrix2::new(f64::NAN, 0.0, 0.0, 1.0), &b, &q, &r, 1e-12),
        Err(LqrError::NonFinite { what: "A" })
    ));
    assert!(matches!(
        lqr::discretize(&a, &b, 0.0),
        Err(LqrError::BadPeriod { .. })
    ));
    // Marginal modes (poles at exactly 1) the input cannot reach: the cost grows with the
    // horizon forever (H doubles at every doubling step); the bounded iteration reports it
    // instead of looping.
    let e = lqr::dare(&Matrix2::identity(), &Vector2::zeros(), &q, &r, 1e-12).unwrap_err();
    assert!(
        matches!(
            e,
            LqrError::NotConverged {
                iterations: lqr::MAX_ITERATIONS,
                ..
            }
        ),
        "{e:?}"
    );
    eprintln!("marginal: {e}");
}

#[test]
fn configuration_errors_name_the_parameter() {
    let mut cfg = BalanceConfig::<f64>::preset();
    cfg.plant.body_mass = -1.0;
    assert!(matches!(
        BalanceController::new(cfg),
        Err(BalanceError::Parameter {
            field: "body_mass",
            ..
        })
    ));
    let mut cfg = BalanceConfig::<f64>::preset();
    cfg.fall_tilt = 2.0;
    assert!(matches!(
        BalanceController::new(cfg),
        Err(BalanceError::Parameter {
            field: "fall_tilt",
            ..
        })
    ));
    let mut cfg = BalanceConfig::<f64>::preset();
    cfg.plant.ball_radius = 0.2;
    assert!(matches!(
        BalanceController::new(cfg),
        Err(BalanceError::Parameter { .. })
    ));
    let mut cfg = BalanceConfig::<f64>::preset();
    cfg.weights.tilt = 0.0;
    assert!(matches!(
        BalanceController::new(cfg),
        Err(BalanceError::Parameter {
            field: "weights.tilt",
            ..
        })
    ));
    let mut cfg = BalanceConfig::<f64>::preset();
    cfg.geometry.zenith = 0.0;
    assert!(matches!(
        BalanceController::new(cfg),
        Err(BalanceError::Geometry(_))
    ));
}

#[test]
fn static_feed_forward_holds_the_commanded_acceleration_in_the_linear_model() {
    let p = PlantParams::<f64>::preset();
    let cfg = BalanceConfig::<f64>::preset();
    let r = p.ball_radius;
    // Commanded: 0.4 m/s² along x at 0.2 m/s; measured: exactly on the reference, leaning as
    // the feed-forward asks. The torque must then make φ̈ = a/R, θ̈ = 0 in the planar model.
    let m = PlanarModel::new(&p, Plane::Sagittal);
    let (acc, vel) = (0.4, 0.2);
    // Solve the linear model for the lean independently: rows 3–4 with φ̇ = v/R, θ̇ = 0.
    let f = Matrix2::new(m.a[(2, 1)], m.b[2], m.a[(3, 1)], m.b[3]);
    let rhs = Vector2::new(acc / r - m.a[(2, 2)] * vel / r, -m.a[(3, 2)] * vel / r);
    let sol = f.try_inverse().unwrap() * rhs;
    let mut c = BalanceController::new(cfg).unwrap();
    let meas = Measurement {
        tilt: [0.0, sol[0]],
        ball_velocity: [vel, 0.0],
        ..still()
    };
    let cmd = BalanceCommand {
        velocity: [vel, 0.0],
        acceleration: [acc, 0.0],
        ..BalanceCommand::hold()
    };
    let out = c.step(&meas, &cmd).unwrap();
    assert!(!out.saturated);
    let ty = out.model_torques[1];
    eprintln!(
        "feed-forward for 0.4 m/s²: lean {:.3}° (a/g = {:.3}°), Ty = {ty:.4} N·m",
        sol[0] / DEG,
        (acc / 9.81f64).atan() / DEG
    );
    assert!((ty - sol[1]).abs() < 1e-9, "{ty} vs {}", sol[1]);
    let phidd = m.a[(2, 1)] * sol[0] + m.a[(2, 2)] * vel / r + m.b[2] * ty;
    let thetadd = m.a[(3, 1)] * sol[0] + m.a[(3, 2)] * vel / r + m.b[3] * ty;
    assert!((phidd - acc / r).abs() < 1e-9 && thetadd.abs() < 1e-9);
    assert!(out.model_torques[0].abs() < 1e-12);
    // The lean is forward and near the quasi-static a/g (heavier than that: the ball's inertia).
    assert!(sol[0] > (acc / 9.81f64).atan() && sol[0] < 1.5 * (acc / 9.81f64).atan());
    // A previewed lean equal to the static one asks the same torque (its ball row).
    let mut c2 = BalanceController::new(cfg).unwrap();
    let with_lean = BalanceCommand {
        lean: Some(Lean {
            tilt: [sol[0], 0.0],
            rate: [0.0; 2],
            accel: [0.0; 2],
        }),
        ..cmd
    };
    let out2 = c2.step(&meas, &with_lean).unwrap();
    assert!((out2.model_torques[1] - ty).abs() < 1e-9 * ty.abs().max(1.0));
}

#[test]
fn saturation_keeps_the_torque_direction_and_a_fall_turns_the_motors_off() {
    let cfg = BalanceConfig::<f64>::preset();
    let mut c = BalanceController::new(cfg).unwrap();
    let robot = Ballbot::new(cfg.geometry).unwrap();
    let meas = Measurement {
        tilt: [6.0 * DEG, -9.0 * DEG],
        tilt_rate: [0.5, 0.3],
        ..still()
    };
    let out = c.step(&meas, &BalanceCommand::hold()).unwrap();
    assert!(out.saturated && out.scale < 1.0 && out.scale > 0.0);
    let peak = out.wheel_torques.iter().fold(0.0f64, |a, t| a.max(t.abs()));
    assert!((peak - cfg.torque_limit).abs() < 1e-12);
    let unscaled = robot.wheel_torques(out.requested, 0.0).unwrap();
    for i in 0..3 {
        assert!((out.wheel_torques[i] - out.scale * unscaled[i]).abs() < 1e-12);
        assert!((out.model_torques[i] - out.scale * out.requested[i]).abs() < 1e-12);
    }
    // The applied wheel torques map back to the applied model torques (E2 round trip).
    let back = robot.model_torques(out.wheel_torques, 0.0).unwrap();
    for i in 0..3 {
        assert!((back[i] - out.model_torques[i]).abs() < 1e-12);
    }
    assert_eq!(out.status, BalanceState::Balancing);

    // Past the 20° threshold: fallen, motors off, latched.
    let over = Measurement {
        tilt: [15.0 * DEG, 15.0 * DEG], // ≈ 21°
        ..still()
    };
    let out = c.step(&over, &BalanceCommand::hold()).unwrap();
    assert!(
        out.tilt > 20.0 * DEG && out.tilt < 22.0 * DEG,
        "{}",
        out.tilt / DEG
    );
    assert_eq!(out.status, BalanceState::Fallen);
    assert_eq!(out.wheel_torques, [0.0; 3]);
    let out = c.step(&still(), &BalanceCommand::hold()).unwrap();
    assert_eq!(out.status, BalanceState::Fallen, "the fall must latch");
    assert_eq!(out.wheel_torques, [0.0; 3]);
    c.reset();
    assert_eq!(
        c.step(&still(), &BalanceCommand::hold()).unwrap().status,
        BalanceState::Balancing
    );
    // Just below the threshold it still balances.
    let mut c = BalanceController::new(cfg).unwrap();
    let under = Measurement {
        tilt: [19.9 * DEG, 0.0],
        ..still()
    };
    assert_eq!(
        c.step(&under, &BalanceCommand::hold()).unwrap().status,
        BalanceState::Balancing
    );
}

#[test]
fn bad_input_is_an_error_and_leaves_the_state_alone() {
    let mut c = controller();
    c.step(&still(), &BalanceCommand::hold()).unwrap();
    let before = c;
    let bad = Measurement {
        ball_velocity: [0.0, f64::NAN],
        ..still()
    };
    assert_eq!(
        c.step(&bad, &BalanceCommand::hold()).unwrap_err(),
        InputError::NonFinite {
            field: "ball_velocity[1]"
        }
    );
    let bad_cmd = BalanceCommand {
        yaw_rate: f64::INFINITY,
        ..BalanceCommand::hold()
    };
    assert!(c.step(&still(), &bad_cmd).is_err());
    assert_eq!(c, before);
}

#[test]
fn measurement_from_attitude_gives_heading_frame_tilts() {
    // Yaw 1 rad, then a tilt of 4° about the heading frame's x axis.
    let yaw = 1.0;
    let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 4.0 * DEG);
    // Body rotating about the heading x axis at 0.3 rad/s, expressed in the body frame.
    let w_world =
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw) * Vector3::new(0.3, 0.0, 0.1);
    let gyro = q.inverse() * w_world;
    let m = Measurement::from_attitude(&q, gyro.into(), [1.0, 2.0], [0.1, 0.0]);
    assert!((m.yaw - yaw).abs() < 1e-12);
    assert!((m.tilt[0] - 4.0 * DEG).abs() < 1e-12 && m.tilt[1].abs() < 1e-12);
    assert!((m.tilt_rate[0] - 0.3).abs() < 1e-12 && m.tilt_rate[1].abs() < 1e-12);
    assert!((m.yaw_rate - 0.1).abs() < 1e-12);
    assert!((m.tilt_angle() - 4.0 * DEG).abs() < 1e-12);
}

/// A deterministic wobbling measurement sequence (no simulator in the core's tests).
fn wobble(k: usize) -> Measurement<f64> {
    let t = k as f64 * 0.005;
    Measurement {
        tilt: [2.0 * DEG * (3.0 * t).sin(), -1.5 * DEG * (2.0 * t).cos()],
        tilt_rate: [0.1 * (3.0 * t).cos(), 0.05 * (2.0 * t).sin()],
        yaw: 0.3 * t,
        yaw_rate: 0.3,
        ball_position: [0.1 * t, 0.05 * t.sin()],
        ball_velocity: [0.1, 0.05 * t.cos()],
    }
}

#[test]
fn f32_and_f64_controllers_agree() {
    let mut c64 = controller();
    let mut c32 = BalanceController::<f32>::new(BalanceConfig::preset()).unwrap();
    let mut worst = 0.0f64;
    let mut worst_abs = 0.0f64;
    for k in 0..600 {
        let m = wobble(k);
        let cmd = BalanceCommand {
            velocity: [0.1, 0.0],
            acceleration: [0.0, 0.02],
            yaw_rate: 0.3,
            lean: None,
        };
        let m32 = Measurement {
            tilt: m.tilt.map(|v| v as f32),
            tilt_rate: m.tilt_rate.map(|v| v as f32),
            yaw: m.yaw as f32,
            yaw_rate: m.yaw_rate as f32,
            ball_position: m.ball_position.map(|v| v as f32),
            ball_velocity: m.ball_velocity.map(|v| v as f32),
        };
        let cmd32 = BalanceCommand {
            velocity: [0.1f32, 0.0],
            acceleration: [0.0, 0.02],
            yaw_rate: 0.3,
            lean: None,
        };
        let a = c64.step(&m, &cmd).unwrap();
        let b = c32.step(&m32, &cmd32).unwrap();
        assert_eq!(a.saturated, b.saturated);
        for i in 0..3 {
            let d = (a.wheel_torques[i] - b.wheel_torques[i] as f64).abs();
            worst = worst.max(d / a.wheel_torques[i].abs().max(0.1));
            worst_abs = worst_abs.max(d);
        }
    }
    eprintln!(
        "f32 vs f64 over 3 s: worst wheel-torque difference {worst_abs:.2e} N·m ({worst:.2e} relative)"
    );
    // f32 rounding of the measurements (≈ 6e-8 relative) through the gains (K ≈ 90 N·m/rad)
    // and of the integrated reference position: well under 1 mN·m (0.05 % of the limit).
    assert!(worst_abs < 1e-3, "{worst_abs}");
    // Both designs run in f64; they differ only by the f32 rounding of the parameters.
    for (d64, d32) in c64.designs().iter().zip(c32.designs()) {
        let rel = (d64.gain - d32.gain).amax() / d64.gain.amax();
        assert!(rel < 1e-6, "{:?}: gains differ by {rel}", d64.plane);
    }
}
