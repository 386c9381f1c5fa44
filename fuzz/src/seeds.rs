//! Seed corpora: valid inputs for every target, from the repository's own files (robot
//! descriptions), the planner (plan CSV) and the link codec (frames of every message type),
//! so that fuzzing starts past the checks a random input never passes.

use omnikin::estimate::events::EventCounters;
use omnikin::link::{
    Busy, EndReason, Estimate, HANDSHAKE_BODY, Hello, HelloAck, KIND_TAGGED, Key, LinkCounters,
    MAX_FRAME, MacKey, Message, NONCE_LEN, Opening, PROTOCOL_VERSION, RobotInfo, RobotKind,
    SimTruth, Telemetry, WireFix, WirePoint, encode_hello, encode_message, encode_open,
};
use omnikin::runtime::{Faults, FixCounters, Frame, Mode, PlanStatus};

use crate::link::{
    FUZZ_KEY, clock, clock_us, cycles, derive, hello_record, open_record, record, record_to,
    robot_nonce,
};

/// One seed: target, file name, content.
pub type Seed = (&'static str, String, Vec<u8>);

/// Every target name, in the order CI runs them.
pub const TARGETS: [&str; 8] = [
    "frame_decoder",
    "link_session",
    "robot_toml",
    "profile_toml",
    "waypoints",
    "csv_tables",
    "mcap_files",
    "mcap_messages",
];

fn point(t: f32) -> WirePoint {
    WirePoint {
        t,
        pose: [0.1 * t, -0.05 * t, 0.2 * t],
        twist: [0.1, -0.05, 0.2],
    }
}

fn telemetry() -> Telemetry {
    Telemetry {
        time_us: 1_234_567,
        mode: Mode::EStop,
        faults: Faults(0),
        fault_history: Faults(4),
        pose: [0.5, -0.25, 1.5],
        twist: [0.2, 0.0, 0.1],
        command: [0.2, 0.0, 0.1],
        wheels: 3,
        wheel_rates: [3.0, -1.5, -1.5, 0.0, 0.0, 0.0],
        steer_rates: [0.0; omnikin::MAX_WHEELS],
        wheel_angles: [10.0, -5.0, -5.0, 0.0, 0.0, 0.0],
        steer_angles: [0.0; omnikin::MAX_WHEELS],
        gyro: [0.0, 0.0, 0.1],
        accel: [0.0, 0.0, 9.81],
        plan: PlanStatus {
            id: 2,
            received: 8,
            len: 8,
            done: false,
        },
        plan_time: 0.75,
        reference: [0.5, -0.25, 1.5],
        slip_residual: 0.001,
        rejected: 1,
        last_command_us: 1_230_000,
        link: LinkCounters {
            ok: 40,
            framing: 1,
            crc: 2,
            auth: 3,
            replay: 1,
            session: 2,
            throttled: 5,
            stale: 2,
            ..LinkCounters::default()
        },
        ack_seq: 41,
        estop_seq: 39,
        clear_seq: 12,
    }
}

/// One message of every type of a session.
pub fn messages() -> Vec<(&'static str, Message)> {
    let mut chunk = heapless::Vec::new();
    for k in 0..3 {
        let _ = chunk.push(point(0.1 * k as f32));
    }
    let mut full = heapless::Vec::new();
    for k in 0..omnikin::link::CHUNK_POINTS {
        let _ = full.push(point(0.1 * k as f32));
    }
    vec![
        ("heartbeat", Message::Heartbeat),
        (
            "velocity-robot",
            Message::SetVelocity {
                frame: Frame::Robot,
                vx: 0.2,
                vy: -0.1,
                yaw_rate: 0.5,
            },
        ),
        (
            "velocity-world",
            Message::SetVelocity {
                frame: Frame::World,
                vx: -0.3,
                vy: 0.3,
                yaw_rate: -1.0,
            },
        ),
        ("plan-begin", Message::PlanBegin { id: 1, len: 3 }),
        ("plan-splice", Message::PlanSplice { id: 2, len: 3 }),
        (
            "plan-splice-rebased",
            Message::PlanSpliceRebased { id: 2, len: 3 },
        ),
        (
            "plan-chunk",
            Message::PlanChunk {
                id: 1,
                offset: 0,
                points: chunk,
            },
        ),
        (
            "plan-chunk-full",
            Message::PlanChunk {
                id: 1,
                offset: 0,
                points: full,
            },
        ),
        ("plan-start", Message::PlanStart { id: 1 }),
        ("stop", Message::Stop),
        ("estop", Message::EStop),
        ("clear", Message::Clear),
        (
            "set-pose",
            Message::SetPose {
                x: 1.0,
                y: -2.0,
                heading: 0.5,
            },
        ),
        ("telemetry", Message::Telemetry(telemetry())),
        ("session-end", Message::SessionEnd(EndReason::TakenOver)),
        (
            "fix",
            Message::Fix(WireFix {
                capture_us: 1_200_000,
                x: 0.4,
                y: -0.1,
                heading: Some(0.3),
                std_xy: 0.01,
                std_heading: 0.05,
            }),
        ),
        (
            "fix-position",
            Message::Fix(WireFix {
                capture_us: 900_000,
                x: -0.2,
                y: 0.7,
                heading: None,
                std_xy: 0.005,
                std_heading: 0.0,
            }),
        ),
        (
            "estimate",
            Message::Estimate(Estimate {
                time_us: 1_250_000,
                covariance: [1e-4, 2e-4, 3e-3],
                odometry: [0.41, -0.09, 0.31],
                gyro_bias: 0.0,
                wheel_scale: 1.01,
                fixes: FixCounters {
                    accepted: 12,
                    rejected: 2,
                    too_late: 1,
                    recoveries: 1,
                },
                events: EventCounters {
                    slips: 1,
                    collisions: 1,
                },
            }),
        ),
        (
            "truth",
            Message::Truth(SimTruth {
                time_us: 1_250_000,
                pose: [0.40, -0.10, 0.30],
            }),
        ),
        (
            "busy-answer",
            Message::Busy(Busy {
                holder: 0x0123_4567_89ab_cdef,
                idle_ms: 250,
                held_s: 42,
            }),
        ),
    ]
}

fn session(setup: u8, parts: &[&[u8]]) -> Vec<u8> {
    let mut v = vec![setup];
    for p in parts {
        v.extend_from_slice(p);
    }
    v
}

/// A plan of `len` points uploaded in chunks, then started.
fn plan_upload(id: u16, len: u16, first_seq: u64) -> Vec<u8> {
    let mut out = Vec::new();
    let mut seq = first_seq;
    out.extend(record(&Message::PlanBegin { id, len }, seq));
    let mut offset = 0;
    while offset < len {
        seq += 1;
        let mut points = heapless::Vec::new();
        for k in offset..len.min(offset + omnikin::link::CHUNK_POINTS as u16) {
            let _ = points.push(point(0.1 * f32::from(k)));
        }
        let n = points.len() as u16;
        out.extend(record(&Message::PlanChunk { id, offset, points }, seq));
        offset += n;
    }
    out.extend(record(&Message::PlanStart { id }, seq + 1));
    out
}

/// Structured inputs of the `link_session` target (see [`crate::link`]): a v3 handshake (Hello,
/// then the open frame that proves the key), then session frames of every message type,
/// driving, plan upload, e-stop, replays; a second operator answered Busy, then taking over;
/// a replayed first frame; epochs that age and retire; an e-stop then a held-back clear and
/// motion; and each corruption the format can express.
pub fn link_session() -> Vec<Seed> {
    let mut out = Vec::new();
    let hello = hello_record(0x11);
    let hb = |seq| record(&Message::Heartbeat, seq);
    let open = open_record(0, &Message::Heartbeat, 1, false);
    let velocity = |seq| {
        record(
            &Message::SetVelocity {
                frame: Frame::Robot,
                vx: 0.5,
                vy: 0.2,
                yaw_rate: 1.0,
            },
            seq,
        )
    };
    for setup in [0u8, 1, 2, 3, 4, 5, 8, 9, 11] {
        for (name, m) in messages() {
            let s = session(setup, &[&hello, &open, &record(&m, 2), &cycles(3)]);
            out.push(("link_session", format!("seed-{setup}-{name}"), s));
        }
        // Drive, keep alive, then let the watchdog stop the robot.
        let s = session(
            setup,
            &[
                &hello,
                &open,
                &velocity(2),
                &cycles(10),
                &hb(3),
                &cycles(10),
                &hb(4),
                &cycles(16),
                &cycles(16),
                &cycles(16),
                &cycles(16),
            ],
        );
        out.push(("link_session", format!("seed-{setup}-drive"), s));
        // Plan upload and run; a second plan replaces it; e-stop and clear.
        let s = session(
            setup,
            &[
                &hello,
                &open,
                &plan_upload(7, 11, 2),
                &cycles(16),
                &plan_upload(8, 3, 20),
                &cycles(8),
                &record(&Message::EStop, 30),
                &cycles(2),
                &record(&Message::Clear, 31),
                &cycles(2),
            ],
        );
        out.push(("link_session", format!("seed-{setup}-plan"), s));
        // Duplicates, an old frame, a jump ahead, and what the window then refuses; the open
        // frame repeated once the session is open (a duplicate, too).
        let s = session(
            setup,
            &[
                &hello,
                &open_record(0, &Message::Heartbeat, 5, false),
                &open_record(0, &Message::Heartbeat, 5, false),
                &hb(5),
                &hb(3),
                &hb(100),
                &hb(5),
                &hb(99),
                &hb(u64::MAX),
                &hb(1),
            ],
        );
        out.push(("link_session", format!("seed-{setup}-replay"), s));
        // A second operator is answered Busy while the first is live (its handshake is then
        // used up), then takes over with a new handshake (the first gets SessionEnd); the first
        // one's frames and its replayed first frame are then refused; its Hello, repeated in
        // the same epoch, gets the same answer.
        let s = session(
            setup,
            &[
                &hello,
                &open,
                &record(&Message::EStop, 2),
                &cycles(2),
                &hello_record(0x22),
                &hello_record(0x22),
                &open_record(0, &Message::Heartbeat, 1, false),
                // The Busy answer used that handshake up: its take-over frame is a replay.
                &open_record(0, &Message::Heartbeat, 2, true),
                // A new handshake asks to take over.
                &hello_record(0x33),
                &open_record(0, &Message::Heartbeat, 1, true),
                &cycles(2),
                &record_to(2, &Message::Heartbeat, 9),
                &open_record(2, &Message::Heartbeat, 1, true),
                &hello_record(0x11),
                &hb(3),
                &cycles(1),
            ],
        );
        out.push(("link_session", format!("seed-{setup}-takeover"), s));
        // Busy (the handshake is used up: its next first frame is a replay), then the holder
        // falls silent for LIVE_US: the newcomer's next handshake opens without asking.
        let s = session(
            setup,
            &[
                &hello,
                &open,
                &hello_record(0x22),
                &open_record(0, &Message::Heartbeat, 1, false),
                &clock(5),
                &open_record(0, &Message::Heartbeat, 2, false),
                &clock(5),
                &hello_record(0x33),
                &open_record(0, &Message::Heartbeat, 1, false),
                &hb(4),
                &cycles(2),
            ],
        );
        out.push(("link_session", format!("seed-{setup}-busy"), s));
        // Epochs age: a HelloAck of the previous epoch is still good after a rotation, one
        // two epochs old is not; a Hello answered just before the epoch ends and opened just
        // after.
        let s = session(
            setup,
            &[
                &hello,
                &clock(100),
                &hello_record(0x22),
                &open_record(1, &Message::Heartbeat, 1, true),
                &hello_record(0x33),
                &clock(200),
                &open_record(0, &Message::Heartbeat, 1, true),
                &hello_record(0x44),
                &clock_us(9_999_999),
                &hello_record(0x55),
                &clock_us(2),
                &open_record(0, &Message::Heartbeat, 1, true),
                &hb(2),
                &cycles(1),
            ],
        );
        out.push(("link_session", format!("seed-{setup}-epochs"), s));
        // A replayed first frame: opened, taken over, then replayed (its nonce is used).
        let s = session(
            setup,
            &[
                &hello,
                &open,
                &hb(2),
                &hello_record(0x22),
                &open_record(0, &Message::Heartbeat, 1, true),
                &open_record(1, &Message::Heartbeat, 1, true),
                &hb(2),
                &cycles(1),
            ],
        );
        out.push(("link_session", format!("seed-{setup}-replayed-open"), s));
        // An epoch opens USED_PER_EPOCH sessions and retires; the next Hello starts another.
        let mut parts: Vec<Vec<u8>> = Vec::new();
        for i in 0..=omnikin::link::USED_PER_EPOCH as u8 {
            parts.push(hello_record(0x40 + i));
            parts.push(open_record(0, &Message::Heartbeat, 1, true));
        }
        parts.push(open_record(3, &Message::Heartbeat, 1, true));
        parts.push(cycles(1).to_vec());
        let refs: Vec<&[u8]> = parts.iter().map(|p| &p[..]).collect();
        out.push((
            "link_session",
            format!("seed-{setup}-retire"),
            session(setup, &refs),
        ));
        // Issue 30, observation 3: the operator's clear (3), velocity (4) and set-pose (5) are
        // held back and delivered after its e-stop (6): all stale, the robot stays in e-stop;
        // a newer clear (7) ends it and the telemetry names it; a newer velocity (8) drives.
        let s = session(
            setup,
            &[
                &hello,
                &open,
                &velocity(2),
                &cycles(2),
                &record(&Message::EStop, 6),
                &cycles(1),
                &record(&Message::Clear, 3),
                &velocity(4),
                &record(
                    &Message::SetPose {
                        x: 1.0,
                        y: 1.0,
                        heading: 0.0,
                    },
                    5,
                ),
                &cycles(2),
                &record(&Message::Clear, 7),
                &velocity(8),
                &cycles(2),
            ],
        );
        out.push(("link_session", format!("seed-{setup}-estop-held-back"), s));
    }
    // Each corruption, on a Hello, an open frame and a heartbeat: CRC, tag, tag presence, PSK
    // instead of K_s, an unpadded Hello, another protocol, failing entropy, a throttled Hello,
    // an open frame's unknown flag, wrong epoch and wrong nonce, junk; and an arbitrary frame.
    let hbr = hb(2);
    let flip = |r: &[u8], bits: u8| {
        let mut r = r.to_vec();
        r[0] |= bits;
        r
    };
    let opening = |flags: u8, epoch_delta: u8| {
        let mut r = open.clone();
        r[10] = flags;
        r[11] = epoch_delta;
        r
    };
    let mut unpadded = flip(&hello, 128);
    unpadded.extend_from_slice(&[PROTOCOL_VERSION, 0, 0]);
    let mut v2 = flip(&hello, 128);
    v2.extend_from_slice(&[2, 51, 0]);
    let mut throttled = flip(&hello, 128);
    throttled.extend_from_slice(&[PROTOCOL_VERSION, HANDSHAKE_BODY as u8, 1]);
    let mut any = vec![2u8, PROTOCOL_VERSION, 3 | KIND_TAGGED];
    any.extend_from_slice(&5u64.to_le_bytes());
    any.extend_from_slice(&1u64.to_le_bytes());
    any.extend_from_slice(&[1, 1, 0, 0]);
    let ho = [&hello[..], &open[..]].concat();
    for setup in [0u8, 1, 2, 3] {
        let cases: [(&str, Vec<u8>); 19] = [
            ("hello-crc", flip(&hello, 8)),
            ("hello-tag", flip(&hello, 16)),
            ("hello-tag-presence", flip(&hello, 32)),
            ("hello-entropy", flip(&hello, 64)),
            ("hello-unpadded", unpadded.clone()),
            ("hello-v2", v2.clone()),
            ("hello-throttled", throttled.clone()),
            ("open-crc", [&hello[..], &flip(&open, 8)].concat()),
            ("open-tag", [&hello[..], &flip(&open, 16)].concat()),
            ("open-psk-tag", [&hello[..], &flip(&open, 128)].concat()),
            ("open-flag", [&hello[..], &opening(4, 0)].concat()),
            ("open-epoch", [&hello[..], &opening(0, 1)].concat()),
            ("open-nonce", [&hello[..], &opening(2, 0)].concat()),
            ("crc", [&ho[..], &flip(&hbr, 8)].concat()),
            ("tag", [&ho[..], &flip(&hbr, 16)].concat()),
            ("tag-presence", [&ho[..], &flip(&hbr, 32)].concat()),
            ("psk-tag", [&ho[..], &flip(&hbr, 128)].concat()),
            ("any", [&ho[..], &any].concat()),
            (
                "junk",
                [
                    &ho[..],
                    &[4u8, 4, 1, 2, 3, 0][..],
                    &[12, 2, 9, 9][..],
                    &hbr[..],
                ]
                .concat(),
            ),
        ];
        for (name, r) in cases {
            out.push((
                "link_session",
                format!("seed-{setup}-bad-{name}"),
                session(setup, &[&r]),
            ));
        }
    }
    out
}

/// The raw target's robot: its entropy source fills with 0x5a, so its first epoch's secret
/// is 32 such bytes and its number `0x5a5a5a5a`.
pub const RAW_SECRET: [u8; 32] = [0x5a; 32];
/// The raw target's first epoch number.
pub const RAW_EPOCH: u32 = 0x5a5a_5a5a;

/// Wire frames as a robot reads them, keyed and not, for the raw `frame_decoder` target: a
/// Hello, then frames of every message type in the session that Hello opens with the target's
/// fixed epoch secret (so they are accepted) — singly as open frames, and as one stream whose
/// first frame is an open frame; a second operator's open frame answered Busy; a HelloAck.
pub fn frame_decoder() -> Vec<Seed> {
    let key = Key::new(FUZZ_KEY).expect("key");
    let mut out = Vec::new();
    for (k, kname) in [(None, "plain"), (Some(key), "keyed")] {
        let mut buf = [0u8; MAX_FRAME];
        let psk: &[u8] = if k.is_some() { FUZZ_KEY } else { &[] };
        // A Hello and the session it opens, for the client nonce `c`.
        let handshake = |c: u8| {
            let nonce = [c; NONCE_LEN];
            let hello = Hello {
                protocol: PROTOCOL_VERSION,
                client_nonce: nonce,
            };
            let mut buf = [0u8; MAX_FRAME];
            let n = encode_hello(&hello, k.as_ref(), &mut buf).expect("a Hello encodes");
            let rn = robot_nonce(&RAW_SECRET, &nonce);
            let (id, ks) = derive(psk, &nonce, &rn);
            let opening = Opening {
                client_nonce: nonce,
                epoch: RAW_EPOCH,
                take_over: false,
            };
            (buf[..n].to_vec(), id, ks, opening, rn)
        };
        let (hello, id, ks, opening, rn) = handshake(0x11);
        out.push((
            "frame_decoder",
            format!("seed-{kname}-hello"),
            hello.clone(),
        ));
        let mac = k.as_ref().map(|_| MacKey::new(&ks));
        let mut stream = hello.clone();
        for (seq, (name, m)) in (1u64..).zip(messages()) {
            let n = encode_open(id, seq, &opening, &m, mac.as_ref(), &mut buf).expect("encodes");
            let frame = [&hello[..], &buf[..n]].concat();
            out.push(("frame_decoder", format!("seed-{kname}-{name}"), frame));
            let n = if seq == 1 {
                n
            } else {
                encode_message(id, seq, &m, mac.as_ref(), &mut buf).expect("encodes")
            };
            stream.extend_from_slice(&buf[..n]);
        }
        out.push(("frame_decoder", format!("seed-{kname}-stream"), stream));
        // A second operator, while the first is live: Busy.
        let (hello2, id2, ks2, opening2, _) = handshake(0x22);
        let mac2 = k.as_ref().map(|_| MacKey::new(&ks2));
        let n = encode_open(id, 1, &opening, &Message::Heartbeat, mac.as_ref(), &mut buf)
            .expect("encodes");
        let mut busy = [&hello[..], &buf[..n], &hello2[..]].concat();
        let n = encode_open(
            id2,
            1,
            &opening2,
            &Message::Heartbeat,
            mac2.as_ref(),
            &mut buf,
        )
        .expect("encodes");
        busy.extend_from_slice(&buf[..n]);
        // And then a new handshake with take-over (the Busy one is used up).
        let (hello3, id3, ks3, opening3, _) = handshake(0x33);
        let mac3 = k.as_ref().map(|_| MacKey::new(&ks3));
        let over = Opening {
            take_over: true,
            ..opening3
        };
        busy.extend_from_slice(&hello3);
        let n = encode_open(id3, 1, &over, &Message::Heartbeat, mac3.as_ref(), &mut buf)
            .expect("encodes");
        busy.extend_from_slice(&buf[..n]);
        out.push(("frame_decoder", format!("seed-{kname}-busy"), busy));
        // The answer an operator reads (the raw target feeds its operator end too).
        let ack = HelloAck {
            info: RobotInfo {
                protocol: PROTOCOL_VERSION,
                kind: RobotKind::Caster,
                plan_capacity: 64,
                rate_hz: 100.0,
                watchdog: 0.5,
                authenticated: k.is_some(),
                limits: omnikin::link::RobotLimits {
                    max_accel: 1.0,
                    max_yaw_accel: 4.0,
                    max_jerk: f32::INFINITY,
                },
            },
            client_nonce: [0x11; NONCE_LEN],
            robot_nonce: rn,
            epoch: RAW_EPOCH,
        };
        let n = omnikin::link::encode_frame_with(
            omnikin::link::FrameKind::HelloAck,
            0,
            0,
            k.as_ref().map(Key::mac),
            |b| {
                postcard::to_slice(&ack, b)
                    .map(|s| s.len())
                    .map_err(|_| omnikin::link::EncodeError::TooLarge)
            },
            &mut buf,
        )
        .expect("a HelloAck encodes");
        out.push((
            "frame_decoder",
            format!("seed-{kname}-hello-ack"),
            buf[..n].to_vec(),
        ));
    }
    out
}

/// The robot presets, from the core's one table (`robots/*.toml` compiled in).
const ROBOTS: [(&str, &str); omnikin::description::PRESETS.len()] = omnikin::description::PRESETS;

/// Layouts beyond the presets (issue 13): the most wheels of an omni base, mixed rollers and
/// radii, and the smallest swerve with steering optimisation and steer limits.
const LAYOUTS: [(&str, &str); 2] = [
    (
        "omni6-mixed",
        "kind = \"omni\"\nname = \"hex\"\n\n[[geometry.wheels]]\nposition = [0.2, 0.0]\ndrive_angle_deg = 90.0\nroller_angle_deg = 0.0\nradius = 0.05\n\n[[geometry.wheels]]\nposition = [0.1, 0.17]\ndrive_angle_deg = 150.0\nroller_angle_deg = 45.0\nradius = 0.04\n\n[[geometry.wheels]]\nposition = [-0.1, 0.17]\ndrive_angle_deg = 210.0\nroller_angle_deg = -45.0\nradius = 0.05\n\n[[geometry.wheels]]\nposition = [-0.2, 0.0]\ndrive_angle_deg = 270.0\nroller_angle_deg = 10.0\nradius = 0.06\n\n[[geometry.wheels]]\nposition = [-0.1, -0.17]\ndrive_angle_deg = 330.0\nroller_angle_deg = 0.0\nradius = 0.05\n\n[[geometry.wheels]]\nposition = [0.1, -0.17]\ndrive_angle_deg = -330.0\nroller_angle_deg = 0.0\nradius = 0.05\n\n[limits]\nmax_wheel_rate = 30.0\n",
    ),
    (
        "swerve2-optimized",
        "kind = \"swerve\"\n\n[geometry]\noptimize_steering = true\n\n[[geometry.modules]]\nposition = [0.25, 0.0]\nwheel_radius = 0.05\n\n[[geometry.modules]]\nposition = [-0.25, 0.0]\nwheel_radius = 0.04\n\n[limits]\nmax_wheel_rate = 50.0\nmax_steer_rate = 10.0\nmax_steer_accel = 50.0\n",
    ),
];

fn text(target: &'static str, name: &str, t: &str) -> Seed {
    (target, format!("seed-{name}"), t.as_bytes().to_vec())
}

/// Robot descriptions: the repository's `robots/*.toml` and variants of them.
pub fn robot_toml() -> Vec<Seed> {
    let mut out = Vec::new();
    for (name, t) in ROBOTS {
        out.push(text("robot_toml", name, t));
        // Without comments, name and limits: the smallest valid files.
        let bare: String = t
            .lines()
            .map(|l| l.split('#').next().unwrap_or("").trim_end())
            .filter(|l| !l.is_empty() && !l.starts_with("name"))
            .take_while(|l| *l != "[limits]")
            .map(|l| format!("{l}\n"))
            .collect();
        out.push(text("robot_toml", &format!("{name}-bare"), &bare));
    }
    for (name, t) in LAYOUTS {
        out.push(text("robot_toml", name, t));
    }
    out
}

const PROFILE_FULL: &str = r#"rate = 1000.0
hold = "linear"

[wheel_motor]
steps_per_rev = 200
microsteps = 16
max_step_rate = 40000.0
lag_time_constant = 0.005
max_accel = 300.0
fluctuation_abs = 0.02
fluctuation_rel = 0.01
fluctuation_period = 0.01
radius_error_std = 0.003
rate_bias_rel = 0.0

[steer_motor]
max_accel = 100.0
lag_time_constant = 0.01

[shell_spin]
std = 0.01
slip_gain = 0.875
slip_exponent = 1.22

[roller]
amplitude = 0.02
rollers = 8

[floor]
rel_std = 0.01
corr_time = 0.5

[tracking]
offset = [0.0, 0.0]
height = -0.03
tilt_gain = 1.0
noise_std = 0.001

[encoder]
counts_per_rev = 4096
"#;

const SENSORS_FULL: &str = r#"counts_per_rev = 4096
steer_counts_per_rev = 2048

[gyro]
noise_std = 0.002
bias = 0.001
bias_std = 0.0005

[yaw]
noise_std = 0.01
wrap = true

[imu]
gyro_noise_std = 0.001
gyro_bias = [0.0, 0.0, 0.002]
accel_noise_std = 0.05
mag_noise_std = 0.5
field = [0.0, 20.0, -45.0]

[camera]
period = 0.1
latency = 0.1
noise_std = 0.005
heading_noise_std = 0.02
outlier_probability = 0.01
outlier_distance = 0.5
"#;

/// Disturbance and sensor profiles: every key of each.
pub fn profile_toml() -> Vec<Seed> {
    vec![
        text("profile_toml", "disturbance-full", PROFILE_FULL),
        text(
            "profile_toml",
            "disturbance-zoh",
            "hold = \"zoh\"\n[encoder]\ncounts_per_rev = 1024\n",
        ),
        text("profile_toml", "empty", ""),
        text("profile_toml", "sensors-full", SENSORS_FULL),
        text(
            "profile_toml",
            "sensors-gyro",
            "counts_per_rev = 4096\n[gyro]\nnoise_std = 0.002\nbias = 0.0\nbias_std = 0.0\n",
        ),
    ]
}

/// Waypoint files, CSV and TOML.
pub fn waypoints() -> Vec<Seed> {
    vec![
        text("waypoints", "csv-xy", "0,0\n1,0\n1,1\n0,1\n"),
        text(
            "waypoints",
            "csv-header-heading",
            "# a square, facing the motion\nx,y,heading\n0.0,0.0,0.0\n\n1.0,0.0,1.5708\n1.0,1.0,3.1416\n",
        ),
        text("waypoints", "csv-header", "x, y\n-0.5, 0.25\n0.5e0, -1\n"),
        text(
            "waypoints",
            "toml",
            "[[waypoint]]\nx = 0.0\ny = 0.0\n\n[[waypoint]]\nx = 1.0\ny = 0.5\n",
        ),
        text(
            "waypoints",
            "toml-heading",
            "[[waypoint]]\nx = 0.0\ny = 0.0\nheading = 0.0\n[[waypoint]]\nx = 1.0\ny = 0.0\nheading = 1.57\n[[waypoint]]\nx = 1.0\ny = 1.0\nheading = 3.14\n",
        ),
    ]
}

/// A plan CSV from the planner: the first `rows` samples of paper 000's circle 1 on `robot`.
fn planned_csv(robot: &str, rows: usize) -> Vec<u8> {
    use omnikin_plan::generators::Circle;
    use omnikin_plan::planner::plan;
    let d = omnikin::description::RobotDescription::preset(robot).expect("preset");
    let model = omnikin_plan::RobotModel::from_description(&d).expect("preset model");
    let c = Circle::paper(1.0);
    let opts = c.options(20.0);
    let mut planned = plan(&c.path().expect("path"), &c.heading(), &model, &opts)
        .expect("paper circle plans")
        .plan;
    planned.samples.truncate(rows);
    let mut out = Vec::new();
    planned.write_csv(&mut out).expect("to memory");
    out
}

/// CSV tables: plans (sphere, caster, mecanum, swerve4) from the planner, a tracked run, encoder logs and
/// camera fixes.
pub fn csv_tables() -> Vec<Seed> {
    let mut out = vec![
        (
            "csv_tables",
            "seed-plan-sphere".into(),
            planned_csv("sphere-omni", 12),
        ),
        (
            "csv_tables",
            "seed-plan-caster".into(),
            planned_csv("caster3", 12),
        ),
        (
            "csv_tables",
            "seed-plan-mecanum".into(),
            planned_csv("mecanum", 12),
        ),
        (
            "csv_tables",
            "seed-plan-swerve4".into(),
            planned_csv("swerve4", 12),
        ),
    ];
    out.push(text(
        "csv_tables",
        "track",
        "t,x,y,heading\n0.0,0.0,0.0,0.0\n0.1,0.01,0.0,0.01\n0.2,0.02,0.001,0.02\n0.3,0.031,0.002,0.03\n",
    ));
    out.push(text(
        "csv_tables",
        "track-quoted",
        "\"t\",\"x\",\"y\",extra\n0,0,0,a\n0.05,\"0.001\",0,b\n\n0.1,0.002,0,\"c,d\"\n",
    ));
    out.push(text(
        "csv_tables",
        "encoder-log",
        "t,q1,q2,q3,gyro_z,yaw\n0.00,0.0,0.0,0.0,0.0,0.0\n0.01,0.012,-0.006,-0.006,0.1,0.001\n0.02,0.024,-0.012,-0.012,0.1,0.002\n",
    ));
    out.push(text(
        "csv_tables",
        "encoder-log-caster",
        "t,q1,q2,q3,s1,s2,s3\n0,0,0,0,0,0,0\n0.01,0.02,0.02,0.02,0.001,0.001,0.001\n",
    ));
    out.push(text(
        "csv_tables",
        "encoder-log-swerve4",
        "t,q1,q2,q3,q4,s1,s2,s3,s4,gyro_z\n0,0,0,0,0,2.11,1.03,-2.82,-0.32,1.0\n0.01,0.117,0.117,0.063,0.063,2.12,1.04,-2.81,-0.31,1.0\n",
    ));
    out.push(text(
        "csv_tables",
        "fixes",
        "t,x,y,heading,arrival\n0.1,0.01,0.0,0.0,0.2\n0.2,0.02,0.001,0.01,0.3\n",
    ));
    out
}

/// Every seed of every target.
pub fn all() -> Vec<Seed> {
    let mut v = frame_decoder();
    v.extend(link_session());
    v.extend(robot_toml());
    v.extend(profile_toml());
    v.extend(waypoints());
    v.extend(csv_tables());
    v.extend(mcap_files());
    v.extend(mcap_messages());
    v.extend(ros2_cdr());
    v
}

/// MCAP files: a valid one, a truncated one and the crafted files of issue 31 (a record
/// length near 2⁶⁴, a schema name of length 0xFFFFFFF0, an attachment without its CRC, a
/// chunk's record past its end, a zstd chunk, a 5 000-entry map).
pub fn mcap_files() -> Vec<Seed> {
    crate::mcap::seeds()
        .into_iter()
        .map(|(name, bytes)| ("mcap_files", format!("seed-{name}"), bytes))
        .collect()
}

/// Protobuf messages: each log topic's message as the writer encodes it, and an empty one.
pub fn mcap_messages() -> Vec<Seed> {
    crate::mcap::message_seeds()
        .into_iter()
        .map(|(name, bytes)| ("mcap_messages", format!("seed-{name}"), bytes))
        .collect()
}

/// ROS 2 CDR samples: one valid sample per message type and a forged string length.
pub fn ros2_cdr() -> Vec<Seed> {
    crate::ros2::seeds()
        .into_iter()
        .map(|(name, bytes)| ("ros2_cdr", format!("seed-{name}"), bytes))
        .collect()
}
