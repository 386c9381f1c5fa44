//! `omnikin plan` on a sphere: the largest quasi-static platform tilt the plan causes
//! ([`omnikin_plan::tilt`], with the robot file's `[dynamics]`), a warning past its
//! `max_tilt_deg`, and `--max-tilt DEG`, which slows the moves that would exceed it.

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin_plan::planner::Planned;
use omnikin_plan::tilt::{TiltModel, limit_tilt, peak_tilt};

/// The lean model of a `sphere-omni` description, `None` for other kinds.
fn model(d: &RobotDescription) -> Result<Option<TiltModel>> {
    if d.robot_kind() != omnikin::Kind::Sphere {
        return Ok(None);
    }
    let p = omnikin_sim::dynamics::sphere::SphereDynamics::from_description(d)
        .with_context(|| format!("robot {}: [dynamics]", d.name))?;
    Ok(Some(TiltModel {
        platform_mass: p.platform_mass,
        com_depth: p.com_depth,
        total_mass: p.total_mass(),
        shell_radius: p.geometry.shell_radius,
        shell_inertia: p.shell_inertia,
        gravity: p.gravity,
    }))
}

/// Applies `--max-tilt` (degrees) to `planned`. Returns the plan to write when it was slowed
/// (`None`: unchanged) and the tilt lines of the summary.
pub(super) fn apply(
    d: &RobotDescription,
    max_tilt_deg: Option<f64>,
    planned: &Planned,
) -> Result<(Option<Planned>, Vec<String>)> {
    let mut lines = Vec::new();
    let Some(m) = model(d)? else {
        if max_tilt_deg.is_some() {
            bail!(
                "--max-tilt: only a sphere-omni robot has a platform that tilts (robot {} is {})",
                d.name,
                d.kind()
            );
        }
        return Ok((None, lines));
    };
    if let Some(deg) = max_tilt_deg
        && !(deg > 0.0 && deg < 90.0)
    {
        bail!("--max-tilt: must be strictly between 0 and 90 degrees (got {deg})");
    }
    let peak = peak_tilt(&planned.plan, &m);
    let mut out = None;
    if let Some(deg) = max_tilt_deg {
        let (plan, slowed) = limit_tilt(planned, &m, deg.to_radians());
        for s in &slowed {
            lines.push(format!(
                "tilt-limited: move(s) {}..{} slowed to {:.1} % of their speed (quasi-static tilt {} > --max-tilt {deg} deg; the peaks above are before this slow-down)",
                s.moves.0 + 1,
                s.moves.1 + 1,
                100.0 * s.factor,
                degrees(s.tilt_before)
            ));
        }
        if !slowed.is_empty() {
            let mut p = planned.clone();
            p.report.duration = plan.samples.last().map_or(0.0, |s| s.t - plan.samples[0].t);
            p.plan = plan;
            out = Some(p);
        }
    }
    let shown = out.as_ref().unwrap_or(planned);
    let after = peak_tilt(&shown.plan, &m);
    lines.push(format!(
        "largest platform tilt (quasi-static, [dynamics]) {} at t = {:.2} s (|a| = {:.3} m/s^2){}",
        degrees(after.tilt),
        after.t,
        after.accel,
        if out.is_some() {
            format!(
                "; {} before --max-tilt, duration now {:.3} s",
                degrees(peak.tilt),
                shown.report.duration
            )
        } else {
            String::new()
        }
    ));
    if let Some(limit) = d.sphere_dynamics.as_ref().and_then(|s| s.max_tilt_deg)
        && after.tilt.to_degrees() > limit
    {
        lines.push(format!(
            "warning: the plan tilts the platform by {}, more than the robot file's dynamics.max_tilt_deg = {limit} deg; use --max-tilt {limit} to slow the moves that exceed it",
            degrees(after.tilt)
        ));
    }
    Ok((out, lines))
}

/// A tilt for the summary: degrees, or the lack of an equilibrium lean.
fn degrees(tilt: f64) -> String {
    if tilt >= core::f64::consts::FRAC_PI_2 {
        "90 deg (no quasi-static lean holds this acceleration: the platform would swing over)"
            .into()
    } else {
        format!("{:.2} deg", tilt.to_degrees())
    }
}
