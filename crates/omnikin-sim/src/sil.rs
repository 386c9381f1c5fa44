//! Software in the loop: the simulated robot as a **board** for the robot runtime.
//!
//! [`SilPlant`] implements the hardware traits of [`omnikin::runtime::hal`] — encoders, IMU,
//! motor outputs and clock — on top of the same motor models and disturbances as
//! [`crate::simulate_trial`] (a [`Profile`]): the runtime's motor set-points go through the
//! motor models (lag, acceleration limit, stepper quantisation, speed fluctuation), the
//! per-trial wheel-radius errors, roller hand-over, shell spin and floor slip, then the forward
//! kinematics and the exact SE(2) step move the **true** pose. The encoders read the motors'
//! output angles (what a real encoder sees: radius errors and floor slip are invisible to
//! them), the gyro reads the true yaw rate. Stepping is explicit ([`SilPlant::advance`]), so
//! the same plant runs in real time (the `omnikin robot --sim` command sleeps between steps),
//! faster than real time in tests, or in lock-step.

use omnikin::caster::CasterRates;
use omnikin::runtime::hal::{
    Clock, EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs,
};
use omnikin::runtime::{Runtime, Status};
use omnikin::{Pose2, Robot, Twist2, se2};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::motor::Motor;
use crate::plant::SimError;
use crate::profile::Profile;

/// The simulated robot: true state, motors and disturbances. Implements
/// [`Encoders`], [`Imu`], [`MotorOutputs`] and [`Clock`].
#[derive(Clone, Debug)]
pub struct SilPlant {
    robot: Robot<f64>,
    profile: Profile,
    rng: ChaCha8Rng,
    wheels: [Motor; 3],
    steer_motors: [Motor; 3],
    steer: [f64; 3],
    command: MotorCommand<f64>,
    pose: Pose2<f64>,
    twist: Twist2<f64>,
    time_us: u64,
    /// Sub-step remainder, s (advance() may be called with any dt).
    carry: f64,
    radius_scale: [f64; 3],
    const_spin: f64,
    roller_phase: [f64; 3],
    floor: [f64; 3],
    slip_residual: f64,
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

impl SilPlant {
    /// A plant for `robot` at rest at the true pose `pose` (world), with the disturbances of
    /// `profile` drawn from a ChaCha8 stream seeded with `seed` (reproducible).
    pub fn new(robot: Robot<f64>, profile: Profile, seed: u64, pose: Pose2<f64>) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let wm = profile.wheel_motor;
        let radius_scale =
            core::array::from_fn(|_| 1.0 + wm.radius_error_std.unwrap_or(0.0) * gauss(&mut rng));
        let const_spin = profile.shell_spin.std.unwrap_or(0.0) * gauss(&mut rng);
        let roller_phase = core::array::from_fn(|_| rng.random_range(0.0..core::f64::consts::TAU));
        let floor_std = profile.floor.rel_std.unwrap_or(0.0);
        let floor = if floor_std > 0.0 {
            core::array::from_fn(|_| floor_std * gauss(&mut rng))
        } else {
            [0.0; 3]
        };
        Self {
            robot,
            profile,
            rng,
            wheels: core::array::from_fn(|_| Motor::new(wm, 0.0)),
            steer_motors: core::array::from_fn(|_| Motor::new(profile.steer_motor, 0.0)),
            steer: [0.0; 3],
            command: MotorCommand::zero(),
            pose,
            twist: Twist2::default(),
            time_us: 0,
            carry: 0.0,
            radius_scale,
            const_spin,
            roller_phase,
            floor,
            slip_residual: 0.0,
        }
    }

    /// The true pose (world; m, m, rad unwrapped).
    pub fn true_pose(&self) -> Pose2<f64> {
        self.pose
    }

    /// The true robot-frame twist of the last plant step.
    pub fn true_twist(&self) -> Twist2<f64> {
        self.twist
    }

    /// Simulated time, µs.
    pub fn time_us(&self) -> u64 {
        self.time_us
    }

    /// The motor command being applied.
    pub fn command(&self) -> MotorCommand<f64> {
        self.command
    }

    /// One control cycle of `runtime` on this board at the plant's clock: reads the encoders
    /// and the gyro, runs [`Runtime::cycle`], applies the motor set-points. Does not advance
    /// time (call [`SilPlant::advance`] with the control period).
    pub fn run_cycle<const N: usize>(&mut self, runtime: &mut Runtime<f64, N>) -> Status<f64> {
        let now = self.time_us;
        let enc = match Encoders::read(self) {
            Ok(e) => e,
            Err(e) => match e {},
        };
        let imu = match Imu::read(self) {
            Ok(i) => i,
            Err(e) => match e {},
        };
        runtime.cycle(now, &mut Held(enc), &mut Held(imu), self)
    }

    /// Pushes the robot: adds `delta` (world frame, m, m, rad) to the true pose (a kick the
    /// odometry cannot see).
    pub fn push(&mut self, delta: Pose2<f64>) {
        self.pose = Pose2::new(
            self.pose.x + delta.x,
            self.pose.y + delta.y,
            self.pose.heading + delta.heading,
        );
    }

    /// Advances the plant by `dt` seconds under the current motor command, in sub-steps of
    /// the profile's plant rate (1 kHz by default).
    ///
    /// # Errors
    /// [`SimError::Kinematics`] if the forward kinematics reject a state (diverged motion).
    pub fn advance(&mut self, dt: f64) -> Result<(), SimError> {
        let h = 1.0 / self.profile.rate_hz();
        self.carry += dt;
        let start_us = self.time_us;
        let mut elapsed = 0.0;
        while self.carry >= h * (1.0 - 1e-9) {
            self.substep(h, start_us as f64 * 1e-6 + elapsed)?;
            self.carry -= h;
            elapsed += h;
        }
        // Time advances by exactly `dt` (rounded to µs), whatever the sub-steps did.
        self.time_us = start_us + (dt * 1e6).round() as u64;
        Ok(())
    }

    fn substep(&mut self, dt: f64, t: f64) -> Result<(), SimError> {
        let p = &self.profile;
        let roller_amp = p.roller.amplitude.unwrap_or(0.0);
        let rollers = p.roller.rollers.unwrap_or(8) as f64;
        let mut w = [0.0; 3];
        for i in 0..3 {
            let q0 = self.wheels[i].angle();
            let dq = self.wheels[i].step(self.command.wheel[i], dt, &mut self.rng);
            let mut eff = dq / dt * self.radius_scale[i];
            if roller_amp > 0.0 {
                eff *= 1.0 + roller_amp * (rollers * (q0 + 0.5 * dq) + self.roller_phase[i]).cos();
            }
            w[i] = eff;
        }
        let kin = |source| SimError::Kinematics { t, source };
        let mut twist = match &self.robot {
            Robot::Sphere(m) => {
                let tw0 = m.body_twist(w, 0.0).map_err(kin)?;
                let speed = tw0.vx.hypot(tw0.vy);
                let g = p.shell_spin.slip_gain.unwrap_or(0.0);
                let e = p.shell_spin.slip_exponent.unwrap_or(1.0);
                let spin = self.const_spin + g * speed.powf(e) * (-tw0.yaw_rate);
                Twist2::new(tw0.vx, tw0.vy, tw0.yaw_rate + spin)
            }
            Robot::Ballbot(m) => m.body_twist(w, self.const_spin).map_err(kin)?,
            Robot::Caster(m) => {
                let mut sd = [0.0; 3];
                let mut next = self.steer;
                for i in 0..3 {
                    let d = self.steer_motors[i].step(self.command.steer[i], dt, &mut self.rng);
                    sd[i] = d / dt;
                    next[i] += d;
                }
                let mid: [f64; 3] = core::array::from_fn(|i| 0.5 * (self.steer[i] + next[i]));
                let fwd = m
                    .body_twist(&CasterRates { roll: w, steer: sd }, self.pose.heading, mid)
                    .map_err(kin)?;
                self.slip_residual = fwd.slip_residual;
                self.steer = next;
                fwd.twist.to_robot(self.pose.heading)
            }
            _ => {
                return Err(kin(omnikin::InputError::Singular {
                    reason: "this robot kind is not simulated yet",
                }));
            }
        };
        let floor_std = p.floor.rel_std.unwrap_or(0.0);
        if floor_std > 0.0 {
            let tau = p.floor.corr_time.unwrap_or(0.5);
            let decay = (-dt / tau).exp();
            let kick = floor_std * (1.0 - decay * decay).sqrt();
            for e in self.floor.iter_mut() {
                *e = *e * decay + kick * gauss(&mut self.rng);
            }
            twist = Twist2::new(
                twist.vx * (1.0 + self.floor[0]),
                twist.vy * (1.0 + self.floor[1]),
                twist.yaw_rate * (1.0 + self.floor[2]),
            );
        }
        self.twist = twist;
        self.pose = se2::integrate(self.pose, twist, dt);
        Ok(())
    }
}

/// A sensor reading taken before the cycle (so the plant can be the motor board at the same
/// time).
struct Held<R>(R);

impl Encoders<f64> for Held<EncoderAngles<f64>> {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<EncoderAngles<f64>, Self::Error> {
        Ok(self.0)
    }
}

impl Imu<f64> for Held<Option<ImuSample<f64>>> {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<Option<ImuSample<f64>>, Self::Error> {
        Ok(self.0)
    }
}

impl Encoders<f64> for SilPlant {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<EncoderAngles<f64>, Self::Error> {
        Ok(EncoderAngles {
            wheel: core::array::from_fn(|i| self.wheels[i].angle()),
            steer: self.steer,
        })
    }
}

impl Imu<f64> for SilPlant {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<Option<ImuSample<f64>>, Self::Error> {
        Ok(Some(ImuSample {
            gyro: [0.0, 0.0, self.twist.yaw_rate],
            accel: [0.0, 0.0, 9.81],
        }))
    }
}

impl MotorOutputs<f64> for SilPlant {
    type Error = core::convert::Infallible;
    fn set_rates(&mut self, command: &MotorCommand<f64>) -> Result<(), Self::Error> {
        self.command = *command;
        Ok(())
    }
}

impl Clock for SilPlant {
    fn now_us(&mut self) -> u64 {
        self.time_us
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use omnikin::runtime::{Command, Config, Frame, Runtime};
    use omnikin::sphere::{SphereOmni, SphereParams};

    #[test]
    fn runtime_drives_the_ideal_plant_exactly() {
        let robot = Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap());
        let mut plant = SilPlant::new(robot, Profile::default(), 1, Pose2::default());
        let mut rt = Runtime::<f64, 16>::new(robot, Config::new(100.0), Pose2::default()).unwrap();
        rt.handle(
            Command::Velocity {
                twist: Twist2::new(0.1, 0.05, 0.2),
                frame: Frame::Robot,
            },
            0,
        )
        .unwrap();
        for _ in 0..40 {
            rt.handle(Command::Heartbeat, plant.now_us()).unwrap();
            plant.run_cycle(&mut rt);
            plant.advance(0.01).unwrap();
        }
        // One more cycle reads the encoders at the final time.
        let est = plant.run_cycle(&mut rt).pose;
        let truth = plant.true_pose();
        assert!(
            (est.x - truth.x).abs() < 1e-9 && (est.y - truth.y).abs() < 1e-9,
            "{est:?} {truth:?}"
        );
        assert!(truth.x > 0.02);
        assert_eq!(plant.time_us(), 400_000);
    }
}
