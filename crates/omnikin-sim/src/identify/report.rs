//! What an identification reports, the same for every front end (`omnikin identify`,
//! `omnikin.identify`): the table of parameter, prior, estimate, 1σ and change with the
//! residual RMS, and the same as one JSON object.

use super::{FitStatus, Identified, ParameterEstimate};

/// The table `omnikin identify` prints: a header, one line per parameter (a held one with its
/// reason instead of an estimate), and a closing line with the residual RMS, the number of
/// residuals and the condition number. Lines end with `\n`.
pub fn table(id: &Identified) -> String {
    let mut out = format!(
        "{:<26} {:>12} {:>12} {:>10} {:>11}  unit\n",
        "parameter", "prior", "estimate", "1σ", "change"
    );
    for e in id.geometry.iter().chain(&id.gyro).chain(&id.dynamics) {
        let line = match &e.status {
            FitStatus::Fitted => format!(
                "{:<26} {:>12.6} {:>12.6} {:>10.2e} {:>+11.2e}  {}",
                e.name,
                e.prior,
                e.value,
                e.sigma,
                e.value - e.prior,
                e.unit
            ),
            FitStatus::Fixed(why) => {
                format!("{:<26} {:>12.6} {:>12}  held: {why}", e.name, e.prior, "—")
            }
        };
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out.push_str(&format!(
        "residual RMS: position {:.3e} m{}{}; {} residuals, condition {:.1}\n",
        id.position_rms,
        id.heading_rms
            .map(|h| format!(", heading {h:.3e} rad"))
            .unwrap_or_default(),
        id.gyro_rms
            .map(|g| format!(", gyro windows {g:.3e} rad"))
            .unwrap_or_default(),
        id.residuals,
        id.condition
    ));
    out
}

fn estimate(e: &ParameterEstimate) -> serde_json::Value {
    let (status, reason) = match &e.status {
        FitStatus::Fitted => ("fitted", None),
        FitStatus::Fixed(why) => ("held", Some(why.clone())),
    };
    serde_json::json!({
        "name": e.name, "unit": e.unit, "prior": e.prior, "value": e.value,
        "sigma": e.sigma, "status": status, "reason": reason,
    })
}

/// The result as one JSON object: `parameters` (each with `name`, `unit`, `prior`, `value`,
/// `sigma`, `status` `fitted`/`held` and the `reason` when held; sphere-omni's
/// `dynamics.com_depth`, `dynamics.rolling_resistance` and `dynamics.pivot_friction` among
/// them), the rocking fitted after each stop (`rocking`), the spin's decay fitted after each
/// stop of a spin in place (`spin_decay`: deceleration and its 1σ in rad/s², time to rest in s,
/// null when the spin did not come to rest in the window), the residual RMS
/// (`position_rms_m`, `heading_rms_rad`, `gyro_window_rms_rad`), `condition`, `residuals`,
/// and per run its files and position residual RMS before and after the fit (`runs`).
pub fn json(id: &Identified) -> serde_json::Value {
    serde_json::json!({
        "parameters": id.geometry.iter().chain(&id.gyro).chain(&id.dynamics).map(estimate).collect::<Vec<_>>(),
        "rocking": id.rocking.iter().map(|r| serde_json::json!({
            "imu": r.file, "t0_s": r.t0, "duration_s": r.duration,
            "natural_rad_s": r.natural.0, "natural_sigma_rad_s": r.natural.1,
            "damped_rad_s": r.damped.0, "decay_1_s": r.decay.0,
            "amplitude_rad_s": r.amplitude, "residual_rms_rad_s": r.residual_rms,
        })).collect::<Vec<_>>(),
        "spin_decay": id.spin_decay.iter().map(|d| serde_json::json!({
            "gyro": d.file, "stop_s": d.stop, "t0_s": d.t0, "duration_s": d.duration,
            "initial_rate_rad_s": d.initial_rate,
            "deceleration_rad_s2": d.deceleration.0, "deceleration_sigma_rad_s2": d.deceleration.1,
            "to_rest_s": d.to_rest, "offset_rad_s": d.offset, "samples": d.samples,
            "residual_rms_rad_s": d.residual_rms,
        })).collect::<Vec<_>>(),
        "position_rms_m": id.position_rms,
        "heading_rms_rad": id.heading_rms,
        "gyro_window_rms_rad": id.gyro_rms,
        "condition": id.condition,
        "residuals": id.residuals,
        "runs": id.series.iter().map(|r| serde_json::json!({
            "encoders": r.encoders, "reference": r.reference,
            "position_rms_before_m": r.before.position_rms(),
            "position_rms_after_m": r.after.position_rms(),
        })).collect::<Vec<_>>(),
    })
}
