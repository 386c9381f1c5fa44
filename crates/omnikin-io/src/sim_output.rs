//! What a simulation writes into its output directory and prints: `trials.csv`, `mean.csv`,
//! `metrics.json`, the figures and the summary line of `simulate` (every plant), and the
//! report of `reproduce` (table.md, table.csv, metrics.json, one figure per series and
//! profile); shared by one run, its shards and `merge`, for every front end. The figures are
//! the caller's ([`RunFigures`]; `omnikin_plot::FigureFormat` draws them), so this crate needs
//! no plotting.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use omnikin::description::RobotDescription;
use omnikin_plan::Plan;
use omnikin_sim::metrics::{MeanTrajectory, Metrics};
use omnikin_sim::{Profile, Trial};
use serde_json::json;

use omnikin_sim::metrics::Run;

/// How the figures of a simulation are named and drawn (`omnikin_plot::FigureFormat`
/// implements it: SVG, PNG or PDF, drawn in the Sphere paper's style).
pub trait RunFigures: Sync {
    /// The file name of the figure `stem` (`figure` → `figure.svg`).
    fn file_name(&self, stem: &str) -> String;
    /// Draws the plan, `runs` (the first few of `n_runs`) and their mean to `path` under
    /// `title`; errors name `--out`.
    ///
    /// # Errors
    /// A file that cannot be written.
    fn draw(
        &self,
        path: &Path,
        title: &str,
        plan: &Plan,
        runs: &[Run],
        mean: &MeanTrajectory,
        n_runs: usize,
    ) -> Result<()>;
}

/// Writes a dynamic run's `trials.csv`, `metrics.json` and `mean.csv` into `out`.
pub fn write_dynamic_run(
    out: &Path,
    plan: &Plan,
    sim: &omnikin_sim::dynamic_run::DynamicSimulation,
) -> Result<()> {
    let trials_path = out.join("trials.csv");
    let mut trials_csv = crate::output::OutFile::create("--out", &trials_path)?;
    writeln!(trials_csv, "{}", trials_header(3))
        .and_then(|_| write_trial(&mut trials_csv, 0, sim.trial()))
        .with_context(|| format!("cannot write {}", trials_path.display()))?;
    trials_csv.commit()?;
    write_file(&out.join("metrics.json"), |w| {
        writeln!(
            w,
            "{}",
            serde_json::to_string_pretty(&sim.metrics_json).unwrap_or_default()
        )
    })?;
    write_mean(&out.join("mean.csv"), plan, &sim.evaluation.mean)
}

/// Creates the output directory of `--out` (new, or empty unless --force; see
/// [`crate::output`]).
fn create_dir(dir: &Path) -> Result<()> {
    crate::output::create_dir("--out", dir)
}

/// [`create_dir`], then the output rules for every file the command will write there, before
/// any is written: with `--force`, an input under one of these names used to be refused only
/// when its turn came, after the files before it had been replaced (a failed command leaving
/// new `metrics.json`/`trials.csv` beside the old figure).
pub fn create_dir_for(dir: &Path, names: &[&str]) -> Result<()> {
    create_dir(dir)?;
    for n in names {
        crate::output::check_file("--out", &dir.join(n))?;
    }
    Ok(())
}

/// Writes one file of the output directory (temporary file, then rename).
pub fn write_file(
    path: &Path,
    write: impl FnOnce(&mut crate::output::OutFile) -> std::io::Result<()>,
) -> Result<()> {
    crate::output::write_file("--out", path, write)
}

/// Writes `mean.csv`: the mean trajectory, its 95 % half-widths, and the plan
/// ([`omnikin_sim::run_columns`]).
pub fn write_mean(path: &Path, plan: &Plan, mean: &MeanTrajectory) -> Result<()> {
    use omnikin_sim::run_columns::{MEAN_COLUMNS, csv_line, mean_row};
    write_file(path, |w| {
        writeln!(w, "{}", MEAN_COLUMNS.join(","))?;
        for k in 0..plan.samples.len() {
            writeln!(w, "{}", csv_line(&mean_row(plan, mean, k)))?;
        }
        Ok(())
    })
}

/// Header of `trials.csv` for a robot of `wheels` wheels ([`omnikin_sim::run_columns`]).
pub fn trials_header(wheels: usize) -> String {
    omnikin_sim::run_columns::trial_columns(wheels).join(",")
}

/// Writes trial `i`'s rows of `trials.csv`.
pub fn write_trial(w: &mut impl Write, i: usize, tr: &Trial) -> std::io::Result<()> {
    use omnikin_sim::run_columns::{csv_line, trial_row};
    let mut row = Vec::new();
    for k in 0..tr.t.len() {
        trial_row(i, tr, k, &mut row);
        writeln!(w, "{}", csv_line(&row))?;
    }
    Ok(())
}

/// The metrics as they are written: every one a finite number, or an error naming the first
/// that is not (JSON would write NaN as `null`, read as "no value").
pub fn finite(m: &Metrics) -> Result<()> {
    m.check_finite()
        .context("the metrics cannot be computed for these inputs")
}

/// Prints the headline metrics for a person.
pub fn print_summary(m: &Metrics) {
    crate::errln!(
        "{} run(s), path {:.3} m in {:.2} s: max deviation {:.4} m ({:.2} % of path), RMS {:.4} m, plan farthest from a run {:.4} m, end-point error {:.4} m, max deviation from the mean {:.4} m",
        m.runs,
        m.path_length_m,
        m.duration_s,
        m.max_deviation_m,
        m.max_deviation_pct_of_path,
        m.rms_deviation_m,
        m.max_plan_distance_from_run_m,
        m.end_point_error_m,
        m.max_deviation_from_mean_m
    );
    if let (Some(p), Some(f), Some(r)) = (m.planned_circle, m.fitted_circle, m.radius_ratio) {
        crate::errln!(
            "circle: planned radius {:.4} m, fitted {:.4} m (centre {:.4}, {:.4}), ratio {:.3}",
            p.radius,
            f.radius,
            f.center[0],
            f.center[1],
            r
        );
    }
}

/// Warns about the sections of a disturbance profile that `robot`'s kind does not simulate
/// ([`Profile::unused_sections`]).
pub fn warn_unused_sections(profile: &Profile, robot: &omnikin::Robot<f64>, file: &str) {
    for w in profile.unused_sections(robot) {
        crate::errln!("warning: {file}: {w}");
    }
}

/// What `simulate`'s outputs say about the run (metrics.json's `simulation`, the figure's
/// title): the same from one run and from `omnikin merge` of its shards.
#[derive(Clone, Debug)]
pub struct SimulationInfo {
    /// Robot name.
    pub robot: String,
    /// Robot kind.
    pub kind: String,
    /// The plan file as named on the command line.
    pub plan: String,
    /// The disturbance profile as named on the command line.
    pub disturbances: Option<String>,
    /// `--trials`.
    pub trials: u64,
    /// `--seed`.
    pub seed: u64,
    /// The plant's integration rate, Hz.
    pub plant_rate_hz: f64,
}

/// The finishing step of `simulate`, shared by one run and `omnikin merge`: checks the
/// metrics, writes metrics.json, mean.csv and the figure (`figure.<format>`) into `out`
/// (trials.csv is already there) and prints the summary. `reference` is the planned path of
/// the tracked point.
pub fn finish_simulation(
    out: &Path,
    info: &SimulationInfo,
    reference: &Plan,
    mc: omnikin_sim::MonteCarlo,
    figures: &dyn RunFigures,
) -> Result<()> {
    let figure = figures.file_name("figure");
    let (metrics, mean) = (mc.evaluation.metrics, mc.evaluation.mean);
    finite(&metrics)?;
    let plan = reference;
    let meta = json!({
        "robot": info.robot, "kind": info.kind, "plan": info.plan,
        "disturbances": info.disturbances,
        "trials": info.trials, "seed": info.seed, "plant_rate_hz": info.plant_rate_hz,
    });
    let mut j = serde_json::to_value(&metrics)?;
    j["simulation"] = meta;
    write_file(&out.join("metrics.json"), |w| {
        writeln!(
            w,
            "{}",
            serde_json::to_string_pretty(&j).unwrap_or_default()
        )
    })?;
    write_mean(&out.join("mean.csv"), plan, &mean)?;
    let shown = if (mc.figure_runs.len() as u64) < info.trials {
        format!(" (first {} drawn)", mc.figure_runs.len())
    } else {
        String::new()
    };
    figures.draw(
        &out.join(&figure),
        &format!(
            "{} — {} trials of {}{shown}",
            info.robot, info.trials, info.plan
        ),
        plan,
        &mc.figure_runs,
        &mean,
        metrics.runs,
    )?;
    print_summary(&metrics);
    crate::errln!(
        "wrote {}/{{metrics.json, trials.csv, mean.csv, {figure}}}",
        out.display().to_string().trim_end_matches('/')
    );
    Ok(())
}

/// What `reproduce` says for the built-in preset as its robot file.
pub const PRESET_LABEL: &str = "preset sphere-omni";

/// The built-in `sphere-omni` preset's TOML text.
pub fn preset_toml() -> Result<&'static str> {
    omnikin::description::PRESETS
        .iter()
        .find(|(n, _)| *n == "sphere-omni")
        .map(|(_, t)| *t)
        .context("the sphere-omni preset is missing")
}

/// Says on stderr when a robot file's `[dynamics]` names a floor and gives some of its values
/// explicitly too: which ones override the surface's (`omnikin_sim`'s `floor_note`).
pub fn say_floor_overrides(
    d: &RobotDescription,
    params: &omnikin_sim::dynamics::sphere::SphereDynamics,
) {
    if let Some(note) = omnikin_sim::dynamics::sphere::floor_override_note(d, params) {
        crate::errln!("note: robot {}: {note}", d.name);
    }
}

/// The dynamic profile's robot file as loaded: the parameters and what the outputs say about
/// them.
#[derive(Clone, Debug)]
pub struct DynamicInfo {
    /// The robot file's `[dynamics]` as loaded.
    pub params: omnikin_sim::dynamics::sphere::SphereDynamics,
    /// Its name and its one fitted value.
    pub source: omnikin_sim::reproduce::DynamicSource,
}

impl DynamicInfo {
    /// The dynamic profile of `d`, loaded from `robot_toml` named `robot_file`.
    pub fn new(robot_file: &str, robot_toml: &str, d: &RobotDescription) -> Result<Self> {
        let params = omnikin_sim::dynamics::sphere::SphereDynamics::from_description(d)
            .with_context(|| format!("{robot_file}: [dynamics]"))?;
        say_floor_overrides(d, &params);
        let source = omnikin_sim::reproduce::DynamicSource::new(robot_file, robot_toml, &params);
        Ok(Self { params, source })
    }
}

/// What `reproduce`'s outputs say about the run: the same from one run and from `omnikin
/// merge` of its shards.
#[derive(Clone, Debug)]
pub struct ReproduceInfo {
    /// `--trials` per series and kinematic profile.
    pub trials: usize,
    /// Trials per series of the dynamic profile (0 when it does not run).
    pub dynamic_trials: usize,
    /// Robots drawn from the priors for the dynamic profile's prior band (0: none).
    pub prior_samples: usize,
    /// `--seed`.
    pub seed: u64,
    /// `--rate`, Hz.
    pub rate: f64,
    /// The profiles that ran, in table order.
    pub profiles: Vec<&'static str>,
    /// The robot file the series were planned with (and the dynamic profile simulated with):
    /// its path as given or [`PRESET_LABEL`].
    pub robot_file: String,
    /// Its TOML text (shards carry it, so a merge rebuilds the same robot).
    pub robot_toml: String,
    /// The dynamic profile's parameters, when it ran.
    pub dynamic: Option<DynamicInfo>,
}

/// The finishing step of `reproduce`, shared by one run and `omnikin merge`: one figure per
/// series and profile as the outcomes come ([`Report::add`]), then table.md, table.csv and
/// metrics.json ([`Report::finish`]).
pub struct Report<'a> {
    out: &'a Path,
    info: ReproduceInfo,
    rows: Vec<omnikin_sim::reproduce::Row>,
    all: serde_json::Map<String, serde_json::Value>,
    drawn: usize,
    figures: &'a dyn RunFigures,
    /// The dynamic profile's contact events over each series' trials, in series order.
    tallies: Vec<(String, omnikin_sim::reproduce::ContactTally)>,
}

impl<'a> Report<'a> {
    /// A report into the output directory `out` (created and checked), its figures drawn by
    /// `figures`.
    pub fn new(out: &'a Path, info: ReproduceInfo, figures: &'a dyn RunFigures) -> Self {
        Self {
            out,
            info,
            rows: Vec::new(),
            all: serde_json::Map::new(),
            drawn: 0,
            figures,
            tallies: Vec::new(),
        }
    }

    /// The dynamic profile's prior band of series `s` (`None` without the dynamic profile or
    /// with `prior_samples` 0); its robots run on the current rayon pool (the caller's
    /// `pool.install`).
    pub fn prior_band(
        &self,
        s: &omnikin_sim::reproduce::PaperSeries,
    ) -> Result<Option<omnikin_sim::reproduce::PriorBand>> {
        let Some(d) = self.info.dynamic.as_ref() else {
            return Ok(None);
        };
        omnikin_sim::reproduce::prior_band(d.params, s, self.info.prior_samples, self.info.seed)
            .with_context(|| format!("{}: prior band", s.name))
    }

    /// One series' outcomes: its figures, its metrics and its table row; `tally`, the
    /// dynamic profile's contact events over its trials, and `band`, its prior band (when
    /// they were made).
    pub fn add(
        &mut self,
        s: &omnikin_sim::reproduce::PaperSeries,
        outcomes: &[omnikin_sim::reproduce::Outcome],
        tally: Option<omnikin_sim::reproduce::ContactTally>,
        band: Option<omnikin_sim::reproduce::PriorBand>,
    ) -> Result<()> {
        for o in outcomes {
            if o.profile == "ideal" {
                continue;
            }
            finite(&o.metrics).with_context(|| format!("{} ({})", s.name, o.profile))?;
            let shown = if o.runs.len() < o.metrics.runs {
                format!(" (first {} drawn)", o.runs.len())
            } else {
                String::new()
            };
            let title = format!(
                "Sphere paper, {} at {:.1} m/s — {} profile, {} runs{shown}",
                s.experiment_name(),
                s.speed,
                o.profile,
                o.metrics.runs
            );
            self.figures.draw(
                &self
                    .out
                    .join(self.figures.file_name(&format!("{}-{}", s.name, o.profile))),
                &title,
                &s.plan,
                &o.runs,
                &o.mean,
                o.metrics.runs,
            )?;
            self.drawn += 1;
        }
        self.all.insert(
            s.name.clone(),
            json!(
                outcomes
                    .iter()
                    .map(|o| (o.profile, &o.metrics))
                    .collect::<std::collections::BTreeMap<_, _>>()
            ),
        );
        if let Some(d) = self.info.dynamic.as_ref()
            && outcomes.iter().any(|o| o.profile == "dynamic")
        {
            let c = omnikin_sim::reproduce::nominal_contact_events(d.params, s)
                .with_context(|| format!("{}: contact events", s.name))?;
            if let Some(series) = self.all.get_mut(&s.name) {
                series["dynamic_nominal_contact_events"] = json!({
                    "roller_slips": c.roller_slips,
                    "lift_offs": c.lift_offs,
                    "floor_slips": c.floor_slips,
                    "lost_steps": c.lost_steps,
                });
                if let Some(t) = tally {
                    series["dynamic_contact_events"] = json!(t);
                }
                if let Some(b) = band {
                    series["dynamic_prior_band"] = json!(b);
                }
            }
            if let Some(t) = tally {
                self.tallies.push((s.name.clone(), t));
            }
        }
        self.rows
            .push(omnikin_sim::reproduce::row(s, outcomes, band.as_ref()));
        Ok(())
    }

    /// Writes table.md, table.csv and metrics.json, prints the table, and says what was
    /// written in how long since `start`.
    pub fn finish(self, start: std::time::Instant) -> Result<()> {
        use omnikin_sim::reproduce as rp;
        let (out, info, rows) = (self.out, &self.info, &self.rows);
        let source = info.dynamic.as_ref().map(|d| &d.source);
        let dyn_trials = info.dynamic_trials;
        let md = rp::table_markdown(
            rows,
            info.trials,
            info.seed,
            source.map(|f| (f, dyn_trials)),
        );
        write_file(&out.join("table.md"), |w| w.write_all(md.as_bytes()))?;
        write_file(&out.join("table.csv"), |w| {
            w.write_all(rp::table_csv(rows).as_bytes())
        })?;
        let (g, p) = rp::spin_slip_fit();
        let meta = json!({
            "trials": info.trials, "dynamic_trials": dyn_trials, "seed": info.seed,
            "dynamic_prior_samples": source.map(|_| info.prior_samples),
            "dynamic_prior_band_note": source.map(|_| "series.*.dynamic_prior_band: 5th and 95th percentiles of the deterministic model's max deviation (% of path) and radius ratio over dynamic_prior_samples robots drawn uniformly from each [dynamics] value's plausible range (omnikin_sim::dynamics::sphere::priors::PRIORS; com_depth kept), no trial jitter"),
            "profiles": info.profiles,
            "plan_rate_hz": info.rate,
            "spin_slip_gain": g, "spin_slip_exponent": p,
            "spin_slip_fit": { "fitted_on": ["circle-0.4", "circle-0.5"], "parameters": ["spin_slip_gain", "spin_slip_exponent"] },
            "dynamic_robot_file": source.map(|f| &f.robot_file),
            "dynamic_fitted": source.map(|f| json!({
                "name": f.fitted_name, "value": f.fitted_value, "unit": "m",
                "comment": f.fitted_comment,
            })),
            "dynamic_contact_events_note": source.map(|_| "series.*.dynamic_nominal_contact_events: roller slips and lift-offs per wheel, floor slides (starts of the shell sliding on the floor), lost steps per wheel, of the deterministic model with the robot file's values (no trial jitter); series.*.dynamic_contact_events: the same events over every trial of the dynamic profile (each with its jitter), summed over the wheels: total, trials_with_any, max_per_trial"),
            "series": self.all,
        });
        write_file(&out.join("metrics.json"), |w| {
            writeln!(
                w,
                "{}",
                serde_json::to_string_pretty(&meta).unwrap_or_default()
            )
        })?;
        crate::outln!("{md}")?;
        if !self.tallies.is_empty() {
            crate::errln!("{}", contact_sentence(&self.tallies));
        }
        crate::errln!(
            "wrote {dir}/table.md, {dir}/table.csv, {dir}/metrics.json and {n} figures in {:.1} s",
            start.elapsed().as_secs_f64(),
            dir = out.display(),
            n = self.drawn
        );
        Ok(())
    }
}

/// The dynamic profile's contact events over the trials of each series, in one sentence for
/// stderr: per kind, the series with any (trials with any of the trials, most in one trial).
pub fn contact_sentence(tallies: &[(String, omnikin_sim::reproduce::ContactTally)]) -> String {
    use omnikin_sim::reproduce::{ContactTally, EventCount};
    type Kind = fn(&ContactTally) -> EventCount;
    let kinds: [(&str, Kind); 4] = [
        ("roller slips", |t| t.roller_slips),
        ("lift-offs", |t| t.lift_offs),
        ("floor slides", |t| t.floor_slips),
        ("lost steps", |t| t.lost_steps),
    ];
    let parts: Vec<String> = kinds
        .iter()
        .map(|(kind, get)| {
            let hit: Vec<String> = tallies
                .iter()
                .filter(|(_, t)| get(t).total > 0)
                .map(|(name, t)| {
                    let c = get(t);
                    format!(
                        "{name} {}/{} (≤ {})",
                        c.trials_with_any, t.trials, c.max_per_trial
                    )
                })
                .collect();
            if hit.is_empty() {
                format!("{kind} in no trial")
            } else {
                format!("{kind} in {}", hit.join(", "))
            }
        })
        .collect();
    format!(
        "dynamic profile, contact events over every trial (trials with any / trials, most in one trial): {}",
        parts.join("; ")
    )
}
