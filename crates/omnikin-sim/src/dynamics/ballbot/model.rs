//! The 3D equations of motion ([`BallbotPlant::accelerations`]), the energy, the wheel rates
//! and the effect of a push, for a [`BallbotState`].

use omnikin::ballbot::Ballbot;
use omnikin::control::{BalanceError, Measurement, PlanarModel, Plane};
use omnikin::nalgebra::{Matrix3, Matrix6, UnitQuaternion, Vector3, Vector6};

use super::params::BallbotDynamics;
use super::state::BallbotState;

/// Skew matrix `[v]×` (`[v]× w = v × w`).
pub(crate) fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// A ballbot's 3D dynamic model: parameters, the wheel model of the core and the constant
/// rolling matrix `P` (`v_ball = P Ω`).
#[derive(Clone, Copy, Debug)]
pub struct BallbotPlant {
    params: BallbotDynamics,
    robot: Ballbot<f64>,
    /// `P = −R [e_z]×`: ball-centre velocity from the ball's angular velocity (rolling).
    p: Matrix3<f64>,
}

impl BallbotPlant {
    /// Builds the model.
    ///
    /// # Errors
    /// [`BalanceError`] naming a parameter [`BallbotDynamics::validate`] rejects.
    pub fn new(params: BallbotDynamics) -> Result<Self, BalanceError> {
        params.validate()?;
        let robot = Ballbot::new(params.geometry)?;
        let p = -skew(&Vector3::z()) * params.geometry.ball_radius;
        Ok(Self { params, robot, p })
    }

    /// The parameters.
    pub fn params(&self) -> &BallbotDynamics {
        &self.params
    }

    /// The core's kinematic and torque model of the wheels.
    pub fn robot(&self) -> &Ballbot<f64> {
        &self.robot
    }

    /// Body centre-of-mass offset from the ball centre, world frame: `r = l R_B e_z`, m.
    pub fn com_offset(&self, s: &BallbotState) -> Vector3<f64> {
        s.orientation * Vector3::z() * self.params.com_height
    }

    /// Ball-centre velocity `P Ω`, world frame, m/s.
    pub fn ball_velocity(&self, s: &BallbotState) -> Vector3<f64> {
        self.p * s.ball_rate
    }

    /// Velocity of the body's centre of mass, world frame, m/s: `P Ω + ω × r`.
    pub fn com_velocity(&self, s: &BallbotState) -> Vector3<f64> {
        self.ball_velocity(s) + s.body_rate.cross(&self.com_offset(s))
    }

    /// The wheels' torque on the ball, world frame, N·m: `R_B k (−Tx, −Ty, Tz)` with
    /// `(Tx, Ty, Tz) = A(0) T` the body-frame model torques of paper 001 (the body receives
    /// the opposite torque).
    pub fn ball_torque(&self, s: &BallbotState, wheel_torques: [f64; 3]) -> Vector3<f64> {
        let k = self.params.geometry.ball_radius / self.params.geometry.wheel_radius;
        let g = self
            .robot
            .model_torques(wheel_torques, 0.0)
            .unwrap_or([f64::NAN; 3]);
        s.orientation * Vector3::new(-g[0], -g[1], g[2]) * k
    }

    /// Wheel rates `ψ̇ = (R/r_w) B R_Bᵀ (Ω − ω)` (rad/s): the core's velocity map applied to the
    /// ball's rotation relative to the body, in the body frame (exact at any tilt).
    pub fn wheel_rates(&self, s: &BallbotState) -> [f64; 3] {
        let rel = s.orientation.inverse() * (s.ball_rate - s.body_rate);
        self.robot
            .wheel_rates_from_relative(rel)
            .unwrap_or([f64::NAN; 3])
    }

    /// The mass matrix `M(q)` of the generalized speeds `u = (Ω, ω)` (world frame).
    pub fn mass_matrix(&self, s: &BallbotState) -> Matrix6<f64> {
        let d = &self.params;
        let r = self.com_offset(s);
        let rx = skew(&r);
        let rot = s.orientation.to_rotation_matrix();
        let jw = rot.matrix()
            * Matrix3::from_diagonal(&Vector3::from(d.body_inertia))
            * rot.matrix().transpose();
        let mut m = Matrix6::zeros();
        let ptp = self.p.transpose() * self.p;
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(ptp * d.total_mass() + Matrix3::identity() * d.ball_inertia));
        m.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-self.p.transpose() * rx * d.body_mass));
        m.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(rx * self.p * d.body_mass));
        m.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(jw - rx * rx * d.body_mass));
        m
    }

    /// The accelerations `(Ω̇, ω̇)` (rad/s², world frame) for the wheel torques (N·m) and a
    /// horizontal or any force `force` (N, world frame) on the body's centre of mass, from
    /// Kane's equations (module doc): `M(q) u̇ = f(q, u) + Q(T) + Q(F)`.
    pub fn accelerations(
        &self,
        s: &BallbotState,
        wheel_torques: [f64; 3],
        force: Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let d = &self.params;
        let r = self.com_offset(s);
        let (om, w) = (s.ball_rate, s.body_rate);
        let rot = s.orientation.to_rotation_matrix();
        let jw = rot.matrix()
            * Matrix3::from_diagonal(&Vector3::from(d.body_inertia))
            * rot.matrix().transpose();
        let tau = self.ball_torque(s, wheel_torques);
        let centripetal = w.cross(&w.cross(&r));
        let rel = om - w;
        let damp_ball = -om * d.floor_damping - rel * d.relative_damping;
        let damp_body = rel * d.relative_damping;
        let f_ball = tau - self.p.transpose() * centripetal * d.body_mass
            + damp_ball
            + self.p.transpose() * force;
        let f_body = -r.cross(&Vector3::z()) * (d.body_mass * d.gravity)
            - r.cross(&centripetal) * d.body_mass
            - tau
            - w.cross(&(jw * w))
            + damp_body
            + r.cross(&force);
        let rhs = Vector6::new(f_ball.x, f_ball.y, f_ball.z, f_body.x, f_body.y, f_body.z);
        let acc = self
            .mass_matrix(s)
            .cholesky()
            .map(|c| c.solve(&rhs))
            .unwrap_or(Vector6::repeat(f64::NAN));
        (
            Vector3::new(acc[0], acc[1], acc[2]),
            Vector3::new(acc[3], acc[4], acc[5]),
        )
    }

    /// Total mechanical energy, J: kinetic energy of ball and body plus the body's potential
    /// energy `m_B g r_z` (ball centre at height 0).
    pub fn energy(&self, s: &BallbotState) -> f64 {
        let d = &self.params;
        let vb = self.ball_velocity(s);
        let vc = self.com_velocity(s);
        let rot = s.orientation.to_rotation_matrix();
        let wb = rot.inverse() * s.body_rate;
        let j = Vector3::from(d.body_inertia);
        0.5 * d.ball_mass * vb.norm_squared()
            + 0.5 * d.ball_inertia * s.ball_rate.norm_squared()
            + 0.5 * d.body_mass * vc.norm_squared()
            + 0.5 * (j.x * wb.x * wb.x + j.y * wb.y * wb.y + j.z * wb.z * wb.z)
            + d.body_mass * d.gravity * self.com_offset(s).z
    }

    /// Mechanical power of the wheels on ball and body, W: `τ · (Ω − ω)`.
    pub fn wheel_power(&self, s: &BallbotState, wheel_torques: [f64; 3]) -> f64 {
        self.ball_torque(s, wheel_torques)
            .dot(&(s.ball_rate - s.body_rate))
    }

    /// Applies an impulse `impulse` (N·s, world frame) at the body's centre of mass: the
    /// generalized speeds jump by `M⁻¹ Jᵀ impulse` (`J` the partial velocities of the centre of
    /// mass), as a short push does.
    pub fn apply_impulse(&self, s: &mut BallbotState, impulse: Vector3<f64>) {
        let r = self.com_offset(s);
        let g_ball = self.p.transpose() * impulse;
        let g_body = r.cross(&impulse);
        let rhs = Vector6::new(g_ball.x, g_ball.y, g_ball.z, g_body.x, g_body.y, g_body.z);
        if let Some(c) = self.mass_matrix(s).cholesky() {
            let du = c.solve(&rhs);
            s.ball_rate += Vector3::new(du[0], du[1], du[2]);
            s.body_rate += Vector3::new(du[3], du[4], du[5]);
        }
    }

    /// Tilt of the body: angle between its z axis and the vertical, rad.
    pub fn tilt(&self, s: &BallbotState) -> f64 {
        (s.orientation * Vector3::z()).z.clamp(-1.0, 1.0).acos()
    }

    /// What the controller measures, noise-free: tilts and rates from the orientation and the
    /// body-frame gyro (as the AHRS gives them), ball position and velocity (as the odometry,
    /// corrected for the tilt, gives them).
    pub fn measurement(&self, s: &BallbotState) -> Measurement<f64> {
        let gyro = s.orientation.inverse() * s.body_rate;
        let v = self.ball_velocity(s);
        Measurement::from_attitude(&s.orientation, gyro.into(), s.position, [v.x, v.y])
    }

    /// The three planar models (paper 001) linearised about upright, in the order `Tx`
    /// (lateral), `Ty` (sagittal), `Tz` (yaw), in closed form (core
    /// [`omnikin::control::planar`]).
    pub fn planar_models(&self) -> [PlanarModel<f64>; 3] {
        let p = self.params.plant_params();
        Plane::ALL.map(|plane| PlanarModel::new(&p, plane))
    }

    /// Upright at rest at the origin, yaw `yaw` (rad).
    pub fn upright(&self, yaw: f64) -> BallbotState {
        BallbotState {
            position: [0.0, 0.0],
            orientation: UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw),
            ball_rate: Vector3::zeros(),
            body_rate: Vector3::zeros(),
            wheel_angles: [0.0; 3],
        }
    }
}
