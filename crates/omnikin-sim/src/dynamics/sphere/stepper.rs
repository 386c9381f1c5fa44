//! The hybrid stepper motor as the sphere's motors see it ([`Stepper`]): a torque–angle law
//! that pulls the rotor towards the commanded (field) angle, a pull-out torque that falls with
//! speed, and the bookkeeping of lost steps.
//!
//! **Model.** A two-phase hybrid stepper with `S` full steps per revolution has `N_r = S/4`
//! rotor teeth: its static torque is periodic in the rotor's lag behind the field with period
//! `2π/N_r` (4 full steps, one electrical cycle). With `e = θ_rotor − θ_field`,
//!
//! ```text
//! τ = −T(|θ̇_field|) sin(N_r e) − b (θ̇_rotor − θ̇_field)
//! ```
//!
//! A steady load `τ_L` is carried at the lag `sin(N_r e) = −τ_L/T`; the largest load the
//! motor carries at a speed is `T`, its **pull-out torque** there, so the torque–angle
//! amplitude at each speed is the datasheet's pull-out curve. Past `|N_r e| = π/2` the
//! restoring torque falls: the rotor slips a pole (4 full steps lost per electrical cycle)
//! and, with the field running on at speed, the average torque is near zero — the motor
//! **stalls**; it catches a pole again only if the command slows enough for the rotor to
//! follow. Nothing resynchronises it on purpose (the firmware has no closed loop on the rotor).
//!
//! **The pull-out curve** ([`Stepper::pull_out`]): `T(ω) = T₀` up to the corner speed `ω_c`,
//! `T₀ ω_c/|ω|` above (constant power: the chopper can no longer hold the rated current, the
//! winding's current falls as `V/(N_r ω L)`). Datasheet class: a 1.8° NEMA 17 hybrid stepper
//! of ≈ 0.4 N·m holding torque (1.5–1.7 A, ≈ 1.5 Ω, ≈ 3 mH per phase, the class of e.g.
//! 17HS4401), driven by a current chopper from a 12 V battery; paper 000 names neither motor
//! nor supply (its figure shows 42 mm motors). Such datasheets show a pull-out torque of
//! ≈ 0.3 N·m at low step rates, flat to a few hundred full steps per second and then falling
//! roughly as 1/speed; the corner from the electrical values is
//! `ω_c ≈ V/(N_r L I) = 12/(50 · 2.8e-3 · 1.7)` ≈ 50 rad/s (≈ 480 rpm, 1 600 full steps/s).
//! The paper's wheel rates (≤ 12 rad/s) lie on the flat part.
//!
//! **Damping** `b`: the rotor's motion against the field induces a back-EMF; with the winding
//! voltage-driven that damps at `k_t²/R` ≈ (0.4/1.7)²/1.5 ≈ 0.04 N·m·s/rad; a current chopper
//! cancels most of it below the corner speed. Default 0.01 N·m·s/rad, an estimate (0–0.04).

use super::params::SphereDynamics;

/// One stepper motor's torque law (see the [module](self) doc). All motors of a robot share it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stepper {
    /// Electrical cycles per revolution `N_r` (full steps per revolution / 4).
    pub teeth: f64,
    /// Pull-out torque at low speed `T₀`, N·m.
    pub torque: f64,
    /// Corner speed `ω_c`, rad/s: above it the pull-out torque falls as `T₀ ω_c/|ω|`.
    pub corner_speed: f64,
    /// Viscous damping of the rotor against the field `b`, N·m·s/rad.
    pub damping: f64,
}

impl Stepper {
    /// The stepper of `p` (its `pull_out_torque`, `stepper_steps_per_rev`,
    /// `stepper_corner_speed`, `stepper_damping`); no check (see [`SphereDynamics::validate`]).
    pub fn of(p: &SphereDynamics) -> Self {
        Self {
            teeth: p.stepper_steps_per_rev / 4.0,
            torque: p.pull_out_torque,
            corner_speed: p.stepper_corner_speed,
            damping: p.stepper_damping,
        }
    }

    /// Pull-out torque at the field's speed `speed` (rad/s, either sign), N·m: `T₀` up to the
    /// corner speed, `T₀ ω_c/|ω|` above.
    pub fn pull_out(&self, speed: f64) -> f64 {
        let w = speed.abs();
        if w <= self.corner_speed {
            self.torque
        } else {
            self.torque * self.corner_speed / w
        }
    }

    /// The motor's torque on its rotor, N·m (right-handed about the wheel axis), for the lag
    /// `lag = θ_rotor − θ_field` (rad), the rotor's rate relative to the field's `rel_rate`
    /// (rad/s) and the field's speed `speed` (rad/s).
    pub fn torque(&self, lag: f64, rel_rate: f64, speed: f64) -> f64 {
        -self.pull_out(speed) * (self.teeth * lag).sin() - self.damping * rel_rate
    }

    /// The lag (rad) at which the motor holds a steady load that needs the motor torque `load`
    /// (N·m) at speed `speed`: `−asin(load/T)/N_r`, the load clamped to the pull-out torque.
    pub fn lag_for(&self, load: f64, speed: f64) -> f64 {
        let t = self.pull_out(speed);
        -(load / t).clamp(-1.0, 1.0).asin() / self.teeth
    }

    /// The electrical cycle the rotor sits in for the lag `lag` (rad): 0 while within half a
    /// cycle of its own pole, ±1 after slipping one pole (4 full steps) and so on.
    pub fn cycle(&self, lag: f64) -> i64 {
        (self.teeth * lag / core::f64::consts::TAU).round() as i64
    }
}
