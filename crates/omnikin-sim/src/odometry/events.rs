//! Slip and collision events of `omnikin odometry`: the core's detector
//! ([`omnikin::estimate::events`], the same one the runtime runs) over a log, and the thresholds
//! a run resolves from its flags, the robot file's `[events]` and the defaults.

use omnikin::estimate::events::EventDetector;
use omnikin::estimate::odometry::OdometryStep;

pub use omnikin::estimate::events::EventKind;

/// Detection thresholds (f64). [`Default`]: 0.3 rad/s, 0.05 m/s, 3 m/s² (the robot file's
/// defaults, [`omnikin::description::events`]), 50 ms window, 10 ms smoothing, 0.2 s hold.
pub type EventThresholds = omnikin::estimate::events::EventThresholds<f64>;

/// One detected event (times in the log's clock, s).
pub type OdometryEvent = omnikin::estimate::events::Event<f64>;

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

/// The detector over a log's odometry steps, collecting the finished events.
#[derive(Clone, Debug)]
pub(crate) struct Detector {
    inner: EventDetector<f64>,
    /// Whether the heading comes from the IMU (the yaw-rate comparison is possible).
    imu: bool,
    pub(crate) events: Vec<OdometryEvent>,
}

impl Detector {
    pub(crate) fn new(th: EventThresholds, imu: bool, redundant: bool) -> Self {
        Self {
            inner: EventDetector::new(th, redundant),
            imu,
            events: Vec::new(),
        }
    }

    pub(crate) fn step(&mut self, s: &OdometryStep<f64>) {
        // With the heading from the IMU the step's heading change is the IMU's.
        let imu_rate = (self.imu && s.dt > 0.0).then(|| s.delta.heading / s.dt);
        let out = self.inner.step(s, imu_rate);
        self.events.extend(out.finished.into_iter().flatten());
    }

    /// Ends the open events at the end of the log; all events by start time.
    pub(crate) fn finish(mut self) -> Vec<OdometryEvent> {
        let open = self.inner.finish();
        self.events.extend(open.into_iter().flatten());
        self.events.sort_by(|a, b| a.start.total_cmp(&b.start));
        self.events
    }
}
