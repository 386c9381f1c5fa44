//! The planner: path + heading law + timing → a sampled [`Plan`](crate::Plan) of wheel commands that
//! respects the robot's motor limits (paper 000, §5: `r_C(t)`, `ψ(t)` → wheel rates by
//! eqs. 5.6–5.7; likewise for the ballbot, paper 001, the caster base, paper 003, eq. 2, and
//! every omni and swerve drive, through the core's uniform inverse).
//!
//! # How a plan is made
//!
//! 1. **Moves.** The path is cut into *moves* that start and end at rest: at its stops
//!    ([`crate::path::Corners::Stop`]) and wherever the wheel rates per unit speed jump (the
//!    tangent or the heading rate `dψ/ds` jumps — e.g. where a fillet meets a leg under the
//!    tangent heading law; for set-point steering also where the curvature or the heading
//!    acceleration `ψ''` jumps, which a swerve's steer rates per unit speed follow); a jump in
//!    a motor rate at non-zero speed would need infinite motor acceleration. Under the tangent law (paper 000, eq. 5.5) a stop where the direction
//!    changes gets a **turn in place** from the old to the new direction. For set-point
//!    steering (swerve) a move whose start needs other module directions than the previous
//!    move ended with (a square's corner, a turn in place, given initial angles) is preceded
//!    by a **re-steer at rest**: the modules turn the shortest way (or flip, if the robot
//!    optimises its steering) at a rate timed like a turn in place, the robot standing still,
//!    so no module is asked to turn between two samples.
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
//!    motor's largest value on the move, down to 2 mm. The time-optimal timing, whose speed
//!    caps allow for the bulge between nodes and whose residual excesses are mended where they
//!    occur (step 4), starts from 15 cm (150 mrad) and refines at 20 %. The rows of `A` are the robot's motor
//!    **channels** ([`RobotModel::channel`]): its `N` wheels, then its `N` steer motors if it
//!    has steering. For the caster the steer angles `γ(σ)` obey `dγ/dσ = J2(θ, γ) q'(σ)`
//!    (paper 003, eq. 5), which does not depend on the timing, so they are integrated once
//!    along the grid (RK4). A swerve's steer angles are set-points, the module directions of
//!    the inverse at `q'(σ)`; its steer rates per unit speed follow from the derivative of the
//!    robot-frame twist along the move (`γ̇ = (u ẇ − w u̇)/(u² + w²)` for a module velocity
//!    `(u, w)`), so they are linear in `σ̇` too.
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
//!      cell's polygon whose end is reachable); the forward pass then accelerates from rest
//!      (or from a given start speed, [`plan_from_velocity`], which must be within the first
//!      node's reachable value) as hard as the cell allows without leaving the reachable set. No step can get stuck, and
//!      the joint limits of all motors are respected at every node. Jerk is not limited in
//!      this mode.
//! 4. **Sampling** at the requested rate: pose, world twist, motor rates from the core
//!    inverse kinematics ([`omnikin::Robot::inverse_accel`]; a swerve's steer angles from the
//!    previous sample's, so a stopped module keeps its angle). A move shorter than two sample periods
//!    (a tiny fillet arc or turn in place) is first slowed uniformly to last two, so some
//!    sample sees its motion. Finally every sample is
//!    checked against the limits (rates at each sample, accelerations as differences between
//!    consecutive samples); a residual excess from the grid approximation is removed by slowing
//!    the offending move further (profiles, constant speed), or, for the time-optimal timing,
//!    where it occurs: the grid stretch holding it gets four times the cells (or, at the finest
//!    cells, the limits of the cells around it are lowered) and the pass runs again. The
//!    time-optimal timing is also checked **between** the samples, cell by cell with the exact
//!    kinematics (`continuous.rs`), and an excess there is mended the same way.
//!
//! # Where each step lives
//!
//! | file | what |
//! |---|---|
//! | `options.rs` | the request: [`MotionLimits`], [`Timing`], [`OnLimit`], [`InitialSteer`], [`PlanOptions`] |
//! | `moves.rs` | step 1: cutting the path into moves (stops, jumps of `q'`, turns in place, re-steers at rest) |
//! | `geometry.rs` | step 2: a move's configuration `q(σ)`, `q'(σ)` and `A(σ)`, and the heading unwrap |
//! | `grid.rs` | step 2: the adaptive grid of a move and the cell lookup |
//! | `steer.rs` | step 2: the steer state along a move (caster: RK4 of paper 003, eq. 5; swerve: set-points), aligned start, grid step |
//! | `timing.rs` | step 3: a move's timing, its first timing (dilation or rejection), the requested limits |
//! | `time_optimal.rs` | step 3: the time-optimal reachability pass |
//! | `switches.rs` | step 3: the grid stretches where the time-optimal profile switches (refined before the final check) |
//! | `sample.rs` | step 4: sampling the timed moves |
//! | `continuous.rs` | step 4: the time-optimal timing checked between the samples, inside each cell |
//! | `report.rs` | the result: [`Planned`], [`PlanReport`], [`plan_peaks`] |
//! | this file | [`plan`]: the steps in order, the final check and slow-down |

mod cells;
mod continuous;
mod geometry;
mod grid;
mod limiter;
mod move_timing;
mod moves;
mod options;
mod report;
mod sample;
mod steer;
mod switches;
mod time_optimal;
mod timing;

pub use limiter::{Limiter, Retiming};
pub use options::{InitialSteer, MotionLimits, OnLimit, PlanOptions, StartVelocity, Timing};
pub use report::{MoveKind, MoveSummary, Peak, PlanReport, Planned, plan_peaks};

use crate::PlanningError;
use crate::error::Violation;
use crate::heading::HeadingLaw;
use crate::limits::{RATE_RANGE, SPEED_RANGE, check_range};
use crate::path::Path;
use crate::profile::ProfileKind;
use crate::robot::RobotModel;

use continuous::Excess;
use geometry::Ctx;
use grid::Move;
use move_timing::MoveTiming;
use moves::build_moves;
use report::report;
use sample::{resolve_short_moves, sample};
use switches::{SWITCH_ROUNDS, switch_stretches};
use time_optimal::time_optimal;
use timing::{initial_timing, note_retime, user_limits};

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
    plan_moves(path, heading, robot, opts, 0.0).map(|(_, planned)| planned)
}

/// Largest disagreement (m/s, rad/s) between a [`StartVelocity`] and the motion the path and
/// heading law give at the start speed: the first sample's velocity and yaw rate are the
/// path's (tangent × speed, `ψ'(0)` × speed), so they equal the given ones within it.
pub const START_TOLERANCE: f64 = 1e-9;

/// [`plan`] from a moving start: the robot moves at `start` (world frame) at the path's first
/// point, and the time-optimal pass starts at that speed instead of rest (its forward pass
/// begins at `x = ṡ²` of the start speed; module docs, step 3). The first sample's velocity
/// and yaw rate are the given ones within [`START_TOLERANCE`]; every limit is checked as in
/// [`plan`]. Used to re-plan on the move and splice the new plan into a running one. At rest
/// (zero velocity and yaw rate) it is [`plan`], sample for sample.
///
/// # Errors
/// As [`plan`], and [`PlanningError::InvalidParameter`] for a non-finite start velocity;
/// [`PlanningError::Infeasible`] when
/// * the timing is not [`Timing::TimeOptimal`] (the profiles start from rest);
/// * the velocity is off the path's first tangent by more than [`START_TOLERANCE`] (naming
///   the angle and the perpendicular part), or the yaw rate is not the heading law's at that
///   speed (naming both), or a yaw rate is given without a speed (a turn in place from a
///   yaw rate);
/// * a steerable robot is given initial steer angles ([`InitialSteer::Given`]): a moving start
///   needs its modules along the motion ([`InitialSteer::Aligned`]), not a re-steer at rest;
/// * the start speed is above what the speed limits allow at the start, or above the speed
///   from which the first move can still end at rest within the limits (naming the limit,
///   the largest start speed and the excess in %).
pub fn plan_from_velocity(
    path: &Path,
    heading: &HeadingLaw,
    robot: &RobotModel,
    opts: &PlanOptions,
    start: StartVelocity,
) -> Result<Planned, PlanningError> {
    for (name, v) in [
        ("start velocity vx", start.vx),
        ("start velocity vy", start.vy),
        ("start yaw rate", start.yaw_rate.unwrap_or(0.0)),
    ] {
        if !v.is_finite() {
            return Err(PlanningError::InvalidParameter {
                name,
                value: v,
                rule: "must be finite (m/s, rad/s)",
            });
        }
    }
    let speed = start.speed();
    let yaw_rate = start.yaw_rate.unwrap_or(0.0);
    if speed == 0.0 && yaw_rate == 0.0 {
        return plan(path, heading, robot, opts);
    }
    if speed == 0.0 {
        return Err(PlanningError::Infeasible(format!(
            "a start yaw rate ({yaw_rate} rad/s) needs a start speed: a plan starts at rest or \
             moving along its path, and its heading follows the arc length"
        )));
    }
    if !matches!(opts.timing, Timing::TimeOptimal { .. }) {
        return Err(PlanningError::Infeasible(
            "a start velocity needs the time-optimal timing (the trapezoid, S-curve and \
             constant-speed timings start from rest or at their own speed)"
                .into(),
        ));
    }
    if robot.steerable() && matches!(opts.initial_steer, InitialSteer::Given(_)) {
        return Err(PlanningError::Infeasible(
            "a moving start needs the steer angles along the motion (aligned), not given \
             initial steer angles (their re-steer happens at rest)"
                .into(),
        ));
    }
    let first = path.at_side(0.0, crate::heading::Side::After);
    let [tx, ty] = first.tangent;
    let perp = (start.vx * ty - start.vy * tx).abs();
    let along = start.vx * tx + start.vy * ty;
    if perp > START_TOLERANCE || along <= 0.0 {
        return Err(PlanningError::Infeasible(format!(
            "the start velocity ({}, {}) m/s is {:.4}° off the path's first tangent ({tx:.6}, \
             {ty:.6}): its part across the path is {perp:.3e} m/s (at most {START_TOLERANCE:e})",
            start.vx,
            start.vy,
            (start.vx * ty - start.vy * tx)
                .atan2(along)
                .abs()
                .to_degrees()
        )));
    }
    let dpsi = match heading {
        HeadingLaw::Constant(_) => 0.0,
        HeadingLaw::Tangent { .. } => first.curvature,
        HeadingLaw::Profile(p) => p.at(0.0, crate::heading::Side::After).1,
    };
    if let Some(w) = start.yaw_rate
        && (w - dpsi * speed).abs() > START_TOLERANCE
    {
        return Err(PlanningError::Infeasible(format!(
            "the start yaw rate {w} rad/s is not the heading law's {:.9} rad/s at the start \
             speed {speed} m/s (dψ/ds = {dpsi:.9} rad/m at the start; off by {:.3e} rad/s)",
            dpsi * speed,
            w - dpsi * speed
        )));
    }
    plan_moves(path, heading, robot, opts, speed * speed).map(|(_, planned)| planned)
}

/// The context of a plan: the request's path, heading law and robot with what is derived
/// from them once.
fn context<'a>(
    path: &'a Path,
    heading: &'a HeadingLaw,
    robot: &'a RobotModel,
    opts: &PlanOptions,
) -> Ctx<'a> {
    let heading_cs = match heading {
        HeadingLaw::Constant(a) | HeadingLaw::Tangent { offset: a } => {
            let (s, c) = a.sin_cos();
            [c, s]
        }
        HeadingLaw::Profile(_) => [1.0, 0.0],
    };
    Ctx {
        path,
        heading,
        robot,
        heading_cs,
        set_point: robot.model.kind().steer_is_set_point(),
        grid_tol: grid::grid_tol(&opts.timing),
        grid_max: grid::grid_max(&opts.timing),
        linear: geometry::linear_inverse(robot),
    }
}

/// [`plan`], also returning the timed moves (the plan's continuous timing, which the tests
/// evaluate between the samples).
fn plan_moves(
    path: &Path,
    heading: &HeadingLaw,
    robot: &RobotModel,
    opts: &PlanOptions,
    x_start: f64,
) -> Result<(Vec<Move>, Planned), PlanningError> {
    validate_request(heading, opts)?;
    let ctx = context(path, heading, robot, opts);
    let mut moves = build_moves(&ctx, opts)?;
    if x_start > 0.0 {
        // Only a travel move can start moving (a moving start has no turn in place or
        // re-steer before it: `plan_from_velocity` takes aligned steering).
        if !matches!(moves[0].kind, geometry::Kind::Travel { .. }) {
            return Err(PlanningError::Infeasible(
                "a moving start needs the plan to begin by travelling along the path".into(),
            ));
        }
        moves[0].x_start = x_start;
    }
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
        let (mut timing, mut limiters) = initial_timing(robot, mv, opts, i, &mut retimed)?;
        if matches!(opts.timing, Timing::TimeOptimal { .. }) {
            // Finer cells where the profile switches (see `switches.rs`).
            let (_, a_user, _) = user_limits(robot, opts, &mv.kind);
            for _ in 0..SWITCH_ROUNDS {
                mv.timing = timing.clone();
                let js = switch_stretches(mv, a_user);
                let Some(finer) = (if js.is_empty() {
                    None
                } else {
                    ctx.refine(mv, &js, switches::SWITCH_FACTOR)?
                }) else {
                    break;
                };
                *mv = finer;
                (timing, limiters) = initial_timing(robot, mv, opts, i, &mut retimed)?;
            }
        }
        mv.timing = timing;
        t0 += mv.timing.duration(mv.len);
        active_w.extend(limiters);
    }
    // Sample, check strictly, slow down what still exceeds (grid approximation), repeat.
    let mut checked = vec![false; moves.len()];
    for round in 0..25 {
        resolve_short_moves(&mut moves, opts.rate);
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
        // The time-optimal timing between the samples too (the other timings' first timing
        // comes from dense peaks of the whole move): (plan time, ratio) of every cell's worst.
        // A move is checked again only after its timing changed.
        let mut between: Vec<(f64, f64, Excess)> = Vec::new();
        if matches!(opts.timing, Timing::TimeOptimal { .. }) {
            for (mv, done) in moves.iter().zip(checked.iter_mut()) {
                if *done {
                    continue;
                }
                for e in ctx.continuous_excesses(mv)? {
                    between.push((mv.t0 + e.t, e.ratio, e));
                }
                *done = true;
            }
        }
        match worst {
            None if between.is_empty() => {
                let report = report(
                    path,
                    &moves,
                    plan.duration(),
                    peaks,
                    retimed,
                    active_w,
                    &plan,
                );
                return Ok((moves, Planned { plan, report }));
            }
            _ if round < 24 && matches!(opts.timing, Timing::TimeOptimal { .. }) => {
                for m in slow_down_locally(&ctx, opts, &mut moves, &plan, &between)? {
                    checked[m] = false;
                }
            }
            Some((p, ratio)) if round < 24 => slow_down(opts, &mut moves, &mut retimed, *p, ratio)?,
            None => {
                let (t, _, e) = between
                    .iter()
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .expect("an excess between the samples");
                let (quantity, motor) = robot.channel(e.channel, e.accel);
                return Err(PlanningError::Infeasible(format!(
                    "could not bring {} {} within {} between the samples after repeated \
                     slow-downs ({:.4} times the limit at t = {t:.4} s)",
                    quantity.motor(),
                    motor,
                    quantity.key(),
                    e.ratio,
                )));
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

/// Checks the request before anything is built: the heading law, the sampling rate, the
/// timing's motion limits and the given initial steer angles, each against its
/// range in [`crate::limits`].
fn validate_request(heading: &HeadingLaw, opts: &PlanOptions) -> Result<(), PlanningError> {
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
    Ok(())
}

/// Cells on either side of a residual excess whose motor limits the time-optimal pass lowers
/// when the grid there is already at its finest ([`slow_down_locally`]): the excess is seen
/// between two samples, which may straddle a node.
const SLOW_CELLS: usize = 2;

/// The factor on the cells of a grid stretch holding a residual excess ([`slow_down_locally`]).
const EXCESS_FACTOR: usize = 4;

/// For the time-optimal timing: removes **every** residual excess the samples show (a rate above
/// its limit at a sample, an acceleration — the difference of two samples over their time
/// step — above its limit) and every one `between` them (plan time, ratio; from
/// [`Ctx::continuous_excesses`]), each where it is. The grid stretches that hold one get
/// [`EXCESS_FACTOR`] times the cells ([`Ctx::refine`]: the excess is the grid's interpolation residue, which shrinks with
/// the cells); where a stretch is already at [`grid::GRID_MIN`], the motor limits of the cells
/// within [`SLOW_CELLS`] of the excess are lowered by its ratio (and 0.5 % more). Then the pass
/// of each move concerned runs again (their indices are returned). Lowering the whole move's limits (as [`slow_down`] does
/// for the other timings) would slow every stretch for a local residue.
fn slow_down_locally(
    ctx: &Ctx,
    opts: &PlanOptions,
    moves: &mut [Move],
    plan: &crate::Plan,
    between: &[(f64, f64, Excess)],
) -> Result<Vec<usize>, PlanningError> {
    let robot = ctx.robot;
    let n = robot.wheels();
    let chans = robot.channels();
    let value = |s: &crate::plan::Sample, ch: usize| report::channel_value(s, n, ch);
    // Per move: the stretches to refine, and per cell the factor its limits would get.
    let mut stretches: Vec<Vec<usize>> = vec![Vec::new(); moves.len()];
    let mut factor: Vec<Vec<f64>> = vec![Vec::new(); moves.len()];
    let mut note = |t: f64, ratio: f64, moves: &[Move]| {
        let m = moves.iter().rposition(|mv| mv.t0 <= t).unwrap_or(0);
        let mv = &moves[m];
        let MoveTiming::Grid { t: times, .. } = &mv.timing else {
            return;
        };
        let (sigma, _, _) = mv.timing.eval(t - mv.t0, mv.len, &mv.sig, &mut 0);
        let j = cells::cell(&mv.bounds, sigma);
        if !stretches[m].contains(&j) {
            stretches[m].push(j);
        }
        let cells = times.len() - 1;
        let f = &mut factor[m];
        if f.is_empty() {
            *f = vec![1.0; cells];
        }
        let k = cells::cell(times, t - mv.t0);
        for v in &mut f[k.saturating_sub(SLOW_CELLS)..=(k + SLOW_CELLS).min(cells - 1)] {
            *v = v.min(0.995 / ratio);
        }
    };
    for ch in 0..chans {
        if let Some(l) = robot.rate_limit(ch) {
            for s in &plan.samples {
                let r = value(s, ch).abs() / l;
                if r > 1.0 + 1e-9 {
                    note(s.t, r, moves);
                }
            }
        }
        if let Some(l) = robot.accel_limit(ch) {
            for w in plan.samples.windows(2) {
                let r = ((value(&w[1], ch) - value(&w[0], ch)) / (w[1].t - w[0].t)).abs() / l;
                if r > 1.0 + 1e-9 {
                    note(w[0].t, r, moves);
                    note(w[1].t, r, moves);
                }
            }
        }
    }
    for &(t, ratio, _) in between {
        note(t, ratio, moves);
    }
    let mut retimed = Vec::new();
    for (m, ((mv, f), js)) in moves.iter_mut().zip(factor).zip(stretches).enumerate() {
        if f.is_empty() {
            continue;
        }
        retimed.push(m);
        if let Some(finer) = ctx.refine(mv, &js, EXCESS_FACTOR)? {
            *mv = finer;
        } else if mv.limit_scale.is_empty() {
            mv.limit_scale = f;
        } else {
            for (s, g) in mv.limit_scale.iter_mut().zip(f) {
                *s *= g;
            }
        }
        let (v_user, a_user, user) = user_limits(robot, opts, &mv.kind);
        let (timing, _) = time_optimal(robot, mv, v_user, a_user, user)?;
        mv.timing = timing;
    }
    Ok(retimed)
}

/// Slows down the move that holds the worst excess `p` (`ratio` = peak / limit, > 1) found on
/// the samples, a residue of the grid approximation, for the profile and constant-speed
/// timings: by a further time dilation. Refuses instead under [`OnLimit::Reject`]. (The
/// time-optimal timing is mended by [`slow_down_locally`].)
fn slow_down(
    opts: &PlanOptions,
    moves: &mut [Move],
    retimed: &mut Vec<Retiming>,
    p: Peak,
    ratio: f64,
) -> Result<(), PlanningError> {
    let idx = moves.iter().rposition(|m| m.t0 <= p.t).unwrap_or(0);
    if opts.on_limit == OnLimit::Reject {
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
            note_retime(retimed, idx, *lambda, limiter);
        }
        MoveTiming::Constant { v } => {
            *v *= 0.999 / f;
            if let Timing::ConstantSpeed { speed } = opts.timing {
                note_retime(retimed, idx, *v / speed, limiter);
            }
        }
        MoveTiming::Grid { .. } => {
            // Only the time-optimal timing makes grid timings, and it slows down locally.
            unreachable!("grid timings are slowed down by slow_down_locally")
        }
    }
    Ok(())
}

#[cfg(test)]
mod continuous_tests;
#[cfg(test)]
mod tests;
