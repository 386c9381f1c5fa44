//! `omnikin evaluate --truth TRUTH.csv POSES.csv…`: pose estimates scored against ground
//! truth with the absolute trajectory error and the relative pose error
//! ([`omnikin_sim::pose_error`]); this file reads the files and prints, nothing more.

use std::path::Path;

use anyhow::{Result, bail};
use omnikin_sim::pose_error::{
    Alignment, ErrorStats, PoseErrorOptions, PoseErrorSummary, RpeDelta, evaluate_run, summarize,
};
use omnikin_sim::track::Track;
use serde_json::json;

use crate::sim_args::AlignArg;
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
        alignment: match a.align {
            AlignArg::None => Alignment::None,
            AlignArg::Se2 => Alignment::Se2,
        },
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
    let delta = match rpe_delta {
        RpeDelta::TimeS(t) => format!("Δ = {t} s"),
        RpeDelta::DistanceM(d) => format!("Δ = {d} m"),
    };
    let align = match options.alignment {
        Alignment::None => "none (the estimate's start pose is known)",
        Alignment::Se2 => "se2 (least-squares rotation and translation)",
    };
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

/// `rms R, mean M, median D, max X` in mm or mrad.
fn stats(s: &Option<ErrorStats>, unit: &str) -> String {
    match s {
        Some(s) => format!(
            "rms {:.1}, mean {:.1}, median {:.1}, max {:.1} {unit}",
            1e3 * s.rms,
            1e3 * s.mean,
            1e3 * s.median,
            1e3 * s.max
        ),
        None => "—".into(),
    }
}

/// Two lines per run: ATE (and heading error), RPE.
fn print_summary(name: &str, s: &PoseErrorSummary) -> Result<()> {
    crate::outln!(
        "{name}: {} samples; ATE {}; heading error {}",
        s.samples,
        stats(&s.ate_m, "mm"),
        stats(&s.heading_error_rad, "mrad")
    )?;
    crate::outln!(
        "{name}: RPE over {} pairs: translation {}; rotation {}",
        s.rpe_translation_m.map_or(0, |r| r.count),
        stats(&s.rpe_translation_m, "mm"),
        stats(&s.rpe_rotation_rad, "mrad")
    )
}
