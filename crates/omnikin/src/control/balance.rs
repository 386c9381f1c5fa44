//! The ballbot balance controller: an LQR per planar model of paper 001, an outer loop that
//! follows a plan's velocities (feed-forward lean for the commanded acceleration, position
//! from the integrated velocity), the paper's map to the three wheel torques, direction-
//! preserving saturation and fall detection.
//!
//! **Cycle** ([`BalanceController::step`], at the rate of [`BalanceConfig::rate_hz`]):
//! 1. *Fall check*: the tilt `ϑ` (angle between the body z axis and the vertical, from the
//!    heading-frame tilts, `tan²ϑ = tan²θ_x + tan²θ_y`) above [`BalanceConfig::fall_tilt`]
//!    latches [`BalanceState::Fallen`]: all torques 0 (motors off) until [`BalanceController::reset`].
//! 2. *Reference*: the commanded world velocity `v_ref` is integrated into a reference position
//!    `p_ref` (started at the measured position on the first cycle), the commanded yaw rate
//!    into a reference yaw. The position error `p − p_ref` is limited to
//!    [`BalanceConfig::max_position_error`] (after a push the robot returns at a bounded lean
//!    instead of leaning as far as the error asks).
//! 3. *Feed-forward*: for each vertical plane the lean `θ_ff` and torque `u_ff` that hold the
//!    commanded acceleration at the commanded velocity in the linear model
//!    (`φ̈ = α_ref, θ̈ = 0`): `[A₃₂ B₃; A₄₂ B₄] [θ_ff; u_ff] = [α_ref − A₃₃ φ̇_ref; −A₄₃ φ̇_ref]`
//!    (without damping `θ_ff = (a + b) α_ref / G`, ≈ `a_ref/g` for a heavy body).
//! 4. *LQR*: `u = u_ff − K (φ − φ_ref, θ − θ_ff, φ̇ − φ̇_ref, θ̇)` per vertical plane (planar
//!    coordinates of [`super::planar`]), `Tz = u_ff − K_z (β − β_ref, β̇ − β̇_ref)` for yaw.
//! 5. *Wheels*: `(T1, T2, T3) = A(0)⁻¹ (Tx, Ty, Tz)` (paper 001, inverse map corrected by erratum
//!    E2: [`crate::ballbot::Ballbot::wheel_torques`]), then, if a wheel exceeds the torque limit,
//!    all three are scaled by the same factor (the model-torque direction is kept) and
//!    [`BalanceOutput::saturated`] says so.
//!
//! **Design** ([`BalanceController::new`]): each planar model is discretised with a zero-order
//! hold at the control period and [`super::lqr::dare`] gives its gain. The design runs in `f64`
//! whatever `T` is (once, at construction; in `f32` the Riccati iteration would stop at a
//! relative precision of 10⁻⁶), so `f32` and `f64` controllers have the same gains to `f32`
//! rounding. **Weights** (Bryson's rule, `Q = diag(1/x_max²)`, `R = 1/u_max²`, see
//! [`Weights::default`]): position 0.05 m, tilt 1°, ball speed 0.2 m/s, tilt rate 0.1 rad/s,
//! model torque 1 N·m; yaw 0.1 rad, 0.5 rad/s, 0.5 N·m.
//!
//! **Inputs**: tilts and rates as the AHRS gives them ([`Measurement::from_attitude`]: the
//! orientation quaternion and the gyro), the ball's world position and velocity as the
//! odometry gives them (corrected for the body's tilt: the wheel encoders measure the ball's
//! rotation relative to the body).
//!
//! No allocation, no panic. **Cost of one cycle** (callgrind, `bench/instructions.sh balance
//! balance-f64`: [`Measurement::from_attitude`] from the AHRS quaternion and gyro, then
//! [`BalanceController::step`], with the `libm` math of a `no_std` build): ≈ 1 510 x86-64
//! instructions in `f32`, ≈ 1 680 in `f64` — a few dozen multiply-adds for the three laws and
//! the wheel-torque map; most of the rest is the trigonometry (Euler yaw, tilt `atan2`s, the
//! tilt angle's `tan`/`atan`, the heading rotation's `sin_cos`).

use nalgebra::{Matrix2, Matrix4, Vector2, Vector4};

use super::config::{BalanceConfig, BalanceError, Weights, check, plant_f64, validate_plant};
use super::lqr::{self, LqrError};
use super::planar::{PlanarModel, Plane, PlantParams};
use super::signals::{BalanceCommand, BalanceOutput, BalanceState, Measurement};
use crate::ballbot::Ballbot;
use crate::real::{finite, finite_out};
use crate::{InputError, Real};

/// The design of one planar model: discrete model, gain and closed loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneDesign {
    /// The planar model.
    pub plane: Plane,
    /// Discrete state matrix (zero-order hold at the control period); for yaw only the upper
    /// left 2×2 block is used (`(β, β̇)`), the rest is 0.
    pub a: Matrix4<f64>,
    /// Discrete input vector (yaw: first two entries).
    pub b: Vector4<f64>,
    /// Gain `K` (`u = −K s`); yaw: first two entries.
    pub gain: Vector4<f64>,
    /// Number of states (4, yaw 2).
    pub states: usize,
    /// Largest closed-loop pole magnitude (< 1 for a stable loop).
    pub spectral_radius: f64,
    /// Riccati doubling iterations used.
    pub iterations: usize,
}

/// Per-plane gains and feed-forward in the controller's scalar type.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PlaneLaw<T> {
    gain: Vector4<T>,
    /// `[θ_ff; u_ff] = ff_inv [α − A₃₃ φ̇ ; −A₄₃ φ̇]`.
    ff_inv: Matrix2<T>,
    a33: T,
    a43: T,
    /// Ball row of the planar model: `τ = a φ̈ + b θ̈ + d φ̇ − c_r θ̇`, `u = τ / tau_per_u`.
    a: T,
    b: T,
    d: T,
    cr: T,
    tau_per_u: T,
}

/// The balance controller (see the module doc). `Copy`, fixed size, no allocation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BalanceController<T: Real> {
    config: BalanceConfig<T>,
    robot: Ballbot<T>,
    dt: T,
    lateral: PlaneLaw<T>,
    sagittal: PlaneLaw<T>,
    yaw_gain: Vector2<T>,
    yaw_ff: T,
    designs: [PlaneDesign; 3],
    reference: Option<([T; 2], T)>,
    fallen: bool,
}

/// `x²`.
fn sq(x: f64) -> f64 {
    x * x
}

/// `1/x²` (Bryson's rule).
fn inv_sq(x: f64) -> f64 {
    1.0 / (x * x)
}

fn vertical_design(
    p: &PlantParams<f64>,
    plane: Plane,
    w: &Weights,
    dt: f64,
) -> Result<(PlaneDesign, PlanarModel<f64>), BalanceError> {
    let err = |error| BalanceError::Lqr { plane, error };
    let m = PlanarModel::new(p, plane);
    let (ad, bd) = lqr::discretize(&m.a, &m.b, dt).map_err(err)?;
    let r = p.ball_radius;
    let q = Matrix4::from_diagonal(&Vector4::new(
        sq(r / w.position),
        inv_sq(w.tilt),
        sq(r / w.velocity),
        inv_sq(w.tilt_rate),
    ));
    let rw = nalgebra::Matrix1::new(inv_sq(w.torque));
    let d = lqr::dare(&ad, &bd, &q, &rw, 1e-12).map_err(err)?;
    Ok((
        PlaneDesign {
            plane,
            a: ad,
            b: bd,
            gain: d.gain.transpose(),
            states: 4,
            spectral_radius: d.spectral_radius,
            iterations: d.iterations,
        },
        m,
    ))
}

fn law<T: Real>(
    d: &PlaneDesign,
    m: &PlanarModel<f64>,
    p: &PlantParams<f64>,
    plane: Plane,
) -> Result<PlaneLaw<T>, BalanceError> {
    let f = Matrix2::new(m.a[(2, 1)], m.b[2], m.a[(3, 1)], m.b[3]);
    let inv = f.try_inverse().ok_or(BalanceError::Lqr {
        plane,
        error: LqrError::Singular {
            what: "feed-forward matrix [A32 B3; A42 B4]",
        },
    })?;
    Ok(PlaneLaw {
        gain: d.gain.map(T::of),
        ff_inv: inv.map(T::of),
        a33: T::of(m.a[(2, 2)]),
        a43: T::of(m.a[(3, 2)]),
        a: T::of((p.ball_mass + p.body_mass) * p.ball_radius * p.ball_radius + p.ball_inertia),
        b: T::of(p.body_mass * p.com_height * p.ball_radius),
        d: T::of(p.floor_damping + p.relative_damping),
        cr: T::of(p.relative_damping),
        tau_per_u: T::of(-p.ball_radius / p.wheel_radius),
    })
}

impl<T: Real> BalanceController<T> {
    /// Builds the controller: validates the parameters and designs the three LQR gains.
    ///
    /// # Errors
    /// [`BalanceError::Geometry`] for a wheel geometry [`Ballbot::new`] rejects,
    /// [`BalanceError::Parameter`] for a non-positive mass, inertia, length, rate, torque limit,
    /// fall tilt (must be in (0, 90°)) or position-error bound, a negative damping or a weight
    /// that is not finite and > 0, [`BalanceError::Lqr`] when a design fails.
    pub fn new(config: BalanceConfig<T>) -> Result<Self, BalanceError> {
        let robot = Ballbot::new(config.geometry)?;
        validate_plant(&config.plant)?;
        let rate = config.rate_hz.to_f64();
        const POS: &str = "must be finite and > 0";
        check("rate_hz", rate, rate > 0.0, POS)?;
        let lim = config.torque_limit.to_f64();
        check("torque_limit", lim, lim > 0.0, POS)?;
        let fall = config.fall_tilt.to_f64();
        check(
            "fall_tilt",
            fall,
            fall > 0.0 && fall < core::f64::consts::FRAC_PI_2,
            "must be in (0, π/2) rad",
        )?;
        let pe = config.max_position_error.to_f64();
        check("max_position_error", pe, pe > 0.0, POS)?;
        let w = config.weights;
        for (field, v) in [
            ("weights.position", w.position),
            ("weights.tilt", w.tilt),
            ("weights.velocity", w.velocity),
            ("weights.tilt_rate", w.tilt_rate),
            ("weights.torque", w.torque),
            ("weights.yaw", w.yaw),
            ("weights.yaw_rate", w.yaw_rate),
            ("weights.yaw_torque", w.yaw_torque),
        ] {
            check(field, v, v > 0.0, POS)?;
        }
        if config.geometry.ball_radius != config.plant.ball_radius
            || config.geometry.wheel_radius != config.plant.wheel_radius
        {
            return Err(BalanceError::Parameter {
                field: "plant.ball_radius / plant.wheel_radius",
                value: config.plant.ball_radius.to_f64(),
                rule: "must equal the geometry's ball and wheel radii",
            });
        }
        let p = plant_f64(&config.plant);
        let dt = 1.0 / rate;
        let (dl, ml) = vertical_design(&p, Plane::Lateral, &w, dt)?;
        let (ds, ms) = vertical_design(&p, Plane::Sagittal, &w, dt)?;
        let yaw_err = |error| BalanceError::Lqr {
            plane: Plane::Yaw,
            error,
        };
        let (ya, yb) = PlanarModel::yaw_reduced(&p);
        let (yad, ybd) = lqr::discretize(&ya, &yb, dt).map_err(yaw_err)?;
        let yq = Matrix2::from_diagonal(&Vector2::new(inv_sq(w.yaw), inv_sq(w.yaw_rate)));
        let yr = nalgebra::Matrix1::new(inv_sq(w.yaw_torque));
        let yd = lqr::dare(&yad, &ybd, &yq, &yr, 1e-12).map_err(yaw_err)?;
        let mut a4 = Matrix4::zeros();
        a4.fixed_view_mut::<2, 2>(0, 0).copy_from(&yad);
        let dy = PlaneDesign {
            plane: Plane::Yaw,
            a: a4,
            b: Vector4::new(ybd[0], ybd[1], 0.0, 0.0),
            gain: Vector4::new(yd.gain[0], yd.gain[1], 0.0, 0.0),
            states: 2,
            spectral_radius: yd.spectral_radius,
            iterations: yd.iterations,
        };
        // Constant yaw rate against the relative damping: −k Tz = c_r β̇.
        let k = p.ball_radius / p.wheel_radius;
        Ok(Self {
            config,
            robot,
            dt: T::of(dt),
            lateral: law(&dl, &ml, &p, Plane::Lateral)?,
            sagittal: law(&ds, &ms, &p, Plane::Sagittal)?,
            yaw_gain: Vector2::new(T::of(yd.gain[0]), T::of(yd.gain[1])),
            yaw_ff: T::of(-p.relative_damping / k),
            designs: [dl, ds, dy],
            reference: None,
            fallen: false,
        })
    }

    /// The configuration the controller was built from.
    pub fn config(&self) -> &BalanceConfig<T> {
        &self.config
    }

    /// The designs of the planar models, in the order lateral (`Tx`), sagittal (`Ty`), yaw
    /// (`Tz`): discrete models, gains, closed-loop spectral radii.
    pub fn designs(&self) -> &[PlaneDesign; 3] {
        &self.designs
    }

    /// The control period, s.
    pub fn period(&self) -> T {
        self.dt
    }

    /// Whether the fall latch is set.
    pub fn fallen(&self) -> bool {
        self.fallen
    }

    /// The reference position (world, m) and yaw (rad), once the first cycle has set them.
    pub fn reference(&self) -> Option<([T; 2], T)> {
        self.reference
    }

    /// Clears the fall latch and the reference (the next cycle starts from the measured
    /// position and yaw).
    pub fn reset(&mut self) {
        self.reference = None;
        self.fallen = false;
    }

    /// Sets the reference position (world, m) and yaw (rad) explicitly (e.g. a plan's start).
    pub fn set_reference(&mut self, position: [T; 2], yaw: T) {
        self.reference = Some((position, yaw));
    }

    /// One control cycle (see the module doc).
    ///
    /// # Errors
    /// [`InputError::NonFinite`] naming the first non-finite input; [`InputError::Overflow`]
    /// if the torques overflow. The controller's state is unchanged on error.
    pub fn step(
        &mut self,
        m: &Measurement<T>,
        cmd: &BalanceCommand<T>,
    ) -> Result<BalanceOutput<T>, InputError> {
        finite(m.tilt[0], "tilt[0]")?;
        finite(m.tilt[1], "tilt[1]")?;
        finite(m.tilt_rate[0], "tilt_rate[0]")?;
        finite(m.tilt_rate[1], "tilt_rate[1]")?;
        finite(m.yaw, "yaw")?;
        finite(m.yaw_rate, "yaw_rate")?;
        finite(m.ball_position[0], "ball_position[0]")?;
        finite(m.ball_position[1], "ball_position[1]")?;
        finite(m.ball_velocity[0], "ball_velocity[0]")?;
        finite(m.ball_velocity[1], "ball_velocity[1]")?;
        finite(cmd.velocity[0], "command.velocity[0]")?;
        finite(cmd.velocity[1], "command.velocity[1]")?;
        finite(cmd.acceleration[0], "command.acceleration[0]")?;
        finite(cmd.acceleration[1], "command.acceleration[1]")?;
        finite(cmd.yaw_rate, "command.yaw_rate")?;
        if let Some(l) = &cmd.lean {
            for (v, field) in [
                (l.tilt[0], "command.lean.tilt[0]"),
                (l.tilt[1], "command.lean.tilt[1]"),
                (l.rate[0], "command.lean.rate[0]"),
                (l.rate[1], "command.lean.rate[1]"),
                (l.accel[0], "command.lean.accel[0]"),
                (l.accel[1], "command.lean.accel[1]"),
            ] {
                finite(v, field)?;
            }
        }
        let tilt = m.tilt_angle();
        let z = T::zero();
        let off = |tilt| BalanceOutput {
            wheel_torques: [z; 3],
            model_torques: [z; 3],
            requested: [z; 3],
            saturated: false,
            scale: z,
            tilt,
            status: BalanceState::Fallen,
        };
        if self.fallen || !tilt.is_finite() || tilt > self.config.fall_tilt {
            self.fallen = true;
            return Ok(off(tilt));
        }
        let (p_ref, yaw_ref) = self.reference.unwrap_or((m.ball_position, m.yaw));
        let r = self.config.plant.ball_radius;
        let inv_r = T::one() / r;
        let (s, c) = m.yaw.sin_cos();
        // World → heading frame.
        let to_h = |v: [T; 2]| [c * v[0] + s * v[1], -s * v[0] + c * v[1]];
        let mut e = to_h([m.ball_position[0] - p_ref[0], m.ball_position[1] - p_ref[1]]);
        let en = (e[0] * e[0] + e[1] * e[1]).sqrt();
        if en > self.config.max_position_error {
            let f = self.config.max_position_error / en;
            e = [e[0] * f, e[1] * f];
        }
        let v = to_h(m.ball_velocity);
        let vr = to_h(cmd.velocity);
        let ar = to_h(cmd.acceleration);
        // Previewed lean in the heading frame, per plane: sagittal θ_y = ℓ_x, lateral θ_x = −ℓ_y.
        let lean = cmd.lean.map(|l| {
            let (t, r, a) = (to_h(l.tilt), to_h(l.rate), to_h(l.accel));
            ([t[0], r[0], a[0]], [-t[1], -r[1], -a[1]])
        });
        // Sagittal: φ = x/R; lateral: φ = −y/R.
        let ty = plane_law(
            &self.sagittal,
            [e[0] * inv_r, m.tilt[1], v[0] * inv_r, m.tilt_rate[1]],
            vr[0] * inv_r,
            ar[0] * inv_r,
            lean.map(|l| l.0),
        );
        let tx = plane_law(
            &self.lateral,
            [-e[1] * inv_r, m.tilt[0], -v[1] * inv_r, m.tilt_rate[0]],
            -vr[1] * inv_r,
            -ar[1] * inv_r,
            lean.map(|l| l.1),
        );
        let yaw_err = crate::wrap_angle(m.yaw - yaw_ref);
        let tz = self.yaw_ff * cmd.yaw_rate
            - (self.yaw_gain[0] * yaw_err + self.yaw_gain[1] * (m.yaw_rate - cmd.yaw_rate));
        let requested: [T; 3] = finite_out([tx, ty, tz], "model torques")?;
        let wheels = self.robot.wheel_torques(requested, z)?;
        let peak = wheels
            .iter()
            .fold(z, |acc, t| if t.abs() > acc { t.abs() } else { acc });
        let lim = self.config.torque_limit;
        let (scale, saturated) = if peak > lim {
            (lim / peak, true)
        } else {
            (T::one(), false)
        };
        let wheel_torques = wheels.map(|t| t * scale);
        let model_torques = requested.map(|t| t * scale);
        // Commit the state only now (no change on error).
        let dt = self.dt;
        self.reference = Some((
            [
                p_ref[0] + cmd.velocity[0] * dt,
                p_ref[1] + cmd.velocity[1] * dt,
            ],
            crate::wrap_angle(yaw_ref + cmd.yaw_rate * dt),
        ));
        Ok(BalanceOutput {
            wheel_torques,
            model_torques,
            requested,
            saturated,
            scale,
            tilt,
            status: BalanceState::Balancing,
        })
    }
}

/// `u = u_ff − K (φ̃, θ − θ_ref, φ̇ − φ̇_ref, θ̇ − θ̇_ref)` with `s = (φ̃, θ, φ̇, θ̇)`; the
/// reference lean `(θ, θ̇, θ̈)` is the previewed one or the static feed-forward `(θ_ff, 0, 0)`.
fn plane_law<T: Real>(
    l: &PlaneLaw<T>,
    s: [T; 4],
    rate_ref: T,
    accel_ref: T,
    lean: Option<[T; 3]>,
) -> T {
    let (theta, theta_d, u_ff) = match lean {
        Some([th, thd, thdd]) => {
            let tau = l.a * accel_ref + l.b * thdd + l.d * rate_ref - l.cr * thd;
            (th, thd, tau / l.tau_per_u)
        }
        None => {
            let rhs = Vector2::new(accel_ref - l.a33 * rate_ref, -l.a43 * rate_ref);
            let ff = l.ff_inv * rhs;
            (ff[0], T::zero(), ff[1])
        }
    };
    let x = Vector4::new(s[0], s[1] - theta, s[2] - rate_ref, s[3] - theta_d);
    u_ff - l.gain.dot(&x)
}
