//! The telemetry schema: every field of a telemetry frame ([`Telemetry`]) that the host side
//! records or shows, named once with its unit, and the link's receive counters
//! ([`LINK_COUNTERS`]). Derived from it: the telemetry CSV log's header and rows
//! ([`csv_header`], [`csv_row`]: `drive --out`, the console's recording, Python's
//! `omnikin.Link`), the console's telemetry message ([`json_fields`]) and the MCAP
//! `omnikin.LinkCounters` schema, its protobuf descriptor and `convert`'s `/link` columns
//! ([`crate::mcap_log::foxglove::Counters`]).
//!
//! So a new telemetry field touches the message ([`Telemetry`]), the runtime that fills it and
//! one entry of [`FIELDS`] (or of [`LINK_COUNTERS`] for a new receive counter). What the MCAP
//! logs carry of the rest of a frame goes through Foxglove's own schemas (pose, transform,
//! wheel rates: [`crate::mcap_log::telemetry_sample`]), whose fields are fixed by Foxglove.

use omnikin::MAX_WHEELS;
use omnikin::link::{LinkCounters, Telemetry};
use serde_json::{Map, Value as Json};

/// One value of a telemetry frame, as the schema reads it.
#[derive(Clone, Debug, PartialEq)]
pub enum Value<'a> {
    /// A robot-clock time, µs (written in seconds: 6 decimals in the CSV).
    Micros(u64),
    /// A real number in the field's unit.
    Real(f32),
    /// Three real numbers (a pose `[x, y, heading]` or a twist `[vx, vy, yaw_rate]`).
    Triple([f32; 3]),
    /// One real number per wheel (module); the frame's wheel count says how many are used.
    PerWheel(&'a [f32; MAX_WHEELS]),
    /// A count or an id.
    Count(u64),
    /// A flag.
    Flag(bool),
    /// A name (a mode, a fault set).
    Text(String),
    /// The link's receive counters ([`LINK_COUNTERS`]).
    Counters(&'a LinkCounters),
}

/// How a field appears in the telemetry CSV log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CsvColumns {
    /// Not in the CSV log.
    None,
    /// One column.
    One(&'static str),
    /// Three columns (a [`Value::Triple`]).
    Three([&'static str; 3]),
    /// One column per wheel, `prefix1..prefixN` (a [`Value::PerWheel`]).
    PerWheel(&'static str),
    /// One column per steer motor, `prefix1..prefixN`, for kinds with steer motors only.
    PerSteer(&'static str),
    /// One column per [`LINK_COUNTERS`] entry, `prefix` + its name.
    Counters(&'static str),
}

/// Where a field appears in the console's telemetry message (a JSON object).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JsonKey {
    /// Not in the console's message.
    None,
    /// A key of the message.
    Key(&'static str),
    /// A key of the object under the first name (`plan.id`).
    In(&'static str, &'static str),
    /// The per-steer values under this key, `null` for kinds without steer motors.
    Steer(&'static str),
}

/// One field of the telemetry schema.
#[derive(Clone, Copy, Debug)]
pub struct Field {
    /// Its unit (`"s"`, `"m"`, `"rad/s"`, `""` for counts and names).
    pub unit: &'static str,
    /// What it is.
    pub doc: &'static str,
    /// Its CSV columns.
    pub csv: CsvColumns,
    /// Its key in the console's message.
    pub json: JsonKey,
    /// Reads it from a frame.
    pub value: for<'a> fn(&'a Telemetry) -> Value<'a>,
}

/// The telemetry fields, in the CSV log's column order (the conventions' pose CSV first, so a
/// telemetry log is a pose CSV and, with its `q` columns, an encoder log for
/// `omnikin odometry`).
pub const FIELDS: [Field; 24] = [
    Field {
        unit: "s",
        doc: "robot clock",
        csv: CsvColumns::One("t"),
        json: JsonKey::Key("t"),
        value: |t| Value::Micros(t.time_us),
    },
    Field {
        unit: "m, m, rad",
        doc: "the robot's estimated pose [x, y, heading], world frame",
        csv: CsvColumns::Three(["x", "y", "heading"]),
        json: JsonKey::Key("pose"),
        value: |t| Value::Triple(t.pose),
    },
    Field {
        unit: "m/s, m/s, rad/s",
        doc: "measured twist [vx, vy, yaw_rate] from the encoders, robot frame",
        csv: CsvColumns::Three(["vx", "vy", "yaw_rate"]),
        json: JsonKey::Key("twist"),
        value: |t| Value::Triple(t.twist),
    },
    Field {
        unit: "m/s, m/s, rad/s",
        doc: "commanded twist after the runtime's limits, robot frame",
        csv: CsvColumns::Three(["cmd_vx", "cmd_vy", "cmd_yaw_rate"]),
        json: JsonKey::Key("command"),
        value: |t| Value::Triple(t.command),
    },
    Field {
        unit: "rad/s",
        doc: "commanded wheel rates, the robot file's wheel order",
        csv: CsvColumns::PerWheel("w"),
        json: JsonKey::Key("wheel_cmd"),
        value: |t| Value::PerWheel(&t.wheel_rates),
    },
    Field {
        unit: "rad",
        doc: "encoder wheel angles",
        csv: CsvColumns::PerWheel("q"),
        json: JsonKey::None,
        value: |t| Value::PerWheel(&t.wheel_angles),
    },
    Field {
        unit: "rad",
        doc: "encoder steer angles (kinds with steer motors)",
        csv: CsvColumns::PerSteer("s"),
        json: JsonKey::Steer("steer_angles"),
        value: |t| Value::PerWheel(&t.steer_angles),
    },
    Field {
        unit: "rad/s",
        doc: "gyro rate about the vertical, robot frame (0 without an IMU)",
        csv: CsvColumns::One("gyro_z"),
        json: JsonKey::None,
        value: |t| Value::Real(t.gyro[2]),
    },
    Field {
        unit: "",
        doc: "the runtime's mode",
        csv: CsvColumns::One("mode"),
        json: JsonKey::Key("mode"),
        value: |t| Value::Text(t.mode.name().to_string()),
    },
    Field {
        unit: "",
        doc: "faults active in this cycle",
        csv: CsvColumns::One("faults"),
        json: JsonKey::Key("faults"),
        value: |t| Value::Text(t.faults.to_string()),
    },
    Field {
        unit: "",
        doc: "faults since the last clear",
        csv: CsvColumns::One("fault_history"),
        json: JsonKey::Key("fault_history"),
        value: |t| Value::Text(t.fault_history.to_string()),
    },
    Field {
        unit: "",
        doc: "the plan buffer's plan id",
        csv: CsvColumns::One("plan_id"),
        json: JsonKey::In("plan", "id"),
        value: |t| Value::Count(t.plan.id.into()),
    },
    Field {
        unit: "",
        doc: "plan points received",
        csv: CsvColumns::One("plan_received"),
        json: JsonKey::In("plan", "received"),
        value: |t| Value::Count(t.plan.received.into()),
    },
    Field {
        unit: "",
        doc: "plan points announced",
        csv: CsvColumns::One("plan_len"),
        json: JsonKey::In("plan", "len"),
        value: |t| Value::Count(t.plan.len.into()),
    },
    Field {
        unit: "s",
        doc: "plan time",
        csv: CsvColumns::One("plan_time"),
        json: JsonKey::Key("plan_time"),
        value: |t| Value::Real(t.plan_time),
    },
    Field {
        unit: "m, m, rad",
        doc: "the plan's reference pose at the plan time, world frame",
        csv: CsvColumns::Three(["ref_x", "ref_y", "ref_heading"]),
        json: JsonKey::Key("reference"),
        value: |t| Value::Triple(t.reference),
    },
    Field {
        unit: "",
        doc: "commands rejected by the runtime",
        csv: CsvColumns::One("rejected"),
        json: JsonKey::Key("rejected"),
        value: |t| Value::Count(t.rejected.into()),
    },
    Field {
        unit: "s",
        doc: "robot clock of the last valid command (0: none)",
        csv: CsvColumns::One("last_command_t"),
        json: JsonKey::None,
        value: |t| Value::Micros(t.last_command_us),
    },
    Field {
        unit: "frames",
        doc: "the robot's receive counters",
        csv: CsvColumns::Counters(RX_PREFIX),
        json: JsonKey::Key("robot_link"),
        value: |t| Value::Counters(&t.link),
    },
    Field {
        unit: "",
        doc: "true once the running plan reached its last point",
        csv: CsvColumns::None,
        json: JsonKey::In("plan", "done"),
        value: |t| Value::Flag(t.plan.done),
    },
    Field {
        unit: "m/s",
        doc: "least-squares slip residual of the odometry fit",
        csv: CsvColumns::None,
        json: JsonKey::Key("slip_residual"),
        value: |t| Value::Real(t.slip_residual),
    },
    Field {
        unit: "",
        doc: "the robot's wheel (module) count: the used length of the per-wheel fields",
        csv: CsvColumns::None,
        json: JsonKey::Key("wheels"),
        value: |t| Value::Count(usize::from(t.wheels).min(MAX_WHEELS) as u64),
    },
    Field {
        unit: "",
        doc: "sequence number of the newest command frame accepted in this session",
        csv: CsvColumns::None,
        json: JsonKey::Key("ack_seq"),
        value: |t| Value::Count(t.ack_seq),
    },
    Field {
        unit: "",
        doc: "sequence number of this session's e-stop while it is latched (0: none)",
        csv: CsvColumns::None,
        json: JsonKey::Key("estop_seq"),
        value: |t| Value::Count(t.estop_seq),
    },
];

/// One of the link's receive counters ([`LinkCounters`]), frames since start.
#[derive(Clone, Copy, Debug)]
pub struct Counter {
    /// Its name (the CSV's `rx_` + name, the console's and MCAP's `/link` key).
    pub name: &'static str,
    /// What it counts.
    pub doc: &'static str,
    /// Its field number in the MCAP `omnikin.LinkCounters` protobuf message: fixed for good
    /// once a log carries it (a new counter takes the next free number, from
    /// [`NEXT_FIELD_NUMBER`]; [`DROPPED_FIELD`] and [`REJECTED_FIELD`] are taken).
    pub field: u32,
    /// Reads it.
    pub value: fn(&LinkCounters) -> u32,
}

/// The receive counters the host side records and shows, in their column order. The core's
/// `throttled` (Hellos a host dropped unread over their sender's rate) and `stale` (commands
/// held back by an e-stop, also in `ok`) are not recorded (a test lists every field of
/// [`LinkCounters`], so a new one is a decision here).
pub const LINK_COUNTERS: [Counter; 9] = [
    Counter {
        name: "ok",
        field: 2,
        doc: "Frames accepted",
        value: |c| c.ok,
    },
    Counter {
        name: "framing",
        field: 3,
        doc: "Dropped: framing",
        value: |c| c.framing,
    },
    Counter {
        name: "crc",
        field: 4,
        doc: "Dropped: CRC",
        value: |c| c.crc,
    },
    Counter {
        name: "version",
        field: 5,
        doc: "Dropped: protocol version",
        value: |c| c.version,
    },
    Counter {
        name: "auth",
        field: 6,
        doc: "Dropped: authentication",
        value: |c| c.auth,
    },
    Counter {
        name: "replay",
        field: 7,
        doc: "Dropped: replay",
        value: |c| c.replay,
    },
    Counter {
        name: "malformed",
        field: 8,
        doc: "Dropped: malformed",
        value: |c| c.malformed,
    },
    Counter {
        name: "session",
        field: 9,
        doc: "Dropped: other session",
        value: |c| c.session,
    },
    Counter {
        name: "entropy",
        field: 10,
        doc: "Dropped: entropy failure",
        value: |c| c.entropy,
    },
];

/// The prefix of the receive counters' CSV columns (`rx_ok`, …).
pub const RX_PREFIX: &str = "rx_";

/// The name of the derived counter of every frame dropped ([`LinkCounters::dropped`]).
pub const DROPPED: &str = "dropped";
/// [`DROPPED`]'s field number in the MCAP `omnikin.LinkCounters` message.
pub const DROPPED_FIELD: u32 = 11;
/// The field number of the runtime's rejected commands in the MCAP `omnikin.LinkCounters`
/// message.
pub const REJECTED_FIELD: u32 = 12;
/// The field number the next receive counter added to [`LINK_COUNTERS`] takes.
pub const NEXT_FIELD_NUMBER: u32 = 13;

/// The CSV header of a robot of `wheels` wheels (`steer`: with steer motors), from [`FIELDS`].
pub fn csv_header(wheels: usize, steer: bool) -> String {
    let mut names: Vec<String> = Vec::new();
    for f in &FIELDS {
        match f.csv {
            CsvColumns::None => {}
            CsvColumns::One(n) => names.push(n.to_string()),
            CsvColumns::Three(n) => names.extend(n.iter().map(|s| s.to_string())),
            CsvColumns::PerWheel(p) => names.extend((1..=wheels).map(|i| format!("{p}{i}"))),
            CsvColumns::PerSteer(p) if steer => {
                names.extend((1..=wheels).map(|i| format!("{p}{i}")))
            }
            CsvColumns::PerSteer(_) => {}
            CsvColumns::Counters(p) => {
                names.extend(LINK_COUNTERS.iter().map(|c| format!("{p}{}", c.name)))
            }
        }
    }
    names.join(",")
}

/// One CSV row of `t` in the columns of [`csv_header`] (no line end).
pub fn csv_row(t: &Telemetry, wheels: usize, steer: bool) -> String {
    use std::fmt::Write;
    let mut r = String::new();
    let cell = |r: &mut String, s: std::fmt::Arguments| {
        if !r.is_empty() {
            r.push(',');
        }
        let _ = r.write_fmt(s);
    };
    for f in &FIELDS {
        if matches!(f.csv, CsvColumns::None) || (matches!(f.csv, CsvColumns::PerSteer(_)) && !steer)
        {
            continue;
        }
        match (f.value)(t) {
            Value::Micros(us) => cell(&mut r, format_args!("{:.6}", us as f64 * 1e-6)),
            Value::Real(x) => cell(&mut r, format_args!("{x}")),
            Value::Triple(v) => v.iter().for_each(|x| cell(&mut r, format_args!("{x}"))),
            Value::PerWheel(v) => v
                .iter()
                .take(wheels)
                .for_each(|x| cell(&mut r, format_args!("{x}"))),
            Value::Count(n) => cell(&mut r, format_args!("{n}")),
            Value::Flag(b) => cell(&mut r, format_args!("{b}")),
            Value::Text(s) => cell(&mut r, format_args!("{s}")),
            Value::Counters(c) => LINK_COUNTERS
                .iter()
                .for_each(|k| cell(&mut r, format_args!("{}", (k.value)(c)))),
        }
    }
    r
}

/// The receive counters as the console shows them: every [`LINK_COUNTERS`] entry by name and
/// [`DROPPED`].
pub fn counters_json(c: &LinkCounters) -> Json {
    let mut m = Map::new();
    m.insert(DROPPED.into(), Json::from(c.dropped()));
    for k in &LINK_COUNTERS {
        m.insert(k.name.into(), Json::from((k.value)(c)));
    }
    Json::Object(m)
}

/// The console's telemetry message's fields of `t` from [`FIELDS`] (`steer`: the robot has
/// steer motors); the console adds what it derives (measured rates, tracking error, the true
/// pose, its own counters).
pub fn json_fields(t: &Telemetry, steer: bool) -> Map<String, Json> {
    let n = usize::from(t.wheels).min(MAX_WHEELS);
    let mut m = Map::new();
    for f in &FIELDS {
        let (parent, key) = match f.json {
            JsonKey::None => continue,
            JsonKey::Key(k) | JsonKey::Steer(k) => (None, k),
            JsonKey::In(p, k) => (Some(p), k),
        };
        let v = match (f.value)(t) {
            Value::PerWheel(_) if matches!(f.json, JsonKey::Steer(_)) && !steer => Json::Null,
            Value::Micros(us) => Json::from(us as f64 * 1e-6),
            Value::Real(x) => Json::from(x),
            Value::Triple(v) => Json::from(v.to_vec()),
            Value::PerWheel(v) => Json::from(v[..n].to_vec()),
            Value::Count(c) => Json::from(c),
            Value::Flag(b) => Json::from(b),
            Value::Text(s) => Json::from(s),
            Value::Counters(c) => counters_json(c),
        };
        match parent {
            None => {
                m.insert(key.into(), v);
            }
            Some(p) => {
                if let Json::Object(o) = m.entry(p).or_insert_with(|| Json::Object(Map::new())) {
                    o.insert(key.into(), v);
                }
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use omnikin::runtime::{Faults, Mode};
    use std::collections::HashMap;

    /// A frame whose every field holds a value of its own.
    fn frame(wheels: u8) -> Telemetry {
        let z = [0.0f32; MAX_WHEELS];
        let mut t = Telemetry {
            time_us: 12_345_678,
            mode: Mode::Trajectory,
            faults: Faults::SLIP,
            fault_history: Faults::LINK_LOST,
            pose: [1.5, -2.25, 0.5],
            twist: [0.25, 0.125, -0.75],
            command: [0.3, 0.2, -0.7],
            wheels,
            wheel_rates: z,
            steer_rates: z,
            wheel_angles: z,
            steer_angles: z,
            gyro: [0.01, 0.02, 0.375],
            accel: [0.0; 3],
            plan: Default::default(),
            plan_time: 4.5,
            reference: [1.25, -2.0, 0.625],
            slip_residual: 0.0625,
            rejected: 7,
            last_command_us: 11_000_001,
            link: LinkCounters::default(),
            ack_seq: 42,
            estop_seq: 3,
            clear_seq: 0,
        };
        for i in 0..MAX_WHEELS {
            t.wheel_rates[i] = 10.0 + i as f32;
            t.wheel_angles[i] = 20.0 + i as f32;
            t.steer_angles[i] = 30.0 + i as f32;
        }
        t.plan.id = 9;
        t.plan.received = 120;
        t.plan.len = 130;
        t.plan.done = true;
        t.link.ok = 1000;
        t.link.crc = 4;
        t.link.replay = 2;
        t.link.entropy = 1;
        t
    }

    #[test]
    fn every_link_counter_is_recorded_or_left_out_by_name() {
        // No `..`: a field added to the core's counters fails to compile here until it is
        // put in LINK_COUNTERS or named as left out.
        let LinkCounters {
            ok: _,
            framing: _,
            crc: _,
            version: _,
            auth: _,
            replay: _,
            malformed: _,
            session: _,
            entropy: _,
            throttled: _,
            stale: _,
        } = LinkCounters::default();
        let recorded: Vec<&str> = LINK_COUNTERS.iter().map(|c| c.name).collect();
        assert_eq!(
            recorded,
            [
                "ok",
                "framing",
                "crc",
                "version",
                "auth",
                "replay",
                "malformed",
                "session",
                "entropy"
            ]
        );
    }

    #[test]
    fn protobuf_field_numbers_are_fixed_and_unique() {
        // The numbers logs already carry: 2..=10 for the nine counters, 11 dropped, 12 rejected.
        let fields: Vec<u32> = LINK_COUNTERS.iter().map(|c| c.field).collect();
        assert_eq!(fields, (2..=10).collect::<Vec<u32>>());
        let mut all = fields.clone();
        all.extend([DROPPED_FIELD, REJECTED_FIELD]);
        let n = all.len();
        all.sort_unstable();
        all.dedup();
        assert_eq!(all.len(), n, "a field number used twice");
        assert!(all.iter().all(|f| (2..NEXT_FIELD_NUMBER).contains(f)));
    }

    #[test]
    fn the_csv_header_is_the_telemetry_logs() {
        // The file format the conventions and `omnikin odometry` read: pinned.
        assert_eq!(
            csv_header(3, false),
            "t,x,y,heading,vx,vy,yaw_rate,cmd_vx,cmd_vy,cmd_yaw_rate,w1,w2,w3,q1,q2,q3,gyro_z,\
             mode,faults,fault_history,plan_id,plan_received,plan_len,plan_time,ref_x,ref_y,\
             ref_heading,rejected,last_command_t,rx_ok,rx_framing,rx_crc,rx_version,rx_auth,\
             rx_replay,rx_malformed,rx_session,rx_entropy"
        );
        for (w, steer) in [(1, false), (3, false), (4, true), (MAX_WHEELS, true)] {
            let h = csv_header(w, steer);
            let names: Vec<&str> = h.split(',').collect();
            let unique: std::collections::HashSet<&&str> = names.iter().collect();
            assert_eq!(unique.len(), names.len(), "{h}");
            assert_eq!(
                names
                    .iter()
                    .filter(|n| n.starts_with('s') && n[1..].parse::<usize>().is_ok())
                    .count(),
                if steer { w } else { 0 }
            );
        }
    }

    #[test]
    fn a_row_reads_back_by_its_column_names() {
        for (w, steer) in [(3usize, false), (4, true)] {
            let t = frame(w as u8);
            let h = csv_header(w, steer);
            let r = csv_row(&t, w, steer);
            let names: Vec<&str> = h.split(',').collect();
            let cells: Vec<&str> = r.split(',').collect();
            assert_eq!(names.len(), cells.len(), "{h}\n{r}");
            let c: HashMap<&str, &str> = names.into_iter().zip(cells).collect();
            let num = |k: &str| c[k].parse::<f64>().unwrap();
            assert_eq!(num("t"), 12.345678);
            assert_eq!((num("x"), num("y"), num("heading")), (1.5, -2.25, 0.5));
            assert_eq!(c["cmd_yaw_rate"].parse::<f32>().unwrap(), -0.7f32);
            assert_eq!(num(&format!("w{w}")), 10.0 + (w - 1) as f64);
            assert_eq!(num("q1"), 20.0);
            assert_eq!(
                c.get("s2").map(|s| s.parse::<f64>().unwrap()),
                steer.then_some(31.0)
            );
            assert_eq!(num("gyro_z"), 0.375);
            assert_eq!((c["mode"], c["faults"]), ("trajectory", "slip"));
            assert_eq!(
                (num("plan_id"), num("plan_received"), num("plan_len")),
                (9.0, 120.0, 130.0)
            );
            assert_eq!(
                (num("plan_time"), num("ref_y"), num("rejected")),
                (4.5, -2.0, 7.0)
            );
            assert_eq!(num("last_command_t"), 11.000001);
            assert_eq!(
                (num("rx_ok"), num("rx_crc"), num("rx_replay")),
                (1000.0, 4.0, 2.0)
            );
            assert_eq!((num("rx_entropy"), num("rx_framing")), (1.0, 0.0));
        }
    }

    #[test]
    fn the_console_message_holds_what_the_schema_says() {
        let t = frame(3);
        let m = Json::Object(json_fields(&t, false));
        assert_eq!(m["t"], 12.345678);
        assert_eq!(m["pose"], serde_json::json!([1.5, -2.25, 0.5]));
        assert_eq!(m["wheel_cmd"], serde_json::json!([10.0, 11.0, 12.0]));
        assert_eq!(m["steer_angles"], Json::Null);
        assert_eq!(
            m["plan"],
            serde_json::json!({"id": 9, "received": 120, "len": 130, "done": true})
        );
        assert_eq!(
            (m["mode"].as_str(), m["rejected"].as_u64()),
            (Some("trajectory"), Some(7))
        );
        assert_eq!(
            (
                m["ack_seq"].as_u64(),
                m["estop_seq"].as_u64(),
                m["wheels"].as_u64()
            ),
            (Some(42), Some(3), Some(3))
        );
        assert_eq!(m["robot_link"]["crc"], 4);
        assert_eq!(m["robot_link"][DROPPED], u64::from(t.link.dropped()));
        assert_eq!(m["robot_link"][DROPPED], 7);
        // CSV-only fields stay out of the console's message.
        assert!(m.get("gyro_z").is_none() && m.get("q1").is_none());
        let s = Json::Object(json_fields(&frame(4), true));
        assert_eq!(
            s["steer_angles"],
            serde_json::json!([30.0, 31.0, 32.0, 33.0])
        );
    }
}
