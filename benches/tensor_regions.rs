//! cargo bench --bench tensor_regions
//! Targets: the whole tensor_regions plan of wing_mould < 1 s
//! (release, 2-core machine); the simulator verifying it < 5 s.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use toolpath_planner::planners::{self, NoProgress};
use toolpath_planner::samples;
use toolpath_planner::simulation::scallop::{simulate, ScallopSettings};

fn benches(c: &mut Criterion) {
    let job = samples::job("wing_mould").expect("sample");
    let mut g = c.benchmark_group("wing_mould");
    g.sample_size(10);
    g.bench_function("tensor_regions_plan", |b| {
        b.iter(|| planners::plan(black_box(&job), &NoProgress).unwrap())
    });
    let result = planners::plan(&job, &NoProgress).unwrap();
    let surface = job.surface().unwrap();
    g.bench_function("tensor_regions_verify", |b| {
        b.iter(|| {
            simulate(
                surface,
                job.tool().unwrap(),
                black_box(&result),
                &ScallopSettings::default(),
            )
            .unwrap()
        })
    });
    g.finish();
}

criterion_group!(group, benches);
criterion_main!(group);
