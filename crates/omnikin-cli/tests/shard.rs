//! `simulate`/`reproduce --shard K/N` and `omnikin merge`: the merged shards write exactly what
//! one run writes, and a merge refuses shards that are not one whole run.

#[path = "common/test_dir.rs"]
mod test_dir;
use test_dir::TestDir;

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use predicates::prelude::*;

fn omnikin() -> Command {
    let mut c = Command::cargo_bin("omnikin").unwrap();
    // The plan and profile are named relative to examples/, as a user would.
    c.current_dir(examples());
    c
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn tmp(name: &str) -> TestDir {
    TestDir::new("shard-cli", name)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `simulate` of the example circle under the noisy profile, with `extra` flags.
fn simulate(trials: &str, seed: &str, out: &Path, extra: &[&str]) -> assert_cmd::assert::Assert {
    omnikin()
        .args([
            "simulate",
            "plans/circle-sphere.csv",
            "--robot",
            "sphere-omni",
            "--disturbances",
            "profiles/noisy.toml",
            "--trials",
            trials,
            "--seed",
            seed,
            "--out",
            s(out),
        ])
        .args(extra)
        .assert()
}

fn same_files(a: &Path, b: &Path, names: &[&str]) {
    for n in names {
        let (x, y) = (
            std::fs::read(a.join(n)).unwrap(),
            std::fs::read(b.join(n)).unwrap(),
        );
        assert!(!x.is_empty(), "{n} is empty");
        assert!(
            x == y,
            "{n} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

#[test]
fn three_simulate_shards_merge_into_one_runs_files_byte_for_byte() {
    let d = tmp("simulate");
    let one = d.join("one");
    simulate("12", "7", &one, &[]).success();
    // Each shard on its own thread count: the trials depend on (seed, index) only.
    for (k, threads) in [(1, "1"), (2, "2"), (3, "3")] {
        simulate(
            "12",
            "7",
            &d.join(format!("shard-{k}")),
            &["--shard", &format!("{k}/3"), "--threads", threads],
        )
        .success()
        .stderr(predicate::str::contains(format!("shard {k}/3 of simulate")));
    }
    // Shard 2 of 3 of 12 trials holds trials 4..=7.
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("shard-2/shard.json")).unwrap()).unwrap();
    assert_eq!(
        (m["runs"][0]["first"].as_u64(), m["runs"][0]["end"].as_u64()),
        (Some(4), Some(8))
    );
    let merged = d.join("merged");
    // In any order.
    omnikin()
        .args([
            "merge",
            s(&d.join("shard-3")),
            s(&d.join("shard-1")),
            s(&d.join("shard-2")),
        ])
        .args(["--out", s(&merged)])
        .assert()
        .success()
        .stderr(
            predicate::str::contains("12 run(s)").and(predicate::str::contains("merged 3 shards")),
        );
    same_files(
        &one,
        &merged,
        &["metrics.json", "trials.csv", "mean.csv", "figure.svg"],
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn two_reproduce_shards_merge_into_one_runs_table() {
    let d = tmp("reproduce");
    let run = |out: &Path, extra: &[&str]| {
        omnikin()
            .args([
                "reproduce",
                "sphere-2019",
                "--profiles",
                "ideal,hardware",
                "--trials",
                "4",
            ])
            .args(["--out", s(out)])
            .args(extra)
            .assert()
            .success()
    };
    let one = d.join("one");
    let table = run(&one, &[]).get_output().stdout.clone();
    for k in 1..=2 {
        run(
            &d.join(format!("shard-{k}")),
            &["--shard", &format!("{k}/2")],
        );
    }
    assert!(
        !d.join("shard-1/table.csv").exists(),
        "a shard writes no table"
    );
    let merged = d.join("merged");
    let out = omnikin()
        .args([
            "merge",
            s(&d.join("shard-1")),
            s(&d.join("shard-2")),
            "--out",
            s(&merged),
        ])
        .assert()
        .success();
    assert_eq!(out.get_output().stdout, table, "the printed table");
    same_files(
        &one,
        &merged,
        &[
            "table.md",
            "table.csv",
            "metrics.json",
            "circle-0.4-hardware.svg",
            "square-0.1-hardware.svg",
        ],
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// The dynamic profile counts every trial's contact events: a merge of shards gives the
/// same counts as one run (the shards carry each trial's events), a series that slips
/// (the 0.5 m/s square's hard starts) has slips in every trial, and the ramped 0.1 m/s square
/// none of any kind; stderr says it in a sentence.
#[test]
fn the_dynamic_profile_counts_every_trials_contacts_and_shards_keep_them() {
    let d = tmp("contacts");
    let run = |out: &Path, extra: &[&str]| {
        omnikin()
            .args(["reproduce", "sphere-2019", "--profiles", "dynamic"])
            .args([
                "--dynamic-trials",
                "3",
                "--prior-samples",
                "3",
                "--out",
                s(out),
            ])
            .args(extra)
            .assert()
            .success()
    };
    let one = d.join("one");
    let stderr = String::from_utf8_lossy(&run(&one, &[]).get_output().stderr).to_string();
    assert!(
        stderr.contains("contact events over every trial")
            && stderr.contains("roller slips in ")
            && stderr.contains("square-0.5 3/3"),
        "{stderr}"
    );
    for k in 1..=2 {
        run(
            &d.join(format!("shard-{k}")),
            &["--shard", &format!("{k}/2")],
        );
    }
    let merged = d.join("merged");
    omnikin()
        .args(["merge", s(&d.join("shard-1")), s(&d.join("shard-2"))])
        .args(["--out", s(&merged)])
        .assert()
        .success();
    same_files(&one, &merged, &["metrics.json", "table.csv", "table.md"]);
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(one.join("metrics.json")).unwrap()).unwrap();
    let c = |series: &str, kind: &str, key: &str| {
        m["series"][series]["dynamic_contact_events"][kind][key]
            .as_u64()
            .unwrap_or_else(|| panic!("{series}.{kind}.{key}: {}", m["series"][series]))
    };
    assert_eq!(
        m["series"]["square-0.5"]["dynamic_contact_events"]["trials"],
        3
    );
    // The prior band (3 robots from the priors) beside the figures, recomputed alike by the
    // merge.
    let band = &m["series"]["circle-0.4"]["dynamic_prior_band"];
    assert_eq!(band["samples"], 3, "{band}");
    let r = band["radius_ratio"].as_array().unwrap();
    assert!(r[0].as_f64().unwrap() <= r[1].as_f64().unwrap(), "{band}");
    assert!(m["series"]["square-0.1"]["dynamic_prior_band"]["radius_ratio"].is_null());
    assert!(c("square-0.5", "roller_slips", "total") > 0);
    assert_eq!(c("square-0.5", "roller_slips", "trials_with_any"), 3);
    assert!(c("square-0.5", "roller_slips", "max_per_trial") > 0);
    for kind in ["roller_slips", "lift_offs", "floor_slips", "lost_steps"] {
        for key in ["total", "trials_with_any", "max_per_trial"] {
            assert_eq!(c("square-0.1", kind, key), 0, "square-0.1 {kind}.{key}");
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn merge_refuses_what_is_not_one_whole_run() {
    let d = tmp("errors");
    for k in 1..=3 {
        simulate(
            "3",
            "1",
            &d.join(format!("s{k}")),
            &["--shard", &format!("{k}/3")],
        )
        .success();
    }
    // The same shard 2 with another seed.
    simulate("3", "2", &d.join("seed2"), &["--shard", "2/3"]).success();
    let merge = |dirs: &[&str], out: &str| {
        let mut c = omnikin();
        c.arg("merge");
        for x in dirs {
            c.arg(s(&d.join(x)));
        }
        c.args(["--out", s(&d.join(out))]).assert()
    };
    merge(&["s1", "s3"], "o1")
        .failure()
        .stderr(predicate::str::contains("shard 2/3 missing"));
    // A copy of shard 1 under another name.
    std::fs::create_dir_all(d.join("copy")).unwrap();
    for f in ["shard.json", "plan.csv", "trials.csv", "runs.bin"] {
        std::fs::copy(d.join("s1").join(f), d.join("copy").join(f)).unwrap();
    }
    merge(&["s1", "s2", "s3", "copy"], "o2").failure().stderr(
        predicate::str::contains("shard 1/3 is given twice").and(predicate::str::contains("copy")),
    );
    merge(&["s1", "seed2", "s3"], "o3")
        .failure()
        .stderr(predicate::str::contains(
            "ran different inputs: seed is 2 there and 1 here",
        ));
    std::fs::create_dir_all(d.join("empty")).unwrap();
    merge(&["s1", "empty"], "o4")
        .failure()
        .stderr(predicate::str::contains(
            "empty: not a finished shard directory: it has no shard.json",
        ));
    // Never into an input directory.
    merge(&["s1", "s2", "s3"], "s2/out")
        .failure()
        .stderr(predicate::str::contains("is inside the shard directory"));
    merge(&["s1", "s2", "s3"], "s3")
        .failure()
        .stderr(predicate::str::contains("is the shard directory"));
    // A cut runs file is named.
    let runs = d.join("copy/runs.bin");
    let bytes = std::fs::read(&runs).unwrap();
    std::fs::write(&runs, &bytes[..bytes.len() - 8]).unwrap();
    merge(&["copy", "s2", "s3"], "o5")
        .failure()
        .stderr(predicate::str::contains("runs.bin").and(predicate::str::contains("truncated")));
    // The merge's output follows the output rules: not replaced without --force.
    merge(&["s1", "s2", "s3"], "o6").success();
    merge(&["s1", "s2", "s3"], "o6")
        .failure()
        .stderr(predicate::str::contains("--force"));
    omnikin()
        .args([
            "--force",
            "merge",
            s(&d.join("s1")),
            s(&d.join("s2")),
            s(&d.join("s3")),
        ])
        .args(["--out", s(&d.join("o6"))])
        .assert()
        .success();
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn shard_flags_are_checked_at_the_edge() {
    let d = tmp("flags");
    for (shard, says) in [
        ("0/3", "K must be between 1 and N = 3"),
        ("4/3", "K must be between 1 and N = 3"),
        ("3", "expected K/N"),
        ("x/3", "K must be a whole number"),
        ("1/0", "N must be between 1 and"),
    ] {
        simulate("3", "1", &d.join("o"), &["--shard", shard])
            .failure()
            .stderr(predicate::str::contains(says));
    }
    simulate("3", "1", &d.join("o"), &["--shard", "1/4"])
        .failure()
        .stderr(predicate::str::contains("4 shards of 3 trials"));
    simulate(
        "3",
        "1",
        &d.join("o"),
        &["--shard", "1/2", "--emit-sensors"],
    )
    .failure()
    .stderr(predicate::str::contains("--shard: not with --emit-sensors"));
    simulate(
        "3",
        "1",
        &d.join("o"),
        &["--shard", "1/2", "--plant", "dynamic"],
    )
    .failure()
    .stderr(predicate::str::contains(
        "--shard: the dynamic plant runs one trial",
    ));
    omnikin()
        .args([
            "reproduce",
            "sphere-2019",
            "--profiles",
            "ideal",
            "--trials",
            "2",
        ])
        .args(["--shard", "1/3", "--out", s(&d.join("r"))])
        .assert()
        .failure()
        .stderr(
            predicate::str::contains("3 shards of 2 trials")
                .and(predicate::str::contains("--trials")),
        );
    let _ = std::fs::remove_dir_all(&d);
}
