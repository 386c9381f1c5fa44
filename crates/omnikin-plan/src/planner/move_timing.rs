//! How a move's parameter `σ` advances in time (module docs, step 3): [`MoveTiming`], a profile
//! with its time dilation, a constant speed, or the time-optimal grid, evaluated at a time.
//! It depends only on the cell lookup ([`super::cells`]); the grid, the timings and the report
//! build on it.

use crate::profile::Profile1D;

use super::cells::cell_from;

#[derive(Clone, Debug)]
pub(super) enum MoveTiming {
    Profile {
        p: Profile1D,
        lambda: f64,
    },
    Constant {
        v: f64,
    },
    /// `x = σ̇²` and times at the move's grid nodes (`Move::sig`).
    Grid {
        x: Vec<f64>,
        t: Vec<f64>,
    },
}

impl MoveTiming {
    pub(super) fn duration(&self, len: f64) -> f64 {
        match self {
            MoveTiming::Profile { p, lambda } => p.duration() / lambda,
            MoveTiming::Constant { v } => len / v,
            MoveTiming::Grid { t, .. } => *t.last().unwrap_or(&0.0),
        }
    }

    /// Slows the timing uniformly by `lambda` (in (0, 1]): the same path at `λ` times the
    /// speed, so every motor rate scales with `λ` and every acceleration with `λ²` (both stay
    /// within any limit they kept) and the duration with `1/λ`.
    pub(super) fn dilate(&mut self, lambda: f64) {
        match self {
            MoveTiming::Profile { lambda: l, .. } => *l *= lambda,
            MoveTiming::Constant { v } => *v *= lambda,
            MoveTiming::Grid { x, t } => {
                x.iter_mut().for_each(|x| *x *= lambda * lambda);
                t.iter_mut().for_each(|t| *t /= lambda);
            }
        }
    }

    /// `(σ, σ̇, σ̈)` at time `t` into the move whose grid nodes are `sig`; `from` is the grid
    /// cell of the previous call (for times that mostly increase) and is updated.
    pub(super) fn eval(&self, t: f64, len: f64, sig: &[f64], from: &mut usize) -> (f64, f64, f64) {
        match self {
            MoveTiming::Profile { p, lambda } => {
                let (s, v, a) = p.eval(lambda * t);
                (s, lambda * v, lambda * lambda * a)
            }
            MoveTiming::Constant { v } => ((v * t).clamp(0.0, len), *v, 0.0),
            MoveTiming::Grid { x, t: times } => {
                let n = x.len() - 1;
                let k = if t.is_nan() {
                    n.saturating_sub(1)
                } else {
                    cell_from(times, t, *from)
                };
                *from = k;
                let u = (x[k + 1] - x[k]) / (2.0 * (sig[k + 1] - sig[k]));
                let v0 = x[k].max(0.0).sqrt();
                let tau = (t - times[k]).clamp(0.0, times[k + 1] - times[k]);
                let s = (sig[k] + v0 * tau + 0.5 * u * tau * tau).clamp(0.0, len);
                ((s).min(len), (v0 + u * tau).max(0.0), u)
            }
        }
    }
}
