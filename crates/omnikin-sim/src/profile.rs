//! Disturbance profiles: which imperfections the plant simulates, read from TOML.
//!
//! Every section and key is optional; an empty profile (the default) is the ideal kinematic
//! plant, which reproduces a plan to integration precision. Example:
//!
//! ```toml
//! rate = 1000.0                 # plant integration rate, Hz
//! hold = "linear"               # motor set-points between plan samples: "linear" or "zoh"
//!
//! [wheel_motor]                 # omni-wheel / roll motors
//! steps_per_rev = 200           # stepper quantisation (with microsteps)
//! microsteps = 16
//! max_step_rate = 40000.0       # steps/s; faster commands are clipped
//! lag_time_constant = 0.005     # s, first-order lag of the motor rate
//! max_accel = 300.0             # rad/s², ramp phases (paper 003 §4.2)
//! fluctuation_abs = 0.02        # rad/s, speed fluctuation amplitude (paper 003 §4.1)
//! fluctuation_rel = 0.01        # fraction of the rate, added to fluctuation_abs
//! fluctuation_period = 0.01     # s, the fluctuation is constant over this period
//! radius_error_std = 0.003      # relative wheel-radius error, drawn per wheel per trial
//! rate_bias_rel = 0.0           # relative rate bias (clock or gear-ratio error)
//!
//! [steer_motor]                 # steering motors (caster, swerve): same keys
//!
//! [shell_spin]                  # sphere-omni: the shell, ballbot: the ball (plant_step)
//! std = 0.01                    # rad/s, constant random spin per trial
//! slip_gain = 0.875             # speed-dependent spin Ω3 = gain·|V|^exponent·ω̃_z
//! slip_exponent = 1.22
//!
//! [roller]                      # sphere-omni: roller hand-over modulation of each wheel
//! amplitude = 0.02              # relative rate modulation
//! rollers = 8                   # rollers per wheel (modulation period 2π/rollers)
//!
//! [floor]                       # slip of the whole body on the floor
//! rel_std = 0.01                # relative velocity error (Ornstein–Uhlenbeck process)
//! corr_time = 0.5               # s, its correlation time
//!
//! [tracking]                    # what the camera sees
//! offset = [0.0, 0.0]           # tracked point in the robot frame relative to the centre, m
//! height = -0.03                # m above the centre (paper 000: platform top, 30 mm below)
//! tilt_gain = 1.0               # quasi-static lean toward the acceleration (0: level)
//! noise_std = 0.001             # m, white position noise per frame
//!
//! [encoder]                     # every robot: encoder quantisation of the wheel angles
//! counts_per_rev = 4096
//! ```

use serde::Deserialize;

/// Motor imperfections (wheel motors, or the steering motors of a steerable kind). All optional.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorProfile {
    /// Full steps per revolution of a stepper (quantisation); needs `microsteps` too.
    pub steps_per_rev: Option<u32>,
    /// Microsteps per full step (default 1).
    pub microsteps: Option<u32>,
    /// Largest step rate, steps/s (microsteps included); faster commands are clipped.
    pub max_step_rate: Option<f64>,
    /// Time constant of a first-order lag of the motor rate, s.
    pub lag_time_constant: Option<f64>,
    /// Largest acceleration of the motor rate, rad/s² (ramp phases, paper 003 §4.2).
    pub max_accel: Option<f64>,
    /// Absolute amplitude of the speed fluctuation, rad/s (paper 003 §4.1).
    pub fluctuation_abs: Option<f64>,
    /// Relative amplitude of the speed fluctuation (fraction of the rate).
    pub fluctuation_rel: Option<f64>,
    /// Period over which a fluctuation value holds, s (default: one plant step).
    pub fluctuation_period: Option<f64>,
    /// Standard deviation of the relative wheel-radius error, drawn per wheel per trial.
    pub radius_error_std: Option<f64>,
    /// Relative rate bias of every motor of this kind (step-generator clock or gear-ratio
    /// error): the motor runs at `(1 + bias)` times its rate. A constant speed error, the
    /// worst case of paper 003 §4.1's fluctuation.
    pub rate_bias_rel: Option<f64>,
}

/// Spin of the sphere's shell (or the ballbot's ball) about the vertical. All optional.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpinProfile {
    /// Standard deviation of a constant random spin per trial, rad/s.
    pub std: Option<f64>,
    /// Gain `g` of the speed-dependent spin slip `Ω3 = g·|V|^p·ω̃_z` (|V| in m/s): the shell
    /// gives way to the wheels' reaction torque when the platform turns (paper 000's suspected
    /// cause of the large circles at 0.4–0.5 m/s).
    pub slip_gain: Option<f64>,
    /// Exponent `p` of the speed-dependent spin slip (default 1).
    pub slip_exponent: Option<f64>,
}

/// Roller hand-over of the sphere's omni-wheels: the effective rate of wheel `i` is modulated
/// by `1 + amplitude·cos(rollers·q_i + phase_i)` (random phase per trial and wheel).
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RollerProfile {
    /// Relative modulation amplitude.
    pub amplitude: Option<f64>,
    /// Rollers per wheel (default 8).
    pub rollers: Option<u32>,
}

/// Floor slip: the body-frame velocity is scaled by `1 + e(t)` per axis, `e` an
/// Ornstein–Uhlenbeck process with standard deviation `rel_std` and correlation time
/// `corr_time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorProfile {
    /// Stationary standard deviation of the relative velocity error.
    pub rel_std: Option<f64>,
    /// Correlation time, s (default 0.5).
    pub corr_time: Option<f64>,
}

/// What an external tracker (camera) records.
///
/// The tracked point sits at `offset` (horizontal, robot frame) and `height` above the robot's
/// centre (the sphere's shell centre; paper 000 tracked the platform top, 120 mm above the floor
/// contact, i.e. 30 mm *below* the centre of its 0.15 m shell: `height = -0.03`). A kinematic
/// plant keeps the platform level, so the height matters only with `tilt_gain`: a quasi-static
/// lean `θ = atan(tilt_gain·|a|/g)` of the platform toward the body's acceleration `a`, which
/// moves the tracked point horizontally by `−height·sin θ` along `a`. This is a stand-in for
/// the platform's rocking, not a dynamic model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackingProfile {
    /// Horizontal position of the tracked point relative to the robot centre, robot frame, m.
    pub offset: Option<[f64; 2]>,
    /// Height of the tracked point above the robot centre, m (negative: below).
    pub height: Option<f64>,
    /// Gain of the quasi-static lean toward the acceleration (0: level platform).
    pub tilt_gain: Option<f64>,
    /// Standard deviation of white position noise per recorded sample, m.
    pub noise_std: Option<f64>,
}

/// Wheel encoders: the recorded wheel angles are quantised to whole counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EncoderProfile {
    /// Counts per wheel revolution (after any quadrature multiplication).
    pub counts_per_rev: Option<u32>,
}

/// How motor set-points are interpolated between plan samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Hold {
    /// Linear ramp between samples (a stepper driver's ramp generator).
    #[default]
    Linear,
    /// Zero-order hold: each sample's rate until the next.
    Zoh,
}

/// A complete disturbance profile (see the module docs for the TOML form).
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    /// Plant integration rate, Hz (default 1000).
    pub rate: Option<f64>,
    /// Set-point interpolation between plan samples.
    #[serde(default)]
    pub hold: Hold,
    /// Roll / omni-wheel motors.
    #[serde(default)]
    pub wheel_motor: MotorProfile,
    /// Steering motors of the steerable kinds (caster, swerve).
    #[serde(default)]
    pub steer_motor: MotorProfile,
    /// Shell (ball) spin.
    #[serde(default)]
    pub shell_spin: SpinProfile,
    /// Roller hand-over.
    #[serde(default)]
    pub roller: RollerProfile,
    /// Floor slip.
    #[serde(default)]
    pub floor: FloorProfile,
    /// Tracking.
    #[serde(default)]
    pub tracking: TrackingProfile,
    /// Wheel encoders.
    #[serde(default)]
    pub encoder: EncoderProfile,
}

/// `text` without a leading UTF-8 byte-order mark (editors on Windows write one).
pub(crate) fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// A profile that failed to load: file, line or field, rule.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct ProfileError {
    /// The file (or `<string>`).
    pub file: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// What is wrong: the key and the rule.
    pub message: String,
}

impl Profile {
    /// The sections of this profile that `robot`'s kind does not simulate, one sentence each
    /// (empty when every section applies): a `[shell_spin]` without a shell or ball, a
    /// `[steer_motor]` without steering — ignored without a word before, so a mecanum "with
    /// spin slip" ran as if ideal. The front ends print them as warnings.
    pub fn unused_sections(&self, robot: &omnikin::Robot<f64>) -> Vec<String> {
        let kind = robot.kind().name();
        let mut out = Vec::new();
        if !robot.kind().has_vertical_spin() && self.shell_spin != Default::default() {
            out.push(format!(
                "[shell_spin] applies to sphere-omni and ballbot only; robot kind {kind} ignores \
                 it (for slip on the floor use [floor])"
            ));
        }
        if !robot.steerable() && self.steer_motor != Default::default() {
            out.push(format!(
                "[steer_motor] applies to kinds with steering (caster3, swerve) only; robot kind \
                 {kind} ignores it"
            ));
        }
        out
    }

    /// The plant integration rate, Hz.
    pub fn rate_hz(&self) -> f64 {
        self.rate.unwrap_or(1000.0)
    }

    /// Reads and validates a profile file.
    pub fn load(path: &std::path::Path) -> Result<Self, ProfileError> {
        let file = path.display().to_string();
        let text = omnikin::description::read_text_limited(
            path,
            omnikin::description::MAX_TOML_BYTES,
            "MAX_TOML_BYTES of omnikin::description",
        )
        .map_err(|e| ProfileError {
            file: file.clone(),
            line: None,
            message: format!("cannot read: {e}"),
        })?;
        Self::from_toml_str(&text, &file)
    }

    /// Parses and validates a profile from TOML text.
    pub fn from_toml_str(text: &str, file: &str) -> Result<Self, ProfileError> {
        let text = strip_bom(text);
        let p: Profile = toml::from_str(text).map_err(|e| ProfileError {
            file: file.to_string(),
            line: e
                .span()
                .map(|s| 1 + text[..s.start.min(text.len())].matches('\n').count()),
            message: e.message().trim().to_string(),
        })?;
        p.validate().map_err(|message| ProfileError {
            file: file.to_string(),
            line: None,
            message,
        })?;
        Ok(p)
    }

    /// Checks every value's range (the `*_RANGE` constants of [`crate::limits`]); the error
    /// names the key, the value and the range or rule.
    pub fn validate(&self) -> Result<(), String> {
        use crate::limits::*;
        let int = |v: Option<u32>| v.map(f64::from);
        check("rate", self.rate, PLANT_RATE_RANGE, "Hz")?;
        for (name, m) in [
            ("wheel_motor", &self.wheel_motor),
            ("steer_motor", &self.steer_motor),
        ] {
            let key = |k: &str| format!("{name}.{k}");
            check(
                &key("steps_per_rev"),
                int(m.steps_per_rev),
                STEPS_PER_REV_RANGE,
                "",
            )?;
            check(&key("microsteps"), int(m.microsteps), MICROSTEPS_RANGE, "")?;
            if m.microsteps.is_some() && m.steps_per_rev.is_none() {
                return Err(format!("{name}.microsteps: needs {name}.steps_per_rev"));
            }
            check(
                &key("max_step_rate"),
                m.max_step_rate,
                STEP_RATE_RANGE,
                "steps/s",
            )?;
            if m.max_step_rate.is_some() && m.steps_per_rev.is_none() {
                return Err(format!("{name}.max_step_rate: needs {name}.steps_per_rev"));
            }
            check(
                &key("lag_time_constant"),
                m.lag_time_constant,
                MOTOR_TIME_RANGE,
                "s",
            )?;
            check(&key("max_accel"), m.max_accel, MOTOR_ACCEL_RANGE, "rad/s²")?;
            check(
                &key("fluctuation_abs"),
                m.fluctuation_abs,
                FLUCTUATION_ABS_RANGE,
                "rad/s",
            )?;
            check(
                &key("fluctuation_rel"),
                m.fluctuation_rel,
                FRACTION_RANGE,
                "",
            )?;
            check(
                &key("fluctuation_period"),
                m.fluctuation_period,
                MOTOR_TIME_RANGE,
                "s",
            )?;
            check(
                &key("radius_error_std"),
                m.radius_error_std,
                RADIUS_ERROR_RANGE,
                "",
            )?;
            if let Some(b) = m.rate_bias_rel
                && !(b.is_finite() && b.abs() < 1.0)
            {
                return Err(format!(
                    "{name}.rate_bias_rel: must be finite with |bias| < 1 (got {})",
                    num(b)
                ));
            }
        }
        check(
            "shell_spin.std",
            self.shell_spin.std,
            ANGULAR_RATE_NOISE_RANGE,
            "rad/s",
        )?;
        check(
            "shell_spin.slip_gain",
            self.shell_spin.slip_gain,
            SLIP_GAIN_RANGE,
            "",
        )?;
        check(
            "shell_spin.slip_exponent",
            self.shell_spin.slip_exponent,
            SLIP_EXPONENT_RANGE,
            "",
        )?;
        check(
            "roller.amplitude",
            self.roller.amplitude,
            FRACTION_RANGE,
            "",
        )?;
        if self.roller.amplitude.unwrap_or(0.0) >= 1.0 {
            return Err("roller.amplitude: must be < 1".into());
        }
        check(
            "roller.rollers",
            int(self.roller.rollers),
            ROLLERS_RANGE,
            "",
        )?;
        check("floor.rel_std", self.floor.rel_std, FRACTION_RANGE, "")?;
        check(
            "floor.corr_time",
            self.floor.corr_time,
            CORR_TIME_RANGE,
            "s",
        )?;
        check(
            "tracking.noise_std",
            self.tracking.noise_std,
            POSITION_NOISE_RANGE,
            "m",
        )?;
        check(
            "tracking.tilt_gain",
            self.tracking.tilt_gain,
            TILT_GAIN_RANGE,
            "",
        )?;
        let offset = (-MAX_TRACKING_OFFSET, MAX_TRACKING_OFFSET);
        check("tracking.height", self.tracking.height, offset, "m")?;
        if let Some(o) = self.tracking.offset {
            check("tracking.offset[0]", Some(o[0]), offset, "m")?;
            check("tracking.offset[1]", Some(o[1]), offset, "m")?;
        }
        if self.encoder.counts_per_rev == Some(0) {
            return Err("encoder.counts_per_rev: must be ≥ 1".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn module_doc_example_parses() {
        let doc = include_str!("profile.rs");
        let example: String = doc
            .lines()
            .skip_while(|l| !l.starts_with("//! ```toml"))
            .skip(1)
            .take_while(|l| !l.starts_with("//! ```"))
            .map(|l| l.trim_start_matches("//!").trim_start_matches(' '))
            .collect::<Vec<_>>()
            .join("\n");
        let p = Profile::from_toml_str(&example, "doc").unwrap();
        assert_eq!(p.wheel_motor.steps_per_rev, Some(200));
        assert_eq!(p.hold, Hold::Linear);
        assert_eq!(p.roller.rollers, Some(8));
    }

    #[test]
    fn empty_profile_is_ideal() {
        let p = Profile::from_toml_str("", "empty").unwrap();
        assert_eq!(p, Profile::default());
        assert_eq!(p.rate_hz(), 1000.0);
    }

    #[test]
    fn bad_profiles_name_the_key() {
        let e = Profile::from_toml_str("[wheel_motor]\nmax_accel = -3\n", "p.toml").unwrap_err();
        assert_eq!(
            e.to_string(),
            "p.toml: wheel_motor.max_accel: -3 rad/s² is outside the plausible range \
             [0.001, 1e7] rad/s² (omnikin_sim::limits)"
        );
        let e = Profile::from_toml_str("rate = 1000.0\n[floor]\nrel_sdt = 0.1\n", "p.toml")
            .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("p.toml:3: unknown field `rel_sdt`"),
            "{e}"
        );
        let e = Profile::from_toml_str("hold = \"cubic\"\n", "p.toml").unwrap_err();
        assert!(e.to_string().contains("p.toml:1"), "{e}");
        let e = Profile::from_toml_str("[roller]\namplitude = 1.5\n", "p.toml").unwrap_err();
        assert!(e.to_string().contains("roller.amplitude"), "{e}");
        let e = Profile::from_toml_str("[steer_motor]\nmicrosteps = 16\n", "p.toml").unwrap_err();
        assert!(
            e.to_string().contains("needs steer_motor.steps_per_rev"),
            "{e}"
        );
    }
}
