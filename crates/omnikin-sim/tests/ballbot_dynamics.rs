//! The ballbot's 3D dynamics and the balance controller in closed loop (issue 15): the planar
//! models against a numerical Jacobian, energy, settling from a tilt, a square, pushes, power.

use omnikin::Robot;
use omnikin::control::ball_velocity_from_wheels;
use omnikin::control::{BalanceCommand, BalanceConfig, BalanceController, BalanceState, Plane};
use omnikin::nalgebra::{UnitQuaternion, Vector3};
use omnikin_plan::RobotModel;
use omnikin_plan::generators::Square;
use omnikin_plan::planner::{OnLimit, plan};
use omnikin_plan::profile::ProfileKind;
use omnikin_sim::dynamics::ballbot::closed_loop::{CycleRecord, Push, RunOptions, run, run_with};
use omnikin_sim::dynamics::ballbot::preview::lean_preview;
use omnikin_sim::dynamics::ballbot::{BallbotDynamics, BallbotPlant, BallbotState};

const DEG: f64 = std::f64::consts::PI / 180.0;
/// Plant RK4 steps per 200 Hz control cycle (1 kHz).
const SUBSTEPS: usize = 5;

fn plant() -> BallbotPlant {
    BallbotPlant::new(BallbotDynamics::preset()).unwrap()
}

fn controller() -> BalanceController<f64> {
    BalanceController::new(BalanceConfig::preset()).unwrap()
}

/// The plane's axis, its index in (x, y, z) and the model-torque vector for input `u`.
fn axis(plane: Plane) -> (Vector3<f64>, usize) {
    match plane {
        Plane::Lateral => (Vector3::x(), 0),
        Plane::Sagittal => (Vector3::y(), 1),
        Plane::Yaw => (Vector3::z(), 2),
    }
}

/// `(Ω̇, ω̇)` of the 3D model at a state near upright: tilt `theta` about the plane's axis,
/// ball rate `phid` and body rate `thetad` about it, model torque `u` about it.
fn accel_at(
    p: &BallbotPlant,
    plane: Plane,
    theta: f64,
    phid: f64,
    thetad: f64,
    u: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let (ax, i) = axis(plane);
    let mut s = p.upright(0.0);
    s.orientation = UnitQuaternion::from_scaled_axis(ax * theta);
    s.ball_rate = ax * phid;
    s.body_rate = ax * thetad;
    let mut g = [0.0; 3];
    g[i] = u;
    let t = p.robot().wheel_torques(g, 0.0).unwrap();
    p.accelerations(&s, t, Vector3::zeros())
}

#[test]
fn planar_models_match_a_numerical_jacobian_of_the_3d_model_at_upright() {
    let p = plant();
    let models = p.planar_models();
    let h = 1e-6;
    for (plane, m) in Plane::ALL.into_iter().zip(models) {
        let (_, i) = axis(plane);
        // Columns: θ, φ̇, θ̇, u (φ, the ball's rotation angle, does not enter the dynamics:
        // the model has no position dependence, so its column must be 0).
        let mut num = [[0.0; 4]; 2];
        let mut coupling = 0.0f64;
        for c in 0..4 {
            let mut d = [0.0; 4];
            d[c] = h;
            let (op, wp) = accel_at(&p, plane, d[0], d[1], d[2], d[3]);
            let (om, wm) = accel_at(&p, plane, -d[0], -d[1], -d[2], -d[3]);
            let dom = (op - om) / (2.0 * h);
            let dw = (wp - wm) / (2.0 * h);
            num[0][c] = dom[i];
            num[1][c] = dw[i];
            for j in (0..3).filter(|&j| j != i) {
                coupling = coupling.max(dom[j].abs()).max(dw[j].abs());
            }
        }
        let mut err = 0.0f64;
        let mut scale = 0.0f64;
        for r in 0..2 {
            assert_eq!(m.a[(2 + r, 0)], 0.0, "{plane:?}: ball angle enters");
            let closed = [
                m.a[(2 + r, 1)],
                m.a[(2 + r, 2)],
                m.a[(2 + r, 3)],
                m.b[2 + r],
            ];
            for c in 0..4 {
                err = err.max((closed[c] - num[r][c]).abs());
                scale = scale.max(closed[c].abs());
            }
        }
        let rel = err / scale;
        eprintln!(
            "{plane:?}: Jacobian max |closed − numeric| = {err:.3e} ({rel:.2e} relative), cross-plane coupling {coupling:.2e}"
        );
        assert!(rel < 1e-6, "{plane:?}: relative error {rel}");
        assert!(
            coupling < 1e-6 * scale,
            "{plane:?}: couples to another plane ({coupling})"
        );
    }
    // The vertical planes really are unstable pendulums (the gravity entry is positive).
    assert!(models[1].a[(3, 1)] > 10.0);
}

/// A general state: tilted about an oblique axis, every rate non-zero.
fn tumbling(p: &BallbotPlant) -> BallbotState {
    let mut s = p.upright(0.3);
    s.orientation =
        UnitQuaternion::from_scaled_axis(Vector3::new(1.0, 0.5, 0.0).normalize() * (10.0 * DEG))
            * s.orientation;
    s.ball_rate = Vector3::new(0.3, 0.4, 1.0);
    s.body_rate = Vector3::new(0.2, -0.1, 0.5);
    s
}

#[test]
fn energy_is_conserved_without_friction_and_control_and_decays_with_friction() {
    let free = BallbotPlant::new(BallbotDynamics::preset().frictionless()).unwrap();
    let mut s = tumbling(&free);
    let e0 = free.energy(&s);
    let scale = free.params().body_mass * free.params().gravity * free.params().com_height;
    let dt = 1e-3;
    let mut drift = 0.0f64;
    let mut steps = 0;
    // Until the body has fallen to 60° (the model has no floor contact for the body).
    while free.tilt(&s) < 60.0 * DEG && steps < 5000 {
        free.step(&mut s, [0.0; 3], Vector3::zeros(), dt);
        drift = drift.max((free.energy(&s) - e0).abs());
        steps += 1;
    }
    eprintln!(
        "energy: {steps} steps of 1 ms to {:.1}° tilt, max |E − E0| = {drift:.3e} J ({:.2e} of m_B g l)",
        free.tilt(&s) / DEG,
        drift / scale
    );
    assert!(free.tilt(&s) >= 60.0 * DEG, "the upright body must fall");
    assert!(drift / scale < 1e-7, "energy drift {drift} J");
    // With friction, energy only decreases.
    let damped = plant();
    let mut s = tumbling(&damped);
    let mut e = damped.energy(&s);
    for _ in 0..300 {
        damped.step(&mut s, [0.0; 3], Vector3::zeros(), dt);
        let e1 = damped.energy(&s);
        assert!(e1 <= e + 1e-9, "friction created energy: {e} → {e1}");
        e = e1;
    }
    assert!(e < damped.energy(&tumbling(&damped)) - 1e-6);
}

/// Runs the preset closed loop from `s0`, returning the records.
fn closed_loop(
    s0: BallbotState,
    seconds: f64,
    pushes: &[Push],
    command: impl FnMut(f64) -> BalanceCommand<f64>,
) -> (Vec<CycleRecord>, BallbotState) {
    let p = plant();
    let mut c = controller();
    let mut log = Vec::new();
    let cycles = (seconds * 200.0).round() as usize;
    let opts = RunOptions {
        cycles,
        substeps: SUBSTEPS,
        pushes,
    };
    let end = run(&p, &mut c, s0, &opts, command, |r| log.push(*r)).unwrap();
    (log, end)
}

fn tilted(deg: f64, axis: Vector3<f64>) -> BallbotState {
    let mut s = plant().upright(0.0);
    s.orientation = UnitQuaternion::from_scaled_axis(axis.normalize() * (deg * DEG));
    s
}

#[test]
fn closed_loop_is_upright_within_3_s_from_5_degrees() {
    let p = plant();
    for ax in [Vector3::x(), Vector3::y(), Vector3::new(1.0, -2.0, 0.0)] {
        let (log, end) = closed_loop(tilted(5.0, ax), 6.0, &[], |_| BalanceCommand::hold());
        let settle = log
            .iter()
            .rev()
            .find(|r| p.tilt(&r.state) >= 0.5 * DEG)
            .map_or(0.0, |r| r.t + 0.005);
        let max_torque = log
            .iter()
            .flat_map(|r| r.output.wheel_torques)
            .fold(0.0f64, |a, t| a.max(t.abs()));
        let saturated = log.iter().filter(|r| r.output.saturated).count();
        let drift = (end.position[0].powi(2) + end.position[1].powi(2)).sqrt();
        eprintln!(
            "5° about {ax:?}: below 0.5° from {settle:.3} s on, final tilt {:.4}°, peak wheel torque {max_torque:.3} N·m ({saturated} saturated cycles), ball {drift:.3} m from start at 6 s",
            p.tilt(&end) / DEG
        );
        assert!(settle <= 3.0, "settles at {settle} s");
        assert!(
            log.iter()
                .all(|r| r.output.status == BalanceState::Balancing)
        );
        assert!(p.tilt(&end) < 0.1 * DEG);
    }
}

/// Rest before a plan starts, s: with a previewed lean the body starts leaning ≈ 1/z before
/// the plan accelerates, so the closed loop gets this lead-in.
const LEAD_IN: f64 = 1.0;

/// A plan's commands, the plan starting at [`LEAD_IN`]: the sample's world velocity, the
/// acceleration to the next sample and, with `preview`, the previewed lean.
fn plan_commands(
    plan: &omnikin_plan::Plan,
    preview: bool,
) -> impl FnMut(f64) -> BalanceCommand<f64> + '_ {
    let s = &plan.samples;
    let dt = s[1].t - s[0].t;
    let lead = (LEAD_IN / dt).round() as usize;
    // Rest for the lead-in, then the plan's samples.
    let vel: Vec<[f64; 2]> = std::iter::repeat_n([0.0; 2], lead)
        .chain(s.iter().map(|x| [x.twist.vx, x.twist.vy]))
        .collect();
    let n = vel.len();
    let acc: Vec<[f64; 2]> = (0..n)
        .map(|k| {
            let next = vel[(k + 1).min(n - 1)];
            [(next[0] - vel[k][0]) / dt, (next[1] - vel[k][1]) / dt]
        })
        .collect();
    let lean = lean_preview(&BallbotDynamics::preset().plant_params(), dt, &vel, &acc);
    move |t| {
        let k = (t / dt).round() as usize;
        if k >= n {
            return BalanceCommand::hold();
        }
        BalanceCommand {
            velocity: vel[k],
            acceleration: acc[k],
            yaw_rate: k.checked_sub(lead).map_or(0.0, |i| s[i].twist.yaw_rate),
            lean: preview.then_some(lean[k]),
        }
    }
}

/// The plan's position at closed-loop time `t` (the start during the lead-in, the end after).
fn plan_position(plan: &omnikin_plan::Plan, t: f64) -> [f64; 2] {
    let s = &plan.samples;
    let dt = s[1].t - s[0].t;
    let k = ((t - LEAD_IN) / dt).round().max(0.0) as usize;
    let q = s[k.min(s.len() - 1)].pose;
    [q.x, q.y]
}

fn square_plan() -> omnikin_plan::Plan {
    let robot = RobotModel::from_description(
        &omnikin::description::RobotDescription::preset("ballbot").unwrap(),
    )
    .unwrap();
    let sq = Square {
        side: 0.4,
        speed: 0.2,
        ramp_fraction: 0.25,
        profile: ProfileKind::Trapezoid,
    };
    plan(
        &sq.path().unwrap(),
        &sq.heading(),
        &robot,
        &sq.options(200.0, OnLimit::Reject),
    )
    .unwrap()
    .plan
}

/// Max tracking error (m), max tilt (rad), saturated cycles and the log of the square.
fn square_run(preview: bool) -> (f64, f64, usize, Vec<CycleRecord>) {
    let p = plant();
    let plan = square_plan();
    let duration = plan.duration();
    let (log, _) = closed_loop(
        p.upright(0.0),
        LEAD_IN + duration + 2.0,
        &[],
        plan_commands(&plan, preview),
    );
    let mut max_err = 0.0f64;
    let mut max_tilt = 0.0f64;
    for r in &log {
        let q = plan_position(&plan, r.t);
        let e =
            ((r.state.position[0] - q[0]).powi(2) + (r.state.position[1] - q[1]).powi(2)).sqrt();
        max_err = max_err.max(e);
        max_tilt = max_tilt.max(p.tilt(&r.state));
    }
    let saturated = log.iter().filter(|r| r.output.saturated).count();
    (max_err, max_tilt, saturated, log)
}

#[test]
fn closed_loop_follows_the_square_within_5_cm_and_8_degrees() {
    let (static_err, static_tilt, static_sat, _) = square_run(false);
    eprintln!(
        "square without preview (static feed-forward lean): max tracking error {:.2} cm, max tilt {:.2}°, {static_sat} saturated cycles",
        static_err * 100.0,
        static_tilt / DEG
    );
    let (max_err, max_tilt, saturated, log) = square_run(true);
    let duration = square_plan().duration();
    let end = log.last().unwrap().state;
    let end_err = (end.position[0].powi(2) + end.position[1].powi(2)).sqrt();
    eprintln!(
        "square with previewed lean, 0.4 m at 0.2 m/s (ramps 0.25): {duration:.2} s, max tracking error {:.2} cm, max tilt {:.2}°, end {:.2} cm from the start, {saturated} saturated cycles",
        max_err * 100.0,
        max_tilt / DEG,
        end_err * 100.0
    );
    assert!(max_err < 0.05, "tracking error {max_err} m");
    assert!(max_tilt < 8.0 * DEG, "tilt {} deg", max_tilt / DEG);
    assert!(
        log.iter()
            .all(|r| r.output.status == BalanceState::Balancing)
    );
    // The path was actually driven (not a robot standing at the origin).
    let far = log
        .iter()
        .map(|r| r.state.position[0].min(r.state.position[1]))
        .fold(f64::MIN, f64::max);
    assert!(far > 0.35, "never reached the far corner ({far} m)");
}

/// Pushes along x at 0.5 s: survived (upright again, never fallen) or fallen (detected,
/// motors off).
fn push(impulse: f64) -> (Vec<CycleRecord>, BallbotState) {
    let p = plant();
    let pushes = [Push {
        time: 0.5,
        impulse: [impulse, 0.0],
    }];
    closed_loop(p.upright(0.0), 6.0, &pushes, |_| BalanceCommand::hold())
}

/// Survived: 12 N·s on the body's centre of mass (≈ 0.7 m/s of the 17.6 kg robot's centre of
/// mass), leaning ≈ 10°. The preset's limit lies between 16 and 18 N·s.
const SURVIVED_PUSH: f64 = 12.0;
/// Fatal: 20 N·s — the fall is detected at the 20° threshold and the motors go off.
const FATAL_PUSH: f64 = 20.0;

#[test]
fn survives_a_push_and_falls_with_motors_off_beyond_a_larger_one() {
    let p = plant();
    let (log, end) = push(SURVIVED_PUSH);
    let max_tilt = log.iter().map(|r| p.tilt(&r.state)).fold(0.0, f64::max);
    let saturated = log.iter().filter(|r| r.output.saturated).count();
    eprintln!(
        "push {SURVIVED_PUSH} N·s: max tilt {:.2}°, final tilt {:.3}°, {saturated} saturated cycles",
        max_tilt / DEG,
        p.tilt(&end) / DEG
    );
    assert!(
        log.iter()
            .all(|r| r.output.status == BalanceState::Balancing)
    );
    assert!(p.tilt(&end) < 0.5 * DEG);
    assert!(
        saturated > 0,
        "a push this size should reach the torque limit"
    );

    let (log, _) = push(FATAL_PUSH);
    let fall = log
        .iter()
        .position(|r| r.output.status == BalanceState::Fallen)
        .expect("a push this size must make it fall");
    eprintln!(
        "push {FATAL_PUSH} N·s: fall detected at {:.3} s at {:.1}°",
        log[fall].t,
        log[fall].output.tilt / DEG
    );
    assert!(log[fall].output.tilt > 20.0 * DEG);
    for r in &log[fall..] {
        assert_eq!(r.output.status, BalanceState::Fallen);
        assert_eq!(r.output.wheel_torques, [0.0; 3], "motors must be off");
    }
}

#[test]
fn wheel_torque_power_equals_model_torque_power_in_the_closed_loop() {
    let p = plant();
    let robot = Robot::Ballbot(*p.robot());
    let plan = square_plan();
    let (log, _) = closed_loop(
        tilted(3.0, Vector3::x()),
        LEAD_IN + 4.0,
        &[],
        plan_commands(&plan, true),
    );
    let mut worst = 0.0f64;
    let mut peak = 0.0f64;
    let none = [0.0; omnikin::MAX_WHEELS];
    for r in &log {
        let t = r.output.wheel_torques;
        let w = r.wheel_rates;
        let p_wheels: f64 = (0..3).map(|i| t[i] * w[i]).sum();
        let mut tp = none;
        tp[..3].copy_from_slice(&t);
        let g = robot.generalized_forces(&tp, &none).unwrap().unwrap();
        let v = p.robot().model_rates(w, 0.0).unwrap();
        let p_model: f64 = (0..3).map(|i| g[i] * v[i]).sum();
        let p_mech = p.wheel_power(&r.state, t);
        // The applied model torques are the generalized forces of the applied wheel torques.
        for i in 0..3 {
            assert!((g[i] - r.output.model_torques[i]).abs() < 1e-9);
        }
        worst = worst
            .max((p_wheels - p_model).abs())
            .max((p_wheels - p_mech).abs());
        peak = peak.max(p_wheels.abs());
    }
    eprintln!("power: peak |T·ψ̇| {peak:.3} W, worst mismatch {worst:.2e} W");
    assert!(peak > 0.1);
    assert!(worst < 1e-9 * peak.max(1.0));
}

/// Balancing on odometry: the ball's position is dead-reckoned at the control rate from the
/// wheel rates and the gyro ([`ball_velocity_from_wheels`]), as on the robot. Without the
/// gyro correction the estimate is off by `R θ` (the lean read as rolling).
#[test]
fn balances_on_wheel_odometry_corrected_for_the_lean() {
    let p = plant();
    let dt = 0.005;
    let mut drift = [0.0f64; 2];
    for (k, corrected) in [true, false].into_iter().enumerate() {
        let mut c = controller();
        let mut est = [0.0f64; 2];
        let mut worst = 0.0f64;
        let opts = RunOptions {
            cycles: 1200,
            substeps: SUBSTEPS,
            pushes: &[],
        };
        let mut measure = |_t: f64, s: &BallbotState| {
            let mut m = p.measurement(s);
            let gyro = s.orientation.inverse() * s.body_rate;
            let g = if corrected { gyro.into() } else { [0.0; 3] };
            let v = ball_velocity_from_wheels(p.robot(), p.wheel_rates(s), &s.orientation, g)?;
            worst = worst.max((est[0] - s.position[0]).hypot(est[1] - s.position[1]));
            m.ball_position = est;
            m.ball_velocity = v;
            est = [est[0] + v[0] * dt, est[1] + v[1] * dt];
            Ok(m)
        };
        let end = run_with(
            &p,
            &mut c,
            tilted(5.0, Vector3::new(1.0, 1.0, 0.0)),
            &opts,
            &mut measure,
            |_| BalanceCommand::hold(),
            |_| {},
        )
        .unwrap();
        drift[k] = worst;
        eprintln!(
            "odometry {}: worst position estimate error {:.2} mm, final tilt {:.4}°",
            if corrected {
                "with the gyro correction"
            } else {
                "without it"
            },
            worst * 1000.0,
            p.tilt(&end) / DEG
        );
        assert!(p.tilt(&end) < 0.5 * DEG);
    }
    // Dead reckoning at 200 Hz: within 2 mm with the correction; the uncorrected one is off by
    // about R·5° ≈ 1 cm.
    assert!(drift[0] < 0.002, "{}", drift[0]);
    assert!(drift[1] > 0.005, "{}", drift[1]);
}

/// With sensor noise (white, per cycle: tilt 0.05°, gyro 0.005 rad/s, ball position 1 mm,
/// ball velocity 5 mm/s; seeded), the loop still settles from 5° and stays upright.
#[test]
fn balances_with_sensor_noise() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let p = plant();
    let mut c = controller();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(15);
    let mut n = move || -> f64 { StandardNormal.sample(&mut rng) };
    let opts = RunOptions {
        cycles: 1200,
        substeps: SUBSTEPS,
        pushes: &[],
    };
    let mut late_max = 0.0f64;
    let end = run_with(
        &p,
        &mut c,
        tilted(5.0, Vector3::y()),
        &opts,
        |t, s| {
            let mut m = p.measurement(s);
            for i in 0..2 {
                m.tilt[i] += 0.05 * DEG * n();
                m.tilt_rate[i] += 0.005 * n();
                m.ball_position[i] += 0.001 * n();
                m.ball_velocity[i] += 0.005 * n();
            }
            m.yaw_rate += 0.005 * n();
            if t >= 3.0 {
                late_max = late_max.max(p.tilt(s));
            }
            Ok(m)
        },
        |_| BalanceCommand::hold(),
        |r| assert_eq!(r.output.status, BalanceState::Balancing),
    )
    .unwrap();
    eprintln!(
        "with sensor noise: max tilt after 3 s {:.3}°, ball {:.2} cm from the start at 6 s",
        late_max / DEG,
        end.position[0].hypot(end.position[1]) * 100.0
    );
    assert!(late_max < 0.5 * DEG, "{}", late_max / DEG);
}

/// The robot file's `[dynamics]` gives the preset's model.
#[test]
fn the_robot_file_gives_the_preset_dynamics() {
    let d = omnikin::description::RobotDescription::preset("ballbot").unwrap();
    let m = BallbotDynamics::from_config(&d.balance_config().unwrap());
    let p = BallbotDynamics::preset();
    m.validate().unwrap();
    assert_eq!(m.geometry, p.geometry);
    for (a, b) in [
        (m.ball_inertia, p.ball_inertia),
        (m.body_mass, p.body_mass),
        (m.com_height, p.com_height),
        (m.torque_limit, p.torque_limit),
        (m.body_inertia[1], p.body_inertia[1]),
    ] {
        assert!((a - b).abs() < 1e-12 * b, "{a} vs {b}");
    }
}
