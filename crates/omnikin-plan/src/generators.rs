//! Ready-made plans for paper 000's two experiments (§6): the square with full stops
//! (eq. 6.1) and the circle with the platform turning with the motion (eq. 6.3).
//!
//! Paper 000's series on its robot (`sphere-omni`):
//! * square, side 0.4 m, `V = 0.1 k` m/s, leg time `T = 4/k` s, `k = 1, 2, 4, 5`
//!   ([`Square::paper`]);
//! * circle, `R_t = 0.2` m, `ω0 = 0.5, 1, 2, 2.5` rad/s ([`Circle::paper`]).

use crate::PlanningError;
use crate::heading::HeadingLaw;
use crate::limits::{
    ACCEL_RANGE, JERK_RANGE, LENGTH_RANGE, RAMP_RANGE, SPEED_RANGE, TURNS_RANGE, YAW_RATE_RANGE,
    check_range,
};
use crate::path::{Corners, Path};
use crate::planner::{InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing};
use crate::profile::ProfileKind;

/// Paper 000's `k` values (`V = 0.1 k` m/s, `ω0 = 0.5 k` rad/s on the 0.2 m circle).
pub const PAPER_K: [f64; 4] = [1.0, 2.0, 4.0, 5.0];

/// The square of paper 000, eq. 6.1: from the origin, legs along `+y`, `+x`, `−y`, `−x` of
/// length `side`, heading held at `ψ = 0`, a full stop before each turn.
///
/// Each leg is a rest-to-rest profile with cruise speed `speed`; each ramp (up and down) takes
/// `ramp_fraction · side/speed` seconds (paper: "≤ 5 % of the leg time", default 0.05), so a
/// leg lasts `(1 + ramp_fraction) · side/speed`. A trapezoid ramps at constant acceleration
/// `speed / t_ramp`; an S-curve ramp is jerk-limited throughout (acceleration peaking at
/// `2 speed / t_ramp`, jerk `4 speed / t_ramp²`) and takes the same time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Square {
    /// Side length, m.
    pub side: f64,
    /// Cruise speed `V` along each leg, m/s.
    pub speed: f64,
    /// Duration of each ramp as a fraction of `side/speed` (0 < f ≤ 0.5).
    pub ramp_fraction: f64,
    /// Ramp shape.
    pub profile: ProfileKind,
}

impl Square {
    /// Paper 000's square number `k` (`k = 1, 2, 4, 5`): side 0.4 m, `V = 0.1 k` m/s
    /// (leg time `T = 4/k` s), 5 % trapezoidal ramps.
    pub fn paper(k: f64) -> Self {
        Self {
            side: 0.4,
            speed: 0.1 * k,
            ramp_fraction: 0.05,
            profile: ProfileKind::Trapezoid,
        }
    }

    /// Checks the parameters.
    ///
    /// # Errors
    /// [`PlanningError::OutOfRange`] for a side or speed outside its range in
    /// [`crate::limits`]; [`PlanningError::InvalidParameter`] for a ramp fraction outside
    /// (0, 0.5].
    pub fn validate(&self) -> Result<(), PlanningError> {
        check_range("side", self.side, LENGTH_RANGE, "m")?;
        check_range("speed", self.speed, SPEED_RANGE, "m/s")?;
        if !(self.ramp_fraction > 0.0 && self.ramp_fraction <= 0.5) {
            return Err(PlanningError::InvalidParameter {
                name: "ramp fraction",
                value: self.ramp_fraction,
                rule: "must be in (0, 0.5]: each ramp takes this fraction of side/speed",
            });
        }
        // The ramps' acceleration (and jerk) follow from the three: check them here, where
        // the message can name what to change.
        if let Timing::Profile { limits, .. } = self.timing() {
            check_range(
                "ramp acceleration speed²/(ramp fraction × side)",
                limits.max_accel,
                ACCEL_RANGE,
                "m/s²",
            )?;
            if self.profile == ProfileKind::SCurve {
                check_range(
                    "ramp jerk 4·speed³/(ramp fraction × side)²",
                    limits.max_jerk,
                    JERK_RANGE,
                    "m/s³",
                )?;
            }
        }
        Ok(())
    }

    /// The path: `(0,0) → (0,L) → (L,L) → (L,0) → (0,0)` with stops at the corners.
    pub fn path(&self) -> Result<Path, PlanningError> {
        self.validate()?;
        let l = self.side;
        Path::polyline(
            &[[0.0, 0.0], [0.0, l], [l, l], [l, 0.0], [0.0, 0.0]],
            Corners::Stop,
        )
    }

    /// `ψ = 0` (eq. 6.1: the heading is kept).
    pub fn heading(&self) -> HeadingLaw {
        HeadingLaw::Constant(0.0)
    }

    /// Ramp duration, s.
    pub fn ramp_time(&self) -> f64 {
        self.ramp_fraction * self.side / self.speed
    }

    /// The timing: a profile per leg as described on [`Square`].
    pub fn timing(&self) -> Timing {
        let tr = self.ramp_time();
        let (a, j) = match self.profile {
            ProfileKind::Trapezoid => (self.speed / tr, f64::INFINITY),
            ProfileKind::SCurve => (2.0 * self.speed / tr, 4.0 * self.speed / (tr * tr)),
        };
        Timing::Profile {
            kind: self.profile,
            limits: MotionLimits {
                max_speed: self.speed,
                max_accel: a,
                max_jerk: if j.is_finite() { j } else { 1.0 },
                ..MotionLimits::default()
            },
        }
    }

    /// Options for sampling at `rate` Hz, re-timing or rejecting per `on_limit`.
    pub fn options(&self, rate: f64, on_limit: OnLimit) -> PlanOptions {
        PlanOptions {
            timing: self.timing(),
            on_limit,
            rate,
            initial_steer: InitialSteer::Aligned,
        }
    }
}

/// The circle of paper 000, eq. 6.3: `x = R_t cos ω0 t`, `y = R_t sin ω0 t`, `ψ = ω0 t`.
///
/// The centre moves at `R_t |ω0|` and the platform turns with the motion: `ψ = ω0 t` is the
/// direction of motion minus 90° (for `ω0 > 0`), so in the platform frame the velocity is
/// `(0, R_t ω0)` — the platform's +y axis leads. With `face_motion` the heading is instead the
/// direction of motion itself (eq. 5.5, `ψ = ω0 t + π/2`, platform velocity `(R_t ω0, 0)`): the
/// same motion turned by 90° in the platform, with different wheel rates (on `sphere-omni` at
/// `ω0 = 2.5` rad/s the peak is 8.84 rad/s for eq. 6.3 and 10.93 rad/s facing the motion). The paper's law **starts and ends at full
/// speed** (the first sample already moves); with `ramp` set, the speed instead ramps up from
/// rest over `ramp` seconds (constant acceleration) and back down at the end, and `ψ` is the
/// polar angle (equal to `ω0 t` at constant speed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle {
    /// Radius `R_t`, m.
    pub radius: f64,
    /// Angular rate `ω0` about the centre, rad/s (> 0 counter-clockwise).
    pub omega: f64,
    /// Number of turns (> 0).
    pub turns: f64,
    /// Optional ramp time, s (None: paper's law, full speed from the start).
    pub ramp: Option<f64>,
    /// Face the direction of motion (eq. 5.5) instead of `ψ = ω0 t` (eq. 6.3).
    pub face_motion: bool,
}

impl Circle {
    /// Paper 000's circle number `k` (`k = 1, 2, 4, 5`): `R_t = 0.2` m, `ω0 = 0.5 k` rad/s,
    /// one turn, no ramp.
    pub fn paper(k: f64) -> Self {
        Self {
            radius: 0.2,
            omega: 0.5 * k,
            turns: 1.0,
            ramp: None,
            face_motion: false,
        }
    }

    /// Checks the parameters.
    ///
    /// # Errors
    /// [`PlanningError::OutOfRange`] for a radius, turn count, `|ω0|`, speed `R|ω0|` or ramp
    /// outside its range in [`crate::limits`] (a ramp also at most half the circle's time at
    /// full speed); [`PlanningError::InvalidParameter`] for `ω0` = 0 / not finite.
    pub fn validate(&self) -> Result<(), PlanningError> {
        check_range("radius", self.radius, LENGTH_RANGE, "m")?;
        check_range("turns", self.turns, TURNS_RANGE, "")?;
        if !(self.omega.is_finite() && self.omega != 0.0) {
            return Err(PlanningError::InvalidParameter {
                name: "omega",
                value: self.omega,
                rule: "must be finite and non-zero (rad/s; > 0 counter-clockwise)",
            });
        }
        check_range("|omega|", self.omega.abs(), YAW_RATE_RANGE, "rad/s")?;
        check_range("speed (radius × |omega|)", self.speed(), SPEED_RANGE, "m/s")?;
        if let Some(r) = self.ramp {
            check_range("ramp", r, RAMP_RANGE, "s")?;
            // Each ramp must fit in half the circle's time at full speed: a longer one never
            // reaches the requested omega (the plan would be a different, slower motion).
            let half = 0.5 * self.turns * std::f64::consts::TAU / self.omega.abs();
            if r > half {
                return Err(PlanningError::OutOfRange {
                    name: "ramp",
                    value: r,
                    min: RAMP_RANGE.0,
                    max: half,
                    unit: "s (at most half the circle's time at full speed, turns·π/|omega|)",
                });
            }
            check_range(
                "ramp acceleration radius × |omega| / ramp",
                self.speed() / r,
                ACCEL_RANGE,
                "m/s²",
            )?;
        }
        Ok(())
    }

    /// The path: `turns` circles of radius `R_t` about the origin from `(R_t, 0)`, in the
    /// direction of `ω0`.
    pub fn path(&self) -> Result<Path, PlanningError> {
        self.validate()?;
        Path::circle(
            [0.0, 0.0],
            self.radius,
            0.0,
            self.turns * self.omega.signum(),
        )
    }

    /// `ψ = ω0 t`: the tangent law (eq. 5.5) with offset `−sign(ω0)·π/2`; offset 0 with
    /// `face_motion`.
    pub fn heading(&self) -> HeadingLaw {
        HeadingLaw::Tangent {
            offset: if self.face_motion {
                0.0
            } else {
                -self.omega.signum() * std::f64::consts::FRAC_PI_2
            },
        }
    }

    /// Centre speed `R_t |ω0|`, m/s.
    pub fn speed(&self) -> f64 {
        self.radius * self.omega.abs()
    }

    /// The timing: constant speed (paper), or a trapezoid with the ramp.
    pub fn timing(&self) -> Timing {
        match self.ramp {
            None => Timing::ConstantSpeed {
                speed: self.speed(),
            },
            Some(r) => Timing::Profile {
                kind: ProfileKind::Trapezoid,
                limits: MotionLimits {
                    max_speed: self.speed(),
                    max_accel: self.speed() / r,
                    ..MotionLimits::default()
                },
            },
        }
    }

    /// Options for sampling at `rate` Hz. `ω0` is fixed by the request, so a circle that is
    /// too fast is rejected ([`OnLimit::Reject`]), never slowed.
    pub fn options(&self, rate: f64) -> PlanOptions {
        PlanOptions {
            timing: self.timing(),
            on_limit: OnLimit::Reject,
            rate,
            initial_steer: InitialSteer::Aligned,
        }
    }
}
