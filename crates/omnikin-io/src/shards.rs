//! `simulate … --shard K/N`, `reproduce … --shard K/N` and `omnikin merge`: one Monte-Carlo
//! run split across processes or machines by trial, and put back together bit for bit.
//!
//! A shard directory holds what its trials leave for the metrics — every trial's tracked
//! positions and true headings, exactly ([`omnikin_sim::shard`]'s runs files) — and
//! `shard.json`, the manifest: command, `K`, `N`, the trial ranges, the omnikin version and
//! fingerprints of every input. `simulate` shards also keep their `trials.csv` rows and a copy
//! of the plan. `merge` checks that the manifests agree (same inputs, every shard `1..N`
//! exactly once), reads the runs back in trial order and runs the same finishing code as one
//! run ([`crate::sim_output::finish_simulation`], [`crate::sim_output::Report`]): the metrics are two passes
//! of floating-point sums over the trials in trial order, so only reading every trial back —
//! never adding per-shard sums — gives the single run's numbers bit for bit.
//!
//! No scheduler: run the shards with whatever runs jobs (GNU parallel, a Slurm job array, a
//! shell loop over ssh) and merge their directories.

use std::collections::BTreeMap;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin_plan::Plan;
use omnikin_sim::shard::{RunsFile, RunsWriter, Shard, fingerprint};
use omnikin_sim::{MonteCarloError, Profile, Trial};
use serde::{Deserialize, Serialize};

use crate::sim_output::{ReproduceInfo, RunFigures, SimulationInfo, create_dir_for, write_file};

/// The manifest's format number; a merge refuses any other.
const FORMAT: u32 = 1;
const MANIFEST: &str = "shard.json";
const SIMULATE: &str = "simulate";
const REPRODUCE: &str = "reproduce sphere-2019";

/// One runs file of a shard: the trials `first..end` of `trials` of one profile (and series).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
struct Runs {
    /// `simulate`, or `SERIES/PROFILE` for reproduce.
    name: String,
    /// Trials of that profile in the whole run.
    trials: usize,
    /// The shard's first trial.
    first: usize,
    /// One past its last trial.
    end: usize,
    /// The file, relative to the shard directory.
    file: String,
}

/// `shard.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Manifest {
    /// [`FORMAT`].
    format: u32,
    /// The omnikin that wrote the shard.
    omnikin_version: String,
    /// `simulate` or `reproduce sphere-2019`.
    command: String,
    /// `K`.
    shard: usize,
    /// `N`.
    shards: usize,
    /// Positions per trial.
    samples: BTreeMap<String, usize>,
    /// What must be the same in every shard: fingerprints of the inputs, seed, counts, and the
    /// floats the outputs print, as exact decimal strings (Rust's shortest round-trip form).
    inputs: BTreeMap<String, String>,
    /// Names as given on the command line (may differ between machines; a merge writes the
    /// first shard's).
    names: BTreeMap<String, String>,
    /// The shard's runs files.
    runs: Vec<Runs>,
    /// reproduce with the dynamic profile: each of the shard's dynamic trials' contact events
    /// by series, in trial order (the runs' range of that series' dynamic runs file).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    contacts: BTreeMap<String, Vec<omnikin_sim::dynamics::sphere::ContactEvents>>,
}

/// `f64` → text that parses back to the same bits.
fn exact(v: f64) -> String {
    format!("{v:?}")
}

fn hex(v: u64) -> String {
    format!("{v:016x}")
}

impl Manifest {
    fn new(command: &str, shard: Shard) -> Self {
        Manifest {
            format: FORMAT,
            omnikin_version: env!("CARGO_PKG_VERSION").into(),
            command: command.into(),
            shard: shard.index,
            shards: shard.count,
            samples: BTreeMap::new(),
            inputs: BTreeMap::new(),
            names: BTreeMap::new(),
            runs: Vec::new(),
            contacts: BTreeMap::new(),
        }
    }

    fn write(&self, dir: &Path) -> Result<()> {
        write_file(&dir.join(MANIFEST), |w| {
            writeln!(
                w,
                "{}",
                serde_json::to_string_pretty(self).unwrap_or_default()
            )
        })
    }

    fn input(&self, dir: &Path, key: &str) -> Result<&str> {
        self.inputs
            .get(key)
            .map(String::as_str)
            .with_context(|| format!("{}: has no input \"{key}\"", dir.join(MANIFEST).display()))
    }

    fn float(&self, dir: &Path, key: &str) -> Result<f64> {
        let v = self.input(dir, key)?;
        v.parse().ok().with_context(|| {
            format!(
                "{}: input \"{key}\" = \"{v}\" is not a number",
                dir.join(MANIFEST).display()
            )
        })
    }
}

/// Ends a shard: the trials ran, `shard.json` is written last (a directory without it is an
/// unfinished shard), and the summary.
fn done(
    dir: &Path,
    m: &Manifest,
    trials: usize,
    files: &str,
    start: std::time::Instant,
) -> Result<()> {
    m.write(dir)?;
    let r = &m.runs[0];
    crate::errln!(
        "shard {}/{} of {}: trials {}..={} ({} of {trials}{}) in {:.1} s; wrote {}/{{{files}, shard.json}}; merge all {} shard directories with `omnikin merge SHARD_DIR… --out DIR`",
        m.shard,
        m.shards,
        m.command,
        r.first,
        r.end.saturating_sub(1),
        r.end - r.first,
        if m.runs.len() > 1 {
            format!(" per series and profile, {} runs files", m.runs.len())
        } else {
            String::new()
        },
        start.elapsed().as_secs_f64(),
        dir.display().to_string().trim_end_matches('/'),
        m.shards
    );
    Ok(())
}

/// The run a `simulate` shard belongs to (`omnikin simulate`'s flags).
#[derive(Clone, Copy, Debug)]
pub struct SimulateRun<'a> {
    /// The plan file (read again and compared with `plan`, then copied into the shard).
    pub plan: &'a Path,
    /// The disturbance profile's file, as named on the command line.
    pub disturbances: Option<&'a Path>,
    /// Trials of the whole run.
    pub trials: u64,
    /// The run's seed (trial `i` draws from `trial_rng(seed, i)`).
    pub seed: u64,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    /// The shard directory.
    pub out: &'a Path,
}

/// `omnikin simulate … --shard K/N`: the shard's trials into `trials.csv` and `runs.bin`, the
/// plan copied to `plan.csv`, then `shard.json`.
///
/// # Errors
/// A shard of more than the run's trials, a plan changed while read, a file that cannot be
/// written, a trial that cannot be simulated.
pub fn simulate_shard(
    a: &SimulateRun<'_>,
    shard: Shard,
    d: &RobotDescription,
    robot: &omnikin::Robot<f64>,
    plan: &Plan,
    profile: &Profile,
) -> Result<()> {
    let start = std::time::Instant::now();
    let trials = a.trials as usize;
    shard.check(trials, "--trials")?;
    let name = a.plan.display().to_string();
    let bytes = std::fs::read(a.plan).with_context(|| format!("cannot read the plan {name}"))?;
    if Plan::read_csv(bytes.as_slice(), &name).ok().as_ref() != Some(plan) {
        bail!("{name}: changed while it was read; run the shard again");
    }
    let files = ["plan.csv", "trials.csv", "runs.bin", MANIFEST];
    create_dir_for(a.out, &files)?;
    write_file(&a.out.join("plan.csv"), |w| w.write_all(&bytes))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let range = shard.range(trials);
    let samples = plan.samples.len();
    let pb = crate::output::progress_bar(range.len() as u64, "simulating");
    let trials_path = a.out.join("trials.csv");
    let runs_path = a.out.join("runs.bin");
    let mut trials_csv = crate::output::OutFile::create("--out", &trials_path)?;
    writeln!(
        trials_csv,
        "{}",
        crate::sim_output::trials_header(robot.wheels())
    )
    .with_context(|| format!("cannot write {}", trials_path.display()))?;
    let runs_file = crate::output::OutFile::create("--out", &runs_path)?;
    let mut runs = RunsWriter::new(runs_file, samples, range.start, range.len())
        .with_context(|| format!("cannot write {}", runs_path.display()))?;
    let simulate = |i: usize| {
        omnikin_sim::simulate_trial(robot, plan, profile, &mut omnikin_sim::trial_rng(a.seed, i))
    };
    pool.install(|| {
        omnikin_sim::simulate_range(&simulate, range.clone(), &|| pb.inc(1), |i, t: Trial| {
            crate::sim_output::write_trial(&mut trials_csv, i, &t)
                .with_context(|| format!("cannot write {}", trials_path.display()))?;
            runs.push(&omnikin_sim::trial_run(t))
                .with_context(|| format!("cannot write {}", runs_path.display()))
        })
    })
    .map_err(|e| match e {
        MonteCarloError::Visit(e) => e,
        e => anyhow::Error::new(e),
    })?;
    pb.finish_and_clear();
    trials_csv.commit()?;
    runs.finish()
        .with_context(|| format!("cannot write {}", runs_path.display()))?
        .commit()?;
    let mut m = Manifest::new(SIMULATE, shard);
    m.samples.insert(SIMULATE.into(), samples);
    let offset = profile.tracking.offset.unwrap_or([0.0; 2]);
    for (k, v) in [
        ("plan_fingerprint", hex(fingerprint(&bytes))),
        (
            "robot_fingerprint",
            hex(fingerprint(format!("{d:?}").as_bytes())),
        ),
        (
            "profile_fingerprint",
            hex(fingerprint(format!("{profile:?}").as_bytes())),
        ),
        ("robot", d.name.clone()),
        ("kind", d.kind().to_string()),
        ("wheels", robot.wheels().to_string()),
        ("trials", trials.to_string()),
        ("seed", a.seed.to_string()),
        ("plant_rate_hz", exact(profile.rate_hz())),
        ("tracking_offset_x", exact(offset[0])),
        ("tracking_offset_y", exact(offset[1])),
    ] {
        m.inputs.insert(k.into(), v);
    }
    m.names.insert("plan".into(), name);
    if let Some(p) = a.disturbances {
        m.names
            .insert("disturbances".into(), p.display().to_string());
    }
    m.runs.push(Runs {
        name: SIMULATE.into(),
        trials,
        first: range.start,
        end: range.end,
        file: "runs.bin".into(),
    });
    done(a.out, &m, trials, "plan.csv, trials.csv, runs.bin", start)
}

/// The fingerprint of the series plans (their every sample, exactly).
fn series_fingerprint(series: &[omnikin_sim::reproduce::PaperSeries]) -> String {
    let text: String = series
        .iter()
        .map(|s| format!("{}:{:?}\n", s.name, s.plan))
        .collect();
    hex(fingerprint(text.as_bytes()))
}

fn reproduce_inputs(
    info: &ReproduceInfo,
    series: &[omnikin_sim::reproduce::PaperSeries],
) -> BTreeMap<String, String> {
    let mut m = BTreeMap::new();
    m.insert("trials".into(), info.trials.to_string());
    m.insert("dynamic_trials".into(), info.dynamic_trials.to_string());
    m.insert("prior_samples".into(), info.prior_samples.to_string());
    m.insert("seed".into(), info.seed.to_string());
    m.insert("rate".into(), exact(info.rate));
    m.insert("profiles".into(), info.profiles.join(","));
    m.insert("series_fingerprint".into(), series_fingerprint(series));
    // The robot file, text and all: a merge rebuilds the same series and dynamic parameters
    // from it, whatever file the merging machine has.
    m.insert("robot_file".into(), info.robot_file.clone());
    m.insert("robot_toml".into(), info.robot_toml.clone());
    if let Some(d) = &info.dynamic {
        m.insert("dynamic_fitted_name".into(), d.source.fitted_name.into());
        m.insert("dynamic_fitted_value".into(), exact(d.source.fitted_value));
        m.insert(
            "dynamic_fitted_comment".into(),
            d.source.fitted_comment.clone(),
        );
    }
    m
}

fn runs_file_name(series: &str, profile: &str) -> String {
    format!("runs/{series}-{profile}.bin")
}

/// `omnikin reproduce sphere-2019 … --shard K/N`: the shard's trials of every series and
/// profile into `runs/SERIES-PROFILE.bin`, then `shard.json`.
///
/// # Errors
/// A file that cannot be written, a trial that cannot be simulated.
pub fn reproduce_shard(
    out: &Path,
    shard: Shard,
    info: &ReproduceInfo,
    plants: &omnikin_sim::reproduce::Plants<'_>,
    series: &[omnikin_sim::reproduce::PaperSeries],
    pool: &rayon::ThreadPool,
) -> Result<()> {
    let start = std::time::Instant::now();
    let counts = plants.runs(info.trials, info.dynamic_trials);
    let ranges: Vec<(&'static str, core::ops::Range<usize>)> =
        counts.iter().map(|(n, t)| (*n, shard.range(*t))).collect();
    crate::output::create_subdir("--out", &out.join("runs"))?;
    let total: u64 = series.len() as u64 * ranges.iter().map(|r| r.1.len() as u64).sum::<u64>();
    let pb = crate::output::progress_bar(total, "reproducing the Sphere paper (shard)");
    let mut m = Manifest::new(REPRODUCE, shard);
    m.inputs = reproduce_inputs(info, series);
    for s in series {
        m.samples.insert(s.name.clone(), s.plan.samples.len());
        let mut writers = Vec::new();
        for ((name, range), (_, trials)) in ranges.iter().zip(&counts) {
            let file = runs_file_name(&s.name, name);
            let path = out.join(&file);
            crate::output::check_file("--out", &path)?;
            let f = crate::output::OutFile::create("--out", &path)?;
            let w = RunsWriter::new(f, s.plan.samples.len(), range.start, range.len())
                .with_context(|| format!("cannot write {}", path.display()))?;
            writers.push((*name, path, w));
            m.runs.push(Runs {
                name: format!("{}/{name}", s.name),
                trials: *trials,
                first: range.start,
                end: range.end,
                file,
            });
        }
        pool.install(|| {
            omnikin_sim::reproduce::shard_series(
                plants,
                s,
                &ranges,
                &|| pb.inc(1),
                |name, _, run, events| {
                    if let Some(e) = events {
                        m.contacts.entry(s.name.clone()).or_default().push(e);
                    }
                    let (_, path, w) = writers
                        .iter_mut()
                        .find(|(n, _, _)| *n == name)
                        .context("a profile without its runs file")?;
                    w.push(&run)
                        .with_context(|| format!("cannot write {}", path.display()))
                },
            )
        })
        .map_err(|e| match e {
            MonteCarloError::Visit(e) => e,
            e => anyhow::Error::new(e),
        })?;
        for (_, path, w) in writers {
            w.finish()
                .with_context(|| format!("cannot write {}", path.display()))?
                .commit()?;
        }
    }
    pb.finish_and_clear();
    done(out, &m, info.trials, "runs/*.bin", start)
}

/// The files of the shard directories `shards`, for the output rules (inputs are never
/// overwritten).
pub fn input_files(shards: &[PathBuf]) -> Vec<PathBuf> {
    shards
        .iter()
        .flat_map(|d| {
            ["shard.json", "plan.csv", "trials.csv", "runs.bin"]
                .into_iter()
                .map(move |f| d.join(f))
        })
        .collect()
}

/// `path` made absolute with its existing part resolved (symlinks), for comparing directories.
fn resolved(path: &Path) -> PathBuf {
    if let Ok(c) = path.canonicalize() {
        return c;
    }
    match (path.parent(), path.file_name()) {
        (Some(p), Some(n)) => {
            let p = if p.as_os_str().is_empty() {
                Path::new(".")
            } else {
                p
            };
            resolved(p).join(n)
        }
        _ => std::env::current_dir()
            .map(|d| d.join(path))
            .unwrap_or_else(|_| path.to_path_buf()),
    }
}

/// A shard directory and its manifest.
struct Loaded {
    dir: PathBuf,
    m: Manifest,
}

fn load(dir: &Path) -> Result<Loaded> {
    let shown = dir.display();
    if !dir.is_dir() {
        bail!(
            "{shown}: not a directory; merge takes the shard directories (--out of `simulate … --shard K/N`)"
        );
    }
    let path = dir.join(MANIFEST);
    if !path.exists() {
        bail!(
            "{shown}: not a finished shard directory: it has no {MANIFEST} (a shard writes it \
             last, after all its trials; run `omnikin simulate … --shard K/N --out {shown}` or \
             its reproduce equivalent again)"
        );
    }
    let text = omnikin::description::read_text_limited(
        &path,
        omnikin::description::MAX_TOML_BYTES,
        "MAX_TOML_BYTES of omnikin::description",
    )
    .with_context(|| format!("cannot read {}", path.display()))?;
    let m: Manifest = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a shard manifest", path.display()))?;
    if m.format != FORMAT {
        bail!(
            "{}: shard format {}, this omnikin reads format {FORMAT}",
            path.display(),
            m.format
        );
    }
    let me = env!("CARGO_PKG_VERSION");
    if m.omnikin_version != me {
        bail!(
            "{shown}: written by omnikin {}, this is omnikin {me}: the numbers may differ between versions; merge with the omnikin that ran the shards (or run them again)",
            m.omnikin_version
        );
    }
    if m.shards == 0 || m.shard == 0 || m.shard > m.shards {
        bail!(
            "{}: shard {}/{} is not K/N with 1 ≤ K ≤ N",
            path.display(),
            m.shard,
            m.shards
        );
    }
    let shard = Shard {
        index: m.shard,
        count: m.shards,
    };
    for r in &m.runs {
        if (r.first..r.end) != shard.range(r.trials) {
            bail!(
                "{}: {} holds trials {}..{} but shard {shard} of {} trials is {:?}",
                path.display(),
                r.name,
                r.first,
                r.end,
                r.trials,
                shard.range(r.trials)
            );
        }
    }
    Ok(Loaded {
        dir: dir.to_path_buf(),
        m,
    })
}

/// Loads and checks the shards: one run (same command, inputs, N), every shard `1..N` exactly
/// once. Returns them in shard order.
fn check(dirs: &[PathBuf]) -> Result<Vec<Loaded>> {
    let shards: Vec<Loaded> = dirs.iter().map(|d| load(d)).collect::<Result<_>>()?;
    let first = &shards[0];
    let f = &first.m;
    for s in &shards[1..] {
        let (a, b) = (first.dir.display(), s.dir.display());
        if s.m.command != f.command {
            bail!(
                "{b} is a shard of `{}`, {a} of `{}`: not one run",
                s.m.command,
                f.command
            );
        }
        if s.m.shards != f.shards {
            bail!(
                "{b} is shard {}/{}, {a} is shard {}/{}: the shards of one run have the same N",
                s.m.shard,
                s.m.shards,
                f.shard,
                f.shards
            );
        }
        let keys: std::collections::BTreeSet<&String> =
            f.inputs.keys().chain(s.m.inputs.keys()).collect();
        for k in keys {
            let (x, y) = (f.inputs.get(k), s.m.inputs.get(k));
            if x != y {
                bail!(
                    "{b} and {a} ran different inputs: {k} is {} there and {} here; every shard of one run needs the same plan, robot, profile, seed and trial count",
                    y.map_or("absent", |v| v.as_str()),
                    x.map_or("absent", |v| v.as_str()),
                );
            }
        }
        if s.m.samples != f.samples {
            bail!("{b} and {a}: the plans have different numbers of samples");
        }
        let names = |m: &Manifest| {
            m.runs
                .iter()
                .map(|r| (r.name.clone(), r.trials))
                .collect::<Vec<_>>()
        };
        if names(&s.m) != names(f) {
            bail!("{b} and {a} hold different profiles or trial counts");
        }
    }
    let n = f.shards;
    let mut by_index: Vec<Option<&Loaded>> = vec![None; n];
    for s in &shards {
        let slot = &mut by_index[s.m.shard - 1];
        if let Some(other) = slot {
            bail!(
                "shard {}/{n} is given twice: {} and {}; give each shard once",
                s.m.shard,
                other.dir.display(),
                s.dir.display()
            );
        }
        *slot = Some(s);
    }
    let missing: Vec<String> = by_index
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_none())
        .map(|(k, _)| format!("{}/{n}", k + 1))
        .collect();
    if !missing.is_empty() {
        bail!(
            "shard{} {} missing: a merge needs all {n} shards of the run (given: {})",
            if missing.len() > 1 { "s" } else { "" },
            missing.join(", "),
            dirs.iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let mut shards = shards;
    shards.sort_by_key(|s| s.m.shard);
    Ok(shards)
}

/// Every shard's runs files, by run name, in trial order.
struct Sources {
    files: BTreeMap<String, Vec<RunsFile>>,
}

impl Sources {
    fn open(shards: &[Loaded]) -> Result<Self> {
        let mut files: BTreeMap<String, Vec<RunsFile>> = BTreeMap::new();
        for s in shards {
            for r in &s.m.runs {
                let series = r.name.split('/').next().unwrap_or_default();
                let samples = *s.m.samples.get(series).with_context(|| {
                    format!(
                        "{}: no sample count for {}",
                        s.dir.join(MANIFEST).display(),
                        r.name
                    )
                })?;
                let f = RunsFile::open(&s.dir.join(&r.file), samples, r.first..r.end)?;
                files.entry(r.name.clone()).or_default().push(f);
            }
        }
        Ok(Self { files })
    }

    /// Trial `i` of the run `name`.
    fn read(&self, name: &str, i: usize) -> Result<omnikin_sim::metrics::Run, String> {
        let files = self
            .files
            .get(name)
            .ok_or_else(|| format!("no shard holds runs of {name}"))?;
        let k = files.partition_point(|f| f.range().end <= i);
        files
            .get(k)
            .ok_or_else(|| format!("no shard holds trial {i} of {name}"))?
            .read(i)
            .map_err(|e| e.to_string())
    }
}

/// How `omnikin merge` writes the single run's files.
#[derive(Clone, Copy)]
pub struct MergeOutput<'a> {
    /// The output directory (new or empty unless `--force`; never a shard directory, inside
    /// one or around one).
    pub out: &'a Path,
    /// Worker threads for the metrics (`None`: all cores).
    pub threads: Option<usize>,
    /// How the figures are named and drawn.
    pub figures: &'a dyn RunFigures,
}

/// `omnikin merge SHARD_DIR… --out DIR`: checks the shards (one run, each of `1..N` once, the
/// same inputs) and writes what the single run writes, bit for bit.
///
/// # Errors
/// A directory that is not a finished shard, shards of different runs or versions, a shard
/// missing or given twice, an output directory that is or holds a shard, a file that cannot
/// be read or written.
pub fn merge(shard_dirs: &[PathBuf], a: &MergeOutput<'_>) -> Result<()> {
    let start = std::time::Instant::now();
    let out = resolved(a.out);
    for d in shard_dirs {
        let d_abs = resolved(d);
        if out.starts_with(&d_abs) || d_abs.starts_with(&out) {
            bail!(
                "--out {}: {} the shard directory {}; a merge never writes into (or around) an input directory: choose another --out",
                a.out.display(),
                if out == d_abs {
                    "is"
                } else if out.starts_with(&d_abs) {
                    "is inside"
                } else {
                    "contains"
                },
                d.display()
            );
        }
    }
    let shards = check(shard_dirs)?;
    let sources = Sources::open(&shards)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let n = shards.len();
    match shards[0].m.command.as_str() {
        SIMULATE => merge_simulate(a, &shards, &sources, &pool)?,
        REPRODUCE => merge_reproduce(a, &shards, &sources, &pool, start)?,
        other => bail!(
            "{}: unknown command \"{other}\" (simulate or reproduce sphere-2019)",
            shards[0].dir.join(MANIFEST).display()
        ),
    }
    crate::errln!(
        "merged {n} shards in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn visit_err(e: MonteCarloError<String>) -> anyhow::Error {
    match e {
        MonteCarloError::Visit(e) => anyhow::anyhow!(e),
        MonteCarloError::Sim(e) => anyhow::Error::new(e),
        MonteCarloError::Metrics(e) => anyhow::Error::new(e),
    }
}

fn merge_simulate(
    a: &MergeOutput<'_>,
    shards: &[Loaded],
    sources: &Sources,
    pool: &rayon::ThreadPool,
) -> Result<()> {
    let (first, m) = (&shards[0].dir, &shards[0].m);
    let want = m.input(first, "plan_fingerprint")?;
    for s in shards {
        let p = s.dir.join("plan.csv");
        let bytes = std::fs::read(&p).with_context(|| format!("cannot read {}", p.display()))?;
        if hex(fingerprint(&bytes)) != want {
            bail!(
                "{}: not the plan its shard.json names (changed after the shard ran)",
                p.display()
            );
        }
    }
    let plan = Plan::load_csv(&first.join("plan.csv"))?;
    let offset = [
        m.float(first, "tracking_offset_x")?,
        m.float(first, "tracking_offset_y")?,
    ];
    let reference = omnikin_sim::metrics::tracked_reference(&plan, offset);
    let trials = m.runs[0].trials;
    let parse = |k: &str| -> Result<u64> {
        m.input(first, k)?
            .parse()
            .ok()
            .with_context(|| format!("{}: {k} is not a count", first.join(MANIFEST).display()))
    };
    let info = SimulationInfo {
        robot: m.input(first, "robot")?.to_string(),
        kind: m.input(first, "kind")?.to_string(),
        plan: m.names.get("plan").cloned().unwrap_or_default(),
        disturbances: m.names.get("disturbances").cloned(),
        trials: parse("trials")?,
        seed: parse("seed")?,
        plant_rate_hz: m.float(first, "plant_rate_hz")?,
    };
    create_dir_for(
        a.out,
        &[
            "metrics.json",
            "trials.csv",
            "mean.csv",
            &a.figures.file_name("figure"),
        ],
    )?;
    // trials.csv: the shards' rows in shard (= trial) order under one header.
    let trials_path = a.out.join("trials.csv");
    let mut trials_csv = crate::output::OutFile::create("--out", &trials_path)?;
    let mut header: Option<String> = None;
    let samples = plan.samples.len();
    for s in shards {
        let p = s.dir.join("trials.csv");
        let f = std::fs::File::open(&p).with_context(|| format!("cannot read {}", p.display()))?;
        let mut r = std::io::BufReader::new(f);
        let mut h = String::new();
        r.read_line(&mut h)
            .with_context(|| format!("cannot read {}", p.display()))?;
        match &header {
            None => {
                trials_csv.write_all(h.as_bytes())?;
                header = Some(h);
            }
            Some(want) if *want != h => {
                bail!(
                    "{}: another header than {}'s trials.csv",
                    p.display(),
                    first.display()
                )
            }
            Some(_) => {}
        }
        let mut rows = 0usize;
        loop {
            let buf = r
                .fill_buf()
                .with_context(|| format!("cannot read {}", p.display()))?;
            if buf.is_empty() {
                break;
            }
            rows += buf.iter().filter(|b| **b == b'\n').count();
            trials_csv
                .write_all(buf)
                .with_context(|| format!("cannot write {}", trials_path.display()))?;
            let n = buf.len();
            r.consume(n);
        }
        let want = (s.m.runs[0].end - s.m.runs[0].first) * samples;
        if rows != want {
            bail!(
                "{}: {rows} rows, {want} expected for its trials (truncated or edited)",
                p.display()
            );
        }
    }
    trials_csv.commit()?;
    let pb = crate::output::progress_bar(trials as u64, "merging");
    let mc = pool
        .install(|| {
            omnikin_sim::evaluate_runs(
                &|i| sources.read(SIMULATE, i),
                samples,
                &reference,
                trials,
                &|| pb.inc(1),
            )
        })
        .map_err(visit_err)?;
    pb.finish_and_clear();
    crate::sim_output::finish_simulation(a.out, &info, &reference, mc, a.figures)
}

fn merge_reproduce(
    a: &MergeOutput<'_>,
    shards: &[Loaded],
    sources: &Sources,
    pool: &rayon::ThreadPool,
    start: std::time::Instant,
) -> Result<()> {
    use omnikin_sim::reproduce as rp;
    let (first, m) = (&shards[0].dir, &shards[0].m);
    let count = |k: &str| -> Result<usize> {
        m.input(first, k)?
            .parse()
            .ok()
            .with_context(|| format!("{}: {k} is not a count", first.join(MANIFEST).display()))
    };
    let rate = m.float(first, "rate")?;
    let robot_file = m.input(first, "robot_file")?.to_string();
    let robot_toml = m.input(first, "robot_toml")?.to_string();
    let d = RobotDescription::from_toml_str(&robot_toml, &robot_file)?;
    let series = rp::sphere_2019_series(&d, rate)?;
    if series_fingerprint(&series) != m.input(first, "series_fingerprint")? {
        bail!("{first:?}: the shards planned other series than this omnikin plans at {rate} Hz");
    }
    let known: Vec<&'static str> = rp::profiles()
        .iter()
        .map(|p| p.0)
        .chain(["dynamic", "closed-loop"])
        .collect();
    let profiles: Vec<&'static str> =
        m.input(first, "profiles")?
            .split(',')
            .map(|p| {
                known.iter().copied().find(|k| *k == p).with_context(|| {
                    format!("{}: unknown profile {p}", first.join(MANIFEST).display())
                })
            })
            .collect::<Result<_>>()?;
    let dynamic = if profiles.contains(&"dynamic") {
        let info = crate::sim_output::DynamicInfo::new(&robot_file, &robot_toml, &d)?;
        if exact(info.params.com_depth) != m.input(first, "dynamic_fitted_value")? {
            bail!(
                "{}: the shards' robot file does not load to their com_depth",
                first.join(MANIFEST).display()
            );
        }
        Some(info)
    } else {
        None
    };
    let info =
        ReproduceInfo {
            trials: count("trials")?,
            dynamic_trials: count("dynamic_trials")?,
            prior_samples: count("prior_samples")?,
            seed: m.input(first, "seed")?.parse().ok().with_context(|| {
                format!("{}: seed is not a number", first.join(MANIFEST).display())
            })?,
            rate,
            profiles: profiles.clone(),
            robot_file,
            robot_toml,
            dynamic,
        };
    let runs: Vec<(&'static str, usize)> = profiles
        .iter()
        .map(|p| {
            (
                *p,
                if *p == "dynamic" || *p == "closed-loop" {
                    info.dynamic_trials
                } else {
                    info.trials
                },
            )
        })
        .collect();
    create_dir_for(a.out, &["table.md", "table.csv", "metrics.json"])?;
    let total: u64 = series.len() as u64 * runs.iter().map(|r| r.1 as u64).sum::<u64>();
    let pb = crate::output::progress_bar(total, "merging the Sphere paper's re-run");
    let report_dynamic_trials = if profiles.contains(&"dynamic") {
        info.dynamic_trials
    } else {
        0
    };
    let mut report = crate::sim_output::Report::new(a.out, info, a.figures);
    for s in &series {
        let outcomes = pool
            .install(|| {
                rp::evaluate_series(
                    s,
                    &runs,
                    &|name, i| sources.read(&format!("{}/{name}", s.name), i),
                    &|| pb.inc(1),
                )
            })
            .map_err(visit_err)?;
        let tally = if report_dynamic_trials > 0 {
            // The shards in shard order hold the trials in trial order.
            let events: Vec<_> = shards
                .iter()
                .flat_map(|sh| sh.m.contacts.get(&s.name).into_iter().flatten())
                .copied()
                .collect();
            if events.len() != report_dynamic_trials {
                bail!(
                    "{}: the shards hold the contact events of {} of its {report_dynamic_trials} dynamic trials (shards of an older omnikin, or edited)",
                    s.name,
                    events.len()
                );
            }
            Some(rp::ContactTally::of(&events))
        } else {
            None
        };
        let band = pool.install(|| report.prior_band(s))?;
        report.add(s, &outcomes, tally, band)?;
    }
    pb.finish_and_clear();
    report.finish(start)
}
