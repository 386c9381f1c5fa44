//! `omnikin.identify`: `omnikin identify` (a robot's wheel geometry and gyro from recorded
//! runs) through the functions the CLI calls — [`LoggedRun::from_tables`],
//! [`omnikin_sim::identify::identify`], [`robot_file::rewrite`] and [`report`] — so the
//! result is the CLI's, as a JSON string the Python layer turns into a dict.

use numpy::PyReadonlyArray2;
use omnikin_sim::identify::runs::LoggedRun;
use omnikin_sim::identify::{Options, identify, report, robot_file};
use omnikin_sim::table::NumericTable;
use pyo3::prelude::*;

use crate::arrays::value_error;
use crate::odometry::table;
use crate::robot::PyRobot;

/// A table argument: `(path, None)` or `(None, (columns, values))` (see [`table`]).
type TableArg<'py> = (
    Option<String>,
    Option<(Vec<String>, PyReadonlyArray2<'py, f64>)>,
);

/// The table `arg`, named `name[i]` (a dict's error names it) or by its path.
fn load(name: &str, i: usize, arg: TableArg<'_>) -> PyResult<(String, NumericTable)> {
    let name = format!("{name}[{i}]");
    let label = arg.0.clone().unwrap_or_else(|| name.clone());
    Ok((label, table(&name, arg.0.as_deref(), arg.1)?))
}

/// `omnikin.identify`: `(result_json, table, robot_file_text)`, the result as the CLI's
/// `--json` object, the CLI's table and the identified robot file's text. One reference per
/// encoder log (`fixes` or `tracked`), in the same order; `imu` empty or one per log.
#[pyfunction]
#[pyo3(signature = (robot, encoders, references, reference_name, imu))]
pub fn identify_native<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    encoders: Vec<TableArg<'py>>,
    references: Vec<TableArg<'py>>,
    reference_name: &str,
    imu: Vec<TableArg<'py>>,
) -> PyResult<(String, String, String)> {
    let n = encoders.len();
    if n == 0 {
        return Err(value_error("encoders: at least one encoder log is needed"));
    }
    if references.len() != n {
        return Err(value_error(format!(
            "{reference_name}: {} files for {n} encoder logs (one per run, in the same order)",
            references.len()
        )));
    }
    if !imu.is_empty() && imu.len() != n {
        return Err(value_error(format!(
            "imu: {} files for {n} encoder logs (one per run, in the same order)",
            imu.len()
        )));
    }
    let (wheels, steerable) = (robot.model.wheels(), robot.model.steerable());
    let mut imu = imu.into_iter();
    let mut runs = Vec::with_capacity(n);
    // Named as the CLI names them: the encoder logs, then the references, then the IMU logs.
    let mut files: [Vec<String>; 3] = Default::default();
    for (i, (log, reference)) in encoders.into_iter().zip(references).enumerate() {
        let (log_name, log) = load("encoders", i, log)?;
        let (ref_name, reference) = load(reference_name, i, reference)?;
        let imu = imu.next().map(|t| load("imu", i, t)).transpose()?;
        files[0].push(log_name);
        files[1].push(ref_name);
        files[2].extend(imu.as_ref().map(|t| t.0.clone()));
        runs.push(
            LoggedRun::from_tables(
                &log,
                &reference,
                imu.as_ref().map(|t| &t.1),
                wheels,
                steerable,
            )
            .map_err(|e| value_error(e.to_string()))?,
        );
    }
    let desc = &robot.desc;
    let id = py
        .detach(|| identify(desc, &runs, &Options::default()))
        .map_err(|e| value_error(e.to_string()))?;
    let text = robot_file::rewrite(robot.text(), &id, &files.concat().join(", "))
        .map_err(|e| value_error(e.to_string()))?;
    Ok((report::json(&id).to_string(), report::table(&id), text))
}
