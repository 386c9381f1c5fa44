//! A replacement plan from [`splice_to_goal`] against the core runtime (as
//! `crates/omnikin/tests/runtime_splice.rs` drives it: an ideal board whose motors turn exactly
//! as commanded): the runtime accepts the splice, never stops before the new plan's end, its
//! reference moves continuously across the switch, and the robot ends at the new goal. The
//! same path planned from rest is refused (the velocity jump), so the start speed is what makes
//! the splice acceptable.

use omnikin::description::RobotDescription;
use omnikin::runtime::hal::{EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs};
use omnikin::runtime::{
    Command, CommandError, Config, Mode, PlanPoint, Runtime, Status, plan_reference,
};
use omnikin::{MAX_WHEELS, Pose2};
use omnikin_plan::RobotModel;
use omnikin_plan::map::Map;
use omnikin_plan::map::goal::{goal_heading, goal_path};
use omnikin_plan::planner::{
    InitialSteer, MotionLimits, OnLimit, PlanOptions, START_TOLERANCE, Timing, plan,
};
use omnikin_plan::splice::{splice_start, splice_to_goal};
use omnikin_plan::{Plan, Sample};

#[derive(Default)]
struct Board {
    wheel: [f64; MAX_WHEELS],
}

impl Encoders<f64> for Board {
    type Error = &'static str;
    fn read(&mut self) -> Result<EncoderAngles<f64>, Self::Error> {
        Ok(EncoderAngles {
            wheel: self.wheel,
            steer: [0.0; MAX_WHEELS],
        })
    }
}
impl Imu<f64> for Board {
    type Error = &'static str;
    fn read(&mut self) -> Result<Option<ImuSample<f64>>, Self::Error> {
        Ok(None)
    }
}
impl MotorOutputs<f64> for Board {
    type Error = &'static str;
    fn set_rates(&mut self, _: &MotorCommand<f64>) -> Result<(), Self::Error> {
        Ok(())
    }
}

const DT: f64 = 0.01;
const DT_US: u64 = 10_000;
/// The plan buffer: room for the running plan's rest and a replacement of up to 250 points.
const CAP: usize = 512;
/// Points per plan at most (every k-th sample, the last kept).
const MAX_POINTS: usize = 250;

struct Rig {
    rt: Runtime<f64, CAP>,
    board: Board,
    now: u64,
    log: Vec<Status<f64>>,
}

impl Rig {
    fn new(robot: &RobotModel) -> Self {
        Self {
            rt: Runtime::new(robot.model, Config::new(100.0), Pose2::default()).unwrap(),
            board: Board::default(),
            now: 0,
            log: vec![],
        }
    }
    fn cmd(&mut self, c: Command<'_, f64>) -> Result<(), CommandError> {
        self.rt.handle(c, self.now)
    }
    fn step(&mut self) -> Status<f64> {
        self.cmd(Command::Heartbeat).unwrap();
        self.rt.cycle(
            self.now,
            &mut self.board,
            &mut Board::default(),
            &mut Board::default(),
        );
        let st = self.rt.status();
        for i in 0..MAX_WHEELS {
            self.board.wheel[i] += st.motors.wheel[i] * DT;
        }
        self.now += DT_US;
        self.log.push(st);
        st
    }
    fn run_to(&mut self, t: f64) {
        while self.rt.status().plan_time < t - 1e-9 {
            self.step();
        }
    }
    fn run_out(&mut self) {
        for _ in 0..3000 {
            if self.step().mode == Mode::Idle {
                return;
            }
        }
        panic!("the robot did not come to rest");
    }
    fn upload(
        &mut self,
        id: u16,
        pts: &[PlanPoint<f64>],
        splice: bool,
    ) -> Result<(), CommandError> {
        let len = pts.len() as u16;
        self.cmd(if splice {
            Command::PlanSplice { id, len }
        } else {
            Command::PlanBegin { id, len }
        })?;
        for (k, c) in pts.chunks(8).enumerate() {
            self.cmd(Command::PlanChunk {
                id,
                offset: (k * 8) as u16,
                points: c,
            })?;
        }
        self.cmd(Command::PlanStart { id })
    }
}

/// A plan's samples as the runtime's points, every k-th (first and last kept), times as they are.
fn points(plan: &Plan) -> Vec<PlanPoint<f64>> {
    let n = plan.samples.len();
    let step = n.div_ceil(MAX_POINTS - 1).max(1);
    let mut idx: Vec<usize> = (0..n).step_by(step).collect();
    if idx.last() != Some(&(n - 1)) {
        idx.push(n - 1);
    }
    idx.iter()
        .map(|&i| {
            let s: &Sample = &plan.samples[i];
            PlanPoint {
                t: s.t,
                pose: s.pose,
                twist: s.twist,
            }
        })
        .collect()
}

fn dist(a: Pose2<f64>, b: Pose2<f64>) -> f64 {
    (a.x - b.x).hypot(a.y - b.y)
}

/// Largest change of the world velocity between consecutive points, per second.
fn plan_accel(pts: &[PlanPoint<f64>]) -> f64 {
    pts.windows(2)
        .map(|w| {
            let (a, b) = (w[0].twist, w[1].twist);
            (b.vx - a.vx).hypot(b.vy - a.vy) / (w[1].t - w[0].t)
        })
        .fold(0.0, f64::max)
}

fn setup() -> (RobotModel, Map, PlanOptions, Vec<PlanPoint<f64>>) {
    let robot =
        RobotModel::from_description(&RobotDescription::preset("sphere-omni").unwrap()).unwrap();
    let map = Map::from_toml(
        "[[keep_out]]\ncircle = [1.0, 0.05, 0.25]\n[[keep_out]]\ncircle = [1.2, 1.2, 0.2]\n",
        "test.toml",
    )
    .unwrap();
    let opts = PlanOptions {
        timing: Timing::TimeOptimal {
            limits: MotionLimits {
                max_speed: 0.4,
                max_accel: 0.5,
                ..MotionLimits::default()
            },
        },
        on_limit: OnLimit::Retime,
        rate: 100.0,
        initial_steer: InitialSteer::Aligned,
    };
    // Plan A: from the origin to (2.2, 0), around the first circle, turning to 0.8 rad.
    let way = goal_path(&map, 0.15, [0.0, 0.0], [2.2, 0.0]).unwrap();
    let law = goal_heading(Some(0.0), Some(0.8), way.smoothed.path.length()).unwrap();
    let a = plan(&way.smoothed.path, &law, &robot, &opts).unwrap();
    (robot, map, opts, points(&a.plan))
}

#[test]
fn a_replan_to_a_new_goal_is_spliced_without_a_stop() {
    let (robot, map, opts, a) = setup();
    let end_a = a.last().unwrap().t;
    let t_s = 0.45 * end_a;
    // Mid-plan, at speed and turning: the new goal is up and right, past the second circle.
    let (_, tw) = plan_reference(&a, t_s).unwrap();
    assert!(
        tw.vx.hypot(tw.vy) > 0.2 && tw.yaw_rate.abs() > 1e-3,
        "{tw:?}"
    );
    let spliced = splice_to_goal(&a, t_s, [1.9, 1.6], Some(-0.5), &map, 0.15, &robot, &opts)
        .unwrap_or_else(|e| panic!("{e}"));
    let b = points(&spliced.planned.plan);
    // The first point is the running plan's reference at t_s.
    let (pose, twist) = plan_reference(&a, t_s).unwrap();
    assert_eq!(b[0].t, t_s);
    assert_eq!((b[0].pose.x, b[0].pose.y), (pose.x, pose.y));
    assert!((b[0].pose.heading - pose.heading).abs() <= 1e-12);
    assert!((b[0].twist.vx - twist.vx).abs() <= START_TOLERANCE);
    assert!((b[0].twist.vy - twist.vy).abs() <= START_TOLERANCE);
    assert!((b[0].twist.yaw_rate - twist.yaw_rate).abs() <= START_TOLERANCE);

    let mut rig = Rig::new(&robot);
    rig.upload(1, &a, false).unwrap();
    rig.run_to(t_s - 0.5);
    rig.upload(2, &b, true).unwrap();
    rig.run_out();
    // B was followed: trajectory mode until B's end, then the robot at B's goal.
    let end = rig
        .log
        .iter()
        .position(|s| s.mode != Mode::Trajectory)
        .unwrap();
    let end_b = b.last().unwrap().t;
    assert!(
        // (B's end falls between two cycles: the last cycle before it may be 2 DT earlier.)
        rig.log[end - 1].plan_time >= end_b - 2.0 * DT - 1e-9,
        "left trajectory mode at plan time {} (B ends at {end_b})",
        rig.log[end - 1].plan_time
    );
    assert!(rig.log.iter().any(|s| s.plan.id == 2));
    let last = rig.log.last().unwrap();
    assert!(dist(last.pose, b[b.len() - 1].pose) < 2e-3, "{last:?}");
    assert!(((last.pose.x - 1.9).hypot(last.pose.y - 1.6)) < 2e-3);
    // Continuous: the reference moves at most the plans' top speed per cycle, the commanded
    // velocity changes at most by the plans' own acceleration (1 % and 0.02 m/s² for the
    // sampling), across the switch too.
    let top = a
        .iter()
        .chain(&b)
        .map(|p| p.twist.vx.hypot(p.twist.vy))
        .fold(0.0, f64::max);
    let acc = plan_accel(&a).max(plan_accel(&b));
    let mut around_switch = 0;
    for w in rig.log[..end].windows(2) {
        let step = dist(w[0].reference, w[1].reference);
        assert!(
            step <= top * DT * 1.01,
            "reference step {step} m at {}",
            w[1].plan_time
        );
        let (c0, c1) = (w[0].command, w[1].command);
        let dv = (c1.vx - c0.vx).hypot(c1.vy - c0.vy) / DT;
        assert!(
            dv <= acc * 1.01 + 0.02,
            "velocity change {dv} m/s² at {}",
            w[1].plan_time
        );
        if (w[1].plan_time - t_s).abs() < 2.0 * DT {
            around_switch += 1;
            // Moving at the switch (no stop there).
            assert!(c1.vx.hypot(c1.vy) > 0.1, "{c1:?} at {}", w[1].plan_time);
        }
    }
    assert!(around_switch > 0);
    let worst_in = |from: f64, to: f64| {
        rig.log[..end]
            .iter()
            .filter(|s| s.plan_time >= from && s.plan_time < to)
            .map(|s| (dist(s.pose, s.reference), s.plan_time))
            .fold((0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a })
    };
    println!(
        "tracking: before the switch {:?}, the first second after {:?}, later {:?}",
        worst_in(0.0, t_s),
        worst_in(t_s, t_s + 1.0),
        worst_in(t_s + 1.0, 1e9)
    );
    // At the switch the robot tracks as closely as before it; B's tight fillet (0.15 m at up
    // to 0.4 m/s, 0.7 s later) is the largest error of the run.
    let at_switch = worst_in(t_s - 0.2, t_s + 0.2).0;
    println!("tracking within 0.2 s of the switch: {at_switch:.2e} m");
    assert!(
        at_switch < 1e-3,
        "tracking error {at_switch} m at the switch"
    );
    let worst = worst_in(0.0, 1e9).0;
    println!(
        "splice at {t_s:.3} s of {end_a:.3} s at ({:.4}, {:.4}) m/s, {:.4} rad/s; lead-in \
         {:.4} m; B {:.3} s, {} points; largest reference step {:.5} m (top speed × dt {:.5}); \
         tracking error at most {worst:.2e} m",
        twist.vx,
        twist.vy,
        twist.yaw_rate,
        spliced.lead_in,
        end_b - t_s,
        b.len(),
        rig.log[..end]
            .windows(2)
            .map(|w| dist(w[0].reference, w[1].reference))
            .fold(0.0, f64::max),
        top * DT
    );
    assert!(worst < 5e-3, "tracking error {worst} m");
}

#[test]
fn the_same_path_from_rest_is_refused_by_the_runtime() {
    let (robot, map, opts, a) = setup();
    let t_s = 0.45 * a.last().unwrap().t;
    let spliced =
        splice_to_goal(&a, t_s, [1.9, 1.6], Some(-0.5), &map, 0.15, &robot, &opts).unwrap();
    let rest = plan(
        &spliced.smoothed.path,
        &spliced.heading,
        &robot,
        &PlanOptions { ..opts },
    )
    .unwrap();
    let mut b = points(&rest.plan);
    for p in &mut b {
        p.t += t_s;
    }
    let mut rig = Rig::new(&robot);
    rig.upload(1, &a, false).unwrap();
    rig.run_to(t_s - 0.5);
    let e = rig.upload(2, &b, true);
    assert!(
        matches!(
            e,
            Err(CommandError::OverLimit {
                field: "splice.vx_jump" | "splice.vy_jump",
                ..
            })
        ),
        "{e:?}"
    );
}

#[test]
fn a_splice_time_outside_the_running_plan_is_refused() {
    let (_, _, _, a) = setup();
    let end = a.last().unwrap().t;
    for t in [0.0, end, end + 1.0, f64::NAN] {
        let e = splice_start(&a, t).unwrap_err().to_string();
        assert!(e.contains("is not inside the running plan"), "{e}");
    }
}

/// The points as the link carries them (f32) and back.
fn f32_points(pts: &[PlanPoint<f64>]) -> Vec<PlanPoint<f64>> {
    let r = |v: f64| f64::from(v as f32);
    pts.iter()
        .map(|p| PlanPoint {
            t: r(p.t),
            pose: Pose2::new(r(p.pose.x), r(p.pose.y), r(p.pose.heading)),
            twist: omnikin::Twist2::new(r(p.twist.vx), r(p.twist.vy), r(p.twist.yaw_rate)),
        })
        .collect()
}

/// Splices at a tenth to nine tenths of the running plan (accelerating, cruising round the
/// circle, braking), toward goals ahead, aside and behind, with every point rounded to f32 as
/// on the wire (the operator re-plans from the rounded points the robot holds): each is
/// accepted, followed to its end without a stop, and ends at its goal.
#[test]
fn splices_from_f32_points_at_any_time_are_accepted_and_followed() {
    let (robot, map, opts, a) = setup();
    let a = f32_points(&a);
    let end_a = a.last().unwrap().t;
    let mut rows = Vec::new();
    for (frac, goal) in [
        (0.1, [1.9, 1.6]),
        (0.3, [2.2, -0.6]),
        (0.5, [0.3, 1.0]),
        (0.7, [1.9, 1.6]),
        (0.9, [0.2, -0.5]),
    ] {
        let t_s = f64::from((frac * end_a) as f32);
        let spliced = splice_to_goal(&a, t_s, goal, None, &map, 0.15, &robot, &opts)
            .unwrap_or_else(|e| panic!("at {frac}: {e}"));
        let b = f32_points(&points(&spliced.planned.plan));
        let mut rig = Rig::new(&robot);
        rig.upload(1, &a, false).unwrap();
        rig.run_to(t_s - 0.3);
        rig.upload(2, &b, true)
            .unwrap_or_else(|e| panic!("at {frac}: {e:?}"));
        rig.run_out();
        let end = rig
            .log
            .iter()
            .position(|s| s.mode != Mode::Trajectory)
            .unwrap();
        let end_b = b.last().unwrap().t;
        assert!(
            rig.log[end - 1].plan_time >= end_b - 2.0 * DT - 1e-9,
            "at {frac}: left trajectory mode at {} (B ends at {end_b})",
            rig.log[end - 1].plan_time
        );
        let last = rig.log.last().unwrap();
        let miss = (last.pose.x - goal[0]).hypot(last.pose.y - goal[1]);
        assert!(miss < 2e-3, "at {frac}: ends {miss} m from the goal");
        let (_, tw) = plan_reference(&a, t_s).unwrap();
        rows.push(format!(
            "t_s {t_s:.3} s at {:.3} m/s: lead-in {:.4} m, replacement {:.3} s, end {miss:.1e} m \
             from the goal",
            tw.vx.hypot(tw.vy),
            spliced.lead_in,
            end_b - t_s
        ));
    }
    for r in rows {
        println!("{r}");
    }
}
