//! The physical parameters of the sphere's dynamic model ([`SphereDynamics`]), their defaults
//! for paper 000's robot with where each value comes from, and their validation.

use omnikin::description::{Geometry, MotorModel, RobotDescription, SphereDynamicsSpec};
use omnikin::sphere::SphereParams;

/// A parameter of [`SphereDynamics`] that cannot describe a physical robot, naming the field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DynamicsError {
    /// A field is out of its physical range.
    #[error("dynamics.{field} = {value}: {rule}")]
    Parameter {
        /// The field's name.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What it must satisfy.
        rule: &'static str,
    },
    /// The wheel geometry is rejected by the kinematic model.
    #[error("dynamics.geometry: {0}")]
    Geometry(#[from] omnikin::GeometryError),
    /// The robot description is not of kind `sphere-omni`.
    #[error("the shell + platform dynamics need a sphere-omni robot, not \"{0}\"")]
    Kind(&'static str),
    /// A step input is not usable.
    #[error("{what} = {value}: {rule}")]
    Input {
        /// The input's name.
        what: &'static str,
        /// Its value.
        value: f64,
        /// What it must satisfy.
        rule: &'static str,
    },
}

/// Parameters of the shell + internal platform model (see the [module](super) doc for the
/// equations). SI units; the platform frame is paper 000's `Cxyz` (origin at the shell centre,
/// z up when the platform is level).
///
/// [`SphereDynamics::paper_000`] (also [`Default`]) holds estimates for the robot of paper 000
/// §6; the paper gives only the geometry, so every mass, inertia and friction value is an
/// estimate, stated with its source on the field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereDynamics {
    /// Shell radius and wheel geometry (paper 000 §4, §6; the `sphere-omni` preset).
    pub geometry: SphereParams<f64>,
    /// Shell mass `m_s`, kg. Default 0.5 kg: a 0.3 m polycarbonate/acrylic sphere
    /// (area 4πR² = 0.283 m²) about 1.5 mm thick at 1200 kg/m³.
    pub shell_mass: f64,
    /// Shell moment of inertia `I_s` about its centre (any axis; the shell is taken as
    /// spherically symmetric), kg·m². Default `⅔ m_s R²` = 0.0075 kg·m² (thin shell).
    pub shell_inertia: f64,
    /// Platform mass `m_p`, kg (wheels, motors, electronics, battery, frame). Default 2.0 kg:
    /// three NEMA-17 steppers ≈ 3 × 0.35 kg, three 70 mm omni-wheels ≈ 3 × 0.1 kg, battery
    /// ≈ 0.3 kg, board and frame ≈ 0.35 kg.
    pub platform_mass: f64,
    /// Platform inertia tensor about its centre of mass, platform frame, kg·m² (symmetric,
    /// positive definite). Default diag(0.004, 0.004, 0.006): motors and wheels (1.35 kg) at
    /// ≈ 55 mm from the axis (the wheel centres are at `(R − R_w) sin δ` = 57 mm) give
    /// 0.0041 about z, the rest as a 80 mm disc 0.0021; about x and y half of that plus a
    /// ±20 mm vertical spread.
    pub platform_inertia: [[f64; 3]; 3],
    /// Depth `h` of the platform's centre of mass below the shell centre along the platform's
    /// −z axis, m (the pendulum length). Default 0.08 m: the wheel centres sit
    /// `(R − R_w) cos δ` = 57 mm below the centre, the battery and motors lower; the digest's
    /// plausible value, giving a rocking frequency near 1 Hz.
    pub com_depth: f64,
    /// Stepper pull-out torque, N·m, per motor: beyond it the motor slips (loses steps) and
    /// delivers this torque until its rotor is back at the commanded rate. Default 0.3 N·m (a
    /// 42 mm stepper's pull-out torque at low step rates). `f64::INFINITY` = ideal rate source.
    pub pull_out_torque: f64,
    /// How the motors act: [`MotorModel::Rate`] (default: each imposes its wheel rate up to
    /// `pull_out_torque`, slips at that torque and resynchronises) or [`MotorModel::Stepper`]
    /// (each imposes an angle through a hybrid stepper's torque–angle law, with the pull-out
    /// torque `pull_out_torque` falling above `stepper_corner_speed`, and loses steps past it:
    /// [`super::stepper`]).
    pub motor: MotorModel,
    /// Full steps per revolution of the steppers (a multiple of 4). Default 200: the 1.8°
    /// hybrid stepper of the NEMA 17 class ([`super::stepper`]).
    pub stepper_steps_per_rev: f64,
    /// Speed above which the stepper's pull-out torque falls as 1/speed, rad/s. Default
    /// 50 rad/s: `V/(N_r L I)` for a NEMA 17 of ≈ 2.8 mH, 1.7 A per phase at a 12 V supply
    /// (a derived estimate, range 30–100 rad/s; [`super::stepper`]).
    pub stepper_corner_speed: f64,
    /// Viscous damping of each stepper's rotor against its field, N·m·s/rad. Default 0.01, an
    /// estimate (0–0.04: from a chopper drive's residual to the voltage-driven `k_t²/R`).
    pub stepper_damping: f64,
    /// Coulomb pivot (spin) friction torque at the floor contact, about the vertical, N·m.
    /// Default 0.005 N·m: `(3π/16) μ N a` for the Hertz patch of a polycarbonate shell on a
    /// hard (concrete) floor, a ≈ 1 mm, μ ≈ 0.4, N = M g ≈ 24.5 N. Set from contact mechanics,
    /// not fitted: the `sphere-omni` preset states a vinyl floor, 0.021 N·m (range 0.008–0.042;
    /// the derivation is in docs/sphere-dynamics.md).
    pub pivot_friction: f64,
    /// Velocity scale of the pivot friction's regularisation `τ tanh(Ω3/ε)`, rad/s. Default
    /// 0.005 rad/s (stiffness τ/ε well inside the 1 ms RK4 step's stability region).
    pub pivot_velocity_scale: f64,
    /// Rolling-resistance coefficient `C_rr` (dimensionless; torque `C_rr M g R` opposing the
    /// rolling). Default 0.005 (hard plastic on a hard floor, 0.002–0.01).
    pub rolling_resistance: f64,
    /// Velocity scale of the rolling resistance's regularisation, rad/s (of the shell's
    /// horizontal angular velocity). Default 0.01 rad/s.
    pub rolling_velocity_scale: f64,
    /// Roller–shell friction coefficient μ (dimensionless): a roller force beyond `μ N` (N the
    /// wheel's normal force) makes the roller slide on the shell. Default 0.5: an estimate for
    /// polyurethane (or rubber) rollers on a dry polycarbonate/acrylic shell — handbook dry
    /// values for elastomers on smooth hard plastics lie between about 0.3 and 0.9 (paper 000
    /// names neither material; an estimate, not a measurement). `f64::INFINITY` = rigid
    /// bilateral contacts (never slip, never lift: the model before contacts were added).
    pub roller_friction: f64,
    /// Viscous part of the sliding roller's force, N·s/m (per m/s of slip). Default 1.0 N·s/m,
    /// an estimate (range 0–5): the hysteresis of a soft roller deformed by the slip.
    pub roller_viscous: f64,
    /// Normal preload per wheel, N, added to the normal force that gravity and the platform's
    /// motion give (a spring-loaded support pressing the platform onto the shell). Default 0 N:
    /// paper 000 describes the platform resting on the shell under its own weight.
    pub roller_preload: f64,
    /// Floor friction coefficient μ_f between shell and floor: when the rolling shell would
    /// need a floor force outside the cone `|F_h| ≤ μ_f F_z` it slides, the floor's horizontal
    /// force then being the Coulomb force `μ_f F_z` against the contact point's slip, until the
    /// slip stops (each start is a floor-slip event). Default 0.4: hard plastic on
    /// linoleum/vinyl, an estimate (range 0.2–0.6). `f64::INFINITY` = the shell never slides.
    pub floor_friction: f64,
    /// Gravitational acceleration, m/s². Default 9.81.
    pub gravity: f64,
    /// Height of the tracked point (top of the platform) above the floor contact with the
    /// platform level, m: paper 000 §6 tracked the platform top, 120 mm above the floor.
    /// Default 0.12 m, i.e. `0.12 − R` = −0.03 m along the platform's z axis from the centre.
    pub tracked_height: f64,
    /// Largest integration sub-step, s; each [`super::SphereSim::step`] is split into equal
    /// sub-steps no longer than this. Default 2 ms (5 per step of a 100 Hz plan): paper 000's
    /// eight series agree with a 1 ms sub-step within 0.4 % of each figure at about half the
    /// cost (docs/sphere-dynamics.md); the step-by-step energy-balance tests, which check the
    /// RK4 quadrature of the work against the state's, run at 1 ms.
    pub max_substep: f64,
}

impl Default for SphereDynamics {
    fn default() -> Self {
        Self::paper_000()
    }
}

impl SphereDynamics {
    /// Estimates for the robot of paper 000 §6 (0.3 m shell); see each field.
    pub fn paper_000() -> Self {
        let geometry = SphereParams::preset();
        let r = geometry.shell_radius;
        let shell_mass = 0.5;
        Self {
            geometry,
            shell_mass,
            shell_inertia: 2.0 / 3.0 * shell_mass * r * r,
            platform_mass: 2.0,
            platform_inertia: [[0.004, 0.0, 0.0], [0.0, 0.004, 0.0], [0.0, 0.0, 0.006]],
            com_depth: 0.08,
            pull_out_torque: 0.3,
            motor: MotorModel::Rate,
            stepper_steps_per_rev: 200.0,
            stepper_corner_speed: 50.0,
            stepper_damping: 0.01,
            pivot_friction: 0.005,
            pivot_velocity_scale: 0.005,
            rolling_resistance: 0.005,
            rolling_velocity_scale: 0.01,
            roller_friction: 0.5,
            roller_viscous: 1.0,
            roller_preload: 0.0,
            floor_friction: 0.4,
            gravity: 9.81,
            tracked_height: 0.12,
            max_substep: 2.0e-3,
        }
    }

    /// The parameters of a `sphere-omni` description: its geometry, and its `[dynamics]`
    /// table's values over [`SphereDynamics::paper_000`]'s (an absent `shell_inertia` is
    /// `⅔ m_s R²` of the file's shell; a named `floor` sets the three floor values from
    /// [`super::floor`]'s table, for the file's masses and radius, and the floor values given
    /// explicitly override it: [`floor_note`] says which).
    ///
    /// # Errors
    /// [`DynamicsError::Kind`] for another kind; [`DynamicsError::Parameter`] naming the
    /// field of a combination that is not physical.
    pub fn from_description(robot: &RobotDescription) -> Result<Self, DynamicsError> {
        let Geometry::Sphere(geometry) = robot.geometry else {
            return Err(DynamicsError::Kind(robot.kind()));
        };
        Self::from_spec(geometry, robot.sphere_dynamics.as_ref())
    }

    /// [`SphereDynamics::paper_000`] with `geometry` and the given values of `spec` (see
    /// [`SphereDynamics::from_description`]).
    ///
    /// # Errors
    /// [`DynamicsError`] naming the first invalid field.
    pub fn from_spec(
        geometry: SphereParams<f64>,
        spec: Option<&SphereDynamicsSpec>,
    ) -> Result<Self, DynamicsError> {
        let mut p = Self::paper_000();
        p.geometry = geometry;
        let r = geometry.shell_radius;
        if let Some(s) = spec {
            let set = |dst: &mut f64, v: Option<f64>| {
                if let Some(v) = v {
                    *dst = v;
                }
            };
            set(&mut p.shell_mass, s.shell_mass);
            p.shell_inertia = s.shell_inertia.unwrap_or(2.0 / 3.0 * p.shell_mass * r * r);
            set(&mut p.platform_mass, s.platform_mass);
            if let Some([a, b, c]) = s.platform_moments() {
                p.platform_inertia = [[a, 0.0, 0.0], [0.0, b, 0.0], [0.0, 0.0, c]];
            }
            set(&mut p.com_depth, s.com_depth);
            set(&mut p.pull_out_torque, s.pull_out_torque);
            if let Some(m) = s.motor {
                p.motor = m;
            }
            set(&mut p.stepper_steps_per_rev, s.stepper_steps_per_rev);
            set(&mut p.stepper_corner_speed, s.stepper_corner_speed);
            set(&mut p.stepper_damping, s.stepper_damping);
            // A named floor first; the floor values given explicitly then override it.
            if let Some(surface) = s.floor {
                let c = super::floor::FloorCoefficients::of(surface, p.total_mass() * p.gravity, r);
                p.pivot_friction = c.pivot_friction;
                p.rolling_resistance = c.rolling_resistance;
                p.floor_friction = c.floor_friction;
            }
            set(&mut p.pivot_friction, s.pivot_friction);
            set(&mut p.pivot_velocity_scale, s.pivot_velocity_scale);
            set(&mut p.rolling_resistance, s.rolling_resistance);
            set(&mut p.rolling_velocity_scale, s.rolling_velocity_scale);
            set(&mut p.tracked_height, s.tracked_height);
            set(&mut p.roller_friction, s.roller_friction);
            set(&mut p.roller_viscous, s.roller_viscous);
            set(&mut p.roller_preload, s.roller_preload);
            set(&mut p.floor_friction, s.floor_friction);
        } else {
            p.shell_inertia = 2.0 / 3.0 * p.shell_mass * r * r;
        }
        p.validate()?;
        Ok(p)
    }

    /// The same robot with every dissipation off (no pivot friction, no rolling resistance)
    /// and ideal motors (infinite pull-out torque): the conservative model the tests check.
    pub fn frictionless(mut self) -> Self {
        self.pivot_friction = 0.0;
        self.rolling_resistance = 0.0;
        self.pull_out_torque = f64::INFINITY;
        self.motor = MotorModel::Rate;
        self.rigid_contacts().rigid_floor()
    }

    /// The same robot with rigid roller contacts and a floor the shell never slides on
    /// (`roller_friction` and `floor_friction` infinite): every slip switched off.
    pub fn no_slip(self) -> Self {
        self.rigid_contacts().rigid_floor()
    }

    /// The same robot on a floor the shell never slides on (`floor_friction` infinite): it
    /// rolls whatever horizontal force that takes.
    pub fn rigid_floor(mut self) -> Self {
        self.floor_friction = f64::INFINITY;
        self
    }

    /// The same robot with rigid bilateral roller contacts (`roller_friction` infinite): the
    /// rollers never slide and never lift, whatever force the motion needs.
    pub fn rigid_contacts(mut self) -> Self {
        self.roller_friction = f64::INFINITY;
        self
    }

    /// Total mass `M = m_s + m_p`, kg.
    pub fn total_mass(&self) -> f64 {
        self.shell_mass + self.platform_mass
    }

    /// Small-oscillation (rocking) angular frequency about the floor contact with the wheels
    /// held (shell and platform one rigid body), rad/s, for a rocking axis `axis` (0 = x,
    /// 1 = y of the platform):
    /// `ω² = m_p g h / (I_s + m_s R² + I_p + m_p (R − h)²)`.
    pub fn rocking_frequency(&self, axis: usize) -> f64 {
        let r = self.geometry.shell_radius;
        let (mp, h) = (self.platform_mass, self.com_depth);
        let ip = self.platform_inertia[axis][axis];
        let den = self.shell_inertia + self.shell_mass * r * r + ip + mp * (r - h) * (r - h);
        (mp * self.gravity * h / den).sqrt()
    }

    /// Checks every field, naming the first bad one.
    ///
    /// # Errors
    /// [`DynamicsError::Parameter`] for a non-finite, negative or non-physical value (a
    /// centre of mass outside the shell, an inertia tensor that is not symmetric positive
    /// definite or violates the triangle inequality, a tracked point outside the shell).
    pub fn validate(&self) -> Result<(), DynamicsError> {
        let r = self.geometry.shell_radius;
        positive("shell_mass", self.shell_mass)?;
        positive("shell_inertia", self.shell_inertia)?;
        if self.shell_inertia > self.shell_mass * r * r * (1.0 + 1e-12) {
            return Err(bad(
                "shell_inertia",
                self.shell_inertia,
                "at most m_s R² (all mass on the shell's surface: a thin shell has ⅔ m_s R²)",
            ));
        }
        positive("platform_mass", self.platform_mass)?;
        let j = &self.platform_inertia;
        const NAMES: [[&str; 3]; 3] = [
            [
                "platform_inertia[0][0]",
                "platform_inertia[0][1]",
                "platform_inertia[0][2]",
            ],
            [
                "platform_inertia[1][0]",
                "platform_inertia[1][1]",
                "platform_inertia[1][2]",
            ],
            [
                "platform_inertia[2][0]",
                "platform_inertia[2][1]",
                "platform_inertia[2][2]",
            ],
        ];
        for a in 0..3 {
            for b in 0..3 {
                finite(NAMES[a][b], j[a][b])?;
                if (j[a][b] - j[b][a]).abs() > 1e-12 * (1.0 + j[a][b].abs()) {
                    return Err(bad(
                        NAMES[a][b],
                        j[a][b],
                        "the inertia tensor must be symmetric",
                    ));
                }
            }
            positive(NAMES[a][a], j[a][a])?;
        }
        let m = omnikin::nalgebra::Matrix3::from_fn(|a, b| j[a][b]);
        let eig = m.symmetric_eigenvalues();
        let (e0, e1, e2) = (eig[0], eig[1], eig[2]);
        if eig.min() <= 0.0 {
            return Err(bad(
                "platform_inertia",
                eig.min(),
                "must be positive definite (smallest eigenvalue shown)",
            ));
        }
        let tol = 1e-12 * (e0 + e1 + e2);
        if e0 > e1 + e2 + tol || e1 > e0 + e2 + tol || e2 > e0 + e1 + tol {
            return Err(bad(
                "platform_inertia",
                eig.max(),
                "principal moments must satisfy the triangle inequality (largest shown)",
            ));
        }
        nonneg("com_depth", self.com_depth)?;
        if self.com_depth >= r {
            return Err(bad(
                "com_depth",
                self.com_depth,
                "the platform's centre of mass must lie inside the shell (h < R)",
            ));
        }
        if self.pull_out_torque.is_nan() || self.pull_out_torque <= 0.0 {
            return Err(bad(
                "pull_out_torque",
                self.pull_out_torque,
                "must be positive (f64::INFINITY for an ideal rate source)",
            ));
        }
        if self.motor == MotorModel::Stepper && !self.pull_out_torque.is_finite() {
            return Err(bad(
                "pull_out_torque",
                self.pull_out_torque,
                "must be finite for motor = \"stepper\" (a stepper's torque is bounded)",
            ));
        }
        let n = self.stepper_steps_per_rev;
        if !(n.is_finite() && n >= 4.0 && n % 4.0 == 0.0) {
            return Err(bad(
                "stepper_steps_per_rev",
                n,
                "must be a positive multiple of 4 (full steps per revolution of a two-phase motor)",
            ));
        }
        positive("stepper_corner_speed", self.stepper_corner_speed)?;
        nonneg("stepper_damping", self.stepper_damping)?;
        nonneg("pivot_friction", self.pivot_friction)?;
        positive("pivot_velocity_scale", self.pivot_velocity_scale)?;
        nonneg("rolling_resistance", self.rolling_resistance)?;
        positive("rolling_velocity_scale", self.rolling_velocity_scale)?;
        if self.roller_friction.is_nan() || self.roller_friction <= 0.0 {
            return Err(bad(
                "roller_friction",
                self.roller_friction,
                "must be positive (f64::INFINITY for rigid contacts)",
            ));
        }
        nonneg("roller_viscous", self.roller_viscous)?;
        nonneg("roller_preload", self.roller_preload)?;
        if self.floor_friction.is_nan() || self.floor_friction <= 0.0 {
            return Err(bad(
                "floor_friction",
                self.floor_friction,
                "must be positive (f64::INFINITY for a floor the shell never slides on)",
            ));
        }
        positive("gravity", self.gravity)?;
        finite("tracked_height", self.tracked_height)?;
        if !(0.0..=2.0 * r).contains(&self.tracked_height) {
            return Err(bad(
                "tracked_height",
                self.tracked_height,
                "must lie inside the shell (0 ≤ height ≤ 2R above the floor contact)",
            ));
        }
        positive("max_substep", self.max_substep)?;
        if self.max_substep > 0.01 {
            return Err(bad(
                "max_substep",
                self.max_substep,
                "at most 0.01 s (the friction regularisation and the rocking need a fine step)",
            ));
        }
        Ok(())
    }
}

fn bad(field: &'static str, value: f64, rule: &'static str) -> DynamicsError {
    DynamicsError::Parameter { field, value, rule }
}

fn finite(field: &'static str, v: f64) -> Result<f64, DynamicsError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(bad(field, v, "must be finite"))
    }
}

fn positive(field: &'static str, v: f64) -> Result<f64, DynamicsError> {
    if finite(field, v)? > 0.0 {
        Ok(v)
    } else {
        Err(bad(field, v, "must be positive"))
    }
}

fn nonneg(field: &'static str, v: f64) -> Result<f64, DynamicsError> {
    if finite(field, v)? >= 0.0 {
        Ok(v)
    } else {
        Err(bad(field, v, "must be non-negative"))
    }
}

/// [`floor_note`] only when the file overrides some of its named floor's values (what every
/// command says before it runs the dynamic plant: an override is worth a line, a plain named
/// floor is not).
pub fn floor_override_note(robot: &RobotDescription, params: &SphereDynamics) -> Option<String> {
    let overrides = robot
        .sphere_dynamics
        .as_ref()
        .is_some_and(|s| !s.floor_overrides().is_empty());
    if overrides {
        floor_note(robot, params)
    } else {
        None
    }
}

/// What a robot file's named floor gave, for the commands to print: `None` without
/// `floor = …` in `[dynamics]`; otherwise the surface's three values for this robot and the
/// explicitly given keys that override them (`robot`'s parameters are `params`, from
/// [`SphereDynamics::from_description`]).
pub fn floor_note(robot: &RobotDescription, params: &SphereDynamics) -> Option<String> {
    let spec = robot.sphere_dynamics.as_ref()?;
    let surface = spec.floor?;
    let c = super::floor::FloorCoefficients::of(
        surface,
        params.total_mass() * params.gravity,
        params.geometry.shell_radius,
    );
    let overrides: Vec<String> = spec
        .floor_overrides()
        .into_iter()
        .map(|k| {
            let (given, table) = match k {
                "pivot_friction" => (params.pivot_friction, c.pivot_friction),
                "rolling_resistance" => (params.rolling_resistance, c.rolling_resistance),
                _ => (params.floor_friction, c.floor_friction),
            };
            format!("{k} = {given} (the surface's {table})")
        })
        .collect();
    let base = format!(
        "dynamics.floor = \"{}\": pivot_friction {} N m, rolling_resistance {}, floor_friction {}",
        surface.name(),
        c.pivot_friction,
        c.rolling_resistance,
        c.floor_friction
    );
    Some(if overrides.is_empty() {
        base
    } else {
        format!(
            "{base}; overridden by the values given in [dynamics]: {}",
            overrides.join(", ")
        )
    })
}
