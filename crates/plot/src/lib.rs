//! Pictures of results (PNG or SVG, chosen by the file extension).
//!
//! Freeform results get a top view and an oblique view of the contact-point
//! passes coloured by region, with degenerate points, separatrices and the
//! feed-direction field, plus (when a residual-height map is given) a third
//! panel with the map as a colour field and its scale. Pocket results get the
//! pocket outline with each tool's swept area in its own colour, and the
//! tool-centre paths with the medial axis.
//!
//! Drawing uses plotters' primitives only (no chart layer): the views are
//! plain projections we compute here, which keeps the layout under our control
//! and the output byte-identical for equal inputs. Text needs a TrueType font
//! loaded at run time (see [`font_available`]); without one the picture is
//! drawn without labels.

mod render;

use std::path::Path;
use std::sync::OnceLock;
use toolpath_formats::PlanResult;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::{NurbsSurface, Pocket};

/// Residual height sampled on a (u, v) grid: `xyz[i * nv + j]` is the surface
/// point of sample (i along u, j along v) and `residual` its residual height in
/// mm (`None` where the simulator found no cut: uncovered).
#[derive(Clone, Debug, PartialEq)]
pub struct ResidualOverlay {
    pub nu: usize,
    pub nv: usize,
    pub xyz: Vec<[f64; 3]>,
    pub residual: Vec<Option<f64>>,
    /// Cuts deeper than this below the surface (mm) are painted as gouges;
    /// shallower ones are within the job's tolerance and get the colour map.
    pub gouge_tolerance: f64,
}

impl ResidualOverlay {
    /// Checks that the grid sizes match the sample vectors.
    pub fn validate(&self) -> Result<()> {
        let n = self.nu.saturating_mul(self.nv);
        if self.nu < 2 || self.nv < 2 {
            return Err(Error::invalid(
                "residual.nu",
                "the residual map needs at least 2 x 2 samples",
            ));
        }
        if self.xyz.len() != n {
            return Err(Error::invalid(
                "residual.xyz",
                format!(
                    "{} samples for a {} x {} grid",
                    self.xyz.len(),
                    self.nu,
                    self.nv
                ),
            ));
        }
        if self.residual.len() != n {
            return Err(Error::invalid(
                "residual.residual",
                format!(
                    "{} values for a {} x {} grid",
                    self.residual.len(),
                    self.nu,
                    self.nv
                ),
            ));
        }
        if !(self.gouge_tolerance.is_finite() && self.gouge_tolerance >= 0.0) {
            return Err(Error::invalid(
                "residual.gouge_tolerance",
                format!(
                    "must be a finite depth >= 0 mm, got {}",
                    self.gouge_tolerance
                ),
            ));
        }
        if let Some(i) = self
            .xyz
            .iter()
            .position(|p| p.iter().any(|c| !c.is_finite()))
        {
            return Err(Error::invalid(
                format!("residual.xyz[{i}]"),
                "not a finite point",
            ));
        }
        Ok(())
    }
}

/// What a picture shows.
pub struct PlotInput<'a> {
    pub result: &'a PlanResult,
    pub surface: Option<&'a NurbsSurface>,
    pub pocket: Option<&'a Pocket>,
    pub residual: Option<&'a ResidualOverlay>,
}

/// Output format of a picture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Svg,
}

impl ImageFormat {
    /// The format named by the file extension (`.png` or `.svg`, any case).
    pub fn from_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("svg") => Ok(ImageFormat::Svg),
            _ => Err(Error::invalid(
                "output",
                format!("{}: the picture must end in .png or .svg", path.display()),
            )),
        }
    }
}

/// Font files tried, in order, after `$TOOLPATH_FONT`.
const FONT_CANDIDATES: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation/LiberationSans-Regular.ttf",
];

/// Loads a sans-serif TrueType font once per process (from `$TOOLPATH_FONT`
/// or a system path; Debian: `fonts-dejavu-core`). Returns whether text can
/// be drawn.
pub fn font_available() -> bool {
    static LOADED: OnceLock<bool> = OnceLock::new();
    *LOADED.get_or_init(|| {
        let mut paths: Vec<String> = std::env::var("TOOLPATH_FONT").into_iter().collect();
        paths.extend(FONT_CANDIDATES.iter().map(|s| s.to_string()));
        for path in paths {
            let Ok(bytes) = std::fs::read(&path) else {
                continue;
            };
            // plotters keeps fonts for the life of the process.
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            if plotters::style::register_font(
                "sans-serif",
                plotters::style::FontStyle::Normal,
                bytes,
            )
            .is_ok()
            {
                return true;
            }
        }
        false
    })
}

/// Picture size in pixels for `input` (wider when a residual map is shown).
pub fn picture_size(input: &PlotInput) -> (u32, u32) {
    let panels = if input.residual.is_some() && input.result.tools.is_none() {
        3
    } else {
        2
    };
    (
        render::PANEL_W * panels,
        render::PANEL_H + render::TITLE_H + render::LEGEND_H,
    )
}

/// Draws `input` into `path` (PNG or SVG by extension).
pub fn draw(input: &PlotInput, path: &Path) -> Result<()> {
    let format = ImageFormat::from_path(path)?;
    if let Some(r) = input.residual {
        r.validate()?;
    }
    validate_result(input.result)?;
    if !font_available() {
        eprintln!(
            "warning: no TrueType font found (tried $TOOLPATH_FONT and {}); drawing without labels",
            FONT_CANDIDATES.join(", ")
        );
    }
    let size = picture_size(input);
    let scene = render::Scene::build(input, size);
    let io = |e: String| Error::io(path.display().to_string(), e);
    match format {
        ImageFormat::Png => {
            use plotters::prelude::*;
            let root = BitMapBackend::new(path, size).into_drawing_area();
            scene.render(&root).map_err(|e| io(e.to_string()))?;
            root.present().map_err(|e| io(e.to_string()))?;
        }
        ImageFormat::Svg => {
            use plotters::prelude::*;
            let root = SVGBackend::new(path, size).into_drawing_area();
            scene.render(&root).map_err(|e| io(e.to_string()))?;
            root.present().map_err(|e| io(e.to_string()))?;
        }
    }
    Ok(())
}

/// Non-finite coordinates would make the projection meaningless: name them.
fn validate_result(result: &PlanResult) -> Result<()> {
    for (i, pass) in result.passes.iter().enumerate() {
        for (j, p) in pass.points.iter().enumerate() {
            if p.cc.iter().chain(p.cl.iter()).any(|c| !c.is_finite()) {
                return Err(Error::invalid(
                    format!("passes[{i}].points[{j}]"),
                    "not a finite point",
                ));
            }
        }
    }
    if let Some(tools) = &result.tools {
        for (t, tool) in tools.iter().enumerate() {
            if !(tool.diameter.is_finite() && tool.diameter > 0.0) {
                return Err(Error::invalid(
                    format!("tools[{t}].diameter"),
                    "must be a positive number",
                ));
            }
            for (i, pass) in tool.passes.iter().enumerate() {
                if let Some(j) = pass.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
                    return Err(Error::invalid(
                        format!("tools[{t}].passes[{i}][{j}]"),
                        "not a finite point",
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Colour of region `id` (the same in every picture).
pub fn region_color(id: usize) -> (u8, u8, u8) {
    render::REGION_COLORS[id % render::REGION_COLORS.len()]
}

/// Colour of the pocket tool with index `index` (in `result.tools` order).
pub fn tool_color(index: usize) -> (u8, u8, u8) {
    render::TOOL_COLORS[index % render::TOOL_COLORS.len()]
}

/// Colour of residual-map cells cut deeper than the gouge tolerance.
pub fn gouge_color() -> (u8, u8, u8) {
    render::GOUGE
}

/// Colour-map colour for `t` in [0, 1] (viridis-like).
pub fn colormap(t: f64) -> (u8, u8, u8) {
    render::colormap(t)
}

/// The residual-height map of a milling result, from the scallop simulator
/// (at the job's simulation resolution), judged against the job's gouge
/// tolerance. `None` for pockets and belt grinding.
pub fn residual_for(
    job: &toolpath_formats::Job,
    result: &PlanResult,
) -> Result<Option<ResidualOverlay>> {
    if !toolpath_pipeline::is_milling(job.strategy) || result.passes.is_empty() {
        return Ok(None);
    }
    let report = toolpath_pipeline::verify_milling(job, result)?;
    let map = report.map;
    Ok(Some(ResidualOverlay {
        nu: map.nu,
        nv: map.nv,
        xyz: map.xyz,
        residual: map.residual,
        gouge_tolerance: job.gouge_tolerance(),
    }))
}
