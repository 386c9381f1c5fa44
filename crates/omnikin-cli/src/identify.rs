//! `omnikin identify`: a robot's wheel geometry and gyro bias/scale from recorded runs, written
//! as a robot file with a comment per value (`omnikin_sim::identify` does the work; this reads
//! the files, prints the table and writes the file).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use omnikin::description::{PRESETS, RobotDescription};
use omnikin_sim::identify::runs::{EncoderLog, GyroLog, Reference, Run};
use omnikin_sim::identify::{Estimate, Identified, Options, Status, identify, robot_file};
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
    /// logs' gyro_z.
    #[arg(long, num_args = 1.., value_name = "IMU.csv")]
    pub imu: Vec<PathBuf>,
    /// The identified robot file: the input file with the fitted values, each with a comment
    /// `# identified: value ± 1σ from <logs>`.
    #[arg(long, value_name = "IDENTIFIED.toml")]
    pub out: PathBuf,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
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
fn runs(a: &IdentifyArgs, desc: &RobotDescription) -> Result<Vec<Run>> {
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
        let (encoders, mut gyro) =
            EncoderLog::from_table(&table(log)?, robot.wheels(), robot.steerable())?;
        if let Some(imu) = a.imu.get(i) {
            gyro = Some(GyroLog::from_imu_table(&table(imu)?)?);
        }
        let reference = Reference::from_table(&table(&refs[i])?)?;
        out.push(Run {
            encoders,
            reference,
            gyro,
        });
    }
    Ok(out)
}

fn file_names(a: &IdentifyArgs) -> String {
    let name = |p: &PathBuf| p.display().to_string();
    let mut all: Vec<String> = a.encoders.iter().map(name).collect();
    all.extend(a.fixes.iter().chain(&a.tracked).chain(&a.imu).map(name));
    all.join(", ")
}

fn json(id: &Identified, out: &std::path::Path) -> serde_json::Value {
    let est = |e: &Estimate| {
        let (status, reason) = match &e.status {
            Status::Fitted => ("fitted", None),
            Status::Fixed(why) => ("held", Some(why.clone())),
        };
        serde_json::json!({
            "name": e.name, "unit": e.unit, "prior": e.prior, "value": e.value,
            "sigma": e.sigma, "status": status, "reason": reason,
        })
    };
    serde_json::json!({
        "robot_file": out.display().to_string(),
        "parameters": id.geometry.iter().chain(&id.gyro).map(est).collect::<Vec<_>>(),
        "position_rms_m": id.position_rms,
        "heading_rms_rad": id.heading_rms,
        "gyro_window_rms_rad": id.gyro_rms,
        "condition": id.condition,
        "residuals": id.residuals,
    })
}

fn print_table(id: &Identified) -> Result<()> {
    output::stdout_line(format_args!(
        "{:<26} {:>12} {:>12} {:>10} {:>11}  unit",
        "parameter", "prior", "estimate", "1σ", "change"
    ))?;
    for e in id.geometry.iter().chain(&id.gyro) {
        match &e.status {
            Status::Fitted => {
                let line = format!(
                    "{:<26} {:>12.6} {:>12.6} {:>10.2e} {:>+11.2e}  {}",
                    e.name,
                    e.prior,
                    e.value,
                    e.sigma,
                    e.value - e.prior,
                    e.unit
                );
                output::stdout_line(format_args!("{}", line.trim_end()))?
            }
            Status::Fixed(why) => output::stdout_line(format_args!(
                "{:<26} {:>12.6} {:>12}  held: {why}",
                e.name, e.prior, "—"
            ))?,
        }
    }
    output::stdout_line(format_args!(
        "residual RMS: position {:.3e} m{}{}; {} residuals, condition {:.1}",
        id.position_rms,
        id.heading_rms
            .map(|h| format!(", heading {h:.3e} rad"))
            .unwrap_or_default(),
        id.gyro_rms
            .map(|g| format!(", gyro windows {g:.3e} rad"))
            .unwrap_or_default(),
        id.residuals,
        id.condition
    ))
}

/// Runs `omnikin identify …`.
pub fn run(a: &IdentifyArgs) -> Result<()> {
    let desc = RobotDescription::resolve(&a.robot)?;
    let text = robot_text(&a.robot)?;
    let runs = runs(a, &desc)?;
    let id = identify(&desc, &runs, &Options::default())?;
    let file = robot_file::rewrite(&text, &id, &file_names(a))?;
    output::write_file("--out", &a.out, |f| {
        use std::io::Write;
        f.write_all(file.as_bytes())
    })?;
    if a.json {
        output::stdout_line(format_args!("{}", json(&id, &a.out)))
    } else {
        print_table(&id)
    }
}
