//! Tube planning benches (issue 16, docs/planning.md "Speed"); `cargo xtask bench` runs them
//! and writes `plan_ms_paper_map`, `plan_ms_500_obstacles` and `plan_ms_grid_1000` to bench.json.
//!
//! - `plan/paper_map`: the 11 obstacles of scenarios/paper-10uav.toml, exact clearance.
//! - `plan/obstacles_500`: 25 seeded groves of 20 trunks (500 circles), 100 m x 60 m, exact clearance.
//! - `plan/grid_1000`: a 1000 x 1000 cell grid (0.05 m cells, a 60-trunk forest over
//!   50 m x 50 m), distance transform included.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use host_sim::map::{forest::forest, Grid, LoadedMap, Map};
use host_sim::scenario;

/// The map of `plan/obstacles_500`: 25 groves of 20 trunks (500 circles) over 100 m x 60 m, a
/// grove's trunks within 5 m of its seeded centre; start, goal, map.
pub fn forest_500() -> ([f64; 2], [f64; 2], LoadedMap) {
    let (start, goal) = ([2.0, 30.0], [98.0, 30.0]);
    let Map::Geometric { shapes: centres, .. } = forest(500, 25, [8.0, 92.0, 0.0, 60.0], [5.0, 5.0], &[start, goal], 6.0) else { unreachable!() };
    let mut shapes = Vec::new();
    for (k, c) in centres.iter().enumerate() {
        let host_sim::map::Shape::Circle { center_m, .. } = c else { continue };
        let b = [center_m[0] - 5.0, center_m[0] + 5.0, center_m[1] - 5.0, center_m[1] + 5.0];
        if let Map::Geometric { shapes: grove, .. } = forest(k as u64, 20, b, [0.15, 0.4], &[], 0.0) {
            shapes.extend(grove);
        }
    }
    (start, goal, LoadedMap { source_name: "groves-500".into(), map: Map::Geometric { bounds_m: [0.0, 100.0, 0.0, 60.0], shapes } })
}

/// 1000 x 1000 cells of 0.05 m: a 60-trunk forest over 50 m x 50 m, rasterised.
fn grid_1000_cells() -> Vec<bool> {
    let m = LoadedMap { source_name: "g".into(), map: forest(1000, 60, [0.0, 50.0, 0.0, 50.0], [0.3, 1.0], &[GRID_START, GRID_GOAL], 4.0) };
    (0..1_000_000).map(|k| m.clearance_m([(k % 1000) as f64 * 0.05 + 0.025, (k / 1000) as f64 * 0.05 + 0.025]) <= 0.0).collect()
}

/// Terminals on the grid, m.
const GRID_START: [f64; 2] = [2.0, 25.0];
/// See [`GRID_START`].
const GRID_GOAL: [f64; 2] = [48.0, 25.0];

fn plan(c: &mut Criterion) {
    let paper = scenario::load(None).expect("built-in scenario");
    let params = host_sim::map::params_for(&paper.scenario);
    let world = LoadedMap::from_world(&paper.scenario, "paper");
    let mut g = c.benchmark_group("plan");
    g.bench_function("paper_map", |b| b.iter(|| black_box(world.plan([2.0, 0.0], [48.0, 1.0], &params).expect("plans"))));
    let (s, e, f500) = forest_500();
    if let Err(e) = f500.plan(s, e, &params) {
        panic!("the 500-trunk forest: {e}");
    }
    g.bench_function("obstacles_500", |b| b.iter(|| black_box(f500.plan(s, e, &params).expect("plans"))));
    let cells = grid_1000_cells();
    g.bench_function("grid_1000", |b| {
        b.iter(|| {
            let grid = LoadedMap { source_name: "grid".into(), map: Map::Grid(Grid::new(1000, 1000, 0.05, [0.0, 0.0], cells.clone()).expect("grid")) };
            black_box(grid.plan(GRID_START, GRID_GOAL, &params).expect("plans"))
        });
    });
    g.finish();
}

fn config() -> Criterion {
    Criterion::default().measurement_time(Duration::from_secs(3)).sample_size(20)
}

criterion_group! {
    name = benches;
    config = config();
    targets = plan
}
criterion_main!(benches);
