//! `omnikin odometry` end to end: logs emitted by the simulator's sensor models
//! (`omnikin_sim::sensors`) go through the command and come back as the trial's true path;
//! camera fixes with latency and outliers pull a drifting odometry back; bad logs are rejected
//! with the file, the line and the column.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::f64::consts::{PI, TAU};
use std::path::PathBuf;

use assert_cmd::Command;
use omnikin::caster::{Caster3, CasterParams};
use omnikin::sphere::{SphereOmni, SphereParams};
use omnikin::{Pose2, Robot, Twist2};
use omnikin_plan::{Plan, Sample};
use omnikin_sim::sensors::{
    CameraProfile, SensorProfile, YawProfile, emit, write_encoder_log, write_fixes,
};
use omnikin_sim::{Profile, Trial, simulate_trial, trial_rng};
use predicates::prelude::*;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

/// A fresh directory for one test's files, removed when the test passes.
fn scratch(name: &str) -> TestDir {
    TestDir::new("odometry", name)
}

/// The sphere on a 0.25 m circle, heading tangent, starting at (0.25, 0) facing +y.
fn sphere_trial(profile: &Profile, seed: u64) -> (Robot<f64>, Trial) {
    let m = SphereOmni::new(SphereParams::preset()).unwrap();
    let (rt, w0) = (0.25, 0.8);
    let n = (1.5 * TAU / w0 * 100.0) as usize;
    let plan = Plan {
        wheels: 3,
        samples: (0..=n)
            .map(|k| {
                let t = k as f64 / 100.0;
                let (s, c) = (w0 * t).sin_cos();
                let pose = Pose2::new(rt * c, rt * s, PI / 2.0 + w0 * t);
                let twist = Twist2::new(-rt * w0 * s, rt * w0 * c, w0);
                Sample {
                    t,
                    pose,
                    twist,
                    wheel_rates: omnikin_plan::per_wheel(
                        &m.wheel_rates_world(twist, pose.heading, 0.0).unwrap(),
                    ),
                    steer: None,
                }
            })
            .collect(),
    };
    let robot = Robot::Sphere(m);
    let trial = simulate_trial(&robot, &plan, profile, &mut trial_rng(seed, 0)).unwrap();
    (robot, trial)
}

fn read_poses(path: &PathBuf) -> Vec<[f64; 4]> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,x,y,heading"));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect()
}

fn worst(poses: &[[f64; 4]], trial: &Trial) -> f64 {
    assert_eq!(poses.len(), trial.pose.len());
    poses
        .iter()
        .zip(&trial.pose)
        .map(|(p, q)| (p[1] - q.x).hypot(p[2] - q.y))
        .fold(0.0, f64::max)
}

fn pose_arg(p: Pose2<f64>) -> String {
    format!("{},{},{}", p.x, p.y, p.heading)
}

#[test]
fn sphere_log_gives_the_path_back() {
    let dir = scratch("sphere");
    let zoh = Profile::from_toml_str("hold = \"zoh\"", "zoh").unwrap();
    let (robot, trial) = sphere_trial(&zoh, 1);
    let s = emit(
        &robot,
        &trial,
        &SensorProfile::default(),
        &mut trial_rng(1, 1),
    );
    let log = dir.join("log.csv");
    write_encoder_log(&s.encoder, std::fs::File::create(&log).unwrap()).unwrap();
    let out = dir.join("poses.csv");
    omnikin()
        .args([
            "odometry",
            log.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--out",
        ])
        .arg(&out)
        .args(["--initial-pose", &pose_arg(trial.pose[0])])
        .assert()
        .success()
        .stderr(predicate::str::contains("heading from the wheels"));
    let err = worst(&read_poses(&out), &trial);
    assert!(err < 1e-9, "{err:e}");
}

#[test]
fn caster_log_with_imu_yaw_and_counts() {
    // Parallel wheels with constant steer and roll rates (paper 003, §4): a consistent curve.
    let dir = scratch("caster");
    let m = Caster3::new(CasterParams::preset()).unwrap();
    let p = *m.params();
    let (beta0, rho, xi) = (0.3, 1.5, 4.0);
    let plan = Plan {
        wheels: 3,
        samples: (0..=300)
            .map(|k| {
                let t = k as f64 / 100.0;
                Sample {
                    t,
                    pose: Pose2::new(0.0, 0.0, 0.0),
                    twist: Twist2::new(0.0, 0.0, 0.0),
                    wheel_rates: omnikin_plan::per_wheel(&[xi; 3]),
                    steer: Some((
                        omnikin_plan::per_wheel(&core::array::from_fn::<_, 3, _>(|i| {
                            beta0 - p.mount_angles[i] + rho * t
                        })),
                        omnikin_plan::per_wheel(&[rho; 3]),
                    )),
                }
            })
            .collect(),
    };
    let robot = Robot::Caster(m);
    let trial = simulate_trial(&robot, &plan, &Profile::default(), &mut trial_rng(2, 0)).unwrap();
    let sensors = SensorProfile {
        yaw: Some(YawProfile {
            noise_std: 0.0,
            wrap: true,
        }),
        ..SensorProfile::default()
    };
    let s = emit(&robot, &trial, &sensors, &mut trial_rng(2, 1));
    // As counts of a 2^20-count encoder: q = round(angle / (2π/N)).
    let cpr = 1u32 << 20;
    let step = TAU / cpr as f64;
    let mut text = String::from("t,q1,q2,q3,s1,s2,s3,yaw\n");
    for r in &s.encoder {
        let c = |x: f64| (x / step).round();
        let st = r.steer.unwrap();
        text.push_str(&format!(
            "{},{},{},{},{},{},{},{}\n",
            r.t,
            c(r.q[0]),
            c(r.q[1]),
            c(r.q[2]),
            c(st[0]),
            c(st[1]),
            c(st[2]),
            r.yaw.unwrap()
        ));
    }
    let log = dir.join("log.csv");
    std::fs::write(&log, text).unwrap();
    let out = dir.join("poses.csv");
    omnikin()
        .args([
            "odometry",
            log.to_str().unwrap(),
            "--robot",
            "caster3",
            "--imu",
        ])
        .args(["--counts-per-rev", &cpr.to_string(), "--out"])
        .arg(&out)
        .assert()
        .success()
        .stderr(predicate::str::contains("heading from the yaw column"))
        .stderr(predicate::str::contains("largest slip residual"));
    let err = worst(&read_poses(&out), &trial);
    // 2^20 counts/rev: 6 µrad per count; the steer angles change within each step.
    assert!(err < 2e-5, "{err:e}");
}

#[test]
fn camera_fixes_pull_a_drifting_odometry_back_and_plot() {
    let dir = scratch("fixes");
    // Wheel-radius errors, floor slip and paper 000's speed-dependent shell spin, which the
    // wheels cannot see.
    let noisy = Profile::from_toml_str(
        "[wheel_motor]\nradius_error_std = 0.01\nfluctuation_abs = 0.02\n[floor]\nrel_std = 0.02\n\
         [shell_spin]\nslip_gain = 0.875\nslip_exponent = 1.22\n",
        "noisy",
    )
    .unwrap();
    let (robot, trial) = sphere_trial(&noisy, 11);
    let sensors = SensorProfile {
        counts_per_rev: Some(4096),
        camera: Some(CameraProfile {
            period: 0.2,
            latency: 0.1,
            noise_std: 0.005,
            heading_noise_std: None,
            outlier_probability: 0.05,
            outlier_distance: 0.5,
        }),
        ..SensorProfile::default()
    };
    let s = emit(&robot, &trial, &sensors, &mut trial_rng(11, 1));
    let (log, fixes) = (dir.join("log.csv"), dir.join("fixes.csv"));
    write_encoder_log(&s.encoder, std::fs::File::create(&log).unwrap()).unwrap();
    write_fixes(&s.fixes, std::fs::File::create(&fixes).unwrap()).unwrap();
    let (plain, fused, svg) = (
        dir.join("plain.csv"),
        dir.join("fused.csv"),
        dir.join("p.svg"),
    );
    let start = pose_arg(trial.pose[0]);
    omnikin()
        .args([
            "odometry",
            log.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--out",
        ])
        .arg(&plain)
        .args(["--initial-pose", &start])
        .assert()
        .success();
    omnikin()
        .args([
            "odometry",
            log.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--out",
        ])
        .arg(&fused)
        .args(["--initial-pose", &start, "--fixes"])
        .arg(&fixes)
        .args(["--fix-std", "0.005", "--plot"])
        .arg(&svg)
        .assert()
        .success()
        .stderr(predicate::str::contains("rejected as an outlier"));
    let (e_plain, e_fused) = (
        worst(&read_poses(&plain), &trial),
        worst(&read_poses(&fused), &trial),
    );
    println!("worst error along the path: odometry {e_plain:.4} m, fused {e_fused:.4} m");
    assert!(e_plain > 0.1, "{e_plain}");
    // The spin turns the heading continuously; position-only fixes at 5 Hz correct it with a lag.
    assert!(e_fused < 0.04 && e_fused < e_plain / 5.0, "{e_fused}");
    let svg_text = std::fs::read_to_string(&svg).unwrap();
    assert!(svg_text.contains("<svg") && svg_text.contains("fused with fixes"));
}

#[test]
fn bad_logs_name_the_file_line_and_column() {
    let dir = scratch("bad");
    let out = dir.join("p.csv");
    let cases: [(&str, &str, &str, &str); 6] = [
        (
            "t,q1,q2,q3\n0,0,0,0\n0.1,1,1,1\n0.1,2,2,2\n",
            "sphere-omni",
            "time.csv:4: column t: time 0.1 does not increase (previous 0.1 on line 3)",
            "",
        ),
        (
            "t,q1,q3\n0,0,0\n",
            "ballbot",
            "q.csv:1: missing column(s) q2",
            "",
        ),
        (
            "t,q1,q2,q3\n0,0,0,0\n\n0.1,NaN,0,0\n",
            "sphere-omni",
            "nan.csv:4: column q1: NaN is not finite",
            "",
        ),
        (
            "t,q1,q2,q3\n0,0,0,0\n0.1,0,x,0\n",
            "sphere-omni",
            "word.csv:3: column q2: \"x\" is not a number",
            "",
        ),
        (
            "t,q1,q2,q3\n0,0,0,0\n",
            "caster3",
            "steer.csv:1: missing column(s) s1, s2, s3",
            "",
        ),
        (
            "t,q1,q2,q3\n0,0,0,0\n",
            "sphere-omni",
            "imu.csv:1: --imu needs a yaw or gyro_z column",
            "--imu",
        ),
    ];
    let names = ["time", "q", "nan", "word", "steer", "imu"];
    for ((text, robot, message, extra), name) in cases.iter().zip(names) {
        let path = dir.join(format!("{name}.csv"));
        std::fs::write(&path, text).unwrap();
        let mut cmd = omnikin();
        cmd.current_dir(&dir)
            .args([
                "odometry",
                &format!("{name}.csv"),
                "--robot",
                robot,
                "--out",
            ])
            .arg(&out);
        if !extra.is_empty() {
            cmd.arg(extra);
        }
        cmd.assert()
            .failure()
            .stderr(predicate::str::contains(*message));
    }
}

#[test]
fn fusion_summary_events_file_and_bad_flags() {
    // The sphere circle with fixes but no --initial-pose: the first fix sets the pose, the
    // summary names the counters, the recoveries and the wheel scale, --events writes its CSV.
    let dir = scratch("fusion-flags");
    let zoh = Profile::from_toml_str("hold = \"zoh\"", "zoh").unwrap();
    let (robot, trial) = sphere_trial(&zoh, 3);
    let sensors = SensorProfile {
        camera: Some(CameraProfile {
            period: 0.1,
            latency: 0.3,
            noise_std: 0.002,
            heading_noise_std: None,
            outlier_probability: 0.0,
            outlier_distance: 0.5,
        }),
        ..SensorProfile::default()
    };
    let s = emit(&robot, &trial, &sensors, &mut trial_rng(3, 1));
    let (log, fixes) = (dir.join("log.csv"), dir.join("fixes.csv"));
    write_encoder_log(&s.encoder, std::fs::File::create(&log).unwrap()).unwrap();
    write_fixes(&s.fixes, std::fs::File::create(&fixes).unwrap()).unwrap();
    let (out, events) = (dir.join("p.csv"), dir.join("events.csv"));
    omnikin()
        .args([
            "odometry",
            log.to_str().unwrap(),
            "--robot",
            "sphere-omni",
            "--out",
        ])
        .arg(&out)
        .arg("--fixes")
        .arg(&fixes)
        .arg("--events")
        .arg(&events)
        .assert()
        .success()
        .stderr(predicate::str::contains(
            "fix at t = 0 s sets the initial pose (no --initial-pose)",
        ))
        .stderr(predicate::str::contains(
            "0 arrived too late (> --max-latency)",
        ))
        .stderr(predicate::str::contains(
            "recoveries: 0 re-initialised, 0 inflated",
        ))
        .stderr(predicate::str::contains("estimated wheel scale"));
    assert_eq!(
        std::fs::read_to_string(&events).unwrap(),
        "kind,start,end,peak\n"
    );
    // The fused path ends on the truth although it started at the origin.
    let poses = read_poses(&out);
    let (p, q) = (poses.last().unwrap(), trial.pose.last().unwrap());
    let end = (p[1] - q.x).hypot(p[2] - q.y);
    assert!(end < 0.01, "{end}");
    for (flag, value, message) in [
        ("--max-latency", "0", "must be > 0"),
        ("--recovery-count", "0", "0 is not in 1..=16"),
        ("--collision-decel=-1", "", "must be > 0"),
    ] {
        omnikin()
            .args([
                "odometry",
                log.to_str().unwrap(),
                "--robot",
                "sphere-omni",
                "--out",
            ])
            .arg(dir.join("q.csv"))
            .arg(flag)
            .args((!value.is_empty()).then_some(value))
            .assert()
            .failure()
            .stderr(predicate::str::contains(message));
    }
}

#[test]
fn tilt_compensation_and_event_threshold_sources_in_the_summary() {
    // The sphere circle with a 3-axis gyro and an accelerometer on a platform tilted 0.3 rad:
    // the summary says the tilt was compensated (and how much gyro_z alone would be off), and
    // where each event threshold came from: the robot file's [events], a flag, the default.
    let dir = scratch("tilt-events");
    let (robot, trial) = sphere_trial(&Profile::default(), 5);
    let sensors = SensorProfile::from_toml_str(
        "[gyro]\nnoise_std = 0.001\nbias = 0.0\nbias_std = 0.0\n[tilt]\nroll = 0.3\npitch = 0.0\n",
        "tilt.toml",
    )
    .unwrap();
    let s = emit(&robot, &trial, &sensors, &mut trial_rng(5, 1));
    let log = dir.join("log.csv");
    write_encoder_log(&s.encoder, std::fs::File::create(&log).unwrap()).unwrap();
    let header = std::fs::read_to_string(&log).unwrap();
    assert!(
        header.starts_with("t,q1,q2,q3,gyro_z,gyro_x,gyro_y,accel_x,accel_y,accel_z\n"),
        "{}",
        &header[..80]
    );
    let file = dir.join("sphere.toml");
    let (_, preset) = omnikin::description::PRESETS[0];
    std::fs::write(
        &file,
        format!("{preset}\n[events]\nslip_yaw_rate = 0.5\ncollision_decel = 4.0\n"),
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let out = omnikin()
            .args(["odometry", log.to_str().unwrap(), "--imu", "--robot"])
            .arg(&file)
            .arg("--out")
            .arg(dir.join(format!("p{}.csv", extra.len())))
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success(), "{out:?}");
        String::from_utf8(out.stderr).unwrap()
    };
    let e = run(&[]);
    assert!(e.contains("platform tilt compensated: mean 0.30"), "{e}");
    assert!(e.contains("gyro_z alone gives"), "{e}");
    assert!(
        e.contains(&format!(
            "event thresholds: slip_yaw_rate 0.5 rad/s ([events] of {0}), slip_residual 0.05 m/s \
             (default), collision_decel 4 m/s² ([events] of {0})",
            file.display()
        )),
        "{e}"
    );
    let e = run(&["--no-tilt-compensation", "--collision-decel", "2.5"]);
    assert!(
        e.contains("platform tilt not compensated: switched off"),
        "{e}"
    );
    assert!(
        e.contains("collision_decel 2.5 m/s² (--collision-decel)"),
        "{e}"
    );
}
