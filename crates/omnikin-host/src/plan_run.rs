//! A plan driven by a robot over the link: the check of the robot's estimate against the
//! plan's start, the upload ([`crate::plan_upload`], blocking), following it with heartbeats
//! until the robot reports it done, and — for a robot that takes no plans (plan capacity 0:
//! a balancing ballbot follows velocity commands) — the plan streamed as world-frame velocity
//! commands. `omnikin drive plan` and Python's `omnikin.Link.run_plan` run these.

use std::time::Instant;

use anyhow::{Context, Result, bail};
use omnikin::link::{Message, WirePoint};
use omnikin::runtime::{Frame, Mode};
use omnikin_plan::Plan;

use crate::actions::RobotRefused;
use crate::operator::Session;
use crate::plan_upload::{PlanUpload, Progress};

/// A plan the robot took.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Uploaded {
    /// The plan's id on the wire.
    pub id: u16,
    /// Points sent.
    pub points: usize,
    /// Chunk messages confirmed.
    pub chunks: u32,
    /// From the first upload message to the robot starting the plan, s.
    pub secs: f64,
}

/// A plan the robot followed to its end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Followed {
    /// Largest distance between the robot's estimate and the plan's reference while it
    /// followed the plan, m.
    pub max_deviation: f32,
    /// The robot's estimate at the end `[x, y, heading]` (world; m, m, rad).
    pub end_pose: [f32; 3],
}

/// A plan streamed as velocity commands.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Streamed {
    /// With the pose set to the plan's start: the largest distance from the plan's pose at the
    /// same time (lag included) and the largest distance to the path, m.
    pub deviation: Option<(f64, f64)>,
    /// The robot's estimate at the end `[x, y, heading]` (world; m, m, rad).
    pub end_pose: [f32; 3],
}

impl Session {
    /// How far the robot's estimate is from `start` (world x, y; m), once its first
    /// telemetry frame is in (it also gives the robot's clock for the logs).
    pub fn distance_to(&mut self, start: [f64; 2]) -> Result<f64> {
        self.first_telemetry("telemetry (the robot's pose)")?;
        let t = self.latest.context("no telemetry")?;
        Ok((f64::from(t.pose[0]) - start[0]).hypot(f64::from(t.pose[1]) - start[1]))
    }

    /// Uploads `points` as plan `id` and starts it (set-pose first when asked), each step
    /// re-sent until the robot's telemetry confirms it; the session's MCAP log gets the plan
    /// on `/plan`.
    pub fn upload_plan(
        &mut self,
        id: u16,
        points: Vec<WirePoint>,
        set_pose: bool,
    ) -> Result<Uploaded> {
        let n = points.len();
        // The session's MCAP log records the plan on `/plan` at the robot's time, whichever
        // front end uploads it.
        if let Some(m) = self.mcap.as_mut() {
            omnikin_io::mcap_log::drive_plan(m, self.latest.map_or(0, |t| t.time_us), &points)?;
        }
        let mut up = PlanUpload::new(id, points, set_pose, false);
        let t0 = Instant::now();
        loop {
            let m = up.message();
            self.until(&m, up.step().name(), |s| {
                s.latest.is_some_and(|t| up.confirmed_by(&t))
            })?;
            let t = self.latest.context("no telemetry")?;
            if up.advance(&t) == Progress::Started {
                return Ok(Uploaded {
                    id,
                    points: n,
                    chunks: up.chunks(),
                    secs: t0.elapsed().as_secs_f64(),
                });
            }
        }
    }

    /// Heartbeats while the robot follows its started plan, until it reports it done and is
    /// idle.
    ///
    /// # Errors
    /// [`RobotRefused`] when the robot leaves the plan before its end (an e-stop, a fault);
    /// telemetry stopping for the timeout; the session lost.
    pub fn follow_plan(&mut self) -> Result<Followed> {
        let mut max_deviation = 0.0f32;
        let mut last_seen = Instant::now();
        let mut last_t = 0u64;
        let mut beat = Instant::now();
        loop {
            self.beat(&mut beat, &Message::Heartbeat)?;
            let Some(t) = self.latest else { continue };
            if t.time_us != last_t {
                last_t = t.time_us;
                last_seen = Instant::now();
            }
            if t.mode == Mode::Trajectory {
                let d = (t.pose[0] - t.reference[0]).hypot(t.pose[1] - t.reference[1]);
                max_deviation = max_deviation.max(d);
            } else if t.plan.done && t.mode == Mode::Idle {
                return Ok(Followed {
                    max_deviation,
                    end_pose: t.pose,
                });
            } else if !t.plan.done {
                return Err(RobotRefused(format!(
                    "the robot left the plan (mode {}, faults {})",
                    t.mode, t.fault_history
                ))
                .into());
            }
            self.alive()?;
            if last_seen.elapsed() > self.timeout {
                bail!(
                    "telemetry stopped for {:.1} s while following the plan",
                    self.timeout.as_secs_f64()
                );
            }
        }
    }

    /// The plan's world twist at the robot's time since the start, sent as a world-frame
    /// velocity command every heartbeat, then a stop: for a robot that takes no plans. The
    /// robot's own limits (the ballbot's lean-limited slew) shape it; nothing closes the loop
    /// on the plan's poses, so the end pose shows the drift of the robot's velocity tracking.
    ///
    /// # Errors
    /// [`RobotRefused`] when the robot e-stops while streaming; the link's errors.
    pub fn stream_plan(&mut self, plan: &Plan, set_pose: bool) -> Result<Streamed> {
        let Some(first) = plan.samples.first().map(|s| s.pose) else {
            bail!("the plan has no samples");
        };
        if set_pose {
            let m = Message::SetPose {
                x: first.x as f32,
                y: first.y as f32,
                heading: first.heading as f32,
            };
            self.until(&m, "set-pose", |s| {
                s.latest.is_some_and(|t| {
                    (f64::from(t.pose[0]) - first.x).abs() < 1e-4
                        && (f64::from(t.pose[1]) - first.y).abs() < 1e-4
                })
            })?;
        }
        self.first_telemetry("the session")?;
        let t0 = self.latest.context("no telemetry")?.time_us;
        let end = plan.duration();
        let (mut max_dev, mut max_path_dev) = (0.0f64, 0.0f64);
        let mut beat = Instant::now();
        loop {
            let t = self.latest.context("no telemetry")?;
            let now = t.time_us.saturating_sub(t0) as f64 * 1e-6;
            if now > end {
                break;
            }
            let i = plan
                .samples
                .partition_point(|p| p.t <= now)
                .saturating_sub(1);
            let p = &plan.samples[i];
            if set_pose {
                let (x, y) = (f64::from(t.pose[0]), f64::from(t.pose[1]));
                max_dev = max_dev.max((x - p.pose.x).hypot(y - p.pose.y));
                // Distance to the path, whenever it is passed (the lag along it left out).
                let d = plan
                    .samples
                    .iter()
                    .map(|q| (x - q.pose.x).hypot(y - q.pose.y))
                    .fold(f64::INFINITY, f64::min);
                max_path_dev = max_path_dev.max(d);
            }
            let m = Message::SetVelocity {
                frame: Frame::World,
                vx: p.twist.vx as f32,
                vy: p.twist.vy as f32,
                yaw_rate: p.twist.yaw_rate as f32,
            };
            self.beat(&mut beat, &m)?;
            self.alive()?;
            if let Some(t) = self.latest
                && t.mode == Mode::EStop
            {
                return Err(RobotRefused(format!(
                    "the robot stopped following (mode {}, faults {})",
                    t.mode, t.fault_history
                ))
                .into());
            }
        }
        self.stop()?;
        let t = self.latest.context("no telemetry")?;
        Ok(Streamed {
            deviation: set_pose.then_some((max_dev, max_path_dev)),
            end_pose: t.pose,
        })
    }
}
