//! What the planner hands back besides the samples: the [`PlanReport`] (moves, peaks against
//! the motor limits, re-timed moves, what limited the timing) inside [`Planned`], with
//! [`plan_peaks`], the peaks of a sampled plan, and the assembly of the report.

use crate::path::Path;
use crate::plan::{Plan, Sample};
use crate::robot::{Quantity, RobotModel};

use super::geometry::Kind;
use super::grid::Move;
use super::limiter::{Limiter, Retiming};
use super::move_timing::MoveTiming;

/// The peak of one motor quantity over a plan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Peak {
    /// Which quantity.
    pub quantity: Quantity,
    /// Motor number (1-based) where the peak is.
    pub motor: usize,
    /// Peak magnitude (rad/s or rad/s²; accelerations are differences between consecutive
    /// samples divided by their time step).
    pub value: f64,
    /// Time of the peak, s.
    pub t: f64,
    /// The robot file's limit, if any.
    pub limit: Option<f64>,
}

/// What a move does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MoveKind {
    /// Travel along the path from arc length `s0` to `s1`, m.
    Travel {
        /// Start arc length, m.
        s0: f64,
        /// End arc length, m.
        s1: f64,
    },
    /// Turn in place by `angle` rad (tangent heading law at a stop).
    Turn {
        /// Signed angle, rad.
        angle: f64,
    },
    /// Re-steer at rest (set-point steering, swerve): the modules turn to the next motion's
    /// directions, the largest by `angle` rad.
    Resteer {
        /// The largest module's turn, rad (≥ 0).
        angle: f64,
    },
}

/// One move of a plan: what it does, when, and how fast.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoveSummary {
    /// What it does.
    pub kind: MoveKind,
    /// Start time, s.
    pub t0: f64,
    /// Duration, s.
    pub duration: f64,
    /// Peak speed along the path (m/s), yaw rate of a turn (rad/s) or steer rate of the
    /// fastest module in a re-steer (rad/s).
    pub peak_speed: f64,
}

/// How a plan came out: duration, length, peaks against limits, what limited the timing.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanReport {
    /// Duration, s.
    pub duration: f64,
    /// Path length, m.
    pub path_length: f64,
    /// The moves, in order.
    pub moves: Vec<MoveSummary>,
    /// Peak of every limited-or-not motor quantity (wheel rate and acceleration; steerable
    /// kinds add steer rate and acceleration).
    pub peaks: Vec<Peak>,
    /// Moves slowed down because of a motor limit ([`Timing::Profile`](super::Timing::Profile) /
    /// [`Timing::ConstantSpeed`](super::Timing::ConstantSpeed) with
    /// [`OnLimit::Retime`](super::OnLimit::Retime)).
    pub retimed: Vec<Retiming>,
    /// What limited the speed, with the share of the plan's time (0–1) it was active
    /// (sorted, largest first).
    pub active: Vec<(Limiter, f64)>,
    /// `true` when the plan starts at non-zero speed (paper 000's circle law): the robot must
    /// already move as the first sample says.
    pub starts_moving: bool,
}

/// A plan and its report.
#[derive(Clone, Debug, PartialEq)]
pub struct Planned {
    /// The sampled plan (conventions' columns).
    pub plan: Plan,
    /// Summary for people.
    pub report: PlanReport,
}

/// Peaks of every motor quantity over a sampled plan, against the robot's limits: rates at the
/// samples, accelerations as differences of consecutive samples over their time step.
pub fn plan_peaks(plan: &Plan, robot: &RobotModel) -> Vec<Peak> {
    let n = robot.wheels();
    let chans = robot.channels();
    let value = |s: &Sample, ch: usize| channel_value(s, n, ch);
    let mut out = Vec::new();
    for accel in [false, true] {
        for group in [0..n, n..2 * n] {
            if group.start >= chans {
                continue;
            }
            let (quantity, _) = robot.channel(group.start, accel);
            let mut best = Peak {
                quantity,
                motor: 1,
                value: 0.0,
                t: 0.0,
                limit: if accel {
                    robot.accel_limit(group.start)
                } else {
                    robot.rate_limit(group.start)
                },
            };
            for ch in group {
                if accel {
                    for w in plan.samples.windows(2) {
                        let d = ((value(&w[1], ch) - value(&w[0], ch)) / (w[1].t - w[0].t)).abs();
                        if d > best.value * (1.0 + 1e-9) {
                            best.value = d;
                            best.motor = robot.channel(ch, accel).1;
                            best.t = w[1].t;
                        }
                    }
                } else {
                    for s in &plan.samples {
                        let r = value(s, ch).abs();
                        if r > best.value * (1.0 + 1e-9) {
                            best.value = r;
                            best.motor = robot.channel(ch, accel).1;
                            best.t = s.t;
                        }
                    }
                }
            }
            out.push(best);
        }
    }
    out
}

/// A sample's value of motor channel `ch` of a robot with `n` wheels ([`RobotModel::channel`]):
/// wheel rate `ch` for `ch < n`, else steer rate `ch − n` (0 without steering).
pub(super) fn channel_value(s: &Sample, n: usize, ch: usize) -> f64 {
    if ch < n {
        s.wheel_rates[ch]
    } else {
        s.steer.map_or(0.0, |(_, r)| r[ch - n])
    }
}

pub(super) fn report(
    path: &Path,
    moves: &[Move],
    duration: f64,
    peaks: Vec<Peak>,
    retimed: Vec<Retiming>,
    active_w: Vec<(Limiter, f64)>,
    plan: &Plan,
) -> PlanReport {
    let mut active: Vec<(Limiter, f64)> = Vec::new();
    let total: f64 = active_w.iter().map(|a| a.1).sum();
    for (l, w) in active_w {
        match active.iter_mut().find(|a| a.0 == l) {
            Some(a) => a.1 += w,
            None => active.push((l, w)),
        }
    }
    if total > 0.0 {
        for a in &mut active {
            a.1 /= total;
        }
    }
    active.sort_by(|a, b| b.1.total_cmp(&a.1));
    let moves = moves
        .iter()
        .map(|m| {
            let dur = m.timing.duration(m.len);
            let peak = match &m.timing {
                MoveTiming::Profile { p, lambda } => p.peak_speed() * lambda,
                MoveTiming::Constant { v } => *v,
                MoveTiming::Grid { x, .. } => x.iter().fold(0.0_f64, |a, &b| a.max(b)).sqrt(),
            };
            MoveSummary {
                kind: match m.kind {
                    Kind::Travel { s0, s1 } => MoveKind::Travel { s0, s1 },
                    Kind::Turn { dir, .. } => MoveKind::Turn { angle: dir * m.len },
                    Kind::Resteer { .. } => MoveKind::Resteer { angle: m.len },
                },
                t0: m.t0,
                duration: dur,
                peak_speed: peak,
            }
        })
        .collect();
    let first = plan.samples.first();
    PlanReport {
        duration,
        path_length: path.length(),
        moves,
        peaks,
        retimed,
        active,
        starts_moving: first.is_some_and(|s| {
            s.twist.vx.hypot(s.twist.vy) > 1e-12 || s.twist.yaw_rate.abs() > 1e-12
        }),
    }
}
