//! [`Fix`]: an external pose measurement (camera, motion capture) stamped with the time it was
//! taken, and [`Gate`]: the chi-square test that decides whether a pose filter
//! ([`super::fusion::PoseFusion`]) fuses it or rejects it as an outlier.

use crate::Real;

/// Chi-square gates on the squared Mahalanobis distance of a fix's innovation: a fix is
/// rejected when `d² > position` (position-only fix, 2 degrees of freedom) or `d² > pose` (fix
/// with heading, 3 degrees of freedom).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gate<T> {
    /// Threshold for position-only fixes (χ²₂ quantile).
    pub position: T,
    /// Threshold for fixes with a heading (χ²₃ quantile).
    pub pose: T,
}

impl<T: Real> Gate<T> {
    /// The 99.9 % quantiles: χ²₂ = 13.8155, χ²₃ = 16.2662 (one good fix in 1000 rejected).
    pub fn p999() -> Self {
        Self {
            position: T::of(13.815_510_557_964_274),
            pose: T::of(16.266_236_196_238_1),
        }
    }
    /// The 99 % quantiles: χ²₂ = 9.2103, χ²₃ = 11.3449.
    pub fn p99() -> Self {
        Self {
            position: T::of(9.210_340_371_976_182),
            pose: T::of(11.344_866_730_144_373),
        }
    }
    /// No gate: every fix is fused.
    pub fn none() -> Self {
        Self {
            position: T::of(f64::INFINITY),
            pose: T::of(f64::INFINITY),
        }
    }
}

/// An external pose measurement (camera, motion capture) of the robot centre, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fix<T> {
    /// When the measurement was **taken** (not when it arrived), s, on the odometry's clock.
    pub t: T,
    /// Measured world x, m.
    pub x: T,
    /// Measured world y, m.
    pub y: T,
    /// Measured heading, rad (any wrapping), or `None` for a position-only fix.
    pub heading: Option<T>,
    /// Standard deviation of each position coordinate, m (> 0).
    pub std_xy: T,
    /// Standard deviation of the heading, rad (> 0; unused without a heading).
    pub std_heading: T,
}

impl<T: Real> Fix<T> {
    /// A position-only fix `(x, y)` (m) taken at `t` (s) with standard deviation `std_xy` (m).
    pub fn position(t: T, x: T, y: T, std_xy: T) -> Self {
        Self {
            t,
            x,
            y,
            heading: None,
            std_xy,
            std_heading: T::one(),
        }
    }
}
