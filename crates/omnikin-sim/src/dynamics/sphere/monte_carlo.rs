//! The dynamic plant in a Monte Carlo: [`DynamicProfile`] (the nominal [`SphereDynamics`] and
//! the trial-to-trial variation a real robot's runs have), [`DynamicProfile::trial`] (one
//! seeded trial) and [`fit_com_depth`] (the one-parameter fit of the centre-of-mass depth to a
//! circle's radius ratio: a scan, then bisection).
//!
//! The variation mirrors what [`crate::reproduce::hardware_profile`] draws for the kinematic
//! plant, with the same magnitudes: a wheel-radius error per wheel and trial (as a relative
//! rate error), a speed fluctuation held over each plan interval, and white tracking noise;
//! plus a jitter of the two parameters the dynamics are most sensitive to (centre-of-mass
//! depth and pivot friction), drawn per trial. Every number of trial `i` comes from its own
//! random stream ([`crate::trial_rng`]), so the results do not depend on the thread count.

use omnikin_plan::Plan;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Serialize;

use super::params::{DynamicsError, SphereDynamics};
use super::sim::ContactEvents;
use super::trial::simulate_plan;
use crate::metrics::fit_circle;
use crate::{SimError, Trial};

/// The dynamic plant with its trial-to-trial variation (all standard deviations; 0 = none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DynamicProfile {
    /// The nominal robot.
    pub params: SphereDynamics,
    /// Relative wheel-radius error per wheel and trial (applied as a rate error of the wheel's
    /// command), 1. [`crate::reproduce::hardware_profile`]: 0.01.
    pub radius_error_std: f64,
    /// Relative speed fluctuation of each motor, drawn per wheel for every plan interval (the
    /// hardware profile holds its ±1 % for 10 ms = one interval of a 100 Hz plan), 1.
    pub fluctuation_rel: f64,
    /// Relative scatter of the centre-of-mass depth per trial (battery and cable placement
    /// between runs), 1.
    pub com_depth_rel_std: f64,
    /// Relative scatter of the pivot friction per trial (log-normal: floor patches, dust), 1.
    pub pivot_friction_rel_std: f64,
    /// White noise of the video tracker per frame and axis, m.
    pub tracking_noise_std: f64,
}

impl DynamicProfile {
    /// The dynamic plant without variation: every trial is the deterministic
    /// [`simulate_plan`] of the plan.
    pub fn exact(params: SphereDynamics) -> Self {
        Self {
            params,
            radius_error_std: 0.0,
            fluctuation_rel: 0.0,
            com_depth_rel_std: 0.0,
            pivot_friction_rel_std: 0.0,
            tracking_noise_std: 0.0,
        }
    }

    /// `params` with the variation of [`crate::reproduce::hardware_profile`] (1 % wheel
    /// radius, 1 % speed fluctuation, 2 mm tracking noise) and assumed parameter scatter of
    /// 3 % on the centre-of-mass depth and 20 % on the pivot friction.
    pub fn hardware(params: SphereDynamics) -> Self {
        Self {
            params,
            radius_error_std: 0.01,
            fluctuation_rel: 0.01,
            com_depth_rel_std: 0.03,
            pivot_friction_rel_std: 0.2,
            tracking_noise_std: 0.002,
        }
    }

    /// One trial of `plan` with this trial's draws from `rng` (seed one stream per trial, e.g.
    /// [`crate::trial_rng`]). The record is the one of [`simulate_plan`] with the tracker's
    /// noise added to `tracked`.
    ///
    /// # Errors
    /// [`SimError::Mismatch`] with the dynamics' error (a plan not for the sphere's three
    /// wheels, invalid parameters, a diverging state).
    pub fn trial<R: Rng + ?Sized>(&self, plan: &Plan, rng: &mut R) -> Result<Trial, SimError> {
        self.trial_with_events(plan, rng).map(|(t, _)| t)
    }

    /// [`DynamicProfile::trial`] with the trial's contact events (roller slips, lift-offs,
    /// floor slides, lost steps over the run, [`SphereSim::contact_events`]); the same
    /// draws, so the trial is the same.
    ///
    /// [`SphereSim::contact_events`]: super::SphereSim::contact_events
    ///
    /// # Errors
    /// As [`DynamicProfile::trial`].
    pub fn trial_with_events<R: Rng + ?Sized>(
        &self,
        plan: &Plan,
        rng: &mut R,
    ) -> Result<(Trial, ContactEvents), SimError> {
        let (p, scale) = self.draw_robot(rng);
        let mut n = || -> f64 { StandardNormal.sample(rng) };
        let mut plan = plan.clone();
        if self.radius_error_std > 0.0 || self.fluctuation_rel > 0.0 {
            for s in plan.samples.iter_mut() {
                for (w, k) in s.wheel_rates.iter_mut().zip(scale) {
                    *w *= k * (1.0 + self.fluctuation_rel * n());
                }
            }
        }
        let run = simulate_plan(p, &plan)
            .map_err(|e| SimError::Mismatch(format!("dynamic plant: {e}")))?;
        let (mut t, events) = (run.trial, run.contact_events);
        if self.tracking_noise_std > 0.0 {
            for xy in t.tracked.iter_mut() {
                xy[0] += self.tracking_noise_std * n();
                xy[1] += self.tracking_noise_std * n();
            }
        }
        Ok((t, events))
    }
}

impl DynamicProfile {
    /// This trial's robot, the first draws of a trial from `rng`: the parameters with their
    /// jitter (centre-of-mass depth, pivot friction) and each wheel's rate scale (its radius
    /// error). [`DynamicProfile::trial`] and the closed loop ([`crate::closed_loop`]) both
    /// start a trial with it.
    pub fn draw_robot<R: Rng + ?Sized>(&self, rng: &mut R) -> (SphereDynamics, [f64; 3]) {
        let mut n = || -> f64 { StandardNormal.sample(rng) };
        let mut p = self.params;
        let scale = [0; 3].map(|_| 1.0 + self.radius_error_std * n());
        // Clamped so a far draw cannot leave the physical range (h < R).
        let dh = (self.com_depth_rel_std * n()).clamp(-0.3, 0.3);
        p.com_depth = (p.com_depth * (1.0 + dh)).min(0.95 * p.geometry.shell_radius);
        p.pivot_friction *= (self.pivot_friction_rel_std * n()).clamp(-1.5, 1.5).exp();
        (p, scale)
    }
}

/// The fitted/planned radius of the tracked point's path when `plan` (a circle) runs through
/// the deterministic model `params` ([`simulate_plan`]), by [`fit_circle`] on both paths.
///
/// # Errors
/// The dynamics' error; [`DynamicsError::Input`] when either path is not a circle.
pub fn radius_ratio(params: SphereDynamics, plan: &Plan) -> Result<f64, DynamicsError> {
    let t = simulate_plan(params, plan)?.trial;
    let planned: Vec<[f64; 2]> = plan.samples.iter().map(|s| [s.pose.x, s.pose.y]).collect();
    let not_circle = DynamicsError::Input {
        what: "plan",
        value: plan.samples.len() as f64,
        rule: "a radius ratio needs a plan and a run whose paths are circles",
    };
    match (fit_circle(&t.tracked), fit_circle(&planned)) {
        (Some(f), Some(p)) if p.radius > 0.0 => Ok(f.radius / p.radius),
        _ => Err(not_circle),
    }
}

/// The one fitted parameter of a dynamic profile: what [`fit_com_depth`] found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DynamicFit {
    /// The fitted parameter's name (a `[dynamics]` key of the robot file).
    pub name: &'static str,
    /// Its fitted value (m for `com_depth`).
    pub value: f64,
    /// The series it was fitted on.
    pub fitted_on: String,
    /// The radius ratio it was fitted to.
    pub target_radius_ratio: f64,
    /// The deterministic model's radius ratio with the fitted value.
    pub achieved_radius_ratio: f64,
    /// How: the search, its bracket and its evaluations.
    pub method: String,
}

/// Bracket of [`fit_com_depth`]'s search, m: from a low centre of mass to 0.9 of the preset's
/// 0.15 m shell radius.
pub const COM_DEPTH_BRACKET: (f64, f64) = (0.04, 0.135);

/// Depths of [`fit_com_depth`]'s coarse scan, evenly over [`COM_DEPTH_BRACKET`] (5 mm apart).
pub const FIT_SCAN_POINTS: usize = 20;

/// Bisection iterations of [`fit_com_depth`] inside one 5 mm scan interval: it shrinks to
/// 5 mm / 2^14 ≈ 0.3 µm.
pub const FIT_ITERATIONS: usize = 14;

/// Fits the centre-of-mass depth `h` of `base` so that the deterministic model's radius ratio
/// on `plan` (a circle, named `series`) equals `target`. The ratio is not monotonic in `h` in
/// general (the lean, the start's transient and the contacts pull in different directions), so
/// the search scans [`FIT_SCAN_POINTS`] depths over [`COM_DEPTH_BRACKET`] first, takes the
/// scan interval whose ends straddle `target` nearest to `base.com_depth` (the parts estimate
/// the file held), and bisects inside it ([`FIT_ITERATIONS`] steps). Deterministic.
///
/// # Errors
/// [`DynamicsError::Input`] naming `com_depth` (its value: the scan's ratio nearest to
/// `target`) when no scan interval contains `target`; the dynamics' error at any evaluated
/// depth.
pub fn fit_com_depth(
    base: SphereDynamics,
    plan: &Plan,
    series: &str,
    target: f64,
) -> Result<DynamicFit, DynamicsError> {
    let ratio = |h: f64| {
        let mut p = base;
        p.com_depth = h;
        radius_ratio(p, plan)
    };
    let (a, b) = COM_DEPTH_BRACKET;
    let step = (b - a) / (FIT_SCAN_POINTS - 1) as f64;
    let depths: Vec<f64> = (0..FIT_SCAN_POINTS).map(|k| a + step * k as f64).collect();
    let ratios = depths
        .iter()
        .map(|&h| ratio(h))
        .collect::<Result<Vec<f64>, _>>()?;
    let mut evaluations = FIT_SCAN_POINTS;
    let below = |r: f64| r < target;
    let crossing = (0..FIT_SCAN_POINTS - 1)
        .filter(|&k| below(ratios[k]) != below(ratios[k + 1]))
        .min_by(|&i, &j| {
            let d = |k: usize| (0.5 * (depths[k] + depths[k + 1]) - base.com_depth).abs();
            d(i).total_cmp(&d(j))
        });
    let Some(k) = crossing else {
        let nearest = ratios
            .iter()
            .copied()
            .min_by(|x, y| (x - target).abs().total_cmp(&(y - target).abs()))
            .unwrap_or(f64::NAN);
        return Err(DynamicsError::Input {
            what: "com_depth",
            value: nearest,
            rule: "no centre-of-mass depth in the fit's bracket [0.04, 0.135] m gives the \
                   target radius ratio with the other [dynamics] values as they are (the value \
                   is the scan's ratio nearest to it)",
        });
    };
    let (mut lo, mut hi) = (depths[k], depths[k + 1]);
    let lo_below = below(ratios[k]);
    for _ in 0..FIT_ITERATIONS {
        let mid = 0.5 * (lo + hi);
        evaluations += 1;
        if below(ratio(mid)?) == lo_below {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let value = 0.5 * (lo + hi);
    evaluations += 1;
    let achieved = ratio(value)?;
    Ok(DynamicFit {
        name: "com_depth",
        value,
        fitted_on: series.to_string(),
        target_radius_ratio: target,
        achieved_radius_ratio: achieved,
        method: format!(
            "scan of {FIT_SCAN_POINTS} depths over [{a}, {b}] m, then bisection of the \
             deterministic model's radius ratio on {series} inside [{:.4}, {:.4}] m (the \
             crossing nearest the file's {} m), {evaluations} evaluations",
            depths[k],
            depths[k + 1],
            base.com_depth
        ),
    })
}
