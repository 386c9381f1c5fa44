//! The equations of motion of the shell + platform (the [module](super) doc derives them): the
//! constrained mass matrix in the generalised speeds `u = (ω, Ω)`, the generalised forces
//! (gravity, floor pivot friction and rolling resistance, velocity terms), the wheel
//! constraint rows and the solve for accelerations and wheel constraint forces; the
//! M-metric projection onto the wheel constraints; the energy.

use omnikin::nalgebra::{
    Cholesky, Const, Matrix3, Matrix6, Quaternion, SMatrix, SVector, UnitQuaternion, Vector2,
    Vector3, Vector6,
};
use omnikin::sphere::SphereOmni;

use super::params::{DynamicsError, SphereDynamics};
use super::stepper::Stepper;
use omnikin::description::MotorModel;

/// How a wheel's motor acts during one sub-step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Drive {
    /// The motor imposes the commanded wheel rate (holonomic/rheonomic constraint); its torque
    /// is whatever that takes.
    Locked,
    /// The motor delivers a given constraint force `λ`, N (`λ_i = f_i R/(R − R_i)` for a roller
    /// force `f_i`; the motor torque is `κ_i λ_i`, see [`Model::kappa`]): 0 unpowered (wheel
    /// free), `± pull-out / |κ|` while slipping.
    Force(f64),
    /// The motor turns the wheel at the commanded rate but the roller slides on the shell: the
    /// roller force is the Coulomb + viscous law `f = d μ N + c v` (Karnopp's stick–slip
    /// switching: `d = ±1` the direction of the force the sticking contact needed when it
    /// began to slide, `v` the slip velocity along `α_i`, m/s), with the normal force `N`
    /// (first field, N) frozen over the sub-step; it sticks again when `v d` reaches 0.
    Slip(f64, f64),
    /// The wheel has lost contact with the shell (its normal force would be negative): no
    /// roller force.
    Lifted,
    /// A stepper ([`Model::stepper`]) drives the wheel through its torque–angle law and the
    /// roller sticks to the shell: the rotor angle is the wheel angle `χ_i` plus this offset
    /// (rad; what earlier roller slides and lift-offs moved the rotor against the shell), the
    /// roller force `λ_i = τ_i/κ_i`.
    Stepper(f64),
}

/// The integrated state in one flat form for the Runge–Kutta stages.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Y {
    /// Platform → world rotation (not normalised inside a step's stages).
    pub q: Quaternion<f64>,
    /// Platform angular velocity `ω`, world frame, rad/s.
    pub w: Vector3<f64>,
    /// Shell angular velocity `Ω`, world frame, rad/s.
    pub big_w: Vector3<f64>,
    /// Shell centre `(x, y)`, world frame, m.
    pub p: Vector2<f64>,
    /// Wheel angles relative to the platform, rad.
    pub chi: Vector3<f64>,
    /// Shell centre velocity `(ẋ, ẏ)`, world frame, m/s: a generalised speed of its own while
    /// the shell slides on the floor ([`Floor::Slide`]); while it rolls, kept equal to
    /// `R Ω × γ` by the integrator (and ignored by the rolling equations).
    pub v: Vector2<f64>,
}

/// The shell's contact with the floor during a sub-step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Floor {
    /// Rolling without slip: `v = R Ω × γ` (the constraint built into the generalised speeds
    /// `u = (ω, Ω)`); the floor supplies whatever horizontal force that takes.
    Roll,
    /// Sliding: the centre velocity `v` is free (generalised speeds `(ω, Ω, v)`) and the
    /// floor's horizontal force is the Coulomb force `μ_f N d` at the contact point `C − R γ`,
    /// with the floor's normal force `N` (first field, N) and the unit direction `d` (second,
    /// world `(x, y)`: opposite to the contact point's slip velocity, or at the onset the
    /// direction of the force the rolling contact needed) frozen over the sub-step (Karnopp's
    /// stick–slip switching, as for the rollers); it sticks again when the slip velocity
    /// `v − R Ω × γ` no longer opposes `d`.
    Slide(f64, Vector2<f64>),
}

/// Generalised speeds of the sliding shell `(ω, Ω, v)`.
pub(crate) type U8 = SVector<f64, 8>;

impl Y {
    /// `self + h · d`.
    pub fn add(&self, d: &Y, h: f64) -> Y {
        Y {
            q: self.q + d.q * h,
            w: self.w + d.w * h,
            big_w: self.big_w + d.big_w * h,
            p: self.p + d.p * h,
            chi: self.chi + d.chi * h,
            v: self.v + d.v * h,
        }
    }

    /// The generalised speeds of the sliding shell `(ω, Ω, v)`.
    pub fn u8(&self) -> U8 {
        U8::from_column_slice(&[
            self.w.x,
            self.w.y,
            self.w.z,
            self.big_w.x,
            self.big_w.y,
            self.big_w.z,
            self.v.x,
            self.v.y,
        ])
    }

    /// Sets `(ω, Ω, v)` from `u`.
    pub fn set_u8(&mut self, u: &U8) {
        self.w = Vector3::new(u[0], u[1], u[2]);
        self.big_w = Vector3::new(u[3], u[4], u[5]);
        self.v = Vector2::new(u[6], u[7]);
    }

    /// The generalised speeds `u = (ω, Ω)`.
    pub fn u(&self) -> Vector6<f64> {
        Vector6::new(
            self.w.x,
            self.w.y,
            self.w.z,
            self.big_w.x,
            self.big_w.y,
            self.big_w.z,
        )
    }

    /// Sets `(ω, Ω)` from `u`.
    pub fn set_u(&mut self, u: &Vector6<f64>) {
        self.w = Vector3::new(u[0], u[1], u[2]);
        self.big_w = Vector3::new(u[3], u[4], u[5]);
    }
}

/// Everything configuration-dependent that the derivative, the projection and the reports
/// share, computed once per state.
pub(crate) struct Frame {
    /// Platform → world rotation matrix.
    pub rot: Matrix3<f64>,
    /// Constrained mass matrix `M(q)`, 6 × 6.
    pub mass: Matrix6<f64>,
    /// Constraint rows `C_i = (−σ_i, σ_i)`, `σ_i = Q s_i`.
    pub rows: [Vector6<f64>; 3],
    /// The platform's inertia tensor in the world frame `J_w = Q J_p Qᵀ`.
    pub jw: Matrix3<f64>,
}

/// `M⁻¹` by blocks. With `M = [[A, B], [Bᵀ, D]]` the shell block
/// `D = M R² (I − γ γᵀ) + I_s I` is diagonal (and constant), so
/// `x_ω = S⁻¹ (r_ω − B D⁻¹ r_Ω)`, `x_Ω = D⁻¹ (r_Ω − Bᵀ x_ω)` with the 3 × 3 Schur complement
/// `S = A − B D⁻¹ Bᵀ` (symmetric positive definite as `M` is): one 3 × 3 Cholesky factor
/// instead of a 6 × 6 one, the same solution up to rounding.
pub(crate) struct MassSolve {
    b: Matrix3<f64>,
    dinv: Vector3<f64>,
    schur: Cholesky<f64, Const<3>>,
}

impl MassSolve {
    /// Factors the mass matrix of `f`.
    pub fn new(f: &Frame) -> Result<Self, Singular> {
        let a = f.mass.fixed_view::<3, 3>(0, 0).into_owned();
        let b = f.mass.fixed_view::<3, 3>(0, 3).into_owned();
        let dinv = Vector3::new(
            1.0 / f.mass[(3, 3)],
            1.0 / f.mass[(4, 4)],
            1.0 / f.mass[(5, 5)],
        );
        let bd = Matrix3::from_fn(|r, c| b[(r, c)] * dinv[c]);
        let schur = (a - bd * b.transpose())
            .cholesky()
            .ok_or(Singular("mass matrix"))?;
        Ok(Self { b, dinv, schur })
    }

    /// `M⁻¹ r`.
    pub fn solve(&self, r: &Vector6<f64>) -> Vector6<f64> {
        let rw = Vector3::new(r[0], r[1], r[2]);
        let ro = Vector3::new(r[3], r[4], r[5]);
        let xw = self
            .schur
            .solve(&(rw - self.b * ro.component_mul(&self.dinv)));
        let xo = (ro - self.b.transpose() * xw).component_mul(&self.dinv);
        Vector6::new(xw.x, xw.y, xw.z, xo.x, xo.y, xo.z)
    }
}

/// The model's constants, precomputed from [`SphereDynamics`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Model {
    pub r: f64,
    pub ms: f64,
    pub mp: f64,
    pub is: f64,
    pub h: f64,
    pub g: f64,
    pub jp: Matrix3<f64>,
    /// `s_i = r_i × α_i`, platform frame, m.
    pub s: [Vector3<f64>; 3],
    /// `κ_i = (R_i/R)(s_i·n_i)`, m: `σ_i·(Ω − ω) = κ_i χ̇_i`, motor torque `κ_i λ_i`.
    pub kappa: [f64; 3],
    /// `(R − R_i)`, m (roller-contact residual in m/s).
    pub lever: [f64; 3],
    pub pivot: f64,
    pub pivot_eps: f64,
    /// Rolling-resistance torque `C_rr M g R`, N·m.
    pub rolling: f64,
    pub rolling_eps: f64,
    /// Tracked point along the platform's z axis from the shell centre, m.
    pub z_track: f64,
    /// `α_i`, unit roller axes at the contact, platform frame.
    pub alpha: [Vector3<f64>; 3],
    /// Inverse of the matrix whose columns are the unit contact directions `p̂_i` (shell
    /// centre → contact), platform frame: `N = P̂⁻¹ Qᵀ (Σ N_i p̂_i)`.
    pub contact_inv: Matrix3<f64>,
    /// Roller–shell friction coefficient μ (`f64::INFINITY` = rigid bilateral contacts).
    pub mu: f64,
    /// Roller–shell viscous coefficient `c`, N·s/m.
    pub viscous: f64,
    /// Normal preload per wheel, N.
    pub preload: f64,
    /// Shell–floor friction coefficient μ_f (`f64::INFINITY` = the shell never slides).
    pub mu_floor: f64,
    /// The motors' torque–angle law when they are steppers (`motor = "stepper"`).
    pub stepper: Option<Stepper>,
}

/// The time derivative of the state and what the forces were at that state.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Deriv {
    /// `ẏ`.
    pub d: Y,
    /// Wheel constraint/contact forces `λ_i = f_i R/(R − R_i)`, N (motor torque `κ_i λ_i`).
    pub lambda: [f64; 3],
    /// Roller normal forces `N_i` (the shell pushing the wheel towards the centre), N,
    /// including the preload; negative = the centred platform would need the shell to pull.
    pub normal: [f64; 3],
    /// Power of the wheel forces on shell + platform `Σ λ_i C_i u`, W.
    pub contact_power: f64,
    /// Power of the floor torque `τ_floor·Ω`, W.
    pub floor_power: f64,
    /// Mechanical power the motors deliver to their rotors `Σ τ_i θ̇_rotor,i`, W: the
    /// wheel's rate for a sticking roller, the commanded rate for a sliding one (the rotor
    /// follows its field), 0 for a lifted wheel.
    pub motor_power: f64,
    /// Power dissipated by the sliding rollers `Σ f_i v_i` (roller force times slip velocity),
    /// W; never negative for a physical friction law.
    pub slip_power: f64,
    /// Horizontal floor force over the vertical one (the friction coefficient the floor must
    /// supply); infinite when the vertical force is not positive.
    pub floor_ratio: f64,
    /// The floor's force on the robot `F = m_s a_C + m_p a_p + M g γ`, world frame, N.
    pub floor_force: Vector3<f64>,
    /// Power dissipated by the shell sliding on the floor `−F_t·v_s` (the Coulomb force times
    /// the contact point's slip velocity), W; 0 while rolling. Included in `floor_power`.
    pub floor_slide_power: f64,
}

/// A matrix of the solve was singular (only for a state that is no longer finite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Singular(pub &'static str);

const GAMMA: Vector3<f64> = Vector3::new(0.0, 0.0, 1.0);

/// A wheel's constraint row in the sliding shell's speeds `(ω, Ω, v)` (its contact does not
/// involve `v`).
fn row8(row: &Vector6<f64>) -> U8 {
    let mut r = U8::zeros();
    r.fixed_rows_mut::<6>(0).copy_from(row);
    r
}

impl Model {
    pub fn new(p: &SphereDynamics) -> Result<(Self, SphereOmni<f64>), DynamicsError> {
        p.validate()?;
        let kin = SphereOmni::new(p.geometry)?;
        let r = p.geometry.shell_radius;
        let sn = kin.s_dot_n();
        let pts = kin.contact_points();
        let cols =
            Matrix3::from_columns(&[pts[0].normalize(), pts[1].normalize(), pts[2].normalize()]);
        let contact_inv = cols.try_inverse().ok_or(DynamicsError::Parameter {
            field: "geometry.tilt",
            value: p.geometry.tilt,
            rule: "the three wheel contacts' directions from the shell centre must span 3-D \
                   (their normal forces carry the platform)",
        })?;
        let m = Model {
            r,
            ms: p.shell_mass,
            mp: p.platform_mass,
            is: p.shell_inertia,
            h: p.com_depth,
            g: p.gravity,
            jp: Matrix3::from_fn(|a, b| p.platform_inertia[a][b]),
            s: *kin.levers(),
            kappa: core::array::from_fn(|i| p.geometry.wheel_radius[i] / r * sn[i]),
            lever: core::array::from_fn(|i| r - p.geometry.wheel_radius[i]),
            pivot: p.pivot_friction,
            pivot_eps: p.pivot_velocity_scale,
            rolling: p.rolling_resistance * p.total_mass() * p.gravity * r,
            rolling_eps: p.rolling_velocity_scale,
            z_track: p.tracked_height - r,
            alpha: *kin.roller_axes(),
            contact_inv,
            mu: p.roller_friction,
            viscous: p.roller_viscous,
            preload: p.roller_preload,
            mu_floor: p.floor_friction,
            stepper: (p.motor == MotorModel::Stepper).then(|| Stepper::of(p)),
        };
        Ok((m, kin))
    }

    /// Mass matrix and constraint rows at orientation `q`.
    pub fn frame(&self, q: &Quaternion<f64>) -> Frame {
        let rot = UnitQuaternion::from_quaternion(*q)
            .to_rotation_matrix()
            .into_inner();
        let k = rot.column(2).into_owned();
        let jw = rot * self.jp * rot.transpose();
        let eye = Matrix3::identity();
        // M_ωω = m_p h² (I − k kᵀ) + J_w; M_ωΩ = m_p h R [k]×[γ]× = m_p h R (γ kᵀ − (k·γ) I);
        // M_ΩΩ = M R² (I − γ γᵀ) + I_s I.
        let mww = (eye - k * k.transpose()) * (self.mp * self.h * self.h) + jw;
        let mwo = (GAMMA * k.transpose() - eye * k.dot(&GAMMA)) * (self.mp * self.h * self.r);
        let moo = (eye - GAMMA * GAMMA.transpose()) * ((self.ms + self.mp) * self.r * self.r)
            + eye * self.is;
        let mut mass = Matrix6::zeros();
        mass.fixed_view_mut::<3, 3>(0, 0).copy_from(&mww);
        mass.fixed_view_mut::<3, 3>(0, 3).copy_from(&mwo);
        mass.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&mwo.transpose());
        mass.fixed_view_mut::<3, 3>(3, 3).copy_from(&moo);
        let rows = core::array::from_fn(|i| {
            let sg = rot * self.s[i];
            Vector6::new(-sg.x, -sg.y, -sg.z, sg.x, sg.y, sg.z)
        });
        Frame {
            rot,
            mass,
            rows,
            jw,
        }
    }

    /// Floor torque on the shell, world frame, N·m: pivot friction `−τ_p tanh(Ω3/ε_p) γ` and
    /// rolling resistance `−C_rr M g R Ω_h / √(|Ω_h|² + ε_r²)`.
    pub fn floor_torque(&self, big_w: &Vector3<f64>) -> Vector3<f64> {
        let mut t = Vector3::zeros();
        if self.pivot > 0.0 {
            t.z = -self.pivot * (big_w.z / self.pivot_eps).tanh();
        }
        if self.rolling > 0.0 {
            let n = (big_w.x * big_w.x + big_w.y * big_w.y + self.rolling_eps * self.rolling_eps)
                .sqrt();
            t.x = -self.rolling * big_w.x / n;
            t.y = -self.rolling * big_w.y / n;
        }
        t
    }

    /// Slip velocity of wheel `i`'s roller over the shell along `α_i`, m/s, for the commanded
    /// wheel rate `chi_d` (rad/s): `R (κ_i χ̇_i − C_i u)/(R − R_i)` (the residual of paper 000
    /// eq. 4.4 at the contact; positive = the wheel runs ahead of the shell).
    pub fn slip_velocity(&self, i: usize, row: &Vector6<f64>, u: &Vector6<f64>, chi_d: f64) -> f64 {
        self.r * (self.kappa[i] * chi_d - row.dot(u)) / self.lever[i]
    }

    /// The sliding roller's Coulomb + viscous force `d μ N + c v` for the slip velocity `v`
    /// (m/s), the direction `dir` (±1) and the normal force `normal` (N), expressed as the
    /// constraint force `λ = f R/(R − R_i)`, N.
    pub fn friction_lambda(&self, i: usize, v: f64, dir: f64, normal: f64) -> f64 {
        let f = dir * self.mu * normal.max(0.0) + self.viscous * v;
        f * self.r / self.lever[i]
    }

    /// The stepper's roller force `λ_i = τ_i/κ_i` (N) for the rotor offset `offset` (rad), the
    /// commanded angle `field` (rad) and rate `chi_d` (rad/s), at the state `y` with the
    /// constraint row `row`. 0 when the motors are not steppers.
    pub fn stepper_lambda(
        &self,
        i: usize,
        y: &Y,
        row: &Vector6<f64>,
        offset: f64,
        field: f64,
        chi_d: f64,
    ) -> f64 {
        let Some(st) = &self.stepper else {
            return 0.0;
        };
        let rate = row.dot(&y.u()) / self.kappa[i];
        st.torque(y.chi[i] + offset - field, rate - chi_d, chi_d) / self.kappa[i]
    }

    /// The time derivative of `y` with the motors in `drive`, the commanded wheel angles
    /// `field` (rad, for a stepper), rates `chi_d` (rad/s, for the slip velocity of a sliding
    /// roller and a stepper) and accelerations `chi_dd` (rad/s², for a locked wheel), the
    /// shell rolling or sliding on the floor (`floor`), and the forces at that state
    /// ([`Deriv`]).
    #[allow(clippy::too_many_arguments)]
    pub fn derivative(
        &self,
        y: &Y,
        drive: &[Drive; 3],
        field: &[f64; 3],
        chi_d: &[f64; 3],
        chi_dd: &[f64; 3],
        floor: &Floor,
    ) -> Result<Deriv, Singular> {
        let f = self.frame(&y.q);
        let (w, big_w) = (y.w, y.big_w);
        let u = y.u();
        let k = f.rot.column(2).into_owned();
        let jw = f.jw;
        // Ḃω = h (ω × k) × ω: the platform centre of mass's velocity-dependent acceleration.
        let wb = w.cross(&k).cross(&w) * self.h;
        let rhs_w = k.cross(&GAMMA) * (self.mp * self.g * self.h)
            + k.cross(&wb) * (self.mp * self.h)
            - w.cross(&(jw * w));
        let torque = self.floor_torque(&big_w);
        let rel = big_w - w;
        // C_i u̇ = κ_i χ̈_i − Ċ_i u, Ċ_i u = (ω × σ_i)·(Ω − ω): the locked wheels' right side.
        let lock_rhs: [f64; 3] = core::array::from_fn(|i| {
            let sg = f.rot * self.s[i];
            self.kappa[i] * chi_dd[i] - w.cross(&sg).dot(&rel)
        });
        let (w_dot, big_w_dot, a_c, lambda, slide) = match *floor {
            Floor::Roll => {
                let rhs_o = torque - GAMMA.cross(&wb) * (self.mp * self.r);
                let rhs = Vector6::new(rhs_w.x, rhs_w.y, rhs_w.z, rhs_o.x, rhs_o.y, rhs_o.z);
                let chol = MassSolve::new(&f)?;
                let u0 = chol.solve(&rhs);
                let yc: [Vector6<f64>; 3] = core::array::from_fn(|i| chol.solve(&f.rows[i]));
                let lambda = self.wheel_forces(
                    y,
                    &f.rows,
                    drive,
                    field,
                    chi_d,
                    |i, j| f.rows[i].dot(&yc[j]),
                    core::array::from_fn(|i| lock_rhs[i] - f.rows[i].dot(&u0)),
                )?;
                let ud = u0 + yc[0] * lambda[0] + yc[1] * lambda[1] + yc[2] * lambda[2];
                let big_w_dot = Vector3::new(ud[3], ud[4], ud[5]);
                (
                    Vector3::new(ud[0], ud[1], ud[2]),
                    big_w_dot,
                    big_w_dot.cross(&GAMMA) * self.r,
                    lambda,
                    None,
                )
            }
            Floor::Slide(normal, dir) => {
                // The floor's Coulomb force at the contact C − R γ: on v, and its moment
                // (−R γ) × F_t on the shell.
                let ft = dir * (self.mu_floor * normal.max(0.0));
                let ft3 = Vector3::new(ft.x, ft.y, 0.0);
                let rhs_o = torque - GAMMA.cross(&ft3) * self.r;
                let mut rhs = U8::zeros();
                rhs.fixed_rows_mut::<3>(0).copy_from(&rhs_w);
                rhs.fixed_rows_mut::<3>(3).copy_from(&rhs_o);
                rhs[6] = ft.x - self.mp * wb.x;
                rhs[7] = ft.y - self.mp * wb.y;
                let chol = self
                    .mass8(&f)
                    .cholesky()
                    .ok_or(Singular("sliding mass matrix"))?;
                let u0 = chol.solve(&rhs);
                let rows8: [U8; 3] = core::array::from_fn(|i| row8(&f.rows[i]));
                let yc: [U8; 3] = core::array::from_fn(|i| chol.solve(&rows8[i]));
                let lambda = self.wheel_forces(
                    y,
                    &f.rows,
                    drive,
                    field,
                    chi_d,
                    |i, j| rows8[i].dot(&yc[j]),
                    core::array::from_fn(|i| lock_rhs[i] - rows8[i].dot(&u0)),
                )?;
                let ud = u0 + yc[0] * lambda[0] + yc[1] * lambda[1] + yc[2] * lambda[2];
                (
                    Vector3::new(ud[0], ud[1], ud[2]),
                    Vector3::new(ud[3], ud[4], ud[5]),
                    Vector3::new(ud[6], ud[7], 0.0),
                    lambda,
                    Some(ft),
                )
            }
        };
        // Platform centre of mass at C − h k: a_p = a_C − h ω̇ × k − h ω × (ω × k).
        let a_p = a_c - w_dot.cross(&k) * self.h - w.cross(&w.cross(&k)) * self.h;
        // The platform's Newton equation: m_p a_p = −m_p g γ − Σ N_i p̂_i − Σ f_i α_i.
        let mut push = -(a_p + GAMMA * self.g) * self.mp;
        for i in 0..3 {
            push -= f.rot * self.alpha[i] * (lambda[i] * self.lever[i] / self.r);
        }
        let n = self.contact_inv * (f.rot.transpose() * push);
        let normal = [n.x + self.preload, n.y + self.preload, n.z + self.preload];
        // The floor carries the rest: F = m_s a_C + m_p a_p + M g γ.
        let ff = a_c * self.ms + a_p * self.mp + GAMMA * ((self.ms + self.mp) * self.g);
        let floor_ratio = if ff.z > 0.0 {
            ff.x.hypot(ff.y) / ff.z
        } else {
            f64::INFINITY
        };
        let wq = Quaternion::new(0.0, w.x, w.y, w.z);
        let (p_dot, floor_slide_power) = match slide {
            None => (self.centre_velocity(&big_w), 0.0),
            Some(ft) => (y.v, -ft.dot(&self.floor_slip_velocity(y))),
        };
        let d = Y {
            q: wq * y.q * 0.5,
            w: w_dot,
            big_w: big_w_dot,
            p: p_dot,
            chi: Vector3::from_fn(|i, _| f.rows[i].dot(&u) / self.kappa[i]),
            v: Vector2::new(a_c.x, a_c.y),
        };
        let contact_power = (0..3).map(|i| lambda[i] * f.rows[i].dot(&u)).sum();
        let (mut motor_power, mut slip_power) = (0.0, 0.0);
        for i in 0..3 {
            match drive[i] {
                Drive::Slip(..) => {
                    motor_power += lambda[i] * self.kappa[i] * chi_d[i];
                    // f v = (λ (R − R_i)/R) (R (κ χ̇_d − C u)/(R − R_i)) = λ (κ χ̇_d − C u).
                    slip_power += lambda[i] * (self.kappa[i] * chi_d[i] - f.rows[i].dot(&u));
                }
                Drive::Lifted => {}
                _ => motor_power += lambda[i] * f.rows[i].dot(&u),
            }
        }
        Ok(Deriv {
            d,
            lambda: lambda.into(),
            normal,
            contact_power,
            floor_power: torque.dot(&big_w) - floor_slide_power,
            motor_power,
            slip_power,
            floor_ratio,
            floor_force: ff,
            floor_slide_power,
        })
    }

    /// The wheels' constraint forces `λ`, N: given by each motor's or contact's law, or for
    /// the locked wheels solved from `Σ_j (C_i M⁻¹ C_jᵀ) λ_j = b_i` with `cyc(i, j) =
    /// C_i M⁻¹ C_jᵀ` and `free[i]` = `κ_i χ̈_i − Ċ_i u − C_i M⁻¹ Q` (in whichever
    /// generalised speeds the floor contact leaves).
    #[allow(clippy::too_many_arguments)]
    fn wheel_forces(
        &self,
        y: &Y,
        rows: &[Vector6<f64>; 3],
        drive: &[Drive; 3],
        field: &[f64; 3],
        chi_d: &[f64; 3],
        cyc: impl Fn(usize, usize) -> f64,
        free: [f64; 3],
    ) -> Result<Vector3<f64>, Singular> {
        let u = y.u();
        let mut s = Matrix3::zeros();
        let mut b = Vector3::zeros();
        let mut any_locked = false;
        for i in 0..3 {
            let given = match drive[i] {
                Drive::Locked => {
                    any_locked = true;
                    for j in 0..3 {
                        s[(i, j)] = cyc(i, j);
                    }
                    b[i] = free[i];
                    continue;
                }
                Drive::Force(l) => l,
                Drive::Slip(n, dir) => {
                    let v = self.slip_velocity(i, &rows[i], &u, chi_d[i]);
                    self.friction_lambda(i, v, dir, n)
                }
                Drive::Lifted => 0.0,
                Drive::Stepper(off) => self.stepper_lambda(i, y, &rows[i], off, field[i], chi_d[i]),
            };
            s[(i, i)] = 1.0;
            b[i] = given;
        }
        if any_locked {
            s.lu().solve(&b).ok_or(Singular("wheel constraint matrix"))
        } else {
            Ok(b)
        }
    }

    /// The mass matrix of the sliding shell in `(ω, Ω, v)`: `M_ωω` as rolling,
    /// `M_ΩΩ = I_s I`, `M_vv = M I₂`, `M_ωv = −m_p h [k]×` (the platform's centre of mass moves
    /// at `v + h k × ω`); with `v = R Ω × γ` it reduces to [`Frame::mass`].
    pub fn mass8(&self, f: &Frame) -> SMatrix<f64, 8, 8> {
        let k = f.rot.column(2).into_owned();
        let mut m = SMatrix::<f64, 8, 8>::zeros();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&f.mass.fixed_view::<3, 3>(0, 0));
        for a in 3..6 {
            m[(a, a)] = self.is;
        }
        let total = self.ms + self.mp;
        m[(6, 6)] = total;
        m[(7, 7)] = total;
        // −m_p h [k]× v, v = (v_x, v_y, 0).
        let c = -self.mp * self.h;
        let kx = k.cross_matrix();
        for r in 0..3 {
            for j in 0..2 {
                m[(r, 6 + j)] = c * kx[(r, j)];
                m[(6 + j, r)] = c * kx[(r, j)];
            }
        }
        m
    }

    /// Slip velocity of the shell's floor-contact point `v − R Ω × γ`, world `(x, y)`, m/s.
    pub fn floor_slip_velocity(&self, y: &Y) -> Vector2<f64> {
        y.v - self.centre_velocity(&y.big_w)
    }

    /// Total mechanical energy of the sliding shell `½ uᵀ M₈ u − m_p g h (k·γ)` with
    /// `u = (ω, Ω, v)`, J; equal to [`Model::energy_in`] when `v = R Ω × γ`.
    pub fn energy8(&self, f: &Frame, y: &Y) -> f64 {
        let u = y.u8();
        let k = f.rot.column(2).into_owned();
        0.5 * u.dot(&(self.mass8(f) * u)) - self.mp * self.g * self.h * k.dot(&GAMMA)
    }

    /// Projects the sliding shell's `(ω, Ω, v)` onto the locked wheels' constraints in the
    /// metric of [`Model::mass8`] (as [`Model::project`] does for the rolling shell).
    pub fn project8(
        &self,
        f: &Frame,
        y: &mut Y,
        drive: &[Drive; 3],
        chi_d: &[f64; 3],
    ) -> Result<(), Singular> {
        if !drive.contains(&Drive::Locked) {
            return Ok(());
        }
        let chol = self
            .mass8(f)
            .cholesky()
            .ok_or(Singular("sliding mass matrix"))?;
        let rows8: [U8; 3] = core::array::from_fn(|i| row8(&f.rows[i]));
        let yc: [U8; 3] = core::array::from_fn(|i| chol.solve(&rows8[i]));
        let u = y.u8();
        let mut s = Matrix3::zeros();
        let mut e = Vector3::zeros();
        for i in 0..3 {
            if drive[i] == Drive::Locked {
                for j in 0..3 {
                    s[(i, j)] = if drive[j] == Drive::Locked {
                        rows8[i].dot(&yc[j])
                    } else {
                        0.0
                    };
                }
                e[i] = rows8[i].dot(&u) - self.kappa[i] * chi_d[i];
            } else {
                s[(i, i)] = 1.0;
            }
        }
        let mu = s
            .lu()
            .solve(&e)
            .ok_or(Singular("wheel constraint matrix"))?;
        let u = u - yc[0] * mu[0] - yc[1] * mu[1] - yc[2] * mu[2];
        y.set_u8(&u);
        Ok(())
    }

    /// The sticking floor's impulse: projects `(ω, Ω, v)` onto the rolling constraint
    /// `v − R Ω × γ = 0` in the metric of [`Model::mass8`] (the smallest kinetic-energy
    /// correction, an impulse at the contact point), then sets `v` exactly to `R Ω × γ`.
    pub fn stick_floor(&self, f: &Frame, y: &mut Y) -> Result<(), Singular> {
        let chol = self
            .mass8(f)
            .cholesky()
            .ok_or(Singular("sliding mass matrix"))?;
        // g_x = v_x − R Ω_y, g_y = v_y + R Ω_x.
        let mut gx = U8::zeros();
        gx[6] = 1.0;
        gx[4] = -self.r;
        let mut gy = U8::zeros();
        gy[7] = 1.0;
        gy[3] = self.r;
        let (yx, yy) = (chol.solve(&gx), chol.solve(&gy));
        let s = omnikin::nalgebra::Matrix2::new(gx.dot(&yx), gx.dot(&yy), gy.dot(&yx), gy.dot(&yy));
        let u = y.u8();
        let e = Vector2::new(gx.dot(&u), gy.dot(&u));
        let mu = s
            .lu()
            .solve(&e)
            .ok_or(Singular("floor constraint matrix"))?;
        let u = u - yx * mu.x - yy * mu.y;
        y.set_u8(&u);
        y.v = self.centre_velocity(&y.big_w);
        Ok(())
    }

    /// Shell centre velocity from rolling without slip, `v = R Ω × γ`, world `(x, y)`, m/s.
    pub fn centre_velocity(&self, big_w: &Vector3<f64>) -> Vector2<f64> {
        Vector2::new(self.r * big_w.y, -self.r * big_w.x)
    }

    /// Projects `(ω, Ω)` onto the locked wheels' constraints `σ_i·(Ω − ω) = κ_i χ̇_i` in the
    /// metric of the mass matrix (the smallest kinetic-energy correction); `f` is the frame
    /// of `y`'s orientation (the projection leaves the orientation alone).
    pub fn project(
        &self,
        f: &Frame,
        y: &mut Y,
        drive: &[Drive; 3],
        chi_d: &[f64; 3],
    ) -> Result<(), Singular> {
        if !drive.contains(&Drive::Locked) {
            return Ok(());
        }
        let chol = MassSolve::new(f)?;
        let yc: [Vector6<f64>; 3] = core::array::from_fn(|i| chol.solve(&f.rows[i]));
        let u = y.u();
        let mut s = Matrix3::zeros();
        let mut e = Vector3::zeros();
        for i in 0..3 {
            if drive[i] == Drive::Locked {
                for j in 0..3 {
                    s[(i, j)] = if drive[j] == Drive::Locked {
                        f.rows[i].dot(&yc[j])
                    } else {
                        0.0
                    };
                }
                e[i] = f.rows[i].dot(&u) - self.kappa[i] * chi_d[i];
            } else {
                s[(i, i)] = 1.0;
            }
        }
        let mu = s
            .lu()
            .solve(&e)
            .ok_or(Singular("wheel constraint matrix"))?;
        let u = u - yc[0] * mu[0] - yc[1] * mu[1] - yc[2] * mu[2];
        y.set_u(&u);
        Ok(())
    }

    /// Actual wheel rates `χ̇_i = σ_i·(Ω − ω)/κ_i`, rad/s.
    pub fn wheel_rates(&self, y: &Y) -> [f64; 3] {
        let f = self.frame(&y.q);
        let u = y.u();
        core::array::from_fn(|i| f.rows[i].dot(&u) / self.kappa[i])
    }

    /// Total mechanical energy `½ uᵀ M u − m_p g h (k·γ)`, J (zero of potential at the
    /// shell centre's height).
    pub fn energy(&self, y: &Y) -> f64 {
        self.energy_in(&self.frame(&y.q), y)
    }

    /// [`Model::energy`] with the frame `f` of `y`'s orientation already at hand.
    pub fn energy_in(&self, f: &Frame, y: &Y) -> f64 {
        let u = y.u();
        let k = f.rot.column(2).into_owned();
        0.5 * u.dot(&(f.mass * u)) - self.mp * self.g * self.h * k.dot(&GAMMA)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_block_solve_equals_the_full_cholesky_solve() {
        // Tilted and yawed platforms, a deep and a shallow centre of mass: the Schur-complement
        // solve must give what the 6 × 6 Cholesky factor of the same matrix gives.
        for h in [0.02, 0.08, 0.14] {
            let mut p = SphereDynamics::paper_000();
            p.com_depth = h;
            let (m, _) = Model::new(&p).unwrap();
            for (roll, pitch, yaw) in [(0.0, 0.0, 0.0), (0.3, -0.2, 1.0), (-1.2, 0.7, -2.5)] {
                let q = UnitQuaternion::from_euler_angles(roll, pitch, yaw).into_inner();
                let f = m.frame(&q);
                let full = f.mass.cholesky().unwrap();
                let block = MassSolve::new(&f).unwrap();
                for r in [
                    Vector6::new(1.0, -2.0, 0.5, 0.3, 4.0, -1.0),
                    f.rows[0],
                    f.rows[2],
                ] {
                    let (a, b) = (full.solve(&r), block.solve(&r));
                    assert!((a - b).norm() <= 1e-12 * a.norm(), "{a} vs {b}");
                    assert!((f.mass * b - r).norm() <= 1e-12 * r.norm());
                }
            }
        }
    }
}
