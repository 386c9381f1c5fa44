//! One-dimensional rest-to-rest motion profiles `σ(t)` along a path parameter: trapezoidal
//! (limited speed and acceleration) and S-curve (limited jerk as well).
//!
//! A profile moves a distance `L` from rest to rest: a ramp up to the cruise speed, a cruise,
//! and the mirror image of the ramp. When `L` is too short to reach the requested speed the
//! cruise speed is lowered so the two ramps meet. Units follow the parameter: m, m/s, m/s²,
//! m/s³ along a path, or rad, rad/s, … for a turn in place.

use crate::PlanningError;

/// The shape of a velocity profile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProfileKind {
    /// Constant acceleration ramps (speed and acceleration limited; the acceleration jumps).
    Trapezoid,
    /// Jerk-limited ramps (7-phase "S-curve": the acceleration rises and falls linearly).
    SCurve,
}

/// A ramp from rest to speed `v` with acceleration up to `a` and jerk `j` (`j = ∞`: constant
/// acceleration). Symmetric in time, so it covers `v·T/2`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Ramp {
    v: f64,
    /// Peak acceleration actually reached.
    a: f64,
    j: f64,
    /// Jerk phase duration (0 for a trapezoid).
    t1: f64,
    /// Constant-acceleration phase duration.
    t2: f64,
}

impl Ramp {
    fn new(v: f64, a: f64, j: f64) -> Self {
        if !j.is_finite() {
            return Self {
                v,
                a,
                j,
                t1: 0.0,
                t2: v / a,
            };
        }
        if v * j >= a * a {
            Self {
                v,
                a,
                j,
                t1: a / j,
                t2: v / a - a / j,
            }
        } else {
            let ap = (v * j).sqrt();
            Self {
                v,
                a: ap,
                j,
                t1: ap / j,
                t2: 0.0,
            }
        }
    }

    fn duration(&self) -> f64 {
        2.0 * self.t1 + self.t2
    }

    fn distance(&self) -> f64 {
        self.v * self.duration() / 2.0
    }

    /// `(position, speed, acceleration)` at time `t` into the ramp.
    fn eval(&self, t: f64) -> (f64, f64, f64) {
        let (a, j, t1, t2) = (self.a, self.j, self.t1, self.t2);
        let t = t.clamp(0.0, self.duration());
        if t < t1 {
            return (j * t * t * t / 6.0, j * t * t / 2.0, j * t);
        }
        let (p1, v1) = (j * t1 * t1 * t1 / 6.0, j * t1 * t1 / 2.0);
        let p1 = if t1 > 0.0 { p1 } else { 0.0 };
        let v1 = if t1 > 0.0 { v1 } else { 0.0 };
        if t < t1 + t2 {
            let tau = t - t1;
            return (p1 + v1 * tau + a * tau * tau / 2.0, v1 + a * tau, a);
        }
        let (p2, v2) = (p1 + v1 * t2 + a * t2 * t2 / 2.0, v1 + a * t2);
        let tau = t - t1 - t2;
        if t1 > 0.0 {
            (
                p2 + v2 * tau + a * tau * tau / 2.0 - j * tau * tau * tau / 6.0,
                v2 + a * tau - j * tau * tau / 2.0,
                a - j * tau,
            )
        } else {
            (p2, v2, 0.0)
        }
    }
}

/// A symmetric rest-to-rest profile over a distance `L`: ramp up, cruise, ramp down.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile1D {
    length: f64,
    ramp: Ramp,
    cruise_time: f64,
}

impl Profile1D {
    /// The fastest profile of the given kind that covers `length` from rest to rest with speed
    /// at most `v_max`, acceleration at most `a_max` and, for [`ProfileKind::SCurve`], jerk at
    /// most `j_max` (ignored for a trapezoid). Units of the path parameter (m, m/s, m/s², m/s³).
    ///
    /// # Errors
    /// [`PlanningError::InvalidParameter`] when a limit is not a finite number > 0 (or the
    /// length is negative / not finite).
    pub fn new(
        kind: ProfileKind,
        length: f64,
        v_max: f64,
        a_max: f64,
        j_max: f64,
    ) -> Result<Self, PlanningError> {
        let check = |name, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(PlanningError::InvalidParameter {
                    name,
                    value: v,
                    rule: "must be a finite number > 0",
                })
            }
        };
        check("max speed", v_max)?;
        check("max acceleration", a_max)?;
        let j = match kind {
            ProfileKind::Trapezoid => f64::INFINITY,
            ProfileKind::SCurve => {
                check("max jerk", j_max)?;
                j_max
            }
        };
        if !(length.is_finite() && length >= 0.0) {
            return Err(PlanningError::InvalidParameter {
                name: "profile length",
                value: length,
                rule: "must be finite and ≥ 0",
            });
        }
        let full = Ramp::new(v_max, a_max, j);
        let ramp = if 2.0 * full.distance() <= length {
            full
        } else {
            // Two ramps longer than the distance: lower the peak speed until they meet. The
            // ramp distance grows monotonically with the speed, so bisection converges.
            let (mut lo, mut hi) = (0.0, v_max);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if 2.0 * Ramp::new(mid, a_max, j).distance() <= length {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            Ramp::new(lo, a_max, j)
        };
        let cruise_time = if ramp.v > 0.0 {
            ((length - 2.0 * ramp.distance()) / ramp.v).max(0.0)
        } else {
            0.0
        };
        Ok(Self {
            length,
            ramp,
            cruise_time,
        })
    }

    /// Total duration, s.
    pub fn duration(&self) -> f64 {
        2.0 * self.ramp.duration() + self.cruise_time
    }

    /// The distance covered, in path-parameter units.
    pub fn length(&self) -> f64 {
        self.length
    }

    /// Cruise (peak) speed actually reached.
    pub fn peak_speed(&self) -> f64 {
        self.ramp.v
    }

    /// Duration of each ramp, s.
    pub fn ramp_time(&self) -> f64 {
        self.ramp.duration()
    }

    /// `(σ, σ̇, σ̈)` at time `t` (s), clamped to `[0, duration]`.
    pub fn eval(&self, t: f64) -> (f64, f64, f64) {
        let tr = self.ramp.duration();
        let total = self.duration();
        let t = t.clamp(0.0, total);
        if t <= tr {
            self.ramp.eval(t)
        } else if t <= tr + self.cruise_time {
            (
                self.ramp.distance() + self.ramp.v * (t - tr),
                self.ramp.v,
                0.0,
            )
        } else {
            let (p, v, a) = self.ramp.eval(total - t);
            (self.length - p, v, -a)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_consistency(p: &Profile1D) {
        // Numerically differentiating σ(t) reproduces σ̇ (acceleration ≤ 2), and σ ends at L.
        let n = 4000;
        let dt = p.duration() / n as f64;
        for i in 1..n {
            let t = i as f64 * dt;
            let (a, _, _) = p.eval(t - dt / 2.0);
            let (b, _, _) = p.eval(t + dt / 2.0);
            let (_, v, _) = p.eval(t);
            // Exact for the quadratic pieces; off by at most a·dt/4 across a kink of σ̇.
            assert!(((b - a) / dt - v).abs() < 1e-9 + 2.0 * dt, "t {t}");
        }
        let (end, v_end, _) = p.eval(p.duration());
        assert!((end - p.length()).abs() < 1e-9 && v_end.abs() < 1e-9);
    }

    #[test]
    fn trapezoid_and_s_curve_cover_the_distance() {
        for kind in [ProfileKind::Trapezoid, ProfileKind::SCurve] {
            for len in [0.001, 0.05, 0.4, 3.0] {
                let p = Profile1D::new(kind, len, 0.5, 2.0, 10.0).unwrap();
                check_consistency(&p);
                assert!(p.peak_speed() <= 0.5 + 1e-12);
            }
        }
    }

    #[test]
    fn trapezoid_times_match_hand_values() {
        // 0.4 m at 0.1 m/s with 2 m/s² ramps (0.05 s): 4 s + 0.05 s.
        let p = Profile1D::new(ProfileKind::Trapezoid, 0.4, 0.1, 2.0, 0.0).unwrap();
        assert!((p.duration() - 4.05).abs() < 1e-12, "{}", p.duration());
        // Short move: triangle with peak sqrt(a L).
        let p = Profile1D::new(ProfileKind::Trapezoid, 0.01, 1.0, 1.0, 0.0).unwrap();
        assert!((p.peak_speed() - 0.1).abs() < 1e-9);
        // S-curve reaching a: ramp time v/a + a/j.
        let p = Profile1D::new(ProfileKind::SCurve, 10.0, 1.0, 2.0, 8.0).unwrap();
        assert!((p.ramp_time() - (0.5 + 0.25)).abs() < 1e-12);
    }
}
