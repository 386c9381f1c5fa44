//! `inverse`, `forward`, `torques` and `check`: the kinematics commands of the CLI contract.

use anyhow::{Context, Result, bail};
use omnikin::description::RobotDescription;
use omnikin::drive::TorqueSpace;
use omnikin::{Actuators, MAX_WHEELS, Robot, Twist2};
use serde_json::json;

use crate::args::List;
use crate::{CheckArgs, ForwardArgs, InverseArgs, TorquesArgs};

/// Loads `ROBOT` (preset or file) and builds its f64 model.
fn load(robot: &str) -> Result<(RobotDescription, Robot<f64>)> {
    let d = resolve_robot(robot)?;
    let m = d.build::<f64>()?;
    Ok((d, m))
}

/// `ROBOT` (a preset name or a robot file), with its plausibility warnings printed on stderr
/// (radians in a `_deg` key, proportions no robot has: see
/// [`RobotDescription::plausibility`]). Every command that reads a robot goes through here.
pub fn resolve_robot(robot: &str) -> Result<RobotDescription> {
    let d = RobotDescription::resolve(robot)?;
    for w in d.plausibility() {
        crate::errln!("warning: {}: {w}", d.source_name);
    }
    Ok(d)
}

fn fmt3(label: &str, v: [f64; 3]) -> String {
    format!("{label:<22}{:>12.6} {:>12.6} {:>12.6}", v[0], v[1], v[2])
}

/// A row of one value per wheel.
fn fmt_row(label: &str, v: &[f64]) -> String {
    let mut s = format!("{label:<22}");
    for x in v {
        s += &format!("{x:>12.6} ");
    }
    s.trim_end().to_string()
}

/// The header row `wheel 1 … wheel N` (`module` for swerve).
fn header(robot: &Robot<f64>) -> String {
    let what = robot.kind().wheel_noun();
    let mut s = format!("{:<22}", "");
    for i in 0..robot.wheels() {
        s += &format!("{:>12} ", format!("{what} {}", i + 1));
    }
    s.trim_end().to_string()
}

/// Warns (on stderr) about any rate above the robot file's limit.
fn warn_limits(what: &str, rates: &[f64], limit: Option<f64>, key: &str) {
    if let Some(max) = limit {
        for (i, r) in rates.iter().enumerate() {
            if r.abs() > max {
                let excess = (r.abs() / max - 1.0) * 100.0;
                if r.abs() < 1e9 {
                    crate::errln!(
                        "warning: {what} {} = {r:.6} rad/s exceeds limits.{key} = {max} rad/s (by {excess:.1} %)",
                        i + 1,
                    );
                } else {
                    // A 1e200 rad/s rate is not printed as 200 digits.
                    crate::errln!(
                        "warning: {what} {} = {} rad/s exceeds limits.{key} = {max} rad/s (by {} %)",
                        i + 1,
                        crate::args::num(*r),
                        crate::args::num(excess)
                    );
                }
            }
        }
    }
}

fn reject_for(kind: &str, flag: &str, allowed: &str) -> anyhow::Error {
    anyhow::anyhow!("{flag} applies only to {allowed}, not to robot kind {kind}")
}

/// `--shell-spin`, refused for kinds without a shell or ball.
fn spin_of(robot: &Robot<f64>, spin: Option<f64>) -> Result<f64> {
    match spin {
        Some(_) if !robot.kind().has_vertical_spin() => Err(reject_for(
            robot.kind().name(),
            "--shell-spin",
            "sphere-omni and ballbot",
        )),
        s => Ok(s.unwrap_or(0.0)),
    }
}

/// `--steer`: one angle per wheel for steerable kinds (default 0), refused for the others.
fn steer_of(robot: &Robot<f64>, steer: &Option<List>, name: &str) -> Result<[f64; MAX_WHEELS]> {
    let mut out = [0.0; MAX_WHEELS];
    if let Some(l) = steer {
        if !robot.steerable() {
            return Err(reject_for(
                robot.kind().name(),
                "--steer",
                "kinds with steering (caster3, swerve)",
            ));
        }
        out[..robot.wheels()].copy_from_slice(l.exactly(robot.wheels(), "--steer", name)?);
        // As `plan --initial-steer`: an angle of 1e308 rad has no direction left in it.
        let max = omnikin_plan::limits::MAX_HEADING;
        if let Some((i, g)) = out.iter().enumerate().find(|(_, g)| g.abs() > max) {
            anyhow::bail!(
                "--steer: item {}: {} rad is outside the plausible range [-{max:e}, {max:e}] rad \
                 (omnikin_plan::limits)",
                i + 1,
                crate::args::num(*g)
            );
        }
    }
    Ok(out)
}

pub fn inverse(a: &InverseArgs) -> Result<()> {
    let (d, robot) = load(&a.robot)?;
    let kind = robot.kind();
    let n = robot.wheels();
    let input = Twist2::new(a.vx, a.vy, a.yaw_rate);
    // Every kind's inverse takes the robot-frame twist.
    let robot_twist = if a.world {
        input.to_robot(a.heading)
    } else {
        input
    };
    let spin = spin_of(&robot, a.shell_spin)?;
    let steer = steer_of(&robot, &a.steer, &d.name)?;
    let out = robot.inverse_spin(robot_twist, spin, &Actuators::at_steer(&steer))?;
    let wheel_rates = &out.wheel_rates[..n];
    // The caster's steer motors are rate-driven; a swerve module's steering is a set-point.
    let set_point = kind.steer_is_set_point();
    let steer_rates = (robot.steerable() && !set_point).then(|| &out.steer_rates[..n]);
    let steer_angles = (robot.steerable() && set_point).then(|| &out.steer_angles[..n]);
    warn_limits(
        "wheel",
        wheel_rates,
        d.limits.max_wheel_rate,
        "max_wheel_rate",
    );
    if let Some(s) = steer_rates {
        warn_limits("steer rate", s, d.limits.max_steer_rate, "max_steer_rate");
    }
    if a.json {
        let mut o = json!({ "wheel_rates": wheel_rates });
        if let Some(s) = steer_rates {
            o["steer_rates"] = json!(s);
        }
        if let Some(s) = steer_angles {
            o["steer_angles"] = json!(s);
        }
        crate::outln!("{o}")?;
        return Ok(());
    }
    let frame = if a.world {
        format!("world frame, heading {} rad", a.heading)
    } else {
        "robot frame".into()
    };
    crate::outln!("robot: {} ({}, {})", d.name, kind.name(), d.source_name)?;
    crate::outln!(
        "body motion: vx {} m/s, vy {} m/s ({frame}), yaw rate {} rad/s",
        a.vx,
        a.vy,
        a.yaw_rate
    )?;
    if kind.has_vertical_spin() {
        crate::outln!("{} spin: {spin} rad/s", kind.spin_body().unwrap_or("shell"))?;
    }
    if robot.steerable() && (a.steer.is_some() || !kind.steer_is_set_point()) {
        crate::outln!("steer angles: {:?} rad", &steer[..n])?;
    }
    crate::outln!("{}", header(&robot))?;
    let label = if steer_rates.is_some() {
        "roll rates [rad/s]"
    } else {
        "wheel rates [rad/s]"
    };
    crate::outln!("{}", fmt_row(label, wheel_rates))?;
    if let Some(s) = steer_rates {
        crate::outln!("{}", fmt_row("steer rates [rad/s]", s))?;
    }
    if let Some(s) = steer_angles {
        crate::outln!("{}", fmt_row("steer angles [rad]", s))?;
    }
    Ok(())
}

pub fn forward(a: &ForwardArgs) -> Result<()> {
    let (d, robot) = load(&a.robot)?;
    let kind = robot.kind();
    let n = robot.wheels();
    let spin = spin_of(&robot, a.shell_spin)?;
    let heading = a.heading.unwrap_or(0.0);
    let mut act =
        Actuators::from_wheel_rates(a.wheel_rates.exactly(n, "--wheel-rates", &d.name)?);
    act.steer_angles = steer_of(&robot, &a.steer, &d.name)?;
    // Rate-driven steering (the caster's) is part of the motion; set-point steering is not.
    let rate_steered = robot.steerable() && !kind.steer_is_set_point();
    match (&a.steer_rates, rate_steered) {
        (Some(l), true) => {
            act.steer_rates[..n].copy_from_slice(l.exactly(n, "--steer-rates", &d.name)?)
        }
        (None, true) => bail!(
            "{} needs all {} motor rates: add --steer-rates S1,…,S{n} (rad/s)",
            kind.name(),
            robot.motors()
        ),
        (Some(_), false) => {
            return Err(reject_for(
                kind.name(),
                "--steer-rates",
                "kinds with rate-driven steering (caster3)",
            ));
        }
        (None, false) => {}
    }
    let m = robot.forward_spin(&act, spin)?;
    let twist = m.twist.to_world(heading);
    // Kinds with more wheel constraints than unknowns report how inconsistent the rates are.
    let has_slip = !kind.has_vertical_spin();
    if a.json {
        let mut o = json!({ "vx": twist.vx, "vy": twist.vy, "yaw_rate": twist.yaw_rate });
        if has_slip {
            o["slip_residual"] = json!(m.slip_residual);
        }
        crate::outln!("{o}")?;
        return Ok(());
    }
    let frame = match a.heading {
        Some(h) => format!("world frame, heading {h} rad"),
        None => "robot frame".into(),
    };
    crate::outln!("robot: {} ({}, {})", d.name, kind.name(), d.source_name)?;
    crate::outln!("twist ({frame}):")?;
    crate::outln!("  vx       {:>12.6} m/s", twist.vx)?;
    crate::outln!("  vy       {:>12.6} m/s", twist.vy)?;
    crate::outln!("  yaw rate {:>12.6} rad/s", twist.yaw_rate)?;
    if has_slip {
        let per: Vec<String> = m.wheel_slip[..n]
            .iter()
            .map(|s| format!("{s:.6}"))
            .collect();
        crate::outln!(
            "slip residual {:.6} m/s (per wheel: {}); 0 means the rates are consistent",
            m.slip_residual,
            per.join(" ")
        )?;
    } else {
        crate::outln!(
            "(assumed {} spin {spin} rad/s)",
            kind.spin_body().unwrap_or("shell")
        )?;
    }
    Ok(())
}

pub fn torques(a: &TorquesArgs) -> Result<()> {
    let (d, robot) = load(&a.robot)?;
    let kind = robot.kind();
    let n = robot.wheels();
    let Some(space) = robot.torque_space() else {
        bail!(
            "torques applies only to robot kinds with a torque map (ballbot, omni, swerve), \
             not to {} ({})",
            kind.name(),
            d.source_name
        );
    };
    if space == TorqueSpace::BallbotModel && a.wrench.is_some() {
        bail!("ballbot torques are model torques: use --model TX,TY,TZ, not --wrench");
    }
    if space == TorqueSpace::BodyWrench && a.model.is_some() {
        bail!(
            "{} torques balance a body wrench: use --wrench FX,FY,MZ, not --model",
            kind.name()
        );
    }
    if space == TorqueSpace::BodyWrench && a.yaw != 0.0 {
        bail!("--yaw applies only to the ballbot's model torques");
    }
    let steer = steer_of(&robot, &a.steer, &d.name)?;
    // The ballbot's map at a yaw: model torques in the rotated frame are the body-frame ones
    // turned by the yaw about z (Tz unchanged).
    let rot = |g: [f64; 3], by: f64| {
        let (s, c) = by.sin_cos();
        [c * g[0] - s * g[1], s * g[0] + c * g[1], g[2]]
    };
    let (key, out): (&str, Vec<f64>) = match (a.model.or(a.wrench), &a.wheels) {
        (Some(g), None) => {
            let g = if space == TorqueSpace::BallbotModel {
                rot(g.0, -a.yaw)
            } else {
                g.0
            };
            let t = robot.wheel_torques(g, &steer).context("no torque map")??;
            ("wheel_torques", t[..n].to_vec())
        }
        (None, Some(w)) => {
            let mut tau = [0.0; MAX_WHEELS];
            tau[..n].copy_from_slice(w.exactly(n, "--wheels", &d.name)?);
            let g = robot
                .generalized_forces(&tau, &steer)
                .context("no torque map")??;
            let g = if space == TorqueSpace::BallbotModel {
                rot(g, a.yaw)
            } else {
                g
            };
            (space.name(), g.to_vec())
        }
        _ => bail!(
            "give exactly one of --{} or --wheels T1,…,T{n}",
            if space == TorqueSpace::BallbotModel {
                "model TX,TY,TZ"
            } else {
                "wrench FX,FY,MZ"
            }
        ),
    };
    if a.json {
        crate::outln!("{}", json!({ key: out }))?;
        return Ok(());
    }
    crate::outln!("robot: {} ({}, {})", d.name, kind.name(), d.source_name)?;
    if space == TorqueSpace::BallbotModel {
        crate::outln!("yaw {} rad", a.yaw)?;
    }
    if key == "wheel_torques" {
        crate::outln!("{}", header(&robot))?;
        crate::outln!("{}", fmt_row("wheel torques [N·m]", &out))?;
    } else {
        let [c0, c1, c2] = space.components();
        let [u0, u1, u2] = space.units();
        crate::outln!("{:<22}{:>12} {:>12} {:>12}", "", c0, c1, c2)?;
        crate::outln!(
            "{}",
            fmt3(
                &format!("{} [{u0}, {u1}, {u2}]", space.name()),
                [out[0], out[1], out[2]]
            )
        )?;
    }
    Ok(())
}

/// `omnikin check` ([`omnikin_sim::check`]).
pub fn check(a: &CheckArgs) -> Result<()> {
    let d = resolve_robot(&a.robot)?;
    let r = omnikin_sim::check::check(&d).map_err(anyhow::Error::msg)?;
    if a.json {
        crate::outln!("{}", r.json)?;
    } else {
        crate::outln!("{}", r.text)?;
        for line in &r.limits {
            crate::outln!("{line}")?;
        }
    }
    Ok(())
}
