//! Pose fusion a robot can rely on: an extended Kalman filter over the world pose **and** the
//! gyro bias and a common wheel-scale factor, corrected by delayed external fixes (camera,
//! motion capture), with a history sized by **time**, gate recovery and initialisation from
//! the first fix.
//!
//! State `x = (x, y, θ, b, k)`: world position (m), heading (rad, unwrapped), gyro bias `b`
//! (rad/s) and the common wheel-scale factor `k` (true wheel travel / measured, 1 nominal).
//! An odometry step with the measured robot-frame increment `Δ = (Δx, Δy, Δθ)` over `Δt`
//! ([`crate::estimate::odometry::OdometryStep::delta`]) predicts
//!
//! ```text
//! (x, y)⁺ = (x, y) + R(θ) · k (Δx, Δy)
//! θ⁺      = θ + k Δθ          heading from the wheels  (StepHeading::Wheels)
//!         = θ + Δθ − b Δt     heading from a gyro      (StepHeading::Gyro)
//!         = θ + Δθ            heading from an absolute yaw (StepHeading::Absolute)
//! b⁺ = b + w_b,  k⁺ = k + w_k  (random walks, σ²_b = gyro_bias_walk² Δt, σ²_k = scale_walk² s)
//! ```
//!
//! (the scale of the chord's direction within one step is second order and neglected). Which
//! of `b`, `k` is observable depends on the heading source: `b` only with a gyro, `k` from
//! position fixes while the robot moves. A state switched off in [`FusionConfig`] keeps zero
//! variance and never moves. A common scale is what position fixes can separate from the
//! heading on every kind; per-wheel scales are not estimated.
//!
//! **History by time.** The filter keeps at most `N` odometry entries (a const generic, no
//! allocation) but sizes them by time: consecutive steps are merged into one entry until it
//! spans `max_latency / (N/2)` seconds, so half the buffer always covers
//! [`FusionConfig::max_latency`] whatever the encoder rate (1 kHz encoders and a 1 s latency
//! with `N = 256`: 7.8 ms per entry). A fix taken up to `max_latency` before the latest step is
//! applied **at its time** (the entry containing it split on SE(2), the later entries
//! replayed, as WPILib's pose estimator does); an older one is [`FusionError::TooLate`].
//!
//! **Covariance at the slot rate.** The steps merged into the newest entry move only its
//! increment (a composition on SE(2) and a few sums); the pose after it is the mean of one
//! prediction through the merged increment from the state before the entry (with that state's
//! heading rotation kept from when the entry opened), and its 5 × 5 covariance step runs
//! **once per entry** — when the entry closes, or when a fix or a caller asks for it
//! ([`PoseFusion::pose_covariance`], [`PoseFusion::state`]). This is the prediction a replay
//! after a fix makes anyway (replays go through whole entries), so a filter that receives no
//! fix ends exactly where one that fused a fix of zero weight would. The pose variances alone
//! ([`PoseFusion::pose_variances`]) cost three quadratic forms of the sparse Jacobian, cheap
//! enough for every control cycle.
//!
//! **Gate and recovery.** A fix whose squared Mahalanobis distance exceeds the χ² gate is
//! rejected (Bar-Shalom, Li & Kirubarajan 2001, §5.4). After
//! [`FusionConfig::recovery_count`] rejections in a row the filter recovers: when their
//! innovations agree within [`FusionConfig::recovery_spread`] (the estimate is off, not the
//! camera) the pose is **re-initialised** at the latest fix with its heading variance inflated
//! ([`Recovery::Reinitialised`]); otherwise the pose covariance is **inflated** until the
//! latest fix passes and it is fused ([`Recovery::Inflated`]). Either way a run of rejections
//! ends after at most `recovery_count` fixes: never-ending rejection is impossible.
//!
//! **Initialisation.** [`PoseFusion::awaiting_fix`] starts without a pose; the first fix sets
//! the position (and the heading when it has one) — a start far from the origin is no outlier.

use nalgebra::{Matrix2, Matrix3, SMatrix, SVector, Vector2, Vector3};

use super::fix::{Fix, Gate};
use super::noise::ProcessNoise;
use super::posterior::Posterior;
use crate::{Pose2, Real, se2, wrap_angle};

/// Number of states: x, y, θ, gyro bias, wheel scale.
pub const STATES: usize = 5;
/// Most consecutive rejections remembered for the recovery test.
pub const MAX_RECOVERY_COUNT: u32 = 16;

type Vec5<T> = SVector<T, STATES>;
type Mat5<T> = SMatrix<T, STATES, STATES>;

/// Why the filter refused an input. The state is left unchanged.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum FusionError {
    /// An input value is NaN or infinite.
    #[error("{field} must be finite")]
    NonFinite {
        /// The input's name.
        field: &'static str,
    },
    /// A configuration value or a fix's standard deviation is out of range.
    #[error("{field}: {rule} (got {value})")]
    BadParameter {
        /// The parameter's name.
        field: &'static str,
        /// The rule it breaks.
        rule: &'static str,
        /// The value given.
        value: f64,
    },
    /// An odometry step's time does not increase strictly.
    #[error("time {t} s does not increase (estimate is at {previous} s)")]
    NonMonotonicTime {
        /// The rejected time, s.
        t: f64,
        /// The filter's current time, s.
        previous: f64,
    },
    /// A fix taken before the oldest state kept (more than `max_latency` ago).
    #[error("fix taken at {t} s arrived too late: the history starts at {oldest} s (max_latency)")]
    TooLate {
        /// The fix's time, s.
        t: f64,
        /// Oldest time a fix may carry, s.
        oldest: f64,
    },
    /// A fix stamped after the latest odometry step (the filter does not extrapolate).
    #[error("fix at {t} s is newer than the latest odometry step ({latest} s)")]
    InFuture {
        /// The fix's time, s.
        t: f64,
        /// Time of the latest step, s.
        latest: f64,
    },
}

/// Where an odometry step's heading change came from (decides which of gyro bias and wheel
/// scale enter it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepHeading {
    /// Wheels' forward kinematics: the heading change scales with the wheel scale `k`.
    Wheels,
    /// An integrated gyro rate: the heading change is biased by `b Δt`.
    Gyro,
    /// An absolute yaw (AHRS, magnetometer): neither bias nor scale.
    Absolute,
}

/// Filter parameters. [`FusionConfig::default`] gives the values `omnikin odometry` uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FusionConfig<T> {
    /// Odometry noise of the measured increments.
    pub noise: ProcessNoise<T>,
    /// Gyro-bias random walk, rad/s/√s (≥ 0). Default 1e-4.
    pub gyro_bias_walk: T,
    /// Wheel-scale random walk per √metre travelled, 1/√m (≥ 0). Default 1e-4.
    pub scale_walk: T,
    /// Prior standard deviation of the gyro bias, rad/s (≥ 0; 0 switches the state off).
    /// Default 0.02.
    pub gyro_bias_std: T,
    /// Prior standard deviation of the wheel scale (≥ 0; 0 switches the state off). Default 0.05.
    pub scale_std: T,
    /// Oldest fix, s before the latest odometry step, that is still fused at its time (> 0).
    /// Default 1.
    pub max_latency: T,
    /// χ² gate of the fixes. Default [`Gate::p999`].
    pub gate: Gate<T>,
    /// Rejections in a row that trigger a recovery, 1..=[`MAX_RECOVERY_COUNT`]. Default 5.
    pub recovery_count: u32,
    /// Largest distance of a rejected fix's innovation from the mean of the run for the run to
    /// count as agreeing (re-initialisation), m (> 0). Default 0.05.
    pub recovery_spread: T,
    /// Heading standard deviation added on a re-initialisation from a position-only fix, rad
    /// (≥ 0). Default 0.2.
    pub recovery_heading_std: T,
    /// Heading standard deviation before the first fix of [`PoseFusion::awaiting_fix`], rad
    /// (> 0). Default 0.5.
    pub unknown_heading_std: T,
}

impl<T: Real> Default for FusionConfig<T> {
    fn default() -> Self {
        Self {
            noise: ProcessNoise::wheel_odometry(),
            gyro_bias_walk: T::of(1e-4),
            scale_walk: T::of(1e-4),
            gyro_bias_std: T::of(0.02),
            scale_std: T::of(0.05),
            max_latency: T::one(),
            gate: Gate::p999(),
            recovery_count: 5,
            recovery_spread: T::of(0.05),
            recovery_heading_std: T::of(0.2),
            unknown_heading_std: T::of(0.5),
        }
    }
}

impl<T: Real> FusionConfig<T> {
    fn check(&self) -> Result<(), FusionError> {
        let bad = |field, rule, value: T| {
            Err(FusionError::BadParameter {
                field,
                rule,
                value: value.to_f64(),
            })
        };
        let n = &self.noise;
        for (v, field) in [
            (n.translation, "noise.translation"),
            (n.translation_per_time, "noise.translation_per_time"),
            (n.heading_per_distance, "noise.heading_per_distance"),
            (n.heading_per_turn, "noise.heading_per_turn"),
            (n.heading_per_time, "noise.heading_per_time"),
            (self.gyro_bias_walk, "gyro_bias_walk"),
            (self.scale_walk, "scale_walk"),
            (self.gyro_bias_std, "gyro_bias_std"),
            (self.scale_std, "scale_std"),
            (self.recovery_heading_std, "recovery_heading_std"),
        ] {
            if !v.is_finite() {
                return Err(FusionError::NonFinite { field });
            }
            if v < T::zero() {
                return bad(field, "must be >= 0", v);
            }
        }
        for (v, field) in [
            (self.max_latency, "max_latency"),
            (self.recovery_spread, "recovery_spread"),
            (self.unknown_heading_std, "unknown_heading_std"),
        ] {
            if !(v.is_finite() && v > T::zero()) {
                return bad(field, "must be a finite number > 0", v);
            }
        }
        if !(self.gate.position > T::zero() && self.gate.pose > T::zero()) {
            return bad("gate", "thresholds must be > 0", self.gate.position);
        }
        if self.recovery_count == 0 || self.recovery_count > MAX_RECOVERY_COUNT {
            return bad(
                "recovery_count",
                "must be in 1..=MAX_RECOVERY_COUNT (16)",
                T::of(self.recovery_count as f64),
            );
        }
        Ok(())
    }
}

/// How a run of rejected fixes ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recovery {
    /// The rejected fixes agreed with each other: the pose was re-initialised at the latest.
    Reinitialised,
    /// They did not: the pose covariance was inflated until the latest fix passed the gate.
    Inflated,
}

/// What happened to a fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FusionOutcome<T> {
    /// The first fix of a filter started with [`PoseFusion::awaiting_fix`]: it set the pose.
    Initialised,
    /// Fused at its time; `mahalanobis2` is `d² = νᵀ S⁻¹ ν` against the prior there.
    Accepted {
        /// `d²`.
        mahalanobis2: T,
    },
    /// Rejected by the gate; the estimate is unchanged.
    Rejected {
        /// `d²`.
        mahalanobis2: T,
        /// The threshold it exceeded.
        gate: T,
    },
    /// It ended a run of `rejected` rejections in a row by a recovery, and was fused.
    Recovered {
        /// Re-initialised or inflated.
        recovery: Recovery,
        /// Rejections before it.
        rejected: u32,
    },
}

/// A filter state while it is computed on (the history stores it as a [`Posterior`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct State<T> {
    t: T,
    x: Vec5<T>,
    p: Mat5<T>,
}

impl<T: Real> State<T> {
    /// The stored form (mean, covariance triangle; the time is the entry's).
    fn packed(&self) -> Posterior<T> {
        Posterior::pack(&self.x, &self.p)
    }

    /// The state stored as `post` at time `t`.
    fn at(t: T, post: &Posterior<T>) -> Self {
        Self {
            t,
            x: post.x,
            p: post.covariance(),
        }
    }
}

/// A fix kept in the history: [`Fix`] without its time, which is the end time of the entry
/// that holds it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct StoredFix<T> {
    x: T,
    y: T,
    heading: Option<T>,
    std_xy: T,
    std_heading: T,
}

impl<T: Real> StoredFix<T> {
    fn of(f: &Fix<T>) -> Self {
        Self {
            x: f.x,
            y: f.y,
            heading: f.heading,
            std_xy: f.std_xy,
            std_heading: f.std_heading,
        }
    }

    /// The fix, taken at `t`.
    fn at(&self, t: T) -> Fix<T> {
        Fix {
            t,
            x: self.x,
            y: self.y,
            heading: self.heading,
            std_xy: self.std_xy,
            std_heading: self.std_heading,
        }
    }
}

/// What a fix did at its time, re-applied on every replay.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Action<T> {
    /// Kalman update.
    Fuse,
    /// Pose from the fix, covariance reset (heading variance given).
    Reinit(T),
    /// Pose covariance multiplied by the factor, then a Kalman update.
    Inflate(T),
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Entry<T> {
    /// End time, s.
    t: T,
    dt: T,
    /// Measured robot-frame increment (uncorrected).
    delta: Pose2<T>,
    /// Travelled distance (for the scale walk), m.
    dist: T,
    /// Accumulated robot-frame variances `(σ²_xy, σ²_θ)`.
    q: (T, T),
    heading: StepHeading,
    /// A fix applied at the entry's end time `t`, and what it did.
    event: Option<(StoredFix<T>, Action<T>)>,
    /// The state at `t` (after the event).
    post: Posterior<T>,
}

/// The fusion filter; `N ≥ 8` history entries of 37 scalars each (an increment with its
/// noise, a fix, the mean and covariance triangle after it: 148 bytes in `f32`, 288 in `f64`;
/// `N = 256`, f64: ≈ 74 kB). See the module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseFusion<T, const N: usize> {
    config: FusionConfig<T>,
    slot: T,
    /// The state before the oldest kept entry, and its time.
    base: Posterior<T>,
    base_t: T,
    buf: [Entry<T>; N],
    head: usize,
    len: usize,
    initialised: bool,
    rejected_in_a_row: u32,
    /// Position innovations of the current run of rejections (ring).
    innovations: [Vector2<T>; MAX_RECOVERY_COUNT as usize],
    /// The newest entry still takes steps and its `post` is not computed yet (module docs:
    /// it is computed from the state before the entry when the entry closes or on demand).
    open: bool,
    /// Sine and cosine of the heading of the state before the open entry.
    open_rot: (T, T),
}

/// The non-zero off-diagonal entries of a prediction's Jacobian `F = ∂x⁺/∂x` (its diagonal
/// is 1): rows x, y against θ and k, row θ against b (gyro heading) or k (wheel heading).
#[derive(Clone, Copy, Debug)]
struct Jacobian<T> {
    f02: T,
    f12: T,
    f04: T,
    f14: T,
    f23: T,
    f24: T,
}

fn finite<T: Real>(v: T, field: &'static str) -> Result<(), FusionError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(FusionError::NonFinite { field })
    }
}

impl<T: Real, const N: usize> PoseFusion<T, N> {
    /// A filter at time `t` (s) with the known pose `pose` and its covariance `cov` (m², rad²;
    /// order x, y, heading), the gyro bias starting at 0 and the scale at 1 with the prior
    /// standard deviations of `config`.
    ///
    /// # Errors
    /// [`FusionError::NonFinite`] / [`FusionError::BadParameter`] for a bad input or config (a
    /// negative covariance diagonal included).
    pub fn new(
        t: T,
        pose: Pose2<T>,
        cov: Matrix3<T>,
        config: FusionConfig<T>,
    ) -> Result<Self, FusionError> {
        Self::check_inputs(t, pose, cov, &config)?;
        Ok(Self::new_checked(t, pose, cov, config))
    }

    /// The checks of [`PoseFusion::new`], without building the filter.
    ///
    /// # Errors
    /// As [`PoseFusion::new`].
    pub(crate) fn check_inputs(
        t: T,
        pose: Pose2<T>,
        cov: Matrix3<T>,
        config: &FusionConfig<T>,
    ) -> Result<(), FusionError> {
        config.check()?;
        check_initial(t, pose, cov)
    }

    /// [`PoseFusion::new`] for inputs [`PoseFusion::check_inputs`] accepted: no `Result`
    /// around the `N`-entry filter, which the runtime builds inside its own constructor.
    pub(crate) fn new_checked(
        t: T,
        pose: Pose2<T>,
        cov: Matrix3<T>,
        config: FusionConfig<T>,
    ) -> Self {
        const { assert!(N >= 8, "PoseFusion needs N >= 8 history entries") };
        let base = initial_state(t, pose, cov, &config).packed();
        let entry = Entry {
            t,
            dt: T::zero(),
            delta: Pose2::new(T::zero(), T::zero(), T::zero()),
            dist: T::zero(),
            q: (T::zero(), T::zero()),
            heading: StepHeading::Wheels,
            event: None,
            post: base,
        };
        Self {
            config,
            slot: config.max_latency / T::of((N / 2) as f64),
            base,
            base_t: t,
            buf: [entry; N],
            head: 0,
            len: 0,
            initialised: true,
            rejected_in_a_row: 0,
            innovations: [Vector2::zeros(); MAX_RECOVERY_COUNT as usize],
            open: false,
            open_rot: (T::zero(), T::one()),
        }
    }

    /// Restarts the filter in place at time `t` (s) with the known pose `pose` and its
    /// covariance `cov`, as [`PoseFusion::new`] with the same configuration would (gyro bias and
    /// scale back at their priors, the history forgotten) — without building a second filter
    /// (its history is `N` entries: on a microcontroller's stack that matters).
    ///
    /// # Errors
    /// As [`PoseFusion::new`] for `t`, `pose` and `cov`; the filter is then unchanged.
    pub fn restart(&mut self, t: T, pose: Pose2<T>, cov: Matrix3<T>) -> Result<(), FusionError> {
        check_initial(t, pose, cov)?;
        self.base = initial_state(t, pose, cov, &self.config).packed();
        self.base_t = t;
        self.head = 0;
        self.len = 0;
        self.open = false;
        self.initialised = true;
        self.rejected_in_a_row = 0;
        Ok(())
    }

    /// [`PoseFusion::new_checked`] in place: the filter becomes the one `new_checked` would
    /// build, its whole history cleared, without a second `N`-entry filter on the stack (a
    /// firmware's runtime lives in a `static`, [`crate::runtime::Runtime::reset`]).
    pub(crate) fn reset_checked(
        &mut self,
        t: T,
        pose: Pose2<T>,
        cov: Matrix3<T>,
        config: FusionConfig<T>,
    ) {
        let base = initial_state(t, pose, cov, &config).packed();
        let entry = Entry {
            t,
            dt: T::zero(),
            delta: Pose2::new(T::zero(), T::zero(), T::zero()),
            dist: T::zero(),
            q: (T::zero(), T::zero()),
            heading: StepHeading::Wheels,
            event: None,
            post: base,
        };
        self.config = config;
        self.slot = config.max_latency / T::of((N / 2) as f64);
        self.base = base;
        self.base_t = t;
        for e in self.buf.iter_mut() {
            *e = entry;
        }
        self.head = 0;
        self.len = 0;
        self.initialised = true;
        self.rejected_in_a_row = 0;
        self.innovations = [Vector2::zeros(); MAX_RECOVERY_COUNT as usize];
        self.open = false;
        self.open_rot = (T::zero(), T::one());
    }

    /// A filter at time `t` (s) that does not know where it is: the first fix sets the
    /// position (and the heading if the fix has one; otherwise the heading starts at
    /// `heading_guess` rad with [`FusionConfig::unknown_heading_std`]). Until then the pose is
    /// the origin moved by the odometry.
    ///
    /// # Errors
    /// As [`PoseFusion::new`].
    pub fn awaiting_fix(
        t: T,
        heading_guess: T,
        config: FusionConfig<T>,
    ) -> Result<Self, FusionError> {
        let s = config.unknown_heading_std;
        let mut f = Self::new(
            t,
            Pose2::new(T::zero(), T::zero(), heading_guess),
            Matrix3::from_diagonal(&Vector3::new(T::zero(), T::zero(), s * s)),
            config,
        )?;
        f.initialised = false;
        Ok(f)
    }

    /// The current pose (world frame; m, m, rad unwrapped). Cheap: no covariance step.
    pub fn pose(&self) -> Pose2<T> {
        let x = self.current_mean();
        Pose2::new(x[0], x[1], x[2])
    }

    /// The current pose covariance (m², rad²; order x, y, heading). While the newest history
    /// entry is open this runs its 5 × 5 covariance step (module docs); for the variances
    /// alone, [`PoseFusion::pose_variances`] is cheaper.
    pub fn pose_covariance(&self) -> Matrix3<T> {
        self.current().p.fixed_view::<3, 3>(0, 0).into_owned()
    }

    /// The pose variances (m², m², rad²) as of the newest **closed** history entry: at most
    /// one history slot (`max_latency / (N/2)`) older than [`PoseFusion::pose`], and free —
    /// what a control loop reports every cycle.
    pub fn settled_pose_variances(&self) -> [T; 3] {
        let p = match self.open_entry() {
            Some((prev, _)) => prev,
            None => self.current_ref(),
        };
        [p.cov(0, 0), p.cov(1, 1), p.cov(2, 2)]
    }

    /// The diagonal of [`PoseFusion::pose_covariance`] (m², m², rad²), without the full
    /// covariance step: `Fᵢ P Fᵢᵀ + Qᵢᵢ` for the three pose rows `Fᵢ` of the sparse Jacobian of
    /// the open entry. Equal to the diagonal of [`PoseFusion::pose_covariance`] up to rounding.
    pub fn pose_variances(&self) -> [T; 3] {
        let Some((prev, e)) = self.open_entry() else {
            let p = self.current_ref();
            return [p.cov(0, 0), p.cov(1, 1), p.cov(2, 2)];
        };
        let (sn, cs) = self.open_rot;
        let (_, j) = mean_and_jacobian(&prev.x, sn, cs, e);
        let q = self.noise_diagonal(prev.x[4], e);
        // Fᵢ P Fᵢᵀ over the row's non-zero columns.
        let form = |cols: [(usize, T); 3]| {
            let mut acc = T::zero();
            for &(a, va) in &cols {
                for &(b, vb) in &cols {
                    acc += va * vb * prev.cov(a, b);
                }
            }
            acc
        };
        let one = T::one();
        [
            form([(0, one), (2, j.f02), (4, j.f04)]) + q[0],
            form([(1, one), (2, j.f12), (4, j.f14)]) + q[1],
            form([(2, one), (3, j.f23), (4, j.f24)]) + q[2],
        ]
    }

    /// The full state `(x, y, θ, b, k)` and its 5 × 5 covariance.
    pub fn state(&self) -> (SVector<T, STATES>, SMatrix<T, STATES, STATES>) {
        let s = self.current();
        (s.x, s.p)
    }

    /// Estimated gyro bias, rad/s, and its standard deviation.
    pub fn gyro_bias(&self) -> (T, T) {
        let s = self.current();
        (s.x[3], s.p[(3, 3)].max(T::zero()).sqrt())
    }

    /// Estimated wheel-scale factor (true / measured travel) and its standard deviation.
    pub fn wheel_scale(&self) -> (T, T) {
        let s = self.current();
        (s.x[4], s.p[(4, 4)].max(T::zero()).sqrt())
    }

    /// Time of the current estimate, s.
    pub fn time(&self) -> T {
        if self.len == 0 {
            self.base_t
        } else {
            self.buf[self.index(self.len - 1)].t
        }
    }

    /// Whether a pose is known (always, except before the first fix of
    /// [`PoseFusion::awaiting_fix`]).
    pub fn initialised(&self) -> bool {
        self.initialised
    }

    /// Fixes rejected since the last fused one.
    pub fn rejected_in_a_row(&self) -> u32 {
        self.rejected_in_a_row
    }

    /// Oldest time a fix may carry, s: the state before the oldest kept entry.
    pub fn oldest_time(&self) -> T {
        self.base_t
    }

    /// Moves the filter's clock: every stored time (the state, the history, the fixes in it)
    /// has `offset` seconds subtracted, nothing else changes. A host whose time scalar loses
    /// resolution as time grows (`f32`) re-bases the clock with it; the runtime does so every
    /// 256 s.
    pub fn shift_time(&mut self, offset: T) {
        self.base_t -= offset;
        for k in 0..self.len {
            let i = self.index(k);
            // The posterior's and the fix's time are the entry's.
            self.buf[i].t -= offset;
        }
    }

    /// The current state, with the open entry's covariance step run if there is one.
    fn current(&self) -> State<T> {
        match self.open_entry() {
            Some((prev, e)) => {
                self.propagate(&State::at(self.before_time(self.len - 1), prev), e.t, e)
            }
            None => State::at(self.time(), self.current_ref()),
        }
    }

    /// The newest settled state (the open entry's `post` is not one), without its time
    /// ([`PoseFusion::time`] when no entry is open).
    fn current_ref(&self) -> &Posterior<T> {
        if self.len == 0 {
            &self.base
        } else {
            &self.buf[self.index(self.len - 1)].post
        }
    }

    /// The current mean (no covariance step).
    fn current_mean(&self) -> Vec5<T> {
        match self.open_entry() {
            Some((prev, e)) => {
                let (sn, cs) = self.open_rot;
                mean_and_jacobian(&prev.x, sn, cs, e).0
            }
            None => self.current_ref().x,
        }
    }

    /// The open entry and the state before it.
    fn open_entry(&self) -> Option<(&Posterior<T>, &Entry<T>)> {
        if self.open && self.len > 0 {
            Some((
                self.before_ref(self.len - 1),
                &self.buf[self.index(self.len - 1)],
            ))
        } else {
            None
        }
    }

    /// Runs the open entry's covariance step and stores its `post`: the history is settled.
    fn settle(&mut self) {
        if let Some((prev, e)) = self.open_entry() {
            let prev = State::at(self.before_time(self.len - 1), prev);
            let post = self.propagate(&prev, e.t, e).packed();
            let i = self.index(self.len - 1);
            self.buf[i].post = post;
        }
        self.open = false;
    }

    /// Marks the newest entry open (it takes the next steps), keeping the rotation of the
    /// state before it.
    fn reopen(&mut self) {
        if !self.open && self.len > 0 {
            let h = self.before_ref(self.len - 1).x[2];
            self.open_rot = h.sin_cos();
            self.open = true;
        }
    }

    #[inline]
    fn index(&self, k: usize) -> usize {
        (self.head + k) % N
    }

    /// The state before entry `k`, with its time.
    fn before(&self, k: usize) -> State<T> {
        State::at(self.before_time(k), self.before_ref(k))
    }

    /// The time of the state before entry `k`.
    fn before_time(&self, k: usize) -> T {
        if k == 0 {
            self.base_t
        } else {
            self.buf[self.index(k - 1)].t
        }
    }

    fn before_ref(&self, k: usize) -> &Posterior<T> {
        if k == 0 {
            &self.base
        } else {
            &self.buf[self.index(k - 1)].post
        }
    }

    fn evict(&mut self) {
        if self.len > 0 {
            self.base = self.buf[self.head].post;
            self.base_t = self.buf[self.head].t;
            self.head = (self.head + 1) % N;
            self.len -= 1;
        }
    }

    /// EKF prediction of `s` through entry `e`'s increment, ending at time `t`.
    fn propagate(&self, s: &State<T>, t: T, e: &Entry<T>) -> State<T> {
        let (sn, cs) = s.x[2].sin_cos();
        let (xn, j) = mean_and_jacobian(&s.x, sn, cs, e);
        let mut f = Mat5::identity();
        f[(0, 2)] = j.f02;
        f[(1, 2)] = j.f12;
        f[(0, 4)] = j.f04;
        f[(1, 4)] = j.f14;
        f[(2, 3)] = j.f23;
        f[(2, 4)] = j.f24;
        let q = Mat5::from_diagonal(&Vec5::from(self.noise_diagonal(s.x[4], e)));
        State {
            t,
            x: xn,
            p: symmetric(f * s.p * f.transpose() + q),
        }
    }

    /// Process noise of entry `e` at wheel scale `k` (diagonal): the increment's (isotropic in
    /// x, y, so rotation-free) and the walks, only for the states that are on.
    fn noise_diagonal(&self, k: T, e: &Entry<T>) -> [T; STATES] {
        let (z, c) = (T::zero(), &self.config);
        let qxy = e.q.0 * k * k;
        [
            qxy,
            qxy,
            e.q.1,
            if c.gyro_bias_std > z {
                c.gyro_bias_walk * c.gyro_bias_walk * e.dt
            } else {
                z
            },
            if c.scale_std > z {
                c.scale_walk * c.scale_walk * e.dist
            } else {
                z
            },
        ]
    }

    /// Gate distance and innovation of `fix` against `s`.
    fn innovation(&self, s: &State<T>, fix: &Fix<T>) -> (T, Vector2<T>) {
        let vxy = fix.std_xy * fix.std_xy;
        let nu = Vector2::new(fix.x - s.x[0], fix.y - s.x[1]);
        let d2 = match fix.heading {
            Some(h) => {
                let nu3 = Vector3::new(nu[0], nu[1], wrap_angle(h - s.x[2]));
                let sm = s.p.fixed_view::<3, 3>(0, 0).into_owned()
                    + Matrix3::from_diagonal(&Vector3::new(
                        vxy,
                        vxy,
                        fix.std_heading * fix.std_heading,
                    ));
                sm.try_inverse()
                    .map_or(T::of(f64::INFINITY), |si| (nu3.transpose() * si * nu3)[0])
            }
            None => {
                let sm = s.p.fixed_view::<2, 2>(0, 0).into_owned()
                    + Matrix2::from_diagonal(&Vector2::new(vxy, vxy));
                sm.try_inverse()
                    .map_or(T::of(f64::INFINITY), |si| (nu.transpose() * si * nu)[0])
            }
        };
        (d2, nu)
    }

    /// The state after applying `action` with `fix` to `s` (same time).
    fn apply(&self, s: &State<T>, fix: &Fix<T>, action: Action<T>) -> State<T> {
        let mut s = *s;
        match action {
            Action::Fuse => {}
            Action::Inflate(f) => {
                for i in 0..3 {
                    for j in 0..STATES {
                        s.p[(i, j)] *= f.sqrt();
                        s.p[(j, i)] *= f.sqrt();
                    }
                }
            }
            Action::Reinit(heading_var) => {
                s.x[0] = fix.x;
                s.x[1] = fix.y;
                let vxy = fix.std_xy * fix.std_xy;
                let mut p = Mat5::zeros();
                p[(0, 0)] = vxy;
                p[(1, 1)] = vxy;
                p[(2, 2)] = match fix.heading {
                    Some(h) => {
                        let th = s.x[2];
                        s.x[2] = th + wrap_angle(h - th);
                        fix.std_heading * fix.std_heading
                    }
                    None => heading_var,
                };
                // Bias and scale keep their estimates and variances, not their correlations.
                p[(3, 3)] = s.p[(3, 3)];
                p[(4, 4)] = s.p[(4, 4)];
                s.p = p;
                return s;
            }
        }
        self.update(&s, fix)
    }

    /// Kalman update by sequential scalar updates (exact for the linear `H` rows of x, y, θ and
    /// the diagonal fix covariance), Joseph form.
    fn update(&self, s: &State<T>, fix: &Fix<T>) -> State<T> {
        let mut s = *s;
        let vxy = fix.std_xy * fix.std_xy;
        let rows = [
            (0usize, fix.x, vxy),
            (1, fix.y, vxy),
            (
                2,
                fix.heading.unwrap_or(T::zero()),
                fix.std_heading * fix.std_heading,
            ),
        ];
        let m = if fix.heading.is_some() { 3 } else { 2 };
        for &(i, z, r) in &rows[..m] {
            let nu = if i == 2 {
                wrap_angle(z - s.x[2])
            } else {
                z - s.x[i]
            };
            let sv = s.p[(i, i)] + r;
            if sv.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
                continue;
            }
            let k: Vec5<T> = s.p.column(i) / sv;
            s.x += k * nu;
            let mut ikh = Mat5::<T>::identity();
            for j in 0..STATES {
                ikh[(j, i)] -= k[j];
            }
            s.p = symmetric(ikh * s.p * ikh.transpose() + k * k.transpose() * r);
        }
        s
    }

    /// **Prediction** with one odometry step ending at `t` (s): the measured robot-frame
    /// increment `delta` (m, m, rad; [`crate::estimate::odometry::OdometryStep::delta`]) and
    /// where its heading change came from. Steps shorter than the history slot are merged, and
    /// entries older than `max_latency` forgotten. Returns the new pose.
    ///
    /// # Errors
    /// [`FusionError::NonFinite`], [`FusionError::NonMonotonicTime`].
    pub fn predict(
        &mut self,
        t: T,
        delta: Pose2<T>,
        heading: StepHeading,
    ) -> Result<Pose2<T>, FusionError> {
        self.advance(t, delta, heading)?;
        Ok(self.pose())
    }

    /// [`PoseFusion::predict`] without computing the new pose (a control loop that reads the
    /// pose only when it needs it).
    ///
    /// # Errors
    /// As [`PoseFusion::predict`].
    pub fn advance(
        &mut self,
        t: T,
        delta: Pose2<T>,
        heading: StepHeading,
    ) -> Result<(), FusionError> {
        // One test of the sum for the usual case (a sum of finite terms may still overflow:
        // the field-by-field pass then finds nothing and the step goes on).
        if !(t + delta.x + delta.y + delta.heading).is_finite() {
            for (v, field) in [
                (t, "t"),
                (delta.x, "delta.x"),
                (delta.y, "delta.y"),
                (delta.heading, "delta.heading"),
            ] {
                finite(v, field)?;
            }
        }
        let previous = self.time();
        let dt = t - previous;
        if dt.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
            return Err(FusionError::NonMonotonicTime {
                t: t.to_f64(),
                previous: previous.to_f64(),
            });
        }
        // The chord of one step: no overflow to guard against (`hypot`'s extra cost).
        let dist = (delta.x * delta.x + delta.y * delta.y).sqrt();
        let q = self.config.noise.variances_over(dist, delta.heading, dt);
        // Merge into the last entry while it is shorter than a slot and carries no fix: only
        // its increment moves (module docs, "covariance at the slot rate").
        if self.len > 0 {
            let i = self.index(self.len - 1);
            let slot = self.slot;
            let last = &mut self.buf[i];
            if last.event.is_none() && last.heading == heading && last.dt + dt <= slot {
                last.t = t;
                last.dt += dt;
                let (sn, cs) = se2::sin_cos_near_zero(last.delta.heading);
                last.delta = se2::compose_rotated(last.delta, sn, cs, delta);
                last.dist += dist;
                last.q = (last.q.0 + q.0, last.q.1 + q.1);
                self.reopen();
                self.forget(t);
                return Ok(());
            }
        }
        self.settle();
        // One slot stays free so that a fix can always split an entry.
        while self.len >= N - 1 {
            self.evict();
        }
        let i = self.index(self.len);
        self.buf[i] = Entry {
            t,
            dt,
            delta,
            dist,
            q,
            heading,
            event: None,
            // Computed when the entry closes (`settle`).
            post: *self.current_ref(),
        };
        self.len += 1;
        self.reopen();
        self.forget(t);
        Ok(())
    }

    /// Forgets entries that end more than `max_latency` before `latest` (the test inline,
    /// the eviction, once per history slot, out of line).
    #[inline(always)]
    fn forget(&mut self, latest: T) {
        if self.len > 1 && self.buf[self.head].t < latest - self.config.max_latency {
            self.forget_old(latest);
        }
    }

    #[inline(never)]
    fn forget_old(&mut self, latest: T) {
        while self.len > 1 && self.buf[self.head].t < latest - self.config.max_latency {
            self.evict();
        }
    }

    /// **Correction** with a fix taken at `fix.t` (s), at most `max_latency` before the latest
    /// step: gated against the state at its time, fused there, later entries replayed; a run
    /// of rejections ends in a recovery (module docs).
    ///
    /// # Errors
    /// [`FusionError::NonFinite`] / [`FusionError::BadParameter`] for a bad fix,
    /// [`FusionError::TooLate`], [`FusionError::InFuture`]. A rejected fix is not an error.
    pub fn add_fix(&mut self, fix: &Fix<T>) -> Result<FusionOutcome<T>, FusionError> {
        for (v, field) in [(fix.t, "fix.t"), (fix.x, "fix.x"), (fix.y, "fix.y")] {
            finite(v, field)?;
        }
        let mut stds = [(fix.std_xy, "fix.std_xy"), (T::one(), "")];
        if let Some(h) = fix.heading {
            finite(h, "fix.heading")?;
            stds[1] = (fix.std_heading, "fix.std_heading");
        }
        for (v, field) in stds {
            if !(v.is_finite() && v > T::zero()) {
                return Err(FusionError::BadParameter {
                    field,
                    rule: "must be a finite number > 0",
                    value: v.to_f64(),
                });
            }
        }
        let latest = self.time();
        if fix.t > latest {
            return Err(FusionError::InFuture {
                t: fix.t.to_f64(),
                latest: latest.to_f64(),
            });
        }
        // The history is about to be read at the fix's time and replayed: settled first.
        self.settle();
        // A fix may add an entry: make room first (the fix may then be too late).
        if self.len == N {
            self.evict();
        }
        if fix.t < self.base_t {
            return Err(FusionError::TooLate {
                t: fix.t.to_f64(),
                oldest: self.base_t.to_f64(),
            });
        }
        // The prior at the fix time, and where it goes in the history.
        let (k, split) = self.locate(fix.t);
        let prior = match split {
            Split::Base => State::at(self.base_t, &self.base),
            // The entry's post already includes its own fix, if any.
            Split::At => State::at(fix.t, &self.buf[self.index(k)].post),
            Split::Inside(ref first, _) => self.propagate(&self.before(k), fix.t, first),
        };
        let c = self.config;
        let (action, outcome) = if !self.initialised {
            let hv = c.unknown_heading_std * c.unknown_heading_std;
            (Action::Reinit(hv), FusionOutcome::Initialised)
        } else {
            let (d2, nu) = self.innovation(&prior, fix);
            let gate = if fix.heading.is_some() {
                c.gate.pose
            } else {
                c.gate.position
            };
            if d2.partial_cmp(&gate) != Some(core::cmp::Ordering::Greater) {
                (Action::Fuse, FusionOutcome::Accepted { mahalanobis2: d2 })
            } else {
                let run = self.rejected_in_a_row;
                self.innovations[(run % MAX_RECOVERY_COUNT) as usize] = nu;
                if run + 1 < c.recovery_count {
                    self.rejected_in_a_row = run + 1;
                    return Ok(FusionOutcome::Rejected {
                        mahalanobis2: d2,
                        gate,
                    });
                }
                // Recovery: do the last `recovery_count` innovations agree?
                let n = c.recovery_count;
                let at = |j: u32| {
                    self.innovations[((run + MAX_RECOVERY_COUNT - j) % MAX_RECOVERY_COUNT) as usize]
                };
                let mut mean = Vector2::zeros();
                for j in 0..n {
                    mean += at(j);
                }
                mean /= T::of(n as f64);
                let spread = (0..n).fold(T::zero(), |m, j| m.max((at(j) - mean).norm()));
                let recovery = if spread <= c.recovery_spread {
                    let hv = prior.p[(2, 2)] + c.recovery_heading_std * c.recovery_heading_std;
                    (Action::Reinit(hv), Recovery::Reinitialised)
                } else {
                    // Inflate so that this fix lands at a quarter of the gate.
                    let f = (T::of(4.0) * d2 / gate).max(T::of(4.0));
                    (Action::Inflate(f), Recovery::Inflated)
                };
                (
                    recovery.0,
                    FusionOutcome::Recovered {
                        recovery: recovery.1,
                        rejected: run,
                    },
                )
            }
        };
        self.insert(k, split, fix, action);
        self.initialised = true;
        self.rejected_in_a_row = 0;
        Ok(outcome)
    }

    /// Where a fix at `t` (base.t ≤ t ≤ latest) goes: entry `k` and how.
    fn locate(&self, t: T) -> (usize, Split<T>) {
        if t == self.base_t {
            return (0, Split::Base);
        }
        let mut k = 0;
        while k < self.len && self.buf[self.index(k)].t < t {
            k += 1;
        }
        let e = self.buf[self.index(k)];
        if e.t == t {
            return (k, Split::At);
        }
        let prev_t = self.before_time(k);
        let f = (t - prev_t) / e.dt;
        let xi = se2::log(e.delta);
        let part = |delta: Pose2<T>, g: T, dt: T, t: T| Entry {
            t,
            dt,
            delta,
            dist: e.dist * g,
            q: (e.q.0 * g, e.q.1 * g),
            heading: e.heading,
            event: None,
            post: e.post,
        };
        let first = part(se2::twist_exp(xi, f), f, t - prev_t, t);
        let mut second = part(se2::twist_exp(xi, T::one() - f), T::one() - f, e.t - t, e.t);
        second.event = e.event;
        (k, Split::Inside(first, second))
    }

    fn insert(&mut self, k: usize, split: Split<T>, fix: &Fix<T>, action: Action<T>) {
        match split {
            Split::Base => {
                // Applied to the base itself (its own event is not kept: the base is a state).
                let base = State::at(self.base_t, &self.base);
                self.base = self.apply(&base, fix, action).packed();
                self.replay(0);
            }
            Split::At => {
                let i = self.index(k);
                let e = self.buf[i];
                if e.event.is_some() {
                    // Split off a zero-length entry so that both events survive replays (there
                    // is room: add_fix keeps len < N).
                    self.shift_from(k + 1);
                    let j = self.index(k + 1);
                    self.buf[j] = Entry {
                        t: e.t,
                        dt: T::zero(),
                        delta: Pose2::new(T::zero(), T::zero(), T::zero()),
                        dist: T::zero(),
                        q: (T::zero(), T::zero()),
                        heading: e.heading,
                        event: Some((StoredFix::of(fix), action)),
                        post: e.post,
                    };
                    self.replay(k + 1);
                } else {
                    self.buf[i].event = Some((StoredFix::of(fix), action));
                    self.replay(k);
                }
            }
            Split::Inside(mut first, second) => {
                self.shift_from(k);
                first.event = Some((StoredFix::of(fix), action));
                let (i0, i1) = (self.index(k), self.index(k + 1));
                self.buf[i0] = first;
                self.buf[i1] = second;
                self.replay(k);
            }
        }
    }

    /// Moves entries `k..len` one slot towards the end (len grows by one).
    fn shift_from(&mut self, k: usize) {
        let mut j = self.len;
        while j > k {
            let (dst, src) = (self.index(j), self.index(j - 1));
            self.buf[dst] = self.buf[src];
            j -= 1;
        }
        self.len += 1;
    }

    /// Recomputes the posteriors of entries `k..len` from the state before entry `k`.
    fn replay(&mut self, k: usize) {
        let mut s = self.before(k);
        for j in k..self.len {
            let i = self.index(j);
            let e = self.buf[i];
            if e.dt > T::zero() {
                s = self.propagate(&s, e.t, &e);
            }
            if let Some((fix, action)) = e.event {
                s = self.apply(&s, &fix.at(e.t), action);
            }
            self.buf[i].post = s.packed();
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Split<T> {
    /// At the base time.
    Base,
    /// At the end of entry k.
    At,
    /// Inside entry k: its two parts.
    Inside(Entry<T>, Entry<T>),
}

/// The input checks of [`initial_state`].
fn check_initial<T: Real>(t: T, pose: Pose2<T>, cov: Matrix3<T>) -> Result<(), FusionError> {
    for (v, field) in [
        (t, "t"),
        (pose.x, "pose.x"),
        (pose.y, "pose.y"),
        (pose.heading, "pose.heading"),
    ] {
        finite(v, field)?;
    }
    if !cov.iter().all(|v| v.is_finite()) {
        return Err(FusionError::NonFinite { field: "cov" });
    }
    for i in 0..3 {
        if cov[(i, i)] < T::zero() {
            return Err(FusionError::BadParameter {
                field: "cov",
                rule: "diagonal must be >= 0",
                value: cov[(i, i)].to_f64(),
            });
        }
    }
    Ok(())
}

/// The state of a filter at time `t` that knows it is at `pose` with covariance `cov`, the gyro
/// bias at 0 and the scale at 1 with `config`'s prior standard deviations (inputs checked by
/// [`check_initial`]).
fn initial_state<T: Real>(
    t: T,
    pose: Pose2<T>,
    cov: Matrix3<T>,
    config: &FusionConfig<T>,
) -> State<T> {
    let mut p = Mat5::zeros();
    p.fixed_view_mut::<3, 3>(0, 0).copy_from(&cov);
    p[(3, 3)] = config.gyro_bias_std * config.gyro_bias_std;
    p[(4, 4)] = config.scale_std * config.scale_std;
    let x = Vec5::from([pose.x, pose.y, pose.heading, T::zero(), T::one()]);
    State {
        t,
        x,
        p: symmetric(p),
    }
}

/// The mean after entry `e` from the state `x` whose heading has sine `sn` and cosine `cs`,
/// and the Jacobian of that step (module docs, the prediction equations).
fn mean_and_jacobian<T: Real>(x: &Vec5<T>, sn: T, cs: T, e: &Entry<T>) -> (Vec5<T>, Jacobian<T>) {
    let z = T::zero();
    let (b, k) = (x[3], x[4]);
    let (dx, dy) = (k * e.delta.x, k * e.delta.y);
    let (dth, f23, f24) = match e.heading {
        StepHeading::Wheels => (k * e.delta.heading, z, e.delta.heading),
        StepHeading::Gyro => (e.delta.heading - b * e.dt, -e.dt, z),
        StepHeading::Absolute => (e.delta.heading, z, z),
    };
    let mut xn = *x;
    xn[0] = x[0] + cs * dx - sn * dy;
    xn[1] = x[1] + sn * dx + cs * dy;
    xn[2] = x[2] + dth;
    let j = Jacobian {
        f02: -sn * dx - cs * dy,
        f12: cs * dx - sn * dy,
        f04: cs * e.delta.x - sn * e.delta.y,
        f14: sn * e.delta.x + cs * e.delta.y,
        f23,
        f24,
    };
    (xn, j)
}

fn symmetric<T: Real>(m: Mat5<T>) -> Mat5<T> {
    (m + m.transpose()) * T::of(0.5)
}

#[cfg(test)]
mod layout {
    use super::*;

    /// The history entry's size, which sets the firmware runtime's RAM (`FIX_HISTORY` of
    /// them): 8 scalars of increment and noise, the step's heading source, a 6-scalar fix with
    /// what it did, the 20-scalar posterior.
    #[test]
    fn an_f32_history_entry_is_148_bytes() {
        assert_eq!(core::mem::size_of::<Entry<f32>>(), 148);
    }
}
