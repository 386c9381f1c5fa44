//! The planner: path + heading law + timing → a sampled [`Plan`] of wheel commands that
//! respects the robot's motor limits (paper 000, §5: `r_C(t)`, `ψ(t)` → wheel rates by
//! eqs. 5.6–5.7; likewise for the ballbot, paper 001, and the caster base, paper 003, eq. 2).
//!
//! # How a plan is made
//!
//! 1. **Moves.** The path is cut into *moves* that start and end at rest: at its stops
//!    ([`crate::path::Corners::Stop`]) and wherever the wheel rates per unit speed jump (the
//!    tangent or the heading rate `dψ/ds` jumps — e.g. where a fillet meets a leg under the
//!    tangent heading law); a jump in wheel rate at non-zero speed would need infinite wheel
//!    acceleration. Under the tangent law (paper 000, eq. 5.5) a stop where the direction
//!    changes gets a **turn in place** from the old to the new direction.
//! 2. **Geometry along a move.** Each move has a parameter `σ` (arc length `s` in m, or the
//!    turned angle in rad for a turn in place) and a configuration `q(σ) = (x, y, ψ)`. Because
//!    every robot's motor rates are linear in the world twist `q̇ = q'(σ) σ̇`, they are
//!    `w(σ, σ̇) = A(σ) σ̇` with `A(σ)` the core inverse kinematics applied to `q'(σ)`
//!    (including the heading-rate term `ψ' = dψ/ds`), and the motor accelerations are
//!    `ẇ = A(σ) σ̈ + A'(σ) σ̇²`. `A` is tabulated on an **adaptive grid** of `σ`: a node at
//!    every join of the path's pieces (where `A'` may jump, e.g. the curvature's derivative
//!    at a spline waypoint; `A'` is taken one-sided there) and equal cells between joins,
//!    5 cm (50 mrad for turns; a fifth of the eccentricity for the caster) refined where the
//!    linear interpolation of `A` or `A'` between nodes would be off by more than 1 % of that
//!    motor's largest value on the move, down to 2 mm. For the caster the steer angles `γ(σ)` obey `dγ/dσ = J2(θ, γ) q'(σ)` (paper 003, eq. 5), which
//!    does not depend on the timing, so they are integrated once along the grid (RK4).
//! 3. **Timing**, one of [`Timing`]:
//!    * [`Timing::Profile`]: a trapezoidal or S-curve profile per move with the requested
//!      speed, acceleration and jerk. If a motor would exceed its limit the move is slowed by a
//!      uniform **time dilation** `σ_λ(t) = σ(λt)`: rates scale with `λ`, accelerations with
//!      `λ²`, so `λ = min(1, limit_rate/peak_rate, √(limit_accel/peak_accel))` (the ramps keep
//!      their share of the move's time). [`OnLimit::Reject`] refuses instead.
//!    * [`Timing::ConstantSpeed`]: constant speed from start to end (paper 000's circle law,
//!      eq. 6.3, which starts at full speed); slowed or rejected like a profile.
//!    * [`Timing::TimeOptimal`]: the fastest timing within all limits, by a
//!      **backward reachability pass and a greedy forward pass** over the path parameter on
//!      `x = σ̇²` (time-optimal path parameterisation by reachability analysis, as in Pham &
//!      Pham, "TOPP-RA", IEEE T-RO 2018). On each grid cell `σ̈ = (x_{k+1} − x_k)/(2h)` is
//!      constant, and every acceleration limit (the requested path acceleration and each
//!      motor's `|A_i σ̈ + A_i' x| ≤ limit`, at both ends of the cell) is linear in the two end
//!      values: a convex polygon. Speed caps: `x ≤ v_max²` and `x ≤ (limit_rate_i/|A_i|)²`
//!      (the wheel-rate cap `v_max(s) = max_rate / max_i |∂w_i/∂v(s)|`, with `|A_i|` raised by
//!      its estimated bulge between nodes). The backward pass finds, from rest at the end,
//!      the largest `x_k` from which the end is still reachable (the largest start of the
//!      cell's polygon whose end is reachable); the forward pass then accelerates from rest as
//!      hard as the cell allows without leaving the reachable set. No step can get stuck, and
//!      the joint limits of all motors are respected at every node. Jerk is not limited in
//!      this mode.
//! 4. **Sampling** at the requested rate: pose, world twist, motor rates from the core
//!    inverse kinematics (sphere: `SphereOmni::wheel_rates_world`, ballbot:
//!    `Ballbot::wheel_rates_world`, caster: `Caster3::motor_rates`). Finally every sample is
//!    checked against the limits (rates at each sample, accelerations as differences between
//!    consecutive samples); a residual excess from the grid approximation is removed by slowing
//!    the offending move further.

use omnikin::{Pose2, Robot, Twist2, wrap_angle};

use crate::PlanningError;
use crate::error::Violation;
use crate::heading::{HeadingLaw, Side};
use crate::limits::{
    MAX_MOVE_GRID_CELLS, MAX_PLAN_GRID_CELLS, MAX_PLAN_SAMPLES, RATE_RANGE, SPEED_RANGE,
    check_range,
};
use crate::path::Path;
use crate::plan::{Plan, Sample};
use crate::profile::{Profile1D, ProfileKind};
use crate::robot::{Quantity, RobotModel};

/// Requested limits of the motion itself (not the motors'): along the path, and for turns in
/// place.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionLimits {
    /// Largest speed along the path, m/s.
    pub max_speed: f64,
    /// Largest tangential acceleration along the path, m/s².
    pub max_accel: f64,
    /// Largest jerk along the path, m/s³ (S-curve profiles only).
    pub max_jerk: f64,
    /// Largest yaw rate of a turn in place, rad/s.
    pub max_yaw_rate: f64,
    /// Largest yaw acceleration of a turn in place, rad/s² (an S-curve turn uses the jerk
    /// `max_yaw_accel · max_jerk / max_accel`, so its ramps take as long as the path's).
    pub max_yaw_accel: f64,
}

impl Default for MotionLimits {
    /// 0.2 m/s, 0.5 m/s², 5 m/s³; turns in place 1 rad/s, 2 rad/s².
    fn default() -> Self {
        Self {
            max_speed: 0.2,
            max_accel: 0.5,
            max_jerk: 5.0,
            max_yaw_rate: 1.0,
            max_yaw_accel: 2.0,
        }
    }
}

impl MotionLimits {
    /// Checks every limit against its range in [`crate::limits`].
    fn validate(&self, jerk: bool) -> Result<(), PlanningError> {
        use crate::limits::{
            ACCEL_RANGE, JERK_RANGE, SPEED_RANGE, YAW_ACCEL_RANGE, YAW_RATE_RANGE,
        };
        check_range("max speed", self.max_speed, SPEED_RANGE, "m/s")?;
        check_range("max acceleration", self.max_accel, ACCEL_RANGE, "m/s²")?;
        check_range("max yaw rate", self.max_yaw_rate, YAW_RATE_RANGE, "rad/s")?;
        check_range(
            "max yaw acceleration",
            self.max_yaw_accel,
            YAW_ACCEL_RANGE,
            "rad/s²",
        )?;
        if jerk {
            check_range("max jerk", self.max_jerk, JERK_RANGE, "m/s³")?;
        }
        Ok(())
    }
}

/// How the planner times the path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Timing {
    /// A trapezoidal or S-curve profile per move (rest to rest) within `limits`; slowed
    /// uniformly (time dilation) where a motor limit would be exceeded.
    Profile {
        /// Trapezoid or S-curve.
        kind: ProfileKind,
        /// Speed, acceleration and jerk limits of the motion.
        limits: MotionLimits,
    },
    /// The fastest timing that respects `limits` and every motor limit (forward–backward pass;
    /// jerk not limited).
    TimeOptimal {
        /// Speed and acceleration limits of the motion.
        limits: MotionLimits,
    },
    /// Constant speed `speed` (m/s) from the first sample to the last, no ramps — paper 000's
    /// circle law (eq. 6.3), which starts at full speed. Only for paths without stops.
    ConstantSpeed {
        /// Speed along the path, m/s.
        speed: f64,
    },
}

/// What to do when a requested (non-optimal) timing would exceed a motor limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OnLimit {
    /// Slow the offending moves down until every limit holds, and report it.
    Retime,
    /// Refuse with [`PlanningError::LimitExceeded`] naming the motor, the rate, the time and
    /// the excess.
    Reject,
}

/// Initial steer angles of a caster base (ignored for other robots).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InitialSteer {
    /// Given steer angles `γ_i`, rad.
    Given([f64; 3]),
    /// The configuration the first motion needs: each wheel trails its steering axis so its
    /// steer rate is zero at the start. Wheel `i`'s steering axis `F_i` moves with
    /// `v_F = (ẋ, ẏ) + θ̇ k × D(cos(α_i+θ), sin(α_i+θ))` (direction `χ`); the steer rate
    /// (paper 003, eq. 3) vanishes for `sin(β_i − χ) = θ̇ d/|v_F|`, which has two solutions.
    /// The planner takes the **trailing** one, `β_i = χ + π − asin(θ̇ d/|v_F|)` (for a pure
    /// translation `β_i = χ + π`, a roll rate `φ̇ = v/r > 0`), because it is the stable
    /// equilibrium of `dγ/ds`: a leading wheel (`β_i = χ`) would need ever larger steer rates
    /// to follow any curve (errors grow like `e^{s/d}`), as a shopping-cart caster flips round.
    /// `γ_i = β_i − α_i − θ` is wrapped into (−π, π].
    Aligned,
}

/// Everything the planner needs besides the path, heading law and robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanOptions {
    /// The timing law.
    pub timing: Timing,
    /// Re-time or reject when a motor limit would be exceeded (not used by
    /// [`Timing::TimeOptimal`], which never exceeds one).
    pub on_limit: OnLimit,
    /// Sampling rate of the output, Hz (samples at `k / rate`, plus the exact end time).
    pub rate: f64,
    /// Caster only: initial steer angles.
    pub initial_steer: InitialSteer,
}

/// What limited the timing of (part of) a plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Limiter {
    /// The requested speed along the path.
    MaxSpeed,
    /// The requested acceleration along the path.
    MaxAccel,
    /// The requested yaw rate of a turn in place.
    MaxYawRate,
    /// The requested yaw acceleration of a turn in place.
    MaxYawAccel,
    /// A constant speed fixed by the request (paper 000's circle law).
    RequestedSpeed,
    /// A motor limit of the robot file.
    Motor {
        /// Which limit.
        quantity: Quantity,
        /// Motor number, 1-based.
        motor: usize,
    },
}

impl std::fmt::Display for Limiter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Limiter::MaxSpeed => write!(f, "max speed"),
            Limiter::MaxAccel => write!(f, "max acceleration"),
            Limiter::MaxYawRate => write!(f, "max yaw rate (turn in place)"),
            Limiter::MaxYawAccel => write!(f, "max yaw acceleration (turn in place)"),
            Limiter::RequestedSpeed => write!(f, "requested speed"),
            Limiter::Motor { quantity, motor } => {
                write!(
                    f,
                    "limits.{} ({} {motor})",
                    quantity.key(),
                    quantity.motor()
                )
            }
        }
    }
}

/// The peak of one motor quantity over a plan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Peak {
    /// Which quantity.
    pub quantity: Quantity,
    /// Motor number (1-based) where the peak is.
    pub motor: usize,
    /// Peak magnitude (rad/s or rad/s²; accelerations are differences between consecutive
    /// samples divided by their time step).
    pub value: f64,
    /// Time of the peak, s.
    pub t: f64,
    /// The robot file's limit, if any.
    pub limit: Option<f64>,
}

/// A move slowed down because of a motor limit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Retiming {
    /// Index of the move (0-based, in order).
    pub move_index: usize,
    /// Time-dilation factor `λ ≤ 1` (the move takes `1/λ` times as long).
    pub factor: f64,
    /// The limit that set it.
    pub limiter: Limiter,
}

/// What a move does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MoveKind {
    /// Travel along the path from arc length `s0` to `s1`, m.
    Travel {
        /// Start arc length, m.
        s0: f64,
        /// End arc length, m.
        s1: f64,
    },
    /// Turn in place by `angle` rad (tangent heading law at a stop).
    Turn {
        /// Signed angle, rad.
        angle: f64,
    },
}

/// One move of a plan: what it does, when, and how fast.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoveSummary {
    /// What it does.
    pub kind: MoveKind,
    /// Start time, s.
    pub t0: f64,
    /// Duration, s.
    pub duration: f64,
    /// Peak speed along the path (m/s) or yaw rate of a turn (rad/s).
    pub peak_speed: f64,
}

/// How a plan came out: duration, length, peaks against limits, what limited the timing.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanReport {
    /// Duration, s.
    pub duration: f64,
    /// Path length, m.
    pub path_length: f64,
    /// The moves, in order.
    pub moves: Vec<MoveSummary>,
    /// Peak of every limited-or-not motor quantity (wheel rate and acceleration; the caster adds
    /// steer rate and acceleration).
    pub peaks: Vec<Peak>,
    /// Moves slowed down because of a motor limit ([`Timing::Profile`] /
    /// [`Timing::ConstantSpeed`] with [`OnLimit::Retime`]).
    pub retimed: Vec<Retiming>,
    /// What limited the speed, with the share of the plan's time (0–1) it was active
    /// (sorted, largest first).
    pub active: Vec<(Limiter, f64)>,
    /// `true` when the plan starts at non-zero speed (paper 000's circle law): the robot must
    /// already move as the first sample says.
    pub starts_moving: bool,
}

/// A plan and its report.
#[derive(Clone, Debug, PartialEq)]
pub struct Planned {
    /// The sampled plan (conventions' columns).
    pub plan: Plan,
    /// Summary for people.
    pub report: PlanReport,
}

/// Finest grid step in the move parameter (m or rad).
const GRID_MIN: f64 = 2e-3;
/// Coarsest grid step in the move parameter (m or rad).
const GRID_MAX: f64 = 0.05;
/// Largest linear-interpolation error of the motor rates per unit speed `A(σ)` between grid
/// nodes, relative to the motor's largest `|A|` on the move.
const GRID_TOL: f64 = 1e-2;
/// Fewest grid cells per move.
const MIN_CELLS: usize = 16;
/// The planner aims this fraction below each motor limit, so the final check on the samples
/// (which is strict) passes despite the grid approximation.
const MARGIN: f64 = 1.0 - 1e-4;

/// Configuration and its derivative with respect to the move parameter.
#[derive(Clone, Copy, Debug)]
struct Config {
    pose: Pose2<f64>,
    /// `(cos ψ, sin ψ)` of the heading (from the tangent for the tangent law, so the grid needs
    /// no trigonometry).
    cs: [f64; 2],
    /// `q'(σ) = (dx/dσ, dy/dσ, dψ/dσ)`.
    dq: [f64; 3],
}

#[derive(Clone, Debug)]
enum MoveTiming {
    Profile {
        p: Profile1D,
        lambda: f64,
    },
    Constant {
        v: f64,
    },
    /// `x = σ̇²` and times at the move's grid nodes (`Move::sig`).
    Grid {
        x: Vec<f64>,
        t: Vec<f64>,
    },
}

impl MoveTiming {
    fn duration(&self, len: f64) -> f64 {
        match self {
            MoveTiming::Profile { p, lambda } => p.duration() / lambda,
            MoveTiming::Constant { v } => len / v,
            MoveTiming::Grid { t, .. } => *t.last().unwrap_or(&0.0),
        }
    }

    /// `(σ, σ̇, σ̈)` at time `t` into the move whose grid nodes are `sig`; `from` is the grid
    /// cell of the previous call (for times that mostly increase) and is updated.
    fn eval(&self, t: f64, len: f64, sig: &[f64], from: &mut usize) -> (f64, f64, f64) {
        match self {
            MoveTiming::Profile { p, lambda } => {
                let (s, v, a) = p.eval(lambda * t);
                (s, lambda * v, lambda * lambda * a)
            }
            MoveTiming::Constant { v } => ((v * t).clamp(0.0, len), *v, 0.0),
            MoveTiming::Grid { x, t: times } => {
                let n = x.len() - 1;
                let k = if t.is_nan() {
                    n.saturating_sub(1)
                } else {
                    cell_from(times, t, *from)
                };
                *from = k;
                let u = (x[k + 1] - x[k]) / (2.0 * (sig[k + 1] - sig[k]));
                let v0 = x[k].max(0.0).sqrt();
                let tau = (t - times[k]).clamp(0.0, times[k + 1] - times[k]);
                let s = (sig[k] + v0 * tau + 0.5 * u * tau * tau).clamp(0.0, len);
                ((s).min(len), (v0 + u * tau).max(0.0), u)
            }
        }
    }
}

#[derive(Clone, Debug)]
enum Kind {
    Travel { s0: f64, s1: f64 },
    Turn { x: f64, y: f64, psi0: f64, dir: f64 },
}

/// A move with its grid: node parameters, heading (unwrapped), `A`, `A'` and the caster's
/// steer angles.
#[derive(Clone, Debug)]
struct Move {
    kind: Kind,
    len: f64,
    sig: Vec<f64>,
    psi: Vec<f64>,
    /// `(cos ψ, sin ψ)` at each node (the heading hint of the samples in its cell).
    cs: Vec<[f64; 2]>,
    a: Vec<[f64; 6]>,
    /// `A'` at each node as seen from the cell that ends there (one-sided at a kink).
    b_in: Vec<[f64; 6]>,
    /// `A'` at each node as seen from the cell that starts there (one-sided at a kink).
    b_out: Vec<[f64; 6]>,
    gamma: Vec<[f64; 3]>,
    timing: MoveTiming,
    t0: f64,
    /// Factor (≤ 1) on the motor limits the time-optimal pass aims at, lowered when the final
    /// check on the samples finds a residual excess.
    limit_scale: f64,
}

struct Ctx<'a> {
    path: &'a Path,
    heading: &'a HeadingLaw,
    robot: &'a RobotModel,
    /// `(cos, sin)` of the tangent law's offset, or of the constant heading.
    heading_cs: [f64; 2],
}

/// An unwrapped heading `ψ` (rad) near the one sought, with `(cos ψ, sin ψ)` when known.
#[derive(Clone, Copy, Debug)]
struct Hint {
    psi: f64,
    cs: Option<[f64; 2]>,
}

impl Hint {
    fn angle(psi: f64) -> Self {
        Self { psi, cs: None }
    }

    fn of(c: &Config) -> Self {
        Self {
            psi: c.pose.heading,
            cs: Some(c.cs),
        }
    }

    /// The unwrapped angle of the unit vector `dir` within ±π of the hint: from the angle
    /// between the two, `δ = 2 atan(t)`, `t = (h × d)/(1 + h·d)`, by its series when it is
    /// below 0.1 rad (`|t| < 0.05`: the terms to `t¹¹` leave < 1e-18), as between neighbouring
    /// grid nodes; by `atan2` otherwise.
    fn unwrap(self, dir: [f64; 2]) -> f64 {
        if let Some([c, s]) = self.cs {
            let dot = c * dir[0] + s * dir[1];
            if dot > 0.995 {
                let t = (c * dir[1] - s * dir[0]) / (1.0 + dot);
                let t2 = t * t;
                let atan = t
                    * (1.0
                        - t2 * (1.0 / 3.0
                            - t2 * (1.0 / 5.0
                                - t2 * (1.0 / 7.0 - t2 * (1.0 / 9.0 - t2 * (1.0 / 11.0))))));
                return self.psi + 2.0 * atan;
            }
        }
        self.psi + wrap_angle(dir[1].atan2(dir[0]) - self.psi)
    }
}

impl Ctx<'_> {
    /// Configuration at parameter `sigma` of a move; `hint` is an unwrapped heading within
    /// ±π of the answer (for the tangent law).
    fn config(&self, kind: &Kind, len: f64, sigma: f64, hint: Hint) -> Config {
        match *kind {
            Kind::Travel { s0, s1 } => {
                // The end is evaluated exactly at `s1` on the incoming side (`s0 + len` can
                // round past a join and pick the next piece's direction).
                let s = s0 + sigma.max(0.0);
                let (s, side) = if sigma >= len || s >= s1 {
                    (s1, Side::Before)
                } else {
                    (s, Side::After)
                };
                let p = self.path.at_side(s, side);
                let (psi, cs, dpsi) = match self.heading {
                    HeadingLaw::Constant(c) => (*c, self.heading_cs, 0.0),
                    HeadingLaw::Tangent { .. } => {
                        let [c, s] = self.heading_cs;
                        let [tx, ty] = p.tangent;
                        let d = [c * tx - s * ty, s * tx + c * ty];
                        (hint.unwrap(d), d, p.curvature)
                    }
                    HeadingLaw::Profile(prof) => {
                        let (psi, dpsi) = prof.at(s, side);
                        let (s, c) = psi.sin_cos();
                        (psi, [c, s], dpsi)
                    }
                };
                Config {
                    pose: Pose2::new(p.point[0], p.point[1], psi),
                    cs,
                    dq: [p.tangent[0], p.tangent[1], dpsi],
                }
            }
            Kind::Turn { x, y, psi0, dir } => {
                let psi = psi0 + dir * sigma.clamp(0.0, len);
                let (s, c) = psi.sin_cos();
                Config {
                    pose: Pose2::new(x, y, psi),
                    cs: [c, s],
                    dq: [0.0, 0.0, dir],
                }
            }
        }
    }

    /// Motor rates per unit `σ̇` (the columns `A(σ)`), and `dγ/dσ` for the caster.
    fn rates_per_speed(&self, c: &Config, gamma: [f64; 3]) -> Result<[f64; 6], PlanningError> {
        self.robot.channel_rates_cs(
            c.pose.heading,
            c.cs,
            Twist2::new(c.dq[0], c.dq[1], c.dq[2]),
            gamma,
        )
    }

    /// One RK4 step of `dγ/dσ = J2(θ, γ) q'(σ)` from `(sigma, gamma)` by `step`.
    fn steer_step(
        &self,
        kind: &Kind,
        len: f64,
        sigma: f64,
        gamma: [f64; 3],
        step: f64,
        hint: Hint,
    ) -> Result<[f64; 3], PlanningError> {
        if !self.robot.is_caster() || step == 0.0 {
            return Ok(gamma);
        }
        let f = |s: f64, g: [f64; 3]| -> Result<[f64; 3], PlanningError> {
            let c = self.config(kind, len, s, hint);
            let r = self.rates_per_speed(&c, g)?;
            Ok([r[3], r[4], r[5]])
        };
        let add =
            |g: [f64; 3], k: [f64; 3], f: f64| [g[0] + f * k[0], g[1] + f * k[1], g[2] + f * k[2]];
        let k1 = f(sigma, gamma)?;
        let k2 = f(sigma + step / 2.0, add(gamma, k1, step / 2.0))?;
        let k3 = f(sigma + step / 2.0, add(gamma, k2, step / 2.0))?;
        let k4 = f(sigma + step, add(gamma, k3, step))?;
        Ok(core::array::from_fn(|i| {
            gamma[i] + step / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        }))
    }

    /// Builds a move's grid starting from heading `psi_start` and steer angles `gamma0`. The
    /// grid has a node at every kink `kinks` (σ where `A'` may jump: the joins of the path's
    /// pieces) and, between kinks, equal cells of at most `step`, refined (once, by the factor
    /// the error estimate asks for) until the linear interpolation of every motor's `A(σ)`
    /// between nodes is within [`GRID_TOL`] of that motor's largest `|A|` on the move, or the
    /// cells are [`GRID_MIN`].
    fn build_move(
        &self,
        kind: Kind,
        len: f64,
        psi_start: f64,
        gamma0: [f64; 3],
        step: f64,
        kinks: &[f64],
    ) -> Result<Move, PlanningError> {
        // Stretches between kinks, each with its number of cells.
        let mut bounds = vec![0.0];
        bounds.extend(
            kinks
                .iter()
                .copied()
                .filter(|&k| k > 1e-9 && k < len - 1e-9),
        );
        bounds.push(len);
        let cells = |l: f64, h: f64| ((l / h).ceil() as usize).max(1);
        let too_many_cells = |n: &[usize]| {
            let needed = n.iter().sum::<usize>();
            if needed > MAX_MOVE_GRID_CELLS {
                return Err(PlanningError::TooLarge {
                    what: format!("a move of length {len:.4e} (m or rad)"),
                    items: "grid cells",
                    needed: needed as f64,
                    limit: "MAX_MOVE_GRID_CELLS",
                    max: MAX_MOVE_GRID_CELLS,
                    hint: "shorten the path (--side, --radius, --turns, the waypoints) or cut it \
                           into several plans",
                });
            }
            Ok(())
        };
        let mut n: Vec<usize> = bounds
            .windows(2)
            .map(|w| cells(w[1] - w[0], step))
            .collect();
        let total: usize = n.iter().sum();
        if total < MIN_CELLS {
            let f = MIN_CELLS.div_ceil(total);
            n.iter_mut().for_each(|c| *c *= f);
        }
        too_many_cells(&n)?;
        // Each stretch starts from the end state (heading, steer angles) of the one before.
        let caster = self.robot.is_caster();
        let mut parts: Vec<Stretch> = Vec::with_capacity(n.len());
        for j in 0..n.len() {
            let (psi0, g0) = parts
                .last()
                .map_or((psi_start, gamma0), |p: &Stretch| p.end());
            parts.push(self.stretch(&kind, len, bounds[j], bounds[j + 1], n[j], psi0, g0)?);
        }
        // Refine the stretches whose interpolation error is too large, rebuilding only them (and,
        // for the caster, whose steer angles carry over, every stretch after the first rebuilt).
        let chans = self.robot.channels();
        // Each stretch's largest |A| and |A'|, recomputed only when it is rebuilt.
        let mut scales: Vec<[[f64; 6]; 2]> = parts.iter().map(|p| p.scale(chans)).collect();
        for _ in 0..8 {
            let mut scale = [[0.0_f64; 6]; 2];
            for ps in &scales {
                for i in 0..2 {
                    for ch in 0..chans {
                        scale[i][ch] = scale[i][ch].max(ps[i][ch]);
                    }
                }
            }
            let mut dirty = false;
            for j in 0..parts.len() {
                let c = n[j];
                let h = (bounds[j + 1] - bounds[j]) / c as f64;
                let err = parts[j].error(&scale, chans);
                let refine = err > GRID_TOL && h > GRID_MIN;
                if refine {
                    // Linear interpolation error scales with h²; aim at half the tolerance.
                    let f = (err / (0.5 * GRID_TOL)).sqrt().min(1e3);
                    let want = ((c as f64 * f).ceil() as usize).max(c + 1);
                    n[j] = want.min(cells(bounds[j + 1] - bounds[j], GRID_MIN).max(c));
                }
                if refine || (caster && dirty) {
                    let (psi0, g0) = if j == 0 {
                        (psi_start, gamma0)
                    } else {
                        parts[j - 1].end()
                    };
                    parts[j] =
                        self.stretch(&kind, len, bounds[j], bounds[j + 1], n[j], psi0, g0)?;
                    scales[j] = parts[j].scale(chans);
                    dirty = true;
                }
            }
            if !dirty {
                break;
            }
            too_many_cells(&n)?;
        }
        let total: usize = n.iter().sum();
        let mut sig = Vec::with_capacity(total + 1);
        let mut psi = Vec::with_capacity(total + 1);
        let mut cs = Vec::with_capacity(total + 1);
        let mut a = Vec::with_capacity(total + 1);
        let mut gamma = Vec::with_capacity(total + 1);
        for (j, p) in parts.iter().enumerate() {
            let skip = usize::from(j > 0);
            sig.extend_from_slice(&p.sig[skip..]);
            psi.extend_from_slice(&p.psi[skip..]);
            cs.extend_from_slice(&p.cs[skip..]);
            a.extend_from_slice(&p.a[skip..]);
            gamma.extend_from_slice(&p.gamma[skip..]);
        }
        let (b_in, b_out) = derivative(&a, &sig, &n);
        Ok(Move {
            kind,
            len,
            sig,
            psi,
            cs,
            a,
            b_in,
            b_out,
            gamma,
            timing: MoveTiming::Constant { v: 1.0 },
            t0: 0.0,
            limit_scale: 1.0,
        })
    }

    /// One stretch of a move's grid: `n` equal cells from `s0` to `s1`, starting from heading
    /// hint `psi0` and steer angles `g0`.
    #[allow(clippy::too_many_arguments)]
    fn stretch(
        &self,
        kind: &Kind,
        len: f64,
        s0: f64,
        s1: f64,
        n: usize,
        psi0: f64,
        g0: [f64; 3],
    ) -> Result<Stretch, PlanningError> {
        let sig: Vec<f64> = (0..=n)
            .map(|i| {
                if i == n {
                    s1
                } else {
                    s0 + (s1 - s0) * i as f64 / n as f64
                }
            })
            .collect();
        let (psi, cs, a, gamma) = self.grid(kind, len, psi0, g0, &sig)?;
        Ok(Stretch {
            sig,
            psi,
            cs,
            a,
            gamma,
        })
    }

    /// Heading (and its cosine and sine), `A` and steer angles at the nodes `sig` of a move.
    #[allow(clippy::type_complexity)]
    fn grid(
        &self,
        kind: &Kind,
        len: f64,
        psi_start: f64,
        gamma0: [f64; 3],
        sig: &[f64],
    ) -> Result<(Vec<f64>, Vec<[f64; 2]>, Vec<[f64; 6]>, Vec<[f64; 3]>), PlanningError> {
        let mut psi = Vec::with_capacity(sig.len());
        let mut cs = Vec::with_capacity(sig.len());
        let mut a = Vec::with_capacity(sig.len());
        let mut gamma = Vec::with_capacity(sig.len());
        let mut hint = Hint::angle(psi_start);
        let mut g = gamma0;
        for (k, &sigma) in sig.iter().enumerate() {
            if k > 0 {
                let h = sigma - sig[k - 1];
                g = self.steer_step(kind, len, sig[k - 1], g, h, hint)?;
            }
            let c = self.config(kind, len, sigma, hint);
            hint = Hint::of(&c);
            psi.push(c.pose.heading);
            cs.push(c.cs);
            a.push(self.rates_per_speed(&c, g)?);
            gamma.push(g);
        }
        Ok((psi, cs, a, gamma))
    }

    /// Steer angles at `sigma` within a move, and the configuration there; `from` is the
    /// grid cell of the previous call (see [`cell_from`]) and is updated.
    fn state(
        &self,
        mv: &Move,
        sigma: f64,
        from: &mut usize,
    ) -> Result<(Config, [f64; 3]), PlanningError> {
        let k = cell_from(&mv.sig, sigma, *from);
        *from = k;
        let hint = Hint {
            psi: mv.psi[k],
            cs: Some(mv.cs[k]),
        };
        let c = self.config(&mv.kind, mv.len, sigma, hint);
        let g = self.steer_step(
            &mv.kind,
            mv.len,
            mv.sig[k],
            mv.gamma[k],
            (sigma - mv.sig[k]).max(0.0),
            hint,
        )?;
        Ok((c, g))
    }
}

/// One stretch of a move's grid between kinks (equal cells).
struct Stretch {
    sig: Vec<f64>,
    psi: Vec<f64>,
    cs: Vec<[f64; 2]>,
    a: Vec<[f64; 6]>,
    gamma: Vec<[f64; 3]>,
}

impl Stretch {
    /// Heading and steer angles at the stretch's last node.
    fn end(&self) -> (f64, [f64; 3]) {
        (
            *self.psi.last().expect("a stretch has nodes"),
            *self.gamma.last().expect("a stretch has nodes"),
        )
    }

    /// Largest `|A|` and `|A'|` (central differences) per channel on the stretch (the first
    /// `chans` channels; the others stay 0).
    fn scale(&self, chans: usize) -> [[f64; 6]; 2] {
        let a = &self.a;
        let mut out = [[0.0_f64; 6]; 2];
        for row in a {
            for ch in 0..chans {
                out[0][ch] = out[0][ch].max(row[ch].abs());
            }
        }
        if a.len() >= 3 {
            let h = self.sig[1] - self.sig[0];
            for k in 1..a.len() - 1 {
                for ch in 0..chans {
                    let d = (a[k + 1][ch] - a[k - 1][ch]) / (2.0 * h);
                    out[1][ch] = out[1][ch].max(d.abs());
                }
            }
        }
        out
    }

    /// Largest estimated error of linear interpolation between the nodes of `A`
    /// (`|Δ²A|/8 = h² A''/8`) and of its central differences `A'` (inside the stretch),
    /// relative to each channel's largest `|A|` and `|A'|` on the move (`scale`).
    fn error(&self, scale: &[[f64; 6]; 2], chans: usize) -> f64 {
        let a = &self.a;
        let m = a.len();
        if m < 3 {
            return 0.0;
        }
        let h = self.sig[1] - self.sig[0];
        let inv = |s: f64, f: f64| if s > 0.0 { 1.0 / (f * s) } else { 0.0 };
        let inv_a: [f64; 6] = core::array::from_fn(|ch| inv(scale[0][ch], 8.0));
        // A'(k) = (A[k+1] − A[k−1]) / 2h, so Δ²A'/8 = (A[k+2] − 2A[k+1] + 2A[k−1] − A[k−2]) / 16h.
        let inv_b: [f64; 6] = core::array::from_fn(|ch| inv(scale[1][ch], 16.0 * h));
        let mut err = 0.0_f64;
        for k in 1..m - 1 {
            for ch in 0..chans {
                let d2 = a[k - 1][ch] - 2.0 * a[k][ch] + a[k + 1][ch];
                err = err.max(d2.abs() * inv_a[ch]);
            }
        }
        for k in 2..m.saturating_sub(2) {
            for ch in 0..chans {
                let d = a[k + 2][ch] - 2.0 * a[k + 1][ch] + 2.0 * a[k - 1][ch] - a[k - 2][ch];
                err = err.max(d.abs() * inv_b[ch]);
            }
        }
        err
    }
}

/// Index `k` of the grid cell `[sig[k], sig[k + 1]]` containing `sigma` (clamped).
fn cell(sig: &[f64], sigma: f64) -> usize {
    let n = sig.len() - 1;
    sig.partition_point(|&x| x <= sigma)
        .saturating_sub(1)
        .min(n.saturating_sub(1))
}

/// [`cell`], for queries that mostly move forward a little: a few steps on from the previous
/// answer `from`, bisection otherwise. Same result as [`cell`] for every input.
fn cell_from(sig: &[f64], sigma: f64, from: usize) -> usize {
    let last = sig.len().saturating_sub(2);
    let mut k = from.min(last);
    if sig.len() < 2 || sigma.is_nan() || sig[k] > sigma {
        return cell(sig, sigma);
    }
    for _ in 0..8 {
        if k >= last || sig[k + 1] > sigma {
            return k;
        }
        k += 1;
    }
    k + cell(&sig[k..], sigma)
}

/// Derivative of a vector function tabulated at the nodes `sig`, made of stretches of `n[j]`
/// equal cells: central differences inside a stretch, second-order one-sided differences at
/// the stretch ends (kinks, where the derivative may jump). Returns the derivative seen from
/// the cell ending at each node and from the cell starting there (equal except at kinks).
#[allow(clippy::type_complexity)]
fn derivative(a: &[[f64; 6]], sig: &[f64], n: &[usize]) -> (Vec<[f64; 6]>, Vec<[f64; 6]>) {
    let m = a.len();
    let mut b_in = vec![[0.0; 6]; m];
    let mut b_out = vec![[0.0; 6]; m];
    let mut first = 0;
    for &c in n {
        let last = first + c;
        let h = (sig[last] - sig[first]) / c as f64;
        for k in first..=last {
            let d: [f64; 6] = if k > first && k < last {
                core::array::from_fn(|i| (a[k + 1][i] - a[k - 1][i]) / (2.0 * h))
            } else if c == 1 {
                core::array::from_fn(|i| (a[last][i] - a[first][i]) / h)
            } else if k == first {
                core::array::from_fn(|i| {
                    (-3.0 * a[k][i] + 4.0 * a[k + 1][i] - a[k + 2][i]) / (2.0 * h)
                })
            } else {
                core::array::from_fn(|i| {
                    (3.0 * a[k][i] - 4.0 * a[k - 1][i] + a[k - 2][i]) / (2.0 * h)
                })
            };
            if k > first {
                b_in[k] = d;
            }
            if k < last {
                b_out[k] = d;
            }
        }
        first = last;
    }
    // The first node has no incoming cell and the last no outgoing one.
    b_in[0] = b_out[0];
    b_out[m - 1] = b_in[m - 1];
    (b_in, b_out)
}

/// `true` when two derivative vectors `q'` differ (a jump in the wheel rates per unit speed).
fn jumps(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).any(|i| (a[i] - b[i]).abs() > 1e-9 * (1.0 + a[i].abs().max(b[i].abs())))
}

/// The steer angles of the trailing configuration for the first motion (see
/// [`InitialSteer::Aligned`]).
fn aligned_steer(robot: &RobotModel, c: &Config) -> [f64; 3] {
    let Robot::Caster(m) = &robot.model else {
        return [0.0; 3];
    };
    let p = m.params();
    let th = c.pose.heading;
    core::array::from_fn(|i| {
        let (sa, ca) = (p.mount_angles[i] + th).sin_cos();
        let vf = [
            c.dq[0] - c.dq[2] * p.mount_radius * sa,
            c.dq[1] + c.dq[2] * p.mount_radius * ca,
        ];
        let speed = vf[0].hypot(vf[1]);
        if speed < 1e-12 {
            return 0.0;
        }
        let chi = vf[1].atan2(vf[0]);
        let rho = (c.dq[2] * p.eccentricity / speed).clamp(-1.0, 1.0);
        let beta = chi + std::f64::consts::PI - rho.asin();
        wrap_angle(beta - p.mount_angles[i] - th)
    })
}

/// Peak ratios of a move under a timing: `(rate ratio, channel, t, value)` and the same for
/// accelerations, from a dense evaluation (≥ 2000 points, ≤ 0.5 ms apart).
struct MovePeaks {
    rate: (f64, usize, f64, f64),
    accel: (f64, usize, f64, f64),
}

fn move_peaks(robot: &RobotModel, mv: &Move, timing: &MoveTiming) -> MovePeaks {
    let dur = timing.duration(mv.len);
    let m = ((dur / 5e-4).ceil() as usize).clamp(2000, 400_000);
    let mut out = MovePeaks {
        rate: (0.0, 0, 0.0, 0.0),
        accel: (0.0, 0, 0.0, 0.0),
    };
    let (mut from_t, mut from_s) = (0, 0);
    for j in 0..=m {
        let t = dur * j as f64 / m as f64;
        let (s, v, acc) = timing.eval(t, mv.len, &mv.sig, &mut from_t);
        let k = cell_from(&mv.sig, s, from_s);
        from_s = k;
        let h = mv.sig[k + 1] - mv.sig[k];
        let f = ((s - mv.sig[k]) / h).clamp(0.0, 1.0);
        // Cubic Hermite for A (values and slopes A' at both ends; O(h⁴), so the peaks between
        // nodes are not underestimated the way linear interpolation would), linear for A'.
        let (f2, f3) = (f * f, f * f * f);
        let (h00, h10, h01, h11) = (
            2.0 * f3 - 3.0 * f2 + 1.0,
            f3 - 2.0 * f2 + f,
            -2.0 * f3 + 3.0 * f2,
            f3 - f2,
        );
        for ch in 0..robot.channels() {
            let (b0, b1) = (mv.b_out[k][ch], mv.b_in[k + 1][ch]);
            let a = mv.a[k][ch] * h00 + h * b0 * h10 + mv.a[k + 1][ch] * h01 + h * b1 * h11;
            let b = b0 * (1.0 - f) + b1 * f;
            let w = (a * v).abs();
            let wd = (a * acc + b * v * v).abs();
            if let Some(lim) = robot.rate_limit(ch)
                && w / lim > out.rate.0 * (1.0 + 1e-9)
            {
                out.rate = (w / lim, ch, t, w);
            }
            if let Some(lim) = robot.accel_limit(ch)
                && wd / lim > out.accel.0 * (1.0 + 1e-9)
            {
                out.accel = (wd / lim, ch, t, wd);
            }
        }
    }
    out
}

/// Most constraints of a grid cell: the requested acceleration plus two per motor.
const CELL_MAX: usize = 13;
/// Up to this many cells the time-optimal pass keeps each cell's constraints from the
/// backward pass for the forward one (≈ 12 MB at most) instead of rebuilding them.
const STORED_CELLS: usize = 50_000;

/// The constraints of one grid cell in the unknowns `x = x_k` (start) and `y = x_{k+1}`
/// (end): for each `i`, `−hi[i] + slope[i]·x ≤ y ≤ hi[i] + slope[i]·x` (every constraint is
/// a bound on a magnitude, so the band is symmetric), plus `x ≤ x_max` from constraints that
/// do not involve `y`. `who[i]` names the limit (0: the requested acceleration, `1 + ch`:
/// motor channel `ch`'s acceleration limit).
#[derive(Clone)]
struct CellConstraints {
    hi: [f64; CELL_MAX],
    slope: [f64; CELL_MAX],
    who: [u8; CELL_MAX],
    n: usize,
    x_max: f64,
    x_who: u8,
}

impl CellConstraints {
    fn new() -> Self {
        Self {
            hi: [0.0; CELL_MAX],
            slope: [0.0; CELL_MAX],
            who: [0; CELL_MAX],
            n: 0,
            x_max: f64::INFINITY,
            x_who: 0,
        }
    }

    /// Forgets every constraint (the arrays are overwritten as constraints are added, so one
    /// set is reused for all cells without zeroing or copying it).
    fn clear(&mut self) {
        self.n = 0;
        self.x_max = f64::INFINITY;
        self.x_who = 0;
    }

    /// Adds `|c_y·y + c_x·x| ≤ bound`.
    fn add(&mut self, c_y: f64, c_x: f64, bound: f64, who: u8) {
        if c_y.abs() <= 1e-12 * c_x.abs() || c_y == 0.0 {
            // Only x is constrained (x ≥ 0): |c_x| x ≤ bound.
            if c_x != 0.0 && bound < self.x_max * c_x.abs() {
                self.x_max = bound / c_x.abs();
                self.x_who = who;
            }
            return;
        }
        let inv = 1.0 / c_y;
        let i = self.n;
        self.hi[i] = (bound * inv).abs();
        self.slope[i] = -c_x * inv;
        self.who[i] = who;
        self.n += 1;
    }

    /// The largest `x ∈ [0, x_cap]` for which some `y ∈ [0, y_max]` satisfies every
    /// constraint, and what bounds it (`None` for `x_cap`). `x = 0, y = 0` is always
    /// admissible, so the answer is ≥ 0.
    fn largest_start(&self, x_cap: f64, y_max: f64) -> (f64, Option<u8>) {
        let (mut x, mut who) = if self.x_max < x_cap {
            (self.x_max, Some(self.x_who))
        } else {
            (x_cap, None)
        };
        // g(x) = U(x) − L(x), U the lowest upper bound (y ≤ y_max included), L the highest
        // lower bound (y ≥ 0 included), is concave and piecewise linear with g(0) ≥ 0, and x
        // is admissible iff g(x) ≥ 0. From the right of its root Newton's steps stay right of
        // it and end on it after at most one step per linear piece.
        for _ in 0..2 * CELL_MAX + 2 {
            let (mut u, mut bu, mut iu) = (y_max, 0.0, usize::MAX);
            let (mut l, mut bl, mut il) = (0.0_f64, 0.0, usize::MAX);
            for i in 0..self.n {
                let b = self.slope[i];
                let hi = self.hi[i] + b * x;
                if hi < u || (hi == u && b > bu) {
                    (u, bu, iu) = (hi, b, i);
                }
                let lo = -self.hi[i] + b * x;
                if lo > l || (lo == l && b < bl) {
                    (l, bl, il) = (lo, b, i);
                }
            }
            let g = u - l;
            if g >= -1e-12 * (u.abs() + l.abs()) {
                break;
            }
            let slope = bu - bl;
            if slope >= 0.0 {
                // Cannot happen for a concave g with g(0) ≥ 0 but for rounding; stay safe.
                x = 0.0;
                break;
            }
            x = (x - g / slope).max(0.0);
            // The limit that forces the slow-down: the lower bound's (a deceleration limit)
            // unless it is the trivial y ≥ 0.
            let i = if il != usize::MAX { il } else { iu };
            who = (i != usize::MAX).then(|| self.who[i]);
        }
        (x.max(0.0), who)
    }

    /// The largest admissible `y ≤ y_max` given `x`, and what bounds it (`None` for `y_max`).
    fn largest_end(&self, x: f64, y_max: f64) -> (f64, Option<u8>) {
        let mut y = y_max;
        let mut who = None;
        let mut floor = 0.0_f64;
        for i in 0..self.n {
            let bx = self.slope[i] * x;
            let hi = self.hi[i] + bx;
            if hi < y {
                y = hi;
                who = Some(self.who[i]);
            }
            floor = floor.max(-self.hi[i] + bx);
        }
        // x lies in the reachable set, so floor ≤ y up to rounding.
        (y.max(floor.min(y_max)).max(0.0), who)
    }
}

/// The time-optimal timing of one move (see the module docs): a reachability pass backward
/// from rest at the end, then the greedy forward pass from rest at the start, on `x = σ̇²`.
/// Returns the grid timing and, per cell, what limited it.
fn time_optimal(
    robot: &RobotModel,
    mv: &Move,
    v_user: f64,
    a_user: f64,
    user: (Limiter, Limiter),
) -> Result<(MoveTiming, Vec<Limiter>), PlanningError> {
    time_optimal_storing(robot, mv, v_user, a_user, user, STORED_CELLS)
}

/// [`time_optimal`], keeping the cells' constraints between the passes for moves of up to
/// `stored_cells` cells.
fn time_optimal_storing(
    robot: &RobotModel,
    mv: &Move,
    v_user: f64,
    a_user: f64,
    user: (Limiter, Limiter),
    stored_cells: usize,
) -> Result<(MoveTiming, Vec<Limiter>), PlanningError> {
    let n = mv.a.len() - 1;
    let sig = &mv.sig;
    let chans = robot.channels();
    let margin = MARGIN * mv.limit_scale;
    let motor = |ch: usize, accel: bool| Limiter::Motor {
        quantity: Quantity::of(ch, accel),
        motor: ch % 3 + 1,
    };
    let rate_limits: [Option<f64>; 6] =
        core::array::from_fn(|ch| robot.rate_limit(ch).map(|l| l * margin));
    let accel_limits: [Option<f64>; 6] =
        core::array::from_fn(|ch| robot.accel_limit(ch).map(|l| l * margin));
    // Speed caps on x = σ̇²: the requested speed and every motor's rate limit.
    let mut cap = vec![0.0; n + 1];
    let mut cap_src = vec![user.0; n + 1];
    for k in 0..=n {
        let mut c = v_user * v_user;
        let mut src = user.0;
        for ch in 0..chans {
            // |A| plus the estimated bulge of A between this node and its neighbours (|Δ²A|/8,
            // doubled for its product with a changing speed), so the rate limit also holds
            // between nodes.
            let bulge = if k > 0 && k < n {
                (mv.a[k - 1][ch] - 2.0 * mv.a[k][ch] + mv.a[k + 1][ch]).abs() / 4.0
            } else {
                0.0
            };
            let a = mv.a[k][ch].abs() + bulge;
            if let Some(l) = rate_limits[ch]
                && a > 0.0
                && (l / a).powi(2) < c
            {
                c = (l / a).powi(2);
                src = motor(ch, false);
            }
        }
        cap[k] = c;
        cap_src[k] = src;
    }
    // Constraints of cell k: requested path acceleration |y − x| ≤ 2h a_user, and each motor's
    // acceleration |A σ̈ + A' x| ≤ limit at both ends, σ̈ = (y − x)/(2h).
    let fill = |c: &mut CellConstraints, k: usize| {
        let i2h = 1.0 / (2.0 * (sig[k + 1] - sig[k]));
        let (a0, b0, a1, b1) = (&mv.a[k], &mv.b_out[k], &mv.a[k + 1], &mv.b_in[k + 1]);
        c.clear();
        c.add(i2h, -i2h, a_user, 0);
        for ch in 0..chans {
            if let Some(l) = accel_limits[ch] {
                c.add(a0[ch] * i2h, b0[ch] - a0[ch] * i2h, l, 1 + ch as u8);
                c.add(a1[ch] * i2h + b1[ch], -a1[ch] * i2h, l, 1 + ch as u8);
            }
        }
    };
    let mut c = CellConstraints::new();
    let name = |w: u8| {
        if w == 0 {
            user.1
        } else {
            motor(usize::from(w - 1), true)
        }
    };
    // Backward: reach[k] = the largest x_k from which rest at the end is reachable. The
    // forward pass reuses the cells' constraints (≈ 230 bytes a cell) up to STORED_CELLS
    // cells and rebuilds them beyond, so a long fine grid does not hold them all.
    let store = n <= stored_cells;
    let mut stored: Vec<CellConstraints> = Vec::with_capacity(if store { n } else { 0 });
    let mut reach = vec![0.0; n + 1];
    let mut reach_src = vec![user.0; n + 1];
    for k in (0..n).rev() {
        fill(&mut c, k);
        let (x, who) = c.largest_start(cap[k], reach[k + 1]);
        reach[k] = x;
        reach_src[k] = who.map_or(cap_src[k], name);
        if store {
            stored.push(c.clone());
        }
    }
    // Forward: from rest, the largest admissible end value that stays reachable.
    let mut x = vec![0.0; n + 1];
    let mut who = Vec::with_capacity(n);
    for k in 0..n {
        let cell = if store {
            // Pushed in the backward order.
            &stored[n - 1 - k]
        } else {
            fill(&mut c, k);
            &c
        };
        let (y, limiter) = cell.largest_end(x[k], reach[k + 1]);
        x[k + 1] = y;
        who.push(limiter.map_or(reach_src[k + 1], name));
    }
    let mut t = vec![0.0; n + 1];
    for k in 0..n {
        let den = x[k].sqrt() + x[k + 1].sqrt();
        if den.is_nan() || den <= 0.0 {
            return Err(PlanningError::Infeasible(format!(
                "the motor limits allow no motion at parameter {:.4} of a move (speed cap 0)",
                sig[k]
            )));
        }
        t[k + 1] = t[k] + 2.0 * (sig[k + 1] - sig[k]) / den;
    }
    Ok((MoveTiming::Grid { x, t }, who))
}

/// Plans `path` with the heading law `heading` for `robot` (see the module docs for how).
///
/// # Errors
/// * [`PlanningError::InvalidParameter`] for a non-finite steer angle;
/// * [`PlanningError::OutOfRange`] for a rate, motion limit, heading or steer angle outside
///   its range in [`crate::limits`];
/// * [`PlanningError::TooLarge`] when the path needs more grid cells than
///   [`crate::limits::MAX_MOVE_GRID_CELLS`] / [`crate::limits::MAX_PLAN_GRID_CELLS`] or the
///   timed plan more samples than [`crate::limits::MAX_PLAN_SAMPLES`] (checked before
///   allocating them);
/// * [`PlanningError::LimitExceeded`] when `opts.on_limit` is [`OnLimit::Reject`] and the
///   requested timing needs more than a motor limit allows (the worst excess: motor, value,
///   time, limit, percent);
/// * [`PlanningError::Infeasible`] for a constant-speed law on a path with stops, or a speed
///   cap of zero;
/// * [`PlanningError::Kinematics`] if the kinematics meet a non-finite number.
pub fn plan(
    path: &Path,
    heading: &HeadingLaw,
    robot: &RobotModel,
    opts: &PlanOptions,
) -> Result<Planned, PlanningError> {
    heading.validate()?;
    check_range("rate", opts.rate, RATE_RANGE, "Hz")?;
    match opts.timing {
        Timing::Profile { kind, limits } => limits.validate(kind == ProfileKind::SCurve)?,
        Timing::TimeOptimal { limits } => limits.validate(false)?,
        Timing::ConstantSpeed { speed } => check_range("speed", speed, SPEED_RANGE, "m/s")?,
    }
    if let InitialSteer::Given(g) = opts.initial_steer
        && g.iter().any(|v| !v.is_finite())
    {
        return Err(PlanningError::InvalidParameter {
            name: "initial steer",
            value: g.into_iter().find(|v| !v.is_finite()).unwrap_or(f64::NAN),
            rule: "steer angles must be finite (rad)",
        });
    }
    if let InitialSteer::Given(g) = opts.initial_steer {
        for v in g {
            crate::limits::check_magnitude("initial steer", v, crate::limits::MAX_HEADING, "rad")?;
        }
    }
    let heading_cs = match heading {
        HeadingLaw::Constant(a) | HeadingLaw::Tangent { offset: a } => {
            let (s, c) = a.sin_cos();
            [c, s]
        }
        HeadingLaw::Profile(_) => [1.0, 0.0],
    };
    let ctx = Ctx {
        path,
        heading,
        robot,
        heading_cs,
    };
    let mut moves = build_moves(&ctx, opts)?;
    if matches!(opts.timing, Timing::ConstantSpeed { .. }) && moves.len() != 1 {
        return Err(PlanningError::Infeasible(format!(
            "a constant-speed law cannot stop, but this path/heading law needs {} stops",
            moves.len() - 1
        )));
    }
    let mut retimed = Vec::new();
    let mut active_w: Vec<(Limiter, f64)> = Vec::new();
    let mut t0 = 0.0;
    for (i, mv) in moves.iter_mut().enumerate() {
        mv.t0 = t0;
        let (timing, limiters) = initial_timing(robot, mv, opts, i, &mut retimed)?;
        mv.timing = timing;
        t0 += mv.timing.duration(mv.len);
        active_w.extend(limiters);
    }
    // Sample, check strictly, slow down what still exceeds (grid approximation), repeat.
    for round in 0..25 {
        let mut t0 = 0.0;
        for mv in moves.iter_mut() {
            mv.t0 = t0;
            t0 += mv.timing.duration(mv.len);
        }
        let plan = sample(&ctx, &moves, opts.rate)?;
        let peaks = plan_peaks(&plan, robot);
        let worst = peaks
            .iter()
            .filter_map(|p| p.limit.map(|l| (p, p.value / l)))
            .filter(|(_, r)| *r > 1.0 + 1e-9)
            .max_by(|a, b| a.1.total_cmp(&b.1));
        match worst {
            None => {
                let report = report(
                    path,
                    &moves,
                    plan.duration(),
                    peaks,
                    retimed,
                    active_w,
                    &plan,
                );
                return Ok(Planned { plan, report });
            }
            Some((p, ratio)) if round < 24 => {
                let p = *p;
                let idx = moves.iter().rposition(|m| m.t0 <= p.t).unwrap_or(0);
                if opts.on_limit == OnLimit::Reject
                    && !matches!(opts.timing, Timing::TimeOptimal { .. })
                {
                    // Only a grid-approximation residue can get here; refuse like the dense check.
                    return Err(PlanningError::LimitExceeded(Violation {
                        quantity: p.quantity,
                        motor: p.motor,
                        needed: p.value,
                        t: p.t,
                        limit: p.limit.unwrap_or(f64::NAN),
                    }));
                }
                let f = if p.quantity.is_accel() {
                    ratio.sqrt()
                } else {
                    ratio
                };
                let limiter = Limiter::Motor {
                    quantity: p.quantity,
                    motor: p.motor,
                };
                let mv = &mut moves[idx];
                match &mut mv.timing {
                    MoveTiming::Profile { lambda, .. } => {
                        *lambda *= 0.999 / f;
                        note_retime(&mut retimed, idx, *lambda, limiter);
                    }
                    MoveTiming::Constant { v } => {
                        *v *= 0.999 / f;
                        if let Timing::ConstantSpeed { speed } = opts.timing {
                            note_retime(&mut retimed, idx, *v / speed, limiter);
                        }
                    }
                    MoveTiming::Grid { .. } => {
                        mv.limit_scale *= 0.995 / ratio;
                        let (v_user, a_user, user) = user_limits(opts, &mv.kind);
                        let (timing, _) = time_optimal(robot, mv, v_user, a_user, user)?;
                        mv.timing = timing;
                    }
                }
            }
            Some((p, _)) => {
                return Err(PlanningError::Infeasible(format!(
                    "could not bring {} {} within {} after repeated slow-downs (peak {:.3} {})",
                    p.quantity.motor(),
                    p.motor,
                    p.quantity.key(),
                    p.value,
                    p.quantity.unit()
                )));
            }
        }
    }
    unreachable!("the loop returns on its last round")
}

fn note_retime(retimed: &mut Vec<Retiming>, idx: usize, factor: f64, limiter: Limiter) {
    if let Some(r) = retimed.iter_mut().find(|r| r.move_index == idx) {
        r.factor = r.factor.min(factor);
    } else {
        retimed.push(Retiming {
            move_index: idx,
            factor,
            limiter,
        });
    }
}

/// The requested speed/acceleration for a move's kind, and their limiter labels.
fn user_limits(opts: &PlanOptions, kind: &Kind) -> (f64, f64, (Limiter, Limiter)) {
    let limits = match opts.timing {
        Timing::Profile { limits, .. } | Timing::TimeOptimal { limits } => limits,
        Timing::ConstantSpeed { speed } => MotionLimits {
            max_speed: speed,
            ..MotionLimits::default()
        },
    };
    match kind {
        Kind::Travel { .. } => (
            limits.max_speed,
            limits.max_accel,
            (Limiter::MaxSpeed, Limiter::MaxAccel),
        ),
        Kind::Turn { .. } => (
            limits.max_yaw_rate,
            limits.max_yaw_accel,
            (Limiter::MaxYawRate, Limiter::MaxYawAccel),
        ),
    }
}

/// The first timing of a move, before the final check on the samples.
fn initial_timing(
    robot: &RobotModel,
    mv: &Move,
    opts: &PlanOptions,
    idx: usize,
    retimed: &mut Vec<Retiming>,
) -> Result<(MoveTiming, Vec<(Limiter, f64)>), PlanningError> {
    let timing = match opts.timing {
        Timing::TimeOptimal { .. } => {
            let (v_user, a_user, user) = user_limits(opts, &mv.kind);
            let (timing, who) = time_optimal(robot, mv, v_user, a_user, user)?;
            let MoveTiming::Grid { t, .. } = &timing else {
                unreachable!("time_optimal returns a grid timing")
            };
            let weights = who
                .iter()
                .enumerate()
                .map(|(k, w)| (*w, t[k + 1] - t[k]))
                .collect();
            return Ok((timing, weights));
        }
        Timing::Profile { kind, limits } => {
            let (v, a, j) = match mv.kind {
                Kind::Travel { .. } => (limits.max_speed, limits.max_accel, limits.max_jerk),
                Kind::Turn { .. } => (
                    limits.max_yaw_rate,
                    limits.max_yaw_accel,
                    limits.max_yaw_accel * limits.max_jerk / limits.max_accel,
                ),
            };
            MoveTiming::Profile {
                p: Profile1D::new(kind, mv.len, v, a, j)?,
                lambda: 1.0,
            }
        }
        Timing::ConstantSpeed { speed } => MoveTiming::Constant { v: speed },
    };
    let peaks = move_peaks(robot, mv, &timing);
    let (rr, ra) = (peaks.rate.0, peaks.accel.0);
    let dur = timing.duration(mv.len);
    let user_label = match (&opts.timing, &mv.kind) {
        (Timing::ConstantSpeed { .. }, _) => Limiter::RequestedSpeed,
        (_, Kind::Travel { .. }) => Limiter::MaxSpeed,
        (_, Kind::Turn { .. }) => Limiter::MaxYawRate,
    };
    if rr <= 1.0 && ra <= 1.0 {
        return Ok((timing, vec![(user_label, dur)]));
    }
    let (ratio, (_, ch, _, _), accel) = if rr >= ra.sqrt() {
        (rr, peaks.rate, false)
    } else {
        (ra.sqrt(), peaks.accel, true)
    };
    let quantity = Quantity::of(ch, accel);
    if opts.on_limit == OnLimit::Reject {
        let worst = if rr >= ra {
            (peaks.rate, false)
        } else {
            (peaks.accel, true)
        };
        let ((_, ch, t, value), accel) = worst;
        let quantity = Quantity::of(ch, accel);
        let limit = if accel {
            robot.accel_limit(ch)
        } else {
            robot.rate_limit(ch)
        }
        .unwrap_or(f64::NAN);
        return Err(PlanningError::LimitExceeded(Violation {
            quantity,
            motor: ch % 3 + 1,
            needed: value,
            t: t + mv.t0,
            limit,
        }));
    }
    let lambda = MARGIN / ratio;
    let limiter = Limiter::Motor {
        quantity,
        motor: ch % 3 + 1,
    };
    note_retime(retimed, idx, lambda, limiter);
    let timing = match timing {
        MoveTiming::Profile { p, .. } => MoveTiming::Profile { p, lambda },
        MoveTiming::Constant { v } => MoveTiming::Constant { v: v * lambda },
        g => g,
    };
    let dur = timing.duration(mv.len);
    Ok((timing, vec![(limiter, dur)]))
}

/// The starting grid step of a move, m or rad: [`GRID_MAX`], refined by
/// [`Ctx::build_move`] where `A(σ)` needs it. The caster's steer angles change over a length
/// of the order of its eccentricity `d` (paper 003, eq. 5), so its grid starts at `d/5`.
fn grid_step(robot: &RobotModel) -> f64 {
    match &robot.model {
        Robot::Caster(m) => (m.params().eccentricity / 5.0).clamp(GRID_MIN, GRID_MAX),
        _ => GRID_MAX,
    }
}

/// Cuts the path into moves (see the module docs) and builds their grids.
fn build_moves(ctx: &Ctx, opts: &PlanOptions) -> Result<Vec<Move>, PlanningError> {
    let path = ctx.path;
    let len = path.length();
    let heading_rate = |s: f64, side: Side, curvature: f64| match ctx.heading {
        HeadingLaw::Constant(_) => 0.0,
        HeadingLaw::Tangent { .. } => curvature,
        HeadingLaw::Profile(p) => p.at(s, side).1,
    };
    // Cut points: stops, and joins where q' jumps.
    let mut cuts: Vec<f64> = Vec::new();
    for j in path.joins() {
        let before = [
            j.before.tangent[0],
            j.before.tangent[1],
            heading_rate(j.s, Side::Before, j.before.curvature),
        ];
        let after = [
            j.after.tangent[0],
            j.after.tangent[1],
            heading_rate(j.s, Side::After, j.after.curvature),
        ];
        if j.stop || jumps(before, after) {
            cuts.push(j.s);
        }
    }
    for s in ctx.heading.breakpoints() {
        if s > 0.0 && s < len {
            let p_before = path.at_side(s, Side::Before);
            let p_after = path.at_side(s, Side::After);
            let before = [
                p_before.tangent[0],
                p_before.tangent[1],
                heading_rate(s, Side::Before, p_before.curvature),
            ];
            let after = [
                p_after.tangent[0],
                p_after.tangent[1],
                heading_rate(s, Side::After, p_after.curvature),
            ];
            if jumps(before, after) {
                cuts.push(s);
            }
        }
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    let mut bounds = vec![0.0];
    bounds.extend(cuts.into_iter().filter(|&s| s > 1e-12 && s < len - 1e-12));
    bounds.push(len);

    // The grid's size before refinement, from the lengths alone: refuse a path too long for
    // the grid before building any of it (refinement is checked move by move below).
    let step = grid_step(ctx.robot);
    let coarse: f64 = bounds
        .windows(2)
        .map(|w| ((w[1] - w[0]) / step).ceil().max(MIN_CELLS as f64))
        .sum();
    if coarse.is_nan() || coarse > MAX_PLAN_GRID_CELLS as f64 {
        return Err(too_many_plan_cells(len, bounds.len() - 1, coarse));
    }
    let first = path.at_side(0.0, Side::After);
    let mut psi = match ctx.heading {
        HeadingLaw::Constant(c) => *c,
        HeadingLaw::Tangent { offset } => first.direction() + offset,
        HeadingLaw::Profile(p) => p.at(0.0, Side::After).0,
    };
    let mut gamma = match opts.initial_steer {
        InitialSteer::Given(g) => g,
        InitialSteer::Aligned => {
            let kind = Kind::Travel {
                s0: 0.0,
                s1: bounds[1],
            };
            let c = ctx.config(&kind, bounds[1], 0.0, Hint::angle(psi));
            aligned_steer(ctx.robot, &c)
        }
    };
    if !ctx.robot.is_caster() {
        gamma = [0.0; 3];
    }
    let mut moves = Vec::new();
    for w in bounds.windows(2) {
        let (s0, s1) = (w[0], w[1]);
        if let HeadingLaw::Tangent { offset } = ctx.heading
            && s0 > 0.0
        {
            let want = path.at_side(s0, Side::After).direction() + offset;
            let delta = wrap_angle(want - psi);
            if delta.abs() > 1e-9 {
                let p = path.at(s0).point;
                let kind = Kind::Turn {
                    x: p[0],
                    y: p[1],
                    psi0: psi,
                    dir: delta.signum(),
                };
                let mv = ctx.build_move(kind, delta.abs(), psi, gamma, step, &[])?;
                psi += delta;
                gamma = *mv.gamma.last().unwrap_or(&gamma);
                moves.push(mv);
            }
        }
        let kind = Kind::Travel { s0, s1 };
        let kinks: Vec<f64> = path
            .piece_starts()
            .iter()
            .chain(ctx.heading.knots())
            .filter(|&&k| k > s0 && k < s1)
            .map(|k| k - s0)
            .collect();
        let mv = ctx.build_move(kind, s1 - s0, psi, gamma, step, &kinks)?;
        psi = *mv.psi.last().unwrap_or(&psi);
        gamma = *mv.gamma.last().unwrap_or(&gamma);
        moves.push(mv);
        let cells: usize = moves.iter().map(|m| m.sig.len() - 1).sum();
        if cells > MAX_PLAN_GRID_CELLS {
            return Err(too_many_plan_cells(len, moves.len(), cells as f64));
        }
    }
    Ok(moves)
}

fn too_many_plan_cells(len: f64, moves: usize, cells: f64) -> PlanningError {
    PlanningError::TooLarge {
        what: format!("the path (length {len:.4e} m, {moves} moves)"),
        items: "grid cells",
        needed: cells,
        limit: "MAX_PLAN_GRID_CELLS",
        max: MAX_PLAN_GRID_CELLS,
        hint: "shorten the path or cut it into several plans",
    }
}

/// Samples the timed moves at `rate` Hz (plus the exact end time).
fn sample(ctx: &Ctx, moves: &[Move], rate: f64) -> Result<Plan, PlanningError> {
    let last = moves.last().expect("a path has at least one move");
    let total = last.t0 + last.timing.duration(last.len);
    // Samples at k / rate before the end, plus the end: checked before anything is allocated
    // (NaN or infinite durations fail the comparison too).
    let needed = (total * rate).floor() + 2.0;
    if needed.is_nan() || needed > MAX_PLAN_SAMPLES as f64 {
        return Err(PlanningError::TooLarge {
            what: format!("the plan (duration {total:.4e} s × rate {rate} Hz)"),
            items: "samples",
            needed,
            limit: "MAX_PLAN_SAMPLES",
            max: MAX_PLAN_SAMPLES,
            hint: "lower the sampling rate (--rate), or plan a faster or shorter motion \
                   (--speed, --omega, --max-speed, --turns, --side; or higher [limits] in the \
                   robot file)",
        });
    }
    let mut times = Vec::with_capacity(needed as usize);
    let mut j = 0usize;
    loop {
        let t = j as f64 / rate;
        if t >= total - 1e-9 * total.max(1.0) {
            break;
        }
        times.push(t);
        j += 1;
    }
    times.push(total);
    let caster = ctx.robot.is_caster();
    let mut samples = Vec::with_capacity(times.len());
    let mut m = 0;
    // Grid cells of the previous sample (time and parameter), restarted with each move.
    let (mut from_t, mut from_s) = (0, 0);
    for &t in &times {
        while m + 1 < moves.len() && t >= moves[m + 1].t0 {
            m += 1;
            (from_t, from_s) = (0, 0);
        }
        let mv = &moves[m];
        let (sigma, v, _) = mv.timing.eval(t - mv.t0, mv.len, &mv.sig, &mut from_t);
        let (c, gamma) = ctx.state(mv, sigma, &mut from_s)?;
        let twist = Twist2::new(c.dq[0] * v, c.dq[1] * v, c.dq[2] * v);
        let r = ctx.robot.rates_cs(c.pose.heading, c.cs, twist, gamma)?;
        samples.push(Sample {
            t,
            pose: c.pose,
            twist,
            wheel_rates: r.wheel,
            steer: if caster {
                Some((gamma, r.steer.unwrap_or([0.0; 3])))
            } else {
                None
            },
        });
    }
    Ok(Plan { samples })
}

/// Peaks of every motor quantity over a sampled plan, against the robot's limits: rates at the
/// samples, accelerations as differences of consecutive samples over their time step.
pub fn plan_peaks(plan: &Plan, robot: &RobotModel) -> Vec<Peak> {
    let chans = robot.channels();
    let value = |s: &Sample, ch: usize| -> f64 {
        if ch < 3 {
            s.wheel_rates[ch]
        } else {
            s.steer.map(|(_, r)| r[ch - 3]).unwrap_or(0.0)
        }
    };
    let mut out = Vec::new();
    for accel in [false, true] {
        for group in [0..3, 3..6] {
            if group.start >= chans {
                continue;
            }
            let quantity = Quantity::of(group.start, accel);
            let mut best = Peak {
                quantity,
                motor: 1,
                value: 0.0,
                t: 0.0,
                limit: if accel {
                    robot.accel_limit(group.start)
                } else {
                    robot.rate_limit(group.start)
                },
            };
            for ch in group {
                if accel {
                    for w in plan.samples.windows(2) {
                        let d = ((value(&w[1], ch) - value(&w[0], ch)) / (w[1].t - w[0].t)).abs();
                        if d > best.value * (1.0 + 1e-9) {
                            best.value = d;
                            best.motor = ch % 3 + 1;
                            best.t = w[1].t;
                        }
                    }
                } else {
                    for s in &plan.samples {
                        let r = value(s, ch).abs();
                        if r > best.value * (1.0 + 1e-9) {
                            best.value = r;
                            best.motor = ch % 3 + 1;
                            best.t = s.t;
                        }
                    }
                }
            }
            out.push(best);
        }
    }
    out
}

fn report(
    path: &Path,
    moves: &[Move],
    duration: f64,
    peaks: Vec<Peak>,
    retimed: Vec<Retiming>,
    active_w: Vec<(Limiter, f64)>,
    plan: &Plan,
) -> PlanReport {
    let mut active: Vec<(Limiter, f64)> = Vec::new();
    let total: f64 = active_w.iter().map(|a| a.1).sum();
    for (l, w) in active_w {
        match active.iter_mut().find(|a| a.0 == l) {
            Some(a) => a.1 += w,
            None => active.push((l, w)),
        }
    }
    if total > 0.0 {
        for a in &mut active {
            a.1 /= total;
        }
    }
    active.sort_by(|a, b| b.1.total_cmp(&a.1));
    let moves = moves
        .iter()
        .map(|m| {
            let dur = m.timing.duration(m.len);
            let peak = match &m.timing {
                MoveTiming::Profile { p, lambda } => p.peak_speed() * lambda,
                MoveTiming::Constant { v } => *v,
                MoveTiming::Grid { x, .. } => x.iter().fold(0.0_f64, |a, &b| a.max(b)).sqrt(),
            };
            MoveSummary {
                kind: match m.kind {
                    Kind::Travel { s0, s1 } => MoveKind::Travel { s0, s1 },
                    Kind::Turn { dir, .. } => MoveKind::Turn { angle: dir * m.len },
                },
                t0: m.t0,
                duration: dur,
                peak_speed: peak,
            }
        })
        .collect();
    let first = plan.samples.first();
    PlanReport {
        duration,
        path_length: path.length(),
        moves,
        peaks,
        retimed,
        active,
        starts_moving: first.is_some_and(|s| {
            s.twist.vx.hypot(s.twist.vy) > 1e-12 || s.twist.yaw_rate.abs() > 1e-12
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute force: the largest x ∈ [0, x_cap] for which the y-interval is non-empty, from
    /// every pair of a lower and an upper bound (y ≥ 0 and y ≤ y_max included).
    fn largest_start_pairwise(c: &CellConstraints, x_cap: f64, y_max: f64) -> f64 {
        let mut lower: Vec<(f64, f64)> = vec![(0.0, 0.0)];
        let mut upper: Vec<(f64, f64)> = vec![(y_max, 0.0)];
        for i in 0..c.n {
            lower.push((-c.hi[i], c.slope[i]));
            upper.push((c.hi[i], c.slope[i]));
        }
        let mut best = x_cap.min(c.x_max);
        for &(la, lb) in &lower {
            for &(ua, ub) in &upper {
                if lb - ub > 0.0 {
                    best = best.min((ua - la) / (lb - ub));
                }
            }
        }
        best.max(0.0)
    }

    #[test]
    fn heading_increment_series_is_accurate_to_rounding() {
        // Near the series' largest argument (|δ| just below 0.1 rad, |t| ≈ 0.05, where its last
        // term t¹¹/11 is ≈ 4e-16 of δ) and for small headings, so rounding is ≈ 1e-16: the
        // answer must be within 4e-16 of ψ + δ.
        for &psi in &[0.0, 0.3, -0.7, 1.0] {
            for &delta in &[0.0999, -0.0999, 0.08, -0.05, 0.01, 1e-9] {
                let (s, c) = f64::sin_cos(psi);
                let (sd, cd) = f64::sin_cos(psi + delta);
                let got = Hint {
                    psi,
                    cs: Some([c, s]),
                }
                .unwrap([cd, sd]);
                assert!(
                    (got - (psi + delta)).abs() <= 4e-16,
                    "ψ {psi} δ {delta}: {got} vs {}",
                    psi + delta
                );
            }
        }
    }

    #[test]
    fn time_optimal_timing_is_the_same_with_stored_and_rebuilt_cells() {
        let wps: Vec<[f64; 2]> = (0..8)
            .map(|k| [0.5 * k as f64, 0.4 * (0.9 * k as f64).sin()])
            .collect();
        let path = Path::spline(&wps).expect("spline");
        let heading = HeadingLaw::Tangent { offset: 0.3 };
        for name in ["sphere-omni", "caster3"] {
            let robot = RobotModel::from_description(
                &omnikin::description::RobotDescription::preset(name).expect("preset"),
            )
            .expect("model");
            let heading_cs = [0.3_f64.cos(), 0.3_f64.sin()];
            let ctx = Ctx {
                path: &path,
                heading: &heading,
                robot: &robot,
                heading_cs,
            };
            let opts = PlanOptions {
                timing: Timing::TimeOptimal {
                    limits: MotionLimits {
                        max_speed: 0.6,
                        max_accel: 1.0,
                        ..MotionLimits::default()
                    },
                },
                on_limit: OnLimit::Retime,
                rate: 100.0,
                initial_steer: InitialSteer::Aligned,
            };
            let moves = build_moves(&ctx, &opts).expect("moves");
            for mv in &moves {
                let (v, a, user) = user_limits(&opts, &mv.kind);
                let (kept, who_kept) =
                    time_optimal_storing(&robot, mv, v, a, user, usize::MAX).expect("timing");
                let (rebuilt, who_rebuilt) =
                    time_optimal_storing(&robot, mv, v, a, user, 0).expect("timing");
                let (MoveTiming::Grid { x: x1, t: t1 }, MoveTiming::Grid { x: x2, t: t2 }) =
                    (kept, rebuilt)
                else {
                    panic!("grid timings expected")
                };
                assert!(x1.len() > 16);
                assert_eq!(x1, x2, "{name}");
                assert_eq!(t1, t2, "{name}");
                assert_eq!(who_kept, who_rebuilt, "{name}");
            }
        }
    }

    proptest! {
        /// The forward-stepping cell search answers as the bisection does, wherever it starts.
        /// (`from` stays below the node count so that exact ties ahead of it are queried.)
        #[test]
        fn cell_from_matches_cell(
            steps in proptest::collection::vec(1e-3_f64..1.0, 1..40),
            x in prop_oneof![-1.0_f64..45.0, Just(f64::NAN), Just(f64::INFINITY)],
            from in 0usize..50,
        ) {
            let mut sig = vec![0.0];
            for h in steps {
                sig.push(sig[sig.len() - 1] + h);
            }
            // Arbitrary points, and every node ahead of the start (exact ties included).
            let nodes = (0..12).map(|j| sig[(from + j) % sig.len()]);
            for q in std::iter::once(x).chain(nodes) {
                prop_assert_eq!(cell_from(&sig, q, from), cell(&sig, q), "x {}", q);
            }
        }

        /// The heading increment between neighbouring grid nodes (series of `atan`) agrees with
        /// `atan2` to rounding, near and far from the hint, wrapped or not.
        #[test]
        fn heading_unwrap_matches_atan2(
            psi in -20.0_f64..20.0,
            delta in prop_oneof![-0.12_f64..0.12, -3.1_f64..3.1],
        ) {
            let (s, c) = psi.sin_cos();
            let hint = Hint { psi, cs: Some([c, s]) };
            let (sd, cd) = (psi + delta).sin_cos();
            let got = hint.unwrap([cd, sd]);
            let want = Hint::angle(psi).unwrap([cd, sd]);
            prop_assert!((got - want).abs() < 1e-13, "{} vs {}", got, want);
            prop_assert!((got - (psi + delta)).abs() < 1e-12, "{} vs {}", got, psi + delta);
        }

        #[test]
        fn reachability_step_matches_the_pairwise_lp(
            rows in proptest::collection::vec(
                (-50.0..50.0_f64, -50.0..50.0_f64, 0.1..100.0_f64), 1..13),
            x_cap in 0.0..20.0_f64,
            y_max in 0.0..20.0_f64,
        ) {
            let mut c = CellConstraints::new();
            for (k, &(cy, cx, bound)) in rows.iter().enumerate() {
                c.add(cy, cx, bound, k as u8);
            }
            let (x, _) = c.largest_start(x_cap, y_max);
            let want = largest_start_pairwise(&c, x_cap, y_max);
            prop_assert!((x - want).abs() <= 1e-9 * (1.0 + want), "{x} vs {want}");
            // And the forward step from there finds an admissible end value.
            let (y, _) = c.largest_end(x, y_max);
            prop_assert!(y >= 0.0 && y <= y_max * (1.0 + 1e-12) + 1e-12);
            for i in 0..c.n {
                let tol = 1e-7 * (1.0 + c.hi[i].abs() + (c.slope[i] * x).abs());
                prop_assert!(y <= c.hi[i] + c.slope[i] * x + tol, "upper {i}");
                prop_assert!(y >= -c.hi[i] + c.slope[i] * x - tol, "lower {i}");
            }
        }
    }
}
