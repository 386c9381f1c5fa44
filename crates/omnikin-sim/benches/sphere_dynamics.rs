//! Cost of one dynamic trial: paper 000's 0.4 m/s circle (0.2 m, one turn, full-speed start,
//! 100 Hz plan = 315 steps of 10 ms, each 5 RK4 sub-steps of 2 ms — the default since the
//! sub-step was raised from 1 ms — with the wheel-constraint projection) through the shell +
//! platform model (`dynamics::sphere`) with the default parameters. At the former 1 ms
//! sub-step Criterion reported 8.8 ms (8.2–9.3) per trial on the project's 2-core machine,
//! i.e. ≈ 2.8 µs per sub-step (four derivative evaluations, each a 6 × 6 Cholesky solve and a
//! 3 × 3 constraint solve, plus the projection); the 2 ms sub-step halves the sub-steps
//! (docs/sphere-dynamics.md, "Cost of a trial").

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use omnikin::description::RobotDescription;
use omnikin_sim::dynamics::sphere::{SphereDynamics, SphereSim, SphereState};
use omnikin_sim::reproduce::sphere_2019_series;
use std::hint::black_box;

fn sphere_dynamics(c: &mut Criterion) {
    let d = RobotDescription::preset("sphere-omni").unwrap();
    let series = sphere_2019_series(&d, 100.0).unwrap();
    let circle = &series
        .iter()
        .find(|s| s.name == "circle-0.4")
        .expect("the 0.4 m/s circle")
        .plan;
    let p = SphereDynamics::paper_000();
    let s0 = &circle.samples[0];
    let start = SphereState::at_rest(s0.pose.x, s0.pose.y, s0.pose.heading);
    let mut g = c.benchmark_group("sphere_dynamics");
    g.sample_size(20);
    g.throughput(Throughput::Elements(1));
    g.bench_function("circle_0.4_m_per_s_one_trial", |b| {
        b.iter(|| {
            let mut sim = SphereSim::with_state(p, start).unwrap();
            let mut last = [0.0; 2];
            for w in circle.samples.windows(2) {
                let r = w[1].wheel_rates;
                last = sim
                    .step(w[1].t - w[0].t, [r[0], r[1], r[2]])
                    .unwrap()
                    .tracked;
            }
            black_box(last)
        })
    });
    g.finish();
}

criterion_group!(benches, sphere_dynamics);
criterion_main!(benches);
