//! `simulate … --shard K/N`, `reproduce … --shard K/N` and `omnikin merge`: the shards and the
//! merge are omnikin-io's ([`omnikin_io::shards`]); this is `merge`'s flags and the glue.

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use omnikin::description::RobotDescription;
use omnikin_io::shards::{MergeOutput, SimulateRun};
use omnikin_plan::Plan;
use omnikin_sim::Profile;
use omnikin_sim::shard::Shard;

pub use omnikin_io::shards::reproduce_shard;

/// `omnikin simulate … --shard K/N` ([`omnikin_io::shards::simulate_shard`]).
pub fn simulate_shard(
    a: &crate::sim_args::SimulateArgs,
    shard: Shard,
    d: &RobotDescription,
    robot: &omnikin::Robot<f64>,
    plan: &Plan,
    profile: &Profile,
) -> Result<()> {
    if a.emit_sensors || a.mcap.is_some() {
        bail!(
            "--shard: not with --emit-sensors or --mcap yet (they write per-trial files a merge \
             does not collect); write them from a run without --shard (same --seed: trial i is \
             the same trial)"
        );
    }
    let run = SimulateRun {
        plan: &a.plan,
        disturbances: a.disturbances.as_deref(),
        trials: a.trials,
        seed: a.seed,
        threads: a.threads,
        out: &a.out,
    };
    omnikin_io::shards::simulate_shard(&run, shard, d, robot, plan, profile)
}

/// `omnikin merge`.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// Shard directories written by `simulate … --shard K/N --out DIR` or `reproduce … --shard
    /// K/N --out DIR`: all N shards of one run, each once, in any order.
    #[arg(required = true, value_name = "SHARD_DIR")]
    pub shards: Vec<PathBuf>,
    /// Output directory (created; new or empty unless --force; never a shard directory or
    /// inside one): what the single run writes — simulate: metrics.json, trials.csv, mean.csv,
    /// figure.svg; reproduce: table.md, table.csv, metrics.json and the figures.
    #[arg(long)]
    pub out: PathBuf,
    /// Worker threads for the metrics, 1 to 256 (default: all cores).
    #[arg(long, value_parser = crate::args::threads)]
    pub threads: Option<usize>,
    /// Format of the figures in --out, as the run's own --figure-format: svg (default), png
    /// (rasterised, 2 px per SVG px) or pdf (vector, font embedded).
    #[arg(long, value_enum, default_value_t = crate::plot::FigureFormat::Svg)]
    pub figure_format: crate::plot::FigureFormat,
}

/// The files of the shard directories, for the output rules (inputs are never overwritten).
pub fn input_files(a: &MergeArgs) -> Vec<PathBuf> {
    omnikin_io::shards::input_files(&a.shards)
}

/// `omnikin merge SHARD_DIR… --out DIR`.
pub fn merge(a: &MergeArgs) -> Result<()> {
    let out: &Path = &a.out;
    omnikin_io::shards::merge(
        &a.shards,
        &MergeOutput {
            out,
            threads: a.threads,
            figures: &a.figure_format,
        },
    )
}
