//! # caster — a base on three off-centred steerable wheels (paper 003)
//!
//! [`Caster3`] converts between the motion of a base that stands on three off-centred
//! (castor-like) wheels and the six motor rates that produce it. Each wheel `i` has a steering
//! axis `F_i`, fixed on the body at distance `D` from the body centre `C` and at mounting angle
//! `α_i`, and a wheel of radius `r` whose centre `O_i` trails the steering axis by the
//! eccentricity `d`; a rolling motor turns the wheel (roll rate `φ̇_i`, rad/s) and a steering
//! motor turns it about `F_i` (steer angle `γ_i` relative to the body, 0 = pointing radially
//! outward; steer rate `γ̇_i`, rad/s). With heading `θ`, wheel `i` points along the world
//! direction `β_i = α_i + θ + γ_i` (rad).
//!
//! * The **inverse** kinematics, [`Caster3::motor_rates`], takes a desired **world-frame** twist
//!   `q̇ = (ẋ, ẏ, θ̇)` (m/s, m/s, rad/s) with the current heading `θ` and steer angles `γ`, and
//!   returns the roll and steer rates the no-slip condition requires: the rows of `N_i`
//!   (paper 003, eq. (2)), stacked as `φ̇ = J1 q̇`, `γ̇ = J2 q̇` (paper 003, eqs. (4), (5)).
//! * The **forward** kinematics, [`Caster3::body_twist`], takes all six measured motor rates and
//!   returns the world-frame twist that best explains them. Six rates over-determine three
//!   unknowns, so this is a **least-squares fit**; its [`CasterForward::slip_residual`] (m/s)
//!   says how far the rates are from any rigid-body motion — zero, to rounding, for rates
//!   produced by the inverse, and growing with the wheels fighting each other. Each wheel's part
//!   ([`CasterForward::wheel_slip`]) is the velocity mismatch, in m/s, of the point above that
//!   wheel's centre `O_i` between what its two motors imply and the fitted rigid-body motion.
//!
//! The per-wheel model is paper 003, eq. (1) (`M_i`, motor rates → body velocity) and eq. (2)
//! (`N_i`, its inverse), with the no-slip constraint eq. (3)
//! `(D cos γ_i + d) θ̇ + d γ̇_i = ẋ sin β_i − ẏ cos β_i`. The special motions of §3 are
//! [`Caster3::fixed_steer_motion`] (det `J2` = 0, eq. (6)), [`Caster3::turn_in_place`]
//! (eq. (7)), [`Caster3::spin_in_place`] (eq. (8)) and [`Caster3::translation_from_wheel1`]
//! (eq. (9)); the slip-error estimates of §4 (eqs. (11)–(19)) are in [`slip`].
//!
//! Units are SI (m, rad, s); frames are REP-103 (z up, counter-clockwise positive). Note that the
//! twist is **world-frame** here (unlike the other robots); use [`Twist2::to_world`] to convert a
//! robot-frame command.
//!
//! What these calls do **not** do: they apply no motor speed or acceleration limits, do no
//! desaturation or rate scaling, do not optimise or unwrap steer angles (no "flip the wheel
//! instead of turning it 180°"), and do not integrate the steer angles over time — the caller
//! owns the steer-angle state and feeds the current `γ` to every call.

use nalgebra::Matrix3;

use crate::real::{finite, finite_param, finite3, positive};
use crate::{GeometryError, InputError, Real, Twist2};

/// Names of the steer-angle inputs, for [`InputError::NonFinite`].
const STEER: [&str; 3] = ["steer[0]", "steer[1]", "steer[2]"];
/// Names of the roll-rate inputs.
const ROLL_RATES: [&str; 3] = ["roll_rates[0]", "roll_rates[1]", "roll_rates[2]"];
/// Names of the steer-rate inputs.
const STEER_RATES: [&str; 3] = ["steer_rates[0]", "steer_rates[1]", "steer_rates[2]"];
/// Names of the mounting angles.
const MOUNT_ANGLES: [&str; 3] = ["mount_angles[0]", "mount_angles[1]", "mount_angles[2]"];

/// Smallest accepted distance between two steering axes, as a fraction of `D`:
/// `|F_i − F_j| = 2 D |sin((α_i − α_j)/2)|` must exceed `MIN_MOUNT_SEPARATION · D`.
pub const MIN_MOUNT_SEPARATION: f64 = 1.0e-6;

/// `(cos a, sin a)`.
#[inline]
fn cs<T: Real>(a: T) -> (T, T) {
    let (s, c) = a.sin_cos();
    (c, s)
}

/// Cosines and sines of one wheel's angles (see [`Caster3::wheel_trig_sc`]).
#[derive(Clone, Copy)]
struct WheelTrig<T> {
    /// `cos β_i`, `sin β_i`, `β_i = α_i + θ + γ_i`: the wheel's world direction.
    cb: T,
    sb: T,
    /// `cos γ_i`, `sin γ_i`: the steer angle.
    cg: T,
    sg: T,
}

/// All six rates zero (`CasterRates::default()` needs `T: Default`, which `Real` does not imply).
#[inline]
fn zero_rates<T: Real>() -> CasterRates<T> {
    CasterRates {
        roll: [T::zero(); 3],
        steer: [T::zero(); 3],
    }
}

/// Geometry of a three-caster base (paper 003, §2; SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CasterParams<T> {
    /// `D`, m: horizontal distance from the body centre `C` to each steering axis `F_i`.
    pub mount_radius: T,
    /// `d`, m: eccentricity, the horizontal offset from the steering axis `F_i` to the wheel
    /// centre `O_i`.
    pub eccentricity: T,
    /// `r`, m: wheel radius.
    pub wheel_radius: T,
    /// `α_i`, rad: angle of `C→F_i` from the body x axis (`CF_1`), counter-clockwise. The paper
    /// uses `(0, −2π/3, +2π/3)`.
    pub mount_angles: [T; 3],
}

impl<T: Real> CasterParams<T> {
    /// The reference robot (`robots/caster3.toml`): `D = 0.20 m`, `d = 0.04 m`, `r = 0.05 m`,
    /// `α = (0, −2π/3, +2π/3)` rad (paper 003, §2).
    pub fn preset() -> Self {
        let third = 2.0 * core::f64::consts::PI / 3.0;
        Self {
            mount_radius: T::of(0.20),
            eccentricity: T::of(0.04),
            wheel_radius: T::of(0.05),
            mount_angles: [T::zero(), T::of(-third), T::of(third)],
        }
    }
}

/// Kinematic model of a base on three off-centred steerable wheels (paper 003).
///
/// Built once from [`CasterParams`] with [`Caster3::new`], which validates the geometry and
/// precomputes the ratios `D/r`, `D/d`, `1/r`, `1/d`; every call afterwards is a few
/// trigonometric evaluations and fixed-size products, with no allocation and no panic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Caster3<T> {
    params: CasterParams<T>,
    /// `1/r`, 1/m.
    inv_r: T,
    /// `1/d`, 1/m.
    inv_d: T,
    /// `D/r`.
    big_d_over_r: T,
    /// `D/d`.
    big_d_over_d: T,
    /// `L = D + d`, m: length scale used to make the yaw column commensurate with the linear
    /// ones in tolerances.
    scale: T,
    /// `(cos α_i, sin α_i)` of the mounting angles.
    mount_cs: [(T, T); 3],
    /// `F̄ − C`, m: the centroid of the steering axes `F_i = C + D (cos α_i, sin α_i)`, robot
    /// frame.
    mount_mean: [T; 2],
    /// `F_i − F̄`, m: the steering axes relative to their centroid, robot frame.
    mount_centred: [[T; 2]; 3],
}

/// The six motor rates of a three-caster base.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CasterRates<T> {
    /// Roll rates `φ̇_i`, rad/s (paper 003 sign: `v_Oi = −r φ̇_i (cos β_i, sin β_i)`, so a
    /// positive roll rate moves the wheel centre *against* its direction `β_i`).
    pub roll: [T; 3],
    /// Steer rates `γ̇_i`, rad/s, counter-clockwise about the steering axis, relative to the body.
    pub steer: [T; 3],
}

/// Result of the forward kinematics [`Caster3::body_twist`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CasterForward<T> {
    /// Least-squares **world-frame** twist `(ẋ, ẏ, θ̇)` of the body centre `C`
    /// (m/s, m/s, rad/s).
    pub twist: Twist2<T>,
    /// Root-sum-square of all six weighted residuals, m/s: `sqrt(Σ_i wheel_slip[i]²)`. Zero (to
    /// rounding) when the motor rates are consistent with a rigid-body motion.
    pub slip_residual: T,
    /// Per wheel, m/s: the magnitude of the mismatch between the velocity of the body point above
    /// the wheel centre `O_i` implied by that wheel's two motors and the one of the fitted
    /// rigid-body motion (equivalently, the slip velocity wheel `i` would need).
    pub wheel_slip: [T; 3],
}

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
    /// Validates the geometry and builds the model.
    ///
    /// # Errors
    /// * [`GeometryError::NonFinite`] / [`GeometryError::NotPositive`] when `mount_radius` (`D`),
    ///   `eccentricity` (`d`) or `wheel_radius` (`r`) is not finite and `> 0`;
    /// * [`GeometryError::NonFinite`] naming `mount_angles[i]` for a non-finite angle, or naming
    ///   `"mount_radius / wheel_radius"` etc. if a precomputed ratio overflows;
    /// * [`GeometryError::AngleOutOfRange`] with field `"mount_angles"` when two steering axes
    ///   (nearly) coincide: `2|sin((α_i − α_j)/2)| ≤` [`MIN_MOUNT_SEPARATION`].
    pub fn new(params: CasterParams<T>) -> Result<Self, GeometryError> {
        let big_d = positive(params.mount_radius, "mount_radius")?;
        let d = positive(params.eccentricity, "eccentricity")?;
        let r = positive(params.wheel_radius, "wheel_radius")?;
        for (&a, &name) in params.mount_angles.iter().zip(MOUNT_ANGLES.iter()) {
            finite_param(a, name)?;
        }
        let a = params.mount_angles;
        for (i, j) in [(0, 1), (0, 2), (1, 2)] {
            let sep = T::of(2.0) * ((a[i] - a[j]) * T::of(0.5)).sin().abs();
            if sep <= T::of(MIN_MOUNT_SEPARATION) {
                return Err(GeometryError::AngleOutOfRange {
                    field: "mount_angles",
                    value: a[j].to_f64(),
                    rule: "the steering axes F_i = D·(cos α_i, sin α_i) must be distinct: \
                           2|sin((α_i − α_j)/2)| > 1e-6 for every pair of wheels",
                });
            }
        }
        let inv_r = finite_param(T::one() / r, "1 / wheel_radius")?;
        let inv_d = finite_param(T::one() / d, "1 / eccentricity")?;
        let big_d_over_r = finite_param(big_d / r, "mount_radius / wheel_radius")?;
        let big_d_over_d = finite_param(big_d / d, "mount_radius / eccentricity")?;
        let scale = finite_param(big_d + d, "mount_radius + eccentricity")?;
        let mount_cs = [cs(a[0]), cs(a[1]), cs(a[2])];
        let mount_pos = mount_cs.map(|(c, s)| [big_d * c, big_d * s]);
        let mount_mean = [
            (mount_pos[0][0] + mount_pos[1][0] + mount_pos[2][0]) * T::of(1.0 / 3.0),
            (mount_pos[0][1] + mount_pos[1][1] + mount_pos[2][1]) * T::of(1.0 / 3.0),
        ];
        let mount_centred = mount_pos.map(|f| [f[0] - mount_mean[0], f[1] - mount_mean[1]]);
        Ok(Self {
            params,
            inv_r,
            inv_d,
            big_d_over_r,
            big_d_over_d,
            scale,
            mount_cs,
            mount_mean,
            mount_centred,
        })
    }

    /// The geometry the model was built from.
    #[inline]
    pub fn params(&self) -> &CasterParams<T> {
        &self.params
    }

    /// World directions of the wheels, `β_i = α_i + θ + γ_i` (rad, not wrapped), for heading `θ`
    /// (rad) and steer angles `γ_i` (rad) (paper 003, §2). Non-finite input gives non-finite
    /// output.
    #[inline]
    pub fn wheel_directions(&self, heading: T, steer: [T; 3]) -> [T; 3] {
        let a = self.params.mount_angles;
        [
            a[0] + heading + steer[0],
            a[1] + heading + steer[1],
            a[2] + heading + steer[2],
        ]
    }

    /// The cosines and sines of `β_i = α_i + θ + γ_i` and `γ_i` for the three wheels, from
    /// `(sin θ, cos θ)` of the heading, one `sin_cos` per steer angle and the precomputed
    /// `(cos α_i, sin α_i)`, by the angle-addition formulas.
    #[inline(always)]
    fn wheel_trig_sc(&self, heading_sc: (T, T), steer: [T; 3]) -> [WheelTrig<T>; 3] {
        let (st, ct) = heading_sc;
        let wheel = |i: usize| {
            let (cm, sm) = self.mount_cs[i];
            let (cg, sg) = cs(steer[i]);
            let (ca, sa) = (cm * ct - sm * st, sm * ct + cm * st);
            WheelTrig {
                cb: ca * cg - sa * sg,
                sb: sa * cg + ca * sg,
                cg,
                sg,
            }
        };
        [wheel(0), wheel(1), wheel(2)]
    }

    /// Row `i` of `J1` (× `1/r`-scaled): `[−cos β_i/r, −sin β_i/r, −(D/r) sin γ_i]`.
    #[inline]
    fn j1_row(&self, beta: T, gamma: T) -> [T; 3] {
        let (c, s) = cs(beta);
        [
            -c * self.inv_r,
            -s * self.inv_r,
            -self.big_d_over_r * gamma.sin(),
        ]
    }

    /// Row `i` of `J2`: `[sin β_i/d, −cos β_i/d, −(D/d) cos γ_i − 1]`.
    #[inline]
    fn j2_row(&self, beta: T, gamma: T) -> [T; 3] {
        let (c, s) = cs(beta);
        [
            s * self.inv_d,
            -c * self.inv_d,
            -self.big_d_over_d * gamma.cos() - T::one(),
        ]
    }

    /// `M_i` (paper 003, eq. (1)): maps wheel `wheel`'s `[φ̇_i; γ̇_i; θ̇]` (rad/s) to the
    /// world-frame `[ẋ; ẏ; θ̇]` (m/s, m/s, rad/s) it implies on its own:
    ///
    /// ```text
    /// M_i = [ −r cos β_i    d sin β_i   D sin(α_i+θ) + d sin β_i ;
    ///         −r sin β_i   −d cos β_i  −D cos(α_i+θ) − d cos β_i ;
    ///          0            0           1 ]
    /// ```
    ///
    /// `wheel` is 0-based (0, 1, 2); `None` when out of range. `heading` = `θ`, `steer` = `γ_i`
    /// (rad). Non-finite input gives a non-finite matrix.
    pub fn m_matrix(&self, wheel: usize, heading: T, steer: T) -> Option<Matrix3<T>> {
        let alpha = *self.params.mount_angles.get(wheel)?;
        let p = &self.params;
        let a = alpha + heading;
        let (ca, sa) = cs(a);
        let (cb, sb) = cs(a + steer);
        let (big_d, d, r) = (p.mount_radius, p.eccentricity, p.wheel_radius);
        Some(Matrix3::new(
            -r * cb,
            d * sb,
            big_d * sa + d * sb,
            -r * sb,
            -d * cb,
            -big_d * ca - d * cb,
            T::zero(),
            T::zero(),
            T::one(),
        ))
    }

    /// `N_i = M_i⁻¹` (paper 003, eq. (2)): maps the world-frame `[ẋ; ẏ; θ̇]` (m/s, m/s, rad/s)
    /// to wheel `wheel`'s `[φ̇_i; γ̇_i; θ̇]` (rad/s):
    ///
    /// ```text
    /// N_i = [ −cos β_i/r   −sin β_i/r   −(D/r) sin γ_i ;
    ///          sin β_i/d   −cos β_i/d   −(D/d) cos γ_i − 1 ;
    ///          0            0            1 ]
    /// ```
    ///
    /// `wheel` is 0-based; `None` when out of range. Non-finite input gives a non-finite matrix.
    pub fn n_matrix(&self, wheel: usize, heading: T, steer: T) -> Option<Matrix3<T>> {
        let alpha = *self.params.mount_angles.get(wheel)?;
        let beta = alpha + heading + steer;
        let a = self.j1_row(beta, steer);
        let b = self.j2_row(beta, steer);
        Some(Matrix3::new(
            a[0],
            a[1],
            a[2],
            b[0],
            b[1],
            b[2],
            T::zero(),
            T::zero(),
            T::one(),
        ))
    }

    /// `J1` (paper 003, eq. (4)): the first rows of `N_1, N_2, N_3` stacked, so that
    /// `φ̇ = J1 q̇` (rad/s from the world-frame `q̇ = [ẋ; ẏ; θ̇]` in m/s, m/s, rad/s).
    pub fn j1(&self, heading: T, steer: [T; 3]) -> Matrix3<T> {
        let beta = self.wheel_directions(heading, steer);
        let r0 = self.j1_row(beta[0], steer[0]);
        let r1 = self.j1_row(beta[1], steer[1]);
        let r2 = self.j1_row(beta[2], steer[2]);
        Matrix3::new(
            r0[0], r0[1], r0[2], r1[0], r1[1], r1[2], r2[0], r2[1], r2[2],
        )
    }

    /// `J2` (paper 003, eq. (5)): the second rows of `N_1, N_2, N_3` stacked, so that
    /// `γ̇ = J2 q̇` (rad/s from the world-frame `q̇`).
    pub fn j2(&self, heading: T, steer: [T; 3]) -> Matrix3<T> {
        let beta = self.wheel_directions(heading, steer);
        let r0 = self.j2_row(beta[0], steer[0]);
        let r1 = self.j2_row(beta[1], steer[1]);
        let r2 = self.j2_row(beta[2], steer[2]);
        Matrix3::new(
            r0[0], r0[1], r0[2], r1[0], r1[1], r1[2], r2[0], r2[1], r2[2],
        )
    }

    /// `det J2` (units 1/m²), paper 003, eq. (6): the base can move with its steering held fixed
    /// only where it vanishes (see [`Caster3::fixed_steer_motion`], which uses a scale-free
    /// version of it).
    pub fn det_j2(&self, heading: T, steer: [T; 3]) -> T {
        self.j2(heading, steer).determinant()
    }

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
        self.motor_rates_sc(twist_world, heading, heading.sin_cos(), steer)
    }

    /// [`Caster3::motor_rates`] with `heading_sc = (sin θ, cos θ)` of the heading already known
    /// (the runtime shares one `sin_cos` per cycle between its frame changes and this call);
    /// `heading` itself only names the field in an error.
    #[inline]
    pub(crate) fn motor_rates_sc(
        &self,
        twist_world: Twist2<T>,
        heading: T,
        heading_sc: (T, T),
        steer: [T; 3],
    ) -> Result<CasterRates<T>, InputError> {
        let q = twist_world.to_array();
        let trig = self.wheel_trig_sc(heading_sc, steer);
        let mut out = zero_rates();
        let wheel = |w: &WheelTrig<T>| {
            // Rows i of J1 and J2 (see `j1_row`, `j2_row`).
            let a = [
                -w.cb * self.inv_r,
                -w.sb * self.inv_r,
                -self.big_d_over_r * w.sg,
            ];
            let b = [
                w.sb * self.inv_d,
                -w.cb * self.inv_d,
                -self.big_d_over_d * w.cg - T::one(),
            ];
            (
                a[0] * q[0] + a[1] * q[1] + a[2] * q[2],
                b[0] * q[0] + b[1] * q[1] + b[2] * q[2],
            )
        };
        (out.roll[0], out.steer[0]) = wheel(&trig[0]);
        (out.roll[1], out.steer[1]) = wheel(&trig[1]);
        (out.roll[2], out.steer[2]) = wheel(&trig[2]);
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
    /// # Errors
    /// * [`InputError::NonFinite`] naming `"roll_rates[i]"`, `"steer_rates[i]"`, `"heading"` or
    ///   `"steer[i]"`;
    /// * [`InputError::Singular`] when the three wheel centres `O_i` (nearly) coincide, so the
    ///   yaw rate is unobservable: `Σ |p_i − p̄|² ≤ 1000 ε (D + d)²`. This is possible only when
    ///   `d = D` and every `γ_i = π`.
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
        let fit = self.body_twist_robot_unchecked(rates, steer);
        if fit.is_err() || !heading.is_finite() {
            finite3(rates.roll, ROLL_RATES)?;
            finite3(rates.steer, STEER_RATES)?;
            finite(heading, "heading")?;
            finite3(steer, STEER)?;
        }
        let f = fit?;
        let twist = f.twist.to_world(heading);
        if !twist.is_finite() {
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
    /// steering-axis geometry precomputed at construction: one `sin_cos` per steer angle).
    /// The counterpart of WPILib's `SwerveDriveKinematics::ToChassisSpeeds`, whose chassis
    /// speeds are robot-relative too.
    ///
    /// # Errors
    /// * [`InputError::NonFinite`] naming `"roll_rates[i]"`, `"steer_rates[i]"` or
    ///   `"steer[i]"`, in that order of precedence;
    /// * [`InputError::Singular`] as for [`Caster3::body_twist`].
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
    /// precomputed, so the only trigonometry is one `sin_cos` per steer angle; the fit is the
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
        let dir = core::array::from_fn(|i| {
            let (cm, sm) = self.mount_cs[i];
            let (cg, sg) = cs(steer[i]);
            [cm * cg - sm * sg, sm * cg + cm * sg]
        });
        self.fit(self.mount_centred, self.mount_mean, dir, rates)
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
        if spread <= T::of(1.0e3) * T::EPSILON * self.scale * self.scale {
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
        if !twist.is_finite() {
            return Err(InputError::Singular {
                reason: "the least-squares twist overflows: motor rates too large for the scalar type",
            });
        }
        let mut wheel_slip = [T::zero(); 3];
        let mut total = T::zero();
        for i in 0..3 {
            let ex = n[i][0] + omega * q[i][1];
            let ey = n[i][1] - omega * q[i][0];
            let e2 = ex * ex + ey * ey;
            wheel_slip[i] = e2.sqrt();
            total += e2;
        }
        if !total.is_finite() {
            return Err(InputError::Singular {
                reason: "the slip residual overflows: motor rates too large for the scalar type",
            });
        }
        Ok(CasterForward {
            twist,
            slip_residual: total.sqrt(),
            wheel_slip,
        })
    }

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

/// Slip errors from imperfect motor speeds, paper 003, §4 (eqs. (11)–(19)).
///
/// All of these consider **one wheel on its own** over a short interval with `θ̇ = 0`, constant
/// steer rate `Ρ` (rad/s) and constant roll rate `Ξ` (rad/s), and give the body-centre
/// displacement that wheel alone implies (world frame, m). When the three wheels imply different
/// displacements they fight and slip; the differences computed here estimate that slip. Wheel
/// directions are world angles `β = α_i + θ + γ_i` (rad).
pub mod slip {
    use crate::real::finite;
    use crate::{InputError, Real};

    /// `sin x / x`, with its Taylor series near 0.
    #[inline]
    fn sinc<T: Real>(x: T) -> T {
        if x.abs() < T::of(1.0e-3) {
            let x2 = x * x;
            T::one() - x2 / T::of(6.0) + x2 * x2 / T::of(120.0)
        } else {
            x.sin() / x
        }
    }

    /// A displacement of the body centre in the world frame, m.
    #[derive(Clone, Copy, Debug, Default, PartialEq)]
    pub struct Displacement<T> {
        /// Along world x, m.
        pub dx: T,
        /// Along world y, m.
        pub dy: T,
    }

    /// Inputs of [`single_wheel_step`] (paper 003, eqs. (11)–(13)).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct WheelStep<T> {
        /// `r`, wheel radius, m.
        pub wheel_radius: T,
        /// `d`, eccentricity, m.
        pub eccentricity: T,
        /// `β_0 = α_i + θ_0 + γ_i0`, the wheel's world direction at `t_0`, rad.
        pub beta0: T,
        /// `Ρ`, constant steer rate, rad/s (may be 0).
        pub steer_rate: T,
        /// `Ξ`, constant roll rate, rad/s.
        pub roll_rate: T,
        /// `T = t_1 − t_0`, the control period, s.
        pub period: T,
    }

    /// Result of [`single_wheel_step`].
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct WheelStepResult<T> {
        /// Body-centre displacement `(x_1 − x_0, y_1 − y_0)`, world frame, m.
        pub displacement: Displacement<T>,
        /// `β_1 = β_0 + Ρ T`, the wheel direction at `t_1`, rad (not wrapped).
        pub beta1: T,
    }

    /// Body-centre displacement implied by one wheel over one period, paper 003, eqs. (12), (13),
    /// the exact integral of eq. (11) `ẋ = −r Ξ cos β + d Ρ sin β`,
    /// `ẏ = −r Ξ sin β − d Ρ cos β`, `β(t) = β_0 + Ρ (t − t_0)`, `θ̇ = 0`:
    ///
    /// `x_1 − x_0 = −(r Ξ/Ρ)[sin β_1 − sin β_0] − d [cos β_1 − cos β_0]`,
    /// `y_1 − y_0 = (r Ξ/Ρ)[cos β_1 − cos β_0] − d [sin β_1 − sin β_0]`, `β_1 = β_0 + Ρ T`.
    ///
    /// Evaluated in the division-free form (with `h = Ρ T`, `β_m = β_0 + h/2`)
    /// `x_1 − x_0 = −r Ξ T cos β_m sinc(h/2) + 2 d sin β_m sin(h/2)`,
    /// `y_1 − y_0 = −r Ξ T sin β_m sinc(h/2) − 2 d cos β_m sin(h/2)`, which is accurate as
    /// `Ρ → 0` and reduces to the straight line `−r Ξ T (cos β_0, sin β_0)` at `Ρ = 0`.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming the non-finite field (`"wheel_radius"`, `"eccentricity"`,
    /// `"beta0"`, `"steer_rate"`, `"roll_rate"`, `"period"`), or `"displacement"` if the result
    /// overflows.
    pub fn single_wheel_step<T: Real>(
        step: &WheelStep<T>,
    ) -> Result<WheelStepResult<T>, InputError> {
        let r = finite(step.wheel_radius, "wheel_radius")?;
        let d = finite(step.eccentricity, "eccentricity")?;
        let beta0 = finite(step.beta0, "beta0")?;
        let rho = finite(step.steer_rate, "steer_rate")?;
        let xi = finite(step.roll_rate, "roll_rate")?;
        let t = finite(step.period, "period")?;
        let h = rho * t;
        let half = h * T::of(0.5);
        let (sm, cm) = (beta0 + half).sin_cos();
        let sh = half.sin();
        let lin = r * xi * t * sinc(half);
        let dx = -lin * cm + T::of(2.0) * d * sm * sh;
        let dy = -lin * sm - T::of(2.0) * d * cm * sh;
        let beta1 = beta0 + h;
        if !(dx.is_finite() && dy.is_finite() && beta1.is_finite()) {
            return Err(InputError::NonFinite {
                field: "displacement",
            });
        }
        Ok(WheelStepResult {
            displacement: Displacement { dx, dy },
            beta1,
        })
    }

    /// Inputs of the speed-fluctuation error, paper 003, eqs. (15), (16).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct SpeedFluctuation<T> {
        /// `r`, wheel radius, m.
        pub wheel_radius: T,
        /// `d`, eccentricity, m.
        pub eccentricity: T,
        /// `β_1`, the nominal wheel direction at the end of the period, rad.
        pub beta1: T,
        /// `Ρ`, nominal steer rate, rad/s (must be ≠ 0).
        pub steer_rate: T,
        /// `Ξ`, nominal roll rate, rad/s.
        pub roll_rate: T,
        /// `ΔΡ`, steer-rate error, rad/s.
        pub steer_rate_error: T,
        /// `ΔΞ`, roll-rate error, rad/s (used by [`speed_fluctuation_full`] only; the linearised
        /// form assumes `(Ξ+ΔΞ)/(Ρ+ΔΡ) = Ξ/Ρ`).
        pub roll_rate_error: T,
        /// `T`, the control period, s.
        pub period: T,
    }

    /// Checks the common inputs of the fluctuation formulas; returns `(r, d, β_1, Ρ, Ξ, ΔΡ, ΔΞ,
    /// T, Ξ/Ρ)`.
    #[allow(clippy::type_complexity)]
    fn check_fluctuation<T: Real>(
        f: &SpeedFluctuation<T>,
    ) -> Result<(T, T, T, T, T, T, T, T, T), InputError> {
        let r = finite(f.wheel_radius, "wheel_radius")?;
        let d = finite(f.eccentricity, "eccentricity")?;
        let b1 = finite(f.beta1, "beta1")?;
        let rho = finite(f.steer_rate, "steer_rate")?;
        let xi = finite(f.roll_rate, "roll_rate")?;
        let drho = finite(f.steer_rate_error, "steer_rate_error")?;
        let dxi = finite(f.roll_rate_error, "roll_rate_error")?;
        let t = finite(f.period, "period")?;
        let ratio = ratio(xi, rho, "Ξ/Ρ: the steer rate Ρ is 0 (or Ξ/Ρ overflows)")?;
        Ok((r, d, b1, rho, xi, drho, dxi, t, ratio))
    }

    /// `num/den`, or [`InputError::Singular`] with `reason` when `den = 0` or it overflows.
    #[inline]
    fn ratio<T: Real>(num: T, den: T, reason: &'static str) -> Result<T, InputError> {
        if den == T::zero() {
            return Err(InputError::Singular { reason });
        }
        let q = num / den;
        if q.is_finite() {
            Ok(q)
        } else {
            Err(InputError::Singular { reason })
        }
    }

    /// Position error at `t_1` from a steer-rate fluctuation `ΔΡ`, the paper's **linearised**
    /// form, paper 003, eqs. (15), (16) (world frame, m):
    ///
    /// `Δx_1 = −r (Ξ/Ρ) ΔΡ T cos β_1 + d ΔΡ T sin β_1`,
    /// `Δy_1 = −r (Ξ/Ρ) ΔΡ T sin β_1 − d ΔΡ T cos β_1`.
    ///
    /// Assumptions (paper 003, §4): the angle error `ΔΡ T` is small (first order in it), and the
    /// roll rate fluctuates in proportion so the ratio is unchanged, `(Ξ+ΔΞ)/(Ρ+ΔΡ) = Ξ/Ρ`
    /// (`roll_rate_error` is ignored). It is the first-order expansion of
    /// [`speed_fluctuation_full`] in `ΔΡ T`; a test checks the two agree for small `ΔΡ T`. Note
    /// the error scales with `d ΔΡ T` and `r (Ξ/Ρ) ΔΡ T`: steer-motor fluctuation matters more
    /// than roll-motor fluctuation.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming a non-finite field; [`InputError::Singular`] when
    /// `Ρ = 0` (or `Ξ/Ρ` overflows).
    pub fn speed_fluctuation<T: Real>(
        f: &SpeedFluctuation<T>,
    ) -> Result<Displacement<T>, InputError> {
        let (r, d, b1, _rho, _xi, drho, _dxi, t, ratio) = check_fluctuation(f)?;
        let (s, c) = b1.sin_cos();
        let e = drho * t;
        let dx = -r * ratio * e * c + d * e * s;
        let dy = -r * ratio * e * s - d * e * c;
        if !(dx.is_finite() && dy.is_finite()) {
            return Err(InputError::NonFinite {
                field: "displacement",
            });
        }
        Ok(Displacement { dx, dy })
    }

    /// Position error at `t_1` from rate fluctuations `ΔΡ`, `ΔΞ`, the un-linearised form the
    /// paper starts from, paper 003, §4 before eqs. (15), (16) (world frame, m):
    ///
    /// `Δx_1 = −r [(Ξ+ΔΞ)/(Ρ+ΔΡ) sin(β_1+ΔΡT) − (Ξ/Ρ) sin β_1] − d [cos(β_1+ΔΡT) − cos β_1]`,
    /// `Δy_1 = r [(Ξ+ΔΞ)/(Ρ+ΔΡ) cos(β_1+ΔΡT) − (Ξ/Ρ) cos β_1] − d [sin(β_1+ΔΡT) − sin β_1]`.
    ///
    /// This is the difference between the end points of eqs. (12), (13) with the perturbed and
    /// the nominal rates, taken from the same start, **when the ratio is unchanged**
    /// (`(Ξ+ΔΞ)/(Ρ+ΔΡ) = Ξ/Ρ`); otherwise the exact difference has the extra term
    /// `+ r ((Ξ+ΔΞ)/(Ρ+ΔΡ) − Ξ/Ρ)(sin β_0, −cos β_0)`, which the paper's form (implemented here
    /// as printed) omits.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming a non-finite field; [`InputError::Singular`] when `Ρ = 0`
    /// or `Ρ + ΔΡ = 0` (or a ratio overflows).
    pub fn speed_fluctuation_full<T: Real>(
        f: &SpeedFluctuation<T>,
    ) -> Result<Displacement<T>, InputError> {
        let (r, d, b1, rho, xi, drho, dxi, t, ratio0) = check_fluctuation(f)?;
        let ratio1 = ratio(
            xi + dxi,
            rho + drho,
            "(Ξ+ΔΞ)/(Ρ+ΔΡ): the perturbed steer rate Ρ + ΔΡ is 0 (or the ratio overflows)",
        )?;
        let (s1, c1) = b1.sin_cos();
        let (s2, c2) = (b1 + drho * t).sin_cos();
        let dx = -r * (ratio1 * s2 - ratio0 * s1) - d * (c2 - c1);
        let dy = r * (ratio1 * c2 - ratio0 * c1) - d * (s2 - s1);
        if !(dx.is_finite() && dy.is_finite()) {
            return Err(InputError::NonFinite {
                field: "displacement",
            });
        }
        Ok(Displacement { dx, dy })
    }

    /// Inputs of the acceleration-phase error, paper 003, eqs. (18), (19).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct AccelerationRamp<T> {
        /// `r`, wheel radius, m.
        pub wheel_radius: T,
        /// `β_0 = α_i + θ_0 + γ_i0`, the wheel's world direction when the ramp starts, rad.
        pub beta0: T,
        /// `Ρ_0`, steer rate at the start of the ramp, rad/s.
        pub initial_steer_rate: T,
        /// `Ξ_0`, roll rate at the start of the ramp, rad/s.
        pub initial_roll_rate: T,
        /// `Ρ`, steer rate at the end of the ramp (target), rad/s (must be ≠ 0).
        pub steer_rate: T,
        /// `Ξ`, roll rate at the end of the ramp (target), rad/s.
        pub roll_rate: T,
        /// `t_σ − t_0`, the ramp duration (constant acceleration), s.
        pub duration: T,
    }

    /// Position error accumulated during a constant-acceleration ramp from `(Ρ_0, Ξ_0)` to
    /// `(Ρ, Ξ)`, paper 003, eqs. (18), (19) (world frame, m), using the rates averaged over the
    /// ramp:
    ///
    /// `Δx_1 = r ((Ξ+Ξ_0)/(Ρ+Ρ_0) − Ξ/Ρ) [sin β_0 − sin β_σ]`,
    /// `Δy_1 = r ((Ξ+Ξ_0)/(Ρ+Ρ_0) − Ξ/Ρ) [cos β_σ − cos β_0]`,
    /// `β_σ = β_0 + (Ρ+Ρ_0)/2 · (t_σ − t_0)`.
    ///
    /// It is the difference of eq. (12), (13) evaluated with the ratio of the averaged rates and
    /// with the target ratio `Ξ/Ρ`, over the same sweep `β_0 → β_σ` (the eccentricity terms
    /// cancel). Shorter ramps (higher acceleration) and lower roll rates reduce it.
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming a non-finite field; [`InputError::Singular`] when `Ρ = 0`
    /// or `Ρ + Ρ_0 = 0` (or a ratio overflows).
    pub fn acceleration_ramp<T: Real>(
        ramp: &AccelerationRamp<T>,
    ) -> Result<Displacement<T>, InputError> {
        let r = finite(ramp.wheel_radius, "wheel_radius")?;
        let b0 = finite(ramp.beta0, "beta0")?;
        let rho0 = finite(ramp.initial_steer_rate, "initial_steer_rate")?;
        let xi0 = finite(ramp.initial_roll_rate, "initial_roll_rate")?;
        let rho = finite(ramp.steer_rate, "steer_rate")?;
        let xi = finite(ramp.roll_rate, "roll_rate")?;
        let dt = finite(ramp.duration, "duration")?;
        let target = ratio(
            xi,
            rho,
            "Ξ/Ρ: the target steer rate Ρ is 0 (or Ξ/Ρ overflows)",
        )?;
        let avg = ratio(
            xi + xi0,
            rho + rho0,
            "(Ξ+Ξ0)/(Ρ+Ρ0): the mean steer rate over the ramp is 0 (or the ratio overflows)",
        )?;
        let k = r * (avg - target);
        let bs = b0 + (rho + rho0) * T::of(0.5) * dt;
        let (s0, c0) = b0.sin_cos();
        let (ss, cs) = bs.sin_cos();
        let dx = k * (s0 - ss);
        let dy = k * (cs - c0);
        if !(dx.is_finite() && dy.is_finite()) {
            return Err(InputError::NonFinite {
                field: "displacement",
            });
        }
        Ok(Displacement { dx, dy })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn preset() -> Caster3<f64> {
        Caster3::new(CasterParams::preset()).unwrap()
    }

    #[test]
    fn rejects_bad_geometry() {
        let mut p = CasterParams::<f64>::preset();
        p.eccentricity = 0.0;
        assert!(matches!(
            Caster3::new(p),
            Err(GeometryError::NotPositive {
                field: "eccentricity",
                ..
            })
        ));
        let mut p = CasterParams::<f64>::preset();
        p.mount_angles[2] = f64::NAN;
        assert_eq!(
            Caster3::new(p),
            Err(GeometryError::NonFinite {
                field: "mount_angles[2]"
            })
        );
        let mut p = CasterParams::<f64>::preset();
        p.mount_angles[2] = p.mount_angles[1] + 2.0 * core::f64::consts::PI;
        assert!(matches!(
            Caster3::new(p),
            Err(GeometryError::AngleOutOfRange {
                field: "mount_angles",
                ..
            })
        ));
    }

    #[test]
    fn wheel_index_out_of_range_is_none() {
        let c = preset();
        assert!(c.m_matrix(3, 0.0, 0.0).is_none());
        assert!(c.n_matrix(usize::MAX, 0.0, 0.0).is_none());
        assert!(c.n_matrix(2, 0.0, 0.0).is_some());
    }

    #[test]
    fn forward_singular_when_centres_coincide() {
        let mut p = CasterParams::<f64>::preset();
        p.eccentricity = p.mount_radius;
        let c = Caster3::new(p).unwrap();
        let pi = core::f64::consts::PI;
        let r = c.body_twist(&CasterRates::default(), 0.3, [pi, pi, pi]);
        assert!(matches!(r, Err(InputError::Singular { .. })), "{r:?}");
    }
}
