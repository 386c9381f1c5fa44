//! Sensor emission: what a robot's encoders, IMU and an external camera would have recorded
//! during a simulated [`Trial`], so odometry and state estimation can be tested end to end
//! against known ground truth.
//!
//! From the trial's true cumulative wheel angles, steer angles and poses at the plan's sample
//! times, [`emit`] produces, with a seeded RNG:
//!
//! * the **encoder log** of conventions.md (`t,q1..qN` cumulative wheel angles, `s1..sN` for
//!   the steerable kinds, optional `gyro_z` and `yaw`), angles quantised to whole counts of a counting
//!   encoder (`floor`, `counts_per_rev`);
//! * a level **IMU** (3-axis gyro with constant bias and white noise, accelerometer = specific
//!   force, magnetometer = the world field in the body frame) for AHRS tests;
//! * with [`SensorProfile::tilt`], both on a **tilted platform** (a constant roll and pitch of
//!   the platform relative to its heading frame, `R = Rz(ψ) Ry(pitch) Rx(roll)`): the gyro reads
//!   `Rᵀ ψ̇ e₃` (its z axis `cos(tilt)·ψ̇`), the accelerometer `Rᵀ (a + g e₃)`, and the encoder
//!   log gains the 3-axis columns `gyro_x,gyro_y` (with `gyro_z`) and `accel_x,accel_y,accel_z`
//!   (m/s², specific force, platform frame). The sphere's and ballbot's wheels see it too: they
//!   measure the shell's (ball's) rate relative to the platform in the tilted platform frame,
//!   `Rᵀ ω̃`, so their angles are the plant's level ones mapped by `G Rᵀ G⁻¹`
//!   ([`crate::odometry::tilt::shell_maps`]); the other kinds' wheel angles are the plant's.
//! * with a per-sample [`PlatformAttitude`] ([`emit_with_attitude`], the sphere's dynamic plant),
//!   both on the platform as the dynamic model moves it: the IMU (at
//!   [`PlatformAttitude::imu_offset`] from the shell centre; `omnikin simulate --plant
//!   dynamic` puts it at the platform's centre of mass) reads the model's body rates, the
//!   accelerometer `Rₖᵀ (a + g e₃)` with `a` that point's acceleration (the second difference
//!   of its positions, the rocking's lever arm included) and the magnetometer `Rₖᵀ B` with
//!   `Rₖ = Rz(ψₖ) Ry(pitchₖ) Rx(rollₖ)` the
//!   platform's orientation at sample k; the encoder log's `gyro_z` is the body rate's z; the
//!   wheel angles are the model's own (slipping, stalled), not mapped;
//! * **camera fixes** of the robot centre every `period` seconds with Gaussian noise, a fixed
//!   latency (the fix is stamped with the time it was taken and carries its arrival time) and
//!   occasional outliers.
//!
//! The true yaw rate is the central difference of the trial's heading (second order in the
//! sample interval); the true acceleration its second difference.

use std::io::Write;

use omnikin::{MAX_WHEELS, Robot};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Deserialize;

use crate::Trial;

/// Gyro z (yaw-rate) channel written into the encoder log. All values rad/s.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GyroProfile {
    /// Standard deviation of white noise per sample, rad/s.
    pub noise_std: f64,
    /// Constant bias, rad/s.
    pub bias: f64,
    /// Standard deviation of an extra constant bias drawn per trial, rad/s.
    pub bias_std: f64,
}

/// Absolute yaw channel (e.g. an AHRS or compass heading) written into the encoder log.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YawProfile {
    /// Standard deviation of white noise per sample, rad.
    pub noise_std: f64,
    /// Report the yaw wrapped into (−π, π] like a real AHRS (default: unwrapped).
    #[serde(default)]
    pub wrap: bool,
}

/// Level 9-axis IMU for AHRS tests.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuProfile {
    /// Gyro white noise per sample and axis, rad/s.
    pub gyro_noise_std: f64,
    /// Constant gyro bias, body frame, rad/s.
    pub gyro_bias: [f64; 3],
    /// Accelerometer white noise per axis, m/s².
    pub accel_noise_std: f64,
    /// Magnetometer white noise per axis, µT.
    pub mag_noise_std: f64,
    /// Earth field in the world frame (east-north-up), µT.
    pub field: [f64; 3],
}

impl Default for ImuProfile {
    /// Noise-free, unbiased; field 20 µT north (+y), 45 µT down.
    fn default() -> Self {
        Self {
            gyro_noise_std: 0.0,
            gyro_bias: [0.0; 3],
            accel_noise_std: 0.0,
            mag_noise_std: 0.0,
            field: [0.0, 20.0, -45.0],
        }
    }
}

/// A constant tilt of the platform carrying the IMU (and the gyro of the encoder log), rad:
/// `R = Rz(heading) Ry(pitch) Rx(roll)`, body → world.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TiltProfile {
    /// Roll about the platform's x axis, rad.
    pub roll: f64,
    /// Pitch about the platform's y axis, rad.
    pub pitch: f64,
    /// White noise of the encoder log's accelerometer columns, per axis, m/s² (default 0).
    #[serde(default)]
    pub accel_noise_std: f64,
}

impl TiltProfile {
    /// The tilt rotation `Ry(pitch) Rx(roll)` (platform → heading frame), row-major.
    fn matrix(&self) -> [[f64; 3]; 3] {
        let (sr, cr) = self.roll.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        [
            [cp, sp * sr, sp * cr],
            [0.0, cr, -sr],
            [-sp, cp * sr, cp * cr],
        ]
    }
}

/// The attitude of the platform carrying the inertial sensors at one sample, as a dynamic
/// model has it: `R = Rz(heading) Ry(pitch) Rx(roll)` (body → world, the heading from the
/// trial's pose) and the platform's angular velocity in its own frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlatformAttitude {
    /// Roll about the platform's x axis, rad.
    pub roll: f64,
    /// Pitch about the platform's y axis, rad.
    pub pitch: f64,
    /// Angular velocity of the platform, platform frame (x forward, y left, z up), rad/s.
    pub body_rate: [f64; 3],
    /// Where the IMU sits, platform frame, from the trial pose's point (the sphere's shell
    /// centre), m: the accelerometer reads the specific force of that point, the rocking's
    /// lever-arm terms included. `[0, 0, 0]` (the default): at the pose's point.
    pub imu_offset: [f64; 3],
}

impl PlatformAttitude {
    /// The attitude of the sphere's platform in `state`: roll and pitch of its orientation's
    /// z–y–x Euler angles, and `Qᵀ ω`.
    pub fn of(state: &crate::dynamics::sphere::SphereState) -> Self {
        let (roll, pitch, _) = state.orientation.euler_angles();
        let w = state.orientation.inverse() * state.platform_rate;
        Self {
            roll,
            pitch,
            body_rate: [w.x, w.y, w.z],
            imu_offset: [0.0; 3],
        }
    }

    /// The tilt rotation `Ry(pitch) Rx(roll)` (platform → heading frame), row-major.
    fn matrix(&self) -> [[f64; 3]; 3] {
        TiltProfile {
            roll: self.roll,
            pitch: self.pitch,
            accel_noise_std: 0.0,
        }
        .matrix()
    }
}

/// `Mᵀ v`.
fn transpose_times(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|j| m[0][j] * v[0] + m[1][j] * v[1] + m[2][j] * v[2])
}

/// External camera (e.g. paper 000's overhead camera) tracking the robot centre.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraProfile {
    /// Time between frames, s (fixes are taken at the first sample at or after each multiple).
    pub period: f64,
    /// Delay from taking a frame to its arrival, s.
    pub latency: f64,
    /// Position noise per axis, m.
    pub noise_std: f64,
    /// Heading noise, rad; `None`: position-only fixes.
    pub heading_noise_std: Option<f64>,
    /// Probability that a frame is an outlier (mis-detection).
    pub outlier_probability: f64,
    /// How far an outlier lands from the truth, m (random direction).
    pub outlier_distance: f64,
}

impl Default for CameraProfile {
    /// 10 Hz, 100 ms latency, 5 mm noise, position only, no outliers.
    fn default() -> Self {
        Self {
            period: 0.1,
            latency: 0.1,
            noise_std: 0.005,
            heading_noise_std: None,
            outlier_probability: 0.0,
            outlier_distance: 0.5,
        }
    }
}

impl CameraProfile {
    /// Paper 000's overhead video as a camera for the robot: 25 frames/s (period 40 ms),
    /// 40 ms from capture to the robot, 2 mm position noise, position only, no outliers — the
    /// default of the sphere's closed loop (`omnikin simulate --closed-loop`).
    pub fn paper_000() -> Self {
        Self {
            period: 0.04,
            latency: 0.04,
            noise_std: 0.002,
            heading_noise_std: None,
            outlier_probability: 0.0,
            outlier_distance: 0.5,
        }
    }
}

/// Frames a [`CameraProfile`]'s camera loses: each frame independently with
/// `dropout_probability` (a missed detection, a lost packet), and every frame taken within a
/// scheduled `outage` window (the robot out of view, the camera unplugged). A section of its
/// own beside `[camera]` (`[camera_gaps]` in a sensor profile) so that profiles written before
/// it read the same; without it no frame is lost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraGaps {
    /// Probability that a frame is lost, in [0, 1].
    #[serde(default)]
    pub dropout_probability: f64,
    /// `[start, end)` of the outage, s of the frames' capture time (`None`: no outage).
    #[serde(default)]
    pub outage: Option<[f64; 2]>,
}

impl CameraGaps {
    /// Whether a frame taken at `t` falls in the outage window.
    pub fn in_outage(&self, t: f64) -> bool {
        self.outage.is_some_and(|[a, b]| t >= a && t < b)
    }

    /// Checks the probability and the window; the error names the key, the value and the
    /// rule (`camera_gaps.dropout_probability`, `camera_gaps.outage`).
    pub fn validate(&self) -> Result<(), String> {
        use crate::limits::*;
        check(
            "camera_gaps.dropout_probability",
            Some(self.dropout_probability),
            FRACTION_RANGE,
            "",
        )?;
        if let Some([a, b]) = self.outage {
            check("camera_gaps.outage[0]", Some(a), CAMERA_OUTAGE_RANGE, "s")?;
            check("camera_gaps.outage[1]", Some(b), CAMERA_OUTAGE_RANGE, "s")?;
            if a > b {
                return Err(format!(
                    "camera_gaps.outage: start {a} s is after end {b} s (the window is [start, end))"
                ));
            }
        }
        Ok(())
    }
}

/// Which sensors to emit and how imperfect they are. Every section optional (TOML-loadable).
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorProfile {
    /// Wheel-encoder resolution, counts per revolution (`None`: exact angles).
    pub counts_per_rev: Option<u32>,
    /// Steer-encoder resolution (steerable kinds), counts per revolution (`None`: exact angles).
    pub steer_counts_per_rev: Option<u32>,
    /// Emit a `gyro_z` column.
    pub gyro: Option<GyroProfile>,
    /// Emit a `yaw` column.
    pub yaw: Option<YawProfile>,
    /// Emit a 9-axis IMU log.
    pub imu: Option<ImuProfile>,
    /// Emit camera fixes.
    pub camera: Option<CameraProfile>,
    /// Frames the camera loses (dropouts, an outage window); `None`: none lost.
    pub camera_gaps: Option<CameraGaps>,
    /// Tilt the platform of the inertial sensors; the encoder log then has a 3-axis gyro and an
    /// accelerometer (with [`SensorProfile::gyro`]).
    pub tilt: Option<TiltProfile>,
}

impl SensorProfile {
    /// What `omnikin simulate --emit-sensors` records without a `--sensors` file: 4096-count
    /// wheel (and steer) encoders, a gyro z channel with 0.002 rad/s noise, a level IMU and
    /// camera fixes at 10 Hz with 100 ms latency and 5 mm noise ([`CameraProfile::default`]).
    pub fn typical() -> Self {
        Self {
            counts_per_rev: Some(4096),
            steer_counts_per_rev: Some(4096),
            gyro: Some(GyroProfile {
                noise_std: 0.002,
                bias: 0.0,
                bias_std: 0.0,
            }),
            yaw: None,
            imu: Some(ImuProfile::default()),
            camera: Some(CameraProfile::default()),
            camera_gaps: None,
            tilt: None,
        }
    }

    /// Reads a sensor profile from TOML text (every key of the types above; unknown keys are
    /// errors naming the line).
    pub fn from_toml_str(text: &str, file: &str) -> Result<Self, crate::profile::ProfileError> {
        let text = crate::profile::strip_bom(text);
        let p: Self = toml::from_str(text).map_err(|e| crate::profile::ProfileError {
            file: file.to_string(),
            line: e
                .span()
                .map(|s| 1 + text[..s.start.min(text.len())].matches('\n').count()),
            message: e.message().trim().to_string(),
        })?;
        p.validate()
            .map_err(|message| crate::profile::ProfileError {
                file: file.to_string(),
                line: None,
                message,
            })?;
        Ok(p)
    }

    /// Checks every value's range (the `*_RANGE` constants of [`crate::limits`]); the error
    /// names the key, the value and the range.
    pub fn validate(&self) -> Result<(), String> {
        use crate::limits::*;
        let rate = ANGULAR_RATE_NOISE_RANGE;
        let signed = |(_, max): (f64, f64)| (-max, max);
        if self.counts_per_rev == Some(0) {
            return Err("counts_per_rev: must be ≥ 1".into());
        }
        if self.steer_counts_per_rev == Some(0) {
            return Err("steer_counts_per_rev: must be ≥ 1".into());
        }
        if let Some(g) = self.gyro {
            check("gyro.noise_std", Some(g.noise_std), rate, "rad/s")?;
            check("gyro.bias", Some(g.bias), signed(rate), "rad/s")?;
            check("gyro.bias_std", Some(g.bias_std), rate, "rad/s")?;
        }
        if let Some(y) = self.yaw {
            check("yaw.noise_std", Some(y.noise_std), ANGLE_NOISE_RANGE, "rad")?;
        }
        if let Some(imu) = self.imu {
            check(
                "imu.gyro_noise_std",
                Some(imu.gyro_noise_std),
                rate,
                "rad/s",
            )?;
            for (i, b) in imu.gyro_bias.iter().enumerate() {
                check(
                    &format!("imu.gyro_bias[{i}]"),
                    Some(*b),
                    signed(rate),
                    "rad/s",
                )?;
            }
            check(
                "imu.accel_noise_std",
                Some(imu.accel_noise_std),
                ACCEL_NOISE_RANGE,
                "m/s²",
            )?;
            let field = (-MAX_MAGNETIC_FIELD, MAX_MAGNETIC_FIELD);
            check(
                "imu.mag_noise_std",
                Some(imu.mag_noise_std),
                (0.0, MAX_MAGNETIC_FIELD),
                "µT",
            )?;
            for (i, f) in imu.field.iter().enumerate() {
                check(&format!("imu.field[{i}]"), Some(*f), field, "µT")?;
            }
        }
        if let Some(t) = self.tilt {
            // Up to about 69°: beyond, the platform is lying on its side.
            let tilt = (-1.2, 1.2);
            check("tilt.roll", Some(t.roll), tilt, "rad")?;
            check("tilt.pitch", Some(t.pitch), tilt, "rad")?;
            check(
                "tilt.accel_noise_std",
                Some(t.accel_noise_std),
                ACCEL_NOISE_RANGE,
                "m/s²",
            )?;
        }
        if let Some(c) = self.camera {
            check("camera.period", Some(c.period), CAMERA_PERIOD_RANGE, "s")?;
            check("camera.latency", Some(c.latency), CAMERA_LATENCY_RANGE, "s")?;
            check(
                "camera.noise_std",
                Some(c.noise_std),
                POSITION_NOISE_RANGE,
                "m",
            )?;
            check(
                "camera.heading_noise_std",
                c.heading_noise_std,
                ANGLE_NOISE_RANGE,
                "rad",
            )?;
            check(
                "camera.outlier_probability",
                Some(c.outlier_probability),
                FRACTION_RANGE,
                "",
            )?;
            check(
                "camera.outlier_distance",
                Some(c.outlier_distance),
                OUTLIER_DISTANCE_RANGE,
                "m",
            )?;
        }
        if let Some(g) = self.camera_gaps {
            g.validate()?;
        }
        Ok(())
    }
}

/// One row of the encoder log (conventions.md, "Encoder log CSV for odometry").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncoderRow {
    /// Time, s.
    pub t: f64,
    /// Number of wheels: the used entries of `q` and `steer`.
    pub wheels: usize,
    /// Cumulative wheel angles as the encoders read them, rad (entries `0..wheels`).
    pub q: [f64; MAX_WHEELS],
    /// Steerable kinds (caster, swerve): steer angles as read, rad (entries `0..wheels`).
    pub steer: Option<[f64; MAX_WHEELS]>,
    /// Gyro z rate, rad/s.
    pub gyro_z: Option<f64>,
    /// Absolute yaw, rad.
    pub yaw: Option<f64>,
    /// Gyro x and y rates (tilted platform, [`SensorProfile::tilt`]), rad/s.
    pub gyro_xy: Option<[f64; 2]>,
    /// Specific force (tilted platform), m/s², platform frame.
    pub accel: Option<[f64; 3]>,
}

/// One IMU sample (body frame: x forward, y left, z up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuRow {
    /// Time, s.
    pub t: f64,
    /// Angular rate, rad/s.
    pub gyro: [f64; 3],
    /// Specific force, m/s² (`+9.81` on z at rest).
    pub accel: [f64; 3],
    /// Magnetic field, µT.
    pub mag: [f64; 3],
}

/// One camera fix of the robot centre (world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimulatedFix {
    /// When the frame was taken, s.
    pub t: f64,
    /// When it arrived, s (`t + latency`).
    pub arrival: f64,
    /// Measured x, m.
    pub x: f64,
    /// Measured y, m.
    pub y: f64,
    /// Measured heading, rad (if the camera measures it).
    pub heading: Option<f64>,
    /// Ground truth for tests: this frame is an injected outlier.
    pub outlier: bool,
}

/// Everything [`emit`] produced.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sensors {
    /// The encoder log, one row per trial sample.
    pub encoder: Vec<EncoderRow>,
    /// The IMU log (empty without [`SensorProfile::imu`]).
    pub imu: Vec<ImuRow>,
    /// Camera fixes in order of the time taken (empty without [`SensorProfile::camera`]).
    pub fixes: Vec<SimulatedFix>,
    /// The gyro-z bias actually applied in this trial (profile bias + drawn part), rad/s.
    pub gyro_bias: f64,
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

fn quantise(x: f64, counts_per_rev: Option<u32>) -> f64 {
    match counts_per_rev {
        Some(n) if n > 0 => {
            let step = std::f64::consts::TAU / n as f64;
            (x / step).floor() * step
        }
        _ => x,
    }
}

/// Derivative of `f` at sample `k` (central difference; one-sided at the ends).
fn derivative(t: &[f64], k: usize, f: impl Fn(usize) -> f64) -> f64 {
    let n = t.len();
    if n < 2 {
        return 0.0;
    }
    let (a, b) = if k == 0 {
        (0, 1)
    } else if k + 1 == n {
        (n - 2, n - 1)
    } else {
        (k - 1, k + 1)
    };
    (f(b) - f(a)) / (t[b] - t[a])
}

/// Second derivative of `f` at sample `k` (three-point formula for uneven spacing; 0 at ends).
fn second_derivative(t: &[f64], k: usize, f: impl Fn(usize) -> f64) -> f64 {
    if k == 0 || k + 1 >= t.len() {
        return 0.0;
    }
    let (h0, h1) = (t[k] - t[k - 1], t[k + 1] - t[k]);
    2.0 * (h0 * f(k + 1) - (h0 + h1) * f(k) + h1 * f(k - 1)) / (h0 * h1 * (h0 + h1))
}

/// The sensor logs of Monte-Carlo trial `index` of a run seeded `seed` (`omnikin simulate
/// --emit-sensors`): [`emit`] on a random stream of its own (seed salted, one per trial), so
/// the sensor noise does not change the plant's numbers and the logs do not depend on the
/// thread count.
pub fn emit_trial(
    robot: &Robot<f64>,
    index: usize,
    trial: &Trial,
    profile: &SensorProfile,
    seed: u64,
) -> Sensors {
    emit_trial_with_attitude(robot, index, trial, None, profile, seed)
}

/// [`emit_trial`] with the platform's attitude per sample ([`emit_with_attitude`]): the logs of
/// `omnikin simulate --plant dynamic --emit-sensors`, on the same random stream.
pub fn emit_trial_with_attitude(
    robot: &Robot<f64>,
    index: usize,
    trial: &Trial,
    attitude: Option<&[PlatformAttitude]>,
    profile: &SensorProfile,
    seed: u64,
) -> Sensors {
    let mut rng = crate::trial_rng(seed ^ 0x5E45_0125_5E45_0125, index);
    emit_with_attitude(robot, trial, attitude, profile, &mut rng)
}

/// The sensor logs a robot running `trial` would have recorded (see the module docs). `robot`
/// decides how many wheel columns there are and whether steer angles are written (steerable
/// kinds). All randomness comes from `rng`.
pub fn emit(
    robot: &Robot<f64>,
    trial: &Trial,
    profile: &SensorProfile,
    rng: &mut ChaCha8Rng,
) -> Sensors {
    emit_with_attitude(robot, trial, None, profile, rng)
}

/// As [`emit`], with the inertial sensors on a platform whose attitude a dynamic model gives
/// per sample (`attitude[k]` at `trial.t[k]`; see the module docs): the IMU and the encoder
/// log's gyro read the model's body rates and tilt, and the wheel angles are written as the
/// trial has them. `None` is [`emit`]. A [`SensorProfile::tilt`] is ignored when `attitude` is
/// given (the model tilts the platform); callers refuse it first.
pub fn emit_with_attitude(
    robot: &Robot<f64>,
    trial: &Trial,
    attitude: Option<&[PlatformAttitude]>,
    profile: &SensorProfile,
    rng: &mut ChaCha8Rng,
) -> Sensors {
    let wheels = robot.wheels();
    let steerable = robot.steerable();
    let t = &trial.t;
    let mut n = t.len().min(trial.pose.len()).min(trial.wheel_angles.len());
    if let Some(a) = attitude {
        n = n.min(a.len());
    }
    let heading = |k: usize| trial.pose[k].heading;
    let mut out = Sensors::default();
    if let Some(g) = profile.gyro {
        out.gyro_bias = g.bias + g.bias_std * gauss(rng);
    }
    let tilt = match attitude {
        Some(_) => None,
        None => profile.tilt.map(|p| (p, p.matrix())),
    };
    // The platform's tilt at sample k: the model's, else the profile's constant one.
    let tilt_at = |k: usize| -> Option<[[f64; 3]; 3]> {
        match attitude {
            Some(a) => Some(a[k].matrix()),
            None => tilt.map(|(_, m)| m),
        }
    };
    // A tilted sphere's or ballbot's wheels measure the shell's (ball's) rate relative to the
    // platform in the tilted platform frame: the level angles mapped by G Rᵀ G⁻¹ (linear, R
    // constant, so the cumulative angles map as their increments do). A dynamic model's wheel
    // angles are already the platform's own.
    let wheel_tilt = tilt.and_then(|(_, m)| {
        let (g, g_inv) = crate::odometry::tilt::shell_maps(robot)?;
        let r = omnikin::nalgebra::Matrix3::from_fn(|i, j| m[i][j]);
        Some(g * r.transpose() * g_inv)
    });
    // The IMU point's world position at sample i, relative to the pose's point at height 0:
    // the lever arm `Rz(ψ) M r` of a dynamic model's attitude (zero without one).
    let arm = |i: usize| -> [f64; 3] {
        match attitude {
            Some(a) if a[i].imu_offset != [0.0; 3] => {
                let m = a[i].matrix();
                let r = a[i].imu_offset;
                let h = [0, 1, 2].map(|row| (0..3).map(|j| m[row][j] * r[j]).sum::<f64>());
                let (s, c) = heading(i).sin_cos();
                [c * h[0] - s * h[1], s * h[0] + c * h[1], h[2]]
            }
            _ => [0.0; 3],
        }
    };
    // Specific force in the heading frame (x forward, y left, z up), m/s².
    let specific_force = |k: usize| {
        let (s, c) = heading(k).sin_cos();
        let ax = second_derivative(&t[..n], k, |i| trial.pose[i].x + arm(i)[0]);
        let ay = second_derivative(&t[..n], k, |i| trial.pose[i].y + arm(i)[1]);
        let az = second_derivative(&t[..n], k, |i| arm(i)[2]);
        [c * ax + s * ay, -s * ax + c * ay, 9.81 + az]
    };
    for k in 0..n {
        let mut level = trial.wheel_angles[k];
        if let Some(m) = &wheel_tilt {
            let v = m * omnikin::nalgebra::Vector3::new(level[0], level[1], level[2]);
            level[..3].copy_from_slice(v.as_slice());
        }
        let q = level.map(|x| quantise(x, profile.counts_per_rev));
        let steer = steerable.then(|| {
            trial
                .steer_angles
                .get(k)
                .copied()
                .unwrap_or([0.0; MAX_WHEELS])
                .map(|x| quantise(x, profile.steer_counts_per_rev))
        });
        let rate = derivative(&t[..n], k, heading);
        // The body rate of the (tilted) platform turning about the vertical: Rᵀ ψ̇ e₃; a
        // dynamic model's own body rate.
        let body = match (attitude, &tilt) {
            (Some(a), _) => a[k].body_rate,
            (None, Some((_, m))) => transpose_times(m, [0.0, 0.0, rate]),
            (None, None) => [0.0, 0.0, rate],
        };
        let gyro_z = profile
            .gyro
            .map(|g| body[2] + out.gyro_bias + g.noise_std * gauss(rng));
        let (gyro_xy, accel) = match (profile.gyro, &tilt) {
            (Some(g), Some((p, m))) => {
                let gxy = [0, 1].map(|i| body[i] + g.noise_std * gauss(rng));
                let f = transpose_times(m, specific_force(k));
                (
                    Some(gxy),
                    Some(f.map(|x| x + p.accel_noise_std * gauss(rng))),
                )
            }
            _ => (None, None),
        };
        let yaw = profile.yaw.map(|y| {
            let v = heading(k) + y.noise_std * gauss(rng);
            if y.wrap { omnikin::wrap_angle(v) } else { v }
        });
        out.encoder.push(EncoderRow {
            t: t[k],
            wheels,
            q,
            steer,
            gyro_z,
            yaw,
            gyro_xy,
            accel,
        });
    }
    if let Some(imu) = profile.imu {
        for k in 0..n {
            let (s, c) = heading(k).sin_cos();
            let wz = derivative(&t[..n], k, heading);
            let f = imu.field;
            let m = tilt_at(k);
            let level = |v: [f64; 3]| match &m {
                Some(m) => transpose_times(m, v),
                None => v,
            };
            let mut row = ImuRow {
                t: t[k],
                gyro: match attitude {
                    Some(a) => a[k].body_rate,
                    None => level([0.0, 0.0, wz]),
                },
                accel: level(specific_force(k)),
                mag: level([c * f[0] + s * f[1], -s * f[0] + c * f[1], f[2]]),
            };
            for i in 0..3 {
                row.gyro[i] += imu.gyro_bias[i] + imu.gyro_noise_std * gauss(rng);
                row.accel[i] += imu.accel_noise_std * gauss(rng);
                row.mag[i] += imu.mag_noise_std * gauss(rng);
            }
            out.imu.push(row);
        }
    }
    if let Some(cam) = profile.camera
        && cam.period > 0.0
        && n > 0
    {
        let mut next = t[0];
        for k in 0..n {
            if t[k] + 1e-9 < next {
                continue;
            }
            // The first frame time after this sample. Frames are usually sparser than samples
            // (one addition, as always); when many periods fit in one interval, jump over all
            // but the last two, so the work per sample is bounded whatever the period, and a
            // period below the resolution of t (addition cannot advance `next`) ends the fixes.
            let skip = ((t[k] + 1e-9 - next) / cam.period).floor();
            if skip >= 2.0 {
                next += (skip - 1.0) * cam.period;
            }
            let mut left = 4;
            while next <= t[k] + 1e-9 {
                let after = next + cam.period;
                if after <= next || left == 0 {
                    next = t[k] + cam.period;
                    if next <= t[k] + 1e-9 {
                        next = f64::INFINITY;
                    }
                    break;
                }
                next = after;
                left -= 1;
            }
            let p = trial.pose[k];
            let mut fix = SimulatedFix {
                t: t[k],
                arrival: t[k] + cam.latency,
                x: p.x + cam.noise_std * gauss(rng),
                y: p.y + cam.noise_std * gauss(rng),
                heading: cam.heading_noise_std.map(|s| p.heading + s * gauss(rng)),
                outlier: false,
            };
            if rng.random::<f64>() < cam.outlier_probability {
                let dir = rng.random_range(0.0..std::f64::consts::TAU);
                fix.x += cam.outlier_distance * dir.cos();
                fix.y += cam.outlier_distance * dir.sin();
                fix.outlier = true;
            }
            // Drawn only with gaps, so a profile without them keeps its stream.
            if let Some(g) = profile.camera_gaps {
                let lost = rng.random::<f64>() < g.dropout_probability;
                if lost || g.in_outage(fix.t) {
                    continue;
                }
            }
            out.fixes.push(fix);
        }
    }
    out
}

fn num(x: f64) -> String {
    // Shortest representation that reads back exactly, an exponent for tiny or huge values.
    omnikin_plan::CsvFloat(x).to_string()
}

/// Writes the encoder log CSV of conventions.md: `t,q1..qN`, then `s1..sN` (steerable kinds),
/// `gyro_z`, `yaw` when the rows carry them, and `gyro_x,gyro_y,accel_x,accel_y,accel_z` for a
/// tilted platform (the wheel count and the optional columns decided by the first row).
pub fn write_encoder_log<W: Write>(rows: &[EncoderRow], mut out: W) -> std::io::Result<()> {
    let first = rows.first();
    let (wheels, steer, gyro, yaw) = (
        first.map_or(0, |r| r.wheels.min(MAX_WHEELS)),
        first.is_some_and(|r| r.steer.is_some()),
        first.is_some_and(|r| r.gyro_z.is_some()),
        first.is_some_and(|r| r.yaw.is_some()),
    );
    let inertial = first.is_some_and(|r| r.gyro_xy.is_some() && r.accel.is_some());
    let mut header = String::from("t");
    for i in 1..=wheels {
        header.push_str(&format!(",q{i}"));
    }
    if steer {
        for i in 1..=wheels {
            header.push_str(&format!(",s{i}"));
        }
    }
    if gyro {
        header.push_str(",gyro_z");
    }
    if yaw {
        header.push_str(",yaw");
    }
    if inertial {
        header.push_str(",gyro_x,gyro_y,accel_x,accel_y,accel_z");
    }
    writeln!(out, "{header}")?;
    for r in rows {
        let mut line = num(r.t);
        for q in &r.q[..wheels] {
            line.push(',');
            line.push_str(&num(*q));
        }
        if steer {
            let s = r.steer.unwrap_or([f64::NAN; MAX_WHEELS]);
            for g in &s[..wheels] {
                line.push(',');
                line.push_str(&num(*g));
            }
        }
        if gyro {
            line.push_str(&format!(",{}", num(r.gyro_z.unwrap_or(f64::NAN))));
        }
        if yaw {
            line.push_str(&format!(",{}", num(r.yaw.unwrap_or(f64::NAN))));
        }
        if inertial {
            let g = r.gyro_xy.unwrap_or([f64::NAN; 2]);
            let a = r.accel.unwrap_or([f64::NAN; 3]);
            for v in g.iter().chain(&a) {
                line.push(',');
                line.push_str(&num(*v));
            }
        }
        writeln!(out, "{line}")?;
    }
    out.flush()
}

/// Writes camera fixes as the tracked-trajectory CSV of conventions.md, `t,x,y` plus `heading`
/// when the fixes carry it, plus an `arrival` column (s): `t` is when the frame was taken.
pub fn write_fixes<W: Write>(fixes: &[SimulatedFix], mut out: W) -> std::io::Result<()> {
    let heading = fixes.first().is_some_and(|f| f.heading.is_some());
    writeln!(
        out,
        "{}",
        if heading {
            "t,x,y,heading,arrival"
        } else {
            "t,x,y,arrival"
        }
    )?;
    for f in fixes {
        match (heading, f.heading) {
            (true, h) => writeln!(
                out,
                "{},{},{},{},{}",
                num(f.t),
                num(f.x),
                num(f.y),
                num(h.unwrap_or(f64::NAN)),
                num(f.arrival)
            )?,
            (false, _) => writeln!(
                out,
                "{},{},{},{}",
                num(f.t),
                num(f.x),
                num(f.y),
                num(f.arrival)
            )?,
        }
    }
    out.flush()
}

/// Writes the IMU log: `t,gx,gy,gz,ax,ay,az,mx,my,mz` (rad/s, m/s², µT; body frame).
pub fn write_imu<W: Write>(rows: &[ImuRow], mut out: W) -> std::io::Result<()> {
    writeln!(out, "t,gx,gy,gz,ax,ay,az,mx,my,mz")?;
    for r in rows {
        let v: Vec<String> = std::iter::once(r.t)
            .chain(r.gyro)
            .chain(r.accel)
            .chain(r.mag)
            .map(num)
            .collect();
        writeln!(out, "{}", v.join(","))?;
    }
    out.flush()
}

/// Writes the trial's true poses as the pose CSV of conventions.md, `t,x,y,heading` (the
/// ground truth to compare `omnikin odometry` output with).
pub fn write_truth<W: Write>(trial: &Trial, mut out: W) -> std::io::Result<()> {
    writeln!(out, "t,x,y,heading")?;
    for (t, p) in trial.t.iter().zip(&trial.pose) {
        writeln!(
            out,
            "{},{},{},{}",
            num(*t),
            num(p.x),
            num(p.y),
            num(p.heading)
        )?;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantisation_floors_to_whole_counts() {
        let step = std::f64::consts::TAU / 1000.0;
        assert_eq!(quantise(2.5 * step, Some(1000)), 2.0 * step);
        assert_eq!(quantise(-0.5 * step, Some(1000)), -step);
        assert_eq!(quantise(0.123, None), 0.123);
    }

    #[test]
    fn derivatives_of_a_parabola_are_exact() {
        let t = [0.0, 0.1, 0.25, 0.3, 0.5];
        let f = |i: usize| 3.0 * t[i] * t[i] + t[i];
        for k in 1..4 {
            assert!((second_derivative(&t, k, f) - 6.0).abs() < 1e-9);
        }
        // Central difference on even spacing of a parabola is exact.
        let u = [0.0, 0.1, 0.2];
        let g = |i: usize| 3.0 * u[i] * u[i];
        assert!((derivative(&u, 1, g) - 0.6).abs() < 1e-12);
    }

    #[test]
    fn wrap_range() {
        let pi = std::f64::consts::PI;
        assert!((omnikin::wrap_angle(3.0 * pi) - pi).abs() < 1e-12);
        assert!((omnikin::wrap_angle(-0.5 - 4.0 * pi) + 0.5).abs() < 1e-12);
    }
}
