//! Issue 12, observations 5, 6 and 9 at the simulator's edge: work and memory bounded by
//! stated limits checked before the work starts, and every profile value within a stated
//! range. Each test here hung, ran out of memory or accepted nonsense before the limits.

use omnikin::description::RobotDescription;
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Robot, Twist2};
use omnikin_plan::{Plan, Sample};
use omnikin_sim::limits::MAX_PLANT_STEPS;
use omnikin_sim::reproduce::sphere_2019_series;
use omnikin_sim::sensors::{CameraProfile, SensorProfile, emit};
use omnikin_sim::track::Track;
use omnikin_sim::{Profile, SimError, simulate_trial, trial_rng};

fn sphere() -> Robot<f64> {
    Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap())
}

/// A sphere plan at rest with samples at `times`.
fn plan_at(times: &[f64]) -> Plan {
    Plan {
        wheels: 3,
        samples: times
            .iter()
            .map(|&t| Sample {
                t,
                pose: Pose2::default(),
                twist: Twist2::new(0.0, 0.0, 0.0),
                wheel_rates: [0.0; omnikin::MAX_WHEELS],
                steer: None,
            })
            .collect(),
    }
}

#[test]
fn a_plan_ending_at_1e300_s_is_refused_instead_of_simulated_for_ever() {
    // Observation 6: `simulate` of a plan whose last t is 1e300 looped for ever.
    let plan = plan_at(&[0.0, 0.01, 1e300]);
    let e =
        simulate_trial(&sphere(), &plan, &Profile::default(), &mut trial_rng(1, 0)).unwrap_err();
    let SimError::TooLarge {
        items,
        needed,
        limit,
        max,
        ..
    } = &e
    else {
        panic!("expected TooLarge, got {e:?}");
    };
    assert_eq!(
        (*items, *limit, *max),
        ("plant steps", "MAX_PLANT_STEPS", MAX_PLANT_STEPS)
    );
    assert!(*needed >= 1e302, "{needed}");
    let msg = e.to_string();
    assert!(
        msg.contains("1.0000e300 s") && msg.contains("rate"),
        "{msg}"
    );
    // Just over the limit at the default 1 kHz plant rate, and just under it.
    let over = plan_at(&[0.0, MAX_PLANT_STEPS / 1000.0 + 1.0]);
    assert!(matches!(
        simulate_trial(&sphere(), &over, &Profile::default(), &mut trial_rng(1, 0)),
        Err(SimError::TooLarge { .. })
    ));
    let coarse = Profile::from_toml_str("rate = 1.0\n", "p").unwrap();
    let long = plan_at(&[0.0, 1e4, 2e4]);
    let trial = simulate_trial(&sphere(), &long, &coarse, &mut trial_rng(1, 0)).unwrap();
    assert_eq!(trial.t, vec![0.0, 1e4, 2e4]);
}

#[test]
fn reproduce_refuses_absurd_rates() {
    // Observation 5: `reproduce --rate 1e9` ran out of memory planning the series.
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let e = sphere_2019_series(&d, 1e9).unwrap_err().to_string();
    assert!(e.starts_with("rate = 1e9 Hz (reproduce) is outside"), "{e}");
}

#[test]
fn absurd_profile_values_name_the_key_and_the_range() {
    // Observation 9: `noise_std = 1e308` was a valid profile.
    for (text, key) in [
        (
            "[tracking]\nnoise_std = 1e308\n",
            "tracking.noise_std: 1e308 m",
        ),
        ("rate = 1e-300\n", "rate: 1e-300 Hz"),
        (
            "[wheel_motor]\nlag_time_constant = 1e300\n",
            "wheel_motor.lag_time_constant",
        ),
        (
            "[wheel_motor]\nradius_error_std = 3.0\n",
            "wheel_motor.radius_error_std",
        ),
        ("[shell_spin]\nstd = 1e10\n", "shell_spin.std"),
        ("[floor]\nrel_std = 2.0\n", "floor.rel_std"),
        ("[floor]\ncorr_time = 1e-300\n", "floor.corr_time"),
        ("[tracking]\noffset = [1e9, 0.0]\n", "tracking.offset[0]"),
        ("[roller]\nrollers = 100000\n", "roller.rollers"),
    ] {
        let e = Profile::from_toml_str(text, "p.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("p.toml: {key}")) && e.contains("plausible range"),
            "{text}: {e}"
        );
    }
    // A byte-order mark is not content.
    let p = Profile::from_toml_str("\u{feff}rate = 500.0\n", "p.toml").unwrap();
    assert_eq!(p.rate_hz(), 500.0);
}

#[test]
fn sensor_profiles_are_validated_and_the_camera_loop_is_bounded() {
    for (text, key) in [
        (
            "[camera]\nperiod = 1e-300\nlatency = 0.1\nnoise_std = 0.0\noutlier_probability = 0.0\noutlier_distance = 0.0\n",
            "camera.period",
        ),
        (
            "[camera]\nperiod = 0.1\nlatency = 0.1\nnoise_std = 1e308\noutlier_probability = 0.0\noutlier_distance = 0.0\n",
            "camera.noise_std",
        ),
        (
            "[camera]\nperiod = 0.1\nlatency = 0.1\nnoise_std = 0.0\noutlier_probability = 2.0\noutlier_distance = 0.0\n",
            "camera.outlier_probability",
        ),
        (
            "[gyro]\nnoise_std = 1e300\nbias = 0.0\nbias_std = 0.0\n",
            "gyro.noise_std",
        ),
        ("counts_per_rev = 0\n", "counts_per_rev"),
    ] {
        let e = SensorProfile::from_toml_str(text, "s.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with(&format!("s.toml: {key}")), "{text}: {e}");
    }
    assert!(SensorProfile::from_toml_str("\u{feff}counts_per_rev = 1024\n", "s.toml").is_ok());
    // Built in code (no validation), a camera period far below the sample interval used to
    // spin through every period of the run; now at most one fix per sample, quickly.
    let plan = plan_at(&(0..101).map(|k| k as f64 * 0.01).collect::<Vec<_>>());
    let trial =
        simulate_trial(&sphere(), &plan, &Profile::default(), &mut trial_rng(1, 0)).unwrap();
    for period in [1e-12, 1e-300] {
        let profile = SensorProfile {
            camera: Some(CameraProfile {
                period,
                ..CameraProfile::default()
            }),
            ..SensorProfile::default()
        };
        let s = emit(&sphere(), &trial, &profile, &mut trial_rng(2, 0));
        assert!(
            !s.fixes.is_empty() && s.fixes.len() <= 101,
            "{period}: {}",
            s.fixes.len()
        );
    }
    // The usual case is unchanged: 10 Hz fixes of a 100 Hz trial, one every 10 samples.
    let s = emit(
        &sphere(),
        &trial,
        &SensorProfile {
            camera: Some(CameraProfile::default()),
            ..SensorProfile::default()
        },
        &mut trial_rng(2, 0),
    );
    let times: Vec<f64> = s.fixes.iter().map(|f| f.t).collect();
    let expected: Vec<f64> = (0..11).map(|k| k as f64 * 0.1).collect();
    assert_eq!(times.len(), expected.len(), "{times:?}");
    for (a, b) in times.iter().zip(&expected) {
        assert!((a - b).abs() < 1e-9, "{times:?}");
    }
}

#[test]
fn track_files_with_a_byte_order_mark_read() {
    let t = Track::read_csv("\u{feff}t,x,y\n0,0,0\n0.1,0.01,0\n".as_bytes(), "t.csv").unwrap();
    assert_eq!(t.t, vec![0.0, 0.1]);
}

#[test]
fn a_track_line_longer_than_the_limit_is_refused_while_streaming() {
    use std::io::Read;
    let input = "t,x,y\n"
        .as_bytes()
        .chain(std::io::repeat(b'1').take(4 << 20));
    let e = Track::read_csv(input, "track.csv").unwrap_err().to_string();
    assert!(e.contains("MAX_CSV_LINE") && e.contains("track.csv"), "{e}");
    assert!(e.len() < 1000, "the message does not echo the line");
}
