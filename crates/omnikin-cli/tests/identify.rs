//! `omnikin plan sysid` and `omnikin identify` end to end: the test plans of the kiwi preset
//! are simulated (`omnikin simulate --emit-sensors`) with a robot file whose wheel 2 is 2 %
//! larger and whose wheel 1 sits 5 mm further out, and `identify` with the preset as prior
//! writes a robot file with those values back; bad inputs are refused naming the flag, file
//! and column.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use omnikin::description::{Geometry, RobotDescription};
use predicates::prelude::*;

fn omnikin() -> Command {
    Command::cargo_bin("omnikin").unwrap()
}

const PLANS: [&str; 4] = ["along", "along-across", "spin", "figure-eight"];

/// The sysid plans of the kiwi preset simulated with the perturbed file: the encoder logs and
/// fixes of each, in plan order.
fn recorded(dir: &Path) -> (Vec<PathBuf>, Vec<PathBuf>) {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../robots/kiwi.toml"),
    )
    .unwrap();
    let truth = text
        .replacen("position = [0.15, 0.0]", "position = [0.155, 0.0]", 1)
        .replacen(
            "position = [-0.075, 0.1299038105676658]\ndrive_angle_deg = 210.0\nroller_angle_deg = 0.0\nradius = 0.05",
            "position = [-0.075, 0.1299038105676658]\ndrive_angle_deg = 210.0\nroller_angle_deg = 0.0\nradius = 0.051",
            1,
        );
    assert_ne!(truth, text);
    std::fs::write(dir.join("kiwi-true.toml"), &truth).unwrap();
    std::fs::write(
        dir.join("sensors.toml"),
        "counts_per_rev = 4096\n[gyro]\nnoise_std = 0.002\nbias = 0.01\nbias_std = 0.0\n[camera]\nperiod = 0.1\nlatency = 0.1\nnoise_std = 0.005\noutlier_probability = 0.0\noutlier_distance = 0.5\n",
    )
    .unwrap();
    omnikin()
        .current_dir(dir)
        .args(["plan", "sysid", "--robot", "kiwi", "--out", "plans"])
        .assert()
        .success();
    let readme = std::fs::read_to_string(dir.join("plans/README.txt")).unwrap();
    let (mut enc, mut fixes) = (Vec::new(), Vec::new());
    for p in PLANS {
        assert!(readme.contains(&format!("{p}.csv")), "{readme}");
        omnikin()
            .current_dir(dir)
            .args([
                "simulate",
                "--robot",
                "kiwi-true.toml",
                "--trials",
                "1",
                "--seed",
                "37",
            ])
            .args([
                "--emit-sensors",
                "--sensors",
                "sensors.toml",
                "--out",
                &format!("sim-{p}"),
            ])
            .arg(format!("plans/{p}.csv"))
            .assert()
            .success();
        enc.push(dir.join(format!("sim-{p}/sensors/trial-000/encoders.csv")));
        fixes.push(dir.join(format!("sim-{p}/sensors/trial-000/fixes.csv")));
    }
    (enc, fixes)
}

#[test]
fn identify_recovers_a_perturbed_kiwi_from_simulated_logs() {
    let dir = TestDir::new("identify", "kiwi");
    let (enc, fixes) = recorded(&dir);
    let out = omnikin()
        .current_dir(&*dir)
        .args([
            "identify",
            "--robot",
            "kiwi",
            "--out",
            "identified.toml",
            "--json",
            "--plot",
            "residuals.png",
        ])
        .arg("--encoders")
        .args(&enc)
        .arg("--fixes")
        .args(&fixes)
        .assert()
        .success();
    let json: serde_json::Value =
        serde_json::from_slice(&out.get_output().stdout).expect("one JSON object");
    let param = |name: &str| {
        json["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == name)
            .unwrap()
            .clone()
    };
    for (name, truth, tol) in [
        ("wheels[2].radius_scale", 1.02, 2e-3),
        ("wheels[1].position.x", 0.155, 1e-3),
        ("gyro.bias", 0.01, 5e-4),
    ] {
        let p = param(name);
        let (v, s) = (p["value"].as_f64().unwrap(), p["sigma"].as_f64().unwrap());
        assert!(
            (v - truth).abs() <= 3.0 * s && (v - truth).abs() <= tol,
            "{name}: {p}"
        );
    }
    assert_eq!(param("wheels[1].position.y")["status"], "held");
    // The written file loads and carries the fitted radius with its comment.
    let written = std::fs::read_to_string(dir.join("identified.toml")).unwrap();
    assert!(written.contains("# identified: "), "{written}");
    let d = RobotDescription::from_toml_str(&written, "identified.toml").unwrap();
    let Geometry::Omni(w) = d.geometry else {
        panic!("an omni robot")
    };
    assert!((w[1].radius - 0.051).abs() < 1e-4, "{}", w[1].radius);
    assert!(written.contains("max_wheel_rate = 40.0"));
    // Per run, the estimate explains the logs better than the prior did, down to the camera's
    // noise (5 mm per axis: an RMS length of 5 mm · √2), and the residual figure is a PNG.
    let noise = 0.005 * std::f64::consts::SQRT_2;
    for r in json["runs"].as_array().unwrap() {
        let (b, a) = (
            r["position_rms_before_m"].as_f64().unwrap(),
            r["position_rms_after_m"].as_f64().unwrap(),
        );
        assert!(a < b && (a - noise).abs() < 0.3 * noise, "{r}");
    }
    assert_eq!(json["runs"].as_array().unwrap().len(), PLANS.len());
    let png = std::fs::read(dir.join("residuals.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "{:?}", &png[..8]);
    // SVG and PDF by the extension (the spin alone: quick; a kiwi's other plans alone leave
    // near-blind directions that the fit runs away in), the SVG with its axes' units and series.
    for name in ["residuals.svg", "residuals.pdf"] {
        omnikin()
            .current_dir(&*dir)
            .args(["identify", "--robot", "kiwi", "--plot", name])
            .args(["--out", &format!("{name}.toml")])
            .arg("--encoders")
            .arg(&enc[2])
            .arg("--fixes")
            .arg(&fixes[2])
            .assert()
            .success();
    }
    let svg = std::fs::read_to_string(dir.join("residuals.svg")).unwrap();
    assert!(svg.starts_with("<svg"), "{}", &svg[..40]);
    for label in [
        "position residual |Δp| [m]",
        "time t [s]",
        "before (prior), RMS",
        "after (estimate), RMS",
        "sim-spin",
    ] {
        assert!(svg.contains(label), "{label}");
    }
    let pdf = std::fs::read(dir.join("residuals.pdf")).unwrap();
    assert!(pdf.starts_with(b"%PDF-1."), "{:?}", &pdf[..8]);
    // The loop closes: the paper's square at 0.4 m/s and a 0.5 m circle at 2 rad/s, planned
    // with the preset and with the identified file, each run on the "real" robot
    // (kiwi-true.toml, one trial, no disturbances): the identified plan's largest deviation
    // is at least 2× smaller (measured on these logs, seed 37: square 8.05 → 0.43 mm, circle
    // 10.47 → 1.68 mm).
    for (shape, args) in [
        ("square", vec!["--speed", "0.4"]),
        ("circle", vec!["--radius", "0.5", "--omega", "2"]),
    ] {
        let mut dev = Vec::new();
        for robot in ["kiwi", "identified.toml"] {
            let plan = format!("{shape}-{robot}.csv");
            omnikin()
                .current_dir(&*dir)
                .args(["plan", shape, "--robot", robot, "--out", &plan])
                .args(&args)
                .assert()
                .success();
            let out = format!("loop-{shape}-{robot}");
            omnikin()
                .current_dir(&*dir)
                .args(["simulate", "--robot", "kiwi-true.toml", "--trials", "1"])
                .args(["--out", &out, &plan])
                .assert()
                .success();
            let m: serde_json::Value = serde_json::from_str(
                &std::fs::read_to_string(dir.join(&out).join("metrics.json")).unwrap(),
            )
            .unwrap();
            dev.push(m["max_deviation_m"].as_f64().unwrap());
        }
        eprintln!(
            "{shape}: max deviation preset {} m, identified {} m",
            dev[0], dev[1]
        );
        assert!(2.0 * dev[1] < dev[0], "{shape}: {dev:?}");
    }
}

#[test]
fn identify_refuses_mismatched_or_malformed_inputs() {
    let dir = TestDir::new("identify", "errors");
    std::fs::write(dir.join("enc.csv"), "t,q1,q2\n0,0,0\n0.1,1,1\n").unwrap();
    std::fs::write(dir.join("fix.csv"), "t,x,y\n0,0,0\n0.1,0,0\n").unwrap();
    // One reference for two runs.
    omnikin()
        .current_dir(&*dir)
        .args(["identify", "--robot", "kiwi", "--out", "o.toml"])
        .args(["--encoders", "enc.csv", "enc.csv", "--fixes", "fix.csv"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "--fixes: 1 files for 2 --encoders logs",
        ));
    // No reference at all.
    omnikin()
        .current_dir(&*dir)
        .args([
            "identify",
            "--robot",
            "kiwi",
            "--out",
            "o.toml",
            "--encoders",
            "enc.csv",
        ])
        .assert()
        .failure()
        .stderr(predicate::str::contains("--fixes FIXES.csv… or --tracked"));
    // A kiwi log needs q3.
    omnikin()
        .current_dir(&*dir)
        .args(["identify", "--robot", "kiwi", "--out", "o.toml"])
        .args(["--encoders", "enc.csv", "--fixes", "fix.csv"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("enc.csv").and(predicate::str::contains("q3")));
    // An unknown figure format is refused naming the flag, before anything runs.
    omnikin()
        .current_dir(&*dir)
        .args([
            "identify", "--robot", "kiwi", "--out", "o.toml", "--plot", "r.jpg",
        ])
        .args(["--encoders", "enc.csv", "--fixes", "fix.csv"])
        .assert()
        .failure()
        .stderr(
            predicate::str::contains("--plot r.jpg")
                .and(predicate::str::contains(".svg, .png or .pdf")),
        );
    assert!(!dir.join("o.toml").exists());
    assert!(!dir.join("r.jpg").exists());
}

/// Issue 37 end to end for a swerve: `plan sysid --robot swerve4` (the modules turn at rest
/// between segments), `simulate --emit-sensors` with a robot file whose front modules' wheels
/// are 1.5 % larger and a gyro biased by 0.01 rad/s, then `identify` with the preset as prior:
/// every fitted value within 3σ of the truth (the front scales 1.015, everything else the
/// preset's), the front scales fitted (not held), and the gauge of the module square held.
#[test]
fn identify_recovers_a_perturbed_swerve4_end_to_end() {
    let dir = TestDir::new("identify", "swerve4");
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../robots/swerve4.toml"),
    )
    .unwrap();
    // The first two modules (front left, front right) get 0.05 · 1.015 m wheels.
    let truth = text
        .replacen("wheel_radius = 0.05 ", "wheel_radius = 0.05075 ", 1)
        .replacen(
            "position = [0.3, -0.3]\nwheel_radius = 0.05\n",
            "position = [0.3, -0.3]\nwheel_radius = 0.05075\n",
            1,
        );
    assert_eq!(truth.matches("0.05075").count(), 2, "{truth}");
    std::fs::write(dir.join("swerve4-true.toml"), &truth).unwrap();
    std::fs::write(
        dir.join("sensors.toml"),
        "counts_per_rev = 4096\n[gyro]\nnoise_std = 0.002\nbias = 0.01\nbias_std = 0.0\n[camera]\nperiod = 0.1\nlatency = 0.0\nnoise_std = 0.003\noutlier_probability = 0.0\noutlier_distance = 0.5\n",
    )
    .unwrap();
    omnikin()
        .current_dir(&*dir)
        .args(["plan", "sysid", "--robot", "swerve4", "--out", "plans"])
        .assert()
        .success();
    let (mut enc, mut fixes) = (Vec::new(), Vec::new());
    for p in PLANS {
        omnikin()
            .current_dir(&*dir)
            .args(["simulate", "--robot", "swerve4-true.toml", "--trials", "1"])
            .args([
                "--seed",
                "11",
                "--emit-sensors",
                "--sensors",
                "sensors.toml",
            ])
            .args(["--out", &format!("sim-{p}"), &format!("plans/{p}.csv")])
            .assert()
            .success();
        enc.push(format!("sim-{p}/sensors/trial-000/encoders.csv"));
        fixes.push(format!("sim-{p}/sensors/trial-000/fixes.csv"));
    }
    let out = omnikin()
        .current_dir(&*dir)
        .args([
            "identify",
            "--robot",
            "swerve4",
            "--out",
            "identified.toml",
            "--json",
        ])
        .arg("--encoders")
        .args(&enc)
        .arg("--fixes")
        .args(&fixes)
        .assert()
        .success();
    let json: serde_json::Value =
        serde_json::from_slice(&out.get_output().stdout).expect("one JSON object");
    let mut held = 0;
    for p in json["parameters"].as_array().unwrap() {
        let name = p["name"].as_str().unwrap();
        let truth = match name {
            "modules[1].radius_scale" | "modules[2].radius_scale" => 1.015,
            "gyro.bias" => 0.01,
            _ => p["prior"].as_f64().unwrap(),
        };
        let (v, s) = (p["value"].as_f64().unwrap(), p["sigma"].as_f64().unwrap());
        if p["status"] == "held" {
            held += 1;
            continue;
        }
        assert!(
            (v - truth).abs() <= 3.0 * s && s > 0.0,
            "{name}: {p} vs truth {truth}"
        );
    }
    assert_eq!(held, 6, "{json}");
    for front in ["modules[1].radius_scale", "modules[2].radius_scale"] {
        let p = json["parameters"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["name"] == front)
            .unwrap();
        assert_eq!(p["status"], "fitted", "{p}");
        assert!(p["sigma"].as_f64().unwrap() < 2e-3, "{p}");
    }
    let written = std::fs::read_to_string(dir.join("identified.toml")).unwrap();
    let d = RobotDescription::from_toml_str(&written, "identified.toml").unwrap();
    let Geometry::Swerve { modules, .. } = d.geometry else {
        panic!("a swerve")
    };
    assert!(
        (modules[0].wheel_radius - 0.05075).abs() < 1e-4,
        "{}",
        modules[0].wheel_radius
    );
}

/// The sphere end to end with the dynamic plant: `plan sysid` writes the `stop` and
/// `spin-stop` plans; `simulate --plant dynamic --emit-sensors` with a robot file whose
/// platform's centre of mass is 20 % deeper and whose floor's pivot friction is twice the
/// preset's writes the logs; `identify` with the preset as prior writes that depth and that
/// friction back within 10 % and 2σ, each with its comment, and reports the rocking and the
/// spin's decay in `--json`.
#[test]
fn identify_finds_the_spheres_com_depth_from_dynamic_logs() {
    let dir = TestDir::new("identify", "sphere-dynamic");
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../robots/sphere-omni.toml"),
    )
    .unwrap();
    let prior = RobotDescription::from_toml_str(&text, "sphere-omni.toml").unwrap();
    let h = prior.sphere_dynamics.as_ref().unwrap().com_depth.unwrap() * 1.2;
    // The preset's floor ("vinyl") gives 0.021 N m.
    let tau = 0.042;
    let truth: String = text
        .lines()
        .map(|l| {
            if l.starts_with("com_depth") {
                format!("com_depth = {h}")
            } else if l.starts_with("floor = ") {
                format!("{l}\npivot_friction = {tau}")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(dir.join("sphere-true.toml"), truth).unwrap();
    omnikin()
        .current_dir(&*dir)
        .args(["plan", "sysid", "--robot", "sphere-omni", "--out", "plans"])
        .assert()
        .success();
    let readme = std::fs::read_to_string(dir.join("plans/README.txt")).unwrap();
    assert!(
        readme.contains("stop.csv")
            && readme.contains("com_depth")
            && readme.contains("spin-stop.csv")
            && readme.contains("pivot_friction"),
        "{readme}"
    );
    let runs = ["spin", "stop", "spin-stop"];
    let mut args: Vec<String> = Vec::new();
    for flag in ["encoders", "fixes", "imu"] {
        args.push(format!("--{flag}"));
        for p in runs {
            args.push(format!("sim-{p}/sensors/trial-000/{flag}.csv"));
        }
    }
    for p in runs {
        omnikin()
            .current_dir(&*dir)
            .args([
                "simulate",
                "--robot",
                "sphere-true.toml",
                "--plant",
                "dynamic",
            ])
            .args(["--emit-sensors", "--out", &format!("sim-{p}")])
            .arg(format!("plans/{p}.csv"))
            .assert()
            .success()
            .stderr(predicate::str::contains("sensor logs: "));
        for f in ["encoders", "fixes", "imu", "truth"] {
            assert!(
                dir.join(format!("sim-{p}/sensors/trial-000/{f}.csv"))
                    .is_file()
            );
        }
    }
    let out = omnikin()
        .current_dir(&*dir)
        .args([
            "identify",
            "--robot",
            "sphere-omni",
            "--out",
            "identified.toml",
        ])
        .arg("--json")
        .args(&args)
        .assert()
        .success();
    let json: serde_json::Value =
        serde_json::from_slice(&out.get_output().stdout).expect("one JSON object");
    let p = json["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "dynamics.com_depth")
        .unwrap_or_else(|| panic!("{json}"));
    let (v, s) = (p["value"].as_f64().unwrap(), p["sigma"].as_f64().unwrap());
    assert_eq!(p["status"], "fitted", "{p}");
    assert!(
        (v - h).abs() < 0.1 * h && (v - h).abs() < 2.0 * s,
        "{p} vs {h}"
    );
    assert_eq!(json["rocking"].as_array().unwrap().len(), 1, "{json}");
    let written = std::fs::read_to_string(dir.join("identified.toml")).unwrap();
    let line = written
        .lines()
        .find(|l| l.starts_with("com_depth"))
        .unwrap();
    assert!(
        line.contains("# identified: ") && line.contains("rocking"),
        "{line}"
    );
    let d = RobotDescription::from_toml_str(&written, "identified.toml").unwrap();
    let spec = d.sphere_dynamics.unwrap();
    let back = spec.com_depth.unwrap();
    assert!((back - v).abs() < 1e-8, "{back} vs {v}");
    // The preset leaves the rolling resistance to its named floor: the identified value gets
    // a line of its own in [dynamics], which overrides the floor's.
    let rr = json["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "dynamics.rolling_resistance")
        .unwrap_or_else(|| panic!("{json}"));
    assert_eq!(rr["status"], "fitted", "{rr}");
    let rr_line = written
        .lines()
        .find(|l| l.starts_with("rolling_resistance = "))
        .unwrap_or_else(|| panic!("{written}"));
    assert!(rr_line.contains("# identified: "), "{rr_line}");
    let rr_back = spec.rolling_resistance.unwrap();
    assert!(
        (rr_back - rr["value"].as_f64().unwrap()).abs() < 1e-8,
        "{rr_back} vs {rr}"
    );
    assert!(
        spec.floor_overrides().contains(&"rolling_resistance"),
        "{:?}",
        spec.floor_overrides()
    );
    // The pivot friction, from the spin's decay after spin-stop's stop.
    let pf = json["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "dynamics.pivot_friction")
        .unwrap_or_else(|| panic!("{json}"));
    let (v, s) = (pf["value"].as_f64().unwrap(), pf["sigma"].as_f64().unwrap());
    assert_eq!(pf["status"], "fitted", "{pf}");
    assert!(
        (v - tau).abs() < 0.1 * tau && (v - tau).abs() < 2.0 * s,
        "{pf} vs {tau}"
    );
    assert_eq!(json["spin_decay"].as_array().unwrap().len(), 1, "{json}");
    let pf_line = written
        .lines()
        .find(|l| l.starts_with("pivot_friction = "))
        .unwrap_or_else(|| panic!("{written}"));
    assert!(
        pf_line.contains("# identified: ") && pf_line.contains("spin's decay"),
        "{pf_line}"
    );
    assert!((spec.pivot_friction.unwrap() - v).abs() < 1e-8);
}

/// One poorly exciting run (the kiwi's `along` alone) is refused with "not enough
/// excitation", naming what it does not determine; no robot file is written.
#[test]
fn identify_refuses_a_run_that_does_not_excite_the_geometry() {
    let dir = TestDir::new("identify", "not-excited");
    let (enc, fixes) = recorded(&dir);
    omnikin()
        .current_dir(&*dir)
        .args(["identify", "--robot", "kiwi", "--out", "k.toml"])
        .arg("--encoders")
        .arg(&enc[0])
        .arg("--fixes")
        .arg(&fixes[0])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "not enough excitation: these runs do not determine wheels[",
        ));
    assert!(!dir.join("k.toml").exists());
}

/// The dynamic plant tilts the platform itself: a sensor profile's constant `[tilt]` is
/// refused with `--plant dynamic`, naming the section, and the ballbot's dynamic plant does not
/// emit logs yet.
#[test]
fn dynamic_emit_sensors_refuses_a_constant_tilt_and_the_ballbot() {
    let dir = TestDir::new("identify", "dynamic-refusals");
    omnikin()
        .current_dir(&*dir)
        .args(["plan", "sysid", "--robot", "sphere-omni", "--out", "plans"])
        .assert()
        .success();
    std::fs::write(dir.join("tilt.toml"), "[tilt]\nroll = 0.1\npitch = 0.0\n").unwrap();
    omnikin()
        .current_dir(&*dir)
        .args(["simulate", "--robot", "sphere-omni", "--plant", "dynamic"])
        .args(["--emit-sensors", "--sensors", "tilt.toml", "--out", "o"])
        .arg("plans/stop.csv")
        .assert()
        .failure()
        .stderr(
            predicate::str::contains("[tilt]").and(predicate::str::contains("--plant kinematic")),
        );
    omnikin()
        .current_dir(&*dir)
        .args(["plan", "sysid", "--robot", "ballbot", "--out", "bplans"])
        .assert()
        .success();
    omnikin()
        .current_dir(&*dir)
        .args(["simulate", "--robot", "ballbot", "--plant", "dynamic"])
        .args(["--emit-sensors", "--out", "b", "bplans/along.csv"])
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "--emit-sensors: not yet for the ballbot",
        ));
}
