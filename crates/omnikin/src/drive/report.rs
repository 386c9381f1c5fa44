//! # report — what `omnikin check` says about a robot's derived geometry
//!
//! One function per kind writes the quantities a reader checks a robot file against (the
//! paper's derived vectors, the layout's wheels) as text lines to any [`core::fmt::Write`]
//! (no allocation: the firmware could print them on a serial console), and [`Reach`] is the
//! fastest motion a robot's motor limits allow. [`crate::Robot::describe`] and
//! [`crate::Robot::reach`] dispatch to them, so the CLI has no per-kind code.

use core::fmt::{self, Write};

use crate::ballbot::Ballbot;
use crate::caster::Caster3;
use crate::drive::omni::Omni;
use crate::drive::swerve::Swerve;
use crate::sphere::SphereOmni;
use crate::{MAX_CONDITION, Real};

/// The fastest motion within the motor limits (robot frame, no yaw, no shell spin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reach {
    /// Fastest speed, m/s, along the directions 0°, 45°, …, 315° from robot +x.
    pub speed: [f64; 8],
    /// Fastest turn on the spot, rad/s.
    pub yaw_rate: f64,
}

/// The directions of [`Reach::speed`], degrees from robot +x.
pub const REACH_DIRECTIONS_DEG: [f64; 8] = [0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0];

fn deg<T: Real>(x: T) -> f64 {
    x.to_f64().to_degrees()
}

fn v3<T: Real>(v: &nalgebra::Vector3<T>) -> [f64; 3] {
    [v.x.to_f64(), v.y.to_f64(), v.z.to_f64()]
}

/// `(x, y, z)` with the CLI's fixed widths.
struct Vec3([f64; 3]);

impl fmt::Display for Vec3 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "({:>9.5}, {:>9.5}, {:>9.5})",
            self.0[0], self.0[1], self.0[2]
        )
    }
}

/// Paper 000: the geometry, the derived vectors of §4 and the condition number.
pub(crate) fn sphere<T: Real>(m: &SphereOmni<T>, out: &mut dyn Write) -> fmt::Result {
    let p = m.params();
    let r = p.wheel_radius.map(|x| x.to_f64());
    let az = p.azimuths.map(deg);
    writeln!(
        out,
        "geometry: R {} m, R_i {:?} m, tilt δ {:.3}°, roller angle ξ {:.3}°, azimuths φ {:.3?}°",
        p.shell_radius.to_f64(),
        r,
        deg(p.tilt),
        deg(p.roller_angle),
        az
    )?;
    writeln!(out, "derived vectors (platform frame, paper 000 §4):")?;
    for i in 0..3 {
        writeln!(out, "  wheel {}:", i + 1)?;
        writeln!(
            out,
            "    r_i  {} m   (centre → wheel centre)",
            Vec3(v3(&m.wheel_centres()[i]))
        )?;
        writeln!(
            out,
            "    n_i  {}     (wheel axis)",
            Vec3(v3(&m.wheel_axes()[i]))
        )?;
        writeln!(
            out,
            "    α_i  {}     (roller axis)",
            Vec3(v3(&m.roller_axes()[i]))
        )?;
        writeln!(out, "    s_i  {} m   (r_i × α_i)", Vec3(v3(&m.levers()[i])))?;
        writeln!(out, "    s_i·n_i {:.6} m", m.s_dot_n()[i].to_f64())?;
    }
    writeln!(
        out,
        "condition number of [s1; s2; s3] (normalised): {:.4} (max accepted {MAX_CONDITION:.0e})",
        m.condition_number()
    )
}

/// Paper 001: the geometry, contact and drive directions, the torque projection `A(0)`.
pub(crate) fn ballbot<T: Real>(m: &Ballbot<T>, out: &mut dyn Write) -> fmt::Result {
    let p = m.params();
    writeln!(
        out,
        "geometry: ball R_b {} m, wheel r_w {} m, zenith α {:.3}°, azimuths β_i {:.3?}°",
        p.ball_radius.to_f64(),
        p.wheel_radius.to_f64(),
        deg(p.zenith),
        p.azimuths.map(deg)
    )?;
    writeln!(out, "derived vectors (body frame, paper 001):")?;
    let (c, d) = (m.contact_directions(), m.drive_directions());
    for i in 0..3 {
        writeln!(
            out,
            "  wheel {}: contact direction {}   drive direction {}",
            i + 1,
            Vec3(v3(&c[i])),
            Vec3(v3(&d[i]))
        )?;
    }
    let col = |wheel: usize| {
        let mut e = [T::zero(); 3];
        e[wheel] = T::one();
        m.model_torques(e, T::zero())
            .map(|t| t.map(|x| x.to_f64()))
            .unwrap_or([f64::NAN; 3])
    };
    let a0 = [col(0), col(1), col(2)];
    writeln!(
        out,
        "torque projection A(0) (columns = wheels; [Tx,Ty,Tz] = A [T1,T2,T3]):"
    )?;
    for row in 0..3 {
        writeln!(
            out,
            "  {:>10.6} {:>10.6} {:>10.6}",
            a0[0][row], a0[1][row], a0[2][row]
        )?;
    }
    writeln!(
        out,
        "condition number of the contact matrix: {:.4} (max accepted {MAX_CONDITION:.0e})",
        m.condition_number()
    )
}

/// Paper 003: the geometry, steering axes and wheel centres, `det J2` and the turn-in-place
/// singularity.
pub(crate) fn caster<T: Real>(m: &Caster3<T>, out: &mut dyn Write) -> fmt::Result {
    let p = m.params();
    let (big_d, d) = (p.mount_radius.to_f64(), p.eccentricity.to_f64());
    writeln!(
        out,
        "geometry: D {} m, d {} m, r {} m, mounting angles α_i {:.3?}°",
        big_d,
        d,
        p.wheel_radius.to_f64(),
        p.mount_angles.map(deg)
    )?;
    writeln!(
        out,
        "steering axes F_i and wheel centres O_i at γ = 0 (body frame, paper 003 §2):"
    )?;
    for i in 0..3 {
        let (s, c) = p.mount_angles[i].sin_cos();
        let (s, c) = (s.to_f64(), c.to_f64());
        writeln!(
            out,
            "  wheel {}: F ({:>8.4}, {:>8.4}) m   O ({:>8.4}, {:>8.4}) m",
            i + 1,
            big_d * c,
            big_d * s,
            (big_d + d) * c,
            (big_d + d) * s
        )?;
    }
    writeln!(
        out,
        "det J2 at γ = 0: {:.6} (≠ 0: steering must move for the base to move)",
        m.det_j2(T::zero(), [T::zero(); 3]).to_f64()
    )?;
    writeln!(
        out,
        "turn in place is singular where cos γ_1 = −d/D, i.e. γ_1 = ±{:.3}°",
        deg((-p.eccentricity / p.mount_radius).acos())
    )
}

/// The caster's reach in closed form: wheels aligned with the motion roll at `r·max` in every
/// direction; turning in place (wheels tangential) at `r·max/D`, or the steer limit.
pub(crate) fn caster_reach<T: Real>(
    m: &Caster3<T>,
    max_wheel: f64,
    max_steer: Option<f64>,
) -> Reach {
    let p = m.params();
    let v = p.wheel_radius.to_f64() * max_wheel;
    let mut yaw = v / p.mount_radius.to_f64();
    if let Some(s) = max_steer {
        yaw = yaw.min(s);
    }
    Reach {
        speed: [v; 8],
        yaw_rate: yaw,
    }
}

/// An omni/mecanum layout: its wheels and the condition number of its constraint matrix.
pub(crate) fn omni<T: Real, const N: usize>(m: &Omni<T, N>, out: &mut dyn Write) -> fmt::Result {
    writeln!(
        out,
        "geometry: {N} omni/mecanum wheels (robot frame; drive direction and roller angle from +x, CCW):"
    )?;
    for (i, w) in m.wheels().iter().enumerate() {
        writeln!(
            out,
            "  wheel {}: position ({:>8.4}, {:>8.4}) m   drive {:>8.3}°   roller {:>7.3}°   radius {} m",
            i + 1,
            w.position[0].to_f64(),
            w.position[1].to_f64(),
            deg(w.drive[1].atan2(w.drive[0])),
            deg(w.roller_angle),
            w.radius.to_f64()
        )?;
    }
    writeln!(
        out,
        "condition number of the wheel constraints (scaled): {:.4} (max accepted {MAX_CONDITION:.0e})",
        m.condition()
    )
}

/// A swerve layout: its modules, the steering optimisation and the condition number.
pub(crate) fn swerve<T: Real, const N: usize>(
    m: &Swerve<T, N>,
    out: &mut dyn Write,
) -> fmt::Result {
    writeln!(
        out,
        "geometry: {N} centred swerve modules (robot frame), steering optimisation {}:",
        if m.optimizes() { "on" } else { "off" }
    )?;
    for (i, s) in m.modules().iter().enumerate() {
        writeln!(
            out,
            "  module {}: position ({:>8.4}, {:>8.4}) m   wheel radius {} m",
            i + 1,
            s.position[0].to_f64(),
            s.position[1].to_f64(),
            s.wheel_radius.to_f64()
        )?;
    }
    writeln!(
        out,
        "condition number of the module layout (scaled): {:.4} (max accepted {MAX_CONDITION:.0e})",
        m.condition()
    )
}
