//! Surface evaluation speed: a bicubic NURBS surface evaluated with second
//! derivatives and curvature (LocalGeometry: normal, fundamental forms,
//! principal curvatures and directions). Target: >= 2 million points per
//! second on one core. Run: `cargo bench --bench surface_eval`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use toolpath_planner::geometry::LocalGeometry;
use toolpath_planner::samples::surfaces;

/// Scattered parameters (golden-ratio sequence), so that span lookups vary.
fn params(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|k| {
            let k = k as f64;
            (
                (k * 0.618_033_988_749_895).fract(),
                (k * 0.754_877_666_246_693).fract(),
            )
        })
        .collect()
}

fn surface_eval(c: &mut Criterion) {
    let pts = params(10_000);
    let mut group = c.benchmark_group("surface_eval");
    group.throughput(Throughput::Elements(pts.len() as u64));
    // wing_mould: bicubic 4 x 3 spans; egg_crate: bicubic 48 x 48 spans (deeper span search).
    for (name, s) in [
        ("wing_mould", surfaces::wing_mould()),
        ("egg_crate", surfaces::egg_crate()),
    ] {
        group.bench_with_input(BenchmarkId::new("local_geometry", name), &s, |b, s| {
            b.iter(|| {
                let mut acc = 0.0;
                for &(u, v) in &pts {
                    if let Some(g) = LocalGeometry::at(s, black_box(u), black_box(v)) {
                        acc += g.k_min + g.k_max + g.dir_min.x;
                    }
                }
                acc
            })
        });
        group.bench_with_input(BenchmarkId::new("derivs", name), &s, |b, s| {
            b.iter(|| {
                let mut acc = 0.0;
                for &(u, v) in &pts {
                    let d = s.derivs(black_box(u), black_box(v));
                    acc += d.suu.z + d.suv.z + d.svv.z;
                }
                acc
            })
        });
        group.bench_with_input(BenchmarkId::new("point", name), &s, |b, s| {
            b.iter(|| {
                let mut acc = 0.0;
                for &(u, v) in &pts {
                    acc += s.point(black_box(u), black_box(v)).z;
                }
                acc
            })
        });
    }
    // Rational surface (exact cylinder, quadratic x linear) for the rational path.
    let cyl = surfaces::concave_cylinder();
    group.bench_function(
        BenchmarkId::new("local_geometry", "concave_cylinder_rational"),
        |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for &(u, v) in &pts {
                    if let Some(g) = LocalGeometry::at(&cyl, black_box(u), black_box(v)) {
                        acc += g.k_max;
                    }
                }
                acc
            })
        },
    );
    group.finish();
}

criterion_group!(benches, surface_eval);
criterion_main!(benches);
