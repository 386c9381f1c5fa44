//! The [`Runtime`]: its state, [`Runtime::handle`] for operator commands, and
//! [`Runtime::cycle`] as named steps — clock, sensors and odometry (with the slip checks),
//! watchdog, target of the mode, command shaping ([`super::shape`]), motors, status.

use crate::drive::Rot2;
use crate::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use crate::{Pose2, Real, Robot, Twist2};

use super::command::{Command, CommandError, Frame, check_motion};
use super::config::{Config, ConfigError};
use super::hal::{EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs};
use super::limits::Slew;
use super::plan::{PlanBuffer, zero_twist};
use super::status::{Faults, Mode, Status};

/// Re-base the odometry time every this many seconds so `T = f32` keeps µs resolution.
const REBASE_S: f64 = 256.0;

/// The robot runtime: a fixed-rate control loop for one robot (any kind, up to
/// [`crate::MAX_WHEELS`] wheels) with a plan buffer of `N` points. No allocation, no panic;
/// `cycle` is O(1) except the plan index search, which moves forward only (amortised O(1)).
///
/// Use: call [`Runtime::handle`] for each decoded command as it arrives (the newest valid
/// command wins), and [`Runtime::cycle`] from a timer at [`Config::rate_hz`].
#[derive(Clone, Debug)]
pub struct Runtime<T, const N: usize> {
    pub(super) robot: Robot<T>,
    /// `robot.wheels()`, the used length of every per-wheel array.
    pub(super) wheels: usize,
    /// `robot.kind().steer_is_set_point()`: steer motors track the inverse's angles.
    pub(super) steer_set_point: bool,
    pub(super) config: Config<T>,
    mode: Mode,
    estop: bool,
    history: Faults,
    pub(super) slew: Slew<T>,
    odo: Odometry<T>,
    odo_base_us: Option<u64>,
    last_us: Option<u64>,
    last_rx_us: Option<u64>,
    velocity: (Twist2<T>, Frame),
    plan: PlanBuffer<T, N>,
    /// Motor set-points of the previous cycle.
    pub(super) last_motor: MotorCommand<T>,
    /// Commanded robot-frame twist of the previous cycle.
    pub(super) last_command: Twist2<T>,
    /// Encoder angles of the newest successful read (the steer angles the inverse uses).
    pub(super) encoders: EncoderAngles<T>,
    imu: Option<ImuSample<T>>,
    twist: Twist2<T>,
    slip_residual: T,
    /// Low-passed |gyro − wheel yaw rate| (rad/s) and least-squares slip residual (m/s).
    slip_state: [T; 2],
    rejected: u32,
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
            wheels: robot.wheels(),
            steer_set_point: robot.kind().steer_is_set_point(),
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
            plan: PlanBuffer::new(pose),
            last_motor: MotorCommand::zero(),
            last_command: zero_twist(),
            encoders: EncoderAngles::zero(),
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

    fn apply(&mut self, command: Command<'_, T>) -> Result<(), CommandError> {
        let running = self.mode == Mode::Trajectory;
        match command {
            Command::Hello | Command::Heartbeat => Ok(()),
            Command::Velocity { twist, frame } => {
                check_motion(twist, false, &self.config)?;
                if self.estop {
                    return Err(CommandError::EStopLatched);
                }
                self.velocity = (twist, frame);
                self.mode = Mode::Velocity;
                Ok(())
            }
            Command::PlanBegin { id, len } => self.plan.begin(id, len, running),
            Command::PlanChunk { id, offset, points } => {
                self.plan.chunk(id, offset, points, running, &self.config)
            }
            Command::PlanStart { id } => {
                self.plan.start(id, self.estop)?;
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
        let mut faults = Faults::NONE;
        let dt = self.clock(now_us, &mut faults);
        let hw_ok = self.sense(now_us, encoders, imu, &mut faults);
        let pose = self.odo.pose();
        self.watchdog(now_us, &mut faults);
        // One `sin_cos` of the heading serves every frame change of the cycle.
        let rot = Rot2::from_angle(pose.heading);
        let target = self.target(pose, rot, dt);
        let (command, twist_cmd) = self.actuate(target, rot, dt, hw_ok, &mut faults);
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
            wheels: self.wheels as u8,
            motors: command,
            encoders: self.encoders,
            imu: self.imu,
            plan: self.plan.status,
            plan_time: self.plan.reference_time,
            reference: self.plan.reference,
            slip_residual: self.slip_residual,
            rejected: self.rejected,
            last_command_us: self.last_rx_us.unwrap_or(0),
        }
    }

    /// Step 1, clock: the time since the previous cycle, s (the nominal period on the first
    /// cycle; an overrun beyond twice the period is flagged and clamped).
    #[inline(always)]
    fn clock(&mut self, now_us: u64, faults: &mut Faults) -> T {
        let nominal = T::one() / self.config.rate_hz;
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
        dt
    }

    /// Step 2, sensors: the IMU, then the encoders into the odometry. `false` when the
    /// encoders or the odometry failed (the motors are then zeroed).
    #[inline(always)]
    fn sense<E: Encoders<T>, I: Imu<T>>(
        &mut self,
        now_us: u64,
        encoders: &mut E,
        imu: &mut I,
        faults: &mut Faults,
    ) -> bool {
        match imu.read() {
            Ok(Some(s)) => self.imu = Some(s),
            Ok(None) => {}
            Err(_) => {
                faults.insert(Faults::HARDWARE);
                self.imu = None;
            }
        }
        match encoders.read() {
            Ok(a) => self.odometry(now_us, a, faults),
            Err(_) => {
                faults.insert(Faults::HARDWARE);
                false
            }
        }
    }

    /// Odometry of one encoder reading, the slip checks, and the periodic re-base.
    #[inline(always)]
    fn odometry(&mut self, now_us: u64, a: EncoderAngles<T>, faults: &mut Faults) -> bool {
        let cfg = &self.config;
        self.encoders = a;
        let base = *self.odo_base_us.get_or_insert(now_us);
        let t = T::of(now_us.saturating_sub(base) as f64 * 1e-6);
        let heading = match (cfg.heading_from_gyro, self.imu) {
            (true, Some(s)) => HeadingInput::GyroRate(s.gyro[2]),
            _ => HeadingInput::Wheels,
        };
        if !self.odo.time().is_none_or(|t0| t > t0) {
            return true;
        }
        let reading = EncoderReading::with_steer(t, a.wheel, a.steer);
        let Ok(step) = self.odo.update(&reading, heading) else {
            faults.insert(Faults::HARDWARE);
            return false;
        };
        if step.dt > T::zero() {
            // Slip: the least-squares residual of the fit (over-determined kinds) and the
            // gyro against the wheels' yaw rate, both low-passed.
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
            // Re-base: a fresh odometry at the current pose whose reference is this very
            // reading, so no increment is lost.
            let mut fresh = Odometry::new(self.robot, self.odo.pose());
            let r0 = EncoderReading::with_steer(T::zero(), a.wheel, a.steer);
            if fresh.update(&r0, heading).is_ok() {
                self.odo = fresh;
                self.odo_base_us = Some(now_us);
            }
        }
        true
    }

    /// Step 3, watchdog: no valid command or heartbeat for [`Config::watchdog`] (or a hardware
    /// fault) turns a moving mode into a controlled stop.
    #[inline(always)]
    fn watchdog(&mut self, now_us: u64, faults: &mut Faults) {
        let link_lost = self
            .last_rx_us
            .is_some_and(|t| T::of(now_us.saturating_sub(t) as f64 * 1e-6) > self.config.watchdog);
        if link_lost {
            faults.insert(Faults::LINK_LOST);
        }
        if (link_lost || faults.contains(Faults::HARDWARE))
            && matches!(self.mode, Mode::Velocity | Mode::Trajectory)
        {
            self.mode = Mode::Stopping;
        }
    }

    /// Step 4, the world-frame target twist of the mode (`rot`: the heading's rotation).
    #[inline(always)]
    fn target(&mut self, pose: Pose2<T>, rot: Rot2<T>, dt: T) -> Twist2<T> {
        match self.mode {
            Mode::Idle | Mode::Stopping | Mode::EStop => zero_twist(),
            Mode::Velocity => match self.velocity.1 {
                Frame::Robot => self.velocity.0.rotated_by(rot),
                Frame::World => self.velocity.0,
            },
            Mode::Trajectory => {
                let (target, done) = self.plan.follow(pose, dt, &self.config);
                if done {
                    self.mode = Mode::Stopping;
                }
                target
            }
        }
    }

    /// Step 5, actuation: zero motors on an e-stop or unreadable encoders, otherwise the
    /// shaped command ([`Runtime::shape`]); a mode at rest after a stop becomes idle.
    #[inline(always)]
    fn actuate(
        &mut self,
        target: Twist2<T>,
        rot: Rot2<T>,
        dt: T,
        hw_ok: bool,
        faults: &mut Faults,
    ) -> (MotorCommand<T>, Twist2<T>) {
        let mut command = MotorCommand::zero();
        let mut twist_cmd = zero_twist();
        if self.mode == Mode::EStop || self.estop || !hw_ok {
            self.slew.reset();
            if self.estop {
                faults.insert(Faults::ESTOP);
            }
        } else {
            match self.shape(target, rot, dt, faults) {
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
        (command, twist_cmd)
    }
}
