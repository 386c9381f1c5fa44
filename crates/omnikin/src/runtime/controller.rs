//! The control loop: commands in, motor set-points out, once per cycle.

use serde::{Deserialize, Serialize};

use crate::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use crate::{Pose2, Real, Robot, Twist2, wrap_angle as wrap};

use super::hal::{EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs};
use super::limits::{RateLimits, Slew, SlewLimits, desaturate, motor_rates, saturation_scale};

/// What the robot is doing. Wire-stable: the discriminants are sent as one byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u8)]
pub enum Mode {
    /// At rest, waiting for a command.
    Idle = 0,
    /// Following a velocity command.
    Velocity = 1,
    /// Following the uploaded plan.
    Trajectory = 2,
    /// Braking to rest within the acceleration limits (stop command, watchdog, plan end,
    /// hardware fault); becomes [`Mode::Idle`] at rest.
    Stopping = 3,
    /// Emergency stop: motors at zero; latched until [`Command::Clear`].
    EStop = 4,
}

impl Mode {
    /// Lower-case name: `idle`, `velocity`, `trajectory`, `stopping`, `estop`.
    pub const fn name(self) -> &'static str {
        match self {
            Mode::Idle => "idle",
            Mode::Velocity => "velocity",
            Mode::Trajectory => "trajectory",
            Mode::Stopping => "stopping",
            Mode::EStop => "estop",
        }
    }
}

impl core::fmt::Display for Mode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// Fault flags (a bit set). Wire-stable bit positions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Faults(pub u16);

impl Faults {
    /// No fault.
    pub const NONE: Faults = Faults(0);
    /// A motor rate or acceleration limit shaped the command this cycle (desaturation scale
    /// below 1, or the wheel-acceleration limit was active).
    pub const LIMIT: Faults = Faults(1 << 0);
    /// Wheel slip detected: the gyro's yaw rate disagrees with the wheels' by more than
    /// [`Config::slip_yaw_rate`], or the caster's slip residual exceeds [`Config::slip_speed`]
    /// (both low-passed over [`Config::slip_filter`]).
    pub const SLIP: Faults = Faults(1 << 1);
    /// No valid command or heartbeat within [`Config::watchdog`] seconds.
    pub const LINK_LOST: Faults = Faults(1 << 2);
    /// The emergency stop is latched.
    pub const ESTOP: Faults = Faults(1 << 3);
    /// A command was rejected (non-finite, over the accepted bounds, e-stop latched, plan
    /// error).
    pub const REJECTED: Faults = Faults(1 << 4);
    /// A hardware trait returned an error, or the kinematics rejected a state.
    pub const HARDWARE: Faults = Faults(1 << 5);
    /// A cycle came more than twice the nominal period after the previous one.
    pub const OVERRUN: Faults = Faults(1 << 6);

    /// `true` when every bit of `other` is set.
    pub const fn contains(self, other: Faults) -> bool {
        self.0 & other.0 == other.0
    }
    /// Sets the bits of `other`.
    pub fn insert(&mut self, other: Faults) {
        self.0 |= other.0;
    }
    /// `true` when no bit is set.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Every flag with its name, in bit order.
    pub const ALL: [(Faults, &'static str); 7] = [
        (Faults::LIMIT, "limit"),
        (Faults::SLIP, "slip"),
        (Faults::LINK_LOST, "link_lost"),
        (Faults::ESTOP, "estop"),
        (Faults::REJECTED, "rejected"),
        (Faults::HARDWARE, "hardware"),
        (Faults::OVERRUN, "overrun"),
    ];
}

/// Names joined by `|` (`limit|slip`), or `none`.
impl core::fmt::Display for Faults {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.is_empty() {
            return f.write_str("none");
        }
        let mut first = true;
        for (flag, name) in Faults::ALL {
            if self.contains(flag) {
                if !first {
                    f.write_str("|")?;
                }
                f.write_str(name)?;
                first = false;
            }
        }
        Ok(())
    }
}

/// Frame of a velocity command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Frame {
    /// Robot frame: x forward, y left.
    Robot,
    /// World frame: converted with the current estimated heading every cycle.
    World,
}

/// One sample of an uploaded plan (world frame, SI units; as a row of the plan CSV without the
/// wheel rates, which the runtime recomputes with feedback).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanPoint<T> {
    /// Plan time, s.
    pub t: T,
    /// Reference pose (m, m, rad unwrapped).
    pub pose: Pose2<T>,
    /// Reference **world-frame** twist (m/s, m/s, rad/s): the feed-forward.
    pub twist: Twist2<T>,
}

impl<T: Real> PlanPoint<T> {
    /// All zeros.
    pub fn zero() -> Self {
        let z = T::zero();
        Self {
            t: z,
            pose: Pose2::new(z, z, z),
            twist: Twist2::new(z, z, z),
        }
    }
}

/// An operator command, already authenticated and decoded by the link.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command<'a, T> {
    /// Session start; only feeds the watchdog.
    Hello,
    /// Keeps the link alive (feeds the watchdog).
    Heartbeat,
    /// Drive with this twist (m/s, m/s, rad/s) in `frame` until told otherwise.
    Velocity {
        /// The twist.
        twist: Twist2<T>,
        /// Its frame.
        frame: Frame,
    },
    /// Start uploading plan `id` of `len` points (clears the buffer).
    PlanBegin {
        /// Plan identifier chosen by the operator.
        id: u16,
        /// Number of points that will follow.
        len: u16,
    },
    /// Points `offset..offset + points.len()` of plan `id`. Chunks may be re-sent (idempotent)
    /// and must not leave a gap.
    PlanChunk {
        /// Plan identifier.
        id: u16,
        /// Index of the first point.
        offset: u16,
        /// The points.
        points: &'a [PlanPoint<T>],
    },
    /// Start following plan `id` (all its points must have arrived).
    PlanStart {
        /// Plan identifier.
        id: u16,
    },
    /// Brake to rest within the acceleration limits.
    Stop,
    /// Emergency stop: motors to zero at once; latched until [`Command::Clear`].
    EStop,
    /// Clear the e-stop latch and the fault history.
    Clear,
    /// Reset the pose estimate (world frame, m, m, rad).
    SetPose(Pose2<T>),
}

/// Why a command was rejected (it is then not executed at all, and counted).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum CommandError {
    /// A value is NaN or infinite.
    #[error("{field} must be finite")]
    NonFinite {
        /// The field, e.g. `"vx"`, `"plan.pose.x"`.
        field: &'static str,
    },
    /// A value exceeds the accepted bound ([`Config::max_speed`], [`Config::max_yaw_rate`]).
    #[error("{field} = {value} exceeds the accepted bound {limit}")]
    OverLimit {
        /// The field, `"speed"` or `"yaw_rate"` (or `"plan.speed"`, `"plan.yaw_rate"`).
        field: &'static str,
        /// The value.
        value: f64,
        /// The bound.
        limit: f64,
    },
    /// The emergency stop is latched: only `Clear`, `Stop`, `EStop`, `Hello`, `Heartbeat`
    /// and `SetPose` are accepted.
    #[error("emergency stop is latched; send clear first")]
    EStopLatched,
    /// The plan does not fit the buffer.
    #[error("plan of {len} points exceeds the capacity of {capacity}")]
    PlanTooLong {
        /// Requested length.
        len: u16,
        /// Buffer capacity.
        capacity: usize,
    },
    /// A plan message names another plan than the one being uploaded.
    #[error("plan id {got} does not match the plan being uploaded ({expected})")]
    PlanIdMismatch {
        /// The current plan id.
        expected: u16,
        /// The id in the message.
        got: u16,
    },
    /// A chunk would leave a gap or run past the announced length.
    #[error(
        "plan chunk at offset {offset} with {count} points does not fit (have {have}, announced {len})"
    )]
    PlanChunkOutOfPlace {
        /// Chunk offset.
        offset: u16,
        /// Points in the chunk.
        count: usize,
        /// Points received so far.
        have: u16,
        /// Announced length.
        len: u16,
    },
    /// Plan times do not increase strictly.
    #[error("plan point {index}: time does not increase")]
    PlanTimeNotIncreasing {
        /// Index of the offending point.
        index: usize,
    },
    /// Start requested before every point arrived.
    #[error("plan incomplete: {have} of {len} points")]
    PlanIncomplete {
        /// Points received.
        have: u16,
        /// Announced length (at least 2 needed).
        len: u16,
    },
    /// A new plan upload was begun while a plan is running.
    #[error("a plan is running; stop it first")]
    Busy,
}

/// A configuration value that cannot work.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {rule}")]
pub struct ConfigError {
    /// The field, e.g. `"rate_hz"`.
    pub field: &'static str,
    /// What is allowed.
    pub rule: &'static str,
}

/// Range of the control rate [`Config::rate_hz`] that [`Config::validate`] accepts, Hz: at
/// least 1 Hz (a slower loop cannot keep a sub-second watchdog) and at most 10 kHz (the
/// clock counts whole microseconds, so a cycle needs at least 100 µs to be represented well;
/// faster than any omni drive's motor control needs).
pub const RATE_HZ_RANGE: (f64, f64) = (1.0, 10_000.0);

/// Control-loop settings. SI units; build with [`Config::new`] and adjust fields.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config<T> {
    /// Nominal cycle rate, Hz.
    pub rate_hz: T,
    /// Motor rate limits (desaturation), rad/s.
    pub rate_limits: RateLimits<T>,
    /// Largest wheel (roll) acceleration, rad/s² (`None`: unlimited).
    pub wheel_accel: Option<T>,
    /// Largest caster steer acceleration, rad/s² (`None`: unlimited).
    pub steer_accel: Option<T>,
    /// Body acceleration and jerk limits (world frame).
    pub slew: SlewLimits<T>,
    /// Commands faster than this (m/s, linear speed) are rejected as malformed; slower ones
    /// are desaturated to the motor limits.
    pub max_speed: T,
    /// Commands with a larger yaw-rate magnitude (rad/s) are rejected.
    pub max_yaw_rate: T,
    /// Watchdog time, s: no valid command or heartbeat for this long → controlled stop.
    pub watchdog: T,
    /// Trajectory position feedback gain, 1/s.
    pub k_position: T,
    /// Trajectory heading feedback gain, 1/s.
    pub k_heading: T,
    /// Largest position correction speed added to the feed-forward, m/s.
    pub max_correction: T,
    /// Largest heading correction rate added to the feed-forward, rad/s.
    pub max_yaw_correction: T,
    /// Slip threshold on |gyro yaw rate − wheel yaw rate|, rad/s.
    pub slip_yaw_rate: T,
    /// Slip threshold on the caster's least-squares residual, m/s.
    pub slip_speed: T,
    /// Time constant of the first-order low-pass applied to both slip signals before the
    /// thresholds, s (encoder quantisation makes single-cycle rates noisy).
    pub slip_filter: T,
    /// Take the heading change from the gyro (when an IMU sample arrives) instead of the
    /// wheels.
    pub heading_from_gyro: bool,
}

impl<T: Real> Config<T> {
    /// Defaults for a loop at `rate_hz`: no motor limits, 1 m/s², 4 rad/s², no jerk limit,
    /// accepted bounds 2 m/s and 10 rad/s, watchdog 0.5 s, gains 2/s, corrections ≤ 0.1 m/s
    /// and 0.5 rad/s, slip thresholds 0.5 rad/s and 0.05 m/s filtered over 0.1 s, heading from
    /// the wheels.
    pub fn new(rate_hz: T) -> Self {
        Self {
            rate_hz,
            rate_limits: RateLimits {
                wheel: None,
                steer: None,
            },
            wheel_accel: None,
            steer_accel: None,
            slew: SlewLimits {
                accel: T::one(),
                yaw_accel: T::of(4.0),
                jerk: None,
                yaw_jerk: None,
            },
            max_speed: T::of(2.0),
            max_yaw_rate: T::of(10.0),
            watchdog: T::of(0.5),
            k_position: T::of(2.0),
            k_heading: T::of(2.0),
            max_correction: T::of(0.1),
            max_yaw_correction: T::of(0.5),
            slip_yaw_rate: T::of(0.5),
            slip_speed: T::of(0.05),
            slip_filter: T::of(0.1),
            heading_from_gyro: false,
        }
    }

    /// Checks every value is finite and in range: the control rate within [`RATE_HZ_RANGE`],
    /// motor limits within 10⁻³–10⁵ rad/s and 10⁻³–10⁷ rad/s², body limits within plausible
    /// magnitudes (≤ 100 m/s, ≤ 10³ m/s², watchdog 1 ms to 1000 s; each rule names its range).
    ///
    /// # Errors
    /// [`ConfigError`] naming the first bad field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let pos = |x: T, field: &'static str| {
            if x.is_finite() && x > T::zero() {
                Ok(())
            } else {
                Err(ConfigError {
                    field,
                    rule: "must be finite and > 0",
                })
            }
        };
        let nonneg = |x: T, field: &'static str| {
            if x.is_finite() && x >= T::zero() {
                Ok(())
            } else {
                Err(ConfigError {
                    field,
                    rule: "must be finite and >= 0",
                })
            }
        };
        pos(self.rate_hz, "rate_hz")?;
        if !(self.rate_hz >= T::of(RATE_HZ_RANGE.0) && self.rate_hz <= T::of(RATE_HZ_RANGE.1)) {
            return Err(ConfigError {
                field: "rate_hz",
                rule: "must be between 1 and 10000 Hz (RATE_HZ_RANGE): the clock counts whole \
                       microseconds, and a loop below 1 Hz cannot keep a watchdog",
            });
        }
        let opt = |x: Option<T>, f| x.map_or(Ok(()), |v| pos(v, f));
        opt(self.rate_limits.wheel, "max_wheel_rate")?;
        opt(self.rate_limits.steer, "max_steer_rate")?;
        opt(self.wheel_accel, "max_wheel_accel")?;
        opt(self.steer_accel, "max_steer_accel")?;
        pos(self.slew.accel, "max_accel")?;
        pos(self.slew.yaw_accel, "max_yaw_accel")?;
        opt(self.slew.jerk, "max_jerk")?;
        opt(self.slew.yaw_jerk, "max_yaw_jerk")?;
        pos(self.max_speed, "max_speed")?;
        pos(self.max_yaw_rate, "max_yaw_rate")?;
        pos(self.watchdog, "watchdog")?;
        // Plausible magnitudes (finite but absurd values are errors, not motion that never
        // ends or never starts).
        let within = |x: T, lo: f64, hi: f64, field: &'static str, rule: &'static str| {
            if x >= T::of(lo) && x <= T::of(hi) {
                Ok(())
            } else {
                Err(ConfigError { field, rule })
            }
        };
        let opt_within = |x: Option<T>, lo, hi, field, rule| {
            x.map_or(Ok(()), |v| within(v, lo, hi, field, rule))
        };
        const RATE: &str = "must be between 1e-3 and 1e5 rad/s";
        const ACCEL: &str = "must be between 1e-3 and 1e7 rad/s²";
        opt_within(self.rate_limits.wheel, 1e-3, 1e5, "max_wheel_rate", RATE)?;
        opt_within(self.rate_limits.steer, 1e-3, 1e5, "max_steer_rate", RATE)?;
        opt_within(self.wheel_accel, 1e-3, 1e7, "max_wheel_accel", ACCEL)?;
        opt_within(self.steer_accel, 1e-3, 1e7, "max_steer_accel", ACCEL)?;
        within(
            self.slew.accel,
            1e-6,
            1e3,
            "max_accel",
            "must be between 1e-6 and 1e3 m/s²",
        )?;
        within(
            self.slew.yaw_accel,
            1e-6,
            1e4,
            "max_yaw_accel",
            "must be between 1e-6 and 1e4 rad/s²",
        )?;
        opt_within(
            self.slew.jerk,
            1e-6,
            1e6,
            "max_jerk",
            "must be between 1e-6 and 1e6 m/s³",
        )?;
        opt_within(
            self.slew.yaw_jerk,
            1e-6,
            1e7,
            "max_yaw_jerk",
            "must be between 1e-6 and 1e7 rad/s³",
        )?;
        within(
            self.max_speed,
            1e-6,
            100.0,
            "max_speed",
            "must be between 1e-6 and 100 m/s",
        )?;
        within(
            self.max_yaw_rate,
            1e-6,
            1e3,
            "max_yaw_rate",
            "must be between 1e-6 and 1e3 rad/s",
        )?;
        within(
            self.watchdog,
            1e-3,
            1e3,
            "watchdog",
            "must be between 1e-3 and 1e3 s",
        )?;
        nonneg(self.k_position, "k_position")?;
        nonneg(self.k_heading, "k_heading")?;
        nonneg(self.max_correction, "max_correction")?;
        nonneg(self.max_yaw_correction, "max_yaw_correction")?;
        pos(self.slip_yaw_rate, "slip_yaw_rate")?;
        pos(self.slip_speed, "slip_speed")?;
        nonneg(self.slip_filter, "slip_filter")?;
        Ok(())
    }
}

/// Progress of the plan buffer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PlanStatus {
    /// Current plan id.
    pub id: u16,
    /// Points received.
    pub received: u16,
    /// Points announced.
    pub len: u16,
    /// `true` once the running plan reached its last point.
    pub done: bool,
}

/// Everything the loop knows after a cycle (the content of telemetry).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Status<T> {
    /// Clock time of the cycle, µs.
    pub time_us: u64,
    /// Mode after the cycle.
    pub mode: Mode,
    /// Faults active in this cycle.
    pub faults: Faults,
    /// Faults seen since the last [`Command::Clear`] (sticky).
    pub fault_history: Faults,
    /// Estimated pose (world, m, m, rad unwrapped): wheel odometry, heading per
    /// [`Config::heading_from_gyro`].
    pub pose: Pose2<T>,
    /// Measured robot-frame twist from the encoders (mean over the last cycle).
    pub twist: Twist2<T>,
    /// Commanded robot-frame twist after limits.
    pub command: Twist2<T>,
    /// Motor set-points sent this cycle, rad/s.
    pub motors: MotorCommand<T>,
    /// Encoder angles read this cycle, rad.
    pub encoders: EncoderAngles<T>,
    /// Newest IMU sample, if any.
    pub imu: Option<ImuSample<T>>,
    /// Plan buffer status.
    pub plan: PlanStatus,
    /// Plan time of `reference`, s: the plan time that corresponds to the measured `pose`
    /// (meaningful in [`Mode::Trajectory`]).
    pub plan_time: T,
    /// Reference pose of the plan at `plan_time` (world).
    pub reference: Pose2<T>,
    /// Caster slip residual of the last odometry step, m/s (0 for the others).
    pub slip_residual: T,
    /// Commands rejected since start.
    pub rejected: u32,
    /// Clock time of the last valid command, µs (0 = none yet).
    pub last_command_us: u64,
}

/// Re-base the odometry time every this many seconds so `T = f32` keeps µs resolution.
const REBASE_S: f64 = 256.0;

/// The robot runtime: a fixed-rate control loop for one robot with a plan buffer of `N`
/// points. No allocation, no panic; `cycle` is O(1) except the plan index search, which moves
/// forward only (amortised O(1)).
///
/// Use: call [`Runtime::handle`] for each decoded command as it arrives (the newest valid
/// command wins), and [`Runtime::cycle`] from a timer at [`Config::rate_hz`].
#[derive(Clone, Debug)]
pub struct Runtime<T, const N: usize> {
    robot: Robot<T>,
    config: Config<T>,
    mode: Mode,
    estop: bool,
    history: Faults,
    slew: Slew<T>,
    odo: Odometry<T>,
    odo_base_us: Option<u64>,
    last_us: Option<u64>,
    last_rx_us: Option<u64>,
    velocity: (Twist2<T>, Frame),
    plan: [PlanPoint<T>; N],
    plan_status: PlanStatus,
    plan_time: T,
    reference_time: T,
    plan_index: usize,
    reference: Pose2<T>,
    last_motor: MotorCommand<T>,
    last_command: Twist2<T>,
    encoders: EncoderAngles<T>,
    steer: [T; 3],
    imu: Option<ImuSample<T>>,
    twist: Twist2<T>,
    slip_residual: T,
    /// Low-passed |gyro − wheel yaw rate| (rad/s) and caster residual (m/s).
    slip_state: [T; 2],
    rejected: u32,
}

fn zero_twist<T: Real>() -> Twist2<T> {
    Twist2::new(T::zero(), T::zero(), T::zero())
}

impl<T: Real, const N: usize> Runtime<T, N> {
    /// A runtime for `robot` at rest at `pose` (world, m, m, rad).
    ///
    /// # Errors
    /// [`ConfigError`] from [`Config::validate`].
    pub fn new(robot: Robot<T>, config: Config<T>, pose: Pose2<T>) -> Result<Self, ConfigError> {
        config.validate()?;
        let z = T::zero();
        Ok(Self {
            robot,
            config,
            mode: Mode::Idle,
            estop: false,
            history: Faults::NONE,
            slew: Slew::new(),
            odo: Odometry::new(robot, pose),
            odo_base_us: None,
            last_us: None,
            last_rx_us: None,
            velocity: (zero_twist(), Frame::Robot),
            plan: [PlanPoint::zero(); N],
            plan_status: PlanStatus::default(),
            plan_time: z,
            reference_time: z,
            plan_index: 0,
            reference: pose,
            last_motor: MotorCommand::zero(),
            last_command: zero_twist(),
            encoders: EncoderAngles {
                wheel: [z; 3],
                steer: [z; 3],
            },
            steer: [z; 3],
            imu: None,
            twist: zero_twist(),
            slip_residual: z,
            slip_state: [z; 2],
            rejected: 0,
        })
    }

    /// Plan buffer capacity, points.
    pub const CAPACITY: usize = N;

    /// The configuration.
    pub fn config(&self) -> &Config<T> {
        &self.config
    }

    /// The robot model.
    pub fn robot(&self) -> &Robot<T> {
        &self.robot
    }

    /// The current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The estimated pose (world).
    pub fn pose(&self) -> Pose2<T> {
        self.odo.pose()
    }

    /// Commands rejected so far.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Applies one command received at clock time `now_us`. A valid command feeds the
    /// watchdog and takes effect at the next cycle (the newest one wins); a rejected one
    /// changes nothing except the rejection counter and [`Faults::REJECTED`] in the history.
    ///
    /// # Errors
    /// [`CommandError`] saying why the command was rejected.
    pub fn handle(&mut self, command: Command<'_, T>, now_us: u64) -> Result<(), CommandError> {
        match self.apply(command) {
            Ok(()) => {
                self.last_rx_us = Some(now_us);
                Ok(())
            }
            Err(e) => {
                self.rejected = self.rejected.saturating_add(1);
                self.history.insert(Faults::REJECTED);
                Err(e)
            }
        }
    }

    fn check_motion(&self, twist: Twist2<T>, plan: bool) -> Result<(), CommandError> {
        let f = |x: T, field| {
            if x.is_finite() {
                Ok(())
            } else {
                Err(CommandError::NonFinite { field })
            }
        };
        let (fx, fy, fw, fs, fyr) = if plan {
            (
                "plan.vx",
                "plan.vy",
                "plan.yaw_rate",
                "plan.speed",
                "plan.yaw_rate",
            )
        } else {
            ("vx", "vy", "yaw_rate", "speed", "yaw_rate")
        };
        f(twist.vx, fx)?;
        f(twist.vy, fy)?;
        f(twist.yaw_rate, fw)?;
        let speed = (twist.vx * twist.vx + twist.vy * twist.vy).sqrt();
        if speed > self.config.max_speed {
            return Err(CommandError::OverLimit {
                field: fs,
                value: speed.to_f64(),
                limit: self.config.max_speed.to_f64(),
            });
        }
        if twist.yaw_rate.abs() > self.config.max_yaw_rate {
            return Err(CommandError::OverLimit {
                field: fyr,
                value: twist.yaw_rate.to_f64(),
                limit: self.config.max_yaw_rate.to_f64(),
            });
        }
        Ok(())
    }

    fn apply(&mut self, command: Command<'_, T>) -> Result<(), CommandError> {
        match command {
            Command::Hello | Command::Heartbeat => Ok(()),
            Command::Velocity { twist, frame } => {
                self.check_motion(twist, false)?;
                if self.estop {
                    return Err(CommandError::EStopLatched);
                }
                self.velocity = (twist, frame);
                self.mode = Mode::Velocity;
                Ok(())
            }
            Command::PlanBegin { id, len } => {
                if len as usize > N {
                    return Err(CommandError::PlanTooLong { len, capacity: N });
                }
                if self.mode == Mode::Trajectory {
                    return Err(CommandError::Busy);
                }
                self.plan_status = PlanStatus {
                    id,
                    received: 0,
                    len,
                    done: false,
                };
                Ok(())
            }
            Command::PlanChunk { id, offset, points } => {
                let st = self.plan_status;
                if id != st.id {
                    return Err(CommandError::PlanIdMismatch {
                        expected: st.id,
                        got: id,
                    });
                }
                if self.mode == Mode::Trajectory {
                    return Err(CommandError::Busy);
                }
                let start = offset as usize;
                let end = start + points.len();
                if offset > st.received || end > st.len as usize || points.is_empty() {
                    return Err(CommandError::PlanChunkOutOfPlace {
                        offset,
                        count: points.len(),
                        have: st.received,
                        len: st.len,
                    });
                }
                for (k, p) in points.iter().enumerate() {
                    let fin = |x: T, field| {
                        if x.is_finite() {
                            Ok(())
                        } else {
                            Err(CommandError::NonFinite { field })
                        }
                    };
                    fin(p.t, "plan.t")?;
                    fin(p.pose.x, "plan.x")?;
                    fin(p.pose.y, "plan.y")?;
                    fin(p.pose.heading, "plan.heading")?;
                    self.check_motion(p.twist, true)?;
                    let prev_t = if k > 0 {
                        Some(points[k - 1].t)
                    } else if start > 0 {
                        Some(self.plan[start - 1].t)
                    } else {
                        None
                    };
                    if prev_t.is_some_and(|pt| {
                        p.t.partial_cmp(&pt) != Some(core::cmp::Ordering::Greater)
                    }) {
                        return Err(CommandError::PlanTimeNotIncreasing { index: start + k });
                    }
                }
                self.plan[start..end].copy_from_slice(points);
                if end as u16 > st.received {
                    self.plan_status.received = end as u16;
                }
                Ok(())
            }
            Command::PlanStart { id } => {
                let st = self.plan_status;
                if id != st.id {
                    return Err(CommandError::PlanIdMismatch {
                        expected: st.id,
                        got: id,
                    });
                }
                if st.received != st.len || st.len < 2 {
                    return Err(CommandError::PlanIncomplete {
                        have: st.received,
                        len: st.len,
                    });
                }
                if self.estop {
                    return Err(CommandError::EStopLatched);
                }
                let n = st.len as usize;
                for i in 1..n {
                    if self.plan[i].t.partial_cmp(&self.plan[i - 1].t)
                        != Some(core::cmp::Ordering::Greater)
                    {
                        return Err(CommandError::PlanTimeNotIncreasing { index: i });
                    }
                }
                self.plan_time = self.plan[0].t;
                self.reference_time = self.plan[0].t;
                self.plan_index = 0;
                self.plan_status.done = false;
                self.mode = Mode::Trajectory;
                Ok(())
            }
            Command::Stop => {
                if self.mode != Mode::EStop {
                    self.mode = Mode::Stopping;
                }
                Ok(())
            }
            Command::EStop => {
                self.estop = true;
                self.mode = Mode::EStop;
                self.history.insert(Faults::ESTOP);
                Ok(())
            }
            Command::Clear => {
                self.estop = false;
                self.history = Faults::NONE;
                if self.mode == Mode::EStop {
                    self.mode = Mode::Idle;
                }
                Ok(())
            }
            Command::SetPose(p) => {
                if !(p.x.is_finite() && p.y.is_finite() && p.heading.is_finite()) {
                    return Err(CommandError::NonFinite { field: "pose" });
                }
                self.odo.reset_pose(p);
                Ok(())
            }
        }
    }

    /// Reference pose and world twist of the plan at `tau` (s): cubic Hermite in position and
    /// heading (using the sampled velocities as tangents), linear in velocity.
    fn reference_at(&mut self, tau: T) -> (Pose2<T>, Twist2<T>) {
        let n = self.plan_status.len as usize;
        let pts = &self.plan[..n.min(N)];
        if pts.is_empty() {
            return (self.odo.pose(), zero_twist());
        }
        if tau <= pts[0].t {
            return (pts[0].pose, pts[0].twist);
        }
        let last = pts[pts.len() - 1];
        if tau >= last.t {
            return (last.pose, zero_twist());
        }
        let mut k = self.plan_index.min(pts.len() - 2);
        if pts[k].t > tau {
            k = 0;
        }
        while k + 2 < pts.len() && pts[k + 1].t <= tau {
            k += 1;
        }
        self.plan_index = k;
        let (a, b) = (pts[k], pts[k + 1]);
        let h = b.t - a.t;
        let s = (tau - a.t) / h;
        let (s2, s3) = (s * s, s * s * s);
        let two = T::of(2.0);
        let three = T::of(3.0);
        let h00 = two * s3 - three * s2 + T::one();
        let h10 = s3 - two * s2 + s;
        let h01 = -two * s3 + three * s2;
        let h11 = s3 - s2;
        let herm = |p0: T, v0: T, p1: T, v1: T| h00 * p0 + h10 * h * v0 + h01 * p1 + h11 * h * v1;
        let pose = Pose2::new(
            herm(a.pose.x, a.twist.vx, b.pose.x, b.twist.vx),
            herm(a.pose.y, a.twist.vy, b.pose.y, b.twist.vy),
            herm(
                a.pose.heading,
                a.twist.yaw_rate,
                b.pose.heading,
                b.twist.yaw_rate,
            ),
        );
        let lerp = |x: T, y: T| x + (y - x) * s;
        let twist = Twist2::new(
            lerp(a.twist.vx, b.twist.vx),
            lerp(a.twist.vy, b.twist.vy),
            lerp(a.twist.yaw_rate, b.twist.yaw_rate),
        );
        (pose, twist)
    }

    /// One control cycle at clock time `now_us`: read the encoders and the IMU, update the
    /// odometry, run the watchdog, shape the newest command (desaturation, acceleration and
    /// jerk limits, wheel-acceleration limit), inverse kinematics, write the motors.
    ///
    /// Never panics and never allocates; hardware errors become [`Faults::HARDWARE`] and a
    /// controlled stop (zero motor command if the encoders cannot be read).
    pub fn cycle<E, I, M>(
        &mut self,
        now_us: u64,
        encoders: &mut E,
        imu: &mut I,
        motors: &mut M,
    ) -> Status<T>
    where
        E: Encoders<T>,
        I: Imu<T>,
        M: MotorOutputs<T>,
    {
        let cfg = self.config;
        let nominal = T::one() / cfg.rate_hz;
        let mut faults = Faults::NONE;
        let mut dt = nominal;
        if let Some(last) = self.last_us {
            let el = T::of(now_us.saturating_sub(last) as f64 * 1e-6);
            if el > T::of(2.0) * nominal {
                faults.insert(Faults::OVERRUN);
                dt = T::of(2.0) * nominal;
            } else if el > T::zero() {
                dt = el;
            }
        }
        self.last_us = Some(now_us);

        // Sensors.
        let mut hw_ok = true;
        match imu.read() {
            Ok(Some(s)) => self.imu = Some(s),
            Ok(None) => {}
            Err(_) => {
                faults.insert(Faults::HARDWARE);
                self.imu = None;
            }
        }
        match encoders.read() {
            Ok(a) => {
                self.encoders = a;
                self.steer = a.steer;
                let base = *self.odo_base_us.get_or_insert(now_us);
                let t = T::of(now_us.saturating_sub(base) as f64 * 1e-6);
                let heading = match (cfg.heading_from_gyro, self.imu) {
                    (true, Some(s)) => HeadingInput::GyroRate(s.gyro[2]),
                    _ => HeadingInput::Wheels,
                };
                let reading = EncoderReading::with_steer(t, a.wheel, a.steer);
                if self.odo.time().is_none_or(|t0| t > t0) {
                    match self.odo.update(&reading, heading) {
                        Ok(step) => {
                            if step.dt > T::zero() {
                                self.twist = step.twist;
                                self.slip_residual = step.slip_residual;
                                let k = step.dt / (cfg.slip_filter + step.dt);
                                let st = &mut self.slip_state;
                                st[1] += k * (step.slip_residual - st[1]);
                                if let Some(s) = self.imu {
                                    let wheel_rate = step.wheel_heading_change / step.dt;
                                    st[0] += k * ((s.gyro[2] - wheel_rate).abs() - st[0]);
                                }
                                if st[0] > cfg.slip_yaw_rate || st[1] > cfg.slip_speed {
                                    faults.insert(Faults::SLIP);
                                }
                            }
                            if t > T::of(REBASE_S) {
                                // Re-base: a fresh odometry at the current pose whose reference
                                // is this very reading, so no increment is lost.
                                let mut fresh = Odometry::new(self.robot, self.odo.pose());
                                let r0 = EncoderReading::with_steer(T::zero(), a.wheel, a.steer);
                                if fresh.update(&r0, heading).is_ok() {
                                    self.odo = fresh;
                                    self.odo_base_us = Some(now_us);
                                }
                            }
                        }
                        Err(_) => {
                            faults.insert(Faults::HARDWARE);
                            hw_ok = false;
                        }
                    }
                }
            }
            Err(_) => {
                faults.insert(Faults::HARDWARE);
                hw_ok = false;
            }
        }
        let pose = self.odo.pose();

        // Watchdog.
        let link_lost = self
            .last_rx_us
            .is_some_and(|t| T::of(now_us.saturating_sub(t) as f64 * 1e-6) > cfg.watchdog);
        if link_lost {
            faults.insert(Faults::LINK_LOST);
            if matches!(self.mode, Mode::Velocity | Mode::Trajectory) {
                self.mode = Mode::Stopping;
            }
        }
        if faults.contains(Faults::HARDWARE)
            && matches!(self.mode, Mode::Velocity | Mode::Trajectory)
        {
            self.mode = Mode::Stopping;
        }

        // Target (world frame). One `sin_cos` of the heading serves every frame change below.
        let rot = crate::drive::Rot2::from_angle(pose.heading);
        let target = match self.mode {
            Mode::Idle | Mode::Stopping | Mode::EStop => zero_twist(),
            Mode::Velocity => match self.velocity.1 {
                Frame::Robot => self.velocity.0.rotated_by(rot),
                Frame::World => self.velocity.0,
            },
            Mode::Trajectory => {
                // Feedback against the reference at the time of the measured pose; feed-forward
                // of the mean reference velocity over the coming cycle.
                let (r, _) = self.reference_at(self.plan_time);
                let (_, ff) = self.reference_at(self.plan_time + dt * T::of(0.5));
                self.reference = r;
                self.reference_time = self.plan_time;
                self.plan_time += dt;
                let (ex, ey) = (r.x - pose.x, r.y - pose.y);
                let (mut cx, mut cy) = (cfg.k_position * ex, cfg.k_position * ey);
                let cn = (cx * cx + cy * cy).sqrt();
                if cn > cfg.max_correction && cn > T::zero() {
                    let k = cfg.max_correction / cn;
                    cx *= k;
                    cy *= k;
                }
                let cw = (cfg.k_heading * wrap(r.heading - pose.heading))
                    .clamp(-cfg.max_yaw_correction, cfg.max_yaw_correction);
                let n = self.plan_status.len as usize;
                if n > 0 && self.plan_time >= self.plan[(n - 1).min(N - 1)].t {
                    self.plan_status.done = true;
                    self.mode = Mode::Stopping;
                }
                Twist2::new(ff.vx + cx, ff.vy + cy, ff.yaw_rate + cw)
            }
        };

        let mut command = MotorCommand::zero();
        let mut twist_cmd = zero_twist();
        if self.mode == Mode::EStop || self.estop || !hw_ok {
            self.slew.reset();
            if self.estop {
                faults.insert(Faults::ESTOP);
            }
        } else {
            match self.shape(target, pose.heading, rot, dt, &mut faults) {
                Ok((c, tw)) => {
                    command = c;
                    twist_cmd = tw;
                }
                Err(()) => {
                    faults.insert(Faults::HARDWARE);
                    self.slew.reset();
                    self.mode = Mode::Stopping;
                }
            }
            if self.mode == Mode::Stopping && self.slew.velocity() == zero_twist() {
                self.mode = Mode::Idle;
            }
        }
        if motors.set_rates(&command).is_err() {
            faults.insert(Faults::HARDWARE);
        }
        self.last_motor = command;
        self.last_command = twist_cmd;
        self.history.insert(faults);

        Status {
            time_us: now_us,
            mode: self.mode,
            faults,
            fault_history: self.history,
            pose,
            twist: self.twist,
            command: twist_cmd,
            motors: command,
            encoders: self.encoders,
            imu: self.imu,
            plan: self.plan_status,
            plan_time: self.reference_time,
            reference: self.reference,
            slip_residual: self.slip_residual,
            rejected: self.rejected,
            last_command_us: self.last_rx_us.unwrap_or(0),
        }
    }

    /// Desaturation → slew → inverse kinematics → wheel-acceleration limit → final rate clamp.
    /// `rot` is `{cos, sin}` of `heading`: every frame change here shares it.
    fn shape(
        &mut self,
        target_world: Twist2<T>,
        heading: T,
        rot: crate::drive::Rot2<T>,
        dt: T,
        faults: &mut Faults,
    ) -> Result<(MotorCommand<T>, Twist2<T>), ()> {
        let cfg = &self.config;
        let steer = self.steer;
        let to_world = |v: Twist2<T>| v.rotated_by(rot);
        let to_robot = |v: Twist2<T>| {
            v.rotated_by(crate::drive::Rot2 {
                cos: rot.cos,
                sin: -rot.sin,
            })
        };
        let d = desaturate(
            &self.robot,
            to_robot(target_world),
            heading,
            steer,
            &cfg.rate_limits,
        )
        .map_err(|_| ())?;
        if d.scale < T::one() {
            faults.insert(Faults::LIMIT);
        }
        let v_world = self.slew.step(to_world(d.twist), dt, &cfg.slew);
        let mut v = to_robot(v_world);
        let mut rates = motor_rates(&self.robot, v, heading, steer).map_err(|_| ())?;
        // Wheel (and steer) acceleration limit: scale the change of all rates by one factor.
        let mut s = T::one();
        let mut limit = |new: &[T; 3], old: &[T; 3], a: Option<T>| {
            if let Some(a) = a {
                let step = a * dt;
                for i in 0..3 {
                    let dlt = (new[i] - old[i]).abs();
                    if dlt > step && dlt > T::zero() {
                        s = s.min(step / dlt);
                    }
                }
            }
        };
        limit(&rates.wheel, &self.last_motor.wheel, cfg.wheel_accel);
        limit(&rates.steer, &self.last_motor.steer, cfg.steer_accel);
        if s < T::one() {
            faults.insert(Faults::LIMIT);
            let old = self.last_motor;
            for i in 0..3 {
                rates.wheel[i] = old.wheel[i] + s * (rates.wheel[i] - old.wheel[i]);
                rates.steer[i] = old.steer[i] + s * (rates.steer[i] - old.steer[i]);
            }
            let lc = self.last_command;
            v = Twist2::new(
                lc.vx + s * (v.vx - lc.vx),
                lc.vy + s * (v.vy - lc.vy),
                lc.yaw_rate + s * (v.yaw_rate - lc.yaw_rate),
            );
            self.slew.set_velocity(to_world(v));
        }
        let k = saturation_scale(&rates, &cfg.rate_limits);
        if k < T::one() {
            faults.insert(Faults::LIMIT);
            rates.wheel = rates.wheel.map(|r| r * k);
            rates.steer = rates.steer.map(|r| r * k);
            v = Twist2::new(v.vx * k, v.vy * k, v.yaw_rate * k);
            self.slew.set_velocity(to_world(v));
        }
        let finite = rates
            .wheel
            .iter()
            .chain(rates.steer.iter())
            .all(|x| x.is_finite());
        if !finite {
            return Err(());
        }
        Ok((rates, v))
    }
}
