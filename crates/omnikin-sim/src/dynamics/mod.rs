//! Dynamic plants: rigid-body models with the robot's masses, inertias, motor limits and floor
//! friction, integrated in time, for what a kinematic plant (which follows the wheel rates
//! exactly, [`crate::plant_step`]) cannot show: platform lean, rocking and shell spin at starts
//! of the sphere, and what torques do to a ballbot that must be balanced.
//!
//! * [`sphere`]: paper 000's spherical robot — shell on the floor, internal platform on three
//!   omni-wheels driven by steppers, floor pivot friction and rolling resistance.
//! * [`ballbot`]: the 3D nonlinear ballbot (ball rolling on the floor, body pendulum on the
//!   ball, three omni-wheels) and its three planar models (paper 001).

pub mod ballbot;
pub mod sphere;
