//! The sphere's floor pivot friction from the decay of a spin after a stop
//! (`omnikin identify --robot sphere-omni` with the gyro of the `spin-stop` test plan).
//!
//! **Physics** ([`crate::dynamics::sphere`], "Motors holding fixed rates" and the vertical
//! angular momentum): once the three wheels are still, the constraint rows `C_i u = 0` span
//! the relative rate `Ω − ω` in 3-D, so platform and shell turn as one rigid body. After a
//! spin in place it spins about the vertical through the shell centre `C` and the floor
//! contact: the platform's centre of mass (on its z axis, `h` below `C`) is on that axis, the
//! platform is level, so no parallel-axis term enters. The floor's only torque about the
//! vertical is the pivot friction `−τ_p tanh(Ω3/ε_p)` (the rolling resistance acts on the
//! horizontal rate `Ω_h`, zero in a spin in place), so the vertical angular momentum
//! `(I_s + J_zz) ω_z` falls at the constant rate `τ_p` while `|Ω3| ≫ ε_p`:
//!
//! ```text
//! ω_z(t) = s a (T − t)₊ ,   a = τ_p / (I_s + J_zz)
//! ```
//!
//! a straight line to rest at `t = T`, then rest (`s` the spin's sign; the `tanh`
//! regularisation rounds the corner within `ε_p (I_s + J_zz)/τ_p`, milliseconds).
//!
//! **Estimate.** Each stop of the encoder log ([`super::rocking::stops`]) whose motion over
//! the [`SPIN_SPAN`] s before it was mostly a turn in place (the yaw turned, times the shell
//! radius, exceeds the distance rolled) is a spin stop. From [`SETTLE`] s after the wheels
//! stop (the lock's transient: sliding rollers take a few milliseconds to stick) to the end of
//! the rest, at most [`super::rocking::MAX_WINDOW`] s after the stop, the gyro's `gz` is
//! fitted by least squares with `g(τ) = c + b (T − τ)₊` (`c` the gyro's offset, `b = s a`):
//! for each corner `T` on a grid the model is linear in `(c, b)`; the best is refined by
//! Levenberg–Marquardt over `(b, T, c)`, whose covariance gives `a`'s 1σ (inflated for
//! correlated residuals, as [`super::rocking`] does). A spin that has not come to rest inside
//! the window is fitted by a straight line (its slope alone). Then
//! `τ_p ≈ (I_s + J_zz) a`, the inertias from the robot file (weighed and computed, not
//! identified here): exactly, the `τ_p` at which the dynamic model, released spinning with its
//! wheels held and fitted the same way, shows the same deceleration ([`pivot_friction`]);
//! stops are pooled by inverse variance.
//!
//! A gyro scale error `k` scales `a` (and `τ_p`) by `k`; a constant bias is `c`. A real
//! robot's other losses about the vertical (the shell's air drag, a floor that is not flat)
//! land in this one number.

use super::lsq;
use super::rocking::{MAX_WINDOW, stops};
use super::runs::{EncoderLog, GyroLog};
use crate::dynamics::sphere::SphereDynamics;

/// Time after the wheels stop that is left out of the fit (the lock's transient), s.
pub const SETTLE: f64 = 0.1;
/// Span of the encoder log before a stop whose motion decides whether it was a spin, s.
pub const SPIN_SPAN: f64 = 0.5;
/// Fewest gyro samples on the decaying part of the window that are fitted.
pub const MIN_DECAY_SAMPLES: usize = 10;

/// The decay of one spin after a stop.
#[derive(Clone, Debug, PartialEq)]
pub struct SpinDecay {
    /// The gyro log (as named in messages).
    pub file: String,
    /// The moment the wheels stopped (first still encoder sample), s.
    pub stop: f64,
    /// Start of the fitted window, `stop + SETTLE`, s.
    pub t0: f64,
    /// Length of the fitted window, s.
    pub duration: f64,
    /// The spin's rate at `t0` (offset removed), body z, rad/s.
    pub initial_rate: f64,
    /// Deceleration `a` of the spin and its 1σ, rad/s².
    pub deceleration: (f64, f64),
    /// Time from `t0` to rest `T`, s; `None` when the spin did not come to rest in the window.
    pub to_rest: Option<f64>,
    /// The gyro's offset `c` at rest, rad/s (0 when not at rest in the window).
    pub offset: f64,
    /// Gyro samples fitted.
    pub samples: usize,
    /// RMS of the fit's residuals, rad/s.
    pub residual_rms: f64,
}

/// Whether the stop at encoder sample `k` ends a spin in place: over the [`SPIN_SPAN`] s before
/// it, the yaw turned times `radius` (m) exceeds the distance travelled (each increment's
/// displacement by `robot`'s kinematics). Returns the sign of the turn when it does.
pub fn spin_before(
    robot: &omnikin::Robot<f64>,
    log: &EncoderLog,
    k: usize,
    radius: f64,
) -> Option<f64> {
    let t_stop = log.t[k];
    let first = log.t[..=k].partition_point(|t| *t < t_stop - SPIN_SPAN);
    let (mut turn, mut path) = (0.0, 0.0);
    for j in first..k {
        let d = robot
            .displacement(&log.angles[j], &log.angles[j + 1])
            .ok()?
            .twist;
        turn += d.yaw_rate;
        path += d.vx.hypot(d.vy);
    }
    (turn.abs() * radius > path && turn != 0.0).then_some(turn.signum())
}

/// `g(τ) = c + b (T − τ)₊` at `p = [b, T, c]`.
fn model(p: &[f64], tau: f64) -> f64 {
    p[2] + p[0] * (p[1] - tau).max(0.0)
}

/// For a fixed corner `T`, `(c, b)` by linear least squares and the sum of squared residuals.
fn linear(tau: &[f64], g: &[f64], corner: f64) -> Option<(f64, f64, f64)> {
    let (mut s1, mut sx, mut sxx, mut sy, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (t, y) in tau.iter().zip(g) {
        let x = (corner - t).max(0.0);
        s1 += 1.0;
        sx += x;
        sxx += x * x;
        sy += y;
        sxy += x * y;
    }
    let det = s1 * sxx - sx * sx;
    if det.abs() <= 1e-12 * s1 * sxx.max(1e-300) {
        return None;
    }
    let b = (s1 * sxy - sx * sy) / det;
    let c = (sy - b * sx) / s1;
    let ss = tau
        .iter()
        .zip(g)
        .map(|(t, y)| (c + b * (corner - t).max(0.0) - y).powi(2))
        .sum();
    Some((c, b, ss))
}

/// `sqrt((1 + ρ)/(1 − ρ))` for the lag-1 autocorrelation ρ of `r` (clamped to [0, 0.99]).
fn inflation(r: &[f64]) -> f64 {
    let zero: f64 = r.iter().map(|v| v * v).sum();
    let lag: f64 = r.windows(2).map(|w| w[0] * w[1]).sum();
    let rho = if zero > 0.0 {
        (lag / zero).clamp(0.0, 0.99)
    } else {
        0.0
    };
    ((1.0 + rho) / (1.0 - rho)).sqrt()
}

/// Fits the decay of a spin of sign `sign` in `gyro` over `[stop + SETTLE, t1]` (see the module
/// docs). `None` when the window has fewer than [`MIN_DECAY_SAMPLES`] samples on the decaying
/// part, the spin does not decay towards rest (a fitted rate of the other sign), or the fit
/// fails.
pub fn fit_decay(gyro: &GyroLog, stop: f64, t1: f64, sign: f64) -> Option<SpinDecay> {
    let t0 = stop + SETTLE;
    let idx: Vec<usize> = (0..gyro.t.len())
        .filter(|&k| gyro.t[k] >= t0 && gyro.t[k] <= t1)
        .collect();
    if idx.len() < MIN_DECAY_SAMPLES + 3 {
        return None;
    }
    let tau: Vec<f64> = idx.iter().map(|&k| gyro.t[k] - t0).collect();
    let g: Vec<f64> = idx.iter().map(|&k| gyro.rate[k]).collect();
    let span = tau[tau.len() - 1];
    let dt = span / (tau.len() - 1) as f64;
    // The corner on a grid of half samples; beyond the window the model is a straight line.
    let mut best: Option<(f64, f64, f64, f64)> = None;
    let steps = 2 * tau.len();
    for i in 1..=steps {
        let corner = span * i as f64 / steps as f64;
        if let Some((c, b, ss)) = linear(&tau, &g, corner)
            && best.as_ref().is_none_or(|x| ss < x.3)
        {
            best = Some((corner, c, b, ss));
        }
    }
    let (corner, c, b, _) = best?;
    let at_rest = corner < span - dt;
    let decaying = tau.iter().filter(|t| **t < corner).count();
    if b * sign <= 0.0 || decaying < MIN_DECAY_SAMPLES {
        return None;
    }
    let f = |x: &[f64]| -> Option<Vec<f64>> {
        Some(tau.iter().zip(&g).map(|(t, y)| model(x, *t) - y).collect())
    };
    let scale = b.abs().max(1e-9);
    let (x0, free) = if at_rest {
        ([b, corner, c], [true, true, true])
    } else {
        // A straight line: the corner held beyond the window, the intercept in `c`.
        ([b, span, c], [true, false, true])
    };
    let h = [
        1e-6 * scale,
        1e-6 * span.max(dt),
        1e-6 * scale * span.max(dt),
    ];
    let sol = lsq::solve(&f, &x0, &h, &free).ok()?;
    let r = f(&sol.x)?;
    let k = inflation(&r);
    let (b, corner, c) = (sol.x[0], sol.x[1], sol.x[2]);
    if b * sign <= 0.0 || !b.is_finite() {
        return None;
    }
    Some(SpinDecay {
        file: gyro.file.clone(),
        stop,
        t0,
        duration: span,
        initial_rate: b * corner.max(0.0) + if at_rest { 0.0 } else { c },
        deceleration: (b.abs(), sol.sigma[0] * k),
        to_rest: at_rest.then_some(corner),
        offset: if at_rest { c } else { 0.0 },
        samples: idx.len(),
        residual_rms: sol.residual_rms,
    })
}

/// The stops of one run, sorted by what they ended ([`spin_decays`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunStops {
    /// The decay fitted after each spin stop with a gyro.
    pub spins: Vec<SpinDecay>,
    /// Spin stops found in the encoder log (fitted or not).
    pub spin_stops: usize,
    /// The other stops (translations), as `(first still, last still)` encoder indices, for
    /// the rocking ([`super::rocking::rocking_after`]).
    pub others: Vec<(usize, usize)>,
}

/// Every spin stop's decay in one run ([`spin_before`] with `radius`, m; then [`fit_decay`]
/// from the stop to the end of its rest, at most [`MAX_WINDOW`] s after it), and the other
/// stops.
pub fn spin_decays(
    robot: &omnikin::Robot<f64>,
    radius: f64,
    encoders: &EncoderLog,
    gyro: Option<&GyroLog>,
) -> RunStops {
    let mut out = RunStops::default();
    for (a, b) in stops(encoders) {
        match spin_before(robot, encoders, a, radius) {
            Some(sign) => {
                out.spin_stops += 1;
                let stop = encoders.t[a];
                let t1 = encoders.t[b].min(stop + MAX_WINDOW);
                if let Some(d) = gyro.and_then(|g| fit_decay(g, stop, t1, sign)) {
                    out.spins.push(d);
                }
            }
            None => out.others.push((a, b)),
        }
    }
    out
}

/// The decay the dynamic model `p`, with pivot friction `tau_p` (N·m), shows when it spins
/// about the vertical at `rate` (rad/s), level, its wheels held (platform and shell turning
/// together): the platform's body z rate sampled every `dt` s for `duration` s and fitted as
/// the logs are ([`fit_decay`], the window starting at the release).
pub fn model_decay(
    p: &SphereDynamics,
    tau_p: f64,
    rate: f64,
    dt: f64,
    duration: f64,
) -> Option<SpinDecay> {
    use crate::dynamics::sphere::{SphereSim, SphereState};
    use omnikin::nalgebra::Vector3;
    let mut q = *p;
    q.pivot_friction = tau_p;
    let state = SphereState {
        platform_rate: Vector3::new(0.0, 0.0, rate),
        shell_rate: Vector3::new(0.0, 0.0, rate),
        ..SphereState::at_rest(0.0, 0.0, 0.0)
    };
    let mut sim = SphereSim::with_state(q, state).ok()?;
    let n = (duration / dt).round() as usize;
    let body_z = |s: &SphereState| (s.orientation.inverse() * s.platform_rate).z;
    let mut log = GyroLog {
        file: "model".into(),
        t: Vec::with_capacity(n + 1),
        rate: Vec::with_capacity(n + 1),
    };
    log.t.push(0.0);
    log.rate.push(body_z(&sim.state()));
    for k in 1..=n {
        sim.step(dt, [0.0; 3]).ok()?;
        log.t.push(k as f64 * dt);
        log.rate.push(body_z(&sim.state()));
    }
    fit_decay(&log, -SETTLE, duration, rate.signum())
}

/// The pivot friction `τ_p` (N·m) and its 1σ at which the dynamic model `p` decays as `d` did:
/// released spinning at `d`'s initial rate with its wheels held, the model's spin, sampled and
/// fitted as the log's was ([`model_decay`]), has `d`'s deceleration. A secant solve from the
/// rigid-body value `(I_s + J_zz) a` (the shell's and the platform's inertia about the
/// vertical from the file), to 1e-9 relative; its 1σ is the deceleration's through the model's
/// slope `da/dτ_p`. The match takes out what the straight line misses (the regularised
/// friction's rounded corner at rest, the sampling), as [`super::rocking`] does for the
/// rocking. `None` when the model does not reach the deceleration.
pub fn pivot_friction(p: &SphereDynamics, d: &SpinDecay) -> Option<(f64, f64)> {
    let inertia = p.shell_inertia + p.platform_inertia[2][2];
    let a = d.deceleration.0;
    let dt = d.duration / (d.samples.max(2) - 1) as f64;
    let model =
        |tau: f64| model_decay(p, tau, d.initial_rate, dt, d.duration).map(|m| m.deceleration.0);
    let (mut x0, mut x1) = (inertia * a, inertia * a * 1.01);
    let (mut g0, mut g1) = (model(x0)? - a, model(x1)? - a);
    for _ in 0..12 {
        if g1.abs() <= 1e-9 * a || g1 == g0 {
            break;
        }
        let x2 = (x1 - g1 * (x1 - x0) / (g1 - g0)).max(0.1 * x1);
        (x0, g0) = (x1, g1);
        x1 = x2;
        g1 = model(x1)? - a;
    }
    // The model's slope da/dτ_p (the rigid body's 1/(I_s + J_zz) when nothing else acts).
    let slope = (model(x1 * 1.01)? - model(x1 * 0.99)?) / (0.02 * x1);
    (g1.abs() <= 1e-6 * a && slope > 0.0).then(|| (x1, d.deceleration.1 / slope))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A noiseless Coulomb decay to rest with an offset: the corner, the slope and the offset
    /// come back; a decay that runs past the window gives its slope from a straight line.
    #[test]
    fn a_straight_decay_to_rest_is_fitted() {
        let gyro = |a: f64, v0: f64, c: f64| GyroLog {
            file: "g".into(),
            t: (0..300).map(|k| k as f64 * 0.01).collect(),
            rate: (0..300)
                .map(|k| c + (v0 - a * (k as f64 * 0.01 - 0.1)).max(0.0))
                .collect(),
        };
        let d = fit_decay(&gyro(1.5, 1.2, 0.01), 0.0, 2.99, 1.0).unwrap();
        assert!((d.deceleration.0 - 1.5).abs() < 1e-6, "{d:?}");
        assert!((d.to_rest.unwrap() - 0.8).abs() < 1e-6, "{d:?}");
        assert!((d.offset - 0.01).abs() < 1e-6, "{d:?}");
        let d = fit_decay(&gyro(0.2, 1.2, 0.0), 0.0, 2.99, 1.0).unwrap();
        assert!((d.deceleration.0 - 0.2).abs() < 1e-6, "{d:?}");
        assert_eq!(d.to_rest, None);
        // A rate rising after the stop is no decay.
        assert!(fit_decay(&gyro(-0.2, 1.2, 0.0), 0.0, 2.99, 1.0).is_none());
        // The other sign of spin.
        assert!(fit_decay(&gyro(1.5, 1.2, 0.0), 0.0, 2.99, -1.0).is_none());
    }
}
