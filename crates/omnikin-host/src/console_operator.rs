//! The operator session of `drive`, for `omnikin console` ([`ConsoleOperator`]).

use std::path::Path;
use std::time::Duration;

use anyhow::Result;
use omnikin::link::{Message, RobotInfo, SimTruth, Telemetry};

use crate::operator::Session;

/// The operator session of `drive`, for `omnikin console`: the same handshake (with its v1
/// probe and its diagnosis of a failed handshake), the same session frames and the same
/// telemetry bookkeeping, driven from the console's own event loop instead of a `drive`
/// action.
pub struct ConsoleOperator(Session);

impl ConsoleOperator {
    /// Opens the transport to `connect` (an address as `drive --connect` takes it) with an
    /// optional key file; `heartbeat_hz` and `timeout_s` as `drive --heartbeat/--timeout`.
    pub fn open(
        connect: &str,
        key: Option<&Path>,
        heartbeat_hz: f64,
        timeout_s: f64,
    ) -> Result<Self> {
        let mut s = Session::open(
            connect,
            key,
            heartbeat_hz,
            timeout_s,
            None,
            crate::names::OptionNames::CLI,
        )?;
        // A console watches: it opens a session only while nobody else's is live.
        s.op.set_take_over(false);
        Ok(Self(s))
    }

    /// The handshake (blocks up to the timeout): the robot's answer. Fails with [`RobotBusy`](crate::operator::RobotBusy)
    /// when another operator holds the robot and this one does not take over.
    pub fn hello(&mut self) -> Result<RobotInfo> {
        self.0.hello()
    }

    /// Whether this console's next handshake takes the robot over from a live session (only
    /// when its user acts; `drive` always does).
    pub fn set_take_over(&mut self, take_over: bool) {
        self.0.op.set_take_over(take_over);
    }

    /// Sends `m` in the session.
    pub fn send(&mut self, m: &Message) -> Result<()> {
        self.0.send(m)
    }

    /// Receives for up to `d`; `true` if a new telemetry frame of this session arrived.
    pub fn pump(&mut self, d: Duration) -> Result<bool> {
        self.0.pump(d)
    }

    /// Fails when the session is over (taken over, or silent for the timeout).
    pub fn alive(&self) -> Result<()> {
        self.0.alive()
    }

    /// The newest telemetry of this session.
    pub fn latest(&self) -> Option<Telemetry> {
        self.0.latest
    }

    /// The newest true pose of this session (simulated robots only).
    pub fn truth(&self) -> Option<SimTruth> {
        self.0.truth
    }

    /// The sequence number the next message will carry.
    pub fn next_seq(&self) -> u64 {
        self.0.next_seq()
    }

    /// This end's receive counters.
    pub fn counters(&self) -> omnikin::link::LinkCounters {
        *self.0.op.counters()
    }

    /// Telemetry frames of this session received.
    pub fn frames(&self) -> u64 {
        self.0.frames
    }

    /// The session id, once established.
    pub fn session_id(&self) -> Option<u64> {
        self.0.op.session_id()
    }

    /// The heartbeat period and the timeout.
    pub fn periods(&self) -> (Duration, Duration) {
        (self.0.heartbeat, self.0.timeout)
    }
}
