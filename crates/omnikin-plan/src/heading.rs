//! Heading laws: how the robot frame's yaw `ψ` (rad, world frame, unwrapped) evolves along a
//! path (paper 000, §5).
//!
//! Paper 000 uses two laws: a constant heading (the square, eq. 6.1, `ψ = 0`) and the heading
//! following the direction of motion (eq. 5.5, `ψ = atan2(ẏ, ẋ)`; the circle, eq. 6.3, is this
//! law turned by −90°). A third law here lets the heading follow a given profile along the path
//! (for instance spinning while translating).
//!
//! All laws give `ψ` as a function of the **arc length** `s`, never of time: when the planner
//! slows a stretch down to respect a motor limit, the heading stays tied to the position.

use crate::PlanningError;
use crate::limits::{MAX_HEADING, check_magnitude};

/// The heading law of a plan (paper 000, §5): the yaw `ψ` of the robot frame in the world
/// frame, rad, as a function of arc length along the path.
#[derive(Clone, Debug, PartialEq)]
pub enum HeadingLaw {
    /// `ψ = const` (rad): the platform does not turn (paper 000, square, eq. 6.1 with `ψ = 0`).
    Constant(f64),
    /// `ψ = atan2(ẏ, ẋ) + offset` (paper 000, eq. 5.5), unwrapped so it is continuous. The
    /// direction is the path's tangent, so it is defined at rest too; at a stop where the
    /// direction changes (a polyline corner) the planner turns the robot in place from the
    /// incoming to the outgoing direction (the shorter way). `offset = −π/2` for a
    /// counter-clockwise circle starting on the +x axis gives paper 000's eq. 6.3, `ψ = ω0 t`.
    Tangent {
        /// Constant added to the direction of motion, rad.
        offset: f64,
    },
    /// `ψ(s)` interpolated through given `(s, ψ)` points (see [`HeadingProfile`]).
    Profile(HeadingProfile),
}

/// Which side of a point to evaluate a law that may have a kink there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The limit from smaller arc lengths.
    Before,
    /// The limit from larger arc lengths.
    After,
}

/// A heading profile `ψ(s)`: a natural cubic spline through points `(s_k, ψ_k)` (arc length in
/// m, heading in rad, used as given — no wrapping, so `0 → 2π` is one full turn
/// counter-clockwise). C² inside `[s_0, s_last]`, so the yaw rate `ψ̇ = ψ'(s) ṡ` is continuous
/// there; outside it the heading is held at the end values. A single point is a constant
/// heading.
#[derive(Clone, Debug, PartialEq)]
pub struct HeadingProfile {
    s: Vec<f64>,
    psi: Vec<f64>,
    /// Second derivatives `ψ''(s_k)` of the natural spline, rad/m².
    m: Vec<f64>,
}

impl HeadingProfile {
    /// A profile through `points = [(s_k, ψ_k)]` (m, rad).
    ///
    /// # Errors
    /// [`PlanningError::InvalidParameter`] when there is no point, an arc length is not finite
    /// or the arc lengths do not increase strictly; [`PlanningError::OutOfRange`] for a heading
    /// larger than [`crate::limits::MAX_HEADING`] in magnitude.
    pub fn new(points: &[(f64, f64)]) -> Result<Self, PlanningError> {
        if points.is_empty() {
            return Err(PlanningError::InvalidParameter {
                name: "heading profile",
                value: 0.0,
                rule: "needs at least one (s, heading) point",
            });
        }
        for &(s, p) in points {
            if !s.is_finite() {
                return Err(PlanningError::InvalidParameter {
                    name: "heading profile s",
                    value: s,
                    rule: "must be finite (m)",
                });
            }
            check_magnitude("heading profile heading", p, MAX_HEADING, "rad")?;
        }
        for w in points.windows(2) {
            if w[1].0 <= w[0].0 {
                return Err(PlanningError::InvalidParameter {
                    name: "heading profile s",
                    value: w[1].0,
                    rule: "arc lengths must increase strictly",
                });
            }
        }
        let s: Vec<f64> = points.iter().map(|p| p.0).collect();
        let psi: Vec<f64> = points.iter().map(|p| p.1).collect();
        let n = s.len();
        let mut m = vec![0.0; n];
        if n > 2 {
            // Natural cubic spline: tridiagonal system for the interior second derivatives
            // (Thomas algorithm).
            let h: Vec<f64> = s.windows(2).map(|w| w[1] - w[0]).collect();
            let k = n - 2;
            let mut diag = vec![0.0; k];
            let mut rhs = vec![0.0; k];
            for i in 0..k {
                diag[i] = 2.0 * (h[i] + h[i + 1]);
                rhs[i] =
                    6.0 * ((psi[i + 2] - psi[i + 1]) / h[i + 1] - (psi[i + 1] - psi[i]) / h[i]);
            }
            for i in 1..k {
                let f = h[i] / diag[i - 1];
                diag[i] -= f * h[i];
                rhs[i] -= f * rhs[i - 1];
            }
            for i in (0..k).rev() {
                let upper = if i + 1 < k { h[i + 1] * m[i + 2] } else { 0.0 };
                m[i + 1] = (rhs[i] - upper) / diag[i];
            }
        }
        Ok(Self { s, psi, m })
    }

    /// The arc-length range `[s_0, s_last]` the points cover, m.
    pub fn range(&self) -> (f64, f64) {
        (self.s[0], self.s[self.s.len() - 1])
    }

    /// `(ψ, dψ/ds)` at arc length `s` (rad, rad/m). At the ends of the range `side` picks the
    /// spline's slope ([`Side::After`] at the start, [`Side::Before`] at the end) or the held
    /// value's zero slope.
    pub fn at(&self, s: f64, side: Side) -> (f64, f64) {
        let (psi, dpsi, _) = self.at_with_second(s, side);
        (psi, dpsi)
    }

    /// `(ψ, dψ/ds, d²ψ/ds²)` at arc length `s` (rad, rad/m, rad/m²), the ends as in
    /// [`HeadingProfile::at`] (0 where the value is held). The second derivative is the
    /// spline's, linear between the points.
    pub(crate) fn at_with_second(&self, s: f64, side: Side) -> (f64, f64, f64) {
        let n = self.s.len();
        let (lo, hi) = self.range();
        if n == 1 || s < lo || (s == lo && side == Side::Before) {
            return (self.psi[0], 0.0, 0.0);
        }
        if s > hi || (s == hi && side == Side::After) {
            return (self.psi[n - 1], 0.0, 0.0);
        }
        let i = match self.s.binary_search_by(|x| x.total_cmp(&s)) {
            Ok(i) => i.min(n - 2),
            Err(i) => (i - 1).min(n - 2),
        };
        let h = self.s[i + 1] - self.s[i];
        let a = (self.s[i + 1] - s) / h;
        let b = (s - self.s[i]) / h;
        let (m0, m1) = (self.m[i], self.m[i + 1]);
        let psi = a * self.psi[i]
            + b * self.psi[i + 1]
            + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0;
        let dpsi = (self.psi[i + 1] - self.psi[i]) / h
            + (-(3.0 * a * a - 1.0) * m0 + (3.0 * b * b - 1.0) * m1) * h / 6.0;
        (psi, dpsi, a * m0 + b * m1)
    }
}

impl HeadingLaw {
    /// Checks the law's numbers.
    ///
    /// # Errors
    /// [`PlanningError::OutOfRange`] for a constant or offset that is not finite or larger
    /// than [`crate::limits::MAX_HEADING`].
    pub fn validate(&self) -> Result<(), PlanningError> {
        match self {
            HeadingLaw::Constant(v) => check_magnitude("heading", *v, MAX_HEADING, "rad"),
            HeadingLaw::Tangent { offset } => {
                check_magnitude("heading offset", *offset, MAX_HEADING, "rad")
            }
            HeadingLaw::Profile(_) => Ok(()),
        }
    }

    /// Arc lengths (m) of a profile's points, where `d³ψ/ds³` jumps (empty for the other laws):
    /// the planner puts grid nodes there.
    pub(crate) fn knots(&self) -> &[f64] {
        match self {
            HeadingLaw::Profile(p) => &p.s,
            _ => &[],
        }
    }

    /// Arc lengths (m) where `dψ/ds` may jump for a reason other than the path's own joins: the
    /// ends of a profile's range.
    pub fn breakpoints(&self) -> Vec<f64> {
        match self {
            HeadingLaw::Profile(p) if p.s.len() > 1 => {
                let (a, b) = p.range();
                vec![a, b]
            }
            _ => Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_spline_interpolates_and_is_linear_for_two_points() {
        let p = HeadingProfile::new(&[(0.0, 0.0), (2.0, 1.0)]).unwrap();
        assert_eq!(p.at(1.0, Side::After), (0.5, 0.5));
        let p = HeadingProfile::new(&[(0.0, 0.0), (1.0, 1.0), (3.0, -1.0), (4.0, 0.0)]).unwrap();
        for (s, want) in [(0.0, 0.0), (1.0, 1.0), (3.0, -1.0), (4.0, 0.0)] {
            assert!((p.at(s, Side::After).0 - want).abs() < 1e-12);
        }
        // Slope continuous across a knot.
        let e = 1e-7;
        let (a, b) = (p.at(1.0 - e, Side::After).1, p.at(1.0 + e, Side::After).1);
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        // Held outside the range.
        assert_eq!(p.at(5.0, Side::After), (0.0, 0.0));
        assert!(HeadingProfile::new(&[(1.0, 0.0), (1.0, 1.0)]).is_err());
    }

    #[test]
    fn wrap() {
        assert!(
            (omnikin::wrap_angle(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12
        );
        assert!((omnikin::wrap_angle(-0.5_f64) + 0.5).abs() < 1e-15);
    }
}
