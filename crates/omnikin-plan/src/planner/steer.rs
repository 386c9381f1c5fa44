//! What the planner must know of a caster base's steerable wheels (paper 003): the steer
//! angles integrated along a move ([`Ctx::steer_step`], RK4 of eq. 5), the trailing initial
//! configuration ([`aligned_steer`], [`super::InitialSteer::Aligned`]) and the finer starting
//! grid step its eccentricity needs ([`grid_step`]). Every other robot has no steer angles,
//! and these return zeros or the default step.

use omnikin::Robot;

use crate::PlanningError;
use crate::robot::RobotModel;
use omnikin::wrap_angle;

use super::geometry::{Config, Ctx, Hint, Kind};
use super::grid::{GRID_MAX, GRID_MIN};

impl Ctx<'_> {
    /// One RK4 step of `dγ/dσ = J2(θ, γ) q'(σ)` from `(sigma, gamma)` by `step`.
    pub(super) fn steer_step(
        &self,
        kind: &Kind,
        len: f64,
        sigma: f64,
        gamma: [f64; 3],
        step: f64,
        hint: Hint,
    ) -> Result<[f64; 3], PlanningError> {
        if !self.robot.is_caster() || step == 0.0 {
            return Ok(gamma);
        }
        let f = |s: f64, g: [f64; 3]| -> Result<[f64; 3], PlanningError> {
            let c = self.config(kind, len, s, hint);
            let r = self.rates_per_speed(&c, g)?;
            Ok([r[3], r[4], r[5]])
        };
        let add =
            |g: [f64; 3], k: [f64; 3], f: f64| [g[0] + f * k[0], g[1] + f * k[1], g[2] + f * k[2]];
        let k1 = f(sigma, gamma)?;
        let k2 = f(sigma + step / 2.0, add(gamma, k1, step / 2.0))?;
        let k3 = f(sigma + step / 2.0, add(gamma, k2, step / 2.0))?;
        let k4 = f(sigma + step, add(gamma, k3, step))?;
        Ok(core::array::from_fn(|i| {
            gamma[i] + step / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        }))
    }
}

/// The steer angles of the trailing configuration for the first motion (see
/// [`InitialSteer::Aligned`](super::InitialSteer::Aligned)).
pub(super) fn aligned_steer(robot: &RobotModel, c: &Config) -> [f64; 3] {
    let Robot::Caster(m) = &robot.model else {
        return [0.0; 3];
    };
    let p = m.params();
    let th = c.pose.heading;
    core::array::from_fn(|i| {
        let (sa, ca) = (p.mount_angles[i] + th).sin_cos();
        let vf = [
            c.dq[0] - c.dq[2] * p.mount_radius * sa,
            c.dq[1] + c.dq[2] * p.mount_radius * ca,
        ];
        let speed = vf[0].hypot(vf[1]);
        if speed < 1e-12 {
            return 0.0;
        }
        let chi = vf[1].atan2(vf[0]);
        let rho = (c.dq[2] * p.eccentricity / speed).clamp(-1.0, 1.0);
        let beta = chi + std::f64::consts::PI - rho.asin();
        wrap_angle(beta - p.mount_angles[i] - th)
    })
}

/// The starting grid step of a move, m or rad: [`GRID_MAX`], refined by
/// [`Ctx::build_move`] where `A(σ)` needs it. The caster's steer angles change over a length
/// of the order of its eccentricity `d` (paper 003, eq. 5), so its grid starts at `d/5`.
pub(super) fn grid_step(robot: &RobotModel) -> f64 {
    match &robot.model {
        Robot::Caster(m) => (m.params().eccentricity / 5.0).clamp(GRID_MIN, GRID_MAX),
        _ => GRID_MAX,
    }
}
