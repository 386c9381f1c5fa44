//! Spherical robot rolled by an internal three-omni-wheel platform (paper 000).
//!
//! **Model.** A hollow shell of radius `R` rolls on the floor. Inside, a platform carries three
//! omni-wheels (rollers at angle `ξ` to the wheel axis) that roll on the shell's inner surface.
//! The platform frame has its origin at the shell centre, x forward, y left, z up (level
//! platform). For wheel `i` at azimuth `φ_i`, with axis tilt `δ` and wheel radius `R_i`, the
//! constant platform-frame vectors are (paper 000, §4)
//!
//! ```text
//! r_i = (R − R_i)(sinδ cosφ_i, sinδ sinφ_i, −cosδ)                    centre → wheel centre
//! n_i = (cosδ cosφ_i, cosδ sinφ_i, sinδ)                              wheel axis
//! α_i = (cosδ cosφ_i cosξ − sinφ_i sinξ, cosδ sinφ_i cosξ + cosφ_i sinξ, sinδ cosξ)  roller axis
//! s_i = r_i × α_i
//! ```
//!
//! and are computed once in [`SphereOmni::new`]. No slip along each roller axis gives
//! (paper 000, eq. 4.4) `s_i·ω̃ = (R_i/R)(s_i·n_i) χ̇_i` with `ω̃ = Ω − ω` the shell's angular
//! velocity relative to the platform. The shell rolls without slip on the floor, so
//! (paper 000, eq. 5.2, **corrected**, see below) `Ω = (1/R) e3 × V + Ω3 e3`; with a level
//! platform `ω = ψ̇ e3`, hence (eq. 5.6) `ω̃ = (1/R) e3 × V + (Ω3 − ψ̇) e3` and (eq. 5.7)
//! `χ̇_i = (R/R_i)(s_i·ω̃)/(s_i·n_i)`.
//!
//! * **Inverse** ([`SphereOmni::wheel_rates`]): platform-frame velocity `V = (vx, vy)` of the
//!   shell centre, yaw rate `ψ̇` and shell spin `Ω3` → wheel rates `χ̇_i` (rad/s, right-handed
//!   about `n_i`). One 3×3 matrix–vector product.
//! * **Forward** ([`SphereOmni::body_twist`]): wheel rates and an assumed `Ω3` → twist. The map
//!   is square and invertible for an accepted geometry, so this is an exact inverse (one
//!   product with a matrix inverted at construction). `Ω3` is not observable from the wheels
//!   alone; [`SphereOmni::shell_spin`] recovers it when the yaw rate is measured (gyro).
//!
//! **Erratum E1.** The paper prints `Ω = (1/R) V × γ + Ω3 γ`; substituted into its own floor
//! no-slip condition (5.1) that leaves the floor contact moving at `2V`. The sign is fixed
//! here, and the tests evaluate the floor-contact and roller-contact velocities to pin it.
//!
//! Calls do not apply wheel-rate limits; the caller checks or desaturates.

use nalgebra::{Matrix3, Vector3};

use crate::real::{finite, finite_out, finite_param, finite3, positive};
use crate::{GeometryError, InputError, MAX_CONDITION, Real, Twist2, condition_number};

/// Geometry of a spherical robot with an internal three-omni-wheel platform (paper 000, §4 and
/// §6). Lengths in metres, angles in radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereParams<T> {
    /// Shell radius `R`, m.
    pub shell_radius: T,
    /// Radius `R_i` of each omni-wheel, m (all equal on the paper's robot).
    pub wheel_radius: [T; 3],
    /// Tilt `δ` of the wheel axes from horizontal, rad.
    pub tilt: T,
    /// Roller angle `ξ` between the roller axis and the wheel axis, rad.
    pub roller_angle: T,
    /// Azimuth `φ_i` of each wheel in the platform frame, rad (paper: 0, 2π/3, 4π/3).
    pub azimuths: [T; 3],
}

impl<T: Real> SphereParams<T> {
    /// The robot built in paper 000, §6: `R = 0.15 m`, `R_i = 0.07 m`, `δ = ξ = 45°`,
    /// `φ = 0°, 120°, 240°` (the `sphere-omni` preset).
    pub fn preset() -> Self {
        let deg = core::f64::consts::PI / 180.0;
        Self {
            shell_radius: T::of(0.15),
            wheel_radius: [T::of(0.07); 3],
            tilt: T::of(45.0 * deg),
            roller_angle: T::of(45.0 * deg),
            azimuths: [T::of(0.0), T::of(120.0 * deg), T::of(240.0 * deg)],
        }
    }
}

/// Kinematic model of the spherical robot (paper 000), with every geometric vector and both
/// twist ↔ wheel-rate matrices precomputed. Immutable and `Copy`; calls never allocate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereOmni<T> {
    params: SphereParams<T>,
    r: [Vector3<T>; 3],
    n: [Vector3<T>; 3],
    alpha: [Vector3<T>; 3],
    s: [Vector3<T>; 3],
    s_dot_n: [T; 3],
    /// `χ̇ = G ω̃`, rows `(R/R_i) s_iᵀ / (s_i·n_i)` (eq. 4.4 solved for `χ̇`).
    g: Matrix3<T>,
    /// `ω̃ = G⁻¹ χ̇`.
    g_inv: Matrix3<T>,
    condition: f64,
}

/// Relative tolerance below which `|s_i·n_i| / |s_i|` counts as zero (roller axis parallel to
/// the wheel axis: the wheel cannot push the shell).
const DEAD_WHEEL_TOL: f64 = 1.0e-3;

impl<T: Real> SphereOmni<T> {
    /// Builds the model, precomputing `r_i, n_i, α_i, s_i, s_i·n_i` (paper 000, §4) and the
    /// matrices of eq. 4.4.
    ///
    /// # Errors
    /// [`GeometryError`] when a parameter is not finite, a radius is not positive, a wheel does
    /// not fit in the shell, a wheel's lever `s_i·n_i` vanishes (`ξ ≈ 0`: rollers parallel to
    /// the wheel axis), or the `s_i` are (nearly) coplanar — condition number of the
    /// row-normalised matrix `[s_1; s_2; s_3]` above [`MAX_CONDITION`].
    pub fn new(params: SphereParams<T>) -> Result<Self, GeometryError> {
        let big_r = positive(params.shell_radius, "shell_radius")?;
        const RADIUS: [&str; 3] = ["wheel_radius[0]", "wheel_radius[1]", "wheel_radius[2]"];
        const AZIMUTH: [&str; 3] = ["azimuths[0]", "azimuths[1]", "azimuths[2]"];
        for i in 0..3 {
            let rw = positive(params.wheel_radius[i], RADIUS[i])?;
            if rw >= big_r {
                return Err(GeometryError::WheelTooLarge {
                    wheel: i + 1,
                    wheel_radius: rw.to_f64(),
                    shell_radius: big_r.to_f64(),
                });
            }
            finite_param(params.azimuths[i], AZIMUTH[i])?;
        }
        let delta = finite_param(params.tilt, "tilt")?;
        let xi = finite_param(params.roller_angle, "roller_angle")?;

        let (sd, cd) = delta.sin_cos();
        let (sx, cx) = xi.sin_cos();
        let zero = Vector3::zeros();
        let (mut r, mut n, mut alpha, mut s) = ([zero; 3], [zero; 3], [zero; 3], [zero; 3]);
        let mut s_dot_n = [T::zero(); 3];
        let mut g = Matrix3::zeros();
        let mut s_unit = Matrix3::zeros();
        for i in 0..3 {
            let (sp, cp) = params.azimuths[i].sin_cos();
            let lever = big_r - params.wheel_radius[i];
            r[i] = Vector3::new(sd * cp, sd * sp, -cd) * lever;
            n[i] = Vector3::new(cd * cp, cd * sp, sd);
            alpha[i] = Vector3::new(cd * cp * cx - sp * sx, cd * sp * cx + cp * sx, sd * cx);
            s[i] = r[i].cross(&alpha[i]);
            s_dot_n[i] = s[i].dot(&n[i]);
            let s_norm = s[i].norm();
            if s_norm <= T::zero() || (s_dot_n[i] / s_norm).abs() < T::of(DEAD_WHEEL_TOL) {
                return Err(GeometryError::DeadWheel {
                    wheel: i + 1,
                    quantity: "s·n / |s|",
                    value: if s_norm > T::zero() {
                        (s_dot_n[i] / s_norm).to_f64()
                    } else {
                        0.0
                    },
                    rule: "roller axis parallel to the wheel axis; use a roller angle ξ away from 0",
                });
            }
            let row = s[i] * (big_r / (params.wheel_radius[i] * s_dot_n[i]));
            g.set_row(i, &row.transpose());
            s_unit.set_row(i, &(s[i] / s_norm).transpose());
        }
        let condition = condition_number(&s_unit);
        let ill = || GeometryError::IllConditioned {
            what: "wheel constraint matrix [s1; s2; s3] (paper 000, eq. 4.4)",
            condition,
            max: MAX_CONDITION,
        };
        if condition.is_nan() || condition > MAX_CONDITION {
            return Err(ill());
        }
        let g_inv = g.try_inverse().ok_or_else(ill)?;
        Ok(Self {
            params,
            r,
            n,
            alpha,
            s,
            s_dot_n,
            g,
            g_inv,
            condition,
        })
    }

    /// The parameters the model was built from.
    pub fn params(&self) -> &SphereParams<T> {
        &self.params
    }
    /// `r_i`: shell centre → wheel centre, platform frame, m (paper 000, §4).
    pub fn wheel_centres(&self) -> &[Vector3<T>; 3] {
        &self.r
    }
    /// `n_i`: unit wheel axes, platform frame (paper 000, §4).
    pub fn wheel_axes(&self) -> &[Vector3<T>; 3] {
        &self.n
    }
    /// `α_i`: unit roller axes at the contact, platform frame (paper 000, §4).
    pub fn roller_axes(&self) -> &[Vector3<T>; 3] {
        &self.alpha
    }
    /// `s_i = r_i × α_i`, platform frame, m (paper 000, §4).
    pub fn levers(&self) -> &[Vector3<T>; 3] {
        &self.s
    }
    /// `s_i·n_i`, m (paper 000, eq. 4.4; `(R − R_i) sin ξ` for this geometry).
    pub fn s_dot_n(&self) -> [T; 3] {
        self.s_dot_n
    }
    /// 2-norm condition number of the row-normalised `[s_1; s_2; s_3]` (1 is ideal).
    pub fn condition_number(&self) -> f64 {
        self.condition
    }
    /// The contact points of the wheels on the shell, `r_i · R/(R − R_i)`, platform frame, m
    /// (paper 000, eq. 4.1).
    pub fn contact_points(&self) -> [Vector3<T>; 3] {
        let big_r = self.params.shell_radius;
        core::array::from_fn(|i| self.r[i] * (big_r / (big_r - self.params.wheel_radius[i])))
    }

    /// Wheel rates `χ̇_i` (rad/s) from the shell's angular velocity relative to the platform,
    /// `ω̃ = Ω − ω` (rad/s, platform frame): `χ̇_i = (R/R_i)(s_i·ω̃)/(s_i·n_i)`
    /// (paper 000, eq. 4.4).
    pub fn wheel_rates_from_relative(&self, omega_rel: Vector3<T>) -> Result<[T; 3], InputError> {
        finite3(
            omega_rel.into(),
            ["omega_rel.x", "omega_rel.y", "omega_rel.z"],
        )?;
        finite_out((self.g * omega_rel).into(), "wheel_rates")
    }

    /// Shell angular velocity relative to the platform, `ω̃ = (1/R) e3 × V + (Ω3 − ψ̇) e3`
    /// (rad/s, platform frame; paper 000, eq. 5.6 with erratum E1 corrected), for the
    /// platform-frame twist `(vx, vy, ψ̇)` and shell spin `Ω3` (rad/s about the vertical).
    pub fn relative_rate(&self, twist: Twist2<T>, shell_spin: T) -> Result<Vector3<T>, InputError> {
        twist.check_finite()?;
        finite(shell_spin, "shell_spin")?;
        let inv_r = T::one() / self.params.shell_radius;
        let w: [T; 3] = finite_out(
            [
                -twist.vy * inv_r,
                twist.vx * inv_r,
                shell_spin - twist.yaw_rate,
            ],
            "relative rate",
        )?;
        Ok(Vector3::from(w))
    }

    /// Absolute angular velocity of the shell, `Ω = (1/R) e3 × V + Ω3 e3` (rad/s, platform
    /// frame; paper 000, eq. 5.2 **as corrected by erratum E1**), for the platform-frame
    /// velocity in `twist` and shell spin `Ω3`. Rolling without slip on the floor: the shell
    /// point touching the floor, `−R e3`, has velocity `V + Ω × (−R e3) = 0`.
    pub fn shell_angular_velocity(
        &self,
        twist: Twist2<T>,
        shell_spin: T,
    ) -> Result<Vector3<T>, InputError> {
        let w = self.relative_rate(twist, shell_spin)?;
        Ok(Vector3::new(w.x, w.y, shell_spin))
    }

    /// **Inverse kinematics** (paper 000, eqs. 5.6–5.7): wheel rates `χ̇_i` (rad/s,
    /// right-handed about `n_i`) that move the shell centre with the platform-frame velocity
    /// `(twist.vx, twist.vy)` (m/s) while the platform turns at `twist.yaw_rate = ψ̇` (rad/s)
    /// and the shell spins about the vertical at `shell_spin = Ω3` (rad/s; 0 for "rubber
    /// rolling", the paper's choice). The rates are not limited.
    pub fn wheel_rates(&self, twist: Twist2<T>, shell_spin: T) -> Result<[T; 3], InputError> {
        let w = self.relative_rate(twist, shell_spin)?;
        finite_out((self.g * w).into(), "wheel_rates")
    }

    /// [`SphereOmni::wheel_rates`] at zero shell spin without its input and output checks: the
    /// same arithmetic, the same bits, for a caller that checks the rates itself (a
    /// non-finite twist gives non-finite rates).
    #[inline(always)]
    pub(crate) fn wheel_rates_unchecked(&self, twist: Twist2<T>) -> [T; 3] {
        let inv_r = T::one() / self.params.shell_radius;
        let w = Vector3::new(
            -twist.vy * inv_r,
            twist.vx * inv_r,
            T::zero() - twist.yaw_rate,
        );
        (self.g * w).into()
    }

    /// [`SphereOmni::wheel_rates`] for a **world-frame** velocity `ṙ_C` and platform heading
    /// `ψ` (rad): `V = Q(ψ)ᵀ ṙ_C` (paper 000, eq. 5.4 and §5).
    pub fn wheel_rates_world(
        &self,
        twist_world: Twist2<T>,
        heading: T,
        shell_spin: T,
    ) -> Result<[T; 3], InputError> {
        finite(heading, "heading")?;
        twist_world.check_finite()?;
        self.wheel_rates(twist_world.to_robot(heading), shell_spin)
    }

    /// **Forward kinematics to `ω̃`**: the shell's angular velocity relative to the platform
    /// (rad/s, platform frame) implied by the wheel rates (eq. 4.4 solved for `ω̃`).
    pub fn relative_rate_from_wheels(&self, wheel_rates: [T; 3]) -> Result<Vector3<T>, InputError> {
        finite3(
            wheel_rates,
            ["wheel_rates[0]", "wheel_rates[1]", "wheel_rates[2]"],
        )?;
        let w: [T; 3] = finite_out(
            (self.g_inv * Vector3::from(wheel_rates)).into(),
            "relative rate",
        )?;
        Ok(Vector3::from(w))
    }

    /// **Forward kinematics** (inverse of eqs. 5.6–5.7): the platform-frame twist (shell-centre
    /// velocity `vx, vy` in m/s and platform yaw rate `ψ̇` in rad/s) produced by the wheel rates
    /// (rad/s), given the shell spin `Ω3` (rad/s; not observable from the wheels, 0 for rubber
    /// rolling). From `ω̃`: `vx = R ω̃_y`, `vy = −R ω̃_x`, `ψ̇ = Ω3 − ω̃_z`.
    pub fn body_twist(&self, wheel_rates: [T; 3], shell_spin: T) -> Result<Twist2<T>, InputError> {
        finite(shell_spin, "shell_spin")?;
        let w = self.relative_rate_from_wheels(wheel_rates)?;
        let big_r = self.params.shell_radius;
        let [vx, vy, wz] = finite_out([big_r * w.y, -big_r * w.x, shell_spin - w.z], "twist")?;
        Ok(Twist2::new(vx, vy, wz))
    }

    /// Shell spin `Ω3 = ω̃_z + ψ̇` (rad/s) from the wheel rates and a measured platform yaw rate
    /// `ψ̇` (rad/s, e.g. the gyro's z axis): the quantity paper 000 could not measure "without
    /// special means" (eq. 5.6 read backwards).
    pub fn shell_spin(&self, wheel_rates: [T; 3], yaw_rate: T) -> Result<T, InputError> {
        finite(yaw_rate, "yaw_rate")?;
        let [spin] = finite_out(
            [self.relative_rate_from_wheels(wheel_rates)?.z + yaw_rate],
            "shell_spin",
        )?;
        Ok(spin)
    }
}
