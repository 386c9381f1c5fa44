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
//!
//! [`SilPlant::dynamic`] puts the sphere's shell + platform dynamics
//! ([`crate::dynamics::sphere::SphereSim`]) on the board instead (sphere-omni only): the
//! set-points are ramped over each [`SilPlant::advance`] into the stepper motors of the model,
//! the encoders read the model's wheel angles, the gyro reads the platform's angular velocity
//! in the platform frame (a tilted platform's gyro z is not the world yaw rate), the
//! accelerometer reads the **specific force** at the IMU's mounting point on the platform
//! ([`SilImu`]: the point's acceleration, with the rocking's tangential and centripetal terms,
//! minus gravity, in the platform frame), and the true pose is the shell centre with the
//! platform's heading.

use omnikin::runtime::hal::{
    Clock, EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs,
};
use omnikin::runtime::{Runtime, Status};
use omnikin::{MAX_WHEELS, Pose2, Robot, Twist2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::dynamics::sphere::{DynamicsError, SphereDynamics, SphereSim, SphereState};
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
    /// The dynamic plant, when it replaces the kinematic one ([`SilPlant::dynamic`]).
    dynamic: Option<Box<DynamicBoard>>,
    /// An obstacle: from..until (plant clock, µs) the robot and its wheels are held still.
    obstacle: Option<(u64, u64)>,
}

/// What the dynamic plant's accelerometer reads ([`SilPlant::set_imu`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SilImu {
    /// The specific force `Qᵀ (a_p + g ẑ)` at the point `offset` (m, platform frame, from the
    /// shell centre; the platform's z axis points up from its centre of mass toward the
    /// shell centre), `Q` the platform's orientation. `a_p` is the point's acceleration
    /// averaged over the last [`SilPlant::advance`] (the change of its velocity
    /// `v_C + ω × Q r` over the step, divided by the step: the model's velocities are exact,
    /// its accelerations are not part of its state), so a 100 Hz loop sees what an
    /// accelerometer averaging over its 10 ms sample reads. It includes the shell centre's
    /// acceleration and the rocking's tangential (`ω̇ × Q r`) and centripetal
    /// (`ω × (ω × Q r)`) terms. What a real accelerometer reads.
    SpecificForce {
        /// The IMU's position in the platform frame relative to the shell centre, m.
        offset: [f64; 3],
    },
    /// An idealisation no real sensor gives: the accelerometer reads gravity alone,
    /// `Qᵀ g ẑ` (the platform's tilt without any acceleration). For comparison only.
    GravityOnly,
}

impl SilImu {
    /// The default: the specific force at the platform's centre of mass, `com_depth` below
    /// the shell centre on the platform's axis (where paper 000's board and IMU sit, between
    /// the wheels; `p` the plant's dynamics).
    pub fn at_centre_of_mass(p: &SphereDynamics) -> Self {
        Self::SpecificForce {
            offset: [0.0, 0.0, -p.com_depth],
        }
    }
}

/// The sphere's dynamic model on the board, with what its last step reported.
#[derive(Clone, Debug)]
struct DynamicBoard {
    sim: SphereSim,
    /// Plan heading minus the simulator's (it unwraps from its own wrapped start yaw), rad.
    heading_offset: f64,
    /// True pose at the end of the last step.
    pose: Pose2<f64>,
    /// True robot-frame twist (shell centre velocity, platform yaw rate) of the last step.
    twist: Twist2<f64>,
    /// The accelerometer's model.
    imu: SilImu,
    /// The IMU point's acceleration over the last step, world frame, m/s².
    imu_accel: omnikin::nalgebra::Vector3<f64>,
}

impl DynamicBoard {
    fn new(params: SphereDynamics, pose: Pose2<f64>) -> Result<Self, DynamicsError> {
        let sim =
            SphereSim::with_state(params, SphereState::at_rest(pose.x, pose.y, pose.heading))?;
        let heading_offset = pose.heading - sim.state().yaw();
        let imu = SilImu::at_centre_of_mass(&params);
        Ok(Self {
            sim,
            heading_offset,
            pose,
            twist: Twist2::new(0.0, 0.0, 0.0),
            imu,
            imu_accel: omnikin::nalgebra::Vector3::zeros(),
        })
    }

    /// The world-frame velocity of the platform point `offset` (platform frame, from the shell
    /// centre), m/s: the shell centre's rolling velocity `v_C = R Ω × ẑ` plus `ω × Q r`.
    fn point_velocity(&self, offset: [f64; 3]) -> omnikin::nalgebra::Vector3<f64> {
        let st = self.sim.state();
        let r = self.sim.params().geometry.shell_radius;
        let om = st.shell_rate;
        let v_c = omnikin::nalgebra::Vector3::new(r * om.y, -r * om.x, 0.0);
        let arm = st.orientation * omnikin::nalgebra::Vector3::from(offset);
        v_c + st.platform_rate.cross(&arm)
    }

    fn step(&mut self, dt: f64, wheel: &[f64; MAX_WHEELS]) -> Result<(), DynamicsError> {
        let v0 = match self.imu {
            SilImu::SpecificForce { offset } => Some((offset, self.point_velocity(offset))),
            SilImu::GravityOnly => None,
        };
        let st = self.sim.step(dt, [wheel[0], wheel[1], wheel[2]])?;
        if let Some((offset, v0)) = v0 {
            self.imu_accel = (self.point_velocity(offset) - v0) / dt;
        }
        let heading = st.heading + self.heading_offset;
        self.pose = Pose2::new(st.centre[0], st.centre[1], heading);
        // Rolling without slip: v_C = R Ω × γ.
        let om = self.sim.state().shell_rate;
        let r = self.sim.params().geometry.shell_radius;
        let (vx, vy) = (r * om.y, -r * om.x);
        let (sn, cs) = heading.sin_cos();
        self.twist = Twist2::new(cs * vx + sn * vy, -sn * vx + cs * vy, st.yaw_rate);
        Ok(())
    }
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
            dynamic: None,
            obstacle: None,
        }
    }

    /// A board for the sphere `robot` (kind `sphere-omni`) whose plant is the shell + platform
    /// dynamic model with `params`, at rest and level at the true pose `pose`. Deterministic.
    ///
    /// # Errors
    /// [`DynamicsError::Kind`] for another kind; [`DynamicsError`] for invalid parameters.
    pub fn dynamic(
        robot: Robot<f64>,
        params: SphereDynamics,
        pose: Pose2<f64>,
    ) -> Result<Self, DynamicsError> {
        if robot.kind() != omnikin::Kind::Sphere {
            return Err(DynamicsError::Kind(robot.kind().name()));
        }
        let board = DynamicBoard::new(params, pose)?;
        let mut s = Self::new(robot, Profile::default(), 0, pose);
        s.dynamic = Some(Box::new(board));
        Ok(s)
    }

    /// Sets what the dynamic plant's accelerometer reads (default
    /// [`SilImu::at_centre_of_mass`]); no effect on the kinematic plant. The reading follows
    /// from the next [`SilPlant::advance`] on.
    pub fn set_imu(&mut self, imu: SilImu) {
        if let Some(d) = &mut self.dynamic {
            d.imu = imu;
            d.imu_accel = omnikin::nalgebra::Vector3::zeros();
        }
    }

    /// The dynamic plant's accelerometer model.
    pub fn imu(&self) -> Option<SilImu> {
        self.dynamic.as_deref().map(|d| d.imu)
    }

    /// Whether the plant is the dynamic model ([`SilPlant::dynamic`]).
    pub fn is_dynamic(&self) -> bool {
        self.dynamic.is_some()
    }

    /// The dynamic model's state and counters, with the dynamic plant.
    pub fn dynamics(&self) -> Option<&SphereSim> {
        self.dynamic.as_deref().map(|d| &d.sim)
    }

    /// The true pose (world; m, m, rad unwrapped).
    pub fn true_pose(&self) -> Pose2<f64> {
        match &self.dynamic {
            Some(d) => d.pose,
            None => self.plant.pose(),
        }
    }

    /// The true robot-frame twist of the last plant step.
    pub fn true_twist(&self) -> Twist2<f64> {
        match &self.dynamic {
            Some(d) => d.twist,
            None => self.plant.twist(),
        }
    }

    /// The true kinematic plant: pose, twist, steer angles, slip residual. With the dynamic
    /// plant this is the kinematic plant at its start pose, not stepped (see
    /// [`SilPlant::dynamics`]).
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
        runtime.cycle(now, &mut Held(enc), &mut Held(imu), self);
        runtime.status()
    }

    /// Puts an obstacle in the robot's way from `from_s` for `for_s` seconds of plant time
    /// (kinematic plant only; the dynamic plant ignores it): the robot stops dead and its
    /// wheels are blocked — the motors stall, the encoders stop, the gyro reads zero — then
    /// it drives on. What a collision looks like to the runtime's event detector
    /// ([`omnikin::estimate::events`]). Non-finite or negative times: no obstacle.
    pub fn set_obstacle(&mut self, from_s: f64, for_s: f64) {
        let us = |s: f64| (s * 1e6).round() as u64;
        self.obstacle = (from_s.is_finite() && for_s.is_finite() && from_s >= 0.0 && for_s > 0.0)
            .then(|| (us(from_s), us(from_s) + us(for_s)));
    }

    /// Pushes the robot: adds `delta` (world frame, m, m, rad) to the true pose (a kick the
    /// odometry cannot see). With the dynamic plant the robot is set down at rest, level, at
    /// the pushed pose, its motors holding 0 rad/s until the next command.
    pub fn push(&mut self, delta: Pose2<f64>) {
        self.plant.push(delta);
        if let Some(d) = &mut self.dynamic {
            let p = d.pose;
            let to = Pose2::new(p.x + delta.x, p.y + delta.y, p.heading + delta.heading);
            let mut state = SphereState::at_rest(to.x, to.y, to.heading);
            state.t = d.sim.state().t;
            state.wheel_angles = d.sim.state().wheel_angles;
            if let Ok(sim) = SphereSim::with_state(*d.sim.params(), state) {
                d.heading_offset = to.heading - sim.state().yaw();
                d.sim = sim;
                d.pose = to;
                d.twist = Twist2::new(0.0, 0.0, 0.0);
            }
        }
    }

    /// Advances the plant by `dt` seconds under the current motor command, in sub-steps of
    /// the profile's plant rate (1 kHz by default).
    ///
    /// # Errors
    /// [`SimError::Kinematics`] if the forward kinematics reject a state (diverged motion);
    /// [`SimError::Mismatch`] with the dynamic model's error (a diverging state).
    pub fn advance(&mut self, dt: f64) -> Result<(), SimError> {
        if let Some(d) = &mut self.dynamic {
            // The model ramps to the set-points over the step in ≤ 1 ms sub-steps of its own.
            if dt > 0.0 {
                d.step(dt, &self.command.wheel)
                    .map_err(|e| SimError::Mismatch(format!("dynamic plant: {e}")))?;
            }
            self.time_us += (dt * 1e6).round() as u64;
            return Ok(());
        }
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
        if let Some((from, until)) = self.obstacle
            && (from as f64 * 1e-6..until as f64 * 1e-6).contains(&t)
        {
            self.plant.hold();
            return Ok(());
        }
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
pub(crate) struct Held<R>(pub(crate) R);

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
        if let Some(d) = &self.dynamic {
            let mut wheel = [0.0; MAX_WHEELS];
            wheel[..3].copy_from_slice(&d.sim.state().wheel_angles);
            return Ok(EncoderAngles {
                wheel,
                steer: [0.0; MAX_WHEELS],
            });
        }
        Ok(EncoderAngles {
            wheel: self.motors.wheel_angles(),
            steer: self.plant.steer_angles(),
        })
    }
}

impl Imu<f64> for SilPlant {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<Option<ImuSample<f64>>, Self::Error> {
        if let Some(d) = &self.dynamic {
            let st = d.sim.state();
            let w = st.orientation.inverse() * st.platform_rate;
            let a = match d.imu {
                SilImu::SpecificForce { .. } => d.imu_accel,
                SilImu::GravityOnly => omnikin::nalgebra::Vector3::zeros(),
            };
            let g = st.orientation.inverse()
                * (a + omnikin::nalgebra::Vector3::new(0.0, 0.0, d.sim.params().gravity));
            return Ok(Some(ImuSample {
                gyro: [w.x, w.y, w.z],
                accel: [g.x, g.y, g.z],
            }));
        }
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

    /// The runtime drives the dynamic sphere: it moves as commanded, the odometry (wheel
    /// angles through the kinematic model) stays near the truth at a slow speed, the
    /// platform leans while accelerating, and other kinds are refused.
    #[test]
    fn runtime_drives_the_dynamic_sphere() {
        let robot = Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap());
        let params = SphereDynamics::paper_000();
        let mut plant = SilPlant::dynamic(robot, params, Pose2::default()).unwrap();
        assert!(plant.is_dynamic());
        let mut rt = Runtime::<f64, 16>::new(robot, Config::new(100.0), Pose2::default()).unwrap();
        rt.handle(
            Command::Velocity {
                twist: Twist2::new(0.05, 0.0, 0.0),
                frame: Frame::Robot,
            },
            0,
        )
        .unwrap();
        let mut tilt = 0.0f64;
        for _ in 0..200 {
            rt.handle(Command::Heartbeat, plant.now_us()).unwrap();
            plant.run_cycle(&mut rt);
            plant.advance(0.01).unwrap();
            tilt = tilt.max(plant.dynamics().unwrap().state().tilt());
        }
        let est = plant.run_cycle(&mut rt).pose;
        let truth = plant.true_pose();
        assert_eq!(plant.time_us(), 2_000_000);
        assert!(truth.x > 0.07 && truth.x < 0.11, "{truth:?}");
        let err = (est.x - truth.x).hypot(est.y - truth.y);
        assert!(
            err < 0.02 * truth.x.max(0.5) + 0.005,
            "{est:?} vs {truth:?}"
        );
        assert!(
            tilt > 1e-3,
            "the platform must lean while accelerating: {tilt}"
        );
        // The shell rolls forward, rocking about the commanded speed; no turn, no side slip.
        let tw = plant.true_twist();
        assert!(tw.vx > 0.0 && tw.vx < 0.1, "{tw:?}");
        assert!(tw.vy.abs() < 1e-9 && tw.yaw_rate.abs() < 1e-9, "{tw:?}");
        let kiwi = omnikin::description::RobotDescription::preset("kiwi")
            .unwrap()
            .build::<f64>()
            .unwrap();
        assert!(matches!(
            SilPlant::dynamic(kiwi, params, Pose2::default()),
            Err(DynamicsError::Kind(_))
        ));
    }
}
