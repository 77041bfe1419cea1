//! Pose-query speed on a part of 6 faces at about 1e5 samples (spacing 0.7 mm): a pocket
//! with a wavy floor (the machined face), four walls and a boss; a flat end
//! R 5 with a shank and a conical holder. Target: under 100 us per pose in
//! the clear case (3000 poses within twice a 0.5 s plan).
//!
//! CARGO_TARGET_DIR=/work/helpers/target-collision \
//!   cargo bench --manifest-path crates/collision/Cargo.toml --bench pose_query

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nalgebra::Vector3;
use std::hint::black_box;
use std::sync::Arc;
use toolpath_collision::shapes::{Cylinder, Plane, Wave};
use toolpath_collision::{
    Cutter, Face, HolderSegment, Pose, QueryOptions, SamplingOptions, ToolAssembly, Workpiece,
};

const POSES: usize = 200;

fn floor() -> Wave {
    Wave {
        base: 0.0,
        amplitude: 3.0,
        wavelength: 12.0,
        u: [0.0, 100.0],
        v: [0.0, 80.0],
    }
}

fn faces() -> Vec<Arc<dyn Face>> {
    let wall = |origin: Vector3<f64>, e_u: Vector3<f64>, len: f64| -> Arc<dyn Face> {
        Arc::new(Plane {
            origin,
            e_u,
            e_v: Vector3::z(),
            u: [0.0, len],
            v: [-5.0, 40.0],
        })
    };
    vec![
        Arc::new(floor()),
        wall(Vector3::zeros(), Vector3::x(), 100.0),
        wall(Vector3::new(0.0, 80.0, 0.0), Vector3::x(), 100.0),
        wall(Vector3::zeros(), Vector3::y(), 80.0),
        wall(Vector3::new(100.0, 0.0, 0.0), Vector3::y(), 80.0),
        Arc::new(Cylinder {
            base: Vector3::new(50.0, 40.0, 0.0),
            x: Vector3::x(),
            y: Vector3::y(),
            axis: Vector3::z(),
            radius: 10.0,
            theta: [0.0, std::f64::consts::TAU],
            height: [-3.0, 20.0],
        }),
    ]
}

fn tool() -> ToolAssembly {
    ToolAssembly::new(
        Cutter::flat_end(5.0, 30.0),
        vec![
            HolderSegment::cylinder(40.0, 5.0),
            HolderSegment::cone(60.0, 16.0, 20.0),
        ],
    )
    .expect("tool")
}

fn options() -> SamplingOptions {
    let mut o = SamplingOptions::for_cutter_radius(5.0);
    o.spacing = 0.7;
    o.boundary_spacing = 0.35;
    o
}

/// Poses on the floor along its normal, the cutter's axis at least `gap`
/// from the walls and the boss (a golden-ratio sequence: the same poses on
/// every run).
fn floor_poses(gap: f64) -> Vec<Pose> {
    let f = floor();
    let mut out = Vec::new();
    let mut k = 0.0f64;
    while out.len() < POSES {
        k += 1.0;
        let x = gap + (k * 0.618_033_988_75).fract() * (100.0 - 2.0 * gap);
        let y = gap + (k * 0.414_213_562_37).fract() * (80.0 - 2.0 * gap);
        if (x - 50.0).hypot(y - 40.0) < 10.0 + gap {
            continue;
        }
        let d = f.derivatives(x, y);
        let n = d.su.cross(&d.sv).normalize();
        out.push(Pose::new(d.p, n).expect("pose"));
    }
    out
}

fn pose_queries(c: &mut Criterion) {
    let mut work = Workpiece::new(faces(), options()).expect("part");
    work.set_machined(&[0]).expect("machined");
    eprintln!(
        "samples: {} (per face {:?}), largest cover radius {:.3} mm",
        work.samples().len(),
        work.samples_per_face(),
        work.max_cover()
    );
    let tool = tool();
    let opts = QueryOptions::new(0.01, 1.0);
    let clear = floor_poses(12.0);
    let near = floor_poses(5.5);
    let certified = clear
        .iter()
        .filter(|p| work.clear_by(&tool, p, &opts))
        .count();
    let colliding = near
        .iter()
        .filter(|p| work.query(&tool, p, &opts).collides())
        .count();
    eprintln!("clear poses certified by the fast path: {certified}/{POSES}; near poses colliding: {colliding}/{POSES}");
    let mut g = c.benchmark_group("pose_query");
    g.throughput(Throughput::Elements(POSES as u64));
    g.bench_function("clear_by/clear", |b| {
        b.iter(|| {
            clear
                .iter()
                .filter(|p| work.clear_by(&tool, black_box(p), &opts))
                .count()
        })
    });
    g.bench_function("query/clear", |b| {
        b.iter(|| {
            clear
                .iter()
                .filter(|p| work.query(&tool, black_box(p), &opts).collides())
                .count()
        })
    });
    let check =
        |p: &Pose| work.clear_by(&tool, p, &opts) || !work.query(&tool, p, &opts).collides();
    g.bench_function("check/clear", |b| {
        b.iter(|| clear.iter().filter(|p| check(black_box(p))).count())
    });
    g.bench_function("check/near_walls", |b| {
        b.iter(|| near.iter().filter(|p| check(black_box(p))).count())
    });
    g.finish();
}

fn build(c: &mut Criterion) {
    let mut g = c.benchmark_group("workpiece");
    g.sample_size(10);
    g.bench_function("sample_and_index_1e5", |b| {
        b.iter(|| {
            Workpiece::new(faces(), options())
                .expect("part")
                .samples()
                .len()
        })
    });
    g.finish();
}

criterion_group!(benches, pose_queries, build);
criterion_main!(benches);
