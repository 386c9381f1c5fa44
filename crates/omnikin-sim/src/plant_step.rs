//! The one plant step: what the motors actually turned through → how the robot actually
//! moved. Both the open-loop simulator ([`crate::simulate_trial`]) and software in the loop
//! ([`crate::sil::SilPlant`]) move the true robot only through [`Plant::step`], so for the
//! same motor set-points, profile and seed they produce the same true trajectory.
//!
//! [`Plant`] holds the true state of a simulated robot (world pose, robot-frame twist, steer
//! angles of a steerable kind and slip residual) and the per-trial disturbances of a [`Profile`] that act
//! between the motors and the floor. [`Plant::step`] takes the motors' **actual** motion over
//! one plant step ([`MotorMotion`]: the output of the motor models, i.e. after lag,
//! acceleration limit, fluctuation, bias and stepper quantisation) and, in this order:
//!
//! 1. turns each wheel's mean actual rate `Δq/dt` into an effective rate: × its per-trial
//!    radius scale `1 + ε_i` (`wheel_motor.radius_error_std`), × the roller hand-over
//!    modulation `1 + a·cos(n·q_mid + φ_i)` at the mid-step wheel angle (`[roller]`);
//! 2. applies the robot's forward kinematics, [`Robot::forward_spin`], to get the robot-frame
//!    twist: least squares where the kind is over-determined (an omni drive of more than three
//!    wheels, the caster's six motors, a swerve's 2N wheel constraints), recording the slip
//!    residual of the fit; steerable kinds at the mid-step steer angles, with the steer rates
//!    the steer motors turned at; the rolling-ball kinds ([`omnikin::Kind::has_vertical_spin`])
//!    with the spin law below. The simulator and SIL have no kind dispatch of their own, and
//!    neither has this step: it asks the kind only whether it steers and whether it spins;
//! 3. scales the twist per axis by the floor slip `1 + e(t)`, `e` an Ornstein–Uhlenbeck
//!    process (`[floor]`);
//! 4. holds that twist over the step and advances the pose exactly on SE(2)
//!    ([`omnikin::se2::integrate`]): a constant twist traces an exact circular arc (or line)
//!    whatever the step size, so the plant rate sets only how finely the *inputs* are resolved.
//!
//! # Spin about the vertical (sphere shell, ballbot ball)
//! On both rolling-ball robots the three wheels fix only the angular velocity `ω̃` of the
//! shell (ball) **relative to the body**; how its vertical component splits into the body's
//! yaw rate `ψ̇` and the shell's (ball's) spin `Ω` about the vertical, `ψ̇ = Ω − ω̃_z`, is set by
//! the floor contact, not by the wheels. The two robots have the same chain — body, wheels,
//! shell/ball, floor: the sphere's platform touches nothing but the shell, the ballbot's body
//! nothing but the ball — so the same law holds for both:
//!
//! * **Nominal: `Ω = 0`** ("rubber rolling", paper 000's choice): the floor's pivot friction at
//!   the contact holds the shell/ball, so the wheels' yaw reaction turns the body. This is what
//!   the planner and the runtime assume (their inverse kinematics use spin 0), so the ideal
//!   plant reproduces a plan.
//! * **Disturbed: `Ω = Ω₀ + g·|V|^p·ω̃_z`**, `Ω₀` a constant drawn per trial
//!   (`shell_spin.std`), `g` and `p` = `shell_spin.slip_gain` and `slip_exponent`, `|V|` the
//!   centre's speed (m/s): the contact gives way in the direction the wheels drive the
//!   shell/ball relative to the body, more at speed (paper 000's suspected cause of its large
//!   circles at 0.4–0.5 m/s). `Ω` is passed to the kinematic model as its `shell_spin`
//!   ([`omnikin::sphere::SphereOmni::body_twist`]) or `ball_spin`
//!   ([`omnikin::ballbot::Ballbot::body_twist`]) argument, so `ψ̇ = ψ̇₀ + Ω` with `ψ̇₀` the yaw
//!   rate at zero spin.
//!
//! The other kinds (caster, omni, swerve) have no such degree of freedom and ignore
//! `[shell_spin]` (its constant is still drawn, so the random stream does not depend on the
//! kind). (Before this module
//! SIL gave the ballbot only `Ω₀`, dropping the speed-dependent term the simulator applied, so
//! with a `slip_gain` the two disagreed on the ballbot's heading.)
//!
//! `Motors` (crate-private) is the other half both callers share: the motor models turning
//! set-points into the [`MotorMotion`] this step consumes.

use omnikin::{Actuators, InputError, MAX_WHEELS, Pose2, Robot, Twist2, se2};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::motor::Motor;
use crate::profile::Profile;

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// What the motors actually did during one plant step (after the motor models), rad. Entries
/// `0..robot.wheels()` are used, the rest are zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MotorMotion {
    /// Each wheel (roll) motor's output angle at the start of the step, rad (places the roller
    /// hand-over).
    pub wheel_angle: [f64; MAX_WHEELS],
    /// Angle each wheel (roll) motor turned through during the step, rad: its mean actual rate
    /// × `dt`.
    pub wheel_turn: [f64; MAX_WHEELS],
    /// Steerable kinds ([`Robot::steerable`]): angle each steering motor turned through during
    /// the step, rad (counter-clockwise about the steering axis, relative to the body); ignored
    /// for the other kinds.
    pub steer_turn: [f64; MAX_WHEELS],
}

/// The true state of a simulated robot and the per-trial disturbances between its motors and
/// the floor (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct Plant {
    robot: Robot<f64>,
    /// True pose, world frame (m, m, rad unwrapped).
    pose: Pose2<f64>,
    /// Robot-frame twist of the last step.
    twist: Twist2<f64>,
    /// Steerable kinds: true steer angles, rad (zeros otherwise).
    steer: [f64; MAX_WHEELS],
    /// Slip residual of the last step's least-squares fit, m/s.
    slip_residual: f64,
    radius_scale: [f64; MAX_WHEELS],
    roller_amp: f64,
    rollers: f64,
    roller_phase: [f64; MAX_WHEELS],
    spin_const: f64,
    spin_gain: f64,
    spin_exp: f64,
    floor_std: f64,
    floor_tau: f64,
    floor: [f64; 3],
}

impl Plant {
    /// A plant for `robot` at the true pose `pose` (world) with steer angles `steer` (rad;
    /// steerable kinds only, ignored otherwise; entries `0..robot.wheels()` used), drawing the
    /// per-trial disturbances of `profile` from `rng` in a fixed order: one wheel-radius error
    /// per wheel, the constant spin, one roller phase per wheel, then (with floor slip) the
    /// three initial floor-slip factors (vx, vy, yaw rate).
    pub fn new(
        robot: Robot<f64>,
        profile: &Profile,
        pose: Pose2<f64>,
        steer: [f64; MAX_WHEELS],
        rng: &mut ChaCha8Rng,
    ) -> Self {
        let n = robot.wheels();
        let radius_std = profile.wheel_motor.radius_error_std.unwrap_or(0.0);
        let mut radius_scale = [1.0; MAX_WHEELS];
        for r in &mut radius_scale[..n] {
            *r = 1.0 + radius_std * gauss(rng);
        }
        let spin_const = profile.shell_spin.std.unwrap_or(0.0) * gauss(rng);
        let mut roller_phase = [0.0; MAX_WHEELS];
        for p in &mut roller_phase[..n] {
            *p = rng.random_range(0.0..core::f64::consts::TAU);
        }
        let mut steer_used = [0.0; MAX_WHEELS];
        if robot.steerable() {
            steer_used[..n].copy_from_slice(&steer[..n]);
        }
        let floor_std = profile.floor.rel_std.unwrap_or(0.0);
        let floor = if floor_std > 0.0 {
            core::array::from_fn(|_| floor_std * gauss(rng))
        } else {
            [0.0; 3]
        };
        Self {
            robot,
            pose,
            twist: Twist2::default(),
            steer: steer_used,
            slip_residual: 0.0,
            radius_scale,
            roller_amp: profile.roller.amplitude.unwrap_or(0.0),
            rollers: profile.roller.rollers.unwrap_or(8) as f64,
            roller_phase,
            spin_const,
            spin_gain: profile.shell_spin.slip_gain.unwrap_or(0.0),
            spin_exp: profile.shell_spin.slip_exponent.unwrap_or(1.0),
            floor_std,
            floor_tau: profile.floor.corr_time.unwrap_or(0.5),
            floor,
        }
    }

    /// The simulated robot.
    pub fn robot(&self) -> &Robot<f64> {
        &self.robot
    }

    /// The true pose (world frame; m, m, rad unwrapped).
    pub fn pose(&self) -> Pose2<f64> {
        self.pose
    }

    /// The true robot-frame twist of the last step (m/s, m/s, rad/s; zero before the first).
    pub fn twist(&self) -> Twist2<f64> {
        self.twist
    }

    /// Steerable kinds: the true steer angles, rad (zeros for the other kinds and past the
    /// wheel count).
    pub fn steer_angles(&self) -> [f64; MAX_WHEELS] {
        self.steer
    }

    /// Slip residual of the last step's least-squares forward kinematics, m/s (0 for kinds
    /// with as many constraints as unknowns — sphere, ballbot, 3-wheel omni — and before the
    /// first step).
    pub fn slip_residual(&self) -> f64 {
        self.slip_residual
    }

    /// Holds the robot still (an obstacle): the twist becomes zero, the pose stays.
    pub fn hold(&mut self) {
        self.twist = Twist2::default();
    }

    /// Pushes the robot: adds `delta` (world frame, m, m, rad) to the true pose (a kick no
    /// motor or encoder sees).
    pub fn push(&mut self, delta: Pose2<f64>) {
        self.pose = Pose2::new(
            self.pose.x + delta.x,
            self.pose.y + delta.y,
            self.pose.heading + delta.heading,
        );
    }

    /// **The plant step**: moves the true robot over `dt` seconds (> 0) given what the motors
    /// actually did in that time, drawing the floor slip from `rng` (see the
    /// [module docs](self) for the order of effects). Returns the robot-frame twist that was
    /// held over the step (also [`Plant::twist`]).
    ///
    /// # Errors
    /// The core's [`InputError`] when the forward kinematics reject the state (non-finite
    /// rates: the simulated motion diverged); the state is then unchanged.
    pub fn step(
        &mut self,
        motion: &MotorMotion,
        dt: f64,
        rng: &mut ChaCha8Rng,
    ) -> Result<Twist2<f64>, InputError> {
        let n = self.robot.wheels();
        let w: [f64; MAX_WHEELS] = core::array::from_fn(|i| {
            if i >= n {
                return 0.0;
            }
            let dq = motion.wheel_turn[i];
            let mut eff = dq / dt * self.radius_scale[i];
            if self.roller_amp > 0.0 {
                let q_mid = motion.wheel_angle[i] + 0.5 * dq;
                eff *= 1.0 + self.roller_amp * (self.rollers * q_mid + self.roller_phase[i]).cos();
            }
            eff
        });
        let mut twist = self.forward(w, &motion.steer_turn, dt)?;
        if self.floor_std > 0.0 {
            let decay = (-dt / self.floor_tau).exp();
            let kick = self.floor_std * (1.0 - decay * decay).sqrt();
            for e in self.floor.iter_mut() {
                *e = *e * decay + kick * gauss(rng);
            }
            twist = Twist2::new(
                twist.vx * (1.0 + self.floor[0]),
                twist.vy * (1.0 + self.floor[1]),
                twist.yaw_rate * (1.0 + self.floor[2]),
            );
        }
        self.twist = twist;
        self.pose = se2::integrate(self.pose, twist, dt);
        Ok(twist)
    }

    /// The spin `Ω` about the vertical (rad/s) for the zero-spin twist `tw0`:
    /// `Ω₀ + g·|V|^p·ω̃_z` with `ω̃_z = −ψ̇₀` (module docs).
    fn spin(&self, tw0: Twist2<f64>) -> f64 {
        let speed = tw0.vx.hypot(tw0.vy);
        self.spin_const + self.spin_gain * speed.powf(self.spin_exp) * (-tw0.yaw_rate)
    }

    /// Forward kinematics of the effective wheel rates `w` (rad/s) and, for a steerable kind,
    /// the steer turns (rad) over `dt`: the robot-frame twist. Updates the steer angles and the
    /// slip residual.
    fn forward(
        &mut self,
        w: [f64; MAX_WHEELS],
        steer_turn: &[f64; MAX_WHEELS],
        dt: f64,
    ) -> Result<Twist2<f64>, InputError> {
        let n = self.robot.wheels();
        let mut a = Actuators::from_wheel_rates(&w[..n]);
        let mut next = self.steer;
        if self.robot.steerable() {
            for i in 0..n {
                next[i] = self.steer[i] + steer_turn[i];
                // The fit at the mid-step steer angles, with the rates the steer motors ran at.
                a.steer_angles[i] = 0.5 * (self.steer[i] + next[i]);
                a.steer_rates[i] = steer_turn[i] / dt;
            }
        }
        let spin = if self.robot.kind().has_vertical_spin() {
            self.spin(self.robot.forward_spin(&a, 0.0)?.twist)
        } else {
            0.0
        };
        let motion = self.robot.forward_spin(&a, spin)?;
        self.slip_residual = motion.slip_residual;
        self.steer = next;
        Ok(motion.twist)
    }
}

/// The motor models of one robot: one wheel (roll) motor per wheel and, for a steerable
/// kind, one steering motor per wheel. Turns set-points into the [`MotorMotion`] of a plant
/// step.
#[derive(Clone, Debug)]
pub(crate) struct Motors {
    /// Number of wheels: only motors `0..wheels` are stepped (and draw randomness).
    wheels: usize,
    wheel: [Motor; MAX_WHEELS],
    /// `None` without steering: steering motors are then never stepped (nor draw randomness).
    steer: Option<[Motor; MAX_WHEELS]>,
}

impl Motors {
    /// The motors of `plant`'s robot under `profile`, running at `wheel_rates` and (with
    /// steering) `steer_rates`, rad/s, at output angle 0.
    pub(crate) fn new(
        plant: &Plant,
        profile: &Profile,
        wheel_rates: [f64; MAX_WHEELS],
        steer_rates: [f64; MAX_WHEELS],
    ) -> Self {
        Self {
            wheels: plant.robot().wheels(),
            wheel: core::array::from_fn(|i| Motor::new(profile.wheel_motor, wheel_rates[i])),
            steer: plant
                .robot()
                .steerable()
                .then(|| core::array::from_fn(|i| Motor::new(profile.steer_motor, steer_rates[i]))),
        }
    }

    /// Steps every motor by `dt` seconds under the set-points `wheel` and `steer` (rad/s;
    /// `steer` ignored without steering), drawing from `rng` in a fixed order (wheel motors,
    /// then steering motors), and returns what they did.
    pub(crate) fn step(
        &mut self,
        wheel: [f64; MAX_WHEELS],
        steer: [f64; MAX_WHEELS],
        dt: f64,
        rng: &mut ChaCha8Rng,
    ) -> MotorMotion {
        let mut m = MotorMotion::default();
        for i in 0..self.wheels {
            m.wheel_angle[i] = self.wheel[i].angle();
            m.wheel_turn[i] = self.wheel[i].step(wheel[i], dt, rng);
        }
        if let Some(motors) = &mut self.steer {
            for i in 0..self.wheels {
                m.steer_turn[i] = motors[i].step(steer[i], dt, rng);
            }
        }
        m
    }

    /// The wheel motors' output angles, rad (the encoders' ground truth; zeros past the wheel
    /// count).
    pub(crate) fn wheel_angles(&self) -> [f64; MAX_WHEELS] {
        core::array::from_fn(|i| self.wheel[i].angle())
    }
}

/// Which plant a plan or a runtime runs on: `simulate --plant`, `robot --sim --plant`,
/// Python's `plant=` (a `clap` value with the `clap` feature). One enum for every front end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum PlantKind {
    /// Forward kinematics with the disturbance profile (omnikin_sim::plant_step).
    #[default]
    Kinematic,
    /// The sphere's shell + platform dynamics (omnikin_sim::dynamics::sphere).
    Dynamic,
}
