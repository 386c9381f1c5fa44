//! Motor models: what a motor actually does with a commanded rate.

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

use crate::profile::MotorProfile;

/// State of one simulated motor. Order of effects each step: step-rate clipping → first-order
/// lag → acceleration limit (paper 003 §4.2 ramp phases) → rate bias and speed fluctuation
/// (paper 003 §4.1) →
/// angle integration → stepper quantisation of the angle.
#[derive(Clone, Debug)]
pub(crate) struct Motor {
    cfg: MotorProfile,
    /// Rate after limits and lag, before fluctuation, rad/s.
    rate: f64,
    /// Continuous (unquantised) angle, rad.
    ideal_angle: f64,
    /// Output angle (quantised for a stepper), rad.
    angle: f64,
    /// Current fluctuation factor in [−1, 1] and the time it still holds.
    fluct: f64,
    fluct_left: f64,
    step_angle: Option<f64>,
}

impl Motor {
    /// A motor at rest at angle 0 running at `initial_rate` (rad/s).
    pub(crate) fn new(cfg: MotorProfile, initial_rate: f64) -> Self {
        let step_angle = cfg
            .steps_per_rev
            .map(|spr| core::f64::consts::TAU / (spr as f64 * cfg.microsteps.unwrap_or(1) as f64));
        Self {
            cfg,
            rate: initial_rate,
            ideal_angle: 0.0,
            angle: 0.0,
            fluct: 0.0,
            fluct_left: 0.0,
            step_angle,
        }
    }

    /// Advances the motor by `dt` seconds under the commanded rate `cmd` (rad/s) and returns
    /// the angle it actually turned through, rad.
    pub(crate) fn step(&mut self, cmd: f64, dt: f64, rng: &mut ChaCha8Rng) -> f64 {
        let c = &self.cfg;
        let mut target = cmd;
        if let (Some(max_steps), Some(step)) = (c.max_step_rate, self.step_angle) {
            let max_rate = max_steps * step;
            target = target.clamp(-max_rate, max_rate);
        }
        // `next` is the rate at the end of the step; `mean_rate` its average over the step.
        let (mut next, mut mean_rate) = (target, target);
        if let Some(tau) = c.lag_time_constant {
            let decay = (-dt / tau).exp();
            next = target + (self.rate - target) * decay;
            // Exact integral of the first-order response over the step.
            mean_rate = target + (self.rate - target) * tau * (1.0 - decay) / dt;
        }
        if let Some(a) = c.max_accel {
            let dv = a * dt;
            let delta = next - self.rate;
            if delta.abs() >= dv {
                // Limited for the whole step: a constant-acceleration ramp.
                next = self.rate + dv.copysign(delta);
                mean_rate = self.rate + 0.5 * dv.copysign(delta);
            } else if c.lag_time_constant.is_none() {
                // Reaches the target after |delta|/a, then holds it.
                mean_rate = next - delta * (delta.abs() / a) / (2.0 * dt);
            }
        }
        self.rate = next;
        let amplitude =
            c.fluctuation_abs.unwrap_or(0.0) + c.fluctuation_rel.unwrap_or(0.0) * next.abs();
        let mut actual = mean_rate * (1.0 + c.rate_bias_rel.unwrap_or(0.0));
        if amplitude > 0.0 {
            if self.fluct_left <= 0.0 {
                self.fluct = rng.random_range(-1.0..=1.0);
                self.fluct_left = c.fluctuation_period.unwrap_or(dt);
            }
            self.fluct_left -= dt;
            actual += self.fluct * amplitude;
        }
        self.ideal_angle += actual * dt;
        let new_angle = match self.step_angle {
            Some(step) => (self.ideal_angle / step).round() * step,
            None => self.ideal_angle,
        };
        let delta = new_angle - self.angle;
        self.angle = new_angle;
        delta
    }

    /// The output angle so far, rad (the encoder's ground truth).
    pub(crate) fn angle(&self) -> f64 {
        self.angle
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn rng() -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(7)
    }

    #[test]
    fn ideal_motor_follows_the_command() {
        let mut m = Motor::new(MotorProfile::default(), 0.0);
        let mut r = rng();
        let d = m.step(2.0, 0.01, &mut r);
        assert!((d - 0.02).abs() < 1e-15);
    }

    #[test]
    fn acceleration_limit_ramps() {
        let cfg = MotorProfile {
            max_accel: Some(10.0),
            ..Default::default()
        };
        let mut m = Motor::new(cfg, 0.0);
        let mut r = rng();
        let mut total = 0.0;
        for _ in 0..100 {
            total += m.step(1.0, 0.001, &mut r);
        }
        // 0.1 s ramp at 10 rad/s² to 1 rad/s covers 0.05 rad.
        assert!((total - 0.05).abs() < 1e-12, "{total}");
    }

    #[test]
    fn stepper_quantises_the_angle_and_clips_the_rate() {
        let cfg = MotorProfile {
            steps_per_rev: Some(200),
            microsteps: Some(1),
            max_step_rate: Some(100.0),
            ..Default::default()
        };
        let step = core::f64::consts::TAU / 200.0;
        let mut m = Motor::new(cfg, 0.0);
        let mut r = rng();
        for _ in 0..1000 {
            m.step(100.0, 0.001, &mut r);
            let k = m.angle() / step;
            assert!((k - k.round()).abs() < 1e-9);
        }
        // Clipped at 100 steps/s: 1 s gives 100 steps.
        assert!(
            (m.angle() / step - 100.0).abs() <= 1.0,
            "{}",
            m.angle() / step
        );
    }

    #[test]
    fn fluctuation_is_bounded_and_held_for_its_period() {
        let cfg = MotorProfile {
            fluctuation_abs: Some(0.5),
            fluctuation_period: Some(0.01),
            ..Default::default()
        };
        let mut m = Motor::new(cfg, 0.0);
        let mut r = rng();
        let mut rates = Vec::new();
        for _ in 0..1000 {
            rates.push(m.step(2.0, 0.001, &mut r) / 0.001);
        }
        assert!(rates.iter().all(|x| (x - 2.0).abs() <= 0.5 + 1e-9));
        assert!(rates.iter().any(|x| (x - 2.0).abs() > 0.1));
        for chunk in rates.chunks(10) {
            assert!(chunk.iter().all(|x| (x - chunk[0]).abs() < 1e-9));
        }
    }
}
