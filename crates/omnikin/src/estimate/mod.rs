//! # State estimation: where the robot is and how it is oriented
//!
//! Everything that turns sensor readings into a state estimate, no allocation, no panic:
//!
//! | module | in | out |
//! |---|---|---|
//! | [`odometry`] | cumulative encoder angles (+ gyro or yaw) | world pose by exact SE(2) steps; caster slip residual, sphere shell spin |
//! | [`ahrs`] | gyro + accelerometer + magnetometer | attitude and gyro bias (Mahony's complementary filter) |
//! | [`fix`] | a camera or motion-capture pose, stamped with the time it was taken | the measurement and the χ² gate that accepts or rejects it |
//! | [`noise`] | an odometry step | the variance it adds (distance, turn and time random walks) |
//! | [`events`] | odometry steps + IMU yaw rate | slip and collision events (one per episode) and their counters |
//! | [`fusion`] | odometry steps (+ heading source) + delayed fixes | pose, gyro bias, wheel scale and covariance; history sized by time, gate recovery, start from the first fix |
//!
//! The runtime ([`crate::runtime`]) runs odometry every cycle; the AHRS and the pose filter
//! are for hosts and firmware that have those sensors.

pub mod ahrs;
pub mod events;
pub mod fix;
pub mod fusion;
pub mod noise;
pub mod odometry;
mod posterior;
