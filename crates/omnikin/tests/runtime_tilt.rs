//! The sphere's tilt feedback in the core runtime (`Config::tilt`), in `f32` and `f64`: the
//! velocity it adds is `Δv = −R c (γ_xy − L a_xy)` before the inverse kinematics, the plan's
//! acceleration cancels the steady lean it asks for, and with it a gyro heading integrates the
//! angular velocity's vertical component.

use omnikin::runtime::hal::{EncoderAngles, Encoders, Imu, ImuSample, MotorCommand, MotorOutputs};
use omnikin::runtime::limits::motor_rates;
use omnikin::runtime::{Command, Config, Frame, PlanPoint, Runtime, TiltFeedback};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{MAX_WHEELS, Pose2, Real, Robot, Twist2};

/// A board whose wheels do not move (the encoders read zero) and whose IMU reads `imu`.
struct Board<T: Real> {
    imu: ImuSample<T>,
    cmd: MotorCommand<T>,
}

impl<T: Real> Encoders<T> for Board<T> {
    type Error = ();
    fn read(&mut self) -> Result<EncoderAngles<T>, ()> {
        Ok(EncoderAngles::zero())
    }
}
impl<T: Real> Imu<T> for Board<T> {
    type Error = ();
    fn read(&mut self) -> Result<Option<ImuSample<T>>, ()> {
        Ok(Some(self.imu))
    }
}
impl<T: Real> MotorOutputs<T> for Board<T> {
    type Error = ();
    fn set_rates(&mut self, c: &MotorCommand<T>) -> Result<(), ()> {
        self.cmd = *c;
        Ok(())
    }
}

fn sphere<T: Real>() -> Robot<T> {
    Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap())
}

/// Paper 000's preset as `closed_loop::tilt_feedback` designs it (rounded).
fn feedback<T: Real>() -> TiltFeedback<T> {
    TiltFeedback {
        gain: T::of(8.61),
        shell_radius: T::of(0.15),
        lean_per_accel: T::of(0.146),
        accel_time_constant: T::of(1.0),
    }
}

/// An accelerometer on a platform whose up direction, in its own frame, is `(sx, sy, ·)`.
fn tilted<T: Real>(sx: f64, sy: f64, gyro: [f64; 3]) -> ImuSample<T> {
    let sz = (1.0 - sx * sx - sy * sy).sqrt();
    ImuSample {
        gyro: gyro.map(T::of),
        accel: [T::of(9.81 * sx), T::of(9.81 * sy), T::of(9.81 * sz)],
    }
}

fn close<T: Real>(a: &[T; MAX_WHEELS], b: &[T; MAX_WHEELS], tol: f64) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| (x.to_f64() - y.to_f64()).abs() <= tol * (1.0 + y.to_f64().abs()))
}

/// At rest in velocity mode (no plan, no acceleration) a tilted platform gets exactly the
/// inverse kinematics of `Δv = −R c γ_xy`; without `Config::tilt` nothing moves.
fn tilt_alone<T: Real>(tol: f64) {
    let mut cfg = Config::<T>::new(T::of(100.0));
    cfg.tilt = Some(feedback());
    let imu = tilted::<T>(0.05, -0.02, [0.0; 3]);
    let mut rt =
        Runtime::<T, 16>::new(sphere(), cfg, Pose2::new(T::zero(), T::zero(), T::zero())).unwrap();
    let mut b = Board {
        imu,
        cmd: MotorCommand::zero(),
    };
    rt.handle(
        Command::Velocity {
            twist: Twist2::new(T::zero(), T::zero(), T::zero()),
            frame: Frame::Robot,
        },
        0,
    )
    .unwrap();
    rt.cycle(10_000, &mut b.clone_encoders(), &mut b.imu_reader(), &mut b);
    let k = -0.15 * 8.61;
    let dv = Twist2::new(T::of(k * 0.05), T::of(k * -0.02), T::zero());
    let want = motor_rates(&sphere(), dv, &[T::zero(); MAX_WHEELS]).unwrap();
    assert!(
        close(&b.cmd.wheel, &want.wheel, tol),
        "{:?} vs {:?}",
        b.cmd.wheel,
        want.wheel
    );
    assert!(b.cmd.wheel[0].to_f64().abs() > 0.1, "a visible command");
    // Without the feedback the same tilt commands nothing.
    let mut rt = Runtime::<T, 16>::new(
        sphere(),
        Config::new(T::of(100.0)),
        Pose2::new(T::zero(), T::zero(), T::zero()),
    )
    .unwrap();
    rt.handle(
        Command::Velocity {
            twist: Twist2::new(T::zero(), T::zero(), T::zero()),
            frame: Frame::Robot,
        },
        0,
    )
    .unwrap();
    rt.cycle(10_000, &mut b.clone_encoders(), &mut b.imu_reader(), &mut b);
    assert!(b.cmd.wheel.iter().all(|w| w.to_f64() == 0.0));
}

impl<T: Real> Board<T> {
    fn clone_encoders(&self) -> Board<T> {
        Board {
            imu: self.imu,
            cmd: MotorCommand::zero(),
        }
    }
    fn imu_reader(&self) -> Board<T> {
        self.clone_encoders()
    }
}

/// A plan accelerating at 0.5 m/s² along x, the platform leaning as the quasi-static law says
/// (`γ_x = L a`), the accelerometer reading the specific force (gravity plus the
/// acceleration): the tilt estimate removes the commanded acceleration, the feedback adds
/// nothing, the wheels get what the runtime without it commands. Level instead, the feedback
/// adds `R c L a` along x. (Without the subtraction the estimate would be the apparent
/// vertical, `a/g` = 0.051 rad off, and both comparisons fail.)
fn lean_reference<T: Real>(tol: f64) {
    let a = 0.5;
    let pts: Vec<PlanPoint<T>> = (0..=100)
        .map(|k| {
            let t = k as f64 * 0.01;
            PlanPoint {
                t: T::of(t),
                pose: Pose2::new(T::of(0.5 * a * t * t), T::zero(), T::zero()),
                twist: Twist2::new(T::of(a * t), T::zero(), T::zero()),
            }
        })
        .collect();
    let run = |tilt: Option<TiltFeedback<T>>, imu: ImuSample<T>| {
        let mut cfg = Config::<T>::new(T::of(100.0));
        cfg.tilt = tilt;
        let mut rt =
            Runtime::<T, 128>::new(sphere(), cfg, Pose2::new(T::zero(), T::zero(), T::zero()))
                .unwrap();
        rt.handle(Command::PlanBegin { id: 1, len: 101 }, 0)
            .unwrap();
        for (k, c) in pts.chunks(16).enumerate() {
            rt.handle(
                Command::PlanChunk {
                    id: 1,
                    offset: (k * 16) as u16,
                    points: c,
                },
                0,
            )
            .unwrap();
        }
        rt.handle(Command::PlanStart { id: 1 }, 0).unwrap();
        let mut b = Board {
            imu,
            cmd: MotorCommand::zero(),
        };
        for i in 1..=20u64 {
            rt.handle(Command::Heartbeat, i * 10_000).unwrap();
            rt.cycle(
                i * 10_000,
                &mut b.clone_encoders(),
                &mut b.imu_reader(),
                &mut b,
            );
        }
        b.cmd.wheel
    };
    let lean = 0.146 * a;
    // The accelerometer reads the specific force: gravity along the platform's up plus the
    // commanded acceleration (to first order in the tilt, what the estimate subtracts).
    let with_accel = |mut s: ImuSample<T>| {
        s.accel[0] += T::of(a);
        s
    };
    // τ = one cycle: the estimate is the accelerometer minus the commanded acceleration.
    let fb = TiltFeedback {
        accel_time_constant: T::of(0.01),
        ..feedback()
    };
    let none = run(None, with_accel(tilted(lean, 0.0, [0.0; 3])));
    let leaning = run(Some(fb), with_accel(tilted(lean, 0.0, [0.0; 3])));
    assert!(close(&leaning, &none, tol), "{leaning:?} vs {none:?}");
    let level = run(Some(fb), with_accel(tilted(0.0, 0.0, [0.0; 3])));
    let extra = motor_rates(
        &sphere(),
        Twist2::new(T::of(0.15 * 8.61 * lean), T::zero(), T::zero()),
        &[T::zero(); MAX_WHEELS],
    )
    .unwrap();
    for i in 0..3 {
        let d = level[i].to_f64() - none[i].to_f64();
        assert!(
            (d - extra.wheel[i].to_f64()).abs() < 1e3 * tol * (1.0 + d.abs()),
            "wheel {i}: {d} vs {:?}",
            extra.wheel
        );
    }
}

/// Turning at 1 rad/s about the vertical on a platform leaning by 0.3 rad: the gyro's z reads
/// `cos 0.3` of the turn. With `Config::tilt` the gyro heading integrates `ω·γ` (the true
/// rate); without it, the gyro's z.
fn vertical_rate<T: Real>(tol: f64) {
    let th = 0.3f64;
    // World vertical (0, 0, 1) in a platform pitched by th about y: γ = (−sin th, 0, cos th);
    // the angular velocity (0, 0, 1) world in the platform frame is the same vector.
    let g = [-th.sin(), 0.0, th.cos()];
    let imu = tilted::<T>(g[0], g[1], g);
    let heading = |tilt: Option<TiltFeedback<T>>| {
        let mut cfg = Config::<T>::new(T::of(100.0));
        cfg.tilt = tilt;
        cfg.heading_from_gyro = true;
        let mut rt =
            Runtime::<T, 16>::new(sphere(), cfg, Pose2::new(T::zero(), T::zero(), T::zero()))
                .unwrap();
        let mut b = Board {
            imu,
            cmd: MotorCommand::zero(),
        };
        for i in 1..=101u64 {
            rt.cycle(
                i * 10_000,
                &mut b.clone_encoders(),
                &mut b.imu_reader(),
                &mut b,
            );
        }
        rt.status().odometry.heading.to_f64()
    };
    // 100 steps of 10 ms after the first reading: 1 s.
    let with = heading(Some(feedback()));
    let without = heading(None);
    assert!((with - 1.0).abs() < tol, "{with}");
    assert!((without - th.cos()).abs() < tol, "{without}");
}

#[test]
fn the_tilt_alone_commands_its_velocity_f32_and_f64() {
    tilt_alone::<f32>(1e-4);
    tilt_alone::<f64>(1e-10);
}

#[test]
fn the_plans_acceleration_cancels_the_steady_lean_f32_and_f64() {
    lean_reference::<f32>(1e-5);
    lean_reference::<f64>(1e-12);
}

#[test]
fn a_tilted_gyro_heading_uses_the_vertical_rate_f32_and_f64() {
    vertical_rate::<f32>(1e-3);
    vertical_rate::<f64>(1e-9);
}

#[test]
fn bad_tilt_feedback_is_refused() {
    let mut cfg = Config::<f64>::new(100.0);
    cfg.tilt = Some(TiltFeedback {
        gain: -1.0,
        shell_radius: 0.15,
        lean_per_accel: 0.1,
        accel_time_constant: 1.0,
    });
    assert_eq!(cfg.validate().unwrap_err().field, "tilt.gain");
    cfg.tilt = Some(TiltFeedback {
        gain: 1.0,
        shell_radius: 0.0,
        lean_per_accel: 0.1,
        accel_time_constant: 1.0,
    });
    assert_eq!(cfg.validate().unwrap_err().field, "tilt.shell_radius");
}

/// The platform rocks about y, `θ(t) = 0.1 sin(7.5 t)` (the preset's rocking), on a shell at
/// rest; the IMU 0.087 m below the shell centre reads the rate `θ̇` and the specific force of
/// its point, `a_p = −d θ̈` along the platform's x (the tangential term), which tilts the
/// accelerometer's direction by up to `d · 0.1 · 7.5² / g` ≈ 0.05 rad. From 1 s to 3 s the
/// tilt estimate follows `γ_x = −sin θ` within 0.02 rad, while the accelerometer alone is off
/// by 0.04 rad or more. The expected error: the accelerometer's 0.050 rad through the filter
/// `1/(1 + s τ)` at 7.5 rad/s, 0.0066 rad, plus the gyro step's half-cycle lag,
/// `0.1 · 7.5 · 0.005` = 0.0038 rad (measured 0.013). With the gyro's sign flipped it fails.
fn rocking<T: Real>(flip_gyro: bool) -> (f64, f64) {
    let mut cfg = Config::<T>::new(T::of(100.0));
    cfg.tilt = Some(feedback());
    let mut rt =
        Runtime::<T, 16>::new(sphere(), cfg, Pose2::new(T::zero(), T::zero(), T::zero())).unwrap();
    let (d, amp, w, g) = (0.087, 0.1, 7.5, 9.81);
    let (mut worst_est, mut worst_acc) = (0.0f64, 0.0f64);
    for i in 0..=300u64 {
        let t = i as f64 * 0.01;
        let th = amp * (w * t).sin();
        let th_d = amp * w * (w * t).cos();
        let th_dd = -amp * w * w * (w * t).sin();
        // Specific force in the platform frame: gravity's components plus the point's
        // tangential acceleration along the platform's x.
        let up = [-th.sin(), 0.0, th.cos()];
        let f = [g * up[0] - d * th_dd, 0.0, g * up[2]];
        let rate = if flip_gyro { -th_d } else { th_d };
        let mut b = Board {
            imu: ImuSample {
                gyro: [T::zero(), T::of(rate), T::zero()],
                accel: f.map(T::of),
            },
            cmd: MotorCommand::zero(),
        };
        rt.cycle(
            i * 10_000,
            &mut b.clone_encoders(),
            &mut b.imu_reader(),
            &mut b,
        );
        if t >= 1.0 {
            let est = rt.tilt_estimate().unwrap();
            worst_est = worst_est.max((est[0].to_f64() - up[0]).abs());
            let n = (f[0] * f[0] + f[2] * f[2]).sqrt();
            worst_acc = worst_acc.max((f[0] / n - up[0]).abs());
        }
    }
    (worst_est, worst_acc)
}

#[test]
fn the_tilt_estimate_follows_the_rocking_through_the_gyro_f32_and_f64() {
    for (est, acc) in [rocking::<f32>(false), rocking::<f64>(false)] {
        assert!(est < 0.02, "estimate off by {est} rad");
        assert!(acc > 0.04, "the accelerometer alone must be off: {acc}");
    }
    let (est, _) = rocking::<f64>(true);
    assert!(est > 0.03, "a flipped gyro must fail: {est}");
}
