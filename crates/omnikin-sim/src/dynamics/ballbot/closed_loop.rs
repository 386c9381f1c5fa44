//! The closed loop in simulation: the core's balance controller at its control rate, its
//! wheel torques held (zero-order hold) over RK4 sub-steps of the 3D model, pushes as impulses
//! on the body's centre of mass.

use omnikin::control::{BalanceCommand, BalanceController, BalanceOutput, Measurement};
use omnikin::nalgebra::Vector3;

use super::model::BallbotPlant;
use super::state::BallbotState;

/// A horizontal push: an impulse (N·s, world frame) on the body's centre of mass at time
/// `time` (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Push {
    /// When, s (applied at the first control cycle at or after it).
    pub time: f64,
    /// Impulse `(Jx, Jy)`, N·s, world frame.
    pub impulse: [f64; 2],
}

/// One control cycle of a closed-loop run, as seen at its start.
#[derive(Clone, Copy, Debug)]
pub struct CycleRecord {
    /// Time, s.
    pub t: f64,
    /// The plant's state at the start of the cycle (after any push).
    pub state: BallbotState,
    /// The command of this cycle.
    pub command: BalanceCommand<f64>,
    /// The controller's output (the wheel torques held over the cycle).
    pub output: BalanceOutput<f64>,
    /// Wheel rates at the start of the cycle, rad/s.
    pub wheel_rates: [f64; 3],
}

/// How long and how finely a closed-loop run goes.
#[derive(Clone, Copy, Debug)]
pub struct RunOptions<'a> {
    /// Control cycles to run.
    pub cycles: usize,
    /// RK4 steps of the plant per control cycle (≥ 1).
    pub substeps: usize,
    /// Pushes to apply.
    pub pushes: &'a [Push],
}

/// Runs `opts.cycles` control cycles from `state`: each cycle measures the plant
/// ([`BallbotPlant::measurement`]), asks `command(t)` for the motion to follow, steps the
/// controller and integrates the plant over the control period in `opts.substeps` RK4 steps with
/// the torques held. `record` sees every cycle. Returns the final state, or the controller's
/// input error.
///
/// # Errors
/// [`omnikin::InputError`] when the controller rejects a measurement (a non-finite state).
pub fn run(
    plant: &BallbotPlant,
    controller: &mut BalanceController<f64>,
    state: BallbotState,
    opts: &RunOptions<'_>,
    command: impl FnMut(f64) -> BalanceCommand<f64>,
    record: impl FnMut(&CycleRecord),
) -> Result<BallbotState, omnikin::InputError> {
    run_with(
        plant,
        controller,
        state,
        opts,
        |_, s| Ok(plant.measurement(s)),
        command,
        record,
    )
}

/// [`run`] with the controller's measurement made by `measure(t, state)` (e.g. dead reckoning
/// from the wheel encoders, or with sensor noise) instead of the noise-free
/// [`BallbotPlant::measurement`].
///
/// # Errors
/// The first error of `measure` or of the controller.
pub fn run_with(
    plant: &BallbotPlant,
    controller: &mut BalanceController<f64>,
    mut state: BallbotState,
    opts: &RunOptions<'_>,
    mut measure: impl FnMut(f64, &BallbotState) -> Result<Measurement<f64>, omnikin::InputError>,
    mut command: impl FnMut(f64) -> BalanceCommand<f64>,
    mut record: impl FnMut(&CycleRecord),
) -> Result<BallbotState, omnikin::InputError> {
    let dt = controller.period();
    let n = opts.substeps.max(1);
    let pushes = opts.pushes;
    let h = dt / n as f64;
    let mut pushed = vec![false; pushes.len()];
    for k in 0..opts.cycles {
        let t = k as f64 * dt;
        for (i, p) in pushes.iter().enumerate() {
            if !pushed[i] && t >= p.time {
                plant.apply_impulse(&mut state, Vector3::new(p.impulse[0], p.impulse[1], 0.0));
                pushed[i] = true;
            }
        }
        let cmd = command(t);
        let out = controller.step(&measure(t, &state)?, &cmd)?;
        record(&CycleRecord {
            t,
            state,
            command: cmd,
            output: out,
            wheel_rates: plant.wheel_rates(&state),
        });
        for _ in 0..n {
            plant.step(&mut state, out.wheel_torques, Vector3::zeros(), h);
        }
    }
    Ok(state)
}
