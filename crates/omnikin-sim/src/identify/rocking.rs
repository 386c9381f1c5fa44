//! The sphere's centre-of-mass depth and rolling resistance from the rocking after a stop
//! (`omnikin identify --robot sphere-omni` with IMU logs of the `stop` test plan).
//!
//! **Physics** ([`crate::dynamics::sphere`], "Motors holding fixed rates"): with its wheels
//! held (encoders still) the robot is one rigid body rocking about the floor contact; for small
//! tilts its free motion is a pendulum of natural frequency
//!
//! ```text
//! ω_n² = m_p g h / (I_s + m_s R² + I_p + m_p (R − h)²)
//! ```
//!
//! ([`crate::dynamics::sphere::SphereDynamics::rocking_frequency`]), `h` the platform's
//! centre-of-mass depth below the shell centre, `I_p` its inertia about the rocking axis. The
//! other values are the robot file's (masses and inertias are weighed and computed, the depth
//! is what is hard to measure).
//!
//! **Estimate.** Each stop is found in the encoder log (moving, then every wheel still for at
//! least [`MIN_REST`] s). From the swing's first turning point to the end of the rest (at most
//! [`MAX_WINDOW`] s after the stop), the IMU's body rates `gx`, `gy` are fitted by least
//! squares with one damped oscillation shared by both axes,
//! `g(t) = e^{−σ τ} (A cos ω_d τ + B sin ω_d τ) + c` (its own `A, B, c` per axis), started from
//! the best frequency of a grid. `ω_n² = ω_d² + σ²`; its 1σ from the fit's
//! (`σ² (JᵀJ)⁻¹`, inflated for correlated residuals, the correlation of `ω_d` and `σ`
//! neglected). The depth and the rolling resistance are those at which the dynamic model,
//! released from rest at the tilt that gives the swing's amplitude, with its wheels held,
//! shows the same natural frequency, decay and amplitude when fitted the same way
//! ([`depth_and_resistance`]), started from the small-tilt formula's depth ([`com_depth`]: the root below `R` of
//! `m_p ω_n² (R − h)² − m_p g h + ω_n² (I_s + m_s R² + I_p) = 0`). Their 1σ are the frequency's
//! and the decay's through the model's Jacobian; stops are pooled by inverse variance.
//!
//! **The decay** is the rolling resistance's: with held wheels it is the rocking's only loss
//! in the model (a regularised Coulomb torque `C_rr M g R` at speeds above its scale, which
//! shortens each swing by a fixed amount rather than a fixed ratio — why the decay is matched
//! through the model and not read as a damping ratio). A real robot's other losses (the
//! motors' compliance, the rollers' hysteresis) land in this one number.

use super::lsq;
use super::runs::{EncoderLog, ImuRates};
use crate::dynamics::sphere::SphereDynamics;

/// Shortest rest after a stop that is fitted, s.
pub const MIN_REST: f64 = 1.5;
/// Longest window fitted after a stop, s.
pub const MAX_WINDOW: f64 = 4.0;

/// The rocking after one stop.
#[derive(Clone, Debug, PartialEq)]
pub struct Rocking {
    /// The IMU log (as named in messages).
    pub file: String,
    /// Start of the fitted window (the first still sample), s.
    pub t0: f64,
    /// Its length, s.
    pub duration: f64,
    /// Damped frequency `ω_d` and its 1σ, rad/s.
    pub damped: (f64, f64),
    /// Decay rate `σ` of the envelope and its 1σ, 1/s.
    pub decay: (f64, f64),
    /// Natural frequency `ω_n = √(ω_d² + σ²)` and its 1σ, rad/s.
    pub natural: (f64, f64),
    /// Share of the rocking's energy about the platform's x axis (the rest about y), in [0, 1].
    pub x_share: f64,
    /// Largest fitted rate amplitude, rad/s.
    pub amplitude: f64,
    /// RMS of the fit's residuals, rad/s.
    pub residual_rms: f64,
}

/// The stops of an encoder log: indices `k` where the wheels were moving over `k − 1 → k`
/// and then stay still for at least [`MIN_REST`] s; with the index of the last still sample.
pub fn stops(log: &EncoderLog) -> Vec<(usize, usize)> {
    let n = log.t.len();
    if n < 3 {
        return Vec::new();
    }
    let speed: Vec<f64> = (1..n)
        .map(|k| {
            let dt = log.t[k] - log.t[k - 1];
            let (a, b) = (&log.angles[k - 1].wheel, &log.angles[k].wheel);
            a.iter()
                .zip(b)
                .map(|(a, b)| ((b - a) / dt).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let peak = speed.iter().cloned().fold(0.0, f64::max);
    if peak <= 0.0 {
        return Vec::new();
    }
    // Still: below 2 % of the run's peak wheel rate (a few counts of a quantised encoder).
    let still = |s: f64| s < 0.02 * peak;
    let mut out = Vec::new();
    let mut k = 1;
    while k < speed.len() {
        // speed[k] is the interval k → k+1.
        if !still(speed[k - 1]) && still(speed[k]) {
            let mut e = k;
            while e < speed.len() && still(speed[e]) {
                e += 1;
            }
            // Samples k..=e are still.
            if log.t[e] - log.t[k] >= MIN_REST {
                out.push((k, e));
            }
            k = e + 1;
        } else {
            k += 1;
        }
    }
    out
}

/// The damped oscillation of both axes at `p = [ω_d, σ, A_x, B_x, c_x, A_y, B_y, c_y]`.
fn model(p: &[f64], tau: f64) -> [f64; 2] {
    let e = (-p[1] * tau).exp();
    let (s, c) = (p[0] * tau).sin_cos();
    [
        e * (p[2] * c + p[3] * s) + p[4],
        e * (p[5] * c + p[6] * s) + p[7],
    ]
}

/// For fixed `ω_d` and `σ`, the amplitudes and offsets of both axes by linear least squares,
/// and the sum of squared residuals.
fn linear(tau: &[f64], g: &[[f64; 2]], w: f64, sigma: f64) -> Option<([f64; 6], f64)> {
    use omnikin::nalgebra::{DMatrix, DVector};
    let m = tau.len();
    let a = DMatrix::from_fn(m, 3, |i, j| {
        let e = (-sigma * tau[i]).exp();
        match j {
            0 => e * (w * tau[i]).cos(),
            1 => e * (w * tau[i]).sin(),
            _ => 1.0,
        }
    });
    let svd = a.clone().svd(true, true);
    let mut p = [0.0; 6];
    let mut ss = 0.0;
    for axis in 0..2 {
        let b = DVector::from_fn(m, |i, _| g[i][axis]);
        let x = svd.solve(&b, 1e-12).ok()?;
        let r = &a * &x - &b;
        ss += r.norm_squared();
        p[3 * axis..3 * axis + 3].copy_from_slice(x.as_slice());
    }
    Some((p, ss))
}

/// Fits the rocking in `imu` over `[t0, t1]` (see the module docs). `None` when the window
/// has too few samples or the fit fails.
pub fn fit_window(imu: &ImuRates, t0: f64, t1: f64) -> Option<Rocking> {
    let idx: Vec<usize> = (0..imu.t.len())
        .filter(|&k| imu.t[k] >= t0 && imu.t[k] <= t1)
        .collect();
    if idx.len() < 20 {
        return None;
    }
    let tau: Vec<f64> = idx.iter().map(|&k| imu.t[k] - t0).collect();
    let g: Vec<[f64; 2]> = idx.iter().map(|&k| imu.rate[k]).collect();
    let span = tau[tau.len() - 1];
    // Frequencies the window resolves: at least one cycle, at most a quarter of the sample rate.
    let dt = span / (tau.len() - 1) as f64;
    let (lo, hi) = (
        std::f64::consts::TAU / span,
        std::f64::consts::PI / (2.0 * dt),
    );
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let mut best: Option<(f64, f64, [f64; 6], f64)> = None;
    let steps = 400;
    for i in 0..=steps {
        let w = lo * (hi / lo).powf(i as f64 / steps as f64);
        for frac in [0.0, 0.05, 0.15, 0.4] {
            let s = frac * w;
            if let Some((p, ss)) = linear(&tau, &g, w, s)
                && best.as_ref().is_none_or(|b| ss < b.3)
            {
                best = Some((w, s, p, ss));
            }
        }
    }
    let (w, s, p, _) = best?;
    let x0 = [w, s, p[0], p[1], p[2], p[3], p[4], p[5]];
    let scale = p[..2]
        .iter()
        .chain(&p[3..5])
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(1e-9);
    let h = [
        1e-6 * w,
        1e-6 * w,
        1e-6 * scale,
        1e-6 * scale,
        1e-6 * scale,
        1e-6 * scale,
        1e-6 * scale,
        1e-6 * scale,
    ];
    let f = |x: &[f64]| -> Option<Vec<f64>> {
        let mut r = Vec::with_capacity(2 * tau.len());
        for (t, gk) in tau.iter().zip(&g) {
            let m = model(x, *t);
            r.push(m[0] - gk[0]);
            r.push(m[1] - gk[1]);
        }
        Some(r)
    };
    let sol = lsq::solve(&f, &x0, &h, &[true; 8]).ok()?;
    // The residuals of a model that is not exactly the plant's (or of a real IMU's drift) are
    // correlated: inflate the white-noise 1σ by sqrt((1 + ρ)/(1 − ρ)), ρ their lag-1
    // autocorrelation per axis (clamped to [0, 0.99]), as the kinematic fit does.
    let r = f(&sol.x)?;
    let (mut lag, mut zero) = (0.0, 0.0);
    for axis in 0..2 {
        let series: Vec<f64> = r.iter().skip(axis).step_by(2).copied().collect();
        zero += series.iter().map(|v| v * v).sum::<f64>();
        lag += series.windows(2).map(|w| w[0] * w[1]).sum::<f64>();
    }
    let rho = if zero > 0.0 {
        (lag / zero).clamp(0.0, 0.99)
    } else {
        0.0
    };
    let inflation = ((1.0 + rho) / (1.0 - rho)).sqrt();
    let (wd, sd) = (sol.x[0].abs(), sol.sigma[0] * inflation);
    let (decay, decay_sd) = (sol.x[1], sol.sigma[1] * inflation);
    let wn = (wd * wd + decay * decay).sqrt();
    let wn_sd = ((wd / wn * sd).powi(2) + (decay / wn * decay_sd).powi(2)).sqrt();
    let ex = sol.x[2].powi(2) + sol.x[3].powi(2);
    let ey = sol.x[5].powi(2) + sol.x[6].powi(2);
    Some(Rocking {
        file: imu.file.clone(),
        t0,
        duration: span,
        damped: (wd, sd),
        decay: (decay, decay_sd),
        natural: (wn, wn_sd),
        x_share: if ex + ey > 0.0 { ex / (ex + ey) } else { 0.5 },
        amplitude: ex.max(ey).sqrt(),
        residual_rms: sol.residual_rms,
    })
}

/// Every stop's rocking in one run ([`rocking_after`] of each of [`stops`]).
pub fn rockings(encoders: &EncoderLog, imu: &ImuRates) -> Vec<Rocking> {
    stops(encoders)
        .into_iter()
        .filter_map(|stop| rocking_after(encoders, imu, stop))
        .collect()
}

/// The rocking after the stop `(a, b)` of [`stops`] (first and last still encoder sample). The
/// window: from the first turning point of the swing after the wheels stop (the sample nearest
/// the first sign change of the rate about the rocking's main axis: the platform at its largest
/// tilt, at rest, as [`model_rocking`] releases the model) to the end of the rest, at most
/// [`MAX_WINDOW`] s after the stop. `None` when [`fit_window`] fails.
pub fn rocking_after(
    encoders: &EncoderLog,
    imu: &ImuRates,
    (a, b): (usize, usize),
) -> Option<Rocking> {
    let stop = encoders.t[a];
    let t1 = encoders.t[b].min(stop + MAX_WINDOW);
    let idx: Vec<usize> = (0..imu.t.len())
        .filter(|&k| imu.t[k] >= stop && imu.t[k] <= t1)
        .collect();
    // The main axis: the larger mean square over the window.
    let ms = |axis: usize| idx.iter().map(|&k| imu.rate[k][axis].powi(2)).sum::<f64>();
    let axis = usize::from(ms(1) > ms(0));
    let turn = idx
        .windows(2)
        .find(|w| imu.rate[w[0]][axis] * imu.rate[w[1]][axis] <= 0.0)
        .map_or(stop, |w| {
            // The sample nearer to the sign change.
            let (r0, r1) = (imu.rate[w[0]][axis], imu.rate[w[1]][axis]);
            if r0.abs() <= r1.abs() {
                imu.t[w[0]]
            } else {
                imu.t[w[1]]
            }
        });
    fit_window(imu, turn, t1)
}

/// The rocking the dynamic model `p`, with depth `h` (m) and rolling resistance `c_rr`, shows
/// when it rocks freely from rest, tilted by `tilt` (rad) about the axis of `x_share` (the
/// share of the rocking about the platform's x axis), its wheels held: sampled every `dt` s
/// for `duration` s and fitted as the logs are ([`fit_window`]).
pub fn model_rocking(
    p: &SphereDynamics,
    h: f64,
    c_rr: f64,
    tilt: f64,
    x_share: f64,
    dt: f64,
    duration: f64,
) -> Option<Rocking> {
    use crate::dynamics::sphere::{SphereSim, SphereState};
    use omnikin::nalgebra::UnitQuaternion;
    let mut q = *p;
    q.com_depth = h;
    q.rolling_resistance = c_rr;
    let x = x_share.clamp(0.0, 1.0);
    let state = SphereState {
        orientation: UnitQuaternion::from_euler_angles(
            tilt * x.sqrt(),
            tilt * (1.0 - x).sqrt(),
            0.0,
        ),
        ..SphereState::at_rest(0.0, 0.0, 0.0)
    };
    let mut sim = SphereSim::with_state(q, state).ok()?;
    let n = (duration / dt).round() as usize;
    let mut rates = ImuRates {
        file: "model".into(),
        t: Vec::with_capacity(n + 1),
        rate: Vec::with_capacity(n + 1),
    };
    let body = |s: &SphereState| {
        let w = s.orientation.inverse() * s.platform_rate;
        [w.x, w.y]
    };
    rates.t.push(0.0);
    rates.rate.push(body(&sim.state()));
    for k in 1..=n {
        sim.step(dt, [0.0; 3]).ok()?;
        rates.t.push(k as f64 * dt);
        rates.rate.push(body(&sim.state()));
    }
    fit_window(&rates, 0.0, duration)
}

/// The root of `g` by the secant method from `x0`, `x1`, kept within `[lo, hi]`, to `|g|` below
/// `tol`. `None` when `g` fails or no root is reached.
fn secant(
    g: impl Fn(f64) -> Option<f64>,
    x0: f64,
    x1: f64,
    (lo, hi): (f64, f64),
    tol: f64,
) -> Option<f64> {
    let (mut a, mut b) = (x0, x1);
    let (mut ga, mut gb) = (g(a)?, g(b)?);
    for _ in 0..16 {
        if gb.abs() < tol {
            return Some(b);
        }
        if gb == ga {
            break;
        }
        let c = (b - gb * (b - a) / (gb - ga)).clamp(lo, hi);
        a = b;
        ga = gb;
        b = c;
        gb = g(b)?;
    }
    (gb.abs() < tol).then_some(b)
}

/// What the model-matched rocking gives ([`depth_and_resistance`]): value and 1σ of each.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RockingFit {
    /// The platform's centre-of-mass depth `com_depth`, m.
    pub com_depth: (f64, f64),
    /// The rolling-resistance coefficient `rolling_resistance` (`C_rr`), 1.
    pub rolling_resistance: (f64, f64),
}

/// The depth `h` (m) and the rolling resistance `C_rr` at which the dynamic model `p` rocks as
/// `r` did: released from rest at the tilt that gives `r`'s amplitude, with its wheels held,
/// the model's rocking, fitted as the log's was ([`model_rocking`]), has `r`'s natural
/// frequency and decay rate. Alternating secant solves (the release tilt for the amplitude, the
/// depth for the frequency, `C_rr` for the decay), from the small-tilt formula's depth
/// ([`com_depth`]) and the file's `C_rr`, until all hold to
/// 1e-6 relative. 1σ: the frequency's and the decay's, mapped through the inverse of the
/// model's 2 × 2 Jacobian (central differences of 1 %). The formula alone is biased by the
/// swing's amplitude (a pendulum slows as it swings wider) and by the rolling resistance; the
/// rocking's only loss with held wheels is the rolling resistance (a Coulomb torque
/// `C_rr M g R` above its velocity scale). `None` when the model does not reach the values.
pub fn depth_and_resistance(p: &SphereDynamics, r: &Rocking) -> Option<RockingFit> {
    let ip = r.x_share * p.platform_inertia[0][0] + (1.0 - r.x_share) * p.platform_inertia[1][1];
    let (mut h, _) = com_depth(p, ip, r.natural.0, 0.0)?;
    let mut c = p.rolling_resistance.max(1e-4);
    let mut tilt = r.amplitude / r.damped.0;
    let dt = (r.duration / 200.0).min(0.02);
    let radius = p.geometry.shell_radius;
    let depth = (1e-6 * radius, radius * (1.0 - 1e-6));
    let (wn, decay, amp) = (r.natural.0, r.decay.0, r.amplitude);
    for _ in 0..8 {
        // The release tilt for the swing's fitted amplitude, the depth for the frequency, the
        // rolling resistance for the decay.
        let tilt_new = secant(
            |t| Some(model_rocking(p, h, c, t, r.x_share, dt, r.duration)?.amplitude - amp),
            tilt,
            tilt * 1.05,
            (1e-6, 1.2),
            1e-6 * amp,
        )?;
        let model = |h: f64, c: f64| model_rocking(p, h, c, tilt_new, r.x_share, dt, r.duration);
        let h_new = secant(
            |h| Some(model(h, c)?.natural.0 - wn),
            h,
            (h * 1.02).min(0.5 * (h + radius)),
            depth,
            1e-6 * wn,
        )?;
        let c_new = secant(
            |c| Some(model(h_new, c)?.decay.0 - decay),
            c,
            c * 1.1,
            (0.0, 1.0),
            1e-6 * wn,
        )?;
        let done = (h_new - h).abs() < 1e-6 * h
            && (c_new - c).abs() < 1e-6 * c.max(1e-6)
            && (tilt_new - tilt).abs() < 1e-6 * tilt;
        (h, c, tilt) = (h_new, c_new, tilt_new);
        if done {
            break;
        }
    }
    let model = |h: f64, c: f64| model_rocking(p, h, c, tilt, r.x_share, dt, r.duration);
    // The model's Jacobian of (natural frequency, decay) in (h, C_rr).
    let (dh, dc) = (0.01 * h, 0.01 * c.max(1e-4));
    let at = |h: f64, c: f64| model(h, c).map(|m| [m.natural.0, m.decay.0]);
    let (hp, hm) = (at(h + dh, c)?, at(h - dh, c)?);
    let (cp, cm) = (at(h, c + dc)?, at(h, (c - dc).max(0.0))?);
    let dc_span = c + dc - (c - dc).max(0.0);
    let j = [
        [(hp[0] - hm[0]) / (2.0 * dh), (cp[0] - cm[0]) / dc_span],
        [(hp[1] - hm[1]) / (2.0 * dh), (cp[1] - cm[1]) / dc_span],
    ];
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    // J⁻¹ = [[d, −b], [−c, a]] / det; Cov = J⁻¹ diag(s_w², s_σ²) J⁻ᵀ.
    let inv = [
        [j[1][1] / det, -j[0][1] / det],
        [-j[1][0] / det, j[0][0] / det],
    ];
    let (sw, sd) = (r.natural.1, r.decay.1);
    let sigma = |row: [f64; 2]| ((row[0] * sw).powi(2) + (row[1] * sd).powi(2)).sqrt();
    Some(RockingFit {
        com_depth: (h, sigma(inv[0])),
        rolling_resistance: (c, sigma(inv[1])),
    })
}

/// The centre-of-mass depth (m) and its 1σ for a natural rocking frequency `wn ± wn_sd`
/// (rad/s) of the robot `p` (its other values), rocking about an axis whose platform inertia
/// is `ip` (kg·m²). `None` when no depth inside the shell rocks that fast.
pub fn com_depth(p: &SphereDynamics, ip: f64, wn: f64, wn_sd: f64) -> Option<(f64, f64)> {
    let r = p.geometry.shell_radius;
    let (mp, g) = (p.platform_mass, p.gravity);
    let k = p.shell_inertia + p.shell_mass * r * r + ip;
    let w2 = wn * wn;
    // m_p ω² h² − (2 m_p ω² R + m_p g) h + ω² (m_p R² + K) = 0, the smaller root.
    let a = mp * w2;
    let b = -(2.0 * mp * w2 * r + mp * g);
    let c = w2 * (mp * r * r + k);
    let disc = b * b - 4.0 * a * c;
    if disc.is_nan() || disc < 0.0 || a <= 0.0 {
        return None;
    }
    // The smaller root, in the form that does not cancel.
    let h = 2.0 * c / (-b + disc.sqrt());
    if !(h > 0.0 && h < r) {
        return None;
    }
    let d = k + mp * (r - h) * (r - h);
    let dh_dw = 2.0 * wn * d / (mp * g + 2.0 * w2 * mp * (r - h));
    Some((h, dh_dw.abs() * wn_sd))
}
