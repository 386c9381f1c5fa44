//! What the balancing ballbot can do: the command limits of a balance runtime checked against
//! its 3D model before the robot starts (issue 31: `--max-yaw-rate 10` was accepted and the
//! robot fell at 10 rad/s).
//!
//! **Why a simulation.** The balance controller is designed on the three planar models, which
//! neglect the coupling of the vertical planes through the body's rotation — gyroscopic and
//! centripetal terms quadratic in the yaw rate ([`omnikin::control::planar`]). A spinning body
//! is therefore held only up to a yaw rate that the planar models do not show (the preset: the
//! 3D model holds 7 rad/s within 0.3° and falls at 9). The limit is found where it is decided:
//! the [`BalanceRuntime`] on the robot file's 3D model ([`BallbotSil`], the board
//! `omnikin robot --plant dynamic` runs), commanded from upright.
//!
//! **The rule.** A limit `L` (yaw rate or speed) is accepted when the closed loop holds the
//! command `L / (1 − lean_margin)` — the robot file's share of the lean kept for the
//! controller, kept here too — with the true tilt below the file's `max_tilt_deg` throughout
//! [`hold_seconds`]. A refused limit is reported with the tilt the model reached and the
//! largest limit that passes the same rule ([`largest_accepted`], by bisection).

use omnikin::Twist2;
use omnikin::runtime::{BalanceRuntime, BalanceRuntimeConfig, Command, Frame};

use super::sil::BallbotSil;
use super::{BallbotDynamics, BallbotPlant};

/// Seed of the sensor noise in the capability runs (fixed: the check is reproducible).
pub const CAPABILITY_SEED: u64 = 31;

/// Which command limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Limit {
    /// The largest accepted yaw rate, rad/s.
    YawRate,
    /// The largest accepted speed, m/s.
    Speed,
}

impl Limit {
    /// The runtime configuration's field name.
    pub const fn field(self) -> &'static str {
        match self {
            Limit::YawRate => "max_yaw_rate",
            Limit::Speed => "max_speed",
        }
    }

    /// The unit of the limit.
    pub const fn unit(self) -> &'static str {
        match self {
            Limit::YawRate => "rad/s",
            Limit::Speed => "m/s",
        }
    }

    /// The constant robot-frame command at `value`: a turn in place, or a drive along +x.
    fn twist(self, value: f64) -> Twist2<f64> {
        match self {
            Limit::YawRate => Twist2::new(0.0, 0.0, value),
            Limit::Speed => Twist2::new(value, 0.0, 0.0),
        }
    }
}

/// How the closed loop fared under one constant command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HoldRun {
    /// Largest true tilt from the vertical during the run, rad.
    pub max_tilt: f64,
    /// Simulated time, s.
    pub seconds: f64,
}

/// A limit the robot cannot keep.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error(
    "{field} {value} {unit}: the balancing ballbot cannot hold it: on its 3D model the balance \
     runtime commanded {tried:.3} {unit} (the limit with the lean_margin share kept for the \
     controller) tilts {tilt_deg:.1}° within {seconds:.1} s, past max_tilt_deg {max_tilt_deg}°; \
     it holds at most {largest:.2} {unit}",
    field = limit.field(),
    unit = limit.unit()
)]
pub struct LimitError {
    /// Which limit.
    pub limit: Limit,
    /// The limit asked for.
    pub value: f64,
    /// The command simulated (`value / (1 − lean_margin)`).
    pub tried: f64,
    /// The largest tilt it reached, degrees.
    pub tilt_deg: f64,
    /// The time simulated, s.
    pub seconds: f64,
    /// The tilt bound, degrees.
    pub max_tilt_deg: f64,
    /// The largest limit the same rule accepts.
    pub largest: f64,
}

/// Simulated time of a capability run at `value`: 6 s at full command (the preset's 3D model
/// falls within 4 s at the yaw rates it cannot hold), after the runtime's acceleration slew
/// to a speed.
pub fn hold_seconds(config: &BalanceRuntimeConfig<f64>, limit: Limit, value: f64) -> f64 {
    match limit {
        Limit::YawRate => 6.0,
        Limit::Speed => (value / config.max_accel).min(30.0) + 6.0,
    }
}

/// The balance runtime of `config` on its 3D model, upright at the origin, commanded `twist`
/// (robot frame) every cycle for `seconds`, its sensor noise seeded with `seed`; the runtime's
/// own limits are opened to the command.
pub fn hold(
    config: &BalanceRuntimeConfig<f64>,
    twist: Twist2<f64>,
    seconds: f64,
    seed: u64,
) -> HoldRun {
    let mut cfg = *config;
    cfg.max_yaw_rate = cfg.max_yaw_rate.max(twist.yaw_rate.abs() * 1.01);
    cfg.max_speed = cfg.max_speed.max(twist.vx.hypot(twist.vy) * 1.01);
    let Ok(mut rt) = BalanceRuntime::new(cfg, omnikin::Pose2::default()) else {
        return HoldRun {
            max_tilt: f64::INFINITY,
            seconds: 0.0,
        };
    };
    let balance = &config.balance;
    let Ok(plant) = BallbotPlant::new(BallbotDynamics::from_config(balance)) else {
        return HoldRun {
            max_tilt: f64::INFINITY,
            seconds: 0.0,
        };
    };
    let s0 = plant.upright(0.0);
    let mut board = BallbotSil::new(plant, s0, seed);
    let dt = 1.0 / balance.rate_hz;
    let cycles = (seconds / dt).round() as usize;
    let mut max_tilt = 0.0f64;
    let command = Command::Velocity {
        twist,
        frame: Frame::Robot,
    };
    for _ in 0..cycles {
        let now = board.time_us();
        // A command the runtime refuses cannot be held; neither can one that drives the model
        // to a non-finite state (`f64::max` would pass over a NaN tilt).
        if rt.handle(command, now).is_err() {
            max_tilt = f64::INFINITY;
            break;
        }
        board.run_cycle(&mut rt);
        board.advance(dt);
        let tilt = board.tilt();
        if !tilt.is_finite() {
            max_tilt = f64::INFINITY;
            break;
        }
        max_tilt = max_tilt.max(tilt);
    }
    HoldRun {
        max_tilt,
        seconds: cycles as f64 * dt,
    }
}

/// Whether the rule (module docs) accepts `value` for `limit`: the run at
/// `value / (1 − lean_margin)` and its largest tilt.
fn passes(
    config: &BalanceRuntimeConfig<f64>,
    limit: Limit,
    value: f64,
    max_tilt: f64,
    lean_margin: f64,
) -> (bool, f64, HoldRun) {
    let tried = value / (1.0 - lean_margin);
    let run = hold(
        config,
        limit.twist(tried),
        hold_seconds(config, limit, tried),
        CAPABILITY_SEED,
    );
    (run.max_tilt <= max_tilt, tried, run)
}

/// Where [`largest_accepted`] starts its search when the limit asked for is larger (rad/s or
/// m/s).
pub const SEARCH_CEILING: f64 = 1e3;

/// The largest `limit` the rule accepts, within 1 % (bisection between 0 and `upper`, or
/// [`SEARCH_CEILING`] when `upper` is larger; `upper` itself when it passes).
pub fn largest_accepted(
    config: &BalanceRuntimeConfig<f64>,
    limit: Limit,
    upper: f64,
    max_tilt: f64,
    lean_margin: f64,
) -> f64 {
    if passes(config, limit, upper, max_tilt, lean_margin).0 {
        return upper;
    }
    // No ballbot turns or rolls faster than SEARCH_CEILING: a larger refused limit (a typo, a
    // unit error) is searched from there, in a bounded number of runs.
    let hi = upper.min(SEARCH_CEILING);
    if hi < upper && passes(config, limit, hi, max_tilt, lean_margin).0 {
        return hi;
    }
    let (mut lo, mut hi) = (0.0, hi);
    while hi - lo > 0.01 * hi {
        let mid = 0.5 * (lo + hi);
        if passes(config, limit, mid, max_tilt, lean_margin).0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Checks `config`'s `max_yaw_rate` and `max_speed` against the robot (module docs): `max_tilt`
/// (rad) and `lean_margin` are the robot file's `max_tilt_deg` and `lean_margin`
/// (`RobotDescription::lean_acceleration_limit`).
///
/// # Errors
/// [`LimitError`] for the first limit the model cannot hold, naming the largest it can.
pub fn check_limits(
    config: &BalanceRuntimeConfig<f64>,
    max_tilt: f64,
    lean_margin: f64,
) -> Result<(), LimitError> {
    for (limit, value) in [
        (Limit::YawRate, config.max_yaw_rate),
        (Limit::Speed, config.max_speed),
    ] {
        let (ok, tried, run) = passes(config, limit, value, max_tilt, lean_margin);
        if !ok {
            return Err(LimitError {
                limit,
                value,
                tried,
                tilt_deg: run.max_tilt.to_degrees(),
                seconds: run.seconds,
                max_tilt_deg: max_tilt.to_degrees(),
                largest: largest_accepted(config, limit, value, max_tilt, lean_margin),
            });
        }
    }
    Ok(())
}
