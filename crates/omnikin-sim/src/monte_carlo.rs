//! Seeded, parallel Monte Carlo over trials.

use omnikin::Robot;
use omnikin_plan::Plan;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::plant::{SimError, Trial, simulate_trial};
use crate::profile::Profile;

/// The random generator of trial `index` under `seed`: one ChaCha8 stream per trial, so a
/// trial's numbers depend only on `(seed, index)` — never on thread count or scheduling.
pub fn trial_rng(seed: u64, index: usize) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index as u64);
    rng
}

/// Runs `trials` trials of `plan` in parallel on the current rayon pool and returns them in
/// trial order. `progress` is called once per finished trial (from worker threads).
pub fn run_trials(
    robot: &Robot<f64>,
    plan: &Plan,
    profile: &Profile,
    trials: usize,
    seed: u64,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<Trial>, SimError> {
    (0..trials)
        .into_par_iter()
        .map(|i| {
            let r = simulate_trial(robot, plan, profile, &mut trial_rng(seed, i));
            progress();
            r
        })
        .collect()
}
