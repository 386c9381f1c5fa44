//! What an operator asks of a robot in its session, each confirmed by the robot's telemetry:
//! stop, e-stop, clear, a velocity held for a while, listening (heartbeats only). Every front
//! end runs these: `omnikin drive`, Python's `omnikin.Link`.

use std::time::{Duration, Instant};

use anyhow::Result;
use omnikin::link::Message;
use omnikin::runtime::{Frame, Mode};

use crate::operator::Session;

/// The robot answered, but not as asked: it did not take a command, or left a plan. The
/// front end shows the robot's status with it (`drive` prints it before the error).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RobotRefused(pub String);

impl std::fmt::Display for RobotRefused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for RobotRefused {}

impl Session {
    /// Waits for the session's first telemetry frame (the robot took the session).
    pub fn first_telemetry(&mut self, what: &str) -> Result<()> {
        self.until(&Message::Heartbeat, what, |s| s.latest.is_some())
    }

    /// Stops the robot (`Stop`, repeated until telemetry of this session acknowledges it
    /// and shows the robot idle or e-stopped).
    pub fn stop(&mut self) -> Result<()> {
        let first = self.next_seq();
        self.until(&Message::Stop, "the stop", |s| {
            s.latest
                .is_some_and(|t| t.ack_seq >= first && matches!(t.mode, Mode::Idle | Mode::EStop))
        })
    }

    /// The emergency stop: confirmed only by telemetry of this session naming one of the
    /// `EStop`s sent here (the latch stays until [`Session::clear`]).
    pub fn estop(&mut self) -> Result<()> {
        let first = self.next_seq();
        self.until(&Message::EStop, "the e-stop", |s| {
            s.latest
                .is_some_and(|t| t.mode == Mode::EStop && t.estop_seq >= first)
        })
    }

    /// Clears the e-stop latch and the fault history (confirmed when both are gone).
    pub fn clear(&mut self) -> Result<()> {
        let first = self.next_seq();
        self.until(&Message::Clear, "clear", |s| {
            s.latest.is_some_and(|t| {
                t.ack_seq >= first && t.mode != Mode::EStop && t.fault_history.is_empty()
            })
        })
    }

    /// Sets the robot's pose estimate to `pose` `[x, y, heading]` (world; m, m, rad),
    /// confirmed when its telemetry shows it (within 0.1 mm).
    pub fn set_pose(&mut self, pose: [f64; 3]) -> Result<()> {
        let m = Message::SetPose {
            x: pose[0] as f32,
            y: pose[1] as f32,
            heading: pose[2] as f32,
        };
        self.until(&m, "set-pose", |s| {
            s.latest.is_some_and(|t| {
                (f64::from(t.pose[0]) - pose[0]).abs() < 1e-4
                    && (f64::from(t.pose[1]) - pose[1]).abs() < 1e-4
            })
        })
    }

    /// Sends `m` every heartbeat for `dur`, receiving all the while (telemetry logged, fixes
    /// forwarded); fails when the session is lost.
    pub fn repeat(&mut self, m: &Message, dur: Duration) -> Result<()> {
        let end = Instant::now() + dur;
        let mut beat = Instant::now();
        while Instant::now() < end {
            self.beat(&mut beat, m)?;
            self.alive()?;
        }
        Ok(())
    }

    /// Drives at the twist `[vx, vy, yaw_rate]` (m/s, m/s, rad/s) in `frame` for `dur`,
    /// then stops (confirmed).
    ///
    /// # Errors
    /// [`RobotRefused`] when the robot's mode at the end is not velocity (it refused the
    /// command: e-stop latched, a fault, limits); the link's errors otherwise.
    pub fn velocity(&mut self, frame: Frame, twist: [f64; 3], dur: Duration) -> Result<()> {
        let m = Message::SetVelocity {
            frame,
            vx: twist[0] as f32,
            vy: twist[1] as f32,
            yaw_rate: twist[2] as f32,
        };
        self.repeat(&m, dur)?;
        if let Some(t) = self.latest
            && t.mode != Mode::Velocity
        {
            return Err(RobotRefused(format!(
                "the robot did not take the command (mode {}, rejected {})",
                t.mode, t.rejected
            ))
            .into());
        }
        self.stop()
    }
}
