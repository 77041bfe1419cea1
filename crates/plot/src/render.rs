//! Scene building (world -> pixel projections) and drawing with plotters.

use super::{font_available, PlotInput};
use plotters::coord::Shift;
use plotters::prelude::*;

pub const PANEL_W: u32 = 640;
pub const PANEL_H: u32 = 600;
pub const TITLE_H: u32 = 40;
pub const LEGEND_H: u32 = 70;

/// Distinct colours for regions (Tableau 10).
pub const REGION_COLORS: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

/// Pocket tools: roughing first, then the finer tools.
pub const TOOL_COLORS: [(u8, u8, u8); 6] = [
    (158, 202, 225),
    (253, 174, 107),
    (161, 217, 155),
    (188, 189, 220),
    (252, 146, 114),
    (217, 217, 217),
];

const TRISECTOR: (u8, u8, u8) = (220, 0, 0);
const WEDGE: (u8, u8, u8) = (0, 0, 200);
const SEPARATRIX: (u8, u8, u8) = (0, 0, 0);
const FEED: (u8, u8, u8) = (60, 60, 60);
const OUTLINE: (u8, u8, u8) = (150, 150, 150);
/// Cells where the tool cut below the surface by more than the gouge tolerance.
pub const GOUGE: (u8, u8, u8) = (230, 0, 0);
/// Residual samples the simulator left uncut.
pub const UNCUT: (u8, u8, u8) = (255, 0, 255);

const VIRIDIS: [(f64, f64, f64); 5] = [
    (68.0, 1.0, 84.0),
    (59.0, 82.0, 139.0),
    (33.0, 145.0, 140.0),
    (94.0, 201.0, 98.0),
    (253.0, 231.0, 37.0),
];

pub fn colormap(t: f64) -> (u8, u8, u8) {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |p: f64, q: f64| (p + (q - p) * f).round() as u8;
    (mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

fn rgb(c: (u8, u8, u8)) -> RGBColor {
    RGBColor(c.0, c.1, c.2)
}

/// A projection of world points onto the page.
#[derive(Clone, Copy)]
enum Projection {
    Top,
    /// Rotation about z by `az`, then tilt by `el` (radians).
    Oblique {
        az: f64,
        el: f64,
    },
}

impl Projection {
    /// Page coordinates (y up) and depth (larger = nearer the viewer).
    fn project(self, p: [f64; 3]) -> (f64, f64, f64) {
        match self {
            Projection::Top => (p[0], p[1], p[2]),
            Projection::Oblique { az, el } => {
                let (s, c) = az.sin_cos();
                let xr = c * p[0] - s * p[1];
                let yr = s * p[0] + c * p[1];
                let (se, ce) = el.sin_cos();
                (xr, yr * se + p[2] * ce, -yr * ce + p[2] * se)
            }
        }
    }
}

/// A panel: its pixel rectangle and the world -> pixel map fitted to its content.
#[derive(Clone, Copy)]
struct Panel {
    x0: i32,
    y0: i32,
    w: i32,
    h: i32,
    proj: Projection,
    scale: f64,
    cx: f64,
    cy: f64,
}

impl Panel {
    fn fit(x0: i32, y0: i32, w: i32, h: i32, proj: Projection, points: &[[f64; 3]]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in points {
            let (x, y, _) = proj.project(*p);
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
        if !(lo[0].is_finite() && hi[0].is_finite()) {
            lo = [-1.0, -1.0];
            hi = [1.0, 1.0];
        }
        let dx = (hi[0] - lo[0]).max(1e-9);
        let dy = (hi[1] - lo[1]).max(1e-9);
        // Margins: 30 px around, 24 px at the top for the panel title.
        let scale = ((w - 60) as f64 / dx).min((h - 84) as f64 / dy);
        Panel {
            x0,
            y0,
            w,
            h,
            proj,
            scale,
            cx: 0.5 * (lo[0] + hi[0]),
            cy: 0.5 * (lo[1] + hi[1]),
        }
    }

    fn px(&self, p: [f64; 3]) -> (i32, i32) {
        let (x, y, _) = self.proj.project(p);
        let sx = self.x0 as f64 + 0.5 * self.w as f64 + (x - self.cx) * self.scale;
        let sy = self.y0 as f64 + 0.5 * self.h as f64 + 12.0 - (y - self.cy) * self.scale;
        (sx.round() as i32, sy.round() as i32)
    }

    fn depth(&self, p: [f64; 3]) -> f64 {
        self.proj.project(p).2
    }
}

struct Line {
    points: Vec<(i32, i32)>,
    color: (u8, u8, u8),
    width: u32,
}

struct Marker {
    at: (i32, i32),
    color: (u8, u8, u8),
    /// true: filled triangle (trisector); false: filled square (wedge).
    triangle: bool,
}

struct Quad {
    corners: Vec<(i32, i32)>,
    color: (u8, u8, u8),
    depth: f64,
}

/// Rows of a coverage mask as filled pixel runs: (y, x_start, x_end_exclusive).
struct Runs {
    color: (u8, u8, u8),
    runs: Vec<(i32, i32, i32)>,
}

#[derive(Default)]
struct PanelDrawing {
    title: String,
    frame: (i32, i32, i32, i32),
    fills: Vec<Runs>,
    quads: Vec<Quad>,
    lines: Vec<Line>,
    markers: Vec<Marker>,
    scale_bar: Option<((i32, i32), i32, String)>,
    color_scale: Option<ColorScale>,
    note: Option<String>,
}

struct ColorScale {
    x: i32,
    y: i32,
    h: i32,
    max: f64,
}

/// Everything to draw, in pixels: built once, rendered to any backend.
pub struct Scene {
    size: (u32, u32),
    title: String,
    panels: Vec<PanelDrawing>,
    legend: Vec<((u8, u8, u8), String)>,
}

/// Round length of about a fifth of `extent` (1, 2 or 5 times a power of ten).
fn nice_length(extent: f64) -> f64 {
    let target = (extent / 5.0).max(1e-9);
    let p = 10f64.powf(target.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .rfind(|&l| l <= target)
        .unwrap_or(p)
}

fn format_length(l: f64) -> String {
    if l >= 1.0 {
        format!("{l:.0} mm")
    } else {
        format!("{l} mm")
    }
}

/// Every `k`-th sample so that a polyline keeps at most `max` points.
fn thin<T: Copy>(v: &[T], max: usize) -> Vec<T> {
    if v.len() <= max {
        return v.to_vec();
    }
    let k = v.len().div_ceil(max);
    let mut out: Vec<T> = v.iter().step_by(k).copied().collect();
    if let Some(&last) = v.last() {
        if !(v.len() - 1).is_multiple_of(k) {
            out.push(last);
        }
    }
    out
}

impl Scene {
    pub fn build(input: &PlotInput, size: (u32, u32)) -> Scene {
        let r = input.result;
        // Pocket results keep their tool-centre points per tool, counted in stats.points.
        let points = r.stats.points.unwrap_or_else(|| r.point_count());
        let title = format!(
            "{} - {} - {} passes, {} points, length {:.1} mm",
            if r.job_id.is_empty() {
                "result"
            } else {
                &r.job_id
            },
            r.strategy,
            match &r.tools {
                Some(t) => t.iter().map(|t| t.passes.len()).sum(),
                None => r.passes.len(),
            },
            points,
            r.stats.path_length_mm
        );
        let mut scene = Scene {
            size,
            title,
            panels: Vec::new(),
            legend: Vec::new(),
        };
        if r.tools.is_some() || input.pocket.is_some() {
            scene.build_pocket(input);
        } else {
            scene.build_freeform(input);
        }
        scene
    }

    /// World points that frame the freeform views: surface samples and contact points.
    fn freeform_extent(input: &PlotInput) -> Vec<[f64; 3]> {
        let mut pts: Vec<[f64; 3]> = Vec::new();
        if let Some(s) = input.surface {
            pts.extend(surface_outline(s).into_iter().flatten());
        }
        for pass in &input.result.passes {
            pts.extend(pass.points.iter().map(|p| p.cc));
        }
        if let Some(map) = input.residual {
            pts.extend(map.xyz.iter().copied());
        }
        pts
    }

    /// The freeform picture: the top and oblique views of the passes, the
    /// residual map when the result was simulated, and the legend.
    fn build_freeform(&mut self, input: &PlotInput) {
        let extent = Self::freeform_extent(input);
        let (w, h) = (PANEL_W as i32, PANEL_H as i32);
        let views = [
            ("top view (x right, y up)", Projection::Top),
            (
                "oblique view",
                Projection::Oblique {
                    az: (-35f64).to_radians(),
                    el: 35f64.to_radians(),
                },
            ),
        ];
        for (k, (name, proj)) in views.into_iter().enumerate() {
            let panel = Panel::fit(k as i32 * w, TITLE_H as i32, w, h, proj, &extent);
            let d = Self::freeform_view(input, name, &panel, &extent, k == 0);
            self.panels.push(d);
        }
        if let Some(map) = input.residual {
            self.panels.push(Self::residual_view(map, &extent));
        }
        self.freeform_legend(input);
    }

    /// One view of the passes: surface outline, passes coloured by region,
    /// separatrices, feed arrows, degenerate points; the scale bar on the
    /// first view only.
    fn freeform_view(
        input: &PlotInput,
        name: &str,
        panel: &Panel,
        extent: &[[f64; 3]],
        with_scale_bar: bool,
    ) -> PanelDrawing {
        let r = input.result;
        let (w, h) = (PANEL_W as i32, PANEL_H as i32);
        let mut d = PanelDrawing {
            title: name.to_string(),
            frame: (panel.x0, panel.y0, w, h),
            ..Default::default()
        };
        if let Some(s) = input.surface {
            for curve in surface_outline(s) {
                d.lines.push(Line {
                    points: curve.iter().map(|p| panel.px(*p)).collect(),
                    color: OUTLINE,
                    width: 1,
                });
            }
        }
        for pass in &r.passes {
            let cc: Vec<[f64; 3]> = pass.points.iter().map(|p| p.cc).collect();
            d.lines.push(Line {
                points: thin(&cc, 4000).iter().map(|p| panel.px(*p)).collect(),
                color: REGION_COLORS[pass.region % REGION_COLORS.len()],
                width: 2,
            });
        }
        for sep in r.separatrices.iter().flatten() {
            d.lines.push(Line {
                points: sep.iter().map(|p| panel.px(*p)).collect(),
                color: SEPARATRIX,
                width: 3,
            });
        }
        self::feed_arrows(r, panel, extent, &mut d);
        for dp in r.degenerate_points.iter().flatten() {
            d.markers.push(Marker {
                at: panel.px(dp.xyz),
                color: if dp.kind == "trisector" {
                    TRISECTOR
                } else {
                    WEDGE
                },
                triangle: dp.kind == "trisector",
            });
        }
        if with_scale_bar {
            d.scale_bar = scale_bar(panel, extent);
        }
        if r.passes.is_empty() {
            d.note = Some("no passes in this result".to_string());
        }
        d
    }

    /// The third panel: the simulator's residual height, top view, with its
    /// colour scale.
    fn residual_view(map: &super::ResidualOverlay, extent: &[[f64; 3]]) -> PanelDrawing {
        let (w, h) = (PANEL_W as i32, PANEL_H as i32);
        let y0 = TITLE_H as i32;
        let panel = Panel::fit(2 * w, y0, w - 90, h, Projection::Top, extent);
        let mut d = PanelDrawing {
            title: "residual height (simulator), top view".to_string(),
            frame: (panel.x0, panel.y0, w, h),
            ..Default::default()
        };
        let max =
            map.residual.iter().flatten().fold(
                0.0f64,
                |m, &x| {
                    if x.is_finite() {
                        m.max(x)
                    } else {
                        m
                    }
                },
            );
        residual_quads(map, &panel, max, &mut d);
        d.color_scale = Some(ColorScale {
            x: panel.x0 + w - 84,
            y: y0 + 60,
            h: h - 140,
            max,
        });
        d.scale_bar = scale_bar(&panel, extent);
        d
    }

    /// Legend of the freeform picture: regions (at most 8 named), the kinds of
    /// degenerate point present, separatrix, feed, uncut and gouge colours.
    fn freeform_legend(&mut self, input: &PlotInput) {
        let r = input.result;
        let mut regions: Vec<usize> = r.passes.iter().map(|p| p.region).collect();
        regions.sort_unstable();
        regions.dedup();
        for &id in regions.iter().take(8) {
            self.legend.push((
                REGION_COLORS[id % REGION_COLORS.len()],
                format!("region {id}"),
            ));
        }
        if regions.len() > 8 {
            self.legend
                .push((OUTLINE, format!("... {} regions", regions.len())));
        }
        let kinds = |k: &str| r.degenerate_points.iter().flatten().any(|d| d.kind == k);
        if kinds("trisector") {
            self.legend.push((TRISECTOR, "trisector".into()));
        }
        if r.degenerate_points
            .iter()
            .flatten()
            .any(|d| d.kind != "trisector")
        {
            self.legend.push((WEDGE, "wedge".into()));
        }
        if r.separatrices.as_ref().is_some_and(|s| !s.is_empty()) {
            self.legend.push((SEPARATRIX, "separatrix".into()));
        }
        if !r.passes.is_empty() {
            self.legend.push((FEED, "feed direction".into()));
        }
        if input
            .residual
            .is_some_and(|m| m.residual.iter().any(|x| x.is_none()))
        {
            self.legend.push((UNCUT, "uncut".into()));
        }
        // Stated whenever a map is shown: no red then reads as "no gouge
        // beyond the tolerance", not as "gouges not looked for".
        if let Some(m) = input.residual {
            self.legend
                .push((GOUGE, format!("gouge > {} mm", m.gouge_tolerance)));
        }
    }

    fn build_pocket(&mut self, input: &PlotInput) {
        let r = input.result;
        let tools = r.tools.as_deref().unwrap_or(&[]);
        let mut extent: Vec<[f64; 3]> = Vec::new();
        if let Some(p) = input.pocket {
            extent.extend(p.outer.iter().map(|q| [q[0], q[1], 0.0]));
        }
        for t in tools {
            for pass in &t.passes {
                // The swept area reaches a radius beyond the centre path.
                for q in pass {
                    let rr = 0.5 * t.diameter;
                    extent.push([q[0] - rr, q[1] - rr, 0.0]);
                    extent.push([q[0] + rr, q[1] + rr, 0.0]);
                }
            }
        }
        let (w, h) = (PANEL_W as i32, PANEL_H as i32);
        let y0 = TITLE_H as i32;
        let loops: Vec<Vec<[f64; 3]>> = input
            .pocket
            .map(|p| {
                std::iter::once(&p.outer)
                    .chain(p.holes.iter())
                    .map(|l| {
                        let mut v: Vec<[f64; 3]> = l.iter().map(|q| [q[0], q[1], 0.0]).collect();
                        if let Some(&first) = v.first() {
                            v.push(first);
                        }
                        v
                    })
                    .collect()
            })
            .unwrap_or_default();

        // Panel 1: swept areas.
        let panel = Panel::fit(0, y0, w, h, Projection::Top, &extent);
        let mut d = PanelDrawing {
            title: "swept area per tool".into(),
            frame: (0, y0, w, h),
            ..Default::default()
        };
        for (k, t) in tools.iter().enumerate() {
            d.fills
                .push(swept_runs(t, &panel, TOOL_COLORS[k % TOOL_COLORS.len()]));
        }
        for l in &loops {
            d.lines.push(Line {
                points: l.iter().map(|p| panel.px(*p)).collect(),
                color: (0, 0, 0),
                width: 2,
            });
        }
        d.scale_bar = scale_bar(&panel, &extent);
        if tools.is_empty() {
            d.note = Some("no tools in this result".into());
        }
        self.panels.push(d);

        self.panels
            .push(centre_paths_panel(input, &extent, &loops, (w, y0, w, h)));
        for (k, t) in tools.iter().enumerate() {
            self.legend.push((
                TOOL_COLORS[k % TOOL_COLORS.len()],
                format!("{} D{} mm, {} passes", t.stage, t.diameter, t.passes.len()),
            ));
        }
        if r.medial_axis.is_some() {
            self.legend.push((OUTLINE, "medial axis".into()));
        }
    }

    pub fn render<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        let text = font_available();
        root.fill(&WHITE)?;
        let label = |s: &str, at: (i32, i32), size: u32| label(root, text, s, at, size);
        label(&self.title, (12, 10), 20)?;
        for d in &self.panels {
            let (x, y, w, h) = d.frame;
            for f in &d.fills {
                let style = rgb(f.color).filled();
                for &(ry, xa, xb) in &f.runs {
                    root.draw(&Rectangle::new([(xa, ry), (xb, ry + 1)], style))?;
                }
            }
            for q in &d.quads {
                root.draw(&Polygon::new(q.corners.clone(), rgb(q.color).filled()))?;
            }
            for l in &d.lines {
                if l.points.len() >= 2 {
                    root.draw(&PathElement::new(
                        l.points.clone(),
                        rgb(l.color).stroke_width(l.width),
                    ))?;
                }
            }
            for m in &d.markers {
                let (mx, my) = m.at;
                let style = rgb(m.color).filled();
                if m.triangle {
                    root.draw(&Polygon::new(
                        vec![(mx, my - 8), (mx - 7, my + 5), (mx + 7, my + 5)],
                        style,
                    ))?;
                } else {
                    root.draw(&Rectangle::new([(mx - 6, my - 6), (mx + 6, my + 6)], style))?;
                }
            }
            if let Some((at, len, s)) = &d.scale_bar {
                draw_scale_bar(root, text, *at, *len, s)?;
            }
            if let Some(cs) = &d.color_scale {
                draw_color_scale(root, text, cs)?;
            }
            if let Some(n) = &d.note {
                label(n, (x + 30, y + h / 2), 16)?;
            }
            root.draw(&Rectangle::new(
                [(x + 1, y + 1), (x + w - 1, y + h - 1)],
                RGBColor(200, 200, 200).stroke_width(1),
            ))?;
            label(&d.title, (x + 10, y + 8), 15)?;
        }
        let ly = TITLE_H as i32 + PANEL_H as i32 + 12;
        let mut lx = 12;
        for (c, s) in &self.legend {
            if lx > self.size.0 as i32 - 160 {
                break;
            }
            root.draw(&Rectangle::new(
                [(lx, ly), (lx + 18, ly + 12)],
                rgb(*c).filled(),
            ))?;
            label(s, (lx + 24, ly - 1), 13)?;
            lx += 30 + 8 * s.chars().count() as i32;
        }
        Ok(())
    }
}

/// The pocket's second panel: its outline, the medial axis and each tool's
/// centre paths (`extent`: the points the panel must show; `frame`: x, y,
/// width, height in px).
fn centre_paths_panel(
    input: &PlotInput,
    extent: &[[f64; 3]],
    loops: &[Vec<[f64; 3]>],
    frame: (i32, i32, i32, i32),
) -> PanelDrawing {
    let r = input.result;
    let tools = r.tools.as_deref().unwrap_or(&[]);
    let (x, y, w, h) = frame;
    let panel = Panel::fit(x, y, w, h, Projection::Top, extent);
    let mut d = PanelDrawing {
        title: "tool-centre paths and medial axis".into(),
        frame,
        ..Default::default()
    };
    for l in loops {
        d.lines.push(Line {
            points: l.iter().map(|p| panel.px(*p)).collect(),
            color: OUTLINE,
            width: 1,
        });
    }
    for branch in r.medial_axis.iter().flatten() {
        d.lines.push(Line {
            points: branch
                .points
                .iter()
                .map(|q| panel.px([q[0], q[1], 0.0]))
                .collect(),
            color: OUTLINE,
            width: 1,
        });
    }
    for (k, t) in tools.iter().enumerate() {
        let c = TOOL_COLORS[k % TOOL_COLORS.len()];
        // Darker than the fill so thin lines stay visible.
        let dark = (c.0 / 2, c.1 / 2, c.2 / 2);
        for pass in &t.passes {
            d.lines.push(Line {
                points: pass.iter().map(|q| panel.px([q[0], q[1], 0.0])).collect(),
                color: dark,
                width: 1,
            });
        }
    }
    d
}

/// What drawing on a plotters area returns.
type Drawn<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// Text `s` at `at` in black, `size` px; nothing where no font is
/// available (`text` false).
fn label<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    text: bool,
    s: &str,
    at: (i32, i32),
    size: u32,
) -> Drawn<DB> {
    if text {
        root.draw(&Text::new(
            s.to_string(),
            at,
            ("sans-serif", size).into_font().color(&BLACK),
        ))?;
    }
    Ok(())
}

/// A scale bar of `len` px from `(bx, by)` with ticks at its ends and its
/// length `s` beside it.
fn draw_scale_bar<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    text: bool,
    (bx, by): (i32, i32),
    len: i32,
    s: &str,
) -> Drawn<DB> {
    root.draw(&PathElement::new(
        vec![(bx, by), (bx + len, by)],
        BLACK.stroke_width(3),
    ))?;
    root.draw(&PathElement::new(
        vec![(bx, by - 5), (bx, by + 5)],
        BLACK.stroke_width(2),
    ))?;
    root.draw(&PathElement::new(
        vec![(bx + len, by - 5), (bx + len, by + 5)],
        BLACK.stroke_width(2),
    ))?;
    label(root, text, s, (bx + len + 8, by - 8), 14)
}

/// The colour scale of a map: the colormap from 0 (bottom) to `cs.max`
/// (top) with five labelled ticks, in mm.
fn draw_color_scale<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    text: bool,
    cs: &ColorScale,
) -> Drawn<DB> {
    let steps = 64;
    for i in 0..steps {
        let t = i as f64 / (steps - 1) as f64;
        let ya = cs.y + cs.h - ((i + 1) * cs.h) / steps;
        let yb = cs.y + cs.h - (i * cs.h) / steps;
        root.draw(&Rectangle::new(
            [(cs.x, ya), (cs.x + 16, yb)],
            rgb(colormap(t)).filled(),
        ))?;
    }
    root.draw(&Rectangle::new(
        [(cs.x, cs.y), (cs.x + 16, cs.y + cs.h)],
        BLACK.stroke_width(1),
    ))?;
    for k in 0..=4 {
        let t = k as f64 / 4.0;
        let ty = cs.y + cs.h - (t * cs.h as f64).round() as i32;
        root.draw(&PathElement::new(
            vec![(cs.x + 16, ty), (cs.x + 21, ty)],
            BLACK.stroke_width(1),
        ))?;
        label(
            root,
            text,
            &format!("{:.4}", t * cs.max),
            (cs.x + 23, ty - 6),
            11,
        )?;
    }
    label(root, text, "mm", (cs.x, cs.y - 20), 12)
}

/// The four boundary curves of the surface and a few iso-lines.
fn surface_outline(s: &toolpath_kernel::geometry::NurbsSurface) -> Vec<Vec<[f64; 3]>> {
    let ((u0, u1), (v0, v1)) = s.domain();
    let n = 48;
    let mut curves = Vec::new();
    for k in 0..=4 {
        let t = k as f64 / 4.0;
        let u = u0 + (u1 - u0) * t;
        let v = v0 + (v1 - v0) * t;
        let cu: Vec<[f64; 3]> = (0..=n)
            .map(|i| {
                let p = s.point(u, v0 + (v1 - v0) * i as f64 / n as f64);
                [p.x, p.y, p.z]
            })
            .collect();
        let cv: Vec<[f64; 3]> = (0..=n)
            .map(|i| {
                let p = s.point(u0 + (u1 - u0) * i as f64 / n as f64, v);
                [p.x, p.y, p.z]
            })
            .collect();
        curves.push(cu);
        curves.push(cv);
    }
    curves
}

/// Short arrows along the passes, about 150 in all, pointing along the feed.
fn feed_arrows(
    r: &toolpath_formats::PlanResult,
    panel: &Panel,
    extent: &[[f64; 3]],
    d: &mut PanelDrawing,
) {
    let total = r.point_count();
    if total == 0 {
        return;
    }
    let step = total.div_ceil(150).max(1);
    let diag = world_diagonal(extent);
    let len = 0.035 * diag;
    let mut count = 0usize;
    for pass in &r.passes {
        for (i, p) in pass.points.iter().enumerate() {
            count += 1;
            if !count.is_multiple_of(step) {
                continue;
            }
            let dir = match p.feed {
                Some(f) => f,
                None => {
                    let (a, b) = match (pass.points.get(i), pass.points.get(i + 1)) {
                        (Some(a), Some(b)) => (a.cc, b.cc),
                        _ => match (
                            i.checked_sub(1).and_then(|j| pass.points.get(j)),
                            pass.points.get(i),
                        ) {
                            (Some(a), Some(b)) => (a.cc, b.cc),
                            _ => continue,
                        },
                    };
                    [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
                }
            };
            let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
            if !(n > 0.0 && n.is_finite()) {
                continue;
            }
            let tip = [
                p.cc[0] + dir[0] / n * len,
                p.cc[1] + dir[1] / n * len,
                p.cc[2] + dir[2] / n * len,
            ];
            let (a, b) = (panel.px(p.cc), panel.px(tip));
            let (dx, dy) = ((b.0 - a.0) as f64, (b.1 - a.1) as f64);
            let l = dx.hypot(dy);
            if l < 3.0 {
                continue;
            }
            let (ux, uy) = (dx / l, dy / l);
            let head = 6.0;
            let (c, s) = (0.9f64, 0.45f64);
            let h1 = (
                (b.0 as f64 - head * (c * ux - s * uy)).round() as i32,
                (b.1 as f64 - head * (s * ux + c * uy)).round() as i32,
            );
            let h2 = (
                (b.0 as f64 - head * (c * ux + s * uy)).round() as i32,
                (b.1 as f64 - head * (-s * ux + c * uy)).round() as i32,
            );
            d.lines.push(Line {
                points: vec![a, b],
                color: FEED,
                width: 1,
            });
            d.lines.push(Line {
                points: vec![h1, b, h2],
                color: FEED,
                width: 1,
            });
        }
    }
}

fn world_diagonal(extent: &[[f64; 3]]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in extent {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let d = ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
    if d.is_finite() && d > 0.0 {
        d
    } else {
        1.0
    }
}

/// A bar of round length in the bottom-left corner (top views only).
fn scale_bar(panel: &Panel, extent: &[[f64; 3]]) -> Option<((i32, i32), i32, String)> {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for p in extent {
        lo = lo.min(p[0]);
        hi = hi.max(p[0]);
    }
    let l = nice_length(hi - lo);
    let px = (l * panel.scale).round() as i32;
    if !(px > 4 && px < panel.w) {
        return None;
    }
    Some((
        (panel.x0 + 20, panel.y0 + panel.h - 16),
        px,
        format_length(l),
    ))
}

/// Grid cells of the residual map as projected quads (at most ~150 x 150),
/// painted far-to-near.
fn residual_quads(map: &super::ResidualOverlay, panel: &Panel, max: f64, d: &mut PanelDrawing) {
    let step = map.nu.max(map.nv).div_ceil(150).max(1);
    let at = |i: usize, j: usize| i * map.nv + j;
    let mut i = 0;
    while i + 1 < map.nu {
        let i1 = (i + step).min(map.nu - 1);
        let mut j = 0;
        while j + 1 < map.nv {
            let j1 = (j + step).min(map.nv - 1);
            let idx = [at(i, j), at(i1, j), at(i1, j1), at(i, j1)];
            let vals: Vec<Option<f64>> = idx
                .iter()
                .map(|&k| map.residual.get(k).copied().flatten())
                .collect();
            let known: Vec<f64> = vals
                .iter()
                .flatten()
                .copied()
                .filter(|x| x.is_finite())
                .collect();
            let color = if known.len() < vals.len() {
                UNCUT
            } else if known.iter().any(|&x| x < -map.gouge_tolerance) {
                GOUGE
            } else {
                let mean = known.iter().sum::<f64>() / known.len() as f64;
                colormap(if max > 0.0 { mean / max } else { 0.0 })
            };
            let corners: Vec<[f64; 3]> = idx
                .iter()
                .filter_map(|&k| map.xyz.get(k).copied())
                .collect();
            if corners.len() == 4 {
                let depth = corners.iter().map(|p| panel.depth(*p)).sum::<f64>() / 4.0;
                d.quads.push(Quad {
                    corners: corners.iter().map(|p| panel.px(*p)).collect(),
                    color,
                    depth,
                });
            }
            j = j1;
        }
        i = i1;
    }
    d.quads.sort_by(|a, b| a.depth.total_cmp(&b.depth));
}

/// Pixels within the tool radius of its centre paths, as row runs.
fn swept_runs(
    tool: &toolpath_formats::result::PocketTool,
    panel: &Panel,
    color: (u8, u8, u8),
) -> Runs {
    let (w, h) = (panel.w.max(1) as usize, panel.h.max(1) as usize);
    let mut mask = vec![false; w * h];
    let r = 0.5 * tool.diameter * panel.scale;
    let r2 = r * r;
    for pass in &tool.passes {
        let pts: Vec<(f64, f64)> = pass
            .iter()
            .map(|q| {
                let (x, y) = panel.px([q[0], q[1], 0.0]);
                ((x - panel.x0) as f64, (y - panel.y0) as f64)
            })
            .collect();
        let segs: Vec<((f64, f64), (f64, f64))> = if pts.len() == 1 {
            vec![(pts[0], pts[0])]
        } else {
            pts.windows(2).map(|s| (s[0], s[1])).collect()
        };
        for (a, b) in segs {
            let xa = (a.0.min(b.0) - r).floor().max(0.0) as usize;
            let xb = ((a.0.max(b.0) + r).ceil().max(0.0) as usize).min(w - 1);
            let ya = (a.1.min(b.1) - r).floor().max(0.0) as usize;
            let yb = ((a.1.max(b.1) + r).ceil().max(0.0) as usize).min(h - 1);
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let ll = dx * dx + dy * dy;
            for y in ya..=yb {
                for x in xa..=xb {
                    let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                    let t = if ll > 0.0 {
                        (((px - a.0) * dx + (py - a.1) * dy) / ll).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let (qx, qy) = (a.0 + t * dx - px, a.1 + t * dy - py);
                    if qx * qx + qy * qy <= r2 {
                        mask[y * w + x] = true;
                    }
                }
            }
        }
    }
    let mut runs = Vec::new();
    for y in 0..h {
        let mut x = 0;
        while x < w {
            if mask[y * w + x] {
                let s = x;
                while x < w && mask[y * w + x] {
                    x += 1;
                }
                runs.push((
                    panel.y0 + y as i32,
                    panel.x0 + s as i32,
                    panel.x0 + x as i32,
                ));
            } else {
                x += 1;
            }
        }
    }
    Runs { color, runs }
}
