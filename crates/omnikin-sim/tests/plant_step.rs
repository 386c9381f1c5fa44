//! One plant step for the simulator and software in the loop: for the same motor set-points
//! and seed, `simulate_trial` (open loop, a plan) and `SilPlant` (the runtime's board) move
//! the true robot identically; a constant twist traces an exact arc at any plant step; the
//! ballbot's ball spin follows the profile's spin law in both.

use omnikin::description::RobotDescription;
use omnikin::runtime::hal::{MotorCommand, MotorOutputs};
use omnikin::{Pose2, Robot, Twist2};
use omnikin_plan::{Plan, Sample};
use omnikin_sim::Profile;
use omnikin_sim::plant_step::{MotorMotion, Plant};
use omnikin_sim::sil::SilPlant;
use omnikin_sim::simulate_trial;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn preset(name: &str) -> Robot<f64> {
    RobotDescription::preset(name).unwrap().build().unwrap()
}

const PRESETS: [&str; 3] = ["sphere-omni", "ballbot", "caster3"];

/// Every disturbance that acts between the set-points and the true pose, with zero-order hold
/// (the runtime holds its set-points between cycles) and no tracking noise (tracking is not
/// the plant, and its noise draws from the trial's stream).
fn disturbed() -> Profile {
    Profile::from_toml_str(
        "rate = 1000.0\nhold = \"zoh\"\n\
         [wheel_motor]\nlag_time_constant = 0.02\nmax_accel = 200.0\nfluctuation_abs = 0.05\n\
         fluctuation_rel = 0.02\nfluctuation_period = 0.0125\nradius_error_std = 0.01\n\
         rate_bias_rel = 0.01\n\
         [steer_motor]\nlag_time_constant = 0.01\nfluctuation_abs = 0.02\n\
         fluctuation_period = 0.0235\n\
         [shell_spin]\nstd = 0.02\nslip_gain = 0.875\nslip_exponent = 1.22\n\
         [roller]\namplitude = 0.02\n\
         [floor]\nrel_std = 0.02\ncorr_time = 0.3\n",
        "<test>",
    )
    .unwrap()
}

/// Motor set-points `(wheel, steer)` at control step `k` (period `PERIOD`): at rest at `k = 0`
/// (SIL starts at rest), then smoothly varying rates of a few rad/s.
fn setpoint(robot: &Robot<f64>, k: usize) -> ([f64; 3], [f64; 3]) {
    if k == 0 {
        return ([0.0; 3], [0.0; 3]);
    }
    let t = k as f64 * PERIOD;
    let wave = |a: f64, f: f64, i: usize| a * (f * t + 2.1 * i as f64).sin() + 0.3 * a;
    match robot {
        Robot::Caster(_) => (
            core::array::from_fn(|i| wave(4.0, 1.3, i)),
            core::array::from_fn(|i| wave(0.8, 0.9, i)),
        ),
        _ => (core::array::from_fn(|i| wave(3.0, 1.7, i)), [0.0; 3]),
    }
}

const PERIOD: f64 = 0.01;

/// The set-point sequence as a plan for `simulate_trial` (sample `k` holds set-point `k` until
/// sample `k + 1`; poses and twists are not read by the plant past the first sample).
fn plan_of(robot: &Robot<f64>, steps: usize) -> Plan {
    let caster = matches!(robot, Robot::Caster(_));
    Plan {
        wheels: 3,
        samples: (0..=steps)
            .map(|k| {
                let (w, s) = setpoint(robot, k.min(steps - 1));
                Sample {
                    t: k as f64 * PERIOD,
                    pose: Pose2::default(),
                    twist: Twist2::default(),
                    wheel_rates: omnikin_plan::per_wheel(&w),
                    steer: caster
                        .then_some(([0.0; omnikin::MAX_WHEELS], omnikin_plan::per_wheel(&s))),
                }
            })
            .collect(),
    }
}

/// A HAL motor command of these wheel and steer rates (the rest zero).
fn command(wheel: &[f64], steer: &[f64]) -> MotorCommand<f64> {
    let mut c = MotorCommand::zero();
    c.wheel[..wheel.len()].copy_from_slice(wheel);
    c.steer[..steer.len()].copy_from_slice(steer);
    c
}

/// The true poses of SIL at every control step under the same set-points.
fn sil_poses(robot: Robot<f64>, profile: Profile, seed: u64, steps: usize) -> Vec<Pose2<f64>> {
    let mut plant = SilPlant::new(robot, profile, seed, Pose2::default());
    let mut out = vec![plant.true_pose()];
    for k in 0..steps {
        let (wheel, steer) = setpoint(&robot, k);
        plant.set_rates(&command(&wheel, &steer)).unwrap();
        plant.advance(PERIOD).unwrap();
        out.push(plant.true_pose());
    }
    out
}

fn worst_gap(a: &[Pose2<f64>], b: &[Pose2<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(p, q)| {
            (p.x - q.x)
                .abs()
                .max((p.y - q.y).abs())
                .max((p.heading - q.heading).abs())
        })
        .fold(0.0, f64::max)
}

#[test]
fn simulator_and_sil_move_every_preset_identically_under_all_disturbances() {
    let steps = 150;
    for name in PRESETS {
        let robot = preset(name);
        for seed in [3u64, 11] {
            let plan = plan_of(&robot, steps);
            let trial = simulate_trial(
                &robot,
                &plan,
                &disturbed(),
                &mut ChaCha8Rng::seed_from_u64(seed),
            )
            .unwrap();
            let sil = sil_poses(robot, disturbed(), seed, steps);
            let gap = worst_gap(&trial.pose, &sil);
            // Only the plant steps' dt differ in the last bits (interval/steps vs 1/rate).
            assert!(
                gap < 1e-9,
                "{name} seed {seed}: sim and SIL differ by {gap:e}"
            );
            let end = trial.pose[steps];
            assert!(
                end.x.hypot(end.y) > 0.05 && end.heading.abs() > 0.05,
                "{name}: the robot must move and turn for the test to mean anything: {end:?}"
            );
            // The disturbances act: the same run without them ends elsewhere.
            let ideal = simulate_trial(
                &robot,
                &plan,
                &Profile::from_toml_str("hold = \"zoh\"\n", "<test>").unwrap(),
                &mut ChaCha8Rng::seed_from_u64(seed),
            )
            .unwrap();
            assert!(
                worst_gap(&trial.pose, &ideal.pose) > 1e-3,
                "{name}: disturbances had no effect"
            );
        }
    }
}

/// Paper 000's speed-dependent spin on the ballbot: with ideal motors and constant wheel rates
/// for a robot-frame twist `(vx, vy, ψ̇)`, the ball spins at `Ω = g·|V|^p·ω̃_z` with
/// `ω̃_z = −ψ̇`, so the body turns at `ψ̇(1 − g·|V|^p)` — in the simulator and in SIL alike.
/// (SIL used to pass only the constant spin to the ballbot and turned it at `ψ̇`.)
#[test]
fn ballbot_ball_spin_follows_the_spin_law_in_simulator_and_sil() {
    let (g, p) = (0.875, 1.22);
    let profile = Profile::from_toml_str(
        &format!("hold = \"zoh\"\n[shell_spin]\nslip_gain = {g}\nslip_exponent = {p}\n"),
        "<test>",
    )
    .unwrap();
    for name in ["ballbot", "sphere-omni"] {
        let robot = preset(name);
        let nominal = Twist2::new(0.3, 0.1, 0.5);
        let w = match &robot {
            Robot::Ballbot(m) => m.wheel_rates(nominal, 0.0).unwrap(),
            Robot::Sphere(m) => m.wheel_rates(nominal, 0.0).unwrap(),
            _ => unreachable!("ballbot and sphere only"),
        };
        let speed = nominal.vx.hypot(nominal.vy);
        let yaw = nominal.yaw_rate * (1.0 - g * speed.powf(p));
        let t_end = 2.0;
        let expected = omnikin::se2::integrate(Pose2::default(), Twist2::new(0.3, 0.1, yaw), t_end);

        let plan = Plan {
            wheels: 3,
            samples: [0.0, t_end]
                .map(|t| Sample {
                    t,
                    pose: Pose2::default(),
                    twist: Twist2::default(),
                    wheel_rates: omnikin_plan::per_wheel(&w),
                    steer: None,
                })
                .to_vec(),
        };
        let trial =
            simulate_trial(&robot, &plan, &profile, &mut ChaCha8Rng::seed_from_u64(1)).unwrap();
        let sim_end = trial.pose[1];

        // SIL from rest with ideal motors: the set-point is reached at once.
        let mut sil = SilPlant::new(robot, profile, 1, Pose2::default());
        sil.set_rates(&command(&w, &[])).unwrap();
        sil.advance(t_end).unwrap();
        let twist = sil.true_twist();
        assert!(
            (twist.yaw_rate - yaw).abs() < 1e-12,
            "{name}: SIL yaw rate {} instead of {yaw} (nominal {})",
            twist.yaw_rate,
            nominal.yaw_rate
        );
        for (what, end) in [("sim", sim_end), ("SIL", sil.true_pose())] {
            let gap = worst_gap(&[end], &[expected]);
            assert!(gap < 1e-9, "{name} {what}: {end:?} vs {expected:?}");
        }
        assert!(
            (yaw - nominal.yaw_rate).abs() > 0.1,
            "the spin law must act"
        );
    }
}

/// The pose after holding the robot-frame twist `tw` for `t` seconds from the origin, in
/// closed form (rotation about the instantaneous centre `c = (−v_y, v_x)/ψ̇`), independent of
/// `omnikin::se2`.
fn arc(tw: Twist2<f64>, t: f64) -> Pose2<f64> {
    let th = tw.yaw_rate * t;
    let c = [-tw.vy / tw.yaw_rate, tw.vx / tw.yaw_rate];
    let (s, co) = th.sin_cos();
    // p = c + R(θ)(0 − c)
    Pose2::new(
        c[0] - (co * c[0] - s * c[1]),
        c[1] - (s * c[0] + co * c[1]),
        th,
    )
}

/// Constant motor rates for the robot-frame twist `tw`, with the caster's steer angles at
/// their steady state for it (every steer rate zero, found per wheel by bisection on the
/// inverse kinematics), so the rates stay constant along the arc.
fn constant_rates(robot: &Robot<f64>, tw: Twist2<f64>) -> ([f64; 3], [f64; 3]) {
    match robot {
        Robot::Sphere(m) => (m.wheel_rates(tw, 0.0).unwrap(), [0.0; 3]),
        Robot::Ballbot(m) => (m.wheel_rates(tw, 0.0).unwrap(), [0.0; 3]),
        Robot::Caster(m) => {
            let sd = |i: usize, g: f64| m.motor_rates(tw, 0.0, [g; 3]).unwrap().steer[i];
            let steer: [f64; 3] = core::array::from_fn(|i| {
                let n = 720;
                let grid = |k: usize| {
                    -core::f64::consts::PI + core::f64::consts::TAU * k as f64 / n as f64
                };
                let k = (0..n)
                    .find(|&k| sd(i, grid(k)).signum() != sd(i, grid(k + 1)).signum())
                    .expect("a steady steer angle");
                let (mut lo, mut hi) = (grid(k), grid(k + 1));
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if sd(i, mid).signum() == sd(i, lo).signum() {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                0.5 * (lo + hi)
            });
            let r = m.motor_rates(tw, 0.0, steer).unwrap();
            assert!(r.steer.iter().all(|s| s.abs() < 1e-12), "{r:?}");
            (r.roll, steer)
        }
        _ => unreachable!("the paper robots only"),
    }
}

/// Disturbances that are constant over a trial (radius errors, constant and speed-dependent
/// spin): the held twist differs from the commanded one but is still constant.
fn constant_disturbances(rate: f64) -> Profile {
    Profile::from_toml_str(
        &format!(
            "rate = {rate}\nhold = \"zoh\"\n[wheel_motor]\nradius_error_std = 0.02\n\
             [shell_spin]\nstd = 0.05\nslip_gain = 0.875\nslip_exponent = 1.22\n"
        ),
        "<test>",
    )
    .unwrap()
}

#[test]
fn a_constant_twist_traces_an_exact_arc_at_any_plant_step() {
    let tw = Twist2::new(0.25, -0.08, 0.9);
    let t_end = 2.0;
    for name in PRESETS {
        let robot = preset(name);
        let (w, steer) = constant_rates(&robot, tw);
        // Ideal plant: the commanded arc.
        for dt in [1e-3_f64, 0.01, 0.1, 0.5, 2.0] {
            let profile = Profile::default();
            let mut rng = ChaCha8Rng::seed_from_u64(9);
            let mut plant = Plant::new(
                robot,
                &profile,
                Pose2::default(),
                omnikin_plan::per_wheel(&steer),
                &mut rng,
            );
            let n = (t_end / dt).round() as usize;
            for _ in 0..n {
                let motion = MotorMotion {
                    wheel_angle: [0.0; omnikin::MAX_WHEELS],
                    wheel_turn: omnikin_plan::per_wheel(&w.map(|x| x * dt)),
                    steer_turn: [0.0; omnikin::MAX_WHEELS],
                };
                plant.step(&motion, dt, &mut rng).unwrap();
            }
            let gap = worst_gap(&[plant.pose()], &[arc(tw, t_end)]);
            assert!(
                gap < 1e-12,
                "{name} dt {dt}: {:?} vs {:?}",
                plant.pose(),
                arc(tw, t_end)
            );
            assert!(
                plant.slip_residual() < 1e-12,
                "{name}: consistent rates, no slip"
            );
        }
        // The simulator at plant rates from 1 Hz (two steps) to 1 kHz, with constant
        // disturbances: one arc of the disturbed twist, whatever the rate.
        let plan = Plan {
            wheels: 3,
            samples: [0.0, t_end]
                .map(|t| Sample {
                    t,
                    pose: Pose2::default(),
                    twist: Twist2::default(),
                    wheel_rates: omnikin_plan::per_wheel(&w),
                    steer: robot
                        .steerable()
                        .then_some((omnikin_plan::per_wheel(&steer), [0.0; omnikin::MAX_WHEELS])),
                })
                .to_vec(),
        };
        for rate in [1.0, 3.0, 100.0, 1000.0] {
            let profile = constant_disturbances(rate);
            // The disturbed twist this seed holds: one plant step of the same draws.
            let mut rng = ChaCha8Rng::seed_from_u64(4);
            let mut probe = Plant::new(
                robot,
                &profile,
                Pose2::default(),
                omnikin_plan::per_wheel(&steer),
                &mut rng,
            );
            let motion = MotorMotion {
                wheel_angle: [0.0; omnikin::MAX_WHEELS],
                wheel_turn: omnikin_plan::per_wheel(&w.map(|x| x * 0.01)),
                steer_turn: [0.0; omnikin::MAX_WHEELS],
            };
            let disturbed = probe.step(&motion, 0.01, &mut rng).unwrap();
            assert!(
                worst_gap(&[arc(disturbed, t_end)], &[arc(tw, t_end)]) > 1e-3,
                "{name}: the disturbances must change the twist"
            );
            let trial =
                simulate_trial(&robot, &plan, &profile, &mut ChaCha8Rng::seed_from_u64(4)).unwrap();
            let gap = worst_gap(&[trial.pose[1]], &[arc(disturbed, t_end)]);
            assert!(
                gap < 1e-11,
                "{name} at {rate} Hz: {:?} vs {:?}",
                trial.pose[1],
                arc(disturbed, t_end)
            );
            // SIL starts at rest with zero steer angles: the rolling robots only.
            if !robot.steerable() {
                let mut sil = SilPlant::new(robot, profile, 4, Pose2::default());
                sil.set_rates(&command(&w, &[])).unwrap();
                sil.advance(t_end).unwrap();
                let gap = worst_gap(&[sil.true_pose()], &[arc(disturbed, t_end)]);
                assert!(
                    gap < 1e-11,
                    "{name} SIL at {rate} Hz: {:?}",
                    sil.true_pose()
                );
            }
        }
    }
}
