//! The plausible range of each `[dynamics]` value (docs/sphere-dynamics.md's parameter
//! tables), as data: [`PRIORS`]. `reproduce sphere-2019` draws robots from them for its prior
//! bands ([`draw`], uniform over each range, independent) and sets each value at both ends of
//! its range for its sensitivity table ([`Prior::set`]).
//!
//! The ranges are the documented ones, not chosen for their effect. The fitted value,
//! `com_depth`, is held at the robot file's value (the fit conditions it on the paper's 1.4);
//! the stepper's own keys act only with `motor = "stepper"` and are left out for the rate
//! model (the preset's). `shell_inertia` follows `shell_mass` (`⅔ m_s R²`, a thin shell) and the
//! platform's three principal moments scale together.

use rand::{Rng, RngExt};

use super::params::SphereDynamics;

/// One `[dynamics]` value's plausible range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prior {
    /// The `[dynamics]` key.
    pub key: &'static str,
    /// Lower end of the range, in the key's unit (for `platform_inertia`: a factor on the
    /// file's three moments).
    pub low: f64,
    /// Upper end.
    pub high: f64,
    /// The unit as the tables print it.
    pub unit: &'static str,
    /// Where the range comes from.
    pub source: &'static str,
}

/// The range of the one fitted value, `com_depth`, from where the platform's parts can sit
/// (docs/sphere-dynamics.md: motors and wheels at the wheel centres 57 mm below the shell
/// centre, the battery at most ≈ 0.13 m down), m. The sensitivity table sets it to both ends;
/// the prior band keeps the fitted value (the fit conditions it on the paper's 1.4).
pub const COM_DEPTH_PARTS_RANGE: (f64, f64) = (0.06, 0.10);

/// The ranges of docs/sphere-dynamics.md's parameter tables, for the rate motor model.
pub const PRIORS: [Prior; 11] = [
    Prior {
        key: "shell_mass",
        low: 0.35,
        high: 0.7,
        unit: "kg",
        source: "estimate: 0.3 m PC/acrylic sphere 1–2 mm thick (shell_inertia = ⅔ m_s R² follows)",
    },
    Prior {
        key: "platform_mass",
        low: 1.5,
        high: 2.5,
        unit: "kg",
        source: "parts: three NEMA 17, wheels, battery, board, frame",
    },
    Prior {
        key: "platform_inertia",
        low: 0.7,
        high: 1.3,
        unit: "× file",
        source: "parts at their radii, ±30 %",
    },
    Prior {
        key: "pull_out_torque",
        low: 0.2,
        high: 0.4,
        unit: "N m",
        source: "datasheet class: NEMA 17 hybrid stepper on 12 V",
    },
    Prior {
        key: "pivot_friction",
        low: 0.008,
        high: 0.042,
        unit: "N m",
        source: "Hertz spin torque on vinyl, μ 0.2–0.6, floor modulus 20–100 MPa",
    },
    Prior {
        key: "rolling_resistance",
        low: 0.002,
        high: 0.01,
        unit: "",
        source: "estimate: hard plastic on a hard floor",
    },
    Prior {
        key: "roller_friction",
        low: 0.3,
        high: 0.9,
        unit: "",
        source: "estimate: elastomer rollers on dry polycarbonate",
    },
    Prior {
        key: "roller_viscous",
        low: 0.0,
        high: 5.0,
        unit: "N s/m",
        source: "estimate: roller hysteresis",
    },
    Prior {
        key: "roller_preload",
        low: 0.0,
        high: 10.0,
        unit: "N",
        source: "paper 000: the platform rests by its weight (0); a spring support up to 10",
    },
    Prior {
        key: "floor_friction",
        low: 0.2,
        high: 0.6,
        unit: "",
        source: "estimate: hard plastic on linoleum/vinyl (the shell slides past it)",
    },
    Prior {
        key: "tracked_height",
        low: 0.11,
        high: 0.13,
        unit: "m",
        source: "paper 000 §6: the platform top, 120 mm above the floor",
    },
];

impl Prior {
    /// `base` with this prior's value set to `v` (for `platform_inertia`, the file's moments
    /// times `v`; for `shell_mass`, the thin-shell inertia follows).
    pub fn set(&self, base: &SphereDynamics, v: f64) -> SphereDynamics {
        let mut p = *base;
        let r = p.geometry.shell_radius;
        match self.key {
            "shell_mass" => {
                p.shell_mass = v;
                p.shell_inertia = 2.0 / 3.0 * v * r * r;
            }
            "platform_mass" => p.platform_mass = v,
            "platform_inertia" => {
                for row in p.platform_inertia.iter_mut() {
                    for x in row.iter_mut() {
                        *x *= v;
                    }
                }
            }
            "pull_out_torque" => p.pull_out_torque = v,
            "pivot_friction" => p.pivot_friction = v,
            "rolling_resistance" => p.rolling_resistance = v,
            "roller_friction" => p.roller_friction = v,
            "roller_viscous" => p.roller_viscous = v,
            "roller_preload" => p.roller_preload = v,
            "floor_friction" => p.floor_friction = v,
            "tracked_height" => p.tracked_height = v,
            _ => {}
        }
        p
    }
}

/// A robot drawn from the priors: every value of [`PRIORS`] uniform over its range,
/// independently, in [`PRIORS`]' order, over `base` (whose `com_depth` and motor keys are
/// kept).
pub fn draw<R: Rng + ?Sized>(base: &SphereDynamics, rng: &mut R) -> SphereDynamics {
    let mut p = *base;
    for prior in &PRIORS {
        let u: f64 = rng.random();
        p = prior.set(&p, prior.low + u * (prior.high - prior.low));
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_prior_sets_its_key_and_draws_stay_in_range_and_valid() {
        let base = SphereDynamics::paper_000();
        for prior in &PRIORS {
            assert!(prior.low < prior.high, "{}", prior.key);
            let lo = prior.set(&base, prior.low);
            let hi = prior.set(&base, prior.high);
            assert_ne!(lo, hi, "{} changes nothing", prior.key);
            lo.validate().unwrap();
            hi.validate().unwrap();
        }
        let mut rng = crate::trial_rng(1, 0);
        for _ in 0..200 {
            let p = draw(&base, &mut rng);
            p.validate().unwrap();
            assert_eq!(p.com_depth, base.com_depth);
            assert!((0.35..=0.7).contains(&p.shell_mass));
            assert!((0.008..=0.042).contains(&p.pivot_friction));
            let k = p.platform_inertia[2][2] / base.platform_inertia[2][2];
            assert!((0.7..=1.3).contains(&k));
            assert!((p.platform_inertia[0][0] / base.platform_inertia[0][0] - k).abs() < 1e-12);
        }
    }
}
