//! The timing of a move (module docs, step 3): the first timing ([`MoveTiming`]) of each move
//! ([`initial_timing`]) slowed uniformly or rejected at a motor limit by its dense peaks, and
//! the requested limits per kind of move ([`user_limits`]).

use crate::PlanningError;
use crate::error::Violation;
use crate::profile::Profile1D;
use crate::robot::{Quantity, RobotModel};

use super::cells::cell_from;
use super::geometry::Kind;
use super::grid::Move;
use super::limiter::{Limiter, MARGIN, Retiming};
use super::move_timing::MoveTiming;
use super::options::{MotionLimits, OnLimit, PlanOptions, Timing};
use super::time_optimal::time_optimal;

/// Peak ratios of a move under a timing: `(rate ratio, channel, t, value)` and the same for
/// accelerations, from a dense evaluation (≥ 2000 points, ≤ 0.5 ms apart).
struct MovePeaks {
    rate: (f64, usize, f64, f64),
    accel: (f64, usize, f64, f64),
}

fn move_peaks(robot: &RobotModel, mv: &Move, timing: &MoveTiming) -> MovePeaks {
    let dur = timing.duration(mv.len);
    let m = ((dur / 5e-4).ceil() as usize).clamp(2000, 400_000);
    let mut out = MovePeaks {
        rate: (0.0, 0, 0.0, 0.0),
        accel: (0.0, 0, 0.0, 0.0),
    };
    let (mut from_t, mut from_s) = (0, 0);
    for j in 0..=m {
        let t = dur * j as f64 / m as f64;
        let (s, v, acc) = timing.eval(t, mv.len, &mv.sig, &mut from_t);
        let k = cell_from(&mv.sig, s, from_s);
        from_s = k;
        let h = mv.sig[k + 1] - mv.sig[k];
        let f = ((s - mv.sig[k]) / h).clamp(0.0, 1.0);
        // Cubic Hermite for A (values and slopes A' at both ends; O(h⁴), so the peaks between
        // nodes are not underestimated the way linear interpolation would), linear for A'.
        let (f2, f3) = (f * f, f * f * f);
        let (h00, h10, h01, h11) = (
            2.0 * f3 - 3.0 * f2 + 1.0,
            f3 - 2.0 * f2 + f,
            -2.0 * f3 + 3.0 * f2,
            f3 - f2,
        );
        for ch in 0..robot.channels() {
            let (b0, b1) = (mv.b_out[k][ch], mv.b_in[k + 1][ch]);
            let a = mv.a[k][ch] * h00 + h * b0 * h10 + mv.a[k + 1][ch] * h01 + h * b1 * h11;
            let b = b0 * (1.0 - f) + b1 * f;
            let w = (a * v).abs();
            let wd = (a * acc + b * v * v).abs();
            if let Some(lim) = robot.rate_limit(ch)
                && w / lim > out.rate.0 * (1.0 + 1e-9)
            {
                out.rate = (w / lim, ch, t, w);
            }
            if let Some(lim) = robot.accel_limit(ch)
                && wd / lim > out.accel.0 * (1.0 + 1e-9)
            {
                out.accel = (wd / lim, ch, t, wd);
            }
        }
    }
    out
}

/// The requested speed/acceleration for a move's kind, and their limiter labels.
pub(super) fn user_limits(
    robot: &RobotModel,
    opts: &PlanOptions,
    kind: &Kind,
) -> (f64, f64, (Limiter, Limiter)) {
    let limits = match opts.timing {
        Timing::Profile { limits, .. } | Timing::TimeOptimal { limits } => limits,
        Timing::ConstantSpeed { speed } => MotionLimits {
            max_speed: speed,
            ..MotionLimits::default()
        },
    };
    match kind {
        Kind::Travel { .. } => (
            limits.max_speed,
            limits.max_accel,
            (Limiter::MaxSpeed, Limiter::MaxAccel),
        ),
        Kind::Turn { .. } => (
            limits.max_yaw_rate,
            limits.max_yaw_accel,
            (Limiter::MaxYawRate, Limiter::MaxYawAccel),
        ),
        // A re-steer at rest turns only the modules: the fastest one's steer angle within the
        // steer motors' limits of the robot file; a robot file without them gets the request's
        // turn-in-place limits instead.
        Kind::Resteer { .. } => {
            let steer = |q: Quantity| Limiter::Motor {
                quantity: q,
                motor: 1,
            };
            let (v, lv) = robot
                .limits
                .max_steer_rate
                .map_or((limits.max_yaw_rate, Limiter::MaxYawRate), |l| {
                    (l, steer(Quantity::SteerRate))
                });
            let (a, la) = robot
                .limits
                .max_steer_accel
                .map_or((limits.max_yaw_accel, Limiter::MaxYawAccel), |l| {
                    (l, steer(Quantity::SteerAccel))
                });
            (v * MARGIN, a * MARGIN, (lv, la))
        }
    }
}

/// The first timing of a move, before the final check on the samples.
pub(super) fn initial_timing(
    robot: &RobotModel,
    mv: &Move,
    opts: &PlanOptions,
    idx: usize,
    retimed: &mut Vec<Retiming>,
) -> Result<(MoveTiming, Vec<(Limiter, f64)>), PlanningError> {
    let timing = match opts.timing {
        Timing::TimeOptimal { .. } => {
            let (v_user, a_user, user) = user_limits(robot, opts, &mv.kind);
            let (timing, who) = time_optimal(robot, mv, v_user, a_user, user)?;
            let MoveTiming::Grid { t, .. } = &timing else {
                unreachable!("time_optimal returns a grid timing")
            };
            let weights = who
                .iter()
                .enumerate()
                .map(|(k, w)| (*w, t[k + 1] - t[k]))
                .collect();
            return Ok((timing, weights));
        }
        Timing::Profile { kind, limits } => {
            let (v, a, j) = match mv.kind {
                Kind::Travel { .. } => (limits.max_speed, limits.max_accel, limits.max_jerk),
                Kind::Resteer { .. } => {
                    let (v, a, _) = user_limits(robot, opts, &mv.kind);
                    (v, a, a * limits.max_jerk / limits.max_accel)
                }
                Kind::Turn { .. } => (
                    limits.max_yaw_rate,
                    limits.max_yaw_accel,
                    limits.max_yaw_accel * limits.max_jerk / limits.max_accel,
                ),
            };
            MoveTiming::Profile {
                p: Profile1D::new(kind, mv.len, v, a, j)?,
                lambda: 1.0,
            }
        }
        Timing::ConstantSpeed { speed } => MoveTiming::Constant { v: speed },
    };
    let peaks = move_peaks(robot, mv, &timing);
    let (rr, ra) = (peaks.rate.0, peaks.accel.0);
    let dur = timing.duration(mv.len);
    let user_label = match (&opts.timing, &mv.kind) {
        (Timing::ConstantSpeed { .. }, _) => Limiter::RequestedSpeed,
        (_, Kind::Travel { .. }) => Limiter::MaxSpeed,
        (_, Kind::Turn { .. }) => Limiter::MaxYawRate,
        (_, Kind::Resteer { .. }) => user_limits(robot, opts, &mv.kind).2.0,
    };
    if rr <= 1.0 && ra <= 1.0 {
        return Ok((timing, vec![(user_label, dur)]));
    }
    let (ratio, (_, ch, _, _), accel) = if rr >= ra.sqrt() {
        (rr, peaks.rate, false)
    } else {
        (ra.sqrt(), peaks.accel, true)
    };
    let (quantity, motor) = robot.channel(ch, accel);
    if opts.on_limit == OnLimit::Reject {
        let worst = if rr >= ra {
            (peaks.rate, false)
        } else {
            (peaks.accel, true)
        };
        let ((_, ch, t, value), accel) = worst;
        let (quantity, motor) = robot.channel(ch, accel);
        let limit = if accel {
            robot.accel_limit(ch)
        } else {
            robot.rate_limit(ch)
        }
        .unwrap_or(f64::NAN);
        return Err(PlanningError::LimitExceeded(Violation {
            quantity,
            motor,
            needed: value,
            t: t + mv.t0,
            limit,
        }));
    }
    let lambda = MARGIN / ratio;
    let limiter = Limiter::Motor { quantity, motor };
    note_retime(retimed, idx, lambda, limiter);
    let timing = match timing {
        MoveTiming::Profile { p, .. } => MoveTiming::Profile { p, lambda },
        MoveTiming::Constant { v } => MoveTiming::Constant { v: v * lambda },
        g => g,
    };
    let dur = timing.duration(mv.len);
    Ok((timing, vec![(limiter, dur)]))
}

pub(super) fn note_retime(retimed: &mut Vec<Retiming>, idx: usize, factor: f64, limiter: Limiter) {
    if let Some(r) = retimed.iter_mut().find(|r| r.move_index == idx) {
        r.factor = r.factor.min(factor);
    } else {
        retimed.push(Retiming {
            move_index: idx,
            factor,
            limiter,
        });
    }
}
