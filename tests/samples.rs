//! The built-in samples: shapes have the promised geometry (checked against
//! the defining formulas and by brute force), jobs are valid and round-trip
//! through their files, and the CLI lists and writes them.

use nalgebra::Matrix2;
use std::f64::consts::PI;
use std::process::Command;
use toolpath_planner::formats::{self, Shape, Strategy};
use toolpath_planner::geometry::pocket::signed_area;
use toolpath_planner::geometry::{LocalGeometry, NurbsSurface};
use toolpath_planner::samples::{self, pockets, surfaces};
use toolpath_planner::tools::Tool;

fn grid(n: usize) -> impl Iterator<Item = (f64, f64)> {
    (0..=n).flat_map(move |i| (0..=n).map(move |j| (i as f64 / n as f64, j as f64 / n as f64)))
}

/// Largest |z - f(x, y)| over a fine grid (the sample's x, y come from the surface point).
fn height_error(s: &NurbsSurface, f: impl Fn(f64, f64) -> f64, n: usize) -> f64 {
    grid(n)
        .map(|(u, v)| {
            let p = s.point(u, v);
            (p.z - f(p.x, p.y)).abs()
        })
        .fold(0.0, f64::max)
}

fn extent(s: &NurbsSurface) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (u, v) in grid(50) {
        let p = s.point(u, v);
        for t in 0..3 {
            lo[t] = lo[t].min(p[t]);
            hi[t] = hi[t].max(p[t]);
        }
    }
    (lo, hi)
}

#[test]
fn every_sample_builds_and_its_job_round_trips() {
    assert!(samples::list().len() >= 11);
    for s in samples::list() {
        let job = samples::job(s.name).unwrap_or_else(|e| panic!("{}: {e}", s.name));
        assert_eq!(job.feed_rate, 2000.0);
        let text = formats::to_json_pretty(&job.to_file());
        let back = formats::parse_job(&text, None).unwrap_or_else(|e| panic!("{}: {e}", s.name));
        assert_eq!(back, job, "{}", s.name);
        let shape_text = formats::to_json_pretty(&samples::shape(s.name).unwrap().to_json());
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("shape.json");
        std::fs::write(&path, shape_text).unwrap();
        assert_eq!(formats::read_shape(&path).unwrap(), job.shape, "{}", s.name);
    }
    assert!(samples::job("no_such_sample").is_err());
}

#[test]
fn jobs_use_the_planner_each_sample_is_for() {
    let expect = |name: &str, strategy: Strategy| {
        let job = samples::job(name).unwrap();
        assert_eq!(job.strategy, strategy, "{name}");
        job
    };
    for name in ["plane", "concave_cylinder", "monkey_saddle", "wing_mould"] {
        let job = expect(name, Strategy::TensorRegions);
        assert_eq!(
            job.tool,
            Some(Tool::FlatEnd {
                radius: 2.5,
                length: None
            })
        );
        assert_eq!(job.lead_angle_deg, Some(5.0));
        assert_eq!(job.scallop, Some(0.05));
    }
    let die = expect("die_saddle", Strategy::Mpec);
    assert_eq!(die.tool().unwrap().radius(), 31.5);
    assert_eq!(die.tool().unwrap().corner_radius(), 6.0);
    assert_eq!(die.tolerance, Some(0.01));
    for name in ["sine_wave", "egg_crate", "turbine_blade"] {
        let job = expect(name, Strategy::BeltIsoPlanar);
        assert_eq!(
            job.tool,
            Some(Tool::Belt {
                width: 10.0,
                // The egg crate's dips (radius ~32 mm) need a smaller wheel.
                wheel_radius: if name == "egg_crate" { 25.0 } else { 50.0 }
            })
        );
        assert_eq!(job.scallop, Some(0.01));
    }
    for name in ["rect_pocket", "pocket_with_hole", "leaf_pocket"] {
        let job = expect(name, Strategy::PocketMat);
        assert_eq!(job.tool().unwrap().radius(), 5.0);
        assert!(job.shape.as_pocket().is_some());
    }
}

#[test]
fn every_surface_sample_has_its_tool_side_up() {
    for s in samples::list() {
        if let Ok(surface) = samples::surface(s.name) {
            for (u, v) in grid(8) {
                let n = surface.normal(u, v).unwrap();
                assert!(n.z > 0.3, "{} at ({u}, {v}): normal {n:?}", s.name);
            }
        }
    }
}

#[test]
fn concave_cylinder_is_exact_and_concave_towards_the_tool() {
    let s = surfaces::concave_cylinder();
    assert!(s.is_rational());
    for (u, v) in grid(20) {
        let g = LocalGeometry::at(&s, u, v).unwrap();
        let p = g.point();
        let r = (p.y * p.y + (p.z - 100.0).powi(2)).sqrt();
        assert!((r - 100.0).abs() < 1e-10, "radius {r}");
        assert!(
            (g.k_max - 0.01).abs() < 1e-12 && g.k_min.abs() < 1e-12,
            "{} {}",
            g.k_min,
            g.k_max
        );
        assert!(
            (g.dir_min.x.abs() - 1.0).abs() < 1e-9,
            "feed along the axis"
        );
        // The normal points to the axis (tool side is the inside).
        let to_axis = nalgebra::Vector3::new(0.0, -p.y, 100.0 - p.z).normalize();
        assert!((g.forms.n - to_axis).norm() < 1e-9);
    }
    let (lo, hi) = extent(&s);
    assert!((hi[0] - lo[0] - 100.0).abs() < 1e-9 && (hi[1] - lo[1] - 100.0).abs() < 1e-9);
}

#[test]
fn monkey_saddle_is_the_exact_cubic() {
    let s = surfaces::monkey_saddle();
    let f = |x: f64, y: f64| 1e-5 * (x * x * x - 3.0 * x * y * y);
    assert!(height_error(&s, f, 60) < 1e-12);
    let (lo, hi) = extent(&s);
    for (got, want) in [lo[0], lo[1], hi[0], hi[1]]
        .into_iter()
        .zip([-50.0, -50.0, 50.0, 50.0])
    {
        assert!((got - want).abs() < 1e-12, "{got} vs {want}");
    }
    // Umbilic at the origin: the surface is flat there.
    let g = LocalGeometry::at(&s, 0.5, 0.5).unwrap();
    assert!(g.k_min.abs() < 1e-15 && g.k_max.abs() < 1e-15);
}

#[test]
fn die_saddle_has_the_mpec_curvatures() {
    let s = surfaces::die_saddle();
    let f = |x: f64, y: f64| 0.5 * (-1.0 / 19000.0) * x * x + 0.5 * (1.0 / 1198.0) * y * y;
    assert!(height_error(&s, f, 40) < 1e-9);
    let (lo, hi) = extent(&s);
    assert!((hi[0] - lo[0] - 600.0).abs() < 1e-9 && (hi[1] - lo[1] - 400.0).abs() < 1e-9);
    let g = LocalGeometry::at(&s, 0.5, 0.5).unwrap();
    assert!((1.0 / g.k_max - 1198.0).abs() < 1e-6, "{}", 1.0 / g.k_max);
    assert!((1.0 / g.k_min + 19000.0).abs() < 1e-4, "{}", 1.0 / g.k_min);
    for (u, v) in grid(10) {
        let g = LocalGeometry::at(&s, u, v).unwrap();
        // Concave across the feed (v = y), gently convex along it, everywhere.
        assert!(g.normal_curvature_uv(nalgebra::Vector2::new(0.0, 1.0)) > 0.0);
        assert!(g.normal_curvature_uv(nalgebra::Vector2::new(1.0, 0.0)) < 0.0);
        let radii = [1.0 / g.k_max, -1.0 / g.k_min];
        assert!(radii[0] > 1100.0 && radii[0] < 1400.0, "{radii:?}");
        assert!(radii[1] > 18000.0 && radii[1] < 21000.0, "{radii:?}");
    }
}

#[test]
fn sine_wave_and_egg_crate_approximate_their_functions() {
    let sine = surfaces::sine_wave();
    let e = height_error(&sine, |x, _| 5.0 * (2.0 * PI * x / 100.0).sin(), 400);
    assert!(e < 1e-3, "sine_wave error {e}");
    // Straight along y: the v derivative is constant.
    let d = sine.derivs(0.37, 0.5);
    assert!(d.svv.norm() < 1e-12 && (d.sv.normalize().y - 1.0).abs() < 1e-12);
    let egg = surfaces::egg_crate();
    let k = 2.0 * PI / 50.0;
    let e = height_error(&egg, |x, y| 2.0 * (k * x).sin() * (k * y).sin(), 300);
    assert!(e < 1e-3, "egg_crate error {e}");
}

/// e and f of docs/methods.md, "Degenerate points", from the fundamental forms,
/// computed here independently of LocalGeometry's eigen-solver: with G = L L^T,
/// S = L^-1 D L^-T, e = (S11 - S22) / 2, f = S12.
fn umbilic_ef(s: &NurbsSurface, u: f64, v: f64) -> (f64, f64) {
    let d = s.derivs(u, v);
    let n = d.su.cross(&d.sv).normalize();
    let g = Matrix2::new(
        d.su.dot(&d.su),
        d.su.dot(&d.sv),
        d.su.dot(&d.sv),
        d.sv.dot(&d.sv),
    );
    let dd = Matrix2::new(d.suu.dot(&n), d.suv.dot(&n), d.suv.dot(&n), d.svv.dot(&n));
    let l = g.cholesky().unwrap().l();
    let li = l.try_inverse().unwrap();
    let sm = li * dd * li.transpose();
    (0.5 * (sm[(0, 0)] - sm[(1, 1)]), sm[(0, 1)])
}

/// Brute force: the winding number of (e, f) round every cell of a fine
/// parameter grid. Cells with a non-zero winding contain a zero of e = f = 0.
fn umbilic_cells(s: &NurbsSurface, nu: usize, nv: usize) -> Vec<(usize, usize, i32)> {
    let ang: Vec<Vec<f64>> = (0..=nu)
        .map(|i| {
            (0..=nv)
                .map(|j| {
                    let (e, f) = umbilic_ef(s, i as f64 / nu as f64, j as f64 / nv as f64);
                    f.atan2(e)
                })
                .collect()
        })
        .collect();
    let wrap = |a: f64| (a + PI).rem_euclid(2.0 * PI) - PI;
    let mut found = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let ring = [
                ang[i][j],
                ang[i + 1][j],
                ang[i + 1][j + 1],
                ang[i][j + 1],
                ang[i][j],
            ];
            let turn: f64 = ring.windows(2).map(|w| wrap(w[1] - w[0])).sum();
            let w = (turn / (2.0 * PI)).round() as i32;
            if w != 0 {
                found.push((i, j, w));
            }
        }
    }
    found
}

#[test]
fn wing_mould_has_exactly_one_trisector_umbilic_inside() {
    let s = surfaces::wing_mould();
    let (lo, hi) = extent(&s);
    assert!((hi[0] - lo[0] - 200.0).abs() < 1e-9 && (hi[1] - lo[1] - 150.0).abs() < 1e-9);
    let (nu, nv) = (401, 301);
    let cells = umbilic_cells(&s, nu, nv);
    assert_eq!(cells.len(), 1, "umbilic cells: {cells:?}");
    let (i, j, winding) = cells[0];
    // A trisector turns (e, f) once backwards (line-field index -1/2).
    assert_eq!(winding, -1);
    // It is strictly inside, where the sample says.
    let (uc, vc) = ((i as f64 + 0.5) / nu as f64, (j as f64 + 0.5) / nv as f64);
    assert!(uc > 0.05 && uc < 0.95 && vc > 0.05 && vc < 0.95);
    let p = s.point(uc, vc);
    let want = surfaces::WING_UMBILIC;
    assert!(
        (p.x - want[0]).abs() < 1.0 && (p.y - want[1]).abs() < 1.0,
        "{p:?}"
    );
    let (e0, f0) = umbilic_ef(&s, want[0] / 200.0, want[1] / 150.0);
    assert!(e0.abs() < 1e-15 && f0.abs() < 1e-15, "{e0} {f0}");
    // delta = ad - bc < 0 by central differences at the umbilic.
    let (u0, v0, h) = (want[0] / 200.0, want[1] / 150.0, 1e-4);
    let (eu1, fu1) = umbilic_ef(&s, u0 + h, v0);
    let (eu0, fu0) = umbilic_ef(&s, u0 - h, v0);
    let (ev1, fv1) = umbilic_ef(&s, u0, v0 + h);
    let (ev0, fv0) = umbilic_ef(&s, u0, v0 - h);
    let (a, b) = ((eu1 - eu0) / (2.0 * h), (ev1 - ev0) / (2.0 * h));
    let (c, d) = ((fu1 - fu0) / (2.0 * h), (fv1 - fv0) / (2.0 * h));
    let delta = a * d - b * c;
    assert!(delta < 0.0, "delta {delta}");
    // The umbilic is a real curvature event, not flat ground.
    let g = LocalGeometry::at(&s, u0, v0).unwrap();
    assert!((g.k_min - 1.0 / 250.0).abs() < 1e-9 && g.is_umbilic(1e-12));
}

#[test]
fn the_brute_force_umbilic_count_sees_the_monkey_saddle() {
    // The same brute force finds the monkey saddle's single trisector at the centre.
    let cells = umbilic_cells(&surfaces::monkey_saddle(), 101, 101);
    assert_eq!(cells, vec![(50, 50, -1)]);
}

#[test]
fn turbine_blade_is_developable_and_about_10000_mm2() {
    let s = surfaces::turbine_blade();
    let n = 200;
    let mut area = 0.0;
    for i in 0..n {
        for j in 0..n {
            let (u, v) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let g = LocalGeometry::at(&s, u, v).unwrap();
            area += g.area_element() / (n * n) as f64;
            assert!(
                g.gaussian_curvature().abs() < 1e-12,
                "K = {} at ({u}, {v})",
                g.gaussian_curvature()
            );
            // Curved across the rulings (it is not a plane).
            assert!(g.k_min.abs().max(g.k_max.abs()) > 1e-4);
        }
    }
    assert!((9000.0..11500.0).contains(&area), "area {area}");
    // Tangent plane constant along each ruling.
    for u in [0.1, 0.5, 0.8] {
        let n0 = s.normal(u, 0.0).unwrap();
        let n1 = s.normal(u, 1.0).unwrap();
        assert!((n0 - n1).norm() < 1e-12);
    }
}

#[test]
fn pockets_have_the_promised_shapes() {
    let rect = pockets::rect_pocket();
    assert!((rect.area() - 6000.0).abs() < 1e-9);
    let hole = pockets::pocket_with_hole();
    assert_eq!(hole.holes.len(), 1);
    let want = 120.0 * 80.0 - PI * 225.0;
    assert!((hole.area() - want).abs() < 0.01 * want, "{}", hole.area());
    let leaf = pockets::leaf_pocket();
    assert_eq!(leaf.holes.len(), 2);
    let vertices = leaf.outer.len() + leaf.holes.iter().map(Vec::len).sum::<usize>();
    assert!((200..=800).contains(&vertices), "{vertices}");
    assert!(signed_area(&leaf.outer) > 0.0);
    // Narrow necks: vertical extent at the two neck stations far below the lobes'.
    let width_at = |x: f64| {
        let mut ys: Vec<f64> = Vec::new();
        let o = &leaf.outer;
        for k in 0..o.len() {
            let (a, b) = (o[k], o[(k + 1) % o.len()]);
            if (a[0] - x) * (b[0] - x) <= 0.0 && a[0] != b[0] {
                ys.push(a[1] + (x - a[0]) / (b[0] - a[0]) * (b[1] - a[1]));
            }
        }
        ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - ys.iter().cloned().fold(f64::INFINITY, f64::min)
    };
    for neck in [62.0, 122.0] {
        assert!(width_at(neck) < 18.0, "neck at {neck}: {}", width_at(neck));
    }
    assert!(width_at(92.0) > 55.0);
    // Small tip radius: three consecutive vertices at the tip lie on a circle of about 1.5 mm.
    let tip = leaf
        .outer
        .iter()
        .enumerate()
        .min_by(|a, b| a.1[0].total_cmp(&b.1[0]))
        .map(|(k, _)| k)
        .unwrap();
    let n = leaf.outer.len();
    let (a, b, c) = (
        leaf.outer[(tip + n - 2) % n],
        leaf.outer[tip],
        leaf.outer[(tip + 2) % n],
    );
    let ab = (a[0] - b[0]).hypot(a[1] - b[1]);
    let bc = (b[0] - c[0]).hypot(b[1] - c[1]);
    let ca = (c[0] - a[0]).hypot(c[1] - a[1]);
    let area2 = ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs();
    let circumradius = ab * bc * ca / (2.0 * area2);
    assert!(
        (circumradius - 1.5).abs() < 0.05,
        "tip radius {circumradius}"
    );
}

#[test]
fn cli_lists_and_writes_samples() {
    let bin = env!("CARGO_BIN_EXE_toolpath");
    let out = Command::new(bin)
        .args(["sample", "--list"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for s in samples::list() {
        assert!(
            text.lines()
                .any(|l| l.starts_with(s.name) && l.len() > s.name.len() + 10),
            "{}",
            s.name
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let job_path = dir.path().join("job.json");
    let st = Command::new(bin)
        .args(["sample", "wing_mould", "--job", "-o"])
        .arg(&job_path)
        .status()
        .unwrap();
    assert!(st.success());
    let job = formats::read_job(&job_path).unwrap();
    assert_eq!(job, samples::job("wing_mould").unwrap());
    let shape_path = dir.path().join("leaf.json");
    let st = Command::new(bin)
        .args(["sample", "leaf_pocket", "-o"])
        .arg(&shape_path)
        .status()
        .unwrap();
    assert!(st.success());
    assert!(matches!(
        formats::read_shape(&shape_path).unwrap(),
        Shape::Pocket(_)
    ));
    let bad = Command::new(bin).args(["sample", "nope"]).output().unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("sample"));
}

#[test]
fn cli_inspect_reports_exact_curvatures() {
    let bin = env!("CARGO_BIN_EXE_toolpath");
    let dir = tempfile::tempdir().unwrap();
    let inspect = |name: &str, u: &str, v: &str| {
        let path = dir.path().join(format!("{name}.json"));
        std::fs::write(&path, samples::shape(name).unwrap().to_json().to_string()).unwrap();
        let out = Command::new(bin)
            .arg("inspect")
            .arg(&path)
            .args(["--uv", u, v])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let num = |v: &serde_json::Value, k: &str| v[k].as_f64().unwrap();
    // Concave cylinder trough: k1 = 1/100 across the axis, k2 = 0 along it; lowest line z = 0.
    let c = inspect("concave_cylinder", "0.25", "0.5");
    assert!((num(&c, "k1") - 0.01).abs() < 1e-12 && num(&c, "k2").abs() < 1e-12);
    assert!((c["point"][2].as_f64().unwrap()).abs() < 1e-12);
    assert!((c["normal"][2].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert!((c["dir_k2"][0].as_f64().unwrap().abs() - 1.0).abs() < 1e-9);
    assert_eq!(c["umbilic"], serde_json::Value::Bool(false));
    // Monkey saddle centre: flat umbilic.
    let m = inspect("monkey_saddle", "0.5", "0.5");
    assert_eq!(m["umbilic"], serde_json::Value::Bool(true));
    // Die saddle centre: radii 1198 and -19000.
    let d = inspect("die_saddle", "0.5", "0.5");
    assert!(
        (1.0 / num(&d, "k1") - 1198.0).abs() < 1e-6 && (1.0 / num(&d, "k2") + 19000.0).abs() < 1e-3
    );
    assert!((num(&d, "gaussian_curvature") + 1.0 / (1198.0 * 19000.0)).abs() < 1e-15);
}

/// SplitMix64's first output for `seed`, mapped to [-1, 1] as the random
/// sample documents it (docs/formats.md), written out independently.
fn first_draw(seed: u64) -> f64 {
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

#[test]
fn cli_random_sample_is_seeded_and_checked() {
    let bin = env!("CARGO_BIN_EXE_toolpath");
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, extra: &[&str]| {
        let path = dir.path().join(name);
        let out = Command::new(bin)
            .args(["sample", "random", "--seed", "7", "--size", "120", "90"])
            .args(["--amplitude", "2.5", "--anisotropy", "2"])
            .args(extra)
            .arg("-o")
            .arg(&path)
            .output()
            .unwrap();
        assert!(out.status.success(), "{out:?}");
        std::fs::read(&path).unwrap()
    };
    let a = write("a.json", &[]);
    let b = write("b.json", &[]);
    assert_eq!(a, b, "same seed, same bytes");
    let Shape::Surface(s) = formats::read_shape(&dir.path().join("a.json")).unwrap() else {
        panic!("not a surface");
    };
    // Control point (0, 0): x = y = 0, height amplitude x first draw plus
    // the trough's depth at v = 0 (anisotropy x amplitude x 4 x 1/4).
    let p = s.control_point(0, 0);
    assert_eq!([p[0], p[1]], [0.0, 0.0]);
    assert!(
        (p[2] - (2.5 * first_draw(7) + 2.0 * 2.5)).abs() < 1e-12,
        "{p:?}"
    );
    // 120 / 40 = 3 spans along u, 90 / 40 -> 2 along v: bicubic 6 x 5 net.
    assert_eq!((s.count_u(), s.count_v()), (6, 5));
    let job = write("job.json", &["--job"]);
    let job: serde_json::Value = serde_json::from_slice(&job).unwrap();
    assert_eq!(job["strategy"], "tensor_regions");
    assert_eq!(job["job_id"], "random_s7_120x90_a2.5_k2_job");
    for (args, needle) in [
        (&["sample", "random"][..], "--seed"),
        (
            &["sample", "random", "--seed", "1", "--amplitude=-1"][..],
            "--amplitude",
        ),
        (
            &["sample", "plane", "--seed", "1"][..],
            "only the random sample",
        ),
    ] {
        let out = Command::new(bin).args(args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}
