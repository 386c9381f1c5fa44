//! `simulate` and `evaluate`: Monte-Carlo simulation of a plan, and the same metrics on real
//! tracked runs.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin_plan::Plan;
use omnikin_sim::metrics::{evaluate, tracked_reference};
use omnikin_sim::track::{Track, TrackAlignment};
use omnikin_sim::{MonteCarloError, Profile, Trial};
use serde_json::json;

use crate::sim_args::{
    EvaluateArgs, Experiment, PlantKind, ReproduceArgs, ReproduceProfile, SimulateArgs,
};
use crate::sim_report::{
    DynamicInfo, PRESET_LABEL, Report, ReproduceInfo, SimulationInfo, create_dir_for,
    finish_simulation, finite, preset_toml, print_summary, progress_bar, trials_header,
    warn_unused_sections, write_dynamic_run, write_file, write_mean, write_trial,
};

/// The sensor profile of `--emit-sensors`.
fn sensor_profile(sensors: Option<&Path>) -> Result<omnikin_sim::sensors::SensorProfile> {
    use omnikin_sim::sensors::SensorProfile;
    Ok(match sensors {
        Some(p) => {
            let text = omnikin::description::read_text_limited(
                p,
                omnikin::description::MAX_TOML_BYTES,
                "MAX_TOML_BYTES of omnikin::description",
            )
            .with_context(|| format!("cannot read sensor profile {}", p.display()))?;
            SensorProfile::from_toml_str(&text, &p.display().to_string())?
        }
        None => SensorProfile::typical(),
    })
}

/// Writes the sensor logs of trial `i` under `dir/sensors/trial-NNN/`.
fn emit_sensors(
    dir: &Path,
    robot: &omnikin::Robot<f64>,
    i: usize,
    trial: &Trial,
    attitude: Option<&[omnikin_sim::sensors::PlatformAttitude]>,
    profile: &omnikin_sim::sensors::SensorProfile,
    seed: u64,
) -> Result<()> {
    use omnikin_sim::sensors::{
        emit_trial_with_attitude, write_encoder_log, write_fixes, write_imu, write_truth,
    };
    let s = emit_trial_with_attitude(robot, i, trial, attitude, profile, seed);
    let d = dir.join("sensors").join(format!("trial-{i:03}"));
    crate::output::create_subdir("--out", &d)?;
    write_file(&d.join("encoders.csv"), |w| {
        write_encoder_log(&s.encoder, w)
    })?;
    write_file(&d.join("truth.csv"), |w| write_truth(trial, w))?;
    if !s.fixes.is_empty() {
        write_file(&d.join("fixes.csv"), |w| write_fixes(&s.fixes, w))?;
    }
    if !s.imu.is_empty() {
        write_file(&d.join("imu.csv"), |w| write_imu(&s.imu, w))?;
    }
    Ok(())
}

/// `omnikin simulate --plant dynamic`: the plan once through the sphere's dynamic model
/// (deterministic), with the same files as the kinematic plant and the dynamics' own figures
/// (largest tilt, pull-out events, peak motor torques) in `metrics.json`'s `simulation`
/// ([`omnikin_sim::dynamic_run`]).
fn simulate_dynamic(a: &SimulateArgs, d: &RobotDescription, plan: &Plan) -> Result<()> {
    use omnikin_sim::dynamic_run::{DynamicOptions, DynamicPlant, check_kind, one_trial_note};
    check_kind(d)?;
    if a.disturbances.is_some() {
        bail!("--plant dynamic does not take --disturbances yet");
    }
    let sensors = if a.emit_sensors {
        let sp = sensor_profile(a.sensors.as_deref())?;
        if sp.tilt.is_some() {
            bail!(
                "--sensors: [tilt] sets a constant platform tilt for the kinematic plant; the dynamic plant tilts the platform itself (its IMU carries the model's roll and pitch): remove [tilt] or use --plant kinematic"
            );
        }
        Some(sp)
    } else {
        None
    };
    if a.trials > 1 {
        crate::errln!("note: {}", one_trial_note(d));
    }
    let opts = DynamicOptions {
        plan_name: a.plan.display().to_string(),
        seed: a.seed,
        ..DynamicOptions::default()
    };
    let plant = DynamicPlant::new(d, plan, &opts)?;
    if let omnikin_sim::dynamic_run::DynamicPlant::Sphere(p) = &plant {
        crate::sim_report::say_floor_overrides(d, p);
    }
    let figure = a.figure_format.file_name("figure");
    create_dir_for(&a.out, &["metrics.json", "trials.csv", "mean.csv", &figure])?;
    let sim = plant.run(d, plan, &opts)?;
    write_dynamic_run(&a.out, plan, &sim)?;
    if let Some(sp) = &sensors {
        let robot = d.build::<f64>()?;
        emit_sensors(&a.out, &robot, 0, sim.trial(), sim.attitude(), sp, a.seed)?;
    }
    crate::mcap_log::one_trial(a.mcap.as_deref(), plan, sim.trial())?;
    crate::figures::trajectory_figure(
        "--out",
        &a.out.join(&figure),
        &format!("{} — dynamic plant, {}", d.name, a.plan.display()),
        plan,
        &sim.runs,
        &sim.evaluation.mean,
        sim.evaluation.metrics.runs,
    )?;
    print_summary(&sim.evaluation.metrics);
    for line in sim.summary_lines(&plant) {
        crate::errln!("{line}");
    }
    crate::errln!(
        "wrote {}/{{metrics.json, trials.csv, mean.csv, {figure}}}",
        a.out.display().to_string().trim_end_matches('/')
    );
    if sensors.is_some() {
        crate::errln!(
            "sensor logs: {}/sensors/trial-000/{{encoders.csv, fixes.csv, imu.csv, truth.csv}}",
            a.out.display().to_string().trim_end_matches('/')
        );
    }
    Ok(())
}

/// `omnikin evaluate`: tracked runs against a plan (`--plan`), or pose estimates against
/// ground truth (`--truth`, see [`crate::evaluate_truth`]).
// Exactly one of `--plan` and `--truth` (a group, so that clap's message names both).
pub fn simulate(a: &SimulateArgs) -> Result<()> {
    let d = crate::kinematics::resolve_robot(&a.robot)?;
    let robot = d.build::<f64>()?;
    let plan = Plan::load_csv(&a.plan)?;
    // As `plan` warns: a plan asking more than the robot file allows is not what it will do.
    for w in crate::body_limits::plan_beyond_file(&d, &plan)? {
        crate::errln!(
            "warning: {}: {w}; a robot held to its file's limits lags behind it",
            a.plan.display()
        );
    }
    if a.shard.is_some() && a.plant == PlantKind::Dynamic {
        bail!(
            "--shard: the dynamic plant runs one trial; shards split the kinematic plant's trials"
        );
    }
    if a.closed_loop.closed_loop {
        return crate::sim_closed_loop::simulate(a, &d, &plan);
    }
    let ballbot_dynamic = a.plant == PlantKind::Dynamic && d.robot_kind().balances();
    if !ballbot_dynamic && (a.initial_tilt_deg.is_some() || !a.push.is_empty()) {
        bail!("--initial-tilt-deg and --push need --robot ballbot (kind ballbot) --plant dynamic");
    }
    if ballbot_dynamic {
        if a.mcap.is_some() {
            bail!(
                "--mcap: not yet for the ballbot's dynamic plant (kinematic plants and sphere-omni's dynamic plant only)"
            );
        }
        return crate::sim_ballbot::simulate(a, &d, &plan);
    }
    if a.plant == PlantKind::Dynamic {
        return simulate_dynamic(a, &d, &plan);
    }
    let profile = match &a.disturbances {
        Some(p) => Profile::load(p)?,
        None => Profile::default(),
    };
    if let Some(file) = &a.disturbances {
        warn_unused_sections(&profile, &robot, &file.display().to_string());
    }
    if let Some(why) = omnikin_sim::plan_mismatch(&robot, &plan) {
        crate::errln!("warning: {}: {why}", a.plan.display());
    }
    use crate::steer_steps::{
        MAX_SIMULATED_STEER_STEP, MAX_UNEXPLAINED_STEER_STEP, unexplained_steer_step,
    };
    if let Some(step) = unexplained_steer_step(&plan, MAX_SIMULATED_STEER_STEP) {
        anyhow::bail!(
            "{}: {step}: the simulator turns the steer motors by the sd columns, so it would \
             not follow this plan: {}",
            a.plan.display(),
            step.cause()
        );
    } else if let Some(step) = unexplained_steer_step(&plan, MAX_UNEXPLAINED_STEER_STEP) {
        crate::errln!(
            "warning: {}: {step}: the simulated steering will differ from the plan's by about \
             that much: {}",
            a.plan.display(),
            step.cause()
        );
    }
    if let Some(shard) = a.shard {
        return crate::shard::simulate_shard(a, shard, &d, &robot, &plan, &profile);
    }
    let sensors = if a.emit_sensors {
        Some(sensor_profile(a.sensors.as_deref())?)
    } else {
        None
    };
    create_dir_for(
        &a.out,
        &[
            "metrics.json",
            "trials.csv",
            "mean.csv",
            &a.figure_format.file_name("figure"),
        ],
    )?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let trials = a.trials as usize;
    let passes = 1 + omnikin_sim::second_pass_resimulates(trials, plan.samples.len()) as u64;
    let pb = progress_bar(passes * a.trials, "simulating");
    // Metrics compare what the tracker saw with the planned path of the tracked point.
    let reference = tracked_reference(&plan, profile.tracking.offset.unwrap_or([0.0; 2]));
    // The trials stream through trials.csv (and the sensor logs) into the metrics, in trial
    // order: memory does not grow with --trials.
    let trials_path = a.out.join("trials.csv");
    // Under the output rules: a temporary file, renamed into place only when every trial ran
    // (a run that stops part-way leaves no truncated trials.csv behind).
    let mut trials_csv = crate::output::OutFile::create("--out", &trials_path)?;
    writeln!(trials_csv, "{}", trials_header(robot.wheels()))
        .with_context(|| format!("cannot write {}", trials_path.display()))?;
    let mcap_trials = a.mcap_trials.unwrap_or(1) as usize;
    let mut mcap = crate::mcap_log::simulation(a.mcap.as_deref(), &plan)?;
    let mc = pool
        .install(|| {
            omnikin_sim::simulate_and_evaluate(
                &robot,
                &plan,
                &reference,
                &profile,
                trials,
                a.seed,
                &|| pb.inc(1),
                |i, trial| -> Result<()> {
                    write_trial(&mut trials_csv, i, trial)
                        .with_context(|| format!("cannot write {}", trials_path.display()))?;
                    if let Some(sp) = &sensors {
                        emit_sensors(&a.out, &robot, i, trial, None, sp, a.seed)?;
                    }
                    if let Some(m) = mcap.as_mut().filter(|_| i < mcap_trials) {
                        crate::mcap_log::trial(m, i, trial, &plan)?;
                    }
                    Ok(())
                },
            )
        })
        .map_err(|e| match e {
            MonteCarloError::Visit(e) => e,
            e => anyhow::Error::new(e),
        })
        .and_then(|mc| {
            trials_csv.commit()?;
            Ok(mc)
        })?;
    pb.finish_and_clear();
    if let Some(m) = mcap {
        m.finish()?;
    }
    let info = SimulationInfo {
        robot: d.name.clone(),
        kind: d.kind().to_string(),
        plan: a.plan.display().to_string(),
        disturbances: a.disturbances.as_ref().map(|p| p.display().to_string()),
        trials: a.trials,
        seed: a.seed,
        plant_rate_hz: profile.rate_hz(),
    };
    if a.emit_sensors {
        crate::errln!(
            "sensor logs: {}/sensors/trial-NNN/{{encoders.csv, fixes.csv, imu.csv, truth.csv}}",
            a.out.display().to_string().trim_end_matches('/')
        );
    }
    finish_simulation(&a.out, &info, &reference, mc, &a.figure_format)
}

pub fn evaluate_tracks(a: &EvaluateArgs) -> Result<()> {
    let (Some(plan_path), Some(out)) = (a.plan.as_deref(), a.out.as_deref()) else {
        return match &a.truth {
            Some(truth) => crate::evaluate_truth::run(a, truth),
            None => bail!("evaluate needs --plan PLAN.csv --out DIR, or --truth TRUTH.csv"),
        };
    };
    if !(a.motion_threshold > 0.0 && a.motion_threshold <= 10.0) {
        bail!(
            "--motion-threshold must be > 0 and at most 10 m (got {})",
            a.motion_threshold
        );
    }
    if let Some(o) = a.tracking_offset {
        let max = omnikin_sim::limits::MAX_TRACKING_OFFSET;
        if o.iter().any(|v| v.abs() > max) {
            bail!(
                "--tracking-offset {},{}: each component must be within ±{max} m of the \
                 robot centre (omnikin_sim::limits::MAX_TRACKING_OFFSET)",
                omnikin_sim::limits::num(o[0]),
                omnikin_sim::limits::num(o[1])
            );
        }
    }
    let plan = tracked_reference(
        &Plan::load_csv(plan_path)?,
        a.tracking_offset.unwrap_or([0.0; 2]),
    );
    let align = TrackAlignment {
        motion_threshold_m: a.motion_threshold,
        align_position: !a.no_align_position,
    };
    let mut runs = Vec::new();
    let mut estops = Vec::new();
    for f in &a.tracks {
        let track = Track::load(f)?;
        if let Some(why) = track.did_not_move(&plan, align) {
            bail!("{}: {why}", f.display());
        }
        runs.push(track.resample(&plan, align));
        estops.extend(track.estops_on(&plan, align));
    }
    let omnikin_sim::metrics::Evaluation { metrics, mean } = evaluate(&plan, &runs)?;
    finite(&metrics)?;
    let figure = a.figure_format.file_name("figure");
    create_dir_for(out, &["metrics.json", "runs.csv", "mean.csv", &figure])?;
    let mut j = serde_json::to_value(&metrics)?;
    j["evaluation"] = json!({
        "plan": plan_path.display().to_string(),
        "tracks": a.tracks.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "motion_threshold_m": a.motion_threshold, "align_position": !a.no_align_position,
        "tracking_offset_m": a.tracking_offset.unwrap_or([0.0; 2]),
        "estops": estops.iter().map(|m| json!({"t": m.t, "x": m.xy[0], "y": m.xy[1]})).collect::<Vec<_>>(),
    });
    write_file(&out.join("metrics.json"), |w| {
        writeln!(
            w,
            "{}",
            serde_json::to_string_pretty(&j).unwrap_or_default()
        )
    })?;
    write_file(&out.join("runs.csv"), |w| {
        writeln!(w, "run,t,x,y")?;
        for (i, r) in runs.iter().enumerate() {
            for (k, p) in r.xy.iter().enumerate() {
                writeln!(w, "{i},{},{},{}", plan.samples[k].t, p[0], p[1])?;
            }
        }
        Ok(())
    })?;
    write_mean(&out.join("mean.csv"), &plan, &mean)?;
    crate::figures::trajectory_figure_with_stops(
        "--out",
        &out.join(&figure),
        &format!("{} tracked run(s) vs {}", runs.len(), plan_path.display()),
        &plan,
        &runs,
        &mean,
        metrics.runs,
        &estops,
    )?;
    print_summary(&metrics);
    if !estops.is_empty() {
        crate::errln!(
            "e-stops (from the runs' mode column, marked in the figure): {} at t = {} s (plan time)",
            estops.len(),
            estops
                .iter()
                .map(|m| format!("{:.2}", m.t))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    crate::errln!(
        "wrote {}/{{metrics.json, runs.csv, mean.csv, {figure}}}",
        out.display().to_string().trim_end_matches('/')
    );
    Ok(())
}

pub fn reproduce(a: &ReproduceArgs) -> Result<()> {
    use omnikin_sim::reproduce as rp;
    let Experiment::Sphere2019 = a.experiment;
    if !(a.rate.is_finite() && a.rate > 0.0) {
        bail!("--rate must be a finite number > 0 (got {})", a.rate);
    }
    if a.fit_to_paper {
        let path = a
            .robot_file
            .clone()
            .unwrap_or_else(crate::fit_to_paper::preset_file);
        return crate::fit_to_paper::run(&path, a.rate);
    }
    if a.sensitivity {
        return sensitivity(a);
    }
    let kinematic: Vec<&str> = a
        .profiles
        .iter()
        .filter_map(|p| p.kinematic_name())
        .collect();
    let run_dynamic = a.profiles.contains(&ReproduceProfile::Dynamic) && a.dynamic_trials > 0;
    let run_closed = a.profiles.contains(&ReproduceProfile::ClosedLoop) && a.dynamic_trials > 0;
    if run_closed && a.shard.is_some() {
        bail!("--profiles closed-loop does not run in shards yet (run it without --shard)");
    }
    if kinematic.is_empty() && !run_dynamic && !run_closed {
        bail!(
            "--profiles: nothing to run (the dynamic profile needs --dynamic-trials > 0; the \
             kinematic ones are ideal, hardware, spin-slip)"
        );
    }
    let start = std::time::Instant::now();
    let out = match &a.out {
        Some(p) => p.clone(),
        None => {
            // The default directory is omnikin's own: a new run replaces the files the last
            // run wrote there (an --out of the user's keeps the rule: nothing replaced
            // without --force).
            let d = crate::data_dir::reproduce_default("sphere-2019");
            if std::fs::read_dir(&d).is_ok_and(|mut e| e.next().is_some()) {
                crate::errln!(
                    "reproduce: replacing the previous results in {} (the default --out)",
                    d.display()
                );
                crate::output::set_force(true);
            }
            d
        }
    };
    let (robot_file, robot_toml) = reproduce_robot_file(a)?;
    let d = RobotDescription::from_toml_str(&robot_toml, &robot_file)?;
    let robot = d.build::<f64>()?;
    let series = rp::sphere_2019_series(&d, a.rate)?;
    let dyn_trials = if run_dynamic || run_closed {
        a.dynamic_trials as usize
    } else {
        0
    };
    if let Some(shard) = a.shard {
        shard.check(
            if kinematic.is_empty() {
                dyn_trials
            } else {
                a.trials as usize
            },
            if kinematic.is_empty() {
                "--dynamic-trials"
            } else {
                "--trials"
            },
        )?;
    }
    let files: &[&str] = if a.shard.is_some() {
        &["shard.json"]
    } else {
        &["table.md", "table.csv", "metrics.json"]
    };
    create_dir_for(&out, files)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    // The dynamic profile: the robot file's [dynamics] as loaded, nothing overridden.
    let dynamic = if run_dynamic || run_closed {
        Some(DynamicInfo::new(&robot_file, &robot_toml, &d)?)
    } else {
        None
    };
    let profile = dynamic
        .as_ref()
        .filter(|_| run_dynamic)
        .map(|i| rp::dynamic_profile(i.params));
    let closed = dynamic
        .as_ref()
        .filter(|_| run_closed)
        .map(|i| rp::paper_000_closed_loop(&d, i.params));
    let plants = rp::Plants::new(&robot, a.seed, &kinematic, profile.as_ref())
        .with_closed_loop(closed.as_ref());
    let runs = plants.runs(a.trials as usize, dyn_trials);
    let info = ReproduceInfo {
        trials: a.trials as usize,
        dynamic_trials: dyn_trials,
        prior_samples: if run_dynamic {
            a.prior_samples as usize
        } else {
            0
        },
        seed: a.seed,
        rate: a.rate,
        profiles: runs.iter().map(|r| r.0).collect(),
        robot_file,
        robot_toml,
        dynamic,
    };
    if let Some(shard) = a.shard {
        return crate::shard::reproduce_shard(&out, shard, &info, &plants, &series, &pool);
    }
    let total: u64 = series.len() as u64 * runs.iter().map(|r| r.1 as u64).sum::<u64>();
    let pb = progress_bar(total, "reproducing the Sphere paper");
    let mut report = Report::new(&out, info, &a.figure_format);
    for s in &series {
        let contacts = rp::ContactRecorder::default();
        let outcomes = pool.install(|| {
            rp::evaluate_series(
                s,
                &runs,
                &|name, i| plants.run_recording(s, name, i, &contacts),
                &|| pb.inc(1),
            )
        });
        let outcomes = outcomes.map_err(|e| match e {
            MonteCarloError::Sim(e) | MonteCarloError::Visit(e) => anyhow::Error::new(e),
            e => anyhow::Error::new(e),
        })?;
        let tally = run_dynamic.then(|| rp::ContactTally::of(&contacts.into_events()));
        let band = pool.install(|| report.prior_band(s))?;
        report.add(s, &outcomes, tally, band)?;
    }
    pb.finish_and_clear();
    report.finish(start)
}

/// The robot file `reproduce` plans and simulates with: `--robot-file` (its path and text) or
/// the built-in preset.
fn reproduce_robot_file(a: &ReproduceArgs) -> Result<(String, String)> {
    Ok(match &a.robot_file {
        Some(p) => {
            crate::output::input("--robot-file", p);
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("--robot-file {}: cannot read", p.display()))?;
            (p.display().to_string(), text)
        }
        None => (PRESET_LABEL.to_string(), preset_toml()?.to_string()),
    })
}

/// `reproduce sphere-2019 --sensitivity`: the robot file's `[dynamics]` values, each at both
/// ends of its plausible range, through the eight series (deterministic runs), as a Markdown
/// table on stdout.
fn sensitivity(a: &ReproduceArgs) -> Result<()> {
    use omnikin_sim::reproduce as rp;
    let start = std::time::Instant::now();
    let (robot_file, robot_toml) = reproduce_robot_file(a)?;
    let d = RobotDescription::from_toml_str(&robot_toml, &robot_file)?;
    let info = DynamicInfo::new(&robot_file, &robot_toml, &d)?;
    let series = rp::sphere_2019_series(&d, a.rate)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let table = pool
        .install(|| rp::sensitivity_markdown(info.params, &series))
        .with_context(|| format!("{robot_file}: sensitivity"))?;
    crate::outln!(
        "Sensitivity of the dynamic model ({robot_file}, com_depth {} m): each value at both ends of its plausible range, the others as the file has them; each series run once without trial jitter (max deviation % of the path; circles: / radius ratio).\n\n{table}",
        info.params.com_depth
    )?;
    crate::errln!(
        "{} robots × {} series in {:.1} s",
        3 + 2 * omnikin_sim::dynamics::sphere::priors::PRIORS.len(),
        series.len(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
