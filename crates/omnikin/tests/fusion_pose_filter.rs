//! `PoseFusion` as a pose filter (its gyro-bias and wheel-scale states switched off, the
//! configuration that replaced the former 3-state `PoseEstimator`, whose tests these are):
//! late fixes are fused at their timestamp (identical to receiving them on time), latency
//! compensation beats fusing a fix at its arrival, out-of-order fixes commute, the χ² gate
//! rejects outliers, camera fusion bounds the error while odometry drifts, the covariance is
//! consistent (NEES), and the per-step odometry, filter and AHRS updates never allocate
//! (counting allocator).

use omnikin_testkit::allocations;

use nalgebra::{Matrix3, Vector3};
use omnikin::caster::{Caster3, CasterParams};
use omnikin::estimate::ahrs::{Mahony, MahonyGains};
use omnikin::estimate::fix::{Fix, Gate};
use omnikin::estimate::fusion::{FusionConfig, FusionOutcome, PoseFusion, StepHeading};
use omnikin::estimate::noise::ProcessNoise;
use omnikin::estimate::odometry::{EncoderReading, HeadingInput, Odometry};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Robot, Twist2, se2};

#[global_allocator]
static GLOBAL: omnikin_testkit::Counting = omnikin_testkit::Counting;

/// Small seeded Gaussian source (xorshift64* + Box–Muller) so the core needs no `rand`.
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (core::f64::consts::TAU * v).cos()
    }
}

fn cov(sxy: f64, sth: f64) -> Matrix3<f64> {
    Matrix3::from_diagonal(&Vector3::new(sxy * sxy, sxy * sxy, sth * sth))
}

/// A robot on an arc (robot-frame twist 0.3 m/s, 0.4 rad/s), steps of 20 ms.
const DT: f64 = 0.02;
fn true_step() -> Pose2<f64> {
    se2::twist_exp(Twist2::new(0.3, 0.0, 0.4), DT)
}

type Est = PoseFusion<f64, 64>;

/// The filter as a 3-state pose filter (gyro-bias and wheel-scale states switched off) with
/// odometry noise `noise`, started at the origin with covariance `p0`.
fn pose_filter(p0: Matrix3<f64>, noise: ProcessNoise<f64>) -> Est {
    Est::new(
        0.0,
        Pose2::new(0.0, 0.0, 0.0),
        p0,
        FusionConfig {
            noise,
            gyro_bias_std: 0.0,
            scale_std: 0.0,
            ..FusionConfig::default()
        },
    )
    .unwrap()
}

fn estimator() -> Est {
    pose_filter(cov(0.01, 0.01), ProcessNoise::wheel_odometry())
}

/// Odometry with a heading bias: every step turns 2 % too much.
fn biased_step() -> Pose2<f64> {
    let d = true_step();
    Pose2::new(d.x, d.y, d.heading * 1.02)
}

fn close(a: Pose2<f64>, b: Pose2<f64>, tol: f64) -> bool {
    (a.x - b.x).abs() < tol && (a.y - b.y).abs() < tol && (a.heading - b.heading).abs() < tol
}

#[test]
fn a_late_fix_is_the_same_as_an_on_time_fix() {
    // Fix taken at step 30 (t = 0.6 s), arriving 7 steps (140 ms) later.
    let fix = Fix {
        t: 0.6,
        x: 0.17,
        y: 0.02,
        heading: Some(0.25),
        std_xy: 0.01,
        std_heading: 0.02,
    };
    let mut on_time = estimator();
    let mut late = estimator();
    for k in 1..=40 {
        let t = k as f64 * DT;
        on_time
            .predict(t, biased_step(), StepHeading::Wheels)
            .unwrap();
        late.predict(t, biased_step(), StepHeading::Wheels).unwrap();
        if k == 30 {
            assert!(matches!(
                on_time.add_fix(&fix).unwrap(),
                FusionOutcome::Accepted { .. }
            ));
        }
        if k == 37 {
            assert!(matches!(
                late.add_fix(&fix).unwrap(),
                FusionOutcome::Accepted { .. }
            ));
        }
    }
    assert!(
        close(on_time.pose(), late.pose(), 1e-12),
        "{:?} vs {:?}",
        on_time.pose(),
        late.pose()
    );
    assert!((on_time.pose_covariance() - late.pose_covariance()).norm() < 1e-14);
}

#[test]
fn a_fix_between_two_odometry_steps_splits_the_step_exactly() {
    // Fix at t = 0.61 s, in the middle of the step (0.60, 0.62]. Reference: a filter whose
    // odometry arrived as two half steps with the fix in between.
    // History slots of 0.3 s / 63 = 4.8 ms, shorter than the half step, so that no step is
    // merged with another (merging is exact in the mean, not in the covariance).
    let fix = Fix::position(0.61, 0.2, 0.0, 0.02);
    let xi = Twist2::new(0.3, 0.0, 0.4);
    let short_history = || {
        Est::new(
            0.0,
            Pose2::new(0.0, 0.0, 0.0),
            cov(0.01, 0.01),
            FusionConfig {
                max_latency: 0.3,
                gyro_bias_std: 0.0,
                scale_std: 0.0,
                ..FusionConfig::default()
            },
        )
        .unwrap()
    };
    let mut reference = short_history();
    let mut late = short_history();
    for k in 1..=40 {
        let t = k as f64 * DT;
        if k == 31 {
            reference
                .predict(0.61, se2::twist_exp(xi, DT / 2.0), StepHeading::Wheels)
                .unwrap();
            reference.add_fix(&fix).unwrap();
            reference
                .predict(t, se2::twist_exp(xi, DT / 2.0), StepHeading::Wheels)
                .unwrap();
        } else {
            reference
                .predict(t, true_step(), StepHeading::Wheels)
                .unwrap();
        }
        late.predict(t, true_step(), StepHeading::Wheels).unwrap();
        if k == 35 {
            late.add_fix(&fix).unwrap();
        }
    }
    // Equal to 1e-9 (6e-11 m measured: the split's covariance is interpolated, where the old
    // 3-state filter re-ran the half steps), against a fix that moves the pose by centimetres:
    // fusing it at the step's end instead differs by 0.9 mm.
    assert!(
        close(reference.pose(), late.pose(), 1e-9),
        "{:?} vs {:?}",
        reference.pose(),
        late.pose()
    );
    let d = (reference.pose_covariance() - late.pose_covariance()).norm();
    assert!(d < 1e-9, "{d}");
}

#[test]
fn latency_compensation_beats_applying_the_fix_at_arrival() {
    // Odometry drifts (heading bias); the camera sees the true pose with 150 ms latency, every
    // 0.5 s. Applying each fix at its arrival time puts a 150 ms old position on the current
    // state, i.e. 4.5 cm behind at 0.3 m/s.
    let noise = ProcessNoise::wheel_odometry();
    let mut comp = pose_filter(cov(0.01, 0.01), noise);
    let mut naive = comp;
    let mut truth = vec![Pose2::new(0.0, 0.0, 0.0)];
    let latency_steps = 7; // 140 ms
    let (mut err_comp, mut err_naive) = (0.0f64, 0.0f64);
    for k in 1..=500 {
        let t = k as f64 * DT;
        truth.push(se2::compose(truth[k - 1], true_step()));
        comp.predict(t, biased_step(), StepHeading::Wheels).unwrap();
        naive
            .predict(t, biased_step(), StepHeading::Wheels)
            .unwrap();
        if k % 25 == 0 && k > latency_steps {
            let taken = k - latency_steps;
            let p = truth[taken];
            let fix = |t| Fix {
                t,
                x: p.x,
                y: p.y,
                heading: Some(p.heading),
                std_xy: 0.01,
                std_heading: 0.02,
            };
            comp.add_fix(&fix(taken as f64 * DT)).unwrap();
            naive.add_fix(&fix(t)).unwrap();
        }
        if k > 100 {
            let e = |p: Pose2<f64>| (p.x - truth[k].x).hypot(p.y - truth[k].y);
            err_comp = err_comp.max(e(comp.pose()));
            err_naive = err_naive.max(e(naive.pose()));
        }
    }
    println!(
        "worst error after 2 s: fix at its timestamp {err_comp:.4} m, fix at arrival {err_naive:.4} m"
    );
    assert!(err_comp < 0.02, "{err_comp}");
    assert!(err_naive > 2.0 * err_comp, "{err_naive} vs {err_comp}");
}

#[test]
fn out_of_order_fixes_commute() {
    let a = Fix::position(0.3, 0.09, 0.01, 0.01);
    let b = Fix {
        t: 0.5,
        x: 0.15,
        y: 0.02,
        heading: Some(0.2),
        std_xy: 0.01,
        std_heading: 0.05,
    };
    let run = |first: &Fix<f64>, second: &Fix<f64>| {
        let mut e = estimator();
        for k in 1..=30 {
            e.predict(k as f64 * DT, biased_step(), StepHeading::Wheels)
                .unwrap();
        }
        e.add_fix(first).unwrap();
        e.add_fix(second).unwrap();
        e
    };
    let (ab, ba) = (run(&a, &b), run(&b, &a));
    assert!(
        close(ab.pose(), ba.pose(), 1e-12),
        "{:?} {:?}",
        ab.pose(),
        ba.pose()
    );
    assert!((ab.pose_covariance() - ba.pose_covariance()).norm() < 1e-12);
}

#[test]
fn the_gate_rejects_outliers_and_keeps_the_estimate() {
    let mut e = estimator();
    for k in 1..=50 {
        e.predict(k as f64 * DT, true_step(), StepHeading::Wheels)
            .unwrap();
    }
    let mut open = Est::new(
        0.0,
        Pose2::new(0.0, 0.0, 0.0),
        cov(0.01, 0.01),
        FusionConfig {
            gate: Gate::none(),
            gyro_bias_std: 0.0,
            scale_std: 0.0,
            ..FusionConfig::default()
        },
    )
    .unwrap();
    for k in 1..=50 {
        open.predict(k as f64 * DT, true_step(), StepHeading::Wheels)
            .unwrap();
    }
    let p = e.pose();
    assert_eq!(open.pose(), p);
    let outlier = Fix::position(1.0, p.x + 1.0, p.y, 0.02);
    match e.add_fix(&outlier).unwrap() {
        FusionOutcome::Rejected { mahalanobis2, gate } => {
            assert!(mahalanobis2 > gate && gate > 13.0, "{mahalanobis2} {gate}")
        }
        other => panic!("outlier accepted: {other:?}"),
    }
    assert_eq!(e.pose(), p);
    assert_eq!(e.rejected_in_a_row(), 1);
    // A consistent fix (2 cm off, σ = 2 cm) passes and resets the counter.
    let good = Fix::position(1.0, p.x + 0.02, p.y, 0.02);
    assert!(matches!(
        e.add_fix(&good).unwrap(),
        FusionOutcome::Accepted { .. }
    ));
    assert_eq!(e.rejected_in_a_row(), 0);
    // Without a gate the outlier is fused.
    assert!(matches!(
        open.add_fix(&outlier).unwrap(),
        FusionOutcome::Accepted { .. }
    ));
    assert!(open.pose().x > p.x + 0.3);
}

#[test]
fn camera_fusion_stays_bounded_while_odometry_drifts() {
    // Noisy odometry with a 1 % scale error and 2 % heading error, a camera at 5 Hz with 1 cm
    // noise, 100 ms latency and 5 % outliers 0.5 m off; 60 s on an arc (18 m of travel).
    let mut rng = Rng(0x5eed);
    let noise = ProcessNoise::wheel_odometry();
    let mut est = pose_filter(cov(0.01, 0.01), noise);
    let mut odo = Pose2::new(0.0, 0.0, 0.0);
    let mut truth = vec![Pose2::new(0.0, 0.0, 0.0)];
    let (mut worst_fused, mut sum_sq, mut rejected, mut outliers) = (0.0f64, 0.0, 0, 0);
    let steps = 3000;
    for k in 1..=steps {
        let t = k as f64 * DT;
        let d = true_step();
        truth.push(se2::compose(truth[k - 1], d));
        let meas = Pose2::new(
            d.x * 1.01 + 0.002 * rng.gauss(),
            d.y + 0.002 * rng.gauss(),
            d.heading * 1.02 + 0.002 * rng.gauss(),
        );
        odo = se2::compose(odo, meas);
        est.predict(t, meas, StepHeading::Wheels).unwrap();
        if k % 10 == 0 && k > 5 {
            let p = truth[k - 5];
            let mut fix = Fix::position((k - 5) as f64 * DT, p.x, p.y, 0.01);
            fix.x += 0.01 * rng.gauss();
            fix.y += 0.01 * rng.gauss();
            if rng.uniform() < 0.05 {
                fix.x += 0.5;
                outliers += 1;
            }
            if let FusionOutcome::Rejected { .. } = est.add_fix(&fix).unwrap() {
                rejected += 1;
            }
        }
        if k > 250 {
            let e = est.pose();
            let err = (e.x - truth[k].x).hypot(e.y - truth[k].y);
            worst_fused = worst_fused.max(err);
            sum_sq += err * err;
        }
    }
    let rms = (sum_sq / (steps - 250) as f64).sqrt();
    let end = truth[steps];
    let drift = (odo.x - end.x).hypot(odo.y - end.y);
    let travelled = 0.3 * steps as f64 * DT;
    println!(
        "60 s, {travelled:.1} m: odometry drift {drift:.3} m ({:.2} % of distance), fused error RMS {rms:.4} m, worst {worst_fused:.4} m, {rejected} fixes rejected of {outliers} outliers",
        100.0 * drift / travelled
    );
    assert!(
        drift > 0.3,
        "the odometry must drift for this test to mean something"
    );
    // The camera's σ is 1 cm per axis (1.4 cm radial): the fused estimate stays within 5 cm at
    // every step after the first 5 s, with an RMS error no worse than one camera frame.
    assert!(
        worst_fused < 0.05,
        "fused estimate within 5 cm of truth: {worst_fused}"
    );
    assert!(rms < 0.017, "{rms}");
    assert!(
        rejected >= outliers && rejected <= outliers + 3,
        "{rejected} vs {outliers}"
    );
}

#[test]
fn covariance_is_consistent() {
    // NEES over 200 Monte Carlo runs: odometry noise drawn exactly from the noise model, a
    // position fix every 0.5 s. The average NEES of a consistent 3-state filter is 3.
    let noise = ProcessNoise {
        translation: 0.03,
        translation_per_time: 0.0,
        heading_per_distance: 0.05,
        heading_per_turn: 0.0,
        heading_per_time: 0.0,
    };
    let mut rng = Rng(42);
    let runs = 200;
    let mut nees = 0.0;
    for _ in 0..runs {
        let mut est = pose_filter(cov(1e-3, 1e-3), noise);
        let mut truth = Pose2::new(0.0, 0.0, 0.0);
        for k in 1..=250 {
            let d = true_step();
            let s = d.x.hypot(d.y);
            // The filter's model: measured = true ⊕ noise in the robot frame.
            let n = Pose2::new(
                0.03 * s.sqrt() * rng.gauss(),
                0.03 * s.sqrt() * rng.gauss(),
                0.05 * s.sqrt() * rng.gauss(),
            );
            let meas = Pose2::new(d.x + n.x, d.y + n.y, d.heading + n.heading);
            est.predict(k as f64 * DT, meas, StepHeading::Wheels)
                .unwrap();
            // truth advances by the true step; the filter sees meas (= truth step + error).
            truth = se2::compose(truth, d);
            if k % 25 == 0 {
                let f = Fix::position(
                    k as f64 * DT,
                    truth.x + 0.02 * rng.gauss(),
                    truth.y + 0.02 * rng.gauss(),
                    0.02,
                );
                est.add_fix(&f).unwrap();
            }
        }
        let e = est.pose();
        let v = Vector3::new(e.x - truth.x, e.y - truth.y, e.heading - truth.heading);
        nees += (v.transpose() * est.pose_covariance().try_inverse().unwrap() * v)[0];
    }
    nees /= runs as f64;
    println!("average NEES {nees:.2} (3 expected)");
    // 95 % band for the mean of 200 χ²₃ draws is about 3 ± 0.34; allow linearisation slack.
    assert!((2.4..3.8).contains(&nees), "{nees}");
}

#[test]
fn per_step_updates_allocate_nothing() {
    let sphere = SphereOmni::new(SphereParams::<f64>::preset()).unwrap();
    let caster = Caster3::new(CasterParams::<f64>::preset()).unwrap();
    let w = sphere.wheel_rates(Twist2::new(0.2, 0.0, 0.5), 0.0).unwrap();
    // Set-up outside the counted region is not needed either, but construct it there anyway.
    let (n, _) = allocations(|| {
        let mut acc = 0.0;
        let mut odo = Odometry::new(Robot::Sphere(sphere), Pose2::new(0.0, 0.0, 0.0));
        let mut codo = Odometry::new(Robot::Caster(caster), Pose2::new(0.0, 0.0, 0.0));
        let mut est = estimator();
        let mut ahrs = Mahony::new(MahonyGains::default_gains(), core::f64::consts::FRAC_PI_2);
        for k in 0..200 {
            let t = k as f64 * 0.01;
            let r = EncoderReading::new(t, [w[0] * t, w[1] * t, w[2] * t]);
            let s = odo.update(&r, HeadingInput::GyroRate(0.5)).unwrap();
            let c = codo
                .update(
                    &EncoderReading::with_steer(t, [0.1 * t; 3], [0.0, 0.01 * t, 0.0]),
                    HeadingInput::Wheels,
                )
                .unwrap();
            acc += c.slip_residual;
            if k > 0 {
                est.predict(t, s.delta, StepHeading::Wheels).unwrap();
            }
            if k % 10 == 5 {
                let p = est.pose();
                let _ = est.add_fix(&Fix::position(t - 0.025, p.x, p.y, 0.01));
            }
            acc += ahrs
                .update(
                    0.01,
                    [0.0, 0.0, 0.5],
                    [0.0, 0.0, 9.81],
                    Some([0.2, 0.0, -0.4]),
                )
                .unwrap()
                .yaw;
        }
        // Error paths too.
        acc += odo
            .update(&EncoderReading::new(0.0, [0.0; 3]), HeadingInput::Wheels)
            .is_err() as u8 as f64;
        acc += est.add_fix(&Fix::position(-1.0, 0.0, 0.0, 0.01)).is_err() as u8 as f64;
        acc + est.pose().x
    });
    assert_eq!(n, 0, "odometry / estimator / AHRS allocated {n} times");
    // The counter does count.
    let (n, v) = allocations(|| vec![0u8; 8]);
    assert!(n >= 1 && v.len() == 8);
}
