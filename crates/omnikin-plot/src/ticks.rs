//! Tick labels: every label of an axis with the same number of decimals, as many as the tick
//! step needs, and never `-0.0`.
//!
//! plotters puts the ticks of an `f64` axis at multiples of a step of 1, 2 or 5 × 10ᵏ, the
//! smallest such step that gives at most the requested number of ticks (its
//! `compute_f64_key_points`); its default labels print each value on its own, so one axis
//! shows `0.1`, `0.15000000000000002` or `-0.0` (a tick computed as −1e-17). Here the step is
//! worked out the same way from the axis range, and each label is the value rounded to the
//! step's decimals.

/// The tick step plotters uses for an axis from `lo` to `hi` with at most `max_ticks` ticks:
/// the smallest 1, 2 or 5 × 10ᵏ whose multiples inside the range are at most `max_ticks`.
/// A range without width (or not finite) gives 0.
pub fn step(lo: f64, hi: f64, max_ticks: usize) -> f64 {
    let span = (hi - lo).abs();
    if !span.is_finite() || span <= 0.0 || max_ticks == 0 {
        return 0.0;
    }
    let (lo, hi) = (lo.min(hi), lo.max(hi));
    let count = |s: f64| ((hi / s).floor() - (lo / s).ceil() + 1.0).max(0.0) as usize;
    // Start one decade above the span and refine while the ticks still fit.
    let mut best = 10f64.powf(span.log10().ceil() + 1.0);
    let mut decade = best;
    for _ in 0..40 {
        let mut finer = false;
        for f in [0.5, 0.2, 0.1] {
            let s = decade * f;
            if count(s) > max_ticks {
                return best;
            }
            best = s;
            finer = true;
        }
        if !finer {
            break;
        }
        decade *= 0.1;
    }
    best
}

/// Decimals that show every multiple of `step` exactly (0 for steps of 1 and more).
pub fn decimals(step: f64) -> usize {
    if !(step.is_finite() && step > 0.0) {
        return 3;
    }
    // 1, 2 and 5 × 10ᵏ: -k decimals; a hair of tolerance for 0.1 = 1.0000000000000001e-1.
    (-(step.log10() + 1e-9).floor()).clamp(0.0, 12.0) as usize
}

/// The label of tick `value` on an axis whose labels have `decimals` decimals: the value
/// rounded to them, and `0` rather than `-0` when it rounds to zero.
pub fn label(value: f64, decimals: usize) -> String {
    let s = format!("{value:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_string(),
        _ => s,
    }
}

/// The number of ticks the panels ask plotters for on each axis (its default).
pub const MAX_TICKS: usize = 10;

/// The label formatter of an axis from `lo` to `hi` (see the module doc).
pub fn formatter(lo: f64, hi: f64) -> impl Fn(&f64) -> String {
    let d = decimals(step(lo, hi, MAX_TICKS));
    move |v: &f64| label(*v, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negative_zero_is_labelled_zero() {
        assert_eq!(label(-0.0, 1), "0.0");
        assert_eq!(label(-1e-17, 2), "0.00");
        assert_eq!(label(-0.004, 2), "0.00");
        assert_eq!(label(-0.006, 2), "-0.01");
        assert_eq!(label(-2.0, 0), "-2");
        assert_eq!(label(0.15000000000000002, 2), "0.15");
    }

    #[test]
    fn the_step_is_the_one_plotters_draws() {
        // The step must match the ticks plotters places, or labels are rounded wrongly: compare
        // with the key points plotters computes for the same ranges.
        use plotters::coord::ranged1d::{KeyPointHint, Ranged};
        use plotters::coord::types::RangedCoordf64;
        for (lo, hi) in [
            (-0.2, 0.2),
            (-0.013, 0.011),
            (0.0, 1.0),
            (-1.05, 25.3),
            (0.1, 0.1004),
            (-3.7e3, 9.9e4),
            (12.0, 12.5),
        ] {
            let r: RangedCoordf64 = (lo..hi).into();
            let keys = r.key_points(MAX_TICKS.max_num_points());
            assert!(keys.len() >= 2, "{lo}..{hi}: {keys:?}");
            let plotters_step = keys[1] - keys[0];
            let ours = step(lo, hi, MAX_TICKS);
            assert!(
                (plotters_step / ours - 1.0).abs() < 1e-6,
                "{lo}..{hi}: plotters steps {plotters_step}, ours {ours} ({keys:?})"
            );
            // Every tick's label reads back as the tick.
            let f = formatter(lo, hi);
            for k in keys {
                let l = f(&k);
                let back: f64 = l.parse().unwrap();
                assert!((back - k).abs() <= 1e-9 * k.abs().max(ours), "{k} -> {l}");
                assert!(!l.starts_with("-0") || back != 0.0, "{l}");
            }
        }
    }

    #[test]
    fn decimals_follow_the_step() {
        assert_eq!(decimals(0.5), 1);
        assert_eq!(decimals(0.2), 1);
        assert_eq!(decimals(0.1), 1);
        assert_eq!(decimals(0.05), 2);
        assert_eq!(decimals(0.001), 3);
        assert_eq!(decimals(1.0), 0);
        assert_eq!(decimals(20.0), 0);
        assert_eq!(decimals(0.0), 3);
    }
}
