//! The robot runtime for the N-wheel kinds (mecanum, kiwi, swerve4) on an ideal board (motors
//! turn exactly as commanded, encoders read the exact angles): velocity mode reaches the
//! commanded twist, the odometry pose is the integrated twist, wheel and steer rates stay
//! within their limits, and a swerve's steer angles converge to the inverse's.

use omnikin::description::RobotDescription;
use omnikin::runtime::hal::{EncoderAngles, Encoders, MotorCommand, MotorOutputs, NoImu};
use omnikin::runtime::{Command, Config, Frame, Mode, Runtime, Status};
use omnikin::{Actuators, MAX_WHEELS, Pose2, Robot, Twist2, se2, wrap_angle};

const DT: f64 = 0.01;
const DT_US: u64 = 10_000;

/// Encoders that integrate the commanded rates exactly.
#[derive(Default)]
struct Board {
    wheel: [f64; MAX_WHEELS],
    steer: [f64; MAX_WHEELS],
}

impl Encoders<f64> for Board {
    type Error = ();
    fn read(&mut self) -> Result<EncoderAngles<f64>, ()> {
        Ok(EncoderAngles::new(&self.wheel, &self.steer))
    }
}

struct Sink;
impl MotorOutputs<f64> for Sink {
    type Error = ();
    fn set_rates(&mut self, _: &MotorCommand<f64>) -> Result<(), ()> {
        Ok(())
    }
}

fn preset(name: &str) -> Robot<f64> {
    RobotDescription::preset(name).unwrap().build().unwrap()
}

fn config(robot: &str) -> Config<f64> {
    let l = RobotDescription::preset(robot).unwrap().limits;
    let mut c = Config::new(100.0);
    c.rate_limits.wheel = l.max_wheel_rate;
    c.rate_limits.steer = l.max_steer_rate;
    c.wheel_accel = l.max_wheel_accel;
    c.steer_accel = l.max_steer_accel;
    c
}

/// Runs `cycles` cycles of a robot-frame velocity command; returns every status.
fn drive(
    robot: Robot<f64>,
    cfg: Config<f64>,
    twist: Twist2<f64>,
    cycles: usize,
) -> Vec<Status<f64>> {
    let mut rt = Runtime::<f64, 16>::new(robot, cfg, Pose2::default()).unwrap();
    let mut board = Board::default();
    let cmd = Command::Velocity {
        twist,
        frame: Frame::Robot,
    };
    let mut log = Vec::new();
    for k in 0..cycles as u64 {
        let now = k * DT_US;
        rt.handle(cmd, now).unwrap();
        rt.cycle(now, &mut board, &mut NoImu, &mut Sink);
        let st = rt.status();
        for i in 0..MAX_WHEELS {
            board.wheel[i] += st.motors.wheel[i] * DT;
            board.steer[i] += st.motors.steer[i] * DT;
        }
        log.push(st);
    }
    log
}

fn close(a: Twist2<f64>, b: Twist2<f64>, tol: f64) -> bool {
    (a.vx - b.vx).abs() < tol && (a.vy - b.vy).abs() < tol && (a.yaw_rate - b.yaw_rate).abs() < tol
}

/// The pose of integrating the measured twists of the log (exact SE(2) steps).
fn integrated(log: &[Status<f64>]) -> Pose2<f64> {
    let mut p = Pose2::default();
    for w in log.windows(2) {
        // The twist measured at cycle k+1 is the mean over the step k → k+1.
        p = se2::compose(p, se2::twist_exp(w[1].twist, DT));
    }
    p
}

fn within_limits(log: &[Status<f64>], cfg: &Config<f64>, n: usize) {
    let (w, s) = (cfg.rate_limits.wheel.unwrap(), cfg.rate_limits.steer);
    let mut prev = MotorCommand::<f64>::zero();
    for (k, st) in log.iter().enumerate() {
        for i in 0..MAX_WHEELS {
            assert!(st.motors.wheel[i].abs() <= w + 1e-9, "cycle {k}: wheel {i}");
            if let Some(s) = s {
                assert!(st.motors.steer[i].abs() <= s + 1e-9, "cycle {k}: steer {i}");
            }
            if let Some(a) = cfg.wheel_accel {
                let d = (st.motors.wheel[i] - prev.wheel[i]).abs();
                assert!(d <= a * DT + 1e-9, "cycle {k}: wheel {i} accel {}", d / DT);
            }
            if let Some(a) = cfg.steer_accel {
                let d = (st.motors.steer[i] - prev.steer[i]).abs();
                assert!(d <= a * DT + 1e-9, "cycle {k}: steer {i} accel {}", d / DT);
            }
            if i >= n {
                assert_eq!((st.motors.wheel[i], st.motors.steer[i]), (0.0, 0.0));
            }
        }
        prev = st.motors;
    }
}

#[test]
fn mecanum_and_kiwi_reach_the_twist_and_the_odometry_integrates_it() {
    for name in ["mecanum", "kiwi", "x-drive"] {
        let robot = preset(name);
        let cfg = config(name);
        let twist = Twist2::new(0.3, -0.2, 0.6);
        let log = drive(robot, cfg, twist, 200);
        let st = log.last().unwrap();
        assert_eq!(st.mode, Mode::Velocity, "{name}");
        assert!(close(st.twist, twist, 1e-9), "{name}: {:?}", st.twist);
        assert!(close(st.command, twist, 1e-12), "{name}: {:?}", st.command);
        assert!(st.slip_residual < 1e-9, "{name}: slip {}", st.slip_residual);
        // The commanded wheel rates are the inverse of the twist.
        let a = robot.inverse(twist, &Actuators::zero()).unwrap();
        for i in 0..robot.wheels() {
            assert!(
                (st.motors.wheel[i] - a.wheel_rates[i]).abs() < 1e-9,
                "{name} {i}"
            );
        }
        let p = integrated(&log);
        assert!(
            (p.x - st.pose.x).abs() < 1e-9
                && (p.y - st.pose.y).abs() < 1e-9
                && (p.heading - st.pose.heading).abs() < 1e-9,
            "{name}: {p:?} vs {:?}",
            st.pose
        );
        assert!(st.pose.x.hypot(st.pose.y) > 0.1, "{name}: moved");
        within_limits(&log, &cfg, robot.wheels());
    }
}

#[test]
fn mecanum_desaturates_to_the_wheel_limit_keeping_the_direction() {
    let robot = preset("mecanum");
    let mut cfg = config("mecanum");
    cfg.rate_limits.wheel = Some(10.0);
    let twist = Twist2::new(1.0, 0.5, 0.0);
    let log = drive(robot, cfg, twist, 300);
    let st = log.last().unwrap();
    let worst = st.motors.wheel.iter().fold(0.0f64, |m, r| m.max(r.abs()));
    assert!((worst - 10.0).abs() < 1e-9, "worst wheel {worst}");
    assert!((st.command.vy / st.command.vx - 0.5).abs() < 1e-9);
    assert!(close(st.twist, st.command, 1e-9));
    within_limits(&log, &cfg, 4);
}

#[test]
fn swerve_steer_angles_converge_to_the_inverse_and_the_twist_is_reached() {
    let robot = preset("swerve4");
    let cfg = config("swerve4");
    for twist in [
        Twist2::new(0.5, 0.3, 0.0),
        Twist2::new(0.2, -0.4, 0.8),
        Twist2::new(-0.3, 0.0, -0.5),
        Twist2::new(0.0, 0.0, 1.0),
    ] {
        let log = drive(robot, cfg, twist, 300);
        let st = log.last().unwrap();
        assert_eq!(st.mode, Mode::Velocity);
        let want = robot.inverse(twist, &Actuators::zero()).unwrap();
        for i in 0..4 {
            let e = wrap_angle(st.encoders.steer[i] - want.steer_angles[i]);
            assert!(e.abs() < 1e-6, "{twist:?} module {i}: steer error {e}");
            assert!(
                (st.motors.wheel[i] - want.wheel_rates[i]).abs() < 1e-6,
                "{twist:?} module {i}"
            );
        }
        assert!(close(st.twist, twist, 1e-6), "{twist:?}: {:?}", st.twist);
        assert!(st.slip_residual < 1e-6, "slip {}", st.slip_residual);
        // While turning the modules, the measured motion is what the odometry integrates.
        let p = integrated(&log);
        assert!(
            (p.x - st.pose.x).abs() < 1e-9 && (p.y - st.pose.y).abs() < 1e-9,
            "{p:?} vs {:?}",
            st.pose
        );
        within_limits(&log, &cfg, 4);
        // The steer loop does work: the first command needs the modules to turn.
        assert!(log.iter().any(|s| s.motors.steer[0].abs() > 1.0));
    }
}

#[test]
fn swerve_at_rest_keeps_its_steer_angles_and_stops_with_the_watchdog() {
    let robot = preset("swerve4");
    let cfg = config("swerve4");
    let mut rt = Runtime::<f64, 16>::new(robot, cfg, Pose2::default()).unwrap();
    let mut board = Board::default();
    board.steer[..4].copy_from_slice(&[0.3, -0.2, 1.0, 2.0]);
    // Idle: nothing moves, the modules keep their angles.
    for k in 0..10u64 {
        rt.cycle(k * DT_US, &mut board, &mut NoImu, &mut Sink);
        let st = rt.status();
        assert_eq!(st.motors, MotorCommand::zero());
    }
    // A command, then silence: the watchdog brakes to rest within the limits.
    rt.handle(
        Command::Velocity {
            twist: Twist2::new(0.4, 0.0, 0.0),
            frame: Frame::World,
        },
        10 * DT_US,
    )
    .unwrap();
    let mut log = Vec::new();
    for k in 10..400u64 {
        rt.cycle(k * DT_US, &mut board, &mut NoImu, &mut Sink);
        let st = rt.status();
        for i in 0..MAX_WHEELS {
            board.wheel[i] += st.motors.wheel[i] * DT;
            board.steer[i] += st.motors.steer[i] * DT;
        }
        log.push(st);
    }
    let st = log.last().unwrap();
    assert_eq!(st.mode, Mode::Idle);
    assert_eq!(st.motors.wheel, [0.0; MAX_WHEELS]);
    assert!(log.iter().any(|s| s.twist.vx > 0.1), "it drove");
    within_limits(&log, &cfg, 4);
}
