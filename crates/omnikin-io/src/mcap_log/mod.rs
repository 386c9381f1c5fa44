//! MCAP logs (`--mcap FILE` on `simulate`, `odometry`, `robot`, `drive`) with Foxglove's
//! schemas, and `omnikin convert` between MCAP and the CSV logs.
//!
//! A command hands [`McapLog`] one [`LogRow`] per row of its CSV log (the robot's time, the
//! estimate, the true pose in simulation, the wheels, the link counters, mode and faults);
//! the log's [`Encoder`] turns it into one message on each channel the sample has data for
//! (see [`foxglove::TOPICS`]) and derives `/events` from mode and fault changes. So a channel
//! has as many messages as the CSV log has rows. A live Foxglove server uses the same two steps
//! ([`telemetry_sample`], [`Encoder::messages`]) and publishes what the files hold.
//!
//! The file is chunked (64 KiB of messages, or one second of wall clock, whichever comes first)
//! and a chunk reaches the file only whole, so a process killed outright leaves a file that
//! reads up to its last complete chunk; SIGINT/SIGTERM and errors close it properly (summary
//! and footer) under the output rules of [`crate::output`] (temporary file renamed into place;
//! a log is kept on every exit path). Messages are protobuf ([`ENCODING`], [`proto`]) in
//! zstd-compressed chunks ([`COMPRESSION`]) without message index records: a 100 Hz
//! `robot --mcap` log is about 19 MB per hour of robot time driven by velocity (JSON with
//! message indexes was 58.7 MB, following a plan 83 MB; docs/seeing-the-robot.md); [`inflate`]
//! reads them back with bounded memory.

pub mod convert;
pub mod foxglove;
pub mod inflate;
pub mod proto;
pub mod ros2;
pub mod scan;

use std::collections::HashMap;
use std::io::{self, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use mcap::write::NoSeek;
use omnikin::Pose2;
use omnikin::runtime::{Faults, Mode};
use serde_json::Value;

use crate::output::OutFile;
use foxglove::{Counters, Level, Topic, WheelRates};
use proto::Encoding;

/// Uncompressed size of a chunk, bytes: what a killed process can lose at most (with
/// [`FLUSH_EVERY`]).
pub const CHUNK_SIZE: u64 = 64 * 1024;

/// Largest MCAP file `convert` reads (whole), bytes: 1 GiB, the other logs' limit; also the
/// largest decompressed copy [`inflate`] makes, so message offsets fit the reader's `u32`.
pub const MAX_INPUT_BYTES: u64 = omnikin_sim::limits::MAX_LOG_BYTES as u64;
/// Chunk compression of every MCAP file omnikin writes: zstd at its default level (3). Level
/// 9 was measured 2 % smaller on a 30 s `robot --mcap` log (57.7 against 58.7 MB per hour) at
/// a quarter of the speed: what is left after compression is the f64 values' low bits.
pub const COMPRESSION: mcap::Compression = mcap::Compression::Zstd;
/// Message encoding of every MCAP file omnikin writes: protobuf with Foxglove's schemas
/// ([`proto`]): a 30 s 100 Hz `robot --mcap` log's chunks are 152 kB, about 250 kB as JSON.
pub const ENCODING: Encoding = Encoding::Protobuf;
/// Wall-clock time after which the open chunk is closed and written even if not full.
pub const FLUSH_EVERY: Duration = Duration::from_secs(1);

/// The profile of the MCAP logs this process writes from now on (a global flag like
/// `--force`: `--mcap-profile`); [`ros2::LogProfile::Foxglove`] until set.
static ROS2: AtomicBool = AtomicBool::new(false);

/// Sets the profile of every [`McapLog`] created afterwards (`--mcap-profile`).
pub fn set_profile(p: ros2::LogProfile) {
    ROS2.store(p == ros2::LogProfile::Ros2, Ordering::Relaxed);
}

/// The profile [`McapLog::create`] uses ([`set_profile`]).
pub fn profile() -> ros2::LogProfile {
    if ROS2.load(Ordering::Relaxed) {
        ros2::LogProfile::Ros2
    } else {
        ros2::LogProfile::Foxglove
    }
}

/// The output file under the output rules, flushed to the OS after every write the MCAP
/// writer makes (it writes whole chunks and summary records only).
struct Sink(OutFile);

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.0.write_all(buf)?;
        self.0.flush()?;
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        self.0.flush()
    }
}

/// One row of a command's log, in the robot's time: what the channels show.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LogRow {
    /// Robot time, s (≥ 0): the MCAP log time.
    pub t: f64,
    /// The pose estimate (world frame; m, m, rad): `/pose` and `/tf`.
    pub pose: Pose2<f64>,
    /// The true pose (simulations): `/truth`.
    pub truth: Option<Pose2<f64>>,
    /// The plan's reference pose at the plan time (following a plan): `/reference`.
    pub reference: Option<Pose2<f64>>,
    /// Commanded wheel rates, rad/s (one per wheel): `/wheels`.
    pub commanded: Option<Vec<f64>>,
    /// Commanded steer rates, rad/s (kinds with steer motors): `/wheels`.
    pub commanded_steer: Option<Vec<f64>>,
    /// Encoder wheel angles, rad: `/wheels` has their rates (difference to the previous
    /// sample over the time step).
    pub wheel_angles: Option<Vec<f64>>,
    /// Encoder steer angles, rad: `/wheels` has their rates.
    pub steer_angles: Option<Vec<f64>>,
    /// Link counters: `/link`.
    pub link: Option<Counters>,
    /// Mode and active faults: `/events` on every change.
    pub state: Option<(Mode, Faults)>,
}

/// Per topic prefix (`""`, or `/trial-NNN` for the Monte-Carlo trials of `simulate`): what the
/// previous sample was, for measured rates and events.
#[derive(Default)]
struct Previous {
    t: f64,
    pose: Option<Pose2<f64>>,
    wheel_angles: Option<Vec<f64>>,
    steer_angles: Option<Vec<f64>>,
    state: Option<(Mode, Faults)>,
}

/// Samples to channel messages: the one step from a [`LogRow`] to Foxglove messages, shared by
/// the MCAP writer and a live Foxglove server (stateful: measured rates and events compare
/// each sample with the previous one under the same prefix).
pub struct Encoder {
    /// Process name in `/events` (`omnikin robot`, …).
    name: &'static str,
    previous: HashMap<String, Previous>,
}

impl Encoder {
    /// An encoder whose `/events` name the process `name`.
    pub fn new(name: &'static str) -> Self {
        Self {
            name,
            previous: HashMap::new(),
        }
    }

    /// The messages of one sample at log time `ns` (see [`foxglove::time_ns`]) for the channels
    /// under `prefix` (`""`, or `/trial-NNN`), in this order: `/pose`, `/tf` always;
    /// `/truth`, `/reference`, `/wheels`, `/link` when the sample has them; `/events` when the
    /// mode changed or a fault appeared since the previous sample.
    pub fn messages(&mut self, prefix: &str, s: &LogRow, ns: u64) -> Vec<(Topic, Value)> {
        use foxglove as fg;
        let mut out = vec![
            (fg::POSE, fg::pose_in_frame(ns, s.pose)),
            (fg::TF, fg::frame_transform(ns, s.pose)),
        ];
        if let Some(p) = s.truth {
            out.push((fg::TRUTH, fg::pose_in_frame(ns, p)));
        }
        if let Some(p) = s.reference {
            out.push((fg::REFERENCE, fg::pose_in_frame(ns, p)));
        }
        let step = self.step(prefix, s);
        let w = WheelRates {
            commanded: s.commanded.clone(),
            commanded_steer: s.commanded_steer.clone(),
            measured: step.measured.0,
            measured_steer: step.measured.1,
        };
        let before = step.state;
        if s.commanded.is_some() || s.wheel_angles.is_some() {
            out.push((fg::WHEELS, fg::wheel_rates(ns, &w)));
        }
        if let Some(c) = &s.link {
            out.push((fg::LINK, fg::link_counters(ns, c)));
        }
        if let Some(now) = s.state {
            for (level, text) in events(before, now) {
                out.push((fg::EVENTS, fg::log(ns, level, self.name, &text)));
            }
        }
        out
    }

    /// The messages of one sample in the `ros2` profile ([`ros2::messages`]), with the same
    /// bookkeeping as [`Encoder::messages`] (rates and events against the previous sample
    /// under `prefix`).
    pub fn ros2_messages(&mut self, prefix: &str, s: &LogRow, ns: u64) -> Vec<ros2::Message> {
        let step = self.step(prefix, s);
        let events = s.state.map_or_else(Vec::new, |now| events(step.state, now));
        ros2::messages(
            prefix,
            s,
            ns,
            step.pose,
            step.dt,
            step.measured,
            &events,
            self.name,
        )
    }

    /// Compares `s` with the previous sample under `prefix` (then remembers `s`): the time
    /// step, the encoders' rates, the previous estimate and mode/faults.
    fn step(&mut self, prefix: &str, s: &LogRow) -> Step {
        let prev = self.previous.entry(prefix.to_string()).or_default();
        let dt = s.t - prev.t;
        let measured = |now: &Option<Vec<f64>>, before: &Option<Vec<f64>>| match (now, before) {
            (Some(a), Some(b)) if dt > 0.0 && a.len() == b.len() => Some(rates(a, b, dt)),
            _ => None,
        };
        let step = Step {
            dt,
            measured: (
                measured(&s.wheel_angles, &prev.wheel_angles),
                measured(&s.steer_angles, &prev.steer_angles),
            ),
            pose: prev.pose.replace(s.pose),
            state: std::mem::replace(&mut prev.state, s.state),
        };
        prev.t = s.t;
        prev.wheel_angles.clone_from(&s.wheel_angles);
        prev.steer_angles.clone_from(&s.steer_angles);
        step
    }
}

/// A sample against the previous one under its prefix ([`Encoder::step`]).
struct Step {
    /// Time since the previous sample, s.
    dt: f64,
    /// Encoder rates (wheels, steering), rad/s, when both samples have the angles.
    measured: (Option<Vec<f64>>, Option<Vec<f64>>),
    /// The previous estimate.
    pose: Option<Pose2<f64>>,
    /// The previous mode and faults.
    state: Option<(Mode, Faults)>,
}

/// An MCAP log being written.
pub struct McapLog {
    writer: mcap::Writer<NoSeek<Sink>>,
    flag: String,
    path: String,
    encoder: Encoder,
    encoding: Encoding,
    profile: ros2::LogProfile,
    schemas: HashMap<&'static str, u16>,
    channels: HashMap<String, u16>,
    sequence: u32,
    last_flush: Instant,
}

/// Rates from angle differences: `(a - b) / dt` per wheel.
fn rates(now: &[f64], before: &[f64], dt: f64) -> Vec<f64> {
    now.iter().zip(before).map(|(a, b)| (a - b) / dt).collect()
}

impl McapLog {
    /// Starts the MCAP output `path` named by `flag` (`--mcap`); `name` is the process in
    /// `/events`. With `log`, the file is kept on every exit path like the CSV logs
    /// ([`OutFile::log`]); without, it appears only at [`finish`](Self::finish).
    pub fn create(flag: &str, path: &Path, name: &'static str, log: bool) -> Result<Self> {
        let out = if log {
            OutFile::log(flag, path)?
        } else {
            OutFile::create(flag, path)?
        };
        let shown = path.display().to_string();
        let writer = mcap::WriteOptions::new()
            .compression(Some(COMPRESSION))
            .chunk_size(Some(CHUNK_SIZE))
            .disable_seeking(true)
            // A message index is 16 uncompressed bytes per message after each chunk: 60 % of a
            // 100 Hz protobuf log. They are optional (readers find messages by the chunk
            // indexes and read whole chunks); convert never used them.
            .emit_message_indexes(false)
            .profile(match profile() {
                ros2::LogProfile::Foxglove => "",
                ros2::LogProfile::Ros2 => "ros2",
            })
            .library(concat!("omnikin ", env!("CARGO_PKG_VERSION")))
            .create(NoSeek::new(Sink(out)))
            .with_context(|| format!("{flag} {shown}: cannot write"))?;
        Ok(Self {
            writer,
            flag: flag.to_string(),
            path: shown,
            encoder: Encoder::new(name),
            encoding: ENCODING,
            profile: profile(),
            schemas: HashMap::new(),
            channels: HashMap::new(),
            sequence: 0,
            last_flush: Instant::now(),
        })
    }

    /// [`create`](Self::create) for an optional `--mcap` flag: `None` without one.
    pub fn for_flag(path: Option<&Path>, name: &'static str, log: bool) -> Result<Option<Self>> {
        path.map(|p| Self::create("--mcap", p, name, log))
            .transpose()
    }

    fn context(&self) -> String {
        format!("{} {}: cannot write", self.flag, self.path)
    }

    /// The channel id of `topic` under `prefix`, registered (with its schema) on first use.
    fn channel(&mut self, prefix: &str, topic: Topic) -> Result<u16> {
        let name = format!("{prefix}{}", topic.name);
        if let Some(&id) = self.channels.get(&name) {
            return Ok(id);
        }
        let ctx = self.context();
        let schema = match self.schemas.get(topic.schema.name) {
            Some(&id) => id,
            None => {
                let id = self
                    .writer
                    .add_schema(
                        topic.schema.name,
                        self.encoding.schema_encoding(),
                        self.encoding.schema_data(topic),
                    )
                    .context(ctx.clone())?;
                self.schemas.insert(topic.schema.name, id);
                id
            }
        };
        let id = self
            .writer
            .add_channel(
                schema,
                &name,
                self.encoding.message_encoding(),
                &Default::default(),
            )
            .context(ctx)?;
        self.channels.insert(name, id);
        Ok(id)
    }

    /// Writes one message on `prefix` + `topic` at log time `ns`.
    pub fn message(&mut self, prefix: &str, topic: Topic, ns: u64, v: &Value) -> Result<()> {
        let channel_id = self.channel(prefix, topic)?;
        let data = self
            .encoding
            .encode(topic, v)
            .map_err(|e| anyhow::anyhow!("{}: {prefix}{}: {e}", self.context(), topic.name))?;
        self.write(channel_id, ns, &data)
    }

    /// Writes `data` on channel `channel_id` at log time `ns` (both profiles), and closes the
    /// open chunk when [`FLUSH_EVERY`] has passed.
    fn write(&mut self, channel_id: u16, ns: u64, data: &[u8]) -> Result<()> {
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: ns,
            publish_time: ns,
        };
        self.sequence = self.sequence.wrapping_add(1);
        let ctx = self.context();
        self.writer
            .write_to_known_channel(&header, data)
            .context(ctx.clone())?;
        if self.last_flush.elapsed() >= FLUSH_EVERY {
            self.writer.flush().context(ctx)?;
            self.last_flush = Instant::now();
        }
        Ok(())
    }

    /// The log time of robot time `t`, or an error naming it.
    fn ns(&self, t: f64) -> Result<u64> {
        foxglove::time_ns(t).with_context(|| {
            format!(
                "{} {}: robot time t = {} s cannot be an MCAP log time (it must be ≥ 0 and finite)",
                self.flag,
                self.path,
                crate::num(t)
            )
        })
    }

    /// Writes the planned path on `/plan` at robot time `t` (`nav_msgs/msg/Path` in the
    /// `ros2` profile).
    pub fn plan(&mut self, t: f64, poses: &[Pose2<f64>]) -> Result<()> {
        let ns = self.ns(t)?;
        if self.profile == ros2::LogProfile::Ros2 {
            return self.ros2_message(&ros2::plan(ns, poses), ns);
        }
        self.message("", foxglove::PLAN, ns, &foxglove::poses_in_frame(ns, poses))
    }

    /// Writes one row: [`sample_under`](Self::sample_under) without a prefix.
    pub fn sample(&mut self, s: &LogRow) -> Result<()> {
        self.sample_under("", s)
    }

    /// Writes one row on the channels under `prefix` (`""` or `/trial-NNN`): the messages of
    /// [`Encoder::messages`].
    pub fn sample_under(&mut self, prefix: &str, s: &LogRow) -> Result<()> {
        let ns = self.ns(s.t)?;
        if self.profile == ros2::LogProfile::Ros2 {
            for m in self.encoder.ros2_messages(prefix, s, ns) {
                self.ros2_message(&m, ns)?;
            }
            return Ok(());
        }
        for (topic, v) in self.encoder.messages(prefix, s, ns) {
            self.message(prefix, topic, ns, &v)?;
        }
        Ok(())
    }

    /// Writes one message of the `ros2` profile at log time `ns`, registering its schema
    /// (`ros2msg`) and channel (`cdr`, with rosbag2's QoS and type-hash metadata) on first use.
    fn ros2_message(&mut self, m: &ros2::Message, ns: u64) -> Result<()> {
        let ctx = self.context();
        let channel_id = match self.channels.get(&m.topic) {
            Some(&id) => id,
            None => {
                let schema = match self.schemas.get(m.type_name) {
                    Some(&id) => id,
                    None => {
                        let id = self
                            .writer
                            .add_schema(m.type_name, "ros2msg", m.schema.as_bytes())
                            .context(ctx.clone())?;
                        self.schemas.insert(m.type_name, id);
                        id
                    }
                };
                let metadata = std::collections::BTreeMap::from([
                    (
                        "offered_qos_profiles".to_string(),
                        ros2::OFFERED_QOS.to_string(),
                    ),
                    ("topic_type_hash".to_string(), m.type_hash.to_string()),
                ]);
                let id = self
                    .writer
                    .add_channel(schema, &m.topic, "cdr", &metadata)
                    .context(ctx.clone())?;
                self.channels.insert(m.topic.clone(), id);
                id
            }
        };
        self.write(channel_id, ns, &m.data)
    }

    /// Closes the file (last chunk, summary, footer) and moves it into place.
    pub fn finish(mut self) -> Result<()> {
        let ctx = self.context();
        self.writer.finish().context(ctx)?;
        let Sink(out) = self.writer.into_inner().into_inner();
        out.commit()
    }
}

/// What changed from `before` to `now`, as `/events` lines: a mode change (the e-stop as an
/// error), and every fault that appears (watchdog, slip, rejected command, hardware, overrun;
/// the motor-limit flag is not an event, it shapes commands all the time).
pub fn events(before: Option<(Mode, Faults)>, now: (Mode, Faults)) -> Vec<(Level, String)> {
    let mut out = Vec::new();
    let (mode, faults) = now;
    let (old_mode, old_faults) = match before {
        Some((m, f)) => (Some(m), f),
        None => (None, Faults::NONE),
    };
    if old_mode != Some(mode) {
        match mode {
            Mode::EStop => out.push((
                Level::Error,
                "e-stop: motors off, latched until clear".to_string(),
            )),
            m => out.push((
                Level::Info,
                match old_mode {
                    Some(o) => format!("mode {o} -> {m}"),
                    None => format!("mode {m}"),
                },
            )),
        }
    }
    for (flag, name) in Faults::ALL {
        if !faults.contains(flag) || old_faults.contains(flag) {
            continue;
        }
        let (level, text) = match flag {
            Faults::LINK_LOST => (
                Level::Warning,
                "watchdog: no valid command or heartbeat within the watchdog time: controlled stop",
            ),
            Faults::SLIP => (
                Level::Warning,
                "slip: the wheels disagree with the gyro or with each other",
            ),
            Faults::COLLISION => (
                Level::Warning,
                "the wheel speed fell faster than events.collision_decel (a sudden stop)",
            ),
            Faults::REJECTED => (Level::Warning, "command rejected"),
            Faults::HARDWARE => (Level::Error, "hardware fault"),
            Faults::OVERRUN => (Level::Warning, "cycle overrun"),
            _ => continue,
        };
        out.push((level, format!("{name}: {text}")));
    }
    out
}

// ---------------------------------------------------------------------------------------------
// The commands' hooks: one call per row.

/// `robot --sim`: one control cycle (the runtime's status, the plant's true pose, the link's
/// counters).
pub fn runtime_cycle(
    log: &mut McapLog,
    s: &omnikin::runtime::Status<f64>,
    truth: Pose2<f64>,
    link: &omnikin::link::LinkCounters,
    steerable: bool,
) -> Result<()> {
    let n = usize::from(s.wheels).min(omnikin::MAX_WHEELS);
    log.sample(&LogRow {
        t: s.time_us as f64 * 1e-6,
        pose: s.pose,
        truth: Some(truth),
        reference: (s.mode == Mode::Trajectory).then_some(s.reference),
        commanded: Some(s.motors.wheel[..n].to_vec()),
        commanded_steer: steerable.then(|| s.motors.steer[..n].to_vec()),
        wheel_angles: Some(s.encoders.wheel[..n].to_vec()),
        steer_angles: steerable.then(|| s.encoders.steer[..n].to_vec()),
        link: Some(Counters::from_link(link, s.rejected)),
        state: Some((s.mode, s.faults)),
    })
}

/// The [`LogRow`] of a telemetry frame (robot time, estimate, reference in trajectory mode,
/// commanded rates and encoder angles of the robot's wheels, counters, mode and faults).
pub fn telemetry_sample(t: &omnikin::link::Telemetry) -> LogRow {
    let n = usize::from(t.wheels).min(omnikin::MAX_WHEELS);
    let v = |a: &[f32]| a[..n].iter().map(|&x| f64::from(x)).collect::<Vec<f64>>();
    let p = |a: [f32; 3]| Pose2::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]));
    // Kinds without steer motors send zeros: steer columns only when some are non-zero.
    let steer = t.steer_rates[..n].iter().any(|&x| x != 0.0)
        || t.steer_angles[..n].iter().any(|&x| x != 0.0);
    LogRow {
        t: t.time_us as f64 * 1e-6,
        pose: p(t.pose),
        truth: None,
        reference: (t.mode == Mode::Trajectory).then_some(p(t.reference)),
        commanded: Some(v(&t.wheel_rates)),
        commanded_steer: steer.then(|| v(&t.steer_rates)),
        wheel_angles: Some(v(&t.wheel_angles)),
        steer_angles: steer.then(|| v(&t.steer_angles)),
        link: Some(Counters::from_link(&t.link, t.rejected)),
        state: Some((t.mode, t.faults)),
    }
}

/// [`telemetry_sample`] with the simulated plant's true pose of the same cycle on `/truth`
/// (`robot --sim` sends one before each telemetry frame; `None`, or the truth of another
/// cycle, leaves `/truth` out).
pub fn telemetry_sample_with_truth(
    t: &omnikin::link::Telemetry,
    truth: Option<omnikin::link::SimTruth>,
) -> LogRow {
    let mut s = telemetry_sample(t);
    s.truth = truth
        .filter(|x| x.time_us == t.time_us)
        .map(|x| Pose2::new(x.pose[0].into(), x.pose[1].into(), x.pose[2].into()));
    s
}

/// `drive plan`: the uploaded plan's poses on `/plan`, at the robot time `time_us` (µs) of the
/// newest telemetry frame (0 before any).
pub fn drive_plan(
    log: &mut McapLog,
    time_us: u64,
    points: &[omnikin::link::WirePoint],
) -> Result<()> {
    let poses: Vec<Pose2<f64>> = points
        .iter()
        .map(|w| {
            Pose2::new(
                f64::from(w.pose[0]),
                f64::from(w.pose[1]),
                f64::from(w.pose[2]),
            )
        })
        .collect();
    log.plan(time_us as f64 * 1e-6, &poses)
}

/// `simulate --mcap`: the log (`None` without the flag), with the plan's path on `/plan` at
/// the plan's start time.
pub fn simulation(path: Option<&Path>, plan: &omnikin_plan::Plan) -> Result<Option<McapLog>> {
    let Some(mut log) = McapLog::for_flag(path, "omnikin simulate", false)? else {
        return Ok(None);
    };
    let poses: Vec<Pose2<f64>> = plan.samples.iter().map(|s| s.pose).collect();
    log.plan(plan.samples.first().map_or(0.0, |s| s.t.max(0.0)), &poses)?;
    Ok(Some(log))
}

/// `simulate --plant dynamic --mcap`: the one trial, written and closed.
pub fn one_trial(
    path: Option<&Path>,
    plan: &omnikin_plan::Plan,
    tr: &omnikin_sim::Trial,
) -> Result<()> {
    match simulation(path, plan)? {
        Some(mut log) => {
            trial(&mut log, 0, tr, plan)?;
            log.finish()
        }
        None => Ok(()),
    }
}

/// `simulate`: trial `i` of the Monte-Carlo run (`/truth` the plant, `/pose` what the tracker
/// saw — its position, with the true heading, since the tracker measures no heading —,
/// `/wheels` the plan's wheel commands and the rates of the true wheel angles). Trial 0 is on
/// the plain channels, trial `i > 0` under `/trial-NNN`.
pub fn trial(
    log: &mut McapLog,
    i: usize,
    tr: &omnikin_sim::Trial,
    plan: &omnikin_plan::Plan,
) -> Result<()> {
    let prefix = if i == 0 {
        String::new()
    } else {
        format!("/trial-{i:03}")
    };
    let n = tr.wheels.min(omnikin::MAX_WHEELS);
    let steer = plan.samples.first().is_some_and(|s| s.steer.is_some());
    if tr.t.len() != tr.pose.len() || tr.t.len() != tr.tracked.len() {
        bail!("trial {i}: its columns differ in length");
    }
    for k in 0..tr.t.len() {
        let cmd = plan.samples.get(k);
        let (p, q) = (tr.pose[k], tr.tracked[k]);
        log.sample_under(
            &prefix,
            &LogRow {
                t: tr.t[k],
                pose: Pose2::new(q[0], q[1], p.heading),
                truth: Some(p),
                commanded: cmd.map(|c| c.wheel_rates[..n].to_vec()),
                commanded_steer: cmd.and_then(|c| c.steer.map(|s| s.1[..n].to_vec())),
                wheel_angles: tr.wheel_angles.get(k).map(|a| a[..n].to_vec()),
                steer_angles: if steer {
                    tr.steer_angles.get(k).map(|a| a[..n].to_vec())
                } else {
                    None
                },
                ..Default::default()
            },
        )?;
    }
    Ok(())
}

/// `odometry`'s log: the estimate `(t, pose)` row by row as it is computed (`/pose` the
/// estimate, `/tf`; `/truth` is absent: a recorded log has none). The file appears at
/// [`finish`](Self::finish); dropped before, its temporary file is removed.
pub struct PoseLog(McapLog);

impl PoseLog {
    /// Starts the MCAP output `path` named by `flag`.
    pub fn create(flag: &str, path: &Path) -> Result<Self> {
        McapLog::create(flag, path, "omnikin odometry", false).map(Self)
    }

    /// Writes the estimate `pose` at log time `t` (s).
    pub fn push(&mut self, t: f64, pose: Pose2<f64>) -> Result<()> {
        self.0.sample(&LogRow {
            t,
            pose,
            ..Default::default()
        })
    }

    /// Finishes the file and moves it into place.
    pub fn finish(self) -> Result<()> {
        self.0.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_on_changes_only() {
        let idle = (Mode::Idle, Faults::NONE);
        assert_eq!(events(Some(idle), idle), vec![]);
        let e = events(None, idle);
        assert_eq!(e, vec![(Level::Info, "mode idle".to_string())]);
        let mut f = Faults::LINK_LOST;
        f.insert(Faults::LIMIT);
        let e = events(Some((Mode::Velocity, Faults::NONE)), (Mode::Stopping, f));
        assert_eq!(e.len(), 2, "{e:?}");
        assert!(e[0].1.contains("velocity -> stopping"));
        assert!(e[1].1.starts_with("link_lost: watchdog"), "{e:?}");
        let e = events(Some((Mode::Stopping, f)), (Mode::EStop, f));
        assert_eq!(e.len(), 1);
        assert_eq!(e[0].0, Level::Error);
    }

    #[test]
    fn measured_rates_are_angle_differences() {
        assert_eq!(rates(&[1.0, 3.0], &[0.5, 4.0], 0.5), vec![1.0, -2.0]);
    }
}
