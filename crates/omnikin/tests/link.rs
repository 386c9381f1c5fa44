//! The link, in process: the codec (encode∘decode is the identity, arbitrary bytes never
//! panic, every bad frame lands in exactly one counter) and the v3 session protocol against
//! replay of a recorded keyed session after a robot restart, a forged `seq = 2^64 - 1`, a third
//! party's heartbeats, takeover without a handshake or without asking, replayed Hellos and
//! first frames (no state for an unproven peer, used nonces, expired epochs), a replayed
//! e-stop confirmation, a held-back clear after an e-stop, v1 peers — and a legitimate session
//! through loss, reordering and duplication.

use omnikin::estimate::events::EventCounters;
use omnikin::link::{
    CHUNK_POINTS, DropReason, EPOCH_US, EncodeError, EndReason, Estimate, FrameKind, FrameReader,
    HANDSHAKE_BODY, Hello, Key, LIVE_US, LinkCounters, MAX_FRAME, Message, Opening, OperatorEvent,
    OperatorLink, PROTOCOL_VERSION, RobotEvent, RobotInfo, RobotKind, RobotLimits, RobotLink,
    SimTruth, Telemetry, USED_PER_EPOCH, WireFix, WirePoint, encode_hello, encode_message,
    encode_open, parse_frame, robot_info, serve, v1,
};
use omnikin::runtime::hal::{
    EncoderAngles, Encoders, Entropy, EntropyError, MotorCommand, MotorOutputs, NoImu,
};
use omnikin::runtime::{Config, Faults, FixCounters, Frame, Mode, PlanStatus, Runtime};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{MAX_WHEELS, Pose2, Robot};
use proptest::prelude::*;

fn f() -> impl Strategy<Value = f32> {
    // Any f32 bit pattern except NaN (NaN != NaN would break equality, not the codec).
    any::<f32>().prop_filter("not NaN", |x| !x.is_nan())
}
fn f3() -> impl Strategy<Value = [f32; 3]> {
    [f(), f(), f()]
}
fn f6() -> impl Strategy<Value = [f32; MAX_WHEELS]> {
    [f(), f(), f(), f(), f(), f()]
}

fn point() -> impl Strategy<Value = WirePoint> {
    (f(), f3(), f3()).prop_map(|(t, pose, twist)| WirePoint { t, pose, twist })
}

fn mode() -> impl Strategy<Value = Mode> {
    prop_oneof![
        Just(Mode::Idle),
        Just(Mode::Velocity),
        Just(Mode::Trajectory),
        Just(Mode::Stopping),
        Just(Mode::EStop)
    ]
}

fn telemetry() -> impl Strategy<Value = Telemetry> {
    (
        (
            any::<u64>(),
            mode(),
            any::<u16>(),
            any::<u16>(),
            f3(),
            f3(),
            f3(),
        ),
        (f6(), f6(), f6(), f6(), f3(), f3(), 1u8..=6),
        (
            any::<(u16, u16, u16, bool)>(),
            f(),
            f3(),
            f(),
            any::<u32>(),
            any::<u64>(),
        ),
        (any::<[u32; 11]>(), any::<u64>(), any::<u64>(), any::<u64>()),
    )
        .prop_map(|(a, b, c, (l, ack_seq, estop_seq, clear_seq))| Telemetry {
            time_us: a.0,
            mode: a.1,
            faults: Faults(a.2),
            fault_history: Faults(a.3),
            pose: a.4,
            twist: a.5,
            command: a.6,
            wheels: b.6,
            wheel_rates: b.0,
            steer_rates: b.1,
            wheel_angles: b.2,
            steer_angles: b.3,
            gyro: b.4,
            accel: b.5,
            plan: PlanStatus {
                id: c.0.0,
                received: c.0.1,
                len: c.0.2,
                done: c.0.3,
            },
            plan_time: c.1,
            reference: c.2,
            slip_residual: c.3,
            rejected: c.4,
            last_command_us: c.5,
            link: LinkCounters {
                ok: l[0],
                framing: l[1],
                crc: l[2],
                version: l[3],
                auth: l[4],
                replay: l[5],
                malformed: l[6],
                session: l[7],
                entropy: l[8],
                throttled: l[9],
                stale: l[10],
            },
            ack_seq,
            estop_seq,
            clear_seq,
        })
}

fn message() -> impl Strategy<Value = Message> {
    prop_oneof![
        Just(Message::Heartbeat),
        (any::<bool>(), f(), f(), f()).prop_map(|(w, vx, vy, yaw_rate)| Message::SetVelocity {
            frame: if w { Frame::World } else { Frame::Robot },
            vx,
            vy,
            yaw_rate
        }),
        (any::<u16>(), any::<u16>()).prop_map(|(id, len)| Message::PlanBegin { id, len }),
        (any::<u16>(), any::<u16>()).prop_map(|(id, len)| Message::PlanSplice { id, len }),
        (
            any::<u16>(),
            any::<u16>(),
            prop::collection::vec(point(), 0..=CHUNK_POINTS)
        )
            .prop_map(|(id, offset, pts)| Message::PlanChunk {
                id,
                offset,
                points: heapless::Vec::from_slice(&pts).unwrap(),
            }),
        any::<u16>().prop_map(|id| Message::PlanStart { id }),
        Just(Message::Stop),
        Just(Message::EStop),
        Just(Message::Clear),
        (f(), f(), f()).prop_map(|(x, y, heading)| Message::SetPose { x, y, heading }),
        telemetry().prop_map(Message::Telemetry),
        Just(Message::SessionEnd(EndReason::TakenOver)),
        Just(Message::Bye),
        any::<(u64, u32, u32)>().prop_map(|(holder, idle_ms, held_s)| Message::Busy(
            omnikin::link::Busy {
                holder,
                idle_ms,
                held_s
            }
        )),
        (any::<u64>(), f(), f(), prop::option::of(f()), f(), f()).prop_map(
            |(capture_us, x, y, heading, std_xy, std_heading)| Message::Fix(WireFix {
                capture_us,
                x,
                y,
                heading,
                std_xy,
                std_heading,
            })
        ),
        (any::<u64>(), f3(), f3(), f(), f(), any::<[u32; 6]>()).prop_map(
            |(time_us, covariance, odometry, gyro_bias, wheel_scale, c)| Message::Estimate(
                Estimate {
                    time_us,
                    covariance,
                    odometry,
                    gyro_bias,
                    wheel_scale,
                    fixes: FixCounters {
                        accepted: c[0],
                        rejected: c[1],
                        too_late: c[2],
                        recoveries: c[3],
                    },
                    events: EventCounters {
                        slips: c[4],
                        collisions: c[5],
                    },
                }
            )
        ),
        (any::<u64>(), f3()).prop_map(|(time_us, pose)| Message::Truth(SimTruth { time_us, pose })),
    ]
}

/// Test entropy: xorshift64* (a robot uses its TRNG, a PC its OS).
struct TestRng(u64);
impl Entropy for TestRng {
    fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError> {
        for b in buf {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            *b = (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 56) as u8;
        }
        Ok(())
    }
}

/// An entropy source that has failed.
struct NoEntropy;
impl Entropy for NoEntropy {
    fn fill(&mut self, _: &mut [u8]) -> Result<(), EntropyError> {
        Err(EntropyError)
    }
}

fn key() -> Key {
    Key::new(b"shared secret, 32 bytes long ...").unwrap()
}

fn info(authenticated: bool) -> RobotInfo {
    RobotInfo {
        protocol: PROTOCOL_VERSION,
        kind: RobotKind::Sphere,
        plan_capacity: 4096,
        rate_hz: 100.0,
        watchdog: 0.5,
        authenticated,
        limits: RobotLimits {
            max_accel: 1.0,
            max_yaw_accel: 4.0,
            max_jerk: f32::INFINITY,
        },
    }
}

/// The robot's end with its entropy; frames as on the wire (delimiter included).
struct Bot {
    link: RobotLink,
    rng: TestRng,
    info: RobotInfo,
    /// Robot clock, µs.
    now: u64,
    /// The transport address the next frames come from.
    peer: Vec<u8>,
}

impl Bot {
    fn new(key: Option<Key>, seed: u64) -> Self {
        let info = info(key.is_some());
        Bot {
            link: RobotLink::new(key),
            rng: TestRng(seed),
            info,
            now: 0,
            peer: b"operator".to_vec(),
        }
    }
    /// Receives one wire frame; returns the event and the reply bytes.
    fn rx(&mut self, wire: &[u8]) -> (Result<RobotEvent, DropReason>, Vec<u8>) {
        let mut f = wire[..wire.len() - 1].to_vec();
        let mut reply = [0u8; MAX_FRAME];
        let r = self.link.receive(
            &mut f,
            self.now,
            &self.peer,
            &self.info,
            &mut self.rng,
            &mut reply,
        );
        let n = match &r {
            Ok(RobotEvent::Hello(n) | RobotEvent::Busy(n)) => *n,
            Ok(RobotEvent::Message {
                replaced: Some(n), ..
            }) => *n,
            _ => 0,
        };
        (r, reply[..n].to_vec())
    }
    fn tx(&mut self, m: &Message) -> Result<Vec<u8>, EncodeError> {
        let mut b = [0u8; MAX_FRAME];
        let n = self.link.encode(m, &mut b)?;
        Ok(b[..n].to_vec())
    }
}

fn op_rx(op: &mut OperatorLink, wire: &[u8]) -> Result<OperatorEvent, DropReason> {
    let mut f = wire[..wire.len() - 1].to_vec();
    op.receive(&mut f)
}

fn op_tx(op: &mut OperatorLink, m: &Message) -> Vec<u8> {
    let mut b = [0u8; MAX_FRAME];
    let n = op.encode(m, &mut b).unwrap();
    b[..n].to_vec()
}

fn op_hello(op: &mut OperatorLink, rng: &mut TestRng) -> Vec<u8> {
    let mut b = [0u8; MAX_FRAME];
    let n = op.hello(rng, &mut b).unwrap();
    b[..n].to_vec()
}

/// Handshake and key confirmation (a heartbeat in an open frame, taking over if need be);
/// returns every operator → robot frame sent.
fn connect(op: &mut OperatorLink, bot: &mut Bot, rng: &mut TestRng) -> Vec<Vec<u8>> {
    op.set_take_over(true);
    let hello = op_hello(op, rng);
    let (r, ack) = bot.rx(&hello);
    assert!(matches!(r, Ok(RobotEvent::Hello(_))), "{r:?}");
    assert!(ack.len() <= hello.len(), "anti-amplification");
    assert!(matches!(op_rx(op, &ack), Ok(OperatorEvent::Established(_))));
    let hb = op_tx(op, &Message::Heartbeat);
    let (r, _) = bot.rx(&hb);
    assert!(
        matches!(
            r,
            Ok(RobotEvent::Message {
                new_session: true,
                ..
            })
        ),
        "{r:?}"
    );
    assert_eq!(bot.link.session_id(), op.session_id());
    vec![hello, hb]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn encode_then_decode_is_the_identity(msg in message(), session in 1u64.., seq in 1u64.., keyed in any::<bool>()) {
        let k = key();
        let mac = keyed.then(|| k.mac());
        let mut buf = [0u8; MAX_FRAME];
        let n = encode_message(session, seq, &msg, mac, &mut buf).unwrap();
        prop_assert!(n <= MAX_FRAME);
        prop_assert_eq!(buf[n - 1], 0);
        prop_assert!(buf[..n - 1].iter().all(|&b| b != 0), "COBS leaves no zero inside");
        let p = parse_frame(&mut buf[..n - 1]).unwrap();
        prop_assert_eq!((p.header.kind, p.header.session, p.header.seq, p.header.tagged), (FrameKind::Session, session, seq, keyed));
        prop_assert_eq!(p.verify(mac), Ok(()));
        prop_assert_eq!(omnikin::link::decode_message(p.body).unwrap(), msg);
    }

    #[test]
    fn random_bytes_never_panic_and_are_counted(bytes in prop::collection::vec(any::<u8>(), 0..800)) {
        for key in [None, Some(key())] {
            let mut bot = Bot::new(key.clone(), 7);
            let mut op = OperatorLink::new(key.clone());
            let mut reader = FrameReader::<MAX_FRAME>::new();
            let mut frames = 0u32;
            reader.feed(&bytes, |f| {
                frames += 1;
                match f {
                    Some(f) => {
                        let mut copy = f.to_vec();
                        let mut reply = [0u8; MAX_FRAME];
                        let _ = bot.link.receive(f, 0, &[], &bot.info, &mut bot.rng, &mut reply);
                        let _ = op.receive(&mut copy);
                    }
                    None => {
                        bot.link.count_framing_drop();
                        op.count_framing_drop();
                    }
                }
            });
            if reader.end_of_datagram() {
                frames += 1;
                bot.link.count_framing_drop();
                op.count_framing_drop();
            }
            for c in [*bot.link.counters(), *op.counters()] {
                prop_assert_eq!(c.ok + c.dropped(), frames);
            }
            let mut copy = bytes.clone();
            let _ = parse_frame(&mut copy);
            let mut copy = bytes.clone();
            let _ = v1::parse(&mut copy, key.as_ref());
        }
    }

    #[test]
    fn any_single_byte_change_is_dropped(msg in message(), pos in any::<prop::sample::Index>(), x in 1u8..) {
        // Unkeyed: the CRC and the session id alone must catch it.
        let mut rng = TestRng(3);
        let mut bot = Bot::new(None, 5);
        let mut op = OperatorLink::new(None);
        connect(&mut op, &mut bot, &mut rng);
        let mut f = op_tx(&mut op, &msg);
        let i = pos.index(f.len() - 1);
        let was = f[i];
        f[i] ^= x;
        if f[i] == 0 {
            // A new delimiter would make two frames; keep it one corrupt frame (and a changed
            // one: 0x80 ^ 0x80 turned back into 0x80 once, an unchanged frame rightly accepted).
            f[i] = if was == 0x80 { 0x81 } else { 0x80 };
        }
        prop_assert_ne!(f[i], was);
        let (r, _) = bot.rx(&f);
        prop_assert!(r.is_err(), "corrupt frame accepted: {:?}", r);
        prop_assert_eq!(bot.link.counters().dropped(), 1);
    }
}

#[test]
fn largest_messages_fit_one_frame_and_no_answer_outgrows_its_hello() {
    let p = WirePoint {
        t: f32::MAX,
        pose: [f32::MIN; 3],
        twist: [f32::MAX; 3],
    };
    let chunk = Message::PlanChunk {
        id: u16::MAX,
        offset: u16::MAX,
        points: heapless::Vec::from_slice(&[p; CHUNK_POINTS]).unwrap(),
    };
    let k = key();
    let mut buf = [0u8; MAX_FRAME];
    let n = encode_message(u64::MAX, u64::MAX, &chunk, Some(k.mac()), &mut buf).unwrap();
    println!("largest chunk frame: {n} bytes (MAX_FRAME {MAX_FRAME})");
    assert!(n <= MAX_FRAME);
    // And as an operator's first frame, with the handshake's opening.
    let opening = Opening {
        client_nonce: [0xff; 16],
        epoch: u32::MAX,
        take_over: true,
    };
    let n = encode_open(
        u64::MAX,
        u64::MAX,
        &opening,
        &chunk,
        Some(k.mac()),
        &mut buf,
    )
    .unwrap();
    println!("largest open chunk frame: {n} bytes (MAX_FRAME {MAX_FRAME})");
    assert!(n <= MAX_FRAME);
    let p = parse_frame(&mut buf[..n - 1]).unwrap();
    assert_eq!((p.header.kind, p.opening), (FrameKind::Open, Some(opening)));
    assert_eq!(omnikin::link::decode_message(p.body).unwrap(), chunk);
    // The fix and estimate messages, widest values, keyed and in the largest session.
    let fix = Message::Fix(WireFix {
        capture_us: u64::MAX,
        x: f32::MAX,
        y: f32::MAX,
        heading: Some(f32::MAX),
        std_xy: f32::MAX,
        std_heading: f32::MAX,
    });
    let est = Message::Estimate(Estimate {
        time_us: u64::MAX,
        covariance: [f32::MAX; 3],
        odometry: [f32::MAX; 3],
        gyro_bias: f32::MAX,
        wheel_scale: f32::MAX,
        fixes: FixCounters {
            accepted: u32::MAX,
            rejected: u32::MAX,
            too_late: u32::MAX,
            recoveries: u32::MAX,
        },
        events: EventCounters {
            slips: u32::MAX,
            collisions: u32::MAX,
        },
    });
    let truth = Message::Truth(SimTruth {
        time_us: u64::MAX,
        pose: [f32::MAX; 3],
    });
    for (name, m) in [("fix", &fix), ("estimate", &est), ("truth", &truth)] {
        let n = encode_message(u64::MAX, u64::MAX, m, Some(k.mac()), &mut buf).unwrap();
        println!("largest keyed {name} frame: {n} bytes");
        assert!(n <= MAX_FRAME);
    }
    // The largest HelloAck body is the Hello's padded length.
    let mut widest = info(true);
    widest.plan_capacity = u16::MAX;
    widest.limits = RobotLimits {
        max_accel: f32::MAX,
        max_yaw_accel: f32::NAN,
        max_jerk: f32::INFINITY,
    };
    let ack = omnikin::link::HelloAck {
        info: widest,
        client_nonce: [0xff; 16],
        robot_nonce: [0xff; 16],
        epoch: u32::MAX,
    };
    let mut b = [0u8; 128];
    assert_eq!(
        postcard::to_slice(&ack, &mut b).unwrap().len(),
        HANDSHAKE_BODY
    );
    for keyed in [false, true] {
        let key = keyed.then(key);
        let mut bot = Bot::new(key.clone(), 11);
        bot.info = widest;
        let mut op = OperatorLink::new(key);
        let hello = op_hello(&mut op, &mut TestRng(1));
        let (r, ack) = bot.rx(&hello);
        assert!(matches!(r, Ok(RobotEvent::Hello(_))));
        println!(
            "keyed {keyed}: Hello {} bytes, HelloAck {} bytes",
            hello.len(),
            ack.len()
        );
        assert!(ack.len() <= hello.len());
    }
}

#[test]
fn an_unpadded_hello_is_not_answered() {
    let mut bot = Bot::new(None, 1);
    let h = Hello {
        protocol: PROTOCOL_VERSION,
        client_nonce: [7; 16],
    };
    let mut buf = [0u8; MAX_FRAME];
    let n = omnikin::link::encode_frame_with(
        FrameKind::Hello,
        0,
        0,
        None,
        |b| Ok(postcard::to_slice(&h, b).unwrap().len()),
        &mut buf,
    )
    .unwrap();
    let (r, reply) = bot.rx(&buf[..n]);
    assert_eq!(r, Err(DropReason::Malformed));
    assert!(reply.is_empty());
    // Padded, it is.
    let n = encode_hello(&h, None, &mut buf).unwrap();
    assert!(matches!(bot.rx(&buf[..n]).0, Ok(RobotEvent::Hello(_))));
    assert_eq!(bot.link.counters().malformed, 1);
}

#[test]
fn duplicates_and_replays_in_a_session_are_dropped_and_counted() {
    let mut rng = TestRng(9);
    let mut bot = Bot::new(None, 2);
    let mut op = OperatorLink::new(None);
    connect(&mut op, &mut bot, &mut rng); // seq 1
    let f: Vec<Vec<u8>> = (0..70).map(|_| op_tx(&mut op, &Message::Stop)).collect(); // seq 2..=71
    let mut ok = vec![];
    // 71 first, then 70 (late, in the window), 71 again, 2 (69 behind: outside the window),
    // 8 (63 behind: inside), 8 again.
    for i in [69, 68, 69, 0, 6, 6] {
        if let (Ok(RobotEvent::Message { seq, .. }), _) = bot.rx(&f[i]) {
            ok.push(seq);
        }
    }
    assert_eq!(ok, vec![71, 70, 8]);
    let c = bot.link.counters();
    assert_eq!((c.ok, c.replay, c.dropped()), (5, 3, 3), "{c:?}");
}

#[test]
fn wrong_or_missing_key_and_forged_headers_are_unauthenticated() {
    let k = key();
    let other = Key::new(b"another key of the same length!!").unwrap();
    let mut rng = TestRng(4);
    let mut bot = Bot::new(Some(k.clone()), 3);
    for key in [Some(other), None] {
        let mut op = OperatorLink::new(key);
        let hello = op_hello(&mut op, &mut rng);
        let (r, reply) = bot.rx(&hello);
        assert_eq!(r, Err(DropReason::Auth));
        assert!(reply.is_empty(), "no answer to an unauthenticated Hello");
    }
    assert_eq!(bot.link.session_id(), None);
    // The right key works; a captured frame with a changed seq (CRC fixed up) does not.
    let mut op = OperatorLink::new(Some(k));
    connect(&mut op, &mut bot, &mut rng);
    let f = op_tx(&mut op, &Message::EStop);
    let mut raw = vec![0u8; f.len()];
    let m = cobs::decode(&f[..f.len() - 1], &mut raw).unwrap();
    raw.truncate(m);
    raw[10] = 200; // seq byte
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(&raw[..m - 4]);
    raw[m - 4..].copy_from_slice(&crc.to_le_bytes());
    let mut forged = cobs::encode_vec(&raw);
    forged.push(0);
    assert_eq!(bot.rx(&forged).0, Err(DropReason::Auth));
    // The genuine frame still passes once; a replay of it does not.
    assert!(bot.rx(&f).0.is_ok());
    assert_eq!(bot.rx(&f).0, Err(DropReason::Replay(2)));
    assert_eq!(bot.link.counters().auth, 3);
}

/// A simulated robot: runtime and board whose motors turn as commanded.
struct Plant {
    rt: Runtime<f32, 64>,
    wheel: [f32; MAX_WHEELS],
    rates: [f32; MAX_WHEELS],
    now: u64,
}
struct Enc([f32; MAX_WHEELS]);
impl Encoders<f32> for Enc {
    type Error = ();
    fn read(&mut self) -> Result<EncoderAngles<f32>, ()> {
        Ok(EncoderAngles {
            wheel: self.0,
            steer: [0.0; MAX_WHEELS],
        })
    }
}
struct Out<'a>(&'a mut [f32; MAX_WHEELS]);
impl MotorOutputs<f32> for Out<'_> {
    type Error = ();
    fn set_rates(&mut self, c: &MotorCommand<f32>) -> Result<(), ()> {
        *self.0 = c.wheel;
        Ok(())
    }
}
impl Plant {
    fn new() -> Self {
        let robot = Robot::Sphere(SphereOmni::<f32>::new(SphereParams::preset()).unwrap());
        Plant {
            rt: Runtime::new(robot, Config::new(100.0), Pose2::default()).unwrap(),
            wheel: [0.0; MAX_WHEELS],
            rates: [0.0; MAX_WHEELS],
            now: 0,
        }
    }
    fn cycle(&mut self) -> omnikin::runtime::Status<f32> {
        self.rt.cycle(
            self.now,
            &mut Enc(self.wheel),
            &mut NoImu,
            &mut Out(&mut self.rates),
        );
        let st = self.rt.status();
        for i in 0..3 {
            self.wheel[i] += self.rates[i] * 0.01;
        }
        self.now += 10_000;
        st
    }
    /// One frame into the robot: serve its message; returns the event.
    fn frame(&mut self, bot: &mut Bot, wire: &[u8]) -> Result<RobotEvent, DropReason> {
        let (r, _) = bot.rx(wire);
        if let Ok(RobotEvent::Message { seq, msg, .. }) = &r {
            serve(&mut self.rt, &mut bot.link, *seq, msg, self.now);
        }
        r
    }
}

#[test]
fn observation_1_a_recorded_keyed_session_replayed_after_a_restart_is_rejected() {
    let k = key();
    let mut rng = TestRng(21);
    // The legitimate session, recorded.
    let mut plant = Plant::new();
    let mut bot = Bot::new(Some(k.clone()), 100);
    let mut op = OperatorLink::new(Some(k.clone()));
    let mut recording = connect(&mut op, &mut bot, &mut rng);
    let v = Message::SetVelocity {
        frame: Frame::Robot,
        vx: 0.3,
        vy: 0.0,
        yaw_rate: 0.0,
    };
    for _ in 0..50 {
        let f = op_tx(&mut op, &v);
        assert!(plant.frame(&mut bot, &f).is_ok());
        recording.push(f);
        plant.cycle();
    }
    assert!(
        plant.rt.pose().x > 0.01,
        "the legitimate session moved the robot"
    );
    // The robot restarts (same key, fresh state and nonces), the recording is replayed.
    let mut plant = Plant::new();
    let mut bot = Bot::new(Some(k), 200);
    let mut answers = 0;
    for f in &recording {
        match plant.frame(&mut bot, f) {
            Ok(RobotEvent::Hello(_)) => answers += 1,
            Ok(e) => panic!("replayed frame accepted: {e:?}"),
            Err(e) => assert!(matches!(e, DropReason::Session(_)), "{e:?}"),
        }
        plant.cycle();
    }
    let c = *bot.link.counters();
    println!("replay after restart: {c:?}");
    // The Hello is authentic (it was recorded) and gets one answer no larger than itself; every
    // session frame belongs to a session this robot never had.
    assert_eq!(answers, 1);
    assert_eq!(c.session as usize, recording.len() - 1);
    assert_eq!(c.ok, 1);
    assert_eq!(
        bot.link.session_id(),
        None,
        "the replayer never completes a session"
    );
    assert_eq!(
        bot.tx(&Message::Heartbeat),
        Err(EncodeError::NoSession),
        "no telemetry without a session"
    );
    assert_eq!(plant.rt.pose(), Pose2::default());
    assert_eq!(plant.rt.mode(), Mode::Idle);
}

#[test]
fn observation_2_forged_max_seq_does_not_lock_out_the_operator() {
    let mut rng = TestRng(5);
    let mut bot = Bot::new(None, 6);
    let mut op = OperatorLink::new(None);
    connect(&mut op, &mut bot, &mut rng);
    // An off-path attacker does not know the session id (64 bits from the robot's nonce).
    let mut buf = [0u8; MAX_FRAME];
    for guess in [0u64, 1, 0xdead_beef, u64::MAX] {
        let n = encode_message(guess, u64::MAX, &Message::Stop, None, &mut buf).unwrap();
        assert_eq!(bot.rx(&buf[..n]).0, Err(DropReason::Session(guess)));
    }
    for _ in 0..10 {
        let f = op_tx(&mut op, &Message::Heartbeat);
        assert!(bot.rx(&f).0.is_ok(), "the operator is not locked out");
    }
    assert_eq!(bot.link.counters().session, 4);
}

#[test]
fn observation_2_a_third_party_neither_gets_telemetry_nor_disturbs_the_operator() {
    let mut rng = TestRng(8);
    let mut bot = Bot::new(None, 9);
    let mut op = OperatorLink::new(None);
    connect(&mut op, &mut bot, &mut rng);
    let id = bot.link.session_id();
    // Its heartbeats (with any session id it can make up) are dropped…
    let mut third = OperatorLink::new(None);
    assert_eq!(
        third.encode(&Message::Heartbeat, &mut [0u8; MAX_FRAME]),
        Err(EncodeError::NoSession)
    );
    let mut buf = [0u8; MAX_FRAME];
    let n = encode_message(12345, 1, &Message::Heartbeat, None, &mut buf).unwrap();
    assert_eq!(bot.rx(&buf[..n]).0, Err(DropReason::Session(12345)));
    // …its Hello is answered and changes nothing; the operator's session stays active.
    let h = op_hello(&mut third, &mut rng);
    assert!(matches!(bot.rx(&h).0, Ok(RobotEvent::Hello(_))));
    assert_eq!(bot.link.session_id(), id);
    assert!(bot.rx(&op_tx(&mut op, &Message::Heartbeat)).0.is_ok());
    // Telemetry is in the operator's session: the operator takes it, the third party cannot.
    let t = bot.tx(&Message::SessionEnd(EndReason::TakenOver)).unwrap();
    assert!(op_rx(&mut op, &t).is_ok());
    assert!(matches!(op_rx(&mut third, &t), Err(DropReason::Session(_))));
}

#[test]
fn takeover_only_through_a_valid_handshake() {
    let k = key();
    let mut rng = TestRng(13);
    let mut bot = Bot::new(Some(k.clone()), 14);
    let mut a = OperatorLink::new(Some(k.clone()));
    let rec = connect(&mut a, &mut bot, &mut rng);
    let first = bot.link.session_id().unwrap();
    // A replay of A's own handshake: the Hello gets the same answer no larger than itself and
    // changes nothing; the first frame is a replay.
    let (r, reply) = bot.rx(&rec[0]);
    assert!(matches!(r, Ok(RobotEvent::Hello(_))), "{r:?}");
    assert!(reply.len() <= rec[0].len());
    let (r, reply) = bot.rx(&rec[1]);
    assert!(matches!(r, Err(DropReason::Replay(_))), "{r:?}");
    assert!(reply.is_empty());
    assert_eq!(bot.link.session_id(), Some(first));
    // A Hello recorded from someone else: answered, nothing kept.
    let mut z = OperatorLink::new(Some(k.clone()));
    let zh = op_hello(&mut z, &mut rng);
    assert!(matches!(bot.rx(&zh).0, Ok(RobotEvent::Hello(_))));
    assert_eq!(bot.link.session_id(), Some(first));
    assert!(bot.rx(&op_tx(&mut a, &Message::Heartbeat)).0.is_ok());
    // A session frame with a made-up id and the PSK's tag (not K_s): no such session.
    let mut buf = [0u8; MAX_FRAME];
    let n = encode_message(0x1234, 1, &Message::EStop, Some(k.mac()), &mut buf).unwrap();
    assert_eq!(bot.rx(&buf[..n]).0, Err(DropReason::Session(0x1234)));
    assert_eq!(bot.link.session_id(), Some(first));
    // B completes a handshake without asking to take over: A is live, B is told it is busy.
    let mut b = OperatorLink::new(Some(k));
    let hello = op_hello(&mut b, &mut rng);
    let (_, ack) = bot.rx(&hello);
    assert!(matches!(
        op_rx(&mut b, &ack),
        Ok(OperatorEvent::Established(_))
    ));
    assert_eq!(bot.link.session_id(), Some(first), "not before key proof");
    bot.now += LIVE_US / 2;
    let open = op_tx(&mut b, &Message::Heartbeat);
    let (r, busy) = bot.rx(&open);
    assert!(matches!(r, Ok(RobotEvent::Busy(_))), "{r:?}");
    assert!(
        busy.len() < open.len(),
        "a busy answer is smaller than the frame"
    );
    assert_eq!(bot.link.session_id(), Some(first));
    match op_rx(&mut b, &busy) {
        Ok(OperatorEvent::Busy(x)) => {
            assert_eq!((x.holder, x.idle_ms), (first, (LIVE_US / 2000) as u32));
        }
        r => panic!("{r:?}"),
    }
    assert!(!b.confirmed());
    // The handshake is used up: B's first frame again gets nothing (a copy replayed once A
    // goes quiet opens nothing either).
    assert!(matches!(bot.rx(&open).0, Err(DropReason::Replay(_))));
    bot.now += LIVE_US;
    assert!(matches!(bot.rx(&open).0, Err(DropReason::Replay(_))));
    bot.now -= LIVE_US;
    assert_eq!(bot.link.session_id(), Some(first));
    // Its user acts: a new handshake that takes over; A is told.
    b.set_take_over(true);
    let (_, ack) = bot.rx(&op_hello(&mut b, &mut rng));
    assert!(b.busy().is_none(), "a new handshake");
    assert!(matches!(
        op_rx(&mut b, &ack),
        Ok(OperatorEvent::Established(_))
    ));
    let (r, notice) = bot.rx(&op_tx(&mut b, &Message::Heartbeat));
    assert!(matches!(
        r,
        Ok(RobotEvent::Message {
            new_session: true,
            replaced: Some(_),
            ..
        })
    ));
    assert_eq!(bot.link.session_id(), b.session_id());
    assert!(matches!(
        op_rx(&mut a, &notice),
        Ok(OperatorEvent::Message {
            msg: Message::SessionEnd(EndReason::TakenOver),
            ..
        })
    ));
    assert_eq!(a.ended(), Some(EndReason::TakenOver));
    assert!(matches!(
        bot.rx(&op_tx(&mut a, &Message::Heartbeat)).0,
        Err(DropReason::Session(_))
    ));
    // A's replayed first frame (take-over flag and all) cannot take the robot back.
    let (r, reply) = bot.rx(&rec[1]);
    assert!(matches!(r, Err(DropReason::Replay(_))), "{r:?}");
    assert!(reply.is_empty());
    assert_eq!(bot.link.session_id(), b.session_id());
}

#[test]
fn a_session_that_went_silent_is_not_live_and_opens_without_take_over() {
    let mut rng = TestRng(15);
    let mut bot = Bot::new(None, 16);
    let mut a = OperatorLink::new(None);
    connect(&mut a, &mut bot, &mut rng);
    bot.now += LIVE_US;
    let mut b = OperatorLink::new(None);
    let (_, ack) = bot.rx(&op_hello(&mut b, &mut rng));
    assert!(op_rx(&mut b, &ack).is_ok());
    let (r, _) = bot.rx(&op_tx(&mut b, &Message::Heartbeat));
    assert!(
        matches!(
            r,
            Ok(RobotEvent::Message {
                new_session: true,
                ..
            })
        ),
        "{r:?}"
    );
    assert_eq!(bot.link.session_id(), b.session_id());
}

#[test]
fn an_operator_that_said_bye_is_not_live() {
    let mut rng = TestRng(25);
    let mut bot = Bot::new(None, 26);
    let mut a = OperatorLink::new(None);
    connect(&mut a, &mut bot, &mut rng);
    assert!(bot.rx(&op_tx(&mut a, &Message::Bye)).0.is_ok());
    let mut b = OperatorLink::new(None);
    let (_, ack) = bot.rx(&op_hello(&mut b, &mut rng));
    assert!(op_rx(&mut b, &ack).is_ok());
    let (r, _) = bot.rx(&op_tx(&mut b, &Message::Heartbeat));
    assert!(
        matches!(
            r,
            Ok(RobotEvent::Message {
                new_session: true,
                ..
            })
        ),
        "{r:?}"
    );
}

#[test]
fn a_replayed_hello_from_another_address_opens_nothing_and_the_session_opens_at_the_operators() {
    let k = key();
    let mut rng = TestRng(17);
    let mut bot = Bot::new(Some(k.clone()), 18);
    let mut op = OperatorLink::new(Some(k));
    op.set_take_over(true);
    let hello = op_hello(&mut op, &mut rng);
    let (_, ack) = bot.rx(&hello);
    // The attacker replays the Hello 1000 times from its own address: answers never larger,
    // bound to the attacker's address, nothing kept.
    bot.peer = b"attacker".to_vec();
    let (_, theirs) = bot.rx(&hello);
    assert_ne!(theirs, ack, "an answer is bound to the address it goes to");
    for _ in 0..1000 {
        let (r, reply) = bot.rx(&hello);
        assert!(matches!(r, Ok(RobotEvent::Hello(_))));
        assert_eq!(reply, theirs);
        assert!(reply.len() <= hello.len());
    }
    assert_eq!(bot.link.session_id(), None);
    assert_eq!(
        bot.tx(&Message::Heartbeat),
        Err(EncodeError::NoSession),
        "nothing to stream to anyone"
    );
    // The operator's first frame, copied by an attacker in the path and delivered from the
    // attacker's address first: it does not prove the address, nothing opens.
    assert!(op_rx(&mut op, &ack).is_ok());
    let first = op_tx(&mut op, &Message::Heartbeat);
    assert!(matches!(bot.rx(&first).0, Err(DropReason::Session(_))));
    assert_eq!(bot.link.session_id(), None);
    // From the operator's address it opens the session.
    bot.peer = b"operator".to_vec();
    let (r, _) = bot.rx(&first);
    assert!(matches!(
        r,
        Ok(RobotEvent::Message {
            new_session: true,
            ..
        })
    ));
    // The first frame replayed (from anywhere) is a replay of the open session.
    assert!(matches!(bot.rx(&first).0, Err(DropReason::Replay(1))));
    // The operator is confirmed by the robot's first frame and sends session frames.
    let t = bot.tx(&Message::SessionEnd(EndReason::TakenOver)).unwrap();
    assert!(op_rx(&mut op, &t).is_ok());
    assert!(op.confirmed());
    let next = op_tx(&mut op, &Message::Heartbeat);
    let mut raw = next[..next.len() - 1].to_vec();
    assert_eq!(
        parse_frame(&mut raw).unwrap().header.kind,
        FrameKind::Session
    );
    assert!(bot.rx(&next).0.is_ok());
}

#[test]
fn first_frames_of_old_sessions_are_refused_by_epoch_and_used_nonce() {
    let k = key();
    let mut rng = TestRng(19);
    let mut bot = Bot::new(Some(k.clone()), 20);
    // Six sessions, each taking over from the one before; every first frame recorded.
    let mut firsts = vec![];
    for _ in 0..6 {
        let mut op = OperatorLink::new(Some(k.clone()));
        let rec = connect(&mut op, &mut bot, &mut rng);
        firsts.push(rec[1].clone());
        bot.now += 100_000;
    }
    let active = bot.link.session_id();
    // Replayed within the epochs that opened them: used nonces.
    for f in &firsts {
        let (r, reply) = bot.rx(f);
        assert!(matches!(r, Err(DropReason::Replay(_))), "{r:?}");
        assert!(reply.is_empty());
    }
    assert_eq!(bot.link.session_id(), active);
    // Two epochs later the epochs are gone: unknown sessions, nothing derived (the active
    // session's own first frame is a replay in its window).
    bot.now += 2 * EPOCH_US;
    for f in &firsts[..5] {
        assert!(matches!(bot.rx(f).0, Err(DropReason::Session(_))));
    }
    assert!(matches!(bot.rx(&firsts[5]).0, Err(DropReason::Replay(_))));
    assert_eq!(bot.link.session_id(), active);
    // A HelloAck kept back longer than two epochs is useless too.
    let mut late = OperatorLink::new(Some(k.clone()));
    late.set_take_over(true);
    let (_, ack) = bot.rx(&op_hello(&mut late, &mut rng));
    assert!(op_rx(&mut late, &ack).is_ok());
    bot.now += 2 * EPOCH_US;
    assert!(matches!(
        bot.rx(&op_tx(&mut late, &Message::Heartbeat)).0,
        Err(DropReason::Session(_))
    ));
    // One epoch later it still works.
    let mut prompt = OperatorLink::new(Some(k));
    prompt.set_take_over(true);
    let (_, ack) = bot.rx(&op_hello(&mut prompt, &mut rng));
    assert!(op_rx(&mut prompt, &ack).is_ok());
    bot.now += EPOCH_US;
    assert!(matches!(
        bot.rx(&op_tx(&mut prompt, &Message::Heartbeat)).0,
        Ok(RobotEvent::Message {
            new_session: true,
            ..
        })
    ));
}

#[test]
fn more_sessions_than_an_epoch_remembers_still_open_and_never_replay() {
    let mut rng = TestRng(23);
    let mut bot = Bot::new(None, 24);
    let mut firsts = vec![];
    for _ in 0..3 * USED_PER_EPOCH {
        let mut op = OperatorLink::new(None);
        let rec = connect(&mut op, &mut bot, &mut rng);
        firsts.push(rec[1].clone());
    }
    let active = bot.link.session_id();
    for f in &firsts {
        let r = bot.rx(f).0;
        assert!(
            matches!(r, Err(DropReason::Replay(_) | DropReason::Session(_))),
            "{r:?}"
        );
    }
    assert_eq!(bot.link.session_id(), active);
}

#[test]
fn a_retransmitted_hello_gets_the_same_session() {
    let mut rng = TestRng(31);
    let mut bot = Bot::new(Some(key()), 32);
    let mut op = OperatorLink::new(Some(key()));
    let h1 = op_hello(&mut op, &mut rng);
    let h2 = op_hello(&mut op, &mut rng);
    assert_eq!(h1, h2, "a retransmission reuses the nonce");
    let (_, a1) = bot.rx(&h1);
    let (_, a2) = bot.rx(&h2);
    assert_eq!(a1, a2, "and gets the same answer");
    assert!(op_rx(&mut op, &a1).is_ok());
    assert_eq!(op_rx(&mut op, &a2), Err(DropReason::Replay(0)));
    assert!(bot.rx(&op_tx(&mut op, &Message::Heartbeat)).0.is_ok());
    let c = bot.link.counters();
    assert_eq!(
        (c.ok, c.replay),
        (3, 0),
        "the repeat is answered, not dropped"
    );
    // Once the session is open, the same Hello gets the same answer and opens nothing.
    let id = bot.link.session_id();
    let (r, reply) = bot.rx(&h1);
    assert!(matches!(r, Ok(RobotEvent::Hello(_))));
    assert_eq!(reply, a1);
    assert_eq!(bot.link.session_id(), id);
    // The answer to someone else's Hello is not this operator's.
    let mut other = OperatorLink::new(Some(key()));
    let _ = op_hello(&mut other, &mut rng);
    assert!(matches!(
        op_rx(&mut other, &a1),
        Err(DropReason::Session(_))
    ));
}

#[test]
fn observation_3_a_replayed_estop_confirmation_is_not_taken_for_a_new_one() {
    let k = key();
    let mut rng = TestRng(41);
    let mut plant = Plant::new();
    let mut bot = Bot::new(Some(k.clone()), 42);
    let mut a = OperatorLink::new(Some(k.clone()));
    connect(&mut a, &mut bot, &mut rng);
    let estop = op_tx(&mut a, &Message::EStop);
    let sa = 2;
    assert!(plant.frame(&mut bot, &estop).is_ok());
    let st = plant.cycle();
    let old = bot
        .tx(&Message::Telemetry(bot.link.telemetry(&st)))
        .unwrap();
    match op_rx(&mut a, &old) {
        Ok(OperatorEvent::Message {
            msg: Message::Telemetry(t),
            ..
        }) => assert_eq!((t.mode, t.estop_seq), (Mode::EStop, sa)),
        r => panic!("{r:?}"),
    }
    assert!(
        plant
            .frame(&mut bot, &op_tx(&mut a, &Message::Clear))
            .is_ok()
    );
    let st = plant.cycle();
    assert_eq!(bot.link.telemetry(&st).estop_seq, 0);
    // A new operator session; the old confirmation is replayed at it.
    let mut b = OperatorLink::new(Some(k));
    connect(&mut b, &mut bot, &mut rng);
    assert!(matches!(op_rx(&mut b, &old), Err(DropReason::Session(_))));
    let sb = b.next_seq().unwrap();
    assert!(
        plant
            .frame(&mut bot, &op_tx(&mut b, &Message::EStop))
            .is_ok()
    );
    let st = plant.cycle();
    let fresh = bot
        .tx(&Message::Telemetry(bot.link.telemetry(&st)))
        .unwrap();
    match op_rx(&mut b, &fresh) {
        Ok(OperatorEvent::Message {
            msg: Message::Telemetry(t),
            ..
        }) => assert_eq!((t.mode, t.estop_seq), (Mode::EStop, sb)),
        r => panic!("{r:?}"),
    }
    // Within the session, a repeat of a telemetry frame is a replay.
    assert_eq!(op_rx(&mut b, &fresh), Err(DropReason::Replay(1)));
}

#[test]
fn v1_peers_and_v3_peers_name_the_mismatch() {
    // A v1 Hello built by hand from the v1 format: version 1, flags 0, seq, variant 0, protocol 1.
    let mut raw = vec![1u8, 0];
    raw.extend(77u64.to_le_bytes());
    raw.extend([0, 1]);
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(&raw);
    raw.extend(crc.to_le_bytes());
    let mut hand = cobs::encode_vec(&raw);
    hand.push(0);
    let mut buf = [0u8; MAX_FRAME];
    let n = v1::encode_hello(77, None, &mut buf).unwrap();
    assert_eq!(&buf[..n], &hand[..], "v1 framing unchanged");
    for key in [None, Some(key())] {
        let mut bot = Bot::new(key.clone(), 1);
        let mut hello = [0u8; MAX_FRAME];
        let n = v1::encode_hello(5, key.as_ref(), &mut hello).unwrap();
        assert_eq!(bot.rx(&hello[..n]).0, Err(DropReason::Version(1)));
        assert_eq!(bot.link.counters().version, 1);
        // The robot's answer is what a v1 operator decodes as "protocol 4": v1's body exactly
        // (`v1::parse` refuses trailing bytes), so the limits are not in it.
        let m = bot.link.version_reply(&bot.info, &mut buf).unwrap();
        let (_, f) = v1::parse(&mut buf[..m - 1].to_vec(), key.as_ref()).unwrap();
        assert!(matches!(f, v1::V1Frame::HelloAck(i) if i.protocol == PROTOCOL_VERSION));
        if key.is_some() {
            let other = Key::new(b"another key of the same length!!").unwrap();
            assert_eq!(v1::parse(&mut buf[..m - 1].to_vec(), Some(&other)), None);
        }
        // A v1 robot's answer reaches a later operator as a version drop, readable as v1.
        let mut op = OperatorLink::new(key.clone());
        let n = v1::encode_hello_ack(
            &v1::V1RobotInfo {
                protocol: 1,
                ..v1::V1RobotInfo::from(&info(false))
            },
            1,
            key.as_ref(),
            &mut buf,
        )
        .unwrap();
        assert_eq!(op_rx(&mut op, &buf[..n]), Err(DropReason::Version(1)));
        let (_, f) = v1::parse(&mut buf[..n - 1].to_vec(), key.as_ref()).unwrap();
        assert!(matches!(f, v1::V1Frame::HelloAck(i) if i.protocol == 1));
    }
}

#[test]
fn wrong_direction_and_entropy_failures_are_counted() {
    let mut rng = TestRng(51);
    let mut bot = Bot::new(None, 52);
    let mut op = OperatorLink::new(None);
    let hello = op_hello(&mut op, &mut rng);
    assert_eq!(op_rx(&mut op, &hello), Err(DropReason::Malformed));
    let (_, ack) = bot.rx(&hello);
    assert_eq!(bot.rx(&ack).0, Err(DropReason::Malformed));
    let mut broken = RobotLink::new(None);
    let mut f = hello[..hello.len() - 1].to_vec();
    let r = broken.receive(
        &mut f,
        0,
        &[],
        &info(false),
        &mut NoEntropy,
        &mut [0u8; MAX_FRAME],
    );
    assert_eq!(r, Err(DropReason::Entropy));
    assert_eq!(broken.counters().entropy, 1);
    let mut fresh = OperatorLink::new(None);
    assert_eq!(
        fresh.hello(&mut NoEntropy, &mut [0u8; MAX_FRAME]),
        Err(EncodeError::Entropy)
    );
}

#[test]
fn a_session_survives_loss_reordering_and_duplication() {
    let mut rng = TestRng(61);
    let mut bot = Bot::new(Some(key()), 62);
    let mut op = OperatorLink::new(Some(key()));
    connect(&mut op, &mut bot, &mut rng);
    let mut chan = TestRng(63);
    let mut roll = || {
        let mut b = [0u8; 1];
        chan.fill(&mut b).unwrap();
        b[0]
    };
    let mut queue: Vec<Vec<u8>> = vec![];
    let (mut lost, mut dup, mut sent) = (0u32, 0u32, 0u32);
    for k in 0..2000 {
        let f = op_tx(
            &mut op,
            &Message::SetPose {
                x: k as f32,
                y: 0.0,
                heading: 0.0,
            },
        );
        sent += 1;
        let r = roll();
        if r < 51 {
            lost += 1; // 20 %
            continue;
        }
        if r < 77 {
            dup += 1; // 10 %
            queue.push(f.clone());
        }
        queue.push(f);
        // Reorder: swap with one of the last 8 queued.
        let j = queue.len() - 1 - (roll() as usize % 8).min(queue.len() - 1);
        let last = queue.len() - 1;
        queue.swap(j, last);
    }
    let mut seen = std::collections::HashSet::new();
    for f in &queue {
        if let (Ok(RobotEvent::Message { seq, .. }), _) = bot.rx(f) {
            assert!(seen.insert(seq), "seq {seq} executed twice");
        }
    }
    let c = *bot.link.counters();
    println!("{sent} sent, {lost} lost, {dup} duplicated: {c:?}");
    assert_eq!(
        seen.len() as u32,
        sent - lost,
        "every delivered frame executed once"
    );
    assert_eq!(c.replay, dup);
    assert_eq!(c.dropped(), dup);
}

#[test]
fn a_flood_of_hellos_within_the_round_trip_changes_nothing() {
    let mut rng = TestRng(71);
    let mut bot = Bot::new(None, 72);
    let mut op = OperatorLink::new(None);
    let hello = op_hello(&mut op, &mut rng);
    let (_, ack) = bot.rx(&hello);
    // Ten thousand other Hellos (and replays of this one) before the operator's first frame.
    let others: Vec<Vec<u8>> = (0..100)
        .map(|_| op_hello(&mut OperatorLink::new(None), &mut rng))
        .collect();
    for k in 0..10_000 {
        let h = if k % 7 == 0 { &hello } else { &others[k % 100] };
        assert!(matches!(bot.rx(h).0, Ok(RobotEvent::Hello(_))));
    }
    assert!(op_rx(&mut op, &ack).is_ok());
    let r = bot.rx(&op_tx(&mut op, &Message::Heartbeat)).0;
    assert!(
        matches!(
            r,
            Ok(RobotEvent::Message {
                new_session: true,
                ..
            })
        ),
        "{r:?}"
    );
}

#[test]
fn observation_3_held_back_clear_and_motion_after_an_estop_leave_the_robot_stopped() {
    let k = key();
    let mut rng = TestRng(91);
    let mut plant = Plant::new();
    let mut bot = Bot::new(Some(k.clone()), 92);
    let mut op = OperatorLink::new(Some(k));
    connect(&mut op, &mut bot, &mut rng);
    let v = Message::SetVelocity {
        frame: Frame::Robot,
        vx: 1.0,
        vy: 0.0,
        yaw_rate: 0.0,
    };
    // The operator drives, e-stops, clears and drives again; an attacker in the path holds
    // back an earlier clear and velocity frames and delivers them after the e-stop.
    let held_clear = op_tx(&mut op, &Message::Clear);
    let held_v: Vec<Vec<u8>> = (0..5).map(|_| op_tx(&mut op, &v)).collect();
    let estop = op_tx(&mut op, &Message::EStop);
    let estop_seq = 8;
    assert!(plant.frame(&mut bot, &estop).is_ok());
    let st = plant.cycle();
    assert_eq!(st.mode, Mode::EStop);
    for f in std::iter::once(&held_clear).chain(&held_v) {
        let r = plant.frame(&mut bot, f);
        assert!(r.is_ok(), "authentic and inside the window: {r:?}");
    }
    for _ in 0..50 {
        plant.cycle();
    }
    let st = plant.cycle();
    assert_eq!(st.mode, Mode::EStop, "still e-stopped");
    assert_eq!(plant.rt.pose(), Pose2::default(), "never moved");
    assert_eq!(bot.link.counters().stale, 6);
    let t = bot.link.telemetry(&st);
    assert_eq!((t.estop_seq, t.clear_seq), (estop_seq, 0));
    // The operator's own clear (after the e-stop) ends it, and the telemetry names it.
    let clear = op_tx(&mut op, &Message::Clear);
    assert!(plant.frame(&mut bot, &clear).is_ok());
    let st = plant.cycle();
    assert_ne!(st.mode, Mode::EStop);
    let t = bot.link.telemetry(&st);
    assert_eq!((t.estop_seq, t.clear_seq), (0, estop_seq + 1));
    // The held-back motion is void for good: delivered now, it still does nothing.
    let late = held_v[0].clone();
    assert!(matches!(
        plant.frame(&mut bot, &late).unwrap_err(),
        DropReason::Replay(_)
    ));
    let fresh = op_tx(&mut op, &v);
    assert!(plant.frame(&mut bot, &fresh).is_ok());
    for _ in 0..20 {
        plant.cycle();
    }
    assert!(plant.rt.pose().x > 0.0, "a command after the clear drives");
}

#[test]
fn a_hello_ack_with_a_session_id_or_a_forged_tag_is_refused() {
    let k = key();
    let mut rng = TestRng(93);
    let mut bot = Bot::new(Some(k.clone()), 94);
    let mut op = OperatorLink::new(Some(k.clone()));
    let hello = op_hello(&mut op, &mut rng);
    let (_, ack) = bot.rx(&hello);
    // The same answer under another key, or re-framed with a session id, is refused.
    let other = Key::new(b"another key of the same length!!").unwrap();
    let mut raw = ack[..ack.len() - 1].to_vec();
    let p = parse_frame(&mut raw).unwrap();
    let body = p.body.to_vec();
    let mut buf = [0u8; MAX_FRAME];
    let n = omnikin::link::encode_frame_with(
        FrameKind::HelloAck,
        0,
        0,
        Some(other.mac()),
        |b| {
            b[..body.len()].copy_from_slice(&body);
            Ok(body.len())
        },
        &mut buf,
    )
    .unwrap();
    assert_eq!(op_rx(&mut op, &buf[..n]), Err(DropReason::Auth));
    let n = omnikin::link::encode_frame_with(
        FrameKind::HelloAck,
        7,
        0,
        Some(k.mac()),
        |b| {
            b[..body.len()].copy_from_slice(&body);
            Ok(body.len())
        },
        &mut buf,
    )
    .unwrap();
    assert_eq!(op_rx(&mut op, &buf[..n]), Err(DropReason::Malformed));
    assert!(matches!(
        op_rx(&mut op, &ack),
        Ok(OperatorEvent::Established(_))
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// The link's COBS codec against the `cobs` crate (which v1 peers use), both ways.
    #[test]
    fn cobs_matches_the_cobs_crate(data in prop::collection::vec(
        prop_oneof![3 => any::<u8>(), 1 => Just(0u8)], 0..700)) {
        use omnikin::link::{cobs_decode_in_place, cobs_encode, cobs_max_len};
        let mut ours = vec![0u8; cobs_max_len(data.len())];
        let n = cobs_encode(&data, &mut ours).unwrap();
        prop_assert!(ours[..n].iter().all(|&b| b != 0));
        prop_assert_eq!(&cobs::decode_vec(&ours[..n]).unwrap(), &data);
        let theirs = cobs::encode_vec(&data);
        let mut t = theirs.clone();
        let m = cobs_decode_in_place(&mut t).unwrap();
        prop_assert_eq!(&t[..m], &data[..]);
        let mut o = ours[..n].to_vec();
        let m = cobs_decode_in_place(&mut o).unwrap();
        prop_assert_eq!(&o[..m], &data[..]);
        prop_assert!(cobs_encode(&data, &mut vec![0u8; cobs_max_len(data.len()) - 1]).is_none());
    }

    /// Arbitrary bytes: never a panic; where the `cobs` crate accepts a zero-free input, the
    /// same bytes come out.
    #[test]
    fn cobs_decoder_on_arbitrary_bytes(data in prop::collection::vec(any::<u8>(), 0..600)) {
        use omnikin::link::cobs_decode_in_place;
        let mut a = data.clone();
        let ours = cobs_decode_in_place(&mut a);
        let mut b = data.clone();
        if let (Some(n), Ok(m)) = (ours, cobs::decode_in_place(&mut b)) {
            prop_assert_eq!(&a[..n], &b[..m]);
        }
        if !data.contains(&0) && ours.is_none() {
            prop_assert!(cobs::decode_vec(&data).is_err(), "we reject what cobs accepts");
        }
    }
}

#[test]
fn reflected_frames_are_dropped_and_do_not_move_the_windows() {
    // Both directions of a session share K_s: without a direction check the robot accepts its
    // own telemetry sent back to it (a valid tag, a fresh seq), counts it `ok` and advances its
    // window to the telemetry's seq, so the operator's next commands (lower seqs) land in
    // `replay` — a lock-out by one reflected frame, with a key. Likewise the other way.
    for keyed in [true, false] {
        let k = keyed.then(key);
        let mut rng = TestRng(81);
        let mut bot = Bot::new(k.clone(), 82);
        let mut op = OperatorLink::new(k);
        connect(&mut op, &mut bot, &mut rng);
        let status = Plant::new().cycle();
        // The robot streams 100 telemetry frames; the operator has sent 1 frame.
        let mut tele = vec![];
        for _ in 0..100 {
            let t = bot.link.telemetry(&status);
            tele.push(bot.tx(&Message::Telemetry(t)).unwrap());
        }
        for t in &tele[..99] {
            assert!(op_rx(&mut op, t).is_ok());
        }
        let ok = bot.link.counters().ok;
        // The newest telemetry frame, reflected back to the robot.
        let (r, reply) = bot.rx(&tele[99]);
        assert_eq!(r, Err(DropReason::Malformed), "keyed {keyed}");
        assert!(reply.is_empty());
        assert_eq!(
            bot.link.counters().ok,
            ok,
            "a reflected frame is not accepted"
        );
        assert_eq!(bot.link.counters().malformed, 1);
        // The operator's next command still gets through, and ack_seq names it.
        let cmd = op_tx(&mut op, &Message::Stop);
        let (r, _) = bot.rx(&cmd);
        assert!(matches!(r, Ok(RobotEvent::Message { seq: 2, .. })), "{r:?}");
        assert_eq!(bot.link.telemetry(&status).ack_seq, 2);
        // The other way: the operator has sent 200 more commands, then one of them comes
        // back to it; it is dropped and the robot's next telemetry (seq 101, far below the
        // reflected seq 203) still arrives.
        for _ in 0..200 {
            let f = op_tx(&mut op, &Message::Heartbeat);
            assert!(bot.rx(&f).0.is_ok());
        }
        let reflected = op_tx(&mut op, &Message::Heartbeat);
        let before = op.counters().malformed;
        assert_eq!(op_rx(&mut op, &reflected), Err(DropReason::Malformed));
        assert_eq!(op.counters().malformed, before + 1);
        let t = bot.link.telemetry(&status);
        let next = bot.tx(&Message::Telemetry(t)).unwrap();
        assert!(
            matches!(
                op_rx(&mut op, &next),
                Ok(OperatorEvent::Message { seq: 101, .. })
            ),
            "keyed {keyed}"
        );
    }
}

/// The largest telemetry (every varint at its widest, MAX_WHEELS wheels and steer motors)
/// still fits a frame body: the per-wheel arrays keep the encoding bounded.
#[test]
fn largest_telemetry_fits_a_frame() {
    let m = f32::MAX;
    let t = Telemetry {
        time_us: u64::MAX,
        mode: Mode::EStop,
        faults: Faults(u16::MAX),
        fault_history: Faults(u16::MAX),
        pose: [m; 3],
        twist: [m; 3],
        command: [m; 3],
        wheels: MAX_WHEELS as u8,
        wheel_rates: [m; MAX_WHEELS],
        steer_rates: [m; MAX_WHEELS],
        wheel_angles: [m; MAX_WHEELS],
        steer_angles: [m; MAX_WHEELS],
        gyro: [m; 3],
        accel: [m; 3],
        plan: PlanStatus {
            id: u16::MAX,
            received: u16::MAX,
            len: u16::MAX,
            done: true,
        },
        plan_time: m,
        reference: [m; 3],
        slip_residual: m,
        rejected: u32::MAX,
        last_command_us: u64::MAX,
        link: LinkCounters {
            ok: u32::MAX,
            framing: u32::MAX,
            crc: u32::MAX,
            version: u32::MAX,
            auth: u32::MAX,
            replay: u32::MAX,
            malformed: u32::MAX,
            session: u32::MAX,
            entropy: u32::MAX,
            throttled: u32::MAX,
            stale: u32::MAX,
        },
        ack_seq: u64::MAX,
        estop_seq: u64::MAX,
        clear_seq: u64::MAX,
    };
    let msg = Message::Telemetry(t);
    let k = key();
    let mut buf = [0u8; MAX_FRAME];
    let n = encode_message(u64::MAX, u64::MAX, &msg, Some(k.mac()), &mut buf).unwrap();
    let p = parse_frame(&mut buf[..n - 1]).unwrap();
    assert_eq!(omnikin::link::decode_message(p.body).unwrap(), msg);
}

/// Protocol 4: the HelloAck carries the runtime's effective body limits inside the PSK-tagged
/// body, so the operator learns them from the handshake; a HelloAck whose limits were changed
/// on the way (CRC recomputed, as an attacker would) is refused by the tag.
#[test]
fn the_hello_ack_carries_the_runtimes_body_limits_under_the_tag() {
    let robot = Robot::Sphere(SphereOmni::<f32>::new(SphereParams::preset()).unwrap());
    let mut cfg = Config::new(100.0);
    cfg.slew.accel = 0.75;
    cfg.slew.yaw_accel = 2.5;
    cfg.slew.jerk = Some(9.0);
    let rt = Runtime::<f32, 8>::new(robot, cfg, Pose2::default()).unwrap();
    let told = RobotLimits {
        max_accel: 0.75,
        max_yaw_accel: 2.5,
        max_jerk: 9.0,
    };
    for key in [None, Some(key())] {
        let mut bot = Bot::new(key.clone(), 3);
        bot.info = robot_info(&rt, key.is_some());
        assert_eq!(bot.info.limits, told);
        let mut op = OperatorLink::new(key.clone());
        let hello = op_hello(&mut op, &mut TestRng(4));
        let (r, ack) = bot.rx(&hello);
        assert!(matches!(r, Ok(RobotEvent::Hello(_))), "{r:?}");
        assert!(ack.len() <= hello.len(), "anti-amplification");
        // The limits are the last 12 bytes of the info (before the nonces and the epoch);
        // raise max_accel's exponent on the wire and fix the CRC.
        let mut raw = ack[..ack.len() - 1].to_vec();
        let n = omnikin::link::cobs_decode_in_place(&mut raw).unwrap();
        raw.truncate(n);
        let mut b = [0u8; 64];
        let info_len = postcard::to_slice(&bot.info, &mut b).unwrap().len();
        let at = omnikin::link::HEADER_LEN + info_len - 12;
        assert_eq!(raw[at..at + 4], 0.75f32.to_le_bytes());
        raw[at + 3] ^= 0x01;
        let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(&raw[..n - 4]);
        raw[n - 4..].copy_from_slice(&crc.to_le_bytes());
        let mut forged = vec![0u8; MAX_FRAME];
        let m = omnikin::link::cobs_encode(&raw, &mut forged).unwrap();
        forged.truncate(m);
        forged.push(0);
        let mut spoofed = op.clone();
        match op_rx(&mut spoofed, &forged) {
            Err(DropReason::Auth) if key.is_some() => {}
            Ok(OperatorEvent::Established(i)) if key.is_none() => {
                // Unkeyed, the link has no integrity (docs/security.md): the value changes.
                assert_ne!(i.limits, told);
            }
            other => panic!("forged limits, keyed {}: {other:?}", key.is_some()),
        }
        match op_rx(&mut op, &ack) {
            Ok(OperatorEvent::Established(i)) => assert_eq!(i.limits, told),
            other => panic!("{other:?}"),
        }
        assert_eq!(op.info().map(|i| i.limits), Some(told));
    }
}
