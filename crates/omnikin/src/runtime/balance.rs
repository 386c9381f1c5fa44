//! The runtime's balance mode: a ballbot's control loop on the torque interface
//! ([`super::hal::MotorTorques`]). It takes the operator's velocity commands
//! ([`super::Command`]) like the rate runtime and runs the balance controller
//! ([`crate::control::BalanceController`]) at the control rate.
//!
//! **Cycle** ([`BalanceRuntime::cycle`]):
//! 1. clock → `dt` (the nominal period on the first cycle; clamped to twice it);
//! 2. IMU → AHRS ([`crate::estimate::ahrs::Mahony`], gyro and accelerometer, the latter
//!    corrected by the ball's acceleration from the odometry, low-passed over
//!    [`ACCEL_FILTER_S`]: a ballbot accelerates by leaning, and the raw specific force then
//!    points along the leaning body; the yaw drifts with the gyro bias, as without a
//!    magnetometer it must); encoders → wheel rates by
//!    differences → the ball's velocity corrected for the body's rotation
//!    ([`crate::control::ball_velocity_from_wheels`]), integrated into its position;
//! 3. watchdog: no command or heartbeat for [`BalanceRuntimeConfig::watchdog`] s → the target
//!    velocity is 0 (the robot brakes, leaning, and keeps balancing);
//! 4. the target velocity (a robot-frame command turned into the world with the AHRS yaw) is
//!    slewed at [`BalanceRuntimeConfig::max_accel`] (the lean limit's acceleration: a ballbot
//!    accelerates by leaning). The controller follows it by feedback alone: while the command
//!    is not zero its reference position is the measured one (velocity tracking; it does not
//!    catch up on the distance it lagged while leaning into the motion), and it gets no
//!    feed-forward lean (without a preview of the next commands a lean step makes the ball
//!    roll back first, then overshoot: on the preset a 0.2 m/s step peaked at 0.59 m/s with
//!    the slew's acceleration fed forward, at 0.206 m/s and 2.3° tilt without). Once the
//!    command is zero it holds the position the reference integrates to. Plans, known ahead,
//!    are followed with the lean preview offline (`omnikin simulate --plant dynamic`);
//! 5. [`crate::control::BalanceController::step`] → wheel torques; zero when e-stopped, fallen
//!    (latched by the controller) or after a hardware error;
//! 6. motors.
//!
//! Commands: `Velocity`, `Stop` (target 0), `EStop` (torques 0 at once, latched: the robot
//! falls — a ballbot has no safe motors-off state), `Clear` (clears the e-stop and resets the
//! controller's fall latch; the reference restarts at the measured position), `SetPose`
//! (position and yaw reference), `Hello`/`Heartbeat` (watchdog). Plans are refused
//! ([`CommandError::NotSupported`]): follow one with velocity commands. Refusals are the rate
//! runtime's errors ([`CommandError`]), checked by the same function.
//!
//! The operator link drives it like the rate runtime, through [`Operated`]; its status becomes
//! the link's telemetry ([`crate::link::Telemetry::from_balance`]).
//!
//! No allocation, no panic.

use nalgebra::UnitQuaternion;

use super::Operated;
use super::command::{Command, CommandError, Frame, check_twist};
use super::hal::{Encoders, Imu, MotorTorques, TorqueCommand};
use super::status::{Faults, Mode};
use crate::ballbot::Ballbot;
use crate::control::{
    BalanceConfig, BalanceController, BalanceError, BalanceState, Measurement,
    ball_velocity_from_wheels,
};
use crate::estimate::ahrs::{Mahony, MahonyGains};
use crate::estimate::events::{EventCounters, EventDetector, EventThresholds};
use crate::estimate::odometry::OdometryStep;
use crate::{Kind, Pose2, Real, Twist2};

/// What the balance runtime is built from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BalanceRuntimeConfig<T> {
    /// The balance controller (its `rate_hz` is the control rate).
    pub balance: BalanceConfig<T>,
    /// Largest commanded acceleration, m/s² (a robot file's
    /// `RobotDescription::lean_acceleration_limit`).
    pub max_accel: T,
    /// Largest accepted speed, m/s.
    pub max_speed: T,
    /// Largest accepted yaw rate, rad/s.
    pub max_yaw_rate: T,
    /// Watchdog timeout, s.
    pub watchdog: T,
    /// AHRS gains.
    pub ahrs: MahonyGains<T>,
    /// Collision detection on the ball's speed ([`crate::estimate::events`]; the slip tests
    /// do not apply: the ball's spin about the vertical is not measured, and three wheels
    /// leave no residual). Default [`EventThresholds::standard`]; `omnikin robot` takes the
    /// robot file's `[events]`.
    pub events: EventThresholds<T>,
}

impl<T: Real> BalanceRuntimeConfig<T> {
    /// `balance` with `max_accel`, 1 m/s, 1 rad/s, a 0.5 s watchdog and the AHRS's
    /// [`MahonyGains::default_gains`].
    pub fn new(balance: BalanceConfig<T>, max_accel: T) -> Self {
        Self {
            balance,
            max_accel,
            max_speed: T::one(),
            max_yaw_rate: T::one(),
            watchdog: T::of(0.5),
            events: EventThresholds::standard(),
            ahrs: MahonyGains::default_gains(),
        }
    }
}

/// One cycle's status.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BalanceStatus<T> {
    /// Clock of the cycle, µs.
    pub time_us: u64,
    /// [`Mode::EStop`] when the e-stop is latched or the robot fell (motors off),
    /// [`Mode::Velocity`] while a command is followed, [`Mode::Stopping`] while braking to the
    /// zero target (stop, watchdog), [`Mode::Idle`] at rest (no command, the ball slower than
    /// 2 cm/s).
    pub mode: Mode,
    /// This cycle's faults: `LIMIT` (torque saturation), `LINK_LOST` (watchdog), `ESTOP`,
    /// `REJECTED` (a command refused since the last cycle), `HARDWARE`, `FALLEN`, `COLLISION`
    /// (a collision episode under way, [`BalanceRuntimeConfig::events`]).
    pub faults: Faults,
    /// Faults since the last `Clear`.
    pub fault_history: Faults,
    /// Estimated ball position and body yaw (world; m, m, rad).
    pub pose: Pose2<T>,
    /// Estimated ball velocity (world, m/s).
    pub velocity: [T; 2],
    /// Body yaw rate from the bias-corrected gyro, rad/s (world vertical).
    pub yaw_rate: T,
    /// Commanded (slewed) world velocity, m/s.
    pub command: [T; 2],
    /// Commanded yaw rate, rad/s.
    pub command_yaw_rate: T,
    /// Encoder wheel angles, rad (paper 001's wheel order).
    pub wheel_angles: [T; 3],
    /// The IMU's gyro (rad/s) and accelerometer (m/s²) this cycle, body frame (zeros without a
    /// sample).
    pub imu: ([T; 3], [T; 3]),
    /// Estimated tilt from the vertical, rad.
    pub tilt: T,
    /// The wheel torques applied, N·m.
    pub torques: [T; 3],
    /// The torque limit scaled the request down this cycle.
    pub saturated: bool,
    /// The controller detected a fall (latched; motors off).
    pub fallen: bool,
    /// The e-stop is latched.
    pub estop: bool,
    /// The watchdog has expired (target velocity 0).
    pub watchdog: bool,
    /// A sensor or motor error happened this cycle (torques 0).
    pub hardware_fault: bool,
    /// Commands refused so far.
    pub rejected: u32,
    /// Clock of the newest accepted command, µs (0: none).
    pub last_command_us: u64,
    /// Collisions since start (`slips` stays 0: no slip test on this runtime).
    pub events: EventCounters,
}

/// The balance runtime (module doc). `Copy`-free but fixed size, no allocation.
#[derive(Clone, Debug)]
pub struct BalanceRuntime<T: Real> {
    config: BalanceRuntimeConfig<T>,
    controller: BalanceController<T>,
    robot: Ballbot<T>,
    ahrs: Mahony<T>,
    gyro: [T; 3],
    target: (Twist2<T>, Frame),
    command: [T; 2],
    estop: bool,
    last_us: Option<u64>,
    last_rx_us: Option<u64>,
    last_wheels: Option<[T; 3]>,
    position: [T; 2],
    rejected: u32,
    rejected_seen: u32,
    fault_history: Faults,
    last_velocity: [T; 2],
    ball_accel: [T; 2],
    events: EventDetector<T>,
    /// Clock origin of the event detector, µs (re-based every `EVENT_REBASE_S`).
    event_base_us: Option<u64>,
}

/// Re-base the event detector's clock every this many seconds so `T = f32` keeps µs
/// resolution.
const EVENT_REBASE_S: f64 = 256.0;

/// Time constant of the low-pass on the odometry's ball acceleration that corrects the
/// accelerometer, s.
pub const ACCEL_FILTER_S: f64 = 0.05;

impl<T: Real> BalanceRuntime<T> {
    /// A balance runtime at `pose` (ball position and yaw, world).
    ///
    /// # Errors
    /// [`BalanceError`] from [`BalanceController::new`], or a non-positive `max_accel`,
    /// `max_speed`, `max_yaw_rate` or `watchdog`.
    pub fn new(config: BalanceRuntimeConfig<T>, pose: Pose2<T>) -> Result<Self, BalanceError> {
        for (field, v) in [
            ("max_accel", config.max_accel),
            ("max_speed", config.max_speed),
            ("max_yaw_rate", config.max_yaw_rate),
            ("watchdog", config.watchdog),
            ("events.collision_decel", config.events.collision_decel),
            ("events.window", config.events.window),
            ("events.smoothing", config.events.smoothing),
            ("events.hold", config.events.hold),
            ("events.slip_yaw_rate", config.events.slip_yaw_rate),
            ("events.slip_residual", config.events.slip_residual),
        ] {
            let v = v.to_f64();
            if !(v.is_finite() && v > 0.0) {
                return Err(BalanceError::Parameter {
                    field,
                    value: v,
                    rule: "must be finite and > 0",
                });
            }
        }
        let controller = BalanceController::new(config.balance)?;
        let robot = Ballbot::new(config.balance.geometry)?;
        let mut ahrs = Mahony::new(config.ahrs, T::zero());
        ahrs.set_yaw(pose.heading);
        let z = T::zero();
        Ok(Self {
            config,
            controller,
            robot,
            ahrs,
            gyro: [z; 3],
            target: (Twist2::new(z, z, z), Frame::World),
            command: [z; 2],
            estop: false,
            last_us: None,
            last_rx_us: None,
            last_wheels: None,
            position: [pose.x, pose.y],
            rejected: 0,
            rejected_seen: 0,
            fault_history: Faults::NONE,
            last_velocity: [z; 2],
            ball_accel: [z; 2],
            events: EventDetector::new(config.events, false),
            event_base_us: None,
        })
    }

    /// What it was built from.
    pub fn config(&self) -> &BalanceRuntimeConfig<T> {
        &self.config
    }

    /// The balance controller (its gains, designs, period).
    pub fn controller(&self) -> &BalanceController<T> {
        &self.controller
    }

    /// Takes an operator command received at `now_us` (the newest valid one wins), as
    /// [`super::Runtime::handle`] does.
    ///
    /// # Errors
    /// [`CommandError`]: `NonFinite`/`OverLimit` (the rate runtime's check,
    /// [`BalanceRuntimeConfig::max_speed`], [`BalanceRuntimeConfig::max_yaw_rate`]),
    /// `EStopLatched`, `NotSupported` for plans. A refused command changes nothing and is
    /// counted.
    pub fn handle(&mut self, command: Command<'_, T>, now_us: u64) -> Result<(), CommandError> {
        let r = self.apply(&command);
        match r {
            Ok(()) => self.last_rx_us = Some(now_us),
            Err(_) => self.rejected = self.rejected.saturating_add(1),
        }
        r
    }

    fn apply(&mut self, command: &Command<'_, T>) -> Result<(), CommandError> {
        let z = T::zero();
        match *command {
            Command::Hello | Command::Heartbeat => Ok(()),
            Command::Velocity { twist, frame } => {
                if self.estop {
                    return Err(CommandError::EStopLatched);
                }
                check_twist(
                    twist,
                    false,
                    self.config.max_speed,
                    self.config.max_yaw_rate,
                )?;
                self.target = (twist, frame);
                Ok(())
            }
            Command::Stop => {
                self.target = (Twist2::new(z, z, z), Frame::World);
                Ok(())
            }
            Command::EStop => {
                self.estop = true;
                self.target = (Twist2::new(z, z, z), Frame::World);
                Ok(())
            }
            Command::Clear => {
                self.estop = false;
                self.controller.reset();
                self.command = [z; 2];
                self.fault_history = Faults::NONE;
                Ok(())
            }
            Command::SetPose(p) => {
                if !(p.x.is_finite() && p.y.is_finite() && p.heading.is_finite()) {
                    return Err(CommandError::NonFinite { field: "pose" });
                }
                self.position = [p.x, p.y];
                self.ahrs.set_yaw(p.heading);
                self.controller.reset();
                Ok(())
            }
            Command::PlanBegin { .. }
            | Command::PlanSplice { .. }
            | Command::PlanSpliceRebased { .. }
            | Command::PlanChunk { .. }
            | Command::PlanStart { .. } => Err(CommandError::NotSupported {
                what: "plans",
                instead: "a balancing robot follows velocity commands (send the plan's twists)",
            }),
            Command::Fix(_) => Err(CommandError::NotSupported {
                what: "pose fixes",
                instead: "the balance runtime has no fusion filter; fuse fixes offline (omnikin odometry --fixes)",
            }),
        }
    }

    /// One control cycle at `now_us` (module doc).
    pub fn cycle<E, I, M>(
        &mut self,
        now_us: u64,
        encoders: &mut E,
        imu: &mut I,
        motors: &mut M,
    ) -> BalanceStatus<T>
    where
        E: Encoders<T>,
        I: Imu<T>,
        M: MotorTorques<T>,
    {
        let z = T::zero();
        let period = self.controller.period();
        let dt = match self.last_us {
            Some(l) if now_us > l => {
                let d = T::of((now_us - l) as f64 * 1e-6);
                if d > period + period {
                    period + period
                } else {
                    d
                }
            }
            _ => period,
        };
        self.last_us = Some(now_us);
        let mut fault = false;
        let mut sample = ([z; 3], [z; 3]);
        // IMU → attitude.
        match imu.read() {
            Ok(Some(s)) => {
                sample = (s.gyro, s.accel);
                // The accelerometer at the ball centre reads gravity plus the ball's
                // acceleration; a ballbot accelerates by leaning, so uncorrected it reads
                // "upright" along every lean (the specific force follows the body axis) and the
                // AHRS would learn the lean as the vertical. Subtract the ball's acceleration
                // from the odometry (low-passed), turned into the body frame.
                let a = self.ahrs.quaternion().inverse()
                    * nalgebra::Vector3::new(self.ball_accel[0], self.ball_accel[1], z);
                let f = [s.accel[0] - a.x, s.accel[1] - a.y, s.accel[2] - a.z];
                if self.ahrs.update(dt, s.gyro, f, None).is_err() {
                    fault = true;
                } else {
                    let b = self.ahrs.gyro_bias();
                    self.gyro = [s.gyro[0] - b[0], s.gyro[1] - b[1], s.gyro[2] - b[2]];
                }
            }
            Ok(None) => {}
            Err(_) => fault = true,
        }
        let q: UnitQuaternion<T> = self.ahrs.quaternion();
        // Encoders → ball velocity and position.
        let mut velocity = [z; 2];
        let mut wheel_angles = [z; 3];
        match encoders.read() {
            Ok(e) => {
                let w = [e.wheel[0], e.wheel[1], e.wheel[2]];
                wheel_angles = w;
                if let Some(l) = self.last_wheels {
                    let rates = [(w[0] - l[0]) / dt, (w[1] - l[1]) / dt, (w[2] - l[2]) / dt];
                    match ball_velocity_from_wheels(&self.robot, rates, &q, self.gyro) {
                        Ok(v) => velocity = v,
                        Err(_) => fault = true,
                    }
                }
                self.last_wheels = Some(w);
            }
            Err(_) => fault = true,
        }
        self.position = [
            self.position[0] + velocity[0] * dt,
            self.position[1] + velocity[1] * dt,
        ];
        // The ball's acceleration for the next cycle's accelerometer correction: velocity
        // differences through a first-order low-pass of time constant `ACCEL_FILTER_S`.
        let k = dt / (dt + T::of(ACCEL_FILTER_S));
        for i in 0..2 {
            let raw = (velocity[i] - self.last_velocity[i]) / dt;
            self.ball_accel[i] = self.ball_accel[i] + k * (raw - self.ball_accel[i]);
        }
        self.last_velocity = velocity;
        self.detect_collision(now_us, dt, velocity);
        let m = Measurement::from_attitude(&q, self.gyro, self.position, velocity);
        // Watchdog and target.
        let watchdog = match self.last_rx_us {
            Some(r) => T::of(now_us.saturating_sub(r) as f64 * 1e-6) > self.config.watchdog,
            None => true,
        };
        let (tw, frame) = if watchdog || self.estop {
            (Twist2::new(z, z, z), Frame::World)
        } else {
            self.target
        };
        let target = match frame {
            Frame::World => [tw.vx, tw.vy],
            Frame::Robot => {
                let (s, c) = m.yaw.sin_cos();
                [c * tw.vx - s * tw.vy, s * tw.vx + c * tw.vy]
            }
        };
        // Slew at the lean limit's acceleration.
        let d = [target[0] - self.command[0], target[1] - self.command[1]];
        let n = (d[0] * d[0] + d[1] * d[1]).sqrt();
        let step = self.config.max_accel * dt;
        let k = if n > step { step / n } else { T::one() };
        let d = [d[0] * k, d[1] * k];
        self.command = [self.command[0] + d[0], self.command[1] + d[1]];
        let cmd = crate::control::BalanceCommand {
            velocity: self.command,
            // No feed-forward lean: without a preview of the commands a lean step makes the
            // ball roll back first and then overshoot (a 0.2 m/s command peaked at 0.59 m/s
            // with the slew's acceleration fed forward, at 0.206 m/s without; module doc).
            acceleration: [z, z],
            yaw_rate: tw.yaw_rate,
            lean: None,
        };
        let (mut torques, mut saturated, mut fallen, mut tilt) =
            ([z; 3], false, false, m.tilt_angle());
        // Following a velocity command, the reference position is the measured one: the robot
        // tracks the commanded velocity without catching up on the distance it lagged behind
        // while leaning into it (which would overshoot the commanded speed); once the command
        // is zero it holds the position the reference then integrates to.
        if (self.command[0] != z || self.command[1] != z)
            && let Some((_, yaw_ref)) = self.controller.reference()
        {
            self.controller.set_reference(m.ball_position, yaw_ref);
        }
        match self.controller.step(&m, &cmd) {
            Ok(out) => {
                torques = out.wheel_torques;
                saturated = out.saturated;
                fallen = out.status == BalanceState::Fallen;
                tilt = out.tilt;
            }
            Err(_) => fault = true,
        }
        if fault || self.estop {
            torques = [z; 3];
        }
        let mut tc = TorqueCommand::zero();
        tc.wheel[..3].copy_from_slice(&torques);
        if motors.set_torques(&tc).is_err() {
            fault = true;
        }
        let mut faults = Faults::NONE;
        for (on, flag) in [
            (saturated, Faults::LIMIT),
            (watchdog, Faults::LINK_LOST),
            (self.estop, Faults::ESTOP),
            (self.rejected != self.rejected_seen, Faults::REJECTED),
            (fault, Faults::HARDWARE),
            (fallen, Faults::FALLEN),
            (self.events.colliding(), Faults::COLLISION),
        ] {
            if on {
                faults.insert(flag);
            }
        }
        self.rejected_seen = self.rejected;
        self.fault_history.insert(faults);
        // At rest: no velocity commanded and the ball slower than 2 cm/s.
        let rest = T::of(0.02);
        let moving = self.command[0] != z
            || self.command[1] != z
            || velocity[0] * velocity[0] + velocity[1] * velocity[1] > rest * rest;
        let mode = if self.estop || fallen {
            Mode::EStop
        } else if !watchdog && (tw.vx != z || tw.vy != z || tw.yaw_rate != z) {
            Mode::Velocity
        } else if moving {
            Mode::Stopping
        } else {
            Mode::Idle
        };
        // The yaw rate about the world vertical: the bias-corrected gyro in the world frame.
        let yaw_rate = (q * nalgebra::Vector3::new(self.gyro[0], self.gyro[1], self.gyro[2])).z;
        BalanceStatus {
            time_us: now_us,
            mode,
            faults,
            fault_history: self.fault_history,
            pose: Pose2::new(self.position[0], self.position[1], m.yaw),
            velocity,
            yaw_rate,
            command: self.command,
            command_yaw_rate: tw.yaw_rate,
            wheel_angles,
            imu: sample,
            tilt,
            torques,
            saturated,
            fallen,
            estop: self.estop,
            watchdog,
            hardware_fault: fault,
            rejected: self.rejected,
            last_command_us: self.last_rx_us.unwrap_or(0),
            events: self.events.counters(),
        }
    }

    /// Feeds the event detector the ball's speed of this cycle (world velocity; the
    /// detector only uses its magnitude).
    fn detect_collision(&mut self, now_us: u64, dt: T, velocity: [T; 2]) {
        let z = T::zero();
        let base = *self.event_base_us.get_or_insert(now_us);
        let mut t = T::of(now_us.saturating_sub(base) as f64 * 1e-6);
        if t > T::of(EVENT_REBASE_S) {
            self.events.shift_time(t);
            self.event_base_us = Some(now_us);
            t = z;
        }
        let step = OdometryStep {
            t,
            dt,
            pose: Pose2::new(self.position[0], self.position[1], z),
            delta: Pose2::new(velocity[0] * dt, velocity[1] * dt, z),
            twist: Twist2::new(velocity[0], velocity[1], z),
            wheel_heading_change: z,
            slip_residual: z,
            wheel_slip: [z; crate::MAX_WHEELS],
            shell_spin: None,
        };
        self.events.step(&step, None);
    }
}

impl<T: Real> Operated<T> for BalanceRuntime<T> {
    fn handle(&mut self, command: Command<'_, T>, now_us: u64) -> Result<(), CommandError> {
        BalanceRuntime::handle(self, command, now_us)
    }
    fn kind(&self) -> Kind {
        Kind::Ballbot
    }
    fn plan_capacity(&self) -> usize {
        0
    }
    fn rate_hz(&self) -> T {
        self.config.balance.rate_hz
    }
    fn watchdog(&self) -> T {
        self.config.watchdog
    }
    /// The slew's acceleration; yaw acceleration and jerk are not limited (the balance
    /// controller follows the slewed velocity by leaning).
    fn body_limits(&self) -> crate::link::RobotLimits {
        crate::link::RobotLimits {
            max_accel: self.config.max_accel.to_f64() as f32,
            max_yaw_accel: f32::INFINITY,
            max_jerk: f32::INFINITY,
        }
    }
}
