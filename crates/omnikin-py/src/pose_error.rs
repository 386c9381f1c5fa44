//! `omnikin.pose_error`: estimates scored against ground truth with the absolute trajectory
//! error and the relative pose error, as `omnikin evaluate --truth` (`omnikin_sim::pose_error`,
//! Sturm et al. 2012); files or columns in, the per-run and pooled figures out as JSON.

use numpy::PyReadonlyArray1;
use omnikin_sim::pose_error::{Alignment, PoseErrorOptions, RpeDelta, evaluate_run, summarize};
use omnikin_sim::track::Track;
use pyo3::prelude::*;
use serde_json::json;

use crate::arrays::value_error;

/// A trajectory from Python: a `t,x,y[,heading]` CSV path, or `(name, t, x, y, heading)`
/// columns (float64, 1-D; `heading` may be `None`).
#[derive(FromPyObject)]
pub enum TrackArg<'py> {
    /// A CSV file.
    Path(String),
    /// Columns: a name for messages, then t, x, y and the optional heading.
    Columns(
        String,
        PyReadonlyArray1<'py, f64>,
        PyReadonlyArray1<'py, f64>,
        PyReadonlyArray1<'py, f64>,
        Option<PyReadonlyArray1<'py, f64>>,
    ),
}

impl TrackArg<'_> {
    /// The track, checked as a CSV file is; its name for messages.
    pub(crate) fn load(&self) -> PyResult<(Track, String)> {
        let as_slice = |a: &PyReadonlyArray1<'_, f64>| -> PyResult<Vec<f64>> {
            Ok(a.as_array().iter().copied().collect())
        };
        match self {
            TrackArg::Path(p) => Ok((
                Track::load(std::path::Path::new(p)).map_err(|e| value_error(e.to_string()))?,
                p.clone(),
            )),
            TrackArg::Columns(name, t, x, y, h) => {
                let h = h.as_ref().map(as_slice).transpose()?;
                let track = Track::from_columns(
                    name,
                    &as_slice(t)?,
                    &as_slice(x)?,
                    &as_slice(y)?,
                    h.as_deref(),
                )
                .map_err(|e| value_error(e.to_string()))?;
                Ok((track, name.clone()))
            }
        }
    }
}

/// `omnikin.pose_error`: JSON `{"alignment", "rpe_delta", "runs": [...], "overall"}`.
#[pyfunction]
#[pyo3(signature = (truth, estimates, align="none", rpe_time=None, rpe_distance=None))]
pub fn pose_error_native(
    py: Python<'_>,
    truth: TrackArg<'_>,
    estimates: Vec<TrackArg<'_>>,
    align: &str,
    rpe_time: Option<f64>,
    rpe_distance: Option<f64>,
) -> PyResult<String> {
    let alignment = match align {
        "none" => Alignment::None,
        "se2" => Alignment::Se2,
        other => {
            return Err(value_error(format!(
                "align: \"{other}\" is not an alignment; use \"none\" or \"se2\""
            )));
        }
    };
    let rpe_delta = match (rpe_time, rpe_distance) {
        (Some(_), Some(_)) => {
            return Err(value_error(
                "give rpe_time (s) or rpe_distance (m), not both",
            ));
        }
        (_, Some(d)) if d.is_finite() && d > 0.0 => RpeDelta::DistanceM(d),
        (_, Some(d)) => {
            return Err(value_error(format!("rpe_distance must be > 0 m (got {d})")));
        }
        (Some(t), None) if t.is_finite() && t > 0.0 => RpeDelta::TimeS(t),
        (Some(t), None) => return Err(value_error(format!("rpe_time must be > 0 s (got {t})"))),
        (None, None) => RpeDelta::default(),
    };
    if estimates.is_empty() {
        return Err(value_error("estimates: give at least one trajectory"));
    }
    let options = PoseErrorOptions {
        alignment,
        rpe_delta,
    };
    let (truth, truth_name) = truth.load()?;
    let loaded = estimates
        .iter()
        .map(TrackArg::load)
        .collect::<PyResult<Vec<_>>>()?;
    let runs = py.detach(|| {
        loaded
            .iter()
            .map(|(est, name)| {
                evaluate_run(&truth, est, &options)
                    .map_err(|e| format!("{name} against {truth_name}: {e}"))
            })
            .collect::<Result<Vec<_>, String>>()
    });
    let runs = runs.map_err(value_error)?;
    let per_run: Vec<_> = loaded
        .iter()
        .zip(&runs)
        .map(|((_, name), r)| {
            let mut j = serde_json::to_value(r.summary()).unwrap_or_default();
            j["name"] = json!(name);
            j["alignment"] = serde_json::to_value(r.alignment).unwrap_or_default();
            j
        })
        .collect();
    Ok(json!({
        "alignment": alignment,
        "rpe_delta": rpe_delta,
        "runs": per_run,
        "overall": summarize(&runs),
    })
    .to_string())
}
