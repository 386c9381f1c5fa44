//! Where the time-optimal profile switches (module docs, step 3): the pass's path
//! acceleration `σ̈` is constant on each grid cell, so where the optimum switches between
//! accelerating, cruising and braking inside a cell the cell is crossed on a compromise — a
//! 10 cm cell at the end of a move braked at `x_k/(2h)` instead of the full deceleration over
//! the last few centimetres (5.6 % of the duration at 0.66 m/s and 5 m/s² against the
//! reference solver of `tests/reference.rs`). [`switch_stretches`] finds the grid stretches
//! holding such a switch, which the planner refines ([`super::Ctx::refine`], [`SWITCH_FACTOR`]
//! times the cells) before the final check, so the lost time shrinks with the cells.

use super::grid::Move;
use super::move_timing::MoveTiming;

/// A cell cruises when its path acceleration is below this fraction of the requested one.
const CRUISE: f64 = 1e-6;

/// A cell accelerating or braking at this fraction of the requested path acceleration or more
/// is at it (it loses nothing where it meets a cruise).
const FULL: f64 = 0.999;

/// Rounds of refinement at the switches (each [`SWITCH_FACTOR`] times the cells of the
/// stretches holding one, so the time lost at a switch shrinks as many times). Two rounds of 4× brought the reference
/// test's median from +0.023 % to +0.004 % (worst +0.53 % either way) but cost 2.3 times the
/// instructions of one on the 20-waypoint benchmark plan.
pub(super) const SWITCH_ROUNDS: usize = 1;

/// The factor on the cells of a stretch holding a switch. Against `tests/reference.rs`'s 40
/// cases, on 10 cm cells: 4× gave median +0.023 %, worst +0.530 %; 3× median +0.044 %, worst
/// +0.530 % (the same case, not a switch's loss); 2× worst +1.250 %, over the test's 1 %. On
/// the 15 cm cells of [`super::grid::GRID_MAX_TIME_OPTIMAL`]: 4× median +0.036 %, worst
/// +0.611 %; 3× worst +1.132 % (a ballbot spinning along a filleted path, a switch's loss);
/// 5× median +0.027 %, worst +0.534 % for 8 % more instructions than 4×.
pub(super) const SWITCH_FACTOR: usize = 4;

/// The stretches (indices into `mv.bounds`) holding a switch: a cell neither cruising nor at the full requested path acceleration `a_user`
/// next to a cell that cruises ([`CRUISE`]) or accelerates the other way (empty for timings other than the time-optimal one).
pub(super) fn switch_stretches(mv: &Move, a_user: f64) -> Vec<usize> {
    let MoveTiming::Grid { x, .. } = &mv.timing else {
        return Vec::new();
    };
    let sig = &mv.sig;
    let cells = sig.len() - 1;
    let u: Vec<f64> = (0..cells)
        .map(|k| (x[k + 1] - x[k]) / (2.0 * (sig[k + 1] - sig[k])))
        .collect();
    let mut out: Vec<usize> = Vec::new();
    // The stretch of each cell, walking the stretches' cell counts.
    let (mut j, mut end) = (0, mv.cells.first().copied().unwrap_or(0));
    for k in 0..cells {
        while k >= end && j + 1 < mv.cells.len() {
            j += 1;
            end += mv.cells[j];
        }
        let cruise = |o: usize| u[o].abs() <= CRUISE * a_user;
        let turns = |o: usize| cruise(o) || u[o] * u[k] < 0.0;
        let switch = !cruise(k)
            && u[k].abs() < FULL * a_user
            && ((k > 0 && turns(k - 1)) || (k + 1 < cells && turns(k + 1)));
        if switch && out.last() != Some(&j) {
            out.push(j);
        }
    }
    out
}
