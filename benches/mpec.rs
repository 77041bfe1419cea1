//! Whole `die_saddle` MPEC plan (600 x 400 mm, D63R6, delta 0.01), target < 0.5 s in release.
//! Run: cargo bench --bench mpec

use criterion::{criterion_group, criterion_main, Criterion};
use std::time::Duration;
use toolpath_planner::planners::{self, NoProgress};

fn die_saddle(c: &mut Criterion) {
    let job = toolpath_planner::samples::job("die_saddle").expect("sample job");
    let mut group = c.benchmark_group("mpec");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20));
    group.bench_function("die_saddle_plan", |b| {
        b.iter(|| planners::plan(&job, &NoProgress).expect("plans"))
    });
    group.finish();
}

criterion_group!(benches, die_saddle);
criterion_main!(benches);
