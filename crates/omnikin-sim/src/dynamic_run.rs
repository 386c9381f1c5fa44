//! One plan through a robot's dynamic plant, as `omnikin simulate --plant dynamic` and the
//! Python package's `omnikin.simulate(..., plant="dynamic")` run it: the sphere's shell +
//! platform ([`crate::dynamics::sphere::simulate_plan`], deterministic) or the balancing
//! ballbot ([`crate::dynamics::ballbot::plan_run::run_plan`], sensor noise seeded, with an
//! initial lean and pushes), evaluated against the plan with the kinematic simulator's
//! metrics, and `metrics.json` with the dynamics' own figures.
//!
//! Two steps, so a caller can check its output before the run: [`DynamicPlant::new`] checks
//! the robot, its parameters and the options; [`DynamicPlant::run`] simulates and evaluates.
//! The error texts are the CLI's (they name its flags, `--plant dynamic`, `--push`).
//!
//! **A ballbot fall** is a result, not an error: the run completes (the robot lies where it
//! fell) and `metrics.json` says `"fallen": true` with `"fall_time_s"`.

use omnikin::control::BalanceConfig;
use omnikin::description::RobotDescription;
use omnikin_plan::Plan;
use serde_json::{Value, json};

use crate::Trial;
use crate::dynamics::ballbot::BallbotDynamics;
use crate::dynamics::ballbot::closed_loop::Push;
use crate::dynamics::ballbot::plan_run::{PlanRun, PlanRunError, PlanRunOptions, run_plan};
use crate::dynamics::sphere::{
    ContactEventKind, DynamicTrial, DynamicsError, SphereDynamics, simulate_plan,
};
use crate::metrics::{Evaluation, MetricsError, Run, evaluate};

/// Largest push magnitude, N·s.
pub const MAX_PUSH: f64 = 1000.0;

/// Latest push time, s of closed-loop time.
pub const MAX_PUSH_TIME: f64 = 3600.0;

/// Largest initial lean magnitude (exclusive), degrees.
pub const MAX_INITIAL_TILT_DEG: f64 = 60.0;

/// A number as the CLI quotes it in a message (`1e300`, not a 301-digit number).
fn num(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && a.is_finite() && !(1e-4..1e9).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A horizontal impulse on the ballbot body's centre of mass (the CLI's `--push J@T[@DEG]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PushSpec {
    /// Impulse magnitude, N·s, in (0, [`MAX_PUSH`]].
    pub impulse: f64,
    /// Closed-loop time, s from the start of the lead-in, in [0, [`MAX_PUSH_TIME`]].
    pub time: f64,
    /// Direction, degrees counter-clockwise from world +x.
    pub direction_deg: f64,
}

impl PushSpec {
    /// A checked push; the error says which value breaks which rule.
    pub fn new(impulse: f64, time: f64, direction_deg: f64) -> Result<Self, String> {
        if !(impulse > 0.0 && impulse <= MAX_PUSH) {
            return Err(format!(
                "impulse {} N·s must be in (0, {MAX_PUSH}] (the direction gives its sign)",
                num(impulse)
            ));
        }
        if !(0.0..=MAX_PUSH_TIME).contains(&time) {
            return Err(format!(
                "time {} s must be in [0, {MAX_PUSH_TIME}]",
                num(time)
            ));
        }
        if !direction_deg.is_finite() {
            return Err(format!(
                "direction: must be a finite number, got {direction_deg}"
            ));
        }
        Ok(Self {
            impulse,
            time,
            direction_deg,
        })
    }

    /// The push as the closed loop applies it (world-frame impulse).
    fn push(&self) -> Push {
        let (s, c) = self.direction_deg.to_radians().sin_cos();
        Push {
            time: self.time,
            impulse: [self.impulse * c, self.impulse * s],
        }
    }
}

/// Checks an initial lean, degrees toward +x: finite, within ±[`MAX_INITIAL_TILT_DEG`].
pub fn check_initial_tilt_deg(v: f64) -> Result<f64, String> {
    if !v.is_finite() {
        return Err(format!("must be a finite number, got {v}"));
    }
    if v.abs() >= MAX_INITIAL_TILT_DEG {
        return Err(format!(
            "{}° must be within ±{MAX_INITIAL_TILT_DEG}°",
            num(v)
        ));
    }
    Ok(v)
}

/// The options of a dynamic run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DynamicOptions {
    /// The plan's name in messages and `metrics.json` (its path).
    pub plan_name: String,
    /// Ballbot: the seed of the sensor noise.
    pub seed: u64,
    /// Ballbot: initial lean toward +x, degrees ([`check_initial_tilt_deg`]); `None`: upright.
    pub initial_tilt_deg: Option<f64>,
    /// Ballbot: pushes.
    pub pushes: Vec<PushSpec>,
}

/// Why a dynamic run cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum DynamicError {
    /// The robot's kind has no dynamic model.
    #[error(
        "--plant dynamic: only kinds sphere-omni and ballbot have a dynamic model so far (robot {robot} is {kind})"
    )]
    NoModel {
        /// The robot's name.
        robot: String,
        /// Its kind.
        kind: &'static str,
    },
    /// An initial lean or pushes for a robot that is not a ballbot.
    #[error("--initial-tilt-deg and --push need --robot ballbot (kind ballbot) --plant dynamic")]
    NotBallbot,
    /// The sphere's parameters, or its run, were rejected.
    #[error(transparent)]
    Sphere(#[from] DynamicsError),
    /// The ballbot file has no balance controller.
    #[error("the balance controller needs a ballbot")]
    NoController,
    /// A push after the end of the run.
    #[error(
        "--push at {time} s: the run ends at {end:.2} s (lead-in {lead_in} s, plan {plan:.2} s, tail {tail} s)"
    )]
    PushAfterEnd {
        /// The push's time, s.
        time: f64,
        /// The end of the run, s.
        end: f64,
        /// Lead-in, s.
        lead_in: f64,
        /// The plan's duration, s.
        plan: f64,
        /// Tail, s.
        tail: f64,
    },
    /// The balancing run failed.
    #[error("{plan}: balancing {robot}: {err}")]
    Balancing {
        /// The plan's name.
        plan: String,
        /// The robot's name.
        robot: String,
        /// Why.
        err: PlanRunError,
    },
    /// The run could not be evaluated against the plan.
    #[error(transparent)]
    Metrics(#[from] MetricsError),
    /// A metric is not a finite number.
    #[error("the metrics cannot be computed for these inputs: {err}")]
    NotFinite {
        /// Which metric.
        err: MetricsError,
    },
    /// `metrics.json` could not be built.
    #[error("metrics.json: {0}")]
    Json(String),
}

/// `Ok` when robot `d`'s kind has a dynamic model (sphere-omni, ballbot).
pub fn check_kind(d: &RobotDescription) -> Result<(), DynamicError> {
    if d.robot_kind().has_dynamics() {
        Ok(())
    } else {
        Err(DynamicError::NoModel {
            robot: d.name.clone(),
            kind: d.kind(),
        })
    }
}

/// Why a dynamic run of robot `d` makes one trial only (the CLI's note for `--trials` > 1).
pub fn one_trial_note(d: &RobotDescription) -> &'static str {
    if d.robot_kind().balances() {
        "--plant dynamic runs one trial (its sensor noise is seeded by --seed)"
    } else {
        "--plant dynamic is deterministic without disturbances: one trial"
    }
}

/// A checked dynamic plant, ready to run a plan.
#[derive(Clone, Debug)]
pub enum DynamicPlant {
    /// The sphere's shell + platform.
    Sphere(SphereDynamics),
    /// The balancing ballbot.
    Ballbot {
        /// The 3D model.
        dynamics: BallbotDynamics,
        /// The controller's configuration.
        config: Box<BalanceConfig<f64>>,
        /// Lead-in, tail, lean, pushes, noise.
        opts: PlanRunOptions,
    },
}

/// What a run through the dynamics gives beside the trial.
#[derive(Clone, Debug)]
pub enum DynamicOutcome {
    /// The sphere's run (tilt, shell spin, pull-outs).
    Sphere(Box<DynamicTrial>),
    /// The ballbot's run (per control cycle: tilt, position; fall).
    Ballbot(Box<PlanRun>),
}

/// A dynamic run and its evaluation.
#[derive(Clone, Debug)]
pub struct DynamicSimulation {
    /// The run.
    pub outcome: DynamicOutcome,
    /// The run as the metrics see it (tracked point and heading at the plan's samples).
    pub runs: Vec<Run>,
    /// Metrics and mean trajectory (of one run: the run itself).
    pub evaluation: Evaluation,
    /// `metrics.json`: the metrics, the ballbot's tilt and fall figures, and `simulation`.
    pub metrics_json: Value,
}

impl DynamicPlant {
    /// The plant of robot `d` for `plan` with `opts`: kind sphere-omni or ballbot, parameters
    /// valid, lean and pushes only for a ballbot, every push within the run.
    pub fn new(
        d: &RobotDescription,
        plan: &Plan,
        opts: &DynamicOptions,
    ) -> Result<Self, DynamicError> {
        check_kind(d)?;
        let ballbot = d.robot_kind().balances();
        if !ballbot && (opts.initial_tilt_deg.is_some() || !opts.pushes.is_empty()) {
            return Err(DynamicError::NotBallbot);
        }
        if ballbot {
            let config = d
                .balance_config::<f64>()
                .ok_or(DynamicError::NoController)?;
            let dynamics = BallbotDynamics::from_config(&config);
            let run = PlanRunOptions {
                initial_tilt: opts.initial_tilt_deg.unwrap_or(0.0).to_radians(),
                pushes: opts.pushes.iter().map(PushSpec::push).collect(),
                seed: opts.seed,
                ..PlanRunOptions::default()
            };
            let end = run.lead_in + plan.duration() + run.tail;
            if let Some(p) = opts.pushes.iter().find(|p| p.time > end) {
                return Err(DynamicError::PushAfterEnd {
                    time: p.time,
                    end,
                    lead_in: run.lead_in,
                    plan: plan.duration(),
                    tail: run.tail,
                });
            }
            return Ok(DynamicPlant::Ballbot {
                dynamics,
                config: Box::new(config),
                opts: run,
            });
        }
        Ok(DynamicPlant::Sphere(SphereDynamics::from_description(d)?))
    }

    /// Runs `plan` through the plant and evaluates it; `d` and `opts` as given to
    /// [`DynamicPlant::new`].
    pub fn run(
        &self,
        d: &RobotDescription,
        plan: &Plan,
        opts: &DynamicOptions,
    ) -> Result<DynamicSimulation, DynamicError> {
        let (outcome, trial) = match self {
            DynamicPlant::Sphere(p) => {
                let mut run = simulate_plan(*p, plan)?;
                // The IMU at the platform's centre of mass (as the closed loop's board has
                // it, `SilImu::at_centre_of_mass`): its accelerometer feels the rocking.
                for a in &mut run.attitude {
                    a.imu_offset = [0.0, 0.0, -p.com_depth];
                }
                let trial = run.trial.clone();
                (DynamicOutcome::Sphere(Box::new(run)), trial)
            }
            DynamicPlant::Ballbot {
                dynamics,
                config,
                opts: run_opts,
            } => {
                let run = run_plan(*dynamics, **config, plan, run_opts).map_err(|err| {
                    DynamicError::Balancing {
                        plan: opts.plan_name.clone(),
                        robot: d.name.clone(),
                        err,
                    }
                })?;
                let trial = run.trial.clone();
                (DynamicOutcome::Ballbot(Box::new(run)), trial)
            }
        };
        let runs = vec![run_of(&trial)];
        let evaluation = evaluate(plan, &runs)?;
        evaluation
            .metrics
            .check_finite()
            .map_err(|err| DynamicError::NotFinite { err })?;
        let mut j = serde_json::to_value(&evaluation.metrics)
            .map_err(|e| DynamicError::Json(e.to_string()))?;
        match (self, &outcome) {
            (DynamicPlant::Sphere(p), DynamicOutcome::Sphere(run)) => {
                j["simulation"] = json!({
                    "robot": d.name, "kind": d.kind(), "plan": opts.plan_name,
                    "plant": "dynamic", "trials": 1, "max_substep_s": p.max_substep,
                    "max_tilt_rad": run.max_tilt, "pull_outs": run.pull_outs,
                    "peak_motor_torque_nm": run.peak_torque,
                    "roller_slips": run.contact_events.roller_slips,
                    "lift_offs": run.contact_events.lift_offs,
                    "floor_slips": run.contact_events.floor_slips,
                    "lost_steps": run.contact_events.lost_steps,
                    "min_roller_normal_n": run.min_normal,
                    "min_shell_spin_rad_s": run.shell_spin.iter().cloned().fold(0.0, f64::min),
                    "contact_events": contact_log_json(run),
                });
            }
            (
                DynamicPlant::Ballbot {
                    config,
                    opts: run_opts,
                    ..
                },
                DynamicOutcome::Ballbot(run),
            ) => {
                let deg = f64::to_degrees;
                j["max_tilt_deg"] = json!(deg(run.max_tilt));
                j["final_tilt_deg"] = json!(deg(run.final_tilt));
                j["fallen"] = json!(run.fallen_at.is_some());
                j["fall_time_s"] = json!(run.fallen_at);
                j["simulation"] = json!({
                    "robot": d.name, "kind": d.kind(), "plan": opts.plan_name,
                    "plant": "dynamic", "trials": 1, "seed": opts.seed,
                    "control_rate_hz": config.rate_hz,
                    "plant_rate_hz": config.rate_hz * run_opts.substeps as f64,
                    "lead_in_s": run_opts.lead_in, "tail_s": run_opts.tail,
                    "initial_tilt_deg": deg(run_opts.initial_tilt),
                    "pushes": opts.pushes.iter().map(|p| json!({
                        "impulse_ns": p.impulse, "time_s": p.time, "direction_deg": p.direction_deg,
                    })).collect::<Vec<_>>(),
                    "fall_tilt_deg": deg(config.fall_tilt),
                    "torque_limit_nm": config.torque_limit,
                    "saturated_cycles": run.saturated_cycles,
                    "peak_wheel_torque_nm": run.peak_torque,
                    "sensor_noise": {
                        "tilt_deg": deg(run_opts.noise.tilt), "rate_rad_s": run_opts.noise.rate,
                        "position_m": run_opts.noise.position,
                        "velocity_m_s": run_opts.noise.velocity,
                    },
                });
            }
            _ => unreachable!("the outcome is of the plant's kind"),
        }
        Ok(DynamicSimulation {
            outcome,
            runs,
            evaluation,
            metrics_json: j,
        })
    }
}

/// The trial as the metrics see it.
fn run_of(trial: &Trial) -> Run {
    Run {
        xy: trial.tracked.clone(),
        heading: Some(trial.pose.iter().map(|q| q.heading).collect()),
    }
}

impl DynamicSimulation {
    /// The run at the plan's samples (the row of `trials.csv`).
    pub fn trial(&self) -> &Trial {
        match &self.outcome {
            DynamicOutcome::Sphere(r) => &r.trial,
            DynamicOutcome::Ballbot(r) => &r.trial,
        }
    }

    /// The platform's attitude per sample of [`DynamicSimulation::trial`] for the IMU of
    /// [`crate::sensors::emit_with_attitude`]: the sphere's; `None` for the ballbot (its logs
    /// are not emitted yet).
    pub fn attitude(&self) -> Option<&[crate::sensors::PlatformAttitude]> {
        match &self.outcome {
            DynamicOutcome::Sphere(r) => Some(&r.attitude),
            DynamicOutcome::Ballbot(_) => None,
        }
    }

    /// The lines the CLI prints after the metrics' summary: the largest tilt and pull-outs of
    /// the sphere; the ballbot's tilt, saturation and torque, and its fall.
    pub fn summary_lines(&self, plant: &DynamicPlant) -> Vec<String> {
        match (&self.outcome, plant) {
            (DynamicOutcome::Sphere(run), _) => vec![format!(
                "dynamic plant: largest tilt {:.3} rad, pull-out events {:?}, roller slips {:?}, \
                 lift-offs {:?}, floor slides {}, lost steps {:?}",
                run.max_tilt,
                run.pull_outs,
                run.contact_events.roller_slips,
                run.contact_events.lift_offs,
                run.contact_events.floor_slips,
                run.contact_events.lost_steps
            )],
            (DynamicOutcome::Ballbot(run), DynamicPlant::Ballbot { config, .. }) => {
                let deg = f64::to_degrees;
                let mut v = vec![format!(
                    "balancing: max tilt {:.2}°, final tilt {:.3}°, {} saturated cycles, peak \
                     wheel torque {:.2} N·m (limit {:.2})",
                    deg(run.max_tilt),
                    deg(run.final_tilt),
                    run.saturated_cycles,
                    run.peak_torque.iter().cloned().fold(0.0, f64::max),
                    config.torque_limit
                )];
                if let Some(t) = run.fallen_at {
                    v.push(format!(
                        "FALLEN at t = {t:.3} s (closed-loop time; the plan starts at {:.1} s): \
                         the tilt passed {:.0}°, motors off; the robot lies where it fell",
                        run.plan_start,
                        deg(config.fall_tilt)
                    ));
                }
                v
            }
            _ => Vec::new(),
        }
    }
}

/// The sphere run's contact events in time order, for `metrics.json`'s `simulation`: each
/// `{"t": s, "kind": "roller_slip" | "lift_off" | "floor_slip" | "lost_steps", "wheel": i}`
/// (`t` the end of the plan step in which it began; no wheel for a floor slip; `steps` for
/// lost steps).
fn contact_log_json(run: &DynamicTrial) -> Value {
    run.contact_log
        .iter()
        .map(|e| match e.kind {
            ContactEventKind::RollerSlip => {
                json!({"t": e.t, "kind": "roller_slip", "wheel": e.wheel})
            }
            ContactEventKind::LiftOff => json!({"t": e.t, "kind": "lift_off", "wheel": e.wheel}),
            ContactEventKind::FloorSlip => json!({"t": e.t, "kind": "floor_slip"}),
            ContactEventKind::LostSteps(n) => {
                json!({"t": e.t, "kind": "lost_steps", "wheel": e.wheel, "steps": n})
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pushes_and_leans_are_checked() {
        assert!(PushSpec::new(5.0, 2.0, 45.0).is_ok());
        assert!(
            PushSpec::new(0.0, 2.0, 0.0)
                .unwrap_err()
                .contains("impulse 0 N·s")
        );
        assert!(
            PushSpec::new(1e300, 2.0, 0.0)
                .unwrap_err()
                .contains("1e300")
        );
        assert!(
            PushSpec::new(1.0, -1.0, 0.0)
                .unwrap_err()
                .contains("time -1 s")
        );
        assert!(PushSpec::new(1.0, 1.0, f64::NAN).is_err());
        assert_eq!(check_initial_tilt_deg(-3.0), Ok(-3.0));
        assert!(check_initial_tilt_deg(60.0).unwrap_err().contains("±60°"));
        assert!(check_initial_tilt_deg(f64::INFINITY).is_err());
    }

    #[test]
    fn kinds_without_dynamics_and_misplaced_ballbot_options_are_refused() {
        let plan = Plan {
            wheels: 3,
            samples: Vec::new(),
        };
        let d = RobotDescription::preset("kiwi").unwrap();
        let e = DynamicPlant::new(&d, &plan, &DynamicOptions::default()).unwrap_err();
        assert!(e.to_string().contains("only kinds sphere-omni and ballbot"));
        let d = RobotDescription::preset("sphere-omni").unwrap();
        let o = DynamicOptions {
            initial_tilt_deg: Some(1.0),
            ..DynamicOptions::default()
        };
        assert!(matches!(
            DynamicPlant::new(&d, &plan, &o),
            Err(DynamicError::NotBallbot)
        ));
    }
}
