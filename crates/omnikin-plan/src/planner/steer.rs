//! What the planner must know of steerable wheels, through the uniform robot API: the steer
//! state carried along a move ([`Ctx::steer_step`]) — integrated (RK4 of paper 003, eq. 5)
//! for kinds whose steering follows the path (the caster), the inverse's set-points for kinds
//! whose steering is free (a swerve) — the initial configuration aligned with the first
//! motion ([`aligned_steer`], [`super::InitialSteer::Aligned`]) and the finer starting grid
//! step a steering that relaxes over a length needs ([`grid_step`]). Kinds without steering
//! have no steer state, and these return zeros or the default step.

use omnikin::{Actuators, MAX_WHEELS};

use crate::PlanningError;
use crate::robot::RobotModel;

use super::geometry::{Config, Ctx, Hint, Kind, Steer, body_per_speed};
use super::grid::GRID_MIN;

impl Ctx<'_> {
    /// The steer state at `sigma + step` from `gamma` at `sigma`: one RK4 step of
    /// `dγ/dσ = J2(θ, γ) q'(σ)` for a steering that follows the path, or the inverse's
    /// set-points at `sigma + step` with `gamma` as the current angles.
    pub(super) fn steer_step(
        &self,
        kind: &Kind,
        len: f64,
        sigma: f64,
        gamma: Steer,
        step: f64,
        hint: Hint,
    ) -> Result<Steer, PlanningError> {
        if !self.robot.steerable() || step == 0.0 {
            return Ok(gamma);
        }
        if let Some((angles, _)) = kind.resteer_at(len, sigma + step) {
            return Ok(angles);
        }
        if self.set_point {
            let c = self.config(kind, len, sigma + step, hint);
            let a = self
                .robot
                .model
                .inverse(body_per_speed(&c), &Actuators::at_steer(&gamma))?;
            return Ok(a.steer_angles);
        }
        let n = self.robot.wheels();
        let f = |s: f64, g: Steer| -> Result<Steer, PlanningError> {
            let c = self.config(kind, len, s, hint);
            let r = self.rates_per_speed(kind, len, s, &c, &g)?;
            let mut out = [0.0; MAX_WHEELS];
            out[..n].copy_from_slice(&r[n..2 * n]);
            Ok(out)
        };
        let add = |g: Steer, k: Steer, f: f64| -> Steer {
            let mut out = [0.0; MAX_WHEELS];
            for i in 0..n {
                out[i] = g[i] + f * k[i];
            }
            out
        };
        let k1 = f(sigma, gamma)?;
        let k2 = f(sigma + step / 2.0, add(gamma, k1, step / 2.0))?;
        let k3 = f(sigma + step / 2.0, add(gamma, k2, step / 2.0))?;
        let k4 = f(sigma + step, add(gamma, k3, step))?;
        let mut out = [0.0; MAX_WHEELS];
        for i in 0..n {
            out[i] = gamma[i] + step / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        Ok(out)
    }
}

/// The steer angles aligned with the first motion, at configuration `c` (see
/// [`InitialSteer::Aligned`](super::InitialSteer::Aligned) and
/// [`omnikin::Robot::aligned_steer`]).
pub(super) fn aligned_steer(robot: &RobotModel, c: &Config) -> Result<Steer, PlanningError> {
    Ok(robot.model.aligned_steer(body_per_speed(c))?)
}

/// The starting grid step of a move, m or rad: `grid_max` (the timing's coarsest step,
/// [`super::grid::grid_max`]), refined by
/// [`Ctx::build_move`] where `A(σ)` needs it. Steer angles that follow the path change over a
/// length of the order of [`omnikin::Robot::steer_length`] (the caster's eccentricity `d`,
/// paper 003, eq. 5), so the grid then starts at a fifth of it.
pub(super) fn grid_step(robot: &RobotModel, grid_max: f64) -> f64 {
    robot
        .model
        .steer_length()
        .map_or(grid_max, |d| (d / 5.0).clamp(GRID_MIN, grid_max))
}
