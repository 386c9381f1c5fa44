//! Errors of the planner: what was asked, what is wrong, and by how much.

use crate::robot::Quantity;

/// A motor limit a requested (fixed) timing would break: the worst excess along the plan.
///
/// Displays as `wheel 2 needs 14.10 rad/s at t = 1.23 s, limit 12 rad/s (+17.5 %)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Violation {
    /// Which limit.
    pub quantity: Quantity,
    /// Motor number, 1-based (wheel or steer motor 1, 2, 3).
    pub motor: usize,
    /// The magnitude the plan needs (rad/s or rad/s²).
    pub needed: f64,
    /// When, s from the start of the plan.
    pub t: f64,
    /// The robot file's limit (same unit).
    pub limit: f64,
}

impl Violation {
    /// Excess over the limit, percent.
    pub fn excess_pct(&self) -> f64 {
        (self.needed / self.limit - 1.0) * 100.0
    }
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let q = self.quantity;
        write!(
            f,
            "{} {} needs {:.2} {} at t = {:.2} s, limit {} {} (+{:.1} %; limits.{})",
            q.motor(),
            self.motor,
            self.needed,
            q.unit(),
            self.t,
            self.limit,
            q.unit(),
            self.excess_pct(),
            q.key()
        )
    }
}

/// A number for a message: plain when it reads well, `1e-9` / `1.5e300` style when tiny or
/// huge (so a value of 1e300 does not print as 301 digits).
pub(crate) fn num(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && a.is_finite() && !(1e-3..1e6).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Everything that can go wrong while planning.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlanningError {
    /// The path cannot be built (waypoints, fillets, splines); the message names the waypoint,
    /// leg or segment and the rule.
    #[error("invalid path: {0}")]
    InvalidPath(String),
    /// A parameter is out of range.
    #[error("{name} = {}: {rule}", num(*value))]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What is allowed.
        rule: &'static str,
    },
    /// A parameter is finite but outside its plausible range (see [`crate::limits`]).
    #[error(
        "{name} = {} {unit} is outside the plausible range [{}, {}] {unit} (omnikin_plan::limits)",
        num(*value), num(*min), num(*max)
    )]
    OutOfRange {
        /// The parameter (as the API and the command line name it).
        name: &'static str,
        /// Its value.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
        /// Unit of the value and the range.
        unit: &'static str,
    },
    /// The request would need more of something than a stated limit of [`crate::limits`]
    /// allows (checked before allocating).
    #[error(
        "{what} needs {needed:.4e} {items}, more than the limit {limit} = {max} \
         (omnikin_plan::limits); {hint}"
    )]
    TooLarge {
        /// What would grow, and why (e.g. `the plan (duration 1e9 s × rate 100 Hz)`).
        what: String,
        /// What is counted (`samples`, `grid cells`, `waypoints`).
        items: &'static str,
        /// How many the inputs imply.
        needed: f64,
        /// The limit's name (a constant of [`crate::limits`]).
        limit: &'static str,
        /// The limit's value.
        max: usize,
        /// What to change to stay within it.
        hint: &'static str,
    },
    /// A fixed timing (re-timing not allowed) needs more than a motor can give.
    #[error("{0}")]
    LimitExceeded(Violation),
    /// The request cannot be planned as stated (e.g. a constant-speed law on a path with stops).
    #[error("{0}")]
    Infeasible(String),
    /// The core kinematics rejected an input (non-finite value). Its message includes the
    /// cause, so the cause is not also its `source` (a chain would print it twice).
    #[error("kinematics: {0}")]
    Kinematics(omnikin::InputError),
    /// The robot model could not be built.
    #[error("robot: {0}")]
    Robot(String),
    /// A waypoint file is malformed: file, line and what is wrong.
    #[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Waypoints {
        /// The file.
        file: String,
        /// 1-based line, when known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
}

impl From<omnikin::InputError> for PlanningError {
    fn from(e: omnikin::InputError) -> Self {
        Self::Kinematics(e)
    }
}
