//! Monte-Carlo throughput: 1000 trials of paper 000's 0.1 m/s square (16.8 s) with the plant at
//! 1 kHz under the `hardware` disturbance profile. Criterion reports the time per 1000 trials;
//! trials/s = 1000 / that time.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use omnikin::description::RobotDescription;
use omnikin_plan::RobotModel;
use omnikin_plan::generators::Square;
use omnikin_plan::planner::{OnLimit, plan};
use omnikin_sim::reproduce::hardware_profile;
use omnikin_sim::run_trials;

fn monte_carlo(c: &mut Criterion) {
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let robot = d.build::<f64>().unwrap();
    let sq = Square::paper(1.0);
    let model = RobotModel::from_description(&d).unwrap();
    let square = plan(
        &sq.path().unwrap(),
        &sq.heading(),
        &model,
        &sq.options(100.0, OnLimit::Reject),
    )
    .unwrap()
    .plan;
    let profile = hardware_profile();
    let mut g = c.benchmark_group("monte_carlo");
    g.sample_size(10);
    g.throughput(Throughput::Elements(1000));
    g.bench_function("square_0.1_m_per_s_1khz_1000_trials", |b| {
        b.iter(|| run_trials(&robot, &square, &profile, 1000, 1, &|| {}).unwrap())
    });
    g.finish();
}

criterion_group!(benches, monte_carlo);
criterion_main!(benches);
