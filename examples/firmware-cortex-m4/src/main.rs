//! omnikin on a microcontroller: the robot runtime and the link codec, `no_std`, no heap, in
//! `f32`, on a Cortex-M4F (QEMU `mps2-an386`), for each of the three paper robots and a mecanum base.
//!
//! Each robot runs against a minimal in-firmware plant (motors turn as commanded; the sphere's
//! steppers through [`Steppers`] with 3200 microsteps per revolution, so its encoders read
//! whole steps). An in-firmware "operator" runs the v2 handshake and encodes authenticated
//! session frames exactly as the PC would, and the bytes go through the robot's
//! [`FrameReader`] and [`RobotLink`] — the code path a UART or radio interrupt would feed.
//! QEMU's `mps2-an386` has no TRNG: the nonces come from [`TestOnlyEntropy`], a labelled
//! stand-in that a real board replaces with its hardware RNG. Per robot: upload a 4 s plan in chunks, follow it, then drive at
//! 0.2 m/s and cut the link. Then the ballbot's balance controller ([`balance`]) balances its
//! linearised planar models from a 5° lean. The results go out over semihosting; the exit code says whether
//! every check passed.
//!
//! **Memory.** The runtime and the link state live in `static`s (`.bss`), built once at boot
//! ([`boot`]) and reset in place for each robot ([`Runtime::reset`]), so the robots' runs keep
//! only the cycle's frames on the stack. The report gives the peak stack of the boot
//! (building the runtime) and of the runs separately.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use omnikin::ballbot::{Ballbot, BallbotParams};
use omnikin::caster::{Caster3, CasterParams};
use omnikin::link::{
    CHUNK_POINTS, FrameReader, Key, MAX_FRAME, Message, OperatorEvent, OperatorLink, RobotEvent,
    RobotInfo, RobotLink, WirePoint, heapless, robot_info, serve,
};
use omnikin::runtime::hal::{
    EncoderAngles, Encoders, Entropy, EntropyError, Imu, ImuSample, MotorCommand, MotorOutputs,
    StepOutputs, Steppers,
};
use omnikin::runtime::limits::motor_rates;
use omnikin::runtime::{
    Command, Config, ConfigError, Frame, Mode, PlanPoint, Runtime, TiltFeedback,
};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{MAX_WHEELS, Pose2, Robot, Twist2, se2};
use panic_semihosting as _;

mod balance;

const DT: f32 = 0.01;
const DT_US: u64 = 10_000;
/// Plan buffer of the firmware, points.
const PLAN_CAPACITY: usize = 256;
const PLAN_POINTS: usize = 81;

/// Motors that turn exactly as commanded (rad/s), or steppers (steps/s, whole steps).
struct Plant {
    wheel: [f32; MAX_WHEELS],
    steer: [f32; MAX_WHEELS],
    rates: MotorCommand<f32>,
    /// Stepper mode: accumulated microsteps and microsteps per radian.
    steps: [f32; MAX_WHEELS],
    steps_per_rad: Option<f32>,
}

impl Plant {
    fn new(steps_per_rad: Option<f32>) -> Self {
        Plant {
            wheel: [0.0; MAX_WHEELS],
            steer: [0.0; MAX_WHEELS],
            rates: MotorCommand::zero(),
            steps: [0.0; MAX_WHEELS],
            steps_per_rad,
        }
    }
    fn advance(&mut self) {
        for i in 0..MAX_WHEELS {
            match self.steps_per_rad {
                // `rates.wheel` holds step frequencies in stepper mode.
                Some(k) => {
                    self.steps[i] += self.rates.wheel[i] * DT;
                    self.wheel[i] = libm_round(self.steps[i]) / k;
                }
                None => self.wheel[i] += self.rates.wheel[i] * DT,
            }
            self.steer[i] += self.rates.steer[i] * DT;
        }
    }
    fn reading(&self) -> Reading {
        Reading(EncoderAngles {
            wheel: self.wheel,
            steer: self.steer,
        })
    }
}

fn libm_round(x: f32) -> f32 {
    // Round half away from zero without libm: the nearest whole step.
    let t = x as i64 as f32;
    let f = x - t;
    if f >= 0.5 {
        t + 1.0
    } else if f <= -0.5 {
        t - 1.0
    } else {
        t
    }
}

impl MotorOutputs<f32> for Plant {
    type Error = ();
    fn set_rates(&mut self, c: &MotorCommand<f32>) -> Result<(), ()> {
        self.rates = *c;
        Ok(())
    }
}

/// Stepper drivers: the step frequencies land in the plant's `rates.wheel`.
struct StepPins<'a>(&'a mut Plant);
impl StepOutputs for StepPins<'_> {
    type Error = ();
    fn set_step_frequencies(&mut self, hz: [f32; 2 * MAX_WHEELS]) -> Result<(), ()> {
        self.0.rates.wheel.copy_from_slice(&hz[..MAX_WHEELS]);
        self.0.rates.steer = [0.0; MAX_WHEELS];
        Ok(())
    }
}

struct Reading(EncoderAngles<f32>);
impl Encoders<f32> for Reading {
    type Error = ();
    fn read(&mut self) -> Result<EncoderAngles<f32>, ()> {
        Ok(self.0)
    }
}

/// **TEST ONLY — NOT RANDOM.** QEMU's `mps2-an386` has no TRNG, so this example's nonces
/// come from a xorshift generator with a fixed seed. A real firmware implements [`Entropy`]
/// on its hardware RNG (e.g. the STM32 `RNG` peripheral); predictable nonces would let a
/// recorded session be replayed.
struct TestOnlyEntropy(u32);
impl Entropy for TestOnlyEntropy {
    fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError> {
        for b in buf {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 17;
            self.0 ^= self.0 << 5;
            *b = (self.0 >> 24) as u8;
        }
        Ok(())
    }
}

/// The operator's frames, delivered byte by byte through the robot's frame reader: the link
/// state, in a `static` beside the runtime ([`main`]).
struct Wire {
    operator: OperatorLink,
    robot: RobotLink,
    info: RobotInfo,
    rng: TestOnlyEntropy,
    reader: FrameReader<MAX_FRAME>,
    buf: [u8; MAX_FRAME],
    reply: [u8; MAX_FRAME],
}

impl Wire {
    /// Both ends of a new link with `key` (no session), for a robot that answers `info`.
    fn new(key: Key, info: RobotInfo) -> Self {
        Wire {
            operator: OperatorLink::new(Some(key.clone())),
            robot: RobotLink::new(Some(key)),
            info,
            rng: TestOnlyEntropy(0x2545_f491),
            reader: FrameReader::new(),
            buf: [0; MAX_FRAME],
            reply: [0; MAX_FRAME],
        }
    }

    /// [`Wire::new`] in place (no second link state on the stack).
    fn restart(&mut self, key: Key, info: RobotInfo) {
        self.operator = OperatorLink::new(Some(key.clone()));
        self.robot = RobotLink::new(Some(key));
        self.info = info;
        self.rng = TestOnlyEntropy(0x2545_f491);
        self.reader = FrameReader::new();
        self.buf.fill(0);
        self.reply.fill(0);
    }

    /// Feeds `self.buf[..n]` to the robot; returns the length of a HelloAck it answered.
    fn deliver(&mut self, n: usize, rt: &mut Runtime<f32, PLAN_CAPACITY>, now: u64) -> usize {
        let (robot, info, rng, reply) =
            (&mut self.robot, &self.info, &mut self.rng, &mut self.reply);
        let mut answer = 0;
        self.reader.feed(&self.buf[..n], |f| match f {
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

    /// The v3 handshake: Hello, HelloAck, then the first (open) frame proves the key.
    fn connect(&mut self, rt: &mut Runtime<f32, PLAN_CAPACITY>, now: u64) -> bool {
        let Ok(n) = self.operator.hello(&mut self.rng, &mut self.buf) else {
            return false;
        };
        let a = self.deliver(n, rt, now);
        if a == 0 {
            return false;
        }
        let mut ack = self.reply;
        if !matches!(
            self.operator.receive(&mut ack[..a - 1]),
            Ok(OperatorEvent::Established(_))
        ) {
            return false;
        }
        self.send(&Message::Heartbeat, rt, now);
        self.robot.session_id().is_some()
    }

    fn send(&mut self, msg: &Message, rt: &mut Runtime<f32, PLAN_CAPACITY>, now: u64) {
        let Ok(n) = self.operator.encode(msg, &mut self.buf) else {
            return;
        };
        self.deliver(n, rt, now);
    }
}

/// A smooth rest-to-rest 4 s curve (world frame) sampled every 0.05 s.
fn plan() -> [PlanPoint<f32>; PLAN_POINTS] {
    let twist = |t: f32| {
        let s = libm_sin(core::f32::consts::PI * t / 4.0);
        Twist2::new(0.15 * s * s, 0.02 * s, 0.4 * s * s)
    };
    let mut pts = [PlanPoint::zero(); PLAN_POINTS];
    let mut pose = Pose2::new(0.0, 0.0, 0.0);
    for (k, p) in pts.iter_mut().enumerate() {
        let t = k as f32 * 0.05;
        *p = PlanPoint {
            t,
            pose,
            twist: twist(t).to_world(pose.heading),
        };
        for j in 0..20 {
            pose = se2::integrate(pose, twist(t + (j as f32 + 0.5) * 0.0025), 0.0025);
        }
    }
    pts
}

fn libm_sin(x: f32) -> f32 {
    use omnikin::nalgebra::ComplexField;
    x.sin()
}

struct Outcome {
    max_err: f32,
    end_err: f32,
    stop_s: f32,
    ok_frames: u32,
    dropped: u32,
    rejected: u32,
}

/// One robot's drive on the runtime and link that live in `static`s ([`main`]): `rt` is reset
/// in place for `robot`, `wire` restarted with a new link.
fn run(
    rt: &mut Runtime<f32, PLAN_CAPACITY>,
    wire: &mut Wire,
    robot: Robot<f32>,
    config: Config<f32>,
    steps_per_rad: Option<f32>,
) -> Option<Outcome> {
    rt.reset(robot, config, Pose2::default()).ok()?;
    let key = Key::new(b"omnikin firmware example key!!").ok()?;
    wire.restart(key, robot_info(rt, true));
    let mut plant = Plant::new(steps_per_rad);
    let mut now = 0u64;
    let cycle = |rt: &mut Runtime<f32, PLAN_CAPACITY>, plant: &mut Plant, now: &mut u64| {
        let mut enc = plant.reading();
        match plant.steps_per_rad {
            Some(k) => {
                let mut steppers = Steppers::new(StepPins(plant), 200, 16, 1.0e5);
                steppers.steps_per_rad = [k; 2 * MAX_WHEELS];
                rt.cycle(*now, &mut enc, &mut BoardImu(None), &mut steppers);
            }
            None => {
                rt.cycle(*now, &mut enc, &mut BoardImu(None), plant);
            }
        }
        plant.advance();
        *now += DT_US;
        // This test drive reads the state every cycle; a robot's loop builds it at its
        // telemetry rate.
        rt.status()
    };

    // Upload and follow the plan.
    let pts = plan();
    if !wire.connect(rt, now) {
        return None;
    }
    wire.send(
        &Message::PlanBegin {
            id: 1,
            len: PLAN_POINTS as u16,
        },
        rt,
        now,
    );
    for (k, c) in pts.chunks(CHUNK_POINTS).enumerate() {
        let mut v = heapless::Vec::new();
        for p in c {
            v.push(WirePoint::from_point(p)).ok()?;
        }
        let m = Message::PlanChunk {
            id: 1,
            offset: (k * CHUNK_POINTS) as u16,
            points: v,
        };
        wire.send(&m, rt, now);
    }
    wire.send(&Message::PlanStart { id: 1 }, rt, now);
    if rt.mode() != Mode::Trajectory {
        return None;
    }
    let mut max_err = 0.0f32;
    for _ in 0..450 {
        wire.send(&Message::Heartbeat, rt, now);
        let st = cycle(rt, &mut plant, &mut now);
        if st.mode == Mode::Trajectory {
            let (dx, dy) = (st.pose.x - st.reference.x, st.pose.y - st.reference.y);
            let e = (dx * dx + dy * dy).sqrt_f32();
            if e > max_err {
                max_err = e;
            }
        }
    }
    let end = pts[PLAN_POINTS - 1].pose;
    let p = rt.pose();
    let end_err = ((p.x - end.x) * (p.x - end.x) + (p.y - end.y) * (p.y - end.y)).sqrt_f32();

    // Drive at 0.2 m/s, then the link goes silent.
    let v = Message::SetVelocity {
        frame: Frame::Robot,
        vx: 0.2,
        vy: 0.0,
        yaw_rate: 0.0,
    };
    for _ in 0..100 {
        wire.send(&v, rt, now);
        cycle(rt, &mut plant, &mut now);
    }
    let last = now - DT_US;
    let mut stop_s = -1.0;
    for _ in 0..200 {
        let st = cycle(rt, &mut plant, &mut now);
        if st.mode == Mode::Idle {
            stop_s = (st.time_us - last) as f32 * 1e-6;
            break;
        }
    }
    let c = wire.robot.counters();
    Some(Outcome {
        max_err,
        end_err,
        stop_s,
        ok_frames: c.ok,
        dropped: c.dropped(),
        rejected: rt.rejected(),
    })
}

trait SqrtF32 {
    fn sqrt_f32(self) -> f32;
}
impl SqrtF32 for f32 {
    fn sqrt_f32(self) -> f32 {
        use omnikin::nalgebra::ComplexField;
        self.sqrt()
    }
}

/// Bytes of stack painted below `main`'s frame to measure the peak stack use.
const PAINT: usize = 96 * 1024;
const PATTERN: u32 = 0xA5A5_5A5A;

/// Fills the stack region below the current stack pointer with a pattern (leaving 256 bytes
/// for this function). Returns the painted range `[low, high)`.
fn paint_stack() -> (usize, usize) {
    let sp = cortex_m::register::msp::read() as usize;
    let (low, high) = (sp - PAINT, sp - 256);
    let mut a = low;
    while a < high {
        // SAFETY: RAM below the stack pointer is unused stack on this single-threaded
        // firmware (4 MiB of RAM, no heap, no other users).
        unsafe { core::ptr::write_volatile(a as *mut u32, PATTERN) };
        a += 4;
    }
    (low, high)
}

unsafe extern "C" {
    /// Top of the stack (end of RAM), from cortex-m-rt's link.x.
    static _stack_start: u32;
}

/// Peak stack use since reset, bytes: from the stack top down to the deepest word of the
/// painted region that was overwritten (`main`'s own frame sits above the painted region and
/// is included).
fn stack_used((low, high): (usize, usize)) -> usize {
    let mut a = low;
    // SAFETY: reads of the same painted stack region.
    while a < high && unsafe { core::ptr::read_volatile(a as *const u32) } == PATTERN {
        a += 4;
    }
    let top = core::ptr::addr_of!(_stack_start) as usize;
    top - a
}

/// A robot of the example: its name, its model (`None`: rejected) and, for steppers, the
/// microsteps per radian.
type RobotCase = (&'static str, Option<Robot<f32>>, Option<f32>);

/// What [`Runtime::new`] returns for the firmware's runtime.
type RuntimeResult = Result<Runtime<f32, PLAN_CAPACITY>, ConfigError>;

/// Builds the runtime into its `static` slot, once, at boot. The result stays a `Result`
/// (unwrapping it would move the runtime once more). Rust has no placement construction and
/// the core has no `unsafe`: `Runtime::new` builds its value in this function's frame, which
/// is then copied into `slot` (LLVM does not build a call's result in a `static` directly), so
/// the boot's stack peak is about one `Runtime` plus this frame's other temporaries; the
/// robots' runs after it use much less (both are reported).
#[inline(never)]
fn build_runtime(
    slot: &'static mut MaybeUninit<RuntimeResult>,
    robot: Robot<f32>,
    config: Config<f32>,
) -> &'static mut RuntimeResult {
    slot.write(Runtime::new(robot, config, Pose2::default()))
}

/// Builds the runtime and the link state into their `static`s (`.bss`), once: the runtime
/// for the first robot, reset in place for each robot after. `None` if either cannot be built.
#[inline(never)]
fn boot(cfg: Config<f32>) -> Option<(&'static mut Runtime<f32, PLAN_CAPACITY>, &'static mut Wire)> {
    let sphere = SphereOmni::new(SphereParams::preset()).ok()?;
    let slot = cortex_m::singleton!(RUNTIME: MaybeUninit<RuntimeResult> = MaybeUninit::uninit())?;
    let rt = build_runtime(slot, Robot::Sphere(sphere), cfg)
        .as_mut()
        .ok()?;
    let key = Key::new(b"omnikin firmware example key!!").ok()?;
    let wire = cortex_m::singleton!(WIRE: Wire = Wire::new(key, robot_info(rt, true)))?;
    Some((rt, wire))
}

#[entry]
fn main() -> ! {
    let painted = paint_stack();
    hprintln!(
        "omnikin firmware: Cortex-M4F, f32, plan buffer {} points, Runtime {} bytes, link state {} bytes (frame buffer {} bytes), both static",
        PLAN_CAPACITY,
        core::mem::size_of::<Runtime<f32, PLAN_CAPACITY>>(),
        core::mem::size_of::<Wire>(),
        MAX_FRAME
    );
    let mut cfg = Config::<f32>::new(100.0);
    cfg.watchdog = 0.5;
    cfg.slew.accel = 1.0;
    let Some((rt, wire)) = boot(cfg) else {
        hprintln!("runtime or link state: not built");
        debug::exit(debug::EXIT_FAILURE);
        loop {
            cortex_m::asm::wfi();
        }
    };
    let boot_stack = stack_used(painted);
    // Painted again: the peak of the robots' runs alone.
    let painted = paint_stack();
    let all = drive_all(rt, wire, cfg);
    let run_stack = stack_used(painted);
    hprintln!(
        "peak stack since reset: {} bytes (the only RAM in use besides .data + .bss): building the runtime at boot {} bytes, the robots' runs {} bytes",
        boot_stack.max(run_stack),
        boot_stack,
        run_stack
    );
    hprintln!("{}", if all { "ALL PASS" } else { "SOME FAILED" });
    debug::exit(if all {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::wfi();
    }
}

/// The board's IMU: none for the robots' runs (as `NoImu`), a fixed sample for the tilt check.
/// One type for both, so the control cycle is compiled once for them (flash).
struct BoardImu(Option<ImuSample<f32>>);

impl Imu<f32> for BoardImu {
    type Error = core::convert::Infallible;
    fn read(&mut self) -> Result<Option<ImuSample<f32>>, Self::Error> {
        Ok(self.0)
    }
}

/// The sphere's tilt feedback (`Config::tilt`, docs/closed-loop.md) on this core in `f32`: the
/// static runtime reset for the sphere with paper 000's designed feedback, at rest in velocity
/// mode on a platform whose up direction reads `(0.05, −0.02, ·)`; its wheels must get the
/// inverse kinematics of `Δv = −R c γ_xy`. Returns the largest wheel-rate error, rad/s.
#[inline(never)]
fn tilt_check(rt: &mut Runtime<f32, PLAN_CAPACITY>) -> Option<f32> {
    let mut cfg = Config::new(100.0f32);
    cfg.tilt = Some(TiltFeedback {
        gain: 8.61,
        shell_radius: 0.15,
        lean_per_accel: 0.146,
        accel_time_constant: 1.0,
    });
    cfg.heading_from_gyro = true;
    let robot = Robot::Sphere(SphereOmni::new(SphereParams::preset()).ok()?);
    rt.reset(robot, cfg, Pose2::default()).ok()?;
    rt.handle(
        Command::Velocity {
            twist: Twist2::new(0.0, 0.0, 0.0),
            frame: Frame::Robot,
        },
        0,
    )
    .ok()?;
    let (x, y) = (0.05f32, -0.02f32);
    let z = (1.0 - x * x - y * y).sqrt_f32();
    let mut imu = BoardImu(Some(ImuSample {
        gyro: [0.0; 3],
        accel: [9.81 * x, 9.81 * y, 9.81 * z],
    }));
    let mut plant = Plant::new(None);
    let mut enc = plant.reading();
    rt.cycle(DT_US, &mut enc, &mut imu, &mut plant);
    let k = -0.15 * 8.61;
    let want = motor_rates(&robot, Twist2::new(k * x, k * y, 0.0), &[0.0; MAX_WHEELS]).ok()?;
    Some(
        plant
            .rates
            .wheel
            .iter()
            .zip(want.wheel)
            .fold(0.0f32, |m, (a, b)| m.max((a - b).abs())),
    )
}

/// Each robot's run on the static runtime and link, then the ballbot's balance controller.
/// Whether every check passed.
#[inline(never)]
fn drive_all(rt: &mut Runtime<f32, PLAN_CAPACITY>, wire: &mut Wire, cfg: Config<f32>) -> bool {
    let robots: [RobotCase; 4] = [
        (
            "sphere-omni (steppers)",
            SphereOmni::new(SphereParams::preset())
                .ok()
                .map(Robot::Sphere),
            Some(3200.0 / core::f32::consts::TAU),
        ),
        (
            "ballbot",
            Ballbot::new(BallbotParams::preset())
                .ok()
                .map(Robot::Ballbot),
            None,
        ),
        (
            "caster3",
            Caster3::new(CasterParams::preset()).ok().map(Robot::Caster),
            None,
        ),
        (
            "mecanum",
            Robot::omni(&omnikin::drive::omni::presets::mecanum()).ok(),
            None,
        ),
    ];
    let mut all = true;
    for (name, robot, steps) in robots {
        let Some(robot) = robot else {
            hprintln!("{}: model rejected", name);
            all = false;
            continue;
        };
        match run(rt, wire, robot, cfg, steps) {
            Some(o) => {
                // Stop: watchdog 0.5 s + braking 0.2 s at 1 m/s², within two cycles.
                let pass = o.max_err < 2e-3
                    && o.end_err < 2e-3
                    && (0.69..=0.73).contains(&o.stop_s)
                    && o.dropped == 0
                    && o.rejected == 0;
                all &= pass;
                hprintln!(
                    "{}: plan max error {:.6} m, end error {:.6} m; link cut at 0.2 m/s -> at rest after {:.2} s; frames ok {}, dropped {}, rejected {}: {}",
                    name,
                    o.max_err,
                    o.end_err,
                    o.stop_s,
                    o.ok_frames,
                    o.dropped,
                    o.rejected,
                    if pass { "PASS" } else { "FAIL" }
                );
            }
            None => {
                hprintln!("{}: run failed", name);
                all = false;
            }
        }
    }
    match tilt_check(rt) {
        Some(err) => {
            let pass = err < 1e-4;
            all &= pass;
            hprintln!(
                "sphere tilt feedback (f32): wheel rates within {:.2e} rad/s of the inverse kinematics of -R c gamma_xy: {}",
                err,
                if pass { "PASS" } else { "FAIL" }
            );
        }
        None => {
            hprintln!("sphere tilt feedback: reset or cycle failed");
            all = false;
        }
    }
    match balance::run() {
        Some(b) => {
            let pass = b.settle_s <= 3.0 && b.final_tilt_deg < 0.1 && !b.fell;
            all &= pass;
            hprintln!(
                "ballbot balance controller (f32, 200 Hz, linearised plant): 5° -> below 0.5° from {:.2} s on, {:.4}° at 5 s, {} saturated cycles: {}",
                b.settle_s,
                b.final_tilt_deg,
                b.saturated,
                if pass { "PASS" } else { "FAIL" }
            );
        }
        None => {
            hprintln!("ballbot balance controller: design or cycle failed");
            all = false;
        }
    }
    all
}
