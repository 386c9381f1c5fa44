//! The scalar type: `f32` on a microcontroller, `f64` on the PC.

use nalgebra::RealField;

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// A floating-point scalar the kinematics are generic over: implemented for `f32` and `f64`
/// only (sealed).
///
/// It is [`nalgebra::RealField`] (so `sin`, `cos`, `sqrt`, `atan2`, … work in `no_std` through
/// `libm`) plus exact conversions from and to `f64` for constants, limits and error reports.
pub trait Real: RealField + Copy + sealed::Sealed {
    /// Machine epsilon of the type.
    const EPSILON: Self;
    /// Converts an `f64` constant (rounds to nearest for `f32`).
    fn of(x: f64) -> Self;
    /// Widens to `f64` (exact for both types), for error reports and printing.
    fn to_f64(self) -> f64;
    /// `(sin x_i, cos x_i)` of four angles (rad) at once, as `([sin; 4], [cos; 4])`: for `f64`,
    /// fdlibm's reduction and kernels over the four lanes in one pass when
    /// `Σ |x_i| ≤ 10^5` rad (within 2 ulp of `libm`, absolute `10^-20` near the zeros of sine
    /// and cosine; see the `trig` module), otherwise — or for a non-finite lane — `libm` for
    /// all four; for `f32`, `libm` per lane. The caster's three wheel directions and heading
    /// take one call.
    fn sin_cos4(x: [Self; 4]) -> ([Self; 4], [Self; 4]);
}

impl Real for f32 {
    const EPSILON: Self = f32::EPSILON;
    #[inline(always)]
    fn of(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn sin_cos4(x: [Self; 4]) -> ([Self; 4], [Self; 4]) {
        crate::trig::sin_cos4_f32(x)
    }
}

impl Real for f64 {
    const EPSILON: Self = f64::EPSILON;
    #[inline(always)]
    fn of(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn sin_cos4(x: [Self; 4]) -> ([Self; 4], [Self; 4]) {
        crate::trig::sin_cos4_f64(x)
    }
}

/// `Ok(x)` if `x` is finite, otherwise [`crate::InputError::NonFinite`] naming `field`.
#[inline]
pub(crate) fn finite<T: Real>(x: T, field: &'static str) -> Result<T, crate::InputError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(crate::InputError::NonFinite { field })
    }
}

/// Checks every element of a 3-array is finite; `fields` names them in order.
#[inline]
pub(crate) fn finite3<T: Real>(
    x: [T; 3],
    fields: [&'static str; 3],
) -> Result<[T; 3], crate::InputError> {
    finite(x[0], fields[0])?;
    finite(x[1], fields[1])?;
    finite(x[2], fields[2])?;
    Ok(x)
}

/// `Ok(x)` if every element of the result `x` is finite, otherwise
/// [`crate::InputError::Overflow`] naming `quantity`.
#[inline]
pub(crate) fn finite_out<T: Real, const N: usize>(
    x: [T; N],
    quantity: &'static str,
) -> Result<[T; N], crate::InputError> {
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err(crate::InputError::Overflow { quantity })
    }
}

/// Checks a geometry parameter is finite and strictly positive.
#[inline]
pub(crate) fn positive<T: Real>(x: T, field: &'static str) -> Result<T, crate::GeometryError> {
    if !x.is_finite() {
        Err(crate::GeometryError::NonFinite { field })
    } else if x <= T::zero() {
        Err(crate::GeometryError::NotPositive {
            field,
            value: x.to_f64(),
        })
    } else {
        Ok(x)
    }
}

/// Checks a geometry parameter is finite.
#[inline]
pub(crate) fn finite_param<T: Real>(x: T, field: &'static str) -> Result<T, crate::GeometryError> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(crate::GeometryError::NonFinite { field })
    }
}
