//! # swerve — N ≥ 2 centred steerable modules
//!
//! [`Swerve<T, N>`] is the kinematics of a base on `N` steerable wheels whose steering axis
//! passes through the wheel's floor contact (a *centred* module; the paper-003 caster is the
//! off-centred member of the family, with eccentricity `d > 0`). Module `i` sits at `p_i`
//! (robot frame, m) and has wheel radius `r_i` (m); its **steering direction** is a
//! [`Rot2`] `(cos γ_i, sin γ_i)`, the wheel's rolling direction from robot +x,
//! counter-clockwise; its **wheel rate** `ω_i` (rad/s) rolls it along that direction.
//!
//! ## Model
//!
//! A body twist `t = (vx, vy, ω)` (robot frame) moves module `i`'s contact at
//! `v_i = (vx − ω p_iy, vy + ω p_ix)`. No slip in any direction:
//!
//! * **inverse** ([`Swerve::module_states`]): `ω_i = |v_i| / r_i ≥ 0`,
//!   `(cos γ_i, sin γ_i) = v_i / |v_i|` — WPILib's `SwerveDriveKinematics::ToSwerveModuleStates`
//!   divided by `r_i`, without optimisation. A module whose speed is below
//!   [`MIN_STEER_SPEED`] (1e-6 m/s, WPILib's threshold) keeps its current direction (the
//!   direction of a zero vector is undefined), as WPILib keeps its stored module headings.
//!   Unlike WPILib, the model holds no hidden state: the caller passes the current
//!   directions.
//! * **forward** ([`Swerve::body_twist`]): the `2N` velocity components
//!   `r_i ω_i (cos γ_i, sin γ_i)` over-determine the three unknowns; the least-squares twist is
//!   `t = (BᵀB)⁻¹ Bᵀ u` with `B_i = [[1, 0, −p_iy], [0, 1, p_ix]]` — WPILib's `ToChassisSpeeds`
//!   (the Moore–Penrose pseudo-inverse), precomputed by [`Swerve::new`]. The residual is the
//!   slip of each module's contact ([`SwerveFit::module_slip`], m/s).
//! * **optimisation** ([`Swerve::optimize`], or [`Swerve::with_optimization`] for
//!   [`Drive::inverse`]): a module whose new direction is more than 90° from its current one is
//!   turned the other way and driven backwards (`ω_i < 0`): WPILib's
//!   `SwerveModuleState::Optimize`.
//! * **steer rates** ([`Swerve::steer_rates`]): from the twist and its time derivative (in
//!   the robot frame), `γ̇_i = (v_i × v̇_i) / |v_i|²` and `ω̇_i = (v_i · v̇_i) / (|v_i| r_i)` with
//!   `v̇_i = (v̇x − ω̇ p_iy, v̇y + ω̇ p_ix)`.
//!
//! What these calls do **not** do: no limits, no desaturation (see
//! [`crate::drive::Drive::desaturate`]), no cosine scaling of the wheel rate by the steering
//! error, no steer-angle unwrapping.

use nalgebra::Matrix3;

use super::{
    Drive, Fit, Rot2, WHEEL_ANGLES, WHEEL_RATES, WHEEL_TORQUES, WRENCH, Wrench2, all_finite,
    check_twist, first_non_finite, indexed_names, name_of, sqrt64, twist_error,
};
use crate::{GeometryError, InputError, MAX_CONDITION, Real, Twist2};

const POSITION: [&str; 17] = indexed_names!("modules", ".position");
const RADIUS: [&str; 17] = indexed_names!("modules", ".wheel_radius");
const STEER: [&str; 17] = indexed_names!("steer");

/// Module speed (m/s) below which the inverse keeps the module's current steering direction.
pub const MIN_STEER_SPEED: f64 = 1.0e-6;

/// One centred swerve module (robot frame, SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwerveModule<T> {
    /// `p_i`, m: the steering axis (= the wheel's floor contact) in the robot frame.
    pub position: [T; 2],
    /// `r_i`, m: wheel radius.
    pub wheel_radius: T,
}

/// Preset of `robots/swerve4.toml`: modules at (±0.3, ±0.3) m in WPILib's order FL, FR, RL,
/// RR, `r = 0.05 m`.
pub fn swerve4<T: Real>() -> [SwerveModule<T>; 4] {
    let m = |x: f64, y: f64| SwerveModule {
        position: [T::of(x), T::of(y)],
        wheel_radius: T::of(0.05),
    };
    [m(0.3, 0.3), m(0.3, -0.3), m(-0.3, 0.3), m(-0.3, -0.3)]
}

/// The actuator vector of a swerve drive: one wheel rate and one steering direction per module.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwerveState<T, const N: usize> {
    /// Wheel rates, rad/s (≥ 0 from the unoptimised inverse).
    pub wheel_rates: [T; N],
    /// Steering directions `(cos γ_i, sin γ_i)`.
    pub steer: [Rot2<T>; N],
}

impl<T: Real, const N: usize> SwerveState<T, N> {
    /// From wheel rates (rad/s) and steer angles (rad).
    pub fn from_angles(wheel_rates: [T; N], steer_angles: [T; N]) -> Self {
        Self {
            wheel_rates,
            steer: steer_angles.map(Rot2::from_angle),
        }
    }

    /// The steer angles `γ_i` in `(−π, π]`, rad.
    pub fn steer_angles(&self) -> [T; N] {
        self.steer.map(Rot2::angle)
    }
}

/// One encoder reading of a swerve drive (odometry input).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwervePositions<T, const N: usize> {
    /// Cumulative wheel angles, rad.
    pub wheel_angles: [T; N],
    /// Steering directions at the time of the reading.
    pub steer: [Rot2<T>; N],
}

/// Steer rates and wheel accelerations of [`Swerve::steer_rates`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwerveRates<T, const N: usize> {
    /// `γ̇_i`, rad/s (0 for a module below [`MIN_STEER_SPEED`]).
    pub steer_rates: [T; N],
    /// `ω̇_i`, rad/s² of the unoptimised wheel rate `|v_i|/r_i`; for a module below
    /// [`MIN_STEER_SPEED`], `|v̇_i|/r_i` (the speed it starts to gain).
    pub wheel_accels: [T; N],
}

/// Forward kinematics of [`Swerve::body_fit`]: the least-squares twist and the per-module slip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SwerveFit<T, const N: usize> {
    /// Robot-frame body twist (m/s, m/s, rad/s).
    pub twist: Twist2<T>,
    /// `sqrt(Σ module_slip²)`, m/s.
    pub slip_residual: T,
    /// Per module, m/s: the magnitude of the difference between the contact velocity of the
    /// fitted twist and the one the module's wheel rate and steering give.
    pub module_slip: [T; N],
}

/// Kinematics of a base on `N ≥ 2` centred steerable modules (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Swerve<T, const N: usize> {
    modules: [SwerveModule<T>; N],
    /// `p_ix`, `p_iy`, m (split so the per-module loops vectorise).
    px: [T; N],
    py: [T; N],
    /// `1/r_i`, 1/m.
    inv_r: [T; N],
    /// Forward columns for module `i`: `twist = Σ_i fu[i]·(ω_i cos γ_i) + fw[i]·(ω_i sin γ_i)`
    /// (the pseudo-inverse columns times `r_i`).
    fu: [[T; 3]; N],
    fw: [[T; 3]; N],
    optimize: bool,
    condition: f64,
    /// `ℓ`, m: RMS distance of the modules from the robot origin (the yaw scale).
    scale: T,
}

impl<T: Real, const N: usize> Swerve<T, N> {
    /// Validates the modules and precomputes the least-squares forward matrix. The inverse is
    /// not optimised (see [`Swerve::with_optimization`]).
    ///
    /// # Errors
    /// * [`GeometryError::NonFinite`] naming `modules[i].position` or `.wheel_radius`;
    /// * [`GeometryError::NotPositive`] for `modules[i].wheel_radius ≤ 0`;
    /// * [`GeometryError::IllConditioned`] for fewer than two modules, or modules (nearly) at
    ///   one point (condition number of `B`, yaw column divided by the RMS radius, above
    ///   [`MAX_CONDITION`]).
    pub fn new(modules: [SwerveModule<T>; N]) -> Result<Self, GeometryError> {
        let at_one_point = "swerve matrix B = [[1, 0, −p_iy], [0, 1, p_ix]]: all modules at one \
                            point, a spin about it is undetermined";
        if N < 2 {
            return Err(GeometryError::IllConditioned {
                what: "swerve layout with fewer than 2 modules (cannot determine yaw_rate)",
                condition: f64::INFINITY,
                max: MAX_CONDITION,
            });
        }
        let mut out = Self {
            modules,
            px: modules.map(|m| m.position[0]),
            py: modules.map(|m| m.position[1]),
            inv_r: [T::zero(); N],
            fu: [[T::zero(); 3]; N],
            fw: [[T::zero(); 3]; N],
            optimize: false,
            condition: f64::INFINITY,
            scale: T::one(),
        };
        let mut sum_p2 = T::zero();
        for (i, m) in modules.iter().enumerate() {
            if !all_finite(&m.position) {
                return Err(GeometryError::NonFinite {
                    field: name_of(&POSITION, i),
                });
            }
            crate::real::positive(m.wheel_radius, name_of(&RADIUS, i))?;
            out.inv_r[i] = T::one() / m.wheel_radius;
            sum_p2 += m.position[0] * m.position[0] + m.position[1] * m.position[1];
        }
        let ell = (sum_p2 / T::of(N as f64)).sqrt();
        if !ell.is_finite() || ell <= T::zero() {
            return Err(GeometryError::IllConditioned {
                what: at_one_point,
                condition: f64::INFINITY,
                max: MAX_CONDITION,
            });
        }
        out.scale = ell;
        let inv_ell = T::one() / ell;
        // BᵀB with the yaw column scaled by 1/ℓ: [[N, 0, −Σy'], [0, N, Σx'], [., ., Σ|p'|²]].
        let mut g = Matrix3::<T>::zeros();
        for m in &modules {
            let (x, y) = (m.position[0] * inv_ell, m.position[1] * inv_ell);
            g[(0, 0)] += T::one();
            g[(1, 1)] += T::one();
            g[(0, 2)] -= y;
            g[(1, 2)] += x;
            g[(2, 2)] += x * x + y * y;
        }
        g[(2, 0)] = g[(0, 2)];
        g[(2, 1)] = g[(1, 2)];
        let cond = sqrt64(crate::condition_number(&g));
        out.condition = cond;
        if cond.is_nan() || cond > MAX_CONDITION {
            return Err(GeometryError::IllConditioned {
                what: at_one_point,
                condition: cond,
                max: MAX_CONDITION,
            });
        }
        let Some(g_inv) = g.try_inverse() else {
            return Err(GeometryError::IllConditioned {
                what: at_one_point,
                condition: f64::INFINITY,
                max: MAX_CONDITION,
            });
        };
        for (i, m) in modules.iter().enumerate() {
            let (x, y) = (m.position[0] * inv_ell, m.position[1] * inv_ell);
            let r = m.wheel_radius;
            // Columns of Bᵀ for u_i (vx row) and w_i (vy row), scaled.
            let cu = g_inv * nalgebra::Vector3::new(T::one(), T::zero(), -y);
            let cw = g_inv * nalgebra::Vector3::new(T::zero(), T::one(), x);
            out.fu[i] = [cu[0] * r, cu[1] * r, cu[2] * inv_ell * r];
            out.fw[i] = [cw[0] * r, cw[1] * r, cw[2] * inv_ell * r];
        }
        Ok(out)
    }

    /// The same drive with [`Drive::inverse`] optimising the steering (`true`) or not
    /// (`false`, the default).
    pub fn with_optimization(mut self, optimize: bool) -> Self {
        self.optimize = optimize;
        self
    }

    /// Whether [`Drive::inverse`] optimises the steering.
    pub fn optimizes(&self) -> bool {
        self.optimize
    }

    /// The modules as validated.
    pub fn modules(&self) -> &[SwerveModule<T>; N] {
        &self.modules
    }

    /// Condition number of `B` with its yaw column divided by the modules' RMS radius.
    pub fn condition(&self) -> f64 {
        self.condition
    }

    /// Inverse kinematics without optimisation: wheel rates `≥ 0` (rad/s) and steering
    /// directions for the **robot-frame** `twist`; a module slower than [`MIN_STEER_SPEED`]
    /// keeps its direction from `current`.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `vx`, `vy` or `yaw_rate`; [`InputError::Overflow`]
    /// (`wheel_rates`).
    #[inline]
    pub fn module_states(
        &self,
        twist: Twist2<T>,
        current: &[Rot2<T>; N],
    ) -> Result<SwerveState<T, N>, InputError> {
        let (mut u, mut w, mut s) = ([T::zero(); N], [T::zero(); N], [T::zero(); N]);
        let mut st = SwerveState {
            wheel_rates: [T::zero(); N],
            steer: *current,
        };
        for i in 0..N {
            u[i] = twist.vx - twist.yaw_rate * self.py[i];
            w[i] = twist.vy + twist.yaw_rate * self.px[i];
            s[i] = (u[i] * u[i] + w[i] * w[i]).sqrt();
            st.wheel_rates[i] = s[i] * self.inv_r[i];
        }
        // A non-finite twist makes every rate non-finite: one output check covers the input.
        if !all_finite(&st.wheel_rates) {
            return Err(twist_error(twist, "wheel_rates"));
        }
        let min = T::of(MIN_STEER_SPEED);
        for i in 0..N {
            if s[i] > min {
                let inv = T::one() / s[i];
                st.steer[i] = Rot2 {
                    cos: u[i] * inv,
                    sin: w[i] * inv,
                };
            }
        }
        Ok(st)
    }

    /// Steering optimisation (WPILib `SwerveModuleState::Optimize`): every module of `state`
    /// whose direction is more than 90° from `current` is turned by π and its wheel rate
    /// negated, so no module turns by more than 90°. The motion is unchanged.
    pub fn optimize(state: SwerveState<T, N>, current: &[Rot2<T>; N]) -> SwerveState<T, N> {
        let mut out = state;
        for i in 0..N {
            if state.steer[i].cos_to(current[i]) < T::zero() {
                out.steer[i] = state.steer[i].flipped();
                out.wheel_rates[i] = -state.wheel_rates[i];
            }
        }
        out
    }

    /// Steer rates `γ̇_i` (rad/s) and wheel accelerations `ω̇_i` (rad/s²) of the unoptimised
    /// inverse for the robot-frame `twist` and its time derivative `twist_rate` (the
    /// derivative of the robot-frame components: `v̇x`, `v̇y` in m/s², `ω̇` in rad/s²; from a
    /// world-frame acceleration `a_w` at heading ψ it is `Q(ψ)ᵀ a_w − ω × v`). For an
    /// optimised (flipped) module the steer rate is the same and the acceleration changes
    /// sign.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming the first non-finite component of either twist;
    /// [`InputError::Overflow`] (`steer_rates`).
    pub fn steer_rates(
        &self,
        twist: Twist2<T>,
        twist_rate: Twist2<T>,
    ) -> Result<SwerveRates<T, N>, InputError> {
        check_twist(twist)?;
        check_twist(twist_rate)?;
        let mut out = SwerveRates {
            steer_rates: [T::zero(); N],
            wheel_accels: [T::zero(); N],
        };
        let min = T::of(MIN_STEER_SPEED);
        for i in 0..N {
            let [px, py] = self.modules[i].position;
            let u = twist.vx - twist.yaw_rate * py;
            let w = twist.vy + twist.yaw_rate * px;
            let du = twist_rate.vx - twist_rate.yaw_rate * py;
            let dw = twist_rate.vy + twist_rate.yaw_rate * px;
            let s2 = u * u + w * w;
            let s = s2.sqrt();
            if s > min {
                out.steer_rates[i] = (u * dw - w * du) / s2;
                out.wheel_accels[i] = (u * du + w * dw) / s * self.inv_r[i];
            } else {
                out.wheel_accels[i] = (du * du + dw * dw).sqrt() * self.inv_r[i];
            }
        }
        if all_finite(&out.steer_rates) && all_finite(&out.wheel_accels) {
            Ok(out)
        } else {
            Err(InputError::Overflow {
                quantity: "steer_rates",
            })
        }
    }

    /// The error of a forward call whose output was not finite: the first non-finite wheel
    /// entry (`names`), else the first non-finite steering direction, else an overflow.
    #[cold]
    fn forward_error(
        rates: &[T; N],
        steer: &[Rot2<T>; N],
        names: &[&'static str; 17],
        quantity: &'static str,
    ) -> InputError {
        if !all_finite(rates) {
            return first_non_finite(rates, names);
        }
        match steer
            .iter()
            .position(|r| !(r.cos.is_finite() && r.sin.is_finite()))
        {
            Some(i) => InputError::NonFinite {
                field: name_of(&STEER, i),
            },
            None => InputError::Overflow { quantity },
        }
    }

    /// `Σ` of the pseudo-inverse columns times the module velocities; any non-finite input
    /// makes the output non-finite, so the output check covers the inputs.
    #[inline(always)]
    fn apply_forward(
        &self,
        rates: &[T; N],
        steer: &[Rot2<T>; N],
        names: &[&'static str; 17],
        quantity: &'static str,
    ) -> Result<Twist2<T>, InputError> {
        let (mut vx, mut vy, mut wz) = (T::zero(), T::zero(), T::zero());
        for i in 0..N {
            let a = rates[i] * steer[i].cos;
            let b = rates[i] * steer[i].sin;
            let (fu, fw) = (&self.fu[i], &self.fw[i]);
            vx += fu[0] * a + fw[0] * b;
            vy += fu[1] * a + fw[1] * b;
            wz += fu[2] * a + fw[2] * b;
        }
        if all_finite(&[vx, vy, wz]) {
            Ok(Twist2::new(vx, vy, wz))
        } else {
            Err(Self::forward_error(rates, steer, names, quantity))
        }
    }

    /// Forward kinematics: the least-squares **robot-frame** twist for the measured wheel
    /// rates (rad/s) and steering directions.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `wheel_rates[i]` or `steer[i]`;
    /// [`InputError::Overflow`] (`body_twist`).
    #[inline]
    pub fn body_twist(&self, state: &SwerveState<T, N>) -> Result<Twist2<T>, InputError> {
        self.apply_forward(&state.wheel_rates, &state.steer, &WHEEL_RATES, "body_twist")
    }

    /// [`Swerve::body_twist`] with the per-module slip (m/s).
    ///
    /// # Errors
    /// As [`Swerve::body_twist`].
    pub fn body_fit(&self, state: &SwerveState<T, N>) -> Result<SwerveFit<T, N>, InputError> {
        let twist = self.body_twist(state)?;
        let mut module_slip = [T::zero(); N];
        let mut total = T::zero();
        for i in 0..N {
            let m = &self.modules[i];
            let [px, py] = m.position;
            let speed = state.wheel_rates[i] * m.wheel_radius;
            let eu = twist.vx - twist.yaw_rate * py - speed * state.steer[i].cos;
            let ew = twist.vy + twist.yaw_rate * px - speed * state.steer[i].sin;
            let e2 = eu * eu + ew * ew;
            module_slip[i] = e2.sqrt();
            total += e2;
        }
        let slip_residual = total.sqrt();
        if !slip_residual.is_finite() {
            return Err(InputError::Overflow {
                quantity: "slip_residual",
            });
        }
        Ok(SwerveFit {
            twist,
            slip_residual,
            module_slip,
        })
    }

    /// The robot-frame displacement `(Δx, Δy, Δθ)` (m, m, rad) between two encoder readings:
    /// the wheel-angle increments with the steering of `end` (WPILib's `ToTwist2d`).
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `wheel_angles[i]` or `steer[i]`;
    /// [`InputError::Overflow`].
    #[inline]
    pub fn displacement(
        &self,
        start: &SwervePositions<T, N>,
        end: &SwervePositions<T, N>,
    ) -> Result<Twist2<T>, InputError> {
        if !all_finite(&start.wheel_angles) {
            return Err(first_non_finite(&start.wheel_angles, &WHEEL_ANGLES));
        }
        let d: [T; N] = core::array::from_fn(|i| end.wheel_angles[i] - start.wheel_angles[i]);
        self.apply_forward(&d, &end.steer, &WHEEL_ANGLES, "displacement")
            .map_err(|_| {
                Self::forward_error(&end.wheel_angles, &end.steer, &WHEEL_ANGLES, "displacement")
            })
    }
}

impl<T: Real, const N: usize> Swerve<T, N> {
    /// `b_i = (cos γ_i, sin γ_i, p_i × (cos γ_i, sin γ_i)) / r_i`: the wrench per unit wheel
    /// torque of module `i`.
    #[inline(always)]
    fn wrench_column(&self, i: usize, steer: Rot2<T>) -> [T; 3] {
        let k = self.inv_r[i];
        [
            steer.cos * k,
            steer.sin * k,
            (self.px[i] * steer.sin - self.py[i] * steer.cos) * k,
        ]
    }

    /// The body wrench (robot frame; N, N, N·m) that the wheel torques `torques` (N·m,
    /// positive rolling along the steering direction) exert with the steering `steer`:
    /// `W = Σ τ_i b_i`, the dual of the velocity map.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `wheel_torques[i]` or `steer[i]`;
    /// [`InputError::Overflow`].
    pub fn body_wrench(
        &self,
        torques: &[T; N],
        steer: &[Rot2<T>; N],
    ) -> Result<Wrench2<T>, InputError> {
        let mut w = [T::zero(); 3];
        for i in 0..N {
            let b = self.wrench_column(i, steer[i]);
            for j in 0..3 {
                w[j] += b[j] * torques[i];
            }
        }
        if all_finite(&w) {
            Ok(Wrench2::new(w[0], w[1], w[2]))
        } else {
            Err(Self::forward_error(
                torques,
                steer,
                &WHEEL_TORQUES,
                "body_wrench",
            ))
        }
    }

    /// The minimum-norm wheel torques (N·m) that exert `wrench` (robot frame) with the
    /// steering `steer`: `τ = Bᵀ (B Bᵀ)⁻¹ W` with `B = [b_1 … b_N]`, a 3×3 solve per call.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming `fx`, `fy`, `mz` or `steer[i]`;
    /// [`InputError::Singular`] when the steering cannot produce every wrench (all wheels
    /// parallel, or all wheel lines through one point); [`InputError::Overflow`].
    pub fn wheel_torques(
        &self,
        wrench: Wrench2<T>,
        steer: &[Rot2<T>; N],
    ) -> Result<[T; N], InputError> {
        crate::real::finite3(wrench.to_array(), WRENCH)?;
        Self::check_steer_finite(steer)?;
        // Yaw row scaled by 1/ℓ so the singularity test is unit-free.
        let inv_ell = T::one() / self.scale;
        let mut m = Matrix3::<T>::zeros();
        for i in 0..N {
            let b = self.wrench_column(i, steer[i]);
            let b = [b[0], b[1], b[2] * inv_ell];
            for j in 0..3 {
                for l in 0..3 {
                    m[(j, l)] += b[j] * b[l];
                }
            }
        }
        let tr = (m[(0, 0)] + m[(1, 1)] + m[(2, 2)]) / T::of(3.0);
        let singular = InputError::Singular {
            reason: "the steering cannot exert every wrench (wheels parallel, or their lines \
                     meet in one point)",
        };
        let det = m.determinant();
        if !det.is_finite() || det <= T::of(1e-9) * tr * tr * tr {
            return Err(singular);
        }
        let m_inv = m.try_inverse().ok_or(singular)?;
        let y = m_inv * nalgebra::Vector3::new(wrench.fx, wrench.fy, wrench.mz * inv_ell);
        let mut t = [T::zero(); N];
        for i in 0..N {
            let b = self.wrench_column(i, steer[i]);
            t[i] = b[0] * y[0] + b[1] * y[1] + b[2] * inv_ell * y[2];
        }
        if all_finite(&t) {
            Ok(t)
        } else {
            Err(InputError::Overflow {
                quantity: "wheel_torques",
            })
        }
    }

    /// `Err` naming the first non-finite steering direction.
    fn check_steer_finite(steer: &[Rot2<T>; N]) -> Result<(), InputError> {
        match steer
            .iter()
            .position(|r| !(r.cos.is_finite() && r.sin.is_finite()))
        {
            Some(i) => Err(InputError::NonFinite {
                field: name_of(&STEER, i),
            }),
            None => Ok(()),
        }
    }
}

impl<T: Real, const N: usize> Drive for Swerve<T, N> {
    type Scalar = T;
    type Actuators = SwerveState<T, N>;
    type Positions = SwervePositions<T, N>;
    const WHEELS: usize = N;

    fn rest(&self) -> SwerveState<T, N> {
        SwerveState {
            wheel_rates: [T::zero(); N],
            steer: [Rot2::identity(); N],
        }
    }

    /// [`Swerve::module_states`], then [`Swerve::optimize`] against `current` if enabled by
    /// [`Swerve::with_optimization`].
    #[inline]
    fn inverse(
        &self,
        twist: Twist2<T>,
        current: &SwerveState<T, N>,
    ) -> Result<SwerveState<T, N>, InputError> {
        let st = self.module_states(twist, &current.steer)?;
        Ok(if self.optimize {
            Self::optimize(st, &current.steer)
        } else {
            st
        })
    }

    #[inline]
    fn forward(&self, actuators: &SwerveState<T, N>) -> Result<Twist2<T>, InputError> {
        self.body_twist(actuators)
    }

    fn forward_fit(&self, actuators: &SwerveState<T, N>) -> Result<Fit<T>, InputError> {
        let f = self.body_fit(actuators)?;
        Ok(Fit {
            twist: f.twist,
            slip_residual: f.slip_residual,
        })
    }

    #[inline]
    fn displacement(
        &self,
        start: &SwervePositions<T, N>,
        end: &SwervePositions<T, N>,
    ) -> Result<Twist2<T>, InputError> {
        Swerve::displacement(self, start, end)
    }

    fn wheel_rates(actuators: &SwerveState<T, N>) -> &[T] {
        &actuators.wheel_rates
    }

    fn scale_wheel_rates(actuators: SwerveState<T, N>, factor: T) -> SwerveState<T, N> {
        SwerveState {
            wheel_rates: actuators.wheel_rates.map(|w| w * factor),
            steer: actuators.steer,
        }
    }
}
