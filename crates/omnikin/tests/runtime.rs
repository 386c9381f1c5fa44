//! The robot runtime against an ideal board (motors turn exactly as commanded, encoders read
//! the exact angles): modes, limits, watchdog, e-stop, plan upload and tracking, faults.

use omnikin::ballbot::{Ballbot, BallbotParams};
use omnikin::caster::{Caster3, CasterParams};
use omnikin::runtime::hal::{EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs};
use omnikin::runtime::limits::motor_rates;
use omnikin::runtime::{
    Command, CommandError, Config, Faults, Frame, Mode, PlanPoint, Runtime, Status,
};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{MAX_WHEELS, Pose2, Robot, Twist2};

#[derive(Default)]
struct Board {
    wheel: [f64; MAX_WHEELS],
    steer: [f64; MAX_WHEELS],
    cmd: Option<MotorCommand<f64>>,
    /// Gyro bias added to the true yaw rate (to fake slip), rad/s.
    gyro_offset: f64,
    gyro: bool,
    fail_encoders: bool,
    true_yaw_rate: f64,
    /// The wheels are blocked (a collision): the motors no longer turn them.
    stalled: bool,
}

impl Encoders<f64> for Board {
    type Error = &'static str;
    fn read(&mut self) -> Result<EncoderAngles<f64>, Self::Error> {
        if self.fail_encoders {
            return Err("bus error");
        }
        Ok(EncoderAngles {
            wheel: self.wheel,
            steer: self.steer,
        })
    }
}
impl Imu<f64> for Board {
    type Error = &'static str;
    fn read(&mut self) -> Result<Option<ImuSample<f64>>, Self::Error> {
        Ok(self.gyro.then_some(ImuSample {
            gyro: [0.0, 0.0, self.true_yaw_rate + self.gyro_offset],
            accel: [0.0, 0.0, 9.81],
        }))
    }
}
impl MotorOutputs<f64> for Board {
    type Error = &'static str;
    fn set_rates(&mut self, c: &MotorCommand<f64>) -> Result<(), Self::Error> {
        self.cmd = Some(*c);
        Ok(())
    }
}

const DT: f64 = 0.01;
const DT_US: u64 = 10_000;

struct Rig {
    rt: Runtime<f64, 512>,
    board: Board,
    now: u64,
    log: Vec<Status<f64>>,
}

fn sphere() -> Robot<f64> {
    Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap())
}

impl Rig {
    fn new(robot: Robot<f64>, cfg: Config<f64>) -> Self {
        Self {
            rt: Runtime::new(robot, cfg, Pose2::default()).unwrap(),
            board: Board::default(),
            now: 0,
            log: vec![],
        }
    }
    fn cmd(&mut self, c: Command<'_, f64>) -> Result<(), CommandError> {
        self.rt.handle(c, self.now)
    }
    /// One cycle, then the ideal plant turns the motors for DT.
    fn step(&mut self) -> Status<f64> {
        let mut imu = Board {
            gyro: self.board.gyro,
            gyro_offset: self.board.gyro_offset,
            true_yaw_rate: self.board.true_yaw_rate,
            ..Default::default()
        };
        self.rt
            .cycle(self.now, &mut self.board, &mut imu, &mut Board::default());
        let st = self.rt.status();
        for i in 0..MAX_WHEELS {
            if !self.board.stalled {
                self.board.wheel[i] += st.motors.wheel[i] * DT;
            }
            self.board.steer[i] += st.motors.steer[i] * DT;
        }
        self.board.true_yaw_rate = st.command.yaw_rate;
        self.now += DT_US;
        self.log.push(st);
        st
    }
    fn run(&mut self, cycles: usize, heartbeat: bool) -> Status<f64> {
        let mut st = self.step();
        for _ in 1..cycles {
            if heartbeat {
                self.cmd(Command::Heartbeat).unwrap();
            }
            st = self.step();
        }
        st
    }
}

fn vel(vx: f64, vy: f64, w: f64) -> Command<'static, f64> {
    Command::Velocity {
        twist: Twist2::new(vx, vy, w),
        frame: Frame::Robot,
    }
}

#[test]
fn velocity_command_ramps_within_the_acceleration_limit_and_moves_the_pose() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    rig.cmd(vel(0.2, 0.0, 0.0)).unwrap();
    let st = rig.run(100, true);
    assert_eq!(st.mode, Mode::Velocity);
    assert!((st.command.vx - 0.2).abs() < 1e-12);
    for w in rig.log.windows(2) {
        let a = (w[1].command.vx - w[0].command.vx) / DT;
        assert!(a <= 1.0 + 1e-9, "acceleration {a}");
    }
    // 0.2 s ramp (0.02 m) then 0.8 s at 0.2 m/s; odometry lags the command by one cycle.
    let x = st.pose.x;
    assert!((x - 0.2 * 0.8 - 0.02).abs() < 0.003, "x = {x}");
    assert!(st.pose.y.abs() < 1e-9 && st.pose.heading.abs() < 1e-9);
    assert!(st.faults.is_empty(), "{:?}", st.faults);
}

#[test]
fn world_frame_command_is_turned_by_the_heading() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    rig.cmd(Command::SetPose(Pose2::new(
        0.0,
        0.0,
        core::f64::consts::FRAC_PI_2,
    )))
    .unwrap();
    rig.cmd(Command::Velocity {
        twist: Twist2::new(0.1, 0.0, 0.0),
        frame: Frame::World,
    })
    .unwrap();
    let st = rig.run(50, true);
    // World +x at heading 90° is robot −y.
    assert!((st.command.vy + 0.1).abs() < 1e-9 && st.command.vx.abs() < 1e-9);
    assert!(st.pose.x > 0.03 && st.pose.y.abs() < 1e-9);
}

#[test]
fn desaturation_keeps_direction_and_raises_limit_fault() {
    let mut cfg = Config::new(100.0);
    cfg.rate_limits.wheel = Some(12.0);
    cfg.slew.accel = 100.0;
    cfg.slew.yaw_accel = 100.0;
    let mut rig = Rig::new(sphere(), cfg);
    rig.cmd(vel(1.5, 0.5, 1.0)).unwrap();
    let st = rig.run(50, true);
    let worst = st.motors.wheel.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    assert!((worst - 12.0).abs() < 1e-9, "worst wheel {worst}");
    assert!((st.command.vx / st.command.vy - 3.0).abs() < 1e-9);
    assert!((st.command.yaw_rate / st.command.vy - 2.0).abs() < 1e-9);
    assert!(st.faults.contains(Faults::LIMIT));
    for s in &rig.log {
        assert!(s.motors.wheel.iter().all(|w| w.abs() <= 12.0 + 1e-9));
    }
}

#[test]
fn wheel_acceleration_limit_holds_between_cycles() {
    let mut cfg = Config::new(100.0);
    cfg.wheel_accel = Some(20.0);
    cfg.slew.accel = 10.0;
    let mut rig = Rig::new(sphere(), cfg);
    rig.cmd(vel(0.3, 0.0, 0.0)).unwrap();
    rig.run(100, true);
    for w in rig.log.windows(2) {
        for i in 0..3 {
            let a = (w[1].motors.wheel[i] - w[0].motors.wheel[i]) / DT;
            assert!(a.abs() <= 20.0 + 1e-6, "wheel {i}: {a} rad/s^2");
        }
    }
    assert!(rig.log.iter().any(|s| s.faults.contains(Faults::LIMIT)));
    assert!((rig.log.last().unwrap().command.vx - 0.3).abs() < 1e-9);
}

#[test]
fn malformed_commands_are_rejected_and_not_executed() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    rig.cmd(vel(0.1, 0.0, 0.0)).unwrap();
    rig.run(10, true);
    assert_eq!(
        rig.cmd(vel(f64::NAN, 0.0, 0.0)),
        Err(CommandError::NonFinite { field: "vx" })
    );
    assert!(matches!(
        rig.cmd(vel(0.0, 0.0, f64::INFINITY)),
        Err(CommandError::NonFinite { field: "yaw_rate" })
    ));
    assert!(matches!(
        rig.cmd(vel(3.0, 0.0, 0.0)),
        Err(CommandError::OverLimit { field: "speed", .. })
    ));
    assert!(matches!(
        rig.cmd(vel(0.0, 0.0, -50.0)),
        Err(CommandError::OverLimit {
            field: "yaw_rate",
            ..
        })
    ));
    let st = rig.run(50, true);
    // Still the last valid command.
    assert!((st.command.vx - 0.1).abs() < 1e-12 && st.command.yaw_rate == 0.0);
    assert_eq!(st.rejected, 4);
    assert!(st.fault_history.contains(Faults::REJECTED));
}

#[test]
fn watchdog_brakes_within_the_acceleration_limit() {
    let mut cfg = Config::new(100.0);
    cfg.watchdog = 0.3;
    cfg.slew.accel = 0.5;
    let mut rig = Rig::new(sphere(), cfg);
    rig.cmd(vel(0.2, 0.0, 0.0)).unwrap();
    rig.run(100, true);
    let last_rx = rig.now - DT_US;
    // The link goes silent.
    let mut stopped_at = None;
    for _ in 0..200 {
        let st = rig.step();
        if st.mode == Mode::Idle && stopped_at.is_none() {
            stopped_at = Some(st.time_us);
        }
    }
    let t = (stopped_at.expect("robot must stop") - last_rx) as f64 * 1e-6;
    // watchdog 0.3 s + braking 0.2/0.5 = 0.4 s, + up to two cycles.
    assert!(t <= 0.3 + 0.4 + 0.02 + 1e-9, "stopped after {t} s");
    assert!(t >= 0.3 + 0.4 - 0.02, "stopped too early: {t} s");
    let st = rig.log.last().unwrap();
    assert!(st.faults.contains(Faults::LINK_LOST));
    assert!(st.motors.wheel.iter().all(|w| *w == 0.0));
    for w in rig.log.windows(2) {
        assert!((w[1].command.vx - w[0].command.vx).abs() / DT <= 0.5 + 1e-9);
    }
    // A new command resumes motion and clears the active fault.
    rig.cmd(vel(0.1, 0.0, 0.0)).unwrap();
    let st = rig.step();
    assert_eq!(st.mode, Mode::Velocity);
    assert!(!st.faults.contains(Faults::LINK_LOST));
}

#[test]
fn emergency_stop_latches_until_cleared() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    rig.cmd(vel(0.2, 0.0, 0.0)).unwrap();
    rig.run(50, true);
    rig.cmd(Command::EStop).unwrap();
    let st = rig.step();
    assert_eq!(st.mode, Mode::EStop);
    assert_eq!(
        st.motors.wheel, [0.0; MAX_WHEELS],
        "e-stop zeroes the motors at once"
    );
    assert_eq!(rig.cmd(vel(0.1, 0.0, 0.0)), Err(CommandError::EStopLatched));
    assert_eq!(
        rig.cmd(Command::PlanStart { id: 0 }),
        Err(CommandError::PlanIncomplete { have: 0, len: 0 })
    );
    let st = rig.run(20, true);
    assert_eq!(st.mode, Mode::EStop);
    assert!(st.faults.contains(Faults::ESTOP));
    rig.cmd(Command::Clear).unwrap();
    assert_eq!(rig.step().mode, Mode::Idle);
    rig.cmd(vel(0.1, 0.0, 0.0)).unwrap();
    assert_eq!(rig.step().mode, Mode::Velocity);
}

#[test]
fn stop_brakes_to_idle() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    rig.cmd(vel(0.2, 0.0, 0.5)).unwrap();
    rig.run(50, true);
    rig.cmd(Command::Stop).unwrap();
    let st = rig.run(30, true);
    assert_eq!(st.mode, Mode::Idle);
    assert_eq!(st.command, Twist2::new(0.0, 0.0, 0.0));
}

/// A smooth rest-to-rest curve (world frame), sampled at `dt`; poses integrated exactly from
/// the continuous twist (fine sub-steps), so samples, velocities and poses agree.
fn plan_points(dt: f64) -> Vec<PlanPoint<f64>> {
    let twist = |t: f64| {
        // sin² speed profile so accelerations are small; the robot yaws while it moves.
        let s = (core::f64::consts::PI * t / 4.0).sin();
        Twist2::new(0.15 * s * s, 0.02 * s, 0.4 * s * s)
    };
    let mut pts = vec![];
    let mut pose = Pose2::default();
    let n = (4.0 / dt).round() as usize;
    let sub = 100;
    for k in 0..=n {
        let t = k as f64 * dt;
        pts.push(PlanPoint {
            t,
            pose,
            twist: twist(t).to_world(pose.heading),
        });
        let h = dt / sub as f64;
        for j in 0..sub {
            pose = omnikin::se2::integrate(pose, twist(t + (j as f64 + 0.5) * h), h);
        }
    }
    pts
}

fn upload(rig: &mut Rig, id: u16, pts: &[PlanPoint<f64>]) {
    rig.cmd(Command::PlanBegin {
        id,
        len: pts.len() as u16,
    })
    .unwrap();
    for (k, c) in pts.chunks(8).enumerate() {
        rig.cmd(Command::PlanChunk {
            id,
            offset: (k * 8) as u16,
            points: c,
        })
        .unwrap();
    }
}

#[test]
fn plan_upload_validates_chunks() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    let pts = plan_points(0.05);
    assert!(matches!(
        rig.cmd(Command::PlanBegin { id: 1, len: 600 }),
        Err(CommandError::PlanTooLong { .. })
    ));
    rig.cmd(Command::PlanBegin { id: 1, len: 81 }).unwrap();
    rig.cmd(Command::PlanChunk {
        id: 1,
        offset: 0,
        points: &pts[0..8],
    })
    .unwrap();
    // Re-sent chunk: idempotent.
    rig.cmd(Command::PlanChunk {
        id: 1,
        offset: 0,
        points: &pts[0..8],
    })
    .unwrap();
    // Gap.
    assert!(matches!(
        rig.cmd(Command::PlanChunk {
            id: 1,
            offset: 16,
            points: &pts[16..24]
        }),
        Err(CommandError::PlanChunkOutOfPlace { .. })
    ));
    // Wrong id.
    assert!(matches!(
        rig.cmd(Command::PlanChunk {
            id: 2,
            offset: 8,
            points: &pts[8..16]
        }),
        Err(CommandError::PlanIdMismatch {
            expected: 1,
            got: 2
        })
    ));
    // NaN and non-increasing time.
    let mut bad = pts[8..16].to_vec();
    bad[3].pose.x = f64::NAN;
    assert_eq!(
        rig.cmd(Command::PlanChunk {
            id: 1,
            offset: 8,
            points: &bad
        }),
        Err(CommandError::NonFinite { field: "plan.x" })
    );
    let mut bad = pts[8..16].to_vec();
    bad[2].t = bad[1].t;
    assert_eq!(
        rig.cmd(Command::PlanChunk {
            id: 1,
            offset: 8,
            points: &bad
        }),
        Err(CommandError::PlanTimeNotIncreasing { index: 10 })
    );
    assert!(matches!(
        rig.cmd(Command::PlanStart { id: 1 }),
        Err(CommandError::PlanIncomplete { have: 8, len: 81 })
    ));
    assert_eq!(rig.rt.mode(), Mode::Idle);
}

/// An operator resends `PlanStart` until telemetry shows the plan running; when that telemetry
/// is lost, a second copy arrives while the plan runs (and a late one after it ended). Neither
/// may restart it: under 20 % loss a restart put the reference 1.6 mm behind the robot.
#[test]
fn a_repeated_plan_start_neither_restarts_nor_reruns_the_plan() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    let pts = plan_points(0.05);
    upload(&mut rig, 7, &pts);
    rig.cmd(Command::PlanStart { id: 7 }).unwrap();
    for _ in 0..30 {
        rig.cmd(Command::Heartbeat).unwrap();
        rig.step();
    }
    let before = rig.log.last().unwrap().reference;
    rig.cmd(Command::PlanStart { id: 7 }).unwrap();
    rig.cmd(Command::Heartbeat).unwrap();
    let st = rig.step();
    assert_eq!(st.mode, Mode::Trajectory);
    assert!(
        st.reference.x >= before.x && st.reference.y >= before.y,
        "the reference went back: {before:?} -> {:?}",
        st.reference
    );
    for _ in 0..450 {
        rig.cmd(Command::Heartbeat).unwrap();
        rig.step();
    }
    let st = *rig.log.last().unwrap();
    assert!(st.plan.done && st.mode == Mode::Idle);
    // A late copy after the end does not run it again.
    rig.cmd(Command::PlanStart { id: 7 }).unwrap();
    rig.cmd(Command::Heartbeat).unwrap();
    assert_eq!(rig.step().mode, Mode::Idle);
    // A new upload starts as before.
    upload(&mut rig, 8, &pts);
    rig.cmd(Command::PlanStart { id: 8 }).unwrap();
    assert_eq!(rig.rt.mode(), Mode::Trajectory);
}

#[test]
fn trajectory_is_followed_nearly_exactly_on_an_ideal_plant() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    let pts = plan_points(0.05);
    upload(&mut rig, 7, &pts);
    rig.cmd(Command::PlanStart { id: 7 }).unwrap();
    let mut max_err = 0.0f64;
    for _ in 0..450 {
        rig.cmd(Command::Heartbeat).unwrap();
        let st = rig.step();
        if st.mode == Mode::Trajectory {
            let e = (st.pose.x - st.reference.x).hypot(st.pose.y - st.reference.y);
            max_err = max_err.max(e);
        }
    }
    let st = rig.log.last().unwrap();
    let end = pts.last().unwrap().pose;
    let end_err = (st.pose.x - end.x).hypot(st.pose.y - end.y);
    println!("ideal plant: max tracking error {max_err:.2e} m, end error {end_err:.2e} m");
    assert!(st.plan.done && st.mode == Mode::Idle);
    assert!(max_err < 5e-4, "max tracking error {max_err} m");
    assert!(end_err < 1e-4, "end error {end_err} m");
    assert!((st.pose.heading - end.heading).abs() < 5e-3);
}

#[test]
fn trajectory_returns_to_the_path_after_a_disturbance() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    let pts = plan_points(0.05);
    upload(&mut rig, 3, &pts);
    rig.cmd(Command::PlanStart { id: 3 }).unwrap();
    rig.run(150, true);
    // A kick: the robot is displaced by 5 cm sideways (as the fused pose would report).
    let p = rig.rt.pose();
    rig.cmd(Command::SetPose(Pose2::new(
        p.x,
        p.y + 0.05,
        p.heading + 0.1,
    )))
    .unwrap();
    let mut errs = vec![];
    for _ in 0..300 {
        rig.cmd(Command::Heartbeat).unwrap();
        let st = rig.step();
        errs.push((st.pose.x - st.reference.x).hypot(st.pose.y - st.reference.y));
    }
    assert!(errs[0] > 0.045);
    let st = rig.log.last().unwrap();
    let end = pts.last().unwrap().pose;
    let end_err = (st.pose.x - end.x).hypot(st.pose.y - end.y);
    println!("after a 5 cm kick: end error {end_err:.2e} m");
    assert!(end_err < 0.01, "end error {end_err}");
    assert!((st.pose.heading - end.heading).abs() < 0.02);
}

#[test]
fn hardware_error_stops_and_is_reported() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    rig.cmd(vel(0.1, 0.0, 0.0)).unwrap();
    rig.run(20, true);
    rig.board.fail_encoders = true;
    let st = rig.step();
    assert!(st.faults.contains(Faults::HARDWARE));
    assert_eq!(st.motors.wheel, [0.0; MAX_WHEELS]);
    assert_eq!(st.mode, Mode::Stopping);
}

#[test]
fn gyro_disagreeing_with_the_wheels_is_slip() {
    // The detector's low-pass over 0.1 s instead of the default 10 ms, and a 0.5 rad/s
    // threshold, so that the filter's delay and a glitch's rejection can be seen at 100 Hz.
    let mut cfg = Config::new(100.0);
    cfg.events.smoothing = 0.1;
    cfg.events.slip_yaw_rate = 0.5;
    let mut rig = Rig::new(sphere(), cfg);
    rig.board.gyro = true;
    rig.cmd(vel(0.1, 0.0, 0.2)).unwrap();
    rig.run(30, true);
    assert!(rig.log.iter().all(|s| !s.faults.contains(Faults::SLIP)));
    assert_eq!(rig.log.last().unwrap().events.slips, 0);
    // A 1 rad/s disagreement, low-passed with a = 1 − e^(−dt/τ) per cycle, passes 0.5 rad/s
    // after k cycles with (1 − a)^k < 0.5: k = ⌈ln 0.5 / (−dt/τ)⌉ = 7 (the 7th cycle, index 6).
    rig.board.gyro_offset = 1.0;
    let k = (0.5f64.ln() / (-DT / 0.1)).ceil() as usize;
    let n = (0..30)
        .position(|_| rig.run(1, true).faults.contains(Faults::SLIP))
        .expect("slip must be detected");
    assert_eq!(n + 1, k);
    // One episode however long the slip lasts: the flag stays up, the counter is 1.
    let st = rig.run(50, true);
    assert!(st.faults.contains(Faults::SLIP));
    assert_eq!(st.events.slips, 1);
    // The slip ends; the flag drops once the signal has stayed below for the 0.2 s hold.
    rig.board.gyro_offset = 0.0;
    let st = rig.run(60, true);
    assert!(!st.faults.contains(Faults::SLIP));
    // A brief glitch (2 cycles) is filtered out: no new event.
    rig.board.gyro_offset = 1.0;
    let st = rig.run(2, true);
    assert!(!st.faults.contains(Faults::SLIP));
    rig.board.gyro_offset = 0.0;
    let st = rig.run(30, true);
    assert_eq!(st.events.slips, 1);
    assert_eq!(st.events.collisions, 0);
}

#[test]
fn blocked_wheels_are_one_collision_and_braking_is_none() {
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    rig.cmd(vel(0.5, 0.0, 0.0)).unwrap();
    rig.run(100, true);
    // Braking at the 1 m/s² slew limit is no collision (threshold 3 m/s²).
    rig.cmd(Command::Stop).unwrap();
    rig.run(100, true);
    rig.cmd(vel(0.5, 0.0, 0.0)).unwrap();
    let st = rig.run(100, true);
    assert!((st.twist.vx - 0.5).abs() < 1e-9, "cruising at 0.5 m/s");
    assert!(
        rig.log
            .iter()
            .all(|s| s.faults.0 & Faults::COLLISION.0 == 0)
    );
    assert_eq!(st.events.collisions, 0);
    // The wheels are blocked at 0.5 m/s: a deceleration of ~0.5 m/s in a cycle.
    let before = rig.log.len();
    rig.board.stalled = true;
    let st = rig.run(100, true);
    let hit: Vec<usize> = rig.log[before..]
        .iter()
        .enumerate()
        .filter(|(_, s)| s.faults.contains(Faults::COLLISION))
        .map(|(i, _)| i)
        .collect();
    // Flagged from the first or second cycle of the stop, continuously (one episode), and
    // counted once; no slip (the gyro is off and the sphere has no redundant wheels).
    assert!(hit.first().is_some_and(|&i| i <= 2), "{hit:?}");
    assert_eq!(hit.len(), hit.last().unwrap() - hit.first().unwrap() + 1);
    assert!(!st.faults.contains(Faults::COLLISION), "the episode ended");
    assert_eq!((st.events.collisions, st.events.slips), (1, 0));
}

#[test]
fn caster_and_ballbot_run_the_same_loop() {
    let caster = Robot::Caster(Caster3::new(CasterParams::preset()).unwrap());
    let mut cfg = Config::new(100.0);
    cfg.rate_limits.steer = Some(10.0);
    cfg.rate_limits.wheel = Some(30.0);
    let mut rig = Rig::new(caster, cfg);
    rig.cmd(vel(0.1, 0.1, 0.3)).unwrap();
    let st = rig.run(150, true);
    // Steer angles move during a cycle while the rates were computed at its start: an O(dt)
    // discretisation error (measured 6e-5 m/s at 100 Hz).
    assert!((st.twist.vx - 0.1).abs() < 1e-3 && (st.twist.vy - 0.1).abs() < 1e-3);
    assert!((st.twist.yaw_rate - 0.3).abs() < 1e-3);
    assert!(st.slip_residual < 1e-3, "slip {}", st.slip_residual);
    assert!(
        rig.log
            .iter()
            .all(|s| s.motors.steer.iter().all(|x| x.abs() <= 10.0 + 1e-9))
    );
    // Inverse kinematics consistent with the library call.
    let m = motor_rates(rig.rt.robot(), st.command, &st.encoders.steer).unwrap();
    assert!((m.wheel[0] - st.motors.wheel[0]).abs() < 1e-9);

    let bb = Robot::Ballbot(Ballbot::new(BallbotParams::preset()).unwrap());
    let mut rig = Rig::new(bb, Config::new(100.0));
    rig.cmd(vel(0.0, 0.2, -0.5)).unwrap();
    let st = rig.run(100, true);
    assert!((st.twist.vy - 0.2).abs() < 1e-9 && (st.twist.yaw_rate + 0.5).abs() < 1e-9);
}

#[test]
fn f32_runtime_and_bad_config() {
    let robot = Robot::Sphere(SphereOmni::<f32>::new(SphereParams::preset()).unwrap());
    let mut cfg = Config::<f32>::new(100.0);
    cfg.watchdog = -1.0;
    let e = Runtime::<f32, 4>::new(robot, cfg, Pose2::default()).unwrap_err();
    assert_eq!(e.field, "watchdog");
    cfg.watchdog = 0.5;
    assert!(Runtime::<f32, 4>::new(robot, cfg, Pose2::default()).is_ok());
}

/// `SetPose` restarts the fusion filter at the set pose, known exactly (variances 0), keeps
/// the fix counters, and fixes after it are fused around the new pose.
#[test]
fn set_pose_restarts_the_fusion_filter() {
    use omnikin::runtime::CameraFix;
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    rig.cmd(vel(0.1, 0.0, 0.0)).unwrap();
    let fix = |rig: &Rig, x: f64, y: f64| {
        Command::Fix(CameraFix {
            capture_us: rig.now - DT_US,
            x,
            y,
            heading: None,
            std_xy: 0.01,
            std_heading: 0.0,
        })
    };
    for _ in 0..20 {
        let st = rig.run(10, true);
        // The camera sees the robot 2 cm to the left of the wheels' estimate.
        let c = fix(&rig, st.odometry.x, st.odometry.y + 0.02);
        rig.cmd(c).unwrap();
    }
    let st = rig.run(1, true);
    assert!(st.fixes.accepted >= 19, "{:?}", st.fixes);
    assert!((st.pose.y - 0.02).abs() < 0.01, "fused y {}", st.pose.y);
    assert!(st.covariance[1] > 0.0);
    let fused = st.fixes;
    // Set the pose: both the odometry and the fused pose start from it, exactly.
    let set = Pose2::new(1.0, -2.0, 0.5);
    rig.cmd(Command::SetPose(set)).unwrap();
    let st = rig.run(1, false);
    assert!((st.pose.x - set.x).abs() < 0.01 && (st.pose.y - set.y).abs() < 0.01);
    assert!((st.odometry.y - set.y).abs() < 0.01);
    assert!(
        st.covariance.iter().all(|&v| v < 1e-6),
        "{:?}",
        st.covariance
    );
    assert_eq!(st.fixes, fused, "counters are kept");
    // A fix 1 cm (1 σ) from the set pose is fused around it (not rejected as 2 m away from the
    // pose before the set).
    let st = rig.run(20, true);
    let c = fix(&rig, st.odometry.x + 0.01, st.odometry.y);
    rig.cmd(c).unwrap();
    let st = rig.run(1, true);
    assert_eq!(st.fixes.accepted, fused.accepted + 1, "{:?}", st.fixes);
    assert_eq!(st.fixes.rejected, fused.rejected);
    assert!(st.pose.x > st.odometry.x, "pulled toward the fix");
}

/// `reset` makes a used runtime (a plan uploaded and followed, fixes fused, an e-stop latched,
/// rejections counted) exactly the one `new` builds for another robot, configuration and
/// pose — every field, as its debug form shows; a bad configuration changes nothing.
#[test]
fn reset_in_place_equals_a_new_runtime() {
    use omnikin::runtime::CameraFix;
    let mut rig = Rig::new(sphere(), Config::new(100.0));
    upload(&mut rig, 1, &plan_points(0.05));
    rig.cmd(Command::PlanStart { id: 1 }).unwrap();
    rig.run(50, true);
    for _ in 0..5 {
        let st = rig.run(10, true);
        rig.cmd(Command::Fix(CameraFix {
            capture_us: rig.now - 5 * DT_US,
            x: st.odometry.x,
            y: st.odometry.y + 0.01,
            heading: Some(st.odometry.heading),
            std_xy: 0.01,
            std_heading: 0.05,
        }))
        .unwrap();
    }
    assert!(rig.cmd(vel(f64::NAN, 0.0, 0.0)).is_err());
    rig.cmd(Command::EStop).unwrap();
    let st = rig.run(5, true);
    assert!(st.fixes.accepted > 0 && st.rejected > 0 && st.mode == Mode::EStop);

    let caster = Robot::Caster(Caster3::new(CasterParams::preset()).unwrap());
    let mut cfg = Config::new(200.0);
    cfg.watchdog = 0.3;
    cfg.fusion.max_latency = 0.5;
    let pose = Pose2::new(1.0, -2.0, 0.5);
    let fresh = Runtime::<f64, 512>::new(caster, cfg, pose).unwrap();
    assert_ne!(format!("{:?}", rig.rt), format!("{fresh:?}"));
    rig.rt.reset(caster, cfg, pose).unwrap();
    assert_eq!(format!("{:?}", rig.rt), format!("{fresh:?}"));

    let mut bad = cfg;
    bad.rate_hz = -1.0;
    let before = format!("{:?}", rig.rt);
    assert!(rig.rt.reset(sphere(), bad, Pose2::default()).is_err());
    assert_eq!(
        format!("{:?}", rig.rt),
        before,
        "unchanged by a refused reset"
    );
}
