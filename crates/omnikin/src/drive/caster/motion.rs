//! What a [`Caster3`] can do with its steering held fixed, and turning in place
//! (paper 003, §3: eqs. (6)–(10)).

use super::{Caster3, CasterRates, STEER, cs};
use crate::real::{finite, finite3};
use crate::{InputError, Real, Twist2};

/// What a three-caster base can do with its steering held fixed (`γ̇ = 0`), paper 003, §3.1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FixedSteerMotion<T> {
    /// All wheels parallel: the base can translate along `direction` (or its reverse), a unit
    /// vector in the **world** frame; the roll motors alone drive it. The sign is chosen so that
    /// `direction` points along wheel 1's direction `β_1`.
    Straight {
        /// Unit world-frame direction of travel of the body centre.
        direction: [T; 2],
    },
    /// All wheel axles meet at one point: the base can turn about that instantaneous centre of
    /// rotation (ICR); the roll motors alone drive it.
    Arc {
        /// World-frame offset `P − C` (m) of the ICR `P` from the body centre `C`.
        icr: [T; 2],
    },
    /// `det J2 ≠ 0`: with the steering held fixed the base cannot move at all.
    Locked,
}

/// Rates for turning in place driven by wheel 1's steer rate (paper 003, eq. (8)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpinInPlace<T> {
    /// The six motor rates, rad/s.
    pub rates: CasterRates<T>,
    /// The resulting yaw rate `θ̇`, rad/s (`ẋ = ẏ = 0`).
    pub yaw_rate: T,
}

impl<T: Real> Caster3<T> {
    /// Motion possible with the steering held fixed (`γ̇ = 0`), paper 003, §3.1 and eq. (6).
    ///
    /// With `γ̇ = J2 q̇ = 0`, the base can move only along the null space of `J2`: if
    /// `det J2 ≠ 0` it is [`FixedSteerMotion::Locked`]; otherwise the null vector (the cross
    /// product of the two most independent rows of `J2`) gives either a straight line (all
    /// wheels parallel, `θ̇ = 0`) or an arc about the common intersection of the wheel axles
    /// (ICR offset `P − C = (−ẏ/θ̇, ẋ/θ̇)`, world frame, m).
    ///
    /// **Tolerance.** The test is made scale-free: each row of `J2` is multiplied by `d` and its
    /// yaw entry divided by `L = D + d`, giving rows `ρ_i = (sin β_i, −cos β_i,
    /// −(D cos γ_i + d)/L)` of norm in `[1, √2]`. `det J2` counts as zero when
    /// `|det[ρ_1; ρ_2; ρ_3]| ≤ √ε · |ρ_1| |ρ_2| |ρ_3|` (ε = machine epsilon of `T`:
    /// `√ε ≈ 1.5e-8` for `f64`, `3.5e-4` for `f32`), i.e. the steer angles must be consistent to
    /// roughly `√ε` rad. The motion is `Straight` when the unit null vector's scaled yaw
    /// component is `≤ √ε` (an ICR farther than `L/√ε`). If `J2` has rank ≤ 1 (every pair of
    /// rows parallel) the null space is two-dimensional and `Straight` along wheel 1 is
    /// reported (arcs are then possible too).
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `"heading"` or `"steer[i]"`.
    pub fn fixed_steer_motion(
        &self,
        heading: T,
        steer: [T; 3],
    ) -> Result<FixedSteerMotion<T>, InputError> {
        finite(heading, "heading")?;
        finite3(steer, STEER)?;
        let beta = self.wheel_directions(heading, steer);
        let p = &self.params;
        let inv_l = T::one() / self.scale;
        let mut rows = [nalgebra::Vector3::zeros(); 3];
        let mut norms = [T::zero(); 3];
        for i in 0..3 {
            let (c, s) = cs(beta[i]);
            let z = -(p.mount_radius * steer[i].cos() + p.eccentricity) * inv_l;
            rows[i] = nalgebra::Vector3::new(s, -c, z);
            norms[i] = rows[i].norm();
        }
        let tol = T::EPSILON.sqrt();
        let det = rows[0].dot(&rows[1].cross(&rows[2]));
        if det.abs() > tol * norms[0] * norms[1] * norms[2] {
            return Ok(FixedSteerMotion::Locked);
        }
        let (cb1, sb1) = cs(beta[0]);
        let straight_along_wheel1 = FixedSteerMotion::Straight {
            direction: [cb1, sb1],
        };
        // The most independent pair of rows gives the null vector.
        let mut best = nalgebra::Vector3::zeros();
        let mut best_rel = T::zero();
        for (i, j) in [(0, 1), (0, 2), (1, 2)] {
            let c = rows[i].cross(&rows[j]);
            let rel = c.norm() / (norms[i] * norms[j]);
            if rel > best_rel {
                best_rel = rel;
                best = c;
            }
        }
        if best_rel <= tol {
            return Ok(straight_along_wheel1);
        }
        let nu = best / best.norm();
        if nu[2].abs() <= tol {
            let planar = (nu[0] * nu[0] + nu[1] * nu[1]).sqrt();
            let mut dir = [nu[0] / planar, nu[1] / planar];
            if dir[0] * cb1 + dir[1] * sb1 < T::zero() {
                dir = [-dir[0], -dir[1]];
            }
            return Ok(FixedSteerMotion::Straight { direction: dir });
        }
        // Null vector = (ẋ, ẏ, L θ̇) up to scale: P − C = (−ẏ/θ̇, ẋ/θ̇) = L (−ν_y, ν_x)/ν_z.
        let k = self.scale / nu[2];
        Ok(FixedSteerMotion::Arc {
            icr: [-nu[1] * k, nu[0] * k],
        })
    }

    /// Turning in place at `yaw_rate = θ̇` (rad/s, `ẋ = ẏ = 0`), paper 003, eq. (7):
    /// `γ̇_i = −(D/d cos γ_i + 1) θ̇`, `φ̇_i = −(D/r) sin γ_i θ̇` (rad/s). Independent of the
    /// heading. The same as [`Caster3::motor_rates`] with a pure yaw twist.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `"steer[i]"` or `"yaw_rate"`.
    pub fn turn_in_place(&self, steer: [T; 3], yaw_rate: T) -> Result<CasterRates<T>, InputError> {
        finite3(steer, STEER)?;
        finite(yaw_rate, "yaw_rate")?;
        Ok(CasterRates {
            roll: steer.map(|g| -self.big_d_over_r * g.sin() * yaw_rate),
            steer: steer.map(|g| -(self.big_d_over_d * g.cos() + T::one()) * yaw_rate),
        })
    }

    /// Turning in place driven by wheel 1's steer rate `γ̇_1 = steer_rate_1` (rad/s), paper 003,
    /// eq. (8): `γ̇_i = γ̇_1 (D/d cos γ_i + 1)/(D/d cos γ_1 + 1)`,
    /// `φ̇_i = γ̇_1 (D/r) sin γ_i/(D/d cos γ_1 + 1)`; the yaw rate is
    /// `θ̇ = −γ̇_1/(D/d cos γ_1 + 1)` (rad/s). Equal to [`Caster3::turn_in_place`] at that yaw
    /// rate.
    ///
    /// # Errors
    /// * [`InputError::NonFinite`] naming `"steer[i]"` or `"steer_rate_1"`;
    /// * [`InputError::Singular`] when `|D/d cos γ_1 + 1| ≤ √ε (D/d + 1)` (i.e.
    ///   `cos γ_1 ≈ −d/D`): wheel 1's steering does not move in a turn in place, so its steer
    ///   rate cannot set the yaw rate.
    pub fn spin_in_place(
        &self,
        steer: [T; 3],
        steer_rate_1: T,
    ) -> Result<SpinInPlace<T>, InputError> {
        finite3(steer, STEER)?;
        finite(steer_rate_1, "steer_rate_1")?;
        let denom = self.big_d_over_d * steer[0].cos() + T::one();
        if denom.abs() <= T::EPSILON.sqrt() * (self.big_d_over_d + T::one()) {
            return Err(InputError::Singular {
                reason: "D/d·cos γ_1 + 1 = 0 (cos γ_1 = −d/D): wheel 1's steer angle does not \
                         change in a turn in place, so its steer rate cannot drive the yaw rate \
                         (paper 003, eq. (8))",
            });
        }
        let yaw_rate = -steer_rate_1 / denom;
        if !yaw_rate.is_finite() {
            return Err(InputError::Singular {
                reason: "the yaw rate −γ̇_1/(D/d·cos γ_1 + 1) overflows (paper 003, eq. (8))",
            });
        }
        let rates = self.turn_in_place(steer, yaw_rate)?;
        Ok(SpinInPlace { rates, yaw_rate })
    }

    /// Translation without rotation (`θ̇ = 0`) driven by wheel 1's two motors, paper 003, eq. (9).
    ///
    /// With `J0(i) = [−cos β_i/r, −sin β_i/r; sin β_i/d, −cos β_i/d]` (`|det J0| = 1/(r d)`,
    /// always invertible): `[ẋ; ẏ] = J0(1)⁻¹ [φ̇_1; γ̇_1]`, i.e.
    /// `ẋ = −r cos β_1 φ̇_1 + d sin β_1 γ̇_1`, `ẏ = −r sin β_1 φ̇_1 − d cos β_1 γ̇_1`, and the
    /// other wheels follow `[φ̇_j; γ̇_j] = J0(j) [ẋ; ẏ]`.
    ///
    /// Inputs: heading `θ` and steer angles `γ` (rad), `roll_rate_1 = φ̇_1` and
    /// `steer_rate_1 = γ̇_1` (rad/s). Returns the **world-frame** twist `(ẋ, ẏ, 0)` (m/s) and all
    /// six motor rates (wheel 1's are the inputs, unchanged).
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `"heading"`, `"steer[i]"`, `"roll_rate_1"` or
    /// `"steer_rate_1"`.
    pub fn translation_from_wheel1(
        &self,
        heading: T,
        steer: [T; 3],
        roll_rate_1: T,
        steer_rate_1: T,
    ) -> Result<(Twist2<T>, CasterRates<T>), InputError> {
        finite(heading, "heading")?;
        finite3(steer, STEER)?;
        finite(roll_rate_1, "roll_rate_1")?;
        finite(steer_rate_1, "steer_rate_1")?;
        let p = &self.params;
        let beta = self.wheel_directions(heading, steer);
        let (c1, s1) = cs(beta[0]);
        let (u, w) = (p.wheel_radius * roll_rate_1, p.eccentricity * steer_rate_1);
        let vx = -c1 * u + s1 * w;
        let vy = -s1 * u - c1 * w;
        // [φ̇_j; γ̇_j] = J0(j) [ẋ; ẏ]; wheel 1's rates are the inputs themselves.
        let roll = beta.map(|b| {
            let (c, s) = cs(b);
            (-c * vx - s * vy) * self.inv_r
        });
        let steer_rates = beta.map(|b| {
            let (c, s) = cs(b);
            (s * vx - c * vy) * self.inv_d
        });
        let rates = CasterRates {
            roll: [roll_rate_1, roll[1], roll[2]],
            steer: [steer_rate_1, steer_rates[1], steer_rates[2]],
        };
        let twist = Twist2::new(vx, vy, T::zero());
        if !twist.is_finite() || !roll.iter().chain(&steer_rates).all(|x| x.is_finite()) {
            return Err(InputError::Singular {
                reason: "the translation rates overflow the scalar type (paper 003, eq. (9))",
            });
        }
        Ok((twist, rates))
    }
}
