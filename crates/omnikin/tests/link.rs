//! The link codec: encode∘decode is the identity (property test), arbitrary bytes never panic
//! the decoder, and every corrupt, truncated, unauthenticated, replayed or foreign-version
//! frame is dropped and counted in exactly one counter.

use omnikin::link::{
    CHUNK_POINTS, DropReason, Endpoint, FrameReader, Key, LinkCounters, MAX_FRAME, Message,
    PROTOCOL_VERSION, RobotInfo, RobotKind, Telemetry, WirePoint, encode_frame, parse_frame,
};
use omnikin::runtime::{Faults, Frame, Mode, PlanStatus};
use proptest::prelude::*;

fn f() -> impl Strategy<Value = f32> {
    // Any f32 bit pattern except NaN (NaN != NaN would break equality, not the codec).
    any::<f32>().prop_filter("not NaN", |x| !x.is_nan())
}
fn f3() -> impl Strategy<Value = [f32; 3]> {
    [f(), f(), f()]
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
        (f3(), f3(), f3(), f3(), f3(), f3()),
        (
            any::<(u16, u16, u16, bool)>(),
            f(),
            f3(),
            f(),
            any::<u32>(),
            any::<u64>(),
        ),
        any::<[u32; 7]>(),
    )
        .prop_map(|(a, b, c, l)| Telemetry {
            time_us: a.0,
            mode: a.1,
            faults: Faults(a.2),
            fault_history: Faults(a.3),
            pose: a.4,
            twist: a.5,
            command: a.6,
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
            },
        })
}

fn message() -> impl Strategy<Value = Message> {
    prop_oneof![
        any::<u8>().prop_map(|protocol| Message::Hello { protocol }),
        (
            any::<u16>(),
            f(),
            f(),
            any::<bool>(),
            prop_oneof![
                Just(RobotKind::Sphere),
                Just(RobotKind::Ballbot),
                Just(RobotKind::Caster)
            ]
        )
            .prop_map(|(cap, r, w, a, kind)| Message::HelloAck(RobotInfo {
                protocol: PROTOCOL_VERSION,
                kind,
                plan_capacity: cap,
                rate_hz: r,
                watchdog: w,
                authenticated: a,
            })),
        Just(Message::Heartbeat),
        (any::<bool>(), f(), f(), f()).prop_map(|(w, vx, vy, yaw_rate)| Message::SetVelocity {
            frame: if w { Frame::World } else { Frame::Robot },
            vx,
            vy,
            yaw_rate
        }),
        (any::<u16>(), any::<u16>()).prop_map(|(id, len)| Message::PlanBegin { id, len }),
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
    ]
}

fn key() -> Key {
    Key::new(b"shared secret, 32 bytes long ...").unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn encode_then_decode_is_the_identity(msg in message(), seq in 1u64.., keyed in any::<bool>()) {
        let k = key();
        let key = keyed.then_some(&k);
        let mut buf = [0u8; MAX_FRAME];
        let n = encode_frame(&msg, seq, key, &mut buf).unwrap();
        prop_assert!(n <= MAX_FRAME);
        prop_assert_eq!(buf[n - 1], 0);
        prop_assert!(buf[..n - 1].iter().all(|&b| b != 0), "COBS leaves no zero inside");
        let (s, back) = parse_frame(&mut buf[..n - 1], key).unwrap();
        prop_assert_eq!(s, seq);
        prop_assert_eq!(back, msg);
    }

    #[test]
    fn random_bytes_never_panic_and_are_counted(bytes in prop::collection::vec(any::<u8>(), 0..800)) {
        for key in [None, Some(key())] {
            let mut end = Endpoint::new(key, 1);
            let mut reader = FrameReader::<MAX_FRAME>::new();
            let mut frames = 0u32;
            reader.feed(&bytes, &mut end, |_| frames += 1);
            let tail = reader.end_of_datagram(&mut end);
            let c = *end.counters();
            prop_assert_eq!(c.ok + c.dropped(), frames + tail as u32);
            let mut copy = bytes.clone();
            let _ = parse_frame(&mut copy, key.as_ref());
        }
    }

    #[test]
    fn any_single_byte_change_is_dropped(msg in message(), pos in any::<prop::sample::Index>(), x in 1u8..) {
        let mut buf = [0u8; MAX_FRAME];
        let n = encode_frame(&msg, 5, None, &mut buf).unwrap();
        let i = pos.index(n - 1);
        buf[i] ^= x;
        let mut end = Endpoint::new(None, 1);
        let mut reader = FrameReader::<MAX_FRAME>::new();
        let mut accepted = vec![];
        reader.feed(&buf[..n], &mut end, |r| if let Ok(m) = r { accepted.push(m) });
        prop_assert!(accepted.is_empty(), "corrupt frame accepted: {:?}", accepted);
        prop_assert!(end.counters().dropped() >= 1);
    }
}

fn frame(msg: &Message, seq: u64, key: Option<&Key>) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    let n = encode_frame(msg, seq, key, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn feed(end: &mut Endpoint, bytes: &[u8]) -> Vec<Result<(u64, Message), DropReason>> {
    let mut reader = FrameReader::<MAX_FRAME>::new();
    let mut out = vec![];
    reader.feed(bytes, end, |r| out.push(r));
    reader.end_of_datagram(end);
    out
}

#[test]
fn largest_messages_fit_one_frame() {
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
    let n = frame(&chunk, u64::MAX, Some(&k)).len();
    println!("largest chunk frame: {n} bytes (MAX_FRAME {MAX_FRAME})");
    assert!(n <= MAX_FRAME);
}

#[test]
fn duplicates_and_replays_are_dropped_and_counted() {
    let mut end = Endpoint::new(None, 1);
    let a = frame(&Message::Heartbeat, 100, None);
    let b = frame(&Message::Stop, 101, None);
    let c = frame(&Message::Clear, 99, None); // late but inside the window: fresh
    let old = frame(&Message::EStop, 10, None); // 91 behind: outside the 64-frame window
    let mut stream = vec![];
    for f in [&a, &b, &a, &c, &b, &c, &old] {
        stream.extend_from_slice(f);
    }
    let r = feed(&mut end, &stream);
    let ok: Vec<u64> = r
        .iter()
        .filter_map(|x| x.as_ref().ok().map(|m| m.0))
        .collect();
    assert_eq!(ok, vec![100, 101, 99]);
    assert_eq!(end.counters().replay, 4);
    assert_eq!(end.counters().ok, 3);
}

#[test]
fn wrong_or_missing_key_is_dropped_as_unauthenticated() {
    let k = key();
    let other = Key::new(b"another key of the same length!!").unwrap();
    let mut end = Endpoint::new(Some(k), 1);
    let mut stream = frame(&Message::EStop, 1, Some(&other));
    stream.extend(frame(&Message::EStop, 2, None));
    stream.extend(frame(&Message::EStop, 3, Some(&k)));
    let r = feed(&mut end, &stream);
    assert_eq!(r[0], Err(DropReason::Auth));
    assert_eq!(r[1], Err(DropReason::Auth));
    assert_eq!(r[2], Ok((3, Message::EStop)));
    assert_eq!(end.counters().auth, 2);
    // A replayed authentic frame is caught by the window, not executed twice.
    let again = frame(&Message::EStop, 3, Some(&k));
    assert_eq!(feed(&mut end, &again)[0], Err(DropReason::Replay(3)));
    // Forged sequence number on a captured frame: the tag covers the header.
    let mut forged = frame(&Message::EStop, 4, Some(&k));
    let n = forged.len() - 1;
    let mut raw = vec![0u8; n];
    let m = cobs::decode(&forged[..n], &mut raw).unwrap();
    raw.truncate(m);
    raw[2] = 200; // seq byte
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(&raw[..m - 4]);
    raw[m - 4..].copy_from_slice(&crc.to_le_bytes());
    forged = cobs::encode_vec(&raw);
    forged.push(0);
    assert_eq!(feed(&mut end, &forged)[0], Err(DropReason::Auth));
}

#[test]
fn other_version_truncated_and_oversized_frames_are_counted() {
    let mut end = Endpoint::new(None, 1);
    // Version 2, valid CRC.
    let f = frame(&Message::Heartbeat, 1, None);
    let mut raw = vec![0u8; f.len()];
    let m = cobs::decode(&f[..f.len() - 1], &mut raw).unwrap();
    raw.truncate(m);
    raw[0] = 2;
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(&raw[..m - 4]);
    raw[m - 4..].copy_from_slice(&crc.to_le_bytes());
    let mut v2 = cobs::encode_vec(&raw);
    v2.push(0);
    assert_eq!(feed(&mut end, &v2)[0], Err(DropReason::Version(2)));
    // Truncated: half a frame at the end of a datagram.
    let f = frame(&Message::Stop, 2, None);
    assert!(feed(&mut end, &f[..f.len() / 2]).is_empty());
    // Truncated inside a stream: the cut frame runs into the next one's bytes → CRC/framing.
    let mut s = f[..f.len() / 2].to_vec();
    s.extend(frame(&Message::Clear, 3, None));
    let r = feed(&mut end, &s);
    assert_eq!(r.len(), 1);
    assert!(r[0].is_err());
    // Oversized garbage without delimiter, then a good frame: resynchronised.
    let mut s = vec![0x11u8; 3 * MAX_FRAME];
    s.push(0);
    s.extend(frame(&Message::Clear, 4, None));
    let r = feed(&mut end, &s);
    assert_eq!(r.last().unwrap(), &Ok((4, Message::Clear)));
    let c = end.counters();
    assert_eq!((c.version, c.ok), (1, 1));
    assert_eq!(c.framing + c.crc + c.malformed, 3, "{c:?}");
}
