//! [`ProcessNoise`]: how much uncertainty an odometry step adds to a pose filter
//! ([`super::fusion::PoseFusion`]).

use crate::Real;

/// Odometry noise model: each step adds a zero-mean error with robot-frame variances that grow
/// **linearly** with the distance travelled, the angle turned and the time elapsed (a random
/// walk, so splitting a step in two adds the same variance as the whole step):
///
/// ```text
/// σ²_x = σ²_y = translation² · s + translation_per_time² · Δt
/// σ²_θ = heading_per_distance² · s + heading_per_turn² · |Δθ| + heading_per_time² · Δt
/// ```
///
/// with `s = |(Δx, Δy)|` (m) and `Δθ` (rad) of the step. Units: `translation` in m/√m,
/// `translation_per_time` in m/√s, `heading_per_distance` in rad/√m, `heading_per_turn` in
/// rad/√rad, `heading_per_time` in rad/√s (a gyro's angle random walk when the heading comes
/// from a gyro). (The variance form of Thrun, Burgard & Fox, *Probabilistic Robotics*, 2005,
/// §5.4, made additive.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProcessNoise<T> {
    /// Translation error per √metre travelled, m/√m.
    pub translation: T,
    /// Translation error per √second, m/√s (keeps the covariance from freezing when still).
    pub translation_per_time: T,
    /// Heading error per √metre travelled, rad/√m.
    pub heading_per_distance: T,
    /// Heading error per √radian turned, rad/√rad.
    pub heading_per_turn: T,
    /// Heading error per √second, rad/√s.
    pub heading_per_time: T,
}

impl<T: Real> ProcessNoise<T> {
    /// A moderate wheel-odometry model: 2 cm/√m, 1 mm/√s, 0.02 rad/√m, 0.05 rad/√rad,
    /// 1 mrad/√s.
    pub fn wheel_odometry() -> Self {
        Self {
            translation: T::of(0.02),
            translation_per_time: T::of(0.001),
            heading_per_distance: T::of(0.02),
            heading_per_turn: T::of(0.05),
            heading_per_time: T::of(0.001),
        }
    }

    /// Robot-frame variances `(σ²_xy, σ²_θ)` of a step of chord `s = |(Δx, Δy)|` (m), turn
    /// `dheading` (rad) and length `dt` (s).
    pub(crate) fn variances_over(&self, s: T, dheading: T, dt: T) -> (T, T) {
        let sq = |x: T| x * x;
        (
            sq(self.translation) * s + sq(self.translation_per_time) * dt,
            sq(self.heading_per_distance) * s
                + sq(self.heading_per_turn) * dheading.abs()
                + sq(self.heading_per_time) * dt,
        )
    }
}
