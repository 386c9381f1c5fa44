//! # omnikin-plan — from a path to time-stamped wheel commands
//!
//! The planning layer of omnikin (paper 000, §5–6): a planned trajectory `r_C(t)` with a
//! heading law is turned into wheel rates through the core kinematics, sample by sample.
//!
//! * [`Plan`] / [`Sample`]: a sampled plan and its CSV/JSON file format (conventions.md:
//!   `t,x,y,heading,vx,vy,yaw_rate,w1,w2,w3`, the caster adding `s1,s2,s3,sd1,sd2,sd3`),
//!   read back with line-numbered validation.
#![warn(missing_docs)]

mod plan;

pub use plan::{Plan, PlanError, Sample};
