//! `omnikin simulate PLAN --robot ballbot --plant dynamic`: the plan through the balancing
//! ballbot (the core's balance controller on the 3D model with seeded sensor noise and the
//! previewed lean, `omnikin_sim::dynamics::ballbot::plan_run`), with `--initial-tilt-deg` and
//! `--push`; the kinematic simulate's files plus the tilt figures in `metrics.json`.
//!
//! **A fall** is a result, not an error: the run completes (the robot lies where it fell), the
//! exit code is 0, `metrics.json` says `"fallen": true` with `"fall_time_s"`, and stderr says
//! `FALLEN at t = … s`. Scripts check `fallen`.

use anyhow::{Result, bail};
use omnikin::description::RobotDescription;
use omnikin_plan::Plan;
use omnikin_sim::dynamic_run::{DynamicOptions, DynamicOutcome, DynamicPlant, one_trial_note};
use omnikin_sim::dynamics::ballbot::plan_run::PlanRun;
use plotters::prelude::*;

use crate::plot::{Marker, PALETTE, Series, TimeAxis, TimeMark, draw_err, time_panel_on, xy_panel};
use crate::sim_args::PushArg;
use crate::sim_args::SimulateArgs;

/// Runs the ballbot's dynamic simulate (module doc) through [`omnikin_sim::dynamic_run`].
pub fn simulate(a: &SimulateArgs, d: &RobotDescription, plan: &Plan) -> Result<()> {
    if a.disturbances.is_some() {
        bail!("--plant dynamic does not take --disturbances yet");
    }
    if a.emit_sensors {
        bail!(
            "--emit-sensors: not yet for the ballbot's dynamic plant (sphere-omni's dynamic plant and the kinematic plants only)"
        );
    }
    if a.trials > 1 {
        crate::errln!("note: {}", one_trial_note(d));
    }
    let opts = DynamicOptions {
        plan_name: a.plan.display().to_string(),
        seed: a.seed,
        initial_tilt_deg: a.initial_tilt_deg,
        pushes: a.push.clone(),
    };
    let plant = DynamicPlant::new(d, plan, &opts)?;
    let figure_name = a.figure_format.file_name("figure");
    crate::sim_report::create_dir_for(
        &a.out,
        &["metrics.json", "trials.csv", "mean.csv", &figure_name],
    )?;
    let sim = plant.run(d, plan, &opts)?;
    crate::sim_report::write_dynamic_run(&a.out, plan, &sim)?;
    if let (DynamicOutcome::Ballbot(run), DynamicPlant::Ballbot { config, .. }) =
        (&sim.outcome, &plant)
    {
        figure(
            &a.out.join(&figure_name),
            &format!(
                "{} — balancing (dynamic plant), {}",
                d.name,
                a.plan.display()
            ),
            plan,
            run,
            config.fall_tilt.to_degrees(),
            &a.push,
        )?;
    }
    crate::sim_report::print_summary(&sim.evaluation.metrics);
    for line in sim.summary_lines(&plant) {
        crate::errln!("{line}");
    }
    crate::errln!(
        "wrote {}/{{metrics.json, trials.csv, mean.csv, {figure_name}}}",
        a.out.display().to_string().trim_end_matches('/')
    );
    Ok(())
}

/// The figure: path (plan dashed, run solid, pushes marked), tilt against time (fall threshold
/// dashed) and the distance from the plan, both panels on one time axis — the plan's, which
/// starts at its first sample; the closed loop starts `plan_start` s earlier (the lead-in), so
/// the tilt begins before 0 — with each push marked where and when it is applied.
fn figure(
    path: &std::path::Path,
    title: &str,
    plan: &Plan,
    run: &PlanRun,
    fall_deg: f64,
    pushes: &[PushArg],
) -> Result<()> {
    let t0 = plan.samples[0].t - run.plan_start;
    let push_colour = PALETTE[3];
    let marks: Vec<TimeMark> = pushes
        .iter()
        .enumerate()
        .map(|(i, p)| TimeMark {
            t: p.time + t0,
            label: if i == 0 {
                "push (impulse)".to_string()
            } else {
                String::new()
            },
            color: push_colour,
        })
        .collect();
    // Where the ball centre is when each push is applied (the first control cycle at or after
    // it).
    let pushed_at: Vec<(f64, f64)> = pushes
        .iter()
        .filter_map(|p| {
            let k = run.t.iter().position(|t| *t >= p.time)?;
            run.position.get(k).map(|q| (q[0], q[1]))
        })
        .collect();
    let times = run
        .t
        .iter()
        .map(|t| t + t0)
        .chain(plan.samples.iter().map(|s| s.t));
    let axis = TimeAxis {
        range: Some(crate::plot::range(times, 0.0, 1e-6, "time")?),
        marks,
    };
    crate::plot::svg_file("--out", path, (1400, 700), |root| {
        root.fill(&WHITE).map_err(draw_err)?;
        let root = root
            .titled(&crate::plot::svg_text(title), ("sans-serif", 22))
            .map_err(draw_err)?;
        let (left, right) = root.split_horizontally(700);
        let planned: Vec<(f64, f64)> = plan.samples.iter().map(|s| (s.pose.x, s.pose.y)).collect();
        let ran: Vec<(f64, f64)> = run.position.iter().map(|p| (p[0], p[1])).collect();
        let mut paths = vec![
            Series::dashed("planned", planned, BLACK),
            Series::solid("balancing robot", ran, PALETTE[0]),
        ];
        if !pushed_at.is_empty() {
            paths.push(Series::marks(
                "pushed here",
                pushed_at.clone(),
                push_colour,
                Marker::Cross,
            ));
        }
        xy_panel(
            &left,
            "path (world frame): ball centre",
            "x [m]",
            "y [m]",
            &paths,
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
        time_panel_on(
            &panels[0],
            "body tilt (angle from the vertical)",
            "tilt [deg]",
            &[Series::solid("tilt", tilt, PALETTE[1])],
            &[],
            Some((fall_deg, "fall threshold")),
            &axis,
        )?;
        let err: Vec<(f64, f64)> = plan
            .samples
            .iter()
            .zip(&run.trial.tracked)
            .map(|(s, p)| (s.t, 100.0 * (p[0] - s.pose.x).hypot(p[1] - s.pose.y)))
            .collect();
        time_panel_on(
            &panels[1],
            "distance from the plan",
            "error [cm]",
            &[Series::solid("|position − plan|", err, PALETTE[2])],
            &[],
            None,
            &axis,
        )
    })
}
