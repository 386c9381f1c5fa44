//! Dynamic plants: rigid-body models with the robot's masses, inertias, motor limits and floor
//! friction, integrated in time, for the effects a kinematic plant cannot show (platform lean,
//! rocking, shell spin at starts).
//!
//! * [`sphere`]: paper 000's spherical robot — shell on the floor, internal platform on three
//!   omni-wheels driven by steppers, floor pivot friction and rolling resistance.

pub mod sphere;
