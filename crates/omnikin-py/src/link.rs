//! `omnikin.Link`: an operator session with a robot (a real one, or `omnikin robot --sim`)
//! from Python — the handshake, the heartbeats, the actions each confirmed by the robot's
//! telemetry, a plan driven — all [`omnikin_host`]'s, the code `omnikin drive` runs. The
//! telemetry is kept in memory in the columns of `drive --out`'s CSV log
//! ([`omnikin_host::telemetry_log`]); the pure-Python layer parses it into arrays.
//!
//! Blocking calls hold the GIL (the session is not shared across threads) and check for a
//! pending `KeyboardInterrupt` between receives: Ctrl-C in a notebook ends the wait, and the
//! robot's watchdog stops it once the heartbeats stop.

use std::path::PathBuf;

use numpy::PyReadonlyArray2;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use omnikin::runtime::Frame;
use omnikin_host::operator::{Session, duration};
use omnikin_host::telemetry_log::MemoryLog;

/// An error of the session as a Python exception: a pending `KeyboardInterrupt` (or any
/// Python error raised while waiting) as itself, bad arguments as `ValueError`, the robot's
/// refusals ([`omnikin_host::actions::RobotRefused`]) and the link's failures as
/// `RuntimeError`.
fn py_err(e: anyhow::Error) -> PyErr {
    match e.downcast::<PyErr>() {
        Ok(p) => p,
        Err(e) => PyRuntimeError::new_err(format!("{e:#}")),
    }
}

/// An operator session with a robot (see the module docs).
#[pyclass(name = "Link", module = "omnikin", unsendable, subclass)]
pub struct PyLink {
    s: Option<Session>,
}

impl PyLink {
    fn session(&mut self) -> PyResult<&mut Session> {
        self.s
            .as_mut()
            .ok_or_else(|| PyRuntimeError::new_err("the link is closed"))
    }
}

#[pymethods]
impl PyLink {
    /// Opens a session with the robot at `connect` (`HOST:PORT`, `udp:HOST:PORT` or
    /// `serial:PATH[@BAUD]`): the handshake, then its first telemetry frame.
    #[new]
    #[pyo3(signature = (connect, *, key=None, heartbeat_hz=20.0, timeout_s=1.0, mcap=None, keep_rows=100_000))]
    fn new(
        connect: &str,
        key: Option<PathBuf>,
        heartbeat_hz: f64,
        timeout_s: f64,
        mcap: Option<PathBuf>,
        keep_rows: usize,
    ) -> PyResult<Self> {
        // Named as Python's arguments (the session's own checks name drive's flags).
        if !(0.1..=1e4).contains(&heartbeat_hz) {
            return Err(PyValueError::new_err(format!(
                "heartbeat_hz must be in [0.1, 10000] Hz (got {heartbeat_hz})"
            )));
        }
        if !(timeout_s > 0.0 && timeout_s <= 1e6) {
            return Err(PyValueError::new_err(format!(
                "timeout_s must be in (0, 1e6] s (got {timeout_s})"
            )));
        }
        let mut s = Session::open(
            connect,
            key.as_deref(),
            heartbeat_hz,
            timeout_s,
            mcap.as_deref(),
            omnikin_host::names::OptionNames::PYTHON,
        )
        .map_err(|e| PyValueError::new_err(format!("{e:#}")))?;
        s.memory = Some(MemoryLog::new(keep_rows));
        s.interrupt = Some(Box::new(|| {
            Python::attach(|py| py.check_signals()).map_err(Into::into)
        }));
        s.hello().map_err(py_err)?;
        s.first_telemetry("the session").map_err(py_err)?;
        Ok(Self { s: Some(s) })
    }

    /// What the robot said in the handshake.
    fn info<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let i = self
            .session()?
            .op
            .info()
            .ok_or_else(|| PyRuntimeError::new_err("no handshake"))?;
        let d = PyDict::new(py);
        d.set_item("protocol", i.protocol)?;
        d.set_item("kind", i.kind.name())?;
        d.set_item("plan_capacity", i.plan_capacity)?;
        d.set_item("rate_hz", f64::from(i.rate_hz))?;
        d.set_item("watchdog_s", f64::from(i.watchdog))?;
        d.set_item("authenticated", i.authenticated)?;
        d.set_item("max_accel", f64::from(i.limits.max_accel))?;
        d.set_item("max_yaw_accel", f64::from(i.limits.max_yaw_accel))?;
        d.set_item("max_jerk", f64::from(i.limits.max_jerk))?;
        Ok(d)
    }

    /// Drives at `(vx, vy, yaw_rate)` (m/s, m/s, rad/s; the robot frame, or the world frame
    /// with `world=True`) for `duration` s, then stops.
    #[pyo3(signature = (vx, vy, yaw_rate, duration, *, world=false))]
    fn velocity(
        &mut self,
        vx: f64,
        vy: f64,
        yaw_rate: f64,
        duration: f64,
        world: bool,
    ) -> PyResult<()> {
        let d = self::duration("duration", duration)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        if ![vx, vy, yaw_rate].iter().all(|v| v.is_finite()) {
            return Err(PyValueError::new_err("vx, vy, yaw_rate must be finite"));
        }
        let frame = if world { Frame::World } else { Frame::Robot };
        self.session()?
            .velocity(frame, [vx, vy, yaw_rate], d)
            .map_err(py_err)
    }

    /// Heartbeats only for `duration` s (the robot keeps its session and reports).
    fn listen(&mut self, duration: f64) -> PyResult<()> {
        let d = self::duration("duration", duration)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        self.session()?
            .repeat(&omnikin::link::Message::Heartbeat, d)
            .map_err(py_err)
    }

    /// Stops the robot (confirmed by its telemetry).
    fn stop(&mut self) -> PyResult<()> {
        self.session()?.stop().map_err(py_err)
    }

    /// The emergency stop (latched until `clear`; confirmed by the robot).
    fn estop(&mut self) -> PyResult<()> {
        self.session()?.estop().map_err(py_err)
    }

    /// Clears the e-stop latch and the fault history (confirmed by the robot).
    fn clear(&mut self) -> PyResult<()> {
        self.session()?.clear().map_err(py_err)
    }

    /// Drives a plan (a plan CSV path, or the columns of `omnikin.plan`): held to the robot's
    /// limits, uploaded and followed to its end (streamed as velocities to a robot that takes
    /// no plans). `set_pose`: the estimate becomes the plan's first pose; otherwise a start
    /// farther than `start_tolerance` m from the estimate is refused.
    #[pyo3(signature = (plan_path=None, plan_columns=None, *, set_pose=true, start_tolerance=0.05))]
    fn run_plan_native<'py>(
        &mut self,
        py: Python<'py>,
        plan_path: Option<&str>,
        plan_columns: Option<(Vec<String>, PyReadonlyArray2<'_, f64>)>,
        set_pose: bool,
        start_tolerance: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (plan, label) = crate::sim::load_plan(plan_path, plan_columns)?;
        if plan.samples.len() < 2 {
            return Err(PyValueError::new_err(format!(
                "plan {label}: needs at least 2 samples"
            )));
        }
        let s = self.session()?;
        let info =
            s.op.info()
                .ok_or_else(|| PyRuntimeError::new_err("no handshake"))?;
        let d = PyDict::new(py);
        let within = omnikin_host::body_limits::check_upload(
            &plan,
            &format!("plan {label}"),
            None,
            &info.limits,
        )
        .map_err(|e| PyValueError::new_err(format!("{e:#}")))?;
        d.set_item("limits", within)?;
        let p0 = plan.samples[0].pose;
        let dist = s.distance_to([p0.x, p0.y]).map_err(py_err)?;
        if !set_pose && dist > start_tolerance {
            return Err(PyValueError::new_err(format!(
                "plan {label}: the robot's estimate is {dist:.3} m from the plan's start, more than start_tolerance {start_tolerance} m: pass set_pose=True or a larger start_tolerance"
            )));
        }
        if info.plan_capacity == 0 {
            let r = s.stream_plan(&plan, set_pose).map_err(py_err)?;
            d.set_item("streamed", true)?;
            d.set_item("end_pose", r.end_pose.map(f64::from))?;
            if let Some((lag, path)) = r.deviation {
                d.set_item("max_deviation", lag)?;
                d.set_item("max_path_deviation", path)?;
            }
            return Ok(d);
        }
        let pts = omnikin_host::wire_plan::plan_points(&plan, usize::from(info.plan_capacity));
        let id = (omnikin_host::link_io::epoch_seq() & 0xffff) as u16;
        let up = s.upload_plan(id, pts, set_pose).map_err(py_err)?;
        let f = s.follow_plan().map_err(py_err)?;
        d.set_item("streamed", false)?;
        d.set_item("id", up.id)?;
        d.set_item("points", up.points)?;
        d.set_item("chunks", up.chunks)?;
        d.set_item("upload_s", up.secs)?;
        d.set_item("max_deviation", f64::from(f.max_deviation))?;
        d.set_item("end_pose", f.end_pose.map(f64::from))?;
        Ok(d)
    }

    /// The telemetry since the last call as CSV text (the columns of `drive --out`) and the
    /// number of frames dropped at `keep_rows`.
    fn take_telemetry_native(&mut self) -> PyResult<(String, u64)> {
        let s = self.session()?;
        Ok(s.memory
            .as_mut()
            .map_or((String::new(), 0), MemoryLog::take))
    }

    /// Telemetry frames of this session received so far.
    #[getter]
    fn frames(&mut self) -> PyResult<u64> {
        Ok(self.session()?.frames)
    }

    /// Leaves the session (`Bye`) and closes the MCAP log. Idempotent.
    fn close(&mut self) -> PyResult<()> {
        match self.s.take() {
            Some(mut s) => s.finish().map_err(py_err),
            None => Ok(()),
        }
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_exc))]
    fn __exit__(&mut self, _exc: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<bool> {
        self.close()?;
        Ok(false)
    }
}
