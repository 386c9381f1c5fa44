//! The robot side never touches the heap: a counting global allocator sees zero allocations on
//! this thread across control cycles in every mode, command handling (including rejected
//! commands), plan upload, and the link codec (encode, decode, drops).

use omnikin_testkit::allocations;

use omnikin::control::BalanceConfig;
use omnikin::description::RobotDescription;
use omnikin::link::{
    CHUNK_POINTS, Estimate, FrameReader, Key, MAX_FRAME, Message, OperatorLink, RobotEvent,
    RobotInfo, RobotLink, WireFix, WirePoint, robot_info, serve,
};
use omnikin::runtime::hal::{
    EncoderAngles, Encoders, Entropy, EntropyError, MotorCommand, MotorOutputs, NoImu,
};
use omnikin::runtime::hal::{Imu, ImuSample, MotorTorques, TorqueCommand};
use omnikin::runtime::{
    BalanceRuntime, BalanceRuntimeConfig, Command, Config, Frame, Mode, Operated, PlanPoint,
    Runtime,
};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{MAX_WHEELS, Pose2, Robot, Twist2};

#[global_allocator]
static GLOBAL: omnikin_testkit::Counting = omnikin_testkit::Counting;

struct Board {
    angles: EncoderAngles<f32>,
}
impl Encoders<f32> for Board {
    type Error = ();
    fn read(&mut self) -> Result<EncoderAngles<f32>, ()> {
        Ok(self.angles)
    }
}
struct Out<'a>(&'a mut MotorCommand<f32>);
impl MotorOutputs<f32> for Out<'_> {
    type Error = ();
    fn set_rates(&mut self, c: &MotorCommand<f32>) -> Result<(), ()> {
        *self.0 = *c;
        Ok(())
    }
}

/// A counter standing in for the TRNG (the test is about allocation, not secrecy).
struct Counter(u8);
impl Entropy for Counter {
    fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError> {
        for b in buf {
            self.0 = self.0.wrapping_add(37);
            *b = self.0;
        }
        Ok(())
    }
}

struct Wire {
    op: OperatorLink,
    robot: RobotLink,
    info: RobotInfo,
    rng: Counter,
    reader: FrameReader<MAX_FRAME>,
    frame: [u8; MAX_FRAME],
    reply: [u8; MAX_FRAME],
}

impl Wire {
    /// Bytes through the robot's receive path: reader → decode → session → serve.
    fn deliver<R: Operated<f32>>(&mut self, len: usize, rt: &mut R, now: u64) -> usize {
        let (robot, info, rng, reply) =
            (&mut self.robot, &self.info, &mut self.rng, &mut self.reply);
        let mut answer = 0;
        self.reader.feed(&self.frame[..len], |f| match f {
            Some(f) => match robot.receive(f, now, &[], info, rng, reply) {
                Ok(RobotEvent::Message { seq, msg, .. }) => {
                    serve(rt, robot, seq, &msg, now);
                }
                Ok(RobotEvent::Hello(n) | RobotEvent::Busy(n)) => answer = n,
                Err(_) => {}
            },
            None => robot.count_framing_drop(),
        });
        answer
    }
    /// The handshake, both ways.
    fn connect<R: Operated<f32>>(&mut self, rt: &mut R, now: u64) {
        let len = self.op.hello(&mut self.rng, &mut self.frame).unwrap();
        let n = self.deliver(len, rt, now);
        assert!(n > 0);
        let mut ack = self.reply;
        let _ = self.op.receive(&mut ack[..n - 1]).unwrap();
        self.send(&Message::Heartbeat, rt, now);
        assert!(self.robot.session_id().is_some());
    }
    /// A command through the full link path: encode → bytes → reader → decode → serve.
    fn send<R: Operated<f32>>(&mut self, msg: &Message, rt: &mut R, now: u64) {
        let len = self.op.encode(msg, &mut self.frame).unwrap();
        self.deliver(len, rt, now);
    }
}

#[test]
fn the_counter_counts() {
    let (n, v) = allocations(|| vec![1u8; 16]);
    assert_eq!(v.len(), 16);
    assert!(n >= 1);
}

#[test]
fn control_cycles_and_link_allocate_nothing() {
    session_allocates_nothing(Robot::Sphere(
        SphereOmni::<f32>::new(SphereParams::preset()).unwrap(),
    ));
}

#[test]
fn mecanum_and_swerve_runtimes_allocate_nothing() {
    for name in ["mecanum", "swerve4"] {
        let robot = RobotDescription::preset(name)
            .unwrap()
            .build::<f32>()
            .unwrap();
        session_allocates_nothing(robot);
    }
}

/// A keyed session (velocity, rejected commands, a corrupt frame, a plan upload and its
/// trajectory with telemetry, watchdog stop, e-stop) makes no allocation.
fn session_allocates_nothing(robot: Robot<f32>) {
    let mut cfg = Config::new(100.0);
    cfg.rate_limits.wheel = Some(12.0);
    cfg.wheel_accel = Some(400.0);
    cfg.rate_limits.steer = Some(12.0);
    cfg.steer_accel = Some(80.0);
    cfg.slew.jerk = Some(20.0);
    // Built outside the measured region (construction is allowed to be anywhere, but the
    // runtime is a plain value: no allocation there either).
    let (n0, rt) = allocations(|| Runtime::<f32, 128>::new(robot, cfg, Pose2::default()));
    assert_eq!(n0, 0);
    let mut rt = rt.unwrap();
    let mut board = Board {
        angles: EncoderAngles::zero(),
    };
    let key = Key::new(b"0123456789abcdef").unwrap();
    let mut w = Wire {
        op: OperatorLink::new(Some(key.clone())),
        robot: RobotLink::new(Some(key)),
        info: robot_info(&rt, true),
        rng: Counter(1),
        reader: FrameReader::new(),
        frame: [0u8; MAX_FRAME],
        reply: [0u8; MAX_FRAME],
    };
    let points: [PlanPoint<f32>; 40] = core::array::from_fn(|k| PlanPoint {
        t: k as f32 * 0.05,
        pose: Pose2::new(0.005 * k as f32, 0.0, 0.0),
        twist: Twist2::new(0.1, 0.0, 0.0),
    });

    let mut now = 0u64;
    let mut cycles = 0usize;
    let (n, ()) = allocations(|| {
        let mut cycle = |rt: &mut Runtime<f32, 128>, board: &mut Board, now: &mut u64| {
            let mut out = MotorCommand::zero();
            rt.cycle(*now, board, &mut NoImu, &mut Out(&mut out));
            let st = rt.status();
            for i in 0..MAX_WHEELS {
                board.angles.wheel[i] += out.wheel[i] * 0.01;
                board.angles.steer[i] += out.steer[i] * 0.01;
            }
            *now += 10_000;
            cycles += 1;
            st
        };
        w.connect(&mut rt, now);
        w.send(
            &Message::SetVelocity {
                frame: Frame::Robot,
                vx: 0.3,
                vy: 0.1,
                yaw_rate: 0.5,
            },
            &mut rt,
            now,
        );
        let mut seen = [(0u64, Pose2::default()); 100];
        for k in 0..100usize {
            w.send(&Message::Heartbeat, &mut rt, now);
            let st = cycle(&mut rt, &mut board, &mut now);
            seen[k] = (st.time_us, st.pose);
            // Camera fixes through the link: fused at a capture time 0.3 s back (replaying
            // the history), one far off (gated); the estimate encoded.
            if k >= 40 && k % 10 == 0 {
                let (capture_us, p) = seen[k - 30];
                let x = if k == 90 { 50.0 } else { p.x };
                w.send(
                    &Message::Fix(WireFix {
                        capture_us,
                        x,
                        y: p.y,
                        heading: Some(p.heading),
                        std_xy: 0.02,
                        std_heading: 0.05,
                    }),
                    &mut rt,
                    now,
                );
            }
            let e = Estimate::new(&st, 0.0, 1.0);
            let _ = w.robot.encode(&Message::Estimate(e), &mut w.frame).unwrap();
        }
        // An invalid fix (negative standard deviation): rejected as a command.
        w.send(
            &Message::Fix(WireFix {
                capture_us: now - 20_000,
                x: 0.0,
                y: 0.0,
                heading: None,
                std_xy: -1.0,
                std_heading: 0.0,
            }),
            &mut rt,
            now,
        );
        // Rejected commands (NaN, over-limit) and a corrupt frame.
        w.send(
            &Message::SetVelocity {
                frame: Frame::World,
                vx: f32::NAN,
                vy: 0.0,
                yaw_rate: 0.0,
            },
            &mut rt,
            now,
        );
        let _ = rt.handle(
            Command::Velocity {
                twist: Twist2::new(9.0, 0.0, 0.0),
                frame: Frame::Robot,
            },
            now,
        );
        let len = w.op.encode(&Message::Heartbeat, &mut w.frame).unwrap();
        w.frame[3] ^= 0x55;
        w.deliver(len, &mut rt, now);
        // Plan upload in chunks, then trajectory mode.
        w.send(&Message::Stop, &mut rt, now);
        for _ in 0..100 {
            w.send(&Message::Heartbeat, &mut rt, now);
            cycle(&mut rt, &mut board, &mut now);
        }
        w.send(&Message::PlanBegin { id: 1, len: 40 }, &mut rt, now);
        for (k, c) in points.chunks(CHUNK_POINTS).enumerate() {
            let mut v = heapless::Vec::new();
            for p in c {
                let _ = v.push(WirePoint::from_point(p));
            }
            w.send(
                &Message::PlanChunk {
                    id: 1,
                    offset: (k * CHUNK_POINTS) as u16,
                    points: v,
                },
                &mut rt,
                now,
            );
        }
        w.send(&Message::PlanStart { id: 1 }, &mut rt, now);
        assert_eq!(rt.mode(), Mode::Trajectory);
        for _ in 0..250 {
            w.send(&Message::Heartbeat, &mut rt, now);
            let st = cycle(&mut rt, &mut board, &mut now);
            // Telemetry encoding too.
            let tm = w.robot.telemetry(&st);
            let _ = w
                .robot
                .encode(&Message::Telemetry(tm), &mut w.frame)
                .unwrap();
        }
        // A fix older than the history (max_latency 1 s): too late.
        w.send(
            &Message::Fix(WireFix {
                capture_us: 0,
                x: 0.0,
                y: 0.0,
                heading: None,
                std_xy: 0.01,
                std_heading: 0.0,
            }),
            &mut rt,
            now,
        );
        // Watchdog stop and e-stop.
        for _ in 0..100 {
            cycle(&mut rt, &mut board, &mut now);
        }
        w.send(&Message::EStop, &mut rt, now);
        for _ in 0..10 {
            cycle(&mut rt, &mut board, &mut now);
        }
    });
    assert_eq!(n, 0, "{n} allocations in {cycles} control cycles");
    assert_eq!(cycles, 560);
    assert_eq!(rt.mode(), Mode::EStop);
    assert_eq!(rt.rejected(), 3);
    assert_eq!(w.robot.counters().crc, 1);
    let f = rt.fix_counters();
    assert_eq!((f.accepted, f.rejected, f.too_late), (5, 1, 1), "{f:?}");
}

/// A ballbot board at rest: the IMU reads gravity, the encoders the wheels' angles, the torques
/// are kept.
struct BallbotBoard {
    wheel: [f32; 3],
    torques: [f32; 3],
}
impl Encoders<f32> for BallbotBoard {
    type Error = ();
    fn read(&mut self) -> Result<EncoderAngles<f32>, ()> {
        let mut a = EncoderAngles::zero();
        a.wheel[..3].copy_from_slice(&self.wheel);
        Ok(a)
    }
}
impl Imu<f32> for BallbotBoard {
    type Error = ();
    fn read(&mut self) -> Result<Option<ImuSample<f32>>, ()> {
        Ok(Some(ImuSample {
            gyro: [0.001, -0.002, 0.0005],
            accel: [0.05, -0.03, 9.81],
        }))
    }
}
impl MotorTorques<f32> for BallbotBoard {
    type Error = ();
    fn set_torques(&mut self, c: &TorqueCommand<f32>) -> Result<(), ()> {
        self.torques.copy_from_slice(&c.wheel[..3]);
        Ok(())
    }
}

/// The balance runtime over a keyed session (velocity, rejected and refused commands, a
/// corrupt frame, e-stop, clear, telemetry encoding) makes no allocation either.
#[test]
fn balance_runtime_and_link_allocate_nothing() {
    let cfg = BalanceRuntimeConfig::new(BalanceConfig::<f32>::preset(), 0.9);
    let (n0, rt) = allocations(|| BalanceRuntime::new(cfg, Pose2::default()));
    assert_eq!(n0, 0);
    let mut rt = rt.unwrap();
    let key = Key::new(b"0123456789abcdef").unwrap();
    let mut w = Wire {
        op: OperatorLink::new(Some(key.clone())),
        robot: RobotLink::new(Some(key)),
        info: robot_info(&rt, true),
        rng: Counter(1),
        reader: FrameReader::new(),
        frame: [0u8; MAX_FRAME],
        reply: [0u8; MAX_FRAME],
    };
    assert_eq!(w.info.plan_capacity, 0);
    let mut board = BallbotBoard {
        wheel: [0.0; 3],
        torques: [0.0; 3],
    };
    let mut now = 0u64;
    let mut modes = [false; 5];
    let (n, ()) = allocations(|| {
        let mut cycle = |rt: &mut BalanceRuntime<f32>, w: &mut Wire, now: &mut u64| {
            let mut e = BallbotBoard { ..board };
            let mut i = BallbotBoard { ..board };
            let st = rt.cycle(*now, &mut e, &mut i, &mut board);
            for (k, t) in board.torques.iter().enumerate() {
                board.wheel[k] += t * 0.01;
            }
            *now += 5_000;
            let tm = w.robot.telemetry(&st);
            let mut buf = [0u8; MAX_FRAME];
            let _ = w.robot.encode(&Message::Telemetry(tm), &mut buf);
            modes[st.mode as usize] = true;
        };
        w.connect(&mut rt, now);
        w.send(
            &Message::SetVelocity {
                frame: Frame::Robot,
                vx: 0.2,
                vy: 0.0,
                yaw_rate: 0.3,
            },
            &mut rt,
            now,
        );
        for _ in 0..100 {
            w.send(&Message::Heartbeat, &mut rt, now);
            cycle(&mut rt, &mut w, &mut now);
        }
        w.send(
            &Message::SetVelocity {
                frame: Frame::World,
                vx: f32::NAN,
                vy: 0.0,
                yaw_rate: 0.0,
            },
            &mut rt,
            now,
        );
        let _ = rt.handle(
            Command::Velocity {
                twist: Twist2::new(9.0, 0.0, 0.0),
                frame: Frame::Robot,
            },
            now,
        );
        w.send(&Message::PlanBegin { id: 1, len: 40 }, &mut rt, now);
        w.send(&Message::PlanStart { id: 1 }, &mut rt, now);
        let len = w.op.encode(&Message::Heartbeat, &mut w.frame).unwrap();
        w.frame[3] ^= 0x55;
        w.deliver(len, &mut rt, now);
        w.send(&Message::Stop, &mut rt, now);
        for _ in 0..50 {
            w.send(&Message::Heartbeat, &mut rt, now);
            cycle(&mut rt, &mut w, &mut now);
        }
        w.send(&Message::EStop, &mut rt, now);
        cycle(&mut rt, &mut w, &mut now);
        w.send(&Message::Clear, &mut rt, now);
        // The watchdog expires.
        for _ in 0..150 {
            cycle(&mut rt, &mut w, &mut now);
        }
    });
    assert_eq!(n, 0, "{n} allocations in the balance runtime's session");
    // The refused commands were counted, and the session went through velocity and e-stop.
    assert!(modes[Mode::Velocity as usize] && modes[Mode::EStop as usize]);
}

/// The runtime re-bases its odometry clock every 256 s (`f32` keeps µs resolution); the
/// fusion filter's history moves with it, so fixes keep being fused at their capture time
/// across the re-base, without allocating.
#[test]
fn fixes_are_fused_across_the_clock_rebase() {
    let robot = Robot::Sphere(SphereOmni::<f32>::new(SphereParams::preset()).unwrap());
    let mut rt = Runtime::<f32, 8>::new(robot, Config::new(100.0), Pose2::default()).unwrap();
    let mut board = Board {
        angles: EncoderAngles::zero(),
    };
    let mut now = 0u64;
    let (n, ()) = allocations(|| {
        for k in 0..30_000u64 {
            let mut out = MotorCommand::zero();
            rt.cycle(now, &mut board, &mut NoImu, &mut Out(&mut out));
            if k > 0 && k % 100 == 0 {
                // At rest at the origin; the camera says 3 mm east, 0.2 s ago.
                let fix = omnikin::runtime::CameraFix {
                    capture_us: now - 200_000,
                    x: 0.003,
                    y: 0.0,
                    heading: None,
                    std_xy: 0.01,
                    std_heading: 0.0,
                };
                rt.handle(Command::Fix(fix), now).unwrap();
            }
            now += 10_000;
        }
    });
    assert_eq!(n, 0);
    let f = rt.fix_counters();
    assert_eq!((f.accepted, f.rejected, f.too_late), (299, 0, 0), "{f:?}");
    assert!((rt.pose().x - 0.003).abs() < 2e-4, "{:?}", rt.pose());
    assert_eq!(rt.odometry_pose().x, 0.0);
}
