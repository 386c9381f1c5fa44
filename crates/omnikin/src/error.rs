//! Errors: one type for a robot geometry that cannot work, one for a call with bad input.
//! Both are `Copy`, allocation-free and say exactly which field or wheel is at fault.

/// Why a robot geometry was rejected at construction.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum GeometryError {
    /// A parameter is NaN or infinite.
    #[error("{field} must be finite")]
    NonFinite {
        /// The parameter's name (e.g. `"shell_radius"`).
        field: &'static str,
    },
    /// A length that must be strictly positive is not.
    #[error("{field} must be > 0 (got {value})")]
    NotPositive {
        /// The parameter's name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// A sphere wheel does not fit inside the shell (`wheel_radius ≥ shell_radius`).
    #[error(
        "wheel {wheel}: wheel radius {wheel_radius} m must be smaller than the shell radius {shell_radius} m"
    )]
    WheelTooLarge {
        /// 1-based wheel index.
        wheel: usize,
        /// That wheel's radius, m.
        wheel_radius: f64,
        /// The shell radius, m.
        shell_radius: f64,
    },
    /// A list of wheels (modules) has a length the kind does not support.
    #[error("{field}: {got} given, this kind supports {min} to {max}")]
    WheelCount {
        /// The list's name (`"wheels"`, `"modules"`).
        field: &'static str,
        /// The number given.
        got: usize,
        /// Fewest supported.
        min: usize,
        /// Most supported ([`crate::drive::MAX_WHEELS`]).
        max: usize,
    },
    /// An angle parameter is outside the range the model allows.
    #[error("{field} = {value} rad is out of range: {rule}")]
    AngleOutOfRange {
        /// The parameter's name.
        field: &'static str,
        /// The value given, rad.
        value: f64,
        /// The allowed range, in words.
        rule: &'static str,
    },
    /// A wheel cannot drive the body: its drive lever (sphere: `s_i·n_i`, paper 000 eq. 4.4)
    /// is (nearly) zero, so its rate would be infinite.
    #[error("wheel {wheel}: {quantity} = {value} is ~0, the wheel cannot drive the body ({rule})")]
    DeadWheel {
        /// 1-based wheel index.
        wheel: usize,
        /// The vanishing quantity, e.g. `"s·n"`.
        quantity: &'static str,
        /// Its value.
        value: f64,
        /// What to change.
        rule: &'static str,
    },
    /// The wheels' constraint directions are (nearly) linearly dependent: the 3×3 map from body
    /// motion to wheel rates is singular or too ill-conditioned to invert reliably.
    #[error(
        "{what} is singular or ill-conditioned: condition number {condition:.3e} exceeds {max:.1e} (wheels nearly coplanar or parallel)"
    )]
    IllConditioned {
        /// The matrix, e.g. `"wheel constraint matrix S = [s1; s2; s3]"`.
        what: &'static str,
        /// Its 2-norm condition number (∞ when exactly singular).
        condition: f64,
        /// The largest accepted condition number ([`crate::MAX_CONDITION`]).
        max: f64,
    },
}

/// Why a kinematics call rejected its input. Calls never panic: every problem is one of these.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum InputError {
    /// An input value is NaN or infinite.
    #[error("{field} must be finite")]
    NonFinite {
        /// The input's name (e.g. `"vx"`, `"wheel_rates[2]"`).
        field: &'static str,
    },
    /// The inputs are finite but the result is not representable (overflow to ±∞ or NaN), e.g.
    /// `vx = 1e308`.
    #[error("{quantity} overflowed: the inputs are too large for the result to be finite")]
    Overflow {
        /// The output that overflowed (e.g. `"wheel_rates"`).
        quantity: &'static str,
    },
    /// The requested motion passes through a kinematic singularity of the robot.
    #[error("singular configuration: {reason}")]
    Singular {
        /// What is singular and why.
        reason: &'static str,
    },
}
