//! # identify — a robot's kinematic parameters from its recorded runs
//!
//! What `omnikin identify` computes: given a robot file (the prior) and, per run, an encoder
//! log, a reference trajectory (tracked truth or camera fixes) and optionally a gyro, the
//! wheel geometry that best explains the runs and the gyro's bias and scale, each with its 1σ.
//!
//! * [`runs`]: the input files (conventions.md's encoder log, fixes, tracked and IMU CSVs).
//! * [`params`]: which kinematic parameters each kind has, and the robot a value vector
//!   describes.
//! * [`model`]: the measurement models — dead reckoning against the reference (output error)
//!   and the gyro's integral over windows.
//! * [`lsq`]: Levenberg–Marquardt, the covariance `σ² (JᵀJ)⁻¹` and the rank test.
//! * [`plans`]: the test plans of `omnikin plan sysid`.
//! * [`robot_file`]: the input robot file rewritten with the fitted values.
//! * [`report`]: the table and the JSON object every front end prints.
//! * [`residual_series`]: each run's pose residuals against time, before and after the fit.
//!
//! ## The estimate
//! The unknowns are the kind's parameters ([`params::parameters`]) and, per run, the start pose
//! `(x₀, y₀, ψ₀)` (a nuisance: the reference fixes it). The residuals are the dead-reckoned
//! minus the reference positions (and headings when the reference has them), each group divided
//! by its own standard deviation: a first fit with [`Options::position_sigma`] and
//! [`Options::heading_sigma`], then a second with the groups' residual RMS of the first, so the
//! reported `σ² (JᵀJ)⁻¹` uses the noise the runs actually show. The gyro's bias and scale are
//! fitted in the same problem, on the windows of [`model::gyro_windows`] (a third residual
//! group), so the gyro scale's 1σ includes the uncertainty of the odometry's heading. The 1σ
//! are inflated for correlated residuals (dead reckoning correlates its errors; see
//! `correlation_inflation`).
//!
//! ## Observability
//! Before fitting, the Jacobian at the prior — on the logs the prior robot would have recorded
//! for the same motion ([`model::consistent_log`]), so that the prior's own error does not
//! make a gauge direction look observable — is tested ([`lsq::unobservable`]); each direction
//! of parameter space the runs do not see holds one parameter at its prior, reported as
//! [`FitStatus::Fixed`] with the reason. What the wheel kinematics never see: an omni wheel's
//! position along its own drive direction; with position-only references, the robot frame's
//! orientation (one drive angle is held); without spins, the wheel positions; without a
//! heading change, the gyro's scale; of a four-module swerve, 6 of its 12 numbers (a rotation
//! of all modules about the origin, the radius pattern `(+, −, −, +)`, three deformations).
//! The condition number of the remaining problem is
//! reported; values are never invented for a direction the data do not constrain.
//!
//! ## Dynamics
//! For sphere-omni with IMU logs, the platform's centre-of-mass depth and the rolling
//! resistance from the rocking after stops ([`rocking`]), and with a gyro the floor's pivot
//! friction from the decay of a spin after a stop ([`spin_decay`]), with the other `[dynamics]`
//! values taken from the file.
//!
//! What this does **not** do: the other dynamic parameters (the sphere's roller friction, the
//! ballbot's `[dynamics]`), slip or outlier rejection (a run with wheel slip biases the fit: use runs inside
//! the robot's limits, as `omnikin plan sysid` writes them), time offsets between the logs.

pub mod lsq;
pub mod model;
pub mod params;
pub mod plans;
pub mod report;
pub mod residual_series;
pub mod robot_file;
pub mod rocking;
pub mod runs;
pub mod spin_decay;

use omnikin::Pose2;
use omnikin::description::RobotDescription;

use model::ResidualWeights;
use params::Parameter;
use residual_series::{PoseResiduals, RunResiduals};
use runs::LoggedRun;

/// Why an identification failed. Every message names the file or parameter concerned.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IdentifyError {
    /// A file could not be used (the message names it, with the line when there is one).
    #[error("{0}")]
    Input(String),
    /// The prior robot does not build, or the fit failed.
    #[error("{0}")]
    Fit(String),
}

/// Settings of [`identify`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Position noise assumed by the first fit, m (the second uses the residuals').
    pub position_sigma: f64,
    /// Heading noise assumed by the first fit, rad.
    pub heading_sigma: f64,
    /// Length of the gyro windows, s.
    pub gyro_window: f64,
}

impl Default for Options {
    /// 5 mm, 5 mrad, 1 s windows.
    fn default() -> Self {
        Self {
            position_sigma: 0.005,
            heading_sigma: 0.005,
            gyro_window: 1.0,
        }
    }
}

/// Whether a parameter was fitted.
#[derive(Clone, Debug, PartialEq)]
pub enum FitStatus {
    /// Estimated from the runs.
    Fitted,
    /// Held at its prior; the reason says why (which the runs do not determine).
    Fixed(String),
}

/// One parameter's result.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterEstimate {
    /// Name, as in [`params::parameters`] (`gyro.bias`, `gyro.scale` for the gyro).
    pub name: String,
    /// Unit (`""` for scales, `"m"`, `"rad"`, `"rad/s"`).
    pub unit: &'static str,
    /// The robot file's value (gyro: bias 0, scale 1).
    pub prior: f64,
    /// The estimate (the prior when fixed).
    pub value: f64,
    /// 1σ from the covariance (0 when fixed).
    pub sigma: f64,
    /// Fitted or fixed, and why.
    pub status: FitStatus,
}

/// The result of [`identify`].
#[derive(Clone, Debug, PartialEq)]
pub struct Identified {
    /// The prior description with the fitted geometry.
    pub description: RobotDescription,
    /// The kinematic parameters, in [`params::parameters`] order.
    pub geometry: Vec<ParameterEstimate>,
    /// `gyro.bias` (rad/s) and `gyro.scale`, when a run had a gyro.
    pub gyro: Vec<ParameterEstimate>,
    /// RMS of the position residuals at the estimate, m.
    pub position_rms: f64,
    /// RMS of the heading residuals, rad (references with a heading).
    pub heading_rms: Option<f64>,
    /// RMS of the gyro windows' residuals, rad.
    pub gyro_rms: Option<f64>,
    /// Condition number of the (column-scaled) Jacobian of the fitted robot and gyro
    /// parameters (start poses aside).
    pub condition: f64,
    /// Number of residuals of the pose fit.
    pub residuals: usize,
    /// Each run's pose residuals against time, before (the prior) and after (the estimate),
    /// in the order of the runs.
    pub series: Vec<RunResiduals>,
    /// The dynamic parameters: sphere-omni's `dynamics.com_depth` (m) and
    /// `dynamics.rolling_resistance` from the rocking after stops, when a run has an IMU log
    /// ([`rocking`]), and `dynamics.pivot_friction` (N·m) from the decay of a spin after a
    /// stop, when a run has a gyro ([`spin_decay`]); empty otherwise.
    pub dynamics: Vec<ParameterEstimate>,
    /// The rocking fitted after each stop (sphere-omni with IMU logs).
    pub rocking: Vec<rocking::Rocking>,
    /// The spin's decay fitted after each stop of a spin in place (sphere-omni with a gyro).
    pub spin_decay: Vec<spin_decay::SpinDecay>,
}

/// The name of the sphere's centre-of-mass depth among [`Identified::dynamics`].
pub const COM_DEPTH: &str = "dynamics.com_depth";

/// The name of the sphere's rolling resistance among [`Identified::dynamics`].
pub const ROLLING_RESISTANCE: &str = "dynamics.rolling_resistance";

/// The name of the sphere's floor pivot friction (N·m) among [`Identified::dynamics`].
pub const PIVOT_FRICTION: &str = "dynamics.pivot_friction";

/// What [`sphere_dynamics`] finds: the estimates, each stop's rocking and each spin's decay.
type SphereFound = (
    Vec<ParameterEstimate>,
    Vec<rocking::Rocking>,
    Vec<spin_decay::SpinDecay>,
);

/// `priors` held at their values with the reason `why`.
fn held(priors: &[(&str, &'static str, f64)], why: &str) -> Vec<ParameterEstimate> {
    priors
        .iter()
        .map(|&(name, unit, prior)| ParameterEstimate {
            name: name.into(),
            unit,
            prior,
            value: prior,
            sigma: 0.0,
            status: FitStatus::Fixed(why.into()),
        })
        .collect()
}

/// Sphere-omni's `com_depth` and `rolling_resistance` from the rocking after the runs' stops
/// (see [`rocking`]), when a run has an IMU log, and its `pivot_friction` from the decay of the
/// spin after each stop of a spin in place (see [`spin_decay`]), when a run has a gyro: the
/// estimates (held at the prior, with the reason, when no run has such a stop), each stop's
/// rocking and each spin's decay. Nothing for another kind, or when no run has a gyro or an
/// IMU log.
fn sphere_dynamics(
    prior: &RobotDescription,
    runs: &[LoggedRun],
) -> Result<SphereFound, IdentifyError> {
    use crate::dynamics::sphere::SphereDynamics;
    let with_imu = runs.iter().any(|r| r.imu_rates.is_some());
    let with_gyro = runs.iter().any(|r| r.gyro.is_some());
    if prior.kind() != "sphere-omni" || !(with_imu || with_gyro) {
        return Ok((Vec::new(), Vec::new(), Vec::new()));
    }
    let p = SphereDynamics::from_description(prior)
        .map_err(|e| IdentifyError::Fit(format!("the robot file's [dynamics]: {e}")))?;
    let robot = prior
        .build::<f64>()
        .map_err(|e| IdentifyError::Fit(e.to_string()))?;
    let mut found = Vec::new();
    let mut spins = Vec::new();
    let mut spin_stops = 0;
    for r in runs {
        let stops = spin_decay::spin_decays(
            &robot,
            p.geometry.shell_radius,
            &r.encoders,
            r.gyro.as_ref(),
        );
        spins.extend(stops.spins);
        spin_stops += stops.spin_stops;
        if let Some(imu) = &r.imu_rates {
            found.extend(
                stops
                    .others
                    .into_iter()
                    .filter_map(|stop| rocking::rocking_after(&r.encoders, imu, stop)),
            );
        }
    }
    let mut estimates = Vec::new();
    if with_imu {
        estimates.extend(rocking_estimates(&p, &found)?);
    }
    if with_gyro {
        let prior_value = [(PIVOT_FRICTION, "N m", p.pivot_friction)];
        if spins.is_empty() {
            let why = if spin_stops == 0 {
                "no stop of a spin in place followed by 1.5 s at rest with a gyro (the `spin-stop` plan of plan sysid)"
            } else {
                "the spin after the stop does not decay towards rest over 10 gyro samples in its gyro log (a spin at speed, stopped as shortly as the `spin-stop` plan's, is needed)"
            };
            estimates.extend(held(&prior_value, why));
        } else {
            let (mut sw, mut sv) = (0.0, 0.0);
            for d in &spins {
                let (v, sd) = spin_decay::pivot_friction(&p, d).ok_or_else(|| {
                    IdentifyError::Fit(format!(
                        "{PIVOT_FRICTION}: the spin's decay at {:.4} rad/s² after the stop at {} s \
                         of {} is not reached by the dynamic model with the file's shell_inertia \
                         and platform_inertia",
                        d.deceleration.0, d.stop, d.file
                    ))
                })?;
                let w = 1.0 / (sd * sd).max(1e-300);
                sw += w;
                sv += w * v;
            }
            estimates.push(ParameterEstimate {
                name: PIVOT_FRICTION.into(),
                unit: "N m",
                prior: p.pivot_friction,
                value: sv / sw,
                sigma: 1.0 / sw.sqrt(),
                status: FitStatus::Fitted,
            });
        }
    }
    Ok((estimates, found, spins))
}

/// `com_depth` and `rolling_resistance` from the rockings `found` (see [`sphere_dynamics`]).
fn rocking_estimates(
    p: &crate::dynamics::sphere::SphereDynamics,
    found: &[rocking::Rocking],
) -> Result<Vec<ParameterEstimate>, IdentifyError> {
    let priors = [
        (COM_DEPTH, "m", p.com_depth),
        (ROLLING_RESISTANCE, "", p.rolling_resistance),
    ];
    // Only stops whose rocking the fit resolves: natural frequency within 20 % (1σ).
    let usable: Vec<&rocking::Rocking> = found
        .iter()
        .filter(|r| r.natural.1 > 0.0 && r.natural.1 < 0.2 * r.natural.0)
        .collect();
    if usable.is_empty() {
        let why = if found.is_empty() {
            "no stop from speed followed by 1.5 s at rest with an IMU log (the `stop` plan of plan sysid)"
        } else {
            "the rocking after the stops is too weak to fit (a stop as short as the `stop` plan's is needed)"
        };
        return Ok(held(&priors, why));
    }
    // Each stop's values through the model; the inverse-variance means.
    let mut sums = [(0.0, 0.0); 2];
    for r in &usable {
        let fit = rocking::depth_and_resistance(p, r).ok_or_else(|| {
            IdentifyError::Fit(format!(
                "{COM_DEPTH}, {ROLLING_RESISTANCE}: the rocking at {:.4} rad/s, decaying at \
                 {:.4} /s, after the stop at {} s of {} is not reached by the dynamic model with \
                 a depth inside the shell and the file's other [dynamics] values (shell_mass, \
                 shell_inertia, platform_mass, platform_inertia)",
                r.natural.0, r.decay.0, r.t0, r.file
            ))
        })?;
        for (k, (v, sd)) in [fit.com_depth, fit.rolling_resistance]
            .into_iter()
            .enumerate()
        {
            let w = 1.0 / (sd * sd);
            sums[k].0 += w;
            sums[k].1 += w * v;
        }
    }
    Ok(priors
        .iter()
        .zip(sums)
        .map(|(&(name, unit, prior), (sw, sv))| ParameterEstimate {
            name: name.into(),
            unit,
            prior,
            value: sv / sw,
            sigma: 1.0 / sw.sqrt(),
            status: FitStatus::Fitted,
        })
        .collect())
}

/// Initial start pose of a run: the reference at the log's first time (or its first sample);
/// the heading from the reference, else the angle between the reference's and the prior
/// odometry's displacement to the reference point farthest from the start.
fn start_guess(robot: &omnikin::Robot<f64>, run: &LoggedRun) -> Option<Pose2<f64>> {
    let r = &run.reference;
    let t0 = run.encoders.t[0];
    let k0 = r.t.partition_point(|t| *t < t0).min(r.t.len() - 1);
    let origin = r.xy[k0];
    if let Some(h) = &r.heading {
        return Some(Pose2::new(origin[0], origin[1], h[k0]));
    }
    let poses = model::dead_reckon(robot, &run.encoders, Pose2::new(0.0, 0.0, 0.0))?;
    let end = *run.encoders.t.last()?;
    let far = (k0..r.t.len())
        .filter(|&k| r.t[k] <= end)
        .max_by(|&a, &b| {
            let d = |k: usize| (r.xy[k][0] - origin[0]).hypot(r.xy[k][1] - origin[1]);
            d(a).total_cmp(&d(b))
        })?;
    let p = model::pose_at(&run.encoders.t, &poses, r.t[far])?;
    let q = model::pose_at(&run.encoders.t, &poses, r.t[k0].max(t0))?;
    let want = (r.xy[far][1] - origin[1]).atan2(r.xy[far][0] - origin[0]);
    let got = (p.y - q.y).atan2(p.x - q.x);
    Some(Pose2::new(origin[0], origin[1], want - got))
}

/// Residual groups: each is divided by its own standard deviation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Group {
    Position,
    Heading,
    Gyro,
}

/// Layout of the value vector: geometry, then `(x₀, y₀, ψ₀)` per run, then the gyro's
/// `(bias, scale)` when a run has a gyro.
#[derive(Clone, Copy)]
struct Layout {
    geometry: usize,
    runs: usize,
    gyro: bool,
}

impl Layout {
    fn start(&self, x: &[f64], i: usize) -> Pose2<f64> {
        let k = self.geometry + 3 * i;
        Pose2::new(x[k], x[k + 1], x[k + 2])
    }
    fn gyro_at(&self) -> usize {
        self.geometry + 3 * self.runs
    }
    fn len(&self) -> usize {
        self.gyro_at() + if self.gyro { 2 } else { 0 }
    }
}

/// All residuals for the value vector `x`, with the group of each.
fn residuals(
    prior: &RobotDescription,
    runs: &[LoggedRun],
    l: Layout,
    x: &[f64],
    w: &ResidualWeights,
    gyro_sigma: f64,
    window: f64,
) -> Option<(Vec<f64>, Vec<Group>)> {
    let robot = params::apply(prior, &x[..l.geometry]).build::<f64>().ok()?;
    let mut out = Vec::new();
    let mut group = Vec::new();
    for (i, run) in runs.iter().enumerate() {
        let before = out.len();
        model::pose_residuals(&robot, run, l.start(x, i), *w, &mut out)?;
        // Heading residuals follow each (x, y) pair when the reference has headings.
        let per = if run.reference.heading.is_some() {
            3
        } else {
            2
        };
        group.extend((before..out.len()).map(|k| {
            if (k - before) % per == 2 {
                Group::Heading
            } else {
                Group::Position
            }
        }));
        if let (true, Some(g)) = (l.gyro, &run.gyro) {
            let (bias, scale) = (x[l.gyro_at()], x[l.gyro_at() + 1]);
            let poses = model::dead_reckon(&robot, &run.encoders, l.start(x, i))?;
            for win in model::gyro_windows(&run.encoders.t, &poses, g, window) {
                out.push(
                    (win.integral - scale * win.heading_change - bias * win.duration) / gyro_sigma,
                );
                group.push(Group::Gyro);
            }
        }
    }
    Some((out, group))
}

/// RMS of the residuals of group `g`, in their units (`scale` undoes the weighting).
fn group_rms(r: &[f64], groups: &[Group], g: Group, scale: f64) -> Option<f64> {
    let (mut s, mut n) = (0.0, 0usize);
    for (v, _) in r.iter().zip(groups).filter(|(_, k)| **k == g) {
        s += (v * scale) * (v * scale);
        n += 1;
    }
    (n > 0).then(|| (s / n as f64).sqrt())
}

/// Fits the kinematic parameters of `prior` and the gyro to `runs` (see the module docs).
///
/// # Errors
/// [`IdentifyError::Input`] when there are no runs or a run's reference does not overlap its
/// encoder log; [`IdentifyError::Fit`] when the prior does not build or the fit cannot start.
pub fn identify(
    prior: &RobotDescription,
    runs: &[LoggedRun],
    options: &Options,
) -> Result<Identified, IdentifyError> {
    if runs.is_empty() {
        return Err(IdentifyError::Input("no runs to identify from".into()));
    }
    let robot = prior
        .build::<f64>()
        .map_err(|e| IdentifyError::Fit(e.to_string()))?;
    let geometry: Vec<Parameter> = params::parameters(prior);
    let l = Layout {
        geometry: geometry.len(),
        runs: runs.len(),
        gyro: runs.iter().any(|r| r.gyro.is_some()),
    };
    let mut x0: Vec<f64> = geometry.iter().map(|p| p.prior).collect();
    let mut h: Vec<f64> = geometry.iter().map(|p| p.quantity.step()).collect();
    for run in runs {
        let Some(s) = start_guess(&robot, run) else {
            return Err(IdentifyError::Input(format!(
                "{}: the reference trajectory does not overlap the encoder log {} in time",
                run.reference.file, run.encoders.file
            )));
        };
        x0.extend([s.x, s.y, s.heading]);
        h.extend([1e-6; 3]);
    }
    if l.gyro {
        x0.extend([0.0, 1.0]);
        h.extend([1e-6, 1e-6]);
    }
    let n = l.len();
    // Only geometry and the gyro are held; a start pose the prior leaves unobserved (a spin in
    // place seen by position-only fixes) is left to the damped solver: the real robot drifts a
    // little while it spins, which is what fixes its start heading.
    let fixable: Vec<bool> = (0..n).map(|k| k < l.geometry || k >= l.gyro_at()).collect();
    let mut free = vec![true; n];
    let mut w = ResidualWeights {
        position: options.position_sigma,
        heading: options.heading_sigma,
    };
    // Gyro windows: white noise integrated over a window is small; start at 1 mrad.
    let mut gyro_sigma = 1e-3;
    let window = options.gyro_window;
    let f = |x: &[f64], w: &ResidualWeights, gs: f64| residuals(prior, runs, l, x, w, gs, window);
    // Observability is a property of the model, not of the prior's error: it is tested on the
    // logs the prior robot would have recorded for the same motion (see
    // `model::consistent_log`), where a gauge direction is exactly blind.
    let consistent: Vec<LoggedRun> = runs
        .iter()
        .map(|r| {
            Some(LoggedRun {
                encoders: model::consistent_log(&robot, &r.encoders)?,
                reference: r.reference.clone(),
                gyro: r.gyro.clone(),
                imu_rates: None,
            })
        })
        .collect::<Option<_>>()
        .ok_or_else(|| {
            IdentifyError::Fit("the prior robot cannot dead-reckon these encoder logs".into())
        })?;
    let j = lsq::jacobian(
        &|x: &[f64]| residuals(prior, &consistent, l, x, &w, gyro_sigma, window).map(|r| r.0),
        &x0,
        &h,
        &free,
    )
    .ok_or_else(|| {
        IdentifyError::Fit("the prior robot cannot dead-reckon these encoder logs".into())
    })?;
    let mut reasons = vec![None; n];
    for k in lsq::unobservable(&j, &free, &fixable) {
        free[k] = false;
        reasons[k] = Some(if j.column(k).norm() == 0.0 {
            "the runs do not depend on it".to_string()
        } else {
            "not identifiable from these runs (a direction the Jacobian does not see; held at the prior)"
                .to_string()
        });
    }
    // "Before": the prior geometry from the start poses that fit it best (starts alone free).
    let starts_only: Vec<bool> = (0..n).map(|k| !fixable[k]).collect();
    let prior_starts = lsq::solve(
        &|x: &[f64]| f(x, &w, gyro_sigma).map(|r| r.0),
        &x0,
        &h,
        &starts_only,
    )
    .map_or_else(|_| x0.clone(), |s| s.x);
    let mut x = x0.clone();
    let mut sol = None;
    // A first fit with the assumed noise, then one with each group's residual RMS.
    for _ in 0..2 {
        let fw = |x: &[f64]| f(x, &w, gyro_sigma).map(|r| r.0);
        let s = lsq::solve(&fw, &x, &h, &free).map_err(|e| IdentifyError::Fit(e.to_string()))?;
        let (r, groups) = f(&s.x, &w, gyro_sigma)
            .ok_or_else(|| IdentifyError::Fit("the fitted robot does not build".into()))?;
        let floor = |v: Option<f64>, d: f64| v.unwrap_or(d).max(1e-9);
        let next = ResidualWeights {
            position: floor(
                group_rms(&r, &groups, Group::Position, w.position),
                w.position,
            ),
            heading: floor(group_rms(&r, &groups, Group::Heading, w.heading), w.heading),
        };
        gyro_sigma = floor(group_rms(&r, &groups, Group::Gyro, gyro_sigma), gyro_sigma);
        w = next;
        x = s.x.clone();
        sol = Some(s);
    }
    let sol = sol.ok_or_else(|| IdentifyError::Fit("no fit".into()))?;
    let (r, groups) = f(&sol.x, &w, gyro_sigma)
        .ok_or_else(|| IdentifyError::Fit("the fitted robot does not build".into()))?;
    let inflation = correlation_inflation(prior, runs, l, &sol.x).unwrap_or(1.0);
    // The condition of the robot's and the gyro's parameters (the start poses aside: a spin's
    // start heading, seen only through the robot's drift, would dominate it).
    let own: Vec<bool> = (0..n).map(|k| free[k] && fixable[k]).collect();
    let condition = lsq::jacobian(
        &|x: &[f64]| f(x, &w, gyro_sigma).map(|r| r.0),
        &sol.x,
        &h,
        &own,
    )
    .map_or(sol.condition, |j| lsq::condition(&j, &own));
    let estimate = |k: usize, name: String, unit: &'static str, prior: f64| ParameterEstimate {
        name,
        unit,
        prior,
        value: sol.x[k],
        sigma: sol.sigma[k] * inflation,
        status: reasons[k]
            .clone()
            .map_or(FitStatus::Fitted, FitStatus::Fixed),
    };
    let estimates: Vec<ParameterEstimate> = geometry
        .iter()
        .enumerate()
        .map(|(k, p)| estimate(k, p.name.clone(), p.quantity.unit(), p.prior))
        .collect();
    let gyro = if l.gyro {
        vec![
            estimate(l.gyro_at(), "gyro.bias".into(), "rad/s", 0.0),
            estimate(l.gyro_at() + 1, "gyro.scale".into(), "", 1.0),
        ]
    } else {
        Vec::new()
    };
    check_excitation(prior, estimates.iter().chain(&gyro), condition)?;
    let mut fitted = params::apply(prior, &x[..l.geometry]);
    let (dynamics, rocking, spin_decay) = sphere_dynamics(prior, runs)?;
    for e in dynamics.iter().filter(|e| e.status == FitStatus::Fitted) {
        let spec = fitted.sphere_dynamics.get_or_insert_with(Default::default);
        match e.name.as_str() {
            COM_DEPTH => spec.com_depth = Some(e.value),
            ROLLING_RESISTANCE => spec.rolling_resistance = Some(e.value),
            PIVOT_FRICTION => spec.pivot_friction = Some(e.value),
            _ => {}
        }
    }
    let series = fitted
        .build::<f64>()
        .ok()
        .and_then(|after| {
            runs.iter()
                .enumerate()
                .map(|(i, run)| {
                    Some(RunResiduals {
                        encoders: run.encoders.file.clone(),
                        reference: run.reference.file.clone(),
                        before: PoseResiduals::of(&robot, run, l.start(&prior_starts, i))?,
                        after: PoseResiduals::of(&after, run, l.start(&sol.x, i))?,
                    })
                })
                .collect::<Option<Vec<_>>>()
        })
        .ok_or_else(|| IdentifyError::Fit("the fitted robot cannot dead-reckon the logs".into()))?;
    Ok(Identified {
        description: fitted,
        series,
        geometry: estimates,
        gyro,
        position_rms: group_rms(&r, &groups, Group::Position, w.position).unwrap_or(0.0),
        heading_rms: group_rms(&r, &groups, Group::Heading, w.heading),
        gyro_rms: group_rms(&r, &groups, Group::Gyro, gyro_sigma),
        condition,
        residuals: sol.residuals,
        dynamics,
        rocking,
        spin_decay,
    })
}

/// The size against which a fitted value's 1σ is judged, and the largest change from the prior
/// that is still a calibration ([`check_excitation`]): a scale's own size 1, changed by at
/// most 0.5 (a wheel half or one and a half times the file's is another wheel); a length's
/// prior magnitude, at least the robot's size (`footprint_radius`, else 0.1 m), changed by at
/// most ten times that; an angle 1 rad either; a gyro bias 0.1 and 1 rad/s.
fn excitation_scale(e: &ParameterEstimate, size: f64) -> (f64, f64) {
    match e.unit {
        "m" => {
            let s = e.prior.abs().max(size);
            (s, 10.0 * s)
        }
        "rad" => (1.0, 1.0),
        "rad/s" => (0.1, 1.0),
        _ => (1.0, 0.5),
    }
}

/// Refuses a fit whose runs do not excite a parameter the rank test let through (a nearly
/// blind direction: the damped solver then runs along it, to wheel radii of nanometres or
/// positions of kilometres): a fitted value whose 1σ exceeds its [`excitation_scale`] or is
/// zero (a singular covariance), or that moved from the prior by more than the largest
/// calibration change, or is not finite. The error names each such parameter with its value,
/// 1σ and prior, and the condition number.
fn check_excitation<'a>(
    prior: &RobotDescription,
    estimates: impl Iterator<Item = &'a ParameterEstimate>,
    condition: f64,
) -> Result<(), IdentifyError> {
    let size = prior.footprint_radius.unwrap_or(0.1);
    let mut singular = false;
    let bad: Vec<String> = estimates
        .filter(|e| e.status == FitStatus::Fitted)
        .inspect(|e| singular |= e.sigma == 0.0)
        .filter(|e| {
            let (s, change) = excitation_scale(e, size);
            !(e.value.is_finite()
                && e.sigma > 0.0
                && e.sigma <= s
                && (e.value - e.prior).abs() <= change)
        })
        .map(|e| {
            let u = if e.unit.is_empty() { "" } else { " " };
            format!(
                "{} ({:.4e}{u}{} ± {:.2e}, prior {}{u}{})",
                e.name, e.value, e.unit, e.sigma, e.prior, e.unit
            )
        })
        .collect();
    if bad.is_empty() {
        return Ok(());
    }
    let how = if singular {
        "the covariance is singular".to_string()
    } else {
        format!("condition {condition:.3e}")
    };
    Err(IdentifyError::Fit(format!(
        "not enough excitation: these runs do not determine {} ({how}); \
         add runs that move them (omnikin plan sysid: spin for the wheel positions, along-across \
         for the drive angles and radii, figure-eight for all and the gyro); nothing was written",
        bad.join(", ")
    )))
}

/// `sqrt((1 + ρ) / (1 − ρ))`, ρ the lag-1 autocorrelation of the residual series (x, y and
/// heading of each run separately, pooled): the factor by which the 1σ of
/// white residuals understates that of AR(1)-correlated ones (clamped to [0, 0.99]; the variance of a mean of n
/// AR(1) samples is `(1 + ρ)/(1 − ρ)` times the white one's). Dead reckoning makes its errors
/// correlated (encoder quantisation, the rate of the logs), camera noise does not: the factor is
/// near 1 against camera fixes and larger against an exact tracked truth.
fn correlation_inflation(
    prior: &RobotDescription,
    runs: &[LoggedRun],
    l: Layout,
    x: &[f64],
) -> Option<f64> {
    let robot = params::apply(prior, &x[..l.geometry]).build::<f64>().ok()?;
    let unit = ResidualWeights {
        position: 1.0,
        heading: 1.0,
    };
    let (mut lag, mut zero) = (0.0, 0.0);
    for (i, run) in runs.iter().enumerate() {
        let mut r = Vec::new();
        model::pose_residuals(&robot, run, l.start(x, i), unit, &mut r)?;
        let per = if run.reference.heading.is_some() {
            3
        } else {
            2
        };
        for c in 0..per {
            let series: Vec<f64> = r.iter().skip(c).step_by(per).copied().collect();
            let norm: f64 = series.iter().map(|v| v * v).sum();
            if norm > 0.0 {
                zero += 1.0;
                lag += series.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / norm;
            }
        }
    }
    if zero == 0.0 {
        return None;
    }
    let rho = (lag / zero).clamp(0.0, 0.99);
    Some(((1.0 + rho) / (1.0 - rho)).sqrt())
}
