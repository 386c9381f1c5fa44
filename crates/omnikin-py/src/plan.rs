//! `omnikin.plan(robot, "square" | "circle" | "waypoints" | "goal", **options)` (goal in
//! [`crate::plan_goal`]): the requests of
//! `omnikin plan` (crates/omnikin-cli/src/plan/request.rs) with the same options, defaults and
//! checks, planned by [`omnikin_plan::planner::plan_from_velocity`] (from rest unless
//! `start_velocity` is given) without the GIL; the plan comes back as its CSV columns.

use numpy::ndarray::Array2;
use numpy::prelude::IntoPyArray;
use omnikin_plan::generators::{Circle, Square};
use omnikin_plan::heading::{HeadingLaw, HeadingProfile};
use omnikin_plan::path::{Corners, Path};
use omnikin_plan::planner::{
    MotionLimits, OnLimit, PlanOptions, StartVelocity, Timing, plan_from_velocity,
};
use omnikin_plan::profile::ProfileKind;
use omnikin_plan::steer_steps::{MAX_UNEXPLAINED_STEER_STEP, unexplained_steer_step};
use omnikin_plan::waypoints::Waypoints;
use omnikin_plan::{Plan, PlanningError, RobotModel};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::value_error;
use crate::options::Options;
use crate::plan_request::{Request, initial_steer};
use crate::robot::PyRobot;

/// A planning error as the CLI words it: a parameter out of range starts with the option
/// that set it; a motor limit says which request was too fast for which robot.
fn planning_error(e: PlanningError, context: impl FnOnce() -> String) -> PyErr {
    match &e {
        PlanningError::OutOfRange { name, .. } => {
            value_error(format!("{}: {e}", name.replace(' ', "_")))
        }
        PlanningError::LimitExceeded(_) | PlanningError::Infeasible(_) => {
            value_error(format!("{}: {e}", context()))
        }
        _ => value_error(e.to_string()),
    }
}

fn profile(o: &mut Options) -> PyResult<ProfileKind> {
    Ok(match o.choice("profile", &["trapezoid", "s-curve"])? {
        Some("s-curve") => ProfileKind::SCurve,
        _ => ProfileKind::Trapezoid,
    })
}

fn on_limit(o: &mut Options) -> PyResult<OnLimit> {
    Ok(if o.flag("no_retime")? {
        OnLimit::Reject
    } else {
        OnLimit::Retime
    })
}

/// The heading law of a waypoint plan (the CLI's `waypoint_heading`).
fn waypoint_heading(
    o: &mut Options,
    wp: &Waypoints,
    path: &Path,
    file: &str,
) -> PyResult<HeadingLaw> {
    let law = o.choice("heading_law", &["constant", "tangent", "waypoints"])?;
    let heading = o.f64("heading", 0.0)?;
    let spin = o.f64("spin", 0.0)?;
    let offset = o.f64("heading_offset", 0.0)?;
    let law = law.unwrap_or(if wp.headings.is_some() {
        "waypoints"
    } else {
        "constant"
    });
    let err = |e: PlanningError| planning_error(e, String::new);
    Ok(match law {
        "constant" if spin == 0.0 => HeadingLaw::Constant(heading),
        "constant" => {
            omnikin_plan::limits::check_magnitude(
                "spin",
                spin,
                omnikin_plan::limits::MAX_SPIN,
                "rad/m",
            )
            .map_err(err)?;
            let l = path.length();
            HeadingLaw::Profile(
                HeadingProfile::new(&[(0.0, heading), (l, heading + spin * l)]).map_err(err)?,
            )
        }
        "tangent" => HeadingLaw::Tangent { offset },
        _ => {
            let Some(h) = &wp.headings else {
                return Err(value_error(format!(
                    "{file}: heading_law waypoints needs a heading column (x,y,heading)"
                )));
            };
            let pts: Vec<(f64, f64)> = path
                .waypoint_arc_lengths()
                .iter()
                .copied()
                .zip(h.iter().copied())
                .collect();
            HeadingLaw::Profile(HeadingProfile::new(&pts).map_err(err)?)
        }
    })
}

/// Waypoints from an `(N, 2)` (`x, y`) or `(N, 3)` (`x, y, heading`) array: written as a
/// waypoint CSV (each value exactly, no header) and read with the file's checks, so an error
/// names the row as `points:ROW` (1-based).
fn points_waypoints(points: &Bound<'_, PyAny>) -> PyResult<Waypoints> {
    let what = "waypoints (x, y[, heading]; m, rad)";
    // The width from the array's own shape, so an error names the shape that was meant.
    let shape: Vec<usize> = points
        .py()
        .import("numpy")?
        .call_method1("shape", (points,))?
        .extract()
        .unwrap_or_default();
    let width = if shape.len() == 2 && shape[1] == 3 {
        3
    } else {
        2
    };
    let rows = crate::arrays::rows(points, "points", width, what).map_err(|e| {
        value_error(format!(
            "points: expected shape (N, 2) of x, y or (N, 3) of x, y, heading; {}",
            e.value(points.py())
        ))
    })?;
    if rows.single {
        return Err(value_error(
            "points: expected shape (N, 2) or (N, 3) with N >= 2, got one row",
        ));
    }
    let v = rows.values()?;
    let mut text = String::new();
    for row in v.chunks(width) {
        let cells: Vec<String> = row.iter().map(|x| format!("{x}")).collect();
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    Waypoints::from_csv(&text, "points").map_err(|e| value_error(e.to_string()))
}

fn square(o: &mut Options, d: &PyRobot, robot: &RobotModel) -> PyResult<Request> {
    let sq = Square {
        side: o.positive("side", 0.4)?,
        speed: o.positive("speed", 0.1)?,
        ramp_fraction: o.positive("ramp_fraction", 0.05)?,
        profile: profile(o)?,
    };
    let mut opts = sq.options(o.positive("rate", 100.0)?, on_limit(o)?);
    opts.initial_steer = initial_steer(o, robot)?;
    let path = sq.path().map_err(|e| planning_error(e, String::new))?;
    let ctx = format!("square at {} m/s is too fast for {}", sq.speed, d.desc.name);
    Ok((path, sq.heading(), opts, ctx))
}

fn circle(o: &mut Options, d: &PyRobot, robot: &RobotModel) -> PyResult<Request> {
    let radius = o.positive("radius", 0.2)?;
    let Some(omega) = o.opt_f64("omega")? else {
        return Err(value_error(
            "circle needs omega (rad/s about the centre; negative: clockwise)",
        ));
    };
    let c = Circle {
        radius,
        omega,
        turns: o.positive("turns", 1.0)?,
        ramp: o.opt_positive("ramp")?,
        face_motion: o.flag("face_motion")?,
    };
    let mut opts = c.options(o.positive("rate", 100.0)?);
    opts.initial_steer = initial_steer(o, robot)?;
    let path = c.path().map_err(|e| planning_error(e, String::new))?;
    let ctx = format!(
        "circle with omega {} rad/s (radius {} m) is too fast for {}",
        omega, radius, d.desc.name
    );
    Ok((path, c.heading(), opts, ctx))
}

fn waypoints(o: &mut Options, d: &PyRobot, robot: &RobotModel) -> PyResult<Request> {
    let (wp, file) = match (o.opt_str("file")?, o.any("points")?) {
        (Some(file), None) => (
            Waypoints::load(std::path::Path::new(&file)).map_err(|e| value_error(e.to_string()))?,
            file,
        ),
        (None, Some(points)) => (points_waypoints(&points)?, "points".to_string()),
        (Some(_), Some(_)) => {
            return Err(value_error("waypoints: give file or points, not both"));
        }
        (None, None) => {
            return Err(value_error(
                "waypoints needs file (CSV x,y[,heading] or TOML [[waypoint]]) or points \
                 (an (N, 2) array of x, y or (N, 3) of x, y, heading; m, rad, world frame)",
            ));
        }
    };
    let shape = o
        .choice("path", &["polyline", "spline"])?
        .unwrap_or("polyline");
    let corners = o.choice("corners", &["stop", "fillet"])?.unwrap_or("stop");
    let fillet_radius = o.positive("fillet_radius", 0.1)?;
    let path = match (shape, corners) {
        ("spline", _) => Path::spline(&wp.points),
        (_, "stop") => Path::polyline(&wp.points, Corners::Stop),
        _ => Path::polyline(
            &wp.points,
            Corners::Fillet {
                radius: fillet_radius,
            },
        ),
    }
    .map_err(|e| value_error(wp.locate(&file, e).to_string()))?;
    let heading = waypoint_heading(o, &wp, &path, &file)?;
    let time_optimal = o.flag("time_optimal")?;
    for c in ["max_jerk", "profile", "no_retime"] {
        if time_optimal && o.given(c)? {
            return Err(value_error(format!("{c} cannot be used with time_optimal")));
        }
    }
    let limits = MotionLimits {
        max_speed: o.positive("max_speed", 0.2)?,
        max_accel: o.positive("max_accel", 0.5)?,
        max_jerk: o.positive("max_jerk", 5.0)?,
        max_yaw_rate: o.positive("max_yaw_rate", 1.0)?,
        max_yaw_accel: o.positive("max_yaw_accel", 2.0)?,
    };
    let timing = if time_optimal {
        Timing::TimeOptimal { limits }
    } else {
        Timing::Profile {
            kind: profile(o)?,
            limits,
        }
    };
    let opts = PlanOptions {
        timing,
        on_limit: on_limit(o)?,
        rate: o.positive("rate", 100.0)?,
        initial_steer: initial_steer(o, robot)?,
    };
    let ctx = format!(
        "{file}: the requested timing is too fast for {}",
        d.desc.name
    );
    Ok((path, heading, opts, ctx))
}

/// `start_velocity = [vx, vy]` or `[vx, vy, yaw_rate]` (world frame, m/s, rad/s; the CLI's
/// `--start-velocity`): the plan starts moving; at rest when not given.
fn start_velocity(o: &mut Options) -> PyResult<StartVelocity> {
    match o.list("start_velocity")? {
        None => Ok(StartVelocity::REST),
        Some(v) => StartVelocity::from_components(&v).ok_or_else(|| {
            value_error(format!(
                "start_velocity: expected [vx, vy] or [vx, vy, yaw_rate] (m/s, m/s, rad/s; world \
                 frame), got {} values",
                v.len()
            ))
        }),
    }
}

/// The plan's columns (its CSV header) and values, one row per column (`(columns, samples)`).
pub fn columns<'py>(py: Python<'py>, p: &Plan) -> PyResult<(Vec<String>, Bound<'py, PyAny>)> {
    let cols = p.columns();
    let (n, c, k) = (p.samples.len(), cols.len(), p.wheels);
    let steer = p.steerable();
    let mut a = Array2::<f64>::zeros((c, n));
    for (j, s) in p.samples.iter().enumerate() {
        let mut v = vec![
            s.t,
            s.pose.x,
            s.pose.y,
            s.pose.heading,
            s.twist.vx,
            s.twist.vy,
            s.twist.yaw_rate,
        ];
        v.extend(&s.wheel_rates[..k]);
        if steer {
            let (g, gd) = s.steer.unwrap_or((
                [f64::NAN; omnikin::MAX_WHEELS],
                [f64::NAN; omnikin::MAX_WHEELS],
            ));
            v.extend(&g[..k]);
            v.extend(&gd[..k]);
        }
        for (i, x) in v.into_iter().enumerate() {
            a[[i, j]] = x;
        }
    }
    Ok((cols, a.into_pyarray(py).into_any()))
}

/// `omnikin.plan`: the plan's CSV columns and their values (`(columns, values)` with
/// `values[i]` the column `columns[i]`).
#[pyfunction]
#[pyo3(signature = (robot, kind, **options))]
pub fn plan_columns<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    kind: &str,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Vec<String>, Bound<'py, PyAny>)> {
    let model =
        RobotModel::from_description(&robot.desc).map_err(|e| planning_error(e, String::new))?;
    let mut o = Options::new(options);
    // Only the waypoint and goal plans start moving (an unread option is refused below).
    let start = match kind {
        "waypoints" | "goal" => start_velocity(&mut o)?,
        _ => StartVelocity::REST,
    };
    let (path, heading, mut opts, ctx) = match kind {
        "square" => square(&mut o, robot, &model)?,
        "circle" => circle(&mut o, robot, &model)?,
        "waypoints" => waypoints(&mut o, robot, &model)?,
        "goal" => crate::plan_goal::goal(&mut o, robot, &model, start)?,
        k => {
            return Err(value_error(format!(
                "kind {k:?}: plan square, circle, waypoints or goal"
            )));
        }
    };
    o.finish(&format!("plan {kind}"))?;
    // As `omnikin plan`: a ballbot's acceleration is held to its lean limit.
    let lean = omnikin_plan::lean::apply(&robot.desc, &mut opts);
    let planned = py
        .detach(|| plan_from_velocity(&path, &heading, &model, &opts, start))
        .map_err(|e| planning_error(e, || ctx))?;
    // As `omnikin plan` (crates/omnikin-cli/src/plan/write.rs): a steer step the plan's
    // steer rates do not explain is a warning (omnikin.simulate may refuse the plan).
    if let Some(step) = unexplained_steer_step(&planned.plan, MAX_UNEXPLAINED_STEER_STEP) {
        PyErr::warn(
            py,
            &py.get_type::<pyo3::exceptions::PyUserWarning>(),
            &std::ffi::CString::new(format!(
                "{step}: the steer-rate peak and the limits do not cover it, and \
                 omnikin.simulate may refuse this plan: {}",
                step.cause()
            ))
            .unwrap_or_default(),
            2,
        )?;
    }
    // As `omnikin plan` (crates/omnikin-cli/src/plan/setup.rs): a plan past the robot's body
    // limits is one a robot tracks with a lag, and that omnikin.Link refuses to upload.
    let mut body = robot.desc.body_limits();
    if let Some(l) = &lean {
        if let Some(w) = l.report(&planned.plan).warning {
            crate::sim::warn(py, &w)?;
        }
        // The lean limit's own check, above, is the acceleration's.
        body.max_accel = f64::INFINITY;
    }
    let peaks = omnikin_host::body_limits::peaks(&planned.plan);
    for e in omnikin_host::body_limits::plan_excess(&body, &peaks) {
        crate::sim::warn(
            py,
            &format!(
                "{e}: a robot holds itself to that limit (omnikin robot, omnikin.SimRobot), so \
                 it will lag behind this plan, and omnikin.Link.run_plan refuses to upload it"
            ),
        )?;
    }
    columns(py, &planned.plan)
}
