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
    resimulates(trials, samples, RETAIN_LIMIT_BYTES)
}

fn resimulates(trials: usize, samples: usize, limit: usize) -> bool {
    trials
        .checked_mul(samples)
        .and_then(|n| n.checked_mul(16))
        .is_none_or(|bytes| bytes > limit)
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
    /// The caller's code failed: `visit` (e.g. writing a trial to a file), or the source of
    /// runs of [`evaluate_runs`] (e.g. reading a shard).
    #[error("{0}")]
    Visit(E),
}

/// Trials per parallel batch: enough to keep every worker busy, few enough to bound memory.
fn batch_size() -> usize {
    (8 * rayon::current_num_threads()).clamp(16, 256)
}

/// What the metrics take of one trial: its tracked positions, and the run they make.
trait Tracked: Send {
    /// The tracked positions, one per plan sample.
    fn xy(&self) -> &[[f64; 2]];
    /// The run the metrics see: the tracked positions and the true headings.
    fn into_run(self) -> Run;
}

impl Tracked for Trial {
    fn xy(&self) -> &[[f64; 2]] {
        &self.tracked
    }
    fn into_run(self) -> Run {
        trial_run(self)
    }
}

impl Tracked for Run {
    fn xy(&self) -> &[[f64; 2]] {
        &self.xy
    }
    fn into_run(self) -> Run {
        self
    }
}

/// The run the metrics see of a trial: what the tracker saw (`tracked`) with the true
/// headings (`pose[k].heading`, rad). This is all a shard keeps of a trial for the metrics
/// ([`crate::shard`]).
pub fn trial_run(t: Trial) -> Run {
    Run {
        heading: Some(t.pose.iter().map(|p| p.heading).collect()),
        xy: t.tracked,
    }
}

/// Simulates batches of trials `range` in parallel (`simulate(i)` = trial `i`), computes
/// `prepare(state, trial)` in the same workers, and hands both to `each(state, …)` in trial
/// order.
fn for_each_trial<S: Sync, T: Send, P: Send, E: Send>(
    simulate: &(dyn Fn(usize) -> Result<T, MonteCarloError<E>> + Sync),
    range: core::ops::Range<usize>,
    progress: &(dyn Fn() + Sync),
    state: &mut S,
    prepare: impl Fn(&S, &T) -> P + Sync,
    mut each: impl FnMut(&mut S, usize, T, P) -> Result<(), MonteCarloError<E>>,
) -> Result<(), MonteCarloError<E>> {
    let batch = batch_size();
    let mut start = range.start;
    while start < range.end {
        let end = (start + batch).min(range.end);
        let shared: &S = state;
        let trials: Vec<(T, P)> = (start..end)
            .into_par_iter()
            .map(|i| {
                let r = simulate(i).map(|t| {
                    let p = prepare(shared, &t);
                    (t, p)
                });
                progress();
                r
            })
            .collect::<Result<_, _>>()?;
        for (i, (t, p)) in (start..end).zip(trials) {
            each(state, i, t, p)?;
        }
        start = end;
    }
    Ok(())
}

/// Simulates trials `range` (`simulate(i)` = trial `i`, depending on `i` alone) in parallel
/// batches and hands each to `visit` **in trial order**, keeping one batch in memory: the
/// part of a run a shard does ([`crate::shard`]), with no metrics. `progress` is called once
/// per finished trial (from worker threads).
pub fn simulate_range<T: Send, E: Send>(
    simulate: &(dyn Fn(usize) -> Result<T, SimError> + Sync),
    range: core::ops::Range<usize>,
    progress: &(dyn Fn() + Sync),
    mut visit: impl FnMut(usize, T) -> Result<(), E>,
) -> Result<(), MonteCarloError<E>> {
    for_each_trial(
        &|i| simulate(i).map_err(MonteCarloError::Sim),
        range,
        progress,
        &mut (),
        |_, _| (),
        |_, i, t, ()| visit(i, t).map_err(MonteCarloError::Visit),
    )
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
pub fn simulate_and_evaluate<E: Send>(
    robot: &Robot<f64>,
    plan: &Plan,
    reference: &Plan,
    profile: &Profile,
    trials: usize,
    seed: u64,
    progress: &(dyn Fn() + Sync),
    visit: impl FnMut(usize, &Trial) -> Result<(), E>,
) -> Result<MonteCarlo, MonteCarloError<E>> {
    let simulate = |i: usize| {
        simulate_trial(robot, plan, profile, &mut trial_rng(seed, i)).map_err(MonteCarloError::Sim)
    };
    stream(
        &simulate,
        plan.samples.len(),
        reference,
        trials,
        progress,
        visit,
        RETAIN_LIMIT_BYTES,
    )
}

/// [`simulate_and_evaluate`] for any plant: `simulate(i)` runs trial `i` on the plan's time
/// grid (`samples` samples) and must depend only on `i` (e.g. draw from [`trial_rng`]`(seed,
/// i)`), so the result is bit-identical for any number of threads. Used by the dynamic plant
/// ([`crate::dynamics::sphere::DynamicProfile`]).
pub fn evaluate_trials<E: Send>(
    simulate: &(dyn Fn(usize) -> Result<Trial, SimError> + Sync),
    samples: usize,
    reference: &Plan,
    trials: usize,
    progress: &(dyn Fn() + Sync),
    visit: impl FnMut(usize, &Trial) -> Result<(), E>,
) -> Result<MonteCarlo, MonteCarloError<E>> {
    stream(
        &|i| simulate(i).map_err(MonteCarloError::Sim),
        samples,
        reference,
        trials,
        progress,
        visit,
        RETAIN_LIMIT_BYTES,
    )
}

/// The evaluation of [`simulate_and_evaluate`] over runs that were simulated elsewhere —
/// read back from shards ([`crate::shard`]): `run(i)` returns trial `i`'s [`trial_run`],
/// bit for bit. The same code reduces them in the same order, so the result is bit-identical
/// to one run's. `run` may be called twice per trial (the second pass reads again above
/// [`RETAIN_LIMIT_BYTES`]), from worker threads; its error stops the evaluation as
/// [`MonteCarloError::Visit`].
pub fn evaluate_runs<E: Send>(
    run: &(dyn Fn(usize) -> Result<Run, E> + Sync),
    samples: usize,
    reference: &Plan,
    trials: usize,
    progress: &(dyn Fn() + Sync),
) -> Result<MonteCarlo, MonteCarloError<E>> {
    stream(
        &|i| run(i).map_err(MonteCarloError::Visit),
        samples,
        reference,
        trials,
        progress,
        |_, _: &Run| Ok(()),
        RETAIN_LIMIT_BYTES,
    )
}

/// [`evaluate_trials`] with the bound on kept positions as a parameter, over any source of
/// trials (simulated, or read back).
fn stream<T: Tracked, E: Send>(
    simulate: &(dyn Fn(usize) -> Result<T, MonteCarloError<E>> + Sync),
    samples: usize,
    reference: &Plan,
    trials: usize,
    progress: &(dyn Fn() + Sync),
    mut visit: impl FnMut(usize, &T) -> Result<(), E>,
    retain_limit: usize,
) -> Result<MonteCarlo, MonteCarloError<E>> {
    let resimulate = resimulates(trials, samples, retain_limit);
    let mut first = Evaluator::new(reference);
    let mut figure_runs = Vec::new();
    let mut kept: Vec<Vec<[f64; 2]>> = Vec::new();
    // The nearest-segment queries run in the workers; the sums in trial order.
    for_each_trial(
        simulate,
        0..trials,
        progress,
        &mut first,
        |e, t| e.distances(t.xy()),
        |e, i, t, d| {
            visit(i, &t).map_err(MonteCarloError::Visit)?;
            let run = t.into_run();
            e.add_with(&run, d)?;
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
        },
    )?;
    let mut second = first.second_pass();
    if resimulate {
        for_each_trial(
            simulate,
            0..trials,
            progress,
            &mut second,
            |_, _| (),
            |s, _, t, ()| s.add(t.xy()).map_err(MonteCarloError::Metrics),
        )?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::{evaluate, tracked_reference};
    use omnikin::description::RobotDescription;
    use omnikin_plan::RobotModel;
    use omnikin_plan::generators::Circle;

    /// The sphere preset and paper 000's circle at 2 rad/s, planned at 20 Hz: the runs these
    /// tests simulate.
    fn sphere_circle() -> (omnikin::Robot<f64>, omnikin_plan::Plan) {
        let d = RobotDescription::preset("sphere-omni").unwrap();
        let robot = d.build::<f64>().unwrap();
        let model = RobotModel::from_description(&d).unwrap();
        let c = Circle::paper(2.0);
        let plan =
            omnikin_plan::planner::plan(&c.path().unwrap(), &c.heading(), &model, &c.options(20.0))
                .unwrap()
                .plan;
        (robot, plan)
    }

    /// Streaming equals evaluating every kept trial, bit for bit, whether the second pass
    /// keeps the positions or simulates again, on 1 and 3 threads, and across batches (more
    /// trials than one batch).
    #[test]
    fn streaming_equals_keeping_every_trial_on_any_thread_count() {
        let (robot, plan) = sphere_circle();
        let mut profile = crate::reproduce::hardware_profile();
        profile.rate = Some(200.0);
        profile.tracking.offset = Some([0.01, 0.0]);
        let reference = tracked_reference(&plan, [0.01, 0.0]);
        let trials = 40;
        let pool = |n: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
        };
        let all =
            pool(2).install(|| run_trials(&robot, &plan, &profile, trials, 9, &|| {}).unwrap());
        let runs: Vec<Run> = all
            .iter()
            .map(|t| Run {
                xy: t.tracked.clone(),
                heading: Some(t.pose.iter().map(|p| p.heading).collect()),
            })
            .collect();
        let want = evaluate(&reference, &runs).unwrap();
        for (threads, limit) in [(1, usize::MAX), (3, usize::MAX), (1, 0), (3, 0)] {
            let visited = std::sync::Mutex::new(Vec::new());
            let mc = pool(threads)
                .install(|| {
                    stream(
                        &|i| {
                            simulate_trial(&robot, &plan, &profile, &mut trial_rng(9, i))
                                .map_err(MonteCarloError::Sim)
                        },
                        plan.samples.len(),
                        &reference,
                        trials,
                        &|| {},
                        |i, t: &Trial| {
                            visited.lock().unwrap().push((i, t.tracked[1]));
                            Ok::<(), ()>(())
                        },
                        limit,
                    )
                })
                .unwrap();
            assert_eq!(mc.resimulated, limit == 0);
            assert_eq!(mc.evaluation, want, "threads {threads}, limit {limit}");
            let bits = |m: &crate::metrics::Metrics| {
                m.values()
                    .into_iter()
                    .map(|(_, v)| v.to_bits())
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&mc.evaluation.metrics), bits(&want.metrics));
            // Every trial visited once, in order, as simulated.
            let visited = visited.into_inner().unwrap();
            assert_eq!(visited.len(), trials);
            for (k, (i, p)) in visited.iter().enumerate() {
                assert_eq!((*i, *p), (k, all[k].tracked[1]));
            }
            assert_eq!(mc.figure_runs.len(), FIGURE_RUNS.min(trials));
            assert_eq!(mc.figure_runs[3].xy, all[3].tracked);
        }
    }

    /// Runs read back (a merge of shards) evaluate bit for bit as the simulated trials did,
    /// in batches of any size, and a failing source stops the evaluation with its error.
    #[test]
    fn evaluating_read_back_runs_equals_simulating_them() {
        let (robot, plan) = sphere_circle();
        let profile = crate::reproduce::hardware_profile();
        let trials = 21;
        let want =
            simulate_and_evaluate(&robot, &plan, &plan, &profile, trials, 4, &|| {}, |_, _| {
                Ok::<(), ()>(())
            })
            .unwrap();
        let runs: Vec<Run> = run_trials(&robot, &plan, &profile, trials, 4, &|| {})
            .unwrap()
            .into_iter()
            .map(trial_run)
            .collect();
        let got = evaluate_runs(
            &|i| Ok::<_, ()>(runs[i].clone()),
            plan.samples.len(),
            &plan,
            trials,
            &|| {},
        )
        .unwrap();
        assert_eq!(got.evaluation, want.evaluation);
        assert_eq!(got.figure_runs, want.figure_runs);
        let failed = evaluate_runs(
            &|i| {
                if i == 7 {
                    Err("shard 2 unreadable")
                } else {
                    Ok(runs[i].clone())
                }
            },
            plan.samples.len(),
            &plan,
            trials,
            &|| {},
        );
        assert!(matches!(
            failed,
            Err(MonteCarloError::Visit("shard 2 unreadable"))
        ));
    }

    #[test]
    fn a_failing_visit_stops_the_run_with_its_error() {
        let (robot, plan) = sphere_circle();
        let profile = Profile::default();
        let mut seen = 0;
        let r = simulate_and_evaluate(&robot, &plan, &plan, &profile, 30, 1, &|| {}, |i, _| {
            seen += 1;
            if i == 20 { Err("disk full") } else { Ok(()) }
        });
        assert!(matches!(r, Err(MonteCarloError::Visit("disk full"))));
        assert_eq!(seen, 21);
    }

    #[test]
    fn resimulation_starts_above_the_stated_limit() {
        assert!(!second_pass_resimulates(1000, 1682));
        assert!(second_pass_resimulates(100_000, 1682));
        assert!(second_pass_resimulates(usize::MAX, 2));
        let per = RETAIN_LIMIT_BYTES / 16;
        assert!(!second_pass_resimulates(1, per) && second_pass_resimulates(1, per + 1));
    }
}
