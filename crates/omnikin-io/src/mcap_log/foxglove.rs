//! omnikin data as Foxglove messages: our types become the JSON messages of Foxglove's
//! published schemas (`foxglove.PoseInFrame`, `foxglove.PosesInFrame`,
//! `foxglove.FrameTransform`, `foxglove.Log`) and of two schemas of our own
//! (`omnikin.WheelRates`, `omnikin.LinkCounters`), in this one place, for the MCAP logs
//! ([`super::McapLog`]) and for a live Foxglove WebSocket server (`omnikin console`).
//!
//! Encoding: every message is built as a JSON object (MCAP `message_encoding`
//! [`MESSAGE_ENCODING`]), described by a JSON Schema (MCAP schema `encoding`
//! [`SCHEMA_ENCODING`]) whose name is the schema name Foxglove recognises; the live server
//! publishes them so, the MCAP files hold their protobuf form ([`super::proto`]); the schema texts below carry the fields of Foxglove's
//! published JSON schemas that we fill (the optional `message_id` and `lineage` are left out).
//!
//! Frames and units (conventions.md): the floor frame is [`WORLD`], the robot frame is [`BASE`]
//! (x forward, y left, z up); positions in m with z = 0; a heading ψ (rad, CCW about +z) is the
//! quaternion `(0, 0, sin ψ/2, cos ψ/2)`. Times are the robot's clock, integer nanoseconds
//! ([`time_ns`]), written as Foxglove's `{sec, nsec}`.

use omnikin::Pose2;
use omnikin::link::LinkCounters;

use crate::telemetry_schema;
use serde_json::{Value, json};

/// MCAP `message_encoding` of every channel: JSON.
pub const MESSAGE_ENCODING: &str = "json";
/// MCAP schema `encoding` of every schema: JSON Schema.
pub const SCHEMA_ENCODING: &str = "jsonschema";
/// The world (floor) frame id.
pub const WORLD: &str = "world";
/// The robot frame id (platform / body frame: x forward, y left, z up).
pub const BASE: &str = "base";

/// A message schema: the name Foxglove (or our reader) knows it by, and its JSON Schema text.
#[derive(Clone, Copy)]
pub struct Schema {
    /// Schema name, e.g. `foxglove.PoseInFrame`.
    pub name: &'static str,
    /// JSON Schema (draft 7 style, as Foxglove publishes them) of the messages: a fixed text,
    /// or derived once from [`crate::telemetry_schema`] (`omnikin.LinkCounters`).
    pub data: fn() -> &'static str,
}

impl Schema {
    /// Its JSON Schema text.
    pub fn text(&self) -> &'static str {
        (self.data)()
    }
}

impl PartialEq for Schema {
    /// Schemas are known by their names.
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}
impl Eq for Schema {}

impl std::fmt::Debug for Schema {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Schema").field("name", &self.name).finish()
    }
}

/// A channel of the logs: its topic and the schema of its messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Topic {
    /// Topic name (`/pose`, …).
    pub name: &'static str,
    /// Its messages' schema.
    pub schema: &'static Schema,
}

/// The `time` sub-schema of every schema (held equal to `time!()` by a test).
#[cfg(test)]
const TIME: &str = r#"{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}}"#;

macro_rules! vec3 {
    () => {
        r#"{"title":"foxglove.Vector3","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}},"required":["x","y","z"]}"#
    };
}
macro_rules! quat {
    () => {
        r#"{"title":"foxglove.Quaternion","type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}},"required":["x","y","z","w"]}"#
    };
}
macro_rules! pose {
    () => {
        concat!(
            r#"{"title":"foxglove.Pose","type":"object","properties":{"position":"#,
            vec3!(),
            r#","orientation":"#,
            quat!(),
            r#"},"required":["position","orientation"]}"#
        )
    };
}
macro_rules! time {
    () => {
        r#"{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}}"#
    };
}

/// `foxglove.PoseInFrame`: a timestamped pose in a frame.
pub const POSE_IN_FRAME: Schema = Schema {
    name: "foxglove.PoseInFrame",
    data: || {
        concat!(
            r#"{"title":"foxglove.PoseInFrame","description":"A timestamped pose for an object or reference frame in 3D space","type":"object","properties":{"timestamp":"#,
            time!(),
            r#","frame_id":{"type":"string"},"pose":"#,
            pose!(),
            r#"},"required":["timestamp","frame_id","pose"]}"#
        )
    },
};

/// `foxglove.PosesInFrame`: an array of poses in one frame (a planned path).
pub const POSES_IN_FRAME: Schema = Schema {
    name: "foxglove.PosesInFrame",
    data: || {
        concat!(
            r#"{"title":"foxglove.PosesInFrame","description":"An array of timestamped poses for an object or reference frame in 3D space","type":"object","properties":{"timestamp":"#,
            time!(),
            r#","frame_id":{"type":"string"},"poses":{"type":"array","items":"#,
            pose!(),
            r#"}},"required":["timestamp","frame_id","poses"]}"#
        )
    },
};

/// `foxglove.FrameTransform`: the pose of a child frame in a parent frame.
pub const FRAME_TRANSFORM: Schema = Schema {
    name: "foxglove.FrameTransform",
    data: || {
        concat!(
            r#"{"title":"foxglove.FrameTransform","description":"A transform between two reference frames in 3D space","type":"object","properties":{"timestamp":"#,
            time!(),
            r#","parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},"translation":"#,
            vec3!(),
            r#","rotation":"#,
            quat!(),
            r#"},"required":["timestamp","parent_frame_id","child_frame_id","translation","rotation"]}"#
        )
    },
};

/// `foxglove.Log`: a log line (level 1 debug, 2 info, 3 warning, 4 error, 5 fatal).
pub const LOG: Schema = Schema {
    name: "foxglove.Log",
    data: || {
        concat!(
            r#"{"title":"foxglove.Log","description":"A log message","type":"object","properties":{"timestamp":"#,
            time!(),
            r#","level":{"title":"foxglove.LogLevel","oneOf":[{"title":"UNKNOWN","const":0},{"title":"DEBUG","const":1},{"title":"INFO","const":2},{"title":"WARNING","const":3},{"title":"ERROR","const":4},{"title":"FATAL","const":5}]},"message":{"type":"string"},"name":{"type":"string"},"file":{"type":"string"},"line":{"type":"integer","minimum":0}},"required":["timestamp","level","message","name","file","line"]}"#
        )
    },
};

/// `omnikin.WheelRates`: commanded and measured wheel and steer rates, rad/s, one entry per
/// wheel (module) in the robot file's order; an array the source does not know is absent.
pub const WHEEL_RATES: Schema = Schema {
    name: "omnikin.WheelRates",
    data: || {
        concat!(
            r#"{"title":"omnikin.WheelRates","description":"Commanded and measured wheel and steer rates, rad/s, in the robot file's wheel order (measured: encoder angle differences over the sample interval)","type":"object","properties":{"timestamp":"#,
            time!(),
            r#","commanded":{"type":"array","items":{"type":"number"},"description":"Commanded wheel rates, rad/s"},"commanded_steer":{"type":"array","items":{"type":"number"},"description":"Commanded steer rates, rad/s"},"measured":{"type":"array","items":{"type":"number"},"description":"Measured wheel rates, rad/s"},"measured_steer":{"type":"array","items":{"type":"number"},"description":"Measured steer rates, rad/s"}},"required":["timestamp"]}"#
        )
    },
};

/// `omnikin.LinkCounters`: the receive counters of the link (cumulative frame counts) and the
/// runtime's rejected commands ([`Counters::NAMES`], from [`crate::telemetry_schema`]); a
/// counter the source does not know is absent.
pub const LINK_COUNTERS: Schema = Schema {
    name: "omnikin.LinkCounters",
    data: link_counters_schema,
};

/// The JSON Schema of `omnikin.LinkCounters`, derived from [`Counters::NAMES`] once.
fn link_counters_schema() -> &'static str {
    static TEXT: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
        let mut t = String::from(concat!(
            r#"{"title":"omnikin.LinkCounters","description":"Link receive counters (frames since start) and commands rejected by the runtime","type":"object","properties":{"timestamp":"#,
            time!()
        ));
        for name in Counters::NAMES {
            t.push_str(&format!(r#","{name}":{{"type":"integer","minimum":0}}"#));
        }
        t.push_str(r#"},"required":["timestamp"]}"#);
        t
    });
    &TEXT
}

/// `/pose`: the robot's pose estimate (`foxglove.PoseInFrame`, frame [`WORLD`]).
pub const POSE: Topic = Topic {
    name: "/pose",
    schema: &POSE_IN_FRAME,
};
/// `/truth`: the simulated plant's true pose (`foxglove.PoseInFrame`, frame [`WORLD`]).
pub const TRUTH: Topic = Topic {
    name: "/truth",
    schema: &POSE_IN_FRAME,
};
/// `/reference`: the plan's reference pose at the plan time (`foxglove.PoseInFrame`).
pub const REFERENCE: Topic = Topic {
    name: "/reference",
    schema: &POSE_IN_FRAME,
};
/// `/tf`: the estimate as the transform [`WORLD`] → [`BASE`] (`foxglove.FrameTransform`).
pub const TF: Topic = Topic {
    name: "/tf",
    schema: &FRAME_TRANSFORM,
};
/// `/plan`: the planned path (`foxglove.PosesInFrame`, frame [`WORLD`]).
pub const PLAN: Topic = Topic {
    name: "/plan",
    schema: &POSES_IN_FRAME,
};
/// `/wheels`: commanded and measured wheel/steer rates (`omnikin.WheelRates`).
pub const WHEELS: Topic = Topic {
    name: "/wheels",
    schema: &WHEEL_RATES,
};
/// `/link`: link counters (`omnikin.LinkCounters`).
pub const LINK: Topic = Topic {
    name: "/link",
    schema: &LINK_COUNTERS,
};
/// `/events`: e-stop, watchdog, slip, mode changes (`foxglove.Log`).
pub const EVENTS: Topic = Topic {
    name: "/events",
    schema: &LOG,
};

/// Every channel the logs may have, in this order.
pub const TOPICS: [Topic; 8] = [POSE, TRUTH, REFERENCE, TF, PLAN, WHEELS, LINK, EVENTS];

/// Most digits of the trial number in a `/trial-NNN` prefix.
pub const MAX_TRIAL_DIGITS: usize = 9;

/// The topic named `name` (one of [`TOPICS`]), ignoring a `/trial-NNN` prefix (`NNN` one to
/// [`MAX_TRIAL_DIGITS`] ASCII digits, as `simulate --mcap-trials` writes it; any other prefix
/// is no topic of ours, so a name that reaches a file name is digits and one of [`TOPICS`]).
pub fn topic(name: &str) -> Option<Topic> {
    let base = match name.strip_prefix("/trial-") {
        Some(rest) => {
            let slash = rest.find('/')?;
            let n = &rest[..slash];
            if n.is_empty() || n.len() > MAX_TRIAL_DIGITS || !n.bytes().all(|b| b.is_ascii_digit())
            {
                return None;
            }
            &rest[slash..]
        }
        None => name,
    };
    TOPICS.into_iter().find(|t| t.name == base)
}

/// Robot time `t` (s) as MCAP log time (ns since the robot clock's zero), or `None` when `t`
/// is negative, not finite or beyond 2⁶⁴ ns (585 years).
pub fn time_ns(t: f64) -> Option<u64> {
    let ns = (t * 1e9).round();
    (ns.is_finite() && (0.0..1.8e19).contains(&ns)).then_some(ns as u64)
}

/// Log time `ns` as seconds (the CSV logs' `t`).
pub fn seconds(ns: u64) -> f64 {
    // A division, not a product with 1e-9: 30 ms is written 0.03, not 0.030000000000000002.
    ns as f64 / 1e9
}

/// Foxglove's `time` object `{sec, nsec}` for `ns` nanoseconds.
pub fn timestamp(ns: u64) -> Value {
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

/// The `foxglove.Pose` of a planar pose: position `(x, y, 0)` m, yaw quaternion of `heading`.
pub fn pose(p: Pose2<f64>) -> Value {
    let h = 0.5 * p.heading;
    json!({
        "position": {"x": p.x, "y": p.y, "z": 0.0},
        "orientation": {"x": 0.0, "y": 0.0, "z": h.sin(), "w": h.cos()},
    })
}

/// A `foxglove.PoseInFrame` in [`WORLD`] at `ns`.
pub fn pose_in_frame(ns: u64, p: Pose2<f64>) -> Value {
    json!({"timestamp": timestamp(ns), "frame_id": WORLD, "pose": pose(p)})
}

/// A `foxglove.PosesInFrame` in [`WORLD`] at `ns` (a path: the poses in order).
pub fn poses_in_frame(ns: u64, poses: &[Pose2<f64>]) -> Value {
    let poses: Vec<Value> = poses.iter().map(|p| pose(*p)).collect();
    json!({"timestamp": timestamp(ns), "frame_id": WORLD, "poses": poses})
}

/// A `foxglove.FrameTransform` [`WORLD`] → [`BASE`] at `ns`: the robot frame at pose `p`.
pub fn frame_transform(ns: u64, p: Pose2<f64>) -> Value {
    let h = 0.5 * p.heading;
    json!({
        "timestamp": timestamp(ns),
        "parent_frame_id": WORLD,
        "child_frame_id": BASE,
        "translation": {"x": p.x, "y": p.y, "z": 0.0},
        "rotation": {"x": 0.0, "y": 0.0, "z": h.sin(), "w": h.cos()},
    })
}

/// `foxglove.LogLevel` (the levels omnikin uses; Foxglove also has 1 debug and 5 fatal).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Level {
    /// Information (a mode change).
    Info = 2,
    /// Warning (watchdog, slip, a rejected command).
    Warning = 3,
    /// Error (e-stop, a hardware fault).
    Error = 4,
}

/// A `foxglove.Log` at `ns` from the process `name` (`omnikin robot`, …).
pub fn log(ns: u64, level: Level, name: &str, message: &str) -> Value {
    json!({
        "timestamp": timestamp(ns), "level": level as u8, "message": message,
        "name": name, "file": "", "line": 0,
    })
}

/// Wheel and steer rates of one sample, rad/s, one entry per wheel (module); `None`: unknown.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WheelRates {
    /// Commanded wheel rates.
    pub commanded: Option<Vec<f64>>,
    /// Commanded steer rates (kinds with steer motors).
    pub commanded_steer: Option<Vec<f64>>,
    /// Measured wheel rates.
    pub measured: Option<Vec<f64>>,
    /// Measured steer rates (kinds with steer motors).
    pub measured_steer: Option<Vec<f64>>,
}

/// An `omnikin.WheelRates` at `ns`.
pub fn wheel_rates(ns: u64, w: &WheelRates) -> Value {
    let mut v = json!({"timestamp": timestamp(ns)});
    for (k, a) in [
        ("commanded", &w.commanded),
        ("commanded_steer", &w.commanded_steer),
        ("measured", &w.measured),
        ("measured_steer", &w.measured_steer),
    ] {
        if let Some(a) = a {
            v[k] = json!(a);
        }
    }
    v
}

/// How many `/link` counters there are: the [`LINK_COUNTERS`](crate::telemetry_schema::LINK_COUNTERS),
/// [`DROPPED`](crate::telemetry_schema::DROPPED) and `rejected`.
pub const COUNTER_COUNT: usize = telemetry_schema::LINK_COUNTERS.len() + 2;

/// Link counters of one sample, in the order of [`Counters::NAMES`]; `None`: unknown (a CSV
/// log that has only some of them).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters(pub [Option<u64>; COUNTER_COUNT]);

impl Counters {
    /// The names of the counters (the `/link` fields): the telemetry schema's receive counters
    /// ([`telemetry_schema::LINK_COUNTERS`]), then [`telemetry_schema::DROPPED`] (every frame
    /// dropped) and `rejected` (commands the runtime rejected).
    pub const NAMES: [&'static str; COUNTER_COUNT] = {
        let mut n = [""; COUNTER_COUNT];
        let mut i = 0;
        while i < telemetry_schema::LINK_COUNTERS.len() {
            n[i] = telemetry_schema::LINK_COUNTERS[i].name;
            i += 1;
        }
        n[i] = telemetry_schema::DROPPED;
        n[i + 1] = "rejected";
        n
    };

    /// The protobuf field number of each counter, in the order of [`Counters::NAMES`]
    /// ([`telemetry_schema::Counter::field`], then [`telemetry_schema::DROPPED_FIELD`] and
    /// [`telemetry_schema::REJECTED_FIELD`]).
    pub const FIELDS: [u32; COUNTER_COUNT] = {
        let mut n = [0; COUNTER_COUNT];
        let mut i = 0;
        while i < telemetry_schema::LINK_COUNTERS.len() {
            n[i] = telemetry_schema::LINK_COUNTERS[i].field;
            i += 1;
        }
        n[i] = telemetry_schema::DROPPED_FIELD;
        n[i + 1] = telemetry_schema::REJECTED_FIELD;
        n
    };

    /// Every counter of the link's [`LinkCounters`] and the runtime's rejected commands.
    pub fn from_link(c: &LinkCounters, rejected: u32) -> Self {
        let mut v = [None; COUNTER_COUNT];
        for (x, k) in v.iter_mut().zip(&telemetry_schema::LINK_COUNTERS) {
            *x = Some(u64::from((k.value)(c)));
        }
        v[COUNTER_COUNT - 2] = Some(u64::from(c.dropped()));
        v[COUNTER_COUNT - 1] = Some(u64::from(rejected));
        Self(v)
    }

    /// The counters in the order of [`Counters::NAMES`].
    pub fn values(&self) -> [Option<u64>; COUNTER_COUNT] {
        self.0
    }

    /// Counters from values in the order of [`Counters::NAMES`].
    pub fn from_values(v: [Option<u64>; COUNTER_COUNT]) -> Self {
        Self(v)
    }

    /// The counter called `name` (`None`: unknown, or no such counter).
    pub fn get(&self, name: &str) -> Option<u64> {
        Self::NAMES
            .iter()
            .position(|n| *n == name)
            .and_then(|i| self.0[i])
    }
}

/// An `omnikin.LinkCounters` at `ns`.
pub fn link_counters(ns: u64, c: &Counters) -> Value {
    let mut v = json!({"timestamp": timestamp(ns)});
    for (k, x) in Counters::NAMES.iter().zip(c.values()) {
        if let Some(x) = x {
            v[*k] = json!(x);
        }
    }
    v
}

// ---------------------------------------------------------------------------------------------
// Decoding (for `omnikin convert`): the inverse of the encoders above.

/// The `(x, y, heading)` of a `foxglove.Pose` (heading in (-π, π]), or `None` if it is not one.
pub fn decode_pose(v: &Value) -> Option<Pose2<f64>> {
    let p = v.get("position")?;
    let q = v.get("orientation")?;
    planar(p, q)
}

fn planar(p: &Value, q: &Value) -> Option<Pose2<f64>> {
    let f = |v: &Value, k: &str| v.get(k)?.as_f64();
    // The yaw of a quaternion (x, y, z, w) about +z.
    let (qx, qy, qz, qw) = (f(q, "x")?, f(q, "y")?, f(q, "z")?, f(q, "w")?);
    let heading = (2.0 * (qw * qz + qx * qy)).atan2(1.0 - 2.0 * (qy * qy + qz * qz));
    Some(Pose2::new(f(p, "x")?, f(p, "y")?, heading))
}

/// The pose of a `foxglove.PoseInFrame` message.
pub fn decode_pose_in_frame(v: &Value) -> Option<Pose2<f64>> {
    decode_pose(v.get("pose")?)
}

/// The poses of a `foxglove.PosesInFrame` message.
pub fn decode_poses_in_frame(v: &Value) -> Option<Vec<Pose2<f64>>> {
    v.get("poses")?
        .as_array()?
        .iter()
        .map(decode_pose)
        .collect()
}

/// The pose (translation, yaw) of a `foxglove.FrameTransform` message and its frames.
pub fn decode_frame_transform(v: &Value) -> Option<(Pose2<f64>, &str, &str)> {
    let p = planar(v.get("translation")?, v.get("rotation")?)?;
    Some((
        p,
        v.get("parent_frame_id")?.as_str()?,
        v.get("child_frame_id")?.as_str()?,
    ))
}

/// The `(level, name, message)` of a `foxglove.Log` message.
pub fn decode_log(v: &Value) -> Option<(u64, &str, &str)> {
    Some((
        v.get("level")?.as_u64()?,
        v.get("name")?.as_str()?,
        v.get("message")?.as_str()?,
    ))
}

/// The rates of an `omnikin.WheelRates` message.
pub fn decode_wheel_rates(v: &Value) -> Option<WheelRates> {
    let a = |k: &str| -> Option<Option<Vec<f64>>> {
        match v.get(k) {
            None => Some(None),
            Some(x) => Some(Some(
                x.as_array()?
                    .iter()
                    .map(Value::as_f64)
                    .collect::<Option<_>>()?,
            )),
        }
    };
    Some(WheelRates {
        commanded: a("commanded")?,
        commanded_steer: a("commanded_steer")?,
        measured: a("measured")?,
        measured_steer: a("measured_steer")?,
    })
}

/// The counters of an `omnikin.LinkCounters` message.
pub fn decode_link_counters(v: &Value) -> Option<Counters> {
    let mut out = [None; COUNTER_COUNT];
    for (o, k) in out.iter_mut().zip(Counters::NAMES) {
        if let Some(x) = v.get(k) {
            *o = Some(x.as_u64()?);
        }
    }
    Some(Counters::from_values(out))
}

/// The `{sec, nsec}` timestamp of a message, ns.
#[cfg(test)]
pub fn decode_timestamp(v: &Value) -> Option<u64> {
    let t = v.get("timestamp")?;
    let (s, n) = (t.get("sec")?.as_u64()?, t.get("nsec")?.as_u64()?);
    s.checked_mul(1_000_000_000)?.checked_add(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small JSON Schema check (object, array, number, integer, string; required; const of
    /// oneOf): enough to hold every encoder to the schema it is published under.
    fn conforms(v: &Value, s: &Value, at: &str) -> Result<(), String> {
        if let Some(alts) = s.get("oneOf").and_then(Value::as_array) {
            return alts
                .iter()
                .any(|a| a.get("const") == Some(v))
                .then_some(())
                .ok_or(format!("{at}: {v} is none of oneOf"));
        }
        match s.get("type").and_then(Value::as_str) {
            Some("object") => {
                let o = v.as_object().ok_or(format!("{at}: not an object"))?;
                for r in s
                    .get("required")
                    .and_then(Value::as_array)
                    .into_iter()
                    .flatten()
                {
                    let r = r.as_str().unwrap_or_default();
                    if !o.contains_key(r) {
                        return Err(format!("{at}: required {r} missing"));
                    }
                }
                let props = s.get("properties").and_then(Value::as_object);
                for (k, x) in o {
                    let p = props
                        .and_then(|p| p.get(k))
                        .ok_or(format!("{at}: {k} is not in the schema"))?;
                    conforms(x, p, &format!("{at}.{k}"))?;
                }
                Ok(())
            }
            Some("array") => {
                let a = v.as_array().ok_or(format!("{at}: not an array"))?;
                a.iter()
                    .try_for_each(|x| conforms(x, &s["items"], &format!("{at}[]")))
            }
            Some("number") => v.as_f64().map(|_| ()).ok_or(format!("{at}: not a number")),
            Some("integer") => {
                let n = v.as_u64().ok_or(format!("{at}: not a whole number"))?;
                let max = s.get("maximum").and_then(Value::as_u64).unwrap_or(u64::MAX);
                (n <= max).then_some(()).ok_or(format!("{at}: {n} > {max}"))
            }
            Some("string") => v.as_str().map(|_| ()).ok_or(format!("{at}: not a string")),
            t => Err(format!("{at}: schema type {t:?}")),
        }
    }

    fn check(schema: &Schema, v: &Value) {
        let s: Value = serde_json::from_str(schema.text()).expect("schema is JSON");
        assert_eq!(s["title"], schema.name);
        conforms(v, &s, schema.name).unwrap_or_else(|e| panic!("{e}: {v}"));
    }

    #[test]
    fn the_link_counters_schema_is_derived_from_the_telemetry_schema() {
        // The text the logs carried when it was written by hand: a file written today is
        // read by the same readers.
        let before = concat!(
            r#"{"title":"omnikin.LinkCounters","description":"Link receive counters (frames since start) and commands rejected by the runtime","type":"object","properties":{"timestamp":"#,
            time!(),
            r#","ok":{"type":"integer","minimum":0},"framing":{"type":"integer","minimum":0},"crc":{"type":"integer","minimum":0},"version":{"type":"integer","minimum":0},"auth":{"type":"integer","minimum":0},"replay":{"type":"integer","minimum":0},"malformed":{"type":"integer","minimum":0},"session":{"type":"integer","minimum":0},"entropy":{"type":"integer","minimum":0},"dropped":{"type":"integer","minimum":0},"rejected":{"type":"integer","minimum":0}},"required":["timestamp"]}"#
        );
        assert_eq!(LINK_COUNTERS.text(), before);
        // Every receive counter of the telemetry schema, by name, is a property.
        let s: Value = serde_json::from_str(LINK_COUNTERS.text()).unwrap();
        for c in &telemetry_schema::LINK_COUNTERS {
            assert_eq!(s["properties"][c.name]["type"], "integer", "{}", c.name);
        }
        // The `/link` CSV columns `convert` writes are the telemetry log's own.
        let log = telemetry_schema::csv_header(3, false);
        for n in Counters::NAMES {
            if n != telemetry_schema::DROPPED {
                let col = if n == "rejected" {
                    n.to_string()
                } else {
                    format!("rx_{n}")
                };
                assert!(log.split(',').any(|c| c == col), "{col}");
            }
        }
    }

    #[test]
    fn every_encoder_fits_its_schema_and_decodes_back() {
        let ns = 12_345_678_901;
        let p = Pose2::new(1.5, -0.25, 2.0);
        let near = |a: Pose2<f64>, b: Pose2<f64>| {
            assert!(
                (a.x - b.x).abs() < 1e-12 && (a.y - b.y).abs() < 1e-12,
                "{a:?} {b:?}"
            );
            let d = (a.heading - b.heading).rem_euclid(std::f64::consts::TAU);
            assert!(d.min(std::f64::consts::TAU - d) < 1e-12, "{a:?} {b:?}");
        };
        let v = pose_in_frame(ns, p);
        check(&POSE_IN_FRAME, &v);
        near(decode_pose_in_frame(&v).unwrap(), p);
        assert_eq!(decode_timestamp(&v), Some(ns));
        let v = frame_transform(ns, p);
        check(&FRAME_TRANSFORM, &v);
        let (q, parent, child) = decode_frame_transform(&v).unwrap();
        near(q, p);
        assert_eq!((parent, child), (WORLD, BASE));
        let path = [p, Pose2::new(0.0, 0.0, -3.0), Pose2::new(2.0, 1.0, 7.0)];
        let v = poses_in_frame(ns, &path);
        check(&POSES_IN_FRAME, &v);
        for (a, b) in decode_poses_in_frame(&v).unwrap().into_iter().zip(path) {
            near(a, b);
        }
        let v = log(ns, Level::Error, "omnikin robot", "e-stop");
        check(&LOG, &v);
        assert_eq!(decode_log(&v), Some((4, "omnikin robot", "e-stop")));
        let w = WheelRates {
            commanded: Some(vec![1.0, -2.0, 3.5]),
            commanded_steer: None,
            measured: Some(vec![0.5, 0.25, 0.0]),
            measured_steer: Some(vec![0.0; 3]),
        };
        let v = wheel_rates(ns, &w);
        check(&WHEEL_RATES, &v);
        assert_eq!(decode_wheel_rates(&v), Some(w));
        let c = Counters::from_link(
            &LinkCounters {
                ok: 7,
                crc: 2,
                auth: 1,
                ..Default::default()
            },
            3,
        );
        let v = link_counters(ns, &c);
        check(&LINK_COUNTERS, &v);
        assert_eq!(decode_link_counters(&v), Some(c));
        assert_eq!(c.get("dropped"), Some(3));
    }

    #[test]
    fn times_and_topics() {
        assert_eq!(time_ns(1.5), Some(1_500_000_000));
        assert_eq!(time_ns(-1e-3), None);
        assert_eq!(time_ns(f64::NAN), None);
        assert_eq!(time_ns(1e300), None);
        assert_eq!(
            timestamp(1_500_000_001),
            json!({"sec": 1, "nsec": 500_000_001})
        );
        assert_eq!(topic("/pose"), Some(POSE));
        assert_eq!(topic("/trial-003/wheels"), Some(WHEELS));
        assert_eq!(topic("/other"), None);
        assert_eq!(topic("/trial-3"), None);
        // The time sub-schema is the same text in every schema.
        for t in TOPICS {
            assert!(t.schema.text().contains(TIME), "{}", t.schema.name);
        }
    }
}
