//! A plan through the dynamic model: [`simulate_plan`] steps [`SphereSim`] with the plan's
//! wheel rates and records a [`Trial`] at the plan's sample times (the same record the
//! kinematic simulator makes, so the metrics and files apply unchanged), with what only the
//! dynamics know (tilt, shell spin, pull-out and contact events) beside it.

use omnikin::{MAX_WHEELS, Pose2};
use omnikin_plan::Plan;

use super::params::{DynamicsError, SphereDynamics};
use super::sim::{ContactEvents, SphereSim, SphereState};
use crate::Trial;
use crate::sensors::PlatformAttitude;

/// One plan run through the dynamic model.
#[derive(Clone, Debug, PartialEq)]
pub struct DynamicTrial {
    /// The run, at the plan's sample times: shell-centre pose with the platform's heading,
    /// the tracked point ([`SphereDynamics::tracked_height`]), the wheel angles (encoders
    /// read them exactly), and in `slip_residual` the largest roller-contact residual of the
    /// step (m/s, rounding level).
    pub trial: Trial,
    /// Platform tilt at each sample, rad.
    pub tilt: Vec<f64>,
    /// The platform's z axis in the world frame at each sample (the tilt's direction).
    pub platform_z: Vec<[f64; 3]>,
    /// The platform's attitude at each sample: roll and pitch of its orientation
    /// `Q = Rz(ψ) Ry(pitch) Rx(roll)` and its angular velocity in its own frame, what the IMU
    /// of [`crate::sensors::emit_with_attitude`] is mounted on.
    pub attitude: Vec<PlatformAttitude>,
    /// Shell spin `Ω3` at each sample, rad/s.
    pub shell_spin: Vec<f64>,
    /// Largest tilt over the run, rad.
    pub max_tilt: f64,
    /// Pull-out events per motor over the run.
    pub pull_outs: [u64; 3],
    /// Largest |motor torque| per motor over the run, N·m.
    pub peak_torque: [f64; 3],
    /// Contact events counted over the run (roller slips, lift-offs, floor slides, lost
    /// steps).
    pub contact_events: ContactEvents,
    /// Each contact event with the time of the plan step in which it began, in time order.
    pub contact_log: Vec<ContactEvent>,
    /// Smallest roller normal force per wheel over the run, N (0 = the wheel lifted; negative
    /// only with rigid contacts, where no wheel may lift).
    pub min_normal: [f64; 3],
}

/// What happened at a contact ([`ContactEvent::kind`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactEventKind {
    /// A roller started sliding on the shell (its force reached `μ N`).
    RollerSlip,
    /// A wheel lost contact with the shell (its normal force reached 0).
    LiftOff,
    /// The shell started sliding on the floor (the floor force the rolling shell needed left
    /// the friction cone `μ_f`).
    FloorSlip,
    /// A stepper lost this many full steps during the plan step (`motor = "stepper"`).
    LostSteps(u64),
}

/// One contact event of a [`DynamicTrial`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactEvent {
    /// End time of the plan step in which it began, s.
    pub t: f64,
    /// The wheel (0, 1, 2); 0 for a floor event.
    pub wheel: usize,
    /// What happened.
    pub kind: ContactEventKind,
}

/// Runs `plan` (a three-wheel `sphere-omni` plan) through the dynamic model with `params`.
/// The robot starts at rest at the plan's first pose, level; over each plan interval the
/// motors ramp linearly to the next sample's wheel rates (so a full-speed start is a ramp over
/// the first interval, as fast as the pull-out torque allows). Deterministic.
///
/// # Errors
/// [`DynamicsError::Parameter`] for invalid parameters; [`DynamicsError::Input`] for a plan
/// that is not for three wheels, whose sample times do not increase by at most 1 s, or when
/// the state diverges.
pub fn simulate_plan(params: SphereDynamics, plan: &Plan) -> Result<DynamicTrial, DynamicsError> {
    if plan.wheels != 3 || plan.samples.is_empty() {
        return Err(DynamicsError::Input {
            what: "plan.wheels",
            value: plan.wheels as f64,
            rule: "the sphere's dynamic model needs a non-empty plan for its three wheels",
        });
    }
    let s0 = &plan.samples[0];
    let start = SphereState {
        t: s0.t,
        ..SphereState::at_rest(s0.pose.x, s0.pose.y, s0.pose.heading)
    };
    let mut sim = SphereSim::with_state(params, start)?;
    let n = plan.samples.len();
    let mut trial = Trial::with_capacity(3, n);
    let mut tilt = Vec::with_capacity(n);
    let mut platform_z = Vec::with_capacity(n);
    let mut attitude = Vec::with_capacity(n);
    let mut shell_spin = Vec::with_capacity(n);
    let mut peak_torque = [0.0f64; 3];
    let mut min_normal = [f64::INFINITY; 3];
    let mut contact_log = Vec::new();
    let mut heading = s0.pose.heading;
    let record =
        |trial: &mut Trial, t: f64, centre: [f64; 2], tracked, heading, angles: [f64; 3], res| {
            let mut w = [0.0; MAX_WHEELS];
            w[..3].copy_from_slice(&angles);
            trial.t.push(t);
            trial.pose.push(Pose2::new(centre[0], centre[1], heading));
            trial.tracked.push(tracked);
            trial.slip_residual.push(res);
            trial.wheel_angles.push(w);
            trial.encoder_angles.push(w);
            trial.steer_angles.push([0.0; MAX_WHEELS]);
        };
    let st = sim.state();
    // The simulator unwraps from its wrapped start yaw; the plan's heading may start anywhere.
    let h_off = s0.pose.heading - st.yaw();
    let k = st.platform_z();
    let zt = params.tracked_height - params.geometry.shell_radius;
    record(
        &mut trial,
        s0.t,
        st.centre,
        [st.centre[0] + zt * k.x, st.centre[1] + zt * k.y],
        heading,
        st.wheel_angles,
        0.0,
    );
    tilt.push(st.tilt());
    platform_z.push(k.into());
    attitude.push(PlatformAttitude::of(&st));
    shell_spin.push(st.shell_rate.z);
    for w in plan.samples.windows(2) {
        let r = w[1].wheel_rates;
        let step = sim.step(w[1].t - w[0].t, [r[0], r[1], r[2]])?;
        heading = step.heading + h_off;
        for i in 0..3 {
            peak_torque[i] = peak_torque[i].max(step.peak_torque[i]);
            min_normal[i] = min_normal[i].min(step.min_normal[i]);
            let t = w[1].t;
            if step.roller_slip[i] {
                contact_log.push(ContactEvent {
                    t,
                    wheel: i,
                    kind: ContactEventKind::RollerSlip,
                });
            }
            if step.lift_off[i] {
                contact_log.push(ContactEvent {
                    t,
                    wheel: i,
                    kind: ContactEventKind::LiftOff,
                });
            }
            if step.lost_steps[i] > 0 {
                contact_log.push(ContactEvent {
                    t,
                    wheel: i,
                    kind: ContactEventKind::LostSteps(step.lost_steps[i]),
                });
            }
        }
        if step.floor_slip {
            contact_log.push(ContactEvent {
                t: w[1].t,
                wheel: 0,
                kind: ContactEventKind::FloorSlip,
            });
        }
        let res = sim
            .residuals()
            .rollers
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        record(
            &mut trial,
            w[1].t,
            step.centre,
            step.tracked,
            heading,
            sim.state().wheel_angles,
            res,
        );
        tilt.push(step.tilt);
        platform_z.push(step.platform_z);
        attitude.push(PlatformAttitude::of(&sim.state()));
        shell_spin.push(step.shell_spin);
    }
    let max_tilt = tilt.iter().cloned().fold(0.0, f64::max);
    Ok(DynamicTrial {
        trial,
        tilt,
        platform_z,
        attitude,
        shell_spin,
        max_tilt,
        pull_outs: sim.pull_outs(),
        peak_torque,
        contact_events: sim.contact_events(),
        contact_log,
        min_normal,
    })
}
