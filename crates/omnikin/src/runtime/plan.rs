//! The plan buffer and trajectory following: a fixed array of `N` uploaded [`PlanPoint`]s
//! (begin, chunks, start, each validated), the reference at a plan time (cubic Hermite in
//! pose, linear in velocity), and the trajectory target `v = v_ref + K·(p_ref − p)`.

use super::command::{CommandError, PlanPoint, check_motion};
use super::config::Config;
use super::status::PlanStatus;
use crate::{Pose2, Real, Twist2, wrap_angle as wrap};

/// The uploaded plan and where the runtime is along it. No allocation: `N` points inline.
#[derive(Clone, Debug)]
pub(super) struct PlanBuffer<T, const N: usize> {
    points: [PlanPoint<T>; N],
    /// Upload progress and completion.
    pub(super) status: PlanStatus,
    /// Plan time of the next cycle's measured pose, s.
    time: T,
    /// Plan time of [`PlanBuffer::reference`], s.
    pub(super) reference_time: T,
    /// Segment of the last lookup (moves forward only).
    index: usize,
    /// Reference pose at `reference_time` (world).
    pub(super) reference: Pose2<T>,
    /// The uploaded plan has been started: a later `PlanStart` of it is a retransmission.
    started: bool,
}

pub(super) fn zero_twist<T: Real>() -> Twist2<T> {
    Twist2::new(T::zero(), T::zero(), T::zero())
}

impl<T: Real, const N: usize> PlanBuffer<T, N> {
    /// An empty buffer whose reference is `pose`.
    pub(super) fn new(pose: Pose2<T>) -> Self {
        Self {
            points: [PlanPoint::zero(); N],
            status: PlanStatus::default(),
            time: T::zero(),
            reference_time: T::zero(),
            index: 0,
            reference: pose,
            started: false,
        }
    }

    /// [`PlanBuffer::new`] in place (no second `N`-point buffer on the stack).
    pub(super) fn reset(&mut self, pose: Pose2<T>) {
        self.points.fill(PlanPoint::zero());
        self.status = PlanStatus::default();
        self.time = T::zero();
        self.reference_time = T::zero();
        self.index = 0;
        self.reference = pose;
        self.started = false;
    }

    /// `PlanBegin`: clears the buffer for plan `id` of `len` points.
    pub(super) fn begin(&mut self, id: u16, len: u16, running: bool) -> Result<(), CommandError> {
        if len as usize > N {
            return Err(CommandError::PlanTooLong { len, capacity: N });
        }
        if running {
            return Err(CommandError::Busy);
        }
        self.started = false;
        self.status = PlanStatus {
            id,
            received: 0,
            len,
            done: false,
        };
        Ok(())
    }

    /// `PlanChunk`: stores `points` at `offset` after checking every value.
    pub(super) fn chunk(
        &mut self,
        id: u16,
        offset: u16,
        points: &[PlanPoint<T>],
        running: bool,
        cfg: &Config<T>,
    ) -> Result<(), CommandError> {
        let st = self.status;
        if id != st.id {
            return Err(CommandError::PlanIdMismatch {
                expected: st.id,
                got: id,
            });
        }
        if running {
            return Err(CommandError::Busy);
        }
        let start = offset as usize;
        let end = start + points.len();
        if offset > st.received || end > st.len as usize || points.is_empty() {
            return Err(CommandError::PlanChunkOutOfPlace {
                offset,
                count: points.len(),
                have: st.received,
                len: st.len,
            });
        }
        for (k, p) in points.iter().enumerate() {
            let fin = |x: T, field| {
                if x.is_finite() {
                    Ok(())
                } else {
                    Err(CommandError::NonFinite { field })
                }
            };
            fin(p.t, "plan.t")?;
            fin(p.pose.x, "plan.x")?;
            fin(p.pose.y, "plan.y")?;
            fin(p.pose.heading, "plan.heading")?;
            check_motion(p.twist, true, cfg)?;
            let prev_t = if k > 0 {
                Some(points[k - 1].t)
            } else if start > 0 {
                Some(self.points[start - 1].t)
            } else {
                None
            };
            if prev_t.is_some_and(|pt| p.t.partial_cmp(&pt) != Some(core::cmp::Ordering::Greater)) {
                return Err(CommandError::PlanTimeNotIncreasing { index: start + k });
            }
        }
        self.points[start..end].copy_from_slice(points);
        if end as u16 > st.received {
            self.status.received = end as u16;
        }
        Ok(())
    }

    /// `PlanStart`: checks the plan is complete and strictly increasing in time, and rewinds
    /// to its first point: `Ok(true)`. `estop`: the e-stop is latched (then refused).
    ///
    /// Once per upload: a `PlanStart` of a plan already started (running or done) is an operator's
    /// retransmission whose first copy was answered by telemetry the operator lost, and is
    /// ignored, `Ok(false)` (it restarted a running plan from its first point, 1.6 mm behind
    /// the robot, under 20 % loss). Running a plan again takes a new `PlanBegin`.
    pub(super) fn start(&mut self, id: u16, estop: bool) -> Result<bool, CommandError> {
        let st = self.status;
        if id != st.id {
            return Err(CommandError::PlanIdMismatch {
                expected: st.id,
                got: id,
            });
        }
        if self.started {
            return Ok(false);
        }
        if st.received != st.len || st.len < 2 {
            return Err(CommandError::PlanIncomplete {
                have: st.received,
                len: st.len,
            });
        }
        if estop {
            return Err(CommandError::EStopLatched);
        }
        let n = st.len as usize;
        for i in 1..n {
            if self.points[i].t.partial_cmp(&self.points[i - 1].t)
                != Some(core::cmp::Ordering::Greater)
            {
                return Err(CommandError::PlanTimeNotIncreasing { index: i });
            }
        }
        self.time = self.points[0].t;
        self.reference_time = self.points[0].t;
        self.index = 0;
        self.status.done = false;
        self.started = true;
        Ok(true)
    }

    /// The world-frame target twist of one trajectory cycle of `dt` s at the measured `pose`:
    /// feedback against the reference at the plan time of the pose, feed-forward of the mean
    /// reference velocity over the coming cycle; advances the plan time. Returns the target and
    /// whether the plan ended (the caller then stops).
    pub(super) fn follow(&mut self, pose: Pose2<T>, dt: T, cfg: &Config<T>) -> (Twist2<T>, bool) {
        let (r, _) = self.reference_at(self.time, pose);
        let (_, ff) = self.reference_at(self.time + dt * T::of(0.5), pose);
        self.reference = r;
        self.reference_time = self.time;
        self.time += dt;
        let (ex, ey) = (r.x - pose.x, r.y - pose.y);
        let (mut cx, mut cy) = (cfg.k_position * ex, cfg.k_position * ey);
        let cn = (cx * cx + cy * cy).sqrt();
        if cn > cfg.max_correction && cn > T::zero() {
            let k = cfg.max_correction / cn;
            cx *= k;
            cy *= k;
        }
        let cw = (cfg.k_heading * wrap(r.heading - pose.heading))
            .clamp(-cfg.max_yaw_correction, cfg.max_yaw_correction);
        let n = self.status.len as usize;
        let done = n > 0 && self.time >= self.points[(n - 1).min(N - 1)].t;
        if done {
            self.status.done = true;
        }
        (Twist2::new(ff.vx + cx, ff.vy + cy, ff.yaw_rate + cw), done)
    }

    /// Reference pose and world twist of the plan at `tau` (s): cubic Hermite in position and
    /// heading (using the sampled velocities as tangents), linear in velocity. An empty plan
    /// gives `fallback` at rest.
    fn reference_at(&mut self, tau: T, fallback: Pose2<T>) -> (Pose2<T>, Twist2<T>) {
        let n = self.status.len as usize;
        let pts = &self.points[..n.min(N)];
        if pts.is_empty() {
            return (fallback, zero_twist());
        }
        if tau <= pts[0].t {
            return (pts[0].pose, pts[0].twist);
        }
        let last = pts[pts.len() - 1];
        if tau >= last.t {
            return (last.pose, zero_twist());
        }
        let mut k = self.index.min(pts.len() - 2);
        if pts[k].t > tau {
            k = 0;
        }
        while k + 2 < pts.len() && pts[k + 1].t <= tau {
            k += 1;
        }
        self.index = k;
        let (a, b) = (pts[k], pts[k + 1]);
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
}
