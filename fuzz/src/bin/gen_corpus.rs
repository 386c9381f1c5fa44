//! Writes the seed corpora, `corpus/<target>/seed-*` (or under the directory given as the
//! first argument), and checks that every seed is valid for its decoder and passes its
//! target's checks. Run by `fuzz/run.sh` before fuzzing; deterministic.
//!
//! Built with the fuzz targets (coverage-instrumented), hence linked with libFuzzer, whose
//! `main` this binary's own replaces.

use std::path::PathBuf;

use libfuzzer_sys as _;
use omnikin::link::{Key, MAX_FRAME, RobotEvent, RobotLink, parse_frame};
use omnikin::runtime::hal::{Entropy, EntropyError};
use omnikin_fuzz::alloc::Counting;
use omnikin_fuzz::link::{FUZZ_KEY, run_summary};
use omnikin_fuzz::{seeds, text};

#[global_allocator]
static ALLOC: Counting = Counting;

/// The raw target's entropy source.
struct Fixed;
impl Entropy for Fixed {
    fn fill(&mut self, buf: &mut [u8]) -> Result<(), EntropyError> {
        buf.fill(0x5a);
        Ok(())
    }
}

fn ok<T, E: std::fmt::Display>(r: Result<T, E>) -> Result<(), String> {
    r.map(|_| ()).map_err(|e| e.to_string())
}

/// Whether `seed` is a valid input of its decoder (not only "does not crash").
fn valid(target: &str, name: &str, data: &[u8]) -> Result<(), String> {
    let s = || String::from_utf8_lossy(data).into_owned();
    match target {
        "frame_decoder" => {
            // Every frame parses; the robot (entropy 0x5a, as in the target) takes all of
            // them but a HelloAck, which is for the operator.
            let keyed = name.contains("keyed");
            let key = keyed.then(|| Key::new(FUZZ_KEY).expect("key"));
            let mut robot = RobotLink::new(key);
            let info = omnikin_fuzz::link::raw_info();
            let mut reply = [0u8; MAX_FRAME];
            let mut busy = 0;
            // The target's clock: 1 ms per frame.
            for (i, frame) in (1u64..).zip(data.split(|&b| b == 0).filter(|f| !f.is_empty())) {
                ok(parse_frame(&mut frame.to_vec()))?;
                let r = robot.receive(
                    &mut frame.to_vec(),
                    i * 1_000,
                    &[],
                    &info,
                    &mut Fixed,
                    &mut reply,
                );
                busy += usize::from(matches!(r, Ok(RobotEvent::Busy(_))));
                // A robot → operator message (telemetry, session end, estimate, truth, busy;
                // the stream seed has them all) is dropped by the robot as malformed: a
                // reflected frame.
                let to_operator = [
                    "telemetry",
                    "session-end",
                    "stream",
                    "estimate",
                    "truth",
                    "busy-answer",
                ]
                .iter()
                .any(|m| name.contains(m));
                let reflected = to_operator
                    && r.as_ref()
                        .err()
                        .is_some_and(|e| e.to_string() == "malformed message");
                if !name.contains("hello-ack") && !reflected {
                    ok(r)?;
                }
            }
            if name.ends_with("-busy") && busy != 1 {
                return Err(format!("{busy} Busy answers, not 1"));
            }
            Ok(())
        }
        "link_session" => {
            let s = run_summary(data);
            let accepted = s.accepted;
            // A robot → operator message sent to the robot (a reflected frame) verifies under
            // the shared K_s but is dropped: only the handshake's open frame is taken.
            let reflected = [
                "-telemetry",
                "-session-end",
                "-estimate",
                "-truth",
                "-busy-answer",
            ]
            .iter()
            .any(|m| name.ends_with(m));
            let needed = if reflected { 1 } else { 2 };
            if !name.contains("-bad-") && accepted < needed {
                return Err(format!("only {accepted} frames accepted"));
            }
            // Each scenario reaches the path it is for.
            let c = s.counters;
            let reached = match name {
                // One Busy answer uses the handshake up: its next first frame is a replay.
                n if n.ends_with("-busy") => s.busy == 1 && c.replay == 1,
                n if n.ends_with("-takeover") => s.busy == 1 && c.replay == 2 && c.session == 1,
                n if n.ends_with("-replayed-open") => c.replay == 1,
                n if n.ends_with("-estop-held-back") => c.stale == 3,
                n if n.ends_with("-epochs") => c.session == 1 && accepted == 3,
                n if n.ends_with("-retire") => c.session == 1 && accepted == 9,
                n if n.ends_with("-bad-hello-throttled") => c.throttled == 1 && c.ok == 0,
                n if n.ends_with("-bad-open-flag") => c.malformed == 1,
                n if n.ends_with("-bad-open-epoch") || n.ends_with("-bad-open-nonce") => {
                    c.session == 1
                }
                _ => true,
            };
            if !reached {
                return Err(format!("did not reach its path: {s:?}"));
            }
            Ok(())
        }
        "robot_toml" => ok(omnikin::description::RobotDescription::from_toml_str(
            &s(),
            "seed",
        )),
        "profile_toml" => {
            let t = s();
            if !name.contains("sensors") {
                ok(omnikin_sim::Profile::from_toml_str(&t, "seed"))?;
            }
            if !name.contains("disturbance") {
                ok(omnikin_sim::sensors::SensorProfile::from_toml_str(
                    &t, "seed",
                ))?;
            }
            Ok(())
        }
        "waypoints" => {
            let t = s();
            let r = if name.contains("toml") {
                omnikin_plan::waypoints::Waypoints::from_toml(&t, "seed")
            } else {
                omnikin_plan::waypoints::Waypoints::from_csv(&t, "seed")
            };
            ok(r)
        }
        "csv_tables" => {
            if name.contains("plan") {
                ok(omnikin_plan::Plan::read_csv(data, "seed"))?;
            }
            if name.contains("plan") || name.contains("track") {
                ok(omnikin_sim::track::Track::read_csv(data, "seed"))?;
            } else {
                ok(omnikin_sim::table::NumericTable::parse(&s(), "seed"))?;
            }
            Ok(())
        }
        "mcap_files" => {
            // The valid seeds scan whole; the crafted ones are refused or end at their damage
            // (their point is to reach the scan's checks).
            let inflated = omnikin_fuzz::mcap::inflate::inflate(data);
            let scan = match &inflated {
                Ok(i) if i.damage.is_none() => omnikin_fuzz::mcap::scan::scan(&i.bytes),
                Ok(i) => Err(format!("inflate: {:?}", i.damage)),
                Err(e) => Err(format!("inflate: {e}")),
            };
            match (name.ends_with("-valid"), scan) {
                (true, Ok(s)) if s.damage.is_none() => Ok(()),
                (true, r) => Err(format!("the valid file does not scan whole: {r:?}")),
                (false, Ok(s)) if s.damage.is_none() => Err("a crafted file scans whole".into()),
                (false, _) => Ok(()),
            }
        }
        "mcap_messages" => {
            let (&pick, message) = data.split_first().ok_or("an empty seed")?;
            let topics = omnikin_fuzz::mcap::foxglove::TOPICS;
            let topic = topics[usize::from(pick) % topics.len()];
            let decoded = omnikin_fuzz::mcap::proto::to_json(topic, message);
            match (name.ends_with("-valid"), decoded) {
                (_, Err(e)) => Err(format!("does not decode: {e}")),
                (true, Ok(v)) if v.get("timestamp").is_some() => Ok(()),
                (true, Ok(v)) => Err(format!("no timestamp in {v}")),
                (false, Ok(_)) => Ok(()),
            }
        }
        "ros2_cdr" => {
            let (&pick, sample) = data.split_first().ok_or("an empty seed")?;
            let ok = match pick % 7 {
                0 => omnikin_ros2::msg::from_cdr::<omnikin_ros2::msg::Twist>(sample).is_ok(),
                1 => omnikin_ros2::msg::from_cdr::<omnikin_ros2::msg::TwistStamped>(sample).is_ok(),
                3 => omnikin_ros2::msg::from_cdr::<omnikin_ros2::msg::TfMessage>(sample).is_ok(),
                4 => omnikin_ros2::msg::from_cdr::<omnikin_ros2::msg::JointState>(sample).is_ok(),
                5 => omnikin_ros2::msg::from_cdr::<omnikin_ros2::msg::Imu>(sample).is_ok(),
                6 => omnikin_ros2::msg::from_cdr::<omnikin_ros2::msg::DiagnosticArray>(sample)
                    .is_ok(),
                _ => omnikin_ros2::msg::from_cdr::<omnikin_ros2::msg::Odometry>(sample).is_ok(),
            };
            match (name.ends_with("-valid"), ok) {
                (true, true) | (false, false) => Ok(()),
                (true, false) => Err("the valid sample does not decode".into()),
                (false, true) => Err("the forged sample decodes".into()),
            }
        }
        other => Err(format!("no such target {other}")),
    }
}

fn main() {
    let root = std::env::args_os()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("corpus"));
    let mut bad = 0;
    let mut counts = std::collections::BTreeMap::new();
    for (target, name, data) in seeds::all() {
        if let Err(why) = valid(target, &name, &data) {
            eprintln!("invalid seed {target}/{name}: {why}");
            bad += 1;
        }
        // The target's own checks (a panic here is a finding on a valid input).
        match target {
            "robot_toml" => text::robot_toml(&data),
            "profile_toml" => text::profile_toml(&data),
            "waypoints" => text::waypoints(&data),
            "csv_tables" => text::csv_tables(&data),
            "mcap_files" => omnikin_fuzz::mcap::mcap_files(&data),
            "mcap_messages" => omnikin_fuzz::mcap::mcap_messages(&data),
            "ros2_cdr" => omnikin_fuzz::ros2::ros2_cdr(&data),
            _ => {}
        }
        let dir = root.join(target);
        std::fs::create_dir_all(&dir).expect("create the corpus directory");
        std::fs::write(dir.join(&name), &data).expect("write a seed");
        *counts.entry(target).or_insert(0) += 1;
    }
    for (t, n) in &counts {
        println!("{n:4} seeds  {}", root.join(t).display());
    }
    if bad > 0 {
        eprintln!("{bad} invalid seed(s)");
        std::process::exit(1);
    }
}
