//! The hierarchy's queries against brute force over every sample, on random
//! scenes, tools, poses, limits and machined sets: the best sample, the
//! certified margin and the fast "clear by" answer are the same values.

mod common;

use common::{random_scene, tools, Rng};
use nalgebra::Vector3;
use toolpath_collision::{Pose, QueryOptions, SamplingOptions, ToolPart, Workpiece};

#[test]
fn queries_equal_brute_force_over_all_samples() {
    let mut rng = Rng::new(21);
    let tools = tools();
    let mut compared = [0usize; 3];
    for scene in 0..6 {
        let faces = random_scene(&mut rng, 6);
        let mut opts = SamplingOptions::for_cutter_radius(rng.range(4.0, 12.0));
        opts.threads = 1 + scene % 2;
        let mut w = Workpiece::new(faces, opts).unwrap();
        let machined: Vec<usize> = (0..6).filter(|_| rng.range(0.0, 1.0) < 0.4).collect();
        w.set_machined(&machined).unwrap();
        for _ in 0..60 {
            let tool = &tools[(rng.next_u64() % 3) as usize];
            let tip = Vector3::new(
                rng.range(-50.0, 50.0),
                rng.range(-50.0, 50.0),
                rng.range(-25.0, 25.0),
            );
            let pose = Pose::new(tip, rng.unit()).unwrap();
            let q = QueryOptions {
                cutter_limit: rng.range(-1.0, 2.0),
                holder_limit: rng.range(-1.0, 3.0),
                cutter_all_faces: rng.range(0.0, 1.0) < 0.3,
                search_margin: rng.range(0.0, 3.0),
            };
            // Brute force: per part, least value and least value - cover.
            let n = tool.part_count();
            let mut least = vec![f64::INFINITY; n];
            let mut least_bound = vec![f64::INFINITY; n];
            for s in w.samples() {
                for (i, (l, lb)) in least.iter_mut().zip(least_bound.iter_mut()).enumerate() {
                    let part = ToolPart::from_index(i);
                    if i == 0 && !q.cutter_all_faces && w.is_machined(s.face as usize) {
                        continue;
                    }
                    let value = tool.signed_distance(&pose, part, &s.point);
                    *l = l.min(value);
                    *lb = lb.min(value - s.cover);
                }
            }
            let limit = |i: usize| q.limit(ToolPart::from_index(i));
            let margin = (0..n)
                .map(|i| least_bound[i] - limit(i))
                .fold(f64::INFINITY, f64::min);
            let cap = rng.range(0.0, 10.0);
            assert_eq!(w.certified_margin(tool, &pose, &q, cap), margin.min(cap));
            assert_eq!(w.clear_by(tool, &pose, &q), margin >= 0.0);
            let report = w.query(tool, &pose, &q);
            for (i, p) in report.parts.iter().enumerate() {
                let thr = limit(i) + q.search_margin;
                assert!(
                    p.lower_bound <= least_bound[i].min(thr),
                    "part {i}: bound above the samples'"
                );
                assert!(p.lower_bound <= p.distance);
                if least[i] < thr {
                    compared[i.min(2)] += 1;
                    assert_eq!(p.best_sample.map(|b| b.0), Some(least[i]), "part {i}");
                    assert!(p.distance <= least[i], "refinement only lowers");
                    let c = p.contact.unwrap();
                    let face = w.face(c.face);
                    assert!(face.inside(c.u, c.v), "the contact lies on the face");
                    let at = tool.signed_distance(&pose, p.part, &face.point(c.u, c.v));
                    assert!(
                        (at - p.distance).abs() < 1e-12,
                        "the distance is attained at the contact"
                    );
                }
            }
        }
    }
    assert!(
        compared.iter().all(|&c| c > 10),
        "too few comparisons: {compared:?}"
    );
}

#[test]
fn sampling_is_the_same_on_any_thread_count() {
    let mut rng = Rng::new(4);
    let faces = random_scene(&mut rng, 5);
    let mut opts = SamplingOptions::for_cutter_radius(5.0);
    opts.threads = 1;
    let one = Workpiece::new(faces.clone(), opts).unwrap();
    opts.threads = 3;
    let three = Workpiece::new(faces, opts).unwrap();
    assert_eq!(one.samples(), three.samples());
}
