//! The fitted parameter written into a robot file's text: the `com_depth` line of the
//! `[dynamics]` table replaced by `com_depth = VALUE  # fitted: VALUE m to paper 000's 0.4 m/s
//! circle ratio 1.4 (omnikin reproduce sphere-2019 --fit-to-paper)`, every other byte of the
//! file kept; and that line's comment read back ([`com_depth_comment`]), so `reproduce` can say
//! which value it used and where it came from. The edited text is parsed back and must give
//! the fitted value, so a file this line editor cannot handle is refused, never written wrong.

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

/// Byte ranges (without line ends) of the `com_depth = …` lines of `text`'s `[dynamics]` table.
fn com_depth_lines(text: &str) -> Vec<(usize, usize)> {
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
    hits
}

/// The comment of the `[dynamics]` table's one `com_depth = …` line of `text` (after its `#`,
/// trimmed), `None` when there is no such line, more than one, or no comment on it.
pub fn com_depth_comment(text: &str) -> Option<String> {
    let [(a, b)] = com_depth_lines(text)[..] else {
        return None;
    };
    let (_, comment) = text[a..b].split_once('#')?;
    Some(comment.trim().to_string())
}

/// `text` (a `sphere-omni` robot file) with its `[dynamics]` table's `com_depth` line set to
/// `fit.value` and the comment `# fitted: VALUE m to paper 000's 0.4 m/s circle ratio 1.4
/// (omnikin reproduce sphere-2019 --fit-to-paper)` (series and target from `fit`); the same
/// fit gives the same text, byte for byte.
///
/// # Errors
/// [`DynamicsError::Input`] naming `dynamics.com_depth` when the `[dynamics]` table has no
/// `com_depth = …` line or more than one, or when the edited text does not parse back to the
/// fitted value (`source_name` names the file in a parse error's rule).
pub fn write_fitted_com_depth(
    text: &str,
    fit: &DynamicFit,
    source_name: &str,
) -> Result<String, DynamicsError> {
    let missing = DynamicsError::Input {
        what: "dynamics.com_depth",
        value: fit.value,
        rule: "the robot file needs exactly one `com_depth = …` line in its [dynamics] table \
               for --fit-to-paper to write the fitted value into",
    };
    let [(a, b)] = com_depth_lines(text)[..] else {
        return Err(missing);
    };
    let indent = &text[a..b][..text[a..b].len() - text[a..b].trim_start().len()];
    let speed = fit
        .fitted_on
        .strip_prefix("circle-")
        .unwrap_or(&fit.fitted_on);
    let line = format!(
        "{indent}{KEY} = {v:.6}  # fitted: {v:.6} m to paper 000's {speed} m/s circle ratio {} \
         (omnikin reproduce sphere-2019 --fit-to-paper)",
        fit.target_radius_ratio,
        v = fit.value,
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
        let out = write_fitted_com_depth(PRESET, &fit(0.0917), "t")
            .expect("the preset has a com_depth line");
        let (old, new): (Vec<_>, Vec<_>) = (PRESET.lines().collect(), out.lines().collect());
        assert_eq!(old.len(), new.len());
        let changed: Vec<_> = old.iter().zip(&new).filter(|(a, b)| a != b).collect();
        assert_eq!(changed.len(), 1, "{changed:?}");
        assert!(changed[0].0.starts_with("com_depth"));
        assert_eq!(
            *changed[0].1,
            "com_depth = 0.091700  # fitted: 0.091700 m to paper 000's 0.4 m/s circle ratio 1.4 \
             (omnikin reproduce sphere-2019 --fit-to-paper)"
        );
        assert_eq!(
            com_depth_comment(&out).as_deref(),
            Some(
                "fitted: 0.091700 m to paper 000's 0.4 m/s circle ratio 1.4 (omnikin reproduce \
                 sphere-2019 --fit-to-paper)"
            )
        );
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
        let out = write_fitted_com_depth(&text, &fit(0.09), "t").unwrap();
        assert!(out.contains("# com_depth = 1.0 in a comment\n"));
        assert!(out.contains("# com_depth = 2.0\n"));
        assert!(out.contains("\ncom_depth = 0.090000  # fitted: 0.090000 m"));
    }

    #[test]
    fn a_file_without_the_line_is_refused_naming_the_key() {
        let text: String = PRESET
            .lines()
            .filter(|l| !l.starts_with("com_depth"))
            .map(|l| format!("{l}\n"))
            .collect();
        let e = write_fitted_com_depth(&text, &fit(0.09), "t").unwrap_err();
        assert!(e.to_string().contains("dynamics.com_depth"), "{e}");
        assert_eq!(com_depth_comment(&text), None);
    }

    #[test]
    fn crlf_line_ends_are_kept() {
        let text = PRESET.replace('\n', "\r\n");
        let out = write_fitted_com_depth(&text, &fit(0.09), "t").unwrap();
        assert_eq!(out.matches("\r\n").count(), text.matches("\r\n").count());
        assert!(out.contains("--fit-to-paper)\r\n"), "{out}");
    }
}
