//! The ballbot's balance controller on the MCU (issue 15): built here (the LQR designs run at
//! start-up, in software `f64`), then run in `f32` at 200 Hz against the linearised planar
//! models of the preset (the controller's own zero-order-hold models) from a 5° lean.

use omnikin::control::{
    BalanceCommand, BalanceConfig, BalanceController, BalanceState, Measurement,
};

/// What the run showed.
pub struct BalanceRun {
    /// Last time the tilt was ≥ 0.5°, s.
    pub settle_s: f32,
    /// Tilt at the end (5 s), degrees.
    pub final_tilt_deg: f32,
    /// Cycles in which the wheel torques saturated.
    pub saturated: u32,
    /// Whether the controller ever reported a fall.
    pub fell: bool,
}

/// Builds the preset controller and balances the linear plant from 5° for 5 s.
pub fn run() -> Option<BalanceRun> {
    let mut c = BalanceController::<f32>::new(BalanceConfig::preset()).ok()?;
    let designs = *c.designs();
    let r = c.config().plant.ball_radius;
    // States: lateral (φ, θ_x, φ̇, θ̇_x), sagittal (φ, θ_y, φ̇, θ̇_y), yaw (β, β̇, 0, 0).
    let mut s = [[0.0f32; 4]; 3];
    s[1][1] = 5.0f32.to_radians();
    let mut out = BalanceRun {
        settle_s: 0.0,
        final_tilt_deg: 0.0,
        saturated: 0,
        fell: false,
    };
    let dt = c.period();
    for k in 0..1000u32 {
        let m = Measurement {
            tilt: [s[0][1], s[1][1]],
            tilt_rate: [s[0][3], s[1][3]],
            yaw: s[2][0],
            yaw_rate: s[2][1],
            ball_position: [r * s[1][0], -r * s[0][0]],
            ball_velocity: [r * s[1][2], -r * s[0][2]],
        };
        let o = c.step(&m, &BalanceCommand::hold()).ok()?;
        if o.tilt >= 0.5f32.to_radians() {
            out.settle_s = k as f32 * dt;
        }
        out.saturated += o.saturated as u32;
        out.fell |= o.status == BalanceState::Fallen;
        out.final_tilt_deg = o.tilt.to_degrees();
        for (p, d) in designs.iter().enumerate() {
            let n = d.states;
            let mut next = [0.0f32; 4];
            for (i, x) in next.iter_mut().enumerate().take(n) {
                *x = d.b[i] as f32 * o.model_torques[p]
                    + (0..n).map(|j| d.a[(i, j)] as f32 * s[p][j]).sum::<f32>();
            }
            s[p] = next;
        }
    }
    Some(out)
}
