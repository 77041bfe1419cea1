//! Belt-grinding speed targets: each belt plan of the built-in
//! samples under 0.5 s, and the Hamann removal simulation of a full egg_crate
//! run on a 500 x 500 height field under 2 s (release).
//!
//! cargo bench --bench belt

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;
use toolpath_planner::formats::Strategy;
use toolpath_planner::pipeline::{self, RunOptions};
use toolpath_planner::planners::NoProgress;
use toolpath_planner::simulation::removal::simulate_on_grid;
use toolpath_planner::tools::Tool;

fn belt_plans(c: &mut Criterion) {
    let mut g = c.benchmark_group("belt_plan");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    for name in ["sine_wave", "egg_crate", "turbine_blade"] {
        for strategy in [Strategy::BeltIsoParametric, Strategy::BeltIsoPlanar] {
            let mut job = toolpath_planner::samples::job(name).expect("sample");
            job.strategy = strategy;
            g.bench_function(format!("{name}/{}", strategy.name()), |b| {
                b.iter(|| {
                    pipeline::run(black_box(&job), &NoProgress, RunOptions::PLAN_ONLY)
                        .expect("plan")
                })
            });
        }
    }
    g.finish();
}

fn hamann_egg_crate(c: &mut Criterion) {
    let mut job = toolpath_planner::samples::job("egg_crate").expect("sample");
    job.strategy = Strategy::BeltIsoPlanar;
    let result = pipeline::run(&job, &NoProgress, RunOptions::PLAN_ONLY).expect("plan");
    let Tool::Belt {
        width,
        wheel_radius,
    } = job.tool.expect("a belt job has a tool")
    else {
        unreachable!("egg_crate is a belt job")
    };
    let surface = job.surface().expect("surface").clone();
    let mut g = c.benchmark_group("belt_removal");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("egg_crate_500x500", |b| {
        b.iter(|| {
            simulate_on_grid(
                &surface,
                black_box(&result),
                width,
                wheel_radius,
                &job.grinding,
                (500, 500),
                0.2,
            )
            .expect("simulate")
        })
    });
    g.finish();
}

criterion_group!(benches, belt_plans, hamann_egg_crate);
criterion_main!(benches);
