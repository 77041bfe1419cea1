//! Scallop simulator timing on `wing_mould` (R = 2.5 flat-end, lead 5 deg):
//! the simulator verifying (1) a synthetic dense result of the size of the
//! tensor plan (iso-v passes 2.8 mm apart, points every 2 mm) and (2) each
//! milling planner's own plan of the sample (a strategy that fails to plan
//! is skipped).
//!
//! `cargo bench --bench scallop_sim`

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use toolpath_planner::formats::{Pass, PathPoint, PlanResult, Strategy};
use toolpath_planner::geometry::NurbsSurface;
use toolpath_planner::planners::{self, NoProgress};
use toolpath_planner::samples;
use toolpath_planner::simulation::scallop::{simulate, ScallopSettings};

/// Passes along u at iso-v lines `stepover` apart (in v, scaled to mm by the
/// domain), flat-end with lead `lambda` touching the surface at cc with the
/// lowest rim point.
fn synthetic(
    surface: &NurbsSurface,
    radius: f64,
    lambda: f64,
    stepover: f64,
    spacing: f64,
) -> PlanResult {
    let ((u0, u1), (v0, v1)) = surface.domain();
    let (len_u, len_v) = (
        (surface.point(u1, v0) - surface.point(u0, v0)).norm(),
        (surface.point(u0, v1) - surface.point(u0, v0)).norm(),
    );
    let npass = (len_v / stepover).ceil() as usize + 1;
    let npts = (len_u / spacing).ceil() as usize + 1;
    let mut result = PlanResult::new("bench", "iso_parametric");
    for k in 0..npass {
        let v = v0 + (v1 - v0) * k as f64 / (npass - 1) as f64;
        let points = (0..npts)
            .map(|i| {
                let u = u0 + (u1 - u0) * i as f64 / (npts - 1) as f64;
                let d = surface.derivs(u, v);
                let n = d.su.cross(&d.sv).normalize();
                let f = d.su.normalize();
                let axis = n * lambda.cos() + f * lambda.sin();
                let tip = d.p.coords - (f * lambda.cos() - n * lambda.sin()) * radius;
                PathPoint {
                    cc: [d.p.x, d.p.y, d.p.z],
                    cl: [tip.x, tip.y, tip.z],
                    axis: [axis.x, axis.y, axis.z],
                    uv: [u, v],
                    ..Default::default()
                }
            })
            .collect();
        result.passes.push(Pass {
            region: 0,
            points,
            min_strip_width: None,
        });
    }
    result
}

fn bench(c: &mut Criterion) {
    let job = samples::job("wing_mould").expect("sample job");
    let surface = job.surface().expect("surface").clone();
    let settings = ScallopSettings::with_resolution(job.simulation_resolution);
    let mut group = c.benchmark_group("scallop_sim");
    group.sample_size(10);

    let dense = synthetic(
        &surface,
        job.tool().unwrap().radius(),
        job.lead_angle(),
        2.8,
        2.0,
    );
    group.bench_function("wing_mould_synthetic_dense", |b| {
        b.iter(|| {
            simulate(&surface, job.tool().unwrap(), black_box(&dense), &settings)
                .expect("simulates")
        })
    });

    for strategy in [
        Strategy::TensorRegions,
        Strategy::IsoScallop,
        Strategy::IsoParametric,
    ] {
        let mut j = job.clone();
        j.strategy = strategy;
        // A strategy that fails to plan has nothing to time.
        let Ok(result) = planners::plan(&j, &NoProgress) else {
            continue;
        };
        group.bench_function(format!("wing_mould_{}", strategy.name()), |b| {
            b.iter(|| {
                simulate(&surface, job.tool().unwrap(), black_box(&result), &settings)
                    .expect("simulates")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
