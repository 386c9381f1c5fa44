//! Pose estimation: an extended Kalman filter over the world pose `(x, y, heading)` whose
//! prediction is the odometry step and whose corrections are external position fixes (camera,
//! motion capture), with latency compensation and an outlier gate.
//!
//! Paper 000 recommends an external camera because dead reckoning drifts; a camera frame,
//! however, arrives some tens of milliseconds after it was taken. [`PoseEstimator`] keeps the
//! last `N − 1` odometry steps in a fixed ring buffer (with the filter state after each); a fix
//! stamped in the past is applied **at its timestamp** — the step containing it is split
//! exactly on SE(2), the fix is fused there and the later steps are replayed — as WPILib's
//! `PoseEstimator` does with its odometry history (WPILib 2023+, "latency compensation"). A fix
//! whose Mahalanobis distance `d² = νᵀ S⁻¹ ν` exceeds a chi-square quantile ([`Gate`]) is
//! rejected as an outlier (the standard χ² innovation gate, Bar-Shalom, Li & Kirubarajan,
//! *Estimation with Applications to Tracking and Navigation*, 2001, §5.4).
//!
//! Everything is fixed-size (`nalgebra` 3×3 matrices, an array of `N` entries): no allocation,
//! no panic; errors are [`EstimatorError`] and leave the state unchanged.

use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

use crate::wrap_angle;
use crate::{Pose2, Real, Twist2, se2};

/// Why the estimator rejected an input. The state is left unchanged.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum EstimatorError {
    /// An input value is NaN or infinite.
    #[error("{field} must be finite")]
    NonFinite {
        /// The input's name.
        field: &'static str,
    },
    /// A standard deviation or variance is negative (or a fix's is not positive).
    #[error("{field} must be > 0 (got {value})")]
    BadNoise {
        /// The parameter's name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// An odometry step's time does not increase strictly.
    #[error("time {t} s does not increase (estimate is at {previous} s)")]
    NonMonotonicTime {
        /// The rejected time, s.
        t: f64,
        /// The estimator's current time, s.
        previous: f64,
    },
    /// A fix is older than the odometry history kept in the buffer.
    #[error("fix at {t} s is older than the oldest buffered state ({oldest} s); enlarge N")]
    FixTooOld {
        /// The fix's time, s.
        t: f64,
        /// Time of the oldest state still buffered, s.
        oldest: f64,
    },
    /// A fix is stamped after the latest odometry step (the estimator does not extrapolate).
    #[error("fix at {t} s is newer than the latest odometry step ({latest} s)")]
    FixInFuture {
        /// The fix's time, s.
        t: f64,
        /// Time of the latest odometry step, s.
        latest: f64,
    },
    /// The innovation covariance is not invertible (zero prior and fix covariance).
    #[error("innovation covariance is singular")]
    Singular,
}

/// Odometry noise model: each step adds a zero-mean error with robot-frame variances that grow
/// **linearly** with the distance travelled, the angle turned and the time elapsed (a random
/// walk, so splitting a step in two adds the same variance as the whole step):
///
/// ```text
/// σ²_x = σ²_y = translation² · s + translation_per_time² · Δt
/// σ²_θ = heading_per_distance² · s + heading_per_turn² · |Δθ| + heading_per_time² · Δt
/// ```
///
/// with `s = |(Δx, Δy)|` (m) and `Δθ` (rad) of the step. Units: `translation` in m/√m,
/// `translation_per_time` in m/√s, `heading_per_distance` in rad/√m, `heading_per_turn` in
/// rad/√rad, `heading_per_time` in rad/√s (a gyro's angle random walk when the heading comes
/// from a gyro). (The variance form of Thrun, Burgard & Fox, *Probabilistic Robotics*, 2005,
/// §5.4, made additive.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProcessNoise<T> {
    /// Translation error per √metre travelled, m/√m.
    pub translation: T,
    /// Translation error per √second, m/√s (keeps the covariance from freezing when still).
    pub translation_per_time: T,
    /// Heading error per √metre travelled, rad/√m.
    pub heading_per_distance: T,
    /// Heading error per √radian turned, rad/√rad.
    pub heading_per_turn: T,
    /// Heading error per √second, rad/√s.
    pub heading_per_time: T,
}

impl<T: Real> ProcessNoise<T> {
    /// A moderate wheel-odometry model: 2 cm/√m, 1 mm/√s, 0.02 rad/√m, 0.05 rad/√rad,
    /// 1 mrad/√s.
    pub fn wheel_odometry() -> Self {
        Self {
            translation: T::of(0.02),
            translation_per_time: T::of(0.001),
            heading_per_distance: T::of(0.02),
            heading_per_turn: T::of(0.05),
            heading_per_time: T::of(0.001),
        }
    }

    fn check(&self) -> Result<(), EstimatorError> {
        for (v, field) in [
            (self.translation, "noise.translation"),
            (self.translation_per_time, "noise.translation_per_time"),
            (self.heading_per_distance, "noise.heading_per_distance"),
            (self.heading_per_turn, "noise.heading_per_turn"),
            (self.heading_per_time, "noise.heading_per_time"),
        ] {
            if !v.is_finite() {
                return Err(EstimatorError::NonFinite { field });
            }
            if v < T::zero() {
                return Err(EstimatorError::BadNoise {
                    field,
                    value: v.to_f64(),
                });
            }
        }
        Ok(())
    }

    /// Robot-frame variances `(σ²_xy, σ²_θ)` of a step.
    pub(crate) fn variances(&self, delta: Pose2<T>, dt: T) -> (T, T) {
        self.variances_over(delta.x.hypot(delta.y), delta.heading, dt)
    }

    /// [`Self::variances`] of a step whose chord `s = |(Δx, Δy)|` (m) the caller already has.
    pub(crate) fn variances_over(&self, s: T, dheading: T, dt: T) -> (T, T) {
        let sq = |x: T| x * x;
        (
            sq(self.translation) * s + sq(self.translation_per_time) * dt,
            sq(self.heading_per_distance) * s
                + sq(self.heading_per_turn) * dheading.abs()
                + sq(self.heading_per_time) * dt,
        )
    }
}

/// Chi-square gates on the squared Mahalanobis distance of a fix's innovation: a fix is
/// rejected when `d² > position` (position-only fix, 2 degrees of freedom) or `d² > pose` (fix
/// with heading, 3 degrees of freedom).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gate<T> {
    /// Threshold for position-only fixes (χ²₂ quantile).
    pub position: T,
    /// Threshold for fixes with a heading (χ²₃ quantile).
    pub pose: T,
}

impl<T: Real> Gate<T> {
    /// The 99.9 % quantiles: χ²₂ = 13.8155, χ²₃ = 16.2662 (one good fix in 1000 rejected).
    pub fn p999() -> Self {
        Self {
            position: T::of(13.815_510_557_964_274),
            pose: T::of(16.266_236_196_238_1),
        }
    }
    /// The 99 % quantiles: χ²₂ = 9.2103, χ²₃ = 11.3449.
    pub fn p99() -> Self {
        Self {
            position: T::of(9.210_340_371_976_182),
            pose: T::of(11.344_866_730_144_373),
        }
    }
    /// No gate: every fix is fused.
    pub fn none() -> Self {
        Self {
            position: T::of(f64::INFINITY),
            pose: T::of(f64::INFINITY),
        }
    }
}

/// An external pose measurement (camera, motion capture) of the robot centre, world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fix<T> {
    /// When the measurement was **taken** (not when it arrived), s, on the odometry's clock.
    pub t: T,
    /// Measured world x, m.
    pub x: T,
    /// Measured world y, m.
    pub y: T,
    /// Measured heading, rad (any wrapping), or `None` for a position-only fix.
    pub heading: Option<T>,
    /// Standard deviation of each position coordinate, m (> 0).
    pub std_xy: T,
    /// Standard deviation of the heading, rad (> 0; unused without a heading).
    pub std_heading: T,
}

impl<T: Real> Fix<T> {
    /// A position-only fix `(x, y)` (m) taken at `t` (s) with standard deviation `std_xy` (m).
    pub fn position(t: T, x: T, y: T, std_xy: T) -> Self {
        Self {
            t,
            x,
            y,
            heading: None,
            std_xy,
            std_heading: T::one(),
        }
    }

    fn check(&self) -> Result<(), EstimatorError> {
        for (v, field) in [(self.t, "fix.t"), (self.x, "fix.x"), (self.y, "fix.y")] {
            if !v.is_finite() {
                return Err(EstimatorError::NonFinite { field });
            }
        }
        let mut stds = [(self.std_xy, "fix.std_xy"), (T::one(), "")];
        if let Some(h) = self.heading {
            if !h.is_finite() {
                return Err(EstimatorError::NonFinite {
                    field: "fix.heading",
                });
            }
            stds[1] = (self.std_heading, "fix.std_heading");
        }
        for (v, field) in stds {
            if !v.is_finite() {
                return Err(EstimatorError::NonFinite { field });
            }
            if v <= T::zero() {
                return Err(EstimatorError::BadNoise {
                    field,
                    value: v.to_f64(),
                });
            }
        }
        Ok(())
    }
}

/// What happened to a fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FixOutcome<T> {
    /// Fused at its timestamp; `mahalanobis2` is the squared Mahalanobis distance `d²` of its
    /// innovation against the prior at that time.
    Accepted {
        /// `d² = νᵀ S⁻¹ ν`.
        mahalanobis2: T,
    },
    /// Rejected by the gate (an outlier); the estimate is unchanged.
    Rejected {
        /// `d² = νᵀ S⁻¹ ν`.
        mahalanobis2: T,
        /// The threshold it exceeded.
        gate: T,
    },
}

/// Filter state at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
struct State<T> {
    t: T,
    pose: Pose2<T>,
    cov: Matrix3<T>,
}

/// One buffered odometry step: the increment ending at `t`, its noise, an optional fix fused at
/// `t`, and the posterior state after both.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Entry<T> {
    t: T,
    dt: T,
    delta: Pose2<T>,
    fix: Option<Fix<T>>,
    post: State<T>,
}

/// Extended Kalman filter over the world pose `(x, y, heading)` with odometry prediction,
/// delayed external fixes (latency compensation by replaying up to `N − 1` buffered odometry
/// steps) and a χ² outlier gate. `N ≥ 2`; `N` entries of about 20 scalars each.
///
/// * [`PoseEstimator::predict`]: one odometry step (its robot-frame increment
///   [`crate::estimate::odometry::OdometryStep::delta`]), `x⁺ = x ⊕ Δ`, `P⁺ = F P Fᵀ + G Q Gᵀ` with
///   `F = ∂(x ⊕ Δ)/∂x` and `G` the rotation of the robot frame (EKF on the SE(2) composition).
/// * [`PoseEstimator::add_fix`]: a measurement of `(x, y)` or `(x, y, heading)` taken at
///   `fix.t` in the past; linear update with Joseph-form covariance, heading innovation wrapped
///   into `(−π, π]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseEstimator<T, const N: usize> {
    noise: ProcessNoise<T>,
    gate: Gate<T>,
    /// State just before the oldest buffered entry.
    base: State<T>,
    buf: [Entry<T>; N],
    /// Index of the oldest entry in `buf`.
    head: usize,
    len: usize,
    rejected_in_a_row: u32,
}

impl<T: Real, const N: usize> PoseEstimator<T, N> {
    /// A filter at time `t` (s) with the initial pose `pose` and its covariance `cov` (m², rad²;
    /// order x, y, heading), the odometry noise model `noise` and the 99.9 % gate.
    ///
    /// # Errors
    /// [`EstimatorError::NonFinite`] / [`EstimatorError::BadNoise`] for a non-finite input, a
    /// negative noise parameter or a covariance with a negative diagonal.
    pub fn new(
        t: T,
        pose: Pose2<T>,
        cov: Matrix3<T>,
        noise: ProcessNoise<T>,
    ) -> Result<Self, EstimatorError> {
        const { assert!(N >= 2, "PoseEstimator needs N >= 2 buffer entries") };
        noise.check()?;
        let state = checked_state(t, pose, cov)?;
        let entry = Entry {
            t,
            dt: T::zero(),
            delta: Pose2::new(T::zero(), T::zero(), T::zero()),
            fix: None,
            post: state,
        };
        Ok(Self {
            noise,
            gate: Gate::p999(),
            base: state,
            buf: [entry; N],
            head: 0,
            len: 0,
            rejected_in_a_row: 0,
        })
    }

    /// Replaces the outlier gate.
    pub fn with_gate(mut self, gate: Gate<T>) -> Self {
        self.gate = gate;
        self
    }

    /// Restarts at time `t` with `pose` and `cov`, forgetting the history (e.g. after a
    /// kidnapping or when the gate has rejected many fixes in a row).
    ///
    /// # Errors
    /// As [`PoseEstimator::new`].
    pub fn reset(&mut self, t: T, pose: Pose2<T>, cov: Matrix3<T>) -> Result<(), EstimatorError> {
        self.base = checked_state(t, pose, cov)?;
        self.head = 0;
        self.len = 0;
        self.rejected_in_a_row = 0;
        Ok(())
    }

    /// The current estimate (world frame; m, m, rad unwrapped).
    pub fn pose(&self) -> Pose2<T> {
        self.current().pose
    }

    /// The current covariance (m², rad²; order x, y, heading).
    pub fn covariance(&self) -> Matrix3<T> {
        self.current().cov
    }

    /// Time of the current estimate, s.
    pub fn time(&self) -> T {
        self.current().t
    }

    /// Oldest time a fix may carry, s (older fixes get [`EstimatorError::FixTooOld`]): the
    /// state before the oldest buffered step, or, when fixes have filled all `N` entries since
    /// the last prediction, the end of the oldest step.
    pub fn oldest_time(&self) -> T {
        if self.len == N {
            self.buf[self.head].t
        } else {
            self.base.t
        }
    }

    /// Number of fixes rejected by the gate since the last accepted one: a long run means the
    /// estimate has diverged (or the camera is wrong) and the caller may [`Self::reset`].
    pub fn rejected_in_a_row(&self) -> u32 {
        self.rejected_in_a_row
    }

    fn current(&self) -> &State<T> {
        if self.len == 0 {
            &self.base
        } else {
            &self.buf[self.index(self.len - 1)].post
        }
    }

    #[inline]
    fn index(&self, k: usize) -> usize {
        (self.head + k) % N
    }

    /// State just before buffered entry `k` (the base for `k = 0`).
    fn before(&self, k: usize) -> State<T> {
        if k == 0 {
            self.base
        } else {
            self.buf[self.index(k - 1)].post
        }
    }

    /// Drops the oldest entry, folding it into the base.
    fn evict(&mut self) {
        if self.len > 0 {
            self.base = self.buf[self.head].post;
            self.head = (self.head + 1) % N;
            self.len -= 1;
        }
    }

    /// EKF prediction through the robot-frame increment `delta` lasting `dt`.
    fn propagate(&self, s: &State<T>, t: T, delta: Pose2<T>, dt: T) -> State<T> {
        let (sn, cs) = s.pose.heading.sin_cos();
        let (z, one) = (T::zero(), T::one());
        let f = Matrix3::new(
            one,
            z,
            -sn * delta.x - cs * delta.y,
            z,
            one,
            cs * delta.x - sn * delta.y,
            z,
            z,
            one,
        );
        // Q is isotropic in x, y, so rotating it into the world frame leaves it diagonal.
        let (qxy, qth) = self.noise.variances(delta, dt);
        let q = Matrix3::from_diagonal(&Vector3::new(qxy, qxy, qth));
        let cov = f * s.cov * f.transpose() + q;
        State {
            t,
            pose: se2::compose(s.pose, delta),
            cov: symmetric(cov),
        }
    }

    /// Innovation, its covariance inverse and `d²` of `fix` against `s`, then the updated state.
    fn correct(&self, s: &State<T>, fix: &Fix<T>) -> Result<(T, State<T>), EstimatorError> {
        let vxy = fix.std_xy * fix.std_xy;
        match fix.heading {
            Some(h) => {
                let nu = Vector3::new(
                    fix.x - s.pose.x,
                    fix.y - s.pose.y,
                    wrap_angle(h - s.pose.heading),
                );
                let r = Matrix3::from_diagonal(&Vector3::new(
                    vxy,
                    vxy,
                    fix.std_heading * fix.std_heading,
                ));
                let sm = s.cov + r;
                let si = sm.try_inverse().ok_or(EstimatorError::Singular)?;
                let d2 = (nu.transpose() * si * nu)[0];
                let k = s.cov * si;
                let dx = k * nu;
                let ikh = Matrix3::identity() - k;
                let cov = ikh * s.cov * ikh.transpose() + k * r * k.transpose();
                Ok((
                    d2,
                    State {
                        t: s.t,
                        pose: Pose2::new(
                            s.pose.x + dx[0],
                            s.pose.y + dx[1],
                            s.pose.heading + dx[2],
                        ),
                        cov: symmetric(cov),
                    },
                ))
            }
            None => {
                let nu = Vector2::new(fix.x - s.pose.x, fix.y - s.pose.y);
                let r = Matrix2::from_diagonal(&Vector2::new(vxy, vxy));
                let sm = s.cov.fixed_view::<2, 2>(0, 0).into_owned() + r;
                let si = sm.try_inverse().ok_or(EstimatorError::Singular)?;
                let d2 = (nu.transpose() * si * nu)[0];
                // K = P Hᵀ S⁻¹ with H = [I₂ 0].
                let pht = s.cov.fixed_view::<3, 2>(0, 0).into_owned();
                let k = pht * si;
                let dx = k * nu;
                let mut kh = Matrix3::zeros();
                kh.fixed_view_mut::<3, 2>(0, 0).copy_from(&k);
                let ikh = Matrix3::identity() - kh;
                let cov = ikh * s.cov * ikh.transpose() + k * r * k.transpose();
                Ok((
                    d2,
                    State {
                        t: s.t,
                        pose: Pose2::new(
                            s.pose.x + dx[0],
                            s.pose.y + dx[1],
                            s.pose.heading + dx[2],
                        ),
                        cov: symmetric(cov),
                    },
                ))
            }
        }
    }

    /// **Prediction** with one odometry step ending at `t` (s) whose pose change in the robot
    /// frame at its start is `delta` (m, m, rad): typically
    /// [`crate::estimate::odometry::OdometryStep::delta`]. Returns the new estimate. When the buffer is
    /// full the oldest step is forgotten (fixes older than it become
    /// [`EstimatorError::FixTooOld`]).
    ///
    /// # Errors
    /// [`EstimatorError::NonFinite`], or [`EstimatorError::NonMonotonicTime`] when `t` does not
    /// exceed [`PoseEstimator::time`].
    pub fn predict(&mut self, t: T, delta: Pose2<T>) -> Result<Pose2<T>, EstimatorError> {
        for (v, field) in [
            (t, "t"),
            (delta.x, "delta.x"),
            (delta.y, "delta.y"),
            (delta.heading, "delta.heading"),
        ] {
            if !v.is_finite() {
                return Err(EstimatorError::NonFinite { field });
            }
        }
        let cur = *self.current();
        let dt = t - cur.t;
        if dt.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
            return Err(EstimatorError::NonMonotonicTime {
                t: t.to_f64(),
                previous: cur.t.to_f64(),
            });
        }
        let post = self.propagate(&cur, t, delta, dt);
        // Keep one slot free so that a fix can always split a step.
        while self.len >= N - 1 {
            self.evict();
        }
        let i = self.index(self.len);
        self.buf[i] = Entry {
            t,
            dt,
            delta,
            fix: None,
            post,
        };
        self.len += 1;
        Ok(post.pose)
    }

    /// **Correction** with an external fix taken at `fix.t` (s), which may lie in the past (up
    /// to [`PoseEstimator::oldest_time`]). The filter state at `fix.t` is reconstructed (the
    /// odometry step containing `fix.t` is split exactly: `Δ = exp(ξ)`, parts `exp(fξ)` and
    /// `exp((1−f)ξ)`, with its noise split in proportion), the fix is gated and fused there, and
    /// the later steps (and fixes already fused after `fix.t`) are replayed.
    ///
    /// # Errors
    /// [`EstimatorError::NonFinite`] / [`EstimatorError::BadNoise`] for a bad fix,
    /// [`EstimatorError::FixTooOld`], [`EstimatorError::FixInFuture`],
    /// [`EstimatorError::Singular`]. A rejected outlier is not an error:
    /// [`FixOutcome::Rejected`].
    pub fn add_fix(&mut self, fix: &Fix<T>) -> Result<FixOutcome<T>, EstimatorError> {
        fix.check()?;
        let latest = self.current().t;
        if fix.t > latest {
            return Err(EstimatorError::FixInFuture {
                t: fix.t.to_f64(),
                latest: latest.to_f64(),
            });
        }
        let oldest = self.oldest_time();
        if fix.t < oldest {
            return Err(EstimatorError::FixTooOld {
                t: fix.t.to_f64(),
                oldest: oldest.to_f64(),
            });
        }
        let gate_of = |f: &Fix<T>| {
            if f.heading.is_some() {
                self.gate.pose
            } else {
                self.gate.position
            }
        };
        let gate = gate_of(fix);

        // Fix exactly at the base time: correct the base, replay everything.
        if fix.t == self.base.t {
            let (d2, post) = self.correct(&self.base, fix)?;
            if d2
                .partial_cmp(&gate)
                .is_none_or(|o| o == core::cmp::Ordering::Greater)
            {
                return Ok(self.reject(d2, gate));
            }
            self.base = post;
            self.replay(0)?;
            self.rejected_in_a_row = 0;
            return Ok(FixOutcome::Accepted { mahalanobis2: d2 });
        }

        // First entry ending at or after the fix.
        let mut k = 0;
        while k < self.len && self.buf[self.index(k)].t < fix.t {
            k += 1;
        }
        // k < len here because base.t < fix.t <= latest.
        let entry = self.buf[self.index(k)];
        let prev = self.before(k);
        let attach = fix.t == entry.t && entry.fix.is_none();
        if attach {
            // Prior at the fix time: after the step (and before any fix, none here).
            let prior = self.propagate(&prev, entry.t, entry.delta, entry.dt);
            let (d2, _) = self.correct(&prior, fix)?;
            if d2
                .partial_cmp(&gate)
                .is_none_or(|o| o == core::cmp::Ordering::Greater)
            {
                return Ok(self.reject(d2, gate));
            }
            let i = self.index(k);
            self.buf[i].fix = Some(*fix);
            self.replay(k)?;
            self.rejected_in_a_row = 0;
            return Ok(FixOutcome::Accepted { mahalanobis2: d2 });
        }

        // Split entry k at the fix time.
        let f = (fix.t - prev.t) / entry.dt;
        let xi = se2_log(entry.delta);
        let first = se2::twist_exp(xi, f);
        let second = se2::twist_exp(xi, T::one() - f);
        let dt1 = fix.t - prev.t;
        let prior = self.propagate(&prev, fix.t, first, dt1);
        let (d2, _) = self.correct(&prior, fix)?;
        if d2
            .partial_cmp(&gate)
            .is_none_or(|o| o == core::cmp::Ordering::Greater)
        {
            return Ok(self.reject(d2, gate));
        }
        if self.len == N {
            if k == 0 {
                return Err(EstimatorError::FixTooOld {
                    t: fix.t.to_f64(),
                    oldest: self.buf[self.head].t.to_f64(),
                });
            }
            self.evict();
            k -= 1;
        }
        // Shift entries k.. one slot towards the end.
        let mut j = self.len;
        while j > k {
            let (dst, src) = (self.index(j), self.index(j - 1));
            self.buf[dst] = self.buf[src];
            j -= 1;
        }
        self.len += 1;
        let (i0, i1) = (self.index(k), self.index(k + 1));
        self.buf[i0] = Entry {
            t: fix.t,
            dt: dt1,
            delta: first,
            fix: Some(*fix),
            post: prior,
        };
        self.buf[i1] = Entry {
            t: entry.t,
            dt: entry.dt - dt1,
            delta: second,
            fix: entry.fix,
            post: entry.post,
        };
        self.replay(k)?;
        self.rejected_in_a_row = 0;
        Ok(FixOutcome::Accepted { mahalanobis2: d2 })
    }

    fn reject(&mut self, mahalanobis2: T, gate: T) -> FixOutcome<T> {
        self.rejected_in_a_row = self.rejected_in_a_row.saturating_add(1);
        FixOutcome::Rejected { mahalanobis2, gate }
    }

    /// Recomputes the posterior of entries `k..len` from the state before entry `k`.
    fn replay(&mut self, k: usize) -> Result<(), EstimatorError> {
        let mut s = self.before(k);
        for j in k..self.len {
            let i = self.index(j);
            let e = self.buf[i];
            s = self.propagate(&s, e.t, e.delta, e.dt);
            if let Some(fix) = e.fix {
                s = self.correct(&s, &fix)?.1;
            }
            self.buf[i].post = s;
        }
        Ok(())
    }
}

/// The SE(2) logarithm: the robot-frame "unit-time" twist `ξ` with `twist_exp(ξ, 1) = delta`.
/// Uses `twist_exp((1, 0, θ), 1) = (sinθ/θ, (1−cosθ)/θ, θ)` for the entries of `V(θ)`.
pub(crate) fn se2_log<T: Real>(delta: Pose2<T>) -> Twist2<T> {
    let v = se2::twist_exp(Twist2::new(T::one(), T::zero(), delta.heading), T::one());
    let (a, b) = (v.x, v.y);
    let det = a * a + b * b;
    // V = [[a, −b], [b, a]]  ⇒  V⁻¹ = [[a, b], [−b, a]] / det. det ≥ (2/π)² for |θ| ≤ π; for
    // larger steps it stays positive except at θ = 2πk (k ≠ 0), where V is singular.
    if det > T::EPSILON {
        Twist2::new(
            (a * delta.x + b * delta.y) / det,
            (-b * delta.x + a * delta.y) / det,
            delta.heading,
        )
    } else {
        Twist2::new(delta.x, delta.y, delta.heading)
    }
}

fn symmetric<T: Real>(m: Matrix3<T>) -> Matrix3<T> {
    (m + m.transpose()) * T::of(0.5)
}

fn checked_state<T: Real>(
    t: T,
    pose: Pose2<T>,
    cov: Matrix3<T>,
) -> Result<State<T>, EstimatorError> {
    for (v, field) in [
        (t, "t"),
        (pose.x, "pose.x"),
        (pose.y, "pose.y"),
        (pose.heading, "pose.heading"),
    ] {
        if !v.is_finite() {
            return Err(EstimatorError::NonFinite { field });
        }
    }
    if !cov.iter().all(|v| v.is_finite()) {
        return Err(EstimatorError::NonFinite { field: "cov" });
    }
    for (i, field) in ["cov[0,0]", "cov[1,1]", "cov[2,2]"].into_iter().enumerate() {
        if cov[(i, i)] < T::zero() {
            return Err(EstimatorError::BadNoise {
                field,
                value: cov[(i, i)].to_f64(),
            });
        }
    }
    Ok(State {
        t,
        pose,
        cov: symmetric(cov),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_inverts_exp() {
        for &(vx, vy, w) in &[
            (0.3, -0.1, 0.0),
            (0.3, 0.2, 1.0),
            (-0.5, 0.0, -2.5),
            (0.0, 0.0, 0.7),
            (0.1, 0.0, 1e-5),
        ] {
            let xi = Twist2::new(vx, vy, w);
            let back = se2_log(se2::twist_exp(xi, 1.0f64));
            assert!(
                (back.vx - vx).abs() < 1e-12 && (back.vy - vy).abs() < 1e-12,
                "{xi:?} -> {back:?}"
            );
            // Splitting at f and composing gives the whole step back.
            let f = 0.37;
            let p = se2::compose(se2::twist_exp(xi, f), se2::twist_exp(xi, 1.0 - f));
            let d = se2::twist_exp(xi, 1.0);
            assert!((p.x - d.x).abs() < 1e-12 && (p.y - d.y).abs() < 1e-12);
        }
    }
}
