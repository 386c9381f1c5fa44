//! The geometry of a move, independent of its timing: what a move is ([`Kind`]: travel along
//! the path or turn in place), its configuration `q(σ) = (x, y, ψ)` and derivative `q'(σ)`
//! at a parameter ([`Config`], from [`Ctx::config`]), the unwrapped heading near a hint
//! ([`Hint`]), and the motor rates per unit `σ̇`, `A(σ)` ([`Ctx::rates_per_speed`]), with the
//! robot-frame twist's derivative along the move a swerve's steer rates need
//! ([`Ctx::twist_rate_per_speed`]).

use omnikin::{Actuators, MAX_WHEELS, Pose2, Twist2};

use crate::PlanningError;
use crate::heading::{HeadingLaw, Side};
use crate::path::Path;
use crate::robot::MAX_CHANNELS;
use crate::robot::RobotModel;
use omnikin::wrap_angle;

/// Configuration and its derivative with respect to the move parameter.
#[derive(Clone, Copy, Debug)]
pub(super) struct Config {
    pub(super) pose: Pose2<f64>,
    /// `(cos ψ, sin ψ)` of the heading (from the tangent for the tangent law, so the grid needs
    /// no trigonometry).
    pub(super) cs: [f64; 2],
    /// `q'(σ) = (dx/dσ, dy/dσ, dψ/dσ)`.
    pub(super) dq: [f64; 3],
    /// The path piece the point is on (travel moves).
    pub(super) piece: Option<usize>,
}

#[derive(Clone, Debug)]
pub(super) enum Kind {
    Travel {
        s0: f64,
        s1: f64,
    },
    Turn {
        x: f64,
        y: f64,
        psi0: f64,
        dir: f64,
    },
    /// A re-steer at rest (set-point steering, swerve): the modules turn from `from` by
    /// `delta` (rad each, shortest way) while the robot stands at `(x, y, ψ)`; `σ` is the
    /// largest module's turned angle (rad), so `len = max_i |Δ_i|` and `γ(σ) = from + Δ σ/len`.
    Resteer {
        x: f64,
        y: f64,
        psi: f64,
        from: Steer,
        delta: Steer,
    },
}

impl Kind {
    /// The steer angles of a re-steer at `sigma` of a move of length `len` (wrapped into
    /// `(−π, π]`), and the steer rates per unit `σ̇`; `None` for the other kinds.
    pub(super) fn resteer_at(&self, len: f64, sigma: f64) -> Option<(Steer, Steer)> {
        let Kind::Resteer { from, delta, .. } = self else {
            return None;
        };
        let f = (sigma / len).clamp(0.0, 1.0);
        let angles = core::array::from_fn(|i| {
            if delta[i] == 0.0 && from[i] == 0.0 {
                0.0
            } else {
                wrap_angle(from[i] + delta[i] * f)
            }
        });
        Some((angles, core::array::from_fn(|i| delta[i] / len)))
    }
}

pub(super) struct Ctx<'a> {
    pub(super) path: &'a Path,
    pub(super) heading: &'a HeadingLaw,
    pub(super) robot: &'a RobotModel,
    /// `(cos, sin)` of the tangent law's offset, or of the constant heading.
    pub(super) heading_cs: [f64; 2],
    /// The robot's steer angles are set-points ([`omnikin::Kind::steer_is_set_point`]: a
    /// swerve's follow the twist) rather than a state integrated along the path (the caster).
    pub(super) set_point: bool,
    /// Interpolation tolerance of the move grids ([`super::grid::grid_tol`] of the timing).
    pub(super) grid_tol: f64,
    /// Coarsest cell of the move grids ([`super::grid::grid_max`] of the timing), m or rad.
    pub(super) grid_max: f64,
    /// The wheel rates per unit robot-frame twist of a robot without steering
    /// ([`linear_inverse`]), `None` for steerable kinds.
    pub(super) linear: Option<Linear>,
}

/// The inverse kinematics of a robot without steering as a matrix: wheel `i`'s rate (rad/s)
/// is `row_i · (v_x, v_y, ω)` of the robot-frame twist (m/s, m/s, rad/s); rows past `N` zero.
#[derive(Clone, Copy, Debug)]
pub(super) struct Linear {
    rows: [[f64; 3]; MAX_WHEELS],
    /// The number of wheels `N`.
    n: usize,
}

/// The core inverse kinematics of `robot` as a [`Linear`] matrix, from its answers to the
/// three unit twists, if it has no steering and the matrix reproduces the core's answer to
/// two other twists within 1e-13 (relative): every kind without steering is linear in the
/// twist (paper 000, eqs. 5.6–5.7; paper 001's ballbot; the omni and mecanum matrices), so the
/// planner's grid and samples need three products per wheel instead of the core call with its
/// uniform actuator values. `None` otherwise, and the planner calls the core.
pub(super) fn linear_inverse(robot: &RobotModel) -> Option<Linear> {
    if robot.steerable() {
        return None;
    }
    let n = robot.wheels();
    let rates = |t: Twist2<f64>| robot.model.inverse(t, &AT_REST).ok().map(|a| a.wheel_rates);
    let mut m = [[0.0; 3]; MAX_WHEELS];
    for (j, t) in [
        Twist2::new(1.0, 0.0, 0.0),
        Twist2::new(0.0, 1.0, 0.0),
        Twist2::new(0.0, 0.0, 1.0),
    ]
    .into_iter()
    .enumerate()
    {
        let w = rates(t)?;
        for i in 0..n {
            m[i][j] = w[i];
        }
    }
    for t in [Twist2::new(0.37, -1.3, 0.71), Twist2::new(-2.1, 0.4, -3.3)] {
        let w = rates(t)?;
        for i in 0..n {
            let lin = m[i][0] * t.vx + m[i][1] * t.vy + m[i][2] * t.yaw_rate;
            let off = (lin - w[i]).abs();
            if off.is_nan() || off > 1e-13 * (1.0 + w[i].abs()) {
                return None;
            }
        }
    }
    Some(Linear { rows: m, n })
}

impl Linear {
    /// Wheel rates (rad/s, entries past `N` zero) for the world-frame velocity `dq`
    /// (`ẋ, ẏ, ψ̇`) at heading `(cos ψ, sin ψ) = cs`: the robot-frame twist
    /// `(c ẋ + s ẏ, −s ẋ + c ẏ, ψ̇)`, then the matrix. `None` if a rate is not finite, so the
    /// caller's core call names the value.
    #[inline(always)]
    pub(super) fn wheel_rates(&self, cs: [f64; 2], dq: [f64; 3]) -> Option<[f64; MAX_WHEELS]> {
        let [c, s] = cs;
        let (vx, vy) = (c * dq[0] + s * dq[1], -s * dq[0] + c * dq[1]);
        let mut out = [0.0; MAX_WHEELS];
        for (w, r) in out.iter_mut().zip(&self.rows[..self.n]) {
            *w = r[0] * vx + r[1] * vy + r[2] * dq[2];
        }
        out.iter().sum::<f64>().is_finite().then_some(out)
    }

    /// [`Linear::wheel_rates`] and their derivative along the move, `A'(σ)`, from `q''(σ)`
    /// = `ddq` ([`Ctx::config_with_rate`]): the robot-frame twist per unit speed
    /// `b = (c ẋ + s ẏ, −s ẋ + c ẏ, ψ')` has the derivative
    /// `b' = (c ẍ + s ÿ + ψ' b_y, −s ẍ + c ÿ − ψ' b_x, ψ'')` (`c, s` turn with `ψ'`), and the
    /// wheel rates are linear in it. `None` if a value is not finite.
    #[inline(always)]
    pub(super) fn wheel_rates_with_rate(
        &self,
        cs: [f64; 2],
        dq: [f64; 3],
        ddq: [f64; 3],
    ) -> Option<([f64; MAX_WHEELS], [f64; MAX_WHEELS])> {
        let [c, s] = cs;
        let (vx, vy) = (c * dq[0] + s * dq[1], -s * dq[0] + c * dq[1]);
        let (dvx, dvy) = (
            c * ddq[0] + s * ddq[1] + dq[2] * vy,
            -s * ddq[0] + c * ddq[1] - dq[2] * vx,
        );
        let mut a = [0.0; MAX_WHEELS];
        let mut b = [0.0; MAX_WHEELS];
        for ((w, d), r) in a.iter_mut().zip(b.iter_mut()).zip(&self.rows[..self.n]) {
            *w = r[0] * vx + r[1] * vy + r[2] * dq[2];
            *d = r[0] * dvx + r[1] * dvy + r[2] * ddq[2];
        }
        let sum = a.iter().sum::<f64>() + b.iter().sum::<f64>();
        sum.is_finite().then_some((a, b))
    }
}

/// Steer angles `γ_i` of a steer state (rad), entries `0..N` used (0 for kinds without
/// steering).
pub(super) type Steer = [f64; MAX_WHEELS];

/// The actuators at rest with the steering at 0: the `current` state of kinds without
/// steering, whose inverse does not read it.
pub(super) static AT_REST: Actuators<f64> = Actuators {
    wheel_rates: [0.0; MAX_WHEELS],
    steer_angles: [0.0; MAX_WHEELS],
    steer_rates: [0.0; MAX_WHEELS],
};

/// An unwrapped heading `ψ` (rad) near the one sought, with `(cos ψ, sin ψ)` when known.
#[derive(Clone, Copy, Debug)]
pub(super) struct Hint {
    pub(super) psi: f64,
    pub(super) cs: Option<[f64; 2]>,
    /// The path piece the answer is likely on (that of a neighbouring node), if known.
    pub(super) piece: Option<usize>,
}

impl Hint {
    pub(super) fn angle(psi: f64) -> Self {
        Self {
            psi,
            cs: None,
            piece: None,
        }
    }

    pub(super) fn of(c: &Config) -> Self {
        Self {
            psi: c.pose.heading,
            cs: Some(c.cs),
            piece: c.piece,
        }
    }

    /// The unwrapped angle of the unit vector `dir` within ±π of the hint: from the angle
    /// between the two, `δ = asin(h × d)`, by its series when it is below 0.2 rad
    /// (`h·d > 0.98`, so `|h × d| < 0.199`: the terms to `x²³` leave < 1e-19 rad), as between
    /// neighbouring grid nodes and from a node to the samples in its cell; by `atan2`
    /// otherwise. (The sine's series needs no division, unlike `2 atan((h × d)/(1 + h·d))`:
    /// a shorter dependency chain for every path point on the tangent law.)
    pub(super) fn unwrap(self, dir: [f64; 2]) -> f64 {
        if let Some([c, s]) = self.cs {
            let dot = c * dir[0] + s * dir[1];
            if dot > 0.98 {
                let x = c * dir[1] - s * dir[0];
                // asin x = x Σ aₖ zᵏ, aₖ = (2k)! / (4ᵏ (k!)² (2k + 1)), z = x², k = 0…11, in
                // Estrin's form (pairs of terms in parallel).
                const A: [f64; 12] = [
                    1.0,
                    1.0 / 6.0,
                    3.0 / 40.0,
                    5.0 / 112.0,
                    35.0 / 1152.0,
                    63.0 / 2816.0,
                    231.0 / 13312.0,
                    143.0 / 10240.0,
                    6435.0 / 557056.0,
                    12155.0 / 1245184.0,
                    46189.0 / 5505024.0,
                    88179.0 / 12058624.0,
                ];
                let z = x * x;
                let (z2, pair) = (z * z, |k: usize| A[k] + A[k + 1] * z);
                let (z4, z8) = (z2 * z2, z2 * z2 * (z2 * z2));
                let sum = (pair(0) + z2 * pair(2))
                    + z4 * (pair(4) + z2 * pair(6))
                    + z8 * (pair(8) + z2 * pair(10));
                return self.psi + x * sum;
            }
        }
        self.psi + wrap_angle(dir[1].atan2(dir[0]) - self.psi)
    }
}

impl Ctx<'_> {
    /// Configuration at parameter `sigma` of a move; `hint` is an unwrapped heading within
    /// ±π of the answer (for the tangent law).
    pub(super) fn config(&self, kind: &Kind, len: f64, sigma: f64, hint: Hint) -> Config {
        self.config_at::<false>(kind, len, sigma, hint).0
    }

    /// [`Ctx::config`] and the second derivative `q''(σ) = (d²x/dσ², d²y/dσ², d²ψ/dσ²)`: on
    /// the path the tangent's rate `κ n` (`n` the left normal) and the heading law's `ψ''`
    /// (the tangent law's `dκ/ds`, a heading profile's spline value, 0 for a constant), 0 for
    /// a turn in place (constant rate) and a re-steer at rest. At a join it is the same side's
    /// as the configuration's, where the curvature's rate may jump.
    pub(super) fn config_with_rate(
        &self,
        kind: &Kind,
        len: f64,
        sigma: f64,
        hint: Hint,
    ) -> (Config, [f64; 3]) {
        self.config_at::<true>(kind, len, sigma, hint)
    }

    /// [`Ctx::config`], and with `RATE` [`Ctx::config_with_rate`]'s `q''` (zeros without).
    #[inline(always)]
    fn config_at<const RATE: bool>(
        &self,
        kind: &Kind,
        len: f64,
        sigma: f64,
        hint: Hint,
    ) -> (Config, [f64; 3]) {
        match *kind {
            Kind::Travel { s0, s1 } => {
                // The end is evaluated exactly at `s1` on the incoming side (`s0 + len` can
                // round past a join and pick the next piece's direction).
                let s = s0 + sigma.max(0.0);
                let (s, side) = if sigma >= len || s >= s1 {
                    (s1, Side::Before)
                } else {
                    (s, Side::After)
                };
                // Inside the piece of a neighbouring node no piece search is needed.
                let (piece, (p, dk)) = if RATE {
                    match hint
                        .piece
                        .and_then(|k| self.path.inside_piece_with_rate(k, s))
                    {
                        Some(p) => (hint.piece, p),
                        None => {
                            let (k, p) = self.path.at_side_piece_with_rate(s, side);
                            (Some(k), p)
                        }
                    }
                } else {
                    match hint.piece.and_then(|k| self.path.inside_piece(k, s)) {
                        Some(p) => (hint.piece, (p, 0.0)),
                        None => {
                            let (k, p) = self.path.at_side_piece(s, side);
                            (Some(k), (p, 0.0))
                        }
                    }
                };
                let (psi, cs, dpsi, ddpsi) = match self.heading {
                    HeadingLaw::Constant(c) => (*c, self.heading_cs, 0.0, 0.0),
                    HeadingLaw::Tangent { .. } => {
                        let [c, s] = self.heading_cs;
                        let [tx, ty] = p.tangent;
                        let d = [c * tx - s * ty, s * tx + c * ty];
                        (hint.unwrap(d), d, p.curvature, dk)
                    }
                    HeadingLaw::Profile(prof) => {
                        let (psi, dpsi, ddpsi) = if RATE {
                            prof.at_with_second(s, side)
                        } else {
                            let (psi, dpsi) = prof.at(s, side);
                            (psi, dpsi, 0.0)
                        };
                        let (s, c) = psi.sin_cos();
                        (psi, [c, s], dpsi, ddpsi)
                    }
                };
                let [tx, ty] = p.tangent;
                let k = p.curvature;
                let config = Config {
                    pose: Pose2::new(p.point[0], p.point[1], psi),
                    cs,
                    dq: [tx, ty, dpsi],
                    piece,
                };
                (config, [-k * ty, k * tx, ddpsi])
            }
            Kind::Turn { x, y, psi0, dir } => {
                let psi = psi0 + dir * sigma.clamp(0.0, len);
                let (s, c) = psi.sin_cos();
                let config = Config {
                    pose: Pose2::new(x, y, psi),
                    cs: [c, s],
                    dq: [0.0, 0.0, dir],
                    piece: None,
                };
                (config, [0.0; 3])
            }
            Kind::Resteer { x, y, psi, .. } => {
                let (s, c) = psi.sin_cos();
                let config = Config {
                    pose: Pose2::new(x, y, psi),
                    cs: [c, s],
                    dq: [0.0, 0.0, 0.0],
                    piece: None,
                };
                (config, [0.0; 3])
            }
        }
    }

    /// Motor rates per unit `σ̇` (the columns `A(σ)`, channels as in [`RobotModel::channel`]):
    /// wheel rates, and steer rates per unit speed (`dγ/dσ`) of steerable kinds, at the steer
    /// state `gamma` (the caster's integrated angles; a swerve's set-points at `c`). For kinds
    /// whose steer angles are set-points the robot-frame twist's derivative along the move
    /// ([`Ctx::twist_rate_per_speed`]) fixes the steer rates.
    pub(super) fn rates_per_speed(
        &self,
        kind: &Kind,
        len: f64,
        sigma: f64,
        c: &Config,
        gamma: &Steer,
    ) -> Result<[f64; MAX_CHANNELS], PlanningError> {
        if let Some((_, per_speed)) = kind.resteer_at(len, sigma) {
            // At rest: no wheel motion, the steer motors at `Δ_i / len` per unit `σ̇`.
            let n = self.robot.wheels();
            let mut out = [0.0; MAX_CHANNELS];
            out[n..2 * n].copy_from_slice(&per_speed[..n]);
            return Ok(out);
        }
        if let Some(w) = self.linear.as_ref().and_then(|m| m.wheel_rates(c.cs, c.dq)) {
            let mut out = [0.0; MAX_CHANNELS];
            out[..MAX_WHEELS].copy_from_slice(&w);
            return Ok(out);
        }
        let rate = if self.set_point {
            self.twist_rate_per_speed(kind, len, sigma, c)
        } else {
            Twist2::new(0.0, 0.0, 0.0)
        };
        let steer;
        let current = if self.robot.steerable() {
            steer = Actuators::at_steer(gamma);
            &steer
        } else {
            &AT_REST
        };
        let a =
            self.robot
                .actuators_cs(c.cs, Twist2::new(c.dq[0], c.dq[1], c.dq[2]), rate, current)?;
        Ok(self.robot.channel_values(&a))
    }

    /// `d b/dσ`, the derivative along the move of the robot-frame twist per unit speed
    /// `b(σ) = (Q(ψ)ᵀ (dx/dσ, dy/dσ), dψ/dσ)`, by a central difference over ±[`DIFF_STEP`]
    /// (one-sided at the ends of the move). At speed `σ̇` and path acceleration `σ̈` the
    /// robot-frame twist rate is `b' σ̇² + b σ̈`.
    pub(super) fn twist_rate_per_speed(
        &self,
        kind: &Kind,
        len: f64,
        sigma: f64,
        c: &Config,
    ) -> Twist2<f64> {
        let lo = (sigma - DIFF_STEP).max(0.0);
        let hi = (sigma + DIFF_STEP).min(len);
        if hi <= lo {
            return Twist2::new(0.0, 0.0, 0.0);
        }
        let hint = Hint::of(c);
        let b0 = body_per_speed(&self.config(kind, len, lo, hint));
        let b1 = body_per_speed(&self.config(kind, len, hi, hint));
        let inv = 1.0 / (hi - lo);
        Twist2::new(
            (b1.vx - b0.vx) * inv,
            (b1.vy - b0.vy) * inv,
            (b1.yaw_rate - b0.yaw_rate) * inv,
        )
    }
}

/// Half-width of the central difference of [`Ctx::twist_rate_per_speed`] (m or rad).
pub(super) const DIFF_STEP: f64 = 1e-5;

/// The robot-frame twist per unit speed of a configuration, `(Q(ψ)ᵀ (dx/dσ, dy/dσ), dψ/dσ)`.
pub(super) fn body_per_speed(c: &Config) -> Twist2<f64> {
    let [co, si] = c.cs;
    Twist2::new(
        co * c.dq[0] + si * c.dq[1],
        -si * c.dq[0] + co * c.dq[1],
        c.dq[2],
    )
}
