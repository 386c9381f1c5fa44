//! The shards and the merge as a library (`omnikin_io::shards`): a run split in two shards and
//! merged writes the files one run writes (`omnikin_io::sim_output::finish_simulation` after
//! `simulate_and_evaluate`), byte for byte, and a merge that lacks a shard is refused.

use std::path::{Path, PathBuf};

use anyhow::Result;
use omnikin::description::RobotDescription;
use omnikin_io::shards::{MergeOutput, SimulateRun, merge, simulate_shard};
use omnikin_io::sim_output::{RunFigures, SimulationInfo, create_dir_for, finish_simulation};
use omnikin_plan::Plan;
use omnikin_sim::Profile;
use omnikin_sim::metrics::{MeanTrajectory, Run, tracked_reference};
use omnikin_sim::shard::Shard;

/// Figures as a file holding the title and the number of runs drawn: what the report asks
/// of them, without a plotting crate.
struct TitleFigures;

impl RunFigures for TitleFigures {
    fn file_name(&self, stem: &str) -> String {
        format!("{stem}.txt")
    }
    fn draw(
        &self,
        path: &Path,
        title: &str,
        _plan: &Plan,
        runs: &[Run],
        _mean: &MeanTrajectory,
        n_runs: usize,
    ) -> Result<()> {
        std::fs::write(path, format!("{title}\n{} of {n_runs}\n", runs.len()))?;
        Ok(())
    }
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("omnikin-io-shards-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn two_shards_merge_into_the_single_runs_files() {
    let root = scratch("merge");
    let d = RobotDescription::resolve("kiwi").unwrap();
    let robot = d.build::<f64>().unwrap();
    let series = omnikin_sim::reproduce::sphere_2019_series(
        &RobotDescription::resolve("sphere-omni").unwrap(),
        50.0,
    )
    .unwrap();
    // A kiwi follows the sphere's 0.2 m/s square (the plan is only a path in time).
    let plan = series[1].plan.clone();
    let plan_path = root.join("plan.csv");
    plan.write_csv(std::fs::File::create(&plan_path).unwrap())
        .unwrap();
    let plan = Plan::load_csv(&plan_path).unwrap();
    let profile = Profile::from_toml_str(
        "[wheel_motor]\nfluctuation_rel = 0.05\nfluctuation_period = 0.05\nradius_error_std = 0.01\n\
         [tracking]\nnoise_std = 0.002\n",
        "profile.toml",
    )
    .unwrap();
    let (trials, seed) = (7u64, 11u64);
    let mut dirs = Vec::new();
    for k in 1..=2 {
        let out = root.join(format!("shard-{k}"));
        let run = SimulateRun {
            plan: &plan_path,
            disturbances: None,
            trials,
            seed,
            threads: Some(2),
            out: &out,
        };
        simulate_shard(
            &run,
            Shard { index: k, count: 2 },
            &d,
            &robot,
            &plan,
            &profile,
        )
        .unwrap();
        dirs.push(out);
    }
    let merged = root.join("merged");
    let figures = TitleFigures;
    let output = MergeOutput {
        out: &merged,
        threads: Some(2),
        figures: &figures,
    };
    // One shard alone is not the run.
    let err = merge(&dirs[..1], &output).unwrap_err().to_string();
    assert!(err.contains("shard 2/2 missing"), "{err}");
    merge(&dirs, &output).unwrap();

    // The same run in one piece.
    let single = root.join("single");
    create_dir_for(
        &single,
        &["metrics.json", "trials.csv", "mean.csv", "figure.txt"],
    )
    .unwrap();
    let reference = tracked_reference(&plan, [0.0; 2]);
    let mut csv = String::from(&omnikin_sim::run_columns::trial_columns(robot.wheels()).join(","));
    csv.push('\n');
    let mut row = Vec::new();
    let mc = omnikin_sim::simulate_and_evaluate(
        &robot,
        &plan,
        &reference,
        &profile,
        trials as usize,
        seed,
        &|| {},
        |i, t| -> Result<(), String> {
            for k in 0..t.t.len() {
                omnikin_sim::run_columns::trial_row(i, t, k, &mut row);
                csv.push_str(&omnikin_sim::run_columns::csv_line(&row));
                csv.push('\n');
            }
            Ok(())
        },
    )
    .unwrap();
    std::fs::write(single.join("trials.csv"), &csv).unwrap();
    let info = SimulationInfo {
        robot: d.name.clone(),
        kind: d.kind().to_string(),
        plan: plan_path.display().to_string(),
        disturbances: None,
        trials,
        seed,
        plant_rate_hz: profile.rate_hz(),
    };
    finish_simulation(&single, &info, &reference, mc, &figures).unwrap();
    for f in ["metrics.json", "trials.csv", "mean.csv", "figure.txt"] {
        let (a, b) = (
            std::fs::read(merged.join(f)).unwrap(),
            std::fs::read(single.join(f)).unwrap(),
        );
        assert!(a == b, "{f} differs between the merge and the single run");
    }
    let _ = std::fs::remove_dir_all(&root);
}
