//! The sphere model's steppers (`motor = "stepper"`, `omnikin_sim::dynamics::sphere::stepper`):
//! the pull-out curve, the energy balance with the motors' work, and steps lost past the
//! pull-out torque. Expected values come from the law's parameters, not from a recorded run.

use omnikin::Twist2;
use omnikin::description::MotorModel;
use omnikin_sim::dynamics::sphere::{SphereDynamics, SphereSim, Stepper};

fn stepper_robot() -> SphereDynamics {
    let mut p = SphereDynamics::paper_000();
    p.motor = MotorModel::Stepper;
    p
}

/// Wheel rates for a platform-frame twist `(v, 0, ψ̇)` with `Ω3 = 0` (paper 000 eq. 5.7).
fn rates(sim: &SphereSim, v: f64, yaw_rate: f64) -> [f64; 3] {
    sim.kinematics()
        .wheel_rates(Twist2::new(v, 0.0, yaw_rate), 0.0)
        .unwrap()
}

#[test]
fn the_pull_out_torque_is_flat_to_the_corner_then_falls_as_one_over_speed() {
    let st = Stepper::of(&stepper_robot());
    let (t0, wc) = (st.torque, st.corner_speed);
    assert_eq!(
        st.teeth, 50.0,
        "200 full steps per revolution = 50 electrical cycles"
    );
    assert_eq!(st.pull_out(0.0), t0);
    assert_eq!(st.pull_out(-wc), t0);
    assert!((st.pull_out(2.0 * wc) - t0 / 2.0).abs() < 1e-12);
    assert!((st.pull_out(-4.0 * wc) - t0 / 4.0).abs() < 1e-12);
    // The torque–angle law's largest restoring torque is the pull-out torque, one full step
    // (a quarter of an electrical cycle) behind the field.
    let quarter = std::f64::consts::FRAC_PI_2 / st.teeth;
    for w in [0.0, 10.0, 3.0 * wc] {
        assert!((st.torque(-quarter, 0.0, w) - st.pull_out(w)).abs() < 1e-12);
        assert!(st.torque(-0.5 * quarter, 0.0, w) < st.pull_out(w));
        // The steady lag for a load inverts the law.
        let load = 0.6 * st.pull_out(w);
        assert!((st.torque(st.lag_for(load, w), 0.0, w) - load).abs() < 1e-12);
    }
    assert_eq!(st.cycle(0.49 * 4.0 * quarter), 0);
    assert_eq!(st.cycle(-1.01 * 4.0 * quarter), -1);
}

#[test]
fn energy_balance_motor_work_equals_kinetic_gain_plus_dissipation_step_by_step() {
    // A full-speed start and a hard stop with steppers, sliding rollers, pivot friction and
    // rolling resistance: per step ΔE = motor work − roller slip loss + floor work.
    // The stepper's torque–angle stiffness (≈ 15 N·m/rad) is the stiffest part of the model:
    // the RK4 truncation error of the balance falls as h⁴ (worst step 8.7e-6 at the default
    // 1 ms, 9.2e-7 at 0.5 ms, 6.3e-8 at 0.25 ms), so the check runs at 0.25 ms.
    let mut p = stepper_robot();
    p.max_substep = 0.25e-3;
    let mut sim = SphereSim::new(p).unwrap();
    let go = rates(&sim, 0.4, 2.0);
    let dt = 0.01;
    let mut worst = 0.0f64;
    let (mut w_motor, mut w_slip, mut w_floor) = (0.0, 0.0, 0.0);
    for k in 0..300 {
        let cmd = if k < 150 { go } else { [0.0; 3] };
        let e0 = sim.energy();
        let st = sim.step(dt, cmd).unwrap();
        let de = sim.energy() - e0;
        assert!(st.slip_work >= -1e-12, "k {k}: slip work {}", st.slip_work);
        let work = st.motor_work - st.slip_work + st.floor_work;
        let scale = st.motor_work.abs() + st.slip_work.abs() + st.floor_work.abs() + 1e-9;
        worst = worst.max((de - work).abs() / scale);
        w_motor += st.motor_work;
        w_slip += st.slip_work;
        w_floor += st.floor_work;
    }
    let ev = sim.contact_events();
    eprintln!(
        "stepper energy balance: worst relative mismatch {worst:.2e}; motor {w_motor:.4} J, \
         slip loss {w_slip:.4} J, floor {w_floor:.4} J; {ev:?}"
    );
    assert!(
        ev.roller_slips.iter().sum::<u64>() > 0 && w_slip > 0.0,
        "the test needs sliding rollers"
    );
    assert!(w_floor < 0.0);
    assert!(worst < 1e-6, "worst relative mismatch {worst}");
}

/// Drives straight ahead to `v` (m/s) over `ramp` s, holds for 1 s, and returns the steps
/// lost per wheel with each wheel's deficit against its commanded angle, in full steps.
fn drive(p: SphereDynamics, v: f64, ramp: f64) -> ([u64; 3], [f64; 3]) {
    let mut sim = SphereSim::new(p).unwrap();
    let dir = rates(&sim, 1.0, 0.0);
    let dt = 0.01;
    let n = ((ramp + 1.0) / dt).round() as usize;
    let mut field = [0.0f64; 3];
    let mut prev = [0.0f64; 3];
    for k in 1..=n {
        let s = (k as f64 * dt / ramp).min(1.0);
        let cmd = dir.map(|w| w * v * s);
        let st = sim.step(dt, cmd).unwrap();
        for i in 0..3 {
            // The commanded angle: the linear ramp between samples integrates exactly.
            field[i] += 0.5 * (prev[i] + cmd[i]) * dt;
            assert!(st.wheel_rates[i].is_finite());
        }
        prev = cmd;
    }
    let step = std::f64::consts::TAU / p.stepper_steps_per_rev;
    let angles = sim.state().wheel_angles;
    let deficit = core::array::from_fn(|i| (field[i] - angles[i]).abs() / step);
    (sim.contact_events().lost_steps, deficit)
}

#[test]
fn a_demand_beyond_pull_out_loses_steps_and_one_below_does_not() {
    // Rigid roller contacts, so the motor, not a sliding roller, meets the demand.
    let p = stepper_robot().rigid_contacts();
    // Below: 0 → 0.2 m/s over 1 s (0.2 m/s²) needs a small fraction of the pull-out torque.
    let (lost, deficit) = drive(p, 0.2, 1.0);
    assert_eq!(lost, [0; 3], "a gentle ramp loses no steps");
    for d in deficit {
        assert!(
            d < 1.0,
            "the rotor stays within a full step of its field: {d}"
        );
    }
    // Beyond: 0 → 0.5 m/s within one 10 ms step (≈ 50 m/s²) needs far more torque than
    // the 0.3 N·m pull-out torque can give the robot's inertia.
    let (lost, deficit) = drive(p, 0.5, 0.01);
    eprintln!("full-speed step demand: lost steps {lost:?}, deficit {deficit:?} full steps");
    assert!(lost.iter().sum::<u64>() > 0, "steps are lost");
    for i in 0..3 {
        // The lost steps are what an encoder sees missing against the command: the deficit is
        // the counted steps, give or take the lag inside the current electrical cycle.
        assert!(
            (deficit[i] - lost[i] as f64).abs() <= 2.0,
            "wheel {i}: deficit {} vs lost {}",
            deficit[i],
            lost[i]
        );
    }
    // The rate model resynchronises: it reports pull-outs, never lost steps.
    let mut rate = p;
    rate.motor = MotorModel::Rate;
    let (lost, _) = drive(rate, 0.5, 0.01);
    assert_eq!(lost, [0; 3]);
}
