//! Shared by the 20-goal map tests (`map_goals.rs` on the kinematic plant,
//! `map_goals_closed_loop.rs` on the dynamic one): the map, the margin, the rate, the goal draw
//! and the plan's upload, so both runs face the same goals.

use omnikin::runtime::PlanPoint;
use omnikin_plan::map::Map;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;

/// The cluttered map both runs cross.
pub const MAP: &str = include_str!("../../../../examples/maps/cluttered.toml");
/// Clearance the plans keep beyond the footprint, m: room for tracking errors.
pub const MARGIN: f64 = 0.05;
/// Control rate, Hz (`omnikin robot`'s).
pub const RATE: f64 = 100.0;
/// Plan points the runtime holds.
pub const CAPACITY: usize = 512;
/// Goals reached in a row.
pub const GOALS: usize = 20;
/// How close the true position must come to each goal, m.
pub const REACHED: f64 = 0.03;

/// A random goal of `map` with room for the planned footprint `f`, at least 1 m from `from`.
pub fn random_goal(rng: &mut ChaCha8Rng, map: &Map, f: f64, from: [f64; 2]) -> [f64; 2] {
    loop {
        let p = [rng.random_range(0.0..10.0), rng.random_range(0.0..10.0)];
        if map.clearance(p) >= f * 1.1 && (p[0] - from[0]).hypot(p[1] - from[1]) >= 1.0 {
            return p;
        }
    }
}

/// The plan's samples as the runtime's points, evenly decimated to at most [`CAPACITY`]
/// (keeping the last), as `drive plan` uploads them.
pub fn points(p: &omnikin_plan::Plan) -> Vec<PlanPoint<f64>> {
    let n = p.samples.len();
    let step = n.div_ceil(CAPACITY - 1).max(1);
    let mut idx: Vec<usize> = (0..n).step_by(step).collect();
    if idx.last() != Some(&(n - 1)) {
        idx.push(n - 1);
    }
    idx.iter()
        .map(|&i| {
            let s = &p.samples[i];
            PlanPoint {
                t: s.t,
                pose: s.pose,
                twist: s.twist,
            }
        })
        .collect()
}
