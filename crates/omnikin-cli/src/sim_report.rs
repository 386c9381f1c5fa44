//! What a simulation command writes and prints is omnikin-io's ([`omnikin_io::sim_output`],
//! shared with the other front ends; the figures drawn by [`crate::plot::FigureFormat`]); the
//! progress bar is [`omnikin_io::output::progress_bar`].

pub use omnikin_io::sim_output::*;

pub use omnikin_io::output::progress_bar;
