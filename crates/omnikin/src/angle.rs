//! Angle wrapping: the one helper of the workspace that folds an angle into `(−π, π]`.

use crate::Real;

/// `x` (rad) wrapped into `(−π, π]`: the angle in that interval that differs from `x` by a
/// whole number of turns. The upper end is closed, so `wrap_angle(π) = π`, `wrap_angle(−π) = π`
/// and `wrap_angle(3π) = π`. NaN and ±∞ give NaN. No allocation, no panic; an `x` already in
/// range is returned unchanged (bit for bit).
///
/// Every layer uses this one helper (heading errors of the controller and the planner, odometry
/// and estimator increments, simulated yaw sensors, `omnikin_sim::metrics::angle_diff`), so all
/// of them agree on the boundary.
///
/// ```
/// use core::f64::consts::PI;
/// use omnikin::wrap_angle;
///
/// assert_eq!(wrap_angle(PI), PI);
/// assert_eq!(wrap_angle(-PI), PI);
/// assert!((wrap_angle(0.5 + 4.0 * PI) - 0.5).abs() < 1e-12);
/// ```
#[inline(always)]
pub fn wrap_angle<T: Real>(x: T) -> T {
    // Already in range (every per-step increment): the general path would return `x`
    // unchanged, so skip its `round` (a libm call in no_std builds).
    if x > -T::pi() && x <= T::pi() {
        return x;
    }
    wrap_angle_out_of_range(x)
}

/// [`wrap_angle`] for `x` outside `(−π, π]` (or NaN).
#[cold]
#[inline(never)]
fn wrap_angle_out_of_range<T: Real>(x: T) -> T {
    let two_pi = T::two_pi();
    let mut y = x - two_pi * (x / two_pi).round();
    if y <= -T::pi() {
        y += two_pi;
    } else if y > T::pi() {
        y -= two_pi;
    }
    y
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_angle_range() {
        let pi = core::f64::consts::PI;
        for &(x, y) in &[
            (0.0, 0.0),
            (pi, pi),
            (-pi, pi),
            (3.0 * pi, pi),
            (0.5 + 4.0 * pi, 0.5),
            (-0.5 - 6.0 * pi, -0.5),
        ] {
            assert!(
                (wrap_angle(x) - y).abs() < 1e-12,
                "{x} -> {}",
                wrap_angle(x)
            );
        }
    }
}
