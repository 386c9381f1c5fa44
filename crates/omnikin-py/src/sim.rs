//! `omnikin.simulate` and `omnikin.evaluate`: `omnikin simulate` (kinematic plant, Monte-Carlo
//! trials on a rayon pool of `threads` workers, without the GIL) and `omnikin evaluate`
//! (tracked runs against a plan), as the CLI calls omnikin_sim (crates/omnikin-cli/src/sim.rs);
//! the CSV files' columns and `metrics.json` come back instead of an output directory.

use numpy::ndarray::Array2;
use numpy::prelude::IntoPyArray;
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use omnikin_plan::Plan;
use omnikin_plan::steer_steps::{
    MAX_SIMULATED_STEER_STEP, MAX_UNEXPLAINED_STEER_STEP, unexplained_steer_step,
};
use omnikin_sim::dynamic_run::{
    self, DynamicError, DynamicOptions, DynamicOutcome, DynamicPlant, PushSpec,
};
use omnikin_sim::metrics::{MeanTrajectory, evaluate, tracked_reference};
use omnikin_sim::sensors::SensorProfile;
use omnikin_sim::track::TrackAlignment;
use omnikin_sim::{Profile, Trial};
use pyo3::prelude::*;
use serde_json::json;

use crate::arrays::value_error;
use crate::robot::PyRobot;

/// Columns and values (one row per column), as `plan_columns` returns them.
pub(crate) type Table<'py> = (Vec<String>, Bound<'py, PyAny>);

pub(crate) fn table<'py>(
    py: Python<'py>,
    cols: Vec<String>,
    values: Vec<Vec<f64>>,
) -> PyResult<Table<'py>> {
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
pub(crate) fn load_plan(
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

/// The mean trajectory's columns (`mean.csv`, [`omnikin_sim::run_columns`]).
fn mean_table<'py>(py: Python<'py>, plan: &Plan, mean: &MeanTrajectory) -> PyResult<Table<'py>> {
    use omnikin_sim::run_columns::{MEAN_COLUMNS, mean_row};
    let mut v = vec![Vec::with_capacity(plan.samples.len()); MEAN_COLUMNS.len()];
    for k in 0..plan.samples.len() {
        for (c, x) in mean_row(plan, mean, k).into_iter().enumerate() {
            v[c].push(x);
        }
    }
    table(py, MEAN_COLUMNS.iter().map(|s| s.to_string()).collect(), v)
}

/// Appends trial `i` to the `trials.csv` columns ([`omnikin_sim::run_columns::trial_row`]).
fn add_trial(v: &mut [Vec<f64>], i: usize, tr: &Trial) {
    let mut row = Vec::new();
    for k in 0..tr.t.len() {
        omnikin_sim::run_columns::trial_row(i, tr, k, &mut row);
        for (c, x) in row.iter().enumerate() {
            v[c].push(*x);
        }
    }
}

/// `omnikin.simulate`: `(trials, mean, metrics_json)`.
/// Named tables beside the main ones (`extras` of a dynamic run, one trial's sensor logs).
type Named<'py> = Vec<(String, Table<'py>)>;

/// What `simulate_native` returns: `(trials, mean, metrics_json, extras, sensors)`.
type Simulated<'py> = (Table<'py>, Table<'py>, String, Named<'py>, Vec<Named<'py>>);

/// A CSV text of numbers (as the library's writers write it, every value read back exactly)
/// as columns.
fn csv_table<'py>(py: Python<'py>, text: &[u8], what: &str) -> PyResult<Table<'py>> {
    let text = std::str::from_utf8(text).map_err(|e| value_error(format!("{what}: {e}")))?;
    let mut lines = text.lines();
    let cols: Vec<String> = lines
        .next()
        .unwrap_or_default()
        .split(',')
        .map(str::to_string)
        .collect();
    let mut v = vec![Vec::new(); cols.len()];
    for (n, line) in lines.enumerate() {
        for (c, cell) in line.split(',').enumerate() {
            let x: f64 = cell.parse().map_err(|_| {
                value_error(format!("{what}: line {}: not a number: {cell:?}", n + 2))
            })?;
            match v.get_mut(c) {
                Some(col) => col.push(x),
                None => {
                    return Err(value_error(format!(
                        "{what}: line {}: too many cells",
                        n + 2
                    )));
                }
            }
        }
    }
    table(py, cols, v)
}

/// The sensor profile of `emit_sensors` (a TOML file, or the typical one), read as the CLI
/// reads `--sensors`.
fn sensor_profile(path: Option<&str>) -> PyResult<SensorProfile> {
    Ok(match path {
        Some(p) => {
            let text = omnikin::description::read_text_limited(
                std::path::Path::new(p),
                omnikin::description::MAX_TOML_BYTES,
                "MAX_TOML_BYTES of omnikin::description",
            )
            .map_err(|e| value_error(format!("cannot read sensor profile {p}: {e}")))?;
            SensorProfile::from_toml_str(&text, p).map_err(|e| value_error(e.to_string()))?
        }
        None => SensorProfile::typical(),
    })
}

/// The sensor logs of one trial, as the CLI writes them under `sensors/trial-NNN/` (the
/// library's writers, read back): `encoders`, `truth`, and `fixes` and `imu` when recorded.
fn sensor_tables<'py>(py: Python<'py>, logs: &[(String, Vec<u8>)]) -> PyResult<Named<'py>> {
    logs.iter()
        .map(|(name, text)| Ok((name.clone(), csv_table(py, text, &format!("{name}.csv"))?)))
        .collect()
}

/// The CSV texts of trial `i`'s sensor logs; `attitude`: the dynamic plant's platform attitude
/// per sample (the IMU on the tilting platform), `None` for the kinematic plant.
fn emit_logs(
    robot: &omnikin::Robot<f64>,
    i: usize,
    trial: &Trial,
    attitude: Option<&[omnikin_sim::sensors::PlatformAttitude]>,
    profile: &SensorProfile,
    seed: u64,
) -> std::io::Result<Vec<(String, Vec<u8>)>> {
    use omnikin_sim::sensors::{
        emit_trial_with_attitude, write_encoder_log, write_fixes, write_imu, write_truth,
    };
    let s = emit_trial_with_attitude(robot, i, trial, attitude, profile, seed);
    let mut out = Vec::new();
    let mut w = Vec::new();
    write_encoder_log(&s.encoder, &mut w)?;
    out.push(("encoders".to_string(), std::mem::take(&mut w)));
    if !s.fixes.is_empty() {
        write_fixes(&s.fixes, &mut w)?;
        out.push(("fixes".to_string(), std::mem::take(&mut w)));
    }
    if !s.imu.is_empty() {
        write_imu(&s.imu, &mut w)?;
        out.push(("imu".to_string(), std::mem::take(&mut w)));
    }
    write_truth(trial, &mut w)?;
    out.push(("truth".to_string(), w));
    Ok(out)
}

/// A user warning with `msg`, attributed to the caller's line: stack level 2 skips the
/// wrapper in `omnikin/__init__.py` that called the native function.
pub(crate) fn warn(py: Python<'_>, msg: &str) -> PyResult<()> {
    PyErr::warn(
        py,
        &py.get_type::<pyo3::exceptions::PyUserWarning>(),
        &std::ffi::CString::new(msg).unwrap_or_default(),
        2,
    )
}

/// `omnikin.simulate(..., plant="dynamic")`: the plan once through the robot's dynamic plant
/// ([`omnikin_sim::dynamic_run`], as `omnikin simulate --plant dynamic`); with `emit_sensors`
/// (sphere-omni only, as the CLI) the sensor logs of the run, the IMU on the model's tilting
/// platform, under the profile `sensors` (default: the typical one).
#[allow(clippy::too_many_arguments)]
fn simulate_dynamic<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    plan: Plan,
    plan_name: String,
    disturbances: Option<&str>,
    emit_sensors: bool,
    sensors: Option<&str>,
    trials: u64,
    seed: u64,
    initial_tilt_deg: Option<f64>,
    pushes: Vec<PushSpec>,
) -> PyResult<Simulated<'py>> {
    let d = &robot.desc;
    let err = |e: DynamicError| value_error(e.to_string());
    dynamic_run::check_kind(d).map_err(err)?;
    if disturbances.is_some() {
        return Err(value_error(
            "plant=\"dynamic\" does not take disturbances yet",
        ));
    }
    let sensor_profile = if emit_sensors {
        if d.robot_kind().balances() {
            return Err(value_error(
                "emit_sensors: not yet for the ballbot's dynamic plant (sphere-omni's dynamic plant and the kinematic plants only)",
            ));
        }
        let sp = sensor_profile(sensors)?;
        if sp.tilt.is_some() {
            return Err(value_error(
                "sensors: [tilt] sets a constant platform tilt for the kinematic plant; the dynamic plant tilts the platform itself (its IMU carries the model's roll and pitch): remove [tilt] or use plant=\"kinematic\"",
            ));
        }
        Some(sp)
    } else {
        None
    };
    if trials > 1 {
        warn(py, &format!("note: {}", dynamic_run::one_trial_note(d)))?;
    }
    let opts = DynamicOptions {
        plan_name,
        seed,
        initial_tilt_deg,
        pushes,
    };
    let plant = DynamicPlant::new(d, &plan, &opts).map_err(err)?;
    let sim = py.detach(|| plant.run(d, &plan, &opts)).map_err(err)?;
    let mut v = vec![Vec::new(); 8 + 3];
    add_trial(&mut v, 0, sim.trial());
    let extras = match &sim.outcome {
        DynamicOutcome::Sphere(r) => {
            let cols = ["t", "tilt", "shell_spin"].map(String::from).to_vec();
            vec![(
                "dynamics".to_string(),
                table(
                    py,
                    cols,
                    vec![r.trial.t.clone(), r.tilt.clone(), r.shell_spin.clone()],
                )?,
            )]
        }
        DynamicOutcome::Ballbot(r) => {
            let cols = ["t", "tilt", "x", "y"].map(String::from).to_vec();
            let x = r.position.iter().map(|p| p[0]).collect();
            let y = r.position.iter().map(|p| p[1]).collect();
            vec![(
                "cycles".to_string(),
                table(py, cols, vec![r.t.clone(), r.tilt.clone(), x, y])?,
            )]
        }
    };
    let sensor_logs = match &sensor_profile {
        Some(sp) => {
            let logs = emit_logs(&robot.model, 0, sim.trial(), sim.attitude(), sp, seed)
                .map_err(|e| value_error(format!("sensor logs of trial 0: {e}")))?;
            vec![sensor_tables(py, &logs)?]
        }
        None => Vec::new(),
    };
    Ok((
        table(py, omnikin_sim::run_columns::trial_columns(3), v)?,
        mean_table(py, &plan, &sim.evaluation.mean)?,
        sim.metrics_json.to_string(),
        extras,
        sensor_logs,
    ))
}

/// `omnikin.simulate`: `(trials, mean, metrics_json, extras, sensors)`.
#[pyfunction]
#[pyo3(signature = (robot, plan_path=None, plan_columns=None, disturbances=None, trials=10, seed=1, threads=None, plant="kinematic", initial_tilt_deg=None, push=None, emit_sensors=false, sensors=None))]
#[allow(clippy::too_many_arguments)]
pub fn simulate_native<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    plan_path: Option<&str>,
    plan_columns: Option<(Vec<String>, PyReadonlyArray2<'py, f64>)>,
    disturbances: Option<&str>,
    trials: u64,
    seed: u64,
    threads: Option<usize>,
    plant: &str,
    initial_tilt_deg: Option<f64>,
    push: Option<Vec<Vec<f64>>>,
    emit_sensors: bool,
    sensors: Option<&str>,
) -> PyResult<Simulated<'py>> {
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
    let dynamic = match plant {
        "kinematic" => false,
        "dynamic" => true,
        p => {
            return Err(value_error(format!(
                "plant: {p:?} is not one of kinematic, dynamic"
            )));
        }
    };
    if sensors.is_some() && !emit_sensors {
        return Err(value_error("sensors: needs emit_sensors=True"));
    }
    let initial_tilt_deg = initial_tilt_deg
        .map(|v| {
            dynamic_run::check_initial_tilt_deg(v)
                .map_err(|e| value_error(format!("initial_tilt_deg: {e}")))
        })
        .transpose()?;
    let pushes = push
        .unwrap_or_default()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            match p[..] {
                [j, t] => PushSpec::new(j, t, 0.0),
                [j, t, deg] => PushSpec::new(j, t, deg),
                _ => Err(format!(
                    "expected (impulse N·s, time s[, direction deg]), got {} values",
                    p.len()
                )),
            }
            .map_err(|e| value_error(format!("push {}: {e}", i + 1)))
        })
        .collect::<PyResult<Vec<_>>>()?;
    let (plan, plan_name) = load_plan(plan_path, plan_columns)?;
    let ballbot_dynamic = dynamic && robot.desc.robot_kind().balances();
    if !ballbot_dynamic && (initial_tilt_deg.is_some() || !pushes.is_empty()) {
        return Err(value_error(
            "initial_tilt_deg and push need a ballbot (kind ballbot) and plant=\"dynamic\"",
        ));
    }
    if dynamic {
        return simulate_dynamic(
            py,
            robot,
            plan,
            plan_name,
            disturbances,
            emit_sensors,
            sensors,
            trials,
            seed,
            initial_tilt_deg,
            pushes,
        );
    }
    let model = &robot.model;
    let profile = match disturbances {
        Some(p) => {
            Profile::load(std::path::Path::new(p)).map_err(|e| value_error(e.to_string()))?
        }
        None => Profile::default(),
    };
    if let Some(why) = omnikin_sim::plan_mismatch(model, &plan) {
        warn(py, &format!("{plan_name}: {why}"))?;
    }
    // As `omnikin simulate` (crates/omnikin-cli/src/sim.rs): a steer step the sd columns do
    // not explain is refused beyond MAX_SIMULATED_STEER_STEP, warned about beyond
    // MAX_UNEXPLAINED_STEER_STEP.
    if let Some(step) = unexplained_steer_step(&plan, MAX_SIMULATED_STEER_STEP) {
        return Err(value_error(format!(
            "{plan_name}: {step}: the simulator turns the steer motors by the sd columns, so it \
             would not follow this plan: {}",
            step.cause()
        )));
    } else if let Some(step) = unexplained_steer_step(&plan, MAX_UNEXPLAINED_STEER_STEP) {
        warn(
            py,
            &format!(
                "{plan_name}: {step}: the simulated steering will differ from the plan's by \
                 about that much: {}",
                step.cause()
            ),
        )?;
    }
    let sensor_profile = if emit_sensors {
        Some(sensor_profile(sensors)?)
    } else {
        None
    };
    let mut logs: Vec<Vec<(String, Vec<u8>)>> = Vec::new();
    let reference = tracked_reference(&plan, profile.tracking.offset.unwrap_or([0.0; 2]));
    let cols = omnikin_sim::run_columns::trial_columns(model.wheels());
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
                    if let Some(sp) = &sensor_profile {
                        logs.push(
                            emit_logs(model, i, trial, None, sp, seed)
                                .map_err(|e| format!("sensor logs of trial {i}: {e}"))?,
                        );
                    }
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
    let sensor_logs = logs
        .iter()
        .map(|l| sensor_tables(py, l))
        .collect::<PyResult<Vec<_>>>()?;
    Ok((
        table(py, cols, v)?,
        mean_table(py, &reference, &mean)?,
        j.to_string(),
        Vec::new(),
        sensor_logs,
    ))
}

/// `omnikin.evaluate`: `(runs, mean, metrics_json)` of tracked runs (`t,x,y[,heading]` CSV
/// files or columns, [`crate::pose_error::TrackArg`]) against a plan.
#[pyfunction]
#[pyo3(signature = (tracks, plan_path=None, plan_columns=None, motion_threshold=0.005, align_position=true, tracking_offset=None))]
#[allow(clippy::type_complexity)]
pub fn evaluate_native<'py>(
    py: Python<'py>,
    tracks: Vec<crate::pose_error::TrackArg<'py>>,
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
    let align = TrackAlignment {
        motion_threshold_m: motion_threshold,
        align_position,
    };
    let mut runs = Vec::new();
    let mut names = Vec::with_capacity(tracks.len());
    let mut estops = Vec::new();
    for arg in &tracks {
        let (track, f) = arg.load()?;
        if let Some(why) = track.did_not_move(&plan, align) {
            return Err(value_error(format!("{f}: {why}")));
        }
        runs.push(track.resample(&plan, align));
        estops.extend(track.estops_on(&plan, align));
        names.push(f);
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
        "plan": plan_name, "tracks": names,
        "motion_threshold_m": motion_threshold, "align_position": align_position,
        "tracking_offset_m": tracking_offset.unwrap_or([0.0; 2]),
        "estops": estops.iter().map(|m| json!({"t": m.t, "x": m.xy[0], "y": m.xy[1]})).collect::<Vec<_>>(),
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
