//! Issue 40's closed-loop check: on the example cluttered map, the sphere reaches 20 seeded
//! random goals one after the other, each planned from the runtime's **estimate** with
//! `omnikin_plan::map` and followed by the robot runtime on the software-in-the-loop board
//! (the kinematic plant under the `examples/profiles/noisy.toml` disturbances — stepper
//! quantisation, ±5 % speed fluctuation, 1 % wheel-radius scatter, shell spin — the machinery
//! of `simulate`), with 10 Hz position fixes from the truth (σ 5 mm: the navigation system of
//! paper 000's autonomous mode). The simulated **truth**, not the estimate, must keep the
//! footprint (the shell, 0.15 m) off every shape at every plant step.
//!
//! The plans keep [`MARGIN`] more than the footprint: the planner's paths touch the inflated
//! obstacles exactly (their clearance is the footprint radius), so any tracking error would
//! otherwise be a touch. The test reports the smallest gap the truth left.

use omnikin::Pose2;
use omnikin::description::RobotDescription;
use omnikin::runtime::{CameraFix, Command, Config, Runtime};
use omnikin_plan::RobotModel;
use omnikin_plan::map::Map;
use omnikin_plan::map::footprint::footprint_radius;
use omnikin_plan::map::goal::{goal_heading, goal_path};
use omnikin_plan::planner::{InitialSteer, MotionLimits, OnLimit, PlanOptions, Timing, plan};
use omnikin_sim::profile::Profile;
use omnikin_sim::sil::SilPlant;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

#[path = "common/map_goals.rs"]
mod common;
use common::{CAPACITY, GOALS, MAP, MARGIN, RATE, REACHED, points, random_goal};

const PROFILE: &str = include_str!("../../../examples/profiles/noisy.toml");

#[test]
fn the_true_robot_reaches_twenty_random_goals_without_touching_an_obstacle() {
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
    let profile = Profile::from_toml_str(PROFILE, "noisy.toml").unwrap();
    let start = Pose2::new(0.5, 0.5, 0.0);
    let mut rt = Box::new(Runtime::<f64, CAPACITY>::new(robot, Config::new(RATE), start).unwrap());
    let mut board = SilPlant::new(robot, profile, 40, start);
    let mut rng = ChaCha8Rng::seed_from_u64(40);
    let noise = Normal::new(0.0, 0.005).unwrap();
    let mut smallest_gap = f64::INFINITY;
    let mut worst_miss = 0.0f64;
    let mut travelled = 0.0;
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
        let now = board.time_us();
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
            let now = board.time_us();
            board.run_cycle(&mut rt);
            if k % 10 == 0 {
                // After the cycle at `now`: a fix is never newer than the runtime's clock.
                rt.handle(Command::Heartbeat, now).unwrap();
                let truth = board.true_pose();
                rt.handle(
                    Command::Fix(CameraFix {
                        capture_us: now,
                        x: truth.x + noise.sample(&mut rng),
                        y: truth.y + noise.sample(&mut rng),
                        heading: None,
                        std_xy: 0.005,
                        std_heading: 0.01,
                    }),
                    now,
                )
                .unwrap();
            }
            board.advance(dt).unwrap();
            let truth = board.true_pose();
            let gap = map.clearance([truth.x, truth.y]) - footprint;
            assert!(
                gap > 0.0,
                "leg {leg} at t = {} s: the true robot at ({}, {}) touches a shape \
                 (clearance {} m, footprint {footprint} m)",
                k as f64 * dt,
                truth.x,
                truth.y,
                gap + footprint
            );
            smallest_gap = smallest_gap.min(gap);
        }
        let truth = board.true_pose();
        let miss = (truth.x - goal[0]).hypot(truth.y - goal[1]);
        assert!(
            miss < REACHED,
            "leg {leg}: the true robot stopped {miss} m from the goal {goal:?}"
        );
        worst_miss = worst_miss.max(miss);
    }
    eprintln!(
        "{GOALS} goals, {travelled:.1} m: smallest gap between the true footprint and a shape \
         {smallest_gap:.4} m (plans keep {MARGIN} m), worst miss at a goal {worst_miss:.4} m"
    );
}
