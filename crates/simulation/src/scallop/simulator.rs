//! The swept tool of one result, ready to be queried at surface points,
//! and its run over the surface grid.

use super::motion::{motions_of, Motion};
use super::motion_index::MotionIndex;
use super::report::{ResidualMap, ScallopReport};
use super::residual::Method;
use super::resolution::{extents, grid_resolution};
use super::settings::ScallopSettings;
use nalgebra::Vector3;
use toolpath_formats::PlanResult;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::NurbsSurface;
use toolpath_kernel::progress::{NoProgress, Progress};
use toolpath_kernel::tools::{CutterShape, Tool};

/// The swept tool of one result, ready to be queried at surface points.
pub struct Simulator<'a> {
    pub(super) surface: &'a NurbsSurface,
    pub(super) cutter: CutterShape,
    pub(super) motions: Vec<Motion>,
    /// The motions' swept boxes in a uniform grid.
    pub(super) index: MotionIndex,
    /// Residuals above this are "not reached" (the tool radius).
    pub(super) cap: f64,
    /// Gouges are searched to this depth below the surface (the tool diameter);
    /// deeper ones are reported as this depth.
    pub(super) depth: f64,
    /// Largest spacing of the sub-positions scanned along a motion, mm.
    pub(super) scan_step: f64,
}

/// A surface sample: point, unit tool-side normal, area weight (`None` where the normal is undefined).
pub(super) type Frame = Option<(Vector3<f64>, Vector3<f64>, f64)>;

impl<'a> Simulator<'a> {
    /// Checks the result's tool positions and builds the spatial index.
    pub fn new(surface: &'a NurbsSurface, tool: &Tool, result: &PlanResult) -> Result<Self> {
        let cutter = CutterShape::from_tool(tool)?;
        let big_r = cutter.radius;
        let motions = motions_of(result, &cutter)?;
        let index = MotionIndex::new(&motions, big_r, cutter.length);
        Ok(Self {
            surface,
            cutter,
            motions,
            index,
            cap: big_r,
            depth: 2.0 * big_r,
            scan_step: big_r / 8.0,
        })
    }

    /// Residual at surface parameters (u, v) (clamped to the domain).
    pub fn residual_at(&self, u: f64, v: f64) -> Option<f64> {
        let (p, n, _) = self.sample(u, v)?;
        self.residual(&p, &n, &mut Vec::new())
    }

    /// Point, unit tool-side normal and area element at (u, v).
    pub(super) fn sample(&self, u: f64, v: f64) -> Option<(Vector3<f64>, Vector3<f64>, f64)> {
        let d = self.surface.derivs(u, v);
        let cross = d.su.cross(&d.sv);
        let area = cross.norm();
        let n = cross.try_normalize(1e-300)?;
        Some((d.p.coords, n, area))
    }

    /// Samples the surface and builds the report.
    pub fn run(&self, settings: &ScallopSettings) -> Result<ScallopReport> {
        self.run_with(settings, Method::Fast, &NoProgress)
    }

    /// The report; `progress` is checked per chunk of samples, and a stop
    /// found in any chunk ends the run with it.
    pub(super) fn run_with(
        &self,
        settings: &ScallopSettings,
        method: Method,
        progress: &dyn Progress,
    ) -> Result<ScallopReport> {
        let ((u0, u1), (v0, v1)) = self.surface.domain();
        let (len_u, len_v) = extents(self.surface);
        let res = grid_resolution(settings, &self.cutter, len_u, len_v)?;
        let nu = ((len_u / res).ceil() as usize).max(2);
        let nv = ((len_v / res).ceil() as usize).max(2);
        let du = (u1 - u0) / nu as f64;
        let dv = (v1 - v0) / nv as f64;

        let stop = std::sync::OnceLock::new();
        let (uv, xyz, mut frames) =
            self.sample_grid((u0, v0), (du, dv), (nu, nv), (progress, &stop));
        if let Some(e) = stop.into_inner() {
            return Err(e);
        }
        // Off a trimmed face nothing is machined or counted: those samples
        // get no frame, so no residual and no area.
        let off_face: Vec<bool> = match self.surface.trim() {
            Some(_) => uv
                .iter()
                .map(|p| !self.surface.in_face(p[0], p[1]))
                .collect(),
            None => Vec::new(),
        };
        for (f, off) in frames.iter_mut().zip(&off_face) {
            if *off {
                *f = None;
            }
        }
        let stop = std::sync::OnceLock::new();
        let residual = self.residuals(&frames, (nu, nv), method, (progress, &stop));
        if let Some(e) = stop.into_inner() {
            return Err(e);
        }

        let mut uncovered = 0.0;
        let mut machined = 0.0;
        for (f, r) in frames.iter().zip(&residual) {
            let Some((_, _, area)) = f else { continue };
            match r {
                Some(_) => machined += area,
                None => uncovered += area,
            }
        }
        let map = ResidualMap {
            nu,
            nv,
            uv,
            xyz,
            residual,
            off_face,
        };
        progress.check()?;
        let starts = settings.peak_starts;
        let (max_res, peaks) = self.refine(&map, 1.0, (du, dv), starts, method);
        progress.check()?;
        let (min_res, _) = self.refine(&map, -1.0, (du, dv), starts, method);
        Ok(ScallopReport {
            max_scallop_mm: max_res.map_or(0.0, |r| r.max(0.0)),
            max_gouge_mm: min_res.map_or(0.0, |r| (-r).max(0.0)),
            uncovered_area_mm2: uncovered,
            machined_area_mm2: machined,
            resolution_mm: res,
            map,
            peaks,
        })
    }

    /// The grid's cell centres: (u, v), points, and frames, in parallel over
    /// rows (each sample is independent, so the result does not depend on threads).
    /// A stop found by `check` is put in its cell and leaves the rest unsampled.
    #[allow(clippy::type_complexity)]
    pub(super) fn sample_grid(
        &self,
        (u0, v0): (f64, f64),
        (du, dv): (f64, f64),
        (nu, nv): (usize, usize),
        (progress, stop): (&dyn Progress, &std::sync::OnceLock<Error>),
    ) -> (Vec<[f64; 2]>, Vec<[f64; 3]>, Vec<Frame>) {
        let rows: Vec<usize> = (0..nu).collect();
        let parts = toolpath_kernel::parallel::map_chunks(&rows, 4, |rows| {
            if stop.get().is_some() {
                return Vec::new();
            }
            if let Err(e) = progress.check() {
                let _ = stop.set(e);
                return Vec::new();
            }
            let mut out = Vec::with_capacity(rows.len() * nv);
            for &i in rows {
                for j in 0..nv {
                    let (u, v) = (u0 + (i as f64 + 0.5) * du, v0 + (j as f64 + 0.5) * dv);
                    let (p, frame) = match self.sample(u, v) {
                        Some((p, n, area)) => (p, Some((p, n, area * du * dv))),
                        None => (self.surface.point(u, v).coords, None),
                    };
                    out.push(([u, v], [p.x, p.y, p.z], frame));
                }
            }
            out
        });
        let total = nu * nv;
        let mut uv = Vec::with_capacity(total);
        let mut xyz = Vec::with_capacity(total);
        let mut frames = Vec::with_capacity(total);
        for (a, b, c) in parts.into_iter().flatten() {
            uv.push(a);
            xyz.push(b);
            frames.push(c);
        }
        (uv, xyz, frames)
    }
}
