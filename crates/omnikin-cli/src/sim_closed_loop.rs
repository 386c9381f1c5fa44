//! `omnikin simulate PLAN --robot sphere-omni --plant dynamic --closed-loop`: the core runtime
//! follows the plan on the sphere's dynamic plant with a simulated overhead camera
//! ([`omnikin_sim::closed_loop`]); `--trials` vary the robot (the dynamic profile's hardware
//! variation) and the camera's noise, seeded by `--seed`. The files are `simulate`'s:
//! `metrics.json` (the same keys, computed on the simulated truth, plus `simulation`),
//! `trials.csv`, `mean.csv` and the figure.

use std::io::Write;

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin_plan::Plan;
use omnikin_sim::closed_loop::{self, ClosedLoopOptions, ClosedLoopTrial};
use omnikin_sim::dynamics::sphere::{DynamicProfile, SphereDynamics};
use omnikin_sim::metrics::{Run, evaluate};
use omnikin_sim::sensors::{CameraGaps, CameraProfile};
use rayon::prelude::*;
use serde_json::json;

use crate::sim_args::SimulateArgs;
use crate::sim_report::{create_dir_for, print_summary, trials_header, write_file};

/// `metrics.json`'s description of the camera.
fn camera_json(c: &Option<(CameraProfile, CameraGaps)>) -> serde_json::Value {
    match c {
        None => serde_json::Value::Null,
        Some((p, g)) => json!({
            "rate_hz": 1.0 / p.period, "latency_s": p.latency, "noise_std_m": p.noise_std,
            "heading_noise_std_rad": p.heading_noise_std,
            "dropout_probability": g.dropout_probability, "outage_s": g.outage,
        }),
    }
}

/// Runs `simulate --plant dynamic --closed-loop`.
pub fn simulate(a: &SimulateArgs, d: &RobotDescription, plan: &Plan) -> Result<()> {
    if a.plant != crate::sim_args::PlantKind::Dynamic {
        bail!("--closed-loop needs --plant dynamic (the runtime drives the dynamic plant)");
    }
    if d.robot_kind() != omnikin::Kind::Sphere {
        bail!(
            "--closed-loop: only sphere-omni so far (robot {} is {})",
            d.name,
            d.kind()
        );
    }
    if a.disturbances.is_some()
        || a.emit_sensors
        || a.mcap.is_some()
        || a.initial_tilt_deg.is_some()
        || !a.push.is_empty()
    {
        bail!(
            "--closed-loop does not take --disturbances, --emit-sensors, --mcap, --initial-tilt-deg or --push (the trials vary the dynamic profile)"
        );
    }
    let c = &a.closed_loop;
    let camera = c.camera();
    closed_loop::check_camera(&camera)
        .map_err(|e| anyhow::anyhow!("--camera-*: {e} (flags --camera-rate, --camera-latency, --camera-noise, --camera-dropout, --camera-outage)"))?;
    let robot = d.build::<f64>()?;
    let params = SphereDynamics::from_description(d)
        .with_context(|| format!("--plant dynamic: robot {}", d.name))?;
    crate::sim_report::say_floor_overrides(d, &params);
    let body = d.body_limits();
    let rate = c
        .control_rate
        .unwrap_or(omnikin_host::sim_robot::options::DEFAULT_RATE_HZ);
    let mut config = closed_loop::config(
        rate,
        d.limits.max_wheel_rate,
        d.limits.max_wheel_accel,
        body.max_accel,
        body.max_yaw_accel,
    );
    // The tilt feedback designed from the model as the robot file states it (the trials'
    // robots vary about it).
    config.tilt = (!c.no_tilt_feedback).then(|| closed_loop::tilt_feedback(&params));
    config
        .validate()
        .map_err(|e| anyhow::anyhow!("--closed-loop: runtime configuration: {e}"))?;
    let opts = ClosedLoopOptions {
        config,
        profile: DynamicProfile::hardware(params),
        camera,
        gravity_only_imu: false,
    };
    let figure = a.figure_format.file_name("figure");
    create_dir_for(&a.out, &["metrics.json", "trials.csv", "mean.csv", &figure])?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let pb = crate::sim_report::progress_bar(a.trials, "closed loop");
    let trials: Vec<ClosedLoopTrial> = pool.install(|| {
        (0..a.trials as usize)
            .into_par_iter()
            .map(|i| {
                let r = closed_loop::run(robot, plan, &opts, a.seed, i);
                pb.inc(1);
                r
            })
            .collect::<Result<_, _>>()
    })?;
    pb.finish_and_clear();
    let runs: Vec<Run> = trials
        .iter()
        .map(|t| Run {
            xy: t.trial.tracked.clone(),
            heading: Some(t.trial.pose.iter().map(|q| q.heading).collect()),
        })
        .collect();
    let evaluation = evaluate(plan, &runs)?;
    crate::sim_report::finite(&evaluation.metrics)?;
    let mut j = serde_json::to_value(&evaluation.metrics)?;
    let sum = |f: &dyn Fn(&ClosedLoopTrial) -> u64| trials.iter().map(f).sum::<u64>();
    let max = |f: &dyn Fn(&ClosedLoopTrial) -> f64| trials.iter().map(f).fold(0.0, f64::max);
    j["simulation"] = json!({
        "robot": d.name, "kind": d.kind(), "plan": a.plan.display().to_string(),
        "plant": "dynamic", "closed_loop": true, "trials": a.trials, "seed": a.seed,
        "control_rate_hz": rate, "camera": camera_json(&camera),
        "tilt_feedback": config.tilt.map(|t| json!({
            "gain_per_s": t.gain, "lean_per_accel_rad_s2_per_m": t.lean_per_accel,
            "shell_radius_m": t.shell_radius, "damping_ratio": closed_loop::TILT_DAMPING_RATIO,
            "accel_time_constant_s": t.accel_time_constant,
        })),
        "imu": "specific force at the platform's centre of mass (gyro + accelerometer)",
        "variation": "DynamicProfile::hardware (1 % wheel radius, 1 % speed, 3 % com_depth, 20 % pivot friction)",
        "max_tilt_rad": max(&|t| t.max_tilt),
        "pull_outs": sum(&|t| t.pull_outs.iter().sum()),
        "fixes_sent": sum(&|t| t.fixes_sent),
        "fixes_accepted": sum(&|t| t.fixes.accepted as u64),
        "fixes_rejected": sum(&|t| t.fixes.rejected as u64),
        "fixes_too_late": sum(&|t| t.fixes.too_late as u64),
        "max_estimate_error_m": max(&|t| t.estimate_error.iter().cloned().fold(0.0, f64::max)),
    });
    let trials_path = a.out.join("trials.csv");
    let mut csv = crate::output::OutFile::create("--out", &trials_path)?;
    writeln!(csv, "{}", trials_header(3))
        .and_then(|_| {
            trials
                .iter()
                .enumerate()
                .try_for_each(|(i, t)| crate::sim_report::write_trial(&mut csv, i, &t.trial))
        })
        .with_context(|| format!("cannot write {}", trials_path.display()))?;
    csv.commit()?;
    write_file(&a.out.join("metrics.json"), |w| {
        writeln!(
            w,
            "{}",
            serde_json::to_string_pretty(&j).unwrap_or_default()
        )
    })?;
    crate::sim_report::write_mean(&a.out.join("mean.csv"), plan, &evaluation.mean)?;
    crate::figures::trajectory_figure(
        "--out",
        &a.out.join(&figure),
        &format!(
            "{} — closed loop ({}), {}",
            d.name,
            if camera.is_some() {
                "camera"
            } else {
                "no camera"
            },
            a.plan.display()
        ),
        plan,
        &runs,
        &evaluation.mean,
        evaluation.metrics.runs,
    )?;
    print_summary(&evaluation.metrics);
    crate::errln!(
        "closed loop: {} trials, largest tilt {:.3} rad, fixes sent {} (accepted {}, rejected {}, too late {}), largest estimate error {:.1} mm",
        a.trials,
        j["simulation"]["max_tilt_rad"].as_f64().unwrap_or(0.0),
        j["simulation"]["fixes_sent"],
        j["simulation"]["fixes_accepted"],
        j["simulation"]["fixes_rejected"],
        j["simulation"]["fixes_too_late"],
        1e3 * j["simulation"]["max_estimate_error_m"]
            .as_f64()
            .unwrap_or(0.0)
    );
    crate::errln!(
        "wrote {}/{{metrics.json, trials.csv, mean.csv, {figure}}}",
        a.out.display().to_string().trim_end_matches('/')
    );
    Ok(())
}
