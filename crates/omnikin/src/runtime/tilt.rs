//! The sphere's tilt estimate ([`super::TiltFeedback`]): the up direction in the platform
//! frame from the gyro and the accelerometer minus the commanded acceleration, kept by the
//! runtime's sensing step and read by its shaping (the feedback) and its gyro heading.

use crate::Real;

use super::config::TiltFeedback;
use super::hal::ImuSample;

/// The tilt estimate `up` when it holds one (all zero: none yet).
#[inline(always)]
pub(super) fn tilt_known<T: Real>(up: [T; 3]) -> Option<[T; 3]> {
    let z = T::zero();
    if up[0] == z && up[1] == z && up[2] == z {
        None
    } else {
        Some(up)
    }
}

/// One step of the tilt estimate of [`TiltFeedback`] (its docs give the filter): `up` (the
/// estimated up direction in the platform frame, unit; all zero before the first sample) is
/// carried by the gyro over `dt` and pulled toward the direction of the accelerometer minus
/// the commanded robot-frame acceleration `a` (m/s²) with the time constant `τ`. `up` is left
/// unchanged while the accelerometer reads nothing usable.
///
/// [`TiltFeedback`]: super::TiltFeedback
#[inline(always)]
pub(super) fn tilt_estimate<T: Real>(
    up: &mut [T; 3],
    imu: &ImuSample<T>,
    a: [T; 2],
    dt: T,
    tf: &TiltFeedback<T>,
) {
    let f = imu.accel;
    let m = [f[0] - a[0], f[1] - a[1], f[2]];
    let mn = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
    if !mn.is_finite() || mn <= T::zero() {
        return;
    }
    let meas = [m[0] / mn, m[1] / mn, m[2] / mn];
    let Some(g) = tilt_known(*up) else {
        *up = meas;
        return;
    };
    let w = imu.gyro;
    // Gyro: d γ/dt = γ × ω (a world-fixed vector in the turning platform frame).
    let p = [
        g[0] + dt * (g[1] * w[2] - g[2] * w[1]),
        g[1] + dt * (g[2] * w[0] - g[0] * w[2]),
        g[2] + dt * (g[0] * w[1] - g[1] * w[0]),
    ];
    // Accelerometer minus the commanded acceleration, with the gain Δt/τ (at most 1).
    let mut k = dt / tf.accel_time_constant;
    if k > T::one() {
        k = T::one();
    }
    let q = [
        p[0] + k * (meas[0] - p[0]),
        p[1] + k * (meas[1] - p[1]),
        p[2] + k * (meas[2] - p[2]),
    ];
    let qn = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
    *up = if qn > T::zero() && qn.is_finite() {
        [q[0] / qn, q[1] / qn, q[2] / qn]
    } else {
        meas
    };
}
