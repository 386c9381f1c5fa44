//! The integrator: [`SphereSim`] advances the shell + platform by fixed RK4 sub-steps with the
//! motors' commanded rates ramped linearly over each step, projects the velocities back onto
//! the wheel constraints after every sub-step, switches a motor to slipping when its torque
//! would exceed the pull-out torque (and back when it has caught up), and reports what a
//! tracker, the IMU and the motors would see ([`SphereStep`]).

use omnikin::nalgebra::{UnitQuaternion, Vector2, Vector3};
use omnikin::sphere::SphereOmni;
use omnikin::wrap_angle;

use super::equations::{Drive, Floor, Model, Singular, Y};
use super::params::{DynamicsError, SphereDynamics};
use super::stepper::Stepper;

/// The physical state of the robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereState {
    /// Time, s.
    pub t: f64,
    /// Platform orientation: rotation from the platform frame to the world frame.
    pub orientation: UnitQuaternion<f64>,
    /// Platform angular velocity `ω`, world frame, rad/s.
    pub platform_rate: Vector3<f64>,
    /// Shell angular velocity `Ω`, world frame, rad/s (`Ω_z` = the shell spin `Ω3`).
    pub shell_rate: Vector3<f64>,
    /// Shell centre `(x, y)` on the floor, world frame, m (its height is `R`).
    pub centre: [f64; 2],
    /// Wheel angles relative to the platform (what an encoder on each motor shaft reads), rad.
    pub wheel_angles: [f64; 3],
}

impl SphereState {
    /// At rest, platform level, shell centre at `(x, y)` (m), platform heading `heading` (rad).
    pub fn at_rest(x: f64, y: f64, heading: f64) -> Self {
        Self {
            t: 0.0,
            orientation: UnitQuaternion::from_euler_angles(0.0, 0.0, heading),
            platform_rate: Vector3::zeros(),
            shell_rate: Vector3::zeros(),
            centre: [x, y],
            wheel_angles: [0.0; 3],
        }
    }

    /// The platform's z axis in the world frame.
    pub fn platform_z(&self) -> Vector3<f64> {
        self.orientation * Vector3::z()
    }

    /// Platform tilt: angle between its z axis and the world vertical, rad.
    pub fn tilt(&self) -> f64 {
        let k = self.platform_z();
        k.x.hypot(k.y).atan2(k.z)
    }

    /// Platform yaw (heading ψ): the z–y–x yaw of its orientation, rad in (−π, π].
    pub fn yaw(&self) -> f64 {
        let m = self.orientation.to_rotation_matrix();
        m[(1, 0)].atan2(m[(0, 0)])
    }
}

/// What one [`SphereSim::step`] reports, at the end of the step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereStep {
    /// Time, s.
    pub t: f64,
    /// Shell centre (= floor contact) `(x, y)`, world frame, m.
    pub centre: [f64; 2],
    /// The tracked point (top of the platform, [`SphereDynamics::tracked_height`] above the
    /// floor contact when level) projected on the floor, world frame, m: what a video tracker
    /// above the robot sees.
    pub tracked: [f64; 2],
    /// Platform heading ψ, unwrapped (continuous), rad.
    pub heading: f64,
    /// Platform yaw rate `ω_z` (world vertical component), rad/s: what the gyro's z axis reads
    /// with the platform level.
    pub yaw_rate: f64,
    /// Platform tilt from the vertical, rad.
    pub tilt: f64,
    /// The platform's z axis in the world frame (the direction of the tilt).
    pub platform_z: [f64; 3],
    /// Shell spin about the vertical `Ω3 = Ω·γ`, rad/s.
    pub shell_spin: f64,
    /// Actual wheel rates relative to the platform, rad/s.
    pub wheel_rates: [f64; 3],
    /// Motor torques at the last sub-step, N·m (right-handed about each wheel axis `n_i`).
    pub wheel_torques: [f64; 3],
    /// Largest |motor torque| over the step's sub-steps, N·m.
    pub peak_torque: [f64; 3],
    /// The motor reached its pull-out torque during this step (started slipping).
    pub pull_out: [bool; 3],
    /// The motor is slipping at the end of the step (not at its commanded rate).
    pub slipping: [bool; 3],
    /// Roller normal forces `N_i` at the last sub-step, N (the shell pushing the wheel towards
    /// its centre; 0 while the wheel is lifted, never negative with finite `roller_friction`).
    pub normal_forces: [f64; 3],
    /// Smallest roller normal force over the step's sub-steps, N.
    pub min_normal: [f64; 3],
    /// A roller started sliding on the shell during this step (its force reached `μ N`).
    pub roller_slip: [bool; 3],
    /// A wheel lost contact with the shell during this step (its normal force reached 0).
    pub lift_off: [bool; 3],
    /// The roller is sliding on the shell at the end of the step.
    pub sliding: [bool; 3],
    /// The wheel is off the shell at the end of the step.
    pub lifted: [bool; 3],
    /// Work done on shell + platform over the step by the wheel forces (motors through
    /// sticking rollers, sliding rollers' friction, the sticking impulses that relock a
    /// sliding roller), J.
    pub contact_work: f64,
    /// Work done over the step by the floor (pivot friction, rolling resistance, the sliding
    /// shell's Coulomb force and the impulse that makes it roll again), J.
    pub floor_work: f64,
    /// Energy the shell sliding on the floor dissipated over the step, J (≥ 0; part of
    /// `floor_work`, with the opposite sign).
    pub floor_slide_work: f64,
    /// Largest ratio of horizontal to vertical floor force over the step (the friction
    /// coefficient the floor must supply to keep the shell rolling).
    pub floor_ratio: f64,
    /// The shell started sliding on the floor during this step: the floor force the rolling
    /// shell needed left the friction cone `μ_f` (from then on the floor's horizontal force is
    /// the Coulomb force `μ_f N`, until the slip stops).
    pub floor_slip: bool,
    /// The shell is sliding on the floor at the end of the step.
    pub floor_sliding: bool,
    /// Mechanical work the motors delivered to their rotors over the step, J (for a sliding
    /// roller the rotor turns at the commanded rate; see `slip_work`).
    pub motor_work: f64,
    /// Energy the sliding rollers dissipated over the step, J (≥ 0): with steppers
    /// `ΔE = motor_work − slip_work + floor_work`.
    pub slip_work: f64,
    /// Full steps each stepper lost during this step (0 with `motor = "rate"`).
    pub lost_steps: [u64; 3],
}

/// Contact events so far, per wheel (see [`SphereSim::contact_events`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ContactEvents {
    /// Times each roller started sliding on the shell.
    pub roller_slips: [u64; 3],
    /// Times each wheel lost contact with the shell.
    pub lift_offs: [u64; 3],
    /// Times the shell started sliding on the floor (the floor force the rolling shell needed
    /// left the friction cone `μ_f`).
    pub floor_slips: u64,
    /// Full steps each stepper lost (4 per electrical cycle its rotor slipped against the
    /// field; always 0 with `motor = "rate"`, whose motors resynchronise).
    pub lost_steps: [u64; 3],
}

/// Constraint residuals of the current state (see [`SphereSim::residuals`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Residuals {
    /// |velocity of the shell's floor-contact point| `|v + Ω × (−R γ)|`, m/s: 0 while the
    /// shell rolls, its slip speed while it slides.
    pub floor: f64,
    /// Per wheel, with its motor holding the commanded rate: the velocity mismatch along the
    /// roller axis `α_i` between the wheel's and the shell's material at the contact
    /// (paper 000 eq. 4.4 times `1/(R − R_i)`), m/s; 0 for a slipping or free wheel.
    pub rollers: [f64; 3],
}

/// The shell + platform dynamic model, stepped in time. Deterministic (a fixed sequence of
/// floating-point operations per call, no threads) and allocation-free per step.
#[derive(Clone, Debug)]
pub struct SphereSim {
    params: SphereDynamics,
    model: Model,
    kin: SphereOmni<f64>,
    y: Y,
    t: f64,
    /// Commanded wheel rates in force now (the end of the last ramp), rad/s.
    command: [f64; 3],
    drive: [Drive; 3],
    /// The shell rolling or sliding on the floor.
    floor: Floor,
    heading: f64,
    pull_outs: [u64; 3],
    events: ContactEvents,
    /// Steppers only: the commanded (field) angle of each motor, rad.
    field: [f64; 3],
    /// Steppers only: rotor angle minus the wheel angle `χ_i`, rad (moved by roller slides and
    /// lift-offs, when the rotor turns without the shell).
    offset: [f64; 3],
    /// Steppers only: the electrical cycle each rotor sits in against its field.
    cycle: [i64; 3],
}

impl SphereSim {
    /// The robot at rest at the origin, platform level, heading 0, motors holding 0 rad/s.
    ///
    /// # Errors
    /// [`DynamicsError`] naming the first invalid parameter.
    pub fn new(params: SphereDynamics) -> Result<Self, DynamicsError> {
        Self::with_state(params, SphereState::at_rest(0.0, 0.0, 0.0))
    }

    /// The robot in `state`, motors powered and holding the wheel rates that state implies.
    ///
    /// # Errors
    /// [`DynamicsError`] naming the first invalid parameter or a non-finite state value.
    pub fn with_state(params: SphereDynamics, state: SphereState) -> Result<Self, DynamicsError> {
        let (model, kin) = Model::new(&params)?;
        let q = state.orientation.into_inner();
        let vals = [
            ("state.t", state.t),
            ("state.orientation", q.norm()),
            ("state.platform_rate", state.platform_rate.norm()),
            ("state.shell_rate", state.shell_rate.norm()),
            ("state.centre[0]", state.centre[0]),
            ("state.centre[1]", state.centre[1]),
        ];
        for (what, value) in vals {
            if !value.is_finite() {
                return Err(DynamicsError::Input {
                    what,
                    value,
                    rule: "must be finite",
                });
            }
        }
        let y = Y {
            q,
            w: state.platform_rate,
            big_w: state.shell_rate,
            p: Vector2::from(state.centre),
            chi: Vector3::from(state.wheel_angles),
            v: Vector2::zeros(),
        };
        let mut sim = Self {
            params,
            model,
            kin,
            y,
            t: state.t,
            command: [0.0; 3],
            drive: [Drive::Locked; 3],
            floor: Floor::Roll,
            heading: state.yaw(),
            pull_outs: [0; 3],
            events: ContactEvents::default(),
            field: state.wheel_angles,
            offset: [0.0; 3],
            cycle: [0; 3],
        };
        sim.y.v = sim.model.centre_velocity(&sim.y.big_w);
        sim.command = sim.model.wheel_rates(&sim.y);
        sim.drive = [sim.stick(0); 3];
        Ok(sim)
    }

    /// The mode of wheel `i` whose roller sticks to the shell: its motor holding the
    /// commanded rate, or the stepper's torque–angle law.
    fn stick(&self, i: usize) -> Drive {
        if self.model.stepper.is_some() {
            Drive::Stepper(self.offset[i])
        } else {
            Drive::Locked
        }
    }

    /// The parameters.
    pub fn params(&self) -> &SphereDynamics {
        &self.params
    }

    /// The kinematic model of the same geometry (paper 000 §4–5).
    pub fn kinematics(&self) -> &SphereOmni<f64> {
        &self.kin
    }

    /// The current state.
    pub fn state(&self) -> SphereState {
        SphereState {
            t: self.t,
            orientation: UnitQuaternion::from_quaternion(self.y.q),
            platform_rate: self.y.w,
            shell_rate: self.y.big_w,
            centre: self.y.p.into(),
            wheel_angles: core::array::from_fn(|i| self.y.chi[i] + self.offset[i]),
        }
    }

    /// Total mechanical energy (kinetic + the platform's potential, zero at the shell centre's
    /// height), J.
    pub fn energy(&self) -> f64 {
        match self.floor {
            Floor::Roll => self.model.energy(&self.y),
            Floor::Slide(..) => self.model.energy8(&self.model.frame(&self.y.q), &self.y),
        }
    }

    /// The shell is sliding on the floor.
    pub fn floor_sliding(&self) -> bool {
        matches!(self.floor, Floor::Slide(..))
    }

    /// Pull-out events so far per motor (times it started slipping).
    pub fn pull_outs(&self) -> [u64; 3] {
        self.pull_outs
    }

    /// Roller-slip, lift-off and floor-slip events so far.
    pub fn contact_events(&self) -> ContactEvents {
        self.events
    }

    /// The commanded wheel rates in force now, rad/s.
    pub fn command(&self) -> [f64; 3] {
        self.command
    }

    /// The constraint residuals of the current state.
    pub fn residuals(&self) -> Residuals {
        let m = &self.model;
        let big_w = self.y.big_w;
        let v = match self.floor {
            Floor::Roll => m.centre_velocity(&big_w),
            Floor::Slide(..) => self.y.v,
        };
        let contact = Vector3::new(v.x, v.y, 0.0) + big_w.cross(&Vector3::new(0.0, 0.0, -m.r));
        let f = m.frame(&self.y.q);
        let u = self.y.u();
        let rollers = core::array::from_fn(|i| {
            if self.drive[i] == Drive::Locked {
                m.r * (m.kappa[i] * self.command[i] - f.rows[i].dot(&u)) / m.lever[i]
            } else {
                0.0
            }
        });
        Residuals {
            floor: contact.norm(),
            rollers,
        }
    }

    /// Advances by `dt` (s) with the motors commanded to reach the wheel rates `wheel_rates`
    /// (rad/s, right-handed about `n_i`, paper 000 §4) at the end of the step, ramping
    /// linearly from the rates in force (first-order hold, like the kinematic plant's
    /// interpolation between plan samples). A motor whose torque would exceed the pull-out
    /// torque slips (delivers the pull-out torque) until its rotor is back at the commanded
    /// rate.
    ///
    /// # Errors
    /// [`DynamicsError::Input`] for a non-positive or non-finite `dt` or a non-finite rate, or
    /// when the state stops being finite.
    pub fn step(&mut self, dt: f64, wheel_rates: [f64; 3]) -> Result<SphereStep, DynamicsError> {
        check_dt(dt)?;
        const NAMES: [&str; 3] = ["wheel_rates[0]", "wheel_rates[1]", "wheel_rates[2]"];
        for i in 0..3 {
            if !wheel_rates[i].is_finite() {
                return Err(DynamicsError::Input {
                    what: NAMES[i],
                    value: wheel_rates[i],
                    rule: "must be finite",
                });
            }
        }
        self.integrate(dt, Some(wheel_rates))
    }

    /// Advances by `dt` (s) with the motors unpowered: every wheel turns freely, the platform
    /// and the shell exchange no torque (the wheel contacts' normal forces pass through the
    /// shell centre). The next [`SphereSim::step`] ramps from the wheel rates at the end.
    ///
    /// # Errors
    /// As [`SphereSim::step`].
    pub fn coast(&mut self, dt: f64) -> Result<SphereStep, DynamicsError> {
        check_dt(dt)?;
        self.integrate(dt, None)
    }

    fn integrate(
        &mut self,
        dt: f64,
        target: Option<[f64; 3]>,
    ) -> Result<SphereStep, DynamicsError> {
        let n = (dt / self.params.max_substep).ceil().max(1.0);
        let h = dt / n;
        let start = self.command;
        let slope: [f64; 3] = match target {
            Some(r) => core::array::from_fn(|i| (r[i] - start[i]) / dt),
            None => [0.0; 3],
        };
        if target.is_none() {
            self.drive = [Drive::Force(0.0); 3];
        }
        let tau_max = self.params.pull_out_torque;
        let stepper: Option<Stepper> = self.model.stepper;
        let kappa = self.model.kappa;
        let (mu, lever, r) = (self.model.mu, self.model.lever, self.model.r);
        let contacts = mu.is_finite() && target.is_some();
        let mut pull_out = [false; 3];
        let mut roller_slip = [false; 3];
        let mut lift_off = [false; 3];
        let mut peak = [0.0f64; 3];
        let mut torque = [0.0f64; 3];
        let mut normal = [0.0f64; 3];
        let mut min_normal = [f64::INFINITY; 3];
        let (mut contact_work, mut floor_work) = (0.0, 0.0);
        let (mut motor_work, mut slip_work) = (0.0, 0.0);
        let mut lost = [0u64; 3];
        let field0 = self.field;
        let mut floor_ratio = 0.0f64;
        let mu_floor = self.model.mu_floor;
        let floor_on = mu_floor.is_finite();
        let mut floor_slip = false;
        let mut floor_slide_work = 0.0;
        let diverged = |_: Singular| DynamicsError::Input {
            what: "state",
            value: f64::NAN,
            rule: "the simulation diverged (state no longer finite)",
        };
        let cmd_at = |t: f64| -> [f64; 3] { core::array::from_fn(|i| start[i] + slope[i] * t) };
        // The commanded angle: the integral of the ramped rate.
        let field_at = |t: f64| -> [f64; 3] {
            core::array::from_fn(|i| field0[i] + start[i] * t + 0.5 * slope[i] * t * t)
        };
        for j in 0..n as u64 {
            let t0 = j as f64 * h;
            let t_end = (j + 1) as f64 * h;
            let c0 = cmd_at(t0);
            let a0 = field_at(t0);
            let mut k1 = self
                .model
                .derivative(&self.y, &self.drive, &a0, &c0, &slope, &self.floor)
                .map_err(diverged)?;
            if target.is_some() || floor_on {
                // Contacts first (the shell slides on the floor, a roller slides or a wheel
                // lifts at the contact's limit), then the motor's pull-out torque; re-solved
                // until the modes agree with the forces.
                for _ in 0..4 {
                    let mut changed = false;
                    // A sliding roller's normal force followed the state: k1 must be redone.
                    let mut dirty = false;
                    // The sliding shell's frozen normal force is iterated to the one its own
                    // friction force gives (a fixed point, in the mode loop's passes).
                    let mut floor_moved = false;
                    if floor_on {
                        let ff = k1.floor_force;
                        match self.floor {
                            Floor::Roll if k1.floor_ratio > mu_floor => {
                                // The rolling shell needs more than μ_f N: it slides, the
                                // floor's force in the direction of the force it needed.
                                let fh = Vector2::new(ff.x, ff.y);
                                let n = fh.norm();
                                let dir = if n > 0.0 { fh / n } else { Vector2::x() };
                                self.floor = Floor::Slide(ff.z.max(0.0), dir);
                                floor_slip = true;
                                self.events.floor_slips += 1;
                                changed = true;
                            }
                            Floor::Slide(old, dir) => {
                                // The normal force and the slip's direction follow the state
                                // (frozen within the sub-step); not a change of mode.
                                let vs = self.model.floor_slip_velocity(&self.y);
                                let sn = vs.norm();
                                let dir_now = if sn > 1e-12 { -vs / sn } else { dir };
                                let n = ff.z.max(0.0);
                                if n != old || dir_now != dir {
                                    self.floor = Floor::Slide(n, dir_now);
                                    dirty = true;
                                    floor_moved = (n - old).abs() > 1e-9 * n.max(1.0);
                                }
                            }
                            _ => {}
                        }
                    }
                    for i in 0..3 {
                        if target.is_none() {
                            break;
                        }
                        let (l, nf) = (k1.lambda[i], k1.normal[i]);
                        let f_roller = l.abs() * lever[i] / r;
                        let motor_limit = match &stepper {
                            Some(st) => st.pull_out(c0[i]),
                            None => tau_max,
                        } / kappa[i].abs();
                        match self.drive[i] {
                            Drive::Locked | Drive::Force(_) | Drive::Stepper(_)
                                if contacts && nf <= 0.0 =>
                            {
                                self.drive[i] = Drive::Lifted;
                                lift_off[i] = true;
                                self.events.lift_offs[i] += 1;
                                changed = true;
                            }
                            Drive::Locked | Drive::Force(_) | Drive::Stepper(_)
                                if contacts
                                    && f_roller > mu * nf
                                    && mu * nf * r / lever[i] <= motor_limit =>
                            {
                                self.drive[i] = Drive::Slip(nf, l.signum());
                                roller_slip[i] = true;
                                self.events.roller_slips[i] += 1;
                                changed = true;
                            }
                            Drive::Locked if (kappa[i] * l).abs() > tau_max => {
                                self.drive[i] = Drive::Force(l.signum() * motor_limit);
                                pull_out[i] = true;
                                self.pull_outs[i] += 1;
                                changed = true;
                            }
                            Drive::Slip(..) if nf <= 0.0 => {
                                self.drive[i] = Drive::Lifted;
                                lift_off[i] = true;
                                self.events.lift_offs[i] += 1;
                                changed = true;
                            }
                            Drive::Slip(old, dir) if old != nf => {
                                // The sliding roller's normal force follows the state (frozen
                                // within the sub-step); not a change of mode.
                                self.drive[i] = Drive::Slip(nf, dir);
                                dirty = true;
                            }
                            Drive::Lifted if nf > 0.0 => {
                                // Back on the shell: the roller lands sliding against the slip
                                // it built up while free, and sticks once that is gone.
                                let f = self.model.frame(&self.y.q);
                                let v = self.model.slip_velocity(i, &f.rows[i], &self.y.u(), c0[i]);
                                let mut trial = self.drive;
                                trial[i] = if v == 0.0 {
                                    self.stick(i)
                                } else {
                                    Drive::Slip(nf, v.signum())
                                };
                                // Only if the landed wheel stays loaded (its own friction
                                // force can unload it again): no lift/land chatter.
                                let landed = self
                                    .model
                                    .derivative(&self.y, &trial, &a0, &c0, &slope, &self.floor)
                                    .map_err(diverged)?;
                                if landed.normal[i] > 0.0 {
                                    self.drive = trial;
                                    changed = true;
                                }
                            }
                            _ => {}
                        }
                    }
                    // Nothing changed: k1 is already the derivative in these modes.
                    if !(changed || dirty) {
                        break;
                    }
                    k1 = self
                        .model
                        .derivative(&self.y, &self.drive, &a0, &c0, &slope, &self.floor)
                        .map_err(diverged)?;
                    if !(changed || floor_moved) {
                        break;
                    }
                }
            }
            for i in 0..3 {
                torque[i] = kappa[i] * k1.lambda[i];
                peak[i] = peak[i].max(torque[i].abs());
                // A lifted wheel carries no normal force (what the centred platform would need
                // from it is not a force the contact applies).
                normal[i] = if self.drive[i] == Drive::Lifted {
                    0.0
                } else {
                    k1.normal[i]
                };
                min_normal[i] = min_normal[i].min(normal[i]);
            }
            floor_ratio = floor_ratio.max(k1.floor_ratio);
            let d = &self.drive;
            let fl = &self.floor;
            let cm = cmd_at(t0 + 0.5 * h);
            let c1 = cmd_at(t_end);
            let (am, a1) = (field_at(t0 + 0.5 * h), field_at(t_end));
            let k2 = self
                .model
                .derivative(&self.y.add(&k1.d, 0.5 * h), d, &am, &cm, &slope, fl)
                .map_err(diverged)?;
            let k3 = self
                .model
                .derivative(&self.y.add(&k2.d, 0.5 * h), d, &am, &cm, &slope, fl)
                .map_err(diverged)?;
            let k4 = self
                .model
                .derivative(&self.y.add(&k3.d, h), d, &a1, &c1, &slope, fl)
                .map_err(diverged)?;
            let mut y = self.y.add(&k1.d, h / 6.0);
            y = y.add(&k2.d, h / 3.0);
            y = y.add(&k3.d, h / 3.0);
            y = y.add(&k4.d, h / 6.0);
            // The work over the sub-step by the same quadrature as the state's.
            contact_work += h / 6.0
                * (k1.contact_power
                    + 2.0 * k2.contact_power
                    + 2.0 * k3.contact_power
                    + k4.contact_power);
            floor_work += h / 6.0
                * (k1.floor_power + 2.0 * k2.floor_power + 2.0 * k3.floor_power + k4.floor_power);
            floor_slide_work += h / 6.0
                * (k1.floor_slide_power
                    + 2.0 * k2.floor_slide_power
                    + 2.0 * k3.floor_slide_power
                    + k4.floor_slide_power);
            motor_work += h / 6.0
                * (k1.motor_power + 2.0 * k2.motor_power + 2.0 * k3.motor_power + k4.motor_power);
            slip_work += h / 6.0
                * (k1.slip_power + 2.0 * k2.slip_power + 2.0 * k3.slip_power + k4.slip_power);
            y.q = y.q.normalize();
            if !(y
                .q
                .coords
                .iter()
                .chain(y.w.iter())
                .chain(y.big_w.iter())
                .chain(y.p.iter())
                .chain(y.v.iter()))
            .all(|v| v.is_finite())
            {
                return Err(diverged(Singular("state")));
            }
            let cmd: [f64; 3] = match target {
                Some(_) => c1,
                None => self.model.wheel_rates(&y),
            };
            if let Floor::Slide(_, dir) = self.floor {
                // The sliding shell rolls again once its slip velocity no longer opposes the
                // friction force: the floor's sticking impulse, whose work is the floor's.
                if self.model.floor_slip_velocity(&y).dot(&dir) >= 0.0 {
                    let f = self.model.frame(&y.q);
                    let e0 = self.model.energy8(&f, &y);
                    self.model.stick_floor(&f, &mut y).map_err(diverged)?;
                    floor_work += self.model.energy8(&f, &y) - e0;
                    self.floor = Floor::Roll;
                }
            }
            if target.is_some() {
                // One frame for the end of the sub-step: the projection changes only `u`.
                let f = self.model.frame(&y.q);
                let u = y.u();
                let actual: [f64; 3] = core::array::from_fn(|i| f.rows[i].dot(&u) / kappa[i]);
                for i in 0..3 {
                    match self.drive[i] {
                        // A slipping motor locks again once its rotor has caught up.
                        Drive::Force(l) if (actual[i] - cmd[i]) * kappa[i] * l.signum() >= 0.0 => {
                            self.drive[i] = Drive::Locked;
                        }
                        // A sliding roller sticks again once its slip velocity has come to 0.
                        Drive::Slip(_, dir)
                            if self.model.slip_velocity(i, &f.rows[i], &u, cmd[i]) * dir <= 0.0 =>
                        {
                            self.drive[i] = Drive::Locked;
                        }
                        _ => {}
                    }
                }
                if let Some(st) = &stepper {
                    self.stepper_bookkeeping(st, &y, &k1.lambda, &a1, &c1, &mut lost);
                }
                // The projection is the sticking contacts' impulse: its work is theirs.
                if self.drive.contains(&Drive::Locked) {
                    if self.floor == Floor::Roll {
                        let e0 = self.model.energy_in(&f, &y);
                        self.model
                            .project(&f, &mut y, &self.drive, &cmd)
                            .map_err(diverged)?;
                        contact_work += self.model.energy_in(&f, &y) - e0;
                    } else {
                        let e0 = self.model.energy8(&f, &y);
                        self.model
                            .project8(&f, &mut y, &self.drive, &cmd)
                            .map_err(diverged)?;
                        contact_work += self.model.energy8(&f, &y) - e0;
                    }
                }
            }
            if self.floor == Floor::Roll {
                // Rolling: the centre velocity is the constraint's.
                y.v = self.model.centre_velocity(&y.big_w);
            }
            self.y = y;
            self.command = cmd;
        }
        if target.is_none() {
            self.command = self.model.wheel_rates(&self.y);
            // The steppers are powered again where their rotors are (the driver's field starts
            // at the rotor's pole).
            for i in 0..3 {
                self.field[i] = self.y.chi[i] + self.offset[i];
                self.cycle[i] = 0;
            }
            self.drive = core::array::from_fn(|i| self.stick(i));
        } else if let Some(r) = target {
            // Exactly the commanded rates (the ramp's end, without rounding of the sum).
            self.command = r;
            self.field = field_at(dt);
        }
        self.t += dt;
        let st = self.state();
        self.heading += wrap_angle(st.yaw() - wrap_angle(self.heading));
        let k = st.platform_z();
        let zt = self.model.z_track;
        Ok(SphereStep {
            t: self.t,
            centre: st.centre,
            tracked: [st.centre[0] + zt * k.x, st.centre[1] + zt * k.y],
            heading: self.heading,
            yaw_rate: self.y.w.z,
            tilt: st.tilt(),
            platform_z: k.into(),
            shell_spin: self.y.big_w.z,
            wheel_rates: self.model.wheel_rates(&self.y),
            wheel_torques: torque,
            peak_torque: peak,
            pull_out,
            slipping: core::array::from_fn(|i| matches!(self.drive[i], Drive::Force(_))),
            normal_forces: normal,
            min_normal,
            roller_slip,
            lift_off,
            sliding: core::array::from_fn(|i| matches!(self.drive[i], Drive::Slip(..))),
            lifted: core::array::from_fn(|i| self.drive[i] == Drive::Lifted),
            contact_work,
            floor_work,
            floor_slide_work,
            floor_ratio,
            floor_slip,
            floor_sliding: self.floor_sliding(),
            motor_work,
            slip_work,
            lost_steps: lost,
        })
    }

    /// After a sub-step with steppers: moves each rotor that did not turn with its wheel
    /// (a sliding roller's rotor follows its field at the lag that carries the friction, a
    /// lifted wheel's sits at its field's pole), returns a sliding roller to the stepper's law
    /// when it sticks again, and counts the electrical cycles each rotor slipped.
    fn stepper_bookkeeping(
        &mut self,
        st: &Stepper,
        y: &Y,
        lambda: &[f64; 3],
        field: &[f64; 3],
        rate: &[f64; 3],
        lost: &mut [u64; 3],
    ) {
        for i in 0..3 {
            match self.drive[i] {
                // Still sliding, or (`Locked`: the relocking above) stuck again at the end of
                // this sub-step, when it returns to the torque–angle law from the same lag.
                Drive::Slip(..) | Drive::Locked => {
                    let lag = st.lag_for(self.model.kappa[i] * lambda[i], rate[i]);
                    self.offset[i] = field[i] + lag - y.chi[i];
                    self.cycle[i] = 0;
                    if self.drive[i] == Drive::Locked {
                        self.drive[i] = Drive::Stepper(self.offset[i]);
                    }
                }
                Drive::Lifted => {
                    self.offset[i] = field[i] - y.chi[i];
                    self.cycle[i] = 0;
                }
                _ => {}
            }
            let c = st.cycle(y.chi[i] + self.offset[i] - field[i]);
            let slipped = c.abs_diff(self.cycle[i]);
            if slipped > 0 {
                lost[i] += 4 * slipped;
                self.events.lost_steps[i] += 4 * slipped;
                self.cycle[i] = c;
            }
        }
    }
}

fn check_dt(dt: f64) -> Result<(), DynamicsError> {
    if dt.is_finite() && dt > 0.0 && dt <= 1.0 {
        Ok(())
    } else {
        Err(DynamicsError::Input {
            what: "dt",
            value: dt,
            rule: "must be in (0, 1] s",
        })
    }
}
