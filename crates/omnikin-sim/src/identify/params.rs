//! The kinematic parameters an identification can fit, per robot kind, as named scalars with
//! their prior (the robot file's value) — and the robot a vector of them describes.
//!
//! | kind | parameters |
//! |------|------------|
//! | `omni` (kiwi, X-drive, mecanum) | per wheel: `radius_scale`, `position.x`, `position.y` (m), `drive_angle` (rad) |
//! | `swerve` | per module: `radius_scale`, `position.x`, `position.y` (m) |
//! | `caster3` | `wheel_radius_scale`, `mount_radius` (m), `eccentricity` (m) |
//! | `sphere-omni` | per wheel: `radius_scale` |
//! | `ballbot` | `wheel_radius_scale` |
//!
//! A radius is fitted as a scale of the prior (`r = scale · r_prior`), so its 1σ reads as a
//! fraction. The roller angles of mecanum wheels, the mount angles of the caster and every
//! dynamic parameter are not fitted here. Not every parameter is identifiable from wheel
//! kinematics: an omni wheel moved along its own drive direction rolls exactly as before
//! (its row of the kinematics is `[d, p × d] / r`), so [`super::identify`] finds such
//! directions from the Jacobian and holds the parameter at its prior.

use omnikin::description::{Geometry, RobotDescription};

/// What a parameter measures (its unit, and its Jacobian step).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParameterQuantity {
    /// A dimensionless scale factor (1 = the prior).
    Scale,
    /// A length, m.
    Length,
    /// An angle, rad.
    Angle,
}

impl ParameterQuantity {
    /// The unit as printed: `""`, `"m"`, `"rad"`.
    pub fn unit(self) -> &'static str {
        match self {
            ParameterQuantity::Scale => "",
            ParameterQuantity::Length => "m",
            ParameterQuantity::Angle => "rad",
        }
    }

    /// Central-difference step for the Jacobian (far above f64 rounding, far below any
    /// physical effect: 1 ppm, 1 µm, 1 µrad).
    pub fn step(self) -> f64 {
        1e-6
    }
}

/// One fitted scalar.
#[derive(Clone, Debug, PartialEq)]
pub struct Parameter {
    /// Its name, as the robot file and the report spell it (`wheels[2].position.x`).
    pub name: String,
    /// The robot file's value.
    pub prior: f64,
    /// What it measures.
    pub quantity: ParameterQuantity,
}

fn p(name: String, prior: f64, quantity: ParameterQuantity) -> Parameter {
    Parameter {
        name,
        prior,
        quantity,
    }
}

/// The kinematic parameters of `desc` (see the module table), in a fixed order.
pub fn parameters(desc: &RobotDescription) -> Vec<Parameter> {
    use ParameterQuantity::{Angle, Length, Scale};
    let mut out = Vec::new();
    match &desc.geometry {
        Geometry::Omni(wheels) => {
            for (i, w) in wheels.iter().enumerate() {
                let n = i + 1;
                out.push(p(format!("wheels[{n}].radius_scale"), 1.0, Scale));
                out.push(p(format!("wheels[{n}].position.x"), w.position[0], Length));
                out.push(p(format!("wheels[{n}].position.y"), w.position[1], Length));
                let a = w.drive[1].atan2(w.drive[0]);
                out.push(p(format!("wheels[{n}].drive_angle"), a, Angle));
            }
        }
        Geometry::Swerve { modules, .. } => {
            for (i, m) in modules.iter().enumerate() {
                let n = i + 1;
                out.push(p(format!("modules[{n}].radius_scale"), 1.0, Scale));
                out.push(p(format!("modules[{n}].position.x"), m.position[0], Length));
                out.push(p(format!("modules[{n}].position.y"), m.position[1], Length));
            }
        }
        Geometry::Caster(c) => {
            out.push(p("wheel_radius_scale".into(), 1.0, Scale));
            out.push(p("mount_radius".into(), c.mount_radius, Length));
            out.push(p("eccentricity".into(), c.eccentricity, Length));
        }
        Geometry::Sphere(_) => {
            for n in 1..=3 {
                out.push(p(format!("wheels[{n}].radius_scale"), 1.0, Scale));
            }
        }
        Geometry::Ballbot(_) => out.push(p("wheel_radius_scale".into(), 1.0, Scale)),
    }
    out
}

/// `desc` with its geometry set to `values` (one per entry of [`parameters`], same order).
/// Entries past the geometry's parameters are ignored; missing ones keep the prior.
pub fn apply(desc: &RobotDescription, values: &[f64]) -> RobotDescription {
    let mut out = desc.clone();
    let v = |k: usize, prior: f64| values.get(k).copied().unwrap_or(prior);
    match &mut out.geometry {
        Geometry::Omni(wheels) => {
            for (i, w) in wheels.iter_mut().enumerate() {
                let a0 = w.drive[1].atan2(w.drive[0]);
                w.radius *= v(4 * i, 1.0);
                w.position = [v(4 * i + 1, w.position[0]), v(4 * i + 2, w.position[1])];
                let a = v(4 * i + 3, a0);
                w.drive = [a.cos(), a.sin()];
            }
        }
        Geometry::Swerve { modules, .. } => {
            for (i, m) in modules.iter_mut().enumerate() {
                m.wheel_radius *= v(3 * i, 1.0);
                m.position = [v(3 * i + 1, m.position[0]), v(3 * i + 2, m.position[1])];
            }
        }
        Geometry::Caster(c) => {
            c.wheel_radius *= v(0, 1.0);
            c.mount_radius = v(1, c.mount_radius);
            c.eccentricity = v(2, c.eccentricity);
        }
        Geometry::Sphere(s) => {
            for (i, r) in s.wheel_radius.iter_mut().enumerate() {
                *r *= v(i, 1.0);
            }
        }
        Geometry::Ballbot(b) => b.wheel_radius *= v(0, 1.0),
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_priors_rebuild_the_same_robot() {
        for name in [
            "kiwi",
            "x-drive",
            "mecanum",
            "swerve4",
            "caster3",
            "sphere-omni",
            "ballbot",
        ] {
            let d = RobotDescription::preset(name).unwrap();
            let prior: Vec<f64> = parameters(&d).iter().map(|p| p.prior).collect();
            let back = apply(&d, &prior);
            let (a, b) = (format!("{:?}", d.geometry), format!("{:?}", back.geometry));
            // Drive directions are recomputed from their angle: equal to rounding.
            if name != "kiwi" && name != "x-drive" && name != "mecanum" {
                assert_eq!(a, b, "{name}");
            }
            assert!(back.build::<f64>().is_ok(), "{name}");
        }
    }

    #[test]
    fn a_kiwi_wheel_has_four_parameters_and_they_move_it() {
        let d = RobotDescription::preset("kiwi").unwrap();
        let ps = parameters(&d);
        assert_eq!(ps.len(), 12);
        assert_eq!(ps[5].name, "wheels[2].position.x");
        let mut v: Vec<f64> = ps.iter().map(|p| p.prior).collect();
        v[4] = 1.02;
        v[5] += 0.005;
        let Geometry::Omni(w) = apply(&d, &v).geometry else {
            panic!("kiwi is omni")
        };
        assert!((w[1].radius - 0.05 * 1.02).abs() < 1e-15);
        assert!((w[1].position[0] - (-0.075 + 0.005)).abs() < 1e-15);
    }
}
