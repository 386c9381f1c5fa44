//! # omni — N ≥ 3 omni or mecanum wheels at arbitrary positions (kiwi, X-drive, mecanum)
//!
//! [`Omni<T, N>`] is the kinematics of a rigid base on `N` fixed (non-steered) wheels whose
//! rims carry free rollers. Wheel `i` sits at `p_i` (robot frame, m), rolls along the unit
//! **drive direction** `d_i`, has radius `r_i` (m) and rollers whose axis (at the floor
//! contact, projected on the floor) makes the **roller angle** `ρ_i` with `d_i`,
//! counter-clockwise positive: `ρ = 0` is an omni wheel, `ρ = ±45°` a mecanum wheel.
//!
//! ## The wheel-rate equation
//!
//! The roller touching the floor spins freely about its own axis, so the contact point may
//! slide **perpendicular to the roller axis** at any speed; **along the roller axis** it is
//! held by the wheel. Let `c_i = R(ρ_i) d_i` be the unit vector along the roller axis. A body
//! twist `t = (vx, vy, ω)` (robot frame) moves the contact point at
//! `v_i = (vx − ω p_iy, vy + ω p_ix)`; the wheel turning at `ω_i` (rad/s) moves its rim at
//! `r_i ω_i d_i`. No slip along the roller axis:
//!
//! ```text
//! c_i · v_i = r_i ω_i (c_i · d_i) = r_i ω_i cos ρ_i
//! ω_i = [c_ix, c_iy, p_i × c_i] · (vx, vy, ω) / (r_i cos ρ_i),   p × c = p_x c_y − p_y c_x
//! ```
//!
//! * **Kiwi** (`ρ = 0`, `p_i = L (cos θ_i, sin θ_i)`, `d_i = (−sin θ_i, cos θ_i)`):
//!   `c_i = d_i`, `p_i × d_i = L`, so `ω_i = (−sin θ_i·vx + cos θ_i·vy + L·ω)/r`.
//! * **Mecanum** (`d_i = +x`): `c_i = (cos ρ, sin ρ)`, and `ω_i r = vx − ω p_y + tan ρ (vy + ω p_x)`.
//!   With `ρ = −45°` at FL and RR and `+45°` at FR and RL this is WPILib's
//!   `MecanumDriveKinematics::ToWheelSpeeds`: `FL = vx − vy − (x+y)ω`, `FR = vx + vy + (x−y)ω`,
//!   `RL = vx + vy + (x−y)ω`, `RR = vx − vy − (x+y)ω` (each wheel's own `(x, y)`), divided by
//!   `r`.
//!
//! Stacking the rows `A_i = [c_ix, c_iy, p_i × c_i]` gives the `N × 3` constraint matrix `A`
//! and `k_i = r_i cos ρ_i` (m/rad): `A t = K ω`.
//!
//! ## Forward kinematics, slip
//!
//! With `N > 3` the rates over-determine the twist. [`Omni::body_twist`] returns the
//! least-squares twist `t = (AᵀA)⁻¹ Aᵀ K ω`, minimising the slip velocities along the roller
//! axes `s_i = A_i t − k_i ω_i` (m/s, [`OmniFit::wheel_slip`]); for mecanum layouts with equal
//! wheels this is WPILib's `ToChassisSpeeds` (the pseudo-inverse of its wheel matrix), for
//! `N = 3` the exact inverse. The `3 × N` matrix is precomputed by [`Omni::new`]; a call is
//! `3N` multiply-adds.
//!
//! ## Rank
//!
//! [`Omni::new`] rejects a layout whose `A` (yaw column divided by the layout's RMS radius, so
//! the test is unit-free) has a condition number above [`crate::MAX_CONDITION`]: fewer than
//! three wheels, all roller axes parallel (a sideways motion no wheel sees), or all the lines
//! through `p_i` along `c_i` meeting in one point (a spin about that point no wheel sees).
//!
//! What these calls do **not** do: no limits, no desaturation (see
//! [`crate::drive::Drive::desaturate`]), no wheel-radius calibration.

use nalgebra::Matrix3;

use super::{
    Drive, Fit, WHEEL_ANGLES, WHEEL_RATES, WHEEL_TORQUES, WRENCH, Wrench2, all_finite, array_error,
    first_non_finite, indexed_names, name_of, sqrt64, twist_error,
};
use crate::{GeometryError, InputError, MAX_CONDITION, Real, Twist2};

const POSITION: [&str; 17] = indexed_names!("wheels", ".position");
const DRIVE: [&str; 17] = indexed_names!("wheels", ".drive");
const ROLLER: [&str; 17] = indexed_names!("wheels", ".roller_angle");
const RADIUS: [&str; 17] = indexed_names!("wheels", ".radius");

/// Smallest accepted `cos ρ_i` (|ρ| ≤ 89.43°): at `ρ = ±90°` the roller axis is across the
/// drive direction and the wheel could not push along it at all.
pub const MIN_ROLLER_COS: f64 = 1.0e-2;

/// Shortest accepted drive-direction vector (it is normalised; only its direction counts).
pub const MIN_DRIVE_NORM: f64 = 1.0e-9;

/// One omni or mecanum wheel (robot frame, SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OmniWheel<T> {
    /// `p_i`, m: the contact point's position in the robot frame.
    pub position: [T; 2],
    /// `d_i`: the direction the rim pushes the robot for a positive wheel rate (normalised by
    /// [`Omni::new`]; any non-zero length).
    pub drive: [T; 2],
    /// `ρ_i`, rad: angle from `d_i` to the (floor-projected) axis of the roller at the contact,
    /// counter-clockwise; 0 for omni wheels, ±π/4 for mecanum wheels. `|ρ| < π/2`.
    pub roller_angle: T,
    /// `r_i`, m: wheel radius (to the roller contact).
    pub radius: T,
}

impl<T: Real> OmniWheel<T> {
    /// A wheel at `position` (m) driving along the direction `drive_angle` (rad from robot +x).
    pub fn at_angle(position: [T; 2], drive_angle: T, roller_angle: T, radius: T) -> Self {
        let (s, c) = drive_angle.sin_cos();
        Self {
            position,
            drive: [c, s],
            roller_angle,
            radius,
        }
    }
}

/// Presets of `robots/kiwi.toml`, `robots/x-drive.toml`, `robots/mecanum.toml`.
pub mod presets {
    use super::OmniWheel;
    use crate::Real;

    /// Kiwi: 3 omni wheels at `θ_i = 0°, 120°, 240°`, `L = 0.15 m`, `r = 0.05 m`, wheel `i`
    /// driving along `(−sin θ_i, cos θ_i)`.
    pub fn kiwi<T: Real>() -> [OmniWheel<T>; 3] {
        core::array::from_fn(|i| {
            let th = T::of(i as f64 * 2.0 * core::f64::consts::PI / 3.0);
            let (s, c) = th.sin_cos();
            let l = T::of(0.15);
            OmniWheel {
                position: [l * c, l * s],
                drive: [-s, c],
                roller_angle: T::zero(),
                radius: T::of(0.05),
            }
        })
    }

    /// X-drive: 4 omni wheels at `θ_i = 45°, 135°, 225°, 315°` (FL, RL, RR, FR going
    /// counter-clockwise), `L = 0.2 m`, `r = 0.05 m`, driving along `(−sin θ_i, cos θ_i)`.
    pub fn x_drive<T: Real>() -> [OmniWheel<T>; 4] {
        core::array::from_fn(|i| {
            let th = T::of((45.0 + 90.0 * i as f64).to_radians());
            let (s, c) = th.sin_cos();
            let l = T::of(0.2);
            OmniWheel {
                position: [l * c, l * s],
                drive: [-s, c],
                roller_angle: T::zero(),
                radius: T::of(0.05),
            }
        })
    }

    /// Mecanum, WPILib order FL (0.25, 0.2), FR (0.25, −0.2), RL (−0.25, 0.2),
    /// RR (−0.25, −0.2), `r = 0.05 m`, all driving along +x, rollers at −45° (FL, RR) and
    /// +45° (FR, RL): the rates are WPILib's `MecanumDriveWheelSpeeds` divided by `r`.
    pub fn mecanum<T: Real>() -> [OmniWheel<T>; 4] {
        let q = T::of(core::f64::consts::FRAC_PI_4);
        let w = |x: f64, y: f64, rho: T| OmniWheel {
            position: [T::of(x), T::of(y)],
            drive: [T::one(), T::zero()],
            roller_angle: rho,
            radius: T::of(0.05),
        };
        [
            w(0.25, 0.2, -q),
            w(0.25, -0.2, q),
            w(-0.25, 0.2, q),
            w(-0.25, -0.2, -q),
        ]
    }
}

/// Forward kinematics of [`Omni::body_fit`]: the least-squares twist and the per-wheel slip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OmniFit<T, const N: usize> {
    /// Robot-frame body twist (m/s, m/s, rad/s).
    pub twist: Twist2<T>,
    /// `sqrt(Σ wheel_slip²)`, m/s.
    pub slip_residual: T,
    /// Per wheel, m/s: `s_i = A_i t − r_i cos ρ_i ω_i`, the velocity along the roller axis the
    /// contact point would have to slip for the fitted twist (positive: the body moves faster
    /// along `c_i` than the wheel drives it).
    pub wheel_slip: [T; N],
}

/// Kinematics of a base on `N ≥ 3` omni or mecanum wheels (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Omni<T, const N: usize> {
    wheels: [OmniWheel<T>; N],
    /// Rows `A_i = [c_x, c_y, p × c]` (m/s along `c_i` per unit twist).
    rows: [[T; 3]; N],
    /// `k_i = r_i cos ρ_i`, m/rad.
    k: [T; N],
    /// Inverse matrix, row `i` = `A_i / k_i` (rad/s per unit twist):
    /// `ω_i = inv[i][0] vx + inv[i][1] vy + inv[i][2] yaw_rate`. Row-major on purpose: the
    /// compiler then reads `(vx, vy)` as one 16-byte pair and `yaw_rate` alone, which a twist
    /// just stored to memory (two stores, 16 + 8 bytes) can forward. Column-major made it
    /// read `(vy, yaw_rate)` as one pair straddling the two stores, a store-forwarding stall
    /// of ~10 ns per call (`bench/peers`).
    inv: [[T; 3]; N],
    /// Forward matrix `(AᵀA)⁻¹ Aᵀ K`, row-major (`3 × N`): `vx = fwd[0] · ω`, ….
    fwd: [[T; N]; 3],
    /// Minimum-norm torque matrix `J (JᵀJ)⁻¹` (`N × 3`, column-major, `J = K⁻¹A`):
    /// `τ = tq[0] fx + tq[1] fy + tq[2] mz`.
    tq: [[T; N]; 3],
    /// Condition number of the scaled `A`.
    condition: f64,
}

impl<T: Real, const N: usize> Omni<T, N> {
    /// Validates the layout and precomputes the inverse rows and the least-squares forward
    /// matrix.
    ///
    /// # Errors
    /// * [`GeometryError::NonFinite`] naming `wheels[i].position`, `.drive`, `.roller_angle`
    ///   or `.radius`;
    /// * [`GeometryError::NotPositive`] for `wheels[i].radius ≤ 0`;
    /// * [`GeometryError::DeadWheel`] (1-based wheel) for a drive direction shorter than
    ///   [`MIN_DRIVE_NORM`];
    /// * [`GeometryError::AngleOutOfRange`] for `|ρ_i|` with `cos ρ_i <` [`MIN_ROLLER_COS`];
    /// * [`GeometryError::IllConditioned`] for fewer than three wheels or a rank-deficient
    ///   layout (the `what` says which rule: parallel roller axes, or roller-axis lines through
    ///   one point).
    pub fn new(wheels: [OmniWheel<T>; N]) -> Result<Self, GeometryError> {
        let mut out = Self {
            wheels,
            rows: [[T::zero(); 3]; N],
            k: [T::zero(); N],
            inv: [[T::zero(); 3]; N],
            fwd: [[T::zero(); N]; 3],
            tq: [[T::zero(); N]; 3],
            condition: f64::INFINITY,
        };
        if N < 3 {
            return Err(GeometryError::IllConditioned {
                what: "omni layout with fewer than 3 wheels (cannot determine vx, vy and yaw_rate)",
                condition: f64::INFINITY,
                max: MAX_CONDITION,
            });
        }
        let mut sum_p2 = T::zero();
        for (i, w) in wheels.iter().enumerate() {
            if !all_finite(&w.position) {
                return Err(GeometryError::NonFinite {
                    field: name_of(&POSITION, i),
                });
            }
            if !all_finite(&w.drive) {
                return Err(GeometryError::NonFinite {
                    field: name_of(&DRIVE, i),
                });
            }
            crate::real::finite_param(w.roller_angle, name_of(&ROLLER, i))?;
            crate::real::positive(w.radius, name_of(&RADIUS, i))?;
            let norm = (w.drive[0] * w.drive[0] + w.drive[1] * w.drive[1]).sqrt();
            if norm.to_f64().is_nan() || norm.to_f64() < MIN_DRIVE_NORM {
                return Err(GeometryError::DeadWheel {
                    wheel: i + 1,
                    quantity: "|drive|",
                    value: norm.to_f64(),
                    rule: "the drive direction must be a non-zero vector",
                });
            }
            let (sr, cr) = w.roller_angle.sin_cos();
            if cr.to_f64() < MIN_ROLLER_COS {
                return Err(GeometryError::AngleOutOfRange {
                    field: name_of(&ROLLER, i),
                    value: w.roller_angle.to_f64(),
                    rule: "|roller_angle| must be below π/2 (cos ≥ 0.01): rollers across the \
                           drive direction cannot push",
                });
            }
            let (dx, dy) = (w.drive[0] / norm, w.drive[1] / norm);
            out.wheels[i].drive = [dx, dy];
            let (cx, cy) = (cr * dx - sr * dy, sr * dx + cr * dy);
            let [px, py] = w.position;
            out.rows[i] = [cx, cy, px * cy - py * cx];
            out.k[i] = w.radius * cr;
            let inv_k = T::one() / out.k[i];
            out.inv[i] = [cx * inv_k, cy * inv_k, out.rows[i][2] * inv_k];
            sum_p2 += px * px + py * py;
        }
        // Unit-free rank test: yaw column divided by the layout's RMS radius ℓ.
        let ell = (sum_p2 / T::of(N as f64)).sqrt();
        let parallel = "omni constraint matrix A = [c_i, p_i × c_i]: all roller axes c_i are \
                        parallel, no wheel sees a sideways motion";
        let concurrent = "omni constraint matrix A = [c_i, p_i × c_i]: the lines through every \
                          wheel along its roller axis meet in one point, no wheel sees a spin \
                          about it";
        let mut lin = nalgebra::Matrix2::<T>::zeros();
        for r in &out.rows {
            lin[(0, 0)] += r[0] * r[0];
            lin[(0, 1)] += r[0] * r[1];
            lin[(1, 1)] += r[1] * r[1];
        }
        lin[(1, 0)] = lin[(0, 1)];
        let lin_cond = sqrt64(cond2(&lin));
        if lin_cond.is_nan() || lin_cond > MAX_CONDITION {
            return Err(GeometryError::IllConditioned {
                what: parallel,
                condition: lin_cond,
                max: MAX_CONDITION,
            });
        }
        if !ell.is_finite() || ell <= T::zero() {
            return Err(GeometryError::IllConditioned {
                what: concurrent,
                condition: f64::INFINITY,
                max: MAX_CONDITION,
            });
        }
        let inv_ell = T::one() / ell;
        let mut g = Matrix3::<T>::zeros();
        for r in &out.rows {
            let a = [r[0], r[1], r[2] * inv_ell];
            for j in 0..3 {
                for l in 0..3 {
                    g[(j, l)] += a[j] * a[l];
                }
            }
        }
        let cond = sqrt64(crate::condition_number(&g));
        out.condition = cond;
        if cond.is_nan() || cond > MAX_CONDITION {
            return Err(GeometryError::IllConditioned {
                what: concurrent,
                condition: cond,
                max: MAX_CONDITION,
            });
        }
        let Some(g_inv) = g.try_inverse() else {
            return Err(GeometryError::IllConditioned {
                what: concurrent,
                condition: f64::INFINITY,
                max: MAX_CONDITION,
            });
        };
        for i in 0..N {
            let r = out.rows[i];
            let a = nalgebra::Vector3::new(r[0], r[1], r[2] * inv_ell);
            let col = g_inv * a * out.k[i];
            out.fwd[0][i] = col[0];
            out.fwd[1][i] = col[1];
            out.fwd[2][i] = col[2] * inv_ell;
        }
        // Torques: J̃ = J·diag(1, 1, 1/ℓ), G̃ = J̃ᵀJ̃ (same rank as Ã: K is diagonal, > 0);
        // τ = J̃ G̃⁻¹ (fx, fy, mz/ℓ).
        let mut gj = Matrix3::<T>::zeros();
        for i in 0..N {
            let j = [out.inv[i][0], out.inv[i][1], out.inv[i][2] * inv_ell];
            for a in 0..3 {
                for b in 0..3 {
                    gj[(a, b)] += j[a] * j[b];
                }
            }
        }
        let Some(gj_inv) = gj.try_inverse() else {
            return Err(GeometryError::IllConditioned {
                what: "omni torque map JᵀJ (wheel radii too different)",
                condition: f64::INFINITY,
                max: MAX_CONDITION,
            });
        };
        for i in 0..N {
            let j = nalgebra::Vector3::new(out.inv[i][0], out.inv[i][1], out.inv[i][2] * inv_ell);
            let c = gj_inv * j;
            out.tq[0][i] = c[0];
            out.tq[1][i] = c[1];
            out.tq[2][i] = c[2] * inv_ell;
        }
        Ok(out)
    }

    /// The wheels as validated (drive directions normalised).
    pub fn wheels(&self) -> &[OmniWheel<T>; N] {
        &self.wheels
    }

    /// 2-norm condition number of the constraint matrix `A` with its yaw column divided by the
    /// layout's RMS radius (unit-free; ≤ [`MAX_CONDITION`] for every accepted layout).
    pub fn condition(&self) -> f64 {
        self.condition
    }

    /// The constraint row `A_i = [c_x, c_y, p × c]` of wheel `i` (0-based) and
    /// `k_i = r_i cos ρ_i` (m/rad): `A_i · t = k_i ω_i` without slip. `None` past the last
    /// wheel.
    pub fn constraint(&self, i: usize) -> Option<([T; 3], T)> {
        Some((*self.rows.get(i)?, self.k[i]))
    }

    /// Inverse kinematics: wheel rates (rad/s, wheel order) for the **robot-frame** `twist`
    /// (m/s, m/s, rad/s). Not limited.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `vx`, `vy` or `yaw_rate`; [`InputError::Overflow`]
    /// (`wheel_rates`) if a rate is not finite.
    #[inline]
    pub fn wheel_rates(&self, twist: Twist2<T>) -> Result<[T; N], InputError> {
        let mut w = [T::zero(); N];
        for i in 0..N {
            let r = &self.inv[i];
            w[i] = r[0] * twist.vx + r[1] * twist.vy + r[2] * twist.yaw_rate;
        }
        // A non-finite input makes every rate non-finite (`0·∞` is NaN), so one check of the
        // output covers the input too; the error is classified off the hot path.
        if finite(&w) {
            Ok(w)
        } else {
            Err(twist_error(twist, "wheel_rates"))
        }
    }

    /// Forward kinematics: the least-squares **robot-frame** twist for the wheel rates
    /// (rad/s); exact for `N = 3`.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `wheel_rates[i]`; [`InputError::Overflow`]
    /// (`body_twist`).
    #[inline]
    pub fn body_twist(&self, rates: &[T; N]) -> Result<Twist2<T>, InputError> {
        self.apply_forward(rates, &WHEEL_RATES, "body_twist")
    }

    /// `fwd · x`; a non-finite `x_i` makes all three outputs non-finite, so the output check
    /// covers the input, and the error names the input entry (`names`) or the overflow.
    #[inline(always)]
    fn apply_forward(
        &self,
        x: &[T; N],
        names: &[&'static str; 17],
        quantity: &'static str,
    ) -> Result<Twist2<T>, InputError> {
        let (mut vx, mut vy, mut wz) = (T::zero(), T::zero(), T::zero());
        let [a, b, c] = &self.fwd;
        for i in 0..N {
            vx += a[i] * x[i];
            vy += b[i] * x[i];
            wz += c[i] * x[i];
        }
        if finite(&[vx, vy, wz]) {
            Ok(Twist2::new(vx, vy, wz))
        } else {
            Err(array_error(x, names, quantity))
        }
    }

    /// [`Omni::body_twist`] with the per-wheel slip along the roller axes (m/s).
    ///
    /// # Errors
    /// As [`Omni::body_twist`].
    pub fn body_fit(&self, rates: &[T; N]) -> Result<OmniFit<T, N>, InputError> {
        let twist = self.body_twist(rates)?;
        let mut wheel_slip = [T::zero(); N];
        let mut total = T::zero();
        for i in 0..N {
            let r = &self.rows[i];
            let s =
                r[0] * twist.vx + r[1] * twist.vy + r[2] * twist.yaw_rate - self.k[i] * rates[i];
            wheel_slip[i] = s;
            total += s * s;
        }
        let slip_residual = total.sqrt();
        if !slip_residual.is_finite() {
            return Err(InputError::Overflow {
                quantity: "slip_residual",
            });
        }
        Ok(OmniFit {
            twist,
            slip_residual,
            wheel_slip,
        })
    }

    /// The robot-frame displacement `(Δx, Δy, Δθ)` (m, m, rad) between two readings of the
    /// cumulative wheel angles (rad): the forward kinematics of the increments.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `wheel_angles[i]`; [`InputError::Overflow`].
    #[inline]
    pub fn displacement(&self, start: &[T; N], end: &[T; N]) -> Result<Twist2<T>, InputError> {
        if !all_finite(start) {
            return Err(first_non_finite(start, &WHEEL_ANGLES));
        }
        let d: [T; N] = core::array::from_fn(|i| end[i] - start[i]);
        self.apply_forward(&d, &WHEEL_ANGLES, "displacement")
            .map_err(|_| array_error(end, &WHEEL_ANGLES, "displacement"))
    }
}

impl<T: Real, const N: usize> Omni<T, N> {
    /// The body wrench (robot frame; N, N, N·m) that the wheel torques `torques` (N·m, about
    /// each wheel's axis, positive driving along `d_i`) exert: `W = Jᵀ τ`, the dual of
    /// [`Omni::wheel_rates`] (`Σ τ_i ω_i = W · t`).
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `wheel_torques[i]`; [`InputError::Overflow`].
    pub fn body_wrench(&self, torques: &[T; N]) -> Result<Wrench2<T>, InputError> {
        let (mut fx, mut fy, mut mz) = (T::zero(), T::zero(), T::zero());
        for i in 0..N {
            let r = &self.inv[i];
            fx += r[0] * torques[i];
            fy += r[1] * torques[i];
            mz += r[2] * torques[i];
        }
        if all_finite(&[fx, fy, mz]) {
            Ok(Wrench2::new(fx, fy, mz))
        } else {
            Err(array_error(torques, &WHEEL_TORQUES, "body_wrench"))
        }
    }

    /// The minimum-norm wheel torques (N·m) that exert the body wrench `wrench` (robot frame):
    /// `τ = J (JᵀJ)⁻¹ W`; [`Omni::body_wrench`] of the result is `wrench`.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `fx`, `fy` or `mz`; [`InputError::Overflow`].
    pub fn wheel_torques(&self, wrench: Wrench2<T>) -> Result<[T; N], InputError> {
        let mut t = [T::zero(); N];
        let [a, b, c] = &self.tq;
        for i in 0..N {
            t[i] = a[i] * wrench.fx + b[i] * wrench.fy + c[i] * wrench.mz;
        }
        if all_finite(&t) {
            Ok(t)
        } else {
            crate::real::finite3(wrench.to_array(), WRENCH)?;
            Err(InputError::Overflow {
                quantity: "wheel_torques",
            })
        }
    }
}

/// `true` when every entry of `x` is finite, for the hot paths. A sum is finite only if every
/// entry is, so the fast test is one sum (two interleaved partial sums, which SSE adds two
/// entries at a time); only when the sum is not finite (a non-finite entry, or finite entries
/// whose sum overflows) does the cold fallback look at each entry. `x` goes to the fallback by
/// value: passing its address would keep it in memory on the fast path too.
#[inline(always)]
pub(super) fn finite<T: Real, const N: usize>(x: &[T; N]) -> bool {
    if N == 0 {
        return true;
    }
    let mut even = x[0];
    let mut odd = if N > 1 { x[1] } else { T::zero() };
    let mut i = 2;
    while i + 1 < N {
        even += x[i];
        odd += x[i + 1];
        i += 2;
    }
    if i < N {
        even += x[i];
    }
    let s = even + odd;
    // `0·s` is ±0 for a finite sum and NaN otherwise; "ordered" is one compare and one branch.
    (s * T::zero()).partial_cmp(&T::zero()).is_some() || each_finite(*x)
}

#[cold]
#[inline(never)]
fn each_finite<T: Real, const N: usize>(x: [T; N]) -> bool {
    x.iter().all(|v| v.is_finite())
}

/// Condition number of a symmetric 2×2 positive semi-definite matrix (∞ if singular).
fn cond2<T: Real>(m: &nalgebra::Matrix2<T>) -> f64 {
    let (a, b, d) = (m[(0, 0)].to_f64(), m[(0, 1)].to_f64(), m[(1, 1)].to_f64());
    let mean = 0.5 * (a + d);
    let dev = sqrt64(0.25 * (a - d) * (a - d) + b * b);
    let (hi, lo) = (mean + dev, mean - dev);
    if lo <= hi * 1e-300 || lo <= 0.0 {
        f64::INFINITY
    } else {
        hi / lo
    }
}

impl<T: Real, const N: usize> Drive for Omni<T, N> {
    type Scalar = T;
    /// Wheel rates, rad/s.
    type Actuators = [T; N];
    /// Cumulative wheel angles, rad.
    type Positions = [T; N];
    const WHEELS: usize = N;

    fn rest(&self) -> [T; N] {
        [T::zero(); N]
    }

    #[inline]
    fn inverse(&self, twist: Twist2<T>, _current: &[T; N]) -> Result<[T; N], InputError> {
        self.wheel_rates(twist)
    }

    #[inline]
    fn forward(&self, actuators: &[T; N]) -> Result<Twist2<T>, InputError> {
        self.body_twist(actuators)
    }

    fn forward_fit(&self, actuators: &[T; N]) -> Result<Fit<T>, InputError> {
        let f = self.body_fit(actuators)?;
        Ok(Fit {
            twist: f.twist,
            slip_residual: f.slip_residual,
        })
    }

    #[inline]
    fn displacement(&self, start: &[T; N], end: &[T; N]) -> Result<Twist2<T>, InputError> {
        Omni::displacement(self, start, end)
    }

    fn wheel_rates(actuators: &[T; N]) -> &[T] {
        actuators
    }

    fn scale_wheel_rates(actuators: [T; N], factor: T) -> [T; N] {
        actuators.map(|w| w * factor)
    }
}
