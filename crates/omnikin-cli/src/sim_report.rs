//! What a simulation command writes and prints is omnikin-io's ([`omnikin_io::sim_output`],
//! shared with the other front ends; the figures drawn by [`crate::plot::FigureFormat`]); the
//! progress bar is the terminal's.

pub use omnikin_io::sim_output::*;

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
