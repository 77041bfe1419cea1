//! `toolpath plot`: a picture is produced for results of every kind, and the
//! colours that carry meaning (regions, tools, residual map) are really drawn.

use std::collections::BTreeSet;
use std::path::Path;
use toolpath_planner::formats::result::{DegeneratePoint, MedialBranch, PocketTool};
use toolpath_planner::formats::{Pass, PathPoint, PlanResult};
use toolpath_planner::geometry::{NurbsSurface, Pocket};
use toolpath_planner::plot::{self, PlotInput, ResidualOverlay};

/// A bicubic bump, 100 x 80 mm, 15 mm high in the middle.
fn bump() -> NurbsSurface {
    let knots = vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
    let cps: Vec<Vec<[f64; 3]>> = (0..4)
        .map(|i| {
            (0..4)
                .map(|j| {
                    let z = if (1..3).contains(&i) && (1..3).contains(&j) {
                        20.0
                    } else {
                        0.0
                    };
                    [100.0 * i as f64 / 3.0, 80.0 * j as f64 / 3.0, z]
                })
                .collect()
        })
        .collect();
    NurbsSurface::new(3, 3, knots.clone(), knots, &cps, None).unwrap()
}

/// Zig-zag passes along u over the surface, region 0 for v < 0.5 and 1 above.
fn freeform_result(s: &NurbsSurface) -> PlanResult {
    let mut r = PlanResult::new("bump_job", "tensor_regions");
    for k in 0..12 {
        let v = (k as f64 + 0.5) / 12.0;
        let points = (0..=40)
            .map(|i| {
                let u = if k % 2 == 0 {
                    i as f64 / 40.0
                } else {
                    1.0 - i as f64 / 40.0
                };
                let p = s.point(u, v);
                PathPoint {
                    cc: [p.x, p.y, p.z],
                    cl: [p.x, p.y, p.z],
                    axis: [0.0, 0.0, 1.0],
                    uv: [u, v],
                    ..Default::default()
                }
            })
            .collect();
        r.passes.push(Pass {
            region: usize::from(v > 0.5),
            points,
            min_strip_width: None,
        });
    }
    let p = s.point(0.5, 0.5);
    r.degenerate_points = Some(vec![
        DegeneratePoint {
            uv: [0.5, 0.5],
            xyz: [p.x, p.y, p.z],
            kind: "trisector".into(),
        },
        DegeneratePoint {
            uv: [0.2, 0.5],
            xyz: {
                let q = s.point(0.2, 0.5);
                [q.x, q.y, q.z]
            },
            kind: "wedge".into(),
        },
    ]);
    r.separatrices = Some(vec![(0..=20)
        .map(|i| {
            let q = s.point(i as f64 / 20.0, 0.5);
            [q.x, q.y, q.z]
        })
        .collect()]);
    r.stats.passes = r.passes.len();
    r
}

fn residual(s: &NurbsSurface) -> ResidualOverlay {
    let (nu, nv) = (60, 50);
    let mut xyz = Vec::new();
    let mut res = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let (u, v) = (i as f64 / (nu - 1) as f64, j as f64 / (nv - 1) as f64);
            let p = s.point(u, v);
            xyz.push([p.x, p.y, p.z]);
            // A scallop-like ripple across v, uncut in one corner.
            res.push(if u > 0.9 && v > 0.9 {
                None
            } else {
                Some(0.05 * (v * 12.0 * std::f64::consts::PI).sin().abs())
            });
        }
    }
    ResidualOverlay {
        nu,
        nv,
        xyz,
        residual: res,
        gouge_tolerance: 0.005,
    }
}

/// `map` with the samples of u in [0.3, 0.5], v in [0.2, 0.4] cut `depth` mm
/// below the surface.
fn with_cut_below(mut map: ResidualOverlay, depth: f64) -> ResidualOverlay {
    for i in 0..map.nu {
        for j in 0..map.nv {
            let (u, v) = (
                i as f64 / (map.nu - 1) as f64,
                j as f64 / (map.nv - 1) as f64,
            );
            if (0.3..=0.5).contains(&u) && (0.2..=0.4).contains(&v) {
                map.residual[i * map.nv + j] = Some(-depth);
            }
        }
    }
    map
}

/// Pixels of `c` in the residual-map panel (the third, above the legend):
/// their count and the mean pixel position.
fn in_map_panel(img: &image::RgbImage, c: (u8, u8, u8)) -> (usize, f64, f64) {
    let (mut n, mut sx, mut sy) = (0, 0.0, 0.0);
    for (x, y, p) in img.enumerate_pixels() {
        if x >= 2 * 640 && y < 40 + 600 && (p[0], p[1], p[2]) == c {
            n += 1;
            sx += x as f64;
            sy += y as f64;
        }
    }
    (n, sx / n.max(1) as f64, sy / n.max(1) as f64)
}

fn pocket() -> Pocket {
    let outer = vec![[0.0, 0.0], [60.0, 0.0], [60.0, 40.0], [0.0, 40.0]];
    let hole = vec![[25.0, 15.0], [25.0, 25.0], [35.0, 25.0], [35.0, 15.0]];
    Pocket::new(&outer, &[hole]).unwrap()
}

fn pocket_result() -> PlanResult {
    let mut r = PlanResult::new("pocket_job", "pocket_mat");
    let ring = |off: f64| {
        vec![
            [off, off],
            [60.0 - off, off],
            [60.0 - off, 40.0 - off],
            [off, 40.0 - off],
            [off, off],
        ]
    };
    r.tools = Some(vec![
        PocketTool {
            stage: "roughing".into(),
            diameter: 10.0,
            passes: vec![ring(5.0), ring(12.0)],
            path_length_mm: None,
        },
        PocketTool {
            stage: "corner".into(),
            diameter: 4.0,
            passes: vec![
                vec![[2.0, 2.0], [4.0, 4.0]],
                vec![[58.0, 38.0], [56.0, 36.0]],
            ],
            path_length_mm: None,
        },
    ]);
    r.medial_axis = Some(vec![MedialBranch {
        points: vec![[0.0, 0.0, 0.0], [20.0, 20.0, 20.0], [40.0, 20.0, 20.0]],
    }]);
    r
}

fn colors(path: &Path) -> (u32, u32, BTreeSet<(u8, u8, u8)>, image::RgbImage) {
    let img = image::open(path).unwrap().to_rgb8();
    let set = img.pixels().map(|p| (p[0], p[1], p[2])).collect();
    (img.width(), img.height(), set, img)
}

fn count(img: &image::RgbImage, c: (u8, u8, u8)) -> usize {
    img.pixels().filter(|p| (p[0], p[1], p[2]) == c).count()
}

#[test]
fn freeform_result_with_residual_map() {
    let dir = tempfile::tempdir().unwrap();
    let s = bump();
    let r = freeform_result(&s);
    let map = residual(&s);
    let input = PlotInput {
        result: &r,
        surface: Some(&s),
        pocket: None,
        residual: Some(&map),
    };
    let png = dir.path().join("bump.png");
    plot::draw(&input, &png).unwrap();
    let (w, h, set, img) = colors(&png);
    assert_eq!((w, h), plot::picture_size(&input));
    assert_eq!(w, 3 * 640, "three panels when a residual map is given");
    // Both regions drawn, markers of both kinds.
    for c in [
        plot::region_color(0),
        plot::region_color(1),
        (220, 0, 0),
        (0, 0, 200),
    ] {
        assert!(count(&img, c) > 20, "colour {c:?} missing");
    }
    // The colour map spans low and high values, and the uncut corner shows.
    assert!(set.contains(&plot::colormap(0.0)) || count(&img, plot::colormap(0.05)) > 0);
    assert!(count(&img, (255, 0, 255)) > 10, "uncut cells");
    let high = set
        .iter()
        .filter(|c| c.0 > 200 && c.1 > 200 && c.2 < 80)
        .count();
    assert!(high > 0, "the high end of the colour map is drawn");
    // Region 1 lies in y > 40 in the top view: the upper half of the left panel.
    let (mut upper, mut lower) = (0, 0);
    for (_, y, p) in img.enumerate_pixels().filter(|(x, _, _)| *x < 640) {
        if (p[0], p[1], p[2]) == plot::region_color(1) {
            if y < 40 + 330 {
                upper += 1
            } else {
                lower += 1
            }
        }
    }
    assert!(
        upper > 10 * lower.max(1) / 2 && upper > 50,
        "region 1 is drawn where it is: {upper} vs {lower}"
    );

    let svg = dir.path().join("bump.svg");
    plot::draw(&input, &svg).unwrap();
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg"));
    assert!(
        text.contains("#1F77B4") || text.contains("#1f77b4"),
        "region 0 colour in the SVG"
    );
    // Same input, same bytes.
    let svg2 = dir.path().join("bump2.svg");
    plot::draw(&input, &svg2).unwrap();
    assert_eq!(text, std::fs::read_to_string(&svg2).unwrap());
}

#[test]
fn gouge_is_marked_only_beyond_the_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let s = bump();
    let r = freeform_result(&s);
    let draw = |map: &ResidualOverlay, name: &str| {
        let input = PlotInput {
            result: &r,
            surface: Some(&s),
            pocket: None,
            residual: Some(map),
        };
        let png = dir.path().join(name);
        plot::draw(&input, &png).unwrap();
        colors(&png).3
    };
    let gouge = plot::gouge_color();
    // 0.004 mm below the surface is within the 0.005 mm tolerance: no gouge.
    let within = with_cut_below(residual(&s), 0.004);
    let (n, _, _) = in_map_panel(&draw(&within, "within.png"), gouge);
    assert_eq!(n, 0, "cells within the tolerance painted as gouge");
    // 0.006 mm is beyond it: the patch is red, where it lies. Its centre
    // (u 0.4, v 0.3) is at x = 40 mm, y = 24 mm of the 100 x 80 mm part, left
    // of and below the middle of the top view.
    let beyond = with_cut_below(residual(&s), 0.006);
    let (n, x, y) = in_map_panel(&draw(&beyond, "beyond.png"), gouge);
    assert!(n > 2000, "gouge cells beyond the tolerance: {n} pixels");
    let (mid_x, mid_y) = (2.0 * 640.0 + 0.5 * 550.0, 40.0 + 300.0 + 12.0);
    assert!(
        x < mid_x - 20.0 && y > mid_y + 20.0,
        "gouge drawn at ({x}, {y})"
    );
    // The tolerance is the map's, not a fixed number: at 0.003 mm the
    // 0.004 mm cut is a gouge.
    let strict = ResidualOverlay {
        gouge_tolerance: 0.003,
        ..within.clone()
    };
    let (n, _, _) = in_map_panel(&draw(&strict, "strict.png"), gouge);
    assert!(
        n > 2000,
        "gouge cells beyond a 0.003 mm tolerance: {n} pixels"
    );
    // The legend states the threshold.
    let svg = dir.path().join("within.svg");
    plot::draw(
        &PlotInput {
            result: &r,
            surface: Some(&s),
            pocket: None,
            residual: Some(&within),
        },
        &svg,
    )
    .unwrap();
    let text = std::fs::read_to_string(&svg).unwrap();
    if plot::font_available() {
        assert!(
            text.contains("gouge &gt; 0.005 mm") || text.contains("gouge > 0.005 mm"),
            "legend without the threshold"
        );
    }
    let bad = ResidualOverlay {
        gouge_tolerance: f64::NAN,
        ..within
    };
    let e = plot::draw(
        &PlotInput {
            result: &r,
            surface: None,
            pocket: None,
            residual: Some(&bad),
        },
        &dir.path().join("bad.png"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("residual.gouge_tolerance"), "{e}");
}

#[test]
fn freeform_without_surface_or_map_and_empty_result() {
    let dir = tempfile::tempdir().unwrap();
    let s = bump();
    let r = freeform_result(&s);
    let input = PlotInput {
        result: &r,
        surface: None,
        pocket: None,
        residual: None,
    };
    let png = dir.path().join("plain.png");
    plot::draw(&input, &png).unwrap();
    let (w, _, _, img) = colors(&png);
    assert_eq!(w, 2 * 640);
    assert!(count(&img, plot::region_color(0)) > 50);

    let empty = PlanResult::new("empty", "iso_scallop");
    let input = PlotInput {
        result: &empty,
        surface: Some(&s),
        pocket: None,
        residual: None,
    };
    let png = dir.path().join("empty.png");
    plot::draw(&input, &png).unwrap();
    let (_, _, _, img) = colors(&png);
    assert_eq!(count(&img, plot::region_color(0)), 0);
}

#[test]
fn pocket_result_shows_each_tool() {
    let dir = tempfile::tempdir().unwrap();
    let r = pocket_result();
    let p = pocket();
    let input = PlotInput {
        result: &r,
        surface: None,
        pocket: Some(&p),
        residual: None,
    };
    let png = dir.path().join("pocket.png");
    plot::draw(&input, &png).unwrap();
    let (_, _, _, img) = colors(&png);
    let rough = count(&img, plot::tool_color(0));
    let corner = count(&img, plot::tool_color(1));
    assert!(rough > 1000, "roughing area {rough}");
    assert!(corner > 10, "corner tool area {corner}");
    // The corner tool sweeps far less than the roughing tool.
    assert!(corner * 10 < rough);
    let svg = dir.path().join("pocket.svg");
    plot::draw(&input, &svg).unwrap();
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
}

#[test]
fn belt_result_is_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let s = bump();
    let mut r = freeform_result(&s);
    r.strategy = "belt_iso_planar".into();
    r.degenerate_points = None;
    r.separatrices = None;
    for p in r.passes.iter_mut().flat_map(|p| p.points.iter_mut()) {
        p.feed = Some([1.0, 0.0, 0.0]);
        p.wheel_center = Some(p.cl);
    }
    let input = PlotInput {
        result: &r,
        surface: Some(&s),
        pocket: None,
        residual: None,
    };
    let png = dir.path().join("belt.png");
    plot::draw(&input, &png).unwrap();
    let (_, _, _, img) = colors(&png);
    assert!(count(&img, plot::region_color(1)) > 50);
}

#[test]
fn bad_input_gives_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let s = bump();
    let mut r = freeform_result(&s);
    let input = PlotInput {
        result: &r,
        surface: None,
        pocket: None,
        residual: None,
    };
    let e = plot::draw(&input, &dir.path().join("x.jpg"))
        .unwrap_err()
        .to_string();
    assert!(e.contains(".png or .svg"), "{e}");
    r.passes[3].points[2].cc[1] = f64::NAN;
    let input = PlotInput {
        result: &r,
        surface: None,
        pocket: None,
        residual: None,
    };
    let e = plot::draw(&input, &dir.path().join("x.png"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("passes[3].points[2]"), "{e}");
    let mut map = residual(&s);
    map.residual.pop();
    let r = freeform_result(&s);
    let input = PlotInput {
        result: &r,
        surface: None,
        pocket: None,
        residual: Some(&map),
    };
    let e = plot::draw(&input, &dir.path().join("x.png"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("residual.residual"), "{e}");
}

#[test]
fn cli_plots_a_result_file() {
    let dir = tempfile::tempdir().unwrap();
    let s = bump();
    let r = freeform_result(&s);
    let result = dir.path().join("r.json");
    std::fs::write(&result, serde_json::to_string(&r).unwrap()).unwrap();
    let out = dir.path().join("r.png");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .args([
            "plot",
            result.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .status()
        .unwrap();
    assert!(status.success());
    assert!(image::open(&out).is_ok());
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_toolpath"))
        .args([
            "plot",
            dir.path().join("missing.json").to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("missing.json"));
    if let Ok(keep) = std::env::var("TOOLPATH_PLOT_KEEP") {
        // For looking at the pictures by hand.
        let keep = Path::new(&keep);
        std::fs::create_dir_all(keep).unwrap();
        let map = residual(&s);
        let p = pocket();
        let pr = pocket_result();
        plot::draw(
            &PlotInput {
                result: &r,
                surface: Some(&s),
                pocket: None,
                residual: Some(&map),
            },
            &keep.join("freeform.png"),
        )
        .unwrap();
        plot::draw(
            &PlotInput {
                result: &pr,
                surface: None,
                pocket: Some(&p),
                residual: None,
            },
            &keep.join("pocket.png"),
        )
        .unwrap();
    }
}
