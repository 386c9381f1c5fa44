//! The `omnikin` Python package's native module (`omnikin._native`): PyO3 classes and
//! functions over the Rust crates, numpy arrays in and out. The pure-Python layer in
//! `python/omnikin/` re-exports it.

use pyo3::prelude::*;

/// A robot: a preset name or a TOML robot file.
#[pyclass(module = "omnikin", frozen)]
struct Robot {}

/// The native module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Robot>()?;
    Ok(())
}
