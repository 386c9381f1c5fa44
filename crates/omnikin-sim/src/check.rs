//! What `omnikin check` says about a robot file, for every front end: the validity and
//! warnings, the derived geometry, the footprint maps grow their obstacles by, the fastest
//! motion within the limits, the balance controller's gains and poles (ballbot), the tilt
//! feedback's margins (sphere-omni), and the limits with their sources — as text for a person
//! and as JSON.

use omnikin::control::{BalanceConfig, BalanceController};
use omnikin::description::RobotDescription;
use omnikin::drive::report::REACH_DIRECTIONS_DEG;
use omnikin::nalgebra::{Complex, Matrix2, Matrix4};
use serde_json::{Value, json};

/// A robot file checked: the report's text (without the limits), the limits block, and the
/// same as JSON (`omnikin check --json`).
#[derive(Clone, Debug, PartialEq)]
pub struct CheckReport {
    /// `robot: NAME (KIND, SOURCE): valid…`, the geometry, footprint, reach, balance and tilt
    /// sections, one line each, no trailing newline.
    pub text: String,
    /// `limits:` and one line per limit (value, unit, source).
    pub limits: Vec<String>,
    /// Every figure of the text, with units in the key names.
    pub json: Value,
}

/// Checks `d` (built as an f64 model) and reports on it.
///
/// # Errors
/// The model cannot be built, or (ballbot) its balance controller cannot be designed.
pub fn check(d: &RobotDescription) -> Result<CheckReport, String> {
    let robot = d.build::<f64>().map_err(|e| e.to_string())?;
    let warnings = d.plausibility();
    let mut j = json!({
        "name": d.name, "kind": d.kind(), "source": d.source_name, "valid": true,
        "wheels": robot.wheels(), "motors": robot.motors(), "warnings": warnings,
    });
    let mut text = format!(
        "robot: {} ({}, {}): valid{}\n",
        d.name,
        d.kind(),
        d.source_name,
        match warnings.len() {
            0 => String::new(),
            1 => ", with 1 warning (above)".into(),
            n => format!(", with {n} warnings (above)"),
        }
    );
    robot
        .describe(&mut text)
        .map_err(|e| format!("formatting the derived geometry: {e}"))?;
    // The disk a map's keep-out shapes are grown by (`plan goal --map`, `plan waypoints --map`).
    let (footprint, source) = omnikin_plan::map::footprint::footprint_radius(d);
    text += &format!(
        "footprint radius: {footprint:.4} m, from {} (maps grow their obstacles by it)\n",
        source.describe()
    );
    j["footprint_radius"] = json!(footprint);
    j["footprint_source"] = json!(source.describe());
    if let Some(max) = d.limits.max_wheel_rate
        && let Some(reach) = robot.reach(max, d.limits.max_steer_rate)
    {
        let what = if robot.steerable() {
            "with the wheels steered along the motion"
        } else {
            "robot frame, no yaw, no spin"
        };
        text += &format!("fastest motion within the limits ({what}):\n");
        for (dg, v) in REACH_DIRECTIONS_DEG.iter().zip(reach.speed) {
            text += &format!("  direction {dg:>5.0}°: {v:.4} m/s\n");
        }
        text += &format!("  turning on the spot: {:.4} rad/s\n", reach.yaw_rate);
        j["max_speed_m_per_s"] = json!(
            REACH_DIRECTIONS_DEG
                .iter()
                .zip(reach.speed)
                .map(|(dg, v)| json!({"direction_deg": dg, "speed": v}))
                .collect::<Vec<_>>()
        );
        j["max_yaw_rate_rad_per_s"] = json!(reach.yaw_rate);
    }
    if robot.kind().balances() {
        balance(d, &mut text, &mut j)?;
    }
    if robot.kind() == omnikin::Kind::Sphere
        && let Ok(p) = crate::dynamics::sphere::SphereDynamics::from_description(d)
    {
        // The closed loop's tilt feedback (`simulate --closed-loop`), designed from [dynamics].
        let tf = crate::closed_loop::tilt_feedback(&p);
        let m = crate::closed_loop::tilt_margins(&p, &tf);
        text += &format!(
            "tilt feedback (closed loop, from [dynamics]): gain {:.3} /s, lean {:.4} rad per m/s²; \
             rocking {:.3} rad/s, damping ratio {:.3}; crossover {:.2} rad/s, phase margin {:.0}°, \
             delay margin {:.1} ms (the 100 Hz loop's own delay ≈ 15 ms)\n",
            tf.gain,
            tf.lean_per_accel,
            m.open_frequency,
            m.damping_ratio,
            m.crossover,
            m.phase_margin_deg,
            1e3 * m.delay_margin
        );
        // With the runtime's tilt estimate in the loop (gyro + accelerometer minus the
        // commanded acceleration), the IMU at the platform's centre of mass.
        let e = crate::closed_loop::tilt_poles(&p, &tf, p.com_depth);
        let pole = |x: (f64, f64)| {
            if x.1.abs() > 1e-9 {
                format!("{:.2} ± {:.2}j", x.0, x.1.abs())
            } else {
                format!("{:.2}", x.0)
            }
        };
        let pair = e.poles.iter().find(|x| x.1.abs() > 1e-9).copied();
        text += &format!(
            "tilt estimate (accelerometer time constant {:.2} s, IMU {:.3} m below the shell \
             centre): closed-loop poles {}{} rad/s, damping ratio {:.3}\n",
            tf.accel_time_constant,
            p.com_depth,
            pair.map(|x| format!("{}, ", pole(x))).unwrap_or_default(),
            e.poles
                .iter()
                .filter(|x| x.1.abs() <= 1e-9)
                .map(|x| pole(*x))
                .collect::<Vec<_>>()
                .join(", "),
            e.damping_ratio
        );
        j["tilt_feedback"] = json!({
            "gain_per_s": tf.gain, "lean_per_accel": tf.lean_per_accel,
            "rocking_rad_per_s": m.open_frequency, "damping_ratio": m.damping_ratio,
            "crossover_rad_per_s": m.crossover, "phase_margin_deg": m.phase_margin_deg,
            "delay_margin_s": m.delay_margin,
            "accel_time_constant_s": tf.accel_time_constant,
            "imu_depth_m": p.com_depth,
            "poles_with_estimate": e.poles.iter().map(|x| [x.0, x.1]).collect::<Vec<_>>(),
            "damping_ratio_with_estimate": e.damping_ratio,
        });
    }
    j["limits"] = json!({
        "max_wheel_rate": d.limits.max_wheel_rate, "max_wheel_accel": d.limits.max_wheel_accel,
        "max_steer_rate": d.limits.max_steer_rate, "max_steer_accel": d.limits.max_steer_accel,
        "max_accel": d.body_limits().max_accel, "max_yaw_accel": d.body_limits().max_yaw_accel,
        "max_jerk": d.body_limits().max_jerk,
    });
    Ok(CheckReport {
        text: text.trim_end().to_string(),
        limits: limit_lines(d),
        json: j,
    })
}

/// The limits block: each motor limit (or `(none)`), the body limits with their sources.
fn limit_lines(d: &RobotDescription) -> Vec<String> {
    let l = &d.limits;
    let show = |name: &str, v: Option<f64>, unit: &str| match v {
        Some(x) => format!("  {name:<16} {x} {unit}"),
        None => format!("  {name:<16} (none)"),
    };
    let mut out = vec!["limits:".to_string()];
    out.push(show("max_wheel_rate", l.max_wheel_rate, "rad/s"));
    out.push(show("max_wheel_accel", l.max_wheel_accel, "rad/s²"));
    if l.max_steer_rate.is_some() || l.max_steer_accel.is_some() {
        out.push(show("max_steer_rate", l.max_steer_rate, "rad/s"));
        out.push(show("max_steer_accel", l.max_steer_accel, "rad/s²"));
    }
    // The body limits plan, simulate, robot and drive share (omnikin::description::BodyLimits).
    let b = d.body_limits();
    out.push(format!(
        "  max_accel        {:.4} m/s² ({})",
        b.max_accel,
        b.max_accel_source.describe("max_accel")
    ));
    out.push(format!(
        "  max_yaw_accel    {:.4} rad/s² ({})",
        b.max_yaw_accel,
        b.max_yaw_accel_source.describe("max_yaw_accel")
    ));
    out.push(show("max_jerk", b.max_jerk, "m/s³"));
    out
}

/// Closed-loop poles `eig(A − B K)` of a design (2 for yaw, 4 for the vertical planes).
fn poles(d: &omnikin::control::PlaneDesign) -> Vec<Complex<f64>> {
    let closed: Matrix4<f64> = d.a - d.b * d.gain.transpose();
    if d.states == 2 {
        let c: Matrix2<f64> = closed.fixed_view::<2, 2>(0, 0).into_owned();
        c.complex_eigenvalues().iter().copied().collect()
    } else {
        closed.complex_eigenvalues().iter().copied().collect()
    }
}

/// Appends the balance design of the ballbot description `d` to `text` and `j["balance"]`:
/// its `[dynamics]` (masses, inertias, torque limit, rate, weights; the preset's values where
/// absent, [`RobotDescription::balance_config`]).
fn balance(d: &RobotDescription, text: &mut String, j: &mut Value) -> Result<(), String> {
    let config: BalanceConfig<f64> = d
        .balance_config()
        .ok_or("the balance controller needs a ballbot")?;
    let c = BalanceController::new(config)
        .map_err(|e| format!("designing the balance controller: {e}"))?;
    let p = &config.plant;
    *text += &format!(
        "balance controller (LQR per planar model, {} Hz; [dynamics]: ball {:.3} kg, body {:.3} kg, centre of mass {:.3} m above the ball centre, wheel torque limit {:.3} N·m):\n",
        config.rate_hz, p.ball_mass, p.body_mass, p.com_height, config.torque_limit
    );
    let mut planes = Vec::new();
    let mut all_stable = true;
    for d in c.designs() {
        let pl = poles(d);
        let rho = pl.iter().map(|z| z.re.hypot(z.im)).fold(0.0, f64::max);
        let stable = rho < 1.0;
        all_stable &= stable;
        let gain = &d.gain.as_slice()[..d.states];
        let states = if d.states == 4 {
            "(φ, θ, φ̇, θ̇)"
        } else {
            "(β, β̇)"
        };
        let fmt_pole = |z: &Complex<f64>| {
            if z.im.abs() < 1e-12 {
                format!("{:.5}", z.re)
            } else {
                format!("{:.5}{:+.5}i", z.re, z.im)
            }
        };
        *text += &format!(
            "  {}: K {states} = [{}]\n    poles [{}], |max| = {rho:.5}: {}\n",
            d.plane.name(),
            gain.iter()
                .map(|g| format!("{g:.4}"))
                .collect::<Vec<_>>()
                .join(", "),
            pl.iter().map(fmt_pole).collect::<Vec<_>>().join(", "),
            if stable { "stable" } else { "UNSTABLE" }
        );
        planes.push(json!({
            "plane": d.plane.name(), "gain": gain,
            "poles": pl.iter().map(|z| [z.re, z.im]).collect::<Vec<_>>(),
            "spectral_radius": rho, "stable": stable,
        }));
    }
    *text += &format!(
        "  closed loop: {}\n",
        if all_stable {
            "stable (every pole inside the unit circle)"
        } else {
            "UNSTABLE"
        }
    );
    j["balance"] = json!({
        "rate_hz": config.rate_hz, "torque_limit_nm": config.torque_limit,
        "fall_tilt_deg": config.fall_tilt.to_degrees(), "planes": planes, "stable": all_stable,
    });
    Ok(())
}
