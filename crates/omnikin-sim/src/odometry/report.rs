//! The odometry run told in sentences — what `omnikin odometry` prints on stderr, for every
//! front end: [`fix_messages`] (each fix the gate rejected, each recovery, the initialisation,
//! named by the fixes file and line) and [`summary_lines`] (robot, samples, end pose, slip,
//! shell spin, the fixes' counters and estimated states, the event thresholds and events).

use omnikin::estimate::fusion::Recovery;

use super::{EventKind, FixRecord, FixResult, OdometryEnd, ThresholdSource, TiltReport, num};

/// One line per fix whose fate a user should hear of: `warning: FILE:LINE: …` for a fix
/// rejected as an outlier, `event: FILE:LINE: …` for a recovery or the fix that set the
/// initial pose. `file` names the fixes file as the user gave it.
pub fn fix_messages(file: &str, fixes: &[FixRecord]) -> Vec<String> {
    fixes
        .iter()
        .filter_map(|f| match f.result {
            FixResult::Rejected { mahalanobis2, gate } => Some(format!(
                "warning: {file}:{}: fix at t = {} s rejected as an outlier (d² = {mahalanobis2:.1} > {gate:.1})",
                f.line, f.t
            )),
            FixResult::Recovered { recovery, rejected } => Some(format!(
                "event: {file}:{}: fix at t = {} s ends {rejected} rejections in a row: {}",
                f.line,
                f.t,
                match recovery {
                    Recovery::Reinitialised => "they agree, pose re-initialised at it",
                    Recovery::Inflated => "they disagree, covariance inflated and fused",
                }
            )),
            FixResult::Initialised => Some(format!(
                "event: {file}:{}: fix at t = {} s sets the initial pose (no --initial-pose)",
                f.line, f.t
            )),
            _ => None,
        })
        .collect()
}

/// The run's summary in lines: the robot and heading source; samples, duration, path length
/// and end pose (m, rad); the largest slip residual (kinds fitted by least squares); the shell
/// or ball spin about the vertical and the platform tilt compensation; the fixes' counters,
/// recoveries and estimated gyro bias and wheel scale; the event thresholds (when one is not
/// at its default or events were found, each with its source: the flag, `[events]` of
/// `robot_source`, or the default) and one line per event.
pub fn summary_lines(end: &OdometryEnd, robot_source: &str) -> Vec<String> {
    let mut out = Vec::new();
    let sum = &end.summary;
    let pose = sum.end;
    out.push(format!(
        "robot: {} ({}); heading from {}",
        sum.robot,
        sum.kind,
        sum.heading_source.describe()
    ));
    out.push(format!(
        "{} samples over {:.3} s; odometry path {:.4} m; end pose x {:.4} m, y {:.4} m, heading {:.4} rad",
        sum.samples, sum.duration, sum.path_length, pose.x, pose.y, pose.heading
    ));
    if let Some((slip, at)) = sum.max_slip {
        out.push(format!(
            "largest slip residual {} m/s at t = {} s",
            if slip < 1e9 {
                format!("{slip:.4}")
            } else {
                num(slip)
            },
            num(at)
        ));
    }
    if let Some(spin) = sum.mean_shell_spin {
        out.push(format!(
            "mean shell/ball spin about the vertical (from wheels + IMU heading): {spin:.4} rad/s"
        ));
    }
    if let Some(s) = sum.shell_spin {
        let tilt = match s.tilt {
            TiltReport::Compensated {
                mean_tilt,
                max_tilt,
                tilt_std,
                spin_std,
                uncompensated,
            } => format!(
                "platform tilt compensated: mean {mean_tilt:.4} rad, max {max_tilt:.4} rad, \
                 ± {tilt_std:.4} rad (1σ, {spin_std:.4} rad/s of the bound); gyro_z alone \
                 gives {uncompensated:.4} rad/s"
            ),
            TiltReport::NotCompensated(why) => format!("platform tilt not compensated: {why}"),
        };
        out.push(format!(
            "shell/ball spin Ω3 {:.4} ± {:.4} rad/s (1σ; corrected for the gyro bias and wheel scale {}; {tilt})",
            s.mean,
            s.std,
            if s.from_fixes {
                "estimated from the fixes"
            } else {
                "within their priors, no fixes"
            }
        ));
    }
    if let Some(why) = sum.shell_spin_unobservable {
        out.push(format!("shell/ball spin Ω3 not observable: {why}"));
    }
    if let Some(f) = &sum.fixes {
        out.push(format!(
            "fixes: {} fused, {} rejected as outliers, {} arrived too late (> --max-latency), {} after the log; fused end differs from pure odometry by {:.4} m",
            f.accepted, f.rejected, f.too_late, f.after_log, f.fused_minus_odometry
        ));
        out.push(format!(
            "recoveries: {} re-initialised, {} inflated",
            f.reinitialised, f.inflated
        ));
        if let Some((b, sb)) = f.gyro_bias {
            out.push(format!("estimated gyro bias {b:.6} ± {sb:.6} rad/s (1σ)"));
        }
        if let Some((k, sk)) = f.wheel_scale {
            out.push(format!(
                "estimated wheel scale {k:.5} ± {sk:.5} (1σ; true/measured travel)"
            ));
        }
    }
    let rows = sum.event_thresholds.rows();
    // Said when it matters: a threshold not at its default, or events found with them.
    let all_default = rows.iter().all(|r| matches!(r.3, ThresholdSource::Default));
    if !all_default || !end.events.is_empty() {
        let thresholds: Vec<String> = rows
            .iter()
            .map(|(name, v, unit, source)| {
                format!(
                    "{name} {v} {unit} ({})",
                    match source {
                        ThresholdSource::Given => "--".to_string() + &name.replace('_', "-"),
                        ThresholdSource::RobotFile => format!("[events] of {robot_source}"),
                        ThresholdSource::Default => "default".to_string(),
                    }
                )
            })
            .collect();
        out.push(format!("event thresholds: {}", thresholds.join(", ")));
    }
    for e in &end.events {
        out.push(format!(
            "event: {} from t = {} s to {} s (peak {:.3} {})",
            e.kind.name(),
            e.start,
            e.end,
            e.peak,
            match e.kind {
                EventKind::Collision => "m/s² deceleration",
                EventKind::Slip => "rad/s or m/s",
            }
        ));
    }
    out
}

/// The events as the `--events` CSV: `kind,start,end,peak` and one row per event.
pub fn events_csv(end: &OdometryEnd) -> String {
    let mut text = String::from("kind,start,end,peak\n");
    for e in &end.events {
        text.push_str(&format!(
            "{},{},{},{}\n",
            e.kind.name(),
            e.start,
            e.end,
            e.peak
        ));
    }
    text
}
