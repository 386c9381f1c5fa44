//! A lean the ballbot can follow: the previewed reference lean for a planned ball motion
//! (stable inversion of the planar models), for the balance controller's
//! [`omnikin::control::BalanceCommand::lean`].
//!
//! Adding the two rows of a vertical planar model eliminates the torque:
//! `(a + b) φ̈ + (b + c) θ̈ = G θ − c_f φ̇`, i.e. `θ̈ − z² θ = −h(t)` with `z² = G/(b + c)` and
//! `h = ((a + b) φ̈ + c_f φ̇)/(b + c)` for the planned ball motion `φ(t)`. Its only bounded
//! solution is the two-sided convolution `θ(t) = ∫ e^{−z|t−s|} h(s) ds / (2z)`: the body
//! starts leaning *before* the plan accelerates (by ≈ 1/z ≈ 0.27 s for the preset), so the
//! ball need not roll backwards first and can stay on the plan. Without preview the same lean
//! is reached only after the ball has moved the wrong way (a non-minimum-phase zero at `z`).
//!
//! World-frame leans are computed per axis with the sagittal parameters for x and the lateral
//! ones for y: exact for a constant heading 0 and, since `J_x ≈ J_y`, close for any other.

use omnikin::control::{Lean, PlantParams};

/// `z` and the coefficients of `h = (p φ̈ + q φ̇)` for the plane with body inertia `j`.
fn coefficients(p: &PlantParams<f64>, j: f64) -> (f64, f64, f64) {
    let r = p.ball_radius;
    let a = (p.ball_mass + p.body_mass) * r * r + p.ball_inertia;
    let b = p.body_mass * p.com_height * r;
    let c = j + p.body_mass * p.com_height * p.com_height;
    let g = p.body_mass * p.gravity * p.com_height;
    (
        (g / (b + c)).sqrt(),
        (a + b) / (b + c),
        p.floor_damping / (b + c),
    )
}

/// The lean along one axis for ball accelerations `acc` and velocities `vel` (m/s², m/s)
/// sampled every `dt` s: returns `(θ, θ̇, θ̈)` per sample (rad, rad/s, rad/s²).
fn axis_lean(p: &PlantParams<f64>, j: f64, dt: f64, vel: &[f64], acc: &[f64]) -> Vec<[f64; 3]> {
    let (z, ka, kv) = coefficients(p, j);
    let r = p.ball_radius;
    let n = vel.len().min(acc.len());
    let h: Vec<f64> = (0..n).map(|k| (ka * acc[k] + kv * vel[k]) / r).collect();
    // Causal and anti-causal exponential sums (trapezoidal weights), exact for piecewise
    // linear h up to O(dt²).
    let decay = (-z * dt).exp();
    let mut fwd = vec![0.0; n];
    let mut bwd = vec![0.0; n];
    for k in 1..n {
        fwd[k] = decay * fwd[k - 1] + 0.5 * dt * (decay * h[k - 1] + h[k]);
    }
    for k in (0..n.saturating_sub(1)).rev() {
        bwd[k] = decay * bwd[k + 1] + 0.5 * dt * (decay * h[k + 1] + h[k]);
    }
    (0..n)
        .map(|k| {
            let theta = (fwd[k] + bwd[k]) / (2.0 * z);
            // d/dt of the two sums: fwd' = h − z fwd, bwd' = −h + z bwd.
            let theta_d = (bwd[k] - fwd[k]) / 2.0;
            let theta_dd = z * z * theta - h[k];
            [theta, theta_d, theta_dd]
        })
        .collect()
}

/// The previewed lean for a planned ball motion: world-frame velocities `vel` (m/s) and
/// accelerations `acc` (m/s²) sampled every `dt` s, one [`Lean`] per sample. Before the first
/// and after the last sample the plan is taken to be at rest.
pub fn lean_preview(
    p: &PlantParams<f64>,
    dt: f64,
    vel: &[[f64; 2]],
    acc: &[[f64; 2]],
) -> Vec<Lean<f64>> {
    let col = |v: &[[f64; 2]], i: usize| v.iter().map(|x| x[i]).collect::<Vec<_>>();
    let x = axis_lean(p, p.body_inertia[1], dt, &col(vel, 0), &col(acc, 0));
    // y: the lateral plane has φ = −y/R and θ_x = −ℓ_y, so ℓ_y obeys the x formula in y.
    let y = axis_lean(p, p.body_inertia[0], dt, &col(vel, 1), &col(acc, 1));
    x.iter()
        .zip(&y)
        .map(|(x, y)| Lean {
            tilt: [x[0], y[0]],
            rate: [x[1], y[1]],
            accel: [x[2], y[2]],
        })
        .collect()
}
