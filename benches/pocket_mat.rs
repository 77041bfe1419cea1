//! cargo bench --bench pocket_mat
//! Targets: medial axis of a 10 000-vertex outline < 100 ms; the
//! whole leaf_pocket plan <= 60 ms (release; figures in docs/results.md).

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use toolpath_planner::geometry::medial_axis::medial_axis;
use toolpath_planner::geometry::Pocket;
use toolpath_planner::planners::{self, NoProgress};
use toolpath_planner::samples;

/// A wavy closed outline with `n` vertices (radius 50 +- 13 mm).
fn wavy_outline(n: usize) -> Pocket {
    let pts: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            let t = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            let r = 50.0 + 10.0 * (7.0 * t).sin() + 3.0 * (23.0 * t).sin();
            [r * t.cos(), r * t.sin()]
        })
        .collect();
    Pocket::new(&pts, &[]).expect("valid outline")
}

fn benches(c: &mut Criterion) {
    let outline = wavy_outline(10_000);
    c.bench_function("medial_axis_10000_vertices", |b| {
        b.iter(|| medial_axis(black_box(&outline)).unwrap())
    });
    let job = samples::job("leaf_pocket").expect("sample");
    let mut g = c.benchmark_group("plan");
    g.sample_size(10);
    g.bench_function("leaf_pocket_plan", |b| {
        b.iter(|| planners::plan(black_box(&job), &NoProgress).unwrap())
    });
    g.finish();
}

criterion_group!(pocket, benches);
criterion_main!(pocket);
