//! The runtime's balance mode: a ballbot's control loop on the torque interface
//! ([`super::hal::MotorTorques`]). It takes the operator's velocity commands
//! ([`super::Command`]) like the rate runtime and runs the balance controller
//! ([`crate::control::BalanceController`]) at the control rate.
//!
//! **Cycle** ([`BalanceRuntime::cycle`]):
//! 1. clock → `dt` (the nominal period on the first cycle; clamped to twice it);
//! 2. IMU → AHRS ([`crate::estimate::ahrs::Mahony`], gyro and accelerometer; the yaw drifts
//!    with the gyro bias, as without a magnetometer it must); encoders → wheel rates by
//!    differences → the ball's velocity corrected for the body's rotation
//!    ([`crate::control::ball_velocity_from_wheels`]), integrated into its position;
//! 3. watchdog: no command or heartbeat for [`BalanceRuntimeConfig::watchdog`] s → the target
//!    velocity is 0 (the robot brakes, leaning, and keeps balancing);
//! 4. the target velocity (a robot-frame command turned into the world with the AHRS yaw) is
//!    slewed at [`BalanceRuntimeConfig::max_accel`] (the lean limit's acceleration: a ballbot
//!    accelerates by leaning), which gives the controller's feed-forward acceleration;
//! 5. [`crate::control::BalanceController::step`] → wheel torques; zero when e-stopped, fallen
//!    (latched by the controller) or after a hardware error;
//! 6. motors.
//!
//! Commands: `Velocity`, `Stop` (target 0), `EStop` (torques 0 at once, latched: the robot
//! falls — a ballbot has no safe motors-off state), `Clear` (clears the e-stop and resets the
//! controller's fall latch; the reference restarts at the measured position), `SetPose`
//! (position and yaw reference), `Hello`/`Heartbeat` (watchdog). Plans are refused
//! ([`BalanceCommandError::NotSupported`]): follow one with velocity commands.
//!
//! No allocation, no panic.

use nalgebra::UnitQuaternion;

use super::command::{Command, Frame};
use super::hal::{Encoders, Imu, MotorTorques, TorqueCommand};
use crate::ballbot::Ballbot;
use crate::control::{
    BalanceConfig, BalanceController, BalanceError, Measurement, Status as BalanceState,
    ball_velocity_from_wheels,
};
use crate::estimate::ahrs::{Mahony, MahonyGains};
use crate::{Pose2, Real, Twist2};

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
            ahrs: MahonyGains::default_gains(),
        }
    }
}

/// Why the balance runtime refused a command.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum BalanceCommandError {
    /// A value is NaN or infinite.
    #[error("{field} must be finite")]
    NonFinite {
        /// The field.
        field: &'static str,
    },
    /// A speed or yaw rate above the accepted bound.
    #[error("{field} = {value} exceeds the accepted bound {limit}")]
    OverLimit {
        /// `"speed"` or `"yaw_rate"`.
        field: &'static str,
        /// The value.
        value: f64,
        /// The bound.
        limit: f64,
    },
    /// The e-stop is latched: send `Clear` first.
    #[error("emergency stop is latched; send clear first")]
    EStopLatched,
    /// Plans are not followed in balance mode.
    #[error("plans are not supported in balance mode: send velocity commands")]
    NotSupported,
}

/// One cycle's status.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BalanceStatus<T> {
    /// Estimated ball position and body yaw (world; m, m, rad).
    pub pose: Pose2<T>,
    /// Estimated ball velocity (world, m/s).
    pub velocity: [T; 2],
    /// Commanded (slewed) world velocity, m/s.
    pub command: [T; 2],
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
}

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
        })
    }

    /// The balance controller (its gains, designs, period).
    pub fn controller(&self) -> &BalanceController<T> {
        &self.controller
    }

    /// Takes an operator command received at `now_us` (the newest valid one wins).
    ///
    /// # Errors
    /// [`BalanceCommandError`]; a refused command changes nothing and is counted.
    pub fn handle(
        &mut self,
        now_us: u64,
        command: &Command<'_, T>,
    ) -> Result<(), BalanceCommandError> {
        let r = self.apply(command);
        match r {
            Ok(()) => self.last_rx_us = Some(now_us),
            Err(_) => self.rejected = self.rejected.saturating_add(1),
        }
        r
    }

    fn apply(&mut self, command: &Command<'_, T>) -> Result<(), BalanceCommandError> {
        let z = T::zero();
        match *command {
            Command::Hello | Command::Heartbeat => Ok(()),
            Command::Velocity { twist, frame } => {
                if self.estop {
                    return Err(BalanceCommandError::EStopLatched);
                }
                for (field, v) in [
                    ("vx", twist.vx),
                    ("vy", twist.vy),
                    ("yaw_rate", twist.yaw_rate),
                ] {
                    if !v.is_finite() {
                        return Err(BalanceCommandError::NonFinite { field });
                    }
                }
                let speed = (twist.vx * twist.vx + twist.vy * twist.vy).sqrt();
                if speed > self.config.max_speed {
                    return Err(BalanceCommandError::OverLimit {
                        field: "speed",
                        value: speed.to_f64(),
                        limit: self.config.max_speed.to_f64(),
                    });
                }
                if twist.yaw_rate.abs() > self.config.max_yaw_rate {
                    return Err(BalanceCommandError::OverLimit {
                        field: "yaw_rate",
                        value: twist.yaw_rate.to_f64(),
                        limit: self.config.max_yaw_rate.to_f64(),
                    });
                }
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
                Ok(())
            }
            Command::SetPose(p) => {
                if !(p.x.is_finite() && p.y.is_finite() && p.heading.is_finite()) {
                    return Err(BalanceCommandError::NonFinite { field: "pose" });
                }
                self.position = [p.x, p.y];
                self.ahrs.set_yaw(p.heading);
                self.controller.reset();
                Ok(())
            }
            Command::PlanBegin { .. } | Command::PlanChunk { .. } | Command::PlanStart { .. } => {
                Err(BalanceCommandError::NotSupported)
            }
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
        // IMU → attitude.
        match imu.read() {
            Ok(Some(s)) => {
                if self.ahrs.update(dt, s.gyro, s.accel, None).is_err() {
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
        match encoders.read() {
            Ok(e) => {
                let w = [e.wheel[0], e.wheel[1], e.wheel[2]];
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
        let cmd = crate::control::Command {
            velocity: self.command,
            acceleration: [d[0] / dt, d[1] / dt],
            yaw_rate: tw.yaw_rate,
            lean: None,
        };
        let (mut torques, mut saturated, mut fallen, mut tilt) =
            ([z; 3], false, false, m.tilt_angle());
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
        BalanceStatus {
            pose: Pose2::new(self.position[0], self.position[1], m.yaw),
            velocity,
            command: self.command,
            tilt,
            torques,
            saturated,
            fallen,
            estop: self.estop,
            watchdog,
            hardware_fault: fault,
            rejected: self.rejected,
        }
    }
}
