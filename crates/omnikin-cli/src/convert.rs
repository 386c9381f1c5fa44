//! `omnikin convert`: the flags; the conversion is [`omnikin_io::mcap_log::convert`].

use std::path::PathBuf;

use anyhow::{Result, bail};

/// `omnikin convert`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("to").required(true).args(["csv", "mcap"])))]
pub struct ConvertArgs {
    /// An MCAP file (with --csv); a CSV log or a directory of `convert --csv` files (with
    /// --mcap).
    pub input: PathBuf,
    /// Write each channel of the MCAP input to DIR/CHANNEL.csv (directory created; new or
    /// empty unless --force).
    #[arg(long, value_name = "DIR")]
    pub csv: Option<PathBuf>,
    /// Write the CSV input (a log, or a directory of `convert --csv` files) as MCAP.
    #[arg(long, value_name = "FILE")]
    pub mcap: Option<PathBuf>,
}

/// Runs `omnikin convert`.
pub fn run(a: &ConvertArgs) -> Result<()> {
    use omnikin_io::mcap_log::convert::{to_csv, to_mcap};
    match (&a.csv, &a.mcap) {
        (Some(dir), None) => to_csv(&a.input, dir),
        (None, Some(out)) => to_mcap(&a.input, out),
        _ => bail!("give exactly one of --csv DIR (MCAP to CSV) and --mcap FILE (CSV to MCAP)"),
    }
}
