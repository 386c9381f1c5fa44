//! Software in the loop: the simulated robot as a **board** for the robot runtime.
//!
//! [`SilPlant`] implements the hardware traits of [`omnikin::runtime::hal`] — encoders, IMU,
//! motor outputs and clock — on top of the same plant step as [`crate::simulate_trial`]
//! ([`crate::plant_step`], under a [`Profile`]): the runtime's motor set-points, held between
//! cycles, go through the motor models (lag, acceleration limit, stepper quantisation, speed
//! fluctuation), then [`Plant::step`] (wheel-radius errors, roller hand-over, forward
//! kinematics with the shell/ball spin law, floor slip, exact SE(2) step) moves the **true**
//! pose; for the same set-points and seed the true trajectory is the simulator's. The plant
//! starts at rest (motors at 0 rad/s, caster steer angles 0). The encoders read the motors'
//! output angles (what a real encoder sees: radius errors and floor slip are invisible to
//! them), the gyro reads the true yaw rate. Stepping is explicit ([`SilPlant::advance`]), so
//! the same plant runs in real time (the `omnikin robot --sim` command sleeps between steps),
//! faster than real time in tests, or in lock-step.

use omnikin::runtime::hal::{
    Clock, EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs,
};
use omnikin::runtime::{Runtime, Status};
use omnikin::{MAX_WHEELS, Pose2, Robot, Twist2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::plant::SimError;
use crate::plant_step::{Motors, Plant};
use crate::profile::Profile;

/// The simulated robot: true state, motors and disturbances. Implements
/// [`Encoders`], [`Imu`], [`MotorOutputs`] and [`Clock`].
#[derive(Clone, Debug)]
pub struct SilPlant {
    profile: Profile,
    rng: ChaCha8Rng,
    motors: Motors,
    plant: Plant,
    command: MotorCommand<f64>,
    time_us: u64,
    /// Sub-step remainder, s (advance() may be called with any dt).
    carry: f64,
}

impl SilPlant {
    /// A plant for `robot` at rest at the true pose `pose` (world), with the disturbances of
    /// `profile` drawn from a ChaCha8 stream seeded with `seed` (reproducible; the same stream
    /// as [`crate::simulate_trial`] given `ChaCha8Rng::seed_from_u64(seed)`).
    pub fn new(robot: Robot<f64>, profile: Profile, seed: u64, pose: Pose2<f64>) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let plant = Plant::new(robot, &profile, pose, [0.0; MAX_WHEELS], &mut rng);
        let motors = Motors::new(&plant, &profile, [0.0; MAX_WHEELS], [0.0; MAX_WHEELS]);
        Self {
            profile,
            rng,
            motors,
            plant,
            command: MotorCommand::zero(),
            time_us: 0,
            carry: 0.0,
        }
    }

    /// The true pose (world; m, m, rad unwrapped).
    pub fn true_pose(&self) -> Pose2<f64> {
        self.plant.pose()
    }

    /// The true robot-frame twist of the last plant step.
    pub fn true_twist(&self) -> Twist2<f64> {
        self.plant.twist()
    }

    /// The true plant: pose, twist, steer angles, slip residual.
    pub fn plant(&self) -> &Plant {
        &self.plant
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
        self.plant.push(delta);
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
        let c = &self.command;
        let motion = self.motors.step(c.wheel, c.steer, dt, &mut self.rng);
        self.plant
            .step(&motion, dt, &mut self.rng)
            .map_err(|source| SimError::Kinematics { t, source })?;
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
            wheel: self.motors.wheel_angles(),
            steer: self.plant.steer_angles(),
        })
    }
}

impl Imu<f64> for SilPlant {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<Option<ImuSample<f64>>, Self::Error> {
        Ok(Some(ImuSample {
            gyro: [0.0, 0.0, self.plant.twist().yaw_rate],
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
