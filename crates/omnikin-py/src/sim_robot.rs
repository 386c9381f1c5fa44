//! `omnikin.SimRobot`: a simulated robot served over the link from Python — the code
//! `omnikin robot --sim` runs ([`omnikin_host::robot_serve`]) on a thread of its own, so a
//! notebook or a test can drive it with `omnikin.Link` (or `omnikin drive`) without starting
//! the binary.
//!
//! The robot is built and its address bound when the object is made (bad options raise at
//! once, `listen="127.0.0.1:0"` picks a free port: read `address`); `stop()` ends the serve
//! loop and returns its summary (the JSON `omnikin robot --max-time` prints, as a dict); with
//! `max_time` it ends by itself and `wait()` returns the summary.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

use omnikin_host::robot_serve::{RobotServer, ServeOptions, ServeSummary};
use omnikin_host::sim_robot::{PlantKind, SimOptions};

/// A simulated robot served on its own thread (see the module docs).
#[pyclass(name = "SimRobot", module = "omnikin", subclass)]
pub struct PySimRobot {
    address: Option<String>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<anyhow::Result<ServeSummary>>>,
    summary: Option<String>,
    max_time: Option<f64>,
}

/// A finite option within `[lo, hi]`, named as Python's keyword.
fn within(name: &str, v: Option<f64>, lo: f64, hi: f64, unit: &str) -> PyResult<()> {
    match v {
        Some(x) if !(x.is_finite() && (lo..=hi).contains(&x)) => Err(PyValueError::new_err(
            format!("{name} must be within [{lo}, {hi}] {unit} (got {x})"),
        )),
        _ => Ok(()),
    }
}

impl PySimRobot {
    /// Ends the serve loop's thread (when it runs) and keeps its summary.
    fn join(&mut self, py: Python<'_>, stop: bool) -> PyResult<()> {
        if stop {
            self.stop.store(true, Ordering::Relaxed);
        }
        let Some(t) = self.thread.take() else {
            return Ok(());
        };
        let r = py.detach(|| t.join());
        match r {
            Ok(Ok(served)) => {
                self.summary = Some(served.summary.to_string());
                Ok(())
            }
            Ok(Err(e)) => Err(PyRuntimeError::new_err(format!("simulated robot: {e:#}"))),
            Err(_) => Err(PyRuntimeError::new_err(
                "simulated robot: its thread panicked",
            )),
        }
    }
}

#[pymethods]
impl PySimRobot {
    /// Builds the simulated robot `robot` (a preset name or a robot file) and starts serving it
    /// on `listen` (module docs). The keywords are `omnikin robot --sim`'s flags.
    #[new]
    #[pyo3(signature = (robot, *, listen="127.0.0.1:0", key=None, plant="kinematic", disturbances=None, seed=1, rate=None, telemetry_rate=20.0, watchdog=0.5, time_scale=1.0, max_time=None, max_speed=None, max_yaw_rate=None, max_accel=None, max_yaw_accel=None, max_jerk=None, gyro_heading=false, log=None, mcap=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        robot: &str,
        listen: &str,
        key: Option<PathBuf>,
        plant: &str,
        disturbances: Option<String>,
        seed: u64,
        rate: Option<f64>,
        telemetry_rate: f64,
        watchdog: f64,
        time_scale: f64,
        max_time: Option<f64>,
        max_speed: Option<f64>,
        max_yaw_rate: Option<f64>,
        max_accel: Option<f64>,
        max_yaw_accel: Option<f64>,
        max_jerk: Option<f64>,
        gyro_heading: bool,
        log: Option<PathBuf>,
        mcap: Option<PathBuf>,
    ) -> PyResult<Self> {
        let plant = match plant {
            "kinematic" => PlantKind::Kinematic,
            "dynamic" => PlantKind::Dynamic,
            p => {
                return Err(PyValueError::new_err(format!(
                    "plant must be \"kinematic\" or \"dynamic\" (got {p:?})"
                )));
            }
        };
        // The CLI's value parsers' ranges, named as Python's keywords.
        within("rate", rate, 1.0, 10_000.0, "Hz")?;
        within("telemetry_rate", Some(telemetry_rate), 0.1, 1000.0, "Hz")?;
        within("watchdog", Some(watchdog), 1e-3, 1e6, "s")?;
        within(
            "time_scale",
            Some(time_scale),
            0.01,
            1000.0,
            "times real time",
        )?;
        within("max_time", max_time, 0.0, 1e9, "s")?;
        let (desc, _, _) = crate::robot::load(robot)?;
        let sim = SimOptions {
            plant,
            disturbances,
            rate,
            watchdog,
            max_accel,
            max_yaw_accel,
            max_jerk,
            max_speed,
            max_yaw_rate,
            gyro_heading,
            seed,
            obstacle: None,
        };
        let serve = ServeOptions {
            listen: listen.to_owned(),
            key,
            insecure: false,
            telemetry_rate,
            time_scale,
            max_time,
            log,
            mcap,
            names: omnikin_host::names::OptionNames::PYTHON,
        };
        let server = RobotServer::new(&desc, &sim, serve)
            .map_err(|e| PyValueError::new_err(format!("{e:#}")))?;
        let address = server.local_addr().map(|a| a.to_string());
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let thread = std::thread::Builder::new()
            .name("omnikin-sim-robot".into())
            .spawn(move || server.run(Some(&flag)))
            .map_err(|e| {
                PyRuntimeError::new_err(format!("cannot start the robot's thread: {e}"))
            })?;
        Ok(Self {
            address,
            stop,
            thread: Some(thread),
            summary: None,
            max_time,
        })
    }

    /// The bound UDP address, `HOST:PORT` (`None` on a serial port): give it to
    /// `omnikin.Link`.
    #[getter]
    fn address(&self) -> Option<String> {
        self.address.clone()
    }

    /// Whether the serve loop still runs.
    #[getter]
    fn running(&self) -> bool {
        self.thread.as_ref().is_some_and(|t| !t.is_finished())
    }

    /// Stops the robot (at its next control cycle) and returns its summary as JSON text.
    fn stop_native(&mut self, py: Python<'_>) -> PyResult<Option<String>> {
        self.join(py, true)?;
        Ok(self.summary.clone())
    }

    /// Waits for a robot started with `max_time` to end; returns its summary as JSON text.
    fn wait_native(&mut self, py: Python<'_>) -> PyResult<Option<String>> {
        if self.max_time.is_none() && self.thread.is_some() {
            return Err(PyRuntimeError::new_err(
                "wait(): this robot has no max_time and would serve forever; use stop()",
            ));
        }
        self.join(py, false)?;
        Ok(self.summary.clone())
    }
}

impl Drop for PySimRobot {
    fn drop(&mut self) {
        // A robot dropped while serving: ended, not left running behind the interpreter.
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
