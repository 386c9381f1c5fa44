//! [`MapError`]: what is wrong with a map, or why no path exists on it.

/// A map file that breaks a rule, a start or goal that the footprint cannot occupy, or a goal
/// that no collision-free path reaches. Displayed as `file:line: message`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{source_name}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct MapError {
    /// The map file (or the name the map was given).
    pub source_name: String,
    /// 1-based line in the map file of the table or value concerned, when one is.
    pub line: Option<usize>,
    /// What is wrong and the rule it breaks.
    pub message: String,
}

impl MapError {
    /// An error at `line` of `source_name`.
    pub(crate) fn at(source_name: &str, line: Option<usize>, message: String) -> Self {
        Self {
            source_name: source_name.to_string(),
            line,
            message,
        }
    }
}
