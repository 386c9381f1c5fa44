//! Command shaping, step 5 of the cycle: the target twist becomes motor set-points within
//! every limit — desaturation at the measured steer angles → body slew (acceleration, jerk) →
//! inverse kinematics → motor-acceleration limit → final rate clamp — and, for kinds whose
//! steer angles are set-points (swerve), the steer-angle loop. With [`Config::tilt`] (a
//! sphere's pendulous platform) the tilt feedback's velocity is added between the slew and the
//! inverse kinematics ([`TiltFeedback`]); the slew keeps the command without it.
//!
//! [`Config::tilt`]: super::Config::tilt
//! [`TiltFeedback`]: super::TiltFeedback
//!
//! ## Steering
//! * Rate-driven steering (the caster, [`Kind::steer_is_set_point`] `false`): the inverse's
//!   steer rates are motor rates like the wheels'; they share the wheels' one
//!   acceleration-limit factor and desaturation.
//! * Set-point steering (swerve): the inverse gives each module's steer angle `γ_i*` (at the
//!   measured angles `γ_i`, so a stopped module keeps its angle and the optimisation flips
//!   against what the module really does) and, from the commanded twist's robot-frame rate of
//!   change ([`Robot::inverse_accel`](crate::Robot::inverse_accel)), the feed-forward
//!   `γ̇_i*`. The steer motor is commanded `γ̇_i* + k·wrap(γ_i* − γ_i)` with
//!   `k = min(`[`Config::k_steer`]`, `[`Config::rate_hz`]`)`, clamped to
//!   [`RateLimits::steer`](super::limits::RateLimits::steer) and to a change of at most
//!   [`Config::steer_accel`] × dt per cycle (clamping the steering is normal tracking and is
//!   not flagged as [`Faults::LIMIT`]). Each wheel rate is scaled by `cos(γ_i* − γ_i)`, the
//!   share of the module's motion along its wanted direction (WPILib's cosine scaling), so a
//!   module still turning does not push the robot sideways.
//!
//! [`Kind::steer_is_set_point`]: crate::Kind::steer_is_set_point
//! [`Config::k_steer`]: super::Config::k_steer
//! [`Config::rate_hz`]: super::Config::rate_hz
//! [`Config::steer_accel`]: super::Config::steer_accel
//! [`Faults::LIMIT`]: super::Faults::LIMIT

use crate::drive::Rot2;
use crate::{Actuators, MAX_WHEELS, Real, Twist2, wrap_angle};

use super::controller::Runtime;
use super::cycle_inverse::CycleInverse;
use super::hal::MotorCommand;
use super::limits::saturation_scale;
use super::plan::zero_twist;
use super::status::{Faults, Mode};
use super::tilt::tilt_known;

impl<T: Real, const N: usize> Runtime<T, N> {
    /// Desaturation → slew → inverse kinematics → motor-acceleration limit → final rate
    /// clamp (→ steer-angle loop). `rot` is `{cos, sin}` of the heading: every frame change
    /// here shares it. Writes the motor set-points to `self.last_motor` (read here as the
    /// previous cycle's, and by the cycle for the motors and its status: no copy of the
    /// 96-byte command through the return value) and returns the commanded robot-frame twist.
    /// On `Err` `self.last_motor` is unchanged.
    #[inline(always)]
    pub(super) fn shape(
        &mut self,
        target_world: Twist2<T>,
        rot: Rot2<T>,
        dt: T,
        faults: &mut Faults,
    ) -> Result<Twist2<T>, ()> {
        let cfg = &self.config;
        let steer = &self.encoders.steer;
        let n = self.wheels;
        let to_world = |v: Twist2<T>| v.rotated_by(rot);
        let to_robot = |v: Twist2<T>| {
            v.rotated_by(Rot2 {
                cos: rot.cos,
                sin: -rot.sin,
            })
        };
        // The inverse of this cycle, prepared once for its two uses (`CycleInverse`).
        let inverse = CycleInverse::new(&self.robot, steer)?;
        // Desaturation (limits::desaturate without scaling the rates, which are not used).
        let mut want = to_robot(target_world);
        let scale = saturation_scale(&inverse.rates(want)?, &cfg.rate_limits);
        if scale < T::one() {
            faults.insert(Faults::LIMIT);
            want = Twist2::new(want.vx * scale, want.vy * scale, want.yaw_rate * scale);
        }
        let v_world = self.slew.step(to_world(want), dt, &cfg.slew);
        // Tilt feedback (a sphere's pendulous platform, `Config::tilt`): added after the slew,
        // which keeps the command without it.
        let dv = match (&cfg.tilt, &self.imu) {
            (Some(tf), Some(_)) => {
                // The plan's acceleration (none outside a plan), at most the slew's limit:
                // a plan that starts at full speed asks a step.
                let [mut ax, mut ay] = if self.mode == Mode::Trajectory {
                    self.plan.accel
                } else {
                    [T::zero(); 2]
                };
                let an = (ax * ax + ay * ay).sqrt();
                if an > cfg.slew.accel {
                    ax = ax * cfg.slew.accel / an;
                    ay = ay * cfg.slew.accel / an;
                }
                let a = to_robot(Twist2::new(ax, ay, T::zero()));
                // The next cycle's tilt estimate subtracts it from the accelerometer.
                self.tilt_accel = [a.vx, a.vy];
                match tilt_known(self.tilt_up) {
                    Some(up) => {
                        let k = -tf.shell_radius * tf.gain;
                        Twist2::new(
                            k * (up[0] - tf.lean_per_accel * a.vx),
                            k * (up[1] - tf.lean_per_accel * a.vy),
                            T::zero(),
                        )
                    }
                    None => zero_twist(),
                }
            }
            _ => zero_twist(),
        };
        let mut v = to_robot(v_world);
        v.vx += dv.vx;
        v.vy += dv.vy;
        // Set-point steering: the module angles (and their feed-forward rates) of the inverse;
        // the wheel rates scaled by the cosine of each module's angle error.
        let mut set_points = None;
        let mut rates = if self.steer_set_point {
            let lc = self.last_command;
            let rate = Twist2::new(
                (v.vx - lc.vx) / dt,
                (v.vy - lc.vy) / dt,
                (v.yaw_rate - lc.yaw_rate) / dt,
            );
            let a = self
                .robot
                .inverse_accel(v, rate, &Actuators::at_steer(steer))
                .map_err(|_| ())?;
            let mut wheel = a.wheel_rates;
            for ((w, sp), m) in wheel.iter_mut().zip(&a.steer_angles).zip(steer).take(n) {
                *w *= Rot2::from_angle(*sp - *m).cos;
            }
            set_points = Some(a);
            MotorCommand {
                wheel,
                steer: [T::zero(); MAX_WHEELS],
            }
        } else {
            inverse.rates(v)?
        };
        // Motor acceleration limit: scale the change of all rates by one factor (the steer
        // motors take part when they are rate-driven).
        let mut s = T::one();
        let mut limit = |new: &[T; MAX_WHEELS], old: &[T; MAX_WHEELS], a: Option<T>| {
            if let Some(a) = a {
                let step = a * dt;
                // Unused entries are 0 on both sides: the loop runs over the whole capacity,
                // which the compiler unrolls (a count known only at run time it does not).
                for (x, o) in new.iter().zip(old) {
                    let dlt = (*x - *o).abs();
                    if dlt > step && dlt > T::zero() {
                        s = s.min(step / dlt);
                    }
                }
            }
        };
        limit(&rates.wheel, &self.last_motor.wheel, cfg.wheel_accel);
        if !self.steer_set_point {
            limit(&rates.steer, &self.last_motor.steer, cfg.steer_accel);
        }
        if s < T::one() {
            faults.insert(Faults::LIMIT);
            let old = &self.last_motor;
            let blend = |new: &mut [T; MAX_WHEELS], old: &[T; MAX_WHEELS]| {
                for (x, o) in new.iter_mut().zip(old) {
                    *x = *o + s * (*x - *o);
                }
            };
            blend(&mut rates.wheel, &old.wheel);
            blend(&mut rates.steer, &old.steer);
            let lc = self.last_command;
            v = Twist2::new(
                lc.vx + s * (v.vx - lc.vx),
                lc.vy + s * (v.vy - lc.vy),
                lc.yaw_rate + s * (v.yaw_rate - lc.yaw_rate),
            );
            self.slew.set_velocity(to_world(Twist2::new(
                v.vx - dv.vx,
                v.vy - dv.vy,
                v.yaw_rate,
            )));
        }
        let k = saturation_scale(&rates, &cfg.rate_limits);
        if k < T::one() {
            faults.insert(Faults::LIMIT);
            for x in rates.wheel.iter_mut().chain(rates.steer.iter_mut()) {
                *x *= k;
            }
            v = Twist2::new(v.vx * k, v.vy * k, v.yaw_rate * k);
            self.slew.set_velocity(to_world(Twist2::new(
                v.vx - dv.vx,
                v.vy - dv.vy,
                v.yaw_rate,
            )));
        }
        if let Some(a) = set_points {
            rates.steer = self.steer_rates(&a, dt);
        }
        // One test of the sum (0 × a non-finite value is NaN; unused entries are 0).
        let zero = rates
            .wheel
            .iter()
            .chain(&rates.steer)
            .fold(T::zero(), |acc, x| acc + *x * T::zero());
        if zero != T::zero() {
            return Err(());
        }
        self.last_motor = rates;
        Ok(v)
    }

    /// The steer-motor rates (rad/s) that drive the measured steer angles to the set-points of
    /// `a` (see the module docs), within the steer rate and acceleration limits.
    fn steer_rates(&self, a: &Actuators<T>, dt: T) -> [T; MAX_WHEELS] {
        let cfg = &self.config;
        let k = cfg.k_steer.min(cfg.rate_hz);
        let mut out = [T::zero(); MAX_WHEELS];
        for (i, o) in out.iter_mut().enumerate().take(self.wheels) {
            let err = wrap_angle(a.steer_angles[i] - self.encoders.steer[i]);
            let mut r = a.steer_rates[i] + k * err;
            if let Some(l) = cfg.rate_limits.steer {
                r = r.clamp(-l, l);
            }
            if let Some(acc) = cfg.steer_accel {
                let old = self.last_motor.steer[i];
                let step = acc * dt;
                r = r.clamp(old - step, old + step);
            }
            *o = r;
        }
        out
    }
}
