//! # omnikin — kinematics of omnidirectional wheeled robots
//!
//! The core of the omnikin toolkit, the same code on a microcontroller and on a PC:
//!
//! * **`#![no_std]`, no `alloc`**: nothing here allocates; every call is a few fixed-size
//!   matrix–vector products on values precomputed when the model was built.
//! * **generic over `f32` and `f64`** through the sealed [`Real`] trait.
//! * **never panics on input**: constructors return [`GeometryError`] for a geometry that cannot
//!   work (naming the parameter, wheel and rule), calls return [`InputError`] for non-finite
//!   input or a singular configuration.
//!
//! ## Robots (one module each, same verbs)
//!
//! | module | robot | paper | inverse | forward |
//! |---|---|---|---|---|
//! | [`sphere`] | sphere rolled by an internal 3-omni-wheel platform | 000 | [`sphere::SphereOmni::wheel_rates`] | [`sphere::SphereOmni::body_twist`] |
//! | [`ballbot`] | body balancing on a ball, 3 omni-wheels | 001 | [`ballbot::Ballbot::wheel_rates`] | [`ballbot::Ballbot::body_twist`] |
//! | [`caster`] | base on three off-centred steerable wheels | 003 | [`caster::Caster3::motor_rates`] | [`caster::Caster3::body_twist`] |
//! | [`estimate::odometry`] | all three: encoder angles → pose (exact SE(2) steps), heading from wheels, gyro or yaw; caster slip residual, sphere shell spin | 000, 001, 003 | — | [`estimate::odometry::Odometry::update`] |
//! | [`estimate::ahrs`] | attitude and gyro bias from gyro + accelerometer + magnetometer (Mahony 2008) | 000 | — | [`estimate::ahrs::Mahony::update`] |
//! | [`runtime`] | all three: fixed-rate control loop over hardware traits — limits, desaturation, velocity/trajectory/stop/e-stop modes, watchdog, faults | 000 Fig. 1, 001 | [`runtime::Runtime::cycle`] | odometry |
//! | [`link`] | all three: operator link — postcard + COBS + CRC-32C frames, versioned; sessions from a PSK handshake with fresh nonces, per-session HMAC-SHA256 key, sequence numbers and replay window | 000 Fig. 1 | — | — |
//! | [`estimate::fusion`] | Kalman filter over the pose, gyro bias and wheel scale: odometry prediction, delayed camera fixes (WPILib-style replay), χ² gate and recovery | 000 | — | [`estimate::fusion::PoseFusion::add_fix`] |
//!
//! ```
//! use omnikin::sphere::{SphereOmni, SphereParams};
//! use omnikin::Twist2;
//!
//! // The robot of paper 000 in single precision, as on its microcontroller.
//! let robot = SphereOmni::<f32>::new(SphereParams::preset())?;
//! // 0.1 m/s forward (platform frame), no turning, no shell spin: paper 000, eqs. 5.6–5.7.
//! let rates = robot.wheel_rates(Twist2::new(0.1, 0.0, 0.0), 0.0)?;
//! assert!((rates[0] - -1.428571).abs() < 1e-5);
//! // Forward kinematics gives the motion back.
//! let twist = robot.body_twist(rates, 0.0)?;
//! assert!((twist.vx - 0.1).abs() < 1e-6);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Shared value types are [`Twist2`] and [`Pose2`]; [`se2`] integrates a twist exactly;
//! [`wrap_angle`] folds an angle into `(−π, π]` (the one wrap helper of the workspace).
//! Frames and signs follow REP-103 (x forward, y left, z up, counter-clockwise positive) and
//! the project conventions: where a printed paper formula is wrong (errata E1–E4 of the seed
//! digest) the physically correct one is implemented and the module docs say so.
//!
//! ## Features
//!
//! | feature | default | adds |
//! |---|---|---|
//! | `std` | yes | [`description`]: robot description files (TOML) with validation; `std::error::Error` |
//!
//! Build for firmware with `default-features = false`.
#![no_std]
#![forbid(unsafe_code)]

#[cfg(feature = "std")]
extern crate std;

mod angle;
mod error;
mod real;
mod trig;
mod types;

pub mod control;
pub mod drive;
pub mod estimate;
pub mod link;
pub mod runtime;
pub mod se2;

/// The paper robots' models live in [`drive`] with the other kinds; these paths are theirs too.
pub use drive::{ballbot, caster, sphere};

#[cfg(feature = "std")]
pub mod description;

/// The linear-algebra crate of the public API (vectors such as [`sphere::SphereOmni::levers`]).
pub use nalgebra;

pub use angle::wrap_angle;
pub use error::{GeometryError, InputError};
pub use real::Real;
pub use types::{Pose2, Twist2};

pub use drive::robot::{Actuators, EncoderAngles, Kind, MAX_WHEELS, Motion, Robot};

/// Largest accepted 2-norm condition number of a robot's 3×3 wheel-constraint matrix. Above it
/// a wheel-rate error of 1 % can become a body-velocity error of more than 10 × 1000 %; such a
/// geometry is rejected at construction with [`GeometryError::IllConditioned`].
pub const MAX_CONDITION: f64 = 1.0e3;

/// 2-norm condition number `σ_max/σ_min` of a 3×3 matrix (∞ if singular), computed in the
/// model's scalar type and reported as `f64`.
pub(crate) fn condition_number<T: Real>(m: &nalgebra::Matrix3<T>) -> f64 {
    let sv = m.singular_values();
    let (mut lo, mut hi) = (sv[0], sv[0]);
    for &s in sv.iter() {
        if s < lo {
            lo = s;
        }
        if s > hi {
            hi = s;
        }
    }
    if lo <= T::zero() {
        f64::INFINITY
    } else {
        (hi / lo).to_f64()
    }
}
