//! `omnikin identify`: a robot's wheel geometry and gyro bias/scale (and the sphere's rocking
//! parameters and pivot friction) from recorded runs, written as a robot file with a comment per value
//! (`omnikin_sim::identify` does the work; this reads the files, prints the table and writes
//! the file).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use omnikin::description::{PRESETS, RobotDescription};
use omnikin_sim::identify::runs::LoggedRun;
use omnikin_sim::identify::{Options, identify, report, robot_file};
use omnikin_sim::table::NumericTable;

use crate::output;

/// `omnikin identify`.
#[derive(clap::Args, Debug)]
pub struct IdentifyArgs {
    /// Robot (the prior): preset name (kiwi, x-drive, mecanum, swerve4, caster3, sphere-omni,
    /// ballbot) or path to a TOML description.
    #[arg(long)]
    pub robot: String,
    /// Encoder logs, one per run: t,q1..qN[,s1..sN][,gyro_z] (as `simulate --emit-sensors` and
    /// `robot --log` write them). A gyro_z column is fitted as the gyro.
    #[arg(long, required = true, num_args = 1.., value_name = "LOG.csv")]
    pub encoders: Vec<PathBuf>,
    /// Camera fixes, one per run in the order of --encoders: t,x,y[,heading][,arrival] (the
    /// pose at the capture time t).
    #[arg(long, num_args = 1.., value_name = "FIXES.csv", conflicts_with = "tracked")]
    pub fixes: Vec<PathBuf>,
    /// Tracked trajectories, one per run in the order of --encoders: t,x,y[,heading] (e.g. a
    /// motion-capture record, or a simulation's truth.csv).
    #[arg(long, num_args = 1.., value_name = "RUN.csv")]
    pub tracked: Vec<PathBuf>,
    /// IMU logs, one per run: t,gx,gy,gz,… (rad/s); their gz is the gyro instead of the encoder
    /// logs' gyro_z. For sphere-omni, their gx, gy after a stop (plan sysid's stop.csv) give
    /// [dynamics] com_depth and rolling_resistance from the platform's rocking; the gyro after
    /// the stop of a spin in place (spin-stop.csv) gives pivot_friction from the spin's decay.
    #[arg(long, num_args = 1.., value_name = "IMU.csv")]
    pub imu: Vec<PathBuf>,
    /// The identified robot file: the input file with the fitted values, each with a comment
    /// `# identified: value ± 1σ from <logs>`.
    #[arg(long, value_name = "IDENTIFIED.toml")]
    pub out: PathBuf,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Draw each run's pose residuals against time, before (the prior) and after (the
    /// estimate): SVG, PNG or PDF by the extension.
    #[arg(long, value_name = "PATH")]
    pub plot: Option<PathBuf>,
}

fn table(path: &std::path::Path) -> Result<NumericTable> {
    Ok(NumericTable::load(path)?)
}

/// The robot file's text: the file, or the compiled-in preset.
fn robot_text(robot: &str) -> Result<String> {
    if let Some((_, text)) = PRESETS.iter().find(|(n, _)| *n == robot) {
        return Ok((*text).to_string());
    }
    omnikin::description::read_text_limited(
        std::path::Path::new(robot),
        omnikin::description::MAX_TOML_BYTES,
        "MAX_TOML_BYTES",
    )
    .with_context(|| format!("--robot {robot}: cannot read"))
}

/// The runs of the command line, one per encoder log.
fn runs(a: &IdentifyArgs, desc: &RobotDescription) -> Result<Vec<LoggedRun>> {
    let robot = desc.build::<f64>()?;
    let n = a.encoders.len();
    let (flag, refs) = if a.tracked.is_empty() {
        ("--fixes", &a.fixes)
    } else {
        ("--tracked", &a.tracked)
    };
    if refs.is_empty() {
        bail!(
            "a reference per run is needed: --fixes FIXES.csv… or --tracked RUN.csv… (one per --encoders log)"
        );
    }
    if refs.len() != n {
        bail!(
            "{flag}: {} files for {n} --encoders logs (one per run, in the same order)",
            refs.len()
        );
    }
    if !a.imu.is_empty() && a.imu.len() != n {
        bail!(
            "--imu: {} files for {n} --encoders logs (one per run, in the same order)",
            a.imu.len()
        );
    }
    let mut out = Vec::with_capacity(n);
    for (i, log) in a.encoders.iter().enumerate() {
        let imu = a.imu.get(i).map(|p| table(p)).transpose()?;
        out.push(LoggedRun::from_tables(
            &table(log)?,
            &table(&refs[i])?,
            imu.as_ref(),
            robot.wheels(),
            robot.steerable(),
        )?);
    }
    Ok(out)
}

fn file_names(a: &IdentifyArgs) -> String {
    let name = |p: &PathBuf| p.display().to_string();
    let mut all: Vec<String> = a.encoders.iter().map(name).collect();
    all.extend(a.fixes.iter().chain(&a.tracked).chain(&a.imu).map(name));
    all.join(", ")
}

/// Runs `omnikin identify …`.
pub fn run(a: &IdentifyArgs) -> Result<()> {
    if let Some(p) = &a.plot {
        crate::plot::FigureFormat::of("--plot", p)?;
    }
    let desc = RobotDescription::resolve(&a.robot)?;
    let text = robot_text(&a.robot)?;
    let runs = runs(a, &desc)?;
    let id = identify(&desc, &runs, &Options::default())?;
    let file = robot_file::rewrite(&text, &id, &file_names(a))?;
    output::write_file("--out", &a.out, |f| {
        use std::io::Write;
        f.write_all(file.as_bytes())
    })?;
    if let Some(p) = &a.plot {
        crate::plot::identify::write("--plot", p, &id.series)?;
    }
    if a.json {
        let mut json = report::json(&id);
        json["robot_file"] = a.out.display().to_string().into();
        output::stdout_line(format_args!("{json}"))
    } else {
        output::stdout_line(format_args!("{}", report::table(&id).trim_end()))
    }
}
