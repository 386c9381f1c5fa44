//! Slip errors from imperfect motor speeds, paper 003, §4 (eqs. (11)–(19)).
//!
//! All of these consider **one wheel on its own** over a short interval with `θ̇ = 0`, constant
//! steer rate `Ρ` (rad/s) and constant roll rate `Ξ` (rad/s), and give the body-centre
//! displacement that wheel alone implies (world frame, m). When the three wheels imply different
//! displacements they fight and slip; the differences computed here estimate that slip. Wheel
//! directions are world angles `β = α_i + θ + γ_i` (rad).

use crate::real::finite;
use crate::{InputError, Real};

/// `sin x / x`, with its Taylor series near 0.
#[inline]
fn sinc<T: Real>(x: T) -> T {
    if x.abs() < T::of(1.0e-3) {
        let x2 = x * x;
        T::one() - x2 / T::of(6.0) + x2 * x2 / T::of(120.0)
    } else {
        x.sin() / x
    }
}

/// A displacement of the body centre in the world frame, m.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Displacement<T> {
    /// Along world x, m.
    pub dx: T,
    /// Along world y, m.
    pub dy: T,
}

/// Inputs of [`single_wheel_step`] (paper 003, eqs. (11)–(13)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelStep<T> {
    /// `r`, wheel radius, m.
    pub wheel_radius: T,
    /// `d`, eccentricity, m.
    pub eccentricity: T,
    /// `β_0 = α_i + θ_0 + γ_i0`, the wheel's world direction at `t_0`, rad.
    pub beta0: T,
    /// `Ρ`, constant steer rate, rad/s (may be 0).
    pub steer_rate: T,
    /// `Ξ`, constant roll rate, rad/s.
    pub roll_rate: T,
    /// `T = t_1 − t_0`, the control period, s.
    pub period: T,
}

/// Result of [`single_wheel_step`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelStepResult<T> {
    /// Body-centre displacement `(x_1 − x_0, y_1 − y_0)`, world frame, m.
    pub displacement: Displacement<T>,
    /// `β_1 = β_0 + Ρ T`, the wheel direction at `t_1`, rad (not wrapped).
    pub beta1: T,
}

/// Body-centre displacement implied by one wheel over one period, paper 003, eqs. (12), (13),
/// the exact integral of eq. (11) `ẋ = −r Ξ cos β + d Ρ sin β`,
/// `ẏ = −r Ξ sin β − d Ρ cos β`, `β(t) = β_0 + Ρ (t − t_0)`, `θ̇ = 0`:
///
/// `x_1 − x_0 = −(r Ξ/Ρ)[sin β_1 − sin β_0] − d [cos β_1 − cos β_0]`,
/// `y_1 − y_0 = (r Ξ/Ρ)[cos β_1 − cos β_0] − d [sin β_1 − sin β_0]`, `β_1 = β_0 + Ρ T`.
///
/// Evaluated in the division-free form (with `h = Ρ T`, `β_m = β_0 + h/2`)
/// `x_1 − x_0 = −r Ξ T cos β_m sinc(h/2) + 2 d sin β_m sin(h/2)`,
/// `y_1 − y_0 = −r Ξ T sin β_m sinc(h/2) − 2 d cos β_m sin(h/2)`, which is accurate as
/// `Ρ → 0` and reduces to the straight line `−r Ξ T (cos β_0, sin β_0)` at `Ρ = 0`.
///
/// # Errors
/// [`InputError::NonFinite`] naming the non-finite field (`"wheel_radius"`, `"eccentricity"`,
/// `"beta0"`, `"steer_rate"`, `"roll_rate"`, `"period"`), or `"displacement"` if the result
/// overflows.
pub fn single_wheel_step<T: Real>(step: &WheelStep<T>) -> Result<WheelStepResult<T>, InputError> {
    let r = finite(step.wheel_radius, "wheel_radius")?;
    let d = finite(step.eccentricity, "eccentricity")?;
    let beta0 = finite(step.beta0, "beta0")?;
    let rho = finite(step.steer_rate, "steer_rate")?;
    let xi = finite(step.roll_rate, "roll_rate")?;
    let t = finite(step.period, "period")?;
    let h = rho * t;
    let half = h * T::of(0.5);
    let (sm, cm) = (beta0 + half).sin_cos();
    let sh = half.sin();
    let lin = r * xi * t * sinc(half);
    let dx = -lin * cm + T::of(2.0) * d * sm * sh;
    let dy = -lin * sm - T::of(2.0) * d * cm * sh;
    let beta1 = beta0 + h;
    if !(dx.is_finite() && dy.is_finite() && beta1.is_finite()) {
        return Err(InputError::NonFinite {
            field: "displacement",
        });
    }
    Ok(WheelStepResult {
        displacement: Displacement { dx, dy },
        beta1,
    })
}

/// Inputs of the speed-fluctuation error, paper 003, eqs. (15), (16).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedFluctuation<T> {
    /// `r`, wheel radius, m.
    pub wheel_radius: T,
    /// `d`, eccentricity, m.
    pub eccentricity: T,
    /// `β_1`, the nominal wheel direction at the end of the period, rad.
    pub beta1: T,
    /// `Ρ`, nominal steer rate, rad/s (must be ≠ 0).
    pub steer_rate: T,
    /// `Ξ`, nominal roll rate, rad/s.
    pub roll_rate: T,
    /// `ΔΡ`, steer-rate error, rad/s.
    pub steer_rate_error: T,
    /// `ΔΞ`, roll-rate error, rad/s (used by [`speed_fluctuation_full`] only; the linearised
    /// form assumes `(Ξ+ΔΞ)/(Ρ+ΔΡ) = Ξ/Ρ`).
    pub roll_rate_error: T,
    /// `T`, the control period, s.
    pub period: T,
}

/// Checks the common inputs of the fluctuation formulas; returns `(r, d, β_1, Ρ, Ξ, ΔΡ, ΔΞ,
/// T, Ξ/Ρ)`.
#[allow(clippy::type_complexity)]
fn check_fluctuation<T: Real>(
    f: &SpeedFluctuation<T>,
) -> Result<(T, T, T, T, T, T, T, T, T), InputError> {
    let r = finite(f.wheel_radius, "wheel_radius")?;
    let d = finite(f.eccentricity, "eccentricity")?;
    let b1 = finite(f.beta1, "beta1")?;
    let rho = finite(f.steer_rate, "steer_rate")?;
    let xi = finite(f.roll_rate, "roll_rate")?;
    let drho = finite(f.steer_rate_error, "steer_rate_error")?;
    let dxi = finite(f.roll_rate_error, "roll_rate_error")?;
    let t = finite(f.period, "period")?;
    let ratio = ratio(xi, rho, "Ξ/Ρ: the steer rate Ρ is 0 (or Ξ/Ρ overflows)")?;
    Ok((r, d, b1, rho, xi, drho, dxi, t, ratio))
}

/// `num/den`, or [`InputError::Singular`] with `reason` when `den = 0` or it overflows.
#[inline]
fn ratio<T: Real>(num: T, den: T, reason: &'static str) -> Result<T, InputError> {
    if den == T::zero() {
        return Err(InputError::Singular { reason });
    }
    let q = num / den;
    if q.is_finite() {
        Ok(q)
    } else {
        Err(InputError::Singular { reason })
    }
}

/// Position error at `t_1` from a steer-rate fluctuation `ΔΡ`, the paper's **linearised**
/// form, paper 003, eqs. (15), (16) (world frame, m):
///
/// `Δx_1 = −r (Ξ/Ρ) ΔΡ T cos β_1 + d ΔΡ T sin β_1`,
/// `Δy_1 = −r (Ξ/Ρ) ΔΡ T sin β_1 − d ΔΡ T cos β_1`.
///
/// Assumptions (paper 003, §4): the angle error `ΔΡ T` is small (first order in it), and the
/// roll rate fluctuates in proportion so the ratio is unchanged, `(Ξ+ΔΞ)/(Ρ+ΔΡ) = Ξ/Ρ`
/// (`roll_rate_error` is ignored). It is the first-order expansion of
/// [`speed_fluctuation_full`] in `ΔΡ T`; a test checks the two agree for small `ΔΡ T`. Note
/// the error scales with `d ΔΡ T` and `r (Ξ/Ρ) ΔΡ T`: steer-motor fluctuation matters more
/// than roll-motor fluctuation.
///
/// # Errors
/// [`InputError::NonFinite`] naming a non-finite field; [`InputError::Singular`] when
/// `Ρ = 0` (or `Ξ/Ρ` overflows).
pub fn speed_fluctuation<T: Real>(f: &SpeedFluctuation<T>) -> Result<Displacement<T>, InputError> {
    let (r, d, b1, _rho, _xi, drho, _dxi, t, ratio) = check_fluctuation(f)?;
    let (s, c) = b1.sin_cos();
    let e = drho * t;
    let dx = -r * ratio * e * c + d * e * s;
    let dy = -r * ratio * e * s - d * e * c;
    if !(dx.is_finite() && dy.is_finite()) {
        return Err(InputError::NonFinite {
            field: "displacement",
        });
    }
    Ok(Displacement { dx, dy })
}

/// Position error at `t_1` from rate fluctuations `ΔΡ`, `ΔΞ`, the un-linearised form the
/// paper starts from, paper 003, §4 before eqs. (15), (16) (world frame, m):
///
/// `Δx_1 = −r [(Ξ+ΔΞ)/(Ρ+ΔΡ) sin(β_1+ΔΡT) − (Ξ/Ρ) sin β_1] − d [cos(β_1+ΔΡT) − cos β_1]`,
/// `Δy_1 = r [(Ξ+ΔΞ)/(Ρ+ΔΡ) cos(β_1+ΔΡT) − (Ξ/Ρ) cos β_1] − d [sin(β_1+ΔΡT) − sin β_1]`.
///
/// This is the difference between the end points of eqs. (12), (13) with the perturbed and
/// the nominal rates, taken from the same start, **when the ratio is unchanged**
/// (`(Ξ+ΔΞ)/(Ρ+ΔΡ) = Ξ/Ρ`); otherwise the exact difference has the extra term
/// `+ r ((Ξ+ΔΞ)/(Ρ+ΔΡ) − Ξ/Ρ)(sin β_0, −cos β_0)`, which the paper's form (implemented here
/// as printed) omits.
///
/// # Errors
/// [`InputError::NonFinite`] naming a non-finite field; [`InputError::Singular`] when `Ρ = 0`
/// or `Ρ + ΔΡ = 0` (or a ratio overflows).
pub fn speed_fluctuation_full<T: Real>(
    f: &SpeedFluctuation<T>,
) -> Result<Displacement<T>, InputError> {
    let (r, d, b1, rho, xi, drho, dxi, t, ratio0) = check_fluctuation(f)?;
    let ratio1 = ratio(
        xi + dxi,
        rho + drho,
        "(Ξ+ΔΞ)/(Ρ+ΔΡ): the perturbed steer rate Ρ + ΔΡ is 0 (or the ratio overflows)",
    )?;
    let (s1, c1) = b1.sin_cos();
    let (s2, c2) = (b1 + drho * t).sin_cos();
    let dx = -r * (ratio1 * s2 - ratio0 * s1) - d * (c2 - c1);
    let dy = r * (ratio1 * c2 - ratio0 * c1) - d * (s2 - s1);
    if !(dx.is_finite() && dy.is_finite()) {
        return Err(InputError::NonFinite {
            field: "displacement",
        });
    }
    Ok(Displacement { dx, dy })
}

/// Inputs of the acceleration-phase error, paper 003, eqs. (18), (19).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelerationRamp<T> {
    /// `r`, wheel radius, m.
    pub wheel_radius: T,
    /// `β_0 = α_i + θ_0 + γ_i0`, the wheel's world direction when the ramp starts, rad.
    pub beta0: T,
    /// `Ρ_0`, steer rate at the start of the ramp, rad/s.
    pub initial_steer_rate: T,
    /// `Ξ_0`, roll rate at the start of the ramp, rad/s.
    pub initial_roll_rate: T,
    /// `Ρ`, steer rate at the end of the ramp (target), rad/s (must be ≠ 0).
    pub steer_rate: T,
    /// `Ξ`, roll rate at the end of the ramp (target), rad/s.
    pub roll_rate: T,
    /// `t_σ − t_0`, the ramp duration (constant acceleration), s.
    pub duration: T,
}

/// Position error accumulated during a constant-acceleration ramp from `(Ρ_0, Ξ_0)` to
/// `(Ρ, Ξ)`, paper 003, eqs. (18), (19) (world frame, m), using the rates averaged over the
/// ramp:
///
/// `Δx_1 = r ((Ξ+Ξ_0)/(Ρ+Ρ_0) − Ξ/Ρ) [sin β_0 − sin β_σ]`,
/// `Δy_1 = r ((Ξ+Ξ_0)/(Ρ+Ρ_0) − Ξ/Ρ) [cos β_σ − cos β_0]`,
/// `β_σ = β_0 + (Ρ+Ρ_0)/2 · (t_σ − t_0)`.
///
/// It is the difference of eq. (12), (13) evaluated with the ratio of the averaged rates and
/// with the target ratio `Ξ/Ρ`, over the same sweep `β_0 → β_σ` (the eccentricity terms
/// cancel). Shorter ramps (higher acceleration) and lower roll rates reduce it.
///
/// # Errors
/// [`InputError::NonFinite`] naming a non-finite field; [`InputError::Singular`] when `Ρ = 0`
/// or `Ρ + Ρ_0 = 0` (or a ratio overflows).
pub fn acceleration_ramp<T: Real>(
    ramp: &AccelerationRamp<T>,
) -> Result<Displacement<T>, InputError> {
    let r = finite(ramp.wheel_radius, "wheel_radius")?;
    let b0 = finite(ramp.beta0, "beta0")?;
    let rho0 = finite(ramp.initial_steer_rate, "initial_steer_rate")?;
    let xi0 = finite(ramp.initial_roll_rate, "initial_roll_rate")?;
    let rho = finite(ramp.steer_rate, "steer_rate")?;
    let xi = finite(ramp.roll_rate, "roll_rate")?;
    let dt = finite(ramp.duration, "duration")?;
    let target = ratio(
        xi,
        rho,
        "Ξ/Ρ: the target steer rate Ρ is 0 (or Ξ/Ρ overflows)",
    )?;
    let avg = ratio(
        xi + xi0,
        rho + rho0,
        "(Ξ+Ξ0)/(Ρ+Ρ0): the mean steer rate over the ramp is 0 (or the ratio overflows)",
    )?;
    let k = r * (avg - target);
    let bs = b0 + (rho + rho0) * T::of(0.5) * dt;
    let (s0, c0) = b0.sin_cos();
    let (ss, cs) = bs.sin_cos();
    let dx = k * (s0 - ss);
    let dy = k * (cs - c0);
    if !(dx.is_finite() && dy.is_finite()) {
        return Err(InputError::NonFinite {
            field: "displacement",
        });
    }
    Ok(Displacement { dx, dy })
}
