//! The inverse kinematics of one control cycle: [`super::limits::motor_rates`] at the
//! measured steer angles, prepared once per cycle because the cycle needs it twice (the
//! desaturation of the target, then the shaped command), with the same bits as
//! `motor_rates`.
//!
//! * Sphere and ballbot: their wheel-rate map (`G`, `k B`, paper 000 eq. 4.4 and paper 001)
//!   straight on the twist, without the input checks and the kind-independent actuator arrays
//!   of the full path; one test of the rates' sum replaces the checks (a non-finite twist or
//!   an overflow gives a non-finite rate).
//! * Caster: its inverse rows at this cycle's steer angles
//!   ([`Caster3::robot_frame_inverse`]), so the three steer `sin_cos` are taken once, not
//!   per evaluation.
//! * Every other kind: the full inverse each time.

use crate::caster::{Caster3, CasterInverseRows};
use crate::{MAX_WHEELS, Real, Robot, Twist2};

use super::hal::MotorCommand;
use super::limits::motor_rates;

/// How a cycle evaluates [`motor_rates`] (module docs).
#[derive(Clone, Copy, Debug)]
pub(super) enum CycleInverse<'a, T> {
    /// Sphere or ballbot: their wheel-rate map, unchecked, then one test.
    Direct(&'a Robot<T>),
    /// The caster's rows at this cycle's steer angles.
    Rows(CasterInverseRows<T>),
    /// The full inverse at the steer angles.
    Kinematics(&'a Robot<T>, &'a [T; MAX_WHEELS]),
}

impl<'a, T: Real> CycleInverse<'a, T> {
    /// The inverse of `robot` at the measured steer angles `steer` for one cycle.
    ///
    /// # Errors
    /// `()` for a caster whose steer angles are not finite (as [`motor_rates`] would fail).
    #[inline(always)]
    pub(super) fn new(robot: &'a Robot<T>, steer: &'a [T; MAX_WHEELS]) -> Result<Self, ()> {
        Ok(match robot {
            Robot::Sphere(_) | Robot::Ballbot(_) => Self::Direct(robot),
            Robot::Caster(c) => Self::Rows(caster_rows(c, steer)?),
            _ => Self::Kinematics(robot, steer),
        })
    }

    /// The motor rates of the robot-frame twist `v`: [`motor_rates`]'s, bit for bit.
    ///
    /// # Errors
    /// `()` where [`motor_rates`] fails (a non-finite twist, rates that overflow).
    #[inline(always)]
    pub(super) fn rates(&self, v: Twist2<T>) -> Result<MotorCommand<T>, ()> {
        let mut out = MotorCommand::zero();
        match self {
            Self::Direct(robot) => {
                let w = match robot {
                    Robot::Sphere(s) => s.wheel_rates_unchecked(v),
                    Robot::Ballbot(b) => b.wheel_rates_unchecked(v),
                    _ => return motor_rates(robot, v, &[T::zero(); MAX_WHEELS]).map_err(|_| ()),
                };
                if !(w[0] + w[1] + w[2]).is_finite() {
                    return Err(());
                }
                out.wheel[..3].copy_from_slice(&w);
            }
            Self::Rows(r) => {
                let c = r.motor_rates(v).map_err(|_| ())?;
                out.wheel[..3].copy_from_slice(&c.roll);
                out.steer[..3].copy_from_slice(&c.steer);
            }
            Self::Kinematics(robot, steer) => return motor_rates(robot, v, steer).map_err(|_| ()),
        }
        Ok(out)
    }
}

/// The caster's inverse rows at the first three steer angles.
#[inline(always)]
fn caster_rows<T: Real>(
    c: &Caster3<T>,
    steer: &[T; MAX_WHEELS],
) -> Result<CasterInverseRows<T>, ()> {
    c.robot_frame_inverse([steer[0], steer[1], steer[2]])
        .map_err(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::RobotDescription;

    fn robot(name: &str) -> Robot<f64> {
        RobotDescription::preset(name)
            .expect("preset")
            .build()
            .expect("robot")
    }

    /// Twists of every direction and size, steer states of every quadrant.
    fn cases() -> impl Iterator<Item = (Twist2<f64>, [f64; MAX_WHEELS])> {
        (0..300).map(|k| {
            let f = k as f64;
            let size = [1.0, 1e-6, 1e3][k % 3];
            let twist = Twist2::new(
                size * (0.37 * f).sin(),
                size * (0.91 * f + 0.3).cos(),
                size * 3.0 * (0.53 * f + 1.0).sin(),
            );
            let steer = core::array::from_fn(|i| 3.0 * (0.29 * f + i as f64).sin());
            (twist, steer)
        })
    }

    #[test]
    fn equals_motor_rates_bit_for_bit_on_every_kind() {
        for name in [
            "sphere-omni",
            "ballbot",
            "caster3",
            "kiwi",
            "mecanum",
            "swerve4",
        ] {
            let r = robot(name);
            for (twist, steer) in cases() {
                let inverse = CycleInverse::new(&r, &steer).expect("finite steer");
                let fast = inverse.rates(twist).expect("finite twist");
                let full = motor_rates(&r, twist, &steer).expect("finite twist");
                assert_eq!(fast, full, "{name}: {twist:?} at {steer:?}");
            }
        }
    }

    #[test]
    fn refuses_what_motor_rates_refuses() {
        let bad = [f64::NAN, f64::INFINITY, -f64::INFINITY];
        for name in ["sphere-omni", "ballbot", "caster3", "kiwi"] {
            let r = robot(name);
            let steer = [0.1; MAX_WHEELS];
            let inverse = CycleInverse::new(&r, &steer).expect("finite steer");
            for x in bad {
                for twist in [
                    Twist2::new(x, 0.0, 0.0),
                    Twist2::new(0.0, x, 0.0),
                    Twist2::new(0.0, 0.0, x),
                ] {
                    assert!(motor_rates(&r, twist, &steer).is_err(), "{name}");
                    assert!(inverse.rates(twist).is_err(), "{name}: {twist:?}");
                }
            }
            // Rates that overflow the scalar.
            let huge = Twist2::new(1e308, -1e308, 1e308);
            assert_eq!(
                motor_rates(&r, huge, &steer).is_err(),
                inverse.rates(huge).is_err(),
                "{name}"
            );
        }
        let caster = robot("caster3");
        let mut steer = [0.0; MAX_WHEELS];
        steer[1] = f64::NAN;
        assert!(CycleInverse::new(&caster, &steer).is_err());
    }
}
