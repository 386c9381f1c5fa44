//! # omnikin-sim — simulate and evaluate motion the way paper 000 evaluated its robot
//!
//! Paper 000 ran each trajectory three times, tracked the robot on video and compared the mean
//! trajectory (with a 95 % confidence band) to the theoretical one; paper 003 §4 explains how
//! imperfect motor speeds and acceleration phases make wheels slip. This crate does the same
//! in simulation, and on real tracked data:
//!
//! * [`profile`]: which disturbances to simulate (TOML): stepper quantisation, motor lag and
//!   acceleration limits (ramp phases), speed fluctuation, wheel-radius errors, shell spin
//!   (random and speed-dependent), roller hand-over, floor slip, tracking offset and noise.
//! * [`plant_step`]: the one plant step — the motors' actual motion through the forward
//!   kinematics (with the shell/ball spin law) and floor slip, integrated exactly on SE(2);
//!   shared by the simulator and software in the loop.
//! * [`simulate_trial`]: the open-loop simulator — a plan's motor set-points through the motor
//!   models and the plant step.
//! * [`dynamics`]: dynamic plants — the sphere's shell + platform with floor friction, and the
//!   3D ballbot with its planar models and the balance controller on it.
//! * [`dynamic_run`]: one plan through the dynamic plant of a sphere or a ballbot, evaluated,
//!   with `metrics.json` (`simulate --plant dynamic`).
//! * [`sil`]: software in the loop — the same plant as a board for the robot runtime.
//! * [`run_trials`]: seeded parallel Monte Carlo; trial `i` draws from its own ChaCha8 stream,
//!   so results do not depend on the number of threads.
//! * [`shard`]: one run split into shards `K/N` by trial (any process or machine), and the
//!   runs each shard keeps read back so a merge gives one run's figures bit for bit
//!   ([`simulate_range`], [`evaluate_runs`]).
//! * [`metrics`]: deviation from the planned path (m and % of path), end-point and heading
//!   errors, mean trajectory with a Student-t 95 % band, fitted circle and radius ratio,
//!   repeatability.
//! * [`odometry`]: wheel odometry over a recorded encoder log, fused with delayed camera fixes
//!   (the pipeline of `omnikin odometry`, on in-memory tables).
//! * [`pose_error`]: an estimate scored against ground truth — absolute trajectory error and
//!   relative pose error (Sturm et al. 2012, the TUM RGB-D benchmark), `omnikin evaluate --truth`.
//! * [`limits`]: the stated limits — most plant steps per trial, rows of a track file — and the plausible range of every profile parameter.
//! * [`reproduce`]: paper 000's whole experiment design re-run under three kinematic profiles and the dynamic one, with a
//!   table of our figures next to the paper's.
//! * [`identify`]: a robot's wheel geometry and gyro bias/scale fitted to recorded runs by
//!   non-linear least squares, with 1σ and an observability test (`omnikin identify`).
//! * [`check`]: what `omnikin check` says about a robot file (geometry, footprint, reach,
//!   balance controller, tilt feedback margins, limits), as text and JSON.
//! * [`run_columns`]: the columns of `trials.csv` and `mean.csv`, for every front end.
//! * [`track`]: real tracked runs (`t,x,y[,heading]` CSV), aligned to a plan's start of motion
//!   and resampled onto its time grid, so the same metrics apply to hardware experiments.
#![warn(missing_docs)]

pub mod camera;
pub mod check;
pub mod closed_loop;
pub mod dynamic_run;
pub mod dynamics;
pub mod identify;
pub mod limits;
pub mod metrics;
mod monte_carlo;
mod motor;
pub mod odometry;
mod path_index;
mod plant;
pub mod plant_step;
pub mod pose_error;
pub mod profile;
pub mod reproduce;
pub mod run_columns;
pub mod sensors;
pub mod shard;
pub mod sil;
pub mod table;
pub mod track;

pub use monte_carlo::{
    FIGURE_RUNS, MonteCarlo, MonteCarloError, RETAIN_LIMIT_BYTES, evaluate_runs, evaluate_trials,
    run_trials, second_pass_resimulates, simulate_and_evaluate, simulate_range, trial_rng,
    trial_run,
};
pub use plant::{SimError, Trial, plan_mismatch, simulate_trial};
pub use profile::Profile;
