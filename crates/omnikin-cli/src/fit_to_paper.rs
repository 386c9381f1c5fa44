//! `omnikin reproduce sphere-2019 --fit-to-paper [--robot-file PATH]`: fits the dynamic
//! model's one fitted parameter, the centre-of-mass depth, to the paper's 1.4 radius ratio on
//! the 0.4 m/s circle, with every other `[dynamics]` value of the file as it is, and writes it
//! into that file: the `com_depth` line only, with the comment `# fitted: VALUE m to paper
//! 000's 0.4 m/s circle ratio 1.4 (omnikin reproduce sphere-2019 --fit-to-paper)`. The file is
//! an output like any other: replaced only with `--force`, through a temporary file renamed
//! over it, so an interrupted write leaves the old file.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin_sim::dynamics::sphere::{SphereDynamics, write_fitted_com_depth};
use omnikin_sim::reproduce as rp;

/// Largest relative gap between the model's ratio at the fitted depth and the paper's that is
/// still a fit: the bisection resolves 0.3 µm, so a larger gap means the ratio jumps inside
/// the bracket the scan found (a discontinuity, not a crossing) and nothing is written.
const FIT_TOLERANCE: f64 = 0.005;

/// The `sphere-omni` preset's file in the source tree this binary was built from
/// (`robots/sphere-omni.toml`): what `--fit-to-paper` fits without `--robot-file`. A rebuild
/// compiles the written value into the built-in preset.
pub fn preset_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../robots/sphere-omni.toml")
}

/// Fits `com_depth` for the robot file at `path` (plans sampled at `rate` Hz), writes it into
/// the file and prints what it wrote.
///
/// # Errors
/// The file cannot be read, parsed or written; it is not a `sphere-omni` file; it exists and
/// `--force` was not given; no depth in the search bracket reaches the paper's ratio (then
/// the file is left unchanged and the message gives the model's nearest ratio: a finding, not
/// something to force).
pub fn run(path: &Path, rate: f64) -> Result<()> {
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("--robot-file {shown}: cannot read"))?;
    let d = RobotDescription::from_toml_str(&text, &shown)?;
    let base =
        SphereDynamics::from_description(&d).with_context(|| format!("--robot-file {shown}"))?;
    crate::sim_report::say_floor_overrides(&d, &base);
    // Refuse before the search, not after it: the rules of any output file.
    crate::output::check_file("--robot-file", path)?;
    let series = rp::sphere_2019_series(&d, rate)?;
    let fit = rp::fit_to_paper(base, &series).with_context(|| {
        format!(
            "--fit-to-paper: fitting com_depth of {shown} to the paper's {} on {} ({shown} \
             is unchanged)",
            rp::PAPER_RADIUS_RATIOS[0].1,
            rp::DYNAMIC_FIT_SERIES
        )
    })?;
    let gap = (fit.achieved_radius_ratio / fit.target_radius_ratio - 1.0).abs();
    if gap > FIT_TOLERANCE {
        bail!(
            "--fit-to-paper: the radius ratio on {} jumps across {} near com_depth = {:.4} m \
             (model: {:.3}) with the other [dynamics] values of {shown}; {shown} is unchanged",
            fit.fitted_on,
            fit.target_radius_ratio,
            fit.value,
            fit.achieved_radius_ratio,
        );
    }
    let out = write_fitted_com_depth(&text, &fit, &shown)
        .with_context(|| format!("--robot-file {shown}"))?;
    crate::output::write_file("--robot-file", path, |w| {
        std::io::Write::write_all(w, out.as_bytes())
    })?;
    crate::outln!(
        "wrote com_depth = {:.6} m into {shown} ({}: radius ratio {:.4}, paper {}; {})",
        fit.value,
        fit.fitted_on,
        fit.achieved_radius_ratio,
        fit.target_radius_ratio,
        fit.method
    )?;
    Ok(())
}
