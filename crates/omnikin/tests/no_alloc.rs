//! The kinematics calls of all three robots never touch the heap: a counting global allocator
//! sees zero allocations on this thread while they run (including their error paths).

use omnikin_testkit::allocations;

use omnikin::ballbot::{Ballbot, BallbotParams};
use omnikin::caster::{Caster3, CasterParams, CasterRates};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Twist2, se2};

#[global_allocator]
static GLOBAL: omnikin_testkit::Counting = omnikin_testkit::Counting;

#[test]
fn the_counter_counts() {
    let (n, v) = allocations(|| vec![1u8; 16]);
    assert_eq!(v.len(), 16);
    assert!(n >= 1, "the counting allocator must see a Vec");
}

#[test]
fn kinematics_calls_allocate_nothing() {
    let (n, _) = allocations(|| {
        let mut acc = 0.0f64;
        let tw = Twist2::new(0.1, -0.05, 0.3);
        // Construction too: it is all fixed-size.
        let s = SphereOmni::new(SphereParams::<f64>::preset()).unwrap();
        let w = s.wheel_rates(tw, 0.0).unwrap();
        acc += w[0] + s.wheel_rates_world(tw, 0.4, 0.1).unwrap()[1];
        acc += s.body_twist(w, 0.0).unwrap().vx + s.shell_spin(w, 0.3).unwrap();
        acc += s.wheel_rates(Twist2::new(f64::NAN, 0.0, 0.0), 0.0).is_err() as u8 as f64;

        let b = Ballbot::new(BallbotParams::<f64>::preset()).unwrap();
        let w = b.wheel_rates(tw, 0.0).unwrap();
        acc += b.body_twist(w, 0.0).unwrap().vy + b.wheel_rates_world(tw, 1.0, 0.0).unwrap()[2];
        acc += b.model_torques([0.1, 0.2, 0.3], 0.5).unwrap()[0];
        acc += b.wheel_torques([0.1, 0.2, 0.3], 0.5).unwrap()[1];
        acc += b.model_rates(w, 0.5).unwrap()[2] + b.ball_displacement(w, 0.0, 0.1).unwrap()[0];

        let c = Caster3::new(CasterParams::<f64>::preset()).unwrap();
        let steer = [0.1, -0.2, 0.3];
        let r = c.motor_rates(tw, 0.2, steer).unwrap();
        let f = c.body_twist(&r, 0.2, steer).unwrap();
        acc += f.twist.vx + f.slip_residual;
        acc += c.det_j2(0.2, steer);
        acc += c.spin_in_place(steer, 0.5).unwrap().yaw_rate;
        acc += c.turn_in_place(steer, 0.5).unwrap().roll[0];
        acc += c
            .translation_from_wheel1(0.2, steer, 1.0, 0.1)
            .unwrap()
            .0
            .vx;
        let _ = c.fixed_steer_motion(0.2, steer);
        acc += c
            .body_twist(
                &CasterRates {
                    roll: [f64::NAN; 3],
                    steer: [0.0; 3],
                },
                0.0,
                steer,
            )
            .is_err() as u8 as f64;

        let p = se2::integrate(Pose2::default(), tw, 0.01);
        acc + p.x
    });
    assert_eq!(n, 0, "kinematics allocated {n} times");
}

#[test]
fn balance_controller_allocates_nothing() {
    use omnikin::control::{BalanceCommand, BalanceConfig, BalanceController, Measurement};
    let (n, _) = allocations(|| {
        // Construction (ZOH discretisation, three Riccati iterations) and cycles, f32 and f64.
        let mut c = BalanceController::<f32>::new(BalanceConfig::preset()).unwrap();
        let mut c64 = BalanceController::<f64>::new(BalanceConfig::preset()).unwrap();
        let mut acc = 0.0f64;
        for k in 0..10 {
            let t = k as f32 * 0.005;
            let m = Measurement {
                tilt: [0.02 * t, -0.01],
                tilt_rate: [0.1, 0.0],
                yaw: t,
                yaw_rate: 0.2,
                ball_position: [t, 0.0],
                ball_velocity: [0.1, 0.0],
            };
            acc += c.step(&m, &BalanceCommand::hold()).unwrap().wheel_torques[0] as f64;
        }
        let bad = Measurement {
            tilt: [f64::NAN, 0.0],
            tilt_rate: [0.0; 2],
            yaw: 0.0,
            yaw_rate: 0.0,
            ball_position: [0.0; 2],
            ball_velocity: [0.0; 2],
        };
        acc += c64.step(&bad, &BalanceCommand::hold()).is_err() as u8 as f64;
        acc
    });
    assert_eq!(n, 0, "the balance controller allocated {n} times");
}

#[test]
fn fusion_filter_step_allocates_nothing() {
    use omnikin::estimate::fix::Fix;
    use omnikin::estimate::fusion::{FusionConfig, PoseFusion, StepHeading};
    use omnikin::nalgebra::Matrix3;
    let (n, pose) = allocations(|| {
        // Construction, predictions at 1 kHz, late fixes with replay, a rejected run that
        // recovers, and an error path: all fixed-size.
        let mut f = PoseFusion::<f64, 64>::new(
            0.0,
            Pose2::new(0.0, 0.0, 0.0),
            Matrix3::identity() * 1e-4,
            FusionConfig::default(),
        )
        .unwrap();
        let delta = se2::twist_exp(Twist2::new(0.3, 0.0, 0.2), 1e-3);
        for k in 1..=3000 {
            let t = k as f64 * 1e-3;
            f.predict(t, delta, StepHeading::Gyro).unwrap();
            if k % 100 == 0 {
                let off = if k > 2000 { 3.0 } else { 0.0 };
                let p = f.pose();
                let _ = f.add_fix(&Fix::position(t - 0.3, p.x + off, p.y, 0.01));
            }
        }
        let _ = f.add_fix(&Fix::position(f64::NAN, 0.0, 0.0, 0.01));
        f.pose()
    });
    assert!(pose.x.is_finite());
    assert_eq!(n, 0, "PoseFusion allocated {n} times");
}
