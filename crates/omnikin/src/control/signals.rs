//! What the balance controller reads and writes each cycle: the measured state
//! ([`Measurement`], from the AHRS and the odometry), the motion to follow ([`BalanceCommand`], with an
//! optional previewed [`Lean`]) and the output ([`BalanceOutput`], [`BalanceState`]).

use nalgebra::{UnitQuaternion, Vector3};

use crate::ballbot::Ballbot;
use crate::real::finite_out;
use crate::{InputError, Real};

/// The measured state, one control cycle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement<T> {
    /// Body tilts `(θ_x, θ_y)` about the heading frame's x and y axes, rad: with `z_h` the body
    /// z axis in the heading frame, `θ_y = atan2(z_x, z_z)`, `θ_x = atan2(−z_y, z_z)`.
    pub tilt: [T; 2],
    /// Tilt rates `(θ̇_x, θ̇_y)`: the body's angular velocity about the heading axes, rad/s.
    pub tilt_rate: [T; 2],
    /// Body yaw `β`, rad (world, counter-clockwise from +x).
    pub yaw: T,
    /// Body yaw rate, rad/s.
    pub yaw_rate: T,
    /// Ball centre position, world frame, m.
    pub ball_position: [T; 2],
    /// Ball centre velocity, world frame, m/s.
    pub ball_velocity: [T; 2],
}

impl<T: Real> Measurement<T> {
    /// From the AHRS orientation `q` (body → world, [`crate::estimate::ahrs::Mahony::quaternion`]),
    /// the bias-corrected gyro (body frame, rad/s) and the odometry's ball position and velocity
    /// (world frame). The yaw is the ZYX Euler yaw of `q` and the heading frame `Rz(β)`.
    pub fn from_attitude(
        q: &UnitQuaternion<T>,
        gyro: [T; 3],
        ball_position: [T; 2],
        ball_velocity: [T; 2],
    ) -> Self {
        let (_, _, yaw) = q.euler_angles();
        let heading = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -yaw);
        let tilt_q = heading * q;
        let z = tilt_q * Vector3::z();
        let w = tilt_q * Vector3::from(gyro);
        Self {
            tilt: [(-z.y).atan2(z.z), z.x.atan2(z.z)],
            tilt_rate: [w.x, w.y],
            yaw,
            yaw_rate: w.z,
            ball_position,
            ball_velocity,
        }
    }

    /// The tilt `ϑ` between the body z axis and the vertical, rad:
    /// `atan √(tan²θ_x + tan²θ_y)`.
    pub fn tilt_angle(&self) -> T {
        let (tx, ty) = (self.tilt[0].tan(), self.tilt[1].tan());
        (tx * tx + ty * ty).sqrt().atan()
    }
}

/// A previewed lean: the body's lean along a planned motion (world frame), from a reference
/// generator that knows the plan ahead (e.g. `omnikin_sim::dynamics::ballbot::preview`).
///
/// The lean vector `ℓ = (ℓ_x, ℓ_y)` is the horizontal part of the body z axis (rad for small
/// tilts; in the heading frame `θ_y = ℓ_x`, `θ_x = −ℓ_y` at yaw 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lean<T> {
    /// Lean `ℓ`, rad.
    pub tilt: [T; 2],
    /// Its rate `ℓ̇`, rad/s.
    pub rate: [T; 2],
    /// Its second derivative `ℓ̈`, rad/s².
    pub accel: [T; 2],
}

/// The ball's velocity (world frame, m/s) from the wheel rates, corrected for the body's own
/// rotation: the encoders measure the ball's rotation *relative to the body*,
/// `ω_rel = (k B)⁻¹ ψ̇` (body frame, [`Ballbot::relative_rate_from_wheels`]); the ball's
/// absolute rate is `Ω = R_B (ω_rel + ω_gyro)` and it rolls at `v = R (Ω_y, −Ω_x)`. Without
/// the gyro term a leaning body would read as a rolling ball (`R θ̇`, the Rezero/Kugle
/// correction).
///
/// `q` is the orientation (body → world, from the AHRS), `gyro` the bias-corrected gyro (body
/// frame, rad/s), `wheel_rates` in rad/s.
///
/// # Errors
/// [`InputError::NonFinite`] for a non-finite rate.
pub fn ball_velocity_from_wheels<T: Real>(
    robot: &Ballbot<T>,
    wheel_rates: [T; 3],
    q: &UnitQuaternion<T>,
    gyro: [T; 3],
) -> Result<[T; 2], InputError> {
    let rel = robot.relative_rate_from_wheels(wheel_rates)?;
    let g = Vector3::from(crate::real::finite3(
        gyro,
        ["gyro[0]", "gyro[1]", "gyro[2]"],
    )?);
    let om = q * (rel + g);
    let r = robot.params().ball_radius;
    finite_out([r * om.y, -r * om.x], "ball velocity")
}

/// The motion to follow, one control cycle (a plan sample).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BalanceCommand<T> {
    /// Ball velocity, world frame, m/s.
    pub velocity: [T; 2],
    /// Ball acceleration, world frame, m/s² (the feed-forward lean; 0 if unknown).
    pub acceleration: [T; 2],
    /// Body yaw rate, rad/s.
    pub yaw_rate: T,
    /// A previewed lean, when the plan is known ahead: replaces the static feed-forward lean
    /// (which a ballbot can only reach by first rolling the other way, a few cm behind the
    /// plan at each acceleration step), and the feed-forward torque becomes
    /// `u_ff = −(a φ̈_ref + b θ̈_ref + (c_f + c_r) φ̇_ref − c_r θ̇_ref)/k` (ball row of the
    /// planar model).
    pub lean: Option<Lean<T>>,
}

impl<T: Real> BalanceCommand<T> {
    /// Stand still.
    pub fn hold() -> Self {
        Self {
            velocity: [T::zero(); 2],
            acceleration: [T::zero(); 2],
            yaw_rate: T::zero(),
            lean: None,
        }
    }
}

/// Balancing, or fallen (latched; motors off).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BalanceState {
    /// Balancing.
    Balancing,
    /// The tilt passed the fall threshold: motors off until reset.
    Fallen,
}

/// One cycle's output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BalanceOutput<T> {
    /// Wheel torques `(T1, T2, T3)` to apply, N·m (after saturation; 0 when fallen).
    pub wheel_torques: [T; 3],
    /// Model torques `(Tx, Ty, Tz)` of the applied wheel torques (heading frame), N·m.
    pub model_torques: [T; 3],
    /// Model torques the control law asked for, N·m.
    pub requested: [T; 3],
    /// Whether the torque limit scaled the request down.
    pub saturated: bool,
    /// The saturation factor (1 when not saturated, 0 when fallen).
    pub scale: T,
    /// Tilt `ϑ`, rad.
    pub tilt: T,
    /// Balancing or fallen.
    pub status: BalanceState,
}
