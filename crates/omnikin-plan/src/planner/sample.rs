//! Sampling the timed moves at the requested rate (module docs, step 4): pose, world twist
//! and motor rates from the core inverse kinematics at every sample time.

use omnikin::Twist2;

use crate::PlanningError;
use crate::limits::MAX_PLAN_SAMPLES;
use crate::plan::{Plan, Sample};

use super::geometry::Ctx;
use super::grid::Move;

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
    let caster = ctx.robot.is_caster();
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
        let (sigma, v, _) = mv.timing.eval(t - mv.t0, mv.len, &mv.sig, &mut from_t);
        let (c, gamma) = ctx.state(mv, sigma, &mut from_s)?;
        let twist = Twist2::new(c.dq[0] * v, c.dq[1] * v, c.dq[2] * v);
        let r = ctx.robot.rates_cs(c.pose.heading, c.cs, twist, gamma)?;
        let steer_rates = r.steer.unwrap_or([0.0; 3]);
        samples.push(Sample::new(
            t,
            c.pose,
            twist,
            &r.wheel,
            caster.then_some((&gamma[..], &steer_rates[..])),
        ));
    }
    Ok(Plan {
        wheels: ctx.robot.model.wheels().min(3),
        samples,
    })
}
