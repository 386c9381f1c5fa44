//! Command shaping: inverse kinematics to motor rates, direction-keeping desaturation, and
//! acceleration/jerk limiting. Pure functions and `Copy` state; no allocation, no panic.

use crate::{Actuators, InputError, MAX_WHEELS, Real, Robot, Twist2};

use super::hal::MotorCommand;

/// Motor rates (rad/s) of a **robot-frame** twist at the measured steer angles `steer` (rad;
/// ignored by kinds without steering), with zero shell/ball spin: [`Robot::inverse`]'s wheel
/// rates and steer rates. Kinds whose steer angles are set-points
/// ([`crate::Kind::steer_is_set_point`], swerve) get steer rates 0 here: the runtime drives
/// their steer motors to the inverse's angles itself.
///
/// The map is linear in the twist for fixed steer angles, which is what makes [`desaturate`]
/// keep the direction of motion.
///
/// # Errors
/// [`InputError`] from the kinematics for non-finite input.
#[inline]
pub fn motor_rates<T: Real>(
    robot: &Robot<T>,
    twist: Twist2<T>,
    steer: &[T; MAX_WHEELS],
) -> Result<MotorCommand<T>, InputError> {
    let a = robot.inverse(twist, &Actuators::at_steer(steer))?;
    Ok(MotorCommand {
        wheel: a.wheel_rates,
        steer: a.steer_rates,
    })
}

/// Motor rate limits, rad/s (`None`: unlimited), the same for every wheel motor and for every
/// steer motor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateLimits<T> {
    /// Largest wheel (roll) rate magnitude, rad/s.
    pub wheel: Option<T>,
    /// Largest steer rate magnitude (caster, swerve), rad/s.
    pub steer: Option<T>,
}

/// The factor `s ∈ (0, 1]` that brings every motor rate of `cmd` within `limits`
/// (`s = min(1, limit / max|rate|)`), or 1 when nothing exceeds.
#[inline]
pub fn saturation_scale<T: Real>(cmd: &MotorCommand<T>, limits: &RateLimits<T>) -> T {
    // The largest magnitude of each group, then one division: a branch-free fold the compiler
    // vectorises (NaN entries are skipped by `max`, as by the comparison they replace).
    let peak = |rates: &[T; MAX_WHEELS]| rates.iter().fold(T::zero(), |m, r| m.max(r.abs()));
    let mut s = T::one();
    for (rates, lim) in [(&cmd.wheel, limits.wheel), (&cmd.steer, limits.steer)] {
        if let Some(lim) = lim {
            let a = peak(rates);
            if a > lim && a > T::zero() {
                s = s.min(lim / a);
            }
        }
    }
    s
}

/// Result of [`desaturate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesaturatedTwist<T> {
    /// The scaled robot-frame twist (same direction as the request), m/s, m/s, rad/s.
    pub twist: Twist2<T>,
    /// Its motor rates, rad/s, every one within the limits.
    pub rates: MotorCommand<T>,
    /// The scale applied, in (0, 1]; below 1 means a limit was hit.
    pub scale: T,
}

/// Wheel-rate desaturation that keeps the motion's direction: the **whole** twist (linear
/// velocity and yaw rate together) is scaled by one factor so the worst motor sits exactly at
/// its limit, instead of clipping single wheels (which would bend the path). The rates are
/// those of [`motor_rates`] at the steer angles `steer`.
///
/// # Errors
/// [`InputError`] from the kinematics for non-finite input.
pub fn desaturate<T: Real>(
    robot: &Robot<T>,
    twist: Twist2<T>,
    steer: &[T; MAX_WHEELS],
    limits: &RateLimits<T>,
) -> Result<DesaturatedTwist<T>, InputError> {
    let rates = motor_rates(robot, twist, steer)?;
    let scale = saturation_scale(&rates, limits);
    if scale >= T::one() {
        return Ok(DesaturatedTwist {
            twist,
            rates,
            scale: T::one(),
        });
    }
    let k = |x: [T; MAX_WHEELS]| x.map(|v| v * scale);
    Ok(DesaturatedTwist {
        twist: Twist2::new(twist.vx * scale, twist.vy * scale, twist.yaw_rate * scale),
        rates: MotorCommand {
            wheel: k(rates.wheel),
            steer: k(rates.steer),
        },
        scale,
    })
}

/// Acceleration and jerk limits of the commanded motion (world frame, so they are the
/// physical accelerations of the robot).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlewLimits<T> {
    /// Largest linear acceleration magnitude, m/s² (> 0).
    pub accel: T,
    /// Largest yaw acceleration magnitude, rad/s² (> 0).
    pub yaw_accel: T,
    /// Largest linear jerk, m/s³ (`None`: acceleration may step).
    pub jerk: Option<T>,
    /// Largest yaw jerk, rad/s³ (`None`: yaw acceleration may step).
    pub yaw_jerk: Option<T>,
}

/// Largest acceleration from which a jerk-limited ramp-down (steps of `j·dt` per cycle, after
/// this cycle's step) still stops within the remaining velocity error `e`:
/// `a²/(2j) + 1.5·a·dt ≤ e`.
fn brake_cap<T: Real>(j: T, e: T, dt: T) -> T {
    let h = T::of(1.5) * dt;
    j * (-h + (h * h + T::of(2.0) * e / j).sqrt())
}

/// Rate limiter for a world-frame twist: moves the commanded velocity towards a target with
/// bounded acceleration and (optionally) bounded jerk, keeping the direction of the linear
/// velocity change. With a jerk limit the acceleration is also capped so that a jerk-limited
/// ramp-down still fits in the remaining velocity error (`a²/(2j) + 1.5·a·dt ≤ |error|`): the
/// velocity lands on the target without overshoot (tested: < 1e-3 of the step). Note that the
/// 2-D jerk bound holds for a fixed target direction; a target that turns can need more.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slew<T> {
    /// Current commanded world-frame twist.
    velocity: Twist2<T>,
    /// Current linear acceleration (world) and yaw acceleration.
    accel: [T; 2],
    yaw_accel: T,
}

impl<T: Real> Default for Slew<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> Slew<T> {
    /// At rest.
    pub fn new() -> Self {
        Self {
            velocity: Twist2::new(T::zero(), T::zero(), T::zero()),
            accel: [T::zero(); 2],
            yaw_accel: T::zero(),
        }
    }

    /// The current commanded world-frame twist.
    pub fn velocity(&self) -> Twist2<T> {
        self.velocity
    }

    /// Forces the state (e.g. to zero on an emergency stop, or to a desaturated value).
    pub fn set_velocity(&mut self, v: Twist2<T>) {
        self.velocity = v;
    }

    /// Resets to rest with zero acceleration.
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// One step of `dt` seconds (> 0) towards the world-frame `target`; returns the new
    /// commanded velocity. Non-finite targets are treated as zero.
    pub fn step(&mut self, target: Twist2<T>, dt: T, limits: &SlewLimits<T>) -> Twist2<T> {
        let zero = T::zero();
        let target = if target.is_finite() {
            target
        } else {
            Twist2::new(zero, zero, zero)
        };
        // Linear part (2-D, direction kept).
        let e = [target.vx - self.velocity.vx, target.vy - self.velocity.vy];
        let en = (e[0] * e[0] + e[1] * e[1]).sqrt();
        let (vx, vy);
        // With a jerk limit: land exactly on the target when doing so (and then holding it)
        // changes the acceleration by at most one jerk step.
        let land = limits.jerk.is_some_and(|j| {
            let r = [e[0] / dt, e[1] / dt];
            let d = (r[0] - self.accel[0]).hypot(r[1] - self.accel[1]);
            d <= j * dt && en / dt <= j * dt
        });
        if en == zero || land {
            vx = target.vx;
            vy = target.vy;
            self.accel = [zero, zero];
        } else {
            let mut cap = limits.accel;
            if let Some(j) = limits.jerk {
                cap = cap.min(brake_cap(j, en, dt));
            }
            let mag = cap.min(en / dt);
            let want = [e[0] / en * mag, e[1] / en * mag];
            let a = match limits.jerk {
                Some(j) => {
                    let d = [want[0] - self.accel[0], want[1] - self.accel[1]];
                    let dn = (d[0] * d[0] + d[1] * d[1]).sqrt();
                    let step = j * dt;
                    let k = if dn > step { step / dn } else { T::one() };
                    let mut a = [self.accel[0] + d[0] * k, self.accel[1] + d[1] * k];
                    let an = (a[0] * a[0] + a[1] * a[1]).sqrt();
                    if an > limits.accel {
                        let k = limits.accel / an;
                        a = [a[0] * k, a[1] * k];
                    }
                    a
                }
                None => want,
            };
            vx = self.velocity.vx + a[0] * dt;
            vy = self.velocity.vy + a[1] * dt;
            self.accel = if limits.jerk.is_some() {
                a
            } else {
                [zero, zero]
            };
        }

        // Yaw (1-D), the same rules.
        let e = target.yaw_rate - self.velocity.yaw_rate;
        let land = limits
            .yaw_jerk
            .is_some_and(|j| (e / dt - self.yaw_accel).abs() <= j * dt && (e / dt).abs() <= j * dt);
        let wz = if e == zero || land {
            self.yaw_accel = zero;
            target.yaw_rate
        } else {
            let mut cap = limits.yaw_accel;
            if let Some(j) = limits.yaw_jerk {
                cap = cap.min(brake_cap(j, e.abs(), dt));
            }
            let want = (e / dt).clamp(-cap, cap);
            let ay = match limits.yaw_jerk {
                Some(j) => {
                    let step = j * dt;
                    (self.yaw_accel + (want - self.yaw_accel).clamp(-step, step))
                        .clamp(-limits.yaw_accel, limits.yaw_accel)
                }
                None => want,
            };
            self.yaw_accel = if limits.yaw_jerk.is_some() { ay } else { zero };
            self.velocity.yaw_rate + ay * dt
        };
        self.velocity = Twist2::new(vx, vy, wz);
        self.velocity
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::{SphereOmni, SphereParams};

    fn sphere() -> Robot<f64> {
        Robot::Sphere(SphereOmni::new(SphereParams::preset()).unwrap())
    }

    #[test]
    fn desaturation_keeps_direction_and_puts_worst_wheel_on_limit() {
        let lim = RateLimits {
            wheel: Some(12.0),
            steer: None,
        };
        let tw = Twist2::new(3.0, 1.0, 2.0);
        let d = desaturate(&sphere(), tw, &[0.0; MAX_WHEELS], &lim).unwrap();
        assert!(d.scale < 1.0);
        let worst = d.rates.wheel.iter().fold(0.0f64, |m, r| m.max(r.abs()));
        assert!((worst - 12.0).abs() < 1e-9, "{worst}");
        // Same direction: components in the same ratio.
        assert!((d.twist.vx / d.twist.vy - 3.0).abs() < 1e-12);
        assert!((d.twist.yaw_rate / d.twist.vy - 2.0).abs() < 1e-12);
        // Within limits: untouched.
        let small = Twist2::new(0.1, 0.0, 0.0);
        let d = desaturate(&sphere(), small, &[0.0; MAX_WHEELS], &lim).unwrap();
        assert_eq!(d.scale, 1.0);
        assert_eq!(d.twist, small);
    }

    #[test]
    fn slew_respects_acceleration_and_reaches_target() {
        let lim = SlewLimits {
            accel: 1.0,
            yaw_accel: 2.0,
            jerk: None,
            yaw_jerk: None,
        };
        let mut s = Slew::<f64>::new();
        let dt = 0.01;
        let mut prev = s.velocity();
        for k in 0..200 {
            let v = s.step(Twist2::new(0.3, 0.4, 1.0), dt, &lim);
            let a = ((v.vx - prev.vx).hypot(v.vy - prev.vy)) / dt;
            assert!(a <= 1.0 + 1e-9, "cycle {k}: {a}");
            assert!((v.yaw_rate - prev.yaw_rate).abs() / dt <= 2.0 + 1e-9);
            // Direction of the linear velocity is kept while ramping.
            if v.vx > 0.0 {
                assert!((v.vy / v.vx - 4.0 / 3.0).abs() < 1e-9);
            }
            prev = v;
        }
        assert_eq!(s.velocity(), Twist2::new(0.3, 0.4, 1.0));
        // 0.5 m/s at 1 m/s² takes 0.5 s = 50 cycles.
        let mut s = Slew::<f64>::new();
        let mut n = 0;
        while s.step(Twist2::new(0.3, 0.4, 0.0), dt, &lim).vx < 0.3 {
            n += 1;
        }
        assert_eq!(n, 49);
    }

    #[test]
    fn jerk_limit_bounds_acceleration_changes_and_converges() {
        let lim = SlewLimits {
            accel: 1.0,
            yaw_accel: 2.0,
            jerk: Some(10.0),
            yaw_jerk: Some(20.0),
        };
        let mut s = Slew::<f64>::new();
        let dt = 0.005;
        let (mut pv, mut pa) = (s.velocity(), 0.0f64);
        let mut max_over = 0.0f64;
        for _k in 0..400 {
            let v = s.step(Twist2::new(0.5, 0.0, -1.0), dt, &lim);
            let a = (v.vx - pv.vx) / dt;
            assert!(
                ((a - pa) / dt).abs() <= 10.0 + 1e-6,
                "step {_k}: jerk {}, v {}",
                (a - pa) / dt,
                v.vx
            );
            assert!(a.abs() <= 1.0 + 1e-9);
            max_over = max_over.max(v.vx - 0.5);
            pv = v;
            pa = a;
        }
        assert!(max_over < 5e-4, "overshoot {max_over}");
        assert_eq!(s.velocity(), Twist2::new(0.5, 0.0, -1.0));
    }
}
