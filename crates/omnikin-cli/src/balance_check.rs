//! `omnikin check` for a ballbot: the balance controller's design — LQR gains and closed-loop
//! poles of each planar model (Ballbot paper), and whether every loop is stable.

use anyhow::{Context, Result};
use omnikin::control::{BalanceConfig, BalanceController};
use omnikin::description::RobotDescription;
use omnikin::nalgebra::{Complex, Matrix2, Matrix4};
use serde_json::{Value, json};

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
pub fn report(d: &RobotDescription, text: &mut String, j: &mut Value) -> Result<()> {
    let config: BalanceConfig<f64> = d
        .balance_config()
        .context("the balance controller needs a ballbot")?;
    let c = BalanceController::new(config).context("designing the balance controller")?;
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
