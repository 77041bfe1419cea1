//! The surface forms beyond the elementary ones, against exact answers:
//! offsets of elementary surfaces against closed forms, the fitted offset
//! of a B-spline against inversion on its basis, the implicit B-spline
//! forms against the explicit ones, a periodic surface on its unclamped
//! knots; a STEP error inside a job, and a part's unreadable faces.

use super::*;

/// `text` with entity `#id`'s line replaced by `line` (without its `;`).
fn with_entity(text: &str, id: u64, line: &str) -> String {
    let start = text
        .find(&format!("\n#{id} = "))
        .unwrap_or_else(|| panic!("no #{id}"))
        + 1;
    let end = start + text[start..].find(";\n").unwrap();
    format!("{}{line}{}", &text[..start], &text[end..])
}

/// The entity id a face's surface is, from its `ADVANCED_FACE` line.
fn face_surface_id(text: &str, face: u64) -> u64 {
    let at = text.find(&format!("#{face} = ADVANCED_FACE(")).unwrap();
    let line = &text[at..at + text[at..].find(';').unwrap()];
    let refs: Vec<u64> = line
        .split('#')
        .skip(2)
        .filter_map(|r| r.split(|c: char| !c.is_ascii_digit()).next()?.parse().ok())
        .collect();
    *refs.last().unwrap()
}

#[test]
fn offsets_of_elementary_surfaces_are_exact() {
    // Open CASCADE's offset faces (OFFSET_SURFACE on the elementary
    // surface): every point of the patch on the offset surface, its normal
    // the basis's. Cylinder R 20 + 2.5; sphere 25 - 5; torus tube 10 - 2.
    let n_at = |s: &NurbsSurface, u: f64, v: f64| s.normal(u, v).unwrap();
    let (_, s) = only_face("offset_cylinder");
    for (u, v) in grid_uv(&s, 8) {
        let p = s.point(u, v).coords;
        assert!((p.x.hypot(p.y) - 22.5).abs() < 1e-9, "{p:?}");
        let n = n_at(&s, u, v);
        assert!((n - nalgebra::Vector3::new(p.x, p.y, 0.0) / 22.5).norm() < 1e-9);
    }
    let (_, s) = only_face("offset_sphere");
    for (u, v) in grid_uv(&s, 8) {
        let p = s.point(u, v).coords;
        assert!((p.norm() - 20.0).abs() < 1e-9, "{p:?}");
        assert!((n_at(&s, u, v) - p / 20.0).norm() < 1e-9);
    }
    let (_, s) = only_face("offset_torus");
    for (u, v) in grid_uv(&s, 8) {
        let p = s.point(u, v).coords;
        let rho = p.x.hypot(p.y);
        let d = p - nalgebra::Vector3::new(p.x / rho * 40.0, p.y / rho * 40.0, 0.0);
        assert!((d.norm() - 8.0).abs() < 1e-9, "{p:?}");
        assert!((n_at(&s, u, v) - d / 8.0).norm() < 1e-9);
    }
    // The cone (semi-angle a = atan(15 / 40), radius 30 at z = 0, opening
    // upwards) moved 2 mm outward: rho = 30 + z tan a + 2 / cos a.
    let (_, s) = only_face("offset_cone");
    let a = (15.0f64 / 40.0).atan();
    for (u, v) in grid_uv(&s, 8) {
        let p = s.point(u, v).coords;
        let rho = p.x.hypot(p.y);
        assert!(
            (rho - (30.0 + p.z * a.tan() + 2.0 / a.cos())).abs() < 1e-9,
            "{p:?}"
        );
        let out = nalgebra::Vector3::new(p.x / rho * a.cos(), p.y / rho * a.cos(), -a.sin());
        assert!((n_at(&s, u, v) - out).norm() < 1e-9);
    }
    // An offset that collapses the sphere is refused, naming the entity.
    let text = std::fs::read_to_string(dir().join("offset_sphere.step")).unwrap();
    let collapsed = text.replacen(
        "OFFSET_SURFACE('',#34,-5.,.F.)",
        "OFFSET_SURFACE('',#34,-30.,.F.)",
        1,
    );
    assert_ne!(collapsed, text);
    let f = parse(&collapsed).unwrap();
    let e = invalid_message(f.face(f.face_ids()[0]).err().unwrap());
    assert!(
        e.contains("#33 OFFSET_SURFACE") && e.contains("collapses"),
        "{e}"
    );
}

#[test]
fn offsets_of_freeform_surfaces_are_fitted_within_their_tolerance() {
    use toolpath_planner::formats::step::OFFSET_FIT_TOLERANCE_MM;
    use toolpath_planner::geometry::inversion::closest_point;
    // Open CASCADE's face on the bicubic B-spline of make_step_parts.py
    // (poles (25 i, 20 j, 8 sin i cos j), knots 0, 0.5, 1) offset by 3 mm:
    // every point of the fitted face is 3 mm from that surface (its closest
    // point there, found by inversion) on the side of its normal.
    let poles: Vec<Vec<[f64; 3]>> = (0..5)
        .map(|i| {
            (0..5)
                .map(|j| {
                    let (x, y) = (i as f64, j as f64);
                    [25.0 * x, 20.0 * y, 8.0 * x.sin() * y.cos()]
                })
                .collect()
        })
        .collect();
    let knots = vec![0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0];
    let basis = NurbsSurface::new(3, 3, knots.clone(), knots, &poles, None).unwrap();
    let (_, s) = only_face("offset_bspline");
    let mut worst = 0.0f64;
    let mut inside = 0;
    for (u, v) in grid_uv(&s, 40) {
        if !s.in_face(u, v) {
            continue;
        }
        inside += 1;
        let p = s.point(u, v);
        let c = closest_point(&basis, &p);
        let n = basis.normal(c.uv.x, c.uv.y).unwrap();
        let off = (p - basis.point(c.uv.x, c.uv.y)).dot(&n);
        worst = worst.max((off - 3.0).abs());
    }
    assert!(inside > 1000, "{inside} points on the face");
    assert!(worst <= OFFSET_FIT_TOLERANCE_MM, "{worst} mm");
    assert!(worst > 0.0, "the fit is exact, so nothing was fitted");
    let want = manifest()["offset_bspline"]["area_mm2"].as_f64().unwrap();
    assert!(
        (area(&s) - want).abs() <= AREA_REL * want,
        "{} vs {want}",
        area(&s)
    );
}

#[test]
fn every_b_spline_form_reads_as_the_same_surface() {
    // freeform_nopcurves' surface (bicubic, knots 0, 0.5, 1 with
    // multiplicities 4, 1, 4) is the QUASI_UNIFORM_SURFACE of its control
    // net with (u, v) doubled; written so, it imports as the same face.
    let text = std::fs::read_to_string(dir().join("freeform_nopcurves.step")).unwrap();
    let f = parse(&text).unwrap();
    let face = f.face_ids()[0];
    let original = f.face(face).unwrap().to_surface().unwrap();
    let sid = face_surface_id(&text, face);
    let at = text
        .find(&format!("#{sid} = B_SPLINE_SURFACE_WITH_KNOTS("))
        .unwrap();
    let line = &text[at..at + text[at..].find(';').unwrap()];
    // The control net: everything up to the surface form's enumeration.
    let net_end = line.find(",.UNSPECIFIED.").unwrap();
    let core = &line[line.find('(').unwrap() + 1..net_end];
    let quasi = format!("#{sid} = QUASI_UNIFORM_SURFACE({core},.UNSPECIFIED.,.F.,.F.,.F.)");
    let g = parse(&with_entity(&text, sid, &quasi)).unwrap();
    let s = g.face(face).unwrap().to_surface().unwrap();
    assert_eq!(s.domain(), ((0.0, 2.0), (0.0, 2.0)));
    for (u, v) in grid_uv(&original, 10) {
        assert!((s.point(2.0 * u, 2.0 * v) - original.point(u, v)).norm() < 1e-9);
    }
    assert!((area(&s) - area(&original)).abs() < 1e-6 * area(&original));
    // The complex form of the same: B_SPLINE_SURFACE with a
    // QUASI_UNIFORM_SURFACE part, rational with unit weights.
    let net = &core[core.find(",(").unwrap()..];
    let degrees = &core[..core.find(",(").unwrap()];
    let degrees = degrees.trim_start_matches("''").trim_start_matches(',');
    let ones = "(1.,1.,1.,1.,1.)";
    let complex = format!(
        "#{sid} = ( BOUNDED_SURFACE() B_SPLINE_SURFACE({degrees}{net},.UNSPECIFIED.,.F.,.F.,.F.) GEOMETRIC_REPRESENTATION_ITEM() QUASI_UNIFORM_SURFACE() RATIONAL_B_SPLINE_SURFACE(({ones},{ones},{ones},{ones},{ones})) REPRESENTATION_ITEM('') SURFACE() )"
    );
    let g = parse(&with_entity(&text, sid, &complex)).unwrap();
    let c = g.face(face).unwrap().to_surface().unwrap();
    for (u, v) in grid_uv(&s, 10) {
        assert!((c.point(u, v) - s.point(u, v)).norm() < 1e-9);
    }
    // The step_freeform sample's face is one bicubic Bezier patch: as a
    // BEZIER_SURFACE it is the same surface on the same (u, v).
    let part = step_parts::part("step_freeform").unwrap().text;
    let f = parse(&part).unwrap();
    let face = f.face_ids()[0];
    let original = f.face(face).unwrap().to_surface().unwrap();
    let sid = face_surface_id(&part, face);
    let at = part
        .find(&format!("#{sid} = B_SPLINE_SURFACE_WITH_KNOTS("))
        .unwrap();
    let line = &part[at..at + part[at..].find(';').unwrap()];
    let core = &line[line.find('(').unwrap() + 1..line.find(",.UNSPECIFIED.").unwrap()];
    let bezier = format!("#{sid} = BEZIER_SURFACE({core},.UNSPECIFIED.,.F.,.F.,.F.)");
    let rewritten = with_entity(&part, sid, &bezier);
    let s = parse(&rewritten)
        .unwrap()
        .face(face)
        .unwrap()
        .to_surface()
        .unwrap();
    assert_eq!(s.domain(), original.domain());
    for (u, v) in grid_uv(&original, 10) {
        assert!((s.point(u, v) - original.point(u, v)).norm() < 1e-12);
    }
}

#[test]
fn a_periodic_b_spline_face_imports_on_its_unclamped_knots() {
    // Open CASCADE writes a u-periodic surface with uniform knots -3 .. 11
    // (11 poles, 8 of them distinct round the tube): the domain is [0, 8]
    // and the surface closes on itself, S(0, v) = S(8, v).
    let (_, s) = only_face("periodic_bspline");
    let ((u0, u1), (v0, v1)) = s.domain();
    assert_eq!((u0, u1), (0.0, 8.0));
    for j in 0..=4 {
        let v = v0 + (v1 - v0) * j as f64 / 4.0;
        assert!((s.point(u0, v) - s.point(u1, v)).norm() < 1e-9);
    }
    let want = manifest()["periodic_bspline"]["area_mm2"].as_f64().unwrap();
    assert!(
        (area(&s) - want).abs() <= AREA_REL * want,
        "{} vs {want}",
        area(&s)
    );
}

#[test]
fn a_step_error_in_a_job_names_the_file_and_the_entity_readably() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(dir().join("cylinder.step")).unwrap();
    let broken = text.replacen(
        "CYLINDRICAL_SURFACE('',#34,20.)",
        "CURVE_BOUNDED_SURFACE('',#34,(#34),.F.)",
        1,
    );
    std::fs::write(tmp.path().join("mould.step"), broken).unwrap();
    let file: JobFile = serde_json::from_value(json!({
        "job_id": "broken",
        "surface": {"file": "mould.step", "face": 17},
        "strategy": "iso_scallop",
        "tool": {"kind": "ball", "radius": 4.0},
        "scallop": 0.05,
    }))
    .unwrap();
    let e = Job::from_file(file, Some(tmp.path())).expect_err("refused");
    let text = e.to_string();
    assert!(
        text.starts_with("invalid input: surface (mould.step #33 CURVE_BOUNDED_SURFACE): is not a supported surface"),
        "{text}"
    );
}

#[test]
fn a_part_lists_its_unreadable_faces_and_imports_the_rest() {
    // The four faces of step_multi_face, one shell: the first machined,
    // the others check faces; with the plane's surface broken the plane is
    // listed as unreadable (entity and reason) and the rest still import.
    let part = step_parts::part("step_multi_face").unwrap().text;
    let f = parse(&part).unwrap();
    let ids = f.face_ids();
    assert_eq!(ids.len(), 4);
    let p = f.part_faces(&ids[..1]).unwrap();
    assert_eq!(p.machined.len(), 1);
    assert_eq!(
        p.others.iter().map(|x| x.id).collect::<Vec<_>>(),
        ids[1..].to_vec()
    );
    assert!(p.unreadable.is_empty());
    let plane = ids[1];
    let sid = face_surface_id(&part, plane);
    let broken = part.replacen(
        &format!("#{sid} = PLANE("),
        &format!("#{sid} = CURVE_BOUNDED_SURFACE("),
        1,
    );
    assert_ne!(broken, part);
    let g = parse(&broken).unwrap();
    let p = g.part_faces(&ids[..1]).unwrap();
    assert_eq!(p.others.len(), 2);
    assert_eq!(p.unreadable.len(), 1);
    assert_eq!(p.unreadable[0].id, plane);
    assert!(
        p.unreadable[0]
            .reason
            .contains(&format!("#{sid} CURVE_BOUNDED_SURFACE")),
        "{:?}",
        p.unreadable
    );
    // Machining the broken face is an error naming it.
    let e = invalid_message(g.part_faces(&[plane]).err().unwrap());
    assert!(e.contains(&format!("#{sid} CURVE_BOUNDED_SURFACE")), "{e}");
}
