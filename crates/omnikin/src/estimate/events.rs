//! Slip and collision **events** from the odometry steps and the IMU: one detector for the
//! offline pipeline (`omnikin odometry`) and the runtime on the robot (no allocation, fixed
//! size, no panic).
//!
//! * **Slip** (a wheel spinning or skidding): the wheels' yaw rate
//!   ([`OdometryStep::wheel_heading_change`] / `dt`) disagrees with the IMU's yaw rate by more
//!   than [`EventThresholds::slip_yaw_rate`], or — for the kinds with more wheel constraints
//!   than twist components (caster, swerve, omni with more than three wheels) — the
//!   least-squares slip residual ([`OdometryStep::slip_residual`]) exceeds
//!   [`EventThresholds::slip_residual`]. Both signals are smoothed by a first-order low-pass
//!   of time constant [`EventThresholds::smoothing`] (encoder quantisation at 1 kHz is
//!   otherwise larger than a slip).
//! * **Collision** (a sudden stop the robot did not command): the smoothed wheel speed
//!   `|(vx, vy)|` falls faster than [`EventThresholds::collision_decel`] over
//!   [`EventThresholds::window`], beyond what the commanded speed fell in the same window,
//!   while no slip is under way (the end of a wheel spin is also a sudden drop of the wheel
//!   speed). The detector tests the **unexplained speed** `v_measured − v_commanded`, both
//!   through the same low-pass: braking the robot commanded (an e-stop's motors off, a stop, the
//!   watchdog, a plan's end) drops both together and is no collision; an obstacle drops only
//!   the measured one. Without commands (a log, `omnikin odometry`) the commanded speed is 0
//!   and the test is the measured deceleration alone.
//!
//! An event starts on the first sample over its threshold and ends once the signal has stayed
//! below it for [`EventThresholds::hold`]: **one event per episode**, however long it lasts
//! and however the signal flickers. The deceleration window keeps at most
//! [`WINDOW_SAMPLES`] samples: at encoder rates above `WINDOW_SAMPLES / window` (2.56 kHz
//! with the default 50 ms) the window shortens to the newest [`WINDOW_SAMPLES`] samples.
//!
//! Thresholds come from the robot file's `[events]` table (`omnikin::description::events`);
//! the defaults are [`DEFAULT_SLIP_YAW_RATE`], [`DEFAULT_SLIP_RESIDUAL`] and
//! [`DEFAULT_COLLISION_DECEL`].

use heapless::Deque;
use serde::{Deserialize, Serialize};

use super::odometry::OdometryStep;
use crate::Real;

/// Default [`EventThresholds::slip_yaw_rate`], rad/s.
pub const DEFAULT_SLIP_YAW_RATE: f64 = 0.3;
/// Default [`EventThresholds::slip_residual`], m/s.
pub const DEFAULT_SLIP_RESIDUAL: f64 = 0.05;
/// Default [`EventThresholds::collision_decel`], m/s².
pub const DEFAULT_COLLISION_DECEL: f64 = 3.0;
/// Samples the deceleration window holds at most.
pub const WINDOW_SAMPLES: usize = 128;

/// Detection thresholds and time constants (SI units, each finite and > 0).
/// [`EventThresholds::standard`]: 0.3 rad/s, 0.05 m/s, 3 m/s², 50 ms window, 10 ms smoothing,
/// 0.2 s hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventThresholds<T> {
    /// Yaw-rate disagreement between wheels and IMU that counts as slip, rad/s.
    pub slip_yaw_rate: T,
    /// Least-squares slip residual that counts as slip, m/s (redundant kinds only).
    pub slip_residual: T,
    /// Deceleration of the wheel speed that counts as a collision, m/s².
    pub collision_decel: T,
    /// Window over which the deceleration is measured, s.
    pub window: T,
    /// Low-pass time constant of the signals, s.
    pub smoothing: T,
    /// Time below threshold that ends an event, s.
    pub hold: T,
}

impl<T: Real> EventThresholds<T> {
    /// The defaults (the robot file's defaults for the three thresholds).
    pub fn standard() -> Self {
        Self {
            slip_yaw_rate: T::of(DEFAULT_SLIP_YAW_RATE),
            slip_residual: T::of(DEFAULT_SLIP_RESIDUAL),
            collision_decel: T::of(DEFAULT_COLLISION_DECEL),
            window: T::of(0.05),
            smoothing: T::of(0.01),
            hold: T::of(0.2),
        }
    }

    /// The first field that is not finite and > 0, by name (`"slip_yaw_rate"`, …).
    pub fn invalid_field(&self) -> Option<&'static str> {
        [
            (self.slip_yaw_rate, "slip_yaw_rate"),
            (self.slip_residual, "slip_residual"),
            (self.collision_decel, "collision_decel"),
            (self.window, "window"),
            (self.smoothing, "smoothing"),
            (self.hold, "hold"),
        ]
        .into_iter()
        .find(|(v, _)| !(v.is_finite() && *v > T::zero()))
        .map(|(_, name)| name)
    }
}

impl<T: Real> Default for EventThresholds<T> {
    /// [`EventThresholds::standard`].
    fn default() -> Self {
        Self::standard()
    }
}

/// What happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum EventKind {
    /// Wheel slip or spin.
    Slip,
    /// A sudden stop.
    Collision,
}

impl EventKind {
    /// `slip` or `collision`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Slip => "slip",
            Self::Collision => "collision",
        }
    }
}

/// One detected event (times on the odometry's clock, s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event<T> {
    /// Slip or collision.
    pub kind: EventKind,
    /// First sample over the threshold, s.
    pub start: T,
    /// Last sample over the threshold, s.
    pub end: T,
    /// Largest smoothed signal during it: rad/s (yaw-rate slip), m/s (residual slip) or m/s²
    /// (collision).
    pub peak: T,
}

/// Events started since the detector was made. Wire-stable field order (it is sent in the
/// link's estimate telemetry).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct EventCounters {
    /// Slip episodes.
    pub slips: u32,
    /// Collisions.
    pub collisions: u32,
}

/// What one sample did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventStep<T> {
    /// A slip episode is under way after this sample: from its first sample over the
    /// threshold until the signal has stayed below for the hold time (so a flickering signal
    /// is one episode, and a fault flag driven by this rises once per event).
    pub slipping: bool,
    /// A collision episode is under way after this sample (likewise).
    pub colliding: bool,
    /// An event that started at this sample (slip before collision when both did).
    pub started: [Option<EventKind>; 2],
    /// Events that ended at this sample (their signal stayed below for the hold time).
    pub finished: [Option<Event<T>>; 2],
}

#[derive(Clone, Copy, Debug)]
struct Episode<T> {
    active: Option<Event<T>>,
}

impl<T: Real> Episode<T> {
    /// Feeds one sample: whether an event started, and a finished one.
    fn feed(
        &mut self,
        kind: EventKind,
        t: T,
        over: bool,
        value: T,
        hold: T,
    ) -> (bool, Option<Event<T>>) {
        match (&mut self.active, over) {
            (None, true) => {
                self.active = Some(Event {
                    kind,
                    start: t,
                    end: t,
                    peak: value,
                });
                (true, None)
            }
            (Some(e), true) => {
                e.end = t;
                if value > e.peak {
                    e.peak = value;
                }
                (false, None)
            }
            (Some(e), false) if t - e.end >= hold => (false, self.active.take()),
            _ => (false, None),
        }
    }
}

/// The detector over a stream of odometry steps: [`EventDetector::step`] per sample,
/// [`EventDetector::finish`] at the end of a log. Fixed size (a [`WINDOW_SAMPLES`]-entry
/// window), O(1) amortised per step, no allocation, no panic.
#[derive(Clone, Debug)]
pub struct EventDetector<T> {
    th: EventThresholds<T>,
    redundant: bool,
    yaw_mismatch: T,
    residual: T,
    speed: T,
    /// Smoothed commanded speed (0 without commands).
    commanded: T,
    /// (t, smoothed measured − commanded speed) over the last window.
    speeds: Deque<(T, T), WINDOW_SAMPLES>,
    slip: Episode<T>,
    collision: Episode<T>,
    counters: EventCounters,
    /// The low-pass gain `1 − exp(−dt/smoothing)` of the last step's `dt` (a fixed-rate loop
    /// computes the exponential once).
    gain: (T, T),
}

impl<T: Real> EventDetector<T> {
    /// A detector with `thresholds`; `redundant`: the robot kind has a least-squares slip
    /// residual ([`crate::Kind`] with more wheel constraints than twist components), so the
    /// residual test applies.
    pub fn new(thresholds: EventThresholds<T>, redundant: bool) -> Self {
        let z = T::zero();
        Self {
            th: thresholds,
            redundant,
            yaw_mismatch: z,
            residual: z,
            speed: z,
            commanded: z,
            speeds: Deque::new(),
            slip: Episode { active: None },
            collision: Episode { active: None },
            counters: EventCounters::default(),
            gain: (z, z),
        }
    }

    /// The thresholds in use.
    pub fn thresholds(&self) -> &EventThresholds<T> {
        &self.th
    }

    /// A slip episode is under way ([`EventStep::slipping`] of the last step).
    pub fn slipping(&self) -> bool {
        self.slip.active.is_some()
    }

    /// A collision episode is under way ([`EventStep::colliding`] of the last step).
    pub fn colliding(&self) -> bool {
        self.collision.active.is_some()
    }

    /// Events started so far.
    pub fn counters(&self) -> EventCounters {
        self.counters
    }

    /// Feeds one odometry step; `imu_yaw_rate` is the IMU's yaw rate over the step (rad/s,
    /// robot frame z) when there is one — without it the yaw-rate slip test is off. Steps with
    /// `dt ≤ 0` (the first sample) or a non-finite value change nothing.
    pub fn step(&mut self, s: &OdometryStep<T>, imu_yaw_rate: Option<T>) -> EventStep<T> {
        let sample = EventSample {
            t: s.t,
            dt: s.dt,
            speed: (s.twist.vx * s.twist.vx + s.twist.vy * s.twist.vy).sqrt(),
            slip_residual: s.slip_residual,
            wheel_heading_change: s.wheel_heading_change,
            commanded_speed: None,
        };
        self.sample(&sample, imu_yaw_rate)
    }

    /// [`EventDetector::step`] on what it takes from an odometry step (for a caller that
    /// feeds merged steps, [`EventDecimator`]).
    pub fn sample(&mut self, s: &EventSample<T>, imu_yaw_rate: Option<T>) -> EventStep<T> {
        let mut out = EventStep {
            slipping: false,
            colliding: false,
            started: [None; 2],
            finished: [None; 2],
        };
        let speed = s.speed;
        if !(s.dt > T::zero()
            && s.t.is_finite()
            && speed.is_finite()
            && s.slip_residual.is_finite()
            && s.wheel_heading_change.is_finite()
            && s.commanded_speed.is_none_or(|v| v.is_finite())
            && imu_yaw_rate.is_none_or(|w| w.is_finite()))
        {
            return out;
        }
        if s.dt != self.gain.0 {
            self.gain = (s.dt, T::one() - (-s.dt / self.th.smoothing).exp());
        }
        let a = self.gain.1;
        let mut yaw_over = false;
        if let Some(w) = imu_yaw_rate {
            let mismatch = (w - s.wheel_heading_change / s.dt).abs();
            self.yaw_mismatch += a * (mismatch - self.yaw_mismatch);
            yaw_over = self.yaw_mismatch > self.th.slip_yaw_rate;
        }
        self.residual += a * (s.slip_residual - self.residual);
        self.speed += a * (speed - self.speed);
        self.commanded += a * (s.commanded_speed.unwrap_or(T::zero()) - self.commanded);
        let (slip_over, slip_value) = if yaw_over {
            (true, self.yaw_mismatch)
        } else if self.redundant && self.residual > self.th.slip_residual {
            (true, self.residual)
        } else {
            (false, T::zero())
        };
        let (started, done) =
            self.slip
                .feed(EventKind::Slip, s.t, slip_over, slip_value, self.th.hold);
        if started {
            self.counters.slips = self.counters.slips.saturating_add(1);
            out.started[0] = Some(EventKind::Slip);
        }
        out.finished[0] = done;
        out.slipping = self.slip.active.is_some();
        // The unexplained deceleration over the window, from the oldest value kept.
        let unexplained = self.speed - self.commanded;
        if self.speeds.is_full() {
            self.speeds.pop_front();
        }
        // Cannot fail: one slot was just made free.
        let _ = self.speeds.push_back((s.t, unexplained));
        while self
            .speeds
            .front()
            .is_some_and(|&(t0, _)| s.t - t0 > self.th.window)
        {
            self.speeds.pop_front();
        }
        let decel = match self.speeds.front() {
            Some(&(t0, v0)) if s.t > t0 => (v0 - unexplained) / (s.t - t0),
            _ => T::zero(),
        };
        let over = self.slip.active.is_none() && decel > self.th.collision_decel;
        let (started, done) =
            self.collision
                .feed(EventKind::Collision, s.t, over, decel, self.th.hold);
        if started {
            self.counters.collisions = self.counters.collisions.saturating_add(1);
            out.started[1] = Some(EventKind::Collision);
        }
        out.finished[1] = done;
        out.colliding = self.collision.active.is_some();
        out
    }

    /// Moves the clock origin `by` seconds later (every kept time − `by`): for a caller that
    /// re-bases its odometry clock, so that windows and hold times stay continuous.
    pub fn shift_time(&mut self, by: T) {
        for (t, _) in self.speeds.iter_mut() {
            *t -= by;
        }
        for e in [&mut self.slip.active, &mut self.collision.active]
            .into_iter()
            .flatten()
        {
            e.start -= by;
            e.end -= by;
        }
    }

    /// Ends the open events (at the end of a log): slip first, then collision.
    pub fn finish(&mut self) -> [Option<Event<T>>; 2] {
        [self.slip.active.take(), self.collision.active.take()]
    }
}

/// What the detector takes from one odometry step (or several merged,
/// [`EventDecimator`]). Times on the odometry's clock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventSample<T> {
    /// Time at the end of the sample, s.
    pub t: T,
    /// Length of the sample, s.
    pub dt: T,
    /// Mean wheel speed `|(vx, vy)|` over the sample, m/s.
    pub speed: T,
    /// Mean least-squares slip residual over the sample, m/s.
    pub slip_residual: T,
    /// Heading change implied by the wheels over the sample, rad.
    pub wheel_heading_change: T,
    /// Mean commanded speed `|(vx, vy)|` over the sample, m/s (the runtime's command; `None`
    /// without commands: a log).
    pub commanded_speed: Option<T>,
}

/// Sums consecutive odometry steps into one [`EventSample`] until they span `period`: a
/// control loop at 1 kHz runs the detector at `1/period` instead of every cycle. With the
/// runtime's period (2.5 ms, and at most a quarter of [`EventThresholds::smoothing`]) the
/// low-pass (exact for any sample length) and the deceleration window see the same signals
/// up to that resolution; an event is flagged at most one period later.
///
/// Merging: speed and yaw rate are means over the merged time (the speed of the mean
/// robot-frame velocity), the slip residual its time-weighted mean, the wheels' heading change
/// the sum; the IMU's yaw rate is used only when every merged step had one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventDecimator<T> {
    period: T,
    dt: T,
    vx_dt: T,
    vy_dt: T,
    residual_dt: T,
    wheel_heading_change: T,
    gyro_dt: T,
    gyro_every_step: bool,
}

impl<T: Real> EventDecimator<T> {
    /// Samples of at least `period` seconds (`period ≤ 0`: every step is a sample).
    pub fn new(period: T) -> Self {
        let z = T::zero();
        Self {
            period,
            dt: z,
            vx_dt: z,
            vy_dt: z,
            residual_dt: z,
            wheel_heading_change: z,
            gyro_dt: z,
            gyro_every_step: true,
        }
    }

    /// Adds one step (`dt > 0`; others are ignored) and the IMU's yaw rate over it; returns the
    /// merged sample and its mean IMU yaw rate once the steps span the period. The sample's
    /// [`EventSample::commanded_speed`] is `None`: a caller with commands sets it (the command
    /// at the sample's end is within one merge period of its mean, well inside the smoothing).
    pub fn push(
        &mut self,
        s: &OdometryStep<T>,
        imu_yaw_rate: Option<T>,
    ) -> Option<(EventSample<T>, Option<T>)> {
        if s.dt.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
            return None;
        }
        self.dt += s.dt;
        self.vx_dt += s.twist.vx * s.dt;
        self.vy_dt += s.twist.vy * s.dt;
        self.residual_dt += s.slip_residual * s.dt;
        self.wheel_heading_change += s.wheel_heading_change;
        match imu_yaw_rate {
            Some(w) => self.gyro_dt += w * s.dt,
            None => self.gyro_every_step = false,
        }
        // Not finite: emitted at once, and the detector ignores it.
        if self.dt < self.period {
            return None;
        }
        let dt = self.dt;
        let sample = EventSample {
            t: s.t,
            dt,
            speed: (self.vx_dt * self.vx_dt + self.vy_dt * self.vy_dt).sqrt() / dt,
            slip_residual: self.residual_dt / dt,
            wheel_heading_change: self.wheel_heading_change,
            commanded_speed: None,
        };
        let gyro = self.gyro_every_step.then(|| self.gyro_dt / dt);
        *self = Self::new(self.period);
        Some((sample, gyro))
    }
}
