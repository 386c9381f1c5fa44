//! The plant against known answers: the ideal plant reproduces a plan; paper 003 §4's slip
//! formulas predict the simulated deviations; Monte Carlo is deterministic and its band
//! shrinks like 1/√N.

use omnikin::caster::{Caster3, CasterParams, slip};
use omnikin::description::RobotDescription;
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Robot, Twist2};
use omnikin_plan::{Plan, Sample};
use omnikin_sim::metrics::{Run, evaluate, mean_trajectory};
use omnikin_sim::{Profile, run_trials, simulate_trial, trial_rng};

fn sphere() -> Robot<f64> {
    Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap())
}

/// A sphere plan from an analytic motion: pose(t) and world twist(t), wheel rates from the core.
fn sphere_plan(
    duration: f64,
    rate: f64,
    motion: impl Fn(f64) -> (Pose2<f64>, Twist2<f64>),
) -> Plan {
    let m = SphereOmni::new(SphereParams::preset()).unwrap();
    let n = (duration * rate).round() as usize;
    Plan {
        wheels: 3,
        samples: (0..=n)
            .map(|k| {
                let t = k as f64 / rate;
                let (pose, twist) = motion(t);
                Sample {
                    t,
                    pose,
                    twist,
                    wheel_rates: omnikin_plan::per_wheel(
                        &m.wheel_rates_world(twist, pose.heading, 0.0).unwrap(),
                    ),
                    steer: None,
                }
            })
            .collect(),
    }
}

/// Paper 000, eq. 6.3: x = Rt cos ω0 t, y = Rt sin ω0 t, ψ = ω0 t.
fn paper_circle(rt: f64, w0: f64, rate: f64) -> Plan {
    let period = core::f64::consts::TAU / w0;
    sphere_plan(period, rate, |t| {
        let (s, c) = (w0 * t).sin_cos();
        (
            Pose2::new(rt * c, rt * s, w0 * t),
            Twist2::new(-rt * w0 * s, rt * w0 * c, w0),
        )
    })
}

#[test]
fn ideal_plant_reproduces_a_circle_exactly() {
    let plan = paper_circle(0.2, 0.5, 100.0);
    let trial =
        simulate_trial(&sphere(), &plan, &Profile::default(), &mut trial_rng(1, 0)).unwrap();
    let mut worst = 0.0f64;
    for (p, s) in trial.pose.iter().zip(&plan.samples) {
        worst = worst
            .max((p.x - s.pose.x).hypot(p.y - s.pose.y))
            .max((p.heading - s.pose.heading).abs());
    }
    // Constant body twist: the exact SE(2) steps are exact up to rounding (12 566 steps).
    assert!(worst < 1e-10, "worst error {worst:e}");
}

#[test]
fn ideal_plant_reproduces_a_varying_motion_to_integration_precision() {
    // Speed and yaw rate vary smoothly: v(t) = 0.1(1 − cos t), ψ̇ = 0.3 sin t; moving along the
    // platform's x axis. The pose is integrated here finely as the reference.
    let v = |t: f64| 0.1 * (1.0 - t.cos());
    let w = |t: f64| 0.3 * t.sin();
    let reference = {
        let mut out = Vec::new();
        let mut pose = Pose2::new(0.0, 0.0, 0.0);
        let fine = 600_000;
        let dt = 6.0 / fine as f64;
        for k in 0..=fine {
            let t = k as f64 * dt;
            if k % 1000 == 0 {
                out.push(pose);
            }
            let tm = t + 0.5 * dt;
            pose = omnikin::se2::integrate(pose, Twist2::new(v(tm), 0.0, w(tm)), dt);
        }
        out
    };
    let plan = sphere_plan(6.0, 100.0, |t| {
        let k = (t * 100.0).round() as usize;
        let p = reference[k];
        (p, Twist2::new(v(t), 0.0, w(t)).to_world(p.heading))
    });
    let trial =
        simulate_trial(&sphere(), &plan, &Profile::default(), &mut trial_rng(1, 0)).unwrap();
    let worst = trial
        .pose
        .iter()
        .zip(&plan.samples)
        .map(|(p, s)| (p.x - s.pose.x).hypot(p.y - s.pose.y))
        .fold(0.0, f64::max);
    // Linear set-point hold between 100 Hz samples: second-order error, ~1e-6 m here.
    assert!(worst < 1e-5, "worst error {worst:e}");
    assert!(trial.slip_residual.iter().all(|&s| s == 0.0));
}

/// A caster plan with all three wheels parallel (β_i = β0) and constant steer rate Ρ and roll
/// rate Ξ: every wheel implies the same translation (paper 003, eq. 11), so the rates are
/// consistent and the body translates along the single-wheel curve.
fn caster_single_wheel_plan(
    beta0: f64,
    steer_rate: f64,
    roll_rate: f64,
    duration: f64,
    rate: f64,
) -> (Plan, Caster3<f64>) {
    let m = Caster3::<f64>::new(CasterParams::preset()).unwrap();
    let p = *m.params();
    let gamma0: [f64; 3] = core::array::from_fn(|i| beta0 - p.mount_angles[i]);
    let n = (duration * rate).round() as usize;
    let samples = (0..=n)
        .map(|k| {
            let t = k as f64 / rate;
            let beta = beta0 + steer_rate * t;
            let (s, c) = beta.sin_cos();
            Sample {
                t,
                pose: Pose2::new(0.0, 0.0, 0.0), // not used by the plant beyond the first sample
                twist: Twist2::new(
                    -p.wheel_radius * roll_rate * c + p.eccentricity * steer_rate * s,
                    -p.wheel_radius * roll_rate * s - p.eccentricity * steer_rate * c,
                    0.0,
                ),
                wheel_rates: omnikin_plan::per_wheel(&[roll_rate; 3]),
                steer: Some((
                    omnikin_plan::per_wheel(&core::array::from_fn::<_, 3, _>(|i| {
                        gamma0[i] + steer_rate * t
                    })),
                    omnikin_plan::per_wheel(&[steer_rate; 3]),
                )),
            }
        })
        .collect();
    (Plan { wheels: 3, samples }, m)
}

#[test]
fn consistent_caster_motion_has_no_slip_and_follows_eq_12_13() {
    let (plan, m) = caster_single_wheel_plan(0.3, 1.5, 4.0, 2.0, 100.0);
    let trial = simulate_trial(
        &Robot::Caster(m),
        &plan,
        &Profile::default(),
        &mut trial_rng(0, 0),
    )
    .unwrap();
    assert!(
        trial.slip_residual.iter().all(|&s| s < 1e-12),
        "{:?}",
        trial.slip_residual.iter().cloned().fold(0.0, f64::max)
    );
    let exact = slip::single_wheel_step(&slip::WheelStep {
        wheel_radius: 0.05,
        eccentricity: 0.04,
        beta0: 0.3,
        steer_rate: 1.5,
        roll_rate: 4.0,
        period: 2.0,
    })
    .unwrap();
    let end = trial.pose.last().unwrap();
    // The plant holds each step's twist (mid-step steer angles): second order in the 1 ms step.
    assert!(
        (end.x - exact.displacement.dx).abs() < 1e-7
            && (end.y - exact.displacement.dy).abs() < 1e-7,
        "{end:?} vs {exact:?}"
    );
    assert!(end.heading.abs() < 1e-12);
}

/// Paper 003 §4.1 (eqs. 14–16): with both motors of every wheel running `(1 + b)` times too
/// fast, the simulated deviation after a period T equals the paper's formula (exactly for the
/// un-linearised form, since the ratio Ξ/Ρ is unchanged; to O((ΔΡT)²) for eqs. 15–16).
#[test]
fn speed_fluctuation_matches_paper_003_section_4_1() {
    let (beta0, rho, xi, period, b) = (0.3, 1.5, 4.0, 0.2, 0.02);
    let (plan, m) = caster_single_wheel_plan(beta0, rho, xi, period, 1000.0);
    let ideal = simulate_trial(
        &Robot::Caster(m),
        &plan,
        &Profile::default(),
        &mut trial_rng(0, 0),
    )
    .unwrap();
    let biased_profile = Profile::from_toml_str(
        &format!("[wheel_motor]\nrate_bias_rel = {b}\n[steer_motor]\nrate_bias_rel = {b}\n"),
        "test",
    )
    .unwrap();
    let biased = simulate_trial(
        &Robot::Caster(m),
        &plan,
        &biased_profile,
        &mut trial_rng(0, 0),
    )
    .unwrap();
    let (e, i) = (biased.pose.last().unwrap(), ideal.pose.last().unwrap());
    let (dx, dy) = (e.x - i.x, e.y - i.y);
    let f = slip::SpeedFluctuation {
        wheel_radius: 0.05,
        eccentricity: 0.04,
        beta1: beta0 + rho * period,
        steer_rate: rho,
        roll_rate: xi,
        steer_rate_error: b * rho,
        roll_rate_error: b * xi,
        period,
    };
    let full = slip::speed_fluctuation_full(&f).unwrap();
    assert!(
        (dx - full.dx).abs() < 1e-9 && (dy - full.dy).abs() < 1e-9,
        "sim ({dx:e}, {dy:e}) vs eq. 14 ({:e}, {:e})",
        full.dx,
        full.dy
    );
    let lin = slip::speed_fluctuation(&f).unwrap();
    let size = dx.hypot(dy);
    assert!(size > 1e-4);
    assert!(
        (dx - lin.dx).hypot(dy - lin.dy) < 0.05 * size,
        "sim ({dx:e}, {dy:e}) vs eqs. 15-16 ({:e}, {:e})",
        lin.dx,
        lin.dy
    );
}

/// Paper 003 §4.2 (eqs. 18–19): accelerating both motors with constant acceleration from
/// (Ρ0, Ξ0) to (Ρ, Ξ) over tσ displaces the wheel, relative to an instantaneous change, by the
/// paper's averaged-rate estimate; simulation and formula agree to 15 % for a short ramp.
#[test]
fn acceleration_phase_matches_paper_003_section_4_2() {
    let (beta0, rho0, xi0, rho, xi, t_sigma) = (0.2, 0.5, 1.0, 1.5, 6.0, 0.1);
    let m = Caster3::<f64>::new(CasterParams::preset()).unwrap();
    let p = *m.params();
    let gamma0: [f64; 3] = core::array::from_fn(|i| beta0 - p.mount_angles[i]);
    // Commands jump from (Ρ0, Ξ0) at t = 0 to (Ρ, Ξ) right after; run until the ramp ends.
    let rate = 1000.0f64;
    let n = (t_sigma * rate).round() as usize;
    let samples: Vec<Sample> = (0..=n)
        .map(|k| {
            let (sr, rr) = if k == 0 { (rho0, xi0) } else { (rho, xi) };
            Sample {
                t: k as f64 / rate,
                pose: Pose2::default(),
                twist: Twist2::default(),
                wheel_rates: omnikin_plan::per_wheel(&[rr; 3]),
                steer: Some((
                    omnikin_plan::per_wheel(&gamma0),
                    omnikin_plan::per_wheel(&[sr; 3]),
                )),
            }
        })
        .collect();
    let plan = Plan { wheels: 3, samples };
    let ramp = Profile::from_toml_str(
        &format!(
            "hold = \"zoh\"\n[wheel_motor]\nmax_accel = {}\n[steer_motor]\nmax_accel = {}\n",
            (xi - xi0) / t_sigma,
            (rho - rho0) / t_sigma
        ),
        "test",
    )
    .unwrap();
    let ramped = simulate_trial(&Robot::Caster(m), &plan, &ramp, &mut trial_rng(0, 0)).unwrap();
    // The reference: the target rates from t = 0 on, with β advancing at the target rate.
    let target = slip::single_wheel_step(&slip::WheelStep {
        wheel_radius: 0.05,
        eccentricity: 0.04,
        beta0,
        steer_rate: rho,
        roll_rate: xi,
        period: t_sigma,
    })
    .unwrap();
    let end = ramped.pose.last().unwrap();
    let beta_sigma = beta0 + 0.5 * (rho + rho0) * t_sigma;
    // The paper compares at the same final wheel direction βσ: the target-rate path reaching βσ.
    let reach = slip::single_wheel_step(&slip::WheelStep {
        wheel_radius: 0.05,
        eccentricity: 0.04,
        beta0,
        steer_rate: rho,
        roll_rate: xi,
        period: (beta_sigma - beta0) / rho,
    })
    .unwrap();
    let (dx, dy) = (end.x - reach.displacement.dx, end.y - reach.displacement.dy);
    let f = slip::acceleration_ramp(&slip::AccelerationRamp {
        wheel_radius: 0.05,
        beta0,
        initial_steer_rate: rho0,
        initial_roll_rate: xi0,
        steer_rate: rho,
        roll_rate: xi,
        duration: t_sigma,
    })
    .unwrap();
    let size = f.dx.hypot(f.dy);
    assert!(size > 1e-4, "{f:?}");
    eprintln!(
        "ramp: sim ({dx:e}, {dy:e}) formula ({:e}, {:e}) rel {:.3}",
        f.dx,
        f.dy,
        (dx - f.dx).hypot(dy - f.dy) / size
    );
    assert!(
        (dx - f.dx).hypot(dy - f.dy) < 0.15 * size,
        "sim ({dx:e}, {dy:e}) vs eqs. 18-19 ({:e}, {:e}); target-rate end {:?}",
        f.dx,
        f.dy,
        target.displacement
    );
}

fn noisy_profile() -> Profile {
    Profile::from_toml_str(
        "[wheel_motor]\nsteps_per_rev = 200\nmicrosteps = 16\nfluctuation_rel = 0.05\nfluctuation_period = 0.05\nradius_error_std = 0.01\n[shell_spin]\nstd = 0.02\n[tracking]\nnoise_std = 0.001\n",
        "test",
    )
    .unwrap()
}

#[test]
fn same_seed_same_numbers_on_one_and_two_threads() {
    let plan = paper_circle(0.2, 1.0, 100.0);
    let robot = sphere();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run_trials(&robot, &plan, &noisy_profile(), 8, 42, &|| {}).unwrap())
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a, b);
    // A different seed gives different numbers.
    let c = run_trials(&robot, &plan, &noisy_profile(), 8, 43, &|| {}).unwrap();
    assert_ne!(a[0].pose.last(), c[0].pose.last());
}

#[test]
fn confidence_band_shrinks_like_one_over_sqrt_n() {
    let plan = paper_circle(0.2, 1.0, 50.0);
    let robot = sphere();
    let band = |n: usize| {
        let trials = run_trials(&robot, &plan, &noisy_profile(), n, 7, &|| {}).unwrap();
        let runs: Vec<Run> = trials
            .iter()
            .map(|t| Run {
                xy: t.tracked.clone(),
                heading: None,
            })
            .collect();
        let m = mean_trajectory(&runs, 0.95);
        let tq = omnikin_sim::metrics::t_quantile(0.95, n);
        // Standard error at the end of the run (largest spread), band / t-quantile.
        let h = m.half_width.last().unwrap();
        h[0].hypot(h[1]) / tq
    };
    let (se16, se64) = (band(16), band(64));
    let ratio = se16 / se64;
    assert!(
        (ratio - 2.0).abs() < 0.6,
        "standard error ratio {ratio} for 4x the trials (expected ~2)"
    );
}

#[test]
fn metrics_of_ideal_runs_are_zero_and_of_a_scaled_circle_give_the_ratio() {
    let plan = paper_circle(0.2, 0.5, 100.0);
    let ideal: Vec<Run> = (0..3)
        .map(|_| Run {
            xy: plan.samples.iter().map(|s| [s.pose.x, s.pose.y]).collect(),
            heading: Some(plan.samples.iter().map(|s| s.pose.heading).collect()),
        })
        .collect();
    let m = evaluate(&plan, &ideal).unwrap().metrics;
    assert!(
        m.max_deviation_m < 1e-12
            && m.end_point_error_m < 1e-12
            && m.max_heading_error_rad.unwrap() < 1e-12
    );
    assert!((m.radius_ratio.unwrap() - 1.0).abs() < 1e-9);
    // Runs on a 1.4× circle through the same start point.
    let big: Vec<Run> = (0..3)
        .map(|_| Run {
            xy: plan
                .samples
                .iter()
                .map(|s| [0.2 + 1.4 * (s.pose.x - 0.2), 1.4 * s.pose.y])
                .collect(),
            heading: None,
        })
        .collect();
    let m = evaluate(&plan, &big).unwrap().metrics;
    assert!((m.radius_ratio.unwrap() - 1.4).abs() < 1e-6, "{m:?}");
    assert!(
        (m.max_deviation_m - 0.16).abs() < 1e-3,
        "{}",
        m.max_deviation_m
    );
    assert!(
        (m.max_deviation_pct_of_path - 100.0 * 0.16 / (0.4 * core::f64::consts::PI)).abs() < 0.1
    );
}

#[test]
fn presets_simulate() {
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let robot = d.build::<f64>().unwrap();
    let plan = paper_circle(0.2, 2.5, 100.0);
    let t = simulate_trial(&robot, &plan, &noisy_profile(), &mut trial_rng(3, 0)).unwrap();
    assert_eq!(t.t.len(), plan.samples.len());
    // A caster plan on a sphere is refused with the reason.
    let (cplan, _) = caster_single_wheel_plan(0.0, 1.0, 1.0, 0.1, 100.0);
    let e = simulate_trial(&robot, &cplan, &Profile::default(), &mut trial_rng(3, 0)).unwrap_err();
    assert!(e.to_string().contains("has no steering"), "{e}");
}

#[test]
fn encoder_quantisation_floors_to_whole_counts() {
    let plan = paper_circle(0.2, 1.0, 50.0);
    let p = Profile::from_toml_str("[encoder]\ncounts_per_rev = 100\n", "test").unwrap();
    let t = simulate_trial(&sphere(), &plan, &p, &mut trial_rng(0, 0)).unwrap();
    let q = core::f64::consts::TAU / 100.0;
    let mut moved = false;
    for (e, w) in t.encoder_angles.iter().zip(&t.wheel_angles) {
        for i in 0..3 {
            let counts = e[i] / q;
            assert!(
                (counts - counts.round()).abs() < 1e-9,
                "not whole counts: {counts}"
            );
            assert!(
                e[i] <= w[i] + 1e-12 && w[i] - e[i] < q,
                "{} vs {}",
                e[i],
                w[i]
            );
            moved |= e[i] != w[i];
        }
    }
    assert!(moved);
}

#[test]
fn tracking_offset_rotates_with_heading_and_matches_its_reference() {
    // A marker 0.1 m ahead of the centre on the circle (heading ψ = ω0 t).
    let plan = paper_circle(0.2, 1.0, 50.0);
    let p = Profile::from_toml_str("[tracking]\noffset = [0.1, 0.0]\n", "test").unwrap();
    let t = simulate_trial(&sphere(), &plan, &p, &mut trial_rng(0, 0)).unwrap();
    for (k, s) in plan.samples.iter().enumerate() {
        let (sn, cs) = s.pose.heading.sin_cos();
        let want = [s.pose.x + 0.1 * cs, s.pose.y + 0.1 * sn];
        assert!((t.tracked[k][0] - want[0]).hypot(t.tracked[k][1] - want[1]) < 1e-9);
    }
    let run = [Run {
        xy: t.tracked.clone(),
        heading: None,
    }];
    let against_centre = evaluate(&plan, &run).unwrap().metrics;
    let against_marker = evaluate(
        &omnikin_sim::metrics::tracked_reference(&plan, [0.1, 0.0]),
        &run,
    )
    .unwrap()
    .metrics;
    assert!(against_centre.max_deviation_m > 0.05);
    assert!(
        against_marker.max_deviation_m < 1e-9
            && (against_marker.radius_ratio.unwrap() - 1.0).abs() < 1e-9
    );
}

#[test]
fn quasi_static_lean_moves_a_low_tracking_point_toward_the_acceleration() {
    // On the circle the acceleration points to the centre (|a| = Rt ω0²); a point 30 mm below
    // the shell centre leans toward it by 0.03·sin(atan(|a|/g)).
    let (rt, w0) = (0.2, 2.5);
    let plan = paper_circle(rt, w0, 100.0);
    let p =
        Profile::from_toml_str("[tracking]\nheight = -0.03\ntilt_gain = 1.0\n", "test").unwrap();
    let t = simulate_trial(&sphere(), &plan, &p, &mut trial_rng(0, 0)).unwrap();
    let lean = 0.03 * (rt * w0 * w0 / 9.80665).atan().sin();
    for k in 10..plan.samples.len() {
        let r = t.tracked[k][0].hypot(t.tracked[k][1]);
        assert!(
            (r - (rt - lean)).abs() < 2e-5,
            "k {k}: radius {r} vs {}",
            rt - lean
        );
    }
}

#[test]
fn ballbot_plant_reproduces_its_plan_and_caster_slip_shows_with_a_bad_wheel() {
    use omnikin::ballbot::{Ballbot, BallbotParams};
    let b = Ballbot::new(BallbotParams::preset()).unwrap();
    let samples = (0..=200)
        .map(|k| {
            let t = k as f64 / 100.0;
            let (pose, twist) = (
                Pose2::new(0.3 * t, 0.0, 0.2 * t),
                Twist2::new(0.3, 0.0, 0.2),
            );
            Sample {
                t,
                pose,
                twist,
                wheel_rates: omnikin_plan::per_wheel(
                    &b.wheel_rates_world(twist, pose.heading, 0.0).unwrap(),
                ),
                steer: None,
            }
        })
        .collect();
    let plan = Plan { wheels: 3, samples };
    let t = simulate_trial(
        &Robot::Ballbot(b),
        &plan,
        &Profile::default(),
        &mut trial_rng(0, 0),
    )
    .unwrap();
    let end = t.pose.last().unwrap();
    // The ball rolls straight along world x while the body turns (the twist above is
    // world-frame): a straight line, not an arc.
    // Second-order error of the linear set-point hold (the body-frame twist rotates).
    assert!(
        (end.x - 0.6).abs() < 1e-6 && end.y.abs() < 1e-6 && (end.heading - 0.4).abs() < 1e-9,
        "{end:?}"
    );
    // Caster: the same bias on every motor keeps the wheels consistent (no slip, a different
    // path); per-wheel radius scatter makes them disagree, and the least-squares fit shows it.
    let (cplan, m) = caster_single_wheel_plan(0.3, 1.5, 4.0, 1.0, 100.0);
    let fight = Profile::from_toml_str("[wheel_motor]\nradius_error_std = 0.05\n", "test").unwrap();
    let fair = Profile::from_toml_str(
        "[steer_motor]\nrate_bias_rel = 0.05\n[wheel_motor]\nrate_bias_rel = 0.05\n",
        "test",
    )
    .unwrap();
    let bad = simulate_trial(&Robot::Caster(m), &cplan, &fight, &mut trial_rng(0, 0)).unwrap();
    let good = simulate_trial(&Robot::Caster(m), &cplan, &fair, &mut trial_rng(0, 0)).unwrap();
    let max = |t: &omnikin_sim::Trial| t.slip_residual.iter().cloned().fold(0.0, f64::max);
    assert!(max(&good) < 1e-12, "{}", max(&good));
    assert!(max(&bad) > 1e-3, "{}", max(&bad));
}

#[test]
fn plan_mismatch_is_detected() {
    let plan = paper_circle(0.2, 1.0, 50.0);
    assert!(omnikin_sim::plan_mismatch(&sphere(), &plan).is_none());
    let d = RobotDescription::preset("ballbot").unwrap();
    let why = omnikin_sim::plan_mismatch(&d.build::<f64>().unwrap(), &plan).unwrap();
    assert!(why.contains("inverse kinematics"), "{why}");
}
