//! Late camera fixes through the `f32` runtime the firmware runs (its [`FIX_HISTORY`]-entry
//! fusion filter): a kiwi base whose encoders read 3 % short drives a circle, and fixes of the
//! true pose arrive late at a camera's rate. Every fix within the latency the history covers
//! is fused at its capture time, and the fused pose stays on the true one while the wheel
//! odometry drifts.

use omnikin::drive::omni::presets;
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::runtime::hal::{EncoderAngles, Encoders, MotorCommand, MotorOutputs, NoImu};
use omnikin::runtime::{CameraFix, Command, Config, FIX_HISTORY, Frame, Runtime};
use omnikin::{MAX_WHEELS, Pose2, Robot, Twist2};

/// Encoders that read `READ_SCALE` × the true wheel angles (a wheel radius 3 % off).
const READ_SCALE: f64 = 0.97;
const RATE_HZ: f64 = 100.0;
const DT_US: u64 = 10_000;

/// Motors that turn exactly as commanded; the true angles in f64.
struct Board {
    wheel: [f64; MAX_WHEELS],
    rates: [f32; MAX_WHEELS],
}

struct Reading([f32; MAX_WHEELS]);
impl Encoders<f32> for Reading {
    type Error = ();
    fn read(&mut self) -> Result<EncoderAngles<f32>, ()> {
        Ok(EncoderAngles {
            wheel: self.0,
            steer: [0.0; MAX_WHEELS],
        })
    }
}

impl MotorOutputs<f32> for Board {
    type Error = ();
    fn set_rates(&mut self, c: &MotorCommand<f32>) -> Result<(), ()> {
        self.rates = c.wheel;
        Ok(())
    }
}

/// Figures of one drive.
#[derive(Debug)]
struct Run {
    sent: u32,
    accepted: u32,
    too_late: u32,
    /// RMS distance fused pose – true pose over the second half of the drive, m.
    fused_rms: f64,
    /// The wheel odometry's distance to the true pose at the end, m.
    odometry_end: f64,
}

/// 20 s on a circle (0.3 m/s, 0.4 rad/s) with a fix of the true pose every `period` cycles,
/// captured `latency` cycles before it reaches the runtime.
fn drive(period: usize, latency: usize) -> Run {
    let kiwi = presets::kiwi::<f32>();
    let robot = Robot::omni(&kiwi).unwrap();
    let truth_robot = Robot::omni(&presets::kiwi::<f64>()).unwrap();
    let mut cfg = Config::<f32>::new(RATE_HZ as f32);
    cfg.watchdog = 1.0e3;
    let mut rt = Runtime::<f32, 16>::new(robot, cfg, Pose2::default()).unwrap();
    // The true pose: exact odometry of the true wheel angles.
    let mut truth = Odometry::new(truth_robot, Pose2::default());
    let mut board = Board {
        wheel: [0.0; MAX_WHEELS],
        rates: [0.0; MAX_WHEELS],
    };
    rt.handle(
        Command::Velocity {
            twist: Twist2::new(0.3, 0.0, 0.4),
            frame: Frame::Robot,
        },
        0,
    )
    .unwrap();
    let cycles = 2000;
    let mut poses = Vec::with_capacity(cycles);
    let (mut sent, mut sum2, mut n) = (0, 0.0, 0);
    let mut odometry_end = 0.0;
    for k in 0..cycles {
        let now = k as u64 * DT_US;
        let mut read = Reading(board.wheel.map(|a| (a * READ_SCALE) as f32));
        rt.cycle(now, &mut read, &mut NoImu, &mut board);
        let st = rt.status();
        let reading = EncoderReading {
            t: k as f64 / RATE_HZ,
            wheel_angles: board.wheel,
            steer_angles: [0.0; MAX_WHEELS],
        };
        truth.update(&reading, HeadingInput::Wheels).unwrap();
        let p = truth.pose();
        poses.push((now, p));
        if k >= cycles / 2 {
            let (dx, dy) = (f64::from(st.pose.x) - p.x, f64::from(st.pose.y) - p.y);
            sum2 += dx * dx + dy * dy;
            n += 1;
        }
        let (dx, dy) = (
            f64::from(st.odometry.x) - p.x,
            f64::from(st.odometry.y) - p.y,
        );
        odometry_end = (dx * dx + dy * dy).sqrt();
        for i in 0..MAX_WHEELS {
            board.wheel[i] += f64::from(board.rates[i]) / RATE_HZ;
        }
        if k >= latency && k % period == 0 {
            let (capture_us, p) = poses[k - latency];
            rt.handle(
                Command::Fix(CameraFix {
                    capture_us,
                    x: p.x as f32,
                    y: p.y as f32,
                    heading: Some(p.heading as f32),
                    std_xy: 0.01,
                    std_heading: 0.02,
                }),
                now,
            )
            .unwrap();
            sent += 1;
        }
    }
    let c = rt.fix_counters();
    Run {
        sent,
        accepted: c.accepted,
        too_late: c.too_late,
        fused_rms: (sum2 / f64::from(n)).sqrt(),
        odometry_end,
    }
}

fn check(r: &Run, rms_bound: f64) {
    assert_eq!(r.too_late, 0, "{r:?}");
    assert_eq!(r.accepted, r.sent, "{r:?}");
    assert!(r.odometry_end > 0.1, "the wheels drift: {r:?}");
    assert!(r.fused_rms < rms_bound, "{r:?}");
}

/// A 25 Hz camera whose frames arrive 0.3 s late.
#[test]
fn fixes_at_25_hz_arriving_300_ms_late_are_all_fused() {
    let r = drive(4, 30);
    println!("FIX_HISTORY {FIX_HISTORY}, 25 Hz, 0.3 s late: {r:?}");
    check(&r, 1e-3);
}

/// A 10 Hz camera whose frames arrive 0.9 s late (within the default 1 s `max_latency`).
#[test]
fn fixes_at_10_hz_arriving_900_ms_late_are_all_fused() {
    let r = drive(10, 90);
    println!("FIX_HISTORY {FIX_HISTORY}, 10 Hz, 0.9 s late: {r:?}");
    check(&r, 2e-3);
}
