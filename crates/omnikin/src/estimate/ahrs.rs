//! Attitude and heading from a 3-axis gyroscope, accelerometer and magnetometer (the inertial
//! unit on paper 000's control board): Mahony's explicit complementary filter on SO(3), whose
//! integral term estimates the gyro bias.
//!
//! [`Mahony`] implements the "explicit complementary filter with bias correction" of Mahony,
//! Hamel & Pflimlin, *Nonlinear complementary filters on the special orthogonal group*, IEEE
//! TAC 53(5), 2008, eqs. (32)–(33), in the quaternion form popularised by Madgwick's 2010
//! report (`MahonyAHRS`): the correction `e = â × v̂ + ê_m` (measured × predicted reference
//! directions) drives the gyro rates through a proportional gain `k_P` and an integral term
//! `b̂̇ = −k_I e` that converges to the gyro bias. Two deliberate differences from that report:
//! the magnetometer term is the sine of the horizontal heading error applied about the
//! estimated vertical (its gain does not depend on the field's dip, and a magnetic disturbance
//! acts on the yaw, reaching roll and pitch only through the small bias transient), and the reference field's horizontal direction is a
//! parameter (REP-103 world frames are east-north-up, so magnetic north is `+y`, azimuth π/2,
//! unless you choose otherwise). The quaternion is advanced with the exact exponential of the
//! corrected rate over the step.
//!
//! Frames: body x forward, y left, z up; the quaternion maps body to world (`v_world = q v_body`).
//! The accelerometer measures specific force (`+g` along body `+z` when level and still); units
//! of the accelerometer and magnetometer do not matter (they are normalised). Angles in rad,
//! rates in rad/s, roll/pitch/yaw in the Z-Y-X convention (`R = Rz(yaw) Ry(pitch) Rx(roll)`).

use nalgebra::{UnitQuaternion, Vector3};

use crate::Real;

/// Why an AHRS update was rejected. The state is left unchanged.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum AhrsError {
    /// An input value is NaN or infinite.
    #[error("{field} must be finite")]
    NonFinite {
        /// The input's name (`"dt"`, `"gyro[0]"`, `"accel"`, …).
        field: &'static str,
    },
    /// The time step is not positive.
    #[error("dt must be > 0 (got {dt} s)")]
    NonPositiveDt {
        /// The step given, s.
        dt: f64,
    },
    /// A reference vector has zero length (or, for the magnetometer, is vertical), so it has
    /// no direction.
    #[error("{field} has no usable direction (zero or vertical)")]
    Degenerate {
        /// `"accel"` or `"mag"`.
        field: &'static str,
    },
}

/// Gains of the Mahony filter: `kp` (rad/s per unit of the cross-product error; sets the
/// crossover frequency, ≈ `kp` rad/s) and `ki` (rad/s² per unit error; the bias-estimation
/// bandwidth, keep `ki ≪ kp²`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MahonyGains<T> {
    /// Proportional gain, rad/s.
    pub kp: T,
    /// Integral gain, rad/s².
    pub ki: T,
}

impl<T: Real> MahonyGains<T> {
    /// `kp = 1 rad/s`, `ki = 0.05 rad/s²`: accelerometer/magnetometer trusted above ~0.16 Hz,
    /// bias converging in tens of seconds.
    pub fn default_gains() -> Self {
        Self {
            kp: T::one(),
            ki: T::of(0.05),
        }
    }
}

/// Orientation and gyro bias estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Attitude<T> {
    /// Roll about body x, rad, in (−π, π].
    pub roll: T,
    /// Pitch about body y, rad, in [−π/2, π/2].
    pub pitch: T,
    /// Yaw (heading) about world z, rad, in (−π, π], counter-clockwise from world +x.
    pub yaw: T,
    /// Estimated gyro bias (body frame), rad/s: subtract it from raw gyro readings.
    pub gyro_bias: [T; 3],
}

/// Mahony explicit complementary filter (Mahony et al. 2008) with gyro-bias estimation.
/// Fixed-size state (a quaternion and a 3-vector), `Copy`, no allocation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mahony<T: Real> {
    q: UnitQuaternion<T>,
    bias: Vector3<T>,
    gains: MahonyGains<T>,
    field_azimuth: T,
}

fn vec3<T: Real>(v: [T; 3], field: &'static str) -> Result<Vector3<T>, AhrsError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(Vector3::from(v))
    } else {
        Err(AhrsError::NonFinite { field })
    }
}

impl<T: Real> Mahony<T> {
    /// A filter starting level and facing world +x, with zero bias. `field_azimuth` (rad) is
    /// the direction of the horizontal magnetic field in the world frame, counter-clockwise
    /// from +x (π/2 for an east-north-up world with magnetic north; add the declination for
    /// true north).
    pub fn new(gains: MahonyGains<T>, field_azimuth: T) -> Self {
        Self {
            q: UnitQuaternion::identity(),
            bias: Vector3::zeros(),
            gains,
            field_azimuth,
        }
    }

    /// A filter initialised from one still accelerometer and magnetometer reading: roll and pitch
    /// from gravity, yaw from the tilt-compensated field (`yaw = azimuth − atan2(h_y, h_x)`).
    ///
    /// # Errors
    /// [`AhrsError::NonFinite`] or [`AhrsError::Degenerate`].
    pub fn from_accel_mag(
        gains: MahonyGains<T>,
        field_azimuth: T,
        accel: [T; 3],
        mag: [T; 3],
    ) -> Result<Self, AhrsError> {
        let a = vec3(accel, "accel")?;
        let m = vec3(mag, "mag")?;
        if !field_azimuth.is_finite() {
            return Err(AhrsError::NonFinite {
                field: "field_azimuth",
            });
        }
        if a.norm() <= T::zero() {
            return Err(AhrsError::Degenerate { field: "accel" });
        }
        let roll = a.y.atan2(a.z);
        let pitch = (-a.x).atan2(a.y.hypot(a.z));
        let tilt = UnitQuaternion::from_euler_angles(roll, pitch, T::zero());
        let h = tilt * m;
        if h.x.hypot(h.y) <= T::EPSILON * m.norm() {
            return Err(AhrsError::Degenerate { field: "mag" });
        }
        let yaw = field_azimuth - h.y.atan2(h.x);
        Ok(Self {
            q: UnitQuaternion::from_euler_angles(roll, pitch, yaw),
            bias: Vector3::zeros(),
            gains,
            field_azimuth,
        })
    }

    /// A filter initialised from one still accelerometer reading, without a magnetometer: roll
    /// and pitch from gravity (`roll = atan2(a_y, a_z)`, `pitch = atan2(−a_x, √(a_y² + a_z²))`),
    /// yaw 0. For a platform whose tilt matters and whose heading comes from elsewhere
    /// (wheels, camera): [`Mahony::update`] with `mag = None` then integrates the yaw.
    ///
    /// # Errors
    /// [`AhrsError::NonFinite`], or [`AhrsError::Degenerate`] for a zero reading.
    pub fn from_accel(
        gains: MahonyGains<T>,
        field_azimuth: T,
        accel: [T; 3],
    ) -> Result<Self, AhrsError> {
        let a = vec3(accel, "accel")?;
        if !field_azimuth.is_finite() {
            return Err(AhrsError::NonFinite {
                field: "field_azimuth",
            });
        }
        if a.norm() <= T::zero() {
            return Err(AhrsError::Degenerate { field: "accel" });
        }
        let roll = a.y.atan2(a.z);
        let pitch = (-a.x).atan2(a.y.hypot(a.z));
        Ok(Self {
            q: UnitQuaternion::from_euler_angles(roll, pitch, T::zero()),
            bias: Vector3::zeros(),
            gains,
            field_azimuth,
        })
    }

    /// The tilt: angle between the body's z axis and the world vertical, rad, in [0, π].
    pub fn tilt(&self) -> T {
        let z = self.q * Vector3::z();
        z.z.max(-T::one()).min(T::one()).acos()
    }

    /// The body rate `gyro` (raw, rad/s, body frame) less the estimated bias, projected onto
    /// the world vertical: `e₃ᵀ R (ω − b̂)`, rad/s. This is the heading rate of a tilted body
    /// (the gyro's z axis alone reads `cos(tilt)` of it when the body turns about the
    /// vertical); it depends on roll and pitch only, not on the (unobserved) yaw.
    pub fn vertical_rate(&self, gyro: [T; 3]) -> T {
        let w = Vector3::from(gyro) - self.bias;
        (self.q * w).z
    }

    /// The unit vector of the world vertical in the body frame, `Rᵀ e₃` (the direction the
    /// accelerometer reads gravity in when the body does not accelerate).
    pub fn up_in_body(&self) -> [T; 3] {
        (self.q.inverse() * Vector3::z()).into()
    }

    /// The orientation, body → world.
    pub fn quaternion(&self) -> UnitQuaternion<T> {
        self.q
    }

    /// Roll, pitch, yaw and gyro bias.
    pub fn attitude(&self) -> Attitude<T> {
        let (roll, pitch, yaw) = self.q.euler_angles();
        Attitude {
            roll,
            pitch,
            yaw,
            gyro_bias: self.bias.into(),
        }
    }

    /// Sets the yaw (rad, world, counter-clockwise from +x), keeping roll and pitch (a pose
    /// reset; without a magnetometer the yaw is otherwise only integrated).
    pub fn set_yaw(&mut self, yaw: T) {
        let (_, _, old) = self.q.euler_angles();
        let turn = UnitQuaternion::from_axis_angle(&nalgebra::Vector3::z_axis(), yaw - old);
        self.q = turn * self.q;
    }

    /// The gyro-bias estimate (body frame), rad/s.
    pub fn gyro_bias(&self) -> [T; 3] {
        self.bias.into()
    }

    /// One filter step of `dt` seconds with the raw gyro rates (rad/s, body frame), the
    /// accelerometer (any unit, body frame) and optionally the magnetometer (any unit, body
    /// frame). An accelerometer reading of zero length (free fall) skips the gravity correction;
    /// a magnetometer reading with no horizontal component skips the heading correction.
    ///
    /// With `v̂ = q⁻¹ e_z` the predicted direction of gravity, `h = q m` the measured field in the
    /// world and `δ` the angle from its horizontal part to the reference azimuth,
    /// `e = â × v̂ + sin(δ) v̂`, `b̂ ← b̂ − k_I e dt`, `ω = gyro − b̂ + k_P e`,
    /// `q ← q ⊗ exp(ω dt)` (Mahony et al. 2008, eqs. 32–33).
    ///
    /// # Errors
    /// [`AhrsError::NonFinite`] for any non-finite input, [`AhrsError::NonPositiveDt`].
    pub fn update(
        &mut self,
        dt: T,
        gyro: [T; 3],
        accel: [T; 3],
        mag: Option<[T; 3]>,
    ) -> Result<Attitude<T>, AhrsError> {
        if !dt.is_finite() {
            return Err(AhrsError::NonFinite { field: "dt" });
        }
        if dt.partial_cmp(&T::zero()) != Some(core::cmp::Ordering::Greater) {
            return Err(AhrsError::NonPositiveDt { dt: dt.to_f64() });
        }
        let g = vec3(gyro, "gyro")?;
        let a = vec3(accel, "accel")?;
        let m = match mag {
            Some(m) => Some(vec3(m, "mag")?),
            None => None,
        };
        let inv = self.q.inverse();
        let up = inv * Vector3::z();
        let mut e = Vector3::zeros();
        let an = a.norm();
        if an > T::zero() {
            e += (a / an).cross(&up);
        }
        if let Some(m) = m {
            // Heading error from the horizontal part of the measured field mapped into the
            // world: `sin δ = (ĥ_xy × b̂_xy)_z` with `b̂_xy` the reference direction; applied
            // about the vertical only (Madgwick 2010's reference `b = (|h_xy|, 0, h_z)`, with
            // the dip removed so the yaw gain does not depend on it).
            let h = self.q * m;
            let hxy = h.x.hypot(h.y);
            if hxy > T::EPSILON * m.norm() {
                let (s, c) = self.field_azimuth.sin_cos();
                let sin_delta = (h.x * s - h.y * c) / hxy;
                e += up * sin_delta;
            }
        }
        let bias = self.bias - e * (self.gains.ki * dt);
        let w = g - bias + e * self.gains.kp;
        let q = self.q * UnitQuaternion::from_scaled_axis(w * dt);
        if !(q.coords.iter().all(|x| x.is_finite()) && bias.iter().all(|x| x.is_finite())) {
            return Err(AhrsError::NonFinite { field: "state" });
        }
        self.q = UnitQuaternion::new_normalize(q.into_inner());
        self.bias = bias;
        Ok(self.attitude())
    }
}
