//! The simulated ballbot's state ([`BallbotState`]); its integration is in `step.rs`.

use omnikin::nalgebra::{UnitQuaternion, Vector3};

/// State of the 3D ballbot. The ball is homogeneous, so its own orientation does not enter the
/// dynamics and is not kept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallbotState {
    /// Ball-centre position on the floor `(x, y)`, world frame, m (the centre is at height
    /// `R`).
    pub position: [f64; 2],
    /// Body orientation, body → world.
    pub orientation: UnitQuaternion<f64>,
    /// Ball angular velocity `Ω`, world frame, rad/s.
    pub ball_rate: Vector3<f64>,
    /// Body angular velocity `ω`, world frame, rad/s.
    pub body_rate: Vector3<f64>,
    /// Cumulative wheel angles `ψ_i`, rad (what the encoders count).
    pub wheel_angles: [f64; 3],
}
