//! `omnikin.odometry`: `omnikin odometry` (wheel odometry over an encoder log, optionally
//! fused with camera fixes) through [`omnikin_sim::odometry::run`], the function the CLI
//! calls; the log and the fixes come as CSV paths or as columns, the poses back as columns.

use numpy::PyReadonlyArray2;
use numpy::PyUntypedArrayMethods;
use omnikin::Pose2;
use omnikin::estimate::fusion::Recovery;
use omnikin_sim::odometry::{
    EventOverrides, FixResult, OdometryOptions, ThresholdSource, TiltReport, run,
};
use omnikin_sim::table::NumericTable;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::json;

use crate::arrays::value_error;
use crate::robot::PyRobot;

/// A table argument: a CSV path, or `(columns, values)` with `values[i]` the column
/// `columns[i]` (written as CSV, each value exactly, and read with the file's checks: an
/// error's line is the row + 1, the header being line 1). `omnikin.identify` reads its tables
/// with it too.
pub(crate) fn table(
    name: &str,
    path: Option<&str>,
    columns: Option<(Vec<String>, PyReadonlyArray2<'_, f64>)>,
) -> PyResult<NumericTable> {
    let e = |e: omnikin_sim::table::TableError| value_error(e.to_string());
    match (path, columns) {
        (Some(p), None) => NumericTable::load(std::path::Path::new(p)).map_err(e),
        (None, Some((cols, values))) => {
            let shape = values.shape();
            if shape[0] != cols.len() {
                return Err(value_error(format!(
                    "{name}: {} columns but {} value rows",
                    cols.len(),
                    shape[0]
                )));
            }
            if let Some(c) = cols.iter().find(|c| c.contains([',', '\n', '\r'])) {
                return Err(value_error(format!(
                    "{name}: column name {c:?} has a comma or a line break"
                )));
            }
            let rows = shape[1];
            if rows > omnikin_sim::limits::MAX_TRACK_ROWS {
                return Err(value_error(format!(
                    "{name}: {rows} rows, more than MAX_TRACK_ROWS ({}) of omnikin_sim::limits",
                    omnikin_sim::limits::MAX_TRACK_ROWS
                )));
            }
            let v = values.as_array();
            let mut text = cols.join(",");
            text.push('\n');
            for j in 0..rows {
                let row: Vec<String> = (0..shape[0]).map(|i| format!("{}", v[[i, j]])).collect();
                text.push_str(&row.join(","));
                text.push('\n');
            }
            NumericTable::parse(&text, name).map_err(e)
        }
        (None, None) => Err(value_error(format!(
            "{name}: give a dict of columns or a CSV path"
        ))),
        (Some(_), Some(_)) => Err(value_error(format!(
            "{name}: give a dict of columns or a CSV path, not both"
        ))),
    }
}

/// `omnikin.odometry`: `(poses_columns, poses_values, odometry_values, fixes_json,
/// summary_json)`.
#[pyfunction]
#[pyo3(signature = (robot, log_path=None, log_columns=None, fixes_path=None, fixes_columns=None, imu=false, counts_per_rev=None, initial_pose=None, fix_std=0.01, fix_heading_std=0.05, gyro_bias=0.0, max_latency=1.0, estimate_gyro_bias=true, estimate_wheel_scale=true, recovery_count=5, recovery_spread=0.05, tilt_compensation=true, slip_yaw_rate=None, slip_residual=None, collision_decel=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn odometry_native<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    log_path: Option<&str>,
    log_columns: Option<(Vec<String>, PyReadonlyArray2<'py, f64>)>,
    fixes_path: Option<&str>,
    fixes_columns: Option<(Vec<String>, PyReadonlyArray2<'py, f64>)>,
    imu: bool,
    counts_per_rev: Option<u32>,
    initial_pose: Option<[f64; 3]>,
    fix_std: f64,
    fix_heading_std: f64,
    gyro_bias: f64,
    max_latency: f64,
    estimate_gyro_bias: bool,
    estimate_wheel_scale: bool,
    recovery_count: u32,
    recovery_spread: f64,
    tilt_compensation: bool,
    slip_yaw_rate: Option<f64>,
    slip_residual: Option<f64>,
    collision_decel: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let log = table("log", log_path, log_columns)?;
    let fixes = match (fixes_path, fixes_columns) {
        (None, None) => None,
        (p, c) => Some(table("fixes", p, c)?),
    };
    let options = OdometryOptions {
        imu,
        counts_per_rev,
        initial_pose: initial_pose.map(|p| Pose2::new(p[0], p[1], p[2])),
        fix_std,
        fix_heading_std,
        gyro_bias,
        max_latency,
        estimate_gyro_bias,
        estimate_wheel_scale,
        recovery_count,
        recovery_spread,
        tilt_compensation,
        events: EventOverrides {
            slip_yaw_rate,
            slip_residual,
            collision_decel,
        },
    };
    let r = py
        .detach(|| run(&robot.desc, &log, fixes.as_ref(), &options))
        .map_err(|e| value_error(e.to_string()))?;
    if let Some(table) = &fixes {
        for f in &r.fixes {
            if let FixResult::Rejected { mahalanobis2, gate } = f.result {
                crate::sim::warn(
                    py,
                    &format!(
                        "{}:{}: fix at t = {} s rejected as an outlier (d² = {mahalanobis2:.1} > \
                         {gate:.1})",
                        table.file, f.line, f.t
                    ),
                )?;
            }
        }
    }
    let c = &r.columns;
    let poses = crate::sim::table(
        py,
        ["t", "x", "y", "heading"].map(String::from).to_vec(),
        vec![c.t.clone(), c.x.clone(), c.y.clone(), c.heading.clone()],
    )?;
    let odo = crate::sim::table(
        py,
        ["t", "x", "y", "heading"].map(String::from).to_vec(),
        vec![
            c.t.clone(),
            c.odometry_x.clone(),
            c.odometry_y.clone(),
            c.odometry_heading.clone(),
        ],
    )?;
    let fixes_json: Vec<_> = r
        .fixes
        .iter()
        .map(|f| {
            let (result, d2, gate) = match f.result {
                FixResult::Accepted { mahalanobis2 } => ("accepted", Some(mahalanobis2), None),
                FixResult::Rejected { mahalanobis2, gate } => {
                    ("rejected", Some(mahalanobis2), Some(gate))
                }
                FixResult::TooLate => ("too_late", None, None),
                FixResult::AfterLog => ("after_log", None, None),
                FixResult::Initialised => ("initialised", None, None),
                FixResult::Recovered {
                    recovery: Recovery::Reinitialised,
                    ..
                } => ("reinitialised", None, None),
                FixResult::Recovered {
                    recovery: Recovery::Inflated,
                    ..
                } => ("inflated", None, None),
            };
            json!({
                "line": f.line, "t": f.t, "arrival": f.arrival, "x": f.x, "y": f.y,
                "heading": f.heading, "result": result, "mahalanobis2": d2, "gate": gate,
            })
        })
        .collect();
    let s = &r.summary;
    let summary = json!({
        "robot": s.robot, "kind": s.kind, "heading_source": s.heading_source.describe(),
        "samples": s.samples, "duration_s": s.duration, "path_length_m": s.path_length,
        "end": { "x": s.end.x, "y": s.end.y, "heading": s.end.heading },
        "max_slip_m_s": s.max_slip.map(|m| m.0), "max_slip_t_s": s.max_slip.map(|m| m.1),
        "mean_shell_spin_rad_s": s.mean_shell_spin,
        "fixes": s.fixes.map(|f| json!({
            "accepted": f.accepted, "rejected": f.rejected, "too_late": f.too_late,
            "after_log": f.after_log, "fused_minus_odometry_m": f.fused_minus_odometry,
            "reinitialised": f.reinitialised, "inflated": f.inflated,
            "initialised_at_s": f.initialised_at,
            "gyro_bias_rad_s": f.gyro_bias.map(|b| json!({ "value": b.0, "std": b.1 })),
            "wheel_scale": f.wheel_scale.map(|k| json!({ "value": k.0, "std": k.1 })),
        })),
        "shell_spin_rad_s": s.shell_spin.map(|w| json!({
            "mean": w.mean, "std": w.std, "from_fixes": w.from_fixes,
            "tilt": match w.tilt {
                TiltReport::Compensated { mean_tilt, max_tilt, tilt_std, spin_std, uncompensated } => json!({
                    "compensated": true, "mean_rad": mean_tilt, "max_rad": max_tilt,
                    "std_rad": tilt_std, "spin_std_rad_s": spin_std,
                    "uncompensated_rad_s": uncompensated,
                }),
                TiltReport::NotCompensated(why) => json!({ "compensated": false, "why": why }),
            },
        })),
        "event_thresholds": s.event_thresholds.rows().iter().map(|(name, v, unit, source)| json!({
            "name": name, "value": v, "unit": unit,
            "source": match source {
                ThresholdSource::Given => "option",
                ThresholdSource::RobotFile => "robot file",
                ThresholdSource::Default => "default",
            },
        })).collect::<Vec<_>>(),
        "shell_spin_unobservable": s.shell_spin_unobservable,
        "events": r.events.iter().map(|e| json!({
            "kind": e.kind.name(), "start_s": e.start, "end_s": e.end, "peak": e.peak,
        })).collect::<Vec<_>>(),
    });
    let d = PyDict::new(py);
    d.set_item("poses", poses)?;
    d.set_item("odometry", odo)?;
    d.set_item("fixes", json!(fixes_json).to_string())?;
    d.set_item("summary", summary.to_string())?;
    Ok(d)
}
