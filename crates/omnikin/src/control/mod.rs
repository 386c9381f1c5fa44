//! Feedback control on the microcontroller: the ballbot's balance controller (paper 001's
//! purpose).
//!
//! * [`planar`]: the three planar models of paper 001 (two vertical planes, yaw), linearised
//!   about upright in closed form, and the physical parameters they need.
//! * [`lqr`]: zero-order-hold discretisation and a bounded discrete Riccati iteration.
//! * [`config`]: its weights, configuration (with the preset's values) and build errors.
//! * [`signals`]: what it reads and writes each cycle (measurement, command, output).
//! * [`balance`]: the balance controller — LQR per planar model, an outer loop following a
//!   plan's velocities with a feed-forward lean, the wheel-torque map, saturation and fall
//!   detection.
//!
//! `no_std`, no allocation, generic over `f32` and `f64`.

pub mod balance;
pub mod config;
pub mod lqr;
pub mod planar;
pub mod signals;

pub use balance::{BalanceController, PlaneDesign};
pub use config::{BalanceConfig, BalanceError, PRESET_TORQUE_LIMIT, Weights, validate_plant};
pub use planar::{PlanarModel, Plane, PlantParams};
pub use signals::{
    BalanceCommand, BalanceOutput, BalanceState, Lean, Measurement, ball_velocity_from_wheels,
};
