//! The measured table of docs/closed-loop.md: paper 000's eight series, open loop and in closed
//! loop in several set-ups, 20 trials each with the dynamic profile's variation
//! ([`reproduce::dynamic_profile`] of the preset as loaded). A measurement, not a check:
//! `#[ignore]`, run by hand —
//!
//! ```text
//! CL_TRIALS=20 CL_VARIANTS=open,nocam,cam cargo test -p omnikin-sim --test closed_loop_table -- --ignored --nocapture
//! ```
//!
//! A variant is `open` (the dynamic profile, open loop) or parts joined by `+`: `cam` (paper
//! 000's camera, position only; the default), `nocam`, `camhS` (the camera with a heading of
//! noise `S` rad), `tilt` (the tilt feedback designed from the preset), `tiltcF` / `tiltlF`
//! (its gain / lean per acceleration times `F`), `tilthF` (designed from a model whose
//! `com_depth` is `F` times the plant's). `CL_SERIES` picks series, `CL_SEED` the seed (2019),
//! `CL_DIAG` prints each trial's fixes, estimate and heading errors and largest tilt.

use omnikin::description::RobotDescription;
use omnikin_sim::closed_loop::{self, ClosedLoopOptions};
use omnikin_sim::dynamics::sphere::SphereDynamics;
use omnikin_sim::metrics::Run;
use omnikin_sim::reproduce::{self, sphere_2019_series};
use omnikin_sim::sensors::{CameraGaps, CameraProfile};

fn env(name: &str, default: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| default.to_string())
}

/// The closed-loop options of a variant name.
fn options(d: &RobotDescription, params: SphereDynamics, variant: &str) -> ClosedLoopOptions {
    let body = d.body_limits();
    let mut o = ClosedLoopOptions {
        config: closed_loop::config(
            100.0,
            d.limits.max_wheel_rate,
            d.limits.max_wheel_accel,
            body.max_accel,
            body.max_yaw_accel,
        ),
        profile: reproduce::dynamic_profile(params),
        camera: Some((CameraProfile::paper_000(), CameraGaps::default())),
        gravity_only_imu: false,
    };
    for part in variant.split('+') {
        match part {
            "nocam" => o.camera = None,
            // The idealised accelerometer that reads gravity alone (for comparison).
            "gonly" => o.gravity_only_imu = true,
            // The tilt estimate's accelerometer time constant, s (diagnostic).
            p if p.starts_with("tau") => {
                if let Some(t) = o.config.tilt.as_mut() {
                    t.accel_time_constant = p[3..].parse::<f64>().unwrap();
                }
            }
            "cam" => {}
            p if p.starts_with("camh") => {
                let s: f64 = p[4..].parse().unwrap_or(0.01);
                o.camera.as_mut().unwrap().0.heading_noise_std = Some(s);
            }
            "tilt" => o.config.tilt = Some(closed_loop::tilt_feedback(&params)),
            // Diagnostics: the designed gain times a factor, the lean reference times a factor.
            p if p.starts_with("tiltc") => {
                let mut t = closed_loop::tilt_feedback(&params);
                t.gain *= p[5..].parse::<f64>().unwrap();
                o.config.tilt = Some(t);
            }
            // The controller's model with its centre-of-mass depth times a factor (the plant
            // keeps the file's).
            p if p.starts_with("tilth") => {
                let mut m = params;
                m.com_depth *= p[5..].parse::<f64>().unwrap();
                o.config.tilt = Some(closed_loop::tilt_feedback(&m));
            }
            p if p.starts_with("tiltl") => {
                let mut t = closed_loop::tilt_feedback(&params);
                t.lean_per_accel *= p[5..].parse::<f64>().unwrap();
                o.config.tilt = Some(t);
            }
            other => panic!("unknown variant part {other}"),
        }
    }
    o
}

#[test]
#[ignore = "a measurement (minutes): run by hand, see the module doc"]
fn closed_loop_table() {
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let robot = d.build::<f64>().unwrap();
    let params = SphereDynamics::from_description(&d).unwrap();
    let trials: usize = env("CL_TRIALS", "20").parse().unwrap();
    let seed: u64 = env("CL_SEED", "2019").parse().unwrap();
    let variants = env("CL_VARIANTS", "open,nocam,cam");
    let want = env("CL_SERIES", "");
    let series = sphere_2019_series(&d, 100.0).unwrap();
    println!("trials {trials}, seed {seed}");
    for v in variants.split(',') {
        let t0 = std::time::Instant::now();
        let mut line = format!("| {v} |");
        for s in &series {
            if !want.is_empty() && !want.split(',').any(|w| w == s.name) {
                continue;
            }
            let runs: Vec<Run> = (0..trials)
                .map(|i| {
                    let trial = if v == "open" {
                        let mut rng = omnikin_sim::trial_rng(seed, i);
                        reproduce::dynamic_profile(params)
                            .trial(&s.plan, &mut rng)
                            .unwrap()
                    } else {
                        let c = closed_loop::run(robot, &s.plan, &options(&d, params, v), seed, i)
                            .unwrap();
                        if std::env::var("CL_DIAG").is_ok() {
                            let e = c.estimate_error.iter().copied().fold(0.0, f64::max);
                            let h = c.heading_error.iter().copied().fold(0.0, f64::max);
                            println!(
                                "  {} {v} #{i}: fixes {} {:?}, max est err {e:.3} m, heading {h:.3} rad, tilt {:.3}",
                                s.name, c.fixes_sent, c.fixes, c.max_tilt
                            );
                        }
                        c.trial
                    };
                    omnikin_sim::trial_run(trial)
                })
                .collect();
            let m = omnikin_sim::metrics::evaluate(&s.plan, &runs)
                .unwrap()
                .metrics;
            let r = m
                .radius_ratio
                .map_or(String::new(), |r| format!(" / {r:.3}"));
            line.push_str(&format!(
                " {}: {:.1} %{r} |",
                s.name, m.max_deviation_pct_of_path
            ));
        }
        println!("{line} ({:.0} s)", t0.elapsed().as_secs_f64());
    }
}

#[test]
#[ignore = "a diagnostic"]
fn lean_direction_on_a_circle() {
    use omnikin_sim::dynamics::sphere::{SphereSim, SphereState};
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let params = SphereDynamics::from_description(&d).unwrap();
    let series = sphere_2019_series(&d, 100.0).unwrap();
    let s = series.iter().find(|s| s.name == "circle-0.2").unwrap();
    let pts: Vec<[f64; 2]> = s
        .plan
        .samples
        .iter()
        .map(|p| [p.pose.x, p.pose.y])
        .collect();
    let c = omnikin_sim::metrics::fit_circle(&pts).unwrap();
    let s0 = &s.plan.samples[0];
    let mut sim = SphereSim::with_state(
        params,
        SphereState::at_rest(s0.pose.x, s0.pose.y, s0.pose.heading),
    )
    .unwrap();
    for (j, w) in s.plan.samples.windows(2).enumerate() {
        let r = w[1].wheel_rates;
        sim.step(w[1].t - w[0].t, [r[0], r[1], r[2]]).unwrap();
        if j % 50 == 0 {
            let st = sim.state();
            let k = st.platform_z();
            let (dx, dy) = (st.centre[0] - c.center[0], st.centre[1] - c.center[1]);
            let n = dx.hypot(dy);
            // outward component of the platform's z axis (top)
            println!(
                "t {:.2}: top outward {:.4}, tilt {:.4}",
                w[1].t,
                (k.x * dx + k.y * dy) / n,
                st.tilt()
            );
        }
    }
}
