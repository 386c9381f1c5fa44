//! One parameter set for every command (issue 35): `reproduce sphere-2019` uses the robot file
//! as loaded (no run-time overrides), `plan` + `simulate --plant dynamic` with the same file
//! give its fast circles' ratios, and `--fit-to-paper` writes the one fitted value into the
//! file (that line only, replaced only with `--force`).

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use predicates::prelude::*;
use serde_json::Value;

/// The shipped preset's text (what the binary under test compiles in).
const PRESET: &str = include_str!("../../../robots/sphere-omni.toml");

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

fn tmp(name: &str) -> TestDir {
    TestDir::new("repro-file", name)
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The preset with its `com_depth` line replaced by `line`.
fn with_com_depth(line: &str) -> String {
    PRESET
        .lines()
        .map(|l| {
            if l.starts_with("com_depth") {
                line.to_string()
            } else {
                l.to_string()
            }
        })
        .map(|l| l + "\n")
        .collect()
}

/// `reproduce sphere-2019 --profiles dynamic --dynamic-trials 2` with `robot_file` (the
/// built-in preset without one) into `out`; its metrics.json.
fn reproduce(out: &Path, robot_file: Option<&Path>) -> Value {
    let mut cmd = omnikin();
    cmd.args([
        "reproduce",
        "sphere-2019",
        "--profiles",
        "dynamic",
        "--dynamic-trials",
        "2",
        "--out",
    ])
    .arg(out);
    if let Some(f) = robot_file {
        cmd.arg("--robot-file").arg(f);
    }
    let assert = cmd.assert().success();
    let stdout = String::from_utf8_lossy(&assert.get_output().stdout).to_string();
    let name = robot_file.map_or("preset sphere-omni".into(), |f| f.display().to_string());
    assert!(
        stdout.contains(&format!("the robot file as loaded**, {name};")),
        "reproduce must say which robot file it used:\n{stdout}"
    );
    json(&out.join("metrics.json"))
}

/// `plan circle --radius 0.2 --omega OMEGA` then `simulate --plant dynamic`, both with
/// `robot` (a preset name or a file): the deterministic run's radius ratio.
fn plan_and_simulate(dir: &Path, robot: &str, omega: &str) -> f64 {
    let plan = dir.join(format!("circle-{omega}.csv"));
    omnikin()
        .args(["plan", "circle", "--robot", robot, "--radius", "0.2"])
        .args(["--omega", omega, "--rate", "100", "--out"])
        .arg(&plan)
        .assert()
        .success();
    let out = dir.join(format!("sim-{omega}"));
    omnikin()
        .arg("simulate")
        .arg(&plan)
        .args(["--robot", robot, "--plant", "dynamic", "--out"])
        .arg(&out)
        .assert()
        .success();
    json(&out.join("metrics.json"))["radius_ratio"]
        .as_f64()
        .unwrap()
}

fn dynamic_ratio(m: &Value, series: &str) -> f64 {
    m["series"][series]["dynamic"]["radius_ratio"]
        .as_f64()
        .unwrap_or_else(|| panic!("{series}: no dynamic radius ratio"))
}

/// The issue's "one tool, two answers": `plan circle --omega 2` / `2.5` then `simulate
/// --plant dynamic` with the shipped preset must give reproduce's 0.4 / 0.5 m/s ratios within
/// 5 % (they gave 1.873 vs 1.403 and 2.832 vs 1.747 while reproduce overrode the file).
#[test]
fn simulate_with_the_preset_gives_reproduces_fast_circles() {
    let d = tmp("same-answer");
    let m = reproduce(&d.join("r"), None);
    assert_eq!(m["dynamic_robot_file"], "preset sphere-omni");
    for (omega, series) in [("2", "circle-0.4"), ("2.5", "circle-0.5")] {
        let sim = plan_and_simulate(&d, "sphere-omni", omega);
        let rep = dynamic_ratio(&m, series);
        assert!(
            (sim / rep - 1.0).abs() < 0.05,
            "{series}: simulate {sim:.3}, reproduce {rep:.3}"
        );
    }
    // The shipped value and its provenance reach metrics.json as the file states them.
    let fitted = &m["dynamic_fitted"];
    assert_eq!(fitted["name"], "com_depth");
    let line = PRESET.lines().find(|l| l.starts_with("com_depth")).unwrap();
    let value: f64 = line
        .split('=')
        .nth(1)
        .and_then(|v| v.split('#').next())
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert_eq!(fitted["value"].as_f64(), Some(value));
    assert_eq!(
        fitted["comment"].as_str(),
        Some(line.split_once('#').unwrap().1.trim())
    );
    // Contact counts per series, each wheel's.
    for s in ["square-0.5", "circle-0.5"] {
        let c = &m["series"][s]["dynamic_nominal_contact_events"];
        for k in ["roller_slips", "lift_offs", "lost_steps"] {
            assert_eq!(c[k].as_array().map(Vec::len), Some(3), "{s}.{k}: {c}");
        }
        assert!(c["floor_slips"].is_u64(), "{s}: {c}");
    }
}

/// A file with a deeper centre of mass leans less: reproduce must follow the file (before
/// issue 35 it ignored the robot file's `[dynamics]` altogether).
#[test]
fn a_robot_file_with_another_com_depth_changes_reproduce() {
    let d = tmp("other-depth");
    let file = d.join("deep.toml");
    std::fs::write(&file, with_com_depth("com_depth = 0.11  # a test's value")).unwrap();
    let deep = reproduce(&d.join("deep"), Some(&file));
    let shipped = reproduce(&d.join("shipped"), None);
    assert_eq!(deep["dynamic_robot_file"], file.display().to_string());
    assert_eq!(deep["dynamic_fitted"]["value"].as_f64(), Some(0.11));
    assert_eq!(deep["dynamic_fitted"]["comment"], "a test's value");
    let (a, b) = (
        dynamic_ratio(&deep, "circle-0.4"),
        dynamic_ratio(&shipped, "circle-0.4"),
    );
    assert!(
        a < b - 0.05,
        "deeper centre of mass: {a:.3}, shipped: {b:.3}"
    );
}

/// `--fit-to-paper` on a copy of the preset with the parts estimate back in: refused without
/// `--force` (the file untouched); with it, exactly the `com_depth` line changes, to the value
/// the shipped preset holds (the shipped preset is what the command writes), and that file's
/// 0.4 m/s circle through `plan` + `simulate` comes out at the paper's 1.4.
#[test]
fn fit_to_paper_writes_only_the_one_line_and_only_with_force() {
    let d = tmp("fit");
    let file: PathBuf = d.join("sphere.toml");
    let before = with_com_depth(
        "com_depth = 0.08                  # h, platform centre of mass below the shell centre [m]",
    );
    std::fs::write(&file, &before).unwrap();
    omnikin()
        .args(["reproduce", "sphere-2019", "--fit-to-paper", "--robot-file"])
        .arg(&file)
        .assert()
        .failure()
        .stderr(predicate::str::contains("--force"));
    assert_eq!(std::fs::read_to_string(&file).unwrap(), before);
    omnikin()
        .args(["--force", "reproduce", "sphere-2019", "--fit-to-paper"])
        .arg("--robot-file")
        .arg(&file)
        .assert()
        .success()
        .stdout(predicate::str::contains("wrote com_depth = "));
    let after = std::fs::read_to_string(&file).unwrap();
    let (old, new): (Vec<_>, Vec<_>) = (before.lines().collect(), after.lines().collect());
    assert_eq!(old.len(), new.len());
    let changed: Vec<_> = old.iter().zip(&new).filter(|(a, b)| a != b).collect();
    assert_eq!(changed.len(), 1, "{changed:?}");
    let line = changed[0].1;
    let shipped = PRESET.lines().find(|l| l.starts_with("com_depth")).unwrap();
    assert_eq!(
        *line, shipped,
        "the shipped preset is not what --fit-to-paper writes"
    );
    assert!(
        line.ends_with(
            "m to paper 000's 0.4 m/s circle ratio 1.4 (omnikin reproduce sphere-2019 \
             --fit-to-paper)"
        ),
        "{line}"
    );
    let ratio = plan_and_simulate(&d, file.to_str().unwrap(), "2");
    assert!((ratio - 1.4).abs() < 0.01, "fitted file: {ratio}");
}

/// `reproduce sphere-2019 --sensitivity` prints the nominal row and each `[dynamics]` value at
/// both ends of its range for the eight series, writes nothing; a robot file that names a
/// floor and gives one of its values too is told so on stderr.
#[test]
fn sensitivity_prints_each_value_at_both_ends_and_a_floor_override_is_said() {
    let d = tmp("sensitivity");
    let file = d.join("carpet.toml");
    let text: String = PRESET
        .replace(
            "floor = \"vinyl\"",
            "floor = \"carpet\"\npivot_friction = 0.03",
        )
        .to_string();
    assert!(
        text.contains("floor = \"carpet\""),
        "the preset names its floor"
    );
    std::fs::write(&file, &text).unwrap();
    let out = omnikin()
        .current_dir(&*d)
        .args(["reproduce", "sphere-2019", "--sensitivity", "--robot-file"])
        .arg(&file)
        .assert()
        .success();
    let stdout = String::from_utf8_lossy(&out.get_output().stdout).to_string();
    let stderr = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        stderr.contains("dynamics.floor = \"carpet\"")
            && stderr.contains("overridden")
            && stderr.contains("pivot_friction = 0.03"),
        "{stderr}"
    );
    let rows: Vec<&str> = stdout.lines().filter(|l| l.starts_with("| ")).collect();
    // Header, nominal, the fitted com_depth's two ends, two ends of each of the 11 values.
    assert_eq!(rows.len(), 1 + 1 + 2 + 22, "{stdout}");
    assert!(rows[0].contains("circle-0.5: dev % / ratio") && rows[0].contains("square-0.1: dev %"));
    assert!(rows[1].starts_with("| nominal (the file) |"));
    for key in [
        "pivot_friction",
        "roller_friction",
        "platform_mass",
        "tracked_height",
    ] {
        assert_eq!(
            rows.iter()
                .filter(|r| r.starts_with(&format!("| `{key}` = ")))
                .count(),
            2,
            "{key}"
        );
    }
    assert_eq!(
        std::fs::read_dir(&*d).unwrap().count(),
        1,
        "--sensitivity writes nothing"
    );
}
