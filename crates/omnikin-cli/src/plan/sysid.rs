//! `omnikin plan sysid`: the identification test plans (`omnikin_sim::identify::plans`) written
//! as plan CSVs into a directory, with a README.txt saying what each identifies.

use std::path::PathBuf;

use anyhow::Result;
use omnikin::description::RobotDescription;
use omnikin_sim::identify::plans::sysid_plans;

use crate::output;

/// `omnikin plan sysid`.
#[derive(clap::Args, Debug)]
pub struct SysidArgs {
    /// Robot: preset name or path to a TOML description.
    #[arg(long)]
    pub robot: String,
    /// Output directory: along.csv, along-across.csv, spin.csv, figure-eight.csv and
    /// README.txt (what each plan identifies).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Sample rate of the plans, Hz.
    #[arg(long, default_value_t = 50.0, value_parser = crate::args::finite_f64)]
    pub rate: f64,
}

/// Runs `omnikin plan sysid …`.
pub fn run(a: &SysidArgs) -> Result<()> {
    if !(1.0..=10_000.0).contains(&a.rate) {
        anyhow::bail!("--rate {}: must be within 1 to 10000 Hz", a.rate);
    }
    let desc = RobotDescription::resolve(&a.robot)?;
    let plans = sysid_plans(&desc, a.rate)?;
    output::create_dir("--out", &a.out)?;
    let mut readme = format!(
        "Identification test plans for {} (omnikin plan sysid; every plan within half the robot file's limits).\nRun each, record the encoder log and a reference (camera fixes or a tracked trajectory), then: omnikin identify --robot ROBOT --encoders … --fixes … --out identified.toml\n\n",
        desc.name
    );
    for p in &plans {
        let path = a.out.join(format!("{}.csv", p.name));
        output::write_file("--out", &path, |f| p.plan.write_csv(f))?;
        readme.push_str(&format!(
            "{}.csv ({:.1} s): identifies {}\n",
            p.name,
            p.plan.duration(),
            p.identifies
        ));
        output::eprintln_quiet(format_args!(
            "{}: {:.1} s, identifies {}",
            path.display(),
            p.plan.duration(),
            p.identifies
        ));
    }
    output::write_file("--out", &a.out.join("README.txt"), |f| {
        use std::io::Write;
        f.write_all(readme.as_bytes())
    })
}
