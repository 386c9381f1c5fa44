//! The control loop's settings: [`Config`] (rates, motor and body limits, watchdog, gains,
//! event thresholds) and their validation ([`ConfigError`], [`RATE_HZ_RANGE`]).

use super::limits::{RateLimits, SlewLimits};
use crate::Real;
use crate::estimate::events::EventThresholds;
use crate::estimate::fusion::FusionConfig;

/// A configuration value that cannot work.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {rule}")]
pub struct ConfigError {
    /// The field, e.g. `"rate_hz"`.
    pub field: &'static str,
    /// What is allowed.
    pub rule: &'static str,
}

/// Range of the control rate [`Config::rate_hz`] that [`Config::validate`] accepts, Hz: at
/// least 1 Hz (a slower loop cannot keep a sub-second watchdog) and at most 10 kHz (the
/// clock counts whole microseconds, so a cycle needs at least 100 µs to be represented well;
/// faster than any omni drive's motor control needs).
pub const RATE_HZ_RANGE: (f64, f64) = (1.0, 10_000.0);

/// Control-loop settings. SI units; build with [`Config::new`] and adjust fields.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config<T> {
    /// Nominal cycle rate, Hz.
    pub rate_hz: T,
    /// Motor rate limits (desaturation), rad/s.
    pub rate_limits: RateLimits<T>,
    /// Largest wheel (roll) acceleration, rad/s² (`None`: unlimited).
    pub wheel_accel: Option<T>,
    /// Largest steer-motor acceleration (caster, swerve), rad/s² (`None`: unlimited).
    pub steer_accel: Option<T>,
    /// Steer-angle gain of kinds whose steer angles are set-points
    /// ([`Kind::steer_is_set_point`](crate::Kind::steer_is_set_point), swerve), 1/s: the
    /// steer-rate command is the inverse's feed-forward plus `k_steer ×` the wrapped angle
    /// error. A gain above [`Config::rate_hz`] acts as `rate_hz` (more would overshoot in one
    /// cycle). Unused by the other kinds.
    pub k_steer: T,
    /// Body acceleration and jerk limits (world frame).
    pub slew: SlewLimits<T>,
    /// Commands faster than this (m/s, linear speed) are rejected as malformed; slower ones
    /// are desaturated to the motor limits.
    pub max_speed: T,
    /// Commands with a larger yaw-rate magnitude (rad/s) are rejected.
    pub max_yaw_rate: T,
    /// Watchdog time, s: no valid command or heartbeat for this long → controlled stop.
    pub watchdog: T,
    /// Trajectory position feedback gain, 1/s.
    pub k_position: T,
    /// Trajectory heading feedback gain, 1/s.
    pub k_heading: T,
    /// Largest position correction speed added to the feed-forward, m/s.
    pub max_correction: T,
    /// Largest heading correction rate added to the feed-forward, rad/s.
    pub max_yaw_correction: T,
    /// Slip and collision detection ([`crate::estimate::events`], the detector `omnikin
    /// odometry` runs offline): |gyro yaw rate − wheel yaw rate| and the least-squares slip
    /// residual (kinds with more than three motors) for slip, the wheel speed's deceleration
    /// for a collision. `omnikin robot` sets the three thresholds from the robot file's
    /// `[events]` table. Default [`EventThresholds::standard`].
    pub events: EventThresholds<T>,
    /// Take the heading change from the gyro (when an IMU sample arrives) instead of the
    /// wheels.
    pub heading_from_gyro: bool,
    /// The pose fusion of external fixes ([`Command::Fix`](super::Command::Fix)): odometry
    /// noise, gate, recovery, `max_latency` (how old a fix may be and still be fused at its
    /// capture time), gyro-bias and wheel-scale states. Default [`FusionConfig::default`].
    pub fusion: FusionConfig<T>,
    /// Tilt feedback of a sphere's pendulous platform (`None`: off, the default). See
    /// [`TiltFeedback`].
    pub tilt: Option<TiltFeedback<T>>,
}

/// Tilt feedback for a sphere whose platform hangs like a pendulum below the shell centre
/// (paper 000's robot): the commanded robot-frame velocity gets
///
/// ```text
/// Δv = −R c (γ̂_xy − L a_xy)
/// ```
///
/// before the inverse kinematics, where `γ̂` is the **estimated** up direction in the platform
/// frame (`(0, 0, 1)` level; the tilt estimate below), `a` the plan's robot-frame acceleration
/// of this cycle (the change of its feed-forward velocity, at most the slew's `max_accel`,
/// m/s²), `R` [`TiltFeedback::shell_radius`], `c` [`TiltFeedback::gain`] and `L`
/// [`TiltFeedback::lean_per_accel`].
///
/// **Why `Δv ∝ tilt`.** Per horizontal axis, linearised about the level platform at rest
/// (shell roll rate `φ̇`, platform pitch `θ` with the centre of mass at `x − h sin θ`; the
/// wheels impose the relative rate `u = φ̇ − θ̇`, which is what a rate command sets):
/// `J θ̈ + m_p g h θ = −B u̇`, `J = I_s + m_s R² + I_p + m_p (R − h)²`, `B = M R² + I_s − m_p h R`.
/// Rate-controlled wheels leave this mode undamped; `u = u_ref + c θ` makes it
/// `J θ̈ + B c θ̇ + m_p g h θ = −B u̇_ref`, damping ratio `ζ = B c / (2 √(J m_p g h))`.
/// Feeding back the tilt *rate* would only change the mode's inertia. `L a` is the
/// quasi-static lean of a steady acceleration linearised (`m_p g h θ = a (M R − m_p h +
/// I_s/R)`, module doc of `omnikin_plan::tilt`), so a steady curve keeps its lean and the
/// feedback acts on the rocking about it. A host computes the numbers from the robot's
/// dynamics (`omnikin_sim::closed_loop::tilt_feedback`).
///
/// **The tilt estimate.** An accelerometer reads the specific force `f = Qᵀ (a_p + g ẑ)`, so
/// its direction is the *apparent* vertical: in a steady acceleration it leans by `a/g`
/// (more than the platform's own lean `L a` on the preset), and the rocking's own
/// acceleration enters it (`a_p = R u̇ + (R − d) θ̈` at a point `d` below the shell centre). Fed
/// back directly it destabilises the loop. So `γ̂` is a complementary filter: the gyro `ω`
/// (platform frame) carries it through the rocking, `γ̂ ← γ̂ + Δt γ̂ × ω` (a world-fixed
/// vector seen from a turning frame), and it is pulled toward the accelerometer's direction
/// **after subtracting the acceleration the runtime commanded**, `f − (a_x, a_y, 0)`, with
/// the time constant `τ` [`TiltFeedback::accel_time_constant`]:
/// `γ̂ ← γ̂ + (Δt/τ) (dir(f − a) − γ̂)`, then normalised. Linearised per axis, with the
/// estimate's error `e = γ̂_x − γ_x`, `τ ė + e = (a_p − a)/g`, and the loop's characteristic
/// polynomial is the cubic of `omnikin_sim::closed_loop::tilt_poles`: for `τ → ∞` the
/// designed pair and an integrator; for `τ → 0` (the accelerometer alone) the leading
/// coefficient is `c (J R − B (R − d))/g`, negative with the IMU at the shell centre on the
/// preset (`J < B`: unstable), and with it at the centre of mass the damping falls from 0.71
/// to 0.39. The estimate starts at the first accelerometer direction (minus the commanded
/// acceleration).
///
/// With it, a gyro heading ([`Config::heading_from_gyro`]) integrates the angular velocity's
/// vertical component (the gyro against `γ̂`) instead of the gyro's z, which a leaning
/// platform reads short by `cos θ`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltFeedback<T> {
    /// `c`, 1/s: relative roll rate per radian of tilt.
    pub gain: T,
    /// `R`, m: the shell radius (the level model's `v = R u`).
    pub shell_radius: T,
    /// `L`, rad per m/s²: the quasi-static lean per unit acceleration.
    pub lean_per_accel: T,
    /// `τ`, s: how slowly the tilt estimate follows the accelerometer (minus the commanded
    /// acceleration); faster than `τ` it follows the gyro. Must be > 0.
    pub accel_time_constant: T,
}

impl<T: Real> Config<T> {
    /// Defaults for a loop at `rate_hz`: no motor limits, 1 m/s², 4 rad/s², no jerk limit,
    /// accepted bounds 2 m/s and 10 rad/s, watchdog 0.5 s, gains 2/s, corrections ≤ 0.1 m/s
    /// and 0.5 rad/s, the event thresholds of [`EventThresholds::standard`] (0.3 rad/s, 0.05 m/s, 3 m/s²), heading from
    /// the wheels, steer-angle gain `rate_hz / 5`.
    pub fn new(rate_hz: T) -> Self {
        Self {
            rate_hz,
            rate_limits: RateLimits {
                wheel: None,
                steer: None,
            },
            wheel_accel: None,
            steer_accel: None,
            k_steer: rate_hz * T::of(0.2),
            slew: SlewLimits {
                accel: T::one(),
                yaw_accel: T::of(4.0),
                jerk: None,
                yaw_jerk: None,
            },
            max_speed: T::of(2.0),
            max_yaw_rate: T::of(10.0),
            watchdog: T::of(0.5),
            k_position: T::of(2.0),
            k_heading: T::of(2.0),
            max_correction: T::of(0.1),
            max_yaw_correction: T::of(0.5),
            events: EventThresholds::standard(),
            heading_from_gyro: false,
            fusion: FusionConfig::default(),
            tilt: None,
        }
    }

    /// Checks every value is finite and in range: the control rate within [`RATE_HZ_RANGE`],
    /// motor limits within 10⁻³–10⁵ rad/s and 10⁻³–10⁷ rad/s², body limits within plausible
    /// magnitudes (≤ 100 m/s, ≤ 10³ m/s², watchdog 1 ms to 1000 s; each rule names its range).
    ///
    /// # Errors
    /// [`ConfigError`] naming the first bad field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let pos = |x: T, field: &'static str| {
            if x.is_finite() && x > T::zero() {
                Ok(())
            } else {
                Err(ConfigError {
                    field,
                    rule: "must be finite and > 0",
                })
            }
        };
        let nonneg = |x: T, field: &'static str| {
            if x.is_finite() && x >= T::zero() {
                Ok(())
            } else {
                Err(ConfigError {
                    field,
                    rule: "must be finite and >= 0",
                })
            }
        };
        pos(self.rate_hz, "rate_hz")?;
        if !(self.rate_hz >= T::of(RATE_HZ_RANGE.0) && self.rate_hz <= T::of(RATE_HZ_RANGE.1)) {
            return Err(ConfigError {
                field: "rate_hz",
                rule: "must be between 1 and 10000 Hz (RATE_HZ_RANGE): the clock counts whole \
                       microseconds, and a loop below 1 Hz cannot keep a watchdog",
            });
        }
        let opt = |x: Option<T>, f| x.map_or(Ok(()), |v| pos(v, f));
        opt(self.rate_limits.wheel, "max_wheel_rate")?;
        opt(self.rate_limits.steer, "max_steer_rate")?;
        opt(self.wheel_accel, "max_wheel_accel")?;
        opt(self.steer_accel, "max_steer_accel")?;
        pos(self.slew.accel, "max_accel")?;
        pos(self.slew.yaw_accel, "max_yaw_accel")?;
        opt(self.slew.jerk, "max_jerk")?;
        opt(self.slew.yaw_jerk, "max_yaw_jerk")?;
        pos(self.max_speed, "max_speed")?;
        pos(self.max_yaw_rate, "max_yaw_rate")?;
        pos(self.watchdog, "watchdog")?;
        // Plausible magnitudes (finite but absurd values are errors, not motion that never
        // ends or never starts).
        let within = |x: T, lo: f64, hi: f64, field: &'static str, rule: &'static str| {
            if x >= T::of(lo) && x <= T::of(hi) {
                Ok(())
            } else {
                Err(ConfigError { field, rule })
            }
        };
        let opt_within = |x: Option<T>, lo, hi, field, rule| {
            x.map_or(Ok(()), |v| within(v, lo, hi, field, rule))
        };
        const RATE: &str = "must be between 1e-3 and 1e5 rad/s";
        const ACCEL: &str = "must be between 1e-3 and 1e7 rad/s²";
        opt_within(self.rate_limits.wheel, 1e-3, 1e5, "max_wheel_rate", RATE)?;
        opt_within(self.rate_limits.steer, 1e-3, 1e5, "max_steer_rate", RATE)?;
        opt_within(self.wheel_accel, 1e-3, 1e7, "max_wheel_accel", ACCEL)?;
        opt_within(self.steer_accel, 1e-3, 1e7, "max_steer_accel", ACCEL)?;
        within(
            self.slew.accel,
            1e-6,
            1e3,
            "max_accel",
            "must be between 1e-6 and 1e3 m/s²",
        )?;
        within(
            self.slew.yaw_accel,
            1e-6,
            1e4,
            "max_yaw_accel",
            "must be between 1e-6 and 1e4 rad/s²",
        )?;
        opt_within(
            self.slew.jerk,
            1e-6,
            1e6,
            "max_jerk",
            "must be between 1e-6 and 1e6 m/s³",
        )?;
        opt_within(
            self.slew.yaw_jerk,
            1e-6,
            1e7,
            "max_yaw_jerk",
            "must be between 1e-6 and 1e7 rad/s³",
        )?;
        within(
            self.max_speed,
            1e-6,
            100.0,
            "max_speed",
            "must be between 1e-6 and 100 m/s",
        )?;
        within(
            self.max_yaw_rate,
            1e-6,
            1e3,
            "max_yaw_rate",
            "must be between 1e-6 and 1e3 rad/s",
        )?;
        within(
            self.watchdog,
            1e-3,
            1e3,
            "watchdog",
            "must be between 1e-3 and 1e3 s",
        )?;
        nonneg(self.k_position, "k_position")?;
        nonneg(self.k_heading, "k_heading")?;
        nonneg(self.max_correction, "max_correction")?;
        nonneg(self.max_yaw_correction, "max_yaw_correction")?;
        if let Some(field) = self.events.invalid_field() {
            return Err(ConfigError {
                field,
                rule: "event thresholds and times must be finite and > 0 (Config::events)",
            });
        }
        nonneg(self.k_steer, "k_steer")?;
        if let Some(t) = &self.tilt {
            nonneg(t.gain, "tilt.gain")?;
            pos(t.shell_radius, "tilt.shell_radius")?;
            nonneg(t.lean_per_accel, "tilt.lean_per_accel")?;
            pos(t.accel_time_constant, "tilt.accel_time_constant")?;
        }
        Ok(())
    }
}
