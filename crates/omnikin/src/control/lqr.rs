//! Discrete-time LQR design: zero-order-hold discretisation of a continuous linear model and
//! the discrete algebraic Riccati equation (DARE) solved by a bounded Riccati iteration.
//!
//! Everything is fixed-size (`nalgebra` static matrices), allocation-free and meant to run
//! once, at construction. For `x[k+1] = A x[k] + B u[k]` and the cost
//! `Σ x[k]ᵀ Q x[k] + u[k]ᵀ R u[k]` the optimal feedback is `u = −K x`,
//! `K = (R + Bᵀ P B)⁻¹ Bᵀ P A`, with `P` the stabilising solution of
//! `P = Q + Aᵀ P A − Aᵀ P B (R + Bᵀ P B)⁻¹ Bᵀ P A`.
//!
//! [`dare`] iterates that equation in its *doubling* form (the structure-preserving doubling
//! algorithm, SDA: `A ← A (I + G H)⁻¹ A`, `G ← G + A (I + G H)⁻¹ G Aᵀ`,
//! `H ← H + Aᵀ H (I + G H)⁻¹ A` from `A₀ = A`, `G₀ = B R⁻¹ Bᵀ`, `H₀ = Q`; `H → P`): iteration
//! `k` equals `2ᵏ` steps of the plain Riccati recursion, so a slow plant (closed-loop poles near
//! 1 at a high control rate) converges in a few dozen iterations instead of many thousands.
//! The iteration count is bounded ([`MAX_ITERATIONS`]); the result is checked (finite,
//! closed loop strictly stable) and every failure is a precise [`LqrError`].

use nalgebra::{ComplexField, SMatrix};

use crate::Real;

/// Most doubling iterations [`dare`] runs (each doubles the horizon: 2⁶⁰ Riccati steps).
pub const MAX_ITERATIONS: usize = 60;

/// Why an LQR design failed.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum LqrError {
    /// A model or weight matrix has a NaN or infinite entry.
    #[error("{what} has a non-finite entry")]
    NonFinite {
        /// Which matrix (`"A"`, `"B"`, `"Q"`, `"R"`).
        what: &'static str,
    },
    /// A weight matrix is not symmetric positive (semi)definite as required.
    #[error("{what} must be {rule}")]
    BadWeight {
        /// `"Q"` or `"R"`.
        what: &'static str,
        /// The rule broken.
        rule: &'static str,
    },
    /// The sampling period is not finite and positive.
    #[error("sampling period {dt} s must be finite and > 0")]
    BadPeriod {
        /// The period given, s.
        dt: f64,
    },
    /// A matrix that must be inverted is singular (e.g. `I + G H` when the pair is not
    /// stabilisable).
    #[error("{what} is singular")]
    Singular {
        /// Which matrix.
        what: &'static str,
    },
    /// The Riccati iteration overflowed: there is no stabilising solution (an unstable mode
    /// that the input cannot reach, i.e. the pair `(A, B)` is not stabilisable).
    #[error("Riccati iteration diverged after {iterations} iterations: (A, B) is not stabilisable")]
    Diverged {
        /// Iterations run before the overflow.
        iterations: usize,
    },
    /// The Riccati iteration did not settle within its iteration bound.
    #[error(
        "Riccati iteration did not converge in {iterations} iterations (last relative change {change:e}, tolerance {tolerance:e})"
    )]
    NotConverged {
        /// Iterations run.
        iterations: usize,
        /// `‖H[k+1] − H[k]‖ / ‖H[k+1]‖` at the last iteration.
        change: f64,
        /// The tolerance asked for.
        tolerance: f64,
    },
    /// The gain does not stabilise the model (a closed-loop pole on or outside the unit circle;
    /// e.g. an unstable mode the input cannot reach).
    #[error("closed loop is not stable: spectral radius {spectral_radius} ≥ 1")]
    NotStabilising {
        /// Largest closed-loop pole magnitude.
        spectral_radius: f64,
    },
}

fn check_finite<T: Real, const R: usize, const C: usize>(
    m: &SMatrix<T, R, C>,
    what: &'static str,
) -> Result<(), LqrError> {
    if m.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(LqrError::NonFinite { what })
    }
}

/// Zero-order-hold discretisation of `ẋ = A x + B u` over the period `dt` (s):
/// `A_d = e^{A dt}`, `B_d = ∫₀^dt e^{A s} ds B`.
///
/// Computed by scaling and squaring: `h = dt/2ˢ` with `‖A‖₁ h ≤ ½`, the Taylor series of
/// `Φ(h) = e^{A h}` and `Γ(h) = ∫₀^h e^{A s} ds` to machine precision (at most 30 terms), then
/// `s` doublings `Γ ← Γ + Φ Γ`, `Φ ← Φ²`.
///
/// # Errors
/// [`LqrError::BadPeriod`], [`LqrError::NonFinite`] (also when the result overflows).
pub fn discretize<T: Real, const N: usize, const M: usize>(
    a: &SMatrix<T, N, N>,
    b: &SMatrix<T, N, M>,
    dt: T,
) -> Result<(SMatrix<T, N, N>, SMatrix<T, N, M>), LqrError> {
    if !(dt.is_finite() && dt > T::zero()) {
        return Err(LqrError::BadPeriod { dt: dt.to_f64() });
    }
    check_finite(a, "A")?;
    check_finite(b, "B")?;
    // 1-norm (largest column sum) bounds the spectral radius and the series' terms.
    let mut norm = T::zero();
    for c in 0..N {
        let s = a.column(c).iter().fold(T::zero(), |acc, v| acc + v.abs());
        if s > norm {
            norm = s;
        }
    }
    let half = T::of(0.5);
    let mut h = dt;
    let mut squarings = 0u32;
    while norm * h > half && squarings < 64 {
        h *= half;
        squarings += 1;
    }
    let ah = a * h;
    let mut term = SMatrix::<T, N, N>::identity(); // (A h)^k / k!
    let mut phi = SMatrix::<T, N, N>::identity();
    let mut gamma = SMatrix::<T, N, N>::identity() * h; // Σ A^k h^{k+1}/(k+1)!
    for k in 1..30usize {
        term = term * ah * (T::one() / T::of(k as f64));
        phi += term;
        let g = term * (h / T::of((k + 1) as f64));
        gamma += g;
        if term.iter().all(|v| v.abs() <= T::EPSILON * T::of(1e-3)) {
            break;
        }
    }
    for _ in 0..squarings {
        gamma += phi * gamma;
        phi = phi * phi;
    }
    let bd = gamma * b;
    check_finite(&phi, "A")?;
    check_finite(&bd, "B")?;
    Ok((phi, bd))
}

/// A discrete LQR design: the gain, the Riccati solution and how it was reached.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lqr<T: Real, const N: usize, const M: usize> {
    /// Feedback gain `K` (`u = −K x`).
    pub gain: SMatrix<T, M, N>,
    /// Stabilising solution `P` of the DARE.
    pub riccati: SMatrix<T, N, N>,
    /// Doubling iterations used.
    pub iterations: usize,
    /// Largest closed-loop pole magnitude `ρ(A − B K)` (< 1).
    pub spectral_radius: f64,
}

/// Solves the DARE for `(A, B, Q, R)` and returns the LQR gain (see the module doc).
///
/// `Q` must be symmetric positive semidefinite and `R` symmetric positive definite; the
/// iteration stops when the relative change of `H` falls below `tolerance` (e.g. `1e-12` in
/// `f64`, `1e-6` in `f32`) or after [`MAX_ITERATIONS`].
///
/// # Errors
/// [`LqrError::NonFinite`], [`LqrError::BadWeight`], [`LqrError::Singular`],
/// [`LqrError::Diverged`], [`LqrError::NotConverged`], [`LqrError::NotStabilising`].
pub fn dare<T: Real, const N: usize, const M: usize>(
    a: &SMatrix<T, N, N>,
    b: &SMatrix<T, N, M>,
    q: &SMatrix<T, N, N>,
    r: &SMatrix<T, M, M>,
    tolerance: T,
) -> Result<Lqr<T, N, M>, LqrError> {
    check_finite(a, "A")?;
    check_finite(b, "B")?;
    check_finite(q, "Q")?;
    check_finite(r, "R")?;
    let sym_tol = T::of(1e-9);
    if (q - q.transpose()).amax() > sym_tol * (T::one() + q.amax()) {
        return Err(LqrError::BadWeight {
            what: "Q",
            rule: "symmetric",
        });
    }
    if q.diagonal().iter().any(|v| *v < T::zero()) {
        return Err(LqrError::BadWeight {
            what: "Q",
            rule: "positive semidefinite (a negative diagonal entry)",
        });
    }
    if (r - r.transpose()).amax() > sym_tol * (T::one() + r.amax()) || r.cholesky().is_none() {
        return Err(LqrError::BadWeight {
            what: "R",
            rule: "symmetric positive definite",
        });
    }
    let r_inv = r.try_inverse().ok_or(LqrError::Singular { what: "R" })?;
    let id = SMatrix::<T, N, N>::identity();
    let mut ak = *a;
    let mut gk = b * r_inv * b.transpose();
    let mut hk = *q;
    let mut change = f64::INFINITY;
    let mut converged = None;
    for it in 1..=MAX_ITERATIONS {
        let w = (id + gk * hk)
            .try_inverse()
            .ok_or(LqrError::Singular { what: "I + G H" })?;
        let wa = w * ak;
        let a_next = ak * wa;
        let g_next = gk + ak * w * gk * ak.transpose();
        let h_next = hk + ak.transpose() * hk * wa;
        if !h_next.iter().all(|v| v.is_finite()) {
            return Err(LqrError::Diverged { iterations: it });
        }
        let scale = h_next.amax();
        change = if scale > T::zero() {
            ((h_next - hk).amax() / scale).to_f64()
        } else {
            0.0
        };
        ak = a_next;
        gk = g_next;
        hk = h_next;
        if change <= tolerance.to_f64() {
            converged = Some(it);
            break;
        }
    }
    let iterations = converged.ok_or(LqrError::NotConverged {
        iterations: MAX_ITERATIONS,
        change,
        tolerance: tolerance.to_f64(),
    })?;
    let p = (hk + hk.transpose()) * T::of(0.5);
    let s = r + b.transpose() * p * b;
    let s_inv = s.try_inverse().ok_or(LqrError::Singular {
        what: "R + Bᵀ P B"
    })?;
    let gain = s_inv * b.transpose() * p * a;
    check_finite(&gain, "B")?;
    let closed = a - b * gain;
    let rho = spectral_radius(&closed);
    if rho.is_nan() || rho >= 1.0 {
        return Err(LqrError::NotStabilising {
            spectral_radius: rho,
        });
    }
    Ok(Lqr {
        gain,
        riccati: p,
        iterations,
        spectral_radius: rho,
    })
}

/// Largest eigenvalue magnitude `ρ(m)` by Gelfand's formula `ρ = lim ‖m^(2^k)‖^(2^-k)`:
/// 48 normalised squarings (the norm's logarithm is carried separately, so neither a stable
/// nor an unstable matrix over- or underflows). Accurate to far better than 10⁻⁶ relative for
/// the small matrices here; NaN for a non-finite matrix; 0 for a nilpotent one.
pub fn spectral_radius<T: Real, const N: usize>(m: &SMatrix<T, N, N>) -> f64 {
    if !m.iter().all(|v| v.is_finite()) {
        return f64::NAN;
    }
    let n0 = m.amax();
    if n0 == T::zero() {
        return 0.0;
    }
    let mut x = m * (T::one() / n0);
    let mut log_norm = ln(n0.to_f64()); // ln ‖m^(2^k)‖ = log_norm + ln ‖x‖, with ‖x‖ = 1
    let mut power = 1.0f64;
    for _ in 0..48 {
        x = x * x;
        log_norm *= 2.0;
        power *= 2.0;
        let n = x.amax();
        if n == T::zero() {
            return 0.0;
        }
        x *= T::one() / n;
        log_norm += ln(n.to_f64());
    }
    <f64 as ComplexField>::exp(log_norm / power)
}

/// `ln x` through `nalgebra` (f64's inherent `ln` needs `std`).
fn ln(x: f64) -> f64 {
    <f64 as ComplexField>::ln(x)
}
