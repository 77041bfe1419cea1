//! A face's bounds as closed polylines in its patch's (u, v): edges read in
//! loop order, sampled by bisection until every chord's surface image is
//! within the trim tolerance of the edge, loops closed and oriented.

use super::curves::Curve;
use super::patches::Patch;
use super::surfaces::Basis;
use super::{StepFile, SurfaceFile, V3};
use nalgebra::Point3;
use ruststep::ast::Parameter;
use std::f64::consts::TAU;
use toolpath_kernel::error::Result;
use toolpath_kernel::geometry::inversion::closest_point;
use toolpath_kernel::geometry::trim::DEFAULT_TOLERANCE_MM;
use toolpath_kernel::geometry::NurbsSurface;

/// Deepest bisection of an edge's parameter range when sampling it.
pub(super) const MAX_DEPTH: u32 = 18;

/// Pieces per edge of the samples that bound a plane's or revolved
/// surface's patch: fine enough that a curved edge's bulge between two of
/// them stays far below the trim tolerance (a boundary point outside the
/// patch would be clamped onto it and never meet the tolerance).
pub(super) const COARSE: usize = 256;

/// Uniform pieces an edge starts from before bisection.
pub(super) const START_PIECES: usize = 8;

/// Bisection steps one trim loop may take to follow its edges within the
/// tolerance: hundreds of times what the test parts need. An edge that
/// would need more (a degenerate curve or map that bisection never
/// resolves) ends the sampling there and the face is refused, instead of
/// bisecting every piece to [`MAX_DEPTH`] (millions of point inversions).
pub(super) const MAX_LOOP_STEPS: usize = 100_000;

/// One edge of a loop: a curve (3-D, or a pcurve in (u, v)) run from `ta` to `tb`.
pub(super) struct EdgeUse {
    id: u64,
    curve: Curve,
    in_uv: bool,
    ta: f64,
    tb: f64,
}

/// One bound of a face (`FACE_OUTER_BOUND` or `FACE_BOUND`) with its edges.
pub(super) struct Bound {
    /// The bound's entity id.
    pub(super) id: u64,
    /// Whether it is a `FACE_OUTER_BOUND`.
    pub(super) declared_outer: bool,
    /// Its orientation flag: `.F.` reverses the loop.
    pub(super) orientation: bool,
    pub(super) edges: Vec<EdgeUse>,
}

/// A bound sampled into a closed polyline in the patch's (u, v), oriented.
pub(super) struct SampledLoop {
    /// The bound's entity id.
    pub(super) bound: u64,
    pub(super) declared_outer: bool,
    pub(super) points: Vec<[f64; 2]>,
}

impl StepFile {
    /// The outer loop: the `FACE_OUTER_BOUND`, else the one loop running
    /// counter-clockwise in (u, v) with the face normal towards the viewer
    /// (material on its left, as STEP orients bounds), else the largest.
    pub(super) fn outer_index(&self, face: u64, loops: &[SampledLoop]) -> Result<usize> {
        let declared: Vec<usize> = (0..loops.len())
            .filter(|&k| loops[k].declared_outer)
            .collect();
        match declared.len() {
            1 => return Ok(declared[0]),
            0 => {}
            _ => return Err(self.err(face, "has more than one FACE_OUTER_BOUND")),
        }
        let areas: Vec<f64> = loops.iter().map(|l| shoelace(&l.points)).collect();
        let ccw: Vec<usize> = (0..loops.len()).filter(|&k| areas[k] > 0.0).collect();
        if ccw.len() == 1 {
            return Ok(ccw[0]);
        }
        if ccw.len() > 1 && loops.len() > 1 {
            return Err(self.err(
                face,
                format!(
                    "has {} outer loops (bounds {}): one outer loop per face is supported",
                    ccw.len(),
                    ccw.iter()
                        .map(|&k| format!("#{}", loops[k].bound))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        Ok((0..loops.len())
            .max_by(|&a, &b| areas[a].abs().total_cmp(&areas[b].abs()))
            .unwrap_or(0))
    }
}

impl StepFile {
    /// The edges of an `EDGE_LOOP` in loop order, each with the curve to
    /// sample (the pcurve on `surface_id` when there is one and the basis is
    /// a B-spline) and the parameter range its vertices bound.
    pub(super) fn edge_loop(
        &self,
        id: u64,
        surface_id: u64,
        basis: &Basis,
    ) -> Result<Vec<EdgeUse>> {
        let (_, p) = self.expect(id, &["EDGE_LOOP"])?;
        let nurbs = match basis {
            Basis::Bspline(s) => Some(s.to_surface()?),
            _ => None,
        };
        let out = self
            .references(id, p, 1)?
            .into_iter()
            .map(|oe| self.edge_use(oe, surface_id, nurbs.as_ref()))
            .collect::<Result<Vec<_>>>()?;
        if out.is_empty() {
            return Err(self.err(id, "has no edges"));
        }
        Ok(out)
    }

    /// One `ORIENTED_EDGE` of a loop on `surface_id` (`nurbs`: that
    /// surface when it is a B-spline, whose pcurves are then used).
    fn edge_use(&self, oe: u64, surface_id: u64, nurbs: Option<&NurbsSurface>) -> Result<EdgeUse> {
        let (_, op) = self.expect(oe, &["ORIENTED_EDGE"])?;
        let edge = self.reference(oe, op, 3)?;
        let forward = self.boolean(oe, op, 4)?;
        let (_, ep) = self.expect(edge, &["EDGE_CURVE"])?;
        let (v1, v2) = (self.reference(edge, ep, 1)?, self.reference(edge, ep, 2)?);
        let geometry = self.reference(edge, ep, 3)?;
        let same_sense = self.boolean(edge, ep, 4)?;
        let vertex = |v: u64| -> Result<V3> {
            let (_, vp) = self.expect(v, &["VERTEX_POINT"])?;
            self.point3(self.reference(v, vp, 1)?)
        };
        let (p1, p2) = (vertex(v1)?, vertex(v2)?);
        let (mut curve_id, mut pcurve) = (geometry, None);
        if let Ok((_, sp)) = self.expect(geometry, &["SURFACE_CURVE", "SEAM_CURVE"]) {
            curve_id = self.reference(geometry, sp, 1)?;
            if nurbs.is_some() {
                pcurve = self.pcurve_on(geometry, sp, surface_id)?;
            }
        }
        let (curve, in_uv, q1, q2) = match (pcurve, nurbs) {
            (Some(pc), Some(s)) => {
                let uv = |q: &V3| {
                    let c = closest_point(s, &Point3::from(*q));
                    V3::new(c.uv.x, c.uv.y, 0.0)
                };
                (self.curve(pc, true)?, true, uv(&p1), uv(&p2))
            }
            _ => (self.curve(curve_id, false)?, false, p1, p2),
        };
        let closed = v1 == v2 || (p1 - p2).norm() <= 1e-9 * (1.0 + p1.norm());
        let (ta, tb) = self.edge_range(edge, &curve, closed, (q1, q2), same_sense)?;
        let (ta, tb) = if forward { (ta, tb) } else { (tb, ta) };
        Ok(EdgeUse {
            id: edge,
            curve,
            in_uv,
            ta,
            tb,
        })
    }

    /// The pcurve of a `SURFACE_CURVE` or `SEAM_CURVE` (`sp`: its
    /// parameters) on `surface_id`, if it lists one.
    fn pcurve_on(&self, geometry: u64, sp: &[Parameter], surface_id: u64) -> Result<Option<u64>> {
        for pc in self.references(geometry, sp, 2)? {
            if let Some(pp) = self.part(pc, "PCURVE") {
                if self.reference(pc, pp, 1)? == surface_id {
                    let rep = self.reference(pc, pp, 2)?;
                    let (_, rp) = self.expect(rep, &["DEFINITIONAL_REPRESENTATION"])?;
                    return Ok(self.references(rep, rp, 1)?.first().copied());
                }
            }
        }
        Ok(None)
    }

    /// The parameter range of `curve` from vertex `q1` to vertex `q2` (the
    /// whole curve, or a whole turn from `q1`, for a closed edge), run
    /// backwards when the edge's `same_sense` is false.
    fn edge_range(
        &self,
        edge: u64,
        curve: &Curve,
        closed: bool,
        (q1, q2): (V3, V3),
        same_sense: bool,
    ) -> Result<(f64, f64)> {
        if closed {
            return match curve.range() {
                Some((a, b)) if curve.periodic() => {
                    let t = curve.locate(&q1);
                    if same_sense {
                        Ok((t, t + (b - a)))
                    } else {
                        Ok((t, t - (b - a)))
                    }
                }
                Some((a, b)) => {
                    if same_sense {
                        Ok((a, b))
                    } else {
                        Ok((b, a))
                    }
                }
                None => Err(self.err(edge, "is a closed edge on a line")),
            };
        }
        let (ta, mut tb) = (curve.locate(&q1), curve.locate(&q2));
        if curve.periodic() {
            if same_sense {
                while tb <= ta {
                    tb += TAU;
                }
                while tb - ta > TAU {
                    tb -= TAU;
                }
            } else {
                while tb >= ta {
                    tb -= TAU;
                }
                while ta - tb > TAU {
                    tb += TAU;
                }
            }
        }
        Ok((ta, tb))
    }

    /// Builds the NURBS of the basis and samples every loop into (u, v).
    pub(super) fn sample_loops(
        &self,
        face: u64,
        basis: Basis,
        loops: &[Bound],
    ) -> Result<(SurfaceFile, Vec<SampledLoop>)> {
        // Coarse 3-D samples of every loop: the extent of a plane or
        // cylinder patch, and each loop's unwrapped start angle.
        let coarse: Vec<Vec<V3>> = loops
            .iter()
            .map(|b| {
                b.edges
                    .iter()
                    .filter(|e| !e.in_uv)
                    .flat_map(|e| {
                        (0..=COARSE).map(move |k| {
                            e.curve
                                .point(e.ta + (e.tb - e.ta) * k as f64 / COARSE as f64)
                        })
                    })
                    .collect()
            })
            .collect();
        let Patch {
            surface,
            to_uv: map,
        } = self.patch(face, basis, &coarse)?;
        let nurbs = surface.to_surface()?;
        let mut out = Vec::new();
        for Bound {
            id: bound,
            declared_outer,
            orientation,
            edges,
        } in loops
        {
            let mut pts: Vec<[f64; 2]> = Vec::new();
            let mut steps = MAX_LOOP_STEPS;
            for e in edges {
                let seed = pts.last().copied();
                let eval = |t: f64, seed: Option<[f64; 2]>| -> ([f64; 2], V3) {
                    let c = e.curve.point(t);
                    if e.in_uv {
                        let p = nurbs.point(c.x, c.y);
                        ([c.x, c.y], p.coords)
                    } else {
                        (map(&c, seed), c)
                    }
                };
                sample_edge(&nurbs, e, &eval, seed, &mut steps, &mut pts);
                if steps == 0 {
                    return Err(self.err(
                        e.id,
                        format!(
                            "cannot be followed within the trim tolerance in {MAX_LOOP_STEPS} bisection steps: its curve or the face's surface is degenerate along it"
                        ),
                    ));
                }
            }
            let (Some(&first), Some(&last)) = (pts.first(), pts.last()) else {
                return Err(self.err(*bound, "has an empty loop"));
            };
            let gap = (nurbs.point(first[0], first[1]) - nurbs.point(last[0], last[1])).norm();
            let size = {
                let (lo, hi) = nurbs.bounding_box();
                (hi - lo).norm()
            };
            if gap > 1e-4 * size.max(1.0) {
                let e = edges.last().map(|e| e.id).unwrap_or(*bound);
                return Err(self.err(
                    *bound,
                    format!("is not closed: its last edge #{e} ends {gap:.3e} mm from its start"),
                ));
            }
            *pts.last_mut().unwrap_or(&mut [0.0; 2]) = first;
            if !orientation {
                pts.reverse();
            }
            out.push(SampledLoop {
                bound: *bound,
                declared_outer: *declared_outer,
                points: pts,
            });
        }
        Ok((surface, out))
    }
}

/// Samples one edge into `pts`: the (u, v) images of parameters from `ta`
/// to `tb`, bisected until the surface image of each chord's midpoint lies
/// within the trim tolerance of the edge's point there.
pub(super) fn sample_edge(
    nurbs: &NurbsSurface,
    e: &EdgeUse,
    eval: &dyn Fn(f64, Option<[f64; 2]>) -> ([f64; 2], V3),
    seed: Option<[f64; 2]>,
    steps: &mut usize,
    pts: &mut Vec<[f64; 2]>,
) {
    let tol = DEFAULT_TOLERANCE_MM * 0.5;
    let (mut t, (mut uv, mut p)) = (e.ta, eval(e.ta, seed));
    push(pts, uv);
    for k in 1..=START_PIECES {
        let t1 = e.ta + (e.tb - e.ta) * k as f64 / START_PIECES as f64;
        let (uv1, p1) = eval(t1, Some(uv));
        bisect(nurbs, eval, (t, uv, p), (t1, uv1, p1), tol, 0, steps, pts);
        (t, uv, p) = (t1, uv1, p1);
    }
}

#[allow(clippy::too_many_arguments)]
pub(super) fn bisect(
    nurbs: &NurbsSurface,
    eval: &dyn Fn(f64, Option<[f64; 2]>) -> ([f64; 2], V3),
    a: (f64, [f64; 2], V3),
    b: (f64, [f64; 2], V3),
    tol: f64,
    depth: u32,
    steps: &mut usize,
    pts: &mut Vec<[f64; 2]>,
) {
    if *steps == 0 {
        push(pts, b.1);
        return;
    }
    *steps -= 1;
    let tm = 0.5 * (a.0 + b.0);
    let (uvm, pm) = eval(tm, Some(a.1));
    let chord = nurbs.point(0.5 * (a.1[0] + b.1[0]), 0.5 * (a.1[1] + b.1[1]));
    if depth < MAX_DEPTH && (chord.coords - pm).norm() > tol {
        bisect(nurbs, eval, a, (tm, uvm, pm), tol, depth + 1, steps, pts);
        bisect(nurbs, eval, (tm, uvm, pm), b, tol, depth + 1, steps, pts);
    } else {
        push(pts, b.1);
    }
}

/// Appends q unless it repeats the last point: two edges' images of their
/// shared vertex differ by rounding (about 1e-12), and keeping both would
/// make the loop turn back on itself there.
pub(super) fn push(pts: &mut Vec<[f64; 2]>, q: [f64; 2]) {
    if pts
        .last()
        .is_none_or(|l| (l[0] - q[0]).abs() > 1e-9 || (l[1] - q[1]).abs() > 1e-9)
    {
        pts.push(q);
    }
}

/// Twice the signed area... halved: the shoelace area of a closed polyline.
pub(super) fn shoelace(l: &[[f64; 2]]) -> f64 {
    0.5 * l
        .windows(2)
        .map(|w| w[0][0] * w[1][1] - w[1][0] * w[0][1])
        .sum::<f64>()
}
