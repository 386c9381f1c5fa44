//! Small value types shared by every robot model (SI units, REP-103 frames).

use crate::Real;

/// A planar rigid-body velocity: `vx`, `vy` in m/s and `yaw_rate` in rad/s (counter-clockwise
/// positive about +z).
///
/// The frame is stated by whoever produces or consumes it: the *robot frame* (x forward, y
/// left) or the *world frame* (x, y on the floor). [`Twist2::to_world`] and
/// [`Twist2::to_robot`] convert between them for a given heading; the yaw rate is the same in
/// both.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Twist2<T> {
    /// Velocity along x, m/s.
    pub vx: T,
    /// Velocity along y, m/s.
    pub vy: T,
    /// Rotation rate about +z, rad/s.
    pub yaw_rate: T,
}

impl<T: Real> Twist2<T> {
    /// A twist from its three components (m/s, m/s, rad/s).
    #[inline]
    pub const fn new(vx: T, vy: T, yaw_rate: T) -> Self {
        Self { vx, vy, yaw_rate }
    }

    /// Rotates the linear part by `angle` (rad, counter-clockwise); the yaw rate is unchanged.
    #[inline]
    pub fn rotated(self, angle: T) -> Self {
        self.rotated_by(crate::drive::Rot2::from_angle(angle))
    }

    /// [`Twist2::rotated`] by the rotation `r = {cos, sin}` (one `sin_cos` shared by several
    /// frame changes at the same heading; `{cos ψ, −sin ψ}` turns world → robot).
    #[inline]
    pub fn rotated_by(self, r: crate::drive::Rot2<T>) -> Self {
        let (c, s) = (r.cos, r.sin);
        Self::new(
            c * self.vx - s * self.vy,
            s * self.vx + c * self.vy,
            self.yaw_rate,
        )
    }

    /// Robot-frame twist → world-frame twist for a robot whose heading is `heading` (rad):
    /// `v_world = Q(heading) v_robot` (paper 000, eq. 5.4).
    #[inline]
    pub fn to_world(self, heading: T) -> Self {
        self.rotated(heading)
    }

    /// World-frame twist → robot-frame twist: `v_robot = Q(heading)ᵀ v_world` (paper 000, §5).
    #[inline]
    pub fn to_robot(self, heading: T) -> Self {
        self.rotated(-heading)
    }

    /// The components as an array `[vx, vy, yaw_rate]`.
    #[inline]
    pub fn to_array(self) -> [T; 3] {
        [self.vx, self.vy, self.yaw_rate]
    }

    /// `true` when all three components are finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.vx.is_finite() && self.vy.is_finite() && self.yaw_rate.is_finite()
    }

    /// `Err` naming the first non-finite component (`"vx"`, `"vy"`, `"yaw_rate"`).
    #[inline]
    pub(crate) fn check_finite(self) -> Result<Self, crate::InputError> {
        crate::real::finite3(self.to_array(), ["vx", "vy", "yaw_rate"])?;
        Ok(self)
    }
}

/// A planar pose in the world frame: position `x`, `y` (m) and `heading` (rad, the yaw of the
/// robot frame; kept unwrapped by the integrators, never folded into (−π, π]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose2<T> {
    /// World x, m.
    pub x: T,
    /// World y, m.
    pub y: T,
    /// Yaw of the robot frame in the world frame, rad (unwrapped).
    pub heading: T,
}

impl<T: Real> Pose2<T> {
    /// A pose from its components (m, m, rad).
    #[inline]
    pub const fn new(x: T, y: T, heading: T) -> Self {
        Self { x, y, heading }
    }
}
