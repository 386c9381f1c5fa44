//! Keyword options of `plan`, `simulate` and `evaluate`, read with the CLI's defaults and value
//! checks; an option a command does not know is an error that lists the ones it does.

use std::collections::BTreeSet;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::value_error;

/// The keyword options of one call; each read marks the name as known.
pub struct Options<'py> {
    dict: Option<Bound<'py, PyDict>>,
    known: BTreeSet<&'static str>,
}

impl<'py> Options<'py> {
    /// The options of a call (`None`: none given).
    pub fn new(dict: Option<&Bound<'py, PyDict>>) -> Self {
        Options {
            dict: dict.cloned(),
            known: BTreeSet::new(),
        }
    }

    /// The raw value of `name`, if given and not `None`.
    pub fn any(&mut self, name: &'static str) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.known.insert(name);
        match &self.dict {
            Some(d) => Ok(d.get_item(name)?.filter(|v| !v.is_none())),
            None => Ok(None),
        }
    }

    /// Whether `name` was given (not `None`).
    pub fn given(&mut self, name: &'static str) -> PyResult<bool> {
        Ok(self.any(name)?.is_some())
    }

    /// A finite number, if given.
    pub fn opt_f64(&mut self, name: &'static str) -> PyResult<Option<f64>> {
        match self.any(name)? {
            None => Ok(None),
            Some(v) => {
                let x: f64 = v
                    .extract()
                    .map_err(|_| value_error(format!("{name}: expected a number, got {v}")))?;
                if !x.is_finite() {
                    return Err(value_error(format!("{name}: must be finite, got {x}")));
                }
                Ok(Some(x))
            }
        }
    }

    /// A finite number (default `default`).
    pub fn f64(&mut self, name: &'static str, default: f64) -> PyResult<f64> {
        Ok(self.opt_f64(name)?.unwrap_or(default))
    }

    /// A finite number > 0, if given (the CLI's `positive`).
    pub fn opt_positive(&mut self, name: &'static str) -> PyResult<Option<f64>> {
        match self.opt_f64(name)? {
            Some(v) if v <= 0.0 => Err(value_error(format!("{name}: must be > 0, got {v}"))),
            v => Ok(v),
        }
    }

    /// A finite number > 0 (default `default`).
    pub fn positive(&mut self, name: &'static str, default: f64) -> PyResult<f64> {
        Ok(self.opt_positive(name)?.unwrap_or(default))
    }

    /// A flag (default false).
    pub fn flag(&mut self, name: &'static str) -> PyResult<bool> {
        match self.any(name)? {
            None => Ok(false),
            Some(v) => v
                .extract()
                .map_err(|_| value_error(format!("{name}: expected True or False, got {v}"))),
        }
    }

    /// A string, if given.
    pub fn opt_str(&mut self, name: &'static str) -> PyResult<Option<String>> {
        match self.any(name)? {
            None => Ok(None),
            Some(v) => {
                // Paths (pathlib) are accepted where a string is.
                let s = v.str()?.to_string();
                Ok(Some(s))
            }
        }
    }

    /// One of `choices` (the CLI's value names; `_` may stand for `-`), if given.
    pub fn choice(
        &mut self,
        name: &'static str,
        choices: &[&'static str],
    ) -> PyResult<Option<&'static str>> {
        match self.opt_str(name)? {
            None => Ok(None),
            Some(s) => {
                let s = s.replace('_', "-");
                choices
                    .iter()
                    .find(|c| **c == s)
                    .copied()
                    .map(Some)
                    .ok_or_else(|| {
                        value_error(format!(
                            "{name}: {s:?} is not one of {}",
                            choices.join(", ")
                        ))
                    })
            }
        }
    }

    /// A list of finite numbers, if given.
    pub fn list(&mut self, name: &'static str) -> PyResult<Option<Vec<f64>>> {
        match self.any(name)? {
            None => Ok(None),
            Some(v) => {
                let l: Vec<f64> = v.extract().map_err(|_| {
                    value_error(format!("{name}: expected a list of numbers, got {v}"))
                })?;
                if let Some((i, x)) = l.iter().enumerate().find(|(_, x)| !x.is_finite()) {
                    return Err(value_error(format!(
                        "{name}: item {}: must be finite, got {x}",
                        i + 1
                    )));
                }
                Ok(Some(l))
            }
        }
    }

    /// Fails on any option that was not read.
    pub fn finish(self, what: &str) -> PyResult<()> {
        if let Some(d) = &self.dict {
            for k in d.keys() {
                let k = k.str()?.to_string();
                if !self.known.contains(k.as_str()) {
                    return Err(value_error(format!(
                        "{what}: unknown option {k:?} (options: {})",
                        self.known.iter().copied().collect::<Vec<_>>().join(", ")
                    )));
                }
            }
        }
        Ok(())
    }
}
