//! # omnikin's files, for every front end
//!
//! What the `omnikin` command, the Python package and the ROS 2 node share when they read and
//! write files:
//!
//! | module | what |
//! |---|---|
//! | [`output`] | the output rules: an input is never overwritten, an existing output only with `--force`, every file written to a temporary file and renamed into place, logs kept on every exit path (SIGINT/SIGTERM included), stdout written fallibly |
//! | [`mcap_log`] | MCAP logs with Foxglove schemas (JSON or protobuf): the writer `robot --mcap` and `simulate --mcap` use, the bounded reader, and `convert` (MCAP → CSV, JSON → protobuf) |
//! | [`shards`] | one Monte-Carlo run split across processes or machines (`simulate`/`reproduce --shard K/N`) and `merge`d back bit for bit |
//! | [`telemetry_schema`] | the telemetry frame's fields and the link's counters, named once: the telemetry CSV log's columns, the console's telemetry message and the MCAP `omnikin.LinkCounters` schema are derived from it |
//! | [`sim_output`] | a simulation's output directory: `simulate`'s trials.csv, mean.csv, metrics.json and figure, `reproduce`'s report (tables, metrics, one figure per series and profile), the same from one run and from a merge of shards |
//!
//! Messages name the flag or file, the rule and how to override it; `flag` arguments are the
//! names a front end shows its user (`--out`, `--mcap`).

pub mod mcap_log;
pub mod output;
pub mod shards;
pub mod sim_output;
pub mod telemetry_schema;

/// A number for a message: plain, or `1e300` style when tiny or huge (so 1e308 does not print
/// as 309 digits).
pub fn num(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && a.is_finite() && !(1e-4..1e9).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}
