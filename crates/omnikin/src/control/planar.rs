//! The three planar models of a ballbot (paper 001): two vertical planes (ball + body
//! pendulum) and yaw, linearised about upright, in closed form.
//!
//! **Frames and coordinates.** The heading frame `h` is the world frame turned by the body yaw
//! `β` about +z (x forward, y left, z up). Each vertical plane has the state
//! `s = (φ, θ, φ̇, θ̇)` — the ball's absolute rotation angle `φ` about the plane's normal axis
//! (rad) and the body's tilt `θ` about the same axis (rad) — and the input `u` = the model
//! ("virtual wheel") torque of paper 001 about that axis (N·m):
//!
//! | plane | normal axis | ball position | tilt | input |
//! |---|---|---|---|---|
//! | [`Plane::Sagittal`] | `y_h` | `x_h = R φ` | `θ_y` (body z toward +x_h) | `Ty` |
//! | [`Plane::Lateral`] | `x_h` | `y_h = −R φ` | `θ_x` (body z toward −y_h) | `Tx` |
//!
//! The wheels exert the torque `τ = k (−Tx, −Ty, Tz)` on the ball (and `−τ` on the body),
//! `k = R/r_w` (see [`crate::ballbot`]). For a plane with ball torque `τ = −k u`, total mass
//! `m = m_ball + m_body`, ball inertia `I_b`, body inertia `J` about its centre of mass
//! (the plane's axis), centre-of-mass height `l` above the ball centre, floor (rolling)
//! damping `c_f` on the ball's absolute rate and relative damping `c_r` between ball and body,
//! the linearised Lagrange equations (a full derivation from the 3D model is in
//! `omnikin_sim::dynamics::ballbot`) are
//!
//! ```text
//! [a b] [φ̈]   [ τ − c_f φ̇ − c_r (φ̇ − θ̇)      ]     a = m R² + I_b
//! [b c] [θ̈] = [ m_body g l θ − τ + c_r (φ̇ − θ̇) ]     b = m_body l R,  c = J + m_body l²
//! ```
//!
//! so with `D = a c − b²`, `G = m_body g l`:
//! `φ̈ = [(c + b)(τ − c_r φ̇ + c_r θ̇) − c c_f φ̇ − b G θ]/D`,
//! `θ̈ = [a G θ − (a + b)(τ − c_r φ̇ + c_r θ̇) + b c_f φ̇]/D`.
//!
//! **Yaw** ([`Plane::Yaw`]): the same form with `φ` the ball's spin angle about the vertical,
//! `θ = β` the body yaw, `a = I_b`, `b = 0`, `c = J_z`, no gravity and `τ = +k Tz`. Its ball
//! spin is not controllable on its own (the wheels only exchange vertical angular momentum
//! between ball and body), so the yaw controller uses the reduced model
//! [`PlanarModel::yaw_reduced`] on `(β, β̇)` that neglects the ball spin's drag on the body.
//!
//! **What the decomposition neglects**: the products of inertia of the body, the coupling of the
//! planes through the body's rotation (gyroscopic and centripetal terms, quadratic in the
//! rates), the tilt's effect on the yaw axis, the wheels' own inertia (massless wheels) and
//! Coulomb friction.

use nalgebra::{Matrix2, Matrix4, Vector2, Vector4};

use crate::Real;

/// Physical parameters of a ballbot for its dynamics (SI units, see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantParams<T> {
    /// Ball radius `R`, m.
    pub ball_radius: T,
    /// Omni-wheel radius `r_w`, m (sets `k = R/r_w`).
    pub wheel_radius: T,
    /// Ball mass, kg.
    pub ball_mass: T,
    /// Ball moment of inertia about its centre `I_b`, kg·m².
    pub ball_inertia: T,
    /// Body mass (everything but the ball), kg.
    pub body_mass: T,
    /// Body principal moments of inertia about its centre of mass, body axes `(x, y, z)`,
    /// kg·m².
    pub body_inertia: [T; 3],
    /// Height `l` of the body's centre of mass above the ball centre (along body z), m.
    pub com_height: T,
    /// Viscous damping of the ball's absolute rotation (rolling resistance, spin friction),
    /// N·m·s/rad.
    pub floor_damping: T,
    /// Viscous damping of the ball's rotation relative to the body (wheels, gears), N·m·s/rad.
    pub relative_damping: T,
    /// Gravitational acceleration, m/s².
    pub gravity: T,
}

impl<T: Real> PlantParams<T> {
    /// The `ballbot` preset: the preset's ball (0.12 m) and wheels (0.05 m) with the masses,
    /// inertias, centre of mass and friction of the **Kugle V1** ballbot (Aalborg University
    /// 2019; `Parameters/Constants_Kugle.m` of its MATLAB repository): ball 1.478 kg (a thin
    /// shell inside a 4 mm coating: `I_b = ⅔ m_b (R − 0.004)²`), body 16.154 kg with principal
    /// inertia (1.295, 1.306, 0.100) kg·m² about its centre of mass, 0.421 m above the ball
    /// centre, viscous friction 0.001 N·m·s/rad, `g = 9.81` m/s². Rezero (ETH 2010) is of the
    /// same class (≈ 14.5 kg, ball radius 0.125 m).
    pub fn preset() -> Self {
        let ball_radius = 0.12;
        let ball_mass = 1.478;
        let shell: f64 = ball_radius - 0.004;
        Self {
            ball_radius: T::of(ball_radius),
            wheel_radius: T::of(0.05),
            ball_mass: T::of(ball_mass),
            ball_inertia: T::of(2.0 / 3.0 * ball_mass * shell * shell),
            body_mass: T::of(14.31 + 1.844),
            body_inertia: [T::of(1.29465), T::of(1.30640), T::of(0.100218)],
            com_height: T::of(0.550_238_54 - 0.129),
            floor_damping: T::of(1e-3),
            relative_damping: T::of(1e-3),
            gravity: T::of(9.81),
        }
    }
}

impl<T: Real> PlantParams<T> {
    /// The ball acceleration (m/s²) the vertical planar model holds at a constant lean
    /// `tilt` (rad, < 90°) without damping: adding its two rows eliminates the torque,
    /// `(a + b) φ̈ = G θ` at `θ̈ = 0`, so `ẍ = R φ̈ = R m_body g l / (m R² + I_b + m_body l R) · θ`
    /// (module doc), with `tan θ` for `θ` (the body's weight against its lean). For a light
    /// ball this is ≈ `g tan θ` scaled by `m_body l R / (m R² + I_b + m_body l R)` (0.74 for the
    /// preset): the ball's own inertia costs lean. A plan's acceleration limit for a ballbot.
    pub fn acceleration_for_lean(&self, tilt: T) -> T {
        let r = self.ball_radius;
        let m = self.ball_mass + self.body_mass;
        let b = self.body_mass * self.com_height * r;
        let a = m * r * r + self.ball_inertia;
        r * self.body_mass * self.gravity * self.com_height / (a + b) * tilt.tan()
    }
}

/// One of the three planar models of paper 001.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plane {
    /// About the heading frame's x axis: lateral motion along y, input `Tx`.
    Lateral,
    /// About the heading frame's y axis: forward motion along x, input `Ty`.
    Sagittal,
    /// About the vertical: body yaw, input `Tz`.
    Yaw,
}

impl Plane {
    /// The three planes in the order of the model torques `(Tx, Ty, Tz)`.
    pub const ALL: [Plane; 3] = [Plane::Lateral, Plane::Sagittal, Plane::Yaw];

    /// A short name (`"x (lateral)"`, …) for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Plane::Lateral => "x (lateral)",
            Plane::Sagittal => "y (sagittal)",
            Plane::Yaw => "z (yaw)",
        }
    }
}

/// A continuous-time planar model `ṡ = A s + B u`, `s = (φ, θ, φ̇, θ̇)` (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarModel<T> {
    /// State matrix `A`.
    pub a: Matrix4<T>,
    /// Input vector `B` (per N·m of model torque).
    pub b: Vector4<T>,
}

impl<T: Real> PlanarModel<T> {
    /// The closed-form linearisation about upright of `plane` (module doc).
    pub fn new(p: &PlantParams<T>, plane: Plane) -> Self {
        let r = p.ball_radius;
        let k = r / p.wheel_radius;
        let (a, b, c, grav, sign) = match plane {
            Plane::Lateral | Plane::Sagittal => {
                let j = if plane == Plane::Lateral {
                    p.body_inertia[0]
                } else {
                    p.body_inertia[1]
                };
                let l = p.com_height;
                (
                    (p.ball_mass + p.body_mass) * r * r + p.ball_inertia,
                    p.body_mass * l * r,
                    j + p.body_mass * l * l,
                    p.body_mass * p.gravity * l,
                    -T::one(),
                )
            }
            Plane::Yaw => (
                p.ball_inertia,
                T::zero(),
                p.body_inertia[2],
                T::zero(),
                T::one(),
            ),
        };
        let d = a * c - b * b;
        let (cf, cr) = (p.floor_damping, p.relative_damping);
        let z = T::zero();
        // Generalized forces per unit of φ̇, θ̇ and τ (ball row, body row).
        // ball: τ − (c_f + c_r) φ̇ + c_r θ̇ ; body: G θ − τ + c_r φ̇ − c_r θ̇
        let inv = Matrix2::new(c, -b, -b, a) * (T::one() / d);
        let col_theta = inv * Vector2::new(z, grav);
        let col_phid = inv * Vector2::new(-(cf + cr), cr);
        let col_thetad = inv * Vector2::new(cr, -cr);
        let col_tau = inv * Vector2::new(T::one(), -T::one());
        let mut am = Matrix4::zeros();
        am[(0, 2)] = T::one();
        am[(1, 3)] = T::one();
        for row in 0..2 {
            am[(2 + row, 1)] = col_theta[row];
            am[(2 + row, 2)] = col_phid[row];
            am[(2 + row, 3)] = col_thetad[row];
        }
        let bm = Vector4::new(z, z, col_tau[0] * k * sign, col_tau[1] * k * sign);
        Self { a: am, b: bm }
    }

    /// The yaw model reduced to `(β, β̇)`: `J_z β̈ = −k Tz − c_r β̇` (ball spin's drag on the
    /// body neglected). Returns `(A, B)`.
    pub fn yaw_reduced(p: &PlantParams<T>) -> (Matrix2<T>, Vector2<T>) {
        let jz = p.body_inertia[2];
        let k = p.ball_radius / p.wheel_radius;
        (
            Matrix2::new(T::zero(), T::one(), T::zero(), -p.relative_damping / jz),
            Vector2::new(T::zero(), -k / jz),
        )
    }
}
