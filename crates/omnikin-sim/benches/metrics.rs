//! Scaling of the metrics: one tracked run against a plan of the same number of samples, from
//! 10^3 to 10^6 rows (10^6 = 2.8 h at 100 Hz), on two kinds of path:
//!
//! * `meander` — a path that never comes back (a slalom at 0.3 m/s): `evaluate` is
//!   O(n log n), the time per row grows only with log n;
//! * `laps` — a figure-eight of 60 s driven again and again, drifting 6 cm per lap (166 laps at
//!   10^6 rows): where laps overlap, every lap near a sample is a candidate nearest segment, so
//!   the exact distance costs O(laps) per sample there.
//!
//! The exhaustive scan it replaced (every sample against every segment, O(n²)) is measured at
//! 10^3 and 10^4 rows for comparison; at 10^5 it takes minutes.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use omnikin::{Pose2, Twist2};
use omnikin_plan::{Plan, Sample};
use omnikin_sim::metrics::{PathIndex, Run, distance_to_path, evaluate};
use std::hint::black_box;

/// The plan at 100 Hz; the run follows it with ±1 cm of deterministic noise.
fn plan_and_run(n: usize, laps: bool) -> (Plan, Run) {
    let xy: Vec<[f64; 2]> = (0..n)
        .map(|k| {
            let t = k as f64 * 0.01;
            if laps {
                let a = core::f64::consts::TAU * t / 60.0;
                [2.0 * a.sin() + 0.001 * t, (2.0 * a).sin()]
            } else {
                [0.3 * t, 0.5 * (t / 5.0).sin()]
            }
        })
        .collect();
    let plan = Plan {
        wheels: 3,
        samples: xy
            .iter()
            .enumerate()
            .map(|(k, p)| Sample {
                t: k as f64 * 0.01,
                pose: Pose2::new(p[0], p[1], 0.0),
                twist: Twist2::new(0.0, 0.0, 0.0),
                wheel_rates: [0.0; omnikin::MAX_WHEELS],
                steer: None,
            })
            .collect(),
    };
    let noise = |k: usize| ((k.wrapping_mul(2_654_435_761) % 2001) as f64 - 1000.0) * 1e-5;
    let run = Run {
        xy: xy
            .iter()
            .enumerate()
            .map(|(k, p)| [p[0] + noise(k), p[1] + noise(k + 7)])
            .collect(),
        heading: None,
    };
    (plan, run)
}

fn metrics(c: &mut Criterion) {
    let mut g = c.benchmark_group("metrics");
    g.sample_size(10);
    for n in [1_000, 10_000, 100_000, 1_000_000] {
        g.throughput(Throughput::Elements(n as u64));
        let (plan, run) = plan_and_run(n, true);
        g.bench_with_input(BenchmarkId::new("evaluate/laps", n), &n, |b, _| {
            b.iter(|| evaluate(black_box(&plan), std::slice::from_ref(&run)).unwrap())
        });
        let (plan, run) = plan_and_run(n, false);
        g.bench_with_input(BenchmarkId::new("evaluate/meander", n), &n, |b, _| {
            b.iter(|| evaluate(black_box(&plan), std::slice::from_ref(&run)).unwrap())
        });
        let path: Vec<[f64; 2]> = plan.samples.iter().map(|s| [s.pose.x, s.pose.y]).collect();
        g.bench_with_input(BenchmarkId::new("path_index/meander", n), &n, |b, _| {
            b.iter(|| {
                let index = PathIndex::new(black_box(&path));
                let mut hint = 0;
                let mut max = 0.0f64;
                for p in &run.xy {
                    let (d, seg) = index.nearest(*p, hint);
                    hint = seg;
                    max = max.max(d);
                }
                max
            })
        });
        if n <= 10_000 {
            g.bench_with_input(
                BenchmarkId::new("exhaustive_scan/meander", n),
                &n,
                |b, _| {
                    b.iter(|| {
                        run.xy
                            .iter()
                            .map(|p| distance_to_path(*p, black_box(&path)))
                            .fold(0.0, f64::max)
                    })
                },
            );
        }
    }
    g.finish();
}

criterion_group!(benches, metrics);
criterion_main!(benches);
