//! # Robot runtime: the control loop that runs on the robot
//!
//! Paper 000's control system (Fig. 1) and paper 001's control iteration, as one `no_std`
//! loop: an operator's commands arrive over a link ([`crate::link`]), and every cycle the
//! runtime reads the encoders (and the IMU), updates the wheel odometry
//! ([`crate::estimate::odometry::Odometry`]), takes the newest valid command, shapes it within the
//! robot's limits, runs the inverse kinematics and writes the motor set-points.
//!
//! * [`hal`]: the hardware traits ([`hal::Clock`], [`hal::Encoders`], [`hal::Imu`],
//!   [`hal::MotorOutputs`] or [`hal::StepOutputs`] through [`hal::Steppers`]); the same loop
//!   drives the simulator (`omnikin_sim::sil`) and real hardware.
//! * [`limits`]: direction-keeping desaturation ([`limits::desaturate`]: the whole twist is
//!   scaled so the worst wheel sits at its limit) and acceleration/jerk limiting
//!   ([`limits::Slew`], world frame).
//! * [`Runtime`]: modes [`Mode::Velocity`] (robot or world frame), [`Mode::Trajectory`]
//!   (a plan of up to `N` [`PlanPoint`]s uploaded in chunks, followed with feed-forward plus
//!   pose feedback), [`Mode::Stopping`], and a latching [`Mode::EStop`]; a watchdog that brakes
//!   to rest within the acceleration limit when no valid command or heartbeat arrives for
//!   [`Config::watchdog`] seconds; [`Faults`] (limit hit, slip, link lost, …) in every
//!   [`Status`].
//! * Re-planning without stopping: [`Command::PlanSplice`] uploads a replacement of the running
//!   plan's future into the buffer's free part while the plan goes on; armed by its
//!   [`Command::PlanStart`], it takes over at its first point's time `t_s`. Refused, with the
//!   running plan going on, when `t_s` has passed or lies past the plan's end
//!   ([`CommandError::SpliceOutside`]), when it does not fit the free points
//!   ([`CommandError::SpliceNoRoom`]), or when its first point is not the plan's reference at
//!   `t_s` within [`SPLICE_MAX_JUMP`] in each of x, y, heading, vx, vy and yaw rate
//!   ([`CommandError::OverLimit`] naming `splice.x_jump`, `splice.y_jump`,
//!   `splice.heading_jump`, `splice.vx_jump`, `splice.vy_jump` or `splice.yaw_rate_jump`). [`plan_reference`] gives an operator that reference.
//!   [`Command::PlanSpliceRebased`] is the same upload planned from where the robot is (after
//!   a drift): its position and velocity are not checked, and at its switch the reference is re-based on
//!   the measured pose (zero tracking error), the offset fading out no faster than
//!   [`Config::max_correction`].
//!
//! ## Guarantees
//! * **No allocation, no panic** in [`Runtime::handle`] and [`Runtime::cycle`] (tested with a
//!   counting allocator; the crate has no `alloc` at all). The plan buffer is a fixed array of
//!   `N` points (`N` is a const generic, so the firmware chooses its RAM use:
//!   `N × 7 × size_of::<T>()` bytes, e.g. 7 KiB for 256 points in `f32`).
//! * A rejected command ([`CommandError`]) is not executed at all and is counted
//!   ([`Status::rejected`]).
//! * The motor set-points never exceed [`Config::rate_limits`]; consecutive set-points never
//!   differ by more than [`Config::wheel_accel`] × dt; the commanded body velocity never
//!   changes faster than [`Config::slew`] (except an emergency stop, which zeroes the motors at
//!   once).
//!
//! ## Cycle order
//! 1. clock → `dt` (an overrun beyond twice the nominal period is flagged and clamped);
//! 2. IMU, encoders → odometry (heading from the wheels, or the gyro with
//!    [`Config::heading_from_gyro`]) → prediction of the fix fusion filter (fixes themselves
//!    arrive through [`Runtime::handle`] as [`Command::Fix`] and are fused at their capture
//!    time; the control uses the fused pose once one has been accepted); slip checks;
//! 3. watchdog;
//! 4. target twist of the mode (world frame); trajectory: `v = v_ref + K·(p_ref − p)`;
//! 5. desaturation at the current heading/steer → slew (acceleration, jerk) → inverse
//!    kinematics → motor-acceleration limit → final rate clamp (→ the steer-angle loop of a
//!    swerve);
//! 6. motors.
//!
//! Every kind runs the same loop through the uniform [`crate::Robot`] API: the per-wheel
//! arrays hold [`crate::MAX_WHEELS`] entries of which the robot's
//! [`crate::Robot::wheels`] are used. How the steer motors are driven (rate-driven caster,
//! set-point swerve with its angle loop) is in the docs of the shaping step, `shape.rs`:
//! the steer motor of a swerve module is commanded the inverse's feed-forward steer rate plus
//! [`Config::k_steer`] × the wrapped angle error, within [`limits::RateLimits::steer`] and
//! [`Config::steer_accel`], and its wheel rate is scaled by the cosine of that error.
//!
//! **Balancing** ([`balance`]): a ballbot cannot follow rate set-points without falling; its
//! [`BalanceRuntime`] runs the balance controller at the control rate on the torque interface
//! [`hal::MotorTorques`], driven by the same velocity commands.
//!
//! Files: `controller.rs` (the [`Runtime`] and its cycle as named steps), `command.rs`,
//! `config.rs`, `status.rs` (the types), `plan.rs` (plan buffer, trajectory following),
//! `shape.rs` (command shaping and steering).
//!
//! ```
//! use omnikin::runtime::{Config, Runtime, Command, Frame, Mode, hal::*};
//! use omnikin::sphere::{SphereOmni, SphereParams};
//! use omnikin::{MAX_WHEELS, Pose2, Robot, Twist2};
//!
//! // A board whose motors turn exactly as commanded (omnikin_sim::sil adds motor models and
//! // disturbances). Encoders are read into `Enc` first so the board can be the motor output.
//! struct Board { angles: [f32; MAX_WHEELS], rates: [f32; MAX_WHEELS] }
//! struct Enc([f32; MAX_WHEELS]);
//! impl Encoders<f32> for Enc {
//!     type Error = ();
//!     fn read(&mut self) -> Result<EncoderAngles<f32>, ()> {
//!         Ok(EncoderAngles { wheel: self.0, steer: [0.0; MAX_WHEELS] })
//!     }
//! }
//! impl MotorOutputs<f32> for Board {
//!     type Error = ();
//!     fn set_rates(&mut self, c: &MotorCommand<f32>) -> Result<(), ()> {
//!         self.rates = c.wheel;
//!         Ok(())
//!     }
//! }
//! let robot = Robot::Sphere(SphereOmni::new(SphereParams::preset())?);
//! let mut rt = Runtime::<f32, 64>::new(robot, Config::new(100.0), Pose2::default())?;
//! let mut board = Board { angles: [0.0; MAX_WHEELS], rates: [0.0; MAX_WHEELS] };
//! rt.handle(Command::Velocity { twist: Twist2::new(0.1, 0.0, 0.0), frame: Frame::Robot }, 0)
//!     .unwrap();
//! for k in 0..100u64 {
//!     let now = k * 10_000; // µs
//!     rt.handle(Command::Heartbeat, now).unwrap(); // the link feeds the watchdog
//!     let faults = rt.cycle(now, &mut Enc(board.angles), &mut NoImu, &mut board);
//!     assert!(faults.is_empty());
//!     assert_eq!(rt.status().mode, Mode::Velocity); // telemetry: built when asked for
//!     for i in 0..3 { board.angles[i] += board.rates[i] * 0.01; }
//! }
//! // 0.1 s ramp at 1 m/s², then 0.1 m/s; the estimate lags one cycle: about 9.4 cm.
//! assert!((rt.pose().x - 0.094).abs() < 1e-3, "{}", rt.pose().x);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
pub mod balance;
pub mod hal;
pub mod limits;

mod command;
mod config;
mod controller;
mod cycle_inverse;
mod plan;
mod reference;
mod shape;
mod status;
mod tilt;

use crate::Real;
pub use balance::{BalanceRuntime, BalanceRuntimeConfig, BalanceStatus};
pub use command::{
    CameraFix, Command, CommandError, FIX_HISTORY, FIX_MAX_COORDINATE, FIX_MAX_STD_XY, Frame,
    PlanPoint,
};
pub use config::{Config, ConfigError, RATE_HZ_RANGE, TiltFeedback};
pub use controller::Runtime;
pub use plan::{REBASE_MIN_BLEND, SPLICE_MAX_JUMP};
pub use reference::plan_reference;
pub use status::{Faults, FixCounters, Mode, PlanStatus, Status};

/// A runtime the operator link drives ([`crate::link::serve`], [`crate::link::robot_info`]):
/// the rate runtime ([`Runtime`]) and the balance runtime ([`BalanceRuntime`]). One command
/// language and one error type for both, so one robot end serves either.
pub trait Operated<T: Real> {
    /// Takes an operator command received at clock time `now_us`, µs.
    ///
    /// # Errors
    /// [`CommandError`]: the command is refused, changes nothing, and is counted.
    fn handle(&mut self, command: Command<'_, T>, now_us: u64) -> Result<(), CommandError>;
    /// The robot kind it controls.
    fn kind(&self) -> crate::Kind;
    /// Plan buffer capacity, points (0: plans are refused).
    fn plan_capacity(&self) -> usize;
    /// Control rate, Hz.
    fn rate_hz(&self) -> T;
    /// Watchdog timeout, s.
    fn watchdog(&self) -> T;
    /// The body limits every command is held to (the link's HelloAck tells the operator).
    fn body_limits(&self) -> crate::link::RobotLimits;
}

impl<T: Real, const N: usize> Operated<T> for Runtime<T, N> {
    fn handle(&mut self, command: Command<'_, T>, now_us: u64) -> Result<(), CommandError> {
        Runtime::handle(self, command, now_us)
    }
    fn kind(&self) -> crate::Kind {
        self.robot().kind()
    }
    fn plan_capacity(&self) -> usize {
        N
    }
    fn rate_hz(&self) -> T {
        self.config().rate_hz
    }
    fn watchdog(&self) -> T {
        self.config().watchdog
    }
    fn body_limits(&self) -> crate::link::RobotLimits {
        let s = &self.config().slew;
        crate::link::RobotLimits {
            max_accel: s.accel.to_f64() as f32,
            max_yaw_accel: s.yaw_accel.to_f64() as f32,
            max_jerk: s.jerk.map_or(f32::INFINITY, |j| j.to_f64() as f32),
        }
    }
}
