//! Planar paths parametrised by arc length `s` (m): straight segments, circular arcs, full
//! circles and quintic splines, chained into one [`Path`].
//!
//! A path is purely geometric — where the robot's centre goes, not when. Every primitive answers
//! the same question at arc length `s`: the world-frame point `r_C(s)` (m), the unit tangent
//! `dr_C/ds` and the signed curvature `κ(s)` (1/m, positive turning counter-clockwise). The
//! planner ([`crate::planner`]) adds a heading law and a timing `s(t)` to obtain the trajectory
//! `r_C(t)` of paper 000, §5.
//!
//! Besides its geometry a path carries **stops**: arc lengths where the robot must be at rest
//! (the corners of a polyline planned with [`Corners::Stop`], as in paper 000's square,
//! eq. 6.1).

use crate::PlanningError;
use crate::heading::Side;

/// A point of a path: position, direction and curvature at one arc length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathPoint {
    /// World-frame position `r_C(s) = (x, y)`, m.
    pub point: [f64; 2],
    /// Unit tangent `dr_C/ds` (world frame, dimensionless): the direction of travel.
    pub tangent: [f64; 2],
    /// Signed curvature `κ = dφ/ds`, 1/m (`φ` the tangent's angle; > 0 turning
    /// counter-clockwise, 0 on straight segments).
    pub curvature: f64,
}

impl PathPoint {
    /// Direction of travel `atan2(t_y, t_x)` in (−π, π], rad (the heading of paper 000,
    /// eq. 5.5, before unwrapping).
    pub fn direction(&self) -> f64 {
        self.tangent[1].atan2(self.tangent[0])
    }
}

/// What a polyline does at a corner (a waypoint where the direction changes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Corners {
    /// Straight legs with a full stop at every corner (paper 000's square, eq. 6.1). Waypoints
    /// where the direction does not change are passed without stopping.
    Stop,
    /// Each corner is rounded by a circular fillet of this radius (m), tangent to both legs, so
    /// the robot need not stop. The curvature jumps from 0 to `1/radius` where a fillet meets a
    /// leg: with a heading law that follows the curvature (tangent heading) the wheel rates jump
    /// there too, and the planner stops the robot at those points (use [`Path::spline`] for a
    /// path with continuous curvature).
    Fillet {
        /// Fillet radius, m (> 0).
        radius: f64,
    },
}

/// Points per quintic segment in the arc-length lookup table.
const TABLE: usize = 16;
/// 5-point Gauss–Legendre nodes on [0, 1] and weights (the tests' reference quadrature).
#[cfg(test)]
const GL_X: [f64; 5] = [
    0.046_910_077_030_668,
    0.230_765_344_947_158,
    0.5,
    0.769_234_655_052_842,
    0.953_089_922_969_332,
];
#[cfg(test)]
const GL_W: [f64; 5] = [
    0.118_463_442_528_095,
    0.239_314_335_249_683,
    0.284_444_444_444_444,
    0.239_314_335_249_683,
    0.118_463_442_528_095,
];

/// Weights of the two-point Hermite rule with a midpoint on [0, 1]: end values, end first
/// derivatives (difference), end second derivatives and the midpoint value
/// (`19/70, 1/35, 1/840, 16/35`; exact for polynomials of degree 7).
const MID_W: [f64; 4] = [19.0 / 70.0, 1.0 / 35.0, 1.0 / 840.0, 16.0 / 35.0];

/// One quintic polynomial segment `p(u) = Σ c_k u^k`, `u ∈ [0, 1]`, with its arc-length table.
#[derive(Clone, Debug, PartialEq)]
struct Quintic {
    /// Coefficients `c_0..c_5` for x and y.
    c: [[f64; 2]; 6],
    /// Coefficients of `dp/du = Σ d_k u^k`, `d_k = (k + 1) c_{k+1}`, `k = 0..4` (precomputed:
    /// the speed `|dp/du|` is the inner loop of the arc-length table).
    dc: [[f64; 2]; 5],
    /// Coefficients of `d²p/du² = Σ f_k u^k`, `f_k = (k + 1) d_{k+1}`, `k = 0..3`.
    ddc: [[f64; 2]; 4],
    /// `cum[k]` = arc length from `u = 0` to `u = k/TABLE`, m.
    cum: [f64; TABLE + 1],
    /// Per table cell `k`: the inverse `u(s)` on the cell as a septic in
    /// `t = (s − cum[k]) / (cum[k+1] − cum[k])` (coefficients 0–7, see [`Quintic::u_at`]), and
    /// `1 / (cum[k+1] − cum[k])` (entry 8; 0 for an empty cell).
    inv: [[f64; 9]; TABLE],
    /// Smallest `|dp/du|` seen while building the table (table and quadrature nodes), m.
    min_speed: f64,
    /// `TABLE / length` (1/m): the proportional guess of the table cell at an arc length.
    per_length: f64,
}

impl Quintic {
    /// Quintic Hermite segment from end values `p`, first derivatives `v` and second
    /// derivatives `a` with respect to `u` at `u = 0` and `u = 1`.
    fn hermite(
        p0: [f64; 2],
        v0: [f64; 2],
        a0: [f64; 2],
        p1: [f64; 2],
        v1: [f64; 2],
        a1: [f64; 2],
    ) -> Box<Self> {
        let mut c = [[0.0; 2]; 6];
        for d in 0..2 {
            [c[0][d], c[1][d], c[2][d], c[3][d], c[4][d], c[5][d]] =
                hermite5(p0[d], v0[d], a0[d], p1[d], v1[d], a1[d]);
        }
        let dc = core::array::from_fn(|k| {
            let f = (k + 1) as f64;
            [f * c[k + 1][0], f * c[k + 1][1]]
        });
        let ddc = core::array::from_fn(|k| {
            let f = (k + 1) as f64;
            [f * dc[k + 1][0], f * dc[k + 1][1]]
        });
        // Built in its box (the tables are filled in place, not copied into it).
        let mut q = Box::new(Self {
            c,
            dc,
            ddc,
            cum: [0.0; TABLE + 1],
            inv: [[0.0; 9]; TABLE],
            min_speed: f64::INFINITY,
            per_length: 0.0,
        });
        // At each table node: the speed v = |p'| and the derivatives of the inverse u(s),
        // u' = 1/v, u'' = −v_u/v³, u''' = 3 v_u²/v⁵ − v_uu/v⁴ (v_u = p'·p''/v,
        // v_uu = (|p''|² + p'·p''')/v − v_u²/v).
        // The dot products first, then every square root and reciprocal in loops of their
        // own: independent lanes, which the benchmark build pairs (`sqrtpd`, `divpd`; the
        // auto-vectoriser's choice, so it may not hold for every build), where one node at a
        // time left the divider's throughput the table's cost.
        let w = 1.0 / TABLE as f64;
        let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
        let (mut v2, mut p12, mut p2) = ([0.0; TABLE + 1], [0.0; TABLE + 1], [0.0; TABLE + 1]);
        for k in 0..=TABLE {
            let (d1, d2, d3) = q.derivatives(k as f64 * w);
            (v2[k], p12[k]) = (dot(d1, d1), dot(d1, d2));
            p2[k] = dot(d2, d2) + dot(d1, d3);
        }
        let mid2: [f64; TABLE] = core::array::from_fn(|k| q.speed_squared((k as f64 + 0.5) * w));
        let v: [f64; TABLE + 1] = core::array::from_fn(|k| v2[k].sqrt());
        let mid: [f64; TABLE] = core::array::from_fn(|k| mid2[k].sqrt());
        let iv: [f64; TABLE + 1] = core::array::from_fn(|k| 1.0 / v[k]);
        let mut spd = [[0.0; 3]; TABLE + 1];
        let mut du = [[0.0; 3]; TABLE + 1];
        let mut nan = false;
        for k in 0..=TABLE {
            let iv = iv[k];
            let vu = p12[k] * iv;
            let vuu = (p2[k] - vu * vu) * iv;
            let (iv2, iv3) = (iv * iv, iv * iv * iv);
            spd[k] = [v[k], vu, vuu];
            du[k] = [iv, -vu * iv3, (3.0 * vu * vu * iv - vuu) * iv2 * iv2];
            nan |= v[k].is_nan();
        }
        let min_speed = v.iter().chain(&mid).copied().fold(f64::INFINITY, f64::min);
        // Each cell by the symmetric rule on the speed and its first two derivatives at the
        // cell's ends (which the inverse below needs anyway) and the speed at its middle:
        // w [19/70 (v₀ + v₁) + w/35 (v₀' − v₁') + w²/840 (v₀'' + v₁'') + 16/35 v(½)], exact for
        // degree 7 like 5-point Gauss–Lobatto (error ∝ w⁹, 7 × Lobatto's constant) for one
        // speed evaluation instead of three (the tests hold the table to 1e-11 of the segment's
        // length against a 256-interval 5-point reference: 5.1e-11 on the tests' bent spline).
        for k in 0..TABLE {
            let (a, b) = (spd[k], spd[k + 1]);
            let sum = MID_W[0] * (a[0] + b[0])
                + MID_W[1] * w * (a[1] - b[1])
                + MID_W[2] * w * w * (a[2] + b[2])
                + MID_W[3] * mid[k];
            q.cum[k + 1] = q.cum[k] + sum * w;
        }
        let span: [f64; TABLE] = core::array::from_fn(|k| q.cum[k + 1] - q.cum[k]);
        let ispan: [f64; TABLE] = core::array::from_fn(|k| 1.0 / span[k]);
        for k in 0..TABLE {
            // The inverse on the cell: the septic Hermite interpolant of u(s) through the
            // cell's ends with its first three derivatives there. In t = (s − cum[k]) / span
            // the j-th derivative scales by spanʲ.
            let span = span[k];
            let u0 = k as f64 * w;
            if span > 0.0 {
                let (h2, h3) = (span * span, span * span * span);
                let end = |j: usize, u: f64| [u, du[j][0] * span, du[j][1] * h2, du[j][2] * h3];
                let c = hermite7(end(k, u0), end(k + 1, u0 + w));
                q.inv[k] = [c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], ispan[k]];
            } else {
                q.inv[k] = [u0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            }
        }
        // A NaN anywhere makes the minimum NaN, so the caller's cusp check sees it.
        q.min_speed = if nan { f64::NAN } else { min_speed };
        q.per_length = TABLE as f64 / q.cum[TABLE];
        q
    }

    /// Position, first and second derivative with respect to `u`.
    fn eval(&self, u: f64) -> ([f64; 2], [f64; 2], [f64; 2]) {
        let (c, e, f) = (&self.c, &self.dc, &self.ddc);
        let mut p = [0.0; 2];
        let mut d1 = [0.0; 2];
        let mut d2 = [0.0; 2];
        // Estrin's form (pairs of coefficients in parallel: a shorter dependency chain than
        // Horner's rule, which set much of a path point's latency).
        let (u2, u4) = (u * u, u * u * (u * u));
        for d in 0..2 {
            p[d] = (c[0][d] + u * c[1][d])
                + u2 * (c[2][d] + u * c[3][d])
                + u4 * (c[4][d] + u * c[5][d]);
            d1[d] = (e[0][d] + u * e[1][d]) + u2 * (e[2][d] + u * e[3][d]) + u4 * e[4][d];
            d2[d] = (f[0][d] + u * f[1][d]) + u2 * (f[2][d] + u * f[3][d]);
        }
        (p, d1, d2)
    }

    /// First, second and third derivative with respect to `u`.
    fn derivatives(&self, u: f64) -> ([f64; 2], [f64; 2], [f64; 2]) {
        let (e, f) = (&self.dc, &self.ddc);
        let mut d1 = [0.0; 2];
        let mut d2 = [0.0; 2];
        let mut d3 = [0.0; 2];
        for d in 0..2 {
            d1[d] = e[0][d] + u * (e[1][d] + u * (e[2][d] + u * (e[3][d] + u * e[4][d])));
            d2[d] = f[0][d] + u * (f[1][d] + u * (f[2][d] + u * f[3][d]));
            d3[d] = f[1][d] + u * (2.0 * f[2][d] + u * 3.0 * f[3][d]);
        }
        (d1, d2, d3)
    }

    /// `|dp/du|`, m (the tests' quadrature).
    #[cfg(test)]
    fn speed(&self, u: f64) -> f64 {
        self.speed_squared(u).sqrt()
    }

    /// `|dp/du|²`, m², by Horner's rule like [`Quintic::derivatives`] (the table's points are
    /// independent, so their latency overlaps; Estrin's form there cost 3.5 k instructions a
    /// plan for no time). Its square root, not `hypot`: the derivatives of a path in metres are
    /// far from the range where `hypot`'s overflow protection matters, and it costs several
    /// times less.
    fn speed_squared(&self, u: f64) -> f64 {
        let c = &self.dc;
        let d = |i: usize| c[0][i] + u * (c[1][i] + u * (c[2][i] + u * (c[3][i] + u * c[4][i])));
        let (dx, dy) = (d(0), d(1));
        dx * dx + dy * dy
    }

    /// Arc length between `u0` and `u1` by 5-point Gauss–Legendre quadrature (the tests'
    /// reference).
    #[cfg(test)]
    fn gauss(&self, u0: f64, u1: f64) -> f64 {
        let w = u1 - u0;
        let mut sum = 0.0;
        for (&x, wt) in GL_X.iter().zip(GL_W) {
            sum += wt * self.speed(u0 + w * x);
        }
        sum * w
    }

    fn length(&self) -> f64 {
        self.cum[TABLE]
    }

    /// The curve parameter `u` at arc length `s` (clamped to `[0, length]`): the table cell
    /// holding `s`, then that cell's septic Hermite interpolant of `u(s)` (value and first
    /// three derivatives at both ends; error of order `(Δs)⁸`: 1e-10 m along the curve on
    /// waypoint splines like the planner benchmark's, 1.2e-8 m on the tests' bent one, which
    /// `arc_length_inversion_solves_to_rounding` checks against Newton on the quadrature), so
    /// no iteration. Inlined into both of its callers ([`Quintic::at`] and
    /// [`Quintic::at_with_rate`]): out of line, the call cost the 1 kHz benchmark plan 280 k
    /// instructions (18 683 samples).
    #[inline(always)]
    fn u_at(&self, s: f64) -> f64 {
        let s = s.clamp(0.0, self.length());
        // The last node with `cum[k] ≤ s`: the table is close to linear in `k` (the speed
        // varies little along a segment), so start from the proportional guess and walk (a
        // step or two, cheaper than a bisection of the table).
        // (As i32: in range, a conversion cheaper than to usize.)
        let guess = (s * self.per_length) as i32;
        let mut k = (guess.max(0) as usize).min(TABLE - 1);
        while k > 0 && self.cum[k] > s {
            k -= 1;
        }
        while k < TABLE - 1 && self.cum[k + 1] <= s {
            k += 1;
        }
        let c = &self.inv[k];
        let t = (s - self.cum[k]) * c[8];
        // Estrin's form (pairs in parallel: a shorter dependency chain than Horner's rule).
        let (t2, pair) = (t * t, |j: usize| c[j] + t * c[j + 1]);
        let u = (pair(0) + t2 * pair(2)) + (t2 * t2) * (pair(4) + t2 * pair(6));
        let w = 1.0 / TABLE as f64;
        if u.is_finite() {
            u.clamp(k as f64 * w, (k + 1) as f64 * w)
        } else {
            k as f64 * w
        }
    }

    fn at(&self, s: f64) -> PathPoint {
        self.at_u(self.u_at(s))
    }

    /// [`Quintic::at`] and the curvature's rate `dκ/ds` there (1/m²).
    fn at_with_rate(&self, s: f64) -> (PathPoint, f64) {
        let u = self.u_at(s);
        let (p, d1, d2) = self.eval(u);
        let f = &self.ddc;
        let d3: [f64; 2] =
            core::array::from_fn(|d| f[1][d] + u * (2.0 * f[2][d] + u * 3.0 * f[3][d]));
        let v2 = d1[0] * d1[0] + d1[1] * d1[1];
        let inv = 1.0 / v2.sqrt();
        let inv3 = inv * inv * inv;
        let k = cross(d1, d2) * inv3;
        // κ = (p' × p'')/|p'|³ in u, so dκ/du = (p' × p''')/|p'|³ − 3κ (p'·p'')/|p'|², and
        // ds/du = |p'|.
        let dk_du = cross(d1, d3) * inv3 - 3.0 * k * dot(d1, d2) / v2;
        let point = PathPoint {
            point: p,
            tangent: [d1[0] * inv, d1[1] * inv],
            curvature: k,
        };
        (point, dk_du * inv)
    }

    /// Point, unit tangent and curvature at the curve parameter `u`.
    fn at_u(&self, u: f64) -> PathPoint {
        let (p, d1, d2) = self.eval(u);
        let inv = 1.0 / (d1[0] * d1[0] + d1[1] * d1[1]).sqrt();
        PathPoint {
            point: p,
            tangent: [d1[0] * inv, d1[1] * inv],
            curvature: (d1[0] * d2[1] - d1[1] * d2[0]) * (inv * inv * inv),
        }
    }
}

/// Coefficients `a_0..a_5` of the quintic on `[0, 1]` with value, first and second
/// derivative `(f0, g0, c0)` at 0 and `(f1, g1, c1)` at 1 (quintic Hermite interpolation).
fn hermite5(f0: f64, g0: f64, c0: f64, f1: f64, g1: f64, c1: f64) -> [f64; 6] {
    let d = f1 - f0;
    [
        f0,
        g0,
        0.5 * c0,
        10.0 * d - 6.0 * g0 - 4.0 * g1 - 0.5 * (3.0 * c0 - c1),
        -15.0 * d + 8.0 * g0 + 7.0 * g1 + 0.5 * (3.0 * c0 - 2.0 * c1),
        6.0 * d - 3.0 * g0 - 3.0 * g1 - 0.5 * (c0 - c1),
    ]
}

/// Coefficients `a_0..a_7` of the septic on `[0, 1]` with value and first three derivatives
/// `d0` at 0 and `d1` at 1 (Hermite interpolation; the inverse of the end conditions'
/// 4 × 4 system on `a_4..a_7` is written out).
fn hermite7(d0: [f64; 4], d1: [f64; 4]) -> [f64; 8] {
    let (a0, a1, a2, a3) = (d0[0], d0[1], 0.5 * d0[2], d0[3] / 6.0);
    let r0 = d1[0] - (a0 + a1 + a2 + a3);
    let r1 = d1[1] - (a1 + 2.0 * a2 + 3.0 * a3);
    let r2 = d1[2] - (2.0 * a2 + 6.0 * a3);
    let r3 = d1[3] - 6.0 * a3;
    [
        a0,
        a1,
        a2,
        a3,
        35.0 * r0 - 15.0 * r1 + 2.5 * r2 - r3 / 6.0,
        -84.0 * r0 + 39.0 * r1 - 7.0 * r2 + 0.5 * r3,
        70.0 * r0 - 34.0 * r1 + 6.5 * r2 - 0.5 * r3,
        -20.0 * r0 + 10.0 * r1 - 2.0 * r2 + r3 / 6.0,
    ]
}

/// One primitive of a path, parametrised by its own arc length.
#[derive(Clone, Debug, PartialEq)]
enum Piece {
    Line {
        start: [f64; 2],
        dir: [f64; 2],
        len: f64,
    },
    Arc {
        centre: [f64; 2],
        radius: f64,
        start_angle: f64,
        /// Signed sweep, rad (> 0 counter-clockwise).
        sweep: f64,
    },
    Quintic(Box<Quintic>),
}

impl Piece {
    fn length(&self) -> f64 {
        match self {
            Piece::Line { len, .. } => *len,
            Piece::Arc { radius, sweep, .. } => radius * sweep.abs(),
            Piece::Quintic(q) => q.length(),
        }
    }

    /// The point at the piece's end (`end`) or start: for a quintic at `u = 1` or `0`
    /// exactly, without the arc-length inversion.
    fn at_end(&self, end: bool) -> PathPoint {
        match self {
            Piece::Quintic(q) => q.at_u(if end { 1.0 } else { 0.0 }),
            _ => self.at(if end { self.length() } else { 0.0 }),
        }
    }

    fn at(&self, s: f64) -> PathPoint {
        let s = s.clamp(0.0, self.length());
        match self {
            Piece::Line { start, dir, .. } => PathPoint {
                point: [start[0] + s * dir[0], start[1] + s * dir[1]],
                tangent: *dir,
                curvature: 0.0,
            },
            Piece::Arc {
                centre,
                radius,
                start_angle,
                sweep,
            } => {
                let sign = sweep.signum();
                let a = start_angle + sign * s / radius;
                let (sa, ca) = a.sin_cos();
                PathPoint {
                    point: [centre[0] + radius * ca, centre[1] + radius * sa],
                    tangent: [-sign * sa, sign * ca],
                    curvature: sign / radius,
                }
            }
            Piece::Quintic(q) => q.at(s),
        }
    }

    /// [`Piece::at`] and the curvature's rate `dκ/ds` there (1/m²; 0 on lines and arcs).
    fn at_with_rate(&self, s: f64) -> (PathPoint, f64) {
        match self {
            Piece::Quintic(q) => q.at_with_rate(s.clamp(0.0, q.length())),
            _ => (self.at(s), 0.0),
        }
    }
}

/// Where a path's pieces meet: the geometry seen from both sides, and whether the robot stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Join {
    /// Arc length of the join, m.
    pub s: f64,
    /// The end of the piece before the join.
    pub before: PathPoint,
    /// The start of the piece after it.
    pub after: PathPoint,
    /// `true` when the robot must be at rest here (a [`Corners::Stop`] corner).
    pub stop: bool,
}

/// A planar path `r_C(s)` parametrised by arc length `s ∈ [0, length]` (m), world frame.
///
/// Built from waypoints ([`Path::polyline`], [`Path::spline`]) or as an arc or circle
/// ([`Path::arc`], [`Path::circle`]). Evaluate with [`Path::at`].
#[derive(Clone, Debug, PartialEq)]
pub struct Path {
    pieces: Vec<Piece>,
    /// Arc length at the start of each piece, plus the total length at the end.
    offsets: Vec<f64>,
    /// Pieces per metre of path (the proportional guess of the piece at an arc length).
    per_length: f64,
    /// Whether the robot stops at the start of piece `k` (index `k ≥ 1`).
    stop_before: Vec<bool>,
    /// Arc length of each input waypoint on the path (closest point for filleted corners).
    waypoint_s: Vec<f64>,
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}
fn norm(a: [f64; 2]) -> f64 {
    a[0].hypot(a[1])
}
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}
fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// Largest turn at a waypoint (rad) that a fillet or a spline can round: beyond it the path
/// nearly reverses and has to stop instead.
const MAX_SMOOTH_TURN: f64 = 179.0 * std::f64::consts::PI / 180.0;

/// Checks waypoints: at least two, finite, no two consecutive ones equal. Returns the legs'
/// unit directions and lengths.
fn legs(points: &[[f64; 2]]) -> Result<(Vec<[f64; 2]>, Vec<f64>), PlanningError> {
    if points.len() < 2 {
        return Err(PlanningError::InvalidPath(format!(
            "a path needs at least 2 waypoints, got {}",
            points.len()
        )));
    }
    for (i, p) in points.iter().enumerate() {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return Err(PlanningError::InvalidPath(format!(
                "waypoint {}: ({}, {}) is not finite",
                i + 1,
                p[0],
                p[1]
            )));
        }
    }
    let mut dirs = Vec::with_capacity(points.len() - 1);
    let mut lens = Vec::with_capacity(points.len() - 1);
    for (i, w) in points.windows(2).enumerate() {
        let d = sub(w[1], w[0]);
        let l = norm(d);
        if l <= 1e-9 {
            return Err(PlanningError::InvalidPath(format!(
                "waypoint {} ({}, {}) repeats waypoint {}; consecutive waypoints must differ by more than 1e-9 m",
                i + 2,
                w[1][0],
                w[1][1],
                i + 1
            )));
        }
        dirs.push([d[0] / l, d[1] / l]);
        lens.push(l);
    }
    Ok((dirs, lens))
}

impl Path {
    fn from_pieces(pieces: Vec<Piece>, stop_before: Vec<bool>, waypoint_s: Vec<f64>) -> Self {
        let mut offsets = Vec::with_capacity(pieces.len() + 1);
        let mut s = 0.0;
        for p in &pieces {
            offsets.push(s);
            s += p.length();
        }
        offsets.push(s);
        Self {
            per_length: pieces.len() as f64 / s,
            pieces,
            offsets,
            stop_before,
            waypoint_s,
        }
    }

    /// A polyline through `waypoints` (world frame, m): straight legs, with a full stop or a
    /// circular fillet at every corner (see [`Corners`]).
    ///
    /// # Errors
    /// [`PlanningError::InvalidPath`] for fewer than two waypoints, a non-finite or repeated
    /// waypoint, a fillet that does not fit on its legs (naming the leg and the lengths), a
    /// non-positive fillet radius, or a corner that reverses direction (turn above 179°) when
    /// filleting.
    pub fn polyline(waypoints: &[[f64; 2]], corners: Corners) -> Result<Self, PlanningError> {
        let (dirs, lens) = legs(waypoints)?;
        let n = waypoints.len();
        // Turn angle at each interior waypoint k = 1..n-2.
        let turn = |k: usize| {
            let (a, b) = (dirs[k - 1], dirs[k]);
            cross(a, b).atan2(dot(a, b))
        };
        match corners {
            Corners::Stop => {
                let mut pieces = Vec::new();
                let mut stop_before = Vec::new();
                let mut waypoint_s = vec![0.0];
                let mut s = 0.0;
                for k in 0..n - 1 {
                    let stop = k > 0 && turn(k).abs() > 1e-9;
                    // Merge collinear legs into one piece so nothing marks a join there.
                    if k > 0 && !stop {
                        if let Some(Piece::Line { len, .. }) = pieces.last_mut() {
                            *len += lens[k];
                        }
                    } else {
                        pieces.push(Piece::Line {
                            start: waypoints[k],
                            dir: dirs[k],
                            len: lens[k],
                        });
                        stop_before.push(stop);
                    }
                    s += lens[k];
                    waypoint_s.push(s);
                }
                Ok(Self::from_pieces(pieces, stop_before, waypoint_s))
            }
            Corners::Fillet { radius } => {
                crate::limits::check_range(
                    "fillet radius",
                    radius,
                    crate::limits::LENGTH_RANGE,
                    "m",
                )?;
                // Tangent length r·tan(|turn|/2) at each interior corner.
                let mut tlen = vec![0.0; n];
                for k in 1..n - 1 {
                    let th = turn(k);
                    if th.abs() > MAX_SMOOTH_TURN {
                        return Err(PlanningError::InvalidPath(format!(
                            "waypoint {} ({}, {}) turns by {:.1}°: a fillet cannot round a reversal; use stops at the corners",
                            k + 1,
                            waypoints[k][0],
                            waypoints[k][1],
                            th.to_degrees()
                        )));
                    }
                    tlen[k] = radius * (th.abs() / 2.0).tan();
                }
                for j in 0..n - 1 {
                    let need = tlen[j] + tlen[j + 1];
                    if need > lens[j] * (1.0 + 1e-12) {
                        return Err(PlanningError::InvalidPath(format!(
                            "a fillet of radius {radius} m does not fit on leg {} (waypoints {} → {}, {:.4} m long): its corners need {:.4} + {:.4} m of it",
                            j + 1,
                            j + 1,
                            j + 2,
                            lens[j],
                            tlen[j],
                            tlen[j + 1]
                        )));
                    }
                }
                let mut pieces = Vec::new();
                let mut waypoint_s = vec![0.0];
                let mut s = 0.0;
                for j in 0..n - 1 {
                    let start = [
                        waypoints[j][0] + tlen[j] * dirs[j][0],
                        waypoints[j][1] + tlen[j] * dirs[j][1],
                    ];
                    let len = lens[j] - tlen[j] - tlen[j + 1];
                    if len > 1e-12 {
                        pieces.push(Piece::Line {
                            start,
                            dir: dirs[j],
                            len,
                        });
                        s += len;
                    }
                    if j + 1 < n - 1 {
                        let k = j + 1;
                        let th = turn(k);
                        if tlen[k] > 0.0 {
                            let sign = th.signum();
                            let a = dirs[k - 1];
                            let normal = [-sign * a[1], sign * a[0]];
                            let p0 = [
                                waypoints[k][0] - tlen[k] * a[0],
                                waypoints[k][1] - tlen[k] * a[1],
                            ];
                            let centre = [p0[0] + radius * normal[0], p0[1] + radius * normal[1]];
                            let start_angle = (p0[1] - centre[1]).atan2(p0[0] - centre[0]);
                            let arc = Piece::Arc {
                                centre,
                                radius,
                                start_angle,
                                sweep: th,
                            };
                            let l = arc.length();
                            pieces.push(arc);
                            waypoint_s.push(s + l / 2.0);
                            s += l;
                        } else {
                            waypoint_s.push(s);
                        }
                    }
                }
                waypoint_s.push(s);
                let stops = vec![false; pieces.len()];
                Ok(Self::from_pieces(pieces, stops, waypoint_s))
            }
        }
    }

    /// A circular arc (world frame): centre `centre` (m), radius `radius` (m), starting at polar
    /// angle `start_angle` (rad) about the centre and sweeping `sweep` rad (> 0
    /// counter-clockwise, < 0 clockwise; may exceed 2π for several turns).
    ///
    /// # Errors
    /// [`PlanningError::InvalidParameter`] for a non-finite value, a radius ≤ 0 or a sweep of 0.
    pub fn arc(
        centre: [f64; 2],
        radius: f64,
        start_angle: f64,
        sweep: f64,
    ) -> Result<Self, PlanningError> {
        for (name, v) in [
            ("centre x", centre[0]),
            ("centre y", centre[1]),
            ("start angle", start_angle),
        ] {
            if !v.is_finite() {
                return Err(PlanningError::InvalidParameter {
                    name,
                    value: v,
                    rule: "must be finite",
                });
            }
        }
        if !(radius.is_finite() && radius > 0.0) {
            return Err(PlanningError::InvalidParameter {
                name: "radius",
                value: radius,
                rule: "must be a finite number > 0 (m)",
            });
        }
        if !(sweep.is_finite() && sweep != 0.0) {
            return Err(PlanningError::InvalidParameter {
                name: "sweep",
                value: sweep,
                rule: "must be finite and non-zero (rad)",
            });
        }
        let piece = Piece::Arc {
            centre,
            radius,
            start_angle,
            sweep,
        };
        let l = piece.length();
        Ok(Self::from_pieces(vec![piece], vec![false], vec![0.0, l]))
    }

    /// `turns` full circles of radius `radius` (m) about `centre`, starting at polar angle
    /// `start_angle` (rad); `turns > 0` counter-clockwise, `< 0` clockwise. With centre at the
    /// origin and `start_angle = 0` this is the path of paper 000, eq. 6.3:
    /// `x = R_t cos φ`, `y = R_t sin φ`.
    ///
    /// # Errors
    /// As [`Path::arc`]; `turns` must be finite and non-zero.
    pub fn circle(
        centre: [f64; 2],
        radius: f64,
        start_angle: f64,
        turns: f64,
    ) -> Result<Self, PlanningError> {
        if !(turns.is_finite() && turns != 0.0) {
            return Err(PlanningError::InvalidParameter {
                name: "turns",
                value: turns,
                rule: "must be finite and non-zero",
            });
        }
        Self::arc(centre, radius, start_angle, turns * std::f64::consts::TAU)
    }

    /// A smooth curve through `waypoints` (world frame, m) with **continuous curvature**: a
    /// quintic Hermite spline on chord-length knots `t_k` (`t_{k+1} − t_k = |P_{k+1} − P_k|`).
    ///
    /// At an interior waypoint `P_k` the first and second derivatives are those of the parabola
    /// through `P_{k−1}, P_k, P_{k+1}` (Bessel's three-point rule):
    /// `D1_k = (Δ_k m_{k−1} + Δ_{k−1} m_k)/(Δ_{k−1} + Δ_k)`, `D2_k = 2(m_k − m_{k−1})/(Δ_{k−1} + Δ_k)`
    /// with `m_j` the unit chord directions and `Δ_j` the chord lengths; at the two ends `D1` is
    /// the end parabola's slope and `D2 = 0` (zero curvature, so the robot starts and stops on a
    /// straight). Both derivatives are shared by the segments meeting at a waypoint, so the curve
    /// is C² and its curvature continuous; each waypoint only moves the curve between its
    /// neighbours. Arc length comes from a 16-interval table per segment (a two-point Hermite
    /// rule with a midpoint, exact for degree 7),
    /// inverted on each interval by a septic Hermite interpolant of `u(s)`.
    ///
    /// # Errors
    /// [`PlanningError::InvalidPath`] for fewer than two waypoints, a non-finite or repeated
    /// waypoint, a reversal (turn above 179° at a waypoint) or a segment whose speed `|dp/du|`
    /// nearly vanishes (a cusp; spread the waypoints more evenly).
    pub fn spline(waypoints: &[[f64; 2]]) -> Result<Self, PlanningError> {
        let (m, d) = legs(waypoints)?;
        let n = waypoints.len();
        let mut d1 = vec![[0.0; 2]; n];
        let mut d2 = vec![[0.0; 2]; n];
        if n == 2 {
            d1[0] = m[0];
            d1[1] = m[0];
        } else {
            // The chord directions are unit vectors: a turn above MAX_SMOOTH_TURN is a dot
            // product below its cosine (the angle itself only for the message).
            let min_dot = MAX_SMOOTH_TURN.cos();
            for k in 1..n - 1 {
                let cos_turn = dot(m[k - 1], m[k]);
                if cos_turn.is_nan() || cos_turn < min_dot {
                    let turn = cross(m[k - 1], m[k]).atan2(dot(m[k - 1], m[k]));
                    return Err(PlanningError::InvalidPath(format!(
                        "waypoint {} ({}, {}) turns by {:.1}°: a smooth spline cannot pass a reversal; use a polyline with stops",
                        k + 1,
                        waypoints[k][0],
                        waypoints[k][1],
                        turn.to_degrees()
                    )));
                }
                let (da, db) = (d[k - 1], d[k]);
                for c in 0..2 {
                    d1[k][c] = (db * m[k - 1][c] + da * m[k][c]) / (da + db);
                    d2[k][c] = 2.0 * (m[k][c] - m[k - 1][c]) / (da + db);
                }
            }
            // End slopes of the parabolas through the first and last three waypoints.
            let c0 = 2.0 * (m[1][0] - m[0][0]) / (d[0] + d[1]);
            let c1 = 2.0 * (m[1][1] - m[0][1]) / (d[0] + d[1]);
            d1[0] = [m[0][0] - c0 * d[0] / 2.0, m[0][1] - c1 * d[0] / 2.0];
            let (a, b) = (n - 3, n - 2);
            let e0 = 2.0 * (m[b][0] - m[a][0]) / (d[a] + d[b]);
            let e1 = 2.0 * (m[b][1] - m[a][1]) / (d[a] + d[b]);
            d1[n - 1] = [m[b][0] + e0 * d[b] / 2.0, m[b][1] + e1 * d[b] / 2.0];
        }
        let mut pieces = Vec::with_capacity(n - 1);
        let mut waypoint_s = vec![0.0];
        let mut s = 0.0;
        for k in 0..n - 1 {
            let h = d[k];
            let sc = |v: [f64; 2], f: f64| [v[0] * f, v[1] * f];
            let q = Quintic::hermite(
                waypoints[k],
                sc(d1[k], h),
                sc(d2[k], h * h),
                waypoints[k + 1],
                sc(d1[k + 1], h),
                sc(d2[k + 1], h * h),
            );
            let min_speed = q.min_speed;
            if min_speed.is_nan() || min_speed <= 1e-3 * h || !q.length().is_finite() {
                return Err(PlanningError::InvalidPath(format!(
                    "spline segment {} (waypoints {} → {}) has a cusp (|dp/du| falls to {:.2e} m); spread the waypoints more evenly",
                    k + 1,
                    k + 1,
                    k + 2,
                    min_speed
                )));
            }
            s += q.length();
            waypoint_s.push(s);
            pieces.push(Piece::Quintic(q));
        }
        let stops = vec![false; pieces.len()];
        Ok(Self::from_pieces(pieces, stops, waypoint_s))
    }

    /// Total arc length, m.
    pub fn length(&self) -> f64 {
        self.offsets[self.pieces.len()]
    }

    /// Arc lengths (m) where the path's pieces start (and, last, its length): where the
    /// curvature's derivative may jump.
    pub(crate) fn piece_starts(&self) -> &[f64] {
        &self.offsets
    }

    /// Index of the piece containing arc length `s` (the later one at a join).
    fn piece_index(&self, s: f64) -> usize {
        let n = self.pieces.len();
        // The last piece starting at or before `s`: a spline's pieces have similar lengths, so
        // the proportional guess is usually right or a step off; bisect when it is not.
        let k = ((s * self.per_length) as usize).min(n - 1);
        if self.offsets[k] <= s && (k + 1 == n || self.offsets[k + 1] > s) {
            return k;
        }
        if k + 1 < n && self.offsets[k + 1] <= s && (k + 2 == n || self.offsets[k + 2] > s) {
            return k + 1;
        }
        if k > 0 && self.offsets[k - 1] <= s && self.offsets[k] > s {
            return k - 1;
        }
        self.offsets[..n]
            .partition_point(|&o| o <= s)
            .saturating_sub(1)
    }

    /// Point, unit tangent and curvature at arc length `s` (m), clamped to `[0, length]`. At a
    /// join between pieces the later piece answers (see [`Path::joins`] for both sides).
    pub fn at(&self, s: f64) -> PathPoint {
        let s = if s.is_nan() {
            0.0
        } else {
            s.clamp(0.0, self.length())
        };
        let k = self.piece_index(s);
        self.pieces[k].at(s - self.offsets[k])
    }

    /// [`Path::at_side`] and the index of the piece that answered.
    pub(crate) fn at_side_piece(&self, s: f64, side: Side) -> (usize, PathPoint) {
        self.on_side_piece(s, side, Piece::at)
    }

    /// [`Path::at_side_piece`] with the curvature's rate `dκ/ds` (1/m², one-sided at a join
    /// like the rest: where it jumps, e.g. at a spline's waypoints).
    pub(crate) fn at_side_piece_with_rate(&self, s: f64, side: Side) -> (usize, (PathPoint, f64)) {
        self.on_side_piece(s, side, Piece::at_with_rate)
    }

    /// `eval` of the piece holding arc length `s` (clamped; at a join the side decides), at
    /// the arc length within it, and the piece's index.
    fn on_side_piece<T>(&self, s: f64, side: Side, eval: impl Fn(&Piece, f64) -> T) -> (usize, T) {
        let s = if s.is_nan() {
            0.0
        } else {
            s.clamp(0.0, self.length())
        };
        let mut k = self.piece_index(s);
        if side == Side::Before && k > 0 && s <= self.offsets[k] {
            k -= 1;
        }
        (k, eval(&self.pieces[k], s - self.offsets[k]))
    }

    /// The point at arc length `s` if it lies strictly inside piece `k` (not at either end,
    /// where [`Path::at_side`] decides the side), `None` otherwise.
    pub(crate) fn inside_piece(&self, k: usize, s: f64) -> Option<PathPoint> {
        self.inside_piece_with(k, s, Piece::at)
    }

    /// [`Path::inside_piece`] with the curvature's rate `dκ/ds` (1/m²).
    pub(crate) fn inside_piece_with_rate(&self, k: usize, s: f64) -> Option<(PathPoint, f64)> {
        self.inside_piece_with(k, s, Piece::at_with_rate)
    }

    /// `eval` of piece `k` at arc length `s` if `s` lies strictly inside it.
    fn inside_piece_with<T>(&self, k: usize, s: f64, eval: impl Fn(&Piece, f64) -> T) -> Option<T> {
        let (start, end) = (*self.offsets.get(k)?, *self.offsets.get(k + 1)?);
        (start < s && s < end).then(|| eval(&self.pieces[k], s - start))
    }

    /// Like [`Path::at`], but at a join [`Side::Before`] evaluates the piece that ends there
    /// (the incoming direction and curvature) and [`Side::After`] the one that starts there.
    pub fn at_side(&self, s: f64, side: Side) -> PathPoint {
        self.at_side_piece(s, side).1
    }

    /// The interior joins between pieces, in order, each seen from both sides: where the
    /// curvature may jump (fillets) and where the robot must stop ([`Corners::Stop`]).
    pub fn joins(&self) -> Vec<Join> {
        (1..self.pieces.len())
            .map(|k| {
                let prev = &self.pieces[k - 1];
                Join {
                    s: self.offsets[k],
                    before: prev.at_end(true),
                    after: self.pieces[k].at_end(false),
                    stop: self.stop_before[k],
                }
            })
            .collect()
    }

    /// Arc lengths (m) of the interior points where the robot must be at rest.
    pub fn stops(&self) -> Vec<f64> {
        self.joins()
            .into_iter()
            .filter(|j| j.stop)
            .map(|j| j.s)
            .collect()
    }

    /// Arc length (m) on the path of each waypoint it was built from (the middle of the fillet
    /// for a rounded corner; `[0, length]` for an arc or circle). Used to key a heading profile
    /// to the waypoints.
    pub fn waypoint_arc_lengths(&self) -> &[f64] {
        &self.waypoint_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quintic_hermite_meets_its_end_conditions() {
        let q = Quintic::hermite(
            [0.0, 1.0],
            [2.0, 0.5],
            [0.3, -1.0],
            [1.0, -2.0],
            [-1.0, 0.7],
            [4.0, 2.0],
        );
        let (p, v, a) = q.eval(1.0);
        for (got, want) in [(p, [1.0, -2.0]), (v, [-1.0, 0.7]), (a, [4.0, 2.0])] {
            assert!(
                (got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12,
                "{got:?} vs {want:?}"
            );
        }
    }

    /// The exact inverse `u(s)` of a segment's arc length, by Newton on the reference
    /// quadrature from the table node below (to convergence, from the interpolant's answer).
    fn u_exact(q: &Quintic, s: f64) -> f64 {
        let mut u = q.u_at(s);
        for _ in 0..20 {
            let k = ((u * TABLE as f64).floor() as usize).min(TABLE - 1);
            let f = q.cum[k] + q.gauss(k as f64 / TABLE as f64, u) - s;
            let step = f / q.speed(u);
            u -= step;
            if step.abs() < 1e-16 {
                break;
            }
        }
        u
    }

    /// Largest `|Δu|·|p'|` (m: how far along the curve the interpolated inverse lands from
    /// the exact one) over `n + 1` arc lengths per segment of `p`, table nodes included.
    fn worst_inversion(p: &Path, n: usize) -> f64 {
        let mut worst = 0.0_f64;
        for piece in &p.pieces {
            let Piece::Quintic(q) = piece else {
                unreachable!("a spline is made of quintics")
            };
            for i in 0..=n {
                let s = q.length() * i as f64 / n as f64;
                let u = q.u_at(s);
                worst = worst.max((u - u_exact(q, s)).abs() * q.speed(u));
            }
            for k in 0..=TABLE {
                let u = q.u_at(q.cum[k]);
                worst = worst.max((u - k as f64 / TABLE as f64).abs() * q.speed(u));
            }
        }
        worst
    }

    #[test]
    fn arc_length_inversion_solves_to_rounding() {
        // u(s) from the per-cell septic interpolant against Newton on the quadrature, on a bent
        // spline (its long last segment turns hardest): within 3e-8 m along the curve (1.15e-8 m
        // seen), where the quintic one without the third derivatives leaves 3.5e-7 m.
        // And the table itself: s(u) from it against a 256-interval reference, relative to the
        // segment's length.
        let p =
            Path::spline(&[[0.0, 0.0], [1.0, 0.5], [2.0, -0.3], [2.5, 1.0], [2.6, 3.0]]).unwrap();
        let worst = worst_inversion(&p, 997);
        assert!(worst < 3e-8, "inverse off by {worst:e} m");
        let mut worst_table = 0.0_f64;
        for piece in &p.pieces {
            let Piece::Quintic(q) = piece else {
                unreachable!("a spline is made of quintics")
            };
            for i in 0..=997 {
                let s = q.length() * i as f64 / 997.0;
                let u = u_exact(q, s);
                let back: f64 = (0..256)
                    .map(|j| q.gauss(u * j as f64 / 256.0, u * (j + 1) as f64 / 256.0))
                    .sum();
                worst_table = worst_table.max((back - s).abs() / q.length());
            }
        }
        // 5.1e-11 seen (5-point Gauss–Lobatto: 7.4e-12); a wrong weight leaves ≫ 1e-10.
        assert!(
            worst_table < 1e-10,
            "table off by {worst_table:e} of a segment's length"
        );
    }

    #[test]
    fn arc_length_inversion_is_within_a_nanometre_on_a_waypoint_spline() {
        // The accuracy claim behind the planner's figures: on the 20-waypoint benchmark spline
        // (waypoints 0.5 m apart) the interpolated inverse, with no Newton step, lands within
        // 3e-10 m of the exact one (9.6e-11 m seen; 1.1e-8 m for the quintic one without the
        // third derivatives).
        let wps: Vec<[f64; 2]> = (0..20)
            .map(|k| {
                let k = k as f64;
                [0.5 * k, 0.4 * (0.9 * k).sin() + 0.1 * (2.3 * k).cos()]
            })
            .collect();
        let worst = worst_inversion(&Path::spline(&wps).unwrap(), 499);
        assert!(worst < 3e-10, "inverse off by {worst:e} m");
    }

    #[test]
    fn curvature_rate_is_the_derivative_of_the_curvature() {
        // dκ/ds against a central difference of κ over ±1e-5 m (error ~1e-10 relative at the
        // curvature's scale), on a bent spline and inside every piece of a filleted polyline,
        // seen from both sides of every join.
        let spline = Path::spline(&[[0.0, 0.0], [1.0, 0.5], [2.0, -0.3], [2.5, 1.0]]).unwrap();
        let fillet = Path::polyline(
            &[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]],
            Corners::Fillet { radius: 0.3 },
        )
        .unwrap();
        let mut worst_scale = 0.0_f64;
        for path in [&spline, &fillet] {
            let len = path.length();
            let joins: Vec<f64> = path.piece_starts().to_vec();
            for i in 1..200 {
                let s = len * i as f64 / 200.0;
                let d = 1e-5;
                if joins.iter().any(|&j| (j - s).abs() < 2.0 * d) {
                    continue;
                }
                let (_, (p, rate)) = path.at_side_piece_with_rate(s, Side::After);
                let fd = (path.at(s + d).curvature - path.at(s - d).curvature) / (2.0 * d);
                assert_eq!(p, path.at(s), "the point at s = {s}");
                assert!(
                    (rate - fd).abs() <= 1e-5 * (1.0 + fd.abs()),
                    "dκ/ds at s = {s}: {rate} against the difference {fd}"
                );
                worst_scale = worst_scale.max(fd.abs());
            }
            for &j in &joins[1..joins.len() - 1] {
                for (side, off) in [(Side::Before, -1e-5), (Side::After, 1e-5)] {
                    let (_, (_, rate)) = path.at_side_piece_with_rate(j, side);
                    let (_, (_, near)) = path.at_side_piece_with_rate(j + off, side);
                    assert!(
                        (rate - near).abs() <= 1e-3 * (1.0 + near.abs()),
                        "dκ/ds at the join {j} ({side:?}): {rate} against {near} beside it"
                    );
                }
            }
        }
        // The spline's curvature does vary (the test compares something).
        assert!(worst_scale > 0.1, "largest |dκ/ds| {worst_scale}");
    }

    #[test]
    fn arc_length_inversion_is_consistent() {
        let p = Path::spline(&[[0.0, 0.0], [1.0, 0.5], [2.0, -0.3], [2.5, 1.0]]).unwrap();
        // Summing chords over a fine grid of s reproduces the length: s is arc length.
        let n = 20_000;
        let mut chord = 0.0;
        let mut prev = p.at(0.0).point;
        for i in 1..=n {
            let q = p.at(p.length() * i as f64 / n as f64).point;
            chord += norm(sub(q, prev));
            prev = q;
        }
        assert!(
            (chord - p.length()).abs() < 1e-6 * p.length(),
            "{chord} vs {}",
            p.length()
        );
    }
}
