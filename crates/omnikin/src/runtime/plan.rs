//! The plan buffer and trajectory following: a ring of `N` uploaded [`PlanPoint`]s (begin,
//! chunks, start, each validated), the reference at a plan time (cubic Hermite in pose, linear
//! in velocity), the trajectory target `v = v_ref + K·(p_ref − p)`, and the **splice** that
//! replaces the running plan's future without stopping.
//!
//! ## Splice
//! A plan runs from ring slot `base` for `len` points; the slots before its current segment
//! and after its last point are free. A splice upload (`PlanSplice`, then the usual chunks and
//! start) is written into those free slots, after the running plan's last point, while the
//! running plan goes on untouched. Its start arms it; the cycle whose plan time reaches the
//! splice's first point time `t_s` follows the splice from then on (the reference at
//! `t ≥ t_s` is the splice's). The start refuses, and the running plan goes on as if nothing
//! had been sent, when
//! * `t_s` is not ahead of the running plan's time or not before its end
//!   ([`CommandError::SpliceOutside`]);
//! * the splice's first point is not the running plan's reference at `t_s` within
//!   [`SPLICE_MAX_JUMP`] in each of x, y, heading, vx, vy, yaw rate
//!   ([`CommandError::OverLimit`] naming `splice.x_jump`, …). So the reference is
//!   continuous in pose and velocity across the switch, and the commanded twist changes by no
//!   more than the plan's own change over a cycle plus these tolerances.
//!
//! The splice's begin refuses an upload that does not fit the free slots
//! ([`CommandError::SpliceNoRoom`]) and a splice with no plan running
//! ([`CommandError::NothingToSplice`]). No second buffer: the plan memory stays `N` points.
//!
//! ## Re-based splice
//! A splice begun with `PlanSpliceRebased` is planned from where the robot **is** (its
//! estimate, predicted to `t_s` by the operator) rather than from the running plan's
//! reference: its first point's position and velocity (x, y, vx, vy) are not checked against
//! the reference — a robot held up or pushed is elsewhere on (or off) its path, moving as it
//! does there — while heading and yaw rate are, as above. A change of velocity at the switch
//! is then shaped like any other by the slew's acceleration limit. At the switch the
//! runtime **re-bases** the reference on the measured pose: with `r(t)` the splice's reference,
//! `p` the pose and `t₀` the plan time of the switch cycle, the offset `o = p − r(t₀)` is
//! added to the reference and fades out linearly over `T = max(`[`REBASE_MIN_BLEND`]`,
//! |o| / max_correction)`:
//!
//! `r'(t) = r(t) + o · (1 − (t − t₀)/T)` for `t₀ ≤ t < t₀ + T`, and its feed-forward velocity
//! `v'(t) = v(t) − o/T` (the reference's own derivative).
//!
//! So the tracking error at the switch is exactly zero — the position loop pulls nowhere — and
//! the robot is brought onto the splice's path no faster than `max_correction`, the position
//! loop's own authority (`|o|/T ≤ max_correction`). The offset is the operator's prediction
//! error (a few centimetres), not the drift: the drift is in the splice's path, planned from
//! the estimate. The offset is independent of which plan runs: a plain splice armed while it
//! fades is checked against the plan's points and the fade goes on across its switch; a fresh
//! plan clears it. The planned acceleration (the tilt feedback's lean) is the plan's, without
//! the fade.

use super::command::{CommandError, PlanPoint, check_motion};
use super::config::Config;
use super::reference::between;
use super::status::PlanStatus;
use crate::{Pose2, Real, Twist2, wrap_angle as wrap};

/// Largest difference between a splice's first point and the running plan's reference at its
/// time, per component: x, y (m), heading (rad, unwrapped as plans are), world vx, vy (m/s) and
/// yaw rate (rad/s). The wire carries `f32` (a relative rounding of 6e-8: 60 µm at 1 km from
/// the origin), so an operator that samples its own copy of the running plan at `t_s` with
/// the runtime's interpolation ([`plan_reference`](super::plan_reference)) lands well within
/// 1e-3; a step that small in the reference moves the command by at most `k_position` × 1 mm.
pub const SPLICE_MAX_JUMP: f64 = 1.0e-3;

/// The fields of [`CommandError::OverLimit`] for a splice's jump in x, y, heading, vx, vy, yaw rate.
/// Shortest fade of a re-based splice's offset, s (module docs, "Re-based splice"): a second,
/// the scale of a position-loop time constant (`1/k_position` is 0.5 s with [`Config::new`]'s
/// gains), so that a small offset leaves the reference's velocity within a few mm/s of the plan's.
pub const REBASE_MIN_BLEND: f64 = 1.0;

const JUMP_FIELDS: [&str; 6] = [
    "splice.x_jump",
    "splice.y_jump",
    "splice.heading_jump",
    "splice.vx_jump",
    "splice.vy_jump",
    "splice.yaw_rate_jump",
];

/// The uploaded plan and where the runtime is along it. No allocation: `N` points inline, used
/// as a ring (the running plan, then a splice's upload after it).
#[derive(Clone, Debug)]
pub(super) struct PlanBuffer<T, const N: usize> {
    points: [PlanPoint<T>; N],
    /// Upload progress (of a fresh plan or a splice) and the running plan's completion.
    pub(super) status: PlanStatus,
    /// Plan time of the next cycle's measured pose, s.
    time: T,
    /// Plan time of [`PlanBuffer::reference`], s.
    pub(super) reference_time: T,
    /// Segment of the last lookup (moves forward only), logical index in the running plan.
    index: usize,
    /// Reference pose at `reference_time` (world).
    pub(super) reference: Pose2<T>,
    /// The uploaded plan has been started: a later `PlanStart` of it is a retransmission.
    started: bool,
    /// Ring slot of the running plan's first point.
    base: usize,
    /// Points of the running plan (0 before a start).
    len: usize,
    /// Ring slot of the upload's first point.
    upload: usize,
    /// The upload is a splice of the running plan.
    splice: bool,
    /// A complete splice was started: switch to it at its first point's time.
    armed: bool,
    /// The upload is a re-based splice (module docs): its position is not checked, and the
    /// reference is re-based on the pose at its switch.
    rebase: bool,
    /// The re-base offset's fade rate `o/T` (world, m/s): the reference is moved by
    /// `fade · (fade_end − t)` until `fade_end` (three numbers, not four: the firmware's
    /// `Runtime` is held to a RAM budget).
    fade: [T; 2],
    /// Plan time at which the offset has faded out, s (not after the plan time: no offset).
    fade_end: T,
    /// The plan's feed-forward (world twist, without a re-base's fade) of the previous
    /// [`PlanBuffer::follow`].
    last_ff: Twist2<T>,
    /// The planned world acceleration of the latest [`PlanBuffer::follow`]: the change of its
    /// feed-forward over the cycle, m/s² (what a sphere's tilt feedback leans for).
    pub(super) accel: [T; 2],
}

pub(super) fn zero_twist<T: Real>() -> Twist2<T> {
    Twist2::new(T::zero(), T::zero(), T::zero())
}

/// Ring slot `i` places after slot `start` (`start < N`, `i ≤ N`; no division, no panic).
fn slot<const N: usize>(start: usize, i: usize) -> usize {
    let j = start + i;
    if j >= N { j - N } else { j }
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
            base: 0,
            len: 0,
            upload: 0,
            splice: false,
            armed: false,
            rebase: false,
            fade: [T::zero(); 2],
            fade_end: T::zero(),
            last_ff: zero_twist(),
            accel: [T::zero(); 2],
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
        self.base = 0;
        self.len = 0;
        self.upload = 0;
        self.splice = false;
        self.last_ff = zero_twist();
        self.accel = [T::zero(); 2];
        self.armed = false;
        self.rebase = false;
        self.fade = [T::zero(); 2];
        self.fade_end = T::zero();
    }

    /// Point `i` of the running plan.
    fn pt(&self, i: usize) -> PlanPoint<T> {
        self.points[slot::<N>(self.base, i)]
    }

    /// Point `i` of the upload.
    fn up(&self, i: usize) -> PlanPoint<T> {
        self.points[slot::<N>(self.upload, i)]
    }

    /// `PlanBegin` (`splice` false): clears the buffer for plan `id` of `len` points, refused
    /// while a plan runs. `PlanSplice` (`splice` true): an upload of `len` points into the
    /// free slots after the running plan, which goes on; `PlanSpliceRebased` (`splice` and
    /// `rebase` true): the same, re-based at its switch (module docs).
    pub(super) fn begin(
        &mut self,
        id: u16,
        len: u16,
        running: bool,
        splice: bool,
        rebase: bool,
    ) -> Result<(), CommandError> {
        if len as usize > N {
            return Err(CommandError::PlanTooLong { len, capacity: N });
        }
        if splice {
            if !running {
                return Err(CommandError::NothingToSplice);
            }
            if id == self.status.id {
                // A copy of this splice's begin (an operator re-sends it until telemetry shows
                // the id): it must not clear the upload, nor disarm a started splice.
                return if self.splice && self.rebase == rebase {
                    Ok(())
                } else {
                    Err(CommandError::OutOfRange {
                        field: "splice.id",
                        value: id as f64,
                        rule: "must differ from the running plan's id",
                    })
                };
            }
            // Slots before the current segment are read no more (it only moves forward).
            let free = N - (self.len - self.index.min(self.len));
            if len as usize > free {
                return Err(CommandError::SpliceNoRoom { len, free });
            }
            self.upload = slot::<N>(self.base, self.len);
        } else {
            if running {
                return Err(CommandError::Busy);
            }
            self.upload = 0;
        }
        self.splice = splice;
        self.rebase = splice && rebase;
        self.armed = false;
        self.started = false;
        self.status = PlanStatus {
            id,
            received: 0,
            len,
            done: false,
        };
        Ok(())
    }

    /// `PlanChunk`: stores `points` at `offset` after checking every value (a fresh plan's
    /// chunk is refused while a plan runs; a splice's is what the running plan waits for).
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
        if running && !self.splice {
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
                Some(self.up(start - 1).t)
            } else {
                None
            };
            if prev_t.is_some_and(|pt| p.t.partial_cmp(&pt) != Some(core::cmp::Ordering::Greater)) {
                return Err(CommandError::PlanTimeNotIncreasing { index: start + k });
            }
        }
        for (k, p) in points.iter().enumerate() {
            self.points[slot::<N>(self.upload, start + k)] = *p;
        }
        if end as u16 > st.received {
            self.status.received = end as u16;
        }
        Ok(())
    }

    /// `PlanStart`: checks the plan is complete and strictly increasing in time. A fresh plan
    /// rewinds to its first point: `Ok(true)`. A splice (with its plan still `running`) is
    /// checked against the running plan (module docs) and armed: `Ok(false)`, the mode does
    /// not change. `estop`: the e-stop is latched (then refused).
    ///
    /// Once per upload: a `PlanStart` of a plan already started (running or done) is an operator's
    /// retransmission whose first copy was answered by telemetry the operator lost, and is
    /// ignored, `Ok(false)` (it restarted a running plan from its first point, 1.6 mm behind
    /// the robot, under 20 % loss). Running a plan again takes a new `PlanBegin`.
    pub(super) fn start(
        &mut self,
        id: u16,
        estop: bool,
        running: bool,
    ) -> Result<bool, CommandError> {
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
            if self.up(i).t.partial_cmp(&self.up(i - 1).t) != Some(core::cmp::Ordering::Greater) {
                return Err(CommandError::PlanTimeNotIncreasing { index: i });
            }
        }
        if self.splice {
            self.check_splice(running)?;
            self.armed = true;
            self.started = true;
            return Ok(false);
        }
        self.base = self.upload;
        self.len = n;
        self.fade_end = T::zero();
        self.fade = [T::zero(); 2];
        self.time = self.up(0).t;
        self.reference_time = self.time;
        self.index = 0;
        self.status.done = false;
        self.started = true;
        Ok(true)
    }

    /// A complete splice against the running plan: its first time ahead of the plan time and
    /// before the plan's end, its first point on the plan's reference there.
    fn check_splice(&mut self, running: bool) -> Result<(), CommandError> {
        if !running || self.len < 2 {
            return Err(CommandError::NothingToSplice);
        }
        let first = self.up(0);
        let end = self.pt(self.len - 1).t;
        if !(first.t > self.time && first.t < end) {
            return Err(CommandError::SpliceOutside {
                at: first.t.to_f64(),
                now: self.time.to_f64(),
                end: end.to_f64(),
            });
        }
        // The lookup must not move the running plan's segment (slots before it may be the
        // splice's now).
        let index = self.index;
        let (pose, twist) = self.reference_at(first.t, first.pose);
        self.index = index;
        // Component by component (no square roots, names in one table: the firmware's flash
        // is tight). A re-based splice starts where the robot is: its position and velocity
        // are free.
        let free = if self.rebase { T::zero() } else { T::one() };
        let jumps = [
            (first.pose.x - pose.x) * free,
            (first.pose.y - pose.y) * free,
            first.pose.heading - pose.heading,
            (first.twist.vx - twist.vx) * free,
            (first.twist.vy - twist.vy) * free,
            first.twist.yaw_rate - twist.yaw_rate,
        ];
        for (jump, field) in jumps.iter().zip(JUMP_FIELDS) {
            let value = jump.abs().to_f64();
            if value > SPLICE_MAX_JUMP {
                return Err(CommandError::OverLimit {
                    field,
                    value,
                    limit: SPLICE_MAX_JUMP,
                });
            }
        }
        Ok(())
    }

    /// The world-frame target twist of one trajectory cycle of `dt` s at the measured `pose`:
    /// feedback against the reference at the plan time of the pose, feed-forward of the mean
    /// reference velocity over the coming cycle; advances the plan time. Returns the target and
    /// whether the plan ended (the caller then stops).
    pub(super) fn follow(&mut self, pose: Pose2<T>, dt: T, cfg: &Config<T>) -> (Twist2<T>, bool) {
        let mut rebase = false;
        if self.armed && self.time >= self.up(0).t {
            // The splice's first point is the running plan's reference at its time (or, for a
            // re-based splice, where the robot was predicted to be): switch.
            self.base = self.upload;
            self.len = self.status.len as usize;
            self.index = 0;
            self.armed = false;
            self.splice = false;
            rebase = self.rebase;
            self.rebase = false;
        }
        let (mut r, _) = self.reference_at(self.time, pose);
        let (_, plan_ff) = self.reference_at(self.time + dt * T::of(0.5), pose);
        if rebase {
            // Re-base on the measured pose: zero tracking error at the switch, the offset
            // fading no faster than the position loop's authority (module docs).
            let o = [pose.x - r.x, pose.y - r.y];
            let n = (o[0] * o[0] + o[1] * o[1]).sqrt();
            let floor = T::of(REBASE_MIN_BLEND);
            let by_speed = if cfg.max_correction > T::zero() {
                n / cfg.max_correction
            } else {
                floor
            };
            let fade_for = if by_speed > floor { by_speed } else { floor };
            self.fade = [o[0] / fade_for, o[1] / fade_for];
            self.fade_end = self.time + fade_for;
        }
        let mut ff = plan_ff;
        let left = self.fade_end - self.time;
        if left > T::zero() {
            // The offset o·(1 − (t − t₀)/T) = (o/T)·(t_end − t), and its rate −o/T.
            r.x += self.fade[0] * left;
            r.y += self.fade[1] * left;
            if left > dt * T::of(0.5) {
                ff.vx -= self.fade[0];
                ff.vy -= self.fade[1];
            }
        }
        self.reference = r;
        self.reference_time = self.time;
        self.time += dt;
        if dt > T::zero() {
            self.accel = [
                (plan_ff.vx - self.last_ff.vx) / dt,
                (plan_ff.vy - self.last_ff.vy) / dt,
            ];
        }
        self.last_ff = plan_ff;
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
        // An armed splice starts before the running plan's end: not done yet.
        let done = self.len > 0 && !self.armed && self.time >= self.pt(self.len - 1).t;
        if done {
            self.status.done = true;
        }
        (Twist2::new(ff.vx + cx, ff.vy + cy, ff.yaw_rate + cw), done)
    }

    /// Reference pose and world twist of the plan at `tau` (s): cubic Hermite in position and
    /// heading (using the sampled velocities as tangents), linear in velocity. An empty plan
    /// gives `fallback` at rest.
    fn reference_at(&mut self, tau: T, fallback: Pose2<T>) -> (Pose2<T>, Twist2<T>) {
        let n = self.len;
        if n == 0 {
            return (fallback, zero_twist());
        }
        // Points before the segment of the last lookup are read no more (a splice may have
        // overwritten them): the plan time only moves forward.
        let mut k = self.index.min(n - 1);
        let first = self.pt(k);
        if tau <= first.t {
            return (first.pose, first.twist);
        }
        let last = self.pt(n - 1);
        if tau >= last.t {
            return (last.pose, zero_twist());
        }
        // Here k + 1 < n (the last point would have returned above).
        while k + 2 < n && self.pt(k + 1).t <= tau {
            k += 1;
        }
        self.index = k;
        between(&self.pt(k), &self.pt(k + 1), tau)
    }
}
