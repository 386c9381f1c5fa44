//! Slip and collision events from the odometry steps.
//!
//! * **Slip** (a wheel spinning or skidding): the wheels' heading rate disagrees with the IMU's
//!   (heading from `gyro_z` or `yaw`) by more than [`EventThresholds::slip_yaw_rate`], or — for
//!   the kinds with more motors than twist components — the least-squares slip residual exceeds
//!   [`EventThresholds::slip_residual`]. Both signals are smoothed by a first-order low-pass of
//!   time constant [`EventThresholds::smoothing`] (encoder quantisation at 1 kHz is otherwise
//!   larger than a slip).
//! * **Collision** (a sudden stop): the smoothed wheel speed falls faster than
//!   [`EventThresholds::collision_decel`] over [`EventThresholds::window`], while no slip is
//!   under way (the end of a wheel spin is also a sudden drop of the wheel speed).
//!
//! An event starts on the first sample over its threshold and ends once the signal has stayed
//! below it for [`EventThresholds::hold`]: one event per episode.

use std::collections::VecDeque;

use omnikin::estimate::odometry::OdometryStep;

/// Detection thresholds. [`Default`]: 0.3 rad/s, 0.05 m/s, 3 m/s² (the robot file's defaults,
/// [`omnikin::description::events`]), 50 ms window, 10 ms smoothing, 0.2 s hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventThresholds {
    /// Yaw-rate disagreement between wheels and IMU that counts as slip, rad/s (> 0).
    pub slip_yaw_rate: f64,
    /// Least-squares slip residual that counts as slip, m/s (> 0; redundant kinds).
    pub slip_residual: f64,
    /// Deceleration of the wheel speed that counts as a collision, m/s² (> 0).
    pub collision_decel: f64,
    /// Window over which the deceleration is measured, s (> 0).
    pub window: f64,
    /// Low-pass time constant of the signals, s (> 0).
    pub smoothing: f64,
    /// Time below threshold that ends an event, s (> 0).
    pub hold: f64,
}

impl Default for EventThresholds {
    fn default() -> Self {
        Self {
            slip_yaw_rate: omnikin::description::events::DEFAULT_SLIP_YAW_RATE,
            slip_residual: omnikin::description::events::DEFAULT_SLIP_RESIDUAL,
            collision_decel: omnikin::description::events::DEFAULT_COLLISION_DECEL,
            window: 0.05,
            smoothing: 0.01,
            hold: 0.2,
        }
    }
}

/// Thresholds given to the pipeline that override the robot file's `[events]` (`None`: the
/// robot file's value, else the default). Each must be finite and > 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EventOverrides {
    /// As [`EventThresholds::slip_yaw_rate`], rad/s.
    pub slip_yaw_rate: Option<f64>,
    /// As [`EventThresholds::slip_residual`], m/s.
    pub slip_residual: Option<f64>,
    /// As [`EventThresholds::collision_decel`], m/s².
    pub collision_decel: Option<f64>,
}

/// Where a threshold came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ThresholdSource {
    /// Given to the pipeline ([`EventOverrides`]; a command-line flag).
    Given,
    /// The robot file's `[events]` table.
    RobotFile,
    /// Neither: the default.
    Default,
}

/// The thresholds a run used, and where each of the three came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResolvedThresholds {
    /// The values.
    pub thresholds: EventThresholds,
    /// Sources of `slip_yaw_rate`, `slip_residual`, `collision_decel`, in that order.
    pub sources: [ThresholdSource; 3],
}

impl ResolvedThresholds {
    /// Override > robot file > default, per threshold.
    pub fn resolve(given: &EventOverrides, file: &omnikin::description::EventSpec) -> Self {
        let pick = |g: Option<f64>, f: Option<f64>, d: f64| match (g, f) {
            (Some(v), _) => (v, ThresholdSource::Given),
            (None, Some(v)) => (v, ThresholdSource::RobotFile),
            (None, None) => (d, ThresholdSource::Default),
        };
        let d = EventThresholds::default();
        let (a, sa) = pick(given.slip_yaw_rate, file.slip_yaw_rate, d.slip_yaw_rate);
        let (b, sb) = pick(given.slip_residual, file.slip_residual, d.slip_residual);
        let (c, sc) = pick(
            given.collision_decel,
            file.collision_decel,
            d.collision_decel,
        );
        Self {
            thresholds: EventThresholds {
                slip_yaw_rate: a,
                slip_residual: b,
                collision_decel: c,
                ..d
            },
            sources: [sa, sb, sc],
        }
    }

    /// `(name, value, unit, source)` of the three, for a summary.
    pub fn rows(&self) -> [(&'static str, f64, &'static str, ThresholdSource); 3] {
        let t = &self.thresholds;
        [
            ("slip_yaw_rate", t.slip_yaw_rate, "rad/s", self.sources[0]),
            ("slip_residual", t.slip_residual, "m/s", self.sources[1]),
            (
                "collision_decel",
                t.collision_decel,
                "m/s²",
                self.sources[2],
            ),
        ]
    }
}

/// What happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventKind {
    /// Wheel slip or spin.
    Slip,
    /// A sudden stop.
    Collision,
}

impl EventKind {
    /// `slip` or `collision`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Slip => "slip",
            Self::Collision => "collision",
        }
    }
}

/// One detected event.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryEvent {
    /// Slip or collision.
    pub kind: EventKind,
    /// First sample over the threshold, s.
    pub start: f64,
    /// Last sample over the threshold, s.
    pub end: f64,
    /// Largest smoothed signal during it: rad/s (yaw-rate slip), m/s (residual slip) or m/s²
    /// (collision).
    pub peak: f64,
}

#[derive(Clone, Copy, Debug, Default)]
struct Episode {
    active: Option<OdometryEvent>,
}

impl Episode {
    /// Feeds one sample; returns a finished event.
    fn feed(
        &mut self,
        kind: EventKind,
        t: f64,
        over: bool,
        value: f64,
        hold: f64,
    ) -> Option<OdometryEvent> {
        match (&mut self.active, over) {
            (None, true) => {
                self.active = Some(OdometryEvent {
                    kind,
                    start: t,
                    end: t,
                    peak: value,
                });
                None
            }
            (Some(e), true) => {
                e.end = t;
                e.peak = e.peak.max(value);
                None
            }
            (Some(e), false) if t - e.end >= hold => self.active.take(),
            _ => None,
        }
    }
}

/// The detector over a stream of odometry steps.
#[derive(Clone, Debug)]
pub(crate) struct Detector {
    th: EventThresholds,
    /// Whether the heading comes from the IMU (the yaw-rate comparison is possible).
    imu: bool,
    redundant: bool,
    yaw_mismatch: f64,
    residual: f64,
    speed: f64,
    /// (t, smoothed speed) over the last window.
    speeds: VecDeque<(f64, f64)>,
    slip: Episode,
    collision: Episode,
    pub(crate) events: Vec<OdometryEvent>,
}

impl Detector {
    pub(crate) fn new(th: EventThresholds, imu: bool, redundant: bool) -> Self {
        Self {
            th,
            imu,
            redundant,
            yaw_mismatch: 0.0,
            residual: 0.0,
            speed: 0.0,
            speeds: VecDeque::new(),
            slip: Episode::default(),
            collision: Episode::default(),
            events: Vec::new(),
        }
    }

    pub(crate) fn step(&mut self, s: &OdometryStep<f64>) {
        if s.dt <= 0.0 {
            return;
        }
        let a = 1.0 - (-s.dt / self.th.smoothing).exp();
        let mismatch = ((s.wheel_heading_change - s.delta.heading) / s.dt).abs();
        self.yaw_mismatch += a * (mismatch - self.yaw_mismatch);
        self.residual += a * (s.slip_residual - self.residual);
        self.speed += a * (s.twist.vx.hypot(s.twist.vy) - self.speed);
        let (slip_over, slip_value) = if self.imu && self.yaw_mismatch > self.th.slip_yaw_rate {
            (true, self.yaw_mismatch)
        } else if self.redundant && self.residual > self.th.slip_residual {
            (true, self.residual)
        } else {
            (false, 0.0)
        };
        if let Some(e) = self
            .slip
            .feed(EventKind::Slip, s.t, slip_over, slip_value, self.th.hold)
        {
            self.events.push(e);
        }
        // Deceleration over the window, from the oldest smoothed speed kept.
        self.speeds.push_back((s.t, self.speed));
        while self
            .speeds
            .front()
            .is_some_and(|&(t0, _)| s.t - t0 > self.th.window)
        {
            self.speeds.pop_front();
        }
        let decel = self.speeds.front().map_or(0.0, |&(t0, v0)| {
            if s.t > t0 {
                (v0 - self.speed) / (s.t - t0)
            } else {
                0.0
            }
        });
        let slipping = self.slip.active.is_some();
        let over = !slipping && decel > self.th.collision_decel;
        if let Some(e) = self
            .collision
            .feed(EventKind::Collision, s.t, over, decel, self.th.hold)
        {
            self.events.push(e);
        }
    }

    /// Ends the open events at the end of the log.
    pub(crate) fn finish(mut self) -> Vec<OdometryEvent> {
        for e in [self.slip.active.take(), self.collision.active.take()]
            .into_iter()
            .flatten()
        {
            self.events.push(e);
        }
        self.events.sort_by(|a, b| a.start.total_cmp(&b.start));
        self.events
    }
}
