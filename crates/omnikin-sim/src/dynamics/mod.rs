//! Rigid-body dynamic models of the robots, for closed-loop simulation (the kinematic plant of
//! [`crate::plant_step`] follows wheel rates exactly; these models say what torques do).
//!
//! * [`ballbot`]: the 3D nonlinear ballbot (ball rolling on the floor, body pendulum on the
//!   ball, three omni-wheels) and its three planar models (paper 001).
pub mod ballbot;
