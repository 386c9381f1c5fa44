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
//!
//! Files: this one holds the geometry and the value types; `model.rs` construction and the
//! constraint matrices, `kinematics.rs` the inverse and forward maps, `motion.rs` the special
//! motions of §3, [`slip`] the slip-error formulas of §4.

use crate::{Real, Twist2};

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

/// Cosines and sines of one wheel's angles (see `Caster3::wheel_trig`).
#[derive(Clone, Copy)]
struct WheelTrig<T> {
    /// `cos β_i`, `sin β_i`, `β_i = α_i + θ + γ_i`: the wheel's world direction.
    cb: T,
    sb: T,
    /// `cos γ_i`, `sin γ_i`: the steer angle.
    cg: T,
    sg: T,
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
    /// `1000 ε L²`, m²: the spread `Σ |q_i|²` of the wheel centres at or below which the
    /// forward kinematics call the yaw rate unobservable.
    min_spread: T,
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

mod kinematics;
mod model;
mod motion;
pub mod slip;

pub use kinematics::CasterInverseRows;
pub use motion::{FixedSteerMotion, SpinInPlace};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{GeometryError, InputError};

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
