//! Input limits of the simulator: how much work and memory a simulation may take, and the
//! plausible range of every parameter of a disturbance or sensor profile.
//!
//! Work and memory that grow with the input (trials are streamed into the metrics, so memory
//! does not grow with the trial count: see [`crate::simulate_and_evaluate`]) are bounded by the `MAX_*` constants below,
//! checked before the work starts from what the inputs imply (plant steps = Σ interval × plant
//! rate), and refused with [`crate::SimError::TooLarge`]
//! naming the limit, the value and what to change. Profile values outside their `*_RANGE`
//! (SI units) are refused with the key, the value and the range. To raise a limit, change the
//! constant here and rebuild.

/// Most plant integration steps in one trial: `Σ max(1, round(Δt_k × rate))` over the plan's
/// intervals. 10⁸ steps are 27.8 h of motion at the default 1 kHz plant rate (seconds to
/// minutes of computing per trial); a plan whose times run to 1e300 s is refused instead of
/// looping for ever.
pub const MAX_PLANT_STEPS: f64 = 1e8;

/// Sampling rate of the plans `reproduce` makes, Hz (the paper's experiment at 100 Hz).
pub const REPRODUCE_RATE_RANGE: (f64, f64) = (1.0, 1e4);

/// Most rows of a tracked-trajectory CSV (and of the encoder logs and camera fixes
/// `omnikin odometry` reads): 10⁷ rows are 28 h at 100 Hz.
pub const MAX_TRACK_ROWS: usize = 10_000_000;

/// Largest encoder log or camera-fix file ([`crate::table::NumericRows::open`]), bytes: 1 GiB
/// (about [`MAX_TRACK_ROWS`] rows). A larger one is refused before it is read. The file is
/// streamed row by row (`omnikin odometry`); a [`crate::table::NumericTable`] holds it whole.
pub const MAX_LOG_BYTES: usize = 1 << 30;

/// Plant integration rate (`rate`), Hz.
pub const PLANT_RATE_RANGE: (f64, f64) = (1.0, 1e6);

/// Stepper full steps per revolution (`steps_per_rev`).
pub const STEPS_PER_REV_RANGE: (f64, f64) = (1.0, 1e6);

/// Microsteps per full step (`microsteps`).
pub const MICROSTEPS_RANGE: (f64, f64) = (1.0, 1e4);

/// Largest step rate (`max_step_rate`), steps/s.
pub const STEP_RATE_RANGE: (f64, f64) = (1.0, 1e9);

/// Time constants and periods of a motor (`lag_time_constant`, `fluctuation_period`), s.
pub const MOTOR_TIME_RANGE: (f64, f64) = (1e-6, 1e3);

/// Motor acceleration limit (`max_accel`), rad/s².
pub const MOTOR_ACCEL_RANGE: (f64, f64) = (1e-3, 1e7);

/// Absolute speed fluctuation (`fluctuation_abs`), rad/s.
pub const FLUCTUATION_ABS_RANGE: (f64, f64) = (0.0, 1e3);

/// Relative quantities that are fractions of a whole (`fluctuation_rel`, `floor.rel_std`).
pub const FRACTION_RANGE: (f64, f64) = (0.0, 1.0);

/// Relative wheel-radius error (`radius_error_std`).
pub const RADIUS_ERROR_RANGE: (f64, f64) = (0.0, 0.5);

/// Standard deviation of a random shell spin (`shell_spin.std`), and of angular-rate noise
/// and biases (gyro), rad/s.
pub const ANGULAR_RATE_NOISE_RANGE: (f64, f64) = (0.0, 100.0);

/// Gain of the speed-dependent shell spin (`shell_spin.slip_gain`).
pub const SLIP_GAIN_RANGE: (f64, f64) = (0.0, 1e3);

/// Exponent of the speed-dependent shell spin (`shell_spin.slip_exponent`).
pub const SLIP_EXPONENT_RANGE: (f64, f64) = (0.0, 10.0);

/// Rollers per omni-wheel (`roller.rollers`).
pub const ROLLERS_RANGE: (f64, f64) = (1.0, 1e3);

/// Correlation time of the floor slip (`floor.corr_time`), s.
pub const CORR_TIME_RANGE: (f64, f64) = (1e-4, 1e4);

/// Position noise of a tracker or camera (`tracking.noise_std`, `camera.noise_std`), m.
pub const POSITION_NOISE_RANGE: (f64, f64) = (0.0, 10.0);

/// Gain of the quasi-static lean (`tracking.tilt_gain`).
pub const TILT_GAIN_RANGE: (f64, f64) = (0.0, 100.0);

/// Largest magnitude of the tracked point's offset and height from the robot centre, m.
pub const MAX_TRACKING_OFFSET: f64 = 10.0;

/// Angle noise (`yaw.noise_std`, `camera.heading_noise_std`), rad.
pub const ANGLE_NOISE_RANGE: (f64, f64) = (0.0, 100.0);

/// Accelerometer noise (`imu.accel_noise_std`), m/s².
pub const ACCEL_NOISE_RANGE: (f64, f64) = (0.0, 1e3);

/// Magnetometer noise and field components (`imu.mag_noise_std`, `imu.field`), µT.
pub const MAX_MAGNETIC_FIELD: f64 = 1e4;

/// Time between camera frames (`camera.period`), s.
pub const CAMERA_PERIOD_RANGE: (f64, f64) = (1e-4, 1e4);

/// Camera latency (`camera.latency`), s.
pub const CAMERA_LATENCY_RANGE: (f64, f64) = (0.0, 1e4);

/// Start and end of a camera outage window (`camera_gaps.outage`), s.
pub const CAMERA_OUTAGE_RANGE: (f64, f64) = (0.0, 1e6);

/// How far an outlier lands (`camera.outlier_distance`), m.
pub const OUTLIER_DISTANCE_RANGE: (f64, f64) = (0.0, 1e4);

/// Checks that `value` (if given) is finite and within `(min, max)`; the message names `key`,
/// the value, the range and `unit`.
pub(crate) fn check(
    key: &str,
    value: Option<f64>,
    (min, max): (f64, f64),
    unit: &str,
) -> Result<(), String> {
    match value {
        Some(v) if !(v.is_finite() && v >= min && v <= max) => {
            let unit = if unit.is_empty() {
                String::new()
            } else {
                format!(" {unit}")
            };
            Err(format!(
                "{key}: {}{unit} is outside the plausible range [{}, {}]{unit} \
                 (omnikin_sim::limits)",
                num(v),
                num(min),
                num(max)
            ))
        }
        _ => Ok(()),
    }
}

/// A number for a message: plain, or `1e300` style when tiny or huge (so 1e308 does not print
/// as 309 digits).
pub fn num(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && a.is_finite() && !(1e-3..1e6).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}
