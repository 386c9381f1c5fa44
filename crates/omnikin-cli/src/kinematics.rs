//! `inverse`, `forward`, `torques` and `check`: the kinematics commands of the CLI contract.

use anyhow::{Context, Result, bail};
use omnikin::description::{Limits, RobotDescription};
use omnikin::drive::TorqueSpace;
use omnikin::{Actuators, Kind, MAX_WHEELS, Robot, Twist2};
use serde_json::json;

use crate::args::List;
use crate::{CheckArgs, ForwardArgs, InverseArgs, TorquesArgs};

/// Loads `ROBOT` (preset or file) and builds its f64 model.
fn load(robot: &str) -> Result<(RobotDescription, Robot<f64>)> {
    let d = RobotDescription::resolve(robot)?;
    let m = d.build::<f64>()?;
    Ok((d, m))
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
    let what = if robot.kind() == Kind::Swerve {
        "module"
    } else {
        "wheel"
    };
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
                crate::errln!(
                    "warning: {what} {} = {r:.6} rad/s exceeds limits.{key} = {max} rad/s (by {:.1} %)",
                    i + 1,
                    (r.abs() / max - 1.0) * 100.0
                );
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
    let steer_rates = (kind == Kind::Caster).then(|| &out.steer_rates[..n]);
    let steer_angles = (kind == Kind::Swerve).then(|| &out.steer_angles[..n]);
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
    match kind {
        Kind::Sphere => crate::outln!("shell spin: {spin} rad/s")?,
        Kind::Ballbot => crate::outln!("ball spin: {spin} rad/s")?,
        Kind::Caster => crate::outln!("steer angles: {:?} rad", &steer[..n])?,
        Kind::Swerve if a.steer.is_some() => {
            crate::outln!("current steer angles: {:?} rad", &steer[..n])?
        }
        _ => {}
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
    match (&a.steer_rates, kind) {
        (Some(l), Kind::Caster) => {
            act.steer_rates[..n].copy_from_slice(l.exactly(n, "--steer-rates", &d.name)?)
        }
        (None, Kind::Caster) => {
            bail!("caster3 needs all six motor rates: add --steer-rates S1,S2,S3 (rad/s)")
        }
        (Some(_), _) => return Err(reject_for(kind.name(), "--steer-rates", "caster3")),
        (None, _) => {}
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
            if kind == Kind::Ballbot {
                "ball"
            } else {
                "shell"
            }
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

/// Fastest speed along each of 8 robot-frame directions, and fastest pure yaw rate, for a
/// linear wheel-rate map (sphere, ballbot) under `max_rate`.
fn linear_reach(peak_rate: impl Fn(Twist2<f64>) -> f64, max_rate: f64) -> (Vec<(f64, f64)>, f64) {
    let dirs = (0..8)
        .map(|k| {
            let deg = 45.0 * k as f64;
            let (s, c) = deg.to_radians().sin_cos();
            (deg, max_rate / peak_rate(Twist2::new(c, s, 0.0)))
        })
        .collect();
    let yaw = max_rate / peak_rate(Twist2::new(0.0, 0.0, 1.0));
    (dirs, yaw)
}

/// `check` for the layouts (omni, swerve): the wheels of the robot file and the condition of
/// the wheel-constraint map.
fn describe_layout(
    d: &RobotDescription,
    robot: &Robot<f64>,
    text: &mut Vec<String>,
    j: &mut serde_json::Value,
) {
    use omnikin::description::Geometry;
    match &d.geometry {
        Geometry::Omni(wheels) => {
            text.push(format!(
                "geometry: {} omni/mecanum wheels (robot frame; drive direction and roller angle from +x, CCW):",
                wheels.len()
            ));
            for (i, w) in wheels.iter().enumerate() {
                text.push(format!(
                    "  wheel {}: position ({:>8.4}, {:>8.4}) m   drive {:>8.3}°   roller {:>7.3}°   radius {} m",
                    i + 1,
                    w.position[0],
                    w.position[1],
                    w.drive[1].atan2(w.drive[0]).to_degrees(),
                    w.roller_angle.to_degrees(),
                    w.radius
                ));
            }
        }
        Geometry::Swerve { modules, optimize } => {
            text.push(format!(
                "geometry: {} centred swerve modules (robot frame), steering optimisation {}:",
                modules.len(),
                if *optimize { "on" } else { "off" }
            ));
            for (i, m) in modules.iter().enumerate() {
                text.push(format!(
                    "  module {}: position ({:>8.4}, {:>8.4}) m   wheel radius {} m",
                    i + 1,
                    m.position[0],
                    m.position[1],
                    m.wheel_radius
                ));
            }
        }
        _ => {}
    }
    text.push(format!(
        "wheels: {}, motors: {} (valid: the layout controls vx, vy and yaw)",
        robot.wheels(),
        robot.motors()
    ));
    j["wheels"] = json!(robot.wheels());
    j["motors"] = json!(robot.motors());
}

fn vec3(v: &[f64; 3]) -> String {
    format!("({:>9.5}, {:>9.5}, {:>9.5})", v[0], v[1], v[2])
}

fn print_limits(l: &Limits) -> Result<()> {
    let show = |name: &str, v: Option<f64>, unit: &str| -> Result<()> {
        match v {
            Some(x) => crate::outln!("  {name:<16} {x} {unit}"),
            None => crate::outln!("  {name:<16} (none)"),
        }
    };
    crate::outln!("limits:")?;
    show("max_wheel_rate", l.max_wheel_rate, "rad/s")?;
    show("max_wheel_accel", l.max_wheel_accel, "rad/s²")?;
    if l.max_steer_rate.is_some() || l.max_steer_accel.is_some() {
        show("max_steer_rate", l.max_steer_rate, "rad/s")?;
        show("max_steer_accel", l.max_steer_accel, "rad/s²")?;
    }
    Ok(())
}

pub fn check(a: &CheckArgs) -> Result<()> {
    let (d, robot) = load(&a.robot)?;
    let deg = |x: f64| x.to_degrees();
    let mut j = json!({ "name": d.name, "kind": d.kind(), "source": d.source_name, "valid": true });
    let mut text: Vec<String> = vec![format!(
        "robot: {} ({}, {}): valid",
        d.name,
        d.kind(),
        d.source_name
    )];
    let mut reach: Option<(Vec<(f64, f64)>, f64)> = None;
    match robot {
        Robot::Sphere(m) => {
            let p = m.params();
            text.push(format!(
                "geometry: R {} m, R_i {:?} m, tilt δ {:.3}°, roller angle ξ {:.3}°, azimuths φ {:.3?}°",
                p.shell_radius, p.wheel_radius, deg(p.tilt), deg(p.roller_angle), p.azimuths.map(deg)
            ));
            text.push("derived vectors (platform frame, paper 000 §4):".into());
            let arr = |v: &omnikin::nalgebra::Vector3<f64>| [v.x, v.y, v.z];
            for i in 0..3 {
                text.push(format!("  wheel {}:", i + 1));
                text.push(format!(
                    "    r_i  {} m   (centre → wheel centre)",
                    vec3(&arr(&m.wheel_centres()[i]))
                ));
                text.push(format!(
                    "    n_i  {}     (wheel axis)",
                    vec3(&arr(&m.wheel_axes()[i]))
                ));
                text.push(format!(
                    "    α_i  {}     (roller axis)",
                    vec3(&arr(&m.roller_axes()[i]))
                ));
                text.push(format!(
                    "    s_i  {} m   (r_i × α_i)",
                    vec3(&arr(&m.levers()[i]))
                ));
                text.push(format!("    s_i·n_i {:.6} m", m.s_dot_n()[i]));
            }
            text.push(format!(
                "condition number of [s1; s2; s3] (normalised): {:.4} (max accepted {:.0e})",
                m.condition_number(),
                omnikin::MAX_CONDITION
            ));
            j["condition_number"] = json!(m.condition_number());
            j["vectors"] = json!((0..3).map(|i| json!({
                "r": arr(&m.wheel_centres()[i]), "n": arr(&m.wheel_axes()[i]),
                "alpha": arr(&m.roller_axes()[i]), "s": arr(&m.levers()[i]), "s_dot_n": m.s_dot_n()[i],
            })).collect::<Vec<_>>());
            if let Some(max) = d.limits.max_wheel_rate {
                reach = Some(linear_reach(
                    |t| {
                        m.wheel_rates(t, 0.0)
                            .map(|w| w.iter().fold(0.0f64, |m, x| m.max(x.abs())))
                            .unwrap_or(f64::INFINITY)
                    },
                    max,
                ));
            }
        }
        Robot::Ballbot(m) => {
            let p = m.params();
            text.push(format!(
                "geometry: ball R_b {} m, wheel r_w {} m, zenith α {:.3}°, azimuths β_i {:.3?}°",
                p.ball_radius,
                p.wheel_radius,
                deg(p.zenith),
                p.azimuths.map(deg)
            ));
            text.push("derived vectors (body frame, paper 001):".into());
            let arr = |v: &omnikin::nalgebra::Vector3<f64>| [v.x, v.y, v.z];
            for i in 0..3 {
                text.push(format!(
                    "  wheel {}: contact direction {}   drive direction {}",
                    i + 1,
                    vec3(&arr(&m.contact_directions()[i])),
                    vec3(&arr(&m.drive_directions()[i]))
                ));
            }
            let a0: Vec<[f64; 3]> = (0..3)
                .map(|i| {
                    let mut e = [0.0; 3];
                    e[i] = 1.0;
                    m.model_torques(e, 0.0).unwrap_or([f64::NAN; 3])
                })
                .collect();
            text.push(
                "torque projection A(0) (columns = wheels; [Tx,Ty,Tz] = A [T1,T2,T3]):".into(),
            );
            for row in [0usize, 1, 2] {
                let [c1, c2, c3] = [0, 1, 2].map(|wheel| a0[wheel][row]);
                text.push(format!("  {c1:>10.6} {c2:>10.6} {c3:>10.6}"));
            }
            text.push(format!(
                "condition number of the contact matrix: {:.4} (max accepted {:.0e})",
                m.condition_number(),
                omnikin::MAX_CONDITION
            ));
            j["condition_number"] = json!(m.condition_number());
            if let Some(max) = d.limits.max_wheel_rate {
                reach = Some(linear_reach(
                    |t| {
                        m.wheel_rates(t, 0.0)
                            .map(|w| w.iter().fold(0.0f64, |m, x| m.max(x.abs())))
                            .unwrap_or(f64::INFINITY)
                    },
                    max,
                ));
            }
        }
        Robot::Caster(m) => {
            let p = m.params();
            text.push(format!(
                "geometry: D {} m, d {} m, r {} m, mounting angles α_i {:.3?}°",
                p.mount_radius,
                p.eccentricity,
                p.wheel_radius,
                p.mount_angles.map(deg)
            ));
            text.push(
                "steering axes F_i and wheel centres O_i at γ = 0 (body frame, paper 003 §2):"
                    .into(),
            );
            for i in 0..3 {
                let (s, c) = p.mount_angles[i].sin_cos();
                text.push(format!(
                    "  wheel {}: F ({:>8.4}, {:>8.4}) m   O ({:>8.4}, {:>8.4}) m",
                    i + 1,
                    p.mount_radius * c,
                    p.mount_radius * s,
                    (p.mount_radius + p.eccentricity) * c,
                    (p.mount_radius + p.eccentricity) * s
                ));
            }
            let det = m.det_j2(0.0, [0.0; 3]);
            text.push(format!(
                "det J2 at γ = 0: {det:.6} (≠ 0: steering must move for the base to move)"
            ));
            text.push(format!(
                "turn in place is singular where cos γ_1 = −d/D, i.e. γ_1 = ±{:.3}°",
                deg((-p.eccentricity / p.mount_radius).acos())
            ));
            j["det_j2_at_zero_steer"] = json!(det);
            if let Some(max) = d.limits.max_wheel_rate {
                let v = p.wheel_radius * max;
                let mut yaw = v / p.mount_radius;
                if let Some(ms) = d.limits.max_steer_rate {
                    yaw = yaw.min(ms);
                }
                text.push("fastest motion within the limits:".into());
                text.push(format!("  translation, wheels aligned with the motion: {v:.4} m/s in every direction (r · max_wheel_rate)"));
                text.push(format!(
                    "  turning in place, wheels tangential (γ = ±90°): {yaw:.4} rad/s"
                ));
                // Same shape as the other robots: one entry per direction (all equal here).
                j["max_speed_m_per_s"] = json!(
                    (0..8)
                        .map(|k| json!({"direction_deg": 45.0 * k as f64, "speed": v}))
                        .collect::<Vec<_>>()
                );
                j["max_yaw_rate_rad_per_s"] = json!(yaw);
            }
        }
        _ => {
            describe_layout(&d, &robot, &mut text, &mut j);
            if let Some(max) = d.limits.max_wheel_rate {
                let n = robot.wheels();
                reach = Some(linear_reach(
                    |t| {
                        robot
                            .inverse(t, &Actuators::zero())
                            .map(|a| {
                                a.wheel_rates[..n]
                                    .iter()
                                    .fold(0.0f64, |m, x| m.max(x.abs()))
                            })
                            .unwrap_or(f64::INFINITY)
                    },
                    max,
                ));
            }
        }
    }
    if let Some((dirs, yaw)) = reach {
        text.push("fastest motion within max_wheel_rate (robot frame, no yaw, no spin):".into());
        for (dg, v) in &dirs {
            text.push(format!("  direction {dg:>5.0}°: {v:.4} m/s"));
        }
        text.push(format!("  turning on the spot: {yaw:.4} rad/s"));
        j["max_speed_m_per_s"] = json!(
            dirs.iter()
                .map(|(dg, v)| json!({"direction_deg": dg, "speed": v}))
                .collect::<Vec<_>>()
        );
        j["max_yaw_rate_rad_per_s"] = json!(yaw);
    }
    j["limits"] = json!({
        "max_wheel_rate": d.limits.max_wheel_rate, "max_wheel_accel": d.limits.max_wheel_accel,
        "max_steer_rate": d.limits.max_steer_rate, "max_steer_accel": d.limits.max_steer_accel,
    });
    if a.json {
        crate::outln!("{j}")?;
    } else {
        for line in text {
            crate::outln!("{line}")?;
        }
        print_limits(&d.limits)?;
    }
    Ok(())
}
