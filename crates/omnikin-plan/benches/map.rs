//! Finding the way across `examples/maps/cluttered.toml` (30 keep-out circles and polygons in
//! a 10 m keep-in square) for the sphere's 0.15 m footprint, corner to corner: the route
//! (visibility graph + A*), and the route smoothed and checked against the map. Issue 40's
//! target is under 50 ms for 30 obstacles; the figure is stated in docs/maps.md, never asserted.
//!
//! `cargo bench -p omnikin-plan --bench map` (or `-- --test` for one quick run of each).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use omnikin_plan::map::Map;
use omnikin_plan::map::goal::goal_path;
use omnikin_plan::map::route::shortest_route;

const MAP: &str = include_str!("../../../examples/maps/cluttered.toml");

fn bench(c: &mut Criterion) {
    let map = Map::from_toml(MAP, "examples/maps/cluttered.toml").unwrap();
    let (f, from, to) = (0.15, [0.5, 0.5], [9.5, 9.5]);
    let mut group = c.benchmark_group("cluttered map, 30 obstacles");
    group.sample_size(20);
    group.bench_function("route", |b| {
        b.iter(|| shortest_route(black_box(&map), f, from, to).unwrap())
    });
    group.bench_function("route + smoothing", |b| {
        b.iter(|| goal_path(black_box(&map), f, from, to).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
