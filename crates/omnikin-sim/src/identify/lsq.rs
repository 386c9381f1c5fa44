//! Non-linear least squares: Levenberg–Marquardt with a central-difference Jacobian, the
//! covariance `σ² (JᵀJ)⁻¹` of the estimate, and the observability test that decides which
//! parameters the data cannot determine.
//!
//! The problem is `min_x Σ r_i(x)²` for a residual function `r: ℝⁿ → ℝᵐ` that may fail (a
//! trial point whose geometry is singular returns `None` and counts as an infinite cost).
//! Each step solves `(JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr` (Marquardt's scaling, so the damping is
//! unit-free) and adapts `λ` by ×10 / ÷10 on rejection / acceptance (Nocedal & Wright §10.3).
//!
//! **Observability.** The columns of `J` are scaled to unit norm (so metres, radians and
//! scale factors compare) and its singular values computed; a singular value below
//! [`RANK_TOLERANCE`] × the largest marks a direction of parameter space the residuals do not
//! see. [`unobservable`] names, for each such direction, the free parameter with the largest
//! component in it: fixing that parameter at its prior removes the direction.
//!
//! What this does **not** do: bounds, robust losses, or analytic Jacobians.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// A singular value of the column-scaled Jacobian below this fraction of the largest marks a
/// direction the data do not determine. Central differences carry relative errors near 1e-8,
/// so exact null directions come out around that level; real excitation is far above 1e-5.
pub const RANK_TOLERANCE: f64 = 1e-5;

/// Most Levenberg–Marquardt iterations.
pub const MAX_ITERATIONS: usize = 60;

/// Why a fit could not be done.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LsqError {
    /// The residuals could not be evaluated at the starting point.
    #[error("the model cannot be evaluated at the prior values")]
    BadStart,
    /// Fewer residuals than free parameters.
    #[error("{residuals} residuals cannot determine {parameters} parameters")]
    TooFewResiduals {
        /// Number of residuals.
        residuals: usize,
        /// Number of free parameters.
        parameters: usize,
    },
}

/// The result of [`solve`].
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    /// The estimate (all parameters; fixed ones at their given values).
    pub x: Vec<f64>,
    /// 1σ of each parameter, `sqrt(diag(σ² (JᵀJ)⁻¹))` over the free ones; 0 for fixed ones.
    pub sigma: Vec<f64>,
    /// `σ² = Σr² / (m − n)`, the residual variance (in the residuals' units²).
    pub residual_variance: f64,
    /// RMS of the residuals at the estimate.
    pub residual_rms: f64,
    /// Number of residuals.
    pub residuals: usize,
    /// Iterations taken.
    pub iterations: usize,
    /// Condition number of the column-scaled Jacobian of the free parameters at the estimate.
    pub condition: f64,
}

/// Central-difference Jacobian of `f` at `x` over the parameters with `free[j]`, step `h[j]`
/// (columns of fixed parameters are zero). `None` if `f` fails at a probe or the probes
/// disagree in length.
///
/// The columns are independent (each re-evaluates `f`, which for identification re-dead-reckons
/// every log), so they are computed in parallel on rayon's pool; each column is the same
/// arithmetic as serially, so the result does not depend on the number of threads. `f(x)`
/// itself is evaluated only when no parameter is free (for the number of rows).
pub fn jacobian<F>(f: &F, x: &[f64], h: &[f64], free: &[bool]) -> Option<DMatrix<f64>>
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
    let cols: Vec<usize> = (0..x.len()).filter(|&c| free[c]).collect();
    let columns: Vec<Vec<f64>> = cols
        .par_iter()
        .map(|&c| {
            let mut probe = x.to_vec();
            probe[c] = x[c] + h[c];
            let up = f(&probe)?;
            probe[c] = x[c] - h[c];
            let down = f(&probe)?;
            (up.len() == down.len()).then(|| {
                up.iter()
                    .zip(&down)
                    .map(|(u, d)| (u - d) / (2.0 * h[c]))
                    .collect()
            })
        })
        .collect::<Option<_>>()?;
    let rows = match columns.first() {
        Some(col) => col.len(),
        None => f(x)?.len(),
    };
    let mut j = DMatrix::zeros(rows, x.len());
    for (&c, col) in cols.iter().zip(&columns) {
        if col.len() != rows {
            return None;
        }
        j.column_mut(c).copy_from_slice(col);
    }
    Some(j)
}

/// The free columns of `j`, each divided by its norm (zero columns stay zero), and the norms.
fn scaled_free(j: &DMatrix<f64>, free: &[bool]) -> (DMatrix<f64>, Vec<usize>) {
    let cols: Vec<usize> = (0..j.ncols()).filter(|&c| free[c]).collect();
    let mut s = DMatrix::zeros(j.nrows(), cols.len());
    for (k, &c) in cols.iter().enumerate() {
        let col = j.column(c);
        let n = col.norm();
        if n > 0.0 {
            s.set_column(k, &(col / n));
        }
    }
    (s, cols)
}

/// Condition number (largest / smallest singular value) of the column-scaled free Jacobian;
/// infinite when a column is zero or the rank is short.
pub fn condition(j: &DMatrix<f64>, free: &[bool]) -> f64 {
    let (s, cols) = scaled_free(j, free);
    if cols.is_empty() {
        return 1.0;
    }
    let sv = s.singular_values();
    let max = sv.max();
    let min = sv.min();
    if min > 0.0 { max / min } else { f64::INFINITY }
}

/// The parameters that must be fixed for the Jacobian `j` to have full column rank over the
/// free ones: one per singular direction (singular value < [`RANK_TOLERANCE`] × the largest),
/// the free parameter with the largest component in it. A direction dominated by a parameter
/// without `fixable[j]` (a nuisance, e.g. a run's start heading, observable only through the
/// non-linear terms the prior makes zero) is left to the damped solver: that parameter is set
/// aside for the rest of the analysis but not named. Parameters whose column is zero (the data
/// do not depend on them at all) are always named when fixable.
pub fn unobservable(j: &DMatrix<f64>, free: &[bool], fixable: &[bool]) -> Vec<usize> {
    let mut free = free.to_vec();
    let mut out = Vec::new();
    for _ in 0..free.len() {
        let (s, cols) = scaled_free(j, &free);
        if cols.is_empty() {
            break;
        }
        let svd = s.clone().svd(false, true);
        let Some(v_t) = svd.v_t else { break };
        let sv = &svd.singular_values;
        let max = sv.max();
        // With fewer rows than columns the missing singular values are zero.
        let short = s.nrows() < cols.len();
        let Some((idx, _)) = sv
            .iter()
            .enumerate()
            .filter(|(_, v)| **v < RANK_TOLERANCE * max || short)
            .min_by(|a, b| a.1.total_cmp(b.1))
        else {
            break;
        };
        let dir = v_t.row(idx);
        let Some(k) = (0..cols.len()).max_by(|&a, &b| dir[a].abs().total_cmp(&dir[b].abs())) else {
            break;
        };
        free[cols[k]] = false;
        if fixable[cols[k]] {
            out.push(cols[k]);
        }
    }
    out
}

fn cost(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// Minimises `Σ f(x)²` from `x0` over the parameters with `free[j]` (the others stay at their
/// `x0` value), with Jacobian steps `h`. See the module docs.
///
/// # Errors
/// [`LsqError::BadStart`] if `f(x0)` fails; [`LsqError::TooFewResiduals`] if there are not
/// more residuals than free parameters.
pub fn solve<F>(f: &F, x0: &[f64], h: &[f64], free: &[bool]) -> Result<Solution, LsqError>
where
    F: Fn(&[f64]) -> Option<Vec<f64>> + Sync,
{
    let mut x = x0.to_vec();
    let mut r = f(&x).ok_or(LsqError::BadStart)?;
    let n_free = free.iter().filter(|f| **f).count();
    if r.len() <= n_free {
        return Err(LsqError::TooFewResiduals {
            residuals: r.len(),
            parameters: n_free,
        });
    }
    let cols: Vec<usize> = (0..x.len()).filter(|&c| free[c]).collect();
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut c = cost(&r);
    while iterations < MAX_ITERATIONS && !cols.is_empty() {
        iterations += 1;
        let Some(j) = jacobian(f, &x, h, free) else {
            break;
        };
        let jf = DMatrix::from_fn(j.nrows(), cols.len(), |a, b| j[(a, cols[b])]);
        let jtj = jf.transpose() * &jf;
        let jtr = jf.transpose() * DVector::from_column_slice(&r);
        let mut improved = false;
        for _ in 0..12 {
            let mut a = jtj.clone();
            // Marquardt's scaling, with a floor so a (nearly) unobserved nuisance parameter
            // does not make the system singular.
            let floor = 1e-12 * jtj.diagonal().max();
            for k in 0..cols.len() {
                a[(k, k)] += lambda * jtj[(k, k)].max(floor).max(1e-300);
            }
            let Some(delta) = a.cholesky().map(|ch| ch.solve(&(-&jtr))) else {
                lambda *= 10.0;
                continue;
            };
            let mut trial = x.clone();
            for (k, &col) in cols.iter().enumerate() {
                trial[col] += delta[k];
            }
            match f(&trial) {
                Some(rt) if cost(&rt) < c => {
                    let small = delta
                        .iter()
                        .zip(&cols)
                        .all(|(d, &col)| d.abs() < 1e-10 * (1.0 + x[col].abs()));
                    let gain = (c - cost(&rt)) / c.max(1e-300);
                    x = trial;
                    c = cost(&rt);
                    r = rt;
                    lambda = (lambda / 10.0).max(1e-12);
                    improved = !(small || gain < 1e-12);
                    break;
                }
                _ => lambda *= 10.0,
            }
        }
        if !improved {
            break;
        }
    }
    let m = r.len();
    let dof = (m - n_free).max(1) as f64;
    let variance = c / dof;
    let mut sigma = vec![0.0; x.len()];
    let mut cond = 1.0;
    if let Some(j) = jacobian(f, &x, h, free)
        && !cols.is_empty()
    {
        cond = condition(&j, free);
        let jf = DMatrix::from_fn(j.nrows(), cols.len(), |a, b| j[(a, cols[b])]);
        // Pseudo-inverse: a direction left singular (see `unobservable`) gets no variance
        // instead of an infinite one; the others are those of the inverse.
        let jtj = jf.transpose() * &jf;
        let eps = 1e-14 * jtj.diagonal().max();
        if let Ok(inv) = jtj.pseudo_inverse(eps) {
            for (k, &col) in cols.iter().enumerate() {
                sigma[col] = (variance * inv[(k, k)]).max(0.0).sqrt();
            }
        }
    }
    Ok(Solution {
        x,
        sigma,
        residual_variance: variance,
        residual_rms: (c / m as f64).sqrt(),
        residuals: m,
        iterations,
        condition: cond,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `y = a·exp(b·t)` sampled without noise: LM from a poor start recovers `a, b` exactly.
    #[test]
    fn recovers_an_exponential() {
        let t: Vec<f64> = (0..20).map(|k| k as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 2.5 * (-1.3 * t).exp()).collect();
        let f = |x: &[f64]| {
            Some(
                t.iter()
                    .zip(&y)
                    .map(|(t, y)| x[0] * (x[1] * t).exp() - y)
                    .collect(),
            )
        };
        let s = solve(&f, &[1.0, 0.0], &[1e-6, 1e-6], &[true, true]).unwrap();
        assert!((s.x[0] - 2.5).abs() < 1e-8, "{:?}", s.x);
        assert!((s.x[1] + 1.3).abs() < 1e-8, "{:?}", s.x);
    }

    /// The numerical Jacobian of a known function matches its analytic derivative.
    #[test]
    fn jacobian_matches_the_analytic_one() {
        let f = |x: &[f64]| Some(vec![x[0] * x[1], x[0].sin(), x[1] * x[1] * x[1]]);
        let x = [0.7, -1.2];
        let j = jacobian(&f, &x, &[1e-6, 1e-6], &[true, true]).unwrap();
        let want = [[x[1], x[0]], [x[0].cos(), 0.0], [0.0, 3.0 * x[1] * x[1]]];
        for r in 0..3 {
            for c in 0..2 {
                assert!(
                    (j[(r, c)] - want[r][c]).abs() < 1e-8,
                    "{r},{c}: {}",
                    j[(r, c)]
                );
            }
        }
    }

    /// A straight-line fit with known noise level: the covariance's 1σ of the slope matches
    /// the textbook `σ / sqrt(Σ (t − t̄)²)`.
    #[test]
    fn covariance_of_a_line_fit() {
        let t: Vec<f64> = (0..11).map(|k| k as f64).collect();
        // Deterministic ±0.1 alternating "noise": Σr² known after the fit.
        let y: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(k, t)| 1.0 + 0.5 * t + if k % 2 == 0 { 0.1 } else { -0.1 })
            .collect();
        let f = |x: &[f64]| Some(t.iter().zip(&y).map(|(t, y)| x[0] + x[1] * t - y).collect());
        let s = solve(&f, &[0.0, 0.0], &[1e-6, 1e-6], &[true, true]).unwrap();
        let sxx: f64 = t.iter().map(|t| (t - 5.0) * (t - 5.0)).sum();
        let want = (s.residual_variance / sxx).sqrt();
        assert!(
            (s.sigma[1] - want).abs() < 1e-9 * want.max(1.0),
            "{} vs {want}",
            s.sigma[1]
        );
        assert!(s.residual_variance > 0.0);
    }

    /// The parallel columns: a fixed parameter's column is zero, the others are those of the
    /// analytic Jacobian, and a probe where `f` fails (here `x[1] > 1.5`) fails the whole.
    #[test]
    fn fixed_columns_are_zero_and_a_failing_probe_fails() {
        let f = |x: &[f64]| {
            (x[1] <= 1.5).then(|| vec![x[0] * x[1], x[0] + 3.0 * x[2], x[1] * x[2] * x[2]])
        };
        let x = [2.0, 1.0, 0.5];
        let j = jacobian(&f, &x, &[1e-6; 3], &[true, false, true]).unwrap();
        let want = [[1.0, 0.0, 0.0], [1.0, 0.0, 3.0], [0.0, 0.0, 1.0]];
        for (r, row) in want.iter().enumerate() {
            for (c, w) in row.iter().enumerate() {
                assert!((j[(r, c)] - w).abs() < 1e-6, "({r},{c}): {}", j[(r, c)]);
            }
        }
        assert!(jacobian(&f, &[2.0, 1.5, 0.5], &[1e-3; 3], &[false, true, false]).is_none());
        let none_free = jacobian(&f, &x, &[1e-6; 3], &[false; 3]).unwrap();
        assert_eq!(none_free.shape(), (3, 3));
        assert!(none_free.iter().all(|v| *v == 0.0));
    }

    /// Two parameters that only enter as a sum: one of them is named unobservable, and with it
    /// fixed the sum is still fitted.
    #[test]
    fn a_sum_of_two_parameters_is_rank_deficient() {
        let t: Vec<f64> = (0..10).map(|k| k as f64).collect();
        let f = |x: &[f64]| Some(t.iter().map(|t| (x[0] + x[1]) * t - 3.0 * t).collect());
        let x = [1.0, 1.0];
        let j = jacobian(&f, &x, &[1e-6, 1e-6], &[true, true]).unwrap();
        let fixed = unobservable(&j, &[true, true], &[true, true]);
        assert_eq!(fixed.len(), 1, "{fixed:?}");
        assert!(condition(&j, &[true, true]) > 1e6);
        let mut free = [true, true];
        free[fixed[0]] = false;
        let s = solve(&f, &x, &[1e-6, 1e-6], &free).unwrap();
        assert!((s.x[0] + s.x[1] - 3.0).abs() < 1e-9);
        // A parameter that nothing depends on is named too.
        let g = |x: &[f64]| Some(t.iter().map(|t| x[0] * t - 2.0).collect());
        let j = jacobian(&g, &x, &[1e-6, 1e-6], &[true, true]).unwrap();
        assert_eq!(unobservable(&j, &[true, true], &[true, true]), vec![1]);
    }
}
