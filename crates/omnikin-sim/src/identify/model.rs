//! The measurement models of an identification: the pose a robot with trial parameters would
//! have dead-reckoned from its encoder log (output error against the reference trajectory),
//! and the yaw-rate integral its gyro would have read over windows of that motion.
//!
//! **Poses.** From a start pose, each encoder increment is turned into a robot-frame
//! displacement by the robot's forward kinematics ([`Robot::displacement`]) and composed
//! exactly on SE(2) ([`omnikin::se2::integrate`] over one unit of time), as `omnikin odometry`
//! does. The pose at a reference time is interpolated linearly between encoder samples. With
//! a rigid robot that does not slip, the residuals against a tracked or camera reference are
//! the reference's noise, which is what least squares assumes.
//!
//! **Gyro.** Over a window `[a, b]` of the run the gyro integrates to
//! `∫ g dt = scale · Δψ + bias · (t_b − t_a)` plus noise, `Δψ` the heading change of the
//! (fitted) wheel odometry: linear in `(bias, scale)`. Windows do not overlap, so their noise
//! is independent (the integral of white noise over disjoint windows).

use omnikin::{Actuators, EncoderAngles, Kind, Pose2, Robot, Twist2};

use super::runs::{EncoderLog, GyroLog, LoggedRun};

/// Dead-reckons `log` with `robot` from `start` (the pose at the log's first sample): one pose
/// per sample. `None` when the kinematics refuse an increment (non-finite angles).
pub fn dead_reckon(
    robot: &Robot<f64>,
    log: &EncoderLog,
    start: Pose2<f64>,
) -> Option<Vec<Pose2<f64>>> {
    let mut out = Vec::with_capacity(log.angles.len());
    let mut pose = start;
    out.push(pose);
    for w in log.angles.windows(2) {
        let d = robot.displacement(&w[0], &w[1]).ok()?.twist;
        pose = omnikin::se2::integrate(pose, Twist2::new(d.vx, d.vy, d.yaw_rate), 1.0);
        out.push(pose);
    }
    Some(out)
}

/// The encoder log `robot` itself would have recorded for the motion it dead-reckons from
/// `log`: each increment's displacement turned back into wheel increments (and steer angles)
/// by its inverse kinematics. On this log the robot's kinematics are exactly consistent (no
/// module or wheel disagrees with the others), which the observability test needs: a direction
/// of parameter space that changes no twist of a consistent robot (a swerve's modules rotated
/// together about the origin) does change the twist of inconsistent data, in proportion to
/// the inconsistency — the very parameter error being identified — and so looks observable at
/// a wrong prior although the runs carry no information on it.
///
/// The caster keeps its own log (its steer angles are state the inverse only gives rates for,
/// and its parameters are all identifiable). `None` when the kinematics refuse an increment.
pub fn consistent_log(robot: &Robot<f64>, log: &EncoderLog) -> Option<EncoderLog> {
    if robot.kind() == Kind::Caster {
        return Some(log.clone());
    }
    let n = robot.wheels();
    let first = *log.angles.first()?;
    let mut act = Actuators::zero();
    act.steer_angles = first.steer;
    let mut reading: EncoderAngles<f64> = first;
    let mut angles = Vec::with_capacity(log.angles.len());
    angles.push(reading);
    for w in log.angles.windows(2) {
        let d = robot.displacement(&w[0], &w[1]).ok()?.twist;
        // The displacement is a twist over one unit of time: its "rates" are increments.
        act = robot
            .inverse(Twist2::new(d.vx, d.vy, d.yaw_rate), &act)
            .ok()?;
        for i in 0..n {
            reading.wheel[i] += act.wheel_rates[i];
            reading.steer[i] = act.steer_angles[i];
        }
        angles.push(reading);
    }
    Some(EncoderLog {
        file: log.file.clone(),
        t: log.t.clone(),
        angles,
    })
}

/// The pose at time `time`, linearly interpolated in `(t, poses)`; `None` outside `t`.
pub fn pose_at(t: &[f64], poses: &[Pose2<f64>], time: f64) -> Option<Pose2<f64>> {
    let (first, last) = (*t.first()?, *t.last()?);
    if !(first..=last).contains(&time) {
        return None;
    }
    let k = t.partition_point(|v| *v <= time).clamp(1, t.len() - 1);
    let (a, b) = (poses.get(k - 1)?, poses.get(k)?);
    let u = (time - t[k - 1]) / (t[k] - t[k - 1]);
    Some(Pose2::new(
        a.x + u * (b.x - a.x),
        a.y + u * (b.y - a.y),
        a.heading + u * (b.heading - a.heading),
    ))
}

/// Weights of the two residual groups: the standard deviation each residual is divided by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResidualWeights {
    /// Position, m.
    pub position: f64,
    /// Heading, rad.
    pub heading: f64,
}

/// Appends the run's pose residuals (predicted − reference, divided by `w`): `x, y` per
/// reference sample inside the encoder log's time span, and the heading (wrapped into
/// (−π, π]) when the reference has one. Returns how many position and heading residuals it
/// wrote, or `None` when the kinematics refuse the log.
pub fn pose_residuals(
    robot: &Robot<f64>,
    run: &LoggedRun,
    start: Pose2<f64>,
    w: ResidualWeights,
    out: &mut Vec<f64>,
) -> Option<(usize, usize)> {
    let poses = dead_reckon(robot, &run.encoders, start)?;
    let r = &run.reference;
    let (mut np, mut nh) = (0, 0);
    for (k, &time) in r.t.iter().enumerate() {
        let Some(p) = pose_at(&run.encoders.t, &poses, time) else {
            continue;
        };
        out.push((p.x - r.xy[k][0]) / w.position);
        out.push((p.y - r.xy[k][1]) / w.position);
        np += 2;
        if let Some(h) = &r.heading {
            out.push(omnikin::wrap_angle(p.heading - h[k]) / w.heading);
            nh += 1;
        }
    }
    Some((np, nh))
}

/// Cumulative trapezoid integral of the gyro at its sample times.
fn cumulative(g: &GyroLog) -> Vec<f64> {
    let mut out = Vec::with_capacity(g.t.len());
    let mut acc = 0.0;
    out.push(0.0);
    for k in 1..g.t.len() {
        acc += 0.5 * (g.rate[k] + g.rate[k - 1]) * (g.t[k] - g.t[k - 1]);
        out.push(acc);
    }
    out
}

fn interpolate(t: &[f64], v: &[f64], time: f64) -> Option<f64> {
    let (first, last) = (*t.first()?, *t.last()?);
    if !(first..=last).contains(&time) || t.len() < 2 {
        return None;
    }
    let k = t.partition_point(|x| *x <= time).clamp(1, t.len() - 1);
    let u = (time - t[k - 1]) / (t[k] - t[k - 1]);
    Some(v[k - 1] + u * (v[k] - v[k - 1]))
}

/// One gyro window: the odometry's heading change, the duration and the gyro's integral.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroWindow {
    /// Heading change of the wheel odometry, rad.
    pub heading_change: f64,
    /// Duration, s.
    pub duration: f64,
    /// `∫ g dt` over the window, rad.
    pub integral: f64,
}

/// Splits the encoder samples into consecutive windows at least `window` s long and pairs each
/// with the gyro's integral over it (windows outside the gyro's time span are skipped).
pub fn gyro_windows(
    t: &[f64],
    poses: &[Pose2<f64>],
    gyro: &GyroLog,
    window: f64,
) -> Vec<GyroWindow> {
    let g = cumulative(gyro);
    let mut out = Vec::new();
    let mut a = 0;
    for b in 1..t.len().min(poses.len()) {
        if t[b] - t[a] < window {
            continue;
        }
        if let (Some(ga), Some(gb)) = (
            interpolate(&gyro.t, &g, t[a]),
            interpolate(&gyro.t, &g, t[b]),
        ) {
            out.push(GyroWindow {
                heading_change: poses[b].heading - poses[a].heading,
                duration: t[b] - t[a],
                integral: gb - ga,
            });
        }
        a = b;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use omnikin::EncoderAngles;
    use omnikin::description::RobotDescription;

    /// A kiwi spinning in place at 1 rad/s for 1 s: the wheel angles of the inverse
    /// kinematics dead-reckon to a heading of 1 rad and no translation.
    #[test]
    fn dead_reckoning_a_spin() {
        let robot = RobotDescription::preset("kiwi")
            .unwrap()
            .build::<f64>()
            .unwrap();
        let rates = robot
            .inverse(Twist2::new(0.0, 0.0, 1.0), &omnikin::Actuators::zero())
            .unwrap();
        let t: Vec<f64> = (0..=10).map(|k| k as f64 * 0.1).collect();
        let angles = t
            .iter()
            .map(|t| {
                let q: Vec<f64> = rates.wheel_rates[..3].iter().map(|w| w * t).collect();
                EncoderAngles::new(&q, &[])
            })
            .collect();
        let log = EncoderLog {
            file: "x".into(),
            t: t.clone(),
            angles,
        };
        let poses = dead_reckon(&robot, &log, Pose2::new(1.0, 2.0, 0.0)).unwrap();
        let end = poses.last().unwrap();
        assert!((end.heading - 1.0).abs() < 1e-12);
        assert!((end.x - 1.0).abs() < 1e-12 && (end.y - 2.0).abs() < 1e-12);
        let mid = pose_at(&t, &poses, 0.55).unwrap();
        assert!((mid.heading - 0.55).abs() < 1e-12);
        assert!(pose_at(&t, &poses, 1.5).is_none());
    }

    /// A gyro reading `1.01 · ψ̇ + 0.02` over windows integrates to exactly that.
    #[test]
    fn gyro_windows_integrate_rate_and_bias() {
        let t: Vec<f64> = (0..=40).map(|k| k as f64 * 0.05).collect();
        let poses: Vec<Pose2<f64>> = t.iter().map(|t| Pose2::new(0.0, 0.0, 0.5 * t)).collect();
        let gyro = GyroLog {
            file: "g".into(),
            t: t.clone(),
            rate: t.iter().map(|_| 1.01 * 0.5 + 0.02).collect(),
        };
        let w = gyro_windows(&t, &poses, &gyro, 0.5);
        assert_eq!(w.len(), 4);
        for win in &w {
            let want = 1.01 * win.heading_change + 0.02 * win.duration;
            assert!((win.integral - want).abs() < 1e-12, "{win:?}");
        }
    }

    /// A swerve log whose module 2 rolls 2 % too far (its wheel is larger than the file says)
    /// is inconsistent; its consistent copy dead-reckons to the same poses and moves every
    /// module at the rigid-body velocity (the inverse of its own forward).
    #[test]
    fn a_consistent_log_dead_reckons_the_same() {
        let robot = RobotDescription::preset("swerve4")
            .unwrap()
            .build::<f64>()
            .unwrap();
        let tw = Twist2::new(0.3, 0.1, 0.8);
        let a = robot.inverse(tw, &omnikin::Actuators::zero()).unwrap();
        let t: Vec<f64> = (0..=20).map(|k| k as f64 * 0.05).collect();
        let angles: Vec<EncoderAngles<f64>> = t
            .iter()
            .map(|t| {
                let mut q: Vec<f64> = a.wheel_rates[..4].iter().map(|w| w * t).collect();
                q[1] *= 1.02;
                EncoderAngles::new(&q, &a.steer_angles[..4])
            })
            .collect();
        let log = EncoderLog {
            file: "x".into(),
            t,
            angles,
        };
        let c = consistent_log(&robot, &log).unwrap();
        let start = Pose2::new(0.5, -0.2, 0.3);
        let (p, q) = (
            dead_reckon(&robot, &log, start).unwrap(),
            dead_reckon(&robot, &c, start).unwrap(),
        );
        for (p, q) in p.iter().zip(&q) {
            assert!((p.x - q.x).abs() < 1e-12 && (p.y - q.y).abs() < 1e-12);
            assert!((p.heading - q.heading).abs() < 1e-12);
        }
        // Each increment of the copy is the inverse of its own displacement.
        let d = robot
            .displacement(&c.angles[3], &c.angles[4])
            .unwrap()
            .twist;
        let back = robot
            .inverse(Twist2::new(d.vx, d.vy, d.yaw_rate), &a)
            .unwrap();
        for i in 0..4 {
            let inc = c.angles[4].wheel[i] - c.angles[3].wheel[i];
            assert!((inc - back.wheel_rates[i]).abs() < 1e-12, "module {i}");
        }
        // The original's module 2 disagrees with the others; the copy's does not.
        let orig = log.angles[4].wheel[1] - log.angles[3].wheel[1];
        let copy = c.angles[4].wheel[1] - c.angles[3].wheel[1];
        assert!((orig - copy).abs() > 1e-3 * orig.abs(), "{orig} vs {copy}");
    }
}
