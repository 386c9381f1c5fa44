//! The fitted parameter written into a robot file's text: the `com_depth` line of the
//! `[dynamics]` table replaced by `com_depth = VALUE  # fitted …` (what it was fitted on, to
//! what, when), every other byte of the file kept. The edited text is parsed back and must
//! give the fitted value, so a file this line editor cannot handle is refused, never written
//! wrong.

use omnikin::description::RobotDescription;

use super::{DynamicFit, DynamicsError, SphereDynamics};

/// The `[dynamics]` key the fit writes.
const KEY: &str = "com_depth";

/// `true` when `line` (without its line end) assigns `key`: `key`, optional blanks, `=`.
fn assigns(line: &str, key: &str) -> bool {
    line.trim_start()
        .strip_prefix(key)
        .is_some_and(|rest| rest.trim_start().starts_with('='))
}

/// The table a header line opens (`[dynamics]` → `dynamics`), `None` for other lines.
fn header(line: &str) -> Option<&str> {
    let t = line.trim();
    let t = t.split('#').next().unwrap_or("").trim_end();
    t.strip_prefix('[')?.strip_suffix(']').map(str::trim)
}

/// `text` (a `sphere-omni` robot file) with its `[dynamics]` table's `com_depth` line set to
/// `fit.value` and a comment naming the series, the target, the model's achieved ratio and
/// `when` (a UTC date-time, given by the caller so the result is reproducible).
///
/// # Errors
/// [`DynamicsError::Input`] naming `dynamics.com_depth` when the `[dynamics]` table has no
/// `com_depth = …` line or more than one, or when the edited text does not parse back to the
/// fitted value (`source_name` names the file in a parse error's rule).
pub fn write_fitted_com_depth(
    text: &str,
    fit: &DynamicFit,
    when: &str,
    source_name: &str,
) -> Result<String, DynamicsError> {
    let missing = DynamicsError::Input {
        what: "dynamics.com_depth",
        value: fit.value,
        rule: "the robot file needs exactly one `com_depth = …` line in its [dynamics] table \
               for --fit-to-paper to write the fitted value into",
    };
    let mut table = "";
    let mut hits = Vec::new();
    let mut start = 0;
    for line in text.split_inclusive('\n') {
        let body = line.trim_end_matches(['\n', '\r']);
        if let Some(t) = header(body) {
            table = t;
        } else if table == "dynamics" && assigns(body, KEY) {
            hits.push((start, start + body.len()));
        }
        start += line.len();
    }
    let [(a, b)] = hits[..] else {
        return Err(missing);
    };
    let indent = &text[a..b][..text[a..b].len() - text[a..b].trim_start().len()];
    let line = format!(
        "{indent}{KEY} = {:.6}  # fitted by `omnikin reproduce sphere-2019 --fit-to-paper` on {} to radius ratio {} (model: {:.4}), {when}",
        fit.value, fit.fitted_on, fit.target_radius_ratio, fit.achieved_radius_ratio
    );
    let out = format!("{}{line}{}", &text[..a], &text[b..]);
    let parsed = RobotDescription::from_toml_str(&out, source_name)
        .ok()
        .and_then(|d| SphereDynamics::from_description(&d).ok());
    match parsed {
        Some(p) if (p.com_depth - fit.value).abs() <= 1e-6 => Ok(out),
        _ => Err(missing),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PRESET: &str = include_str!("../../../../../robots/sphere-omni.toml");

    fn fit(value: f64) -> DynamicFit {
        DynamicFit {
            name: "com_depth",
            value,
            fitted_on: "circle-0.4".into(),
            target_radius_ratio: 1.4,
            achieved_radius_ratio: 1.4003,
            method: String::new(),
        }
    }

    #[test]
    fn only_the_com_depth_line_changes_and_it_parses_back() {
        let out = write_fitted_com_depth(PRESET, &fit(0.0917), "2026-12-04T16:00:00Z", "t")
            .expect("the preset has a com_depth line");
        let (old, new): (Vec<_>, Vec<_>) = (PRESET.lines().collect(), out.lines().collect());
        assert_eq!(old.len(), new.len());
        let changed: Vec<_> = old.iter().zip(&new).filter(|(a, b)| a != b).collect();
        assert_eq!(changed.len(), 1, "{changed:?}");
        assert!(changed[0].0.starts_with("com_depth"));
        assert!(changed[0].1.contains("0.091700  # fitted by"));
        assert!(changed[0].1.contains("2026-12-04T16:00:00Z"));
        let d = RobotDescription::from_toml_str(&out, "t").unwrap();
        let p = SphereDynamics::from_description(&d).unwrap();
        assert!((p.com_depth - 0.0917).abs() < 1e-12);
    }

    #[test]
    fn a_commented_out_com_depth_is_not_touched() {
        let text = PRESET.replace(
            "[limits]",
            "# com_depth = 1.0 in a comment\n[limits]\n# com_depth = 2.0",
        );
        let out = write_fitted_com_depth(&text, &fit(0.09), "now", "t").unwrap();
        assert!(out.contains("# com_depth = 1.0 in a comment\n"));
        assert!(out.contains("# com_depth = 2.0\n"));
        assert!(out.contains("\ncom_depth = 0.090000  # fitted"));
    }

    #[test]
    fn a_file_without_the_line_is_refused_naming_the_key() {
        let text: String = PRESET
            .lines()
            .filter(|l| !l.starts_with("com_depth"))
            .map(|l| format!("{l}\n"))
            .collect();
        let e = write_fitted_com_depth(&text, &fit(0.09), "now", "t").unwrap_err();
        assert!(e.to_string().contains("dynamics.com_depth"), "{e}");
    }

    #[test]
    fn crlf_line_ends_are_kept() {
        let text = PRESET.replace('\n', "\r\n");
        let out = write_fitted_com_depth(&text, &fit(0.09), "now", "t").unwrap();
        assert_eq!(out.matches("\r\n").count(), text.matches("\r\n").count());
        assert!(out.contains(", now\r\n"), "{out}");
    }
}
