//! Named floor surfaces (`floor = "linoleum" | "vinyl" | "carpet" | "concrete"` in a
//! `sphere-omni` robot file's `[dynamics]`): the three floor values of [`SphereDynamics`] —
//! pivot (spin) friction, rolling resistance, shell–floor friction coefficient — from one table
//! ([`FloorCoefficients::of`]), with where each number comes from.
//!
//! **Pivot friction** is contact mechanics: the Coulomb spin torque of a Hertz contact,
//! `M = (3π/16) μ N a` (Johnson, *Contact Mechanics*, 1985, §5.6), with the patch radius
//! `a = (3 N R / 4E*)^{1/3}` of a 1.5 mm polycarbonate shell (E 2.3 GPa, ν 0.37, handbook) on
//! the floor's material; docs/sphere-dynamics.md derives every row. The table holds `M` for the
//! paper's robot, the reference load `N₀ = 2.5 kg · 9.81 m/s²` (shell 0.5 kg + platform 2.0 kg)
//! and shell radius `R₀ = 0.15 m`; another robot's torque follows the Hertz scaling
//! `M ∝ N^{4/3} R^{1/3}` (`a ∝ (N R)^{1/3}`), exact at the reference. The carpet row is not a
//! Hertz contact (the pile yields): its patch is estimated from the pile's compression and
//! scaled the same way, an approximation.
//!
//! | surface | pivot friction `M` at `N₀`, `R₀` | source | `C_rr` | `μ_f` |
//! |---|---|---|---|---|
//! | `linoleum` | 0.021 N·m | Hertz, floor E ≈ 50 MPa, ν 0.45 (estimate, same order as vinyl: no source separates them): a 3.56 mm, μ 0.4 → 20.6 mN·m, rounded | 0.005 (estimate) | 0.4 (estimate) |
//! | `vinyl` | 0.021 N·m | the same row (the `sphere-omni` preset's floor) | 0.005 (estimate) | 0.4 (estimate) |
//! | `concrete` | 0.006 N·m | Hertz, E 30 GPa, ν 0.2 (handbook): a 1.04 mm, μ 0.4 | 0.003 (estimate) | 0.4 (estimate) |
//! | `carpet` | 0.12 N·m | estimate: ≈ 1 mm pile compression under the robot, flat patch `a ≈ √(2 R δ)` ≈ 17 mm, μ 0.5 | 0.03 (estimate) | 0.5 (estimate) |
//!
//! Rolling resistance and the friction coefficients are estimates (no source measures a
//! polycarbonate shell on these floors): hard plastic on a hard smooth floor 0.002–0.01 (less
//! on concrete, which indents least), on carpet an order more (the pile is pressed down ahead
//! of the contact, 0.01–0.06); plastic on vinyl, linoleum or concrete μ 0.2–0.6, on carpet
//! 0.3–0.7. The shell slides on the floor when the rolling shell would need more than `μ_f`
//! (a Coulomb slide, reported as a floor-slip event: [`super::SphereDynamics::floor_friction`]).

use omnikin::description::FloorSurface;

/// The reference load of [`FloorCoefficients::of`]'s table, N: the paper's robot,
/// `(0.5 + 2.0) kg · 9.81 m/s²`.
pub const REFERENCE_LOAD_N: f64 = 2.5 * 9.81;

/// The reference shell radius of [`FloorCoefficients::of`]'s table, m (paper 000's robot).
pub const REFERENCE_SHELL_RADIUS_M: f64 = 0.15;

/// The floor values of one surface for one robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloorCoefficients {
    /// Coulomb pivot (spin) friction torque at the floor contact, N·m
    /// ([`SphereDynamics::pivot_friction`](super::SphereDynamics::pivot_friction)).
    pub pivot_friction: f64,
    /// Rolling-resistance coefficient `C_rr`, 1
    /// ([`SphereDynamics::rolling_resistance`](super::SphereDynamics::rolling_resistance)).
    pub rolling_resistance: f64,
    /// Shell–floor friction coefficient `μ_f`, 1
    /// ([`SphereDynamics::floor_friction`](super::SphereDynamics::floor_friction)).
    pub floor_friction: f64,
}

impl FloorCoefficients {
    /// The table's row for `surface` (module doc), at the reference load and radius.
    pub fn reference(surface: FloorSurface) -> Self {
        let (pivot_friction, rolling_resistance, floor_friction) = match surface {
            FloorSurface::Linoleum | FloorSurface::Vinyl => (0.021, 0.005, 0.4),
            FloorSurface::Concrete => (0.006, 0.003, 0.4),
            FloorSurface::Carpet => (0.12, 0.03, 0.5),
        };
        Self {
            pivot_friction,
            rolling_resistance,
            floor_friction,
        }
    }

    /// The floor values of `surface` for a robot of weight `load` (N, `(m_s + m_p) g`) and
    /// shell radius `shell_radius` (m): the table's pivot friction scaled by
    /// `(load/N₀)^{4/3} (shell_radius/R₀)^{1/3}` (Hertz), the other two as tabled. Equal to
    /// [`FloorCoefficients::reference`] at the reference load and radius, bit for bit.
    pub fn of(surface: FloorSurface, load: f64, shell_radius: f64) -> Self {
        let mut c = Self::reference(surface);
        let (n, r) = (
            load / REFERENCE_LOAD_N,
            shell_radius / REFERENCE_SHELL_RADIUS_M,
        );
        if n != 1.0 || r != 1.0 {
            c.pivot_friction *= n.powf(4.0 / 3.0) * r.cbrt();
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_robot_gets_the_table_and_the_hertz_law_scales_it() {
        for s in FloorSurface::ALL {
            let c = FloorCoefficients::of(s, (0.5 + 2.0) * 9.81, 0.15);
            assert_eq!(c, FloorCoefficients::reference(s), "{}", s.name());
        }
        // Hertz: a ∝ (N R)^{1/3}, M = (3π/16) μ N a ∝ N^{4/3} R^{1/3}.
        let c0 = FloorCoefficients::reference(FloorSurface::Vinyl);
        let c = FloorCoefficients::of(FloorSurface::Vinyl, 2.0 * REFERENCE_LOAD_N, 0.15);
        assert!((c.pivot_friction / c0.pivot_friction - 2f64.powf(4.0 / 3.0)).abs() < 1e-12);
        let c = FloorCoefficients::of(FloorSurface::Vinyl, REFERENCE_LOAD_N, 8.0 * 0.15);
        assert!((c.pivot_friction / c0.pivot_friction - 2.0).abs() < 1e-12);
        assert_eq!(c.rolling_resistance, c0.rolling_resistance);
        assert_eq!(c.floor_friction, c0.floor_friction);
    }

    #[test]
    fn the_hertz_rows_match_their_derivation() {
        // (3π/16) μ N a with the patch radius a = (3 N R / 4 E*)^{1/3}, PC shell on the floor.
        let e_star = |e_floor: f64, nu_floor: f64| {
            1.0 / ((1.0 - 0.37f64.powi(2)) / 2.3e9 + (1.0 - nu_floor * nu_floor) / e_floor)
        };
        let m = |e_star: f64| {
            let a = (3.0 * REFERENCE_LOAD_N * 0.15 / (4.0 * e_star)).cbrt();
            3.0 * core::f64::consts::PI / 16.0 * 0.4 * REFERENCE_LOAD_N * a
        };
        let vinyl = m(e_star(50e6, 0.45));
        let concrete = m(e_star(30e9, 0.2));
        // The table rounds to 1 mN·m.
        let t = |s| FloorCoefficients::reference(s).pivot_friction;
        assert!((t(FloorSurface::Vinyl) - vinyl).abs() < 0.5e-3, "{vinyl}");
        assert!(
            (t(FloorSurface::Concrete) - concrete).abs() < 0.5e-3,
            "{concrete}"
        );
    }
}
