//! The flags of `omnikin simulate`, `evaluate` and `reproduce`, and of the runs they hand on
//! to (`--closed-loop`, the ballbot's `--push`, `--shard`, `evaluate --align`): one leaf that
//! every simulation command reads, so the commands do not import each other for their flags.

use std::path::PathBuf;

use omnikin_sim::dynamic_run::{PushSpec, check_initial_tilt_deg};
use omnikin_sim::sensors::{CameraGaps, CameraProfile};
use omnikin_sim::shard::Shard;

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
    /// DIR/sensors/trial-NNN/{encoders.csv, fixes.csv, imu.csv, truth.csv}. With --plant
    /// dynamic (sphere-omni) the IMU rides the model's tilting platform and the encoders read
    /// the model's wheel angles.
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
    #[arg(long, allow_hyphen_values = true, value_name = "DEG", value_parser = crate::sim_args::parse_tilt)]
    pub initial_tilt_deg: Option<f64>,
    /// Ballbot, --plant dynamic: a horizontal impulse on the body's centre of mass, N_S@T
    /// (N·s along +x at time T s from the start of the 1 s lead-in) or N_S@T@DEG (direction,
    /// degrees from +x); repeatable. A fall is reported in metrics.json ("fallen", exit 0).
    #[arg(long, allow_hyphen_values = true, value_name = "N_S@T[@DEG]", value_parser = crate::sim_args::parse_push)]
    pub push: Vec<crate::sim_args::PushArg>,
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
    #[arg(long, value_name = "K/N", value_parser = crate::sim_args::parse_shard)]
    pub shard: Option<omnikin_sim::shard::Shard>,
    /// The closed loop's flags (--closed-loop, --no-camera, --camera-*).
    #[command(flatten)]
    pub closed_loop: crate::sim_args::ClosedLoopArgs,
}

/// The plant `omnikin simulate` runs a plan through (one enum for every front end).
pub use omnikin_sim::plant_step::PlantKind;

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
    /// t,x,y and optionally heading (a pose CSV of `omnikin odometry`); with --plan an optional
    /// `mode` column (a robot's --log) marks each e-stop in the figure and metrics.json.
    #[arg(required = true, value_name = "TRACK.csv")]
    pub tracks: Vec<PathBuf>,
    /// With --truth: the alignment before the ATE: `none` (the estimate's start pose is
    /// known) or `se2` (the least-squares rotation and translation, Umeyama/Horn in 2-D).
    #[arg(long, value_enum, default_value = "none", requires = "truth")]
    pub align: omnikin_sim::pose_error::Alignment,
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
    #[arg(long, value_name = "K/N", value_parser = crate::sim_args::parse_shard)]
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
    /// Robots drawn from the `[dynamics]` values' plausible ranges (uniform, independent;
    /// `com_depth` kept at the file's fitted value) for the dynamic profile's prior band: each
    /// series run once per robot without trial jitter, its 5th–95th percentile of the max
    /// deviation and radius ratio beside the dynamic figures (table column, metrics.json
    /// `series.*.dynamic_prior_band`); 0 leaves it out.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(0..=10_000))]
    pub prior_samples: u64,
    /// Print the sensitivity table instead of re-running the paper: each `[dynamics]` value
    /// of the robot file at both ends of its plausible range (the fitted com_depth at its parts
    /// range, 0.06–0.10 m; the others as the file has them),
    /// every series run once without jitter (max deviation %, radius ratio); runs no trials
    /// and writes nothing.
    #[arg(long, conflicts_with_all = ["fit_to_paper", "shard"])]
    pub sensitivity: bool,
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
    /// The core runtime in closed loop on the dynamic plant (tilt feedback designed from the
    /// robot file's dynamics, paper 000's camera); --dynamic-trials trials.
    ClosedLoop,
}

impl ReproduceProfile {
    /// The profile's name in [`omnikin_sim::reproduce::profiles`] (the kinematic ones).
    pub(crate) fn kinematic_name(self) -> Option<&'static str> {
        match self {
            ReproduceProfile::Ideal => Some("ideal"),
            ReproduceProfile::Hardware => Some("hardware"),
            ReproduceProfile::SpinSlip => Some("spin-slip"),
            ReproduceProfile::Dynamic | ReproduceProfile::ClosedLoop => None,
        }
    }
}
/// The closed loop's flags of `omnikin simulate`.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ClosedLoopArgs {
    /// With --plant dynamic (sphere-omni): the core runtime (the firmware's loop) follows the
    /// plan on the dynamic plant, fusing an overhead camera's fixes (default: paper 000's
    /// video, 25 frames/s, 40 ms latency, 2 mm noise); metrics on the simulated truth.
    #[arg(long)]
    pub closed_loop: bool,
    /// With --closed-loop: no camera (the runtime's wheel odometry only).
    #[arg(long, requires = "closed_loop")]
    pub no_camera: bool,
    /// With --closed-loop: camera frame rate, Hz (default 25).
    #[arg(long, value_name = "HZ", requires = "closed_loop", conflicts_with = "no_camera", value_parser = crate::args::finite_f64)]
    pub camera_rate: Option<f64>,
    /// With --closed-loop: camera latency from capture to the robot, s (default 0.04).
    #[arg(long, value_name = "S", requires = "closed_loop", conflicts_with = "no_camera", value_parser = crate::args::finite_f64)]
    pub camera_latency: Option<f64>,
    /// With --closed-loop: camera position noise per axis, m (default 0.002).
    #[arg(long, value_name = "M", requires = "closed_loop", conflicts_with = "no_camera", value_parser = crate::args::finite_f64)]
    pub camera_noise: Option<f64>,
    /// With --closed-loop: probability that a camera frame is lost (default 0).
    #[arg(long, value_name = "P", requires = "closed_loop", conflicts_with = "no_camera", value_parser = crate::args::finite_f64)]
    pub camera_dropout: Option<f64>,
    /// With --closed-loop: no camera frames captured in [START, END), s from the plan's start.
    #[arg(long, value_name = "START,END", requires = "closed_loop", conflicts_with = "no_camera", value_parser = parse_window)]
    pub camera_outage: Option<[f64; 2]>,
    /// With --closed-loop: the camera also measures the heading (two markers), with this noise,
    /// rad (default: position only, as paper 000's video tracked one point).
    #[arg(long, value_name = "RAD", requires = "closed_loop", conflicts_with = "no_camera", value_parser = crate::args::finite_f64)]
    pub camera_heading_noise: Option<f64>,
    /// With --closed-loop: no tilt feedback (the runtime as a level robot's: rate set-points
    /// from the trajectory loop only).
    #[arg(long, requires = "closed_loop")]
    pub no_tilt_feedback: bool,
    /// With --closed-loop: the runtime's control rate, Hz (default 100, `omnikin robot`'s).
    #[arg(long, value_name = "HZ", requires = "closed_loop", value_parser = crate::args::control_rate_hz)]
    pub control_rate: Option<f64>,
}

/// Parses `START,END` (two finite numbers).
fn parse_window(s: &str) -> Result<[f64; 2], String> {
    let v: Vec<&str> = s.split(',').collect();
    let [a, b] = v.as_slice() else {
        return Err(format!("expected START,END (two numbers), got `{s}`"));
    };
    let num = |x: &str| {
        x.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("`{x}` is not a finite number"))
    };
    Ok([num(a)?, num(b)?])
}

impl ClosedLoopArgs {
    /// The camera the flags ask for: paper 000's video with the flags' changes, or none.
    pub fn camera(&self) -> Option<(CameraProfile, CameraGaps)> {
        if self.no_camera {
            return None;
        }
        let mut p = CameraProfile::paper_000();
        if let Some(hz) = self.camera_rate {
            p.period = if hz > 0.0 { 1.0 / hz } else { f64::INFINITY };
        }
        if let Some(l) = self.camera_latency {
            p.latency = l;
        }
        if let Some(n) = self.camera_noise {
            p.noise_std = n;
        }
        p.heading_noise_std = self.camera_heading_noise;
        let g = CameraGaps {
            dropout_probability: self.camera_dropout.unwrap_or(0.0),
            outage: self.camera_outage,
        };
        Some((p, g))
    }
}
/// A `--push` value: `J@T` (an impulse of `J` N·s along world +x at closed-loop time `T` s) or
/// `J@T@DEG` (along the world direction `DEG` degrees counter-clockwise from +x).
pub type PushArg = PushSpec;

/// Parses `J@T[@DEG]` (ranges: [`PushSpec::new`]).
pub fn parse_push(s: &str) -> Result<PushArg, String> {
    let parts: Vec<&str> = s.split('@').collect();
    if !(2..=3).contains(&parts.len()) {
        return Err(format!(
            "expected N_S@T or N_S@T@DEG (impulse in N·s, time in s, direction in degrees \
             from +x), got \"{s}\""
        ));
    }
    let impulse = crate::args::finite_f64(parts[0]).map_err(|e| format!("impulse: {e}"))?;
    let time = crate::args::finite_f64(parts[1]).map_err(|e| format!("time: {e}"))?;
    let direction_deg = match parts.get(2) {
        Some(d) => crate::args::finite_f64(d).map_err(|e| format!("direction: {e}"))?,
        None => 0.0,
    };
    PushSpec::new(impulse, time, direction_deg)
}

/// Parses `--initial-tilt-deg`: finite, |x| < 60° ([`check_initial_tilt_deg`]).
pub fn parse_tilt(s: &str) -> Result<f64, String> {
    check_initial_tilt_deg(crate::args::finite_f64(s)?)
}
/// `--shard K/N` (clap value parser).
pub fn parse_shard(s: &str) -> Result<Shard, String> {
    Shard::parse(s).map_err(|e| match e {
        omnikin_sim::shard::ShardError::Parse { rule, .. } => rule,
        e => e.to_string(),
    })
}
