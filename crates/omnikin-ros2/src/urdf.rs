//! The robot file as a URDF (`omnikin urdf ROBOT`).
//!
//! `base_link` is the robot frame of `conventions.md` on the floor (REP-105; odometry is
//! planar, so `odom → base_link` has z = 0). Each wheel is a `continuous` joint whose axis is
//! the wheel's spin axis with the sign of omnikin's wheel rates (a positive rate is a
//! right-handed spin about the axis), placed at the wheel centre:
//!
//! | kind | wheel centre | wheel axis (robot frame) | steering |
//! |---|---|---|---|
//! | omni, mecanum | `(p_x, p_y, r)` | `ẑ × d_i = (−d_y, d_x, 0)`: a positive rate rolls the wheel along its drive direction `d_i` | — |
//! | swerve | steer frame origin `(p_x, p_y, r)` | `+y` of the steer frame (rolling along its `+x` at steer angle 0) | `steer_i` about `+z` at the module |
//! | caster3 | `(d, 0, 0)` in the steer frame at `F_i = D(cos α_i, sin α_i)`, `r` up, yawed by `α_i` | `−y` of the steer frame: `v_Oi = −r φ̇_i (cos β_i, sin β_i)` (paper 003) | `steer_i` about `+z`; angle 0 = wheel radially outward |
//! | sphere-omni | `r_i = (R − R_i)(sin δ cos φ_i, sin δ sin φ_i, −cos δ)` from the shell centre | `n_i = (cos δ cos φ_i, cos δ sin φ_i, sin δ)` (paper 000, digest) | — |
//! | ballbot | `(R_b + r_w) n_i`, `n_i = (sin α cos β_i, sin α sin β_i, cos α)` from the ball centre | `(cos α cos β_i, cos α sin β_i, −sin α)`: the rate law of `conventions.md` | — |
//!
//! The ballbot's axis sign follows from the rate law: with the wheel centre outside the ball
//! along `n_i` and the rim moving along `t_i = (−sin β_i, cos β_i, 0)`, equal contact
//! velocities along `t_i` give `ψ̇_i = −(R_b/r_w) ω·(n_i × t_i) / ((a × n_i)·t_i)`, which is the
//! convention's `(R_b/r_w)(n_i × t_i)·ω` for `a = −(n_i × t_i)`.
//!
//! What a URDF cannot hold: the sphere's shell rolls freely about the platform and the
//! ballbot's body leans on its ball; both are drawn upright and fixed (`shell`, `ball` links
//! by `fixed` joints), which is what `robot_state_publisher` needs to place the wheels.

use core::fmt::Write as _;

use omnikin::description::{Geometry, RobotDescription};

/// Width of a drawn wheel (a cylinder along its axis), m: only for the picture.
const WHEEL_WIDTH: f64 = 0.02;

/// One joint of the URDF, as the tests and the writer see it.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    /// `wheel_i`, `steer_i`, or a fixed joint's name.
    pub name: String,
    /// `continuous` or `fixed`.
    pub kind: &'static str,
    /// Parent link.
    pub parent: String,
    /// Child link.
    pub child: String,
    /// Origin in the parent frame, m.
    pub xyz: [f64; 3],
    /// Origin rotation (roll, pitch, yaw), rad.
    pub rpy: [f64; 3],
    /// Axis in the joint frame (unit), for continuous joints.
    pub axis: [f64; 3],
}

/// A link's picture: a cylinder (radius, length along the given axis) or a sphere.
#[derive(Clone, Debug, PartialEq)]
enum Shape {
    Cylinder {
        radius: f64,
        length: f64,
        axis: [f64; 3],
    },
    Sphere {
        radius: f64,
    },
}

/// The robot as links and joints, before it is written.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The robot's name (`name` of the robot file).
    pub name: String,
    /// Links with an optional picture, `base_link` first.
    links: Vec<(String, Option<Shape>)>,
    /// Joints in the order written.
    pub joints: Vec<Joint>,
}

fn continuous(name: String, parent: &str, xyz: [f64; 3], rpy: [f64; 3], axis: [f64; 3]) -> Joint {
    Joint {
        child: format!("{name}_link"),
        name,
        kind: "continuous",
        parent: parent.to_string(),
        xyz,
        rpy,
        axis,
    }
}

fn fixed(name: &str, parent: &str, child: &str, xyz: [f64; 3]) -> Joint {
    Joint {
        name: name.to_string(),
        kind: "fixed",
        parent: parent.to_string(),
        child: child.to_string(),
        xyz,
        rpy: [0.0; 3],
        axis: [0.0, 0.0, 1.0],
    }
}

fn wheel_shape(radius: f64, axis: [f64; 3]) -> Option<Shape> {
    Some(Shape::Cylinder {
        radius,
        length: WHEEL_WIDTH,
        axis,
    })
}

impl Model {
    /// The URDF model of `d` (see the module docs for each kind's joints).
    pub fn of(d: &RobotDescription) -> Self {
        let mut links: Vec<(String, Option<Shape>)> = vec![("base_link".into(), None)];
        let mut joints = Vec::new();
        match &d.geometry {
            Geometry::Omni(wheels) => {
                for (i, w) in wheels.iter().enumerate() {
                    let n = d_norm(w.drive);
                    let axis = [-n[1], n[0], 0.0];
                    let j = continuous(
                        format!("wheel_{}", i + 1),
                        "base_link",
                        [w.position[0], w.position[1], w.radius],
                        [0.0; 3],
                        axis,
                    );
                    links.push((j.child.clone(), wheel_shape(w.radius, axis)));
                    joints.push(j);
                }
            }
            Geometry::Swerve { modules, .. } => {
                for (i, m) in modules.iter().enumerate() {
                    let s = continuous(
                        format!("steer_{}", i + 1),
                        "base_link",
                        [m.position[0], m.position[1], m.wheel_radius],
                        [0.0; 3],
                        [0.0, 0.0, 1.0],
                    );
                    let w = continuous(
                        format!("wheel_{}", i + 1),
                        &s.child,
                        [0.0; 3],
                        [0.0; 3],
                        [0.0, 1.0, 0.0],
                    );
                    links.push((s.child.clone(), None));
                    links.push((
                        w.child.clone(),
                        wheel_shape(m.wheel_radius, [0.0, 1.0, 0.0]),
                    ));
                    joints.push(s);
                    joints.push(w);
                }
            }
            Geometry::Caster(p) => {
                for (i, &a) in p.mount_angles.iter().enumerate() {
                    let s = continuous(
                        format!("steer_{}", i + 1),
                        "base_link",
                        [
                            p.mount_radius * a.cos(),
                            p.mount_radius * a.sin(),
                            p.wheel_radius,
                        ],
                        [0.0, 0.0, a],
                        [0.0, 0.0, 1.0],
                    );
                    let w = continuous(
                        format!("wheel_{}", i + 1),
                        &s.child,
                        [p.eccentricity, 0.0, 0.0],
                        [0.0; 3],
                        [0.0, -1.0, 0.0],
                    );
                    links.push((s.child.clone(), None));
                    links.push((
                        w.child.clone(),
                        wheel_shape(p.wheel_radius, [0.0, -1.0, 0.0]),
                    ));
                    joints.push(s);
                    joints.push(w);
                }
            }
            Geometry::Sphere(p) => {
                let r = p.shell_radius;
                links.push(("platform".into(), None));
                links.push(("shell".into(), Some(Shape::Sphere { radius: r })));
                joints.push(fixed(
                    "platform_joint",
                    "base_link",
                    "platform",
                    [0.0, 0.0, r],
                ));
                joints.push(fixed("shell_joint", "platform", "shell", [0.0; 3]));
                let (sd, cd) = p.tilt.sin_cos();
                for (i, &phi) in p.azimuths.iter().enumerate() {
                    let (sp, cp) = phi.sin_cos();
                    let l = r - p.wheel_radius[i];
                    let axis = [cd * cp, cd * sp, sd];
                    let j = continuous(
                        format!("wheel_{}", i + 1),
                        "platform",
                        [l * sd * cp, l * sd * sp, -l * cd],
                        [0.0; 3],
                        axis,
                    );
                    links.push((j.child.clone(), wheel_shape(p.wheel_radius[i], axis)));
                    joints.push(j);
                }
            }
            Geometry::Ballbot(p) => {
                let r = p.ball_radius;
                links.push(("ball".into(), Some(Shape::Sphere { radius: r })));
                links.push(("body".into(), None));
                joints.push(fixed("ball_joint", "base_link", "ball", [0.0, 0.0, r]));
                joints.push(fixed("body_joint", "ball", "body", [0.0; 3]));
                let (sa, ca) = p.zenith.sin_cos();
                for (i, &b) in p.azimuths.iter().enumerate() {
                    let (sb, cb) = b.sin_cos();
                    let l = r + p.wheel_radius;
                    let axis = [ca * cb, ca * sb, -sa];
                    let j = continuous(
                        format!("wheel_{}", i + 1),
                        "body",
                        [l * sa * cb, l * sa * sb, l * ca],
                        [0.0; 3],
                        axis,
                    );
                    links.push((j.child.clone(), wheel_shape(p.wheel_radius, axis)));
                    joints.push(j);
                }
            }
        }
        Self {
            name: d.name.clone(),
            links,
            joints,
        }
    }

    /// The URDF document (UTF-8 XML), with a comment naming `d`'s source.
    pub fn to_xml(&self, source: &str) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "<?xml version=\"1.0\"?>");
        let _ = writeln!(
            s,
            "<!-- {} by omnikin urdf (omnikin-ros2 {}); conventions.md, \"ROS 2\" -->",
            xml_escape(source),
            env!("CARGO_PKG_VERSION")
        );
        let _ = writeln!(s, "<robot name=\"{}\">", xml_escape(&self.name));
        for (name, shape) in &self.links {
            match shape {
                None => {
                    let _ = writeln!(s, "  <link name=\"{name}\"/>");
                }
                Some(shape) => {
                    let _ = writeln!(s, "  <link name=\"{name}\">\n    <visual>");
                    match shape {
                        Shape::Cylinder {
                            radius,
                            length,
                            axis,
                        } => {
                            // The cylinder's z along the axis: R = Rz(yaw) Ry(pitch).
                            let yaw = axis[1].atan2(axis[0]);
                            let pitch = axis[0].hypot(axis[1]).atan2(axis[2]);
                            let _ = writeln!(
                                s,
                                "      <origin xyz=\"0 0 0\" rpy=\"0 {} {}\"/>\n      \
                                 <geometry><cylinder radius=\"{}\" length=\"{}\"/></geometry>",
                                f(pitch),
                                f(yaw),
                                f(*radius),
                                f(*length)
                            );
                        }
                        Shape::Sphere { radius } => {
                            let _ = writeln!(
                                s,
                                "      <geometry><sphere radius=\"{}\"/></geometry>",
                                f(*radius)
                            );
                        }
                    }
                    let _ = writeln!(s, "    </visual>\n  </link>");
                }
            }
        }
        for j in &self.joints {
            let _ = writeln!(s, "  <joint name=\"{}\" type=\"{}\">", j.name, j.kind);
            let _ = writeln!(s, "    <parent link=\"{}\"/>", j.parent);
            let _ = writeln!(s, "    <child link=\"{}\"/>", j.child);
            let _ = writeln!(
                s,
                "    <origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/>",
                f(j.xyz[0]),
                f(j.xyz[1]),
                f(j.xyz[2]),
                f(j.rpy[0]),
                f(j.rpy[1]),
                f(j.rpy[2])
            );
            if j.kind == "continuous" {
                let _ = writeln!(
                    s,
                    "    <axis xyz=\"{} {} {}\"/>",
                    f(j.axis[0]),
                    f(j.axis[1]),
                    f(j.axis[2])
                );
            }
            let _ = writeln!(s, "  </joint>");
        }
        let _ = writeln!(s, "</robot>");
        s
    }
}

/// `v / |v|` (a robot file's drive direction is validated non-zero).
fn d_norm(v: [f64; 2]) -> [f64; 2] {
    let n = v[0].hypot(v[1]);
    [v[0] / n, v[1] / n]
}

/// A number as the URDF writes it: shortest round-trip form; below 1e-15 in magnitude (the
/// rounding of `cos 90°`, `-0`) as `0`.
fn f(v: f64) -> String {
    if v.abs() < 1e-15 {
        "0".into()
    } else {
        format!("{v}")
    }
}

/// `&`, `<`, `>`, `"` escaped, and `--` broken up (it may not appear in an XML comment).
fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace("--", "-&#45;")
}

#[cfg(test)]
mod tests {
    use omnikin::description::PRESETS;

    use super::*;

    /// Rolls each wheel of the omni presets by a small positive angle and checks that the
    /// contact-free wheel centre moves along the drive direction: `ω a × (−r ẑ)` is the rim's
    /// velocity at the floor relative to the centre, so the centre moves by `−` that.
    #[test]
    fn a_positive_wheel_rate_rolls_an_omni_wheel_along_its_drive_direction() {
        for name in ["kiwi", "x-drive", "mecanum"] {
            let d = RobotDescription::preset(name).unwrap();
            let Geometry::Omni(wheels) = &d.geometry else {
                panic!("{name}")
            };
            let m = Model::of(&d);
            for (w, j) in wheels.iter().zip(&m.joints) {
                let a = j.axis;
                // centre velocity per unit rate = r (a × ẑ)
                let v = [a[1] * w.radius, -a[0] * w.radius];
                let dir = d_norm(w.drive);
                let along = (v[0] * dir[0] + v[1] * dir[1]) / w.radius;
                assert!((along - 1.0).abs() < 1e-12, "{name} {}: {along}", j.name);
                assert!((j.xyz[2] - w.radius).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn every_preset_has_one_wheel_joint_per_wheel_and_a_well_formed_document() {
        for (name, _) in PRESETS {
            let d = RobotDescription::preset(name).unwrap();
            let m = Model::of(&d);
            let wheels = m
                .joints
                .iter()
                .filter(|j| j.name.starts_with("wheel_"))
                .count();
            let expected = match &d.geometry {
                Geometry::Omni(w) => w.len(),
                Geometry::Swerve { modules, .. } => modules.len(),
                _ => 3,
            };
            assert_eq!(wheels, expected, "{name}");
            for j in &m.joints {
                let n = (j.axis[0].powi(2) + j.axis[1].powi(2) + j.axis[2].powi(2)).sqrt();
                assert!((n - 1.0).abs() < 1e-12, "{name} {}: |axis| {n}", j.name);
            }
            let xml = m.to_xml(&d.source_name);
            assert_eq!(xml.matches("<joint ").count(), m.joints.len());
            assert_eq!(
                xml.matches("<joint ").count(),
                xml.matches("</joint>").count()
            );
            assert!(xml.ends_with("</robot>\n"));
        }
    }

    #[test]
    fn the_ballbot_axis_gives_the_conventions_rate_law() {
        // ψ̇ from contact velocities with the written axis equals (R/r)(n × t)·ω.
        let d = RobotDescription::preset("ballbot").unwrap();
        let Geometry::Ballbot(p) = &d.geometry else {
            panic!()
        };
        let m = Model::of(&d);
        let omega = [0.3, -0.7, 0.2];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        for (i, &b) in p.azimuths.iter().enumerate() {
            let (sa, ca) = p.zenith.sin_cos();
            let n = [sa * b.cos(), sa * b.sin(), ca];
            let t = [-b.sin(), b.cos(), 0.0];
            let a = m.joints[2 + i].axis;
            // Ball surface velocity along t equals the rim's: R (ω × n)·t = −r ψ̇ (a × n)·t.
            let rate =
                -p.ball_radius * dot(cross(omega, n), t) / (p.wheel_radius * dot(cross(a, n), t));
            let law = (p.ball_radius / p.wheel_radius)
                * (-ca * b.cos() * omega[0] - ca * b.sin() * omega[1] + sa * omega[2]);
            assert!(
                (rate - law).abs() < 1e-12,
                "wheel {}: {rate} vs {law}",
                i + 1
            );
        }
    }
}
