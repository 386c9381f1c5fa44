//! Seed corpora: valid inputs for every target, from the repository's own files (robot
//! descriptions), the planner (plan CSV) and the link codec (frames of every message type),
//! so that fuzzing starts past the checks a random input never passes.

use omnikin::link::{
    Endpoint, Key, LinkCounters, MAX_FRAME, Message, PROTOCOL_VERSION, RobotInfo, RobotKind,
    Telemetry, WirePoint,
};
use omnikin::runtime::{Faults, Frame, Mode, PlanStatus};

use crate::link::{FUZZ_KEY, cycles, record};

/// One seed: target, file name, content.
pub type Seed = (&'static str, String, Vec<u8>);

/// Every target name, in the order CI runs them.
pub const TARGETS: [&str; 6] = [
    "frame_decoder",
    "link_session",
    "robot_toml",
    "profile_toml",
    "waypoints",
    "csv_tables",
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
        mode: Mode::Velocity,
        faults: Faults(0),
        fault_history: Faults(4),
        pose: [0.5, -0.25, 1.5],
        twist: [0.2, 0.0, 0.1],
        command: [0.2, 0.0, 0.1],
        wheel_rates: [3.0, -1.5, -1.5],
        steer_rates: [0.0; 3],
        wheel_angles: [10.0, -5.0, -5.0],
        steer_angles: [0.0; 3],
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
            version: 0,
            auth: 3,
            replay: 1,
            malformed: 0,
        },
    }
}

/// One message of every type of the protocol.
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
        (
            "hello",
            Message::Hello {
                protocol: PROTOCOL_VERSION,
            },
        ),
        (
            "hello-ack",
            Message::HelloAck(RobotInfo {
                protocol: PROTOCOL_VERSION,
                kind: RobotKind::Caster,
                plan_capacity: 64,
                rate_hz: 100.0,
                watchdog: 0.5,
                authenticated: true,
            }),
        ),
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

/// Structured inputs of the `link_session` target (see [`crate::link`]).
pub fn link_session() -> Vec<Seed> {
    let mut out = Vec::new();
    let hello = record(
        &Message::Hello {
            protocol: PROTOCOL_VERSION,
        },
        1,
    );
    for setup in [0u8, 1, 2, 3, 4, 5, 8, 9, 11] {
        for (name, m) in messages() {
            let s = session(setup, &[&hello, &record(&m, 2), &cycles(3)]);
            out.push(("link_session", format!("seed-{setup}-{name}"), s));
        }
        let velocity = record(
            &Message::SetVelocity {
                frame: Frame::Robot,
                vx: 0.5,
                vy: 0.2,
                yaw_rate: 1.0,
            },
            2,
        );
        // Drive, keep alive, then let the watchdog stop the robot.
        let hb = |seq| record(&Message::Heartbeat, seq);
        let s = session(
            setup,
            &[
                &hello,
                &velocity,
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
        // Duplicates, an old frame, a jump ahead, and what the window then refuses.
        let s = session(
            setup,
            &[
                &hello,
                &hb(5),
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
    }
    // Each corruption the spec can express, on a heartbeat: CRC, tag, AUTH flag, version,
    // flags byte, and junk before and between frames.
    let hb = record(&Message::Heartbeat, 9);
    let mutate = |bit: u8, extra: &[u8]| {
        let mut r = vec![hb[0] | bit];
        r.extend_from_slice(&hb[1..9]);
        r.extend_from_slice(extra);
        r.extend_from_slice(&hb[9..]);
        r
    };
    for setup in [0u8, 1, 2, 3] {
        let cases: [(&str, Vec<u8>); 6] = [
            ("crc", mutate(8, &[])),
            ("tag", mutate(16, &[])),
            ("auth-flag", mutate(32, &[])),
            ("version", mutate(64, &[2])),
            ("flags", mutate(128, &[0xff])),
            (
                "junk",
                [&[3u8, 4, 1, 2, 3, 0][..], &[7, 2, 9, 9][..], &hb[..]].concat(),
            ),
        ];
        for (name, r) in cases {
            out.push((
                "link_session",
                format!("seed-{setup}-bad-{name}"),
                session(setup, &[&hello, &r]),
            ));
        }
    }
    out
}

/// Wire frames (as a receiver reads them) of every message type, keyed and not, single and
/// back to back, for the raw `frame_decoder` target.
pub fn frame_decoder() -> Vec<Seed> {
    let key = Key::new(FUZZ_KEY).expect("key");
    let mut out = Vec::new();
    for (k, kname) in [(None, "plain"), (Some(key), "keyed")] {
        let mut end = Endpoint::new(k, 1);
        let mut stream = Vec::new();
        for (name, m) in messages() {
            let mut buf = [0u8; MAX_FRAME];
            let n = end.encode(&m, &mut buf).expect("seed message encodes");
            out.push((
                "frame_decoder",
                format!("seed-{kname}-{name}"),
                buf[..n].to_vec(),
            ));
            stream.extend_from_slice(&buf[..n]);
        }
        out.push(("frame_decoder", format!("seed-{kname}-stream"), stream));
    }
    out
}

const ROBOTS: [(&str, &str); 3] = [
    ("sphere-omni", include_str!("../../robots/sphere-omni.toml")),
    ("ballbot", include_str!("../../robots/ballbot.toml")),
    ("caster3", include_str!("../../robots/caster3.toml")),
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

/// CSV tables: plans (sphere, caster) from the planner, a tracked run, encoder logs and
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
    v
}
