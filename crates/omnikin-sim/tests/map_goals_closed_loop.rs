//! Issue 40's closed-loop check with the sphere's **dynamic** plant: the twenty seeded random
//! goals of `map_goals.rs` (the same cluttered map, the same goal draws, the same planner
//! options and margin), each planned from the runtime's **estimate** and followed by the core
//! runtime in closed loop on the shell + platform plant ([`SilPlant::dynamic`]) with its tilt
//! feedback and lean feed-forward, as `simulate --closed-loop` runs it — the runtime
//! configured by [`closed_loop::config`] and [`closed_loop::tilt_feedback`] (their public
//! API only), fed the fixes of paper 000's overhead camera (25 frames/s, 40 ms latency, σ 2 mm,
//! taken of the tracked point), the robot drawn once with [`DynamicProfile::hardware`]'s
//! variation (1 % wheel radius, 1 % speed fluctuation per cycle, 3 % centre-of-mass depth,
//! 20 % pivot friction). The legs follow one another: the robot is never reset, and each plan
//! starts from where the runtime believes it is.
//!
//! The simulated **truth** (the shell's centre; the footprint is the shell's radius) must keep
//! off every shape at every control cycle. The test prints the smallest gap it left and the
//! largest tilt. Measured (seed as here): 122.0 m over the 20 legs, smallest gap 0.0450 m
//! (the plans keep 0.05 m), worst miss at a goal 6.5 mm, largest estimate error 11.2 mm,
//! largest tilt 6.05°.
//!
//! The simulated IMU's accelerometer reads the specific force at the platform's centre of mass
//! ([`SilPlant`]'s default), and the runtime feeds back its tilt estimate (docs/closed-loop.md).

use omnikin::Pose2;
use omnikin::description::RobotDescription;
use omnikin::runtime::hal::{EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs};
use omnikin::runtime::{CameraFix, Command, Runtime};
use omnikin_plan::RobotModel;
use omnikin_plan::map::Map;
use omnikin_plan::map::footprint::footprint_radius;
use omnikin_plan::map::goal::{goal_heading, goal_path};
use omnikin_plan::planner::{InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing, plan};
use omnikin_sim::camera::Camera;
use omnikin_sim::closed_loop;
use omnikin_sim::dynamics::sphere::{DynamicProfile, SphereDynamics};
use omnikin_sim::sensors::{CameraGaps, CameraProfile};
use omnikin_sim::sil::SilPlant;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

#[path = "common/map_goals.rs"]
mod common;
use common::{CAPACITY, GOALS, MAP, MARGIN, RATE, REACHED, points, random_goal};

/// The motor board: the runtime's set-points scaled by the drawn wheel errors (the rate error
/// the encoders see, as the closed loop's trials apply it).
struct Scaled<'a> {
    plant: &'a mut SilPlant,
    scale: [f64; 3],
}

impl MotorOutputs<f64> for Scaled<'_> {
    type Error = core::convert::Infallible;
    fn set_rates(&mut self, c: &MotorCommand<f64>) -> Result<(), Self::Error> {
        let mut c = *c;
        for (w, k) in c.wheel.iter_mut().zip(self.scale) {
            *w *= k;
        }
        self.plant.set_rates(&c)
    }
}

/// A sensor reading taken before the cycle, so that the plant can be the motor board.
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

#[test]
fn the_dynamic_sphere_in_closed_loop_reaches_twenty_random_goals_without_touching_an_obstacle() {
    let desc = RobotDescription::preset("sphere-omni").unwrap();
    let (footprint, _) = footprint_radius(&desc);
    let planned_f = footprint + MARGIN;
    let model = RobotModel::from_description(&desc).unwrap();
    let opts = PlanOptions {
        timing: Timing::TimeOptimal {
            limits: MotionLimits {
                max_speed: 0.3,
                max_accel: 0.5,
                max_jerk: 5.0,
                max_yaw_rate: 1.0,
                max_yaw_accel: 2.0,
            },
        },
        on_limit: OnLimit::Retime,
        rate: 20.0,
        initial_steer: InitialSteer::Aligned,
    };
    let map = Map::from_toml(MAP, "cluttered.toml").unwrap();
    let robot = desc.build::<f64>().unwrap();
    let body = desc.body_limits();
    let mut config = closed_loop::config(
        RATE,
        desc.limits.max_wheel_rate,
        desc.limits.max_wheel_accel,
        body.max_accel,
        body.max_yaw_accel,
    );
    let nominal = SphereDynamics::from_description(&desc).unwrap();
    let profile = DynamicProfile::hardware(nominal);
    let mut draws = ChaCha8Rng::seed_from_u64(4040);
    let (params, radius_scale) = profile.draw_robot(&mut draws);
    // The runtime's feedback is designed from the nominal robot, not the drawn one.
    config.tilt = Some(closed_loop::tilt_feedback(&nominal));
    let start = Pose2::new(0.5, 0.5, 0.0);
    let mut rt = Box::new(Runtime::<f64, CAPACITY>::new(robot, config, start).unwrap());
    let mut plant = SilPlant::dynamic(robot, params, start).unwrap();
    let mut camera = Camera::new(
        CameraProfile::paper_000(),
        CameraGaps::default(),
        ChaCha8Rng::seed_from_u64(4041),
    )
    .unwrap();
    let zt = params.tracked_height - params.geometry.shell_radius;
    // The goals are `map_goals.rs`'s draws (its seed), so both plants cross the same room.
    let mut rng = ChaCha8Rng::seed_from_u64(40);
    let (mut smallest_gap, mut worst_miss, mut max_tilt) = (f64::INFINITY, 0.0f64, 0.0f64);
    let (mut travelled, mut worst_estimate) = (0.0, 0.0f64);
    let dt = 1.0 / RATE;
    for leg in 0..GOALS {
        let est = rt.pose();
        let from = [est.x, est.y];
        let goal = random_goal(&mut rng, &map, planned_f, from);
        let path = goal_path(&map, planned_f, from, goal)
            .unwrap_or_else(|e| panic!("leg {leg}: {from:?} to {goal:?}: {e}"));
        let len = path.smoothed.path.length();
        travelled += len;
        let heading = goal_heading(Some(est.heading), None, len).unwrap();
        let p = plan(&path.smoothed.path, &heading, &model, &opts)
            .unwrap()
            .plan;
        let pts = points(&p);
        let id = leg as u16;
        let now = plant.time_us();
        rt.handle(
            Command::PlanBegin {
                id,
                len: pts.len() as u16,
            },
            now,
        )
        .unwrap();
        for (k, c) in pts.chunks(8).enumerate() {
            rt.handle(
                Command::PlanChunk {
                    id,
                    offset: (k * 8) as u16,
                    points: c,
                },
                now,
            )
            .unwrap();
        }
        rt.handle(Command::PlanStart { id }, now).unwrap();
        // The plan's duration and 3 s to settle.
        let cycles = ((p.samples.last().unwrap().t + 3.0) * RATE).ceil() as usize;
        for k in 0..cycles {
            let now = plant.time_us();
            let t = now as f64 * 1e-6;
            let st = plant.dynamics().unwrap().state();
            let kz = st.platform_z();
            let truth = plant.true_pose();
            rt.handle(Command::Heartbeat, now).unwrap();
            camera.capture(
                t,
                st.centre[0] + zt * kz.x,
                st.centre[1] + zt * kz.y,
                truth.heading,
            );
            while let Some(f) = camera.deliver(t) {
                // A fix beyond the runtime's gate is refused and counted: not an error here.
                let _ = rt.handle(
                    Command::Fix(CameraFix {
                        capture_us: (f.t * 1e6).round() as u64,
                        x: f.x,
                        y: f.y,
                        heading: None,
                        std_xy: camera.profile().noise_std,
                        std_heading: 1.0,
                    }),
                    now,
                );
            }
            let Ok(enc) = Encoders::read(&mut plant);
            let Ok(imu) = Imu::read(&mut plant);
            let mut scale = radius_scale;
            for s in scale.iter_mut() {
                let n: f64 = StandardNormal.sample(&mut draws);
                *s *= 1.0 + profile.fluctuation_rel * n;
            }
            rt.cycle(
                now,
                &mut Held(enc),
                &mut Held(imu),
                &mut Scaled {
                    plant: &mut plant,
                    scale,
                },
            );
            plant
                .advance(dt)
                .unwrap_or_else(|e| panic!("leg {leg} at t = {t} s: {e}"));
            let truth = plant.true_pose();
            let gap = map.clearance([truth.x, truth.y]) - footprint;
            assert!(
                gap > 0.0,
                "leg {leg} at {} s into it: the true sphere at ({}, {}) touches a shape \
                 (clearance {} m, footprint {footprint} m)",
                k as f64 * dt,
                truth.x,
                truth.y,
                gap + footprint
            );
            smallest_gap = smallest_gap.min(gap);
            max_tilt = max_tilt.max(plant.dynamics().unwrap().state().tilt());
            let e = rt.pose();
            worst_estimate = worst_estimate.max((e.x - truth.x).hypot(e.y - truth.y));
        }
        let truth = plant.true_pose();
        let miss = (truth.x - goal[0]).hypot(truth.y - goal[1]);
        eprintln!(
            "leg {leg}: {len:.2} m to ({:.2}, {:.2}), stopped {miss:.4} m from it",
            goal[0], goal[1]
        );
        assert!(
            miss < REACHED,
            "leg {leg}: the true sphere stopped {miss} m from the goal {goal:?}"
        );
        worst_miss = worst_miss.max(miss);
    }
    eprintln!(
        "{GOALS} goals, {travelled:.1} m on the dynamic plant in closed loop: smallest gap \
         between the true footprint and a shape {smallest_gap:.4} m (plans keep {MARGIN} m), \
         worst miss at a goal {worst_miss:.4} m, largest estimate error {worst_estimate:.4} m, \
         largest tilt {:.2}°",
        max_tilt.to_degrees()
    );
}
