//! `omnikin.simulate` and `omnikin.evaluate`: `omnikin simulate` (kinematic plant, Monte-Carlo
//! trials on a rayon pool of `threads` workers, without the GIL) and `omnikin evaluate`
//! (tracked runs against a plan), as the CLI calls omnikin_sim (crates/omnikin-cli/src/sim.rs);
//! the CSV files' columns and `metrics.json` come back instead of an output directory.

use numpy::ndarray::Array2;
use numpy::prelude::IntoPyArray;
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use omnikin_plan::Plan;
use omnikin_sim::metrics::{MeanTrajectory, evaluate, tracked_reference};
use omnikin_sim::track::{Alignment, Track};
use omnikin_sim::{Profile, Trial};
use pyo3::prelude::*;
use serde_json::json;

use crate::arrays::value_error;
use crate::robot::PyRobot;

/// Columns and values (one row per column), as `plan_columns` returns them.
type Table<'py> = (Vec<String>, Bound<'py, PyAny>);

fn table<'py>(py: Python<'py>, cols: Vec<String>, values: Vec<Vec<f64>>) -> PyResult<Table<'py>> {
    let n = values.first().map_or(0, Vec::len);
    let mut a = Array2::<f64>::zeros((cols.len(), n));
    for (i, v) in values.iter().enumerate() {
        for (j, x) in v.iter().enumerate() {
            a[[i, j]] = *x;
        }
    }
    Ok((cols, a.into_pyarray(py).into_any()))
}

/// The plan: a plan CSV file, or the columns of `omnikin.plan` (written as the CLI writes a
/// plan CSV, exactly, and read back with its checks).
fn load_plan(
    path: Option<&str>,
    columns: Option<(Vec<String>, PyReadonlyArray2<'_, f64>)>,
) -> PyResult<(Plan, String)> {
    match (path, columns) {
        (Some(p), None) => Ok((
            Plan::load_csv(std::path::Path::new(p)).map_err(|e| value_error(e.to_string()))?,
            p.to_string(),
        )),
        (None, Some((cols, values))) => {
            let shape = values.shape();
            if shape[0] != cols.len() {
                return Err(value_error(format!(
                    "plan: {} columns but {} value rows",
                    cols.len(),
                    shape[0]
                )));
            }
            let v = values.as_array();
            let mut text = cols.join(",");
            text.push('\n');
            for j in 0..shape[1] {
                let row: Vec<String> = (0..shape[0]).map(|i| format!("{}", v[[i, j]])).collect();
                text.push_str(&row.join(","));
                text.push('\n');
            }
            Ok((
                Plan::read_csv(text.as_bytes(), "plan").map_err(|e| value_error(e.to_string()))?,
                "<plan>".to_string(),
            ))
        }
        _ => Err(value_error("plan: give a plan dict or a plan CSV path")),
    }
}

/// The mean trajectory's columns (`mean.csv`).
fn mean_table<'py>(py: Python<'py>, plan: &Plan, mean: &MeanTrajectory) -> PyResult<Table<'py>> {
    let cols = ["t", "x", "y", "x_ci95", "y_ci95", "plan_x", "plan_y"];
    let mut v = vec![Vec::with_capacity(plan.samples.len()); cols.len()];
    for (k, s) in plan.samples.iter().enumerate() {
        let (m, h) = (mean.mean[k], mean.half_width[k]);
        for (c, x) in [s.t, m[0], m[1], h[0], h[1], s.pose.x, s.pose.y]
            .into_iter()
            .enumerate()
        {
            v[c].push(x);
        }
    }
    table(py, cols.iter().map(|s| s.to_string()).collect(), v)
}

/// Appends trial `i` to the `trials.csv` columns.
fn add_trial(v: &mut [Vec<f64>], i: usize, tr: &Trial) {
    let wheels = tr.wheels.min(omnikin::MAX_WHEELS);
    for k in 0..tr.t.len() {
        let (p, q) = (tr.pose[k], tr.tracked[k]);
        let row = [
            i as f64,
            tr.t[k],
            p.x,
            p.y,
            p.heading,
            q[0],
            q[1],
            tr.slip_residual[k],
        ];
        for (c, x) in row.into_iter().enumerate() {
            v[c].push(x);
        }
        for (w, a) in tr.encoder_angles[k][..wheels].iter().enumerate() {
            v[8 + w].push(*a);
        }
    }
}

/// `omnikin.simulate`: `(trials, mean, metrics_json)`.
#[pyfunction]
#[pyo3(signature = (robot, plan_path=None, plan_columns=None, disturbances=None, trials=10, seed=1, threads=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn simulate_native<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    plan_path: Option<&str>,
    plan_columns: Option<(Vec<String>, PyReadonlyArray2<'py, f64>)>,
    disturbances: Option<&str>,
    trials: u64,
    seed: u64,
    threads: Option<usize>,
) -> PyResult<(Table<'py>, Table<'py>, String)> {
    if !(1..=100_000).contains(&trials) {
        return Err(value_error(format!(
            "trials: must be in 1..=100000, got {trials}"
        )));
    }
    if let Some(t) = threads
        && !(1..=256).contains(&t)
    {
        return Err(value_error(format!("threads: must be in 1..=256, got {t}")));
    }
    let (plan, plan_name) = load_plan(plan_path, plan_columns)?;
    let model = &robot.model;
    let profile = match disturbances {
        Some(p) => {
            Profile::load(std::path::Path::new(p)).map_err(|e| value_error(e.to_string()))?
        }
        None => Profile::default(),
    };
    if let Some(why) = omnikin_sim::plan_mismatch(model, &plan) {
        PyErr::warn(
            py,
            &py.get_type::<pyo3::exceptions::PyUserWarning>(),
            &std::ffi::CString::new(format!("{plan_name}: {why}")).unwrap_or_default(),
            1,
        )?;
    }
    let reference = tracked_reference(&plan, profile.tracking.offset.unwrap_or([0.0; 2]));
    let k = model.wheels();
    let mut cols: Vec<String> = [
        "trial",
        "t",
        "x",
        "y",
        "heading",
        "tracked_x",
        "tracked_y",
        "slip_residual",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    cols.extend((1..=k).map(|i| format!("q{i}")));
    let mut v = vec![Vec::new(); cols.len()];
    let n = trials as usize;
    let mc = py.detach(|| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.unwrap_or(0))
            .build()
            .map_err(|e| format!("cannot start worker threads: {e}"))?;
        pool.install(|| {
            omnikin_sim::simulate_and_evaluate(
                model,
                &plan,
                &reference,
                &profile,
                n,
                seed,
                &|| {},
                |i, trial| -> Result<(), String> {
                    add_trial(&mut v, i, trial);
                    Ok(())
                },
            )
        })
        .map_err(|e| e.to_string())
    });
    let mc = mc.map_err(value_error)?;
    let (metrics, mean) = (mc.evaluation.metrics, mc.evaluation.mean);
    metrics.check_finite().map_err(|e| {
        value_error(format!(
            "the metrics cannot be computed for these inputs: {e}"
        ))
    })?;
    let mut j = serde_json::to_value(&metrics).map_err(|e| value_error(e.to_string()))?;
    j["simulation"] = json!({
        "robot": robot.desc.name, "kind": robot.desc.kind(), "plan": plan_name,
        "disturbances": disturbances, "trials": trials, "seed": seed,
        "plant_rate_hz": profile.rate_hz(),
    });
    Ok((
        table(py, cols, v)?,
        mean_table(py, &reference, &mean)?,
        j.to_string(),
    ))
}

/// `omnikin.evaluate`: `(runs, mean, metrics_json)` of tracked runs (`t,x,y[,heading]` CSV
/// files) against a plan.
#[pyfunction]
#[pyo3(signature = (tracks, plan_path=None, plan_columns=None, motion_threshold=0.005, align_position=true, tracking_offset=None))]
#[allow(clippy::type_complexity)]
pub fn evaluate_native<'py>(
    py: Python<'py>,
    tracks: Vec<String>,
    plan_path: Option<&str>,
    plan_columns: Option<(Vec<String>, PyReadonlyArray2<'py, f64>)>,
    motion_threshold: f64,
    align_position: bool,
    tracking_offset: Option<[f64; 2]>,
) -> PyResult<(Table<'py>, Table<'py>, String)> {
    if !(motion_threshold > 0.0 && motion_threshold <= 10.0) {
        return Err(value_error(format!(
            "motion_threshold must be > 0 and at most 10 m (got {motion_threshold})"
        )));
    }
    if let Some(o) = tracking_offset {
        let max = omnikin_sim::limits::MAX_TRACKING_OFFSET;
        if o.iter().any(|v| !v.is_finite() || v.abs() > max) {
            return Err(value_error(format!(
                "tracking_offset {},{}: each component must be within ±{max} m of the robot \
                 centre (omnikin_sim::limits::MAX_TRACKING_OFFSET)",
                omnikin_sim::limits::num(o[0]),
                omnikin_sim::limits::num(o[1])
            )));
        }
    }
    if tracks.is_empty() {
        return Err(value_error(
            "tracks: give at least one tracked run (CSV t,x,y[,heading])",
        ));
    }
    let (plan, plan_name) = load_plan(plan_path, plan_columns)?;
    let plan = tracked_reference(&plan, tracking_offset.unwrap_or([0.0; 2]));
    let align = Alignment {
        motion_threshold_m: motion_threshold,
        align_position,
    };
    let mut runs = Vec::new();
    for f in &tracks {
        let track = Track::load(std::path::Path::new(f)).map_err(|e| value_error(e.to_string()))?;
        if let Some(why) = track.did_not_move(&plan, align) {
            return Err(value_error(format!("{f}: {why}")));
        }
        runs.push(track.resample(&plan, align));
    }
    let e = py
        .detach(|| evaluate(&plan, &runs))
        .map_err(|e| value_error(e.to_string()))?;
    e.metrics.check_finite().map_err(|e| {
        value_error(format!(
            "the metrics cannot be computed for these inputs: {e}"
        ))
    })?;
    let mut j = serde_json::to_value(&e.metrics).map_err(|e| value_error(e.to_string()))?;
    j["evaluation"] = json!({
        "plan": plan_name, "tracks": tracks,
        "motion_threshold_m": motion_threshold, "align_position": align_position,
        "tracking_offset_m": tracking_offset.unwrap_or([0.0; 2]),
    });
    let mut v = vec![Vec::new(); 4];
    for (i, r) in runs.iter().enumerate() {
        for (k, p) in r.xy.iter().enumerate() {
            for (c, x) in [i as f64, plan.samples[k].t, p[0], p[1]]
                .into_iter()
                .enumerate()
            {
                v[c].push(x);
            }
        }
    }
    let cols = ["run", "t", "x", "y"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    Ok((
        table(py, cols, v)?,
        mean_table(py, &plan, &e.mean)?,
        j.to_string(),
    ))
}
