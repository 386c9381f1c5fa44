//! `omnikin.read_mcap(path)`: the omnikin channels of an MCAP log (what `robot --mcap`,
//! `drive --mcap`, `simulate --mcap` write, Foxglove profile) as CSV tables, read by
//! [`omnikin_io::mcap_log::convert::tables`] — the reader behind `omnikin convert --csv`, with
//! its bounds (file size, each zstd chunk's declared size) and its handling of a damaged or
//! truncated file. The pure-Python layer parses the tables into columns.
//!
//! `omnikin.write_mcap(path, tables)`: the other way — columns in the same form (the
//! pure-Python layer writes them as CSV text) to an MCAP file, by
//! [`omnikin_io::mcap_log::convert::tables_to_mcap`], the writer of `omnikin convert DIR
//! --mcap`.

use pyo3::prelude::*;

use crate::arrays::value_error;

/// One channel: topic, message count, CSV text.
type Channel = (String, usize, String);

/// The channels of the MCAP file at `path` and the warnings to show (damage, skipped
/// channels). The file is read without the GIL.
#[pyfunction]
pub fn read_mcap_native(py: Python<'_>, path: &str) -> PyResult<(Vec<Channel>, Vec<String>)> {
    let path = std::path::PathBuf::from(path);
    let t = py
        .detach(|| omnikin_io::mcap_log::convert::tables(&path))
        .map_err(|e| value_error(format!("{e:#}")))?;
    Ok((t.channels, t.warnings))
}

/// Writes the channels `(topic, CSV text)` to a new MCAP file at `path` (never replacing one);
/// the number of messages. Written without the GIL.
#[pyfunction]
pub fn write_mcap_native(
    py: Python<'_>,
    path: &str,
    channels: Vec<(String, String)>,
) -> PyResult<usize> {
    let path = std::path::PathBuf::from(path);
    py.detach(|| omnikin_io::mcap_log::convert::tables_to_mcap("path", channels, &path))
        .map_err(|e| value_error(format!("{e:#}")))
}
