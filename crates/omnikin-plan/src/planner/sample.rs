//! Sampling the timed moves at the requested rate (module docs, step 4): pose, world twist
//! and motor rates from the core inverse kinematics at every sample time; steer angles
//! integrated along the move (caster) or the inverse's set-points from the previous sample's
//! (swerve), whose steer rates follow from the robot-frame twist rate.

use omnikin::{Actuators, Twist2};

use crate::PlanningError;
use crate::limits::MAX_PLAN_SAMPLES;
use crate::plan::{Plan, Sample};

use super::cells;
use super::geometry::{AT_REST, Ctx, body_per_speed};
use super::grid::Move;
use super::move_timing::MoveTiming;

/// Fewest sample periods a move lasts. A move shorter than one period can fall between two
/// samples: its motion (a 5.7 µm fillet arc turning the tangent heading by 2.8e-4 rad in
/// 2.4 ms, between two samples at rest 10 ms apart) would be in the poses but in no sample's
/// rates, so commands played back at the plan's rate would never make it. A move of two
/// periods or more has a sample in its middle half, wherever the sample clock falls.
pub(super) const MIN_MOVE_PERIODS: f64 = 2.0;

/// Slows every move shorter than [`MIN_MOVE_PERIODS`] sample periods at `rate` Hz uniformly
/// ([`MoveTiming::dilate`]) to last exactly that long; its rates and accelerations only
/// shrink, so no limit it kept is lost. A move that starts moving is left alone: slowing it
/// would change its start speed, and its first sample, at its start, already shows its motion.
pub(super) fn resolve_short_moves(moves: &mut [Move], rate: f64) {
    let min = MIN_MOVE_PERIODS / rate;
    for mv in moves {
        let d = mv.timing.duration(mv.len);
        if d > 0.0 && d < min && mv.x_start == 0.0 {
            mv.timing.dilate(d / min);
        }
    }
}

/// Samples the timed moves at `rate` Hz (plus the exact end time).
pub(super) fn sample(ctx: &Ctx, moves: &[Move], rate: f64) -> Result<Plan, PlanningError> {
    let last = moves.last().expect("a path has at least one move");
    let total = last.t0 + last.timing.duration(last.len);
    // Samples at k / rate before the end, plus the end: checked before anything is allocated
    // (NaN or infinite durations fail the comparison too).
    let needed = (total * rate).floor() + 2.0;
    if needed.is_nan() || needed > MAX_PLAN_SAMPLES as f64 {
        return Err(PlanningError::TooLarge {
            what: format!("the plan (duration {total:.4e} s × rate {rate} Hz)"),
            items: "samples",
            needed,
            limit: "MAX_PLAN_SAMPLES",
            max: MAX_PLAN_SAMPLES,
            hint: "lower the sampling rate (--rate), or plan a faster or shorter motion \
                   (--speed, --omega, --max-speed, --turns, --side; or higher [limits] in the \
                   robot file)",
        });
    }
    let mut times = Vec::with_capacity(needed as usize);
    let mut j = 0usize;
    loop {
        let t = j as f64 / rate;
        if t >= total - 1e-9 * total.max(1.0) {
            break;
        }
        times.push(t);
        j += 1;
    }
    times.push(total);
    let robot = ctx.robot;
    let (n, steerable) = (robot.wheels(), robot.steerable());
    // A swerve's set-points at each sample follow from the previous sample's angles (a
    // stopped module keeps its angle), starting from the initial steer angles.
    let mut current = Actuators::at_steer(&moves[0].gamma[0]);
    let mut samples = Vec::with_capacity(times.len());
    let mut m = 0;
    // Grid cells of the previous sample (time and parameter), restarted with each move.
    let (mut from_t, mut from_s) = (0, 0);
    for &t in &times {
        while m + 1 < moves.len() && t >= moves[m + 1].t0 {
            m += 1;
            (from_t, from_s) = (0, 0);
        }
        let mv = &moves[m];
        let (sigma, v, acc) = mv.timing.eval(t - mv.t0, mv.len, &mv.sig, &mut from_t);
        if matches!(mv.timing, MoveTiming::Grid { .. }) {
            // A grid timing's time cell is the parameter's cell (up to rounding at its end,
            // where either node serves as the hint): no second search.
            from_s = from_t;
        } else {
            from_s = cells::cell_from(&mv.sig, sigma, from_s);
        }
        let (c, gamma) = ctx.state(mv, sigma, from_s)?;
        let twist = Twist2::new(c.dq[0] * v, c.dq[1] * v, c.dq[2] * v);
        let a = if let Some((angles, per_speed)) = mv.kind.resteer_at(mv.len, sigma) {
            // A re-steer at rest: the modules' angles along the move, turning at `Δ/len · σ̇`.
            let mut a = Actuators::zero();
            a.steer_angles = angles;
            for (r, k) in a.steer_rates.iter_mut().zip(per_speed) {
                *r = k * v;
            }
            current = a;
            a
        } else if ctx.set_point {
            // Robot-frame twist rate b' σ̇² + b σ̈ for the steer rates.
            let b1 = ctx.twist_rate_per_speed(&mv.kind, mv.len, sigma, &c);
            let b = body_per_speed(&c);
            let rate = |d1: f64, d0: f64| d1 * v * v + d0 * acc;
            let twist_rate = Twist2::new(
                rate(b1.vx, b.vx),
                rate(b1.vy, b.vy),
                rate(b1.yaw_rate, b.yaw_rate),
            );
            let a = robot.actuators_cs(c.cs, twist, twist_rate, &current)?;
            current = a;
            a
        } else if let Some(w) = ctx
            .linear
            .as_ref()
            .and_then(|m| m.wheel_rates(c.cs, [twist.vx, twist.vy, twist.yaw_rate]))
        {
            // Without steering: the inverse kinematics as a matrix (`linear_inverse`).
            Actuators {
                wheel_rates: w,
                ..Actuators::zero()
            }
        } else {
            let zero = Twist2::new(0.0, 0.0, 0.0);
            let at_steer;
            let current = if steerable {
                at_steer = Actuators::at_steer(&gamma);
                &at_steer
            } else {
                &AT_REST
            };
            robot.actuators_cs(c.cs, twist, zero, current)?
        };
        let angles = if ctx.set_point { a.steer_angles } else { gamma };
        // The actuators' entries past `n` are zero, as a sample's must be.
        samples.push(Sample {
            t,
            pose: c.pose,
            twist,
            wheel_rates: a.wheel_rates,
            steer: steerable.then_some((angles, a.steer_rates)),
        });
    }
    Ok(Plan { wheels: n, samples })
}
