//! `omnikin simulate PLAN --robot ballbot --plant dynamic`: the plan through the balancing
//! ballbot (the core's balance controller on the 3D model with seeded sensor noise and the
//! previewed lean, `omnikin_sim::dynamics::ballbot::plan_run`), with `--initial-tilt-deg` and
//! `--push`; the kinematic simulate's files plus the tilt figures in `metrics.json`.
//!
//! **A fall** is a result, not an error: the run completes (the robot lies where it fell), the
//! exit code is 0, `metrics.json` says `"fallen": true` with `"fall_time_s"`, and stderr says
//! `FALLEN at t = … s`. Scripts check `fallen`.

use std::io::Write;

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin_plan::Plan;
use omnikin_sim::dynamics::ballbot::BallbotDynamics;
use omnikin_sim::dynamics::ballbot::closed_loop::Push;
use omnikin_sim::dynamics::ballbot::plan_run::{PlanRun, PlanRunOptions, run_plan};
use omnikin_sim::metrics::{Run, evaluate};
use plotters::prelude::*;
use serde_json::json;

use crate::plot::{PALETTE, Series, draw_err, time_panel, xy_panel};
use crate::sim::SimulateArgs;

/// Largest push magnitude `--push` takes, N·s.
const MAX_PUSH: f64 = 1000.0;

/// A `--push` value: `J@T` (an impulse of `J` N·s along world +x at closed-loop time `T` s) or
/// `J@T@DEG` (along the world direction `DEG` degrees counter-clockwise from +x).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PushArg {
    /// Impulse magnitude, N·s.
    pub impulse: f64,
    /// Time, s.
    pub time: f64,
    /// Direction, degrees from world +x.
    pub direction_deg: f64,
}

/// Parses `J@T[@DEG]`.
pub fn parse_push(s: &str) -> Result<PushArg, String> {
    let parts: Vec<&str> = s.split('@').collect();
    if !(2..=3).contains(&parts.len()) {
        return Err(format!(
            "expected N_S@T or N_S@T@DEG (impulse in N·s, time in s, direction in degrees \
             from +x), got \"{s}\""
        ));
    }
    let impulse = crate::args::finite_f64(parts[0]).map_err(|e| format!("impulse: {e}"))?;
    if !(impulse > 0.0 && impulse <= MAX_PUSH) {
        return Err(format!(
            "impulse {} N·s must be in (0, {MAX_PUSH}] (the direction gives its sign)",
            crate::args::num(impulse)
        ));
    }
    let time = crate::args::finite_f64(parts[1]).map_err(|e| format!("time: {e}"))?;
    if !(0.0..=3600.0).contains(&time) {
        return Err(format!(
            "time {} s must be in [0, 3600]",
            crate::args::num(time)
        ));
    }
    let direction_deg = match parts.get(2) {
        Some(d) => crate::args::finite_f64(d).map_err(|e| format!("direction: {e}"))?,
        None => 0.0,
    };
    Ok(PushArg {
        impulse,
        time,
        direction_deg,
    })
}

/// Parses `--initial-tilt-deg`: finite, |x| < 60°.
pub fn parse_tilt(s: &str) -> Result<f64, String> {
    let v = crate::args::finite_f64(s)?;
    if v.abs() >= 60.0 {
        return Err(format!("{}° must be within ±60°", crate::args::num(v)));
    }
    Ok(v)
}

/// Runs the ballbot's dynamic simulate (module doc).
pub fn simulate(a: &SimulateArgs, d: &RobotDescription, plan: &Plan) -> Result<()> {
    if a.disturbances.is_some() || a.emit_sensors {
        bail!("--plant dynamic does not take --disturbances or --emit-sensors yet");
    }
    if a.trials > 1 {
        crate::errln!(
            "note: --plant dynamic runs one trial (its sensor noise is seeded by --seed)"
        );
    }
    let config = d
        .balance_config::<f64>()
        .context("the balance controller needs a ballbot")?;
    let dynamics = BallbotDynamics::from_config(&config);
    let opts = PlanRunOptions {
        initial_tilt: a.initial_tilt_deg.unwrap_or(0.0).to_radians(),
        pushes: a
            .push
            .iter()
            .map(|p| {
                let (s, c) = p.direction_deg.to_radians().sin_cos();
                Push {
                    time: p.time,
                    impulse: [p.impulse * c, p.impulse * s],
                }
            })
            .collect(),
        seed: a.seed,
        ..PlanRunOptions::default()
    };
    if let Some(p) = a
        .push
        .iter()
        .find(|p| p.time > opts.lead_in + plan.duration() + opts.tail)
    {
        bail!(
            "--push at {} s: the run ends at {:.2} s (lead-in {} s, plan {:.2} s, tail {} s)",
            p.time,
            opts.lead_in + plan.duration() + opts.tail,
            opts.lead_in,
            plan.duration(),
            opts.tail
        );
    }
    crate::sim::create_dir_for(
        &a.out,
        &["metrics.json", "trials.csv", "mean.csv", "figure.svg"],
    )?;
    let run = run_plan(dynamics, config, plan, &opts)
        .with_context(|| format!("{}: balancing {}", a.plan.display(), d.name))?;
    let trial = &run.trial;
    let trials_path = a.out.join("trials.csv");
    let mut trials_csv = crate::output::OutFile::create("--out", &trials_path)?;
    writeln!(trials_csv, "{}", crate::sim::trials_header(3))
        .and_then(|_| crate::sim::write_trial(&mut trials_csv, 0, trial))
        .with_context(|| format!("cannot write {}", trials_path.display()))?;
    trials_csv.commit()?;
    let runs = [Run {
        xy: trial.tracked.clone(),
        heading: Some(trial.pose.iter().map(|q| q.heading).collect()),
    }];
    let e = evaluate(plan, &runs)?;
    let (metrics, mean) = (e.metrics, e.mean);
    crate::sim::finite(&metrics)?;
    let deg = f64::to_degrees;
    let mut j = serde_json::to_value(&metrics)?;
    j["max_tilt_deg"] = json!(deg(run.max_tilt));
    j["final_tilt_deg"] = json!(deg(run.final_tilt));
    j["fallen"] = json!(run.fallen_at.is_some());
    j["fall_time_s"] = json!(run.fallen_at);
    j["simulation"] = json!({
        "robot": d.name, "kind": d.kind(), "plan": a.plan.display().to_string(),
        "plant": "dynamic", "trials": 1, "seed": a.seed,
        "control_rate_hz": config.rate_hz, "plant_rate_hz": config.rate_hz * opts.substeps as f64,
        "lead_in_s": opts.lead_in, "tail_s": opts.tail,
        "initial_tilt_deg": deg(opts.initial_tilt),
        "pushes": a.push.iter().map(|p| json!({
            "impulse_ns": p.impulse, "time_s": p.time, "direction_deg": p.direction_deg,
        })).collect::<Vec<_>>(),
        "fall_tilt_deg": deg(config.fall_tilt),
        "torque_limit_nm": config.torque_limit,
        "saturated_cycles": run.saturated_cycles,
        "peak_wheel_torque_nm": run.peak_torque,
        "sensor_noise": {
            "tilt_deg": deg(opts.noise.tilt), "rate_rad_s": opts.noise.rate,
            "position_m": opts.noise.position, "velocity_m_s": opts.noise.velocity,
        },
    });
    crate::sim::write_file(&a.out.join("metrics.json"), |w| {
        writeln!(
            w,
            "{}",
            serde_json::to_string_pretty(&j).unwrap_or_default()
        )
    })?;
    crate::sim::write_mean(&a.out.join("mean.csv"), plan, &mean)?;
    figure(
        &a.out.join("figure.svg"),
        &format!(
            "{} — balancing (dynamic plant), {}",
            d.name,
            a.plan.display()
        ),
        plan,
        &run,
        deg(config.fall_tilt),
    )?;
    crate::sim::print_summary(&metrics);
    crate::errln!(
        "balancing: max tilt {:.2}°, final tilt {:.3}°, {} saturated cycles, peak wheel torque \
         {:.2} N·m (limit {:.2})",
        deg(run.max_tilt),
        deg(run.final_tilt),
        run.saturated_cycles,
        run.peak_torque.iter().cloned().fold(0.0, f64::max),
        config.torque_limit
    );
    if let Some(t) = run.fallen_at {
        crate::errln!(
            "FALLEN at t = {t:.3} s (closed-loop time; the plan starts at {:.1} s): the tilt \
             passed {:.0}°, motors off; the robot lies where it fell",
            run.plan_start,
            deg(config.fall_tilt)
        );
    }
    crate::errln!(
        "wrote {}/{{metrics.json, trials.csv, mean.csv, figure.svg}}",
        a.out.display().to_string().trim_end_matches('/')
    );
    Ok(())
}

/// The figure: path (plan dashed, run solid), tilt against time (fall threshold dashed) and
/// the distance from the plan.
fn figure(
    path: &std::path::Path,
    title: &str,
    plan: &Plan,
    run: &PlanRun,
    fall_deg: f64,
) -> Result<()> {
    let t0 = plan.samples[0].t - run.plan_start;
    crate::plot::svg_file("--out", path, (1400, 700), |root| {
        root.fill(&WHITE).map_err(draw_err)?;
        let root = root
            .titled(&crate::plot::svg_text(title), ("sans-serif", 22))
            .map_err(draw_err)?;
        let (left, right) = root.split_horizontally(700);
        let planned: Vec<(f64, f64)> = plan.samples.iter().map(|s| (s.pose.x, s.pose.y)).collect();
        let ran: Vec<(f64, f64)> = run.position.iter().map(|p| (p[0], p[1])).collect();
        xy_panel(
            &left,
            "path (world frame): ball centre",
            "x [m]",
            "y [m]",
            &[
                Series::dashed("planned", planned, BLACK),
                Series::solid("balancing robot", ran, PALETTE[0]),
            ],
            &[],
            &[],
        )?;
        let panels = right.split_evenly((2, 1));
        let tilt: Vec<(f64, f64)> = run
            .t
            .iter()
            .zip(&run.tilt)
            .map(|(t, v)| (t + t0, v.to_degrees()))
            .collect();
        time_panel(
            &panels[0],
            "body tilt (angle from the vertical)",
            "tilt [deg]",
            &[Series::solid("tilt", tilt, PALETTE[1])],
            &[],
            Some((fall_deg, "fall threshold")),
        )?;
        let err: Vec<(f64, f64)> = plan
            .samples
            .iter()
            .zip(&run.trial.tracked)
            .map(|(s, p)| (s.t, 100.0 * (p[0] - s.pose.x).hypot(p[1] - s.pose.y)))
            .collect();
        time_panel(
            &panels[1],
            "distance from the plan",
            "error [cm]",
            &[Series::solid("|position − plan|", err, PALETTE[2])],
            &[],
            None,
        )
    })
}
