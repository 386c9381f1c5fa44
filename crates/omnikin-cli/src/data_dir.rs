//! Where `omnikin reproduce` writes when no `--out` is given: the platform's per-user data
//! directory, never the current directory (which is often a git work tree).

use std::path::PathBuf;

/// The default output directory of `omnikin reproduce EXPERIMENT`:
/// `$XDG_DATA_HOME/omnikin/reproduce-EXPERIMENT` if `XDG_DATA_HOME` is set (any platform),
/// else `~/Library/Application Support/omnikin/…` on macOS, `%LOCALAPPDATA%\omnikin\…` on
/// Windows, `~/.local/share/omnikin/…` elsewhere, and the system temporary directory
/// (`$TMPDIR/omnikin/…`) when no home directory is known.
pub fn reproduce_default(experiment: &str) -> PathBuf {
    data_home()
        .join("omnikin")
        .join(format!("reproduce-{experiment}"))
}

fn var(name: &str) -> Option<PathBuf> {
    std::env::var_os(name)
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .filter(|p| p.is_absolute())
}

fn data_home() -> PathBuf {
    if let Some(p) = var("XDG_DATA_HOME") {
        return p;
    }
    if cfg!(windows) {
        if let Some(p) = var("LOCALAPPDATA") {
            return p;
        }
    } else if let Some(home) = var("HOME") {
        return if cfg!(target_os = "macos") {
            home.join("Library").join("Application Support")
        } else {
            home.join(".local").join("share")
        };
    }
    std::env::temp_dir()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_absolute_and_named_after_the_experiment() {
        let p = reproduce_default("sphere-2019");
        assert!(p.is_absolute(), "{}", p.display());
        assert!(
            p.ends_with("omnikin/reproduce-sphere-2019"),
            "{}",
            p.display()
        );
    }
}
