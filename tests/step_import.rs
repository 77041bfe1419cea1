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
use toolpath_planner::samples::step_parts;

/// Offsets, the B-spline forms, periodic surfaces, errors in a job and a
/// part's unreadable faces.
#[path = "step_import/forms.rs"]
mod forms;

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

/// Plans `job` through the pipeline (simulated, repaired where needed) and
/// checks it within the job's h by the simulator with nothing uncovered;
/// returns the machined area.
fn plans_within_h(label: &str, job: &Job) -> f64 {
    let r = pipeline::run(job, &NoProgress, RunOptions::default()).unwrap();
    let st = &r.stats;
    let h = job.scallop.unwrap();
    let scallop = st.max_scallop_mm.unwrap();
    eprintln!(
        "{label}: {:.1} mm, scallop {scallop:.5} (h {h})",
        st.path_length_mm
    );
    assert_eq!(r.within_scallop, Some(true), "{label}: scallop {scallop}");
    assert!(scallop <= h, "{label}: scallop {scallop}");
    assert_eq!(st.extra["uncovered_area_mm2"], 0.0, "{label}");
    st.extra["machined_area_mm2"]
}

/// [`plans_within_h`], and the machined area within 1 % of the trimmed
/// face's own area (by quadrature).
fn plans_the_face_within_h(label: &str, job: &Job) {
    let machined = plans_within_h(label, job);
    let a = area(job.surface().unwrap());
    eprintln!("{label}: machined {machined:.1} of {a:.1} mm²");
    assert!(
        (machined - a).abs() <= 0.01 * a,
        "{label}: {machined} vs {a}"
    );
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
            assert!(
                (g.forms.n - radial).norm() < 1e-9,
                "normal {:?} at {p:?}",
                g.forms.n
            );
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
        plans_the_face_within_h(strategy, &job);
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
    // Whole numbers too long for the parser (it would panic on them): the
    // line named; a long fraction is fine.
    let line = text[..text.find("CYLINDRICAL_SURFACE('',#34,20.)").unwrap()]
        .matches('\n')
        .count()
        + 1;
    for (long, why) in [
        ("20000000000000000000.", "20000000000000000000"),
        ("20.E1234567890123456789", "1234567890123456789"),
        ("20.", ""),
    ] {
        let t = text.replacen(
            "CYLINDRICAL_SURFACE('',#34,20.)",
            &format!("CYLINDRICAL_SURFACE('',#34,{long})"),
            1,
        );
        match parse(&t) {
            Ok(_) => assert!(why.is_empty(), "{long} was read"),
            Err(e) => {
                let e = invalid_message(e);
                assert!(
                    e.contains(&format!(
                        "line {line}: the number {why} has more than 18 digits"
                    )),
                    "{e}"
                );
            }
        }
    }
    let fraction = text.replacen(
        "CYLINDRICAL_SURFACE('',#34,20.)",
        "CYLINDRICAL_SURFACE('',#34,20.000000000000000000000000001)",
        1,
    );
    assert!(parse(&fraction).is_ok());
    // An unsupported surface.
    let unsupported = text.replacen(
        "CYLINDRICAL_SURFACE('',#34,20.)",
        "CURVE_BOUNDED_SURFACE('',#34,(#34),.F.)",
        1,
    );
    let f = parse(&unsupported).unwrap();
    let e = invalid_message(f.face(17).err().unwrap());
    assert!(
        e.contains("#33 CURVE_BOUNDED_SURFACE") && e.contains("not a supported surface"),
        "{e}"
    );
    // An offset of something that is no surface names that entity.
    let offset = text.replacen(
        "CYLINDRICAL_SURFACE('',#34,20.)",
        "OFFSET_SURFACE('',#34,20.,.F.)",
        1,
    );
    let e = invalid_message(parse(&offset).unwrap().face(17).err().unwrap());
    assert!(
        e.contains("#34 AXIS2_PLACEMENT_3D") && e.contains("not a supported surface"),
        "{e}"
    );
    // An offset of an offset of ... itself: a cycle, refused.
    let cycle = text.replacen(
        "CYLINDRICAL_SURFACE('',#34,20.)",
        "OFFSET_SURFACE('',#33,1.,.F.)",
        1,
    );
    let e = invalid_message(parse(&cycle).unwrap().face(17).err().unwrap());
    assert!(
        e.contains("#33 OFFSET_SURFACE") && e.contains("too deeply"),
        "{e}"
    );
    // A sphere of no radius.
    let sphere = text.replacen(
        "CYLINDRICAL_SURFACE('',#34,20.)",
        "SPHERICAL_SURFACE('',#34,0.)",
        1,
    );
    let e = invalid_message(parse(&sphere).unwrap().face(17).err().unwrap());
    assert!(
        e.contains("#33 SPHERICAL_SURFACE") && e.contains("not positive"),
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

/// Area element of the bicubic Bezier patch `cp` at (u, v), by central
/// differences of its points (independent of the NURBS evaluation).
fn area_element(cp: &[[[f64; 3]; 4]; 4], u: f64, v: f64) -> f64 {
    let h = 1e-6;
    let p = |u: f64, v: f64| nalgebra::Vector3::from(step_parts::bicubic_point(cp, u, v));
    let su = (p(u + h, v) - p(u - h, v)) / (2.0 * h);
    let sv = (p(u, v + h) - p(u, v - h)) / (2.0 * h);
    su.cross(&sv).norm()
}

/// Area of the patch over the ellipse with centre `c` and semi-axes `ab`
/// in (u, v): polar coordinates, trapezoid in the angle (periodic:
/// spectrally accurate), Simpson in the radius.
fn ellipse_area(cp: &[[[f64; 3]; 4]; 4], c: [f64; 2], ab: [f64; 2]) -> f64 {
    let (nt, nr) = (256, 200);
    let mut total = 0.0;
    for k in 0..nt {
        let t = std::f64::consts::TAU * k as f64 / nt as f64;
        for i in 0..=nr {
            let r = i as f64 / nr as f64;
            let w = if i == 0 || i == nr {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let (u, v) = (c[0] + ab[0] * r * t.cos(), c[1] + ab[1] * r * t.sin());
            total += w * area_element(cp, u, v) * ab[0] * ab[1] * r;
        }
    }
    total * std::f64::consts::TAU / nt as f64 / (3.0 * nr as f64)
}

/// Area of the patch over the whole unit square, composite Simpson.
fn square_area(cp: &[[[f64; 3]; 4]; 4]) -> f64 {
    let n = 200;
    let w = |i: usize| {
        if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        }
    };
    let mut total = 0.0;
    for i in 0..=n {
        for j in 0..=n {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            total += w(i) * w(j) * area_element(cp, u, v);
        }
    }
    total / (3.0 * n as f64).powi(2)
}

fn sample_part(name: &str) -> (StepFile, Vec<u64>) {
    let part = step_parts::part(name).unwrap();
    let file = StepFile::parse(&part.text, &format!("{name}.step"), name).unwrap();
    (file, part.faces)
}

#[test]
fn the_step_samples_import_with_their_exact_areas() {
    use step_parts::*;
    let pi = std::f64::consts::PI;
    // The freeform face: the ellipse's area on the patch minus the hole's.
    let cp = freeform_control_points();
    let exact_free = ellipse_area(&cp, FREEFORM_OUTER.0, FREEFORM_OUTER.1)
        - ellipse_area(&cp, FREEFORM_HOLE.0, [FREEFORM_HOLE.1; 2]);
    // The multi-face part: the bicubic face over its square; the plane
    // 40 x 80; the quarter cylinder r pi / 2 x 80; the wall under the
    // front edge, 20 mm deep plus the mean of the edge's control heights.
    let mean_front: f64 = MULTI_Z.iter().map(|row| row[0]).sum::<f64>() / 4.0;
    let expect: [(&str, Vec<(&str, f64)>); 2] = [
        (
            "step_freeform",
            vec![("B_SPLINE_SURFACE_WITH_KNOTS", exact_free)],
        ),
        (
            "step_multi_face",
            vec![
                (
                    "B_SPLINE_SURFACE_WITH_KNOTS",
                    square_area(&multi_control_points()),
                ),
                ("PLANE", MULTI_PLANE_W * MULTI_Y),
                ("CYLINDRICAL_SURFACE", MULTI_R * pi / 2.0 * MULTI_Y),
                ("PLANE", MULTI_X * (MULTI_WALL + mean_front)),
            ],
        ),
    ];
    for (name, faces) in expect {
        let (file, ids) = sample_part(name);
        assert_eq!(file.face_ids(), ids, "{name}");
        let listed = file.summaries();
        assert_eq!(listed.len(), faces.len(), "{name}");
        for (s, (kind, exact)) in listed.iter().zip(faces) {
            let extent = s.imported.clone().unwrap();
            let (a, lo, hi) = (extent.area_mm2, extent.lo, extent.hi);
            eprintln!(
                "{name} #{}: {kind} {a:.4} mm² (exact {exact:.4}), {lo:?}..{hi:?}",
                s.id
            );
            assert_eq!(s.surface_type, kind, "{name} #{}", s.id);
            assert!(
                (a - exact).abs() <= AREA_REL * exact,
                "{name} #{}: {a} vs {exact}",
                s.id
            );
        }
    }
    // The freeform sample's hole: its loop lies on the circle in (u, v).
    let (file, ids) = sample_part("step_freeform");
    let s = file.face(ids[0]).unwrap().to_surface().unwrap();
    let trim = s.trim().unwrap();
    assert_eq!(trim.holes.len(), 1);
    let (c, r) = FREEFORM_HOLE;
    for q in &trim.holes[0] {
        assert!(((q[0] - c[0]).hypot(q[1] - c[1]) - r).abs() < 1e-9, "{q:?}");
    }
    // The cylinder's points are at radius 30 about its axis, with an
    // outward normal and curvature 1/30 across the axis.
    let (file, ids) = sample_part("step_multi_face");
    let s = file.face(ids[2]).unwrap().to_surface().unwrap();
    let ((u0, u1), (v0, v1)) = s.domain();
    for k in 0..=8 {
        let (u, v) = (u0 + (u1 - u0) * k as f64 / 8.0, 0.5 * (v0 + v1));
        let p = s.point(u, v);
        let radial = nalgebra::Vector3::new(p.x - MULTI_X, 0.0, p.z + MULTI_R);
        assert!((radial.norm() - MULTI_R).abs() < 1e-9, "{p:?}");
        let g = LocalGeometry::at(&s, u, v).unwrap();
        assert!(
            (g.forms.n - radial / MULTI_R).norm() < 1e-9,
            "{:?} at {p:?}",
            g.forms.n
        );
        let k_abs = g.k_min.abs().max(g.k_max.abs());
        assert!((k_abs - 1.0 / MULTI_R).abs() < 1e-9, "{k_abs}");
    }
}

#[test]
fn a_face_of_each_step_sample_plans_within_h() {
    for name in step_parts::STEP_SAMPLES {
        let job = toolpath_planner::samples::job(name).unwrap();
        plans_the_face_within_h(name, &job);
    }
}

/// The job of a STEP sample's freeform face for mpec: torus R8 r2,
/// tolerance 0.05 (docs/results.md, "STEP samples").
fn mpec_job(name: &str) -> Job {
    let mut job = toolpath_planner::samples::job(name).unwrap();
    job.strategy = toolpath_planner::formats::Strategy::Mpec;
    job.tool = Some(toolpath_planner::tools::Tool::Torus {
        radius: 8.0,
        corner_radius: 2.0,
        length: None,
    });
    job.scallop = None;
    job.tolerance = Some(0.05);
    job.lead_angle_deg = None;
    job.feed_direction = Some(toolpath_planner::formats::FeedDirection::U);
    job
}

/// mpec plans both STEP samples' freeform faces (bent to radii of
/// about 50 mm, trimmed, one with a hole) and the simulator finds the face
/// within the tolerance band: residual and gouge at most 0.05, nothing
/// uncovered, the machined area the face's own.
#[test]
fn mpec_plans_each_step_sample_face_within_its_band() {
    for name in step_parts::STEP_SAMPLES {
        let job = mpec_job(name);
        let r = pipeline::run(&job, &NoProgress, RunOptions::default())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let st = &r.stats;
        let machined = st.extra["machined_area_mm2"];
        let a = area(job.surface().unwrap());
        eprintln!(
            "{name} mpec: {} passes, {:.1} mm, scallop {:.5}, gouge {:.5}, machined {machined:.1} of {a:.1} mm², {:?}",
            r.passes.len(),
            st.path_length_mm,
            st.max_scallop_mm.unwrap(),
            st.max_gouge_mm.unwrap(),
            r.warnings
        );
        assert_eq!(r.within_scallop, Some(true), "{name}: {:?}", r.warnings);
        assert!(st.max_scallop_mm.unwrap() <= 0.05, "{name}");
        assert!(
            st.max_gouge_mm.unwrap() <= 0.05 + pipeline::CONFORMANCE_SLACK_MM,
            "{name}"
        );
        assert_eq!(st.extra["uncovered_area_mm2"], 0.0, "{name}");
        assert!(
            (machined - a).abs() <= 0.01 * a,
            "{name}: {machined} vs {a}"
        );
        // Every point of the clipped plan is on the face or within the
        // cutter's reach of it.
        let s = job.surface().unwrap();
        let trim = s.trim().unwrap();
        for p in r.passes.iter().flat_map(|p| &p.points) {
            let (u, v) = (p.uv[0].clamp(0.0, 1.0), p.uv[1].clamp(0.0, 1.0));
            assert!(
                trim.contains(u, v) || trim.distance_mm(s, [u, v]) <= 8.0 * 4.0 + 2.0,
                "{name}: {:?}",
                p.uv
            );
        }
    }
}

/// Closed-form areas of the analytic parts (tests/python/make_step_parts.py).
#[test]
fn analytic_faces_have_their_closed_form_areas() {
    let pi = std::f64::consts::PI;
    let rad = |d: f64| d.to_radians();
    let slant = (40.0f64 * 40.0 + 15.0 * 15.0).sqrt();
    let cases = [
        // Cone frustum, 120 degrees of radii 30 and 15, 40 high.
        ("cone", (2.0 * pi / 3.0) / 2.0 * (30.0 + 15.0) * slant),
        // Sphere zone: angle R² (sin b - sin a).
        (
            "sphere_zone",
            pi / 2.0 * 25.0 * 25.0 * (rad(45.0).sin() - rad(-30.0).sin()),
        ),
        // The same sphere from latitude 30 degrees to its pole.
        ("sphere_pole", pi / 2.0 * 25.0 * 25.0 * (1.0 - 0.5)),
        // Torus patch: angle r (R (b - a) + r (sin b - sin a)).
        (
            "torus",
            rad(100.0) * 10.0 * (40.0 * rad(140.0) + 10.0 * (rad(80.0).sin() - rad(-60.0).sin())),
        ),
    ];
    for (name, exact) in cases {
        let (_, s) = only_face(name);
        let a = area(&s);
        eprintln!("{name}: {a:.4} mm² (closed form {exact:.4})");
        assert!(
            (a - exact).abs() <= AREA_REL * exact,
            "{name}: {a} vs {exact}"
        );
    }
}

/// Points of the face's domain on a grid (the face's own, trim ignored).
fn grid_uv(s: &NurbsSurface, n: usize) -> Vec<(f64, f64)> {
    let ((u0, u1), (v0, v1)) = s.domain();
    let mut out = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            out.push((
                u0 + (u1 - u0) * i as f64 / n as f64,
                v0 + (v1 - v0) * j as f64 / n as f64,
            ));
        }
    }
    out
}

fn principal(s: &NurbsSurface, u: f64, v: f64) -> (f64, f64, nalgebra::Vector3<f64>) {
    let g = LocalGeometry::at(s, u, v).unwrap();
    let (a, b) = (g.k_min.abs(), g.k_max.abs());
    (a.min(b), a.max(b), g.forms.n)
}

#[test]
fn analytic_faces_are_exact_with_their_curvatures_and_outward_normals() {
    // Sphere: every point at radius 25, normal radial, both curvatures 1/25.
    let (_, s) = only_face("sphere_zone");
    for (u, v) in grid_uv(&s, 8) {
        let p = s.point(u, v).coords;
        assert!((p.norm() - 25.0).abs() < 1e-9, "{p:?}");
        let (k1, k2, n) = principal(&s, u, v);
        assert!((n - p / 25.0).norm() < 1e-9, "{n:?} at {p:?}");
        assert!(
            (k1 - 0.04).abs() < 1e-9 && (k2 - 0.04).abs() < 1e-9,
            "{k1} {k2}"
        );
    }
    // Cone of semi-angle a (radius 30 at z = 0 to 15 at z = 40): on it,
    // normal outward, curvatures 0 along the ruling and cos a / rho across.
    let (_, s) = only_face("cone");
    let a = (15.0f64 / 40.0).atan();
    for (u, v) in grid_uv(&s, 8) {
        let p = s.point(u, v).coords;
        let rho = p.x.hypot(p.y);
        assert!((rho - (30.0 - p.z * a.tan())).abs() < 1e-9, "{p:?}");
        let (k1, k2, n) = principal(&s, u, v);
        let out = nalgebra::Vector3::new(p.x / rho * a.cos(), p.y / rho * a.cos(), a.sin());
        assert!((n - out).norm() < 1e-9, "{n:?} at {p:?}");
        assert!(k1.abs() < 1e-9, "{k1}");
        assert!((k2 - a.cos() / rho).abs() < 1e-9, "{k2} at {p:?}");
    }
    // Torus R 40, r 10: on it, normal away from the tube's centre circle; at
    // the outer equator (z = 0, rho = 50) curvatures 1/50 and 1/10.
    let (_, s) = only_face("torus");
    let tube_centre = |p: &nalgebra::Vector3<f64>| {
        let rho = p.x.hypot(p.y);
        nalgebra::Vector3::new(p.x / rho * 40.0, p.y / rho * 40.0, 0.0)
    };
    for (u, v) in grid_uv(&s, 8) {
        let p = s.point(u, v).coords;
        let d = p - tube_centre(&p);
        assert!((d.norm() - 10.0).abs() < 1e-9, "{p:?}");
        let (_, _, n) = principal(&s, u, v);
        assert!((n - d / 10.0).norm() < 1e-9, "{n:?} at {p:?}");
    }
    let ((u0, u1), (v0, v1)) = s.domain();
    let u = 0.5 * (u0 + u1);
    // The equator: z = 0 by bisection in v (z rises with v there).
    let (mut lo, mut hi) = (v0, v1);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if s.point(u, mid).z < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let p = s.point(u, lo).coords;
    assert!((p.x.hypot(p.y) - 50.0).abs() < 1e-9, "{p:?}");
    let (k1, k2, _) = principal(&s, u, lo);
    assert!(
        (k1 - 1.0 / 50.0).abs() < 1e-9 && (k2 - 0.1).abs() < 1e-9,
        "{k1} {k2}"
    );
    // The surface of revolution keeps its profile's distance from the axis
    // along each meridian (turning changes only the angle).
    let (_, s) = only_face("revolution");
    let ((u0, _), (v0, v1)) = s.domain();
    for j in 0..=8 {
        let v = v0 + (v1 - v0) * j as f64 / 8.0;
        let p0 = s.point(u0, v);
        for (u, _) in grid_uv(&s, 8).into_iter().step_by(9) {
            let p = s.point(u, v);
            assert!((p.x.hypot(p.y) - p0.x.hypot(p0.y)).abs() < 1e-9 && (p.z - p0.z).abs() < 1e-9);
        }
    }
}

#[test]
fn extruded_faces_are_exact_rulings_along_their_vector() {
    // The elliptic arc (semi-axes 30 and 18 in z = 0) swept along
    // (10, 0, 35): every point moved back along the vector to z = 0 lies on
    // the ellipse, and the u = const lines are rulings along the vector.
    let (_, s) = only_face("extrusion_arc");
    let dir = nalgebra::Vector3::new(10.0, 0.0, 35.0);
    for (u, v) in grid_uv(&s, 8) {
        let p = s.point(u, v).coords;
        let q = p - dir * (p.z / 35.0);
        let on = (q.x / 30.0).powi(2) + (q.y / 18.0).powi(2);
        assert!((on - 1.0).abs() < 1e-9, "{p:?} -> {q:?}: {on}");
    }
    // Both faces: rulings straight along the vector (developable: Gaussian
    // curvature 0), the normal across the vector, and v running along the
    // file's extrusion vector, so the normal u x v is STEP's. (Open CASCADE
    // writes its prism's surface along the opposite of the sweep, with the
    // rulings' pcurves running to negative v.)
    for (name, dir) in [
        ("extrusion", nalgebra::Vector3::new(0.0, 12.0, 40.0)),
        ("extrusion_arc", dir),
    ] {
        let (_, s) = only_face(name);
        let unit = dir.normalize();
        let ((_, _), (v0, v1)) = s.domain();
        for (u, v) in grid_uv(&s, 8) {
            let (a, b) = (s.point(u, v0).coords, s.point(u, v1).coords);
            let off = (s.point(u, v).coords - a).cross(&unit).norm();
            assert!(
                off < 1e-9 && (b - a).cross(&unit).norm() < 1e-9,
                "{name}: {off}"
            );
            assert!(
                (b - a).dot(&unit) < 0.0,
                "{name}: v runs against the file's vector"
            );
            let g = LocalGeometry::at(&s, u, v).unwrap();
            assert!(
                (g.k_min * g.k_max).abs() < 1e-9,
                "{name}: K = {}",
                g.k_min * g.k_max
            );
            assert!(
                g.forms.n.dot(&unit).abs() < 1e-9,
                "{name}: normal {:?}",
                g.forms.n
            );
        }
    }
}

#[test]
fn the_face_through_the_pole_imports_with_a_collapsed_edge() {
    // Latitude 30 degrees to the pole: the face's loop runs along the
    // patch's collapsed edge, every point of which is the pole.
    let (_, s) = only_face("sphere_pole");
    let ((u0, u1), (_, v1)) = s.domain();
    for k in 0..=4 {
        let p = s.point(u0 + (u1 - u0) * k as f64 / 4.0, v1);
        assert!(
            (p.coords - nalgebra::Vector3::new(0.0, 0.0, 25.0)).norm() < 1e-9,
            "{p:?}"
        );
    }
    let (lo, hi) = s.bounding_box();
    assert!(
        (hi.z - 25.0).abs() < 1e-9 && (lo.z - 12.5).abs() < 1e-9,
        "{lo:?} {hi:?}"
    );
}

#[test]
fn analytic_faces_away_from_poles_plan_within_h() {
    let h = 0.05;
    for name in ["sphere_zone", "torus", "cone", "extrusion", "extrusion_arc"] {
        let surface = serde_json::to_value(
            StepFile::read(&dir().join(format!("{name}.step")))
                .unwrap()
                .face(17)
                .unwrap(),
        )
        .unwrap();
        let file: JobFile = serde_json::from_value(json!({
            "job_id": format!("step_{name}"),
            "surface": surface,
            "strategy": "iso_scallop",
            "tool": {"kind": "ball", "radius": 3.0},
            "scallop": h,
        }))
        .unwrap();
        let job = Job::from_file(file, None).unwrap();
        plans_within_h(name, &job);
    }
}

/// The multi-face sample written to a directory, with a job on `faces`.
fn multi_face_job(dir: &Path, faces: serde_json::Value) -> Result<Vec<Job>, Error> {
    let part = step_parts::part("step_multi_face").unwrap();
    std::fs::write(dir.join("part.step"), &part.text).unwrap();
    let job = dir.join("job.json");
    std::fs::write(
        &job,
        json!({
            "job_id": "multi",
            "surface": {"file": "part.step", "faces": faces},
            "strategy": "iso_scallop",
            "tool": {"kind": "ball", "radius": 4.0},
            "scallop": 0.05,
        })
        .to_string(),
    )
    .unwrap();
    toolpath_planner::formats::read_jobs(&job)
}

#[test]
fn a_job_on_several_faces_plans_each_within_its_trim_grouped_by_face() {
    let tmp = tempfile::tempdir().unwrap();
    let ids = step_parts::part("step_multi_face").unwrap().faces;
    // The plane, then the freeform face, then the cylinder: the order given.
    let order = [ids[1], ids[0], ids[2]];
    let jobs = multi_face_job(tmp.path(), json!(order)).unwrap();
    assert_eq!(jobs.len(), 3);
    let r = pipeline::run_faces(&jobs, &NoProgress, RunOptions::default()).unwrap();
    let faces = r.pass_faces.clone().unwrap();
    assert_eq!(faces.len(), r.passes.len());
    assert!(faces.windows(2).all(|w| w[0] <= w[1]), "grouped: {faces:?}");
    for k in 0..3 {
        assert!(faces.contains(&k), "face {k} has no pass: {faces:?}");
    }
    // Contacts on the face are on its geometry; run-ins and run-outs (off
    // the trim) stay within the tool's radius of it.
    let mut on_face = [0usize; 3];
    for (pass, &k) in r.passes.iter().zip(&faces) {
        let s = jobs[k].surface().unwrap();
        for q in &pass.points {
            let c = q.cc;
            if !s.in_face(q.uv[0], q.uv[1]) {
                let reach = 4.0 + 1e-6;
                let (lo, hi) = [(-40.0, 0.0), (0.0, 100.0), (100.0, 130.0)][k];
                assert!(
                    c[0] > lo - reach && c[0] < hi + reach,
                    "face {k}: run-out {c:?}"
                );
                continue;
            }
            on_face[k] += 1;
            // On the face: within h of its boundary (the planners' closure).
            let e = 0.05;
            let ok = match k {
                // The plane z = 0, x in [-40, 0].
                0 => c[2].abs() < 1e-6 && c[0] > -40.0 - e && c[0] < e,
                // The freeform face, x in [0, 100].
                1 => c[0] > -e && c[0] < 100.0 + e,
                // The quarter cylinder of radius 30 about (100, y, -30).
                _ => ((c[0] - 100.0).hypot(c[2] + 30.0) - 30.0).abs() < 1e-4 && c[0] > 100.0 - e,
            };
            assert!(ok, "face {k}: contact {c:?} off its face");
        }
    }
    assert!(on_face.iter().all(|&n| n > 0), "{on_face:?}");
    let length: f64 = r
        .passes
        .iter()
        .map(|p| {
            p.points
                .windows(2)
                .map(|w| {
                    let (a, b) = (w[0].cl, w[1].cl);
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                })
                .sum::<f64>()
        })
        .sum();
    eprintln!(
        "3 faces: {} passes {faces:?}, {:.1} mm, scallop {:?}",
        r.passes.len(),
        r.stats.path_length_mm,
        r.stats.max_scallop_mm
    );
    assert!(
        (length - r.stats.path_length_mm).abs() < 1e-6 * length,
        "{length}"
    );
    assert_eq!(r.within_scallop, Some(true));
    assert!(r.stats.max_scallop_mm.unwrap() <= 0.05);
}

#[test]
fn bad_face_lists_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let ids = step_parts::part("step_multi_face").unwrap().faces;
    for (faces, want) in [
        (json!([]), "is empty"),
        (json!([ids[0], ids[1], ids[0]]), "repeats face"),
        (json!([ids[0], 424242]), "#424242"),
        (json!([ids[0], "x"]), "surface.faces[1]"),
        (json!(17), "must be a list"),
    ] {
        let e = multi_face_job(tmp.path(), faces.clone()).expect_err("refused");
        let text = invalid_message(e);
        assert!(text.contains(want), "{faces}: {text}");
    }
    // One job (the node's way) refuses a face list.
    let file: JobFile = serde_json::from_value(json!({
        "job_id": "multi",
        "surface": {"file": "part.step", "faces": [ids[0]]},
        "strategy": "iso_scallop",
        "tool": {"kind": "ball", "radius": 4.0},
        "scallop": 0.05,
    }))
    .unwrap();
    let e = Job::from_file(file, Some(tmp.path())).expect_err("refused");
    assert!(e.to_string().contains("surface.faces"), "{e}");
}
