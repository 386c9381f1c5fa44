//! `inverse`, `forward`, `torques` and `check`: the kinematics commands of the CLI contract.

use anyhow::{Context, Result, bail};
use omnikin::description::{Limits, RobotDescription};
use omnikin::{Robot, Twist2};
use serde_json::json;

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

/// Warns (on stderr) about any rate above the robot file's limit.
fn warn_limits(what: &str, rates: [f64; 3], limit: Option<f64>, key: &str) {
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

pub fn inverse(a: &InverseArgs) -> Result<()> {
    let (d, robot) = load(&a.robot)?;
    let kind = d.kind();
    let input = Twist2::new(a.vx, a.vy, a.yaw_rate);
    // Robot-frame twist for sphere and ballbot; world-frame for the caster model.
    let robot_twist = if a.world {
        input.to_robot(a.heading)
    } else {
        input
    };
    let spin = a.shell_spin.unwrap_or(0.0);
    let (wheel_rates, steer_rates) = match robot {
        Robot::Sphere(m) => {
            if a.steer.is_some() {
                return Err(reject_for(kind, "--steer", "caster3"));
            }
            (m.wheel_rates(robot_twist, spin)?, None)
        }
        Robot::Ballbot(m) => {
            if a.steer.is_some() {
                return Err(reject_for(kind, "--steer", "caster3"));
            }
            (m.wheel_rates(robot_twist, spin)?, None)
        }
        Robot::Caster(m) => {
            if a.shell_spin.is_some() {
                return Err(reject_for(kind, "--shell-spin", "sphere-omni and ballbot"));
            }
            let steer = a.steer.map(|t| t.0).unwrap_or([0.0; 3]);
            let world = robot_twist.to_world(a.heading);
            let r = m.motor_rates(world, a.heading, steer)?;
            (r.roll, Some(r.steer))
        }
        _ => anyhow::bail!("{} is not supported by this command yet", d.kind()),
    };
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
        crate::outln!("{o}")?;
        return Ok(());
    }
    let frame = if a.world {
        format!("world frame, heading {} rad", a.heading)
    } else {
        "robot frame".into()
    };
    crate::outln!("robot: {} ({}, {})", d.name, kind, d.source_name)?;
    crate::outln!(
        "body motion: vx {} m/s, vy {} m/s ({frame}), yaw rate {} rad/s",
        a.vx,
        a.vy,
        a.yaw_rate
    )?;
    match kind {
        "sphere-omni" => crate::outln!("shell spin: {spin} rad/s")?,
        "ballbot" => crate::outln!("ball spin: {spin} rad/s")?,
        _ => crate::outln!(
            "steer angles: {:?} rad",
            a.steer.map(|t| t.0).unwrap_or([0.0; 3])
        )?,
    }
    crate::outln!(
        "{:<22}{:>12} {:>12} {:>12}",
        "",
        "wheel 1",
        "wheel 2",
        "wheel 3"
    )?;
    let label = if steer_rates.is_some() {
        "roll rates [rad/s]"
    } else {
        "wheel rates [rad/s]"
    };
    crate::outln!("{}", fmt3(label, wheel_rates))?;
    if let Some(s) = steer_rates {
        crate::outln!("{}", fmt3("steer rates [rad/s]", s))?;
    }
    Ok(())
}

pub fn forward(a: &ForwardArgs) -> Result<()> {
    let (d, robot) = load(&a.robot)?;
    let kind = d.kind();
    let w = a.wheel_rates.0;
    let spin = a.shell_spin.unwrap_or(0.0);
    let heading = a.heading.unwrap_or(0.0);
    let (twist, slip) = match robot {
        Robot::Sphere(_) | Robot::Ballbot(_) if a.steer.is_some() || a.steer_rates.is_some() => {
            return Err(reject_for(kind, "--steer/--steer-rates", "caster3"));
        }
        Robot::Sphere(m) => (m.body_twist(w, spin)?.to_world(heading), None),
        Robot::Ballbot(m) => (m.body_twist(w, spin)?.to_world(heading), None),
        Robot::Caster(m) => {
            if a.shell_spin.is_some() {
                return Err(reject_for(kind, "--shell-spin", "sphere-omni and ballbot"));
            }
            let steer_rates = a
                .steer_rates
                .context("caster3 needs all six motor rates: add --steer-rates S1,S2,S3 (rad/s)")?;
            let steer = a.steer.map(|t| t.0).unwrap_or([0.0; 3]);
            let rates = omnikin::caster::CasterRates {
                roll: w,
                steer: steer_rates.0,
            };
            let f = m.body_twist(&rates, heading, steer)?;
            (f.twist, Some(f))
        }
        _ => anyhow::bail!("{} is not supported by this command yet", d.kind()),
    };
    if a.json {
        let mut o = json!({ "vx": twist.vx, "vy": twist.vy, "yaw_rate": twist.yaw_rate });
        if let Some(f) = slip {
            o["slip_residual"] = json!(f.slip_residual);
        }
        crate::outln!("{o}")?;
        return Ok(());
    }
    let frame = match a.heading {
        Some(h) => format!("world frame, heading {h} rad"),
        None => "robot frame".into(),
    };
    crate::outln!("robot: {} ({}, {})", d.name, kind, d.source_name)?;
    crate::outln!("twist ({frame}):")?;
    crate::outln!("  vx       {:>12.6} m/s", twist.vx)?;
    crate::outln!("  vy       {:>12.6} m/s", twist.vy)?;
    crate::outln!("  yaw rate {:>12.6} rad/s", twist.yaw_rate)?;
    if let Some(f) = slip {
        crate::outln!(
            "slip residual {:.6} m/s (per wheel: {:.6} {:.6} {:.6}); 0 means the six rates are consistent",
            f.slip_residual,
            f.wheel_slip[0],
            f.wheel_slip[1],
            f.wheel_slip[2]
        )?;
    } else {
        crate::outln!(
            "(assumed {} spin {spin} rad/s)",
            if kind == "ballbot" { "ball" } else { "shell" }
        )?;
    }
    Ok(())
}

pub fn torques(a: &TorquesArgs) -> Result<()> {
    let (d, robot) = load(&a.robot)?;
    let Robot::Ballbot(m) = robot else {
        bail!(
            "torques applies only to robot kind ballbot, not to {} ({})",
            d.kind(),
            d.source_name
        );
    };
    let (key, out) = match (a.model, a.wheels) {
        (Some(t), None) => ("wheel_torques", m.wheel_torques(t.0, a.yaw)?),
        (None, Some(t)) => ("model_torques", m.model_torques(t.0, a.yaw)?),
        _ => bail!("give exactly one of --model TX,TY,TZ or --wheels T1,T2,T3"),
    };
    if a.json {
        crate::outln!("{}", json!({ key: out }))?;
    } else {
        crate::outln!(
            "robot: {} ({}, {}), yaw {} rad",
            d.name,
            d.kind(),
            d.source_name,
            a.yaw
        )?;
        if key == "wheel_torques" {
            crate::outln!("{:<22}{:>12} {:>12} {:>12}", "", "T1", "T2", "T3")?;
            crate::outln!("{}", fmt3("wheel torques [N·m]", out))?;
        } else {
            crate::outln!("{:<22}{:>12} {:>12} {:>12}", "", "Tx", "Ty", "Tz")?;
            crate::outln!("{}", fmt3("model torques [N·m]", out))?;
        }
    }
    Ok(())
}

/// Fastest speed along each of 8 robot-frame directions, and fastest pure yaw rate, for a
/// linear wheel-rate map (sphere, ballbot) under `max_rate`.
fn linear_reach(
    wheel_rates: impl Fn(Twist2<f64>) -> [f64; 3],
    max_rate: f64,
) -> (Vec<(f64, f64)>, f64) {
    let scale = |w: [f64; 3]| w.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let dirs = (0..8)
        .map(|k| {
            let deg = 45.0 * k as f64;
            let (s, c) = deg.to_radians().sin_cos();
            (deg, max_rate / scale(wheel_rates(Twist2::new(c, s, 0.0))))
        })
        .collect();
    let yaw = max_rate / scale(wheel_rates(Twist2::new(0.0, 0.0, 1.0)));
    (dirs, yaw)
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
                    |t| m.wheel_rates(t, 0.0).unwrap_or([f64::INFINITY; 3]),
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
                    |t| m.wheel_rates(t, 0.0).unwrap_or([f64::INFINITY; 3]),
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
        _ => anyhow::bail!("{} is not supported by this command yet", d.kind()),
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
