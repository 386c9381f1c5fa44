//! Hardware traits: what a board (or the simulator) must provide to run the control loop.
//!
//! Four small traits, in the spirit of `embedded-hal`: each is implemented once per board and
//! knows nothing about kinematics. All values are SI; angles and rates are about each motor's
//! own axis (right-hand rule, as in the project conventions), IMU vectors are in the robot frame
//! (x forward, y left, z up).
//!
//! A firmware crate implements them on its peripherals, for example on a Cortex-M board:
//!
//! * [`Clock`]: a free-running microsecond counter (SysTick or a 32-bit timer extended to
//!   64 bits in its overflow interrupt);
//! * [`Encoders`]: quadrature timers read as counts and converted with
//!   [`crate::estimate::odometry::counts_to_radians`] (or step counters of the stepper drivers for
//!   open-loop steppers);
//! * [`Imu`]: an SPI/I²C gyro and accelerometer, converted to rad/s and m/s²;
//! * [`MotorOutputs`]: PWM/velocity set-points of the motor drivers, **or** [`StepOutputs`] for
//!   stepper drivers (step/dir pins driven by timers), wrapped in [`Steppers`] which converts
//!   rad/s to step frequencies; or [`MotorTorques`] for a balancing robot (torque set-points,
//!   [`super::balance`]);
//! * [`Entropy`]: unpredictable bytes for the link's handshake nonces ([`crate::link`]): the
//!   MCU's TRNG (e.g. the STM32 `RNG` peripheral), or the OS on a PC.
//!
//! ## What a board fills, per robot
//!
//! A robot has [`Robot::wheels`](crate::Robot::wheels) wheels (modules), at most
//! [`MAX_WHEELS`]; the HAL's arrays are that capacity, in the robot file's wheel order, and
//! entries past the wheel count are ignored on input and zero on output:
//!
//! * [`Encoders::read`] returns an [`EncoderAngles`] (the core's one type for an encoder
//!   reading): `wheel[i]`, the cumulative roll angle of wheel `i` (rad, unwrapped, about its
//!   axle, right-hand rule); `steer[i]`, the steer angle of module `i` for kinds with steer
//!   motors ([`Kind::steerable`](crate::Kind::steerable): rad, counter-clockwise, may be
//!   wrapped), 0 otherwise.
//! * [`MotorOutputs::set_rates`] receives a [`MotorCommand`]: `wheel[i]` the roll-rate
//!   set-point of wheel `i` (rad/s), `steer[i]` the steer-rate set-point of module `i`
//!   (rad/s; 0 for kinds without steering). Steer motors are always rate-driven: for a swerve,
//!   whose steer *angles* are the kinematic set-points, the runtime closes the angle loop
//!   itself ([`crate::runtime`], "Steering") so a board only needs velocity control.
//!
//! Every method returns a `Result` with the board's own error type; the runtime never panics
//! on a hardware error, it raises [`super::Faults::HARDWARE`] and brings the robot to rest.

use crate::{MAX_WHEELS, Real};

pub use crate::EncoderAngles;

/// A free-running monotonic clock.
pub trait Clock {
    /// Microseconds since an arbitrary epoch; must never decrease (64 bits: no wrap-around in
    /// practice).
    fn now_us(&mut self) -> u64;
}

/// Reads the motor encoders.
pub trait Encoders<T> {
    /// The board's error (bus error, encoder not responding, …).
    type Error: core::fmt::Debug;
    /// The cumulative angles now. Called exactly once per control cycle.
    fn read(&mut self) -> Result<EncoderAngles<T>, Self::Error>;
}

/// One inertial sample in the robot frame (x forward, y left, z up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample<T> {
    /// Angular rate, rad/s (`gyro[2]` is the yaw rate, counter-clockwise positive).
    pub gyro: [T; 3],
    /// Specific force, m/s² (about `(0, 0, +9.81)` at rest).
    pub accel: [T; 3],
}

/// Reads the inertial sensor.
pub trait Imu<T> {
    /// The board's error.
    type Error: core::fmt::Debug;
    /// The newest sample, or `Ok(None)` when no new sample is ready this cycle.
    fn read(&mut self) -> Result<Option<ImuSample<T>>, Self::Error>;
}

/// A board without an IMU: always `Ok(None)`.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoImu;

impl<T> Imu<T> for NoImu {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<Option<ImuSample<T>>, Self::Error> {
        Ok(None)
    }
}

/// Motor set-points of one cycle, rad/s, in the robot file's wheel order. Entries past
/// [`Robot::wheels`](crate::Robot::wheels) are zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorCommand<T> {
    /// Wheel (roll) rates, rad/s, about each wheel's axis (right-hand rule).
    pub wheel: [T; MAX_WHEELS],
    /// Steer rates, rad/s, of kinds with steer motors (caster, swerve); zeros otherwise.
    pub steer: [T; MAX_WHEELS],
}

impl<T: Real> MotorCommand<T> {
    /// All motors at rest.
    pub fn zero() -> Self {
        Self {
            wheel: [T::zero(); MAX_WHEELS],
            steer: [T::zero(); MAX_WHEELS],
        }
    }
}

/// Motors driven by rate set-points (velocity-controlled drivers).
pub trait MotorOutputs<T> {
    /// The board's error.
    type Error: core::fmt::Debug;
    /// Applies the set-points; they hold until the next call. Called exactly once per cycle.
    fn set_rates(&mut self, command: &MotorCommand<T>) -> Result<(), Self::Error>;
}

/// Wheel torque set-points of one cycle, N·m at the wheel, in the robot file's wheel order
/// (the torque interface of a balancing robot; entries past the wheel count are zero).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TorqueCommand<T> {
    /// Wheel torques, N·m, about each wheel's axis (right-hand rule).
    pub wheel: [T; MAX_WHEELS],
}

impl<T: Real> TorqueCommand<T> {
    /// All motors off (zero torque).
    pub fn zero() -> Self {
        Self {
            wheel: [T::zero(); MAX_WHEELS],
        }
    }
}

/// Motors driven by torque (current) set-points, alongside the rate interface
/// [`MotorOutputs`]: what a balancing robot needs (a ballbot, [`super::balance`]), e.g. the
/// current loops of field-oriented motor drivers with `torque = gear · k_t · current`.
pub trait MotorTorques<T> {
    /// The board's error.
    type Error: core::fmt::Debug;
    /// Applies the torques; they hold until the next call. Called exactly once per cycle.
    fn set_torques(&mut self, command: &TorqueCommand<T>) -> Result<(), Self::Error>;
}

/// Stepper drivers driven by step frequencies (step/dir interface).
pub trait StepOutputs {
    /// The board's error.
    type Error: core::fmt::Debug;
    /// Sets the signed step frequencies, steps/s (sign = direction pin): wheels 1–`MAX_WHEELS`
    /// (entry `i`), then the steer motors 1–`MAX_WHEELS` (entry `MAX_WHEELS + i`); entries
    /// past the robot's wheel count, and the steer entries of kinds without steering, are 0.
    fn set_step_frequencies(&mut self, hz: [f32; 2 * MAX_WHEELS]) -> Result<(), Self::Error>;
}

/// Adapts [`StepOutputs`] to [`MotorOutputs`]: `f = ω · steps_per_rev · microsteps / 2π`,
/// clamped to `±max_step_rate` (steps/s). No allocation; the conversion is a multiply per motor.
#[derive(Clone, Copy, Debug)]
pub struct Steppers<S> {
    /// The stepper outputs.
    pub outputs: S,
    /// Microsteps per radian of each motor, in the order of
    /// [`StepOutputs::set_step_frequencies`] (wheels, then steer motors).
    pub steps_per_rad: [f32; 2 * MAX_WHEELS],
    /// Largest step frequency a driver accepts, steps/s.
    pub max_step_rate: f32,
}

impl<S> Steppers<S> {
    /// Steppers with `steps_per_rev` full steps and `microsteps` per full step on every motor.
    pub fn new(outputs: S, steps_per_rev: u32, microsteps: u32, max_step_rate: f32) -> Self {
        let k = (steps_per_rev as f32 * microsteps as f32) / core::f32::consts::TAU;
        Self {
            outputs,
            steps_per_rad: [k; 2 * MAX_WHEELS],
            max_step_rate,
        }
    }

    /// The step frequencies (steps/s) for a rate command.
    pub fn frequencies<T: Real>(&self, command: &MotorCommand<T>) -> [f32; 2 * MAX_WHEELS] {
        let mut hz = [0.0f32; 2 * MAX_WHEELS];
        for i in 0..2 * MAX_WHEELS {
            let w = if i < MAX_WHEELS {
                command.wheel[i]
            } else {
                command.steer[i - MAX_WHEELS]
            };
            let f = w.to_f64() as f32 * self.steps_per_rad[i];
            hz[i] = if f.is_finite() {
                f.clamp(-self.max_step_rate, self.max_step_rate)
            } else {
                0.0
            };
        }
        hz
    }
}

impl<T: Real, S: StepOutputs> MotorOutputs<T> for Steppers<S> {
    type Error = S::Error;
    fn set_rates(&mut self, command: &MotorCommand<T>) -> Result<(), Self::Error> {
        let hz = self.frequencies(command);
        self.outputs.set_step_frequencies(hz)
    }
}

/// The entropy source failed (a TRNG seed or clock error, an OS error).
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("the entropy source failed")]
pub struct EntropyError;

/// Unpredictable random bytes, for the nonces of the link handshake ([`crate::link`]).
///
/// The link's security rests on these bytes being unpredictable to anyone else: use a
/// hardware TRNG (or a CSPRNG seeded from one), never a counter, a clock or a fixed seed —
/// a predictable robot nonce lets an attacker without the key replay a recorded session.
pub trait Entropy {
    /// Fills `buf` with random bytes.
    ///
    /// # Errors
    /// [`EntropyError`] when the source cannot deliver (the handshake is then refused).
    fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError>;
}

impl<E: Entropy + ?Sized> Entropy for &mut E {
    fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError> {
        (**self).fill(buf)
    }
}
