//! Ball-balancing robot (ballbot) on three omni-wheels (paper 001).
//!
//! **Model.** A body balances on a ball of radius `R_b`. Wheel `i` (radius `r_w`) touches the
//! ball at zenith angle `α` and, in the body-yaw-aligned frame, azimuth `β_i` (paper 001's
//! order: `0°, +120°, −120°`; in the world frame the azimuths are `β + β_i` with `β` the body
//! yaw). Its drive direction at the contact is the horizontal tangent `t_i = (−sinβ_i, cosβ_i,
//! 0)` and a positive wheel rate moves its rim at the contact along `+t_i` (wheel axis
//! `t_i × p̂_i`, `p̂_i` the unit contact direction). No slip along `t_i` gives the standard
//! ballbot relation (paper 001, velocity map)
//!
//! ```text
//! ψ̇_i = (R_b/r_w)(−cosα cosβ_i ω_x − cosα sinβ_i ω_y + sinα ω_z)
//! ```
//!
//! with `ω` the ball's angular velocity **relative to the body**. The ball rolls without slip:
//! `ẋ = R_b Ω_y`, `ẏ = −R_b Ω_x` for its absolute rate `Ω`; with the body upright and turning at
//! `β̇`, `ω = (−v_y/R_b, v_x/R_b, Ω_z − β̇)` in the body frame, `Ω_z` being the ball's spin about
//! the vertical (0 unless a spin is commanded or measured).
//!
//! * **Inverse** ([`Ballbot::wheel_rates`]): ball-centre velocity + body yaw rate (+ ball spin)
//!   → wheel rates (rad/s).
//! * **Forward** ([`Ballbot::body_twist`]): wheel rates (+ assumed ball spin) → ball velocity and
//!   body yaw rate; exact (square, invertible map precomputed at construction).
//! * **Torques** (paper 001, projections): model ("virtual wheel") torques
//!   `[Tx, Ty, Tz]ᵀ = A(β) [T1, T2, T3]ᵀ`, `A(β)` rows `cosα cos(β+β_i)`, `cosα sin(β+β_i)`,
//!   `sinα` ([`Ballbot::model_torques`]) and its inverse ([`Ballbot::wheel_torques`]). Their
//!   power-conjugate rates are the model rates `v = A(β)⁻ᵀ ψ̇` ([`Ballbot::model_rates`]), so
//!   `T·ψ̇ = (A T)·v` exactly: the velocity map `ψ̇ = A(β)ᵀ v` is the dual of the torque map.
//!   In the body frame `v = (R_b/r_w)(−ω_x, −ω_y, ω_z)`. Sign note: the torque the wheels
//!   exert on the ball is `τ_ball = (R_b/r_w)(−Tx, −Ty, Tz)` (body frame at `β = 0`), i.e. the
//!   model's `Tx`, `Ty` are opposite to the ball torque about x and y, as the paper's
//!   projection defines them; `Tz` has the ball torque's sign.
//! * **Odometry step** ([`Ballbot::ball_displacement`]): wheel-angle increments and the body
//!   yaw at both ends of the step → world-frame ball displacement; the body's own rotation
//!   (which turns every wheel through `sinα`) produces no displacement.
//!
//! **Errata** (seed digest): E2 — the printed inverse torque map swaps `Tx` and `Ty`; the
//! inverse here is the true inverse of the forward map (closed form at `β = 0`:
//! `T1 = ⅓(Tz/sinα + 2Tx/cosα)`, `T2 = ⅓(Tz/sinα − Tx/cosα + √3 Ty/cosα)`,
//! `T3 = ⅓(Tz/sinα − Tx/cosα − √3 Ty/cosα)`). E3 — the printed yaw projection is not a
//! rotation; here `A(β) = Rz(β) A(0)`: model torques at yaw `β` are the body-frame ones rotated
//! counter-clockwise by `β` (world frame). E4 — `T1+T2+T3 = Tx+Ty+Tz` does not hold and is not
//! used.
//!
//! Calls do not apply wheel-rate or torque limits.

use nalgebra::{Matrix3, Vector3};

use crate::real::{finite, finite_out, finite_param, finite3, positive};
use crate::{GeometryError, InputError, MAX_CONDITION, Pose2, Real, Twist2, condition_number, se2};

/// Geometry of a ballbot (paper 001). Lengths in metres, angles in radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallbotParams<T> {
    /// Ball radius `R_b`, m.
    pub ball_radius: T,
    /// Omni-wheel radius `r_w`, m.
    pub wheel_radius: T,
    /// Zenith angle `α` of the wheel contacts, rad, in (0, π/2).
    pub zenith: T,
    /// Azimuth `β_i` of each wheel's contact in the body frame, rad (paper 001: 0, +2π/3,
    /// −2π/3).
    pub azimuths: [T; 3],
}

impl<T: Real> BallbotParams<T> {
    /// The `ballbot` preset: ball radius 0.12 m, wheel radius 0.05 m, `α = 45°`, azimuths
    /// `0°, 120°, −120°`.
    pub fn preset() -> Self {
        let deg = core::f64::consts::PI / 180.0;
        Self {
            ball_radius: T::of(0.12),
            wheel_radius: T::of(0.05),
            zenith: T::of(45.0 * deg),
            azimuths: [T::of(0.0), T::of(120.0 * deg), T::of(-120.0 * deg)],
        }
    }
}

/// Kinematic and torque model of a ballbot (paper 001) with all matrices precomputed.
/// Immutable and `Copy`; calls never allocate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ballbot<T> {
    params: BallbotParams<T>,
    /// `ψ̇ = k B ω`, rows `b_i = (−cosα cosβ_i, −cosα sinβ_i, sinα)`, `k = R_b/r_w`.
    kb: Matrix3<T>,
    /// `ω = (k B)⁻¹ ψ̇`.
    kb_inv: Matrix3<T>,
    /// `A(0)`: columns `a_i = (cosα cosβ_i, cosα sinβ_i, sinα)`.
    a0: Matrix3<T>,
    a0_inv: Matrix3<T>,
    condition: f64,
}

impl<T: Real> Ballbot<T> {
    /// Builds the model and precomputes the velocity and torque matrices.
    ///
    /// # Errors
    /// [`GeometryError`] when a parameter is not finite, a radius is not positive, `α` is not
    /// in (0, π/2) (at 0 the wheels cannot spin the ball about the vertical, at π/2 they cannot
    /// roll it), or the wheel azimuths make the map singular (condition number above
    /// [`MAX_CONDITION`], e.g. two wheels at the same azimuth).
    pub fn new(params: BallbotParams<T>) -> Result<Self, GeometryError> {
        let rb = positive(params.ball_radius, "ball_radius")?;
        let rw = positive(params.wheel_radius, "wheel_radius")?;
        let alpha = finite_param(params.zenith, "zenith")?;
        if !(alpha > T::zero() && alpha < T::frac_pi_2()) {
            return Err(GeometryError::AngleOutOfRange {
                field: "zenith",
                value: alpha.to_f64(),
                rule: "the contact zenith angle must be strictly between 0 and 90°",
            });
        }
        const AZIMUTH: [&str; 3] = ["azimuths[0]", "azimuths[1]", "azimuths[2]"];
        let (sa, ca) = alpha.sin_cos();
        let k = rb / rw;
        let mut b = Matrix3::zeros();
        let mut a0 = Matrix3::zeros();
        for i in 0..3 {
            let (sb, cb) = finite_param(params.azimuths[i], AZIMUTH[i])?.sin_cos();
            b.set_row(i, &Vector3::new(-ca * cb, -ca * sb, sa).transpose());
            a0.set_column(i, &Vector3::new(ca * cb, ca * sb, sa));
        }
        // Rows of B all have unit length, so cond(B) measures the azimuth layout alone.
        let condition = condition_number(&b);
        let ill = || GeometryError::IllConditioned {
            what: "wheel contact matrix B (paper 001, velocity map)",
            condition,
            max: MAX_CONDITION,
        };
        if condition.is_nan() || condition > MAX_CONDITION {
            return Err(ill());
        }
        let kb = b * k;
        let kb_inv = kb.try_inverse().ok_or_else(ill)?;
        let a0_inv = a0.try_inverse().ok_or_else(ill)?;
        Ok(Self {
            params,
            kb,
            kb_inv,
            a0,
            a0_inv,
            condition,
        })
    }

    /// The parameters the model was built from.
    pub fn params(&self) -> &BallbotParams<T> {
        &self.params
    }

    /// 2-norm condition number of the contact matrix `B` (unit rows; 1 is ideal).
    pub fn condition_number(&self) -> f64 {
        self.condition
    }

    /// Unit direction from the ball centre to wheel `i`'s contact, body frame:
    /// `(sinα cosβ_i, sinα sinβ_i, cosα)`.
    pub fn contact_directions(&self) -> [Vector3<T>; 3] {
        let (sa, ca) = self.params.zenith.sin_cos();
        core::array::from_fn(|i| {
            let (sb, cb) = self.params.azimuths[i].sin_cos();
            Vector3::new(sa * cb, sa * sb, ca)
        })
    }

    /// Unit drive direction `t_i = (−sinβ_i, cosβ_i, 0)` of wheel `i` at its contact, body
    /// frame: a positive wheel rate moves the wheel rim there along `+t_i`.
    pub fn drive_directions(&self) -> [Vector3<T>; 3] {
        core::array::from_fn(|i| {
            let (sb, cb) = self.params.azimuths[i].sin_cos();
            Vector3::new(-sb, cb, T::zero())
        })
    }

    /// Wheel rates (rad/s) from the ball's angular velocity relative to the body `ω` (rad/s,
    /// body-yaw-aligned frame): `ψ̇_i = (R_b/r_w)(−cosα cosβ_i ω_x − cosα sinβ_i ω_y + sinα ω_z)`
    /// (paper 001, velocity map).
    pub fn wheel_rates_from_relative(&self, omega_rel: Vector3<T>) -> Result<[T; 3], InputError> {
        finite3(
            omega_rel.into(),
            ["omega_rel.x", "omega_rel.y", "omega_rel.z"],
        )?;
        finite_out((self.kb * omega_rel).into(), "wheel_rates")
    }

    /// The ball's angular velocity relative to the body, `ω = (−v_y/R_b, v_x/R_b, Ω_z − β̇)`
    /// (rad/s, body frame), for the body-frame ball velocity and body yaw rate in `twist` and
    /// the ball's spin `Ω_z` about the vertical (rad/s).
    pub fn relative_rate(&self, twist: Twist2<T>, ball_spin: T) -> Result<Vector3<T>, InputError> {
        twist.check_finite()?;
        finite(ball_spin, "ball_spin")?;
        let inv = T::one() / self.params.ball_radius;
        let w: [T; 3] = finite_out(
            [-twist.vy * inv, twist.vx * inv, ball_spin - twist.yaw_rate],
            "relative rate",
        )?;
        Ok(Vector3::from(w))
    }

    /// **Inverse kinematics**: wheel rates (rad/s) for the ball-centre velocity
    /// `(twist.vx, twist.vy)` (m/s, body-yaw-aligned frame), body yaw rate `twist.yaw_rate = β̇`
    /// (rad/s) and ball spin about the vertical `ball_spin` (rad/s, usually 0). Not limited.
    pub fn wheel_rates(&self, twist: Twist2<T>, ball_spin: T) -> Result<[T; 3], InputError> {
        let w = self.relative_rate(twist, ball_spin)?;
        finite_out((self.kb * w).into(), "wheel_rates")
    }

    /// [`Ballbot::wheel_rates`] at zero ball spin without its input and output checks: the
    /// same arithmetic, the same bits, for a caller that checks the rates itself (a
    /// non-finite twist gives non-finite rates).
    #[inline(always)]
    pub(crate) fn wheel_rates_unchecked(&self, twist: Twist2<T>) -> [T; 3] {
        let inv = T::one() / self.params.ball_radius;
        let w = Vector3::new(-twist.vy * inv, twist.vx * inv, T::zero() - twist.yaw_rate);
        (self.kb * w).into()
    }

    /// [`Ballbot::wheel_rates`] for a **world-frame** ball velocity and body yaw `yaw = β`
    /// (rad).
    pub fn wheel_rates_world(
        &self,
        twist_world: Twist2<T>,
        yaw: T,
        ball_spin: T,
    ) -> Result<[T; 3], InputError> {
        finite(yaw, "yaw")?;
        twist_world.check_finite()?;
        self.wheel_rates(twist_world.to_robot(yaw), ball_spin)
    }

    /// **Forward kinematics to `ω`**: the ball's angular velocity relative to the body (rad/s,
    /// body frame) implied by the wheel rates (rad/s).
    pub fn relative_rate_from_wheels(&self, wheel_rates: [T; 3]) -> Result<Vector3<T>, InputError> {
        finite3(
            wheel_rates,
            ["wheel_rates[0]", "wheel_rates[1]", "wheel_rates[2]"],
        )?;
        let w: [T; 3] = finite_out(
            (self.kb_inv * Vector3::from(wheel_rates)).into(),
            "relative rate",
        )?;
        Ok(Vector3::from(w))
    }

    /// **Forward kinematics**: ball-centre velocity (m/s, body-yaw-aligned frame) and body yaw
    /// rate (rad/s) from the wheel rates (rad/s), given the ball spin `Ω_z` (rad/s; 0 unless
    /// known): `v_x = R_b ω_y`, `v_y = −R_b ω_x`, `β̇ = Ω_z − ω_z`.
    pub fn body_twist(&self, wheel_rates: [T; 3], ball_spin: T) -> Result<Twist2<T>, InputError> {
        finite(ball_spin, "ball_spin")?;
        let w = self.relative_rate_from_wheels(wheel_rates)?;
        let rb = self.params.ball_radius;
        let [vx, vy, wz] = finite_out([rb * w.y, -rb * w.x, ball_spin - w.z], "twist")?;
        Ok(Twist2::new(vx, vy, wz))
    }

    /// `A(β) = Rz(β) A(0)`: the projection matrix of paper 001 at body yaw `β`, columns
    /// `(cosα cos(β+β_i), cosα sin(β+β_i), sinα)` (erratum E3: a proper rotation).
    fn projection(&self, yaw: T) -> Matrix3<T> {
        rot_z(yaw) * self.a0
    }

    /// **Wheel torques → model torques** (paper 001, projections of the physical torques):
    /// `[Tx, Ty, Tz] = A(β) [T1, T2, T3]` (N·m). `Tx, Ty` are in the frame rotated
    /// counter-clockwise by the body yaw `yaw = β` (rad) from the body frame (the world frame
    /// when `β` is the heading); `β = 0` gives the body-frame torques.
    pub fn model_torques(&self, wheel_torques: [T; 3], yaw: T) -> Result<[T; 3], InputError> {
        finite3(
            wheel_torques,
            ["wheel_torques[0]", "wheel_torques[1]", "wheel_torques[2]"],
        )?;
        finite(yaw, "yaw")?;
        finite_out(
            (self.projection(yaw) * Vector3::from(wheel_torques)).into(),
            "model_torques",
        )
    }

    /// **Model torques → wheel torques**: `[T1, T2, T3] = A(β)⁻¹ [Tx, Ty, Tz]` (N·m), the exact
    /// inverse of [`Ballbot::model_torques`] (paper 001 inverse, corrected per erratum E2).
    pub fn wheel_torques(&self, model_torques: [T; 3], yaw: T) -> Result<[T; 3], InputError> {
        finite3(
            model_torques,
            ["model_torques[0]", "model_torques[1]", "model_torques[2]"],
        )?;
        finite(yaw, "yaw")?;
        finite_out(
            (self.a0_inv * (rot_z(-yaw) * Vector3::from(model_torques))).into(),
            "wheel_torques",
        )
    }

    /// **Wheel rates → model rates** `v = A(β)⁻ᵀ ψ̇` (rad/s), the rates power-conjugate to the
    /// model torques: `Σ T_i ψ̇_i = Tx v_x + Ty v_y + Tz v_z` for any torques (the encoder
    /// feedback transform of paper 001). In the body frame `v = (R_b/r_w)(−ω_x, −ω_y, ω_z)`.
    pub fn model_rates(&self, wheel_rates: [T; 3], yaw: T) -> Result<[T; 3], InputError> {
        finite3(
            wheel_rates,
            ["wheel_rates[0]", "wheel_rates[1]", "wheel_rates[2]"],
        )?;
        finite(yaw, "yaw")?;
        let v_body = self.a0_inv.transpose() * Vector3::from(wheel_rates);
        finite_out((rot_z(yaw) * v_body).into(), "model_rates")
    }

    /// **Model rates → wheel rates** `ψ̇ = A(β)ᵀ v` (rad/s): the dual of
    /// [`Ballbot::model_torques`].
    pub fn wheel_rates_from_model(
        &self,
        model_rates: [T; 3],
        yaw: T,
    ) -> Result<[T; 3], InputError> {
        finite3(
            model_rates,
            ["model_rates[0]", "model_rates[1]", "model_rates[2]"],
        )?;
        finite(yaw, "yaw")?;
        finite_out(
            (self.projection(yaw).transpose() * Vector3::from(model_rates)).into(),
            "wheel_rates",
        )
    }

    /// **Odometry step** (paper 001): world-frame ball displacement `(dx, dy)` (m) from the
    /// wheel-angle increments `delta_wheel_angles` (rad) over one step and the body yaw at its
    /// start and end (rad, absolute heading, e.g. from the IMU).
    ///
    /// The increments give the relative ball rotation `Δω = (k B)⁻¹ Δψ`; its horizontal part is
    /// the body-frame rolling distance `(R_b Δω_y, −R_b Δω_x)` and its vertical part, the body's
    /// own turning, moves nothing. Assuming a constant body-frame velocity and yaw rate over the
    /// step, the world displacement is the SE(2) exponential ([`se2::twist_exp`]) rotated by the
    /// start yaw — exact on arcs, second order otherwise.
    pub fn ball_displacement(
        &self,
        delta_wheel_angles: [T; 3],
        yaw_start: T,
        yaw_end: T,
    ) -> Result<[T; 2], InputError> {
        finite(yaw_start, "yaw_start")?;
        finite(yaw_end, "yaw_end")?;
        let step = self.ball_step(delta_wheel_angles, yaw_end - yaw_start)?;
        let p = se2::compose(Pose2::new(T::zero(), T::zero(), yaw_start), step);
        finite_out([p.x, p.y], "ball displacement")
    }

    /// [`Ballbot::ball_displacement`] in the body frame at the step's start: the pose change
    /// `exp(R_b Δω_y, −R_b Δω_x, yaw_change)` (m, m, rad; the heading change is
    /// `yaw_change` exactly), which the caller rotates by the start yaw it already has.
    pub(crate) fn ball_step(
        &self,
        delta_wheel_angles: [T; 3],
        yaw_change: T,
    ) -> Result<Pose2<T>, InputError> {
        let dw = self.relative_rate_from_wheels(delta_wheel_angles)?;
        let rb = self.params.ball_radius;
        let body_step = Twist2::new(rb * dw.y, -rb * dw.x, yaw_change);
        let d = se2::twist_exp(body_step, T::one());
        let [x, y] = finite_out([d.x, d.y], "ball displacement")?;
        Ok(Pose2::new(x, y, yaw_change))
    }
}

/// Rotation about +z by `angle` (rad).
fn rot_z<T: Real>(angle: T) -> Matrix3<T> {
    let (s, c) = angle.sin_cos();
    let z = T::zero();
    Matrix3::new(c, -s, z, s, c, z, z, z, T::one())
}
