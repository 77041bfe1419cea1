//! STEP import against exact answers: the parts of tests/data/step, written
//! by tests/python/make_step_parts.py with Open CASCADE, whose face areas
//! (BRepGProp) are in tests/data/step/parts.json. A trimmed plane of known
//! area (in mm and in inches), a cylinder patch (area and curvature 1/R), a
//! B-spline face with a hole (with and without pcurves), a rational face
//! whose orientation is reversed; the freeform face planned and judged by
//! the simulator within h on the face; bad files refused naming the entity.

use serde_json::json;
use std::path::{Path, PathBuf};
use toolpath_planner::error::Error;
use toolpath_planner::formats::step::{StepFile, LIST_CELLS};
use toolpath_planner::formats::{Job, JobFile};
use toolpath_planner::geometry::{LocalGeometry, NurbsSurface};
use toolpath_planner::pipeline::{self, RunOptions};
use toolpath_planner::planners::NoProgress;

/// Relative area error the integration over the trimmed face may make: its
/// boundary cells are counted by subcell (docs/methods.md, "Trimmed faces").
const AREA_REL: f64 = 5e-4;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/step")
}

fn manifest() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir().join("parts.json")).unwrap()).unwrap()
}

/// The only face of a part, imported and validated.
fn only_face(name: &str) -> (StepFile, NurbsSurface) {
    let file = StepFile::read(&dir().join(format!("{name}.step"))).unwrap();
    let ids = file.face_ids();
    assert_eq!(ids.len(), 1, "{name}: faces {ids:?}");
    let s = file.face(ids[0]).unwrap().to_surface().unwrap();
    (file, s)
}

fn area(s: &NurbsSurface) -> f64 {
    s.trim().unwrap().face_area(s, LIST_CELLS)
}

#[test]
fn every_part_has_open_cascades_area() {
    let m = manifest();
    for (name, part) in m.as_object().unwrap() {
        let (_, s) = only_face(name);
        let exact = part["area_mm2"].as_f64().unwrap();
        let a = area(&s);
        eprintln!("{name}: {a:.4} mm² (Open CASCADE {exact:.4})");
        assert!(
            (a - exact).abs() <= AREA_REL * exact,
            "{name}: {a} vs {exact}"
        );
    }
}

#[test]
fn the_plane_with_a_hole_has_its_exact_area_in_mm_and_in_inches() {
    let exact = 100.0 * 60.0 - std::f64::consts::PI * 15.0 * 15.0;
    for name in ["plane_hole", "plane_hole_inch"] {
        let (file, s) = only_face(name);
        let unit = if name.ends_with("inch") { 25.4 } else { 1.0 };
        assert_eq!(file.mm_per_unit(), unit);
        let a = area(&s);
        assert!(
            (a - exact).abs() <= AREA_REL * exact,
            "{name}: {a} vs {exact}"
        );
        // The hole's loop is the circle of radius 15 mm about (35, 30).
        let trim = s.trim().unwrap();
        assert_eq!(trim.holes.len(), 1);
        for q in &trim.holes[0] {
            let p = s.point(q[0], q[1]);
            let r = (p.x - 35.0).hypot(p.y - 30.0);
            assert!((r - 15.0).abs() < 1e-9 && p.z.abs() < 1e-12, "{p:?}");
        }
        let (lo, hi) = s.bounding_box();
        assert!(
            (lo.x - 0.0).abs() < 1e-9 && (hi.x - 100.0).abs() < 1e-9,
            "{lo:?} {hi:?}"
        );
        assert!(
            (lo.y - 0.0).abs() < 1e-9 && (hi.y - 60.0).abs() < 1e-9,
            "{lo:?} {hi:?}"
        );
    }
}

#[test]
fn the_cylinder_patch_has_curvature_one_over_r_and_an_outward_normal() {
    let (_, s) = only_face("cylinder");
    let ((u0, u1), (v0, v1)) = s.domain();
    for i in 0..=8 {
        for j in 0..=4 {
            let (u, v) = (
                u0 + (u1 - u0) * i as f64 / 8.0,
                v0 + (v1 - v0) * j as f64 / 4.0,
            );
            let p = s.point(u, v);
            assert!(
                (p.x.hypot(p.y) - 20.0).abs() < 1e-9,
                "{p:?} off the cylinder"
            );
            let g = LocalGeometry::at(&s, u, v).unwrap();
            // Outward normal: the cylinder is convex seen from it.
            let radial = nalgebra::Vector3::new(p.x, p.y, 0.0) / 20.0;
            assert!((g.n - radial).norm() < 1e-9, "normal {:?} at {p:?}", g.n);
            let (k_lo, k_hi) = (g.k_min.min(g.k_max), g.k_min.max(g.k_max));
            assert!(k_hi.abs() < 1e-9, "k {k_lo} {k_hi}");
            assert!((k_lo.abs() - 1.0 / 20.0).abs() < 1e-9, "k {k_lo} {k_hi}");
        }
    }
}

#[test]
fn a_reversed_face_gets_the_faces_normal() {
    // The rational surface's own normal points to +z; the face is reversed.
    let (_, s) = only_face("rational_reversed");
    let trim = s.trim().unwrap();
    let q = trim.outer[0];
    let c: [f64; 2] = trim
        .outer
        .iter()
        .fold([0.0, 0.0], |a, p| [a[0] + p[0], a[1] + p[1]]);
    let c = [
        c[0] / trim.outer.len() as f64,
        c[1] / trim.outer.len() as f64,
    ];
    assert!(s.in_face(c[0], c[1]), "centre {c:?} of {q:?}");
    let n = s.normal(c[0], c[1]).unwrap();
    assert!(n.z < -0.5, "normal {n:?}");
}

#[test]
fn pcurves_and_projected_edges_give_the_same_face() {
    let (_, a) = only_face("freeform");
    let (_, b) = only_face("freeform_nopcurves");
    assert_eq!(a.domain(), b.domain());
    let (ta, tb) = (a.trim().unwrap(), b.trim().unwrap());
    // Every projected loop point lies on the pcurve loop within the
    // sampling tolerance (mm on the surface).
    for (la, lb) in [(&ta.outer, &tb.outer), (&ta.holes[0], &tb.holes[0])] {
        for q in lb {
            let d = la
                .windows(2)
                .map(|w| seg_dist_mm(&a, *q, w[0], w[1]))
                .fold(f64::INFINITY, f64::min);
            assert!(d < 2e-3, "{q:?} is {d} mm off");
        }
    }
}

/// Distance (mm) from the surface point at `q` to the image of the (u, v)
/// segment a-b, by dense sampling.
fn seg_dist_mm(s: &NurbsSurface, q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let p = s.point(q[0], q[1]);
    (0..=20)
        .map(|k| {
            let t = k as f64 / 20.0;
            (s.point(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])) - p).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn the_freeform_face_plans_within_h_on_the_face() {
    let file = StepFile::read(&dir().join("freeform.step")).unwrap();
    let surface = serde_json::to_value(file.face(17).unwrap()).unwrap();
    let h = 0.05;
    for strategy in ["iso_scallop", "tensor_regions"] {
        let j = json!({
            "job_id": "step_freeform",
            "surface": surface,
            "strategy": strategy,
            "tool": {"kind": "ball", "radius": 4.0},
            "scallop": h,
        });
        let file: JobFile = serde_json::from_value(j).unwrap();
        let job = Job::from_file(file, None).unwrap();
        let s = job.surface().unwrap();
        let r = pipeline::run(&job, &NoProgress, RunOptions::default()).unwrap();
        let st = &r.stats;
        let scallop = st.max_scallop_mm.unwrap();
        let machined = st.extra["machined_area_mm2"];
        let a = area(s);
        eprintln!(
            "{strategy}: {:.1} mm, scallop {scallop:.5} (h {h}), machined {machined:.1} of {a:.1} mm²",
            st.path_length_mm
        );
        assert!(scallop <= h, "{strategy}: scallop {scallop}");
        assert_eq!(r.within_scallop, Some(true), "{strategy}");
        assert_eq!(st.extra["uncovered_area_mm2"], 0.0, "{strategy}");
        assert!(
            (machined - a).abs() <= 0.01 * a,
            "{strategy}: {machined} vs {a}"
        );
    }
}

fn invalid_message(e: Error) -> String {
    match &e {
        Error::Invalid { .. } => e.to_string(),
        other => panic!("not an input error: {other:?}"),
    }
}

fn parse(text: &str) -> Result<StepFile, Error> {
    StepFile::parse(text, "part.step", "part")
}

#[test]
fn bad_step_input_is_a_clear_error_naming_the_entity() {
    let text = std::fs::read_to_string(dir().join("cylinder.step")).unwrap();
    // Truncated.
    let e = invalid_message(parse(&text[..text.len() / 2]).err().unwrap());
    assert!(e.contains("truncated"), "{e}");
    // Not a STEP file at all.
    let e = invalid_message(parse("{\"kind\": \"nurbs\"}").err().unwrap());
    assert!(e.contains("not a STEP file"), "{e}");
    // Garbled inside.
    let garbled = text.replacen("#17 = ADVANCED_FACE(", "#17 = ADVANCED_FACE((", 1);
    let e = invalid_message(parse(&garbled).err().unwrap());
    assert!(e.contains("not valid STEP"), "{e}");
    // An unsupported surface.
    let sphere = text.replacen(
        "CYLINDRICAL_SURFACE('',#34,20.)",
        "SPHERICAL_SURFACE('',#34,20.)",
        1,
    );
    let f = parse(&sphere).unwrap();
    let e = invalid_message(f.face(17).err().unwrap());
    assert!(
        e.contains("#33 SPHERICAL_SURFACE") && e.contains("not a supported surface"),
        "{e}"
    );
    // A face id that does not exist, and one that is no face.
    let f = parse(&text).unwrap();
    let e = invalid_message(f.face(9999).err().unwrap());
    assert!(e.contains("no entity #9999") && e.contains("#17"), "{e}");
    let e = invalid_message(f.face(18).err().unwrap());
    assert!(
        e.contains("#18 FACE_BOUND") && e.contains("not a face"),
        "{e}"
    );
    // A reference to nothing.
    let dangling = text.replacen(
        "#17 = ADVANCED_FACE('',(#18),#33,.T.)",
        "#17 = ADVANCED_FACE('',(#18),#12345,.T.)",
        1,
    );
    let f = parse(&dangling).unwrap();
    let e = invalid_message(f.face(17).err().unwrap());
    assert!(e.contains("#12345"), "{e}");
    // An unsupported edge curve.
    let curve = text.replacen(
        "#27 = CIRCLE('',#28,20.)",
        "#27 = HYPERBOLA('',#28,20.,3.)",
        1,
    );
    let f = parse(&curve).unwrap();
    let e = invalid_message(f.face(17).err().unwrap());
    assert!(e.contains("#27 HYPERBOLA"), "{e}");
}

#[test]
fn a_job_names_a_step_face_directly() {
    let imported = serde_json::to_value(
        StepFile::read(&dir().join("freeform.step"))
            .unwrap()
            .face(17)
            .unwrap(),
    )
    .unwrap();
    let job_with = |surface: serde_json::Value| {
        let file: JobFile = serde_json::from_value(json!({
            "job_id": "step_face_job",
            "surface": surface,
            "strategy": "iso_scallop",
            "tool": {"kind": "ball", "radius": 4.0},
            "scallop": 0.05,
        }))
        .unwrap();
        Job::from_file(file, Some(&dir()))
    };
    // The same geometry (trim included) as importing the face and embedding it.
    let by_reference = job_with(json!({"file": "freeform.step", "face": 17})).unwrap();
    let embedded = job_with(imported).unwrap();
    assert_eq!(
        by_reference.shape.fingerprint(),
        embedded.shape.fingerprint()
    );
    assert!(by_reference.surface().unwrap().trim().is_some());
    for (face, want) in [
        (json!(999_999), "999999"),
        (json!("17"), "surface.face"),
        (json!(-3), "surface.face"),
    ] {
        let e = job_with(json!({"file": "freeform.step", "face": face})).expect_err("refused");
        let text = e.to_string();
        assert!(text.contains(want) && text.contains("surface"), "{text}");
        assert!(!text.contains('\n'), "{text}");
    }
}
