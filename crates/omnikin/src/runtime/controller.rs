//! The [`Runtime`]: its state, [`Runtime::handle`] for operator commands, and
//! [`Runtime::cycle`] as named steps — clock, sensors and odometry (with the slip checks),
//! watchdog, target of the mode, command shaping ([`super::shape`]), motors, status.

use nalgebra::Matrix3;

use crate::drive::Rot2;
use crate::estimate::events::{EventDecimator, EventDetector};
use crate::estimate::fix::Fix;
use crate::estimate::fusion::{FusionError, FusionOutcome, PoseFusion, StepHeading};
use crate::estimate::odometry::{HeadingInput, Odometry};
use crate::{Pose2, Real, Robot, Twist2};

use super::command::{CameraFix, Command, CommandError, FIX_HISTORY, Frame, check_motion};
use super::config::{Config, ConfigError};
use super::hal::{EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs};
use super::limits::Slew;
use super::plan::{PlanBuffer, zero_twist};
use super::status::{Faults, FixCounters, Mode, Status};
use super::tilt::{tilt_estimate, tilt_known};

/// Longest sample of the event detector, s: odometry steps are merged up to this (and up to a
/// quarter of the detector's smoothing time), so a 1 kHz loop runs it at 400 Hz; a loop at
/// 400 Hz or slower feeds it every step.
const EVENT_SAMPLE_PERIOD_S: f64 = 0.0025;

/// Re-base the odometry time every this many seconds so `T = f32` keeps µs resolution.
const REBASE_S: f64 = 256.0;

/// The robot runtime: a fixed-rate control loop for one robot (any kind, up to
/// [`crate::MAX_WHEELS`] wheels) with a plan buffer of `N` points. No allocation, no panic;
/// `cycle` is O(1) except the plan index search, which moves forward only (amortised O(1)).
///
/// Use: call [`Runtime::handle`] for each decoded command as it arrives (the newest valid
/// command wins), and [`Runtime::cycle`] from a timer at [`Config::rate_hz`].
///
/// **Fixes.** Beside the wheel odometry the runtime runs a pose fusion filter
/// ([`PoseFusion`], [`FIX_HISTORY`] entries, [`Config::fusion`]) fed with every odometry
/// step; a [`Command::Fix`] is fused at its capture time (up to `max_latency` late; older
/// ones are counted [`FixCounters::too_late`]). Once a fix has been accepted the control —
/// velocity commands in the world frame, plan following — uses the **fused** pose, so a
/// plan's tracking is corrected by the camera; until then it uses the wheel odometry (the
/// two are the same prediction, so nothing changes for a robot that gets no fixes). The
/// wheel odometry keeps running uncorrected ([`Status::odometry`]).
#[derive(Clone, Debug)]
pub struct Runtime<T, const N: usize> {
    pub(super) robot: Robot<T>,
    /// `robot.wheels()`, the used length of every per-wheel array.
    pub(super) wheels: usize,
    /// `robot.kind().steer_is_set_point()`: steer motors track the inverse's angles.
    pub(super) steer_set_point: bool,
    pub(super) config: Config<T>,
    pub(super) mode: Mode,
    estop: bool,
    history: Faults,
    /// The faults of the latest cycle ([`Status::faults`]).
    faults: Faults,
    pub(super) slew: Slew<T>,
    odo: Odometry<T>,
    odo_base_us: Option<u64>,
    /// The fusion filter, on the odometry's (re-based) clock.
    fusion: PoseFusion<T, FIX_HISTORY>,
    fixes: FixCounters,
    /// Clock time of the newest odometry step, µs.
    odo_us: Option<u64>,
    last_us: Option<u64>,
    last_rx_us: Option<u64>,
    velocity: (Twist2<T>, Frame),
    pub(super) plan: PlanBuffer<T, N>,
    /// Motor set-points of the previous cycle.
    pub(super) last_motor: MotorCommand<T>,
    /// Commanded robot-frame twist of the previous cycle.
    pub(super) last_command: Twist2<T>,
    /// Encoder angles of the newest successful read (the steer angles the inverse uses).
    pub(super) encoders: EncoderAngles<T>,
    pub(super) imu: Option<ImuSample<T>>,
    twist: Twist2<T>,
    slip_residual: T,
    /// Slip and collision events ([`Config::events`]).
    events: EventDetector<T>,
    /// The odometry steps merged for the event detector ([`EVENT_SAMPLE_PERIOD_S`], at most
    /// a quarter of the smoothing time).
    event_steps: EventDecimator<T>,
    rejected: u32,
    /// The tilt estimate of [`Config::tilt`]: up in the platform frame, unit (all zero before
    /// the first accelerometer sample; see [`super::TiltFeedback`]). Last in the struct: the
    /// firmware's boot builds the runtime in one frame (bench/budgets.toml).
    pub(super) tilt_up: [T; 3],
    /// The robot-frame acceleration the last cycle commanded (what the tilt estimate
    /// subtracts from the accelerometer), m/s²; zero once used.
    pub(super) tilt_accel: [T; 2],
}

/// The heading rate an IMU sample gives, rad/s: the gyro's z (a platform that stays level),
/// or, with `up` (a sphere's pendulous platform, [`Config::tilt`]: the tilt estimate, up in
/// the platform frame, unit), the angular velocity's component along the vertical, `ω · γ̂`:
/// on a platform leaning by `θ` while it turns at `ψ̇`, the gyro's z reads `ψ̇ cos θ`, and the
/// heading would lag by `1 − cos θ` of every turn (2 % at 0.2 rad).
#[inline(always)]
fn yaw_rate<T: Real>(s: &ImuSample<T>, up: Option<[T; 3]>) -> T {
    let w = s.gyro;
    match up {
        Some(g) => w[0] * g[0] + w[1] * g[1] + w[2] * g[2],
        None => w[2],
    }
}

impl<T: Real, const N: usize> Runtime<T, N> {
    /// A runtime for `robot` at rest at `pose` (world, m, m, rad).
    ///
    /// # Errors
    /// [`ConfigError`] from [`Config::validate`].
    pub fn new(robot: Robot<T>, config: Config<T>, pose: Pose2<T>) -> Result<Self, ConfigError> {
        config.validate()?;
        Self::check_filter(pose, &config)?;
        let z = T::zero();
        Ok(Self {
            robot,
            wheels: robot.wheels(),
            steer_set_point: robot.kind().steer_is_set_point(),
            config,
            mode: Mode::Idle,
            estop: false,
            history: Faults::NONE,
            faults: Faults::NONE,
            slew: Slew::new(),
            odo: Odometry::new(robot, pose),
            odo_base_us: None,
            // Checked above; built without a `Result` around its history.
            fusion: PoseFusion::new_checked(T::zero(), pose, Matrix3::zeros(), config.fusion),
            fixes: FixCounters::default(),
            odo_us: None,
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
            events: EventDetector::new(config.events, robot.motors() > 3),
            event_steps: EventDecimator::new(Self::event_period(&config)),
            rejected: 0,
            tilt_up: [z; 3],
            tilt_accel: [z; 2],
        })
    }

    /// Makes this runtime the one [`Runtime::new`] would build for `robot`, `config` and
    /// `pose`, **in place**: a firmware keeps its runtime in a `static` (the plan buffer and
    /// the fusion history are most of its size) and never builds a second one on the stack.
    /// Everything is forgotten — mode, e-stop latch, fault history, plan, fusion history,
    /// counters.
    ///
    /// # Errors
    /// As [`Runtime::new`]; the runtime is then unchanged.
    pub fn reset(
        &mut self,
        robot: Robot<T>,
        config: Config<T>,
        pose: Pose2<T>,
    ) -> Result<(), ConfigError> {
        config.validate()?;
        Self::check_filter(pose, &config)?;
        let z = T::zero();
        self.robot = robot;
        self.wheels = robot.wheels();
        self.steer_set_point = robot.kind().steer_is_set_point();
        self.config = config;
        self.mode = Mode::Idle;
        self.estop = false;
        self.history = Faults::NONE;
        self.faults = Faults::NONE;
        self.slew = Slew::new();
        self.odo = Odometry::new(robot, pose);
        self.odo_base_us = None;
        self.fusion
            .reset_checked(T::zero(), pose, Matrix3::zeros(), config.fusion);
        self.fixes = FixCounters::default();
        self.odo_us = None;
        self.last_us = None;
        self.last_rx_us = None;
        self.velocity = (zero_twist(), Frame::Robot);
        self.plan.reset(pose);
        self.last_motor = MotorCommand::zero();
        self.last_command = zero_twist();
        self.encoders = EncoderAngles::zero();
        self.imu = None;
        self.twist = zero_twist();
        self.slip_residual = z;
        self.events = EventDetector::new(config.events, robot.motors() > 3);
        self.event_steps = EventDecimator::new(Self::event_period(&config));
        self.rejected = 0;
        self.tilt_up = [z; 3];
        self.tilt_accel = [z; 2];
        Ok(())
    }

    /// Length of the event detector's samples, s (at most a quarter of its smoothing time).
    fn event_period(config: &Config<T>) -> T {
        (config.events.smoothing * T::of(0.25)).min(T::of(EVENT_SAMPLE_PERIOD_S))
    }

    /// The checks of the fusion filter [`Runtime::new`] builds at `pose`, as configuration
    /// errors.
    fn check_filter(pose: Pose2<T>, config: &Config<T>) -> Result<(), ConfigError> {
        PoseFusion::<T, FIX_HISTORY>::check_inputs(
            T::zero(),
            pose,
            Matrix3::zeros(),
            &config.fusion,
        )
        .map_err(|e| match e {
            FusionError::BadParameter { field, rule, .. } => ConfigError { field, rule },
            FusionError::NonFinite { field } => ConfigError {
                field,
                rule: "must be finite",
            },
            _ => ConfigError {
                field: "fusion",
                rule: "invalid fusion filter parameters",
            },
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

    /// The estimated pose (world) the control uses: the fused pose once a fix has been
    /// accepted, the wheel odometry before (see the type's docs).
    pub fn pose(&self) -> Pose2<T> {
        if self.fixes.accepted > 0 {
            self.fusion.pose()
        } else {
            self.odo.pose()
        }
    }

    /// The pure wheel odometry (world), never corrected by fixes.
    pub fn odometry_pose(&self) -> Pose2<T> {
        self.odo.pose()
    }

    /// The fusion filter (pose, covariance, gyro bias, wheel scale).
    pub fn fusion(&self) -> &PoseFusion<T, FIX_HISTORY> {
        &self.fusion
    }

    /// What became of the fixes so far.
    pub fn fix_counters(&self) -> FixCounters {
        self.fixes
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
        let feeds_watchdog = !matches!(command, Command::Fix(_));
        match self.apply(command) {
            Ok(()) => {
                if feeds_watchdog {
                    self.last_rx_us = Some(now_us);
                }
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
            Command::PlanBegin { id, len } => self.plan.begin(id, len, running, false, false),
            Command::PlanSplice { id, len } => self.plan.begin(id, len, running, true, false),
            Command::PlanSpliceRebased { id, len } => self.plan.begin(id, len, running, true, true),
            Command::PlanChunk { id, offset, points } => {
                self.plan.chunk(id, offset, points, running, &self.config)
            }
            Command::PlanStart { id } => {
                // A retransmitted start of the running (or finished) plan changes nothing.
                if self.plan.start(id, self.estop, running)? {
                    self.mode = Mode::Trajectory;
                }
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
                // The filter restarts at the set pose, known exactly (bias and scale
                // estimates restart at their priors), in place: no second filter on the stack.
                let _ = self.fusion.restart(self.fusion.time(), p, Matrix3::zeros());
                Ok(())
            }
            Command::Fix(fix) => self.fix(&fix),
        }
    }

    /// Fuses one external fix (validated first) at its capture time and counts the outcome.
    fn fix(&mut self, fix: &CameraFix<T>) -> Result<(), CommandError> {
        fix.check()?;
        let (Some(base), Some(latest)) = (self.odo_base_us, self.odo_us) else {
            // No odometry yet: nothing to fuse into.
            self.fixes.too_late = self.fixes.too_late.saturating_add(1);
            return Ok(());
        };
        if fix.capture_us > latest {
            return Err(CommandError::FixInFuture {
                capture_us: fix.capture_us,
                latest_us: latest,
            });
        }
        // On the odometry's re-based clock (negative before the latest re-base).
        let t = T::of((fix.capture_us as f64 - base as f64) * 1e-6);
        let f = Fix {
            t,
            x: fix.x,
            y: fix.y,
            heading: fix.heading,
            std_xy: fix.std_xy,
            std_heading: fix.std_heading,
        };
        let c = &mut self.fixes;
        match self.fusion.add_fix(&f) {
            Ok(FusionOutcome::Initialised | FusionOutcome::Accepted { .. }) => {
                c.accepted = c.accepted.saturating_add(1);
            }
            Ok(FusionOutcome::Recovered { .. }) => {
                c.accepted = c.accepted.saturating_add(1);
                c.recoveries = c.recoveries.saturating_add(1);
            }
            Ok(FusionOutcome::Rejected { .. }) => c.rejected = c.rejected.saturating_add(1),
            Err(FusionError::TooLate { .. }) => c.too_late = c.too_late.saturating_add(1),
            // Within a cycle of the latest step on the µs clock but past it on `T`'s.
            Err(FusionError::InFuture { .. }) => {
                return Err(CommandError::FixInFuture {
                    capture_us: fix.capture_us,
                    latest_us: latest,
                });
            }
            Err(FusionError::NonFinite { field }) => return Err(CommandError::NonFinite { field }),
            Err(FusionError::BadParameter { field, value, rule }) => {
                return Err(CommandError::OutOfRange { field, value, rule });
            }
            Err(FusionError::NonMonotonicTime { .. }) => {}
        }
        Ok(())
    }

    /// One control cycle at clock time `now_us`: read the encoders and the IMU, update the
    /// odometry, run the watchdog, shape the newest command (desaturation, acceleration and
    /// jerk limits, wheel-acceleration limit), inverse kinematics, write the motors. Returns
    /// the cycle's faults; the whole state is [`Runtime::status`], built when it is asked for
    /// (a telemetry frame at the link's rate), not every cycle.
    ///
    /// Never panics and never allocates; hardware errors become [`Faults::HARDWARE`] and a
    /// controlled stop (zero motor command if the encoders cannot be read).
    pub fn cycle<E, I, M>(
        &mut self,
        now_us: u64,
        encoders: &mut E,
        imu: &mut I,
        motors: &mut M,
    ) -> Faults
    where
        E: Encoders<T>,
        I: Imu<T>,
        M: MotorOutputs<T>,
    {
        let mut faults = Faults::NONE;
        let dt = self.clock(now_us, &mut faults);
        let hw_ok = self.sense(now_us, encoders, imu, &mut faults);
        // An event's flag stays up for its whole episode (cycles without a new encoder step
        // included), so it rises once per event.
        if self.events.slipping() {
            faults.insert(Faults::SLIP);
        }
        if self.events.colliding() {
            faults.insert(Faults::COLLISION);
        }
        let pose = self.pose();
        self.watchdog(now_us, &mut faults);
        // One `sin_cos` of the heading serves every frame change of the cycle: the odometry's
        // (computed with its pose, which it composes the next step with) until a fix moves
        // the control to the fused pose.
        let rot = if self.fixes.accepted > 0 {
            Rot2::from_angle(pose.heading)
        } else {
            self.odo.rotation()
        };
        let target = self.target(pose, rot, dt);
        let twist_cmd = self.actuate(target, rot, dt, hw_ok, &mut faults);
        if motors.set_rates(&self.last_motor).is_err() {
            faults.insert(Faults::HARDWARE);
        }
        self.last_command = twist_cmd;
        self.history.insert(faults);
        self.faults = faults;
        faults
    }

    /// The tilt estimate of [`Config::tilt`]: the up direction in the platform frame (unit;
    /// `(0, 0, 1)` level), from the gyro and the accelerometer minus the commanded
    /// acceleration ([`super::TiltFeedback`]). `None` without `Config::tilt` or before the
    /// first IMU sample.
    pub fn tilt_estimate(&self) -> Option<[T; 3]> {
        tilt_known(self.tilt_up)
    }

    /// The state after the latest [`Runtime::cycle`] (the content of telemetry): mode, this
    /// cycle's and the latched faults, the control's pose (fused once a fix was accepted) and
    /// the wheel odometry's, the command, the motors, the plan. Before the first cycle: time 0,
    /// the initial pose, no faults.
    pub fn status(&self) -> Status<T> {
        Status {
            time_us: self.last_us.unwrap_or(0),
            mode: self.mode,
            faults: self.faults,
            fault_history: self.history,
            pose: self.pose(),
            odometry: self.odo.pose(),
            covariance: self.fusion.settled_pose_variances(),
            fixes: self.fixes,
            twist: self.twist,
            command: self.last_command,
            wheels: self.wheels as u8,
            motors: self.last_motor,
            encoders: self.encoders,
            imu: self.imu,
            plan: self.plan.status,
            plan_time: self.plan.reference_time,
            reference: self.plan.reference,
            slip_residual: self.slip_residual,
            events: self.events.counters(),
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
            Ok(Some(s)) => {
                self.imu = Some(s);
                if let Some(tf) = &self.config.tilt {
                    let dt = T::one() / self.config.rate_hz;
                    tilt_estimate(&mut self.tilt_up, &s, self.tilt_accel, dt, tf);
                    self.tilt_accel = [T::zero(); 2];
                }
            }
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
            (true, Some(s)) => HeadingInput::GyroRate(yaw_rate(
                &s,
                if cfg.tilt.is_some() {
                    tilt_known(self.tilt_up)
                } else {
                    None
                },
            )),
            _ => HeadingInput::Wheels,
        };
        if !self.odo.time().is_none_or(|t0| t > t0) {
            return true;
        }
        // The step read in place, in the `Result` the odometry wrote (moving it out would copy
        // its 168 bytes every cycle).
        let result = self.odo.update_angles(t, &a, heading);
        let Ok(step) = &result else {
            faults.insert(Faults::HARDWARE);
            return false;
        };
        self.odo_us = Some(now_us);
        if step.dt > T::zero() {
            let sh = match heading {
                HeadingInput::GyroRate(_) => StepHeading::Gyro,
                _ => StepHeading::Wheels,
            };
            // Cannot fail for a finite step at a later time; the filter is left as it was.
            let _ = self.fusion.advance(t, step.delta, sh);
            // Events: slip (the least-squares residual of the fit on over-determined kinds,
            // the gyro against the wheels' yaw rate) and collision (the wheel speed's
            // deceleration), the detector `omnikin odometry` runs, on steps merged over a
            // quarter of its smoothing time.
            self.twist = step.twist;
            self.slip_residual = step.slip_residual;
            if let Some((mut sample, gyro)) =
                self.event_steps.push(step, self.imu.map(|s| s.gyro[2]))
            {
                // The speed commanded now: the last cycle's command (an e-stop's zero
                // included), so the braking the robot commanded is not taken for a collision.
                let c = self.last_command;
                sample.commanded_speed = Some((c.vx * c.vx + c.vy * c.vy).sqrt());
                self.events.sample(&sample, gyro);
            }
        }
        if t > T::of(REBASE_S) {
            // Re-base: a fresh odometry at the current pose whose reference is this very
            // reading, so no increment is lost.
            let mut fresh = Odometry::new(self.robot, self.odo.pose());
            if fresh.update_angles(T::zero(), &a, heading).is_ok() {
                self.odo = fresh;
                self.odo_base_us = Some(now_us);
                self.fusion.shift_time(t);
                self.events.shift_time(t);
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
    /// shaped command ([`Runtime::shape`]); a mode at rest after a stop becomes idle. The
    /// motor set-points are left in `self.last_motor`; returns the commanded twist.
    #[inline(always)]
    fn actuate(
        &mut self,
        target: Twist2<T>,
        rot: Rot2<T>,
        dt: T,
        hw_ok: bool,
        faults: &mut Faults,
    ) -> Twist2<T> {
        let mut twist_cmd = zero_twist();
        if self.mode == Mode::EStop || self.estop || !hw_ok {
            self.last_motor = MotorCommand::zero();
            self.slew.reset();
            if self.estop {
                faults.insert(Faults::ESTOP);
            }
        } else {
            match self.shape(target, rot, dt, faults) {
                Ok(tw) => twist_cmd = tw,
                Err(()) => {
                    self.last_motor = MotorCommand::zero();
                    faults.insert(Faults::HARDWARE);
                    self.slew.reset();
                    self.mode = Mode::Stopping;
                }
            }
            if self.mode == Mode::Stopping && self.slew.velocity() == zero_twist() {
                self.mode = Mode::Idle;
            }
        }
        twist_cmd
    }
}
