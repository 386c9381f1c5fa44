//! # omnikin-plan — from a path to time-stamped wheel commands
//!
//! The planning layer of omnikin (paper 000, §5–6): a planned trajectory `r_C(t)` with a
//! heading law `ψ(t)` is turned into wheel rates through the core kinematics, sample by
//! sample, within the motor limits of the robot file. Units are SI (m, s, rad); positions,
//! velocities and headings are in the world frame (REP-103: x, y on the floor, counter-clockwise
//! positive), as in the project conventions.
//!
//! | module | what |
//! |---|---|
//! | [`path`] | arc-length parametrised paths: polylines (stops or fillets), arcs, circles, quintic splines |
//! | [`heading`] | heading laws: constant, tangent to the motion (paper 000, eq. 5.5), a profile along the path |
//! | [`profile`] | rest-to-rest 1-D velocity profiles: trapezoid and S-curve |
//! | [`planner`] | timing under motor limits (re-timing, time-optimal forward–backward pass) and sampling |
//! | [`generators`] | paper 000's experiments: the square (eq. 6.1) and the circle (eq. 6.3) |
//! | [`map`] | maps (keep-out circles and polygons, keep-in polygon), the footprint, the shortest collision-free route and its smoothing |
//! | [`limits`] | the stated limits: most samples, grid cells and waypoints, and the plausible range of every physical parameter |
//! | [`splice`] | re-planning on the move: a plan from a running plan's reference at a splice time to a new goal, which the runtime takes over without a stop |
//! | [`steer_steps`] | a plan's steer-angle steps that its steer rates do not explain (a re-steer at rest between two samples) |
//! | [`tilt`] | a sphere's quasi-static platform tilt along a plan, and slowing the moves that exceed a limit |
//! | [`waypoints`] | waypoint files (CSV or TOML) with `file:line` errors |
//! | [`csv_number`] | how a number is written into the CSV files: shortest round-trip digits, an exponent for tiny or huge magnitudes ([`CsvFloat`]) |
//! | [`Plan`] / [`Sample`] | the sampled plan and its CSV/JSON format (conventions.md: `t,x,y,heading,vx,vy,yaw_rate,w1..wN`, steerable kinds adding `s1..sN,sd1..sdN`) |
//!
//! ```
//! use omnikin::description::RobotDescription;
//! use omnikin_plan::generators::Square;
//! use omnikin_plan::planner::{plan, OnLimit};
//! use omnikin_plan::RobotModel;
//!
//! let robot = RobotModel::from_description(&RobotDescription::preset("sphere-omni").unwrap())?;
//! // Paper 000's square at 0.1 m/s (k = 1): four 4 s legs plus 5 % ramps.
//! let sq = Square::paper(1.0);
//! let planned = plan(&sq.path()?, &sq.heading(), &robot, &sq.options(100.0, OnLimit::Retime))?;
//! assert!((planned.report.duration - 4.0 * 4.2).abs() < 1e-9);
//! let peak = planned.report.peaks[0]; // wheel rate
//! assert!(peak.value <= 12.0);
//! # Ok::<(), omnikin_plan::PlanningError>(())
//! ```
#![warn(missing_docs)]

mod error;
mod plan;

pub mod csv_number;
pub mod generators;
pub mod heading;
pub mod lean;
pub mod limits;
pub mod map;
pub mod path;
pub mod planner;
pub mod profile;
pub mod robot;
pub mod splice;
pub mod steer_steps;
pub mod tilt;
pub mod waypoints;

pub use csv_number::CsvFloat;
pub use error::{PlanningError, Violation};
pub use plan::{COLUMNS, Plan, PlanError, Sample, per_wheel, wheel_columns};
pub use robot::{MAX_CHANNELS, Quantity, RobotModel};
