//! Cost of a dynamic trial: paper 000's eight series (squares and circles at 0.1, 0.2, 0.4,
//! 0.5 m/s, 100 Hz plans) through the shell + platform model with the shipped `sphere-omni`
//! preset's `[dynamics]`, each run `REPS` times; prints, per series and in total, the best
//! wall time per trial, the simulated time and their ratio (× real time), and the process's
//! CPU time per pass over the eight (Linux `/proc/self/stat`, 10 ms ticks: on a loaded
//! machine the CPU time is the steadier figure). Beside each series: its deterministic
//! figures at that sub-step (largest deviation, % of the path; circles: radius ratio), to
//! compare sub-steps.
//!
//! ```text
//! cargo run --release -p omnikin-sim --example sphere_trial_cost -- [SUBSTEP_S] [REPS]
//! ```
//! `SUBSTEP_S`: the RK4 sub-step `max_substep`, s (default: the preset's); `REPS`: repetitions
//! per series, the fastest is reported (default 5).

use omnikin::description::RobotDescription;
use omnikin_sim::dynamics::sphere::{SphereDynamics, simulate_plan};
use omnikin_sim::reproduce::{deterministic_figures, sphere_2019_series};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let d = RobotDescription::preset("sphere-omni").expect("preset");
    let mut p = SphereDynamics::from_description(&d).expect("dynamics");
    if let Some(h) = args.first() {
        p.max_substep = h.parse().expect("SUBSTEP_S: a number of seconds");
    }
    let reps: usize = args
        .get(1)
        .map(|r| r.parse().expect("REPS: a whole number"))
        .unwrap_or(5);
    let series = sphere_2019_series(&d, 100.0).expect("series");
    println!(
        "sub-step {} s, best of {reps}: series, wall per trial [ms], simulated [s], × real time, \
         max dev [%], radius ratio",
        p.max_substep
    );
    let (mut wall, mut simulated) = (0.0, 0.0);
    let mut cpu_runs = 0.0;
    for s in &series {
        let mut best = f64::INFINITY;
        let cpu0 = cpu_seconds();
        for _ in 0..reps {
            let t0 = Instant::now();
            let run = simulate_plan(p, &s.plan).expect("trial");
            best = best.min(t0.elapsed().as_secs_f64());
            std::hint::black_box(run);
        }
        if let (Some(a), Some(b)) = (cpu0, cpu_seconds()) {
            cpu_runs += b - a;
        }
        let span = s.plan.samples.last().unwrap().t - s.plan.samples[0].t;
        let (dev, ratio) = deterministic_figures(p, s).expect("figures");
        println!(
            "{:<11} {:>8.2} {:>7.2} {:>8.0} {:>9.4} {}",
            s.name,
            best * 1e3,
            span,
            span / best,
            dev,
            ratio.map_or("—".into(), |r| format!("{r:.5}"))
        );
        wall += best;
        simulated += span;
    }
    println!(
        "all eight  {:>8.2} {:>7.2} {:>8.0}",
        wall * 1e3,
        simulated,
        simulated / wall
    );
    if cpu_runs > 0.0 {
        let per_pass = cpu_runs / reps as f64;
        println!(
            "CPU time per pass over the eight: {:.1} ms ({:.0} × real time)",
            per_pass * 1e3,
            simulated / per_pass
        );
    }
}

/// This process's user + system CPU time, s (Linux: fields 14 and 15 of `/proc/self/stat`,
/// in clock ticks of 10 ms).
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The command name (field 2) is in parentheses and may hold spaces: count after it.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}
