//! `omnikin evaluate --truth TRUTH.csv POSES.csv…`: pose estimates scored against ground
//! truth with the absolute trajectory error and the relative pose error
//! ([`omnikin_sim::pose_error`]); this file reads the files and prints, nothing more.

use std::path::Path;

use anyhow::{Result, bail};
use omnikin_sim::pose_error::{
    PoseErrorOptions, PoseErrorSummary, RpeDelta, evaluate_run, summarize,
};
use omnikin_sim::track::Track;
use serde_json::json;

use crate::sim_args::EvaluateArgs;

/// Runs `evaluate --truth`.
pub fn run(a: &EvaluateArgs, truth_path: &Path) -> Result<()> {
    let rpe_delta = match (a.rpe_time, a.rpe_distance) {
        (_, Some(d)) if d > 0.0 => RpeDelta::DistanceM(d),
        (_, Some(d)) => bail!("--rpe-distance must be > 0 m (got {d})"),
        (Some(t), None) if t > 0.0 => RpeDelta::TimeS(t),
        (Some(t), None) => bail!("--rpe-time must be > 0 s (got {t})"),
        (None, None) => RpeDelta::default(),
    };
    let options = PoseErrorOptions {
        alignment: a.align,
        rpe_delta,
    };
    let truth = Track::load(truth_path)?;
    let mut runs = Vec::with_capacity(a.tracks.len());
    for f in &a.tracks {
        let est = Track::load(f)?;
        let r = evaluate_run(&truth, &est, &options).map_err(|e| {
            anyhow::anyhow!("{} against {}: {e}", f.display(), truth_path.display())
        })?;
        if est.heading.is_none() || truth.heading.is_none() {
            crate::errln!(
                "warning: {}: no RPE and no heading error: {} has no heading column",
                f.display(),
                if truth.heading.is_none() {
                    truth_path.display()
                } else {
                    f.display()
                }
            );
        }
        if r.outside_truth > 0 {
            crate::errln!(
                "warning: {}: {} of {} samples lie outside the truth's time span \
                 ({} to {} s) and are not scored",
                f.display(),
                r.outside_truth,
                est.t.len(),
                truth.t[0],
                truth.t[truth.t.len() - 1]
            );
        }
        runs.push(r);
    }
    let overall = summarize(&runs);
    let (delta, align) = (rpe_delta.describe(), options.alignment.describe());
    if a.json {
        let per_run: Vec<_> = a
            .tracks
            .iter()
            .zip(&runs)
            .map(|(f, r)| {
                let mut j = serde_json::to_value(r.summary()).unwrap_or_default();
                j["file"] = json!(f.display().to_string());
                j["alignment"] = serde_json::to_value(r.alignment).unwrap_or_default();
                j
            })
            .collect();
        let j = json!({
            "truth": truth_path.display().to_string(),
            "alignment": options.alignment,
            "rpe_delta": options.rpe_delta,
            "runs": per_run,
            "overall": overall,
        });
        crate::outln!("{}", serde_json::to_string_pretty(&j)?)?;
        return Ok(());
    }
    crate::outln!(
        "truth {} ({} samples, t {} to {} s); alignment {align}; RPE {delta}",
        truth_path.display(),
        truth.t.len(),
        truth.t[0],
        truth.t[truth.t.len() - 1]
    )?;
    for (f, r) in a.tracks.iter().zip(&runs) {
        print_summary(&f.display().to_string(), &r.summary())?;
    }
    if runs.len() > 1 {
        print_summary(&format!("overall ({} runs)", runs.len()), &overall)?;
    }
    Ok(())
}

/// Two lines per run: ATE (and heading error), RPE ([`PoseErrorSummary::lines`]).
fn print_summary(name: &str, s: &PoseErrorSummary) -> Result<()> {
    for line in s.lines(name) {
        crate::outln!("{line}")?;
    }
    Ok(())
}
