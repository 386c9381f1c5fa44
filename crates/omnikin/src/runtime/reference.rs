//! A plan's reference between its points, as the runtime follows it: cubic Hermite in position
//! and heading (the sampled world velocities as tangents), linear in velocity. One definition
//! for the robot ([`Runtime`](super::Runtime)'s trajectory mode) and for an operator that must
//! start a splice exactly on the running plan ([`plan_reference`]).

use super::command::PlanPoint;
use crate::{Pose2, Real, Twist2};

/// Reference pose and world twist at `tau` (s) between points `a` and `b`
/// (`a.t < b.t`; `tau` in `[a.t, b.t]`).
pub(super) fn between<T: Real>(
    a: &PlanPoint<T>,
    b: &PlanPoint<T>,
    tau: T,
) -> (Pose2<T>, Twist2<T>) {
    let h = b.t - a.t;
    let s = (tau - a.t) / h;
    let (s2, s3) = (s * s, s * s * s);
    let two = T::of(2.0);
    let three = T::of(3.0);
    let h00 = two * s3 - three * s2 + T::one();
    let h10 = s3 - two * s2 + s;
    let h01 = -two * s3 + three * s2;
    let h11 = s3 - s2;
    let herm = |p0: T, v0: T, p1: T, v1: T| h00 * p0 + h10 * h * v0 + h01 * p1 + h11 * h * v1;
    let pose = Pose2::new(
        herm(a.pose.x, a.twist.vx, b.pose.x, b.twist.vx),
        herm(a.pose.y, a.twist.vy, b.pose.y, b.twist.vy),
        herm(
            a.pose.heading,
            a.twist.yaw_rate,
            b.pose.heading,
            b.twist.yaw_rate,
        ),
    );
    let lerp = |x: T, y: T| x + (y - x) * s;
    let twist = Twist2::new(
        lerp(a.twist.vx, b.twist.vx),
        lerp(a.twist.vy, b.twist.vy),
        lerp(a.twist.yaw_rate, b.twist.yaw_rate),
    );
    (pose, twist)
}

/// The reference of the plan `points` (strictly increasing times) at `tau` (s), as the runtime
/// follows it: the first point before the plan, the last at rest after it, the interpolation of
/// the module docs between the two points around `tau` otherwise; `None` for an empty plan. An operator builds a splice's first
/// point with it ([`Command::PlanSplice`](super::Command::PlanSplice): the robot checks that
/// point against its own reference at the same time).
pub fn plan_reference<T: Real>(points: &[PlanPoint<T>], tau: T) -> Option<(Pose2<T>, Twist2<T>)> {
    let (first, last) = (points.first()?, points.last()?);
    if tau <= first.t {
        return Some((first.pose, first.twist));
    }
    if tau >= last.t {
        let z = T::zero();
        return Some((last.pose, Twist2::new(z, z, z)));
    }
    // The last point with t ≤ tau: 0 ≤ k < len − 1 here.
    let k = points.partition_point(|p| p.t <= tau).saturating_sub(1);
    Some(between(&points[k], points.get(k + 1)?, tau))
}
