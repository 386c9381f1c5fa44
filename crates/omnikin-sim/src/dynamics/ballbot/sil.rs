//! Software in the loop for a balancing ballbot: the 3D model ([`super::BallbotPlant`]) as a
//! **board** for the runtime's balance mode ([`omnikin::runtime::BalanceRuntime`]): wheel
//! torques in ([`MotorTorques`], held between cycles), encoders (wheel angles quantised to
//! [`BallbotSil::COUNTS_PER_REV`]) and an IMU out.
//!
//! The IMU sits on the body at the ball centre (the pivot): its gyro reads `R_Bᵀ ω`, its
//! accelerometer the specific force `R_Bᵀ (g e_z + a)` with `a` the ball centre's
//! acceleration over the last step; both with seeded white noise (gyro 0.005 rad/s,
//! accelerometer 0.05 m/s²). Stepping is explicit ([`BallbotSil::advance`], RK4 at ≤ 1 ms).

use omnikin::MAX_WHEELS;
use omnikin::nalgebra::Vector3;
use omnikin::runtime::hal::{EncoderAngles, Encoders, Imu, ImuSample, MotorTorques, TorqueCommand};
use omnikin::runtime::{BalanceRuntime, BalanceStatus};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::{BallbotPlant, BallbotState};

/// The simulated ballbot board (module doc).
#[derive(Clone, Debug)]
pub struct BallbotSil {
    plant: BallbotPlant,
    state: BallbotState,
    torques: [f64; 3],
    accel: Vector3<f64>,
    rng: ChaCha8Rng,
    time_us: u64,
}

impl BallbotSil {
    /// Encoder counts per wheel revolution.
    pub const COUNTS_PER_REV: f64 = 4096.0;

    /// A board for `plant` starting in `state`, its sensor noise seeded with `seed`.
    pub fn new(plant: BallbotPlant, state: BallbotState, seed: u64) -> Self {
        Self {
            plant,
            state,
            torques: [0.0; 3],
            accel: Vector3::zeros(),
            rng: crate::trial_rng(seed, 0),
            time_us: 0,
        }
    }

    /// The true state.
    pub fn state(&self) -> &BallbotState {
        &self.state
    }

    /// The model.
    pub fn plant(&self) -> &BallbotPlant {
        &self.plant
    }

    /// The true tilt from the vertical, rad.
    pub fn tilt(&self) -> f64 {
        self.plant.tilt(&self.state)
    }

    /// Simulated time, µs.
    pub fn time_us(&self) -> u64 {
        self.time_us
    }

    /// One control cycle of `runtime` on this board at the board's clock: reads the encoders
    /// and the IMU (each once: the IMU's noise is drawn from the board's one generator), runs
    /// [`BalanceRuntime::cycle`], holds its torques. Does not advance time (call
    /// [`BallbotSil::advance`] with the control period).
    pub fn run_cycle(&mut self, runtime: &mut BalanceRuntime<f64>) -> BalanceStatus<f64> {
        let enc = match Encoders::read(self) {
            Ok(e) => e,
            Err(e) => match e {},
        };
        let imu = match Imu::read(self) {
            Ok(i) => i,
            Err(e) => match e {},
        };
        let now = self.time_us;
        runtime.cycle(
            now,
            &mut crate::sil::Held(enc),
            &mut crate::sil::Held(imu),
            self,
        )
    }

    /// A horizontal impulse on the body's centre of mass (world, N·s).
    pub fn push(&mut self, impulse: [f64; 2]) {
        self.plant
            .apply_impulse(&mut self.state, Vector3::new(impulse[0], impulse[1], 0.0));
    }

    /// Advances by `dt` seconds under the held torques, in RK4 steps of at most 1 ms. Once the
    /// body tilts past [`super::plan_run::FLOOR_TILT`] it lies still (the floor is not
    /// modelled).
    pub fn advance(&mut self, dt: f64) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        let n = (dt / 1e-3).ceil().max(1.0) as usize;
        let h = dt / n as f64;
        let v0 = self.plant.ball_velocity(&self.state);
        for _ in 0..n {
            if self.tilt() >= super::plan_run::FLOOR_TILT {
                self.state.ball_rate = Vector3::zeros();
                self.state.body_rate = Vector3::zeros();
                break;
            }
            self.plant
                .step(&mut self.state, self.torques, Vector3::zeros(), h);
        }
        self.accel = (self.plant.ball_velocity(&self.state) - v0) / dt;
        self.time_us += (dt * 1e6).round() as u64;
    }

    fn noise(&mut self, sigma: f64) -> f64 {
        let x: f64 = StandardNormal.sample(&mut self.rng);
        sigma * x
    }
}

impl Encoders<f64> for BallbotSil {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<EncoderAngles<f64>, Self::Error> {
        let q = core::f64::consts::TAU / Self::COUNTS_PER_REV;
        let mut wheel = [0.0; MAX_WHEELS];
        for (w, a) in wheel.iter_mut().zip(self.state.wheel_angles) {
            *w = (a / q).floor() * q;
        }
        Ok(EncoderAngles {
            wheel,
            steer: [0.0; MAX_WHEELS],
        })
    }
}

impl Imu<f64> for BallbotSil {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<Option<ImuSample<f64>>, Self::Error> {
        let inv = self.state.orientation.inverse();
        let g = inv * self.state.body_rate;
        let f = inv * (Vector3::z() * self.plant.params().gravity + self.accel);
        let mut s = ImuSample {
            gyro: [g.x, g.y, g.z],
            accel: [f.x, f.y, f.z],
        };
        for i in 0..3 {
            s.gyro[i] += self.noise(0.005);
            s.accel[i] += self.noise(0.05);
        }
        Ok(Some(s))
    }
}

impl MotorTorques<f64> for BallbotSil {
    type Error = core::convert::Infallible;
    fn set_torques(&mut self, command: &TorqueCommand<f64>) -> Result<(), Self::Error> {
        self.torques = [command.wheel[0], command.wheel[1], command.wheel[2]];
        Ok(())
    }
}
