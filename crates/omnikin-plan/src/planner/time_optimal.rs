//! [`Timing::TimeOptimal`](super::Timing::TimeOptimal): the backward reachability pass and
//! the greedy forward pass over `x = σ̇²` on a move's grid (module docs, step 3; Pham & Pham,
//! "TOPP-RA"), with each cell's linear constraints in [`CellConstraints`].

use crate::PlanningError;
use crate::robot::{MAX_CHANNELS, RobotModel};

use super::grid::Move;
use super::limiter::{Limiter, MARGIN};
use super::move_timing::MoveTiming;

/// Most constraints of a grid cell: the requested acceleration plus two per motor channel.
const CELL_MAX: usize = 1 + 2 * MAX_CHANNELS;

/// Up to this many cells the time-optimal pass keeps each cell's constraints from the
/// backward pass for the forward one (≤ 17 bytes a constraint, ≈ 11 MB at most) instead of
/// rebuilding them.
const STORED_CELLS: usize = 25_000;

/// The constraints of one grid cell in the unknowns `x = x_k` (start) and `y = x_{k+1}`
/// (end): for each `i`, `−hi[i] + slope[i]·x ≤ y ≤ hi[i] + slope[i]·x` (every constraint is
/// a bound on a magnitude, so the band is symmetric), plus `x ≤ x_max` from constraints that
/// do not involve `y`. `who[i]` names the limit (0: the requested acceleration, `1 + ch`:
/// motor channel `ch`'s acceleration limit).
#[derive(Clone)]
pub(super) struct CellConstraints {
    pub(super) hi: [f64; CELL_MAX],
    pub(super) slope: [f64; CELL_MAX],
    pub(super) who: [u8; CELL_MAX],
    pub(super) n: usize,
    pub(super) x_max: f64,
    pub(super) x_who: u8,
}

impl CellConstraints {
    pub(super) fn new() -> Self {
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
    pub(super) fn add(&mut self, c_y: f64, c_x: f64, bound: f64, who: u8) {
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
    pub(super) fn largest_start(&self, x_cap: f64, y_max: f64) -> (f64, Option<u8>) {
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
    pub(super) fn largest_end(&self, x: f64, y_max: f64) -> (f64, Option<u8>) {
        largest_end(&self.rows()[..self.n], &self.who[..self.n], x, y_max)
    }

    /// The constraints as rows `[hi, slope]` (the first `n` are set).
    fn rows(&self) -> [[f64; 2]; CELL_MAX] {
        core::array::from_fn(|i| [self.hi[i], self.slope[i]])
    }
}

/// [`CellConstraints::largest_end`] over constraint rows `[hi, slope]` and their limits `who`
/// (as kept between the passes).
fn largest_end(rows: &[[f64; 2]], who: &[u8], x: f64, y_max: f64) -> (f64, Option<u8>) {
    let mut y = y_max;
    let mut by = None;
    let mut floor = 0.0_f64;
    for (&[h, slope], &w) in rows.iter().zip(who) {
        let bx = slope * x;
        let hi = h + bx;
        if hi < y {
            y = hi;
            by = Some(w);
        }
        floor = floor.max(-h + bx);
    }
    // x lies in the reachable set, so floor ≤ y up to rounding.
    (y.max(floor.min(y_max)).max(0.0), by)
}

/// The time-optimal timing of one move (see the module docs): a reachability pass backward
/// from rest at the end, then the greedy forward pass from the move's start (rest, or
/// `mv.x_start` for a plan that starts moving), on `x = σ̇²`.
/// Returns the grid timing and, per cell, what limited it.
pub(super) fn time_optimal(
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
pub(super) fn time_optimal_storing(
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
    // The final check's per-cell factors on the motor limits (1 where it found no excess): a
    // cell's accelerations use its own, a node's rate cap the lower of its two cells'.
    let scale = |k: usize| mv.limit_scale.get(k).copied().unwrap_or(1.0);
    let node_scale = |k: usize| {
        if mv.limit_scale.is_empty() {
            1.0
        } else {
            scale(k.saturating_sub(1)).min(scale(k.min(n - 1)))
        }
    };
    let motor = |ch: usize, accel: bool| {
        let (quantity, motor) = robot.channel(ch, accel);
        Limiter::Motor { quantity, motor }
    };
    // The limits the pass aims at, once per move and infinite for a motor without one: then
    // neither its speed cap `(l/|A|)²` nor its acceleration test `… > l` below ever binds.
    let rate_limits: [f64; MAX_CHANNELS] =
        core::array::from_fn(|ch| robot.rate_limit(ch).map_or(f64::INFINITY, |l| l * MARGIN));
    let accel_limits: [f64; MAX_CHANNELS] =
        core::array::from_fn(|ch| robot.accel_limit(ch).map_or(f64::INFINITY, |l| l * MARGIN));
    // Speed caps on x = σ̇²: the requested speed and every motor's rate limit.
    let mut cap = vec![0.0; n + 1];
    let mut cap_src = vec![user.0; n + 1];
    for k in 0..=n {
        let mut c = v_user * v_user;
        let mut src = user.0;
        let ks = node_scale(k);
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
            let l = rate_limits[ch] * ks;
            if a > 0.0 && (l / a).powi(2) < c {
                c = (l / a).powi(2);
                src = motor(ch, false);
            }
        }
        cap[k] = c;
        cap_src[k] = src;
    }
    // Constraints of cell k: requested path acceleration |y − x| ≤ 2h a_user, and each motor's
    // acceleration |A σ̈ + A' x| ≤ limit at both ends, σ̈ = (y − x)/(2h). A motor's constraint
    // is left out where the others imply it — where even |A| a_user + |A'| cap, the largest it
    // can reach with |σ̈| ≤ a_user and x within the node's speed cap, is within the limit — so
    // on a stretch far from the motors' acceleration limits a cell is a one-constraint LP.
    let fill = |c: &mut CellConstraints, k: usize| {
        let i2h = 1.0 / (2.0 * (sig[k + 1] - sig[k]));
        let (a0, b0, a1, b1) = (&mv.a[k], &mv.b_out[k], &mv.a[k + 1], &mv.b_in[k + 1]);
        let (x0, x1) = (cap[k], cap[k + 1]);
        let ks = scale(k);
        c.clear();
        c.add(i2h, -i2h, a_user, 0);
        for ch in 0..chans {
            let l = accel_limits[ch] * ks;
            if a0[ch].abs() * a_user + b0[ch].abs() * x0 > l {
                c.add(a0[ch] * i2h, b0[ch] - a0[ch] * i2h, l, 1 + ch as u8);
            }
            if a1[ch].abs() * a_user + b1[ch].abs() * x1 > l {
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
    // forward pass reuses the cells' constraints (17 bytes each, a cell's count, pushed in the
    // backward order) up to STORED_CELLS cells and rebuilds them beyond, so a long fine grid
    // does not hold them all.
    let store = n <= stored_cells;
    let cap_rows = if store { 2 * n } else { 0 };
    let (mut kept_rows, mut kept_who) =
        (Vec::with_capacity(cap_rows), Vec::with_capacity(cap_rows));
    let mut kept_n: Vec<u8> = Vec::with_capacity(if store { n } else { 0 });
    let mut reach = vec![0.0; n + 1];
    let mut reach_src = vec![user.0; n + 1];
    for k in (0..n).rev() {
        fill(&mut c, k);
        let (x, who) = c.largest_start(cap[k], reach[k + 1]);
        reach[k] = x;
        reach_src[k] = who.map_or(cap_src[k], name);
        if store {
            kept_n.push(c.n as u8);
            for i in 0..c.n {
                kept_rows.push([c.hi[i], c.slope[i]]);
                kept_who.push(c.who[i]);
            }
        }
    }
    // A move that starts moving (`x_start > 0`): its start must be within the speed caps and
    // the reachable set, up to the rounding of a speed read back from a plan's points.
    if mv.x_start > 0.0 {
        start_within(mv, cap[0], cap_src[0], reach[0], reach_src[0])?;
    }
    // Forward: from the start (rest, or `x_start`), the largest admissible end value that
    // stays reachable.
    let mut x = vec![0.0; n + 1];
    x[0] = mv.x_start;
    let mut who = Vec::with_capacity(n);
    let mut end = kept_rows.len();
    for k in 0..n {
        let (y, limiter) = if store {
            let m = usize::from(kept_n[n - 1 - k]);
            let start = end - m;
            let cell = largest_end(
                &kept_rows[start..end],
                &kept_who[start..end],
                x[k],
                reach[k + 1],
            );
            end = start;
            cell
        } else {
            fill(&mut c, k);
            c.largest_end(x[k], reach[k + 1])
        };
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

/// Relative excess of a start `x = σ̇²` over its bound that counts as rounding: a speed read
/// back from a plan's f32 points (the link's) is within 1e-7 of the planner's, whose speed
/// caps stay [`MARGIN`] (1e-4) below every motor limit.
const START_ROUNDING: f64 = 1e-6;

/// Checks a moving start against the first node's speed cap `cap` (set by `cap_src`) and the
/// largest start `reach` from which the move's end is reachable at rest within every limit (set
/// by `reach_src`): an error names the limit and the excess.
fn start_within(
    mv: &Move,
    cap: f64,
    cap_src: Limiter,
    reach: f64,
    reach_src: Limiter,
) -> Result<(), PlanningError> {
    let v = mv.x_start.sqrt();
    let pct = |bound: f64| 100.0 * (v / bound.sqrt() - 1.0);
    if mv.x_start > cap * (1.0 + START_ROUNDING) {
        return Err(PlanningError::Infeasible(format!(
            "start speed {v:.6} m/s is above the {:.6} m/s that {cap_src} allows at the start \
             of the path (by {:.3} %)",
            cap.sqrt(),
            pct(cap)
        )));
    }
    if mv.x_start > reach * (1.0 + START_ROUNDING) {
        return Err(PlanningError::Infeasible(format!(
            "start speed {v:.6} m/s is above the {2:.6} m/s from which the first move \
             ({0:.6} m along the path) can still end at rest within {reach_src} (by {1:.3} %)",
            mv.len,
            pct(reach),
            reach.sqrt()
        )));
    }
    Ok(())
}
