//! Inverse and forward kinematics of a [`Caster3`]: motor rates from a twist
//! (paper 003, eqs. (2), (4), (5)) and the least-squares twist, with its slip residuals,
//! from six motor rates.

use super::{Caster3, CasterForward, CasterRates, ROLL_RATES, STEER, STEER_RATES, WheelTrig, cs};
use crate::drive::Rot2;
use crate::real::{finite, finite3};
use crate::{InputError, Real, Twist2};

impl<T: Real> Caster3<T> {
    /// Inverse kinematics (paper 003, eqs. (2), (4), (5)): the roll and steer rates (rad/s) that
    /// move the base with the **world-frame** twist `twist_world` (m/s, m/s, rad/s) at heading
    /// `θ = heading` (rad) with steer angles `steer = γ` (rad), without slip:
    /// `φ̇_i = (−cos β_i ẋ − sin β_i ẏ − D sin γ_i θ̇)/r`,
    /// `γ̇_i = (sin β_i ẋ − cos β_i ẏ − (D cos γ_i + d) θ̇)/d`.
    ///
    /// Always solvable (every twist is reachable from every steer state). No limits applied.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `"vx"`, `"vy"`, `"yaw_rate"`, `"heading"` or
    /// `"steer[i]"`; [`InputError::Overflow`] when finite inputs give non-finite rates.
    pub fn motor_rates(
        &self,
        twist_world: Twist2<T>,
        heading: T,
        steer: [T; 3],
    ) -> Result<CasterRates<T>, InputError> {
        // One libm sin_cos per angle, not the four-lane `Real::sin_cos4`: the six rates follow
        // the trigonometry by two short products, so the call's time is the trigonometry's
        // latency, which four independent libm calls overlap better (measured on the peer
        // bench: 28–29 ns with 510 instructions, against 35 ns with 472).
        let rot = Rot2::from_angle(heading);
        let steer_cs = steer.map(cs);
        let out = self
            .inverse_rows(rot, steer_cs)
            .rates_unchecked(twist_world);
        // A non-finite input makes every rate of its rows non-finite (`sin_cos` of a non-finite
        // angle is NaN, and each rate has every twist component times a finite coefficient), so
        // one test of the six rates covers the usual call; only a failure pays for naming the
        // field, with the same precedence as checking the inputs first.
        let sum =
            out.roll[0] + out.roll[1] + out.roll[2] + out.steer[0] + out.steer[1] + out.steer[2];
        if !sum.is_finite() {
            twist_world.check_finite()?;
            finite(heading, "heading")?;
            finite3(steer, STEER)?;
            crate::real::finite_out(out.roll, "roll rates")?;
            crate::real::finite_out(out.steer, "steer rates")?;
        }
        Ok(out)
    }

    /// The rows of `J1` and `J2` (paper 003, eq. (2); see `j1_row`, `j2_row`) at the heading's
    /// rotation `rot` and steer angles `steer` (rad): what [`Caster3::motor_rates`] computes
    /// before applying them to the twist, kept to apply to many twists at one steer state.
    #[inline]
    pub(crate) fn inverse_rows(&self, rot: Rot2<T>, steer_cs: [(T, T); 3]) -> CasterInverseRows<T> {
        let trig = self.wheel_trig(rot, steer_cs);
        let wheel = |w: &WheelTrig<T>| {
            (
                [
                    -w.cb * self.inv_r,
                    -w.sb * self.inv_r,
                    -self.big_d_over_r * w.sg,
                ],
                [
                    w.sb * self.inv_d,
                    -w.cb * self.inv_d,
                    -self.big_d_over_d * w.cg - T::one(),
                ],
            )
        };
        let (r0, r1, r2) = (wheel(&trig[0]), wheel(&trig[1]), wheel(&trig[2]));
        CasterInverseRows {
            roll: [r0.0, r1.0, r2.0],
            steer: [r0.1, r1.1, r2.1],
        }
    }

    /// The inverse kinematics in the **robot frame** at fixed steer angles `steer` (rad): the
    /// six rates of many twists at one steer state (a vectorised `inverse` with one steer row)
    /// for the trigonometry of one. [`CasterInverseRows::motor_rates`] of a twist equals
    /// [`Caster3::motor_rates`]`(twist, 0, steer)` exactly.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `"steer[i]"`.
    pub fn robot_frame_inverse(&self, steer: [T; 3]) -> Result<CasterInverseRows<T>, InputError> {
        finite3(steer, STEER)?;
        // The same trigonometry as `motor_rates` (one libm sin_cos per angle), so the rows
        // give its rates exactly.
        let (rot, steer_cs) = (Rot2::identity(), steer.map(cs));
        Ok(self.inverse_rows(rot, steer_cs))
    }

    /// Forward kinematics: the **world-frame** twist `(ẋ, ẏ, θ̇)` (m/s, m/s, rad/s) that best
    /// explains all six measured motor rates (rad/s) at heading `θ` and steer angles `γ` (rad).
    ///
    /// The six equations of paper 003, eq. (2) are weighted to physical units — each `J1` row
    /// by `r`, each `J2` row by `d`:
    /// `r φ̇_i = (−cos β_i, −sin β_i, −D sin γ_i)·q̇`,
    /// `d γ̇_i = (sin β_i, −cos β_i, −(D cos γ_i + d))·q̇` — and solved by least squares through
    /// the 3×3 normal equations. Per wheel these two weighted rows are an orthogonal transform of
    /// `v_C + θ̇ k × (O_i − C)`, so the normal equations reduce to a rigid-velocity fit, solved
    /// here in closed form (Schur complement): with `p_i = O_i − C`, the implied point velocities
    /// `m_i = (−r φ̇_i cos β_i + d γ̇_i sin β_i, −r φ̇_i sin β_i − d γ̇_i cos β_i)` (the first two
    /// columns of `M_i`, paper 003, eq. (1)), and bars for means over the wheels:
    /// `θ̇ = Σ (p_i − p̄) × (m_i − m̄) / Σ |p_i − p̄|²`, `v_C = m̄ − θ̇ k × p̄`.
    ///
    /// The residuals are velocities in m/s (see [`CasterForward`]).
    ///
    /// The wheel directions are taken as the rounded sums `α_i + γ_i`, so an angle's error is
    /// half an ulp of the sum: ≈ 10^-15 rad for steer angles within a few turns, 7·10^-12 rad
    /// at 10^5 rad (in `f32`, up to 2.4·10^-7 rad between 4 and 8 rad). A steer encoder that
    /// counts turns without bound is better wrapped before the call.
    ///
    /// # Errors
    /// * [`InputError::NonFinite`] naming `"roll_rates[i]"`, `"steer_rates[i]"`, `"heading"` or
    ///   `"steer[i]"`;
    /// * [`InputError::Singular`] when the three wheel centres `O_i` (nearly) coincide, so the
    ///   yaw rate is unobservable: `Σ |p_i − p̄|² ≤ 1000 ε (D + d)²`. This is possible only when
    ///   `d = D` and every `γ_i = π`.
    // Inlined into the caller (a control loop's call costs about 400 instructions; out of line
    // its prologue, the result's trip through memory and the caller's unwrap were 16–20 more).
    #[inline(always)]
    pub fn body_twist(
        &self,
        rates: &CasterRates<T>,
        heading: T,
        steer: [T; 3],
    ) -> Result<CasterForward<T>, InputError> {
        // The fit is done in the robot frame on the precomputed steering-axis geometry and the
        // twist turned into the world frame after (the residuals' magnitudes do not depend on
        // the frame). A non-finite input always ends in a non-finite twist, which the fit
        // reports as an error, so the inputs are tested — in the documented order, before any
        // error of the fit — only when the fit fails or the heading is not finite.
        let (dir, rot) = self.robot_directions(steer, heading);
        let fit = self.fit(self.mount_centred, self.mount_mean, dir, rates);
        if fit.is_err() || !heading.is_finite() {
            finite3(rates.roll, ROLL_RATES)?;
            finite3(rates.steer, STEER_RATES)?;
            finite(heading, "heading")?;
            finite3(steer, STEER)?;
        }
        let f = fit?;
        let twist = f.twist.rotated_by(rot);
        // The yaw rate is the fit's, already tested; the rotated velocity's sum is one test.
        if !(twist.vx + twist.vy).is_finite() && !twist.is_finite() {
            return Err(InputError::Singular {
                reason: "the least-squares twist overflows: motor rates too large for the scalar type",
            });
        }
        Ok(CasterForward { twist, ..f })
    }

    /// Forward kinematics in the **robot** frame: the twist `(v_x, v_y, θ̇)` of the body centre
    /// (m/s, m/s, rad/s, robot axes) that best explains all six motor rates (rad/s) at steer
    /// angles `γ` (rad) — [`Caster3::body_twist`] without the turn into the world frame, so it
    /// needs no heading (paper 003, eqs. (1), (2); the same least-squares fit, on the
    /// steering-axis geometry precomputed at construction: one four-lane `Real::sin_cos4` of the
    /// wheel directions `α_i + γ_i`, the fourth lane idle).
    /// The counterpart of WPILib's `SwerveDriveKinematics::ToChassisSpeeds`, whose chassis
    /// speeds are robot-relative too.
    ///
    /// # Errors
    /// * [`InputError::NonFinite`] naming `"roll_rates[i]"`, `"steer_rates[i]"` or
    ///   `"steer[i]"`, in that order of precedence;
    /// * [`InputError::Singular`] as for [`Caster3::body_twist`].
    // Inlined into the caller, as `body_twist`.
    #[inline(always)]
    pub fn robot_twist(
        &self,
        rates: &CasterRates<T>,
        steer: [T; 3],
    ) -> Result<CasterForward<T>, InputError> {
        // A non-finite input always ends in a non-finite twist, which the fit reports as an
        // error: the inputs are tested (in the documented order) only then.
        let fit = self.body_twist_robot_unchecked(rates, steer);
        if fit.is_err() {
            finite3(rates.roll, ROLL_RATES)?;
            finite3(rates.steer, STEER_RATES)?;
            finite3(steer, STEER)?;
        }
        fit
    }

    /// [`Caster3::body_twist`] at heading `θ = 0`, i.e. the least-squares twist in the **robot**
    /// frame (m/s, m/s, rad/s, or m, m, rad for angle increments), for callers that have
    /// already checked their inputs (the odometry step, which feeds encoder increments as
    /// rates): `rates` in rad/s (or rad), `steer` = `γ_i` in rad, all finite (not checked here;
    /// non-finite input gives non-finite output or an error). The steering-axis geometry is
    /// precomputed, so the only trigonometry is one four-lane `sin_cos4` of the wheel directions; the fit is the
    /// same as `body_twist`'s (paper 003, eqs. (1), (2)), equal to it to rounding.
    ///
    /// # Errors
    /// [`InputError::Singular`] as for [`Caster3::body_twist`].
    #[inline]
    pub(crate) fn body_twist_robot_unchecked(
        &self,
        rates: &CasterRates<T>,
        steer: [T; 3],
    ) -> Result<CasterForward<T>, InputError> {
        let (dir, _) = self.robot_directions(steer, T::zero());
        self.fit(self.mount_centred, self.mount_mean, dir, rates)
    }

    /// The wheel directions `(cos β_i, sin β_i)`, `β_i = α_i + γ_i`, in the robot frame at steer
    /// angles `steer` (rad), and the rotation by `angle` (rad; the heading, or 0 when the
    /// caller needs none), from one four-lane [`Real::sin_cos4`].
    #[inline(always)]
    fn robot_directions(&self, steer: [T; 3], angle: T) -> ([[T; 2]; 3], Rot2<T>) {
        let a = self.params.mount_angles;
        let (s, c) = T::sin_cos4([a[0] + steer[0], a[1] + steer[1], a[2] + steer[2], angle]);
        let dir = [[c[0], s[0]], [c[1], s[1]], [c[2], s[2]]];
        (
            dir,
            Rot2 {
                cos: c[3],
                sin: s[3],
            },
        )
    }

    /// The least-squares rigid-velocity fit of [`Caster3::body_twist`] (see there), in the
    /// frame the twist is wanted in, given the steering axes relative to their centroid,
    /// `centred[i] = F_i − F̄` (m), the centroid `mean = F̄ − C` (m) and each wheel's direction
    /// `dir[i] = (cos β_i, sin β_i)`.
    ///
    /// With `b̄` the mean direction, the wheel centres relative to their centroid are
    /// `q_i = O_i − Ō = (F_i − F̄) + d (b_i − b̄)` and `Ō − C = F̄ + d b̄`; with `n_i = m_i − m̄`
    /// the implied velocities relative to their mean, `θ̇ = Σ q_i × n_i / Σ |q_i|²`,
    /// `v_C = m̄ − θ̇ k × (Ō − C)`, and the residual of wheel `i` is `n_i − θ̇ k × q_i`.
    #[inline(always)]
    fn fit(
        &self,
        centred: [[T; 2]; 3],
        mean: [T; 2],
        dir: [[T; 2]; 3],
        rates: &CasterRates<T>,
    ) -> Result<CasterForward<T>, InputError> {
        let p = &self.params;
        let (d, r) = (p.eccentricity, p.wheel_radius);
        let third = T::of(1.0 / 3.0);
        let bbar = [
            (dir[0][0] + dir[1][0] + dir[2][0]) * third,
            (dir[0][1] + dir[1][1] + dir[2][1]) * third,
        ];
        let mut q = [[T::zero(); 2]; 3];
        let mut m = [[T::zero(); 2]; 3];
        for i in 0..3 {
            let [cb, sb] = dir[i];
            q[i] = [
                centred[i][0] + d * (cb - bbar[0]),
                centred[i][1] + d * (sb - bbar[1]),
            ];
            // The velocity of the point above O_i implied by wheel i's motors (the first two
            // columns of M_i, paper 003, eq. (1)).
            let (u, w) = (r * rates.roll[i], d * rates.steer[i]);
            m[i] = [w * sb - u * cb, -(u * sb + w * cb)];
        }
        let mbar = [
            (m[0][0] + m[1][0] + m[2][0]) * third,
            (m[0][1] + m[1][1] + m[2][1]) * third,
        ];
        // Σ q_i = 0, so Σ q_i × n_i = Σ q_i × m_i: the moment does not wait for the mean m̄.
        let (mut spread, mut moment) = (T::zero(), T::zero());
        for i in 0..3 {
            spread += q[i][0] * q[i][0] + q[i][1] * q[i][1];
            moment += q[i][0] * m[i][1] - q[i][1] * m[i][0];
        }
        let n = m.map(|mi| [mi[0] - mbar[0], mi[1] - mbar[1]]);
        if spread <= self.min_spread {
            return Err(InputError::Singular {
                reason: "the three wheel centres O_i coincide (d = D with every steer angle \
                         γ_i = π): the yaw rate cannot be recovered from the motor rates",
            });
        }
        let omega = moment / spread;
        // v_C = m̄ − θ̇ k × (Ō − C), with k × (x, y) = (−y, x).
        let pbar = [mean[0] + d * bbar[0], mean[1] + d * bbar[1]];
        let vx = mbar[0] + omega * pbar[1];
        let vy = mbar[1] - omega * pbar[0];
        let twist = Twist2::new(vx, vy, omega);
        let mut wheel_slip = [T::zero(); 3];
        let mut total = T::zero();
        for i in 0..3 {
            let ex = n[i][0] + omega * q[i][1];
            let ey = n[i][1] - omega * q[i][0];
            let e2 = ex * ex + ey * ey;
            wheel_slip[i] = e2.sqrt();
            total += e2;
        }
        // One test for the usual call: a non-finite twist or residual makes the sum non-finite
        // (a finite sum's overflow only sends the call down the precise tests).
        if !((vx + vy) + (omega + total)).is_finite() {
            if !twist.is_finite() {
                return Err(InputError::Singular {
                    reason: "the least-squares twist overflows: motor rates too large for the scalar type",
                });
            }
            if !total.is_finite() {
                return Err(InputError::Singular {
                    reason: "the slip residual overflows: motor rates too large for the scalar type",
                });
            }
        }
        Ok(CasterForward {
            twist,
            slip_residual: total.sqrt(),
            wheel_slip,
        })
    }
}

/// The inverse kinematics of a [`Caster3`] at one heading and steer state: row `i` of `J1`
/// (`roll[i]`, × `1/r`) and of `J2` (`steer[i]`), paper 003, eq. (2). From
/// [`Caster3::robot_frame_inverse`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CasterInverseRows<T> {
    roll: [[T; 3]; 3],
    steer: [[T; 3]; 3],
}

impl<T: Real> CasterInverseRows<T> {
    /// The six rates of `twist` without the finiteness check.
    #[inline(always)]
    fn rates_unchecked(&self, twist: Twist2<T>) -> CasterRates<T> {
        let q = twist.to_array();
        let dot = |a: &[T; 3]| a[0] * q[0] + a[1] * q[1] + a[2] * q[2];
        CasterRates {
            roll: [dot(&self.roll[0]), dot(&self.roll[1]), dot(&self.roll[2])],
            steer: [
                dot(&self.steer[0]),
                dot(&self.steer[1]),
                dot(&self.steer[2]),
            ],
        }
    }

    /// Roll and steer rates (rad/s) of the twist `twist` (m/s, m/s, rad/s; the frame the rows
    /// were made for), as [`Caster3::motor_rates`].
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `"vx"`, `"vy"` or `"yaw_rate"`;
    /// [`InputError::Overflow`] when finite inputs give non-finite rates.
    #[inline]
    pub fn motor_rates(&self, twist: Twist2<T>) -> Result<CasterRates<T>, InputError> {
        let out = self.rates_unchecked(twist);
        let sum =
            out.roll[0] + out.roll[1] + out.roll[2] + out.steer[0] + out.steer[1] + out.steer[2];
        if !sum.is_finite() {
            twist.check_finite()?;
            crate::real::finite_out(out.roll, "roll rates")?;
            crate::real::finite_out(out.steer, "steer rates")?;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod rows_tests {
    use super::*;

    #[test]
    fn the_fixed_steer_inverse_is_motor_rates_exactly() {
        let c = Caster3::<f64>::new(super::super::CasterParams::preset()).unwrap();
        // A small LCG: many twists and steer states, including large and tiny values.
        let mut s = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for k in 0..2000 {
            let scale = if k % 7 == 0 { 1e3 } else { 1.0 };
            let steer = [4.0 * next(), 4.0 * next(), 4.0 * next()];
            let rows = c.robot_frame_inverse(steer).unwrap();
            for _ in 0..5 {
                let tw = Twist2::new(scale * next(), scale * next(), scale * next());
                let want = c.motor_rates(tw, 0.0, steer).unwrap();
                let got = rows.motor_rates(tw).unwrap();
                assert_eq!(got.roll, want.roll);
                assert_eq!(got.steer, want.steer);
            }
        }
        let rows = c.robot_frame_inverse([0.0; 3]).unwrap();
        let bad = Twist2::new(0.0, f64::NAN, 0.0);
        assert_eq!(
            rows.motor_rates(bad).unwrap_err(),
            c.motor_rates(bad, 0.0, [0.0; 3]).unwrap_err()
        );
        let huge = Twist2::new(f64::MAX, f64::MAX, 0.0);
        assert_eq!(
            rows.motor_rates(huge).unwrap_err(),
            c.motor_rates(huge, 0.0, [0.0; 3]).unwrap_err()
        );
        assert!(c.robot_frame_inverse([0.0, f64::INFINITY, 0.0]).is_err());
    }
}
