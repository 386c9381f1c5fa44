//! The cell lookup on a sorted grid of nodes (a move's `σ` nodes, or its node times): which
//! cell `[sig[k], sig[k + 1]]` holds a value. A leaf of the planner: it uses no other module.

/// Index `k` of the grid cell `[sig[k], sig[k + 1]]` containing `sigma` (clamped).
pub(super) fn cell(sig: &[f64], sigma: f64) -> usize {
    let n = sig.len() - 1;
    sig.partition_point(|&x| x <= sigma)
        .saturating_sub(1)
        .min(n.saturating_sub(1))
}

/// [`cell`], for queries that mostly move forward a little: a few steps on from the previous
/// answer `from`, bisection otherwise. Same result as [`cell`] for every input.
pub(super) fn cell_from(sig: &[f64], sigma: f64, from: usize) -> usize {
    let last = sig.len().saturating_sub(2);
    let mut k = from.min(last);
    if sig.len() < 2 || sigma.is_nan() || sig[k] > sigma {
        return cell(sig, sigma);
    }
    for _ in 0..8 {
        if k >= last || sig[k + 1] > sigma {
            return k;
        }
        k += 1;
    }
    k + cell(&sig[k..], sigma)
}
