//! Runs `N` control cycles of one robot, or `N` calls of one kernel, for instruction counting
//! (`bench/instructions.sh` runs it under callgrind at two values of `N`: the difference of
//! the counts divided by the difference of the `N`s is the cost of one cycle or call, without
//! the set-up).
//!
//! `omnikin-cycle-driver WHAT N`, `WHAT` one of
//! * `sphere`, `ballbot`, `caster`: a full control cycle ([`omnikin_bench::Loop::step`]);
//! * `ROBOT-inverse`, `ROBOT-forward`, `ROBOT-odometry`: one kinematics call or odometry step
//!   on the shared input table;
//! * `plan20-RATE` (`plan20-11`, `plan20-1000`): building and planning the 20-waypoint spline of the peer
//!   comparison (time-optimal, sphere-omni limits) sampled at RATE Hz;
//! * `link-open`, `link-keyed`: one command frame (a `SetVelocity`) encoded by the operator's
//!   endpoint and decoded by the robot's, then one telemetry frame the other way, without and
//!   with a key — the per-frame cost of the link codec (its throughput on one core);
//! * `handshake-open`, `handshake-keyed`: one whole handshake (Hello, HelloAck, the first open
//!   frame that proves the key and opens the session) on both ends;
//! * `hello-open`, `hello-keyed`: the robot's answer to one (replayed) Hello — the cost a
//!   flood of Hellos imposes.

use std::hint::black_box;

use omnikin::Robot;
use omnikin::caster::CasterRates;
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::runtime::{Faults, Mode};
use omnikin_bench::{Inputs, K, Loop, robot};

/// Control cycles per telemetry frame in the `cycle` kernel: 1 kHz control, 50 Hz telemetry.
const TELEMETRY_EVERY: u64 = 20;

fn usage() -> ! {
    eprintln!(
        "usage: omnikin-cycle-driver WHAT N\n  WHAT: sphere|ballbot|caster (control cycle), \
         or sphere-tilt (the tilt feedback), or ROBOT-inverse|ROBOT-forward|ROBOT-odometry, or balance|balance-f64 (ballbot \
         balance controller)"
    );
    std::process::exit(2);
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(what), Some(n)) = (args.get(1), args.get(2).and_then(|s| s.parse::<u64>().ok()))
    else {
        usage()
    };
    if let Some(rate) = what.strip_prefix("plan20-") {
        let Ok(rate) = rate.parse::<f64>() else {
            usage()
        };
        let (_, heading, model, opts) = omnikin_bench::plan20(rate);
        let wps = omnikin_bench::waypoints20();
        for _ in 0..n {
            // Spline and plan, as WPILib's GenerateTrajectory builds its spline too.
            let path = omnikin_plan::path::Path::spline(black_box(&wps)).unwrap();
            black_box(omnikin_plan::planner::plan(&path, &heading, &model, &opts).unwrap());
        }
        return;
    }
    for (prefix, hello_only) in [("handshake-", false), ("hello-", true)] {
        if let Some(mode) = what.strip_prefix(prefix) {
            let keyed = match mode {
                "open" => false,
                "keyed" => true,
                _ => usage(),
            };
            handshakes(keyed, hello_only, n);
            return;
        }
    }
    if let Some(mode) = what.strip_prefix("link-") {
        let keyed = match mode {
            "open" => false,
            "keyed" => true,
            _ => usage(),
        };
        link_frames(keyed, n);
        return;
    }
    if what == "balance" || what == "balance-f64" {
        if what == "balance" {
            balance_cycles::<f32>(n);
        } else {
            balance_cycles::<f64>(n);
        }
        return;
    }
    let (name, kernel) = what.split_once('-').unwrap_or((what.as_str(), "cycle"));
    let Some(rob) = robot(name) else { usage() };
    let inp = Inputs::new();
    let k = |i: u64| i as usize & (K - 1);
    match (kernel, rob) {
        ("tilt", Robot::Sphere(_)) => {
            // The sphere's cycle with the tilt feedback and the gyro heading (`sphere-tilt`
            // in bench/budgets.toml).
            let mut lp = Loop::tilted(rob);
            for i in 1..n {
                black_box(lp.step_tilted(&inp));
                if i % TELEMETRY_EVERY == 0 {
                    let st = lp.status();
                    black_box(&st);
                }
            }
        }
        ("cycle", _) => {
            let mut lp = Loop::new(rob);
            // A firmware loop at 1 kHz sends telemetry at 50 Hz: the status is built every
            // 20th cycle (its cost, ~100 instructions, counts at that rate). Each status is
            // built in a fresh local and only its address escapes (a move into a variable kept
            // across iterations would count the driver's `memcpy`, not the runtime).
            for i in 1..n {
                black_box(lp.step(&inp));
                if i % TELEMETRY_EVERY == 0 {
                    let st = lp.status();
                    black_box(&st);
                }
            }
            if n > 0 {
                lp.step(&inp);
                let st = lp.status();
                // Every cycle must have run the full path (a stopped loop would be cheaper).
                assert_eq!(st.mode, Mode::Velocity, "{st:?}");
                // LIMIT (a motor limit shaped the command) is part of the work; nothing else.
                assert_eq!(st.faults.0 & !Faults::LIMIT.0, 0, "{st:?}");
            }
        }
        ("inverse", Robot::Sphere(s)) => {
            for i in 0..n {
                black_box(
                    s.wheel_rates(black_box(inp.twist[k(i)]), black_box(0.0))
                        .unwrap(),
                );
            }
        }
        ("inverse", Robot::Ballbot(b)) => {
            for i in 0..n {
                black_box(
                    b.wheel_rates(black_box(inp.twist[k(i)]), black_box(0.0))
                        .unwrap(),
                );
            }
        }
        ("inverse", Robot::Caster(c)) => {
            for i in 0..n {
                let r = c.motor_rates(
                    black_box(inp.twist[k(i)]),
                    black_box(inp.heading[k(i)]),
                    black_box(inp.steer[k(i)]),
                );
                black_box(r.unwrap());
            }
        }
        ("forward", Robot::Sphere(s)) => {
            for i in 0..n {
                let w = black_box([inp.twist[k(i)].vx, inp.twist[k(i)].vy, 0.3]);
                black_box(s.body_twist(w, black_box(0.0)).unwrap());
            }
        }
        ("forward", Robot::Ballbot(b)) => {
            for i in 0..n {
                let w = black_box([inp.twist[k(i)].vx, inp.twist[k(i)].vy, 0.3]);
                black_box(b.body_twist(w, black_box(0.0)).unwrap());
            }
        }
        ("forward", Robot::Caster(c)) => {
            for i in 0..n {
                let t = inp.twist[k(i)];
                let rates = black_box(CasterRates {
                    roll: [t.vx, t.vy, t.yaw_rate],
                    steer: [t.vy, t.yaw_rate, t.vx],
                });
                let r = c.body_twist(
                    &rates,
                    black_box(inp.heading[k(i)]),
                    black_box(inp.steer[k(i)]),
                );
                black_box(r.unwrap());
            }
        }
        ("odometry", rob) => {
            let mut odo = Odometry::new(rob, omnikin::Pose2::new(0.0, 0.0, 0.0));
            let (mut t, mut yaw, mut wheel) = (0.0f64, 0.0f64, [0.0f64; 3]);
            for i in 0..n {
                for j in 0..3 {
                    wheel[j] += inp.dist_step[k(i)][j] * 20.0;
                }
                t += 1e-3;
                yaw += 1e-3 * inp.twist[k(i)].yaw_rate;
                let reading = EncoderReading::with_steer(
                    black_box(t),
                    black_box(wheel),
                    black_box(inp.steer[k(i)]),
                );
                let step = odo.update(&reading, HeadingInput::Absolute(black_box(yaw)));
                black_box(step.unwrap());
            }
        }
        _ => usage(),
    }
}

/// `n` cycles of the ballbot's balance controller (issue 15): the AHRS quaternion and gyro
/// turned into heading-frame tilts ([`Measurement::from_attitude`]), then one controller step
/// (two 4-state LQR laws with feed-forward, the yaw law, the wheel-torque map, saturation).
fn balance_cycles<T: omnikin::Real>(n: u64) {
    use omnikin::control::{BalanceCommand, BalanceConfig, BalanceController, Measurement};
    use omnikin::nalgebra::{UnitQuaternion, Vector3};
    let mut c = BalanceController::<T>::new(BalanceConfig::preset()).unwrap();
    let cmd = BalanceCommand {
        velocity: [T::of(0.1), T::of(0.0)],
        acceleration: [T::of(0.0), T::of(0.05)],
        yaw_rate: T::of(0.1),
        lean: None,
    };
    // Orientations prepared outside the loop (set-up, not the cycle).
    let qs: Vec<UnitQuaternion<T>> = (0..1024)
        .map(|i| {
            let t = T::of(i as f64 * 1e-4);
            UnitQuaternion::from_scaled_axis(Vector3::new(t, -t, t))
        })
        .collect();
    for i in 0..n {
        let t = T::of((i & 1023) as f64 * 1e-4);
        let m = Measurement::from_attitude(
            black_box(&qs[(i & 1023) as usize]),
            black_box([t, T::of(0.01), T::of(0.1)]),
            black_box([t, T::of(0.0)]),
            black_box([T::of(0.1), t]),
        );
        black_box(c.step(&m, black_box(&cmd)).unwrap());
    }
}

/// `n` command frames operator → robot and `n` telemetry frames robot → operator, in one
/// established session (the handshake is set-up, outside the per-frame cost).
fn link_frames(keyed: bool, n: u64) {
    use omnikin::link::{
        Key, MAX_FRAME, Message, OperatorEvent, OperatorLink, PROTOCOL_VERSION, RobotEvent,
        RobotInfo, RobotKind, RobotLink,
    };
    use omnikin::runtime::Frame;
    use omnikin::runtime::hal::{Entropy, EntropyError};
    struct Fixed(u8);
    impl Entropy for Fixed {
        fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError> {
            buf.fill(self.0);
            self.0 = self.0.wrapping_add(1);
            Ok(())
        }
    }
    let key = keyed.then(|| Key::new(b"benchmark key, 32 bytes long ...").unwrap());
    let mut op = OperatorLink::new(key.clone());
    let mut rob = RobotLink::new(key);
    let mut lp = Loop::new(robot("sphere").unwrap());
    let inp = Inputs::new();
    lp.step(&inp);
    let status = lp.status();
    let info = RobotInfo {
        protocol: PROTOCOL_VERSION,
        kind: RobotKind::Sphere,
        plan_capacity: 16,
        rate_hz: 1000.0,
        watchdog: 0.5,
        authenticated: keyed,
        limits: omnikin::link::RobotLimits {
            max_accel: 1.0,
            max_yaw_accel: 4.0,
            max_jerk: f32::INFINITY,
        },
    };
    let (mut rng, mut buf, mut reply) = (Fixed(1), [0u8; MAX_FRAME], [0u8; MAX_FRAME]);
    let m = op.hello(&mut rng, &mut buf).unwrap();
    let Ok(RobotEvent::Hello(a)) =
        rob.receive(&mut buf[..m - 1], 0, &[], &info, &mut rng, &mut reply)
    else {
        panic!("hello")
    };
    assert!(matches!(
        op.receive(&mut reply[..a - 1]),
        Ok(OperatorEvent::Established(_))
    ));
    let tele = Message::Telemetry(rob.telemetry(&status));
    let mut ok = 0u64;
    for i in 0..n {
        let cmd = Message::SetVelocity {
            frame: Frame::Robot,
            vx: black_box(i as f32 * 1e-6),
            vy: 0.1,
            yaw_rate: 0.2,
        };
        let m = op.encode(black_box(&cmd), &mut buf).unwrap();
        ok += rob
            .receive(
                black_box(&mut buf[..m - 1]),
                0,
                &[],
                &info,
                &mut rng,
                &mut reply,
            )
            .is_ok() as u64;
        let m = rob.encode(black_box(&tele), &mut buf).unwrap();
        ok += op.receive(black_box(&mut buf[..m - 1])).is_ok() as u64;
    }
    assert_eq!(ok, 2 * n, "every frame must decode");
}

/// `n` handshakes (or, with `hello_only`, `n` answers to one replayed Hello).
fn handshakes(keyed: bool, hello_only: bool, n: u64) {
    use omnikin::link::{
        Key, MAX_FRAME, Message, OperatorEvent, OperatorLink, PROTOCOL_VERSION, RobotEvent,
        RobotInfo, RobotKind, RobotLink,
    };
    use omnikin::runtime::hal::{Entropy, EntropyError};
    struct Counter(u64);
    impl Entropy for Counter {
        fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError> {
            for b in buf {
                self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1);
                *b = (self.0 >> 56) as u8;
            }
            Ok(())
        }
    }
    // An IPv4 address and port, as a UDP host passes it.
    const PEER: &[u8] = &[127, 0, 0, 1, 0x1b, 0x58];
    let key = keyed.then(|| Key::new(b"benchmark key, 32 bytes long ...").unwrap());
    let mut rob = RobotLink::new(key.clone());
    let info = RobotInfo {
        protocol: PROTOCOL_VERSION,
        kind: RobotKind::Sphere,
        plan_capacity: 16,
        rate_hz: 1000.0,
        watchdog: 0.5,
        authenticated: keyed,
        limits: omnikin::link::RobotLimits {
            max_accel: 1.0,
            max_yaw_accel: 4.0,
            max_jerk: f32::INFINITY,
        },
    };
    let (mut rng, mut buf, mut reply) = (Counter(1), [0u8; MAX_FRAME], [0u8; MAX_FRAME]);
    let mut opened = 0u64;
    let mut hello = OperatorLink::new(key.clone());
    let h = hello.hello(&mut rng, &mut buf).unwrap();
    let recorded = buf[..h - 1].to_vec();
    for i in 0..n {
        let now = i * 1000;
        if hello_only {
            let mut f = recorded.clone();
            let r = rob.receive(black_box(&mut f), now, PEER, &info, &mut rng, &mut reply);
            opened += matches!(r, Ok(RobotEvent::Hello(_))) as u64;
            continue;
        }
        let mut op = OperatorLink::new(key.clone());
        op.set_take_over(true);
        let m = op.hello(&mut rng, &mut buf).unwrap();
        let Ok(RobotEvent::Hello(a)) = rob.receive(
            black_box(&mut buf[..m - 1]),
            now,
            PEER,
            &info,
            &mut rng,
            &mut reply,
        ) else {
            panic!("hello")
        };
        assert!(matches!(
            op.receive(&mut reply[..a - 1]),
            Ok(OperatorEvent::Established(_))
        ));
        let m = op.encode(&Message::Heartbeat, &mut buf).unwrap();
        let r = rob.receive(
            black_box(&mut buf[..m - 1]),
            now,
            PEER,
            &info,
            &mut rng,
            &mut reply,
        );
        opened += matches!(
            r,
            Ok(RobotEvent::Message {
                new_session: true,
                ..
            })
        ) as u64;
    }
    assert_eq!(opened, n, "every handshake must complete");
}
