//! The host-side parsers of user files, each through its public parsing function, with the
//! properties every one must keep: no panic, heap bounded by the input
//! ([`crate::alloc::text_budget`]), a result that satisfies the format's rules (checked again
//! here, independently), and an error that names the file and a line or a field.

use omnikin::description::RobotDescription;
use omnikin_plan::waypoints::Waypoints;
use omnikin_plan::{Plan, PlanError, PlanningError, RobotModel};
use omnikin_sim::profile::ProfileError;
use omnikin_sim::sensors::SensorProfile;
use omnikin_sim::table::NumericTable;
use omnikin_sim::track::Track;

use crate::alloc::{measure, text_budget, toml_budget};

/// The name the fuzzed text is parsed under (every error must start with it).
pub const FILE: &str = "fuzz-input";

fn bounded<R>(len: usize, f: impl FnOnce() -> R) -> R {
    within(text_budget(len), len, f)
}

/// [`bounded`] for TOML parsers ([`toml_budget`]).
fn bounded_toml<R>(len: usize, f: impl FnOnce() -> R) -> R {
    within(toml_budget(len), len, f)
}

fn within<R>(budget: usize, len: usize, f: impl FnOnce() -> R) -> R {
    let (r, usage) = measure(f);
    assert!(
        usage.peak <= budget,
        "{} bytes of input took {} bytes of heap (budget {})",
        len,
        usage.peak,
        budget
    );
    r
}

/// Lines an error may point at: every line of `text`, and the empty one after a final
/// `\n` (where "unexpected end of file" is).
fn line_count(text: &str) -> usize {
    1 + text.matches('\n').count()
}

/// Rules about the whole file, whose errors name no line.
const WHOLE_FILE: [&str; 2] = ["needs at least", "no samples after the header"];

fn whole_file(message: &str) -> bool {
    WHOLE_FILE.iter().any(|p| message.starts_with(p))
}

fn assert_names_file(msg: &str) {
    assert!(
        msg.starts_with(FILE),
        "error does not name the file: {msg:?}"
    );
}

/// `true` if `message` starts with TOML key paths and a colon (`wheel_motor.max_accel: …`,
/// `wheel_motor.steps_per_rev / microsteps: …`).
fn names_key(message: &str) -> bool {
    let Some((keys, _)) = message.split_once(": ") else {
        return false;
    };
    keys.split(" / ").all(|key| {
        key.split('.').all(|p| {
            // A list element is named by its index: `imu.gyro_bias[1]`.
            let p = match p.strip_suffix(']').and_then(|q| q.rsplit_once('[')) {
                Some((name, index))
                    if !index.is_empty() && index.bytes().all(|b| b.is_ascii_digit()) =>
                {
                    name
                }
                _ => p,
            };
            !p.is_empty() && p.bytes().all(|b| b.is_ascii_lowercase() || b == b'_')
        })
    })
}

/// Robot description TOML: [`RobotDescription::from_toml_str`], then what the CLI and the
/// planner do with a valid one (build in `f64` and `f32`, [`RobotModel::from_description`]).
pub fn robot_toml(data: &[u8]) {
    // Files are read with `read_to_string`: non-UTF-8 is an I/O error naming the file.
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let r = bounded_toml(text.len(), || RobotDescription::from_toml_str(text, FILE));
    match r {
        Ok(d) => {
            assert!(!d.name.is_empty());
            d.build::<f64>()
                .unwrap_or_else(|e| panic!("validated description does not build: {e}"));
            if let Err(e) = d.build::<f32>() {
                assert_names_file(&e.to_string());
            }
            match RobotModel::from_description(&d) {
                Ok(m) => assert_eq!(m.model.kind(), d.robot_kind()),
                Err(e) => assert!(!e.to_string().is_empty()),
            }
        }
        Err(e) => {
            let msg = e.to_string();
            assert_names_file(&msg);
            assert!(
                e.line.is_some_and(|l| l >= 1 && l <= line_count(text)) || !e.field.is_empty(),
                "error names neither a line nor a field: {msg:?}"
            );
            assert!(!e.rule.is_empty(), "error states no rule: {msg:?}");
        }
    }
}

fn check_profile_error(e: &ProfileError, text: &str) {
    let msg = e.to_string();
    assert_names_file(&msg);
    assert!(
        e.line.is_some_and(|l| l >= 1 && l <= line_count(text)) || names_key(&e.message),
        "error names neither a line nor a key: {msg:?}"
    );
}

/// Disturbance profile ([`omnikin_sim::Profile::from_toml_str`]) and sensor profile
/// ([`SensorProfile::from_toml_str`]) TOML, the same text through both.
pub fn profile_toml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match bounded_toml(text.len(), || {
        omnikin_sim::Profile::from_toml_str(text, FILE)
    }) {
        Ok(p) => {
            p.validate()
                .unwrap_or_else(|e| panic!("accepted profile fails validate: {e}"));
            assert!(p.rate_hz().is_finite() && p.rate_hz() > 0.0);
        }
        Err(e) => check_profile_error(&e, text),
    }
    match bounded_toml(text.len(), || SensorProfile::from_toml_str(text, FILE)) {
        Ok(_) => {}
        Err(e) => check_profile_error(&e, text),
    }
}

fn check_waypoints(r: Result<Waypoints, PlanningError>, text: &str) {
    match r {
        Ok(w) => {
            let n = w.points.len();
            assert!(n >= 2, "fewer than 2 waypoints accepted");
            assert_eq!(w.lines.len(), n);
            assert!(
                w.lines.windows(2).all(|l| l[0] < l[1]),
                "lines {:?}",
                w.lines
            );
            assert!(w.lines.iter().all(|&l| l >= 1 && l <= line_count(text)));
            if let Some(h) = &w.headings {
                assert_eq!(h.len(), n);
                assert!(h.iter().all(|x| x.is_finite()));
            }
            assert!(w.points.iter().flatten().all(|x| x.is_finite()));
            for p in w.points.windows(2) {
                let d = (p[1][0] - p[0][0]).hypot(p[1][1] - p[0][1]);
                assert!(d > 1e-9, "repeated waypoint accepted: {p:?}");
            }
        }
        Err(PlanningError::Waypoints {
            file,
            line,
            message,
        }) => {
            assert_eq!(file, FILE);
            assert!(
                line.is_some_and(|l| l >= 1 && l <= line_count(text)) || whole_file(&message),
                "error names no line: {message:?} (line {line:?})"
            );
        }
        Err(e) => panic!("waypoint parser returned another error kind: {e}"),
    }
}

/// Waypoint files: [`Waypoints::from_csv`] and [`Waypoints::from_toml`], the same text
/// through both.
pub fn waypoints(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    check_waypoints(
        bounded(text.len(), || Waypoints::from_csv(text, FILE)),
        text,
    );
    check_waypoints(
        bounded_toml(text.len(), || Waypoints::from_toml(text, FILE)),
        text,
    );
}

fn increasing(t: impl Iterator<Item = f64>) -> bool {
    let mut prev = f64::NEG_INFINITY;
    for x in t {
        if !(x.is_finite() && x > prev) {
            return false;
        }
        prev = x;
    }
    true
}

/// CSV tables: plan ([`Plan::read_csv`]), tracked run ([`Track::read_csv`]) and encoder log /
/// camera fixes ([`NumericTable::parse`]), the same bytes through all three.
pub fn csv_tables(data: &[u8]) {
    // Plan and track read bytes (the csv crate reports bad UTF-8 with its line).
    match bounded(data.len(), || Plan::read_csv(data, FILE)) {
        Ok(plan) => {
            assert!(increasing(plan.samples.iter().map(|s| s.t)));
            for s in &plan.samples {
                let p = s.pose;
                let v = s.twist;
                let mut all = vec![p.x, p.y, p.heading, v.vx, v.vy, v.yaw_rate];
                all.extend(s.wheel_rates);
                if let Some((g, gd)) = s.steer {
                    all.extend(g);
                    all.extend(gd);
                }
                assert!(all.iter().all(|x| x.is_finite()), "non-finite sample {s:?}");
            }
            // What is read is what is written: write_csv∘read_csv is the identity.
            let mut out = Vec::new();
            plan.write_csv(&mut out).expect("writes to memory");
            let again = Plan::read_csv(out.as_slice(), FILE).expect("a written plan reads back");
            assert_eq!(again, plan, "plan CSV round trip");
        }
        Err(PlanError::Format {
            file,
            line,
            message,
        }) => {
            assert_eq!(file, FILE);
            assert!(
                line.is_some_and(|l| l >= 1) || whole_file(&message),
                "error names no line: {message:?}"
            );
        }
        Err(e @ PlanError::Io { .. }) => panic!("I/O error reading memory: {e}"),
    }
    match bounded(data.len(), || Track::read_csv(data, FILE)) {
        Ok(track) => {
            let n = track.t.len();
            assert_eq!(track.xy.len(), n);
            assert!(increasing(track.t.iter().copied()));
            assert!(track.xy.iter().flatten().all(|x| x.is_finite()));
            if let Some(h) = &track.heading {
                assert_eq!(h.len(), n);
                assert!(h.iter().all(|x| x.is_finite()));
            }
        }
        Err(e) => {
            assert_eq!(e.file, FILE);
            assert!(
                e.line.is_some_and(|l| l >= 1) || whole_file(&e.message),
                "error names no line: {e}"
            );
        }
    }
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match bounded(text.len(), || NumericTable::parse(text, FILE)) {
        Ok(t) => {
            let w = t.header.len();
            assert!(t.rows.iter().all(|(_, v)| v.len() == w));
            assert!(t.rows.iter().flat_map(|(_, v)| v).all(|x| x.is_finite()));
            let it = t.col("t").expect("accepted table has a t column");
            assert!(increasing(t.rows.iter().map(|(_, v)| v[it])));
            assert!(t.rows.windows(2).all(|r| r[0].0 < r[1].0));
            assert!(
                t.rows
                    .iter()
                    .all(|(l, _)| *l >= 2 && *l <= line_count(text))
            );
        }
        Err(e) => {
            assert_eq!(e.file, FILE);
            assert!(
                e.line >= 1 && e.line <= line_count(text),
                "line {} of {}",
                e.line,
                line_count(text)
            );
        }
    }
}
