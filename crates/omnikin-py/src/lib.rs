//! The `omnikin` Python package's native module (`omnikin._native`): PyO3 classes and
//! functions over the Rust crates, numpy arrays in and out. The pure-Python layer in
//! `python/omnikin/` re-exports it and turns column tables into dicts.
//!
//! `robot` holds `omnikin.Robot` and its kinematics, `arrays` the argument checks,
//! `kernels` the row-parallel loops, `options` the keyword options, `plan` `omnikin.plan`,
//! `sim` `omnikin.simulate` and `omnikin.evaluate`, `odometry` `omnikin.odometry`,
//! `pose_error` `omnikin.pose_error`, `identify` `omnikin.identify`, `mcap` `omnikin.read_mcap` and `omnikin.write_mcap`, `link` `omnikin.Link` (an operator
//! session), `sim_robot` `omnikin.SimRobot` (a simulated robot served on a thread).

mod arrays;
mod identify;
mod kernels;
mod link;
mod mcap;
mod odometry;
mod options;
mod plan;
mod plan_goal;
mod plan_request;
mod pose_error;
mod robot;
mod sim;
mod sim_robot;

use pyo3::prelude::*;

/// The native module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // Python has no `--force`: an existing output is never replaced, and errors say so.
    omnikin_io::output::set_no_force_option();
    m.add_class::<robot::PyRobot>()?;
    m.add_class::<link::PyLink>()?;
    m.add_class::<sim_robot::PySimRobot>()?;
    m.add_function(wrap_pyfunction!(plan::plan_columns, m)?)?;
    m.add_function(wrap_pyfunction!(sim::simulate_native, m)?)?;
    m.add_function(wrap_pyfunction!(sim::evaluate_native, m)?)?;
    m.add_function(wrap_pyfunction!(odometry::odometry_native, m)?)?;
    m.add_function(wrap_pyfunction!(pose_error::pose_error_native, m)?)?;
    m.add_function(wrap_pyfunction!(identify::identify_native, m)?)?;
    m.add_function(wrap_pyfunction!(mcap::read_mcap_native, m)?)?;
    m.add_function(wrap_pyfunction!(mcap::write_mcap_native, m)?)?;
    Ok(())
}
