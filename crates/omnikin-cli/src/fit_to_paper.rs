//! `omnikin reproduce sphere-2019 --fit-to-paper --robot-file PATH`: fits the dynamic model's
//! one fitted parameter, the centre-of-mass depth, to the paper's 1.4 radius ratio on the
//! 0.4 m/s circle, with every other `[dynamics]` value of the file as it is, and writes it into
//! that file (the `com_depth` line only, with a comment saying on what, to what and when;
//! a temporary file beside it renamed over it, so an interrupted write leaves the old file).

use std::io::Write;
use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin_sim::dynamics::sphere::{SphereDynamics, write_fitted_com_depth};
use omnikin_sim::reproduce as rp;

/// Largest relative gap between the model's ratio at the fitted depth and the paper's that is
/// still a fit: the bisection itself resolves 0.4 µm, so a larger gap means the target lies
/// outside the search bracket and nothing is written.
const FIT_TOLERANCE: f64 = 0.005;

/// The proleptic Gregorian UTC date-time of `secs` since the Unix epoch, `YYYY-MM-DDTHH:MMZ`
/// (days to civil date: H. Hinnant, "chrono-Compatible Low-Level Date Algorithms").
fn utc(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let (hh, mm) = ((secs % 86_400) / 3600, (secs % 3600) / 60);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}T{hh:02}:{mm:02}Z")
}

/// Fits `com_depth` for the robot file at `path` (plans sampled at `rate` Hz), writes it into
/// the file and prints what it wrote.
///
/// # Errors
/// The file cannot be read, parsed or written; it is not a `sphere-omni` file; no depth in
/// the search bracket reaches the paper's ratio (then the file is left unchanged and the
/// message gives the model's nearest ratio: a finding, not something to force).
pub fn run(path: &Path, rate: f64) -> Result<()> {
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("--robot-file {shown}: cannot read"))?;
    let d = RobotDescription::from_toml_str(&text, &shown)?;
    let base =
        SphereDynamics::from_description(&d).with_context(|| format!("--robot-file {shown}"))?;
    let series = rp::sphere_2019_series(&d, rate)?;
    let fit = rp::fit_to_paper(base, &series).context("fitting the centre-of-mass depth")?;
    let gap = (fit.achieved_radius_ratio / fit.target_radius_ratio - 1.0).abs();
    if gap > FIT_TOLERANCE {
        bail!(
            "--fit-to-paper: no com_depth in the search bracket gives {} on {} with the other \
             [dynamics] values of {shown} (nearest: {:.3} at com_depth = {:.4} m); {shown} is \
             unchanged",
            fit.target_radius_ratio,
            fit.fitted_on,
            fit.achieved_radius_ratio,
            fit.value
        );
    }
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |t| t.as_secs());
    let out = write_fitted_com_depth(&text, &fit, &utc(secs), &shown)
        .with_context(|| format!("--robot-file {shown}"))?;
    let name = path
        .file_name()
        .with_context(|| format!("--robot-file {shown}: not a file name"))?;
    let mut tmp_name = name.to_os_string();
    tmp_name.push(".fit-tmp");
    let tmp = path.with_file_name(tmp_name);
    let write = || -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(out.as_bytes())?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    };
    if let Err(e) = write() {
        let _ = std::fs::remove_file(&tmp);
        return Err(e).with_context(|| format!("--robot-file {shown}: cannot write"));
    }
    println!(
        "wrote com_depth = {:.6} m into {shown} ({}: radius ratio {:.4}, paper {})",
        fit.value, fit.fitted_on, fit.achieved_radius_ratio, fit.target_radius_ratio
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::utc;

    #[test]
    fn utc_dates_match_known_instants() {
        assert_eq!(utc(0), "1970-01-01T00:00Z");
        assert_eq!(utc(951_782_400), "2000-02-29T00:00Z");
        assert_eq!(utc(1_796_402_040), "2026-12-04T16:34Z");
    }
}
