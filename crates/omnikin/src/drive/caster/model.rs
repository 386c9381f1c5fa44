//! Building a [`Caster3`] from its geometry, and its constraint matrices: the wheel
//! directions, `M_i`, `N_i`, `J1`, `J2` and `det J2` (paper 003, eqs. (1)–(3)).

use nalgebra::Matrix3;

use super::{Caster3, CasterParams, MIN_MOUNT_SEPARATION, MOUNT_ANGLES, WheelTrig, cs};
use crate::drive::Rot2;
use crate::real::{finite_param, positive};
use crate::{GeometryError, Real};

impl<T: Real> Caster3<T> {
    /// Validates the geometry and builds the model.
    ///
    /// # Errors
    /// * [`GeometryError::NonFinite`] / [`GeometryError::NotPositive`] when `mount_radius` (`D`),
    ///   `eccentricity` (`d`) or `wheel_radius` (`r`) is not finite and `> 0`;
    /// * [`GeometryError::NonFinite`] naming `mount_angles[i]` for a non-finite angle, or naming
    ///   `"mount_radius / wheel_radius"` etc. if a precomputed ratio overflows;
    /// * [`GeometryError::AngleOutOfRange`] with field `"mount_angles"` when two steering axes
    ///   (nearly) coincide: `2|sin((α_i − α_j)/2)| ≤` [`MIN_MOUNT_SEPARATION`].
    pub fn new(params: CasterParams<T>) -> Result<Self, GeometryError> {
        let big_d = positive(params.mount_radius, "mount_radius")?;
        let d = positive(params.eccentricity, "eccentricity")?;
        let r = positive(params.wheel_radius, "wheel_radius")?;
        for (&a, &name) in params.mount_angles.iter().zip(MOUNT_ANGLES.iter()) {
            finite_param(a, name)?;
        }
        let a = params.mount_angles;
        for (i, j) in [(0, 1), (0, 2), (1, 2)] {
            let sep = T::of(2.0) * ((a[i] - a[j]) * T::of(0.5)).sin().abs();
            if sep <= T::of(MIN_MOUNT_SEPARATION) {
                return Err(GeometryError::AngleOutOfRange {
                    field: "mount_angles",
                    value: a[j].to_f64(),
                    rule: "the steering axes F_i = D·(cos α_i, sin α_i) must be distinct: \
                           2|sin((α_i − α_j)/2)| > 1e-6 for every pair of wheels",
                });
            }
        }
        let inv_r = finite_param(T::one() / r, "1 / wheel_radius")?;
        let inv_d = finite_param(T::one() / d, "1 / eccentricity")?;
        let big_d_over_r = finite_param(big_d / r, "mount_radius / wheel_radius")?;
        let big_d_over_d = finite_param(big_d / d, "mount_radius / eccentricity")?;
        let scale = finite_param(big_d + d, "mount_radius + eccentricity")?;
        let mount_cs = [cs(a[0]), cs(a[1]), cs(a[2])];
        let mount_pos = mount_cs.map(|(c, s)| [big_d * c, big_d * s]);
        let mount_mean = [
            (mount_pos[0][0] + mount_pos[1][0] + mount_pos[2][0]) * T::of(1.0 / 3.0),
            (mount_pos[0][1] + mount_pos[1][1] + mount_pos[2][1]) * T::of(1.0 / 3.0),
        ];
        let mount_centred = mount_pos.map(|f| [f[0] - mount_mean[0], f[1] - mount_mean[1]]);
        Ok(Self {
            params,
            inv_r,
            inv_d,
            big_d_over_r,
            big_d_over_d,
            scale,
            min_spread: T::of(1.0e3) * T::EPSILON * scale * scale,
            mount_cs,
            mount_mean,
            mount_centred,
        })
    }

    /// The geometry the model was built from.
    #[inline]
    pub fn params(&self) -> &CasterParams<T> {
        &self.params
    }

    /// World directions of the wheels, `β_i = α_i + θ + γ_i` (rad, not wrapped), for heading `θ`
    /// (rad) and steer angles `γ_i` (rad) (paper 003, §2). Non-finite input gives non-finite
    /// output.
    #[inline]
    pub fn wheel_directions(&self, heading: T, steer: [T; 3]) -> [T; 3] {
        let a = self.params.mount_angles;
        [
            a[0] + heading + steer[0],
            a[1] + heading + steer[1],
            a[2] + heading + steer[2],
        ]
    }

    /// The cosines and sines of `β_i = α_i + θ + γ_i` and `γ_i` for the three wheels, from
    /// the heading's rotation `{cos θ, sin θ}`, the steer angles' `steer_cs[i] = (cos γ_i,
    /// sin γ_i)` and the precomputed `(cos α_i, sin α_i)`, by the angle-addition formulas.
    #[inline(always)]
    pub(super) fn wheel_trig(&self, heading: Rot2<T>, steer_cs: [(T, T); 3]) -> [WheelTrig<T>; 3] {
        let (ct, st) = (heading.cos, heading.sin);
        let wheel = |i: usize| {
            let (cm, sm) = self.mount_cs[i];
            let (cg, sg) = steer_cs[i];
            let (ca, sa) = (cm * ct - sm * st, sm * ct + cm * st);
            WheelTrig {
                cb: ca * cg - sa * sg,
                sb: sa * cg + ca * sg,
                cg,
                sg,
            }
        };
        [wheel(0), wheel(1), wheel(2)]
    }

    /// Row `i` of `J1` (× `1/r`-scaled): `[−cos β_i/r, −sin β_i/r, −(D/r) sin γ_i]`.
    #[inline]
    fn j1_row(&self, beta: T, gamma: T) -> [T; 3] {
        let (c, s) = cs(beta);
        [
            -c * self.inv_r,
            -s * self.inv_r,
            -self.big_d_over_r * gamma.sin(),
        ]
    }

    /// Row `i` of `J2`: `[sin β_i/d, −cos β_i/d, −(D/d) cos γ_i − 1]`.
    #[inline]
    fn j2_row(&self, beta: T, gamma: T) -> [T; 3] {
        let (c, s) = cs(beta);
        [
            s * self.inv_d,
            -c * self.inv_d,
            -self.big_d_over_d * gamma.cos() - T::one(),
        ]
    }

    /// `M_i` (paper 003, eq. (1)): maps wheel `wheel`'s `[φ̇_i; γ̇_i; θ̇]` (rad/s) to the
    /// world-frame `[ẋ; ẏ; θ̇]` (m/s, m/s, rad/s) it implies on its own:
    ///
    /// ```text
    /// M_i = [ −r cos β_i    d sin β_i   D sin(α_i+θ) + d sin β_i ;
    ///         −r sin β_i   −d cos β_i  −D cos(α_i+θ) − d cos β_i ;
    ///          0            0           1 ]
    /// ```
    ///
    /// `wheel` is 0-based (0, 1, 2); `None` when out of range. `heading` = `θ`, `steer` = `γ_i`
    /// (rad). Non-finite input gives a non-finite matrix.
    pub fn m_matrix(&self, wheel: usize, heading: T, steer: T) -> Option<Matrix3<T>> {
        let alpha = *self.params.mount_angles.get(wheel)?;
        let p = &self.params;
        let a = alpha + heading;
        let (ca, sa) = cs(a);
        let (cb, sb) = cs(a + steer);
        let (big_d, d, r) = (p.mount_radius, p.eccentricity, p.wheel_radius);
        Some(Matrix3::new(
            -r * cb,
            d * sb,
            big_d * sa + d * sb,
            -r * sb,
            -d * cb,
            -big_d * ca - d * cb,
            T::zero(),
            T::zero(),
            T::one(),
        ))
    }

    /// `N_i = M_i⁻¹` (paper 003, eq. (2)): maps the world-frame `[ẋ; ẏ; θ̇]` (m/s, m/s, rad/s)
    /// to wheel `wheel`'s `[φ̇_i; γ̇_i; θ̇]` (rad/s):
    ///
    /// ```text
    /// N_i = [ −cos β_i/r   −sin β_i/r   −(D/r) sin γ_i ;
    ///          sin β_i/d   −cos β_i/d   −(D/d) cos γ_i − 1 ;
    ///          0            0            1 ]
    /// ```
    ///
    /// `wheel` is 0-based; `None` when out of range. Non-finite input gives a non-finite matrix.
    pub fn n_matrix(&self, wheel: usize, heading: T, steer: T) -> Option<Matrix3<T>> {
        let alpha = *self.params.mount_angles.get(wheel)?;
        let beta = alpha + heading + steer;
        let a = self.j1_row(beta, steer);
        let b = self.j2_row(beta, steer);
        Some(Matrix3::new(
            a[0],
            a[1],
            a[2],
            b[0],
            b[1],
            b[2],
            T::zero(),
            T::zero(),
            T::one(),
        ))
    }

    /// `J1` (paper 003, eq. (4)): the first rows of `N_1, N_2, N_3` stacked, so that
    /// `φ̇ = J1 q̇` (rad/s from the world-frame `q̇ = [ẋ; ẏ; θ̇]` in m/s, m/s, rad/s).
    pub fn j1(&self, heading: T, steer: [T; 3]) -> Matrix3<T> {
        let beta = self.wheel_directions(heading, steer);
        let r0 = self.j1_row(beta[0], steer[0]);
        let r1 = self.j1_row(beta[1], steer[1]);
        let r2 = self.j1_row(beta[2], steer[2]);
        Matrix3::new(
            r0[0], r0[1], r0[2], r1[0], r1[1], r1[2], r2[0], r2[1], r2[2],
        )
    }

    /// `J2` (paper 003, eq. (5)): the second rows of `N_1, N_2, N_3` stacked, so that
    /// `γ̇ = J2 q̇` (rad/s from the world-frame `q̇`).
    pub fn j2(&self, heading: T, steer: [T; 3]) -> Matrix3<T> {
        let beta = self.wheel_directions(heading, steer);
        let r0 = self.j2_row(beta[0], steer[0]);
        let r1 = self.j2_row(beta[1], steer[1]);
        let r2 = self.j2_row(beta[2], steer[2]);
        Matrix3::new(
            r0[0], r0[1], r0[2], r1[0], r1[1], r1[2], r2[0], r2[1], r2[2],
        )
    }

    /// `det J2` (units 1/m²), paper 003, eq. (6): the base can move with its steering held fixed
    /// only where it vanishes (see [`Caster3::fixed_steer_motion`], which uses a scale-free
    /// version of it).
    pub fn det_j2(&self, heading: T, steer: [T; 3]) -> T {
        self.j2(heading, steer).determinant()
    }
}
