//! Strategy pocket_mat against exact answers (docs/methods.md, "Pocket
//! references") and independent brute-force checks: exact wall distances of
//! every tool-centre path, a fine raster of the swept discs, path lengths of
//! the single-tool baseline.

use std::f64::consts::PI;
use toolpath_planner::formats::{self, job::DEFAULT_TOOL_CATALOGUE};
use toolpath_planner::geometry::Pocket;
use toolpath_planner::planners::pocket::pocket_mat::{
    plan_pocket, plan_single_tool, PocketPlan, WALL_TOL,
};
use toolpath_planner::planners::NoProgress;
use toolpath_planner::samples;

type P2 = [f64; 2];

fn seg_dist(a: P2, b: P2, p: P2) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * d[0]).hypot(p[1] - a[1] - t * d[1])
}

/// Distance between two segments (0 if they cross).
fn seg_seg_dist(a: P2, b: P2, c: P2, d: P2) -> f64 {
    let o = |p: P2, q: P2, r: P2| (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]);
    let (d1, d2, d3, d4) = (o(c, d, a), o(c, d, b), o(a, b, c), o(a, b, d));
    if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
        return 0.0;
    }
    seg_dist(c, d, a)
        .min(seg_dist(c, d, b))
        .min(seg_dist(a, b, c))
        .min(seg_dist(a, b, d))
}

fn loops(p: &Pocket) -> Vec<&Vec<P2>> {
    std::iter::once(&p.outer).chain(p.holes.iter()).collect()
}

/// Smallest distance from any segment of the tool-centre paths to the walls,
/// minus the tool radius, over all tools (brute force over all pairs).
fn worst_clearance(p: &Pocket, plan: &PocketPlan) -> f64 {
    let walls: Vec<(P2, P2)> = loops(p)
        .iter()
        .flat_map(|l| (0..l.len()).map(move |i| (l[i], l[(i + 1) % l.len()])))
        .collect();
    let mut worst = f64::INFINITY;
    for s in &plan.stages {
        let r = 0.5 * s.diameter;
        for path in &s.passes {
            for (k, q) in path.iter().enumerate() {
                assert!(
                    p.contains(*q),
                    "{} tool centre {q:?} outside the pocket",
                    s.stage
                );
                let next = path.get(k + 1).copied().unwrap_or(*q);
                for &(a, b) in &walls {
                    worst = worst.min(seg_seg_dist(*q, next, a, b) - r);
                }
            }
        }
    }
    worst
}

/// Uncovered pocket points on an independent raster (cell centres, offset by
/// a third of a cell from the planner's grid), with the brute-force swept test.
fn uncovered_points(p: &Pocket, plan: &PocketPlan, h: f64) -> Vec<P2> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for q in &p.outer {
        for t in 0..2 {
            lo[t] = lo[t].min(q[t]);
            hi[t] = hi[t].max(q[t]);
        }
    }
    let segs: Vec<(P2, P2, f64)> = plan
        .stages
        .iter()
        .flat_map(|s| {
            s.passes.iter().flat_map(move |path| {
                let pts: Vec<P2> = if path.len() == 1 {
                    vec![path[0], path[0]]
                } else {
                    path.clone()
                };
                pts.windows(2)
                    .map(move |w| (w[0], w[1], 0.5 * s.diameter))
                    .collect::<Vec<_>>()
            })
        })
        .collect();
    // Bucket the segments for speed (the test is still brute force inside a bucket).
    let cell = 2.0;
    let nx = ((hi[0] - lo[0]) / cell).ceil() as usize + 1;
    let ny = ((hi[1] - lo[1]) / cell).ceil() as usize + 1;
    let mut buckets: Vec<Vec<usize>> = vec![Vec::new(); nx * ny];
    for (k, &(a, b, r)) in segs.iter().enumerate() {
        let x0 = ((a[0].min(b[0]) - r - lo[0]) / cell).floor().max(0.0) as usize;
        let x1 = (((a[0].max(b[0]) + r - lo[0]) / cell).floor() as usize).min(nx - 1);
        let y0 = ((a[1].min(b[1]) - r - lo[1]) / cell).floor().max(0.0) as usize;
        let y1 = (((a[1].max(b[1]) + r - lo[1]) / cell).floor() as usize).min(ny - 1);
        for y in y0..=y1 {
            for x in x0..=x1 {
                buckets[y * nx + x].push(k);
            }
        }
    }
    let mut out = Vec::new();
    let mut y = lo[1] + h / 3.0;
    while y < hi[1] {
        let mut x = lo[0] + h / 3.0;
        while x < hi[0] {
            let q = [x, y];
            if p.contains(q) {
                let bx = (((x - lo[0]) / cell) as usize).min(nx - 1);
                let by = (((y - lo[1]) / cell) as usize).min(ny - 1);
                let hit = buckets[by * nx + bx].iter().any(|&k| {
                    let (a, b, r) = segs[k];
                    seg_dist(a, b, q) <= r + 1e-9
                });
                if !hit {
                    out.push(q);
                }
            }
            x += h;
        }
        y += h;
    }
    out
}

fn rectangle(w: f64, h: f64) -> Pocket {
    Pocket::new(&[[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]], &[]).unwrap()
}

/// Uncut area a tool of radius r leaves in a sharp corner of angle alpha.
fn corner_area(r: f64, alpha: f64) -> f64 {
    r * r * (1.0 / (alpha / 2.0).tan() - (PI - alpha) / 2.0)
}

#[test]
fn rectangle_sequence_matches_reference() {
    let p = rectangle(100.0, 60.0);
    let plan = plan_pocket(&p, &DEFAULT_TOOL_CATALOGUE, None, &NoProgress).unwrap();
    assert!((plan.medial_axis.dmax - 60.0).abs() < 0.01);
    let rough = &plan.stages[0];
    assert_eq!((rough.stage, rough.diameter), ("roughing", 30.0));
    // R = 15 leaves (4 - pi) R^2 = 193.14 mm^2 in the four corners.
    let want = (4.0 - PI) * 225.0;
    assert!((want - 193.14).abs() < 0.01);
    assert!(
        (rough.uncut_after - want).abs() < 0.01 * want,
        "{} vs {want}",
        rough.uncut_after
    );
    // The medial axis meets the roughing arc at r1 = R (1 - sin 45 deg): Dmax1 = 8.787.
    let corner = &plan.stages[1];
    assert_eq!(corner.stage, "corner");
    let dmax1 = corner.residual_dmax.unwrap();
    assert!((dmax1 - 8.787).abs() < 1e-3, "{dmax1}");
    assert!(corner.diameter >= dmax1 / 2.0 && corner.diameter < 30.0);
    for w in plan.stages.windows(2) {
        assert!(w[1].diameter < w[0].diameter);
        assert!(w[1].uncut_after <= w[0].uncut_after);
    }
    // Every tool stays off the walls; the last tool leaves only its own four corners.
    assert!(worst_clearance(&p, &plan) > -1e-3);
    let last = plan.stages.last().unwrap();
    let r = 0.5 * last.diameter;
    let want = 4.0 * corner_area(r, PI / 2.0);
    let h = 0.01;
    let uncovered = uncovered_points(&p, &plan, h);
    let area = uncovered.len() as f64 * h * h;
    assert!(
        (area - want).abs() < 0.1 * want + 4.0 * h * h,
        "uncovered {area} vs corners {want}"
    );
    assert!(
        plan.uncut_area() < want * 2.0 + 0.05,
        "{}",
        plan.uncut_area()
    );
}

/// A triangle with angles 50, 60, 70 degrees and one tool with Dmax/2 <= D <= Dmax:
/// one contour pass leaves exactly the three corner areas.
#[test]
fn triangle_corner_areas_match_formula() {
    let (a, b) = (50f64.to_radians(), 60f64.to_radians());
    let c = PI - a - b;
    let base = 120.0;
    // Apex from the two base angles.
    let t = base * b.sin() / c.sin();
    let apex = [t * a.cos(), t * a.sin()];
    let p = Pocket::new(&[[0.0, 0.0], [base, 0.0], apex], &[]).unwrap();
    let area = p.area();
    let s = 0.5 * (base + t + (apex[0] - base).hypot(apex[1]));
    let inradius = area / s;
    let d = 1.5 * inradius;
    let plan = plan_pocket(&p, &[d], Some(0.02), &NoProgress).unwrap();
    assert!((plan.medial_axis.dmax - 2.0 * inradius).abs() < 0.01);
    assert_eq!(plan.stages.len(), 1);
    let r = 0.5 * d;
    let want: f64 = [a, b, c].iter().map(|&al| corner_area(r, al)).sum();
    assert!(
        (plan.uncut_area() - want).abs() < 0.01 * want,
        "{} vs {want}",
        plan.uncut_area()
    );
    assert!(worst_clearance(&p, &plan) > -1e-3);
}

/// Distance from q to the nearest convex (for the tool: concave) vertex, and its angle.
fn nearest_sharp_vertex(p: &Pocket, q: P2) -> (f64, f64) {
    let mut best = (f64::INFINITY, PI);
    for l in loops(p) {
        let n = l.len();
        for i in 0..n {
            let (a, v, c) = (l[(i + n - 1) % n], l[i], l[(i + 1) % n]);
            let turn = (v[0] - a[0]) * (c[1] - v[1]) - (v[1] - a[1]) * (c[0] - v[0]);
            if turn <= 0.0 {
                continue;
            }
            let u = [a[0] - v[0], a[1] - v[1]];
            let w = [c[0] - v[0], c[1] - v[1]];
            let alpha = ((u[0] * w[0] + u[1] * w[1]) / (u[0].hypot(u[1]) * w[0].hypot(w[1])))
                .clamp(-1.0, 1.0)
                .acos();
            let d = (q[0] - v[0]).hypot(q[1] - v[1]);
            if d < best.0 {
                best = (d, alpha);
            }
        }
    }
    best
}

#[test]
fn leaf_pocket_no_gouge_full_coverage_and_shorter_than_root_alone() {
    let job = samples::job("leaf_pocket").unwrap();
    let p = job.pocket().unwrap().clone();
    let plan = plan_pocket(&p, &job.tool_catalogue, None, &NoProgress).unwrap();
    for s in &plan.stages {
        eprintln!(
            "{} D={} passes={} length={:.1} residual={:?} uncut={:.3}",
            s.stage,
            s.diameter,
            s.passes.len(),
            s.path_length,
            s.residual_dmax,
            s.uncut_after
        );
    }
    eprintln!(
        "dmax {} min corner radius {}",
        plan.medial_axis.dmax, plan.medial_axis.min_corner_radius
    );
    assert!(
        plan.stages.len() >= 3,
        "roughing, corner and root tools expected"
    );
    assert_eq!(plan.stages[0].stage, "roughing");
    assert_eq!(plan.stages.last().unwrap().stage, "root");
    // 1. No gouge: every path segment keeps at least R - 1e-3 from every wall and hole.
    let clearance = worst_clearance(&p, &plan);
    assert!(clearance > -1e-3, "gouge {clearance}");
    // 2. Coverage: what stays uncut lies in corners sharper than the root tool reaches,
    //    i.e. within R / sin(alpha/2) of a vertex of interior angle alpha.
    let r_root = 0.5 * plan.stages.last().unwrap().diameter;
    let h = 0.05;
    let uncovered = uncovered_points(&p, &plan, h);
    //    Residue thinner than WALL_TOL (10 um) on a wall is left to finishing by design.
    let walls: Vec<(P2, P2)> = loops(&p)
        .iter()
        .flat_map(|l| (0..l.len()).map(move |i| (l[i], l[(i + 1) % l.len()])))
        .collect();
    for q in &uncovered {
        let (d, alpha) = nearest_sharp_vertex(&p, *q);
        let wall = walls
            .iter()
            .map(|&(a, b)| seg_dist(a, b, *q))
            .fold(f64::INFINITY, f64::min);
        assert!(
            d <= r_root / (alpha / 2.0).sin() + 2.0 * h || wall <= WALL_TOL + 1e-9,
            "uncovered point {q:?} {d} from a corner of {alpha}, {wall} from the wall"
        );
    }
    assert!(uncovered.len() as f64 * h * h < 1.0);
    // 3. At least 3 times shorter than the root tool alone.
    let single = plan_single_tool(&p, plan.stages.last().unwrap().diameter, None).unwrap();
    let ratio = single.path_length() / plan.path_length();
    eprintln!(
        "sequence {:.1} mm, root alone {:.1} mm, ratio {ratio:.2}",
        plan.path_length(),
        single.path_length()
    );
    assert!(ratio >= 3.0, "ratio {ratio}");
    // The baseline really machines the pocket (same coverage check).
    assert!(worst_clearance(&p, &single) > -1e-3);
}

fn job_text(outer: &str, holes: &str, catalogue: &str) -> String {
    format!(
        r#"{{"job_id": "t", "strategy": "pocket_mat", "tool": {{"kind": "flat_end", "radius": 5}},
            "surface": {{"kind": "pocket", "outer": {outer}, "holes": {holes}}} {catalogue}}}"#
    )
}

#[test]
fn bad_input_gives_clear_errors() {
    let square = "[[0,0],[100,0],[100,100],[0,100]]";
    // Self-intersecting outline (bow tie).
    let e = formats::parse_job(
        &job_text("[[0,0],[100,0],[100,100],[60,-10],[0,50]]", "[]", ""),
        None,
    )
    .unwrap_err();
    assert!(e.to_string().contains("intersects itself"), "{e}");
    // Hole crossing the outer loop.
    let e = formats::parse_job(
        &job_text(square, "[[[90,40],[120,40],[120,60],[90,60]]]", ""),
        None,
    )
    .unwrap_err();
    assert!(e.to_string().contains("holes[0]"), "{e}");
    // Empty catalogue.
    let e =
        formats::parse_job(&job_text(square, "[]", r#", "tool_catalogue": []"#), None).unwrap_err();
    assert!(e.to_string().contains("tool_catalogue"), "{e}");
    // A pocket narrower than the smallest tool: a 100 x 4 slot and tools from 5 mm.
    let job = formats::parse_job(
        &job_text(
            "[[0,0],[100,0],[100,4],[0,4]]",
            "[]",
            r#", "tool_catalogue": [5, 10]"#,
        ),
        None,
    )
    .unwrap();
    let e = toolpath_planner::planners::plan(&job, &NoProgress).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("tool_catalogue") && msg.contains("narrower"),
        "{msg}"
    );
    assert!(plan_pocket(job.pocket().unwrap(), &[], None, &NoProgress).is_err());
}

#[test]
fn result_fields_and_determinism() {
    let job = samples::job("pocket_with_hole").unwrap();
    let opts = toolpath_planner::pipeline::RunOptions::PLAN_ONLY;
    let a = toolpath_planner::pipeline::run(&job, &NoProgress, opts).unwrap();
    let b = toolpath_planner::pipeline::run(&job, &NoProgress, opts).unwrap();
    assert_eq!(formats::to_json_pretty(&a), formats::to_json_pretty(&b));
    let tools = a.tools.as_ref().unwrap();
    let per_tool = a.stats.path_length_per_tool_mm.as_ref().unwrap();
    assert_eq!(per_tool.len(), tools.len());
    assert!(a.dmax.unwrap() > 0.0 && a.medial_axis.as_ref().unwrap().len() >= 5);
    assert!(a.stats.uncut_area_mm2.unwrap() >= 0.0);
    // The pipeline's total is the sum over the tools' flattened paths.
    let total: f64 = per_tool.iter().sum();
    assert!((a.stats.path_length_mm - total).abs() < 1e-3 * total);
    // Counts: passes and tool-centre points of every tool, time at the feed rate.
    let passes: usize = tools.iter().map(|t| t.passes.len()).sum();
    let points: usize = tools.iter().flat_map(|t| &t.passes).map(Vec::len).sum();
    assert!(points > passes && passes > 0);
    assert_eq!(a.stats.passes, passes);
    assert_eq!(a.stats.points, Some(points));
    let minutes = a.stats.machining_time_min.unwrap();
    assert!((minutes - a.stats.path_length_mm / job.feed_rate).abs() < 1e-9 * minutes);
}

#[test]
fn compare_cli_reports_sequence_against_root_tool() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("rect.json");
    let exe = env!("CARGO_BIN_EXE_toolpath");
    let st = std::process::Command::new(exe)
        .args(["sample", "rect_pocket", "--job", "-o"])
        .arg(&job)
        .status()
        .unwrap();
    assert!(st.success());
    let out = std::process::Command::new(exe)
        .arg("compare")
        .arg(&job)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("medial-axis tools") && text.contains("root tool alone"),
        "{text}"
    );
    // The two cutting lengths in the table agree with the planner's own figures.
    let p = rectangle(100.0, 60.0);
    let seq = plan_pocket(&p, &DEFAULT_TOOL_CATALOGUE, None, &NoProgress).unwrap();
    let single = plan_single_tool(&p, seq.stages.last().unwrap().diameter, None).unwrap();
    for (label, plan) in [("medial-axis tools", &seq), ("root tool alone", &single)] {
        let line = text.lines().find(|l| l.starts_with(label)).unwrap();
        let want = format!("{:.1}", plan.path_length());
        assert!(line.contains(&want), "{line} lacks {want}");
    }
    // The root tool alone: contour passes every 0.9 D cover a 100 x 60 rectangle with
    // total length about area / stepover; the sequence must be far shorter.
    let d = seq.stages.last().unwrap().diameter;
    let estimate = 100.0 * 60.0 / (0.9 * d);
    assert!(
        (single.path_length() - estimate).abs() < 0.15 * estimate,
        "{} vs {estimate}",
        single.path_length()
    );
    assert!(single.path_length() > 3.0 * seq.path_length());
}

/// Random star-shaped pockets with a hole: the plan never panics, never gouges,
/// and leaves uncut only corner material the root tool cannot reach.
#[test]
fn random_star_pockets_plan_without_gouge() {
    let mut rng = toolpath_planner::rng::Lcg64(0x9e37_79b9_7f4a_7c15);
    let mut rnd = move || rng.unit();
    for case in 0..3 {
        let n = 12 + (rnd() * 40.0) as usize;
        let outer: Vec<P2> = (0..n)
            .map(|i| {
                let t = 2.0 * PI * (i as f64 + 0.3 * rnd()) / n as f64;
                let r = 30.0 + 25.0 * rnd();
                [r * t.cos(), r * t.sin()]
            })
            .collect();
        let hole: Vec<P2> = (0..16)
            .map(|i| {
                let t = -2.0 * PI * i as f64 / 16.0;
                [5.0 * t.cos(), 5.0 * t.sin()]
            })
            .collect();
        let p = Pocket::new(&outer, &[hole]).unwrap();
        let plan = match plan_pocket(&p, &DEFAULT_TOOL_CATALOGUE, None, &NoProgress) {
            Ok(plan) => plan,
            Err(e) => panic!("case {case}: {e}"),
        };
        let clearance = worst_clearance(&p, &plan);
        assert!(clearance > -1e-3, "case {case}: gouge {clearance}");
        for w in plan.stages.windows(2) {
            assert!(w[1].diameter < w[0].diameter, "case {case}");
        }
        let r_root = 0.5 * plan.stages.last().unwrap().diameter;
        let h = 0.2;
        let walls: Vec<(P2, P2)> = loops(&p)
            .iter()
            .flat_map(|l| (0..l.len()).map(move |i| (l[i], l[(i + 1) % l.len()])))
            .collect();
        for q in uncovered_points(&p, &plan, h) {
            let (d, alpha) = nearest_sharp_vertex(&p, q);
            let wall = walls
                .iter()
                .map(|&(a, b)| seg_dist(a, b, q))
                .fold(f64::INFINITY, f64::min);
            assert!(
                d <= r_root / (alpha / 2.0).sin() + 2.0 * h || wall <= WALL_TOL + 1e-9,
                "case {case}: uncovered {q:?}, {d} from a corner of {alpha}, {wall} from the wall"
            );
        }
    }
}

/// Dmax / D > 2: several contour passes; the islands they leave at the corners of
/// the contours are cleared along the medial axis, so only the four wall corners
/// stay uncut.
#[test]
fn multi_pass_roughing_clears_islands_along_the_axis() {
    let p = rectangle(100.0, 60.0);
    let plan = plan_pocket(&p, &[8.0], Some(0.02), &NoProgress).unwrap();
    assert_eq!(plan.stages.len(), 1);
    let s = &plan.stages[0];
    assert!(s.passes.len() > 4, "{} passes", s.passes.len());
    let want = 4.0 * corner_area(4.0, PI / 2.0);
    assert!(
        (plan.uncut_area() - want).abs() < 0.02 * want,
        "{} vs {want}",
        plan.uncut_area()
    );
    assert!(worst_clearance(&p, &plan) > -1e-3);
    // Independent raster: nothing uncovered farther than R / sin 45 from a corner.
    for q in uncovered_points(&p, &plan, 0.1) {
        let (d, _) = nearest_sharp_vertex(&p, q);
        assert!(d <= 4.0 * 2f64.sqrt() + 0.2, "{q:?}");
    }
}

/// pocket_mat takes its tools from the catalogue, so a pocket job needs no
/// `tool`; every other strategy still does, and says so.
#[test]
fn pocket_job_without_a_tool_plans_and_others_need_one() {
    let square = "[[0,0],[100,0],[100,60],[0,60]]";
    let text = format!(
        r#"{{"job_id": "t", "strategy": "pocket_mat",
            "surface": {{"kind": "pocket", "outer": {square}, "holes": []}}}}"#
    );
    let job = formats::parse_job(&text, None).unwrap();
    assert!(job.tool.is_none());
    let opts = toolpath_planner::pipeline::RunOptions::PLAN_ONLY;
    let without = toolpath_planner::pipeline::run(&job, &NoProgress, opts).unwrap();
    // The same pocket with a tool named plans the same passes: the tools come
    // from the medial axis and the catalogue either way.
    let with = formats::parse_job(&job_text(square, "[]", ""), None).unwrap();
    let with = toolpath_planner::pipeline::run(&with, &NoProgress, opts).unwrap();
    assert_eq!(
        serde_json::to_string(&without.tools).unwrap(),
        serde_json::to_string(&with.tools).unwrap()
    );
    // A 100 x 60 rectangle: Dmax = 60, roughed with the 30 mm tool.
    let tools = without.tools.as_ref().unwrap();
    assert_eq!(tools[0].diameter, 30.0);
    let plane = samples::job("plane").unwrap();
    let mut f = plane.to_file();
    f.tool = None;
    let e = formats::Job::new(f, plane.shape.clone()).unwrap_err();
    assert!(e.to_string().contains("tool"), "{e}");
}
