//! Cutting the path into moves that start and end at rest (module docs, step 1): at stops
//! and where `q'` jumps, with a turn in place at a stop where the tangent heading law changes
//! direction; each move's grid is built as it is cut ([`build_moves`]).

use crate::PlanningError;
use crate::heading::{HeadingLaw, Side};
use crate::limits::MAX_PLAN_GRID_CELLS;
use crate::path::Path;
use omnikin::{Actuators, MAX_WHEELS, wrap_angle};

use super::geometry::{Config, Ctx, Hint, Kind, Steer, body_per_speed};
use super::grid::{MIN_CELLS, Move};
use super::options::{InitialSteer, PlanOptions};
use super::steer::{aligned_steer, grid_step};

/// Cuts the path into moves (see the module docs) and builds their grids.
pub(super) fn build_moves(ctx: &Ctx, opts: &PlanOptions) -> Result<Vec<Move>, PlanningError> {
    let path = ctx.path;
    let len = path.length();
    let heading_rate = |s: f64, side: Side, curvature: f64| match ctx.heading {
        HeadingLaw::Constant(_) => 0.0,
        HeadingLaw::Tangent { .. } => curvature,
        HeadingLaw::Profile(p) => p.at(s, side).1,
    };
    // A set-point steering's (a swerve's) steer rates per unit speed follow the robot-frame
    // twist's rate along the path, which holds the curvature: where it jumps (a fillet meeting
    // a leg) the steer rates would jump at speed, an infinite steer acceleration, so the
    // curvature counts as part of `q'` for those kinds.
    let steer_curvature = |curvature: f64| if ctx.set_point { curvature } else { 0.0 };
    // Likewise the heading acceleration `ψ''`: under the tangent law it is `dκ/ds`, which
    // jumps at a C² spline's waypoints (a profile's `ψ''` is continuous, a constant's 0).
    let heading_accel = |s: f64, side: Side| match ctx.heading {
        HeadingLaw::Tangent { .. } if ctx.set_point => curvature_rate(path, s, side),
        _ => 0.0,
    };
    // Cut points: stops, and joins where q' jumps.
    let mut cuts: Vec<f64> = Vec::new();
    for j in path.joins() {
        let before = [
            j.before.tangent[0],
            j.before.tangent[1],
            heading_rate(j.s, Side::Before, j.before.curvature),
            steer_curvature(j.before.curvature),
            heading_accel(j.s, Side::Before),
        ];
        let after = [
            j.after.tangent[0],
            j.after.tangent[1],
            heading_rate(j.s, Side::After, j.after.curvature),
            steer_curvature(j.after.curvature),
            heading_accel(j.s, Side::After),
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
                steer_curvature(p_before.curvature),
                heading_accel(s, Side::Before),
            ];
            let after = [
                p_after.tangent[0],
                p_after.tangent[1],
                heading_rate(s, Side::After, p_after.curvature),
                steer_curvature(p_after.curvature),
                heading_accel(s, Side::After),
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
    let step = grid_step(ctx.robot, ctx.grid_max);
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
            aligned_steer(ctx.robot, &c)?
        }
    };
    let n = ctx.robot.wheels();
    if !ctx.robot.steerable() {
        gamma = [0.0; MAX_WHEELS];
    }
    gamma[n..].fill(0.0);
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
                if ctx.set_point {
                    let c = ctx.config(&kind, delta.abs(), 0.0, Hint::angle(psi));
                    if let Some(mv) = resteer(ctx, &c, gamma, step)? {
                        gamma = *mv.gamma.last().unwrap_or(&gamma);
                        moves.push(mv);
                    }
                }
                let mv = ctx.build_move(kind, delta.abs(), psi, gamma, step, &[])?;
                psi += delta;
                gamma = *mv.gamma.last().unwrap_or(&gamma);
                moves.push(mv);
            }
        }
        let kind = Kind::Travel { s0, s1 };
        let kinks = move_kinks(path.piece_starts(), ctx.heading.knots(), s0, s1);
        if ctx.set_point {
            let c = ctx.config(&kind, s1 - s0, 0.0, Hint::angle(psi));
            if let Some(mv) = resteer(ctx, &c, gamma, step)? {
                gamma = *mv.gamma.last().unwrap_or(&gamma);
                moves.push(mv);
            }
        }
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

/// Closest two kinks of a move may be (m): nearer ones are one node (a stretch between them
/// would be a cell of rounding error, and the one-sided derivatives there meaningless).
pub(super) const KINK_TOL: f64 = 1e-9;

/// The kinks of the travel move from `s0` to `s1` (σ = s − s0, where `A'` may jump): the
/// path's piece starts and the heading profile's knots strictly inside the move, merged into
/// one increasing sequence without duplicates (within [`KINK_TOL`], and not within it of
/// either end). Both lists are increasing on their own but interleave: chained unsorted, a
/// waypoint profile's knots (the spline's own joins again) made the grid run backwards.
fn move_kinks(piece_starts: &[f64], knots: &[f64], s0: f64, s1: f64) -> Vec<f64> {
    let mut kinks: Vec<f64> = piece_starts
        .iter()
        .chain(knots)
        .filter(|&&k| k > s0 + KINK_TOL && k < s1 - KINK_TOL)
        .map(|k| k - s0)
        .collect();
    kinks.sort_by(f64::total_cmp);
    kinks.dedup_by(|b, a| *b - *a <= KINK_TOL);
    kinks
}

/// For set-point steering (swerve): the re-steer at rest that turns the modules from `gamma`
/// to the directions the motion starting at configuration `c` needs (the inverse's set-points
/// at `gamma`, so the steering optimisation, if on, picks the shorter of turning and
/// reversing), or `None` when no module turns by more than `RESTEER_MIN`. Without it the
/// modules would be asked to turn between two samples at the start of the motion.
fn resteer(ctx: &Ctx, c: &Config, gamma: Steer, step: f64) -> Result<Option<Move>, PlanningError> {
    let n = ctx.robot.wheels();
    let want = ctx
        .robot
        .model
        .inverse(body_per_speed(c), &Actuators::at_steer(&gamma))?
        .steer_angles;
    let mut delta = [0.0; MAX_WHEELS];
    for i in 0..n {
        delta[i] = wrap_angle(want[i] - gamma[i]);
    }
    let len = delta.iter().fold(0.0_f64, |m, d| m.max(d.abs()));
    if len <= RESTEER_MIN {
        return Ok(None);
    }
    let kind = Kind::Resteer {
        x: c.pose.x,
        y: c.pose.y,
        psi: c.pose.heading,
        from: gamma,
        delta,
    };
    Ok(Some(ctx.build_move(
        kind,
        len,
        c.pose.heading,
        gamma,
        step,
        &[],
    )?))
}

/// The smallest module turn (rad) that gets a re-steer move of its own; below it the first
/// samples of the motion turn the modules (well within any steer-rate limit at 1 kHz).
const RESTEER_MIN: f64 = 1e-6;

/// `true` when two derivative vectors `q'` (with the curvature and heading acceleration for
/// set-point steering) differ (a jump in the motor rates per unit speed). The heading
/// acceleration is a finite difference ([`curvature_rate`]), so its tolerance is wider.
fn jumps(a: [f64; 5], b: [f64; 5]) -> bool {
    let tol = [1e-9, 1e-9, 1e-9, 1e-9, 1e-6];
    (0..5).any(|i| (a[i] - b[i]).abs() > tol[i] * (1.0 + a[i].abs().max(b[i].abs())))
}

/// Step of the one-sided difference of [`curvature_rate`], m.
const CURVATURE_STEP: f64 = 1e-5;

/// `dκ/ds` at `s` seen from `side` (1/m²): a second-order one-sided difference of the
/// curvature over [`CURVATURE_STEP`] on that side, within the path (0 at an end it faces).
fn curvature_rate(path: &Path, s: f64, side: Side) -> f64 {
    let h = match side {
        Side::Before => -CURVATURE_STEP,
        Side::After => CURVATURE_STEP,
    };
    let (s1, s2) = (s + h, s + 2.0 * h);
    if s2 < 0.0 || s2 > path.length() {
        return 0.0;
    }
    let k = |s: f64| path.at_side(s, side).curvature;
    (-3.0 * k(s) + 4.0 * k(s1) - k(s2)) / (2.0 * h)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinks_are_merged_in_order_without_duplicates() {
        // A spline's joins and a waypoint profile's knots at (almost) the same arc lengths.
        let pieces = [0.0, 0.858, 1.481, 2.339];
        let knots = [0.0, 0.858 + 1e-12, 1.481, 2.0, 2.339];
        assert_eq!(
            move_kinks(&pieces, &knots, 0.0, 2.339),
            vec![0.858, 1.481, 2.0]
        );
        // Relative to the move's start, only those strictly inside it.
        let k = move_kinks(&pieces, &knots, 0.858, 2.0);
        assert_eq!(k.len(), 1);
        assert!((k[0] - (1.481 - 0.858)).abs() < 1e-15);
    }
}
