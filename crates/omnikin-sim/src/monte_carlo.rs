//! Seeded, parallel Monte Carlo over trials: [`run_trials`] keeps every trial,
//! [`simulate_and_evaluate`] streams them into the metrics in bounded memory.

use omnikin::Robot;
use omnikin_plan::Plan;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::metrics::{Evaluation, Evaluator, MetricsError, Run};
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

/// Runs the trials are kept for figures ([`MonteCarlo::figure_runs`]): the first ones by
/// index. A figure of more grey runs shows nothing more and grows with the trial count.
pub const FIGURE_RUNS: usize = 50;

/// Bound on the tracked positions [`simulate_and_evaluate`] keeps between its two passes, bytes
/// (16 per sample and trial). Above it, the second pass simulates the trials again (same
/// numbers, twice the time) instead of keeping them.
pub const RETAIN_LIMIT_BYTES: usize = 256 << 20;

/// Whether [`simulate_and_evaluate`] of `trials` trials of a plan with `samples` samples
/// simulates every trial twice (its tracked positions exceed [`RETAIN_LIMIT_BYTES`]).
pub fn second_pass_resimulates(trials: usize, samples: usize) -> bool {
    trials
        .checked_mul(samples)
        .and_then(|n| n.checked_mul(16))
        .is_none_or(|bytes| bytes > RETAIN_LIMIT_BYTES)
}

/// A Monte-Carlo run reduced to what its outputs need.
#[derive(Clone, Debug)]
pub struct MonteCarlo {
    /// The metrics and the mean trajectory with its 95 % band.
    pub evaluation: Evaluation,
    /// The first [`FIGURE_RUNS`] runs (tracked positions; headings omitted), for figures.
    pub figure_runs: Vec<Run>,
    /// Whether the second pass simulated the trials again ([`second_pass_resimulates`]).
    pub resimulated: bool,
}

/// Why [`simulate_and_evaluate`] stopped.
#[derive(Debug, thiserror::Error)]
pub enum MonteCarloError<E> {
    /// A trial could not be simulated.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The metrics could not be computed.
    #[error(transparent)]
    Metrics(#[from] MetricsError),
    /// The caller's `visit` failed (e.g. writing a trial to a file).
    #[error("{0}")]
    Visit(E),
}

/// Trials per parallel batch: enough to keep every worker busy, few enough to bound memory.
fn batch_size() -> usize {
    (8 * rayon::current_num_threads()).clamp(16, 256)
}

/// Simulates batches of trials `range` in parallel and hands them to `each` in trial order.
fn for_each_trial<E>(
    robot: &Robot<f64>,
    plan: &Plan,
    profile: &Profile,
    seed: u64,
    range: core::ops::Range<usize>,
    progress: &(dyn Fn() + Sync),
    mut each: impl FnMut(usize, Trial) -> Result<(), MonteCarloError<E>>,
) -> Result<(), MonteCarloError<E>> {
    let batch = batch_size();
    let mut start = range.start;
    while start < range.end {
        let end = (start + batch).min(range.end);
        let trials: Vec<Trial> = (start..end)
            .into_par_iter()
            .map(|i| {
                let r = simulate_trial(robot, plan, profile, &mut trial_rng(seed, i));
                progress();
                r
            })
            .collect::<Result<_, _>>()?;
        for (i, t) in (start..end).zip(trials) {
            each(i, t)?;
        }
        start = end;
    }
    Ok(())
}

/// Runs `trials` trials of `plan` (seeded like [`run_trials`]) and evaluates what the tracker
/// saw, with the true headings, against `reference` (the planned path of the tracked point,
/// [`crate::metrics::tracked_reference`]), **without keeping the trials**: they are simulated
/// in parallel batches and reduced in trial order, so the result is bit-identical for any
/// number of threads and equal to [`crate::metrics::evaluate`] of all the runs.
///
/// `visit` sees every trial once, in trial order (e.g. to write it to a file). Memory: one
/// batch of trials, O(samples) for the metrics, the [`FIGURE_RUNS`] figure runs, and the
/// tracked positions for the second pass up to [`RETAIN_LIMIT_BYTES`] — above that the second
/// pass simulates the trials again (`progress` then counts each trial twice).
#[allow(clippy::too_many_arguments)]
pub fn simulate_and_evaluate<E>(
    robot: &Robot<f64>,
    plan: &Plan,
    reference: &Plan,
    profile: &Profile,
    trials: usize,
    seed: u64,
    progress: &(dyn Fn() + Sync),
    mut visit: impl FnMut(usize, &Trial) -> Result<(), E>,
) -> Result<MonteCarlo, MonteCarloError<E>> {
    let resimulate = second_pass_resimulates(trials, plan.samples.len());
    let mut first = Evaluator::new(reference);
    let mut figure_runs = Vec::new();
    let mut kept: Vec<Vec<[f64; 2]>> = Vec::new();
    for_each_trial(robot, plan, profile, seed, 0..trials, progress, |i, t| {
        visit(i, &t).map_err(MonteCarloError::Visit)?;
        let run = Run {
            xy: t.tracked,
            heading: Some(t.pose.iter().map(|p| p.heading).collect()),
        };
        first.add(&run)?;
        if figure_runs.len() < FIGURE_RUNS {
            figure_runs.push(Run {
                xy: run.xy.clone(),
                heading: None,
            });
        }
        if !resimulate {
            kept.push(run.xy);
        }
        Ok(())
    })?;
    let mut second = first.second_pass();
    if resimulate {
        for_each_trial(robot, plan, profile, seed, 0..trials, progress, |_, t| {
            second.add(&t.tracked).map_err(MonteCarloError::Metrics)
        })?;
    } else {
        for xy in &kept {
            second.add(xy)?;
        }
    }
    Ok(MonteCarlo {
        evaluation: second.finish()?,
        figure_runs,
        resimulated: resimulate,
    })
}
