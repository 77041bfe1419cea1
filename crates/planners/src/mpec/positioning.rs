//! Strategy `mpec`: mid-point error control tool positioning for a torus
//! cutter with wide strips (docs/methods.md, "MPEC: error curve and lead",
//! "The part under the tool" and "Pass spacing").
//!
//! Drive curves are iso-parametric curves along `feed_direction`. At every
//! drive point the tool sits with the middle of its "W" error curve at +delta
//! and the lead angle is the smallest whose dips stay at or above -delta, found
//! by regula falsi (Illinois) on a bracket ([`super::error_curve`]). A pass's
//! usable width is its narrowest strip; the next drive curve is placed so that
//! the facing half-widths of adjacent passes meet, found iteratively on the
//! surface.
//!
//! The part is seen by the error-curve core as a height field over the
//! tangent plane at the drive point. That height field comes from the real
//! NURBS surface: a quartic least-squares fit of 49 exact surface points
//! around the drive point, used only when it reproduces them within
//! delta/50; otherwise every height is found by exact point inversion
//! (Newton on (u, v)), which is slower but general.

use super::error_curve::{self as ec, LeadSearch, LocalHeight, Status};
use crate::Progress;
use nalgebra::{Point3, SMatrix, SVector, Vector2, Vector3};
use toolpath_formats::{FeedDirection, Job, Pass, PathPoint, PlanResult};
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::inversion::{extended_derivs, extended_point, invert_in_frame};
use toolpath_kernel::geometry::numeric::Bracket;
use toolpath_kernel::geometry::{LocalGeometry, NurbsSurface};
use toolpath_kernel::tools::CutterShape;
use toolpath_kernel::tools::Tool;

/// Drive-point spacing along a pass, mm (the paper: 400 points on ~600 mm).
pub(crate) const POINT_SPACING: f64 = 1.5;

/// Drive points per parallel chunk of a pass (each chunk's first point is
/// solved without a neighbour's warm start).
const PASS_CHUNK: usize = 32;

/// The tool's second reference frame at a drive point.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub p: Point3<f64>,
    pub e1: Vector3<f64>,
    pub e2: Vector3<f64>,
    pub e3: Vector3<f64>,
}

impl Frame {
    pub(crate) fn to_world(&self, local: [f64; 3]) -> Point3<f64> {
        self.p + self.e1 * local[0] + self.e2 * local[1] + self.e3 * local[2]
    }
    pub(crate) fn dir_to_world(&self, local: [f64; 3]) -> Vector3<f64> {
        self.e1 * local[0] + self.e2 * local[1] + self.e3 * local[2]
    }
}

/// Exact height of the part over the tangent plane: the shared point
/// inversion in the drive point's frame, on the (extended) surface, seeded
/// at the drive point or, where the footprint's parameters were marched
/// ([`march_footprint`]), at the nearest marched grid point (next to a pole
/// the parameters are far from linear in the distance and one seed strays).
pub(crate) struct ExactHeight<'a> {
    pub surface: &'a NurbsSurface,
    pub frame: Frame,
    pub uv: Vector2<f64>,
    pub seeds: Option<SeedGrid>,
}

impl LocalHeight for ExactHeight<'_> {
    fn height(&self, x: f64, y: f64) -> (f64, f64, f64) {
        let f = &self.frame;
        let seed = self.seeds.as_ref().map_or(self.uv, |g| g.nearest(x, y));
        let q = invert_in_frame(self.surface, &f.p, &f.e1, &f.e2, [x, y], seed);
        (q.height, q.slope[0], q.slope[1])
    }
}

/// Surface parameters at the [`fit_box`]'s 7 x 7 grid points.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SeedGrid {
    bx: (f64, f64),
    by: (f64, f64),
    uv: [Vector2<f64>; FIT_GRID * FIT_GRID],
}

impl SeedGrid {
    fn nearest(&self, x: f64, y: f64) -> Vector2<f64> {
        let index = |t: f64, (lo, hi): (f64, f64)| {
            let k = ((t - lo) / (hi - lo) * (FIT_GRID - 1) as f64).round();
            k.clamp(0.0, (FIT_GRID - 1) as f64) as usize
        };
        self.uv[index(x, self.bx) * FIT_GRID + index(y, self.by)]
    }
}

/// The part under the tool at one drive point, and its error against the
/// real surface (mm, 0 for exact heights).
enum PartModel<'a> {
    Fitted(FittedHeight, f64),
    Exact(Box<ExactHeight<'a>>),
}

impl PartModel<'_> {
    fn height(&self) -> (&dyn LocalHeight, f64) {
        match self {
            PartModel::Fitted(fit, e) => (fit, *e),
            PartModel::Exact(exact) => (exact.as_ref(), 0.0),
        }
    }
}

const FIT_TERMS: usize = 15;
const FIT_GRID: usize = 7;

/// Quartic height field z = sum c_ij X^i Y^j (i + j <= 4, X = x / L, Y = y / L)
/// fitted to exact surface points.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FittedHeight {
    c: [f64; FIT_TERMS],
    inv_scale: f64,
}

#[inline]
fn monomials(x: f64, y: f64) -> [f64; FIT_TERMS] {
    let (x2, y2) = (x * x, y * y);
    [
        1.0,
        x,
        y,
        x2,
        x * y,
        y2,
        x2 * x,
        x2 * y,
        x * y2,
        y2 * y,
        x2 * x2,
        x2 * x * y,
        x2 * y2,
        x * y2 * y,
        y2 * y2,
    ]
}

impl LocalHeight for FittedHeight {
    #[inline]
    fn height(&self, x: f64, y: f64) -> (f64, f64, f64) {
        let (x, y) = (x * self.inv_scale, y * self.inv_scale);
        let c = &self.c;
        let (x2, y2) = (x * x, y * y);
        let h = c[0]
            + c[1] * x
            + c[2] * y
            + c[3] * x2
            + c[4] * x * y
            + c[5] * y2
            + c[6] * x2 * x
            + c[7] * x2 * y
            + c[8] * x * y2
            + c[9] * y2 * y
            + c[10] * x2 * x2
            + c[11] * x2 * x * y
            + c[12] * x2 * y2
            + c[13] * x * y2 * y
            + c[14] * y2 * y2;
        let dy = c[2]
            + c[4] * x
            + 2.0 * c[5] * y
            + c[7] * x2
            + 2.0 * c[8] * x * y
            + 3.0 * c[9] * y2
            + c[11] * x2 * x
            + 2.0 * c[12] * x2 * y
            + 3.0 * c[13] * x * y2
            + 4.0 * c[14] * y2 * y;
        let dx = c[1]
            + 2.0 * c[3] * x
            + c[4] * y
            + 3.0 * c[6] * x2
            + 2.0 * c[7] * x * y
            + c[8] * y2
            + 4.0 * c[10] * x2 * x
            + 3.0 * c[11] * x2 * y
            + 2.0 * c[12] * x * y2
            + c[13] * y2 * y;
        (h, dx * self.inv_scale, dy * self.inv_scale)
    }
}

/// The footprint behind the drive point that the fits cover: x from
/// -(2 R0 + r) to r, y within +-(R0 + r).
fn fit_box(tool: CutterShape) -> ((f64, f64), (f64, f64)) {
    let reach = tool.tube_radius() + tool.corner_radius;
    (
        (
            -(2.0 * tool.tube_radius() + tool.corner_radius),
            tool.corner_radius,
        ),
        (-reach, reach),
    )
}

/// Least-squares quartic through samples (x, y, z) given in units of
/// `scale`; returns it with its largest residual at the samples (mm).
fn fit_samples(
    samples: &[(f64, f64, f64); FIT_GRID * FIT_GRID],
    scale: f64,
) -> Option<(FittedHeight, f64)> {
    let mut ata = SMatrix::<f64, FIT_TERMS, FIT_TERMS>::zeros();
    let mut atb = SVector::<f64, FIT_TERMS>::zeros();
    for &(lx, ly, lz) in samples {
        let m = SVector::<f64, FIT_TERMS>::from(monomials(lx, ly));
        ata += m * m.transpose();
        atb += m * lz;
    }
    let c = ata.cholesky()?.solve(&atb);
    let fit = FittedHeight {
        c: c.into(),
        inv_scale: 1.0 / scale,
    };
    let residual = samples
        .iter()
        .map(|&(x, y, z)| (fit.height(x * scale, y * scale).0 - z).abs())
        .fold(0.0, f64::max);
    residual.is_finite().then_some((fit, residual))
}

/// Fits the quartic to a 7 x 7 grid of exact surface points covering the
/// tool's footprint behind the drive point, reached by a linear step in
/// (u, v). Returns the fit and its largest residual at the fitted points (mm).
pub(crate) fn fit_height(
    surface: &NurbsSurface,
    g: &LocalGeometry,
    frame: &Frame,
    tool: CutterShape,
) -> Option<(FittedHeight, f64)> {
    let ((x0, x1), (y0, y1)) = fit_box(tool);
    let d = &g.forms.derivs;
    let j = nalgebra::Matrix2::new(
        d.su.dot(&frame.e1),
        d.sv.dot(&frame.e1),
        d.su.dot(&frame.e2),
        d.sv.dot(&frame.e2),
    );
    let ji = j.try_inverse()?;
    let scale = tool.tube_radius() + tool.corner_radius;
    let mut samples = [(0.0, 0.0, 0.0); FIT_GRID * FIT_GRID];
    for a in 0..FIT_GRID {
        for b in 0..FIT_GRID {
            let x = x0 + (x1 - x0) * a as f64 / (FIT_GRID - 1) as f64;
            let y = y0 + (y1 - y0) * b as f64 / (FIT_GRID - 1) as f64;
            let uv = g.forms.uv + ji * Vector2::new(x, y);
            let p = extended_point(surface, uv.x, uv.y) - frame.p;
            samples[a * FIT_GRID + b] = (
                p.dot(&frame.e1) / scale,
                p.dot(&frame.e2) / scale,
                p.dot(&frame.e3),
            );
        }
    }
    fit_samples(&samples, scale)
}

/// The quartic fitted to the heights over the 7 x 7 grid of the footprint
/// itself, found by [`march_footprint`]: where the parameters are far from
/// linear in the distance (next to a pole or a collapsed edge) the linear
/// step of [`fit_height`] strays, while the height field stays smooth.
/// Returns the fit, its largest residual (mm) and the marched parameters.
pub(crate) fn fit_height_inverted(
    surface: &NurbsSurface,
    g: &LocalGeometry,
    frame: &Frame,
    tool: CutterShape,
) -> (Option<(FittedHeight, f64)>, SeedGrid) {
    let (samples, seeds) = march_footprint(surface, g, frame, tool);
    let scale = tool.tube_radius() + tool.corner_radius;
    (fit_samples(&samples, scale), seeds)
}

/// Heights over the [`fit_box`]'s 7 x 7 grid (x and y in units of R0 + r)
/// and their surface parameters, each found by the frame inversion from its
/// neighbour's parameters: rows outwards from the drive point's own y, each
/// row's middle seeded by the last row's.
pub(crate) fn march_footprint(
    surface: &NurbsSurface,
    g: &LocalGeometry,
    frame: &Frame,
    tool: CutterShape,
) -> ([(f64, f64, f64); FIT_GRID * FIT_GRID], SeedGrid) {
    let ((x0, x1), (y0, y1)) = fit_box(tool);
    let scale = tool.tube_radius() + tool.corner_radius;
    let mut samples = [(0.0, 0.0, 0.0); FIT_GRID * FIT_GRID];
    let mut seeds = SeedGrid {
        bx: (x0, x1),
        by: (y0, y1),
        uv: [g.forms.uv; FIT_GRID * FIT_GRID],
    };
    let mut row_seed = g.forms.uv;
    let mid = (FIT_GRID - 1) / 2;
    for a in (0..FIT_GRID).rev() {
        let x = x0 + (x1 - x0) * a as f64 / (FIT_GRID - 1) as f64;
        let centre = invert_in_frame(surface, &frame.p, &frame.e1, &frame.e2, [x, 0.0], row_seed);
        row_seed = centre.uv;
        for half in [
            (mid..FIT_GRID).collect::<Vec<_>>(),
            (0..=mid).rev().collect(),
        ] {
            let mut seed = centre.uv;
            for b in half {
                let y = y0 + (y1 - y0) * b as f64 / (FIT_GRID - 1) as f64;
                let q = invert_in_frame(surface, &frame.p, &frame.e1, &frame.e2, [x, y], seed);
                seed = q.uv;
                samples[a * FIT_GRID + b] = (x / scale, y / scale, q.height);
                seeds.uv[a * FIT_GRID + b] = q.uv;
            }
        }
    }
    (samples, seeds)
}

/// One positioned drive point.
#[derive(Clone, Debug)]
pub struct DrivePoint {
    pub uv: [f64; 2],
    pub frame: Frame,
    pub solution: ec::Solution,
    /// Counts for the pass's width: inside the surface's parameter domain
    /// and within the tool's reach of the face (false on the run-out past
    /// the edge and off a trimmed face).
    pub inside: bool,
}

impl DrivePoint {
    /// Half-widths towards increasing / decreasing cross parameter.
    fn half_widths(&self, cross_sign: f64) -> (f64, f64) {
        if cross_sign > 0.0 {
            (self.solution.y_right, -self.solution.y_left)
        } else {
            (-self.solution.y_left, self.solution.y_right)
        }
    }

    pub fn to_path_point(&self, tool: CutterShape) -> PathPoint {
        let (tip, axis) = ec::tip_and_axis(tool, self.solution.pos);
        let f = &self.frame;
        let cl = f.to_world(tip);
        let axis = f.dir_to_world(axis).normalize();
        PathPoint {
            cc: f.p.into(),
            cl: cl.into(),
            axis: axis.into(),
            uv: self.uv,
            strip_width: Some(self.solution.strip_width()),
            feed: Some(f.e1.into()),
            lead_deg: Some(self.solution.pos.theta.to_degrees()),
            mpec: Some(
                match self.solution.status {
                    Status::Ok => "ok",
                    Status::NotApplicable => "not_applicable",
                    Status::Lifted => "lifted",
                }
                .to_string(),
            ),
            normal: Some(f.e3.into()),
            ..Default::default()
        }
    }
}

/// Everything fixed for one job.
pub struct Planner<'a> {
    pub surface: &'a NurbsSurface,
    pub tool: CutterShape,
    pub delta: f64,
    pub feed: FeedDirection,
    pub theta_min: f64,
    /// Side tilt: fixed rotation of the tool about the normal before the lead (0 by default).
    pub phi: f64,
    /// Force exact point inversion for every height (tests; slow).
    pub exact_heights: bool,
}

impl<'a> Planner<'a> {
    /// Validates the job's parameters for MPEC.
    pub fn from_job(job: &'a Job) -> Result<Self> {
        let surface = job.surface()?;
        let Tool::Torus {
            radius,
            corner_radius,
            ..
        } = *job.tool()?
        else {
            return Err(Error::invalid(
                "tool.kind",
                format!(
                    "strategy mpec needs a torus tool, got {}",
                    job.tool()?.kind()
                ),
            ));
        };
        if corner_radius >= radius {
            return Err(Error::invalid(
                "tool.corner_radius",
                format!(
                    "corner radius {corner_radius} must be smaller than the cutter radius {radius}"
                ),
            ));
        }
        let delta = job.tolerance()?;
        toolpath_kernel::validate::positive("tolerance", delta)?;
        if delta >= 0.5 * corner_radius {
            return Err(Error::invalid(
                "tolerance",
                format!("{delta} mm is not small against the corner radius {corner_radius} mm; MPEC needs delta << r"),
            ));
        }
        let phi = job.side_tilt();
        if phi.abs() > 45f64.to_radians() {
            return Err(Error::invalid(
                "side_tilt_deg",
                format!(
                    "the rotation about the normal must be within +-45 degrees, got {}",
                    phi.to_degrees()
                ),
            ));
        }
        let theta_min = job.lead_angle();
        if !(0.0..60f64.to_radians()).contains(&theta_min) {
            return Err(Error::invalid(
                "lead_angle_deg",
                format!(
                    "is the smallest lead mpec may use and must be in 0..60 degrees, got {}",
                    theta_min.to_degrees()
                ),
            ));
        }
        Ok(Self {
            surface,
            tool: CutterShape::torus(radius, corner_radius),
            delta,
            feed: job.feed_direction.unwrap_or(FeedDirection::U),
            theta_min,
            phi,
            exact_heights: false,
        })
    }

    /// (u, v) from (feed parameter s, cross parameter t).
    pub fn uv(&self, s: f64, t: f64) -> (f64, f64) {
        match self.feed {
            FeedDirection::U => (s, t),
            FeedDirection::V => (t, s),
        }
    }

    /// Feed and cross parameter ranges.
    pub fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let (du, dv) = self.surface.domain();
        match self.feed {
            FeedDirection::U => (du, dv),
            FeedDirection::V => (dv, du),
        }
    }

    /// Cross-parameter range of the face: the domain's, narrowed to the
    /// outer trim loop's extent on a trimmed face (no pass is planned
    /// wholly beside the face).
    pub(crate) fn face_cross_range(&self) -> (f64, f64) {
        let (_, (t0, t1)) = self.ranges();
        let Some(trim) = self.surface.trim() else {
            return (t0, t1);
        };
        let k = match self.feed {
            FeedDirection::U => 1,
            FeedDirection::V => 0,
        };
        let (lo, hi) = trim
            .loops()
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p[k]), b.max(p[k]))
            });
        if lo < hi {
            (lo.max(t0), hi.min(t1))
        } else {
            (t0, t1)
        }
    }

    /// +1 when e2 points towards increasing cross parameter.
    fn cross_sign(&self) -> f64 {
        match self.feed {
            FeedDirection::U => 1.0,
            FeedDirection::V => -1.0,
        }
    }

    pub fn point(&self, s: f64, t: f64) -> Point3<f64> {
        let (u, v) = self.uv(s, t);
        extended_point(self.surface, u, v)
    }

    /// Frame and geometry at (s, t) on the extended surface.
    fn local(&self, s: f64, t: f64) -> Result<(LocalGeometry, Frame)> {
        let (u, v) = self.uv(s, t);
        let d = extended_derivs(self.surface, u, v);
        let g = LocalGeometry::from_derivs(Vector2::new(u, v), d).ok_or_else(|| {
            Error::planning(format!(
                "the surface is degenerate (no normal) at (u, v) = ({u:.6}, {v:.6})"
            ))
        })?;
        let tangent = match self.feed {
            FeedDirection::U => d.su,
            FeedDirection::V => d.sv,
        };
        let e3 = g.forms.n;
        let e1 = (tangent - e3 * tangent.dot(&e3)).normalize();
        let e2 = e3.cross(&e1);
        Ok((g, Frame { p: d.p, e1, e2, e3 }))
    }

    /// The part under the tool at a drive point (docs/methods.md, "The part
    /// under the tool"): within delta / 50 the linear-step fit as it is;
    /// failing that, the better of the two fits within delta / 5 (its
    /// residual is taken off both sides of the band), far faster than
    /// inverting every height; failing both, exact heights seeded from the
    /// marched footprint.
    fn part_model(&self, g: &LocalGeometry, frame: Frame) -> PartModel<'a> {
        let good = |f: &(FittedHeight, f64)| f.1 <= self.delta / 50.0;
        let linear = fit_height(self.surface, g, &frame, self.tool);
        let (fitted, seeds) = match linear.filter(good) {
            Some(f) if !self.exact_heights => (Some(f), None),
            _ => {
                let (inverted, seeds) = fit_height_inverted(self.surface, g, &frame, self.tool);
                let best = [linear, inverted]
                    .into_iter()
                    .flatten()
                    .filter(|f| f.1 <= self.delta / 5.0)
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                (best.filter(|_| !self.exact_heights), Some(seeds))
            }
        };
        match fitted {
            Some((fit, e)) => PartModel::Fitted(fit, e),
            None => PartModel::Exact(Box::new(ExactHeight {
                surface: self.surface,
                frame,
                uv: g.forms.uv,
                seeds,
            })),
        }
    }

    /// How far past a drive point the pass must run for its strip to be
    /// finished ([`ec::strip_trailing_reach`]), mm.
    fn trailing_reach(&self, p: &DrivePoint) -> f64 {
        let uv = Vector2::new(p.uv[0], p.uv[1]);
        let d = extended_derivs(self.surface, uv.x, uv.y);
        let Some(g) = LocalGeometry::from_derivs(uv, d) else {
            return self.tool.tube_radius() + self.tool.corner_radius;
        };
        let model = self.part_model(&g, p.frame);
        let (h, _) = model.height();
        let s = &p.solution;
        ec::strip_trailing_reach(self.tool, s.pos, h, s.y_left, s.y_right)
    }

    /// Positions the tool at (s, t).
    pub(crate) fn drive_point(
        &self,
        s: f64,
        t: f64,
        hint: Option<&DrivePoint>,
        inside: bool,
    ) -> Result<DrivePoint> {
        let (g, frame) = self.local(s, t)?;
        let kappa_across = g.normal_curvature(frame.e2);
        let search = LeadSearch {
            theta_min: self.theta_min,
            phi: self.phi,
            hint: hint.map(|p| p.solution.pos.theta),
            strip_hint: hint.map(|p| (p.solution.y_left, p.solution.y_right)),
            ..LeadSearch::default()
        };
        let model = self.part_model(&g, frame);
        let (h, model_error) = model.height();
        // A fit whose error matters against the band (over delta / 1000)
        // keeps it off the band's gouge side; a fit exact to rounding (a
        // quadric part) is used as it is.
        // A twisted part (e1, e2 not principal): the twist tilts the part
        // under the characteristic points by about |k12| R0^2 / 2 across the
        // strip, and the swept tool goes a little lower between poses than
        // one pose's characteristic points, so above TWIST_SHARE of delta the
        // "W" keeps the conventional position's margin too (docs/methods.md,
        // "Where MPEC does not apply"). A part fed along its principal
        // directions stays below the share and keeps -delta
        // (`twist_share_parts_die_saddle_from_the_twisted_part`).
        let k12 = g.normal_curvature((frame.e1 + frame.e2) / 2f64.sqrt())
            - 0.5 * (g.normal_curvature(frame.e1) + kappa_across);
        let r0 = self.tool.tube_radius();
        let twisted = 0.5 * k12.abs() * r0 * r0 > TWIST_SHARE * self.delta;
        let search = LeadSearch {
            gouge_margin: if twisted {
                ec::CONVENTIONAL_MARGIN * self.delta
            } else {
                0.0
            },
            fit_error: if model_error > 1e-3 * self.delta {
                model_error
            } else {
                0.0
            },
            ..search
        };
        // Concave tighter than the corner radius: no lead holds the band.
        let fits = g.k_max * self.tool.corner_radius < 1.0;
        let solved = if fits {
            ec::solve(self.tool, h, kappa_across, self.delta, &search).ok()
        } else {
            None
        };
        // docs/methods.md, "Where MPEC does not apply": a lopsided "W", one
        // half-strip less than half the other, or none on one side (the part
        // twists or turns convex within the footprint), gives way to the
        // conventional position when that one is wider on its narrower side;
        // no position at all gives the lifted one.
        let narrower = |s: &ec::Solution| (-s.y_left).min(s.y_right);
        let lopsided = |s: &ec::Solution| 2.0 * narrower(s) <= (-s.y_left).max(s.y_right);
        let conventional = || {
            let fresh = LeadSearch {
                hint: None,
                strip_hint: None,
                ..search
            };
            ec::solve_conventional(self.tool, h, self.delta, &fresh).ok()
        };
        let solution = match solved {
            Some(s) if s.status == Status::Ok && lopsided(&s) => match conventional() {
                Some(c) if narrower(&c) > narrower(&s) => c,
                _ => s,
            },
            Some(s) => s,
            None => match (fits && kappa_across > 1e-9).then(conventional).flatten() {
                Some(c) => c,
                None => ec::solve_lifted(self.tool, h, self.delta, &search),
            },
        };
        Ok(DrivePoint {
            uv: [g.forms.uv.x, g.forms.uv.y],
            frame,
            solution,
            inside: inside && self.near_face(g.forms.uv.x, g.forms.uv.y),
        })
    }

    /// On the face, or off a trimmed face by less than the cutter radius
    /// (its strip can still reach the face).
    fn near_face(&self, u: f64, v: f64) -> bool {
        match self.surface.trim() {
            None => true,
            Some(trim) => {
                trim.contains(u, v) || trim.distance_mm(self.surface, [u, v]) <= self.tool.radius
            }
        }
    }

    /// The half-width a pass may always count on, mm: the corner radius r
    /// touching a flat part stays within +delta up to sqrt(2 r delta) to
    /// either side of its lowest point. Where a pass's strip is narrower
    /// (the tool lifted clear of a spot too tight for it), the passes are
    /// still spaced by this and the simulator reports what is left.
    pub(crate) fn floor_half_width(&self) -> f64 {
        (2.0 * self.tool.corner_radius * self.delta).sqrt()
    }

    /// A pass's usable half-width from its narrowest one: at least
    /// [`Self::floor_half_width`]; the tube radius for a pass with no point
    /// near the face (its width does not matter).
    fn usable(&self, narrowest: f64) -> f64 {
        if narrowest.is_finite() {
            narrowest.max(self.floor_half_width())
        } else {
            self.tool.tube_radius()
        }
    }

    /// Feed parameters of the drive points: the domain at about
    /// [`POINT_SPACING`], then a run-out past the far edge long enough for
    /// the trailing characteristic points (behind the contact, down to
    /// -2 R0 along the feed) to finish the last sections: 2 R0 + r, trimmed
    /// per pass by [`Self::pass`] to what its strip needs, never below
    /// R0 + r.
    pub fn feed_samples(&self) -> Vec<(f64, bool)> {
        let ((s0, s1), _) = self.ranges();
        let (n, ds, step_len) = self.feed_grid();
        let mut out: Vec<(f64, bool)> = (0..=n).map(|i| (s0 + ds * i as f64, true)).collect();
        let (_, longest) = self.runout_counts(step_len);
        out.extend((1..=longest).map(|i| (s1 + ds * i as f64, false)));
        out
    }

    /// Drive points over the domain along the feed: (intervals n, parameter
    /// step, step in mm along the longest of three drive curves).
    fn feed_grid(&self) -> (usize, f64, f64) {
        let ((s0, s1), (t0, t1)) = self.ranges();
        let length = |t: f64| {
            (0..64)
                .map(|i| {
                    let a = s0 + (s1 - s0) * i as f64 / 64.0;
                    let b = s0 + (s1 - s0) * (i + 1) as f64 / 64.0;
                    (self.point(b, t) - self.point(a, t)).norm()
                })
                .sum::<f64>()
        };
        let len = [t0, 0.5 * (t0 + t1), t1]
            .into_iter()
            .map(length)
            .fold(0.0, f64::max);
        let n = ((len / POINT_SPACING).ceil() as usize).max(2);
        (n, (s1 - s0) / n as f64, len / n as f64)
    }

    /// Run-out drive points past the far edge at `step_len` mm apart
    /// ([`Self::feed_grid`]): (at least, at most), for R0 + r and 2 R0 + r.
    fn runout_counts(&self, step_len: f64) -> (usize, usize) {
        let count = |mm: f64| {
            if step_len > 0.0 {
                (mm / step_len).ceil() as usize
            } else {
                0
            }
        };
        let (r0, r) = (self.tool.tube_radius(), self.tool.corner_radius);
        (count(r0 + r), count(2.0 * r0 + r))
    }

    /// Positions every drive point of the pass at cross parameter `t`, in
    /// chunks of [`PASS_CHUNK`] points on the machine's cores. Each chunk
    /// warm-starts its searches from its own previous point, so the answer is
    /// the same on any number of threads.
    pub fn pass(&self, t: f64, samples: &[(f64, bool)]) -> Result<Vec<DrivePoint>> {
        let parts = toolpath_kernel::parallel::map_chunks(samples, PASS_CHUNK, |chunk| {
            let mut out: Vec<DrivePoint> = Vec::with_capacity(chunk.len());
            for &(s, inside) in chunk {
                let point = self.drive_point(s, t, out.last(), inside)?;
                out.push(point);
            }
            Ok(out)
        });
        let mut out = Vec::with_capacity(samples.len());
        for part in parts {
            out.extend(part?);
        }
        // The run-out: as far as the strip at the far edge is finished
        // ([`Self::trailing_reach`]), at least R0 + r.
        let last_inside = samples.iter().rposition(|&(_, inside)| inside);
        let runout = samples.len() - last_inside.map_or(samples.len(), |i| i + 1);
        if let Some(i) = last_inside.filter(|_| runout > 0) {
            let (_, _, step_len) = self.feed_grid();
            let (least, _) = self.runout_counts(step_len);
            let reach = self.trailing_reach(&out[i]);
            let needed = if step_len > 0.0 && reach.is_finite() {
                (reach / step_len).ceil() as usize
            } else {
                runout
            };
            out.truncate(i + 1 + needed.max(least).min(runout));
        }
        Ok(out)
    }

    /// Narrowest half-widths (towards +cross, towards -cross) over the points inside the surface.
    fn narrowest(&self, pass: &[DrivePoint]) -> (f64, f64) {
        let sign = self.cross_sign();
        pass.iter()
            .filter(|p| p.inside)
            .map(|p| p.half_widths(sign))
            .fold((f64::INFINITY, f64::INFINITY), |(a, b), (c, d)| {
                (a.min(c), b.min(d))
            })
    }

    /// Largest distance between the drive curves at `from` and `to`, over the feed samples.
    pub fn gap(&self, samples: &[(f64, bool)], from: f64, to: f64) -> f64 {
        let base: Vec<Point3<f64>> = self.curve(samples, from);
        self.gap_from(samples, &base, to)
    }

    /// Points of the drive curve at cross parameter `t`, at the inside feed samples.
    fn curve(&self, samples: &[(f64, bool)], t: f64) -> Vec<Point3<f64>> {
        samples
            .iter()
            .filter(|(_, inside)| *inside)
            .map(|&(s, _)| self.point(s, t))
            .collect()
    }

    fn gap_from(&self, samples: &[(f64, bool)], base: &[Point3<f64>], to: f64) -> f64 {
        samples
            .iter()
            .filter(|(_, inside)| *inside)
            .zip(base)
            .map(|(&(s, _), p)| (self.point(s, to) - p).norm())
            .fold(0.0, f64::max)
    }

    /// Cross parameter beyond `from` (towards `end`) at which the gap is
    /// `target` (to 1e-6 mm): regula falsi (Illinois) on the gap, which grows
    /// smoothly and monotonically with the distance from `from`.
    pub fn advance(&self, samples: &[(f64, bool)], from: f64, end: f64, target: f64) -> f64 {
        let base = self.curve(samples, from);
        let g = |t: f64| self.gap_from(samples, &base, t) - target;
        let g_end = g(end);
        if g_end <= 0.0 {
            return end;
        }
        let mut br = Bracket::new(from, -target, end, g_end);
        for _ in 0..100 {
            if br.f_neg > -1e-6 || br.width() <= 1e-12 * (1.0 + br.neg.abs()) {
                break;
            }
            let m = br.trial_clamped(0.01);
            br.narrow(m, g(m));
        }
        br.neg
    }

    /// Places the pass after `from` so that `fixed` (the facing half-width of
    /// the previous pass, or 0 at the boundary) plus the new pass's own
    /// narrowest facing half-width covers the gap. The new half-width is not
    /// known before the pass is computed: start from `guess`, compute the pass
    /// on every fourth drive point, and move it closer until its half-width
    /// covers the assumption (or further out while it is wider); then compute
    /// the whole pass and check again. `progress` is checked before every
    /// trial pass, so a cancel stops the placement, not only the plan.
    fn place_next(
        &self,
        samples: &[(f64, bool)],
        (from, end): (f64, f64),
        fixed: f64,
        guess: f64,
        progress: &dyn Progress,
    ) -> Result<(f64, Vec<DrivePoint>)> {
        let trial = trial_samples(samples);
        let facing_of = |pass: &[DrivePoint]| {
            let (plus, minus) = self.narrowest(pass);
            self.usable(if end > from { minus } else { plus })
        };
        let floor = self.floor_half_width();
        let mut guess = guess.max(floor);
        for _ in 0..6 {
            let mut accepted: Option<(f64, f64)> = None;
            for _ in 0..8 {
                let t = self.advance(samples, from, end, fixed + guess);
                progress.check()?;
                let facing = facing_of(&self.pass(t, &trial)?);
                if facing >= guess - 1e-9 {
                    let widen = facing > guess * 1.01 && t != end;
                    accepted = Some((t, guess));
                    if !widen {
                        break;
                    }
                    // Wider than assumed: try placing it further out.
                    guess = facing;
                } else if accepted.is_some() {
                    break;
                } else {
                    guess = (facing * 0.999).max(floor);
                }
            }
            let Some((t, used)) = accepted else {
                break;
            };
            progress.check()?;
            let full = self.pass(t, samples)?;
            let facing = facing_of(&full);
            if facing >= used - 1e-9 {
                return Ok((t, full));
            }
            guess = (facing * 0.999).max(floor);
        }
        self.place_by_bisection(samples, from, end, fixed, progress)
    }

    /// The fallback of [`Self::place_next`] where the strip width changes
    /// too fast across the passes for its fixed point (the part twists or
    /// turns within a footprint): the pass at the gap `fixed` + floor half-
    /// width always holds (its usable half-width is at least the floor);
    /// bisection on the cross parameter between it and the gap `fixed` +
    /// the tool's reach keeps the furthest one found whose own facing
    /// half-width covers its gap, checked on the whole pass.
    fn place_by_bisection(
        &self,
        samples: &[(f64, bool)],
        from: f64,
        end: f64,
        fixed: f64,
        progress: &dyn Progress,
    ) -> Result<(f64, Vec<DrivePoint>)> {
        let trial = trial_samples(samples);
        let base = self.curve(samples, from);
        let holds = |t: f64, pass: &[DrivePoint]| {
            let (plus, minus) = self.narrowest(pass);
            let facing = self.usable(if end > from { minus } else { plus });
            fixed + facing >= self.gap_from(samples, &base, t) - 1e-9
        };
        let safe = self.advance(samples, from, end, fixed + self.floor_half_width());
        let reach = self.tool.tube_radius() + self.tool.corner_radius;
        let (mut lo, mut hi) = (safe, self.advance(samples, from, end, fixed + reach));
        for _ in 0..3 {
            for _ in 0..BISECTION_STEPS {
                if (hi - lo).abs() <= 1e-9 * (1.0 + hi.abs()) {
                    break;
                }
                let mid = 0.5 * (lo + hi);
                progress.check()?;
                if holds(mid, &self.pass(mid, &trial)?) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let full = self.pass(lo, samples)?;
            if lo == safe || holds(lo, &full) {
                return Ok((lo, full));
            }
            (lo, hi) = (safe, lo);
        }
        Ok((safe, self.pass(safe, samples)?))
    }
}

/// " around (x, y, z) mm": the mean of some drive points, for a warning.
fn around(points: &[Point3<f64>]) -> String {
    if points.is_empty() {
        return String::new();
    }
    let n = points.len() as f64;
    let c = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    format!(" (around ({:.1}, {:.1}, {:.1}) mm)", c.x, c.y, c.z)
}

/// Share of delta above which the twist's tilt across the strip,
/// |k12| R0^2 / 2, makes a "W" keep [`ec::CONVENTIONAL_MARGIN`].
const TWIST_SHARE: f64 = 0.2;

/// Halvings of the cross-parameter bracket per round of
/// `place_by_bisection`.
const BISECTION_STEPS: usize = 12;

/// Every fourth inside feed sample and the last one: enough to find a
/// pass's narrowest strip while placing it.
fn trial_samples(samples: &[(f64, bool)]) -> Vec<(f64, bool)> {
    samples
        .iter()
        .enumerate()
        .filter(|(i, (_, inside))| {
            *inside && (i % 4 == 0 || samples.get(i + 1).is_none_or(|n| !n.1))
        })
        .map(|(_, s)| *s)
        .collect()
}

/// The strategy `mpec`: passes on levels of the cross parameter, refined
/// with passes added at the middle of the gaps the simulator finds above
/// the band.
pub struct Mpec;

impl crate::Strategy for Mpec {
    fn id(&self) -> toolpath_formats::Strategy {
        toolpath_formats::Strategy::Mpec
    }
    fn plan(&self, job: &Job, progress: &dyn Progress) -> Result<PlanResult> {
        plan_refined(job, progress, &[])
    }
    fn path_levels(&self) -> Option<crate::strategy::PathLevels> {
        Some(crate::strategy::PathLevels::CrossParameter)
    }
    fn plan_refined(
        &self,
        job: &Job,
        progress: &dyn Progress,
        refinement: &crate::refine::Refinement,
    ) -> Result<PlanResult> {
        plan_refined(job, progress, &refinement.added)
    }
}

/// Plans an MPEC job with more passes at the cross parameters `added` (the levels
/// of `crate::refine`), in order of the cross parameter.
pub(crate) fn plan_refined(
    job: &Job,
    progress: &dyn Progress,
    added: &[f64],
) -> Result<PlanResult> {
    let planner = Planner::from_job(job)?;
    plan_with(&planner, &job.job_id, progress, added)
}

/// Plans with a prepared [`Planner`] (tests use it to force exact heights),
/// adding passes at the cross parameters `added`.
pub(crate) fn plan_with(
    planner: &Planner,
    job_id: &str,
    progress: &dyn Progress,
    added: &[f64],
) -> Result<PlanResult> {
    let samples = planner.feed_samples();
    let mut passes = place_passes(planner, &samples, progress)?;
    let (t0, t1) = planner.face_cross_range();
    for &t in added {
        if (t0..=t1).contains(&t) {
            progress.check()?;
            passes.push((t, planner.pass(t, &samples)?));
        }
    }
    // Stable: the planned passes keep their order among equal levels.
    passes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut result = PlanResult::new(job_id, "mpec");
    let found = assemble_passes(planner, &passes, &mut result);
    result.warnings.push(runout_note(planner, &passes));
    found.warn(planner, &mut result);
    Ok(result)
}

/// The passes across the face, each at its cross parameter: the first with
/// its lower strip edge on the boundary t0, each next placed so that the
/// facing half-widths meet, until the last strip reaches t1.
fn place_passes(
    planner: &Planner,
    samples: &[(f64, bool)],
    progress: &dyn Progress,
) -> Result<Vec<(f64, Vec<DrivePoint>)>> {
    let (t0, t1) = planner.face_cross_range();
    let mut passes: Vec<(f64, Vec<DrivePoint>)> = Vec::new();
    let probe = planner.pass(t0, &trial_samples(samples))?;
    let (_, minus0) = planner.narrowest(&probe);
    let (mut t, mut pass) =
        planner.place_next(samples, (t0, t1), 0.0, planner.usable(minus0), progress)?;
    loop {
        let plus = planner.usable(planner.narrowest(&pass).0);
        passes.push((t, pass));
        progress.set(((t - t0) / (t1 - t0)).clamp(0.0, 1.0) as f32 * 0.99);
        progress.check()?;
        if t >= t1 || planner.gap(samples, t, t1) <= plus {
            return Ok(passes);
        }
        if passes.len() > 10_000 {
            return Err(Error::planning(
                "more than 10 000 passes: the strips are far too narrow for this surface",
            ));
        }
        let (_, minus_prev) =
            planner.narrowest(passes.last().map(|p| p.1.as_slice()).unwrap_or(&[]));
        let (nt, np) =
            planner.place_next(samples, (t, t1), plus, planner.usable(minus_prev), progress)?;
        if nt <= t {
            return Err(Error::planning(format!(
                "the drive curves stopped advancing at cross parameter {t:.6}: zero strip width"
            )));
        }
        t = nt;
        pass = np;
    }
}

/// Drive points an MPEC plan reports in its warnings.
struct Found {
    not_applicable: usize,
    /// Where the tool is lifted clear of a concavity it cannot follow.
    lifted: Vec<Point3<f64>>,
    /// Where the band holds over less than the floor half-width on a side.
    narrow: Vec<Point3<f64>>,
}

/// Puts the passes into `result` with their strip-width figures in
/// `extra`; returns the drive points the warnings report.
fn assemble_passes(
    planner: &Planner,
    passes: &[(f64, Vec<DrivePoint>)],
    result: &mut PlanResult,
) -> Found {
    let mut found = Found {
        not_applicable: 0,
        lifted: Vec::new(),
        narrow: Vec::new(),
    };
    let floor = planner.floor_half_width();
    let sign = planner.cross_sign();
    let mut widths = Vec::new();
    for (_, pass) in passes {
        let inside: Vec<f64> = pass
            .iter()
            .filter(|p| p.inside)
            .map(|p| p.solution.strip_width())
            .collect();
        widths.extend(inside.iter().copied());
        found.not_applicable += pass
            .iter()
            .filter(|p| p.inside && p.solution.status == Status::NotApplicable)
            .count();
        for p in pass.iter().filter(|p| p.inside) {
            let (a, b) = p.half_widths(sign);
            if p.solution.status == Status::Lifted {
                found.lifted.push(p.frame.p);
            } else if a.min(b) < floor {
                found.narrow.push(p.frame.p);
            }
        }
        result.passes.push(Pass {
            region: 0,
            points: pass.iter().map(|p| p.to_path_point(planner.tool)).collect(),
            min_strip_width: (!inside.is_empty())
                .then(|| inside.iter().copied().fold(f64::INFINITY, f64::min)),
        });
    }
    let mean = widths.iter().sum::<f64>() / widths.len().max(1) as f64;
    let narrowest = if widths.is_empty() {
        0.0
    } else {
        widths.iter().copied().fold(f64::INFINITY, f64::min)
    };
    let extra = &mut result.stats.extra;
    extra.insert("mean_strip_width_mm".into(), mean);
    extra.insert("min_strip_width_mm".into(), narrowest);
    extra.insert("not_applicable_points".into(), found.not_applicable as f64);
    found
}

/// How far the passes run past the far edge of the surface, in words.
fn runout_note(planner: &Planner, passes: &[(f64, Vec<DrivePoint>)]) -> String {
    let (least, _) = planner.runout_counts(planner.feed_grid().2);
    let ((_, s1), _) = planner.ranges();
    let feed_of = |p: &DrivePoint| match planner.feed {
        FeedDirection::U => p.uv[0],
        FeedDirection::V => p.uv[1],
    };
    let longest = passes
        .iter()
        .map(|(_, pass)| pass.iter().filter(|p| feed_of(p) > s1).count())
        .max()
        .unwrap_or(0);
    let (r0, r) = (planner.tool.tube_radius(), planner.tool.corner_radius);
    let mut runout = format!(
        "every pass runs {:.1} mm (R0 + r) past the far edge of the surface, on its second-order continuation, so the tool's trailing part finishes the last sections",
        r0 + r
    );
    if longest > least {
        runout += &format!(
            "; up to {:.1} mm (2 R0 + r) where the heel finishes the strip further behind the contact",
            2.0 * r0 + r
        );
    }
    runout
}

impl Found {
    /// The warnings for the drive points where MPEC does not apply, the
    /// tool is lifted or the band is narrow (and `lifted_points` in `extra`).
    fn warn(&self, planner: &Planner, result: &mut PlanResult) {
        let Found {
            not_applicable,
            lifted,
            narrow,
        } = self;
        if *not_applicable > 0 {
            result.warnings.push(format!(
                "{not_applicable} drive points are convex (or flat) across the feed, or twisted so that the \"W\" is narrower on one side than the conventional strip: MPEC does not apply there; they use the conventional position (tool touching, smallest non-gouging lead) with the strip where the scallop stays below the tolerance"
            ));
        }
        if !lifted.is_empty() {
            result
                .stats
                .extra
                .insert("lifted_points".into(), lifted.len() as f64);
            result.warnings.push(format!(
                "{} drive points{} lie where the part is concave tighter than the torus can follow at any lead: the tool is lifted clear there (no gouge beyond the tolerance) and leaves more than the tolerance; a smaller tool finishes them",
                lifted.len(),
                around(lifted)
            ));
        }
        if !narrow.is_empty() {
            let floor = planner.floor_half_width();
            result.warnings.push(format!(
                "{} drive points{} hold the band over less than {floor:.3} mm on one side (the corner radius at the tolerance); their passes are spaced by that and the simulator judges what is left",
                narrow.len(),
                around(narrow)
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_formats::shape::Shape;

    /// The largest twist tilt |k12| R0^2 / 2 and the largest error of the
    /// part model over a 13 x 13 grid of drive points of `job`'s surface,
    /// mm. k12 is the second fundamental form on (e1, e2), worked out here
    /// in (u, v) and checked against the polarisation the planner uses.
    fn twist_and_fit(job: &Job) -> (f64, f64) {
        let planner = Planner::from_job(job).unwrap();
        let ((s0, s1), (t0, t1)) = planner.ranges();
        let r0 = planner.tool.tube_radius();
        let (mut twist, mut fit) = (0.0f64, 0.0f64);
        for i in 0..=12 {
            for j in 0..=12 {
                let s = s0 + (s1 - s0) * i as f64 / 12.0;
                let t = t0 + (t1 - t0) * j as f64 / 12.0;
                let (g, frame) = planner.local(s, t).unwrap();
                let f = &g.forms;
                let in_uv = |e: Vector3<f64>| {
                    let b = nalgebra::Vector2::new(e.dot(&f.derivs.su), e.dot(&f.derivs.sv));
                    f.first.try_inverse().unwrap() * b
                };
                let (a, b) = (in_uv(frame.e1), in_uv(frame.e2));
                let k12 = (a.transpose() * f.second * b)[(0, 0)];
                let polarised = g.normal_curvature((frame.e1 + frame.e2) / 2f64.sqrt())
                    - 0.5 * (g.normal_curvature(frame.e1) + g.normal_curvature(frame.e2));
                assert!(
                    (k12 - polarised).abs() < 1e-9 * (1.0 + k12.abs()),
                    "{k12} {polarised}"
                );
                twist = twist.max(0.5 * k12.abs() * r0 * r0);
                fit = fit.max(planner.part_model(&g, frame).height().1);
            }
        }
        (twist, fit)
    }

    /// [`TWIST_SHARE`] parts the two kinds of part: die_saddle, a quadric
    /// fed along its principal directions, tilts by about 4.4e-5 mm, a
    /// fiftieth of the share's 2e-3 mm (so its "W" keeps -delta), and its
    /// part model is exact to rounding (no fit error taken off the band);
    /// the twisted surface of tests/mpec.rs tilts by about 0.29 mm, over a
    /// hundred times the share, where the "W" keeps the conventional margin
    /// (without it that surface gouges 0.01022 mm against a band of 0.01,
    /// docs/methods.md, "Where MPEC does not apply").
    #[test]
    fn twist_share_parts_die_saddle_from_the_twisted_part() {
        let die = toolpath_samples::job("die_saddle").unwrap();
        let delta = die.tolerance().unwrap();
        let (twist, fit) = twist_and_fit(&die);
        eprintln!("die_saddle: twist {twist:.3e} mm, fit error {fit:.3e} mm");
        // About 4.4e-5 mm against the share's 2e-3 mm: the twist of a
        // quadric fed along its axes comes from the slope alone.
        assert!((3e-5..6e-5).contains(&twist), "die_saddle twist {twist} mm");
        assert!(twist < TWIST_SHARE * delta / 10.0);
        // Exact to rounding, far below the delta / 1000 that counts.
        assert!(fit < 1e-7, "die_saddle fit error {fit} mm");
        let f = |x: f64, y: f64| {
            (1.0 + 0.4 * (y / 45.0).sin()) * x * x / 1800.0 + 2.0 * (y / 70.0).cos()
        };
        let twisted = toolpath_kernel::geometry::interpolation::interpolate_height_field(
            f,
            (-90.0, 90.0),
            (0.0, 200.0),
            (3, 12),
            (3, 16),
        )
        .unwrap();
        let mut job = die.clone();
        job.shape = Shape::Surface(twisted);
        job.feed_direction = Some(FeedDirection::V);
        let (twist, _) = twist_and_fit(&job);
        eprintln!("twisted: twist {twist:.3e} mm");
        // About 0.29 mm: over a hundred times the share.
        assert!(
            (0.2..0.4).contains(&twist),
            "twisted part's twist {twist} mm"
        );
        assert!(twist > 100.0 * TWIST_SHARE * delta);
    }
}
