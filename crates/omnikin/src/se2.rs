//! Exact integration on SE(2): the one function that turns a constant twist held for a time
//! step into a pose change. Odometry, planner checks and the simulator all use it, so they
//! agree to the last bit and none of them accumulates Euler drift on arcs.

use crate::{Pose2, Real, Twist2};

/// `(sin θ / θ, (1 − cos θ) / θ)`: Taylor series for `|θ| < 0.25` rad (the per-step heading
/// change of any sampled odometry or trajectory at a realistic rate), so both stay accurate
/// near 0 and need no `sin`; from `sin` beyond.
#[inline]
fn sinc_cosc<T: Real>(theta: T) -> (T, T) {
    let t2 = theta * theta;
    if theta.abs() < T::of(1e-3) {
        // sinθ/θ = 1 − θ²/6 + θ⁴/120;  (1−cosθ)/θ = θ/2 − θ³/24 + θ⁵/720
        let a = T::one() - t2 / T::of(6.0) + t2 * t2 / T::of(120.0);
        let b = theta * (T::of(0.5) - t2 / T::of(24.0) + t2 * t2 / T::of(720.0));
        (a, b)
    } else if theta.abs() < T::of(0.25) {
        // The same series through θ¹⁰ (θ¹¹): the first omitted terms, θ¹²/13! and θ¹³/14!,
        // are below 1.1e-17 and 7e-19 of the leading ones at |θ| = 0.25, under half an ulp
        // of f64. Horner in θ²; the constants 1/(2k+1)! and 1/(2k+2)! are rounded once.
        let a = T::one()
            - t2 * (T::of(1.0 / 6.0)
                - t2 * (T::of(1.0 / 120.0)
                    - t2 * (T::of(1.0 / 5040.0)
                        - t2 * (T::of(1.0 / 362_880.0) - t2 * T::of(1.0 / 39_916_800.0)))));
        let b = theta
            * (T::of(0.5)
                - t2 * (T::of(1.0 / 24.0)
                    - t2 * (T::of(1.0 / 720.0)
                        - t2 * (T::of(1.0 / 40_320.0)
                            - t2 * (T::of(1.0 / 3_628_800.0) - t2 * T::of(1.0 / 479_001_600.0))))));
        (a, b)
    } else {
        // 1 − cosθ = 2 sin²(θ/2) avoids cancellation for small θ.
        let h = (theta * T::of(0.5)).sin();
        (theta.sin() / theta, T::of(2.0) * h * h / theta)
    }
}

/// The pose change, in the frame of the starting pose, of a body moving for `dt` seconds with
/// the constant **robot-frame** twist `twist`: the SE(2) exponential `exp(dt · twist)`.
///
/// With `θ = yaw_rate·dt`, `(dx, dy) = V(θ)·(vx, vy)·dt` where
/// `V(θ) = [[sinθ/θ, −(1−cosθ)/θ], [(1−cosθ)/θ, sinθ/θ]]`; `dheading = θ`. Exact for motion
/// on a circular arc (or a line when `yaw_rate = 0`).
#[inline]
pub fn twist_exp<T: Real>(twist: Twist2<T>, dt: T) -> Pose2<T> {
    let theta = twist.yaw_rate * dt;
    let (a, b) = sinc_cosc(theta);
    let (ux, uy) = (twist.vx * dt, twist.vy * dt);
    Pose2::new(a * ux - b * uy, b * ux + a * uy, theta)
}

/// `(sin θ, cos θ)` through the series of [`sinc_cosc`] for `|θ| < 0.25` rad — the heading
/// of an odometry increment, without a call to `sin_cos` — and from `sin_cos` beyond.
#[inline]
pub(crate) fn sin_cos_near_zero<T: Real>(theta: T) -> (T, T) {
    if theta.abs() < T::of(0.25) {
        let (a, b) = sinc_cosc(theta);
        (theta * a, T::one() - theta * b)
    } else {
        theta.sin_cos()
    }
}

/// Composes a world pose with a pose change expressed in that pose's frame (`pose ⊕ delta`).
/// The heading is added without wrapping.
#[inline]
pub fn compose<T: Real>(pose: Pose2<T>, delta: Pose2<T>) -> Pose2<T> {
    let (s, c) = pose.heading.sin_cos();
    compose_rotated(pose, s, c, delta)
}

/// [`compose`] given `(s, c) = pose.heading.sin_cos()`.
#[inline(always)]
pub(crate) fn compose_rotated<T: Real>(pose: Pose2<T>, s: T, c: T, delta: Pose2<T>) -> Pose2<T> {
    Pose2::new(
        pose.x + c * delta.x - s * delta.y,
        pose.y + s * delta.x + c * delta.y,
        pose.heading + delta.heading,
    )
}

/// Advances `pose` (world frame) by holding the **robot-frame** `twist` for `dt` seconds,
/// exactly (see [`twist_exp`]).
#[inline]
pub fn integrate<T: Real>(pose: Pose2<T>, twist: Twist2<T>, dt: T) -> Pose2<T> {
    compose(pose, twist_exp(twist, dt))
}

/// The SE(2) logarithm: the robot-frame unit-time twist `ξ` with `twist_exp(ξ, 1) = delta`
/// (the inverse of [`twist_exp`] for `|Δθ| < 2π`). Uses `twist_exp((1, 0, θ), 1) =
/// (sinθ/θ, (1−cosθ)/θ, θ)` for the entries of `V(θ)`; at `θ = 2πk (k ≠ 0)`, where `V` is
/// singular, returns `(Δx, Δy, Δθ)`.
pub fn log<T: Real>(delta: Pose2<T>) -> Twist2<T> {
    let v = twist_exp(Twist2::new(T::one(), T::zero(), delta.heading), T::one());
    let (a, b) = (v.x, v.y);
    let det = a * a + b * b;
    // V = [[a, −b], [b, a]]  ⇒  V⁻¹ = [[a, b], [−b, a]] / det. det ≥ (2/π)² for |θ| ≤ π; for
    // larger steps it stays positive except at θ = 2πk (k ≠ 0), where V is singular.
    if det > T::EPSILON {
        Twist2::new(
            (a * delta.x + b * delta.y) / det,
            (-b * delta.x + a * delta.y) / det,
            delta.heading,
        )
    } else {
        Twist2::new(delta.x, delta.y, delta.heading)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_inverts_twist_exp() {
        for tw in [
            Twist2::new(0.3_f64, -0.1, 0.0),
            Twist2::new(0.3, -0.1, 1e-9),
            Twist2::new(-1.2, 0.4, 2.5),
            Twist2::new(0.0, 0.0, -3.0),
        ] {
            let back = log(twist_exp(tw, 1.0));
            assert!(
                (back.vx - tw.vx).abs() < 1e-12
                    && (back.vy - tw.vy).abs() < 1e-12
                    && (back.yaw_rate - tw.yaw_rate).abs() < 1e-12,
                "{tw:?} -> {back:?}"
            );
        }
    }

    #[test]
    fn full_circle_closes() {
        // 1 m/s forward, 1 rad/s: a unit circle; 2π seconds in 1000 exact steps closes.
        let tw = Twist2::new(1.0_f64, 0.0, 1.0);
        let dt = 2.0 * core::f64::consts::PI / 1000.0;
        let mut p = Pose2::default();
        for _ in 0..1000 {
            p = integrate(p, tw, dt);
        }
        assert!(p.x.abs() < 1e-12 && p.y.abs() < 1e-12, "{p:?}");
        assert!((p.heading - 2.0 * core::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn quarter_arc_in_one_step_is_exact() {
        let tw = Twist2::new(1.0_f64, 0.0, 1.0);
        let p = twist_exp(tw, core::f64::consts::FRAC_PI_2);
        assert!((p.x - 1.0).abs() < 1e-15 && (p.y - 1.0).abs() < 1e-15);
    }

    #[test]
    fn long_series_matches_sin_up_to_a_quarter_radian() {
        for k in 0..=500 {
            let th = 1e-3 + (0.25 - 1e-3) * k as f64 / 500.0 - 1e-12;
            for th in [th, -th] {
                let (a, b) = sinc_cosc(th);
                let h = (th / 2.0).sin();
                assert!((a - th.sin() / th).abs() < 4e-16, "{th}: {a}");
                assert!((b - 2.0 * h * h / th).abs() < 4e-16, "{th}: {b}");
            }
        }
        let (a, b) = sinc_cosc(0.25_f32);
        assert!(
            (a - 0.25_f32.sin() / 0.25).abs() < 2e-7
                && (b - (1.0 - 0.25_f32.cos()) / 0.25).abs() < 2e-7
        );
    }

    #[test]
    fn small_angle_series_is_continuous() {
        for &th in &[0.999e-3_f64, 1.001e-3, -0.999e-3, -1.001e-3] {
            let (a, b) = sinc_cosc(th);
            assert!((a - th.sin() / th).abs() < 1e-15);
            let h = (th / 2.0).sin();
            assert!((b - 2.0 * h * h / th).abs() < 1e-15);
        }
    }
}
