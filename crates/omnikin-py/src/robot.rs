//! `omnikin.Robot`: a preset or robot file loaded as the CLI loads `ROBOT`
//! ([`RobotDescription::resolve`], then [`RobotDescription::build`]), its properties, and the
//! vectorised kinematics verbs `inverse`, `forward` and `torques` of the CLI contract.

use omnikin::description::{PRESETS, RobotDescription};
use omnikin::drive::{KindModel, KindVisitor, TorqueSpace};
use omnikin::{Actuators, MAX_WHEELS, Robot, Twist2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{Rows, matching, row, rows, to_array, value_error};
use crate::kernels::{RowError, map_chunks2, map_rows, map_rows2};

/// A robot: a preset name (`sphere-omni`, `ballbot`, `caster3`, `kiwi`, `x-drive`,
/// `mecanum`, `swerve4`) or the path of a TOML robot file.
///
/// Invalid files raise `ValueError` with the CLI's message (`FILE: FIELD: RULE`).
#[pyclass(module = "omnikin", name = "Robot", frozen)]
pub struct PyRobot {
    pub desc: RobotDescription,
    pub model: Robot<f64>,
    /// The TOML text it was read from.
    text: String,
}

/// A description error or a build error as a `ValueError` with the CLI's text.
pub fn load(name_or_path: &str) -> PyResult<(RobotDescription, Robot<f64>, String)> {
    let desc = RobotDescription::resolve(name_or_path).map_err(|e| value_error(e.to_string()))?;
    let model = desc
        .build::<f64>()
        .map_err(|e| value_error(e.to_string()))?;
    let text = match PRESETS.iter().find(|(n, _)| *n == name_or_path) {
        Some((_, t)) => t.to_string(),
        None => omnikin::description::read_text_limited(
            std::path::Path::new(name_or_path),
            omnikin::description::MAX_TOML_BYTES,
            "MAX_TOML_BYTES of omnikin::description",
        )
        .map_err(|e| value_error(format!("{name_or_path}: cannot read: {e}")))?,
    };
    Ok((desc, model, text))
}

impl PyRobot {
    /// The TOML text the robot was read from (for Rust callers; Python's is `toml`).
    pub fn text(&self) -> &str {
        &self.text
    }
}

fn reject_for(kind: &str, arg: &str, allowed: &str) -> PyErr {
    value_error(format!(
        "{arg} applies only to {allowed}, not to robot kind {kind}"
    ))
}

impl PyRobot {
    fn k(&self) -> usize {
        self.model.wheels()
    }

    /// `shell_spin`, refused for kinds without a shell or ball (as `--shell-spin`).
    fn spin(&self, spin: Option<f64>) -> PyResult<f64> {
        match spin {
            Some(_) if !self.model.kind().has_vertical_spin() => Err(reject_for(
                self.model.kind().name(),
                "shell_spin",
                "sphere-omni and ballbot",
            )),
            Some(s) if !s.is_finite() => Err(value_error("shell_spin must be finite")),
            s => Ok(s.unwrap_or(0.0)),
        }
    }

    /// `steer` (one angle per wheel/module per row, rad), refused for kinds without steering
    /// and checked against the CLI's plausible range.
    fn steer<'py>(
        &self,
        steer: Option<&Bound<'py, PyAny>>,
        n: usize,
        of: &str,
    ) -> PyResult<Option<Rows<'py>>> {
        let s = matching(steer, "steer", self.k(), "steer angles, rad", n, of)?;
        if s.is_some() && !self.model.steerable() {
            return Err(reject_for(
                self.model.kind().name(),
                "steer",
                "kinds with steering (caster3, swerve)",
            ));
        }
        if let Some(r) = &s {
            let max = omnikin_plan::limits::MAX_HEADING;
            if let Some(g) = r.values()?.iter().find(|g| g.abs() > max) {
                return Err(value_error(format!(
                    "steer: {g} rad is outside the plausible range [-{max:e}, {max:e}] rad \
                     (omnikin_plan::limits)"
                )));
            }
        }
        Ok(s)
    }
}

#[pymethods]
impl PyRobot {
    #[new]
    fn new(name_or_path: &str) -> PyResult<Self> {
        let (desc, model, text) = load(name_or_path)?;
        Ok(PyRobot { desc, model, text })
    }

    /// The kind: `sphere-omni`, `ballbot`, `caster3`, `omni` or `swerve`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.desc.kind()
    }

    /// The robot's name (the file's `name` key, or its kind).
    #[getter]
    fn name(&self) -> &str {
        &self.desc.name
    }

    /// Where it came from: a file path or `preset <name>`.
    #[getter]
    fn source(&self) -> &str {
        &self.desc.source_name
    }

    /// Number of wheels (modules for swerve).
    #[getter]
    fn wheels(&self) -> usize {
        self.k()
    }

    /// Number of motors (wheels plus steer motors).
    #[getter]
    fn motors(&self) -> usize {
        self.model.motors()
    }

    /// Whether the wheels are steered (caster3, swerve).
    #[getter]
    fn steerable(&self) -> bool {
        self.model.steerable()
    }

    /// The limits, as `omnikin check --json` gives them: the `[limits]` table's motor limits
    /// `max_wheel_rate`, `max_wheel_accel` (rad/s, rad/s²), `max_steer_rate`,
    /// `max_steer_accel` (`None` where the file sets none: unlimited), and the body limits
    /// every command uses, `max_accel` (m/s²), `max_yaw_accel` (rad/s²) — from the file, else
    /// derived from the motor limits — and `max_jerk` (m/s³, `None`: unlimited).
    #[getter]
    fn limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let l = &self.desc.limits;
        let b = self.desc.body_limits();
        let d = PyDict::new(py);
        d.set_item("max_wheel_rate", l.max_wheel_rate)?;
        d.set_item("max_wheel_accel", l.max_wheel_accel)?;
        d.set_item("max_steer_rate", l.max_steer_rate)?;
        d.set_item("max_steer_accel", l.max_steer_accel)?;
        d.set_item("max_accel", b.max_accel)?;
        d.set_item("max_yaw_accel", b.max_yaw_accel)?;
        d.set_item("max_jerk", b.max_jerk)?;
        Ok(d)
    }

    /// The robot file (TOML) as a dict, as written (units as in the file).
    #[getter]
    fn description<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let t: toml::Table = self
            .text
            .strip_prefix('\u{feff}')
            .unwrap_or(&self.text)
            .parse()
            .map_err(|e| value_error(format!("{}: {e}", self.desc.source_name)))?;
        let j = serde_json::to_string(&t).map_err(|e| value_error(e.to_string()))?;
        py.import("json")?.call_method1("loads", (j,))
    }

    /// The robot file's TOML text.
    #[getter]
    fn toml(&self) -> &str {
        &self.text
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot({:?}: {}, {} wheels, {})",
            self.desc.name,
            self.desc.kind(),
            self.k(),
            self.desc.source_name
        )
    }

    /// Inverse kinematics of `twists` (`(N, 3)` or `(3,)`: `vx, vy` m/s and `yaw_rate` rad/s,
    /// robot frame) at steer angles `steer` (`(N, k)` or `(k,)`, rad; steerable kinds, default
    /// 0) and shell/ball spin `shell_spin` (rad/s; sphere-omni and ballbot).
    ///
    /// Returns the keys of `omnikin inverse --json`: `wheel_rates` `(N, k)` rad/s, and
    /// `steer_rates` (caster3, rad/s) or `steer_angles` (swerve, rad) `(N, k)`.
    #[pyo3(signature = (twists, steer=None, shell_spin=None))]
    fn inverse<'py>(
        &self,
        py: Python<'py>,
        twists: &Bound<'py, PyAny>,
        steer: Option<&Bound<'py, PyAny>>,
        shell_spin: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let tw = rows(twists, "twists", 3, "vx, vy, yaw_rate")?;
        let spin = self.spin(shell_spin)?;
        let st = self.steer(steer, tw.rows, "twists")?;
        let k = self.k();
        let kind = self.model.kind();
        let steered = self.model.steerable();
        let set_point = kind.steer_is_set_point();
        let sw = if steered { k } else { 0 };
        let (tv, sv) = (tw.values()?, st.as_ref().map(|s| s.values()).transpose()?);
        let s_single = st.as_ref().is_some_and(|s| s.single);
        let model = &self.model;
        let n = tw.rows;
        // caster3 with one steer state for every row (none given: zeros): the trigonometry
        // of that state once (Caster3::robot_frame_inverse, equal to the per-row inverse
        // exactly), then three dot products per rate. A non-finite steer row takes the
        // per-row path, whose error names it.
        if let Robot::Caster(c) = model
            && (sv.is_none() || s_single)
        {
            let mut g = [0.0; 3];
            if let Some(v) = sv {
                g.copy_from_slice(&v[..3]);
            }
            if let Ok(inv) = c.robot_frame_inverse(g) {
                let out = py.detach(|| {
                    map_chunks2(n, 3, 3, |start, w, s| {
                        let rows = w.len() / 3;
                        let tws = tv[3 * start..3 * (start + rows)].chunks_exact(3);
                        let outs = w.chunks_exact_mut(3).zip(s.chunks_exact_mut(3));
                        for (j, (t, (w, s))) in tws.zip(outs).enumerate() {
                            let r = inv
                                .motor_rates(Twist2::new(t[0], t[1], t[2]))
                                .map_err(|e| (start + j, e.to_string()))?;
                            w.copy_from_slice(&r.roll);
                            s.copy_from_slice(&r.steer);
                        }
                        Ok(())
                    })
                });
                let (w, s) = out.map_err(|(i, e)| value_error(format!("twists row {i}: {e}")))?;
                let d = PyDict::new(py);
                d.set_item("wheel_rates", to_array(py, w, n, k, tw.single)?)?;
                d.set_item("steer_rates", to_array(py, s, n, k, tw.single)?)?;
                return Ok(d);
            }
        }
        let out = py.detach(|| {
            // Once per chunk into the robot's concrete kind (Robot::visit), so the kind's
            // inverse inlines into the row loop instead of dispatching on the kind per row.
            map_chunks2(n, k, sw, |start, w, s| {
                model.visit(InverseChunk {
                    start,
                    twists: &tv[3 * start..3 * start + 3 * (w.len() / k)],
                    steer: sv,
                    steer_single: s_single,
                    spin,
                    wheels: k,
                    steer_out: steered.then_some(set_point),
                    wheel_rates: w,
                    steer_values: s,
                })
            })
        });
        let (w, s) = out.map_err(|(i, e)| value_error(format!("twists row {i}: {e}")))?;
        let d = PyDict::new(py);
        d.set_item("wheel_rates", to_array(py, w, n, k, tw.single)?)?;
        if steered {
            let key = if set_point {
                "steer_angles"
            } else {
                "steer_rates"
            };
            d.set_item(key, to_array(py, s, n, k, tw.single)?)?;
        }
        Ok(d)
    }

    /// Forward kinematics: the robot-frame twist `(N, 3)` (`vx, vy` m/s, `yaw_rate` rad/s) of
    /// `wheel_rates` (`(N, k)` or `(k,)`, rad/s) at steer angles `steer` (rad) with steer
    /// rates `steer_rates` (rad/s; required for caster3, whose steering is part of the
    /// motion), assuming shell/ball spin `shell_spin` (rad/s; sphere-omni and ballbot).
    ///
    /// With `slip=True`, returns `(twists, slip_residual)`: the least-squares residual `(N,)`,
    /// m/s, of kinds with more wheel constraints than unknowns (as `forward --json`'s
    /// `slip_residual`; 0 when the rates are consistent).
    #[pyo3(signature = (wheel_rates, steer=None, steer_rates=None, shell_spin=None, slip=false))]
    #[allow(clippy::too_many_arguments)]
    fn forward<'py>(
        &self,
        py: Python<'py>,
        wheel_rates: &Bound<'py, PyAny>,
        steer: Option<&Bound<'py, PyAny>>,
        steer_rates: Option<&Bound<'py, PyAny>>,
        shell_spin: Option<f64>,
        slip: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let k = self.k();
        let kind = self.model.kind();
        let wr = rows(wheel_rates, "wheel_rates", k, "one rate per wheel, rad/s")?;
        let n = wr.rows;
        let spin = self.spin(shell_spin)?;
        let st = self.steer(steer, n, "wheel_rates")?;
        let sr = matching(
            steer_rates,
            "steer_rates",
            k,
            "steer rates, rad/s",
            n,
            "wheel_rates",
        )?;
        let rate_steered = self.model.steerable() && !kind.steer_is_set_point();
        match (&sr, rate_steered) {
            (None, true) => {
                return Err(value_error(format!(
                    "{} needs all {} motor rates: give steer_rates (N, {k}) (rad/s)",
                    kind.name(),
                    self.model.motors()
                )));
            }
            (Some(_), false) => {
                return Err(reject_for(
                    kind.name(),
                    "steer_rates",
                    "kinds with rate-driven steering (caster3)",
                ));
            }
            _ => {}
        }
        if slip && kind.has_vertical_spin() {
            return Err(value_error(format!(
                "slip: {} has as many wheel constraints as unknowns (no slip residual)",
                kind.name()
            )));
        }
        let wv = wr.values()?;
        let sv = st.as_ref().map(|s| s.values()).transpose()?;
        let rv = sr.as_ref().map(|s| s.values()).transpose()?;
        let (s1, r1) = (
            st.as_ref().is_some_and(|s| s.single),
            sr.as_ref().is_some_and(|s| s.single),
        );
        let model = &self.model;
        let out = py.detach(|| {
            map_rows2(n, 3, 1, |i, o, res| {
                let mut act = Actuators::from_wheel_rates(&wv[k * i..k * (i + 1)]);
                if let Some(g) = row(sv, k, s1, i) {
                    act.steer_angles[..k].copy_from_slice(g);
                }
                if let Some(g) = row(rv, k, r1, i) {
                    act.steer_rates[..k].copy_from_slice(g);
                }
                let m = model.forward_spin(&act, spin).map_err(|e| e.to_string())?;
                o.copy_from_slice(&[m.twist.vx, m.twist.vy, m.twist.yaw_rate]);
                res[0] = m.slip_residual;
                Ok(())
            })
        });
        let (tw, res) = out.map_err(|(i, e)| value_error(format!("wheel_rates row {i}: {e}")))?;
        let tw = to_array(py, tw, n, 3, wr.single)?;
        if slip {
            let res = if wr.single {
                res[0].into_pyobject(py)?.into_any()
            } else {
                numpy::PyArray1::from_vec(py, res).into_any()
            };
            Ok((tw, res).into_pyobject(py)?.into_any())
        } else {
            Ok(tw)
        }
    }

    /// The torque map (ballbot, omni, swerve), as `omnikin torques --json`: give exactly one of
    /// `model` (ballbot: model torques `Tx, Ty, Tz`, N·m, at body yaw `yaw` rad), `wrench`
    /// (omni, swerve: body wrench `fx, fy, mz`, N, N, N·m, robot frame) — both `(N, 3)` or
    /// `(3,)`, giving `wheel_torques` `(N, k)` N·m — or `wheels` (`(N, k)` wheel torques, N·m)
    /// giving `model_torques` or `wrench`. `steer`: swerve module angles, rad.
    #[pyo3(signature = (model=None, wrench=None, wheels=None, yaw=0.0, steer=None))]
    fn torques<'py>(
        &self,
        py: Python<'py>,
        model: Option<&Bound<'py, PyAny>>,
        wrench: Option<&Bound<'py, PyAny>>,
        wheels: Option<&Bound<'py, PyAny>>,
        yaw: f64,
        steer: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let kind = self.model.kind();
        let k = self.k();
        let Some(space) = self.model.torque_space() else {
            return Err(value_error(format!(
                "torques applies only to robot kinds with a torque map (ballbot, omni, swerve), \
                 not to {} ({})",
                kind.name(),
                self.desc.source_name
            )));
        };
        let (model, wrench, wheels) = (
            model.filter(|o| !o.is_none()),
            wrench.filter(|o| !o.is_none()),
            wheels.filter(|o| !o.is_none()),
        );
        if space == TorqueSpace::BallbotModel && wrench.is_some() {
            return Err(value_error(
                "ballbot torques are model torques: use model=[TX, TY, TZ], not wrench",
            ));
        }
        if space == TorqueSpace::BodyWrench && model.is_some() {
            return Err(value_error(format!(
                "{} torques balance a body wrench: use wrench=[FX, FY, MZ], not model",
                kind.name()
            )));
        }
        if space == TorqueSpace::BodyWrench && yaw != 0.0 {
            return Err(value_error(
                "yaw applies only to the ballbot's model torques",
            ));
        }
        if !yaw.is_finite() {
            return Err(value_error("yaw must be finite"));
        }
        let rot = move |g: [f64; 3], by: f64| {
            let (s, c) = by.sin_cos();
            [c * g[0] - s * g[1], s * g[0] + c * g[1], g[2]]
        };
        let ballbot = space == TorqueSpace::BallbotModel;
        let robot = &self.model;
        let d = PyDict::new(py);
        match (model.or(wrench), wheels) {
            (Some(g), None) => {
                let arg = if ballbot { "model" } else { "wrench" };
                let [c0, c1, c2] = space.components();
                let g = rows(g, arg, 3, &format!("{c0}, {c1}, {c2}"))?;
                let st = self.steer(steer, g.rows, arg)?;
                let (gv, sv, s1, n) = (
                    g.values()?,
                    st.as_ref().map(|s| s.values()).transpose()?,
                    st.as_ref().is_some_and(|s| s.single),
                    g.rows,
                );
                let out = py
                    .detach(|| {
                        map_rows(n, k, |i, o| {
                            let mut gi = [gv[3 * i], gv[3 * i + 1], gv[3 * i + 2]];
                            if ballbot {
                                gi = rot(gi, -yaw);
                            }
                            let mut steer = [0.0; MAX_WHEELS];
                            if let Some(s) = row(sv, k, s1, i) {
                                steer[..k].copy_from_slice(s);
                            }
                            let t = robot
                                .wheel_torques(gi, &steer)
                                .ok_or("no torque map")?
                                .map_err(|e| e.to_string())?;
                            o.copy_from_slice(&t[..k]);
                            Ok(())
                        })
                    })
                    .map_err(|(i, e)| value_error(format!("{arg} row {i}: {e}")))?;
                d.set_item("wheel_torques", to_array(py, out, n, k, g.single)?)?;
            }
            (None, Some(w)) => {
                let w = rows(w, "wheels", k, "one torque per wheel, N·m")?;
                let st = self.steer(steer, w.rows, "wheels")?;
                let (wv, sv, s1, n) = (
                    w.values()?,
                    st.as_ref().map(|s| s.values()).transpose()?,
                    st.as_ref().is_some_and(|s| s.single),
                    w.rows,
                );
                let out = py
                    .detach(|| {
                        map_rows(n, 3, |i, o| {
                            let mut tau = [0.0; MAX_WHEELS];
                            tau[..k].copy_from_slice(&wv[k * i..k * (i + 1)]);
                            let mut steer = [0.0; MAX_WHEELS];
                            if let Some(s) = row(sv, k, s1, i) {
                                steer[..k].copy_from_slice(s);
                            }
                            let g = robot
                                .generalized_forces(&tau, &steer)
                                .ok_or("no torque map")?
                                .map_err(|e| e.to_string())?;
                            o.copy_from_slice(&if ballbot { rot(g, yaw) } else { g });
                            Ok(())
                        })
                    })
                    .map_err(|(i, e)| value_error(format!("wheels row {i}: {e}")))?;
                d.set_item(space.name(), to_array(py, out, n, 3, w.single)?)?;
            }
            _ => {
                return Err(value_error(format!(
                    "give exactly one of {} or wheels (N, {k})",
                    if ballbot {
                        "model (N, 3)"
                    } else {
                        "wrench (N, 3)"
                    }
                )));
            }
        }
        Ok(d)
    }
}

/// A chunk of `robot.inverse`: the rows `start..` of the twists through the concrete kind's
/// [`KindModel::inverse_spin`] (the same call as [`Robot::inverse_spin`], without its per-row
/// dispatch), written into the chunk's outputs.
struct InverseChunk<'a> {
    /// First row of the chunk (for errors and the steer rows).
    start: usize,
    /// The chunk's twists, 3 per row.
    twists: &'a [f64],
    /// All steer rows (`k` per row), if given.
    steer: Option<&'a [f64]>,
    /// One steer row for every twist.
    steer_single: bool,
    /// Shell/ball spin, rad/s.
    spin: f64,
    /// `k`.
    wheels: usize,
    /// Steerable: `Some(true)` writes the steer angles (swerve set-points), `Some(false)` the
    /// steer rates (caster3).
    steer_out: Option<bool>,
    /// The chunk's wheel rates, `k` per row.
    wheel_rates: &'a mut [f64],
    /// The chunk's steer values, `k` per row (empty when not steerable).
    steer_values: &'a mut [f64],
}

impl KindVisitor<f64> for InverseChunk<'_> {
    type Output = Result<(), RowError>;

    fn visit<M: KindModel<f64>>(self, m: &M) -> Self::Output {
        let k = self.wheels;
        let mut act = Actuators::zero();
        for (j, t) in self.twists.chunks_exact(3).enumerate() {
            let i = self.start + j;
            if let Some(g) = row(self.steer, k, self.steer_single, i) {
                act.steer_angles[..k].copy_from_slice(g);
            }
            let r = m
                .inverse_spin(Twist2::new(t[0], t[1], t[2]), self.spin, &act)
                .map_err(|e| (i, e.to_string()))?;
            self.wheel_rates[j * k..(j + 1) * k].copy_from_slice(&r.wheel_rates[..k]);
            if let Some(set_point) = self.steer_out {
                let g = if set_point {
                    &r.steer_angles
                } else {
                    &r.steer_rates
                };
                self.steer_values[j * k..(j + 1) * k].copy_from_slice(&g[..k]);
            }
        }
        Ok(())
    }
}
