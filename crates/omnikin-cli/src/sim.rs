//! `simulate` and `evaluate`: Monte-Carlo simulation of a plan, and the same metrics on real
//! tracked runs.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin_plan::Plan;
use omnikin_sim::metrics::{MeanTrajectory, Metrics, evaluate, tracked_reference};
use omnikin_sim::track::{Alignment, Track};
use omnikin_sim::{MonteCarloError, Profile, Trial};
use serde_json::json;

use crate::plot::FigureFormat;

/// `omnikin simulate`.
#[derive(clap::Args, Debug)]
pub struct SimulateArgs {
    /// Plan CSV (t,x,y,heading,vx,vy,yaw_rate,w1..wN[,s1..sN,sd1..sdN]: one w per wheel, steer
    /// columns for the steerable kinds), e.g. from `omnikin plan`.
    pub plan: PathBuf,
    /// Robot: preset name (sphere-omni, ballbot, caster3, kiwi, x-drive, mecanum, swerve4) or
    /// path to a TOML description.
    #[arg(long)]
    pub robot: String,
    /// Disturbance profile (TOML; see the omnikin-sim docs). Default: the ideal kinematic plant.
    #[arg(long, value_name = "PROFILE.toml")]
    pub disturbances: Option<PathBuf>,
    /// Number of Monte-Carlo trials.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=100_000))]
    pub trials: u64,
    /// Random seed: the same seed gives the same numbers on any number of threads.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads, 1 to 256 (default: all cores).
    #[arg(long, value_parser = crate::args::threads)]
    pub threads: Option<usize>,
    /// Output directory (created): metrics.json, trials.csv, mean.csv, figure.svg (or
    /// figure.png / figure.pdf with --figure-format).
    #[arg(long)]
    pub out: PathBuf,
    /// Format of the figure in --out: svg (default), png (rasterised, 2 px per SVG px) or pdf
    /// (vector, font embedded); the file is figure.<format>.
    #[arg(long, value_enum, default_value_t = FigureFormat::Svg)]
    pub figure_format: FigureFormat,
    /// Also write what each trial's sensors recorded, for `omnikin odometry`:
    /// DIR/sensors/trial-NNN/{encoders.csv, fixes.csv, imu.csv, truth.csv}.
    #[arg(long)]
    pub emit_sensors: bool,
    /// Sensor profile for --emit-sensors (TOML: counts_per_rev, [gyro], [yaw], [imu], [camera],
    /// [tilt]; see omnikin_sim::sensors). Default: 4096-count encoders, a gyro, camera fixes at 10 Hz.
    #[arg(long, value_name = "SENSORS.toml", requires = "emit_sensors")]
    pub sensors: Option<PathBuf>,
    /// Plant: `kinematic` (the motors' motion through the forward kinematics, with the
    /// disturbance profile) or `dynamic` (the robot file's [dynamics]: sphere-omni's shell +
    /// platform, deterministic; ballbot's balance controller on its 3D model with seeded
    /// sensor noise; one trial, no disturbance profile yet).
    #[arg(long, value_enum, default_value_t = PlantKind::Kinematic)]
    pub plant: PlantKind,
    /// Ballbot, --plant dynamic: start with the body leaning this many degrees toward +x.
    #[arg(long, allow_hyphen_values = true, value_name = "DEG", value_parser = crate::sim_ballbot::parse_tilt)]
    pub initial_tilt_deg: Option<f64>,
    /// Ballbot, --plant dynamic: a horizontal impulse on the body's centre of mass, N_S@T
    /// (N·s along +x at time T s from the start of the 1 s lead-in) or N_S@T@DEG (direction,
    /// degrees from +x); repeatable. A fall is reported in metrics.json ("fallen", exit 0).
    #[arg(long, allow_hyphen_values = true, value_name = "N_S@T[@DEG]", value_parser = crate::sim_ballbot::parse_push)]
    pub push: Vec<crate::sim_ballbot::PushArg>,
    /// Also write the first trial as MCAP with Foxglove schemas (/pose, /truth, /tf, /plan,
    /// /wheels; docs/seeing-the-robot.md).
    #[arg(long, value_name = "FILE")]
    pub mcap: Option<PathBuf>,
    /// With --mcap: the first N trials in the one file (trial 0 on /pose, /truth, …, trial k
    /// on /trial-NNN/pose, …).
    #[arg(long, value_name = "N", requires = "mcap", value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub mcap_trials: Option<u64>,
    /// Run only shard K of N (1 ≤ K ≤ N ≤ --trials): trials ⌊(K−1)·T/N⌋ to ⌊K·T/N⌋−1 of the
    /// T = --trials, seeded exactly as in one run. --out then holds that shard's trials.csv
    /// rows, its runs (runs.bin), a copy of the plan and shard.json; `omnikin merge` of all N
    /// shard directories writes what one run writes, bit for bit.
    #[arg(long, value_name = "K/N", value_parser = crate::shard::parse_shard)]
    pub shard: Option<omnikin_sim::shard::Shard>,
}

/// The plant `omnikin simulate` runs a plan through.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlantKind {
    /// Forward kinematics with the disturbance profile (omnikin_sim::plant_step).
    Kinematic,
    /// The sphere's shell + platform dynamics (omnikin_sim::dynamics::sphere).
    Dynamic,
}

/// The sensor profile of `--emit-sensors`.
fn sensor_profile(sensors: Option<&Path>) -> Result<omnikin_sim::sensors::SensorProfile> {
    use omnikin_sim::sensors::SensorProfile;
    Ok(match sensors {
        Some(p) => {
            let text = omnikin::description::read_text_limited(
                p,
                omnikin::description::MAX_TOML_BYTES,
                "MAX_TOML_BYTES of omnikin::description",
            )
            .with_context(|| format!("cannot read sensor profile {}", p.display()))?;
            SensorProfile::from_toml_str(&text, &p.display().to_string())?
        }
        None => SensorProfile::typical(),
    })
}

/// Writes the sensor logs of trial `i` under `dir/sensors/trial-NNN/`.
fn emit_sensors(
    dir: &Path,
    robot: &omnikin::Robot<f64>,
    i: usize,
    trial: &Trial,
    profile: &omnikin_sim::sensors::SensorProfile,
    seed: u64,
) -> Result<()> {
    use omnikin_sim::sensors::{
        emit_trial, write_encoder_log, write_fixes, write_imu, write_truth,
    };
    let s = emit_trial(robot, i, trial, profile, seed);
    let d = dir.join("sensors").join(format!("trial-{i:03}"));
    crate::output::create_subdir("--out", &d)?;
    write_file(&d.join("encoders.csv"), |w| {
        write_encoder_log(&s.encoder, w)
    })?;
    write_file(&d.join("truth.csv"), |w| write_truth(trial, w))?;
    if !s.fixes.is_empty() {
        write_file(&d.join("fixes.csv"), |w| write_fixes(&s.fixes, w))?;
    }
    if !s.imu.is_empty() {
        write_file(&d.join("imu.csv"), |w| write_imu(&s.imu, w))?;
    }
    Ok(())
}

/// `omnikin simulate --plant dynamic`: the plan once through the sphere's dynamic model
/// (deterministic), with the same files as the kinematic plant and the dynamics' own figures
/// (largest tilt, pull-out events, peak motor torques) in `metrics.json`'s `simulation`
/// ([`omnikin_sim::dynamic_run`]).
fn simulate_dynamic(a: &SimulateArgs, d: &RobotDescription, plan: &Plan) -> Result<()> {
    use omnikin_sim::dynamic_run::{DynamicOptions, DynamicPlant, check_kind, one_trial_note};
    check_kind(d)?;
    if a.disturbances.is_some() || a.emit_sensors {
        bail!("--plant dynamic does not take --disturbances or --emit-sensors yet");
    }
    if a.trials > 1 {
        crate::errln!("note: {}", one_trial_note(d));
    }
    let opts = DynamicOptions {
        plan_name: a.plan.display().to_string(),
        seed: a.seed,
        ..DynamicOptions::default()
    };
    let plant = DynamicPlant::new(d, plan, &opts)?;
    let figure = a.figure_format.file_name("figure");
    create_dir_for(&a.out, &["metrics.json", "trials.csv", "mean.csv", &figure])?;
    let sim = plant.run(d, plan, &opts)?;
    write_dynamic_run(&a.out, plan, &sim)?;
    crate::mcap_log::one_trial(a.mcap.as_deref(), plan, sim.trial())?;
    crate::figures::trajectory_figure(
        "--out",
        &a.out.join(&figure),
        &format!("{} — dynamic plant, {}", d.name, a.plan.display()),
        plan,
        &sim.runs,
        &sim.evaluation.mean,
        sim.evaluation.metrics.runs,
    )?;
    print_summary(&sim.evaluation.metrics);
    for line in sim.summary_lines(&plant) {
        crate::errln!("{line}");
    }
    crate::errln!(
        "wrote {}/{{metrics.json, trials.csv, mean.csv, {figure}}}",
        a.out.display().to_string().trim_end_matches('/')
    );
    Ok(())
}

/// Writes a dynamic run's `trials.csv`, `metrics.json` and `mean.csv` into `out`.
pub(crate) fn write_dynamic_run(
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

/// `omnikin evaluate`: tracked runs against a plan (`--plan`), or pose estimates against
/// ground truth (`--truth`, see [`crate::evaluate_truth`]).
// Exactly one of `--plan` and `--truth` (a group, so that clap's message names both).
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("reference").required(true).args(["plan", "truth"])))]
pub struct EvaluateArgs {
    /// The plan the runs followed (plan CSV).
    #[arg(long)]
    pub plan: Option<PathBuf>,
    /// Ground truth (t,x,y[,heading] CSV): score each file as a pose estimate against it with
    /// the absolute trajectory error and the relative pose error (Sturm et al. 2012, the TUM
    /// RGB-D benchmark) instead of comparing runs with a plan.
    #[arg(long, value_name = "TRUTH.csv")]
    pub truth: Option<PathBuf>,
    /// Tracked runs (with --plan) or pose estimates (with --truth): CSV files with columns
    /// t,x,y and optionally heading (a pose CSV of `omnikin odometry`).
    #[arg(required = true, value_name = "TRACK.csv")]
    pub tracks: Vec<PathBuf>,
    /// With --truth: the alignment before the ATE: `none` (the estimate's start pose is
    /// known) or `se2` (the least-squares rotation and translation, Umeyama/Horn in 2-D).
    #[arg(long, value_enum, default_value = "none", requires = "truth")]
    pub align: crate::evaluate_truth::AlignArg,
    /// With --truth: RPE over pairs of samples this many seconds apart.
    #[arg(long, value_name = "S", requires = "truth", conflicts_with = "rpe_distance", value_parser = crate::args::finite_f64)]
    pub rpe_time: Option<f64>,
    /// With --truth: RPE over pairs of samples this many metres apart along the truth's path
    /// (default: --rpe-time 1).
    #[arg(long, value_name = "M", requires = "truth", value_parser = crate::args::finite_f64)]
    pub rpe_distance: Option<f64>,
    /// With --truth: print one JSON object (per-run and overall figures) instead of text.
    #[arg(long, requires = "truth")]
    pub json: bool,
    /// Displacement from the first tracked position that counts as the start of motion, m.
    #[arg(long, default_value_t = 0.005, conflicts_with = "truth")]
    pub motion_threshold: f64,
    /// Keep the tracked coordinates as they are (default: translate each run so it starts
    /// moving from the plan's start point).
    #[arg(long, conflicts_with = "truth")]
    pub no_align_position: bool,
    /// Where the tracked marker sits on the robot: X,Y in the robot frame, m (default 0,0:
    /// the centre). The runs are compared with the planned path of that point.
    #[arg(long, allow_hyphen_values = true, value_name = "X,Y", value_parser = parse_pair, conflicts_with = "truth")]
    pub tracking_offset: Option<[f64; 2]>,
    /// Output directory (created): metrics.json, runs.csv, mean.csv, figure.svg (or
    /// figure.png / figure.pdf with --figure-format).
    #[arg(long, required_unless_present = "truth", conflicts_with = "truth")]
    pub out: Option<PathBuf>,
    /// Format of the figure in --out: svg (default), png (rasterised, 2 px per SVG px) or pdf
    /// (vector, font embedded); the file is figure.<format>.
    #[arg(long, value_enum, default_value_t = FigureFormat::Svg, conflicts_with = "truth")]
    pub figure_format: FigureFormat,
}

/// Parses `X,Y` (two finite numbers).
fn parse_pair(s: &str) -> Result<[f64; 2], String> {
    let v: Vec<&str> = s.split(',').collect();
    if v.len() != 2 {
        return Err(format!(
            "expected two comma-separated numbers X,Y (m), got \"{s}\""
        ));
    }
    let x = crate::args::finite_f64(v[0])?;
    let y = crate::args::finite_f64(v[1])?;
    Ok([x, y])
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
pub(crate) fn create_dir_for(dir: &Path, names: &[&str]) -> Result<()> {
    create_dir(dir)?;
    for n in names {
        crate::output::check_file("--out", &dir.join(n))?;
    }
    Ok(())
}

/// Writes one file of the output directory (temporary file, then rename).
pub(crate) fn write_file(
    path: &Path,
    write: impl FnOnce(&mut crate::output::OutFile) -> std::io::Result<()>,
) -> Result<()> {
    crate::output::write_file("--out", path, write)
}

/// Writes `mean.csv`: the mean trajectory, its 95 % half-widths, and the plan.
pub fn write_mean(path: &Path, plan: &Plan, mean: &MeanTrajectory) -> Result<()> {
    write_file(path, |w| {
        writeln!(w, "t,x,y,x_ci95,y_ci95,plan_x,plan_y")?;
        for (k, s) in plan.samples.iter().enumerate() {
            let (m, h) = (mean.mean[k], mean.half_width[k]);
            writeln!(
                w,
                "{},{},{},{},{},{},{}",
                s.t, m[0], m[1], h[0], h[1], s.pose.x, s.pose.y
            )?;
        }
        Ok(())
    })
}

/// Header of `trials.csv` for a robot of `wheels` wheels: one encoder column `q1..qN` per wheel.
pub(crate) fn trials_header(wheels: usize) -> String {
    let mut h = String::from("trial,t,x,y,heading,tracked_x,tracked_y,slip_residual");
    for i in 1..=wheels {
        h.push_str(&format!(",q{i}"));
    }
    h
}

/// Writes trial `i`'s rows of `trials.csv`.
pub(crate) fn write_trial(w: &mut impl Write, i: usize, tr: &Trial) -> std::io::Result<()> {
    let wheels = tr.wheels.min(omnikin::MAX_WHEELS);
    for k in 0..tr.t.len() {
        let (p, q) = (tr.pose[k], tr.tracked[k]);
        write!(
            w,
            "{i},{},{},{},{},{},{},{}",
            tr.t[k], p.x, p.y, p.heading, q[0], q[1], tr.slip_residual[k],
        )?;
        for a in &tr.encoder_angles[k][..wheels] {
            write!(w, ",{a}")?;
        }
        writeln!(w)?;
    }
    Ok(())
}

/// The metrics as they are written: every one a finite number, or an error naming the first
/// that is not (JSON would write NaN as `null`, read as "no value").
pub(crate) fn finite(m: &Metrics) -> Result<()> {
    m.check_finite()
        .context("the metrics cannot be computed for these inputs")
}

/// A progress bar on stderr when it is a terminal; silent otherwise.
pub fn progress_bar(len: u64, what: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} [{bar:30}] {pos}/{len} trials, {elapsed} (eta {eta})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
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

/// Warns about the sections of a disturbance profile that `robot`'s kind does not simulate: a
/// `[shell_spin]` without a shell or ball, a `[steer_motor]` without steering (they were
/// ignored without a word, so a mecanum "with spin slip" ran as if ideal).
pub fn warn_unused_sections(profile: &Profile, robot: &omnikin::Robot<f64>, file: &str) {
    let kind = robot.kind().name();
    if !robot.kind().has_vertical_spin() && profile.shell_spin != Default::default() {
        crate::errln!(
            "warning: {file}: [shell_spin] applies to sphere-omni and ballbot only; robot kind \
             {kind} ignores it (for slip on the floor use [floor])"
        );
    }
    if !robot.steerable() && profile.steer_motor != Default::default() {
        crate::errln!(
            "warning: {file}: [steer_motor] applies to kinds with steering (caster3, swerve) \
             only; robot kind {kind} ignores it"
        );
    }
}

pub fn simulate(a: &SimulateArgs) -> Result<()> {
    let d = crate::kinematics::resolve_robot(&a.robot)?;
    let robot = d.build::<f64>()?;
    let plan = Plan::load_csv(&a.plan)?;
    // As `plan` warns: a plan asking more than the robot file allows is not what it will do.
    for w in crate::body_limits::plan_beyond_file(&d, &plan)? {
        crate::errln!(
            "warning: {}: {w}; a robot held to its file's limits lags behind it",
            a.plan.display()
        );
    }
    if a.shard.is_some() && a.plant == PlantKind::Dynamic {
        bail!(
            "--shard: the dynamic plant runs one trial; shards split the kinematic plant's trials"
        );
    }
    let ballbot_dynamic = a.plant == PlantKind::Dynamic && d.robot_kind().balances();
    if !ballbot_dynamic && (a.initial_tilt_deg.is_some() || !a.push.is_empty()) {
        bail!("--initial-tilt-deg and --push need --robot ballbot (kind ballbot) --plant dynamic");
    }
    if ballbot_dynamic {
        if a.mcap.is_some() {
            bail!(
                "--mcap: not yet for the ballbot's dynamic plant (kinematic plants and sphere-omni's dynamic plant only)"
            );
        }
        return crate::sim_ballbot::simulate(a, &d, &plan);
    }
    if a.plant == PlantKind::Dynamic {
        return simulate_dynamic(a, &d, &plan);
    }
    let profile = match &a.disturbances {
        Some(p) => Profile::load(p)?,
        None => Profile::default(),
    };
    if let Some(file) = &a.disturbances {
        warn_unused_sections(&profile, &robot, &file.display().to_string());
    }
    if let Some(why) = omnikin_sim::plan_mismatch(&robot, &plan) {
        crate::errln!("warning: {}: {why}", a.plan.display());
    }
    use crate::steer_steps::{
        MAX_SIMULATED_STEER_STEP, MAX_UNEXPLAINED_STEER_STEP, unexplained_steer_step,
    };
    if let Some(step) = unexplained_steer_step(&plan, MAX_SIMULATED_STEER_STEP) {
        anyhow::bail!(
            "{}: {step}: the simulator turns the steer motors by the sd columns, so it would \
             not follow this plan: {}",
            a.plan.display(),
            step.cause()
        );
    } else if let Some(step) = unexplained_steer_step(&plan, MAX_UNEXPLAINED_STEER_STEP) {
        crate::errln!(
            "warning: {}: {step}: the simulated steering will differ from the plan's by about \
             that much: {}",
            a.plan.display(),
            step.cause()
        );
    }
    if let Some(shard) = a.shard {
        return crate::shard::simulate_shard(a, shard, &d, &robot, &plan, &profile);
    }
    let sensors = if a.emit_sensors {
        Some(sensor_profile(a.sensors.as_deref())?)
    } else {
        None
    };
    create_dir_for(
        &a.out,
        &[
            "metrics.json",
            "trials.csv",
            "mean.csv",
            &a.figure_format.file_name("figure"),
        ],
    )?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let trials = a.trials as usize;
    let passes = 1 + omnikin_sim::second_pass_resimulates(trials, plan.samples.len()) as u64;
    let pb = progress_bar(passes * a.trials, "simulating");
    // Metrics compare what the tracker saw with the planned path of the tracked point.
    let reference = tracked_reference(&plan, profile.tracking.offset.unwrap_or([0.0; 2]));
    // The trials stream through trials.csv (and the sensor logs) into the metrics, in trial
    // order: memory does not grow with --trials.
    let trials_path = a.out.join("trials.csv");
    // Under the output rules: a temporary file, renamed into place only when every trial ran
    // (a run that stops part-way leaves no truncated trials.csv behind).
    let mut trials_csv = crate::output::OutFile::create("--out", &trials_path)?;
    writeln!(trials_csv, "{}", trials_header(robot.wheels()))
        .with_context(|| format!("cannot write {}", trials_path.display()))?;
    let mcap_trials = a.mcap_trials.unwrap_or(1) as usize;
    let mut mcap = crate::mcap_log::simulation(a.mcap.as_deref(), &plan)?;
    let mc = pool
        .install(|| {
            omnikin_sim::simulate_and_evaluate(
                &robot,
                &plan,
                &reference,
                &profile,
                trials,
                a.seed,
                &|| pb.inc(1),
                |i, trial| -> Result<()> {
                    write_trial(&mut trials_csv, i, trial)
                        .with_context(|| format!("cannot write {}", trials_path.display()))?;
                    if let Some(sp) = &sensors {
                        emit_sensors(&a.out, &robot, i, trial, sp, a.seed)?;
                    }
                    if let Some(m) = mcap.as_mut().filter(|_| i < mcap_trials) {
                        crate::mcap_log::trial(m, i, trial, &plan)?;
                    }
                    Ok(())
                },
            )
        })
        .map_err(|e| match e {
            MonteCarloError::Visit(e) => e,
            e => anyhow::Error::new(e),
        })
        .and_then(|mc| {
            trials_csv.commit()?;
            Ok(mc)
        })?;
    pb.finish_and_clear();
    if let Some(m) = mcap {
        m.finish()?;
    }
    let info = SimulationInfo {
        robot: d.name.clone(),
        kind: d.kind().to_string(),
        plan: a.plan.display().to_string(),
        disturbances: a.disturbances.as_ref().map(|p| p.display().to_string()),
        trials: a.trials,
        seed: a.seed,
        plant_rate_hz: profile.rate_hz(),
    };
    if a.emit_sensors {
        crate::errln!(
            "sensor logs: {}/sensors/trial-NNN/{{encoders.csv, fixes.csv, imu.csv, truth.csv}}",
            a.out.display().to_string().trim_end_matches('/')
        );
    }
    finish_simulation(&a.out, &info, &reference, mc, a.figure_format)
}

/// What `simulate`'s outputs say about the run (metrics.json's `simulation`, the figure's
/// title): the same from one run and from `omnikin merge` of its shards.
#[derive(Clone, Debug)]
pub(crate) struct SimulationInfo {
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
pub(crate) fn finish_simulation(
    out: &Path,
    info: &SimulationInfo,
    reference: &Plan,
    mc: omnikin_sim::MonteCarlo,
    format: FigureFormat,
) -> Result<()> {
    let figure = format.file_name("figure");
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
    crate::figures::trajectory_figure(
        "--out",
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

pub fn evaluate_tracks(a: &EvaluateArgs) -> Result<()> {
    let (Some(plan_path), Some(out)) = (a.plan.as_deref(), a.out.as_deref()) else {
        return match &a.truth {
            Some(truth) => crate::evaluate_truth::run(a, truth),
            None => bail!("evaluate needs --plan PLAN.csv --out DIR, or --truth TRUTH.csv"),
        };
    };
    if !(a.motion_threshold > 0.0 && a.motion_threshold <= 10.0) {
        bail!(
            "--motion-threshold must be > 0 and at most 10 m (got {})",
            a.motion_threshold
        );
    }
    if let Some(o) = a.tracking_offset {
        let max = omnikin_sim::limits::MAX_TRACKING_OFFSET;
        if o.iter().any(|v| v.abs() > max) {
            bail!(
                "--tracking-offset {},{}: each component must be within ±{max} m of the \
                 robot centre (omnikin_sim::limits::MAX_TRACKING_OFFSET)",
                omnikin_sim::limits::num(o[0]),
                omnikin_sim::limits::num(o[1])
            );
        }
    }
    let plan = tracked_reference(
        &Plan::load_csv(plan_path)?,
        a.tracking_offset.unwrap_or([0.0; 2]),
    );
    let align = Alignment {
        motion_threshold_m: a.motion_threshold,
        align_position: !a.no_align_position,
    };
    let mut runs = Vec::new();
    for f in &a.tracks {
        let track = Track::load(f)?;
        if let Some(why) = track.did_not_move(&plan, align) {
            bail!("{}: {why}", f.display());
        }
        runs.push(track.resample(&plan, align));
    }
    let omnikin_sim::metrics::Evaluation { metrics, mean } = evaluate(&plan, &runs)?;
    finite(&metrics)?;
    let figure = a.figure_format.file_name("figure");
    create_dir_for(out, &["metrics.json", "runs.csv", "mean.csv", &figure])?;
    let mut j = serde_json::to_value(&metrics)?;
    j["evaluation"] = json!({
        "plan": plan_path.display().to_string(),
        "tracks": a.tracks.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "motion_threshold_m": a.motion_threshold, "align_position": !a.no_align_position,
        "tracking_offset_m": a.tracking_offset.unwrap_or([0.0; 2]),
    });
    write_file(&out.join("metrics.json"), |w| {
        writeln!(
            w,
            "{}",
            serde_json::to_string_pretty(&j).unwrap_or_default()
        )
    })?;
    write_file(&out.join("runs.csv"), |w| {
        writeln!(w, "run,t,x,y")?;
        for (i, r) in runs.iter().enumerate() {
            for (k, p) in r.xy.iter().enumerate() {
                writeln!(w, "{i},{},{},{}", plan.samples[k].t, p[0], p[1])?;
            }
        }
        Ok(())
    })?;
    write_mean(&out.join("mean.csv"), &plan, &mean)?;
    crate::figures::trajectory_figure(
        "--out",
        &out.join(&figure),
        &format!("{} tracked run(s) vs {}", runs.len(), plan_path.display()),
        &plan,
        &runs,
        &mean,
        metrics.runs,
    )?;
    print_summary(&metrics);
    crate::errln!(
        "wrote {}/{{metrics.json, runs.csv, mean.csv, {figure}}}",
        out.display().to_string().trim_end_matches('/')
    );
    Ok(())
}

/// Experiments `omnikin reproduce` knows.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Experiment {
    /// The Sphere paper (spherical robot, 2019): square at 0.1/0.2/0.4/0.5 m/s, circle at
    /// ω0 = 0.5/1/2/2.5 rad/s.
    #[value(name = "sphere-2019")]
    Sphere2019,
}

/// `omnikin reproduce`.
#[derive(clap::Args, Debug)]
pub struct ReproduceArgs {
    /// Which paper's experiments to re-run.
    pub experiment: Experiment,
    /// Output directory (created): table.md, table.csv, metrics.json, one figure per series.
    /// Default: the per-user data directory, `$XDG_DATA_HOME/omnikin/reproduce-sphere-2019`
    /// (`~/.local/share/omnikin/…` on Linux), never the current directory; a run there
    /// replaces the previous run's files (a directory given here is never replaced without
    /// --force).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Format of the per-series figures in --out (`<series>-<profile>.<format>`): svg
    /// (default), png (rasterised, 2 px per SVG px) or pdf (vector, font embedded).
    #[arg(long, value_enum, default_value_t = FigureFormat::Svg)]
    pub figure_format: FigureFormat,
    /// Monte-Carlo trials per series and disturbance profile (the paper ran 3).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..=10_000))]
    pub trials: u64,
    /// Trials per series of the dynamic profile (shell + platform dynamics of the robot file
    /// as loaded, its one fitted parameter written there by --fit-to-paper); 0 leaves the
    /// dynamic profile out.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(0..=10_000))]
    pub dynamic_trials: u64,
    /// Which profiles run, comma-separated, in any order: `ideal`, `hardware`, `spin-slip`
    /// (kinematic), `dynamic` (default: all four). A profile left out leaves its columns
    /// empty (`—`).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "ideal,hardware,spin-slip,dynamic"
    )]
    pub profiles: Vec<ReproduceProfile>,
    /// Random seed.
    #[arg(long, default_value_t = 2019)]
    pub seed: u64,
    /// Plan sampling rate, Hz (the plant integrates at 1 kHz).
    #[arg(long, default_value_t = 100.0)]
    pub rate: f64,
    /// Worker threads, 1 to 256 (default: all cores).
    #[arg(long, value_parser = crate::args::threads)]
    pub threads: Option<usize>,
    /// Run only shard K of N (1 ≤ K ≤ N ≤ --trials): trials ⌊(K−1)·T/N⌋ to ⌊K·T/N⌋−1 of
    /// every series and profile (the dynamic profile's --dynamic-trials split the same way),
    /// seeded exactly as in one run. --out then holds those trials' runs (runs/*.bin) and
    /// shard.json; `omnikin merge` of all N shard directories writes what one run writes.
    #[arg(long, value_name = "K/N", value_parser = crate::shard::parse_shard)]
    pub shard: Option<omnikin_sim::shard::Shard>,
    /// Fit the dynamic model's one fitted parameter, `com_depth`, so that the 0.4 m/s
    /// circle's radius ratio is the paper's 1.4 with every other `[dynamics]` value of the
    /// robot file as it is, and write it into that file (its `com_depth` line only, with a
    /// comment saying to what and by which command; an existing file is replaced only with
    /// --force, like any output); runs no trials. Nothing is written when no depth inside the
    /// search bracket reaches 1.4.
    #[arg(long)]
    pub fit_to_paper: bool,
    /// The sphere-omni robot file: the one every series is planned and the dynamic profile
    /// simulated with, as loaded (default: the built-in preset); with --fit-to-paper the file
    /// fitted and written (default: the preset's file in the source tree,
    /// robots/sphere-omni.toml).
    #[arg(long, value_name = "PATH")]
    pub robot_file: Option<PathBuf>,
}

/// A profile of `omnikin reproduce` (`--profiles`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReproduceProfile {
    /// The ideal kinematic plant.
    Ideal,
    /// Plausible hardware imperfections (kinematic).
    Hardware,
    /// The fitted speed-dependent shell spin (kinematic).
    SpinSlip,
    /// The shell + platform dynamics of the robot file (its one fitted parameter written
    /// there by --fit-to-paper).
    Dynamic,
}

impl ReproduceProfile {
    /// The profile's name in [`omnikin_sim::reproduce::profiles`] (the kinematic ones).
    fn kinematic_name(self) -> Option<&'static str> {
        match self {
            ReproduceProfile::Ideal => Some("ideal"),
            ReproduceProfile::Hardware => Some("hardware"),
            ReproduceProfile::SpinSlip => Some("spin-slip"),
            ReproduceProfile::Dynamic => None,
        }
    }
}

pub fn reproduce(a: &ReproduceArgs) -> Result<()> {
    use omnikin_sim::reproduce as rp;
    let Experiment::Sphere2019 = a.experiment;
    if !(a.rate.is_finite() && a.rate > 0.0) {
        bail!("--rate must be a finite number > 0 (got {})", a.rate);
    }
    if a.fit_to_paper {
        let path = a
            .robot_file
            .clone()
            .unwrap_or_else(crate::fit_to_paper::preset_file);
        return crate::fit_to_paper::run(&path, a.rate);
    }
    let kinematic: Vec<&str> = a
        .profiles
        .iter()
        .filter_map(|p| p.kinematic_name())
        .collect();
    let run_dynamic = a.profiles.contains(&ReproduceProfile::Dynamic) && a.dynamic_trials > 0;
    if kinematic.is_empty() && !run_dynamic {
        bail!(
            "--profiles: nothing to run (the dynamic profile needs --dynamic-trials > 0; the \
             kinematic ones are ideal, hardware, spin-slip)"
        );
    }
    let start = std::time::Instant::now();
    let out = match &a.out {
        Some(p) => p.clone(),
        None => {
            // The default directory is omnikin's own: a new run replaces the files the last
            // run wrote there (an --out of the user's keeps the rule: nothing replaced
            // without --force).
            let d = crate::data_dir::reproduce_default("sphere-2019");
            if std::fs::read_dir(&d).is_ok_and(|mut e| e.next().is_some()) {
                crate::errln!(
                    "reproduce: replacing the previous results in {} (the default --out)",
                    d.display()
                );
                crate::output::set_force(true);
            }
            d
        }
    };
    let (robot_file, robot_toml) = match &a.robot_file {
        Some(p) => {
            crate::output::input("--robot-file", p);
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("--robot-file {}: cannot read", p.display()))?;
            (p.display().to_string(), text)
        }
        None => (PRESET_LABEL.to_string(), preset_toml()?.to_string()),
    };
    let d = RobotDescription::from_toml_str(&robot_toml, &robot_file)?;
    let robot = d.build::<f64>()?;
    let series = rp::sphere_2019_series(&d, a.rate)?;
    let dyn_trials = if run_dynamic {
        a.dynamic_trials as usize
    } else {
        0
    };
    if let Some(shard) = a.shard {
        shard.check(
            if kinematic.is_empty() {
                dyn_trials
            } else {
                a.trials as usize
            },
            if kinematic.is_empty() {
                "--dynamic-trials"
            } else {
                "--trials"
            },
        )?;
    }
    let files: &[&str] = if a.shard.is_some() {
        &["shard.json"]
    } else {
        &["table.md", "table.csv", "metrics.json"]
    };
    create_dir_for(&out, files)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    // The dynamic profile: the robot file's [dynamics] as loaded, nothing overridden.
    let dynamic = if run_dynamic {
        Some(DynamicInfo::new(&robot_file, &robot_toml, &d)?)
    } else {
        None
    };
    let profile = dynamic.as_ref().map(|i| rp::dynamic_profile(i.params));
    let plants = rp::Plants::new(&robot, a.seed, &kinematic, profile.as_ref());
    let runs = plants.runs(a.trials as usize, dyn_trials);
    let info = ReproduceInfo {
        trials: a.trials as usize,
        dynamic_trials: dyn_trials,
        seed: a.seed,
        rate: a.rate,
        profiles: runs.iter().map(|r| r.0).collect(),
        robot_file,
        robot_toml,
        dynamic,
    };
    if let Some(shard) = a.shard {
        return crate::shard::reproduce_shard(&out, shard, &info, &plants, &series, &pool);
    }
    let total: u64 = series.len() as u64 * runs.iter().map(|r| r.1 as u64).sum::<u64>();
    let pb = progress_bar(total, "reproducing the Sphere paper");
    let mut report = Report::new(&out, info).figure_format(a.figure_format);
    for s in &series {
        let outcomes = pool.install(|| {
            rp::evaluate_series(
                s,
                &runs,
                &|name, i| plants.trial(s, name, i).map(omnikin_sim::trial_run),
                &|| pb.inc(1),
            )
        });
        let outcomes = outcomes.map_err(|e| match e {
            MonteCarloError::Sim(e) | MonteCarloError::Visit(e) => anyhow::Error::new(e),
            e => anyhow::Error::new(e),
        })?;
        report.add(s, &outcomes)?;
    }
    pb.finish_and_clear();
    report.finish(start)
}

/// What `reproduce` says for the built-in preset as its robot file.
pub(crate) const PRESET_LABEL: &str = "preset sphere-omni";

/// The built-in `sphere-omni` preset's TOML text.
pub(crate) fn preset_toml() -> Result<&'static str> {
    omnikin::description::PRESETS
        .iter()
        .find(|(n, _)| *n == "sphere-omni")
        .map(|(_, t)| *t)
        .context("the sphere-omni preset is missing")
}

/// The dynamic profile's robot file as loaded: the parameters and what the outputs say about
/// them.
#[derive(Clone, Debug)]
pub(crate) struct DynamicInfo {
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
        let source = omnikin_sim::reproduce::DynamicSource::new(robot_file, robot_toml, &params);
        Ok(Self { params, source })
    }
}

/// What `reproduce`'s outputs say about the run: the same from one run and from `omnikin
/// merge` of its shards.
#[derive(Clone, Debug)]
pub(crate) struct ReproduceInfo {
    /// `--trials` per series and kinematic profile.
    pub trials: usize,
    /// Trials per series of the dynamic profile (0 when it does not run).
    pub dynamic_trials: usize,
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
pub(crate) struct Report<'a> {
    out: &'a Path,
    info: ReproduceInfo,
    rows: Vec<omnikin_sim::reproduce::Row>,
    all: serde_json::Map<String, serde_json::Value>,
    figures: usize,
    format: FigureFormat,
}

impl<'a> Report<'a> {
    /// A report into the output directory `out` (created and checked).
    pub fn new(out: &'a Path, info: ReproduceInfo) -> Self {
        Self {
            out,
            info,
            rows: Vec::new(),
            all: serde_json::Map::new(),
            figures: 0,
            format: FigureFormat::Svg,
        }
    }

    /// The same report with its figures written in `format` (default SVG).
    pub fn figure_format(self, format: FigureFormat) -> Self {
        Self { format, ..self }
    }

    /// One series' outcomes: its figures, its metrics and its table row.
    pub fn add(
        &mut self,
        s: &omnikin_sim::reproduce::Series,
        outcomes: &[omnikin_sim::reproduce::Outcome],
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
            crate::figures::trajectory_figure(
                "--out",
                &self
                    .out
                    .join(self.format.file_name(&format!("{}-{}", s.name, o.profile))),
                &title,
                &s.plan,
                &o.runs,
                &o.mean,
                o.metrics.runs,
            )?;
            self.figures += 1;
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
            }
        }
        self.rows.push(omnikin_sim::reproduce::row(s, outcomes));
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
            "profiles": info.profiles,
            "plan_rate_hz": info.rate,
            "spin_slip_gain": g, "spin_slip_exponent": p,
            "spin_slip_fit": { "fitted_on": ["circle-0.4", "circle-0.5"], "parameters": ["spin_slip_gain", "spin_slip_exponent"] },
            "dynamic_robot_file": source.map(|f| &f.robot_file),
            "dynamic_fitted": source.map(|f| json!({
                "name": f.fitted_name, "value": f.fitted_value, "unit": "m",
                "comment": f.fitted_comment,
            })),
            "dynamic_contact_events_note": source.map(|_| "series.*.dynamic_nominal_contact_events: roller slips and lift-offs per wheel, floor-cone exits (steps), lost steps per wheel, of the deterministic model with the robot file's values (no trial jitter)"),
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
        crate::errln!(
            "wrote {dir}/table.md, {dir}/table.csv, {dir}/metrics.json and {n} figures in {:.1} s",
            start.elapsed().as_secs_f64(),
            dir = out.display(),
            n = self.figures
        );
        Ok(())
    }
}
