//! Platform tilt from a 3-axis gyro and an accelerometer in the encoder log, so that the heading
//! rate (and the sphere's or ballbot's `Ω3`) is the body rate about the **vertical**, not about
//! the gyro's z axis.
//!
//! On a platform tilted by `θ` and turning at `ψ̇` about the vertical, the gyro's z axis reads
//! `cos θ · ψ̇`: integrating `gyro_z` biases the heading rate, and hence `Ω3`, by
//! `−ψ̇ (1 − cos θ)`. The core's attitude filter ([`omnikin::estimate::ahrs::Mahony`], no
//! magnetometer) tracks roll and pitch from the gyro and the direction of gravity; the heading
//! rate is then `e₃ᵀ R (ω − b̂)` ([`Mahony::vertical_rate`]). The accelerometer reads
//! `Rᵀ (a + g e₃)`: the platform's own horizontal acceleration `a`, from the wheel odometry
//! (`a = v̇ + ψ̇ e₃ × v` in the heading frame, both low-passed with [`SMOOTHING`]), is removed
//! before the filter sees it, or a robot on a circle would read its centripetal acceleration as
//! tilt (`atan(a/g)`: 0.08 rad at 0.8 m/s²). While the platform only turns about the vertical,
//! a tilt error `δθ` changes the vertical rate by `ψ̇ (1 − cos δθ)` only (second order), so the
//! heading rate is robust to it; the reported tilt is not.
//!
//! The tilt's 1-σ error, `σ_θ² = r̄² k_P Δt / 2 + (σ_a / g)²`, combines the scatter `r̄` (rms)
//! of the accelerometer's direction about the filter's vertical, averaged by the filter
//! (bandwidth `k_P`), and an accelerometer bias prior [`ACCEL_BIAS_PRIOR`] that no averaging
//! removes. An error `δθ` (a small rotation about a horizontal axis of the world) moves the
//! vertical rate `e₃ᵀ R ω` by `(δθ × Rω)·e₃` to first order, at most `|ω_h| δθ` with `ω_h` the
//! horizontal part of the body rate in the world (zero while the platform only turns about the
//! vertical), and by `ψ̇ (1 − cos δθ) ≈ ψ̇ δθ²/2` to second order; so `Ω3`'s bound gains
//! `√((σ_θ · mean |ω_h|)² + (mean |ψ̇| · σ_θ²)²)` (fully correlated over the log: added, not
//! averaged down).
//!
//! A sphere's or ballbot's wheels see the tilt as well: they measure the shell's (ball's)
//! rotation relative to the platform in the tilted platform frame, so their increments are
//! de-tilted before the level kinematics ([`shell_maps`], `Δχ_level = G R G⁻¹ Δχ`), and `Ω3`
//! is then the shell's rate about the vertical, `e₃ · (ω + ω̃)`. A tilt error then also mixes
//! the shell's rolling into it: `ω_h` above is the shell's horizontal rate for these kinds.

use omnikin::Robot;
use omnikin::estimate::ahrs::{AhrsError, Mahony, MahonyGains};
use omnikin::estimate::odometry::OdometryStep;
use omnikin::nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// The linear maps between the wheel rates and the rate `ω̃` of the shell (sphere) or ball
/// (ballbot) relative to the platform in the platform frame: `(G, G⁻¹)` with `χ̇ = G ω̃`
/// (paper 000 eq. 4.4; paper 001 likewise). `None` for the other kinds.
///
/// On a platform tilted by `R` (platform → heading frame, roll and pitch) the wheels measure
/// `ω̃` in the *tilted* frame, `Rᵀ ω̃_h` with `ω̃_h` the relative rate in the heading frame, so
/// wheel increments `Δχ` of a tilted platform are those of a level one mapped by
/// `G Rᵀ G⁻¹`, and the level increments the odometry's kinematics expect are `G R G⁻¹ Δχ`.
pub fn shell_maps(robot: &Robot<f64>) -> Option<(Matrix3<f64>, Matrix3<f64>)> {
    let columns = |f: &dyn Fn(usize) -> Option<Vector3<f64>>| -> Option<Matrix3<f64>> {
        let c = [f(0)?, f(1)?, f(2)?];
        Some(Matrix3::from_columns(&c))
    };
    let unit = |i: usize| {
        let mut e = [0.0; 3];
        e[i] = 1.0;
        e
    };
    match robot {
        Robot::Sphere(m) => Some((
            columns(&|i| {
                m.wheel_rates_from_relative(unit(i).into())
                    .ok()
                    .map(Vector3::from)
            })?,
            columns(&|i| m.relative_rate_from_wheels(unit(i)).ok())?,
        )),
        Robot::Ballbot(m) => Some((
            columns(&|i| {
                m.wheel_rates_from_relative(unit(i).into())
                    .ok()
                    .map(Vector3::from)
            })?,
            columns(&|i| m.relative_rate_from_wheels(unit(i)).ok())?,
        )),
        _ => None,
    }
}

/// Time constant of the low-pass filters on the odometry velocity and its derivative, s.
pub const SMOOTHING: f64 = 0.1;

/// Accelerometer bias assumed when bounding the tilt, m/s² (a consumer MEMS part after a
/// level calibration).
pub const ACCEL_BIAS_PRIOR: f64 = 0.02;

/// Standard gravity used to turn the bias prior into an angle, m/s².
const G: f64 = 9.81;

/// The tilt estimate over a log and its figures.
#[derive(Clone, Debug)]
pub(crate) struct TiltTracker {
    ahrs: Option<Mahony<f64>>,
    gains: MahonyGains<f64>,
    last_t: f64,
    /// Smoothed robot-frame velocity (m/s) and yaw rate (rad/s).
    v: [f64; 2],
    yaw_rate: f64,
    /// Smoothed derivative of `v`, m/s².
    dv: [f64; 2],
    /// Horizontal acceleration in the heading frame, m/s².
    accel: [f64; 2],
    /// Vertical rate minus gyro z of the last sample, rad/s.
    pub(crate) last_difference: f64,
    samples: usize,
    tilt_sum: f64,
    tilt_max: f64,
    residual2_sum: f64,
    horizontal_sum: f64,
    vertical_sum: f64,
    dt_sum: f64,
    /// Body rate of the last sample in the world frame (bias removed), rad/s.
    last_world_rate: Vector3<f64>,
    /// Sum and count of `|Ω_h|`, the horizontal rate of the shell or ball (platform rate plus
    /// the wheels' relative rate) in the world, over the de-tilted steps.
    shell_horizontal_sum: f64,
    shell_samples: usize,
}

/// What the tracker saw over the log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TiltFigures {
    pub(crate) mean_tilt: f64,
    pub(crate) max_tilt: f64,
    pub(crate) tilt_std: f64,
    /// Mean `|ω_h|`, rad/s: the horizontal body rate in the world of the platform, or, for a
    /// sphere or ballbot whose wheel increments are de-tilted ([`shell_maps`]), of the shell
    /// or ball (platform rate plus the wheels' relative rate).
    pub(crate) mean_horizontal_rate: f64,
    /// Mean `|ψ̇|` (the vertical rate), rad/s.
    pub(crate) mean_vertical_rate: f64,
}

impl TiltFigures {
    /// The tilt error's share of the 1-σ bound of a mean vertical rate, rad/s.
    pub(crate) fn rate_std(&self) -> f64 {
        let s = self.tilt_std;
        (s * self.mean_horizontal_rate).hypot(self.mean_vertical_rate * s * s)
    }
}

impl TiltTracker {
    pub(crate) fn new() -> Self {
        Self {
            ahrs: None,
            gains: MahonyGains::default_gains(),
            last_t: 0.0,
            v: [0.0; 2],
            yaw_rate: 0.0,
            dv: [0.0; 2],
            accel: [0.0; 2],
            last_difference: 0.0,
            samples: 0,
            tilt_sum: 0.0,
            tilt_max: 0.0,
            residual2_sum: 0.0,
            horizontal_sum: 0.0,
            vertical_sum: 0.0,
            dt_sum: 0.0,
            last_world_rate: Vector3::zeros(),
            shell_horizontal_sum: 0.0,
            shell_samples: 0,
        }
    }

    /// One log sample: `gyro` (rad/s, platform frame, the known z bias removed) and `accel`
    /// (m/s², specific force, platform frame). Returns the heading rate about the vertical.
    pub(crate) fn step(
        &mut self,
        t: f64,
        gyro: [f64; 3],
        accel: [f64; 3],
    ) -> Result<f64, AhrsError> {
        let Some(ahrs) = self.ahrs.as_mut() else {
            // At the start the odometry knows no acceleration: the robot is taken as still.
            let a = Mahony::from_accel(self.gains, 0.0, accel)?;
            self.ahrs = Some(a);
            self.last_t = t;
            return Ok(self.record(gyro, None));
        };
        let dt = t - self.last_t;
        if dt <= 0.0 {
            let rate = ahrs.vertical_rate(gyro);
            self.last_difference = rate - gyro[2];
            return Ok(rate);
        }
        self.last_t = t;
        // The platform's own acceleration, heading frame → platform frame (the filter's yaw is
        // its own integral; only the tilt part of the rotation is used).
        let q = ahrs.quaternion();
        let yaw = UnitQuaternion::from_euler_angles(0.0, 0.0, ahrs.attitude().yaw);
        let a_body = q.inverse() * (yaw * Vector3::new(self.accel[0], self.accel[1], 0.0));
        let corrected = Vector3::from(accel) - a_body;
        let up = Vector3::from(ahrs.up_in_body());
        let residual = if corrected.norm() > 0.0 {
            (corrected.normalize().cross(&up).norm()).min(1.0).asin()
        } else {
            0.0
        };
        ahrs.update(dt, gyro, corrected.into(), None)?;
        self.dt_sum += dt;
        Ok(self.record(gyro, Some(residual)))
    }

    fn record(&mut self, gyro: [f64; 3], residual: Option<f64>) -> f64 {
        let Some(ahrs) = self.ahrs.as_ref() else {
            return gyro[2];
        };
        let rate = ahrs.vertical_rate(gyro);
        let b = ahrs.gyro_bias();
        let w = ahrs.quaternion() * (Vector3::from(gyro) - Vector3::from(b));
        let tilt = ahrs.tilt();
        self.samples += 1;
        self.tilt_sum += tilt;
        self.tilt_max = self.tilt_max.max(tilt);
        self.horizontal_sum += w.x.hypot(w.y);
        self.last_world_rate = w;
        self.vertical_sum += rate.abs();
        if let Some(r) = residual {
            self.residual2_sum += r * r;
        }
        self.last_difference = rate - gyro[2];
        rate
    }

    /// The level wheel increments of a tilted sphere's or ballbot's increments `dq` over `dt`
    /// seconds (`maps` from [`shell_maps`]): `G R G⁻¹ Δχ` with `R` the filter's current tilt
    /// (platform → heading frame). Records the shell's horizontal rate for the bound. Before
    /// the first sample, or with `dt ≤ 0`, `dq` unchanged.
    pub(crate) fn level_increments(
        &mut self,
        maps: &(Matrix3<f64>, Matrix3<f64>),
        dq: [f64; 3],
        dt: f64,
    ) -> [f64; 3] {
        let Some(ahrs) = self.ahrs.as_ref() else {
            return dq;
        };
        let q = ahrs.quaternion();
        let yaw = UnitQuaternion::from_euler_angles(0.0, 0.0, ahrs.attitude().yaw);
        let tilt = yaw.inverse() * q;
        let rel = maps.1 * Vector3::from(dq);
        if dt > 0.0 {
            let shell = self.last_world_rate + q * (rel / dt);
            self.shell_horizontal_sum += shell.x.hypot(shell.y);
            self.shell_samples += 1;
        }
        (maps.0 * (tilt * rel)).into()
    }

    /// After the odometry step of the sample: updates the platform's acceleration.
    pub(crate) fn after_step(&mut self, s: &OdometryStep<f64>) {
        if s.dt <= 0.0 {
            return;
        }
        let a = 1.0 - (-s.dt / SMOOTHING).exp();
        let old = self.v;
        let v = [s.twist.vx, s.twist.vy];
        for i in 0..2 {
            self.v[i] += a * (v[i] - self.v[i]);
            let d = (self.v[i] - old[i]) / s.dt;
            self.dv[i] += a * (d - self.dv[i]);
        }
        self.yaw_rate += a * (s.twist.yaw_rate - self.yaw_rate);
        // a = v̇ + ψ̇ e₃ × v.
        self.accel = [
            self.dv[0] - self.yaw_rate * self.v[1],
            self.dv[1] + self.yaw_rate * self.v[0],
        ];
    }

    /// The figures over the log (`None` before the first sample).
    pub(crate) fn figures(&self) -> Option<TiltFigures> {
        if self.samples == 0 {
            return None;
        }
        let n = self.samples as f64;
        let updates = (self.samples - 1).max(1) as f64;
        let dt = self.dt_sum / updates;
        let rms2 = self.residual2_sum / updates;
        let floor = ACCEL_BIAS_PRIOR / G;
        Some(TiltFigures {
            mean_tilt: self.tilt_sum / n,
            max_tilt: self.tilt_max,
            tilt_std: (rms2 * self.gains.kp * dt / 2.0 + floor * floor).sqrt(),
            // The reported vertical rate is the shell's once the wheels are de-tilted: its
            // horizontal rate is what a tilt error turns into a vertical one.
            mean_horizontal_rate: if self.shell_samples > 0 {
                self.shell_horizontal_sum / self.shell_samples as f64
            } else {
                self.horizontal_sum / n
            },
            mean_vertical_rate: self.vertical_sum / n,
        })
    }
}
