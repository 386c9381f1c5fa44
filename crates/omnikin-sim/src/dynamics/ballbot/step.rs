//! The ballbot's fixed-step integration: [`BallbotPlant::step`], classical RK4 on the packed
//! 15-element state with a renormalised orientation quaternion.

use omnikin::nalgebra::{Quaternion, SVector, UnitQuaternion, Vector3};

use super::model::BallbotPlant;
use super::state::BallbotState;

type Vec15 = SVector<f64, 15>;

fn pack(s: &BallbotState) -> Vec15 {
    let q = s.orientation.quaternion();
    let mut v = Vec15::zeros();
    v[0] = s.position[0];
    v[1] = s.position[1];
    v[2] = q.w;
    v[3] = q.i;
    v[4] = q.j;
    v[5] = q.k;
    v.fixed_rows_mut::<3>(6).copy_from(&s.ball_rate);
    v.fixed_rows_mut::<3>(9).copy_from(&s.body_rate);
    v[12] = s.wheel_angles[0];
    v[13] = s.wheel_angles[1];
    v[14] = s.wheel_angles[2];
    v
}

fn unpack(v: &Vec15) -> BallbotState {
    BallbotState {
        position: [v[0], v[1]],
        orientation: UnitQuaternion::from_quaternion(Quaternion::new(v[2], v[3], v[4], v[5])),
        ball_rate: v.fixed_rows::<3>(6).into_owned(),
        body_rate: v.fixed_rows::<3>(9).into_owned(),
        wheel_angles: [v[12], v[13], v[14]],
    }
}

impl BallbotPlant {
    /// Time derivative of the packed state (`ẋ, ẏ = P Ω`, `q̇ = ½ (0, ω) ⊗ q`, the
    /// accelerations, the wheel rates).
    fn derivative(
        &self,
        s: &BallbotState,
        q_raw: &Quaternion<f64>,
        torques: [f64; 3],
        force: Vector3<f64>,
    ) -> Vec15 {
        let v = self.ball_velocity(s);
        let qd = Quaternion::from_imag(s.body_rate) * q_raw * 0.5;
        let (dom, dw) = self.accelerations(s, torques, force);
        let psi = self.wheel_rates(s);
        let mut d = Vec15::zeros();
        d[0] = v.x;
        d[1] = v.y;
        d[2] = qd.w;
        d[3] = qd.i;
        d[4] = qd.j;
        d[5] = qd.k;
        d.fixed_rows_mut::<3>(6).copy_from(&dom);
        d.fixed_rows_mut::<3>(9).copy_from(&dw);
        d[12] = psi[0];
        d[13] = psi[1];
        d[14] = psi[2];
        d
    }

    /// Advances `s` by `dt` seconds (classical RK4) with constant wheel torques (N·m) and a
    /// constant force on the body's centre of mass (N, world frame). The quaternion is
    /// renormalised after the step.
    pub fn step(
        &self,
        s: &mut BallbotState,
        wheel_torques: [f64; 3],
        force: Vector3<f64>,
        dt: f64,
    ) {
        let x0 = pack(s);
        let eval = |x: &Vec15| {
            let st = unpack(x);
            let q_raw = Quaternion::new(x[2], x[3], x[4], x[5]);
            self.derivative(&st, &q_raw, wheel_torques, force)
        };
        let k1 = eval(&x0);
        let k2 = eval(&(x0 + k1 * (0.5 * dt)));
        let k3 = eval(&(x0 + k2 * (0.5 * dt)));
        let k4 = eval(&(x0 + k3 * dt));
        let x1 = x0 + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0);
        *s = unpack(&x1);
    }
}
