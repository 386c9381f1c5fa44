//! The protobuf wire form of the log messages (MCAP `message_encoding` [`MESSAGE_ENCODING`],
//! schema `encoding` [`SCHEMA_ENCODING`]): what every MCAP file omnikin writes holds, about
//! half the size of the JSON form after compression.
//!
//! The messages are built as JSON values ([`super::foxglove`], also what the live Foxglove
//! server publishes); [`encode`] writes one as protobuf and [`to_json`] reads it back into the
//! same JSON, so `omnikin convert` has one decoder for both encodings.
//!
//! Foxglove's schemas are the Foxglove SDK's (the `foxglove` crate): its prost types and the
//! serialized `FileDescriptorSet` that Foxglove and the Python `mcap-protobuf-support` reader
//! need. omnikin's own messages are declared here, in package `omnikin`:
//!
//! ```proto
//! syntax = "proto3";
//! package omnikin;
//! import "google/protobuf/timestamp.proto";
//! // Commanded and measured wheel and steer rates, rad/s, in the robot file's wheel order;
//! // a list the source does not know is empty (a robot has at least one wheel).
//! message WheelRates {
//!   google.protobuf.Timestamp timestamp = 1;
//!   repeated float commanded = 2;
//!   repeated float commanded_steer = 3;
//!   repeated float measured = 4;
//!   repeated float measured_steer = 5;
//! }
//! // Link receive counters (frames since start) and commands rejected by the runtime; a
//! // counter the source does not know is absent. The fields are the telemetry schema's
//! // counters (crate::telemetry_schema), each with its fixed number: today
//! message LinkCounters {
//!   google.protobuf.Timestamp timestamp = 1;
//!   optional uint64 ok = 2;        optional uint64 framing = 3;  optional uint64 crc = 4;
//!   optional uint64 version = 5;   optional uint64 auth = 6;     optional uint64 replay = 7;
//!   optional uint64 malformed = 8; optional uint64 session = 9;  optional uint64 entropy = 10;
//!   optional uint64 dropped = 11;  optional uint64 rejected = 12;
//! }
//! ```
//!
//! Wheel rates are `float`: the link carries them as f32 (docs/wire-format.md), and 7
//! significant digits are far below any encoder's resolution; [`to_json`] gives each back as
//! the shortest decimal that reads as the same f32 (`0.1`, not `0.10000000149011612`). Poses
//! stay `double` (Foxglove's `Vector3`/`Quaternion`).
//!
//! Decoding is bounded: prost reads from the message's bytes only (no length it has not
//! checked against them, nesting at most 100 deep), so a message costs at most its own size.

use std::sync::LazyLock;

use foxglove::Encode;
use foxglove::messages as fm;
use prost::Message;
use prost_types::field_descriptor_proto::{Label, Type};
use prost_types::{
    DescriptorProto, FieldDescriptorProto, FileDescriptorProto, FileDescriptorSet,
    OneofDescriptorProto,
};
use serde_json::{Value, json};

use super::foxglove::{Counters, Topic};

/// MCAP `message_encoding` of the protobuf channels.
pub const MESSAGE_ENCODING: &str = "protobuf";
/// MCAP schema `encoding` of the protobuf schemas (the data is a `FileDescriptorSet`).
pub const SCHEMA_ENCODING: &str = "protobuf";

/// How a log's messages are encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// JSON with JSON Schemas ([`super::foxglove`]).
    Json,
    /// Protobuf with `FileDescriptorSet` schemas (this module).
    Protobuf,
}

impl Encoding {
    /// The encoding of a channel with MCAP `message_encoding` `m` and schema `encoding` `s`, if
    /// it is one of ours.
    pub fn of(m: &str, s: &str) -> Option<Self> {
        match (m, s) {
            (super::foxglove::MESSAGE_ENCODING, super::foxglove::SCHEMA_ENCODING) => {
                Some(Self::Json)
            }
            (MESSAGE_ENCODING, SCHEMA_ENCODING) => Some(Self::Protobuf),
            _ => None,
        }
    }

    /// MCAP `message_encoding` of the channels.
    pub fn message_encoding(self) -> &'static str {
        match self {
            Self::Json => super::foxglove::MESSAGE_ENCODING,
            Self::Protobuf => MESSAGE_ENCODING,
        }
    }

    /// MCAP schema `encoding` of the schemas.
    pub fn schema_encoding(self) -> &'static str {
        match self {
            Self::Json => super::foxglove::SCHEMA_ENCODING,
            Self::Protobuf => SCHEMA_ENCODING,
        }
    }

    /// The schema data of `topic`'s schema in this encoding.
    pub fn schema_data(self, topic: Topic) -> &'static [u8] {
        match self {
            Self::Json => topic.schema.text().as_bytes(),
            Self::Protobuf => schema(topic.schema.name),
        }
    }

    /// The message bytes of `v` (a message of `topic`'s schema) in this encoding.
    pub fn encode(self, topic: Topic, v: &Value) -> Result<Vec<u8>, String> {
        match self {
            Self::Json => serde_json::to_vec(v).map_err(|e| e.to_string()),
            Self::Protobuf => encode(topic, v),
        }
    }

    /// The JSON message of `data` (a message of `topic`'s schema in this encoding), or why it
    /// is not one.
    pub fn decode(self, topic: Topic, data: &[u8]) -> Result<Value, String> {
        match self {
            Self::Json => serde_json::from_slice(data).map_err(|e| format!("not JSON: {e}")),
            Self::Protobuf => to_json(topic, data),
        }
    }
}

/// omnikin's `WheelRates` (see the module docs).
#[derive(Clone, PartialEq, Message)]
pub struct WheelRates {
    /// Sample time.
    #[prost(message, optional, tag = "1")]
    pub timestamp: Option<fm::Timestamp>,
    /// Commanded wheel rates, rad/s.
    #[prost(float, repeated, tag = "2")]
    pub commanded: Vec<f32>,
    /// Commanded steer rates, rad/s.
    #[prost(float, repeated, tag = "3")]
    pub commanded_steer: Vec<f32>,
    /// Measured wheel rates, rad/s.
    #[prost(float, repeated, tag = "4")]
    pub measured: Vec<f32>,
    /// Measured steer rates, rad/s.
    #[prost(float, repeated, tag = "5")]
    pub measured_steer: Vec<f32>,
}

/// omnikin's `LinkCounters`: the timestamp (field 1) and the counters of [`Counters::NAMES`] as
/// `optional uint64` fields numbered by [`Counters::FIELDS`] — names and numbers come from
/// [`crate::telemetry_schema`], so this message (its encoder, decoder and descriptor,
/// [`link_counters_descriptor`]) follows a counter added there.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LinkCounters {
    /// Sample time.
    pub timestamp: Option<fm::Timestamp>,
    /// The counters; `None`: unknown (absent on the wire).
    pub counters: Counters,
}

/// The field number of the `i`-th counter of [`Counters::NAMES`] ([`Counters::FIELDS`]: fixed
/// per counter, so a counter added to the schema leaves the others' numbers as old logs carry
/// them).
fn counter_field(i: usize) -> u32 {
    Counters::FIELDS[i]
}

impl Message for LinkCounters {
    fn encode_raw(&self, buf: &mut impl prost::bytes::BufMut) {
        if let Some(t) = &self.timestamp {
            prost::encoding::message::encode(1, t, buf);
        }
        for (i, v) in self.counters.0.iter().enumerate() {
            if let Some(v) = v {
                prost::encoding::uint64::encode(counter_field(i), v, buf);
            }
        }
    }

    fn merge_field(
        &mut self,
        tag: u32,
        wire_type: prost::encoding::WireType,
        buf: &mut impl prost::bytes::Buf,
        ctx: prost::encoding::DecodeContext,
    ) -> Result<(), prost::DecodeError> {
        let counter = Counters::FIELDS.iter().position(|&f| f == tag);
        match (tag, counter) {
            (1, _) => prost::encoding::message::merge(
                wire_type,
                self.timestamp.get_or_insert_with(Default::default),
                buf,
                ctx,
            ),
            (_, Some(i)) => prost::encoding::uint64::merge(
                wire_type,
                self.counters.0[i].get_or_insert(0),
                buf,
                ctx,
            ),
            _ => prost::encoding::skip_field(wire_type, tag, buf, ctx),
        }
    }

    fn encoded_len(&self) -> usize {
        let t = self
            .timestamp
            .as_ref()
            .map_or(0, |t| prost::encoding::message::encoded_len(1, t));
        let c: usize = self
            .counters
            .0
            .iter()
            .enumerate()
            .filter_map(|(i, v)| {
                v.map(|v| prost::encoding::uint64::encoded_len(counter_field(i), &v))
            })
            .sum();
        t + c
    }

    fn clear(&mut self) {
        *self = Self::default();
    }
}

/// The file that declares `google.protobuf.Timestamp`.
const TIMESTAMP_FILE: &str = "google/protobuf/timestamp.proto";
/// The package of omnikin's own messages.
const PACKAGE: &str = "omnikin";

fn scalar(name: &str, number: i32, ty: Type, label: Label) -> FieldDescriptorProto {
    FieldDescriptorProto {
        name: Some(name.to_string()),
        number: Some(number),
        label: Some(label as i32),
        r#type: Some(ty as i32),
        ..Default::default()
    }
}

fn timestamp_field() -> FieldDescriptorProto {
    FieldDescriptorProto {
        type_name: Some(".google.protobuf.Timestamp".to_string()),
        ..scalar("timestamp", 1, Type::Message, Label::Optional)
    }
}

/// The descriptor of omnikin's `WheelRates`, as protoc writes it for the module docs' text.
fn wheel_rates_descriptor() -> DescriptorProto {
    let mut field = vec![timestamp_field()];
    for (i, name) in ["commanded", "commanded_steer", "measured", "measured_steer"]
        .into_iter()
        .enumerate()
    {
        field.push(scalar(name, i as i32 + 2, Type::Float, Label::Repeated));
    }
    DescriptorProto {
        name: Some("WheelRates".to_string()),
        field,
        ..Default::default()
    }
}

/// The descriptor of omnikin's `LinkCounters`: proto3 `optional` fields, each in its synthetic
/// oneof `_NAME` (as protoc writes them).
fn link_counters_descriptor() -> DescriptorProto {
    let mut field = vec![timestamp_field()];
    let mut oneof_decl = Vec::new();
    for (i, name) in Counters::NAMES.into_iter().enumerate() {
        field.push(FieldDescriptorProto {
            oneof_index: Some(i as i32),
            proto3_optional: Some(true),
            ..scalar(name, i as i32 + 2, Type::Uint64, Label::Optional)
        });
        oneof_decl.push(OneofDescriptorProto {
            name: Some(format!("_{name}")),
            ..Default::default()
        });
    }
    DescriptorProto {
        name: Some("LinkCounters".to_string()),
        field,
        oneof_decl,
        ..Default::default()
    }
}

/// The serialized `FileDescriptorSet` of one of omnikin's messages: `google/protobuf/
/// timestamp.proto` (the copy in the SDK's schemas) and `omnikin/NAME.proto` with the message.
fn own_schema(message: DescriptorProto) -> Vec<u8> {
    // The SDK's schemas carry the file their timestamps are declared in.
    let timestamp = FileDescriptorSet::decode(sdk_schema::<fm::PoseInFrame>())
        .ok()
        .and_then(|s| s.file.into_iter().find(|f| f.name() == TIMESTAMP_FILE))
        .unwrap_or_default();
    let ours = FileDescriptorProto {
        name: Some(format!("{PACKAGE}/{}.proto", message.name())),
        package: Some(PACKAGE.to_string()),
        dependency: vec![timestamp.name().to_string()],
        message_type: vec![message],
        syntax: Some("proto3".to_string()),
        ..Default::default()
    };
    FileDescriptorSet {
        file: vec![timestamp, ours],
    }
    .encode_to_vec()
}

static WHEEL_RATES_SCHEMA: LazyLock<Vec<u8>> =
    LazyLock::new(|| own_schema(wheel_rates_descriptor()));
static LINK_COUNTERS_SCHEMA: LazyLock<Vec<u8>> =
    LazyLock::new(|| own_schema(link_counters_descriptor()));

fn sdk_schema<T: Encode>() -> &'static [u8] {
    match T::get_schema().map(|s| s.data) {
        Some(std::borrow::Cow::Borrowed(b)) => b,
        // The SDK's well-known schemas are static descriptor sets.
        _ => &[],
    }
}

/// The schema data (a serialized `FileDescriptorSet`) of the schema named `name` (one of the
/// [`super::foxglove::TOPICS`]' schemas; the schema names are the protobuf message names).
pub fn schema(name: &str) -> &'static [u8] {
    match name {
        "foxglove.PoseInFrame" => sdk_schema::<fm::PoseInFrame>(),
        "foxglove.PosesInFrame" => sdk_schema::<fm::PosesInFrame>(),
        "foxglove.FrameTransform" => sdk_schema::<fm::FrameTransform>(),
        "foxglove.Log" => sdk_schema::<fm::Log>(),
        "omnikin.WheelRates" => &WHEEL_RATES_SCHEMA,
        "omnikin.LinkCounters" => &LINK_COUNTERS_SCHEMA,
        _ => &[],
    }
}

// ---------------------------------------------------------------------------------------------
// JSON message -> protobuf.

fn num(v: &Value, k: &str) -> f64 {
    v.get(k).and_then(Value::as_f64).unwrap_or(0.0)
}

fn text(v: &Value, k: &str) -> String {
    v.get(k).and_then(Value::as_str).unwrap_or("").to_string()
}

/// The `timestamp` of a JSON message (`{sec, nsec}`); seconds beyond 2³² (136 years) do not
/// fit protobuf's `Timestamp` as Foxglove declares it.
fn timestamp(v: &Value) -> Result<Option<fm::Timestamp>, String> {
    let Some(t) = v.get("timestamp") else {
        return Ok(None);
    };
    let sec = t.get("sec").and_then(Value::as_u64).unwrap_or(0);
    let nsec = t.get("nsec").and_then(Value::as_u64).unwrap_or(0);
    let sec = u32::try_from(sec).map_err(|_| format!("timestamp {sec} s is beyond 2³² s"))?;
    let nsec = u32::try_from(nsec).map_err(|_| format!("timestamp nsec {nsec} is not < 10⁹"))?;
    fm::Timestamp::new_checked(sec, nsec)
        .map(Some)
        .ok_or_else(|| format!("timestamp {sec} s {nsec} ns is beyond 2³² s"))
}

fn vector3(v: &Value) -> fm::Vector3 {
    fm::Vector3 {
        x: num(v, "x"),
        y: num(v, "y"),
        z: num(v, "z"),
    }
}

fn quaternion(v: &Value) -> fm::Quaternion {
    fm::Quaternion {
        x: num(v, "x"),
        y: num(v, "y"),
        z: num(v, "z"),
        w: num(v, "w"),
    }
}

fn pose(v: &Value) -> fm::Pose {
    fm::Pose {
        position: v.get("position").map(vector3),
        orientation: v.get("orientation").map(quaternion),
    }
}

fn floats(v: &Value, k: &str) -> Vec<f32> {
    v.get(k)
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .filter_map(Value::as_f64)
                .map(|x| x as f32)
                .collect()
        })
        .unwrap_or_default()
}

/// The protobuf bytes of the JSON message `v` of `topic`'s schema (built by
/// [`super::foxglove`]'s encoders), or why it cannot be written.
pub fn encode(topic: Topic, v: &Value) -> Result<Vec<u8>, String> {
    let timestamp = timestamp(v)?;
    Ok(match topic.schema.name {
        "foxglove.PoseInFrame" => fm::PoseInFrame {
            timestamp,
            frame_id: text(v, "frame_id"),
            pose: v.get("pose").map(pose),
        }
        .encode_to_vec(),
        "foxglove.PosesInFrame" => fm::PosesInFrame {
            timestamp,
            frame_id: text(v, "frame_id"),
            poses: v
                .get("poses")
                .and_then(Value::as_array)
                .map(|a| a.iter().map(pose).collect())
                .unwrap_or_default(),
        }
        .encode_to_vec(),
        "foxglove.FrameTransform" => fm::FrameTransform {
            timestamp,
            parent_frame_id: text(v, "parent_frame_id"),
            child_frame_id: text(v, "child_frame_id"),
            translation: v.get("translation").map(vector3),
            rotation: v.get("rotation").map(quaternion),
        }
        .encode_to_vec(),
        "foxglove.Log" => fm::Log {
            timestamp,
            level: v.get("level").and_then(Value::as_i64).unwrap_or(0) as i32,
            message: text(v, "message"),
            name: text(v, "name"),
            file: text(v, "file"),
            line: v.get("line").and_then(Value::as_u64).unwrap_or(0) as u32,
        }
        .encode_to_vec(),
        "omnikin.WheelRates" => WheelRates {
            timestamp,
            commanded: floats(v, "commanded"),
            commanded_steer: floats(v, "commanded_steer"),
            measured: floats(v, "measured"),
            measured_steer: floats(v, "measured_steer"),
        }
        .encode_to_vec(),
        "omnikin.LinkCounters" => LinkCounters {
            timestamp,
            counters: super::foxglove::decode_link_counters(v)
                .ok_or("a counter is not a whole number")?,
        }
        .encode_to_vec(),
        other => return Err(format!("no protobuf form for schema {other}")),
    })
}

// ---------------------------------------------------------------------------------------------
// protobuf -> JSON message.

fn json_timestamp(t: Option<fm::Timestamp>) -> Value {
    let t = t.unwrap_or(fm::Timestamp::MIN);
    json!({"sec": t.sec(), "nsec": t.nsec()})
}

fn json_vector3(v: &fm::Vector3) -> Value {
    json!({"x": v.x, "y": v.y, "z": v.z})
}

fn json_quaternion(q: &fm::Quaternion) -> Value {
    json!({"x": q.x, "y": q.y, "z": q.z, "w": q.w})
}

/// A pose; a missing position or orientation is a missing key (the decoders refuse it).
fn json_pose(p: &fm::Pose) -> Value {
    let mut v = json!({});
    if let Some(x) = &p.position {
        v["position"] = json_vector3(x);
    }
    if let Some(q) = &p.orientation {
        v["orientation"] = json_quaternion(q);
    }
    v
}

/// An f32 as the shortest decimal that reads back as it (Rust's `Display`), in f64.
fn widen(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(f64::from(x))
}

/// The JSON message (as [`super::foxglove`]'s encoders build it) of the protobuf message
/// `data` of `topic`'s schema, or why it is not one.
pub fn to_json(topic: Topic, data: &[u8]) -> Result<Value, String> {
    let bad = |e: prost::DecodeError| format!("not a protobuf {}: {e}", topic.schema.name);
    Ok(match topic.schema.name {
        "foxglove.PoseInFrame" => {
            let m = fm::PoseInFrame::decode(data).map_err(bad)?;
            let mut v = json!({"timestamp": json_timestamp(m.timestamp), "frame_id": m.frame_id});
            if let Some(p) = &m.pose {
                v["pose"] = json_pose(p);
            }
            v
        }
        "foxglove.PosesInFrame" => {
            let m = fm::PosesInFrame::decode(data).map_err(bad)?;
            let poses: Vec<Value> = m.poses.iter().map(json_pose).collect();
            json!({"timestamp": json_timestamp(m.timestamp), "frame_id": m.frame_id, "poses": poses})
        }
        "foxglove.FrameTransform" => {
            let m = fm::FrameTransform::decode(data).map_err(bad)?;
            let mut v = json!({
                "timestamp": json_timestamp(m.timestamp),
                "parent_frame_id": m.parent_frame_id,
                "child_frame_id": m.child_frame_id,
            });
            if let Some(t) = &m.translation {
                v["translation"] = json_vector3(t);
            }
            if let Some(q) = &m.rotation {
                v["rotation"] = json_quaternion(q);
            }
            v
        }
        "foxglove.Log" => {
            let m = fm::Log::decode(data).map_err(bad)?;
            let level = u8::try_from(m.level)
                .map_err(|_| format!("foxglove.Log level {} is not 0 to 5", m.level))?;
            json!({
                "timestamp": json_timestamp(m.timestamp), "level": level, "message": m.message,
                "name": m.name, "file": m.file, "line": m.line,
            })
        }
        "omnikin.WheelRates" => {
            let m = WheelRates::decode(data).map_err(bad)?;
            let mut v = json!({"timestamp": json_timestamp(m.timestamp)});
            for (k, a) in [
                ("commanded", &m.commanded),
                ("commanded_steer", &m.commanded_steer),
                ("measured", &m.measured),
                ("measured_steer", &m.measured_steer),
            ] {
                if !a.is_empty() {
                    v[k] = a.iter().map(|x| widen(*x)).collect();
                }
            }
            v
        }
        "omnikin.LinkCounters" => {
            let m = LinkCounters::decode(data).map_err(bad)?;
            let mut v = json!({"timestamp": json_timestamp(m.timestamp)});
            for (k, x) in Counters::NAMES.iter().zip(m.counters.values()) {
                if let Some(x) = x {
                    v[*k] = json!(x);
                }
            }
            v
        }
        other => return Err(format!("no protobuf form for schema {other}")),
    })
}

#[cfg(test)]
mod tests {
    use super::super::foxglove as fg;
    use super::*;
    use omnikin::Pose2;
    use omnikin::link::LinkCounters as Link;

    /// Every field a message's bytes carry (number, wire type), read with prost's own key
    /// decoder: what a reader that knows only the schema's descriptor would see.
    fn wire_fields(mut data: &[u8]) -> Vec<(u32, prost::encoding::WireType)> {
        let mut out = Vec::new();
        while !data.is_empty() {
            let (tag, wire) = prost::encoding::decode_key(&mut data).expect("a key");
            prost::encoding::skip_field(wire, tag, &mut data, Default::default()).expect("a field");
            out.push((tag, wire));
        }
        out
    }

    fn wire_type_of(t: Type) -> prost::encoding::WireType {
        use prost::encoding::WireType as W;
        match t {
            Type::Float => W::LengthDelimited, // repeated floats are packed
            Type::Uint64 => W::Varint,
            Type::Message => W::LengthDelimited,
            other => panic!("type {other:?} not used"),
        }
    }

    /// omnikin's descriptors say what the prost types write: every field of a fully set
    /// message is in the descriptor under its number, name order and wire type, and every
    /// descriptor field is written.
    #[test]
    fn own_descriptors_match_the_messages_they_describe() {
        let ns = 3_000_000_007;
        let w = fg::WheelRates {
            commanded: Some(vec![1.0, -2.0]),
            commanded_steer: Some(vec![0.5]),
            measured: Some(vec![0.25, 4.0]),
            measured_steer: Some(vec![-1.0]),
        };
        let c = fg::Counters::from_values([Some(1); fg::COUNTER_COUNT]);
        for (topic, v) in [
            (fg::WHEELS, fg::wheel_rates(ns, &w)),
            (fg::LINK, fg::link_counters(ns, &c)),
        ] {
            let set = FileDescriptorSet::decode(schema(topic.schema.name)).unwrap();
            let file = set.file.last().unwrap();
            let d = &file.message_type[0];
            assert_eq!(
                format!("{}.{}", file.package(), d.name()),
                topic.schema.name
            );
            assert_eq!(set.file[0].name(), TIMESTAMP_FILE);
            assert_eq!(set.file[0].message_type[0].name(), "Timestamp");
            assert_eq!(file.dependency, [TIMESTAMP_FILE.to_string()]);
            let got = wire_fields(&encode(topic, &v).unwrap());
            let want: Vec<_> = d
                .field
                .iter()
                .map(|f| (f.number() as u32, wire_type_of(f.r#type())))
                .collect();
            assert_eq!(got, want, "{}", topic.schema.name);
            // The names are the JSON keys.
            for f in &d.field {
                assert!(
                    v.get(f.name()).is_some(),
                    "{} {}",
                    topic.schema.name,
                    f.name()
                );
            }
        }
    }

    #[test]
    fn every_message_round_trips_through_protobuf() {
        let ns = 12_345_678_901;
        let p = Pose2::new(1.5, -0.25, 2.0);
        let w = fg::WheelRates {
            commanded: Some(vec![1.0, -2.0, 0.1]),
            commanded_steer: None,
            measured: Some(vec![0.5, 0.25, 1e-3]),
            measured_steer: None,
        };
        let c = fg::Counters::from_link(
            &Link {
                ok: 7,
                crc: 2,
                ..Default::default()
            },
            3,
        );
        let mut partial = fg::Counters::default();
        partial.0[0] = Some(0);
        let cases = [
            (fg::POSE, fg::pose_in_frame(ns, p)),
            (fg::TF, fg::frame_transform(ns, p)),
            (
                fg::PLAN,
                fg::poses_in_frame(ns, &[p, Pose2::new(0.0, 0.0, -3.0)]),
            ),
            (
                fg::EVENTS,
                fg::log(ns, fg::Level::Error, "omnikin robot", "e-stop"),
            ),
            (fg::WHEELS, fg::wheel_rates(ns, &w)),
            (fg::LINK, fg::link_counters(ns, &c)),
            // A counter at 0 is known (present), the others unknown (absent).
            (fg::LINK, fg::link_counters(ns, &partial)),
        ];
        for (topic, v) in cases {
            let bytes = Encoding::Protobuf.encode(topic, &v).unwrap();
            let json = Encoding::Json.encode(topic, &v).unwrap();
            assert!(bytes.len() < json.len(), "{}", topic.name);
            let back = Encoding::Protobuf.decode(topic, &bytes).unwrap();
            assert_eq!(back, v, "{}", topic.name);
            assert_eq!(fg::decode_timestamp(&back), Some(ns));
        }
    }

    #[test]
    fn damaged_messages_are_named_not_trusted() {
        let v = fg::pose_in_frame(5, Pose2::new(1.0, 2.0, 0.5));
        let bytes = encode(fg::POSE, &v).unwrap();
        // Cut short, a length past the end, a field of the wrong wire type.
        for bad in [
            &bytes[..bytes.len() - 3],
            &[0x1a, 0xff, 0xff, 0xff, 0x0f][..],
            &[0x12, 0x05, b'w'][..],
            &[0x0b][..],
        ] {
            let e = to_json(fg::POSE, bad).unwrap_err();
            assert!(e.contains("not a protobuf foxglove.PoseInFrame"), "{e}");
        }
        // A message without its pose decodes, and the pose decoder refuses it.
        let v = to_json(fg::POSE, &[]).unwrap();
        assert_eq!(fg::decode_pose_in_frame(&v), None);
        let e = to_json(fg::EVENTS, &[0x10, 0xff, 0xff, 0xff, 0xff, 0x0f]).unwrap_err();
        assert!(e.contains("level -1"), "{e}");
        // A time beyond the protobuf Timestamp's seconds is refused by name.
        let e = encode(fg::POSE, &fg::pose_in_frame(1 << 63, Pose2::default())).unwrap_err();
        assert!(e.contains("beyond 2³² s"), "{e}");
    }

    #[test]
    fn sdk_schemas_are_descriptor_sets_naming_the_message() {
        for t in fg::TOPICS {
            let set = FileDescriptorSet::decode(schema(t.schema.name)).unwrap();
            let found = set.file.iter().any(|f| {
                f.message_type
                    .iter()
                    .any(|m| format!("{}.{}", f.package(), m.name()) == t.schema.name)
            });
            assert!(found, "{}", t.schema.name);
        }
    }
}
