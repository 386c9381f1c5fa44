//! The platform tilt a plan causes on a spherical robot (quasi-static estimate), and
//! [`limit_tilt`], which slows the moves that would exceed a limit.
//!
//! A sphere's internal platform hangs like a pendulum below the shell centre; to accelerate
//! the robot at `a` (the shell centre's acceleration, tangential and centripetal) its centre
//! of mass must move ahead of the floor contact. The moment balance about the shell centre in
//! steady acceleration (the derivation is in `omnikin_sim::dynamics::sphere`) gives the lean
//! `θ`:
//!
//! ```text
//! m_p h sin θ = (a/g) (M z_cm + I_s/R),   z_cm = R − m_p h cos θ / M
//! ⇔ sin θ + (a/g) cos θ = (a/g)(M R + I_s/R) / (m_p h)
//! ```
//!
//! (`m_p`, `h`: platform mass and centre-of-mass depth below the shell centre; `M`: total
//! mass; `R`, `I_s`: shell radius and inertia.) Above `(a/g)(M R + I_s/R) > m_p h √(1 +
//! (a/g)²)` there is no equilibrium: the platform would swing over. This is the
//! quasi-static estimate only: the rocking that a sudden start or stop excites (the dynamic
//! model shows up to twice the quasi-static lean) and the plan's full-speed start (a velocity
//! step, no acceleration the samples show) are not in it.
//!
//! [`limit_tilt`] slows a move whose tilt would pass the limit by a **uniform time dilation**
//! (as the planner's re-timing does for motor limits): every velocity, yaw rate and wheel rate
//! of the move times `f`, its time stretched by `1/f`, so every acceleration scales by `f²`
//! exactly and `f = √(a_limit / a_peak)` meets the limit in one pass. Moves joined at non-zero
//! speed are slowed together (by the smallest factor), so the plan stays continuous. The
//! slowed moves keep their samples (each is an exact point of the slowed trajectory), spaced
//! `dt/f` instead of `dt`.

use crate::Plan;
use crate::planner::Planned;

/// The parameters of the quasi-static lean (SI units; see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltModel {
    /// Platform mass `m_p`, kg.
    pub platform_mass: f64,
    /// Depth `h` of the platform's centre of mass below the shell centre, m (> 0).
    pub com_depth: f64,
    /// Total mass `M` (shell + platform), kg.
    pub total_mass: f64,
    /// Shell radius `R`, m.
    pub shell_radius: f64,
    /// Shell moment of inertia `I_s` about its centre, kg·m².
    pub shell_inertia: f64,
    /// Gravity `g`, m/s².
    pub gravity: f64,
}

impl TiltModel {
    /// The quasi-static lean for a shell-centre acceleration of magnitude `accel` (m/s²), rad
    /// in `[0, π/2)`; `None` when no lean can hold it (the platform would swing over).
    pub fn tilt(&self, accel: f64) -> Option<f64> {
        let k = accel.abs() / self.gravity;
        let rhs = k
            * (self.total_mass * self.shell_radius + self.shell_inertia / self.shell_radius)
            / (self.platform_mass * self.com_depth);
        let s = rhs / (1.0 + k * k).sqrt();
        if s.is_nan() || s >= 1.0 {
            return None;
        }
        Some((s.asin() - k.atan()).max(0.0))
    }

    /// The largest acceleration (m/s²) whose quasi-static lean is `tilt` (rad, in `(0, π/2)`):
    /// `a = g m_p h sin θ / (M R − m_p h cos θ + I_s/R)`.
    pub fn accel_for_tilt(&self, tilt: f64) -> f64 {
        let mh = self.platform_mass * self.com_depth;
        self.gravity * mh * tilt.sin()
            / (self.total_mass * self.shell_radius - mh * tilt.cos()
                + self.shell_inertia / self.shell_radius)
    }
}

/// The largest quasi-static tilt of a plan.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltPeak {
    /// The tilt, rad (`π/2` when some acceleration has no equilibrium lean).
    pub tilt: f64,
    /// The shell centre's acceleration there, m/s².
    pub accel: f64,
    /// Its time, s.
    pub t: f64,
}

/// The shell centre's acceleration magnitude at each sample (m/s²): the world-frame velocity
/// differentiated between samples (central differences inside, one-sided at the ends), so the
/// centripetal part of a curve is included.
pub fn accelerations(plan: &Plan) -> Vec<f64> {
    let s = &plan.samples;
    let n = s.len();
    (0..n)
        .map(|i| {
            if n < 2 {
                return 0.0;
            }
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let dt = s[b].t - s[a].t;
            if dt <= 0.0 {
                return 0.0;
            }
            let ax = (s[b].twist.vx - s[a].twist.vx) / dt;
            let ay = (s[b].twist.vy - s[a].twist.vy) / dt;
            ax.hypot(ay)
        })
        .collect()
}

/// The largest quasi-static tilt over `plan`'s samples.
pub fn peak_tilt(plan: &Plan, model: &TiltModel) -> TiltPeak {
    let mut peak = TiltPeak {
        tilt: 0.0,
        accel: 0.0,
        t: plan.samples.first().map_or(0.0, |s| s.t),
    };
    for (s, a) in plan.samples.iter().zip(accelerations(plan)) {
        let tilt = model.tilt(a).unwrap_or(core::f64::consts::FRAC_PI_2);
        if tilt > peak.tilt {
            peak = TiltPeak {
                tilt,
                accel: a,
                t: s.t,
            };
        }
    }
    peak
}

/// One group of moves [`limit_tilt`] slowed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltSlowdown {
    /// First and last move (0-based, the planner report's order) of the group.
    pub moves: (usize, usize),
    /// The speed factor `f` (< 1): velocities × f, durations / f.
    pub factor: f64,
    /// The group's quasi-static tilt before, rad.
    pub tilt_before: f64,
}

/// `planned` with every group of moves whose quasi-static tilt exceeds `max_tilt` (rad)
/// slowed by a uniform time dilation (see the module doc), and what was slowed. Moves are
/// found from the report's move durations; a group ends where the robot is at rest (every
/// wheel rate and the twist below 1e-9). The report is not recomputed: its durations and
/// peaks are those of the plan before.
pub fn limit_tilt(
    planned: &Planned,
    model: &TiltModel,
    max_tilt: f64,
) -> (Plan, Vec<TiltSlowdown>) {
    let plan = &planned.plan;
    let samples = &plan.samples;
    if samples.is_empty() {
        return (plan.clone(), Vec::new());
    }
    let t0 = samples[0].t;
    // Move boundaries in time, then groups joined at non-zero speed.
    let mut ends = Vec::new();
    let mut acc = t0;
    for m in &planned.report.moves {
        acc += m.duration;
        ends.push(acc);
    }
    let at_rest = |t: f64| {
        samples
            .iter()
            .min_by(|a, b| (a.t - t).abs().total_cmp(&(b.t - t).abs()))
            .is_some_and(|s| {
                s.twist.vx.hypot(s.twist.vy) < 1e-9
                    && s.twist.yaw_rate.abs() < 1e-9
                    && s.wheel_rates.iter().all(|w| w.abs() < 1e-9)
            })
    };
    let mut groups: Vec<(usize, usize, f64)> = Vec::new(); // (first move, last move, end time)
    let mut first = 0;
    for (i, &e) in ends.iter().enumerate() {
        if i + 1 == ends.len() || at_rest(e) {
            groups.push((first, i, e));
            first = i + 1;
        }
    }
    if groups.is_empty() {
        groups.push((0, 0, f64::INFINITY));
    }
    let accel = accelerations(plan);
    let a_limit = model.accel_for_tilt(max_tilt);
    let group_of = |t: f64| {
        groups
            .iter()
            .position(|g| t <= g.2 + 1e-9)
            .unwrap_or(groups.len() - 1)
    };
    let mut peak = vec![0.0f64; groups.len()];
    for (s, a) in samples.iter().zip(&accel) {
        let g = group_of(s.t);
        peak[g] = peak[g].max(*a);
    }
    let factor: Vec<f64> = peak
        .iter()
        .map(|&a| {
            if a > a_limit && a > 0.0 {
                // Slightly below the exact factor so rounding cannot leave the limit exceeded.
                (a_limit / a).sqrt() * (1.0 - 1e-9)
            } else {
                1.0
            }
        })
        .collect();
    let slowed: Vec<TiltSlowdown> = groups
        .iter()
        .zip(&factor)
        .zip(&peak)
        .filter(|&((_, f), _)| *f < 1.0)
        .map(|((g, f), a)| TiltSlowdown {
            moves: (g.0, g.1),
            factor: *f,
            tilt_before: model.tilt(*a).unwrap_or(core::f64::consts::FRAC_PI_2),
        })
        .collect();
    let mut out = plan.clone();
    let (mut t_old, mut t_new) = (t0, t0);
    for (k, s) in out.samples.iter_mut().enumerate() {
        let f = factor[group_of(samples[k].t)];
        t_new += (samples[k].t - t_old) / f;
        t_old = samples[k].t;
        s.t = t_new;
        s.twist.vx *= f;
        s.twist.vy *= f;
        s.twist.yaw_rate *= f;
        for w in s.wheel_rates.iter_mut() {
            *w *= f;
        }
        if let Some((_, rates)) = &mut s.steer {
            for r in rates.iter_mut() {
                *r *= f;
            }
        }
    }
    (out, slowed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RobotModel;
    use crate::generators::{Circle, Square};
    use crate::planner::{OnLimit, plan};
    use omnikin::description::RobotDescription;

    /// Paper 000's robot with the dynamic model's default estimates.
    fn model() -> TiltModel {
        TiltModel {
            platform_mass: 2.0,
            com_depth: 0.08,
            total_mass: 2.5,
            shell_radius: 0.15,
            shell_inertia: 0.0075,
            gravity: 9.81,
        }
    }

    fn robot() -> RobotModel {
        RobotModel::from_description(&RobotDescription::preset("sphere-omni").unwrap()).unwrap()
    }

    #[test]
    fn the_lean_satisfies_the_moment_balance_and_inverts() {
        let m = model();
        for a in [0.05, 0.3, 1.25, 3.0] {
            let th = m.tilt(a).unwrap();
            let z_cm = m.shell_radius - m.platform_mass * m.com_depth * th.cos() / m.total_mass;
            let lhs = m.platform_mass * m.com_depth * th.sin();
            let rhs = a / m.gravity * (m.total_mass * z_cm + m.shell_inertia / m.shell_radius);
            assert!((lhs - rhs).abs() < 1e-12, "a {a}: {lhs} vs {rhs}");
            assert!((m.accel_for_tilt(th) - a).abs() < 1e-9 * a.max(1.0));
        }
        assert_eq!(m.tilt(0.0), Some(0.0));
        // Too much acceleration for a pendulum this short.
        assert_eq!(m.tilt(100.0), None);
    }

    #[test]
    fn the_circle_tilts_by_its_centripetal_acceleration_and_is_slowed_to_the_limit() {
        let c = Circle::paper(5.0);
        let planned = plan(
            &c.path().unwrap(),
            &c.heading(),
            &robot(),
            &c.options(100.0),
        )
        .unwrap();
        let m = model();
        let peak = peak_tilt(&planned.plan, &m);
        let (v, r) = (c.speed(), c.radius);
        let want = m.tilt(v * v / r).unwrap();
        assert!((peak.tilt - want).abs() < 1e-3 * want, "{peak:?} vs {want}");
        let limit = 8f64.to_radians();
        assert!(peak.tilt > limit);
        let (slow, slowed) = limit_tilt(&planned, &m, limit);
        assert_eq!(slowed.len(), 1);
        let f = slowed[0].factor;
        let after = peak_tilt(&slow, &m);
        assert!(
            after.tilt <= limit && after.tilt > limit - 1e-6,
            "{after:?}"
        );
        let (d0, d1) = (
            planned.plan.samples.last().unwrap().t,
            slow.samples.last().unwrap().t,
        );
        assert!((d1 - d0 / f).abs() < 1e-9, "{d0} / {f} vs {d1}");
        // Same path, samples kept; wheel rates scaled.
        assert_eq!(slow.samples.len(), planned.plan.samples.len());
        let (a, b) = (&planned.plan.samples[37], &slow.samples[37]);
        assert_eq!((a.pose.x, a.pose.y), (b.pose.x, b.pose.y));
        assert!((b.wheel_rates[0] - f * a.wheel_rates[0]).abs() < 1e-12);
        // A generous limit changes nothing.
        let (same, none) = limit_tilt(&planned, &m, 30f64.to_radians());
        assert!(none.is_empty());
        assert_eq!(same, planned.plan);
    }

    #[test]
    fn square_legs_are_slowed_one_by_one() {
        let sq = Square::paper(5.0);
        let planned = plan(
            &sq.path().unwrap(),
            &sq.heading(),
            &robot(),
            &sq.options(100.0, OnLimit::Reject),
        )
        .unwrap();
        let m = model();
        let before = peak_tilt(&planned.plan, &m);
        let limit = 0.5 * before.tilt;
        let (slow, slowed) = limit_tilt(&planned, &m, limit);
        assert!(peak_tilt(&slow, &m).tilt <= limit);
        // Four legs from rest to rest: four groups, each slowed on its own.
        assert_eq!(slowed.len(), planned.report.moves.len(), "{slowed:?}");
        assert!(
            slowed
                .iter()
                .all(|s| s.moves.0 == s.moves.1 && s.factor < 1.0)
        );
        // Times still increase.
        assert!(slow.samples.windows(2).all(|w| w[1].t > w[0].t));
    }
}
