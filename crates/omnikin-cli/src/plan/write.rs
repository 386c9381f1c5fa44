//! What `omnikin plan` writes: the plan (CSV or JSON, conventions.md columns) to `--out` or
//! stdout, the `--plot` figure, and the human summary on stderr (moves, peaks against the
//! limits, what limited the timing, re-timed moves).

use std::io::Write;

use anyhow::{Context, Result};
use omnikin::description::RobotDescription;
use omnikin_plan::planner::{Limiter, MoveKind, Planned};
use omnikin_plan::{Plan, Quantity, RobotModel};

use super::args::{Common, Format};
use omnikin_plot::plan::plan_figure;

/// Writes the plan, the figure and the summary.
pub(super) fn finish(
    c: &Common,
    d: &RobotDescription,
    robot: &RobotModel,
    what: &str,
    planned: &Planned,
    map: Option<&omnikin_plan::map::Map>,
    start_velocity: bool,
) -> Result<()> {
    let (slowed, tilt_lines) = super::tilt::apply(d, c.max_tilt, planned)?;
    let planned = slowed.as_ref().unwrap_or(planned);
    let plan = &planned.plan;
    match &c.out {
        Some(path) => {
            let mut f = crate::output::OutFile::create("--out", path)?;
            write_plan(plan, c.format, &mut f)
                .with_context(|| format!("--out {}: cannot write", path.display()))?;
            f.commit()?;
        }
        None => {
            write_plan(plan, c.format, crate::output::Stdout)
                .context("cannot write the plan to stdout")?;
        }
    }
    if let Some(svg) = &c.plot {
        let title = format!("{} — {}", d.name, what.split(':').next().unwrap_or(what));
        plan_figure("--plot", svg, &title, plan, robot, map)?;
    }
    summary(c, d, robot, what, planned, start_velocity);
    for line in tilt_lines {
        crate::errln!("{line}");
    }
    if let Some(step) = crate::steer_steps::unexplained_steer_step(
        plan,
        crate::steer_steps::MAX_UNEXPLAINED_STEER_STEP,
    ) {
        crate::errln!(
            "warning: {step}: the steer-rate peak above and the limits do not cover it, and \
             `omnikin simulate` may refuse this plan: {}",
            step.cause()
        );
    }
    Ok(())
}

fn write_plan<W: Write>(plan: &Plan, format: Format, mut out: W) -> Result<()> {
    match format {
        Format::Csv => plan.write_csv(&mut out)?,
        Format::Json => {
            plan.write_json(&mut out)?;
            writeln!(out)?;
        }
    }
    out.flush()?;
    Ok(())
}

fn summary(
    c: &Common,
    d: &RobotDescription,
    robot: &RobotModel,
    what: &str,
    planned: &Planned,
    start_velocity: bool,
) {
    let r = &planned.report;
    let n = planned.plan.samples.len();
    crate::errln!("plan: {what}");
    crate::errln!("robot: {} ({}, {})", d.name, d.kind(), d.source_name);
    crate::errln!(
        "{n} samples at {} Hz -> {} ({})",
        c.rate,
        c.out
            .as_ref()
            .map_or("stdout".to_string(), |p| p.display().to_string()),
        match c.format {
            Format::Csv => "csv",
            Format::Json => "json",
        }
    );
    let count = |f: fn(&MoveKind) -> bool| r.moves.iter().filter(|m| f(&m.kind)).count();
    let turns = count(|k| matches!(k, MoveKind::Turn { .. }));
    let resteers = count(|k| matches!(k, MoveKind::Resteer { .. }));
    let mut extra = Vec::new();
    if turns > 0 {
        extra.push(format!("{turns} turn(s) in place"));
    }
    if resteers > 0 {
        extra.push(format!("{resteers} re-steer(s) at rest"));
    }
    crate::errln!(
        "duration {:.3} s, path length {:.3} m, {} move(s){}",
        r.duration,
        r.path_length,
        r.moves.len(),
        if !extra.is_empty() {
            format!(" incl. {}", extra.join(" and "))
        } else {
            String::new()
        }
    );
    for p in &r.peaks {
        let name = match p.quantity {
            Quantity::WheelRate => "peak wheel rate ",
            Quantity::WheelAccel => "peak wheel accel",
            Quantity::SteerRate => "peak steer rate ",
            Quantity::SteerAccel => "peak steer accel",
        };
        let limit = match p.limit {
            Some(l) => format!(
                "limit {l} {} ({:.1} % of it)",
                p.quantity.unit(),
                100.0 * p.value / l
            ),
            None => "no limit in the robot file".into(),
        };
        if p.value < 1e-9 {
            crate::errln!(
                "{name} {:>9.3} {:<7} (constant), {limit}",
                0.0,
                p.quantity.unit()
            );
            continue;
        }
        crate::errln!(
            "{name} {:>9.3} {:<7} ({} {} at t = {:.2} s), {limit}",
            p.value,
            p.quantity.unit(),
            p.quantity.motor(),
            p.motor,
            p.t
        );
    }
    let n = planned.plan.wheels;
    let per_wheel: Vec<String> = (0..n)
        .map(|i| {
            let peak = planned
                .plan
                .samples
                .iter()
                .fold(0.0_f64, |m, s| m.max(s.wheel_rates[i].abs()));
            format!("w{} {peak:.3}", i + 1)
        })
        .collect();
    crate::errln!("peak wheel rate per wheel: {} rad/s", per_wheel.join(", "));
    let motor_active = r
        .active
        .iter()
        .any(|(l, _)| matches!(l, Limiter::Motor { .. }));
    let shares: Vec<String> = r
        .active
        .iter()
        .map(|(l, s)| format!("{l} {:.0} %", 100.0 * s))
        .collect();
    crate::errln!(
        "timing limited by: {}{}",
        shares.join(", "),
        if motor_active {
            ""
        } else {
            " (no motor limit was active)"
        }
    );
    for rt in &r.retimed {
        let m = &r.moves[rt.move_index];
        crate::errln!(
            "re-timed: move {} ({}) slowed to {:.1} % of the requested speed by {}",
            rt.move_index + 1,
            match m.kind {
                MoveKind::Travel { s0, s1 } => format!("s = {s0:.3}..{s1:.3} m"),
                MoveKind::Turn { angle } => format!("turn in place by {angle:.3} rad"),
                MoveKind::Resteer { angle } => {
                    format!("re-steer at rest (largest module turn {angle:.3} rad)")
                }
            },
            100.0 * rt.factor,
            rt.limiter
        );
    }
    let list = |v: &[f64], prec: usize| -> String {
        v.iter()
            .map(|x| format!("{x:.prec$}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    if r.starts_moving
        && let Some(s) = planned.plan.samples.first()
    {
        if start_velocity {
            crate::errln!(
                "starts moving (--start-velocity): at t = 0 the wheels turn at {} rad/s",
                list(&s.wheel_rates[..n], 3)
            );
        } else {
            crate::errln!(
                "note: the plan starts at full speed (the Sphere paper's law): at t = 0 the wheels must already turn at {} rad/s; use --ramp to start from rest",
                list(&s.wheel_rates[..n], 3)
            );
        }
    }
    if robot.steerable()
        && let Some((g, _)) = planned.plan.samples.first().and_then(|s| s.steer)
    {
        crate::errln!(
            "initial steer angles: {} rad{}",
            list(&g[..n], 4),
            if c.initial_steer.is_none() {
                " (aligned with the first motion)"
            } else {
                ""
            }
        );
    }
}
