//! The limits between the samples (module docs, step 4): a time-optimal move's continuous
//! timing checked against every motor's rate and acceleration limit with the exact
//! kinematics inside each grid cell, not only at the nodes the pass constrains and the
//! samples the final check sees.
//!
//! On a cell `[σ_k, σ_{k+1}]` of length `h` the timing has the constant path acceleration
//! `u = (x_{k+1} − x_k)/(2h)`, so `x(σ) = σ̇² = x_k + 2u(σ − σ_k)` is linear, and each motor's
//! rate is `A(σ) √x(σ)` and its acceleration `A(σ) u + A'(σ) x(σ)` (module docs, step 2).
//! Here `A` and `A'` come from the kinematics at the point itself: for a robot without
//! steering from the configuration's first and second derivatives along the move (one
//! evaluation; [`Ctx::config_with_rate`]), for the steerable kinds `A` from
//! [`Ctx::state`] and [`Ctx::rates_per_speed`] and `A'` from a central difference of it over
//! ±[`DIFF`] inside the cell; at [`POINTS`] points per cell from just inside one end to just
//! inside the other (one-sided at a kink, where `A'` jumps); a cell whose table values stay
//! clear of every limit ([`SCREEN`]) is evaluated only at an end that is a kink, or not at
//! all; the planner checks a move again only after its timing changed.

use crate::PlanningError;
use crate::robot::MAX_CHANNELS;

use super::geometry::Ctx;
use super::grid::Move;
use super::move_timing::MoveTiming;

/// Points per cell at which the continuous timing is evaluated (both ends included, from
/// inside the cell).
const POINTS: usize = 3;

/// Half-width of the central difference for `A'` (m or rad); the end points lie
/// [`INSET`] of it inside the cell. A set-point steering's `A` is itself a central difference
/// over ±[`super::geometry::DIFF_STEP`] (the twist's rate), so no point of either difference
/// may lie within that of a node, where `A'` may jump (on a small cell both shrink with it).
const DIFF: f64 = 1e-5;

/// How far inside the cell the end points lie, in [`DIFF`]s: the central difference around
/// them, and the twist-rate difference of a set-point steering around each of its ends, stay
/// inside the cell.
const INSET: f64 = 2.5;

/// A cell is evaluated when the tabulated rate or acceleration of some motor on it (see
/// [`near_limit`]) reaches this fraction of its limit, or when it touches a kink, where the
/// tabulated `A'` is one-sided and can be off by tens of percent. (Inside a stretch it is a
/// central difference on a grid refined to the interpolation tolerance.)
const SCREEN: f64 = 0.97;

/// The worst excess found inside a cell: the time into the move, the ratio of the value to
/// its limit (> 1), and the motor channel and quantity.
#[derive(Clone, Copy, Debug)]
pub(super) struct Excess {
    pub(super) t: f64,
    pub(super) ratio: f64,
    pub(super) channel: usize,
    pub(super) accel: bool,
}

impl Ctx<'_> {
    /// Every cell of a time-optimal move `mv` where some motor's rate or acceleration exceeds
    /// its limit (by more than a relative 1e-9) between or at the nodes, with the worst ratio
    /// in the cell (see the module docs). Moves with another timing give none.
    pub(super) fn continuous_excesses(&self, mv: &Move) -> Result<Vec<Excess>, PlanningError> {
        let MoveTiming::Grid { x, t } = &mv.timing else {
            return Ok(Vec::new());
        };
        let robot = self.robot;
        let chans = robot.channels();
        let rate: [Option<f64>; MAX_CHANNELS] = core::array::from_fn(|ch| robot.rate_limit(ch));
        let accel: [Option<f64>; MAX_CHANNELS] = core::array::from_fn(|ch| robot.accel_limit(ch));
        // The screen's thresholds once per move (a missing limit never binds).
        let screen = |l: Option<f64>| l.map_or(f64::INFINITY, |l| SCREEN * l);
        let screen_rate: [f64; MAX_CHANNELS] = core::array::from_fn(|ch| screen(rate[ch]));
        let screen_accel: [f64; MAX_CHANNELS] = core::array::from_fn(|ch| screen(accel[ch]));
        let sig = &mv.sig;
        let mut out = Vec::new();
        // Node indices that are kinks (stretch ends).
        let mut kink = vec![false; sig.len()];
        let mut at = 0;
        kink[0] = true;
        for &c in &mv.cells {
            at += c;
            kink[at.min(sig.len() - 1)] = true;
        }
        for k in 0..sig.len() - 1 {
            let h = sig[k + 1] - sig[k];
            if h.is_nan() || h <= 0.0 {
                continue;
            }
            let u = (x[k + 1] - x[k]) / (2.0 * h);
            // Every point when the table comes near a limit on the cell; else only an end at
            // a kink, where the table's one-sided `A'` may be off.
            let all = near_limit(mv, k, x, u, &screen_rate, &screen_accel, chans);
            if !all && !kink[k] && !kink[k + 1] {
                continue;
            }
            let mut worst: Option<Excess> = None;
            let d = DIFF.min(0.02 * h);
            let inset = INSET * d;
            for j in 0..POINTS {
                let at_kink = (j == 0 && kink[k]) || (j == POINTS - 1 && kink[k + 1]);
                if !(all || at_kink) {
                    continue;
                }
                // From `inset` inside the start to `inset` inside the end.
                let f = j as f64 / (POINTS - 1) as f64;
                let sigma = sig[k] + inset + (h - 2.0 * inset) * f;
                let (av, bv) = self.a_and_rate_at(mv, k, sigma, d)?;
                let xs = (x[k] + 2.0 * u * (sigma - sig[k])).max(0.0);
                for ch in 0..chans {
                    let (a, b) = (av[ch], bv[ch]);
                    let checks = [
                        (rate[ch], (a * xs.sqrt()).abs(), false),
                        (accel[ch], (a * u + b * xs).abs(), true),
                    ];
                    for (limit, value, is_accel) in checks {
                        let Some(l) = limit else { continue };
                        let r = value / l;
                        if r > 1.0 + 1e-9 && worst.is_none_or(|w| r > w.ratio) {
                            // The time at σ within the cell: x is linear in σ, so the time
                            // is that of the mean speed over [σ_k, σ].
                            let ds = sigma - sig[k];
                            let den = x[k].max(0.0).sqrt() + xs.sqrt();
                            let dt = if den > 0.0 { 2.0 * ds / den } else { 0.0 };
                            worst = Some(Excess {
                                t: (t[k] + dt).min(t[k + 1]),
                                ratio: r,
                                channel: ch,
                                accel: is_accel,
                            });
                        }
                    }
                }
            }
            out.extend(worst);
        }
        Ok(out)
    }

    /// `A(σ)` and `A'(σ)` at `sigma` inside cell `k` of `mv`, from the exact kinematics: for a
    /// robot without steering both at once from the configuration's derivatives
    /// ([`Ctx::config_with_rate`], [`super::geometry::Linear::wheel_rates_with_rate`]), else
    /// `A` as the mean and `A'` as the central difference of `A` at `sigma ± d`.
    pub(super) fn a_and_rate_at(
        &self,
        mv: &Move,
        k: usize,
        sigma: f64,
        d: f64,
    ) -> Result<([f64; MAX_CHANNELS], [f64; MAX_CHANNELS]), PlanningError> {
        if let Some(lin) = &self.linear {
            let hint = self.hint_at(mv, k);
            let (c, ddq) = self.config_with_rate(&mv.kind, mv.len, sigma, hint);
            if let Some((a, b)) = lin.wheel_rates_with_rate(c.cs, c.dq, ddq) {
                let (mut av, mut bv) = ([0.0; MAX_CHANNELS], [0.0; MAX_CHANNELS]);
                av[..a.len()].copy_from_slice(&a);
                bv[..b.len()].copy_from_slice(&b);
                return Ok((av, bv));
            }
            // A value that is not finite: the core call below names it.
        }
        let lo = self.a_at(mv, k, sigma - d)?;
        let hi = self.a_at(mv, k, sigma + d)?;
        Ok((
            core::array::from_fn(|ch| 0.5 * (lo[ch] + hi[ch])),
            core::array::from_fn(|ch| (hi[ch] - lo[ch]) / (2.0 * d)),
        ))
    }

    /// `A(σ)` at `sigma` inside cell `k` of `mv`, from the exact kinematics.
    pub(super) fn a_at(
        &self,
        mv: &Move,
        k: usize,
        sigma: f64,
    ) -> Result<[f64; MAX_CHANNELS], PlanningError> {
        let (c, gamma) = self.state(mv, sigma, k)?;
        self.rates_per_speed(&mv.kind, mv.len, sigma, &c, &gamma)
    }
}

/// `true` when the tabulated values bring some motor's rate or acceleration to [`SCREEN`] of
/// its limit anywhere on cell `k`: at its ends and at three points between, with `A` by cubic
/// Hermite interpolation of the nodes' `A` and `A'`, and `A'` linear (no kinematics); `rl`,
/// `al` are [`SCREEN`] times each channel's rate and acceleration limit (infinite without one).
fn near_limit(
    mv: &Move,
    k: usize,
    x: &[f64],
    u: f64,
    rl: &[f64; MAX_CHANNELS],
    al: &[f64; MAX_CHANNELS],
    chans: usize,
) -> bool {
    let h = mv.sig[k + 1] - mv.sig[k];
    let (a0, a1, b0, b1) = (&mv.a[k], &mv.a[k + 1], &mv.b_out[k], &mv.b_in[k + 1]);
    // Each point: its speed squared and root once, every channel against the thresholds.
    let chans = chans.min(MAX_CHANNELS);
    // A bound over the whole cell first (on [0, 1] the Hermite weights h00, h01 are
    // non-negative with sum 1 and |h10|, |h11| ≤ 4/27; x is linear): when it stays clear,
    // so do the points below, and the cell is clear at a single pass over the channels.
    let x_max = x[k].max(x[k + 1]).max(0.0);
    let root_max = x_max.sqrt();
    let clear = (0..chans).all(|ch| {
        let a_max =
            a0[ch].abs().max(a1[ch].abs()) + h * (b0[ch].abs() + b1[ch].abs()) * (4.0 / 27.0);
        let b_max = b0[ch].abs().max(b1[ch].abs());
        a_max * root_max < rl[ch] && a_max * u.abs() + b_max * x_max < al[ch]
    });
    if clear {
        return false;
    }
    [0.0, 0.25, 0.5, 0.75, 1.0].iter().any(|&f| {
        let (f2, f3) = (f * f, f * f * f);
        let (h00, h10, h01, h11) = (
            2.0 * f3 - 3.0 * f2 + 1.0,
            f3 - 2.0 * f2 + f,
            -2.0 * f3 + 3.0 * f2,
            f3 - f2,
        );
        let xs = (x[k] + 2.0 * u * h * f).max(0.0);
        let root = xs.sqrt();
        (0..chans).any(|ch| {
            let a = a0[ch] * h00 + h * b0[ch] * h10 + a1[ch] * h01 + h * b1[ch] * h11;
            let b = b0[ch] * (1.0 - f) + b1[ch] * f;
            (a * root).abs() >= rl[ch] || (a * u + b * xs).abs() >= al[ch]
        })
    })
}
